//! Program arguments to files: paths as they are, glob patterns expanded here, so
//! `nccomp check 'programs/**/*.nc'` works without a shell (CI runners, Windows).

use crate::diag::Error;
use std::path::{Path, PathBuf};

/// The files named by `args`, in order, each once. An argument with `*`, `?` or `[` that
/// is not the name of a file is a glob pattern (`**` crosses directories) and must match
/// at least one file; its matches come sorted. Every match that is not a directory is
/// kept, readable or not (a dangling symbolic link is reported when it is read), and so
/// is a match whose name is not UTF-8 (matched by its name with each bad byte taken as
/// U+FFFD). Any other argument is taken as a path, whether it exists or not (a missing
/// file is reported when it is read).
pub fn expand(args: &[String]) -> crate::Result<Vec<PathBuf>> {
    expand_marked(args).map(|files| files.into_iter().map(|(p, _)| p).collect())
}

/// [`expand`], each file with whether a pattern matched it and it is not a regular file
/// (a FIFO or a socket: reading one waits for a writer, so it is named, not read). A path
/// given as it is, a FIFO included (`check <(…)`), is read.
pub fn expand_marked(args: &[String]) -> crate::Result<Vec<(PathBuf, bool)>> {
    let mut files: Vec<(PathBuf, bool)> = Vec::new();
    let mut push = |p: PathBuf, matched: bool| {
        if !files.iter().any(|(f, _)| *f == p) {
            let special = matched && not_regular(&p);
            files.push((p, special));
        }
    };
    for arg in args {
        // A file whose name holds `[` or `?` is still that file.
        if !arg.contains(['*', '?', '[']) || Path::new(arg).is_file() {
            push(PathBuf::from(arg), false);
            continue;
        }
        let paths = glob::glob(arg)
            .map_err(|e| Error::Usage(format!("`{arg}` is not a valid pattern: {e}")))?;
        let mut matched: Vec<PathBuf> = Vec::new();
        for entry in paths {
            let path = entry.map_err(|e| {
                let path = e.path().to_path_buf();
                Error::io(&path, e.into())
            })?;
            // Directories are not programs; anything else the pattern names is one to
            // check or to name as unreadable, never left out without a word.
            if !path.is_dir() {
                matched.push(path);
            }
        }
        // The glob crate passes over names that are not UTF-8.
        matched.extend(non_utf8_matches(arg).into_iter().filter(|p| !p.is_dir()));
        if matched.is_empty() {
            return Err(Error::Usage(format!("`{arg}` matches no file")));
        }
        matched.sort();
        matched.into_iter().for_each(|p| push(p, true));
    }
    if files.is_empty() {
        return Err(Error::Usage("no program to check".into()));
    }
    Ok(files)
}

/// The file at `path` is a FIFO or a socket.
pub fn not_regular(path: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        std::fs::metadata(path).is_ok_and(|m| m.file_type().is_fifo() || m.file_type().is_socket())
    }
    #[cfg(not(unix))]
    {
        let _ = path;
        false
    }
}

/// The paths `pattern` matches whose names are not UTF-8 (which `glob::glob` never
/// yields): the directories under the pattern's literal start are walked as deep as the
/// pattern reaches (`**`: any depth, symbolic links to directories not followed), and a
/// path is matched by its text with each bad byte replaced by U+FFFD.
fn non_utf8_matches(pattern: &str) -> Vec<PathBuf> {
    let Ok(matcher) = glob::Pattern::new(pattern) else {
        return Vec::new();
    };
    let options = glob::MatchOptions {
        case_sensitive: true,
        require_literal_separator: true,
        require_literal_leading_dot: false,
    };
    let components: Vec<&std::ffi::OsStr> = Path::new(pattern).iter().collect();
    let literal = components
        .iter()
        .take_while(|c| !c.to_string_lossy().contains(['*', '?', '[']))
        .count();
    let base: PathBuf = components[..literal].iter().collect();
    let rest = &components[literal..];
    let depth = if rest.iter().any(|c| c.to_string_lossy().contains("**")) {
        usize::MAX
    } else {
        rest.len()
    };
    let mut found = Vec::new();
    // (directory, its depth below `base`)
    let mut todo = vec![(base, 0usize)];
    while let Some((dir, level)) = todo.pop() {
        if level >= depth {
            continue;
        }
        let listing = if dir.as_os_str().is_empty() {
            std::fs::read_dir(".")
        } else {
            std::fs::read_dir(&dir)
        };
        let Ok(listing) = listing else { continue };
        for entry in listing.flatten() {
            let path = dir.join(entry.file_name());
            let is_dir = entry.file_type().is_ok_and(|t| t.is_dir());
            if path.to_str().is_none() && matcher.matches_with(&path.to_string_lossy(), options) {
                found.push(path.clone());
            }
            if is_dir {
                todo.push((path, level + 1));
            }
        }
    }
    found
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn patterns_expand_sorted_and_paths_stay_as_given() {
        let dir = tempfile::tempdir().unwrap();
        for name in ["b.nc", "a.nc", "c.txt", "odd[1].nc"] {
            std::fs::write(dir.path().join(name), "G0 X1\n").unwrap();
        }
        std::fs::create_dir(dir.path().join("sub.nc")).unwrap();
        let d = dir.path().display();
        let got = expand(&[
            format!("{d}/missing.nc"),
            format!("{d}/*.nc"),
            format!("{d}/a.nc"),
        ])
        .unwrap();
        let names: Vec<String> = got
            .iter()
            .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
            .collect();
        // Directories are not programs; a file named twice is checked once.
        assert_eq!(names, ["missing.nc", "a.nc", "b.nc", "odd[1].nc"]);
        let err = expand(&[format!("{d}/*.tap")]).unwrap_err();
        assert!(err.to_string().ends_with("matches no file"), "{err}");
        assert!(expand(&[format!("{d}/[.nc")]).is_err());
        let odd = expand(&[format!("{d}/odd[1].nc")]).unwrap();
        assert!(odd[0].ends_with("odd[1].nc"), "{odd:?}");
    }
}
