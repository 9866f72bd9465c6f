//! `nccomp contour`: the contour error of a program from a trace of the machine's axes.

use super::files::{Std, destinations, read_file, write_all};
use crate::model::machine_file;
use std::path::PathBuf;

#[derive(clap::Args)]
pub(super) struct ContourArgs {
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

pub(super) fn contour(args: &ContourArgs) -> crate::Result<()> {
    use crate::contour::{self, plot, report};
    for (name, v) in [
        ("--step", args.step),
        ("--window", args.window),
        ("--capture", Some(args.capture)),
    ] {
        if let Some(v) = v
            && !(v > 0.0 && v.is_finite())
        {
            return Err(crate::Error::Usage(format!(
                "{name} {v}: expected a positive length in mm"
            )));
        }
    }
    let [plot_to, csv_to] = destinations(
        &[
            ("the machine file", Some(&args.machine)),
            ("the program", Some(&args.program)),
            ("the trace", Some(&args.trace)),
        ],
        [
            ("--plot", args.plot.as_deref()),
            ("-o", args.output.as_deref()),
        ],
    )?;
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
    // The plot and the points, all or nothing; then the summary.
    let svg = match &plot_to {
        Some(_) => {
            let title = format!("Contour error of {program_name} on {machine_name} ({trace_name})");
            Some(plot::svg(&a, &title).map_err(crate::Error::Usage)?)
        }
        None => None,
    };
    let csv = csv_to.as_ref().map(|_| report::points_csv(&a, args.rapids));
    let mut outputs: Vec<(&_, &[u8])> = Vec::new();
    if let (Some(to), Some(svg)) = (&plot_to, &svg) {
        outputs.push((to, svg.as_bytes()));
    }
    if let (Some(to), Some(csv)) = (&csv_to, &csv) {
        outputs.push((to, csv.as_bytes()));
    }
    write_all(&outputs)?;
    if !args.quiet {
        let text = report::summary_text(&a, &program_name, &trace_name, &machine_name);
        let csv_to_stdout = csv_to.as_ref().is_some_and(|d| d.is_stdout());
        let to = if csv_to_stdout { Std::Err } else { Std::Out };
        to.write(text.as_bytes())?;
    }
    Ok(())
}
