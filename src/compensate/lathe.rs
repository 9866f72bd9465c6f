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

use super::exact::{Position, Unit};
use super::{Compensator, State, code_text};
use crate::diag::Diagnostic;
use crate::nc::{self, Token, TokenKind, Value};

/// What the lathe's spindle does.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Spindle {
    /// Stopped where the program has not positioned it (at the start, after M5).
    Free,
    /// Turning, since M3 or M4 at this line.
    Turning(usize),
    /// Positioned (M19 or a C word): an axis like any other.
    Positioned,
}

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
            nominal: state.nominal[v],
            nominal_exact: state.nominal_exact[v],
            emitted: state.emitted[v],
            written: state.written[v],
            decimals: state.decimals[v],
            optional_line: state.optional_line[v],
            corrected_line: state.corrected_line[v],
            flags: [
                bit(state.unknown),
                bit(state.programmed),
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
        state.nominal[v] = self.nominal;
        state.nominal_exact[v] = self.nominal_exact;
        state.emitted[v] = self.emitted;
        state.written[v] = self.written;
        state.decimals[v] = self.decimals;
        state.optional_line[v] = self.optional_line;
        state.corrected_line[v] = self.corrected_line;
        let masks = [
            &mut state.unknown,
            &mut state.programmed,
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
    /// Follow the block's T word and spindle codes: switch `state` to the pass the block
    /// runs in.
    pub(super) fn select(
        &self,
        line: &nc::Line<'_>,
        tokens: &[Token],
        state: &mut State,
        summary: &mut super::Summary,
        at: &dyn Fn(usize, String) -> Diagnostic,
    ) -> Result<(), Diagnostic> {
        let lathe = self.machine.lathe;
        let tools_listed = self.machine.tool_chains.iter().any(|c| !c.tools.is_empty());
        if lathe.is_none() && !tools_listed {
            return Ok(());
        }
        let optional = tokens
            .iter()
            .find(|t| t.kind != TokenKind::Space)
            .is_some_and(|t| t.kind == TokenKind::BlockDelete);
        let current = self.passes[state.pass].chain;
        let mut chain = current;
        let mut spindle = state.spindle;
        // The first word that changes something, for messages.
        let mut cause: Option<&Token> = None;
        let mut spindle_word: Option<&Token> = None;
        let spindle_letter = lathe.map(|l| self.machine.axes[l.spindle].word as u8);
        for t in tokens {
            let TokenKind::Word(w) = &t.kind else {
                continue;
            };
            // Expressions and parameters are refused when the block is read.
            let Value::Number { value, .. } = w.value else {
                continue;
            };
            match w.letter {
                b'T' if tools_listed => {
                    if value < 0.0 || value.fract() != 0.0 || value > f64::from(u32::MAX) {
                        return Err(at(
                            t.span.start,
                            format!(
                                "`{}`: expected a tool number (a whole number from 0)",
                                code_text(line.content, t)
                            ),
                        ));
                    }
                    let number = value as u32;
                    if number == 0 {
                        continue;
                    }
                    chain = self.machine.chain_of_tool(number).ok_or_else(|| {
                        let lists: Vec<String> = self
                            .machine
                            .tool_chains
                            .iter()
                            .filter(|c| !c.tools.is_empty())
                            .map(|c| {
                                let tools: Vec<String> =
                                    c.tools.iter().map(|t| format!("T{t}")).collect();
                                format!("`{}` {}", c.name, tools.join(" "))
                            })
                            .collect();
                        at(
                            t.span.start,
                            format!(
                                "T{number} selects no tool chain: expected a tool the machine file lists in a chain's `tools` ({})",
                                lists.join("; ")
                            ),
                        )
                    })?;
                    if chain != current {
                        cause.get_or_insert(t);
                    }
                }
                b'M' if lathe.is_some() => {
                    let before = spindle;
                    match (value * 10.0).round() as i64 {
                        30 | 40 => spindle = Spindle::Turning(line.number),
                        // Stopping a positioned spindle leaves it where it is.
                        50 if spindle != Spindle::Positioned => spindle = Spindle::Free,
                        190 => spindle = Spindle::Positioned,
                        _ => {}
                    }
                    if spindle != before {
                        cause.get_or_insert(t);
                    }
                }
                letter if Some(letter) == spindle_letter => spindle_word = Some(t),
                _ => {}
            }
        }
        if let Some(t) = spindle_word {
            if let Spindle::Turning(on) = spindle {
                let letter = spindle_letter.map_or('C', char::from);
                return Err(at(
                    t.span.start,
                    format!(
                        "{letter} positions the spindle, but it turns (M3/M4 at line {on}): expected M5 or M19 before the spindle is positioned"
                    ),
                ));
            }
            if spindle != Spindle::Positioned {
                cause.get_or_insert(t);
                spindle = Spindle::Positioned;
            }
        }
        let Some(cause) = cause else {
            return Ok(());
        };
        let what = code_text(line.content, cause);
        if optional {
            return Err(at(
                cause.span.start,
                format!(
                    "{what} in an optional block (/) cannot be compensated: whether the block runs would decide which tool chain or spindle mode every later block is compensated in (move it out of the optional block)"
                ),
            ));
        }
        let positioned = spindle == Spindle::Positioned;
        let was_positioned = state.spindle == Spindle::Positioned;
        if state.tcp && (chain != current || positioned != was_positioned) {
            return Err(at(
                cause.span.start,
                format!(
                    "{what} under tool-centre-point control (G43.4/G43.5) cannot be compensated: cancel it (G49) first"
                ),
            ));
        }
        if chain != current && self.switch_chain(state, chain) {
            summary.lathe_unknown = true;
        }
        let pass = chain
            + if lathe.is_some() && !positioned {
                self.machine.tool_chains.len()
            } else {
                0
            };
        if positioned && !was_positioned {
            // Until a C word says where, the spindle stands at an angle nccomp does not
            // know (M19's orientation is the machine's own).
            let p = &self.passes[pass];
            if let Some(v) = lathe.and_then(|l| p.kin.axes().iter().position(|&i| i == l.spindle)) {
                state.unknown |= 1 << v;
                state.uncertain &= !(1 << v);
                state.unsettled &= !(1 << v);
                summary.lathe_unknown = true;
            }
        }
        state.spindle = spindle;
        state.pass = pass;
        Ok(())
    }

    /// Park the axes of the active chain and bring in those of `chain`. True when an axis
    /// of the new chain starts unknown.
    fn switch_chain(&self, state: &mut State, chain: usize) -> bool {
        let from = &self.passes[state.pass];
        // The milling pass of `chain`: its turning pass has the same variables.
        let to = &self.passes[chain];
        let moved = state.programmed != 0 || state.unknown != 0;
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
        state.unknown &= !beyond;
        state.programmed &= !beyond;
        state.uncertain &= !beyond;
        state.unsettled &= !beyond;
        unknown
    }
}
