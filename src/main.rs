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
