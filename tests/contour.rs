//! Contour errors of synthetic traces, against the errors injected into them.
//!
//! A trace is made from a program's reference path: the machine runs it at a constant tip
//! speed, every sample is taken a known lag behind and at a jittered instant, and at every
//! sample the tool tip is moved off the path by a known offset perpendicular to it and the
//! tool tilted by a known angle; the axis values come from the machine's nominal inverse
//! kinematics. The offset, its direction in the normal plane and the tilt vary smoothly
//! along the path (random sinusoids). The analysis must give back, at every reference
//! point, the offset within 0.1 µm and the tilt within 1 µrad, as the trace shows them:
//! between two samples the machine moves joint-linearly, so the trace holds the injected
//! errors interpolated between the samples', not the smooth ones. Where the offset (e) turns
//! by Δφ between samples the trace cuts inside it by up to e·Δφ²/8 (0.15 µm for 15 µm
//! turning by 0.28 rad between samples 0.3 mm apart), so the test works out the distance to
//! the path through the injected samples itself (`against_chords`).
//!
//! Noise: besides the jitter of the sampling instants, every sample's tip can be moved by
//! a random amount perpendicular to the path and its tool tilted by a random angle. The
//! smooth offset then no longer tells the error between samples, so the test works it out
//! itself from the poses it injected: the shortest distance from the reference tip to the
//! polyline through the injected tips (every sample interval tried), and the angle to the
//! injected tool direction interpolated there.
//!
//! A sampled trace cannot show a corner of the path between two samples (a chord across a
//! corner of angle δ between samples L apart cuts it by up to L·δ/4, docs/contour.md), so
//! these traces also hold a sample where the machine passes each block end, as a trace
//! of the interpolator's block ends would.

use nalgebra::{Rotation3, Unit, Vector3};
use nccomp::contour::s_shape::{Finishing, SShape, finishing_program};
use nccomp::contour::trace::{Trace, axis_names};
use nccomp::contour::{self, Analysis};
use nccomp::kinematics::{Kinematics, MAX_AXES, Model, Pose, SolveOptions, angle_between};
use nccomp::model::{AxisKind, ErrorModel, Machine, machine_file};
use nccomp::program::moves::{NominalMove, nominal_moves};
use proptest::prelude::*;
use std::collections::HashMap;
use std::f64::consts::TAU;

fn machine(name: &str) -> Machine {
    let path = format!(
        "{}/fixtures/{name}.machine.toml",
        env!("CARGO_MANIFEST_DIR")
    );
    machine_file::load(std::path::Path::new(&path)).unwrap()
}

/// A smooth function of the path parameter: `mean + amplitude · sin(2π σ / period + phase)`.
#[derive(Debug, Clone, Copy)]
struct Wave {
    mean: f64,
    amplitude: f64,
    period: f64,
    phase: f64,
}

impl Wave {
    fn at(&self, s: f64) -> f64 {
        self.mean + self.amplitude * (TAU * s / self.period + self.phase).sin()
    }

    fn slope(&self, s: f64) -> f64 {
        self.amplitude * TAU / self.period * (TAU * s / self.period + self.phase).cos()
    }
}

/// What goes into a synthetic trace.
#[derive(Debug, Clone, Copy)]
struct Injection {
    /// Tip speed (mm/s), sample period (s), lag (s) and jitter of the sampling instants
    /// (share of the period).
    speed: f64,
    period: f64,
    lag: f64,
    jitter: f64,
    /// The tip offset (mm), the angle (rad) of its direction in the plane normal to the
    /// path, and the tilt of the tool (rad), as functions of the path parameter.
    offset: Wave,
    angle: Wave,
    tilt: Wave,
    /// Make the offset perpendicular to the path as it runs over a block's length rather
    /// than to the block (not where the path turns back on itself).
    smooth: bool,
    /// Largest random tip offset perpendicular to the path (mm) and tool tilt (rad) added
    /// to each sample on its own (0: none).
    noise: f64,
    tilt_noise: f64,
    seed: u64,
}

/// The program's path: the moves after the first, move m running over σ ∈ [m, m + 1].
struct Path<'a> {
    kin: &'a Kinematics,
    moves: Vec<NominalMove>,
    length: f64,
    /// Time at which each move starts, and the total.
    starts: Vec<f64>,
    total: f64,
}

impl<'a> Path<'a> {
    fn new(kin: &'a Kinematics, all: &[NominalMove], length: f64, speed: f64) -> Self {
        let n = kin.len();
        let mut moves = Vec::new();
        let mut starts = Vec::new();
        let mut t = 0.0;
        for m in all.iter().filter(|m| m.start.is_some()) {
            let mut tip = 0.0;
            let mut last = kin.pose(Model::Nominal, &m.at(0.0, n)[..n], length).0.p;
            for k in 1..=16 {
                let p = kin
                    .pose(Model::Nominal, &m.at(f64::from(k) / 16.0, n)[..n], length)
                    .0
                    .p;
                tip += (p - last).norm();
                last = p;
            }
            // Moves that stay put (an approach of length 0) are not on the path.
            if tip > 0.0 {
                moves.push(*m);
                starts.push(t);
                t += tip / speed;
            }
        }
        Path {
            kin,
            moves,
            length,
            starts,
            total: t,
        }
    }

    /// The path parameter at time `t` (clamped to the path).
    fn sigma(&self, t: f64) -> f64 {
        let t = t.clamp(0.0, self.total);
        let m = self.starts.partition_point(|&s| s <= t).saturating_sub(1);
        let end = self.starts.get(m + 1).copied().unwrap_or(self.total);
        m as f64 + ((t - self.starts[m]) / (end - self.starts[m])).clamp(0.0, 1.0)
    }

    /// The program's pose at σ.
    fn pose(&self, sigma: f64) -> Pose {
        let n = self.kin.len();
        let m = (sigma.floor() as usize).min(self.moves.len() - 1);
        let q = self.moves[m].at(sigma - m as f64, n);
        self.kin.pose(Model::Nominal, &q[..n], self.length).0
    }

    /// Axis values, pose and unit tangent at σ.
    fn at(&self, sigma: f64) -> ([f64; MAX_AXES], Pose, Vector3<f64>) {
        let n = self.kin.len();
        let m = (sigma.floor() as usize).min(self.moves.len() - 1);
        let mv = &self.moves[m];
        let q = mv.at(sigma - m as f64, n);
        let (pose, jac) = self
            .kin
            .pose_and_jacobian(Model::Nominal, &q[..n], self.length);
        let start = mv.start.unwrap();
        let tangent = (0..n)
            .map(|k| jac.dp[k] * (mv.end[k] - start[k]))
            .fold(Vector3::zeros(), |t, d| t + d);
        (q, pose, tangent)
    }
}

/// The injected tip offset and tool direction at σ, the size of the offset the shortest
/// distance sees, the axis values of σ and how far (in σ) from σ the perpendicular from
/// the reference point meets the offset path.
///
/// The offset points a set angle off a direction that turns smoothly with the tool, made
/// perpendicular to the path as it runs over a block's length (not to the block itself,
/// whose direction jumps at block ends), so the offset path has no gaps at block ends. The
/// distance sees the offset's part perpendicular to the offset path there.
fn injected(path: &Path, inj: &Injection, sigma: f64) -> (Pose, f64, [f64; MAX_AXES], f64) {
    let (q, pose, tangent) = path.at(sigma);
    let o = pose.o;
    let tip = |s: f64| path.at(s.clamp(0.0, path.moves.len() as f64)).1.p;
    let smooth = if inj.smooth {
        (tip(sigma + 0.5) - tip(sigma - 0.5)).normalize()
    } else {
        tangent.normalize()
    };
    // A tilt axis perpendicular to the tool that turns smoothly with it.
    let m = o.cross(&Vector3::x()).normalize();
    let angle = inj.angle.at(sigma);
    let v = m * angle.cos() + o.cross(&m) * angle.sin();
    let n = (v - smooth * v.dot(&smooth)).normalize();
    let offset = n * inj.offset.at(sigma);
    let slope = inj.offset.slope(sigma) / tangent.norm();
    let along = (tangent.normalize() + n * slope).normalize();
    let seen = (offset - along * offset.dot(&along)).norm();
    let tilted = Rotation3::from_axis_angle(&Unit::new_normalize(m), inj.tilt.at(sigma)) * o;
    (
        Pose {
            p: pose.p + offset,
            o: tilted,
        },
        seen,
        q,
        -offset.dot(&along) / tangent.norm(),
    )
}

/// A trace of the program's `moves` with the errors of `inj`, and the pose injected at
/// each of its samples and the path parameter σ there (in path order).
fn synthetic_trace(
    machine: &Machine,
    path: &Path,
    inj: &Injection,
) -> (Trace, Vec<Pose>, Vec<f64>) {
    let kin = path.kin;
    let n = kin.len();
    let mut rng = inj.seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    let mut uniform = || {
        rng ^= rng >> 12;
        rng ^= rng << 25;
        rng ^= rng >> 27;
        (rng.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    };
    let samples = ((path.total + inj.lag) / inj.period).ceil() as usize + 20;
    let mut trace = Trace {
        axes: axis_names(machine, kin),
        ..Trace::default()
    };
    let options = SolveOptions::default();
    // The sample instants, jittered, and one where the machine passes each block end (and
    // the program's start and end).
    let mut instants: Vec<(f64, f64)> = (0..samples)
        .map(|j| {
            let time = j as f64 * inj.period;
            (
                time,
                path.sigma(time - inj.lag + inj.jitter * inj.period * uniform()),
            )
        })
        .collect();
    instants.extend(path.starts.iter().enumerate().map(|(m, start)| {
        let time = start + inj.lag;
        (time, m as f64)
    }));
    instants.push((path.total + inj.lag, path.moves.len() as f64));
    // In path order (a jittered sample may pass a block end before its sample does);
    // times stay in order.
    instants.sort_by(|a, b| a.1.total_cmp(&b.1));
    let mut last = f64::NEG_INFINITY;
    let mut poses = Vec::with_capacity(instants.len());
    let sigmas = instants.iter().map(|i| i.1).collect();
    for (time, sigma) in instants {
        let time = time.max(last);
        last = time;
        let (mut target, _, guess, _) = injected(path, inj, sigma);
        if inj.noise > 0.0 || inj.tilt_noise > 0.0 {
            let tangent = path.at(sigma).2.normalize();
            let across = tangent.cross(&Vector3::new(0.3, -0.5, 0.8)).normalize();
            let phi = TAU * uniform();
            let side = across * phi.cos() + tangent.cross(&across) * phi.sin();
            target.p += side * (inj.noise * uniform());
            let o = target.o;
            let m = o.cross(&Vector3::new(0.6, 0.7, -0.2)).normalize();
            let psi = TAU * uniform();
            let axis = m * psi.cos() + o.cross(&m) * psi.sin();
            target.o =
                Rotation3::from_axis_angle(&Unit::new_normalize(axis), inj.tilt_noise * uniform())
                    * o;
        }
        let sol = kin
            .inverse(Model::Nominal, &target, &guess[..n], path.length, &options)
            .unwrap_or_else(|| panic!("the injected pose at σ = {sigma} cannot be reached"));
        trace.time.push(time);
        trace.actual.extend_from_slice(sol.values());
        poses.push(target);
    }
    (trace, poses, sigmas)
}

/// Run the analysis and compare every reported point with the injection.
/// Returns the analysis and the actual tool tips of the trace.
fn check(
    machine: &Machine,
    program: &str,
    inj: &Injection,
) -> Result<(Analysis, Vec<Vector3<f64>>), TestCaseError> {
    let (moves, chain) = nominal_moves(machine, 0, program.as_bytes(), "t.nc", 20).unwrap();
    let kin = &Kinematics::new(machine, &ErrorModel::zero(machine), chain).unwrap();
    let length = moves.last().unwrap().tool_length;
    let path = Path::new(kin, &moves, length, inj.speed);
    let (trace, poses, sigmas) = synthetic_trace(machine, &path, inj);
    // Where each sample is and how far its injected pose is off the program's.
    let errors: Vec<(f64, Vector3<f64>, Vector3<f64>)> = poses
        .iter()
        .zip(&sigmas)
        .map(|(pose, &s)| {
            let program = path.pose(s);
            (s, pose.p - program.p, pose.o - program.o)
        })
        .collect();
    let a = contour::analyse_trace(
        kin,
        &moves,
        &trace,
        ("t.nc", program.as_bytes()),
        &contour::Options::default(),
    )
    .map_err(|e| TestCaseError::fail(e.render()))?;
    prop_assert_eq!(a.beyond, 0);
    let first_line = moves[0].line;
    let index: HashMap<usize, usize> = path
        .moves
        .iter()
        .enumerate()
        .map(|(i, m)| (m.line, i))
        .collect();
    let (mut worst_tip, mut worst_axis) = (0.0f64, 0.0f64);
    for p in a.points() {
        let r = &p.reference;
        let sigma = if r.line == first_line {
            0.0
        } else {
            index[&r.line] as f64 + r.s
        };
        // The reference point is the program's pose there.
        let (_, pose, _) = path.at(sigma);
        prop_assert!(
            (pose.p - r.p).norm() < 1e-9 && angle_between(&pose.o, &r.o) < 1e-9,
            "line {} s = {}: reference {:?}, program {:?}",
            r.line,
            r.s,
            r,
            pose
        );
        if inj.noise > 0.0 || inj.tilt_noise > 0.0 {
            let (dt, da) = against_polyline(&poses, &r.p, &r.o, p.actual.tip, p.actual.axis);
            worst_tip = worst_tip.max(dt);
            worst_axis = worst_axis.max(da);
            prop_assert!(
                dt < 1e-4 && da < 1e-6,
                "line {} s = {:.4}: tip {:.5} µm, {:.5} µm off the injected; axis {:.4} µrad, {:.4} µrad off",
                r.line,
                r.s,
                p.actual.tip * 1e3,
                dt * 1e3,
                p.actual.axis * 1e6,
                da * 1e6
            );
            continue;
        }
        // Where the shortest distance meets the smooth offset path: an offset that is not
        // quite perpendicular to the path moves that place a little along the path. The
        // actual path starts and ends where the program does.
        let (_, tip, _, shift) = injected(&path, inj, sigma);
        let near = (sigma + shift).clamp(0.0, path.moves.len() as f64);
        // Between samples the trace shows the injected errors interpolated, not the smooth
        // ones (the smooth ones are in the message).
        let (dt, da) = against_chords(
            &path,
            &errors,
            &r.p,
            &r.o,
            near,
            p.actual.tip,
            p.actual.axis,
        );
        worst_tip = worst_tip.max(dt);
        worst_axis = worst_axis.max(da);
        prop_assert!(
            dt < 1e-4 && da < 1e-6,
            "line {} s = {:.4} (σ = {sigma:.4}): tip {:.5} µm, {:.5} µm off what the trace shows (smooth injected {:.5} µm); axis {:.4} µrad, {:.4} µrad off (smooth injected {:.4} µrad)",
            r.line,
            r.s,
            p.actual.tip * 1e3,
            dt * 1e3,
            tip * 1e3,
            p.actual.axis * 1e6,
            da * 1e6,
            angle_between(&injected(&path, inj, near).0.o, &r.o) * 1e6
        );
    }
    prop_assert!(a.reported.len() > 60, "{} points", a.reported.len());
    eprintln!(
        "{} points, worst differences {:.4} µm and {:.4} µrad",
        a.reported.len(),
        worst_tip * 1e3,
        worst_axis * 1e6
    );
    let n = kin.len();
    let tips = (0..trace.len())
        .map(|i| {
            kin.pose(Model::Nominal, &trace.actual[i * n..(i + 1) * n], length)
                .0
                .p
        })
        .collect();
    Ok((a, tips))
}

/// How far a computed tip distance and tool angle are from what the trace shows of the
/// injected errors: the shortest distance from `p` to the path the machine runs between
/// the injected samples, and the angle between `o` and the tool direction there. `errors`
/// holds each sample's σ and how far its injected pose is off the program's (tip and tool
/// direction); `near` is where the perpendicular from `p` meets the smooth offset path.
///
/// Between two samples the machine moves joint-linearly, so it follows the program's path
/// with the injected error interpolated linearly between the samples' (up to terms of
/// second order in the error), not the smooth one: where the offset of size e turns by Δφ
/// between samples the path cuts inside it by up to e·Δφ²/8 (0.15 µm for 15 µm turning
/// by 0.28 rad), and a tilt varying as a sinusoid of amplitude θ and period T falls short
/// of it by up to θ·(2π·Δσ/T)²/8. That is what a trace shows between its samples, and what
/// the analysis must give. The nearest place on that path is within nanometres of the
/// smooth one's (the two differ by the sag), so the sample intervals within 1 µm of `near`
/// are tried. Where several are within 5 nm as near (the corner at a block end, the
/// samples where the machine stands at the start), the angle at any of them will do, as in
/// [`against_polyline`].
fn against_chords(
    path: &Path,
    errors: &[(f64, Vector3<f64>, Vector3<f64>)],
    p: &Vector3<f64>,
    o: &Vector3<f64>,
    near: f64,
    tip: f64,
    axis: f64,
) -> (f64, f64) {
    let reach = 1e-3 / path.at(near).2.norm();
    let first = errors
        .partition_point(|e| e.0 < near - reach)
        .saturating_sub(1);
    let feet: Vec<(f64, f64)> = errors[first..]
        .windows(2)
        .take_while(|w| w[0].0 <= near + reach)
        .map(|w| {
            let ((a, pa, oa), (b, pb, ob)) = (w[0], w[1]);
            let pose = |s: f64| {
                // Where the machine stands (before the start, after the end) an interval
                // has no length.
                let t = if b > a { (s - a) / (b - a) } else { 0.0 };
                let pose = path.pose(s);
                (pose.p + pa + (pb - pa) * t, pose.o + oa + (ob - oa) * t)
            };
            let distance = |s: f64| (pose(s).0 - p).norm();
            // Golden-section search: the distance has one minimum over a sample interval
            // (the path bends over centimetres, the interval is at most half a millimetre).
            let g = (5f64.sqrt() - 1.0) / 2.0;
            let (mut lo, mut hi) = (a, b);
            let (mut x1, mut x2) = (hi - g * (hi - lo), lo + g * (hi - lo));
            let (mut f1, mut f2) = (distance(x1), distance(x2));
            for _ in 0..40 {
                if f1 <= f2 {
                    (hi, x2, f2) = (x2, x1, f1);
                    x1 = hi - g * (hi - lo);
                    f1 = distance(x1);
                } else {
                    (lo, x1, f1) = (x1, x2, f2);
                    x2 = lo + g * (hi - lo);
                    f2 = distance(x2);
                }
            }
            let (foot, d) = [(a, distance(a)), (b, distance(b)), (x1, f1), (x2, f2)]
                .into_iter()
                .min_by(|x, y| x.1.total_cmp(&y.1))
                .unwrap();
            (d, angle_between(&pose(foot).1.normalize(), o))
        })
        .collect();
    let nearest = feet.iter().map(|f| f.0).fold(f64::INFINITY, f64::min);
    let angle = feet
        .iter()
        .filter(|f| f.0 <= nearest + 5e-6)
        .map(|f| (f.1 - axis).abs())
        .fold(f64::INFINITY, f64::min);
    ((tip - nearest).abs(), angle)
}

/// How far a computed tip distance and tool angle are from what the injected sample poses
/// give: the shortest distance from `p` to the polyline through their tips, and the angle
/// between `o` and their tool direction interpolated at the nearest place. Where other
/// places are within 5 nm as near (ties between neighbouring sample intervals), the angle
/// at any of them will do.
fn against_polyline(
    poses: &[Pose],
    p: &Vector3<f64>,
    o: &Vector3<f64>,
    tip: f64,
    axis: f64,
) -> (f64, f64) {
    let feet: Vec<(f64, Vector3<f64>)> = poses
        .windows(2)
        .map(|w| {
            let ab = w[1].p - w[0].p;
            let len2 = ab.norm_squared();
            let t = if len2 > 0.0 {
                ((p - w[0].p).dot(&ab) / len2).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let foot = w[0].p + ab * t;
            let dir = (w[0].o + (w[1].o - w[0].o) * t).normalize();
            ((foot - p).norm(), dir)
        })
        .collect();
    let nearest = feet.iter().map(|f| f.0).fold(f64::INFINITY, f64::min);
    let angle = feet
        .iter()
        .filter(|f| f.0 <= nearest + 5e-6)
        .map(|f| (angle_between(&f.1, o) - axis).abs())
        .fold(f64::INFINITY, f64::min);
    ((tip - nearest).abs(), angle)
}

/// A five-axis program along a smooth tip curve with a smoothly leaning tool, one block
/// every half millimetre, solved into axis values for `machine`.
fn smooth_program(machine: &Machine, shape: [f64; 6], blocks: usize) -> String {
    let kin = Kinematics::new(machine, &ErrorModel::zero(machine), 0).unwrap();
    let n = kin.len();
    let length = machine.tool.length;
    let [a, b, rho, lean, lean_wave, turn] = shape;
    let pose = |u: f64| {
        let p = Vector3::new(
            u - 15.0,
            a * (u / rho).sin(),
            b * (1.0 - (u / (1.3 * rho)).cos()),
        );
        let theta = (lean + lean_wave * (u / 7.0).sin()).to_radians();
        let psi = (40.0 + turn * u).to_radians();
        let o = Vector3::new(
            theta.sin() * psi.cos(),
            theta.sin() * psi.sin(),
            theta.cos(),
        );
        Pose { p, o }
    };
    let options = SolveOptions::default();
    let within = |q: &[f64]| {
        (0..n).all(|v| {
            machine.axes[kin.axes()[v]]
                .travel
                .is_none_or(|[lo, hi]| (lo..=hi).contains(&q[v]))
        })
    };
    // The first pose from a grid of rotary values; then each from the one before.
    let rotary: Vec<usize> = (0..n)
        .filter(|&v| kin.kind(v) == AxisKind::Rotary)
        .collect();
    let mut q = None;
    'grid: for i in -6..=6 {
        for j in -6..=6 {
            let mut guess = [0.0; MAX_AXES];
            guess[rotary[0]] = f64::from(i) * 30.0;
            guess[rotary[1]] = f64::from(j) * 30.0;
            if let Some(s) = kin.inverse(Model::Nominal, &pose(0.0), &guess[..n], length, &options)
                && within(s.values())
            {
                q = Some(s.q);
                break 'grid;
            }
        }
    }
    let mut q = q.expect("the first pose is reachable");
    let letters: Vec<char> = kin.axes().iter().map(|&i| machine.axes[i].word).collect();
    let mut text = String::from("G21 G90 G94\n");
    for k in 0..=blocks {
        let sol = kin
            .inverse(
                Model::Nominal,
                &pose(0.5 * k as f64),
                &q[..n],
                length,
                &options,
            )
            .expect("every pose is reachable");
        assert!(within(sol.values()), "block {k} is beyond the travel");
        q = sol.q;
        text.push_str("G1");
        for v in 0..n {
            text.push_str(&format!(" {}{:.4}", letters[v], q[v]));
        }
        text.push_str(if k == 0 { " F1000\n" } else { "\n" });
    }
    text.push_str("M30\n");
    text
}

fn wave(mean: f64, amplitude: f64, period: f64, phase: f64) -> Wave {
    Wave {
        mean,
        amplitude,
        period,
        phase,
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 6, failure_persistence: None, ..ProptestConfig::default() })]

    /// Random smooth five-axis programs on the three five-axis machines, random offsets,
    /// tilts, lags and jitter.
    #[test]
    fn injected_errors_come_back(
        which in 0usize..3,
        a in 1.0f64..4.0,
        b in 0.5f64..3.0,
        rho in 12.0f64..20.0,
        lean in 15.0f64..25.0,
        lean_wave in 0.0f64..4.0,
        turn in -1.0f64..1.0,
        e in (-0.015f64..0.015, 0.0f64..0.005, 10.0f64..40.0, 0.0f64..TAU),
        phi in (0.0f64..TAU, 0.0f64..1.0),
        tilt in (-1e-3f64..1e-3, 0.0f64..3e-4, 8.0f64..40.0, 0.0f64..TAU),
        lag in 0.0f64..0.05,
        jitter in 0.0f64..0.4,
        coarse in any::<bool>(),
        seed in any::<u64>(),
    ) {
        let m = machine(["ac_trunnion", "bc_trunnion", "head_head"][which]);
        let program = smooth_program(&m, [a, b, rho, lean, lean_wave, turn], 48);
        let stretch = if coarse { 4.0 } else { 1.0 };
        let inj = Injection {
            speed: 20.0,
            // Every 20 µm, or every 0.3 mm as paper 003's 15 ms at F1200.
            period: if coarse { 0.015 } else { 0.001 },
            lag,
            jitter,
            // What a trace sampled every 0.3 mm can show varies slowly along the path.
            offset: wave(e.0, e.1, e.2 * stretch, e.3),
            angle: wave(phi.0, phi.1, 18.0 * stretch, 0.0),
            tilt: wave(tilt.0, tilt.1, tilt.2 * stretch, tilt.3),
            smooth: true,
            noise: 0.0,
            tilt_noise: 0.0,
            seed,
        };
        check(&m, &program, &inj)?;
    }

    /// The same with every sample's tip moved off the path by up to a micron and its tool
    /// tilted by up to 5 µrad on its own, sampled every 20 µm.
    #[test]
    fn injected_errors_and_noise_come_back(
        which in 0usize..3,
        a in 1.0f64..4.0,
        rho in 12.0f64..20.0,
        turn in -1.0f64..1.0,
        e in (-0.015f64..0.015, 0.0f64..0.005, 10.0f64..40.0, 0.0f64..TAU),
        tilt in (-1e-3f64..1e-3, 0.0f64..3e-4, 8.0f64..40.0, 0.0f64..TAU),
        noise in (1e-4f64..1e-3, 1e-7f64..5e-6),
        lag in 0.0f64..0.05,
        jitter in 0.0f64..0.4,
        seed in any::<u64>(),
    ) {
        let m = machine(["ac_trunnion", "bc_trunnion", "head_head"][which]);
        let program = smooth_program(&m, [a, 1.5, rho, 20.0, 2.0, turn], 24);
        let inj = Injection {
            speed: 20.0,
            period: 0.001,
            lag,
            jitter,
            offset: wave(e.0, e.1, e.2, e.3),
            angle: wave(0.3, 0.7, 18.0, 0.0),
            tilt: wave(tilt.0, tilt.1, tilt.2, tilt.3),
            smooth: true,
            noise: noise.0,
            tilt_noise: noise.1,
            seed,
        };
        check(&m, &program, &inj)?;
    }
}

/// The S-shaped test piece's finishing cut on the AC trunnion: offsets of 5 to 15 µm,
/// tilts of 200 to 400 µrad, 12 ms of lag, sampled every millisecond and every 15 ms.
#[test]
fn injected_errors_come_back_on_the_s_shaped_piece() {
    let m = machine("ac_trunnion");
    let finishing = Finishing {
        segments: 400,
        clearance: 0.0,
        ..Finishing::default()
    };
    let program = finishing_program(&m, &SShape::paper(), &finishing).unwrap();
    let inj = Injection {
        speed: 20.0,
        period: 0.001,
        lag: 0.012,
        jitter: 0.3,
        offset: wave(0.010, 0.005, 57.0, 0.3),
        angle: wave(0.2, 0.8, 130.0, 0.0),
        tilt: wave(3e-4, 1e-4, 90.0, 1.0),
        smooth: true,
        noise: 0.0,
        tilt_noise: 0.0,
        seed: 3,
    };
    let (a, _) = check(&m, &program, &inj).unwrap();
    assert!(a.path_length > 220.0, "{}", a.path_length);
    let coarse = Injection {
        period: 0.015,
        ..inj
    };
    check(&m, &program, &coarse).unwrap();
}

/// Where the path doubles back on itself the way out and the way back are microns apart;
/// each reference point must be matched on its own pass. The offset is 15 µm at the start,
/// 10 µm at the turn and 5 µm at the end, on the same side: at a place passed twice the
/// two passes differ by up to 10 µm, so a match on the wrong pass fails. Here the passes
/// are 30 mm apart along the path, further than the search window reaches; the next test
/// is about the turn itself.
#[test]
fn a_path_that_doubles_back_is_matched_pass_by_pass() {
    let m = machine("ac_trunnion");
    let program = "G21 G90 G94\nG1 X-10 Y5 Z2 A-20 C30 F1000\nG1 X20 Y8 Z3 A-24 C36\nG1 X-10 Y5 Z2 A-20 C30\nM30\n";
    let inj = Injection {
        speed: 20.0,
        period: 0.001,
        lag: 0.02,
        jitter: 0.3,
        // 10 + 5·cos(πσ/2) µm.
        offset: wave(0.010, 0.005, 4.0, TAU / 4.0),
        angle: wave(0.5, 0.0, 1.0, 0.0),
        tilt: wave(2e-4, 1e-4, 4.0, TAU / 4.0),
        smooth: false,
        noise: 0.0,
        tilt_noise: 0.0,
        seed: 11,
    };
    let (a, tips) = check(&m, program, &inj).unwrap();
    // The test can tell: the nearest trace sample to a point on the way out lies on the
    // way back, 7 µm off the injected offset.
    let p = a
        .points()
        .find(|p| p.reference.line == 3 && (p.reference.s - 0.5).abs() < 0.01)
        .unwrap();
    let nearest = tips
        .iter()
        .map(|t| (t - p.reference.p).norm())
        .fold(f64::INFINITY, f64::min);
    assert!(
        (nearest - p.actual.tip).abs() > 0.005,
        "{nearest} {}",
        p.actual.tip
    );
}

/// At the turn of a path that doubles back both passes lie within the search window. The
/// offset ripples (10 ± 5 µm, 1.2 mm period) and falls through the turn, so just before
/// it the way back runs microns nearer to the reference than the way out: only a search
/// that keeps to the reference's direction of travel matches those points on the way out.
#[test]
fn the_turn_of_a_path_that_doubles_back_is_matched_on_the_way_out() {
    let m = machine("ac_trunnion");
    let program = "G21 G90 G94\nG1 X-10 Y5 Z2 A-20 C30 F1000\nG1 X-7 Y5.3 Z2.1 A-20.4 C30.6\nG1 X-10 Y5 Z2 A-20 C30\nM30\n";
    let inj = Injection {
        speed: 20.0,
        period: 0.001,
        lag: 0.02,
        jitter: 0.3,
        // 10 + 5·sin(5πσ) µm: 10 at the turn (σ = 1), more before it, less after.
        offset: wave(0.010, 0.005, 0.4, 0.0),
        angle: wave(0.5, 0.0, 1.0, 0.0),
        tilt: wave(2e-4, 1e-4, 1.5, 0.0),
        smooth: false,
        noise: 0.0,
        tilt_noise: 0.0,
        seed: 5,
    };
    let (a, tips) = check(&m, program, &inj).unwrap();
    // The test can tell: just before the turn a trace sample on the way back is microns
    // nearer than the injected offset of the way out.
    let nearer = a
        .points()
        .filter(|p| p.reference.line == 3 && p.reference.s > 0.97 && p.reference.s < 1.0)
        .filter(|p| {
            let nearest = tips
                .iter()
                .map(|t| (t - p.reference.p).norm())
                .fold(f64::INFINITY, f64::min);
            nearest < p.actual.tip - 0.0005
        })
        .count();
    assert!(nearer >= 2, "{nearer} points");
}
