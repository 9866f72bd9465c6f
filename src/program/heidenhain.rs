//! The Heidenhain TNC front end (conversational language, Klartext): a block's tokens
//! ([`crate::nc::heidenhain`]) into its [`BlockMotion`], following the [`Modal`] state.
//!
//! What a statement means follows Heidenhain's user manuals (sources in
//! `docs/nc-support.md`, section Heidenhain):
//!
//! * `L` is a straight move; `FMAX` makes it a rapid for that block only; `M91`/`M92` give
//!   machine coordinates (the axes named end at an unknown program position, like G53);
//!   `M128`/`FUNCTION TCPM` and `M129`/`FUNCTION RESET TCPM` switch tool-centre-point
//!   control.
//! * `CYCL DEF 7` shifts the datum; `PLANE SPATIAL` tilts the working plane (rotations
//!   about the fixed X, then Y, then Z axes) about the shifted datum; `STAY` leaves the
//!   rotary axes where they stand and the control's angles in Q120–Q122 for the program's
//!   next `L` block, `TURN` turns them at once; `SEQ±` and `TABLE ROT` choose the
//!   solution. `PLANE RESET` ends the plane.
//! * `FN 0` sets a Q parameter; a Q parameter in a word is its value.
//! * `CALL LBL` runs a label's body (up to `LBL 0`) when it moves nothing; the labels after
//!   `M30` run only when called.
//!
//! Everything else that could move the machine or change a transformation is refused at
//! its place.

use std::collections::HashMap;
use std::sync::Arc;

use super::gcode::{At, MAX_WORD};
use super::{BlockMotion, CodeName, Modal, Motion, MoveKind, Reader, WorkingPlane};
use crate::diag::Diagnostic;
use crate::kinematics::MAX_AXES;
use crate::nc::{self, Token, TokenKind, Value, heidenhain::is_q_parameter};

/// The deepest a label may call labels.
const MAX_CALL_DEPTH: u8 = 8;

/// The most label blocks a program's `CALL LBL`s may run in all, calls within calls
/// counted each time they run: labels that call labels several times grow exponentially
/// with their depth (ten calls eight deep are 10^8 blocks), and the reading stops there
/// with a refusal at the call rather than run on for days.
pub const MAX_LABEL_BLOCKS: usize = 1_000_000;

/// What the TNC front end keeps between blocks, beside the [`Modal`] state.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Tnc {
    /// Q parameters the program has set to constants, by [`q_key`].
    pub q: HashMap<u32, f64>,
    /// The datum shift of CYCL DEF 7 (X Y Z, mm) in the part frame.
    pub datum: [f64; 3],
    /// The last cycle defined (CYCL DEF), which M99 and CYCL CALL call.
    pub cycle: Option<CycleDef>,
    /// The line ends in `~`: the next line continues the block.
    pub continued: bool,
    /// The cycle whose parameters the continued lines give.
    pub defining: Option<CycleDef>,
    /// Q120–Q122 hold the angles of the PLANE in force, set with STAY and not yet used.
    pub plane_angles: bool,
    /// The circle centre (pole) of the last CC.
    pub pole: Option<Pole>,
    /// The CC blocks read so far.
    pub poles: u64,
    /// The program's labels.
    pub labels: Arc<Labels>,
    /// How deep in label calls the block being read is.
    pub depth: u8,
    /// The label blocks run so far by the program's calls (at most [`MAX_LABEL_BLOCKS`]).
    pub label_blocks: usize,
    /// The line of the M2/M30 that ended the program, and whether it was optional (`/`).
    pub end: Option<(usize, bool)>,
    /// The line being read.
    pub line: usize,
    /// The caller runs the bodies of `CALL LBL`s that move, and follows jumps in them
    /// ([`Flow`]): the compensation pass and the verification gate do; a caller that
    /// does not gets such a call refused.
    pub follow_calls: bool,
    /// What the caller must run next, set by the block just read: a label's body that
    /// moves, or a jump taken in a body the caller runs.
    pub request: Option<Flow>,
    /// How many label bodies the caller is running (each called or jumped to).
    pub in_body: u8,
    /// A jump taken in the main program: the lines up to this label (its name, and the
    /// line of the jump) are skipped.
    pub skip_to: Option<(String, usize)>,
    /// A body run by `CALL LBL` (at any depth) moved.
    pub moved: bool,
}

/// A change of the order the control runs the lines in, for the caller to follow.
#[derive(Debug, Clone, PartialEq)]
pub enum Flow {
    /// `CALL LBL name` at `line`, whose body moves: run the body (the lines after
    /// `LBL name` up to `LBL 0`), then go on after the call.
    Call { name: String, line: usize },
    /// A jump (`FN 9`–`FN 12` whose condition holds) at `line`, in a body the caller runs:
    /// go on with the lines after `LBL name`, up to its `LBL 0`, which returns from the
    /// call.
    Jump { name: String, line: usize },
}

/// The circle centre (pole) of a `CC` block.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pole {
    /// Its plane (0 X-Y, 1 Z-X, 2 Y-Z, as [`super::Modal::plane`]).
    pub plane: u8,
    /// Its two coordinates in that plane's order (program units).
    pub centre: [f64; 2],
    /// The frame its coordinates were given in: the working plane's origin and axes, or
    /// the datum shift outside a plane; and whether tool-centre-point control was on
    /// (the words are the tip on the part, not the axes).
    pub frame: [f64; 13],
    /// Which CC of the program set it (counted from 1): a pole set again to the same
    /// coordinates is another.
    pub seq: u64,
}

/// The frame a TNC block's coordinates are given in: the working plane in force (its
/// origin and axes), or outside one the datum shift of CYCL DEF 7.
fn frame_of(modal: &Modal, tnc: &Tnc) -> [f64; 13] {
    let mut key = [0.0; 13];
    key[12] = f64::from(u8::from(modal.tcp));
    match &modal.working_plane {
        Some(plane) => {
            key[..3].copy_from_slice(plane.origin.as_slice());
            key[3..12].copy_from_slice(plane.rotation.matrix().as_slice());
        }
        None => key[..3].copy_from_slice(&tnc.datum),
    }
    key
}

/// A cycle definition: its number and the Q parameters of its continued lines.
#[derive(Debug, Clone, PartialEq)]
pub struct CycleDef {
    pub number: u32,
    /// The line of `CYCL DEF`.
    pub line: usize,
    pub params: Vec<(u32, Param)>,
    /// The definition's lines as written (the `CYCL DEF` line and its continued lines).
    pub text: Vec<Vec<u8>>,
    /// The surface coordinate (Q203) the control now holds for it, where nccomp has
    /// written a copy of the definition with another (program units).
    pub surface_written: Option<f64>,
    /// A Sinumerik drilling cycle (`MCALL CYCLE81(…)`) read as this definition.
    pub siemens: Option<SiemensCall>,
}

/// How a Sinumerik drilling call is written again with another depth: its reference
/// plane RFP (argument 2) takes the new surface, and an absolute depth DP (argument 4)
/// moves with it by `depth`, DP − RFP as programmed (`None` when the depth is DPR,
/// relative to RFP); the retraction plane RTP the tool ends at (program units) stays.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SiemensCall {
    pub depth: Option<f64>,
    pub end: f64,
}

/// A cycle parameter's value.
#[derive(Debug, Clone, PartialEq)]
pub enum Param {
    Known(f64),
    /// What it reads that the program never sets to a constant.
    Unknown(String),
}

impl CycleDef {
    /// The value of parameter Q`n`.
    pub fn get(&self, n: u32) -> Option<&Param> {
        self.params.iter().find(|(k, _)| *k == n).map(|(_, p)| p)
    }
}

/// A program's labels: each label's body, the lines from the label to `LBL 0`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Labels {
    pub bodies: HashMap<String, Body>,
    /// The line of the program's end (the first `M2`/`M30` without `/`, or `END PGM`):
    /// the labels after it run only when called.
    pub end: Option<usize>,
}

/// A label's body: its lines after the `LBL` line, up to `LBL 0`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Body {
    /// The line of `LBL`.
    pub line: usize,
    pub lines: Vec<BodyLine>,
    /// An `LBL 0` ends it (otherwise it runs to the end of the file).
    pub closed: bool,
}

/// A line of a label's body, as the file holds it.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct BodyLine {
    pub number: usize,
    /// Its first byte's offset in the file.
    pub offset: usize,
    pub content: Vec<u8>,
    pub ending: Vec<u8>,
}

impl BodyLine {
    /// The line as the file holds it.
    pub fn line(&self) -> nc::Line<'_> {
        nc::Line {
            number: self.number,
            offset: self.offset,
            content: &self.content,
            ending: &self.ending,
        }
    }
}

impl Body {
    /// Whether the body lies after the program's end (a subprogram the main program
    /// calls), and ends in `LBL 0`: then it runs only when called, and nccomp may write
    /// it for its calls.
    pub fn callable(&self, labels: &Labels) -> bool {
        self.closed && labels.end.is_some_and(|end| self.line > end)
    }
}

impl Labels {
    /// The labels of program `src`.
    pub fn scan(src: &[u8]) -> Labels {
        let mut scan = LabelScan::default();
        for line in nc::lines(src) {
            scan.line(&line);
        }
        scan.finish()
    }
}

/// [`Labels::scan`] line by line, for a program read in chunks: a first pass that keeps
/// only the labels' bodies and where the program ends, so that the pass after it can
/// stream the program.
#[derive(Debug, Default)]
pub struct LabelScan {
    labels: Labels,
    /// The labels since the last `LBL 0`: each line goes into their bodies.
    open: Vec<String>,
    tokens: Vec<Token>,
}

impl LabelScan {
    /// The program's next line, numbered and placed as in the whole file.
    pub fn line(&mut self, line: &nc::Line<'_>) {
        if self.labels.end.is_none()
            && (memchr::memmem::find(line.content, b"M30").is_some()
                || memchr::memmem::find(line.content, b"M2").is_some()
                || memchr::memmem::find(line.content, b"END").is_some())
        {
            nc::heidenhain::parse_line(line.content, &mut self.tokens);
            let tokens = &self.tokens;
            let sig = significant(line.content, tokens);
            let words: Vec<&str> = sig
                .iter()
                .map(|&i| text(line.content, &tokens[i]))
                .collect();
            let optional = tokens.iter().any(|t| t.kind == TokenKind::BlockDelete);
            if (words.first() == Some(&"END") && words.get(1) == Some(&"PGM"))
                || (!optional && ends_program(&words))
            {
                self.labels.end = Some(line.number);
            }
        }
        let label = self.label(line.content);
        if label.as_deref() == Some("0") {
            for name in self.open.drain(..) {
                if let Some(body) = self.labels.bodies.get_mut(&name) {
                    body.closed = true;
                }
            }
            return;
        }
        for name in &self.open {
            if let Some(body) = self.labels.bodies.get_mut(name) {
                body.lines.push(BodyLine {
                    number: line.number,
                    offset: line.offset,
                    content: line.content.to_vec(),
                    ending: line.ending.to_vec(),
                });
            }
        }
        // A label defined twice keeps its first body.
        if let Some(name) = label
            && !self.labels.bodies.contains_key(&name)
        {
            self.labels.bodies.insert(
                name.clone(),
                Body {
                    line: line.number,
                    lines: Vec::new(),
                    closed: false,
                },
            );
            self.open.push(name);
        }
    }

    /// The name a `LBL` line gives.
    fn label(&mut self, content: &[u8]) -> Option<String> {
        // Only a line that says LBL can be one: the rest are not cut into tokens.
        memchr::memmem::find(content, b"LBL")?;
        nc::heidenhain::parse_line(content, &mut self.tokens);
        let tokens = &self.tokens;
        let sig = significant(content, tokens);
        if sig.first().map(|&i| text(content, &tokens[i])) != Some("LBL") {
            return None;
        }
        label_name(content, tokens, &sig[1..])
    }

    pub fn finish(self) -> Labels {
        self.labels
    }
}

/// A block's words end the program (`M2`, `M30` among its M functions; `L … M30`).
fn ends_program(words: &[&str]) -> bool {
    words
        .first()
        .is_some_and(|w| *w == "L" || w.starts_with('M'))
        && words.iter().any(|w| matches!(*w, "M2" | "M30" | "M02"))
}

/// The name of a label as `LBL`/`CALL LBL` give it: its number, or its quoted name.
fn label_name(content: &[u8], tokens: &[Token], sig: &[usize]) -> Option<String> {
    let t = text(content, &tokens[*sig.first()?]);
    if t.starts_with('"') {
        return Some(t.trim_matches('"').to_string());
    }
    t.parse::<u32>().ok().map(|n| n.to_string())
}

/// The key of a Q parameter (`Q5`, `QL5`, `QR5`): its number, in its own range per kind.
pub fn q_key(text: &[u8]) -> Option<(u32, f64)> {
    if !is_q_parameter(text) {
        return None;
    }
    let (sign, t) = match text.first() {
        Some(b'-') => (-1.0, &text[1..]),
        Some(b'+') => (1.0, &text[1..]),
        _ => (1.0, text),
    };
    let t = &t[1..];
    let (base, digits) = match t.first() {
        Some(b'L') => (1_000_000, &t[1..]),
        Some(b'R') => (2_000_000, &t[1..]),
        _ => (0, t),
    };
    let n: u32 = std::str::from_utf8(digits).ok()?.parse().ok()?;
    (n < 1_000_000).then_some((base + n, sign))
}

/// A Q parameter's name for messages.
fn q_name(key: u32) -> String {
    match key / 1_000_000 {
        1 => format!("QL{}", key % 1_000_000),
        2 => format!("QR{}", key % 1_000_000),
        _ => format!("Q{key}"),
    }
}

/// Replace every Q-parameter word whose value the program has set by that number.
pub fn substitute(content: &[u8], tokens: &mut [Token], tnc: &Tnc) {
    for t in tokens.iter_mut() {
        let TokenKind::Word(w) = &mut t.kind else {
            continue;
        };
        if w.value != Value::Parameter {
            continue;
        }
        let Some((key, sign)) = content.get(w.value_span.clone()).and_then(q_key) else {
            continue;
        };
        if let Some(&v) = tnc.q.get(&key) {
            w.value = Value::Number {
                value: sign * v,
                decimals: decimals_of(v),
            };
        }
    }
}

/// The fewest decimals (at most 9) that print `v` as it is.
fn decimals_of(v: f64) -> u8 {
    (0..=9u8)
        .find(|&d| {
            let s = 10f64.powi(i32::from(d));
            ((v * s).round() / s - v).abs() <= v.abs() * 1e-15
        })
        .unwrap_or(9)
}

/// The tokens that are not spaces, comments, the block delete or the block number.
fn significant(content: &[u8], tokens: &[Token]) -> Vec<usize> {
    let mut sig = Vec::with_capacity(tokens.len());
    let mut numbered = false;
    for (i, t) in tokens.iter().enumerate() {
        match t.kind {
            TokenKind::Space | TokenKind::Comment | TokenKind::BlockDelete => {}
            TokenKind::Other
                if !numbered
                    && sig.is_empty()
                    && content[t.span.clone()].iter().all(u8::is_ascii_digit) =>
            {
                numbered = true;
            }
            _ => sig.push(i),
        }
    }
    sig
}

/// Names for a message: `a, b, c`, or `none`.
pub(super) fn listed(names: impl Iterator<Item = String>) -> String {
    let names: Vec<String> = names.collect();
    if names.is_empty() {
        "none".into()
    } else {
        names.join(", ")
    }
}

/// The token of the block's statement keyword (`L`, `CP` …), if it has one.
pub fn keyword(content: &[u8], tokens: &[Token]) -> Option<usize> {
    significant(content, tokens).first().copied()
}

/// The token of the block number, if the line has one.
pub fn block_number(content: &[u8], tokens: &[Token]) -> Option<usize> {
    tokens
        .iter()
        .position(|t| !matches!(t.kind, TokenKind::Space | TokenKind::BlockDelete))
        .filter(|&i| {
            tokens[i].kind == TokenKind::Other
                && content[tokens[i].span.clone()]
                    .iter()
                    .all(u8::is_ascii_digit)
        })
}

fn text<'a>(content: &'a [u8], t: &Token) -> &'a str {
    std::str::from_utf8(&content[t.span.clone()]).unwrap_or("")
}

/// The line ends in `~`: the block goes on in the next line.
fn continues(content: &[u8]) -> bool {
    content.trim_ascii_end().ends_with(b"~")
}

/// The parameters a continued line of a cycle definition sets: each `Qn=value` with its
/// key and value text, however the spaces fall around the `=` (`Q200=3`, `Q200=  3`,
/// `Q200 = 3`: the control reads them alike). A `~` that continues the block is not part
/// of a value.
fn cycle_parameters<'a>(
    content: &'a [u8],
    tokens: &[Token],
    sig: &[usize],
    at: At<'_>,
) -> Result<Vec<(u32, &'a str)>, Diagnostic> {
    let parts: Vec<(usize, &str)> = sig
        .iter()
        .map(|&i| (tokens[i].span.start, text(content, &tokens[i])))
        .filter(|(_, t)| *t != "~")
        .collect();
    let mut out = Vec::new();
    let mut k = 0;
    while k < parts.len() {
        let (col, t) = parts[k];
        k += 1;
        // The name, then `=` in this token or the next, then the value after it (in this
        // token or the next).
        let (name, rest) = match t.split_once('=') {
            Some((name, rest)) => (name, Some(rest)),
            None => match parts.get(k) {
                Some((_, next)) if next.starts_with('=') => {
                    k += 1;
                    (t, Some(&next[1..]))
                }
                _ => (t, None),
            },
        };
        let Some(rest) = rest else {
            return Err(at(
                col,
                format!("`{t}` in a cycle definition: expected a parameter such as Q200=2"),
            ));
        };
        let value = if rest.is_empty() {
            match parts.get(k) {
                Some((_, value)) => {
                    k += 1;
                    *value
                }
                None => "",
            }
        } else {
            rest
        };
        let value = value.trim_end_matches('~');
        let Some((key, _)) = q_key(name.as_bytes()).filter(|(_, sign)| *sign == 1.0) else {
            return Err(at(
                col,
                format!(
                    "`{}` in a cycle definition: expected a Q parameter such as Q200",
                    if name.is_empty() { t } else { name }
                ),
            ));
        };
        if value.is_empty() || value.contains('=') {
            return Err(at(
                col,
                format!(
                    "`{}=` in a cycle definition: expected its value (a number, or a Q parameter)",
                    q_name(key)
                ),
            ));
        }
        out.push((key, value));
    }
    Ok(out)
}

/// The cycle a `CYCL DEF` block defines, however the control's spellings place the spaces
/// (`CYCL DEF 200`, `CYCL DEF9.0`, `CYCL DEF 9 .0`, `CYCL DEF9 .1`): its number, its
/// sub-block (`1` of `7.1`; empty for none), the index in `sig` of the token that names it,
/// and of the first token after the number. `None`: the block is not `CYCL DEF n`.
fn cycle_number<'a>(word: impl Fn(usize) -> &'a str) -> Option<(u32, &'a str, usize, usize)> {
    let (id, at, mut next) = match word(1) {
        "DEF" => (word(2), 2, 3),
        w => (w.strip_prefix("DEF")?, 1, 2),
    };
    let id = id.trim_end_matches('~');
    let (main, mut sub) = id.split_once('.').unwrap_or((id, ""));
    if !id.contains('.')
        && let Some(s) = word(next).trim_end_matches('~').strip_prefix('.')
        && !s.is_empty()
        && s.bytes().all(|b| b.is_ascii_digit())
    {
        sub = s;
        next += 1;
    }
    if main.is_empty() || !main.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    Some((main.parse().ok()?, sub, at, next))
}

/// What an `L` block's words ask for, beside its axis words.
#[derive(Default)]
struct LWords {
    rapid: bool,
    machine: Option<usize>,
    tcp_on: bool,
    tcp_off: Option<usize>,
    end: bool,
    call: Option<usize>,
    /// Rotary words given by Q120–Q122 after PLANE … STAY.
    plane_words: Vec<(usize, usize, u32)>,
    /// M140: a retraction along the tool axis.
    retract: Option<usize>,
    /// Its `MB MAX`.
    to_limit: bool,
}

impl Reader<'_> {
    /// Read one TNC block (see [`Reader::read`]).
    pub(super) fn read_tnc(
        &self,
        line: &nc::Line<'_>,
        tokens: &[Token],
        modal: &mut Modal,
        at: At<'_>,
        out: &mut BlockMotion,
    ) -> Result<bool, Diagnostic> {
        let mut tnc = modal.tnc.take().unwrap_or_default();
        let read = self.tnc_block(line.number, line.content, tokens, modal, &mut tnc, at, out);
        modal.tnc = Some(tnc);
        read
    }

    #[allow(clippy::too_many_arguments)]
    fn tnc_block(
        &self,
        number: usize,
        content: &[u8],
        tokens: &[Token],
        modal: &mut Modal,
        tnc: &mut Tnc,
        at: At<'_>,
        out: &mut BlockMotion,
    ) -> Result<bool, Diagnostic> {
        *out = BlockMotion::default();
        tnc.line = number;
        out.optional = tokens.iter().any(|t| t.kind == TokenKind::BlockDelete);
        let sig = significant(content, tokens);
        let word = |k: usize| sig.get(k).map_or("", |&i| text(content, &tokens[i]));
        let col = |k: usize| sig.get(k).map_or(0, |&i| tokens[i].span.start);
        if tnc.continued {
            tnc.continued = continues(content);
            if let Some(def) = tnc.defining.as_mut() {
                def.text.push(content.to_vec());
                for (key, value) in cycle_parameters(content, tokens, &sig, at)? {
                    let param = match value.parse::<f64>() {
                        Ok(v) if v.is_finite() => Param::Known(v),
                        _ => match q_key(value.as_bytes()) {
                            Some((k, sign)) => match tnc.q.get(&k) {
                                Some(v) => Param::Known(sign * v),
                                None => Param::Unknown(q_name(k)),
                            },
                            None => Param::Unknown(value.to_string()),
                        },
                    };
                    def.params.push((key, param));
                }
            }
            if !tnc.continued
                && let Some(def) = tnc.defining.take()
            {
                tnc.cycle = Some(def);
            }
            return Ok(false);
        }
        tnc.continued = continues(content);
        if sig.is_empty() {
            return Ok(false);
        }
        if let Some((target, from)) = &tnc.skip_to {
            // A jump taken in the main program: the lines up to its label do not run.
            if word(0) == "LBL" && label_name(content, tokens, &sig[1..]).as_ref() == Some(target) {
                tnc.skip_to = None;
                return Ok(false);
            }
            let words: Vec<&str> = sig.iter().map(|&i| text(content, &tokens[i])).collect();
            if (word(0) == "END" && word(1) == "PGM") || ends_program(&words) {
                return Err(at(
                    col(0),
                    format!(
                        "the jump at line {from} to LBL {target} runs past the program's end here: not followed (expected the label before the end)"
                    ),
                ));
            }
            return Ok(false);
        }
        // Past END PGM nothing belongs to the program: passed unchanged, and counted.
        if tnc.depth == 0 && modal.program_end.is_some() {
            modal.after_end += 1;
            return Ok(false);
        }
        if tnc.depth == 0 && word(0) == "END" && word(1) == "PGM" {
            modal.program_end = Some(number);
        }
        if let Some((end_line, optional)) = tnc.end {
            // Past M30 only labels follow, run when called; past an optional M30 the
            // control runs on into them with block skip on: they may set data, jump
            // within themselves, and must move nothing.
            if !optional || tnc.depth > 0 {
                return Ok(false);
            }
            let after_end = |line: usize| {
                format!(
                    "line {line} follows the optional program end at line {end_line} (/ M30): with block skip on the control runs it"
                )
            };
            if word(0) == "FN"
                && matches!(
                    word(1),
                    "9:" | "10:" | "11:" | "12:" | "9" | "10" | "11" | "12"
                )
            {
                let labels = tnc.labels.clone();
                let target = sig
                    .iter()
                    .rposition(|&i| text(content, &tokens[i]) == "LBL")
                    .and_then(|k| label_name(content, tokens, &sig[k + 1..]));
                return match target.as_ref().and_then(|t| labels.bodies.get(t)) {
                    Some(body) if body.line > end_line => Ok(false),
                    _ => Err(at(
                        col(0),
                        format!(
                            "{}, and it jumps to a label before that end (or one nccomp cannot find): not followed (expected the jump within the labels after M30)",
                            after_end(number)
                        ),
                    )),
                };
            }
            if word(0) == "LBL" {
                return Ok(false);
            }
            tnc.end = None;
            let read = self.tnc_block(number, content, tokens, modal, tnc, at, out);
            tnc.end = Some((end_line, optional));
            return match read {
                Ok(true) => Err(at(
                    col(0),
                    format!(
                        "{}, and this block moves the machine: not followed (expected M30 without /, or no moves after it)",
                        after_end(number)
                    ),
                )),
                other => other,
            };
        }
        match word(0) {
            "BEGIN" | "END" if word(1) == "PGM" => {
                let unit = sig.iter().rev().map(|&i| text(content, &tokens[i])).next();
                match unit {
                    Some("MM") => modal.inch = false,
                    Some("INCH") => modal.inch = true,
                    _ => {
                        return Err(at(
                            col(0),
                            "expected the program's unit (MM or INCH) at the end of BEGIN PGM / END PGM".into(),
                        ));
                    }
                }
                modal.units_stated = true;
                if word(0) == "END" {
                    tnc.end.get_or_insert((number, false));
                }
                Ok(false)
            }
            "BLK" | "LBL" | "STOP" => Ok(false),
            "TOOL" => self.tool(content, tokens, &sig, modal, at, out),
            "L" => self.straight(content, tokens, &sig, modal, tnc, at, out),
            "CC" => self
                .pole(content, tokens, &sig, modal, tnc, at)
                .map(|()| false),
            "C" | "CR" | "CP" => self.arc(content, tokens, &sig, modal, tnc, at, out),
            "CT" | "LP" | "RND" | "CHF" | "LN" | "SPL" | "CTP" | "LCT" => Err(at(
                col(0),
                format!(
                    "{} blocks (tangential arcs, polar lines, corners, vectors, splines) are not compensated in TNC programs: their geometry depends on the blocks around them (expected L, C, CR or CP)",
                    word(0)
                ),
            )),
            "CYCL" => self.cycle(number, content, tokens, &sig, modal, tnc, at, out),
            "PLANE" => self.plane(content, tokens, &sig, modal, tnc, at, out),
            "FUNCTION" => self.function(content, tokens, &sig, modal, at),
            "FN" => self.fn_statement(number, content, tokens, &sig, tnc, at),
            "CALL" => self.call(content, tokens, &sig, modal, tnc, at),
            _ if matches!(&tokens[sig[0]].kind, TokenKind::Word(w) if w.letter == b'M') => {
                // A block of M functions.
                let mut words = LWords::default();
                for &i in &sig {
                    self.m_word(content, tokens, i, &mut words, modal, at)?;
                }
                self.l_after(modal, tnc, &words, at, out)?;
                if let Some(i) = words.machine {
                    return Err(at(
                        tokens[i].span.start,
                        "M91/M92 without axis words: expected them in an L block".into(),
                    ));
                }
                if let Some(i) = words.call {
                    return self.cycle_call(tokens[i].span.start, modal, tnc, at, out);
                }
                Ok(false)
            }
            other => Err(at(
                col(0),
                format!(
                    "`{other}` is not a TNC statement nccomp reads (expected L, CYCL DEF, PLANE, FN, CALL LBL, TOOL CALL, FUNCTION TCPM, M functions, comments)"
                ),
            )),
        }
    }

    /// `CC X… Y…`: the circle centre (pole) in the plane of its two coordinates.
    fn pole(
        &self,
        content: &[u8],
        tokens: &[Token],
        sig: &[usize],
        modal: &Modal,
        tnc: &mut Tnc,
        at: At<'_>,
    ) -> Result<(), Diagnostic> {
        let mut xyz: [Option<f64>; 3] = [None; 3];
        for &i in &sig[1..] {
            let t = &tokens[i];
            match &t.kind {
                TokenKind::Word(w) if matches!(w.letter, b'X' | b'Y' | b'Z') => match w.value {
                    Value::Number { value, .. } if value.abs() <= MAX_WORD => {
                        xyz[(w.letter - b'X') as usize] = Some(value);
                    }
                    _ => {
                        return Err(at(
                            t.span.start,
                            format!(
                                "`{}`: the circle centre is decided at run time (expected a number)",
                                text(content, t)
                            ),
                        ));
                    }
                },
                _ => {
                    return Err(at(
                        t.span.start,
                        format!(
                            "`{}` in CC cannot be compensated (expected two of X, Y, Z with numbers; incremental and polar centres are not followed)",
                            text(content, t)
                        ),
                    ));
                }
            }
        }
        let (plane, centre) = match xyz {
            [Some(x), Some(y), None] => (0, [x, y]),
            [Some(x), None, Some(z)] => (1, [z, x]),
            [None, Some(y), Some(z)] => (2, [y, z]),
            _ => {
                return Err(at(
                    tokens[sig[0]].span.start,
                    "CC needs the centre's two coordinates in the plane of the arc (X and Y, Z and X, or Y and Z)".into(),
                ));
            }
        };
        tnc.poles += 1;
        tnc.pole = Some(Pole {
            plane,
            centre,
            frame: frame_of(modal, tnc),
            seq: tnc.poles,
        });
        Ok(())
    }

    /// `C X… Y… DR±` (about the pole), `CR X… Y… R± DR±`, `CP PA|IPA… DR±` (about the
    /// pole). The coordinate along the axis perpendicular to the arc's plane (`Z` for a
    /// pole in X-Y, absolute, or `IZ` in CP, from the start) makes a helix. Under a tilted
    /// working plane the words, the pole's among them, are in the plane's frame.
    #[allow(clippy::too_many_arguments)]
    fn arc(
        &self,
        content: &[u8],
        tokens: &[Token],
        sig: &[usize],
        modal: &mut Modal,
        tnc: &mut Tnc,
        at: At<'_>,
        out: &mut BlockMotion,
    ) -> Result<bool, Diagnostic> {
        let kind = text(content, &tokens[sig[0]]);
        let col0 = tokens[sig[0]].span.start;
        let axes = &self.chains[modal.chain];
        let (plane, centre) = match kind {
            "CR" => (0, None),
            _ => match tnc.pole {
                Some(pole) if pole.frame != frame_of(modal, tnc) => {
                    return Err(at(
                        col0,
                        format!(
                            "{kind} runs about the circle centre of the last CC, which was given in another frame (the working plane or datum shift has changed since, or tool-centre-point control was switched): where the control puts it is not followed (expected CC again after PLANE, CYCL DEF 7, M128/M129 or FUNCTION TCPM)"
                        ),
                    ));
                }
                Some(pole) => (pole.plane, Some(pole.centre)),
                None => {
                    return Err(at(
                        col0,
                        format!(
                            "{kind} needs a circle centre, and the program has given none (expected CC before it)"
                        ),
                    ));
                }
            },
        };
        let (letters, third) = match plane {
            0 => ([b'X', b'Y'], b'Z'),
            1 => ([b'Z', b'X'], b'Y'),
            _ => ([b'Y', b'Z'], b'X'),
        };
        let mut clockwise = None;
        let mut words = LWords::default();
        // R0, RL or RR in the block: the side (RL: left), and its column.
        let mut comp: Option<(Option<bool>, usize)> = None;
        for &i in &sig[1..] {
            let t = &tokens[i];
            let raw = text(content, t);
            match &t.kind {
                TokenKind::Word(w) if w.letter == b'M' => {
                    self.m_word(content, tokens, i, &mut words, modal, at)?;
                }
                TokenKind::Word(w) if w.letter == b'F' => {}
                TokenKind::Word(w) if w.letter == b'R' && kind == "CR" => {
                    if !matches!(w.value, Value::Number { value, .. } if value != 0.0 && value.abs() <= MAX_WORD)
                    {
                        return Err(at(
                            t.span.start,
                            format!("`{raw}`: expected the arc's radius as a number"),
                        ));
                    }
                    out.arc_words[3] = Some(i);
                }
                TokenKind::Word(w) if w.letter == b'R' => {
                    if w.value
                        != (Value::Number {
                            value: 0.0,
                            decimals: 0,
                        })
                    {
                        return Err(at(
                            t.span.start,
                            format!("`{raw}` in an arc: expected R0, RL or RR"),
                        ));
                    }
                    comp = Some((None, t.span.start));
                }
                TokenKind::Word(w)
                    if (letters.contains(&w.letter) && kind != "CP") || w.letter == third =>
                {
                    let Some(v) = axes.linear_of(w.letter) else {
                        return Err(at(
                            t.span.start,
                            format!("{} is not an axis of this machine", w.letter as char),
                        ));
                    };
                    match w.value {
                        Value::Number { value, .. } if value.abs() <= MAX_WORD => {}
                        _ => {
                            return Err(at(
                                t.span.start,
                                format!(
                                    "`{raw}`: the arc's end is decided at run time (expected a number)"
                                ),
                            ));
                        }
                    }
                    if out.axis_words[v].is_some() || out.lead.is_some() {
                        return Err(at(
                            t.span.start,
                            format!("`{raw}`: the arc's {} is given twice", w.letter as char),
                        ));
                    }
                    out.axis_words[v] = Some(i);
                }
                TokenKind::Word(w) => {
                    let expected = if kind == "CP" {
                        format!("PA or IPA, and {t} or I{t} for a helix", t = third as char)
                    } else {
                        format!(
                            "the end's {} and {}, and {} for a helix",
                            letters[0] as char, letters[1] as char, third as char
                        )
                    };
                    return Err(at(
                        t.span.start,
                        format!(
                            "{} in a {kind} arc about a centre in {}-{} cannot be compensated (expected {expected})",
                            w.letter as char, letters[0] as char, letters[1] as char
                        ),
                    ));
                }
                _ => match raw {
                    "DR+" => clockwise = Some(false),
                    "DR-" => clockwise = Some(true),
                    "FMAX" | "FAUTO" => {}
                    "RL" | "RR" => comp = Some((Some(raw == "RL"), t.span.start)),
                    _ if kind == "CP" && (raw.starts_with("IPA") || raw.starts_with("PA")) => {
                        let incremental = raw.starts_with('I');
                        let value = &raw[if incremental { 3 } else { 2 }..];
                        // An incremental angle (a helix's) may turn 15 times (±5400°, the
                        // control's input range); an absolute one at most once.
                        let limit = if incremental { 5400.0 } else { 360.0 };
                        match value.parse::<f64>() {
                            Ok(angle) if angle.is_finite() && angle.abs() <= limit => {
                                out.polar = Some((angle, incremental));
                            }
                            _ => {
                                return Err(at(
                                    t.span.start,
                                    format!(
                                        "`{raw}`: expected the polar angle in degrees, a number within ±{limit}"
                                    ),
                                ));
                            }
                        }
                    }
                    _ if kind == "CP"
                        && raw.len() > 2
                        && raw.as_bytes()[0] == b'I'
                        && raw.as_bytes()[1] == third =>
                    {
                        let value = raw[2..].parse::<f64>();
                        let lead = match value {
                            Ok(x) if x.is_finite() && x.abs() <= MAX_WORD => x,
                            _ => {
                                return Err(at(
                                    t.span.start,
                                    format!(
                                        "`{raw}`: expected the helix's height along {} as a number",
                                        third as char
                                    ),
                                ));
                            }
                        };
                        if axes.linear_of(third).is_none() {
                            return Err(at(
                                t.span.start,
                                format!("{} is not an axis of this machine", third as char),
                            ));
                        }
                        let given = axes
                            .linear_of(third)
                            .is_some_and(|v| out.axis_words[v].is_some());
                        if given || out.lead.is_some() {
                            return Err(at(
                                t.span.start,
                                format!("`{raw}`: the arc's {} is given twice", third as char),
                            ));
                        }
                        out.lead = Some(if modal.inch { lead * super::INCH } else { lead });
                    }
                    _ => {
                        return Err(at(
                            t.span.start,
                            format!(
                                "`{raw}` is not expected in a {kind} arc (expected its end, DR+ or DR-, F, R0, RL or RR)"
                            ),
                        ));
                    }
                },
            }
        }
        let Some(clockwise) = clockwise else {
            return Err(at(
                col0,
                format!("{kind} needs its direction: DR+ (counter-clockwise) or DR- (clockwise)"),
            ));
        };
        match out.polar {
            None if kind == "CP" => {
                return Err(at(col0, "CP needs its polar angle (PA or IPA)".into()));
            }
            // An incremental angle turns the way its sign says; DR must agree.
            Some((angle, true)) if angle == 0.0 || (angle < 0.0) != clockwise => {
                return Err(at(
                    col0,
                    format!(
                        "CP with IPA{angle:+} and DR{}: expected an incremental polar angle other than 0 whose sign is the direction's (IPA+ with DR+, IPA- with DR-)",
                        if clockwise { '-' } else { '+' }
                    ),
                ));
            }
            _ => {}
        }
        if kind == "CR" && out.arc_words[3].is_none() {
            return Err(at(col0, "CR needs its radius R".into()));
        }
        if words.machine.is_some()
            || words.call.is_some()
            || words.tcp_on
            || words.tcp_off.is_some()
        {
            return Err(at(
                col0,
                format!(
                    "M91, M92, M99, M128 or M129 in a {kind} arc cannot be compensated (expected them in an L block)"
                ),
            ));
        }
        if words.end {
            tnc.end = Some((tnc.line, out.optional));
        }
        modal.plane = plane;
        modal.motion = Some(Motion::Arc);
        modal.rapid = false;
        modal.clockwise = clockwise;
        modal.arc_absolute = true;
        radius_comp(modal, comp, true, at)?;
        out.centre = centre.map(|[a, b]| {
            if modal.inch {
                [a * super::INCH, b * super::INCH]
            } else {
                [a, b]
            }
        });
        out.arc_code = Some(sig[0]);
        out.kind = MoveKind::Arc { clockwise };
        Ok(true)
    }

    /// `TOOL CALL n Z S… DL…`, `TOOL CALL "name" …`: the called tool's length (the
    /// machine file's `[tool]` lengths by number, `named_lengths` by name; a tool whose
    /// length is not given is refused) plus DL. A call of a tool by number or name is a
    /// tool change: the axes of the machine file's `change_moves` (default Z) go to the
    /// change position and are unknown after it (true: the block moves them).
    fn tool(
        &self,
        content: &[u8],
        tokens: &[Token],
        sig: &[usize],
        modal: &mut Modal,
        at: At<'_>,
        out: &mut BlockMotion,
    ) -> Result<bool, Diagnostic> {
        let word = |k: usize| sig.get(k).map_or("", |&i| text(content, &tokens[i]));
        match word(1) {
            "DEF" => return Ok(false),
            "CALL" => {}
            _ => {
                return Err(at(
                    tokens[sig[0]].span.start,
                    "expected TOOL CALL or TOOL DEF".into(),
                ));
            }
        }
        if modal.tcp {
            return Err(at(
                tokens[sig[0]].span.start,
                "TOOL CALL under tool-centre-point control (M128, FUNCTION TCPM) cannot be compensated (expected M129 or FUNCTION RESET TCPM before it)".into(),
            ));
        }
        let mut delta = 0.0;
        let mut delta_col = None;
        // DR: the radius's delta (mm).
        let mut delta_r = 0.0;
        // The tool called: by number or by name, and the column of its word.
        let mut number = None;
        let mut name = None;
        let mut called_at = None;
        for &i in &sig[2..] {
            let t = text(content, &tokens[i]);
            if let Ok(n) = t.parse::<u32>() {
                number = Some(n);
                called_at = Some(tokens[i].span.start);
                continue;
            }
            if t.len() >= 2 && t.starts_with('"') && t.ends_with('"') {
                name = Some(&t[1..t.len() - 1]);
                called_at = Some(tokens[i].span.start);
                continue;
            }
            if let Some(dl) = t.strip_prefix("DL") {
                let Ok(dl) = dl.parse::<f64>() else {
                    return Err(at(
                        tokens[i].span.start,
                        format!("`{t}`: expected the length's delta as a number (DL+0.5)"),
                    ));
                };
                delta += if modal.inch { dl * super::INCH } else { dl };
                delta_col = Some(tokens[i].span.start);
                continue;
            }
            if let Some(dr) = t.strip_prefix("DR")
                && dr.starts_with(['+', '-'])
            {
                let Ok(dr) = dr.parse::<f64>() else {
                    return Err(at(
                        tokens[i].span.start,
                        format!("`{t}`: expected the radius's delta as a number (DR+0.1)"),
                    ));
                };
                delta_r += if modal.inch { dr * super::INCH } else { dr };
                continue;
            }
            if matches!(t, "X" | "Y") {
                return Err(at(
                    tokens[i].span.start,
                    format!("a tool axis {t} cannot be compensated (expected Z)"),
                ));
            }
        }
        let tool = &self.machine.tool;
        let base = match (number, name) {
            (Some(n), _) => *tool.lengths.get(&n).ok_or_else(|| {
                at(
                    called_at.unwrap_or(0),
                    format!(
                        "tool {n} has no length in the machine file (expected it in [tool] lengths, which lists {}): where its tip is, and so the correction, depends on it",
                        listed(tool.lengths.keys().map(u32::to_string))
                    ),
                )
            })?,
            (None, Some(name)) => *tool.named_lengths.get(name).ok_or_else(|| {
                at(
                    called_at.unwrap_or(0),
                    format!(
                        "tool \"{name}\" has no length in the machine file (expected it in [tool] named_lengths, which lists {}): where its tip is, and so the correction, depends on it",
                        listed(tool.named_lengths.keys().map(|k| format!("\"{k}\"")))
                    ),
                )
            })?,
            // No tool called: the tool in the spindle stays, with its length.
            (None, None) => {
                if delta_r != 0.0 {
                    // Which tool's radius DR adds to is the control's state: only a bound
                    // for any tool still holds.
                    modal.tool_radius = tool.max_radius.map(|r| super::ToolRadius {
                        radius: r + delta_r.abs(),
                        source: super::RadiusSource::Max,
                    });
                }
                if let Some(col) = delta_col {
                    return Err(at(
                        col,
                        "a length delta (DL) in a TOOL CALL that names no tool cannot be compensated: which tool's length it adds to is the control's state (expected TOOL CALL with the tool's number or name)".into(),
                    ));
                }
                return Ok(false);
            }
        };
        modal.length = base + delta;
        modal.tool = number;
        // The radius RL/RR offsets by: the tool's own plus DR, or a bound for any tool.
        let own = match (number, name) {
            (Some(n), _) => tool
                .radii
                .get(&n)
                .map(|&r| (r, super::RadiusSource::Number)),
            (None, Some(name)) => tool
                .named_radii
                .get(name)
                .map(|&r| (r, super::RadiusSource::Name)),
            (None, None) => None,
        };
        modal.tool_radius = match own {
            Some((r, source)) => Some(super::ToolRadius {
                radius: (r + delta_r).abs(),
                source,
            }),
            None => tool.max_radius.map(|r| super::ToolRadius {
                radius: r + delta_r.abs(),
                source: super::RadiusSource::Max,
            }),
        };
        // The change moves the machine file's `change_moves` axes.
        let axes = self.axes(modal.chain);
        let letters = tool.change_moves;
        let homed = (0..26u8)
            .filter(|&l| letters & 1 << l != 0)
            .filter_map(|l| axes.var_of_letter[l as usize])
            .fold(0u32, |m, v| m | 1 << v);
        if homed == 0 {
            return Ok(false);
        }
        out.kind = MoveKind::Home;
        out.homed = homed;
        Ok(true)
    }

    /// An `L` block.
    #[allow(clippy::too_many_arguments)]
    fn straight(
        &self,
        content: &[u8],
        tokens: &[Token],
        sig: &[usize],
        modal: &mut Modal,
        tnc: &mut Tnc,
        at: At<'_>,
        out: &mut BlockMotion,
    ) -> Result<bool, Diagnostic> {
        let axes = &self.chains[modal.chain];
        let mut words = LWords::default();
        // R0, RL or RR in the block: the side (RL: left), and its column.
        let mut comp: Option<(Option<bool>, usize)> = None;
        let mut k = 1;
        while k < sig.len() {
            let i = sig[k];
            let t = &tokens[i];
            let at_t = t.span.start;
            let raw = text(content, t);
            k += 1;
            match &t.kind {
                TokenKind::Word(w) if w.letter == b'M' => {
                    self.m_word(content, tokens, i, &mut words, modal, at)?;
                }
                TokenKind::Word(w) if w.letter == b'F' => words.rapid = false,
                TokenKind::Word(w) if w.letter == b'R' => {
                    if w.value
                        != (Value::Number {
                            value: 0.0,
                            decimals: 0,
                        })
                    {
                        return Err(at(
                            at_t,
                            format!("`{raw}` in an L block: expected R0, RL or RR"),
                        ));
                    }
                    comp = Some((None, at_t));
                }
                TokenKind::Word(w) => {
                    let Some(v) = axes.var_of_letter[(w.letter - b'A') as usize] else {
                        return Err(at(
                            at_t,
                            format!(
                                "{} is not an axis of this machine (expected {} words)",
                                w.letter as char,
                                String::from_utf8_lossy(&axes.letters)
                            ),
                        ));
                    };
                    match w.value {
                        Value::Number { value, .. }
                            if value.is_finite() && value.abs() <= MAX_WORD => {}
                        Value::Number { .. } => {
                            return Err(at(
                                at_t,
                                format!(
                                    "{} is out of range: expected a number within ±{MAX_WORD:e}",
                                    w.letter as char
                                ),
                            ));
                        }
                        _ => {
                            let q = q_key(&content[w.value_span.clone()]);
                            match q {
                                Some((key @ 120..=122, 1.0))
                                    if tnc.plane_angles && !axes.is_linear(v) =>
                                {
                                    words.plane_words.push((i, v, key));
                                }
                                Some((key, _)) if (120..=122).contains(&key) => {
                                    return Err(at(
                                        at_t,
                                        format!(
                                            "{} is given by {}, the angle the control computed for a PLANE … STAY: nccomp follows it only in the L block right after that PLANE, as the rotary axis it belongs to, with a + sign",
                                            w.letter as char,
                                            q_name(key)
                                        ),
                                    ));
                                }
                                Some((key, _)) => {
                                    return Err(at(
                                        at_t,
                                        format!(
                                            "{} is given by {}, which the program never sets to a constant before this block: its value is decided at run time (expected a number, or FN 0: {}=… earlier)",
                                            w.letter as char,
                                            q_name(key),
                                            q_name(key)
                                        ),
                                    ));
                                }
                                None => {
                                    return Err(at(at_t, format!("`{raw}`: expected a number")));
                                }
                            }
                            continue;
                        }
                    }
                    if out.axis_words[v].is_some() {
                        return Err(at(at_t, format!("{} is given twice", w.letter as char)));
                    }
                    out.axis_words[v] = Some(i);
                }
                _ => match raw {
                    "FMAX" => words.rapid = true,
                    "F" if sig
                        .get(k)
                        .is_some_and(|&j| text(content, &tokens[j]) == "MAX") =>
                    {
                        words.rapid = true;
                        k += 1;
                    }
                    "FAUTO" | "F" => words.rapid = false,
                    "MB" if words.retract.is_some()
                        && sig
                            .get(k)
                            .is_some_and(|&j| text(content, &tokens[j]) == "MAX") =>
                    {
                        words.to_limit = true;
                        k += 1;
                    }
                    "RL" | "RR" => comp = Some((Some(raw == "RL"), at_t)),
                    _ if raw.len() > 1
                        && raw.starts_with('I')
                        && raw.as_bytes()[1].is_ascii_uppercase() =>
                    {
                        return Err(at(
                            at_t,
                            format!(
                                "incremental words ({raw}) are not compensated in TNC programs yet (expected absolute coordinates)"
                            ),
                        ));
                    }
                    _ => {
                        return Err(at(
                            at_t,
                            format!(
                                "`{raw}` is not expected in an L block (expected axis words, R0, F or FMAX, M functions)"
                            ),
                        ));
                    }
                },
            }
        }
        // FMAX holds for its block only; F is modal.
        modal.rapid = words.rapid;
        modal.motion = Some(Motion::Line);
        self.l_after(modal, tnc, &words, at, out)?;
        radius_comp(modal, comp, false, at)?;
        let n = axes.len();
        let moves = out.axis_words[..n].iter().any(Option::is_some);
        if !words.plane_words.is_empty() {
            if let Some(i) = out.axis_words[..n].iter().flatten().next() {
                return Err(at(
                    tokens[*i].span.start,
                    "axis words beside the rotary angles of a PLANE … STAY: expected the rotary axes alone (L A+Q120 C+Q122)".into(),
                ));
            }
            for &(i, v, key) in &words.plane_words {
                let expected = match axes.letters[v] {
                    b'A' => 120,
                    b'B' => 121,
                    b'C' => 122,
                    _ => 0,
                };
                if key != expected {
                    return Err(at(
                        tokens[i].span.start,
                        format!(
                            "{} is given by {}, which the control sets to the angle of axis {}",
                            axes.letters[v] as char,
                            q_name(key),
                            ["A", "B", "C"][(key - 120) as usize]
                        ),
                    ));
                }
            }
            let given: u32 = words.plane_words.iter().fold(0, |m, &(_, v, _)| m | 1 << v);
            let rotary: u32 = (0..n)
                .filter(|&v| !axes.is_linear(v))
                .fold(0, |m, v| m | 1 << v);
            if given != rotary {
                return Err(at(
                    tokens[words.plane_words[0].0].span.start,
                    "this block positions only some of the rotary axes the PLANE turns: expected a word for each (L A+Q120 C+Q122)".into(),
                ));
            }
            tnc.plane_angles = false;
            if let Some(plane) = modal.working_plane.as_mut() {
                plane.tilted = true;
            }
            out.kind = MoveKind::ToPlane;
            out.arc_code = Some(words.plane_words[0].0);
            return Ok(true);
        }
        if let Some(i) = words.call {
            if words.machine.is_some() {
                return Err(at(tokens[i].span.start, "M99 with M91/M92 cannot be compensated (expected the hole's position in program coordinates)".into()));
            }
            if let Some((v, j)) = (0..n)
                .filter_map(|v| out.axis_words[v].map(|j| (v, j)))
                .find(|&(v, _)| !matches!(axes.letters[v], b'X' | b'Y'))
            {
                return Err(at(
                    tokens[j].span.start,
                    format!(
                        "{} in a block that calls a cycle (M99): expected the hole's X and Y only (the cycle moves along the tool axis from its own levels)",
                        axes.letters[v] as char
                    ),
                ));
            }
            return self.cycle_call(tokens[i].span.start, modal, tnc, at, out);
        }
        if let Some(i) = words.tcp_off
            && moves
        {
            return Err(at(
                tokens[i].span.start,
                "M129 in a block that moves cannot be compensated (expected M129 in a block of its own)".into(),
            ));
        }
        if let Some(i) = words.retract {
            let at_t = tokens[i].span.start;
            if moves || !words.to_limit {
                return Err(at(at_t, "M140 is followed only as `L M140 MB MAX` in a block of its own (a retraction to the tool axis's travel limit)".into()));
            }
            if modal.working_plane.is_some() || modal.tcp {
                return Err(at(at_t, "M140 under a tilted working plane or tool-centre-point control retracts along a tilted tool axis: not followed (expected it after PLANE RESET and M129)".into()));
            }
            // The tool axis goes to its travel limit: a machine position.
            let Some(z) = axes.linear_of(b'Z') else {
                return Err(at(
                    at_t,
                    "M140 retracts along Z, and this machine has no Z axis".into(),
                ));
            };
            out.kind = MoveKind::Home;
            out.homed = 1 << z;
            return Ok(true);
        }
        if words.machine.is_some() {
            if modal.working_plane.is_some_and(|p| !p.rotation_only) || modal.tcp {
                return Err(at(
                    tokens[words.machine.unwrap_or(0)].span.start,
                    "M91/M92 under a tilted plane or tool-centre-point control cannot be compensated (expected them after PLANE RESET and M129)".into(),
                ));
            }
            if !moves {
                return Ok(false);
            }
            out.kind = MoveKind::Machine;
            out.from_m92 = words
                .machine
                .is_some_and(|i| text(content, &tokens[i]).ends_with("92"));
            return Ok(true);
        }
        if !moves {
            return Ok(false);
        }
        out.kind = MoveKind::Program;
        Ok(true)
    }

    /// One M word of a block.
    fn m_word(
        &self,
        content: &[u8],
        tokens: &[Token],
        i: usize,
        words: &mut LWords,
        modal: &mut Modal,
        at: At<'_>,
    ) -> Result<(), Diagnostic> {
        let t = &tokens[i];
        let TokenKind::Word(w) = &t.kind else {
            return Ok(());
        };
        let raw = text(content, t);
        let Value::Number { value, .. } = w.value else {
            return Err(at(
                t.span.start,
                format!("`{raw}`: expected an M function's number"),
            ));
        };
        if value.fract() != 0.0 || !(0.0..1e4).contains(&value) {
            return Err(at(
                t.span.start,
                format!("`{raw}`: expected an M function's number"),
            ));
        }
        match value as u32 {
            // Stops, spindle, coolant, tool change, feed rate modes, shortest path.
            0 | 1 | 3 | 4 | 5 | 6 | 7 | 8 | 9 | 13 | 14 | 109 | 110 | 111 | 116 | 117 | 126
            | 127 | 136 | 137 | 148 | 149 => {}
            2 | 30 => words.end = true,
            91 | 92 => words.machine = Some(i),
            99 => words.call = Some(i),
            128 => {
                words.tcp_on = true;
                modal.tcp = true;
                modal.tcp_vector = false;
            }
            129 => words.tcp_off = Some(i),
            140 => words.retract = Some(i),
            code => {
                let name = CodeName {
                    letter: b'M',
                    code10: i64::from(code) * 10,
                };
                match self.machine.codes.meaning(name) {
                    Some(super::Code::Harmless) => {}
                    _ => {
                        return Err(at(
                            t.span.start,
                            format!(
                                "M{code} is not an M function nccomp follows in TNC programs (expected M0–M9, M13, M14, M30, M91, M92, M99, M126–M129 …, or the code named harmless under [codes] in the machine file)"
                            ),
                        ));
                    }
                }
            }
        }
        Ok(())
    }

    /// What an L or M block's functions do after its words: TCP off, the program's end.
    fn l_after(
        &self,
        modal: &mut Modal,
        tnc: &mut Tnc,
        words: &LWords,
        _at: At<'_>,
        _out: &mut BlockMotion,
    ) -> Result<(), Diagnostic> {
        if words.tcp_off.is_some() && !words.tcp_on {
            modal.tcp = false;
            modal.tcp_vector = false;
        }
        if words.end {
            tnc.end = Some((tnc.line, _out.optional));
        }
        Ok(())
    }

    /// `CYCL DEF …` and `CYCL CALL`.
    #[allow(clippy::too_many_arguments)]
    fn cycle(
        &self,
        number: usize,
        content: &[u8],
        tokens: &[Token],
        sig: &[usize],
        modal: &mut Modal,
        tnc: &mut Tnc,
        at: At<'_>,
        out: &mut BlockMotion,
    ) -> Result<bool, Diagnostic> {
        let word = |k: usize| sig.get(k).map_or("", |&i| text(content, &tokens[i]));
        let col = |k: usize| sig.get(k).map_or(0, |&i| tokens[i].span.start);
        if word(1) == "CALL" {
            if sig.len() > 2 {
                return Err(at(
                    col(2),
                    format!(
                        "CYCL CALL {} cannot be compensated yet (expected CYCL CALL on its own, or M99)",
                        word(2)
                    ),
                ));
            }
            return self.cycle_call(col(0), modal, tnc, at, out);
        }
        if !word(1).starts_with("DEF") {
            return Err(at(col(1), "expected CYCL DEF or CYCL CALL".into()));
        }
        let Some((cycle, sub, id, next)) = cycle_number(word) else {
            let (c, id) = match word(1) {
                "DEF" if sig.len() > 2 => (col(2), word(2)),
                "DEF" => (col(1), ""),
                w => (col(1) + 3, &w[3..]),
            };
            let what = if id.is_empty() {
                String::new()
            } else {
                format!("`{id}`: ")
            };
            return Err(at(
                c,
                format!("{what}expected a cycle number after CYCL DEF (such as 200 or 7.1)"),
            ));
        };
        match cycle {
            7 => self.datum_shift(
                content,
                tokens,
                &sig[next.min(sig.len())..],
                sub,
                modal,
                tnc,
                at,
            ),
            // The dwell time (9) acts where it is defined, and the control never calls it:
            // the drilling cycle defined before it stays the one M99 and CYCL CALL call.
            // Tolerance (32) and the dynamic tuning cycles (332, 392) move nothing and
            // transform nothing.
            9 | 32 | 332 | 392 => {
                if tnc.continued {
                    tnc.defining = None;
                }
                Ok(false)
            }
            8 | 10 | 11 | 19 | 26 | 247 => Err(at(
                col(id),
                format!(
                    "CYCL DEF {cycle} ({}) is not followed by nccomp (expected PLANE for tilting, CYCL DEF 7 for datum shifts)",
                    match cycle {
                        8 => "mirror image",
                        10 => "rotation",
                        11 | 26 => "scaling",
                        19 => "working plane",
                        _ => "preset",
                    }
                ),
            )),
            _ => {
                // Drilling cycles (200–209) and the others, which are refused when
                // called (`drilling_levels`).
                let def = CycleDef {
                    number: cycle,
                    line: number,
                    params: Vec::new(),
                    text: vec![content.to_vec()],
                    surface_written: None,
                    siemens: None,
                };
                if tnc.continued {
                    tnc.defining = Some(def);
                } else {
                    tnc.cycle = Some(def);
                }
                Ok(false)
            }
        }
    }

    /// M99 or CYCL CALL: the drilling cycle defined last, at the block's X, Y (or where
    /// the tool stands).
    fn cycle_call(
        &self,
        col: usize,
        modal: &mut Modal,
        tnc: &mut Tnc,
        at: At<'_>,
        out: &mut BlockMotion,
    ) -> Result<bool, Diagnostic> {
        let Some(def) = &tnc.cycle else {
            return Err(at(
                col,
                "a cycle call, but no cycle is defined (expected CYCL DEF before it)".into(),
            ));
        };
        super::tnc_cycles::reach(def, modal.inch).map_err(|why| {
            at(
                col,
                format!(
                    "the call of cycle {} (defined at line {}) cannot be compensated: {why}",
                    def.number, def.line
                ),
            )
        })?;
        if modal.tcp {
            return Err(at(col, "a cycle call under tool-centre-point control (M128, FUNCTION TCPM) cannot be compensated (expected M129 or FUNCTION RESET TCPM before it)".into()));
        }
        out.kind = MoveKind::Cycle;
        out.cycle_col = Some(col);
        Ok(true)
    }

    /// `CYCL DEF 7.n X… Y… Z…` (`words`: the tokens after the cycle number): the datum
    /// shift, in the working plane in force.
    #[allow(clippy::too_many_arguments)]
    fn datum_shift(
        &self,
        content: &[u8],
        tokens: &[Token],
        words: &[usize],
        sub: &str,
        modal: &mut Modal,
        tnc: &mut Tnc,
        at: At<'_>,
    ) -> Result<bool, Diagnostic> {
        if sub == "0" || sub.is_empty() {
            return Ok(false);
        }
        for &i in words {
            let t = &tokens[i];
            let raw = text(content, t);
            let (c, value) = match &t.kind {
                TokenKind::Word(w) if matches!(w.letter, b'X' | b'Y' | b'Z') => match w.value {
                    Value::Number { value, .. } if value.abs() <= MAX_WORD => {
                        ((w.letter - b'X') as usize, value)
                    }
                    _ => {
                        return Err(at(
                            t.span.start,
                            format!(
                                "`{raw}`: the datum shift is decided at run time (expected a number, or a Q parameter set to a constant)"
                            ),
                        ));
                    }
                },
                _ => {
                    return Err(at(
                        t.span.start,
                        format!(
                            "`{raw}` in a datum shift cannot be compensated (expected X, Y or Z with a number; incremental and rotary shifts are not followed)"
                        ),
                    ));
                }
            };
            let value = if modal.inch {
                value * super::INCH
            } else {
                value
            };
            match modal.working_plane.as_mut() {
                // In a tilted plane the shift is along the plane's axes.
                Some(plane) if !plane.rotation_only => {
                    let mut d = plane.rotation.inverse() * plane.origin;
                    d[c] = value;
                    plane.origin = plane.rotation * d;
                    tnc.datum = plane.origin.into();
                }
                _ => {
                    tnc.datum[c] = value;
                    modal.local_shift = tnc.datum;
                    modal.shift = modal.shift_from(self.machine);
                }
            }
        }
        Ok(false)
    }

    /// `PLANE SPATIAL … STAY|TURN …` and `PLANE RESET`.
    #[allow(clippy::too_many_arguments)]
    fn plane(
        &self,
        content: &[u8],
        tokens: &[Token],
        sig: &[usize],
        modal: &mut Modal,
        tnc: &mut Tnc,
        at: At<'_>,
        out: &mut BlockMotion,
    ) -> Result<bool, Diagnostic> {
        let word = |k: usize| sig.get(k).map_or("", |&i| text(content, &tokens[i]));
        let col = |k: usize| sig.get(k).map_or(0, |&i| tokens[i].span.start);
        if modal.tcp {
            return Err(at(
                col(0),
                "PLANE under tool-centre-point control (M128, FUNCTION TCPM) cannot be compensated (expected M129 or FUNCTION RESET TCPM before it)".into(),
            ));
        }
        let mut turn = None;
        let mut sequence = None;
        let mut table_rot = false;
        let kind = word(1);
        let reset = kind == "RESET";
        // The values each form takes: spatial angles, Euler angles, or the plane's X axis
        // (base) and normal vectors.
        let keys: &[&str] = match kind {
            "SPATIAL" | "RELATIV" => &["SPA", "SPB", "SPC"],
            "EULER" => &["EULPR", "EULNU", "EULROT"],
            "VECTOR" => &["BX", "BY", "BZ", "NX", "NY", "NZ"],
            "RESET" => &[],
            _ => {
                return Err(at(
                    col(1),
                    format!(
                        "PLANE {kind} is not followed by nccomp (expected PLANE SPATIAL, EULER, VECTOR, RELATIV or RESET)"
                    ),
                ));
            }
        };
        let mut values: [Option<f64>; 6] = [None; 6];
        let mut k = 2;
        while k < sig.len() {
            let t = word(k);
            let c = col(k);
            k += 1;
            if let Some((slot, value)) = keys
                .iter()
                .enumerate()
                .find_map(|(a, p)| t.strip_prefix(p).map(|v| (a, v)))
            {
                let limit = if kind == "VECTOR" { MAX_WORD } else { 360.0 };
                let value = match value.parse::<f64>() {
                    Ok(v) if v.is_finite() && v.abs() <= limit => v,
                    _ => match q_key(value.as_bytes())
                        .and_then(|(key, sign)| tnc.q.get(&key).map(|v| sign * v))
                    {
                        Some(v) => v,
                        None => {
                            return Err(at(
                                c,
                                format!(
                                    "`{t}`: expected a number (an angle in degrees, or a vector's component), or a Q parameter set to a constant"
                                ),
                            ));
                        }
                    },
                };
                values[slot] = Some(value);
                continue;
            }
            match t {
                "STAY" => turn = Some(false),
                "TURN" => turn = Some(true),
                "MOVE" => {
                    return Err(at(c, "PLANE … MOVE turns the rotary axes and moves the tool with them, about a point at DIST: not followed by nccomp (expected STAY or TURN)".into()));
                }
                "SEQ+" => sequence = Some(true),
                "SEQ-" => sequence = Some(false),
                "TABLE" if word(k) == "ROT" => {
                    table_rot = true;
                    k += 1;
                }
                "COORD" if word(k) == "ROT" => {
                    table_rot = false;
                    k += 1;
                }
                "FMAX" => {}
                "F" if word(k) == "MAX" => k += 1,
                _ if t.starts_with('F') => {}
                _ if t.starts_with("MB") || t.starts_with("DIST") => {
                    return Err(at(
                        c,
                        format!(
                            "`{t}` (a retraction or distance of the tilting move) is not followed by nccomp (expected STAY or TURN without it)"
                        ),
                    ));
                }
                _ => {
                    return Err(at(
                        c,
                        format!(
                            "`{t}` is not expected in PLANE {} (expected SPA SPB SPC, STAY or TURN, SEQ+ or SEQ-, TABLE ROT or COORD ROT)",
                            word(1)
                        ),
                    ));
                }
            }
        }
        tnc.plane_angles = false;
        if reset {
            if turn == Some(true) {
                return Err(at(col(0), "PLANE RESET TURN turns the rotary axes to their home positions: not followed by nccomp (expected PLANE RESET STAY and an L block for the rotary axes)".into()));
            }
            modal.working_plane = None;
            modal.local_shift = tnc.datum;
            modal.shift = modal.shift_from(self.machine);
            return Ok(false);
        }
        let Some(turn) = turn else {
            return Err(at(col(0), format!("expected STAY or TURN in PLANE {kind}")));
        };
        if modal.working_plane.is_some_and(|p| p.rotation_only) {
            return Err(at(
                col(0),
                "PLANE under a coordinate rotation cannot be compensated".into(),
            ));
        }
        let all = |n: usize, what: &str| -> Result<Vec<f64>, Diagnostic> {
            values[..n]
                .iter()
                .map(|v| v.ok_or_else(|| at(col(0), format!("PLANE {kind} needs {what}"))))
                .collect()
        };
        let mut plane = match kind {
            "SPATIAL" => {
                let v = all(3, "all three spatial angles SPA, SPB and SPC")?;
                WorkingPlane::spatial(tnc.datum, [v[0], v[1], v[2]])
            }
            "EULER" => {
                let v = all(3, "all three Euler angles EULPR, EULNU and EULROT")?;
                WorkingPlane::new(tnc.datum, [v[0], v[1], v[2]])
            }
            "VECTOR" => {
                let v = all(6, "the base vector BX BY BZ and the normal vector NX NY NZ")?;
                WorkingPlane::vectors(tnc.datum, [v[0], v[1], v[2]], [v[3], v[4], v[5]])
                    .ok_or_else(|| {
                        at(
                            col(0),
                            "PLANE VECTOR needs a normal vector and a base vector not along it"
                                .into(),
                        )
                    })?
            }
            _ => {
                // RELATIV: one spatial angle about an axis of the plane in force.
                let given: Vec<(usize, f64)> = values[..3]
                    .iter()
                    .enumerate()
                    .filter_map(|(a, v)| v.map(|v| (a, v)))
                    .collect();
                let [(axis, angle)] = given[..] else {
                    return Err(at(
                        col(0),
                        "PLANE RELATIV needs exactly one of SPA, SPB, SPC".into(),
                    ));
                };
                let base = modal
                    .working_plane
                    .unwrap_or_else(|| WorkingPlane::spatial(tnc.datum, [0.0; 3]));
                base.turned(axis, angle)
            }
        };
        plane.sequence = sequence;
        plane.table_rot = table_rot;
        modal.working_plane = Some(plane);
        modal.local_shift = [0.0; 3];
        modal.shift = modal.shift_from(self.machine);
        if turn {
            if let Some(p) = modal.working_plane.as_mut() {
                p.tilted = true;
            }
            out.kind = MoveKind::ToPlane;
            out.arc_code = Some(sig[0]);
            return Ok(true);
        }
        tnc.plane_angles = true;
        Ok(false)
    }

    /// `FUNCTION TCPM …` and `FUNCTION RESET TCPM`.
    fn function(
        &self,
        content: &[u8],
        tokens: &[Token],
        sig: &[usize],
        modal: &mut Modal,
        at: At<'_>,
    ) -> Result<bool, Diagnostic> {
        let word = |k: usize| sig.get(k).map_or("", |&i| text(content, &tokens[i]));
        let col = |k: usize| sig.get(k).map_or(0, |&i| tokens[i].span.start);
        match (word(1), word(2)) {
            ("RESET", "TCPM") => {
                modal.tcp = false;
                modal.tcp_vector = false;
                Ok(false)
            }
            ("TCPM", _) => {
                let mut k = 2;
                while k < sig.len() {
                    match (word(k), word(k + 1)) {
                        ("F", "TCP" | "CONT") | ("AXIS", "POS") | ("PATHCTRL", "AXIS") => k += 2,
                        ("AXIS", "SPAT") => {
                            return Err(at(col(k), "FUNCTION TCPM … AXIS SPAT reads rotary words as spatial angles: not followed by nccomp (expected AXIS POS)".into()));
                        }
                        ("PATHCTRL", "VECTOR") => {
                            return Err(at(col(k), "FUNCTION TCPM … PATHCTRL VECTOR moves the tool vector on a great circle: not followed by nccomp (expected PATHCTRL AXIS)".into()));
                        }
                        (other, _) => {
                            return Err(at(
                                col(k),
                                format!(
                                    "`{other}` is not expected in FUNCTION TCPM (expected F TCP or F CONT, AXIS POS, PATHCTRL AXIS)"
                                ),
                            ));
                        }
                    }
                }
                if modal.working_plane.is_some() {
                    return Err(at(col(0), "FUNCTION TCPM under a tilted working plane cannot be compensated (expected PLANE RESET before it)".into()));
                }
                modal.tcp = true;
                modal.tcp_vector = false;
                Ok(false)
            }
            (other, _) => Err(at(
                col(1),
                format!(
                    "FUNCTION {other} is not followed by nccomp (expected FUNCTION TCPM or FUNCTION RESET TCPM)"
                ),
            )),
        }
    }

    /// `FN 0: Qn = value`, and the jumps `FN 9`–`FN 12` whose condition is known;
    /// other FN functions are refused.
    fn fn_statement(
        &self,
        number_line: usize,
        content: &[u8],
        tokens: &[Token],
        sig: &[usize],
        tnc: &mut Tnc,
        at: At<'_>,
    ) -> Result<bool, Diagnostic> {
        // `FN 0: Q3=50`, `FN 0:Q3=50`, `FN 0: Q3 = +50`: the statement's text after `FN`.
        let start = tokens[sig[0]].span.end;
        let end = tokens
            .iter()
            .rposition(|t| t.kind != TokenKind::Comment && t.kind != TokenKind::Space)
            .map_or(content.len(), |i| tokens[i].span.end);
        let body = std::str::from_utf8(&content[start..end.max(start)]).unwrap_or("");
        let col0 = tokens[sig[0]].span.start;
        let compact: String = body.chars().filter(|c| !c.is_whitespace()).collect();
        let Some((number, rest)) = compact.split_once(':') else {
            return Err(at(col0, "expected FN n: after FN".into()));
        };
        if matches!(number, "9" | "10" | "11" | "12") {
            let rest = body.split_once(':').map_or("", |(_, r)| r);
            return self.jump(number_line, number, rest, tnc, col0, at);
        }
        if number != "0" {
            return Err(at(
                col0,
                format!(
                    "FN {number} is not followed by nccomp (only FN 0 assignments of constants are; jumps and computations decide values at run time)"
                ),
            ));
        }
        let Some((name, value)) = rest.split_once('=') else {
            return Err(at(col0, "expected FN 0: Qn=value".into()));
        };
        let Some((key, _)) = q_key(name.as_bytes()).filter(|(_, s)| *s == 1.0) else {
            return Err(at(
                col0,
                format!("`{name}`: expected a Q parameter to assign"),
            ));
        };
        let value = match value.parse::<f64>() {
            Ok(v) if v.is_finite() => Some(v),
            _ => q_key(value.as_bytes()).and_then(|(k, sign)| tnc.q.get(&k).map(|v| sign * v)),
        };
        match value {
            Some(v) => {
                tnc.q.insert(key, v);
            }
            None => {
                tnc.q.remove(&key);
            }
        }
        Ok(false)
    }

    /// `FN 9: IF a EQU b GOTO LBL n` (`FN 10` NE, `FN 11` GT, `FN 12` LT): where the
    /// condition holds the control goes on after `LBL n`. Both sides must be numbers or Q
    /// parameters the program has set to constants here. In a label's body the jump is
    /// followed to the label's body (its `LBL 0` returns from the call); in the main
    /// program a jump forward skips the lines up to the label; a jump back (a loop) is
    /// refused.
    fn jump(
        &self,
        line: usize,
        number: &str,
        rest: &str,
        tnc: &mut Tnc,
        col0: usize,
        at: At<'_>,
    ) -> Result<bool, Diagnostic> {
        let op = match number {
            "9" => "EQU",
            "10" => "NE",
            "11" => "GT",
            _ => "LT",
        };
        let expected = format!("expected FN {number}: IF a {op} b GOTO LBL n");
        let Some((condition, target)) = rest
            .trim()
            .strip_prefix("IF")
            .and_then(|r| r.split_once("GOTO"))
        else {
            return Err(at(col0, expected));
        };
        let words: Vec<&str> = condition.split_whitespace().collect();
        let [a, o, b] = words[..] else {
            return Err(at(col0, expected));
        };
        if o != op {
            return Err(at(col0, expected));
        }
        let value = |w: &str| -> Result<f64, Diagnostic> {
            match w.parse::<f64>() {
                Ok(v) if v.is_finite() => Ok(v),
                _ => match q_key(w.as_bytes()) {
                    Some((k, sign)) => tnc.q.get(&k).map(|v| sign * v).ok_or_else(|| {
                        at(
                            col0,
                            format!(
                                "FN {number}: {} is not set to a constant before this jump: whether it jumps is decided at run time (expected the Q parameter set by FN 0 on every way here)",
                                q_name(k)
                            ),
                        )
                    }),
                    None => Err(at(
                        col0,
                        format!("FN {number}: `{w}` is not a number or a Q parameter"),
                    )),
                },
            }
        };
        let (a, b) = (value(a)?, value(b)?);
        let taken = match number {
            "9" => a == b,
            "10" => a != b,
            "11" => a > b,
            _ => a < b,
        };
        let target = target.trim();
        let Some(name) = target.strip_prefix("LBL").map(str::trim).and_then(|t| {
            if t.starts_with('"') && t.ends_with('"') && t.len() >= 2 {
                Some(t[1..t.len() - 1].to_string())
            } else {
                t.parse::<u32>().ok().map(|n| n.to_string())
            }
        }) else {
            return Err(at(
                col0,
                format!(
                    "FN {number}: `GOTO {target}`: expected GOTO LBL with a label number or a quoted name (a label given by a parameter is decided at run time)"
                ),
            ));
        };
        let labels = tnc.labels.clone();
        let Some(body) = labels.bodies.get(&name) else {
            return Err(at(
                col0,
                format!("FN {number} jumps to LBL {name}, but the program has no LBL {name}"),
            ));
        };
        if !taken {
            return Ok(false);
        }
        if tnc.depth > 0 || tnc.in_body > 0 {
            tnc.request = Some(Flow::Jump { name, line });
            return Ok(false);
        }
        if body.line <= line {
            return Err(at(
                col0,
                format!(
                    "FN {number} jumps back to LBL {name} at line {}: a loop in the main program is not followed (expected jumps forward, or in a called label)",
                    body.line
                ),
            ));
        }
        tnc.skip_to = Some((name, line));
        Ok(false)
    }

    /// `CALL LBL n`: the label's body, which must move nothing.
    fn call(
        &self,
        content: &[u8],
        tokens: &[Token],
        sig: &[usize],
        modal: &mut Modal,
        tnc: &mut Tnc,
        at: At<'_>,
    ) -> Result<bool, Diagnostic> {
        let word = |k: usize| sig.get(k).map_or("", |&i| text(content, &tokens[i]));
        let col0 = tokens[sig[0]].span.start;
        if word(1) != "LBL" {
            return Err(at(
                col0,
                format!(
                    "CALL {} (another program) is not followed by nccomp (expected CALL LBL)",
                    word(1)
                ),
            ));
        }
        let Some(name) = label_name(content, tokens, &sig[2..]) else {
            return Err(at(
                col0,
                "expected a label number or name after CALL LBL".into(),
            ));
        };
        if sig.len() > 3 {
            return Err(at(
                tokens[sig[3]].span.start,
                format!(
                    "`{}` after CALL LBL (repeats) is not followed by nccomp",
                    word(3)
                ),
            ));
        }
        let labels = tnc.labels.clone();
        let Some(body) = labels.bodies.get(&name) else {
            return Err(at(
                col0,
                format!("CALL LBL {name}, but the program has no LBL {name}"),
            ));
        };
        if tnc.depth >= MAX_CALL_DEPTH {
            return Err(at(
                col0,
                format!("label calls nested more than {MAX_CALL_DEPTH} deep"),
            ));
        }
        // A caller that runs moving bodies gets them handed over: the body is first read
        // here, on a copy of the state, to learn whether it moves.
        let handing = tnc.follow_calls && tnc.depth == 0;
        let saved = handing.then(|| (modal.clone(), tnc.clone()));
        tnc.depth += 1;
        let mut sub_tokens = Vec::new();
        let mut motion = BlockMotion::default();
        let mut result = Ok(false);
        let continued = tnc.continued;
        tnc.continued = false;
        let mut running = name.clone();
        let mut body = body;
        let mut k = 0;
        while let Some(line) = body.lines.get(k) {
            k += 1;
            let (number, line) = (line.number, &line.content);
            tnc.label_blocks += 1;
            if tnc.label_blocks > MAX_LABEL_BLOCKS {
                result = Err(at(
                    col0,
                    format!(
                        "CALL LBL {name} is not followed: the program's label calls run more than {MAX_LABEL_BLOCKS} label blocks in all (labels that call labels, each call run through; expected label calls that run fewer blocks)"
                    ),
                ));
                break;
            }
            nc::heidenhain::parse_line(line, &mut sub_tokens);
            substitute(line, &mut sub_tokens, tnc);
            let inner = |_: usize, message: String| {
                at(col0, format!("in LBL {running}, line {number}: {message}"))
            };
            match self.tnc_block(number, line, &sub_tokens, modal, tnc, &inner, &mut motion) {
                Ok(false) => {}
                Ok(true) => {
                    tnc.moved = true;
                    result = Err(at(
                        col0,
                        format!(
                            "CALL LBL {name} runs line {number}, which moves the machine: nccomp follows only labels that move nothing here (expected the moves in the main program, or the label after the program's end, ended by LBL 0)"
                        ),
                    ));
                    break;
                }
                Err(d) => {
                    result = Err(d);
                    break;
                }
            }
            if tnc.end.is_some() {
                result = Err(at(
                    col0,
                    format!("CALL LBL {name} ends the program at line {number}: not followed"),
                ));
                break;
            }
            if let Some(Flow::Jump { name: to, .. }) = tnc.request.take() {
                // A jump in the body: on after the label it names, up to its LBL 0.
                match labels.bodies.get(&to) {
                    Some(b) => {
                        body = b;
                        running = to;
                        k = 0;
                    }
                    None => {
                        result = Err(at(col0, format!("the program has no LBL {to}")));
                        break;
                    }
                }
            }
        }
        tnc.depth -= 1;
        tnc.continued = continued;
        if let Some((m, t)) = saved
            && tnc.moved
        {
            // The body moves: the caller runs it, from the state at the call.
            let called = labels.bodies.get(&name).expect("looked up above");
            if !called.callable(&labels) {
                return Err(at(
                    col0,
                    format!(
                        "CALL LBL {name} runs a body that moves, and LBL {name} (line {}) is not a subprogram after the program's end ended by LBL 0: not followed (expected the label after M30, up to LBL 0)",
                        called.line
                    ),
                ));
            }
            *modal = m;
            *tnc = t;
            tnc.request = Some(Flow::Call {
                name,
                line: tnc.line,
            });
            return Ok(false);
        }
        result
    }
}

/// The axis word count a TNC block may hold.
const _: () = assert!(MAX_AXES >= 6);

/// The start of the `k`-th block inserted before a line (0 the first): its block number
/// (the line's own, moved on by the `shift` blocks inserted before it in the program and by
/// `k`) and `L`.
pub fn inserted_start(content: &[u8], tokens: &[Token], shift: u64, k: usize) -> Vec<String> {
    let mut words = Vec::with_capacity(2);
    if let Some(n) = number_of(content, tokens) {
        words.push((n + shift + k as u64).to_string());
    }
    words.push("L".to_string());
    words
}

/// The line's block number, if it has one.
pub fn number_of(content: &[u8], tokens: &[Token]) -> Option<u64> {
    let i = block_number(content, tokens)?;
    std::str::from_utf8(&content[tokens[i].span.clone()])
        .ok()?
        .parse()
        .ok()
}

/// R0, RL or RR in an L or arc block (`comp`: the side, RL being left, or `None` for R0,
/// and its column): tool radius compensation from this block on, on that side of the
/// contour, or cancelled. A block without any keeps the state. RL/RR need the called
/// tool's radius (the machine file's `[tool]` radii) and are refused under TCP. The
/// control begins and ends radius compensation in straight-line blocks only (TNC 620 ISO
/// programming manual, "Fundamentals of path functions": "You cannot activate radius
/// compensation in a circle block"): an arc that would is refused, one that repeats the
/// side in force is read.
fn radius_comp(
    modal: &mut Modal,
    comp: Option<(Option<bool>, usize)>,
    arc: bool,
    at: At<'_>,
) -> Result<(), Diagnostic> {
    if arc
        && let Some((side, col)) = comp
        && side.map(|left| {
            if left {
                super::RadiusSide::Left
            } else {
                super::RadiusSide::Right
            }
        }) != modal.radius_comp
    {
        return Err(at(
            col,
            "an arc that begins, changes or ends tool radius compensation (RL, RR, R0): the control does that in straight-line (L) blocks only (expected the arc to keep the compensation in force)".into(),
        ));
    }
    let Some((side, col)) = comp else {
        if modal.tcp && modal.radius_comp.is_some() {
            return Err(at(
                0,
                "tool-centre-point control (M128, FUNCTION TCPM) with tool radius compensation (RL/RR) in force: the control's 3-D offset is not followed by nccomp (expected R0 before M128)".into(),
            ));
        }
        return Ok(());
    };
    let Some(left) = side else {
        modal.radius_comp = None;
        return Ok(());
    };
    let name = if left { "RL" } else { "RR" };
    if modal.tcp {
        return Err(at(
            col,
            format!(
                "tool radius compensation ({name}) under tool-centre-point control (M128, FUNCTION TCPM) cannot be compensated: the control offsets the tool in 3-D there (expected R0, or the contour programmed as the tool centre path)"
            ),
        ));
    }
    if modal.tool_radius.is_none() {
        return Err(at(
            col,
            format!(
                "tool radius compensation ({name}) needs the called tool's radius: give it in the machine file's [tool] radii / named_radii / max_radius (the control offsets the contour by it, and the correction at the offset point differs from the contour's)"
            ),
        ));
    }
    modal.radius_comp = Some(if left {
        super::RadiusSide::Left
    } else {
        super::RadiusSide::Right
    });
    Ok(())
}

/// The words a block inserted before an L block repeats: its radius compensation (R0;
/// not a CR arc's radius).
pub fn carried_words(tokens: &[Token]) -> impl Iterator<Item = usize> + '_ {
    tokens
        .iter()
        .enumerate()
        .filter_map(|(i, t)| match &t.kind {
            TokenKind::Word(w)
                if w.letter == b'R'
                    && matches!(w.value, Value::Number { value, .. } if value == 0.0) =>
            {
                Some(i)
            }
            _ => None,
        })
}
