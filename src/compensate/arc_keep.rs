//! Keeping an arc an arc.
//!
//! The controller interpolates G2/G3 in axis space; on a machine with errors the arc that
//! traces the intended one on the part is not exactly a circle in axis space, but for the
//! errors of a real machine it is very nearly one. nccomp compensates the arc's end and
//! the circle through the compensated start, middle and end, writes those, and evaluates
//! what the controller will do with the written words (its circle through the written
//! start and end about the written centre, other axes linear in the angle, a radius that
//! differs between the ends blended linearly, as LinuxCNC does) against the nominal arc
//! along the way. Where that stays within the path tolerance the arc is kept; otherwise it
//! is replaced by straight pieces (`arcs`).

use super::pipeline::{Cx, Out};
use super::{INCH, Pass, State};
use crate::kinematics::path::PathTolerance;
use crate::kinematics::{MAX_AXES, Model, Solution, angle_between};
use crate::nc::number::{same_text, scaled, write_fixed};
use crate::nc::{TokenKind, Value};
use crate::program::arc::{ArcPath, Centre, circle};
use crate::program::exact::Unit;
use std::f64::consts::TAU;

/// The centre of the circle through three points, if they are not (nearly) on a line.
pub(super) fn circle_centre(p: [(f64, f64); 3]) -> Option<(f64, f64)> {
    let [(ax, ay), (bx, by), (cx, cy)] = p;
    let d = 2.0 * (ax * (by - cy) + bx * (cy - ay) + cx * (ay - by));
    let scale = [(bx - ax), (by - ay), (cx - ax), (cy - ay)]
        .iter()
        .fold(0.0f64, |m, x| m.max(x.abs()));
    if d.is_nan() || d.abs() <= 1e-9 * scale * scale {
        return None;
    }
    let (a2, b2, c2) = (ax * ax + ay * ay, bx * bx + by * by, cx * cx + cy * cy);
    Some((
        (a2 * (by - cy) + b2 * (cy - ay) + c2 * (ay - by)) / d,
        (a2 * (cx - bx) + b2 * (ax - cx) + c2 * (bx - ax)) / d,
    ))
}

/// A kept arc's centre words: (token index, or the letter to add; number text) for
/// I/J/K or R.
pub(super) type CentreWords = Vec<(Result<usize, u8>, String)>;

impl Pass<'_> {
    /// The centre words of the arc `nominal` kept as an arc (the block `cx`, its end solved
    /// as `end_solution`), if what the controller makes of it stays within `tol` of the
    /// nominal arc.
    pub(super) fn keep_arc(
        &self,
        nominal: &ArcPath,
        end_solution: &Solution,
        cx: &Cx<'_, '_>,
        centre_letters: [u8; 2],
        state: &State,
        tol: &PathTolerance,
    ) -> Option<CentreWords> {
        let (tokens, motion) = (cx.tokens, cx.motion);
        let n = self.kin.len();
        let length = state.modal.length;
        let solve = |s: f64| {
            self.kin.compensate(
                &nominal.point(s, n)[..n],
                length,
                self.hold,
                // The centre is fitted through these points: a chord a sixth of the
                // radius magnifies their error sixfold, so they are solved to the
                // analysis tools' tolerance, not to a tenth of the resolution.
                &self.options.solve,
            )
        };
        // A rotary axis held at a singular pose or a solve that failed: the straight pieces
        // deal with it.
        if self.missed(end_solution) {
            return None;
        }
        let start = state.emitted;
        // The end as it will be written.
        let mut end = end_solution.q;
        for (v, x) in end.iter_mut().enumerate().take(n) {
            let unit = self.unit(v, &state.modal);
            let d = state.decimals[v].max(self.res_decimals(v, unit));
            if let Some(k) = scaled(unit.of_mm(*x), d) {
                *x = unit.to_mm(k as f64 / 10f64.powi(d.into()));
            }
        }
        let full = nominal.sweep.abs() > TAU - 1e-9;
        let (s1, s2) = if full {
            (1.0 / 3.0, 2.0 / 3.0)
        } else {
            (0.5, 1.0)
        };
        let (m1, m2) = (solve(s1).q, if full { solve(s2).q } else { end });
        let plane = |q: &[f64; MAX_AXES]| (q[nominal.va], q[nominal.vb]);
        let centre = circle_centre([plane(&start), plane(&m1), plane(&m2)])?;

        // The centre words as they will be written, and the controller's arc from them.
        let number = |i: usize| match &tokens[i].kind {
            TokenKind::Word(w) => match w.value {
                Value::Number { value, decimals } => Some((value, decimals)),
                _ => None,
            },
            _ => None,
        };
        // Centres and radii are never diameters.
        let centre_unit = Unit {
            inch: state.modal.inch,
            diameter: false,
        };
        let unit = if state.modal.inch { INCH } else { 1.0 };
        let mut centre_words = Vec::new();
        let written_centre = if let Some(ri) = motion.arc_words[3] {
            let (old, decimals) = number(ri)?;
            let probe = ArcPath::through(nominal, centre, start, end);
            let radius = probe.r0 / unit;
            let d = decimals.max(self.res_decimals(nominal.va, centre_unit));
            let new = radius.copysign(old);
            let mut text = String::new();
            write_fixed(new, d, &mut text);
            let r: f64 = text.parse().ok()?;
            if !same_text(old, new, d) {
                centre_words.push((Ok(ri), text));
            }
            // The controller's centre from R and the written ends.
            let clockwise = nominal.sweep < 0.0;
            circle(
                plane(&start),
                plane(&end),
                clockwise,
                Centre::Radius(r * unit),
                false,
            )
            .ok()?
            .centre
        } else {
            let origin = if state.modal.arc_absolute {
                (0.0, 0.0)
            } else {
                plane(&start)
            };
            let mut written = [0.0; 2];
            for c in 0..2 {
                let letter = centre_letters[c];
                let index = motion.arc_words[b"IJKR".iter().position(|&l| l == letter)?];
                let offset = ([centre.0, centre.1][c] - [origin.0, origin.1][c]) / unit;
                let var = if c == 0 { nominal.va } else { nominal.vb };
                let res = self.res_decimals(var, centre_unit);
                let (old, d) = match index.and_then(number) {
                    Some((old, decimals)) => (Some(old), decimals.max(res)),
                    None => (None, res),
                };
                let mut text = String::new();
                write_fixed(offset, d, &mut text);
                written[c] = text.parse::<f64>().ok()? * unit;
                match (index, old) {
                    (Some(i), Some(old)) if !same_text(old, offset, d) => {
                        centre_words.push((Ok(i), text))
                    }
                    (None, _) if !same_text(0.0, offset, d) => {
                        centre_words.push((Err(letter), text))
                    }
                    _ => {}
                }
            }
            (origin.0 + written[0], origin.1 + written[1])
        };
        // The arc the control runs: from the written start and end about the written
        // centre, the way G2/G3 turns (not the sweep nearest the nominal one: a centre
        // fitted across the chord makes a G3 of a short arc nearly a full circle).
        let clockwise = nominal.sweep < 0.0;
        let controller = ArcPath::commanded(nominal, written_centre, start, end, clockwise);
        if (controller.sweep - nominal.sweep).abs() > 0.1 {
            return None;
        }
        // Where the written ends lie within their rounding of the same angle about the
        // centre (a sweep near 0 or a full turn), which way round the control goes hangs
        // on the last digit: not kept.
        // Half a unit of the last written digit: the end words' (in the axes' units) and
        // the centre words' (never diameters).
        let half_unit = |unit: Unit, d: u8| 0.5 * unit.to_mm(10f64.powi(-i32::from(d)));
        let rounding = [nominal.va, nominal.vb]
            .iter()
            .map(|&v| {
                let unit = self.unit(v, &state.modal);
                let d = state.decimals[v].max(self.res_decimals(v, unit));
                half_unit(unit, d) + half_unit(centre_unit, self.res_decimals(v, centre_unit))
            })
            .fold(0.0f64, f64::max)
            * std::f64::consts::SQRT_2
            * 2.0;
        let margin = rounding / controller.r0.min(controller.r1).max(1e-9);
        if !full && (controller.sweep.abs() <= margin || controller.sweep.abs() >= TAU - margin) {
            return None;
        }
        // The controller's arc against the nominal one, at the quarter points and between:
        // the distance of the real tip from the nominal arc (its closest point nearby: the
        // two arcs' parametrisations differ by a micron along the way, which is timing,
        // not path).
        let nominal_at = |s: f64| {
            self.kin
                .pose_and_jacobian(Model::Nominal, &nominal.point(s, n)[..n], length)
        };
        let nominal_p = |s: f64| {
            self.kin
                .pose(Model::Nominal, &nominal.point(s, n)[..n], length)
                .0
                .p
        };
        let samples = (0..32)
            .map(|k| (k as f64 + 0.5) / 32.0)
            .chain([0.25, 0.5, 0.75]);
        for s in samples {
            let (actual, _) = self
                .kin
                .pose(Model::Actual, &controller.point(s, n)[..n], length);
            // The closest point of the nominal arc near s: two Newton steps along its
            // tangent (the offset is microns against an arc millimetres long).
            // (Each point's pose once, and the Jacobian only where it is used: ten poses
            // with Jacobians a sample were nine tenths of a kept arc's cost.)
            let mut closest = s;
            let mut p = nominal_p(closest);
            let mut last = None;
            for k in 0..2 {
                let h = 1e-4;
                let (lo, hi) = ((closest - h).max(0.0), (closest + h).min(1.0));
                let tangent = (nominal_p(hi) - nominal_p(lo)) / (hi - lo).max(f64::EPSILON);
                let step = (actual.p - p).dot(&tangent) / tangent.norm_squared().max(1e-300);
                closest = (closest + step).clamp(0.0, 1.0);
                if k == 1 {
                    last = Some(nominal_at(closest));
                } else {
                    p = nominal_p(closest);
                }
            }
            let (target, jac) = last?;
            if (target.p - actual.p).norm() > tol.position {
                return None;
            }
            let singular =
                self.kin
                    .singular_axes(&target, &jac.axis_dir, self.options.solve.singular_angle)
                    & !self.hold;
            if singular != end_solution.singular {
                // A rotary axis enters or leaves the singular cone along the arc: its
                // correction jumps there, which the straight pieces deal with.
                return None;
            }
            if singular == 0 && angle_between(&actual.o, &target.o) > tol.direction {
                return None;
            }
        }
        Some(centre_words)
    }

    /// Edits for the centre words of a kept arc: changed numbers in place, missing words
    /// after the block's last axis or centre word.
    pub(super) fn centre_edits(
        &self,
        cx: &Cx<'_, '_>,
        words: &[(Result<usize, u8>, String)],
        out: &mut Out<'_>,
    ) {
        let last = cx
            .motion
            .axis_words
            .iter()
            .chain(&cx.motion.arc_words)
            .flatten()
            .map(|&i| cx.tokens[i].span.end)
            .max()
            .unwrap_or(0);
        let mut editor = cx.editor(out.edits);
        let mut added: Vec<(u8, &str)> = Vec::new();
        for (word, text) in words {
            match word {
                Ok(i) => editor.replace_number(*i, text.as_str()),
                Err(letter) => added.push((*letter, text)),
            }
        }
        editor.insert_words_at(last, &added);
    }
}
