//! The Sinumerik 840D front end: a block's tokens into its [`BlockMotion`], following the
//! [`Modal`] state and what the front end keeps beside it ([`Siemens`]).
//!
//! A Sinumerik block is mostly ISO G-code (`G1 X10 Y5 F200`) with the control's own
//! instructions beside it. The instructions are read here: variables (`DEF REAL`, `R`
//! parameters, assignments), `TRAORI`/`TRAFOOF` (tool-centre-point control), `SUPA`
//! (machine positions), the frames (`TRANS`, `ATRANS`, `ROT`, `AROT`, `CYCLE800`), drilling
//! cycles called by `MCALL`, and the instructions that move nothing (`MSG`, `FNORM`,
//! `CYCLE832` …). The G functions are Siemens' (`G710` metric, `G642` smoothing, `G153`
//! machine positions); each is translated to the dialect-free meaning or refused. What is
//! left is read as G-code by [`Reader::read`]'s ISO reading, with the statements the
//! front end has followed blanked out of its copy of the tokens (same token indices, so
//! the pass edits the program's own tokens).
//!
//! Sources and the choices made where Siemens' documentation leaves room are in
//! docs/sinumerik.md.

use super::gcode::At;
use super::heidenhain::{CycleDef, Param};
use super::params::{Params, evaluate_840d};
use super::{BlockMotion, Modal, MoveKind, Reader, WorkingPlane};
use crate::diag::Diagnostic;
use crate::nc::sinumerik::{is_name, wrapper};
use crate::nc::{self, Token, TokenKind, Value};
use nalgebra::{Rotation3, Vector3};

/// What the Sinumerik front end keeps between blocks, beside the [`Modal`] state.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Siemens {
    /// The variables (`DEF REAL _DEPTH`, `R1`) the program has set, by name uppercased.
    pub vars: Params,
    /// The programmable frame: its translation (mm) and rotation (TRANS, ATRANS, ROT, AROT).
    pub trans: [f64; 3],
    pub rot: Option<Rotation3<f64>>,
    /// The swivel frame of CYCLE800.
    pub swivel: Option<Swivel>,
    /// The drilling cycle `MCALL` calls at each position block.
    pub mcall: Option<CycleDef>,
    /// Each rotary axis's last absolute value (degrees), by letter: where `DC`, `ACP` and
    /// `ACN` words start from.
    pub angles: [Option<f64>; 26],
    /// The tool selected by name (`T="…"`, without its quotes); a numbered T word after it
    /// selects by number (`Modal::tool`).
    pub named_tool: Option<String>,
}

/// A swivel frame (CYCLE800): where the plane's zero lies in the part frame, its axes,
/// and whether the cycle turned the rotary axes to it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Swivel {
    pub origin: Vector3<f64>,
    pub rotation: Rotation3<f64>,
    /// `_DIR`: +1 the solution with the reference axis's larger value, -1 the smaller,
    /// 0 no turn.
    pub dir: i8,
}

/// A Sinumerik G function's dialect-free reading.
enum GFunction {
    /// The same number as ISO reads it.
    Same,
    /// ISO's code of the same meaning (times ten).
    As(i64),
    /// Moves no block end (exact stop, smoothing, corner behaviour).
    Neutral,
    /// Not followed: why.
    Refused(&'static str),
}

/// The meaning of Sinumerik G function `code10` (its number times ten).
fn g_function(code10: i64) -> GFunction {
    use GFunction::*;
    match code10 {
        // Motion, dwell, planes, work offsets, distances, feeds, spindle speed modes.
        0 | 10 | 20 | 30 | 40 | 170 | 180 | 190 | 400 | 530 | 540 | 550 | 560 | 570 | 900 | 910
        | 930 | 940 | 950 | 960 | 970 => Same,
        1530 => As(530),
        // Inch and metric: G70/G71 for the geometry, G700/G710 the feed too.
        700 | 7000 => As(200),
        710 | 7100 => As(210),
        // Exact stop, continuous path and smoothing, corner behaviour.
        90 | 600 | 640 | 6010 | 6020 | 6030 | 6410 | 6420 | 6430 | 6440 | 6450 | 4500 | 4510 => {
            Neutral
        }
        410 | 420 => Refused(
            "tool radius compensation (G41/G42) moves the path by the radius, which nccomp does not follow (expected G40)",
        ),
        5000 => Refused(
            "G500 switches the settable frame (work offset) off: program zero moves to a place the machine file does not give (expected G54 … G57)",
        ),
        5050..=5990 => Refused(
            "a settable frame beyond G57 (G505 … G599) is not followed (expected G54 … G57)",
        ),
        250 | 260 => Refused(
            "G25/G26 set working-area or spindle-speed limits from the block's words, which nccomp does not follow",
        ),
        330 | 3310 | 3320 | 630 | 340 | 350 => Refused("thread cutting and tapping"),
        740 | 750 => Refused(
            "reference point and fixed point approach (G74/G75) send axes to machine positions (expected SUPA or G153 with the positions)",
        ),
        1100 | 1110 | 1120 => Refused("polar coordinates (G110 … G112)"),
        _ => Refused("this G function is not one nccomp reads in Sinumerik programs"),
    }
}

/// Instructions that move no block end and transform nothing.
const NEUTRAL: [&str; 19] = [
    "FNORM", "SOFT", "BRISK", "FFWON", "FFWOF", "STOPRE", "COMPOF", "COMPCAD", "COMPCURV",
    "COMPSURF", "CFC", "CFTCP", "CFIN", "UPATH", "SPATH", "ORIWKS", "ORIAXES", "RET", "M17",
];

/// Instructions with arguments that move no block end.
const NEUTRAL_CALLS: [&str; 6] = [
    "MSG(",
    "SETMS(",
    "CYCLE832(",
    "WORKPIECE(",
    "FGROUP(",
    "G4(",
];

/// The arguments of a call's text `NAME(a, b, …)`: each argument's bytes and where it
/// starts in `text`; `None` when the brackets do not close the text.
pub fn arguments(text: &[u8]) -> Option<Vec<(usize, &[u8])>> {
    let open = text.iter().position(|&b| b == b'(')?;
    if !text.ends_with(b")") {
        return None;
    }
    let inner = open + 1..text.len() - 1;
    let mut args = Vec::new();
    let mut start = inner.start;
    let mut quoted = false;
    let mut depth = 0usize;
    for k in inner.clone() {
        match text[k] {
            b'"' => quoted = !quoted,
            b'(' if !quoted => depth += 1,
            b')' if !quoted => depth = depth.saturating_sub(1),
            b',' if !quoted && depth == 0 => {
                args.push((start, &text[start..k]));
                start = k + 1;
            }
            _ => {}
        }
    }
    if !(inner.is_empty() && args.is_empty()) {
        args.push((start, &text[start..inner.end]));
    }
    Some(args)
}

/// Replace every variable word (and expression over variables) whose value the program
/// has set to a constant by that number.
pub fn substitute(content: &[u8], tokens: &mut [Token], siemens: &Siemens) {
    for t in tokens.iter_mut() {
        let TokenKind::Word(w) = &mut t.kind else {
            continue;
        };
        if !matches!(w.value, Value::Parameter | Value::Expression) {
            continue;
        }
        if let Some((value, decimals)) = content
            .get(w.value_span.clone())
            .and_then(|text| evaluate_840d(text, &siemens.vars))
        {
            w.value = Value::Number { value, decimals };
        }
    }
}

fn text<'a>(content: &'a [u8], t: &Token) -> &'a str {
    std::str::from_utf8(&content[t.span.clone()]).unwrap_or("")
}

/// A rotation of `degrees` about axis `axis` (0 X, 1 Y, 2 Z).
fn about(axis: usize, degrees: f64) -> Rotation3<f64> {
    let a = [Vector3::x_axis(), Vector3::y_axis(), Vector3::z_axis()][axis.min(2)];
    Rotation3::from_axis_angle(&a, degrees.to_radians())
}

/// The statements of one block, found before its words are read.
#[derive(Default)]
struct Statements {
    supa: Option<usize>,
    traori: Option<usize>,
    trafoof: bool,
    frame: Option<(usize, &'static str)>,
    rpl: Option<(usize, usize)>,
    swivel: Option<usize>,
    mcall: Option<usize>,
    cycle: Option<usize>,
    named_tool: Option<(usize, String)>,
}

impl Reader<'_> {
    /// Read one Sinumerik block (see [`Reader::read`]).
    pub(super) fn read_840d(
        &self,
        line: &nc::Line<'_>,
        tokens: &[Token],
        modal: &mut Modal,
        at: At<'_>,
        out: &mut BlockMotion,
    ) -> Result<bool, Diagnostic> {
        let mut siemens = modal.siemens.take().unwrap_or_default();
        let read = self.siemens_block(line, tokens, modal, &mut siemens, at, out);
        modal.siemens = Some(siemens);
        read
    }

    fn siemens_block(
        &self,
        line: &nc::Line<'_>,
        tokens: &[Token],
        modal: &mut Modal,
        s: &mut Siemens,
        at: At<'_>,
        out: &mut BlockMotion,
    ) -> Result<bool, Diagnostic> {
        let content = line.content;
        let optional = tokens
            .iter()
            .find(|t| t.kind != TokenKind::Space)
            .is_some_and(|t| t.kind == TokenKind::BlockDelete);
        // The ISO reading's copy of the tokens, made where the block needs one.
        let mut copy: Option<Vec<Token>> = None;
        let blank = |copy: &mut Option<Vec<Token>>, i: usize| {
            copy.get_or_insert_with(|| tokens.to_vec())[i].kind = TokenKind::Comment;
        };
        let mut st = Statements::default();
        let first_other = tokens.iter().position(|t| t.kind == TokenKind::Other);
        if let Some(i) = first_other {
            let first = text(content, &tokens[i]);
            if first.eq_ignore_ascii_case("DEF") {
                return self.declaration(content, tokens[i].span.end, optional, s, at);
            }
            // The program's header (`%_N_PART_MPF`), as the control's file names it.
            if first.starts_with("%_N_") && i == 0 && tokens.len() == 1 {
                return Ok(false);
            }
        }
        for (i, t) in tokens.iter().enumerate() {
            if t.kind != TokenKind::Other {
                continue;
            }
            let raw = text(content, t);
            let upper = raw.to_ascii_uppercase();
            let col = t.span.start;
            if let Some((name, value)) = raw.split_once('=')
                && is_name(name.as_bytes())
                && !name.is_empty()
            {
                match name.to_ascii_uppercase().as_str() {
                    "RPL" => st.rpl = Some((i, col)),
                    "AR" => {
                        return Err(at(col, "arcs by their opening angle (AR=) are not compensated (expected I, J, K or CR=)".into()));
                    }
                    "TURN" => {
                        return Err(at(col, "helices with turns (TURN=) are not compensated (expected an arc of one turn at most)".into()));
                    }
                    "T" if value.starts_with('"') => {
                        let name = value.trim_matches('"').to_string();
                        st.named_tool = Some((col, name));
                    }
                    "A2" | "B2" | "C2" => {
                        return Err(at(
                            col,
                            format!(
                                "`{raw}`: the tool orientation by Euler or RPY angles is not followed (expected the rotary axes' positions under TRAORI)"
                            ),
                        ));
                    }
                    "A3" | "B3" | "C3" => {}
                    n => {
                        let known = if optional {
                            None
                        } else {
                            evaluate_840d(value.as_bytes(), &s.vars)
                        };
                        if n.len() == 1 {
                            return Err(at(
                                col,
                                format!(
                                    "`{raw}`: {n} is not an address nccomp reads in Sinumerik programs"
                                ),
                            ));
                        }
                        s.vars.set(n.to_string(), known);
                    }
                }
                blank(&mut copy, i);
                continue;
            }
            match upper.as_str() {
                "TRAORI" | "TRAORI()" | "TRAORI(1)" => st.traori = Some(col),
                "TRAFOOF" => st.trafoof = true,
                "SUPA" => st.supa = Some(col),
                "TRANS" => st.frame = Some((col, "TRANS")),
                "ATRANS" => st.frame = Some((col, "ATRANS")),
                "ROT" => st.frame = Some((col, "ROT")),
                "AROT" => st.frame = Some((col, "AROT")),
                "MCALL" => st.mcall = Some(col),
                u if NEUTRAL.contains(&u) => {}
                u if NEUTRAL_CALLS.iter().any(|c| u.starts_with(c)) => {}
                u if u.starts_with("CYCLE800(") => st.swivel = Some(i),
                u if u.starts_with("CYCLE8") && u.ends_with(')') => st.cycle = Some(i),
                u if u.starts_with('$') => {
                    return Err(at(
                        col,
                        format!(
                            "`{raw}`: writing or reading the control's system variables is not followed (their values are the control's at run time)"
                        ),
                    ));
                }
                u if [
                    "GOTO", "GOTOF", "GOTOB", "IF", "ELSE", "ENDIF", "WHILE", "ENDWHILE", "FOR",
                    "ENDFOR", "REPEAT", "UNTIL", "LOOP", "ENDLOOP", "CALL", "PCALL", "MCALL",
                    "PROC",
                ]
                .contains(&u)
                    || u.ends_with(':') =>
                {
                    return Err(at(
                        col,
                        format!(
                            "`{raw}`: control flow, labels and subprogram calls are not compensated (each pass through the text would need its own correction)"
                        ),
                    ));
                }
                _ => {
                    return Err(at(
                        col,
                        format!(
                            "`{raw}` is not a Sinumerik instruction nccomp reads (expected G-code words, DEF, variable assignments, TRAORI, TRAFOOF, SUPA, TRANS/ATRANS/ROT/AROT, CYCLE800, MCALL CYCLE81 … CYCLE83, MSG, T=\"name\")"
                        ),
                    ));
                }
            }
            blank(&mut copy, i);
        }
        if let Some((col, name)) = st.named_tool {
            if self.tools_listed {
                return Err(at(col, "a tool by name cannot select a tool chain: the machine file lists tools by number (expected T with the tool's number)".into()));
            }
            if modal.tcp {
                return Err(at(
                    col,
                    "a tool change under TRAORI cannot be compensated (expected TRAFOOF before it)"
                        .into(),
                ));
            }
            s.named_tool = Some(name);
            modal.tool = None;
        }
        // The words: Siemens' G functions into ISO's, the addresses ISO reads otherwise.
        let mut incremental = modal.incremental;
        let mut d_word: Option<(f64, usize)> = None;
        for (i, t) in tokens.iter().enumerate() {
            let TokenKind::Word(w) = &t.kind else {
                continue;
            };
            let col = t.span.start;
            let letter = w.letter;
            let Value::Number { value, .. } = w.value else {
                if matches!(letter, b'F' | b'S') {
                    continue;
                }
                let what = String::from_utf8_lossy(&content[w.value_span.clone()]);
                return Err(at(
                    col,
                    match w.value {
                        Value::Missing => format!(
                            "{} has no value (expected a number after it)",
                            letter as char
                        ),
                        _ => format!(
                            "{} is given by `{what}`, which the program does not set to a constant before this block (a variable or R parameter never assigned, assigned at run time, or a function nccomp does not evaluate): expected a number, or DEF/R variables set to constants and + - * / over them",
                            letter as char
                        ),
                    },
                ));
            };
            match letter {
                b'G' => {
                    let code10 = (value * 10.0).round() as i64;
                    match g_function(code10) {
                        GFunction::Same => {}
                        GFunction::As(iso) => {
                            let c = copy.get_or_insert_with(|| tokens.to_vec());
                            if let TokenKind::Word(w) = &mut c[i].kind {
                                w.value = Value::Number {
                                    value: iso as f64 / 10.0,
                                    decimals: 0,
                                };
                            }
                        }
                        GFunction::Neutral => blank(&mut copy, i),
                        GFunction::Refused(why) => {
                            return Err(at(
                                col,
                                format!("{} cannot be compensated: {why}", text(content, t)),
                            ));
                        }
                    }
                    match code10 {
                        900 => incremental = false,
                        910 => incremental = true,
                        _ => {}
                    }
                }
                // The end of a subprogram.
                b'M' if value == 17.0 => blank(&mut copy, i),
                b'D' => {
                    d_word = Some((value, col));
                    blank(&mut copy, i);
                }
                b'H' | b'L' | b'P' | b'O' | b'Q' | b'E' => {
                    let why = match letter {
                        b'H' => {
                            "H auxiliary functions go to the machine's PLC, and what they do is the machine's own"
                        }
                        b'L' | b'P' => "subprogram calls (L, P) are not compensated",
                        _ => "it is not an address nccomp reads in Sinumerik programs",
                    };
                    return Err(at(
                        col,
                        format!("{} cannot be compensated: {why}", text(content, t)),
                    ));
                }
                _ => {}
            }
        }
        // Axis words with `=AC(…)`, `=IC(…)`, `=DC(…)` …
        let words = self.axes(modal.chain);
        for t in tokens {
            let TokenKind::Word(w) = &t.kind else {
                continue;
            };
            let how = wrapper(content, w).to_ascii_uppercase();
            if how.is_empty() {
                continue;
            }
            let col = t.span.start;
            let letter = w.letter;
            let name = String::from_utf8_lossy(&content[t.span.clone()]).to_string();
            let var = letter
                .is_ascii_uppercase()
                .then(|| words.var_of_letter[(letter - b'A') as usize])
                .flatten();
            let x = w.number().unwrap_or(0.0);
            match (how.as_slice(), var) {
                (b"AC", _) if !incremental && !matches!(letter, b'I' | b'J' | b'K') => {}
                (b"IC", _) if incremental || matches!(letter, b'I' | b'J' | b'K') => {}
                (b"AC" | b"IC", _) => {
                    return Err(at(
                        col,
                        format!(
                            "`{name}`: a word in the other distance mode than its block's ({}) is not followed, nor absolute arc centres (expected the block's mode for every word)",
                            if incremental { "G91" } else { "G90" }
                        ),
                    ));
                }
                (b"DC" | b"ACP" | b"ACN", Some(v)) if !words.is_linear(v) && !incremental => {
                    let Some(from) = s.angles[(letter - b'A') as usize] else {
                        return Err(at(
                            col,
                            format!(
                                "`{name}` turns from where the axis stands, which is not known here (expected a plain absolute {} word first)",
                                letter as char
                            ),
                        ));
                    };
                    let target = match how.as_slice() {
                        b"DC" => from + (x - from + 180.0).rem_euclid(360.0) - 180.0,
                        b"ACP" => from + (x - from).rem_euclid(360.0),
                        _ => from - (from - x).rem_euclid(360.0),
                    };
                    if (target - x).abs() > 1e-9 {
                        return Err(at(
                            col,
                            format!(
                                "`{name}` turns from {from} to {target} (modulo 360°), not to {x}: nccomp reads rotary words as positions without wrapping (expected {}{x} reached without crossing a full turn, or the position written out)",
                                letter as char
                            ),
                        ));
                    }
                }
                _ => {
                    return Err(at(
                        col,
                        format!(
                            "`{name}`: {} is read for rotary axes in G90 only, and CAC/CIC … not at all",
                            String::from_utf8_lossy(&how)
                        ),
                    ));
                }
            }
        }
        if st.traori.is_some() || st.trafoof {
            if modal.working_plane.is_some() && st.traori.is_some() {
                return Err(at(st.traori.unwrap_or(0), "TRAORI under a frame (CYCLE800, TRANS, ROT) cannot be compensated (expected CYCLE800() and TRANS before it)".into()));
            }
            modal.tcp = st.traori.is_some();
            modal.tcp_vector = false;
        }
        // Under TRAORI a block gives the tool's orientation by the rotary axes' positions or
        // by a vector (A3= B3= C3=, read as I J K), block by block.
        let mut vector: Option<usize> = None;
        let mut centre = false;
        let mut rotary = false;
        for t in tokens {
            let TokenKind::Word(w) = &t.kind else {
                continue;
            };
            match w.letter {
                b'I' | b'J' | b'K' => {
                    if matches!(
                        content[t.span.start].to_ascii_uppercase(),
                        b'A' | b'B' | b'C'
                    ) {
                        vector.get_or_insert(t.span.start);
                    } else {
                        centre = true;
                    }
                }
                b'R' => centre = true,
                l => {
                    let var = l
                        .is_ascii_uppercase()
                        .then(|| words.var_of_letter[(l - b'A') as usize])
                        .flatten();
                    rotary |= var.is_some_and(|v| !words.is_linear(v));
                }
            }
        }
        let arc_code = tokens.iter().any(|t| {
            matches!(&t.kind, TokenKind::Word(w) if w.letter == b'G' && matches!(w.number(), Some(2.0 | 3.0)))
        });
        let line_code = tokens.iter().any(|t| {
            matches!(&t.kind, TokenKind::Word(w) if w.letter == b'G' && matches!(w.number(), Some(0.0 | 1.0)))
        });
        let arc = arc_code || (modal.motion == Some(super::Motion::Arc) && !line_code);
        if let Some(col) = vector {
            let why = if !modal.tcp {
                Some("a tool vector (A3=, B3=, C3=) outside TRAORI")
            } else if rotary {
                Some("a tool vector (A3=, B3=, C3=) and rotary axis words in one block")
            } else if centre || arc {
                Some("a tool vector (A3=, B3=, C3=) in an arc block")
            } else {
                None
            };
            if let Some(why) = why {
                return Err(at(
                    col,
                    format!(
                        "{why} cannot be compensated (expected the orientation by rotary axis words or by a vector, in a straight move under TRAORI)"
                    ),
                ));
            }
            modal.tcp_vector = true;
        } else if modal.tcp && (rotary || arc) {
            modal.tcp_vector = false;
        }
        if let Some((col, kind)) = st.frame {
            return self.frame(content, tokens, kind, col, st.rpl, modal, s, at);
        }
        if let Some((_, col)) = st.rpl {
            return Err(at(col, "RPL= outside ROT/AROT: expected ROT RPL=…".into()));
        }
        if let Some(i) = st.swivel {
            return self.swivel(content, &tokens[i], modal, s, at, out);
        }
        if let Some(col) = st.mcall {
            match st.cycle {
                Some(i) => {
                    s.mcall = Some(self.drill_def(line.number, content, &tokens[i], s, at)?)
                }
                None => s.mcall = None,
            }
            if tokens
                .iter()
                .any(|t| matches!(&t.kind, TokenKind::Word(w) if w.letter != b'N'))
            {
                return Err(at(
                    col,
                    "MCALL with other words in its block: expected MCALL CYCLE8…(…) or MCALL alone"
                        .into(),
                ));
            }
            return Ok(false);
        }
        if let Some(i) = st.cycle {
            return Err(at(tokens[i].span.start, "a drilling cycle called once (without MCALL) is not compensated (expected MCALL CYCLE8…(…), the hole positions, then MCALL)".into()));
        }
        let toks = copy.as_deref().unwrap_or(tokens);
        self.select(line, toks, modal, at)?;
        let moves = self.read_words(line, toks, modal, at, out)?;
        if let Some((d, col)) = d_word {
            let tool = &self.machine.tool;
            let length = if d == 0.0 {
                0.0
            } else if let Some(n) = modal.tool {
                *tool.lengths.get(&n).ok_or_else(|| {
                    at(col, format!(
                        "D{d} takes the length of tool T{n}, which has none in the machine file (expected it in [tool] lengths, which lists {}): where its tip is, and so the correction, depends on it",
                        super::heidenhain::listed(tool.lengths.keys().map(u32::to_string))
                    ))
                })?
            } else if let Some(name) = &s.named_tool {
                *tool.named_lengths.get(name).ok_or_else(|| {
                    at(col, format!(
                        "D{d} takes the length of tool \"{name}\", which has none in the machine file (expected it in [tool] named_lengths, which lists {}): where its tip is, and so the correction, depends on it",
                        super::heidenhain::listed(tool.named_lengths.keys().map(|k| format!("\"{k}\"")))
                    ))
                })?
            } else {
                // No tool selected: the tool in the spindle is the operator's, its length
                // not known; a move compensated with it is refused (`Modal::length`).
                f64::NAN
            };
            if modal.tcp && length.to_bits() != modal.length.to_bits() {
                return Err(at(col, "a change of the tool offset under TRAORI cannot be compensated (expected TRAFOOF before it)".into()));
            }
            modal.length = length;
        }
        // Where the rotary axes end, for the DC/ACP/ACN words of later blocks.
        let n = words.letters.len();
        for v in 0..n {
            if words.is_linear(v) {
                continue;
            }
            let slot = (words.letters[v] - b'A') as usize;
            match out.axis_words[v].filter(|_| moves) {
                Some(i) => {
                    let x = match &tokens[i].kind {
                        TokenKind::Word(w) => w.number(),
                        _ => None,
                    };
                    s.angles[slot] = match (x, modal.incremental) {
                        (Some(x), false) => Some(x),
                        (Some(x), true) => s.angles[slot].map(|a| a + x),
                        _ => None,
                    };
                }
                None if moves && out.kind == MoveKind::Home => s.angles[slot] = None,
                None => {}
            }
        }
        if let Some(col) = st.supa {
            if !moves {
                return Ok(false);
            }
            if out.kind != MoveKind::Program {
                return Err(at(col, "SUPA with an arc, a cycle or a home move cannot be compensated (expected SUPA G0 or G1 with machine positions)".into()));
            }
            out.kind = MoveKind::Machine;
        }
        if moves && out.kind == MoveKind::Program && !modal.tcp && s.mcall.is_some() {
            out.kind = MoveKind::Cycle;
            out.cycle_col = Some(
                out.axis_words
                    .iter()
                    .flatten()
                    .map(|&i| tokens[i].span.start)
                    .min()
                    .unwrap_or(0),
            );
        }
        Ok(moves)
    }

    /// `DEF type name[=value], …`: the variables, 0 until assigned (as the control sets
    /// them), a value given by an expression the program's constants fix, or unknown.
    fn declaration(
        &self,
        content: &[u8],
        after: usize,
        optional: bool,
        s: &mut Siemens,
        at: At<'_>,
    ) -> Result<bool, Diagnostic> {
        let end = content
            .iter()
            .position(|&b| b == b';')
            .unwrap_or(content.len());
        let rest = std::str::from_utf8(&content[after..end]).unwrap_or("");
        let body = rest.trim_start();
        let skip = after + (rest.len() - body.len());
        let (kind, names) = body.split_once([' ', '\t']).unwrap_or((body, ""));
        let numeric = matches!(kind.to_ascii_uppercase().as_str(), "REAL" | "INT");
        let mut pos = skip + kind.len();
        for part in names.split(',') {
            let start = pos;
            pos += part.len() + 1;
            let part = part.trim();
            if part.is_empty() {
                return Err(at(
                    start,
                    "expected a variable's name after DEF's type".into(),
                ));
            }
            let (name, value) = match part.split_once('=') {
                Some((n, v)) => (n.trim(), Some(v.trim())),
                None => (part, None),
            };
            let plain = is_name(name.as_bytes());
            let key = name.split('[').next().unwrap_or(name).to_ascii_uppercase();
            let known = match value {
                _ if !numeric || !plain || optional => None,
                None => Some((0.0, 0)),
                Some(v) => evaluate_840d(v.as_bytes(), &s.vars),
            };
            s.vars.set(key, known);
        }
        Ok(false)
    }

    /// TRANS, ATRANS, ROT, AROT: the programmable frame; X, Y, Z are its data.
    #[allow(clippy::too_many_arguments)]
    fn frame(
        &self,
        content: &[u8],
        tokens: &[Token],
        kind: &str,
        col: usize,
        rpl: Option<(usize, usize)>,
        modal: &mut Modal,
        s: &mut Siemens,
        at: At<'_>,
    ) -> Result<bool, Diagnostic> {
        let mut xyz: [Option<f64>; 3] = [None; 3];
        for t in tokens {
            let TokenKind::Word(w) = &t.kind else {
                continue;
            };
            match w.letter {
                b'N' => {}
                b'X' | b'Y' | b'Z' => {
                    let value = w.number();
                    // (As for axis words: a shift beyond any travel is a typing error,
                    // and an infinite one would stall the solve.)
                    if value.is_some_and(|v| !v.is_finite() || v.abs() > super::gcode::MAX_WORD) {
                        return Err(at(
                            t.span.start,
                            format!(
                                "{} in {kind} is out of range: expected a number within ±{:e} mm",
                                w.letter as char,
                                super::gcode::MAX_WORD
                            ),
                        ));
                    }
                    xyz[(w.letter - b'X') as usize] = value;
                }
                _ => {
                    return Err(at(
                        t.span.start,
                        format!(
                            "`{}` in a {kind} block: expected X, Y, Z only (a frame's statement stands in its own block)",
                            text(content, t)
                        ),
                    ));
                }
            }
        }
        let scale = if modal.inch { super::INCH } else { 1.0 };
        let rot = s.rot.unwrap_or_else(Rotation3::identity);
        match kind {
            "TRANS" | "ATRANS" => {
                let d = Vector3::new(
                    xyz[0].unwrap_or(0.0),
                    xyz[1].unwrap_or(0.0),
                    xyz[2].unwrap_or(0.0),
                ) * scale;
                if kind == "TRANS" {
                    s.trans = d.into();
                    s.rot = None;
                } else {
                    s.trans = (Vector3::from(s.trans) + rot * d).into();
                }
            }
            _ => {
                let r = match rpl {
                    Some((i, c)) => {
                        if xyz.iter().any(Option::is_some) {
                            return Err(at(
                                c,
                                "RPL= with X, Y or Z angles: expected one of them".into(),
                            ));
                        }
                        let raw = text(content, &tokens[i]);
                        let value = raw.split_once('=').map_or("", |(_, v)| v);
                        let angle = evaluate_840d(value.as_bytes(), &s.vars).ok_or_else(|| at(c, format!("`{raw}`: expected the angle as a number or a variable set to a constant")))?.0;
                        if modal.plane != 0 {
                            return Err(at(
                                c,
                                "RPL= outside G17 is not followed (expected G17)".into(),
                            ));
                        }
                        about(2, angle)
                    }
                    // Roll, pitch, yaw: about Z, then the new Y, then the new X.
                    None => {
                        about(2, xyz[2].unwrap_or(0.0))
                            * about(1, xyz[1].unwrap_or(0.0))
                            * about(0, xyz[0].unwrap_or(0.0))
                    }
                };
                if kind == "ROT" {
                    s.trans = [0.0; 3];
                    s.rot = Some(r);
                } else {
                    s.rot = Some(rot * r);
                }
            }
        }
        if modal.tcp {
            return Err(at(
                col,
                format!(
                    "{kind} under TRAORI cannot be compensated (expected TRAFOOF before it, or the frame set before TRAORI)"
                ),
            ));
        }
        self.apply_frames(modal, s);
        Ok(false)
    }

    /// The frames in force as the modal state's working plane and shift.
    fn apply_frames(&self, modal: &mut Modal, s: &Siemens) {
        let t = Vector3::from(s.trans);
        let identity = |r: &Rotation3<f64>| r.angle() < 1e-12;
        match (&s.swivel, &s.rot) {
            (None, None) => {
                modal.working_plane = None;
                modal.local_shift = s.trans;
            }
            (None, Some(r)) if identity(r) => {
                modal.working_plane = None;
                modal.local_shift = s.trans;
            }
            (None, Some(r)) => {
                let about_z = (r * Vector3::z() - Vector3::z()).norm() < 1e-12;
                modal.working_plane = Some(WorkingPlane {
                    origin: t,
                    rotation: *r,
                    tilted: false,
                    rotation_only: about_z,
                    sequence: None,
                    table_rot: false,
                });
                modal.local_shift = [0.0; 3];
            }
            (Some(sw), r) => {
                let r = r.unwrap_or_else(Rotation3::identity);
                modal.working_plane = Some(WorkingPlane {
                    origin: sw.origin + sw.rotation * t,
                    rotation: sw.rotation * r,
                    tilted: sw.dir != 0,
                    rotation_only: false,
                    sequence: (sw.dir != 0).then_some(sw.dir > 0),
                    table_rot: false,
                });
                modal.local_shift = [0.0; 3];
            }
        }
        modal.shift = modal.shift_from(self.machine);
    }

    /// `CYCLE800(_FR, _TC, _ST, _MODE, _X0, _Y0, _Z0, _A, _B, _C, _X1, _Y1, _Z1, _DIR,
    /// _FR_I, _DMODE)`: the swivel plane; with `_DIR` ±1 the rotary axes turn to it.
    fn swivel(
        &self,
        content: &[u8],
        t: &Token,
        modal: &mut Modal,
        s: &mut Siemens,
        at: At<'_>,
        out: &mut BlockMotion,
    ) -> Result<bool, Diagnostic> {
        let call = &content[t.span.clone()];
        let col = t.span.start;
        if modal.tcp {
            return Err(at(
                col,
                "CYCLE800 under TRAORI cannot be compensated (expected TRAFOOF before it)".into(),
            ));
        }
        let args = arguments(call).ok_or_else(|| {
            at(
                col,
                "expected CYCLE800(…) with its arguments in brackets".into(),
            )
        })?;
        if args.is_empty() {
            // Swivel off: the plane goes, the rotary axes stay.
            s.swivel = None;
            self.apply_frames(modal, s);
            return Ok(false);
        }
        if s.trans != [0.0; 3] || s.rot.is_some() {
            return Err(at(col, "CYCLE800 with a programmable frame in force (TRANS, ATRANS, ROT, AROT): whether the swivel keeps or clears it is the control's setting, not followed (expected TRANS alone, which clears the frame, before CYCLE800)".into()));
        }
        const NAMES: [&str; 16] = [
            "_FR", "_TC", "_ST", "_MODE", "_X0", "_Y0", "_Z0", "_A", "_B", "_C", "_X1", "_Y1",
            "_Z1", "_DIR", "_FR_I", "_DMODE",
        ];
        if args.len() > NAMES.len() {
            return Err(at(
                col + args[NAMES.len()].0,
                format!("CYCLE800 takes at most {} arguments", NAMES.len()),
            ));
        }
        let mut v = [0.0f64; 16];
        let mut tc = String::new();
        for (k, (start, raw)) in args.iter().enumerate() {
            let a = std::str::from_utf8(raw).unwrap_or("").trim();
            if k == 1 {
                tc = a.trim_matches('"').to_string();
                continue;
            }
            if a.is_empty() {
                continue;
            }
            v[k] = evaluate_840d(a.as_bytes(), &s.vars)
                .ok_or_else(|| {
                    at(col + start, format!("CYCLE800's {} is `{a}`: expected a number, or a variable the program sets to a constant", NAMES[k]))
                })?
                .0;
        }
        if tc == "0" {
            s.swivel = None;
            self.apply_frames(modal, s);
            return Ok(false);
        }
        let arg_col = |k: usize| col + args.get(k).map_or(0, |a| a.0);
        let st = v[2];
        if st != 0.0 && st != 1.0 {
            return Err(at(
                arg_col(2),
                format!(
                    "CYCLE800's _ST is {st}: nccomp follows 0 (a new plane) and 1 (added to the plane in force); the other digits select behaviours it does not know"
                ),
            ));
        }
        let mode = v[3];
        if mode.fract() != 0.0 || !(0.0..256.0).contains(&mode) {
            return Err(at(
                arg_col(3),
                format!("CYCLE800's _MODE is {mode}: expected a whole number 0 … 255"),
            ));
        }
        let mode = mode as u32;
        if mode & 0xC0 != 0 {
            return Err(at(
                arg_col(3),
                format!(
                    "CYCLE800's _MODE {mode} is not the axis-by-axis mode (bits 7-6 zero): solid, projection and direct rotary-axis angles are not followed (expected the axis-by-axis mode, such as 57 for X, then Y, then Z, or 27 for Z, then Y, then X)"
                ),
            ));
        }
        let order = [mode & 3, (mode >> 2) & 3, (mode >> 4) & 3];
        if order.contains(&0)
            || order[0] == order[1]
            || order[1] == order[2]
            || order[0] == order[2]
        {
            return Err(at(
                arg_col(3),
                format!(
                    "CYCLE800's _MODE {mode} does not name three different axes (bits 1-0, 3-2, 5-4: 1 X, 2 Y, 3 Z)"
                ),
            ));
        }
        // Each rotation about the axis as the ones before have turned it.
        let rotation = about(order[0] as usize - 1, v[7])
            * about(order[1] as usize - 1, v[8])
            * about(order[2] as usize - 1, v[9]);
        let dir = v[13];
        if ![-1.0, 0.0, 1.0].contains(&dir) {
            return Err(at(
                arg_col(13),
                format!(
                    "CYCLE800's _DIR is {dir}: expected -1 or +1 (the solution with the reference axis's smaller or larger angle), or 0 (no turn)"
                ),
            ));
        }
        let fr = v[0];
        let scale = if modal.inch { super::INCH } else { 1.0 };
        let x0 = Vector3::new(v[4], v[5], v[6]) * scale;
        let x1 = Vector3::new(v[10], v[11], v[12]) * scale;
        let (base_origin, base_rotation) = match (st == 1.0, s.swivel) {
            (true, Some(sw)) => (sw.origin, sw.rotation),
            _ => (Vector3::zeros(), Rotation3::identity()),
        };
        let origin = base_origin + base_rotation * (x0 + rotation * x1);
        s.swivel = Some(Swivel {
            origin,
            rotation: base_rotation * rotation,
            dir: dir as i8,
        });
        self.apply_frames(modal, s);
        // The retraction before the turn, to positions of the machine's own.
        let words = self.axes(modal.chain);
        let var = |l: u8| words.var_of_letter[(l - b'A') as usize];
        let retracted: &[u8] = match fr as i64 {
            0 => b"",
            1 => b"Z",
            2 | 4 | 5 => b"XYZ",
            _ => {
                return Err(at(
                    arg_col(0),
                    format!(
                        "CYCLE800's _FR is {fr}: expected 0 (no retraction), 1 (Z), 2 (Z, then X, Y), 4 or 5 (along the tool)"
                    ),
                ));
            }
        };
        out.homed = retracted
            .iter()
            .filter_map(|&l| var(l))
            .fold(0, |m, v| m | 1 << v);
        if dir == 0.0 {
            if out.homed != 0 {
                out.kind = MoveKind::Home;
                return Ok(true);
            }
            return Ok(false);
        }
        out.kind = MoveKind::ToPlane;
        out.arc_code = None;
        out.cycle_col = Some(col);
        Ok(true)
    }

    /// `CYCLE81(RTP, RFP, SDIS, DP, DPR)` (and 82, 83, whose first five arguments are the
    /// same) as the levels the pass drills to: surface RFP, bottom DP (or RFP − DPR),
    /// set-up clearance RFP + SDIS, end RTP.
    fn drill_def(
        &self,
        number: usize,
        content: &[u8],
        t: &Token,
        s: &Siemens,
        at: At<'_>,
    ) -> Result<CycleDef, Diagnostic> {
        let call = &content[t.span.clone()];
        let col = t.span.start;
        let name =
            String::from_utf8_lossy(&call[..call.iter().position(|&b| b == b'(').unwrap_or(0)])
                .to_ascii_uppercase();
        match name.as_str() {
            // Drilling, with a dwell at the bottom, deep-hole drilling: down the tool axis
            // and back.
            "CYCLE81" | "CYCLE82" | "CYCLE83" => {}
            _ => {
                return Err(at(
                    col,
                    format!(
                        "{name} is not a drilling cycle nccomp follows (expected CYCLE81, CYCLE82 or CYCLE83)"
                    ),
                ));
            }
        }
        let args = arguments(call)
            .ok_or_else(|| at(col, format!("expected {name}(…) with its arguments")))?;
        let value = |k: usize| -> Result<Option<f64>, Diagnostic> {
            let Some((start, raw)) = args.get(k) else {
                return Ok(None);
            };
            let a = std::str::from_utf8(raw).unwrap_or("").trim();
            if a.is_empty() {
                return Ok(None);
            }
            evaluate_840d(a.as_bytes(), &s.vars)
                .map(|v| Some(v.0))
                .ok_or_else(|| at(col + start, format!("{name}'s argument {} is `{a}`: expected a number, or a variable set to a constant", k + 1)))
        };
        let need = |k: usize, what: &str| -> Result<f64, Diagnostic> {
            value(k)?.ok_or_else(|| at(col, format!("{name} needs {what}")))
        };
        let rtp = need(0, "the retraction plane RTP")?;
        let rfp = need(1, "the reference plane RFP")?;
        let sdis = value(2)?.unwrap_or(0.0);
        let (bottom, depth) = match (value(3)?, value(4)?) {
            (Some(_), Some(_)) => {
                return Err(at(
                    col,
                    format!(
                        "{name} gives both depths, DP and DPR: which one the cycle takes is not followed (expected one of them)"
                    ),
                ));
            }
            (Some(dp), None) => (dp, Some(dp - rfp)),
            (None, Some(dpr)) => (rfp - dpr.abs(), None),
            (None, None) => {
                return Err(at(col, format!("{name} needs the depth DP or DPR")));
            }
        };
        Ok(CycleDef {
            number: 200,
            line: number,
            params: vec![
                (203, Param::Known(rfp)),
                (201, Param::Known(bottom - rfp)),
                (200, Param::Known(sdis)),
                (204, Param::Known(rtp - rfp)),
            ],
            text: vec![content.to_vec()],
            surface_written: None,
            siemens: Some(super::heidenhain::SiemensCall { depth, end: rtp }),
        })
    }
}
