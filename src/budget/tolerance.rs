//! Tolerance design (paper 002, section 4): the cost–quality model solved for the
//! tolerances of the key errors within bounds.
//!
//! - **Quality loss.** The error along the direction, y, is smaller-the-better, with the
//!   loss `L = K·y²` (K: a cost per mm², from the budget file as Taguchi's `A/Δ²`: the
//!   cost `A` of a part whose error is `Δ`). Over the workspace, L is the mean over the
//!   poses. A second-order response surface of L in the key errors is fitted by least
//!   squares to a maximin Latin hypercube sample (the paper's "optimal Latin hypercube";
//!   each error within ±3σ of its widest tolerance), with R² and adjusted R² (table 8).
//! - **T = 6σ.** Each error is normal with mean 0 and σ = T/6, independent of the others,
//!   so the expected loss is `Cq(T) = a0 + Σ d_i (T_i/6)²` (eq. 8): the linear and cross
//!   terms of the surface drop out.
//! - **Manufacturing cost** `Cm(T) = Σ C_i(T_i)` (eq. 10) with the paper's cost–tolerance
//!   curves of a plane feature and of a positioning feature (T in mm). An angular tolerance
//!   enters its curve as the length it spans over a reference length (the paper's
//!   `0.04/1000`: 40 µrad is 0.04 mm over 1000 mm).
//! - **Use cost** `Cu = λ·Cq` (eq. 9) and the objective `QC = W·Cq + (1 − W)(Cm + Cu)`
//!   (W = 0.7, λ = 1 in the paper), minimised within bounds (eq. 11).
//!
//! The optimizer is a cyclic coordinate search: for each tolerance in turn, the objective
//! is scanned on 200 steps between its bounds and the best step refined by golden-section
//! search; cycles repeat until a cycle no longer improves. It needs no gradient and copes
//! with the kinks of the cost curves. Under the model's assumptions (zero means,
//! independent errors) the objective is a sum of one function per tolerance, so one cycle
//! reaches the global minimum on the scan's resolution; the cycles are there for
//! objectives that are not.

use super::Probe;
use super::sampling::{Rng, maximin_latin_hypercube};
use nalgebra::{DMatrix, DVector, Vector3};
use serde::Serialize;

/// The paper's cost–tolerance curves (its ref. 16), tolerance T in mm, relative cost.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum CostCurve {
    /// Plane features (guideway straightness and parallelism):
    /// `5.0261·e^(−15.8903·T) + T/(0.3927·T + 0.1176)` up to 0.165 mm, 1.273338 beyond.
    Plane,
    /// Positioning features (ball-screw lead):
    /// `13.3114·T·e^(0.0438/T) + 7.6593·e^(−25.1731·T)` up to 0.11 mm, 1.463467 beyond.
    Positioning,
}

impl CostCurve {
    /// The cost of a tolerance of `t` mm (infinite where the curve is: T ≤ 0 for
    /// positioning).
    // 0.3927 is the paper's coefficient, not π/8.
    #[allow(clippy::approx_constant)]
    pub fn cost(self, t: f64) -> f64 {
        match self {
            CostCurve::Plane if t <= 0.165 => {
                5.0261 * (-15.8903 * t).exp() + t / (0.3927 * t + 0.1176)
            }
            CostCurve::Plane => 1.273338,
            CostCurve::Positioning if t <= 0.0 => f64::INFINITY,
            CostCurve::Positioning if t <= 0.11 => {
                13.3114 * t * (0.0438 / t).exp() + 7.6593 * (-25.1731 * t).exp()
            }
            CostCurve::Positioning => 1.463467,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            CostCurve::Plane => "plane",
            CostCurve::Positioning => "positioning",
        }
    }
}

/// A key error whose tolerance is designed. Values in model units (mm, rad).
#[derive(Debug, Clone, PartialEq)]
pub struct TolTerm {
    pub lower: f64,
    pub upper: f64,
    /// Where the optimizer starts (the middle of the bounds unless the file says).
    pub start: f64,
    pub curve: CostCurve,
    /// mm of the cost curve per model unit: 1 for lengths, the reference length (mm) for
    /// angles.
    pub length: f64,
}

/// The model's constants.
#[derive(Debug, Clone, PartialEq)]
pub struct ToleranceOptions {
    pub direction: Vector3<f64>,
    /// W.
    pub weight: f64,
    /// λ.
    pub lambda: f64,
    /// K, cost per mm² of error along the direction.
    pub loss: f64,
    /// Response-surface samples; 0: three per coefficient.
    pub samples: usize,
    pub seed: u64,
}

/// The second-order response surface of the quality loss, in model units.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ResponseSurface {
    pub a0: f64,
    pub b: Vec<f64>,
    /// c[i][j] for i < j (zero elsewhere).
    pub c: Vec<Vec<f64>>,
    pub d: Vec<f64>,
    pub r2: f64,
    pub r2_adjusted: f64,
    pub samples: usize,
    pub coefficients: usize,
}

impl ResponseSurface {
    /// Fit L = K·mean over poses of y² with each term within ±half[i].
    pub fn fit(
        probe: &Probe,
        half: &[f64],
        direction: &Vector3<f64>,
        loss: f64,
        samples: usize,
        seed: u64,
    ) -> Self {
        let k = half.len();
        let m = (k + 1) * (k + 2) / 2;
        let n = if samples == 0 {
            3 * m
        } else {
            samples.max(m + 1)
        };
        let mut rng = Rng::new(seed);
        let design = maximin_latin_hypercube(n, k, 20, &mut rng);
        let np = probe.poses.len();
        let mut x = DMatrix::zeros(n, m);
        let mut target = DVector::zeros(n);
        let mut y = vec![0.0; np];
        let mut values = vec![0.0; k];
        for (r, point) in design.iter().enumerate() {
            let z: Vec<f64> = point.iter().map(|u| 2.0 * u - 1.0).collect();
            for i in 0..k {
                values[i] = z[i] * half[i];
            }
            probe.along(&values, direction, &mut y);
            target[r] = loss * y.iter().map(|v| v * v).sum::<f64>() / np as f64;
            for (col, f) in basis(&z).into_iter().enumerate() {
                x[(r, col)] = f;
            }
        }
        // Scale the target so the solve is well conditioned whatever K is.
        let scale = target.amax().max(f64::MIN_POSITIVE);
        let svd = x.clone().svd(true, true);
        let beta = svd
            .solve(&(&target / scale), 1e-12)
            .expect("the SVD was computed with U and V")
            * scale;
        let fitted = &x * &beta;
        let mean = target.mean();
        let sse: f64 = (&target - &fitted).norm_squared();
        let sst: f64 = target.iter().map(|t| (t - mean).powi(2)).sum();
        let r2 = if sst > 0.0 { 1.0 - sse / sst } else { 1.0 };
        let p = (m - 1) as f64;
        let r2_adjusted = 1.0 - (1.0 - r2) * (n as f64 - 1.0) / (n as f64 - p - 1.0);
        // Back from the scaled variables z = v / half.
        let mut b = vec![0.0; k];
        let mut c = vec![vec![0.0; k]; k];
        let mut d = vec![0.0; k];
        let mut col = 1;
        for i in 0..k {
            b[i] = beta[col] / half[i];
            col += 1;
        }
        for i in 0..k {
            for j in i + 1..k {
                c[i][j] = beta[col] / (half[i] * half[j]);
                col += 1;
            }
        }
        for i in 0..k {
            d[i] = beta[col] / (half[i] * half[i]);
            col += 1;
        }
        ResponseSurface {
            a0: beta[0],
            b,
            c,
            d,
            r2,
            r2_adjusted,
            samples: n,
            coefficients: m,
        }
    }

    /// The expected loss for zero-mean independent errors with standard deviations σ_i
    /// (eq. 6 with μ = 0): `a0 + Σ d_i σ_i²`.
    pub fn expected(&self, sigma: &[f64]) -> f64 {
        self.a0
            + self
                .d
                .iter()
                .zip(sigma)
                .map(|(d, s)| d * s * s)
                .sum::<f64>()
    }
}

/// 1, z_i, z_i z_j (i < j), z_i².
fn basis(z: &[f64]) -> Vec<f64> {
    let k = z.len();
    let mut f = Vec::with_capacity((k + 1) * (k + 2) / 2);
    f.push(1.0);
    f.extend_from_slice(z);
    for i in 0..k {
        for j in i + 1..k {
            f.push(z[i] * z[j]);
        }
    }
    f.extend(z.iter().map(|v| v * v));
    f
}

/// The parts of the objective at a set of tolerances.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Objective {
    /// Quality level, the expected quality loss (eq. 8).
    pub cq: f64,
    /// Manufacturing cost (eq. 10).
    pub cm: f64,
    /// Use cost λ·Cq (eq. 9).
    pub cu: f64,
    /// W·Cq + (1 − W)(Cm + Cu).
    pub qc: f64,
}

/// One designed tolerance.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ToleranceRow {
    pub term: String,
    /// The unit of bounds, start and tolerance: `mm` or `rad`.
    pub unit: &'static str,
    pub curve: CostCurve,
    /// mm per model unit in the cost curve (1, or the reference length for angles).
    pub length: f64,
    pub lower: f64,
    pub upper: f64,
    pub start: f64,
    pub tolerance: f64,
    /// C_i at start and at the design.
    pub cost_start: f64,
    pub cost: f64,
    /// d_i (T_i/6)²: this term's part of Cq at the design.
    pub quality: f64,
    /// The response-surface coefficient d_i (cost per model unit²).
    pub d: f64,
    /// `lower`, `upper` or `inside`.
    pub at: &'static str,
}

/// The result of the tolerance design.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Design {
    pub weight: f64,
    pub lambda: f64,
    pub loss: f64,
    pub direction: [f64; 3],
    pub rows: Vec<ToleranceRow>,
    pub start: Objective,
    pub optimum: Objective,
    pub surface: ResponseSurface,
    pub cycles: usize,
    pub evaluations: usize,
}

/// Design the tolerances of the probe's terms (parallel to `terms`).
pub fn design(probe: &Probe, terms: &[TolTerm], options: &ToleranceOptions) -> Design {
    let direction = options.direction.normalize();
    let half: Vec<f64> = terms.iter().map(|t| t.upper / 2.0).collect();
    let surface = ResponseSurface::fit(
        probe,
        &half,
        &direction,
        options.loss,
        options.samples,
        options.seed,
    );
    let (w, lambda) = (options.weight, options.lambda);
    let parts = |t: &[f64]| {
        let sigma: Vec<f64> = t.iter().map(|v| v / 6.0).collect();
        let cq = surface.expected(&sigma);
        let cm: f64 = terms
            .iter()
            .zip(t)
            .map(|(term, v)| term.curve.cost(v * term.length))
            .sum();
        let cu = lambda * cq;
        Objective {
            cq,
            cm,
            cu,
            qc: w * cq + (1.0 - w) * (cm + cu),
        }
    };
    let start: Vec<f64> = terms.iter().map(|t| t.start).collect();
    let mut evaluations = 0;
    let mut objective = |t: &[f64]| {
        evaluations += 1;
        let q = parts(t).qc;
        if q.is_nan() { f64::INFINITY } else { q }
    };
    let mut t = start.clone();
    let mut best = objective(&t);
    let mut cycles = 0;
    while cycles < 50 {
        cycles += 1;
        let before = best;
        for i in 0..t.len() {
            let (lo, hi) = (terms[i].lower, terms[i].upper);
            let mut trial = t.clone();
            let mut g = |v: f64| {
                trial[i] = v;
                objective(&trial)
            };
            let (v, q) = minimize_1d(&mut g, lo, hi);
            if q < best {
                t[i] = v;
                best = q;
            }
        }
        let improved = best < before - 1e-12 * before.abs().max(1e-300);
        if !improved {
            break;
        }
    }
    let rows = terms
        .iter()
        .zip(&t)
        .enumerate()
        .map(|(i, (term, &v))| {
            let span = term.upper - term.lower;
            let at = if v <= term.lower + 1e-9 * span {
                "lower"
            } else if v >= term.upper - 1e-9 * span {
                "upper"
            } else {
                "inside"
            };
            ToleranceRow {
                term: probe.terms[i].name.clone(),
                unit: probe.terms[i].model_unit(),
                curve: term.curve,
                length: term.length,
                lower: term.lower,
                upper: term.upper,
                start: term.start,
                tolerance: v,
                cost_start: term.curve.cost(term.start * term.length),
                cost: term.curve.cost(v * term.length),
                quality: surface.d[i] * (v / 6.0).powi(2),
                d: surface.d[i],
                at,
            }
        })
        .collect();
    Design {
        weight: w,
        lambda,
        loss: options.loss,
        direction: [direction.x, direction.y, direction.z],
        rows,
        start: parts(&start),
        optimum: parts(&t),
        surface,
        cycles,
        evaluations,
    }
}

/// The minimum of `g` on [lo, hi]: a scan on 200 steps, the best step refined by golden
/// section between its neighbours.
fn minimize_1d(g: &mut dyn FnMut(f64) -> f64, lo: f64, hi: f64) -> (f64, f64) {
    const STEPS: usize = 200;
    let at = |j: usize| lo + (hi - lo) * j as f64 / STEPS as f64;
    let mut best = (lo, f64::INFINITY);
    let mut best_j = 0;
    for j in 0..=STEPS {
        let v = at(j);
        let q = g(v);
        if q < best.1 {
            best = (v, q);
            best_j = j;
        }
    }
    let (mut a, mut b) = (at(best_j.saturating_sub(1)), at((best_j + 1).min(STEPS)));
    let phi = (5f64.sqrt() - 1.0) / 2.0;
    let mut x1 = b - phi * (b - a);
    let mut x2 = a + phi * (b - a);
    let (mut f1, mut f2) = (g(x1), g(x2));
    for _ in 0..100 {
        if b - a <= 1e-12 * (hi - lo).abs().max(f64::MIN_POSITIVE) {
            break;
        }
        if f1 <= f2 {
            b = x2;
            x2 = x1;
            f2 = f1;
            x1 = b - phi * (b - a);
            f1 = g(x1);
        } else {
            a = x1;
            x1 = x2;
            f1 = f2;
            x2 = a + phi * (b - a);
            f2 = g(x2);
        }
    }
    for (v, q) in [(x1, f1), (x2, f2)] {
        if q < best.1 {
            best = (v, q);
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cost_curves_are_the_papers() {
        // Continuous (to the paper's digits) where they switch to the constant.
        assert!((CostCurve::Plane.cost(0.165) - 1.273338).abs() < 5e-3);
        assert!((CostCurve::Plane.cost(0.0) - 5.0261).abs() < 1e-12);
        assert!(CostCurve::Positioning.cost(0.0).is_infinite());
        // Tighter is dearer over the paper's bounds.
        for curve in [CostCurve::Plane, CostCurve::Positioning] {
            let mut last = f64::INFINITY;
            for j in 1..=40 {
                let c = curve.cost(0.001 * j as f64);
                assert!(c < last, "{curve:?} at {}", 0.001 * j as f64);
                last = c;
            }
        }
    }

    #[test]
    fn golden_section_finds_an_interior_minimum_and_a_bound() {
        let (v, q) = minimize_1d(&mut |x| (x - 0.3).powi(2) + 1.0, 0.0, 1.0);
        assert!((v - 0.3).abs() < 1e-7 && (q - 1.0).abs() < 1e-12);
        let (v, _) = minimize_1d(&mut |x| -x, 0.0, 2.0);
        assert_eq!(v, 2.0);
    }
}
