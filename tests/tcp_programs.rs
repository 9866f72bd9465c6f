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
