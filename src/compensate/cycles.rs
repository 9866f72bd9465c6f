//! Drilling and boring cycles (G73, G81–G86, G88, G89) in three-axis work.
//!
//! A cycle block names the hole (X, Y), its bottom (Z) and the retract plane (R); the
//! controller positions over the hole, goes down to R, feeds to Z and retracts. nccomp
//! compensates the cycle at its positioning points: the hole's X, Y and bottom Z from the
//! pose at the bottom, R from the pose at the R plane, the rotary axes held where they are
//! (a cycle has no rotary words). That is honest only where one X, Y serves the whole
//! depth: where the tool at the R plane, with the bottom's X, Y, would be further from the
//! hole's axis than the path tolerance, the cycle is refused (program it as G0/G1 moves).

use super::exact::Unit;
use super::{Edit, Pass, State, Summary};
use crate::diag::Diagnostic;
use crate::kinematics::Model;
use crate::model::AxisKind;
use crate::nc::number::{same_text, write_fixed};
use crate::nc::{self, Token, TokenKind, Value};
use crate::program::BlockMotion;

/// The modal state of an active cycle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Cycle {
    /// Bottom and R plane as programmed (mm), and as last written (program units).
    pub bottom: Option<f64>,
    pub r_plane: Option<f64>,
    pub bottom_written: Option<f64>,
    pub r_written: Option<f64>,
    /// The Z level before the cycle began: nominal and as the machine was told (mm).
    pub initial: (f64, f64),
}

impl Pass<'_> {
    /// One block of an active drilling cycle.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn cycle_block(
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
        let col = motion
            .arc_code
            .map(|i| tokens[i].span.start)
            .or_else(|| {
                axis_words
                    .iter()
                    .chain(&motion.arc_words)
                    .flatten()
                    .map(|&i| tokens[i].span.start)
                    .min()
            })
            .unwrap_or(0);
        let refuse = |why: String| {
            Err(at(
                col,
                format!("this canned cycle cannot be compensated: {why}"),
            ))
        };
        let var = |letter: u8| {
            self.var_of_letter[(letter - b'A') as usize]
                .filter(|&v| self.kin.kind(v) == AxisKind::Linear)
        };
        let (Some(vx), Some(vy), Some(vz)) = (var(b'X'), var(b'Y'), var(b'Z')) else {
            return refuse("the machine has no linear X, Y and Z axes".into());
        };
        if state.modal.incremental {
            return refuse(
                "in incremental mode (G91) its R and Z are relative (program the cycle in G90)"
                    .into(),
            );
        }
        if state.modal.plane != 0 {
            return refuse("only cycles in the G17 plane (drilling along Z) are supported".into());
        }
        if state.modal.tcp {
            return refuse(
                "cycles under tool-centre-point control (G43.4/G43.5) are not supported".into(),
            );
        }
        if self.turning {
            return refuse(
                "cycles while turning (the spindle turns or is not positioned) are not supported (program the hole as G1 moves)"
                    .into(),
            );
        }
        if motion.optional {
            return refuse("an optional block (/) with a cycle is not supported".into());
        }
        if state.unknown & !self.spindle != 0 {
            return refuse(
                "it starts where an axis is at a place nccomp does not know (after G28, G30, G53, M19 or a change of tool chain)".into(),
            );
        }
        for (v, word) in axis_words.iter().enumerate().take(n) {
            if let Some(i) = *word
                && ![vx, vy, vz].contains(&v)
            {
                return Err(at(
                    tokens[i].span.start,
                    format!(
                        "{} words in a canned cycle cannot be compensated (cycles with rotary or other axis words are not supported; expected X, Y, Z and R)",
                        self.letter(v) as char
                    ),
                ));
            }
        }
        for c in 0..3 {
            if let Some(i) = motion.arc_words[c] {
                return Err(at(
                    tokens[i].span.start,
                    "I, J and K words in a canned cycle are not supported (expected X, Y, Z and R)"
                        .into(),
                ));
            }
        }
        let number = |i: usize| match &tokens[i].kind {
            TokenKind::Word(w) => match w.value {
                Value::Number { value, decimals } => (value, decimals, w.value_span.clone()),
                _ => unreachable!("cycle words are numbers"),
            },
            _ => unreachable!("cycle words are words"),
        };
        // Z and R are never diameters; X may be (G7).
        let zu = Unit::inch(state.modal.inch);
        let mut cycle = state.cycle.unwrap_or(Cycle {
            bottom: None,
            r_plane: None,
            bottom_written: None,
            r_written: None,
            initial: (state.nominal[vz], state.emitted[vz]),
        });
        if let Some(i) = axis_words[vz] {
            cycle.bottom = Some(zu.to_mm(number(i).0));
        }
        if let Some(i) = motion.arc_words[3] {
            cycle.r_plane = Some(zu.to_mm(number(i).0));
        }
        let (Some(bottom), Some(r_plane)) = (cycle.bottom, cycle.r_plane) else {
            return refuse("it needs its bottom (Z) and retract plane (R)".into());
        };
        for v in [vx, vy] {
            if let Some(i) = axis_words[v] {
                state.nominal[v] = self.unit(v, &state.modal).to_mm(number(i).0);
                state.programmed |= 1 << v;
            }
            if state.programmed & (1 << v) == 0 {
                return refuse(format!(
                    "the program has not set {} before the cycle",
                    self.letter(v) as char
                ));
            }
        }
        // The rotary axes stay where they are; the linear ones take the whole correction.
        let mut hold = self.hold;
        for v in 0..n {
            if !self.is_linear(v) {
                hold |= 1 << v;
            }
        }
        let at_depth = |z: f64| {
            let mut q = state.nominal;
            q[vz] = z;
            let sol = self
                .kin
                .compensate(&q[..n], state.modal.length, hold, &self.options.solve);
            (q, sol)
        };
        let (q_bottom, bottom_sol) = at_depth(bottom);
        let (q_r, r_sol) = at_depth(r_plane);
        self.check_piece(&q_bottom, &bottom_sol.q, col, at)?;
        self.check_piece(&q_r, &r_sol.q, col, at)?;
        // The tool at the R plane with the bottom's X, Y: is it still on the hole's axis?
        let tolerance = self.options.path.unwrap_or_default().position;
        let mut at_r = r_sol.q;
        at_r[vx] = bottom_sol.q[vx];
        at_r[vy] = bottom_sol.q[vy];
        let (reached, _) = self.kin.pose(Model::Actual, &at_r[..n], state.modal.length);
        let off = (reached.p - r_sol.target.p).norm();
        if off > tolerance || bottom_sol.position_residual > 1e-6 {
            return refuse(format!(
                "one X, Y cannot serve the whole depth here: with the bottom's correction the tool is {:.2} µm off the hole's axis at the R plane (more than {:.2} µm; program the cycle as G0/G1 moves)",
                off * 1e3,
                tolerance * 1e3
            ));
        }
        summary.motion_blocks += 1;

        // X, Y and the bottom Z, as any block's axis words (a missing Z is compared with the
        // cycle's bottom as last written, not with where the machine stands).
        state.emitted[vz] = cycle.bottom_written.map_or(f64::NAN, |z| zu.to_mm(z));
        self.write_positions(
            line,
            tokens,
            axis_words,
            &bottom_sol.q,
            false,
            state,
            edits,
            summary,
            at,
        )?;
        cycle.bottom_written = Some(zu.of_mm(state.emitted[vz]));
        // R: rewritten where it is, added where the modal value no longer fits.
        let r_value = zu.of_mm(r_sol.q[vz]);
        let d = self.res_decimals(vz, zu);
        match motion.arc_words[3] {
            Some(i) => {
                let (old, decimals, span) = number(i);
                let d = decimals.max(d);
                let mut text = String::new();
                write_fixed(r_value, d, &mut text);
                if !same_text(old, r_value, d) {
                    edits.push(Edit {
                        at: span,
                        text: text.clone().into(),
                    });
                    summary.words_changed += 1;
                }
                cycle.r_written = text.parse().ok();
            }
            None => {
                let d = state.decimals[vz].max(d);
                if cycle
                    .r_written
                    .is_none_or(|old| !same_text(old, r_value, d))
                {
                    let mut text = String::new();
                    write_fixed(r_value, d, &mut text);
                    let end = axis_words
                        .iter()
                        .flatten()
                        .map(|&i| tokens[i].span.end)
                        .max()
                        .unwrap_or(line.content.len());
                    let style = super::split::Style::of(line.content, tokens);
                    edits.push(Edit {
                        at: end..end,
                        text: format!("{}{}{text}", style.separator, style.letter(b'R')).into(),
                    });
                    summary.words_added += 1;
                    cycle.r_written = text.parse().ok();
                }
            }
        }
        let (ap, ad) = self
            .kin
            .pose(Model::Actual, &state.emitted[..n], state.modal.length)
            .0
            .deviation(&bottom_sol.target);
        summary.record(
            line.number,
            bottom_sol.start_position_error,
            bottom_sol.start_direction_error,
            ap,
            ad,
            false,
            bottom_sol.beyond,
        );
        // Where the cycle leaves the tool: the R plane (G99) or the initial level (G98;
        // R when that is higher).
        let r_emitted = cycle.r_written.map_or(r_sol.q[vz], |r| zu.to_mm(r));
        let (z_nominal, z_emitted) = if state.modal.retract_to_initial && cycle.initial.0 > r_plane
        {
            cycle.initial
        } else {
            (r_plane, r_emitted)
        };
        state.nominal[vz] = z_nominal;
        state.emitted[vz] = z_emitted;
        state.written[vz] = super::exact::Position::Decimal {
            value: zu.of_mm(z_emitted),
            decimals: state.decimals[vz],
            unit: zu,
        };
        state.cycle = Some(cycle);
        Ok(())
    }
}
