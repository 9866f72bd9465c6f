//! `nccomp probe`: probing speeds per direction, and the probing program rewritten with
//! them.

use super::files::{Std, destinations, is_std, read_file, write_all};
use crate::model::machine_file;
use std::io::Read;
use std::path::{Path, PathBuf};

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
pub(super) struct ProbeArgs {
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

pub(super) fn probe(args: &ProbeArgs) -> crate::Result<()> {
    use crate::probe::report::{self, Tau};
    use crate::probe::{self as pr, FrameSource, ProbeFrame};
    let usage = |m: String| crate::Error::Usage(m);
    let surface = match args.surface {
        SurfaceArg::Inside => pr::Surface::Inside,
        SurfaceArg::Outside => pr::Surface::Outside,
    };
    let kind = match args.map_kind {
        MapKindArg::Radius => pr::MapKind::Radius,
        MapKindArg::PreTravel => pr::MapKind::PreTravel,
    };
    if !crate::probe::positive(args.feed_step) {
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
    // The rewritten program goes to -o, or to standard output.
    let program_output = args
        .input
        .as_ref()
        .map(|_| args.output.as_deref().unwrap_or(Path::new("-")));
    let [plot_to, program_to] = destinations(
        &[
            ("the ring-gauge data", args.ring.as_deref()),
            ("the direction map", args.map.as_deref()),
            ("the machine file", args.machine.as_deref()),
            ("the probing program", args.input.as_deref()),
        ],
        [("--plot", args.plot.as_deref()), ("-o", program_output)],
    )?;
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
                    .map_err(|e| crate::Error::io(Path::new("<stdin>"), e))?;
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
    // Outputs: the plot and the program, all or nothing; then the report.
    let mut outputs: Vec<(&_, &[u8])> = Vec::new();
    if let (Some(to), Some(svg)) = (&plot_to, &svg) {
        outputs.push((to, svg.as_bytes()));
    }
    if let (Some(to), Some(out)) = (&program_to, &program_out) {
        outputs.push((to, out));
    }
    write_all(&outputs)?;
    if args.quiet {
        return Ok(());
    }
    let program_to_stdout = program_to.as_ref().is_some_and(|d| d.is_stdout());
    let (main_text, side_text) = match (args.format, csv_report) {
        (FormatArg::Csv, Some(csv)) => (csv, Some(text_report)),
        _ => (text_report, None),
    };
    let main = if program_to_stdout {
        Std::Err
    } else {
        Std::Out
    };
    main.write(main_text.as_bytes())?;
    if let Some(side) = side_text {
        Std::Err.write(side.as_bytes())?;
    }
    Ok(())
}
