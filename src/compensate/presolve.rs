//! Solving ahead on a second core: the pipeline behind [`Compensator::run_stream`] with
//! `Options::threads` = 2.
//!
//! The pass must run in order (each block's modal state comes from the blocks before it),
//! but the costly part of a block, the solve, is a pure function of the nominal axis
//! values, the tool length and the held axes. A helper thread reads each chunk of lines
//! ahead of the pass with the pass's own reader (`program::Reader`), predicts those inputs
//! for G90 moves in machine axes, and solves them. The pass takes a solution only
//! when the inputs it has arrived at are bitwise the predicted ones, and solves itself
//! otherwise (G91, TCP, arcs, anything the prediction does not follow): the output is the
//! single-threaded output by construction.
//!
//! The prediction follows the tool chain a program starts in. On machines whose tool
//! chains list tools it stops at the first T word that selects another chain, and on a
//! lathe it does not start (turning and milling change with the spindle's M codes): the
//! pass then solves every block itself.

use std::cmp::Ordering;
use std::time::Duration;

use super::Compensator;
use crate::diag::Diagnostic;
use crate::kinematics::{MAX_AXES, Solution};
use crate::nc;
use crate::program::{BlockMotion, Modal, Motion, MoveKind};

/// The share of the solves the pass keeps for itself at the start: the helper does the
/// rest. [`balance`] then moves it chunk by chunk towards where neither thread waits for
/// the other: how much of a block's work only the pass can do (reading, rewriting, the
/// "after" pose, path splitting) depends on the program, the machine and the options, and
/// a fixed share tuned on one of them left the other thread idle (callgrind, 10,000
/// blocks of the benchmark program with one solve in five kept: 99.6 M instructions on the
/// pass's thread, 77.0 M on the helper's).
pub(super) const START_SHARE: f64 = 0.1;

/// The most of the solves the pass keeps, and how far one chunk moves the share.
const MOST_SHARE: f64 = 0.6;
const SHARE_STEP: f64 = 0.01;

/// The next chunk's share from this one's: up when the pass waited longer for the helper
/// than the helper for the pass (the helper is behind), down in the other case.
pub(super) fn balance(share: f64, pass_waited: Duration, helper_waited: Duration) -> f64 {
    let share = match pass_waited.cmp(&helper_waited) {
        Ordering::Greater => share + SHARE_STEP,
        Ordering::Less => share - SHARE_STEP,
        Ordering::Equal => share,
    };
    share.clamp(0.0, MOST_SHARE)
}

/// The inputs of one solve, bitwise.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Key {
    /// The pass (tool chain and mode, index into `Compensator::passes`).
    pass: usize,
    q: [u64; MAX_AXES],
    length: u64,
    hold: u32,
}

impl Key {
    fn new(pass: usize, q: &[f64], length: f64, hold: u32) -> Self {
        let mut bits = [0; MAX_AXES];
        for (b, x) in bits.iter_mut().zip(q) {
            *b = x.to_bits();
        }
        Key {
            pass,
            q: bits,
            length: length.to_bits(),
            hold,
        }
    }
}

/// A solve done ahead for a line.
#[derive(Debug, Clone)]
pub(super) struct Ahead {
    line: usize,
    key: Key,
    solution: Solution,
}

/// The solutions worked out ahead for the chunk the pass is in, in line order.
#[derive(Debug, Clone, Default)]
pub(super) struct Presolved {
    ahead: Vec<Ahead>,
    next: usize,
}

impl Presolved {
    /// Hand over the solutions of the next chunk; returns the spent list for reuse.
    pub(super) fn refill(&mut self, ahead: Vec<Ahead>) -> Vec<Ahead> {
        self.next = 0;
        std::mem::replace(&mut self.ahead, ahead)
    }

    /// The solution for `line` if it was solved ahead with these very inputs.
    pub(super) fn take(
        &mut self,
        line: usize,
        pass: usize,
        q: &[f64],
        length: f64,
        hold: u32,
    ) -> Option<Solution> {
        while self.ahead.get(self.next).is_some_and(|a| a.line < line) {
            self.next += 1;
        }
        let a = self.ahead.get(self.next).filter(|a| a.line == line)?;
        if a.key != Key::new(pass, q, length, hold) {
            return None;
        }
        self.next += 1;
        Some(a.solution)
    }
}

/// The helper's reading of the program: the same reader as the pass's, with the modal state
/// followed on its own.
pub(super) struct Predictor {
    modal: Modal,
    nominal: [f64; MAX_AXES],
    tokens: Vec<nc::Token>,
    motion: BlockMotion,
    /// The pass predicted (index into `Compensator::passes`); `None`: the program has
    /// left what the prediction follows.
    pass: Option<usize>,
    /// Solves owed to the pass: each solvable block adds the chunk's share, and the pass
    /// keeps the block that brings it to one.
    owed: f64,
}

impl Predictor {
    pub(super) fn new(comp: &Compensator<'_>) -> Self {
        Predictor {
            modal: Modal::start(comp.machine, comp.start),
            nominal: [0.0; MAX_AXES],
            tokens: Vec::new(),
            motion: BlockMotion::default(),
            pass: comp.machine.lathe.is_none().then_some(comp.start),
            owed: 0.0,
        }
    }

    /// Read program `src` (its whole text) in `dialect`.
    pub(super) fn program_with(
        &mut self,
        dialect: nc::Dialect,
        labels: &std::sync::Arc<crate::program::heidenhain::Labels>,
    ) {
        self.modal.for_program_with(dialect, labels.clone());
    }

    /// Solve ahead for the lines of `chunk` (whose first line is number `before + 1`),
    /// appending to `out`, leaving about `share` of the solves to the pass.
    pub(super) fn chunk(
        &mut self,
        comp: &Compensator<'_>,
        chunk: &[u8],
        before: usize,
        share: f64,
        out: &mut Vec<Ahead>,
    ) {
        // The pass reports refusals; here they only end what can be predicted.
        let at = |_: usize, message: String| Diagnostic {
            path: String::new(),
            line: 0,
            column: 0,
            message,
            source_line: String::new(),
            code: None,
        };
        for line in nc::lines(chunk) {
            let Some(index) = self.pass else {
                return;
            };
            let pass = &comp.passes[index];
            crate::program::tokenize(&self.modal, line.content, &mut self.tokens);
            let Ok(moves) =
                comp.reader
                    .read(&line, &self.tokens, &mut self.modal, &at, &mut self.motion)
            else {
                self.pass = None;
                return;
            };
            // Another tool chain's axes start from where it was parked.
            if self.modal.chain != pass.chain {
                self.pass = None;
                return;
            }
            let motion = &self.motion;
            if !moves {
                continue;
            }
            if motion.kind != MoveKind::Program
                || motion.optional
                || self.modal.incremental
                || self.modal.tcp
                || self.modal.working_plane.is_some()
                || self.modal.shift != Some([0.0; 3])
                || self.modal.motion != Some(Motion::Line)
            {
                continue;
            }
            let n = pass.kin.len();
            for (v, word) in motion.axis_words[..n].iter().enumerate() {
                if let Some(i) = *word
                    && let nc::TokenKind::Word(w) = &self.tokens[i].kind
                    && let nc::Value::Number { value, .. } = w.value
                {
                    self.nominal[v] = pass.unit(v, &self.modal).to_mm(value);
                }
            }
            self.owed += share;
            if self.owed >= 1.0 {
                self.owed -= 1.0;
                continue;
            }
            let q = &self.nominal[..n];
            let length = self.modal.length;
            let solution = pass.kin.compensate(q, length, pass.hold, &pass.axes_solve);
            out.push(Ahead {
                line: before + line.number,
                key: Key::new(index, q, length, pass.hold),
                solution,
            });
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_share_moves_towards_the_thread_that_waits() {
        let ms = Duration::from_millis;
        // The pass waited: the helper is behind, the pass keeps more.
        assert!(balance(START_SHARE, ms(5), ms(0)) > START_SHARE);
        // The helper waited: it takes more.
        assert!(balance(START_SHARE, ms(0), ms(5)) < START_SHARE);
        assert_eq!(balance(START_SHARE, ms(3), ms(3)), START_SHARE);
        // Never below none, never above the most.
        assert_eq!(balance(0.0, ms(0), ms(5)), 0.0);
        assert_eq!(balance(MOST_SHARE, ms(5), ms(0)), MOST_SHARE);
    }

    #[test]
    fn the_helper_leaves_the_share_of_the_solves_to_the_pass() {
        use crate::model::{error_file, machine_file};
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures");
        let machine = machine_file::load(&root.join("ac_trunnion.machine.toml")).expect("fixture");
        let errors =
            error_file::load(&root.join("ac_trunnion.errors.toml"), &machine).expect("fixture");
        let comp = Compensator::new(&machine, &errors, super::super::Options::default())
            .expect("compensator");
        let program: String = (0..100)
            .map(|i| format!("G1 X{i}.5 Y2 Z3 A-{} C{i}\n", i % 40))
            .collect();
        for (share, solved) in [(0.0, 100), (0.25, 75), (0.5, 50)] {
            let mut ahead = Vec::new();
            Predictor::new(&comp).chunk(&comp, program.as_bytes(), 0, share, &mut ahead);
            assert_eq!(ahead.len(), solved, "share {share}");
        }
    }
}
