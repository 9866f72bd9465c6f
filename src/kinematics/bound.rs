//! A bound on how far a compensated move can stray from its nominal move between its ends,
//! from the move's size and the error model's size alone: no pose.
//!
//! The deviation along a move is f(s) = p_real(c(s)) − p_nom(q(s)), s ∈ [0, 1], with q and
//! c the nominal and compensated axis values interpolated linearly. Where f is twice
//! differentiable with |f''| ≤ M on [0, 1], f stays within M/8 of the chord between f(0)
//! and f(1); a kink where f' jumps by J adds at most J/4. So
//! |f(s)| ≤ max(|f(0)|, |f(1)|) + M/8 + ΣJ/4.
//!
//! Write f = [p_nom(c) − p_nom(q)] + [p_real(c) − p_nom(c)]. The first is the nominal
//! machine moved by the correction Δ = c − q (linear in s): through the segment from q to c
//! it is ∫ Dp_nom(q + tΔ)·Δ dt, whose second derivative along s takes the third and second
//! derivatives of the nominal chain. The second is the error field at the real axis values:
//! scaling every error by μ from 0 to 1 at the same values c(s), it is the integral of the
//! errors' first-order effect, a sum of small twists (angles A, lengths D, their rates A',
//! D' along the move) carried by the chain. Both are derivatives of chains of rigid motions
//! along a line of axis values, and such a chain obeys, for directions a, b with rotary
//! rates Ω (rad, table slopes of angle included) and linear rates V (mm, table slopes of
//! length included), and ρ a bound on the tip's distance from every rotation centre in
//! every frame: |D²p[a, b]| ≤ Ω_aΩ_bρ + Ω_aV_b + Ω_bV_a and |D³p[a, a, b]| ≤
//! Ω_a²(Ω_bρ + V_b) + 2Ω_aΩ_bV_a (each derivative of a rotation factor is its rate times a
//! map of norm ≤ 1; a translation factor has no second derivative). The error field adds
//! A(4Ω²ρ + 4ΩV) + DΩ² + A'(4Ωρ + 2V) + 2ΩD'. Tables are linear between their positions,
//! so the error field is smooth except where an axis's real value crosses a position of its
//! table: there its twist's rate jumps, by at most twice the table's largest slope times
//! the axis's rate (times ρ for angles). The tool direction, a free vector, obeys the same
//! with ρ = 1 and no lengths. What is of second order in the errors (a rotation's
//! exponential against its first order, axes tilted by microradians) is covered by a 10 %
//! margin. `tests/path_bound.rs` holds the bound against the deviation sampled densely on
//! every fixture machine with random error models.

use super::chain::Joint;
use super::{Kinematics, angle_between};
use crate::model::{AxisKind, IndexedTable};

/// What the bound needs of one joint of the real machine.
#[derive(Debug, Clone)]
struct JointBound {
    var: usize,
    rotary: bool,
    /// Largest slope of the error table's angles (rad) and lengths (mm), per mm of a
    /// linear axis or per radian of a rotary one.
    slope_angle: f64,
    slope_length: f64,
    /// Linear: the angle between the direction with squareness and without.
    squareness: f64,
    /// The error table, to tell where it is affine.
    table: Option<IndexedTable>,
    table_offset: f64,
    shift: f64,
}

/// The error model's size as the bound uses it (see the module's documentation).
#[derive(Debug, Clone)]
pub(super) struct PathBound {
    joints: Vec<JointBound>,
    /// A and D: the errors' angles (rad) and lengths (mm) summed over the machine.
    angles: f64,
    lengths: f64,
    /// ρ without the tip and the linear axes' values: what the rotary joints, the tables
    /// and the reference points add to any point's distance from a rotation centre.
    reach: f64,
}

/// Largest norm of a table's angles and lengths, and of their slopes per unit of the
/// table's position.
fn table_sizes(joint: &Joint) -> (f64, f64, f64, f64) {
    let Some(table) = &joint.motion else {
        return (0.0, 0.0, 0.0, 0.0);
    };
    let p = &table.positions;
    let value = |c: usize, i: usize| table.values[c].as_ref().map_or(0.0, |v| v[i]);
    let norm = |i: usize, from: usize| {
        (0..3)
            .map(|c| value(from + c, i).powi(2))
            .sum::<f64>()
            .sqrt()
    };
    let (mut length, mut angle) = (0.0f64, 0.0f64);
    for i in 0..p.len() {
        length = length.max(norm(i, 0));
        angle = angle.max(norm(i, 3));
    }
    let mut segments: Vec<(usize, usize, f64)> =
        (1..p.len()).map(|j| (j - 1, j, p[j] - p[j - 1])).collect();
    if table.periodic && p.len() > 1 {
        segments.push((p.len() - 1, 0, p[0] + 360.0 - p[p.len() - 1]));
    }
    let (mut slope_length, mut slope_angle) = (0.0f64, 0.0f64);
    for (i, j, span) in segments {
        if span <= 0.0 {
            continue;
        }
        let slope = |from: usize| {
            (0..3)
                .map(|c| ((value(from + c, j) - value(from + c, i)) / span).powi(2))
                .sum::<f64>()
                .sqrt()
        };
        slope_length = slope_length.max(slope(0));
        slope_angle = slope_angle.max(slope(3));
    }
    (length, angle, slope_length, slope_angle)
}

impl PathBound {
    /// The bound's constants for the real chains `actual` against the nominal `nominal`
    /// (the same joints in the same order).
    pub(super) fn new<'a>(
        actual: impl Iterator<Item = &'a Joint>,
        nominal: impl Iterator<Item = &'a Joint>,
    ) -> PathBound {
        let per_radian = 180.0 / std::f64::consts::PI;
        let mut bound = PathBound {
            joints: Vec::new(),
            angles: 0.0,
            lengths: 0.0,
            reach: 0.0,
        };
        let mut farthest_point = 0.0f64;
        for (real, nom) in actual.zip(nominal) {
            let rotary = real.kind == AxisKind::Rotary;
            let (length, angle, mut slope_length, mut slope_angle) = table_sizes(real);
            if rotary {
                slope_length *= per_radian;
                slope_angle *= per_radian;
            }
            bound.angles += angle;
            bound.lengths += length;
            let tilt = angle_between(&real.dir, &nom.dir);
            farthest_point = farthest_point.max(real.point.norm()).max(nom.point.norm());
            if rotary {
                // Rot(ã, θ) = Q·Rot(a, θ)·Qᵀ: two twists of the tilt; a shifted centre, two
                // translations; the zero error, a turn about the axis.
                let (s0, c0) = real.zero;
                bound.angles += 2.0 * tilt + s0.atan2(c0).abs();
                bound.lengths += 2.0 * (real.point - nom.point).norm();
                bound.reach += 2.0 * real.point.norm().max(nom.point.norm()) + length;
            } else {
                bound.reach += length + angle * real.point.norm();
            }
            bound.joints.push(JointBound {
                var: real.var,
                rotary,
                slope_angle,
                slope_length,
                squareness: if rotary { 0.0 } else { tilt },
                table: real.motion.as_ref().map(IndexedTable::new),
                table_offset: real.table_offset,
                shift: real.shift,
            });
        }
        bound.reach += farthest_point;
        bound
    }

    /// The same constants for kinematics whose linear joints are shifted by `shift`.
    pub(super) fn shifted(&self, shift: &[f64]) -> PathBound {
        let mut bound = self.clone();
        for j in bound.joints.iter_mut().filter(|j| !j.rotary) {
            j.shift = shift.get(j.var).copied().unwrap_or(0.0);
        }
        bound
    }
}

/// The sags a move can add to its end deviations: position (mm) and tool direction (the
/// chord between directions; an angle below 0.1 rad exceeds its chord by under 0.1 %).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sag {
    pub position: f64,
    pub direction: f64,
}

impl Kinematics {
    /// A bound on how much further than its ends the move from nominal `qa` → `qb`,
    /// executed as `ca` → `cb` on the real machine, can stray between them (see the
    /// module's documentation); `None` where no bound is given (turning kinematics, a move
    /// of a turn or more on a rotary axis with a table).
    pub fn path_sag(
        &self,
        (qa, qb): (&[f64], &[f64]),
        (ca, cb): (&[f64], &[f64]),
        length: f64,
    ) -> Option<Sag> {
        if self.turning.is_some() {
            return None;
        }
        let bound = &self.bound;
        let to_rad = std::f64::consts::PI / 180.0;
        // Rates along the move of the compensated values (the largest of any λ), of the
        // correction Δ and of its change w; Ω in radians, V in mm.
        let (mut om_c, mut v_c, mut om_d, mut v_d, mut om_w, mut v_w) =
            (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
        // A', D' and the lengths that grow with a linear axis's value (squareness).
        let (mut rate_angles, mut rate_lengths, mut square_lengths) = (0.0, 0.0, 0.0);
        // The jumps of the error field's rate where an axis crosses a table position: their
        // rates in angle and in length, summed (ρ is known only after the loop).
        let (mut kink_angles, mut kink_lengths) = (0.0, 0.0);
        let mut reach = bound.reach + self.tip(length).norm();
        for j in &bound.joints {
            let k = j.var;
            let scale = if j.rotary { to_rad } else { 1.0 };
            let u = (qb[k] - qa[k]) * scale;
            let (da, db) = ((ca[k] - qa[k]) * scale, (cb[k] - qb[k]) * scale);
            let w = (db - da).abs();
            let rate = u.abs() + w;
            let delta = da.abs().max(db.abs());
            // A joint's rates: its own motion and its table's slopes.
            let (rot, lin) = if j.rotary {
                (1.0 + j.slope_angle, j.slope_length)
            } else {
                (j.slope_angle, 1.0 + j.slope_length)
            };
            om_c += rate * rot;
            v_c += rate * lin;
            om_d += delta * rot;
            v_d += delta * lin;
            om_w += w * rot;
            v_w += w * lin;
            rate_angles += rate * j.slope_angle;
            rate_lengths += rate * (j.slope_length + j.squareness);
            let values = [qa[k], qb[k], ca[k], cb[k]];
            if !j.rotary {
                let far = values
                    .iter()
                    .map(|x| (x + j.shift).abs())
                    .fold(0.0f64, f64::max);
                reach += far;
                square_lengths += far * j.squareness;
            }
            if let Some(table) = &j.table {
                // Only the real machine reads the tables, at the compensated values.
                let at = |x: f64| x + j.shift + j.table_offset;
                let (lo, hi) = (ca[k].min(cb[k]), ca[k].max(cb[k]));
                let kinks = table.kinks_within(at(lo), at(hi))? as f64;
                let real_rate = (cb[k] - ca[k]).abs() * scale;
                kink_angles += kinks * 2.0 * j.slope_angle * real_rate;
                kink_lengths += kinks * 2.0 * j.slope_length * real_rate;
            }
        }
        let rho = reach;
        let (a, d) = (bound.angles, bound.lengths + square_lengths);
        let position = om_c * om_c * (om_d * rho + v_d)
            + 2.0 * om_c * om_d * v_c
            + 2.0 * (om_c * om_w * rho + om_c * v_w + om_w * v_c)
            + a * (4.0 * om_c * om_c * rho + 4.0 * om_c * v_c)
            + d * om_c * om_c
            + rate_angles * (4.0 * om_c * rho + 2.0 * v_c)
            + 2.0 * om_c * rate_lengths;
        let direction = om_c * om_c * om_d
            + 2.0 * om_c * om_w
            + 4.0 * a * om_c * om_c
            + 4.0 * rate_angles * om_c;
        let margin = 1.1;
        let sag = Sag {
            position: margin * (position / 8.0 + (kink_angles * rho + kink_lengths) / 4.0),
            direction: margin * (direction / 8.0 + kink_angles / 4.0),
        };
        (sag.position.is_finite() && sag.direction.is_finite()).then_some(sag)
    }
}
