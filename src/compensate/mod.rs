//! The compensation pass: stream over the blocks of a program, follow its modal state,
//! solve every pose through the error model and rewrite the axis words that change.
//!
//! Bytes that need no change are copied as they were: a word keeps its text unless its
//! compensated value rounds differently (design/model.md, "Numbers in programs"); a block
//! that omits an axis whose value must change gets that word added.

mod arc_keep;
mod arcs;
mod axes;
mod cycles;
mod holes;
mod lateral;
mod lathe;
mod pipeline;
mod plane;
mod presolve;
mod radius;
mod split;
pub(crate) mod stream;
mod summary;
mod tcp;
mod tnc_cycles;
mod writing;

pub use radius::RadiusReport;
pub use summary::{Extreme, Sample, Summary};

use crate::diag::{Diagnostic, Error};
use crate::kinematics::{Kinematics, MAX_AXES, SolveOptions};
use crate::model::{AxisKind, ErrorModel, Machine};
use crate::nc;
use crate::nc::number::decimals_for;
use crate::program::axes::{Axes, Positions};
use crate::program::exact::{self, Position, Unit};
use crate::program::{INCH, Modal, Reader};
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
    /// The language of the programs; `None`: each program's own, from its text
    /// ([`crate::nc::Dialect::detect`]).
    pub dialect: Option<crate::nc::Dialect>,
    /// Read every output back as the control reads it and hold it against the original
    /// ([`crate::verify`]) before it is kept: [`Compensator::run`] refuses a program that
    /// fails. Off only to measure what the gate costs.
    pub verify: bool,
    /// The block delete switch the output is for: `Some(true)` blocks with `/` are
    /// skipped (copied unchanged, not read), `Some(false)` they run; `None`: the output
    /// must be right in both states (the gate judges both).
    pub block_delete: Option<bool>,
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
            dialect: None,
            verify: true,
            block_delete: None,
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
    /// `Options::dialect`.
    dialect: Option<crate::nc::Dialect>,
    /// Passes for program zeros other than the machine file's geometry zero (work offsets,
    /// G52): the pass they shift (index into `passes`), the shift, the shifted pass. Made
    /// when a program first uses them.
    shifted: Vec<std::sync::OnceLock<(usize, [f64; 3], Pass<'m>)>>,
}

/// The most a straight piece that replaces an arc lies from the arc (mm).
const CHORD: f64 = 0.0005;

/// How many different program zeros one program may use.
const MAX_ZEROS: usize = 64;

/// The pass for one configuration: one tool chain, milling or turning.
#[derive(Debug, Clone)]
struct Pass<'m> {
    machine: &'m Machine,
    kin: Kinematics,
    options: Options,
    /// The chain's variables as the words drive them.
    axes: Axes,
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
    /// Program zero from the machine file's geometry zero, by variable (mm; 0 for rotary
    /// axes): the kinematics and travels are shifted by it.
    shift: [f64; MAX_AXES],
    /// Bit k: variable k is a rollover axis (FANUC ROA).
    rollover: u32,
    /// The solve's options for machine-axis words: the linear axes take up the rounding
    /// of the rotary words (under TCP or a plane the controller places the tip itself).
    axes_solve: crate::kinematics::SolveOptions,
    /// The compensation solve's options elsewhere (under TCP, in a plane, the pieces of a
    /// split move or an arc): design/model.md's residual, a tenth of the resolution. The
    /// controller's own (nominal) solves keep `options.solve`'s tighter tolerances: they
    /// stand for a controller that computes exactly.
    comp_solve: crate::kinematics::SolveOptions,
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
    /// In TCP mode and under a tilted working plane: the programmed tip words, and the tip
    /// words as written (mm; in the plane's frame under a plane).
    tip_nominal: [f64; 3],
    tip_written: [f64; 3],
    /// An active drilling cycle.
    cycle: Option<cycles::Cycle>,
    /// The last N number seen (for numbering inserted blocks).
    last_n: Option<u64>,
    /// In a TNC program: the blocks inserted so far, by which every later block number
    /// moves on (the control wants them consecutive).
    renumber: u64,
    /// Where the program's words put the axes (nominal values, and which are unknown or
    /// programmed).
    pos: Positions,
    /// What the machine was last told, mm and degrees.
    emitted: [f64; MAX_AXES],
    /// The same, exactly: the written absolute value, or the sum of the written increments.
    written: [Position; MAX_AXES],
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
    /// The nominal values before the current block, and its G91 words' increments exactly
    /// (scratch of the machine-axes mode).
    previous: [f64; MAX_AXES],
    units: [i128; MAX_AXES],
    /// Solutions worked out ahead by a helper thread.
    presolved: presolve::Presolved,
    /// Emptied texts of earlier edits, to write new ones in without allocating.
    spare_texts: Vec<Vec<u8>>,
    /// The program zero the positions above are in (see [`Modal::shift`]), and the shifted
    /// pass for it (index into [`Compensator::shifted`]; `None`: the geometry's zero).
    zero: [f64; 3],
    shifted: Option<usize>,
    /// The pieces of the move being checked for splitting, reused from block to block.
    pieces: Vec<crate::kinematics::path::Piece>,
    /// The deviation the last block left at its end: the start of the next move's path
    /// check, known without evaluating it again.
    end: Option<EndDeviation>,
    /// An arc was written as a straight move (G1) while the original stays in arc mode
    /// (G2/G3): the next arc kept as an arc must carry its own G2/G3, modal in the
    /// original or not.
    straightened: bool,
    /// A TNC pole (CC) nccomp wrote before a kept arc: which CC of the program was in
    /// force then (its `seq`) and the centre written (mm, the pole's plane): the control
    /// holds it until the program's next CC.
    pole_written: Option<(u64, [f64; 2])>,
    /// The tool length the last block that moved ran with: a feed move under another
    /// (a length changed with the axes standing) would start off the pose it needs.
    moved_length: f64,
    /// The last block that moved turned the rotary axes to a working plane (G53.1, PLANE
    /// TURN, CYCLE800) with the linear axes standing: the tip moved by the nominal turn,
    /// not the corrected one, and a feed move from there would start off the pose it needs.
    turned_at_rest: bool,
    /// The last block that moved called a cycle that moves the tool around the hole's
    /// axis: where in the plane the control leaves the tool after it (at the centre, or
    /// where its last pass ended) is the control's, so a feed move from there is refused.
    around_end: Option<usize>,
    /// A TNC cycle call one X, Y cannot serve whose motion along the axis nccomp knows:
    /// the steps to write out as L moves instead (`stream::Run::line`).
    hole_steps: Option<Vec<crate::program::tnc_cycles::HoleStep>>,
    /// In a TNC program: the F word in force (`F500`, `FQ1`), the last one programmed.
    feed: Option<String>,
    /// Tool radius compensation (RL/RR) being followed: the element waiting for the next.
    radius: Option<radius::Section>,
}

/// The deviation the real machine has at the axis values `told` from the nominal pose at
/// `nominal` (tool length `length`, the kinematics at address `kin`): a value of what it
/// is keyed by, so a block may use it only where all four are bitwise its own.
#[derive(Debug, Clone, Copy)]
struct EndDeviation {
    kin: usize,
    told: [f64; MAX_AXES],
    nominal: [f64; MAX_AXES],
    length: f64,
    position: f64,
    direction: f64,
}

impl<'m> Compensator<'m> {
    pub fn new(machine: &'m Machine, errors: &ErrorModel, options: Options) -> crate::Result<Self> {
        let start = machine.start_chain(options.tool_chain.as_deref())?;
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
            dialect: options.dialect,
            shifted: (0..MAX_ZEROS).map(|_| std::sync::OnceLock::new()).collect(),
        })
    }

    /// The pass a block goes through: its tool chain's and mode's, for its program zero.
    fn pass(&self, state: &State) -> &Pass<'m> {
        match state.shifted.and_then(|k| self.shifted[k].get()) {
            Some((base, _, pass)) if *base == state.pass => pass,
            _ => &self.passes[state.pass],
        }
    }

    /// Follow a change of program zero (a work offset, G10, G52): the positions the pass
    /// keeps move into the new zero's coordinates, and blocks go through a pass shifted
    /// by it. Refused where a block moves while the zero is not known.
    fn follow_shift(&self, state: &mut State, moves: bool) -> Result<(), String> {
        let Some(shift) = state.modal.shift else {
            if moves {
                let name = crate::model::WorkOffsets::name(&state.modal.work_offset.unwrap_or(540));
                return Err(format!(
                    "where program zero lies is not known: the machine file's [work_offsets] does not give {name} and the program has not set it (expected {name} in [work_offsets] or a G10 L2/L20 setting it before this block)"
                ));
            }
            return Ok(());
        };
        let base = &self.passes[state.pass];
        if shift != state.zero {
            // The axes stay where they are: their program coordinates change, the exact
            // ones too (a G91 word after the change travels from where the axes stand).
            for (c, letter) in [b'X', b'Y', b'Z'].into_iter().enumerate() {
                if let Some(v) = base.tip_var(letter) {
                    let d = state.zero[c] - shift[c];
                    let units = exact::from_f64(state.zero[c]) - exact::from_f64(shift[c]);
                    state.pos.nominal[v] += d;
                    state.pos.exact[v] = state.pos.exact[v].add(units);
                    state.emitted[v] += d;
                    state.written[v] = state.written[v].add(units);
                }
            }
            state.zero = shift;
        }
        if shift == [0.0; 3] {
            state.shifted = None;
            return Ok(());
        }
        if self.machine.lathe.is_some() {
            return Err("a program zero other than the machine file's geometry zero on a lathe cannot be compensated (the turning kinematics assume the geometry's zero)".into());
        }
        for (k, slot) in self.shifted.iter().enumerate() {
            match slot.get() {
                Some((p, s, _)) if *p == state.pass && *s == shift => {
                    state.shifted = Some(k);
                    return Ok(());
                }
                Some(_) => {}
                None => {
                    let _ = slot.set((state.pass, shift, base.shifted(shift)));
                    state.shifted = Some(k);
                    return Ok(());
                }
            }
        }
        Err(format!(
            "this program uses more than {MAX_ZEROS} different program zeros (work offsets and G52 shifts)"
        ))
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
        let start = out.len();
        let mut run = Run::new(self, trace);
        let dialect = self.dialect_of(path, src);
        run.program(dialect, src);
        for line in nc::lines(src) {
            if !run.line(&line, path, out) {
                break;
            }
        }
        let (mut summary, mut refused) = run.finish_all();
        if refused.is_empty()
            && let Some(d) =
                self.predicted_beyond(&summary, crate::verify::Text { name: path, src }.into())
        {
            refused.push(d);
        }
        if refused.is_empty() && self.passes[0].options.verify {
            let written = crate::verify::Text {
                name: path,
                src: &out[start..],
            };
            let original = crate::verify::Text { name: path, src };
            match self.verify(original.into(), written.into(), dialect) {
                Ok(verdict) if verdict.passed() => summary.verdict = Some(verdict),
                Ok(verdict) => refused = verdict.in_original(original.into()),
                Err(crate::Error::Input(d)) => refused = vec![*d],
                Err(crate::Error::Inputs(ds)) => refused = ds,
                Err(e) => {
                    refused = vec![Diagnostic::at(
                        path,
                        src,
                        0,
                        format!("the verification gate cannot read this program: {e}"),
                    )]
                }
            }
        }
        (summary, refused)
    }

    /// The refusal of a program whose own prediction after compensation leaves the tip
    /// further from the nominal one than the gate's end tolerance: such a program must
    /// not pass as compensated, whether or not the gate follows the block.
    pub fn predicted_beyond(
        &self,
        summary: &Summary,
        original: crate::verify::Source<'_>,
    ) -> Option<Diagnostic> {
        let options = &self.passes[0].options;
        let tolerances = crate::verify::Tolerances::new(
            self.machine,
            options.path.map(|t| (t.position, t.direction)),
        );
        let worst = summary.after_position;
        let held_linear = self
            .passes
            .iter()
            .any(|p| (0..p.kin.len()).any(|v| p.is_linear(v) && p.hold & !p.idle & (1 << v) != 0));
        if summary.zero_model || held_linear || worst.value <= tolerances.end_position {
            return None;
        }
        let mut d = [original.at_line(
            worst.line,
            format!(
                "nccomp's own prediction leaves the tool tip {:.4} mm from the nominal one after compensation here, beyond the tolerance of {:.4} mm: this block cannot be compensated to it (expected a pose the solve can reach, e.g. away from a singular direction)",
                worst.value, tolerances.end_position
            ),
        )];
        // (Without the line's text the diagnostic still names file, line and column.)
        let _ = original.fill(&mut d);
        let [d] = d;
        Some(d)
    }

    /// The block delete state outputs are for: the option's, else the machine file's.
    pub fn block_delete(&self) -> Option<bool> {
        self.passes[0]
            .options
            .block_delete
            .or(self.machine.block_delete)
    }

    /// Whether outputs are verified ([`Options::verify`]).
    pub fn verifies(&self) -> bool {
        self.passes[0].options.verify
    }

    /// Hold `written` against `original` (read in `dialect`) with the verification gate,
    /// with this compensator's machine, errors, tolerances and held axes.
    pub fn verify(
        &self,
        original: crate::verify::Source<'_>,
        written: crate::verify::Source<'_>,
        dialect: nc::Dialect,
    ) -> crate::Result<crate::verify::Verdict> {
        let options = &self.passes[0].options;
        let chains = self.passes[..self.machine.tool_chains.len()]
            .iter()
            .map(|p| p.kin.clone())
            .collect();
        let tolerances = crate::verify::Tolerances::new(
            self.machine,
            options.path.map(|t| (t.position, t.direction)),
        );
        let chains_n = self.machine.tool_chains.len();
        let turn: crate::verify::read::Turn<'_> =
            std::rc::Rc::new(move |chain, plane, from, length| {
                (chain < chains_n)
                    .then(|| self.passes[chain].plane_rotaries(plane, from, length).ok())
                    .flatten()
            });
        let gate =
            crate::verify::Gate::with_chains(self.machine, chains, tolerances, &options.hold)
                .with_turn(turn);
        gate.verify(original, written, dialect, self.start, self.block_delete())
    }

    /// The dialect program `src` of file `name` is read in (`src`: the program, or its
    /// start).
    pub fn dialect_of(&self, name: &str, src: &[u8]) -> nc::Dialect {
        self.dialect
            .unwrap_or_else(|| nc::Dialect::detect_named(name, src))
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
        let modal = Modal::start(self.machine, self.start);
        let mut state = State {
            moved_length: modal.length,
            turned_at_rest: false,
            around_end: None,
            hole_steps: None,
            feed: None,
            radius: None,
            modal,
            pass,
            parked: vec![None; self.machine.axes.len()],
            last_n: None,
            renumber: 0,
            cycle: None,
            vector_nominal: [0.0, 0.0, 1.0],
            vector_written: [0.0, 0.0, 1.0],
            tip_nominal: [0.0; 3],
            tip_written: [0.0; 3],
            pos: Positions::default(),
            emitted: [0.0; MAX_AXES],
            written: [Position::Units(0); MAX_AXES],
            decimals: [0; MAX_AXES],
            uncertain: 0,
            unsettled: 0,
            optional_line: [0; MAX_AXES],
            corrected_line: [0; MAX_AXES],
            previous: [0.0; MAX_AXES],
            units: [0; MAX_AXES],
            presolved: presolve::Presolved::default(),
            spare_texts: Vec::new(),
            pieces: Vec::new(),
            end: None,
            straightened: false,
            pole_written: None,
            zero: [0.0; 3],
            shifted: None,
        };
        for v in 0..first.kin.len() {
            state.decimals[v] = first.res_decimals(v, Unit::MM);
        }
        // An axis the program has not set stands where the operator left it: not known
        // until a word sets it (not at home).
        state.pos.unknown = ((1u32 << first.kin.len()) - 1) & !(first.spindle | first.idle);
        for &(axis, value) in &self.machine.start {
            if let Some(v) = first.kin.axes().iter().position(|&a| a == axis) {
                state.pos.unknown &= !(1 << v);
                state.pos.nominal[v] = value;
                state.emitted[v] = value;
                state.previous[v] = value;
            }
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
        let axes = Axes::of(machine, chain);
        let var_of_letter = axes.var_of_letter;
        let mut pass = Pass {
            machine,
            kin: kin.clone(),
            options: options.clone(),
            axes,
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
            shift: [0.0; MAX_AXES],
            rollover: 0,
            axes_solve: options.solve,
            comp_solve: options.solve,
        };
        pass.comp_solve = crate::kinematics::SolveOptions {
            position_tolerance: (machine.resolution.linear / 10.0)
                .max(options.solve.position_tolerance),
            angle_tolerance: (machine.resolution.rotary.to_radians() / 10.0)
                .max(options.solve.angle_tolerance),
            ..options.solve
        };
        pass.axes_solve = crate::kinematics::SolveOptions {
            rotary_rounding: Some((pass.decimals.1, machine.resolution.linear / 4.0)),
            written: Some(pass.decimals),
            ..pass.comp_solve
        };
        pass.rollover = (0..kin.len())
            .filter(|&v| machine.axes[kin.axes()[v]].rollover)
            .fold(0, |m, v| m | 1 << v);
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

    /// The path tolerance for the block being compensated: under tool radius compensation
    /// (RL/RR) half the options' (the offset's bound has the other half, see
    /// [`radius`]).
    fn path_tolerance(&self, state: &State) -> Option<crate::kinematics::path::PathTolerance> {
        self.options.path.map(|mut t| {
            if state.modal.radius_comp.is_some() || state.radius.is_some() {
                t.position /= 2.0;
            }
            t
        })
    }

    /// [`Pass::path_tolerance`], the default where the options give none.
    fn path_tolerance_or_default(&self, state: &State) -> crate::kinematics::path::PathTolerance {
        let mut t = self.options.path.unwrap_or_default();
        if state.modal.radius_comp.is_some() || state.radius.is_some() {
            t.position /= 2.0;
        }
        t
    }

    /// How far a straight piece that replaces an arc may lie from the arc (mm): half a
    /// micrometre, and never more than half the path tolerance, so that the piece's own
    /// compensated path has the other half.
    fn chord(&self) -> f64 {
        let tolerance = self.options.path.unwrap_or_default().position;
        (tolerance / 2.0).min(CHORD)
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
        self.axes.unit(var, modal)
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

    /// `from` with each rollover axis moved by whole turns to within half a turn of `to`:
    /// where the control starts a move to `to` from, turning the shortest way. `Err` with
    /// the variable of a move of exactly half a turn, whose way is the control's choice.
    fn shortest_from(
        &self,
        from: &[f64; MAX_AXES],
        to: &[f64; MAX_AXES],
    ) -> Result<[f64; MAX_AXES], usize> {
        let mut out = *from;
        if self.rollover == 0 {
            return Ok(out);
        }
        for v in (0..self.kin.len()).filter(|&v| self.rollover & (1 << v) != 0) {
            let d = to[v] - from[v];
            let wrapped = d - 360.0 * (d / 360.0).round();
            if (wrapped.abs() - 180.0).abs() < 1e-9 {
                return Err(v);
            }
            out[v] = to[v] - wrapped;
        }
        Ok(out)
    }

    /// The solve's options for a block in `state`'s modes.
    /// Whether a compensation solve fell short of its target (a pose out of reach, an
    /// axis held): its residual is above the solve's tolerance (a tenth of the
    /// resolution, design/model.md), and above a micrometre's thousandth in any case.
    fn missed(&self, sol: &crate::kinematics::Solution) -> bool {
        sol.position_residual > self.comp_solve.position_tolerance.max(1e-6)
    }

    fn solve_options(&self, state: &State) -> &crate::kinematics::SolveOptions {
        if state.modal.tcp || state.modal.working_plane.is_some() {
            &self.comp_solve
        } else {
            &self.axes_solve
        }
    }

    fn travel(&self, var: usize) -> Option<[f64; 2]> {
        let shift = self.shift[var];
        self.machine.axes[self.kin.axes()[var]]
            .travel
            .map(|[lo, hi]| [lo - shift, hi - shift])
    }

    /// The variable a linear X, Y or Z word drives, if any.
    fn tip_var(&self, letter: u8) -> Option<usize> {
        self.axes.var_of_letter[(letter - b'A') as usize].filter(|&v| self.is_linear(v))
    }

    /// This pass for a program zero `shift` (X Y Z, mm) from the geometry's.
    fn shifted(&self, shift: [f64; 3]) -> Pass<'m> {
        let mut by_var = [0.0; MAX_AXES];
        for (c, letter) in [b'X', b'Y', b'Z'].into_iter().enumerate() {
            if let Some(v) = self.tip_var(letter) {
                by_var[v] = shift[c];
            }
        }
        let mut pass = self.clone();
        pass.kin = self.kin.shifted(&by_var);
        pass.shift = by_var;
        pass
    }
}

/// The usual order of axis words in a block.
fn axis_order(letter: u8) -> usize {
    b"XYZUVWABC".iter().position(|&l| l == letter).unwrap_or(9)
}
