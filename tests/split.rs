//! Splitting moves in the pass (--tolerance): inserted blocks in the program's style, on
//! the nominal path, and a G93 move keeping its time.

mod common;

use common::{Lcg, ac_trunnion, random_errors};
use nccomp::compensate::{Compensator, Options};
use nccomp::kinematics::path::PathTolerance;
use nccomp::kinematics::{Kinematics, Model};

fn run(program: &str, path: Option<PathTolerance>) -> (String, nccomp::compensate::Summary) {
    let machine = ac_trunnion([0.0, 0.0, -100.0], [0.0, 0.0, 0.0]);
    let errors = random_errors(&machine, &mut Lcg(17));
    let comp = Compensator::new(
        &machine,
        &errors,
        Options {
            path,
            ..Options::default()
        },
    )
    .unwrap();
    let mut out = Vec::new();
    let summary = comp.run(program.as_bytes(), "p.nc", &mut out).unwrap();
    (String::from_utf8(out).unwrap(), summary)
}

fn values(line: &str, q: &mut [f64; 5]) -> bool {
    let mut moved = false;
    for word in line.split('(').next().unwrap().split_whitespace() {
        if let Some(k) = "XYZAC".find(&word[..1]) {
            q[k] = word[1..].parse().unwrap();
            moved = true;
        }
    }
    moved
}

const PROGRAM: &str =
    "N100 G0 X-200 Y-150 Z40 A-50 C10\nN200 G1 X200 Y150 Z60 A-10 C170 F800\nN300 X-150 A-80\n";

#[test]
fn without_a_tolerance_every_block_in_is_one_block_out() {
    let (out, summary) = run(PROGRAM, None);
    assert_eq!(out.lines().count(), 3);
    assert_eq!(summary.blocks_added, 0);
}

#[test]
fn long_moves_get_blocks_inserted_on_their_nominal_path() {
    let (out, summary) = run(PROGRAM, Some(PathTolerance::default()));
    let lines: Vec<&str> = out.lines().collect();
    assert!(
        summary.blocks_added > 0 && lines.len() == 3 + summary.blocks_added,
        "{out}"
    );
    // Inserted blocks take numbers in the gaps (N101, N102, ... and N201, ...), carry the
    // block's G word and F, and come before the block they belong to.
    assert!(lines[1].starts_with("N101 G1 "), "{out}");
    assert!(lines[1].contains(" F800"), "{out}");
    let n300 = lines.iter().position(|l| l.starts_with("N300")).unwrap();
    assert!(lines[n300 - 1].starts_with("N2"), "{out}");
    // Every inserted point is the compensated image of a point on the nominal path: the
    // real machine there sits on the straight joint-space line of the nominal move.
    let machine = ac_trunnion([0.0, 0.0, -100.0], [0.0, 0.0, 0.0]);
    let errors = random_errors(&machine, &mut Lcg(17));
    let kin = Kinematics::new(&machine, &errors, 0).unwrap();
    let (mut q, mut nominal) = ([0.0; 5], [0.0; 5]);
    let input: Vec<&str> = PROGRAM.lines().collect();
    let mut previous = [0.0; 5];
    for line in &lines {
        values(line, &mut q);
        let is_original = input
            .iter()
            .any(|l| l.split(' ').next() == line.split(' ').next());
        if is_original {
            previous = nominal;
            let original = input
                .iter()
                .find(|l| l.split(' ').next() == line.split(' ').next())
                .unwrap();
            values(original, &mut nominal);
            continue;
        }
        // An inserted block: find s on the upcoming nominal move where the poses agree.
        let number = |l: &str| l.split(' ').next().unwrap()[1..].parse::<u32>().unwrap();
        let next = input.iter().find(|l| number(l) > number(line)).unwrap();
        let mut target = nominal;
        values(next, &mut target);
        let (reached, _) = kin.pose(Model::Actual, &q, 0.0);
        let off = |s: f64| {
            let qn: Vec<f64> = (0..5)
                .map(|k| nominal[k] + (target[k] - nominal[k]) * s)
                .collect();
            kin.pose(Model::Nominal, &qn, 0.0).0.deviation(&reached).0
        };
        // Coarse scan, then a ternary search around the best sample.
        let coarse = (0..=400)
            .min_by(|&a, &b| off(a as f64 / 400.0).total_cmp(&off(b as f64 / 400.0)))
            .unwrap();
        let (mut lo, mut hi) = (
            ((coarse as f64) - 1.0) / 400.0,
            ((coarse as f64) + 1.0) / 400.0,
        );
        for _ in 0..60 {
            let (m1, m2) = (lo + (hi - lo) / 3.0, hi - (hi - lo) / 3.0);
            if off(m1) < off(m2) { hi = m2 } else { lo = m1 }
        }
        let best = off(0.5 * (lo + hi));
        assert!(best < 1e-3, "{line}: {best} mm off the nominal path");
        let _ = previous;
    }
}

#[test]
fn inverse_time_pieces_keep_the_moves_time() {
    let program = "N10 G0 X-200 Y-150 Z40 A-50 C10\nN20 G93 G1 X200 Y150 Z60 A-10 C170 F2.5\n";
    let (out, summary) = run(program, Some(PathTolerance::default()));
    assert!(summary.blocks_added > 0, "{out}");
    // Σ 1/F over the pieces = 1/2.5 min (to the written precision).
    let minutes: f64 = out
        .lines()
        .skip(1)
        .map(|l| {
            let f = l.split_whitespace().find(|w| w.starts_with('F')).expect(l);
            1.0 / f[1..].parse::<f64>().unwrap()
        })
        .sum();
    assert!((minutes - 0.4).abs() < 1e-4, "{minutes} min\n{out}");
}

#[test]
fn no_split_from_a_start_the_program_left_unknown() {
    // After G28 Z the start of the next move is not known: it must not be split as if it
    // began at the old Z.
    let program = "N10 G0 X-100 Y-100 Z2 A-30 C0\nN20 G91 G28 Z0\nN30 G90 G0 X100 Z2\n";
    let (out, _) = run(program, Some(PathTolerance::default()));
    assert_eq!(out.lines().count(), 3, "{out}");
}

/// Absolute positions after every line that moves, in units of 1e-4 (mm or degree), from a
/// program in G90 or G91 (the axis words read exactly from their text).
fn positions(program: &str) -> Vec<[i64; 5]> {
    let mut q = [0i64; 5];
    let mut incremental = false;
    let mut out = Vec::new();
    for line in program.lines() {
        let mut moved = false;
        for word in line.split_whitespace() {
            match word {
                "G90" => incremental = false,
                "G91" => incremental = true,
                _ => {}
            }
            if let Some(k) = "XYZAC".find(&word[..1]) {
                let text = &word[1..];
                let (int, frac) = text.split_once('.').unwrap_or((text, ""));
                assert!(frac.len() <= 4, "{line}: more than 4 decimals");
                let negative = int.starts_with('-');
                let units = int.trim_start_matches('-').parse::<i64>().unwrap_or(0) * 10_000
                    + format!("{frac:0<4}").parse::<i64>().unwrap();
                let units = if negative { -units } else { units };
                q[k] = if incremental { q[k] + units } else { units };
                moved = true;
            }
        }
        if moved {
            out.push(q);
        }
    }
    out
}

#[test]
fn incremental_moves_are_split_like_absolute_ones_without_drift() {
    // The same random five-axis program in G90 and in G91 (exact increments): compensated
    // with the path tolerance, both give the same blocks at the same absolute positions,
    // inserted pieces included.
    let mut rng = Lcg(77);
    let mut absolute = String::from("G90 G0 X0 Y0 Z50 A-30 C0\nG1 F1000\n");
    let mut incremental = String::from("G90 G0 X0 Y0 Z50 A-30 C0\nG91 G1 F1000\n");
    let mut last = [0i64, 0, 500_000, -300_000, 0];
    for _ in 0..120 {
        let next = [
            (rng.sym(150.0) * 1e4).round() as i64,
            (rng.sym(150.0) * 1e4).round() as i64,
            ((40.0 + rng.sym(30.0)) * 1e4).round() as i64,
            ((-50.0 + rng.sym(40.0)) * 1e4).round() as i64,
            (rng.sym(180.0) * 1e4).round() as i64,
        ];
        let word = |k: usize, u: i64| {
            format!(
                "{}{}{}.{:04}",
                &"XYZAC"[k..=k],
                if u < 0 { "-" } else { "" },
                u.abs() / 10_000,
                u.abs() % 10_000
            )
        };
        let abs: Vec<String> = (0..5).map(|k| word(k, next[k])).collect();
        let inc: Vec<String> = (0..5).map(|k| word(k, next[k] - last[k])).collect();
        absolute.push_str(&(abs.join(" ") + "\n"));
        incremental.push_str(&(inc.join(" ") + "\n"));
        last = next;
    }
    let tol = Some(PathTolerance::default());
    let (out_abs, s_abs) = run(&absolute, tol);
    let (out_inc, s_inc) = run(&incremental, tol);
    assert!(s_abs.blocks_added > 40, "{}", s_abs.blocks_added);
    assert_eq!(s_abs.blocks_added, s_inc.blocks_added);
    assert_eq!(out_abs.lines().count(), out_inc.lines().count());
    let (pa, pi) = (positions(&out_abs), positions(&out_inc));
    assert_eq!(pa.len(), pi.len());
    for (k, (a, i)) in pa.iter().zip(&pi).enumerate() {
        assert_eq!(a, i, "moving line {k}: G90 {a:?}, G91 {i:?}");
    }
}

#[test]
fn a_rotary_value_far_beyond_travel_does_not_explode_the_move() {
    // Found by fuzzing: A swung through 10^8 degrees crosses the singular cone hundreds of
    // thousands of times; written with --allow-limit-violations it used to take seconds
    // and insert some 35,000 blocks per move. A move's pieces are bounded. (A word beyond
    // 10^6 is refused now; 999,999 degrees still cross the cone thousands of times.)
    let machine = ac_trunnion([0.0, 0.0, -100.0], [0.0, 0.0, 0.0]);
    let errors = random_errors(&machine, &mut Lcg(17));
    let tolerance = PathTolerance::default();
    let comp = Compensator::new(
        &machine,
        &errors,
        Options {
            path: Some(tolerance),
            allow_limit_violations: true,
            ..Options::default()
        },
    )
    .unwrap();
    let program = "G0 X10 Y5 Z10 A18.8 C5\nG1 X11 A999999 F1000\n";
    let mut out = Vec::new();
    // Its pieces stop refining at the bound, so the path strays: the gate refuses what
    // the pass wrote (bounded all the same).
    let (summary, refused) = comp.run_all(program.as_bytes(), "p.nc", &mut out);
    assert!(
        refused.iter().all(|d| d.message.contains("as the control")),
        "{refused:?}"
    );
    let bound = (nccomp::kinematics::path::MOVE_PIECES + 3) << tolerance.max_depth;
    assert!(
        summary.blocks_added > 0 && summary.blocks_added <= bound,
        "{} blocks added, bound {bound}",
        summary.blocks_added
    );
}

#[test]
fn a_move_through_the_singular_pose_names_the_held_axis() {
    // A swings through 0 (the tool along C): the pieces at and near A = 0 hold C, and the
    // summary names it (it once printed "tool along axis )" when only pieces were held).
    let machine = ac_trunnion([0.0, 0.0, -100.0], [0.0, 0.0, 0.0]);
    let errors = random_errors(&machine, &mut Lcg(17));
    let comp = Compensator::new(
        &machine,
        &errors,
        Options {
            path: Some(PathTolerance::default()),
            ..Options::default()
        },
    )
    .unwrap();
    let program = "G0 X10 Y5 Z10 A-20 C30\nG1 X12 A20 F1000\n";
    let mut out = Vec::new();
    let summary = comp.run(program.as_bytes(), "p.nc", &mut out).unwrap();
    assert!(summary.singular_blocks > 0, "{summary:?}");
    assert_eq!(summary.held_axes, ["C"]);
    assert!(
        summary.to_string().contains("(tool along axis C)"),
        "{summary}"
    );
}

/// A four-axis machine (the AC trunnion without its C table) cannot correct the tool's
/// direction: halving a move cannot bring it nearer than its ends, so the direction does
/// not split it, while the tip's path still does.
#[test]
fn a_direction_no_split_can_improve_does_not_split_the_move() {
    let mut machine = ac_trunnion([0.0, 0.0, -100.0], [0.0, 0.0, 0.0]);
    machine.axes.remove(4);
    machine.workpiece_chain = vec![1, 0, 3];
    let errors = random_errors(&machine, &mut Lcg(17));
    let tol = PathTolerance::default();
    let comp = Compensator::new(
        &machine,
        &errors,
        Options {
            path: Some(tol),
            ..Options::default()
        },
    )
    .unwrap();
    let program = "N10 G0 X-50. Y-40. Z40. A-10.\nN20 G1 X60. Y30. Z20. A-70. F800.\n";
    let mut out = Vec::new();
    let summary = comp.run(program.as_bytes(), "p.nc", &mut out).unwrap();
    let written = String::from_utf8(out).unwrap();
    // The ends leave tens of µrad: more than the tolerance, at every point of the move.
    assert!(
        summary.after_direction.value > 3.0 * tol.direction,
        "{summary}"
    );
    let pieces = summary.blocks_added;
    assert!(pieces < 100, "{pieces} blocks added\n{summary}");
    // The tip stays on the nominal path.
    let kin = Kinematics::new(&machine, &errors, 0).unwrap();
    let mut q = [0.0; 4];
    let mut ends = Vec::new();
    for line in written.lines() {
        for word in line.split_whitespace() {
            if let Some(k) = "XYZA".find(&word[..1]) {
                q[k] = word[1..].parse().unwrap();
            }
        }
        ends.push(q);
    }
    let (a, b) = ([-50.0, -40.0, 40.0, -10.0], [60.0, 30.0, 20.0, -70.0]);
    let mut worst = 0.0f64;
    for w in ends[1..].windows(2) {
        for i in 0..=16 {
            let u = i as f64 / 16.0;
            let c: Vec<f64> = (0..4).map(|k| w[0][k] + (w[1][k] - w[0][k]) * u).collect();
            let real = kin.pose(Model::Actual, &c, 0.0).0.p;
            // The nearest point of the nominal path: the best of a coarse search, refined.
            let off = |s: f64| {
                let n: Vec<f64> = (0..4).map(|k| a[k] + (b[k] - a[k]) * s).collect();
                (kin.pose(Model::Nominal, &n, 0.0).0.p - real).norm()
            };
            let j = (0..=200)
                .min_by(|&i, &j| off(i as f64 / 200.0).total_cmp(&off(j as f64 / 200.0)))
                .unwrap();
            let (mut lo, mut hi) = (((j as f64) - 1.0) / 200.0, ((j as f64) + 1.0) / 200.0);
            for _ in 0..80 {
                let (m1, m2) = (lo + (hi - lo) / 3.0, hi - (hi - lo) / 3.0);
                if off(m1) < off(m2) {
                    hi = m2;
                } else {
                    lo = m1;
                }
            }
            worst = worst.max(off(lo.clamp(0.0, 1.0)));
        }
    }
    assert!(worst < 1.5 * tol.position, "{worst}\n{written}");
}

#[test]
fn a_resolution_coarser_than_the_tolerance_is_the_floor_not_a_reason_to_split() {
    // 0.0001 in is 2.54 µm: a word rounded to it can leave its end up to 1.3 µm per axis
    // off, more than the 1 µm tolerance, and no piece can do better than the start it is
    // written from. Before, every such move was halved to the limit (10 blocks a move).
    let mut machine = ac_trunnion([0.0, 0.0, -100.0], [0.0, 0.0, 0.0]);
    machine.resolution.linear = 0.00254;
    let errors = random_errors(&machine, &mut Lcg(17));
    let kin = Kinematics::new(&machine, &errors, 0).unwrap();
    let comp = Compensator::new(&machine, &errors, Options::default()).unwrap();
    let mut program = String::from("G20 G90\nG0 X0 Y0 Z1. A0 C0\nG1 Z0. F10.\n");
    let mut rng = Lcg(3);
    for _ in 0..40 {
        program.push_str(&format!("X{:.4} Y{:.4}\n", rng.sym(3.0), rng.sym(3.0)));
    }
    let mut out = Vec::new();
    let summary = comp.run(program.as_bytes(), "inch.nc", &mut out).unwrap();
    let written = String::from_utf8(out).unwrap();
    assert_eq!(summary.blocks_added, 0, "{written}");
    // The path of every written move, against the nominal one: within the tolerance plus
    // what its written ends are left off by (their rounding).
    let mm = |q: [f64; 5]| [q[0] * 25.4, q[1] * 25.4, q[2] * 25.4, q[3], q[4]];
    let dev = |p: &[f64; 5], w: &[f64; 5]| {
        let (meant, _) = kin.pose(Model::Nominal, &mm(*p), 0.0);
        let (reached, _) = kin.pose(Model::Actual, &mm(*w), 0.0);
        (reached.p - meant.p).norm()
    };
    let lerp = |a: &[f64; 5], b: &[f64; 5], s: f64| {
        let mut q = [0.0; 5];
        for k in 0..5 {
            q[k] = a[k] + s * (b[k] - a[k]);
        }
        q
    };
    let (mut p0, mut w0, mut p1, mut w1) = ([0.0; 5], [0.0; 5], [0.0; 5], [0.0; 5]);
    let mut worst: f64 = 0.0;
    for (k, (li, lo)) in program.lines().zip(written.lines()).enumerate().skip(1) {
        values(li, &mut p1);
        values(lo, &mut w1);
        if k > 2 {
            let floor = dev(&p0, &w0) + dev(&p1, &w1);
            for s in [0.25, 0.5, 0.75] {
                let d = dev(&lerp(&p0, &p1, s), &lerp(&w0, &w1, s));
                assert!(d <= floor + 1e-3, "{lo}: {:.3} µm at {s}", d * 1e3);
                worst = worst.max(d);
            }
        }
        // The ends: within the rounding to 0.0001 in.
        assert!(dev(&p1, &w1) < 2.6e-3, "{lo}");
        (p0, w0) = (p1, w1);
    }
    // Uncompensated, the same moves are several microns off: the checks can fail.
    assert!(worst > 0.0);
}
