//! Tool radius compensation (TNC RL/RR): the control offsets the programmed contour by the
//! tool's radius at run time, so the tool centre runs beside the words, not on them.
//!
//! nccomp compensates the contour as it does a tool-centre path (its words are corrected,
//! the path between them checked against the nominal contour), and bounds what the offset
//! adds. Where the written contour is W(s), the nominal P(s), and the control offsets them
//! by d' = r·n' and d = r·n (n', n the in-plane normals on the compensation's side), the
//! real tool centre is off the nominal offset point by at most
//!
//! - the contour's own deviation, real(W(s)) − P(s): what the pass's path check holds, at
//!   half the tolerance inside a compensated section;
//! - the error field's change over the offset,
//!   L = [real(W + d) − real(W)] − [nom(P + d) − nom(P)], |d| ≤ r in the plane:
//!   `Pass::lateral_bound` over the cylinder about the element's chord (for an arc, of
//!   radius r plus the arc's greatest distance from its chord, taken twice: the arc point
//!   is itself an offset from the chord);
//! - the offset's change, |d' − d|: at the element's ends (lines have one normal; an arc's
//!   radial direction turns in proportion along it, so its ends bound it), with the
//!   corners as the control makes them: the intersection of the offset paths at an inside
//!   corner (the miter point r(n₁+n₂)/(1+n₁·n₂)), a transition arc about the corner point
//!   at an outside one (bounded by its ends, r·n₁ and r·n₂); the approach block (the first
//!   RL/RR block) ends at the offset of the next element's start, the departure (the R0
//!   block after) starts at the last element's end offset.
//!
//! An element whose bound, beside the half tolerance its contour is held to, exceeds the
//! other half plus the words' rounding floor is refused, naming the bound.

use super::lateral::Cylinder;
use super::{Pass, State};
use crate::diag::Diagnostic;
use crate::kinematics::MAX_AXES;
use crate::program::{RadiusSide, WorkingPlane};
use nalgebra::Vector3;

/// A joint at an arc whose directions differ by less than this (rad) is near tangent:
/// the offset paths there meet near the offset of the joint, within the offset's own
/// change (what the words of a tangent joint, rounded, and a kept arc's written pole make
/// of it: 0.1 mrad in the corpus's pockets); beyond it, an inside corner at an arc is
/// refused.
const TANGENT: f64 = 0.01;

/// An in-plane vector (the working plane's X, Y; mm).
type V2 = [f64; 2];

fn sub(a: V2, b: V2) -> V2 {
    [a[0] - b[0], a[1] - b[1]]
}
fn add(a: V2, b: V2) -> V2 {
    [a[0] + b[0], a[1] + b[1]]
}
fn scale(a: V2, k: f64) -> V2 {
    [a[0] * k, a[1] * k]
}
fn norm(a: V2) -> f64 {
    a[0].hypot(a[1])
}
fn dot(a: V2, b: V2) -> f64 {
    a[0] * b[0] + a[1] * b[1]
}
fn cross(a: V2, b: V2) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}
fn unit(a: V2) -> Option<V2> {
    let l = norm(a);
    (l > 1e-9).then(|| scale(a, 1.0 / l))
}

/// One element's shape in the plane (nominal or written): its tangents at the start and
/// end (unit), and for an arc its centre.
#[derive(Debug, Clone, Copy)]
struct Shape {
    t0: V2,
    t1: V2,
    /// An arc's centre, its greatest distance from its chord.
    arc: Option<(V2, f64)>,
}

impl Shape {
    fn line(start: V2, end: V2) -> Option<Shape> {
        let t = unit(sub(end, start))?;
        Some(Shape {
            t0: t,
            t1: t,
            arc: None,
        })
    }

    /// An arc about `centre` from `start` to `end`, turning `sweep` radians (positive:
    /// counter-clockwise).
    fn arc(start: V2, end: V2, centre: V2, sweep: f64) -> Option<Shape> {
        let tangent = |p: V2| {
            let u = unit(sub(p, centre))?;
            Some(if sweep >= 0.0 {
                [-u[1], u[0]]
            } else {
                [u[1], -u[0]]
            })
        };
        let rho = norm(sub(start, centre)).max(norm(sub(end, centre)));
        let half = (sweep.abs() / 2.0).min(std::f64::consts::PI);
        // The arc's greatest distance from its chord: its sagitta up to a half turn, the
        // diameter beyond.
        let h = if sweep.abs() <= std::f64::consts::PI {
            rho * (1.0 - half.cos())
        } else {
            2.0 * rho
        };
        Some(Shape {
            t0: tangent(start)?,
            t1: tangent(end)?,
            arc: Some((centre, h)),
        })
    }

    fn normal(t: V2, side: RadiusSide) -> V2 {
        match side {
            RadiusSide::Left => [-t[1], t[0]],
            RadiusSide::Right => [t[1], -t[0]],
        }
    }
}

/// Where the offset path goes at a corner between two elements, from the corner point.
#[derive(Debug, Clone, Copy)]
enum Corner {
    /// At one point: the offset of a tangent joint, the intersection at an inside corner.
    Point(V2),
    /// A transition arc about the corner point, from the one offset to the other.
    Arc(V2, V2),
}

/// The corner between tangents `t1` (the end of one element) and `t2` (the start of the
/// next), offset by `r` on `side`; `None` for a reversal, which has no corner the control
/// can make.
fn corner(t1: V2, t2: V2, r: f64, side: RadiusSide) -> Option<Corner> {
    let (n1, n2) = (
        scale(Shape::normal(t1, side), r),
        scale(Shape::normal(t2, side), r),
    );
    let turn = cross(t1, t2);
    let c = dot(t1, t2);
    if turn.abs() < 1e-12 && c > 0.0 {
        return Some(Corner::Point(n1));
    }
    let inside = match side {
        RadiusSide::Left => turn > 0.0,
        RadiusSide::Right => turn < 0.0,
    };
    if inside {
        let k = 1.0 + c;
        if k < 1e-6 {
            return None;
        }
        Some(Corner::Point(scale(add(n1, n2), 1.0 / k)))
    } else {
        Some(Corner::Arc(n1, n2))
    }
}

impl Corner {
    /// The offset at which the element before ends, and the one after starts.
    fn ends(self) -> (V2, V2) {
        match self {
            Corner::Point(m) => (m, m),
            Corner::Arc(a, b) => (a, b),
        }
    }

    /// How far the written corner's offsets are from the nominal's (matched ends of two
    /// transition arcs; any pair otherwise).
    fn distance(written: Corner, nominal: Corner) -> f64 {
        match (written, nominal) {
            (Corner::Point(a), Corner::Point(b)) => norm(sub(a, b)),
            (Corner::Arc(a1, a2), Corner::Arc(b1, b2)) => norm(sub(a1, b1)).max(norm(sub(a2, b2))),
            (Corner::Point(m), Corner::Arc(a, b)) | (Corner::Arc(a, b), Corner::Point(m)) => {
                norm(sub(m, a)).max(norm(sub(m, b)))
            }
        }
    }
}

/// A block of a compensated section waiting for the next one (its end's offset depends on
/// the corner there).
#[derive(Debug, Clone)]
pub(super) struct Element {
    line: usize,
    nominal: Shape,
    written: Shape,
    /// The offsets (from the contour point) at its start, nominal and written.
    start: (V2, V2),
    /// The approach block: it starts at its start point itself (no offset).
    approach: bool,
    cyl: Cylinder,
    length: f64,
    /// The largest offset at its start (mm).
    reach: f64,
}

/// A section under RL/RR being followed.
#[derive(Debug, Clone)]
pub(super) struct Section {
    side: RadiusSide,
    radius: f64,
    pending: Option<Element>,
    /// The working plane its contour is in (`None`: machine axes).
    frame: Option<WorkingPlane>,
}

/// What the summary reports of the compensated sections.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RadiusReport {
    /// Sections (RL/RR to R0) and blocks in them.
    pub sections: usize,
    pub moves: usize,
    /// The largest radius used (mm) and where it came from (the machine file's key).
    pub radius: f64,
    pub source: &'static str,
    /// The largest bound of an element (mm) and its line.
    pub bound: f64,
    pub line: usize,
}

/// An arc under tool radius compensation: its nominal centre and sweep (rad, positive
/// counter-clockwise), its written centre and sweep.
pub(super) type ArcPair = ([f64; 2], f64, [f64; 2], f64);

/// A block that moves, as the pass saw it: the tip words (in the plane) and axis values
/// at its start and end, nominal and written, and for an arc its centres and sweep.
pub(super) struct Move<'a> {
    /// The working plane; `None`: machine axes, the words X, Y, Z.
    pub frame: Option<&'a WorkingPlane>,
    pub tip: [[f64; 3]; 2],
    pub tip_written: [[f64; 3]; 2],
    pub q: [[f64; MAX_AXES]; 2],
    pub q_written: [[f64; MAX_AXES]; 2],
    /// Nominal centre and sweep (rad), written centre and sweep.
    pub arc: Option<ArcPair>,
    /// Straight pieces inserted before the block.
    pub pieces: usize,
}

impl Pass<'_> {
    /// Follow tool radius compensation over a block that moved (`mv`; `None`: a block
    /// nccomp cannot follow under it): check the element before it, now that its end's
    /// corner is known.
    pub(super) fn radius_block(
        &self,
        line: usize,
        col: usize,
        state: &mut State,
        mv: Option<Move<'_>>,
        summary: &mut super::Summary,
        at: &dyn Fn(usize, String) -> Diagnostic,
    ) -> Result<(), Diagnostic> {
        let side = state.modal.radius_comp;
        if side.is_none() && state.radius.is_none() {
            return Ok(());
        }
        let Some(mv) = mv else {
            return Err(at(
                col,
                "a block nccomp does not follow as a contour element while tool radius compensation (RL/RR) is in force: only L blocks, and C/CP arcs kept as arcs in a working plane (PLANE; in machine axes an arc is written as pieces), are compensated there (expected R0 before it)".into(),
            ));
        };
        // Refusals point at this block: an element before it is checked once this one
        // shows how its offset ends (its message names the element's line).
        let refuse = |why: String| at(col, why);
        if mv.pieces > 0 {
            return Err(refuse(format!(
                "this block under tool radius compensation (RL/RR) would be written as {} pieces, and the control offsets each piece on its own (expected a tolerance the block meets whole, or the contour programmed as the tool centre path with R0)",
                mv.pieces + 1
            )));
        }
        let n = self.kin.len();
        if (0..n).any(|v| !self.is_linear(v) && mv.q[0][v] != mv.q[1][v]) {
            return Err(refuse(
                "a rotary axis turns under tool radius compensation (RL/RR): the control's offset is in the working plane, with the axes standing (expected R0 before the turn)".into(),
            ));
        }
        let p2 = |t: &[f64; 3]| [t[0], t[1]];
        let shapes = match mv.arc {
            None => Shape::line(p2(&mv.tip[0]), p2(&mv.tip[1]))
                .zip(Shape::line(p2(&mv.tip_written[0]), p2(&mv.tip_written[1]))),
            Some((c, sweep, cw, sweep_w)) => Shape::arc(p2(&mv.tip[0]), p2(&mv.tip[1]), c, sweep)
                .zip(Shape::arc(
                    p2(&mv.tip_written[0]),
                    p2(&mv.tip_written[1]),
                    cw,
                    sweep_w,
                )),
        };
        let tolerance = self.options.path.unwrap_or_default().position;
        let limit = tolerance / 2.0 + crate::verify::Tolerances::rounding(self.machine);
        // The departure's direction does not matter (it starts at the last element's end
        // offset and ends at its end point).
        let departure = side.is_none();
        let shapes = shapes.or_else(|| {
            departure.then(|| {
                let still = Shape {
                    t0: [1.0, 0.0],
                    t1: [1.0, 0.0],
                    arc: None,
                };
                (still, still)
            })
        });
        let Some((nominal, written)) = shapes else {
            return Err(refuse(
                "a move along the tool axis alone (or of no length in the plane) under tool radius compensation (RL/RR): where the control puts the offset for it is not followed (expected R0 before it)".into(),
            ));
        };
        let length = state.modal.length;
        let cyl = self.radius_cylinder(&mv, length).ok_or_else(|| {
            refuse("the nominal machine cannot reach the offset of this contour element with the rotary axes where they stand (tool radius compensation, RL/RR)".into())
        })?;
        let element = |start: (V2, V2), approach: bool, reach: f64| Element {
            line,
            nominal,
            written,
            start,
            approach,
            cyl: cyl.clone(),
            length,
            reach,
        };
        if state
            .radius
            .as_ref()
            .is_some_and(|s| s.frame != mv.frame.copied())
        {
            return Err(refuse(
                "the working plane or the datum shift changed while tool radius compensation (RL/RR) is in force: the control's offset across the change is not followed (expected R0 before PLANE or CYCL DEF 7)".into(),
            ));
        }
        match (state.radius.take(), side) {
            // The approach block: it starts at its start point, and ends at the offset of
            // the next element's start.
            (None, Some(side)) => {
                let radius = state.modal.tool_radius.map_or(0.0, |r| r.radius);
                if let Some(r) = state.modal.tool_radius {
                    summary.radius.sections += 1;
                    if r.radius >= summary.radius.radius {
                        summary.radius.radius = r.radius;
                        summary.radius.source = r.source.key();
                    }
                }
                summary.radius.moves += 1;
                state.radius = Some(Section {
                    side,
                    radius,
                    pending: Some(element(([0.0; 2], [0.0; 2]), true, 0.0)),
                    frame: mv.frame.copied(),
                });
            }
            (Some(mut section), Some(side)) if side == section.side => {
                summary.radius.moves += 1;
                let pending = section.pending.take();
                let start = match pending {
                    Some(p) => self.radius_check(
                        &p,
                        &section,
                        Some((nominal, written)),
                        limit,
                        summary,
                        &refuse,
                    )?,
                    None => (
                        scale(Shape::normal(nominal.t0, side), section.radius),
                        scale(Shape::normal(written.t0, side), section.radius),
                    ),
                };
                let reach = norm(start.0).max(norm(start.1));
                section.pending = Some(element(start, false, reach));
                state.radius = Some(section);
            }
            (Some(_), Some(_)) => {
                return Err(refuse(
                    "tool radius compensation changes side (RL to RR or back) without R0 between: how the control joins the two offsets is not followed (expected R0 first)".into(),
                ));
            }
            // The departure: from the last element's end offset to the block's end.
            (Some(mut section), None) => {
                summary.radius.moves += 1;
                let pending = section.pending.take();
                if let Some(p) = pending {
                    let start = self.radius_check(&p, &section, None, limit, summary, &refuse)?;
                    let reach = norm(start.0).max(norm(start.1));
                    let departure = element(start, false, reach);
                    // Its end is its end point itself.
                    self.radius_element(
                        &departure,
                        &section,
                        ([0.0; 2], [0.0; 2]),
                        0.0,
                        limit,
                        summary,
                        &refuse,
                    )?;
                }
            }
            (None, None) => {}
        }
        Ok(())
    }

    /// Check `p` now that what follows it is known (`next`: the next element's nominal and
    /// written shapes; `None`: the departure, which starts at `p`'s own end offset). The
    /// offsets at the next element's start.
    fn radius_check(
        &self,
        p: &Element,
        section: &Section,
        next: Option<(Shape, Shape)>,
        limit: f64,
        summary: &mut super::Summary,
        refuse: &dyn Fn(String) -> Diagnostic,
    ) -> Result<(V2, V2), Diagnostic> {
        let (r, side) = (section.radius, section.side);
        let own = |s: &Shape| scale(Shape::normal(s.t1, side), r);
        let (end, next_start, corner_bound) = match next {
            None => {
                let e = (own(&p.nominal), own(&p.written));
                (e, e, 0.0)
            }
            Some((nn, nw)) if p.approach => {
                // The approach ends at the offset of the next element's start.
                let e = (
                    scale(Shape::normal(nn.t0, side), r),
                    scale(Shape::normal(nw.t0, side), r),
                );
                (e, e, 0.0)
            }
            Some((nn, nw)) => {
                let (Some(cn), Some(cw)) = (
                    corner(p.nominal.t1, nn.t0, r, side),
                    corner(p.written.t1, nw.t0, r, side),
                ) else {
                    return Err(refuse(format!(
                        "the contour turns back on itself at the end of this element under tool radius compensation (RL/RR; line {}): the control's offset there is not followed (expected R0 before the reversal)",
                        p.line
                    )));
                };
                // At an inside corner of an arc the control intersects the offset arc with
                // the other offset element, which the miter point does not bound: refused
                // beyond what the words can make of a tangent joint.
                let inside = match side {
                    RadiusSide::Left => cross(p.nominal.t1, nn.t0) > 0.0,
                    RadiusSide::Right => cross(p.nominal.t1, nn.t0) < 0.0,
                };
                let angle = cross(p.nominal.t1, nn.t0)
                    .abs()
                    .atan2(dot(p.nominal.t1, nn.t0));
                if inside && angle > TANGENT && (p.nominal.arc.is_some() || nn.arc.is_some()) {
                    return Err(refuse(format!(
                        "an inside corner of {:.3}° at an arc under tool radius compensation (RL/RR; the end of line {}): where the control intersects the offset arc with the next element is not bounded by nccomp (expected the joint tangent, or the contour programmed as the tool centre path with R0)",
                        angle.to_degrees(),
                        p.line
                    )));
                }
                let (en, sn) = cn.ends();
                let (ew, sw) = cw.ends();
                ((en, ew), (sn, sw), Corner::distance(cw, cn))
            }
        };
        let reach = norm(end.0).max(norm(end.1));
        self.radius_element(p, section, end, reach.max(p.reach), limit, summary, refuse)
            .and_then(|()| {
                if corner_bound > limit {
                    Err(self.radius_refusal(p, section, corner_bound, limit, refuse))
                } else {
                    Ok(())
                }
            })?;
        Ok(next_start)
    }

    /// Bound element `p`, whose offsets at its end are `end` (nominal, written), the
    /// largest offset on it `reach`; refused where the bound exceeds `limit`.
    #[allow(clippy::too_many_arguments)]
    fn radius_element(
        &self,
        p: &Element,
        section: &Section,
        end: (V2, V2),
        reach: f64,
        limit: f64,
        summary: &mut super::Summary,
        refuse: &dyn Fn(String) -> Diagnostic,
    ) -> Result<(), Diagnostic> {
        // The offset's change: at the ends; along an arc the radial directions turn in
        // proportion, so the angle between them (not its chord) is bounded by the ends'.
        let change = |a: V2, b: V2| {
            let d = norm(sub(a, b));
            let (la, lb) = (norm(a), norm(b));
            if p.nominal.arc.is_some() && la > 1e-9 && lb > 1e-9 {
                // The arc length between the two directions at the larger radius.
                let c = (dot(a, b) / (la * lb)).clamp(-1.0, 1.0);
                d.max(c.acos() * la.max(lb))
            } else {
                d
            }
        };
        let normal = change(p.start.1, p.start.0).max(change(end.1, end.0)) * 1.01;
        let (h, factor) = match (p.nominal.arc, p.written.arc) {
            (Some((_, h)), Some((_, hw))) => (h.max(hw) + 1e-4, 2.0),
            _ => (0.0, 1.0),
        };
        let mut cyl = p.cyl.clone();
        cyl.radius = (reach + h).max(1e-6);
        let enough = ((limit - normal) / factor).max(0.0);
        let lateral = self
            .lateral_bound(&cyl, p.length, enough)
            .ok_or_else(|| {
                refuse(
                    format!(
                        "the error field's change over the tool radius cannot be bounded at this contour element (tool radius compensation, RL/RR; line {}): the error model gives no bound (expected the contour programmed as the tool centre path, R0)",
                        p.line
                    ),
                )
            })?;
        let bound = normal + factor * lateral;
        if bound > summary.radius.bound {
            summary.radius.bound = bound;
            summary.radius.line = p.line;
        }
        if bound > limit {
            return Err(self.radius_refusal(p, section, bound, limit, refuse));
        }
        Ok(())
    }

    fn radius_refusal(
        &self,
        p: &Element,
        section: &Section,
        bound: f64,
        limit: f64,
        refuse: &dyn Fn(String) -> Diagnostic,
    ) -> Diagnostic {
        let tolerance = self.options.path.unwrap_or_default().position;
        let rounding = crate::verify::Tolerances::rounding(self.machine);
        // The tolerance at which the bound fits the half beside the contour's.
        let needed = 2.0 * (bound - rounding).max(0.0);
        refuse(format!(
            "tool radius compensation (RL/RR) offsets the contour element at line {} by the tool's radius of {:.4} mm, and the error field's change over that offset, with the offset's own change where the compensated contour turns, can move the tool centre by up to {:.2} µm from its nominal place: more than {:.2} µm (half the tolerance of {:.2} µm, the other half held by the contour, and what the words' rounding to the machine's resolution can add; expected the contour programmed as the tool centre path (R0), which nccomp compensates, or a tolerance of {:.4} mm or more)",
            p.line,
            section.radius,
            bound * 1e3,
            limit * 1e3,
            tolerance * 1e3,
            needed.max(tolerance * 1.0001)
        ))
    }

    /// The cylinder about a move's chord: its ends' axis values, nominal and written, and
    /// the axis values of unit offsets along the plane's X and Y (radius set by the
    /// caller).
    fn radius_cylinder(&self, mv: &Move<'_>, length: f64) -> Option<Cylinder> {
        let n = self.kin.len();
        let Some(frame) = mv.frame else {
            // Machine axes: a unit offset in X, Y is one on their axes.
            let mut along = [[0.0; MAX_AXES]; 2];
            along[0][self.tip_var(b'X')?] = 1.0;
            along[1][self.tip_var(b'Y')?] = 1.0;
            return Some(Cylinder {
                nominal: mv.q,
                written: mv.q_written,
                along,
                radius: 0.0,
            });
        };
        let at = |w: &[f64; 3], from: &[f64; MAX_AXES]| {
            self.plane_axes(frame, &Vector3::from(*w), from, length)
        };
        let top = mv.q[1];
        let w = mv.tip[1];
        let ex = at(&[w[0] + 1.0, w[1], w[2]], &top)?;
        let ey = at(&[w[0], w[1] + 1.0, w[2]], &top)?;
        let mut along = [[0.0; MAX_AXES]; 2];
        for v in 0..n {
            along[0][v] = ex[v] - top[v];
            along[1][v] = ey[v] - top[v];
        }
        Some(Cylinder {
            nominal: mv.q,
            written: mv.q_written,
            along,
            radius: 0.0,
        })
    }
}
