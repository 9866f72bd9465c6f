//! `nccomp errors`: converting calibration files from the field into error files.

use super::files::{destinations, eprint, read_file, write_all};
use crate::model::machine_file;
use clap::Subcommand;
use std::path::Path;
use std::path::PathBuf;

#[derive(Subcommand)]
pub(super) enum ErrorsCommand {
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
pub(super) struct ConvertArgs {
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

pub(super) fn convert(args: &ConvertArgs) -> crate::Result<()> {
    use crate::import::{self, Format};
    let [output] = destinations(
        &[
            ("the calibration file", Some(&args.input)),
            ("the machine file", args.machine.as_deref()),
        ],
        [("-o", Some(args.output.as_deref().unwrap_or(Path::new("-"))))],
    )?;
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
    if let Some(output) = &output {
        write_all(&[(output, converted.toml.as_bytes())])?;
    }
    for note in &converted.notes {
        eprint(&format!("note: {note}\n"))?;
    }
    eprint(&format!("{}\n", converted.summary))
}
