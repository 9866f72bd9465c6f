//! The tokens of a Sinumerik 840D line, lossless as G-code's.
//!
//! A block is `[/][N…] words and statements… [; comment]`. The tokens say what each run of
//! bytes is; what a statement means is [`crate::program::sinumerik`]'s to read.
//!
//! # Tokenization choices
//!
//! * `Comment`: `;` to the end of the line (outside a quoted string).
//! * `BlockDelete`: `/` before anything else.
//! * A run of bytes between spaces is one token; a quoted string or a bracket keeps its
//!   spaces in the run (`MSG("A B")`, `CYCLE800(1, "T", 0)`).
//! * `Word`: an address letter and its value, as one run: `X12.5`, `G1`, `N10`, or with
//!   `=`: `X=12.5`, `Z=_Z_HOME` (a variable: [`Value::Parameter`]), `X=R1+2`
//!   ([`Value::Expression`]), `A=DC(90)` (the value's span is what stands in the
//!   brackets, so a rewritten number keeps its `DC(…)`). `A3=`, `B3=`, `C3=` (the tool
//!   vector under TRAORI) are words I, J, K, and `CR=` (an arc's radius) is word R: the
//!   letters the dialect-free reading gives those meanings.
//! * `Other`: every other run (`TRAORI`, `DEF`, `REAL`, `_X_HOME=0`, `R1=5`, `T="DRILL"`,
//!   `CYCLE800()`, `AR=90`, `RPL=30`).

use super::{Token, TokenKind, Value, Word};

/// Cut one line's content into tokens that cover every byte.
pub fn parse_line(content: &[u8], out: &mut Vec<Token>) {
    out.clear();
    let n = content.len();
    let mut i = 0;
    let mut first = true;
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
        if b == b';' {
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
        first = false;
        // A run up to the next space or comment, over quoted strings and brackets.
        let mut depth = 0usize;
        let mut quoted = false;
        while i < n {
            let c = content[i];
            if quoted {
                quoted = c != b'"';
            } else {
                match c {
                    b'"' => quoted = true,
                    b'(' | b'[' => depth += 1,
                    b')' | b']' => depth = depth.saturating_sub(1),
                    b' ' | b'\t' | b'\r' | b';' if depth == 0 => break,
                    _ => {}
                }
            }
            i += 1;
        }
        let run = &content[start..i];
        let kind = word(run, start).map_or(TokenKind::Other, TokenKind::Word);
        out.push(Token {
            kind,
            span: start..i,
        });
    }
}

/// The addresses with `=` whose value `DC(…)`, `ACP(…)` … may wrap.
const WRAPPERS: [&[u8]; 9] = [
    b"DC(", b"ACP(", b"ACN(", b"AC(", b"IC(", b"CAC(", b"CIC(", b"CACP(", b"CACN(",
];

/// `run` (at byte `start` of the line) as a word, when it is one whole.
fn word(run: &[u8], start: usize) -> Option<Word> {
    let (&first, rest) = run.split_first()?;
    if !first.is_ascii_alphabetic() || rest.is_empty() {
        return None;
    }
    let lowercase = first.is_ascii_lowercase();
    let upper = first.to_ascii_uppercase();
    let rest_upper = |k: usize| rest.get(k).map(u8::to_ascii_uppercase);
    // The address's letter and where its value starts in `run`.
    let (letter, value_at) = match (upper, rest[0]) {
        (_, b'=') => (upper, 2),
        (b'A' | b'B' | b'C', b'3') if rest.get(1) == Some(&b'=') => {
            (b"IJK"[(upper - b'A') as usize], 3)
        }
        (b'C', _) if rest_upper(0) == Some(b'R') && rest.get(1) == Some(&b'=') => (b'R', 3),
        (_, c) if c.is_ascii_digit() || matches!(c, b'.' | b'+' | b'-') => {
            let (len, value) = super::parse::plain_number_len(rest)?;
            return (len == rest.len()).then(|| Word {
                letter: upper,
                lowercase,
                value,
                value_span: start + 1..start + run.len(),
            });
        }
        _ => return None,
    };
    let text = &run[value_at..];
    let (value, span) = value(text, start + value_at)?;
    Some(Word {
        letter,
        lowercase,
        value,
        value_span: span,
    })
}

/// What follows an address's `=` (at byte `at` of the line): its value and span.
fn value(text: &[u8], at: usize) -> Option<(Value, std::ops::Range<usize>)> {
    if text.is_empty() {
        return Some((Value::Missing, at..at));
    }
    if text[0] == b'"' {
        return None;
    }
    for w in WRAPPERS {
        if text.len() > w.len() && text[..w.len()].eq_ignore_ascii_case(w) && text.ends_with(b")") {
            let inner = &text[w.len()..text.len() - 1];
            let start = at + w.len();
            return Some((kind(inner), start..start + inner.len()));
        }
    }
    Some((kind(text), at..at + text.len()))
}

/// A value's kind: a number, a variable (`_NAME`, `R12`) or an expression.
fn kind(text: &[u8]) -> Value {
    if let Some((len, value)) = super::parse::plain_number_len(text)
        && len == text.len()
    {
        return value;
    }
    if is_name(text) {
        Value::Parameter
    } else {
        Value::Expression
    }
}

/// `[A-Za-z_][A-Za-z0-9_]*`: a variable's (or an R parameter's) name.
pub fn is_name(text: &[u8]) -> bool {
    text.first()
        .is_some_and(|b| b.is_ascii_alphabetic() || *b == b'_')
        && text.iter().all(|b| b.is_ascii_alphanumeric() || *b == b'_')
}

/// The bytes before a word's value that say how it is read: `DC(`, `IC(` …, or empty.
pub fn wrapper<'a>(content: &'a [u8], w: &Word) -> &'a [u8] {
    let before = &content[..w.value_span.start];
    WRAPPERS
        .iter()
        .find(|p| {
            before.len() >= p.len() && before[before.len() - p.len()..].eq_ignore_ascii_case(p)
        })
        .map_or(&[][..], |p| {
            &before[before.len() - p.len()..before.len() - 1]
        })
}

/// Whether a line is one only Sinumerik writes: a declaration, a Siemens instruction, or an
/// assignment to a named variable (comments and `(…)` brackets aside).
pub fn looks_like(content: &[u8]) -> bool {
    let text = String::from_utf8_lossy(content);
    let body = text
        .trim_start()
        .trim_start_matches('/')
        .trim_start_matches(['N', 'n'])
        .trim_start_matches(|c: char| c.is_ascii_digit())
        .trim_start();
    if body.starts_with("%_N_") || body.starts_with(";%_N_") {
        return true;
    }
    let mut code = String::new();
    let mut depth = 0;
    for c in body.chars().take_while(|&c| c != ';') {
        match c {
            '(' => depth += 1,
            ')' => depth = (depth - 1).max(0),
            _ if depth == 0 => code.push(c),
            _ => {}
        }
    }
    const SINUMERIK: [&str; 21] = [
        "DEF",
        "MSG",
        "TRAORI",
        "TRAFOOF",
        "SUPA",
        "CYCLE800",
        "CYCLE81",
        "CYCLE82",
        "CYCLE83",
        "CYCLE832",
        "WORKPIECE",
        "STOPRE",
        "MCALL",
        "ATRANS",
        "AROT",
        "FNORM",
        "G153",
        "G700",
        "G710",
        "G641",
        "G642",
    ];
    let assigns_named = code.contains("=_") || code.trim_start().starts_with('_');
    let quoted_tool = code.contains("T=\"");
    assigns_named
        || quoted_tool
        || code
            .split(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
            .any(|w| SINUMERIK.contains(&w))
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
                let kind = match &t.kind {
                    TokenKind::Word(w) => format!(
                        "{}{}",
                        w.letter as char,
                        match w.value {
                            Value::Number { .. } => "=",
                            Value::Parameter => "#",
                            Value::Expression => "[",
                            Value::Missing => "?",
                        }
                    ),
                    TokenKind::Comment => ";".into(),
                    TokenKind::BlockDelete => "/".into(),
                    _ => "o".into(),
                };
                let text = match &t.kind {
                    TokenKind::Word(w) => s[w.value_span.clone()].to_string(),
                    _ => s[t.span.clone()].to_string(),
                };
                (kind, text)
            })
            .collect()
    }

    #[test]
    fn words_with_and_without_equals() {
        let k = kinds("N90 SUPA X=_X_HOME Y=0 A=DC(12.5) C=ACP(-90) Z=R1+2 D1 ; home");
        assert_eq!(
            k,
            [
                ("N=".into(), "90".into()),
                ("o".into(), "SUPA".into()),
                ("X#".into(), "_X_HOME".into()),
                ("Y=".into(), "0".into()),
                ("A=".into(), "12.5".into()),
                ("C=".into(), "-90".into()),
                ("Z[".into(), "R1+2".into()),
                ("D=".into(), "1".into()),
                (";".into(), "; home".into()),
            ]
        );
    }

    #[test]
    fn statements_strings_and_vector_words() {
        let k = kinds("N100 T=\"DRILL 8.5\" M6 MSG(\"A; B\") CYCLE800(1,\"TC 1\",0,57)");
        assert_eq!(k[1], ("o".into(), "T=\"DRILL 8.5\"".into()));
        assert_eq!(k[2].0, "M=");
        assert_eq!(k[3], ("o".into(), "MSG(\"A; B\")".into()));
        assert_eq!(k[4], ("o".into(), "CYCLE800(1,\"TC 1\",0,57)".into()));
        let k = kinds("G1 X1 A3=0.5 B3=-.5 C3=0.7071 CR=5 AR=90 R1=5 _V=2 CYCLE81");
        let letters: Vec<&str> = k.iter().map(|(k, _)| k.as_str()).collect();
        assert_eq!(
            letters,
            ["G=", "X=", "I=", "J=", "K=", "R=", "o", "o", "o", "o"]
        );
        let k = kinds("/N10 G0 X=");
        assert_eq!(k[0].0, "/");
        assert_eq!(k[3].0, "X?");
    }

    #[test]
    fn the_wrapper_of_a_word() {
        let s = b"A=ACN(10) B=5 C=dc(1)";
        let mut out = Vec::new();
        parse_line(s, &mut out);
        let w: Vec<&[u8]> = out
            .iter()
            .filter_map(|t| match &t.kind {
                TokenKind::Word(w) => Some(wrapper(s, w)),
                _ => None,
            })
            .collect();
        assert_eq!(w, [&b"ACN"[..], b"", b"dc"]);
    }

    #[test]
    fn sinumerik_lines_are_recognised() {
        assert!(looks_like(b"N10 DEF REAL _X_HOME"));
        assert!(looks_like(b"N30 _X_HOME=0 _Y_HOME=0"));
        assert!(looks_like(b"TRAORI"));
        assert!(looks_like(b"N100 T=\"DRILL 8.5\" M6"));
        assert!(!looks_like(b"N10 G1 X10 (MSG, TRAORI)"));
        assert!(!looks_like(b"G1 X10 Y5"));
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
                if let TokenKind::Word(w) = &t.kind {
                    proptest::prop_assert!(w.value_span.start >= t.span.start && w.value_span.end <= t.span.end);
                }
                pos = t.span.end;
            }
            proptest::prop_assert_eq!(pos, content.len());
        }
    }
}
