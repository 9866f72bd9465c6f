//! Writing a compensated block's axis words: positions in G90, increments in G91.

use super::pipeline::{Cx, Out};
use super::{INCH, Pass, State, axis_order};
use crate::diag::Diagnostic;
use crate::kinematics::MAX_AXES;
use crate::nc::edit::{Editor, Style};
use crate::nc::number::{same_text, write_fixed_value, write_scaled_bytes};
use crate::program::exact::{self, Position, Unit};
use nalgebra::Vector3;

impl Pass<'_> {
    /// G90: write each axis's compensated position `q` (mm, degrees); a word keeps its
    /// bytes when the new value prints the same, an axis the block omits gets a word when
    /// its value changes.
    pub(super) fn write_positions(
        &self,
        cx: &Cx<'_, '_>,
        q: &[f64],
        optional: bool,
        state: &mut State,
        out: &mut Out<'_>,
    ) -> Result<(), Diagnostic> {
        let axis_words = &cx.motion.axis_words;
        let line = cx.line;
        for &v in &self.write_order {
            let unit = self.unit(v, &state.modal);
            let value = unit.of_mm(q[v]);
            match axis_words[v] {
                Some(i) => {
                    let (old, decimals, _) = cx.number(i);
                    let d = decimals.max(self.res_decimals(v, unit));
                    state.decimals[v] = d;
                    let mut editor = Editor::new(line.content, cx.tokens, out.edits)
                        .with_spare(&mut state.spare_texts);
                    let (written, changed) = editor.set_number_from(i, old, value, d);
                    state.emitted[v] = unit.to_mm(written);
                    if changed {
                        state.written[v] = Position::Decimal {
                            value,
                            decimals: d,
                            unit,
                        };
                        out.summary.words_changed += 1;
                    } else {
                        state.written[v] = state.pos.exact[v];
                    }
                    state.pos.programmed |= 1 << v;
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
                            return Err(cx.refuse(
                                cx.first_col(),
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
                        self.insert_axis_word(cx, out, v, &text);
                        out.summary.words_added += 1;
                        if state.pos.programmed & (1 << v) == 0 {
                            out.summary
                                .note_assumed_home(self.axis_name(v), line.number);
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
    /// word when its compensated increment is not 0. `units`: the block's words, exactly;
    /// `only`: the variables written (a cycle's X and Y).
    pub(super) fn write_increments(
        &self,
        cx: &Cx<'_, '_>,
        units: &[i128; MAX_AXES],
        q: &[f64],
        only: u32,
        state: &mut State,
        out: &mut Out<'_>,
    ) -> Result<(), Diagnostic> {
        let (line, axis_words) = (cx.line, &cx.motion.axis_words);
        for &v in self.write_order.iter().filter(|&&v| only & (1 << v) != 0) {
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
            let col = word.map_or_else(|| cx.first_col(), |i| cx.col(i));
            let d = match word {
                Some(i) => cx.number(i).1.max(self.res_decimals(v, unit)),
                None => state.decimals[v]
                    .max(self.res_decimals(v, unit))
                    .min(exact::MAX_DECIMALS),
            };
            let (k, e) =
                exact::increment(state.written[v].units(), value, d, unit).ok_or_else(|| {
                    cx.refuse(
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
                return Err(cx.refuse(
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
                    state.pos.programmed |= bit;
                    if increment != units[v] {
                        let mut text = state.spare_texts.pop().unwrap_or_default();
                        write_scaled_bytes(k, e, &mut text);
                        cx.editor(out.edits).replace_number(i, text);
                        out.summary.words_changed += 1;
                    }
                }
                None if k != 0 => {
                    let mut text = String::new();
                    exact::write_digits(k, e, &mut text);
                    self.insert_axis_word(cx, out, v, &text);
                    out.summary.words_added += 1;
                    if state.pos.programmed & bit == 0 {
                        out.summary
                            .note_assumed_home(self.axis_name(v), line.number);
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

impl Pass<'_> {
    /// The axis words of a block inserted before the line that takes the axes to `q`: a word
    /// for each axis whose written value changes, in the usual order and `style`; in G91 the
    /// exact difference between two written absolute positions, as the block's own
    /// increments are written (no drift). Follows what the machine is told.
    pub(super) fn piece_words(
        &self,
        q: &[f64; MAX_AXES],
        state: &mut State,
        style: &Style,
        words: &mut Vec<String>,
    ) {
        for &v in &self.write_order {
            let unit = self.unit(v, &state.modal);
            let value = unit.of_mm(q[v]);
            let d = state.decimals[v].max(self.res_decimals(v, unit));
            let mut number = String::new();
            if state.modal.incremental {
                let d = d.min(exact::MAX_DECIMALS);
                let Some((k, e)) = exact::increment(state.written[v].units(), value, d, unit)
                else {
                    continue;
                };
                if k == 0 {
                    continue;
                }
                exact::write_digits(k, e, &mut number);
                state.written[v] = state.written[v].add(exact::units(k, e, unit).unwrap_or(0));
                state.emitted[v] = exact::to_f64(state.written[v].units());
            } else {
                if same_text(unit.of_mm(state.emitted[v]), value, d) {
                    continue;
                }
                let x = write_fixed_value(value, d, &mut number);
                state.emitted[v] = unit.to_mm(x);
                state.written[v] = Position::Decimal {
                    value,
                    decimals: d,
                    unit,
                };
            }
            words.push(style.word(self.letter(v), &number));
        }
    }

    /// G91: the increments of the variables in `only` from what the machine was told to
    /// their compensated positions `q`, as (variable, digits, units), for a block of its own (a
    /// repeat of an L-repeated hole); an increment of 0 is left out. Follows what the
    /// machine is told.
    pub(super) fn hole_words(
        &self,
        cx: &Cx<'_, '_>,
        q: &[f64; MAX_AXES],
        only: u32,
        state: &mut State,
        words: &mut Vec<(usize, String, i128)>,
    ) {
        for &v in self.write_order.iter().filter(|&&v| only & (1 << v) != 0) {
            let unit = self.unit(v, &state.modal);
            // As the block's own increments are written (`write_increments`).
            let d = match cx.motion.axis_words[v] {
                Some(i) => cx.number(i).1.max(self.res_decimals(v, unit)),
                None => state.decimals[v]
                    .max(self.res_decimals(v, unit))
                    .min(exact::MAX_DECIMALS),
            };
            let Some((k, e)) =
                exact::increment(state.written[v].units(), unit.of_mm(q[v]), d, unit)
            else {
                continue;
            };
            let increment = exact::units(k, e, unit).unwrap_or(0);
            if k != 0 {
                let mut number = String::new();
                exact::write_digits(k, e, &mut number);
                words.push((v, number, increment));
            }
            state.written[v] = state.written[v].add(increment);
            state.emitted[v] = exact::to_f64(state.written[v].units());
        }
    }

    /// The tip words X, Y, Z for the tip `tip` (mm; TCP, a tilted working plane, a cycle in
    /// it) and, where `rotary` is given, the rotary words for its values: a word keeps its
    /// bytes when its new value prints the same, a word the block lacks is added when its
    /// value no longer prints as last written. Follows `State::tip_written` and, for the
    /// rotary axes, what the controller is told.
    pub(super) fn write_tip_words(
        &self,
        cx: &Cx<'_, '_>,
        tips: &[usize; 3],
        tip: &Vector3<f64>,
        rotary: Option<&[f64; MAX_AXES]>,
        state: &mut State,
        out: &mut Out<'_>,
    ) {
        let inch = state.modal.inch;
        let to_units = |x: f64| if inch { x / INCH } else { x };
        let mut editor = cx.editor(out.edits);
        let mut added: Vec<(usize, String)> = Vec::new();
        for &v in &self.write_order {
            let tip_c = tips.iter().position(|&t| t == v);
            let rotary_value = match (tip_c, rotary) {
                (None, None) => continue,
                (_, r) => r.map_or(0.0, |r| r[v]),
            };
            let unit = Unit::inch(inch && tip_c.is_some());
            let (value, before) = match tip_c {
                Some(c) => (to_units(tip[c]), to_units(state.tip_written[c])),
                None => (rotary_value, state.emitted[v]),
            };
            let written = match cx.motion.axis_words[v] {
                Some(i) => {
                    let d = cx.number(i).1.max(self.res_decimals(v, unit));
                    state.decimals[v] = d;
                    if editor.set_fixed(i, value, d) {
                        out.summary.words_changed += 1;
                        super::tcp::round(value, d)
                    } else {
                        super::tcp::round(cx.number(i).0, d)
                    }
                }
                None => {
                    let d = state.decimals[v].max(self.res_decimals(v, unit));
                    if same_text(before, value, d) {
                        continue;
                    }
                    let mut text = String::new();
                    let x = write_fixed_value(value, d, &mut text);
                    added.push((v, text));
                    x
                }
            };
            match tip_c {
                Some(c) => state.tip_written[c] = if inch { written * INCH } else { written },
                None => {
                    state.emitted[v] = written;
                    state.written[v] = Position::Decimal {
                        value: written,
                        decimals: state.decimals[v],
                        unit: Unit::MM,
                    };
                }
            }
        }
        for (v, text) in &added {
            self.insert_axis_word(cx, out, *v, text);
            out.summary.words_added += 1;
        }
    }

    /// Add variable `v`'s word with `number` to a block that lacks it: in the usual order of
    /// axis words among the block's own, in the style of its neighbour.
    pub(super) fn insert_axis_word(
        &self,
        cx: &Cx<'_, '_>,
        out: &mut Out<'_>,
        v: usize,
        number: &str,
    ) {
        let order = |var: usize| axis_order(self.letter(var));
        let mine = order(v);
        let present = || {
            cx.motion
                .axis_words
                .iter()
                .enumerate()
                .filter_map(|(var, t)| t.map(|i| (var, i)))
        };
        let after = present()
            .filter(|&(var, _)| order(var) < mine)
            .max_by_key(|&(var, _)| order(var));
        let before = present()
            .filter(|&(var, _)| order(var) > mine)
            .min_by_key(|&(var, _)| order(var));
        // A block with axis words always has a neighbour.
        let (neighbour, is_after) = match (after, before) {
            (Some((_, i)), _) => (i, true),
            (None, Some((_, i))) => (i, false),
            // A TNC block's words follow its keyword (`L`, `C` …).
            (None, None) if state_is_tnc(cx) => {
                match crate::program::heidenhain::keyword(cx.line.content, cx.tokens) {
                    Some(k) => (k, true),
                    None => (0, false),
                }
            }
            (None, None) => (0, false),
        };
        cx.editor(out.edits)
            .insert_word_by(neighbour, is_after, self.letter(v), number);
    }
}

/// The block is a TNC block: it starts with a block number and a keyword.
fn state_is_tnc(cx: &Cx<'_, '_>) -> bool {
    crate::program::heidenhain::block_number(cx.line.content, cx.tokens).is_some()
        && !cx
            .tokens
            .iter()
            .any(|t| matches!(&t.kind, crate::nc::TokenKind::Word(w) if w.letter == b'G' || w.letter == b'N'))
}
