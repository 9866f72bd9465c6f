//! `nccomp check` and `nccomp compensate --check` as a CI job runs them: exit codes 0, 1
//! and 2 in both formats, the JSON against its published schema, and a stale committed
//! output caught by one digit.

mod common;
use common::cli::{scratch, stderr};

use serde_json::Value;
use std::path::Path;
use std::process::{Command, Output};

const M: &str = "fixtures/ac_trunnion.machine.toml";
const E: &str = "fixtures/ac_trunnion.errors.toml";

fn nccomp(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_nccomp"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .env_remove("NO_COLOR")
        .output()
        .unwrap()
}

/// `check` against the AC trunnion. Its exaggerated errors leave up to 166 µrad of
/// direction error at singular poses (C along the tool, held), above the default
/// --max-angle of 100 µrad (tests/check_config.rs shows it failing): these tests are about
/// other findings, so they judge the direction at 200 µrad unless they say.
fn check(extra: &[&str]) -> Output {
    let mut args = vec!["check", "-m", M, "-e", E];
    if !extra.contains(&"--max-angle") {
        args.extend(["--max-angle", "200"]);
    }
    args.extend_from_slice(extra);
    nccomp(&args)
}

fn stdout(out: &Output) -> String {
    String::from_utf8(out.stdout.clone()).unwrap()
}

/// A program with cutter compensation (refused) and a move below Z's travel (-100 … 400).
const DEMO: &str = "fixtures/check_demo.nc";

/// The JSON output, checked against docs/check.schema.json.
fn valid_json(out: &Output) -> Value {
    let schema: Value = serde_json::from_str(
        &std::fs::read_to_string(
            Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/check.schema.json"),
        )
        .unwrap(),
    )
    .unwrap();
    jsonschema::meta::validate(&schema).unwrap();
    let validator = jsonschema::validator_for(&schema).unwrap();
    let doc: Value = serde_json::from_str(&stdout(out)).unwrap();
    let errors: Vec<String> = validator
        .iter_errors(&doc)
        .map(|e| format!("{} at {}", e, e.instance_path()))
        .collect();
    assert!(errors.is_empty(), "{errors:#?}\n{doc:#}");
    // The validator does judge: a document with a status the schema does not know fails.
    let mut wrong = doc.clone();
    wrong["programs"][0]["status"] = "fine".into();
    assert!(!validator.is_valid(&wrong));
    doc
}

/// The line of `compensate`'s summary that starts with `label`.
fn summary_line(program: &str, label: &str) -> String {
    let out = nccomp(&["compensate", "-m", M, "-e", E, program, "-o", "-"]);
    assert!(out.status.success());
    stderr(&out)
        .lines()
        .find(|l| l.starts_with(label))
        .unwrap()
        .to_string()
}

#[test]
fn exit_0_human_every_program_is_clean_and_stderr_stays_silent() {
    let dir = scratch("clean");
    for (name, fixture) in [
        ("b.nc", "ac_trunnion_tcp.nc"),
        ("a.nc", "ac_trunnion_g91.nc"),
    ] {
        std::fs::copy(Path::new("fixtures").join(fixture), dir.join(name)).unwrap();
    }
    let pattern = format!("{}/*.nc", dir.display());
    let out = check(&[&pattern, "fixtures/feature_workpiece.nc"]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    // No progress bar and no colour without a terminal.
    assert_eq!(stderr(&out), "");
    let text = stdout(&out);
    assert!(!text.contains('\x1b'), "{text}");
    // The pattern is expanded by nccomp, sorted; the path after it keeps its place.
    let headers: Vec<&str> = text.lines().filter(|l| l.ends_with(": clean")).collect();
    let d = dir.display();
    assert_eq!(
        headers,
        [
            format!("{d}/a.nc: clean"),
            format!("{d}/b.nc: clean"),
            "fixtures/feature_workpiece.nc: clean".to_string(),
        ]
    );
    assert!(
        text.ends_with(
            "checked 3 programs against fixtures/ac_trunnion.machine.toml and fixtures/ac_trunnion.errors.toml: 3 clean, 0 with findings, 0 unusable (--max-error 0.01 mm, --max-angle 200 µrad)\n"
        ),
        "{text}"
    );
    // The predictions are the compensation pass's own: the same figures as its summary.
    let tip = summary_line("fixtures/feature_workpiece.nc", "predicted tip error:");
    let before = tip
        .split("before ")
        .nth(1)
        .unwrap()
        .split(',')
        .next()
        .unwrap();
    let after = tip.split("after ").nth(1).unwrap();
    assert!(
        text.contains(&format!(
            "  before compensation: tip error up to {before}, mean "
        )),
        "{before}\n{text}"
    );
    assert!(
        text.contains(&format!("  after compensation:  tip error up to {after}")),
        "{after}\n{text}"
    );
    assert!(text.contains("compensation lands every pose within the thresholds"));
}

#[test]
fn exit_0_json_matches_the_schema_and_the_summary() {
    let out = check(&["--format", "json", "fixtures/feature_workpiece.nc"]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    assert_eq!(stderr(&out), "");
    let doc = valid_json(&out);
    assert_eq!(doc["status"], "clean");
    assert_eq!(doc["exit_code"], 0);
    assert_eq!(doc["thresholds"]["max_error_mm"], 0.01);
    assert_eq!(doc["thresholds"]["max_angle_urad"], 200.0);
    let p = &doc["programs"][0];
    assert_eq!(p["lands_every_pose"], true);
    let lines = std::fs::read_to_string("fixtures/feature_workpiece.nc")
        .unwrap()
        .lines()
        .count();
    assert_eq!(p["lines"], lines);
    // Largest, mean and where, as compensate's summary states them (µm with 3 decimals).
    let tip = summary_line("fixtures/feature_workpiece.nc", "predicted tip error:");
    let before = &p["before"]["tip_mm"];
    let shown = format!(
        "before {:.3} µm (line {})",
        before["max"].as_f64().unwrap() * 1e3,
        before["line"]
    );
    assert!(tip.contains(&shown), "{tip} / {shown}");
    let mean = before["mean"].as_f64().unwrap();
    assert!(mean > 0.0 && mean < before["max"].as_f64().unwrap());
    let after = p["after"]["tip_mm"]["max"].as_f64().unwrap();
    assert!(after < 1e-3, "{after}");
}

#[test]
fn exit_1_human_points_at_the_offending_words() {
    let bad = DEMO;
    let out = check(&[bad]);
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
    assert_eq!(stderr(&out), "");
    let text = stdout(&out);
    assert!(text.starts_with(&format!("{bad}: 2 findings\n")), "{text}");
    assert!(
        text.contains("  compensation does not land every pose\n"),
        "{text}"
    );
    let refused = format!(
        "error[refused]: G41 cannot be compensated: cutter radius compensation (G41/G42) is not supported\n --> {bad}:5:5\n  |\n5 | N30 G41 D1 X10. Y10.\n  |     ^^^\n"
    );
    assert!(text.contains(&refused), "{text}");
    let travel = format!(
        "error[travel_limit]: axis Z is programmed to -250.0000, outside its travel -100 … 400 (use --allow-limit-violations to compensate it anyway)\n --> {bad}:7:20\n  |\n7 | N50 G1 X-40. Y-40. Z-250. A-20. C0\n  |                    ^^^^^^\n"
    );
    assert!(text.contains(&travel), "{text}");
    assert!(
        text.contains(": 0 clean, 1 with findings, 0 unusable"),
        "{text}"
    );

    // -q leaves the clean programs out of the report, not out of the totals.
    let out = check(&["-q", "fixtures/ac_trunnion_tcp.nc", bad]);
    assert_eq!(out.status.code(), Some(1));
    let quiet = stdout(&out);
    assert!(!quiet.contains("ac_trunnion_tcp.nc"), "{quiet}");
    assert!(
        quiet.starts_with(&format!("{bad}: 2 findings\n")),
        "{quiet}"
    );
    assert!(
        quiet.contains(&refused) && quiet.contains(&travel),
        "{quiet}"
    );
    assert!(quiet.ends_with(
        "1 clean, 1 with findings, 0 unusable (--max-error 0.01 mm, --max-angle 200 µrad)\n"
    ));
}

#[test]
fn exit_1_json_lists_every_kind_of_finding() {
    // With --allow-limit-violations the travel violation is written and still a finding.
    let out = check(&["--format", "json", "--allow-limit-violations", DEMO]);
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
    let doc = valid_json(&out);
    assert_eq!(
        (&doc["status"], &doc["exit_code"]),
        (&"findings".into(), &1.into())
    );
    let findings = doc["programs"][0]["findings"].as_array().unwrap();
    let kinds: Vec<(&str, u64, u64)> = findings
        .iter()
        .map(|f| {
            (
                f["kind"].as_str().unwrap(),
                f["line"].as_u64().unwrap(),
                f["column"].as_u64().unwrap(),
            )
        })
        .collect();
    assert_eq!(kinds, [("refused", 5, 5), ("travel_limit", 7, 20)]);
    assert_eq!(
        findings[1]["source_line"],
        "N50 G1 X-40. Y-40. Z-250. A-20. C0"
    );
    assert_eq!(
        findings[1]["message"],
        "axis Z is programmed to -250.0000, below its travel limit -100"
    );

    // Thresholds turn predictions into findings: a tip tolerance below what the rounded
    // output reaches, and a direction tolerance below what singular poses keep.
    let out = check(&[
        "--format",
        "json",
        "--max-error",
        "0.00001",
        "--max-angle",
        "100",
        "fixtures/feature_workpiece.nc",
    ]);
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
    let doc = valid_json(&out);
    let p = &doc["programs"][0];
    assert_eq!(p["lands_every_pose"], false);
    let kinds: Vec<&str> = p["findings"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f["kind"].as_str().unwrap())
        .collect();
    assert_eq!(kinds.len(), 2, "{p:#}");
    assert!(kinds.contains(&"tip_error") && kinds.contains(&"direction_error"));
    // Each at the line where the error is largest: the direction's at a singular pose or
    // elsewhere, whichever is larger.
    let after = &p["after"];
    let worst_direction = ["direction_urad", "singular_direction_urad"]
        .iter()
        .map(|k| &after[*k])
        .max_by(|a, b| a["max"].as_f64().partial_cmp(&b["max"].as_f64()).unwrap())
        .unwrap();
    assert!(
        after["singular_direction_urad"]["max"].as_f64().unwrap() > 100.0,
        "{p:#}"
    );
    for (kind, peak) in [
        ("tip_error", &after["tip_mm"]),
        ("direction_error", worst_direction),
    ] {
        let f = p["findings"]
            .as_array()
            .unwrap()
            .iter()
            .find(|f| f["kind"] == kind)
            .unwrap();
        assert_eq!(f["line"], peak["line"], "{kind}");
    }
}

#[test]
fn exit_2_when_a_program_cannot_be_read_the_others_are_still_reported() {
    let out = check(&["fixtures/missing.nc", "fixtures/ac_trunnion_tcp.nc"]);
    assert_eq!(out.status.code(), Some(2));
    let text = stdout(&out);
    assert!(
        text.contains(
            "fixtures/missing.nc: unusable\nerror: fixtures/missing.nc: No such file or directory"
        ),
        "{text}"
    );
    assert!(
        text.contains("fixtures/ac_trunnion_tcp.nc: clean"),
        "{text}"
    );
    assert!(text.contains("1 unusable"), "{text}");

    let out = check(&[
        "--format",
        "json",
        "fixtures/missing.nc",
        "fixtures/ac_trunnion_tcp.nc",
    ]);
    assert_eq!(out.status.code(), Some(2));
    let doc = valid_json(&out);
    assert_eq!(
        (&doc["status"], &doc["exit_code"]),
        (&"unusable".into(), &2.into())
    );
    assert_eq!(doc["totals"]["unusable"], 1);
    assert_eq!(doc["programs"][0]["before"], Value::Null);
    assert!(
        doc["programs"][0]["error"]
            .as_str()
            .unwrap()
            .contains("No such file")
    );
    assert_eq!(doc["programs"][1]["status"], "clean");
}

#[test]
fn exit_2_for_unusable_options_and_files_before_any_report() {
    let dir = scratch("u2");
    let machine = dir.join("m.toml");
    std::fs::write(
        &machine,
        "workpiece_chain = [\"Y\"]\ntool_chain = []\nspeed = 3\n",
    )
    .unwrap();
    for (args, expected) in [
        (
            vec![
                "check",
                "-m",
                machine.to_str().unwrap(),
                "-e",
                E,
                "fixtures/feature_workpiece.nc",
            ],
            "error: ",
        ),
        (
            vec![
                "check",
                "-m",
                M,
                "-e",
                E,
                "--max-error",
                "0",
                "fixtures/feature_workpiece.nc",
            ],
            "error: --max-error 0: expected a positive number (mm)\n",
        ),
        (
            vec!["check", "-m", M, "-e", E, "fixtures/*.tap"],
            "error: `fixtures/*.tap` matches no file\n",
        ),
        (
            vec![
                "check",
                "-m",
                M,
                "-e",
                E,
                "--format",
                "json",
                "fixtures/*.tap",
            ],
            "error: `fixtures/*.tap` matches no file\n",
        ),
    ] {
        let out = nccomp(&args);
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        assert_eq!(stdout(&out), "", "{args:?}");
        assert!(
            stderr(&out).starts_with(expected),
            "{args:?}: {}",
            stderr(&out)
        );
    }
}

#[test]
fn no_color_and_pipes_get_plain_text() {
    // stdout is a pipe here: whatever NO_COLOR says, no escape codes.
    let out = Command::new(env!("CARGO_BIN_EXE_nccomp"))
        .args(["check", "-m", M, "-e", E, DEMO])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .env("NO_COLOR", "1")
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(!stdout(&out).contains('\x1b'));
}

#[test]
fn the_stale_check_catches_a_one_digit_change() {
    let dir = scratch("stale");
    let committed = dir.join("fw.comp.nc");
    let program = "fixtures/feature_workpiece.nc";
    let out = nccomp(&[
        "compensate",
        "-q",
        "-m",
        M,
        "-e",
        E,
        program,
        "-o",
        committed.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let stale = |expected: &Path| {
        nccomp(&[
            "compensate",
            "-q",
            "-m",
            M,
            "-e",
            E,
            "--check",
            program,
            "--expected",
            expected.to_str().unwrap(),
        ])
    };
    // Up to date: exit 0, nothing printed, nothing written.
    let out = stale(&committed);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    assert_eq!(stdout(&out), "");
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);

    // One digit of one compensated word changed by hand.
    let text = std::fs::read_to_string(&committed).unwrap();
    let (number, line) = text
        .lines()
        .enumerate()
        .find(|(_, l)| l.contains('X') && l.contains('.'))
        .map(|(i, l)| (i + 1, l.to_string()))
        .unwrap();
    let digit = line.rfind(|c: char| c.is_ascii_digit()).unwrap();
    let mut edited = line.clone();
    let old = edited.as_bytes()[digit];
    edited.replace_range(digit..=digit, if old == b'7' { "8" } else { "7" });
    let changed = text.replacen(&format!("{line}\n"), &format!("{edited}\n"), 1);
    assert_ne!(changed, text);
    std::fs::write(&committed, &changed).unwrap();
    let out = stale(&committed);
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
    let diff = stdout(&out);
    let name = committed.display();
    assert!(
        diff.starts_with(&format!(
            "{name} is not what nccomp writes now (first difference at line {number}; 1 line removed, 1 added)\n"
        )),
        "{diff}"
    );
    assert!(
        diff.contains(&format!(
            "--- {name} (committed)\n+++ {name} (nccomp now)\n"
        )),
        "{diff}"
    );
    assert!(diff.contains(&format!("\n-{edited}\n+{line}\n")), "{diff}");
    // The committed file is left as it was.
    assert_eq!(std::fs::read_to_string(&committed).unwrap(), changed);

    // A committed file that cannot be read is unusable input.
    let out = stale(&dir.join("none.nc"));
    assert_eq!(out.status.code(), Some(2));
    // --check needs --expected and writes no output.
    let out = nccomp(&["compensate", "-m", M, "-e", E, "--check", program]);
    assert_eq!(out.status.code(), Some(2));
    let out = nccomp(&[
        "compensate",
        "-m",
        M,
        "-e",
        E,
        "--check",
        program,
        "--expected",
        committed.to_str().unwrap(),
        "-o",
        "x.nc",
    ]);
    assert_eq!(out.status.code(), Some(2));
}

#[test]
fn one_bad_program_never_stops_the_check_of_the_others() {
    let dir = scratch("bad-one");
    let digits = "9".repeat(310);
    // Numbers that overflow to infinity once crashed the whole run (exit 101, no report).
    let bad = [
        (
            "x.nc",
            format!("G21 G90\nG0 X0 Y0 Z50 A-30 C0\nG1 X{digits} F100\n"),
        ),
        (
            "j.nc",
            format!("G21 G90\nG0 X0 Y0 Z50 A-30 C0\nG43.5 H1 X1 Y1 Z1 I0 J{digits} K1\n"),
        ),
        (
            "r.nc",
            format!("G21 G90\nG0 X0 Y0 Z50 A-30 C0\nG2 X10 Y0 R{digits} F100\n"),
        ),
    ];
    let mut args = vec!["--format".to_string(), "json".to_string()];
    args.push("fixtures/ac_trunnion_tcp.nc".into());
    for (name, text) in &bad {
        std::fs::write(dir.join(name), text).unwrap();
        args.push(dir.join(name).display().to_string());
    }
    args.push("fixtures/ac_trunnion_g91.nc".into());
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let out = check(&args);
    assert!(!stderr(&out).contains("panicked"), "{}", stderr(&out));
    let doc = valid_json(&out);
    // Every program has its entry, in order; the good ones are checked.
    let programs = doc["programs"].as_array().unwrap();
    assert_eq!(programs.len(), 5);
    assert_eq!(programs[0]["status"], "clean");
    assert_eq!(programs[4]["status"], "clean");
    // Each bad one is this program's outcome: a finding or unusable, with a message that
    // names it.
    for (p, (name, _)) in programs[1..4].iter().zip(&bad) {
        assert!(p["path"].as_str().unwrap().ends_with(name));
        match p["status"].as_str().unwrap() {
            "findings" => assert!(!p["findings"].as_array().unwrap().is_empty()),
            "unusable" => assert!(p["error"].as_str().unwrap().contains(name), "{p:#}"),
            other => panic!("{name}: {other}"),
        }
    }
    assert_eq!(
        out.status.code(),
        doc["exit_code"].as_i64().map(|c| c as i32)
    );
}

#[test]
fn a_zero_model_reads_no_program_so_each_is_a_finding_unless_allowed() {
    let dir = scratch("zero");
    let zero = dir.join("zero.errors.toml");
    std::fs::write(&zero, "length_unit = \"mm\"\nangle_unit = \"rad\"\n").unwrap();
    std::fs::write(dir.join("garbage.nc"), b"\x00\xff not a program\n").unwrap();
    let garbage = dir.join("garbage.nc").display().to_string();
    let zero = zero.display().to_string();
    let run = |extra: &[&str]| {
        let mut args = vec!["check", "-m", M, "-e", &zero];
        args.extend_from_slice(extra);
        nccomp(&args)
    };
    let out = run(&["--format", "json", DEMO, &garbage]);
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
    let doc = valid_json(&out);
    for p in doc["programs"].as_array().unwrap() {
        assert_eq!(p["status"], "findings", "{p:#}");
        let f = &p["findings"][0];
        assert_eq!(f["kind"], "unread");
        assert_eq!((&f["line"], &f["column"]), (&1.into(), &1.into()));
        assert!(
            f["message"]
                .as_str()
                .unwrap()
                .contains("the error model is zero, so the program was passed through unread"),
            "{f:#}"
        );
    }
    let out = run(&[&garbage]);
    assert_eq!(out.status.code(), Some(1));
    assert!(
        stdout(&out).contains("error[unread]: the error model is zero"),
        "{}",
        stdout(&out)
    );
    // Allowed: clean, and still said.
    let out = run(&["--allow-unread", DEMO, &garbage]);
    assert_eq!(out.status.code(), Some(0), "{}", stdout(&out));
    assert!(stdout(&out).contains(
        "note: the error model is zero: the program passes unchanged and nothing was checked"
    ));
}

/// A pattern's matches that cannot be read, or whose names are not UTF-8, are never left
/// out without a word (issue 34, case 10): a dangling symbolic link is named unusable
/// (exit 2), a file whose name is not UTF-8 is checked like any other (here its program
/// fails: exit 1 for it alone would already be non-zero).
#[cfg(unix)]
#[test]
fn a_pattern_names_every_file_it_matched_even_dangling_links_and_non_utf8_names() {
    use std::ffi::OsStr;
    use std::os::unix::ffi::OsStrExt;
    let dir = scratch("pattern-unreadable");
    std::fs::copy(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/ac_trunnion_tcp.nc"),
        dir.join("good.nc"),
    )
    .unwrap();
    // A program that fails (cutter compensation is refused), under a Latin-1 name.
    let odd = dir.join(OsStr::from_bytes(b"caf\xe9.nc"));
    std::fs::copy(Path::new(env!("CARGO_MANIFEST_DIR")).join(DEMO), &odd).unwrap();
    let pattern = format!("{}/*.nc", dir.display());

    // The non-UTF-8 name alone: checked, its findings reported.
    let out = check(&["--format", "json", &pattern]);
    let doc = valid_json(&out);
    let programs = doc["programs"].as_array().unwrap();
    assert_eq!(programs.len(), 2, "{doc:#}");
    let bad = programs
        .iter()
        .find(|p| p["path"].as_str().unwrap().contains("caf"))
        .unwrap_or_else(|| panic!("the non-UTF-8 name is not in the report: {doc:#}"));
    assert_eq!(bad["status"], "findings", "{bad:#}");
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));

    // A dangling link the pattern matches: named, unusable, exit 2; a FIFO likewise
    // (reading it would wait for a writer forever).
    std::os::unix::fs::symlink(dir.join("nowhere.nc"), dir.join("link.nc")).unwrap();
    let fifo = Command::new("mkfifo")
        .arg(dir.join("pipe.nc"))
        .status()
        .unwrap();
    assert!(fifo.success());
    let out = check(&[&pattern]);
    let text = stdout(&out);
    assert_eq!(out.status.code(), Some(2), "{text}");
    assert!(text.contains("link.nc: unusable"), "{text}");
    assert!(
        text.contains("pipe.nc: unusable") && text.contains("not a regular file"),
        "{text}"
    );
    assert!(text.contains("good.nc: clean"), "{text}");
    assert!(text.contains("caf\u{fffd}.nc: 2 findings"), "{text}");
}
