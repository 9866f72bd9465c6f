//! The NC program as a lossless document.
//!
//! A program is split into lines (blocks); each line into tokens that cover every byte of
//! it. Emitting the tokens' source bytes gives the input back byte for byte, so a pass can
//! replace a single number and leave everything else exactly as it was (the toml_edit
//! idea: a value keeps its own text).

pub mod edit;
pub mod heidenhain;
pub mod number;
mod parse;
pub mod sinumerik;

pub(crate) use parse::to_f64;
pub use parse::{LineEnds, line_at, line_ends, lines, parse_line, whole_lines};

use std::ops::Range;

/// The language a program is written in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Dialect {
    /// ISO G-code (Fanuc, Haas, LinuxCNC, …).
    #[default]
    Iso,
    /// Heidenhain TNC conversational language (Klartext, `.h` files).
    Heidenhain,
    /// Siemens Sinumerik 840D language (`.mpf`, `.spf` files).
    Sinumerik,
}

impl Dialect {
    /// The dialect of a program's text: Heidenhain when its first line that is not empty
    /// is a numbered `BEGIN PGM` (the control writes every program so), Sinumerik when one
    /// of its first 200 lines is one only Sinumerik writes ([`sinumerik::looks_like`]),
    /// else ISO.
    pub fn detect(src: &[u8]) -> Dialect {
        let first = lines(src)
            .map(|l| l.content.trim_ascii())
            .find(|c| !c.is_empty())
            .unwrap_or_default();
        let body = first.trim_ascii_start();
        let digits = body.iter().take_while(|b| b.is_ascii_digit()).count();
        if digits > 0 && body[digits..].trim_ascii_start().starts_with(b"BEGIN PGM") {
            Dialect::Heidenhain
        } else if lines(src)
            .take(200)
            .any(|l| sinumerik::looks_like(l.content))
        {
            Dialect::Sinumerik
        } else {
            Dialect::Iso
        }
    }

    /// The dialect of the program in file `name`: Sinumerik for a `.mpf` or `.spf` file (the
    /// control's main programs and subprograms), else [`Dialect::detect`] of its text.
    pub fn detect_named(name: &str, src: &[u8]) -> Dialect {
        let ext = std::path::Path::new(name)
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        match ext.as_deref() {
            Some("mpf" | "spf") => Dialect::Sinumerik,
            _ => Dialect::detect(src),
        }
    }

    /// Cut a line's content into tokens, in this dialect.
    pub fn parse_line(self, content: &[u8], out: &mut Vec<Token>) {
        match self {
            Dialect::Iso => parse_line(content, out),
            Dialect::Heidenhain => heidenhain::parse_line(content, out),
            Dialect::Sinumerik => sinumerik::parse_line(content, out),
        }
    }

    /// Its name, as `--dialect` takes it.
    pub fn name(self) -> &'static str {
        match self {
            Dialect::Iso => "iso",
            Dialect::Heidenhain => "heidenhain",
            Dialect::Sinumerik => "sinumerik",
        }
    }
}

/// One line of a program: its content (without the line ending) and the ending itself.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Line<'a> {
    /// 1-based line number in the file.
    pub number: usize,
    /// Byte offset of the line's first byte in the file.
    pub offset: usize,
    /// The line without its ending (a `\r` before `\n` belongs to the ending).
    pub content: &'a [u8],
    /// `b"\n"` with any `\r`s before it (`b"\r\n"`), `b"\r"` alone, or `b""` (last line
    /// without a newline).
    pub ending: &'a [u8],
}

/// What a run of bytes in a line is.
#[derive(Debug, Clone, PartialEq)]
pub enum TokenKind {
    /// Spaces and tabs (and stray `\r`).
    Space,
    /// `( ... )` (to the end of the line if unclosed) or `;` to the end of the line.
    Comment,
    /// `/` at the start of a block (after optional spaces).
    BlockDelete,
    /// A line holding `%` (program start/end marker); the token covers the `%`.
    Percent,
    /// A letter and its value.
    Word(Word),
    /// Anything else (`#1=5`, `=`, keywords of O-word lines, stray bytes...).
    Other,
}

/// A token: its kind and the bytes it covers, relative to the start of the line content.
#[derive(Debug, Clone, PartialEq)]
pub struct Token {
    pub kind: TokenKind,
    pub span: Range<usize>,
}

/// A word such as `X-12.5`, `n10`, `G 1`, `X[#1+2]`.
#[derive(Debug, Clone, PartialEq)]
pub struct Word {
    /// The letter, uppercased.
    pub letter: u8,
    /// Whether the source letter was lowercase.
    pub lowercase: bool,
    pub value: Value,
    /// The value's bytes (after the letter and any spaces), relative to the line start.
    /// Empty at the end of the word for [`Value::Missing`].
    pub value_span: Range<usize>,
}

/// A word's value.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Value {
    /// A literal number; `decimals` counts the digits after the decimal point
    /// (`10.` has 0, `10.50` has 2).
    Number { value: f64, decimals: u8 },
    /// `[ ... ]`, an expression (rs274ngc).
    Expression,
    /// `#5`, `#<name>`, a parameter reference.
    Parameter,
    /// The letter stands alone (`X` followed by something that is not a value).
    Missing,
}

impl Word {
    pub fn number(&self) -> Option<f64> {
        match self.value {
            Value::Number { value, .. } => Some(value),
            _ => None,
        }
    }
}

/// A change to one line: replace the bytes `at` (relative to the line's content) by `text`;
/// an empty range inserts.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Edit {
    pub at: Range<usize>,
    /// Bytes, not a `String`: the pass writes digits straight into it (ASCII, the NC text
    /// around it is whatever the file holds).
    pub text: Vec<u8>,
}

/// Append `line` to `out` with `edits` applied (sorted here; edits at the same place keep
/// their order), then its line ending. Bytes no edit touches are copied as they were.
pub fn emit_line(line: &Line<'_>, edits: &mut [Edit], out: &mut Vec<u8>) {
    // The usual edits come in the order of the line's words.
    if !edits.is_sorted_by_key(|e| (e.at.start, e.at.end)) {
        edits.sort_by_key(|e| (e.at.start, e.at.end));
    }
    let mut pos = 0;
    for e in edits.iter() {
        // What stands between rewritten numbers is mostly a space and a letter: a call
        // to `memcpy` costs more than the bytes.
        let between = &line.content[pos..e.at.start];
        if between.len() <= 4 {
            for &b in between {
                out.push(b);
            }
        } else {
            out.extend_from_slice(between);
        }
        out.extend_from_slice(&e.text);
        pos = e.at.end;
    }
    out.extend_from_slice(&line.content[pos..]);
    out.extend_from_slice(line.ending);
}

#[cfg(test)]
mod tests {
    use super::*;

    proptest::proptest! {
        /// Edits in any order give the line with each range replaced, left to right.
        #[test]
        fn edits_are_applied_in_place(
            content in proptest::collection::vec(proptest::num::u8::ANY, 0..60),
            cuts in proptest::collection::vec((0usize..60, 0usize..12, "[ -~]{0,10}"), 0..8),
            order in proptest::num::u64::ANY,
        ) {
            // Ranges that do not overlap (inserts may share a place with nothing else).
            let mut edits: Vec<Edit> = Vec::new();
            let mut taken = vec![false; content.len() + 1];
            for (start, len, text) in cuts {
                let start = start.min(content.len());
                let end = (start + len).min(content.len());
                if taken[start..=end].iter().any(|&t| t) {
                    continue;
                }
                taken[start..=end].iter_mut().for_each(|t| *t = true);
                edits.push(Edit { at: start..end, text: text.into_bytes() });
            }
            let mut expected = Vec::new();
            let mut sorted = edits.clone();
            sorted.sort_by_key(|e| e.at.start);
            let mut pos = 0;
            for e in &sorted {
                expected.extend_from_slice(&content[pos..e.at.start]);
                expected.extend_from_slice(&e.text);
                pos = e.at.end;
            }
            expected.extend_from_slice(&content[pos..]);
            expected.extend_from_slice(b"\r\n");
            // Shuffled by the seed.
            let n = edits.len();
            for i in (1..n).rev() {
                edits.swap(i, (order as usize ^ i.wrapping_mul(0x9e37)) % (i + 1));
            }
            let line = Line { number: 1, offset: 0, content: &content, ending: b"\r\n" };
            let mut out = b"kept".to_vec();
            emit_line(&line, &mut edits, &mut out);
            proptest::prop_assert_eq!(&out[..4], b"kept");
            proptest::prop_assert_eq!(&out[4..], &expected[..]);
        }
    }
}
