//! The `nccomp` command: a thin layer over the library. Errors are printed once, here.

use clap::{Parser, Subcommand};
use nccomp::budget::study::{self, StudyOptions};
use nccomp::budget::{self, Poses, Probe, Term, budget_file, ranking, report, tolerance};
use nccomp::check::{Checker, Status, Thresholds};
use nccomp::compensate::{Compensator, Options};
use nccomp::diag::use_color;
use nccomp::kinematics::Kinematics;
use nccomp::model::{ErrorModel, error_file, machine_file};
use std::io::{Read, Seek, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

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
struct Cli {
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
    /// Parameter study and key errors: how much each error term moves the tool tip, and
    /// which terms matter most for the error in one direction (paper 002).
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
    /// Tolerance design: the cost–quality model of paper 002 solved for the tolerances of
    /// the key errors within their bounds.
    #[command(
        after_help = "Example:\n  nccomp tolerance -m fixtures/grinder.machine.toml -b fixtures/grinder.budget.toml\n\n\
The key errors, their bounds and cost curves and the model's constants come from the budget \
file's [tolerance] table. See docs/budget.md.\n\n\
Exit status: 0 on success, 2 when an input file or option is unusable."
    )]
    Tolerance(ToleranceArgs),
    /// Compensate a touch probe's pre-travel: a probing speed per direction (paper 001).
    #[command(
        long_about = "Compensate a touch-trigger probe's systematic error by its probing speed \
(paper 001). Pre-travel is w = wT(α, β) + v·τ; choosing the speed per direction as \
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
    /// Write an HTML report on a program: predicted errors before and after compensation,
    /// the correction per axis, and maps of the machine's volumetric error.
    #[command(
        after_help = "Example:\n  nccomp report --machine fixtures/ac_trunnion.machine.toml \\\n      --errors fixtures/ac_trunnion.errors.toml fixtures/feature_workpiece.nc \\\n      --at A=0,C=0 --at A=-90,C=90 -o report.html\n\n\
One self-contained HTML file (inline SVG, no external resources). See docs/report.md.\n\n\
Exit status: 0 when the report was written, 2 when an input is unusable or a block cannot be \
compensated. The file is written only on success, and atomically."
    )]
    Report(ReportArgs),
    /// Error files: convert calibration files from the field (ISG CSV, Etalon) into nccomp's.
    #[command(subcommand)]
    Errors(ErrorsCommand),
    /// Identify the errors from a cut feature workpiece measured on the machine and on a
    /// CMM, and separate quasi-static from dynamic errors (paper 000).
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
    /// Contour error of a program from a trace of the machine's axes (paper 003).
    #[command(
        long_about = "Contour error of a five-axis program from a measured trace (paper 003). \
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

#[derive(clap::Args)]
struct ContourArgs {
    /// Machine file (TOML).
    #[arg(long, short = 'm', value_name = "MACHINE.toml")]
    machine: PathBuf,
    /// The NC program the trace was recorded with.
    #[arg(value_name = "PROGRAM")]
    program: PathBuf,
    /// The trace (CSV: time, one column per axis, optional <axis>_cmd columns).
    #[arg(long, short = 't', value_name = "TRACE.csv")]
    trace: PathBuf,
    /// Write the error at every reference point as CSV (`-`: standard output, the
    /// summary then goes to standard error).
    #[arg(long, short = 'o', value_name = "POINTS.csv")]
    output: Option<PathBuf>,
    /// Write an SVG plot of both errors along the path.
    #[arg(long, value_name = "FILE.svg")]
    plot: Option<PathBuf>,
    /// Sample the program every this many mm of tool tip travel (default: as densely as
    /// the trace, the median distance between its samples).
    #[arg(long, value_name = "MM")]
    step: Option<f64>,
    /// Margin of the search window along the actual path, mm (default: the step).
    #[arg(long, value_name = "MM")]
    window: Option<f64>,
    /// How close (mm) the trace must come to where the program starts (and restarts
    /// after G28/G53) to be taken as its trace.
    #[arg(long, value_name = "MM", default_value_t = 1.0)]
    capture: f64,
    /// Report points on rapid (G0) moves too.
    #[arg(long)]
    rapids: bool,
    /// Tool chain on machines with several.
    #[arg(long, value_name = "NAME")]
    tool_chain: Option<String>,
    /// Print no summary.
    #[arg(long, short = 'q')]
    quiet: bool,
}

#[derive(clap::Args)]
struct ReportArgs {
    /// Machine file (TOML).
    #[arg(long, short = 'm', value_name = "MACHINE.toml")]
    machine: PathBuf,
    /// Error file (TOML).
    #[arg(long, short = 'e', value_name = "ERRORS.toml")]
    errors: PathBuf,
    /// The NC program.
    #[arg(value_name = "PROGRAM")]
    input: PathBuf,
    /// Where to write the HTML report.
    #[arg(long, short = 'o', value_name = "REPORT.html")]
    output: PathBuf,
    /// Axis values of a volumetric map, e.g. A=30,C=90 (axes left out are 0; give the
    /// third linear axis to draw one level instead of three). Repeat for more maps.
    #[arg(long, value_name = "POSE")]
    at: Vec<String>,
    /// Grid points per linear axis of a map.
    #[arg(long, value_name = "N", default_value_t = 15)]
    grid: usize,
    /// Tool chain to use on machines with several.
    #[arg(long, value_name = "NAME")]
    tool_chain: Option<String>,
    /// Axes that keep their programmed values, comma-separated.
    #[arg(long, value_name = "AXES", value_delimiter = ',')]
    hold: Vec<String>,
}

#[derive(Subcommand)]
enum ErrorsCommand {
    /// Convert a Beckhoff/ISG `ISG_CSV` table or an Etalon exchange file into an error file.
    #[command(
        after_help = "Example:\n  nccomp errors convert volcomp.csv -o errors.toml\n  \
nccomp errors convert laser.txt --from etalon --machine m.toml -o errors.toml\n\n\
Names are mapped onto ISO 230 names as nccomp writes them (X0B is EX0B), values kept in the \
file's units (mm, rad), signs unchanged unless --reverse. See docs/import.md.\n\n\
Exit status: 0 when the file was converted, 2 when the input is unusable (the message names \
file:line:column)."
    )]
    Convert(ConvertArgs),
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum FieldFormat {
    /// Beckhoff/ISG volumetric compensation table.
    IsgCsv,
    /// Etalon exchange format ("Vendor" variant).
    Etalon,
}

#[derive(clap::Args)]
struct ConvertArgs {
    /// The calibration file.
    #[arg(value_name = "IN")]
    input: PathBuf,
    /// Its format (detected from the content by default).
    #[arg(long, value_enum)]
    from: Option<FieldFormat>,
    /// Check the names against this machine's axes (by default: X, Y, Z, A, B, C).
    #[arg(long, short = 'm', value_name = "MACHINE.toml")]
    machine: Option<PathBuf>,
    /// Axes whose error motions change sign, comma-separated (see docs/import.md).
    #[arg(long, value_name = "AXES", value_delimiter = ',')]
    reverse: Vec<String>,
    /// Where to write the error file; standard output when left out or `-`.
    #[arg(long, short = 'o', value_name = "ERRORS.toml")]
    output: Option<PathBuf>,
}

/// Inputs the identification commands share.
#[derive(clap::Args)]
struct WorkpieceArgs {
    /// Machine file (TOML).
    #[arg(long, short = 'm', value_name = "MACHINE.toml")]
    machine: PathBuf,
    /// Measurement plan (TOML): the points, their features and the terms to identify.
    #[arg(long, value_name = "PLAN.toml")]
    plan: PathBuf,
    /// The NC program that cut the workpiece.
    #[arg(long, value_name = "PROGRAM.nc")]
    program: PathBuf,
}

#[derive(clap::Args)]
struct IdentifyArgs {
    #[command(flatten)]
    work: WorkpieceArgs,
    /// The points the machine's probe measured (CSV: feature,id,x,y,z).
    #[arg(long, value_name = "A.csv")]
    on_machine: PathBuf,
    /// The points the CMM measured (CSV: feature,id,x,y,z).
    #[arg(long, value_name = "B.csv")]
    cmm: PathBuf,
    /// Which errors go into the error file.
    #[arg(long, value_enum, default_value = "quasi-static")]
    part: nccomp::identify::separate::Part,
    /// Where to write the error file (left out: only the table is printed).
    #[arg(long, short = 'o', value_name = "ERRORS.toml")]
    output: Option<PathBuf>,
}

#[derive(clap::Args)]
struct SimulateCutArgs {
    #[command(flatten)]
    work: WorkpieceArgs,
    /// The machine's quasi-static errors (error file).
    #[arg(long, short = 'e', value_name = "ERRORS.toml")]
    errors: PathBuf,
    /// Errors that act only while cutting (error file).
    #[arg(long, value_name = "ERRORS.toml")]
    dynamic: Option<PathBuf>,
    /// Measurement noise, standard deviation per coordinate (µm).
    #[arg(
        long,
        value_name = "UM",
        default_value_t = 0.5,
        allow_negative_numbers = true
    )]
    noise: f64,
    /// Seed of the noise.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Where to write the on-machine probe's points (CSV).
    #[arg(long, value_name = "A.csv")]
    on_machine: PathBuf,
    /// Where to write the CMM's points (CSV).
    #[arg(long, value_name = "B.csv")]
    cmm: PathBuf,
}

/// Output formats of the budget commands.
#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum Format {
    Human,
    Csv,
    Json,
}

/// Where and how the budget commands look at the machine.
#[derive(clap::Args)]
struct BudgetCommon {
    /// Machine file (TOML).
    #[arg(long, short = 'm', value_name = "MACHINE.toml")]
    machine: PathBuf,
    /// Evaluate at this pose (axis values, e.g. X=50,Y=45,Z=5; axes left out are 0).
    /// Repeat for several poses (worst case / pooled over them). Overrides the budget file.
    #[arg(long, value_name = "POSE")]
    at: Vec<String>,
    /// Evaluate on a grid of N points per axis over its travel (default 3, or the budget
    /// file's [poses]).
    #[arg(long, value_name = "N", conflicts_with = "at")]
    grid: Option<usize>,
    /// The direction of the error that matters, in the workpiece frame, e.g. 0,0,1 (the
    /// budget file's `direction` by default, else Z).
    #[arg(
        long,
        value_name = "X,Y,Z",
        value_delimiter = ',',
        allow_hyphen_values = true
    )]
    direction: Vec<f64>,
    /// Tool chain on machines with several.
    #[arg(long, value_name = "NAME")]
    tool_chain: Option<String>,
    /// Active tool length in mm (default: the budget file's, else the machine's reference
    /// tool).
    #[arg(long, value_name = "MM")]
    tool_length: Option<f64>,
    /// Output format.
    #[arg(long, value_enum, default_value = "human")]
    format: Format,
}

#[derive(clap::Args)]
struct SensitivityArgs {
    #[command(flatten)]
    common: BudgetCommon,
    /// Budget file (TOML) with the ranges of the terms to rank.
    #[arg(long, short = 'b', value_name = "BUDGET.toml")]
    budget: Option<PathBuf>,
    /// Terms of the parameter study, comma-separated (default: every error motion,
    /// rotary-axis location errors and one squareness per pair of linear axes).
    #[arg(long, value_name = "TERMS", value_delimiter = ',')]
    terms: Vec<String>,
    /// The unit of length terms in the study, µm.
    #[arg(long, value_name = "UM", default_value_t = 1.0)]
    unit_length: f64,
    /// The unit of angular terms in the study, µrad.
    #[arg(long, value_name = "URAD", default_value_t = 10.0)]
    unit_angle: f64,
    /// Sobol base sample size (overrides the budget file).
    #[arg(long, value_name = "N")]
    samples: Option<usize>,
    /// Seed of the Sobol sample (overrides the budget file).
    #[arg(long, value_name = "SEED")]
    seed: Option<u64>,
    /// Write an SVG bar chart of the ranking to this file (needs --budget).
    #[arg(long, value_name = "FILE.svg")]
    svg: Option<PathBuf>,
}

#[derive(clap::Args)]
struct ToleranceArgs {
    #[command(flatten)]
    common: BudgetCommon,
    /// Budget file (TOML) with the [tolerance] table.
    #[arg(long, short = 'b', value_name = "BUDGET.toml")]
    budget: PathBuf,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum MapKindArg {
    /// Trigger radius about the best-fit centre (ring gauge, reference sphere).
    Radius,
    /// Pre-travel from the probe's rest position.
    PreTravel,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum SurfaceArg {
    /// Inside (ring gauge, bore): the radius grows with pre-travel.
    Inside,
    /// Outside (sphere, plug): the radius shrinks with pre-travel.
    Outside,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum FormatArg {
    /// A human-readable report.
    Table,
    /// The direction table as CSV (the summary goes to standard error).
    Csv,
}

#[derive(clap::Args)]
struct ProbeArgs {
    /// The probe's delay τ between trigger and latch, ms.
    #[arg(
        long,
        value_name = "MS",
        conflicts_with = "ring",
        allow_negative_numbers = true
    )]
    tau: Option<f64>,
    /// Ring-gauge data (CSV: speed, radius[, direction]) to fit τ from.
    #[arg(long, value_name = "RING.csv")]
    ring: Option<PathBuf>,
    /// The direction map (CSV: alpha, beta, radius, speed).
    #[arg(long, value_name = "MAP.csv")]
    map: Option<PathBuf>,
    /// What the map's radius column holds.
    #[arg(long, value_enum, default_value = "radius")]
    map_kind: MapKindArg,
    /// The kind of surface the map's radii were measured on (the ring-gauge data's kind
    /// is read from the sign of its slope).
    #[arg(long, value_enum, default_value = "inside")]
    surface: SurfaceArg,
    /// The lowest probing speed allowed, mm/min.
    #[arg(long, value_name = "MM/MIN", allow_negative_numbers = true)]
    min_feed: Option<f64>,
    /// The highest probing speed allowed, mm/min.
    #[arg(long, value_name = "MM/MIN", allow_negative_numbers = true)]
    max_feed: Option<f64>,
    /// The mean of the new speeds, mm/min (default: the mean of the map's speeds).
    #[arg(long, value_name = "MM/MIN", allow_negative_numbers = true)]
    mean_feed: Option<f64>,
    /// The step of the written speeds, mm/min.
    #[arg(
        long,
        value_name = "MM/MIN",
        default_value_t = 0.1,
        allow_negative_numbers = true
    )]
    feed_step: f64,
    /// The probe axis in program coordinates, from the stylus tip towards the spindle
    /// (default 0,0,1).
    #[arg(
        long,
        value_name = "X,Y,Z",
        allow_hyphen_values = true,
        conflicts_with = "machine"
    )]
    probe_axis: Option<String>,
    /// Machine file: the probe axis is the machine's tool direction at each probing move.
    #[arg(long, short = 'm', value_name = "MACHINE.toml")]
    machine: Option<PathBuf>,
    /// Tool chain to use on machines with several.
    #[arg(long, value_name = "NAME", requires = "machine")]
    tool_chain: Option<String>,
    /// The probing program to rewrite; `-` for standard input.
    #[arg(value_name = "PROGRAM")]
    input: Option<PathBuf>,
    /// Where to write the rewritten program; standard output when left out or `-`.
    #[arg(long, short = 'o', value_name = "OUTPUT", requires = "input")]
    output: Option<PathBuf>,
    /// Report format.
    #[arg(long, value_enum, default_value = "table")]
    format: FormatArg,
    /// Write an SVG polar plot of the map, measured and predicted.
    #[arg(long, value_name = "FILE.svg", requires = "map")]
    plot: Option<PathBuf>,
    /// Print no report.
    #[arg(long, short = 'q')]
    quiet: bool,
}

#[derive(clap::Args)]
struct CompensateArgs {
    #[command(flatten)]
    pass: PassArgs,
    /// The NC program to compensate; standard input when left out or `-`.
    #[arg(value_name = "INPUT")]
    input: Option<PathBuf>,
    /// Where to write the compensated program; standard output when left out or `-`.
    #[arg(long, short = 'o', value_name = "OUTPUT")]
    output: Option<PathBuf>,
    /// Write nothing; exit 1 with a diff when the --expected file is not byte for byte
    /// what nccomp writes now (a stale committed output), 0 when it is.
    #[arg(long, requires = "expected", conflicts_with = "output")]
    check: bool,
    /// With --check: the committed compensated program to compare.
    #[arg(long, value_name = "OUTPUT", requires = "check")]
    expected: Option<PathBuf>,
    /// Threads: 1 runs the pass alone; 2 adds a helper that solves blocks ahead on a
    /// second core. The output is the same either way.
    #[arg(long, value_name = "N", default_value_t = 2, value_parser = clap::value_parser!(u64).range(1..=2))]
    threads: u64,
    /// Print no summary.
    #[arg(long, short = 'q')]
    quiet: bool,
}

/// The machine, its errors and the options of the compensation pass (`compensate` and
/// `check` share them, so a check predicts what compensation will do).
#[derive(clap::Args)]
struct PassArgs {
    /// Machine file (TOML): axes, chains, pivot points, travels, tool lengths.
    #[arg(long, short = 'm', value_name = "MACHINE.toml")]
    machine: PathBuf,
    /// Error file (TOML): the machine's measured errors (a calibration).
    #[arg(long, short = 'e', value_name = "ERRORS.toml")]
    errors: PathBuf,
    /// Tool chain the program starts in on machines with several (e.g. `upper` or `lower`
    /// turret); the machine file's first by default. T words switch chains where the
    /// machine file lists each chain's `tools`.
    #[arg(long, value_name = "NAME")]
    tool_chain: Option<String>,
    /// Axes that keep their programmed values, comma-separated (e.g. `C` for a spindle
    /// that turns, on a machine file without a [lathe] table). Other axes take up the
    /// correction.
    #[arg(long, value_name = "AXES", value_delimiter = ',')]
    hold: Vec<String>,
    /// Write blocks whose compensated values leave the travel limits anyway, with a
    /// warning (by default such a block is an error).
    #[arg(long)]
    allow_limit_violations: bool,
    /// Split G1 moves whose compensated path strays more than this (mm) from the nominal
    /// path between block ends, by inserting blocks; `off` keeps one block out for every
    /// block in (arcs aside).
    #[arg(long, value_name = "MM|off", default_value = "0.001", value_parser = path_tolerance)]
    tolerance: PathLimit,
    /// The tool direction's tolerance along the path, in µrad.
    #[arg(long, value_name = "URAD", default_value_t = 10.0)]
    angular_tolerance: f64,
}

#[derive(clap::Args)]
struct CheckArgs {
    #[command(flatten)]
    pass: PassArgs,
    /// NC programs: paths or glob patterns (quoted, expanded by nccomp: `'progs/**/*.nc'`).
    #[arg(value_name = "PROGRAM", required = true)]
    programs: Vec<String>,
    /// Largest predicted tip error after compensation, mm.
    #[arg(long, value_name = "MM", default_value_t = 0.010)]
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
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum CheckFormat {
    Human,
    Json,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Compensate(args) => compensate(&args),
        Command::Check(args) => check(&args),
        Command::Sensitivity(args) => sensitivity(&args).map(|()| Status::Clean),
        Command::Tolerance(args) => tolerance(&args).map(|()| Status::Clean),
        Command::Probe(args) => probe(&args).map(|()| Status::Clean),
        Command::Report(args) => report(&args).map(|()| Status::Clean),
        Command::Errors(ErrorsCommand::Convert(args)) => convert(&args).map(|()| Status::Clean),
        Command::Identify(args) => identify(&args).map(|()| Status::Clean),
        Command::SimulateCut(args) => simulate_cut(&args).map(|()| Status::Clean),
        Command::Contour(args) => contour(&args).map(|()| Status::Clean),
    };
    match result {
        Ok(status) => ExitCode::from(status.exit_code()),
        Err(e) => {
            eprintln!("{}", e.render_styled(use_color(&std::io::stderr())));
            ExitCode::from(EXIT_BAD_INPUT)
        }
    }
}

/// `--tolerance`: a distance in mm, or `off`.
#[derive(Debug, Clone, Copy)]
struct PathLimit(Option<f64>);

fn path_tolerance(text: &str) -> Result<PathLimit, String> {
    if text.eq_ignore_ascii_case("off") {
        return Ok(PathLimit(None));
    }
    match text.parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(PathLimit(Some(v))),
        _ => Err(format!(
            "expected a positive distance in mm (e.g. 0.001) or `off`, found `{text}`"
        )),
    }
}

fn is_std(path: &Option<PathBuf>) -> bool {
    path.as_deref().is_none_or(|p| p == Path::new("-"))
}

fn compensate(args: &CompensateArgs) -> nccomp::Result<Status> {
    let machine = machine_file::load(&args.pass.machine)?;
    let errors = error_file::load(&args.pass.errors, &machine)?;
    let options = Options {
        threads: args.threads as usize,
        ..args.pass.options()?
    };
    let comp = Compensator::new(&machine, &errors, options)?;
    // The program streams through in bounded memory, to a temporary file that takes the
    // output's place only when every block has been compensated.
    let (input, name): (Box<dyn Read>, String) = if is_std(&args.input) {
        use std::io::IsTerminal;
        if std::io::stdin().is_terminal() {
            eprintln!(
                "nccomp: reading the program from standard input (end with Ctrl-D; see --help)"
            );
        }
        (Box::new(std::io::stdin().lock()), "<stdin>".to_string())
    } else {
        let path = args.input.as_deref().unwrap_or(Path::new("-"));
        let file = std::fs::File::open(path).map_err(|e| nccomp::Error::io(path, e))?;
        (Box::new(file), path.display().to_string())
    };
    let mut status = Status::Clean;
    let summary = match (&args.expected, &args.output) {
        (Some(expected), _) => {
            let mut out = Vec::new();
            let summary = comp.run_stream(input, &name, &mut out, "<memory>")?;
            let (committed, expected_name) = read_file(expected)?;
            if let Some(diff) = nccomp::check::stale::compare(&expected_name, &committed, &out) {
                print(&format!(
                    "{diff}to update it, run the same command with `-o {expected_name}` in place of `--check --expected {expected_name}`\n"
                ))?;
                status = Status::Findings;
            }
            summary
        }
        (None, Some(path)) if !is_std(&args.output) => write_atomically_with(path, |file| {
            comp.run_stream(input, &name, file, &path.display().to_string())
        })?,
        _ => {
            // Standard output gets nothing from a failed run either: the program is
            // spooled to an unnamed temporary file and copied out at the end.
            let spool_error = |e| nccomp::Error::io(Path::new("<temporary file>"), e);
            let mut spool = tempfile::tempfile().map_err(spool_error)?;
            let summary = comp.run_stream(input, &name, &mut spool, "<temporary file>")?;
            let mut stdout = std::io::stdout().lock();
            spool
                .seek(std::io::SeekFrom::Start(0))
                .map_err(spool_error)?;
            std::io::copy(&mut spool, &mut stdout)
                .and_then(|_| stdout.flush())
                .map_err(|e| nccomp::Error::io(Path::new("<stdout>"), e))?;
            summary
        }
    };
    if !args.quiet {
        eprintln!("{name}: {summary}");
    }
    Ok(status)
}

impl PassArgs {
    fn options(&self) -> nccomp::Result<Options> {
        let v = self.angular_tolerance;
        if !(v.is_finite() && v > 0.0) {
            return Err(nccomp::Error::Usage(format!(
                "--angular-tolerance {v}: expected a positive number of µrad"
            )));
        }
        Ok(Options {
            tool_chain: self.tool_chain.clone(),
            allow_limit_violations: self.allow_limit_violations,
            hold: self.hold.clone(),
            path: self
                .tolerance
                .0
                .map(|mm| nccomp::kinematics::path::PathTolerance {
                    position: mm,
                    direction: v * 1e-6,
                    ..Default::default()
                }),
            ..Options::default()
        })
    }
}

fn check(args: &CheckArgs) -> nccomp::Result<Status> {
    let thresholds = Thresholds::new(args.max_error, args.max_angle)?;
    let machine = machine_file::load(&args.pass.machine)?;
    let errors = error_file::load(&args.pass.errors, &machine)?;
    let checker = Checker::new(&machine, &errors, args.pass.options()?, thresholds)?;
    let paths = nccomp::check::expand(&args.programs)?;
    let bar = nccomp::check::progress_bar(paths.len());
    let programs = checker.files(&paths, &|| bar.inc(1));
    bar.finish_and_clear();
    let run = nccomp::check::Run {
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

fn report(args: &ReportArgs) -> nccomp::Result<()> {
    use nccomp::report;
    let machine = machine_file::load(&args.machine)?;
    let errors = error_file::load(&args.errors, &machine)?;
    let (src, name) = read_file(&args.input)?;
    let options = report::Options {
        compensate: Options {
            tool_chain: args.tool_chain.clone(),
            hold: args.hold.clone(),
            ..Options::default()
        },
        at: args.at.clone(),
        grid: args.grid,
    };
    let names = report::Names {
        program: name,
        machine: args.machine.display().to_string(),
        errors: args.errors.display().to_string(),
    };
    let r = report::build(&machine, &errors, &src, names, &options)?;
    let html = r.html().map_err(nccomp::Error::Usage)?;
    write_atomically(&args.output, html.as_bytes())
}

fn convert(args: &ConvertArgs) -> nccomp::Result<()> {
    use nccomp::import::{self, Format};
    let (bytes, name) = read_file(&args.input)?;
    let machine = args
        .machine
        .as_deref()
        .map(machine_file::load)
        .transpose()?;
    let options = import::Options {
        format: args.from.map(|f| match f {
            FieldFormat::IsgCsv => Format::IsgCsv,
            FieldFormat::Etalon => Format::Etalon,
        }),
        reverse: args.reverse.clone(),
    };
    let text = String::from_utf8_lossy(&bytes);
    let converted = import::convert(&text, &name, machine.as_ref(), &options)?;
    match &args.output {
        Some(path) if !is_std(&args.output) => write_atomically(path, converted.toml.as_bytes())?,
        _ => print(&converted.toml)?,
    }
    for note in &converted.notes {
        eprintln!("note: {note}");
    }
    eprintln!("{}", converted.summary);
    Ok(())
}

fn contour(args: &ContourArgs) -> nccomp::Result<()> {
    use nccomp::contour::{self, plot, report};
    for (name, v) in [
        ("--step", args.step),
        ("--window", args.window),
        ("--capture", Some(args.capture)),
    ] {
        if let Some(v) = v
            && !(v > 0.0 && v.is_finite())
        {
            return Err(nccomp::Error::Usage(format!(
                "{name} {v}: expected a positive length in mm"
            )));
        }
    }
    let machine = machine_file::load(&args.machine)?;
    let (program, program_name) = read_file(&args.program)?;
    let (trace, trace_name) = read_file(&args.trace)?;
    let options = contour::Options {
        tool_chain: args.tool_chain.clone(),
        step: args.step,
        window: args.window,
        capture: args.capture,
        rapids: args.rapids,
        ..contour::Options::default()
    };
    let a = contour::analyse(
        &machine,
        (&program_name, &program),
        (&trace_name, &trace),
        &options,
    )?;
    let machine_name = machine
        .name
        .clone()
        .unwrap_or(args.machine.display().to_string());
    if let Some(path) = &args.plot {
        let title = format!("Contour error of {program_name} on {machine_name} ({trace_name})");
        let svg = plot::svg(&a, &title).map_err(nccomp::Error::Usage)?;
        write_atomically(path, svg.as_bytes())?;
    }
    let csv_to_stdout = args.output.is_some() && is_std(&args.output);
    if let Some(path) = &args.output {
        let csv = report::points_csv(&a, args.rapids);
        if csv_to_stdout {
            print(&csv)?;
        } else {
            write_atomically(path, csv.as_bytes())?;
        }
    }
    if !args.quiet {
        let text = report::summary_text(&a, &program_name, &trace_name, &machine_name);
        if csv_to_stdout {
            eprint!("{text}");
        } else {
            print(&text)?;
        }
    }
    Ok(())
}

fn read_file(path: &Path) -> nccomp::Result<(Vec<u8>, String)> {
    let buf = std::fs::read(path).map_err(|e| nccomp::Error::io(path, e))?;
    Ok((buf, path.display().to_string()))
}

fn probe(args: &ProbeArgs) -> nccomp::Result<()> {
    use nccomp::probe::report::{self, Tau};
    use nccomp::probe::{self as pr, FrameSource, ProbeFrame};
    let usage = |m: String| nccomp::Error::Usage(m);
    let surface = match args.surface {
        SurfaceArg::Inside => pr::Surface::Inside,
        SurfaceArg::Outside => pr::Surface::Outside,
    };
    let kind = match args.map_kind {
        MapKindArg::Radius => pr::MapKind::Radius,
        MapKindArg::PreTravel => pr::MapKind::PreTravel,
    };
    if !nccomp::probe::positive(args.feed_step) {
        return Err(usage(format!(
            "--feed-step {}: the step must be positive",
            args.feed_step
        )));
    }
    for (name, v) in [
        ("--min-feed", args.min_feed),
        ("--max-feed", args.max_feed),
        ("--mean-feed", args.mean_feed),
        ("--tau", args.tau),
    ] {
        if let Some(v) = v
            && !(v > 0.0 && v.is_finite())
        {
            return Err(usage(format!("{name} {v}: expected a positive number")));
        }
    }
    if let (Some(lo), Some(hi)) = (args.min_feed, args.max_feed)
        && lo > hi
    {
        return Err(usage(format!("--min-feed {lo} is above --max-feed {hi}")));
    }
    if args.input.is_some() && args.map.is_none() {
        return Err(usage(
            "a program needs a direction map to take its speeds from (--map)".into(),
        ));
    }
    if args.map.is_none() && args.ring.is_none() {
        return Err(usage(
            "nothing to do: give --ring to fit τ, or --map (with --tau or --ring) to compute speeds"
                .into(),
        ));
    }
    // τ.
    let tau = match (&args.ring, args.tau) {
        (Some(path), _) => {
            let (text, name) = read_file(path)?;
            let fit = pr::delay::delay_from_csv(&name, &text, None)?;
            Some(Tau::Fitted { path: name, fit })
        }
        (None, Some(t)) => Some(Tau::Given(t)),
        (None, None) => None,
    };
    let mut text_report = String::new();
    if let Some(tau) = &tau {
        text_report += &report::tau_lines(tau);
    }
    let mut csv_report = None;
    let mut program_out: Option<Vec<u8>> = None;
    let mut svg = None;
    if let Some(map_path) = &args.map {
        let Some(tau) = &tau else {
            return Err(usage(
                "the speeds need the probe's delay: give --tau MS or --ring RING.csv".into(),
            ));
        };
        let (text, map_name) = read_file(map_path)?;
        let map = pr::map::read_map(&map_name, &text)?;
        let opts = pr::SpeedOptions {
            tau_ms: tau.ms(),
            kind,
            surface,
            mean_feed: args.mean_feed,
            min_feed: args.min_feed,
            max_feed: args.max_feed,
            feed_step: args.feed_step,
            ..pr::SpeedOptions::default()
        };
        let plan = pr::speeds::equalise(&map, &opts)?;
        text_report += &report::plan_lines(&map_name, &map, &plan, kind, tau.ms());
        text_report.push('\n');
        text_report += &report::direction_table(&map, &plan, kind);
        csv_report = Some(report::direction_csv(&map, &plan));
        if args.plot.is_some() {
            let what = match kind {
                pr::MapKind::Radius => "trigger radius",
                pr::MapKind::PreTravel => "pre-travel",
            };
            svg = Some(pr::plot::polar_svg(&map, &plan, what).map_err(usage)?);
        }
        if args.input.is_some() {
            let (src, name) = if is_std(&args.input) {
                let mut buf = Vec::new();
                std::io::stdin()
                    .read_to_end(&mut buf)
                    .map_err(|e| nccomp::Error::io(Path::new("<stdin>"), e))?;
                (buf, "<stdin>".to_string())
            } else {
                read_file(args.input.as_deref().unwrap_or(Path::new("-")))?
            };
            let machine = args
                .machine
                .as_deref()
                .map(machine_file::load)
                .transpose()?;
            let frame = match (&machine, &args.probe_axis) {
                (Some(m), _) => {
                    let chain = match &args.tool_chain {
                        None => 0,
                        Some(n) => m.tool_chain(n).ok_or_else(|| {
                            usage(format!(
                                "--tool-chain {n}: the machine file has no such tool chain"
                            ))
                        })?,
                    };
                    FrameSource::Machine { machine: m, chain }
                }
                (None, Some(text)) => {
                    let expected = || {
                        usage(format!(
                            "--probe-axis {text}: expected three numbers X,Y,Z (e.g. 0,0,1)"
                        ))
                    };
                    let v: Vec<f64> = text
                        .split(',')
                        .map(|x| x.trim().parse::<f64>())
                        .collect::<Result<_, _>>()
                        .map_err(|_| expected())?;
                    let [x, y, z] = v[..] else {
                        return Err(expected());
                    };
                    FrameSource::Frame(
                        ProbeFrame::from_axis(&nalgebra::Vector3::new(x, y, z)).ok_or_else(
                            || usage(format!("--probe-axis {text}: the axis must not be zero")),
                        )?,
                    )
                }
                (None, None) => FrameSource::Frame(ProbeFrame::vertical()),
            };
            let speeds = plan.speeds.clone();
            let speed_at = |d: pr::Direction| map.interpolate(d, &speeds);
            let mut out = Vec::with_capacity(src.len() + 64);
            let summary = pr::rewrite::rewrite(
                &src,
                &name,
                &speed_at,
                &pr::RewriteOptions {
                    frame,
                    feed_step: args.feed_step,
                },
                &mut out,
            )?;
            text_report.push('\n');
            text_report += &report::program_lines(&name, &summary);
            if !summary.moves.is_empty() {
                text_report.push('\n');
                text_report += &report::moves_table(&summary);
            }
            program_out = Some(out);
        }
    }
    // Outputs: the plot and the program, each atomically; then the report.
    if let (Some(path), Some(svg)) = (&args.plot, &svg) {
        write_atomically(path, svg.as_bytes())?;
    }
    let program_to_stdout = program_out.is_some() && is_std(&args.output);
    if let Some(out) = &program_out {
        if program_to_stdout {
            let mut stdout = std::io::stdout().lock();
            stdout
                .write_all(out)
                .and_then(|()| stdout.flush())
                .map_err(|e| nccomp::Error::io(Path::new("<stdout>"), e))?;
        } else if let Some(path) = &args.output {
            write_atomically(path, out)?;
        }
    }
    if args.quiet {
        return Ok(());
    }
    let (main_text, side_text) = match (args.format, csv_report) {
        (FormatArg::Csv, Some(csv)) => (csv, Some(text_report)),
        _ => (text_report, None),
    };
    let print = |to_stderr: bool, s: &str| {
        if to_stderr {
            eprint!("{s}");
        } else {
            print!("{s}");
        }
    };
    print(program_to_stdout, &main_text);
    if let Some(side) = side_text {
        eprint!("{side}");
    }
    Ok(())
}

/// What the budget commands share: the machine, the budget file, the probe's settings.
struct Setup {
    machine: nccomp::model::Machine,
    budget: Option<budget_file::Budget>,
    chain: usize,
    active: Vec<usize>,
    length: f64,
    poses: Poses,
    direction: nalgebra::Vector3<f64>,
}

fn setup(common: &BudgetCommon, budget: Option<&Path>) -> nccomp::Result<Setup> {
    let usage = |m: String| nccomp::Error::Usage(m);
    let machine = machine_file::load(&common.machine)?;
    let budget = budget
        .map(|b| budget_file::load(b, &machine, common.tool_chain.as_deref()))
        .transpose()?;
    let chain = match (&common.tool_chain, &budget) {
        (_, Some(b)) => b.chain,
        (Some(name), None) => machine.tool_chain(name).ok_or_else(|| {
            let names: Vec<String> = machine.tool_chains.iter().map(|c| c.name.clone()).collect();
            usage(format!(
                "the machine has no tool chain `{name}`: expected {}",
                names.join(", ")
            ))
        })?,
        (None, None) => 0,
    };
    let active = Kinematics::new(&machine, &ErrorModel::zero(&machine), chain)
        .map_err(|e| usage(e.to_string()))?
        .axes()
        .to_vec();
    let length = common
        .tool_length
        .or(budget.as_ref().map(|b| b.tool_length))
        .unwrap_or(machine.tool.length);
    let poses = if !common.at.is_empty() {
        let list = common
            .at
            .iter()
            .map(|p| budget::parse_pose(&machine, &active, p).map_err(usage))
            .collect::<nccomp::Result<Vec<_>>>()?;
        Poses::At(list)
    } else if let Some(n) = common.grid {
        Poses::Grid(n)
    } else if let Some(b) = &budget {
        b.poses.clone()
    } else {
        Poses::Grid(3)
    };
    let direction = match common.direction.as_slice() {
        [] => budget
            .as_ref()
            .map_or(nalgebra::Vector3::z(), |b| b.ranking.direction),
        &[x, y, z] if (x * x + y * y + z * z) > 0.0 && (x + y + z).is_finite() => {
            nalgebra::Vector3::new(x, y, z).normalize()
        }
        d => {
            return Err(usage(format!(
                "--direction {}: expected three numbers X,Y,Z of a non-zero direction, such as \
                 0,0,1",
                d.iter()
                    .map(|v| v.to_string())
                    .collect::<Vec<_>>()
                    .join(",")
            )));
        }
    };
    Ok(Setup {
        machine,
        budget,
        chain,
        active,
        length,
        poses,
        direction,
    })
}

fn print(text: &str) -> nccomp::Result<()> {
    let mut stdout = std::io::stdout().lock();
    stdout
        .write_all(text.as_bytes())
        .and_then(|()| stdout.flush())
        .map_err(|e| nccomp::Error::io(Path::new("<stdout>"), e))
}

fn sensitivity(args: &SensitivityArgs) -> nccomp::Result<()> {
    let usage = |m: String| nccomp::Error::Usage(m);
    let s = setup(&args.common, args.budget.as_deref())?;
    for (name, v) in [
        ("--unit-length", args.unit_length),
        ("--unit-angle", args.unit_angle),
    ] {
        if !(v > 0.0 && v.is_finite()) {
            return Err(usage(format!("{name} {v}: expected a positive unit")));
        }
    }
    if args.svg.is_some() && s.budget.is_none() {
        return Err(usage(
            "--svg draws the ranking, which needs the ranges of a budget file (--budget)".into(),
        ));
    }
    let terms = if args.terms.is_empty() {
        budget::default_terms(&s.machine, &s.active)
    } else {
        args.terms
            .iter()
            .map(|t| Term::new(&s.machine, &s.active, t.trim()).map_err(usage))
            .collect::<nccomp::Result<Vec<_>>>()?
    };
    let probe = Probe::new(&s.machine, s.chain, s.length, &s.poses, terms)?;
    let options = StudyOptions {
        unit_length: args.unit_length * 1e-3,
        unit_angle: args.unit_angle * 1e-6,
    };
    let study = study::run(&probe, &options);

    let ranking = match &s.budget {
        Some(b) => {
            if b.ranges.is_empty() {
                return Err(usage(format!(
                    "{}: the budget file has no [ranges]: nothing to rank",
                    args.budget.as_deref().unwrap_or(Path::new("")).display()
                )));
            }
            let (terms, levels): (Vec<Term>, Vec<[f64; 3]>) = b.ranges.iter().cloned().unzip();
            let probe = Probe::new(&s.machine, s.chain, s.length, &s.poses, terms)?;
            let mut options = b.ranking.clone();
            options.direction = s.direction;
            if let Some(n) = args.samples {
                options.samples = n.max(2);
            }
            if let Some(seed) = args.seed {
                options.seed = seed;
            }
            Some(ranking::rank(&probe, &levels, &options))
        }
        None => None,
    };
    if let (Some(path), Some(r)) = (&args.svg, &ranking) {
        let name = s.machine.name.clone().unwrap_or_else(|| "machine".into());
        let svg = report::ranking_svg(r, &format!("Key errors of {name}"))
            .map_err(|m| usage(format!("cannot draw the ranking: {m}")))?;
        write_atomically(path, svg.as_bytes())?;
    }
    let text = match args.common.format {
        Format::Human => {
            let mut t = report::study_human(&study);
            if let Some(r) = &ranking {
                t.push('\n');
                t.push_str(&report::ranking_human(r));
            }
            t
        }
        Format::Csv => {
            let mut t = report::study_csv(&study);
            if let Some(r) = &ranking {
                t.push('\n');
                t.push_str(&report::ranking_csv(r));
            }
            t
        }
        Format::Json => report::Report {
            study: Some(&study),
            ranking: ranking.as_ref(),
            tolerance: None,
        }
        .json(),
    };
    print(&text)
}

fn tolerance(args: &ToleranceArgs) -> nccomp::Result<()> {
    let s = setup(&args.common, Some(&args.budget))?;
    let b = s.budget.as_ref().expect("a budget file was given");
    let Some(spec) = &b.tolerance else {
        return Err(nccomp::Error::Usage(format!(
            "{}: the budget file has no [tolerance] table: nothing to design (see docs/budget.md)",
            args.budget.display()
        )));
    };
    let (terms, tol): (Vec<Term>, Vec<_>) = spec.terms.iter().cloned().unzip();
    let probe = Probe::new(&s.machine, s.chain, s.length, &s.poses, terms)?;
    let mut options = spec.options.clone();
    options.direction = s.direction;
    let design = tolerance::design(&probe, &tol, &options);
    let text = match args.common.format {
        Format::Human => report::design_human(&design),
        Format::Csv => report::design_csv(&design),
        Format::Json => report::Report {
            tolerance: Some(&design),
            ..Default::default()
        }
        .json(),
    };
    print(&text)
}

fn identify(args: &IdentifyArgs) -> nccomp::Result<()> {
    use nccomp::identify::files::{self, Workpiece};
    let w = &args.work;
    let work = Workpiece::load(&w.machine, &w.plan, &w.program)?;
    let id = files::identify(&work, &args.on_machine, &args.cmm, args.part)?;
    if let Some(path) = &args.output {
        write_atomically(path, id.errors.as_bytes())?;
    }
    print(&id.table)
}

fn simulate_cut(args: &SimulateCutArgs) -> nccomp::Result<()> {
    use nccomp::identify::files::{self, Workpiece};
    let w = &args.work;
    let work = Workpiece::load(&w.machine, &w.plan, &w.program)?;
    let sim = files::simulate_cut(
        &work,
        &args.errors,
        args.dynamic.as_deref(),
        args.noise,
        args.seed,
    )?;
    write_atomically(&args.on_machine, sim.on_machine.as_bytes())?;
    write_atomically(&args.cmm, sim.cmm.as_bytes())?;
    print(&sim.summary)
}

/// Write `bytes` to `path` through a temporary file in the same directory and a rename, so
/// the path holds either the old content or the complete new one, never a part.
fn write_atomically(path: &Path, bytes: &[u8]) -> nccomp::Result<()> {
    write_atomically_with(path, |file| {
        file.write_all(bytes)
            .map_err(|e| nccomp::Error::io(path, e))
    })
}

/// Let `write` fill a temporary file beside `path` and rename it to `path` when `write`
/// succeeds: the path holds either the old content or the complete new one, never a part.
/// A failed run removes its temporary file. The file's name says what it is
/// (`.NAME.nccomp-PID-XXXXXX.tmp`), and one left by a run that was killed (its process is
/// gone) is removed by the next run writing the same file.
fn write_atomically_with<T>(
    path: &Path,
    write: impl FnOnce(&mut std::fs::File) -> nccomp::Result<T>,
) -> nccomp::Result<T> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let io = |e| nccomp::Error::io(path, e);
    if !dir.is_dir() {
        return Err(io(std::io::Error::new(
            std::io::ErrorKind::NotFound,
            format!(
                "cannot write the output: directory {} does not exist",
                dir.display()
            ),
        )));
    }
    let name = path
        .file_name()
        .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
    let prefix = format!(".{name}.nccomp-");
    remove_stale_temporaries(dir, &prefix);
    // tempfile's own error names the temporary path, which means nothing to the user.
    let mut tmp = tempfile::Builder::new()
        .prefix(&format!("{prefix}{}-", std::process::id()))
        .suffix(".tmp")
        .tempfile_in(dir)
        .map_err(|e| {
            io(std::io::Error::new(
                e.kind(),
                format!(
                    "cannot create the output file in {}: {}",
                    dir.display(),
                    e.kind()
                ),
            ))
        })?;
    let value = write(tmp.as_file_mut())?;
    // A temporary file is private (0600); the program should look like any other file the
    // user writes, or keep the permissions of the file it replaces.
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let permissions = match std::fs::metadata(path) {
            Ok(meta) => meta.permissions(),
            Err(_) => std::fs::Permissions::from_mode(0o644),
        };
        tmp.as_file().set_permissions(permissions).map_err(io)?;
    }
    tmp.as_file().sync_all().map_err(io)?;
    tmp.persist(path).map_err(|e| io(e.error))?;
    Ok(value)
}

/// Remove the temporary files `prefix PID-XXXXXX.tmp` in `dir` whose process no longer
/// runs: what a run killed before its rename left behind. Only where the process table
/// can be read (`/proc`); elsewhere they stay, to be deleted by hand.
fn remove_stale_temporaries(dir: &Path, prefix: &str) {
    let proc = Path::new("/proc");
    if !proc.join("self").exists() {
        return;
    }
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let file_name = entry.file_name();
        let Some(rest) = file_name
            .to_str()
            .and_then(|n| n.strip_prefix(prefix))
            .filter(|r| r.ends_with(".tmp"))
        else {
            continue;
        };
        let Some(pid) = rest.split('-').next().and_then(|p| p.parse::<u32>().ok()) else {
            continue;
        };
        if !proc.join(pid.to_string()).exists() {
            let _ = std::fs::remove_file(entry.path());
        }
    }
}
