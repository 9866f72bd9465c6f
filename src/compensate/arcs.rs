//! Arcs (G2/G3 in G17/G18/G19, centres by I/J/K or a radius R).
//!
//! A controller interpolates an arc in the program's coordinates; on a machine with errors
//! no arc in axis space traces the intended arc on the part. An arc is kept as an arc where
//! what the controller makes of its compensated end and centre stays within the path
//! tolerance (`arc_keep`); otherwise nccomp replaces it by straight pieces whose chords stay within half a micron of the nominal arc, each piece's
//! end compensated like any block (pieces are not split further by `--tolerance`; they are
//! short already). The arc's own line becomes the last piece: its G2/G3 turns into G1 and
//! its I/J/K/R words go; the pieces before it are inserted in the program's style, the
//! first one carrying the block's G, H, D, S and F words so every piece runs as the block
//! would. A block with M or T words is refused: they would run after the pieces.

use super::Pass;
use super::pipeline::{Block, Cx, Mode, Out};
use crate::diag::Diagnostic;
use crate::kinematics::{MAX_AXES, Solution};
use crate::nc::edit::Editor;
use crate::nc::number::write_fixed;
use crate::program::arc::{ArcPath, arc_path, plane_letters};
use crate::program::{gcode, heidenhain};
use std::fmt::Write;

/// More pieces than this for one arc means a radius or a tolerance that makes no sense.
const MAX_PIECES: usize = 100_000;

/// A G2/G3 block in machine axes.
pub(super) struct ArcMode {
    clockwise: bool,
    /// The arc as programmed (set by the target stage).
    path: Option<ArcPath>,
    /// Kept as an arc: its centre words.
    kept: Option<Vec<(Result<usize, u8>, String)>>,
    /// Replaced by straight pieces: how many (the block itself is the last).
    pieces: usize,
}

impl ArcMode {
    pub(super) fn new(clockwise: bool) -> Self {
        ArcMode {
            clockwise,
            path: None,
            kept: None,
            pieces: 0,
        }
    }

    /// The column of the block's G2/G3 word, or of its first axis word.
    fn col(cx: &Cx<'_, '_>) -> usize {
        cx.motion
            .arc_code
            .map_or_else(|| cx.first_col(), |i| cx.col(i))
    }
}

impl Mode for ArcMode {
    fn target(&mut self, b: &mut Block, q: &mut [f64; MAX_AXES]) -> Result<bool, Diagnostic> {
        let (pass, cx, state, out) = b.parts();
        let n = pass.kin.len();
        let col = Self::col(cx);
        let refuse =
            |why: &str| Err(cx.refuse(col, format!("this arc cannot be compensated: {why}")));
        if state.modal.incremental {
            return refuse(
                "arcs in incremental mode (G91) are not supported (program them in G90)",
            );
        }
        if cx.motion.optional {
            return refuse("an optional block (/) with an arc is not supported");
        }
        if state.modal.inverse_time && cx.word(b'F').is_none() {
            return refuse("in inverse-time feed (G93) an arc needs its own F word");
        }
        let path = arc_path(
            &pass.axes,
            cx.tokens,
            cx.motion,
            self.clockwise,
            &state.pos,
            &state.modal,
            pass.spindle,
        )
        .map_err(|why| cx.refuse(col, format!("this arc cannot be compensated: {why}")))?;
        for (v, word) in cx.motion.axis_words.iter().enumerate().take(n) {
            // Axes turning holds are not corrected.
            if state.pos.programmed & (1 << v) == 0 && word.is_none() && pass.idle & (1 << v) == 0 {
                out.summary
                    .note_assumed_home(pass.axis_name(v), cx.line.number);
            }
            if word.is_some() {
                state.pos.programmed |= 1 << v;
            }
        }
        pass.check_travel(&path.end, col, cx)?;
        if state.modal.dialect != crate::nc::Dialect::Heidenhain {
            // The end words, exactly: a G91 block after the arc adds to them.
            state.pos.advance(
                &pass.axes,
                cx.line.content,
                cx.tokens,
                cx.motion,
                &state.modal,
                cx.at,
                &mut state.units,
            )?;
        }
        state.pos.nominal = path.end;
        self.path = Some(path);
        *q = path.end;
        Ok(true)
    }

    fn path(&mut self, b: &mut Block, end: &Solution, hold: u32) -> Result<(), Diagnostic> {
        let (pass, cx, state, out) = b.parts();
        let n = pass.kin.len();
        let Some(path) = self.path else {
            return Ok(());
        };
        let col = Self::col(cx);
        let Some((_, centre_letters)) = plane_letters(state.modal.plane) else {
            return Ok(());
        };
        // Kept as an arc where what the controller makes of the compensated words stays
        // within the path tolerance (the default one under --tolerance off).
        let tolerance = pass.options.path.unwrap_or_default();
        // A TNC arc's centre is its CC block, which the control has read already: the arc
        // is not kept.
        let tnc = state.modal.dialect == crate::nc::Dialect::Heidenhain;
        if !tnc && let Some(kept) = pass.keep_arc(&path, end, cx, centre_letters, state, &tolerance)
        {
            self.kept = Some(kept);
            return Ok(());
        }
        if let Some(i) = gcode::once_word(cx.tokens) {
            return Err(cx.refuse(
                cx.col(i),
                "this arc must be replaced by straight pieces (kept as an arc it strays from the path) and cannot be with an M or T word in its block: the word would run only after the first pieces (put it in a block of its own)".into(),
            ));
        }
        let radius = path.r0.max(path.r1);
        let step = 2.0 * (1.0 - (pass.chord() / radius).min(1.0)).acos();
        let pieces = ((path.sweep.abs() / step).ceil() as usize).max(1);
        if pieces > MAX_PIECES {
            return Err(cx.refuse(
                col,
                format!("this arc cannot be compensated: it would take {pieces} straight pieces"),
            ));
        }
        self.pieces = pieces;
        // The inserted pieces, then the arc's own line as the last one.
        let mut editor = cx.editor(out.edits);
        let style = editor.style();
        let numbers = editor.inserted_numbers(state.last_n, pieces - 1);
        let tnc = state.modal.dialect == crate::nc::Dialect::Heidenhain;
        let ending = Editor::ending(cx.line.ending);
        let f_word = cx.word(b'F');
        let mut text = String::new();
        for k in 1..pieces {
            let q = path.point(k as f64 / pieces as f64, n);
            pass.check_travel(&q, col, cx)?;
            let (sol, _) = pass.solve(&q, hold, cx, state)?;
            let mut words: Vec<String> = Vec::new();
            if tnc {
                words =
                    heidenhain::inserted_start(cx.line.content, cx.tokens, state.renumber, k - 1);
            } else if let Some(number) = &numbers[k - 1] {
                words.push(style.word(b'N', number));
            }
            if k == 1 && !tnc {
                // The block's own modal words, so the first piece runs as the block would.
                for ti in gcode::carried_words(cx.tokens, cx.motion.arc_code) {
                    words.push(String::from_utf8_lossy(editor.text(ti)).into_owned());
                }
                words.push(gcode::linear_code(&style));
            }
            pass.piece_words(&sol.q, state, &style, &mut words);
            if tnc {
                for i in heidenhain::carried_words(cx.tokens) {
                    words.push(String::from_utf8_lossy(editor.text(i)).into_owned());
                }
            }
            if let Some(f) = f_word
                && let Some((value, decimals)) = editor.number(f)
            {
                if state.modal.inverse_time {
                    let mut number = String::new();
                    write_fixed(value * pieces as f64, decimals.max(3) + 1, &mut number);
                    words.push(style.word(b'F', &number));
                } else if k == 1 {
                    words.push(String::from_utf8_lossy(editor.text(f)).into_owned());
                }
            }
            pass.record(cx.line.number, &sol, state, out.summary);
            let _ = write!(text, "{}{}", words.join(style.separator), ending);
        }
        editor.insert_blocks(text);
        Ok(())
    }

    fn write(&mut self, b: &mut Block, end: &Solution) -> Result<(), Diagnostic> {
        let (pass, cx, state, out) = b.parts();
        if let Some(centre_words) = &self.kept {
            pass.write_positions(cx, &end.q, false, state, out)?;
            for (word, _) in centre_words {
                match word {
                    Ok(_) => out.summary.words_changed += 1,
                    Err(_) => out.summary.words_added += 1,
                }
            }
            pass.centre_edits(cx, centre_words, out);
            if cx.motion.arc_code.is_none() && state.straightened {
                // Modal in the original, but the output's last motion code is the G1 of a
                // straightened arc: the block says G2/G3 itself.
                restore_arc_code(cx, out, self.clockwise);
            }
            state.straightened = false;
            out.summary.note_arc_kept();
            return Ok(());
        }
        // The arc's own line: G1, no centre words, its end compensated.
        let pieces = self.pieces;
        straighten(cx, out, pieces > 1);
        state.straightened = true;
        let mut editor = cx.editor(out.edits);
        if state.modal.inverse_time
            && let Some(f) = cx.word(b'F')
            && let Some((value, decimals)) = editor.number(f)
        {
            let mut number = String::new();
            write_fixed(value * pieces as f64, decimals.max(3) + 1, &mut number);
            editor.replace_number(f, number);
        }
        out.summary.note_arc(cx.line.number, pieces - 1);
        pass.write_positions(cx, &end.q, false, state, out)
    }
}

/// Make an arc's own line a straight move (the last of its pieces): G1, no centre words. A
/// modal arc gets a G1 unless inserted pieces have set it already.
pub(super) fn straighten(cx: &Cx<'_, '_>, out: &mut Out<'_>, pieces_inserted: bool) {
    let mut editor = cx.editor(out.edits);
    if cx.motion.centre.is_some() || cx.motion.polar.is_some() || is_tnc_radius_arc(cx) {
        // A TNC arc (C, CR, CP) becomes an L block: its keyword, its direction, its radius,
        // its polar angle and a helix's height (IZ: the end's Z is written) go.
        if let Some(k) = cx.motion.arc_code {
            editor.replace_token(k, b"L");
        }
        for (i, t) in cx.tokens.iter().enumerate() {
            let text = &cx.line.content[t.span.clone()];
            let lead = cx.motion.lead.is_some()
                && text.len() > 2
                && text[0] == b'I'
                && matches!(text[1], b'X' | b'Y' | b'Z');
            let gone = t.kind == crate::nc::TokenKind::Other
                && (text.starts_with(b"DR")
                    || text.starts_with(b"IPA")
                    || text.starts_with(b"PA")
                    || lead);
            if gone || cx.motion.arc_words[3] == Some(i) {
                editor.remove_word(i);
            }
        }
        return;
    }
    let first = cx
        .motion
        .axis_words
        .iter()
        .flatten()
        .copied()
        .min_by_key(|&i| cx.col(i))
        .filter(|_| !pieces_inserted);
    gcode::make_linear(&mut editor, cx.motion.arc_code, first);
    for i in cx.motion.arc_words.iter().flatten() {
        editor.remove_word(*i);
    }
}

/// Give a kept arc modal in the original its G2/G3 (`clockwise`: G2) before its first
/// axis word.
pub(super) fn restore_arc_code(cx: &Cx<'_, '_>, out: &mut Out<'_>, clockwise: bool) {
    let first = cx
        .motion
        .axis_words
        .iter()
        .chain(&cx.motion.arc_words)
        .flatten()
        .copied()
        .min_by_key(|&i| cx.col(i));
    if let Some(first) = first {
        let mut editor = cx.editor(out.edits);
        let style = editor.style();
        let code = style.word(b'G', if clockwise { "2" } else { "3" });
        editor.insert_before_word(first, &(code + style.separator));
    }
}

/// A TNC `CR` block (its keyword is `CR`).
fn is_tnc_radius_arc(cx: &Cx<'_, '_>) -> bool {
    cx.motion
        .arc_code
        .is_some_and(|k| &cx.line.content[cx.tokens[k].span.clone()] == b"CR")
        && !cx
            .tokens
            .iter()
            .any(|t| matches!(&t.kind, crate::nc::TokenKind::Word(w) if w.letter == b'G'))
}

impl Pass<'_> {
    /// A point of a move, as programmed, must lie within the travel.
    pub(super) fn check_travel(
        &self,
        nominal: &[f64; MAX_AXES],
        col: usize,
        cx: &Cx<'_, '_>,
    ) -> Result<(), Diagnostic> {
        if self.options.allow_limit_violations {
            return Ok(());
        }
        for (v, &x) in nominal.iter().enumerate().take(self.kin.len()) {
            if let Some([lo, hi]) = self.travel(v)
                && (x < lo - 1e-9 || x > hi + 1e-9)
            {
                return Err(cx
                    .refuse(
                        col,
                        format!(
                            "the move takes axis {} to {x:.4}, outside its travel {lo} … {hi} (use --allow-limit-violations to write it anyway)",
                            self.axis_name(v)
                        ),
                    )
                    .with_code(super::TRAVEL_LIMIT));
            }
        }
        Ok(())
    }
}
