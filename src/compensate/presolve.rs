//! Solving ahead on a second core: the pipeline behind [`Compensator::run_stream`] with
//! `Options::threads` = 2.
//!
//! The pass must run in order (each block's modal state comes from the blocks before it),
//! but the costly part of a block, the solve, is a pure function of the nominal axis
//! values, the tool length and the held axes. A helper thread reads each chunk of lines
//! ahead of the pass, predicts those inputs with a light reading of the modal state (G90
//! moves in mm or inches, tool lengths) and solves them. The pass takes a solution only
//! when the inputs it has arrived at are bitwise the predicted ones, and solves itself
//! otherwise (G91, TCP, arcs, anything the prediction does not follow): the output is the
//! single-threaded output by construction.
//!
//! The prediction follows the tool chain a program starts in. On machines whose tool
//! chains list tools it stops at the first T word that selects another chain, and on a
//! lathe it does not start (turning and milling change with the spindle's M codes): the
//! pass then solves every block itself.

use super::gcodes::{self, GCode};
use super::{Compensator, INCH};
use crate::kinematics::{MAX_AXES, Solution};
use crate::model::AxisKind;
use crate::nc;

/// Without path splitting, the helper leaves one block in this many to the pass: per
/// block the pass then does about what the helper does (callgrind, 100,000 blocks of the
/// benchmark program on the AC trunnion: with one in seven, 1.35 G instructions on the
/// pass's thread against 1.50 G on the helper's; with one in five, 1.45 G against
/// 1.41 G).
const PASS_SHARE: usize = 5;

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

/// The helper's light reading of the program.
pub(super) struct Predictor {
    nominal: [f64; MAX_AXES],
    inch: bool,
    incremental: bool,
    /// G43.4/G43.5 active, or arcs modal: the pass does not solve as predicted.
    tcp: bool,
    arcs: bool,
    length: f64,
    tool: Option<u32>,
    words: Vec<(u8, f64)>,
    /// The pass predicted (index into `Compensator::passes`); `None`: the program has
    /// left what the prediction follows.
    pass: Option<usize>,
    /// Lines read.
    count: usize,
}

impl Predictor {
    pub(super) fn new(comp: &Compensator<'_>) -> Self {
        Predictor {
            nominal: [0.0; MAX_AXES],
            inch: false,
            incremental: false,
            tcp: false,
            arcs: false,
            length: comp.machine.tool.length,
            tool: None,
            words: Vec::new(),
            pass: comp.machine.lathe.is_none().then_some(comp.start),
            count: 0,
        }
    }

    /// Solve ahead for the lines of `chunk` (whose first line is number `before + 1`),
    /// appending to `out`.
    pub(super) fn chunk(
        &mut self,
        comp: &Compensator<'_>,
        chunk: &[u8],
        before: usize,
        out: &mut Vec<Ahead>,
    ) {
        let tools_listed = comp.machine.tool_chains.iter().any(|c| !c.tools.is_empty());
        for line in nc::lines(chunk) {
            let Some(index) = self.pass else {
                return;
            };
            let pass = &comp.passes[index];
            if !words(line.content, &mut self.words) {
                continue;
            }
            let mut moves = false;
            let mut skip = false;
            let mut g43 = false;
            let mut h = None;
            for &(letter, value) in &self.words {
                match letter {
                    b'G' => match gcodes::classify((value * 10.0).round() as i64) {
                        GCode::Motion => self.arcs = false,
                        GCode::Arc => self.arcs = true,
                        GCode::Inch => self.inch = true,
                        GCode::Millimetre => self.inch = false,
                        GCode::Absolute => self.incremental = false,
                        GCode::Incremental => self.incremental = true,
                        GCode::ToolLength => g43 = true,
                        GCode::ToolLengthOff => {
                            self.length = comp.machine.tool.length;
                            self.tcp = false;
                        }
                        GCode::ToolCentrePoint | GCode::ToolCentrePointVector => self.tcp = true,
                        GCode::Harmless | GCode::WorkOffset | GCode::CancelCycle => {}
                        _ => skip = true,
                    },
                    b'H' => h = Some(value),
                    b'T' => {
                        self.tool = Some(value as u32);
                        // Another tool chain's axes start from where it was parked.
                        if tools_listed
                            && value != 0.0
                            && comp.machine.chain_of_tool(value as u32) != Some(pass.chain)
                        {
                            self.pass = None;
                        }
                    }
                    letter => {
                        if let Some(v) = pass.var_of_letter[(letter - b'A') as usize] {
                            let linear = pass.kin.kind(v) == AxisKind::Linear;
                            self.nominal[v] = if self.inch && linear {
                                value * INCH
                            } else {
                                value
                            };
                            moves = true;
                        }
                    }
                }
            }
            if g43 {
                let number = h.map(|h| h as u32).or(self.tool);
                if let Some(l) = number.and_then(|k| comp.machine.tool.lengths.get(&k)) {
                    self.length = *l;
                }
            }
            // Without path splitting the pass has less to do per block than the helper:
            // it keeps one solve in `PASS_SHARE` to balance the two threads.
            self.count += 1;
            let share = pass.options.path.is_none() && self.count.is_multiple_of(PASS_SHARE);
            if self.pass.is_some()
                && moves
                && !skip
                && !share
                && !self.incremental
                && !self.tcp
                && !self.arcs
            {
                let q = &self.nominal[..pass.kin.len()];
                let solution = pass
                    .kin
                    .compensate(q, self.length, pass.hold, &pass.options.solve);
                out.push(Ahead {
                    line: before + line.number,
                    key: Key::new(index, q, self.length, pass.hold),
                    solution,
                });
            }
        }
    }
}

/// The words of a line as (uppercase letter, value), read lightly: false when the line
/// holds anything but plain words, spaces and comments (block delete, expressions,
/// parameters, keywords), which the prediction leaves to the pass. The values are those
/// the NC parser reads.
fn words(content: &[u8], out: &mut Vec<(u8, f64)>) -> bool {
    out.clear();
    let mut i = 0;
    let blank = |b: u8| b == b' ' || b == b'\t' || b == b'\r';
    while i < content.len() {
        let b = content[i];
        if blank(b) {
            i += 1;
        } else if b == b'(' {
            i = content[i..]
                .iter()
                .position(|&c| c == b')')
                .map_or(content.len(), |p| i + p + 1);
        } else if b == b';' {
            return true;
        } else if b.is_ascii_alphabetic() {
            i += 1;
            while i < content.len() && (content[i] == b' ' || content[i] == b'\t') {
                i += 1;
            }
            let start = i;
            if i < content.len() && (content[i] == b'+' || content[i] == b'-') {
                i += 1;
            }
            let digits = i;
            while i < content.len() && content[i].is_ascii_digit() {
                i += 1;
            }
            let whole = i - digits;
            let mut fraction = 0;
            if i < content.len() && content[i] == b'.' {
                i += 1;
                while i < content.len() && content[i].is_ascii_digit() {
                    i += 1;
                    fraction += 1;
                }
            }
            if whole + fraction == 0 {
                return false;
            }
            out.push((b.to_ascii_uppercase(), nc::to_f64(&content[start..i])));
        } else {
            return false;
        }
    }
    true
}
