//! Heidenhain drilling cycles (CYCL DEF 200–203, 205–207, 209) called by M99 or CYCL CALL.
//!
//! The definition gives the levels along the tool axis (Q203 the surface, Q201 the depth
//! below it, Q200 the set-up clearance above it, Q204 the second set-up clearance); the
//! call gives the hole's X, Y (the L block that carries M99) or takes the tool's. The
//! control goes down the tool axis at the hole's X, Y and comes back: in the tilted
//! working plane under PLANE, along the plane's Z.
//!
//! As for G81 (see [`super::cycles`]) the hole is compensated at its bottom: X, Y in the
//! calling block, the depth through the surface coordinate. One definition serves many
//! holes and may not be rewritten where it stands (the control has read it), so where a
//! hole needs another surface coordinate than the one the control holds, a copy of the
//! definition with that Q203 is inserted before the call. The same check as G81's holds:
//! one X, Y must serve the whole depth, judged on the written X, Y at the set-up clearance
//! above the surface coordinate the control holds
//! ([`super::Pass::hole_axis_as_written`]).

use super::cycles::HoleAxis;
use super::lateral::Cylinder;
use super::pipeline::Out;
use super::pipeline::{Block, Cx, Mode};
use super::{Pass, State};
use crate::diag::Diagnostic;
use crate::kinematics::{MAX_AXES, Model, Solution};
use crate::model::AxisKind;
use crate::nc::Edit;
use crate::nc::edit::Editor;
use crate::nc::number::{same_text, write_fixed};
use crate::program::WorkingPlane;
use crate::program::exact::{Position, Unit};
use crate::program::heidenhain::{self, CycleDef, Param};
use crate::program::tnc_cycles::{self as cycles, HoleStep, value_at};
use nalgebra::Vector3;

/// A TNC cycle call being compensated.
#[derive(Default)]
pub(super) struct TncCycleMode {
    /// The X, Y, Z variables.
    vars: [usize; 3],
    frame: Option<WorkingPlane>,
    /// The definition called, and its levels (mm): surface, bottom, clearance, end.
    def: Option<CycleDef>,
    levels: [f64; 4],
    /// How far its motion reaches around the axis (mm): the radius, and below the bottom;
    /// and what moves it there, for messages.
    radius: f64,
    below: f64,
    around: String,
    /// The nominal values at the set-up clearance, and their solution.
    r_plane: [f64; MAX_AXES],
    r_solution: Option<Solution>,
    /// Under a plane: the bottom and the clearance point of the compensated hole, in the
    /// plane's frame (mm).
    bottom_words: Vector3<f64>,
    r_words: Vector3<f64>,
}

impl TncCycleMode {
    fn col(cx: &Cx<'_, '_>) -> usize {
        cx.motion.cycle_col.unwrap_or_else(|| cx.first_word_col())
    }

    fn refuse(cx: &Cx<'_, '_>, why: String) -> Diagnostic {
        cx.refuse(
            Self::col(cx),
            format!("this cycle call cannot be compensated: {why}"),
        )
    }

    /// The hole's axis from its set-up clearance.
    fn axis(&self, cx: &Cx<'_, '_>) -> HoleAxis<'_> {
        HoleAxis {
            top: &self.r_plane,
            frame: self.frame.as_ref(),
            col: Self::col(cx),
            level: "set-up clearance",
            instead: "program the hole as L moves",
        }
    }
}

impl Mode for TncCycleMode {
    fn target(&mut self, b: &mut Block, q: &mut [f64; MAX_AXES]) -> Result<bool, Diagnostic> {
        let (pass, cx, state, _) = b.parts();
        let var = |letter: u8| {
            pass.axes.var_of_letter[(letter - b'A') as usize]
                .filter(|&v| pass.kin.kind(v) == AxisKind::Linear)
        };
        let (Some(vx), Some(vy), Some(vz)) = (var(b'X'), var(b'Y'), var(b'Z')) else {
            return Err(Self::refuse(
                cx,
                "the machine has no linear X, Y and Z axes".into(),
            ));
        };
        self.vars = [vx, vy, vz];
        self.frame = state.modal.working_plane;
        if cx.motion.optional {
            return Err(Self::refuse(
                cx,
                "an optional block (/) with a cycle call is not supported".into(),
            ));
        }
        if state.pos.unknown != 0 {
            return Err(Self::refuse(
                cx,
                "it starts where an axis is at a place nccomp does not know (after a machine move: M91, M92 without a known reference)".into(),
            ));
        }
        let Some(def) = state.modal.called_cycle().cloned() else {
            return Err(Self::refuse(cx, "no cycle is defined".into()));
        };
        let reach = cycles::reach(&def, state.modal.inch).map_err(|why| Self::refuse(cx, why))?;
        let mut levels = reach.levels;
        if let Some(call) = def.siemens {
            levels[3] = call.end;
        }
        let zu = Unit::inch(state.modal.inch);
        self.levels = levels.map(|x| zu.to_mm(x));
        (self.radius, self.below, self.around) =
            (zu.to_mm(reach.radius), zu.to_mm(reach.below), reach.around);
        self.def = Some(def);
        let [_, bottom, clearance, _] = self.levels;
        let length = state.modal.length;
        let (q_bottom, r_plane) = if let Some(frame) = self.frame {
            pass.plane_checks(cx, state, &self.vars)?;
            for (c, &v) in self.vars[..2].iter().enumerate() {
                if let Some(i) = cx.motion.axis_words[v] {
                    state.tip_nominal[c] = zu.to_mm(cx.number(i).0);
                }
            }
            let at = |z: f64| {
                let w = Vector3::new(state.tip_nominal[0], state.tip_nominal[1], z);
                pass.plane_axes(&frame, &w, &state.pos.nominal, length)
                    .ok_or_else(|| {
                        Self::refuse(
                            cx,
                            format!(
                                "the nominal machine cannot put the tip at X{:.4} Y{:.4} Z{z:.4} of the plane with the rotary axes where they stand",
                                w.x, w.y
                            ),
                        )
                    })
            };
            (at(bottom)?, at(clearance)?)
        } else {
            // Without a tilted plane the cycle drills along the machine's Z: only where
            // the head's rotary axes leave the tool along it.
            let chain = &pass.machine.tool_chains[pass.chain].axes;
            if let Some(v) = (0..pass.kin.len()).find(|&v| {
                pass.kin.kind(v) == AxisKind::Rotary
                    && chain.contains(&pass.kin.axes()[v])
                    && state.pos.nominal[v] != 0.0
            }) {
                return Err(Self::refuse(
                    cx,
                    format!(
                        "without a tilted working plane the cycle drills along Z, and the head's axis {} stands at {:.4} (expected PLANE for a tilted hole)",
                        pass.axis_name(v),
                        state.pos.nominal[v]
                    ),
                ));
            }
            for v in [vx, vy] {
                if state.pos.programmed & (1 << v) == 0 && cx.motion.axis_words[v].is_none() {
                    return Err(Self::refuse(
                        cx,
                        format!(
                            "the program has not set {} before the cycle",
                            pass.letter(v) as char
                        ),
                    ));
                }
            }
            state.pos.advance(
                &pass.axes,
                cx.line.content,
                cx.tokens,
                cx.motion,
                &state.modal,
                cx.at,
                &mut state.units,
            )?;
            let mut q_bottom = state.pos.nominal;
            q_bottom[vz] = bottom;
            let mut r_plane = state.pos.nominal;
            r_plane[vz] = clearance;
            // The rotary axes stand where the last block left them (corrected, where it
            // corrected the tool's direction): the hole's nominal points are reached with
            // them there, so that the call writes no rotary word.
            (
                pass.standing(&q_bottom, &state.emitted, length),
                pass.standing(&r_plane, &state.emitted, length),
            )
        };
        pass.check_travel(&q_bottom, Self::col(cx), cx)?;
        pass.check_travel(&r_plane, Self::col(cx), cx)?;
        self.r_plane = r_plane;
        *q = q_bottom;
        Ok(true)
    }

    /// The rotary axes stay where they are; the linear ones take the whole correction.
    fn hold(&self, pass: &Pass<'_>) -> u32 {
        (0..pass.kin.len())
            .filter(|&v| !pass.is_linear(v))
            .fold(0, |m, v| m | 1 << v)
    }

    /// The solution at the set-up clearance (where one X, Y serves the whole depth is
    /// judged on the written words, in [`Mode::write`]).
    fn path(&mut self, b: &mut Block, end: &Solution, hold: u32) -> Result<(), Diagnostic> {
        let (pass, cx, state, _) = b.parts();
        let depth = pass.hole_top(cx, state, &self.axis(cx), end, hold, |why| {
            Self::refuse(cx, why)
        })?;
        (self.r_solution, self.bottom_words, self.r_words) = (Some(depth.0), depth.1, depth.2);
        Ok(())
    }

    /// X, Y in the calling block; the depth through a copy of the definition with the
    /// surface coordinate the hole needs, where the control's differs.
    fn write(&mut self, b: &mut Block, end: &Solution) -> Result<(), Diagnostic> {
        let (pass, cx, state, out) = b.parts();
        let Some(def) = self.def.as_ref() else {
            return Ok(());
        };
        let vz = self.vars[2];
        let zu = Unit::inch(state.modal.inch);
        let [surface, bottom, clearance, _] = self.levels;
        let given_xy = self.vars[..2]
            .iter()
            .all(|&v| cx.motion.axis_words[v].is_some());
        let corrected_bottom = match &self.frame {
            Some(_) => {
                let height = state.tip_written[2];
                let before = [state.tip_written[0], state.tip_written[1]];
                let xy = Vector3::new(self.bottom_words.x, self.bottom_words.y, height);
                pass.write_tip_words(cx, &self.vars, &xy, None, state, out);
                let moved = [state.tip_written[0], state.tip_written[1]] != before;
                if moved && !given_xy && cx.motion.axis_words.iter().all(Option::is_none) {
                    // Written out as L moves where nccomp knows the cycle's motion: they
                    // give the corrected X, Y.
                    state.hole_steps = self.written_out(state).ok();
                    return Err(Self::refuse(
                        cx,
                        "the hole needs a corrected X, Y and the call does not give them (expected L X… Y… … M99)".into(),
                    ));
                }
                self.bottom_words.z
            }
            None => {
                let mut q = end.q;
                q[vz] = state.emitted[vz];
                let emitted = state.emitted;
                pass.write_positions(cx, &q, false, state, out)?;
                if state.emitted != emitted && cx.motion.axis_words.iter().all(Option::is_none) {
                    state.hole_steps = self.written_out(state).ok();
                    return Err(Self::refuse(
                        cx,
                        "the hole needs a corrected X, Y and the call does not give them (expected L X… Y… … M99)".into(),
                    ));
                }
                end.q[vz]
            }
        };
        // The surface coordinate (a Sinumerik call: the reference plane, its absolute depth
        // moving with it) that puts the corrected bottom where the control drills.
        let (text_decimals, programmed) = surface_text(def).unwrap_or((0, zu.of_mm(surface)));
        let d = text_decimals.max(pass.res_decimals(vz, zu));
        let needed = zu.of_mm(surface + (corrected_bottom - bottom));
        let mut held = def.surface_written.unwrap_or(programmed);
        if !same_text(held, needed, d) {
            let mut number = String::new();
            write_fixed(needed, d, &mut number);
            let text = copy_with_surface(cx, def, &number, d, state.renumber);
            // Before any word inserted at the line's start (as `Editor::insert_blocks`).
            out.edits.insert(0, Edit { at: 0..0, text });
            out.summary.words_changed += 1;
            let written: f64 = number.parse().unwrap_or(needed);
            if let Some(c) = state.modal.called_cycle_mut() {
                c.surface_written = Some(written);
            }
            if let Some(d) = self.def.as_mut() {
                d.surface_written = Some(written);
            }
            held = written;
        }
        // What the control is told: the hole's bottom as the written words and surface
        // put it, and the set-up clearance it feeds from (the Sinumerik cycle's safety
        // distance above its reference plane likewise).
        let bottom_written = zu.to_mm(held) + (bottom - surface);
        let clearance_written = zu.to_mm(held) + (clearance - surface);
        let length = state.modal.length;
        let top_written = match self.frame {
            Some(frame) => {
                let tip = Vector3::new(state.tip_written[0], state.tip_written[1], bottom_written);
                if let Some(q) = pass.plane_axes(&frame, &tip, &state.emitted, length) {
                    state.emitted = q;
                }
                let tip = Vector3::new(
                    state.tip_written[0],
                    state.tip_written[1],
                    clearance_written,
                );
                pass.plane_axes(&frame, &tip, &state.emitted, length)
                    .ok_or_else(|| {
                        Self::refuse(
                            cx,
                            "the nominal machine cannot reach the set-up clearance above the corrected hole".into(),
                        )
                    })?
            }
            None => {
                state.emitted[vz] = bottom_written;
                let mut q = state.emitted;
                q[vz] = clearance_written;
                q
            }
        };
        let Some(top) = self.r_solution.as_ref() else {
            return Ok(());
        };
        // Where one X, Y cannot serve the whole depth, a hole whose motion nccomp knows is
        // written out as L moves instead (the stream runs them, `stream::Run::line`).
        let steps = self.written_out(state);
        let off =
            pass.hole_axis_as_written(state, &self.axis(cx), (end, top), &top_written, |why| {
                match &steps {
                    Ok(_) => Self::refuse(cx, why),
                    Err(no) => Self::refuse(
                        cx,
                        format!("{why}; nccomp does not write it out as L moves: {no}"),
                    ),
                }
            });
        let off = match off {
            Ok(off) => off,
            Err(d) => {
                state.hole_steps = steps.ok();
                return Err(d);
            }
        };
        if self.radius > 0.0 {
            let levels = (bottom_written - self.below, clearance_written);
            self.around_bound(pass, cx, state, out, off, levels)?;
        }
        Ok(())
    }

    /// The tool ends at the larger of the set-up clearances above the surface the control
    /// holds.
    fn after(&mut self, b: &mut Block) {
        let (pass, cx, state, _) = b.parts();
        let Some(def) = self.def.as_ref() else {
            return;
        };
        if self.radius > 0.0 {
            state.around_end = Some(cx.line.number);
        }
        let zu = Unit::inch(state.modal.inch);
        let [surface, _, _, end] = self.levels;
        let held = def.surface_written.map_or(surface, |s| zu.to_mm(s));
        let z_written = match def.siemens {
            // A Sinumerik cycle ends at its retraction plane, whatever the depth.
            Some(_) => end,
            None => held + (end - surface),
        };
        let z_nominal = end;
        let vz = self.vars[2];
        if let Some(frame) = &self.frame {
            state.tip_nominal[2] = z_nominal;
            state.tip_written[2] = z_written;
            let length = state.modal.length;
            let (nominal, written) = (
                Vector3::from(state.tip_nominal),
                Vector3::from(state.tip_written),
            );
            if let Some(q) = pass.plane_axes(frame, &nominal, &state.pos.nominal, length) {
                state.pos.nominal = q;
            }
            if let Some(q) = pass.plane_axes(frame, &written, &state.emitted, length) {
                state.emitted = q;
            }
            for v in 0..pass.kin.len() {
                state.written[v] = Position::Decimal {
                    value: state.emitted[v],
                    decimals: state.decimals[v],
                    unit: Unit::MM,
                };
            }
            return;
        }
        state.pos.nominal[vz] = z_nominal;
        state.emitted[vz] = z_written;
        state.written[vz] = Position::Decimal {
            value: zu.of_mm(z_written),
            decimals: state.decimals[vz],
            unit: zu,
        };
    }
}

impl Pass<'_> {
    /// Nominal axis values that put the tip where `q` puts it with the rotary axes at
    /// their values in `standing` (`q` itself where they stand there already, or where
    /// the nominal machine cannot).
    fn standing(
        &self,
        q: &[f64; MAX_AXES],
        standing: &[f64; MAX_AXES],
        length: f64,
    ) -> [f64; MAX_AXES] {
        let n = self.kin.len();
        if (0..n).all(|v| self.is_linear(v) || standing[v].to_bits() == q[v].to_bits()) {
            return *q;
        }
        let tip = self.kin.pose(Model::Nominal, &q[..n], length).0.p;
        let mut guess = *q;
        for v in (0..n).filter(|&v| !self.is_linear(v)) {
            guess[v] = standing[v];
        }
        let sol = self
            .kin
            .tcp_axes_with_rotaries(&tip, &guess[..n], length, &self.options.solve);
        if sol.position_residual <= 1e-9 {
            sol.q
        } else {
            *q
        }
    }
}

impl TncCycleMode {
    /// The motion along the axis the called cycle makes, to write out as L moves where
    /// one X, Y cannot serve the whole depth (`Err`: why it is not written out). A feed or
    /// dwell the definition gives by a Q parameter is written as that parameter, which
    /// must still hold the value it had at the definition.
    fn written_out(&self, state: &State) -> Result<Vec<HoleStep>, String> {
        let Some(def) = self.def.as_ref() else {
            return Err("no cycle is defined".into());
        };
        let steps = cycles::hole_steps(def, |q| cycles::param_text(def, q))?;
        let current = state.modal.tnc.as_ref().map(|t| &t.q);
        for q in [206, 208, 210, 211] {
            let (Some(text), Some(Param::Known(at_definition))) =
                (cycles::param_text(def, q), def.get(q))
            else {
                continue;
            };
            if let Some((key, sign)) = heidenhain::q_key(text.as_bytes()) {
                let now = current.and_then(|c| c.get(&key)).map(|v| sign * v);
                if now != Some(*at_definition) {
                    return Err(format!(
                        "Q{q} is given by {text}, which no longer holds the value it had where the cycle was defined"
                    ));
                }
            }
        }
        Ok(steps)
    }

    /// The cylinder the cycle's motion around the axis stays in, from its deepest point
    /// to its set-up clearance: nominal, and as the control is told for the written words
    /// (`written`: those two levels along the hole's axis, mm).
    fn cylinder(&self, pass: &Pass<'_>, state: &State, written: (f64, f64)) -> Option<Cylinder> {
        let [_, bottom, clearance, _] = self.levels;
        let nominal_levels = [bottom - self.below, clearance];
        let written_levels = [written.0, written.1];
        let length = state.modal.length;
        let mut cyl = Cylinder {
            nominal: [[0.0; MAX_AXES]; 2],
            written: [[0.0; MAX_AXES]; 2],
            along: [[0.0; MAX_AXES]; 2],
            radius: self.radius,
        };
        match &self.frame {
            Some(frame) => {
                let at = |x: f64, y: f64, z: f64, from: &[f64; MAX_AXES]| {
                    pass.plane_axes(frame, &Vector3::new(x, y, z), from, length)
                };
                let [x, y, _] = state.tip_nominal;
                let [xw, yw, _] = state.tip_written;
                for k in 0..2 {
                    cyl.nominal[k] = at(x, y, nominal_levels[k], &state.pos.nominal)?;
                    cyl.written[k] = at(xw, yw, written_levels[k], &state.emitted)?;
                }
                let top = cyl.nominal[1];
                let ex = at(x + 1.0, y, nominal_levels[1], &top)?;
                let ey = at(x, y + 1.0, nominal_levels[1], &top)?;
                for v in 0..pass.kin.len() {
                    cyl.along[0][v] = ex[v] - top[v];
                    cyl.along[1][v] = ey[v] - top[v];
                }
            }
            None => {
                let vz = self.vars[2];
                for k in 0..2 {
                    cyl.nominal[k] = state.pos.nominal;
                    cyl.nominal[k][vz] = nominal_levels[k];
                    cyl.written[k] = state.emitted;
                    cyl.written[k][vz] = written_levels[k];
                }
                cyl.along[0][self.vars[0]] = 1.0;
                cyl.along[1][self.vars[1]] = 1.0;
            }
        }
        Some(cyl)
    }

    /// A cycle that moves around its axis: what that motion can add to the `off` (mm) the
    /// tool is off the axis at the set-up clearance, the error field's change over the
    /// cycle's radius (`Pass::lateral_bound`), must keep the whole motion within the
    /// tolerance plus the words' floor; refused naming the bound otherwise.
    fn around_bound(
        &self,
        pass: &Pass<'_>,
        cx: &Cx<'_, '_>,
        state: &State,
        out: &mut Out<'_>,
        off: f64,
        written: (f64, f64),
    ) -> Result<(), Diagnostic> {
        let tolerance = pass.options.path.unwrap_or_default().position;
        let limit = tolerance + crate::verify::Tolerances::rounding(pass.machine);
        let bound = self
            .cylinder(pass, state, written)
            .and_then(|cyl| pass.lateral_bound(&cyl, state.modal.length, limit - off));
        let Some(bound) = bound else {
            return Err(Self::refuse(
                cx,
                format!(
                    "the motion of {} around the hole's axis cannot be bounded here (the nominal machine cannot reach its cylinder with the rotary axes where they stand, or the error model gives no bound; expected its path programmed as L moves)",
                    self.around
                ),
            ));
        };
        if off + bound > limit {
            return Err(Self::refuse(
                cx,
                format!(
                    "the motion of {} around the hole's axis can add up to {:.2} µm (the error field's change over its radius of {:.4} mm) to the {:.2} µm the tool is off the axis at the set-up clearance: {:.2} µm, more than {:.2} µm (the tolerance of {:.2} µm and what the words' rounding to the machine's resolution can add; expected its path programmed as L moves, which nccomp compensates, or a tolerance of {:.4} mm or more)",
                    self.around,
                    bound * 1e3,
                    self.radius,
                    off * 1e3,
                    (off + bound) * 1e3,
                    limit * 1e3,
                    tolerance * 1e3,
                    (off + bound - limit + tolerance + 5e-5).max(tolerance)
                ),
            ));
        }
        out.summary.cycles_around += 1;
        out.summary.around_bound.update(off + bound, cx.line.number);
        Ok(())
    }
}

/// The decimals and value of the definition's `Q203=` (a Sinumerik call: its RFP) as
/// written.
fn surface_text(def: &CycleDef) -> Option<(u8, f64)> {
    if def.siemens.is_some() {
        // Its reference plane RFP.
        let line = def.text.first()?;
        let (_, raw) = siemens_argument(line, 1)?;
        let text = std::str::from_utf8(raw).ok()?.trim();
        let decimals = text.split_once('.').map_or(0, |(_, f)| f.len());
        return Some((u8::try_from(decimals).ok()?, text.parse().ok()?));
    }
    def.text.iter().find_map(|line| {
        let (_, value) = value_at(line, b"Q203")?;
        let text = std::str::from_utf8(value).ok()?;
        let decimals = text.split_once('.').map_or(0, |(_, f)| f.len());
        Some((u8::try_from(decimals).ok()?, text.parse().ok()?))
    })
}

/// The definition's lines with `Q203=` set to `number` and the block number it takes as a
/// block inserted before the calling line, each with the line's ending.
fn copy_with_surface(
    cx: &Cx<'_, '_>,
    def: &CycleDef,
    number: &str,
    decimals: u8,
    shift: u64,
) -> Vec<u8> {
    let ending = Editor::ending(cx.line.ending);
    if let Some(call) = def.siemens {
        // `MCALL CYCLE81(…)` with RFP (and an absolute DP with it) replaced, without its
        // block number (a Sinumerik block needs none).
        let mut line = def.text.first().cloned().unwrap_or_default();
        let replace = |k: usize, text: &str, line: &mut Vec<u8>| {
            if let Some((start, raw)) = siemens_argument(line, k) {
                let lead = raw.iter().take_while(|b| b.is_ascii_whitespace()).count();
                let trail = raw
                    .iter()
                    .rev()
                    .take_while(|b| b.is_ascii_whitespace())
                    .count();
                let range = start + lead..start + raw.len().max(lead + trail) - trail;
                line.splice(range, text.bytes());
            }
        };
        // The later argument first: the earlier one's place stays.
        if let Some(depth) = call.depth {
            let surface: f64 = number.parse().unwrap_or(0.0);
            let own = siemens_argument(&line, 3)
                .and_then(|(_, raw)| std::str::from_utf8(raw).ok())
                .and_then(|t| t.trim().split_once('.'))
                .map_or(0, |(_, f)| u8::try_from(f.len()).unwrap_or(u8::MAX));
            let mut dp = String::new();
            write_fixed(surface + depth, decimals.max(own), &mut dp);
            replace(3, &dp, &mut line);
        }
        replace(1, number, &mut line);
        let from = line
            .windows(5)
            .position(|w| w.eq_ignore_ascii_case(b"MCALL"))
            .unwrap_or(0);
        let mut text = line[from..].to_vec();
        text.extend_from_slice(ending.as_bytes());
        return text;
    }
    let own = heidenhain::number_of(cx.line.content, cx.tokens);
    let mut text = Vec::new();
    for (k, line) in def.text.iter().enumerate() {
        let mut line = line.clone();
        if k == 0
            && let Some(n) = own
        {
            let start = line
                .iter()
                .take_while(|b| matches!(b, b' ' | b'\t'))
                .count();
            let digits = line[start..]
                .iter()
                .take_while(|b| b.is_ascii_digit())
                .count();
            if digits > 0 {
                line.splice(start..start + digits, (n + shift).to_string().bytes());
            }
        }
        if let Some((start, value)) = value_at(&line, b"Q203") {
            let end = start + value.len();
            line.splice(start..end, number.bytes());
        }
        text.extend_from_slice(&line);
        text.extend_from_slice(ending.as_bytes());
    }
    text
}

/// Argument `k` of the `CYCLE8…(…)` call in a Sinumerik line: where it starts and its bytes.
fn siemens_argument(line: &[u8], k: usize) -> Option<(usize, &[u8])> {
    let start = line
        .windows(5)
        .position(|w| w.eq_ignore_ascii_case(b"CYCLE"))?;
    let len = line[start..].iter().position(|&b| b == b')')? + 1;
    let call = &line[start..start + len];
    let (at, raw) = *crate::program::sinumerik::arguments(call)?.get(k)?;
    Some((start + at, raw))
}
