//! What a user types: `nccomp contour ...`, its exit codes, its messages and its files.

mod common;
use common::cli::{nccomp, scratch, stderr, stdout};

use nccomp::contour::s_shape::{Finishing, SShape, finishing_program};
use nccomp::contour::simulate::{Servo, simulate};
use nccomp::kinematics::Kinematics;
use nccomp::model::{ErrorModel, machine_file};
use nccomp::program::moves::nominal_moves;
use std::path::Path;
use std::process::Output;

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
    let short = write(
        &dir,
        "short.csv",
        "time,X,Y,Z,A,C\n0,1,2,3,4,5\n0.015,1,2,3,4\n",
    );
    let out = nccomp(&["contour", "-m", MACHINE, PROGRAM, "--trace", &short]);
    refused(
        &out,
        &format!("{short}:3:1"),
        "this row has 5 fields but the header names 6 columns (expected one field per column",
    );
    let back = write(
        &dir,
        "back.csv",
        "time,X,Y,Z,A,C\n0.2,1,2,3,4,5\n0.1,1,2,3,4,5\n",
    );
    let out = nccomp(&["contour", "-m", MACHINE, PROGRAM, "--trace", &back]);
    refused(
        &out,
        &format!("{back}:3:1"),
        "time goes back here (0.1 s after 0.2 s): expected the samples in time order",
    );
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

/// The per-point CSV as rows of numbers, after its header.
fn rows(csv: &str) -> Vec<Vec<f64>> {
    csv.lines()
        .skip(1)
        .map(|l| l.split(',').map(|f| f.parse().unwrap()).collect())
        .collect()
}

/// A three-axis machine whose table carries the part (the grinder): a trace that runs 5 µm
/// beside the first straight move and 3 µm beside the second gives exactly those errors,
/// and no tool-axis error.
#[test]
fn a_trace_beside_a_three_axis_program_gives_its_offsets() {
    let dir = scratch("grinder");
    let program = write(
        &dir,
        "square.nc",
        "G21 G90\nG0 X0 Y0 Z0\nG1 X10 F600\nG1 Y5\nM30\n",
    );
    let mut trace = String::from("time,X,Y,Z\n");
    let mut time = 0.0;
    let mut sample = |x: f64, y: f64| {
        trace += &format!("{time:.3},{x:.4},{y:.4},0\n");
        time += 0.01;
    };
    for k in 0..=100 {
        sample(f64::from(k) * 0.1, 0.005);
    }
    sample(10.003, 0.005);
    for k in 1..=50 {
        sample(10.003, f64::from(k) * 0.1);
    }
    let trace = write(&dir, "square.csv", &trace);
    let out = nccomp(&[
        "contour",
        "-m",
        "fixtures/grinder.machine.toml",
        &program,
        "--trace",
        &trace,
        "-o",
        "-",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let rows = rows(&stdout(&out));
    // About every 0.1 mm (the median spacing of the samples) along 15 mm of path.
    assert!((150..=152).contains(&rows.len()), "{} points", rows.len());
    for r in &rows {
        let (line, tip, axis) = (r[0], r[7], r[11]);
        let expected = if line == 3.0 { 5.0 } else { 3.0 };
        assert!((tip - expected).abs() < 1e-3, "{r:?}");
        assert_eq!(axis, 0.0, "{r:?}");
    }
    assert!(stderr(&out).contains("tool-tip contour error:  max 5.000 µm at line 3"));
}

/// The S-shaped piece's program and a simulated trace of it, for each five-axis machine.
#[test]
fn the_s_shape_on_every_five_axis_machine() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    for name in ["bc_trunnion", "head_head"] {
        let machine_path = root.join(format!("fixtures/{name}.machine.toml"));
        let machine = machine_file::load(&machine_path).unwrap();
        let program = finishing_program(&machine, &SShape::paper(), &Finishing::default())
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        let (moves, chain) = nominal_moves(&machine, 0, program.as_bytes(), name, 20).unwrap();
        let kin = &Kinematics::new(&machine, &ErrorModel::zero(&machine), chain).unwrap();
        let length = machine.tool.lengths[&Finishing::default().tool];
        let servo = Servo::paper(kin.len());
        let trace = simulate(&machine, kin, &moves, length, &servo);
        let dir = scratch(name);
        let program = write(&dir, "s_shape.nc", &program);
        let trace = write(&dir, "s_shape.trace.csv", &trace.to_csv());
        let out = nccomp(&[
            "contour",
            "-m",
            machine_path.to_str().unwrap(),
            &program,
            "--trace",
            &trace,
            "-o",
            "-",
        ]);
        assert!(out.status.success(), "{name}: {}", stderr(&out));
        let rows = rows(&stdout(&out));
        assert!(rows.len() > 800, "{name}: {} points", rows.len());
        // Along the S, away from the corners at its ends, the servo lags leave the tool
        // microns off the path, and the commanded path is on it.
        let along: Vec<&Vec<f64>> = rows
            .iter()
            .filter(|r| r[2] > 30.0 && r[2] < 230.0)
            .collect();
        assert!(along.len() > 600, "{name}");
        for r in along {
            assert!(r[7] < 30.0 && r[11] < 200.0, "{name}: {r:?}");
            assert!(r[12] < 5.0 && r[13] < 10.0, "{name}: {r:?}");
        }
    }
}

/// On a turning-milling centre the trace follows one tool chain, milling.
#[test]
fn a_mill_turn_program_is_followed_while_it_mills_in_one_tool_chain() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let machine_path = "fixtures/mill_turn.machine.toml";
    let machine = machine_file::load(&root.join(machine_path)).unwrap();
    // The pocket of the milling fixture, with its live tool on the upper turret.
    let milling = std::fs::read_to_string(root.join("fixtures/mill_turn_milling.nc")).unwrap();
    let pocket: String = milling
        .lines()
        .take_while(|l| !l.starts_with("(C-AXIS"))
        .map(|l| format!("{l}\n"))
        .collect::<String>()
        + "M30\n";
    let (moves, chain) = nominal_moves(&machine, 0, pocket.as_bytes(), "pocket.nc", 20).unwrap();
    let kin = &Kinematics::new(&machine, &ErrorModel::zero(&machine), chain).unwrap();
    let trace = simulate(
        &machine,
        kin,
        &moves,
        moves[0].tool_length,
        &Servo::paper(kin.len()),
    );
    let dir = scratch("mill_turn");
    let program = write(&dir, "pocket.nc", &pocket);
    let trace = write(&dir, "pocket.csv", &trace.to_csv());
    let out = nccomp(&["contour", "-m", machine_path, &program, "--trace", &trace]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(
        stdout(&out).contains("reference: 5 feed moves"),
        "{}",
        stdout(&out)
    );
    // Turning moves, and a switch to the other turret, are refused at their blocks.
    let turning = nccomp(&[
        "contour",
        "-m",
        machine_path,
        "fixtures/mill_turn_turning.nc",
        "--trace",
        &trace,
    ]);
    refused(
        &turning,
        "fixtures/mill_turn_turning.nc:8:8",
        "a turning move cannot be followed",
    );
    // Once, not at every turning block.
    assert_eq!(stderr(&turning).matches("error:").count(), 1);
    let two = write(
        &dir,
        "two.nc",
        &pocket.replace("M30\n", "T11\nM19\nG0 X30 Z5 C0\nM30\n"),
    );
    let out = nccomp(&["contour", "-m", machine_path, &two, "--trace", &trace]);
    refused(
        &out,
        &format!("{two}:18:4"),
        "this block moves in tool chain `lower`, the ones before in `upper`",
    );
}
