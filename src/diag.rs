//! Errors that point at a place in an input file.
//!
//! Every message about bad input names the file, the line and the column, and says
//! what was expected, so a user can go straight to the offending byte.

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
}

impl Diagnostic {
    /// A diagnostic at byte `offset` of `text` (the whole file).
    pub fn at(path: &str, text: &[u8], offset: usize, message: impl Into<String>) -> Self {
        let offset = offset.min(text.len());
        let line_start = text[..offset]
            .iter()
            .rposition(|&b| b == b'\n')
            .map_or(0, |i| i + 1);
        let line_end = text[offset..]
            .iter()
            .position(|&b| b == b'\n')
            .map_or(text.len(), |i| offset + i);
        let line = text[..line_start].iter().filter(|&&b| b == b'\n').count() + 1;
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
        }
    }

    /// The diagnostic with the source line and a caret under the column.
    pub fn render(&self) -> String {
        let mut out = self.to_string();
        if !self.source_line.is_empty() {
            let pad: String = self
                .source_line
                .chars()
                .take(self.column.saturating_sub(1))
                .map(|c| if c == '\t' { '\t' } else { ' ' })
                .collect();
            out.push_str(&format!("\n    {}\n    {}^", self.source_line, pad));
        }
        out
    }
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

    /// The message with the source line and a caret, where there is one.
    pub fn render(&self) -> String {
        match self {
            Error::Input(d) => d.render(),
            Error::Inputs(ds) => ds
                .iter()
                .map(Diagnostic::render)
                .collect::<Vec<_>>()
                .join("\n"),
            other => other.to_string(),
        }
    }
}

pub type Result<T, E = Error> = std::result::Result<T, E>;

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
        assert!(d.render().ends_with("\n          ^"));
    }
}
