//! Moves in machine axes (G0/G1; on a lathe also the turning moves, whose pass turns): the
//! words are the axis values, so the controller's transformation is the identity.
//!
//! Target: the block's axis words, absolute or incremental (G91 exactly, `exact`).
//! Path: a G1 from a known start is split where its compensated path strays ([`super::split`]).
//! Write: the axis words ([`super::writing`]).

use super::TRAVEL_LIMIT;
use super::pipeline::{Block, Mode};
use crate::diag::Diagnostic;
use crate::kinematics::{MAX_AXES, Solution};
use crate::program::exact;

/// A G0/G1 block in machine axes. (The nominal values before the block and the G91 words'
/// exact increments are kept in `State::previous` and `State::units`: a mode is made for
/// every block, and 384 bytes in it would be copied each time.)
#[derive(Default)]
pub(super) struct AxesMode {
    /// Variables whose start was known.
    start_known: u32,
}

impl Mode for AxesMode {
    fn target(&mut self, b: &mut Block, q: &mut [f64; MAX_AXES]) -> Result<bool, Diagnostic> {
        let (pass, cx, state) = (b.pass, b.cx, &mut *b.state);
        let optional = cx.motion.optional;
        if optional && state.modal.incremental {
            return Err(cx.refuse(
                cx.first_col(),
                "an optional block (/) in incremental mode (G91) cannot be compensated: whether it runs shifts every later incremental move, and no correction is right for both settings of block delete (program the block in G90)".into(),
            ));
        }
        if pass.options.path.is_some() {
            state.previous = state.pos.nominal;
        }
        self.start_known = state.pos.programmed & !state.pos.unknown;
        // A feed move cuts from where the axes stand: an axis whose place is not known
        // before it (even one the block sets) leaves the cut's start unknown.
        let unknown_before = state.pos.unknown & !(pass.spindle | pass.idle);
        if !state.modal.rapid && unknown_before != 0 {
            let n = pass.kin.len();
            let names: Vec<&str> = (0..n)
                .filter(|&v| unknown_before & (1 << v) != 0)
                .map(|v| pass.axis_name(v))
                .collect();
            return Err(cx.refuse(
                cx.first_col(),
                format!(
                    "a feed move while axis {} stands where the program has not set it (at the start, or after G28, G30, G53, a machine move or a tool change): where the real tool cuts is not known (expected a rapid G0 that sets every axis before the first feed move)",
                    names.join(", ")
                ),
            ));
        }
        Self::advance(b)?;
        let (pass, cx, state, out) = b.parts();
        let n = pass.kin.len();
        let unknown = state.pos.unknown & !(pass.spindle | pass.idle);
        // An optional block that sets every unknown axis ends at a known pose when it runs
        // (block delete off): it is corrected like any other, and the axes stay unknown
        // after it, as they are when it is skipped.
        let sets = (0..n)
            .filter(|&v| cx.motion.axis_words[v].is_some())
            .fold(0u32, |m, v| m | 1 << v);
        if unknown == 0 || (optional && unknown & !sets == 0) {
            *q = state.pos.nominal;
            return Ok(true);
        }
        // An axis an optional block set where it was unknown is known only when that block
        // runs: this rapid's end is a pose to correct with block delete off, and unknown
        // with it on.
        if let Some(v) = (0..n).find(|&v| !optional && unknown & state.uncertain & (1 << v) != 0) {
            let letter = pass.axis_name(v);
            return Err(cx.refuse(
                cx.first_col(),
                format!(
                    "this rapid leaves axis {letter} where the optional block (/) at line {} put it, and {letter} was not known before that block: with block delete off the move ends at a known pose that needs correcting, with it on at an unknown one (program {letter} in this block, or declare the block-delete state: --block-delete, or block_delete in the machine file)",
                    state.optional_line[v]
                ),
            ));
        }
        // The pose cannot be evaluated: a rapid (in the air; a feed move from an unknown
        // place was refused above) is written as it is, and what the machine is told is
        // what the program says.
        for (v, word) in cx.motion.axis_words.iter().enumerate().take(n) {
            let bit = 1u32 << v;
            let Some(i) = *word else { continue };
            if state.pos.unknown & bit != 0 {
                if optional && !state.modal.incremental {
                    state.uncertain |= bit;
                    state.optional_line[v] = cx.line.number;
                }
                continue;
            }
            let decimals = cx.number(i).1;
            state.decimals[v] = decimals.max(pass.res_decimals(v, pass.unit(v, &state.modal)));
            state.pos.programmed |= bit;
            if state.modal.incremental {
                // The optional-block bits stay: an increment does not settle them.
                state.written[v] = state.written[v].add(state.units[v]);
                state.emitted[v] = exact::to_f64(state.written[v].units());
            } else {
                state.written[v] = state.pos.exact[v];
                state.emitted[v] = state.pos.nominal[v];
                state.unsettled &= !bit;
                if optional {
                    state.uncertain |= bit;
                    state.optional_line[v] = cx.line.number;
                } else {
                    state.uncertain &= !bit;
                }
            }
        }
        let unknown: Vec<&str> = (0..n)
            .filter(|&v| state.pos.unknown & !pass.spindle & (1 << v) != 0)
            .map(|v| pass.axis_name(v))
            .collect();
        out.summary.note_uncompensated(cx.line.number, &unknown);
        Ok(false)
    }

    fn rollover_aware(&self) -> bool {
        true
    }

    fn targets_nominal_pose(&self) -> bool {
        true
    }

    fn path(&mut self, b: &mut Block, end: &Solution, hold: u32) -> Result<(), Diagnostic> {
        let (pass, cx, state, out) = b.parts();
        // Split the move where its path strays (G1 from a known start).
        let n = pass.kin.len();
        if pass.options.path.is_some()
            && !state.modal.rapid
            && (0..n).all(|v| (self.start_known | pass.idle) & (1 << v) != 0)
        {
            // A rollover axis turns the shortest way to its word.
            let ways = pass
                .shortest_from(&state.previous, &state.pos.nominal)
                .and_then(|previous| Ok((previous, pass.shortest_from(&state.emitted, &end.q)?)));
            let (previous, from) = ways.map_err(|v| {
                cx.refuse(
                    cx.motion.axis_words[v].map_or(0, |i| cx.col(i)),
                    format!(
                        "this move turns rollover axis {} by exactly half a turn: which way the control turns it is its own setting (program the move in two)",
                        pass.axis_name(v)
                    ),
                )
            })?;
            pass.split_move(cx, (&previous, &from), end, hold, state, out);
        }
        Ok(())
    }

    fn write(&mut self, b: &mut Block, end: &Solution) -> Result<(), Diagnostic> {
        let (pass, cx, state, out) = b.parts();
        if state.modal.incremental {
            let units = state.units;
            pass.write_increments(cx, &units, &end.q, u32::MAX, state, out)
        } else {
            pass.write_positions(cx, &end.q, cx.motion.optional, state, out)
        }
    }
}

impl AxesMode {
    /// Follow a G0/G1 block's axis words: `state.pos.nominal` (and its exact twin) become the
    /// block's programmed end, absolute or incremental, in mm and degrees, and
    /// `state.units` each G91 word's increment exactly (zeros elsewhere). A programmed value
    /// outside the travel is refused unless limit violations are allowed.
    fn advance(b: &mut Block) -> Result<(), Diagnostic> {
        let (pass, cx, state, out) = b.parts();
        let n = pass.kin.len();
        let axis_words = &cx.motion.axis_words;
        let from_home = state.pos.advance(
            &pass.axes,
            cx.line.content,
            cx.tokens,
            cx.motion,
            &state.modal,
            cx.at,
            &mut state.units,
        )?;
        for v in (0..n).filter(|_| from_home != 0) {
            if from_home & (1 << v) != 0 {
                out.summary
                    .note_incremental_from_home(pass.axis_name(v), cx.line.number);
            }
        }
        // Programmed values outside the travel are the program's own fault.
        for (v, word) in axis_words.iter().enumerate().take(n) {
            if state.pos.unknown & (1 << v) != 0 {
                continue;
            }
            if let Some([lo, hi]) = pass.travel(v)
                && !(lo..=hi).contains(&state.pos.nominal[v])
                && !pass.options.allow_limit_violations
            {
                let col = word.map_or(0, |i| cx.col(i));
                return Err(cx
                    .refuse(
                        col,
                        format!(
                            "axis {} is programmed to {:.4}, outside its travel {lo} … {hi} (use --allow-limit-violations to compensate it anyway)",
                            pass.axis_name(v),
                            state.pos.nominal[v]
                        ),
                    )
                    .with_code(TRAVEL_LIMIT));
            }
        }
        Ok(())
    }
}
