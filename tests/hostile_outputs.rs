//! Hostile output paths and process conditions on the command line (issue 22, items 3, 4
//! and 8): an output that is an input, a symlink, a FIFO, a device or standard output as
//! the output, outputs written all or nothing, closed standard streams, signals and
//! `ulimit -f`, temporary files of other runs, and the mode of new files.

#![cfg(unix)]

mod common;
use common::cli::{nccomp, scratch, stderr};

use std::os::unix::fs::{FileTypeExt, MetadataExt, PermissionsExt};
use std::os::unix::process::ExitStatusExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

#[path = "../benches/common/program.rs"]
mod program;

const M: &str = "fixtures/ac_trunnion.machine.toml";
const E: &str = "fixtures/ac_trunnion.errors.toml";
const PROGRAM: &str = "fixtures/ac_trunnion_g91.nc";

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// A copy of the demo program in `dir`.
fn program_in(dir: &Path) -> PathBuf {
    let p = dir.join("p.nc");
    std::fs::copy(root().join(PROGRAM), &p).unwrap();
    p
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// `compensate -q` of the demo program to `output`.
fn compensate_to(output: &str) -> Output {
    nccomp(&["compensate", "-q", "-m", M, "-e", E, PROGRAM, "-o", output])
}

/// `simulate-cut` of the feature workpiece, writing its two CSV files.
fn simulate_cut(on_machine: &str, cmm: &str) -> Output {
    nccomp(&[
        "simulate-cut",
        "-m",
        M,
        "--plan",
        "fixtures/feature_workpiece.plan.toml",
        "--program",
        "fixtures/feature_workpiece.nc",
        "-e",
        E,
        "--on-machine",
        on_machine,
        "--cmm",
        cmm,
    ])
}

/// What `compensate` writes for the demo program (to standard output).
fn compensated() -> Vec<u8> {
    let out = nccomp(&["compensate", "-q", "-m", M, "-e", E, PROGRAM]);
    assert!(out.status.success(), "{}", stderr(&out));
    out.stdout
}

/// `sh -c script` from the crate's directory, `$NCCOMP` being the binary.
fn sh(script: &str) -> Output {
    Command::new("sh")
        .arg("-c")
        .arg(script)
        .env("NCCOMP", env!("CARGO_BIN_EXE_nccomp"))
        .current_dir(root())
        .output()
        .unwrap()
}

/// The files in `dir` whose names end in `.tmp`.
fn temporaries(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".tmp"))
        .collect()
}

#[track_caller]
fn refused_as_same_file(out: &Output, says: &str) {
    let err = stderr(out);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains(says), "expected {says:?} in: {err}");
    assert!(
        err.contains("nccomp never writes over one of its inputs"),
        "{err}"
    );
}

#[test]
fn an_output_that_is_an_input_is_refused_before_anything_is_written() {
    let dir = scratch("same-file");
    let p = program_in(&dir);
    let before = std::fs::read(&p).unwrap();
    // The program itself, by another name (a hard link), and through standard input.
    let out = nccomp(&["compensate", "-m", M, "-e", E, s(&p), "-o", s(&p)]);
    refused_as_same_file(
        &out,
        &format!("`-o {0}` is the same file as the program {0}", s(&p)),
    );
    let hard = dir.join("hard.nc");
    std::fs::hard_link(&p, &hard).unwrap();
    let out = nccomp(&["compensate", "-m", M, "-e", E, s(&p), "-o", s(&hard)]);
    refused_as_same_file(
        &out,
        &format!(
            "`-o {}` is the same file as the program {}",
            s(&hard),
            s(&p)
        ),
    );
    let out = sh(&format!(
        "\"$NCCOMP\" compensate -m {M} -e {E} -o {0} < {0}",
        s(&p)
    ));
    refused_as_same_file(&out, "is the same file as the program (standard input)");
    assert_eq!(
        std::fs::read(&p).unwrap(),
        before,
        "the program was changed"
    );
    // The calibration and the machine file.
    let errors = dir.join("e.toml");
    std::fs::copy(root().join(E), &errors).unwrap();
    let out = nccomp(&[
        "compensate",
        "-m",
        M,
        "-e",
        s(&errors),
        PROGRAM,
        "-o",
        s(&errors),
    ]);
    refused_as_same_file(&out, "is the same file as the error file");
    assert_eq!(
        std::fs::read(&errors).unwrap(),
        std::fs::read(root().join(E)).unwrap()
    );
    let out = nccomp(&["report", "-m", M, "-e", E, PROGRAM, "-o", M]);
    refused_as_same_file(&out, "is the same file as the machine file");
    // Every command that writes: errors convert, contour, probe, simulate-cut, sensitivity.
    let isg = dir.join("isg.csv");
    std::fs::copy(root().join("fixtures/import/ac_trunnion.isg.csv"), &isg).unwrap();
    let out = nccomp(&["errors", "convert", s(&isg), "-o", s(&isg)]);
    refused_as_same_file(&out, "is the same file as the calibration file");
    let out = nccomp(&[
        "contour",
        "-m",
        M,
        "fixtures/s_shape.nc",
        "--trace",
        "fixtures/s_shape.trace.csv",
        "-o",
        "fixtures/s_shape.trace.csv",
    ]);
    refused_as_same_file(&out, "is the same file as the trace");
    let out = nccomp(&[
        "probe",
        "--tau",
        "12.68",
        "--map",
        "fixtures/probe_map.csv",
        "--plot",
        "fixtures/probe_map.csv",
    ]);
    refused_as_same_file(&out, "is the same file as the direction map");
    let out = nccomp(&[
        "sensitivity",
        "-m",
        "fixtures/grinder.machine.toml",
        "-b",
        "fixtures/grinder.budget.toml",
        "--svg",
        "fixtures/grinder.budget.toml",
    ]);
    refused_as_same_file(&out, "is the same file as the budget file");
    let out = simulate_cut("fixtures/feature_workpiece.nc", s(&dir.join("cmm.csv")));
    refused_as_same_file(&out, "is the same file as the program");
    // Two outputs of one command on one file.
    let twice = dir.join("twice.csv");
    let out = simulate_cut(s(&twice), s(&twice));
    assert_eq!(out.status.code(), Some(2));
    assert!(
        stderr(&out).contains(&format!(
            "`--cmm {0}` and `--on-machine {0}` are the same file",
            s(&twice)
        )),
        "{}",
        stderr(&out)
    );
    assert!(!twice.exists());
    assert_eq!(temporaries(&dir), Vec::<String>::new());
}

#[test]
fn a_symlink_is_written_through_and_stays_a_symlink() {
    let dir = scratch("symlink");
    let target = dir.join("target.nc");
    std::fs::write(&target, "old\n").unwrap();
    std::fs::set_permissions(&target, std::fs::Permissions::from_mode(0o640)).unwrap();
    let link = dir.join("link.nc");
    std::os::unix::fs::symlink("target.nc", &link).unwrap();
    let out = compensate_to(s(&link));
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(
        std::fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink()
    );
    assert_eq!(std::fs::read(&target).unwrap(), compensated());
    // The target keeps its mode.
    assert_eq!(std::fs::metadata(&target).unwrap().mode() & 0o777, 0o640);
    // A dangling symlink: the file it names is made.
    let dangling = dir.join("dangling.nc");
    std::os::unix::fs::symlink("made.nc", &dangling).unwrap();
    let out = compensate_to(s(&dangling));
    assert!(out.status.success(), "{}", stderr(&out));
    assert_eq!(std::fs::read(dir.join("made.nc")).unwrap(), compensated());
    assert!(
        std::fs::symlink_metadata(&dangling)
            .unwrap()
            .file_type()
            .is_symlink()
    );
    // A symlink to the input is the input.
    let to_input = dir.join("to_input.nc");
    std::os::unix::fs::symlink(root().join(PROGRAM), &to_input).unwrap();
    let out = nccomp(&["compensate", "-m", M, "-e", E, PROGRAM, "-o", s(&to_input)]);
    refused_as_same_file(&out, "is the same file as the program");
    assert_eq!(temporaries(&dir), Vec::<String>::new());
}

#[test]
fn a_fifo_a_device_and_standard_output_are_written_as_streams() {
    let dir = scratch("streams");
    let fifo = dir.join("fifo");
    assert!(
        Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .unwrap()
            .success()
    );
    let reader = std::thread::spawn({
        let fifo = fifo.clone();
        move || std::fs::read(fifo).unwrap()
    });
    let out = compensate_to(s(&fifo));
    assert!(out.status.success(), "{}", stderr(&out));
    assert_eq!(reader.join().unwrap(), compensated());
    assert!(std::fs::metadata(&fifo).unwrap().file_type().is_fifo());
    // A character device stays one.
    let out = compensate_to("/dev/null");
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(
        std::fs::metadata("/dev/null")
            .unwrap()
            .file_type()
            .is_char_device()
    );
    // /dev/stdout is standard output, appended to as the shell set it up.
    let log = dir.join("log.nc");
    std::fs::write(&log, "before\n").unwrap();
    let out = sh(&format!(
        "\"$NCCOMP\" compensate -q -m {M} -e {E} {PROGRAM} -o /dev/stdout >> {}",
        s(&log)
    ));
    assert!(out.status.success(), "{}", stderr(&out));
    let mut expected = b"before\n".to_vec();
    expected.extend(compensated());
    assert_eq!(std::fs::read(&log).unwrap(), expected);
    // A directory is no output.
    let out = nccomp(&["compensate", "-m", M, "-e", E, PROGRAM, "-o", s(&dir)]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        stderr(&out).contains(
            "the output is a directory: expected a file, a FIFO, a character device or `-`"
        ),
        "{}",
        stderr(&out)
    );
    assert_eq!(temporaries(&dir), Vec::<String>::new());
}

#[test]
fn outputs_of_one_command_are_written_all_or_nothing() {
    let dir = scratch("all-or-nothing");
    // The plot could be written, the program could not: neither is.
    let plot = dir.join("map.svg");
    let out = nccomp(&[
        "probe",
        "--ring",
        "fixtures/probe_ring.csv",
        "--map",
        "fixtures/probe_map.csv",
        "--surface",
        "outside",
        "fixtures/probe_demo.nc",
        "-o",
        s(&dir.join("no such dir/p.nc")),
        "--plot",
        s(&plot),
    ]);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(stderr(&out).contains("does not exist"), "{}", stderr(&out));
    assert!(!plot.exists(), "the plot was written without the program");
    // contour: plot and points likewise.
    let out = nccomp(&[
        "contour",
        "-m",
        M,
        "fixtures/s_shape.nc",
        "--trace",
        "fixtures/s_shape.trace.csv",
        "--plot",
        s(&plot),
        "-o",
        s(&dir.join("no such dir/points.csv")),
    ]);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(!plot.exists(), "the plot was written without the points");
    assert_eq!(temporaries(&dir), Vec::<String>::new());
}

#[test]
fn new_files_follow_the_umask_and_replaced_files_keep_their_mode() {
    let dir = scratch("modes");
    let out = sh(&format!(
        "umask 027; \"$NCCOMP\" compensate -q -m {M} -e {E} {PROGRAM} -o {0}/new.nc && umask 002 && \"$NCCOMP\" probe --tau 12.68 --map fixtures/probe_map.csv --plot {0}/map.svg",
        s(&dir)
    ));
    assert!(out.status.success(), "{}", stderr(&out));
    let mode = |name: &str| std::fs::metadata(dir.join(name)).unwrap().mode() & 0o777;
    assert_eq!(mode("new.nc"), 0o640);
    assert_eq!(mode("map.svg"), 0o664);
    std::fs::set_permissions(dir.join("new.nc"), std::fs::Permissions::from_mode(0o600)).unwrap();
    let out = compensate_to(s(&dir.join("new.nc")));
    assert!(out.status.success());
    assert_eq!(mode("new.nc"), 0o600);
}

#[test]
fn a_closed_standard_stream_is_exit_2_never_a_lost_program_or_a_crash() {
    let dir = scratch("closed");
    // Closed standard output: nothing is done, and it is said.
    let out = sh(&format!(
        "\"$NCCOMP\" compensate -m {M} -e {E} {PROGRAM} >&-"
    ));
    assert_eq!(out.status.code(), Some(2));
    assert!(
        stderr(&out).contains("standard output is closed"),
        "{}",
        stderr(&out)
    );
    // Closed standard error: nothing is done (nothing could be said).
    let dest = dir.join("out.nc");
    let out = sh(&format!(
        "\"$NCCOMP\" compensate -m {M} -e {E} {PROGRAM} -o {} 2>&-",
        s(&dest)
    ));
    assert_eq!(out.status.code(), Some(2));
    assert!(!dest.exists());
    // /dev/null is not closed: the summary goes nowhere, as asked.
    let out = sh(&format!(
        "\"$NCCOMP\" compensate -m {M} -e {E} {PROGRAM} -o {} 2>/dev/null",
        s(&dest)
    ));
    assert_eq!(out.status.code(), Some(0));
    // A reader that went away before nccomp wrote: exit 2, not a panic (101).
    let out = Command::new(env!("CARGO_BIN_EXE_nccomp"))
        .args(["compensate", "-m", M, "-e", E, PROGRAM])
        .current_dir(root())
        .stdout(closed_pipe())
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("<stdout>: Broken pipe"),
        "{}",
        stderr(&out)
    );
    // Standard error whose reader went away, after the output was written: exit 2.
    let out = Command::new(env!("CARGO_BIN_EXE_nccomp"))
        .args(["compensate", "-m", M, "-e", E, PROGRAM, "-o", s(&dest)])
        .current_dir(root())
        .stderr(closed_pipe())
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2), "{out:?}");
    assert_eq!(std::fs::read(&dest).unwrap(), compensated());
}

/// The writing end of a pipe whose reader is gone.
fn closed_pipe() -> Stdio {
    let (reader, writer) = std::io::pipe().unwrap();
    drop(reader);
    writer.into()
}

/// Start `compensate` of a long program into `dest` and wait until its temporary file is
/// there: the child and the temporary file's name.
fn started(dir: &Path, dest: &Path) -> (std::process::Child, String) {
    let input = dir.join("big.nc");
    if !input.exists() {
        std::fs::write(&input, program::program(200_000)).unwrap();
    }
    let mut child = Command::new(env!("CARGO_BIN_EXE_nccomp"))
        .args([
            "compensate",
            "-q",
            "-m",
            M,
            "-e",
            E,
            s(&input),
            "-o",
            s(dest),
        ])
        .current_dir(root())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let start = Instant::now();
    loop {
        if let Some(t) = temporaries(dir).into_iter().next() {
            return (child, t);
        }
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "no temporary file"
        );
        assert!(
            child.try_wait().unwrap().is_none(),
            "finished before its temporary file was seen"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
}

#[test]
fn sigint_sigterm_and_sighup_remove_the_temporary_file() {
    let dir = scratch("signals");
    let dest = dir.join("part.nc");
    std::fs::write(&dest, "old program\n").unwrap();
    for (signal, number) in [("INT", 2), ("TERM", 15), ("HUP", 1)] {
        let (mut child, temporary) = started(&dir, &dest);
        assert!(temporary.starts_with(".part.nc.nccomp-"), "{temporary}");
        std::thread::sleep(Duration::from_millis(50));
        let kill = Command::new("kill")
            .args([format!("-{signal}"), child.id().to_string()])
            .status()
            .unwrap();
        assert!(kill.success());
        let status = child.wait().unwrap();
        assert_eq!(status.signal(), Some(number), "{signal}: {status:?}");
        assert_eq!(temporaries(&dir), Vec::<String>::new(), "{signal}");
        assert_eq!(std::fs::read(&dest).unwrap(), b"old program\n");
    }
}

#[test]
fn a_file_size_limit_is_a_write_error_that_leaves_no_temporary_file() {
    let dir = scratch("ulimit");
    let input = dir.join("big.nc");
    std::fs::write(&input, program::program(20_000)).unwrap();
    let dest = dir.join("part.nc");
    // ulimit -f counts 512-byte blocks in sh: 100 KiB.
    let out = sh(&format!(
        "ulimit -f 200; exec \"$NCCOMP\" compensate -q -m {M} -e {E} {} -o {}",
        s(&input),
        s(&dest)
    ));
    assert_eq!(out.status.code(), Some(2), "{out:?}");
    assert!(
        stderr(&out).contains(&format!("{}: File too large", s(&dest))),
        "{}",
        stderr(&out)
    );
    assert!(!dest.exists());
    assert_eq!(temporaries(&dir), Vec::<String>::new());
}

#[test]
fn a_run_never_removes_a_temporary_file_another_run_holds() {
    let dir = scratch("live");
    let dest = dir.join("part.nc");
    // A temporary file named for a process that is gone, but held (locked) by a live
    // one: a run in another PID namespace, as in a container sharing the directory.
    let held = dir.join(".part.nc.nccomp-4194304-AbC123.tmp");
    std::fs::write(&held, "being written\n").unwrap();
    let lock = std::fs::File::open(&held).unwrap();
    lock.lock().unwrap();
    // And the temporary file of another output whose name starts the same.
    let other = dir.join(".part.nc.nccomp-4194304-x.nccomp-4194305-Zz9Yy8.tmp");
    std::fs::write(&other, "another output's\n").unwrap();
    let out = compensate_to(s(&dest));
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(held.exists(), "a held temporary file was removed");
    assert!(
        other.exists(),
        "another output's temporary file was removed"
    );
    // Once nobody holds it, it is what a killed run left: the next run removes it.
    drop(lock);
    let out = compensate_to(s(&dest));
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(!held.exists(), "a stale temporary file stayed");
    assert!(other.exists());
}

#[test]
fn probe_reports_to_a_closed_pipe_with_exit_2() {
    let out = Command::new(env!("CARGO_BIN_EXE_nccomp"))
        .args(["probe", "--ring", "fixtures/probe_ring.csv"])
        .current_dir(root())
        .stdout(closed_pipe())
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("<stdout>: Broken pipe"),
        "{}",
        stderr(&out)
    );
}
