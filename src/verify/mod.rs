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
    /// Disagreements beyond the tolerances, located in the written program.
    pub findings: Vec<Diagnostic>,
    /// Why the program was not verified at all (a linear axis held by `--hold`: the tip
    /// cannot be put on the nominal path, and the pass reports what is left).
    pub skipped: Option<String>,
}

impl Verdict {
    pub fn passed(&self) -> bool {
        self.findings.is_empty()
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
            let kinds: Vec<String> = self
                .not_followed
                .iter()
                .map(|(k, n)| format!("{n} {}", k.name()))
                .collect();
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

/// A shifted kinematics made by the gate: (chain, shift, kinematics).
type Shifted = (usize, [f64; 3], std::rc::Rc<Kinematics>);

/// The gate for one machine and error model.
pub struct Gate<'m> {
    machine: &'m Machine,
    /// The kinematics of each tool chain (milling).
    chains: Vec<Kinematics>,
    /// Shifted kinematics made so far: (chain, shift, kinematics).
    shifted: std::cell::RefCell<Vec<Shifted>>,
    tolerances: Tolerances,
    /// Variables whose values the user holds (`--hold`), by chain.
    held: Vec<u32>,
    singular_angle: f64,
}

/// At most this many written pieces stand for one original move before the gate says
/// the written program has left the move.
const MAX_PIECES: usize = 8 * 1024;

/// After a stretch the gate does not follow, at most this many written blocks are passed
/// over before the written program must take up the original's path again.
const RESYNC: usize = 64;

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
            tolerances,
            held,
            singular_angle: SolveOptions::default().singular_angle,
        }
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
        let axes = crate::program::axes::Axes::of(self.machine, chain);
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
        original: Text<'_>,
        written: Text<'_>,
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
            let mut orig = lookahead(self.machine, start_chain, dialect, original, skip);
            let mut out = lookahead(self.machine, start_chain, dialect, written, skip);
            let state = state_words(skip, both);
            self.judge(&mut orig, &mut out, original, written, state, &mut verdict);
            // Read the original to its end: its refusals, and whether it has `/` blocks.
            while orig.take().is_some() {}
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
        Ok(verdict)
    }

    /// Hold the written items against the original's in one block-delete state (`state`:
    /// its words for messages).
    fn judge<O, W>(
        &self,
        orig: &mut Lookahead<O>,
        out: &mut Lookahead<W>,
        original: Text<'_>,
        written: Text<'_>,
        state: &str,
        verdict: &mut Verdict,
    ) where
        O: Iterator<Item = Result<Item, Diagnostic>>,
        W: Iterator<Item = Result<Item, Diagnostic>>,
    {
        let finding = |verdict: &mut Verdict, w_line: usize, message: String| {
            let offset = line_offset(written.src, w_line);
            verdict
                .findings
                .push(Diagnostic::at(written.name, written.src, offset, message));
        };
        // After a stretch the gate does not follow, the written program is taken up again
        // at the first written move that ends where the original's next move ends.
        let mut in_gap = false;
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
                                    let w_line = item_line(other).unwrap_or(last_line(written.src));
                                    finding(
                                        verdict,
                                        w_line,
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
                                        w.mv.line,
                                        format!(
                                            "this move{state} does not end where the original's move at line {} ends, as the control reads the written words (the real tool tip {:.4} mm from the nominal one)",
                                            o.mv.line,
                                            self.end_distance(&o, &w)
                                        ),
                                    );
                                    return;
                                }
                            }
                            other => {
                                let w_line = item_line(other).unwrap_or(last_line(written.src));
                                let last = pieces.last().map(|w| w.mv.line).unwrap_or(w_line);
                                finding(
                                    verdict,
                                    last,
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
                    for (w_line, text) in self.judge_move(&o, &pieces, verdict) {
                        finding(verdict, w_line, format!("{text}{state}"));
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
                    format!(
                        "the written program{state} moves after the original's last move ({}), as the control reads it",
                        original.name
                    ),
                );
                return;
            }
        }
    }

    /// The nominal pose at the end of original step `o`.
    fn nominal_end(&self, o: &Step) -> Pose {
        let kin = self.kin(o.chain, o.shift);
        kin.pose(Model::Nominal, &o.mv.end[..kin.len()], o.mv.tool_length)
            .0
    }

    fn real_at(&self, w: &Step, q: &[f64; MAX_AXES]) -> Pose {
        let kin = self.kin(w.chain, w.shift);
        kin.pose(Model::Actual, &q[..kin.len()], w.mv.tool_length).0
    }

    fn nominal_at(&self, o: &Step, q: &[f64; MAX_AXES]) -> Pose {
        let kin = self.kin(o.chain, o.shift);
        kin.pose(Model::Nominal, &q[..kin.len()], o.mv.tool_length)
            .0
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
        let target = self.nominal_end(o);
        let real = self.real_at(w, &w.mv.end);
        if (real.p - target.p).norm() > self.tolerances.end_position {
            return false;
        }
        self.rotary_as_programmed(o, w)
            || !self.direction_judged(o, &o.mv.end)
            || angle_between(&real.o, &target.o) <= self.tolerances.end_direction
    }

    /// Whether the tool direction is held at the nominal pose `q` of `o`: the machine can
    /// turn the tool about two free rotary axes there (not at a singular pose, where the
    /// contract leaves the direction about the singular axis).
    fn direction_judged(&self, o: &Step, q: &[f64; MAX_AXES]) -> bool {
        let kin = self.kin(o.chain, o.shift);
        let held = self.held[o.chain];
        let free = (0..kin.len())
            .filter(|&v| kin.kind(v) == AxisKind::Rotary && held & (1 << v) == 0)
            .count();
        if free < 2 {
            return false;
        }
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

    /// Judge the written pieces of original move `o`: the messages of what is off, with
    /// the written line each is at.
    fn judge_move(&self, o: &Step, pieces: &[Step], verdict: &mut Verdict) -> Vec<(usize, String)> {
        let mut found = Vec::new();
        let n = self.kin(o.chain, o.shift).len();
        let held = self.rotary_as_programmed(o, pieces.last().unwrap_or(o));
        let tol = self.tolerances;
        // Each piece's end on the original move: the last at its end, the others where
        // they come nearest the nominal path.
        let mut s_prev = 0.0;
        let mut ends = Vec::with_capacity(pieces.len());
        for (k, w) in pieces.iter().enumerate() {
            let real = self.real_at(w, &w.mv.end);
            let landing = if k + 1 == pieces.len() {
                let target = self.nominal_end(o);
                Landing {
                    s: 1.0,
                    position: (real.p - target.p).norm(),
                }
            } else {
                self.landing(o, &real, s_prev, n)
            };
            let direction = {
                let q = o.mv.at(landing.s, n);
                if !held && self.direction_judged(o, &q) {
                    angle_between(&real.o, &self.nominal_at(o, &q).o)
                } else {
                    0.0
                }
            };
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
            s_prev = landing.s;
        }
        // Between block ends: feed moves whose starts are known.
        let Some((path_p, path_d)) = tol.path else {
            return found;
        };
        if o.rapid || o.mv.start.is_none() {
            return found;
        }
        for (w, &(s0, s1)) in pieces.iter().zip(&ends) {
            if w.mv.start.is_none() || w.rapid {
                continue;
            }
            let (mut worst_p, mut worst_d) = (0.0_f64, 0.0_f64);
            for t in SAMPLES {
                let q_o = o.mv.at(s0 + (s1 - s0) * t, n);
                let target = self.nominal_at(o, &q_o);
                let real = self.real_at(w, &w.mv.at(t, n));
                let dp = (real.p - target.p).norm();
                worst_p = worst_p.max(dp);
                if !held && self.direction_judged(o, &q_o) {
                    worst_d = worst_d.max(angle_between(&real.o, &target.o));
                }
            }
            verdict.path_position.update(worst_p, w.mv.line, o.mv.line);
            verdict.path_direction.update(worst_d, w.mv.line, o.mv.line);
            if worst_p > path_p {
                found.push((
                    w.mv.line,
                    format!(
                        "between its ends this move strays {:.6} mm from the nominal path of the original's move at line {}, as the control interpolates the written words (tolerance {:.6} mm)",
                        worst_p, o.mv.line, path_p
                    ),
                ));
            } else if worst_d > path_d {
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
        found
    }

    /// Where on original move `o` (from fraction `from` on) the real tip `real` comes
    /// nearest its nominal path.
    fn landing(&self, o: &Step, real: &Pose, from: f64, n: usize) -> Landing {
        let dist = |s: f64| (self.nominal_at(o, &o.mv.at(s, n)).p - real.p).norm();
        // A coarse scan, then a golden-section search about the best sample.
        const COARSE: usize = 32;
        let (mut best_s, mut best) = (from, dist(from));
        for k in 1..=COARSE {
            let s = from + (1.0 - from) * k as f64 / COARSE as f64;
            let d = dist(s);
            if d < best {
                (best_s, best) = (s, d);
            }
        }
        let step = (1.0 - from) / COARSE as f64;
        let (mut a, mut b) = ((best_s - step).max(from), (best_s + step).min(1.0));
        let g = (5f64.sqrt() - 1.0) / 2.0;
        for _ in 0..60 {
            let (c, d) = (b - g * (b - a), a + g * (b - a));
            if dist(c) < dist(d) {
                b = d;
            } else {
                a = c;
            }
            if b - a < 1e-12 {
                break;
            }
        }
        let s = (a + b) / 2.0;
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

/// Fractions of a written move at which the path between its ends is judged: the
/// quarter points, as the pass's own split check.
const SAMPLES: [f64; 3] = [0.25, 0.5, 0.75];

/// One item of look-ahead over a program's items; a refusal ends the items and is kept.
struct Lookahead<I: Iterator<Item = Result<Item, Diagnostic>>> {
    items: I,
    buf: Option<Item>,
    error: Option<Diagnostic>,
}

impl<I: Iterator<Item = Result<Item, Diagnostic>>> Lookahead<I> {
    fn peek(&mut self) -> Option<&Item> {
        if self.buf.is_none() && self.error.is_none() {
            match self.items.next() {
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
fn lookahead<'m, 'a>(
    machine: &'m Machine,
    chain: usize,
    dialect: Dialect,
    text: Text<'a>,
    skip: bool,
) -> Lookahead<read::Items<'m, 'a, impl Iterator<Item = nc::Line<'a>> + use<'a>>> {
    Lookahead {
        items: read::items(machine, chain, dialect, text.src, text.name, skip),
        buf: None,
        error: None,
    }
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

fn last_line(src: &[u8]) -> usize {
    nc::lines(src).count().max(1)
}

/// The byte offset of 1-based line `line` in `src`.
fn line_offset(src: &[u8], line: usize) -> usize {
    nc::lines(src)
        .nth(line.saturating_sub(1))
        .map_or(src.len(), |l| l.offset)
}
