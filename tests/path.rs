//! The path between block ends: measuring how far a compensated move strays, and splitting
//! it until it does not.

mod common;

use common::{Lcg, ac_trunnion, random_errors};
use nccomp::kinematics::path::PathTolerance;
use nccomp::kinematics::{Kinematics, SolveOptions};
use nccomp::model::ErrorModel;

fn setup(seed: u64) -> (nccomp::model::Machine, ErrorModel) {
    let machine = ac_trunnion([0.0, 0.0, -100.0], [0.0, 0.0, 0.0]);
    let errors = random_errors(&machine, &mut Lcg(seed));
    (machine, errors)
}

const EIGHTHS: [f64; 7] = [0.125, 0.25, 0.375, 0.5, 0.625, 0.75, 0.875];

#[test]
fn a_perfect_machine_needs_no_split() {
    let (machine, _) = setup(1);
    let kin = Kinematics::new(&machine, &ErrorModel::zero(&machine), 0).unwrap();
    let opts = SolveOptions::default();
    let (qa, qb) = (
        [-200.0, 10.0, 50.0, -60.0, 0.0],
        [200.0, -30.0, 20.0, 20.0, 180.0],
    );
    let dev = kin.deviation((&qa, &qb), (&qa, &qb), 0.0, &EIGHTHS, &opts);
    // Zero but for rounding: the target comes with its Jacobian, the real pose without,
    // and the two take their products in different orders.
    assert!(dev.position < 1e-12, "{}", dev.position);
    let pieces = kin.subdivide(
        (&qa, &qb),
        (&qa, &qb),
        0.0,
        0,
        &PathTolerance::default(),
        &opts,
    );
    assert_eq!(pieces.len(), 1);
    assert_eq!(pieces[0].s, 1.0);
}

#[test]
fn long_moves_are_split_until_every_piece_holds() {
    let opts = SolveOptions::default();
    let tol = PathTolerance::default();
    for seed in 1..=6 {
        let (machine, errors) = setup(seed);
        let kin = Kinematics::new(&machine, &errors, 0).unwrap();
        let mut rng = Lcg(seed * 7);
        for _ in 0..5 {
            let qa = [
                rng.sym(200.0),
                rng.sym(200.0),
                50.0 + rng.sym(40.0),
                -60.0 + rng.sym(50.0),
                rng.sym(180.0),
            ];
            let qb = [
                rng.sym(200.0),
                rng.sym(200.0),
                50.0 + rng.sym(40.0),
                -60.0 + rng.sym(50.0),
                rng.sym(180.0),
            ];
            let ca = kin.compensate(&qa, 0.0, 0, &opts);
            let cb = kin.compensate(&qb, 0.0, 0, &opts);
            let before =
                kin.deviation((&qa, &qb), (ca.values(), cb.values()), 0.0, &EIGHTHS, &opts);
            let pieces = kin.subdivide((&qa, &qb), (ca.values(), cb.values()), 0.0, 0, &tol, &opts);
            assert_eq!(pieces.last().unwrap().s, 1.0);
            assert_eq!(&pieces.last().unwrap().q[..5], cb.values());
            if before.position > 2.0 * tol.position {
                assert!(
                    pieces.len() > 1,
                    "a {} mm deviation is split",
                    before.position
                );
            }
            // Every piece, sampled more finely than the split looked, stays close.
            let mut s0 = 0.0;
            let mut c0 = ca.q;
            for piece in &pieces {
                let lerp =
                    |s: f64| -> Vec<f64> { (0..5).map(|k| qa[k] + (qb[k] - qa[k]) * s).collect() };
                let (n0, n1) = (lerp(s0), lerp(piece.s));
                let dev =
                    kin.deviation((&n0, &n1), (&c0[..5], &piece.q[..5]), 0.0, &EIGHTHS, &opts);
                assert!(
                    dev.position < 1.5e-3,
                    "seed {seed}: piece [{s0}, {}] strays {} mm",
                    piece.s,
                    dev.position
                );
                assert!(
                    dev.direction < 15e-6,
                    "seed {seed}: piece strays {} rad",
                    dev.direction
                );
                s0 = piece.s;
                c0 = piece.q;
            }
        }
    }
}
