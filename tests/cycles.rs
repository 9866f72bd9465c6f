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

// ---------------------------------------------------------------------------------------
// Heidenhain drilling cycles outside a plane (CYCL DEF 200 … called by M99).

/// The holes a TNC program drills in machine axes, read as the control reads them (not by
/// nccomp's reader): the drilling cycle defined last (`CYCL DEF 200` … `209`, however the
/// spaces fall, with its `~` lines: Q200 the set-up clearance, Q201 the depth, Q203 the
/// surface; `Q200=3`, `Q200=  3` and `Q200 = 3` alike) is called by `M99` at the X, Y of the
/// `L` block that carries it. `CYCL DEF 9` (dwell time) acts where it stands: it is never
/// called and leaves the called cycle as it was. Each hole: (x, y, bottom, set-up
/// clearance), mm.
fn tnc_holes(program: &str) -> Vec<[f64; 4]> {
    let (mut x, mut y) = (f64::NAN, f64::NAN);
    // Q200, Q201, Q203 of the cycle being defined and of the one in force.
    let (mut defining, mut in_force): (Option<[f64; 3]>, Option<[f64; 3]>) = (None, None);
    let mut continued = false;
    let mut holes = Vec::new();
    for line in program.lines() {
        let body = line.split(';').next().unwrap();
        let was_continued = continued;
        continued = line.trim_end().ends_with('~');
        if was_continued {
            let compact: String = body
                .chars()
                .filter(|c| !c.is_whitespace() && *c != '~')
                .collect();
            if let (Some(def), Some((name, value))) = (defining.as_mut(), compact.split_once('=')) {
                let k = match name {
                    "Q200" => 0,
                    "Q201" => 1,
                    "Q203" => 2,
                    _ => 3,
                };
                if k < 3 {
                    def[k] = value.parse().unwrap();
                }
            }
            if !continued && defining.is_some() {
                in_force = defining.take();
            }
            continue;
        }
        let mut words = body.split_whitespace();
        let _number = words.next();
        let rest: Vec<&str> = words.collect();
        match rest.first().copied() {
            Some("CYCL") => {
                let compact: String = rest[1..].concat();
                let number: String = compact
                    .strip_prefix("DEF")
                    .expect("CYCL DEF")
                    .chars()
                    .take_while(char::is_ascii_digit)
                    .collect();
                match number.parse::<u32>().unwrap() {
                    200..=209 => defining = Some([f64::NAN; 3]),
                    9 => {}
                    other => panic!("cycle {other} is not in these programs"),
                }
            }
            Some("L") => {
                for w in &rest[1..] {
                    if let Some(v) = w.strip_prefix('X') {
                        x = v.parse().unwrap();
                    } else if let Some(v) = w.strip_prefix('Y') {
                        y = v.parse().unwrap();
                    }
                }
                if rest.contains(&"M99") {
                    let [q200, q201, q203] = in_force.expect("a call of a defined cycle");
                    holes.push([x, y, q203 + q201, q203 + q200]);
                }
            }
            _ => {}
        }
    }
    holes
}

/// How far each hole of `written` is from the same hole of `program` on the AC trunnion at
/// A0 C0 (mm): the largest distance of the real tip from the programmed bottom, and of the
/// real tip at the written set-up clearance from the programmed hole's axis (the line
/// through its bottom and its clearance point; where the tool stands along it, in the air,
/// is not judged).
fn tnc_holes_land(kin: &Kinematics, program: &str, written: &str) -> (usize, f64, f64) {
    let (nominal, actual) = (tnc_holes(program), tnc_holes(written));
    assert_eq!(nominal.len(), actual.len(), "{written}");
    let (mut bottom, mut clearance): (f64, f64) = (0.0, 0.0);
    for (n, a) in nominal.iter().zip(&actual) {
        let meant = |k: usize| {
            kin.pose(Model::Nominal, &[n[0], n[1], n[k], 0.0, 0.0], 0.0)
                .0
                .p
        };
        let reached = |k: usize| {
            kin.pose(Model::Actual, &[a[0], a[1], a[k], 0.0, 0.0], 0.0)
                .0
                .p
        };
        bottom = bottom.max((reached(2) - meant(2)).norm());
        clearance = clearance.max(off_axis(reached(3), meant(2), meant(3)));
    }
    (nominal.len(), bottom, clearance)
}

/// The distance of `p` from the line through `a` and `b`.
fn off_axis(p: Vector3<f64>, a: Vector3<f64>, b: Vector3<f64>) -> f64 {
    let d = (b - a).normalize();
    let v = p - a;
    (v - d * v.dot(&d)).norm()
}

/// A TNC drilling program on the AC trunnion at A0 C0, its definition's lines `params`.
fn tnc_drilling(params: &str, between: &str) -> String {
    format!(
        "0 BEGIN PGM D MM\n1 L X+0 Y+0 Z+50 A+0 C+0 R0 FMAX\n2 CYCL DEF 200 DRILLING~\n{params}\n\
         3 L X+10 Y+20 R0 FMAX M99\n{between}\n5 L X+40 Y-15 R0 FMAX M99\n\
         6 L X-60 Y+35 R0 FMAX M99\n7 L Z+100 R0 FMAX\n8 M30\n9 END PGM D MM\n"
    )
}

#[test]
fn tnc_cycle_spellings_the_control_accepts_are_read_alike() {
    let machine = ac_trunnion([0.0, 0.0, -100.0], [0.0, 0.0, 0.0]);
    let errors = shop_errors(&machine, &mut Lcg(41));
    let kin = Kinematics::new(&machine, &errors, 0).unwrap();
    let comp = Compensator::new(&machine, &errors, Options::default()).unwrap();
    let run = |program: &str| {
        let mut out = Vec::new();
        comp.run(program.as_bytes(), "d.h", &mut out)
            .map(|_| String::from_utf8(out).unwrap())
    };
    let plain = "    Q200=3 ;SET-UP CLEARANCE~\n    Q201=-12 ;DEPTH~\n    Q206=150 ;FEED RATE FOR PLUNGING~\n    Q203=-1.5 ;SURFACE COORDINATE~\n    Q204=30 ;2ND SET-UP CLEARANCE";
    let spaced = "    Q200=  3 ;SET-UP CLEARANCE~\n    Q201 = -12 ;DEPTH~\n    Q206=  150 ;FEED RATE FOR PLUNGING~\n    Q203=   -1.5 ;SURFACE COORDINATE~\n    Q204 =30 ;2ND SET-UP CLEARANCE";
    let mut written = Vec::new();
    for (params, dwell) in [
        (plain, "4 CYCL DEF 9.0 DWELL TIME\n4 CYCL DEF 9.1 DWELL 1.5"),
        (plain, "4 CYCL DEF9.0 VERWEILZEIT\n4 CYCL DEF9.1 V.ZEIT 0"),
        (
            spaced,
            "4 CYCL DEF 9 .0 DWELL TIME\n4 CYCL DEF 9 .1 DWELL 2",
        ),
        (
            spaced,
            "4 CYCL DEF9 .0 VARAKOZASI IDO\n4 CYCL DEF9.1 V.IDO5",
        ),
    ] {
        let program = tnc_drilling(params, dwell);
        let out = run(&program).unwrap_or_else(|e| panic!("{program}\n{e}"));
        // Every hole drills with cycle 200 (the dwell between calls replaces nothing), at
        // the depth and clearance its parameters give, spaced or not.
        let holes = tnc_holes(&program);
        assert_eq!(holes.len(), 3);
        assert!(
            holes.iter().all(|h| h[2] == -13.5 && h[3] == 1.5),
            "{holes:?}"
        );
        let (n, bottom, clearance) = tnc_holes_land(&kin, &program, &out);
        assert_eq!(n, 3);
        assert!(
            bottom < 2e-4,
            "a bottom is {:.3} µm off\n{out}",
            bottom * 1e3
        );
        assert!(
            clearance < 1e-3,
            "{:.3} µm at the clearance",
            clearance * 1e3
        );
        // Uncompensated, the same holes are microns off: the check can fail.
        let (_, as_programmed, _) = tnc_holes_land(&kin, &program, &program);
        assert!(as_programmed > 5e-3, "{as_programmed}");
        written.push(out);
    }
    // The dwell's spelling changes nothing that is written.
    let strip = |s: &str| {
        s.lines()
            .filter(|l| !l.contains("CYCL DEF 9") && !l.contains("CYCL DEF9"))
            .map(|l| l.replace(' ', ""))
            .collect::<Vec<_>>()
    };
    assert_eq!(strip(&written[0]), strip(&written[1]));
    assert_eq!(strip(&written[2]), strip(&written[3]));
    // A copy of the definition with another Q203 keeps the spacing it does not change.
    assert!(written[2].contains("Q200=  3 ;SET-UP"), "{}", written[2]);
}

#[test]
fn tnc_cycle_definitions_the_control_refuses_are_refused_with_their_place() {
    let machine = ac_trunnion([0.0, 0.0, -100.0], [0.0, 0.0, 0.0]);
    let errors = shop_errors(&machine, &mut Lcg(41));
    let comp = Compensator::new(&machine, &errors, Options::default()).unwrap();
    let params = "    Q200=3 ;SET-UP CLEARANCE~\n    Q201=-12 ;DEPTH~\n    Q203=-1.5 ;SURFACE COORDINATE~\n    Q204=30 ;2ND SET-UP CLEARANCE";
    for (program, at) in [
        (
            tnc_drilling(params, "4 CYCL DEFX.0 DWELL"),
            "d.h:9:11: `X.0`: expected a cycle number after CYCL DEF",
        ),
        (
            tnc_drilling(params, "4 CYCL DEF 9 0 DWELL"),
            // `9 0`: the sub-block must follow the dot (the control's `9.0` or `9 .0`):
            // read as cycle 9, whose other tokens are not read.
            "",
        ),
        (
            tnc_drilling(
                "    Q200= ;SET-UP CLEARANCE~\n    Q201=-12 ;DEPTH~\n    Q203=-1.5",
                "",
            ),
            "d.h:4:5: `Q200=` in a cycle definition: expected its value",
        ),
        (
            tnc_drilling(params, "4 CYCL DEF"),
            "d.h:9:8: expected a cycle number after CYCL DEF",
        ),
        (
            tnc_drilling("    = 3 ;SET-UP CLEARANCE~\n    Q201=-12", ""),
            "d.h:4:5: `=` in a cycle definition: expected a Q parameter such as Q200",
        ),
        (
            tnc_drilling("    Q200 3 ;SET-UP CLEARANCE~\n    Q201=-12", ""),
            "d.h:4:5: `Q200` in a cycle definition: expected a parameter such as Q200=2",
        ),
        (
            tnc_drilling("    Q200=Q7 ;SET-UP CLEARANCE~\n    Q201=-12 ;DEPTH~\n    Q203=-1.5", ""),
            "d.h:7:23: the call of cycle 200 (defined at line 3) cannot be compensated: Q200 is given by Q7, which the program never sets",
        ),
        (
            "0 BEGIN PGM D MM\n1 L X+0 Y+0 Z+50 A+0 C+0 R0 FMAX\n2 CYCL DEF 9.0 DWELL TIME\n3 CYCL DEF 9.1 DWELL 1\n4 L X+10 Y+20 R0 FMAX M99\n5 END PGM D MM\n".to_string(),
            "d.h:5:23: a cycle call, but no cycle is defined",
        ),
    ] {
        let result = comp.run(program.as_bytes(), "d.h", &mut Vec::new());
        if at.is_empty() {
            assert!(result.is_ok(), "{program}: {result:?}");
            continue;
        }
        let err = result.unwrap_err().to_string();
        assert!(err.contains(at), "{program}\n{err}");
    }
}

// ---------------------------------------------------------------------------------------
// One X, Y serves the whole depth: judged on the words as written, to the floor of what
// they can say.

/// The axis values X, Y, Z (the others as given) that put the real tip where the nominal
/// machine puts it at `q`: the test's own fixed-point solve (each linear axis moves the tip
/// along its own direction within microradians, so the step converges).
fn solve_xyz(kin: &Kinematics, q: &[f64]) -> Vec<f64> {
    let target = kin.pose(Model::Nominal, q, 0.0).0.p;
    let mut s = q.to_vec();
    for _ in 0..100 {
        let d = target - kin.pose(Model::Actual, &s, 0.0).0.p;
        for k in 0..3 {
            s[k] += d[k];
        }
        if d.norm() < 1e-13 {
            break;
        }
    }
    s
}

/// A number rounded to `d` decimals.
fn round_to(x: f64, d: i32) -> f64 {
    let s = 10f64.powi(d);
    (x * s).round() / s
}

/// The lateral distance (mm) of the real tool from the nominal axis of a TNC hole on the AC
/// trunnion at A0 C0 (X, Y, surface Q203, depth Q201, set-up clearance Q200, in mm), at
/// its set-up clearance, with the bottom's correction: unrounded (the solve's values), and
/// as the words are written (X, Y and the copied Q203 to four decimals).
fn tnc_lean(kin: &Kinematics, [x, y, q203, q201, q200]: [f64; 5]) -> (f64, f64) {
    let at = |z: f64| [x, y, z, 0.0, 0.0];
    let nominal = |z: f64| kin.pose(Model::Nominal, &at(z), 0.0).0.p;
    let (bottom, top) = (nominal(q203 + q201), nominal(q203 + q200));
    let b = solve_xyz(kin, &at(q203 + q201));
    let t = solve_xyz(kin, &at(q203 + q200));
    let real = |q: [f64; 5]| kin.pose(Model::Actual, &q, 0.0).0.p;
    let unrounded = off_axis(real([b[0], b[1], t[2], 0.0, 0.0]), bottom, top);
    let surface = round_to(q203 + (b[2] - (q203 + q201)), 4);
    let written = [
        round_to(b[0], 4),
        round_to(b[1], 4),
        surface + q200,
        0.0,
        0.0,
    ];
    (unrounded, off_axis(real(written), bottom, top))
}

/// Shop errors with the Z axis leaning `lean` rad about Y (EB0Z): the tool at the hole's
/// top stands off the axis through its corrected bottom by `lean` × the depth.
fn leaning_errors(machine: &Machine, seed: u64, lean: f64) -> ErrorModel {
    let mut errors = shop_errors(machine, &mut Lcg(seed));
    errors.axes[2].squareness = Vector3::new(0.0, lean, 0.0);
    errors
}

/// A TNC program drilling cycle 200 (Q200=2, Q201=-8.5, Q203=0: 10.5 mm from the bottom to
/// the set-up clearance) at each of `holes`.
fn tnc_rows(holes: &[[f64; 2]]) -> String {
    let mut p = String::from(
        "0 BEGIN PGM D MM\n1 L X+0 Y+0 Z+50 A+0 C+0 R0 FMAX\n2 CYCL DEF 200 DRILLING~\n    Q200=2 ;SET-UP CLEARANCE~\n    Q201=-8.5 ;DEPTH~\n    Q206=150 ;FEED RATE FOR PLUNGING~\n    Q203=+0 ;SURFACE COORDINATE~\n    Q204=30 ;2ND SET-UP CLEARANCE\n",
    );
    for (k, [x, y]) in holes.iter().enumerate() {
        p.push_str(&format!("{} L X{x:+.3} Y{y:+.3} R0 FMAX M99\n", k + 3));
    }
    let n = holes.len() + 3;
    p.push_str(&format!(
        "{n} L Z+100 R0 FMAX\n{} M30\n{} END PGM D MM\n",
        n + 1,
        n + 2
    ));
    p
}

/// The tolerance a hole's axis is held to at its top (mm): the path tolerance and what the
/// words' rounding to the resolution `res` can add, (√3/2 + 1/4)·res, as the gate holds
/// block ends.
fn axis_bound(res: f64) -> f64 {
    0.001 + (0.75_f64.sqrt() + 0.25) * res
}

#[test]
fn tnc_holes_are_judged_on_the_words_as_written() {
    let machine = ac_trunnion([0.0, 0.0, -100.0], [0.0, 0.0, 0.0]);
    let mut rng = Lcg(43);
    // As the program gives them, to three decimals.
    let holes: Vec<[f64; 2]> = (0..12)
        .map(|_| [round_to(rng.sym(150.0), 3), round_to(rng.sym(150.0), 3)])
        .collect();
    // A lean of 97 µrad over 10.5 mm: each hole's axis at the set-up clearance is
    // 1.02 µm off before its words are rounded, beyond the 1 µm tolerance, within what the
    // words can say (0.1 µm steps: 1.112 µm). A check of the values before rounding refuses
    // every hole; the written words are within the bound.
    let errors = leaning_errors(&machine, 47, 97e-6);
    let kin = Kinematics::new(&machine, &errors, 0).unwrap();
    let comp = Compensator::new(&machine, &errors, Options::default()).unwrap();
    let program = tnc_rows(&holes);
    let mut out = Vec::new();
    comp.run(program.as_bytes(), "d.h", &mut out)
        .unwrap_or_else(|e| panic!("{e}"));
    let written = String::from_utf8(out).unwrap();
    let (n, bottom, clearance) = tnc_holes_land(&kin, &program, &written);
    assert_eq!(n, holes.len());
    assert!(bottom < 2e-4, "a bottom is {:.3} µm off", bottom * 1e3);
    let bound = axis_bound(1e-4);
    assert!(
        clearance <= bound,
        "{:.4} µm at the set-up clearance (bound {:.4} µm)",
        clearance * 1e3,
        bound * 1e3
    );
    for &[x, y] in &holes {
        let (unrounded, _) = tnc_lean(&kin, [x, y, 0.0, -8.5, 2.0]);
        assert!(unrounded > 1e-3 && unrounded < 1.05e-3, "{unrounded}");
    }

    // Leaning 120 µrad (1.26 µm before rounding) every hole is beyond what the words can
    // say, and the refusal names the figure of the words as they would be written: the
    // test's own solve, rounded, evaluated on the real machine. The hole is one whose
    // rounding moves the figure by more than the message's last digit.
    let errors = leaning_errors(&machine, 47, 120e-6);
    let kin = Kinematics::new(&machine, &errors, 0).unwrap();
    let comp = Compensator::new(&machine, &errors, Options::default()).unwrap();
    let (hole, (unrounded, written)) = holes
        .iter()
        .map(|&[x, y]| ([x, y], tnc_lean(&kin, [x, y, 0.0, -8.5, 2.0])))
        .find(|(_, (u, w))| (u - w).abs() > 2e-5)
        .expect("a hole whose rounding shows");
    assert!(written > bound, "{written}");
    let program = tnc_rows(&[hole]);
    let err = comp
        .run(program.as_bytes(), "d.h", &mut Vec::new())
        .unwrap_err()
        .to_string();
    // At the call's M99, in the hole's line.
    let call = program.lines().nth(8).unwrap();
    let at = format!(
        "d.h:9:{}: this cycle call cannot be compensated",
        call.find("M99").unwrap() + 1
    );
    assert!(err.contains(&at), "{err}");
    let figure: f64 = err
        .split("the tool is ")
        .nth(1)
        .and_then(|s| s.split(" µm").next())
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| panic!("{err}"));
    assert!(
        (figure - written * 1e3).abs() <= 0.0051,
        "the refusal says {figure} µm; the written words leave {:.4} µm (before rounding {:.4} µm)\n{err}",
        written * 1e3,
        unrounded * 1e3
    );
    assert!(
        err.contains("at the set-up clearance (more than 1.11 µm"),
        "{err}"
    );
}

/// A three-axis mill programmed in inch (words to 0.0001 in, 2.54 µm): X, Y in the table,
/// Z in the head.
fn inch_mill() -> Machine {
    let mut machine = ac_trunnion([0.0, 0.0, -100.0], [0.0, 0.0, 0.0]);
    machine.axes.truncate(3);
    machine.workpiece_chain = vec![1, 0];
    machine.resolution.linear = 0.00254;
    machine.inch_default = true;
    machine
}

/// A Haas-style drilling program in inch: peck drilling (G83) with an R plane 0.1 in above
/// the part, to 0.9 in deep (1 in, 25.4 mm, from R to the bottom), a row of holes given by
/// X and Y alone.
const HAAS_DRILLING: &str = "%\nO01001 (PLATE HOLES)\nN5 G20 G00 G17 G40 G49 G80 G90 G98\nN10 G00 X0.56 Y-0.425\nN15 Z1. M08\nN20 G83 Z-0.9 R0.1 Q0.1875 F10.\nN25 X1.04\nN30 X1.52\nN35 Y-0.875\nN40 X1.04\nN45 X0.56\nN50 G80\nN55 G00 Z1. M09\nN60 M30\n%\n";

#[test]
fn haas_inch_holes_are_held_to_what_their_words_can_say() {
    let machine = inch_mill();
    // A lean of 41.7 µrad: the axis at the R plane is 1.06 µm off with the bottom's
    // correction, beyond the 1 µm tolerance, well within a word's step (2.54 µm).
    let mut errors = shop_errors(&machine, &mut Lcg(53));
    errors.axes[2].squareness = Vector3::new(0.0, 41.7e-6, 0.0);
    let kin = Kinematics::new(&machine, &errors, 0).unwrap();
    let comp = Compensator::new(&machine, &errors, Options::default()).unwrap();
    let mut out = Vec::new();
    let summary = comp
        .run(HAAS_DRILLING.as_bytes(), "o01001.nc", &mut out)
        .unwrap_or_else(|e| panic!("{e}"));
    let written = String::from_utf8(out).unwrap();
    assert!(summary.words_changed > 0, "{written}");
    // Every hole, read as a Haas reads the words: its bottom and its axis at the R plane.
    let mm = |h: &[f64; 4]| h.map(|v| v * 25.4);
    let (nominal, actual) = (holes_of(HAAS_DRILLING), holes_of(&written));
    assert_eq!(nominal.len(), 6);
    assert_eq!(nominal.len(), actual.len(), "{written}");
    let (mut bottom, mut axis, mut lean): (f64, f64, f64) = (0.0, 0.0, 0.0);
    for (n, a) in nominal.iter().zip(&actual) {
        let (n, a) = (mm(n), mm(a));
        let meant = |z: f64| kin.pose(Model::Nominal, &[n[0], n[1], z], 0.0).0.p;
        let real = |z: f64| kin.pose(Model::Actual, &[a[0], a[1], z], 0.0).0.p;
        bottom = bottom.max((real(a[2]) - meant(n[2])).norm());
        axis = axis.max(off_axis(real(a[3]), meant(n[2]), meant(n[3])));
        // Before rounding: the bottom's solved X, Y at the R plane's solved Z.
        let b = solve_xyz(&kin, &[n[0], n[1], n[2]]);
        let t = solve_xyz(&kin, &[n[0], n[1], n[3]]);
        let p = kin.pose(Model::Actual, &[b[0], b[1], t[2]], 0.0).0.p;
        lean = lean.max(off_axis(p, meant(n[2]), meant(n[3])));
    }
    // The words say the bottom to their rounding: half a step on each of three axes.
    assert!(
        bottom <= 0.75_f64.sqrt() * 0.00254 + 1e-5,
        "a bottom is {:.3} µm off",
        bottom * 1e3
    );
    assert!(
        axis <= axis_bound(0.00254),
        "the axis at the R plane is {:.3} µm off",
        axis * 1e3
    );
    // The lean alone is beyond the tolerance: a bound without the floor refuses these.
    assert!(lean > 1.05e-3 && lean < 1.07e-3, "{lean}");
}

#[test]
fn a_refused_hole_leaves_its_levels_to_the_holes_after_it() {
    let machine = inch_mill();
    // A lean of 300 µrad: 7.6 µm off at the R plane, more than the words' floor allows.
    let mut errors = shop_errors(&machine, &mut Lcg(53));
    errors.axes[2].squareness = Vector3::new(0.0, 300e-6, 0.0);
    let comp = Compensator::new(&machine, &errors, Options::default()).unwrap();
    let err = comp
        .run(HAAS_DRILLING.as_bytes(), "o01001.nc", &mut Vec::new())
        .unwrap_err()
        .to_string();
    // Every hole is refused at its own line for what it is (the first at its G83, the
    // others at their first word), none for levels it does not repeat.
    let lines: Vec<&str> = err.lines().filter(|l| l.contains("cannot")).collect();
    for (k, at) in ["6:5", "7:5", "8:5", "9:5", "10:5", "11:5"]
        .iter()
        .enumerate()
    {
        let line = lines.get(k).unwrap_or_else(|| panic!("{err}"));
        assert!(
            line.starts_with(&format!("o01001.nc:{at}: this canned cycle cannot be compensated: one X, Y cannot serve the whole depth here")),
            "{line}\n{err}"
        );
    }
    assert!(!err.contains("needs its bottom"), "{err}");
}

// ---------------------------------------------------------------------------------------
// TNC cycles that move around their axis, and holes written out as L moves.

/// A TNC cycle call read as the control runs it (not by nccomp's reader): the X, Y of the
/// `L` block that carries `M99` (words absolute, modal), with the cycle defined last: its
/// number and parameters. Dwells (`CYCL DEF 9`) are never called.
#[derive(Debug, Clone)]
struct Call {
    xy: [f64; 2],
    number: u32,
    q: std::collections::HashMap<u32, f64>,
}

impl Call {
    fn get(&self, k: u32) -> f64 {
        *self
            .q
            .get(&k)
            .unwrap_or_else(|| panic!("cycle {} has no Q{k}", self.number))
    }

    /// Set-up clearance, bottom and surface as levels along Z.
    fn levels(&self) -> (f64, f64, f64) {
        let s = self.get(203);
        (s + self.get(200), s + self.get(201), s)
    }

    /// The radius the cycle moves the tool within around its axis, as the control's
    /// manuals describe it, and how far below the bottom (mm).
    fn reach(&self) -> (f64, f64) {
        match self.number {
            208 => (self.get(335) / 2.0, 0.0),
            262 => (self.get(335) / 2.0, 2.0 * self.get(239).abs()),
            252 => (self.get(223) / 2.0, 0.0),
            202 => (1.0, 0.0),
            _ => (0.0, 0.0),
        }
    }
}

fn tnc_calls(program: &str) -> Vec<Call> {
    let (mut x, mut y) = (f64::NAN, f64::NAN);
    let mut defining: Option<Call> = None;
    let mut in_force: Option<Call> = None;
    let mut continued = false;
    let mut calls = Vec::new();
    for line in program.lines() {
        let body = line.split(';').next().unwrap();
        let was_continued = continued;
        continued = line.trim_end().ends_with('~');
        if was_continued {
            let compact: String = body
                .chars()
                .filter(|c| !c.is_whitespace() && *c != '~')
                .collect();
            if let (Some(def), Some((name, value))) = (defining.as_mut(), compact.split_once('='))
                && let (Ok(k), Ok(v)) = (name[1..].parse::<u32>(), value.parse::<f64>())
            {
                def.q.insert(k, v);
            }
            if !continued && defining.is_some() {
                in_force = defining.take();
            }
            continue;
        }
        let rest: Vec<&str> = body.split_whitespace().skip(1).collect();
        match rest.first().copied() {
            Some("CYCL") => {
                let compact: String = rest[1..].concat();
                let number: String = compact
                    .strip_prefix("DEF")
                    .expect("CYCL DEF")
                    .chars()
                    .take_while(char::is_ascii_digit)
                    .collect();
                match number.parse::<u32>().unwrap() {
                    9 => {}
                    n => {
                        defining = Some(Call {
                            xy: [0.0; 2],
                            number: n,
                            q: Default::default(),
                        })
                    }
                }
            }
            Some("L") => {
                for w in &rest[1..] {
                    if let Some(v) = w.strip_prefix('X') {
                        x = v.parse().unwrap();
                    } else if let Some(v) = w.strip_prefix('Y') {
                        y = v.parse().unwrap();
                    }
                }
                if rest.contains(&"M99") {
                    let mut call = in_force.clone().expect("a call of a defined cycle");
                    call.xy = [x, y];
                    calls.push(call);
                }
            }
            _ => {}
        }
    }
    calls
}

/// A TNC program on the AC trunnion at A0 C0 that defines `definition` (its `~` lines)
/// as cycle `number` and calls it at each of `holes`; the tool stands at Z+50 before
/// them and FQ1 (800) is the feed in force; after them a rapid to Z+60 and a move at
/// that feed.
fn tnc_program(number: u32, definition: &str, holes: &[[f64; 2]]) -> String {
    let mut p = format!(
        "0 BEGIN PGM D MM\n1 FN 0:Q1=800\n2 FN 0:Q3=150\n3 L X+0 Y+0 Z+50 A+0 C+0 R0 FMAX\n4 L X+1 FQ1\n5 CYCL DEF {number} CYCLE~\n{definition}\n"
    );
    for (k, [x, y]) in holes.iter().enumerate() {
        p.push_str(&format!("{} L X{x:+.3} Y{y:+.3} R0 FMAX M99\n", k + 6));
    }
    let n = holes.len() + 6;
    p.push_str(&format!(
        "{n} L Z+60 R0 FMAX\n{} L X+0 Y+0\n{} L Z+100 R0 FMAX\n{} M30\n{} END PGM D MM\n",
        n + 1,
        n + 2,
        n + 3,
        n + 4
    ));
    p
}

/// The largest change, over the disk of radius `r` about a hole's axis at every depth
/// from `below` under its bottom to its set-up clearance, of the real tip's error from the
/// error on the axis at the same depth (mm), the written hole `(x, y, surface)` against the
/// programmed one; and the largest distance of the real tip from the programmed hole's
/// axis there (Z: the hole's axis at A0 C0).
fn around(
    kin: &Kinematics,
    programmed: &Call,
    written: &Call,
    (r, below): (f64, f64),
) -> (f64, f64) {
    let (top, bottom, surface) = programmed.levels();
    let shift = written.get(203) - surface;
    let tip = |model: Model, q: [f64; 5]| kin.pose(model, &q, 0.0).0.p;
    let (mut change, mut lateral): (f64, f64) = (0.0, 0.0);
    for j in 0..=30 {
        let z = (bottom - below) + (top - bottom + below) * j as f64 / 30.0;
        let n0 = tip(
            Model::Nominal,
            [programmed.xy[0], programmed.xy[1], z, 0.0, 0.0],
        );
        let r0 = tip(
            Model::Actual,
            [written.xy[0], written.xy[1], z + shift, 0.0, 0.0],
        );
        for ring in 1..=4 {
            for a in 0..60 {
                let t = a as f64 / 60.0 * std::f64::consts::TAU;
                let (dx, dy) = (
                    r * ring as f64 / 4.0 * t.cos(),
                    r * ring as f64 / 4.0 * t.sin(),
                );
                let n = tip(
                    Model::Nominal,
                    [programmed.xy[0] + dx, programmed.xy[1] + dy, z, 0.0, 0.0],
                );
                let real = tip(
                    Model::Actual,
                    [written.xy[0] + dx, written.xy[1] + dy, z + shift, 0.0, 0.0],
                );
                change = change.max(((real - r0) - (n - n0)).norm());
                let d = real - n;
                lateral = lateral.max(d.x.hypot(d.y));
            }
        }
    }
    (change, lateral)
}

/// Bore milling (208), thread milling (262), a circular pocket (252) and boring that moves
/// off the wall at the bottom (202 with Q214): each is compensated by its centre, axis and
/// depth; sampled over the disk it moves in at every depth, the real tool stays within
/// the tolerance of the programmed hole's axis, and the error's change from the axis's
/// stays within the bound nccomp states.
#[test]
fn tnc_cycles_that_move_around_their_axis_stay_within_their_bound() {
    let machine = ac_trunnion([0.0, 0.0, -100.0], [0.0, 0.0, 0.0]);
    let mut rng = Lcg(61);
    // A finer machine than `shop_errors`' (whose tables of ±15 µm change by up to 1 µm
    // over a D12 bore): its tables scaled to a tenth, X and Y out of square by 40 µrad
    // (0.24 µm over the 6 mm radius of a D12 bore).
    let mut errors = shop_errors(&machine, &mut rng);
    for axis in &mut errors.axes {
        if let Some(table) = axis.motion.as_mut() {
            for values in table.values.iter_mut().flatten() {
                for v in values.iter_mut() {
                    *v *= 0.1;
                }
            }
        }
    }
    errors.axes[1].squareness = Vector3::new(0.0, 0.0, 40e-6);
    let kin = Kinematics::new(&machine, &errors, 0).unwrap();
    let comp = Compensator::new(&machine, &errors, Options::default()).unwrap();
    let holes: Vec<[f64; 2]> = (0..5)
        .map(|_| [round_to(rng.sym(150.0), 3), round_to(rng.sym(150.0), 3)])
        .collect();
    let bound = axis_bound(1e-4);
    for (number, definition) in [
        (
            208,
            "  Q200=1 ;SET-UP CLEARANCE~\n  Q201=-12 ;DEPTH~\n  Q206=Q3 ;FEED RATE FOR PLUNGING~\n  Q334=1 ;PLUNGING DEPTH~\n  Q203=-1 ;SURFACE COORDINATE~\n  Q204=20 ;2ND SET-UP CLEARANCE~\n  Q335=12 ;NOMINAL DIAMETER~\n  Q342=11.8 ;ROUGHING DIAMETER",
        ),
        (
            262,
            "  Q335=10 ;NOMINAL DIAMETER~\n  Q239=+1.5 ;THREAD PITCH~\n  Q201=-10 ;DEPTH~\n  Q355=0 ;THREADS PER STEP~\n  Q253=Q3 ;F PRE-POSITIONING~\n  Q351=+1 ;CLIMB OR UP-CUT~\n  Q200=2 ;SET-UP CLEARANCE~\n  Q203=+0 ;SURFACE COORDINATE~\n  Q204=20 ;2ND SET-UP CLEARANCE~\n  Q207=Q1 ;FEED RATE FOR MILLING",
        ),
        (
            252,
            "  Q215=0 ;MACHINING OPERATION~\n  Q223=16 ;CIRCLE DIAMETER~\n  Q368=0.1 ;FINISHING ALLOWANCE FOR SIDE~\n  Q207=Q1 ;FEED RATE FOR MILLING~\n  Q351=+1 ;CLIMB OR UP-CUT~\n  Q201=-5 ;DEPTH~\n  Q202=2 ;PLUNGING DEPTH~\n  Q369=0 ;FINISHING ALLOWANCE FOR FLOOR~\n  Q206=Q3 ;FEED RATE FOR PLUNGING~\n  Q338=0 ;INFEED FOR FINISHING~\n  Q200=2 ;SET-UP CLEARANCE~\n  Q203=+0 ;SURFACE COORDINATE~\n  Q204=20 ;2ND SET-UP CLEARANCE~\n  Q370=1 ;TOOL PATH OVERLAP~\n  Q366=1 ;PLUNGE~\n  Q385=500 ;FINISHING FEED RATE",
        ),
        (
            202,
            "  Q200=2 ;SET-UP CLEARANCE~\n  Q201=-15 ;DEPTH~\n  Q206=100 ;FEED RATE FOR PLUNGING~\n  Q211=0.5 ;DWELL TIME AT BOTTOM~\n  Q208=500 ;RETRACTION FEED RATE~\n  Q203=+0 ;SURFACE COORDINATE~\n  Q204=20 ;2ND SET-UP CLEARANCE~\n  Q214=2 ;DISENGAGING DIRECTN~\n  Q336=0 ;ANGLE OF SPINDLE",
        ),
    ] {
        let program = tnc_program(number, definition, &holes);
        let mut out = Vec::new();
        let summary = comp
            .run(program.as_bytes(), "m.h", &mut out)
            .unwrap_or_else(|e| panic!("cycle {number}: {e}"));
        let written = String::from_utf8(out).unwrap();
        assert_eq!(summary.cycles_around, holes.len(), "cycle {number}");
        let (programmed, calls) = (tnc_calls(&program), tnc_calls(&written));
        assert_eq!(programmed.len(), calls.len());
        let (mut change, mut lateral, mut axis): (f64, f64, f64) = (0.0, 0.0, 0.0);
        for (p, w) in programmed.iter().zip(&calls) {
            let (top, bottom, _) = p.levels();
            let (wtop, wbottom, _) = w.levels();
            let at = |model: Model, xy: [f64; 2], z: f64| {
                kin.pose(model, &[xy[0], xy[1], z, 0.0, 0.0], 0.0).0.p
            };
            let off = (at(Model::Actual, w.xy, wbottom) - at(Model::Nominal, p.xy, bottom)).norm();
            assert!(
                off < 2e-4,
                "cycle {number}: a bottom {:.3} µm off",
                off * 1e3
            );
            axis = axis.max(off_axis(
                at(Model::Actual, w.xy, wtop),
                at(Model::Nominal, p.xy, bottom),
                at(Model::Nominal, p.xy, top),
            ));
            let (c, l) = around(&kin, p, w, p.reach());
            change = change.max(c);
            lateral = lateral.max(l);
        }
        eprintln!(
            "cycle {number}: axis at the set-up clearance within {:.3} µm; over its reach within {:.3} µm of the axis, the error changing by up to {:.3} µm from the axis's (nccomp's bound, with the axis's {:.3} µm)",
            axis * 1e3,
            lateral * 1e3,
            change * 1e3,
            summary.around_bound.value * 1e3
        );
        assert!(axis <= bound, "cycle {number}: {axis}");
        assert!(lateral <= bound, "cycle {number}: {:.3} µm", lateral * 1e3);
        assert!(
            change <= summary.around_bound.value,
            "cycle {number}: sampled {:.4} µm beyond the bound {:.4} µm",
            change * 1e3,
            summary.around_bound.value * 1e3
        );
        // The motion around the axis adds something to bound.
        if number != 202 {
            assert!(change > 0.05e-3, "cycle {number}: {change}");
        }
    }
}

/// Where the error field changes more than the tolerance over a cycle's radius (X and Y
/// out of square by 300 µrad: 1.8 µm over a D12 bore), the call is refused at its M99,
/// naming the bound; the change sampled over the disk is within it, and the bound is not
/// far above it.
#[test]
fn a_cycle_whose_motion_around_its_axis_exceeds_the_tolerance_is_refused_naming_the_bound() {
    let machine = ac_trunnion([0.0, 0.0, -100.0], [0.0, 0.0, 0.0]);
    let mut errors = shop_errors(&machine, &mut Lcg(67));
    errors.axes[1].squareness = Vector3::new(0.0, 0.0, 300e-6);
    let kin = Kinematics::new(&machine, &errors, 0).unwrap();
    let comp = Compensator::new(&machine, &errors, Options::default()).unwrap();
    let program = tnc_program(
        208,
        "  Q200=1 ;SET-UP CLEARANCE~\n  Q201=-12 ;DEPTH~\n  Q206=Q3 ;FEED RATE FOR PLUNGING~\n  Q334=1 ;PLUNGING DEPTH~\n  Q203=-1 ;SURFACE COORDINATE~\n  Q204=20 ;2ND SET-UP CLEARANCE~\n  Q335=12 ;NOMINAL DIAMETER~\n  Q342=11.8 ;ROUGHING DIAMETER",
        &[[35.25, -60.5]],
    );
    let err = comp
        .run(program.as_bytes(), "m.h", &mut Vec::new())
        .unwrap_err()
        .to_string();
    let call = program.lines().nth(14).unwrap();
    assert!(
        err.contains(&format!(
            "m.h:15:{}: this cycle call cannot be compensated: the motion of bore milling (208) within its nominal diameter Q335 = 12 around the hole's axis can add up to",
            call.find("M99").unwrap() + 1
        )),
        "{err}"
    );
    let named: f64 = err
        .split("can add up to ")
        .nth(1)
        .and_then(|s| s.split(" µm").next())
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| panic!("{err}"));
    // The written hole as nccomp solves it: its centre's correction (the test's own
    // solve), the same at every offset.
    let p = &tnc_calls(&program)[0];
    let b = solve_xyz(&kin, &[p.xy[0], p.xy[1], p.levels().1, 0.0, 0.0]);
    let mut w = p.clone();
    w.xy = [b[0], b[1]];
    w.q.insert(203, p.get(203) + (b[2] - p.levels().1));
    let (change, _) = around(&kin, p, &w, p.reach());
    eprintln!(
        "refused: the bound named {named:.2} µm; sampled over the disk {:.3} µm",
        change * 1e3
    );
    assert!(change * 1e3 <= named + 0.005, "{err}");
    assert!(named <= 1.5 * change * 1e3 + 0.1, "{err}");
}

/// One written TNC block in machine axes (A0 C0), as the control reads it: X, Y, Z where
/// it ends (modal), at FMAX or at feed (its F word's text, modal), or a dwell.
#[derive(Debug, Clone, PartialEq)]
enum Block {
    Move {
        q: [f64; 3],
        rapid: bool,
        feed: String,
    },
    Dwell(f64),
}

fn tnc_blocks(program: &str) -> Vec<(usize, Block)> {
    let mut q = [f64::NAN; 3];
    let mut feed = String::new();
    let mut blocks = Vec::new();
    for (i, line) in program.lines().enumerate() {
        let body = line.split(';').next().unwrap();
        let rest: Vec<&str> = body.split_whitespace().skip(1).collect();
        match rest.first().copied() {
            Some("CYCL") if rest.len() >= 5 && rest[2] == "9.1" => {
                blocks.push((i, Block::Dwell(rest[4].parse().unwrap())));
            }
            Some("L") => {
                let mut rapid = false;
                let mut moved = false;
                for w in &rest[1..] {
                    match *w {
                        "FMAX" => rapid = true,
                        w if w.starts_with('F') => feed = w.to_string(),
                        w if "XYZ".contains(&w[..1]) => {
                            q["XYZ".find(&w[..1]).unwrap()] = w[1..].parse().unwrap();
                            moved = true;
                        }
                        _ => {}
                    }
                }
                if moved || !rapid {
                    blocks.push((
                        i,
                        Block::Move {
                            q,
                            rapid,
                            feed: feed.clone(),
                        },
                    ));
                }
            }
            _ => {}
        }
    }
    blocks
}

/// Deep holes leaning 150 µrad (6 µm over 40 mm, far beyond one X, Y) are written out as
/// L moves: read as the control reads the written blocks, each hole is the cycle's motion
/// as its description gives it (200: pecks of Q202 from the set-up clearance above the
/// depth reached, the dwells at the top and the bottom; 201: out at the retraction feed;
/// 240: to its depth and back), every block ending on the programmed hole's axis at its
/// level, each move at feed staying within the tolerance of the axis, at the cycle's feed;
/// then the program's feed (FQ1) is given back where the tool stands. The numbering stays
/// consecutive, and the program's other blocks come out as they would.
#[test]
fn tnc_holes_one_xy_cannot_serve_are_written_out_as_their_motion() {
    let machine = ac_trunnion([0.0, 0.0, -100.0], [0.0, 0.0, 0.0]);
    let errors = leaning_errors(&machine, 71, 150e-6);
    let kin = Kinematics::new(&machine, &errors, 0).unwrap();
    let options = Options {
        path: Some(nccomp::kinematics::path::PathTolerance::default()),
        ..Options::default()
    };
    let comp = Compensator::new(&machine, &errors, options).unwrap();
    let holes = [[20.0, -35.5], [-64.25, 12.0]];
    for (number, definition, expected) in [
        (
            200,
            "  Q200=2 ;SET-UP CLEARANCE~\n  Q201=-40 ;DEPTH~\n  Q206=Q3 ;FEED RATE FOR PLUNGING~\n  Q202=15 ;PLUNGING DEPTH~\n  Q210=0.5 ;DWELL TIME AT TOP~\n  Q203=-1 ;SURFACE COORDINATE~\n  Q204=30 ;2ND SET-UP CLEARANCE~\n  Q211=1.5 ;DWELL TIME AT BOTTOM",
            // (level, rapid, feed) or a dwell: the cycle's description, by hand.
            vec![
                (1.0, true, ""),
                (-16.0, false, "FQ3"),
                (1.0, true, ""),
                (-0.5, false, ""),
                (-14.0, true, ""),
                (-31.0, false, "FQ3"),
                (1.0, true, ""),
                (-0.5, false, ""),
                (-29.0, true, ""),
                (-41.0, false, "FQ3"),
                (-1.5, false, ""),
                (29.0, true, ""),
            ],
        ),
        (
            201,
            "  Q200=2 ;SET-UP CLEARANCE~\n  Q201=-36 ;DEPTH~\n  Q206=Q3 ;FEED RATE FOR PLUNGING~\n  Q211=0 ;DWELL TIME AT BOTTOM~\n  Q208=400 ;RETRACTION FEED RATE~\n  Q203=+0 ;SURFACE COORDINATE~\n  Q204=15 ;2ND SET-UP CLEARANCE",
            vec![
                (2.0, true, ""),
                (-36.0, false, "FQ3"),
                (2.0, false, "F400"),
                (15.0, true, ""),
            ],
        ),
        (
            240,
            "  Q200=2 ;SET-UP CLEARANCE~\n  Q343=0 ;SELECT DIA./DEPTH~\n  Q201=-38 ;DEPTH~\n  Q344=-9 ;DIAMETER~\n  Q206=Q3 ;FEED RATE FOR PLUNGING~\n  Q211=0.2 ;DWELL TIME AT DEPTH~\n  Q203=+0 ;SURFACE COORDINATE~\n  Q204=10 ;2ND SET-UP CLEARANCE",
            vec![
                (2.0, true, ""),
                (-38.0, false, "FQ3"),
                (-0.2, false, ""),
                (10.0, true, ""),
            ],
        ),
    ] {
        let program = tnc_program(number, definition, &holes);
        let mut out = Vec::new();
        let summary = comp
            .run(program.as_bytes(), "w.h", &mut out)
            .unwrap_or_else(|e| panic!("cycle {number}: {e}"));
        let written = String::from_utf8(out).unwrap();
        assert_eq!(summary.holes_written_out, holes.len(), "{written}");
        assert!(!written.contains("M99"), "{written}");
        // Consecutive block numbers.
        let numbers: Vec<u64> = written
            .lines()
            .filter_map(|l| l.split_whitespace().next()?.parse().ok())
            .collect();
        assert!(numbers.windows(2).all(|w| w[1] == w[0] + 1), "{written}");
        let blocks = tnc_blocks(&written);
        let at =
            |model: Model, q: [f64; 3]| kin.pose(model, &[q[0], q[1], q[2], 0.0, 0.0], 0.0).0.p;
        // The blocks before the first hole: as the program's.
        let mut k = blocks
            .iter()
            .position(|(i, _)| written.lines().nth(*i).unwrap().contains("X+20") || *i >= 7)
            .unwrap();
        let (mut ends, mut path): (f64, f64) = (0.0, 0.0);
        // Where the tool stands along Z: Z+50, then where each hole leaves it.
        let mut height = 50.0;
        for &[x, y] in &holes {
            // The positioning: to the hole's X, Y at that height (at FMAX).
            let Block::Move { q, rapid, .. } = &blocks[k].1 else {
                panic!("{written}")
            };
            assert!(*rapid);
            let off = (at(Model::Actual, *q) - at(Model::Nominal, [x, y, height])).norm();
            assert!(off < 2e-4, "the positioning {off}\n{written}");
            let mut from = height;
            let mut last = *q;
            k += 1;
            for &(level, rapid, feed) in &expected {
                if !rapid && feed.is_empty() {
                    assert_eq!(blocks[k].1, Block::Dwell(-level), "{written}");
                    k += 1;
                    continue;
                }
                // The block (and any pieces before it) ending at the level on the axis.
                let target = at(Model::Nominal, [x, y, level]);
                let axis = (at(Model::Nominal, [x, y, from]), target);
                loop {
                    let Block::Move {
                        q,
                        rapid: r,
                        feed: f,
                    } = &blocks[k].1
                    else {
                        panic!("a dwell where the hole moves: {written}")
                    };
                    k += 1;
                    assert_eq!(*r, rapid, "{written}");
                    if !rapid {
                        assert_eq!(f, feed, "{written}");
                        let dev =
                            |q: [f64; 3]| off_axis_segment(at(Model::Actual, q), axis.0, axis.1);
                        let floor = dev(last) + dev(*q);
                        for j in 0..=40 {
                            let u = j as f64 / 40.0;
                            let p: [f64; 3] =
                                std::array::from_fn(|c| last[c] + (q[c] - last[c]) * u);
                            let d = dev(p);
                            path = path.max(d);
                            assert!(
                                d <= 1e-3 + floor,
                                "cycle {number}: {:.3} µm off the axis\n{written}",
                                d * 1e3
                            );
                        }
                    }
                    last = *q;
                    let off = (at(Model::Actual, *q) - target).norm();
                    if off < 5e-4 {
                        ends = ends.max(off);
                        assert!(
                            off < 2e-4,
                            "cycle {number}: a block ends {off} off\n{written}"
                        );
                        break;
                    }
                    assert!(!rapid, "a rapid was split\n{written}");
                }
                from = level;
            }
            // The program's feed given back, where the tool stands.
            let Block::Move { q, rapid, feed } = &blocks[k].1 else {
                panic!("{written}")
            };
            assert!(!rapid && feed == "FQ1" && *q == last, "{written}");
            k += 1;
            height = from;
        }
        // The program's rapid to Z+60, then its feed move at FQ1.
        let Block::Move { rapid, .. } = &blocks[k].1 else {
            panic!("{written}")
        };
        assert!(*rapid, "{written}");
        let Block::Move { feed, rapid, .. } = &blocks[k + 1].1 else {
            panic!("{written}")
        };
        assert!(!rapid && feed == "FQ1");
        eprintln!(
            "cycle {number}: {} holes written out as {} blocks, every block end within {:.3} µm of the hole's axis point, moves at feed within {:.3} µm of the axis",
            holes.len(),
            summary.hole_blocks_added + holes.len(),
            ends * 1e3,
            path * 1e3
        );
        // As a cycle call the same hole is refused: it could not be served by one X, Y.
        let (unrounded, _) = tnc_lean(&kin, [holes[0][0], holes[0][1], 0.0, -36.0, 2.0]);
        assert!(unrounded > 3e-3, "{unrounded}");
    }
}

/// The distance of `p` from the segment from `a` to `b`.
fn off_axis_segment(p: Vector3<f64>, a: Vector3<f64>, b: Vector3<f64>) -> f64 {
    let d = b - a;
    let s = ((p - a).dot(&d) / d.norm_squared().max(1e-30)).clamp(0.0, 1.0);
    (p - (a + d * s)).norm()
}

/// Holes one X, Y cannot serve whose motion nccomp does not write out are refused at
/// their call, naming why: tapping (the spindle turns with the feed), universal drilling's
/// chip breaking, single-lip deep-hole drilling's spindle and coolant changes.
#[test]
fn tnc_holes_whose_motion_is_not_written_out_are_refused_with_the_reason() {
    let machine = ac_trunnion([0.0, 0.0, -100.0], [0.0, 0.0, 0.0]);
    let errors = leaning_errors(&machine, 71, 150e-6);
    let comp = Compensator::new(&machine, &errors, Options::default()).unwrap();
    for (number, definition, why) in [
        (
            207,
            "  Q200=2 ;SET-UP CLEARANCE~\n  Q201=-30 ;DEPTH~\n  Q239=+1.25 ;THREAD PITCH~\n  Q203=+0 ;SURFACE COORDINATE~\n  Q204=50 ;2ND SET-UP CLEARANCE",
            "tapping turns the spindle with the feed",
        ),
        (
            203,
            "  Q200=2 ;SET-UP CLEARANCE~\n  Q201=-30 ;DEPTH~\n  Q206=150 ;FEED RATE FOR PLUNGING~\n  Q202=10 ;PLUNGING DEPTH~\n  Q210=0 ;DWELL TIME AT TOP~\n  Q203=+0 ;SURFACE COORDINATE~\n  Q204=50 ;2ND SET-UP CLEARANCE~\n  Q212=0.2 ;DECREMENT~\n  Q213=3 ;BREAKS~\n  Q205=3 ;MIN. PLUNGING DEPTH~\n  Q211=0.25 ;DWELL TIME AT DEPTH~\n  Q208=500 ;RETRACTION FEED RATE~\n  Q256=0.2 ;DIST. FOR CHIP BRKNG",
            "chip breaking",
        ),
        (
            241,
            "  Q200=2 ;SET-UP CLEARANCE~\n  Q201=-30 ;DEPTH~\n  Q206=25 ;FEED RATE FOR PLUNGING~\n  Q211=0 ;DWELL TIME AT BOTTOM~\n  Q203=+0 ;SURFACE COORDINATE~\n  Q204=30 ;2ND SET-UP CLEARANCE~\n  Q379=5 ;STARTING POINT~\n  Q253=50 ;F PRE-POSITIONING~\n  Q208=300 ;RETRACTION FEED TIME~\n  Q426=3 ;DIR. OF SPINDLE ROT.~\n  Q427=50 ;ROT. SPEED INFEED/OUT~\n  Q428=1194 ;DRILLING SPEED~\n  Q429=8 ;COOLANT ON~\n  Q430=9 ;COOLANT OFF~\n  Q435=0 ;DWELL DEPTH",
            "spindle's speed and direction and the coolant",
        ),
    ] {
        let program = tnc_program(number, definition, &[[20.0, -35.5]]);
        let err = comp
            .run(program.as_bytes(), "r.h", &mut Vec::new())
            .unwrap_err()
            .to_string();
        let call = program.lines().find(|l| l.contains("M99")).unwrap();
        let line = program.lines().position(|l| l == call).unwrap() + 1;
        assert!(
            err.contains(&format!(
                "r.h:{line}:{}: this cycle call cannot be compensated: one X, Y cannot serve the whole depth here",
                call.find("M99").unwrap() + 1
            )) && err.contains("nccomp does not write it out as L moves")
                && err.contains(why),
            "cycle {number}: {err}"
        );
    }
}

/// `CYCL CALL` gives no X, Y: where the hole needs another X, Y than the positioning
/// block's (the tool leans 30 µrad: 1.9 µm between Z+50 and the bottom, 0.4 µm over the
/// hole, which one X, Y would serve), it is written out as L moves where nccomp knows the
/// cycle's motion (they carry X, Y), its bottom where it is meant; a tapping cycle, which
/// is not written out, is refused there as before.
#[test]
fn a_cycl_call_that_needs_a_corrected_xy_is_written_out() {
    let machine = ac_trunnion([0.0, 0.0, -100.0], [0.0, 0.0, 0.0]);
    let errors = leaning_errors(&machine, 73, 30e-6);
    let kin = Kinematics::new(&machine, &errors, 0).unwrap();
    let comp = Compensator::new(&machine, &errors, Options::default()).unwrap();
    let program = |number: u32, definition: &str| {
        format!(
            "0 BEGIN PGM D MM\n1 FN 0:Q3=150\n2 L X+0 Y+0 Z+50 A+0 C+0 R0 FMAX\n3 CYCL DEF {number} CYCLE~\n{definition}\n4 L X+20 Y-35.5 R0 FMAX\n5 CYCL CALL\n6 L Z+100 R0 FMAX\n7 M30\n8 END PGM D MM\n"
        )
    };
    let drilling = program(
        200,
        "  Q200=2 ;SET-UP CLEARANCE~\n  Q201=-12 ;DEPTH~\n  Q206=Q3 ;FEED RATE FOR PLUNGING~\n  Q202=12 ;PLUNGING DEPTH~\n  Q203=+0 ;SURFACE COORDINATE~\n  Q204=20 ;2ND SET-UP CLEARANCE",
    );
    let mut out = Vec::new();
    let summary = comp
        .run(drilling.as_bytes(), "c.h", &mut out)
        .unwrap_or_else(|e| panic!("{e}"));
    let written = String::from_utf8(out).unwrap();
    assert_eq!(summary.holes_written_out, 1, "{written}");
    assert!(!written.contains("CYCL CALL"), "{written}");
    let numbers: Vec<u64> = written
        .lines()
        .filter_map(|l| l.split_whitespace().next()?.parse().ok())
        .collect();
    assert!(numbers.windows(2).all(|w| w[1] == w[0] + 1), "{written}");
    // Its blocks: to the set-up clearance, to the bottom at FQ3, out to the 2nd set-up
    // clearance; the bottom where it is meant.
    let blocks = tnc_blocks(&written);
    let moves: Vec<([f64; 3], bool, String)> = blocks
        .iter()
        .filter_map(|(_, b)| match b {
            Block::Move { q, rapid, feed } => Some((*q, *rapid, feed.clone())),
            Block::Dwell(_) => None,
        })
        .collect();
    let bottom = moves
        .iter()
        .find(|(_, rapid, feed)| !rapid && feed == "FQ3")
        .unwrap_or_else(|| panic!("{written}"));
    let at = |model: Model, q: [f64; 3]| kin.pose(model, &[q[0], q[1], q[2], 0.0, 0.0], 0.0).0.p;
    let off = (at(Model::Actual, bottom.0) - at(Model::Nominal, [20.0, -35.5, -12.0])).norm();
    assert!(
        off < 2e-4,
        "the bottom is {:.3} µm off\n{written}",
        off * 1e3
    );
    assert!(
        (bottom.0[0] - 20.0).abs() > 1e-4,
        "X needs its correction: {written}"
    );
    let tapping = program(
        207,
        "  Q200=2 ;SET-UP CLEARANCE~\n  Q201=-12 ;DEPTH~\n  Q239=+1.25 ;THREAD PITCH~\n  Q203=+0 ;SURFACE COORDINATE~\n  Q204=20 ;2ND SET-UP CLEARANCE",
    );
    let err = comp
        .run(tapping.as_bytes(), "c.h", &mut Vec::new())
        .unwrap_err()
        .to_string();
    let line = tapping
        .lines()
        .position(|l| l.contains("CYCL CALL"))
        .unwrap()
        + 1;
    assert!(
        err.contains(&format!("c.h:{line}:3: this cycle call cannot be compensated: the hole needs a corrected X, Y and the call does not give them")),
        "{err}"
    );
}

/// After a cycle that moves the tool around its axis, where the control leaves the tool
/// in the plane is its own: a feed move right after the call is refused at its line, a
/// rapid positioning first passes.
#[test]
fn a_feed_move_right_after_a_cycle_around_its_axis_is_refused() {
    let machine = ac_trunnion([0.0, 0.0, -100.0], [0.0, 0.0, 0.0]);
    let errors = ErrorModel::zero(&machine);
    let mut errors = errors;
    errors.axes[1].squareness = Vector3::new(0.0, 0.0, 20e-6);
    let comp = Compensator::new(&machine, &errors, Options::default()).unwrap();
    let definition = "  Q200=1 ;SET-UP CLEARANCE~\n  Q201=-12 ;DEPTH~\n  Q206=Q3 ;FEED RATE FOR PLUNGING~\n  Q334=1 ;PLUNGING DEPTH~\n  Q203=-1 ;SURFACE COORDINATE~\n  Q204=20 ;2ND SET-UP CLEARANCE~\n  Q335=12 ;NOMINAL DIAMETER~\n  Q342=11.8 ;ROUGHING DIAMETER";
    let program = tnc_program(208, definition, &[[35.25, -60.5]]);
    comp.run(program.as_bytes(), "f.h", &mut Vec::new())
        .unwrap_or_else(|e| panic!("{e}"));
    let right_after = program.replace("7 L Z+60 R0 FMAX", "7 L X+10 Y+5");
    let err = comp
        .run(right_after.as_bytes(), "f.h", &mut Vec::new())
        .unwrap_err()
        .to_string();
    let line = right_after
        .lines()
        .position(|l| l == "7 L X+10 Y+5")
        .unwrap()
        + 1;
    assert!(
        err.contains(&format!(
            "f.h:{line}:5: a feed move right after the cycle called at line {}",
            line - 1
        )),
        "{err}"
    );
}
