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

/// Issue 34, case 2: a tool vector the AC trunnion's rotary axes cannot reach (the tool
/// pointing away from the spindle, -Z on the part) is refused where it stands, in ISO
/// (G43.5 I J K) and Sinumerik (TRAORI A3= B3= C3=); it was written flipped (K1, C3=1).
#[test]
fn a_tool_vector_the_rotary_axes_cannot_reach_is_refused() {
    use nccomp::compensate::{Compensator, Options};
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures");
    let m = nccomp::model::machine_file::load(&root.join("ac_trunnion.machine.toml")).unwrap();
    let e = nccomp::model::error_file::load(&root.join("ac_trunnion.errors.toml"), &m).unwrap();
    let run = |program: &str, name: &str| {
        let mut out = Vec::new();
        Compensator::new(&m, &e, Options::default())
            .unwrap()
            .run(program.as_bytes(), name, &mut out)
            .map(|_| String::from_utf8(out).unwrap())
            .map_err(|e| e.to_string())
    };
    let iso = "N10 G21 G90 G94 G17\nN20 T1 M6\nN30 G0 X0 Y0 Z100. A0 C0\nN40 G43.5 H1\nN50 G0 X-40. Y-30. Z30. I0 J0 K-1\n";
    let sinumerik = "N10 G17 G710 G90 G94\nN20 T1 D1 M6\nN30 G54\nN40 G0 X0 Y0 Z50 A0 C0\nN50 TRAORI\nN60 G1 X1 A3=0 B3=0 C3=-1 F500\n";
    for (program, name, place) in [(iso, "p.nc", "p.nc:5:"), (sinumerik, "p.mpf", "p.mpf:6:")] {
        match run(program, name) {
            Ok(out) => panic!("{name} passed:\n{out}"),
            Err(err) => assert!(
                err.contains(place)
                    && err.contains("cannot be reached by the machine's rotary axes"),
                "{err}"
            ),
        }
    }
    // A reachable vector beside it still passes.
    let ok = iso.replace("I0 J0 K-1", "I0 J0 K1");
    run(&ok, "p.nc").unwrap();
}

/// Issue 34, case 14: after `G49` ends TCP the axes stand where the controller's solve of
/// the last tip words put them; a G91 move travels from there (it was written from the
/// last tip words, 15.8 mm short).
#[test]
fn an_increment_after_tcp_ends_travels_from_where_the_axes_stand() {
    use nccomp::compensate::{Compensator, Options};
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures");
    let m = nccomp::model::machine_file::load(&root.join("ac_trunnion.machine.toml")).unwrap();
    let e = nccomp::model::error_file::load(&root.join("ac_trunnion.errors.toml"), &m).unwrap();
    let kin = Kinematics::new(&m, &e, 0).unwrap();
    let length = m.tool.lengths[&1];
    let program = "G21 G90\nG43.4 H1\nG0 X-40. Y-30. Z30. A-20. C15.\nG49\nG91 G0 Z100.\n";
    let mut out = Vec::new();
    Compensator::new(&m, &e, Options::default())
        .unwrap()
        .run(program.as_bytes(), "p.nc", &mut out)
        .unwrap();
    let out = String::from_utf8(out).unwrap();
    let words = |line: &str| -> Vec<(usize, f64)> {
        line.split_whitespace()
            .filter_map(|w| {
                let k = "XYZAC".find(&w[..1])?;
                Some((k, w[1..].parse().ok()?))
            })
            .collect()
    };
    let lines: Vec<&str> = out.lines().collect();
    assert_eq!(lines.len(), 5, "{out}");
    let opts = SolveOptions::default();
    // The controller: a line's tip words and rotary words, solved nominally.
    let tcp_solve = |line: &str| {
        let mut w = [0.0; 5];
        for (k, v) in words(line) {
            w[k] = v;
        }
        let tip = nalgebra::Vector3::new(w[0], w[1], w[2]);
        let sol = kin.tcp_axes_with_rotaries(&tip, &[w[0], w[1], w[2], w[3], w[4]], length, &opts);
        let q: [f64; 5] = sol.q[..5].try_into().unwrap();
        q
    };
    let nominal_start = tcp_solve(program.lines().nth(2).unwrap());
    let mut nominal_end = nominal_start;
    nominal_end[2] += 100.0;
    let mut reached = tcp_solve(lines[2]);
    for (k, v) in words(lines[4]) {
        reached[k] += v;
    }
    // G49 leaves the tool length of H1 in this model (the reference tool's is the same).
    let target = kin.pose(Model::Nominal, &nominal_end, length).0.p;
    let real = kin.pose(Model::Actual, &reached, length).0.p;
    let off = (real - target).norm();
    assert!(off < 1e-3, "{out}\n{off} mm off");
}
