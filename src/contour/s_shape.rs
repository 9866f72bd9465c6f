//! Paper 003's S-shaped test piece and a five-axis finishing program for it.
//!
//! The piece's face is a ruled surface: a straight line (the ruling) swept along two
//! directrices, a lower one on the table (z = 0) and an upper one at the piece's height,
//! each a quasi-uniform cubic B-spline (end control points of multiplicity four, so the
//! curve starts and ends at them). The two directrices differ in shape, so the rulings
//! twist along the S and the surface is not developable: a cylinder laid along the ruling
//! does not touch it along a line, which is what makes the piece a test of five-axis
//! contouring. The control points are ours (the paper does not give them), chosen to
//! make an S 150 mm long and 35 mm high with rulings leaning 12° to 20° from vertical,
//! clear of the AC trunnion's singular pose (A = 0).
//!
//! The finishing program flank-mills the face with a flat end mill whose axis lies along
//! the ruling, its end face a little below the bottom edge, every pose solved into axis
//! values through the machine's inverse kinematics, so the program is for any five-axis
//! machine file.

use crate::kinematics::{Kinematics, MAX_AXES, Model, Pose, SolveOptions};
use crate::model::{AxisKind, ErrorModel, Machine};
use nalgebra::Vector3;
use std::fmt::Write;

/// A clamped (quasi-uniform) cubic B-spline.
#[derive(Debug, Clone, PartialEq)]
pub struct CubicBSpline {
    points: Vec<Vector3<f64>>,
    knots: Vec<f64>,
}

impl CubicBSpline {
    /// The spline of `points` (at least four) with end knots of multiplicity four and
    /// uniform knots between.
    pub fn new(points: Vec<Vector3<f64>>) -> Self {
        assert!(
            points.len() >= 4,
            "a cubic B-spline needs four control points"
        );
        let spans = points.len() - 3;
        let mut knots = vec![0.0; 4];
        knots.extend((1..spans).map(|i| i as f64 / spans as f64));
        knots.extend([1.0; 4]);
        CubicBSpline { points, knots }
    }

    /// The point and the first derivative at `u` ∈ [0, 1].
    pub fn eval(&self, u: f64) -> (Vector3<f64>, Vector3<f64>) {
        let u = u.clamp(0.0, 1.0);
        let p = &self.points;
        // The derivative is the quadratic spline of the control points' differences.
        let derivative: Vec<Vector3<f64>> = (0..p.len() - 1)
            .map(|i| (p[i + 1] - p[i]) * (3.0 / (self.knots[i + 4] - self.knots[i + 1])))
            .collect();
        (
            de_boor(3, &self.knots, p, u),
            de_boor(2, &self.knots[1..self.knots.len() - 1], &derivative, u),
        )
    }
}

/// The B-spline of degree `p` with `knots` and control `points` at `u` (de Boor's
/// algorithm; `u` = 1 falls in the last span).
fn de_boor(p: usize, knots: &[f64], points: &[Vector3<f64>], u: f64) -> Vector3<f64> {
    let n = points.len();
    let k = (p..n).rev().find(|&k| knots[k] <= u).unwrap_or(p);
    let mut d: Vec<Vector3<f64>> = (0..=p).map(|j| points[j + k - p]).collect();
    for r in 1..=p {
        for j in (r..=p).rev() {
            let (lo, hi) = (knots[j + k - p], knots[j + 1 + k - r]);
            let a = if hi > lo { (u - lo) / (hi - lo) } else { 0.0 };
            d[j] = d[j - 1] * (1.0 - a) + d[j] * a;
        }
    }
    d[p]
}

/// The ruled surface between two directrices.
#[derive(Debug, Clone, PartialEq)]
pub struct SShape {
    pub lower: CubicBSpline,
    pub upper: CubicBSpline,
}

impl SShape {
    /// The piece nccomp uses: 150 mm long, 35 mm high, centred on program zero.
    pub fn paper() -> Self {
        let lower = [
            (-75.0, -5.0),
            (-55.0, -45.0),
            (-15.0, -40.0),
            (0.0, 0.0),
            (15.0, 40.0),
            (55.0, 45.0),
            (75.0, 5.0),
        ];
        let upper = [
            (-72.0, -14.0),
            (-50.0, -52.0),
            (-12.0, -50.0),
            (4.0, -10.0),
            (20.0, 28.0),
            (58.0, 36.0),
            (80.0, -4.0),
        ];
        let curve = |pts: &[(f64, f64)], z: f64| {
            CubicBSpline::new(pts.iter().map(|&(x, y)| Vector3::new(x, y, z)).collect())
        };
        SShape {
            lower: curve(&lower, 0.0),
            upper: curve(&upper, 35.0),
        }
    }

    /// The ruling at `u`: its lower and upper end.
    pub fn ruling(&self, u: f64) -> (Vector3<f64>, Vector3<f64>) {
        (self.lower.eval(u).0, self.upper.eval(u).0)
    }

    /// The unit normal of face A at the lower end of the ruling at `u` (the side the
    /// cross product of the directrix's tangent and the ruling points to).
    pub fn normal(&self, u: f64) -> Vector3<f64> {
        let (l, dl) = self.lower.eval(u);
        let up = self.upper.eval(u).0;
        dl.cross(&(up - l)).normalize()
    }
}

/// How the finishing program is made.
#[derive(Debug, Clone, PartialEq)]
pub struct Finishing {
    /// Name of the tool chain to use (`None`: the machine's first).
    pub tool_chain: Option<String>,
    /// Tool number (T and H word); its length comes from the machine file.
    pub tool: u32,
    /// Radius of the flat end mill (mm).
    pub tool_radius: f64,
    /// How far the end face goes below the bottom edge, along the tool axis (mm).
    pub below: f64,
    /// G1 blocks along the face per pass.
    pub segments: usize,
    /// Cutting feed (mm/min).
    pub feed: f64,
    /// Passes: the tool goes there and back, stepping `step_down` mm along its axis
    /// each time (one pass is the finishing cut).
    pub passes: usize,
    pub step_down: f64,
    /// Approach and retract distance along the tool axis (mm).
    pub clearance: f64,
}

impl Default for Finishing {
    fn default() -> Self {
        Finishing {
            tool_chain: None,
            tool: 1,
            tool_radius: 5.0,
            below: 2.0,
            segments: 200,
            feed: 1200.0,
            passes: 1,
            step_down: 1.0,
            clearance: 20.0,
        }
    }
}

/// The finishing program of face A of `shape` for `machine`.
pub fn finishing_program(
    machine: &Machine,
    shape: &SShape,
    f: &Finishing,
) -> Result<String, String> {
    let chain = match &f.tool_chain {
        None => 0,
        Some(name) => machine
            .tool_chain(name)
            .ok_or_else(|| format!("the machine has no tool chain `{name}`"))?,
    };
    let kin =
        Kinematics::new(machine, &ErrorModel::zero(machine), chain).map_err(|e| e.to_string())?;
    let n = kin.len();
    let rotary: Vec<usize> = (0..n)
        .filter(|&v| kin.kind(v) == AxisKind::Rotary)
        .collect();
    if n < 5 || rotary.len() < 2 {
        return Err(format!(
            "the S-shaped piece needs a five-axis machine (two rotary axes); this configuration has {n} axes, {} rotary",
            rotary.len()
        ));
    }
    let length = *machine.tool.lengths.get(&f.tool).ok_or_else(|| {
        format!(
            "tool {} has no length in the machine file's [tool] lengths",
            f.tool
        )
    })?;
    let options = SolveOptions::default();
    let pose_at = |u: f64, extra: f64| {
        let (l, up) = shape.ruling(u);
        let o = (up - l).normalize();
        Pose {
            p: l + shape.normal(u) * f.tool_radius - o * (f.below + extra),
            o,
        }
    };
    // The first pose from a grid of rotary starting values: the solution within the
    // travel limits with the smallest rotary values.
    let travel = |v: usize| machine.axes[kin.axes()[v]].travel;
    let within = |q: &[f64]| {
        (0..n).all(|v| travel(v).is_none_or(|[lo, hi]| (lo - 1e-9..=hi + 1e-9).contains(&q[v])))
    };
    let first_target = pose_at(0.0, 0.0);
    let mut best: Option<[f64; MAX_AXES]> = None;
    let grid: Vec<f64> = (-6..=6).map(|k| f64::from(k) * 30.0).collect();
    let combos = grid.len().pow(rotary.len() as u32);
    for c in 0..combos {
        let mut guess = [0.0; MAX_AXES];
        let mut rest = c;
        for &v in &rotary {
            guess[v] = grid[rest % grid.len()];
            rest /= grid.len();
        }
        if let Some(sol) = kin.inverse(Model::Nominal, &first_target, &guess[..n], length, &options)
            && within(sol.values())
        {
            let size = |q: &[f64; MAX_AXES]| rotary.iter().map(|&v| q[v].abs()).sum::<f64>();
            if best.is_none_or(|b| size(&sol.q) < size(&b) - 1e-9) {
                best = Some(sol.q);
            }
        }
    }
    let mut q = best.ok_or("no axis values within the travel reach the piece's first pose")?;
    let solve = |target: &Pose, q: &mut [f64; MAX_AXES]| -> Result<[f64; MAX_AXES], String> {
        let sol = kin
            .inverse(Model::Nominal, target, &q[..n], length, &options)
            .ok_or_else(|| {
                format!(
                    "the pose at tip {:.3}, {:.3}, {:.3} cannot be reached",
                    target.p.x, target.p.y, target.p.z
                )
            })?;
        if !within(sol.values()) {
            return Err(format!(
                "the pose at tip {:.3}, {:.3}, {:.3} needs axis values beyond the travel",
                target.p.x, target.p.y, target.p.z
            ));
        }
        *q = sol.q;
        Ok(sol.q)
    };
    let mut order: Vec<usize> = (0..n).collect();
    let letter = |v: usize| machine.axes[kin.axes()[v]].word.to_ascii_uppercase();
    order.sort_by_key(|&v| b"XYZUVWABC".iter().position(|&l| l as char == letter(v)));
    let words = |q: &[f64; MAX_AXES]| {
        let mut s = String::new();
        for &v in &order {
            let _ = write!(s, " {}{:.4}", letter(v), q[v] + 0.0);
        }
        s
    };
    let mut text = String::new();
    let mut number = 0;
    let mut block = |text: &mut String, body: &str| {
        number += 10;
        let _ = writeln!(text, "N{number} {body}");
    };
    // A comment ends at the first `)` and cannot hold a `(` (nor `;`, which starts one).
    let name: String = machine
        .name
        .as_deref()
        .unwrap_or("unnamed machine")
        .chars()
        .map(|c| match c {
            '(' | '[' => '[',
            ')' | ']' => ']',
            ';' => ',',
            c => c,
        })
        .collect();
    let _ = writeln!(
        text,
        "%\nO0003 (S-SHAPED TEST PIECE, FINISHING OF FACE A: PAPER 003)\n(MACHINE: {name})\n(RULED SURFACE BETWEEN TWO CUBIC B-SPLINE DIRECTRICES, Z0 AND Z35)\n(TOOL T{}: FLAT END MILL R{}, FLANK CUT ALONG THE RULINGS, END FACE {} MM BELOW THE EDGE)\n(MADE BY nccomp: cargo run --example s_shape)",
        f.tool, f.tool_radius, f.below
    );
    block(&mut text, "G21 G90 G94 G17");
    block(&mut text, &format!("T{} M6", f.tool));
    block(&mut text, &format!("G43 H{}", f.tool));
    let start = pose_at(0.0, 0.0);
    let above = Pose {
        p: start.p + start.o * f.clearance,
        o: start.o,
    };
    let qa = solve(&above, &mut q)?;
    block(&mut text, &format!("G0{}", words(&qa)));
    let q0 = solve(&start, &mut q)?;
    block(&mut text, &format!("G1{} F{:.0}", words(&q0), f.feed / 2.0));
    let mut fed = false;
    for pass in 0..f.passes.max(1) {
        let extra = f.step_down * pass as f64;
        if pass > 0 {
            let u = if pass % 2 == 1 { 1.0 } else { 0.0 };
            let qs = solve(&pose_at(u, extra), &mut q)?;
            block(&mut text, &format!("G1{}", words(&qs)));
        }
        for k in 1..=f.segments {
            let s = k as f64 / f.segments as f64;
            let u = if pass % 2 == 1 { 1.0 - s } else { s };
            let qk = solve(&pose_at(u, extra), &mut q)?;
            let feed = if fed {
                String::new()
            } else {
                fed = true;
                format!(" F{:.0}", f.feed)
            };
            block(&mut text, &format!("G1{}{feed}", words(&qk)));
        }
    }
    let end_u = if f.passes.max(1) % 2 == 1 { 1.0 } else { 0.0 };
    let end = pose_at(end_u, f.step_down * (f.passes.max(1) - 1) as f64);
    let away = Pose {
        p: end.p + end.o * f.clearance,
        o: end.o,
    };
    let qe = solve(&away, &mut q)?;
    block(&mut text, &format!("G0{}", words(&qe)));
    block(&mut text, "M30");
    text.push_str("%\n");
    Ok(text)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_spline_starts_and_ends_at_its_end_points() {
        let s = SShape::paper();
        let (a, _) = s.lower.eval(0.0);
        let (b, _) = s.lower.eval(1.0);
        assert!((a - Vector3::new(-75.0, -5.0, 0.0)).norm() < 1e-12);
        assert!((b - Vector3::new(75.0, 5.0, 0.0)).norm() < 1e-12);
    }

    #[test]
    fn the_derivative_is_the_slope() {
        let s = SShape::paper();
        for &u in &[0.0f64, 0.1, 0.249, 0.25, 0.5, 0.77, 1.0] {
            let h = 1e-6f64;
            let (lo, hi) = ((u - h).max(0.0), (u + h).min(1.0));
            let slope = (s.upper.eval(hi).0 - s.upper.eval(lo).0) / (hi - lo);
            let (_, d) = s.upper.eval(u);
            assert!(
                (slope - d).norm() < 1e-4 * d.norm(),
                "u = {u}: {slope} vs {d}"
            );
        }
    }

    #[test]
    fn rulings_lean_and_twist() {
        let s = SShape::paper();
        let lean = |u: f64| {
            let (l, up) = s.ruling(u);
            (up - l).normalize().z.acos().to_degrees()
        };
        for k in 0..=100 {
            let a = lean(f64::from(k) / 100.0);
            assert!((8.0..25.0).contains(&a), "lean {a}° at u = {k}/100");
        }
        // Not developable: the normal turns along the ruling, i.e. the tangent plane at
        // the top differs from the one at the bottom.
        let u = 0.3;
        let (l, up) = s.ruling(u);
        let top_normal = s.upper.eval(u).1.cross(&(up - l)).normalize();
        let twist = s.normal(u).dot(&top_normal).clamp(-1.0, 1.0).acos();
        assert!(twist > 1e-3, "{twist}");
    }
}
