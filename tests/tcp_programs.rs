//! G43.4 programs through the pass: the controller's nominal solve of the written tip and
//! rotary words lands the real machine on the programmed pose.

mod common;

use common::{Lcg, ac_trunnion, random_errors};
use nalgebra::Vector3;
use nccomp::compensate::{Compensator, Options};
use nccomp::kinematics::{Kinematics, Model, SolveOptions};

fn words(line: &str, q: &mut [f64; 5]) -> bool {
    let mut moved = false;
    for word in line.split('(').next().unwrap().split_whitespace() {
        if let Some(k) = "XYZAC".find(&word[..1]) {
            q[k] = word[1..].parse().unwrap();
            moved = true;
        }
    }
    moved
}

#[test]
fn g43_4_programs_land_the_real_machine_on_the_programmed_tip_and_direction() {
    let mut machine = ac_trunnion([0.0, 0.0, -100.0], [0.0, 0.0, 0.0]);
    machine.tool.lengths.insert(1, 0.0);
    let errors = random_errors(&machine, &mut Lcg(23));
    let kin = Kinematics::new(&machine, &errors, 0).unwrap();
    let mut rng = Lcg(5);
    let mut program = String::from("G21 G90\nG0 X0 Y0 Z100 A0 C0\nG43.4 H1\n");
    for _ in 0..150 {
        program.push_str(&format!(
            "G1 X{:.4} Y{:.4} Z{:.4} A{:.4} C{:.4}\n",
            rng.sym(80.0),
            rng.sym(80.0),
            20.0 + rng.sym(15.0),
            -70.0 + rng.sym(60.0),
            rng.sym(170.0)
        ));
    }
    program.push_str("G49\nG0 Z100\nM30\n");
    let comp = Compensator::new(&machine, &errors, Options::default()).unwrap();
    let mut out = Vec::new();
    let summary = comp.run(program.as_bytes(), "tcp.nc", &mut out).unwrap();
    let out = String::from_utf8(out).unwrap();
    assert_eq!(out.lines().count(), program.lines().count());
    assert!(summary.words_changed > 0);
    let opts = SolveOptions::default();
    let (mut qi, mut qo) = ([0.0; 5], [0.0; 5]);
    let mut tcp = false;
    let mut controller = [0.0; 5];
    for (li, lo) in program.lines().zip(out.lines()) {
        if li.starts_with("G43.4") {
            tcp = true;
            continue;
        }
        if li.starts_with("G49") {
            tcp = false;
        }
        let moved = words(li, &mut qi);
        words(lo, &mut qo);
        if !moved || !tcp {
            continue;
        }
        // Intended: the programmed tip, the direction of the programmed rotaries.
        let (at_rotaries, _) = kin.pose(Model::Nominal, &[0.0, 0.0, 0.0, qi[3], qi[4]], 0.0);
        let intended_p = Vector3::new(qi[0], qi[1], qi[2]);
        // The controller: linear axes from the written tip at the written rotaries.
        let mut guess = controller;
        guess[3] = qo[3];
        guess[4] = qo[4];
        let sol =
            kin.tcp_axes_with_rotaries(&Vector3::new(qo[0], qo[1], qo[2]), &guess, 0.0, &opts);
        controller = sol.q[..5].try_into().unwrap();
        let (reached, _) = kin.pose(Model::Actual, &controller, 0.0);
        let dp = (reached.p - intended_p).norm();
        assert!(dp < 1e-3, "{lo}: tip off by {dp} mm");
        if qi[3].abs() >= 3.0 {
            let dd = nccomp::kinematics::angle_between(&reached.o, &at_rotaries.o);
            assert!(dd < 10e-6, "{lo}: direction off by {dd} rad");
        }
    }
}

fn vector_words(line: &str, tip: &mut [f64; 3], vector: &mut [f64; 3]) -> bool {
    let body = line.split('(').next().unwrap();
    let mut moved = false;
    let mut given = false;
    let mut ijk = [0.0; 3];
    for word in body.split_whitespace() {
        let value = || word[1..].parse::<f64>().unwrap();
        if let Some(k) = "XYZ".find(&word[..1]) {
            tip[k] = value();
            moved = true;
        } else if let Some(k) = "IJK".find(&word[..1]) {
            ijk[k] = value();
            given = true;
            moved = true;
        }
    }
    if given {
        *vector = ijk;
    }
    moved
}

#[test]
fn g43_5_programs_land_the_real_machine_on_the_programmed_tip_and_vector() {
    let mut machine = ac_trunnion([0.0, 0.0, -100.0], [0.0, 0.0, 0.0]);
    machine.tool.lengths.insert(1, 0.0);
    let errors = random_errors(&machine, &mut Lcg(31));
    let kin = Kinematics::new(&machine, &errors, 0).unwrap();
    let mut rng = Lcg(9);
    // A start away from the singular A = 0, where C (and so the branch) is undetermined.
    let mut program = String::from("G21 G90\nG0 X0 Y0 Z100 A-30 C0\nG43.5 H1\n");
    // Tool vectors of reachable poses, in small steps (as CAM writes them), some blocks
    // without a vector (the previous one stays).
    let (mut a, mut c) = (-30.0f64, 0.0f64);
    for k in 0..150 {
        a = (a + rng.sym(4.0)).clamp(-95.0, -5.0);
        c += rng.sym(6.0);
        let (pose, _) = kin.pose(Model::Nominal, &[0.0, 0.0, 0.0, a, c], 0.0);
        let o = pose.o;
        let tip = format!(
            "X{:.4} Y{:.4} Z{:.4}",
            rng.sym(80.0),
            rng.sym(80.0),
            20.0 + rng.sym(15.0)
        );
        match k % 10 {
            0 => {
                program.push_str(&format!("G1 {tip}\n"));
                continue;
            }
            _ => program.push_str(&format!("G1 {tip} I{:.6} J{:.6} K{:.6}\n", o.x, o.y, o.z)),
        }
    }
    program.push_str("G49\nG0 Z100\nM30\n");
    let comp = Compensator::new(&machine, &errors, Options::default()).unwrap();
    let mut out = Vec::new();
    let summary = comp.run(program.as_bytes(), "tcp5.nc", &mut out).unwrap();
    let out = String::from_utf8(out).unwrap();
    assert_eq!(out.lines().count(), program.lines().count());
    assert!(summary.words_changed > 100, "{summary:?}");
    let opts = SolveOptions::default();
    let (mut tip_in, mut tip_out) = ([0.0; 3], [0.0; 3]);
    // Until a block gives one, the vector is the direction at the axes where G43.5 began.
    let (start, _) = kin.pose(Model::Nominal, &[0.0, 0.0, 100.0, -30.0, 0.0], 0.0);
    let (mut vec_in, mut vec_out): ([f64; 3], [f64; 3]) = (start.o.into(), start.o.into());
    let mut tcp = false;
    let mut checked = 0;
    // The controller: its nominal inverse kinematics from where the axes are.
    let mut controller = [0.0, 0.0, 100.0, -30.0, 0.0];
    let mut intended_axes = controller;
    for (li, lo) in program.lines().zip(out.lines()) {
        if li.starts_with("G43.5") {
            tcp = true;
            continue;
        }
        if li.starts_with("G49") {
            tcp = false;
        }
        let moved = vector_words(li, &mut tip_in, &mut vec_in);
        vector_words(lo, &mut tip_out, &mut vec_out);
        if !moved || !tcp {
            continue;
        }
        let intended = nccomp::kinematics::Pose {
            p: Vector3::from(tip_in),
            o: Vector3::from(vec_in).normalize(),
        };
        let written = nccomp::kinematics::Pose {
            p: Vector3::from(tip_out),
            o: Vector3::from(vec_out).normalize(),
        };
        let sol = kin
            .inverse(Model::Nominal, &written, &controller, 0.0, &opts)
            .unwrap_or_else(|| panic!("{lo}: the controller finds no axes"));
        controller = sol.q[..5].try_into().unwrap();
        let nominal = kin
            .inverse(Model::Nominal, &intended, &intended_axes, 0.0, &opts)
            .unwrap();
        intended_axes = nominal.q[..5].try_into().unwrap();
        let (reached, _) = kin.pose(Model::Actual, &controller, 0.0);
        let dp = (reached.p - intended.p).norm();
        assert!(dp < 1e-3, "{lo}: tip off by {dp} mm");
        // The same branch as the uncompensated program: axes within a correction's reach.
        for k in 0..5 {
            assert!(
                (controller[k] - intended_axes[k]).abs() < 0.05,
                "{lo}: axis {k} at {} instead of near {}",
                controller[k],
                intended_axes[k]
            );
        }
        let dd = nccomp::kinematics::angle_between(&reached.o, &intended.o);
        assert!(dd < 10e-6, "{lo}: direction off by {dd} rad");
        checked += 1;
    }
    assert_eq!(checked, 150);
}

#[test]
fn g43_5_refuses_rotary_words_and_zero_vectors() {
    let mut machine = ac_trunnion([0.0, 0.0, -100.0], [0.0, 0.0, 0.0]);
    machine.tool.lengths.insert(1, 0.0);
    let errors = random_errors(&machine, &mut Lcg(3));
    let comp = Compensator::new(&machine, &errors, Options::default()).unwrap();
    for (program, col, what) in [
        ("G43.5 H1\nG1 X1 Y2 Z30 A-20\n", 14, "A is a rotary word"),
        (
            "G43.5 H1\nG0 X1 Y2 Z30 I0 J0 K1\nG1 X1 I0 J0 K0\n",
            4,
            "the tool vector I, J, K is zero",
        ),
        (
            "G43.5 H1\nG0 X1 Y2 Z30 I0 J0 K1\nG1 X1 R5\n",
            7,
            "R words are not expected under G43.5",
        ),
    ] {
        let mut out = Vec::new();
        let err = comp
            .run(program.as_bytes(), "p.nc", &mut out)
            .unwrap_err()
            .to_string();
        let line = program.lines().count();
        assert!(
            err.contains(&format!("p.nc:2:{col}: {what}"))
                || err.contains(&format!("p.nc:{line}:{col}: {what}")),
            "{err}"
        );
    }
}
