//! Tool-centre-point blocks (G43.4): X, Y, Z are the tool tip in the workpiece frame and
//! the rotary words the rotary axes' positions; the controller solves the linear axes with
//! its nominal kinematics.
//!
//! nccomp finds the axis values the real machine needs for the intended pose, then writes
//! the tip at which the nominal machine would sit there, and the rotary values themselves:
//! the controller's nominal solve of what is written lands the real machine on the pose
//! (`kinematics::tcp`).

use super::exact::{Position, Unit};
use super::{Edit, INCH, Pass, State, Summary};
use crate::diag::Diagnostic;
use crate::kinematics::{MAX_AXES, Model};
use crate::model::AxisKind;
use crate::nc::number::{same_text, write_fixed};
use crate::nc::{self, Token, TokenKind, Value};

impl Pass<'_> {
    /// The variables driven by the X, Y and Z words, which TCP programs use for the tip.
    pub(super) fn tip_vars(&self) -> Option<[usize; 3]> {
        let mut vars = [0; 3];
        for (c, letter) in [b'X', b'Y', b'Z'].iter().enumerate() {
            let v = self.var_of_letter[(letter - b'A') as usize]?;
            if self.kin.kind(v) != AxisKind::Linear {
                return None;
            }
            vars[c] = v;
        }
        Some(vars)
    }

    /// G43.4 or G43.5 switches on: from now on X, Y, Z words are the tip (and under G43.5,
    /// I, J, K the tool vector).
    pub(super) fn enter_tcp(
        &self,
        state: &mut State,
        at: &dyn Fn(usize, String) -> Diagnostic,
    ) -> Result<(), Diagnostic> {
        let code = if state.modal.tcp_vector {
            "G43.5"
        } else {
            "G43.4"
        };
        if self.turning {
            return Err(at(
                0,
                format!(
                    "{code} cannot be compensated while turning: the spindle turns or has not been positioned (position it with M19 or a C word first)"
                ),
            ));
        }
        if state.modal.diameter {
            return Err(at(
                0,
                format!(
                    "{code} in diameter mode (G7) cannot be compensated (program it in radius mode, G8)"
                ),
            ));
        }
        if self.tip_vars().is_none() {
            return Err(at(
                0,
                format!(
                    "{code} needs linear axes driven by X, Y and Z words for the tool tip; this machine has none"
                ),
            ));
        }
        if state.modal.incremental {
            return Err(at(
                0,
                format!(
                    "{code} in incremental mode (G91) cannot be compensated (program the TCP part in G90)"
                ),
            ));
        }
        let n = self.kin.len();
        let (nominal, _) = self
            .kin
            .pose(Model::Nominal, &state.nominal[..n], state.modal.length);
        let (written, _) = self
            .kin
            .pose(Model::Nominal, &state.emitted[..n], state.modal.length);
        state.tip_nominal = nominal.p.into();
        state.tip_written = written.p.into();
        state.vector_nominal = nominal.o.into();
        state.vector_written = written.o.into();
        state.modal.tcp = true;
        Ok(())
    }

    /// One G43.4 block that moves.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn tcp_block(
        &self,
        line: &nc::Line<'_>,
        tokens: &[Token],
        axis_words: &[Option<usize>; MAX_AXES],
        optional: bool,
        state: &mut State,
        edits: &mut Vec<Edit>,
        summary: &mut Summary,
        at: &dyn Fn(usize, String) -> Diagnostic,
    ) -> Result<(), Diagnostic> {
        let n = self.kin.len();
        let first = axis_words
            .iter()
            .flatten()
            .map(|&i| tokens[i].span.start)
            .min()
            .unwrap_or(0);
        if state.modal.incremental {
            return Err(at(first, "incremental moves (G91) under G43.4 cannot be compensated (program the TCP part in G90)".into()));
        }
        if optional {
            return Err(at(first, "an optional block (/) under G43.4 cannot be compensated safely (take it out of the TCP part)".into()));
        }
        let tips = self.tip_vars().expect("checked when G43.4 was switched on");
        let number = |i: usize| match &tokens[i].kind {
            TokenKind::Word(w) => match w.value {
                Value::Number { value, decimals } => (value, decimals, w.value_span.clone()),
                _ => unreachable!("axis words are numbers"),
            },
            _ => unreachable!("axis words are words"),
        };
        // The programmed pose: tip words and rotary positions.
        let mut guess = state.nominal;
        for v in 0..n {
            let Some(i) = axis_words[v] else { continue };
            let (value, _, _) = number(i);
            match tips.iter().position(|&t| t == v) {
                Some(c) => {
                    state.tip_nominal[c] = if state.modal.inch {
                        value * INCH
                    } else {
                        value
                    }
                }
                None => guess[v] = value,
            }
            state.programmed |= 1 << v;
        }
        let tip = nalgebra::Vector3::from(state.tip_nominal);
        let nominal = self.kin.tcp_axes_with_rotaries(
            &tip,
            &guess[..n],
            state.modal.length,
            &self.options.solve,
        );
        if nominal.position_residual > 1e-6 {
            return Err(at(
                first,
                format!(
                    "the programmed tip cannot be reached with these rotary positions (off by {:.4} mm)",
                    nominal.position_residual
                ),
            ));
        }
        state.nominal = nominal.q;
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
        // What to write for each variable, in program units.
        for v in 0..n {
            let tip_c = tips.iter().position(|&t| t == v);
            let inch = state.modal.inch && tip_c.is_some();
            let to_units = |x: f64| if inch { x / INCH } else { x };
            let (value, written) = match tip_c {
                Some(c) => (to_units(programmed.p[c]), to_units(state.tip_written[c])),
                None => (sol.q[v], state.emitted[v]),
            };
            let mut text = String::new();
            match axis_words[v] {
                Some(i) => {
                    let (old, decimals, span) = number(i);
                    let d = decimals.max(self.res_decimals(v, Unit::inch(state.modal.inch)));
                    state.decimals[v] = d;
                    if !same_text(old, value, d) {
                        write_fixed(value, d, &mut text);
                        edits.push(Edit {
                            at: span,
                            text: text.clone().into(),
                        });
                        summary.words_changed += 1;
                    } else {
                        write_fixed(old, d, &mut text);
                    }
                }
                None => {
                    let d =
                        state.decimals[v].max(self.res_decimals(v, Unit::inch(state.modal.inch)));
                    if same_text(written, value, d) {
                        continue;
                    }
                    write_fixed(value, d, &mut text);
                    edits.push(self.insertion(line.content, tokens, axis_words, v, &text));
                    summary.words_added += 1;
                }
            }
            let x = crate::nc::to_f64(text.as_bytes());
            match tip_c {
                Some(c) => state.tip_written[c] = if inch { x * INCH } else { x },
                None => {
                    state.emitted[v] = x;
                    state.written[v] = Position::Decimal {
                        value: x,
                        decimals: state.decimals[v],
                        unit: Unit::MM,
                    };
                }
            }
        }
        // What the controller will do with what is written, as the model predicts it.
        let mut ctrl_guess = sol.q;
        for (v, guess) in ctrl_guess.iter_mut().enumerate().take(n) {
            if self.kin.kind(v) == AxisKind::Rotary {
                *guess = state.emitted[v];
            }
        }
        let ctrl = self.kin.tcp_axes_with_rotaries(
            &nalgebra::Vector3::from(state.tip_written),
            &ctrl_guess[..n],
            state.modal.length,
            &self.options.solve,
        );
        for (v, &ctrl_value) in ctrl.q.iter().enumerate().take(n) {
            if self.kin.kind(v) == AxisKind::Linear {
                state.emitted[v] = ctrl_value;
            }
        }
        let (after, beyond) = self
            .kin
            .pose(Model::Actual, ctrl.values(), state.modal.length);
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
}
