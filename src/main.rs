//! The `nccomp` command: a thin layer over the library. Errors are printed once, here.

use clap::{Parser, Subcommand};
use nccomp::budget::study::{self, StudyOptions};
use nccomp::budget::{self, Poses, Probe, Term, budget_file, ranking, report, tolerance};
use nccomp::compensate::{Compensator, Options};
use nccomp::kinematics::Kinematics;
use nccomp::model::{ErrorModel, error_file, machine_file};
use std::io::{Read, Write};
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
Exit status: 0 when the program was compensated, 2 when an input file is unusable or a \
block cannot be compensated (the message names file:line:column). The output file is \
written only on success, and atomically: a failed run never leaves a half-written program."
    )]
    Compensate(CompensateArgs),
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

#[derive(clap::Args)]
struct CompensateArgs {
    /// Machine file (TOML): axes, chains, pivot points, travels, tool lengths.
    #[arg(long, short = 'm', value_name = "MACHINE.toml")]
    machine: PathBuf,
    /// Error file (TOML): the machine's measured errors (a calibration).
    #[arg(long, short = 'e', value_name = "ERRORS.toml")]
    errors: PathBuf,
    /// The NC program to compensate; standard input when left out or `-`.
    #[arg(value_name = "INPUT")]
    input: Option<PathBuf>,
    /// Where to write the compensated program; standard output when left out or `-`.
    #[arg(long, short = 'o', value_name = "OUTPUT")]
    output: Option<PathBuf>,
    /// Tool chain to use on machines with several (e.g. `upper` or `lower` turret); the
    /// machine file's first by default.
    #[arg(long, value_name = "NAME")]
    tool_chain: Option<String>,
    /// Axes that keep their programmed values, comma-separated (e.g. `C` for a lathe
    /// spindle that turns rather than positions). Other axes take up the correction.
    #[arg(long, value_name = "AXES", value_delimiter = ',')]
    hold: Vec<String>,
    /// Write blocks whose compensated values leave the travel limits anyway, with a
    /// warning (by default such a block is an error).
    #[arg(long)]
    allow_limit_violations: bool,
    /// Print no summary.
    #[arg(long, short = 'q')]
    quiet: bool,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Compensate(args) => compensate(&args),
        Command::Sensitivity(args) => sensitivity(&args),
        Command::Tolerance(args) => tolerance(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("{}", e.render());
            ExitCode::from(EXIT_BAD_INPUT)
        }
    }
}

fn is_std(path: &Option<PathBuf>) -> bool {
    path.as_deref().is_none_or(|p| p == Path::new("-"))
}

fn compensate(args: &CompensateArgs) -> nccomp::Result<()> {
    let machine = machine_file::load(&args.machine)?;
    let errors = error_file::load(&args.errors, &machine)?;
    let (src, name) = if is_std(&args.input) {
        use std::io::IsTerminal;
        if std::io::stdin().is_terminal() {
            eprintln!(
                "nccomp: reading the program from standard input (end with Ctrl-D; see --help)"
            );
        }
        let mut buf = Vec::new();
        std::io::stdin()
            .read_to_end(&mut buf)
            .map_err(|e| nccomp::Error::io(Path::new("<stdin>"), e))?;
        (buf, "<stdin>".to_string())
    } else {
        let path = args.input.as_deref().unwrap_or(Path::new("-"));
        let buf = std::fs::read(path).map_err(|e| nccomp::Error::io(path, e))?;
        (buf, path.display().to_string())
    };
    let options = Options {
        tool_chain: args.tool_chain.clone(),
        allow_limit_violations: args.allow_limit_violations,
        hold: args.hold.clone(),
        ..Options::default()
    };
    let comp = Compensator::new(&machine, &errors, options)?;
    let mut out = Vec::with_capacity(src.len() + src.len() / 8);
    let summary = comp.run(&src, &name, &mut out)?;
    match &args.output {
        Some(path) if !is_std(&args.output) => write_atomically(path, &out)?,
        _ => {
            let mut stdout = std::io::stdout().lock();
            stdout
                .write_all(&out)
                .and_then(|()| stdout.flush())
                .map_err(|e| nccomp::Error::io(Path::new("<stdout>"), e))?;
        }
    }
    if !args.quiet {
        eprintln!("{name}: {summary}");
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

/// Write `bytes` to `path` through a temporary file in the same directory and a rename, so
/// the path holds either the old content or the complete new one, never a part.
fn write_atomically(path: &Path, bytes: &[u8]) -> nccomp::Result<()> {
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
    // tempfile's own error names the temporary path, which means nothing to the user.
    let mut tmp = tempfile::Builder::new()
        .prefix(".nccomp-")
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
    tmp.write_all(bytes).map_err(io)?;
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
    Ok(())
}
