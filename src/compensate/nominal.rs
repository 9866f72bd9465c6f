//! The program's path on the nominal machine, move by move, for analyses that compare it
//! with what the machine did (`contour`). The blocks and the modal state are read exactly
//! as the compensation pass reads them; nothing is solved or written.

use super::arc_keep::ArcPath;
use super::pipeline::{Cx, Out};
use super::{Compensator, Pass, State, Summary};
use crate::diag::{Diagnostic, Error};
use crate::kinematics::{Kinematics, MAX_AXES};
use crate::nc::{self, Token, TokenKind, Value};
use crate::program::INCH;
use crate::program::{BlockMotion, MoveKind};

/// How a move goes from its start to its end.
// A move is stored once per block and copied rarely; boxing the arc would allocate per arc
// for nothing.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Shape {
    /// G0: straight in axis space at the rapid rate (a controller may dogleg it).
    Rapid,
    /// G1: straight in axis space, every axis in proportion (joint-linear).
    Linear,
    /// G2/G3: a circle in the plane's two linear axes, the other axes in proportion.
    Arc(ArcPath),
}

/// One move of a program on the nominal machine.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NominalMove {
    /// 1-based line of the block.
    pub line: usize,
    /// Byte offset of the line's first byte in the program.
    pub offset: usize,
    /// Axis values (mm, degrees) where the move starts; `None` where that is not known:
    /// the program's first move, and the first after G28, G30 or G53 sent an axis to a
    /// machine position.
    pub start: Option<[f64; MAX_AXES]>,
    pub end: [f64; MAX_AXES],
    pub shape: Shape,
    /// The active tool length (mm).
    pub tool_length: f64,
    /// The modal feed in mm/min (`None` before the first F word, and under G93).
    pub feed: Option<f64>,
}

impl NominalMove {
    /// The axis values at parameter `s` ∈ [0, 1] of the move (of the first `n` variables);
    /// the end for a move whose start is not known.
    pub fn at(&self, s: f64, n: usize) -> [f64; MAX_AXES] {
        let Some(start) = self.start else {
            return self.end;
        };
        match &self.shape {
            Shape::Arc(arc) => arc.point(s, n),
            Shape::Rapid | Shape::Linear => {
                let mut q = [0.0; MAX_AXES];
                for v in 0..n {
                    q[v] = start[v] + (self.end[v] - start[v]) * s;
                }
                q
            }
        }
    }
}

impl Compensator<'_> {
    /// The moves of program `src` (named `path` in messages) on the nominal machine, in
    /// order, and the kinematics they run in. Blocks the pass would refuse are refused here
    /// too, each error at its place; tool-centre-point blocks (G43.4) are refused as well,
    /// since the controller, not the program, decides their axis values. Optional blocks
    /// (`/`) are taken to run. The moves must all run in one tool chain, milling: a move in
    /// another chain, or a turning move on a lathe, is refused.
    pub fn nominal_moves(
        &self,
        src: &[u8],
        path: &str,
    ) -> crate::Result<(Vec<NominalMove>, &Kinematics)> {
        let mut state = self.start_state();
        // The pass's notes are of no use here.
        let mut summary = Summary::default();
        let mut moves = Vec::new();
        let mut errors: Vec<Diagnostic> = Vec::new();
        let mut tokens: Vec<Token> = Vec::new();
        let mut motion = BlockMotion::default();
        let mut feed: Option<f64> = None;
        // The pass the first move runs in.
        let mut followed: Option<usize> = None;
        // A block in another pass than the first move's: one message says it all.
        let mut elsewhere = false;
        for line in nc::lines(src) {
            nc::parse_line(line.content, &mut tokens);
            let at = |offset: usize, message: String| {
                Diagnostic::at(path, src, line.offset + offset, message)
            };
            let result = self
                .read(&line, &tokens, &mut state, &mut summary, &at, &mut motion)
                .and_then(|moving| {
                    let pass = &self.passes[state.pass];
                    if let Some(f) = feed_word(&tokens) {
                        feed = Some(if state.modal.inch { f * INCH } else { f });
                    }
                    if !moving {
                        return Ok(None);
                    }
                    let col = motion
                        .axis_words
                        .iter()
                        .flatten()
                        .map(|&i| tokens[i].span.start)
                        .min()
                        .unwrap_or(0);
                    // Moves to machine positions (G28, G30, G53) only leave the path.
                    let moves_on_path =
                        !matches!(motion.kind, MoveKind::Machine | MoveKind::Home);
                    if moves_on_path && pass.turning {
                        elsewhere = true;
                        return Err(at(
                            col,
                            "a turning move cannot be followed: the spindle turns or stands where the program has not positioned it (expected milling moves, after M19 and a C word)".into(),
                        ));
                    }
                    match followed {
                        _ if !moves_on_path => {}
                        None => followed = Some(state.pass),
                        Some(p) if p != state.pass => {
                            elsewhere = true;
                            let name = |p: usize| &self.machine.tool_chains[self.passes[p].chain].name;
                            return Err(at(
                                col,
                                format!(
                                    "this block moves in tool chain `{}`, the ones before in `{}`: the trace is followed in one tool chain (expected a program for one tool chain; split it at the tool change)",
                                    name(state.pass),
                                    name(p)
                                ),
                            ));
                        }
                        Some(_) => {}
                    }
                    pass.nominal_move(&line, &tokens, &motion, &mut state, &mut summary, &at, col)
                        .map(|m| {
                            m.map(|(start, end, shape)| NominalMove {
                                line: line.number,
                                offset: line.offset,
                                start: (!moves.is_empty()).then_some(start).flatten(),
                                end,
                                shape,
                                tool_length: state.modal.length,
                                feed: feed.filter(|_| !state.modal.inverse_time),
                            })
                        })
                });
            match result {
                Ok(Some(m)) => moves.push(m),
                Ok(None) => {}
                Err(d) => {
                    errors.push(d);
                    if elsewhere || errors.len() >= self.passes[state.pass].options.max_errors {
                        break;
                    }
                }
            }
        }
        if !errors.is_empty() {
            return Err(Error::Inputs(errors));
        }
        Ok((moves, &self.passes[followed.unwrap_or(self.start)].kin))
    }
}

impl Pass<'_> {
    /// Follow one motion block: its start (`None` where an axis was at a place nccomp does
    /// not know), end and shape; `None` for a block that leaves the program's coordinates
    /// (G28, G30, G53) or ends where they are not known.
    #[allow(clippy::too_many_arguments)]
    #[allow(clippy::type_complexity)]
    fn nominal_move(
        &self,
        line: &nc::Line<'_>,
        tokens: &[Token],
        motion: &BlockMotion,
        state: &mut State,
        summary: &mut Summary,
        at: &dyn Fn(usize, String) -> Diagnostic,
        col: usize,
    ) -> Result<Option<(Option<[f64; MAX_AXES]>, [f64; MAX_AXES], Shape)>, Diagnostic> {
        let n = self.kin.len();
        let known = state.unknown & !self.spindle == 0;
        let start = state.nominal;
        let shape = match motion.kind {
            MoveKind::Machine | MoveKind::Home => {
                // As in the pass: the axes sent to machine positions (all of them for a
                // bare G28/G30) leave the program's coordinates.
                let mut gone = (0..n)
                    .filter(|&v| motion.axis_words[v].is_some())
                    .fold(0u32, |m, v| m | 1 << v);
                if motion.kind == MoveKind::Home && gone == 0 {
                    gone = (0..n).fold(0u32, |m, v| m | 1 << v);
                }
                state.unknown |= gone;
                return Ok(None);
            }
            MoveKind::Cycle => {
                return Err(at(
                    col,
                    "a drilling cycle cannot be followed: the controller decides its moves (expected the holes as G0/G1 moves)".into(),
                ));
            }
            _ if state.modal.tcp => {
                return Err(at(
                    col,
                    "a tool-centre-point block (G43.4/G43.5) cannot be followed: the controller solves its axis values (expected a program in machine axes)".into(),
                ));
            }
            MoveKind::Arc { clockwise } => {
                if state.modal.incremental {
                    return Err(at(
                        col,
                        "arcs in incremental mode (G91) cannot be followed (expected them in G90)"
                            .into(),
                    ));
                }
                let arc = self
                    .arc_path(tokens, motion, clockwise, state)
                    .map_err(|why| at(col, format!("this arc cannot be followed: {why}")))?;
                state.nominal = arc.end;
                Shape::Arc(arc)
            }
            MoveKind::Program => {
                let cx = Cx {
                    line,
                    tokens,
                    motion,
                    at,
                };
                let mut edits = Vec::new();
                let mut out = Out {
                    edits: &mut edits,
                    summary,
                };
                self.advance_nominal(&cx, state, &mut out)?;
                if state.modal.rapid {
                    Shape::Rapid
                } else {
                    Shape::Linear
                }
            }
        };
        for (v, word) in motion.axis_words.iter().enumerate().take(n) {
            if word.is_some() {
                state.programmed |= 1 << v;
            }
        }
        if state.unknown & !self.spindle != 0 {
            return Ok(None);
        }
        Ok(Some((known.then_some(start), state.nominal, shape)))
    }
}

/// The value of the block's F word, if it has one.
fn feed_word(tokens: &[Token]) -> Option<f64> {
    tokens.iter().find_map(|t| match &t.kind {
        TokenKind::Word(w) if w.letter == b'F' => match w.value {
            Value::Number { value, .. } => Some(value),
            _ => None,
        },
        _ => None,
    })
}
