//! `nccomp check`: the CI gate over many programs, against one machine given on the
//! command line or against each program's machine from the shop's `nccomp.toml`.

use super::compensate::{PassOptions, load_pass};
use super::files::print;
use crate::check::config::{self, Config};
use crate::check::settings::Settings;
use crate::check::{Checker, ProgramCheck, Run, Status};
use crate::diag::{Error, use_color};
use rayon::prelude::*;
use std::path::{Path, PathBuf};

#[derive(clap::Args)]
pub(super) struct CheckArgs {
    /// Machine file (TOML). Left out: each program's machine comes from the config
    /// (`nccomp.toml` in this directory or above, or --config).
    #[arg(long, short = 'm', value_name = "MACHINE.toml")]
    machine: Option<PathBuf>,
    /// Error file (TOML), with --machine. Left out: the one the machine file names.
    #[arg(long, short = 'e', value_name = "ERRORS.toml", requires = "machine")]
    errors: Option<PathBuf>,
    #[command(flatten)]
    options: PassOptions,
    /// NC programs: paths or glob patterns (quoted, expanded by nccomp:
    /// `'progs/**/*.nc'`). Without --machine they may be left out: the config's whole
    /// library is checked.
    #[arg(value_name = "PROGRAM")]
    programs: Vec<String>,
    /// The config mapping programs to machines (docs/ci.md); by default `nccomp.toml` in
    /// the current directory or the nearest above it, up to the repository's root.
    #[arg(long, value_name = "nccomp.toml", conflicts_with = "machine")]
    config: Option<PathBuf>,
    /// Largest predicted tip error after compensation, mm (default 0.010, or the
    /// config's).
    #[arg(long, value_name = "MM")]
    max_error: Option<f64>,
    /// Largest predicted tool direction error after compensation, µrad (default 100, or
    /// the config's).
    #[arg(long, value_name = "URAD")]
    max_angle: Option<f64>,
    /// Output format: diagnostics for people, or JSON (docs/check.schema.json).
    #[arg(long, value_enum, default_value = "human")]
    format: CheckFormat,
    /// Human format: leave clean programs out of the report (the totals still count them).
    #[arg(long, short = 'q')]
    quiet: bool,
    /// Let programs that were not read pass as clean. With a zero error model the pass
    /// copies programs unread, and each is a finding (`unread`) by default.
    #[arg(long)]
    allow_unread: bool,
}

/// An entry's checker, or its machine file's name and why the entry cannot be used.
type EntryChecker<'m> = Result<Checker<'m>, (String, String)>;

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum CheckFormat {
    Human,
    Json,
}

impl CheckArgs {
    /// What the command line gives (the nearest place: over a config's entry and
    /// defaults).
    fn settings(&self) -> Settings {
        Settings {
            max_error: self.max_error,
            max_angle: self.max_angle,
            allow_unread: self.allow_unread.then_some(true),
            ..self.options.settings()
        }
    }
}

pub(super) fn check(args: &CheckArgs) -> crate::Result<Status> {
    let run = match &args.machine {
        Some(machine) => one_machine(args, machine)?,
        None => from_config(args)?,
    };
    print(&match args.format {
        CheckFormat::Human => run.human(use_color(&std::io::stdout()), args.quiet),
        CheckFormat::Json => run.json(),
    })?;
    Ok(run.status())
}

fn one_machine(args: &CheckArgs, machine: &Path) -> crate::Result<Run> {
    if args.programs.is_empty() {
        return Err(Error::Usage(
            "no program to check: expected PROGRAM arguments (paths or quoted patterns) with --machine".into(),
        ));
    }
    let settings = args.settings();
    let thresholds = settings.thresholds()?;
    let options = settings.options()?;
    let pass = load_pass(machine, args.errors.as_deref(), settings.setup_files())?;
    let (m, e) = (
        machine.display().to_string(),
        pass.errors_path.display().to_string(),
    );
    let checker = Checker::new(&pass.machine, &pass.errors, options, thresholds)?
        .allow_unread(settings.allow_unread.unwrap_or(false))
        .described(&m, &e, pass.used.clone());
    let paths = crate::check::expand_marked(&args.programs)?;
    let bar = crate::check::progress_bar(paths.len());
    let programs = quietly(|| checker.matched_files(&paths, &|| bar.inc(1)));
    bar.finish_and_clear();
    Ok(Run {
        config: None,
        machine: Some(m),
        errors: Some(e),
        thresholds: Some(thresholds),
        programs,
    })
}

/// A panic on one program is caught and reported in that program's entry: the default
/// hook's "panicked at" on standard error would only repeat it.
fn quietly<T>(f: impl FnOnce() -> T) -> T {
    let hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    let out = f();
    std::panic::set_hook(hook);
    out
}

fn from_config(args: &CheckArgs) -> crate::Result<Run> {
    let path = match &args.config {
        Some(p) => p.clone(),
        None => config::discover(Path::new(".")).ok_or_else(|| {
            Error::Usage(format!(
                "no --machine and no {} in this directory or above it (up to the repository's root): expected --machine FILE (and --errors FILE), or a config mapping programs to machines (docs/ci.md)",
                config::FILE_NAME
            ))
        })?,
    };
    let config = Config::load(&path)?;
    let config_name = path.display().to_string();
    // Each program with the entry that claims it, and whether a pattern matched it and
    // it is a FIFO or a socket (named, not read: reading one waits for a writer).
    let claims: Vec<(PathBuf, Option<usize>, bool)> = if args.programs.is_empty() {
        config
            .claims()?
            .into_iter()
            .map(|c| {
                let special = crate::check::not_regular(&c.path);
                (c.path, c.entry, special)
            })
            .collect()
    } else {
        crate::check::expand_marked(&args.programs)?
            .into_iter()
            .map(|(p, special)| {
                let entry = config.claim(&p);
                (p, entry, special)
            })
            .collect()
    };
    if claims.is_empty() {
        return Err(Error::Usage(format!(
            "{config_name}: its library holds no program (`library` and the entries' `paths` match no file): expected programs to check"
        )));
    }
    let cli = args.settings();
    // One machine, error model and checker per entry that claims a program; an entry
    // whose files are unusable makes its programs unusable, not the others.
    let mut loaded = Vec::new();
    for (i, entry) in config.entries.iter().enumerate() {
        if !claims.iter().any(|(_, e, _)| *e == Some(i)) {
            continue;
        }
        let settings = cli
            .clone()
            .over(&entry.settings.clone().over(&config.defaults));
        let pass = settings.thresholds().and_then(|t| {
            let options = settings.options()?;
            let pass = load_pass(
                &entry.machine,
                entry.errors.as_deref(),
                settings.setup_files(),
            )?;
            Ok((pass, t, options))
        });
        loaded.push((i, settings, pass));
    }
    let mut checkers: Vec<(usize, EntryChecker<'_>)> = Vec::new();
    for (i, settings, pass) in &loaded {
        let entry = &config.entries[*i];
        let m = entry.machine.display().to_string();
        let checker = match pass {
            Ok((pass, t, options)) => {
                let e = pass.errors_path.display().to_string();
                Checker::new(&pass.machine, &pass.errors, options.clone(), *t)
                    .map(|c| {
                        c.allow_unread(settings.allow_unread.unwrap_or(false))
                            .described(&m, &e, pass.used.clone())
                    })
                    .map_err(|err| (m.clone(), err.to_string()))
            }
            Err(err) => Err((m.clone(), err.to_string())),
        };
        checkers.push((*i, checker));
    }
    let bar = crate::check::progress_bar(claims.len());
    let programs: Vec<ProgramCheck> = quietly(|| {
        claims
            .par_iter()
            .map(|(path, entry, special)| {
                let name = path.display().to_string();
                let check = match entry.and_then(|e| checkers.iter().find(|(i, _)| *i == e)) {
                    Some(_) if *special => ProgramCheck::unusable(
                        &name,
                        &Error::Usage(format!(
                            "{name}: not a regular file (a FIFO or a socket), matched by a pattern: expected an NC program file"
                        )),
                    ),
                    Some((_, Ok(checker))) => checker.file(path),
                    Some((i, Err((machine, error)))) => {
                        let mut c = ProgramCheck::unusable(
                            &name,
                            &Error::Usage(format!(
                                "[[programs]] entry {} of {config_name} cannot be used: {error}",
                                config.entries[*i].number
                            )),
                        );
                        c.machine = Some(machine.clone());
                        c
                    }
                    None => ProgramCheck::unusable(
                        &name,
                        &Error::Usage(format!(
                            "no [[programs]] entry of {config_name} claims {name}: expected an entry whose `paths` match it (each program of the library is checked against its own machine, never a guessed one)"
                        )),
                    ),
                };
                bar.inc(1);
                check
            })
            .collect()
    });
    bar.finish_and_clear();
    Ok(Run {
        config: Some(config_name),
        machine: None,
        errors: None,
        thresholds: None,
        programs,
    })
}
