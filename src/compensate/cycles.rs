//! Drilling and boring cycles (G73, G81–G86, G88, G89) in three-axis work.
//!
//! A cycle block names the hole (X, Y), its bottom (Z) and the retract plane (R); the
//! controller positions over the hole, goes down to R, feeds to Z and retracts. nccomp
//! compensates the cycle at its positioning points: the hole's X, Y and bottom Z from the
//! pose at the bottom, R from the pose at the R plane, the rotary axes held where they are
//! (a cycle has no rotary words). That is honest only where one X, Y serves the whole
//! depth: judged on the words as written, the tool at the R plane the control holds, with
//! the bottom's written X, Y, must be on the hole's axis within the path tolerance plus
//! what rounding the words to the machine's resolution can add (no word can do better: a
//! 0.0001 in step is 2.54 µm); otherwise the cycle is refused (program it as G0/G1 moves).
//!
//! Under a tilted working plane (G68.2 after G53.1) the cycle drills along the plane's Z:
//! X, Y, Z and R are the tip in the plane's frame, the controller turns them into axis
//! values with its nominal transformation, and the rotary axes stay where G53.1 put them.
//! The same rules hold there with the words in the plane's frame.

use super::Pass;
use super::pipeline::{Block, Cx, Mode, Out};
use crate::diag::Diagnostic;
use crate::kinematics::{MAX_AXES, Model, Solution};
use crate::model::AxisKind;
use crate::nc::TokenKind;
use crate::nc::edit::Editor;
use crate::nc::number::write_fixed;
use crate::program::WorkingPlane;
use crate::program::exact::{Position, Unit};
use crate::program::gcode;
use nalgebra::Vector3;
use std::fmt::Write;

/// The modal state of an active cycle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Cycle {
    /// Bottom and R plane as programmed (mm), and as last written (program units).
    pub bottom: Option<f64>,
    pub r_plane: Option<f64>,
    pub bottom_written: Option<f64>,
    pub r_written: Option<f64>,
    /// The Z level before the cycle began: nominal and as the machine was told (mm).
    pub initial: (f64, f64),
    /// The nominal initial level and R plane exactly (for G91 blocks after the cycle).
    pub initial_exact: Position,
    pub r_exact: Option<Position>,
}

/// A block of an active drilling cycle.
#[derive(Default)]
pub(super) struct CycleMode {
    /// The X, Y, Z variables.
    vars: [usize; 3],
    cycle: Option<Cycle>,
    /// The nominal values at the R plane, and their solution.
    r_plane: [f64; MAX_AXES],
    r_solution: Option<Solution>,
    /// Under a tilted working plane: the plane, and the words (mm) the bottom and the R
    /// plane are written as.
    frame: Option<WorkingPlane>,
    bottom_words: Vector3<f64>,
    r_words: Vector3<f64>,
    /// The holes of an L- or K-repeated block in G91 (see [`Hole`]); `None`: the block is
    /// one hole, written in place.
    holes: Option<Vec<Hole>>,
}

impl CycleMode {
    /// The column of the cycle's G word, or of its first word.
    fn col(cx: &Cx<'_, '_>) -> usize {
        cx.motion
            .arc_code
            .map_or_else(|| cx.first_word_col(), |i| cx.col(i))
    }

    fn refuse(cx: &Cx<'_, '_>, why: String) -> Diagnostic {
        cx.refuse(
            Self::col(cx),
            format!("this canned cycle cannot be compensated: {why}"),
        )
    }

    /// The hole's axis from its R plane.
    fn axis(&self, cx: &Cx<'_, '_>) -> HoleAxis<'_> {
        HoleAxis {
            top: &self.r_plane,
            frame: self.frame.as_ref(),
            col: Self::col(cx),
            level: "R plane",
            instead: "program the cycle as G0/G1 moves",
        }
    }

    /// One X, Y serves the whole depth as the hole is written: the bottom's written X, Y
    /// at the R plane the control holds (`r_written`, program units).
    fn judge_written(
        &self,
        pass: &Pass<'_>,
        cx: &Cx<'_, '_>,
        state: &crate::compensate::State,
        end: &Solution,
        r_written: Option<f64>,
    ) -> Result<(), Diagnostic> {
        let (Some(top), Some(r)) = (self.r_solution.as_ref(), r_written) else {
            return Ok(());
        };
        let r = Unit::inch(state.modal.inch).to_mm(r);
        let written = match &self.frame {
            Some(frame) => {
                let tip = Vector3::new(state.tip_written[0], state.tip_written[1], r);
                pass.plane_axes(frame, &tip, &state.emitted, state.modal.length)
                    .ok_or_else(|| {
                        Self::refuse(
                            cx,
                            "the nominal machine cannot reach the R plane above the corrected hole"
                                .into(),
                        )
                    })?
            }
            None => {
                let mut q = state.emitted;
                q[self.vars[2]] = r;
                q
            }
        };
        pass.hole_axis_as_written(state, &self.axis(cx), (end, top), &written, |why| {
            Self::refuse(cx, why)
        })?;
        Ok(())
    }
}

impl CycleMode {
    /// The target of a cycle under a tilted working plane: X, Y the hole in the plane, the
    /// bottom and R along the plane's Z; the rotary axes stay.
    fn plane_target(
        &mut self,
        b: &mut Block,
        frame: &WorkingPlane,
        cycle: Cycle,
        q: &mut [f64; MAX_AXES],
    ) -> Result<bool, Diagnostic> {
        let (pass, cx, state, _) = b.parts();
        let to_mm = |x: f64| Unit::inch(state.modal.inch).to_mm(x);
        for c in 0..2 {
            if let Some(i) = cx.motion.axis_words[self.vars[c]] {
                state.tip_nominal[c] = to_mm(cx.number(i).0);
            }
        }
        let (Some(bottom), Some(r_plane)) = (cycle.bottom, cycle.r_plane) else {
            return Err(Self::refuse(
                cx,
                "it needs its bottom (Z) and retract plane (R)".into(),
            ));
        };
        let length = state.modal.length;
        let at = |z: f64| {
            let w = Vector3::new(state.tip_nominal[0], state.tip_nominal[1], z);
            pass.plane_axes(frame, &w, &state.pos.nominal, length)
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
        let q_bottom = at(bottom)?;
        self.r_plane = at(r_plane)?;
        pass.check_travel(&q_bottom, Self::col(cx), cx)?;
        pass.check_travel(&self.r_plane, Self::col(cx), cx)?;
        self.cycle = Some(cycle);
        *q = q_bottom;
        Ok(true)
    }
}

/// A hole's axis, for [`Pass::hole_top`] and [`Pass::hole_axis_as_written`].
pub(super) struct HoleAxis<'a> {
    /// The nominal values where the tool feeds from (the R plane, a set-up clearance).
    pub top: &'a [f64; MAX_AXES],
    /// The tilted working plane the hole is drilled in, along its Z.
    pub frame: Option<&'a WorkingPlane>,
    /// The column refusals point at, the level's name and what to do instead.
    pub col: usize,
    pub level: &'a str,
    pub instead: &'a str,
}

impl Pass<'_> {
    /// The solution at a hole's top level (where the tool feeds from) and, under a plane,
    /// the words of the bottom solved to `end` and of the top, in the plane's frame. Whether
    /// one X, Y serves the whole depth is judged on the words as written
    /// ([`Pass::hole_axis_as_written`]).
    pub(super) fn hole_top(
        &self,
        cx: &Cx<'_, '_>,
        state: &mut crate::compensate::State,
        hole: &HoleAxis<'_>,
        end: &Solution,
        hold: u32,
        refuse: impl Fn(String) -> Diagnostic,
    ) -> Result<(Solution, Vector3<f64>, Vector3<f64>), Diagnostic> {
        let (top, _) = self.solve(hole.top, hold, cx, state)?;
        self.check_travel(&top.q, hole.col, cx)?;
        if self.missed(end) {
            return Err(refuse(format!(
                "the tool cannot be put at the hole's bottom: the solve leaves it {:.2} µm off ({})",
                end.position_residual * 1e3,
                hole.instead
            )));
        }
        let (mut bottom_words, mut top_words) = (Vector3::zeros(), Vector3::zeros());
        if let Some(frame) = hole.frame {
            let length = state.modal.length;
            bottom_words = self.plane_words(frame, &end.q, length);
            top_words = self.plane_words(frame, &top.q, length);
        }
        Ok((top, bottom_words, top_words))
    }

    /// One X, Y serves the whole depth, as the words are written: the control goes down
    /// the hole's axis (the machine's Z, or the plane's) at the bottom's written X, Y, from
    /// the top level as written (the R word, or the surface coordinate the control holds
    /// plus the set-up clearance), so `written` (the axis values it commands there) must put
    /// the real tool on the nominal hole's axis, the line through the nominal bottom (`end`)
    /// and top (`top`), within the path tolerance plus what rounding the words to the
    /// machine's resolution can add (the floor the verification gate gives every block end,
    /// [`crate::verify::Tolerances::rounding`]: no word can do better). Where the tool
    /// stands along the axis there (in the air, above the surface) is not judged. Returns
    /// the distance (mm).
    pub(super) fn hole_axis_as_written(
        &self,
        state: &crate::compensate::State,
        hole: &HoleAxis<'_>,
        (end, top): (&Solution, &Solution),
        written: &[f64; MAX_AXES],
        refuse: impl Fn(String) -> Diagnostic,
    ) -> Result<f64, Diagnostic> {
        let n = self.kin.len();
        let (reached, _) = self
            .kin
            .pose(Model::Actual, &written[..n], state.modal.length);
        let off = distance_from_axis(&reached.p, &end.target.p, &top.target.p);
        let tolerance = self.options.path.unwrap_or_default().position;
        let bound = tolerance + crate::verify::Tolerances::rounding(self.machine);
        if off.is_nan() || off > bound {
            return Err(refuse(format!(
                "one X, Y cannot serve the whole depth here: with the bottom's correction, as the words are written, the tool is {:.2} µm off the hole's axis at the {} (more than {:.2} µm: the tolerance of {:.2} µm and what the words' rounding to the machine's resolution can add; {})",
                off * 1e3,
                hole.level,
                bound * 1e3,
                tolerance * 1e3,
                hole.instead
            )));
        }
        Ok(off)
    }
}

/// The distance of `p` from the line through `a` and `b` (from `b` where they coincide).
fn distance_from_axis(p: &Vector3<f64>, a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    let d = b - a;
    let len = d.norm();
    if len.is_nan() || len <= 1e-9 {
        return (p - b).norm();
    }
    (p - b).cross(&(d / len)).norm()
}

/// A hole of an L-repeated block: its X, Y increments (variable, digits, exact units; none
/// for 0), and the Z and R words it needs (letter, digits).
type Hole = (Vec<(usize, String, i128)>, Vec<(u8, String)>);

/// Words added after the block's axis words (Z and R of a hole in G91).
fn insert_after_axis_words(cx: &Cx<'_, '_>, out: &mut Out<'_>, words: &[(u8, String)]) {
    if words.is_empty() {
        return;
    }
    let words: Vec<(u8, &str)> = words.iter().map(|(l, t)| (*l, t.as_str())).collect();
    cx.editor(out.edits)
        .insert_words_at(cx.axis_words_end(), &words);
    out.summary.words_added += words.len();
}

/// A cycle block's L or K word and its number of holes, when it has one above 1 (L1 is one
/// hole; in G90 the holes are all in one place, and the block is one hole's).
pub(super) fn repeats(cx: &Cx<'_, '_>) -> Result<Option<(usize, u32)>, Diagnostic> {
    // Haas and LinuxCNC write L, FANUC K.
    let (i, letter) = match (cx.word(b'L'), cx.word(b'K')) {
        (Some(_), Some(k)) => {
            return Err(cx.refuse(
                cx.col(k),
                "a cycle block with both L and K: each is a number of holes (Haas and LinuxCNC write L, FANUC K); expected one".into(),
            ));
        }
        (Some(i), None) => (i, 'L'),
        (None, Some(i)) => (i, 'K'),
        (None, None) => return Ok(None),
    };
    let (value, _, _) = cx.number(i);
    let is_number = matches!(&cx.tokens[i].kind, TokenKind::Word(w) if matches!(w.value, crate::nc::Value::Number { .. }));
    if !is_number || value.fract() != 0.0 || !(1.0..=9999.0).contains(&value) {
        return Err(cx.refuse(
            cx.col(i),
            format!("the {letter} word of a cycle block is its number of holes: expected a whole number from 1 to 9999 ({letter}0, which stores the cycle without drilling, is not supported)"),
        ));
    }
    Ok((value > 1.0).then_some((i, value as u32)))
}

impl CycleMode {
    /// A cycle block repeated `repeats` times in G91 (Haas's L, FANUC's K): each hole is
    /// compensated on its own. Where every hole takes the same corrected words the block
    /// keeps its L or K with them; otherwise it is unrolled: a block for each hole but the
    /// last inserted before the line (its G codes, feed and cycle words carried, as a split
    /// move's pieces are), the line itself the last hole, without its L or K.
    pub(super) fn repeated(b: &mut Block, l_word: usize, repeats: u32) -> Result<(), Diagnostic> {
        if let Some(i) = gcode::once_word(b.cx.tokens) {
            return Err(b.cx.refuse(
                b.cx.col(i),
                "an M or T word in a cycle block with an L or K repeat cannot be compensated: the holes' corrections differ, and unrolled the word would run once per hole (put it in a block of its own)".into(),
            ));
        }
        let mut mode = CycleMode {
            holes: Some(Vec::new()),
            ..CycleMode::default()
        };
        for _ in 0..repeats {
            super::pipeline::run(&mut mode, b)?;
        }
        let holes = mode.holes.take().unwrap_or_default();
        let (pass, cx, state, out) = b.parts();
        let Some(last) = holes.last() else {
            return Ok(());
        };
        let same = holes.iter().all(|h| h == last);
        if !same {
            let mut editor = cx.editor(out.edits);
            let style = editor.style();
            let ending = Editor::ending(cx.line.ending);
            let numbers = editor.inserted_numbers(state.last_n, holes.len() - 1);
            let mut text = String::new();
            for (k, hole) in holes[..holes.len() - 1].iter().enumerate() {
                let mut words: Vec<String> = Vec::new();
                if let Some(number) = &numbers[k] {
                    words.push(style.word(b'N', number));
                }
                for (i, t) in cx.tokens.iter().enumerate() {
                    if let TokenKind::Word(w) = &t.kind
                        && !matches!(w.letter, b'N' | b'L' | b'K' | b'O')
                        && !cx.motion.axis_words.contains(&Some(i))
                    {
                        words.push(String::from_utf8_lossy(editor.text(i)).into_owned());
                    }
                }
                for (v, digits, units) in &hole.0 {
                    // An increment as programmed keeps the program's text.
                    match cx.motion.axis_words[*v] {
                        Some(i) if *units == state.units[*v] => {
                            words.push(String::from_utf8_lossy(editor.text(i)).into_owned());
                        }
                        _ => words.push(style.word(pass.letter(*v), digits)),
                    }
                }
                for (letter, digits) in &hole.1 {
                    words.push(style.word(*letter, digits));
                }
                let _ = write!(text, "{}{}", words.join(style.separator), ending);
            }
            editor.insert_blocks(text);
            editor.remove_word(l_word);
            out.summary.note_unrolled(cx.line.number, holes.len() - 1);
        }
        // The line: the last hole's increments (every hole's, where they agree).
        for v in [mode.vars[0], mode.vars[1]] {
            let hole = last.0.iter().find(|h| h.0 == v);
            match cx.motion.axis_words[v] {
                Some(i) if hole.map_or(0, |h| h.2) != state.units[v] => {
                    let digits = hole.map_or_else(|| "0".to_string(), |h| h.1.clone());
                    cx.editor(out.edits).replace_number(i, digits);
                    out.summary.words_changed += 1;
                }
                Some(_) => {}
                None => {
                    if let Some((_, digits, _)) = hole {
                        pass.insert_axis_word(cx, out, v, digits);
                        out.summary.words_added += 1;
                    }
                }
            }
        }
        insert_after_axis_words(cx, out, &last.1);
        Ok(())
    }
}

impl Mode for CycleMode {
    fn target(&mut self, b: &mut Block, q: &mut [f64; MAX_AXES]) -> Result<bool, Diagnostic> {
        let (pass, cx, state, _) = b.parts();
        let n = pass.kin.len();
        let axis_words = &cx.motion.axis_words;
        let refuse = |why: &str| Err(Self::refuse(cx, why.to_string()));
        let var = |letter: u8| {
            pass.axes.var_of_letter[(letter - b'A') as usize]
                .filter(|&v| pass.kin.kind(v) == AxisKind::Linear)
        };
        let (Some(vx), Some(vy), Some(vz)) = (var(b'X'), var(b'Y'), var(b'Z')) else {
            return refuse("the machine has no linear X, Y and Z axes");
        };
        self.vars = [vx, vy, vz];
        self.frame = state.modal.working_plane;
        if state.modal.incremental
            && (self.frame.is_some()
                || axis_words[vz].is_some()
                || cx.motion.arc_words[3].is_some())
        {
            return refuse(
                "in incremental mode (G91) a cycle's Z and R are distances (R from the level the cycle starts from, Z from R), which nccomp does not follow; in G91 it follows X and Y increments, with Z and R given in G90 before (program Z and R in G90)",
            );
        }
        if state.modal.plane != 0 {
            return refuse("only cycles in the G17 plane (drilling along Z) are supported");
        }
        if state.modal.tcp {
            return refuse(
                "cycles under tool-centre-point control (G43.4/G43.5) are not supported",
            );
        }
        if pass.turning {
            return refuse(
                "cycles while turning (the spindle turns or is not positioned) are not supported (program the hole as G1 moves)",
            );
        }
        if cx.motion.optional {
            return refuse("an optional block (/) with a cycle is not supported");
        }
        if state.pos.unknown & !pass.spindle != 0 {
            return refuse(
                "it starts where an axis is at a place nccomp does not know (after G28, G30, G53, a machine move code, M19 or a change of tool chain)",
            );
        }
        if let Some((v, i)) = cx.word_outside(n, &[vx, vy, vz]) {
            return Err(cx.refuse(
                cx.col(i),
                format!(
                    "{} words in a canned cycle cannot be compensated (cycles with rotary or other axis words are not supported; expected X, Y, Z and R)",
                    pass.letter(v) as char
                ),
            ));
        }
        // K is FANUC's number of holes (`repeats`); I and J a shift at the bottom.
        if let Some(i) = cx.motion.arc_words[..2].iter().flatten().next() {
            return Err(cx.refuse(
                cx.col(*i),
                "I and J words in a canned cycle are not supported (expected X, Y, Z, R, and L or K for the number of holes)"
                    .into(),
            ));
        }
        if self.frame.is_some() {
            if state.zero != [0.0; 3] {
                return refuse(
                    "under a tilted working plane with a program zero other than the machine file's geometry zero (a work offset, a set-up's preset or a G52 shift)",
                );
            }
            if state.modal.diameter {
                return refuse("in diameter mode (G7) under a tilted working plane");
            }
            pass.plane_checks(cx, state, &self.vars)?;
        }
        // Z and R are never diameters; X may be (G7).
        let zu = Unit::inch(state.modal.inch);
        let initial = match self.frame {
            Some(_) => (state.tip_nominal[2], state.tip_written[2]),
            None => (state.pos.nominal[vz], state.emitted[vz]),
        };
        let mut cycle = state.cycle.unwrap_or(Cycle {
            bottom: None,
            r_plane: None,
            bottom_written: None,
            r_written: None,
            initial,
            initial_exact: state.pos.exact[vz],
            r_exact: None,
        });
        if let Some(i) = axis_words[vz] {
            cycle.bottom = Some(zu.to_mm(cx.number(i).0));
        }
        if let Some(i) = cx.motion.arc_words[3] {
            let (value, decimals, _) = cx.number(i);
            cycle.r_plane = Some(zu.to_mm(value));
            cycle.r_exact = Some(Position::Decimal {
                value,
                decimals,
                unit: zu,
            });
        }
        if cycle.r_plane.is_none() && pass.machine.cycle_r_initial {
            // The control's rule, as the machine file states it: R is where the cycle
            // starts, so no R word is needed while the corrected R prints the same.
            cycle.r_plane = Some(cycle.initial.0);
            cycle.r_written = Some(zu.of_mm(cycle.initial.1));
            cycle.r_exact = Some(cycle.initial_exact);
        }
        let (Some(bottom), Some(r_plane)) = (cycle.bottom, cycle.r_plane) else {
            return refuse(match (cycle.bottom, cycle.r_plane) {
                (None, None) => "it needs its bottom (Z) and retract plane (R)",
                (None, Some(_)) => "it gives no bottom (expected a Z word)",
                (Some(_), _) => {
                    "it gives no R plane, and where a control then puts it is the control's rule (expected an R word; a machine file whose control takes the level the cycle starts from says so with `[cycles] missing_r = \"initial\"`)"
                }
            });
        };
        // The control holds the cycle's levels from here on, whether or not this hole can
        // be compensated: the holes after it are judged with them (and refused for their
        // own reasons, not for levels they do not repeat).
        state.cycle = Some(cycle);
        if let Some(frame) = self.frame {
            return self.plane_target(b, &frame, cycle, q);
        }
        for v in [vx, vy] {
            if state.pos.programmed & (1 << v) == 0
                && (state.modal.incremental || axis_words[v].is_none())
            {
                return Err(Self::refuse(
                    cx,
                    format!(
                        "the program has not set {} before the cycle",
                        pass.letter(v) as char
                    ),
                ));
            }
        }
        // X and Y (G91 exactly); the Z word's place is taken again below and after the
        // hole.
        state.pos.advance(
            &pass.axes,
            cx.line.content,
            cx.tokens,
            cx.motion,
            &state.modal,
            cx.at,
            &mut state.units,
        )?;
        self.cycle = Some(cycle);
        let mut q_bottom = state.pos.nominal;
        q_bottom[vz] = bottom;
        self.r_plane = state.pos.nominal;
        self.r_plane[vz] = r_plane;
        pass.check_travel(&q_bottom, Self::col(cx), cx)?;
        pass.check_travel(&self.r_plane, Self::col(cx), cx)?;
        *q = q_bottom;
        Ok(true)
    }

    /// The rotary axes stay where they are; the linear ones take the whole correction.
    fn hold(&self, pass: &Pass<'_>) -> u32 {
        (0..pass.kin.len())
            .filter(|&v| !pass.is_linear(v))
            .fold(0, |m, v| m | 1 << v)
    }

    /// The solution at the R plane (where one X, Y serves the whole depth is judged on the
    /// written words, in [`Mode::write`]).
    fn path(&mut self, b: &mut Block, end: &Solution, hold: u32) -> Result<(), Diagnostic> {
        let (pass, cx, state, _) = b.parts();
        let depth = pass.hole_top(cx, state, &self.axis(cx), end, hold, |why| {
            Self::refuse(cx, why)
        })?;
        (self.r_solution, self.bottom_words, self.r_words) = (Some(depth.0), depth.1, depth.2);
        Ok(())
    }

    /// X, Y and the bottom Z, as any block's axis words (a missing Z is compared with the
    /// cycle's bottom as last written, not with where the machine stands); R rewritten
    /// where it is, added where the modal value no longer fits.
    fn write(&mut self, b: &mut Block, end: &Solution) -> Result<(), Diagnostic> {
        let (pass, cx, state, out) = b.parts();
        let (Some(cycle), Some(r_sol)) = (self.cycle.as_mut(), self.r_solution) else {
            return Ok(());
        };
        let vz = self.vars[2];
        let zu = Unit::inch(state.modal.inch);
        let r_value = match &self.frame {
            Some(frame) => {
                state.tip_written[2] = cycle.bottom_written.map_or(f64::NAN, |z| zu.to_mm(z));
                pass.write_tip_words(cx, &self.vars, &self.bottom_words, None, state, out);
                cycle.bottom_written = Some(zu.of_mm(state.tip_written[2]));
                // What the controller commands for the written words, for the travel limits.
                let tip = Vector3::from(state.tip_written);
                if let Some(q) = pass.plane_axes(frame, &tip, &state.emitted, state.modal.length) {
                    state.emitted = q;
                }
                zu.of_mm(self.r_words.z)
            }
            None if state.modal.incremental => {
                // X and Y as increments. Z and R keep their places while they print the
                // same; otherwise they are written as the distances G91 reads: Z from the
                // R plane (every control), R from the initial level, which is where the
                // tool starts each hole only under G98.
                let d = pass.res_decimals(vz, zu).max(state.decimals[vz]).min(9);
                let scale = 10f64.powi(d.into());
                let m = |x: f64| (x * scale).round() as i64;
                let fits =
                    |written: Option<f64>, value: f64| written.is_some_and(|w| m(w) == m(value));
                let (bottom, r) = (zu.of_mm(end.q[vz]), zu.of_mm(r_sol.q[vz]));
                let mut zr: Vec<(u8, String)> = Vec::new();
                let r_fits = fits(cycle.r_written, r);
                if !r_fits {
                    let initial = zu.of_mm(cycle.initial.1);
                    if !state.modal.retract_to_initial
                        || (initial * scale - m(initial) as f64).abs() > 1e-6
                    {
                        return Err(Self::refuse(
                            cx,
                            format!(
                                "here the corrected R plane ({r:.6}) no longer prints as given ({:.6}), and a G91 R word is a distance whose start differs between controls unless the tool starts each hole at the initial level (G98) (program this hole in G90, or in G98)",
                                cycle.r_written.unwrap_or(f64::NAN)
                            ),
                        ));
                    }
                    let inc = m(r) - m(initial);
                    let mut text = String::new();
                    crate::nc::number::write_scaled(inc.into(), d, &mut text);
                    zr.push((b'R', text));
                    cycle.r_written = Some((m(initial) + inc) as f64 / scale);
                }
                if !r_fits || !fits(cycle.bottom_written, bottom) {
                    let from = m(cycle.r_written.unwrap_or(r));
                    let inc = m(bottom) - from;
                    let mut text = String::new();
                    crate::nc::number::write_scaled(inc.into(), d, &mut text);
                    zr.insert(0, (b'Z', text));
                    cycle.bottom_written = Some((from + inc) as f64 / scale);
                }
                // At the bottom, for the record of the block.
                state.emitted[vz] = cycle.bottom_written.map_or(f64::NAN, |z| zu.to_mm(z));
                let units = state.units;
                let xy = 1 << self.vars[0] | 1 << self.vars[1];
                match self.holes.as_mut() {
                    // A repeat of an L-repeated hole: its words, for a block of its own.
                    Some(holes) => {
                        let mut words = Vec::new();
                        pass.hole_words(cx, &end.q, xy, state, &mut words);
                        holes.push((words, zr));
                    }
                    None => {
                        pass.write_increments(cx, &units, &end.q, xy, state, out)?;
                        insert_after_axis_words(cx, out, &zr);
                    }
                }
                let r_written = self.cycle.and_then(|c| c.r_written);
                return self.judge_written(pass, cx, state, end, r_written);
            }
            None => {
                state.emitted[vz] = cycle.bottom_written.map_or(f64::NAN, |z| zu.to_mm(z));
                pass.write_positions(cx, &end.q, false, state, out)?;
                cycle.bottom_written = Some(zu.of_mm(state.emitted[vz]));
                zu.of_mm(r_sol.q[vz])
            }
        };
        let d = pass.res_decimals(vz, zu);
        let mut editor = cx.editor(out.edits);
        match cx.motion.arc_words[3] {
            Some(i) => {
                let d = cx.number(i).1.max(d);
                let mut text = String::new();
                write_fixed(r_value, d, &mut text);
                if editor.set_fixed(i, r_value, d) {
                    out.summary.words_changed += 1;
                }
                cycle.r_written = text.parse().ok();
            }
            None => {
                let d = state.decimals[vz].max(d);
                let mut text = String::new();
                write_fixed(r_value, d, &mut text);
                let fits = cycle
                    .r_written
                    .is_some_and(|old| crate::nc::number::same_text(old, r_value, d));
                if !fits {
                    editor.insert_words_at(cx.axis_words_end(), &[(b'R', &text)]);
                    out.summary.words_added += 1;
                    cycle.r_written = text.parse().ok();
                }
            }
        }
        let r_written = self.cycle.and_then(|c| c.r_written);
        self.judge_written(pass, cx, state, end, r_written)
    }

    /// Where the cycle leaves the tool: the R plane (G99) or the initial level (G98; R
    /// when that is higher).
    fn after(&mut self, b: &mut Block) {
        let (pass, _, state, _) = b.parts();
        let (Some(cycle), Some(r_sol)) = (self.cycle, self.r_solution) else {
            return;
        };
        let vz = self.vars[2];
        let zu = Unit::inch(state.modal.inch);
        let r_plane = cycle.r_plane.unwrap_or(self.r_plane[vz]);
        let r_at = if self.frame.is_some() {
            self.r_words.z
        } else {
            r_sol.q[vz]
        };
        let r_emitted = cycle.r_written.map_or(r_at, |r| zu.to_mm(r));
        let (z_nominal, z_emitted) = if state.modal.retract_to_initial && cycle.initial.0 > r_plane
        {
            cycle.initial
        } else {
            (r_plane, r_emitted)
        };
        if let Some(frame) = &self.frame {
            state.tip_nominal[2] = z_nominal;
            state.tip_written[2] = z_emitted;
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
            state.cycle = Some(cycle);
            return;
        }
        state.pos.nominal[vz] = z_nominal;
        state.pos.exact[vz] = if z_nominal == cycle.initial.0 {
            cycle.initial_exact
        } else {
            cycle.r_exact.unwrap_or(cycle.initial_exact)
        };
        state.emitted[vz] = z_emitted;
        state.written[vz] = Position::Decimal {
            value: zu.of_mm(z_emitted),
            decimals: state.decimals[vz],
            unit: zu,
        };
        state.cycle = Some(cycle);
    }
}
