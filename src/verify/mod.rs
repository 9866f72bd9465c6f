//! The verification gate: a compensated program read back as the control reads it, the
//! real machine taken along the control's interpolation of its words, held against the
//! nominal path of the original (design/model.md, "Every output is verified").
//!
//! The gate reads two texts and nothing else: the original and the written program, each
//! through the one reader ([`read`]), in every block-delete state the original can run
//! in. It knows nothing of how the written program was made, so it judges a program
//! another tool wrote, or a hand-edited one, the same way.
//!
//! Matching: the written moves are taken in order; each original move is matched by the
//! written moves up to the first that ends where it ends (the real machine at the written
//! end within the end tolerance of the nominal machine at the original's end). Written
//! moves before that are pieces of it: each must end on the original move's nominal path,
//! and along each the real machine must stay within the path tolerance of the nominal
//! path at the same fraction of the piece. Where the gate cannot follow a program (tool
//! centre point, tilted planes, cycles, turning, axes whose place is not known), both
//! programs must leave and re-enter what it follows at the same blocks, and what lies in
//! between is counted as not verified.

pub mod read;

use crate::diag::Diagnostic;
use crate::kinematics::{Kinematics, MAX_AXES, Model, Pose, SolveOptions, angle_between};
use crate::model::{AxisKind, ErrorModel, Machine};
use crate::nc::{self, Dialect};
use read::{GapKind, Item, Step};

/// What the gate holds a written program to.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tolerances {
    /// At block ends: tip distance (mm) and tool direction (rad).
    pub end_position: f64,
    pub end_direction: f64,
    /// Between block ends, along feed moves; `None`: the path between ends is not judged
    /// (`--tolerance off`).
    pub path: Option<(f64, f64)>,
}

impl Tolerances {
    /// The tolerances of a run with path tolerance `path` (mm, rad; `None` for `off`) on
    /// `machine`: the path tolerance (1 µm, 10 µrad when it is off) at block ends and
    /// between them, plus what the words' own rounding can add
    /// ([`Tolerances::rounding`]): the pass meets the tolerance with the values it solves,
    /// and the words that carry them are rounded to the machine's resolution.
    pub fn new(machine: &Machine, path: Option<(f64, f64)>) -> Tolerances {
        let (p, d) = path.unwrap_or((0.001, 10e-6));
        let r = Tolerances::rounding(machine);
        let ra = Tolerances::angular_rounding(machine);
        Tolerances {
            end_position: p + r,
            end_direction: d + ra,
            path: path.map(|(p, d)| (p + r, d + ra)),
        }
    }

    /// How far rounding two rotary words to the machine's resolution can turn the tool:
    /// half a step on each (rad).
    pub fn angular_rounding(machine: &Machine) -> f64 {
        0.5_f64.sqrt() * machine.resolution.rotary.to_radians()
    }

    /// How far rounding the words to the machine's resolution can move the tool tip: half
    /// a step on each of three linear axes, and the quarter step within which the linear
    /// words take up the rounding of the rotary ones (mm).
    pub fn rounding(machine: &Machine) -> f64 {
        let res = machine.resolution.linear;
        (0.75_f64.sqrt() + 0.25) * res
    }
}

/// The largest value of a measure and where: the written program's line and the
/// original's.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Worst {
    pub value: f64,
    pub written_line: usize,
    pub original_line: usize,
}

impl Worst {
    fn update(&mut self, value: f64, written_line: usize, original_line: usize) {
        if value > self.value {
            *self = Worst {
                value,
                written_line,
                original_line,
            };
        }
    }
}

/// What the gate found.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Verdict {
    /// The block-delete states judged: `false` every block runs, `true` blocks with `/`
    /// are skipped. A program without `/` is judged once.
    pub states: Vec<bool>,
    /// The original has blocks with `/`.
    pub has_optional: bool,
    /// Original moves judged, and written moves (pieces included), over all states.
    pub moves: usize,
    pub written_moves: usize,
    /// Blocks the gate does not follow, by kind (over all states).
    pub not_followed: Vec<(GapKind, usize)>,
    /// The largest deviations found: at block ends and between them.
    pub end_position: Worst,
    pub end_direction: Worst,
    pub path_position: Worst,
    pub path_direction: Worst,
    /// Disagreements beyond the tolerances, located in the written program ...
    pub findings: Vec<Diagnostic>,
    /// ... and the original's line each belongs to (0: none).
    pub original_lines: Vec<usize>,
    /// Why the program was not verified at all (a linear axis held by `--hold`: the tip
    /// cannot be put on the nominal path, and the pass reports what is left).
    pub skipped: Option<String>,
}

impl Verdict {
    pub fn passed(&self) -> bool {
        self.findings.is_empty()
    }

    /// The findings located in the original program `original` (for a run that keeps no
    /// written program to point at), each naming its written line.
    pub fn in_original(&self, original: Source<'_>) -> Vec<Diagnostic> {
        let mut found: Vec<Diagnostic> = self
            .findings
            .iter()
            .enumerate()
            .map(|(k, d)| match self.original_lines.get(k).copied().unwrap_or(0) {
                0 => d.clone(),
                line => original.at_line(
                    line,
                    format!(
                        "{} (the compensated block would be line {} of the output; nothing was written)",
                        d.message.replace(&format!("the original's move at line {line}"), "this block's move"),
                        d.line
                    ),
                ),
            })
            .collect();
        // (Without the line's text the diagnostic still names file, line and column.)
        let _ = original.fill(&mut found);
        found
    }

    /// Blocks not followed, over all kinds.
    pub fn unfollowed(&self) -> usize {
        self.not_followed.iter().map(|(_, n)| n).sum()
    }

    fn not_followed(&mut self, kind: GapKind) {
        match self.not_followed.iter_mut().find(|(k, _)| *k == kind) {
            Some((_, n)) => *n += 1,
            None => self.not_followed.push((kind, 1)),
        }
    }
}

impl std::fmt::Display for Verdict {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if let Some(why) = &self.skipped {
            return write!(f, "not verified as the control reads it: {why}");
        }
        let states = match self.states.as_slice() {
            _ if !self.has_optional => "".to_string(),
            s => format!(
                " (block delete {})",
                s.iter()
                    .map(|&on| if on { "on" } else { "off" })
                    .collect::<Vec<_>>()
                    .join(" and ")
            ),
        };
        write!(
            f,
            "verified as the control reads it{states}: {} on their nominal path (block ends within {:.3} µm, {:.2} µrad; between them within {:.3} µm, {:.2} µrad)",
            if self.moves == 1 {
                "1 move".to_string()
            } else {
                format!("{} moves", self.moves)
            },
            self.end_position.value * 1e3,
            self.end_direction.value * 1e6,
            self.path_position.value * 1e3,
            self.path_direction.value * 1e6,
        )?;
        if self.unfollowed() > 0 {
            let kinds: Vec<String> = self.not_followed.iter().map(|(k, n)| k.count(*n)).collect();
            write!(f, "; not verified: {}", kinds.join(", "))?;
        }
        Ok(())
    }
}

/// One program to verify: its name in messages and its text.
#[derive(Debug, Clone, Copy)]
pub struct Text<'a> {
    pub name: &'a str,
    pub src: &'a [u8],
}

/// Opens a program for reading from its start.
pub type Open<'a> = dyn Fn() -> std::io::Result<Box<dyn std::io::Read>> + 'a;

/// A program the gate reads: its text in memory, or read again from its start for each
/// reading (streamed in chunks: the gate then holds a chunk of it, not the program; a TNC
/// program, whose labels are looked up by name, is read once more first for its labels).
#[derive(Clone, Copy)]
pub enum Source<'a> {
    Memory(Text<'a>),
    Stream { name: &'a str, open: &'a Open<'a> },
}

impl<'a> From<Text<'a>> for Source<'a> {
    fn from(text: Text<'a>) -> Self {
        Source::Memory(text)
    }
}

impl<'a> Source<'a> {
    /// Its name in messages.
    pub fn name(&self) -> &'a str {
        match self {
            Source::Memory(t) => t.name,
            Source::Stream { name, .. } => name,
        }
    }

    /// Its first `n` bytes (or all of it, if shorter): enough to tell its dialect.
    pub fn head(&self, n: usize) -> crate::Result<Vec<u8>> {
        use std::io::Read;
        match self {
            Source::Memory(t) => Ok(t.src[..n.min(t.src.len())].to_vec()),
            Source::Stream { name, open } => {
                let mut head = Vec::new();
                open()
                    .and_then(|r| r.take(n as u64).read_to_end(&mut head))
                    .map_err(|e| read_error(name, e))?;
                Ok(head)
            }
        }
    }

    /// A diagnostic at the start of line `line` (its text filled in by [`Source::fill`]
    /// for a streamed program).
    pub fn at_line(&self, line: usize, message: String) -> Diagnostic {
        match self {
            Source::Memory(t) => Diagnostic::at(t.name, t.src, line_offset(t.src, line), message),
            Source::Stream { name, .. } => Diagnostic {
                path: name.to_string(),
                line: line.max(1),
                column: 1,
                message,
                source_line: String::new(),
                code: None,
            },
        }
    }

    /// The text of the lines of this program's diagnostics made by [`Source::at_line`]
    /// (one more reading of a streamed program).
    pub fn fill(&self, diagnostics: &mut [Diagnostic]) -> crate::Result<()> {
        let Source::Stream { name, open } = self else {
            return Ok(());
        };
        let mut wanted: Vec<usize> = diagnostics
            .iter()
            .filter(|d| d.path == *name && d.source_line.is_empty())
            .map(|d| d.line)
            .collect();
        if wanted.is_empty() {
            return Ok(());
        }
        wanted.sort_unstable();
        wanted.dedup();
        let mut found = std::collections::HashMap::new();
        let mut chunks =
            crate::compensate::stream::Chunks::new(open().map_err(|e| read_error(name, e))?);
        while let Some((chunk, before, _)) = chunks.next().map_err(|e| read_error(name, e))? {
            let last = before + nc::line_ends(chunk) + 1;
            if wanted.iter().any(|&l| l > before && l <= last) {
                for line in nc::lines(chunk) {
                    let number = before + line.number;
                    if wanted.binary_search(&number).is_ok() {
                        let mut text = String::from_utf8_lossy(line.content).into_owned();
                        if text.ends_with('\r') {
                            text.pop();
                        }
                        found.insert(number, text);
                    }
                }
            }
            if wanted.last().is_some_and(|&l| l <= last) {
                break;
            }
        }
        for d in diagnostics
            .iter_mut()
            .filter(|d| d.path == *name && d.source_line.is_empty())
        {
            if let Some(text) = found.get(&d.line) {
                d.source_line = text.clone();
            }
        }
        Ok(())
    }
}

/// A program that cannot be read.
pub(crate) fn read_error(name: &str, source: std::io::Error) -> crate::Error {
    crate::Error::Io {
        path: name.to_string(),
        source,
    }
}

/// The end poses of a written move matched to an original one, by their lines and end
/// values: ((original line, written line, original end, written end), real, nominal).
type EndKey = ((usize, usize, [f64; MAX_AXES], [f64; MAX_AXES]), Pose, Pose);

/// Kinematics made for a tool chain and program zero: (chain, shift, kinematics).
type Shifted = (usize, [f64; 3], std::rc::Rc<Kinematics>);

/// The gate for one machine and error model.
pub struct Gate<'m> {
    machine: &'m Machine,
    /// The kinematics of each tool chain (milling).
    chains: Vec<Kinematics>,
    /// Shifted kinematics made so far: (chain, shift, kinematics).
    shifted: std::cell::RefCell<Vec<Shifted>>,
    /// The variables of each tool chain as the words drive them (made once: the TCP
    /// tip is read from them at every pose).
    axes: Vec<crate::program::axes::Axes>,
    /// The last end poses evaluated ([`Gate::end_poses`]).
    last_end: std::cell::RefCell<Option<EndKey>>,
    tolerances: Tolerances,
    /// Variables whose values the user holds (`--hold`), by chain.
    held: Vec<u32>,
    singular_angle: f64,
    /// The control's turn to a working plane: with it the gate follows moves in tilted
    /// planes.
    turn: Option<read::Turn<'m>>,
}

/// At most this many written pieces stand for one original move before the gate says
/// the written program has left the move.
const MAX_PIECES: usize = 8 * 1024;

/// After a stretch the gate does not follow, at most this many written blocks are passed
/// over before the written program must take up the original's path again.
const RESYNC: usize = MAX_PIECES + 64;

/// The deviation a move was judged to leave at its end, and the axis values it ended at
/// (written and original), to start the next move's path bound from.
#[derive(Debug, Clone, Copy)]
struct EndDev {
    written: [f64; MAX_AXES],
    original: [f64; MAX_AXES],
    position: f64,
    direction: f64,
    /// The direction was measured there (or is not judged on this machine at all).
    measured: bool,
}

/// Equal to the last bit.
fn same(a: &[f64; MAX_AXES], b: &[f64; MAX_AXES]) -> bool {
    a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits())
}

/// Where a piece of an original move ends: the fraction and the deviation there.
struct Landing {
    s: f64,
    position: f64,
}

impl<'m> Gate<'m> {
    /// A gate with tolerances `tolerances`; `hold`: axes (by name or letter) the user
    /// holds at their programmed values.
    pub fn new(
        machine: &'m Machine,
        errors: &ErrorModel,
        tolerances: Tolerances,
        hold: &[String],
    ) -> crate::Result<Self> {
        let chains = (0..machine.tool_chains.len())
            .map(|chain| {
                Kinematics::new(machine, errors, chain)
                    .map_err(|e| crate::Error::Usage(e.to_string()))
            })
            .collect::<crate::Result<Vec<_>>>()?;
        Ok(Gate::with_chains(machine, chains, tolerances, hold))
    }

    /// [`Gate::new`] with the kinematics of each tool chain made already (milling, at the
    /// machine file's geometry zero).
    pub fn with_chains(
        machine: &'m Machine,
        chains: Vec<Kinematics>,
        tolerances: Tolerances,
        hold: &[String],
    ) -> Self {
        let held = chains
            .iter()
            .map(|kin| {
                kin.axes()
                    .iter()
                    .enumerate()
                    .filter(|&(_, &i)| {
                        let axis = &machine.axes[i];
                        hold.iter().any(|h| {
                            axis.name.eq_ignore_ascii_case(h)
                                || axis.word.to_string().eq_ignore_ascii_case(h)
                        })
                    })
                    .fold(0u32, |m, (v, _)| m | 1 << v)
            })
            .collect();
        Gate {
            machine,
            chains,
            shifted: std::cell::RefCell::new(Vec::new()),
            last_end: std::cell::RefCell::new(None),
            axes: (0..machine.tool_chains.len())
                .map(|c| crate::program::axes::Axes::of(machine, c))
                .collect(),
            tolerances,
            held,
            singular_angle: SolveOptions::default().singular_angle,
            turn: None,
        }
    }

    /// This gate following moves in tilted working planes, the rotary axes turned to each
    /// plane by `turn` (the controller's rule).
    pub fn with_turn(mut self, turn: read::Turn<'m>) -> Self {
        self.turn = Some(turn);
        self
    }

    /// The name of a linear axis of chain `chain` that the user holds, if any.
    fn held_linear(&self, chain: usize) -> Option<String> {
        let kin = &self.chains[chain];
        (0..kin.len())
            .find(|&v| kin.kind(v) == AxisKind::Linear && self.held[chain] & (1 << v) != 0)
            .map(|v| self.machine.axes[kin.axes()[v]].name.clone())
    }

    /// The kinematics of chain `chain` for program zero `shift`.
    fn kin(&self, chain: usize, shift: [f64; 3]) -> std::rc::Rc<Kinematics> {
        let mut cache = self.shifted.borrow_mut();
        if let Some((_, _, k)) = cache.iter().find(|(c, s, _)| *c == chain && *s == shift) {
            return k.clone();
        }
        let base = &self.chains[chain];
        let axes = &self.axes[chain];
        let mut by_var = [0.0; MAX_AXES];
        for (c, letter) in [b'X', b'Y', b'Z'].into_iter().enumerate() {
            if let Some(v) = axes.linear_of(letter) {
                by_var[v] = shift[c];
            }
        }
        let kin = std::rc::Rc::new(if shift == [0.0; 3] {
            base.clone()
        } else {
            base.shifted(&by_var[..base.len()])
        });
        if cache.len() > 64 {
            cache.clear();
        }
        cache.push((chain, shift, kin.clone()));
        kin
    }

    /// Verify `written` against `original`, both read in `dialect`. `Err` where the
    /// original cannot be read (the reader's refusals).
    pub fn verify(
        &self,
        original: Source<'_>,
        written: Source<'_>,
        dialect: Dialect,
        start_chain: usize,
        block_delete: Option<bool>,
    ) -> crate::Result<Verdict> {
        let mut verdict = Verdict::default();
        if let Some(name) = self.held_linear(start_chain) {
            verdict.skipped = Some(format!(
                "linear axis {name} is held (--hold), so the tip is not put on the nominal path; the predicted errors above are what is left"
            ));
            return Ok(verdict);
        }
        // Block delete off first; a program with `/` blocks then with it on (unless the
        // user declared the state).
        let mut both = false;
        let states: &[bool] = match block_delete {
            Some(true) => &[true],
            Some(false) => &[false],
            None => &[false, true],
        };
        for &skip in states {
            if skip && !both && block_delete.is_none() {
                break;
            }
            verdict.states.push(skip);
            let mut orig = lookahead(self, start_chain, dialect, original, skip)?;
            let mut out = lookahead(self, start_chain, dialect, written, skip)?;
            let state = state_words(skip, both);
            self.judge(&mut orig, &mut out, original, written, state, &mut verdict);
            // Read the original to its end: its refusals, and whether it has `/` blocks.
            while orig.take().is_some() {}
            for (text, side, unreachable) in [
                (original, "the original", orig.unreachable),
                (written, "the written program", out.unreachable),
            ] {
                if let Some((line, angle)) = unreachable {
                    verdict.findings.push(text.at_line(
                        line,
                        format!(
                            "{side}'s tool vector here cannot be given by the machine's rotary axes{state}: the controller's solve ends {:.4}° from it (expected a direction the machine can reach)",
                            angle.to_degrees()
                        ),
                    ));
                    verdict.original_lines.push(0);
                }
            }
            if let Some(mut d) = orig.error {
                if skip {
                    d.message = format!(
                        "with block delete on (blocks with / skipped) the control reads this block, and nccomp cannot follow it: {} (expected the switch's state given by --block-delete off or the machine file's block_delete = \"off\", or a program right in both states)",
                        d.message
                    );
                }
                return Err(crate::Error::Input(Box::new(d)));
            }
            if let Some(d) = out.error {
                verdict.findings.push(Diagnostic {
                    message: format!(
                        "the written program cannot be read back{state}: {}",
                        d.message
                    ),
                    ..d
                });
            }
            verdict.has_optional |= orig.items.has_optional();
            if !skip && orig.items.has_optional() && block_delete.is_none() {
                both = true;
                // The first state's messages named no state: they hold with block delete off.
                for d in &mut verdict.findings {
                    d.message.push_str(" (with block delete off)");
                }
            }
        }
        original.fill(&mut verdict.findings)?;
        written.fill(&mut verdict.findings)?;
        Ok(verdict)
    }

    /// Hold the written items against the original's in one block-delete state (`state`:
    /// its words for messages).
    fn judge(
        &self,
        orig: &mut Lookahead<'_, 'm, '_>,
        out: &mut Lookahead<'_, 'm, '_>,
        original: Source<'_>,
        written: Source<'_>,
        state: &str,
        verdict: &mut Verdict,
    ) {
        let finding = |verdict: &mut Verdict, w_line: usize, o_line: usize, message: String| {
            verdict.findings.push(written.at_line(w_line, message));
            verdict.original_lines.push(o_line);
        };
        // After a stretch the gate does not follow, the written program is taken up again
        // at the first written move that ends where the original's next move ends.
        let mut in_gap = false;
        let mut last_length: Option<f64> = None;
        // Where the last move judged ended, for the path bound of the next.
        let mut previous: Option<EndDev> = None;
        while let Some(item) = orig.take() {
            if verdict.findings.len() >= 20 {
                return;
            }
            match item {
                Item::Gap { kind, .. } => {
                    verdict.not_followed(kind);
                    in_gap = true;
                }
                Item::Move(o) => {
                    if in_gap {
                        in_gap = false;
                        let mut skipped = 0;
                        loop {
                            match out.peek() {
                                Some(Item::Move(w)) if self.ends_together(&o, w) => break,
                                Some(_) if skipped < RESYNC => {
                                    out.take();
                                    skipped += 1;
                                }
                                other => {
                                    let w_line = item_line(other).unwrap_or(out.items.last_line());
                                    finding(
                                        verdict,
                                        w_line,
                                        o.mv.line,
                                        format!(
                                            "the written program{state} has no move that ends where the original's move at line {} ends, as the control reads it",
                                            o.mv.line
                                        ),
                                    );
                                    return;
                                }
                            }
                        }
                    }
                    let mut pieces: Vec<Step> = Vec::new();
                    loop {
                        match out.peek() {
                            Some(Item::Move(w)) => {
                                let w = *w;
                                out.take();
                                pieces.push(w);
                                if self.ends_together(&o, &w) {
                                    break;
                                }
                                if o.mv.start.is_none() || pieces.len() > MAX_PIECES {
                                    finding(
                                        verdict,
                                        pieces[0].mv.line,
                                        o.mv.line,
                                        format!(
                                            "this move{state} does not end where the original's move at line {} ends, as the control reads the written words (the real tool tip {:.4} mm from the nominal one)",
                                            o.mv.line,
                                            self.end_distance(&o, &pieces[0])
                                        ),
                                    );
                                    return;
                                }
                            }
                            other => {
                                let w_line = item_line(other).unwrap_or(out.items.last_line());
                                // At the first written move that took it up: where it went astray.
                                let last = pieces.first().map(|w| w.mv.line).unwrap_or(w_line);
                                finding(
                                    verdict,
                                    last,
                                    o.mv.line,
                                    format!(
                                        "the written program{state} has no move that ends where the original's move at line {} ends, as the control reads it",
                                        o.mv.line
                                    ),
                                );
                                return;
                            }
                        }
                    }
                    verdict.moves += 1;
                    verdict.written_moves += pieces.len();
                    // A tool-length change at rest moves the nominal tip: the move then
                    // starts from a pose no earlier end was judged at.
                    let changed = last_length.is_some_and(|l: f64| l != o.mv.tool_length);
                    last_length = Some(o.mv.tool_length);
                    let (messages, end) = self.judge_move(&o, &pieces, changed, previous, verdict);
                    previous = Some(end);
                    for (w_line, text) in messages {
                        finding(verdict, w_line, o.mv.line, format!("{text}{state}"));
                    }
                }
            }
        }
        // What the written program does after the original's last move (unless that
        // stretch is one the gate does not follow).
        while let Some(item) = out.take() {
            if let (Item::Move(w), false) = (item, in_gap) {
                finding(
                    verdict,
                    w.mv.line,
                    0,
                    format!(
                        "the written program{state} moves after the original's last move ({}), as the control reads it",
                        original.name()
                    ),
                );
                return;
            }
        }
    }

    /// The nominal pose at the end of original step `o`.
    fn nominal_end(&self, o: &Step) -> Pose {
        self.nominal_at(o, &o.mv.end)
    }

    /// Turn a G43.5 step's tool vectors into the rotary values the controller solves for
    /// them (its nominal inverse kinematics from where it last commanded the axes, `last`),
    /// so that it is followed as a TCP move with rotary words; `last` becomes the axis
    /// values it commands at the step's end. `Err` with the angle left where a vector
    /// cannot be reached.
    fn resolve(&self, step: &mut Step, last: &mut [f64; MAX_AXES]) -> Result<(), f64> {
        let Some((v0, v1)) = step.vector.take() else {
            *last = self.commanded(step, &step.mv.end);
            return Ok(());
        };
        let kin = self.kin(step.chain, step.shift);
        let n = kin.len();
        let (chain, length) = (step.chain, step.mv.tool_length);
        let mut worst = 0.0_f64;
        let mut turn = |words: &mut [f64; MAX_AXES], v: [f64; 3], from: &[f64; MAX_AXES]| {
            // No vector given since TCP came on: the tool points where the axes stand.
            let o = if v == [0.0; 3] {
                kin.pose(Model::Nominal, &from[..n], length).0.o
            } else {
                nalgebra::Vector3::from(v)
            };
            let target = Pose {
                p: self.tip_at(chain, words),
                o,
            };
            let solution = kin.solve(
                Model::Nominal,
                &target,
                &from[..n],
                length,
                0,
                &SolveOptions::compensation(),
            );
            worst = worst.max(solution.direction_residual);
            for k in (0..n).filter(|&k| kin.kind(k) == AxisKind::Rotary) {
                words[k] = solution.q[k];
            }
            solution.q
        };
        if let Some(start) = step.mv.start.as_mut() {
            *last = turn(start, v0, last);
        }
        *last = turn(&mut step.mv.end, v1, last);
        if worst > 1e-6 { Err(worst) } else { Ok(()) }
    }

    /// The tool tip a TCP block's words `q` give (X, Y, Z in the part frame).
    fn tip_words(&self, step: &Step, q: &[f64; MAX_AXES]) -> nalgebra::Vector3<f64> {
        let words = self.tip_at(step.chain, q);
        match &step.frame {
            // In a working plane the words are the tip in the plane's frame.
            Some(plane) => plane.part(&words),
            None => words,
        }
    }

    fn tip_at(&self, chain: usize, q: &[f64; MAX_AXES]) -> nalgebra::Vector3<f64> {
        let axes = &self.axes[chain];
        let at = |l: u8| axes.linear_of(l).map_or(0.0, |v| q[v]);
        nalgebra::Vector3::new(at(b'X'), at(b'Y'), at(b'Z'))
    }

    /// The axis values the controller commands for words `q` of step `step`: the words
    /// themselves in machine axes; under TCP its nominal inverse kinematics.
    fn commanded(&self, step: &Step, q: &[f64; MAX_AXES]) -> [f64; MAX_AXES] {
        if !step.tcp {
            return *q;
        }
        let kin = self.kin(step.chain, step.shift);
        let tip = self.tip_words(step, q);
        kin.tcp_axes_with_rotaries(
            &tip,
            &q[..kin.len()],
            step.mv.tool_length,
            &SolveOptions::compensation(),
        )
        .q
    }

    /// The real machine where the control puts it for written words `q`.
    fn real_at(&self, w: &Step, q: &[f64; MAX_AXES]) -> Pose {
        let kin = self.kin(w.chain, w.shift);
        let axes = self.commanded(w, q);
        kin.pose(Model::Actual, &axes[..kin.len()], w.mv.tool_length)
            .0
    }

    /// The nominal pose original words `q` mean: the nominal machine at them; under TCP
    /// the tip they give, with the direction of their rotary values.
    fn nominal_at(&self, o: &Step, q: &[f64; MAX_AXES]) -> Pose {
        let kin = self.kin(o.chain, o.shift);
        let pose = kin
            .pose(Model::Nominal, &q[..kin.len()], o.mv.tool_length)
            .0;
        if o.tcp {
            Pose {
                p: self.tip_words(o, q),
                o: pose.o,
            }
        } else {
            pose
        }
    }

    fn end_distance(&self, o: &Step, w: &Step) -> f64 {
        (self.real_at(w, &w.mv.end).p - self.nominal_end(o).p).norm()
    }

    /// Whether a rotary axis ends written `w` at the value original `o` gives it: held
    /// there (at a travel limit, or by rounding), so the direction error about it is the
    /// one the pass reports, not a finding.
    fn rotary_as_programmed(&self, o: &Step, w: &Step) -> bool {
        let kin = self.kin(o.chain, o.shift);
        w.chain == o.chain
            && (0..kin.len()).any(|v| {
                kin.kind(v) == AxisKind::Rotary && (w.mv.end[v] - o.mv.end[v]).abs() < 1e-9
            })
    }

    /// Whether written step `w` ends where original step `o` does (tip within the end
    /// tolerance, and the direction where it is judged).
    fn ends_together(&self, o: &Step, w: &Step) -> bool {
        // On a move that turns a rotary axis half a turn or more, a written end half a
        // turn or more from the original's may give the same pose at another place of
        // the move (a piece of a move that turns past a full turn). (Elsewhere values a
        // turn apart are the same place: the controller's turn to a plane may pick either.)
        let kin = self.kin(o.chain, o.shift);
        if w.chain == o.chain
            && let Some(start) = o.mv.start
            && (0..kin.len()).any(|v| {
                kin.kind(v) == AxisKind::Rotary
                    && (o.mv.end[v] - start[v]).abs() >= 180.0
                    && (w.mv.end[v] - o.mv.end[v]).abs() >= 180.0
            })
        {
            return false;
        }
        let (real, target) = self.end_poses(o, w);
        if (real.p - target.p).norm() > self.tolerances.end_position {
            return false;
        }
        // (The singular-pose test only where the angle would fail: it costs a pose.)
        angle_between(&real.o, &target.o) <= self.tolerances.end_direction
            || self.rotary_as_programmed(o, w)
            || !self.direction_judged(o, &o.mv.end)
    }

    /// The real pose at written `w`'s end and the nominal one at original `o`'s end: the
    /// matching and the judging of a move's end take the same two poses, evaluated once.
    fn end_poses(&self, o: &Step, w: &Step) -> (Pose, Pose) {
        let key = (o.mv.line, w.mv.line, o.mv.end, w.mv.end);
        if let Some((k, real, target)) = *self.last_end.borrow()
            && k.0 == key.0
            && k.1 == key.1
            && same(&k.2, &key.2)
            && same(&k.3, &key.3)
        {
            return (real, target);
        }
        let (real, target) = (self.real_at(w, &w.mv.end), self.nominal_end(o));
        *self.last_end.borrow_mut() = Some((key, real, target));
        (real, target)
    }

    /// Whether the tool direction is held at the nominal pose `q` of `o`: the machine can
    /// turn the tool about two free rotary axes there (not at a singular pose, where the
    /// contract leaves the direction about the singular axis).
    fn direction_judged(&self, o: &Step, q: &[f64; MAX_AXES]) -> bool {
        if self.free_rotaries(o) < 2 {
            return false;
        }
        let kin = self.kin(o.chain, o.shift);
        let n = kin.len();
        let mut dirs = [nalgebra::Vector3::zeros(); MAX_AXES];
        let angles = kin.angles(&q[..n]);
        let (pose, _) = kin.axes_at(
            Model::Nominal,
            &q[..n],
            o.mv.tool_length,
            &angles,
            &mut dirs,
        );
        kin.singular_axes(&pose, &dirs, self.singular_angle) == 0
    }

    /// The rotary axes of `o`'s chain that the user does not hold.
    fn free_rotaries(&self, o: &Step) -> usize {
        if o.frame.is_some() {
            // The controller holds the rotary axes where it turned them to the plane.
            return 0;
        }
        let kin = self.kin(o.chain, o.shift);
        let held = self.held[o.chain];
        (0..kin.len())
            .filter(|&v| kin.kind(v) == AxisKind::Rotary && held & (1 << v) == 0)
            .count()
    }

    /// Judge the written pieces of original move `o`: the messages of what is off, with
    /// the written line each is at.
    fn judge_move(
        &self,
        o: &Step,
        pieces: &[Step],
        check_start: bool,
        before: Option<EndDev>,
        verdict: &mut Verdict,
    ) -> (Vec<(usize, String)>, EndDev) {
        let mut found = Vec::new();
        let mut end_dev = EndDev {
            written: [0.0; MAX_AXES],
            original: o.mv.end,
            position: 0.0,
            direction: 0.0,
            measured: false,
        };
        // (A rapid is in the air: where it starts does not matter.)
        if check_start
            && !o.rapid
            && let (Some(os), Some(w)) = (o.mv.start, pieces.first())
            && let Some(ws) = w.mv.start
        {
            let off = (self.real_at(w, &ws).p - self.nominal_at(o, &os).p).norm();
            if off > self.tolerances.end_position {
                found.push((
                    w.mv.line,
                    format!(
                        "this move starts {off:.4} mm off the nominal path of the original's move at line {}: the tool length changed while the axes stood, and the real tool is not where the nominal one now is (expected a positioning move after the change; tolerance {:.6} mm)",
                        o.mv.line, self.tolerances.end_position
                    ),
                ));
            }
        }
        let n = self.kin(o.chain, o.shift).len();
        let held = self.rotary_as_programmed(o, pieces.last().unwrap_or(o));
        let tol = self.tolerances;
        // Each piece's end on the original move: the last at its end, the others where
        // they come nearest the nominal path.
        let mut s_prev = 0.0;
        let mut ends = Vec::with_capacity(pieces.len());
        let mut end_devs: Vec<f64> = Vec::with_capacity(pieces.len());
        for (k, w) in pieces.iter().enumerate() {
            let last_piece = k + 1 == pieces.len();
            let (real, end_target) = if last_piece {
                let (real, target) = self.end_poses(o, w);
                (real, Some(target))
            } else {
                (self.real_at(w, &w.mv.end), None)
            };
            let landing = if let Some(target) = end_target {
                Landing {
                    s: 1.0,
                    position: (real.p - target.p).norm(),
                }
            } else {
                self.landing(o, &real, &w.mv.end, s_prev, n)
            };
            // A split move's inner ends may swing a rotary axis across the singular cone
            // (the pass holds it there by design): the direction is judged at the move's
            // end, and between ends of a move written whole.
            let last = k + 1 == pieces.len();
            let mut measured = self.free_rotaries(o) < 2;
            let direction = if last && !held && !measured {
                let q = o.mv.at(landing.s, n);
                let angle = match end_target {
                    Some(target) if landing.s == 1.0 => angle_between(&real.o, &target.o),
                    _ => angle_between(&real.o, &self.nominal_at(o, &q).o),
                };
                // Within the tolerance it is what it is; beyond it, it counts only where
                // the direction is held (the singular-pose test costs a pose).
                if angle <= tol.end_direction || self.direction_judged(o, &q) {
                    measured = true;
                    angle
                } else {
                    0.0
                }
            } else {
                0.0
            };
            if last {
                end_dev = EndDev {
                    written: w.mv.end,
                    original: o.mv.end,
                    position: landing.position,
                    direction,
                    measured,
                };
            }
            // Where the direction is not held (a singular pose, an axis as programmed),
            // the written words may leave it as uncompensated words would, and no worse.
            if last && direction == 0.0 && self.free_rotaries(o) >= 2 {
                let target = self.nominal_end(o).o;
                let left = angle_between(&real.o, &target);
                let before = angle_between(&self.real_at(o, &o.mv.end).o, &target);
                if left > before + tol.end_direction {
                    found.push((
                        w.mv.line,
                        format!(
                            "this block ends with the tool {:.2} µrad off the nominal direction of the original's move at line {}, more than the original's words leave it ({:.2} µrad), as the control reads the written words",
                            left * 1e6,
                            o.mv.line,
                            before * 1e6
                        ),
                    ));
                }
            }
            verdict
                .end_position
                .update(landing.position, w.mv.line, o.mv.line);
            verdict
                .end_direction
                .update(direction, w.mv.line, o.mv.line);
            if landing.position > tol.end_position {
                found.push((
                    w.mv.line,
                    format!(
                        "this block ends {:.4} mm off the nominal path of the original's move at line {}, as the control reads the written words (tolerance {:.6} mm)",
                        landing.position, o.mv.line, tol.end_position
                    ),
                ));
            } else if direction > tol.end_direction {
                found.push((
                    w.mv.line,
                    format!(
                        "this block ends with the tool {:.2} µrad off the nominal direction of the original's move at line {}, as the control reads the written words (tolerance {:.2} µrad)",
                        direction * 1e6,
                        o.mv.line,
                        tol.end_direction * 1e6
                    ),
                ));
            }
            ends.push((s_prev, landing.s));
            end_devs.push(landing.position);
            s_prev = landing.s;
        }
        // Between block ends: feed moves whose starts are known.
        let Some((path_p, path_d)) = tol.path else {
            return (found, end_dev);
        };
        if o.rapid || o.mv.start.is_none() {
            return (found, end_dev);
        }
        for (k, (w, &(s0, s1))) in pieces.iter().zip(&ends).enumerate() {
            if w.mv.start.is_none() || w.rapid {
                continue;
            }
            // A straight move written whole, from where the last one ended: the bound on
            // how far it can stray beyond its ends (the pass's, `Kinematics::path_sag`)
            // clears it without a pose where it can.
            if pieces.len() == 1
                && let Some(start) = before.filter(|b| {
                    w.mv.start.is_some_and(|ws| same(&ws, &b.written))
                        && o.mv.start.is_some_and(|os| same(&os, &b.original))
                })
                && self.cleared(o, w, &start, &end_dev, (path_p, path_d))
            {
                continue;
            }
            let (mut worst_p, mut worst_d) = (0.0_f64, 0.0_f64);
            for t in SAMPLES {
                let real = self.real_at(w, &w.mv.at(t, n));
                // The nominal path's point nearest the real tip, from the same fraction
                // by one step along the path's tangent: two parametrisations that differ
                // along the way are timing, not path (the pass's arc check reads it so).
                let guess = s0 + (s1 - s0) * t;
                let at_guess = self.nominal_at(o, &o.mv.at(guess, n));
                let h = 1e-6;
                let ahead = self.nominal_at(o, &o.mv.at(guess + h, n));
                let tangent = (ahead.p - at_guess.p) / h;
                let along = tangent.norm_squared();
                let s_near = if along > 1e-18 {
                    (guess - (at_guess.p - real.p).dot(&tangent) / along)
                        .clamp(s0.min(s1) - (s1 - s0).abs(), s0.max(s1) + (s1 - s0).abs())
                        .clamp(0.0, 1.0)
                } else {
                    guess
                };
                let q_o = o.mv.at(s_near, n);
                let target = self.nominal_at(o, &q_o);
                let dp = (real.p - target.p).norm().min((real.p - at_guess.p).norm());
                worst_p = worst_p.max(dp);
                if !held && pieces.len() == 1 && self.free_rotaries(o) >= 2 {
                    // Either reading, as for the position; the singular-pose test only
                    // where the angle would fail.
                    let angle =
                        angle_between(&real.o, &target.o).min(angle_between(&real.o, &at_guess.o));
                    if angle <= path_d || self.direction_judged(o, &q_o) {
                        worst_d = worst_d.max(angle);
                    }
                }
            }
            verdict.path_position.update(worst_p, w.mv.line, o.mv.line);
            verdict.path_direction.update(worst_d, w.mv.line, o.mv.line);
            // What the piece's ends leave (each judged above) is the floor under its
            // path: halving cannot take the path below it. The path may stray the
            // tolerance beyond it (as the pass's split check holds it).
            let floor = |this: &Self| {
                let start = if k == 0 {
                    let (Some(ws), Some(os)) = (w.mv.start, o.mv.start) else {
                        return 0.0;
                    };
                    (this.real_at(w, &ws).p - this.nominal_at(o, &os).p).norm()
                } else {
                    end_devs[k - 1]
                };
                start.max(end_devs[k]) - Tolerances::rounding(this.machine)
            };
            // The same for the direction: what the piece's ends leave (a rotary axis
            // held at a travel limit or at a singular pose, where the pass reports it).
            let direction_floor = |this: &Self| {
                let (Some(ws), Some(os)) = (w.mv.start, o.mv.start) else {
                    return 0.0;
                };
                let os = if k == 0 { os } else { o.mv.at(s0, n) };
                let start = angle_between(&this.real_at(w, &ws).o, &this.nominal_at(o, &os).o);
                let end = angle_between(
                    &this.real_at(w, &w.mv.end).o,
                    &this.nominal_at(o, &o.mv.at(s1, n)).o,
                );
                start.max(end)
            };
            if worst_p > path_p && worst_p > path_p + floor(self).max(0.0) {
                found.push((
                    w.mv.line,
                    format!(
                        "between its ends this move strays {:.6} mm from the nominal path of the original's move at line {}, as the control interpolates the written words (tolerance {:.6} mm)",
                        worst_p, o.mv.line, path_p
                    ),
                ));
            } else if worst_d > path_d && worst_d > path_d + direction_floor(self) {
                found.push((
                    w.mv.line,
                    format!(
                        "between its ends this move turns the tool {:.2} µrad from the nominal direction of the original's move at line {}, as the control interpolates the written words (tolerance {:.2} µrad)",
                        worst_d * 1e6,
                        o.mv.line,
                        path_d * 1e6
                    ),
                ));
            }
        }
        (found, end_dev)
    }

    /// Whether the bound on a straight move's deviation between its ends clears it: the
    /// move in machine axes, with the original's kinematics and tool.
    fn cleared(&self, o: &Step, w: &Step, start: &EndDev, end: &EndDev, tol: (f64, f64)) -> bool {
        let straight = |s: &Step| !matches!(s.mv.shape, crate::program::moves::Shape::Arc(_));
        if o.tcp
            || w.tcp
            || !straight(o)
            || !straight(w)
            || o.chain != w.chain
            || o.shift != w.shift
            || o.mv.tool_length.to_bits() != w.mv.tool_length.to_bits()
        {
            return false;
        }
        let (Some(os), Some(ws)) = (o.mv.start, w.mv.start) else {
            return false;
        };
        if !(start.measured && end.measured) {
            return false;
        }
        let kin = self.kin(o.chain, o.shift);
        let n = kin.len();
        let Some(sag) = kin.path_sag(
            (&os[..n], &o.mv.end[..n]),
            (&ws[..n], &w.mv.end[..n]),
            o.mv.tool_length,
        ) else {
            return false;
        };
        let position = start.position.max(end.position) + sag.position + 1e-9;
        let chord = start.direction.max(end.direction) + sag.direction;
        chord < 0.1 && position <= tol.0 && chord * 1.001 + 1e-12 <= tol.1
    }

    /// Where on original move `o` (from fraction `from` on) the real tip `real` of written
    /// words `words` comes nearest its nominal path: searched about the fraction whose
    /// words are nearest the written ones (a piece's words are the original's at its
    /// fraction plus a correction), and over the whole rest of the move.
    fn landing(
        &self,
        o: &Step,
        real: &Pose,
        words: &[f64; MAX_AXES],
        from: f64,
        n: usize,
    ) -> Landing {
        let dist = |s: f64| (self.nominal_at(o, &o.mv.at(s, n)).p - real.p).norm();
        let near = projection(o, words, n).clamp(from, 1.0);
        let mut best = self.search(&dist, near, (near - 0.02).max(from), (near + 0.02).min(1.0));
        // Where the words' own place on the move lands, it is the landing: a rotary axis
        // turning past a full turn passes the same pose twice, and the other one is not
        // where this piece is.
        if best.position <= self.tolerances.end_position {
            return best;
        }
        let wide = self.search(&dist, from, from, 1.0);
        if wide.position < best.position {
            best = wide;
        }
        best
    }

    /// The fraction in `[a, b]` where `dist` is least: a scan of 32 samples (and `guess`),
    /// then a golden-section search about the best.
    fn search(&self, dist: &dyn Fn(f64) -> f64, guess: f64, a: f64, b: f64) -> Landing {
        const COARSE: usize = 32;
        let (mut best_s, mut best) = (guess, dist(guess));
        for k in 0..=COARSE {
            let s = a + (b - a) * k as f64 / COARSE as f64;
            let d = dist(s);
            if d < best {
                (best_s, best) = (s, d);
            }
        }
        let step = (b - a) / COARSE as f64;
        let (mut lo, mut hi) = ((best_s - step).max(a), (best_s + step).min(b));
        let g = (5f64.sqrt() - 1.0) / 2.0;
        for _ in 0..80 {
            let (c, d) = (hi - g * (hi - lo), lo + g * (hi - lo));
            if dist(c) < dist(d) {
                hi = d;
            } else {
                lo = c;
            }
            if hi - lo < 1e-13 {
                break;
            }
        }
        let s = (lo + hi) / 2.0;
        let d = dist(s);
        if d < best {
            (best_s, best) = (s, d);
        }
        Landing {
            s: best_s,
            position: best,
        }
    }
}

/// The fraction of move `o` whose words are nearest `words`: along the move's straight
/// line in axis space, or by the angle about an arc's centre.
fn projection(o: &Step, words: &[f64; MAX_AXES], n: usize) -> f64 {
    let Some(start) = o.mv.start else {
        return 1.0;
    };
    if let crate::program::moves::Shape::Arc(arc) = &o.mv.shape
        && arc.sweep != 0.0
    {
        let th = (words[arc.vb] - arc.centre.1).atan2(words[arc.va] - arc.centre.0);
        let turned = (th - arc.th0) * arc.sweep.signum();
        let turned = turned.rem_euclid(std::f64::consts::TAU);
        return (turned / arc.sweep.abs()).clamp(0.0, 1.0);
    }
    let (mut num, mut den) = (0.0, 0.0);
    for v in 0..n {
        let d = o.mv.end[v] - start[v];
        num += (words[v] - start[v]) * d;
        den += d * d;
    }
    if den > 0.0 {
        (num / den).clamp(0.0, 1.0)
    } else {
        1.0
    }
}

/// Fractions of a written move at which the path between its ends is judged: the
/// quarter points, as the pass's own split check.
const SAMPLES: [f64; 3] = [0.25, 0.5, 0.75];

/// One item of look-ahead over a program's items, each G43.5 move turned into rotary
/// values as the controller turns it; a refusal ends the items and is kept.
struct Lookahead<'g, 'm, 'a> {
    gate: &'g Gate<'m>,
    items: read::Items<'m, 'a>,
    buf: Option<Item>,
    error: Option<Diagnostic>,
    /// The axis values the controller last commanded (where its solve starts).
    last: [f64; MAX_AXES],
    /// The first block whose tool vector the machine cannot give: line, angle left (rad).
    unreachable: Option<(usize, f64)>,
}

impl Lookahead<'_, '_, '_> {
    fn peek(&mut self) -> Option<&Item> {
        if self.buf.is_none() && self.error.is_none() {
            match self.items.next() {
                Some(Ok(Item::Move(mut step))) => {
                    if let Err(angle) = self.gate.resolve(&mut step, &mut self.last) {
                        self.unreachable.get_or_insert((step.mv.line, angle));
                    }
                    self.buf = Some(Item::Move(step));
                }
                Some(Ok(item)) => self.buf = Some(item),
                Some(Err(d)) => self.error = Some(d),
                None => {}
            }
        }
        self.buf.as_ref()
    }

    fn take(&mut self) -> Option<Item> {
        self.peek();
        self.buf.take()
    }
}

/// The items of `text` with one item of look-ahead.
fn lookahead<'g, 'm, 'a>(
    gate: &'g Gate<'m>,
    chain: usize,
    dialect: Dialect,
    source: Source<'a>,
    skip: bool,
) -> crate::Result<Lookahead<'g, 'm, 'a>> {
    Ok(Lookahead {
        gate,
        items: read::items(
            gate.machine,
            chain,
            dialect,
            source,
            skip,
            gate.turn.clone(),
        )?,
        buf: None,
        error: None,
        last: [0.0; MAX_AXES],
        unreachable: None,
    })
}

fn state_words(skip: bool, both: bool) -> &'static str {
    match (both, skip) {
        (false, _) => "",
        (true, false) => " with block delete off",
        (true, true) => " with block delete on",
    }
}

fn item_line(item: Option<&Item>) -> Option<usize> {
    match item? {
        Item::Move(s) => Some(s.mv.line),
        Item::Gap { line, .. } => Some(*line),
    }
}

/// The byte offset of 1-based line `line` in `src`.
fn line_offset(src: &[u8], line: usize) -> usize {
    nc::lines(src)
        .nth(line.saturating_sub(1))
        .map_or(src.len(), |l| l.offset)
}
