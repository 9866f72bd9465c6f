//! The command line: the `nccomp` parser and its dispatch to one module a command. The
//! binary only parses and calls [`run`]; errors are printed once, here.

mod budget;
mod check;
mod compensate;
mod contour;
mod errors;
mod files;
mod identify;
mod probe;
mod report;
mod verify;

use crate::check::Status;
use crate::diag::{panic_message, use_color};
use budget::{SensitivityArgs, ToleranceArgs};
use check::CheckArgs;
use clap::{Parser, Subcommand};
use compensate::CompensateArgs;
use contour::ContourArgs;
use errors::ErrorsCommand;
use files::Std;
use identify::{IdentifyArgs, SimulateCutArgs};
use probe::ProbeArgs;
use report::ReportArgs;
use std::process::ExitCode;
use verify::VerifyArgs;

/// Exit code for bad input or files (0 is success).
const EXIT_BAD_INPUT: u8 = 2;

#[derive(Parser)]
#[command(
    name = "nccomp",
    version,
    about = "Correct NC programs for a machine tool's measured geometric errors",
    long_about = "nccomp reads an NC program written for the ideal machine, evaluates the \
machine's measured error model (squareness, straightness, pitch/yaw/roll, rotary axis \
location errors ...) at every pose, and writes the same program with the axis values the \
real machine needs so the tool ends up where the CAM system meant it to be.\n\n\
Run it after the CAM postprocessor, on programs in machine-axis coordinates (X Y Z and the \
rotary axes). Every byte that needs no change is copied unchanged."
)]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Compensate an NC program through the machine's error model.
    #[command(
        after_help = "Examples:\n  nccomp compensate --machine fixtures/ac_trunnion.machine.toml \\\n      --errors fixtures/ac_trunnion.errors.toml part.nc -o part.comp.nc\n  cat part.nc | nccomp compensate --machine m.toml --errors e.toml > part.comp.nc\n\n\
With --check --expected OUT.nc nothing is written: nccomp compares OUT.nc with what it \
would write and prints a diff of the first differing blocks (like `rustfmt --check`).\n\n\
Exit status: 0 when the program was compensated (with --check: OUT.nc is up to date), 1 \
with --check when OUT.nc differs, 2 when an input file is unusable or a block cannot be \
compensated (the message names file:line:column). The output file is written only on \
success, and atomically: a failed run never leaves a half-written program."
    )]
    Compensate(CompensateArgs),
    /// Check programs as a CI gate: predicted errors before and after compensation,
    /// travel limits, blocks that cannot be compensated (in parallel, nothing written).
    #[command(
        after_help = "Examples:\n  nccomp check -m fixtures/ac_trunnion.machine.toml -e fixtures/ac_trunnion.errors.toml \\\n      'programs/**/*.nc'\n  nccomp check -m m.toml -e e.toml --max-error 0.005 --format json part.nc > check.json\n\n\
Each program is run through the compensation pass with the options given (the same as \
`compensate` takes); findings are blocks that cannot be compensated, travel-limit \
violations, and predicted errors after compensation above --max-error/--max-angle. \
See docs/ci.md.\n\n\
Exit status: 0 when every program is clean, 1 when any has findings, 2 when an input is \
unusable (an option, the machine or error file, or a program that cannot be read)."
    )]
    Check(CheckArgs),
    #[command(
        after_help = "Example:\n  nccomp verify --machine fixtures/ac_trunnion.machine.toml \\\n      --errors fixtures/ac_trunnion.errors.toml part.nc part.comp.nc\n\n\
Reads the compensated program as the control reads it (in each block-delete state the \
original can run in), takes the real machine along the control's interpolation of its \
words and holds it against the nominal path of the original, at block ends and between \
them (--tolerance, --angular-tolerance). The compensated program may come from any tool. \
See docs/ci.md.\n\n\
Exit status: 0 when the compensated program puts the tool on the original's nominal path, \
1 with located findings when it does not, 2 when an input is unusable."
    )]
    Verify(VerifyArgs),
    /// Parameter study and key errors: how much each error term moves the tool tip, and
    /// which terms matter most for the error in one direction (Liu and Hong 2016, docs/model.md).
    #[command(
        after_help = "Examples:\n  nccomp sensitivity -m fixtures/grinder.machine.toml --at X=50,Y=45,Z=5\n  \
nccomp sensitivity -m fixtures/grinder.machine.toml -b fixtures/grinder.budget.toml --svg ranking.svg\n\n\
Without --budget: the parameter study (the change of the tool tip and direction per unit of \
each term, at --at or as the worst case over a grid of poses). With --budget: also the \
ranking of the file's [ranges] terms by an orthogonal-array ANOVA and by Sobol indices. \
See docs/budget.md.\n\n\
Exit status: 0 on success, 2 when an input file or option is unusable."
    )]
    Sensitivity(SensitivityArgs),
    /// Tolerance design: the cost–quality model of Liu and Hong (2016) solved for the tolerances of
    /// the key errors within their bounds.
    #[command(
        after_help = "Example:\n  nccomp tolerance -m fixtures/grinder.machine.toml -b fixtures/grinder.budget.toml\n\n\
The key errors, their bounds and cost curves and the model's constants come from the budget \
file's [tolerance] table. See docs/budget.md.\n\n\
Exit status: 0 on success, 2 when an input file or option is unusable."
    )]
    Tolerance(ToleranceArgs),
    /// Compensate a touch probe's pre-travel: a probing speed per direction (Bai, Li and Wu 2021, docs/model.md).
    #[command(
        long_about = "Compensate a touch-trigger probe's systematic error by its probing speed \
(Bai, Li and Wu 2021, docs/model.md). Pre-travel is w = wT(α, β) + v·τ; choosing the speed per direction as \
v = v0 + (R − r(α, β))/τ makes it the same in every direction.\n\n\
From ring-gauge radii at several speeds (--ring) nccomp fits the delay τ; from a map of \
trigger radius over directions (--map) it computes the speed per direction; with a \
probing program it sets the F of every G31 / G38.2–G38.5 move from the move's direction \
and restores the program's own feed after it. Every other byte is copied unchanged. See \
docs/probe.md for the file formats and conventions.",
        after_help = "Examples:\n  nccomp probe --ring ring.csv\n  nccomp probe --tau 12.68 --map map.csv --min-feed 20 --max-feed 120\n  nccomp probe --ring ring.csv --map map.csv probe.nc -o probe.comp.nc --plot map.svg\n\n\
Exit status: 0 on success, 2 when an input is unusable (the message names file:line:column) \
or the speeds needed fall outside --min-feed/--max-feed. Outputs are written only on \
success, and atomically."
    )]
    Probe(ProbeArgs),
    /// Write an HTML report on a program: pass or fail against --max-error/--max-angle,
    /// predicted errors before and after compensation, the correction per axis, and maps
    /// of the machine's volumetric error over the program's working volume.
    #[command(
        after_help = "Example:\n  nccomp report --machine fixtures/ac_trunnion.machine.toml \\\n      --errors fixtures/ac_trunnion.errors.toml fixtures/feature_workpiece.nc \\\n      --at A=0,C=0 --at A=-90,C=90 -o report.html\n\n\
One self-contained HTML file (inline SVG, no external resources). See docs/report.md.\n\n\
Exit status: 0 when the report was written (whether the page says PASS or FAIL: `nccomp check` \
is the gate), 2 when an input is unusable or a block cannot be compensated. The file is \
written only on success, and atomically."
    )]
    Report(ReportArgs),
    /// Error files: convert calibration files from the field (ISG CSV, Etalon) into nccomp's.
    #[command(subcommand)]
    Errors(ErrorsCommand),
    /// Identify the errors from a cut feature workpiece measured on the machine and on a
    /// CMM, and separate quasi-static from dynamic errors (Liang and Liu 2024, docs/model.md).
    #[command(
        after_help = "Example:\n  nccomp identify -m fixtures/ac_trunnion.machine.toml --plan fixtures/feature_workpiece.plan.toml \\\n      --program fixtures/feature_workpiece.nc --on-machine probe.csv --cmm cmm.csv -o errors.toml\n\n\
Prints the separation table (total = CMM − nominal, quasi-static = CMM − on-machine, dynamic = \
total − quasi-static) and writes the chosen part as an error file for `nccomp compensate`. \
See docs/identify.md.\n\nExit status: 0 on success, 2 when an input is unusable (the message \
names file:line:column)."
    )]
    Identify(IdentifyArgs),
    /// Cut a workpiece in a simulator on a machine with known errors and write what the
    /// on-machine probe and a CMM would measure (the twin of `identify`).
    #[command(
        after_help = "Example:\n  nccomp simulate-cut -m fixtures/ac_trunnion.machine.toml --plan fixtures/feature_workpiece.plan.toml \\\n      --program fixtures/feature_workpiece.nc --errors fixtures/feature_workpiece.quasi_static.toml \\\n      --dynamic fixtures/feature_workpiece.dynamic.toml --on-machine probe.csv --cmm cmm.csv\n\n\
The quasi-static errors act while cutting and probing, the dynamic ones only while cutting. \
See docs/identify.md.\n\nExit status: 0 on success, 2 when an input is unusable."
    )]
    SimulateCut(SimulateCutArgs),
    /// Contour error of a program from a trace of the machine's axes (Yu and Chen 2025, docs/model.md).
    #[command(
        long_about = "Contour error of a five-axis program from a measured trace (Yu and Chen 2025, docs/model.md). \
The program is the reference path, followed on the nominal machine as the controller \
interpolates it; the trace holds the axis positions the machine reached (time, X, Y, Z, A, C, \
... in mm and degrees, columns named by the machine file's axes, optional commanded \
positions X_cmd, ...). For every reference point: the tool-tip contour error (the shortest \
distance to the actual path) and the tool-axis contour error (the angle between the tool \
directions there), both in the workpiece frame. See docs/contour.md.",
        after_help = "Example:\n  nccomp contour -m fixtures/ac_trunnion.machine.toml fixtures/s_shape.nc \\\n      --trace fixtures/s_shape.trace.csv -o points.csv --plot contour.svg\n\n\
Exit status: 0 on success, 2 when an input is unusable (the message names file:line:column). \
Outputs are written only on success, and atomically."
    )]
    Contour(ContourArgs),
}

/// Run the command `cli` names and print its error, if any: the process's exit code.
///
/// With standard output or standard error closed (`>&-`) nothing is done: what nccomp
/// writes there would be lost without a word. A panic (a bug) is an error like any other,
/// exit code 2, and a command's temporary files are removed as it unwinds.
pub fn run(cli: Cli) -> ExitCode {
    if Std::Err.is_closed() {
        return ExitCode::from(EXIT_BAD_INPUT);
    }
    let result = if Std::Out.is_closed() {
        Err(crate::Error::Usage(
            "standard output is closed (`>&-`): nccomp writes programs and reports there; \
             expected it open (redirect it to /dev/null to discard what goes there)"
                .into(),
        ))
    } else {
        files::ignore_file_size_signal();
        std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| dispatch(cli))).unwrap_or_else(
            |panic| {
                Err(crate::Error::Usage(format!(
                    "nccomp failed ({}): an internal error, please report it with the inputs",
                    panic_message(&*panic)
                )))
            },
        )
    };
    match result {
        Ok(status) => ExitCode::from(status.exit_code()),
        Err(e) => {
            // Nothing is left to tell if standard error itself cannot be written.
            let _ = Std::Err
                .write(format!("{}\n", e.render_styled(use_color(&std::io::stderr()))).as_bytes());
            ExitCode::from(EXIT_BAD_INPUT)
        }
    }
}

fn dispatch(cli: Cli) -> crate::Result<Status> {
    match cli.command {
        Command::Compensate(args) => compensate::compensate(&args),
        Command::Check(args) => check::check(&args),
        Command::Verify(args) => verify::verify(&args),
        Command::Sensitivity(args) => budget::sensitivity(&args).map(|()| Status::Clean),
        Command::Tolerance(args) => budget::tolerance(&args).map(|()| Status::Clean),
        Command::Probe(args) => probe::probe(&args).map(|()| Status::Clean),
        Command::Report(args) => report::report(&args).map(|()| Status::Clean),
        Command::Errors(ErrorsCommand::Convert(args)) => {
            errors::convert(&args).map(|()| Status::Clean)
        }
        Command::Identify(args) => identify::identify(&args).map(|()| Status::Clean),
        Command::SimulateCut(args) => identify::simulate_cut(&args).map(|()| Status::Clean),
        Command::Contour(args) => contour::contour(&args).map(|()| Status::Clean),
    }
}
