//! Tool-centre-point programs along their whole path, checked against an independent model
//! of the controller: closed-form kinematics of the AC trunnion (not nccomp's solver), the
//! tip moved on a straight line in the part frame and the rotary axes in proportion
//! (LinuxCNC's planner, Fanuc's conventional TCP), and the real machine evaluated with the
//! error model. The path of the written words must stay within the tolerance of the path of
//! the programmed words; codes that are not known are refused where they stand.

mod common;

use common::{Lcg, ac_trunnion, random_errors};
use nalgebra::{Rotation3, Vector3};
use nccomp::compensate::{Compensator, Options};
use nccomp::kinematics::path::PathTolerance;
use nccomp::kinematics::{Kinematics, Model, angle_between};
use nccomp::model::{ErrorModel, Machine};
use nccomp::program::{CodeName, MachineCodes};

/// The A axis line passes through (0, 0, A_Z), the C axis line through the origin.
const A_Z: f64 = -100.0;
/// The tool length (the machine's reference length is 0).
const L: f64 = 100.0;

fn machine() -> Machine {
    let mut m = ac_trunnion([0.0, 0.0, A_Z], [0.0, 0.0, 0.0]);
    m.tool.lengths.insert(1, L);
    m
}

fn rx(deg: f64) -> Rotation3<f64> {
    Rotation3::from_axis_angle(&Vector3::x_axis(), deg.to_radians())
}

fn rz(deg: f64) -> Rotation3<f64> {
    Rotation3::from_axis_angle(&Vector3::z_axis(), deg.to_radians())
}

/// The nominal tip and direction in the part frame at axis values [X, Y, Z, A, C]: the
/// workpiece chain Y X A C (X and Y move the table, A about -X through (0, 0, A_Z), C
/// about -Z), the tool chain Z.
fn forward(q: [f64; 5]) -> (Vector3<f64>, Vector3<f64>) {
    let a = Vector3::new(0.0, 0.0, A_Z);
    let w = Vector3::new(q[0], q[1], q[2] - L);
    let p = rz(q[4]) * (a + rx(q[3]) * (w - a));
    let o = rz(q[4]) * rx(q[3]) * Vector3::z();
    (p, o)
}

/// The controller's linear axes for a tip at rotary values A, C.
fn linear_axes(tip: Vector3<f64>, a_deg: f64, c_deg: f64) -> [f64; 5] {
    let a = Vector3::new(0.0, 0.0, A_Z);
    let w = a + rx(-a_deg) * (rz(-c_deg) * tip - a);
    [w.x, w.y, w.z + L, a_deg, c_deg]
}

/// The controller's rotary values for a tool vector, nearest `from` (A first, then C);
/// along the C axis C keeps its value.
fn rotary_axes(v: Vector3<f64>, from: [f64; 2]) -> [f64; 2] {
    let v = v.normalize();
    let a = v.z.clamp(-1.0, 1.0).acos().to_degrees();
    let s = a.to_radians().sin();
    if s.abs() < 1e-12 {
        return [0.0, from[1]];
    }
    let near = |c: f64| c + 360.0 * ((from[1] - c) / 360.0).round();
    // o = (sin A sin C, -sin A cos C, cos A), A = ±acos(K).
    let candidates = [a, -a].map(|a| {
        let s = a.to_radians().sin();
        [
            a,
            near(v.x.atan2(-v.y).to_degrees() + if s < 0.0 { 180.0 } else { 0.0 }),
        ]
    });
    let cost = |q: &[f64; 2]| ((q[0] - from[0]).abs(), (q[1] - from[1]).abs());
    if cost(&candidates[0]) <= cost(&candidates[1]) {
        candidates[0]
    } else {
        candidates[1]
    }
}

/// A TCP block as the controller sees it: its N number, and the tip and the rotary values
/// (or the vector's) at its end.
type State = (u64, Vector3<f64>, [f64; 2]);

/// A program's TCP blocks, in order.
fn tcp_states(program: &str, vector: bool) -> Vec<State> {
    let mut tcp = false;
    let mut tip = Vector3::zeros();
    let mut rot = [0.0, 0.0];
    let mut ijk = Vector3::z();
    let mut out = Vec::new();
    for line in program.lines() {
        let body = line.split(['(', ';']).next().unwrap();
        let words: Vec<&str> = body.split_whitespace().collect();
        if words
            .iter()
            .any(|w| ["G43.4", "G43.5", "M428", "G234"].contains(w))
        {
            tcp = true;
            continue;
        }
        if words.iter().any(|w| ["G49", "M429"].contains(w)) {
            tcp = false;
            continue;
        }
        let mut moved = false;
        let mut given = false;
        let mut vec = [0.0; 3];
        let mut number = 0;
        for w in &words {
            let value = || w[1..].parse::<f64>().unwrap();
            match &w[..1] {
                "N" => {
                    number = w[1..].parse().unwrap();
                    continue;
                }
                "X" => tip.x = value(),
                "Y" => tip.y = value(),
                "Z" => tip.z = value(),
                "A" => rot[0] = value(),
                "C" => rot[1] = value(),
                "I" | "J" | "K" => {
                    vec["IJK".find(&w[..1]).unwrap()] = value();
                    given = true;
                }
                _ => continue,
            }
            moved = true;
        }
        if !tcp || !moved {
            continue;
        }
        if vector {
            if given {
                ijk = Vector3::from(vec);
            }
            rot = rotary_axes(ijk, rot);
        }
        out.push((number, tip, rot));
    }
    out
}

/// How far the real machine, running `written` as the controller does, strays from the path
/// the controller makes of `programmed` (whose blocks are numbered N1000, N2000, ...;
/// blocks inserted in `written` are numbered in between): the largest tip distance (mm) and tool
/// angle (rad, outside A's singular cone) at the same point of each move, sampled densely.
/// A written block's place on its move is where its real tip lies on the programmed tip's
/// line (block ends land on the path to a fraction of a micron).
fn stray(
    kin: &Kinematics,
    length: f64,
    programmed: &str,
    written: &str,
    vector: bool,
) -> (f64, f64) {
    let nominal = tcp_states(programmed, vector);
    let real = tcp_states(written, vector);
    let (mut worst_p, mut worst_d) = (0.0f64, 0.0f64);
    let actual = |tip: Vector3<f64>, a: f64, c: f64| {
        kin.pose(Model::Actual, &linear_axes(tip, a, c), length).0
    };
    let mut k = real
        .iter()
        .position(|r| r.0 == nominal[0].0)
        .expect("the first block");
    for m in nominal.windows(2) {
        let ((_, n0, m0), (end, n1, m1)) = (m[0], m[1]);
        let d = n1 - n0;
        let at = |p: Vector3<f64>| (p - n0).dot(&d) / d.norm_squared();
        let mut prev = real[k];
        let mut s0 = 0.0;
        loop {
            k += 1;
            let next = real[k];
            let s1 = if next.0 == end {
                1.0
            } else {
                at(actual(next.1, next.2[0], next.2[1]).p)
            };
            for i in 0..=32 {
                let u = i as f64 / 32.0;
                let s = s0 + (s1 - s0) * u;
                let (a, c) = (
                    prev.2[0] + (next.2[0] - prev.2[0]) * u,
                    prev.2[1] + (next.2[1] - prev.2[1]) * u,
                );
                let real = actual(prev.1 + (next.1 - prev.1) * u, a, c);
                let (na, nc) = (m0[0] + (m1[0] - m0[0]) * s, m0[1] + (m1[1] - m0[1]) * s);
                let (_, dir) = forward([0.0, 0.0, 0.0, na, nc]);
                worst_p = worst_p.max((real.p - (n0 + d * s)).norm());
                // The direction is not held at the singular A = 0 (C cannot turn the tool).
                if na.abs() > 3.0 {
                    worst_d = worst_d.max(angle_between(&real.o, &dir));
                }
            }
            prev = next;
            s0 = s1;
            if next.0 == end {
                break;
            }
        }
    }
    (worst_p, worst_d)
}

fn errors(machine: &Machine) -> ErrorModel {
    random_errors(machine, &mut Lcg(47))
}

fn compensate(machine: &Machine, program: &str) -> Result<String, String> {
    let options = Options {
        path: Some(PathTolerance::default()),
        ..Options::default()
    };
    let comp = Compensator::new(machine, &errors(machine), options).unwrap();
    let mut out = Vec::new();
    comp.run(program.as_bytes(), "p.nc", &mut out)
        .map(|_| String::from_utf8(out).unwrap())
        .map_err(|e| e.to_string())
}

#[test]
fn the_closed_forms_are_the_machines_nominal_kinematics() {
    let machine = machine();
    let kin = Kinematics::new(&machine, &ErrorModel::zero(&machine), 0).unwrap();
    let mut rng = Lcg(3);
    for _ in 0..50 {
        let q = [
            rng.sym(200.0),
            rng.sym(200.0),
            rng.sym(200.0),
            rng.sym(110.0),
            rng.sym(400.0),
        ];
        let (p, o) = forward(q);
        let (pose, _) = kin.pose(Model::Nominal, &q, L);
        assert!(
            (pose.p - p).norm() < 1e-9 && (pose.o - o).norm() < 1e-12,
            "{q:?}"
        );
        let back = linear_axes(p, q[3], q[4]);
        assert!((0..5).all(|k| (back[k] - q[k]).abs() < 1e-9), "{q:?}");
        let r = rotary_axes(o, [q[3] + 0.5, q[4] - 0.5]);
        let (_, o2) = forward([0.0, 0.0, 0.0, r[0], r[1]]);
        assert!((o2 - o).norm() < 1e-12, "{q:?}");
    }
}

/// A LinuxCNC-style five-axis program: M428 switches the TCP kinematics on, M429 off
/// (xyzac-trt's remapped codes); X Y Z are the tip, A C the rotary axes.
const LINUXCNC_TCP: &str = "\
M429
G21 G90 G17
T1 M6 G43 H1
G0 X0 Y0 Z150 A0 C0
M428 (TCP on)
N1000 G54 G0 X-40 Y-30 Z10 A-30 C10
N2000 G1 X40 Y-10 Z5 A-60 C120 F600
N3000 X30 Y40 Z0 A-45 C200
N4000 G1 X-20 Y35 A-20 C250
M429
G0 Z150
M30
";

#[test]
fn m_codes_not_on_the_list_are_refused_where_they_stand() {
    let machine = machine();
    for (program, at) in [
        (
            "G0 X0 Y0 Z50 A0 C0\nG1 X10 M128\n",
            "p.nc:2:8: M128 cannot be compensated",
        ),
        (
            "G0 X0 Y0 Z50 A0 C0\nM999\n",
            "p.nc:2:1: M999 cannot be compensated",
        ),
        (LINUXCNC_TCP, "p.nc:1:1: M429 cannot be compensated"),
        (LINUXCNC_TCP, "p.nc:5:1: M428 cannot be compensated"),
    ] {
        let err = compensate(&machine, program).unwrap_err();
        assert!(err.contains(at), "{err}");
        assert!(err.contains("this M code is not known to nccomp"), "{err}");
    }
    // With the zero model nothing can change, so nothing is refused.
    let comp = Compensator::new(&machine, &ErrorModel::zero(&machine), Options::default()).unwrap();
    let mut out = Vec::new();
    comp.run(LINUXCNC_TCP.as_bytes(), "p.nc", &mut out).unwrap();
    assert_eq!(out, LINUXCNC_TCP.as_bytes());
}

#[test]
fn a_machine_files_tcp_switches_make_a_linuxcnc_program_a_tcp_program() {
    let mut machine = machine();
    let name = |s: &str| CodeName::parse(s).unwrap();
    machine.codes = MachineCodes {
        harmless: Vec::new(),
        tcp_on: vec![name("M428")],
        tcp_off: vec![name("M429")],
        machine_moves: Vec::new(),
    };
    let kin = Kinematics::new(&machine, &errors(&machine), 0).unwrap();
    let written = compensate(&machine, LINUXCNC_TCP).unwrap();
    let tol = PathTolerance::default();
    // The program as written strays: this test can fail.
    let (p0, d0) = stray(&kin, L, LINUXCNC_TCP, LINUXCNC_TCP, false);
    assert!(p0 > 10.0 * tol.position, "uncompensated {p0} mm");
    let (p, d) = stray(&kin, L, LINUXCNC_TCP, &written, false);
    eprintln!(
        "{} blocks in, {} out; strays {:.3} µm, {:.2} µrad (as programmed {:.1} µm, {:.1} µrad)",
        LINUXCNC_TCP.lines().count(),
        written.lines().count(),
        p * 1e3,
        d * 1e6,
        p0 * 1e3,
        d0 * 1e6
    );
    assert!(
        written.lines().count() > LINUXCNC_TCP.lines().count(),
        "{written}"
    );
    assert!(
        p <= tol.position && d <= tol.direction,
        "the written path strays {:.3} µm, {:.2} µrad (the programmed {:.1} µm, {:.1} µrad)\n{written}",
        p * 1e3,
        d * 1e6,
        p0 * 1e3,
        d0 * 1e6
    );
}

#[test]
fn a_tcp_move_turning_c_a_full_revolution_is_split_onto_its_path() {
    let machine = machine();
    let kin = Kinematics::new(&machine, &errors(&machine), 0).unwrap();
    let program = "G21 G90\nG0 X0 Y0 Z150 A0 C0\nG43.4 H1\nN1000 G0 X-40 Y0 Z5 A-30 C0\nN2000 G1 X40 Y5 Z5 A-30 C360 F500\nG49\nM30\n";
    let written = compensate(&machine, program).unwrap();
    let tol = PathTolerance::default();
    let (p0, d0) = stray(&kin, L, program, program, false);
    assert!(p0 > 10.0 * tol.position, "uncompensated {p0} mm");
    let (p, d) = stray(&kin, L, program, &written, false);
    eprintln!(
        "{} blocks in, {} out; strays {:.3} µm, {:.2} µrad (as programmed {:.1} µm, {:.1} µrad)",
        program.lines().count(),
        written.lines().count(),
        p * 1e3,
        d * 1e6,
        p0 * 1e3,
        d0 * 1e6
    );
    assert!(
        written.lines().count() > program.lines().count() + 4,
        "{written}"
    );
    assert!(
        p <= tol.position && d <= tol.direction,
        "the written path strays {:.3} µm, {:.2} µrad\n{written}",
        p * 1e3,
        d * 1e6
    );
}

#[test]
fn at_a_singular_pose_under_g43_5_the_controller_holds_the_free_axis() {
    let machine = machine();
    let errors = errors(&machine);
    let kin = Kinematics::new(&machine, &errors, 0).unwrap();
    // From A -40 C 75 to the tool along C: the controller keeps C where it stands.
    let (_, o) = forward([0.0, 0.0, 0.0, -40.0, 75.0]);
    let program = format!(
        "G21 G90\nG0 X0 Y0 Z150 A-40 C75\nG43.5 H1\nG0 X0 Y0 Z150 I{:.6} J{:.6} K{:.6}\nN1000 G1 X-20 Y-10 Z5 I{:.6} J{:.6} K{:.6} F500\nN2000 G1 X10 Y-5 Z5 I0 J0 K1\nG49\nM30\n",
        o.x, o.y, o.z, o.x, o.y, o.z
    );
    let comp = Compensator::new(&machine, &errors, Options::default()).unwrap();
    let mut out = Vec::new();
    let summary = comp.run(program.as_bytes(), "p.nc", &mut out).unwrap();
    let written = String::from_utf8(out).unwrap();
    let states = tcp_states(&written, true);
    let (_, tip, [a, c]) = *states.last().unwrap();
    let before = states[states.len() - 2].2[1];
    let resolution = machine.resolution.rotary;
    assert!(
        (c - before).abs() <= resolution / 2.0 && a.abs() <= resolution / 2.0,
        "the controller lands at A {a} C {c}, from C {before}\n{written}"
    );
    assert!((c - 75.0).abs() < 0.05, "C {c}");
    // What the written words do, evaluated here, is what the summary reports.
    let (actual, _) = kin.pose(Model::Actual, &linear_axes(tip, a, c), L);
    let intended = (Vector3::new(10.0, -5.0, 5.0), Vector3::z());
    let dp = (actual.p - intended.0).norm();
    let dd = angle_between(&actual.o, &intended.1);
    assert!(dp < 2e-4, "tip off by {dp} mm\n{written}");
    assert_eq!(summary.singular_direction.line, 6, "{summary:?}");
    assert!(
        (summary.singular_direction.value - dd).abs() < 0.01e-6,
        "summary {} µrad, evaluated {} µrad",
        summary.singular_direction.value * 1e6,
        dd * 1e6
    );
    assert!(summary.after_position.value < 2e-4, "{summary:?}");
}

#[test]
fn an_arc_under_tcp_becomes_straight_tcp_moves_on_its_circle() {
    let machine = machine();
    let kin = Kinematics::new(&machine, &errors(&machine), 0).unwrap();
    // A half circle of radius 30 about (0, 0) at Z 5, A and C turning along.
    let program = "G21 G90 G17\nG0 X0 Y0 Z150 A0 C0\nG43.4 H1\nN1000 G0 X30 Y0 Z5 A-20 C0\nN2000 G3 X-30 Y0 I-30 J0 A-40 C90 F500\nG49\nM30\n";
    let written = compensate(&machine, program).unwrap();
    assert!(!written.contains("G3"), "{written}");
    let states = tcp_states(&written, false);
    let start = states.iter().position(|s| s.0 == 1000).unwrap();
    assert!(
        states.len() - start > 100,
        "{} pieces",
        states.len() - start
    );
    let mut worst = 0.0f64;
    for w in states[start..].windows(2) {
        let ((_, t0, r0), (_, t1, r1)) = (w[0], w[1]);
        for i in 0..=8 {
            let u = i as f64 / 8.0;
            let q = linear_axes(
                t0 + (t1 - t0) * u,
                r0[0] + (r1[0] - r0[0]) * u,
                r0[1] + (r1[1] - r0[1]) * u,
            );
            let (real, _) = kin.pose(Model::Actual, &q, L);
            let radial = (real.p.x.hypot(real.p.y) - 30.0).abs();
            worst = worst.max(radial.hypot(real.p.z - 5.0));
        }
    }
    let (end, _) = kin.pose(
        Model::Actual,
        &{
            let (_, t, r) = *states.last().unwrap();
            linear_axes(t, r[0], r[1])
        },
        L,
    );
    assert!(
        (end.p - Vector3::new(-30.0, 0.0, 5.0)).norm() < 2e-4,
        "{end:?}"
    );
    assert!(
        worst < PathTolerance::default().position,
        "{worst} mm off the circle"
    );
}

#[test]
fn g43_ends_tcp_and_tcp_notes_axes_it_assumed_at_home() {
    let machine = machine();
    // G43 H1 under G43.4 ends TCP (one modal group): X Y Z are machine axes again, so the
    // block after it is compensated as machine axes, not as a tip.
    // (A rapid positions the tool after G43.4 H1 changed the length at rest.)
    let program = "G21 G90\nG0 X10 Y5 Z150 A0 C0\nG43.4 H1\nG0 X10 Y5 Z150 A0 C0\nG1 X-20 Y-10 Z5 A-30 C20 F500\nG43 H1\nG1 X12.5 Y3 Z40 A-30 C20\nM30\n";
    let comp = Compensator::new(&machine, &errors(&machine), Options::default()).unwrap();
    let mut out = Vec::new();
    comp.run(program.as_bytes(), "p.nc", &mut out).unwrap();
    let written = String::from_utf8(out).unwrap();
    let last_move = written.lines().nth(6).unwrap();
    let kin = Kinematics::new(&machine, &errors(&machine), 0).unwrap();
    let q: Vec<f64> = ["X", "Y", "Z", "A", "C"]
        .iter()
        .map(|l| {
            last_move
                .split_whitespace()
                .find_map(|w| w.strip_prefix(l))
                .unwrap()
                .parse()
                .unwrap()
        })
        .collect();
    // The machine-axis reading of the block: the real machine at the written axes lands
    // where the ideal one would at the programmed axes.
    let (real, _) = kin.pose(Model::Actual, &q, L);
    let (ideal, _) = kin.pose(Model::Nominal, &[12.5, 3.0, 40.0, -30.0, 20.0], L);
    assert!((real.p - ideal.p).norm() < 2e-4, "{written}");
    // TCP switched on before the program set X and Y, and a block that leaves them out:
    // where the tip is is not known, and the feed move is refused.
    let program = "G21 G90\nG43.4 H1\nG1 Z5 A-30 C20 F500\nM30\n";
    let mut out = Vec::new();
    let err = comp
        .run(program.as_bytes(), "p.nc", &mut out)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("p.nc:3:4: where the tool stands before this block under G43.4 is not known"),
        "{err}"
    );
}

/// Haas's TCPC: `G234 H…` switches tool-centre-point control on, G49 off. A machine file
/// that says so (`[codes] tcp_on = ["G234"]`) makes it a TCP program like G43.4.
const HAAS_TCP: &str = "\
G21 G90 G17
T1 M6 G43 H1
G0 X0 Y0 Z150 A0 C0
G234 H1 (TCPC on)
N1000 G0 X-40 Y-30 Z10 A-30 C10
N2000 G1 X40 Y-10 Z5 A-60 C120 F600
N3000 X30 Y40 Z0 A-45 C200
G49
G0 Z150
M30
";

#[test]
fn haas_g234_is_tool_centre_point_control_where_the_machine_file_says_so() {
    let mut machine = machine();
    // Unknown to nccomp without the machine file.
    let err = compensate(&machine, HAAS_TCP).unwrap_err();
    assert!(
        err.contains("p.nc:4:1: G234 cannot be compensated"),
        "{err}"
    );
    machine.codes.tcp_on = vec![CodeName::parse("G234").unwrap()];
    let kin = Kinematics::new(&machine, &errors(&machine), 0).unwrap();
    let written = compensate(&machine, HAAS_TCP).unwrap();
    let tol = PathTolerance::default();
    let (p0, _) = stray(&kin, L, HAAS_TCP, HAAS_TCP, false);
    assert!(p0 > 10.0 * tol.position, "uncompensated {p0} mm");
    let (p, d) = stray(&kin, L, HAAS_TCP, &written, false);
    assert!(
        p <= tol.position && d <= tol.direction,
        "the written path strays {:.3} µm, {:.2} µrad\n{written}",
        p * 1e3,
        d * 1e6
    );
}
