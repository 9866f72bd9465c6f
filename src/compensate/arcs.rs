//! Arcs (G2/G3 in G17/G18/G19, centres by I/J/K or a radius R).
//!
//! A controller interpolates an arc in the program's coordinates; on a machine with errors
//! no arc in axis space traces the intended arc on the part. nccomp replaces each arc by
//! straight pieces whose chords stay within half a micron of the nominal arc, each piece's
//! end compensated like any block (pieces are not split further by `--tolerance`; they are
//! short already). The arc's own line becomes the last piece: its G2/G3 turns into G1 and
//! its I/J/K/R words go; the pieces before it are inserted in the program's style, the
//! first one carrying the block's G, H, D, S and F words so every piece runs as the block
//! would. A block with M or T words is refused: they would run after the pieces.

use super::arc_keep::ArcPath;
use super::exact::Position;
use super::split::Style;
use super::{Edit, INCH, Pass, State, Summary, axis_order};
use crate::diag::Diagnostic;
use crate::kinematics::MAX_AXES;
use crate::model::AxisKind;
use crate::nc::number::{same_text, write_fixed};
use crate::nc::{self, Token, TokenKind, Value};
use crate::program::BlockMotion;
use std::f64::consts::TAU;
use std::fmt::Write;

/// Largest distance (mm) of a chord from its arc.
const CHORD: f64 = 0.0005;
/// More pieces than this for one arc means a radius or a tolerance that makes no sense.
const MAX_PIECES: usize = 100_000;

/// The plane's two axes (as program letters, first and second) and the letters of the
/// centre words along them.
fn plane_letters(plane: u8) -> Option<([u8; 2], [u8; 2])> {
    match plane {
        0 => Some(([b'X', b'Y'], [b'I', b'J'])),
        1 => Some(([b'Z', b'X'], [b'K', b'I'])),
        2 => Some(([b'Y', b'Z'], [b'J', b'K'])),
        _ => None,
    }
}

impl Pass<'_> {
    /// One G2/G3 block.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn arc_block(
        &self,
        line: &nc::Line<'_>,
        tokens: &[Token],
        motion: &BlockMotion,
        clockwise: bool,
        state: &mut State,
        edits: &mut Vec<Edit>,
        summary: &mut Summary,
        at: &dyn Fn(usize, String) -> Diagnostic,
    ) -> Result<(), Diagnostic> {
        let n = self.kin.len();
        let axis_words = &motion.axis_words;
        let col = motion
            .arc_code
            .map(|i| tokens[i].span.start)
            .or_else(|| {
                axis_words
                    .iter()
                    .flatten()
                    .map(|&i| tokens[i].span.start)
                    .min()
            })
            .unwrap_or(0);
        let refuse = |why: &str| Err(at(col, format!("this arc cannot be compensated: {why}")));
        if state.modal.incremental {
            return refuse(
                "arcs in incremental mode (G91) are not supported (program them in G90)",
            );
        }
        if motion.optional {
            return refuse("an optional block (/) with an arc is not supported");
        }
        if state.modal.tcp {
            return refuse("arcs under tool-centre-point control (G43.4/G43.5) are not supported");
        }
        let m_or_t = tokens
            .iter()
            .find(|t| matches!(&t.kind, TokenKind::Word(w) if matches!(w.letter, b'M' | b'T')));
        if state.modal.inverse_time
            && !tokens
                .iter()
                .any(|t| matches!(&t.kind, TokenKind::Word(w) if w.letter == b'F'))
        {
            return refuse("in inverse-time feed (G93) an arc needs its own F word");
        }
        let path = self
            .arc_path(tokens, motion, clockwise, state)
            .map_err(|why| at(col, format!("this arc cannot be compensated: {why}")))?;
        for (v, word) in axis_words.iter().enumerate().take(n) {
            // Axes turning holds are not corrected.
            if state.programmed & (1 << v) == 0 && word.is_none() && self.idle & (1 << v) == 0 {
                summary.note_assumed_home(self.axis_name(v), line.number);
            }
            if word.is_some() {
                state.programmed |= 1 << v;
            }
        }
        let ArcPath {
            r0, r1, sweep, end, ..
        } = path;
        let Some((_, centre_letters)) = plane_letters(state.modal.plane) else {
            unreachable!("arc_path accepts only the three planes");
        };
        // Kept as an arc where what the controller makes of the compensated words stays
        // within the path tolerance (the default one under --tolerance off).
        let tolerance = self.options.path.unwrap_or_default();
        if let Some(kept) = self.keep_arc(&path, tokens, motion, centre_letters, state, &tolerance)
        {
            self.check_piece(&end, &kept.end, col, at)?;
            state.nominal = end;
            self.write_positions(
                line, tokens, axis_words, &kept.end, false, state, edits, summary, at,
            )?;
            for (word, _) in &kept.centre_words {
                match word {
                    Ok(_) => summary.words_changed += 1,
                    Err(_) => summary.words_added += 1,
                }
            }
            self.centre_edits(line, tokens, motion, &kept.centre_words, edits);
            self.record_block(line.number, &kept.end_solution, state, summary);
            summary.note_arc_kept();
            return Ok(());
        }
        if let Some(t) = m_or_t {
            return Err(at(
                t.span.start,
                "this arc must be replaced by straight pieces (kept as an arc it strays from the path) and cannot be with an M or T word in its block: the word would run only after the first pieces (put it in a block of its own)".into(),
            ));
        }
        let radius = r0.max(r1);
        let step = 2.0 * (1.0 - (CHORD / radius).min(1.0)).acos();
        let pieces = ((sweep.abs() / step).ceil() as usize).max(1);
        if pieces > MAX_PIECES {
            return refuse(&format!("it would take {pieces} straight pieces"));
        }
        // The inserted pieces, then the arc's own line as the last one.
        let style = Style::of(line.content, tokens);
        let numbers = self.inserted_numbers(tokens, line.content, state, pieces - 1);
        let ending = if line.ending.is_empty() {
            "\n"
        } else {
            std::str::from_utf8(line.ending).unwrap_or("\n")
        };
        let mut order: Vec<usize> = (0..n).collect();
        order.sort_by_key(|&v| axis_order(self.letter(v)));
        let f_word = tokens
            .iter()
            .find(|t| matches!(&t.kind, TokenKind::Word(w) if w.letter == b'F'));
        let mut text = String::new();
        for k in 1..pieces {
            let q = path.point(k as f64 / pieces as f64, n);
            let sol =
                self.kin
                    .compensate(&q[..n], state.modal.length, self.hold, &self.options.solve);
            self.check_piece(&q, &sol.q, col, at)?;
            let mut words: Vec<String> = Vec::new();
            if let Some(number) = &numbers[k - 1] {
                words.push(style.letter(b'N') + number);
            }
            if k == 1 {
                // The block's own modal words, so the first piece runs as the block would.
                for (ti, t) in tokens.iter().enumerate() {
                    if let TokenKind::Word(w) = &t.kind
                        && matches!(w.letter, b'G' | b'H' | b'D' | b'S')
                        && Some(ti) != motion.arc_code
                    {
                        words.push(
                            String::from_utf8_lossy(&line.content[t.span.clone()]).into_owned(),
                        );
                    }
                }
                words.push(style.letter(b'G') + "1");
            }
            for &v in &order {
                let unit = self.unit(v, &state.modal);
                let value = unit.of_mm(sol.q[v]);
                let emitted = unit.of_mm(state.emitted[v]);
                let d = state.decimals[v].max(self.res_decimals(v, unit));
                if same_text(emitted, value, d) {
                    continue;
                }
                let mut number = String::new();
                write_fixed(value, d, &mut number);
                let x: f64 = number.parse().unwrap_or(value);
                state.emitted[v] = unit.to_mm(x);
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
                    let mut number = String::new();
                    write_fixed(value * pieces as f64, decimals.max(3) + 1, &mut number);
                    words.push(style.letter(b'F') + &number);
                } else if k == 1 {
                    words.push(String::from_utf8_lossy(&line.content[f.span.clone()]).into_owned());
                }
            }
            self.record_block(line.number, &sol, state, summary);
            let _ = write!(text, "{}{}", words.join(style.separator), ending);
        }
        if pieces > 1 {
            edits.push(Edit {
                at: 0..0,
                text: text.into(),
            });
        }
        // The arc's own line: G1, no centre words, its end compensated.
        if let Some(i) = motion.arc_code {
            let t = &tokens[i];
            if let TokenKind::Word(w) = &t.kind {
                let digits = &line.content[w.value_span.clone()];
                let text = if digits.first() == Some(&b'0') {
                    "01"
                } else {
                    "1"
                };
                edits.push(Edit {
                    at: w.value_span.clone(),
                    text: text.into(),
                });
            }
        } else if pieces == 1 {
            // A modal arc of one piece: the motion mode must become G1 here.
            let first = axis_words
                .iter()
                .flatten()
                .map(|&i| tokens[i].span.start)
                .min()
                .unwrap_or(0);
            edits.push(Edit {
                at: first..first,
                text: (style.letter(b'G') + "1" + style.separator).into(),
            });
        }
        for i in motion.arc_words.iter().flatten() {
            let t = &tokens[*i];
            // The word and the space before it.
            let start = tokens
                .iter()
                .position(|x| x.span.end == t.span.start && x.kind == TokenKind::Space)
                .map_or(t.span.start, |p| tokens[p].span.start);
            edits.push(Edit {
                at: start..t.span.end,
                text: Vec::new(),
            });
        }
        if state.modal.inverse_time
            && let Some(f) = f_word
            && let TokenKind::Word(w) = &f.kind
            && let Value::Number { value, decimals } = w.value
        {
            let mut number = String::new();
            write_fixed(value * pieces as f64, decimals.max(3) + 1, &mut number);
            edits.push(Edit {
                at: w.value_span.clone(),
                text: number.into(),
            });
        }
        state.nominal = end;
        let sol = self.kin.compensate(
            &end[..n],
            state.modal.length,
            self.hold,
            &self.options.solve,
        );
        self.check_piece(&end, &sol.q, col, at)?;
        summary.note_arc(line.number, pieces - 1);
        self.write_positions(
            line, tokens, axis_words, &sol.q, false, state, edits, summary, at,
        )?;
        self.record_block(line.number, &sol, state, summary);
        Ok(())
    }

    /// The arc a G2/G3 block describes from `state.nominal`, in the program's axis values;
    /// `Err` says why it cannot be followed. The state is left as it is.
    pub(super) fn arc_path(
        &self,
        tokens: &[Token],
        motion: &BlockMotion,
        clockwise: bool,
        state: &State,
    ) -> Result<ArcPath, String> {
        let n = self.kin.len();
        let axis_words = &motion.axis_words;
        let refuse = |why: &str| Err(why.to_string());
        if state.unknown & !self.spindle != 0 {
            return refuse(
                "the arc starts where an axis is at a place nccomp does not know (after G28, G30, G53, M19 or a change of tool chain)",
            );
        }
        if state.modal.diameter && state.modal.arc_absolute {
            return refuse(
                "absolute arc centres (G90.1) in diameter mode (G7) are not supported (program the centre incrementally, G91.1)",
            );
        }
        let Some((plane, centre_letters)) = plane_letters(state.modal.plane) else {
            return refuse("arcs in a U/V/W plane (G17.1, G18.1, G19.1) are not supported");
        };
        let var = |letter: u8| {
            self.var_of_letter[(letter - b'A') as usize]
                .filter(|&v| self.kin.kind(v) == AxisKind::Linear)
        };
        let (Some(va), Some(vb)) = (var(plane[0]), var(plane[1])) else {
            return refuse("the machine has no linear axes for this arc plane");
        };
        // The arc's start in its plane must be known; other axes the program never set are
        // taken at home (0), as for straight moves, and the summary says so.
        if (state.programmed & (1 << va)) == 0 || (state.programmed & (1 << vb)) == 0 {
            return refuse("the program has not yet set where the arc starts in its plane");
        }
        let number = |i: usize| match &tokens[i].kind {
            TokenKind::Word(w) => match w.value {
                Value::Number { value, .. } => value,
                _ => 0.0,
            },
            _ => 0.0,
        };
        let mm = |x: f64| if state.modal.inch { x * INCH } else { x };
        // Start and end of the move, nominal.
        let start = state.nominal;
        let mut end = state.nominal;
        for v in 0..n {
            if let Some(i) = axis_words[v] {
                end[v] = self.unit(v, &state.modal).to_mm(number(i));
            }
        }
        let (a0, b0, a1, b1) = (start[va], start[vb], end[va], end[vb]);
        // The centre.
        let word =
            |letter: u8| motion.arc_words[b"IJKR".iter().position(|&l| l == letter).unwrap_or(0)];
        let centre = if let Some(ri) = motion.arc_words[3] {
            let r = mm(number(ri));
            let (dx, dy) = (a1 - a0, b1 - b0);
            let d = (dx * dx + dy * dy).sqrt();
            if d == 0.0 || d > 2.0 * r.abs() + 1e-9 {
                return refuse(
                    "with R the end point must differ from the start and lie within 2R of it",
                );
            }
            let h = (r * r - d * d / 4.0).max(0.0).sqrt();
            // The centre to the left of the chord for a short CCW arc (or long CW).
            let left = clockwise == (r < 0.0);
            let (mx, my) = ((a0 + a1) / 2.0, (b0 + b1) / 2.0);
            let (ux, uy) = (-dy / d, dx / d);
            if left {
                (mx + ux * h, my + uy * h)
            } else {
                (mx - ux * h, my - uy * h)
            }
        } else {
            let (ci, cj) = (word(centre_letters[0]), word(centre_letters[1]));
            if ci.is_none() && cj.is_none() {
                return refuse("it gives neither a centre (I/J/K for its plane) nor a radius (R)");
            }
            let off_a = ci.map_or(0.0, |i| mm(number(i)));
            let off_b = cj.map_or(0.0, |i| mm(number(i)));
            if state.modal.arc_absolute {
                (off_a, off_b)
            } else {
                (a0 + off_a, b0 + off_b)
            }
        };
        let r0 = ((a0 - centre.0).powi(2) + (b0 - centre.1).powi(2)).sqrt();
        let r1 = ((a1 - centre.0).powi(2) + (b1 - centre.1).powi(2)).sqrt();
        if r0 < 1e-9 || (r0 - r1).abs() > 0.002_f64.max(1e-6 * r0) {
            return refuse(&format!(
                "its end is not on its circle (radius {r0:.4} at the start, {r1:.4} at the end)"
            ));
        }
        let th0 = (b0 - centre.1).atan2(a0 - centre.0);
        let th1 = (b1 - centre.1).atan2(a1 - centre.0);
        // Signed sweep: clockwise negative; equal ends make a full circle.
        let sweep = if clockwise {
            let s = -(th0 - th1).rem_euclid(TAU);
            if s == 0.0 { -TAU } else { s }
        } else {
            let s = (th1 - th0).rem_euclid(TAU);
            if s == 0.0 { TAU } else { s }
        };
        Ok(ArcPath {
            va,
            vb,
            centre,
            r0,
            r1,
            th0,
            sweep,
            start,
            end,
        })
    }

    /// A piece's nominal point must lie within the travel, and its correction must be
    /// small (as for any block).
    pub(super) fn check_piece(
        &self,
        nominal: &[f64; MAX_AXES],
        compensated: &[f64; MAX_AXES],
        col: usize,
        at: &dyn Fn(usize, String) -> Diagnostic,
    ) -> Result<(), Diagnostic> {
        for v in 0..self.kin.len() {
            if let Some([lo, hi]) = self.travel(v)
                && !self.options.allow_limit_violations
            {
                for (x, what) in [
                    (nominal[v], "the arc takes"),
                    (compensated[v], "after compensation the arc takes"),
                ] {
                    if x < lo - 1e-9 || x > hi + 1e-9 {
                        return Err(at(
                            col,
                            format!(
                                "{what} axis {} to {x:.4}, outside its travel {lo} … {hi} (use --allow-limit-violations to write it anyway)",
                                self.axis_name(v)
                            ),
                        )
                        .with_code(super::TRAVEL_LIMIT));
                    }
                }
            }
            let delta = (compensated[v] - nominal[v]).abs();
            let limit = if self.is_linear(v) {
                self.options.max_correction.0
            } else {
                self.options.max_correction.1
            };
            if delta.is_nan() || delta > limit {
                return Err(at(
                    col,
                    format!(
                        "the correction of axis {} would be {delta:.4} {} on this arc (more than {limit}); the error model or this pose is not sound",
                        self.axis_name(v),
                        if self.is_linear(v) { "mm" } else { "°" }
                    ),
                ));
            }
        }
        Ok(())
    }
}
