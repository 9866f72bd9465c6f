//! Driving the pass over a program line by line: from a slice in memory ([`Compensator::run`])
//! or streamed from a reader to a writer in bounded memory ([`Compensator::run_stream`]).
//!
//! Both feed the same [`Run`], so a streamed program comes out byte for byte as it does
//! in memory. The stream is read in chunks and cut at the last line ending of each; lines
//! are handed to the pass as slices of the chunk (no copy, no allocation per line), and
//! the output is written in chunks as well. Memory is bounded by the chunk size and the
//! longest line, whatever the length of the program.

use std::io::{ErrorKind, Read, Write};

use super::pipeline::{Cx, Out};
use super::presolve::{Ahead, Predictor, START_SHARE, balance};
use super::{Compensator, State, Summary};
use crate::diag::{Diagnostic, Error};
use crate::nc::{self, Edit, Token, TokenKind};
use crate::program::BlockMotion;
use crate::program::heidenhain::{LabelScan, Labels};
use std::sync::Arc;

/// Bytes read at a time; a longer line makes the buffer grow to hold it.
pub(super) const CHUNK: usize = 256 * 1024;

/// The longest line a program may have: no NC block is a megabyte, and the pass keeps a
/// token for every few bytes of a line (a 110 MB line took 4.9 GB).
pub const MAX_LINE: usize = 1 << 20;

/// A line longer than [`MAX_LINE`], found while reading: its number and how it starts.
#[derive(Debug)]
struct LineTooLong {
    line: usize,
    start: String,
}

impl std::fmt::Display for LineTooLong {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "line {} is longer than {} bytes", self.line, MAX_LINE)
    }
}

impl std::error::Error for LineTooLong {}

/// The refusal of a line longer than [`MAX_LINE`] (`content`'s first bytes shown).
fn too_long(path: &str, line: usize, content: &str) -> Diagnostic {
    Diagnostic {
        path: path.to_string(),
        line,
        column: 1,
        message: format!(
            "this line is longer than {} MiB: expected NC blocks (no program needs a line this long; is the file a program, with line endings?)",
            MAX_LINE >> 20
        ),
        source_line: content.to_string(),
        code: None,
    }
}

/// A read error of the stream `input_name`, or the refusal of its over-long line.
fn read_failure(input_name: &str, source: std::io::Error) -> Error {
    match source
        .get_ref()
        .and_then(|e| e.downcast_ref::<LineTooLong>())
    {
        Some(long) => Error::Inputs(vec![too_long(input_name, long.line, &long.start)]),
        None => Error::Io {
            path: input_name.to_string(),
            source,
        },
    }
}

/// The pass over one program: its modal state, scratch buffers reused from line to line,
/// and what it has found so far.
pub(super) struct Run<'c, 'm> {
    pub(super) comp: &'c Compensator<'m>,
    pub(super) state: State,
    tokens: Vec<Token>,
    /// The current block's motion (filled by the reader).
    motion: BlockMotion,
    edits: Vec<Edit>,
    pub(super) errors: Vec<Diagnostic>,
    pub(super) summary: Summary,
    /// What the lines of label bodies run by `CALL LBL`s were written as (a TNC
    /// subprogram after the program's end), by line number: written there when the pass
    /// reaches them.
    captured: std::collections::HashMap<usize, Capture>,
    /// The copies of labels written for calls in other states, by label.
    copies: std::collections::HashMap<String, Vec<Copy>>,
}

/// A copy of a label for the calls that write it otherwise: its name, and its lines'
/// texts as [`Capture`] holds them.
struct Copy {
    name: String,
    texts: std::collections::HashMap<usize, (Vec<u8>, u64)>,
}

/// A body line as its calls wrote it: the text (its block numbers as if no block were
/// inserted before it), the blocks it inserted, and the call that first ran it.
struct Capture {
    text: Vec<u8>,
    inserted: u64,
    call: usize,
}

impl<'c, 'm> Run<'c, 'm> {
    pub(super) fn new(comp: &'c Compensator<'m>, trace: bool) -> Self {
        Run {
            comp,
            state: comp.start_state(),
            tokens: Vec::new(),
            motion: BlockMotion::default(),
            edits: Vec::new(),
            errors: Vec::new(),
            captured: std::collections::HashMap::new(),
            copies: std::collections::HashMap::new(),
            summary: Summary {
                zero_model: comp.zero_model,
                trace: trace.then(Vec::new),
                ..Summary::default()
            },
        }
    }

    /// Read program `src` (its whole text) in `dialect`.
    pub(super) fn program(&mut self, dialect: nc::Dialect, src: &[u8]) {
        self.state.modal.for_program(dialect, src);
        if let Some(tnc) = self.state.modal.tnc.as_mut() {
            tnc.follow_calls = true;
        }
    }

    /// Read a streamed program in `dialect` whose labels were scanned first.
    pub(super) fn program_with(&mut self, dialect: nc::Dialect, labels: &Arc<Labels>) {
        self.state.modal.for_program_with(dialect, labels.clone());
        if let Some(tnc) = self.state.modal.tnc.as_mut() {
            tnc.follow_calls = true;
        }
    }

    /// Whether a block has been refused (the output is then of no use).
    pub(super) fn failed(&self) -> bool {
        !self.errors.is_empty()
    }

    /// Compensate one line (of the file `path`) and append it to `out`. False when the
    /// pass has refused as many blocks as it may and should stop. A TNC hole that one X, Y
    /// cannot serve over its depth, whose motion nccomp knows, is written out as L moves
    /// instead ([`Run::write_out`]).
    pub(super) fn line(&mut self, line: &nc::Line<'_>, path: &str, out: &mut Vec<u8>) -> bool {
        if let Some(capture) = self.captured.remove(&line.number) {
            // A subprogram's line, written when its calls ran it: read again in its place
            // (past the end, where it does not run), written as the calls wrote it.
            let shift = self.state.renumber;
            let go_on = self.line_step(line, path, &mut Vec::new());
            self.state.renumber = shift + capture.inserted;
            shifted(&capture.text, shift, out);
            return go_on;
        }
        let mark = out.len();
        let go_on = self.line_step(line, path, out);
        let go_on = go_on && self.follow_calls(line, path, out, mark);
        if go_on {
            self.write_copies(line, out);
        }
        go_on
    }

    /// Run the label bodies a `CALL LBL` just read hands over ([`Flow`]): each line of a
    /// body, as the control runs it from the state at the call (jumps and calls within
    /// followed), compensated in that state and kept to be written where the body stands.
    /// Calls that write a body alike share it; a call that writes it otherwise gets a copy
    /// of the label of its own (a new name, after the label's `LBL 0`), and its `CALL LBL`
    /// (the last line of `out`, from `mark`) names the copy. Where a call runs more than
    /// one label (jumps, calls within) it must write them as the calls before it did, or
    /// it is refused, naming both calls. False when the pass should stop.
    fn follow_calls(
        &mut self,
        call: &nc::Line<'_>,
        path: &str,
        out: &mut Vec<u8>,
        mark: usize,
    ) -> bool {
        use crate::program::heidenhain::{Flow, MAX_LABEL_BLOCKS};
        let request = |run: &mut Self| run.state.modal.tnc.as_mut().and_then(|t| t.request.take());
        let Some(first) = request(self) else {
            return true;
        };
        let Some(labels) = self.state.modal.tnc.as_ref().map(|t| t.labels.clone()) else {
            return true;
        };
        let top = match &first {
            Flow::Call { name, .. } => name.clone(),
            Flow::Jump { .. } => String::new(),
        };
        let shift = self.state.renumber;
        let lines = self.summary.lines;
        // The bodies being run: label, the next line's index, the call.
        let mut frames: Vec<(String, usize, usize)> = Vec::new();
        let mut next = Some(first);
        let mut blocks = 0usize;
        let mut go_on = true;
        // What this call writes: line → (text, blocks inserted); and whether it ran a
        // label other than the one it calls.
        let mut written: Vec<(usize, Vec<u8>, u64)> = Vec::new();
        let mut others = false;
        let fail = |run: &mut Self, message: String| {
            run.errors.push(in_line(path, call, 0, message));
        };
        loop {
            match next.take() {
                Some(Flow::Call { name, line }) => {
                    others |= !frames.is_empty();
                    frames.push((name, 0, line));
                }
                Some(Flow::Jump { name, .. }) => match frames.last_mut() {
                    Some(top) => {
                        others = true;
                        top.0 = name;
                        top.1 = 0;
                    }
                    None => break,
                },
                None => {}
            }
            if let Some(t) = self.state.modal.tnc.as_mut() {
                t.in_body = u8::try_from(frames.len()).unwrap_or(u8::MAX);
            }
            let Some((name, index, _)) = frames.last_mut() else {
                break;
            };
            let Some(body) = labels.bodies.get(name.as_str()) else {
                let message = format!("the program has no LBL {name}");
                fail(self, message);
                break;
            };
            let Some(body_line) = body.lines.get(*index) else {
                frames.pop();
                continue;
            };
            *index += 1;
            blocks += 1;
            if blocks > MAX_LABEL_BLOCKS {
                fail(
                    self,
                    format!(
                        "the label calls from here run more than {MAX_LABEL_BLOCKS} label blocks: not followed"
                    ),
                );
                break;
            }
            let l = body_line.line();
            let mut text = Vec::new();
            self.state.renumber = 0;
            go_on = self.line_step(&l, path, &mut text);
            written.push((l.number, text, self.state.renumber));
            if !go_on || self.failed() {
                break;
            }
            if self
                .state
                .modal
                .tnc
                .as_ref()
                .is_some_and(|t| t.end.is_some())
            {
                fail(
                    self,
                    format!(
                        "the label called here ends the program at line {}: not followed",
                        l.number
                    ),
                );
                break;
            }
            next = request(self);
        }
        if let Some(t) = self.state.modal.tnc.as_mut() {
            t.in_body = 0;
        }
        self.state.renumber = shift;
        self.summary.lines = lines;
        if go_on && !self.failed() {
            self.share(&top, call.number, written, others, path, &labels, out, mark);
        }
        go_on && self.errors.len() < self.comp.passes[self.state.pass].options.max_errors
    }

    /// Keep what a call wrote of its label (see [`Run::follow_calls`]).
    #[allow(clippy::too_many_arguments)]
    fn share(
        &mut self,
        top: &str,
        call: usize,
        written: Vec<(usize, Vec<u8>, u64)>,
        others: bool,
        path: &str,
        labels: &crate::program::heidenhain::Labels,
        out: &mut Vec<u8>,
        mark: usize,
    ) {
        let conflict = written.iter().find_map(|(n, text, _)| {
            self.captured
                .get(n)
                .filter(|c| &c.text != text)
                .map(|c| (*n, c.call))
        });
        let Some((line, first)) = conflict else {
            for (n, text, inserted) in written {
                self.captured.entry(n).or_insert(Capture {
                    text,
                    inserted,
                    call,
                });
            }
            return;
        };
        // A copy this call's texts match, or a new one.
        let copies = self.copies.entry(top.to_string()).or_default();
        let found = copies.iter().position(|c| {
            written
                .iter()
                .all(|(n, t, _)| c.texts.get(n).is_none_or(|(ct, _)| ct == t))
        });
        let same_lines = labels.bodies.get(top).is_some_and(|b| {
            b.lines
                .iter()
                .all(|l| written.iter().any(|(n, _, _)| *n == l.number))
        });
        if others || !same_lines {
            let message = format!(
                "this line would be written differently for the call at line {first} and the call at line {call}: the calls run it in different states (position, working plane, datum, tool), and nccomp writes a label's body once for calls that share its state, or a copy per state where a call runs only its own label's lines (this one jumps or calls, or skips lines): expected the moves in the main program, or one label per state"
            );
            let body_line = labels
                .bodies
                .values()
                .flat_map(|b| b.lines.iter())
                .find(|l| l.number == line);
            match body_line {
                Some(l) => self.errors.push(in_line(path, &l.line(), 0, message)),
                None => self.errors.push(Diagnostic {
                    path: path.to_string(),
                    line,
                    column: 1,
                    message,
                    source_line: String::new(),
                    code: None,
                }),
            }
            return;
        }
        let index = match found {
            Some(k) => k,
            None => {
                // A name no label of the program has, nor another copy.
                let taken = |name: &str, copies: &Vec<Copy>| {
                    labels.bodies.contains_key(name) || copies.iter().any(|c| c.name == name)
                };
                let mut k = copies.len() + 2;
                let mut name = format!("{top}_{k}");
                while taken(&name, copies) {
                    k += 1;
                    name = format!("{top}_{k}");
                }
                self.summary
                    .label_copies
                    .push((top.to_string(), name.clone(), call));
                copies.push(Copy {
                    name,
                    texts: written
                        .iter()
                        .map(|(n, t, i)| (*n, (t.clone(), *i)))
                        .collect(),
                });
                copies.len() - 1
            }
        };
        let name = copies[index].name.clone();
        // The call names the copy: `LBL 10` or `LBL "10"` becomes `LBL "10_2"`.
        let emitted = out[mark..].to_vec();
        if let Some(at) = memchr::memmem::find(&emitted, b"LBL") {
            let rest = &emitted[at + 3..];
            let spaces = rest.iter().take_while(|b| **b == b' ').count();
            let token = rest[spaces..]
                .iter()
                .take_while(|b| !b.is_ascii_whitespace() && **b != b';')
                .count();
            let mut line = emitted[..at + 3 + spaces].to_vec();
            line.extend_from_slice(format!("\"{name}\"").as_bytes());
            line.extend_from_slice(&rest[spaces + token..]);
            out.truncate(mark);
            out.extend_from_slice(&line);
        }
    }

    /// After a label's `LBL 0` (the line just written), the copies of the label written
    /// for its calls in other states: `LBL "name"`, its lines, `LBL 0`, numbered on.
    fn write_copies(&mut self, line: &nc::Line<'_>, out: &mut Vec<u8>) {
        if self.copies.is_empty() {
            return;
        }
        let Some(labels) = self.state.modal.tnc.as_ref().map(|t| t.labels.clone()) else {
            return;
        };
        let Some((label, body)) = labels
            .bodies
            .iter()
            .find(|(_, b)| b.closed && b.line + b.lines.len() + 1 == line.number)
        else {
            return;
        };
        let Some(copies) = self.copies.remove(label) else {
            return;
        };
        // The number the LBL 0 line was written with.
        let ending: &[u8] = if line.ending.is_empty() {
            b"\n"
        } else {
            line.ending
        };
        let mut number = crate::program::heidenhain::number_of(line.content, &{
            let mut t = Vec::new();
            nc::heidenhain::parse_line(line.content, &mut t);
            t
        })
        .map(|n| n + self.state.renumber);
        if line.ending.is_empty() {
            out.extend_from_slice(ending);
        }
        let mut block = |out: &mut Vec<u8>, text: &[u8], number: &mut Option<u64>| {
            // A numbered line gets the next number; a continued line stays as it is.
            let lead = text
                .iter()
                .take_while(|b| b.is_ascii_whitespace() || **b == b'/')
                .count();
            let digits = text[lead..]
                .iter()
                .take_while(|b| b.is_ascii_digit())
                .count();
            match number.as_mut() {
                Some(n) if digits > 0 => {
                    *n += 1;
                    self.state.renumber += 1;
                    out.extend_from_slice(&text[..lead]);
                    out.extend_from_slice(n.to_string().as_bytes());
                    out.extend_from_slice(&text[lead + digits..]);
                }
                _ => out.extend_from_slice(text),
            }
        };
        for copy in copies {
            let head = format!("0 LBL \"{}\"", copy.name);
            let mut text = head.into_bytes();
            text.extend_from_slice(ending);
            block(out, &text, &mut number);
            for l in &body.lines {
                let mut lines = match copy.texts.get(&l.number) {
                    Some((t, _)) => t.clone(),
                    None => [l.content.as_slice(), ending].concat(),
                };
                if !lines.ends_with(b"\n") && !lines.ends_with(b"\r") {
                    lines.extend_from_slice(ending);
                }
                let mut rest = &lines[..];
                while !rest.is_empty() {
                    let end = rest
                        .iter()
                        .position(|&b| b == b'\n')
                        .map_or(rest.len(), |k| k + 1);
                    let (one, tail) = rest.split_at(end);
                    rest = tail;
                    block(out, one, &mut number);
                }
            }
            let mut text = b"0 LBL 0".to_vec();
            text.extend_from_slice(ending);
            block(out, &text, &mut number);
        }
    }

    /// Compensate one line where the control runs it (see [`Run::line`]).    /// Compensate one line where the control runs it (see [`Run::line`]).
    fn line_step(&mut self, line: &nc::Line<'_>, path: &str, out: &mut Vec<u8>) -> bool {
        let snapshot = self.hole_snapshot(line);
        let (errors, mark) = (self.errors.len(), out.len());
        let go_on = self.line_once(line, path, out);
        let steps = self.state.hole_steps.take();
        if let (Some(saved), Some(steps)) = (snapshot, steps)
            && self.errors.len() == errors + 1
        {
            // The call as it was refused goes; the state before it comes back.
            let refused = self.errors.pop();
            out.truncate(mark);
            self.restore(saved);
            return self.write_out(line, path, out, &steps, refused);
        }
        go_on
    }

    /// Compensate one line as it is (see [`Run::line`]).
    pub(super) fn line_once(&mut self, line: &nc::Line<'_>, path: &str, out: &mut Vec<u8>) -> bool {
        let comp = self.comp;
        let state = &mut self.state;
        let summary = &mut self.summary;
        summary.lines += 1;
        if line.content.len() > MAX_LINE {
            let start = String::from_utf8_lossy(&line.content[..120]).into_owned();
            self.errors.push(too_long(path, line.number, &start));
            return self.errors.len() < comp.passes[state.pass].options.max_errors;
        }
        crate::program::tokenize(&state.modal, line.content, &mut self.tokens);
        if comp.block_delete() == Some(true)
            && self.tokens.iter().any(|t| t.kind == TokenKind::BlockDelete)
        {
            // With block delete on the control skips the block: so does the pass.
            self.edits.clear();
            if state.modal.dialect == nc::Dialect::Heidenhain {
                renumber(line, &self.tokens, &mut self.edits, &mut state.renumber);
            }
            nc::emit_line(line, &mut self.edits, out);
            return true;
        }
        // The texts of the last line's edits hold their allocations for this line's.
        // (A few: edits made elsewhere do not take from them.)
        for edit in self.edits.drain(..) {
            if state.spare_texts.len() < 32 {
                let mut text = edit.text;
                text.clear();
                state.spare_texts.push(text);
            }
        }
        let at = |offset: usize, message: String| in_line(path, line, offset, message);
        let tokens = &self.tokens;
        let edits = &mut self.edits;
        let blocks = summary.motion_blocks;
        if state.modal.dialect == nc::Dialect::Heidenhain {
            super::holes::follow_feed(line.content, tokens, state);
        }
        let motion = &mut self.motion;
        let result = comp
            .read(line, tokens, state, summary, &at, motion)
            .and_then(|moves| {
                comp.follow_shift(state, moves).map_err(|m| at(0, m))?;
                if state.radius.is_some() && state.modal.program_end == Some(line.number) {
                    // The last element under RL/RR is checked when the block after it is
                    // known: the program may not end before that.
                    return Err(at(
                        0,
                        "the program ends with tool radius compensation (RL/RR) in force: its last contour element's offset is not followed to an end (expected R0 in the last move before the end)".into(),
                    ));
                }
                if !moves {
                    return Ok(());
                }
                let cx = Cx {
                    line,
                    tokens,
                    motion,
                    at: &at,
                };
                let mut out = Out { edits, summary };
                comp.pass(state).block(&cx, state, &mut out)
            });
        let pass = comp.pass(state);
        if summary.motion_blocks > blocks {
            if pass.turning {
                summary.turning_blocks += summary.motion_blocks - blocks;
            }
            summary.note_chain(&comp.machine.tool_chains[pass.chain].name);
        }
        if let Err(d) = result {
            self.errors.push(d);
            if self.errors.len() >= pass.options.max_errors {
                return false;
            }
        }
        let n = pass.kin.len();
        if let Some(s) = summary.trace.as_mut().and_then(|t| t.last_mut())
            && s.line == line.number
        {
            s.nominal = state.pos.nominal[..n].to_vec();
            s.written = state.emitted[..n].to_vec();
            s.chain = pass.chain;
            s.feed = !state.modal.rapid;
        }
        if let Some(number) = tokens.iter().find_map(|t| match &t.kind {
            TokenKind::Word(w) if w.letter == b'N' => {
                let digits = &line.content[w.value_span.clone()];
                block_number(digits)
            }
            _ => None,
        }) {
            state.last_n = Some(number);
        }
        if state.modal.dialect == nc::Dialect::Heidenhain {
            renumber(line, tokens, &mut self.edits, &mut state.renumber);
        }
        nc::emit_line(line, &mut self.edits, out);
        true
    }

    /// Take the solutions solved ahead for the next chunk; gives back the spent ones.
    fn ahead(&mut self, ahead: Vec<Ahead>) -> Vec<Ahead> {
        self.state.presolved.refill(ahead)
    }

    /// Run the lines of `chunk` (after `before` lines, at `offset` in the stream),
    /// appending the output to `out` while no block has been refused. False when the pass
    /// should stop.
    fn chunk(
        &mut self,
        chunk: &[u8],
        before: usize,
        offset: usize,
        path: &str,
        out: &mut Vec<u8>,
    ) -> bool {
        for mut line in nc::lines(chunk) {
            line.number += before;
            line.offset += offset;
            let go_on = self.line(&line, path, out);
            if self.failed() {
                out.clear();
            }
            if !go_on {
                return false;
            }
        }
        true
    }

    /// The summary, or every block refused.
    pub(super) fn finish(self) -> crate::Result<Summary> {
        Compensator::refusing(self.finish_all())
    }

    /// The summary and the blocks refused.
    pub(super) fn finish_all(mut self) -> (Summary, Vec<Diagnostic>) {
        let modal = &self.state.modal;
        if let Some(end) = modal.program_end
            && modal.after_end > 0
        {
            self.summary.after_end = Some((end, modal.after_end));
        }
        (self.summary, self.errors)
    }
}

impl Compensator<'_> {
    /// Set `Options::threads` (it changes how fast, never what, the pass writes).
    pub fn set_threads(&mut self, threads: usize) {
        self.threads = threads;
    }

    /// The pass over `chunks` with a helper thread solving each chunk ahead (see
    /// `presolve`): the reading and the pass stay on this thread, in order.
    fn run_ahead<R: Read>(
        &self,
        chunks: &mut Chunks<R>,
        input_name: &str,
        output: &mut impl Write,
        output_name: &str,
        pass: &mut Run<'_, '_>,
        program: Option<(nc::Dialect, &Arc<Labels>)>,
    ) -> crate::Result<()> {
        use std::collections::VecDeque;
        use std::sync::mpsc::{RecvTimeoutError, sync_channel};
        use std::time::{Duration, Instant};
        // A chunk to read ahead (its index, a copy of its bytes, the share of its solves
        // the pass keeps); and back, with how long the helper waited for it.
        type ToHelper = (usize, Vec<u8>, usize, Vec<Ahead>, f64);
        type ToPass = (usize, Vec<u8>, Vec<Ahead>, Duration);
        std::thread::scope(|scope| {
            let (to_helper, work) = sync_channel::<ToHelper>(2);
            let (to_pass, done) = sync_channel::<ToPass>(2);
            scope.spawn(move || {
                let mut predictor = Predictor::new(self);
                if let Some((dialect, labels)) = program {
                    predictor.program_with(dialect, labels);
                }
                let mut idle_since = Instant::now();
                for (index, bytes, before, mut ahead, share) in work {
                    let waited = idle_since.elapsed();
                    ahead.clear();
                    predictor.chunk(self, &bytes, before, share, &mut ahead);
                    idle_since = Instant::now();
                    if to_pass.send((index, bytes, ahead, waited)).is_err() {
                        break;
                    }
                }
            });
            // The helper's channels; dropped when the pass goes on alone.
            let mut link = Some((to_helper, done));
            let mut share = START_SHARE;
            // Buffers to reuse: chunk bytes, and solves ahead.
            let mut bufs: Vec<Vec<u8>> = Vec::new();
            let mut aheads: Vec<Vec<Ahead>> = Vec::new();
            let mut out = Vec::with_capacity(CHUNK + CHUNK / 4);
            // Chunks read and not yet run: index, bytes, lines before, offset.
            let mut pending: VecDeque<(usize, Vec<u8>, usize, usize)> = VecDeque::new();
            let mut next_index = 0;
            let mut reading = true;
            // The longest the pass waits for the helper's reply: about what the chunk
            // would take it alone (its first chunk, which it runs alone, or its last one,
            // if longer). A helper that cannot reply in that time (the other core busy) is
            // left, and the pass goes on alone: two threads are never much slower than one.
            let mut alone = Duration::ZERO;
            let mut patience = Duration::ZERO;
            loop {
                // Keep the helper up to two chunks ahead of the pass.
                while reading && pending.len() < 2 {
                    match chunks
                        .next()
                        .map_err(|source| read_failure(input_name, source))?
                    {
                        Some((chunk, before, offset)) => {
                            let mut bytes = bufs.pop().unwrap_or_default();
                            bytes.clear();
                            bytes.extend_from_slice(chunk);
                            if let Some((to_helper, _)) = &link {
                                // The first chunk's solves the pass keeps: it starts
                                // at once (a short program never waits for the helper).
                                let keep = if next_index == 0 { 1.0 } else { share };
                                let mut copy = bufs.pop().unwrap_or_default();
                                copy.clear();
                                copy.extend_from_slice(chunk);
                                let ahead = aheads.pop().unwrap_or_default();
                                if to_helper
                                    .send((next_index, copy, before, ahead, keep))
                                    .is_err()
                                {
                                    link = None;
                                }
                            }
                            pending.push_back((next_index, bytes, before, offset));
                            next_index += 1;
                        }
                        None => reading = false,
                    }
                }
                let Some((index, bytes, before, offset)) = pending.pop_front() else {
                    return Ok(());
                };
                let mut ahead = Vec::new();
                if index > 0
                    && let Some((_, done)) = &link
                {
                    let asked = Instant::now();
                    loop {
                        match done.recv_timeout(patience.saturating_sub(asked.elapsed())) {
                            // (The first chunk's reply has nothing for the pass.)
                            Ok((i, back, reply, _)) if i < index => {
                                bufs.push(back);
                                aheads.push(reply);
                            }
                            Ok((_, back, reply, helper_waited)) => {
                                share = balance(share, asked.elapsed(), helper_waited);
                                ahead = reply;
                                bufs.push(back);
                                break;
                            }
                            Err(RecvTimeoutError::Timeout) => {
                                link = None;
                                break;
                            }
                            // The helper is gone (it cannot fail; this is a panic,
                            // which the scope passes on).
                            Err(RecvTimeoutError::Disconnected) => return Ok(()),
                        }
                    }
                }
                let started = Instant::now();
                let spent = pass.ahead(ahead);
                let go_on = pass.chunk(&bytes, before, offset, input_name, &mut out);
                let took = started.elapsed();
                if index == 0 {
                    alone = took;
                }
                patience = took.max(alone).max(Duration::from_millis(2));
                output.write_all(&out).map_err(|source| Error::Io {
                    path: output_name.to_string(),
                    source,
                })?;
                out.clear();
                bufs.push(bytes);
                aheads.push(spent);
                if !go_on {
                    return Ok(());
                }
            }
        })
    }
}

/// A TNC line's block number moved on by the blocks inserted before it (those of earlier
/// lines, `shift`, and this line's own, which it counts into `shift`).
fn renumber(line: &nc::Line<'_>, tokens: &[Token], edits: &mut Vec<Edit>, shift: &mut u64) {
    // Blocks, not lines: a cycle definition runs on over lines without numbers.
    let inserted: usize = edits
        .iter()
        .filter(|e| e.at == (0..0))
        .flat_map(|e| e.text.split(|&b| b == b'\n' || b == b'\r'))
        .filter(|l| {
            let l = l.trim_ascii_start();
            let l = l.strip_prefix(b"/").unwrap_or(l);
            l.first().is_some_and(u8::is_ascii_digit)
        })
        .count();
    *shift += inserted as u64;
    if *shift == 0 {
        return;
    }
    let Some(i) = crate::program::heidenhain::block_number(line.content, tokens) else {
        return;
    };
    if let Some(n) = crate::program::heidenhain::number_of(line.content, tokens) {
        edits.push(Edit {
            at: tokens[i].span.clone(),
            text: (n + *shift).to_string().into_bytes(),
        });
    }
}

/// Append `text` with the block number that starts each of its lines moved on by
/// `shift` (a subprogram's lines, written with the numbers of their place).
fn shifted(text: &[u8], shift: u64, out: &mut Vec<u8>) {
    if shift == 0 {
        out.extend_from_slice(text);
        return;
    }
    let mut rest = text;
    while !rest.is_empty() {
        let end = rest
            .iter()
            .position(|&b| b == b'\n')
            .map_or(rest.len(), |k| k + 1);
        let (line, tail) = rest.split_at(end);
        rest = tail;
        let lead = line
            .iter()
            .take_while(|b| b.is_ascii_whitespace() || **b == b'/')
            .count();
        let digits = line[lead..]
            .iter()
            .take_while(|b| b.is_ascii_digit())
            .count();
        match std::str::from_utf8(&line[lead..lead + digits])
            .ok()
            .and_then(|d| d.parse::<u64>().ok())
        {
            Some(n) if digits > 0 => {
                out.extend_from_slice(&line[..lead]);
                out.extend_from_slice((n + shift).to_string().as_bytes());
                out.extend_from_slice(&line[lead + digits..]);
            }
            _ => out.extend_from_slice(line),
        }
    }
}

/// An N word's number as `str::parse::<u64>` reads it (an optional `+`, then digits), without
/// the UTF-8 check.
fn block_number(text: &[u8]) -> Option<u64> {
    let digits = text.strip_prefix(b"+").unwrap_or(text);
    if digits.is_empty() {
        return None;
    }
    digits.iter().try_fold(0u64, |n, &b| {
        if b.is_ascii_digit() {
            n.checked_mul(10)?.checked_add(u64::from(b - b'0'))
        } else {
            None
        }
    })
}

/// A diagnostic at byte `offset` of `line`'s content, as [`Diagnostic::at`] gives it for
/// the whole file (a last line's stray `\r` is not shown).
pub(super) fn in_line(
    path: &str,
    line: &nc::Line<'_>,
    offset: usize,
    message: String,
) -> Diagnostic {
    let offset = offset.min(line.content.len());
    let mut source_line = String::from_utf8_lossy(line.content).into_owned();
    if line.ending.is_empty() && source_line.ends_with('\r') {
        source_line.pop();
    }
    Diagnostic {
        path: path.to_string(),
        line: line.number,
        column: String::from_utf8_lossy(&line.content[..offset])
            .chars()
            .count()
            + 1,
        message,
        source_line,
        code: None,
    }
}

/// The zero model's pass: the bytes straight through, a chunk at a time whatever the lines
/// (nothing is parsed, so no line is too long), and the lines counted.
fn copy_through(
    mut input: impl Read,
    input_name: &str,
    mut output: impl Write,
    output_name: &str,
) -> crate::Result<Summary> {
    let mut buf = vec![0u8; CHUNK];
    // Line endings as the pass cuts lines (a CR LF may be split between two reads).
    let (mut ends, mut last) = (nc::LineEnds::default(), b'\n');
    loop {
        let k = match input.read(&mut buf) {
            Ok(0) => break,
            Ok(k) => k,
            Err(e) if e.kind() == ErrorKind::Interrupted => continue,
            Err(source) => {
                return Err(Error::Io {
                    path: input_name.to_string(),
                    source,
                });
            }
        };
        ends.feed(&buf[..k]);
        last = buf[k - 1];
        output.write_all(&buf[..k]).map_err(|source| Error::Io {
            path: output_name.to_string(),
            source,
        })?;
    }
    output.flush().map_err(|source| Error::Io {
        path: output_name.to_string(),
        source,
    })?;
    // A last line without its ending counts too.
    Ok(Summary {
        zero_model: true,
        lines: ends.finish() + usize::from(last != b'\n' && last != b'\r'),
        ..Summary::default()
    })
}

/// Reads a stream in chunks cut after their last line ending.
pub(crate) struct Chunks<R> {
    input: R,
    buf: Vec<u8>,
    /// Bytes of `buf` read and not yet handed out.
    filled: usize,
    /// Bytes at the start of `buf` handed out by the last [`Chunks::next`].
    taken: usize,
    /// Line number and file offset of the first line of the next chunk, less one line.
    lines: usize,
    offset: usize,
    eof: bool,
}

impl<R: Read> Chunks<R> {
    pub(crate) fn new(input: R) -> Self {
        Self::with_capacity(input, CHUNK)
    }

    fn with_capacity(input: R, capacity: usize) -> Self {
        Chunks {
            input,
            buf: vec![0; capacity.max(1)],
            filled: 0,
            taken: 0,
            lines: 0,
            offset: 0,
            eof: false,
        }
    }

    /// Hand out the last chunk again at the next [`Chunks::next`].
    fn unread(&mut self) {
        self.lines -= nc::line_ends(&self.buf[..self.taken]);
        self.taken = 0;
    }

    /// The next run of whole lines (the last one may lack its ending at the end of the
    /// input), with the number of lines before it and its offset in the stream; `None` at
    /// the end.
    pub(crate) fn next(&mut self) -> std::io::Result<Option<(&[u8], usize, usize)>> {
        self.buf.copy_within(self.taken..self.filled, 0);
        self.filled -= self.taken;
        self.offset += self.taken;
        self.taken = 0;
        loop {
            let cut = if self.eof {
                self.filled
            } else {
                nc::whole_lines(&self.buf[..self.filled])
            };
            // Read more unless a good share of the buffer holds whole lines.
            if self.eof || (cut > 0 && self.filled >= self.buf.len() / 2) {
                if cut == 0 {
                    return Ok(None);
                }
                self.taken = cut;
                let chunk = &self.buf[..cut];
                let before = self.lines;
                self.lines += nc::line_ends(chunk);
                return Ok(Some((chunk, before, self.offset)));
            }
            if self.filled == self.buf.len() {
                // A line longer than the buffer; past `MAX_LINE` it is refused before it
                // is read whole (a pass keeps a token for every few bytes of a line).
                if self.buf.len() >= MAX_LINE {
                    let start = &self.buf[..self.filled.min(120)];
                    return Err(std::io::Error::new(
                        ErrorKind::InvalidData,
                        LineTooLong {
                            line: self.lines + 1,
                            start: String::from_utf8_lossy(start).into_owned(),
                        },
                    ));
                }
                self.buf.resize(self.buf.len() * 2, 0);
            }
            match self.input.read(&mut self.buf[self.filled..]) {
                Ok(0) => self.eof = true,
                Ok(k) => self.filled += k,
                Err(e) if e.kind() == ErrorKind::Interrupted => {}
                Err(e) => return Err(e),
            }
        }
    }
}

impl Compensator<'_> {
    /// Compensate the program read from `input` (named `input_name` in messages), writing
    /// the result to `output` (named `output_name`) as it goes, in memory bounded by a
    /// chunk and the longest line. The bytes written are those [`Self::run`] appends.
    ///
    /// On an error (a refused block, a read or write failure) part of the output may have
    /// been written: write to a temporary file and keep it only on success. Once a block is
    /// refused nothing more is written, but the rest of the program is still checked (up
    /// to `Options::max_errors` refusals).
    pub fn run_stream(
        &self,
        input: impl Read,
        input_name: &str,
        output: impl Write,
        output_name: &str,
    ) -> crate::Result<Summary> {
        let read_error = |source| read_failure(input_name, source);
        if self.zero_model {
            return copy_through(input, input_name, output, output_name);
        }
        let mut chunks = Chunks::new(input);
        if let Some((first, _, _)) = chunks.next().map_err(read_error)?
            && self.dialect_of(input_name, first) != nc::Dialect::Iso
        {
            // A TNC program calls labels written after its end: a first pass keeps their
            // bodies (and a copy of the text, in a temporary file, to read again), then
            // the program streams as G-code does. A Sinumerik program streams at once.
            let dialect = self.dialect_of(input_name, first);
            chunks.unread();
            if dialect != nc::Dialect::Heidenhain {
                let labels = Arc::default();
                let mut pass = Run::new(self, false);
                pass.program_with(dialect, &labels);
                let program = Some((dialect, &labels));
                return self.stream(&mut chunks, input_name, output, output_name, pass, program);
            }
            let mut copy = tempfile::tempfile().map_err(read_error)?;
            let mut scan = LabelScan::default();
            while let Some((chunk, before, at)) = chunks.next().map_err(read_error)? {
                for line in nc::lines(chunk) {
                    scan.line(&nc::Line {
                        number: line.number + before,
                        offset: line.offset + at,
                        ..line
                    });
                }
                copy.write_all(chunk).map_err(read_error)?;
            }
            let labels = Arc::new(scan.finish());
            let mut pass = Run::new(self, false);
            pass.program_with(dialect, &labels);
            use std::io::{Seek, SeekFrom};
            copy.seek(SeekFrom::Start(0)).map_err(read_error)?;
            let mut chunks = Chunks::new(copy);
            let program = Some((dialect, &labels));
            return self.stream(&mut chunks, input_name, output, output_name, pass, program);
        }
        chunks.unread();
        let pass = Run::new(self, false);
        self.stream(&mut chunks, input_name, output, output_name, pass, None)
    }

    /// The pass over `chunks`, one thread or with the solve-ahead helper.
    fn stream<R: Read>(
        &self,
        chunks: &mut Chunks<R>,
        input_name: &str,
        mut output: impl Write,
        output_name: &str,
        mut pass: Run<'_, '_>,
        program: Option<(nc::Dialect, &Arc<Labels>)>,
    ) -> crate::Result<Summary> {
        let read_error = |source| read_failure(input_name, source);
        let write_error = |source| Error::Io {
            path: output_name.to_string(),
            source,
        };
        if self.threads > 1 {
            self.run_ahead(
                chunks,
                input_name,
                &mut output,
                output_name,
                &mut pass,
                program,
            )?;
        } else {
            let mut out = Vec::with_capacity(CHUNK + CHUNK / 4);
            while let Some((chunk, before, offset)) = chunks.next().map_err(read_error)? {
                let go_on = pass.chunk(chunk, before, offset, input_name, &mut out);
                output.write_all(&out).map_err(write_error)?;
                out.clear();
                if !go_on {
                    break;
                }
            }
        }
        if !pass.failed() {
            output.flush().map_err(write_error)?;
        }
        pass.finish()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Hands out 1 to 3 bytes per read.
    struct Trickle<'a>(&'a [u8], usize);

    impl Read for Trickle<'_> {
        fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
            self.1 += 1;
            let k = (1 + self.1 % 3).min(buf.len()).min(self.0.len());
            buf[..k].copy_from_slice(&self.0[..k]);
            self.0 = &self.0[k..];
            Ok(k)
        }
    }

    proptest! {
        /// The zero model copies the bytes and counts the lines `nc::lines` cuts, however
        /// the reads split a CR LF.
        #[test]
        fn the_zero_models_copy_counts_lines_as_the_pass_does(
            bytes in prop::collection::vec(prop::sample::select(b"ab\r\n".to_vec()), 0..100),
        ) {
            let mut out = Vec::new();
            let summary = copy_through(Trickle(&bytes, 0), "in", &mut out, "out").unwrap();
            prop_assert_eq!(&out, &bytes);
            prop_assert_eq!(summary.lines, nc::lines(&bytes).count());
        }

        #[test]
        fn block_numbers_read_as_std_reads_them(text in "[+-]?[0-9]{0,22}[.a ]?[0-9]{0,2}") {
            prop_assert_eq!(block_number(text.as_bytes()), text.parse::<u64>().ok());
        }

        #[test]
        fn chunks_are_whole_lines_in_order(
            bytes in prop::collection::vec(prop::sample::select(b"ab\r\n".to_vec()), 0..200),
            capacity in 1usize..12,
        ) {
            let mut chunks = Chunks::with_capacity(Trickle(&bytes, 0), capacity);
            let mut joined = Vec::new();
            let mut cut = Vec::new();
            while let Some((chunk, before, offset)) = chunks.next().unwrap() {
                prop_assert!(!chunk.is_empty());
                prop_assert_eq!(offset, joined.len());
                prop_assert_eq!(before, nc::line_ends(&joined));
                joined.extend_from_slice(chunk);
                // Only the input's last line may come without its ending, and a CR ends
                // a chunk only when no LF follows it.
                prop_assert!(
                    chunk.ends_with(b"\n")
                        || (chunk.ends_with(b"\r") && bytes.get(joined.len()) != Some(&b'\n'))
                        || joined.len() == bytes.len()
                );
                for mut line in nc::lines(chunk) {
                    line.number += before;
                    line.offset += offset;
                    cut.push((line.number, line.offset, line.content.to_vec(), line.ending.to_vec()));
                }
            }
            // The lines of the chunks are the lines of the whole.
            let whole: Vec<_> = nc::lines(&bytes)
                .map(|l| (l.number, l.offset, l.content.to_vec(), l.ending.to_vec()))
                .collect();
            prop_assert_eq!(cut, whole);
            prop_assert_eq!(joined, bytes);
        }
    }
}
