//! Errors that point at a place in an input file.
//!
//! Every message about bad input names the file, the line and the column, and says
//! what was expected, so a user can go straight to the offending byte.

use annotate_snippets::{AnnotationKind, Group, Level, Origin, Renderer, Snippet};
use std::fmt;
use std::path::Path;

/// A problem at a place in an input file (1-based line and column; the column counts
/// characters, not bytes).
#[derive(Debug, Clone, PartialEq)]
pub struct Diagnostic {
    pub path: String,
    pub line: usize,
    pub column: usize,
    pub message: String,
    /// The text of the offending line (without its line ending), for a caret display.
    pub source_line: String,
    /// What kind of problem it is, for programs that sort diagnostics (e.g.
    /// `compensate::TRAVEL_LIMIT`); shown as `error[code]`.
    pub code: Option<&'static str>,
}

impl Diagnostic {
    /// A diagnostic at byte `offset` of `text` (the whole file).
    pub fn at(path: &str, text: &[u8], offset: usize, message: impl Into<String>) -> Self {
        let offset = offset.min(text.len());
        // Lines as `nc::lines` cuts them (a `\r` alone ends one).
        let (line, line_start, line_end) = crate::nc::line_at(text, offset);
        let line_end = line_end.max(offset);
        let prefix = String::from_utf8_lossy(&text[line_start..offset]);
        let mut source_line = String::from_utf8_lossy(&text[line_start..line_end]).into_owned();
        if source_line.ends_with('\r') {
            source_line.pop();
        }
        Diagnostic {
            path: path.to_string(),
            line,
            column: prefix.chars().count() + 1,
            message: message.into(),
            source_line,
            code: None,
        }
    }

    /// The diagnostic with a [`Diagnostic::code`].
    pub fn with_code(self, code: &'static str) -> Self {
        Diagnostic {
            code: Some(code),
            ..self
        }
    }

    /// The diagnostic as an error, rustc-style: the message, `--> file:line:column`, the
    /// source line and carets under the offending word. Plain text (no colour).
    pub fn render(&self) -> String {
        self.render_as(Severity::Error, false)
    }

    /// The diagnostic rendered at `severity`, with ANSI colour when `color` is set.
    pub fn render_as(&self, severity: Severity, color: bool) -> String {
        renderer(color).render(&[self.group(severity)])
    }

    fn group(&self, severity: Severity) -> Group<'_> {
        let mut title = severity.level().primary_title(self.message.as_str());
        if let Some(code) = self.code {
            title = title.id(code);
        }
        if self.source_line.is_empty() {
            return title.element(
                Origin::path(self.path.as_str())
                    .line(self.line)
                    .char_column(self.column),
            );
        }
        title.element(
            Snippet::source(self.source_line.as_str())
                .line_start(self.line)
                .path(self.path.as_str())
                .annotation(AnnotationKind::Primary.span(self.word())),
        )
    }

    /// The byte range in `source_line` of the word the diagnostic points at: an NC word
    /// (a letter and its number, parameter or expression: `X-1.5`, `G43.4`, `X#1`), a
    /// name (`EZQ`, `tool_chain`), a number, a quoted string, a bracketed list or a
    /// comment, or else the one character at the column.
    pub fn word(&self) -> std::ops::Range<usize> {
        let line = self.source_line.as_bytes();
        let start = self
            .source_line
            .char_indices()
            .nth(self.column.saturating_sub(1))
            .map_or(line.len(), |(i, _)| i);
        let is_number = |b: u8| b.is_ascii_digit() || b == b'.';
        let run = |from: usize, pred: &dyn Fn(u8) -> bool| {
            from + line[from..].iter().take_while(|&&b| pred(b)).count()
        };
        let Some(&first) = line.get(start) else {
            return start..start;
        };
        let end = if first.is_ascii_alphabetic() {
            // A letter directly followed by a (signed) number is an NC word.
            let after = start + 1;
            let signed = matches!(line.get(after), Some(b'-' | b'+'))
                && line.get(after + 1).is_some_and(|&b| is_number(b));
            if signed || line.get(after).is_some_and(|&b| is_number(b)) {
                run(after + usize::from(signed), &is_number)
            } else if line.get(after) == Some(&b'#') {
                // A parameter: `X#1`, `X#<depth>`.
                run(after + 1, &|b: u8| {
                    b.is_ascii_alphanumeric() || matches!(b, b'_' | b'<' | b'>')
                })
            } else if line.get(after) == Some(&b'[') {
                // An expression, to its closing bracket.
                line[after..]
                    .iter()
                    .position(|&b| b == b']')
                    .map_or(line.len(), |i| after + i + 1)
            } else {
                run(start, &|b: u8| b.is_ascii_alphanumeric() || b == b'_')
            }
        } else if is_number(first) || first == b'-' || first == b'+' {
            run(start + 1, &is_number)
        } else if let Some(close) = match first {
            b'"' => Some(b'"'),
            b'[' => Some(b']'),
            b'(' => Some(b')'),
            _ => None,
        } {
            // A quoted string, a bracketed list or expression, a comment: to its end.
            line[start + 1..]
                .iter()
                .position(|&b| b == close)
                .map_or(line.len(), |i| start + 1 + i + 1)
        } else {
            // One character, however many bytes it takes.
            start
                + self.source_line[start..]
                    .chars()
                    .next()
                    .map_or(1, char::len_utf8)
        };
        start..end.max(start + 1).min(line.len())
    }
}

/// How a diagnostic is shown: its level word and colour.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Severity {
    Error,
    Warning,
    Note,
}

impl Severity {
    fn level(self) -> Level<'static> {
        match self {
            Severity::Error => Level::ERROR,
            Severity::Warning => Level::WARNING,
            Severity::Note => Level::NOTE,
        }
    }
}

fn renderer(color: bool) -> Renderer {
    if color {
        Renderer::styled()
    } else {
        Renderer::plain()
    }
}

/// A message without a place in a file, rendered like the diagnostics (`error: ...`).
pub fn render_message(severity: Severity, message: &str, color: bool) -> String {
    renderer(color).render(&[Group::with_title(severity.level().primary_title(message))])
}

/// Whether to colour what goes to `stream`: only on a terminal, and never when the
/// `NO_COLOR` environment variable is set to anything non-empty (no-color.org).
pub fn use_color(stream: &impl std::io::IsTerminal) -> bool {
    stream.is_terminal() && std::env::var_os("NO_COLOR").is_none_or(|v| v.is_empty())
}

impl fmt::Display for Diagnostic {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}:{}:{}: {}",
            self.path, self.line, self.column, self.message
        )
    }
}

/// The library's error type.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Bad input at a known place in a file.
    #[error("{0}")]
    Input(Box<Diagnostic>),
    /// Several problems in one input (each located).
    #[error("{}", .0.iter().map(|d| d.to_string()).collect::<Vec<_>>().join("\n"))]
    Inputs(Vec<Diagnostic>),
    /// A request that cannot be carried out (a tool chain that does not exist, ...).
    #[error("{0}")]
    Usage(String),
    /// A file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        path: String,
        #[source]
        source: std::io::Error,
    },
}

impl Error {
    pub fn at(path: &str, text: &[u8], offset: usize, message: impl Into<String>) -> Self {
        Error::Input(Box::new(Diagnostic::at(path, text, offset, message)))
    }

    pub fn io(path: &Path, source: std::io::Error) -> Self {
        Error::Io {
            path: path.display().to_string(),
            source,
        }
    }

    /// The error rustc-style, in plain text: located ones with the source line and carets
    /// under the offending word, each as `error: message` (several separated by a blank
    /// line).
    pub fn render(&self) -> String {
        self.render_styled(false)
    }

    /// [`Error::render`], with ANSI colour when `color` is set (see [`use_color`]).
    pub fn render_styled(&self, color: bool) -> String {
        match self {
            Error::Input(d) => d.render_as(Severity::Error, color),
            Error::Inputs(ds) => ds
                .iter()
                .map(|d| d.render_as(Severity::Error, color))
                .collect::<Vec<_>>()
                .join("\n\n"),
            other => render_message(Severity::Error, &other.to_string(), color),
        }
    }
}

pub type Result<T, E = Error> = std::result::Result<T, E>;

/// The message a panic carried (`panic!("...")`, a failed `expect`, an overflow), for
/// reporting it as an internal error where it was caught.
pub fn panic_message(payload: &(dyn std::any::Any + Send)) -> &str {
    payload
        .downcast_ref::<&str>()
        .copied()
        .or_else(|| payload.downcast_ref::<String>().map(String::as_str))
        .unwrap_or("a panic without a message")
}

/// For pointing a diagnostic at a field of a CSV row: byte offsets of the first `n`
/// fields of the row starting at `start` (leading spaces skipped, quotes respected);
/// fewer if the row has fewer. The probe and trace readers share it.
pub fn csv_field_offsets(text: &[u8], start: usize, n: usize) -> Vec<usize> {
    let mut out = Vec::with_capacity(n);
    let mut i = start.min(text.len());
    let skip_spaces = |mut i: usize| {
        while i < text.len() && (text[i] == b' ' || text[i] == b'\t') {
            i += 1;
        }
        i
    };
    while out.len() < n {
        i = skip_spaces(i);
        out.push(i);
        let mut quoted = false;
        while i < text.len() {
            match text[i] {
                b'"' => quoted = !quoted,
                b',' if !quoted => break,
                b'\n' | b'\r' if !quoted => return out,
                _ => {}
            }
            i += 1;
        }
        if i >= text.len() {
            break;
        }
        i += 1; // the comma
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_and_column_count_from_one() {
        let text = b"G0 X1\r\nG1 Y\xc3\xa9 Z2\n";
        let d = Diagnostic::at("p.nc", text, 14, "bad");
        assert_eq!((d.line, d.column), (2, 7));
        assert_eq!(d.source_line, "G1 Y\u{e9} Z2");
        assert_eq!(d.to_string(), "p.nc:2:7: bad");
        assert_eq!(
            d.render(),
            "error: bad\n --> p.nc:2:7\n  |\n2 | G1 Y\u{e9} Z2\n  |       ^^"
        );
    }

    #[test]
    fn the_caret_underlines_the_offending_word() {
        let word = |line: &str, column: usize| {
            let d = Diagnostic::at("f", line.as_bytes(), 0, "m");
            let d = Diagnostic { column, ..d };
            line[d.word()].to_string()
        };
        assert_eq!(word("G81 X10 Y10 Z-5", 1), "G81");
        assert_eq!(word("G81 X10 Y10 Z-5", 13), "Z-5");
        assert_eq!(word("G1X10.5Y5", 3), "X10.5");
        assert_eq!(word("G43.4 H1", 1), "G43.4");
        assert_eq!(word("EZQ = [1, 2]", 1), "EZQ");
        assert_eq!(word("EX0C = 2.3", 1), "EX0C");
        assert_eq!(word("50,abc", 4), "abc");
        assert_eq!(word("50,-1.5e3", 4), "-1.5");
        assert_eq!(word("G1 #1", 4), "#");
        assert_eq!(word("chain = [\"A\", \"CC\"]", 15), "\"CC\"");
        assert_eq!(word("ECX = [0.0349]  # yaw", 7), "[0.0349]");
        assert_eq!(word("G0 (retract) X1", 4), "(retract)");
        assert_eq!(word("G1 X#1 Y10", 4), "X#1");
        assert_eq!(word("G1 X#<depth> Y10", 4), "X#<depth>");
        assert_eq!(word("G1 X[#1 + 2] Y1", 4), "X[#1 + 2]");
        assert_eq!(word("G1 X[#1 + 2", 4), "X[#1 + 2");
        assert_eq!(word("(\u{e9}t\u{e9})", 2), "\u{e9}");
        // Past the end of the line: an empty word, never a panic.
        assert_eq!(word("G1", 9), "");
    }

    #[test]
    fn errors_without_a_place_render_as_errors_too() {
        let e = Error::Usage("nothing to do".into());
        assert_eq!(e.render(), "error: nothing to do");
        // Colour only when asked for.
        assert!(!e.render().contains('\x1b'));
        assert!(e.render_styled(true).contains('\x1b'));
    }

    #[test]
    fn field_offsets_respect_quotes() {
        let t = b"1, \"a,b\" ,3\n";
        assert_eq!(csv_field_offsets(t, 0, 3), vec![0, 3, 10]);
        assert_eq!(csv_field_offsets(t, 0, 5), vec![0, 3, 10]);
    }
}
