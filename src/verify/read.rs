//! The gate's reading of a program: block by block through the one reader, as the control
//! runs it in one block-delete state, into the moves it makes in machine axes and the
//! places where the gate cannot follow it (gaps).
//!
//! Nothing here knows how the program was written: the original and the compensated
//! program are read alike, from their text.

use crate::diag::Diagnostic;
use crate::kinematics::MAX_AXES;
use crate::model::Machine;
use crate::nc::{self, Dialect, Token, TokenKind};
use crate::program::moves::{NominalMove, Shape, follow};
use crate::program::{BlockMotion, Modal, MoveKind, Reader};

/// Why a stretch of a program is not followed by the gate.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GapKind {
    /// Tool-centre-point blocks (the controller solves their axis values).
    Tcp,
    /// Blocks in a tilted working plane or a coordinate rotation.
    Plane,
    /// Drilling cycle blocks.
    Cycle,
    /// Turning moves on a lathe.
    Turning,
    /// A move that ends where an axis's program coordinate is not known (after G28, G53, a
    /// tool change), or whose program zero is not known.
    Unknown,
    /// G28/G30/G53 and machine moves: the axes leave the program's coordinates.
    Machine,
    /// A move the reader follows but the gate cannot (e.g. an arc in G91).
    Other,
}

impl GapKind {
    pub fn name(self) -> &'static str {
        match self {
            GapKind::Tcp => "tool-centre-point blocks",
            GapKind::Plane => "blocks in tilted working planes",
            GapKind::Cycle => "drilling cycles",
            GapKind::Turning => "turning moves",
            GapKind::Unknown => "moves from or to a place the program has not set",
            GapKind::Machine => "moves to machine positions",
            GapKind::Other => "other moves",
        }
    }
}

/// One move the control makes, in machine axes of tool chain `chain`.
#[derive(Debug, Clone, Copy)]
pub struct Step {
    pub mv: NominalMove,
    pub chain: usize,
    /// Program zero from the machine file's geometry zero (X Y Z, mm).
    pub shift: [f64; 3],
    /// Under G0 (a controller may dogleg a rapid: only its end is judged).
    pub rapid: bool,
}

/// What the gate reads of one block. (Copied once a block: the move's size is its data.)
#[derive(Debug, Clone, Copy)]
#[allow(clippy::large_enum_variant)]
pub enum Item {
    Move(Step),
    Gap { kind: GapKind, line: usize },
}

/// A program read as the control runs it with block delete `skip_optional`.
pub struct Follower<'m> {
    machine: &'m Machine,
    reader: Reader<'m>,
    modal: Modal,
    pos: crate::program::axes::Positions,
    tokens: Vec<Token>,
    motion: BlockMotion,
    skip_optional: bool,
    /// Some block started with `/`.
    pub has_optional: bool,
    /// The last item was a gap: the next move's start is not judged.
    after_gap: bool,
}

impl<'m> Follower<'m> {
    pub fn new(
        machine: &'m Machine,
        chain: usize,
        dialect: Dialect,
        src: &[u8],
        skip_optional: bool,
    ) -> Self {
        let mut modal = Modal::start(machine, chain);
        modal.for_program(dialect, src);
        // An axis the program has not set stands where the control left it: not known.
        let pos = crate::program::axes::Positions {
            unknown: !0,
            ..Default::default()
        };
        Follower {
            machine,
            reader: Reader::new(machine),
            modal,
            pos,
            tokens: Vec::new(),
            motion: BlockMotion::default(),
            skip_optional,
            has_optional: false,
            after_gap: true,
        }
    }

    /// Read one line; `Err` where the reader refuses it (the control would read something
    /// nccomp does not know).
    pub fn line(
        &mut self,
        line: &nc::Line<'_>,
        path: &str,
        src: &[u8],
    ) -> Result<Option<Item>, Diagnostic> {
        crate::program::tokenize(&self.modal, line.content, &mut self.tokens);
        if self.tokens.iter().any(|t| t.kind == TokenKind::BlockDelete) {
            self.has_optional = true;
            if self.skip_optional {
                return Ok(None);
            }
        }
        let at = |offset: usize, message: String| {
            Diagnostic::at(path, src, line.offset + offset, message)
        };
        let chain_before = self.modal.chain;
        let tcp_before = self.modal.tcp;
        let plane_before = self.modal.working_plane;
        let moving =
            self.reader
                .read(line, &self.tokens, &mut self.modal, &at, &mut self.motion)?;
        if self.modal.chain != chain_before {
            // Another chain's axes stand where this program has not said.
            self.pos.unknown = !0;
        }
        let n = self.reader.axes(self.modal.chain).len();
        let all = (1u32 << n) - 1;
        // The control's frame changed: where the axes stand in it is recomputed by the
        // control; the gate does not follow that.
        if self.modal.tcp != tcp_before || self.modal.working_plane != plane_before {
            self.pos.unknown = !0;
            return Ok(Some(self.gap(GapKind::Unknown, line.number)));
        }
        if !moving {
            // A tool-length change at rest is not a gap: the next move starts at the old
            // axis values with the new length, on the real machine as on the nominal one.
            return Ok(None);
        }
        let motion = self.motion;
        let kind = if matches!(motion.kind, MoveKind::Machine | MoveKind::Home) {
            self.pos.leave(&motion, n);
            Some(GapKind::Machine)
        } else if matches!(motion.kind, MoveKind::Cycle) {
            Some(GapKind::Cycle)
        } else if self.modal.tcp {
            Some(GapKind::Tcp)
        } else if self.modal.working_plane.is_some() || motion.kind == MoveKind::ToPlane {
            Some(GapKind::Plane)
        } else if self.modal.turning(self.machine) {
            Some(GapKind::Turning)
        } else if self.modal.shift.is_none() {
            Some(GapKind::Unknown)
        } else {
            None
        };
        if let Some(kind) = kind {
            if kind != GapKind::Machine {
                // The gate does not know where these blocks leave the axes.
                self.pos.unknown = !0;
            }
            return Ok(Some(self.gap(kind, line.number)));
        }
        let col = motion
            .axis_words
            .iter()
            .flatten()
            .map(|&i| self.tokens[i].span.start)
            .min()
            .unwrap_or(0);
        let axes = self.reader.axes(self.modal.chain);
        let known_before = self.pos.unknown & all == 0;
        match follow(
            axes,
            line,
            &self.tokens,
            &motion,
            &self.modal,
            &mut self.pos,
            &at,
            col,
        ) {
            Ok(Some((start, end, shape))) => {
                let mut start = if self.after_gap || !known_before {
                    None
                } else {
                    start
                };
                // A rollover axis (FANUC ROA) turns the shortest way to its word: the move
                // starts whole turns from where the words left it.
                if let Some(from) = start.as_mut() {
                    for (v, &axis) in self.machine.variables(self.modal.chain).iter().enumerate() {
                        if v < n && self.machine.axes[axis].rollover {
                            let d = end[v] - from[v];
                            from[v] = end[v] - (d - 360.0 * (d / 360.0).round());
                        }
                    }
                }
                self.after_gap = false;
                Ok(Some(Item::Move(Step {
                    mv: NominalMove {
                        line: line.number,
                        offset: line.offset,
                        start,
                        end,
                        shape,
                        tool_length: self.modal.length,
                        feed: None,
                    },
                    chain: self.modal.chain,
                    shift: self.modal.shift.unwrap_or([0.0; 3]),
                    rapid: matches!(shape, Shape::Rapid),
                })))
            }
            Ok(None) => Ok(Some(self.gap(GapKind::Unknown, line.number))),
            Err(_) => {
                self.pos.unknown = !0;
                Ok(Some(self.gap(GapKind::Other, line.number)))
            }
        }
    }

    fn gap(&mut self, kind: GapKind, line: usize) -> Item {
        self.after_gap = true;
        Item::Gap { kind, line }
    }

    /// The number of variables of tool chain `chain`.
    pub fn vars(&self, chain: usize) -> usize {
        self.reader.axes(chain).len()
    }
}

/// The items of program `src` in one block-delete state, one at a time (a program of
/// millions of blocks is never held as items); an `Err` item is the reader's refusal, and
/// ends the reading.
pub struct Items<'m, 'a, L: Iterator<Item = nc::Line<'a>>> {
    follower: Follower<'m>,
    lines: L,
    src: &'a [u8],
    path: &'a str,
    done: bool,
}

impl<'m, 'a, L: Iterator<Item = nc::Line<'a>>> Iterator for Items<'m, 'a, L> {
    type Item = Result<Item, Diagnostic>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.done {
            return None;
        }
        for line in self.lines.by_ref() {
            match self.follower.line(&line, self.path, self.src) {
                Ok(Some(item)) => return Some(Ok(item)),
                Ok(None) => {}
                Err(d) => {
                    self.done = true;
                    return Some(Err(d));
                }
            }
        }
        self.done = true;
        None
    }
}

impl<'m, 'a, L: Iterator<Item = nc::Line<'a>>> Items<'m, 'a, L> {
    /// Whether a block read so far started with `/`.
    pub fn has_optional(&self) -> bool {
        self.follower.has_optional
    }
}

/// The items of program `src` (named `path`) read in `dialect` from tool chain `chain`,
/// with block delete `skip_optional`.
pub fn items<'m, 'a>(
    machine: &'m Machine,
    chain: usize,
    dialect: Dialect,
    src: &'a [u8],
    path: &'a str,
    skip_optional: bool,
) -> Items<'m, 'a, impl Iterator<Item = nc::Line<'a>> + use<'a>> {
    Items {
        follower: Follower::new(machine, chain, dialect, src, skip_optional),
        lines: nc::lines(src),
        src,
        path,
        done: false,
    }
}

/// The axis values at parameter `s` of a step (its end where its start is not known).
pub fn at(step: &Step, s: f64, n: usize) -> [f64; MAX_AXES] {
    step.mv.at(s, n)
}
