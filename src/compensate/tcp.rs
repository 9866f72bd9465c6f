//! Tool-centre-point moves: G43.4 (and a machine's own TCP switch, such as LinuxCNC's
//! M428) with rotary words, G43.5 with tool vectors. X, Y, Z are the tool tip in the
//! workpiece frame; the controller finds the axis values with its *nominal* inverse
//! kinematics.
//!
//! Target: the nominal inverse kinematics of the programmed tip and rotary words (the
//! linear axes; the rotary axes are the words) or tool vector (all axes: of the solutions
//! the controller takes the one nearest the axes' current values, a rotary axis along the
//! tool keeps its current value).
//!
//! Write: the tip and direction at which the nominal machine sits at the solved axis
//! values, so that the controller's nominal solve of what is written commands exactly the
//! axis values the real machine needs (design/model.md, "Output rule"). Under G43.5 the
//! vector is written with as many decimals as make the controller's solve of it land on
//! those rotary values within the machine's resolution; at a singular pose (the tool along
//! a rotary axis) the rotary axes keep their programmed values, so the vector is written as
//! programmed and the controller holds the free axis where it is.
//!
//! Path: the controller moves the tip on a straight line (or an arc) in the workpiece frame
//! and the rotary axes linearly between the block's ends (LinuxCNC's planner, Fanuc's
//! conventional TCP, Heidenhain's PATHCTRL AXIS). A move is split where the real machine,
//! following the written words that way, leaves the nominal path of the programmed words by
//! more than the tolerance; an arc is replaced by straight TCP moves within half a micron
//! of it, each end compensated. Inserted blocks are TCP blocks in the program's style.

use super::arc_keep::{CentreWords, circle_centre};
use super::pipeline::{Block, Cx, Mode, Out};
use super::{INCH, Pass, State};
use crate::diag::Diagnostic;
use crate::kinematics::path::{MOVE_PIECES, PathTolerance};
use crate::kinematics::{MAX_AXES, Model, Pose, Solution, SolveOptions, angle_between};
use crate::model::AxisKind;
use crate::nc::edit::Editor;
use crate::nc::number::{decimals_for, same_text, write_fixed};
use crate::program::arc::{Centre, circle, commanded_sweep, plane_arc, plane_letters, plane_third};
use crate::program::exact::{Position, Unit};
use crate::program::{WorkingPlane, gcode, heidenhain};
use nalgebra::Vector3;
use std::f64::consts::TAU;
use std::fmt::Write;

/// Decimals of a TNC polar angle (PA, IPA) as nccomp writes it: the control's 0.0001°.
const ANGLE_DECIMALS: u8 = 4;

/// More pieces than this for one arc means a radius or a tolerance that makes no sense.
const MAX_ARC_PIECES: usize = 100_000;
/// The angle (rad) by which the direction the controller's solve reaches may differ from a
/// programmed tool vector: the solve holds an axis only within 10⁻⁷ rad of it, so anything
/// beyond is a vector the rotary axes cannot give.
const UNREACHED_VECTOR: f64 = 1e-5;

/// Decimals of a tool vector's components, at most.
const MAX_VECTOR_DECIMALS: u8 = 10;

/// The tip's arc of a G2/G3 block under TCP: in the plane of two tip components.
#[derive(Debug, Clone, Copy)]
struct TipArc {
    /// The plane's tip components (0 X, 1 Y, 2 Z).
    a: usize,
    b: usize,
    centre: (f64, f64),
    r0: f64,
    r1: f64,
    th0: f64,
    sweep: f64,
}

/// One end of a piece of a TCP move, as programmed and as written.
#[derive(Debug, Clone, Copy)]
struct End {
    /// Parameter along the block's move.
    s: f64,
    /// The controller's axis values for the written words.
    ctrl: [f64; MAX_AXES],
    /// The written tip words (mm; in the plane's frame under G68.2).
    tip: Vector3<f64>,
    /// The written tool vector (G43.5, as written: not normalised).
    vector: [f64; 3],
    solution: Option<Solution>,
}

/// A TCP block.
pub(super) struct TcpMode {
    /// G2/G3: clockwise or not.
    arc: Option<bool>,
    tips: [usize; 3],
    /// The move's start: nominal axis values, programmed tip, and the controller's end of
    /// the previous block.
    q0: [f64; MAX_AXES],
    tip0: Vector3<f64>,
    start: Option<End>,
    /// The programmed tool vector's length (G43.5), kept in what is written.
    scale: f64,
    tip_arc: Option<TipArc>,
    /// The axes the solve holds beyond the pass's: under G43.5 the rotary axes at a
    /// singular pose.
    hold: u32,
    /// The programmed tool direction where the solve's target is not it (see
    /// [`Mode::direction`]).
    direction: Option<Vector3<f64>>,
    /// Points inserted before the block, in order.
    pieces: Vec<End>,
    /// The block's end as written.
    end: Option<End>,
    /// Under a tilted working plane (G68.2) the tip words are in its frame; the rotary
    /// axes stand where the plane put them.
    frame: Option<WorkingPlane>,
    /// An arc in a plane kept as an arc: its centre as written.
    kept: Option<KeptCentre>,
}

/// How a kept arc's centre is written.
enum KeptCentre {
    /// The block's I/J/K or R words (TNC: CR's R), changed or added.
    Words(CentreWords),
    /// A TNC arc about its pole: the pole's words to insert as a `CC` block before it
    /// (none where the control holds that pole already), its value (mm), and the arc
    /// written as `CP` where it is one.
    Pole(Option<Vec<(u8, String)>>, [f64; 2], Option<Polar>),
}

/// A kept TNC arc written as a polar arc (`CP`): a CP of the program, or a C whose end
/// needs the third coordinate it does not give (a helix in polar form, which every TNC
/// reads).
struct Polar {
    /// The angle's token as written (`IPA+180.0012`, `PA-90.0004`).
    angle: String,
    /// The helix's height as written (`IZ-0.5001`), where the block gives it so.
    lead: Option<String>,
    /// Where the control ends the arc (words, mm).
    end: Vector3<f64>,
}

impl TcpMode {
    /// Under a working plane, what tool radius compensation follows of the block: the
    /// nominal arc's centre and sweep and the written arc's (in the plane's X, Y), for an
    /// arc about a pole in X-Y kept as an arc; `Err(())` for an arc it cannot follow.
    pub(super) fn radius_arc(
        &self,
        tip0_written: &[f64; 3],
        tip1_written: &[f64; 3],
    ) -> Result<Option<super::radius::ArcPair>, ()> {
        let Some(arc) = &self.tip_arc else {
            return Ok(None);
        };
        if (arc.a, arc.b) != (0, 1) {
            return Err(());
        }
        let centre = [arc.centre.0, arc.centre.1];
        let written = match &self.kept {
            Some(KeptCentre::Pole(_, c, _)) => *c,
            _ => return Err(()),
        };
        let angle = |p: &[f64; 3], c: [f64; 2]| (p[1] - c[1]).atan2(p[0] - c[0]);
        let wrap = |x: f64| (x + std::f64::consts::PI).rem_euclid(TAU) - std::f64::consts::PI;
        let th1 = arc.th0 + arc.sweep;
        let d0 = wrap(angle(tip0_written, written) - arc.th0);
        let d1 = wrap(angle(tip1_written, written) - th1);
        Ok(Some((centre, arc.sweep, written, arc.sweep + d1 - d0)))
    }

    /// Straight pieces inserted before the block.
    pub(super) fn pieces(&self) -> usize {
        self.pieces.len()
    }

    pub(super) fn line() -> Self {
        Self::new(None)
    }

    pub(super) fn arc(clockwise: bool) -> Self {
        Self::new(Some(clockwise))
    }

    fn new(arc: Option<bool>) -> Self {
        TcpMode {
            arc,
            tips: [0; 3],
            q0: [0.0; MAX_AXES],
            tip0: Vector3::zeros(),
            start: None,
            scale: 1.0,
            tip_arc: None,
            hold: 0,
            direction: None,
            pieces: Vec::new(),
            end: None,
            frame: None,
            kept: None,
        }
    }

    /// The part-frame tip of tip words `w` (mm).
    fn part(&self, w: &Vector3<f64>) -> Vector3<f64> {
        self.frame.as_ref().map_or(*w, |f| f.part(w))
    }

    /// The tip words (mm) of part-frame tip `p`.
    fn words(&self, p: &Vector3<f64>) -> Vector3<f64> {
        self.frame.as_ref().map_or(*p, |f| f.words(p))
    }
}

/// The name of the TCP mode for messages.
fn code(state: &State) -> &'static str {
    if let Some(plane) = &state.modal.working_plane {
        plane.name()
    } else if state.modal.tcp_vector {
        "G43.5"
    } else {
        match state.modal.dialect {
            crate::nc::Dialect::Heidenhain => "M128 / FUNCTION TCPM",
            crate::nc::Dialect::Sinumerik => "TRAORI",
            crate::nc::Dialect::Iso => "G43.4",
        }
    }
}

impl Mode for TcpMode {
    fn target(&mut self, b: &mut Block, q: &mut [f64; MAX_AXES]) -> Result<bool, Diagnostic> {
        let (pass, cx, state, out) = b.parts();
        let n = pass.kin.len();
        let code = code(state);
        let first = cx.first_word_col();
        if state.modal.incremental {
            return Err(cx.refuse(first, format!("incremental moves (G91) under {code} cannot be compensated (program this part in G90)")));
        }
        if cx.motion.optional {
            return Err(cx.refuse(first, format!("an optional block (/) under {code} cannot be compensated safely (take it out of this part)")));
        }
        let Some(tips) = pass.tip_vars() else {
            return Err(cx.refuse(
                first,
                format!("{code} needs linear axes driven by X, Y and Z words for the tool tip; this machine has none"),
            ));
        };
        self.tips = tips;
        self.frame = state.modal.working_plane;
        if state.zero != [0.0; 3] {
            return Err(cx.refuse(first, format!("{code} with a program zero other than the machine file's geometry zero (a work offset, a set-up's preset or a G52 shift) cannot be compensated: the tip words would need the shift in the part frame (expected the work offset the geometry is given in, `geometry` of [work_offsets])")));
        }
        if self.frame.is_some() {
            pass.plane_checks(cx, state, &tips)?;
            self.hold = pass.rotary_mask();
        } else if state.modal.dialect == crate::nc::Dialect::Heidenhain {
            // Under M128 / FUNCTION TCPM a block that does not program a rotary axis
            // leaves it where it stands: the tip is corrected with the linear axes, and
            // the direction error is reported.
            self.hold = (0..n)
                .filter(|&v| {
                    pass.rotary_mask() & (1 << v) != 0 && cx.motion.axis_words[v].is_none()
                })
                .fold(0, |m, v| m | 1 << v);
        }
        // The tip depends on every axis: after a machine move (G53, M91 …) the block must
        // give all of it, and then every linear axis is known again.
        let given = |v: usize| cx.motion.axis_words[v].is_some();
        let tip_given = tips.iter().all(|&v| given(v));
        let rotary = pass.rotary_mask();
        // Under G43.5 a vector sets every rotary axis.
        let vector_given =
            state.modal.tcp_vector && cx.motion.arc_words[..3].iter().any(Option::is_some);
        let rotary_unknown = (0..n)
            .filter(|&v| rotary & (1 << v) != 0 && state.pos.unknown & (1 << v) != 0 && !given(v))
            .fold(0u32, |m, v| m | 1 << v);
        if state.modal.tcp_vector
            && let Some((v, i)) = cx.word_outside(n, &tips)
        {
            return Err(cx.refuse(
                cx.col(i),
                format!(
                    "{} is a rotary word; under G43.5 the tool direction is programmed by I, J, K (expected X, Y, Z, I, J, K)",
                    pass.letter(v) as char
                ),
            ));
        }
        let start_unknown = state.pos.unknown != 0;
        if start_unknown && (!tip_given || (rotary_unknown != 0 && !vector_given)) {
            return Err(cx.refuse(
                first,
                format!("where the tool stands before this block under {code} is not known (at the start, or after a machine move: G28, G30, G53, M91, M92 or a machine move code; expected X, Y and Z and the tool's direction in this block)"),
            ));
        }
        if start_unknown && !state.modal.rapid {
            // The end is known, the start is not: where a feed move cuts on its way is not.
            return Err(cx.refuse(
                first,
                format!("a feed move under {code} from where the tool stands, which is not known here (at the start, or after a machine move: G28, G30, G53, M91, M92 or a machine move code): where the real tool cuts on the way is not known (expected a rapid G0 to this block's pose first)"),
            ));
        }
        state.pos.unknown = 0;
        let vector = state.modal.tcp_vector;
        if vector && self.arc.is_some() {
            return Err(cx.refuse(
                first,
                "arcs under G43.5 cannot be compensated: I, J, K are the tool vector there (program the arc as G1 moves, or under G43.4)".into(),
            ));
        }
        let to_mm = |x: f64| if state.modal.inch { x * INCH } else { x };
        // Where the move starts.
        self.q0 = state.pos.nominal;
        self.tip0 = Vector3::from(state.tip_nominal);
        self.start = (!start_unknown).then(|| End {
            s: 0.0,
            ctrl: state.emitted,
            tip: Vector3::from(state.tip_written),
            vector: state.vector_written,
            solution: None,
        });
        for v in 0..n {
            if state.pos.programmed & (1 << v) == 0 && cx.motion.axis_words[v].is_none() {
                out.summary
                    .note_assumed_home(pass.axis_name(v), cx.line.number);
            }
        }
        // The programmed end: tip, and rotary words or vector.
        let mut guess = state.pos.nominal;
        for (v, word) in cx.motion.axis_words.iter().enumerate().take(n) {
            let Some(i) = *word else { continue };
            let value = cx.number(i).0;
            match tips.iter().position(|&t| t == v) {
                Some(c) => state.tip_nominal[c] = to_mm(value),
                None => guess[v] = value,
            }
        }
        if let Some(clockwise) = self.arc {
            // The arc's end: a TNC polar arc's and a helix's are not all in its words.
            let (arc, end) = self.tip_arc(cx, state, clockwise)?;
            self.tip_arc = Some(arc);
            state.tip_nominal = end.into();
        }
        let words = Vector3::from(state.tip_nominal);
        let tip = self.part(&words);
        let nominal = if vector {
            let given = cx.motion.arc_words[..3].iter().any(Option::is_some);
            if given {
                for c in 0..3 {
                    state.vector_nominal[c] =
                        cx.motion.arc_words[c].map_or(0.0, |i| cx.number(i).0);
                }
            }
            let v = Vector3::from(state.vector_nominal);
            self.scale = v.norm();
            if self.scale.is_nan() || self.scale <= 1e-9 {
                return Err(cx.refuse(
                    first,
                    "the tool vector I, J, K is zero (expected a direction from the tip towards the spindle)".into(),
                ));
            }
            let target = Pose {
                p: tip,
                o: v / self.scale,
            };
            let q = pass.controller_ik(&target, &state.pos.nominal, state.modal.length)
                .ok_or_else(|| cx.refuse(first, "the nominal machine cannot reach this tip and tool vector from the previous axis positions (no inverse-kinematics solution near them)".into()))?;
            // The solve holds a rotary axis the target direction lies along: the direction
            // it reaches is then the axis's, which may be the opposite of the vector's
            // (a tool pointing away from the spindle on a trunnion). Never written flipped.
            let (reached, _) = pass.kin.pose(Model::Nominal, &q[..n], state.modal.length);
            let off = angle_between(&reached.o, &target.o);
            if off.is_nan() || off > UNREACHED_VECTOR {
                return Err(cx.refuse(
                    first,
                    format!(
                        "the tool vector cannot be reached by the machine's rotary axes: the controller's solve ends {:.4}° from it (expected a direction the rotary axes can give)",
                        off.to_degrees()
                    ),
                ));
            }
            q
        } else {
            let sol = pass.kin.tcp_axes_with_rotaries(
                &tip,
                &guess[..n],
                state.modal.length,
                &pass.options.solve,
            );
            if sol.position_residual > 1e-6 {
                return Err(cx.refuse(
                    first,
                    format!(
                        "the programmed tip cannot be reached with these rotary positions (off by {:.4} mm)",
                        sol.position_residual
                    ),
                ));
            }
            sol.q
        };
        // Under G43.5 at a singular pose the rotary axes keep their programmed values: the
        // vector is then written as programmed, and the controller holds the free axis where
        // it stands. The programmed axis values hold it where the program left it (the next
        // blocks start from them); the solve starts where the controller holds it.
        let mut solve_at = nominal;
        if vector {
            let (pose, jac) =
                pass.kin
                    .pose_and_jacobian(Model::Nominal, &nominal[..n], state.modal.length);
            let singular =
                pass.kin
                    .singular_axes(&pose, &jac.axis_dir, pass.options.solve.singular_angle);
            if singular != 0 {
                // The solve holds the singular axes itself (and says so).
                self.hold = pass.rotary_mask() & !singular;
                let target = Pose { p: tip, o: pose.o };
                if let Some(held) = pass.controller_ik(&target, &state.emitted, state.modal.length)
                {
                    solve_at = held;
                }
            }
        }
        if !vector && self.frame.is_none() && self.hold != 0 {
            // The held rotary axes stand where the last block left them (corrected), not
            // at their programmed values: the tip is put in place with them there.
            let mut at = solve_at;
            for v in (0..n).filter(|&v| self.hold & (1 << v) != 0) {
                at[v] = state.emitted[v];
            }
            let there = pass.kin.tcp_axes_with_rotaries(
                &tip,
                &at[..n],
                state.modal.length,
                &pass.options.solve,
            );
            if there.position_residual <= 1e-6 {
                solve_at = there.q;
                let (pose, _) = pass
                    .kin
                    .pose(Model::Nominal, &nominal[..n], state.modal.length);
                self.direction = Some(pose.o);
            }
        }
        state.pos.nominal = nominal;
        state.pos.programmed |= (1u32 << n) - 1;
        *q = solve_at;
        Ok(true)
    }

    fn direction(&self) -> Option<Vector3<f64>> {
        self.direction
    }

    fn hold(&self, _pass: &Pass<'_>) -> u32 {
        self.hold
    }

    fn path(&mut self, b: &mut Block, end: &Solution, hold: u32) -> Result<(), Diagnostic> {
        let (pass, cx, state, out) = b.parts();
        let Some(start) = self.start else {
            return Ok(());
        };
        // The rotary axes held at a singular end are held there only: on the way the pose
        // is not singular (or is, and the solve holds the axis itself). Under a plane they
        // are held all the way.
        let hold = if self.frame.is_some() {
            hold
        } else {
            hold & !self.hold
        };
        let last = self.written_end(pass, 1.0, end, state);
        self.pieces.clear();
        self.kept = None;
        if self.tip_arc.is_some()
            && let Some(kept) = self.keep_plane_arc(pass, cx, state, &start, &last, hold)?
        {
            // Kept as an arc: no pieces.
            self.kept = Some(kept);
            self.end = Some(last);
            return Ok(());
        }
        if let Some(arc) = self.tip_arc {
            // Chords of the tip's arc, each end compensated.
            let radius = arc.r0.max(arc.r1);
            let step = 2.0 * (1.0 - (pass.chord() / radius).min(1.0)).acos();
            let count = ((arc.sweep.abs() / step).ceil() as usize).max(1);
            if count > MAX_ARC_PIECES {
                return Err(cx.refuse(
                    cx.first_col(),
                    format!(
                        "this arc cannot be compensated: it would take {count} straight pieces"
                    ),
                ));
            }
            for k in 1..count {
                let piece = self.point(pass, cx, k as f64 / count as f64, hold, state)?;
                self.pieces.push(piece);
            }
        } else if let Some(tolerance) = &pass.path_tolerance(state)
            && !state.modal.rapid
        {
            let mut pieces = Vec::new();
            self.split(
                pass,
                cx,
                tolerance,
                start,
                last,
                hold,
                0,
                state,
                &mut pieces,
            )?;
            pieces.pop();
            self.pieces = pieces;
        }
        self.end = Some(last);
        if !self.pieces.is_empty() {
            self.insert(pass, cx, state, out);
        }
        Ok(())
    }

    fn write(&mut self, b: &mut Block, end: &Solution) -> Result<(), Diagnostic> {
        let (pass, cx, state, out) = b.parts();
        let last = match self.end {
            Some(e) => e,
            None => self.written_end(pass, 1.0, end, state),
        };
        let n = pass.kin.len();
        let (programmed, _) = pass
            .kin
            .pose(Model::Nominal, end.values(), state.modal.length);
        let programmed_words = self.words(&programmed.p);
        let vector_mode = state.modal.tcp_vector;
        // Under a plane the rotary axes have no words: they stay where G53.1 put them.
        let rotary = (!vector_mode && self.frame.is_none()).then_some(&end.q);
        match &self.kept {
            Some(KeptCentre::Pole(_, _, Some(polar))) => {
                self.write_polar(pass, cx, polar, &programmed_words, state, out);
            }
            _ => pass.write_tip_words(cx, &self.tips, &programmed_words, rotary, state, out),
        }
        if vector_mode {
            self.write_vector(pass, cx, &last, state, out);
        }
        if let Some(kept) = &self.kept {
            self.write_centre(pass, cx, kept, state, out);
        } else if self.tip_arc.is_some() {
            // The arc's own line is the last straight piece.
            super::arcs::straighten(cx, out, !self.pieces.is_empty());
            state.straightened = true;
            out.summary.note_arc(cx.line.number, self.pieces.len());
        }
        // What the controller commands for what is written.
        let ctrl = self
            .controller_at(pass, state, &Vector3::from(state.tip_written), end)
            .unwrap_or(last.ctrl);
        for (v, &x) in ctrl.iter().enumerate().take(n) {
            state.emitted[v] = x;
            state.written[v] = Position::Decimal {
                value: x,
                decimals: state.decimals[v],
                unit: Unit::MM,
            };
        }
        Ok(())
    }
}

/// `x` as written with `d` decimals.
pub(super) fn round(x: f64, d: u8) -> f64 {
    crate::nc::number::Rounded::new(x, d).read_back()
}

impl TcpMode {
    /// The tip's arc of the block, in the modal plane, from the programmed start tip to the
    /// end its words give (the programmed tip words, `state.tip_nominal`), and that end.
    fn tip_arc(
        &self,
        cx: &Cx<'_, '_>,
        state: &State,
        clockwise: bool,
    ) -> Result<(TipArc, Vector3<f64>), Diagnostic> {
        let col = cx
            .motion
            .arc_code
            .map_or_else(|| cx.first_col(), |i| cx.col(i));
        let refuse = |why: String| cx.refuse(col, format!("this arc cannot be compensated: {why}"));
        // The tip components of the plane's two axes and of the third.
        let Some((plane, _)) = plane_letters(state.modal.plane) else {
            return Err(refuse("arcs in a U/V/W plane are not supported".into()));
        };
        let component = |letter: u8| usize::from(letter - b'X');
        let (a, b) = (component(plane[0]), component(plane[1]));
        let c = component(plane_third(state.modal.plane));
        if state.modal.inverse_time && cx.word(b'F').is_none() {
            return Err(refuse(
                "in inverse-time feed (G93) an arc needs its own F word".into(),
            ));
        }
        if cx.word(b'P').is_some() {
            return Err(refuse("a P word (several turns) is not supported".into()));
        }
        let at = |t: &Vector3<f64>| [t[a], t[b], t[c]];
        let words = Vector3::from(state.tip_nominal);
        let (e, circle) = plane_arc(
            cx.tokens,
            cx.motion,
            &state.modal,
            clockwise,
            at(&self.tip0),
            at(&words),
        )
        .map_err(refuse)?;
        let mut end = words;
        end[a] = e[0];
        end[b] = e[1];
        end[c] = e[2];
        Ok((
            TipArc {
                a,
                b,
                centre: circle.centre,
                r0: circle.r0,
                r1: circle.r1,
                th0: circle.th0,
                sweep: circle.sweep,
            },
            end,
        ))
    }

    /// The programmed tip (in the part frame) and nominal axis values at parameter `s` of
    /// the move: the tip words on their line or arc, the rotary axes in proportion (the
    /// linear axes at `s` in proportion too: a guess for the inverse kinematics).
    fn programmed_at(
        &self,
        pass: &Pass<'_>,
        s: f64,
        state: &State,
    ) -> (Vector3<f64>, [f64; MAX_AXES]) {
        let n = pass.kin.len();
        let tip1 = Vector3::from(state.tip_nominal);
        let mut tip = self.tip0 + (tip1 - self.tip0) * s;
        if let Some(arc) = &self.tip_arc {
            let th = arc.th0 + arc.sweep * s;
            let r = arc.r0 + (arc.r1 - arc.r0) * s;
            tip[arc.a] = arc.centre.0 + r * th.cos();
            tip[arc.b] = arc.centre.1 + r * th.sin();
        }
        let tip = self.part(&tip);
        let mut q = [0.0; MAX_AXES];
        for (v, x) in q.iter_mut().enumerate().take(n) {
            *x = self.q0[v] + (state.pos.nominal[v] - self.q0[v]) * s;
        }
        (tip, q)
    }

    /// The nominal pose at parameter `s`: the programmed tip, the direction of the rotary
    /// axes there (the nominal linear axes only translate).
    fn target_at(&self, pass: &Pass<'_>, s: f64, state: &State) -> Pose {
        let n = pass.kin.len();
        let (tip, q) = self.programmed_at(pass, s, state);
        let (pose, _) = pass.kin.pose(Model::Nominal, &q[..n], state.modal.length);
        Pose { p: tip, o: pose.o }
    }

    /// The block's compensated point at parameter `s` (solved with the guards), as it will
    /// be written, after `prev`.
    fn point(
        &self,
        pass: &Pass<'_>,
        cx: &Cx<'_, '_>,
        s: f64,
        hold: u32,
        state: &mut State,
    ) -> Result<End, Diagnostic> {
        let n = pass.kin.len();
        let (tip, guess) = self.programmed_at(pass, s, state);
        let nominal = pass.kin.tcp_axes_with_rotaries(
            &tip,
            &guess[..n],
            state.modal.length,
            &pass.options.solve,
        );
        let (sol, _) = pass.solve(&nominal.q, hold, cx, state)?;
        Ok(self.written_end(pass, s, &sol, state))
    }

    /// The block's point at parameter `s` for the solution `sol`: the tip and rotary values
    /// or vector as written, and the axis values the controller commands for them.
    fn written_end(&self, pass: &Pass<'_>, s: f64, sol: &Solution, state: &State) -> End {
        let n = pass.kin.len();
        let inch = state.modal.inch;
        let (programmed, _) = pass
            .kin
            .pose(Model::Nominal, sol.values(), state.modal.length);
        let words = self.words(&programmed.p);
        let mut tip = Vector3::zeros();
        for (c, &v) in self.tips.iter().enumerate() {
            let d = state.decimals[v].max(pass.res_decimals(v, Unit::inch(inch)));
            tip[c] = if inch {
                round(words[c] / INCH, d) * INCH
            } else {
                round(words[c], d)
            };
        }
        let mut guess = sol.q;
        let mut vector = state.vector_written;
        if state.modal.tcp_vector {
            let decimals = self.vector_decimals(pass, &programmed, sol, state);
            for (c, x) in vector.iter_mut().enumerate() {
                *x = round(programmed.o[c] * self.scale, decimals);
            }
        } else if self.frame.is_none() {
            // Rotary words as written; under a plane they stand where G53.1 put them.
            for (v, x) in guess.iter_mut().enumerate().take(n) {
                if pass.kin.kind(v) == AxisKind::Rotary {
                    *x = round(*x, state.decimals[v].max(pass.decimals.1));
                }
            }
        }
        let ctrl = self
            .controller(pass, state, &tip, &vector, &guess)
            .unwrap_or(sol.q);
        End {
            s,
            ctrl,
            tip,
            vector,
            solution: Some(*sol),
        }
    }

    /// The axis values the controller commands for the written `tip` and rotary values
    /// (G43.4: `rotary`'s rotary entries) or `vector` (G43.5, from where the axes stand).
    fn controller(
        &self,
        pass: &Pass<'_>,
        state: &State,
        tip: &Vector3<f64>,
        vector: &[f64; 3],
        rotary: &[f64; MAX_AXES],
    ) -> Option<[f64; MAX_AXES]> {
        let n = pass.kin.len();
        if state.modal.tcp_vector {
            let o = Vector3::from(*vector);
            let norm = o.norm();
            if norm.is_nan() || norm <= 1e-9 {
                return None;
            }
            let target = Pose {
                p: *tip,
                o: o / norm,
            };
            pass.controller_ik(&target, rotary, state.modal.length)
        } else {
            let sol = pass.kin.tcp_axes_with_rotaries(
                &self.part(tip),
                &rotary[..n],
                state.modal.length,
                &pass.options.solve,
            );
            (sol.position_residual <= 1e-6).then_some(sol.q)
        }
    }

    /// What the controller commands for the words written in the block itself: under
    /// G43.4 the written rotary values (already in `State::emitted`), under G43.5 the
    /// solution nearest where the axes stand (`State::emitted`, the previous block's).
    fn controller_at(
        &self,
        pass: &Pass<'_>,
        state: &State,
        tip: &Vector3<f64>,
        end: &Solution,
    ) -> Option<[f64; MAX_AXES]> {
        let mut from = end.q;
        for (v, x) in from.iter_mut().enumerate().take(pass.kin.len()) {
            if pass.kin.kind(v) == AxisKind::Rotary || state.modal.tcp_vector {
                *x = state.emitted[v];
            }
        }
        self.controller(pass, state, tip, &state.vector_written, &from)
    }

    /// Decimals for the tool vector of `sol` (whose nominal pose is `programmed`): the
    /// fewest from the machine's rotary resolution up that make the controller's solve of
    /// the written vector land the rotary axes within half the resolution of `sol`'s.
    fn vector_decimals(
        &self,
        pass: &Pass<'_>,
        programmed: &Pose,
        sol: &Solution,
        state: &State,
    ) -> u8 {
        let n = pass.kin.len();
        let base = decimals_for(pass.machine.resolution.rotary.to_radians());
        let half = pass.machine.resolution.rotary / 2.0;
        for d in base..=MAX_VECTOR_DECIMALS {
            let mut o = Vector3::zeros();
            for c in 0..3 {
                o[c] = round(programmed.o[c] * self.scale, d);
            }
            let Some(norm) = Some(o.norm()).filter(|x| *x > 1e-9) else {
                continue;
            };
            let target = Pose {
                p: programmed.p,
                o: o / norm,
            };
            if let Some(q) = pass.controller_ik(&target, &sol.q, state.modal.length)
                && (0..n).all(|v| {
                    pass.kin.kind(v) != AxisKind::Rotary || (q[v] - sol.q[v]).abs() <= half
                })
            {
                return d;
            }
        }
        MAX_VECTOR_DECIMALS
    }

    /// The words of the tool vector (G43.5): at the programmed vector's length, so that
    /// unchanged components keep their text. A block that gives any of I, J, K gives the
    /// vector (an omitted component is 0); a block that gives none keeps the previous one.
    fn write_vector(
        &self,
        pass: &Pass<'_>,
        cx: &Cx<'_, '_>,
        last: &End,
        state: &mut State,
        out: &mut Out<'_>,
    ) {
        let vector_words = &cx.motion.arc_words[..3];
        let given = vector_words.iter().any(Option::is_some);
        let decimals = |c: usize| {
            let own = vector_words[c].map_or(0, |i| cx.number(i).1);
            let needed = (0..=MAX_VECTOR_DECIMALS)
                .find(|&d| {
                    same_text(
                        last.vector[c],
                        round(last.vector[c], d),
                        MAX_VECTOR_DECIMALS,
                    )
                })
                .unwrap_or(MAX_VECTOR_DECIMALS);
            own.max(needed)
                .max(decimals_for(pass.machine.resolution.rotary.to_radians()))
        };
        let changed = (0..3).any(|c| {
            let old = vector_words[c].map_or(state.vector_written[c], |i| cx.number(i).0);
            !same_text(old, last.vector[c], decimals(c))
        });
        let mut editor = cx.editor(out.edits);
        let mut missing: Vec<(usize, String)> = Vec::new();
        for (c, word) in vector_words.iter().enumerate() {
            let d = decimals(c);
            let value = last.vector[c];
            match *word {
                Some(i) => {
                    if editor.set_fixed(i, value, d) {
                        out.summary.words_changed += 1;
                    }
                }
                None if given && same_text(0.0, value, d) => {}
                None if !given && !changed => {}
                None => {
                    let mut text = String::new();
                    write_fixed(value, d, &mut text);
                    missing.push((c, text));
                }
            }
        }
        if !given && !changed {
            return;
        }
        state.vector_written = last.vector;
        if !missing.is_empty() {
            let end = cx
                .motion
                .axis_words
                .iter()
                .chain(&cx.motion.arc_words[..3])
                .flatten()
                .map(|&i| cx.tokens[i].span.end)
                .max()
                .unwrap_or(0);
            let style = editor.style();
            let mut text = String::new();
            for (c, number) in &missing {
                text.push_str(style.separator);
                text.push_str(&vector_word(&style, state.modal.dialect, *c, number));
            }
            out.edits.push(crate::nc::Edit {
                at: end..end,
                text: text.into_bytes(),
            });
            out.summary.words_added += missing.len();
        }
    }

    /// Split the part of the move from `a` to `b` where the real machine, following the
    /// controller's interpolation of the written words, strays from the nominal path: the
    /// points after `a`, in order, `b` last.
    #[allow(clippy::too_many_arguments)]
    fn split(
        &self,
        pass: &Pass<'_>,
        cx: &Cx<'_, '_>,
        tol: &PathTolerance,
        a: End,
        b: End,
        hold: u32,
        depth: u32,
        state: &mut State,
        out: &mut Vec<End>,
    ) -> Result<(), Diagnostic> {
        let budget = MOVE_PIECES << tol.max_depth;
        if depth >= tol.max_depth || out.len() >= budget || self.within(pass, tol, &a, &b, state) {
            out.push(b);
            return Ok(());
        }
        let mid = self.point(pass, cx, 0.5 * (a.s + b.s), hold, state)?;
        self.split(pass, cx, tol, a, mid, hold, depth + 1, state, out)?;
        self.split(pass, cx, tol, mid, b, hold, depth + 1, state, out)
    }

    /// Whether the controller's move from `a` to `b` stays within `tol` of the nominal path
    /// at its quarter points.
    fn within(
        &self,
        pass: &Pass<'_>,
        tol: &PathTolerance,
        a: &End,
        b: &End,
        state: &State,
    ) -> bool {
        let n = pass.kin.len();
        let length = state.modal.length;
        for u in [0.25, 0.5, 0.75] {
            let s = a.s + (b.s - a.s) * u;
            let target = self.target_at(pass, s, state);
            // The controller: the tip on a straight line, the rotary axes in proportion.
            let tip = self.part(&(a.tip + (b.tip - a.tip) * u));
            let mut q = [0.0; MAX_AXES];
            for (v, x) in q.iter_mut().enumerate().take(n) {
                *x = a.ctrl[v] + (b.ctrl[v] - a.ctrl[v]) * u;
            }
            let ctrl = pass
                .kin
                .tcp_axes_with_rotaries(&tip, &q[..n], length, &pass.options.solve);
            let (actual, _) = pass.kin.pose(Model::Actual, ctrl.values(), length);
            if (actual.p - target.p).norm() > tol.position {
                return false;
            }
            let (_, jac) = pass.kin.pose_and_jacobian(Model::Nominal, &q[..n], length);
            let singular =
                pass.kin
                    .singular_axes(&target, &jac.axis_dir, pass.options.solve.singular_angle);
            // Under a plane the rotary axes are held: the direction error is the pose's,
            // reported, and no split changes it.
            if singular == 0
                && self.frame.is_none()
                && angle_between(&actual.o, &target.o) > tol.direction
            {
                return false;
            }
        }
        true
    }

    /// Insert the pieces before the line, as TCP blocks in the block's style, and follow
    /// what the controller is told at each.
    fn insert(&self, pass: &Pass<'_>, cx: &Cx<'_, '_>, state: &mut State, out: &mut Out<'_>) {
        let inch = state.modal.inch;
        let mut editor = cx.editor(out.edits);
        let style = editor.style();
        let numbers = editor.inserted_numbers(state.last_n, self.pieces.len());
        let tnc = state.modal.dialect == crate::nc::Dialect::Heidenhain;
        let ending = Editor::ending(cx.line.ending);
        let f_word = cx.word(b'F');
        let mut text = String::new();
        for (k, piece) in self.pieces.iter().enumerate() {
            let mut words: Vec<String> = Vec::new();
            if tnc {
                words = heidenhain::inserted_start(cx.line.content, cx.tokens, state.renumber, k);
            } else if let Some(number) = &numbers[k] {
                words.push(style.word(b'N', number));
            }
            if k == 0 && !tnc {
                // The block's own modal words, so the pieces run as the block would.
                for ti in gcode::carried_words(cx.tokens, cx.motion.arc_code) {
                    words.push(String::from_utf8_lossy(editor.text(ti)).into_owned());
                }
                if self.tip_arc.is_some() {
                    words.push(gcode::linear_code(&style));
                }
            }
            for &v in &pass.write_order {
                let tip_c = self.tips.iter().position(|&t| t == v);
                let (value, before, d) = match tip_c {
                    Some(c) => {
                        let d = state.decimals[v].max(pass.res_decimals(v, Unit::inch(inch)));
                        let f = if inch { INCH } else { 1.0 };
                        (piece.tip[c] / f, state.tip_written[c] / f, d)
                    }
                    None if state.modal.tcp_vector || self.frame.is_some() => continue,
                    None => (
                        piece.ctrl[v],
                        state.emitted[v],
                        state.decimals[v].max(pass.decimals.1),
                    ),
                };
                if same_text(before, value, d) {
                    continue;
                }
                let mut number = String::new();
                write_fixed(value, d, &mut number);
                words.push(style.word(pass.letter(v), &number));
            }
            if state.modal.tcp_vector
                && (0..3).any(|c| {
                    !same_text(
                        state.vector_written[c],
                        piece.vector[c],
                        MAX_VECTOR_DECIMALS,
                    )
                })
            {
                for c in 0..3 {
                    let mut number = String::new();
                    let x = piece.vector[c];
                    let d = (0..=MAX_VECTOR_DECIMALS)
                        .find(|&d| same_text(x, round(x, d), MAX_VECTOR_DECIMALS))
                        .unwrap_or(MAX_VECTOR_DECIMALS)
                        .max(decimals_for(pass.machine.resolution.rotary.to_radians()));
                    write_fixed(x, d, &mut number);
                    words.push(vector_word(&style, state.modal.dialect, c, &number));
                }
                state.vector_written = piece.vector;
            }
            if tnc {
                for i in heidenhain::carried_words(cx.tokens) {
                    words.push(String::from_utf8_lossy(editor.text(i)).into_owned());
                }
            }
            if k == 0
                && let Some(f) = f_word
            {
                words.push(String::from_utf8_lossy(editor.text(f)).into_owned());
            }
            for c in 0..3 {
                state.tip_written[c] = piece.tip[c];
            }
            state.emitted = piece.ctrl;
            if let Some(sol) = &piece.solution {
                pass.record(cx.line.number, sol, state, out.summary);
            }
            let _ = write!(text, "{}{}", words.join(style.separator), ending);
        }
        if self.tip_arc.is_none() {
            out.summary.note_split(cx.line.number, self.pieces.len());
        }
        editor.insert_blocks(text);
    }
}

impl TcpMode {
    /// An arc in a working plane kept as an arc: where the control's arc through the
    /// written start and the compensated end, about the centre of the circle through them
    /// and the compensated middle (a full circle: its thirds), with the third word linear
    /// along it, keeps the real tip within the path tolerance of the nominal arc, the
    /// centre as it will be written; `None` for straight pieces. Polar arcs (CP) and arcs
    /// of more than a turn are not kept.
    fn keep_plane_arc(
        &self,
        pass: &Pass<'_>,
        cx: &Cx<'_, '_>,
        state: &mut State,
        start: &End,
        end: &End,
        hold: u32,
    ) -> Result<Option<KeptCentre>, Diagnostic> {
        let (Some(arc), Some(frame)) = (self.tip_arc, self.frame) else {
            return Ok(None);
        };
        if arc.sweep.abs() > TAU + 1e-9 {
            return Ok(None);
        }
        let n = pass.kin.len();
        let length = state.modal.length;
        let tol = pass
            .path_tolerance(state)
            .unwrap_or_else(|| pass.path_tolerance_or_default(state));
        let full = arc.sweep.abs() > TAU - 1e-9;
        // The middle as solved (not rounded: with no errors it lies on the programmed
        // circle, and the centre comes out as programmed).
        let solved = |e: &End| {
            e.solution
                .map(|sol| self.words(&pass.kin.pose(Model::Nominal, sol.values(), length).0.p))
        };
        let (s1, s2) = if full {
            (1.0 / 3.0, 2.0 / 3.0)
        } else {
            (0.5, 1.0)
        };
        let m1 = self.point(pass, cx, s1, hold, state)?;
        let Some(m1) = solved(&m1) else {
            return Ok(None);
        };
        // A TNC arc written as CP ends where its angle puts it, not at end words: it aims
        // at the end as solved, not as end words would round it.
        let polar = cx.motion.centre.is_some() && self.polar_form(pass, cx, state, start, end);
        let aim = match solved(end) {
            Some(e) if polar => e,
            _ => end.tip,
        };
        let m2 = if full {
            let m2 = self.point(pass, cx, s2, hold, state)?;
            match solved(&m2) {
                Some(m) => m,
                None => return Ok(None),
            }
        } else {
            aim
        };
        if end.solution.is_none_or(|sol| pass.missed(&sol)) {
            return Ok(None);
        }
        let (a, b) = (arc.a, arc.b);
        let plane = |t: &Vector3<f64>| (t[a], t[b]);
        let Some(centre) = circle_centre([plane(&start.tip), plane(&m1), plane(&m2)]) else {
            return Ok(None);
        };
        let inch = state.modal.inch;
        let unit = if inch { INCH } else { 1.0 };
        let centre_unit = Unit::inch(inch);
        let [va, vb] = [self.tips[a], self.tips[b]];
        let d_centre = |v: usize| pass.res_decimals(v, centre_unit);
        let clockwise = arc.sweep < 0.0;
        let (start_p, end_p) = (plane(&start.tip), plane(&aim));
        // The centre words as written, and the centre the control takes from them.
        let (kept, written_centre) = if let Some(pole) = cx.motion.centre {
            // A TNC arc about its pole: a CC block before it, absolute, unless the
            // control holds that pole already.
            let held = match (state.pole_written, current_pole(state)) {
                (Some((seq, w)), Some(now)) if seq == now => w,
                _ => pole,
            };
            let d = [d_centre(va), d_centre(vb)];
            let step = |k: usize| 10f64.powi(-i32::from(d[k]));
            let fitted = [centre.0, centre.1];
            let same = (0..2).all(|k| same_text(held[k] / unit, fitted[k] / unit, d[k]));
            let value = if same {
                held
            } else {
                // The pole as written: of the values within three digits of the fitted
                // centre the one about which the control's arc ends nearest the end (a
                // CP's end lies at the start's radius, at its angle rounded as written; a
                // C's written end at a radius the start's should match), then the nearest.
                let rounded = [0, 1].map(|k| round(fitted[k] / unit, d[k]));
                let absolute = matches!(cx.motion.polar, Some((_, false)));
                let miss = |c: [f64; 2]| {
                    let r0 = (start_p.0 - c[0]).hypot(start_p.1 - c[1]);
                    let r1 = (end_p.0 - c[0]).hypot(end_p.1 - c[1]);
                    if !polar {
                        return (r0 - r1).abs();
                    }
                    let th0 = (start_p.1 - c[1]).atan2(start_p.0 - c[0]);
                    let th1 = (end_p.1 - c[1]).atan2(end_p.0 - c[0]);
                    let sweep = th1 - th0 + TAU * ((arc.sweep - (th1 - th0)) / TAU).round();
                    let theta = if absolute {
                        round((th0 + sweep).to_degrees(), ANGLE_DECIMALS).to_radians()
                    } else {
                        th0 + round(sweep.to_degrees(), ANGLE_DECIMALS).to_radians()
                    };
                    (c[0] + r0 * theta.cos() - end_p.0).hypot(c[1] + r0 * theta.sin() - end_p.1)
                };
                let mut best = (f64::INFINITY, f64::INFINITY, [0.0; 2]);
                for di in -3i32..=3 {
                    for dj in -3i32..=3 {
                        let c = [
                            (rounded[0] + f64::from(di) * step(0)) * unit,
                            (rounded[1] + f64::from(dj) * step(1)) * unit,
                        ];
                        let key = (miss(c), (c[0] - fitted[0]).hypot(c[1] - fitted[1]));
                        if key.0 < best.0 - 1e-12 || (key.0 <= best.0 + 1e-12 && key.1 < best.1) {
                            best = (key.0, key.1, c);
                        }
                    }
                }
                best.2
            };
            let mut words: Vec<(u8, String)> = (0..2)
                .map(|k| {
                    let mut text = String::new();
                    write_fixed(value[k] / unit, d[k], &mut text);
                    (pass.letter([va, vb][k]), text)
                })
                .collect();
            words.sort_by_key(|(letter, _)| *letter);
            (
                KeptCentre::Pole((!same).then_some(words), value, None),
                (value[0], value[1]),
            )
        } else if let Some(ri) = cx.motion.arc_words[3] {
            if state.modal.dialect == crate::nc::Dialect::Heidenhain
                && self.needs_third(pass, cx, state, start, end)
            {
                // A TNC CR whose end needs the third coordinate it does not give: a
                // helix in Cartesian form, which not every TNC reads.
                return Ok(None);
            }
            let (old, decimals, _) = cx.number(ri);
            let radius = (start_p.0 - centre.0).hypot(start_p.1 - centre.1) / unit;
            let d = decimals.max(d_centre(va));
            let new = radius.copysign(old);
            let mut text = String::new();
            write_fixed(new, d, &mut text);
            let Ok(r) = text.parse::<f64>() else {
                return Ok(None);
            };
            let mut words = Vec::new();
            if !same_text(old, new, d) {
                words.push((Ok(ri), text));
            }
            let Ok(from_r) = circle(start_p, end_p, clockwise, Centre::Radius(r * unit), false)
            else {
                return Ok(None);
            };
            (KeptCentre::Words(words), from_r.centre)
        } else {
            let Some((_, centre_letters)) = plane_letters(state.modal.plane) else {
                return Ok(None);
            };
            let origin = if state.modal.arc_absolute {
                (0.0, 0.0)
            } else {
                start_p
            };
            let mut words = Vec::new();
            let mut written = [0.0; 2];
            for k in 0..2 {
                let letter = centre_letters[k];
                let Some(slot) = b"IJK".iter().position(|&l| l == letter) else {
                    return Ok(None);
                };
                let index = cx.motion.arc_words[slot];
                let offset = ([centre.0, centre.1][k] - [origin.0, origin.1][k]) / unit;
                let res = d_centre([va, vb][k]);
                let (old, d) = match index.map(|i| cx.number(i)) {
                    Some((old, decimals, _)) => (Some(old), decimals.max(res)),
                    None => (None, res),
                };
                let mut text = String::new();
                write_fixed(offset, d, &mut text);
                let Ok(x) = text.parse::<f64>() else {
                    return Ok(None);
                };
                written[k] = x * unit;
                match (index, old) {
                    (Some(i), Some(old)) if !same_text(old, offset, d) => words.push((Ok(i), text)),
                    (None, _) if !same_text(0.0, offset, d) => words.push((Err(letter), text)),
                    _ => {}
                }
            }
            (
                KeptCentre::Words(words),
                (origin.0 + written[0], origin.1 + written[1]),
            )
        };
        // The arc the control runs: from the written start to the written end about the
        // written centre, the way its direction turns (a polar arc: by its angle, to where
        // that angle ends it).
        let Ok(mut ctrl) = circle(
            start_p,
            end_p,
            clockwise,
            Centre::Offsets(Some(written_centre.0), Some(written_centre.1)),
            true,
        ) else {
            return Ok(None);
        };
        let mut ctrl_end = end.tip;
        let kept = match kept {
            KeptCentre::Pole(words, value, _) if polar => {
                // The sweep nearest the programmed one: whole turns are the angle's.
                let sweep = ctrl.sweep + TAU * ((arc.sweep - ctrl.sweep) / TAU).round();
                let absolute = matches!(cx.motion.polar, Some((_, false)));
                let r0 = ctrl.r0;
                let (angle, theta) = if absolute {
                    let deg = round((ctrl.th0 + sweep).to_degrees(), ANGLE_DECIMALS);
                    (format!("PA{deg:+.4}"), deg.to_radians())
                } else {
                    let deg = round(sweep.to_degrees(), ANGLE_DECIMALS);
                    (format!("IPA{deg:+.4}"), ctrl.th0 + deg.to_radians())
                };
                ctrl_end[a] = written_centre.0 + r0 * theta.cos();
                ctrl_end[b] = written_centre.1 + r0 * theta.sin();
                let third = usize::from(plane_third(state.modal.plane) - b'X');
                let vc = self.tips[third];
                let given = cx.motion.axis_words[vc].is_some();
                let mut lead = None;
                if !given {
                    let d = state.decimals[vc].max(pass.res_decimals(vc, Unit::inch(inch)));
                    let rise = round((aim[third] - start.tip[third]) / unit, d);
                    ctrl_end[third] = start.tip[third] + rise * unit;
                    if cx.motion.lead.is_some() || !same_text(rise, 0.0, d) {
                        let mut text = String::new();
                        write_fixed(rise, d, &mut text);
                        if !text.starts_with('-') {
                            text.insert(0, '+');
                        }
                        lead = Some(format!("I{}{text}", plane_third(state.modal.plane) as char));
                    }
                }
                ctrl = crate::program::arc::Circle {
                    r1: r0,
                    // IPA turns by itself; PA the way DR turns, at most a turn.
                    sweep: if absolute {
                        commanded_sweep(ctrl.th0, theta, clockwise)
                    } else {
                        theta - ctrl.th0
                    },
                    ..ctrl
                };
                KeptCentre::Pole(
                    words,
                    value,
                    Some(Polar {
                        angle,
                        lead,
                        end: ctrl_end,
                    }),
                )
            }
            other => other,
        };
        if (ctrl.sweep - arc.sweep).abs() > 0.1 {
            return Ok(None);
        }
        // Where the written ends lie within their rounding of the same angle about the
        // centre (a sweep near 0 or a full turn), which way round the control goes hangs on
        // the last digit: not kept.
        let half_unit = |d: u8| 0.5 * unit * 10f64.powi(-i32::from(d));
        let rounding = [va, vb]
            .iter()
            .map(|&v| {
                let d = state.decimals[v].max(pass.res_decimals(v, Unit::inch(inch)));
                half_unit(d) + half_unit(d_centre(v))
            })
            .fold(0.0f64, f64::max)
            * std::f64::consts::SQRT_2
            * 2.0;
        let margin = rounding / ctrl.r0.min(ctrl.r1).max(1e-9);
        if !full && (ctrl.sweep.abs() <= margin || ctrl.sweep.abs() >= TAU - margin) {
            return Ok(None);
        }
        // The control's arc against the nominal one, at the quarter points and between:
        // the real tip's distance from the nominal arc (its closest point nearby).
        let rotaries = start.ctrl;
        let nominal_at = |s: f64| self.target_at(pass, s, state).p;
        let samples = (0..32)
            .map(|k| (k as f64 + 0.5) / 32.0)
            .chain([0.25, 0.5, 0.75]);
        for s in samples {
            let th = ctrl.th0 + ctrl.sweep * s;
            let r = ctrl.r0 + (ctrl.r1 - ctrl.r0) * s;
            let mut w = start.tip + (ctrl_end - start.tip) * s;
            w[a] = ctrl.centre.0 + r * th.cos();
            w[b] = ctrl.centre.1 + r * th.sin();
            let Some(q) = pass.plane_axes(&frame, &w, &rotaries, length) else {
                return Ok(None);
            };
            let (actual, _) = pass.kin.pose(Model::Actual, &q[..n], length);
            let mut closest = s;
            let mut distance = f64::INFINITY;
            for _ in 0..2 {
                let h = 1e-4;
                let p = nominal_at(closest);
                let (lo, hi) = ((closest - h).max(0.0), (closest + h).min(1.0));
                let tangent = (nominal_at(hi) - nominal_at(lo)) / (hi - lo).max(f64::EPSILON);
                let step = (actual.p - p).dot(&tangent) / tangent.norm_squared().max(1e-300);
                closest = (closest + step).clamp(0.0, 1.0);
                distance = (nominal_at(closest) - actual.p).norm();
            }
            if distance.is_nan() || distance > tol.position {
                return Ok(None);
            }
        }
        Ok(Some(kept))
    }

    /// Whether a TNC arc's written end needs the coordinate along the axis perpendicular
    /// to its plane that the block does not give (the compensated end's differs from the
    /// written start's).
    fn needs_third(
        &self,
        pass: &Pass<'_>,
        cx: &Cx<'_, '_>,
        state: &State,
        start: &End,
        end: &End,
    ) -> bool {
        let third = usize::from(plane_third(state.modal.plane) - b'X');
        let v = self.tips[third];
        if cx.motion.axis_words[v].is_some() || cx.motion.lead.is_some() {
            return false;
        }
        let inch = state.modal.inch;
        let unit = if inch { INCH } else { 1.0 };
        let d = state.decimals[v].max(pass.res_decimals(v, Unit::inch(inch)));
        !same_text(start.tip[third] / unit, end.tip[third] / unit, d)
    }

    /// Whether a kept TNC arc about its pole is written as `CP`: a CP of the program, or
    /// a C whose end needs the third coordinate (a helix: every TNC reads it in polar
    /// form, `CP IPA… IZ…`; the Cartesian form only some).
    fn polar_form(
        &self,
        pass: &Pass<'_>,
        cx: &Cx<'_, '_>,
        state: &State,
        start: &End,
        end: &End,
    ) -> bool {
        cx.motion.polar.is_some() || self.needs_third(pass, cx, state, start, end)
    }

    /// Write a kept TNC arc as `CP`: its angle, its helix's height (IZ, or the third
    /// axis's word the block gives), and no end words in the plane (the angle ends it).
    fn write_polar(
        &self,
        pass: &Pass<'_>,
        cx: &Cx<'_, '_>,
        polar: &Polar,
        programmed_words: &Vector3<f64>,
        state: &mut State,
        out: &mut Out<'_>,
    ) {
        let inch = state.modal.inch;
        let unit = if inch { INCH } else { 1.0 };
        let third = usize::from(plane_third(state.modal.plane) - b'X');
        let mut editor = cx.editor(out.edits);
        let text = |i: usize| &cx.line.content[cx.tokens[i].span.clone()];
        let other = |pred: &dyn Fn(&[u8]) -> bool| {
            (0..cx.tokens.len())
                .find(|&i| cx.tokens[i].kind == crate::nc::TokenKind::Other && pred(text(i)))
        };
        let direction = other(&|t| t.starts_with(b"DR"));
        let angle = other(&|t| t.starts_with(b"IPA") || t.starts_with(b"PA"));
        let lead = other(&|t| {
            cx.motion.lead.is_some()
                && t.len() > 2
                && t[0] == b'I'
                && t[1] == plane_third(state.modal.plane)
        });
        if let Some(k) = cx.motion.arc_code
            && text(k) != b"CP"
        {
            editor.replace_token(k, b"CP");
        }
        let separator = editor.style().separator;
        let mut put =
            |at: Option<usize>, new: &str, editor: &mut crate::nc::edit::Editor<'_>| match at {
                Some(i) if text(i) != new.as_bytes() => {
                    editor.replace_token(i, new.as_bytes());
                    out.summary.words_changed += 1;
                }
                Some(_) => {}
                None => {
                    if let Some(dr) = direction {
                        editor.insert_before_word(dr, &format!("{new}{separator}"));
                        out.summary.words_added += 1;
                    }
                }
            };
        put(angle, &polar.angle, &mut editor);
        if let Some(new) = &polar.lead {
            put(lead, new, &mut editor);
        }
        for c in 0..3 {
            let v = self.tips[c];
            match cx.motion.axis_words[v] {
                // The third axis's word of a CP: its end, absolute.
                Some(i) if c == third => {
                    let d = cx.number(i).1.max(pass.res_decimals(v, Unit::inch(inch)));
                    state.decimals[v] = d;
                    if editor.set_fixed(i, programmed_words[c] / unit, d) {
                        out.summary.words_changed += 1;
                    }
                    state.tip_written[c] = round(programmed_words[c] / unit, d) * unit;
                }
                // A C's end in its plane: the angle gives it now.
                Some(i) => {
                    editor.remove_word(i);
                    state.tip_written[c] = polar.end[c];
                }
                None => state.tip_written[c] = polar.end[c],
            }
        }
    }

    /// Write a kept arc's centre: its words, or the CC block before it.
    fn write_centre(
        &self,
        pass: &Pass<'_>,
        cx: &Cx<'_, '_>,
        kept: &KeptCentre,
        state: &mut State,
        out: &mut Out<'_>,
    ) {
        match kept {
            KeptCentre::Words(words) => {
                for (word, _) in words {
                    match word {
                        Ok(_) => out.summary.words_changed += 1,
                        Err(_) => out.summary.words_added += 1,
                    }
                }
                pass.centre_edits(cx, words, out);
            }
            KeptCentre::Pole(words, value, _) => {
                if let Some(words) = words {
                    let mut editor = cx.editor(out.edits);
                    let style = editor.style();
                    let mut block =
                        heidenhain::inserted_start(cx.line.content, cx.tokens, state.renumber, 0);
                    if let Some(keyword) = block.last_mut() {
                        *keyword = "CC".into();
                    }
                    for (letter, number) in words {
                        block.push(style.word(*letter, number));
                    }
                    let ending = Editor::ending(cx.line.ending);
                    editor.insert_blocks(format!("{}{ending}", block.join(style.separator)));
                    out.summary.words_added += words.len();
                    out.summary.arc_poles += 1;
                }
                if let Some(seq) = current_pole(state) {
                    state.pole_written = Some((seq, *value));
                }
            }
        }
        if cx.motion.arc_code.is_none() && state.straightened {
            // Modal in the original, but the output's last motion code is the G1 of a
            // straightened arc: the block says G2/G3 itself.
            super::arcs::restore_arc_code(cx, out, self.arc == Some(true));
        }
        state.straightened = false;
        out.summary.note_arc_kept();
    }
}

/// Which CC of the program gives the TNC pole in force (see [`heidenhain::Pole`]).
fn current_pole(state: &State) -> Option<u64> {
    state.modal.tnc.as_ref().and_then(|t| t.pole).map(|p| p.seq)
}

impl Pass<'_> {
    /// The variables driven by the X, Y and Z words, which TCP programs use for the tip.
    pub(super) fn tip_vars(&self) -> Option<[usize; 3]> {
        let mut vars = [0; 3];
        for (c, letter) in [b'X', b'Y', b'Z'].iter().enumerate() {
            let v = self.axes.var_of_letter[(letter - b'A') as usize]?;
            if self.kin.kind(v) != AxisKind::Linear {
                return None;
            }
            vars[c] = v;
        }
        Some(vars)
    }

    /// The rotary variables.
    pub(super) fn rotary_mask(&self) -> u32 {
        (0..self.kin.len())
            .filter(|&v| self.kin.kind(v) == AxisKind::Rotary)
            .fold(0, |m, v| m | 1 << v)
    }

    /// The controller's nominal inverse kinematics of a tip and tool direction, from the
    /// axis values `from`: the solution Newton's method reaches from there (the branch
    /// nearest it), each rotary axis a whole number of turns from where it would land so
    /// that it moves at most half a turn (within its travel where it has one); a rotary
    /// axis whose line lies along the tool direction keeps its value (Fanuc: "the master
    /// axis does not move from the current angle"). Where Newton's method does not land
    /// from `from` (a start at a singular pose, where the free axis gives no direction),
    /// the solution that moves the rotary axes least from a few starts around it.
    pub(super) fn controller_ik(
        &self,
        target: &Pose,
        from: &[f64; MAX_AXES],
        length: f64,
    ) -> Option<[f64; MAX_AXES]> {
        let n = self.kin.len();
        // A block moves the axes by degrees, not microns: more iterations than a
        // correction; singular only where the direction is along the axis to 0.1 µrad.
        let far = SolveOptions {
            max_iterations: 100,
            singular_angle: 1e-7,
            ..self.options.solve
        };
        let rotary: Vec<usize> = (0..n)
            .filter(|&v| self.kin.kind(v) == AxisKind::Rotary)
            .collect();
        let near = |mut q: [f64; MAX_AXES]| {
            for &v in &rotary {
                q[v] += 360.0 * ((from[v] - q[v]) / 360.0).round();
                if let Some([lo, hi]) = self.travel(v) {
                    if q[v] < lo && q[v] + 360.0 <= hi {
                        q[v] += 360.0;
                    } else if q[v] > hi && q[v] - 360.0 >= lo {
                        q[v] -= 360.0;
                    }
                }
            }
            q
        };
        let solve = |start: &[f64; MAX_AXES]| {
            self.kin
                .inverse(Model::Nominal, target, &start[..n], length, &far)
                .map(|sol| near(sol.q))
        };
        if let Some(q) = solve(from) {
            return Some(q);
        }
        let moved =
            |q: &[f64; MAX_AXES]| rotary.iter().map(|&v| (q[v] - from[v]).abs()).sum::<f64>();
        let mut best: Option<[f64; MAX_AXES]> = None;
        for &v in &rotary {
            for turn in [30.0, -30.0, 90.0, -90.0, 180.0] {
                let mut start = *from;
                start[v] += turn;
                if let Some(q) = solve(&start)
                    && best.is_none_or(|b| moved(&q) < moved(&b) - 1e-9)
                {
                    best = Some(q);
                }
            }
        }
        best
    }

    /// G43.4 or G43.5 switches on: from now on X, Y, Z words are the tip (and under G43.5,
    /// I, J, K the tool vector).
    pub(super) fn enter_tcp(
        &self,
        state: &mut State,
        at: &dyn Fn(usize, String) -> Diagnostic,
    ) -> Result<(), Diagnostic> {
        let code = if state.modal.tcp_vector {
            "G43.5"
        } else {
            "G43.4"
        };
        let refusal = if let Some(plane) = &state.modal.working_plane {
            if plane.rotation_only {
                "under a coordinate rotation (G68) cannot be compensated (expected G69 before it)"
            } else {
                "under a tilted working plane (G68.2) cannot be compensated (expected G69 before it)"
            }
        } else if self.turning {
            "cannot be compensated while turning: the spindle turns or has not been positioned (position it with M19 or a C word first)"
        } else if state.modal.diameter {
            "in diameter mode (G7) cannot be compensated (program it in radius mode, G8)"
        } else if self.tip_vars().is_none() {
            "needs linear axes driven by X, Y and Z words for the tool tip; this machine has none"
        } else if state.modal.incremental {
            "in incremental mode (G91) cannot be compensated (program the TCP part in G90)"
        } else {
            ""
        };
        if !refusal.is_empty() {
            return Err(at(0, format!("{code} {refusal}")));
        }
        let n = self.kin.len();
        let (nominal, _) =
            self.kin
                .pose(Model::Nominal, &state.pos.nominal[..n], state.modal.length);
        let (written, _) = self
            .kin
            .pose(Model::Nominal, &state.emitted[..n], state.modal.length);
        state.tip_nominal = nominal.p.into();
        state.tip_written = written.p.into();
        state.vector_nominal = nominal.o.into();
        state.vector_written = written.o.into();
        Ok(())
    }
}

/// Component `c` of the tool vector as a word: `I`, `J`, `K` (G43.5), or Sinumerik's `A3=`,
/// `B3=`, `C3=` (TRAORI).
fn vector_word(
    style: &crate::nc::edit::Style,
    dialect: crate::nc::Dialect,
    c: usize,
    number: &str,
) -> String {
    match dialect {
        crate::nc::Dialect::Sinumerik => {
            format!("{}3={}", style.letter(b"ABC"[c]), style.number(number))
        }
        _ => style.word(b"IJK"[c], number),
    }
}
