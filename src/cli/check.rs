//! `nccomp check`: the CI gate over many programs.

use super::compensate::PassArgs;
use super::files::print;
use crate::check::{Checker, Status, Thresholds};
use crate::diag::use_color;
use crate::model::{error_file, machine_file};

#[derive(clap::Args)]
pub(super) struct CheckArgs {
    #[command(flatten)]
    pass: PassArgs,
    /// NC programs: paths or glob patterns (quoted, expanded by nccomp: `'progs/**/*.nc'`).
    #[arg(value_name = "PROGRAM", required = true)]
    programs: Vec<String>,
    /// Largest predicted tip error after compensation, mm.
    #[arg(long, value_name = "MM", default_value_t = crate::check::DEFAULT_MAX_ERROR_MM)]
    max_error: f64,
    /// Largest predicted tool direction error after compensation, µrad (by default the
    /// direction error is reported, not judged).
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

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum CheckFormat {
    Human,
    Json,
}

pub(super) fn check(args: &CheckArgs) -> crate::Result<Status> {
    let thresholds = Thresholds::new(args.max_error, args.max_angle)?;
    let machine = machine_file::load(&args.pass.machine)?;
    let errors = error_file::load(&args.pass.errors, &machine)?;
    let checker = Checker::new(&machine, &errors, args.pass.options()?, thresholds)?
        .allow_unread(args.allow_unread);
    let paths = crate::check::expand_marked(&args.programs)?;
    let bar = crate::check::progress_bar(paths.len());
    // A panic on one program is caught and reported in that program's entry: the
    // default hook's "panicked at" on standard error would only repeat it.
    let hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    let programs = checker.matched_files(&paths, &|| bar.inc(1));
    std::panic::set_hook(hook);
    bar.finish_and_clear();
    let run = crate::check::Run {
        machine: args.pass.machine.display().to_string(),
        errors: args.pass.errors.display().to_string(),
        thresholds,
        programs,
    };
    print(&match args.format {
        CheckFormat::Human => run.human(use_color(&std::io::stdout()), args.quiet),
        CheckFormat::Json => run.json(),
    })?;
    Ok(run.status())
}
