//! `nccomp report`: the HTML report on one program.

use super::files::{destinations, read_file, write_all};
use std::path::PathBuf;

#[derive(clap::Args)]
pub(super) struct ReportArgs {
    /// The machine, its errors and the compensation pass's options, as `compensate` takes
    /// them: the report shows the program `compensate` writes with the same options.
    #[command(flatten)]
    pass: super::compensate::PassArgs,
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
    /// The page's pass/fail line: largest predicted tip error after compensation, mm (as
    /// `check --max-error`).
    #[arg(long, value_name = "MM", default_value_t = crate::check::DEFAULT_MAX_ERROR_MM)]
    max_error: f64,
    /// The page's pass/fail line: largest predicted tool direction error after
    /// compensation, µrad (as `check --max-angle`; the default moves the tip of a 100 mm
    /// tool by 10 µm).
    #[arg(long, value_name = "URAD", default_value_t = crate::check::DEFAULT_MAX_ANGLE_URAD)]
    max_angle: f64,
    /// Print no summary.
    #[arg(long, short = 'q')]
    quiet: bool,
}

pub(super) fn report(args: &ReportArgs) -> crate::Result<()> {
    use crate::report;
    let mut inputs = args.pass.inputs();
    inputs.push(("the program", Some(&args.input)));
    let [Some(output)] = destinations(&inputs, [("-o", Some(&args.output))])? else {
        return Err(crate::Error::Usage("report needs -o REPORT.html".into()));
    };
    let super::compensate::Pass {
        machine,
        errors,
        errors_path,
        used,
    } = args.pass.load()?;
    let (src, name) = read_file(&args.input)?;
    let options = report::Options {
        compensate: args.pass.options()?,
        at: args.at.clone(),
        grid: args.grid,
        thresholds: crate::check::Thresholds::new(args.max_error, Some(args.max_angle))?,
    };
    let names = report::Names {
        program: name,
        machine: args.pass.machine.display().to_string(),
        errors: errors_path.display().to_string(),
    };
    let program = names.program.clone();
    let r = report::build(&machine, &errors, &src, names, &options)?;
    let html = r.html().map_err(crate::Error::Usage)?;
    write_all(&[(&output, html.as_bytes())])?;
    if !args.quiet {
        super::files::eprint(&format!("{program}: {}\n", r.summary))?;
        if let Some(line) = crate::model::setup::summary_line(&used) {
            super::files::eprint(&format!("{program}: {line}\n"))?;
        }
    }
    Ok(())
}
