//! TNC holes written out as L moves where one X, Y cannot serve the whole depth
//! (docs/heidenhain.md, "Cycles").
//!
//! A drilling cycle goes down the tool axis at one X, Y: where the real machine leans off
//! the hole's axis over its depth (an out-of-square Z, a tilted plane, a deep hole), no
//! corrected X, Y keeps the whole hole within the tolerance. For the cycles whose motion
//! the control's manuals describe exactly (200 drilling with its pecks and dwells, 201
//! reaming, 240 centering to a depth), the call is then written as that motion: the call's
//! own positioning without `M99`, and an `L` block for each move along the tool axis (FMAX
//! or the cycle's feed), `CYCL DEF 9` for each dwell, every block through the pass like
//! any `L` block of the program: its ends compensated and the path between them held to
//! the tolerance, split where it strays: the correction follows the depth. The blocks
//! take the call's block number on, consecutively. A cycle's feed is modal where the `L`
//! blocks write it; where the program had another feed in force, a last block that stays
//! where the tool stands gives it back.

use super::stream::{Run, in_line};
use super::{State, Summary};
use crate::diag::Diagnostic;
use crate::nc::{self, Token, TokenKind, Value};
use crate::program::heidenhain;
use crate::program::tnc_cycles::HoleStep;

/// The pass as it stood before a cycle call that may be written out.
pub(super) struct Saved {
    state: State,
    summary: Summary,
    /// How many samples the run's trace had (the trace itself is not copied).
    traced: usize,
}

/// Follow the F word in force in a TNC line (`F500`, `FQ1` in an `L`, arc or `TOOL
/// CALL` block; not `FMAX`, `F MAX`, `FAUTO`).
pub(super) fn follow_feed(content: &[u8], tokens: &[Token], state: &mut State) {
    for t in tokens {
        if let TokenKind::Word(w) = &t.kind
            && w.letter == b'F'
            && matches!(w.value, Value::Number { .. } | Value::Parameter)
        {
            state.feed = Some(String::from_utf8_lossy(&content[t.span.clone()]).into_owned());
        }
    }
}

/// `x` with at most six decimals, trailing zeros dropped, signed where the program signs
/// its numbers.
fn number(x: f64, signed: bool) -> String {
    let mut text = String::new();
    crate::nc::number::write_fixed(x, 6, &mut text);
    if text.contains('.') {
        while text.ends_with('0') {
            text.pop();
        }
        if text.ends_with('.') {
            text.pop();
        }
    }
    if text == "-0" {
        text = "0".into();
    }
    if signed && !text.starts_with('-') {
        text.insert(0, '+');
    }
    text
}

impl Run<'_, '_> {
    /// The pass's state before `line`, where it calls a cycle whose motion nccomp may
    /// write out (200, 201, 240 in a TNC program): to come back to if the call is refused
    /// because one X, Y cannot serve its depth.
    pub(super) fn hole_snapshot(&mut self, line: &nc::Line<'_>) -> Option<Saved> {
        if self.state.modal.dialect != nc::Dialect::Heidenhain {
            return None;
        }
        let c = line.content;
        if memchr::memmem::find(c, b"M99").is_none() && memchr::memmem::find(c, b"CALL").is_none() {
            return None;
        }
        let def = self.state.modal.called_cycle()?;
        if def.siemens.is_some() || !matches!(def.number, 200 | 201 | 240) {
            return None;
        }
        // The solutions solved ahead stay with the pass (the saved state does not need
        // them: no cycle is solved ahead).
        let presolved = std::mem::take(&mut self.state.presolved);
        let trace = self.summary.trace.take();
        let saved = Saved {
            state: self.state.clone(),
            summary: self.summary.clone(),
            traced: trace.as_ref().map_or(0, Vec::len),
        };
        self.state.presolved = presolved;
        self.summary.trace = trace;
        Some(saved)
    }

    /// Back to the state of `saved` (the solutions solved ahead as they are now, the
    /// trace without what was added since).
    pub(super) fn restore(&mut self, saved: Saved) {
        let presolved = std::mem::take(&mut self.state.presolved);
        let mut trace = self.summary.trace.take();
        if let Some(t) = trace.as_mut() {
            t.truncate(saved.traced);
        }
        self.state = saved.state;
        self.state.presolved = presolved;
        self.summary = saved.summary;
        self.summary.trace = trace;
    }

    /// Write the hole that `line` calls as the `steps` of its motion (see the module's
    /// documentation), each block through the pass; `refused`: the call's refusal, given
    /// where the blocks cannot be written. False when the pass should stop.
    pub(super) fn write_out(
        &mut self,
        line: &nc::Line<'_>,
        path: &str,
        out: &mut Vec<u8>,
        steps: &[HoleStep],
        refused: Option<Diagnostic>,
    ) -> bool {
        let mut tokens = Vec::new();
        crate::program::tokenize(&self.state.modal, line.content, &mut tokens);
        let content = line.content;
        let m99 = tokens.iter().position(|t| {
            matches!(&t.kind, TokenKind::Word(w) if w.letter == b'M'
                && matches!(w.value, Value::Number { value, .. } if value == 99.0))
        });
        let Some(number) = heidenhain::number_of(content, &tokens) else {
            self.errors.extend(refused);
            return self.errors.len() < self.max_errors();
        };
        let col = m99.map_or_else(
            || heidenhain::keyword(content, &tokens).map_or(0, |i| tokens[i].span.start),
            |i| tokens[i].span.start,
        );
        // The program's style: signed numbers, `F MAX` or `FMAX`.
        let signed = tokens.iter().any(|t| {
            matches!(&t.kind, TokenKind::Word(w) if b"XYZ".contains(&w.letter)
                && content.get(w.value_span.start) == Some(&b'+'))
        });
        let rapid = if memchr::memmem::find(content, b"F MAX").is_some() {
            "F MAX"
        } else {
            "FMAX"
        };
        let mut blocks: Vec<Vec<u8>> = Vec::new();
        // The call's own positioning, without M99 (CYCL CALL positions nothing).
        if let Some(i) = m99 {
            let mut own = content.to_vec();
            let start = match i.checked_sub(1).map(|j| &tokens[j]) {
                Some(t) if t.kind == TokenKind::Space => t.span.start,
                _ => tokens[i].span.start,
            };
            own.drain(start..tokens[i].span.end);
            blocks.push(own);
        }
        let mut last_feed: Option<&str> = None;
        let mut end = None;
        for step in steps {
            match step {
                HoleStep::Rapid(z) => {
                    blocks.push(
                        format!("{number} L Z{} R0 {rapid}", self::number(*z, signed)).into_bytes(),
                    );
                    end = Some(*z);
                }
                HoleStep::Feed(z, f) => {
                    blocks.push(
                        format!("{number} L Z{} R0 F{f}", self::number(*z, signed)).into_bytes(),
                    );
                    last_feed = Some(f);
                    end = Some(*z);
                }
                HoleStep::Dwell(seconds) => {
                    blocks.push(format!("{number} CYCL DEF 9.0 DWELL TIME").into_bytes());
                    blocks.push(
                        format!(
                            "{number} CYCL DEF 9.1 DWELL {}",
                            self::number(*seconds, false)
                        )
                        .into_bytes(),
                    );
                }
            }
        }
        // The feed the program had in force, given back where the cycle's took its place:
        // a block that stays where the tool stands.
        if let (Some(old), Some(new), Some(z)) = (self.state.feed.clone(), last_feed, end)
            && old != format!("F{new}")
        {
            blocks.push(format!("{number} L Z{} R0 {old}", self::number(z, signed)).into_bytes());
        }
        let lines = self.summary.lines;
        let errors = self.errors.len();
        for (k, block) in blocks.iter().enumerate() {
            let written = nc::Line {
                number: line.number,
                offset: line.offset,
                content: block,
                ending: line.ending,
            };
            let go_on = self.line_once(&written, path, out);
            if self.errors.len() > errors {
                // Said at the call, with what its written motion met.
                let met = self.errors.split_off(errors);
                for d in met {
                    self.errors.push(in_line(
                        path,
                        line,
                        col,
                        format!(
                            "this hole, which one X, Y cannot serve over its depth, cannot be written out as L moves either: at its block `{}`: {}",
                            String::from_utf8_lossy(block),
                            d.message
                        ),
                    ));
                }
                self.summary.lines = lines + 1;
                return go_on;
            }
            if k + 1 < blocks.len() {
                self.state.renumber += 1;
            }
        }
        self.summary.lines = lines + 1;
        let summary = &mut self.summary;
        if summary.holes_written_out == 0 {
            summary.first_written_out = line.number;
        }
        summary.holes_written_out += 1;
        summary.hole_blocks_added += blocks.len() - 1;
        true
    }

    fn max_errors(&self) -> usize {
        self.comp.passes[self.state.pass].options.max_errors
    }
}
