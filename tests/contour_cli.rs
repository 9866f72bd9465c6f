//! What a user types: `nccomp contour ...`, its exit codes, its messages and its files.

use nccomp::contour::s_shape::{Finishing, SShape, finishing_program};
use nccomp::model::machine_file;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn nccomp(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_nccomp"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap()
}

fn stdout(out: &Output) -> String {
    String::from_utf8_lossy(&out.stdout).into_owned()
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("nccomp-contour-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The run failed with `message` at `place` (`file:line:column`), as nccomp prints it.
fn refused(out: &Output, place: &str, message: &str) {
    let err = stderr(out);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.starts_with(&format!("error: {message}")), "{err}");
    assert!(err.contains(&format!(" --> {place}\n")), "{err}");
}

fn write(dir: &Path, name: &str, text: &str) -> String {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path.to_str().unwrap().to_string()
}

const MACHINE: &str = "fixtures/ac_trunnion.machine.toml";
const PROGRAM: &str = "fixtures/s_shape.nc";
const TRACE: &str = "fixtures/s_shape.trace.csv";

#[test]
fn the_s_shape_fixture_is_what_the_generator_writes() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let machine = machine_file::load(&root.join(MACHINE)).unwrap();
    let program = finishing_program(&machine, &SShape::paper(), &Finishing::default()).unwrap();
    let fixture = std::fs::read_to_string(root.join(PROGRAM)).unwrap();
    assert!(program == fixture, "run `cargo run --example s_shape`");
}

#[test]
fn the_s_shape_trace_gives_a_summary_points_and_a_plot() {
    let dir = scratch("fixture");
    let csv = dir.join("points.csv");
    let svg = dir.join("contour.svg");
    let out = nccomp(&[
        "contour",
        "-m",
        MACHINE,
        PROGRAM,
        "--trace",
        TRACE,
        "-o",
        csv.to_str().unwrap(),
        "--plot",
        svg.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let summary = stdout(&out);
    insta::assert_snapshot!("s_shape_summary", summary);
    let points = std::fs::read_to_string(&csv).unwrap();
    let mut lines = points.lines();
    assert_eq!(
        lines.next().unwrap(),
        "line,s,along_mm,x_mm,y_mm,z_mm,time_s,tip_error_um,ex_um,ey_um,ez_um,axis_error_urad,cmd_tip_error_um,cmd_axis_error_urad"
    );
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|f| f.parse().unwrap()).collect())
        .collect();
    assert!(summary.contains(&format!(": {} points reported", rows.len())));
    // The error vector's length is the tip error; the largest is the summary's.
    for r in &rows {
        let e = (r[8] * r[8] + r[9] * r[9] + r[10] * r[10]).sqrt();
        assert!((e - r[7]).abs() < 2e-4, "{r:?}");
    }
    let max = rows.iter().map(|r| r[7]).fold(0.0, f64::max);
    assert!(summary.contains(&format!("max {:.3} µm", max)), "{max}");
    let svg = std::fs::read_to_string(&svg).unwrap();
    assert!(svg.starts_with("<svg"));
    assert!(svg.contains("tool-tip contour error (µm)"));
    assert!(svg.contains("tool-axis contour error (µrad)"));
}

#[test]
fn points_go_to_standard_output_and_the_summary_to_standard_error() {
    let out = nccomp(&[
        "contour", "-m", MACHINE, PROGRAM, "--trace", TRACE, "-o", "-", "--rapids",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(stdout(&out).starts_with("line,s,along_mm,"));
    assert!(stdout(&out).lines().next().unwrap().ends_with(",rapid"));
    // The approach and the retract are rapids, reported with --rapids.
    assert!(stdout(&out).lines().any(|l| l.ends_with(",1")));
    assert!(stderr(&out).starts_with("contour error of fixtures/s_shape.nc"));
}

#[test]
fn a_bad_trace_is_reported_at_its_place() {
    let dir = scratch("bad");
    let missing = write(&dir, "missing.csv", "time,X,Y,Z,A\n0,1,2,3,4\n");
    let out = nccomp(&["contour", "-m", MACHINE, PROGRAM, "--trace", &missing]);
    refused(
        &out,
        &format!("{missing}:1:13"),
        "the trace has no column for `C` (expected the columns time, X, Y, Z, A, C",
    );
    let text = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join(TRACE))
        .unwrap()
        .replacen("\n0.030000,-77.", "\n0.030000,-77.x", 1);
    let bad = write(&dir, "bad.csv", &text);
    let out = nccomp(&["contour", "-m", MACHINE, PROGRAM, "--trace", &bad]);
    refused(&out, &format!("{bad}:7:10"), "`X` is `-77.x678700`");
}

#[test]
fn a_trace_of_another_program_is_refused_at_the_block_it_misses() {
    let dir = scratch("other");
    let program = write(
        &dir,
        "other.nc",
        "G21 G90\nG0 X100 Y0 Z50 A-10 C0\nG1 X120 F500\nM30\n",
    );
    let out = nccomp(&["contour", "-m", MACHINE, &program, "--trace", TRACE]);
    refused(
        &out,
        &format!("{program}:2:1"),
        "the trace never comes within 1 mm of where this move ends",
    );
}

#[test]
fn bad_options_and_programs_are_refused() {
    let out = nccomp(&[
        "contour", "-m", MACHINE, PROGRAM, "--trace", TRACE, "--step", "0",
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(stderr(&out).contains("--step 0: expected a positive length in mm"));
    let dir = scratch("tcp");
    let program = write(
        &dir,
        "tcp.nc",
        "G21 G90\nG43.4 H1\nG1 X10 Y0 Z5 A-10 C0 F500\n",
    );
    let out = nccomp(&["contour", "-m", MACHINE, &program, "--trace", TRACE]);
    refused(
        &out,
        &format!("{program}:3:4"),
        "a tool-centre-point block (G43.4/G43.5) cannot be followed",
    );
}
