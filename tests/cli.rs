//! What a user types: `nccomp compensate ...`, its exit codes, its messages and its files.

mod common;
use common::cli::{nccomp, scratch, stderr};

use std::io::Write;
use std::path::Path;
use std::process::{Command, Output, Stdio};

fn nccomp_stdin(args: &[&str], input: &[u8]) -> Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_nccomp"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    child.stdin.take().unwrap().write_all(input).unwrap();
    child.wait_with_output().unwrap()
}

const M: &str = "fixtures/ac_trunnion.machine.toml";
const E: &str = "fixtures/ac_trunnion.errors.toml";

#[test]
fn compensates_the_feature_workpiece_into_a_file() {
    let dir = scratch("fw");
    let out_path = dir.join("fw.comp.nc");
    let out = nccomp(&[
        "compensate",
        "--machine",
        M,
        "--errors",
        E,
        "fixtures/feature_workpiece.nc",
        "-o",
        out_path.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(out.stdout.is_empty());
    let err = stderr(&out);
    assert!(err.contains("motion blocks compensated"), "{err}");
    assert!(err.contains("predicted tip error"), "{err}");
    let written = std::fs::read_to_string(&out_path).unwrap();
    let input = std::fs::read_to_string("fixtures/feature_workpiece.nc").unwrap();
    // The default path tolerance (1 µm) splits moves; the summary counts the new blocks.
    let added: usize = err
        .lines()
        .find_map(|l| {
            l.split(": ")
                .nth(1)?
                .strip_suffix(" blocks added")?
                .parse()
                .ok()
        })
        .unwrap_or_else(|| panic!("no count of added blocks in the summary:\n{err}"));
    assert!(added > 0);
    assert_eq!(written.lines().count(), input.lines().count() + added);
    assert_ne!(written, input);
    // Nothing but the output is left in the directory.
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);

    // `--tolerance off`: one block out for every block in.
    let out = nccomp(&[
        "compensate",
        "--machine",
        M,
        "--errors",
        E,
        "fixtures/feature_workpiece.nc",
        "--tolerance",
        "off",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(!stderr(&out).contains("blocks added"));
    let one_to_one = String::from_utf8(out.stdout).unwrap();
    assert_eq!(one_to_one.lines().count(), input.lines().count());
}

#[test]
fn a_bad_tolerance_is_a_usage_error() {
    for bad in ["0", "-1", "1e", "none"] {
        let flag = format!("--tolerance={bad}");
        let out = nccomp(&["compensate", "-m", M, "-e", E, &flag, "x.nc"]);
        assert_eq!(out.status.code(), Some(2), "--tolerance {bad}");
        let err = stderr(&out);
        assert!(err.contains("expected a positive distance in mm"), "{err}");
    }
}

#[test]
fn reads_standard_input_and_writes_standard_output() {
    let program = std::fs::read("fixtures/bc_trunnion_demo.nc").unwrap();
    let out = nccomp_stdin(
        &[
            "compensate",
            "-m",
            "fixtures/bc_trunnion.machine.toml",
            "-e",
            "fixtures/bc_trunnion.errors.toml",
        ],
        &program,
    );
    assert!(out.status.success(), "{}", stderr(&out));
    assert_eq!(
        String::from_utf8_lossy(&out.stdout).lines().count(),
        String::from_utf8_lossy(&program).lines().count()
    );
    assert!(stderr(&out).starts_with("<stdin>: "));
}

#[test]
fn a_zero_error_model_gives_every_fixture_program_back_byte_for_byte() {
    let dir = scratch("zero");
    let zero = dir.join("zero.errors.toml");
    std::fs::write(&zero, "length_unit = \"um\"\nangle_unit = \"urad\"\n").unwrap();
    for (machine, program) in [
        ("ac_trunnion", "feature_workpiece"),
        ("bc_trunnion", "bc_trunnion_demo"),
        ("head_head", "head_head_demo"),
        ("grinder", "grinder_demo"),
        ("mill_turn", "mill_turn_turning"),
        ("mill_turn", "mill_turn_milling"),
    ] {
        let input = format!("fixtures/{program}.nc");
        let out = nccomp(&[
            "compensate",
            "-m",
            &format!("fixtures/{machine}.machine.toml"),
            "-e",
            zero.to_str().unwrap(),
            &input,
        ]);
        assert!(out.status.success(), "{}", stderr(&out));
        assert_eq!(out.stdout, std::fs::read(&input).unwrap(), "{program}");
    }
}

/// Run compensate on bad input and return (exit code, stderr).
fn fails(args: &[&str]) -> (i32, String) {
    let out = nccomp(args);
    (out.status.code().unwrap_or(-1), stderr(&out))
}

/// The place a rendered diagnostic names: `error: …` then ` --> file:line:column`.
fn place(err: &str) -> (String, usize, usize) {
    let at = err
        .lines()
        .find_map(|l| l.trim_start().strip_prefix("--> "))
        .unwrap_or_else(|| panic!("no place in {err}"));
    let mut parts = at.rsplitn(3, ':');
    let column = parts.next().unwrap().parse().unwrap();
    let line = parts.next().unwrap().parse().unwrap();
    (parts.next().unwrap().to_string(), line, column)
}

fn write(dir: &Path, name: &str, text: &str) -> String {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p.to_str().unwrap().to_string()
}

#[test]
fn bad_machine_files_name_file_line_and_column() {
    let dir = scratch("badm");
    let good = std::fs::read_to_string(M).unwrap();
    let cases = [
        // Unknown key.
        (
            good.replace("travel = [-120, 30]", "travl = [-120, 30]"),
            "unknown key",
        ),
        // An axis named in a chain but not defined.
        (
            good.replace(
                "workpiece_chain = [\"Y\", \"X\", \"A\", \"C\"]",
                "workpiece_chain = [\"Y\", \"X\", \"A\", \"Q\"]",
            ),
            "Q",
        ),
        // Not TOML at all.
        (good.replace("[axes.X]", "[axes.X"), ""),
    ];
    for (i, (text, needle)) in cases.iter().enumerate() {
        let path = write(&dir, &format!("m{i}.toml"), text);
        let (code, err) = fails(&[
            "compensate",
            "-m",
            &path,
            "-e",
            E,
            "fixtures/feature_workpiece.nc",
        ]);
        assert_eq!(code, 2, "{err}");
        assert!(err.starts_with("error: "), "case {i}: {err}");
        let (file, line, column) = place(&err);
        assert_eq!(file, path, "case {i}: {err}");
        assert!(line > 0 && column > 0, "case {i}: {err}");
        assert!(err.contains(needle), "case {i}: {err}");
    }
}

#[test]
fn bad_error_files_name_file_line_and_column() {
    let dir = scratch("bade");
    let good = std::fs::read_to_string(E).unwrap();
    let cases = [
        // A misspelled error name is never silently zero.
        (good.replace("EBX = ", "EBXX = "), "EBXX"),
        (good.replace("EBX = ", "EYB = "), "EYB"),
        // Table lengths that differ.
        (
            good.replace("EBX = [0.0062, 0.0093]", "EBX = [0.0062, 0.0093, 0.01]"),
            "positions",
        ),
        // Positions not increasing.
        (
            good.replace("positions = [-50.0, 50.0]", "positions = [50.0, -50.0]"),
            "increasing",
        ),
        // A meaningless term: a shift along the C axis's own line.
        (good.replace("EX0C = 0.0023", "EZ0C = 0.0023"), "EZ0C"),
        // A term for an axis the machine does not have.
        (format!("{good}\n[location.B]\nEX0B = 1.0\n"), "B"),
    ];
    for (i, (text, needle)) in cases.iter().enumerate() {
        let path = write(&dir, &format!("e{i}.toml"), text);
        let (code, err) = fails(&[
            "compensate",
            "-m",
            M,
            "-e",
            &path,
            "fixtures/feature_workpiece.nc",
        ]);
        assert_eq!(code, 2, "{err}");
        assert_eq!(place(&err).0, path, "case {i}: {err}");
        assert!(err.contains(needle), "case {i}: {err}");
    }
}

#[test]
fn blocks_that_cannot_be_compensated_fail_without_touching_the_output() {
    let dir = scratch("badnc");
    let out_path = dir.join("out.nc");
    std::fs::write(&out_path, "OLD CONTENT\n").unwrap();
    for (program, location, needle) in [
        ("G0 X0 Y0 Z50 A0 C0\nG91 G2 X10 Y0 I5 J0\n", ":2:5\n", "arc"),
        ("G92 X0\n", ":1:1\n", "G92"),
        ("G1 X[#1 + 2]\n", ":1:4\n", "expression"),
        ("G43.1 Z2\n", ":1:1\n", "a dynamic tool length offset"),
    ] {
        let input = write(&dir, "in.nc", program);
        let (code, err) = fails(&[
            "compensate",
            "-m",
            M,
            "-e",
            E,
            &input,
            "-o",
            out_path.to_str().unwrap(),
        ]);
        assert_eq!(code, 2, "{err}");
        assert!(err.contains(&format!(" --> {input}{location}")), "{err}");
        assert!(err.contains(needle), "{err}");
        assert_eq!(std::fs::read_to_string(&out_path).unwrap(), "OLD CONTENT\n");
    }
    assert_eq!(
        std::fs::read_dir(&dir).unwrap().count(),
        2,
        "no temporary file is left"
    );
}

#[test]
fn missing_files_and_bad_options_exit_2() {
    let (code, err) = fails(&[
        "compensate",
        "-m",
        "nope.toml",
        "-e",
        E,
        "fixtures/feature_workpiece.nc",
    ]);
    assert_eq!(code, 2);
    assert!(err.contains("nope.toml"), "{err}");
    let (code, err) = fails(&["compensate", "-m", M, "-e", E, "nope.nc"]);
    assert_eq!(code, 2);
    assert!(err.contains("nope.nc"), "{err}");
    let (code, err) = fails(&[
        "compensate",
        "-m",
        M,
        "-e",
        E,
        "--tool-chain",
        "lower",
        "fixtures/feature_workpiece.nc",
    ]);
    assert_eq!(code, 2);
    assert!(err.contains("lower"), "{err}");
    let (code, _) = fails(&["compensate", "-m", M]);
    assert_eq!(code, 2, "clap's usage errors exit 2 too");
}

#[test]
fn help_speaks_to_the_user() {
    let out = nccomp(&["compensate", "--help"]);
    assert!(out.status.success());
    let help = String::from_utf8_lossy(&out.stdout);
    for needle in [
        "--machine",
        "--errors",
        "--output",
        "Exit status",
        "standard input",
    ] {
        assert!(help.contains(needle), "{needle}: {help}");
    }
}
