//! Lathes and turning–milling centres: the tool chain and the mode each block runs in.
//!
//! The tool chain: a T word selects the chain whose `tools` list its number (machine file
//! `[tool_chains.NAME]`); T0, and T words on machines that list no tools, select nothing.
//! The axes of a chain the program switches to start from what is known of them: where
//! the program left them when that chain was last active, or, for a chain the program has
//! not driven yet, nowhere nccomp knows (the blocks are written uncompensated until a G90
//! block programs them), unless nothing has moved yet at all.
//!
//! The mode (machines with a `[lathe]` table): the spindle is an axis only while it is
//! positioned, from M19 or a C word on. While it turns (M3, M4) or stands where the
//! program has not positioned it (at the start, after M5 stops it turning), blocks are
//! turning blocks: the spindle is held, and the tip's radius and position along the
//! spindle line are compensated with X and Z alone (`kinematics::turning`). A C word while
//! the spindle turns is refused. After M19 the spindle's angle is not known until a C
//! word programs it. The codes act before the block's motion, as in LinuxCNC's order of
//! execution.

use super::{Compensator, State};
use crate::diag::Diagnostic;
use crate::nc::{self, Token};
use crate::program::exact::{self, Position, Unit};
use crate::program::{BlockMotion, Motion, Spindle, WorkingPlane};

/// What the program last told one machine axis, kept while its tool chain is not active.
#[derive(Debug, Clone, Copy)]
pub(super) struct Parked {
    nominal: f64,
    nominal_exact: Position,
    emitted: f64,
    written: Position,
    decimals: u8,
    optional_line: usize,
    corrected_line: usize,
    /// Bits of [`State`]'s masks: unknown, programmed, uncertain, unsettled.
    flags: [bool; 4],
}

impl Parked {
    fn take(state: &State, v: usize) -> Parked {
        let bit = |mask: u32| mask & (1 << v) != 0;
        Parked {
            nominal: state.pos.nominal[v],
            nominal_exact: state.pos.exact[v],
            emitted: state.emitted[v],
            written: state.written[v],
            decimals: state.decimals[v],
            optional_line: state.optional_line[v],
            corrected_line: state.corrected_line[v],
            flags: [
                bit(state.pos.unknown),
                bit(state.pos.programmed),
                bit(state.uncertain),
                bit(state.unsettled),
            ],
        }
    }

    /// An axis the program has not driven: at home, or unknown once anything has moved.
    fn fresh(unknown: bool, decimals: u8) -> Parked {
        Parked {
            nominal: 0.0,
            nominal_exact: Position::Units(0),
            emitted: 0.0,
            written: Position::Units(0),
            decimals,
            optional_line: 0,
            corrected_line: 0,
            flags: [unknown, false, false, false],
        }
    }

    fn put(&self, state: &mut State, v: usize) {
        state.pos.nominal[v] = self.nominal;
        state.pos.exact[v] = self.nominal_exact;
        state.emitted[v] = self.emitted;
        state.written[v] = self.written;
        state.decimals[v] = self.decimals;
        state.optional_line[v] = self.optional_line;
        state.corrected_line[v] = self.corrected_line;
        let masks = [
            &mut state.pos.unknown,
            &mut state.pos.programmed,
            &mut state.uncertain,
            &mut state.unsettled,
        ];
        for (mask, &set) in masks.into_iter().zip(&self.flags) {
            if set {
                *mask |= 1 << v;
            } else {
                *mask &= !(1 << v);
            }
        }
    }
}

impl Compensator<'_> {
    /// Read one block with the program's reader and follow what it changed: the tool chain
    /// and spindle mode (which pass the block runs in, the axes that become unknown), tool-
    /// centre-point control switched on, a cycle ended. Whether it moves, and how (into
    /// `motion`).
    pub(super) fn read(
        &self,
        line: &nc::Line<'_>,
        tokens: &[Token],
        state: &mut State,
        summary: &mut super::Summary,
        at: &dyn Fn(usize, String) -> Diagnostic,
        motion: &mut BlockMotion,
    ) -> Result<bool, Diagnostic> {
        let before = (state.modal.chain, state.modal.spindle);
        let was_tcp = state.modal.tcp.then_some(state.modal.tcp_vector);
        let was_plane = (state.modal.working_plane, state.modal.length);
        let read = self.reader.read(line, tokens, &mut state.modal, at, motion);
        if self.block_delete() == Some(false) {
            // Declared off: a block with `/` runs like any other.
            motion.optional = false;
        }
        if (state.modal.chain, state.modal.spindle) == before {
            // The usual block: the pass stays (a machine with one chain and no lathe never
            // leaves it).
            let moves = read?;
            return self
                .follow_modes(state, (was_tcp, was_plane), at)
                .map(|()| moves);
        }
        // The chain and spindle mode change even when a later word of the block is refused.
        if state.modal.chain != before.0 && self.switch_chain(state, state.modal.chain) {
            summary.lathe_unknown = true;
        }
        let pass = state.modal.chain
            + if state.modal.turning(self.machine) {
                self.machine.tool_chains.len()
            } else {
                0
            };
        if state.modal.spindle == Spindle::Positioned && before.1 != Spindle::Positioned {
            // Until a C word says where, the spindle stands at an angle nccomp does not
            // know (M19's orientation is the machine's own).
            let p = &self.passes[pass];
            let lathe = self.machine.lathe;
            if let Some(v) = lathe.and_then(|l| p.kin.axes().iter().position(|&i| i == l.spindle)) {
                state.pos.unknown |= 1 << v;
                state.uncertain &= !(1 << v);
                state.unsettled &= !(1 << v);
                summary.lathe_unknown = true;
            }
        }
        state.pass = pass;
        let moves = read?;
        self.follow_modes(state, (was_tcp, was_plane), at)
            .map(|()| moves)
    }

    /// Follow what a block read changed of the pass's modes: a cycle ended, a tilted
    /// working plane set or the tool length changed under one (from `was_plane`),
    /// tool-centre-point control switched on (from
    /// `was_tcp`: off, or on with or without vectors).
    fn follow_modes(
        &self,
        state: &mut State,
        (was_tcp, was_plane): (Option<bool>, (Option<WorkingPlane>, f64)),
        at: &dyn Fn(usize, String) -> Diagnostic,
    ) -> Result<(), Diagnostic> {
        if state.cycle.is_some() && state.modal.motion != Some(Motion::Cycle) {
            state.cycle = None;
        }
        if state.modal.motion != Some(Motion::Arc) {
            // The original left arc mode with a code the output keeps.
            state.straightened = false;
        }
        // TCP or a tilted working plane ended: the axes stand where the controller's solve
        // of the tip words put them, and an increment (G91) travels from there, not from
        // the last axis words.
        let left_tcp = was_tcp.is_some() && !state.modal.tcp;
        let left_plane = was_plane.0.is_some() && state.modal.working_plane.is_none();
        if left_tcp || left_plane {
            for v in 0..self.passes[state.pass].kin.len() {
                state.pos.exact[v] = Position::Units(exact::from_f64(state.pos.nominal[v]));
            }
        }
        // A new plane, or a new tool length under one, moves the tip words.
        if (state.modal.working_plane, state.modal.length) != was_plane {
            self.passes[state.pass].enter_plane(state);
        }
        if state.modal.tcp
            && was_tcp != Some(state.modal.tcp_vector)
            && let Err(d) = self.passes[state.pass].enter_tcp(state, at)
        {
            state.modal.tcp = false;
            state.modal.tcp_vector = false;
            return Err(d);
        }
        Ok(())
    }

    /// Park the axes of the active chain and bring in those of `chain`. True when an axis
    /// of the new chain starts unknown.
    fn switch_chain(&self, state: &mut State, chain: usize) -> bool {
        let from = &self.passes[state.pass];
        // The milling pass of `chain`: its turning pass has the same variables.
        let to = &self.passes[chain];
        let moved = state.pos.programmed != 0 || state.pos.unknown != 0;
        for (v, &axis) in from.kin.axes().iter().enumerate() {
            state.parked[axis] = Some(Parked::take(state, v));
        }
        let mut unknown = false;
        for (v, &axis) in to.kin.axes().iter().enumerate() {
            match state.parked[axis] {
                Some(parked) => parked.put(state, v),
                None => {
                    unknown |= moved;
                    Parked::fresh(moved, to.res_decimals(v, Unit::MM)).put(state, v);
                }
            }
        }
        // Variables past the new chain's count must not carry stale bits.
        let n = to.kin.len();
        let beyond = !((1u32 << n) - 1);
        state.pos.unknown &= !beyond;
        state.pos.programmed &= !beyond;
        state.uncertain &= !beyond;
        state.unsettled &= !beyond;
        unknown
    }
}
