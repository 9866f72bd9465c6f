//! Reading inputs and writing outputs for every command. Outputs are written atomically so
//! that a failed run leaves no half-written file; a killed run's temporaries are cleared.

use std::io::Write;
use std::path::{Path, PathBuf};

pub(super) fn is_std(path: &Option<PathBuf>) -> bool {
    path.as_deref().is_none_or(|p| p == Path::new("-"))
}

pub(super) fn read_file(path: &Path) -> crate::Result<(Vec<u8>, String)> {
    let buf = std::fs::read(path).map_err(|e| crate::Error::io(path, e))?;
    Ok((buf, path.display().to_string()))
}

pub(super) fn print(text: &str) -> crate::Result<()> {
    let mut stdout = std::io::stdout().lock();
    stdout
        .write_all(text.as_bytes())
        .and_then(|()| stdout.flush())
        .map_err(|e| crate::Error::io(Path::new("<stdout>"), e))
}

/// Write `bytes` to `path` through a temporary file in the same directory and a rename, so
/// the path holds either the old content or the complete new one, never a part.
pub(super) fn write_atomically(path: &Path, bytes: &[u8]) -> crate::Result<()> {
    write_atomically_with(path, |file| {
        file.write_all(bytes).map_err(|e| crate::Error::io(path, e))
    })
}

/// Let `write` fill a temporary file beside `path` and rename it to `path` when `write`
/// succeeds: the path holds either the old content or the complete new one, never a part.
/// A failed run removes its temporary file. The file's name says what it is
/// (`.NAME.nccomp-PID-XXXXXX.tmp`), and one left by a run that was killed (its process is
/// gone) is removed by the next run writing the same file.
pub(super) fn write_atomically_with<T>(
    path: &Path,
    write: impl FnOnce(&mut std::fs::File) -> crate::Result<T>,
) -> crate::Result<T> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let io = |e| crate::Error::io(path, e);
    if !dir.is_dir() {
        return Err(io(std::io::Error::new(
            std::io::ErrorKind::NotFound,
            format!(
                "cannot write the output: directory {} does not exist",
                dir.display()
            ),
        )));
    }
    let name = path
        .file_name()
        .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
    let prefix = format!(".{name}.nccomp-");
    remove_stale_temporaries(dir, &prefix);
    // tempfile's own error names the temporary path, which means nothing to the user.
    let mut tmp = tempfile::Builder::new()
        .prefix(&format!("{prefix}{}-", std::process::id()))
        .suffix(".tmp")
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
    let value = write(tmp.as_file_mut())?;
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
    Ok(value)
}

/// Remove the temporary files `prefix PID-XXXXXX.tmp` in `dir` whose process no longer
/// runs: what a run killed before its rename left behind. Only where the process table
/// can be read (`/proc`); elsewhere they stay, to be deleted by hand.
fn remove_stale_temporaries(dir: &Path, prefix: &str) {
    let proc = Path::new("/proc");
    if !proc.join("self").exists() {
        return;
    }
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let file_name = entry.file_name();
        let Some(rest) = file_name
            .to_str()
            .and_then(|n| n.strip_prefix(prefix))
            .filter(|r| r.ends_with(".tmp"))
        else {
            continue;
        };
        let Some(pid) = rest.split('-').next().and_then(|p| p.parse::<u32>().ok()) else {
            continue;
        };
        if !proc.join(pid.to_string()).exists() {
            let _ = std::fs::remove_file(entry.path());
        }
    }
}
