//! The kinematics and the solve, against closed forms and against themselves.

mod common;

use common::{Lcg, ac_trunnion, head_head, random_errors};
use nalgebra::{Matrix3, Vector3};
use nccomp::kinematics::{Kinematics, Model, SolveOptions};
use nccomp::model::ErrorModel;
use proptest::prelude::*;

/// Paper 003, eqs. 4–5 (AC double-table machine, A and C axes intersecting at the pivot):
/// workpiece point and tool direction from machine coordinates, as
/// `[x + xo, y + yo, z + zo + L] = Rz(C)·Rx(A)·[X, Y, Z]`, `[i, j, k] = Rz(C)·Rx(A)·[0,0,1]`,
/// with the machine coordinates measured from the pivot.
fn paper_003_forward(
    x: f64,
    y: f64,
    z: f64,
    a_deg: f64,
    c_deg: f64,
) -> (Vector3<f64>, Vector3<f64>) {
    let (sa, ca) = a_deg.to_radians().sin_cos();
    let (sc, cc) = c_deg.to_radians().sin_cos();
    let p = Vector3::new(
        x * cc - y * sc * ca + z * sa * sc,
        x * sc + y * cc * ca - z * sa * cc,
        y * sa + z * ca,
    );
    let o = Vector3::new(sa * sc, -sa * cc, ca);
    (p, o)
}

/// Paper 003, eqs. 6–7: machine coordinates from the workpiece tip and tool direction.
fn paper_003_inverse(p: Vector3<f64>, o: Vector3<f64>) -> [f64; 5] {
    let a = o.z.clamp(-1.0, 1.0).acos();
    let c = if a.abs() < 1e-12 {
        0.0
    } else {
        o.x.atan2(-o.y)
    };
    let (sa, ca) = a.sin_cos();
    let (sc, cc) = c.sin_cos();
    let m = Matrix3::new(cc, -sc * ca, sa * sc, sc, cc * ca, -sa * cc, 0.0, sa, ca);
    let q = m.transpose() * p;
    [q.x, q.y, q.z, a.to_degrees(), c.to_degrees()]
}

const PIVOT: [f64; 3] = [12.0, -7.5, -95.0];

fn trunnion() -> nccomp::model::Machine {
    ac_trunnion(PIVOT, [PIVOT[0], PIVOT[1], 0.0])
}

#[test]
fn nominal_ac_trunnion_equals_paper_003_closed_form() {
    let machine = trunnion();
    let kin = Kinematics::new(&machine, &ErrorModel::zero(&machine), 0).unwrap();
    let pivot = Vector3::from(PIVOT);
    let mut rng = Lcg(3);
    for _ in 0..500 {
        let q = [
            rng.sym(400.0),
            rng.sym(400.0),
            rng.sym(250.0),
            rng.sym(120.0),
            rng.sym(180.0),
        ];
        let (pose, _) = kin.pose(Model::Nominal, &q, 0.0);
        // Machine coordinates from the pivot; the paper's offsets are the pivot's position.
        let (p, o) = paper_003_forward(q[0] - pivot.x, q[1] - pivot.y, q[2] - pivot.z, q[3], q[4]);
        assert!(
            (pose.p - (p + pivot)).norm() < 1e-9,
            "{q:?}: {} vs {}",
            pose.p,
            p + pivot
        );
        assert!((pose.o - o).norm() < 1e-12);
        // And back: the closed-form inverse recovers the axes (on its branch, A ≥ 0).
        if q[3] > 1.0 {
            let back = paper_003_inverse(pose.p - pivot, pose.o);
            let expected = [q[0] - pivot.x, q[1] - pivot.y, q[2] - pivot.z, q[3], q[4]];
            for (b, e) in back.iter().zip(expected) {
                assert!((b - e).abs() < 1e-7, "{back:?} vs {expected:?}");
            }
        }
    }
}

#[test]
fn jacobian_matches_finite_differences() {
    for machine in [trunnion(), head_head(150.0)] {
        let errors = random_errors(&machine, &mut Lcg(11));
        let kin = Kinematics::new(&machine, &errors, 0).unwrap();
        let q = [35.0, -20.0, 12.0, 27.0, -40.0];
        for model in [Model::Nominal, Model::Actual] {
            let (pose, jac) = kin.pose_and_jacobian(model, &q, 30.0);
            for k in 0..5 {
                let h = 1e-6;
                let mut qh = q;
                qh[k] += h;
                let (ph, _) = kin.pose(model, &qh, 30.0);
                let dp = (ph.p - pose.p) / h;
                let do_ = (ph.o - pose.o) / h;
                // The Jacobian leaves out d(error motion)/dq: agree to ~1e-4 relative.
                assert!(
                    (dp - jac.dp[k]).norm() < 1e-3 * (1.0 + dp.norm()),
                    "{model:?} k={k}: {dp} vs {}",
                    jac.dp[k]
                );
                assert!((do_ - jac.do_[k]).norm() < 1e-5, "{model:?} k={k}");
            }
        }
    }
}

#[test]
fn zero_model_is_the_identity() {
    let machine = trunnion();
    let kin = Kinematics::new(&machine, &ErrorModel::zero(&machine), 0).unwrap();
    let sol = kin.compensate(
        &[10.0, 20.0, 30.0, -45.0, 100.0],
        0.0,
        0,
        &SolveOptions::default(),
    );
    assert_eq!(sol.values(), &[10.0, 20.0, 30.0, -45.0, 100.0]);
    assert_eq!(sol.iterations, 0);
}

/// The solve lands within design/model.md's target residual (1e-6 mm, 1e-8 rad) with the
/// default options and with the compensation pass's looser ones.
fn check_lands(machine: &nccomp::model::Machine, seed: u64, q: [f64; 5], length: f64) {
    for opts in [SolveOptions::default(), SolveOptions::compensation()] {
        check_lands_with(machine, seed, q, length, &opts);
    }
}

fn check_lands_with(
    machine: &nccomp::model::Machine,
    seed: u64,
    q: [f64; 5],
    length: f64,
    opts: &SolveOptions,
) {
    let errors = random_errors(machine, &mut Lcg(seed));
    let kin = Kinematics::new(machine, &errors, 0).unwrap();
    let sol = kin.compensate(&q, length, 0, opts);
    let (target, _) = kin.pose(Model::Nominal, &q, length);
    let (reached, _) = kin.pose(Model::Actual, sol.values(), length);
    let (dp, dd) = reached.deviation(&target);
    assert!(dp < 1e-6, "tip off by {dp} mm at {q:?} (seed {seed})");
    // The residual the solve reports (an estimate when its last step went unevaluated)
    // is not below what it left, but for rounding.
    assert!(
        dp <= sol.position_residual + 1e-12,
        "tip off by {dp} mm, reported {} at {q:?} (seed {seed})",
        sol.position_residual
    );
    if sol.held == 0 {
        assert!(
            dd < 1e-8,
            "direction off by {dd} rad at {q:?} (seed {seed})"
        );
    } else {
        // A held axis keeps its programmed value exactly.
        for (k, programmed) in q.iter().enumerate() {
            if sol.held & (1 << k) != 0 {
                assert_eq!(sol.q[k], *programmed);
            }
        }
    }
    // Corrections stay small. Just outside the singular cone a rotary axis turns by
    // (direction error)/sin(angle to the tool), and the linear axes follow the part: up to a
    // few tenths of a degree and millimetres there, microns elsewhere.
    for k in 0..5 {
        let limit = if machine.axes[k].kind == nccomp::model::AxisKind::Rotary {
            1.0
        } else {
            5.0
        };
        assert!(
            (sol.q[k] - q[k]).abs() < limit,
            "axis {k} moved {} at {q:?}",
            sol.q[k] - q[k]
        );
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    #[test]
    fn solved_pose_lands_on_ac_trunnion(
        seed in 0u64..1_000_000,
        x in -400.0..400.0f64, y in -350.0..350.0f64, z in -50.0..350.0f64,
        a in -120.0..30.0f64, c in -180.0..180.0f64, length in 0.0..150.0f64,
    ) {
        check_lands(&trunnion(), seed, [x, y, z, a, c], length);
    }

    #[test]
    fn solved_pose_lands_on_head_head(
        seed in 0u64..1_000_000,
        x in -400.0..400.0f64, y in -350.0..350.0f64, z in -50.0..350.0f64,
        c in -180.0..180.0f64, a in -100.0..100.0f64,
    ) {
        check_lands(&head_head(150.0), seed, [x, y, z, c, a], 0.0);
    }

    #[test]
    fn zero_model_leaves_every_pose_alone(
        x in -400.0..400.0f64, y in -350.0..350.0f64, z in -50.0..350.0f64,
        a in -120.0..30.0f64, c in -180.0..180.0f64,
    ) {
        let machine = trunnion();
        let kin = Kinematics::new(&machine, &ErrorModel::zero(&machine), 0).unwrap();
        let q = [x, y, z, a, c];
        let sol = kin.compensate(&q, 0.0, 0, &SolveOptions::default());
        prop_assert_eq!(sol.values(), &q[..]);
    }
}

#[test]
fn singular_pose_holds_the_free_axis() {
    let machine = trunnion();
    for a in [0.0, 0.5, -2.9, 2.99] {
        let q = [50.0, -30.0, 20.0, a, 73.0];
        check_lands(&machine, 5, q, 0.0);
        let errors = random_errors(&machine, &mut Lcg(5));
        let kin = Kinematics::new(&machine, &errors, 0).unwrap();
        let sol = kin.compensate(&q, 0.0, 0, &SolveOptions::default());
        assert_eq!(sol.held, 1 << 4, "C is held at A = {a}");
        assert_eq!(sol.q[4], 73.0);
    }
    // Outside the singular cone the direction is solved in full.
    let errors = random_errors(&machine, &mut Lcg(5));
    let kin = Kinematics::new(&machine, &errors, 0).unwrap();
    let sol = kin.compensate(
        &[50.0, -30.0, 20.0, 3.5, 73.0],
        0.0,
        0,
        &SolveOptions::default(),
    );
    assert_eq!(sol.held, 0);
    assert!(sol.direction_residual < 1e-8);
}

/// A machine with fewer axes than equations, one of them rotary (a turning spindle A with
/// an X–Z slide), with its axes defined in either order.
fn three_axis_rotary(rotary_first: bool) -> nccomp::model::Machine {
    use common::{linear, rotary};
    let a = rotary("A", [-1.0, 0.0, 0.0], [0.0, 0.0, -100.0]);
    let x = linear("X", [1.0, 0.0, 0.0]);
    let z = linear("Z", [0.0, 0.0, 1.0]);
    let (axes, wp, tool) = if rotary_first {
        (vec![a, x, z], vec![0], vec![1, 2])
    } else {
        (vec![x, z, a], vec![2], vec![0, 1])
    };
    nccomp::model::Machine {
        name: None,
        axes,
        workpiece_chain: wp,
        tool_chains: vec![nccomp::model::Chain {
            name: "tool".into(),
            axes: tool,
            tools: Vec::new(),
        }],
        resolution: Default::default(),
        tool: Default::default(),
        lathe: None,
        codes: Default::default(),
        plane_solution: Default::default(),
        inch_default: false,
        cycle_r_initial: false,
        block_delete: None,
        start: Vec::new(),
        errors_file: None,
        work_offsets: None,
    }
}

#[test]
fn position_lands_with_fewer_axes_than_equations_whatever_the_axis_order() {
    for rotary_first in [true, false] {
        let machine = three_axis_rotary(rotary_first);
        let errors = random_errors(&machine, &mut Lcg(21));
        let kin = Kinematics::new(&machine, &errors, 0).unwrap();
        // Values in machine-file order.
        let q = if rotary_first {
            [10.0, 35.0, 12.0]
        } else {
            [35.0, 12.0, 10.0]
        };
        let sol = kin.compensate(&q, 0.0, 0, &SolveOptions::default());
        assert!(
            sol.position_residual < 1e-6,
            "tip off by {} mm",
            sol.position_residual
        );
        for (k, v) in sol.values().iter().enumerate() {
            assert!((v - q[k]).abs() < 0.1, "axis {k} moved {}", v - q[k]);
        }
    }
}

#[test]
fn the_singular_cone_is_that_of_the_programmed_pose() {
    // The real C axis is tilted by 0.06°: the real angle between tool and C at A = ±2.99°
    // can be over 3°, yet the programmed pose is singular and C must stay where it is.
    let machine = trunnion();
    for sign in [1.0, -1.0] {
        let mut errors = ErrorModel::zero(&machine);
        errors.axes[4].location_tilt = Vector3::new(sign * 1e-3, 0.0, 0.0);
        errors.axes[4].location_shift = Vector3::new(0.01, -0.02, 0.0);
        let kin = Kinematics::new(&machine, &errors, 0).unwrap();
        for a in [2.99, -2.99] {
            let q = [80.0, -40.0, 30.0, a, 120.0];
            let sol = kin.compensate(&q, 0.0, 0, &SolveOptions::default());
            assert_eq!(sol.singular, 1 << 4, "A = {a}, tilt sign {sign}");
            assert_eq!(sol.q[4], 120.0);
            assert!(sol.position_residual < 1e-6);
        }
    }
}
