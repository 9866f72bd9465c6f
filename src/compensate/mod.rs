//! The compensation pass: stream over the blocks of a program, follow its modal state,
//! solve every pose through the error model and rewrite the axis words that change.
//!
//! Bytes that need no change are copied as they were: a word keeps its text unless its
//! compensated value rounds differently (design/model.md, "Numbers in programs"); a block
//! that omits an axis whose value must change gets that word added.

mod arc_keep;
mod arcs;
mod cycles;
mod exact;
mod lathe;
mod nominal;
mod presolve;
mod split;
mod stream;
mod summary;
mod tcp;
mod tcp_vector;
mod writing;

pub use arc_keep::ArcPath;
pub use nominal::{NominalMove, Shape};
pub use summary::{Extreme, Sample, Summary};

use crate::diag::{Diagnostic, Error};
use crate::kinematics::{Kinematics, MAX_AXES, Model, SolveOptions};
use crate::model::{AxisKind, ErrorModel, Machine};
use crate::nc::number::{decimals_for, scaled};
use crate::nc::{self, Edit, Token, TokenKind, Value};
use crate::program::{BlockMotion, INCH, Modal, MoveKind, Reader};
use exact::{Position, Unit};
use stream::Run;

/// The code of diagnostics about travel limits ([`Diagnostic::code`]): a block refused
/// because it would leave an axis's travel, or (with `allow_limit_violations`) a
/// violation written anyway.
pub const TRAVEL_LIMIT: &str = "travel_limit";

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
    /// Split G1 moves whose compensated path strays further than this from the nominal
    /// path between their ends; `None`: one block out for every block in.
    pub path: Option<crate::kinematics::path::PathTolerance>,
    /// Threads for [`Compensator::run_stream`]: 1 runs the pass alone; 2 or more add a
    /// helper that solves blocks ahead (the output is the same).
    pub threads: usize,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            tool_chain: None,
            solve: SolveOptions::compensation(),
            allow_limit_violations: false,
            max_correction: (10.0, 2.0),
            max_errors: 20,
            hold: Vec::new(),
            path: None,
            threads: 1,
        }
    }
}

/// A compensator for one machine and error model: it follows a program through its tool
/// chains (T words, where the machine file maps tools to chains) and, on a lathe, through
/// turning and milling (the spindle's M codes and C words), with one [`Pass`] for each.
#[derive(Debug, Clone)]
pub struct Compensator<'m> {
    machine: &'m Machine,
    /// Reads the program's blocks.
    reader: Reader<'m>,
    /// The milling pass of every tool chain, in the machine file's order, then (on a
    /// lathe) the turning pass of every chain.
    passes: Vec<Pass<'m>>,
    /// The tool chain a program starts in.
    start: usize,
    zero_model: bool,
    /// `Options::threads`.
    threads: usize,
}

/// The pass for one configuration: one tool chain, milling or turning.
#[derive(Debug, Clone)]
struct Pass<'m> {
    machine: &'m Machine,
    kin: Kinematics,
    options: Options,
    /// Variable driven by each letter A..Z.
    var_of_letter: [Option<usize>; 26],
    decimals: (u8, u8),
    /// Bit k: variable k is held (`Options::hold`; while turning also every axis but the
    /// tool's X and Z).
    hold: u32,
    /// Index into [`Machine::tool_chains`].
    chain: usize,
    /// Poses are turning poses: the spindle turns, or stands where the program has not
    /// positioned it.
    turning: bool,
    /// Bit k: variable k is the spindle and this pass turns: where it stands does not
    /// matter.
    spindle: u32,
    /// Bit k: variable k is held for turning (it does not move in a turning move, so a
    /// move can be split without knowing it).
    idle: u32,
    /// The variables in the usual order of words in a block (X Y Z ... A B C): words added
    /// at one place come out in that order.
    write_order: Vec<usize>,
}

/// The pass's state between blocks: the program's modal state (as the reader follows it)
/// and what the pass keeps of its own.
#[derive(Debug, Clone)]
struct State {
    modal: Modal,
    /// The pass blocks go through (index into [`Compensator::passes`]): the modal tool
    /// chain, milling or turning.
    pass: usize,
    /// What the program last told each machine axis, kept while its tool chain is not
    /// active (by machine axis index).
    parked: Vec<Option<lathe::Parked>>,
    /// Under G43.5: the tool vector as programmed, and as written (not normalised).
    vector_nominal: [f64; 3],
    vector_written: [f64; 3],
    /// In TCP mode: the programmed tip, and the tip as written (mm).
    tip_nominal: [f64; 3],
    tip_written: [f64; 3],
    /// An active drilling cycle.
    cycle: Option<cycles::Cycle>,
    /// The last N number seen and its digits (for numbering inserted blocks).
    last_n: Option<(u64, usize)>,
    /// Programmed (nominal) axis values, mm and degrees.
    nominal: [f64; MAX_AXES],
    /// The same, exactly (for G91: no drift).
    nominal_exact: [Position; MAX_AXES],
    /// What the machine was last told, mm and degrees.
    emitted: [f64; MAX_AXES],
    /// The same, exactly: the written absolute value, or the sum of the written increments.
    written: [Position; MAX_AXES],
    /// Bit k: variable k is at a position whose program coordinate nccomp does not know
    /// (after G28, G30 or G53), until a G90 block programs it.
    unknown: u32,
    /// Bit k: variable k has been programmed.
    programmed: u32,
    /// Decimals of the last word written for each variable.
    decimals: [u8; MAX_AXES],
    /// Bit k: variable k was last set by an optional (block delete) block, at the line in
    /// `optional_line[k]`, so its programmed value depends on the block delete switch.
    uncertain: u32,
    /// Bit k: variable k was only corrected (not programmed) by an optional block, so the
    /// machine may be microns off what `emitted` says: the next block writes it.
    unsettled: u32,
    optional_line: [usize; MAX_AXES],
    /// Line of the optional block that left variable k unsettled.
    corrected_line: [usize; MAX_AXES],
    /// Solutions worked out ahead by a helper thread.
    presolved: presolve::Presolved,
    /// Emptied texts of earlier edits, to write new ones in without allocating.
    spare_texts: Vec<Vec<u8>>,
    /// The pieces of the move being checked for splitting, reused from block to block.
    pieces: Vec<crate::kinematics::path::Piece>,
}

impl<'m> Compensator<'m> {
    pub fn new(machine: &'m Machine, errors: &ErrorModel, options: Options) -> crate::Result<Self> {
        let start = match &options.tool_chain {
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
        let modes: &[bool] = if machine.lathe.is_some() {
            &[false, true]
        } else {
            &[false]
        };
        let mut passes = Vec::new();
        for &turning in modes {
            for chain in 0..machine.tool_chains.len() {
                passes.push(Pass::new(machine, errors, &options, chain, turning)?);
            }
        }
        for name in &options.hold {
            if !passes.iter().any(|p| p.var_named(name).is_some()) {
                return Err(Error::Usage(format!(
                    "cannot hold axis `{name}`: the machine's chains have no such axis"
                )));
            }
        }
        Ok(Compensator {
            machine,
            reader: Reader::new(machine),
            passes,
            start,
            zero_model: errors.is_zero(),
            threads: options.threads,
        })
    }

    /// The kinematics a program starts with: its tool chain's, milling.
    pub fn kinematics(&self) -> &Kinematics {
        &self.passes[self.start].kin
    }

    /// The tool chain a program starts in (index into the machine's tool chains).
    pub fn start_chain(&self) -> usize {
        self.start
    }

    /// Compensate the program `src` (named `path` in messages), appending the result to
    /// `out`.
    pub fn run(&self, src: &[u8], path: &str, out: &mut Vec<u8>) -> crate::Result<Summary> {
        Self::refusing(self.run_all_with(src, path, out, false))
    }

    /// [`Self::run`], keeping what the model predicts at every compensated line in
    /// [`Summary::trace`] (for reports).
    pub fn run_traced(&self, src: &[u8], path: &str, out: &mut Vec<u8>) -> crate::Result<Summary> {
        Self::refusing(self.run_all_with(src, path, out, true))
    }

    /// [`Compensator::run`] that keeps going past refused blocks: the summary of the
    /// blocks that were compensated and the refused ones (at most `Options::max_errors`;
    /// the pass stops at that many). `out` is complete only when none was refused.
    pub fn run_all(&self, src: &[u8], path: &str, out: &mut Vec<u8>) -> (Summary, Vec<Diagnostic>) {
        self.run_all_with(src, path, out, false)
    }

    fn refusing((summary, refused): (Summary, Vec<Diagnostic>)) -> crate::Result<Summary> {
        if !refused.is_empty() {
            return Err(Error::Inputs(refused));
        }
        Ok(summary)
    }

    fn run_all_with(
        &self,
        src: &[u8],
        path: &str,
        out: &mut Vec<u8>,
        trace: bool,
    ) -> (Summary, Vec<Diagnostic>) {
        if self.zero_model {
            // Nothing can change: the program passes byte for byte, whatever it holds.
            out.extend_from_slice(src);
            let summary = Summary {
                zero_model: true,
                lines: nc::lines(src).count(),
                trace: trace.then(Vec::new),
                ..Summary::default()
            };
            return (summary, Vec::new());
        }
        let mut run = Run::new(self, trace);
        for line in nc::lines(src) {
            if !run.line(&line, path, out) {
                break;
            }
        }
        run.finish_all()
    }

    /// The modal state at the program start.
    fn start_state(&self) -> State {
        let lathe = self.machine.lathe;
        // A lathe's spindle starts free (not positioned): its passes turn.
        let pass = self.start
            + if lathe.is_some() {
                self.machine.tool_chains.len()
            } else {
                0
            };
        let first = &self.passes[pass];
        let mut state = State {
            modal: Modal::start(self.machine, self.start),
            pass,
            parked: vec![None; self.machine.axes.len()],
            last_n: None,
            cycle: None,
            vector_nominal: [0.0, 0.0, 1.0],
            vector_written: [0.0, 0.0, 1.0],
            tip_nominal: [0.0; 3],
            tip_written: [0.0; 3],
            nominal: [0.0; MAX_AXES],
            nominal_exact: [Position::Units(0); MAX_AXES],
            emitted: [0.0; MAX_AXES],
            written: [Position::Units(0); MAX_AXES],
            unknown: 0,
            programmed: 0,
            decimals: [0; MAX_AXES],
            uncertain: 0,
            unsettled: 0,
            optional_line: [0; MAX_AXES],
            corrected_line: [0; MAX_AXES],
            presolved: presolve::Presolved::default(),
            spare_texts: Vec::new(),
            pieces: Vec::new(),
        };
        for v in 0..first.kin.len() {
            state.decimals[v] = first.res_decimals(v, Unit::MM);
        }
        state
    }
}

impl<'m> Pass<'m> {
    fn new(
        machine: &'m Machine,
        errors: &ErrorModel,
        options: &Options,
        chain: usize,
        turning: bool,
    ) -> crate::Result<Self> {
        let usage = |e: crate::kinematics::KinematicsError| {
            Error::Usage(if machine.tool_chains.len() == 1 {
                e.to_string()
            } else {
                format!("tool chain `{}`: {e}", machine.tool_chains[chain].name)
            })
        };
        let mut kin = Kinematics::new(machine, errors, chain).map_err(usage)?;
        let mut var_of_letter = [None; 26];
        for (var, &axis) in kin.axes().iter().enumerate() {
            let letter = machine.axes[axis].word.to_ascii_uppercase();
            if letter.is_ascii_uppercase() {
                var_of_letter[(letter as u8 - b'A') as usize] = Some(var);
            }
        }
        let mut pass = Pass {
            machine,
            kin: kin.clone(),
            options: options.clone(),
            var_of_letter,
            decimals: (
                decimals_for(machine.resolution.linear),
                decimals_for(machine.resolution.rotary),
            ),
            hold: 0,
            chain,
            turning,
            spindle: 0,
            idle: 0,
            write_order: Vec::new(),
        };
        let mut order: Vec<usize> = (0..kin.len()).collect();
        order.sort_by_key(|&v| axis_order(pass.letter(v)));
        pass.write_order = order;
        for name in &options.hold {
            if let Some(v) = pass.var_named(name) {
                pass.hold |= 1 << v;
            }
        }
        if let (true, Some(lathe)) = (turning, machine.lathe) {
            // The machine file makes sure of all three.
            let spindle = kin.axes().iter().position(|&i| i == lathe.spindle);
            let x = var_of_letter[(b'X' - b'A') as usize];
            let z = var_of_letter[(b'Z' - b'A') as usize];
            let (Some(spindle), Some(x), Some(z)) = (spindle, x, z) else {
                return Err(Error::Usage(format!(
                    "tool chain `{}` cannot turn: it needs the spindle and X and Z axes",
                    machine.tool_chains[chain].name
                )));
            };
            kin = kin.turning(spindle, x).map_err(usage)?;
            pass.kin = kin;
            pass.spindle = 1 << spindle;
            pass.idle = (0..pass.kin.len())
                .filter(|&v| v != x && v != z)
                .fold(0, |m, v| m | 1 << v);
            pass.hold |= pass.idle;
        }
        Ok(pass)
    }

    /// The variable of the axis named `name` (or driven by that letter), if any.
    fn var_named(&self, name: &str) -> Option<usize> {
        self.kin.axes().iter().position(|&i| {
            let axis = &self.machine.axes[i];
            axis.name.eq_ignore_ascii_case(name) || axis.word.to_string().eq_ignore_ascii_case(name)
        })
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

    /// What variable `var`'s words are in, in the program's current modes.
    fn unit(&self, var: usize, modal: &Modal) -> Unit {
        let linear = self.is_linear(var);
        Unit {
            inch: modal.inch && linear,
            diameter: modal.diameter && linear && self.letter(var) == b'X',
        }
    }

    /// The decimals that resolve variable `var` to the machine's resolution in words of
    /// `unit`.
    fn res_decimals(&self, var: usize, unit: Unit) -> u8 {
        if !self.is_linear(var) {
            self.decimals.1
        } else if unit == Unit::MM {
            self.decimals.0
        } else {
            decimals_for(self.machine.resolution.linear / unit.to_mm(1.0))
        }
    }

    /// One block that moves: compensate it.
    #[allow(clippy::too_many_arguments)]
    fn block(
        &self,
        line: &nc::Line<'_>,
        tokens: &[Token],
        motion: BlockMotion,
        state: &mut State,
        edits: &mut Vec<Edit>,
        summary: &mut Summary,
        at: &dyn Fn(usize, String) -> Diagnostic,
    ) -> Result<(), Diagnostic> {
        let BlockMotion {
            axis_words,
            optional,
            kind,
            ..
        } = motion;
        if kind == MoveKind::Cycle {
            return self.cycle_block(line, tokens, &motion, state, edits, summary, at);
        }
        if let MoveKind::Arc { clockwise } = kind {
            return self.arc_block(line, tokens, &motion, clockwise, state, edits, summary, at);
        }
        let n = self.kin.len();
        if state.modal.tcp_vector && kind == MoveKind::Program {
            return self.tcp_vector_block(line, tokens, &motion, state, edits, summary, at);
        }
        if state.modal.tcp && kind == MoveKind::Program {
            return self.tcp_block(
                line,
                tokens,
                &axis_words,
                optional,
                state,
                edits,
                summary,
                at,
            );
        }
        if kind != MoveKind::Program {
            // G53, G28, G30: the block stays as it is, and the axes it sends to machine
            // positions (all of them for a bare G28/G30) leave the program's coordinates.
            let mut gone = (0..n)
                .filter(|&v| axis_words[v].is_some())
                .fold(0u32, |m, v| m | 1 << v);
            if kind == MoveKind::Home && gone == 0 {
                gone = (0..n).fold(0u32, |m, v| m | 1 << v);
            }
            state.unknown |= gone;
            state.uncertain &= !gone;
            state.unsettled &= !gone;
            return Ok(());
        }
        let first_col = axis_words
            .iter()
            .flatten()
            .map(|&i| tokens[i].span.start)
            .min()
            .unwrap_or(0);
        if optional && state.modal.incremental {
            return Err(at(
                first_col,
                "an optional block (/) in incremental mode (G91) cannot be compensated: whether it runs shifts every later incremental move, and no correction is right for both settings of block delete (program the block in G90)".into(),
            ));
        }
        let previous = state.nominal;
        let start_known = state.programmed & !state.unknown;
        let mut units = [0i128; MAX_AXES];
        self.advance_nominal(
            line,
            tokens,
            &axis_words,
            optional,
            state,
            summary,
            at,
            &mut units,
        )?;
        if state.unknown & !self.spindle != 0 {
            // The pose cannot be evaluated: the block is written as it is, and what the
            // machine is told is what the program says.
            for (v, word) in axis_words.iter().enumerate().take(n) {
                let bit = 1u32 << v;
                let Some(i) = *word else { continue };
                if state.unknown & bit != 0 {
                    continue;
                }
                if let TokenKind::Word(w) = &tokens[i].kind
                    && let Value::Number { decimals, .. } = w.value
                {
                    state.decimals[v] =
                        decimals.max(self.res_decimals(v, self.unit(v, &state.modal)));
                }
                state.programmed |= bit;
                if state.modal.incremental {
                    // The optional-block bits stay: an increment does not settle them.
                    state.written[v] = state.written[v].add(units[v]);
                    state.emitted[v] = exact::to_f64(state.written[v].units());
                } else {
                    state.written[v] = state.nominal_exact[v];
                    state.emitted[v] = state.nominal[v];
                    state.unsettled &= !bit;
                    if optional {
                        state.uncertain |= bit;
                        state.optional_line[v] = line.number;
                    } else {
                        state.uncertain &= !bit;
                    }
                }
            }
            let unknown: Vec<&str> = (0..n)
                .filter(|&v| state.unknown & !self.spindle & (1 << v) != 0)
                .map(|v| self.axis_name(v))
                .collect();
            summary.note_uncompensated(line.number, &unknown);
            return Ok(());
        }
        // Solve; an axis the correction would push past a travel limit it was programmed
        // within is held at its programmed value instead (the others still put the tip in
        // place; the direction error it would have fixed is reported).
        let mut hold = self.hold;
        let mut at_limit = 0u32;
        let solve = |hold: u32, state: &mut State| {
            state
                .presolved
                .take(
                    line.number,
                    state.pass,
                    &state.nominal[..n],
                    state.modal.length,
                    hold,
                )
                .unwrap_or_else(|| {
                    self.kin.compensate(
                        &state.nominal[..n],
                        state.modal.length,
                        hold,
                        &self.options.solve,
                    )
                })
        };
        // Solved in place, not moved out of a loop: a solution is 440 bytes.
        let mut sol = solve(hold, state);
        loop {
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
                    sol = solve(hold, state);
                }
                _ => break,
            }
        }
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
            )
            .with_code(TRAVEL_LIMIT));
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
        // Split the move where its path strays (G1 from a known start).
        if let Some(tolerance) = &self.options.path
            && !state.modal.rapid
            && !optional
            && (0..n).all(|v| (start_known | self.idle) & (1 << v) != 0)
        {
            self.split_move(
                tolerance, line, tokens, &previous, &sol.q, hold, state, edits, summary,
            );
        }
        // Rewrite present words, add missing ones.
        if state.modal.incremental {
            self.write_increments(
                line,
                tokens,
                &axis_words,
                &units,
                &sol.q,
                state,
                edits,
                summary,
                at,
            )?;
        } else {
            self.write_positions(
                line,
                tokens,
                &axis_words,
                &sol.q,
                optional,
                state,
                edits,
                summary,
                at,
            )?;
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
                            .push(at(col, message).with_code(TRAVEL_LIMIT));
                    } else {
                        return Err(at(
                            col,
                            format!("{message} (use --allow-limit-violations to write it anyway)"),
                        )
                        .with_code(TRAVEL_LIMIT));
                    }
                }
            }
        }
        // What the block does before and after, as the model predicts it.
        let (after, beyond) = self.kin.pose_near(
            Model::Actual,
            &state.emitted[..n],
            state.modal.length,
            &sol.angles,
        );
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

    /// Follow a G0/G1 block's axis words: `state.nominal` (and its exact twin) become the
    /// block's programmed end, absolute or incremental, in mm and degrees. Writes each G91
    /// word's increment exactly (units) into `units` (zeros elsewhere; an out-parameter,
    /// because 144 bytes returned in a `Result` are copied twice). A programmed value outside
    /// the travel is refused unless limit violations are allowed.
    #[allow(clippy::too_many_arguments)]
    fn advance_nominal(
        &self,
        line: &nc::Line<'_>,
        tokens: &[Token],
        axis_words: &[Option<usize>; MAX_AXES],
        optional: bool,
        state: &mut State,
        summary: &mut Summary,
        at: &dyn Fn(usize, String) -> Diagnostic,
        units: &mut [i128; MAX_AXES],
    ) -> Result<(), Diagnostic> {
        let n = self.kin.len();
        // New nominal values; `units[v]`: a G91 word's value exactly.
        *units = [0i128; MAX_AXES];
        for (v, word) in axis_words.iter().enumerate().take(n) {
            let Some(i) = *word else { continue };
            let t = &tokens[i];
            let TokenKind::Word(w) = &t.kind else {
                unreachable!()
            };
            let Value::Number { value, decimals } = w.value else {
                unreachable!()
            };
            let unit = self.unit(v, &state.modal);
            let bit = 1u32 << v;
            if state.modal.incremental {
                let u = exact::number_units(
                    value,
                    decimals,
                    &line.content[w.value_span.clone()],
                    unit,
                )
                .filter(|_| decimals <= exact::MAX_DECIMALS)
                .ok_or_else(|| {
                    at(
                        t.span.start,
                        format!(
                            "{} has {decimals} decimals; an incremental (G91) word can have at most {} (nccomp sums increments exactly)",
                            w.letter as char,
                            exact::MAX_DECIMALS
                        ),
                    )
                })?;
                if state.programmed & bit == 0 && state.unknown & bit == 0 {
                    summary.note_incremental_from_home(self.axis_name(v), line.number);
                }
                units[v] = u;
                state.nominal_exact[v] = state.nominal_exact[v].add(u);
                state.nominal[v] = exact::to_f64(state.nominal_exact[v].units());
            } else {
                state.nominal[v] = unit.to_mm(value);
                state.nominal_exact[v] = Position::Decimal {
                    value,
                    decimals,
                    unit,
                };
                // An optional block cannot make an axis known: with block delete on it
                // does not run.
                if !optional {
                    state.unknown &= !bit;
                }
            }
        }
        // Programmed values outside the travel are the program's own fault.
        for (v, word) in axis_words.iter().enumerate().take(n) {
            if state.unknown & (1 << v) != 0 {
                continue;
            }
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
                )
                .with_code(TRAVEL_LIMIT));
            }
        }
        Ok(())
    }

    /// Count a compensated block (or inserted piece) and record what the model predicts for
    /// it, at the axis values the machine is now told.
    fn record_block(
        &self,
        line: usize,
        sol: &crate::kinematics::Solution,
        state: &State,
        summary: &mut Summary,
    ) {
        let n = self.kin.len();
        let (after, beyond) = self.kin.pose_near(
            Model::Actual,
            &state.emitted[..n],
            state.modal.length,
            &sol.angles,
        );
        let (ap, ad) = after.deviation(&sol.target);
        summary.motion_blocks += 1;
        summary.record(
            line,
            sol.start_position_error,
            sol.start_direction_error,
            ap,
            ad,
            sol.singular != 0,
            beyond,
        );
    }

    fn travel(&self, var: usize) -> Option<[f64; 2]> {
        self.machine.axes[self.kin.axes()[var]].travel
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
                    text: format!("{sep}{word}").into(),
                }
            }
            None => {
                let start = tokens[neighbour].span.start;
                Edit {
                    at: start..start,
                    text: format!("{word}{sep}").into(),
                }
            }
        }
    }
}

/// The usual order of axis words in a block.
fn axis_order(letter: u8) -> usize {
    b"XYZUVWABC".iter().position(|&l| l == letter).unwrap_or(9)
}
