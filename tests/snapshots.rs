//! The compensated reference programs, pinned: any change to the numbers nccomp writes
//! for the shipped fixtures shows up here as a reviewable diff.

use nccomp::compensate::{Compensator, Options};
use nccomp::model::{error_file, machine_file};
use std::path::Path;

fn compensate(machine: &str, program: &str, options: Options) -> String {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures");
    let m = machine_file::load(&root.join(format!("{machine}.machine.toml"))).unwrap();
    let e = error_file::load(&root.join(format!("{machine}.errors.toml")), &m).unwrap();
    let src = std::fs::read(root.join(format!("{program}.nc"))).unwrap();
    let comp = Compensator::new(&m, &e, options).unwrap();
    let mut out = Vec::new();
    let summary = comp.run(&src, &format!("{program}.nc"), &mut out).unwrap();
    format!("{summary}\n----\n{}", String::from_utf8(out).unwrap())
}

#[test]
fn feature_workpiece_on_the_ac_trunnion() {
    insta::assert_snapshot!(compensate(
        "ac_trunnion",
        "feature_workpiece",
        Options::default()
    ));
}

#[test]
fn bc_trunnion_demo() {
    insta::assert_snapshot!(compensate(
        "bc_trunnion",
        "bc_trunnion_demo",
        Options::default()
    ));
}

#[test]
fn head_head_demo() {
    insta::assert_snapshot!(compensate(
        "head_head",
        "head_head_demo",
        Options::default()
    ));
}

#[test]
fn grinder_demo() {
    insta::assert_snapshot!(compensate("grinder", "grinder_demo", Options::default()));
}

/// Turning on the mill-turn centre: the upper turret in diameter mode (G7: the X words
/// written back are diameters, twice the compensated radius), then the lower turret (T11)
/// in radius mode; the spindle turns, so C is never written.
#[test]
fn mill_turn_turning() {
    insta::assert_snapshot!(compensate(
        "mill_turn",
        "mill_turn_turning",
        Options::default()
    ));
}

/// Milling on the mill-turn centre with live tools: the spindle positioned (M19, C words),
/// Y-axis and C-axis operations and a radial one at B90.
#[test]
fn mill_turn_milling() {
    insta::assert_snapshot!(compensate(
        "mill_turn",
        "mill_turn_milling",
        Options::default()
    ));
}

#[test]
fn tcp_program_on_the_ac_trunnion() {
    insta::assert_snapshot!(compensate(
        "ac_trunnion",
        "ac_trunnion_tcp",
        Options::default()
    ));
}

#[test]
fn tcp_vector_program_on_the_ac_trunnion() {
    insta::assert_snapshot!(compensate(
        "ac_trunnion",
        "ac_trunnion_tcp_vector",
        Options::default()
    ));
}

/// With the default path tolerance (as `nccomp compensate` runs): arcs in each plane, kept
/// where the compensated arc stays within it, replaced by straight pieces where not.
#[test]
fn arcs_in_each_plane_with_the_path_tolerance() {
    insta::assert_snapshot!(compensate(
        "ac_trunnion",
        "ac_trunnion_arcs",
        Options {
            path: Some(nccomp::kinematics::path::PathTolerance::default()),
            ..Options::default()
        }
    ));
}

/// The G91 program with the default path tolerance: split moves get exact increments.
#[test]
fn incremental_program_with_the_path_tolerance() {
    insta::assert_snapshot!(compensate(
        "ac_trunnion",
        "ac_trunnion_g91",
        Options {
            path: Some(nccomp::kinematics::path::PathTolerance::default()),
            ..Options::default()
        }
    ));
}

#[test]
fn ac_trunnion_plane() {
    insta::assert_snapshot!(compensate(
        "ac_trunnion",
        "ac_trunnion_plane",
        Options::default()
    ));
}

/// Arcs in tilted working planes: corners and a short helix kept as arcs (compensated end
/// and centre), wide arcs and full helical turns as pieces.
#[test]
fn ac_trunnion_plane_arcs() {
    insta::assert_snapshot!(compensate(
        "ac_trunnion",
        "ac_trunnion_plane_arcs",
        Options::default()
    ));
}

#[test]
fn head_head_plane() {
    insta::assert_snapshot!(compensate(
        "head_head",
        "head_head_plane",
        Options::default()
    ));
}

#[test]
fn ac_trunnion_rows_of_holes_in_g91() {
    insta::assert_snapshot!(compensate(
        "ac_trunnion",
        "ac_trunnion_rows",
        Options::default()
    ));
}
