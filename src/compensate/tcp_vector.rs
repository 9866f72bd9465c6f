//! Tool-centre-point blocks with tool vectors (G43.5): X, Y, Z are the tool tip and I, J, K
//! the tool direction (from tip towards spindle), both in the workpiece frame; the
//! controller finds all axis values with its nominal inverse kinematics.
//!
//! As under G43.4, nccomp solves the axis values the real machine needs for the intended
//! pose and writes the tip and vector at which the nominal machine sits there. Two
//! conventions of the controllers that offer G43.5 are followed (docs/nc-support.md): a
//! block that gives any of I, J, K gives the vector (an omitted component is 0), a block
//! that gives none keeps the previous vector; and of the inverse kinematics' solutions the
//! controller takes the one nearest the axes' current values.

use super::exact::Position;
use super::exact::Unit;
use super::split::Style;
use super::{Edit, INCH, Pass, State, Summary};
use crate::diag::Diagnostic;
use crate::kinematics::{Model, Pose, SolveOptions};
use crate::nc::number::{decimals_for, same_text, write_fixed};
use crate::nc::{self, Token, TokenKind, Value};
use crate::program::BlockMotion;
use nalgebra::Vector3;

impl Pass<'_> {
    /// One G43.5 block that moves.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn tcp_vector_block(
        &self,
        line: &nc::Line<'_>,
        tokens: &[Token],
        motion: &BlockMotion,
        state: &mut State,
        edits: &mut Vec<Edit>,
        summary: &mut Summary,
        at: &dyn Fn(usize, String) -> Diagnostic,
    ) -> Result<(), Diagnostic> {
        let n = self.kin.len();
        let axis_words = &motion.axis_words;
        let vector_words = &motion.arc_words[..3];
        let present = || axis_words[..n].iter().chain(vector_words).flatten();
        let first = present().map(|&i| tokens[i].span.start).min().unwrap_or(0);
        if state.modal.incremental {
            return Err(at(first, "incremental moves (G91) under G43.5 cannot be compensated (program the TCP part in G90)".into()));
        }
        if motion.optional {
            return Err(at(first, "an optional block (/) under G43.5 cannot be compensated safely (take it out of the TCP part)".into()));
        }
        let tips = self.tip_vars().expect("checked when G43.5 was switched on");
        for (v, word) in axis_words.iter().enumerate().take(n) {
            if let Some(i) = *word
                && !tips.contains(&v)
            {
                return Err(at(
                    tokens[i].span.start,
                    format!(
                        "{} is a rotary word; under G43.5 the tool direction is programmed by I, J, K (expected X, Y, Z, I, J, K)",
                        self.letter(v) as char
                    ),
                ));
            }
        }
        let number = |i: usize| match &tokens[i].kind {
            TokenKind::Word(w) => match w.value {
                Value::Number { value, decimals } => (value, decimals, w.value_span.clone()),
                _ => unreachable!("axis and vector words are numbers"),
            },
            _ => unreachable!("axis and vector words are words"),
        };
        for (c, &v) in tips.iter().enumerate() {
            if let Some(i) = axis_words[v] {
                let (value, _, _) = number(i);
                state.tip_nominal[c] = if state.modal.inch {
                    value * INCH
                } else {
                    value
                };
            }
        }
        if vector_words.iter().any(Option::is_some) {
            for (c, word) in vector_words.iter().enumerate() {
                state.vector_nominal[c] = word.map_or(0.0, |i| number(i).0);
            }
        }
        let vector = Vector3::from(state.vector_nominal);
        let scale = vector.norm();
        if scale.is_nan() || scale <= 1e-9 {
            return Err(at(
                first,
                "the tool vector I, J, K is zero (expected a direction from the tip towards the spindle)".into(),
            ));
        }
        let target = Pose {
            p: Vector3::from(state.tip_nominal),
            o: vector / scale,
        };
        // The controller's solve, from where the axes are.
        // A block moves the axes by degrees and millimetres, not microns: the Newton solve
        // needs more iterations (with its Jacobian refreshed) than a correction does.
        let far = SolveOptions {
            max_iterations: 100,
            ..self.options.solve
        };
        let Some(nominal) = self.kin.inverse(
            Model::Nominal,
            &target,
            &state.nominal[..n],
            state.modal.length,
            &far,
        ) else {
            return Err(at(
                first,
                "the nominal machine cannot reach this tip and tool vector from the previous axis positions (no inverse-kinematics solution near them)".into(),
            ));
        };
        state.nominal = nominal.q;
        state.programmed |= (1u32 << n) - 1;
        let sol = self.kin.compensate(
            &state.nominal[..n],
            state.modal.length,
            self.hold,
            &self.options.solve,
        );
        summary.motion_blocks += 1;
        let (programmed, _) = self
            .kin
            .pose(Model::Nominal, sol.values(), state.modal.length);

        // The tip words, as under G43.4.
        for (c, &v) in tips.iter().enumerate() {
            let to_units = |x: f64| if state.modal.inch { x / INCH } else { x };
            let value = to_units(programmed.p[c]);
            let mut text = String::new();
            match axis_words[v] {
                Some(i) => {
                    let (old, decimals, span) = number(i);
                    let d = decimals.max(self.res_decimals(v, Unit::inch(state.modal.inch)));
                    state.decimals[v] = d;
                    if same_text(old, value, d) {
                        write_fixed(old, d, &mut text);
                    } else {
                        write_fixed(value, d, &mut text);
                        edits.push(Edit {
                            at: span,
                            text: text.clone().into(),
                        });
                        summary.words_changed += 1;
                    }
                }
                None => {
                    let d =
                        state.decimals[v].max(self.res_decimals(v, Unit::inch(state.modal.inch)));
                    if same_text(to_units(state.tip_written[c]), value, d) {
                        continue;
                    }
                    write_fixed(value, d, &mut text);
                    edits.push(self.insertion(line.content, tokens, axis_words, v, &text));
                    summary.words_added += 1;
                }
            }
            let x: f64 = text.parse().unwrap_or(value);
            state.tip_written[c] = if state.modal.inch { x * INCH } else { x };
        }

        // The vector words, at the programmed vector's length so that unchanged components
        // keep their text; fine enough to carry the machine's rotary resolution.
        let resolution = decimals_for(self.machine.resolution.rotary.to_radians());
        let values: [f64; 3] = (programmed.o * scale).into();
        let decimals = |c: usize| vector_words[c].map_or(0, |i| number(i).1).max(resolution);
        let changed = (0..3).any(|c| {
            let old = vector_words[c].map_or(state.vector_written[c], |i| number(i).0);
            !same_text(old, values[c], decimals(c))
        });
        let mut missing = Vec::new();
        let given = vector_words.iter().any(Option::is_some);
        for c in 0..3 {
            let d = decimals(c);
            let mut text = String::new();
            write_fixed(values[c], d, &mut text);
            match vector_words[c] {
                Some(i) => {
                    let (old, _, span) = number(i);
                    if same_text(old, values[c], d) {
                        state.vector_written[c] = old;
                        continue;
                    }
                    edits.push(Edit {
                        at: span,
                        text: text.clone().into(),
                    });
                    summary.words_changed += 1;
                }
                // An omitted component is 0 when the block gives the vector; when it gives
                // none, the whole vector is written once any component changes.
                None if given && same_text(0.0, values[c], d) => {
                    state.vector_written[c] = 0.0;
                    continue;
                }
                None if !given && !changed => continue,
                None => missing.push((c, text.clone())),
            }
            state.vector_written[c] = text.parse().unwrap_or(values[c]);
        }
        if !missing.is_empty() {
            self.append_vector_words(line, tokens, motion, &missing, edits);
            summary.words_added += missing.len();
        }

        // What the controller will do with what is written, as the model predicts it.
        let written = Pose {
            p: Vector3::from(state.tip_written),
            o: Vector3::from(state.vector_written).normalize(),
        };
        let ctrl = self
            .kin
            .inverse(
                Model::Nominal,
                &written,
                sol.values(),
                state.modal.length,
                &far,
            )
            .map_or(sol.q, |c| c.q);
        state.emitted = ctrl;
        for (v, &value) in ctrl.iter().enumerate().take(n) {
            state.written[v] = Position::Decimal {
                value,
                decimals: state.decimals[v],
                unit: Unit::MM,
            };
        }
        let (after, beyond) = self.kin.pose(Model::Actual, &ctrl[..n], state.modal.length);
        let (ap, ad) = after.deviation(&sol.target);
        summary.record(
            line.number,
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
        Ok(())
    }

    /// Add I, J, K words (component index, number) after the block's last tip or vector
    /// word, in the block's style.
    fn append_vector_words(
        &self,
        line: &nc::Line<'_>,
        tokens: &[Token],
        motion: &BlockMotion,
        words: &[(usize, String)],
        edits: &mut Vec<Edit>,
    ) {
        let style = Style::of(line.content, tokens);
        let last = motion
            .axis_words
            .iter()
            .chain(&motion.arc_words[..3])
            .flatten()
            .map(|&i| tokens[i].span.end)
            .max()
            .unwrap_or(0);
        let mut text = String::new();
        for (c, number) in words {
            text.push_str(style.separator);
            text.push_str(&style.letter(b"IJK"[*c]));
            text.push_str(number);
        }
        edits.push(Edit {
            at: last..last,
            text: text.into(),
        });
    }
}
