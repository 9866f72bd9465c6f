//! The `nccomp` command: a thin layer over the library. Errors are printed once, here.

use clap::{Parser, Subcommand};
use nccomp::compensate::{Compensator, Options};
use nccomp::model::{error_file, machine_file};
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
    /// Split G1 moves whose compensated path strays more than this (mm) from the nominal
    /// path between block ends, by inserting blocks (off by default: one block out for
    /// every block in).
    #[arg(long, value_name = "MM")]
    tolerance: Option<f64>,
    /// With --tolerance: the tool direction's tolerance along the path, in µrad.
    #[arg(
        long,
        value_name = "URAD",
        default_value_t = 10.0,
        requires = "tolerance"
    )]
    angular_tolerance: f64,
    /// Print no summary.
    #[arg(long, short = 'q')]
    quiet: bool,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Compensate(args) => compensate(&args),
        Command::Probe(args) => probe(&args),
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
        path: args
            .tolerance
            .map(|mm| nccomp::kinematics::path::PathTolerance {
                position: mm,
                direction: args.angular_tolerance * 1e-6,
                ..Default::default()
            }),
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
