//! Output is all or nothing (docs/robustness.md): a run that is killed, that fails at its
//! last block or that cannot read its input leaves the destination as it was and no
//! temporary file behind (one killed hard leaves one, which the next run removes).

mod common;
use common::cli::scratch;

use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

#[path = "../benches/common/program.rs"]
mod program;

const M: &str = "fixtures/ac_trunnion.machine.toml";
const E: &str = "fixtures/ac_trunnion.errors.toml";

fn command(args: &[&str]) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_nccomp"));
    c.args(args).current_dir(env!("CARGO_MANIFEST_DIR"));
    c
}

fn nccomp(args: &[&str]) -> Output {
    command(args).output().unwrap()
}

/// The files in `dir` other than `keep`.
fn others(dir: &Path, keep: &[&Path]) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| !keep.contains(&p.as_path()))
        .map(|p| p.display().to_string())
        .collect()
}

fn compensate_to(input: &Path, output: &Path) -> Command {
    command(&[
        "compensate",
        "-q",
        "-m",
        M,
        "-e",
        E,
        input.to_str().unwrap(),
        "-o",
        output.to_str().unwrap(),
    ])
}

#[test]
fn a_killed_run_leaves_the_destination_as_it_was() {
    let dir = scratch("kill");
    let input = dir.join("big.nc");
    std::fs::write(&input, program::program(200_000)).unwrap();
    let dest = dir.join("part.nc");
    std::fs::write(&dest, "old program\n").unwrap();
    let mut child = compensate_to(&input, &dest)
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    // Kill it once it is writing its temporary file.
    let start = Instant::now();
    let temporary = loop {
        let found = others(&dir, &[&input, &dest]);
        if let Some(t) = found.first() {
            break t.clone();
        }
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "no temporary file"
        );
        assert!(
            child.try_wait().unwrap().is_none(),
            "finished before it could be killed"
        );
        std::thread::sleep(Duration::from_millis(5));
    };
    std::thread::sleep(Duration::from_millis(100));
    child.kill().unwrap();
    assert!(!child.wait().unwrap().success());
    assert_eq!(std::fs::read(&dest).unwrap(), b"old program\n");
    let name = Path::new(&temporary).file_name().unwrap().to_str().unwrap();
    assert!(name.starts_with(".part.nc.nccomp-"), "{name}");
    assert!(name.ends_with(".tmp"), "{name}");
    // The next run to the same destination removes what the killed one left.
    let small = dir.join("small.nc");
    std::fs::write(&small, "G0 X1 Y2 Z30 A0 C0\nG1 X5 A10 F100\n").unwrap();
    let out = compensate_to(&small, &dest).output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(others(&dir, &[&input, &dest, &small]), Vec::<String>::new());
    assert!(std::fs::read_to_string(&dest).unwrap().starts_with("G0 X"));
}

#[test]
fn an_error_at_the_last_line_writes_nothing() {
    let dir = scratch("last");
    let input = dir.join("bad.nc");
    let mut src = program::program(20_000);
    // Before the program's end (the blocks after M30 do not run, and pass unchanged).
    assert!(src.ends_with(b"M30\n%\n"));
    src.truncate(src.len() - b"M30\n%\n".len());
    src.extend_from_slice(b"G1 X0 Y0 Z10 A-200 C0\n");
    std::fs::write(&input, &src).unwrap();
    let lines = src.iter().filter(|&&b| b == b'\n').count();
    // To a file: the existing one stays, no temporary file is left.
    let dest = dir.join("part.nc");
    std::fs::write(&dest, "old program\n").unwrap();
    let out = compensate_to(&input, &dest).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains(&format!("bad.nc:{lines}:")) && err.contains("outside its travel"),
        "{err}"
    );
    assert_eq!(std::fs::read(&dest).unwrap(), b"old program\n");
    assert_eq!(others(&dir, &[&input, &dest]), Vec::<String>::new());
    // To standard output: nothing.
    let out = nccomp(&["compensate", "-m", M, "-e", E, input.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        out.stdout.is_empty(),
        "{} bytes on stdout",
        out.stdout.len()
    );
}

#[test]
fn a_read_error_is_reported_not_panicked() {
    // A directory opens but cannot be read.
    let dir = scratch("read");
    let dest = dir.join("part.nc");
    let out = compensate_to(&dir, &dest).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains(dir.to_str().unwrap()), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    assert!(!dest.exists());
    assert_eq!(others(&dir, &[]), Vec::<String>::new());
}

#[test]
fn a_large_program_streams_to_the_same_bytes_as_standard_output() {
    let dir = scratch("same");
    let input = dir.join("p.nc");
    std::fs::write(&input, program::program(30_000)).unwrap();
    let dest = dir.join("p.comp.nc");
    let out = compensate_to(&input, &dest).output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let piped = nccomp(&[
        "compensate",
        "-q",
        "-m",
        M,
        "-e",
        E,
        input.to_str().unwrap(),
    ]);
    assert!(piped.status.success());
    assert!(std::fs::read(&dest).unwrap() == piped.stdout);
    assert!(piped.stdout.len() > 1_500_000);
}
