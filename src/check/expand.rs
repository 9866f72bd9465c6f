//! Program arguments to files: paths as they are, glob patterns expanded here, so
//! `nccomp check 'programs/**/*.nc'` works without a shell (CI runners, Windows).

use crate::diag::Error;
use std::path::{Path, PathBuf};

/// The files named by `args`, in order, each once. An argument with `*`, `?` or `[` that
/// is not the name of a file is a glob pattern (`**` crosses directories) and must match
/// at least one file; its matches come sorted. Any other argument is taken as a path,
/// whether it exists or not (a missing file is reported when it is read).
pub fn expand(args: &[String]) -> crate::Result<Vec<PathBuf>> {
    let mut files: Vec<PathBuf> = Vec::new();
    let mut push = |p: PathBuf| {
        if !files.contains(&p) {
            files.push(p);
        }
    };
    for arg in args {
        // A file whose name holds `[` or `?` is still that file.
        if !arg.contains(['*', '?', '[']) || Path::new(arg).is_file() {
            push(PathBuf::from(arg));
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
            if path.is_file() {
                matched.push(path);
            }
        }
        if matched.is_empty() {
            return Err(Error::Usage(format!("`{arg}` matches no file")));
        }
        matched.sort();
        matched.into_iter().for_each(&mut push);
    }
    if files.is_empty() {
        return Err(Error::Usage("no program to check".into()));
    }
    Ok(files)
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
