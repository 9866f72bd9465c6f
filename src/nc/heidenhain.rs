//! The tokens of a Heidenhain TNC conversational line (Klartext), lossless as G-code's.
//!
//! A block is `[/]number statement words… [; comment]`; a block may run on over lines
//! that end in `~` (a cycle's parameters, one a line). The tokens say what each run of
//! bytes is; what a statement means is [`crate::program::heidenhain`]'s to read.
//!
//! # Tokenization choices
//!
//! * `BlockDelete`: `/` before the block number.
//! * The block number is the first `Other` token: the digits that start the line.
//! * `Comment`: `;` to the end of the line, and a whole block whose statement is `*` (a
//!   structure comment such as `* - TOOL: …`). A continued line's `~` after a comment is
//!   part of the comment.
//! * `Word`: an address letter directly followed by a value, as one run of bytes between
//!   spaces: a number `[+-]?(digits[.digits?]|.digits)` (`X+10.5`, `M91`, `R0`), or a Q
//!   parameter `[+-]?Q[LR]?digits` (`A+Q120`, `FQ2`, [`Value::Parameter`]). The value's
//!   span keeps its sign: `X+10.5` is written back signed.
//! * `Other`: every other run of bytes between spaces (`L`, `FMAX`, `SPA90`, `Q200=3`,
//!   `IX+5`, `RL`, `~`), and a quoted string with its spaces (`"T 12"`) as one.

use super::{Token, TokenKind, Value, Word};

/// Cut one line's content into tokens that cover every byte.
pub fn parse_line(content: &[u8], out: &mut Vec<Token>) {
    out.clear();
    let n = content.len();
    let mut i = 0;
    let mut first = true;
    let mut statement = true;
    while i < n {
        let b = content[i];
        let start = i;
        if matches!(b, b' ' | b'\t' | b'\r') {
            while i < n && matches!(content[i], b' ' | b'\t' | b'\r') {
                i += 1;
            }
            out.push(Token {
                kind: TokenKind::Space,
                span: start..i,
            });
            continue;
        }
        if b == b';' || (b == b'*' && statement) {
            out.push(Token {
                kind: TokenKind::Comment,
                span: start..n,
            });
            return;
        }
        if b == b'/' && first {
            out.push(Token {
                kind: TokenKind::BlockDelete,
                span: start..start + 1,
            });
            i += 1;
            first = false;
            continue;
        }
        if b.is_ascii_digit() && (first || is_after_delete(out)) {
            while i < n && content[i].is_ascii_digit() {
                i += 1;
            }
            out.push(Token {
                kind: TokenKind::Other,
                span: start..i,
            });
            first = false;
            continue;
        }
        first = false;
        // A run up to the next space or comment; a quoted string runs to its quote.
        if b == b'"' {
            i += 1;
            while i < n && content[i] != b'"' {
                i += 1;
            }
            i = (i + 1).min(n);
        } else {
            while i < n && !matches!(content[i], b' ' | b'\t' | b'\r' | b';') {
                i += 1;
            }
        }
        statement = false;
        let run = &content[start..i];
        let kind = word(run, start).map_or(TokenKind::Other, TokenKind::Word);
        out.push(Token {
            kind,
            span: start..i,
        });
    }
}

/// The tokens so far are a block delete (and spaces): digits now are the block number.
fn is_after_delete(out: &[Token]) -> bool {
    out.iter().any(|t| t.kind == TokenKind::BlockDelete)
        && out
            .iter()
            .all(|t| matches!(t.kind, TokenKind::BlockDelete | TokenKind::Space))
}

/// `run` (at byte `start` of the line) as a word, when it is one whole.
fn word(run: &[u8], start: usize) -> Option<Word> {
    let (&letter, rest) = run.split_first()?;
    if !letter.is_ascii_uppercase() || rest.is_empty() {
        return None;
    }
    let value_span = start + 1..start + run.len();
    if let Some((len, value)) = super::parse::plain_number_len(rest)
        && len == rest.len()
    {
        return Some(Word {
            letter,
            lowercase: false,
            value,
            value_span,
        });
    }
    if is_q_parameter(rest) {
        return Some(Word {
            letter,
            lowercase: false,
            value: Value::Parameter,
            value_span,
        });
    }
    None
}

/// `[+-]?Q[LR]?digits`.
pub fn is_q_parameter(text: &[u8]) -> bool {
    let t = text
        .strip_prefix(b"+")
        .or_else(|| text.strip_prefix(b"-"))
        .unwrap_or(text);
    let Some(t) = t.strip_prefix(b"Q") else {
        return false;
    };
    let t = t
        .strip_prefix(b"L")
        .or_else(|| t.strip_prefix(b"R"))
        .unwrap_or(t);
    !t.is_empty() && t.iter().all(u8::is_ascii_digit)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn kinds(s: &str) -> Vec<(String, String)> {
        let mut out = Vec::new();
        parse_line(s.as_bytes(), &mut out);
        out.iter()
            .filter(|t| t.kind != TokenKind::Space)
            .map(|t| {
                let text = s[t.span.clone()].to_string();
                let kind = match &t.kind {
                    TokenKind::Word(w) => match w.value {
                        Value::Number { .. } => format!("{}=", w.letter as char),
                        Value::Parameter => format!("{}#", w.letter as char),
                        _ => "?".into(),
                    },
                    TokenKind::Comment => ";".into(),
                    TokenKind::BlockDelete => "/".into(),
                    _ => "o".into(),
                };
                (kind, text)
            })
            .collect()
    }

    #[test]
    fn a_move_block_is_its_number_keyword_and_words() {
        let k = kinds("57 L A+Q120 C+Q122 R0 FMAX M126 ; TURN");
        let texts: Vec<&str> = k.iter().map(|(k, _)| k.as_str()).collect();
        assert_eq!(texts, ["o", "o", "A#", "C#", "R=", "o", "M=", ";"]);
        assert_eq!(k[2].1, "A+Q120");
    }

    #[test]
    fn block_delete_numbers_comments_and_continuations() {
        let k = kinds("/79 M30");
        assert_eq!(k[0].0, "/");
        assert_eq!(k[1], ("o".into(), "79".into()));
        assert_eq!(k[2].0, "M=");
        let k = kinds("36 * - TOOL: T1 | X+10 ; not a word");
        assert_eq!(k.len(), 2);
        assert_eq!(k[1].0, ";");
        let k = kinds("  Q200=3 ;SET-UP CLEARANCE~");
        assert_eq!(k[0], ("o".into(), "Q200=3".into()));
        assert_eq!(k[1].0, ";");
        let k = kinds("37 TOOL CALL \"KW 1\" Z S1003 DL+0");
        assert_eq!(k[3].1, "\"KW 1\"");
        assert_eq!(k[5].0, "S=");
        assert_eq!(k[6].0, "o");
        let k = kinds("12;");
        assert_eq!(k, [("o".into(), "12".into()), (";".into(), ";".into())]);
    }

    proptest::proptest! {
        /// Every byte belongs to one token, in order.
        #[test]
        fn tokens_cover_every_byte(content in proptest::collection::vec(proptest::num::u8::ANY, 0..80)) {
            let mut out = Vec::new();
            parse_line(&content, &mut out);
            let mut pos = 0;
            for t in &out {
                proptest::prop_assert_eq!(t.span.start, pos);
                proptest::prop_assert!(t.span.end > t.span.start);
                pos = t.span.end;
            }
            proptest::prop_assert_eq!(pos, content.len());
        }
    }
}
