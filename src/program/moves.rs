//! The program's path on the nominal machine, move by move, for the analyses that compare
//! it with what a machine did (`contour`) or cut (`identify`). The blocks are read by the
//! one reader and followed by the same positions the compensation pass follows; nothing
//! is solved or written.

use super::arc::{ArcPath, arc_path};
use super::axes::{Axes, Positions};
use super::{BlockMotion, INCH, Modal, MoveKind, Reader};
use crate::diag::{Diagnostic, Error};
use crate::kinematics::MAX_AXES;
use crate::model::Machine;
use crate::nc::{self, Token, TokenKind, Value};

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
                for (v, x) in q.iter_mut().enumerate().take(n) {
                    *x = start[v] + (self.end[v] - start[v]) * s;
                }
                q
            }
        }
    }
}

/// The moves of program `src` (named `path` in messages) on `machine`, starting in tool
/// chain `chain`, in order, and the tool chain they run in. What the reader refuses is
/// refused here too, each error at its place (at most `max_errors`); so are drilling cycles
/// and tool-centre-point blocks (the controller decides their axis values), turning moves
/// on a lathe and moves in another tool chain than the first move's. Optional blocks (`/`)
/// are taken to run.
pub fn nominal_moves(
    machine: &Machine,
    chain: usize,
    src: &[u8],
    path: &str,
    max_errors: usize,
) -> crate::Result<(Vec<NominalMove>, usize)> {
    let reader = Reader::new(machine);
    let mut modal = Modal::start(machine, chain);
    modal.for_program(crate::nc::Dialect::detect(src), src);
    let mut pos = Positions::default();
    let mut moves = Vec::new();
    let mut errors: Vec<Diagnostic> = Vec::new();
    let mut tokens: Vec<Token> = Vec::new();
    let mut motion = BlockMotion::default();
    let mut feed: Option<f64> = None;
    // The tool chain the first move runs in.
    let mut followed: Option<usize> = None;
    'lines: for line in nc::lines(src) {
        super::tokenize(&modal, line.content, &mut tokens);
        let at = |offset: usize, message: String| {
            Diagnostic::at(path, src, line.offset + offset, message)
        };
        let chain_before = modal.chain;
        let read = reader.read(&line, &tokens, &mut modal, &at, &mut motion);
        if modal.chain != chain_before && (pos.programmed != 0 || pos.unknown != 0) {
            // Another chain's axes stand where this program has not said.
            pos.unknown = !0;
        }
        if let Some(f) = feed_word(&tokens) {
            feed = Some(if modal.inch { f * INCH } else { f });
        }
        // A refusal, and whether it says all there is to say (the rest is elsewhere).
        let refused: (Diagnostic, bool) = 'block: {
            let moving = match read {
                Ok(moving) => moving,
                Err(d) => break 'block (d, false),
            };
            if !moving {
                continue 'lines;
            }
            let col = motion
                .axis_words
                .iter()
                .flatten()
                .map(|&i| tokens[i].span.start)
                .min()
                .unwrap_or(0);
            let axes = reader.axes(modal.chain);
            // Moves to machine positions (G28, G30, G53) only leave the path.
            if matches!(motion.kind, MoveKind::Machine | MoveKind::Home) {
                pos.leave(&motion, axes.len());
                continue 'lines;
            }
            if modal.turning(machine) {
                break 'block (
                    at(
                        col,
                        "a turning move cannot be followed: the spindle turns or stands where the program has not positioned it (expected milling moves, after M19 and a C word)".into(),
                    ),
                    true,
                );
            }
            match followed {
                None => followed = Some(modal.chain),
                Some(c) if c != modal.chain => {
                    let name = |c: usize| &machine.tool_chains[c].name;
                    break 'block (
                        at(
                            col,
                            format!(
                                "this block moves in tool chain `{}`, the ones before in `{}`: the trace is followed in one tool chain (expected a program for one tool chain; split it at the tool change)",
                                name(modal.chain),
                                name(c)
                            ),
                        ),
                        true,
                    );
                }
                Some(_) => {}
            }
            match follow(
                axes, &line, &tokens, &motion, &modal, &mut pos, &at, col, false,
            ) {
                Ok(Some((start, end, shape))) => {
                    moves.push(NominalMove {
                        line: line.number,
                        offset: line.offset,
                        start: (!moves.is_empty()).then_some(start).flatten(),
                        end,
                        shape,
                        tool_length: modal.length,
                        feed: feed.filter(|_| !modal.inverse_time),
                    });
                    continue 'lines;
                }
                Ok(None) => continue 'lines,
                Err(d) => (d, false),
            }
        };
        let (d, last) = refused;
        errors.push(d);
        if last || errors.len() >= max_errors {
            break;
        }
    }
    if !errors.is_empty() {
        return Err(Error::Inputs(errors));
    }
    Ok((moves, followed.unwrap_or(chain)))
}

/// Follow one motion block: its start (`None` where an axis was at a place nccomp does not
/// know), end and shape; `None` for a block that ends where the program's coordinates are
/// not known.
#[allow(clippy::too_many_arguments)]
#[allow(clippy::type_complexity)]
pub(crate) fn follow(
    axes: &Axes,
    line: &nc::Line<'_>,
    tokens: &[Token],
    motion: &BlockMotion,
    modal: &Modal,
    pos: &mut Positions,
    at: &dyn Fn(usize, String) -> Diagnostic,
    col: usize,
    tcp_words: bool,
) -> Result<Option<(Option<[f64; MAX_AXES]>, [f64; MAX_AXES], Shape)>, Diagnostic> {
    let n = axes.len();
    let all = (1u32 << n) - 1;
    let known = pos.unknown & all == 0;
    let start = pos.nominal;
    let advance = |pos: &mut Positions| {
        pos.advance(
            axes,
            line.content,
            tokens,
            motion,
            modal,
            at,
            &mut [0; MAX_AXES],
        )
    };
    let shape = match motion.kind {
        MoveKind::Cycle => {
            return Err(at(
                col,
                "a drilling cycle cannot be followed: the controller decides its moves (expected the holes as G0/G1 moves)".into(),
            ));
        }
        _ if modal.tcp && !tcp_words => {
            return Err(at(
                col,
                "a tool-centre-point block (G43.4/G43.5) cannot be followed: the controller solves its axis values (expected a program in machine axes)".into(),
            ));
        }
        MoveKind::Arc { clockwise } => {
            if modal.incremental {
                return Err(at(
                    col,
                    "arcs in incremental mode (G91) cannot be followed (expected them in G90)"
                        .into(),
                ));
            }
            let arc = arc_path(axes, tokens, motion, clockwise, pos, modal, 0)
                .map_err(|why| at(col, format!("this arc cannot be followed: {why}")))?;
            if modal.dialect != crate::nc::Dialect::Heidenhain {
                // The end words, exactly: a G91 block after the arc adds to them.
                advance(pos)?;
            }
            pos.nominal = arc.end;
            Shape::Arc(arc)
        }
        _ => {
            advance(pos)?;
            if modal.rapid {
                Shape::Rapid
            } else {
                Shape::Linear
            }
        }
    };
    for (v, word) in motion.axis_words.iter().enumerate().take(n) {
        if word.is_some() {
            pos.programmed |= 1 << v;
        }
    }
    if pos.unknown & all != 0 {
        return Ok(None);
    }
    Ok(Some((known.then_some(start), pos.nominal, shape)))
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
