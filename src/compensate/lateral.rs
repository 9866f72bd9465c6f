//! A bound on what a cycle's motion around the hole's axis adds to the error left on the
//! axis: the error field's change over the cycle's radius.
//!
//! A cycle that mills around its axis (bore milling, thread milling, a pocket) is
//! compensated by its centre, axis and depth: the control then moves the tool by offsets
//! `d` in the plane of the hole (the machine's X, Y, or the tilted plane's) about the
//! written centre, and the real tool at an offset is off its nominal place by
//! D(s, d) = p_real(c(s) + Δq(d)) − p_nom(q(s) + Δq(d)), with q(s), c(s) the nominal and
//! written axis values on the axis at depth s and Δq(d) the axis values an offset takes
//! (the controller's linear map, the rotary axes standing). On the axis (d = 0) that is
//! what the axis's own check holds (`Pass::hole_axis_as_written`); around it the motion
//! adds L(s, d) = D(s, d) − D(s, 0), the change of the error field over the offset.
//!
//! L is evaluated with the kinematics at the corners of a grid of cells that covers the
//! cylinder of the cycle's radius between its set-up clearance and its deepest point. Any
//! point of a cell lies on a segment along the cell's first side between two points on
//! segments along its second side, and those on segments along the axis between the
//! cell's levels; along each straight segment D stays within `Kinematics::path_sag` of the
//! chord between its ends (the bound the path check rests on), and so does D on the axis
//! between two levels. A sag for each cell dominates every straight segment within it: it
//! is the sag of a move whose every axis spans the cell's whole range (widened by the
//! correction) and whose correction changes as much as between the cell's levels. So
//! |L| ≤ max over a cell's corners + 3 × the cell's sag + the axis's sag between its
//! levels, over every cell. `tests/cycles.rs` holds the bound against L sampled densely.

use super::Pass;
use crate::kinematics::{MAX_AXES, Model};

/// The cylinder a cycle's motion stays in: its axis from its deepest point (index 0) to
/// its set-up clearance (index 1), nominal and as the control is told, and the axis values
/// a unit offset along the plane's X and Y takes.
#[derive(Debug, Clone)]
pub(super) struct Cylinder {
    pub nominal: [[f64; MAX_AXES]; 2],
    pub written: [[f64; MAX_AXES]; 2],
    pub along: [[f64; MAX_AXES]; 2],
    /// Its radius (mm).
    pub radius: f64,
}

/// At most this many pose evaluations for one bound (the grid is refined while the bound
/// exceeds the tolerance and this allows).
const MAX_EVALUATIONS: usize = 400_000;

impl Pass<'_> {
    /// A bound (mm) on |L| over `cyl` (see the module's documentation), refined until it is
    /// within `enough` or the grid is as fine as is allowed; `None` where the kinematics
    /// give no bound (see `Kinematics::path_sag`).
    pub(super) fn lateral_bound(&self, cyl: &Cylinder, length: f64, enough: f64) -> Option<f64> {
        let mut cells = 6usize;
        let mut best = f64::INFINITY;
        loop {
            let bound = self.lateral_bound_on(cyl, length, cells)?;
            best = best.min(bound);
            let next = cells * 2;
            if best <= enough || self.lateral_evaluations(cyl, next) > MAX_EVALUATIONS {
                return Some(best);
            }
            cells = next;
        }
    }

    /// The grid for `cells` cells per radius: the cell's side (mm) and the levels along
    /// the axis.
    fn lateral_grid(&self, cyl: &Cylinder, cells: usize) -> (f64, usize) {
        let side = cyl.radius / cells as f64;
        let n = self.kin.len();
        let height = (0..n)
            .filter(|&v| self.is_linear(v))
            .map(|v| (cyl.nominal[1][v] - cyl.nominal[0][v]).powi(2))
            .sum::<f64>()
            .sqrt();
        let levels = ((height / side).ceil() as usize).clamp(1, 16 * cells);
        (side, levels)
    }

    fn lateral_evaluations(&self, cyl: &Cylinder, cells: usize) -> usize {
        let (_, levels) = self.lateral_grid(cyl, cells);
        2 * (2 * cells + 1).pow(2) * (levels + 1)
    }

    fn lateral_bound_on(&self, cyl: &Cylinder, length: f64, cells: usize) -> Option<f64> {
        let n = self.kin.len();
        let (side, levels) = self.lateral_grid(cyl, cells);
        let m = cells as isize;
        let width = 2 * cells + 1;
        let lerp = |a: &[f64; MAX_AXES], b: &[f64; MAX_AXES], s: f64| {
            let mut q = [0.0; MAX_AXES];
            for (v, x) in q.iter_mut().enumerate().take(n) {
                *x = a[v] + (b[v] - a[v]) * s;
            }
            q
        };
        let offset = |q: &[f64; MAX_AXES], i: isize, j: isize| {
            let mut q = *q;
            let (x, y) = (i as f64 * side, j as f64 * side);
            for (v, value) in q.iter_mut().enumerate().take(n) {
                *value += x * cyl.along[0][v] + y * cyl.along[1][v];
            }
            q
        };
        let tip = |model: Model, q: &[f64; MAX_AXES]| self.kin.pose(model, &q[..n], length).0.p;
        // L at every corner, level by level; and the axis's values per level.
        let mut corner = vec![0.0f64; width * width * (levels + 1)];
        let mut axis = Vec::with_capacity(levels + 1);
        for k in 0..=levels {
            let s = k as f64 / levels as f64;
            let q = lerp(&cyl.nominal[0], &cyl.nominal[1], s);
            let c = lerp(&cyl.written[0], &cyl.written[1], s);
            let (real0, nominal0) = (tip(Model::Actual, &c), tip(Model::Nominal, &q));
            for i in -m..=m {
                for j in -m..=m {
                    // Corners of cells that do not meet the disk are not needed.
                    let near = |t: isize| (t.abs() - 1).max(0) as f64 * side;
                    if near(i).hypot(near(j)) > cyl.radius {
                        continue;
                    }
                    let l = (tip(Model::Actual, &offset(&c, i, j)) - real0)
                        - (tip(Model::Nominal, &offset(&q, i, j)) - nominal0);
                    let index = (k * width + (i + m) as usize) * width + (j + m) as usize;
                    corner[index] = l.norm();
                }
            }
            axis.push((q, c));
        }
        let mut worst_axis = 0.0f64;
        for k in 0..levels {
            let (q0, c0) = &axis[k];
            let (q1, c1) = &axis[k + 1];
            let sag = self
                .kin
                .path_sag((&q0[..n], &q1[..n]), (&c0[..n], &c1[..n]), length)?;
            worst_axis = worst_axis.max(sag.position);
        }
        let mut worst = 0.0f64;
        for k in 0..levels {
            let (q0, c0) = &axis[k];
            let (q1, c1) = &axis[k + 1];
            for i in -m..m {
                for j in -m..m {
                    // The cell [i, i+1] × [j, j+1]: skipped where it does not meet the disk.
                    let nearest = |a: isize| {
                        if a >= 0 {
                            a as f64
                        } else if a < 0 {
                            (a + 1) as f64
                        } else {
                            0.0
                        }
                    };
                    if (nearest(i).abs() * side).hypot(nearest(j).abs() * side) > cyl.radius {
                        continue;
                    }
                    let mut at_corners = 0.0f64;
                    let (mut lo, mut hi) =
                        ([f64::INFINITY; MAX_AXES], [f64::NEG_INFINITY; MAX_AXES]);
                    for (kk, qq) in [(k, q0), (k + 1, q1)] {
                        for (a, b) in [(i, j), (i + 1, j), (i, j + 1), (i + 1, j + 1)] {
                            let index = (kk * width + (a + m) as usize) * width + (b + m) as usize;
                            at_corners = at_corners.max(corner[index]);
                            let p = offset(qq, a, b);
                            for v in 0..n {
                                lo[v] = lo[v].min(p[v]);
                                hi[v] = hi[v].max(p[v]);
                            }
                        }
                    }
                    // A move that spans the cell on every linear axis, widened by the
                    // correction, its correction changing as between the two levels; the
                    // rotary axes as they stand.
                    let (mut qa, mut qb, mut ca, mut cb) = (
                        [0.0; MAX_AXES],
                        [0.0; MAX_AXES],
                        [0.0; MAX_AXES],
                        [0.0; MAX_AXES],
                    );
                    for v in 0..n {
                        let (d0, d1) = (c0[v] - q0[v], c1[v] - q1[v]);
                        if self.is_linear(v) {
                            let pad = 2.0 * d0.abs().max(d1.abs()) + 1e-9;
                            qa[v] = lo[v] - pad;
                            qb[v] = hi[v] + pad;
                        } else {
                            qa[v] = q0[v];
                            qb[v] = q1[v];
                        }
                        ca[v] = qa[v] + d0;
                        cb[v] = qb[v] + d1;
                    }
                    let sag =
                        self.kin
                            .path_sag((&qa[..n], &qb[..n]), (&ca[..n], &cb[..n]), length)?;
                    worst = worst.max(at_corners + 3.0 * sag.position);
                }
            }
        }
        let bound = worst + worst_axis;
        bound.is_finite().then_some(bound)
    }
}
