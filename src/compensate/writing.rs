//! Writing a compensated block's axis words: positions in G90, increments in G91.

use super::exact::{self, Position};
use super::{Edit, Pass, State, Summary};
use crate::diag::Diagnostic;
use crate::kinematics::MAX_AXES;
use crate::nc::number::{Rounded, same_text, write_fixed_value, write_scaled_bytes};
use crate::nc::{self, Token, TokenKind, Value};

/// The value and decimals of a token known to be a numeric word, and its value's span.
fn number(t: &Token) -> (f64, u8, std::ops::Range<usize>) {
    let TokenKind::Word(w) = &t.kind else {
        unreachable!("axis words are words")
    };
    let Value::Number { value, decimals } = w.value else {
        unreachable!("axis words are numbers")
    };
    (value, decimals, w.value_span.clone())
}

impl Pass<'_> {
    /// G90: write each axis's compensated position `q` (mm, degrees); a word keeps its
    /// bytes when the new value prints the same, an axis the block omits gets a word when
    /// its value changes.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn write_positions(
        &self,
        line: &nc::Line<'_>,
        tokens: &[Token],
        axis_words: &[Option<usize>; MAX_AXES],
        q: &[f64],
        optional: bool,
        state: &mut State,
        edits: &mut Vec<Edit>,
        summary: &mut Summary,
        at: &dyn Fn(usize, String) -> Diagnostic,
    ) -> Result<(), Diagnostic> {
        for &v in &self.write_order {
            let unit = self.unit(v, &state.modal);
            let value = unit.of_mm(q[v]);
            match axis_words[v] {
                Some(i) => {
                    let (old, decimals, span) = number(&tokens[i]);
                    let d = decimals.max(self.res_decimals(v, unit));
                    state.decimals[v] = d;
                    let rounded = Rounded::new(value, d);
                    if rounded.prints_as(old) {
                        state.emitted[v] = unit.to_mm(old);
                        state.written[v] = state.nominal_exact[v];
                    } else {
                        let mut text = state.spare_texts.pop().unwrap_or_default();
                        state.emitted[v] = unit.to_mm(rounded.write_bytes(&mut text));
                        state.written[v] = Position::Decimal {
                            value,
                            decimals: d,
                            unit,
                        };
                        edits.push(Edit { at: span, text });
                        summary.words_changed += 1;
                    }
                    state.programmed |= 1 << v;
                    state.unsettled &= !(1 << v);
                    if optional {
                        state.uncertain |= 1 << v;
                        state.optional_line[v] = line.number;
                    } else {
                        state.uncertain &= !(1 << v);
                    }
                }
                None => {
                    let d = state.decimals[v].max(self.res_decimals(v, unit));
                    let unsettled = state.unsettled & (1 << v) != 0 && !optional;
                    if unsettled || !same_text(unit.of_mm(state.emitted[v]), value, d) {
                        if state.uncertain & (1 << v) != 0 && !optional {
                            let letter = self.letter(v) as char;
                            return Err(at(
                                first_column(tokens, axis_words),
                                format!(
                                    "this block needs a corrected {letter} word, but {letter} was last set by the optional block (/) at line {}: adding it would change what the program does when block delete is on (program {letter} in this block)",
                                    state.optional_line[v]
                                ),
                            ));
                        }
                        if optional {
                            state.unsettled |= 1 << v;
                            state.corrected_line[v] = line.number;
                        } else {
                            state.unsettled &= !(1 << v);
                        }
                        let mut text = String::new();
                        state.emitted[v] = unit.to_mm(write_fixed_value(value, d, &mut text));
                        state.written[v] = Position::Decimal {
                            value,
                            decimals: d,
                            unit,
                        };
                        edits.push(self.insertion(line.content, tokens, axis_words, v, &text));
                        summary.words_added += 1;
                        if state.programmed & (1 << v) == 0 {
                            summary.note_assumed_home(self.axis_name(v), line.number);
                        }
                    }
                }
            }
        }
        Ok(())
    }

    /// G91: write each axis's increment from what the machine was told (exactly, the sum
    /// of everything written) to its compensated position `q` rounded: the written
    /// positions never drift from the rounded compensated ones. A word keeps its bytes
    /// when its increment prints the same; an axis the block omits (increment 0) gets a
    /// word when its compensated increment is not 0. `units`: the block's words, exactly.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn write_increments(
        &self,
        line: &nc::Line<'_>,
        tokens: &[Token],
        axis_words: &[Option<usize>; MAX_AXES],
        units: &[i128; MAX_AXES],
        q: &[f64],
        state: &mut State,
        edits: &mut Vec<Edit>,
        summary: &mut Summary,
        at: &dyn Fn(usize, String) -> Diagnostic,
    ) -> Result<(), Diagnostic> {
        for &v in &self.write_order {
            let bit = 1u32 << v;
            let unit = self.unit(v, &state.modal);
            let value = unit.of_mm(q[v]);
            let letter = self.letter(v) as char;
            // The axis's position depends on whether an optional block ran: an increment
            // from it cannot be right for both settings of block delete.
            let optional_line = if state.uncertain & bit != 0 {
                Some(state.optional_line[v])
            } else if state.unsettled & bit != 0 {
                Some(state.corrected_line[v])
            } else {
                None
            };
            let word = axis_words[v];
            let col = word.map_or_else(
                || first_column(tokens, axis_words),
                |i| tokens[i].span.start,
            );
            let d = match word {
                Some(i) => number(&tokens[i]).1.max(self.res_decimals(v, unit)),
                None => state.decimals[v]
                    .max(self.res_decimals(v, unit))
                    .min(exact::MAX_DECIMALS),
            };
            let (k, e) =
                exact::increment(state.written[v].units(), value, d, unit).ok_or_else(|| {
                    at(
                        col,
                        format!(
                            "the increment of axis {} to {value} cannot be written exactly",
                            self.axis_name(v)
                        ),
                    )
                })?;
            let increment = exact::units(k, e, unit).unwrap_or(0);
            if let Some(at_line) = optional_line
                && (word.is_some() || k != 0)
            {
                return Err(at(
                    col,
                    format!(
                        "this incremental (G91) block {} {letter}, but {letter} was last set by the optional block (/) at line {at_line}: where it starts from depends on the block delete switch (program {letter} in G90 after the optional block)",
                        if word.is_some() {
                            "moves"
                        } else {
                            "needs a corrected"
                        }
                    ),
                ));
            }
            match word {
                Some(i) => {
                    state.decimals[v] = d;
                    state.programmed |= bit;
                    if increment != units[v] {
                        let mut text = state.spare_texts.pop().unwrap_or_default();
                        write_scaled_bytes(k, e, &mut text);
                        edits.push(Edit {
                            at: number(&tokens[i]).2,
                            text,
                        });
                        summary.words_changed += 1;
                    }
                }
                None if k != 0 => {
                    let mut text = String::new();
                    exact::write_digits(k, e, &mut text);
                    edits.push(self.insertion(line.content, tokens, axis_words, v, &text));
                    summary.words_added += 1;
                    if state.programmed & bit == 0 {
                        summary.note_assumed_home(self.axis_name(v), line.number);
                    }
                }
                None => {}
            }
            state.written[v] = state.written[v].add(increment);
            state.emitted[v] = exact::to_f64(state.written[v].units());
        }
        Ok(())
    }
}

/// The column of a block's first axis word.
fn first_column(tokens: &[Token], axis_words: &[Option<usize>; MAX_AXES]) -> usize {
    axis_words
        .iter()
        .flatten()
        .map(|&i| tokens[i].span.start)
        .min()
        .unwrap_or(0)
}
