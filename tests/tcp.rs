//! Tool-centre-point correction: what is written, solved by the controller's nominal
//! inverse kinematics, lands the real machine on the intended pose.

mod common;

use common::{Lcg, ac_trunnion, head_head, random_errors};
use nccomp::kinematics::{Kinematics, Model, SolveOptions};

#[test]
fn the_controllers_nominal_solve_of_the_written_pose_lands_the_real_machine() {
    let opts = SolveOptions::default();
    for (machine, seed) in [
        (ac_trunnion([0.0, 0.0, -100.0], [0.0, 0.0, 0.0]), 3u64),
        (head_head(150.0), 4),
    ] {
        let errors = random_errors(&machine, &mut Lcg(seed));
        let kin = Kinematics::new(&machine, &errors, 0).unwrap();
        let mut rng = Lcg(seed + 100);
        for _ in 0..200 {
            let q = [
                rng.sym(200.0),
                rng.sym(200.0),
                50.0 + rng.sym(40.0),
                -60.0 + rng.sym(50.0),
                rng.sym(170.0),
            ];
            let (intended, _) = kin.pose(Model::Nominal, &q, 0.0);
            let fix = kin.compensate_tcp(&q, 0.0, 0, &opts);
            // The controller: nominal inverse kinematics of the written pose, on the branch
            // nearest the previous position.
            let ctrl = kin
                .inverse(Model::Nominal, &fix.programmed, &q, 0.0, &opts)
                .expect("the written pose is reachable");
            let (reached, _) = kin.pose(Model::Actual, ctrl.values(), 0.0);
            let (dp, dd) = reached.deviation(&intended);
            assert!(dp < 1e-6, "tip {dp} mm at {q:?}");
            // At a singular pose the held axis leaves its direction error, as in any block.
            if fix.solution.singular == 0 {
                assert!(dd < 1e-8, "direction {dd} rad at {q:?}");
            }
        }
    }
}

#[test]
fn g43_4_linear_axes_follow_from_the_tip_and_the_programmed_rotaries() {
    let machine = ac_trunnion([0.0, 0.0, -100.0], [0.0, 0.0, 0.0]);
    let errors = random_errors(&machine, &mut Lcg(9));
    let kin = Kinematics::new(&machine, &errors, 0).unwrap();
    let q = [35.0, -20.0, 60.0, -40.0, 75.0];
    let (pose, _) = kin.pose(Model::Nominal, &q, 0.0);
    let guess = [0.0, 0.0, 0.0, -40.0, 75.0];
    let sol = kin.tcp_axes_with_rotaries(&pose.p, &guess, 0.0, &SolveOptions::default());
    for (got, want) in sol.values().iter().zip(q) {
        assert!((got - want).abs() < 1e-9, "{:?}", sol.values());
    }
}
