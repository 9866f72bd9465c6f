//! Drilling cycles in three-axis work: compensated at their positioning points where one
//! X, Y serves the whole depth, refused with line:col where it does not.

mod common;

use common::{Lcg, ac_trunnion};
use nalgebra::Vector3;
use nccomp::compensate::{Compensator, Options};
use nccomp::kinematics::{Kinematics, Model};
use nccomp::model::{ErrorModel, Machine, MotionTable};

/// Errors a drill does not mind along its depth: squareness of X and Y, positioning and
/// straightness of X and Y, positioning of Z (microns); none that tilts the tool.
fn shop_errors(machine: &Machine, rng: &mut Lcg) -> ErrorModel {
    let mut model = ErrorModel::zero(machine);
    for (k, err) in model.axes.iter_mut().enumerate().take(3) {
        let positions = vec![-300.0, -100.0, 100.0, 300.0];
        let mut values: [Option<Vec<f64>>; 6] = Default::default();
        for (c, v) in values.iter_mut().enumerate().take(3) {
            // Z: its positioning error only (its straightness would bend the hole).
            if k < 2 || c == 2 {
                *v = Some(positions.iter().map(|_| rng.sym(0.015)).collect());
            }
        }
        err.motion = Some(MotionTable {
            positions,
            values,
            periodic: false,
        });
        if k == 1 {
            err.squareness = Vector3::new(0.0, 0.0, rng.sym(200e-6));
        }
    }
    model
}

fn words(line: &str, q: &mut [f64; 5], r: &mut f64) -> bool {
    let mut moved = false;
    for word in line.split_whitespace() {
        if let Some(k) = "XYZAC".find(&word[..1]) {
            q[k] = word[1..].parse().unwrap();
            moved = true;
        } else if let Some(v) = word.strip_prefix('R') {
            *r = v.parse().unwrap();
            moved = true;
        }
    }
    moved
}

#[test]
fn holes_land_at_their_bottom_and_on_their_axis_at_the_r_plane() {
    let machine = ac_trunnion([0.0, 0.0, -100.0], [0.0, 0.0, 0.0]);
    let mut rng = Lcg(11);
    let errors = shop_errors(&machine, &mut rng);
    let kin = Kinematics::new(&machine, &errors, 0).unwrap();
    let mut program =
        String::from("G21 G90 G17\nG0 X0 Y0 Z30 A0 C0\nG99 G81 X10 Y10 Z-5 R2 F100\n");
    for k in 0..40 {
        let (x, y) = (rng.sym(200.0), rng.sym(200.0));
        match k % 4 {
            0 => program.push_str(&format!(
                "X{x:.3} Y{y:.3} Z{:.3}\n",
                -2.0 - 20.0 * rng.next()
            )),
            1 => program.push_str(&format!("X{x:.3}\n")),
            2 => program.push_str(&format!("Y{y:.3} R{:.3}\n", 1.0 + 5.0 * rng.next())),
            _ => program.push_str(&format!("G98 G83 X{x:.3} Y{y:.3} Q2\n")),
        }
    }
    program.push_str("G80\nG0 Z50\nX0 Y0\nM30\n");
    let comp = Compensator::new(&machine, &errors, Options::default()).unwrap();
    let mut out = Vec::new();
    let summary = comp.run(program.as_bytes(), "drill.nc", &mut out).unwrap();
    let out = String::from_utf8(out).unwrap();
    assert_eq!(out.lines().count(), program.lines().count());
    assert!(summary.words_changed > 40, "{summary:?}");
    // Every hole: the programmed and the written cycle words, modal Z and R included.
    let (mut qi, mut qo) = ([0.0; 5], [0.0; 5]);
    let (mut ri, mut ro) = (0.0, 0.0);
    let mut holes = 0;
    let mut after = false;
    for (li, lo) in program.lines().zip(out.lines()) {
        if li.starts_with("G80") {
            after = true;
            continue;
        }
        let moved = words(li, &mut qi, &mut ri);
        words(lo, &mut qo, &mut ro);
        if after && moved {
            // Moves after the cycle start from where it retracted, and land.
            let (nominal, _) = kin.pose(Model::Nominal, &qi, 0.0);
            let (reached, _) = kin.pose(Model::Actual, &qo, 0.0);
            let dp = (reached.p - nominal.p).norm();
            assert!(dp < 1e-3, "{li} -> {lo}: off by {dp} mm");
            continue;
        }
        if li.starts_with("G0") {
            continue;
        }
        if !moved || li.starts_with("G21") {
            continue;
        }
        holes += 1;
        let (bottom, _) = kin.pose(Model::Nominal, &qi, 0.0);
        let (reached, _) = kin.pose(Model::Actual, &qo, 0.0);
        let dp = (reached.p - bottom.p).norm();
        assert!(dp < 1e-3, "{li} -> {lo}: bottom off by {dp} mm");
        let (mut at_r_in, mut at_r_out) = (qi, qo);
        at_r_in[2] = ri;
        at_r_out[2] = ro;
        let (plane, _) = kin.pose(Model::Nominal, &at_r_in, 0.0);
        let (reached, _) = kin.pose(Model::Actual, &at_r_out, 0.0);
        let dr = (reached.p - plane.p).norm();
        assert!(dr < 1e-3, "{li} -> {lo}: R plane off by {dr} mm");
    }
    assert_eq!(holes, 41);
}

#[test]
fn cycles_that_cannot_be_compensated_honestly_are_refused() {
    let machine = ac_trunnion([0.0, 0.0, -100.0], [0.0, 0.0, 0.0]);
    let mut errors = shop_errors(&machine, &mut Lcg(5));
    // Z out of square with X: the drill goes down at a slant, not along the hole's axis.
    errors.axes[2].squareness = Vector3::new(0.0, 300e-6, 0.0);
    let comp = Compensator::new(&machine, &errors, Options::default()).unwrap();
    for (program, at, what) in [
        (
            "G0 X0 Y0 Z30 A0 C0\nG81 X10 Y10 Z-40 R2 F100\n",
            "p.nc:2:1: this canned cycle cannot be compensated: one X, Y cannot serve the whole depth",
            "deep hole with a leaning tool",
        ),
        (
            "G0 X0 Y0 Z30 A0 C0\nG81 X10 Y10 Z-4 R2 A5 F100\n",
            "p.nc:2:20: A words in a canned cycle cannot be compensated",
            "rotary word",
        ),
        (
            "G0 X0 Y0 Z30 A0 C0\nG91 G81 X10 Y10 Z-4 R2 F100\n",
            "p.nc:2:5: this canned cycle cannot be compensated: in incremental mode (G91)",
            "G91",
        ),
        (
            "G0 X0 Y0 Z30 A0 C0\nG18 G81 X10 Y10 Z-4 R2 F100\n",
            "p.nc:2:5: this canned cycle cannot be compensated: only cycles in the G17 plane",
            "G18",
        ),
        (
            "G0 X0 Y0 Z30 A0 C0\nG81 X10 Y10 F100\n",
            "p.nc:2:1: this canned cycle cannot be compensated: it needs its bottom (Z) and retract plane (R)",
            "no Z",
        ),
        (
            "G0 X0 Y0 Z30 A0 C0\nG87 X10 Y10 Z-4 R2 I1 K2\n",
            "p.nc:2:1: G87 cannot be compensated: a back boring cycle (G87) is not supported",
            "G87",
        ),
    ] {
        let mut out = Vec::new();
        let err = comp
            .run(program.as_bytes(), "p.nc", &mut out)
            .unwrap_err()
            .to_string();
        assert!(err.contains(at), "{what}: {err}");
    }
    // A shallow hole with the same lean is within the tolerance.
    let mut out = Vec::new();
    comp.run(
        b"G0 X0 Y0 Z30 A0 C0\nG81 X10 Y10 Z-1 R1 F100\n",
        "p.nc",
        &mut out,
    )
    .unwrap();
}
