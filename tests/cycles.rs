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

/// The holes a program drills, read as a FANUC-family control reads them: X, Y absolute
/// (G90) or increments (G91), an L word repeating the hole at each increment; in G91 R is
/// the distance from the initial level (the tool's Z where the cycle began), Z from the R
/// plane. A and C stay 0. Each hole: (x, y, bottom, r).
fn holes_of(program: &str) -> Vec<[f64; 4]> {
    let (mut x, mut y, mut tool_z) = (0.0, 0.0, 0.0);
    let (mut bottom, mut r, mut initial) = (f64::NAN, f64::NAN, f64::NAN);
    let (mut incremental, mut cycle) = (false, false);
    let mut holes = Vec::new();
    for line in program.lines() {
        let (mut dx, mut dy, mut dz, mut dr, mut repeats) = (None, None, None, None, 1);
        for word in line.split_whitespace() {
            let value = |w: &str| w[1..].parse::<f64>().unwrap();
            match &word[..1] {
                "G" => match word {
                    "G90" => incremental = false,
                    "G91" => incremental = true,
                    "G80" => cycle = false,
                    "G81" | "G82" | "G83" if !cycle => {
                        cycle = true;
                        initial = tool_z;
                    }
                    _ => {}
                },
                "X" => dx = Some(value(word)),
                "Y" => dy = Some(value(word)),
                "Z" => dz = Some(value(word)),
                "R" => dr = Some(value(word)),
                "L" => repeats = value(word) as usize,
                _ => {}
            }
        }
        if cycle {
            if let Some(v) = dr {
                r = if incremental { initial + v } else { v };
            }
            if let Some(v) = dz {
                bottom = if incremental { r + v } else { v };
            }
        } else if let Some(v) = dz {
            tool_z = if incremental { tool_z + v } else { v };
        }
        let moved = dx.is_some() || dy.is_some() || dz.is_some() || dr.is_some();
        for _ in 0..repeats {
            if incremental {
                x += dx.unwrap_or(0.0);
                y += dy.unwrap_or(0.0);
            } else {
                x = dx.unwrap_or(x);
                y = dy.unwrap_or(y);
            }
            if cycle && moved {
                holes.push([x, y, bottom, r]);
            }
        }
    }
    holes
}

/// Every hole of `written` lands where the same hole of `program` is meant: at its bottom
/// and, on the hole's axis, at the R plane (µm).
fn assert_holes_land(kin: &Kinematics, program: &str, written: &str) -> usize {
    let (nominal, actual) = (holes_of(program), holes_of(written));
    assert_eq!(nominal.len(), actual.len(), "{written}");
    let mut worst: f64 = 0.0;
    for (n, a) in nominal.iter().zip(&actual) {
        for (zn, za) in [(n[2], a[2]), (n[3], a[3])] {
            let (meant, _) = kin.pose(Model::Nominal, &[n[0], n[1], zn, 0.0, 0.0], 0.0);
            let (reached, _) = kin.pose(Model::Actual, &[a[0], a[1], za, 0.0, 0.0], 0.0);
            worst = worst.max((reached.p - meant.p).norm());
        }
    }
    // The contract's residual: the resolution (0.0001 mm) and the solve.
    assert!(worst < 2e-4, "a hole is {:.3} µm off", worst * 1e3);
    nominal.len()
}

#[test]
fn holes_repeated_with_l_in_g91_each_land() {
    let machine = ac_trunnion([0.0, 0.0, -100.0], [0.0, 0.0, 0.0]);
    let errors = shop_errors(&machine, &mut Lcg(23));
    let kin = Kinematics::new(&machine, &errors, 0).unwrap();
    let program = "G21 G90 G17\nG0 X0 Y0 Z30 A0 C0\nG98 G81 X10 Y10 Z-5 R2 F100\n\
                   G91 X7.5 L6\nY-12.25 L3\nX-7.5 Y2.5\nG90 G80\nG0 Z50\nM30\n";
    let comp = Compensator::new(&machine, &errors, Options::default()).unwrap();
    let mut out = Vec::new();
    let summary = comp.run(program.as_bytes(), "rows.nc", &mut out).unwrap();
    let written = String::from_utf8(out).unwrap();
    assert_eq!(assert_holes_land(&kin, program, &written), 11, "{written}");
    // The holes' corrections differ: each L block became a block per hole.
    assert_eq!(summary.cycles_unrolled, 2, "{written}");
    assert_eq!(summary.holes_added, 5 + 2);
    assert!(!written.contains('L'), "{written}");
    assert_eq!(written.lines().count(), program.lines().count() + 7);
    // Uncorrected, the same words are off by microns: the check can fail.
    let as_programmed = kin.pose(
        Model::Actual,
        &[10.0 + 7.5 * 6.0, 10.0, -5.0, 0.0, 0.0],
        0.0,
    );
    let meant = kin.pose(
        Model::Nominal,
        &[10.0 + 7.5 * 6.0, 10.0, -5.0, 0.0, 0.0],
        0.0,
    );
    assert!((as_programmed.0.p - meant.0.p).norm() > 5e-3);
}

#[test]
fn holes_with_the_same_correction_keep_their_l() {
    let machine = ac_trunnion([0.0, 0.0, -100.0], [0.0, 0.0, 0.0]);
    // Z positions 12 µm short everywhere: every hole takes the same correction.
    let mut errors = nccomp::model::ErrorModel::zero(&machine);
    errors.axes[2].motion = Some(MotionTable {
        positions: vec![-300.0, 300.0],
        values: [None, None, Some(vec![-0.012, -0.012]), None, None, None],
        periodic: false,
    });
    let kin = Kinematics::new(&machine, &errors, 0).unwrap();
    let program = "G21 G90 G17\nG0 X0 Y0 Z30 A0 C0\nG99 G81 X10 Y10 Z-5 R2 F100\n\
                   G91 X7.5 L6\nG90 G80\nM30\n";
    let comp = Compensator::new(&machine, &errors, Options::default()).unwrap();
    let mut out = Vec::new();
    let summary = comp.run(program.as_bytes(), "row.nc", &mut out).unwrap();
    let written = String::from_utf8(out).unwrap();
    assert_eq!(assert_holes_land(&kin, program, &written), 7, "{written}");
    assert_eq!(summary.cycles_unrolled, 0);
    assert!(written.contains("G91 X7.5 L6\n"), "{written}");
    assert!(written.contains("Z-4.9880 R2.0120"), "{written}");
}

#[test]
fn a_cycle_without_r_starts_where_the_machine_file_says() {
    let mut machine = ac_trunnion([0.0, 0.0, -100.0], [0.0, 0.0, 0.0]);
    let errors = shop_errors(&machine, &mut Lcg(29));
    let program =
        "G21 G90 G17\nG0 X0 Y0 Z3 A0 C0\nG98 G82 X10 Y10 Z-5 P100 F100\nX20\nY-5\nG80\nM30\n";
    let comp = Compensator::new(&machine, &errors, Options::default()).unwrap();
    let err = comp
        .run(program.as_bytes(), "p.nc", &mut Vec::new())
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("p.nc:3:5: this canned cycle cannot be compensated: it gives no R plane"),
        "{err}"
    );
    assert!(err.contains("[cycles] missing_r = \"initial\""), "{err}");
    machine.cycle_r_initial = true;
    let kin = Kinematics::new(&machine, &errors, 0).unwrap();
    let comp = Compensator::new(&machine, &errors, Options::default()).unwrap();
    let mut out = Vec::new();
    comp.run(program.as_bytes(), "p.nc", &mut out).unwrap();
    let written = String::from_utf8(out).unwrap();
    // Read with R at the level the cycle starts from, as the control does.
    let with_r = |p: &str| p.replacen("G98 G82", "R3 G98 G82", 1);
    let r_of = |p: &str| holes_of(p).iter().map(|h| h[3]).collect::<Vec<_>>();
    if !written.contains(" R") {
        assert_holes_land(&kin, &with_r(program), &with_r(&written));
    } else {
        // A corrected R that no longer prints as the start level is written.
        assert_holes_land(&kin, &with_r(program), &written);
        assert!(
            r_of(&written).iter().all(|r| (r - 3.0).abs() < 0.05),
            "{written}"
        );
    }
}

#[test]
fn repeats_and_distances_nccomp_does_not_follow_are_refused() {
    let machine = ac_trunnion([0.0, 0.0, -100.0], [0.0, 0.0, 0.0]);
    let errors = shop_errors(&machine, &mut Lcg(31));
    let comp = Compensator::new(&machine, &errors, Options::default()).unwrap();
    for (program, at, what) in [
        (
            "G0 X0 Y0 Z30 A0 C0\nG81 X10 Y10 Z-4 R2 F100\nG91 X5 Z-1\n",
            "p.nc:3:5: this canned cycle cannot be compensated: in incremental mode (G91) a cycle's Z and R are distances",
            "Z in G91",
        ),
        (
            "G0 X0 Y0 Z30 A0 C0\nG99 G81 X10 Y10 Z-4 R2 F100\nG91 X50\n",
            "p.nc:3:5: this canned cycle cannot be compensated: here the corrected R plane",
            "R in G91 under G99",
        ),
        (
            "G0 X0 Y0 Z30 A0 C0\nG81 X10 Y10 Z-4 R2 F100\nG91 X5 L0\n",
            "p.nc:3:8: the L word of a cycle block is its number of holes",
            "L0",
        ),
        (
            "G0 X0 Y0 Z30 A0 C0\nG81 X10 Y10 Z-4 R2 F100\nG91 X5 L3 M8\n",
            "p.nc:3:11: an M or T word in a cycle block with an L or K repeat",
            "M with L",
        ),
    ] {
        let err = comp
            .run(program.as_bytes(), "p.nc", &mut Vec::new())
            .unwrap_err();
        let err = err.to_string();
        assert!(err.contains(at), "{what}: {err}");
    }
}

#[test]
fn fanuc_k_repeats_holes_as_haas_l_does() {
    let machine = ac_trunnion([0.0, 0.0, -100.0], [0.0, 0.0, 0.0]);
    let errors = shop_errors(&machine, &mut Lcg(23));
    let comp = Compensator::new(&machine, &errors, Options::default()).unwrap();
    let with_l = "G21 G90 G17\nG0 X0 Y0 Z30 A0 C0\nG98 G81 X10 Y10 Z-5 R2 F100\n\
                  G91 X7.5 L6\nY-12.25 L3\nG90 G80\nM30\n";
    let with_k = with_l.replace(" L", " K");
    let run = |p: &str| {
        let mut out = Vec::new();
        comp.run(p.as_bytes(), "p.nc", &mut out).unwrap();
        String::from_utf8(out).unwrap()
    };
    // Unrolled, the two programs are the same blocks.
    let (l, k) = (run(with_l), run(&with_k));
    assert!(!l.contains('L') && !k.contains('K'), "{l}\n{k}");
    assert_eq!(l, k);
    for (program, at) in [
        (
            "G0 X0 Y0 Z30 A0 C0\nG81 X10 Y10 Z-4 R2 F100\nG91 X5 L2 K2\n",
            "p.nc:3:11: a cycle block with both L and K",
        ),
        (
            "G0 X0 Y0 Z30 A0 C0\nG81 X10 Y10 Z-4 R2 I1 F100\n",
            "p.nc:2:20: I and J words in a canned cycle are not supported",
        ),
        (
            "G0 X0 Y0 Z30 A0 C0\nG81 X10 Y10 Z-4 R2 F100\nG91 X5 K0\n",
            "p.nc:3:8: the K word of a cycle block is its number of holes",
        ),
    ] {
        let err = comp
            .run(program.as_bytes(), "p.nc", &mut Vec::new())
            .unwrap_err()
            .to_string();
        assert!(err.contains(at), "{err}");
    }
}
