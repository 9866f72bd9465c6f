//! The G-code front end (ISO 6983 as Fanuc, Haas and LinuxCNC write it): a block's tokens
//! into its [`Block`], following the [`Modal`] state.
//!
//! The tool chain and the lathe's spindle mode are read first (T words, M3/M4/M5/M19, the
//! spindle's C word act before the block's motion, as in LinuxCNC's order of execution):
//! the chain decides which letters are axes.

use super::codes::{Code, Cycle, Spindle as SpindleCode, Tcp};
use super::{BlockMotion, Modal, Motion, MoveKind, Reader, Spindle};
use crate::diag::Diagnostic;
use crate::kinematics::MAX_AXES;
use crate::nc::{self, Token, TokenKind, Value};

/// Whether the G code `code10` of this block switches a smoothing or look-ahead mode, which
/// moves no block end: Fanuc's high-speed machining `G05 P10000`/`G05 P0`, AI contour
/// control `G05.1 Q1`/`Q0` and advanced preview `G08 P1`/`P0`. The same numbers are
/// LinuxCNC's splines (G5, G5.1) and lathe radius mode (G8): those come with axis words or
/// without a P (Q) word.
fn smoothing_switch(code10: i64, tokens: &[Token]) -> bool {
    let switch = match code10 {
        50 | 80 => b'P',
        51 => b'Q',
        _ => return false,
    };
    let mut has_switch = false;
    for t in tokens {
        if let TokenKind::Word(w) = &t.kind {
            match w.letter {
                b'X' | b'Y' | b'Z' | b'A' | b'B' | b'C' | b'U' | b'V' | b'W' | b'I' | b'J'
                | b'K' | b'R' => return false,
                letter if letter == switch => has_switch = true,
                _ => {}
            }
        }
    }
    has_switch
}

/// The UTF-8 byte-order mark.
const BOM: &[u8] = b"\xEF\xBB\xBF";

/// The largest magnitude of a word's number (but block and program numbers): a kilometre,
/// a thousand turns or a feed of a kilometre a minute are far beyond any machine; beyond
/// this a number is a mistake.
pub const MAX_WORD: f64 = 1e6;

/// A located refusal: (byte offset in the line, message) → diagnostic.
pub type At<'a> = &'a dyn Fn(usize, String) -> Diagnostic;

/// A G or M word as the program wrote it (for messages).
pub fn code_text(content: &[u8], t: &Token) -> String {
    String::from_utf8_lossy(&content[t.span.clone()])
        .trim()
        .to_string()
}

/// The dialect a block of another control's language is written in, from words no G-code
/// block has: Heidenhain's conversational keywords after the block number, Sinumerik's
/// declarations, instructions and assignments to named variables.
fn foreign_dialect(content: &[u8]) -> Option<&'static str> {
    let text = String::from_utf8_lossy(content);
    let body = text
        .trim_start()
        .trim_start_matches(|c: char| c.is_ascii_digit())
        .trim_start();
    const HEIDENHAIN: [&str; 14] = [
        "BEGIN PGM",
        "END PGM",
        "BLK FORM",
        "TOOL CALL",
        "TOOL DEF",
        "CYCL DEF",
        "CYCL CALL",
        "CALL LBL",
        "LBL ",
        "PLANE ",
        "FUNCTION ",
        "FN ",
        "L ",
        "CC ",
    ];
    if text.starts_with(|c: char| c.is_ascii_digit())
        && HEIDENHAIN.iter().any(|k| body.starts_with(k))
    {
        return Some("a Heidenhain TNC conversational program (`BEGIN PGM`, `L X+…`)");
    }
    // Without comments: `(MSG, …)` is LinuxCNC's, not a Sinumerik instruction.
    if nc::sinumerik::looks_like(content) {
        return Some("a Sinumerik program (`DEF`, `TRAORI`, `CYCLE800`, `X=_NAME`)");
    }
    None
}

/// The block starts with a block delete `/`.
fn is_optional(tokens: &[Token]) -> bool {
    tokens
        .iter()
        .find(|t| t.kind != TokenKind::Space)
        .is_some_and(|t| t.kind == TokenKind::BlockDelete)
}

impl Reader<'_> {
    /// Read one block: check that every word is understood, follow its modal words in
    /// `modal`, and say whether it moves and how (into `motion`, a caller's buffer reused
    /// from block to block). On a refusal `modal` holds what the block changed before the
    /// refused word.
    pub fn read(
        &self,
        line: &nc::Line<'_>,
        tokens: &[Token],
        modal: &mut Modal,
        at: At<'_>,
        motion: &mut BlockMotion,
    ) -> Result<bool, Diagnostic> {
        // Past M2/M30 the program has ended: what follows is not read in the state it
        // ended in (a subprogram stored there runs only when called), and passes unchanged.
        if modal.program_end.is_some() && modal.dialect != nc::Dialect::Heidenhain {
            if tokens
                .iter()
                .any(|t| matches!(t.kind, TokenKind::Word(_) | TokenKind::Other))
            {
                modal.after_end += 1;
            }
            return Ok(false);
        }
        match modal.dialect {
            nc::Dialect::Heidenhain => return self.read_tnc(line, tokens, modal, at, motion),
            nc::Dialect::Sinumerik => return self.read_840d(line, tokens, modal, at, motion),
            nc::Dialect::Iso => {}
        }
        self.select(line, tokens, modal, at)
            .and_then(|()| self.read_words(line, tokens, modal, at, motion))
            .map_err(|d| match foreign_dialect(line.content) {
                // A refusal of another dialect's block says what the program is.
                Some(dialect) if dialect.contains("Heidenhain") => at(
                    0,
                    format!(
                        "this looks like {dialect}, in a program read as G-code: nccomp reads a TNC program as one when it starts with a numbered BEGIN PGM, or with --dialect heidenhain (expected G-code such as G1 X10.5 here)"
                    ),
                ),
                Some(dialect) => at(
                    0,
                    format!(
                        "this looks like {dialect}, in a program read as G-code: nccomp reads a Sinumerik program as one when one of its first 200 lines has a Siemens instruction (DEF, TRAORI, CYCLE800, MSG, T=\"…\" …), or with --dialect sinumerik (expected G-code such as G1 X10.5 here)"
                    ),
                ),
                None => d,
            })
    }

    /// A G68.2 block (`set`: its X Y Z I J K set the tilted working plane, and it moves
    /// nothing) or a G53.1 block (the rotary axes turn the tool to the plane: a motion of
    /// the controller's own). Either takes no other motion or axis words.
    #[allow(clippy::too_many_arguments)]
    /// G10 L2 / L20 (work offset values) and G52 (a local shift): the block's X, Y, Z
    /// words are data; the program zero moves. Nothing moves.
    #[allow(clippy::too_many_arguments)]
    fn offset_data(
        &self,
        line: &nc::Line<'_>,
        tokens: &[Token],
        state: &mut Modal,
        at: At<'_>,
        out: &mut BlockMotion,
        code: usize,
        code10: i64,
    ) -> Result<bool, Diagnostic> {
        let words = &self.chains[state.chain];
        let name = code_text(line.content, &tokens[code]);
        let col = tokens[code].span.start;
        let mut xyz: [Option<f64>; 3] = [None; 3];
        for (v, word) in out.axis_words.iter().enumerate().take(words.len()) {
            let Some(i) = *word else { continue };
            let value = word_number(tokens, i);
            match b"XYZ".iter().position(|&l| l == words.letters[v]) {
                Some(c) if words.is_linear(v) => {
                    xyz[c] = Some(if state.inch {
                        value * super::INCH
                    } else {
                        value
                    });
                }
                _ => {
                    return Err(at(
                        tokens[i].span.start,
                        format!(
                            "{} words in {name} cannot be compensated: offsets of axes other than X, Y, Z are not supported (expected X, Y, Z)",
                            words.letters[v] as char
                        ),
                    ));
                }
            }
        }
        if code10 == 520 {
            if state.incremental {
                return Err(at(
                    col,
                    format!(
                        "{name} in incremental mode (G91) cannot be compensated (expected the shift in G90)"
                    ),
                ));
            }
            for (c, x) in xyz.iter().enumerate() {
                if let Some(x) = x {
                    state.local_shift[c] = *x;
                }
            }
            state.shift = state.shift_from(self.machine);
            return Ok(false);
        }
        let l = letter_number(tokens, b'L');
        let p = p_number(tokens);
        let target = match (l, p) {
            (Some(l), Some(p)) if l == 2.0 && p.fract() == 0.0 && (0.0..=6.0).contains(&p) => {
                if p == 0.0 { 0 } else { 530 + 10 * p as i64 }
            }
            (Some(l), Some(p)) if l == 20.0 && p.fract() == 0.0 && (1.0..=300.0).contains(&p) => {
                100_000 + p as i64
            }
            (Some(l), _) if l != 2.0 && l != 20.0 => {
                return Err(at(
                    col,
                    format!(
                        "{name} L{l} cannot be compensated: it sets data other than work offsets (tool offsets, parameters), which is not supported (G10 L2 and L20 set work offsets)"
                    ),
                ));
            }
            _ => {
                return Err(at(
                    col,
                    format!(
                        "{name} cannot be compensated: expected L2 P0 … P6 (G54 … G59; P0 the external offset) or L20 P1 … P300 (G54.1 P1 …) with the offset's X, Y, Z"
                    ),
                ));
            }
        };
        let table = self.machine.work_offsets.as_ref();
        let known = state
            .offsets
            .iter()
            .rev()
            .find(|(c, _)| *c == target)
            .map(|(_, v)| *v)
            .or_else(|| table.and_then(|t| t.values.get(&target).copied()))
            .or((target == 0).then_some([0.0; 3]));
        let mut value = [0.0; 3];
        for c in 0..3 {
            value[c] = match (xyz[c], known, state.incremental) {
                (Some(x), _, false) => x,
                (Some(x), Some(k), true) => k[c] + x,
                (None, Some(k), _) => k[c],
                (_, None, _) => {
                    let offset = if target == 0 {
                        "the external offset".to_string()
                    } else {
                        crate::model::WorkOffsets::name(&target)
                    };
                    return Err(at(
                        col,
                        format!(
                            "{name} leaves {} of {offset} as it was, and the machine file's [work_offsets] does not give it (expected X, Y and Z in G90, or {offset} in [work_offsets])",
                            ["X", "Y", "Z"][c]
                        ),
                    ));
                }
            };
        }
        state.offsets.retain(|(c, _)| *c != target);
        state.offsets.push((target, value));
        state.shift = state.shift_from(self.machine);
        Ok(false)
    }

    fn working_plane(
        &self,
        tokens: &[Token],
        state: &mut Modal,
        at: At<'_>,
        out: &mut BlockMotion,
        code: usize,
        set: bool,
    ) -> Result<bool, Diagnostic> {
        let words = &self.chains[state.chain];
        let col = tokens[code].span.start;
        let number = |i: usize| word_number(tokens, i);
        if state.tcp {
            return Err(at(
                col,
                "a tilted working plane under tool-centre-point control cannot be compensated (expected G49 before G68.2)".into(),
            ));
        }
        // Other controls' variants (Mazak's G68.2 P1 roll-pitch-yaw, LinuxCNC's G53.1 P
        // turning directions) give P, Q … their own meanings: not guessed.
        let allowed: &[u8] = if set { b"GNXYZIJK" } else { b"GN" };
        if let Some((t, letter)) = tokens.iter().find_map(|t| match &t.kind {
            TokenKind::Word(w) if !allowed.contains(&w.letter) && !b"XYZ".contains(&w.letter) => {
                Some((t, w.letter))
            }
            _ => None,
        }) && !(set
            && out
                .axis_words
                .iter()
                .flatten()
                .any(|&i| tokens[i].span == t.span))
        {
            return Err(at(
                t.span.start,
                format!(
                    "{} words are not expected in {} (expected {})",
                    letter as char,
                    if set { "G68.2" } else { "G53.1" },
                    if set {
                        "X, Y, Z for the plane's origin and I, J, K for its Euler angles"
                    } else {
                        "G53.1 on its own"
                    }
                ),
            ));
        }
        if state.working_plane.is_some_and(|p| p.rotation_only) {
            return Err(at(
                col,
                format!(
                    "{} under a coordinate rotation (G68) cannot be compensated (expected G69 before it)",
                    if set { "G68.2" } else { "G53.1" }
                ),
            ));
        }
        if !set {
            if state.working_plane.is_none() {
                return Err(at(
                    col,
                    "G53.1 turns the tool to the tilted working plane, but no plane is set (expected G68.2 before it)".into(),
                ));
            }
            if let Some(i) = out.axis_words.iter().chain(&out.arc_words).flatten().next() {
                return Err(at(
                    tokens[*i].span.start,
                    "G53.1 takes no axis words: the controller alone turns the rotary axes to the plane (expected G53.1 on its own)".into(),
                ));
            }
            if let Some(plane) = state.working_plane.as_mut() {
                plane.tilted = true;
            }
            out.kind = MoveKind::ToPlane;
            out.arc_code = Some(code);
            return Ok(true);
        }
        if state.incremental {
            return Err(at(
                col,
                "G68.2 in incremental mode (G91) cannot be compensated (expected the plane in G90)"
                    .into(),
            ));
        }
        let mut origin = [0.0; 3];
        for (v, word) in out.axis_words.iter().enumerate().take(words.len()) {
            let Some(i) = *word else { continue };
            match b"XYZ".iter().position(|&l| l == words.letters[v]) {
                Some(c) if words.is_linear(v) => {
                    origin[c] = if state.inch {
                        number(i) * super::INCH
                    } else {
                        number(i)
                    }
                }
                _ => {
                    return Err(at(
                        tokens[i].span.start,
                        format!(
                            "{} words are not expected in G68.2 (expected X, Y, Z for the plane's origin and I, J, K for its Euler angles)",
                            words.letters[v] as char
                        ),
                    ));
                }
            }
        }
        if let Some(i) = out.arc_words[3] {
            return Err(at(
                tokens[i].span.start,
                "R words are not expected in G68.2 (expected X, Y, Z for the plane's origin and I, J, K for its Euler angles)".into(),
            ));
        }
        let euler = [0, 1, 2].map(|c| out.arc_words[c].map_or(0.0, number));
        state.working_plane = Some(super::WorkingPlane::new(origin, euler));
        Ok(false)
    }

    /// `G68 X Y R` in G17: the program's X, Y turned by R degrees about (X, Y). Refused:
    /// another plane, G91, no centre or angle, I/J/K (FANUC's 3-D conversion), under TCP or
    /// a tilted working plane.
    fn rotation(
        &self,
        tokens: &[Token],
        state: &mut Modal,
        at: At<'_>,
        out: &mut BlockMotion,
        code: usize,
    ) -> Result<bool, Diagnostic> {
        let words = &self.chains[state.chain];
        let col = tokens[code].span.start;
        let number = |i: usize| word_number(tokens, i);
        let refuse =
            |col: usize, why: &str| Err(at(col, format!("G68 cannot be compensated: {why}")));
        if state.tcp {
            return refuse(
                col,
                "a rotation under tool-centre-point control is not followed (expected G49 before G68)",
            );
        }
        if state.working_plane.is_some() {
            return refuse(
                col,
                "a rotation under a tilted working plane or another rotation is not followed (expected G69 before G68)",
            );
        }
        if state.plane != 0 {
            return refuse(
                col,
                "only a rotation in the G17 plane (about Z) is followed",
            );
        }
        if state.incremental {
            return refuse(
                col,
                "in G91 its centre and angle may be increments, by the control's settings (expected G68 in G90)",
            );
        }
        if let Some(i) = out.arc_words[..3].iter().flatten().next() {
            return refuse(
                tokens[*i].span.start,
                "with I, J, K it is FANUC's three-dimensional coordinate conversion, which is not followed (expected G68 X Y R)",
            );
        }
        let mut centre = [None; 2];
        for (v, word) in out.axis_words.iter().enumerate().take(words.len()) {
            let Some(i) = *word else { continue };
            match b"XY".iter().position(|&l| l == words.letters[v]) {
                Some(c) if words.is_linear(v) => {
                    let x = number(i);
                    centre[c] = Some(if state.inch { x * super::INCH } else { x });
                }
                _ => {
                    return refuse(
                        tokens[i].span.start,
                        &format!(
                            "{} words are not expected in G68 (expected X, Y for the centre and R for the angle)",
                            words.letters[v] as char
                        ),
                    );
                }
            }
        }
        let (Some(x), Some(y)) = (centre[0], centre[1]) else {
            return refuse(
                col,
                "without X and Y the centre is where the tool stands, which nccomp does not take from a G68 (expected G68 X Y R)",
            );
        };
        let Some(r) = out.arc_words[3] else {
            return refuse(
                col,
                "without R the angle is the control's setting (expected G68 X Y R)",
            );
        };
        state.working_plane = Some(super::WorkingPlane::rotation([x, y], number(r)));
        Ok(false)
    }

    /// Follow the block's T word and spindle codes: the tool chain and spindle mode the
    /// block runs in.
    pub(super) fn select(
        &self,
        line: &nc::Line<'_>,
        tokens: &[Token],
        modal: &mut Modal,
        at: At<'_>,
    ) -> Result<(), Diagnostic> {
        let machine = self.machine;
        let lathe = machine.lathe;
        if lathe.is_none() && !self.tools_listed {
            return Ok(());
        }
        let optional = is_optional(tokens);
        let current = modal.chain;
        let mut chain = current;
        let mut spindle = modal.spindle;
        // The first word that changes something, for messages.
        let mut cause: Option<&Token> = None;
        let mut spindle_word: Option<&Token> = None;
        let spindle_letter = lathe.map(|l| machine.axes[l.spindle].word as u8);
        for t in tokens {
            let TokenKind::Word(w) = &t.kind else {
                continue;
            };
            // Expressions and parameters are refused when the words are read.
            let Value::Number { value, .. } = w.value else {
                continue;
            };
            match w.letter {
                b'T' if self.tools_listed => {
                    if value < 0.0 || value.fract() != 0.0 || value > f64::from(u32::MAX) {
                        return Err(at(
                            t.span.start,
                            format!(
                                "`{}`: expected a tool number (a whole number from 0)",
                                code_text(line.content, t)
                            ),
                        ));
                    }
                    let number = value as u32;
                    if number == 0 {
                        continue;
                    }
                    chain = machine.chain_of_tool(number).ok_or_else(|| {
                        let lists: Vec<String> = machine
                            .tool_chains
                            .iter()
                            .filter(|c| !c.tools.is_empty())
                            .map(|c| {
                                let tools: Vec<String> =
                                    c.tools.iter().map(|t| format!("T{t}")).collect();
                                format!("`{}` {}", c.name, tools.join(" "))
                            })
                            .collect();
                        at(
                            t.span.start,
                            format!(
                                "T{number} selects no tool chain: expected a tool the machine file lists in a chain's `tools` ({})",
                                lists.join("; ")
                            ),
                        )
                    })?;
                    if chain != current {
                        cause.get_or_insert(t);
                    }
                }
                b'M' if lathe.is_some() => {
                    let before = spindle;
                    if let Code::Spindle(code) = self.code(b'M', (value * 10.0).round() as i64) {
                        match code {
                            SpindleCode::Turn => spindle = Spindle::Turning(line.number),
                            // Stopping a positioned spindle leaves it where it is.
                            SpindleCode::Stop if spindle != Spindle::Positioned => {
                                spindle = Spindle::Free
                            }
                            SpindleCode::Stop => {}
                            SpindleCode::Orient => spindle = Spindle::Positioned,
                        }
                    }
                    if spindle != before {
                        cause.get_or_insert(t);
                    }
                }
                letter if Some(letter) == spindle_letter => spindle_word = Some(t),
                _ => {}
            }
        }
        if let Some(t) = spindle_word {
            if let Spindle::Turning(on) = spindle {
                let letter = spindle_letter.map_or('C', char::from);
                return Err(at(
                    t.span.start,
                    format!(
                        "{letter} positions the spindle, but it turns (M3/M4 at line {on}): expected M5 or M19 before the spindle is positioned"
                    ),
                ));
            }
            if spindle != Spindle::Positioned {
                cause.get_or_insert(t);
                spindle = Spindle::Positioned;
            }
        }
        let Some(cause) = cause else {
            return Ok(());
        };
        let what = code_text(line.content, cause);
        if optional {
            return Err(at(
                cause.span.start,
                format!(
                    "{what} in an optional block (/) cannot be compensated: whether the block runs would decide which tool chain or spindle mode every later block is compensated in (move it out of the optional block)"
                ),
            ));
        }
        let positioned = spindle == Spindle::Positioned;
        let was_positioned = modal.spindle == Spindle::Positioned;
        if modal.tcp && (chain != current || positioned != was_positioned) {
            return Err(at(
                cause.span.start,
                format!(
                    "{what} under tool-centre-point control (G43.4/G43.5) cannot be compensated: cancel it (G49) first"
                ),
            ));
        }
        modal.spindle = spindle;
        modal.chain = chain;
        Ok(())
    }

    /// Check that every word is understood, follow the modal words, and say which axis
    /// words the block moves (false: it moves nothing).
    pub(super) fn read_words(
        &self,
        line: &nc::Line<'_>,
        tokens: &[Token],
        state: &mut Modal,
        at: At<'_>,
        out: &mut BlockMotion,
    ) -> Result<bool, Diagnostic> {
        let words = &self.chains[state.chain];
        let n = words.letters.len();
        let optional = is_optional(tokens);
        // A code's refusal: its text as the program wrote it, then why.
        let refuse_code = |t: &Token, why: String| {
            at(
                t.span.start,
                format!("{} {why}", code_text(line.content, t)),
            )
        };
        // Written in place: the block's motion is 340 bytes.
        out.axis_words = [None; MAX_AXES];
        out.arc_words = [None; 4];
        out.arc_code = None;
        out.optional = optional;
        out.homed = 0;
        let axis_words = &mut out.axis_words;
        let mut has_words = false;
        let mut dwell = false;
        let mut motion_in_block: Option<(Motion, usize)> = None;
        let mut h_word: Option<(u32, usize)> = None;
        let mut g43 = false;
        // A plain G43 (or a machine's TCP-off code) ends tool-centre-point control: G43,
        // G43.4, G43.5 and G49 are one modal group (Fanuc's group 08).
        let mut tcp_off = false;
        let mut g49 = false;
        let mut tcp_on = false;
        let mut tcp_vector = false;
        let mut o_word = None;
        let mut other_text = None;
        let mut arc_word: Option<(char, usize)> = None;
        let mut arc_words: [Option<usize>; 4] = [None; 4];
        let mut arc_code = None;
        let mut p_word = None;
        let mut special: Option<MoveKind> = None;
        // The letters of the axes a machine file's code sends to machine positions.
        let mut homed_letters = 0u32;
        // M6: the tool change sends the machine file's `change_moves` axes to the change
        // position.
        let mut tool_change: Option<usize> = None;
        let mut set_reference: Option<usize> = None;
        let mut returned: Option<usize> = None;
        let mut program_end = false;
        // G187: its E word is the smoothing tolerance.
        let mut smoothing = false;
        // G68.2 (its X Y Z I J K are the plane's data) and G53.1.
        let mut plane_words: Option<usize> = None;
        let mut to_plane: Option<usize> = None;
        // G68: a rotation of the program's coordinates.
        let mut rotation: Option<usize> = None;
        // With a work offset table: G10 and G52 (their axis words are offset data), G54.1,
        // and whether the program zero changes.
        let offset_table = self.machine.work_offsets.is_some();
        let mut offset_data: Option<(usize, i64)> = None;
        let mut extended: Option<usize> = None;
        let mut zero_changed = false;
        for (i, t) in tokens.iter().enumerate() {
            let w = match &t.kind {
                TokenKind::Word(w) => w,
                // A UTF-8 byte-order mark before the program's first byte says only how the
                // file is encoded.
                TokenKind::Other
                    if line.offset == 0
                        && i == 0
                        && t.span == (0..3)
                        && line.content.starts_with(BOM) =>
                {
                    continue;
                }
                TokenKind::Other => {
                    other_text.get_or_insert(t.span.start);
                    continue;
                }
                _ => continue,
            };
            has_words = true;
            let letter = w.letter as char;
            let number = match w.value {
                // Past the largest a word may hold (a number too long for a float is
                // infinite): refused here, before it reaches the model.
                Value::Number { value, .. }
                    if (value.is_nan() || value.abs() > MAX_WORD)
                        && !matches!(letter, 'N' | 'O') =>
                {
                    return Err(at(
                        t.span.start,
                        format!(
                            "{letter} is {}: expected a number within ±{MAX_WORD:e} (mm, inch, degrees, a code or a feed)",
                            if value.is_finite() {
                                "out of range"
                            } else {
                                "too large to be a number"
                            }
                        ),
                    ));
                }
                Value::Number { value, .. } => value,
                // Words that never move a block end may keep what nccomp cannot evaluate.
                Value::Expression | Value::Parameter
                    if matches!(letter, 'F' | 'S' | 'P' | 'Q' | 'L' | 'E') =>
                {
                    continue;
                }
                Value::Expression => {
                    let text = &line.content[w.value_span.clone()];
                    let why = match super::params::first_unknown(text, &state.params) {
                        Some(param) => format!("that reads {param}"),
                        None => "nccomp does not evaluate (functions such as SIN, MOD, logical operators, brackets nested more than 64 deep, or a value with more than 9 decimals)".to_string(),
                    };
                    return Err(at(
                        t.span.start,
                        format!(
                            "{letter} is given by an expression {why} (expected a number, or + - * / over numbers and parameters the program sets to constants)"
                        ),
                    ));
                }
                Value::Parameter => {
                    let text = &line.content[w.value_span.clone()];
                    let param =
                        super::params::first_unknown(text, &state.params).unwrap_or_else(|| {
                            format!(
                                "{}, an indirect parameter whose value is decided at run time",
                                String::from_utf8_lossy(text)
                            )
                        });
                    return Err(at(
                        t.span.start,
                        format!(
                            "{letter} is given by a parameter, {param} (expected a number, or a parameter the program sets to a constant before this block, such as #100 = 12.5)"
                        ),
                    ));
                }
                Value::Missing => {
                    if letter == 'O' {
                        o_word = Some(t.span.start);
                        continue;
                    }
                    return Err(at(
                        t.span.start,
                        format!("{letter} has no value (expected a number after it)"),
                    ));
                }
            };
            match letter {
                'G' => {
                    let code10 = (number * 10.0).round() as i64;
                    if smoothing_switch(code10, tokens) {
                        continue;
                    }
                    let code = self.code(b'G', code10);
                    // On a lathe G50 with axis words sets the coordinates of where the
                    // tool stands (G92's meaning on a mill); G50 S… alone limits the
                    // spindle speed.
                    if code10 == 500
                        && self.machine.lathe.is_some()
                        && tokens.iter().any(|t| {
                            matches!(&t.kind, TokenKind::Word(w) if b"XYZUVWABC".contains(&w.letter))
                        })
                    {
                        return Err(refuse_code(t, "cannot be compensated: on a lathe, G50 with axis words is a coordinate setting (program zero moves so that where the tool stands takes the block's coordinates), not a move, and nccomp does not follow it (expected a work offset, G54–G59, for program zero; G50 S… alone, the spindle speed limit, passes)".into()));
                    }
                    if offset_table {
                        match code {
                            Code::DataSetting(_) if code10 == 100 || code10 == 520 => {
                                offset_data = Some((i, code10));
                                continue;
                            }
                            Code::ExtendedWorkOffset => {
                                extended = Some(i);
                                continue;
                            }
                            _ => {}
                        }
                    }
                    match code {
                        code @ (Code::Unsupported(_)
                        | Code::Unknown
                        | Code::DataSetting(_)
                        | Code::TransformOn(_)
                        | Code::Probe
                        | Code::Skip
                        | Code::MacroCall
                        | Code::ModalMacro
                        | Code::ExtendedWorkOffset
                        | Code::Cycle(Cycle::Other(_))) => {
                            if let Code::DataSetting(what) = code
                                && let Some(param) =
                                    unknown_parameter(line.content, tokens, &state.params)
                            {
                                return Err(at(
                                    t.span.start,
                                    format!(
                                        "{} cannot be compensated: {what} writes the controller's offsets from {param}; what the later blocks' words mean depends on it (expected numbers, or parameters the program sets to constants)",
                                        code_text(line.content, t),
                                    ),
                                ));
                            }
                            if (920..=923).contains(&code10) {
                                return Err(refuse_code(t, "cannot be compensated: G92 is a coordinate setting (program zero moves so that where the axes stand takes the block's coordinates), not a move, and nccomp does not follow it (expected a work offset, G54–G59, for program zero)".into()));
                            }
                            let what = match code {
                                Code::Unsupported(what)
                                | Code::DataSetting(what)
                                | Code::TransformOn(what)
                                | Code::Cycle(Cycle::Other(what)) => what,
                                Code::Probe => "probing (G38.x)",
                                Code::Skip => "a skip (probing) move (G31)",
                                Code::MacroCall => {
                                    "a macro call (G65), which runs a program that is not in this file (its motion, a probing or measuring macro's offsets, are decided on the control),"
                                }
                                Code::ModalMacro => "a modal macro call (G66)",
                                Code::ExtendedWorkOffset => "an extended work offset (G54.1)",
                                _ => "this G code",
                            };
                            return Err(at(
                                t.span.start,
                                format!(
                                    "{} cannot be compensated: {what} {}",
                                    code_text(line.content, t),
                                    if what == "this G code" {
                                        "is not known to nccomp"
                                    } else {
                                        "is not supported"
                                    }
                                ),
                            ));
                        }
                        Code::Line { rapid } => {
                            motion_in_block = Some((Motion::Line, t.span.start));
                            state.rapid = rapid;
                        }
                        Code::Arc { clockwise } => {
                            motion_in_block = Some((Motion::Arc, t.span.start));
                            state.rapid = false;
                            state.clockwise = clockwise;
                            arc_code = Some(i);
                        }
                        Code::Dwell => dwell = true,
                        Code::Units { inch } => {
                            state.inch = inch;
                            state.units_stated = true;
                        }
                        Code::ToolLength => {
                            g43 = true;
                            tcp_off = true;
                        }
                        Code::TcpOn(kind) => {
                            g43 = true;
                            tcp_on = true;
                            tcp_vector = kind == Tcp::Vector;
                        }
                        Code::TcpOff => tcp_off = true,
                        Code::ToolLengthOff => g49 = true,
                        Code::WorkOffset(code) if offset_table => {
                            state.work_offset = Some(code);
                            zero_changed = true;
                        }
                        Code::WorkOffset(code) => {
                            if let Some(prev) = state.work_offset
                                && prev != code
                            {
                                return Err(refuse_code(t, "switches the work offset; the machine file describes one program zero, so a program must keep to one work offset".into()));
                            }
                            state.work_offset = Some(code);
                        }
                        Code::CancelCycle => state.motion = None,
                        Code::Cycle(Cycle::Drill) => {
                            motion_in_block = Some((Motion::Cycle, t.span.start));
                            arc_code = Some(i);
                        }
                        Code::CycleReturn { initial } => state.retract_to_initial = initial,
                        Code::Diameter { diameter } => {
                            if diameter && self.machine.lathe.is_none() {
                                return Err(refuse_code(t, "cannot be compensated: lathe diameter mode needs a [lathe] table in the machine file (the spindle that turns the part)".into()));
                            }
                            if optional && diameter != state.diameter {
                                return Err(refuse_code(t, "in an optional block (/) cannot be compensated: whether the block runs would decide how every later X word is read (move it out of the optional block)".into()));
                            }
                            state.diameter = diameter;
                        }
                        Code::Distance { incremental } => {
                            if optional && incremental != state.incremental {
                                return Err(refuse_code(t, "in an optional block (/) cannot be compensated: whether the block runs would decide how every later axis word is read (move the distance mode out of the optional block)".into()));
                            }
                            state.incremental = incremental;
                        }
                        Code::MachineCoordinates => {
                            special.get_or_insert(MoveKind::Machine);
                        }
                        Code::ReturnHome => special = Some(MoveKind::Home),
                        Code::MachineMove(letters) => {
                            special = Some(MoveKind::Home);
                            homed_letters |= letters;
                        }
                        Code::SetReference => set_reference = Some(i),
                        Code::Plane(plane) => state.plane = plane,
                        Code::ArcCentres { absolute } => state.arc_absolute = absolute,
                        Code::Feed { inverse_time, .. } => state.inverse_time = inverse_time,
                        Code::TransformOff
                        | Code::Harmless
                        | Code::Spindle(_)
                        | Code::ProgramEnd
                        | Code::Subprogram
                        | Code::Return => {}
                        Code::Smoothing => smoothing = true,
                        Code::TiltedPlane => plane_words = Some(i),
                        Code::ToolToPlane => to_plane = Some(i),
                        Code::Rotation => rotation = Some(i),
                        Code::PlaneOff => state.working_plane = None,
                    }
                }
                'M' => {
                    let code10 = (number * 10.0).round() as i64;
                    if code10 == 60 {
                        tool_change = Some(t.span.start);
                    }
                    match self.code(b'M', code10) {
                        Code::Return => returned = Some(t.span.start),
                        // With block delete on, an optional end does not end the program.
                        Code::ProgramEnd if !optional => program_end = true,
                        Code::Subprogram => {
                            return Err(refuse_code(t, "cannot be compensated: a subprogram call (M97/M98) is not supported".into()));
                        }
                        Code::TcpOn(_) => {
                            tcp_on = true;
                            tcp_vector = false;
                        }
                        Code::TcpOff => tcp_off = true,
                        Code::MachineMove(letters) => {
                            special = Some(MoveKind::Home);
                            homed_letters |= letters;
                        }
                        Code::Unsupported(what) => {
                            return Err(refuse_code(
                                t,
                                format!("cannot be compensated: {what} is not supported"),
                            ));
                        }
                        Code::Unknown => {
                            return Err(refuse_code(t, "cannot be compensated: this M code is not known to nccomp, and what it does to the machine's motion cannot be guessed (expected a standard M code; a machine file may name the machine's own codes under [codes] as `harmless` or as `tcp_on`/`tcp_off` switches)".into()));
                        }
                        _ => {}
                    }
                }
                'T' => state.tool = Some(number as u32),
                'H' => h_word = Some((number as u32, t.span.start)),
                'O' => o_word = Some(t.span.start),
                'P' => p_word = Some(t.span.start),
                'N' | 'F' | 'S' | 'D' | 'Q' | 'L' => {}
                _ => {
                    let var = (letter.is_ascii_uppercase())
                        .then(|| words.var_of_letter[(w.letter - b'A') as usize])
                        .flatten();
                    match var {
                        Some(v) => {
                            if axis_words[v].is_some() {
                                return Err(at(
                                    t.span.start,
                                    format!("{letter} appears twice in one block"),
                                ));
                            }
                            axis_words[v] = Some(i);
                        }
                        None if dwell && letter == 'X' => {}
                        None if smoothing && letter == 'E' => {}
                        None if "IJKR".contains(letter) => {
                            arc_word.get_or_insert((letter, t.span.start));
                            arc_words["IJKR".find(letter).unwrap_or(0)] = Some(i);
                        }
                        None => {
                            let what = if "XYZABCUVW".contains(letter) {
                                format!(
                                    "{letter} is not an axis of this machine (its axes are {})",
                                    words
                                        .letters
                                        .iter()
                                        .map(|&l| (l as char).to_string())
                                        .collect::<Vec<_>>()
                                        .join(", ")
                                )
                            } else {
                                format!("{letter} words are not known to nccomp")
                            };
                            return Err(at(
                                t.span.start,
                                format!("{what}; expected a G0/G1 block in machine axes"),
                            ));
                        }
                    }
                }
            }
        }
        if let Some(off) = other_text
            && line.content[off] == b'#'
        {
            let assigned = super::params::assign(&line.content[off..], &mut state.params)
                .map_err(|(o, m)| at(off + o, m))?;
            if assigned && optional {
                // Whether the block runs is not known: neither is the value.
                super::params::forget(&line.content[off..], &mut state.params);
            }
        }
        if let Some(off) = other_text {
            // Parameter assignments (`#1 = 5`) move nothing; a parameter used in a word is
            // caught above. Anything else may be motion we do not understand.
            if line.content[off] != b'#' && o_word.is_none() {
                if let Some(why) =
                    super::params::macro_statement(&line.content[off..], &state.params)
                {
                    return Err(at(off, why));
                }
                let end = tokens
                    .iter()
                    .find(|t| t.span.start == off)
                    .map_or(off + 1, |t| t.span.end);
                return Err(at(
                    off,
                    format!(
                        "`{}` cannot be compensated (expected words such as G1 X10.5)",
                        String::from_utf8_lossy(&line.content[off..end])
                    ),
                ));
            }
        }
        if !has_words {
            return Ok(false);
        }
        if let Some(at_line) = state.ended {
            let col = tokens
                .iter()
                .find(|t| matches!(t.kind, TokenKind::Word(_) | TokenKind::Other))
                .map_or(0, |t| t.span.start);
            return Err(at(
                col,
                format!(
                    "this block follows the M99 at line {at_line}, which ends the program (a subprogram returns there, a main program is rewound): expected M99 as the last block"
                ),
            ));
        }
        if returned.is_some() {
            state.ended = Some(line.number);
        }
        if program_end {
            state.program_end = Some(line.number);
        }
        if let Some(i) = extended {
            let p = p_number(tokens).filter(|p| p.fract() == 0.0 && (1.0..=300.0).contains(p));
            let Some(p) = p else {
                return Err(refuse_code(
                    &tokens[i],
                    "needs the number of the extended work offset: expected P1 … P300".into(),
                ));
            };
            state.work_offset = Some(100_000 + p as i64);
            zero_changed = true;
        }
        if let Some((i, code10)) = offset_data {
            if let Some((_, col)) = motion_in_block {
                return Err(at(
                    col,
                    format!(
                        "a move in the block of {} cannot be compensated (expected the offset data alone in its block)",
                        code_text(line.content, &tokens[i])
                    ),
                ));
            }
            return self.offset_data(line, tokens, state, at, out, i, code10);
        }
        if zero_changed {
            state.shift = state.shift_from(self.machine);
        }
        if let Some(code) = rotation {
            out.arc_words = arc_words;
            return self.rotation(tokens, state, at, out, code);
        }
        if let Some(code) = plane_words.or(to_plane) {
            out.arc_words = arc_words;
            return self.working_plane(tokens, state, at, out, code, plane_words.is_some());
        }
        if let Some(col) = o_word {
            if tokens.iter().any(|t| {
                matches!(t.kind, TokenKind::Other | TokenKind::Word(_)) && t.span.start > col
            }) {
                return Err(at(col, "O-word control flow (subprograms, loops, conditionals) cannot be compensated; expected a plain program number line".into()));
            }
            return Ok(false);
        }
        if g43 {
            let tool = &self.machine.tool;
            let number = match h_word {
                Some((h, _)) => h,
                None => state.tool.ok_or_else(|| {
                    at(
                        0,
                        "G43 without an H word takes the length of the tool in the spindle, and the program has selected none (no T word before it): which tool that is, and so where the tip is, is decided at run time (expected G43 Hn, or a T word before the G43)".into(),
                    )
                })?,
            };
            state.length = *tool.lengths.get(&number).ok_or_else(|| {
                at(h_word.map_or(0, |h| h.1), format!(
                    "tool length H{number} is not in the machine file's [tool] lengths (expected one of: {})",
                    tool.lengths.keys().map(|k| k.to_string()).collect::<Vec<_>>().join(", ")
                ))
            })?;
        }
        if g49 {
            state.length = self.machine.tool.length;
        }
        if (g49 || tcp_off) && !tcp_on {
            state.tcp = false;
            state.tcp_vector = false;
        }
        if tcp_on {
            state.tcp = true;
            state.tcp_vector = tcp_vector;
        }
        if let Some((g, _)) = motion_in_block {
            state.motion = Some(g);
        }
        if let Some(col) = tool_change {
            let letters = self.machine.tool.change_moves;
            let vars = (0..26u8)
                .filter(|&l| letters & 1 << l != 0)
                .filter_map(|l| words.var_of_letter[l as usize])
                .fold(0u32, |m, v| m | 1 << v);
            if vars != 0 {
                if state.tcp {
                    return Err(at(col, "M6 under tool-centre-point control cannot be compensated: the tool change moves the axes under the transformation (expected G49 before it)".into()));
                }
                if axis_words[..n].iter().any(Option::is_some) || arc_word.is_some() {
                    let i = axis_words[..n].iter().flatten().next().copied();
                    return Err(at(
                        i.map_or(col, |i| tokens[i].span.start),
                        "axis words with a tool change (M6) cannot be compensated: the change sends the tool axis to the change position (the machine file's [tool] change_moves), and where the words take the axes then is the control's rule (expected M6 in a block of its own)".into(),
                    ));
                }
                match special {
                    None => {
                        special = Some(MoveKind::Home);
                        homed_letters |= letters;
                    }
                    // A machine file's own machine move: both move their axes.
                    Some(MoveKind::Home) if homed_letters != 0 => homed_letters |= letters,
                    // G28/G30 without axis words: every axis goes home anyway.
                    _ => {}
                }
            }
        }
        if state.motion == Some(Motion::Cycle)
            && (motion_in_block.is_some()
                || axis_words[..n].iter().any(Option::is_some)
                || arc_word.is_some())
        {
            if special.is_some() {
                let col = motion_in_block.map_or(0, |m| m.1);
                return Err(at(
                    col,
                    "a canned cycle cannot be combined with G28/G30/G53".into(),
                ));
            }
            out.arc_words = arc_words;
            out.arc_code = arc_code;
            out.kind = MoveKind::Cycle;
            return Ok(true);
        }
        let arc = state.motion == Some(Motion::Arc);
        if arc && (axis_words[..n].iter().any(Option::is_some) || arc_word.is_some()) {
            let col = motion_in_block.map_or(0, |m| m.1);
            if let Some(col) = p_word {
                return Err(at(col, "arcs with a P word (several turns) cannot be compensated; expected one turn at most".into()));
            }
            if special.is_some() {
                return Err(at(col, "an arc cannot be combined with G28/G30/G53".into()));
            }
            out.arc_words = arc_words;
            out.arc_code = arc_code;
            out.kind = MoveKind::Arc {
                clockwise: state.clockwise,
            };
            return Ok(true);
        }
        if state.tcp_vector && special.is_none() {
            // G43.5: I, J, K are the tool vector; R means nothing here.
            if let Some(i) = arc_words[3] {
                return Err(at(
                    tokens[i].span.start,
                    "R words are not expected under G43.5 (expected X, Y, Z for the tip and I, J, K for the tool vector)".into(),
                ));
            }
            let vector = arc_words[..3].iter().any(Option::is_some);
            if dwell || !(vector || axis_words[..n].iter().any(Option::is_some)) {
                return Ok(false);
            }
            out.arc_words = arc_words;
            out.kind = MoveKind::Program;
            return Ok(true);
        }
        if let Some((letter, col)) = arc_word {
            return Err(at(
                col,
                format!(
                    "{letter} words (arc centres and radii, tool vectors) are not supported; expected a G0/G1 block in machine axes"
                ),
            ));
        }
        let moves = axis_words[..n].iter().any(Option::is_some);
        if let Some(i) = set_reference
            && moves
        {
            return Err(at(
                tokens[i].span.start,
                format!(
                    "{} with axis words cannot be compensated: setting a reference point takes none (expected the code on its own)",
                    code_text(line.content, &tokens[i])
                ),
            ));
        }
        if homed_letters != 0 {
            if moves {
                let i = axis_words[..n]
                    .iter()
                    .flatten()
                    .next()
                    .copied()
                    .unwrap_or(0);
                return Err(at(
                    tokens[i].span.start,
                    "axis words with a code the machine file names in `machine_moves` cannot be compensated: the code sends axes to machine positions, and where the words would take them is the control's rule (expected the code in a block of its own)".into(),
                ));
            }
            out.homed = (0..26u8)
                .filter(|&l| homed_letters & 1 << l != 0)
                .filter_map(|l| words.var_of_letter[l as usize])
                .fold(0, |m, v| m | 1 << v);
        }
        match special {
            // G53 without axis words moves nothing.
            Some(MoveKind::Machine) if !moves => return Ok(false),
            Some(kind) => {
                out.kind = kind;
                return Ok(true);
            }
            None => {}
        }
        if dwell || !moves {
            return Ok(false);
        }
        out.kind = MoveKind::Program;
        Ok(true)
    }
}

/// The number of the word at token `i` (0 for one the reader has refused).
fn word_number(tokens: &[Token], i: usize) -> f64 {
    match &tokens[i].kind {
        TokenKind::Word(w) => w.number().unwrap_or(0.0),
        _ => 0.0,
    }
}

/// The first word of `tokens` given by a parameter nccomp does not know (known ones were
/// replaced by their numbers), described for a message.
fn unknown_parameter(
    content: &[u8],
    tokens: &[Token],
    params: &super::params::Params,
) -> Option<String> {
    tokens.iter().find_map(|t| match &t.kind {
        TokenKind::Word(w) if w.value == Value::Parameter => {
            super::params::first_unknown(content.get(w.value_span.clone())?, params)
        }
        _ => None,
    })
}

// Writing blocks in the G-code dialect: what the compensation pass asks of the dialect when
// it inserts blocks before a line or turns an arc into a straight move.

/// Whether words with `letter` name codes (G and M).
pub fn is_code_letter(letter: u8) -> bool {
    matches!(letter, b'G' | b'M')
}

/// The G or M code a word names (`G43.4` is G, 434), if it is one with a number.
pub fn code_name(w: &crate::nc::Word) -> Option<super::CodeName> {
    let number = w.number().filter(|_| is_code_letter(w.letter))?;
    Some(super::CodeName {
        letter: w.letter,
        code10: (number * 10.0).round() as i64,
    })
}

/// A word of the block that must run once and with the block itself (an M function, a tool
/// selection): a block that holds one cannot have pieces inserted before it.
pub fn once_word(tokens: &[Token]) -> Option<usize> {
    tokens
        .iter()
        .position(|t| matches!(&t.kind, TokenKind::Word(w) if matches!(w.letter, b'M' | b'T')))
}

/// The words a block inserted before this one repeats so that it runs as the block would:
/// its G codes (except the word `except`, the block's own arc code), H, D and S words.
pub fn carried_words(tokens: &[Token], except: Option<usize>) -> impl Iterator<Item = usize> + '_ {
    tokens
        .iter()
        .enumerate()
        .filter_map(move |(i, t)| match &t.kind {
            TokenKind::Word(w)
                if matches!(w.letter, b'G' | b'H' | b'D' | b'S') && Some(i) != except =>
            {
                Some(i)
            }
            _ => None,
        })
}

/// The code of a straight move at feed, in the block's style.
pub fn linear_code(style: &crate::nc::edit::Style) -> String {
    style.word(b'G', "1")
}

/// Make the block a straight move: its arc code `code` becomes G1 (G01 where it is written
/// with a leading zero), or, when the arc is modal (no code in the block), G1 goes before
/// its first axis word `first`.
pub fn make_linear(
    editor: &mut crate::nc::edit::Editor<'_>,
    code: Option<usize>,
    first: Option<usize>,
) {
    match (code, first) {
        (Some(i), _) => {
            let padded = editor
                .word(i)
                .is_some_and(|w| editor.content()[w.value_span.clone()].first() == Some(&b'0'));
            editor.replace_number(i, if padded { "01" } else { "1" });
        }
        (None, Some(first)) => {
            let style = editor.style();
            editor.insert_before_word(first, &(linear_code(&style) + style.separator));
        }
        (None, None) => {}
    }
}

/// The number of the block's first word with `letter`, if it is a number.
fn letter_number(tokens: &[Token], letter: u8) -> Option<f64> {
    tokens.iter().find_map(|t| match &t.kind {
        TokenKind::Word(w) if w.letter == letter => w.number(),
        _ => None,
    })
}

/// The number of the block's P word, if it is a number.
fn p_number(tokens: &[Token]) -> Option<f64> {
    letter_number(tokens, b'P')
}
