//! The documentation is tested: every command README.md and docs/*.md show with their
//! output runs here, and its output must be what the page shows. The convention
//! (docs/ci.md, "The documentation is tested"):
//!
//! - A command and its output are one ```` ```console ```` block: a line starting with
//!   `$ ` is a command (continued on the next line while it ends with `\`, and through
//!   the end of a here-document it opens, `<<'EOF'` … `EOF`), the lines
//!   after it up to the next `$ ` are what it prints, standard output and standard error
//!   together, in the order written. A command that prints nothing is followed directly
//!   by the next command.
//! - The output may elide: `...` on a line of its own stands for any number of lines,
//!   `[..]` for any text within a line (snapbox's wildcards, as trycmd uses them). Figures
//!   that depend on the machine or on timing are elided or not shown as output at all.
//! - The commands of a block run in order in one `sh`; the blocks of a page run in order,
//!   in one scratch directory that holds copies of the repository's `fixtures/`, `tools/`,
//!   `docs/` and `examples/` (and `../shared` beside it), so paths are those of the
//!   repository root, a file one block writes is there for the next, and files written
//!   are thrown away. `nccomp` (and `cargo run [--release] [-q] --`, and
//!   `target/release/nccomp`) is the binary this test is built with. A command that exits
//!   non-zero must show an error (a line containing `error`), or be followed by `echo $?`,
//!   which shows its status.
//! - Relative links between the pages, and their `#anchors`, must resolve.
//! - A ```` ```sh ```` block directly followed by a ```` ```text ```` block, or a `text`
//!   block that starts with `$ `, is refused: a shown output is a `console` block.
//! - A block whose commands read `../shared/corpus` is reported as skipped where the
//!   corpus is not there (a failure in CI, common/skip.rs).
//!
//! `SNAPSHOTS=overwrite cargo test --test docs` writes the actual output of every failing
//! command into its page (wildcards of a failing command are lost: put them back).
#![cfg(unix)]

#[path = "common/skip.rs"]
mod skip;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// A block that runs longer than this fails: slow commands (benchmarks, big programs) are
/// stated with their command and date, not run by the tests.
const SLOW: Duration = Duration::from_secs(30);

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// A fenced block of a Markdown page.
struct Block {
    /// The info string's first word (`console`, `sh`, `text`, …).
    lang: String,
    /// Line number (from 1) of the opening fence.
    open: usize,
    /// Line number (from 1) of the closing fence.
    close: usize,
    /// The fence's indentation, removed from the body.
    indent: usize,
    body: Vec<String>,
}

fn blocks(text: &str) -> Vec<Block> {
    let mut out = Vec::new();
    let mut current: Option<Block> = None;
    for (i, line) in text.lines().enumerate() {
        let trimmed = line.trim_start();
        let indent = line.len() - trimmed.len();
        match current.as_mut() {
            None => {
                if let Some(info) = trimmed.strip_prefix("```") {
                    current = Some(Block {
                        lang: info.split_whitespace().next().unwrap_or("").to_string(),
                        open: i + 1,
                        close: 0,
                        indent,
                        body: Vec::new(),
                    });
                }
            }
            Some(block) => {
                if trimmed.trim_end() == "```" {
                    block.close = i + 1;
                    out.push(current.take().unwrap());
                } else {
                    block
                        .body
                        .push(line[indent.min(block.indent)..].to_string());
                }
            }
        }
    }
    assert!(current.is_none(), "a fenced block is not closed");
    out
}

/// One command of a console block and the output the page shows for it.
struct Shown {
    /// Line number (from 1) of the `$ ` line.
    line: usize,
    command: String,
    /// Lines of the page (index from 0) holding the output: `first..end`.
    first: usize,
    end: usize,
    output: Vec<String>,
}

/// The end word of a here-document the command opens (`<<'EOF'`, `<<EOF`), if any.
fn here_document(line: &str) -> Option<String> {
    let (_, rest) = line.split_once("<<")?;
    let word: String = rest
        .trim_start_matches('-')
        .trim_start()
        .trim_matches(|c| c == '\'' || c == '"')
        .chars()
        .take_while(|c| c.is_alphanumeric() || *c == '_')
        .collect();
    (!word.is_empty()).then_some(word)
}

fn commands(block: &Block) -> Result<Vec<Shown>, String> {
    let mut out: Vec<Shown> = Vec::new();
    let mut continued = false;
    let mut here: Option<String> = None;
    for (k, line) in block.body.iter().enumerate() {
        let at = block.open + k; // index from 0 of this line in the page
        if continued || here.is_some() {
            let cmd = out.last_mut().unwrap();
            cmd.command.push('\n');
            cmd.command.push_str(line);
            if here.as_deref() == Some(line.trim()) {
                here = None;
            } else if here.is_none() {
                continued = line.ends_with('\\');
                here = here_document(line);
            }
            cmd.first = at + 1;
            cmd.end = at + 1;
        } else if let Some(command) = line.strip_prefix("$ ") {
            continued = command.ends_with('\\');
            here = here_document(command);
            out.push(Shown {
                line: at + 1,
                command: command.to_string(),
                first: at + 1,
                end: at + 1,
                output: Vec::new(),
            });
        } else if let Some(cmd) = out.last_mut() {
            cmd.output.push(line.clone());
            cmd.end = at + 1;
        } else {
            return Err(format!(
                "line {}: a console block starts with a `$ ` command",
                at + 1
            ));
        }
    }
    if out.is_empty() {
        return Err(format!(
            "line {}: a console block without a command",
            block.open
        ));
    }
    Ok(out)
}

/// `cargo run [--release] [-q] -- ARGS` is the binary with ARGS.
fn as_binary(command: &str) -> String {
    let Some(rest) = command.strip_prefix("cargo run ") else {
        return command.to_string();
    };
    let mut words = rest.splitn(2, " -- ");
    let options = words.next().unwrap_or("");
    match words.next() {
        Some(args)
            if options
                .split_whitespace()
                .all(|o| ["--release", "-q", "--quiet"].contains(&o)) =>
        {
            format!("nccomp {args}")
        }
        _ => command.to_string(),
    }
}

/// The scratch directory commands run in: `work/` (the current directory) holds copies of
/// the repository's directories; `bin/nccomp` is the binary under test.
struct Scratch {
    dir: tempfile::TempDir,
}

impl Scratch {
    fn new() -> Scratch {
        use std::os::unix::fs::symlink;
        let dir = tempfile::Builder::new()
            .prefix("nccomp-docs-")
            .tempdir()
            .unwrap();
        let work = dir.path().join("work");
        let bin = dir.path().join("bin");
        for d in [
            &work,
            &bin,
            &work.join("target/release"),
            &work.join("target/debug"),
        ] {
            std::fs::create_dir_all(d).unwrap();
        }
        for name in ["fixtures", "tools", "docs", "examples"] {
            copy_dir(&root().join(name), &work.join(name));
        }
        let exe = Path::new(env!("CARGO_BIN_EXE_nccomp"));
        for link in [
            bin.join("nccomp"),
            work.join("target/release/nccomp"),
            work.join("target/debug/nccomp"),
        ] {
            symlink(exe, link).unwrap();
        }
        let shared = root().join("../shared");
        if shared.is_dir() {
            symlink(shared.canonicalize().unwrap(), dir.path().join("shared")).unwrap();
        }
        Scratch { dir }
    }

    fn work(&self) -> PathBuf {
        self.dir.path().join("work")
    }
}

/// A copy, so that what a command writes never reaches the repository.
fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for entry in std::fs::read_dir(from).unwrap() {
        let entry = entry.unwrap();
        let target = to.join(entry.file_name());
        if entry.file_type().unwrap().is_dir() {
            copy_dir(&entry.path(), &target);
        } else {
            std::fs::copy(entry.path(), target).unwrap();
        }
    }
}

const MARK: &str = "@@docs-test-command-end";

/// Run the commands of one block in one `sh`; each command's output and exit status.
fn run(scratch: &Scratch, commands: &[Shown]) -> Result<(Vec<(String, i32)>, Duration), String> {
    let mut script = String::new();
    for (i, cmd) in commands.iter().enumerate() {
        writeln!(script, "{}", as_binary(&cmd.command)).unwrap();
        // The status is kept for the next command's `$?` (`echo $?` shows it).
        writeln!(
            script,
            "status=$?; printf '\\n{MARK} {i} %d\\n' \"$status\"; (exit $status)"
        )
        .unwrap();
    }
    let log_path = scratch.dir.path().join("output");
    let _ = std::fs::remove_file(&log_path);
    let log = std::fs::File::create(&log_path).unwrap();
    let path = std::env::join_paths(std::iter::once(scratch.dir.path().join("bin")).chain(
        std::env::split_paths(&std::env::var_os("PATH").unwrap_or_default()),
    ))
    .unwrap();
    let start = Instant::now();
    let mut child = Command::new("sh")
        .arg("-c")
        .arg(&script)
        .current_dir(scratch.work())
        .env("PATH", path)
        .env("NO_COLOR", "1")
        .stdin(Stdio::null())
        .stdout(log.try_clone().unwrap())
        .stderr(log)
        .spawn()
        .unwrap();
    loop {
        if child.try_wait().unwrap().is_some() {
            break;
        }
        if start.elapsed() > 4 * SLOW {
            let _ = child.kill();
            let _ = child.wait();
            return Err(format!("still running after {:?}: killed", 4 * SLOW));
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    let took = start.elapsed();
    let text = String::from_utf8_lossy(&std::fs::read(&log_path).unwrap()).into_owned();
    let mut outputs = Vec::new();
    let mut rest = text.as_str();
    for i in 0..commands.len() {
        let mark = format!("{MARK} {i} ");
        let Some(at) = rest.find(&mark) else {
            return Err(format!(
                "the shell stopped before command {}:\n{rest}",
                i + 1
            ));
        };
        let output = rest[..at].to_string();
        let after = &rest[at + mark.len()..];
        let (status, tail) = after.split_once('\n').unwrap_or((after, ""));
        outputs.push((output, status.trim().parse().unwrap_or(-1)));
        rest = tail;
    }
    Ok((outputs, took))
}

/// The output as compared: trailing white space and blank lines dropped.
fn tidy(text: &str) -> String {
    let mut out: String = text
        .lines()
        .map(|l| l.trim_end())
        .collect::<Vec<_>>()
        .join("\n");
    out.truncate(out.trim_end().len());
    out.push('\n');
    out
}

fn uses_corpus(commands: &[Shown]) -> bool {
    commands.iter().any(|c| c.command.contains("shared/corpus"))
}

/// Check one page; with SNAPSHOTS=overwrite, write the actual output of failing commands
/// into it.
fn check_page(page: &str) {
    let path = root().join(page);
    let text = std::fs::read_to_string(&path).unwrap();
    let all = blocks(&text);
    let mut failures = Vec::new();
    for pair in all.windows(2) {
        let gap = text
            .lines()
            .skip(pair[0].close)
            .take(pair[1].open - 1 - pair[0].close);
        if pair[0].lang == "sh"
            && pair[1].lang == "text"
            && gap.clone().all(|l| l.trim().is_empty())
        {
            failures.push(format!(
                "{page}:{}: a command followed by its output: write them as one ```console \
                 block (docs/ci.md, \"The documentation is tested\")",
                pair[0].open
            ));
        }
    }
    for block in &all {
        if block.lang == "text"
            && block
                .body
                .iter()
                .find(|l| !l.trim().is_empty())
                .is_some_and(|l| l.starts_with("$ "))
        {
            failures.push(format!(
                "{page}:{}: a command and its output in a text block: make it a ```console block",
                block.open
            ));
        }
    }
    let overwrite = std::env::var("SNAPSHOTS").is_ok_and(|v| v == "overwrite");
    let mut replace: Vec<(usize, usize, usize, Vec<String>)> = Vec::new();
    let mut skipped = 0;
    let mut ran = 0;
    let scratch = Scratch::new();
    for block in all.iter().filter(|b| b.lang == "console") {
        let shown = match commands(block) {
            Ok(shown) => shown,
            Err(e) => {
                failures.push(format!("{page}:{e}"));
                continue;
            }
        };
        if uses_corpus(&shown) && !root().join("../shared/corpus").is_dir() {
            skipped += shown.len();
            continue;
        }
        let (outputs, took) = match run(&scratch, &shown) {
            Ok(r) => r,
            Err(e) => {
                failures.push(format!("{page}:{}: {e}", block.open));
                continue;
            }
        };
        if took > SLOW {
            failures.push(format!(
                "{page}:{}: the block took {took:.1?}: state slow commands with their command \
                 and date instead of running them here",
                block.open
            ));
        }
        for (k, (cmd, (actual, status))) in shown.iter().zip(&outputs).enumerate() {
            ran += 1;
            let expected = tidy(&cmd.output.join("\n"));
            let actual = tidy(actual);
            let name = format!("{page}:{}", cmd.line);
            let result = snapbox::Assert::new()
                .normalize_paths(false)
                .palette(snapbox::report::Palette::plain())
                .try_eq(
                    Some(&name),
                    snapbox::IntoData::into_data(actual.clone()),
                    snapbox::IntoData::into_data(expected.clone()),
                );
            if let Err(e) = result {
                failures.push(format!(
                    "{name}: `{}` does not print what the page shows:\n{e}",
                    cmd.command
                ));
                if overwrite {
                    let lines = if actual.trim().is_empty() {
                        Vec::new()
                    } else {
                        actual.lines().map(str::to_string).collect()
                    };
                    replace.push((cmd.first, cmd.end, block.indent, lines));
                }
            }
            let status_shown = shown
                .get(k + 1)
                .is_some_and(|next| next.command == "echo $?");
            if *status != 0 && !expected.contains("error") && !status_shown {
                failures.push(format!(
                    "{name}: `{}` exits {status}, and the page shows no error",
                    cmd.command
                ));
            }
        }
    }
    if skipped > 0 {
        skip::skip_part(
            &format!("{skipped} commands of {page} read ../shared/corpus, which is not there"),
            "clone the corpus of real programs beside the project to run them",
        );
    }
    if overwrite && !replace.is_empty() {
        let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
        replace.sort_by_key(|r| std::cmp::Reverse(r.0));
        for (first, end, indent, new) in replace {
            let pad = " ".repeat(indent);
            lines.splice(
                first..end,
                new.into_iter()
                    .map(|l| if l.is_empty() { l } else { format!("{pad}{l}") }),
            );
        }
        let mut out = lines.join("\n");
        out.push('\n');
        std::fs::write(&path, out).unwrap();
    }
    assert!(
        failures.is_empty(),
        "{} of {ran} documented commands (and blocks) of {page} fail:\n\n{}",
        failures.len(),
        failures.join("\n\n")
    );
}

macro_rules! pages {
    ($($name:ident: $page:literal,)*) => {
        $(
            #[test]
            fn $name() {
                check_page($page);
            }
        )*

        /// A page added to docs/ is tested too.
        #[test]
        fn every_page_is_tested() {
            let listed = [$($page),*];
            let mut pages = vec!["README.md".to_string()];
            for entry in std::fs::read_dir(root().join("docs")).unwrap() {
                let name = entry.unwrap().file_name().into_string().unwrap();
                if name.ends_with(".md") {
                    pages.push(format!("docs/{name}"));
                }
            }
            for page in &pages {
                assert!(
                    listed.contains(&page.as_str()),
                    "{page} is not in tests/docs.rs's list of pages"
                );
            }
        }
    };
}

pages! {
    readme: "README.md",
    budget: "docs/budget.md",
    ci: "docs/ci.md",
    contour: "docs/contour.md",
    conventions: "docs/conventions.md",
    feature_workpiece: "docs/feature-workpiece.md",
    file_formats: "docs/file-formats.md",
    guide: "docs/guide.md",
    heidenhain: "docs/heidenhain.md",
    identify: "docs/identify.md",
    import: "docs/import.md",
    lathe: "docs/lathe.md",
    model: "docs/model.md",
    nc_support: "docs/nc-support.md",
    performance: "docs/performance.md",
    probe: "docs/probe.md",
    report: "docs/report.md",
    robustness: "docs/robustness.md",
    sinumerik: "docs/sinumerik.md",
}

// ------------------------------------------------------------------ links

/// A heading's anchor as GitHub makes it: lower case, letters, digits, `-` and `_` kept,
/// spaces to `-`, everything else dropped.
fn slug(heading: &str) -> String {
    heading
        .trim()
        .to_lowercase()
        .chars()
        .filter_map(|c| match c {
            ' ' => Some('-'),
            c if c.is_alphanumeric() || c == '-' || c == '_' => Some(c),
            _ => None,
        })
        .collect()
}

/// The anchors of a page: its headings' slugs (a repeated one numbered `-1`, `-2`, …)
/// and its `<a id="…">` tags.
fn anchors(text: &str) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    let mut fenced = false;
    for line in text.lines() {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
            continue;
        }
        if fenced {
            continue;
        }
        if let Some(heading) = line.strip_prefix('#') {
            let base = slug(heading.trim_start_matches('#'));
            let mut anchor = base.clone();
            let mut n = 0;
            while out.contains(&anchor) {
                n += 1;
                anchor = format!("{base}-{n}");
            }
            out.push(anchor);
        }
        let mut rest = line;
        while let Some(at) = rest.find("<a id=\"") {
            rest = &rest[at + 7..];
            if let Some(end) = rest.find('"') {
                out.push(rest[..end].to_string());
            }
        }
    }
    out
}

/// Every relative link of README.md and docs/*.md names a file that is there and, with
/// `#…`, an anchor of that page.
#[test]
fn links_between_the_pages_resolve() {
    let mut pages = vec![root().join("README.md")];
    for entry in std::fs::read_dir(root().join("docs")).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "md") {
            pages.push(path);
        }
    }
    let mut broken = Vec::new();
    for page in &pages {
        let text = std::fs::read_to_string(page).unwrap();
        let dir = page.parent().unwrap();
        let mut fenced = false;
        for (n, line) in text.lines().enumerate() {
            if line.trim_start().starts_with("```") {
                fenced = !fenced;
            }
            if fenced {
                continue;
            }
            let mut rest = line;
            while let Some(at) = rest.find("](") {
                rest = &rest[at + 2..];
                let Some(end) = rest.find(')') else { break };
                let target = &rest[..end];
                rest = &rest[end..];
                if target.contains("://") || target.starts_with("mailto:") {
                    continue;
                }
                let (file, anchor) = target.split_once('#').unwrap_or((target, ""));
                let file = if file.is_empty() {
                    page.clone()
                } else {
                    dir.join(file)
                };
                let name = page.strip_prefix(root()).unwrap_or(page);
                let place = format!("{}:{}: `{target}`", name.display(), n + 1);
                if !file.exists() {
                    broken.push(format!("{place}: no such file"));
                } else if !anchor.is_empty() {
                    let linked = std::fs::read_to_string(&file).unwrap_or_default();
                    if !anchors(&linked).iter().any(|a| a == anchor) {
                        broken.push(format!("{place}: no such anchor"));
                    }
                }
            }
        }
    }
    assert!(broken.is_empty(), "broken links:\n{}", broken.join("\n"));
}

#[test]
fn anchors_are_made_as_github_makes_them() {
    assert_eq!(
        slug(" Splitting moves (`--tolerance`)"),
        "splitting-moves---tolerance"
    );
    assert_eq!(
        slug(" Tool-centre-point programs (G43.4, G43.5)"),
        "tool-centre-point-programs-g434-g435"
    );
    assert_eq!(anchors("# A\n## A\n<a id=\"x\"></a>"), ["a", "a-1", "x"]);
}

// ------------------------------------------------------------------ the harness itself

#[test]
fn a_console_block_is_split_into_commands_and_outputs() {
    let page = "x\n```console\n$ a \\\n  b\none\ntwo\n$ c\n```\n";
    let all = blocks(page);
    let shown = commands(&all[0]).unwrap();
    assert_eq!(shown.len(), 2);
    assert_eq!(shown[0].command, "a \\\n  b");
    assert_eq!(shown[0].output, ["one", "two"]);
    assert_eq!((shown[0].first, shown[0].end), (4, 6));
    assert_eq!(shown[1].command, "c");
    assert!(shown[1].output.is_empty());
    let here = "```console\n$ cat > p.nc <<'EOF'\nG0 X1\nEOF\n$ wc -l < p.nc\n1\n```\n";
    let shown = commands(&blocks(here)[0]).unwrap();
    assert_eq!(shown[0].command, "cat > p.nc <<'EOF'\nG0 X1\nEOF");
    assert_eq!(shown[1].output, ["1"]);
    assert_eq!(
        as_binary("cargo run --release -q -- compensate -m m"),
        "nccomp compensate -m m"
    );
    assert_eq!(
        as_binary("cargo run --example x -- y"),
        "cargo run --example x -- y"
    );
}

#[test]
fn a_changed_output_fails() {
    let shown =
        commands(&blocks("```console\n$ nccomp --version\nnccomp 0.0.0\n```\n")[0]).unwrap();
    let (outputs, _) = run(&Scratch::new(), &shown).unwrap();
    assert_eq!(outputs[0].1, 0);
    let compare = |expected: &str| {
        snapbox::Assert::new()
            .palette(snapbox::report::Palette::plain())
            .try_eq(
                None,
                snapbox::IntoData::into_data(tidy(&outputs[0].0)),
                snapbox::IntoData::into_data(tidy(expected)),
            )
    };
    assert!(compare("nccomp 0.0.0").is_err());
    assert!(compare(&format!("nccomp {}", env!("CARGO_PKG_VERSION"))).is_ok());
    assert!(compare("nccomp [..]").is_ok());
}
