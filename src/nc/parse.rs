//! The nom parser for NC lines.
//!
//! Two layers, both lossless:
//!
//! * [`lines`] splits a program into [`Line`]s (content + ending) without allocating; the
//!   newline search is `memchr`.
//! * [`parse_line`] cuts one line's content into [`Token`]s that cover every byte, in order.
//!   It never fails: bytes that are nothing else become [`TokenKind::Other`].
//!
//! # Tokenization choices
//!
//! * `Space`: runs of ` `, `\t` and stray `\r`.
//! * `Comment`: `(` to the first `)` (LinuxCNC forbids nested comments), or to the end of
//!   the line if unclosed; `;` to the end of the line.
//! * `BlockDelete`: `/` when it is the first token of the line that is not `Space`,
//!   together with one directly following digit `1`–`9` (Fanuc's `/2` block-skip levels).
//!   A `/` anywhere else is `Other`.
//! * `Percent`: every `%` byte (outside comments and brackets).
//! * `Word`: an ASCII letter followed, after optional spaces/tabs, by a value: a number
//!   `[+-]?(digits[.digits?]|.digits)` ([`Value::Number`]), an expression `[...]` (nested
//!   brackets, to the end of the line if unclosed), a function call such as `SIN[30]`
//!   or `EXISTS[#<x>]` ([`Value::Expression`]), or a parameter (`#` repeated, then digits,
//!   `<name>` or `[...]`: [`Value::Parameter`]). As in rs274ngc, a `+`/`-` that is not
//!   followed by a digit or `.` is a unary operator in front of a value: `X-#<x_max>` is a
//!   parameter value, `X-[1]` and `X--1` are expressions. When no value follows, the
//!   word is just the letter with [`Value::Missing`], and the spaces after it are a
//!   separate `Space` token.
//! * Keywords: a letter *immediately* followed by another letter starts a run of letters
//!   that is one `Other` token (`sub`, `endsub`, `call`, `while`, `if`, `GOTO`, `DO`,
//!   `MSG`...). So `o100 sub` is `Word(O100)`, `Space`, `Other("sub")`, and `XY10` is
//!   `Other("XY10")` (digits glued to an `Other` run merge into it), never two words.
//!   A letter followed by spaces and then a letter is a `Missing` word (`X Y1`).
//! * `Other`: everything else. A standalone `[...]`, parameter reference (`#1`, `##2`,
//!   `#<name>`, `#[..]`) or `<name>` (as in `o<name> call`) is taken as a unit so that the
//!   letters inside never become words; consecutive `Other` pieces are merged into one
//!   token (`#1=5` is one token). LinuxCNC's polar words `@` (radius) and `^` (angle)
//!   are not letters, so `G1 @.5 ^90` has `Other` tokens `@.5` and `^90`: a pass must not
//!   assume that a line whose `Other` tokens it ignores has no motion.

use nom::branch::alt;
use nom::bytes::complete::{take_until, take_while, take_while1};
use nom::character::complete::{char, digit0, digit1, one_of, satisfy};
use nom::combinator::{consumed, not, opt, peek, recognize, rest, verify};
use nom::multi::{many0_count, many1_count};
use nom::sequence::{preceded, terminated};
use nom::{IResult, Parser};

use super::{Line, Token, TokenKind, Value, Word};

/// Parser result over bytes; the error carries nothing (every failure has a fallback).
type PResult<'a, O> = IResult<&'a [u8], O, ()>;

/// Split a program into lines. Every byte of `src` belongs to exactly one line's content
/// or ending: `\n` ends a line, with the `\r`s just before it (`\r\n`, and `\r\r\n` from
/// a file converted twice), and so does a `\r` alone (old Macintosh files, some TNC
/// transfers). The last line may have no ending, an empty input has no lines and a final
/// ending does not start an extra empty line. [`line_ends`] counts the same endings.
pub fn lines(src: &[u8]) -> impl Iterator<Item = Line<'_>> {
    Lines {
        src,
        pos: 0,
        number: 0,
        lone: 0,
    }
}

/// Counts line endings as [`lines`] cuts them, over a text fed in pieces (a `\r\n` may be
/// split between two).
#[derive(Debug, Clone, Copy, Default)]
pub struct LineEnds {
    ends: usize,
    /// `\r`s at the end of the text fed so far: line ends unless a `\n` follows them.
    pending: usize,
}

impl LineEnds {
    /// Count the endings in the next piece of the text.
    pub fn feed(&mut self, buf: &[u8]) {
        let mut i = 0;
        while i < buf.len() {
            let Some(k) = memchr::memchr2(b'\n', b'\r', &buf[i..]) else {
                if self.pending > 0 && i == 0 {
                    // The `\r`s before ended lines alone.
                    self.ends += self.pending;
                    self.pending = 0;
                }
                return;
            };
            let at = i + k;
            if self.pending > 0 && at > i {
                self.ends += self.pending;
                self.pending = 0;
            }
            if buf[at] == b'\n' {
                self.ends += 1;
                self.pending = 0;
                i = at + 1;
                continue;
            }
            let run = buf[at..].iter().take_while(|&&b| b == b'\r').count();
            match buf.get(at + run) {
                // `\r…\r\n`: one ending.
                Some(b'\n') => {
                    self.ends += 1;
                    self.pending = 0;
                    i = at + run + 1;
                }
                // Each `\r` alone.
                Some(_) => {
                    self.ends += self.pending + run;
                    self.pending = 0;
                    i = at + run;
                }
                // Undecided until the next piece.
                None => {
                    self.pending += run;
                    return;
                }
            }
        }
    }

    /// The endings counted, a text's final `\r`s included.
    pub fn finish(self) -> usize {
        self.ends + self.pending
    }
}

/// The number of line endings in `bytes` as [`lines`] cuts them (`\r`s at the very end
/// count: the caller knows whether a `\n` may follow).
pub fn line_ends(bytes: &[u8]) -> usize {
    let mut count = LineEnds::default();
    count.feed(bytes);
    count.finish()
}

/// The length of the run of whole lines at the start of `buf`, a part of a longer text: up
/// to and with its last line ending, where `\r`s at the very end are not taken (a `\n` may
/// come next and end the line with them).
pub fn whole_lines(buf: &[u8]) -> usize {
    let trailing = buf.iter().rev().take_while(|&&b| b == b'\r').count();
    // The last `\n` or `\r` before them ends a line: a `\r` there is followed by a byte
    // that is neither.
    memchr::memrchr2(b'\n', b'\r', &buf[..buf.len() - trailing]).map_or(0, |i| i + 1)
}

/// The line of `text` that holds byte `offset`: its number (from 1), where it starts and
/// where its content ends (an offset at the end of the text is on the line after a final
/// ending).
pub fn line_at(text: &[u8], offset: usize) -> (usize, usize, usize) {
    let mut start = 0;
    let mut number = 1;
    for line in lines(text) {
        let end = line.offset + line.content.len() + line.ending.len();
        if end <= offset && !line.ending.is_empty() {
            number += 1;
            start = end;
            continue;
        }
        return (number, start, line.offset + line.content.len());
    }
    (number, start, text.len())
}

/// Iterator behind [`lines`].
struct Lines<'a> {
    src: &'a [u8],
    pos: usize,
    number: usize,
    /// The `\r`s before this offset are known to end lines alone (a long run of them is
    /// looked through once, not once a line).
    lone: usize,
}

impl<'a> Iterator for Lines<'a> {
    type Item = Line<'a>;

    #[inline]
    fn next(&mut self) -> Option<Line<'a>> {
        let offset = self.pos;
        let rest = self.src.get(offset..).filter(|r| !r.is_empty())?;
        self.number += 1;
        let (content, ending) = match memchr::memchr2(b'\n', b'\r', rest) {
            Some(cr) if rest[cr] == b'\r' && offset + cr >= self.lone => {
                let run = rest[cr..].iter().take_while(|&&b| b == b'\r').count();
                if rest.get(cr + run) == Some(&b'\n') {
                    // CR LF (or CR CR LF).
                    self.pos = offset + cr + run + 1;
                    (&rest[..cr], &rest[cr..=cr + run])
                } else {
                    // A CR alone, and the others of its run after it.
                    self.lone = offset + cr + run;
                    self.pos = offset + cr + 1;
                    (&rest[..cr], &rest[cr..=cr])
                }
            }
            // LF, or a CR known to stand alone.
            Some(end) => {
                self.pos = offset + end + 1;
                (&rest[..end], &rest[end..=end])
            }
            None => {
                self.pos = self.src.len();
                (rest, &rest[rest.len()..])
            }
        };
        Some(Line {
            number: self.number,
            offset,
            content,
            ending,
        })
    }
}

impl std::iter::FusedIterator for Lines<'_> {}

/// Tokenize one line's content into `out` (cleared first). Never fails and never panics:
/// bytes that are nothing else become [`TokenKind::Other`]. The tokens are contiguous and
/// cover `content` exactly, so concatenating `content[token.span]` gives the line back.
pub fn parse_line(content: &[u8], out: &mut Vec<Token>) {
    tokenize::<true>(content, out);
}

/// [`parse_line`]; `FAST`: words of the usual shape ([`plain_word`]) and single spaces are
/// taken at once (without it, every token takes the general way, which the tests compare
/// it with).
fn tokenize<const FAST: bool>(content: &[u8], out: &mut Vec<Token>) {
    out.clear();
    let mut start = 0;
    let mut block_start = true;
    while start < content.len() {
        if FAST {
            if let Some((end, word)) = plain_word(content, start) {
                out.push(Token {
                    kind: TokenKind::Word(word),
                    span: start..end,
                });
                block_start = false;
                start = end;
                continue;
            }
            // The single space between words.
            if content[start] == b' ' && !content.get(start + 1).is_some_and(|&b| is_space(b)) {
                out.push(Token {
                    kind: TokenKind::Space,
                    span: start..start + 1,
                });
                start += 1;
                continue;
            }
        }
        let input = &content[start..];
        let (len, kind) = token(input, block_start);
        // Every branch consumes at least one byte; guard anyway so that a bug can never
        // turn into an endless loop or an out-of-range span.
        let len = len.clamp(1, input.len());
        let end = start + len;
        match kind {
            TokenKind::Space => {}
            TokenKind::Other => {
                block_start = false;
                if let Some(last) = out.last_mut()
                    && last.kind == TokenKind::Other
                {
                    last.span.end = end;
                    start = end;
                    continue;
                }
            }
            _ => block_start = false,
        }
        let kind = match kind {
            TokenKind::Word(mut w) => {
                w.value_span = start + w.value_span.start..start + w.value_span.end;
                TokenKind::Word(w)
            }
            k => k,
        };
        out.push(Token {
            kind,
            span: start..end,
        });
        start = end;
    }
}

/// One token at the start of `i` (not empty): its length and kind. A word's `value_span`
/// is relative to the start of `i`.
#[inline]
fn token(i: &[u8], block_start: bool) -> (usize, TokenKind) {
    let Some(&first) = i.first() else {
        return (0, TokenKind::Other);
    };
    let taken = |r: &[u8]| i.len() - r.len();
    match first {
        b' ' | b'\t' | b'\r' => (
            1 + i[1..].iter().take_while(|&&b| is_space(b)).count(),
            TokenKind::Space,
        ),
        b'(' | b';' => (taken(comment(i)), TokenKind::Comment),
        b'%' => (1, TokenKind::Percent),
        b'/' if block_start => (taken(block_delete(i)), TokenKind::BlockDelete),
        b if b.is_ascii_alphabetic() => {
            if i.get(1).is_some_and(u8::is_ascii_alphabetic) {
                (taken(keyword(i)), TokenKind::Other)
            } else {
                word(i)
            }
        }
        b'#' => (unit(parameter, i), TokenKind::Other),
        b'[' => (unit(expression, i), TokenKind::Other),
        b'<' => (unit(angle_name, i), TokenKind::Other),
        _ => (unit(plain_other, i), TokenKind::Other),
    }
}

/// Length taken by `p` at the start of `i`, or 1 (a single stray byte) if it fails.
#[inline]
fn unit<'a, O>(mut p: impl Parser<&'a [u8], Output = O, Error = ()>, i: &'a [u8]) -> usize {
    match p.parse(i) {
        Ok((r, _)) => i.len() - r.len(),
        Err(_) => 1,
    }
}

/// The rest of `i` after a parser that cannot fail on this input (or `i[1..]` if it does).
#[inline]
fn after<'a, O>(r: PResult<'a, O>, i: &'a [u8]) -> &'a [u8] {
    match r {
        Ok((r, _)) => r,
        Err(_) => i.get(1..).unwrap_or_default(),
    }
}

fn is_space(b: u8) -> bool {
    b == b' ' || b == b'\t' || b == b'\r'
}

/// `( ... )`, closing at the first `)` or running to the end of the line; `;` to the end.
fn comment(i: &[u8]) -> &[u8] {
    let paren = recognize(preceded(
        char('('),
        alt((terminated(take_until(&b")"[..]), char(')')), rest)),
    ));
    let semicolon = recognize(preceded(char(';'), rest));
    after(alt((paren, semicolon)).parse(i), i)
}

/// `/` with an optional block-skip level `1`–`9`.
fn block_delete(i: &[u8]) -> &[u8] {
    after(
        recognize(preceded(char('/'), opt(one_of("123456789")))).parse(i),
        i,
    )
}

/// A run of letters (a keyword such as `sub` or `while`).
fn keyword(i: &[u8]) -> &[u8] {
    after(take_while1(|b: u8| b.is_ascii_alphabetic()).parse(i), i)
}

/// Bytes that start nothing else; a run of them is one `Other` piece.
fn plain_other(i: &[u8]) -> PResult<'_, &[u8]> {
    take_while1(|b: u8| {
        !(b.is_ascii_alphabetic()
            || is_space(b)
            || matches!(b, b'(' | b';' | b'%' | b'#' | b'[' | b'<'))
    })
    .parse(i)
}

/// A word: the letter, optional spaces/tabs and a value, or the bare letter
/// ([`Value::Missing`]). `i[0]` is an ASCII letter.
fn word(i: &[u8]) -> (usize, TokenKind) {
    let letter = i[0];
    let after_letter = &i[1..];
    let (value_input, _) =
        match take_while::<_, _, ()>(|b: u8| b == b' ' || b == b'\t').parse(after_letter) {
            Ok(ok) => ok,
            Err(_) => (after_letter, &after_letter[..0]),
        };
    let value_start = i.len() - value_input.len();
    let parsed = match plain_number(value_input) {
        Some((n, value)) => Ok((&value_input[n..], value)),
        None => value(value_input),
    };
    let (len, value, value_span) = match parsed {
        Ok((r, value)) => {
            let end = i.len() - r.len();
            (end, value, value_start..end)
        }
        Err(_) => (1, Value::Missing, 1..1),
    };
    let word = Word {
        letter: letter.to_ascii_uppercase(),
        lowercase: letter.is_ascii_lowercase(),
        value,
        value_span,
    };
    (len, TokenKind::Word(word))
}

/// A word's value: a number, an expression or a parameter, as rs274ngc's
/// `read_real_value` reads it: a `+`/`-` not followed by a digit or `.` is a unary
/// operator in front of another value (`X-#<x_max>`, `X-[1+2]`, `X--1`), and a function
/// call (two or more letters and `[...]`, `ATAN[..]/[..]`) is an expression.
///
/// The kind is that of the value after the unary signs, except that a signed number
/// (`--1`) is an [`Value::Expression`]: it is not a literal as written.
fn value(i: &[u8]) -> PResult<'_, Value> {
    let unary_sign = terminated(
        one_of("+-"),
        peek(not(satisfy(|c: char| c.is_ascii_digit() || c == '.'))),
    );
    let (r, signs) = many0_count(unary_sign).parse(i)?;
    let (r, value) = alt((
        number,
        expression.map(|_| Value::Expression),
        parameter.map(|_| Value::Parameter),
        function.map(|_| Value::Expression),
    ))
    .parse(r)?;
    let value = match value {
        Value::Number { .. } if signs > 0 => Value::Expression,
        v => v,
    };
    Ok((r, value))
}

/// A function call as a value: `SIN[30]`, `exists[#<x>]`, `ATAN[1]/[2]`.
fn function(i: &[u8]) -> PResult<'_, &[u8]> {
    let (r, name) = verify(
        take_while1(|b: u8| b.is_ascii_alphabetic()),
        |n: &[u8]| n.len() >= 2,
    )
    .parse(i)?;
    let (r, _) = expression(r)?;
    let r = if name.eq_ignore_ascii_case(b"atan") {
        after(opt((char('/'), expression)).parse(r), r)
    } else {
        r
    };
    let n = i.len() - r.len();
    Ok((r, &i[..n]))
}

/// The usual word, a letter glued to a plain number that [`plain_decimal`] reads (`X-12.5`,
/// `g1`, `N0010`), at `start` of `content`, in one pass over its bytes: its end and the
/// word, as the general way ([`token`], [`word`], [`to_f64`]) makes it. `None` for anything
/// else, left to the general way.
#[inline]
fn plain_word(content: &[u8], start: usize) -> Option<(usize, Word)> {
    const POW10: [f64; 23] = [
        1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
        1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
    ];
    let letter = *content.get(start)?;
    if !letter.is_ascii_alphabetic() {
        return None;
    }
    let value_start = start + 1;
    let mut pos = value_start;
    let negative = match content.get(pos) {
        Some(b'-') => true,
        Some(b'+') => false,
        _ => {
            pos -= 1;
            false
        }
    };
    pos += 1;
    // Up to 15 digits (below 10^15 < 2^53, so exact); longer numbers take the general way.
    let mut mantissa: u64 = 0;
    let mut digits = |pos: &mut usize| {
        let mut n = 0;
        for &b in &content[*pos..] {
            let d = b.wrapping_sub(b'0');
            if d > 9 {
                break;
            }
            mantissa = mantissa.wrapping_mul(10).wrapping_add(u64::from(d));
            n += 1;
        }
        *pos += n;
        n
    };
    let whole = digits(&mut pos);
    let mut frac = 0;
    if content.get(pos) == Some(&b'.') {
        pos += 1;
        frac = digits(&mut pos);
        if whole == 0 && frac == 0 {
            return None;
        }
    } else if whole == 0 {
        return None;
    }
    if whole + frac > 15 {
        return None;
    }
    let value = mantissa as f64 / POW10.get(frac)?;
    let word = Word {
        letter: letter.to_ascii_uppercase(),
        lowercase: letter.is_ascii_lowercase(),
        value: Value::Number {
            value: if negative { -value } else { value },
            decimals: frac as u8,
        },
        value_span: value_start..pos,
    };
    Some((pos, word))
}

/// What [`value`] reads from a plain number (`[+-]?(digits[.digits?]|.digits)`, the usual
/// case), without the parser combinators: its length and value. `None` for anything else,
/// left to [`value`].
#[inline]
pub(super) fn plain_number_len(i: &[u8]) -> Option<(usize, Value)> {
    plain_number(i)
}

#[inline]
fn plain_number(i: &[u8]) -> Option<(usize, Value)> {
    let digits = |from: usize| {
        i.get(from..)
            .map_or(0, |r| r.iter().take_while(|b| b.is_ascii_digit()).count())
    };
    let mut n = usize::from(matches!(i.first(), Some(b'+' | b'-')));
    let whole = digits(n);
    n += whole;
    let frac = if i.get(n) == Some(&b'.') {
        let frac = digits(n + 1);
        if whole == 0 && frac == 0 {
            return None;
        }
        n += 1 + frac;
        frac
    } else if whole == 0 {
        return None;
    } else {
        0
    };
    let value = Value::Number {
        value: to_f64(&i[..n]),
        decimals: u8::try_from(frac).unwrap_or(u8::MAX),
    };
    Some((n, value))
}

/// `[+-]?(digits[.digits?]|.digits)`, as [`Value::Number`].
fn number(i: &[u8]) -> PResult<'_, Value> {
    let (r, (text, frac)) = consumed(preceded(
        opt(one_of("+-")),
        alt((
            (digit1, opt(preceded(char('.'), digit0)))
                .map(|(_, frac): (&[u8], Option<&[u8]>)| frac.map_or(0, <[u8]>::len)),
            preceded(char('.'), digit1).map(<[u8]>::len),
        )),
    ))
    .parse(i)?;
    let decimals = u8::try_from(frac).unwrap_or(u8::MAX);
    Ok((
        r,
        Value::Number {
            value: to_f64(text),
            decimals,
        },
    ))
}

/// The number text as `str::parse::<f64>` reads it (without a leading `+`).
pub(crate) fn to_f64(text: &[u8]) -> f64 {
    if let Some(v) = plain_decimal(text) {
        return v;
    }
    let text = text.strip_prefix(b"+").unwrap_or(text);
    std::str::from_utf8(text)
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(f64::NAN)
}

/// A number of at most 2^53 in units of its last digit and at most 22 decimals, exactly as
/// `str::parse` reads it, without its generality: both the digits (as an integer) and the
/// power of ten are exact in an f64, so their quotient is the correctly rounded value
/// (Clinger's fast path). `None` for anything else. `text` is `[+-]?digits[.digits]`.
#[inline]
fn plain_decimal(text: &[u8]) -> Option<f64> {
    const POW10: [f64; 23] = [
        1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
        1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
    ];
    let (negative, digits) = match text.first()? {
        b'-' => (true, &text[1..]),
        b'+' => (false, &text[1..]),
        _ => (false, text),
    };
    let mut mantissa: u64 = 0;
    let mut decimals = None;
    for (i, &b) in digits.iter().enumerate() {
        match b {
            b'0'..=b'9' => {
                mantissa = mantissa * 10 + u64::from(b - b'0');
                if mantissa > 1 << 53 {
                    return None;
                }
            }
            b'.' if decimals.is_none() => decimals = Some(digits.len() - i - 1),
            _ => return None,
        }
    }
    let value = mantissa as f64 / *POW10.get(decimals.unwrap_or(0))?;
    Some(if negative { -value } else { value })
}

/// `[ ... ]` with nested brackets, to the matching `]` or to the end of the line.
fn expression(i: &[u8]) -> PResult<'_, &[u8]> {
    let (mut r, _) = char('[').parse(i)?;
    let mut depth = 1usize;
    while depth > 0 {
        let (r2, _) = take_while(|b: u8| b != b'[' && b != b']').parse(r)?;
        match r2.first() {
            Some(b'[') => depth += 1,
            Some(_) => depth -= 1,
            None => {
                r = r2;
                break;
            }
        }
        r = &r2[1..];
    }
    let n = i.len() - r.len();
    Ok((r, &i[..n]))
}

/// `<name>` (closed).
fn angle_name(i: &[u8]) -> PResult<'_, &[u8]> {
    recognize((char('<'), take_until(&b">"[..]), char('>'))).parse(i)
}

/// A parameter reference: one or more `#`, then digits, `<name>` or `[...]`
/// (`#5`, `#<_x>`, `##1`, `#[1+2]`).
fn parameter(i: &[u8]) -> PResult<'_, &[u8]> {
    recognize((
        many1_count(char('#')),
        alt((digit1, angle_name, expression)),
    ))
    .parse(i)
}

#[cfg(test)]
mod tests {
    use super::*;

    proptest::proptest! {
        /// The endings counted, whole or in pieces, are the endings `lines` cuts; the
        /// lines cover the text.
        #[test]
        fn line_ends_are_the_endings_lines_cuts(
            bytes in proptest::collection::vec(proptest::sample::select(b"ab\r\n".to_vec()), 0..80),
            cut in 0usize..80,
        ) {
            let all: Vec<_> = lines(&bytes).collect();
            let ends = all.iter().filter(|l| !l.ending.is_empty()).count();
            proptest::prop_assert_eq!(line_ends(&bytes), ends);
            let cut = cut.min(bytes.len());
            let mut count = LineEnds::default();
            count.feed(&bytes[..cut]);
            count.feed(&bytes[cut..]);
            proptest::prop_assert_eq!(count.finish(), ends);
            let joined: Vec<u8> = all.iter().flat_map(|l| [l.content, l.ending].concat()).collect();
            proptest::prop_assert_eq!(joined, bytes.clone());
            for l in &all {
                proptest::prop_assert!(!l.content.contains(&b'\r') && !l.content.contains(&b'\n'));
            }
        }

        #[test]
        fn plain_decimals_read_as_std_reads_them(
            int in "[+-]?[0-9]{0,17}",
            frac in proptest::option::of("[0-9]{0,24}"),
        ) {
            let text = match &frac {
                Some(f) => format!("{int}.{f}"),
                None => int.clone(),
            };
            let digits = text.trim_start_matches(['+', '-']);
            proptest::prop_assume!(digits.bytes().any(|b| b.is_ascii_digit()));
            let std: f64 = text.trim_start_matches('+').parse().unwrap();
            let ours = to_f64(text.as_bytes());
            proptest::prop_assert_eq!(ours.to_bits(), std.to_bits(), "{}", text);
        }
    }

    /// Tokens with their numbers' bits (`-0.0` is not `0.0` here).
    fn exactly(tokens: &[Token]) -> Vec<String> {
        tokens.iter().map(|t| format!("{t:?}")).collect()
    }

    proptest::proptest! {
        #[test]
        fn the_fast_path_reads_as_the_general_way(
            line in proptest::collection::vec(
                proptest::prop_oneof![
                    // Words as programs write them, with odd and huge numbers.
                    "[XYZABCGNFxyzg][-+]?[0-9]{0,20}(\\.[0-9]{0,25})?",
                    "[XYZ] ?[-+]?[0-9]{1,4}\\.?[0-9]{0,4}",
                    // Anything else a line may hold.
                    "[-+.0-9a-zA-Z #<>\\[\\]();/%=\t\r@^]{1,6}",
                    "\\PC{1,3}",
                ],
                0..10,
            ),
        ) {
            let line = line.concat();
            let (mut fast, mut general) = (Vec::new(), Vec::new());
            tokenize::<true>(line.as_bytes(), &mut fast);
            tokenize::<false>(line.as_bytes(), &mut general);
            proptest::prop_assert_eq!(exactly(&fast), exactly(&general), "{:?}", line);
        }
    }

    proptest::proptest! {
        #[test]
        fn plain_numbers_read_as_the_parser_reads_them(text in "[-+.0-9]{0,6}[-+.0-9#\\[a-z ]{0,4}") {
            let fast = plain_number(text.as_bytes()).map(|(n, v)| (n, format!("{v:?}")));
            let slow = value(text.as_bytes()).ok().and_then(|(r, v)| {
                matches!(v, Value::Number { .. }).then(|| (text.len() - r.len(), format!("{v:?}")))
            });
            proptest::prop_assert_eq!(fast, slow, "{}", text);
        }
    }

    #[test]
    fn plain_decimal_edges() {
        for text in [
            "-0",
            "0.",
            ".5",
            "-.5",
            "9007199254740992",
            "9007199254740993",
            "1.0000000000000000000001",
            "123.4567",
            "-0.0000",
        ] {
            let std: f64 = text.parse().unwrap();
            assert_eq!(to_f64(text.as_bytes()).to_bits(), std.to_bits(), "{text}");
        }
    }

    fn toks(s: &[u8]) -> Vec<Token> {
        let mut out = Vec::new();
        parse_line(s, &mut out);
        out
    }

    /// `(kind tag, text)` pairs, for compact assertions.
    fn show(s: &[u8]) -> Vec<(String, String)> {
        toks(s)
            .into_iter()
            .map(|t| {
                let tag = match &t.kind {
                    TokenKind::Space => "S".to_string(),
                    TokenKind::Comment => "C".to_string(),
                    TokenKind::BlockDelete => "/".to_string(),
                    TokenKind::Percent => "%".to_string(),
                    TokenKind::Other => "O".to_string(),
                    TokenKind::Word(w) => match w.value {
                        Value::Number { .. } => format!("W{}", w.letter as char),
                        Value::Expression => format!("E{}", w.letter as char),
                        Value::Parameter => format!("P{}", w.letter as char),
                        Value::Missing => format!("M{}", w.letter as char),
                    },
                };
                (tag, String::from_utf8_lossy(&s[t.span]).into_owned())
            })
            .collect()
    }

    fn v(pairs: &[(&str, &str)]) -> Vec<(String, String)> {
        pairs
            .iter()
            .map(|(a, b)| (a.to_string(), b.to_string()))
            .collect()
    }

    /// Byte-exact reconstruction: emit each token's source bytes, then the ending.
    fn reconstruct(src: &[u8]) -> Vec<u8> {
        let mut out = Vec::with_capacity(src.len());
        let mut tokens = Vec::new();
        for line in lines(src) {
            parse_line(line.content, &mut tokens);
            let mut pos = 0;
            for t in &tokens {
                assert_eq!(t.span.start, pos, "gap or overlap in {:?}", line.content);
                out.extend_from_slice(&line.content[t.span.clone()]);
                pos = t.span.end;
            }
            assert_eq!(pos, line.content.len());
            out.extend_from_slice(line.ending);
        }
        out
    }

    #[test]
    fn reconstructs_byte_for_byte() {
        let src: &[u8] = b"%\r\n(header) ; note\nN10 G1 X 10.5 y-.5 F1200\r\n/ o100 sub\n\n\
              \t#1 = [#2 + 3]\nG1 X[#1+2] Y#5 (unclosed\n\xff\xfe Z1\0\r\rX";
        assert_eq!(reconstruct(src), src);
    }

    #[test]
    fn line_splitting() {
        let ls: Vec<_> = lines(b"a\r\nb\n\nc").collect();
        assert_eq!(ls.len(), 4);
        assert_eq!(
            (ls[0].number, ls[0].offset, ls[0].content, ls[0].ending),
            (1, 0, &b"a"[..], &b"\r\n"[..])
        );
        assert_eq!(
            (ls[1].offset, ls[1].content, ls[1].ending),
            (3, &b"b"[..], &b"\n"[..])
        );
        assert_eq!(
            (ls[2].offset, ls[2].content, ls[2].ending),
            (5, &b""[..], &b"\n"[..])
        );
        assert_eq!(
            (ls[3].number, ls[3].content, ls[3].ending),
            (4, &b"c"[..], &b""[..])
        );
        assert_eq!(lines(b"").count(), 0);
        assert_eq!(lines(b"\n").count(), 1);
        assert_eq!(lines(b"x\n").count(), 1);
        let cr: Vec<_> = lines(b"\r\n\r").collect();
        assert_eq!(cr.len(), 2);
        assert_eq!((cr[0].content, cr[0].ending), (&b""[..], &b"\r\n"[..]));
        assert_eq!((cr[1].content, cr[1].ending), (&b""[..], &b"\r"[..]));
        // A carriage return alone ends a line, wherever it stands.
        let cr: Vec<_> = lines(b"a\rb\r\r\nc\r").collect();
        let cut: Vec<_> = cr.iter().map(|l| (l.number, l.content, l.ending)).collect();
        assert_eq!(
            cut,
            [
                (1, &b"a"[..], &b"\r"[..]),
                (2, &b"b"[..], &b"\r\r\n"[..]),
                (3, &b"c"[..], &b"\r"[..]),
            ]
        );
        // A run of CRs alone: a line each, looked through once.
        let long = [b'\r'; 100_000];
        assert_eq!(lines(&long).count(), 100_000);
        assert_eq!(line_ends(&long), 100_000);
        assert_eq!(whole_lines(b"a\rb\r"), 2);
        assert_eq!(whole_lines(b"a\r\nb\r"), 3);
        assert_eq!(whole_lines(b"a\rb"), 2);
        assert_eq!(whole_lines(b"a\r\rb\r\r"), 3);
        assert_eq!(whole_lines(b"ab"), 0);
        assert_eq!(line_at(b"a\r\r\nb\rc", 5), (2, 4, 5));
        assert_eq!(line_at(b"a\r\r\nb\rc", 2), (1, 0, 1));
        assert_eq!(line_at(b"a\n", 2), (2, 2, 2));
    }

    #[test]
    fn words_and_spaces() {
        assert_eq!(
            show(b"N10 g1 X 10.5"),
            v(&[
                ("WN", "N10"),
                ("S", " "),
                ("WG", "g1"),
                ("S", " "),
                ("WX", "X 10.5"),
            ])
        );
    }

    #[test]
    fn word_value_span_and_decimals() {
        let t = toks(b"G1 X -12.50");
        let TokenKind::Word(w) = &t[2].kind else {
            panic!("{t:?}")
        };
        assert_eq!(t[2].span, 3..11);
        assert_eq!(w.value_span, 5..11);
        assert_eq!(
            w.value,
            Value::Number {
                value: -12.5,
                decimals: 2
            }
        );
    }

    #[test]
    fn missing_values() {
        assert_eq!(
            show(b"X Y1 Z"),
            v(&[
                ("MX", "X"),
                ("S", " "),
                ("WY", "Y1"),
                ("S", " "),
                ("MZ", "Z")
            ])
        );
        let t = toks(b"X  ");
        let TokenKind::Word(w) = &t[0].kind else {
            panic!()
        };
        assert_eq!((t[0].span.clone(), w.value_span.clone()), (0..1, 1..1));
        assert_eq!(t[1].span, 1..3);
        assert_eq!(show(b"X-"), v(&[("MX", "X"), ("O", "-")]));
        assert_eq!(show(b"X#"), v(&[("MX", "X"), ("O", "#")]));
        assert_eq!(show(b"X."), v(&[("MX", "X"), ("O", ".")]));
    }

    #[test]
    fn keywords_are_other() {
        assert_eq!(
            show(b"o100 sub"),
            v(&[("WO", "o100"), ("S", " "), ("O", "sub")])
        );
        assert_eq!(
            show(b"O101 while [#1 LT 3]"),
            v(&[
                ("WO", "O101"),
                ("S", " "),
                ("O", "while"),
                ("S", " "),
                ("O", "[#1 LT 3]")
            ])
        );
        assert_eq!(
            show(b"o<x> call [1]"),
            v(&[
                ("MO", "o"),
                ("O", "<x>"),
                ("S", " "),
                ("O", "call"),
                ("S", " "),
                ("O", "[1]")
            ])
        );
        assert_eq!(show(b"XY10"), v(&[("O", "XY10")]));
        assert_eq!(show(b"WHILE[#1LT2]DO1"), v(&[("O", "WHILE[#1LT2]DO1")]));
    }

    #[test]
    fn parameters_and_expressions() {
        assert_eq!(
            show(b"#1 = [#2 + 3]"),
            v(&[
                ("O", "#1"),
                ("S", " "),
                ("O", "="),
                ("S", " "),
                ("O", "[#2 + 3]")
            ])
        );
        assert_eq!(show(b"#<x>=1"), v(&[("O", "#<x>=1")]));
        assert_eq!(
            show(b"G1 X[#1+[2]] Y#5 Z##1 A#[1+2] B#<_p> C[1"),
            v(&[
                ("WG", "G1"),
                ("S", " "),
                ("EX", "X[#1+[2]]"),
                ("S", " "),
                ("PY", "Y#5"),
                ("S", " "),
                ("PZ", "Z##1"),
                ("S", " "),
                ("PA", "A#[1+2]"),
                ("S", " "),
                ("PB", "B#<_p>"),
                ("S", " "),
                ("EC", "C[1"),
            ])
        );
    }

    #[test]
    fn unary_signs_and_functions() {
        assert_eq!(
            show(b"X-#<x_max> Y+[1] Z--1 A-.5 B- C EXISTS[#1] D atan[1]/[2] E-sin[3]"),
            v(&[
                ("PX", "X-#<x_max>"),
                ("S", " "),
                ("EY", "Y+[1]"),
                ("S", " "),
                ("EZ", "Z--1"),
                ("S", " "),
                ("WA", "A-.5"),
                ("S", " "),
                ("MB", "B"),
                ("O", "-"),
                ("S", " "),
                ("EC", "C EXISTS[#1]"),
                ("S", " "),
                ("ED", "D atan[1]/[2]"),
                ("S", " "),
                ("EE", "E-sin[3]"),
            ])
        );
        // Glued letters stay a keyword run (Fanuc `WHILE[..]` must not be `W` + `HILE[..]`).
        assert_eq!(show(b"Xsin[30]"), v(&[("O", "Xsin[30]")]));
        assert_eq!(show(b"X SIN"), v(&[("MX", "X"), ("S", " "), ("O", "SIN")]));
        assert_eq!(show(b"X ab[1]/[2]"), v(&[("EX", "X ab[1]"), ("O", "/[2]")]));
        // Polar words are not letters.
        assert_eq!(
            show(b"G1 @.5 ^90"),
            v(&[
                ("WG", "G1"),
                ("S", " "),
                ("O", "@.5"),
                ("S", " "),
                ("O", "^90")
            ])
        );
    }

    #[test]
    fn comments_percent_block_delete() {
        assert_eq!(
            show(b"  / G0 (a) (b ; c"),
            v(&[
                ("S", "  "),
                ("/", "/"),
                ("S", " "),
                ("WG", "G0"),
                ("S", " "),
                ("C", "(a)"),
                ("S", " "),
                ("C", "(b ; c"),
            ])
        );
        assert_eq!(show(b"/2G1"), v(&[("/", "/2"), ("WG", "G1")]));
        assert_eq!(show(b"G1 /"), v(&[("WG", "G1"), ("S", " "), ("O", "/")]));
        assert_eq!(show(b"(x)/"), v(&[("C", "(x)"), ("O", "/")]));
        assert_eq!(show(b"X1;(y)"), v(&[("WX", "X1"), ("C", ";(y)")]));
        assert_eq!(
            show(b"%(prog) 100"),
            v(&[("%", "%"), ("C", "(prog)"), ("S", " "), ("O", "100")])
        );
        assert_eq!(
            show(b"(a(b)c)"),
            v(&[("C", "(a(b)"), ("MC", "c"), ("O", ")")])
        );
    }

    #[test]
    fn numbers() {
        for (src, value, decimals) in [
            (&b"X-12.5"[..], -12.5, 1u8),
            (b"x+.5", 0.5, 1),
            (b"Y 10.", 10.0, 0),
            (b"N0010", 10.0, 0),
            (b"G43.4", 43.4, 1),
            (b"A+007.250", 7.25, 3),
            (b"B-.5", -0.5, 1),
            (b"C-0", -0.0, 0),
        ] {
            let t = toks(src);
            assert_eq!(t.len(), 1, "{src:?}");
            let TokenKind::Word(w) = &t[0].kind else {
                panic!()
            };
            assert_eq!(w.value, Value::Number { value, decimals }, "{src:?}");
        }
        let long = format!("X{}.{}", "9".repeat(400), "1".repeat(300));
        let t = toks(long.as_bytes());
        let TokenKind::Word(w) = &t[0].kind else {
            panic!()
        };
        assert_eq!(
            w.value,
            Value::Number {
                value: f64::INFINITY,
                decimals: 255
            }
        );
    }

    #[test]
    fn never_panics_on_odd_bytes() {
        for s in [
            &b""[..],
            b"\0",
            b"\r",
            b"(",
            b"[",
            b"#",
            b"<",
            b"/",
            b"X",
            b"X ",
            b"X[",
            b"X#<",
            b"X#[",
            b"##",
            b"\xc3\x28",
            b"]]]",
        ] {
            let mut out = Vec::new();
            parse_line(s, &mut out);
            let mut pos = 0;
            for t in &out {
                assert_eq!(t.span.start, pos);
                assert!(t.span.end > t.span.start);
                pos = t.span.end;
            }
            assert_eq!(pos, s.len());
        }
    }

    #[test]
    fn deep_nesting_does_not_recurse() {
        let mut s = b"X".to_vec();
        s.extend(std::iter::repeat_n(b'#', 100_000));
        s.extend(std::iter::repeat_n(b'[', 100_000));
        let t = toks(&s);
        assert_eq!(t.len(), 1);
        assert!(matches!(
            &t[0].kind,
            TokenKind::Word(Word {
                value: Value::Parameter,
                ..
            })
        ));
        let mut s = b"X".to_vec();
        s.extend(std::iter::repeat_n(b'-', 100_000));
        s.extend_from_slice(b"#1");
        let t = toks(&s);
        assert_eq!(t.len(), 1);
        assert!(matches!(
            &t[0].kind,
            TokenKind::Word(Word {
                value: Value::Parameter,
                ..
            })
        ));
    }
}
