//! Splitting a move whose compensated path strays from the nominal one.
//!
//! The controller interpolates axis values linearly between blocks; with the ends of a
//! move compensated, its middle can still be off (the errors vary along the move, and the
//! kinematics is not linear). Where the deviation at a piece's quarter points exceeds the
//! tolerance, blocks are inserted before the move, at compensated points of its nominal
//! path (`kinematics::path`). Inserted blocks look like the program's own: N numbers in a
//! gap of the numbering where there is one, the block's G words, letter case, spacing and
//! decimals; in inverse-time feed (G93) each piece gets the F that keeps the move's time.

use super::exact::{self, Position};
use super::{Edit, Pass, State, Summary, axis_order};
use crate::kinematics::MAX_AXES;
use crate::kinematics::path::{PathTolerance, Piece};
use crate::nc::number::{same_text, write_fixed};
use crate::nc::{self, Token, TokenKind, Value};
use std::fmt::Write;

impl Pass<'_> {
    /// Split the current G1 move if its path needs it: push an edit inserting the new
    /// blocks before the line (and, in G93, one giving the block its share of F), and
    /// advance `state` to the last inserted point. `previous`: the nominal values before
    /// the block; `end`: its compensated values.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn split_move(
        &self,
        tolerance: &PathTolerance,
        line: &nc::Line<'_>,
        tokens: &[Token],
        previous: &[f64; MAX_AXES],
        end: &[f64; MAX_AXES],
        hold: u32,
        state: &mut State,
        edits: &mut Vec<Edit>,
        summary: &mut Summary,
    ) {
        let n = self.kin.len();
        // The pass's list of pieces, taken while `state` changes below and given back.
        let mut pieces = std::mem::take(&mut state.pieces);
        self.kin.subdivide_into(
            (&previous[..n], &state.nominal[..n]),
            (&state.emitted[..n], &end[..n]),
            state.modal.length,
            hold,
            tolerance,
            &self.options.solve,
            &mut pieces,
        );
        if pieces.len() >= 2 {
            self.insert_pieces(line, tokens, &pieces, state, edits, summary);
        }
        state.pieces = pieces;
    }

    /// The blocks of a split move before the line (see [`Pass::split_move`]).
    fn insert_pieces(
        &self,
        line: &nc::Line<'_>,
        tokens: &[Token],
        pieces: &[Piece],
        state: &mut State,
        edits: &mut Vec<Edit>,
        summary: &mut Summary,
    ) {
        let n = self.kin.len();
        // Words that would run twice or at the wrong time (tool changes, M functions) keep
        // the block whole, and so does G93 without an F to share out.
        let mut f_word = None;
        let mut whole = false;
        for t in tokens {
            if let TokenKind::Word(w) = &t.kind {
                match w.letter {
                    b'M' | b'T' => whole = true,
                    b'F' => f_word = Some(t),
                    _ => {}
                }
            }
        }
        // In G91 an axis last set by an optional block starts from a place that depends on
        // the block delete switch: no increment from it is right (the block itself says so).
        let uncertain = state.modal.incremental && (state.uncertain | state.unsettled) != 0;
        if whole || uncertain || (state.modal.inverse_time && f_word.is_none()) {
            summary.note_unsplit(line.number);
            return;
        }
        let ending = if line.ending.is_empty() {
            "\n"
        } else {
            std::str::from_utf8(line.ending).unwrap_or("\n")
        };
        let style = Style::of(line.content, tokens);
        let numbers = self.inserted_numbers(tokens, line.content, state, pieces.len() - 1);
        let mut order: Vec<usize> = (0..n).collect();
        order.sort_by_key(|&v| axis_order(self.letter(v)));
        let mut text = String::new();
        let mut s_before = 0.0;
        for (k, piece) in pieces[..pieces.len() - 1].iter().enumerate() {
            let mut words: Vec<String> = Vec::new();
            if let Some(number) = &numbers[k] {
                words.push(style.letter(b'N') + number);
            }
            // The block's own modal words, so the piece runs as the block would.
            for t in tokens {
                if let TokenKind::Word(w) = &t.kind
                    && matches!(w.letter, b'G' | b'H' | b'D' | b'S')
                {
                    words.push(String::from_utf8_lossy(&line.content[t.span.clone()]).into_owned());
                }
            }
            for &v in &order {
                let unit = self.unit(v, &state.modal);
                let value = unit.of_mm(piece.q[v]);
                let d = state.decimals[v].max(self.res_decimals(v, unit));
                if state.modal.incremental {
                    // The exact difference between two written absolute positions, as the
                    // block's own increments are written: no drift.
                    let d = d.min(exact::MAX_DECIMALS);
                    let Some((k, e)) = exact::increment(state.written[v].units(), value, d, unit)
                    else {
                        continue;
                    };
                    if k == 0 {
                        continue;
                    }
                    let mut number = String::new();
                    exact::write_digits(k, e, &mut number);
                    state.written[v] = state.written[v].add(exact::units(k, e, unit).unwrap_or(0));
                    state.emitted[v] = exact::to_f64(state.written[v].units());
                    words.push(style.letter(self.letter(v)) + &number);
                    continue;
                }
                if same_text(unit.of_mm(state.emitted[v]), value, d) {
                    continue;
                }
                let mut number = String::new();
                write_fixed(value, d, &mut number);
                state.emitted[v] = number.parse::<f64>().map_or(piece.q[v], |x| unit.to_mm(x));
                state.written[v] = Position::Decimal {
                    value,
                    decimals: d,
                    unit,
                };
                words.push(style.letter(self.letter(v)) + &number);
            }
            if let Some(f) = f_word
                && let TokenKind::Word(w) = &f.kind
                && let Value::Number { value, decimals } = w.value
            {
                if state.modal.inverse_time {
                    // The piece takes its share of the block's time.
                    let share = piece.s - s_before;
                    let mut number = String::new();
                    write_fixed(value / share, decimals.max(3) + 1, &mut number);
                    words.push(style.letter(b'F') + &number);
                } else if k == 0 {
                    words.push(String::from_utf8_lossy(&line.content[f.span.clone()]).into_owned());
                }
            }
            s_before = piece.s;
            if let Some(sol) = &piece.solution {
                self.record_block(line.number, sol, state, summary);
            }
            let _ = write!(text, "{}{}", words.join(style.separator), ending);
        }
        if state.modal.inverse_time
            && let Some(f) = f_word
            && let TokenKind::Word(w) = &f.kind
            && let Value::Number { value, decimals } = w.value
        {
            let mut number = String::new();
            write_fixed(value / (1.0 - s_before), decimals.max(3) + 1, &mut number);
            edits.push(Edit {
                at: w.value_span.clone(),
                text: number.into(),
            });
        }
        summary.note_split(line.number, pieces.len() - 1);
        edits.insert(
            0,
            Edit {
                at: 0..0,
                text: text.into(),
            },
        );
    }

    /// N numbers for `count` blocks inserted before the current one: consecutive numbers
    /// in the gap after the previous block's number when the gap is wide enough, else the
    /// block's own number again; none when the block has no N word.
    pub(super) fn inserted_numbers(
        &self,
        tokens: &[Token],
        content: &[u8],
        state: &State,
        count: usize,
    ) -> Vec<Option<String>> {
        let own = tokens.iter().find_map(|t| match &t.kind {
            TokenKind::Word(w) if w.letter == b'N' => {
                let digits = &content[w.value_span.clone()];
                let text = String::from_utf8_lossy(digits).into_owned();
                text.parse::<u64>().ok().map(|v| (v, text))
            }
            _ => None,
        });
        let Some((value, text)) = own else {
            return vec![None; count];
        };
        // Zero padding only where the program pads (N0010), never a new leading zero.
        let width = if text.starts_with('0') { text.len() } else { 0 };
        match state.last_n {
            Some((prev, _)) if value > prev && (value - prev - 1) as usize >= count => (1..=count)
                .map(|i| Some(format!("{:0width$}", prev + i as u64)))
                .collect(),
            _ => vec![Some(text); count],
        }
    }
}

/// How a block writes its words: letter case and what stands between words.
pub(super) struct Style {
    lowercase: bool,
    pub(super) separator: &'static str,
}

impl Style {
    pub(super) fn of(_content: &[u8], tokens: &[Token]) -> Style {
        let lowercase = tokens.iter().find_map(|t| match &t.kind {
            TokenKind::Word(w) => Some(w.lowercase),
            _ => None,
        }) == Some(true);
        let packed = tokens.windows(2).any(|w| {
            matches!(w[0].kind, TokenKind::Word(_)) && matches!(w[1].kind, TokenKind::Word(_))
        });
        Style {
            lowercase,
            separator: if packed { "" } else { " " },
        }
    }

    pub(super) fn letter(&self, letter: u8) -> String {
        let c = if self.lowercase {
            letter.to_ascii_lowercase()
        } else {
            letter
        };
        (c as char).to_string()
    }
}
