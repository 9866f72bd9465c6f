//! Arcs along their whole path: random arcs in every plane (I/J/K and R, both directions,
//! helical, full circles) compensated with the default path tolerance, then the written
//! program run through a small controller model of its own here (G1 straight in axis space,
//! G2/G3 a circle about the written centre with the other axes linear in the angle) on the
//! machine with its errors. Every sample of the written path must lie within 1.5 µm of the
//! nominal arc, whether nccomp kept the arc or replaced it by straight pieces.

mod common;

use common::{Lcg, ac_trunnion, random_errors};
use nalgebra::Vector3;
use nccomp::compensate::{Compensator, Options};
use nccomp::kinematics::path::PathTolerance;
use nccomp::kinematics::{Kinematics, Model};
use nccomp::model::ErrorModel;
use std::f64::consts::{PI, TAU};

/// Axis values X Y Z A C.
type Q = [f64; 5];

/// An arc's plane (two axis indices), centre in them, and whether it turns clockwise.
type Arc = ((usize, usize), (f64, f64), bool);

/// A move as a controller runs it.
#[derive(Debug, Clone, Copy)]
struct Move {
    start: Q,
    end: Q,
    /// For arcs: the plane's two axis indices, the centre in them, clockwise.
    arc: Option<Arc>,
}

impl Move {
    fn point(&self, s: f64) -> Q {
        let mut q: Q = std::array::from_fn(|k| self.start[k] + (self.end[k] - self.start[k]) * s);
        if let Some(((a, b), (ca, cb), cw)) = self.arc {
            let th0 = (self.start[b] - cb).atan2(self.start[a] - ca);
            let th1 = (self.end[b] - cb).atan2(self.end[a] - ca);
            let sweep = if cw {
                let d = -(th0 - th1).rem_euclid(TAU);
                if d.abs() < 1e-9 { -TAU } else { d }
            } else {
                let d = (th1 - th0).rem_euclid(TAU);
                if d.abs() < 1e-9 { TAU } else { d }
            };
            let r0 = (self.start[a] - ca).hypot(self.start[b] - cb);
            let r1 = (self.end[a] - ca).hypot(self.end[b] - cb);
            let (th, r) = (th0 + sweep * s, r0 + (r1 - r0) * s);
            q[a] = ca + r * th.cos();
            q[b] = cb + r * th.sin();
        }
        q
    }
}

/// Run a G90 program of G0/G1/G2/G3 in G17/G18/G19: the moves, in order.
fn controller(program: &str) -> Vec<Move> {
    let mut q: Q = [0.0; 5];
    let (mut motion, mut plane) = (0u32, 17u32);
    let mut moves = Vec::new();
    for line in program.lines() {
        let mut end = q;
        let (mut centre_words, mut r_word) = ([None::<f64>; 3], None);
        let mut moved = false;
        for word in line.split_whitespace() {
            let (letter, value) = (word.as_bytes()[0], &word[1..]);
            let Ok(v) = value.parse::<f64>() else {
                continue;
            };
            match letter {
                b'G' => match v as u32 {
                    0..=3 => motion = v as u32,
                    17..=19 => plane = v as u32,
                    _ => {}
                },
                b'X' | b'Y' | b'Z' | b'A' | b'C' => {
                    end[b"XYZAC".iter().position(|&l| l == letter).unwrap()] = v;
                    moved = true;
                }
                b'I' | b'J' | b'K' => centre_words[(letter - b'I') as usize] = Some(v),
                b'R' => r_word = Some(v),
                _ => {}
            }
        }
        if !moved {
            continue;
        }
        let arc = (motion >= 2).then(|| {
            let ((a, b), (ia, ib)) = match plane {
                17 => ((0, 1), (0, 1)),
                18 => ((2, 0), (2, 0)),
                _ => ((1, 2), (1, 2)),
            };
            let cw = motion == 2;
            let centre = match r_word {
                Some(r) => {
                    let (dx, dy) = (end[a] - q[a], end[b] - q[b]);
                    let d = dx.hypot(dy);
                    let h = (r * r - d * d / 4.0).max(0.0).sqrt();
                    let left = cw == (r < 0.0);
                    let (mx, my) = ((q[a] + end[a]) / 2.0, (q[b] + end[b]) / 2.0);
                    let (ux, uy) = (-dy / d, dx / d);
                    if left {
                        (mx + ux * h, my + uy * h)
                    } else {
                        (mx - ux * h, my - uy * h)
                    }
                }
                None => (
                    q[a] + centre_words[ia].unwrap_or(0.0),
                    q[b] + centre_words[ib].unwrap_or(0.0),
                ),
            };
            ((a, b), centre, cw)
        });
        moves.push(Move { start: q, end, arc });
        q = end;
    }
    moves
}

/// Distance from `p` to the polyline, searching the segments near `hint` (the samples
/// come in order along the curve), which is moved to the closest one.
fn distance_to_polyline(p: &Vector3<f64>, line: &[Vector3<f64>], hint: &mut usize) -> f64 {
    let lo = hint.saturating_sub(50);
    let hi = (*hint + 200).min(line.len() - 1);
    let mut best = (f64::INFINITY, *hint);
    for k in lo..hi {
        let (a, b) = (line[k], line[k + 1]);
        let d = b - a;
        let t = ((p - a).dot(&d) / d.norm_squared().max(1e-300)).clamp(0.0, 1.0);
        let dist = (p - (a + d * t)).norm();
        if dist < best.0 {
            best = (dist, k);
        }
    }
    *hint = best.1;
    best.0
}

struct Outcome {
    kept: usize,
    replaced: usize,
    worst: f64,
}

fn check(errors: &ErrorModel, seed: u64, cases: usize) -> Outcome {
    let machine = ac_trunnion([0.0, 0.0, -100.0], [0.0, 0.0, 0.0]);
    let kin = Kinematics::new(&machine, errors, 0).unwrap();
    let options = Options {
        path: Some(PathTolerance::default()),
        ..Options::default()
    };
    let comp = Compensator::new(&machine, errors, options).unwrap();
    let mut rng = Lcg(seed);
    let mut outcome = Outcome {
        kept: 0,
        replaced: 0,
        worst: 0.0,
    };
    for case in 0..cases {
        let plane = [17, 18, 19][case % 3];
        let (a, b, h) = match plane {
            17 => (0, 1, 2),
            18 => (2, 0, 1),
            _ => (1, 2, 0),
        };
        let radius = 5.0 + 35.0 * rng.next();
        let th0 = rng.sym(PI);
        let full = case % 7 == 3;
        let sweep_abs = if full { TAU } else { 0.3 + 5.5 * rng.next() };
        let cw = rng.next() < 0.5;
        let sweep = if cw { -sweep_abs } else { sweep_abs };
        let (ca, cb) = (rng.sym(30.0), rng.sym(30.0));
        let mut start: Q = [0.0, 0.0, 0.0, -15.0 - 45.0 * rng.next(), rng.sym(170.0)];
        start[h] = 20.0 + rng.sym(10.0);
        start[a] = ca + radius * th0.cos();
        start[b] = cb + radius * th0.sin();
        let mut end = start;
        end[h] += rng.sym(5.0);
        end[a] = ca + radius * (th0 + sweep).cos();
        end[b] = cb + radius * (th0 + sweep).sin();
        let round = |x: f64| (x * 1e4).round() / 1e4;
        let centre_letters = ["I", "J", "K"];
        let words = |q: &Q| {
            format!(
                "X{:.4} Y{:.4} Z{:.4} A{:.4} C{:.4}",
                q[0], q[1], q[2], q[3], q[4]
            )
        };
        // R only where it is not a full circle; negative R for more than half a turn.
        let centre = if !full && case % 2 == 1 {
            let r = if sweep_abs > PI { -radius } else { radius };
            format!("R{:.4}", r)
        } else {
            format!(
                "{}{:.4} {}{:.4}",
                centre_letters[a],
                round(ca - round(start[a])),
                centre_letters[b],
                round(cb - round(start[b]))
            )
        };
        let program = format!(
            "G21 G90 G{plane}\nG0 {}\nG{} X{:.4} Y{:.4} Z{:.4} {centre} F500\n",
            words(&start),
            if cw { 2 } else { 3 },
            end[0],
            end[1],
            end[2],
        );
        let mut out = Vec::new();
        let summary = comp
            .run(program.as_bytes(), "arc.nc", &mut out)
            .unwrap_or_else(|e| panic!("{program}\n{e}"));
        let out = String::from_utf8(out).unwrap();
        outcome.kept += summary.arcs_kept;
        outcome.replaced += summary.arcs;
        assert_eq!(summary.arcs_kept + summary.arcs, 1, "{program}\n{out}");
        // The nominal arc, as the controller runs the program as written.
        let nominal = controller(&program);
        let arc = nominal[1];
        let curve: Vec<Vector3<f64>> = (0..=3000)
            .map(|k| {
                kin.pose(Model::Nominal, &arc.point(k as f64 / 3000.0), 0.0)
                    .0
                    .p
            })
            .collect();
        // The compensated moves after the G0, sampled densely.
        let written = controller(&out);
        let end_pose = kin.pose(Model::Nominal, &arc.end, 0.0).0;
        let last = written.last().unwrap();
        let reached = kin.pose(Model::Actual, &last.end, 0.0).0;
        assert!(
            (reached.p - end_pose.p).norm() < 1e-3,
            "{program}\n{out}\nend off by {}",
            (reached.p - end_pose.p).norm()
        );
        let mut hint = 0;
        for m in &written[1..] {
            let samples = if m.arc.is_some() { 64 } else { 4 };
            for k in 1..samples {
                let s = k as f64 / samples as f64;
                let p = kin.pose(Model::Actual, &m.point(s), 0.0).0.p;
                let d = distance_to_polyline(&p, &curve, &mut hint);
                outcome.worst = outcome.worst.max(d);
                assert!(
                    d < 1.5e-3,
                    "{program}\n{out}\n{:?} at s = {s}: {d} mm off the nominal arc",
                    m
                );
            }
        }
    }
    outcome
}

#[test]
fn kept_and_replaced_arcs_stay_on_the_nominal_arc() {
    let machine = ac_trunnion([0.0, 0.0, -100.0], [0.0, 0.0, 0.0]);
    // Errors of a few microns and tens of micro-radians: most arcs can be kept.
    let mut small = random_errors(&machine, &mut Lcg(41));
    for axis in &mut small.axes {
        if let Some(table) = &mut axis.motion {
            for values in table.values.iter_mut().flatten() {
                for v in values.iter_mut() {
                    *v *= 0.05;
                }
            }
        }
        axis.squareness *= 0.05;
        axis.location_tilt *= 0.05;
    }
    let gentle = check(&small, 3, 18);
    // The checker's errors (tens of microns, 100 µrad): more arcs become straight pieces.
    let rough = check(&random_errors(&machine, &mut Lcg(43)), 5, 9);
    println!(
        "small errors: {} kept, {} replaced, worst {:.3} µm; large errors: {} kept, {} replaced, worst {:.3} µm",
        gentle.kept,
        gentle.replaced,
        gentle.worst * 1e3,
        rough.kept,
        rough.replaced,
        rough.worst * 1e3
    );
    assert!(gentle.kept >= 12, "{} of 18 kept", gentle.kept);
    assert!(rough.replaced > 0);
}

/// The written program of `program` run by this file's controller on the machine with its
/// errors, against the nominal path of `program` (its moves after the first, sampled
/// densely): the largest distance (mm) of the real tip from the nominal path.
fn worst_off(kin: &Kinematics, program: &str, out: &str, length: f64) -> f64 {
    let n = kin.len();
    let nominal = controller(program);
    let mut curve: Vec<Vector3<f64>> = Vec::new();
    for m in &nominal[1..] {
        let samples = if m.arc.is_some() { 3000 } else { 300 };
        for k in 0..=samples {
            let q = m.point(k as f64 / samples as f64);
            curve.push(kin.pose(Model::Nominal, &q[..n], length).0.p);
        }
    }
    let written = controller(out);
    let mut worst: f64 = 0.0;
    for m in &written[1..] {
        for k in 0..=64 {
            let q = m.point(k as f64 / 64.0);
            let p = kin.pose(Model::Actual, &q[..n], length).0.p;
            // Search the whole curve: a mirrored arc wanders far from its hint.
            let mut best = f64::INFINITY;
            for j in 0..curve.len() - 1 {
                let (a, b) = (curve[j], curve[j + 1]);
                let d = b - a;
                let t = ((p - a).dot(&d) / d.norm_squared().max(1e-300)).clamp(0.0, 1.0);
                best = best.min((p - (a + d * t)).norm());
            }
            worst = worst.max(best);
        }
    }
    worst
}

/// Issue 34, case 1: a short arc whose sagitta is below the words' rounding. Kept as an
/// arc with centre words fitted to the compensated ends, the centre could land across the
/// chord, and G3 about it runs nearly a full circle. Whatever is written must run, as the
/// control reads it (G3's sweep in (0, 2π]), on the nominal arc.
#[test]
fn a_short_arc_is_never_written_mirrored() {
    let machine = nccomp::model::machine_file::parse(
        r#"
workpiece_chain = ["Y", "X"]
tool_chain = ["Z"]
resolution = { linear = 0.001, rotary = 0.001 }
[axes.X]
kind = "linear"
direction = [-1, 0, 0]
[axes.Y]
kind = "linear"
direction = [0, -1, 0]
[axes.Z]
kind = "linear"
direction = [0, 0, 1]
"#,
        "three.machine.toml",
    )
    .unwrap();
    let errors = nccomp::model::error_file::parse(
        r#"
length_unit = "um"
[motion.X]
positions = [-1000.0, 1000.0]
EXX = [10.0, -10.0]
[motion.Y]
positions = [-1000.0, 1000.0]
EYY = [10.0, -10.0]
"#,
        "three.errors.toml",
        &machine,
    )
    .unwrap();
    let kin = Kinematics::new(&machine, &errors, 0).unwrap();
    let program =
        "G90 G17 G21\nG0 X122.439 Y143.682 Z40.\nG3 X122.223 Y143.75 I-5.24 J-16.476 F250\n";
    let comp = Compensator::new(&machine, &errors, Options::default()).unwrap();
    let mut out = Vec::new();
    comp.run(program.as_bytes(), "short.nc", &mut out).unwrap();
    let out = String::from_utf8(out).unwrap();
    let worst = worst_off(&kin, program, &out, 0.0);
    assert!(worst < 1.5e-3, "{out}\n{} mm off the nominal arc", worst);
}

/// Issue 34, case 1, with R: near a half circle the side of the chord the control puts the
/// centre on (and so the way round) hangs on the last digits of R and the ends. Whatever
/// is written must run, as the control reads it, on the nominal arc.
#[test]
fn a_half_circle_by_radius_is_never_written_the_other_way_round() {
    let machine = nccomp::model::machine_file::parse(
        r#"
workpiece_chain = ["Y", "X"]
tool_chain = ["Z"]
resolution = { linear = 0.001, rotary = 0.001 }
[axes.X]
kind = "linear"
direction = [-1, 0, 0]
[axes.Y]
kind = "linear"
direction = [0, -1, 0]
[axes.Z]
kind = "linear"
direction = [0, 0, 1]
"#,
        "three.machine.toml",
    )
    .unwrap();
    let kin_errors = |scale: f64| {
        nccomp::model::error_file::parse(
            &format!(
                "length_unit = \"um\"\n[motion.X]\npositions = [-1000.0, 1000.0]\nEXX = [{a}, {b}]\n[motion.Y]\npositions = [-1000.0, 1000.0]\nEYY = [{b}, {a}]\n",
                a = 10.0 * scale,
                b = -10.0 * scale
            ),
            "three.errors.toml",
            &machine,
        )
        .unwrap()
    };
    let mut wrong = Vec::new();
    for scale in [1.0, -1.0, 0.3, -2.0] {
        let errors = kin_errors(scale);
        let kin = Kinematics::new(&machine, &errors, 0).unwrap();
        let comp = Compensator::new(&machine, &errors, Options::default()).unwrap();
        for (start, end, r) in [
            ("X120. Y140.", "X140. Y140.", "R10."),
            ("X120. Y140.", "X140.001 Y140.", "R10.0005"),
            ("X-30. Y25.", "X-10. Y25.", "R-10."),
            ("X50. Y-60.", "X50. Y-40.", "R10."),
        ] {
            for code in ["G2", "G3"] {
                let program = format!("G90 G17 G21\nG0 {start} Z40.\n{code} {end} {r} F250\n");
                let mut out = Vec::new();
                comp.run(program.as_bytes(), "half.nc", &mut out).unwrap();
                let out = String::from_utf8(out).unwrap();
                let worst = worst_off(&kin, &program, &out, 0.0);
                if worst >= 1.5e-3 {
                    wrong.push(format!("{out}{worst} mm off"));
                }
            }
        }
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
}

/// Issue 34, case 13: an arc modal in the original (no G2/G3 word) right after an arc
/// replaced by straight pieces (written G1) must still run as an arc, in ISO and Sinumerik.
/// The AC trunnion with a scale error of X and Y (arcs keep) and a bump in the
/// straightness of X between X0 and X20 (the first arc cannot keep).
#[test]
fn an_arc_after_pieces_keeps_its_motion_code() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures");
    let m = nccomp::model::machine_file::load(&root.join("ac_trunnion.machine.toml")).unwrap();
    let e = nccomp::model::error_file::parse(
        r#"
length_unit = "um"
[motion.X]
positions = [-400.0, 0.0, 10.0, 20.0, 400.0]
EXX = [4.0, 0.0, -0.1, -0.2, -4.0]
EZX = [0.0, 0.0, 3.0, 0.0, 0.0]
[motion.Y]
positions = [-400.0, 400.0]
EYY = [4.0, -4.0]
"#,
        "bump.errors.toml",
        &m,
    )
    .unwrap();
    let kin = Kinematics::new(&m, &e, 0).unwrap();
    let program = "G0 X0 Y0 Z20. A0 C0\nG1 Z-1. F500\nG2 X20. Y0 I10. J0\nX40. Y0 I10. J0\nX60. Y0 I10. J0\nG1 X70.\n";
    for dialect in [nccomp::nc::Dialect::Iso, nccomp::nc::Dialect::Sinumerik] {
        let options = Options {
            dialect: Some(dialect),
            ..Options::default()
        };
        let comp = Compensator::new(&m, &e, options).unwrap();
        let mut out = Vec::new();
        let summary = comp.run(program.as_bytes(), "modal.nc", &mut out).unwrap();
        let out = String::from_utf8(out).unwrap();
        assert!(summary.arcs >= 1 && summary.arcs_kept >= 1, "{out}");
        let worst = worst_off(&kin, program, &out, m.tool.length);
        assert!(worst < 1.5e-3, "{out}\n{} mm off the nominal path", worst);
    }
}
