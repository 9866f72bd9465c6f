//! The NC document layer: `lines` + `parse_line` are lossless, and words carry the right
//! letters, values, decimals and spans.

use std::path::{Path, PathBuf};

use nccomp::nc::{Line, Token, TokenKind, Value, Word, lines, parse_line};
use proptest::prelude::*;

#[path = "common/skip.rs"]
mod skip;

/// Split and tokenize `src`, check that the tokens of each line are contiguous and cover
/// it, that line numbers and offsets are consistent, and emit everything back.
fn reconstruct(src: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(src.len());
    let mut tokens: Vec<Token> = Vec::new();
    for (expected_number, line) in (1..).zip(lines(src)) {
        assert_eq!(line.number, expected_number);
        assert_eq!(line.offset, out.len(), "line {} offset", line.number);
        // `\n` with the `\r`s before it, a `\r` alone, or nothing at the end.
        let crs = line.ending.iter().take_while(|&&b| b == b'\r').count();
        assert!(
            matches!(&line.ending[crs..], b"\n") || matches!(line.ending, b"\r" | b""),
            "{:?}",
            line.ending
        );
        assert!(!line.content.contains(&b'\n') && !line.content.contains(&b'\r'));

        parse_line(line.content, &mut tokens);
        let mut pos = 0;
        for t in &tokens {
            assert_eq!(t.span.start, pos, "gap or overlap in line {}", line.number);
            assert!(
                t.span.end > t.span.start,
                "empty token in line {}",
                line.number
            );
            if let TokenKind::Word(w) = &t.kind {
                assert!(w.letter.is_ascii_uppercase());
                assert!(t.span.start < w.value_span.start || w.value == Value::Missing);
                assert!(w.value_span.start <= w.value_span.end);
                assert!(w.value_span.end <= t.span.end);
            }
            out.extend_from_slice(&line.content[t.span.clone()]);
            pos = t.span.end;
        }
        assert_eq!(pos, line.content.len(), "line {} not covered", line.number);
        out.extend_from_slice(line.ending);
    }
    out
}

fn assert_round_trip(src: &[u8]) {
    assert_eq!(
        reconstruct(src),
        src,
        "round trip of {:?}",
        String::from_utf8_lossy(src)
    );
}

fn tokens(content: &[u8]) -> Vec<Token> {
    let mut out = Vec::new();
    parse_line(content, &mut out);
    out
}

/// The single word of `content`, with its token span.
fn only_word(content: &[u8]) -> (Word, std::ops::Range<usize>) {
    let t = tokens(content);
    assert_eq!(t.len(), 1, "{:?}: {t:?}", String::from_utf8_lossy(content));
    match &t[0].kind {
        TokenKind::Word(w) => (w.clone(), t[0].span.clone()),
        k => panic!("{:?} is {k:?}", String::from_utf8_lossy(content)),
    }
}

// ---------------------------------------------------------------------------------------
// Round trips.

#[test]
fn round_trip_typical_programs() {
    let cases: &[&[u8]] = &[
        // Comments in parentheses and after `;`, N numbers, `%` lines.
        b"%\n(PROGRAM 1) ; setup\nN10 G21 G90 (mm, absolute)\nN20 G0 X0 Y0 ; rapid\n%\n",
        // O numbers and O-word subroutines.
        b"O1234\no100 sub\n  G1 X#1\no100 endsub\no100 call [1] [2]\nM30\n",
        // Block delete.
        b"/N30 G1 X1\n  / G0 Z5\n/2 M1\n",
        // Blank lines, CRLF, LF and mixed endings, no trailing newline.
        b"\n\nG0 X1\r\n\r\nG1 Y2\nG2 Z3\r\nM2",
        b"\r\n",
        b"\n",
        b"G1",
        // Lowercase letters, spaces between a letter and its number, tabs.
        b"g1 x 10.5 y\t-3 z  .25\n\tG0\t\tX1\t\n",
        // Parameters and expressions.
        b"#1 = [#2 + 3]\nG1 X[#1+2] Y#5\n#<_depth> = [#<_depth> - 0.5]\nG1 Z##1 F#[1+2]\n",
        // Unclosed comment, unclosed expression.
        b"G1 X1 (no close\nG1 X[1 + [2\n",
        // Invalid UTF-8, NUL, lone CR, non-ASCII.
        b"G1 X1 \xff\xfe\n\0\0G0\r\rY2\r\n(caf\xc3\xa9) \xe2\x82\xac\n",
        // Checksums and stray bytes.
        b"N3 T0*57\n*=<>]])\n",
        // Empty file.
        b"",
    ];
    for src in cases {
        assert_round_trip(src);
    }
}

#[test]
fn line_endings() {
    let src = b"A\r\nB\nC\r\n\nD";
    let ls: Vec<Line> = lines(src).collect();
    let got: Vec<(usize, usize, &[u8], &[u8])> = ls
        .iter()
        .map(|l| (l.number, l.offset, l.content, l.ending))
        .collect();
    assert_eq!(
        got,
        vec![
            (1, 0, &b"A"[..], &b"\r\n"[..]),
            (2, 3, b"B", b"\n"),
            (3, 5, b"C", b"\r\n"),
            (4, 8, b"", b"\n"),
            (5, 9, b"D", b""),
        ]
    );
    assert_eq!(lines(b"").count(), 0);
    assert_eq!(
        lines(b"X1\n").count(),
        1,
        "no extra empty line after a final newline"
    );
    assert_eq!(lines(b"X1\n\n").count(), 2);
    // A lone `\r` ends a line too (CR-only files), and is the line's ending.
    let l: Vec<Line> = lines(b"X1\rY2").collect();
    assert_eq!(l.len(), 2);
    assert_eq!((l[0].content, l[0].ending), (&b"X1"[..], &b"\r"[..]));
    assert_eq!((l[1].offset, l[1].content), (3, &b"Y2"[..]));
}

// ---------------------------------------------------------------------------------------
// Tokens.

#[test]
fn word_details() {
    /// (source, letter, lowercase, value, decimals, value text)
    type Case = (&'static [u8], u8, bool, f64, u8, &'static [u8]);
    let cases: &[Case] = &[
        (b"X-12.5", b'X', false, -12.5, 1, b"-12.5"),
        (b"x+.5", b'X', true, 0.5, 1, b"+.5"),
        (b"Y 10.", b'Y', false, 10.0, 0, b"10."),
        (b"N0010", b'N', false, 10.0, 0, b"0010"),
        (b"G1", b'G', false, 1.0, 0, b"1"),
        (b"G43.4", b'G', false, 43.4, 1, b"43.4"),
        (b"F1200", b'F', false, 1200.0, 0, b"1200"),
        (b"a\t+007.250", b'A', true, 7.25, 3, b"+007.250"),
        (b"z-.5", b'Z', true, -0.5, 1, b"-.5"),
    ];
    for &(src, letter, lowercase, value, decimals, text) in cases {
        let (w, span) = only_word(src);
        assert_eq!(span, 0..src.len());
        assert_eq!(w.letter, letter);
        assert_eq!(w.lowercase, lowercase);
        assert_eq!(w.value, Value::Number { value, decimals }, "{src:?}");
        assert_eq!(w.number(), Some(value));
        assert_eq!(&src[w.value_span.clone()], text);
        assert_eq!(w.value_span.end, src.len());
    }
}

#[test]
fn word_spans_within_a_line() {
    let line = b"N10 G1 X 10.5 Y-2 F1200 (cut)";
    let words: Vec<(u8, &[u8], &[u8])> = tokens(line)
        .iter()
        .filter_map(|t| match &t.kind {
            TokenKind::Word(w) => {
                Some((w.letter, &line[t.span.clone()], &line[w.value_span.clone()]))
            }
            _ => None,
        })
        .collect();
    assert_eq!(
        words,
        vec![
            (b'N', &b"N10"[..], &b"10"[..]),
            (b'G', b"G1", b"1"),
            (b'X', b"X 10.5", b"10.5"),
            (b'Y', b"Y-2", b"-2"),
            (b'F', b"F1200", b"1200"),
        ]
    );
}

#[test]
fn glued_words() {
    let line = b"G0X1.5Y-2Z.3";
    let t = tokens(line);
    let got: Vec<(u8, f64)> = t
        .iter()
        .map(|t| match &t.kind {
            TokenKind::Word(w) => (w.letter, w.number().unwrap()),
            k => panic!("{k:?}"),
        })
        .collect();
    assert_eq!(
        got,
        vec![(b'G', 0.0), (b'X', 1.5), (b'Y', -2.0), (b'Z', 0.3)]
    );
}

#[test]
fn expression_parameter_missing_values() {
    let line = b"G1 X[#1+2] Y#5 Z";
    let t = tokens(line);
    let values: Vec<(u8, Value, &[u8])> = t
        .iter()
        .filter_map(|t| match &t.kind {
            TokenKind::Word(w) => Some((w.letter, w.value, &line[w.value_span.clone()])),
            _ => None,
        })
        .collect();
    assert_eq!(
        values,
        vec![
            (
                b'G',
                Value::Number {
                    value: 1.0,
                    decimals: 0
                },
                &b"1"[..]
            ),
            (b'X', Value::Expression, b"[#1+2]"),
            (b'Y', Value::Parameter, b"#5"),
            (b'Z', Value::Missing, b""),
        ]
    );
    // A missing value's span is empty, right after the letter; following spaces are a
    // separate Space token.
    let t = tokens(b"X  Y1");
    assert_eq!(t[0].span, 0..1);
    let TokenKind::Word(w) = &t[0].kind else {
        panic!()
    };
    assert_eq!((w.value, w.value_span.clone()), (Value::Missing, 1..1));
    assert_eq!(
        (t[1].kind.clone(), t[1].span.clone()),
        (TokenKind::Space, 1..3)
    );
}

/// `(kind, text)` summary of a line.
fn kinds(line: &[u8]) -> Vec<(&'static str, String)> {
    tokens(line)
        .iter()
        .map(|t| {
            let k = match &t.kind {
                TokenKind::Space => "space",
                TokenKind::Comment => "comment",
                TokenKind::BlockDelete => "block-delete",
                TokenKind::Percent => "percent",
                TokenKind::Word(_) => "word",
                TokenKind::Other => "other",
            };
            (
                k,
                String::from_utf8_lossy(&line[t.span.clone()]).into_owned(),
            )
        })
        .collect()
}

fn k(pairs: &[(&'static str, &str)]) -> Vec<(&'static str, String)> {
    pairs.iter().map(|&(a, b)| (a, b.to_string())).collect()
}

#[test]
fn keywords_are_one_other_token() {
    assert_eq!(
        kinds(b"o100 sub"),
        k(&[("word", "o100"), ("space", " "), ("other", "sub")])
    );
    assert_eq!(
        kinds(b"O100 ENDSUB"),
        k(&[("word", "O100"), ("space", " "), ("other", "ENDSUB")])
    );
    assert_eq!(
        kinds(b"o101 if [#1 GT 2]"),
        k(&[
            ("word", "o101"),
            ("space", " "),
            ("other", "if"),
            ("space", " "),
            ("other", "[#1 GT 2]"),
        ])
    );
    assert_eq!(kinds(b"IF[#1GT2]GOTO5"), k(&[("other", "IF[#1GT2]GOTO5")]));
}

#[test]
fn comments_percent_block_delete() {
    assert_eq!(kinds(b"%"), k(&[("percent", "%")]));
    assert_eq!(
        kinds(b"% (end)"),
        k(&[("percent", "%"), ("space", " "), ("comment", "(end)")])
    );
    assert_eq!(
        kinds(b" /G1 (a)(b);c"),
        k(&[
            ("space", " "),
            ("block-delete", "/"),
            ("word", "G1"),
            ("space", " "),
            ("comment", "(a)"),
            ("comment", "(b)"),
            ("comment", ";c"),
        ])
    );
    // Only the first non-space token can be a block delete.
    assert_eq!(
        kinds(b"G1 / X1"),
        k(&[
            ("word", "G1"),
            ("space", " "),
            ("other", "/"),
            ("space", " "),
            ("word", "X1"),
        ])
    );
    // Unclosed comment runs to the end of the line; a comment closes at the first `)`.
    assert_eq!(
        kinds(b"G0 (open ; X1"),
        k(&[("word", "G0"), ("space", " "), ("comment", "(open ; X1")])
    );
    assert_eq!(kinds(b"(MSG, hello)"), k(&[("comment", "(MSG, hello)")]));
}

#[test]
fn unary_signs_and_function_values() {
    // rs274ngc: a sign not followed by a digit or `.` is unary; functions are values.
    let line = b"G01 X-#<x_max> Y-[1] Z--1 A-.5 B EXISTS[#<b>] C ATAN[1]/[2]";
    let values: Vec<(u8, Value, &[u8])> = tokens(line)
        .iter()
        .filter_map(|t| match &t.kind {
            TokenKind::Word(w) => Some((w.letter, w.value, &line[w.value_span.clone()])),
            _ => None,
        })
        .collect();
    assert_eq!(
        values,
        vec![
            (
                b'G',
                Value::Number {
                    value: 1.0,
                    decimals: 0
                },
                &b"01"[..]
            ),
            (b'X', Value::Parameter, b"-#<x_max>"),
            (b'Y', Value::Expression, b"-[1]"),
            (b'Z', Value::Expression, b"--1"),
            (
                b'A',
                Value::Number {
                    value: -0.5,
                    decimals: 1
                },
                b"-.5"
            ),
            (b'B', Value::Expression, b"EXISTS[#<b>]"),
            (b'C', Value::Expression, b"ATAN[1]/[2]"),
        ]
    );
    // Glued letters are a keyword run, not a word and a function.
    assert_eq!(kinds(b"xsin[30]"), k(&[("other", "xsin[30]")]));
    // LinuxCNC polar words are not letters: Other (a pass must not ignore them).
    assert_eq!(
        kinds(b"G1 @.5 ^90"),
        k(&[
            ("word", "G1"),
            ("space", " "),
            ("other", "@.5"),
            ("space", " "),
            ("other", "^90"),
        ])
    );
}

#[test]
fn parameter_assignment_is_other() {
    assert_eq!(
        kinds(b"#1 = [#2 + 3]"),
        k(&[
            ("other", "#1"),
            ("space", " "),
            ("other", "="),
            ("space", " "),
            ("other", "[#2 + 3]"),
        ])
    );
    assert_eq!(kinds(b"#<x>=5"), k(&[("other", "#<x>=5")]));
}

#[test]
fn absurd_numbers_do_not_panic() {
    let digits = "1".repeat(10_000);
    for src in [
        format!("X{digits}"),
        format!("X.{digits}"),
        format!("X-{digits}.{digits}"),
    ] {
        let (w, _) = only_word(src.as_bytes());
        let Value::Number { value, decimals } = w.value else {
            panic!()
        };
        let text = &src.as_bytes()[w.value_span.clone()];
        let expected: f64 = std::str::from_utf8(text).unwrap().parse().unwrap();
        assert_eq!(value.to_bits(), expected.to_bits());
        assert!(decimals == 0 || decimals == u8::MAX);
    }
}

// ---------------------------------------------------------------------------------------
// Properties.

/// Bytes that make up NC programs, plus some that should not be there.
fn nc_ish_bytes() -> impl Strategy<Value = Vec<u8>> {
    let alphabet: &[u8] =
        b"GXYZABCNOFSMgxyzo0123456789.+-#[]()<>;%/ \t\r\n\r\n=*subIFatn@^\0\xff\xc3";
    prop::collection::vec(prop::sample::select(alphabet.to_vec()), 0..200)
}

proptest! {
    // Integration tests have no lib.rs/main.rs next to them for proptest's regression files.
    #![proptest_config(ProptestConfig {
        cases: 2000,
        failure_persistence: None,
        ..ProptestConfig::default()
    })]

    #[test]
    fn arbitrary_bytes_round_trip(src in prop::collection::vec(any::<u8>(), 0..300)) {
        prop_assert_eq!(reconstruct(&src), src);
    }

    #[test]
    fn nc_like_bytes_round_trip(src in nc_ish_bytes()) {
        prop_assert_eq!(reconstruct(&src), src);
    }

    #[test]
    fn well_formed_words(
        letter in prop::sample::select(b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz".to_vec()),
        x in -1.0e6f64..1.0e6,
        k in 0usize..8,
        plus in any::<bool>(),
        spaces in prop::sample::select(vec!["", " ", "\t", "  \t"]),
        trailing_dot in any::<bool>(),
    ) {
        let mut number = format!("{x:.k$}");
        if plus && !number.starts_with('-') {
            number.insert(0, '+');
        }
        if k == 0 && trailing_dot {
            number.push('.');
        }
        let src = format!("{}{spaces}{number}", letter as char);
        let (w, span) = only_word(src.as_bytes());
        prop_assert_eq!(span, 0..src.len());
        prop_assert_eq!(w.letter, letter.to_ascii_uppercase());
        prop_assert_eq!(w.lowercase, letter.is_ascii_lowercase());
        prop_assert_eq!(&src[w.value_span.clone()], number.as_str());
        let Value::Number { value, decimals } = w.value else {
            return Err(TestCaseError::fail(format!("{src}: {:?}", w.value)));
        };
        prop_assert_eq!(decimals as usize, k);
        let expected: f64 = number.trim_start_matches('+').parse().unwrap();
        prop_assert_eq!(value.to_bits(), expected.to_bits());
        prop_assert!((value - x).abs() <= 0.5 * 10f64.powi(-(k as i32)) + 1e-9 * x.abs());

        // The same word glued to the next one, and followed by a comment.
        let line = format!("{src}Y1 (c)");
        let t = tokens(line.as_bytes());
        prop_assert_eq!(&t[0].span, &(0..src.len()));
        prop_assert!(matches!(&t[1].kind, TokenKind::Word(w) if w.letter == b'Y'));
    }
}

// ---------------------------------------------------------------------------------------
// Real programs.

fn walk(dir: &Path, files: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let path = entry.path();
        match entry.file_type() {
            Ok(t) if t.is_dir() => walk(&path, files),
            Ok(t) if t.is_file() => files.push(path),
            _ => {}
        }
    }
}

#[test]
fn corpus_round_trip() {
    let Some(dir) = skip::corpus() else {
        return;
    };
    let mut files = Vec::new();
    walk(&dir, &mut files);
    files.sort();
    let (mut n_lines, mut n_bytes) = (0usize, 0usize);
    for path in &files {
        let src = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let back = reconstruct(&src);
        assert!(back == src, "{} does not round-trip", path.display());
        n_lines += lines(&src).count();
        n_bytes += src.len();
    }
    println!(
        "corpus: {} files checked ({n_lines} lines, {n_bytes} bytes) under {}",
        files.len(),
        dir.display()
    );
    assert!(!files.is_empty(), "corpus directory is empty");
}
