//! The compensation pass: stream over the blocks of a program, follow its modal state,
//! solve every pose through the error model and rewrite the axis words that change.
//!
//! Bytes that need no change are copied as they were: a word keeps its text unless its
//! compensated value rounds differently (design/model.md, "Numbers in programs"); a block
//! that omits an axis whose value must change gets that word added.

mod gcodes;
mod summary;
mod words;

pub use summary::{Extreme, Summary};

use crate::diag::{Diagnostic, Error};
use crate::kinematics::{Kinematics, MAX_AXES, Model, SolveOptions};
use crate::model::{AxisKind, ErrorModel, Machine};
use crate::nc::number::{decimals_for, same_text, scaled, write_fixed};
use crate::nc::{self, Token, TokenKind, Value};
use gcodes::GCode;
use words::BlockMotion;

/// Millimetres per inch.
const INCH: f64 = 25.4;

/// How the pass runs.
#[derive(Debug, Clone, PartialEq)]
pub struct Options {
    /// Name of the active tool chain; `None`: the machine's first.
    pub tool_chain: Option<String>,
    pub solve: SolveOptions,
    /// Report travel-limit violations after compensation instead of failing.
    pub allow_limit_violations: bool,
    /// Largest correction accepted for a linear axis (mm) and a rotary axis (degrees); a
    /// larger one means the model or the pose is wrong, and the block is refused.
    pub max_correction: (f64, f64),
    /// Stop after this many refused blocks.
    pub max_errors: usize,
    /// Axes (by name or program letter) that keep their programmed values: not positioned
    /// by the program (a lathe spindle C while turning) or not to be touched.
    pub hold: Vec<String>,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            tool_chain: None,
            solve: SolveOptions::default(),
            allow_limit_violations: false,
            max_correction: (10.0, 2.0),
            max_errors: 20,
            hold: Vec::new(),
        }
    }
}

/// A compensator for one machine, error model and tool chain.
#[derive(Debug, Clone)]
pub struct Compensator<'m> {
    machine: &'m Machine,
    kin: Kinematics,
    zero_model: bool,
    options: Options,
    /// Variable driven by each letter A..Z.
    var_of_letter: [Option<usize>; 26],
    decimals: (u8, u8),
    /// Bit k: variable k is held (`Options::hold`).
    hold: u32,
}

/// The program's modal state as the pass follows it.
#[derive(Debug, Clone)]
struct State {
    inch: bool,
    motion: Option<GCode>,
    /// Programmed (nominal) axis values, mm and degrees.
    nominal: [f64; MAX_AXES],
    /// What the machine was last told, mm and degrees.
    emitted: [f64; MAX_AXES],
    /// Bit k: variable k has been programmed.
    programmed: u32,
    /// Decimals of the last word written for each variable.
    decimals: [u8; MAX_AXES],
    length: f64,
    tool: Option<u32>,
    work_offset: Option<i64>,
    /// Bit k: variable k was last set by an optional (block delete) block, at the line in
    /// `optional_line[k]`, so its programmed value depends on the block delete switch.
    uncertain: u32,
    /// Bit k: variable k was only corrected (not programmed) by an optional block, so the
    /// machine may be microns off what `emitted` says: the next block writes it.
    unsettled: u32,
    optional_line: [usize; MAX_AXES],
}

/// A change to one line: replace a byte range, or insert at a position (empty range).
#[derive(Debug, Clone)]
struct Edit {
    at: std::ops::Range<usize>,
    text: String,
}

impl<'m> Compensator<'m> {
    pub fn new(machine: &'m Machine, errors: &ErrorModel, options: Options) -> crate::Result<Self> {
        let chain = match &options.tool_chain {
            None => 0,
            Some(name) => machine.tool_chain(name).ok_or_else(|| {
                Error::Usage(if machine.tool_chains.len() == 1 {
                    format!(
                        "--tool-chain {name}: the machine file has a single `tool_chain`, so there is nothing to choose (leave the option out)"
                    )
                } else {
                    format!(
                        "--tool-chain {name}: the machine file has no such tool chain; it has {}",
                        machine
                            .tool_chains
                            .iter()
                            .map(|c| format!("`{}`", c.name))
                            .collect::<Vec<_>>()
                            .join(", ")
                    )
                })
            })?,
        };
        let kin =
            Kinematics::new(machine, errors, chain).map_err(|e| Error::Usage(e.to_string()))?;
        let mut var_of_letter = [None; 26];
        for (var, &axis) in kin.axes().iter().enumerate() {
            let letter = machine.axes[axis].word.to_ascii_uppercase();
            if letter.is_ascii_uppercase() {
                var_of_letter[(letter as u8 - b'A') as usize] = Some(var);
            }
        }
        let mut hold = 0;
        for name in &options.hold {
            let var = kin.axes().iter().position(|&i| {
                let axis = &machine.axes[i];
                axis.name.eq_ignore_ascii_case(name)
                    || axis.word.to_string().eq_ignore_ascii_case(name)
            });
            match var {
                Some(v) => hold |= 1 << v,
                None => {
                    return Err(Error::Usage(format!(
                        "cannot hold axis `{name}`: the active chains have no such axis"
                    )));
                }
            }
        }
        Ok(Compensator {
            hold,
            machine,
            kin,
            zero_model: errors.is_zero(),
            options,
            var_of_letter,
            decimals: (
                decimals_for(machine.resolution.linear),
                decimals_for(machine.resolution.rotary),
            ),
        })
    }

    pub fn kinematics(&self) -> &Kinematics {
        &self.kin
    }

    fn axis_name(&self, var: usize) -> &str {
        &self.machine.axes[self.kin.axes()[var]].name
    }

    fn letter(&self, var: usize) -> u8 {
        self.machine.axes[self.kin.axes()[var]]
            .word
            .to_ascii_uppercase() as u8
    }

    fn is_linear(&self, var: usize) -> bool {
        self.kin.kind(var) == AxisKind::Linear
    }

    /// Compensate the program `src` (named `path` in messages), appending the result to
    /// `out`.
    pub fn run(&self, src: &[u8], path: &str, out: &mut Vec<u8>) -> crate::Result<Summary> {
        let mut summary = Summary {
            zero_model: self.zero_model,
            ..Summary::default()
        };
        if self.zero_model {
            // Nothing can change: the program passes byte for byte, whatever it holds.
            out.extend_from_slice(src);
            summary.lines = nc::lines(src).count();
            return Ok(summary);
        }
        let n = self.kin.len();
        let mut state = State {
            inch: false,
            motion: None,
            nominal: [0.0; MAX_AXES],
            emitted: [0.0; MAX_AXES],
            programmed: 0,
            decimals: [0; MAX_AXES],
            length: self.machine.tool.length,
            tool: None,
            work_offset: None,
            uncertain: 0,
            unsettled: 0,
            optional_line: [0; MAX_AXES],
        };
        for v in 0..n {
            state.decimals[v] = self.res_decimals(v, false);
        }
        let mut tokens: Vec<Token> = Vec::new();
        let mut edits: Vec<Edit> = Vec::new();
        let mut errors: Vec<Diagnostic> = Vec::new();
        for line in nc::lines(src) {
            summary.lines += 1;
            nc::parse_line(line.content, &mut tokens);
            edits.clear();
            let at = |offset: usize, message: String| {
                Diagnostic::at(path, src, line.offset + offset, message)
            };
            if let Err(d) = self.block(&line, &tokens, &mut state, &mut edits, &mut summary, &at) {
                errors.push(d);
                if errors.len() >= self.options.max_errors {
                    break;
                }
            }
            if edits.is_empty() {
                out.extend_from_slice(line.content);
            } else {
                edits.sort_by_key(|e| (e.at.start, e.at.end));
                let mut pos = 0;
                for e in &edits {
                    out.extend_from_slice(&line.content[pos..e.at.start]);
                    out.extend_from_slice(e.text.as_bytes());
                    pos = e.at.end;
                }
                out.extend_from_slice(&line.content[pos..]);
            }
            out.extend_from_slice(line.ending);
        }
        if !errors.is_empty() {
            return Err(Error::Inputs(errors));
        }
        Ok(summary)
    }

    fn res_decimals(&self, var: usize, inch: bool) -> u8 {
        if self.is_linear(var) {
            if inch {
                decimals_for(self.machine.resolution.linear / INCH)
            } else {
                self.decimals.0
            }
        } else {
            self.decimals.1
        }
    }

    /// One block: follow its modal words, and if it moves, compensate it.
    fn block(
        &self,
        line: &nc::Line<'_>,
        tokens: &[Token],
        state: &mut State,
        edits: &mut Vec<Edit>,
        summary: &mut Summary,
        at: &dyn Fn(usize, String) -> Diagnostic,
    ) -> Result<(), Diagnostic> {
        let Some(BlockMotion {
            axis_words,
            optional,
        }) = self.read_block(line, tokens, state, at)?
        else {
            return Ok(());
        };
        let n = self.kin.len();
        // New nominal values.
        for (v, word) in axis_words.iter().enumerate().take(n) {
            if let Some(i) = *word {
                let value = word_number(&tokens[i]);
                state.nominal[v] = if state.inch && self.is_linear(v) {
                    value * INCH
                } else {
                    value
                };
            }
        }
        // Programmed values outside the travel are the program's own fault.
        for (v, word) in axis_words.iter().enumerate().take(n) {
            if let Some([lo, hi]) = self.travel(v)
                && !(lo..=hi).contains(&state.nominal[v])
                && !self.options.allow_limit_violations
            {
                let col = word.map_or(0, |i| tokens[i].span.start);
                return Err(at(
                    col,
                    format!(
                        "axis {} is programmed to {:.4}, outside its travel {lo} … {hi} (use --allow-limit-violations to compensate it anyway)",
                        self.axis_name(v),
                        state.nominal[v]
                    ),
                ));
            }
        }
        // Solve; an axis the correction would push past a travel limit it was programmed
        // within is held at its programmed value instead (the others still put the tip in
        // place; the direction error it would have fixed is reported).
        let mut hold = self.hold;
        let mut at_limit = 0u32;
        let sol = loop {
            let sol =
                self.kin
                    .compensate(&state.nominal[..n], state.length, hold, &self.options.solve);
            // Only rotary axes: holding one costs direction, never position.
            let past = (0..n).find(|&v| {
                hold & (1 << v) == 0
                    && !self.is_linear(v)
                    && self.travel(v).is_some_and(|[lo, hi]| {
                        // As it would be written: a crossing below the resolution is none.
                        let d = self.decimals.1;
                        let x = scaled(sol.q[v], d)
                            .map_or(sol.q[v], |k| k as f64 / 10f64.powi(d.into()));
                        (x < lo || x > hi) && (lo..=hi).contains(&state.nominal[v])
                    })
            });
            match past {
                Some(v) if !self.options.allow_limit_violations => {
                    hold |= 1 << v;
                    at_limit |= 1 << v;
                }
                _ => break sol,
            }
        };
        if at_limit != 0 && sol.position_residual > 1e-6 {
            let v = at_limit.trailing_zeros() as usize;
            let col = axis_words[v].map_or(0, |i| tokens[i].span.start);
            return Err(at(
                col,
                format!(
                    "the correction would push axis {} past its travel limit, and holding it there leaves the tip {:.4} mm off (use --allow-limit-violations to write it anyway)",
                    self.axis_name(v),
                    sol.position_residual
                ),
            ));
        }
        summary.motion_blocks += 1;
        // Guard against a model or pose that turns microns into a big move.
        for v in 0..n {
            let delta = (sol.q[v] - state.nominal[v]).abs();
            let limit = if self.is_linear(v) {
                self.options.max_correction.0
            } else {
                self.options.max_correction.1
            };
            if delta.is_nan() || delta > limit {
                let col = axis_words[v]
                    .or_else(|| {
                        axis_words
                            .iter()
                            .flatten()
                            .copied()
                            .min_by_key(|&i| tokens[i].span.start)
                    })
                    .map_or(0, |i| tokens[i].span.start);
                return Err(at(
                    col,
                    format!(
                        "the correction of axis {} would be {delta:.4} {} (more than {limit}); the error model or this pose is not sound",
                        self.axis_name(v),
                        if self.is_linear(v) { "mm" } else { "°" }
                    ),
                ));
            }
        }
        // Rewrite present words, add missing ones.
        for v in 0..n {
            let to_units = |x: f64| {
                if state.inch && self.is_linear(v) {
                    x / INCH
                } else {
                    x
                }
            };
            let from_units = |x: f64| {
                if state.inch && self.is_linear(v) {
                    x * INCH
                } else {
                    x
                }
            };
            let value = to_units(sol.q[v]);
            match axis_words[v] {
                Some(i) => {
                    let t = &tokens[i];
                    let TokenKind::Word(w) = &t.kind else {
                        unreachable!()
                    };
                    let Value::Number {
                        value: old,
                        decimals,
                    } = w.value
                    else {
                        unreachable!()
                    };
                    let d = decimals.max(self.res_decimals(v, state.inch));
                    state.decimals[v] = d;
                    if same_text(old, value, d) {
                        state.emitted[v] = from_units(old);
                    } else {
                        let mut text = String::new();
                        write_fixed(value, d, &mut text);
                        state.emitted[v] = from_units(text.parse().unwrap_or(value));
                        edits.push(Edit {
                            at: w.value_span.clone(),
                            text,
                        });
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
                    let d = state.decimals[v].max(self.res_decimals(v, state.inch));
                    let unsettled = state.unsettled & (1 << v) != 0 && !optional;
                    if unsettled || !same_text(to_units(state.emitted[v]), value, d) {
                        if state.uncertain & (1 << v) != 0 && !optional {
                            let letter = self.letter(v) as char;
                            let col = axis_words
                                .iter()
                                .flatten()
                                .map(|&i| tokens[i].span.start)
                                .min()
                                .unwrap_or(0);
                            return Err(at(
                                col,
                                format!(
                                    "this block needs a corrected {letter} word, but {letter} was last set by the optional block (/) at line {}: adding it would change what the program does when block delete is on (program {letter} in this block)",
                                    state.optional_line[v]
                                ),
                            ));
                        }
                        if optional {
                            state.unsettled |= 1 << v;
                        } else {
                            state.unsettled &= !(1 << v);
                        }
                        let mut text = String::new();
                        write_fixed(value, d, &mut text);
                        state.emitted[v] = from_units(text.parse().unwrap_or(value));
                        edits.push(self.insertion(line.content, tokens, &axis_words, v, &text));
                        summary.words_added += 1;
                        if state.programmed & (1 << v) == 0 {
                            summary.note_assumed_home(self.axis_name(v), line.number);
                        }
                    }
                }
            }
        }
        // Travel limits, on what the machine is now told.
        for (v, word) in axis_words.iter().enumerate().take(n) {
            if let Some([lo, hi]) = self.machine.axes[self.kin.axes()[v]].travel {
                let x = state.emitted[v];
                if x < lo - 1e-9 || x > hi + 1e-9 {
                    let (limit, side) = if x < lo { (lo, "below") } else { (hi, "above") };
                    let col = word.map_or(0, |i| tokens[i].span.start);
                    let message = if (lo..=hi).contains(&state.nominal[v]) {
                        format!(
                            "after compensation axis {} = {x:.4} is {side} its travel limit {limit}",
                            self.axis_name(v)
                        )
                    } else {
                        format!(
                            "axis {} is programmed to {:.4}, {side} its travel limit {limit}",
                            self.axis_name(v),
                            state.nominal[v]
                        )
                    };
                    if self.options.allow_limit_violations {
                        summary
                            .limit_violations
                            .push(format!("line {}: {message}", line.number));
                    } else {
                        return Err(at(
                            col,
                            format!("{message} (use --allow-limit-violations to write it anyway)"),
                        ));
                    }
                }
            }
        }
        // What the block does before and after, as the model predicts it.
        let (after, beyond) = self
            .kin
            .pose(Model::Actual, &state.emitted[..n], state.length);
        let (bp, bd) = (sol.start_position_error, sol.start_direction_error);
        let (ap, ad) = after.deviation(&sol.target);
        summary.record(line.number, bp, bd, ap, ad, sol.singular != 0, beyond);
        for v in 0..n {
            if sol.singular & (1 << v) != 0 {
                summary.note_held(self.axis_name(v));
            }
            if at_limit & (1 << v) != 0 {
                summary.note_at_limit(self.axis_name(v), line.number);
            }
        }
        Ok(())
    }

    fn travel(&self, var: usize) -> Option<[f64; 2]> {
        self.machine.axes[self.kin.axes()[var]].travel
    }

    fn axis_letters(&self) -> String {
        (0..self.kin.len())
            .map(|v| (self.letter(v) as char).to_string())
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// Where and how to add a word for variable `v` to a block that lacks it: in the
    /// machine's axis order among the block's axis words, in the style of its neighbour
    /// (letter case, a space between letter and number, spaces between words).
    fn insertion(
        &self,
        content: &[u8],
        tokens: &[Token],
        axis_words: &[Option<usize>; MAX_AXES],
        v: usize,
        number: &str,
    ) -> Edit {
        let order = |var: usize| axis_order(self.letter(var));
        let mine = order(v);
        let present = || {
            axis_words
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
        let neighbour = after.or(before).map_or(0, |(_, i)| i);
        let (lowercase, gap) = match &tokens[neighbour].kind {
            TokenKind::Word(w) => (
                w.lowercase,
                &content[tokens[neighbour].span.start + 1..w.value_span.start],
            ),
            _ => (false, &content[0..0]),
        };
        // Packed blocks (G1X10Y5) stay packed; otherwise words get a space between them.
        let packed = tokens.windows(2).any(|w| {
            matches!(w[0].kind, TokenKind::Word(_)) && matches!(w[1].kind, TokenKind::Word(_))
        });
        let sep = if packed { "" } else { " " };
        let letter = if lowercase {
            self.letter(v).to_ascii_lowercase()
        } else {
            self.letter(v)
        } as char;
        let word = format!("{letter}{}{number}", String::from_utf8_lossy(gap));
        match after {
            Some((_, i)) => {
                let end = tokens[i].span.end;
                Edit {
                    at: end..end,
                    text: format!("{sep}{word}"),
                }
            }
            None => {
                let start = tokens[neighbour].span.start;
                Edit {
                    at: start..start,
                    text: format!("{word}{sep}"),
                }
            }
        }
    }
}

/// The usual order of axis words in a block.
fn axis_order(letter: u8) -> usize {
    b"XYZUVWABC".iter().position(|&l| l == letter).unwrap_or(9)
}

/// A G or M word as the program wrote it (for messages).
fn code_text(content: &[u8], t: &Token) -> String {
    String::from_utf8_lossy(&content[t.span.clone()])
        .trim()
        .to_string()
}

/// The number of a token known to be a numeric word.
fn word_number(t: &Token) -> f64 {
    match &t.kind {
        TokenKind::Word(w) => w.number().unwrap_or(0.0),
        _ => 0.0,
    }
}
