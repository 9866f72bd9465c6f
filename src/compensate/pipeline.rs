//! One block, from its text to the words written: the pipeline every block that moves goes
//! through, whatever its mode.
//!
//! A line is first read ([`crate::program::Reader`]: its words, its modal state, how it
//! moves). A block that moves then goes through five stages, here in [`Pass::block`]:
//!
//! 1. **Target** (the mode's): the nominal axis values its words mean at its end: the
//!    axis words themselves (G0/G1, exactly in G91), the end of an arc, a cycle's bottom,
//!    or, under tool-centre-point control, the nominal inverse kinematics of the tip and
//!    the rotary words or tool vector (design/model.md, "Controller transformations").
//! 2. **Solve** ([`Pass::solve`], shared): the axis values the real machine needs there,
//!    with the guards that hold in every mode: a rotary axis that the correction would push
//!    past a travel limit it was programmed within is held (refused when holding it leaves
//!    the tip off), a correction larger than `Options::max_correction` is refused, rotary
//!    axes at singular poses are held.
//! 3. **Path** (the mode's): the move between the block's ends as the controller
//!    interpolates the written words, against the nominal path of the programmed words;
//!    where they part by more than the tolerance, blocks are inserted before the line (a
//!    split G1 or TCP move, an arc's straight pieces), each through the same solve.
//! 4. **Write** (the mode's): the block's words for the solved values, through the lossless
//!    layer's editor ([`crate::nc::edit`]): a number that prints the same keeps its bytes,
//!    a missing word is added in the block's style.
//! 5. **Finish** ([`Pass::finish`], shared): travel limits on what the controller is now
//!    told, and the record of what the model predicts there, before and after.
//!
//! The modes ([`Mode`]): machine axes ([`super::axes`], lathes' turning included), arcs
//! ([`super::arcs`]), drilling cycles ([`super::cycles`]), tool-centre-point moves with
//! rotary words or tool vectors, arcs among them ([`super::tcp`]). G53, G28 and G30 moves
//! are left as they are: their axes leave the program's coordinates.

use super::{Pass, State, Summary, TRAVEL_LIMIT};
use crate::diag::Diagnostic;
use crate::kinematics::{MAX_AXES, Model, Solution};
use crate::nc::edit::Editor;
use crate::nc::number::scaled;
use crate::nc::{self, Edit, Token, TokenKind, Value};
use crate::program::exact::Position;
use crate::program::{BlockMotion, MoveKind};

/// A block being compensated: its line, tokens and words, and where its refusals point.
pub(super) struct Cx<'a, 'l> {
    pub line: &'a nc::Line<'l>,
    pub tokens: &'a [Token],
    pub motion: &'a BlockMotion,
    pub at: &'a dyn Fn(usize, String) -> Diagnostic,
}

impl Cx<'_, '_> {
    /// A refusal at byte `col` of the line.
    pub fn refuse(&self, col: usize, message: String) -> Diagnostic {
        (self.at)(col, message)
    }

    /// The column of token `i`.
    pub fn col(&self, i: usize) -> usize {
        // An index from another block's reading (never expected) points at the line start
        // rather than panicking.
        self.tokens.get(i).map_or(0, |t| t.span.start)
    }

    /// The column of the block's first axis word (0 when it has none).
    pub fn first_col(&self) -> usize {
        self.motion
            .axis_words
            .iter()
            .flatten()
            .map(|&i| self.col(i))
            .min()
            .unwrap_or(0)
    }

    /// The byte just after the block's last axis word (the line's end when it has none):
    /// where words that follow them are added.
    pub fn axis_words_end(&self) -> usize {
        self.motion
            .axis_words
            .iter()
            .flatten()
            .map(|&i| self.tokens[i].span.end)
            .max()
            .unwrap_or(self.line.content.len())
    }

    /// The column of the block's first axis or I/J/K/R word (0 when it has none).
    pub fn first_word_col(&self) -> usize {
        self.motion
            .axis_words
            .iter()
            .chain(&self.motion.arc_words)
            .flatten()
            .map(|&i| self.col(i))
            .min()
            .unwrap_or(0)
    }

    /// The number of the word at token `i` (the reader has checked it is one), its decimals
    /// and the span of its value.
    pub fn number(&self, i: usize) -> (f64, u8, std::ops::Range<usize>) {
        match &self.tokens[i].kind {
            TokenKind::Word(w) => match w.value {
                Value::Number { value, decimals } => (value, decimals, w.value_span.clone()),
                _ => (0.0, 0, w.value_span.clone()),
            },
            _ => (0.0, 0, 0..0),
        }
    }

    /// The block's first axis word of a variable (of the first `n`) not in `allowed`: the
    /// variable and the word's token.
    pub fn word_outside(&self, n: usize, allowed: &[usize]) -> Option<(usize, usize)> {
        self.motion
            .axis_words
            .iter()
            .enumerate()
            .take(n)
            .find_map(|(v, w)| w.filter(|_| !allowed.contains(&v)).map(|i| (v, i)))
    }

    /// The editor of the block's line.
    pub fn editor<'e>(&'e self, edits: &'e mut Vec<Edit>) -> Editor<'e> {
        Editor::new(self.line.content, self.tokens, edits)
    }

    /// The first word with `letter`, if any.
    pub fn word(&self, letter: u8) -> Option<usize> {
        self.tokens
            .iter()
            .position(|t| matches!(&t.kind, TokenKind::Word(w) if w.letter == letter))
    }
}

/// The stages, in order.
pub(super) fn run<M: Mode>(mode: &mut M, b: &mut Block) -> Result<(), Diagnostic> {
    // Filled by the mode (an out-parameter: 128 bytes in a `Result` are copied twice).
    let mut target = [0.0; MAX_AXES];
    if !mode.target(b, &mut target)? {
        return Ok(());
    }
    let pass = b.pass;
    if pass.rollover != 0 && !mode.rollover_aware() {
        for v in (0..pass.kin.len()).filter(|&v| pass.rollover & (1 << v) != 0) {
            if (target[v] - b.state.emitted[v]).abs() >= 180.0 - 1e-9 {
                return Err(b.cx.refuse(
                    b.cx.motion.axis_words[v].map_or(0, |i| b.cx.col(i)),
                    format!(
                        "rollover axis {} turns half a turn or more in this block, and the control turns it the shortest way: the path nccomp follows here (tool-centre-point, arcs) would take the other (program the turn in smaller steps)",
                        pass.axis_name(v)
                    ),
                ));
            }
        }
    }
    // An axis the program has not set yet stands where the operator left it: no word is
    // added for it (that would move it), so it keeps its value and the others correct.
    let unset = (0..pass.kin.len())
        .filter(|&v| b.cx.motion.axis_words[v].is_none())
        .fold(0u32, |m, v| m | 1 << v)
        & !b.state.pos.programmed;
    for v in (0..pass.kin.len()).filter(|&v| unset & !(pass.idle | pass.spindle) & (1 << v) != 0) {
        b.out
            .summary
            .note_assumed_home(pass.axis_name(v), b.cx.line.number);
    }
    let hold = pass.hold | mode.hold(pass) | unset;
    // Used where it lies: moved out of the `Result`, the 440-byte solution is copied.
    let mut solved = pass.solve(&target, hold, b.cx, b.state);
    if let (Ok((end, _)), Some(o)) = (&mut solved, mode.direction()) {
        end.target.o = o;
    }
    let (end, at_limit) = match &solved {
        Ok((end, at_limit)) => (end, *at_limit),
        Err(_) => return solved.map(|_| ()),
    };
    mode.path(b, end, hold | at_limit)?;
    mode.write(b, end)?;
    let (position, direction) = pass.finish(b.cx, end, at_limit, b.state, b.out)?;
    // The end deviation is the next move's start, where the target is the nominal pose at
    // the axis values solved for.
    b.state.end = mode.targets_nominal_pose().then_some(super::EndDeviation {
        kin: pass.kin_id(),
        told: b.state.emitted,
        nominal: target,
        length: b.state.modal.length,
        position,
        direction,
    });
    mode.after(b);
    Ok(())
}

/// Where a block under tool radius compensation starts: the tip words nominal and
/// written, the axis values nominal and written.
type Before = ([f64; 3], [f64; 3], [f64; MAX_AXES], [f64; MAX_AXES]);

/// Where a block's results go.
pub(super) struct Out<'a> {
    pub edits: &'a mut Vec<Edit>,
    pub summary: &'a mut Summary,
}

/// A block going through the pipeline: the pass, the block, the pass's state, and where
/// its results go.
pub(super) struct Block<'b, 'o, 'm> {
    pub pass: &'b Pass<'m>,
    pub cx: &'b Cx<'b, 'b>,
    pub state: &'b mut State,
    pub out: &'b mut Out<'o>,
}

impl<'b, 'o, 'm> Block<'b, 'o, 'm> {
    /// The four, to work with each on its own.
    pub fn parts(&mut self) -> (&'b Pass<'m>, &'b Cx<'b, 'b>, &mut State, &mut Out<'o>) {
        (self.pass, self.cx, &mut *self.state, &mut *self.out)
    }
}

/// What differs between modes: the stages of [`Pass::block`] a mode supplies.
pub(super) trait Mode {
    /// The nominal axis values at the block's end, into `q`; false: the block is written as
    /// it is (its pose cannot be evaluated).
    fn target(&mut self, b: &mut Block, q: &mut [f64; MAX_AXES]) -> Result<bool, Diagnostic>;

    /// Variables the solve holds in this mode, beyond the pass's own.
    fn hold(&self, _pass: &Pass<'_>) -> u32 {
        0
    }

    /// Whether the mode's path follows a rollover axis the shortest way to its word (else
    /// a move of half a turn or more on one is refused).
    fn rollover_aware(&self) -> bool {
        false
    }

    /// Keep the path within the tolerance: blocks inserted before the line. `hold`: the
    /// variables the block's solve held (beyond singular poses).
    fn path(&mut self, b: &mut Block, end: &Solution, hold: u32) -> Result<(), Diagnostic>;

    /// Write the block's words for `end`, and what the controller is told
    /// (`State::emitted`).
    fn write(&mut self, b: &mut Block, end: &Solution) -> Result<(), Diagnostic>;

    /// After the block is recorded: what the controller does at the block's end beyond its
    /// words (a cycle's retract).
    fn after(&mut self, _b: &mut Block) {}

    /// The tool direction the block is meant to have, where the solve's target differs
    /// from it (rotary axes held where an earlier block left them).
    fn direction(&self) -> Option<nalgebra::Vector3<f64>> {
        None
    }

    /// Whether the solve's target is exactly the nominal pose at the axis values the mode
    /// gave (machine-axis moves), so that the block's end deviation can start the next
    /// move's path check.
    fn targets_nominal_pose(&self) -> bool {
        false
    }
}

impl Pass<'_> {
    /// Which kinematics this pass evaluates (see [`super::EndDeviation`]).
    pub(super) fn kin_id(&self) -> usize {
        std::ptr::from_ref(&self.kin) as usize
    }

    /// One block that moves: through the pipeline in its mode.
    pub(super) fn block(
        &self,
        cx: &Cx<'_, '_>,
        state: &mut State,
        out: &mut Out<'_>,
    ) -> Result<(), Diagnostic> {
        // A tool length changed with the axes standing moves the nominal tip, not the
        // machine: a feed move from there would start off the real pose it needs.
        let feed = !state.modal.rapid
            && matches!(cx.motion.kind, MoveKind::Program | MoveKind::Arc { .. });
        if feed
            && state.moved_length.to_bits() != state.modal.length.to_bits()
            && state.pos.unknown & !(self.spindle | self.idle) == 0
        {
            return Err(cx.refuse(
                cx.first_col(),
                "a feed move right after the tool length changed with the axes standing (G43/G49, D, TOOL CALL): the tip the control now assumes is not where the machine stands, and the move would start off the pose it needs (expected a rapid G0 positioning move after the change)".into(),
            ));
        }
        state.moved_length = state.modal.length;
        if feed && state.turned_at_rest {
            return Err(cx.refuse(
                cx.first_col(),
                "a feed move right after the rotary axes turned to the working plane with the linear axes standing (G53.1, PLANE … TURN, CYCLE800): the controller turns them to the nominal angles, the tip is not where the corrected pose needs it, and the move would start off it (expected a rapid G0 positioning move after the turn)".into(),
            ));
        }
        state.turned_at_rest = false;
        if feed && let Some(line) = state.around_end {
            return Err(cx.refuse(
                cx.first_col(),
                format!(
                    "a feed move right after the cycle called at line {line}, which moves the tool around the hole's axis: where the control leaves the tool in the plane after it is the control's, and the move would start where nccomp does not know (expected a rapid positioning move first)"
                ),
            ));
        }
        state.around_end = None;
        let radius = state.modal.radius_comp.is_some() || state.radius.is_some();
        if radius
            && matches!(
                cx.motion.kind,
                MoveKind::Machine | MoveKind::Home | MoveKind::ToPlane | MoveKind::Cycle
            )
        {
            self.radius_block(
                cx.line.number,
                cx.first_col(),
                state,
                None,
                out.summary,
                cx.at,
            )?;
        }
        if matches!(cx.motion.kind, MoveKind::Machine | MoveKind::Home) {
            self.leave_coordinates(cx, state);
            return Ok(());
        }
        if state.modal.length.is_nan() {
            return Err(cx.refuse(
                cx.first_col(),
                "the length of the tool in the spindle is not known here: a tool length (D) was switched on before the program selected a tool, and where the tip is, and so the correction, depends on it (expected T with the tool's number or name, then D, before the first move that is compensated)".into(),
            ));
        }
        // (A shift set back to zero under a plane leaves a rounding residue: not a shift.)
        if self.machine.work_offsets.is_none()
            && state.modal.local_shift.iter().any(|x| x.abs() > 1e-9)
        {
            // Without a work offset table G52 is refused; a datum shift of the other
            // dialects outside a tilted plane is refused the same way, where it would
            // first move the tool.
            let [x, y, z] = state.modal.local_shift;
            return Err(cx.refuse(
                cx.first_col(),
                format!(
                    "a datum shift (CYCL DEF 7, TRANS/ATRANS) of X{x} Y{y} Z{z} is in force outside a tilted working plane, and the machine file has no [work_offsets]: where program zero lies is not followed without one, as for G52 (expected [work_offsets] in the machine file, the shift under a PLANE, or the shift cancelled before this move)"
                ),
            ));
        }
        if cx.motion.kind == MoveKind::ToPlane {
            return self.to_plane(cx, state, out);
        }
        // Under TCP or a tilted working plane, X, Y, Z are the tool tip.
        let tip_words = state.modal.tcp || state.modal.working_plane.is_some();
        // Where a block under tool radius compensation starts, in the plane and in axes.
        let before = radius.then_some((
            state.tip_nominal,
            state.tip_written,
            state.pos.nominal,
            state.emitted,
        ));
        let mut b = Block {
            pass: self,
            cx,
            state,
            out,
        };
        match cx.motion.kind {
            MoveKind::Cycle if b.state.modal.dialect != nc::Dialect::Iso => {
                run(&mut super::tnc_cycles::TncCycleMode::default(), &mut b)
            }
            MoveKind::Cycle => match super::cycles::repeats(cx)? {
                Some((l_word, repeats)) if b.state.modal.incremental => {
                    super::cycles::CycleMode::repeated(&mut b, l_word, repeats)
                }
                _ => run(&mut super::cycles::CycleMode::default(), &mut b),
            },
            MoveKind::Arc { clockwise } if tip_words => {
                let mut mode = super::tcp::TcpMode::arc(clockwise);
                run(&mut mode, &mut b)?;
                self.radius_tcp(&mode, before, &mut b)
            }
            MoveKind::Arc { clockwise } => {
                run(&mut super::arcs::ArcMode::new(clockwise), &mut b)?;
                self.radius_tcp_none(before, &mut b)
            }
            _ if tip_words => {
                let mut mode = super::tcp::TcpMode::line();
                run(&mut mode, &mut b)?;
                self.radius_tcp(&mode, before, &mut b)
            }
            _ => {
                let added = b.out.summary.blocks_added;
                run(&mut super::axes::AxesMode::default(), &mut b)?;
                self.radius_axes(before, added, &mut b)
            }
        }
    }

    /// A block outside a working plane under tool radius compensation: refused (see
    /// [`super::radius`]).
    fn radius_tcp_none(&self, before: Option<Before>, b: &mut Block) -> Result<(), Diagnostic> {
        if before.is_none() {
            return Ok(());
        }
        let (cx, state, out) = (b.cx, &mut *b.state, &mut *b.out);
        self.radius_block(
            cx.line.number,
            cx.first_col(),
            state,
            None,
            out.summary,
            cx.at,
        )
    }

    /// A straight block in machine axes under tool radius compensation: its element
    /// followed in the words' X, Y (see [`super::radius`]); `added`: the summary's blocks
    /// added before it.
    fn radius_axes(
        &self,
        before: Option<Before>,
        added: usize,
        b: &mut Block,
    ) -> Result<(), Diagnostic> {
        let Some((_, _, q0, q0_written)) = before else {
            return Ok(());
        };
        let (cx, state, out) = (b.cx, &mut *b.state, &mut *b.out);
        let (Some(x), Some(y), Some(z)) =
            (self.tip_var(b'X'), self.tip_var(b'Y'), self.tip_var(b'Z'))
        else {
            return self.radius_block(
                cx.line.number,
                cx.first_col(),
                state,
                None,
                out.summary,
                cx.at,
            );
        };
        let tip = |q: &[f64; MAX_AXES]| [q[x], q[y], q[z]];
        let mv = super::radius::Move {
            frame: None,
            tip: [tip(&q0), tip(&state.pos.nominal)],
            tip_written: [tip(&q0_written), tip(&state.emitted)],
            q: [q0, state.pos.nominal],
            q_written: [q0_written, state.emitted],
            arc: None,
            pieces: out.summary.blocks_added - added,
        };
        self.radius_block(
            cx.line.number,
            cx.first_col(),
            state,
            Some(mv),
            out.summary,
            cx.at,
        )
    }

    /// A block in a working plane under tool radius compensation: its element followed
    /// (see [`super::radius`]).
    fn radius_tcp(
        &self,
        mode: &super::tcp::TcpMode,
        before: Option<Before>,
        b: &mut Block,
    ) -> Result<(), Diagnostic> {
        let Some((tip0, tip0_written, q0, q0_written)) = before else {
            return Ok(());
        };
        let (cx, state, out) = (b.cx, &mut *b.state, &mut *b.out);
        let Some(frame) = state.modal.working_plane.filter(|_| !state.modal.tcp) else {
            return self.radius_block(
                cx.line.number,
                cx.first_col(),
                state,
                None,
                out.summary,
                cx.at,
            );
        };
        let Ok(arc) = mode.radius_arc(&tip0_written, &state.tip_written) else {
            return Err(cx.refuse(
                cx.first_col(),
                "an arc under tool radius compensation (RL/RR) that nccomp does not keep as an arc about a pole in the working plane's X-Y: the control's offset of what would be written is not followed (expected C or CP about a CC in X-Y, or R0)".into(),
            ));
        };
        let mv = super::radius::Move {
            frame: Some(&frame),
            tip: [tip0, state.tip_nominal],
            tip_written: [tip0_written, state.tip_written],
            q: [q0, state.pos.nominal],
            q_written: [q0_written, state.emitted],
            arc,
            pieces: mode.pieces(),
        };
        self.radius_block(
            cx.line.number,
            cx.first_col(),
            state,
            Some(mv),
            out.summary,
            cx.at,
        )
    }

    /// G53, G28, G30: the block stays as it is, and the axes it sends to machine positions
    /// (all of them for a bare G28/G30) leave the program's coordinates.
    fn leave_coordinates(&self, cx: &Cx<'_, '_>, state: &mut State) {
        let n = self.kin.len();
        let mut gone = (0..n)
            .filter(|&v| cx.motion.axis_words[v].is_some())
            .fold(0u32, |m, v| m | 1 << v);
        if cx.motion.kind == MoveKind::Home && gone == 0 {
            gone = match cx.motion.homed {
                0 => (0..n).fold(0u32, |m, v| m | 1 << v),
                homed => homed,
            };
        }
        state.uncertain &= !gone;
        state.unsettled &= !gone;
        let known = self.machine_positions(cx, state);
        // A machine move to a known place makes its axes known, unknown before or not.
        state.pos.unknown = (state.pos.unknown | gone) & !known;
    }

    /// G53 and M91/M92 words where the machine file places program zero in machine
    /// coordinates (`[work_offsets]`, and its `M92` reference for M92): the program
    /// positions they reach, followed as the block's written values. The variables that
    /// became known.
    fn machine_positions(&self, cx: &Cx<'_, '_>, state: &mut State) -> u32 {
        let modal = &state.modal;
        let (Some(table), Some(_), MoveKind::Machine) =
            (&self.machine.work_offsets, modal.shift, cx.motion.kind)
        else {
            return 0;
        };
        if modal.tcp || modal.working_plane.is_some() || cx.motion.optional {
            return 0;
        }
        let reference = if cx.motion.from_m92 {
            match table.m92 {
                Some(r) => r,
                None => return 0,
            }
        } else {
            [0.0; 3]
        };
        // Program zero in machine coordinates: the offset in force, the external offset
        // and the local shift (the geometry's offset and `shift` from it).
        let geometry = table.geometry_zero;
        let shift = modal.shift.unwrap_or([0.0; 3]);
        let mut known = 0;
        for v in 0..self.kin.len() {
            let Some(i) = cx.motion.axis_words[v] else {
                continue;
            };
            let (value, decimals, _) = cx.number(i);
            let unit = self.unit(v, modal);
            let p = match b"XYZ".iter().position(|&l| l == self.letter(v)) {
                Some(c) if self.is_linear(v) => {
                    unit.to_mm(value) + reference[c] - geometry[c] - shift[c]
                }
                None if !self.is_linear(v) => value,
                _ => continue,
            };
            let bit = 1u32 << v;
            state.pos.nominal[v] = p;
            state.pos.programmed |= bit;
            state.emitted[v] = p;
            state.written[v] = Position::Decimal {
                value: unit.of_mm(p),
                decimals: decimals.max(self.res_decimals(v, unit)),
                unit,
            };
            known |= bit;
        }
        known
    }

    /// The solve of the pose the nominal machine reaches at `q` holding `hold` (the pass's
    /// held axes included), with the guards every mode shares; the solution and the rotary
    /// axes held at a travel limit.
    pub(super) fn solve(
        &self,
        q: &[f64; MAX_AXES],
        hold: u32,
        cx: &Cx<'_, '_>,
        state: &mut State,
    ) -> Result<(Solution, u32), Diagnostic> {
        let n = self.kin.len();
        let line = cx.line.number;
        // An axis the correction would push past a travel limit it was programmed within
        // is held at its programmed value instead (the others still put the tip in place;
        // the direction error it would have fixed is reported).
        let mut hold = hold;
        let mut at_limit = 0u32;
        let solve = |hold: u32, state: &mut State| {
            state
                .presolved
                .take(line, state.pass, &q[..n], state.modal.length, hold)
                .unwrap_or_else(|| {
                    self.kin.compensate(
                        &q[..n],
                        state.modal.length,
                        hold,
                        self.solve_options(state),
                    )
                })
        };
        // Solved in place, not moved out of a loop: a solution is 440 bytes.
        let mut sol = solve(hold, state);
        loop {
            // Only rotary axes: holding one costs direction, never position.
            let past = (0..n).find(|&v| {
                hold & (1 << v) == 0
                    && !self.is_linear(v)
                    && self.travel(v).is_some_and(|[lo, hi]| {
                        // As it would be written: a crossing below the resolution is none.
                        let d = self.decimals.1;
                        let x = scaled(sol.q[v], d)
                            .map_or(sol.q[v], |k| k as f64 / 10f64.powi(d.into()));
                        (x < lo || x > hi) && (lo..=hi).contains(&q[v])
                    })
            });
            match past {
                Some(v) if !self.options.allow_limit_violations => {
                    hold |= 1 << v;
                    at_limit |= 1 << v;
                    sol = solve(hold, state);
                }
                _ => break,
            }
        }
        let word_col = |v: usize| cx.motion.axis_words[v].map(|i| cx.col(i));
        if at_limit != 0 && self.missed(&sol) {
            let v = at_limit.trailing_zeros() as usize;
            return Err(cx
                .refuse(
                    word_col(v).unwrap_or(0),
                    format!(
                        "the correction would push axis {} past its travel limit, and holding it there leaves the tip {:.4} mm off (use --allow-limit-violations to write it anyway)",
                        self.axis_name(v),
                        sol.position_residual
                    ),
                )
                .with_code(TRAVEL_LIMIT));
        }
        // Guard against a model or pose that turns microns into a big move.
        for (v, &programmed) in q.iter().enumerate().take(n) {
            let delta = (sol.q[v] - programmed).abs();
            let limit = if self.is_linear(v) {
                self.options.max_correction.0
            } else {
                self.options.max_correction.1
            };
            if delta.is_nan() || delta > limit {
                return Err(cx.refuse(
                    word_col(v).unwrap_or_else(|| cx.first_col()),
                    format!(
                        "the correction of axis {} would be {delta:.4} {} (more than {limit}); the error model or this pose is not sound",
                        self.axis_name(v),
                        if self.is_linear(v) { "mm" } else { "°" }
                    ),
                ));
            }
        }
        Ok((sol, at_limit))
    }

    /// Travel limits on what the controller is now told, and the record of the block.
    fn finish(
        &self,
        cx: &Cx<'_, '_>,
        end: &Solution,
        at_limit: u32,
        state: &mut State,
        out: &mut Out<'_>,
    ) -> Result<(f64, f64), Diagnostic> {
        let n = self.kin.len();
        for (v, word) in cx.motion.axis_words.iter().enumerate().take(n) {
            if let Some([lo, hi]) = self.travel(v) {
                let x = state.emitted[v];
                if x < lo - 1e-9 || x > hi + 1e-9 {
                    let (limit, side) = if x < lo { (lo, "below") } else { (hi, "above") };
                    let col = word.map_or(0, |i| cx.col(i));
                    let message = if (lo..=hi).contains(&state.pos.nominal[v]) {
                        format!(
                            "after compensation axis {} = {x:.4} is {side} its travel limit {limit}",
                            self.axis_name(v)
                        )
                    } else {
                        format!(
                            "axis {} is programmed to {:.4}, {side} its travel limit {limit}",
                            self.axis_name(v),
                            state.pos.nominal[v]
                        )
                    };
                    if self.options.allow_limit_violations {
                        out.summary
                            .limit_violations
                            .push(cx.refuse(col, message).with_code(TRAVEL_LIMIT));
                    } else {
                        return Err(cx
                            .refuse(
                                col,
                                format!(
                                    "{message} (use --allow-limit-violations to write it anyway)"
                                ),
                            )
                            .with_code(TRAVEL_LIMIT));
                    }
                }
            }
        }
        let (after, direction) = self.record(cx.line.number, end, state, out.summary);
        // A correction never makes the tip worse: where it would, the machine file or the
        // error model is not sound at this pose (a degenerate geometry, an absurd value).
        if after > end.start_position_error.max(1e-3) || after.is_nan() {
            return Err(cx.refuse(
                cx.first_col(),
                format!(
                    "the compensated values would put the tip {:.3} µm from where the program puts it, more than without compensation ({:.3} µm): the machine file (its geometry, its resolution) or the error file is not sound at this pose",
                    after * 1e3,
                    end.start_position_error * 1e3
                ),
            ));
        }
        for v in 0..n {
            if at_limit & (1 << v) != 0 {
                out.summary.note_at_limit(self.axis_name(v), cx.line.number);
            }
        }
        Ok((after, direction))
    }

    /// Count a compensated block (or inserted piece) and record what the model predicts
    /// for it, at the axis values the controller is now told (`State::emitted`); the tip's
    /// distance (mm) and direction angle (rad) there from the target.
    pub(super) fn record(
        &self,
        line: usize,
        sol: &Solution,
        state: &State,
        summary: &mut Summary,
    ) -> (f64, f64) {
        let n = self.kin.len();
        // The solve's pose at the values as written, where the words are those values.
        let (after, beyond) = match &sol.written {
            Some(w) if w.q[..n] == state.emitted[..n] => (w.pose, w.beyond),
            _ => self.kin.pose_near(
                Model::Actual,
                &state.emitted[..n],
                state.modal.length,
                &sol.angles,
            ),
        };
        let (ap, ad) = after.deviation(&sol.target);
        summary.motion_blocks += 1;
        if !state.modal.units_stated && summary.units_assumed.is_none() {
            let units = if state.modal.inch { "inch" } else { "mm" };
            summary.units_assumed = Some((line, units));
        }
        summary.record(
            line,
            sol.start_position_error,
            sol.start_direction_error,
            ap,
            ad,
            sol.singular != 0,
            beyond,
        );
        for v in 0..n {
            if sol.singular & (1 << v) != 0 {
                summary.note_held(self.axis_name(v));
            }
        }
        if state.modal.working_plane.is_some_and(|p| !p.rotation_only) {
            summary.plane_blocks += 1;
            summary.plane_construct = match state.modal.dialect {
                nc::Dialect::Iso => "G68.2",
                nc::Dialect::Heidenhain => "PLANE",
                nc::Dialect::Sinumerik => "CYCLE800",
            };
            summary.plane_direction.update(ad, line);
            if let Some(s) = summary.trace.as_mut().and_then(|t| t.last_mut())
                && s.line == line
            {
                s.plane = true;
            }
        }
        (ap, ad)
    }
}
