//! The nearest place on the actual path for each reference point: paper 003's local
//! three-point search, generalised to a moving window over the polyline.
//!
//! The actual path is the trace's samples joined as the controller would move between
//! them: joint-linear, so a straight chord where only linear axes move and, where a rotary
//! axis turns, a curve. The curve is followed to second order: it bows off the chord as
//! the reference path does over the same progress (the actual path runs microns from the
//! reference, and the reference's poses are exact), so no pose is evaluated between
//! samples.
//!
//! The window. Consecutive reference points are `Δr` apart and the previous one was `d`
//! from the actual path; since distance to a set is 1-Lipschitz, the next nearest place
//! lies within `2·(d + Δr)` (chord) of the previous one. The search looks only that far
//! along the path on either side of the previous match (plus a margin `w`), so the work per
//! point is bounded and the whole search is O(n). Where the path doubles back on itself
//! the passes there and back lie within the window of each other; a sample interval that
//! runs against the reference's direction of travel (the reference tangent before or after
//! the point) is not taken, so a point on the way out is never matched to the way back.

use super::reference::{LEVER, RefPoint};
use crate::kinematics::{Kinematics, Model, angle_between};
use nalgebra::Vector3;
use rayon::prelude::*;

/// How the search looks.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SearchOptions {
    /// The margin added to the window on either side (mm).
    pub window: f64,
    /// How close (mm) the trace must come to the first point of a piece of reference
    /// path to be taken as following it, and the most a distance widens the window by.
    pub capture: f64,
    /// The measurement noise of a sample's tool tip (mm). Sample intervals up to twice
    /// this long are too short to have a direction and are never refused for running
    /// backwards.
    pub noise: f64,
}

impl Default for SearchOptions {
    fn default() -> Self {
        SearchOptions {
            window: 0.01,
            capture: 1.0,
            noise: 0.001,
        }
    }
}

/// The actual path in the workpiece frame.
#[derive(Debug, Clone)]
pub struct ActualPath<'a> {
    time: &'a [f64],
    p: Vec<Vector3<f64>>,
    o: Vec<Vector3<f64>>,
    /// Path length at each sample (chords).
    along: Vec<f64>,
}

/// Where a reference point meets the actual path.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Match {
    /// Sample interval and the parameter in it.
    pub segment: usize,
    pub t: f64,
    /// The nearest place on the actual path, the tool direction there, and the time.
    pub foot: Vector3<f64>,
    pub o: Vector3<f64>,
    pub time: f64,
    /// Tip distance (mm) and tool direction angle (rad) to the reference point.
    pub tip: f64,
    pub axis: f64,
    /// The nearest place is an end of the trace and further than the capture distance:
    /// the trace does not reach this point.
    pub beyond: bool,
}

impl<'a> ActualPath<'a> {
    /// The path of a trace with axis values `q` (`kin.len()` per sample) at times `time`,
    /// for a tool of length `length`.
    pub fn new(kin: &Kinematics, q: &[f64], time: &'a [f64], length: f64) -> Self {
        let n = kin.len();
        let (p, o): (Vec<Vector3<f64>>, Vec<Vector3<f64>>) = (0..time.len())
            .into_par_iter()
            .map(|i| {
                let (pose, _) = kin.pose(Model::Nominal, &q[i * n..(i + 1) * n], length);
                (pose.p, pose.o)
            })
            .unzip();
        let mut along = Vec::with_capacity(p.len());
        let mut total = 0.0f64;
        for (i, x) in p.iter().enumerate() {
            if i > 0 {
                total += (x - p[i - 1]).norm();
            }
            along.push(total);
        }
        ActualPath { time, p, o, along }
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.p.len()
    }

    pub fn is_empty(&self) -> bool {
        self.p.is_empty()
    }

    /// The tool tip at each sample.
    pub fn tips(&self) -> &[Vector3<f64>] {
        &self.p
    }

    fn segments(&self) -> usize {
        self.p.len().saturating_sub(1)
    }

    /// Nearest place on the chord of segment `k` to `r`: (parameter, distance²).
    #[inline]
    fn chord_foot(&self, k: usize, r: &Vector3<f64>) -> (f64, f64) {
        let a = &self.p[k];
        let ab = self.p[k + 1] - a;
        let ar = r - a;
        let len2 = ab.norm_squared();
        let t = if len2 > 0.0 {
            (ar.dot(&ab) / len2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        (t, (ar - ab * t).norm_squared())
    }

    /// The nearest place on segment `k` (as the machine moves along it) to `r`, starting
    /// from the chord's parameter `t`, for a path bending like the reference (`bend`):
    /// (parameter, place, direction). The parameter is the machine's (joint-linear) one.
    fn refine(
        &self,
        k: usize,
        t: f64,
        r: &Vector3<f64>,
        bend: Option<Bend>,
    ) -> (f64, Vector3<f64>, Vector3<f64>) {
        let (a, b) = (self.p[k], self.p[k + 1]);
        let (oa, ob) = (self.o[k], self.o[k + 1]);
        let ab = b - a;
        let Some(bend) = bend else {
            return (t, a + ab * t, (oa + (ob - oa) * t).normalize());
        };
        // The motion over the segment: c(t) = a + t·(b − a) + 4t(1 − t)·s, s the middle's
        // offset from the chord's middle, −(second difference)/8 scaled to this segment.
        let scale = progress(&ab, (ob - oa).norm()) / bend.step;
        let w2 = -scale * scale / 8.0;
        let (s, so) = (bend.tip * w2, bend.direction * w2);
        let mut t = t;
        for _ in 0..4 {
            let c = a + ab * t + s * (4.0 * t * (1.0 - t));
            let d1 = ab + s * (4.0 - 8.0 * t);
            let d2 = s * -8.0;
            let g = (c - r).dot(&d1);
            let h = d1.norm_squared() + (c - r).dot(&d2);
            if h <= 0.0 {
                break;
            }
            let next = (t - g / h).clamp(0.0, 1.0);
            let done = (next - t).abs() < 1e-12;
            t = next;
            if done {
                break;
            }
        }
        let w = 4.0 * t * (1.0 - t);
        let foot = a + ab * t + s * w;
        let o = (oa + (ob - oa) * t + so * w).normalize();
        (t, foot, o)
    }

    /// The segment at whose chord the path length `x` falls, searching from `k`.
    fn segment_at(&self, mut k: usize, x: f64) -> usize {
        let last = self.segments().saturating_sub(1);
        k = k.min(last);
        while k > 0 && self.along[k] > x {
            k -= 1;
        }
        while k < last && self.along[k + 1] < x {
            k += 1;
        }
        k
    }

    /// Match every reference point. `Err(i)`: the trace never comes within the capture
    /// distance of reference point `i`, the first of a piece of path.
    pub fn match_points(
        &self,
        refs: &[RefPoint],
        options: &SearchOptions,
    ) -> Result<Vec<Match>, usize> {
        let mut out = Vec::with_capacity(refs.len());
        let mut found: Vec<(usize, f64)> = Vec::with_capacity(refs.len());
        if self.segments() == 0 {
            return Err(0);
        }
        let mut k = 0usize;
        let mut here = 0.0;
        let mut d_prev = 0.0f64;
        for (i, r) in refs.iter().enumerate() {
            let (lo, hi, centre) = if r.first || i == 0 {
                let k0 = self
                    .capture(k, &r.p, options.capture, options.window.max(options.noise))
                    .ok_or(i)?;
                (self.along[k0], self.along[k0 + 1], k0)
            } else {
                let dr = (r.p - refs[i - 1].p).norm();
                let reach = 2.0 * (d_prev.min(options.capture) + dr) + options.window;
                (here - reach, here + reach, k)
            };
            // Tangents of the reference before and after the point.
            let before = (!r.first && i > 0).then(|| r.p - refs[i - 1].p);
            let after = refs
                .get(i + 1)
                .filter(|next| !next.first)
                .map(|next| next.p - r.p);
            let tiny = 1e-9;
            let tangents: [Option<Vector3<f64>>; 2] =
                [before, after].map(|t| t.filter(|t| t.norm() > tiny));
            // Both ends of a sample interval are off by up to `noise`, so noise alone turns
            // an interval that moves forward or not at all against the travel only if it is
            // at most twice the noise long. Where the machine stands (before the program's
            // start, after its end, at an exact stop) its samples scatter around one place
            // in intervals up to that long, pointing anywhere: refusing the ones that point
            // backwards would miss the nearest place in the scatter by up to the noise.
            let forward = |j: usize| {
                self.along[j + 1] - self.along[j] <= 2.0 * options.noise
                    || tangents.iter().all(Option::is_none)
                    || tangents
                        .iter()
                        .flatten()
                        .any(|t| t.dot(&(self.p[j + 1] - self.p[j])) > 0.0)
            };
            let start = self.segment_at(centre, lo);
            let mut best: Option<(usize, f64, f64)> = None;
            let mut any: Option<(usize, f64, f64)> = None;
            let mut j = start;
            while j < self.segments() && (j == start || self.along[j] <= hi) {
                let (t, d2) = self.chord_foot(j, &r.p);
                if any.is_none_or(|(_, _, b)| d2 < b) {
                    any = Some((j, t, d2));
                }
                if best.is_none_or(|(_, _, b)| d2 < b) && forward(j) {
                    best = Some((j, t, d2));
                }
                j += 1;
            }
            let (j, t, d2) = best.or(any).ok_or(i)?;
            found.push((j, t));
            k = j;
            here = self.along[j] + (self.along[j + 1] - self.along[j]) * t;
            d_prev = d2.sqrt();
        }
        // The nearest place on the machine's path near each chord's, independently.
        let segments = self.segments();
        refs.par_iter()
            .zip(found.par_iter())
            .enumerate()
            .map(|(i, (r, &(j, t)))| {
                let (t, foot, o) = self.refine(j, t, &r.p, bend(refs, i));
                let tip = (foot - r.p).norm();
                let beyond = tip > options.capture
                    && ((j == 0 && t == 0.0) || (j + 1 == segments && t == 1.0));
                Match {
                    segment: j,
                    t,
                    foot,
                    o,
                    time: self.time[j] + (self.time[j + 1] - self.time[j]) * t,
                    tip,
                    axis: angle_between(&o, &r.o),
                    beyond,
                }
            })
            .collect_into_vec(&mut out);
        Ok(out)
    }

    /// The first segment from `k` on whose chord comes within `capture` of `r`, then the
    /// nearest one after it, up to where the path leaves again (more than `margin` further
    /// than the nearest so far, or beyond `capture`).
    fn capture(&self, k: usize, r: &Vector3<f64>, capture: f64, margin: f64) -> Option<usize> {
        let first = (k..self.segments()).find(|&j| self.chord_foot(j, r).1 <= capture * capture)?;
        let mut best = (first, self.chord_foot(first, r).1.sqrt());
        for j in first + 1..self.segments() {
            let d = self.chord_foot(j, r).1.sqrt();
            if d > capture || d > best.1 + margin {
                break;
            }
            if d < best.1 {
                best = (j, d);
            }
        }
        Some(best.0)
    }
}

/// How the reference path bends at point `i`, from three consecutive points of one move
/// (which are equal steps of the move's parameter apart): the second differences of the
/// tool tip and of the tool direction over one step, and the step's size as
/// [`progress`] measures it. `None` where the move has fewer than three points.
///
/// The actual path runs microns from the reference and the machine moves joint-linearly
/// along both, so between two trace samples the actual path bows off its chord as the
/// reference does over the same progress (the reference's poses are exact).
pub fn bend(refs: &[RefPoint], i: usize) -> Option<Bend> {
    // j + 1 follows j along the path (in j's block, or in the next when j ends its own).
    let same = |j: usize| refs.get(j + 1).is_some_and(|next| !next.first);
    let triple = |j: usize| {
        j >= 1
            && j + 1 < refs.len()
            && same(j - 1)
            && same(j)
            && refs[j + 1].offset == refs[j].offset
    };
    let j = [i, i.wrapping_sub(1), i + 1]
        .into_iter()
        .find(|&j| j < refs.len() && triple(j))?;
    let (a, b, c) = (&refs[j - 1], &refs[j], &refs[j + 1]);
    let step = 0.5 * progress(&(c.p - a.p), (c.o - a.o).norm());
    (step > 0.0).then(|| Bend {
        tip: c.p - b.p * 2.0 + a.p,
        direction: c.o - b.o * 2.0 + a.o,
        step,
    })
}

/// See [`bend`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bend {
    pub tip: Vector3<f64>,
    pub direction: Vector3<f64>,
    pub step: f64,
}

/// How far the machine gets over a tip chord and a turn of the tool (rad, or the chord
/// between the unit directions): a length that grows with either, so that a move that only
/// turns the tool has one too.
pub fn progress(chord: &Vector3<f64>, turn: f64) -> f64 {
    (chord.norm_squared() + (LEVER * turn).powi(2)).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{ErrorModel, machine_file};

    /// Out along X 15 µm to one side, a step across, and back 5 µm to that side: at every
    /// place passed twice the passes are 10 µm apart and well within the window.
    #[test]
    fn a_point_on_the_way_out_is_never_matched_on_the_way_back() {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/fixtures/ac_trunnion.machine.toml"
        );
        let machine = machine_file::load(std::path::Path::new(path)).unwrap();
        let kin = Kinematics::new(&machine, &ErrorModel::zero(&machine), 0).unwrap();
        let length = machine.tool.length;
        let xs: Vec<f64> = (0..=250).map(|i| f64::from(i) * 0.004).collect();
        let mut q = Vec::new();
        for &x in &xs {
            q.extend_from_slice(&[x, 0.015, 0.0, 0.0, 0.0]);
        }
        for &x in xs.iter().rev() {
            q.extend_from_slice(&[x, 0.005, 0.0, 0.0, 0.0]);
        }
        let time: Vec<f64> = (0..q.len() / 5).map(|i| i as f64 * 1e-3).collect();
        let actual = ActualPath::new(&kin, &q, &time, length);
        let point = |x: f64, first: bool| {
            let (pose, _) = kin.pose(Model::Nominal, &[x, 0.0, 0.0, 0.0, 0.0], length);
            RefPoint {
                line: 1,
                offset: 0,
                s: 0.0,
                along: 0.0,
                p: pose.p,
                o: pose.o,
                rapid: false,
                first,
            }
        };
        let mut refs: Vec<RefPoint> = xs.iter().map(|&x| point(x, x == 0.0)).collect();
        refs.extend(xs.iter().rev().skip(1).map(|&x| point(x, false)));
        let options = SearchOptions {
            window: 0.008,
            capture: 1.0,
            noise: 0.001,
        };
        let matches = actual.match_points(&refs, &options).unwrap();
        for (i, m) in matches.iter().enumerate() {
            // The turn itself (the last point out) is on both passes: the nearer counts.
            let expected = if i < xs.len() - 1 { 0.015 } else { 0.005 };
            assert!(
                (m.tip - expected).abs() < 1e-9,
                "point {i}: {} mm, expected {expected}",
                m.tip
            );
        }
        // Without the direction test the window alone would take the way back near the turn.
        let blind = SearchOptions {
            noise: 1.0,
            ..options
        };
        let matches = actual.match_points(&refs, &blind).unwrap();
        assert!(matches[xs.len() - 3].tip < 0.01);
    }
}
