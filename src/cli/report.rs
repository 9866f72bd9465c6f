//! `nccomp report`: the HTML report on one program.

use super::files::{destinations, read_file, write_all};
use crate::compensate::Options;
use crate::model::{error_file, machine_file};
use std::path::PathBuf;

#[derive(clap::Args)]
pub(super) struct ReportArgs {
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
    /// The program's language: `auto` (from the file's extension and text), `iso`,
    /// `heidenhain` or `sinumerik`, as for `compensate`.
    #[arg(long, value_name = "DIALECT", default_value = "auto")]
    dialect: super::compensate::DialectArg,
}

pub(super) fn report(args: &ReportArgs) -> crate::Result<()> {
    use crate::report;
    let [Some(output)] = destinations(
        &[
            ("the machine file", Some(&args.machine)),
            ("the error file", Some(&args.errors)),
            ("the program", Some(&args.input)),
        ],
        [("-o", Some(&args.output))],
    )?
    else {
        return Err(crate::Error::Usage("report needs -o REPORT.html".into()));
    };
    let machine = machine_file::load(&args.machine)?;
    let errors = error_file::load(&args.errors, &machine)?;
    let (src, name) = read_file(&args.input)?;
    let options = report::Options {
        compensate: Options {
            tool_chain: args.tool_chain.clone(),
            hold: args.hold.clone(),
            dialect: args.dialect.get(),
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
    let html = r.html().map_err(crate::Error::Usage)?;
    write_all(&[(&output, html.as_bytes())])
}
