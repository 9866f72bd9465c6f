//! The shipped fixtures are what their generators write, and they load.

use nccomp::kinematics::Kinematics;
use nccomp::model::{ErrorModel, machine_file};
use nccomp::workpiece::{FeatureWorkpiece, ProgramStyle, to_program};
use std::path::Path;

#[test]
fn feature_workpiece_program_is_what_the_generator_writes() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures");
    let machine = machine_file::load(&root.join("ac_trunnion.machine.toml")).unwrap();
    let kin = Kinematics::new(&machine, &ErrorModel::zero(&machine), 0).unwrap();
    let ops = FeatureWorkpiece::default().finishing_path(3.0);
    let program = to_program(&kin, &machine, &ops, &ProgramStyle::feature_workpiece()).unwrap();
    let committed = std::fs::read_to_string(root.join("feature_workpiece.nc")).unwrap();
    assert!(
        program == committed,
        "fixtures/feature_workpiece.nc is stale: run\n  cargo run --example feature_workpiece -- fixtures/ac_trunnion.machine.toml > fixtures/feature_workpiece.nc"
    );
}

#[test]
fn feature_workpiece_program_reaches_the_designed_path() {
    // The nominal machine running the fixture program puts the tool where the path says.
    use nccomp::kinematics::Model;
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures");
    let machine = machine_file::load(&root.join("ac_trunnion.machine.toml")).unwrap();
    let kin = Kinematics::new(&machine, &ErrorModel::zero(&machine), 0).unwrap();
    let length = machine.tool.lengths[&1];
    let ops = FeatureWorkpiece::default().finishing_path(3.0);
    let committed = std::fs::read_to_string(root.join("feature_workpiece.nc")).unwrap();
    // Modal axis values per motion block, in program order.
    let mut q = [0.0; 5];
    let mut poses = Vec::new();
    for line in committed.lines() {
        if line.starts_with('(') || line.starts_with('%') || line.starts_with('O') {
            continue;
        }
        let mut moved = false;
        for word in line.split_whitespace() {
            if let Some(k) = "XYZAC".find(&word[..1]) {
                q[k] = word[1..].parse().unwrap();
                moved = true;
            }
        }
        if moved {
            poses.push(q);
        }
    }
    let points: Vec<_> = ops.iter().flat_map(|op| op.points.iter()).collect();
    // Points with an unchanged pose produce no block; every block is some path point.
    let mut next = 0;
    for q in &poses {
        let (pose, _) = kin.pose(Model::Nominal, q, length);
        let found = points[next..]
            .iter()
            .position(|p| (p.tip - pose.p).norm() < 1e-3);
        let i = found.unwrap_or_else(|| panic!("block at {q:?} reaches no path point"));
        let p = points[next + i];
        assert!((p.dir - pose.o).norm() < 1e-5);
        next += i + 1;
    }
    assert!(poses.len() > 600);
}
