//! What the CLI tests share: running the binary and a scratch directory per test.

use std::path::PathBuf;
use std::process::{Command, Output};

/// Run `nccomp` with `args` from the crate's directory (fixture paths are relative to it).
pub fn nccomp(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_nccomp"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap()
}

pub fn stdout(out: &Output) -> String {
    String::from_utf8_lossy(&out.stdout).into_owned()
}

pub fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// An empty directory for one test; the process id keeps test binaries apart.
pub fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("nccomp-test-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}
