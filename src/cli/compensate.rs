//! `nccomp compensate`: its options, and the compensation pass's options it shares with
//! `check`.

use super::files::{commit, destinations, eprint, is_std, print, read_file};
use crate::check::Status;
use crate::check::settings::Settings;
use crate::compensate::{Compensator, Options};
use crate::model::setup::Used;
use crate::model::{ErrorModel, Machine, error_file, machine_file};
use std::io::Read;
use std::path::{Path, PathBuf};

#[derive(clap::Args)]
pub(super) struct CompensateArgs {
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

/// The machine, its errors and the options of the compensation pass (`compensate`,
/// `check`, `report` and `verify` share them, so a check predicts what compensation will
/// do and the gate judges with the values the pass used).
#[derive(clap::Args)]
pub(super) struct PassArgs {
    /// Machine file (TOML): axes, chains, pivot points, travels, tool lengths.
    #[arg(long, short = 'm', value_name = "MACHINE.toml")]
    pub(super) machine: PathBuf,
    /// Error file (TOML): the machine's measured errors (a calibration). Left out: the
    /// one the machine file names (`errors = "…"`).
    #[arg(long, short = 'e', value_name = "ERRORS.toml")]
    pub(super) errors: Option<PathBuf>,
    #[command(flatten)]
    pub(super) options: PassOptions,
}

/// The options of the compensation pass, each left out unless given (a check from
/// `nccomp.toml` takes what the command line leaves out from the config).
#[derive(clap::Args)]
pub(super) struct PassOptions {
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
    /// block in (arcs aside). Default 0.001.
    #[arg(long, value_name = "MM|off", value_parser = path_tolerance)]
    tolerance: Option<PathLimit>,
    /// The tool direction's tolerance along the path, in µrad. Default 10.
    #[arg(long, value_name = "URAD")]
    angular_tolerance: Option<f64>,
    /// The programs' language: `auto` (the default) reads each program's from its file
    /// and text (a Heidenhain program starts with a numbered `BEGIN PGM`; a Sinumerik
    /// program is a `.mpf` or `.spf` file, or has DEF, TRAORI, CYCLE800, MSG, T="…" or
    /// another Siemens instruction in its first 200 lines), `iso` G-code, `heidenhain` TNC
    /// conversational, `sinumerik` Siemens 840D.
    #[arg(long, value_name = "DIALECT")]
    dialect: Option<DialectArg>,
    /// The block delete switch the program will run with: `on` skips blocks with `/`
    /// (they are copied unchanged), `off` runs them. Without it the output must be right
    /// in both states, and nccomp refuses a program whose optional blocks make that
    /// impossible.
    #[arg(long, value_name = "on|off", value_parser = on_off)]
    block_delete: Option<bool>,
    /// A set-up for this job, layered over the machine file: work offsets (presets) and
    /// tool lengths from nccomp's set-up file (.toml) or the control's tables (LinuxCNC
    /// .var and .tbl, Heidenhain TOOL.T); repeat it for more, a later file's values over
    /// an earlier's. The summary says which values were used (docs/file-formats.md).
    #[arg(long, value_name = "FILE")]
    setup: Vec<PathBuf>,
}

fn on_off(text: &str) -> Result<bool, String> {
    match text.to_ascii_lowercase().as_str() {
        "on" => Ok(true),
        "off" => Ok(false),
        _ => Err(format!("expected `on` or `off`, found `{text}`")),
    }
}

/// `--dialect`.
#[derive(Clone, Copy, clap::ValueEnum)]
pub(super) enum DialectArg {
    Auto,
    Iso,
    Heidenhain,
    Sinumerik,
}

impl DialectArg {
    /// The dialect given, or `None` for `auto`.
    pub(super) fn get(self) -> Option<crate::nc::Dialect> {
        match self {
            DialectArg::Auto => None,
            DialectArg::Iso => Some(crate::nc::Dialect::Iso),
            DialectArg::Heidenhain => Some(crate::nc::Dialect::Heidenhain),
            DialectArg::Sinumerik => Some(crate::nc::Dialect::Sinumerik),
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

pub(super) fn compensate(args: &CompensateArgs) -> crate::Result<Status> {
    let input = args.input.as_deref().unwrap_or(Path::new("-"));
    let output = (!args.check).then(|| args.output.as_deref().unwrap_or(Path::new("-")));
    let mut inputs = vec![("the program", Some(input))];
    inputs.extend(args.pass.inputs());
    let [output] = destinations(&inputs, [("-o", output)])?;
    let Pass {
        machine,
        errors,
        used,
        ..
    } = args.pass.load()?;
    let options = Options {
        threads: args.threads as usize,
        ..args.pass.options()?
    };
    let comp = Compensator::new(&machine, &errors, options)?;
    // The program streams through in bounded memory, to a temporary file that takes the
    // output's place only when every block has been compensated (to standard output, an
    // unnamed one copied out at the end: a failed run writes nothing there either).
    // The gate reads the original again after the pass: standard input is kept.
    let verify = comp.verifies();
    let (input, name, kept): (Box<dyn Read>, String, Option<Vec<u8>>) = if is_std(&args.input) {
        use std::io::IsTerminal;
        if std::io::stdin().is_terminal() {
            eprint(
                "nccomp: reading the program from standard input (end with Ctrl-D; see --help)\n",
            )?;
        }
        if verify {
            let mut src = Vec::new();
            std::io::stdin()
                .lock()
                .read_to_end(&mut src)
                .map_err(|e| crate::Error::io(Path::new("<stdin>"), e))?;
            (Box::new(std::io::empty()), "<stdin>".to_string(), Some(src))
        } else {
            (
                Box::new(std::io::stdin().lock()),
                "<stdin>".to_string(),
                None,
            )
        }
    } else {
        let file = std::fs::File::open(input).map_err(|e| crate::Error::io(input, e))?;
        (Box::new(file), input.display().to_string(), None)
    };
    let input: Box<dyn Read + '_> = match &kept {
        Some(src) => Box::new(&src[..]),
        None => input,
    };
    // The original for the gate: read again from its file (streamed), or the standard
    // input kept.
    let input_path = args.input.clone().unwrap_or_else(|| "-".into());
    let open_input = move || -> std::io::Result<Box<dyn Read>> {
        Ok(Box::new(std::fs::File::open(&input_path)?))
    };
    let original: crate::verify::Source<'_> = match &kept {
        Some(src) => crate::verify::Text { name: &name, src }.into(),
        None => crate::verify::Source::Stream {
            name: &name,
            open: &open_input,
        },
    };
    let mut status = Status::Clean;
    let summary = match (&args.expected, output) {
        (Some(expected), _) => {
            let mut out = Vec::new();
            let mut summary = comp.run_stream(input, &name, &mut out, "<memory>")?;
            if verify && !summary.zero_model {
                let written = crate::verify::Text {
                    name: &name,
                    src: &out,
                };
                let verdict = gate(&comp, &summary, original, written.into())?;
                summary.verdict = Some(verdict);
            }
            let (committed, expected_name) = read_file(expected)?;
            if let Some(diff) = crate::check::stale::compare(&expected_name, &committed, &out) {
                print(&format!(
                    "{diff}to update it, run the same command with `-o {expected_name}` in place of `--check --expected {expected_name}`\n"
                ))?;
                status = Status::Findings;
            }
            summary
        }
        (None, Some(output)) => {
            let mut staged = output.stage()?;
            let output_name = staged.name();
            let mut summary = comp.run_stream(input, &name, staged.file(), &output_name)?;
            if verify && !summary.zero_model {
                // Read back what was written, as it lies in the file to be kept (streamed
                // from its start for each reading: the gate holds a chunk, not the program).
                use std::io::{Seek, SeekFrom};
                let file = staged
                    .file()
                    .try_clone()
                    .map_err(|e| crate::Error::io(Path::new(&output_name), e))?;
                let open_written = move || -> std::io::Result<Box<dyn Read>> {
                    let mut f = file.try_clone()?;
                    f.seek(SeekFrom::Start(0))?;
                    Ok(Box::new(f))
                };
                let written = crate::verify::Source::Stream {
                    name: &output_name,
                    open: &open_written,
                };
                let verdict = gate(&comp, &summary, original, written)?;
                staged
                    .file()
                    .seek(SeekFrom::End(0))
                    .map_err(|e| crate::Error::io(Path::new(&output_name), e))?;
                summary.verdict = Some(verdict);
            }
            commit(vec![staged])?;
            summary
        }
        (None, None) => {
            return Err(crate::Error::Usage(
                "--check needs --expected OUTPUT, the committed program to compare".into(),
            ));
        }
    };
    if !args.quiet {
        eprint(&format!("{name}: {summary}\n"))?;
        if let Some(line) = crate::model::setup::summary_line(&used) {
            eprint(&format!("{name}: {line}\n"))?;
        }
    }
    Ok(status)
}

/// The verification gate on a written program: its verdict, or the findings as refusals
/// (exit 2; nothing is kept).
fn gate(
    comp: &Compensator<'_>,
    summary: &crate::compensate::Summary,
    original: crate::verify::Source<'_>,
    written: crate::verify::Source<'_>,
) -> crate::Result<crate::verify::Verdict> {
    if let Some(d) = comp.predicted_beyond(summary, original) {
        return Err(crate::Error::Input(Box::new(d)));
    }
    let dialect = comp.dialect_of(original.name(), &original.head(64 * 1024)?);
    let verdict = comp.verify(original, written, dialect)?;
    if verdict.passed() {
        Ok(verdict)
    } else {
        Err(crate::Error::Inputs(verdict.in_original(original)))
    }
}

impl PassOptions {
    /// What the command line gives, as settings to layer over a config's.
    pub(super) fn settings(&self) -> Settings {
        Settings {
            tolerance: self.tolerance.map(|t| t.0),
            angular_tolerance: self.angular_tolerance,
            tool_chain: self.tool_chain.clone(),
            hold: (!self.hold.is_empty()).then(|| self.hold.clone()),
            allow_limit_violations: self.allow_limit_violations.then_some(true),
            dialect: self.dialect.map(DialectArg::get),
            block_delete: self.block_delete,
            setup: (!self.setup.is_empty()).then(|| self.setup.clone()),
            ..Settings::default()
        }
    }
}

impl PassArgs {
    pub(super) fn options(&self) -> crate::Result<Options> {
        self.options.settings().options()
    }

    /// The machine (with the set-up's values in it), its error model, the error file's
    /// name and the set-up values used.
    pub(super) fn load(&self) -> crate::Result<Pass> {
        load_pass(&self.machine, self.errors.as_deref(), &self.options.setup)
    }

    /// The input files, for [`super::files::destinations`]: an output must not be one.
    pub(super) fn inputs(&self) -> Vec<(&'static str, Option<&Path>)> {
        let mut inputs = vec![("the machine file", Some(self.machine.as_path()))];
        if let Some(e) = &self.errors {
            inputs.push(("the error file", Some(e.as_path())));
        }
        inputs.extend(
            self.options
                .setup
                .iter()
                .map(|s| ("a set-up file", Some(s.as_path()))),
        );
        inputs
    }
}

/// A machine loaded for a pass.
pub(super) struct Pass {
    pub(super) machine: Machine,
    pub(super) errors: ErrorModel,
    pub(super) errors_path: PathBuf,
    pub(super) used: Vec<Used>,
}

/// Load the machine file, lay the set-up files over it, and load the error file (given,
/// or the one the machine file names).
pub(super) fn load_pass(
    machine: &Path,
    errors: Option<&Path>,
    setup: &[PathBuf],
) -> crate::Result<Pass> {
    let mut m = machine_file::load(machine)?;
    let used = crate::model::setup::load_all(setup, &m)?.apply(&mut m)?;
    let errors_path = match (errors, &m.errors_file) {
        (Some(e), _) => e.to_path_buf(),
        (None, Some(e)) => e.clone(),
        (None, None) => {
            return Err(crate::Error::Usage(format!(
                "no error file: expected --errors FILE (-e), or `errors = \"…\"` in {} naming the machine's error file",
                machine.display()
            )));
        }
    };
    let errors = error_file::load(&errors_path, &m)?;
    Ok(Pass {
        machine: m,
        errors,
        errors_path,
        used,
    })
}
