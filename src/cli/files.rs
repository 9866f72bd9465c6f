//! Reading inputs and writing outputs for every command.
//!
//! A command's outputs are checked before anything is read or written
//! ([`destinations`]): none may be the same file as one of its inputs or as another of its
//! outputs (same device and inode, whatever the names), a symlink is followed to the file
//! it names, and a FIFO, a character device or standard output is written as a stream,
//! never replaced by a regular file. A file is written through a temporary file beside it
//! that takes its place only when the command has succeeded, every output of the command
//! at once ([`commit`]). A run stopped by SIGINT, SIGTERM or SIGHUP removes its temporary
//! files; one left by a run killed hard is removed by the next run writing the same file,
//! once the process that made it is gone.

use crate::Error;
use std::fs::File;
use std::io::{Seek, Write};
use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard};

pub(super) fn is_std(path: &Option<PathBuf>) -> bool {
    path.as_deref().is_none_or(|p| p == Path::new("-"))
}

pub(super) fn read_file(path: &Path) -> crate::Result<(Vec<u8>, String)> {
    let buf = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    Ok((buf, path.display().to_string()))
}

/// Standard output or standard error.
#[derive(Clone, Copy)]
pub(super) enum Std {
    Out,
    Err,
}

impl Std {
    fn name(self) -> &'static str {
        match self {
            Std::Out => "<stdout>",
            Std::Err => "<stderr>",
        }
    }

    /// Whether the stream was closed when nccomp started (`>&-`, `2>&-`). The Rust
    /// runtime puts /dev/null in the place of a closed standard stream, opened for
    /// reading and writing, where a shell's `>/dev/null` opens it for writing only: what
    /// nccomp writes there would be lost without a word.
    pub(super) fn is_closed(self) -> bool {
        #[cfg(unix)]
        {
            use std::os::fd::AsFd;
            use std::os::unix::fs::{FileTypeExt, MetadataExt};
            let fd = match self {
                Std::Out => std::io::stdout().as_fd().try_clone_to_owned(),
                Std::Err => std::io::stderr().as_fd().try_clone_to_owned(),
            };
            let Ok(fd) = fd else { return true };
            let file = File::from(fd);
            let (Ok(meta), Ok(null)) = (file.metadata(), std::fs::metadata("/dev/null")) else {
                return false;
            };
            let read_write = rustix::fs::fcntl_getfl(&file)
                .is_ok_and(|flags| flags & rustix::fs::OFlags::ACCMODE == rustix::fs::OFlags::RDWR);
            meta.file_type().is_char_device() && meta.rdev() == null.rdev() && read_write
        }
        #[cfg(not(unix))]
        false
    }

    /// Write `bytes` and flush: a closed pipe or a full disk is an error naming the stream
    /// (never a panic, as `print!` gives).
    pub(super) fn write(self, bytes: &[u8]) -> crate::Result<()> {
        let result = match self {
            Std::Out => {
                let mut out = std::io::stdout().lock();
                out.write_all(bytes).and_then(|()| out.flush())
            }
            Std::Err => {
                let mut err = std::io::stderr().lock();
                err.write_all(bytes).and_then(|()| err.flush())
            }
        };
        result.map_err(|e| Error::io(Path::new(self.name()), e))
    }
}

/// Print `text` on standard output.
pub(super) fn print(text: &str) -> crate::Result<()> {
    Std::Out.write(text.as_bytes())
}

/// Print `text` on standard error.
pub(super) fn eprint(text: &str) -> crate::Result<()> {
    Std::Err.write(text.as_bytes())
}

/// What identifies a regular file: its device and inode, or where they cannot be read,
/// its canonical path. A terminal, a pipe or a device has none: reading from and writing
/// to one (a terminal both ways) is no overwriting. Standard output that is no file is
/// `Stdout`, the same only as itself.
#[derive(PartialEq)]
enum FileId {
    Node(u64, u64),
    Path(PathBuf),
    Stdout,
}

impl FileId {
    fn of_meta(meta: &std::fs::Metadata) -> Option<FileId> {
        if !meta.is_file() {
            return None;
        }
        #[cfg(unix)]
        {
            use std::os::unix::fs::MetadataExt;
            Some(FileId::Node(meta.dev(), meta.ino()))
        }
        #[cfg(not(unix))]
        {
            let _ = meta;
            None
        }
    }

    /// The file at `path` (`-`: standard input), or `None` when there is none.
    fn of_input(path: &Path) -> Option<FileId> {
        if path == Path::new("-") {
            return Self::of_stdin();
        }
        match std::fs::metadata(path) {
            Ok(meta) => Self::of_meta(&meta),
            Err(_) => std::fs::canonicalize(path).ok().map(FileId::Path),
        }
    }

    fn of_stdin() -> Option<FileId> {
        #[cfg(unix)]
        {
            use std::os::fd::AsFd;
            let fd = std::io::stdin().as_fd().try_clone_to_owned().ok()?;
            Self::of_meta(&File::from(fd).metadata().ok()?)
        }
        #[cfg(not(unix))]
        None
    }

    fn of_stdout() -> FileId {
        #[cfg(unix)]
        {
            use std::os::fd::AsFd;
            let meta = std::io::stdout()
                .as_fd()
                .try_clone_to_owned()
                .and_then(|fd| File::from(fd).metadata());
            if let Some(id) = meta.ok().and_then(|m| Self::of_meta(&m)) {
                return id;
            }
        }
        FileId::Stdout
    }

    /// The file an output goes to; one not yet there is named by its canonical directory
    /// and its name. A stream (FIFO, device) has none: two outputs may both go to
    /// /dev/null.
    fn of_output(to: &Target) -> Option<FileId> {
        match to {
            Target::Stdout => Some(Self::of_stdout()),
            Target::Stream(_) => None,
            Target::File(path) => Self::of_input(path).or_else(|| {
                let dir = std::fs::canonicalize(parent(path)).ok()?;
                Some(FileId::Path(dir.join(path.file_name()?)))
            }),
        }
    }
}

/// Where an output goes, once symlinks are followed.
#[derive(Debug, Clone, PartialEq)]
enum Target {
    /// Standard output (`-`, `/dev/stdout`).
    Stdout,
    /// A FIFO or character device: opened and written, never replaced.
    Stream(PathBuf),
    /// A regular file, or none yet: replaced atomically.
    File(PathBuf),
}

/// A checked output path: what the user gave and where it goes.
#[derive(Debug, Clone)]
pub(super) struct Destination {
    given: PathBuf,
    to: Target,
}

/// `path`'s directory (`.` for a bare name).
fn parent(path: &Path) -> &Path {
    match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    }
}

impl Destination {
    /// Where `given` leads: `-` and /dev/stdout are standard output; a symlink is followed
    /// to the file it names (created when it does not exist); a FIFO or character device
    /// is a stream. A directory, a block device or a socket is refused.
    fn resolve(given: &Path) -> crate::Result<Self> {
        let refuse = |what: &str| {
            Error::Usage(format!(
                "{}: the output is {what}: expected a file, a FIFO, a character device or `-` \
                 (standard output)",
                given.display()
            ))
        };
        let to = if ["-", "/dev/stdout", "/dev/fd/1", "/proc/self/fd/1"]
            .iter()
            .any(|s| given == Path::new(s))
        {
            Target::Stdout
        } else {
            match std::fs::metadata(given) {
                Ok(m) if m.is_file() => {
                    Target::File(std::fs::canonicalize(given).map_err(|e| Error::io(given, e))?)
                }
                Ok(m) if m.is_dir() => return Err(refuse("a directory")),
                Ok(m) => {
                    #[cfg(unix)]
                    {
                        use std::os::unix::fs::FileTypeExt;
                        let t = m.file_type();
                        if t.is_fifo() || t.is_char_device() {
                            Target::Stream(given.to_path_buf())
                        } else if t.is_block_device() {
                            return Err(refuse("a block device"));
                        } else {
                            return Err(refuse("a socket"));
                        }
                    }
                    #[cfg(not(unix))]
                    {
                        let _ = m;
                        return Err(refuse("not a regular file"));
                    }
                }
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                    Target::File(dangling_target(given).map_err(|e| Error::io(given, e))?)
                }
                Err(e) => return Err(Error::io(given, e)),
            }
        };
        Ok(Destination {
            given: given.to_path_buf(),
            to,
        })
    }

    /// The output as messages name it: the path given, or `<stdout>`.
    pub(super) fn name(&self) -> String {
        match self.to {
            Target::Stdout => "<stdout>".into(),
            _ => self.given.display().to_string(),
        }
    }

    pub(super) fn is_stdout(&self) -> bool {
        self.to == Target::Stdout
    }

    /// A file to write the output into: a temporary file beside a regular file, an
    /// unnamed one for a stream. [`commit`] puts it in place.
    pub(super) fn stage(&self) -> crate::Result<Staged> {
        let spool = match &self.to {
            Target::File(path) => Spool::Named(Temporary::beside(path, &self.given)?),
            Target::Stdout | Target::Stream(_) => {
                let file = tempfile::tempfile().map_err(|e| {
                    Error::io(
                        Path::new(&self.name()),
                        std::io::Error::new(
                            e.kind(),
                            format!("cannot create a temporary file: {e}"),
                        ),
                    )
                })?;
                Spool::Unnamed(file)
            }
        };
        Ok(Staged {
            to: self.clone(),
            spool,
        })
    }
}

/// The file a dangling symlink names (the path itself when it is no symlink).
fn dangling_target(path: &Path) -> std::io::Result<PathBuf> {
    let mut path = path.to_path_buf();
    for _ in 0..40 {
        match std::fs::read_link(&path) {
            Ok(to) => path = parent(&path).join(to),
            Err(_) => return Ok(path),
        }
    }
    Err(std::io::Error::other(
        "too many levels of symbolic links: expected a path that leads to a file",
    ))
}

/// The destinations of a command's outputs (each with the option that gave it, for
/// messages; `None`: the output is not written), checked before anything is read or
/// written: none is the same file as one of `inputs` (each with what it is, e.g. "the
/// machine file"; `-` is standard input) or as another output. An output path that is an
/// input is refused with the names of both: nccomp never writes over its own input (a
/// program compensated in place is compensated twice by the next run).
pub(super) fn destinations<const N: usize>(
    inputs: &[(&str, Option<&Path>)],
    outputs: [(&str, Option<&Path>); N],
) -> crate::Result<[Option<Destination>; N]> {
    let inputs: Vec<(&str, &Path, FileId)> = inputs
        .iter()
        .filter_map(|&(what, path)| {
            let path = path?;
            Some((what, path, FileId::of_input(path)?))
        })
        .collect();
    let mut seen: Vec<(&str, &Destination, FileId)> = Vec::new();
    let mut out: [Option<Destination>; N] = std::array::from_fn(|_| None);
    for (slot, &(_, path)) in out.iter_mut().zip(outputs.iter()) {
        let Some(path) = path else { continue };
        *slot = Some(Destination::resolve(path)?);
    }
    for (dest, &(option, _)) in out.iter().zip(outputs.iter()) {
        let Some(dest) = dest else { continue };
        let Some(id) = FileId::of_output(&dest.to) else {
            continue;
        };
        let shown = |d: &Destination| match d.to {
            Target::Stdout => "standard output".to_string(),
            _ => format!("`{option} {}`", d.given.display()),
        };
        if let Some((what, path, _)) = inputs.iter().find(|(_, _, i)| *i == id) {
            let input = if *path == Path::new("-") {
                format!("{what} (standard input)")
            } else {
                format!("{what} {}", path.display())
            };
            return Err(Error::Usage(format!(
                "{} is the same file as {input}: nccomp never writes over one of its inputs; \
                 expected an output path that is none of them",
                shown(dest)
            )));
        }
        if let Some((other, first, _)) = seen.iter().find(|(_, _, i)| *i == id) {
            return Err(Error::Usage(format!(
                "{} and `{other} {}` are the same file: expected a different path for each \
                 output",
                shown(dest),
                first.given.display()
            )));
        }
        seen.push((option, dest, id));
    }
    Ok(out)
}

/// The temporary files this process has open, removed by the signal watcher if the run is
/// stopped.
static LIVE: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

fn live() -> MutexGuard<'static, Vec<PathBuf>> {
    LIVE.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
}

/// A temporary file beside an output, `.NAME.nccomp-PID-XXXXXX.tmp` (XXXXXX: random, so
/// names never collide across runs), registered for removal on SIGINT, SIGTERM and SIGHUP
/// and locked (flock) while this process lives, so that no other run takes it for one a
/// killed run left.
struct Temporary(Option<tempfile::NamedTempFile>);

impl Temporary {
    fn beside(path: &Path, given: &Path) -> crate::Result<Self> {
        let dir = parent(path);
        let io = |e| Error::io(given, e);
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
        watch_signals();
        let own_prefix = format!("{prefix}{}-", std::process::id());
        let mut builder = tempfile::Builder::new();
        builder.prefix(&own_prefix).suffix(".tmp");
        // Made with the mode the output will have (a new file: 0666 less the umask, as a
        // plain `File::create` gives; a replaced one: its own), so it is never more open
        // than the output while it is written.
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            let mode = std::fs::metadata(path).map_or(0o666, |m| m.permissions().mode() & 0o777);
            builder.permissions(std::fs::Permissions::from_mode(mode));
        }
        // Registered under the lock that the signal watcher takes: a signal can never
        // come between the file's creation and its registration.
        let mut live = live();
        // tempfile's own error names the temporary path, which means nothing to the user.
        let file = builder.tempfile_in(dir).map_err(|e| {
            io(std::io::Error::new(
                e.kind(),
                format!(
                    "cannot create the output file in {}: {}",
                    dir.display(),
                    e.kind()
                ),
            ))
        })?;
        let _ = file.as_file().try_lock();
        live.push(file.path().to_path_buf());
        Ok(Temporary(Some(file)))
    }

    fn file(&mut self) -> &mut File {
        self.0
            .as_mut()
            .expect("a temporary file is present until it is persisted")
            .as_file_mut()
    }

    /// Rename the temporary file to `path`.
    fn persist(mut self, path: &Path) -> std::io::Result<()> {
        let mut live = live();
        let Some(file) = self.0.take() else {
            return Ok(());
        };
        let temporary = file.path().to_path_buf();
        live.retain(|p| *p != temporary);
        // On failure the temporary file is removed as `e.file` drops.
        file.persist(path).map(drop).map_err(|e| e.error)
    }
}

impl Drop for Temporary {
    fn drop(&mut self) {
        if let Some(file) = self.0.take() {
            let mut live = live();
            live.retain(|p| p != file.path());
            drop(file);
        }
    }
}

/// Remove the temporary files `PREFIX PID-XXXXXX.tmp` in `dir` that a killed run left:
/// those whose process no longer runs and that no process holds locked. Only where the
/// process table can be read (`/proc`); elsewhere they stay, to be deleted by hand.
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
        let Some((pid, random)) = file_name
            .to_str()
            .and_then(|n| n.strip_prefix(prefix))
            .and_then(|r| r.strip_suffix(".tmp"))
            .and_then(|r| r.split_once('-'))
        else {
            continue;
        };
        // Exactly what this code names its files: another output's temporary whose name
        // starts the same (`.a.nccomp-1-x.nccomp-...` for an output `a.nccomp-1-x`) is not
        // one of these.
        let ours = !pid.is_empty()
            && pid.bytes().all(|b| b.is_ascii_digit())
            && random.len() == 6
            && random.bytes().all(|b| b.is_ascii_alphanumeric());
        if !ours || proc.join(pid).exists() {
            continue;
        }
        let Ok(file) = File::open(entry.path()) else {
            continue;
        };
        if file.try_lock().is_ok() {
            let _ = std::fs::remove_file(entry.path());
        }
    }
}

/// On the first temporary file: a thread that waits for SIGINT, SIGTERM or SIGHUP,
/// removes this process's temporary files and ends the process as the signal would have.
fn watch_signals() {
    #[cfg(unix)]
    {
        static WATCHING: std::sync::Once = std::sync::Once::new();
        WATCHING.call_once(|| {
            use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
            let Ok(mut signals) = signal_hook::iterator::Signals::new([SIGINT, SIGTERM, SIGHUP])
            else {
                return;
            };
            std::thread::spawn(move || {
                if let Some(signal) = signals.forever().next() {
                    // Held to the end: no temporary file is renamed after this.
                    let live = live();
                    for path in live.iter() {
                        let _ = std::fs::remove_file(path);
                    }
                    let _ = signal_hook::low_level::emulate_default_handler(signal);
                    std::process::exit(128 + signal);
                }
            });
        });
    }
}

/// A write that fails with EFBIG past `ulimit -f` instead of the process being killed by
/// SIGXFSZ (which would leave its temporary file).
pub(super) fn ignore_file_size_signal() {
    #[cfg(unix)]
    {
        let flag = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
        let _ = signal_hook::flag::register(signal_hook::consts::SIGXFSZ, flag);
    }
}

enum Spool {
    Named(Temporary),
    Unnamed(File),
}

/// An output being written, not yet in its place.
pub(super) struct Staged {
    to: Destination,
    spool: Spool,
}

impl Staged {
    /// The file to write the output into.
    pub(super) fn file(&mut self) -> &mut File {
        match &mut self.spool {
            Spool::Named(t) => t.file(),
            Spool::Unnamed(f) => f,
        }
    }

    pub(super) fn name(&self) -> String {
        self.to.name()
    }
}

/// Put every staged output in its place: each temporary file gets the mode and owner of
/// the file it replaces and is flushed to disk, then they are all renamed, then the
/// streams (standard output, FIFOs, devices) are written. A failure before the renames
/// leaves every output as it was.
pub(super) fn commit(staged: Vec<Staged>) -> crate::Result<()> {
    let mut renames = Vec::new();
    let mut streams = Vec::new();
    for mut s in staged {
        let io = |e| Error::io(&s.to.given, e);
        match (&s.to.to, &mut s.spool) {
            (Target::File(path), Spool::Named(t)) => {
                #[cfg(unix)]
                if let Ok(meta) = std::fs::metadata(path) {
                    use std::os::unix::fs::MetadataExt;
                    // Root replacing a user's file gives it back to the user; anyone else
                    // can only keep their own, and that is what they have.
                    let _ =
                        std::os::unix::fs::fchown(&*t.file(), Some(meta.uid()), Some(meta.gid()));
                    t.file().set_permissions(meta.permissions()).map_err(io)?;
                }
                t.file().sync_all().map_err(io)?;
                renames.push((path.clone(), s));
            }
            _ => streams.push(s),
        }
    }
    for (path, s) in renames {
        let given = s.to.given.clone();
        if let Spool::Named(t) = s.spool {
            t.persist(&path).map_err(|e| Error::io(&given, e))?;
        }
    }
    for mut s in streams {
        let name = s.name();
        let io = |e| Error::io(Path::new(&name), e);
        let file = s.file();
        file.seek(std::io::SeekFrom::Start(0)).map_err(io)?;
        match &s.to.to {
            Target::Stream(path) => {
                let mut out = std::fs::OpenOptions::new()
                    .write(true)
                    .open(path)
                    .map_err(io)?;
                std::io::copy(s.file(), &mut out)
                    .and_then(|_| out.flush())
                    .map_err(io)?;
            }
            _ => {
                let mut out = std::io::stdout().lock();
                std::io::copy(s.file(), &mut out)
                    .and_then(|_| out.flush())
                    .map_err(io)?;
            }
        }
    }
    Ok(())
}

/// Write each output's bytes, all or nothing as [`commit`] does.
pub(super) fn write_all(outputs: &[(&Destination, &[u8])]) -> crate::Result<()> {
    let mut staged = Vec::with_capacity(outputs.len());
    for (dest, bytes) in outputs {
        let mut s = dest.stage()?;
        s.file()
            .write_all(bytes)
            .map_err(|e| Error::io(Path::new(&s.name()), e))?;
        staged.push(s);
    }
    commit(staged)
}
