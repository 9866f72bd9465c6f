//! Splitting a move whose compensated path strays from the nominal one.
//!
//! The controller interpolates axis values linearly between blocks; with the ends of a
//! move compensated, its middle can still be off (the errors vary along the move, and the
//! kinematics is not linear). Where the deviation at a piece's quarter points exceeds the
//! tolerance, blocks are inserted before the move, at compensated points of its nominal
//! path (`kinematics::path`). Inserted blocks look like the program's own: N numbers in a
//! gap of the numbering where there is one, the block's G words, letter case, spacing and
//! decimals; in inverse-time feed (G93) each piece gets the F that keeps the move's time.

use super::pipeline::{Cx, Out};
use super::{Pass, State};
use crate::kinematics::path::{PathTolerance, Piece};
use crate::kinematics::{MAX_AXES, Solution};
use crate::nc::edit::Editor;
use crate::nc::number::write_fixed;
use crate::nc::{TokenKind, Value};
use crate::program::{gcode, heidenhain};
use std::fmt::Write;

impl Pass<'_> {
    /// Split the current G1 move if its path needs it: push an edit inserting the new
    /// blocks before the line (and, in G93, one giving the block its share of F), and
    /// advance `state` to the last inserted point. `previous`, `from`: the nominal values
    /// before the block and the ones the machine was told; `end`: its solution.
    pub(super) fn split_move(
        &self,
        cx: &Cx<'_, '_>,
        (previous, from): (&[f64; MAX_AXES], &[f64; MAX_AXES]),
        end: &Solution,
        hold: u32,
        state: &mut State,
        out: &mut Out<'_>,
    ) {
        let Some(tolerance) = &self.path_tolerance(state) else {
            return;
        };
        if self.within_bound((previous, from), end, tolerance, state) {
            return;
        }
        let end = &end.q;
        let n = self.kin.len();
        // The pass's list of pieces, taken while `state` changes below and given back.
        let mut pieces = std::mem::take(&mut state.pieces);
        self.kin.subdivide_into(
            (&previous[..n], &state.pos.nominal[..n]),
            (&from[..n], &end[..n]),
            state.modal.length,
            hold,
            tolerance,
            &self.comp_solve,
            &mut pieces,
        );
        if pieces.len() >= 2 {
            self.insert_pieces(cx, &pieces, state, out);
        }
        state.pieces = pieces;
    }

    /// Whether the move is proven within `tolerance` without a pose: its ends' deviations
    /// (the start's from the block before, the end's the solve's residual) and the bound
    /// on what it adds between them (`Kinematics::path_sag`). A move proven so is one the
    /// sampled check would not split: the output is the same. The test mirrors the
    /// sampled check's, its floor included (a start written coarser than the tolerance).
    fn within_bound(
        &self,
        (previous, from): (&[f64; MAX_AXES], &[f64; MAX_AXES]),
        end: &Solution,
        tolerance: &PathTolerance,
        state: &State,
    ) -> bool {
        let n = self.kin.len();
        let length = state.modal.length;
        let Some(start) = state.end.filter(|e| {
            e.kin == self.kin_id()
                && e.length.to_bits() == length.to_bits()
                && bitwise_equal(&e.told[..n], &from[..n])
                && bitwise_equal(&e.nominal[..n], &previous[..n])
        }) else {
            return false;
        };
        let Some(sag) = self.kin.path_sag(
            (&previous[..n], &state.pos.nominal[..n]),
            (&from[..n], &end.q[..n]),
            length,
        ) else {
            return false;
        };
        // Evaluating a pose rounds at 10⁻¹³ mm; the bound is kept clear of that.
        let slack = (1e-9, 1e-12);
        let sag_position = sag.position + slack.0;
        let position = start.position.max(end.position_residual) + sag_position;
        // Directions: the end angles bound their chords; the chord found bounds its angle
        // within 0.1 % below 0.1 rad.
        let chord = start.direction.max(end.direction_residual) + sag.direction;
        let direction = chord * 1.001 + slack.1;
        chord < 0.1
            && direction <= tolerance.direction
            && (position <= tolerance.position
                || (end.position_residual <= start.position && sag_position <= tolerance.position))
    }

    /// The blocks of a split move before the line (see [`Pass::split_move`]).
    fn insert_pieces(
        &self,
        cx: &Cx<'_, '_>,
        pieces: &[Piece],
        state: &mut State,
        out: &mut Out<'_>,
    ) {
        let (line, tokens) = (cx.line, cx.tokens);
        // Words that would run twice or at the wrong time (tool changes, M functions) keep
        // the block whole, and so does G93 without an F to share out.
        let f_word = cx.word(b'F');
        let whole = gcode::once_word(tokens).is_some();
        // In G91 an axis last set by an optional block starts from a place that depends on
        // the block delete switch: no increment from it is right (the block itself says so).
        let uncertain = state.modal.incremental && (state.uncertain | state.unsettled) != 0;
        if whole || uncertain || (state.modal.inverse_time && f_word.is_none()) {
            out.summary.note_unsplit(line.number);
            return;
        }
        let ending = Editor::ending(line.ending);
        let mut editor = cx.editor(out.edits);
        let style = editor.style();
        let numbers = editor.inserted_numbers(state.last_n, pieces.len() - 1);
        let tnc = state.modal.dialect == crate::nc::Dialect::Heidenhain;
        let mut text = String::new();
        let mut s_before = 0.0;
        for (k, piece) in pieces[..pieces.len() - 1].iter().enumerate() {
            let mut words: Vec<String> = Vec::new();
            if tnc {
                words = heidenhain::inserted_start(line.content, tokens, state.renumber, k);
            } else if let Some(number) = &numbers[k] {
                words.push(style.word(b'N', number));
            }
            // The block's own modal words, so the piece runs as the block would.
            if !tnc {
                for i in gcode::carried_words(tokens, None) {
                    words.push(String::from_utf8_lossy(editor.text(i)).into_owned());
                }
            }
            self.piece_words(&piece.q, state, &style, &mut words);
            if tnc {
                for i in heidenhain::carried_words(tokens) {
                    words.push(String::from_utf8_lossy(editor.text(i)).into_owned());
                }
            }
            if let Some(f) = f_word
                && let TokenKind::Word(w) = &tokens[f].kind
                && let Value::Number { value, decimals } = w.value
            {
                if state.modal.inverse_time {
                    // The piece takes its share of the block's time.
                    let share = piece.s - s_before;
                    let mut number = String::new();
                    write_fixed(value / share, decimals.max(3) + 1, &mut number);
                    words.push(style.word(b'F', &number));
                } else if k == 0 {
                    words.push(String::from_utf8_lossy(editor.text(f)).into_owned());
                }
            }
            s_before = piece.s;
            if let Some(sol) = &piece.solution {
                self.record(line.number, sol, state, out.summary);
            }
            // A piece of an optional block is optional too: skipped with its block.
            let skip = if cx.motion.optional { "/" } else { "" };
            let _ = write!(text, "{skip}{}{}", words.join(style.separator), ending);
        }
        if state.modal.inverse_time
            && let Some(f) = f_word
            && let TokenKind::Word(w) = &tokens[f].kind
            && let Value::Number { value, decimals } = w.value
        {
            let mut number = String::new();
            write_fixed(value / (1.0 - s_before), decimals.max(3) + 1, &mut number);
            editor.replace_number(f, number);
        }
        out.summary.note_split(line.number, pieces.len() - 1);
        editor.insert_blocks(text);
    }
}

/// Equal to the last bit (a key, not a measure: -0.0 and 0.0 differ, NaN is never equal).
fn bitwise_equal(a: &[f64], b: &[f64]) -> bool {
    a.iter()
        .zip(b)
        .all(|(x, y)| x.to_bits() == y.to_bits() && !x.is_nan())
}
