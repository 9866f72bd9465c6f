//! Rewriting a probing program: each probing move gets the F its direction needs.
//!
//! Probing moves are `G31` (and `G31.1` … `G31.4`, one-shot, Fanuc/Haas skip) and
//! `G38.2` … `G38.5` (modal, LinuxCNC: a later block with axis words and no other motion
//! code probes again). A probing move's direction is its start → end vector in program
//! coordinates, expressed in the probe frame ([`FrameSource`]). Its F word's value bytes
//! are replaced; a probing move that relies on the modal F gets an F word.
//!
//! Because F is modal, a changed probing F would also be the feed of the blocks after it.
//! The pass follows the feed the original program has in force and, on the next feed
//! move that is not a probing move and has no F of its own (G1/G2/G3 or a canned cycle),
//! adds an F word with the original value (as the program wrote it). Every other byte is
//! copied unchanged.
//!
//! The pass refuses what would make a probing move's direction or feed unknowable:
//! control flow and subprogram calls while a restore is pending, a probing move whose
//! start is not known (after a probing move the machine stands where the probe
//! triggered, not at the programmed end), probing under coordinate rotation, scaling or
//! polar coordinates, and inverse-time or per-revolution feed.

use super::{Direction, ProbeFrame, positive};
use crate::diag::{Diagnostic, Error};
use crate::kinematics::{Kinematics, Model};
use crate::model::{AxisKind, ErrorModel, Machine};
use crate::nc::edit::Editor;
use crate::nc::number::{decimals_for, fixed, same_text};
use crate::nc::{self, Edit, Token, TokenKind, Value};
use crate::program::codes::{self, Code, MachineCodes};
use crate::program::gcode;
use nalgebra::{Rotation3, Unit, Vector3};

/// Millimetres per inch.
const INCH: f64 = 25.4;

/// Where the probe axis (and the α reference) comes from.
#[derive(Debug, Clone, Copy)]
pub enum FrameSource<'m> {
    /// A fixed probe frame in program coordinates (see [`ProbeFrame::from_axis`]).
    Frame(ProbeFrame),
    /// The machine's tool frame at each probing move's axis values (nominal kinematics):
    /// the probe axis is the tool direction, α is counted from the spindle's own x axis;
    /// directions and the frame are both taken in the workpiece frame.
    Machine { machine: &'m Machine, chain: usize },
}

/// How the pass runs.
#[derive(Debug, Clone, Copy)]
pub struct RewriteOptions<'m> {
    pub frame: FrameSource<'m>,
    /// The step of the written F values, mm/min: speeds are rounded to it and written with
    /// its decimals (inch programs: the speed rounded in mm/min, written in inch/min with
    /// the decimals of the same step in inch). A word keeps at least its own decimals.
    pub feed_step: f64,
}

impl Default for RewriteOptions<'_> {
    fn default() -> Self {
        RewriteOptions {
            frame: FrameSource::Frame(ProbeFrame::vertical()),
            feed_step: 0.1,
        }
    }
}

/// What happened to a probing move's F word.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FeedEdit {
    /// Its value was replaced.
    Changed,
    /// The block had none; one was added.
    Added,
    /// The new value prints the same as the old one.
    Unchanged,
}

/// One probing move of the program.
#[derive(Debug, Clone, PartialEq)]
pub struct ProbingMove {
    pub line: usize,
    pub direction: Direction,
    /// Length of the move (the approach distance S), mm.
    pub length: f64,
    /// The feed the original program probes with, mm/min.
    pub old_feed: f64,
    /// The feed written, mm/min.
    pub new_feed: f64,
    pub edit: FeedEdit,
}

/// What the pass did.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RewriteSummary {
    pub lines: usize,
    pub moves: Vec<ProbingMove>,
    /// Lines that got an F word restoring the original modal feed after a probing move.
    pub restored: Vec<usize>,
}

impl RewriteSummary {
    /// Σ S/v over the probing moves before the rewrite, minutes.
    pub fn time_before(&self) -> f64 {
        self.moves.iter().map(|m| m.length / m.old_feed).sum()
    }

    /// Σ S/v over the probing moves after the rewrite, minutes.
    pub fn time_after(&self) -> f64 {
        self.moves.iter().map(|m| m.length / m.new_feed).sum()
    }

    /// The relative increase of the speed-dependent measuring time, ΔtR = t_after/t_before
    /// − 1 (paper 001, eq. 6); `None` without probing moves.
    pub fn delta_t_r(&self) -> Option<f64> {
        let before = self.time_before();
        (before > 0.0).then(|| self.time_after() / before - 1.0)
    }

    pub fn words_changed(&self) -> usize {
        self.moves
            .iter()
            .filter(|m| m.edit == FeedEdit::Changed)
            .count()
    }

    pub fn words_added(&self) -> usize {
        self.moves
            .iter()
            .filter(|m| m.edit == FeedEdit::Added)
            .count()
            + self.restored.len()
    }
}

/// The motion mode a block runs in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Motion {
    Rapid,
    Feed,
    Arc,
    /// G38.x, modal.
    Probe,
    Cycle,
}

/// A G code as the pass sees it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum G {
    Motion(Motion),
    /// G31, G31.1 … G31.4: a one-shot probing move.
    Skip,
    Dwell,
    Inch,
    Millimetre,
    Absolute,
    Incremental,
    FeedPerMinute,
    FeedOther(&'static str),
    CycleCancel,
    /// The block's axis words are data, and the positions of the axes it names (all axes
    /// if it names none) are unknown after it (G10, G92, G52).
    Data,
    /// The axes the block names (all if it names none) are somewhere the program does not
    /// say after it (G28, G30 return to a reference point; G53 moves in machine
    /// coordinates).
    Lost,
    /// A work offset (G54 … G59.3, G54.1): switching to another one loses every position.
    WorkOffset(i64),
    Call,
    TransformOn(&'static str),
    TransformOff,
    Refused(&'static str),
    Harmless,
}

/// What a G code's meaning ([`crate::program::codes`]) is to the probe pass. The pass only
/// rewrites the F of probing moves, so codes it need not follow (planes, cutter
/// compensation, codes the table does not know) are harmless to it.
fn classify(code: Code) -> G {
    use G::*;
    match code {
        Code::Line { rapid: true } => Motion(self::Motion::Rapid),
        Code::Line { rapid: false } => Motion(self::Motion::Feed),
        Code::Arc { .. } => Motion(self::Motion::Arc),
        Code::Probe => Motion(self::Motion::Probe),
        Code::Skip => Skip,
        Code::Cycle(_) => Motion(self::Motion::Cycle),
        Code::Dwell => Dwell,
        Code::Units { inch: true } => Inch,
        Code::Units { inch: false } => Millimetre,
        Code::Distance { incremental: false } => Absolute,
        Code::Distance { incremental: true } => Incremental,
        Code::Feed {
            inverse_time: true, ..
        } => FeedOther("inverse-time feed (G93)"),
        Code::Feed {
            per_revolution: true,
            ..
        } => FeedOther("feed per revolution (G95)"),
        Code::Feed { .. } => FeedPerMinute,
        Code::CancelCycle => CycleCancel,
        Code::DataSetting(_) => Data,
        Code::ReturnHome | Code::SetReference | Code::MachineCoordinates | Code::MachineMove(_) => {
            Lost
        }
        Code::WorkOffset(number) => WorkOffset(number),
        Code::ExtendedWorkOffset => WorkOffset(541),
        Code::MacroCall => Call,
        Code::ModalMacro => Refused("a modal macro call (G66)"),
        Code::TransformOn(what) => TransformOn(what),
        Code::TiltedPlane => TransformOn("a tilted working plane (G68.2)"),
        Code::Rotation => TransformOn("coordinate rotation (G68)"),
        Code::ToolToPlane => Lost,
        Code::TransformOff | Code::PlaneOff => TransformOff,
        _ => Harmless,
    }
}

/// The feed the original program has in force.
#[derive(Debug, Clone, PartialEq)]
enum Feed {
    Unset,
    /// The number as written (program units per minute) and its text.
    Known {
        value: f64,
        text: String,
    },
    Unknown {
        line: usize,
        why: &'static str,
    },
}

/// An axis the pass follows.
#[derive(Debug, Clone, Copy)]
struct AxisInfo {
    letter: u8,
    linear: bool,
    /// The variable in the machine's kinematics.
    var: Option<usize>,
}

/// Why an axis position is not known.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Pos {
    Known(f64),
    Never,
    AfterProbe(usize),
    Lost(usize),
}

struct State {
    inch: bool,
    incremental: bool,
    motion: Option<Motion>,
    feed_other: Option<&'static str>,
    transform: Option<(&'static str, usize)>,
    work_offset: Option<i64>,
    pos: Vec<Pos>,
    /// The original program's modal feed.
    orig: Feed,
    /// The line of an optional block that set the original feed (it may or may not run).
    orig_uncertain: Option<usize>,
    /// The probing move after which the output's modal feed may differ from the original.
    restore: Option<usize>,
}

struct Pass<'a, 'm> {
    axes: Vec<AxisInfo>,
    /// The machine's own codes (none without a machine file).
    codes: &'m MachineCodes,
    frame: FrameSource<'m>,
    kin: Option<Kinematics>,
    feed_step: f64,
    speed_at: &'a dyn Fn(Direction) -> Result<f64, String>,
}

/// Rewrite the probing moves of `src` (named `path` in messages), appending the result to
/// `out`. `speed_at` gives the speed (mm/min) for a direction, or why there is none.
pub fn rewrite(
    src: &[u8],
    path: &str,
    speed_at: &dyn Fn(Direction) -> Result<f64, String>,
    opts: &RewriteOptions<'_>,
    out: &mut Vec<u8>,
) -> crate::Result<RewriteSummary> {
    let (axes, kin) = match opts.frame {
        FrameSource::Frame(_) => (
            b"XYZ"
                .iter()
                .map(|&letter| AxisInfo {
                    letter,
                    linear: true,
                    var: None,
                })
                .collect(),
            None,
        ),
        FrameSource::Machine { machine, chain } => {
            let kin = Kinematics::new(machine, &ErrorModel::zero(machine), chain)
                .map_err(|e| Error::Usage(e.to_string()))?;
            let axes = kin
                .axes()
                .iter()
                .enumerate()
                .map(|(var, &i)| AxisInfo {
                    letter: machine.axes[i].word.to_ascii_uppercase() as u8,
                    linear: machine.axes[i].kind == AxisKind::Linear,
                    var: Some(var),
                })
                .collect();
            (axes, Some(kin))
        }
    };
    static NO_CODES: MachineCodes = MachineCodes {
        harmless: Vec::new(),
        tcp_on: Vec::new(),
        tcp_off: Vec::new(),
        machine_moves: Vec::new(),
    };
    let pass = Pass {
        axes,
        codes: match opts.frame {
            FrameSource::Machine { machine, .. } => &machine.codes,
            FrameSource::Frame(_) => &NO_CODES,
        },
        frame: opts.frame,
        kin,
        feed_step: opts.feed_step,
        speed_at,
    };
    let mut state = State {
        inch: false,
        incremental: false,
        motion: None,
        feed_other: None,
        transform: None,
        work_offset: None,
        pos: vec![Pos::Never; pass.axes.len()],
        orig: Feed::Unset,
        orig_uncertain: None,
        restore: None,
    };
    let mut summary = RewriteSummary::default();
    let mut tokens = Vec::new();
    let mut edits = Vec::new();
    let mut errors = Vec::new();
    for line in nc::lines(src) {
        summary.lines += 1;
        nc::parse_line(line.content, &mut tokens);
        edits.clear();
        let at = |offset: usize, message: String| {
            Diagnostic::at(path, src, line.offset + offset, message)
        };
        if let Err(d) = pass.block(&line, &tokens, &mut state, &mut edits, &mut summary, &at) {
            errors.push(d);
            if errors.len() >= 20 {
                break;
            }
        }
        nc::emit_line(&line, &mut edits, out);
    }
    if !errors.is_empty() {
        return Err(Error::Inputs(errors));
    }
    Ok(summary)
}

/// Keywords that print and move nothing.
const HARMLESS_KEYWORDS: [&str; 4] = ["DPRNT", "BPRNT", "POPEN", "PCLOS"];

impl Pass<'_, '_> {
    fn axis_of(&self, letter: u8) -> Option<usize> {
        self.axes.iter().position(|a| a.letter == letter)
    }

    fn block(
        &self,
        line: &nc::Line<'_>,
        tokens: &[Token],
        state: &mut State,
        edits: &mut Vec<Edit>,
        summary: &mut RewriteSummary,
        at: &dyn Fn(usize, String) -> Diagnostic,
    ) -> Result<(), Diagnostic> {
        let optional = tokens
            .iter()
            .find(|t| t.kind != TokenKind::Space)
            .is_some_and(|t| t.kind == TokenKind::BlockDelete);
        // Read the words.
        let mut gs: Vec<(G, usize)> = Vec::new();
        let mut call: Option<usize> = None;
        let mut end_of_program = false;
        let mut f_word: Option<usize> = None;
        let mut axis_words: Vec<(usize, usize)> = Vec::new(); // (axis, token)
        let mut other_axis: Option<(u8, usize)> = None;
        let mut has_words = false;
        for (i, t) in tokens.iter().enumerate() {
            let w = match &t.kind {
                TokenKind::Word(w) => w,
                TokenKind::Other => {
                    let text = &line.content[t.span.clone()];
                    let upper = text.to_ascii_uppercase();
                    if text.first() == Some(&b'#')
                        || HARMLESS_KEYWORDS
                            .iter()
                            .any(|k| upper.starts_with(k.as_bytes()))
                    {
                        continue;
                    }
                    let word_end = text
                        .iter()
                        .position(|b| !b.is_ascii_alphabetic())
                        .unwrap_or(text.len())
                        .max(1);
                    return Err(at(
                        t.span.start,
                        format!(
                            "`{}` cannot be followed: the probe pass reads straight-line programs (no control flow, subprogram definitions or unknown statements)",
                            String::from_utf8_lossy(&text[..word_end])
                        ),
                    ));
                }
                _ => continue,
            };
            has_words = true;
            match w.letter {
                letter if gcode::is_code_letter(letter) => {
                    let Some(name) = gcode::code_name(w) else {
                        return Err(at(
                            t.span.start,
                            format!(
                                "{} is not a number; the probe pass cannot follow a computed G or M code",
                                w.letter as char
                            ),
                        ));
                    };
                    match codes::meaning(name, self.codes) {
                        Code::Subprogram | Code::Return => call = Some(t.span.start),
                        Code::ProgramEnd => end_of_program = true,
                        code => {
                            let g = classify(code);
                            if g == G::Call {
                                call = Some(t.span.start);
                            }
                            if let G::Refused(what) = g {
                                return Err(at(
                                    t.span.start,
                                    format!("{what} cannot be followed by the probe pass"),
                                ));
                            }
                            gs.push((g, t.span.start));
                        }
                    }
                }
                b'F' => f_word = Some(i),
                letter => {
                    if let Some(a) = self.axis_of(letter) {
                        if axis_words.iter().any(|&(b, _)| b == a) {
                            return Err(at(
                                t.span.start,
                                format!("{} appears twice in one block", letter as char),
                            ));
                        }
                        axis_words.push((a, i));
                    } else if b"XYZABCUVW".contains(&letter) {
                        other_axis.get_or_insert((letter, t.span.start));
                    }
                }
            }
        }
        if !has_words {
            return Ok(());
        }
        let number_of = |i: usize| match &tokens[i].kind {
            TokenKind::Word(w) => w.number(),
            _ => None,
        };
        // A call: the words are arguments; what the subprogram does is not known.
        if let Some(col) = call {
            if let Some(probe_line) = state.restore {
                return Err(at(
                    col,
                    format!(
                        "this block calls a subprogram while the feed differs from the original program's (the probing move at line {probe_line} changed it, and the subprogram may rely on the modal F): put a block with the original F before this call"
                    ),
                ));
            }
            for p in &mut state.pos {
                *p = Pos::Lost(line.number);
            }
            state.orig = Feed::Unknown {
                line: line.number,
                why: "a subprogram call",
            };
            state.orig_uncertain = None;
            return Ok(());
        }
        // Modal words.
        let mut block_motion: Option<(Motion, usize)> = None;
        let mut skip: Option<usize> = None;
        let mut dwell = false;
        let mut data = false;
        let mut lost = false;
        for &(g, col) in &gs {
            match g {
                G::Motion(m) => block_motion = Some((m, col)),
                G::Skip => skip = Some(col),
                G::Dwell => dwell = true,
                G::Inch => state.inch = true,
                G::Millimetre => state.inch = false,
                G::Absolute => state.incremental = false,
                G::Incremental => state.incremental = true,
                G::FeedPerMinute => state.feed_other = None,
                G::FeedOther(what) => state.feed_other = Some(what),
                G::CycleCancel => state.motion = None,
                G::Data => data = true,
                G::Lost => lost = true,
                G::WorkOffset(code) => {
                    if state.work_offset.is_some_and(|w| w != code) {
                        for p in &mut state.pos {
                            *p = Pos::Lost(line.number);
                        }
                    }
                    state.work_offset = Some(code);
                }
                G::TransformOn(what) => state.transform = Some((what, line.number)),
                G::TransformOff => state.transform = None,
                G::Call | G::Refused(_) | G::Harmless => {}
            }
        }
        if let Some((m, _)) = block_motion {
            state.motion = Some(m);
        }
        let unit = |linear: bool| if state.inch && linear { INCH } else { 1.0 };
        // What kind of block is it?
        let probing = skip.is_some()
            || (state.motion == Some(Motion::Probe)
                && (!axis_words.is_empty() || other_axis.is_some())
                && !dwell
                && !data);
        if probing {
            let col = skip.or(block_motion.map(|m| m.1)).unwrap_or(0);
            self.probing_move(
                line,
                tokens,
                state,
                edits,
                summary,
                at,
                optional,
                col,
                f_word,
                &axis_words,
                other_axis,
            )?;
            if end_of_program {
                state.restore = None;
            }
            return Ok(());
        }
        // The original program's feed after this block.
        if let Some(i) = f_word {
            match number_of(i) {
                Some(value) => {
                    let TokenKind::Word(w) = &tokens[i].kind else {
                        unreachable!()
                    };
                    state.orig = Feed::Known {
                        value,
                        text: String::from_utf8_lossy(&line.content[w.value_span.clone()])
                            .into_owned(),
                    };
                }
                None => {
                    state.orig = Feed::Unknown {
                        line: line.number,
                        why: "an F given by a parameter or expression",
                    }
                }
            }
            if optional {
                state.orig_uncertain = Some(line.number);
            } else {
                state.orig_uncertain = None;
                state.restore = None;
            }
        }
        // Does this block feed (and so use the modal F)?
        let moves = !axis_words.is_empty() || other_axis.is_some();
        let feeds = !dwell
            && !data
            && match state.motion {
                Some(Motion::Feed) | Some(Motion::Arc) => moves,
                Some(Motion::Cycle) => moves || block_motion.is_some_and(|m| m.0 == Motion::Cycle),
                _ => false,
            };
        if feeds
            && f_word.is_none()
            && state.feed_other.is_none()
            && let Some(probe_line) = state.restore
        {
            let text = match (&state.orig, state.orig_uncertain) {
                (Feed::Known { text, .. }, None) => text.clone(),
                (Feed::Known { .. }, Some(opt)) => {
                    return Err(at(
                        0,
                        format!(
                            "this feed move needs the original F back after the probing move at line {probe_line}, but the optional block (/) at line {opt} set F: which F the original program uses here depends on the block delete switch (give this block an F)"
                        ),
                    ));
                }
                (Feed::Unknown { line: l, why }, _) => {
                    return Err(at(
                        0,
                        format!(
                            "this feed move needs the original F back after the probing move at line {probe_line}, but the F in force is not known ({why} at line {l}; give this block an F)"
                        ),
                    ));
                }
                (Feed::Unset, _) => {
                    return Err(at(
                        0,
                        format!(
                            "this feed move relies on a modal F, but no F was set before the probing move at line {probe_line} changed it (give this block an F)"
                        ),
                    ));
                }
            };
            Editor::new(line.content, tokens, edits).append_word(b'F', &text);
            summary.restored.push(line.number);
            if !optional {
                state.restore = None;
            }
        }
        if end_of_program {
            state.restore = None;
        }
        // Positions after the block.
        if data || lost {
            if axis_words.is_empty() {
                for p in &mut state.pos {
                    *p = Pos::Lost(line.number);
                }
            }
            for &(a, _) in &axis_words {
                state.pos[a] = Pos::Lost(line.number);
            }
            return Ok(());
        }
        if dwell {
            return Ok(());
        }
        for &(a, i) in &axis_words {
            let info = self.axes[a];
            let new = match number_of(i) {
                None => Pos::Lost(line.number),
                Some(x) => {
                    let x = x * unit(info.linear);
                    if state.incremental {
                        match state.pos[a] {
                            Pos::Known(p) => Pos::Known(p + x),
                            other => other,
                        }
                    } else {
                        Pos::Known(x)
                    }
                }
            };
            state.pos[a] = if optional {
                Pos::Lost(line.number)
            } else {
                new
            };
        }
        if state.motion == Some(Motion::Cycle) && moves {
            // A cycle ends at its R or initial plane.
            for (a, info) in self.axes.iter().enumerate() {
                if info.linear && self.is_drilling_axis(info.letter) {
                    state.pos[a] = Pos::Lost(line.number);
                }
            }
        }
        Ok(())
    }

    fn is_drilling_axis(&self, letter: u8) -> bool {
        letter == b'Z'
    }

    #[allow(clippy::too_many_arguments)]
    fn probing_move(
        &self,
        line: &nc::Line<'_>,
        tokens: &[Token],
        state: &mut State,
        edits: &mut Vec<Edit>,
        summary: &mut RewriteSummary,
        at: &dyn Fn(usize, String) -> Diagnostic,
        optional: bool,
        col: usize,
        f_word: Option<usize>,
        axis_words: &[(usize, usize)],
        other_axis: Option<(u8, usize)>,
    ) -> Result<(), Diagnostic> {
        if let Some((letter, c)) = other_axis {
            return Err(at(
                c,
                format!(
                    "{} in a probing move: probing moves must be straight moves in {}",
                    letter as char,
                    self.linear_letters()
                ),
            ));
        }
        if let Some(&(a, i)) = axis_words.iter().find(|&&(a, _)| !self.axes[a].linear) {
            let _ = a;
            return Err(at(
                tokens[i].span.start,
                format!(
                    "{} in a probing move: probing moves must be straight moves in {} (no rotary axis)",
                    self.axes[a].letter as char,
                    self.linear_letters()
                ),
            ));
        }
        if axis_words.is_empty() {
            return Err(at(
                col,
                "a probing move without an end point (expected axis words such as X10)".into(),
            ));
        }
        if let Some(what) = state.feed_other {
            return Err(at(
                col,
                format!(
                    "a probing move under {what}: the probing speed must be a feed per minute (G94)"
                ),
            ));
        }
        if let Some((what, l)) = state.transform {
            return Err(at(
                col,
                format!(
                    "a probing move under {what} (line {l}): its direction in the probe frame cannot be known"
                ),
            ));
        }
        let unit = if state.inch { INCH } else { 1.0 };
        // Start and end.
        let mut delta = vec![0.0; self.axes.len()];
        let mut end = state.pos.clone();
        for &(a, i) in axis_words {
            let TokenKind::Word(w) = &tokens[i].kind else {
                unreachable!()
            };
            let Some(x) = w.number() else {
                return Err(at(
                    tokens[i].span.start,
                    format!(
                        "{} is not a number: a probing move's end point must be a number to know its direction",
                        w.letter as char
                    ),
                ));
            };
            let x = x * unit;
            if state.incremental {
                delta[a] = x;
            } else {
                match state.pos[a] {
                    Pos::Known(p) => delta[a] = x - p,
                    why => {
                        let letter = self.axes[a].letter as char;
                        let reason = match why {
                            Pos::AfterProbe(l) => format!(
                                "{letter} was last moved by the probing move at line {l}, which stops where the probe triggers"
                            ),
                            Pos::Lost(l) => format!("line {l} left {letter} unknown"),
                            _ => format!("{letter} was never programmed"),
                        };
                        return Err(at(
                            tokens[i].span.start,
                            format!(
                                "the start of this probing move is not known: {reason} (program an absolute {letter} before it, or use G91)"
                            ),
                        ));
                    }
                }
            }
            end[a] = Pos::AfterProbe(line.number);
        }
        let (vector, frame) = self
            .move_in_frame(&state.pos, &delta)
            .map_err(|m| at(col, m))?;
        let length = vector.norm();
        let Some(direction) = frame.direction_of(&vector) else {
            return Err(at(col, "a probing move of zero length".into()));
        };
        let speed = (self.speed_at)(direction)
            .map_err(|m| at(col, format!("no speed for this probing move: {m}")))?;
        // The original feed of this move.
        let (old_value, old_text) = match f_word {
            Some(i) => {
                let TokenKind::Word(w) = &tokens[i].kind else {
                    unreachable!()
                };
                let Some(v) = w.number() else {
                    return Err(at(
                        tokens[i].span.start,
                        "F is not a number: a probing move's F must be a number to be replaced"
                            .into(),
                    ));
                };
                (
                    v,
                    String::from_utf8_lossy(&line.content[w.value_span.clone()]).into_owned(),
                )
            }
            None => match &state.orig {
                Feed::Known { value, text } => (*value, text.clone()),
                Feed::Unset => {
                    return Err(at(
                        col,
                        "this probing move relies on a modal F, but no F was set before it".into(),
                    ));
                }
                Feed::Unknown { line: l, why } => {
                    return Err(at(
                        col,
                        format!(
                            "this probing move relies on a modal F, which is not known ({why} at line {l})"
                        ),
                    ));
                }
            },
        };
        let step_decimals = decimals_for(self.feed_step / unit);
        let own_decimals = f_word
            .and_then(|i| match &tokens[i].kind {
                TokenKind::Word(w) => match w.value {
                    Value::Number { decimals, .. } => Some(decimals),
                    _ => None,
                },
                _ => None,
            })
            .unwrap_or(0);
        let d = step_decimals.max(own_decimals);
        // The speed on the feed step (mm/min), then in program units.
        let speed = if positive(self.feed_step) {
            (speed / self.feed_step).round() * self.feed_step
        } else {
            speed
        };
        let new_value = speed / unit;
        let (edit, written) = match f_word {
            Some(i) => {
                if same_text(old_value, new_value, d) {
                    (FeedEdit::Unchanged, old_value)
                } else {
                    let text = fixed(new_value, d);
                    let written = text.parse().unwrap_or(new_value);
                    Editor::new(line.content, tokens, edits).replace_number(i, text);
                    (FeedEdit::Changed, written)
                }
            }
            None => {
                let text = fixed(new_value, d);
                let written = text.parse().unwrap_or(new_value);
                Editor::new(line.content, tokens, edits).append_word(b'F', &text);
                (FeedEdit::Added, written)
            }
        };
        if !positive(written) {
            return Err(at(
                col,
                format!("the speed for direction {direction} rounds to F{written}: not a feed"),
            ));
        }
        summary.moves.push(ProbingMove {
            line: line.number,
            direction,
            length,
            old_feed: old_value * unit,
            new_feed: written * unit,
            edit,
        });
        // Feeds after the block: the original has `old_value` (if the block set it) or
        // what it had; the output has `written`.
        if f_word.is_some() {
            state.orig = Feed::Known {
                value: old_value,
                text: old_text,
            };
            state.orig_uncertain = optional.then_some(line.number);
        }
        if written != old_value {
            state.restore = Some(line.number);
        } else if !optional {
            state.restore = None;
        }
        state.pos = if optional {
            end.iter()
                .zip(&state.pos)
                .map(|(e, p)| if e == p { *p } else { Pos::Lost(line.number) })
                .collect()
        } else {
            end
        };
        Ok(())
    }

    fn linear_letters(&self) -> String {
        self.axes
            .iter()
            .filter(|a| a.linear)
            .map(|a| (a.letter as char).to_string())
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// The move's vector and the probe frame, both in program (or workpiece) coordinates.
    fn move_in_frame(
        &self,
        start: &[Pos],
        delta: &[f64],
    ) -> Result<(Vector3<f64>, ProbeFrame), String> {
        match (self.frame, &self.kin) {
            (FrameSource::Frame(frame), _) => {
                let mut v = Vector3::zeros();
                for (a, info) in self.axes.iter().enumerate() {
                    let k = match info.letter {
                        b'X' => 0,
                        b'Y' => 1,
                        _ => 2,
                    };
                    v[k] += delta[a];
                }
                Ok((v, frame))
            }
            (FrameSource::Machine { machine, chain }, Some(kin)) => {
                let n = kin.len();
                let mut q = vec![0.0; n];
                for (a, info) in self.axes.iter().enumerate() {
                    let var = info.var.unwrap_or(a);
                    match start[a] {
                        Pos::Known(x) => q[var] = x,
                        // Linear axes: only the difference matters. A rotary axis the
                        // program never set is at home (0), as the machine file says.
                        _ if info.linear => {}
                        Pos::Never => {}
                        _ => {
                            return Err(format!(
                                "the position of rotary axis {} is not known, so neither is the probe axis",
                                info.letter as char
                            ));
                        }
                    }
                }
                let mut q1 = q.clone();
                for (a, info) in self.axes.iter().enumerate() {
                    q1[info.var.unwrap_or(a)] += delta[a];
                }
                let length = machine.tool.length;
                let (p0, _) = kin.pose(Model::Nominal, &q, length);
                let (p1, _) = kin.pose(Model::Nominal, &q1, length);
                let frame = tool_frame(machine, chain, kin, &q);
                Ok((p1.p - p0.p, frame))
            }
            (FrameSource::Machine { .. }, None) => unreachable!(),
        }
    }
}

/// The spindle's frame in the workpiece frame at axis values `q` (nominal): the rotation
/// of the tool chain seen from the workpiece chain, `R(W)⁻¹·R(T)`.
pub fn tool_frame(machine: &Machine, chain: usize, kin: &Kinematics, q: &[f64]) -> ProbeFrame {
    let rotation = |axes: &[usize]| {
        axes.iter().fold(Rotation3::identity(), |acc, &i| {
            let axis = &machine.axes[i];
            match axis.kind {
                AxisKind::Linear => acc,
                AxisKind::Rotary => {
                    let var = kin.axes().iter().position(|&a| a == i).unwrap_or(0);
                    acc * Rotation3::from_axis_angle(
                        &Unit::new_normalize(axis.direction),
                        q[var].to_radians(),
                    )
                }
            }
        })
    };
    let w = rotation(&machine.workpiece_chain);
    let t = rotation(&machine.tool_chains[chain].axes);
    ProbeFrame::from_rotation(&(w.inverse() * t))
}
