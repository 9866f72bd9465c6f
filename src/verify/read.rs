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
use crate::program::heidenhain::{LabelScan, Labels};
use crate::program::moves::{NominalMove, Shape, follow};
use crate::program::{BlockMotion, Modal, MoveKind, Reader, WorkingPlane};
use std::sync::Arc;

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
    /// What a block of this kind is, plural.
    pub fn name(self) -> &'static str {
        self.names().1
    }

    /// `n` blocks of this kind, in words.
    pub fn count(self, n: usize) -> String {
        let (one, many) = self.names();
        if n == 1 {
            format!("1 {one}")
        } else {
            format!("{n} {many}")
        }
    }

    fn names(self) -> (&'static str, &'static str) {
        match self {
            GapKind::Tcp => ("tool-centre-point block", "tool-centre-point blocks"),
            GapKind::Plane => (
                "block in a tilted working plane",
                "blocks in tilted working planes",
            ),
            GapKind::Cycle => ("drilling cycle", "drilling cycles"),
            GapKind::Turning => ("turning move", "turning moves"),
            GapKind::Unknown => (
                "move from or to a place the program has not set",
                "moves from or to a place the program has not set",
            ),
            GapKind::Machine => ("move to machine positions", "moves to machine positions"),
            GapKind::Other => ("other move", "other moves"),
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
    /// Under tool-centre-point control with rotary words: the linear values are the tool
    /// tip in the part frame, and the controller solves the linear axes (nominal inverse
    /// kinematics) for every point of the tip and rotary values interpolated linearly.
    pub tcp: bool,
    /// Under G43.5 (tool vectors): the direction words before and after the block
    /// (normalised); the controller turns each into rotary values.
    pub vector: Option<([f64; 3], [f64; 3])>,
    /// In a working plane (`tcp` too): the linear values are the tip in this frame (the
    /// words), the rotary axes stand where the control turned them or the program left
    /// them; the controller holds the rotary axes, so the tool direction is not judged.
    pub frame: Option<WorkingPlane>,
}

/// The control's turn of the rotary axes to a working plane (G53.1, PLANE … TURN, the
/// positioning block after STAY, CYCLE800): tool chain, plane, axis values the turn
/// starts from, tool length → the rotary values (the other axes as given); `None` where
/// the nominal machine has no turn.
pub type Turn<'m> = std::rc::Rc<
    dyn Fn(usize, &WorkingPlane, &[f64; MAX_AXES], f64) -> Option<[f64; MAX_AXES]> + 'm,
>;

/// What the gate reads of one block. (Items are made and used one at a time: boxing the
/// move would allocate per block for nothing.)
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, Copy)]
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
    /// The tool vector in force under G43.5 (normalised; zero: none given since TCP
    /// came on, the direction the axes stand at).
    vector: [f64; 3],
    /// The control's turn to a working plane, where the gate follows planes.
    turn: Option<Turn<'m>>,
}

impl<'m> Follower<'m> {
    pub fn new(
        machine: &'m Machine,
        chain: usize,
        dialect: Dialect,
        labels: Arc<Labels>,
        skip_optional: bool,
        turn: Option<Turn<'m>>,
    ) -> Self {
        let mut modal = Modal::start(machine, chain);
        modal.for_program_with(dialect, labels);
        // The gate runs the bodies of label calls that move itself, as the control does.
        if let Some(tnc) = modal.tnc.as_mut() {
            tnc.follow_calls = true;
        }
        // An axis the program has not set stands where the control left it: not known,
        // unless the machine file gives the set-up's start position.
        let mut pos = crate::program::axes::Positions {
            unknown: (1u32 << machine.variables(chain).len()) - 1,
            ..Default::default()
        };
        for (v, &axis) in machine.variables(chain).iter().enumerate() {
            if let Some(&(_, value)) = machine.start.iter().find(|(a, _)| *a == axis) {
                pos.unknown &= !(1 << v);
                pos.nominal[v] = value;
            }
        }
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
            vector: [0.0; 3],
            turn,
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
            // With block delete off the control runs the block as any other: its axis
            // words settle the axes they set (the pass's reader keeps them unsettled,
            // as the block may not run).
            self.tokens.retain(|t| t.kind != TokenKind::BlockDelete);
        }
        let at = |offset: usize, message: String| {
            Diagnostic::at(path, src, line.offset + offset, message)
        };
        let chain_before = self.modal.chain;
        let shift_before = self.modal.shift;
        let every = |f: &Self| (1u32 << f.vars(f.modal.chain)) - 1;
        let tcp_before = self.modal.tcp;
        let vector_before_read = self.modal.tcp_vector;
        let plane_before = self.modal.working_plane;
        let moving =
            self.reader
                .read(line, &self.tokens, &mut self.modal, &at, &mut self.motion)?;
        if self.modal.chain != chain_before {
            // Another chain's axes stand where this program has not said.
            self.pos.unknown = every(self);
        }
        let n = self.reader.axes(self.modal.chain).len();
        let all = (1u32 << n) - 1;
        if let (Some(old), Some(new)) = (shift_before, self.modal.shift)
            && old != new
        {
            // A new program zero: the axes stay where they are, their program
            // coordinates move (and an increment after it travels from there).
            let axes = self.reader.axes(self.modal.chain);
            for (c, letter) in [b'X', b'Y', b'Z'].into_iter().enumerate() {
                if let Some(v) = axes.linear_of(letter) {
                    let units = crate::program::exact::from_f64(old[c])
                        - crate::program::exact::from_f64(new[c]);
                    self.pos.nominal[v] += old[c] - new[c];
                    self.pos.exact[v] = self.pos.exact[v].add(units);
                }
            }
        }
        // The control's frame changed: where the axes stand in it is recomputed by the
        // control; the gate does not follow that.
        if self.modal.tcp != tcp_before {
            // Until a block gives one, the tool vector is where the axes point it.
            self.vector = [0.0; 3];
            // The linear words change meaning (tip or axes); the rotary axes stand where
            // their words put them (under G43.5 the controller's solve did: not followed).
            let kept = if vector_before_read || self.modal.tcp_vector {
                0
            } else {
                self.rotary_bits() & !self.pos.unknown
            };
            self.pos.unknown = every(self) & !kept;
            return Ok(Some(self.gap(GapKind::Unknown, line.number)));
        }
        if moving && self.motion.kind == MoveKind::ToPlane {
            if self.modal.working_plane.is_none() {
                // No plane to turn to (CYCLE800() swivels nothing): only the axes it
                // retracts to machine positions move.
                if self.motion.homed == 0 {
                    return Ok(None);
                }
                self.pos.unknown |= self.motion.homed;
                return Ok(Some(self.gap(GapKind::Machine, line.number)));
            }
            return Ok(Some(self.turn_to_plane(line.number)));
        }
        if self.modal.working_plane != plane_before {
            // The words are read in another frame from here: the linear axes' place in it
            // is not known until a block gives it; the rotary axes stand where they were.
            self.vector = [0.0; 3];
            self.pos.unknown |= every(self) & !self.rotary_bits();
            if !moving {
                self.after_gap = true;
                return Ok(None);
            }
            return Ok(Some(self.gap(GapKind::Plane, line.number)));
        }
        if !moving {
            // A tool-length change at rest is not a gap: the next move starts at the old
            // axis values with the new length, on the real machine as on the nominal one.
            return Ok(None);
        }
        let motion = self.motion;
        let kind = if matches!(motion.kind, MoveKind::Machine | MoveKind::Home) {
            self.pos.leave(&motion, n);
            self.rotary_machine_positions(&motion);
            Some(GapKind::Machine)
        } else if matches!(motion.kind, MoveKind::Cycle) {
            Some(GapKind::Cycle)
        } else if self.modal.tcp
            && (self.modal.working_plane.is_some()
                || self.modal.shift != Some([0.0; 3])
                || !matches!(motion.kind, MoveKind::Program | MoveKind::Arc { .. })
                || (self.modal.tcp_vector && !matches!(motion.kind, MoveKind::Program)))
        {
            // Planes and shifted zeros under TCP, and arcs under G43.5, are not followed.
            // (An arc under G43.4 is: the control takes the tip along the arc, the rotary
            // axes in proportion, as an arc's other axes.)
            Some(GapKind::Tcp)
        } else if self.modal.working_plane.is_some() && !self.follows_plane(&motion) {
            Some(GapKind::Plane)
        } else if self.modal.turning(self.machine) {
            Some(GapKind::Turning)
        } else if self.modal.shift.is_none() {
            Some(GapKind::Unknown)
        } else {
            None
        };
        if let Some(kind) = kind {
            if matches!(kind, GapKind::Plane | GapKind::Cycle) && !self.modal.tcp {
                // The gate does not know where these blocks leave the linear axes; the
                // rotary axes stand (a cycle, or a move in a plane, does not turn them).
                self.pos.unknown |= every(self) & !self.rotary_bits();
            } else if kind != GapKind::Machine {
                // The gate does not know where these blocks leave the axes.
                self.pos.unknown = every(self);
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
        let vector_before = self.vector;
        if self.modal.tcp && self.modal.tcp_vector {
            // The rotary axes follow the vector: the controller knows where they go.
            for v in 0..n {
                if !axes.is_linear(v) {
                    self.pos.unknown &= !(1 << v);
                }
            }
            let value = |k: usize| {
                motion.arc_words[k].and_then(|i| match &self.tokens[i].kind {
                    TokenKind::Word(w) => w.number(),
                    _ => None,
                })
            };
            if (0..3).any(|k| motion.arc_words[k].is_some()) {
                let v = [0, 1, 2].map(|k| value(k).unwrap_or(0.0));
                let norm = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
                if norm > 0.0 && norm.is_finite() {
                    self.vector = v.map(|x| x / norm);
                }
            }
        }
        match follow(
            axes,
            line,
            &self.tokens,
            &motion,
            &self.modal,
            &mut self.pos,
            &at,
            col,
            true,
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
                let plane = self.modal.working_plane.filter(|_| !self.modal.tcp);
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
                    tcp: self.modal.tcp || plane.is_some(),
                    frame: plane,
                    vector: (self.modal.tcp && self.modal.tcp_vector)
                        .then_some((vector_before, self.vector)),
                })))
            }
            Ok(None) => Ok(Some(self.gap(GapKind::Unknown, line.number))),
            Err(_) => {
                self.pos.unknown = every(self);
                Ok(Some(self.gap(GapKind::Other, line.number)))
            }
        }
    }

    /// A move to machine positions (G53, SUPA, M91) where the machine file places program
    /// zero (`[work_offsets]`): a rotary axis's machine position is its program value, so
    /// its word makes it known again (the linear axes' words are machine coordinates: the
    /// next block that programs them makes them known).
    fn rotary_machine_positions(&mut self, motion: &BlockMotion) {
        if motion.kind != MoveKind::Machine
            || motion.optional
            || self.machine.work_offsets.is_none()
            || self.modal.shift.is_none()
            || self.modal.tcp
            || self.modal.working_plane.is_some()
        {
            return;
        }
        let rotary = self.rotary_bits();
        for v in (0..MAX_AXES).filter(|&v| rotary & (1 << v) != 0) {
            let Some(i) = motion.axis_words[v] else {
                continue;
            };
            let TokenKind::Word(w) = &self.tokens[i].kind else {
                continue;
            };
            let Some(value) = w.number() else {
                continue;
            };
            self.pos.nominal[v] = value;
            self.pos.exact[v] = crate::program::exact::Position::Decimal {
                value,
                decimals: 6,
                unit: crate::program::exact::Unit::MM,
            };
            self.pos.unknown &= !(1 << v);
        }
    }

    /// The rotary variables of the active chain.
    fn rotary_bits(&self) -> u32 {
        let axes = self.reader.axes(self.modal.chain);
        (0..axes.len())
            .filter(|&v| !axes.is_linear(v))
            .fold(0, |m, v| m | 1 << v)
    }

    /// Whether a move under the working plane in force is followed: a straight move, arc
    /// or rapid of X, Y, Z words at the machine file's geometry zero (the frame the plane's
    /// origin is given in), with the rotary axes known (where the control turned them, or
    /// where the program left them: the controller's transformation takes them as they
    /// stand).
    fn follows_plane(&self, motion: &BlockMotion) -> bool {
        let Some(plane) = self.modal.working_plane else {
            return false;
        };
        let axes = self.reader.axes(self.modal.chain);
        let rotary = self.rotary_bits();
        !plane.rotation_only
            && self.turn.is_some()
            && self.modal.shift == Some([0.0; 3])
            && matches!(motion.kind, MoveKind::Program | MoveKind::Arc { .. })
            && !self.modal.incremental
            && self.pos.unknown & rotary == 0
            && (0..axes.len()).all(|v| axes.is_linear(v) || motion.axis_words[v].is_none())
    }

    /// The control turns the rotary axes to the plane: where they go is the controller's
    /// rule (the same for the original and the written program); the linear axes' place in
    /// the plane is known again at the next block that gives X, Y, Z.
    fn turn_to_plane(&mut self, line: usize) -> Item {
        let every = (1u32 << self.vars(self.modal.chain)) - 1;
        let rotary = self.rotary_bits();
        let turned = match (&self.turn, self.modal.working_plane) {
            (Some(turn), Some(plane))
                if self.pos.unknown & rotary == 0 && self.modal.shift == Some([0.0; 3]) =>
            {
                turn(
                    self.modal.chain,
                    &plane,
                    &self.pos.nominal,
                    self.modal.length,
                )
            }
            _ => None,
        };
        match turned {
            Some(q) => {
                for v in (0..MAX_AXES).filter(|&v| rotary & (1 << v) != 0) {
                    self.pos.nominal[v] = q[v];
                    self.pos.exact[v] = crate::program::exact::Position::Decimal {
                        value: q[v],
                        decimals: 6,
                        unit: crate::program::exact::Unit::MM,
                    };
                }
                self.pos.unknown = every & !rotary;
            }
            None => self.pos.unknown = every,
        }
        self.gap(GapKind::Plane, line)
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

/// The text the items are read from: whole (in memory), or streamed in chunks of whole
/// lines (the gate then holds a chunk, not the program).
enum Text<'a> {
    Whole(std::borrow::Cow<'a, [u8]>),
    Stream {
        chunks: crate::compensate::stream::Chunks<Box<dyn std::io::Read>>,
        buf: Vec<u8>,
        /// Lines before the chunk in `buf`.
        before: usize,
    },
}

/// The items of a program in one block-delete state, one at a time (a program of
/// millions of blocks is never held as items); an `Err` item is the reader's refusal, and
/// ends the reading.
pub struct Items<'m, 'a> {
    follower: Follower<'m>,
    text: Text<'a>,
    /// Where the next line starts in the text (or the chunk), and the lines of the chunk
    /// read so far.
    pos: usize,
    read: usize,
    /// The number of the last line read.
    last: usize,
    path: &'a str,
    done: bool,
    /// The label bodies being run (a TNC program's calls of bodies that move): label,
    /// the next line's index, as the control runs them.
    frames: Vec<(String, usize)>,
    /// Body lines run so far.
    body_blocks: usize,
}

impl Items<'_, '_> {
    /// Follow what the block just read asks of the order the lines run in (a call of a
    /// body that moves, a jump in a body), and give the next body line to run, if one is
    /// running.
    fn body_line(&mut self) -> Result<Option<crate::program::heidenhain::BodyLine>, String> {
        use crate::program::heidenhain::{Flow, MAX_LABEL_BLOCKS};
        let Some(tnc) = self.follower.modal.tnc.as_mut() else {
            return Ok(None);
        };
        match tnc.request.take() {
            Some(Flow::Call { name, .. }) => self.frames.push((name, 0)),
            Some(Flow::Jump { name, .. }) => match self.frames.last_mut() {
                Some(top) => *top = (name, 0),
                None => return Err(format!("a jump to LBL {name} outside a label's body")),
            },
            None => {}
        }
        let labels = tnc.labels.clone();
        loop {
            tnc.in_body = u8::try_from(self.frames.len()).unwrap_or(u8::MAX);
            let Some((name, index)) = self.frames.last_mut() else {
                return Ok(None);
            };
            let Some(body) = labels.bodies.get(name.as_str()) else {
                return Err(format!("the program has no LBL {name}"));
            };
            match body.lines.get(*index) {
                Some(line) => {
                    *index += 1;
                    self.body_blocks += 1;
                    if self.body_blocks > MAX_LABEL_BLOCKS {
                        return Err(format!(
                            "the program's label calls run more than {MAX_LABEL_BLOCKS} label blocks: not followed"
                        ));
                    }
                    return Ok(Some(line.clone()));
                }
                None => {
                    self.frames.pop();
                }
            }
        }
    }
}

impl Iterator for Items<'_, '_> {
    type Item = Result<Item, Diagnostic>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.done {
            return None;
        }
        loop {
            // A label body the control runs (a call of a body that moves).
            match self.body_line() {
                Ok(Some(body)) => {
                    // A streamed program's body line is read from the label scan's copy
                    // of it: located in a buffer of that line alone, its messages are
                    // moved to its line in the file.
                    let mut line = body.line();
                    let (own, shift) = match &self.text {
                        Text::Whole(_) => (None, 0),
                        Text::Stream { .. } => {
                            let mut own = body.content.clone();
                            own.extend_from_slice(&body.ending);
                            line.offset = 0;
                            (Some(own), body.number - 1)
                        }
                    };
                    let buf: &[u8] = match (&own, &self.text) {
                        (Some(own), _) => own,
                        (None, Text::Whole(src)) => src,
                        (None, Text::Stream { .. }) => &[],
                    };
                    self.last = line.number;
                    match self.follower.line(&line, self.path, buf) {
                        Ok(Some(item)) => return Some(Ok(item)),
                        Ok(None) => {}
                        Err(mut d) => {
                            d.line += shift;
                            self.done = true;
                            return Some(Err(d));
                        }
                    }
                    if self
                        .follower
                        .modal
                        .tnc
                        .as_ref()
                        .is_some_and(|t| t.end.is_some())
                    {
                        self.done = true;
                        let mut at = Diagnostic::at(
                            self.path,
                            buf,
                            line.offset,
                            "a called label ends the program here: not followed",
                        );
                        at.line += shift;
                        return Some(Err(at));
                    }
                    continue;
                }
                Ok(None) => {}
                Err(message) => {
                    self.done = true;
                    let line = self.last;
                    return Some(Err(Diagnostic {
                        path: self.path.to_string(),
                        line,
                        column: 1,
                        message,
                        source_line: String::new(),
                        code: None,
                    }));
                }
            }
            let (buf, before) = match &mut self.text {
                Text::Whole(src) => (&src[..], 0),
                Text::Stream {
                    chunks,
                    buf,
                    before,
                } => {
                    if self.pos >= buf.len() {
                        match chunks.next() {
                            Ok(Some((chunk, lines, _))) => {
                                buf.clear();
                                buf.extend_from_slice(chunk);
                                *before = lines;
                                self.pos = 0;
                                self.read = 0;
                            }
                            Ok(None) => {
                                self.done = true;
                                return None;
                            }
                            Err(e) => {
                                self.done = true;
                                return Some(Err(Diagnostic {
                                    path: self.path.to_string(),
                                    line: self.last + 1,
                                    column: 1,
                                    message: format!("the program cannot be read: {e}"),
                                    source_line: String::new(),
                                    code: None,
                                }));
                            }
                        }
                    }
                    (&buf[..], *before)
                }
            };
            let Some(mut line) = nc::lines(&buf[self.pos..]).next() else {
                if matches!(self.text, Text::Whole(_)) {
                    self.done = true;
                    return None;
                }
                self.pos = usize::MAX;
                continue;
            };
            line.offset = self.pos;
            self.read += 1;
            line.number = before + self.read;
            self.last = line.number;
            self.pos += line.content.len() + line.ending.len();
            match self.follower.line(&line, self.path, buf) {
                Ok(Some(item)) => return Some(Ok(item)),
                Ok(None) => {}
                Err(mut d) => {
                    // Located in the chunk: its lines come after `before` others.
                    d.line += before;
                    self.done = true;
                    return Some(Err(d));
                }
            }
        }
    }
}

impl Items<'_, '_> {
    /// Whether a block read so far started with `/`.
    pub fn has_optional(&self) -> bool {
        self.follower.has_optional
    }

    /// The number of the last line read (at the end: the program's last line).
    pub fn last_line(&self) -> usize {
        self.last.max(1)
    }
}

/// The items of program `source` read in `dialect` from tool chain `chain`, with block
/// delete `skip_optional`. They stream; a TNC program's labels (looked up by name) come
/// from a first reading that keeps only their bodies.
pub fn items<'m, 'a>(
    machine: &'m Machine,
    chain: usize,
    dialect: Dialect,
    source: super::Source<'a>,
    skip_optional: bool,
    turn: Option<Turn<'m>>,
) -> crate::Result<Items<'m, 'a>> {
    let path = source.name();
    let tnc = dialect == Dialect::Heidenhain;
    let mut labels = Labels::default();
    let text = match source {
        super::Source::Memory(t) => {
            if tnc {
                labels = Labels::scan(t.src);
            }
            Text::Whole(std::borrow::Cow::Borrowed(t.src))
        }
        super::Source::Stream { open, .. } => {
            let open = || open().map_err(|e| super::read_error(path, e));
            if tnc {
                // A first reading for the labels (a TNC program calls them before they
                // are written), then the program streams.
                let mut chunks = crate::compensate::stream::Chunks::new(open()?);
                let mut scan = LabelScan::default();
                while let Some((chunk, before, at)) =
                    chunks.next().map_err(|e| super::read_error(path, e))?
                {
                    for line in crate::nc::lines(chunk) {
                        scan.line(&crate::nc::Line {
                            number: line.number + before,
                            offset: line.offset + at,
                            ..line
                        });
                    }
                }
                labels = scan.finish();
            }
            Text::Stream {
                chunks: crate::compensate::stream::Chunks::new(open()?),
                buf: Vec::new(),
                before: 0,
            }
        }
    };
    Ok(Items {
        follower: Follower::new(
            machine,
            chain,
            dialect,
            Arc::new(labels),
            skip_optional,
            turn,
        ),
        text,
        pos: 0,
        read: 0,
        last: 0,
        path,
        done: false,
        frames: Vec::new(),
        body_blocks: 0,
    })
}

/// The axis values at parameter `s` of a step (its end where its start is not known).
pub fn at(step: &Step, s: f64, n: usize) -> [f64; MAX_AXES] {
    step.mv.at(s, n)
}
