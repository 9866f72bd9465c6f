//! Reading a block: which words it has, what they mean to the pass, and what it refuses.

use super::gcodes::{self, GCode};
use super::{Pass, State, code_text};
use crate::diag::Diagnostic;
use crate::kinematics::MAX_AXES;
use crate::nc::{self, Token, TokenKind, Value};

/// What a block that moves asks for.
#[derive(Debug, Clone, Copy)]
pub(super) struct BlockMotion {
    /// Token index of each variable's axis word, if the block has one.
    pub axis_words: [Option<usize>; MAX_AXES],
    /// For arcs: token indices of the I, J, K and R words, and of the G2/G3 word. Under
    /// G43.5 the I, J, K words are the tool vector; in a cycle R is the retract plane and
    /// the code word is the cycle's G word.
    pub arc_words: [Option<usize>; 4],
    pub arc_code: Option<usize>,
    /// The block starts with a block delete `/`: it runs only with the switch off.
    pub optional: bool,
    pub kind: MoveKind,
}

/// How a block moves.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum MoveKind {
    /// A G0/G1 move in program coordinates: compensated.
    Program,
    /// G53: the axis words are machine coordinates. Left untouched; the axes it names end
    /// at an unknown program position.
    Machine,
    /// G28/G30: the axes named (all of them if none is) go to a reference point. Left
    /// untouched; those axes end at an unknown program position.
    Home,
    /// G2/G3 in program coordinates: replaced by compensated straight pieces.
    Arc { clockwise: bool },
    /// A block of a drilling cycle (G81 …): compensated at its positioning points.
    Cycle,
}

impl Pass<'_> {
    /// Read one block: check that every word is understood, follow its modal words, and
    /// say which axis words it moves (`None`: it moves nothing).
    pub(super) fn read_block(
        &self,
        line: &nc::Line<'_>,
        tokens: &[Token],
        state: &mut State,
        at: &dyn Fn(usize, String) -> Diagnostic,
    ) -> Result<Option<BlockMotion>, Diagnostic> {
        let n = self.kin.len();
        let optional = tokens
            .iter()
            .find(|t| t.kind != TokenKind::Space)
            .is_some_and(|t| t.kind == TokenKind::BlockDelete);
        // Axis words of this block: (variable, token index).
        let mut axis_words: [Option<usize>; MAX_AXES] = [None; MAX_AXES];
        let mut has_words = false;
        let mut dwell = false;
        let mut motion_in_block = None;
        let mut h_word: Option<(u32, usize)> = None;
        let mut g43 = false;
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
        let mut set_reference: Option<usize> = None;
        for (i, t) in tokens.iter().enumerate() {
            let w = match &t.kind {
                TokenKind::Word(w) => w,
                TokenKind::Other => {
                    other_text.get_or_insert(t.span.start);
                    continue;
                }
                _ => continue,
            };
            has_words = true;
            let letter = w.letter as char;
            let number = match w.value {
                Value::Number { value, .. } => value,
                Value::Expression => {
                    return Err(at(
                        t.span.start,
                        format!(
                            "{letter} is given by an expression; expressions cannot be compensated (expected a number)"
                        ),
                    ));
                }
                Value::Parameter => {
                    return Err(at(
                        t.span.start,
                        format!(
                            "{letter} is given by a parameter; parameters cannot be compensated (expected a number)"
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
            // G and M codes in tenths (G43.4 is 434); axis words need no rounding.
            let code10 = if matches!(letter, 'G' | 'M') {
                (number * 10.0).round() as i64
            } else {
                0
            };
            match letter {
                'G' => match gcodes::classify(code10) {
                    GCode::Unsupported(what) => {
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
                    g @ (GCode::Motion | GCode::Arc) => {
                        motion_in_block = Some((g, t.span.start));
                        state.rapid = code10 == 0;
                        if g == GCode::Arc {
                            state.clockwise = code10 == 20;
                            arc_code = Some(i);
                        }
                    }
                    GCode::Dwell => dwell = true,
                    GCode::Inch => state.inch = true,
                    GCode::Millimetre => state.inch = false,
                    GCode::ToolLength => g43 = true,
                    GCode::ToolCentrePoint => {
                        g43 = true;
                        tcp_on = true;
                        tcp_vector = false;
                    }
                    GCode::ToolCentrePointVector => {
                        g43 = true;
                        tcp_on = true;
                        tcp_vector = true;
                    }
                    GCode::ToolLengthOff => g49 = true,
                    GCode::WorkOffset => {
                        if let Some(prev) = state.work_offset
                            && prev != code10
                        {
                            {
                                return Err(at(
                                    t.span.start,
                                    format!(
                                        "{} switches the work offset; the machine file describes one program zero, so a program must keep to one work offset",
                                        code_text(line.content, t)
                                    ),
                                ));
                            }
                        }
                        state.work_offset = Some(code10);
                    }
                    GCode::CancelCycle => {
                        state.motion = None;
                        state.cycle = None;
                    }
                    GCode::DrillCycle => {
                        motion_in_block = Some((GCode::DrillCycle, t.span.start));
                        arc_code = Some(i);
                    }
                    GCode::CycleReturn => state.retract_to_initial = code10 == 980,
                    g @ (GCode::Diameter | GCode::Radius) => {
                        let diameter = g == GCode::Diameter;
                        if diameter && self.machine.lathe.is_none() {
                            return Err(at(
                                t.span.start,
                                format!(
                                    "{} cannot be compensated: lathe diameter mode needs a [lathe] table in the machine file (the spindle that turns the part)",
                                    code_text(line.content, t)
                                ),
                            ));
                        }
                        if optional && diameter != state.diameter {
                            return Err(at(
                                t.span.start,
                                format!(
                                    "{} in an optional block (/) cannot be compensated: whether the block runs would decide how every later X word is read (move it out of the optional block)",
                                    code_text(line.content, t)
                                ),
                            ));
                        }
                        state.diameter = diameter;
                    }
                    g @ (GCode::Absolute | GCode::Incremental) => {
                        let incremental = g == GCode::Incremental;
                        if optional && incremental != state.incremental {
                            return Err(at(
                                t.span.start,
                                format!(
                                    "{} in an optional block (/) cannot be compensated: whether the block runs would decide how every later axis word is read (move the distance mode out of the optional block)",
                                    code_text(line.content, t)
                                ),
                            ));
                        }
                        state.incremental = incremental;
                    }
                    GCode::MachineCoordinates => {
                        special.get_or_insert(MoveKind::Machine);
                    }
                    GCode::ReturnHome => special = Some(MoveKind::Home),
                    GCode::SetReference => set_reference = Some(i),
                    GCode::Harmless => match code10 {
                        170 => state.plane = 0,
                        180 => state.plane = 1,
                        190 => state.plane = 2,
                        171 | 181 | 191 => state.plane = 3,
                        901 => state.arc_absolute = true,
                        911 => state.arc_absolute = false,
                        930 => state.inverse_time = true,
                        940 | 950 => state.inverse_time = false,
                        _ => {}
                    },
                },
                'M' => {
                    if let Some(what) = gcodes::unsupported_m(code10) {
                        return Err(at(
                            t.span.start,
                            format!(
                                "{} cannot be compensated: {what} is not supported",
                                code_text(line.content, t)
                            ),
                        ));
                    }
                }
                'T' => state.tool = Some(number as u32),
                'H' => h_word = Some((number as u32, t.span.start)),
                'O' => o_word = Some(t.span.start),
                'P' => p_word = Some(t.span.start),
                'N' | 'F' | 'S' | 'D' | 'Q' | 'L' => {}
                _ => {
                    let var = (letter.is_ascii_uppercase())
                        .then(|| self.var_of_letter[(w.letter - b'A') as usize])
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
                        None if "IJKR".contains(letter) => {
                            arc_word.get_or_insert((letter, t.span.start));
                            arc_words["IJKR".find(letter).unwrap_or(0)] = Some(i);
                        }
                        None => {
                            let what = if "XYZABCUVW".contains(letter) {
                                format!(
                                    "{letter} is not an axis of this machine (its axes are {})",
                                    self.axis_letters()
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
        if let Some(off) = other_text {
            // Parameter assignments (`#1 = 5`) move nothing; a parameter used in a word is
            // caught above. Anything else may be motion we do not understand.
            if line.content[off] != b'#' && o_word.is_none() {
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
            return Ok(None);
        }
        if let Some(col) = o_word {
            if tokens.iter().any(|t| {
                matches!(t.kind, TokenKind::Other | TokenKind::Word(_)) && t.span.start > col
            }) {
                return Err(at(col, "O-word control flow (subprograms, loops, conditionals) cannot be compensated; expected a plain program number line".into()));
            }
            return Ok(None);
        }
        if g43 {
            let number = match h_word {
                Some((h, _)) => h,
                None => state.tool.ok_or_else(|| {
                    at(
                        0,
                        "G43 without an H word and no tool selected (expected G43 Hn)".into(),
                    )
                })?,
            };
            state.length = *self.machine.tool.lengths.get(&number).ok_or_else(|| {
                at(h_word.map_or(0, |h| h.1), format!(
                    "tool length H{number} is not in the machine file's [tool] lengths (expected one of: {})",
                    self.machine.tool.lengths.keys().map(|k| k.to_string()).collect::<Vec<_>>().join(", ")
                ))
            })?;
        }
        if g49 {
            state.length = self.machine.tool.length;
            state.tcp = false;
            state.tcp_vector = false;
        }
        if tcp_on && (!state.tcp || state.tcp_vector != tcp_vector) {
            state.tcp_vector = tcp_vector;
            self.enter_tcp(state, at)?;
        }
        if let Some((g, _)) = motion_in_block {
            state.motion = Some(g);
            if g != GCode::DrillCycle {
                state.cycle = None;
            }
        }
        if state.motion == Some(GCode::DrillCycle)
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
            return Ok(Some(BlockMotion {
                axis_words,
                arc_words,
                arc_code,
                optional,
                kind: MoveKind::Cycle,
            }));
        }
        let arc = state.motion == Some(GCode::Arc);
        if arc && (axis_words[..n].iter().any(Option::is_some) || arc_word.is_some()) {
            let col = motion_in_block.map_or(0, |m| m.1);
            if let Some(col) = p_word {
                return Err(at(col, "arcs with a P word (several turns) cannot be compensated; expected one turn at most".into()));
            }
            if special.is_some() {
                return Err(at(col, "an arc cannot be combined with G28/G30/G53".into()));
            }
            return Ok(Some(BlockMotion {
                axis_words,
                arc_words,
                arc_code,
                optional,
                kind: MoveKind::Arc {
                    clockwise: state.clockwise,
                },
            }));
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
                return Ok(None);
            }
            return Ok(Some(BlockMotion {
                axis_words,
                arc_words,
                arc_code: None,
                optional,
                kind: MoveKind::Program,
            }));
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
        match special {
            // G53 without axis words moves nothing.
            Some(MoveKind::Machine) if !moves => return Ok(None),
            Some(kind) => {
                return Ok(Some(BlockMotion {
                    axis_words,
                    arc_words: [None; 4],
                    arc_code: None,
                    optional,
                    kind,
                }));
            }
            None => {}
        }
        if dwell || !moves {
            return Ok(None);
        }
        Ok(Some(BlockMotion {
            axis_words,
            arc_words: [None; 4],
            arc_code: None,
            optional,
            kind: MoveKind::Program,
        }))
    }
}
