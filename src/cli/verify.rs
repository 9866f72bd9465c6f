//! `nccomp verify`: the verification gate as a command, for CI: a compensated program on
//! disk held against its original under today's calibration.

use super::compensate::PassArgs;
use super::files::print;
use crate::check::Status;
use crate::compensate::Compensator;
use crate::diag::{Severity, use_color};
use std::path::PathBuf;

#[derive(clap::Args)]
pub(super) struct VerifyArgs {
    #[command(flatten)]
    pass: PassArgs,
    /// The program as the CAM postprocessor wrote it: the nominal path.
    #[arg(value_name = "ORIGINAL")]
    original: PathBuf,
    /// The compensated program the control will run (nccomp's, another tool's, or
    /// hand-edited).
    #[arg(value_name = "COMPENSATED")]
    compensated: PathBuf,
    /// Output format: diagnostics for people, or JSON.
    #[arg(long, value_enum, default_value = "human")]
    format: VerifyFormat,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum VerifyFormat {
    Human,
    Json,
}

pub(super) fn verify(args: &VerifyArgs) -> crate::Result<Status> {
    let super::compensate::Pass {
        machine,
        errors,
        used,
        ..
    } = args.pass.load()?;
    let comp = Compensator::new(&machine, &errors, args.pass.options()?)?;
    // Both programs are streamed from their files (read again for each reading).
    let original_name = args.original.display().to_string();
    let written_name = args.compensated.display().to_string();
    let open = |path: &std::path::Path| {
        let path = path.to_path_buf();
        move || -> std::io::Result<Box<dyn std::io::Read>> {
            Ok(Box::new(std::fs::File::open(&path)?))
        }
    };
    let (open_original, open_written) = (open(&args.original), open(&args.compensated));
    // Unreadable files are named as such before anything is read.
    for path in [&args.original, &args.compensated] {
        std::fs::File::open(path).map_err(|e| crate::Error::io(path, e))?;
    }
    let original = crate::verify::Source::Stream {
        name: &original_name,
        open: &open_original,
    };
    let written = crate::verify::Source::Stream {
        name: &written_name,
        open: &open_written,
    };
    let dialect = comp.dialect_of(&original_name, &original.head(64 * 1024)?);
    let verdict = comp.verify(original, written, dialect)?;
    let status = if verdict.passed() {
        Status::Clean
    } else {
        Status::Findings
    };
    match args.format {
        VerifyFormat::Human => {
            let color = use_color(&std::io::stdout());
            let mut out = String::new();
            if let Some(line) = crate::model::setup::summary_line(&used) {
                out.push_str(&format!("{written_name}: {line}\n"));
            }
            for d in &verdict.findings {
                out.push_str(&d.render_as(Severity::Error, color));
                out.push('\n');
            }
            if verdict.passed() {
                out.push_str(&format!("{written_name}: {verdict}\n"));
            } else {
                out.push_str(&format!(
                    "{written_name}: {} as the control reads it: it does not put the tool on the nominal path of {original_name}\n",
                    match verdict.findings.len() {
                        1 => "1 finding".to_string(),
                        n => format!("{n} findings"),
                    }
                ));
            }
            print(&out)?;
        }
        VerifyFormat::Json => {
            let doc = serde_json::json!({
                "format": "nccomp-verify",
                "nccomp_version": env!("CARGO_PKG_VERSION"),
                "original": original_name,
                "compensated": written_name,
                "status": if verdict.passed() { "clean" } else { "findings" },
                "exit_code": status.exit_code(),
                "setup": used,
                "block_delete_states": verdict.states.iter().map(|&on| if on { "on" } else { "off" }).collect::<Vec<_>>(),
                "moves": verdict.moves,
                "written_moves": verdict.written_moves,
                "not_verified": verdict.not_followed.iter().map(|(k, n)| serde_json::json!({"kind": k.name(), "blocks": n})).collect::<Vec<_>>(),
                "largest": {
                    "end_position_mm": verdict.end_position.value,
                    "end_direction_rad": verdict.end_direction.value,
                    "path_position_mm": verdict.path_position.value,
                    "path_direction_rad": verdict.path_direction.value,
                },
                "findings": verdict.findings.iter().map(|d| serde_json::json!({
                    "file": d.path,
                    "line": d.line,
                    "column": d.column,
                    "message": d.message,
                })).collect::<Vec<_>>(),
            });
            let mut text = serde_json::to_string_pretty(&doc).expect("plain data serializes");
            text.push('\n');
            print(&text)?;
        }
    }
    Ok(status)
}
