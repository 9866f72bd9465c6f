//! Numbers as programs write them.
//!
//! The contract's rule (design/model.md, "Numbers in programs"): a word whose compensated
//! value rounds to the same text keeps its bytes; a changed value is written with at least
//! the word's own decimals and at least the machine's resolution.

use std::fmt::Write;

/// The fewest decimals whose last digit is no coarser than `step` (0.0001 → 4, 0.0005 → 4,
/// 0.001 → 3, 1 → 0).
pub fn decimals_for(step: f64) -> u8 {
    let mut d = 0u8;
    while d < 12 && 10f64.powi(-i32::from(d)) > step * (1.0 + 1e-9) {
        d += 1;
    }
    d
}

/// `value · 10^decimals` rounded to an integer, when that is certainly what `{:.decimals}`
/// prints: `None` for values too large, not finite, or within a hair of a rounding tie
/// (std's exact algorithm decides those).
pub fn scaled(value: f64, decimals: u8) -> Option<i64> {
    const POW10: [f64; 13] = [
        1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12,
    ];
    let x = value * *POW10.get(usize::from(decimals))?;
    if x.is_nan() || x.abs() >= 1e14 {
        return None;
    }
    // `x.round()` without the library call it is on targets without SSE4.1: below 1e14 the
    // truncation is exact and so is the fraction left. Without branches too: whether a
    // written digit rounds up is a coin toss, and a mispredicted branch on it cost more
    // than the rest of the rounding (a time profile put this function at 40 % of the
    // rewriting of a block's words).
    let t = x as i64 as f64;
    let f = x - t;
    let r = t + f64::from(u8::from(f >= 0.5)) - f64::from(u8::from(f <= -0.5));
    ((x - r).abs() < 0.5 - 1e-6).then_some(r as i64)
}

/// Whether two values print the same with `decimals` digits after the point.
pub fn same_text(a: f64, b: f64, decimals: u8) -> bool {
    match (scaled(a, decimals), scaled(b, decimals)) {
        (Some(x), Some(y)) => x == y,
        _ => fixed(a, decimals) == fixed(b, decimals),
    }
}

/// Append the integer `mantissa · 10^-decimals` with exactly `decimals` digits after the
/// point (no point for 0), never a negative zero.
pub fn write_scaled(mantissa: i128, decimals: u8, out: &mut String) {
    if let Ok(m) = u64::try_from(mantissa.unsigned_abs())
        && decimals <= 20
    {
        write_small(m, mantissa < 0, usize::from(decimals), out);
        return;
    }
    // Sign, digits, point and leading zeros at once: no growing step by step.
    out.reserve(42 + usize::from(decimals));
    if mantissa < 0 {
        out.push('-');
    }
    // The digits, least significant first, on the stack (u128 has at most 39).
    let mut buf = [0u8; 40];
    let mut len = 0;
    let mut wide = mantissa.unsigned_abs();
    // 128-bit division is a library call: only for the digits beyond 64 bits.
    while wide > u128::from(u64::MAX) {
        buf[len] = b'0' + (wide % 10) as u8;
        len += 1;
        wide /= 10;
    }
    let mut m = wide as u64;
    loop {
        buf[len] = b'0' + (m % 10) as u8;
        len += 1;
        m /= 10;
        if m == 0 {
            break;
        }
    }
    // `buf[..len]` holds the digits in reverse.
    let d = usize::from(decimals);
    if len <= d {
        out.push_str("0.");
        out.extend(std::iter::repeat_n('0', d - len));
        out.extend(buf[..len].iter().rev().map(|&b| char::from(b)));
    } else {
        for (i, &b) in buf[..len].iter().enumerate().rev() {
            out.push(char::from(b));
            if i == d && d > 0 {
                out.push('.');
            }
        }
    }
}

/// [`write_scaled`] for the usual numbers (64 bits, at most 20 decimals).
fn write_small(m: u64, negative: bool, decimals: usize, out: &mut String) {
    let (buf, pos) = small_digits(m, negative, decimals);
    // Characters the compiler can see are ASCII (the mask) are pushed as bytes, without the
    // encoding step (`str::from_utf8` on a few bytes costs more than the whole number).
    let text = &buf[pos..];
    out.reserve(text.len());
    for &b in text {
        out.push(char::from(b & 0x7f));
    }
}

/// The text of `±m · 10^-decimals` (at most 20 decimals), put together right to left on
/// the stack two digits at a time: the buffer and where the text starts in it.
#[inline]
fn small_digits(mut m: u64, negative: bool, decimals: usize) -> ([u8; 42], usize) {
    // "00" to "99".
    const PAIRS: &[u8; 200] = b"0001020304050607080910111213141516171819\
        2021222324252627282930313233343536373839404142434445464748495051525354555657585960616263\
        646566676869707172737475767778798081828384858687888990919293949596979899";
    // The last two digits of `m` (taken off it), or its last one, before `pos` in `buf`.
    fn put_two(buf: &mut [u8; 42], pos: &mut usize, m: &mut u64) {
        let r = (*m % 100) as usize;
        *m /= 100;
        *pos -= 2;
        buf[*pos] = PAIRS[2 * r];
        buf[*pos + 1] = PAIRS[2 * r + 1];
    }
    fn put_one(buf: &mut [u8; 42], pos: &mut usize, m: &mut u64) {
        *pos -= 1;
        buf[*pos] = b'0' + (*m % 10) as u8;
        *m /= 10;
    }
    // Sign, 20 integer digits, point, 20 decimals.
    let mut buf = [0u8; 42];
    let mut pos = buf.len();
    for _ in 0..decimals / 2 {
        put_two(&mut buf, &mut pos, &mut m);
    }
    if decimals % 2 == 1 {
        put_one(&mut buf, &mut pos, &mut m);
    }
    if decimals > 0 {
        pos -= 1;
        buf[pos] = b'.';
    }
    // The integer part: at least one digit.
    let point = pos;
    while m >= 10 {
        put_two(&mut buf, &mut pos, &mut m);
    }
    if m > 0 || pos == point {
        put_one(&mut buf, &mut pos, &mut m);
    }
    if negative {
        pos -= 1;
        buf[pos] = b'-';
    }
    (buf, pos)
}

/// [`write_small`] appending bytes: copied from the stack at once (a `String` takes them a
/// character at a time, eleven instructions each).
fn write_small_bytes(m: u64, negative: bool, decimals: usize, out: &mut Vec<u8>) {
    let (buf, pos) = small_digits(m, negative, decimals);
    out.extend_from_slice(&buf[pos..]);
}

/// [`write_scaled`] appending bytes.
pub fn write_scaled_bytes(mantissa: i128, decimals: u8, out: &mut Vec<u8>) {
    if let Ok(m) = u64::try_from(mantissa.unsigned_abs())
        && decimals <= 20
    {
        write_small_bytes(m, mantissa < 0, usize::from(decimals), out);
        return;
    }
    let mut text = String::new();
    write_scaled(mantissa, decimals, &mut text);
    out.extend_from_slice(text.as_bytes());
}

/// Append `value` with exactly `decimals` digits after the point (no point for 0) and never
/// a negative zero.
pub fn write_fixed(value: f64, decimals: u8, out: &mut String) {
    // Hot path: integer digits, no float formatting (which is slow for fixed precision).
    if let Some(n) = scaled(value, decimals) {
        write_scaled(i128::from(n), decimals, out);
        return;
    }
    let start = out.len();
    let _ = write!(out, "{:.*}", usize::from(decimals), value);
    if out.as_bytes()[start] == b'-'
        && out.as_bytes()[start + 1..]
            .iter()
            .all(|&b| b == b'0' || b == b'.')
    {
        out.remove(start);
    }
}

/// [`write_fixed`], returning the number written as the NC parser reads it back (the
/// nearest f64 to the text), without reading the text.
pub fn write_fixed_value(value: f64, decimals: u8, out: &mut String) -> f64 {
    Rounded::new(value, decimals).write(out)
}

/// A value to be written with `decimals` digits after the point, its digits worked out once
/// for both questions a pass asks of it: does a word print the same ([`same_text`]), and
/// what is written instead ([`write_fixed_value`]).
#[derive(Debug, Clone, Copy)]
pub struct Rounded {
    value: f64,
    decimals: u8,
    scaled: Option<i64>,
}

impl Rounded {
    pub fn new(value: f64, decimals: u8) -> Self {
        Rounded {
            value,
            decimals,
            scaled: scaled(value, decimals),
        }
    }

    /// Whether `other` prints the same: `same_text(other, value, decimals)`.
    pub fn prints_as(&self, other: f64) -> bool {
        match (scaled(other, self.decimals), self.scaled) {
            (Some(x), Some(y)) => x == y,
            _ => fixed(other, self.decimals) == fixed(self.value, self.decimals),
        }
    }

    /// [`write_fixed_value`]: below 2^53 units of the last digit, the integer and the power
    /// of ten are exact and their quotient is the f64 the text reads as.
    pub fn write(&self, out: &mut String) -> f64 {
        if let Some((n, value)) = self.exact() {
            write_small(n.unsigned_abs(), n < 0, usize::from(self.decimals), out);
            return value;
        }
        let start = out.len();
        write_fixed(self.value, self.decimals, out);
        crate::nc::to_f64(&out.as_bytes()[start..])
    }

    /// The value the text [`Rounded::write`] writes reads as, without the text where it
    /// is exact (no buffer to allocate).
    pub fn read_back(&self) -> f64 {
        if let Some((_, value)) = self.exact() {
            return value;
        }
        self.write(&mut String::new())
    }

    /// [`Rounded::write`] appending bytes.
    pub fn write_bytes(&self, out: &mut Vec<u8>) -> f64 {
        if let Some((n, value)) = self.exact() {
            write_small_bytes(n.unsigned_abs(), n < 0, usize::from(self.decimals), out);
            return value;
        }
        let mut text = String::new();
        let value = self.write(&mut text);
        out.extend_from_slice(text.as_bytes());
        value
    }

    /// The scaled integer and the value its text reads as, where both are exact.
    #[inline]
    fn exact(&self) -> Option<(i64, f64)> {
        const POW10: [f64; 13] = [
            1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12,
        ];
        let n = self.scaled?;
        // 2^53 has 16 digits, and at most 12 decimals get here.
        let p = POW10.get(usize::from(self.decimals))?;
        if n.unsigned_abs() > 1 << 53 {
            return None;
        }
        let v = n.unsigned_abs() as f64 / p;
        Some((n, if n < 0 { -v } else { v }))
    }
}

/// `value` with exactly `decimals` digits after the point.
pub fn fixed(value: f64, decimals: u8) -> String {
    let mut s = String::new();
    write_fixed(value, decimals, &mut s);
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::strategy::{Just, Strategy};

    #[test]
    fn decimals_from_resolution() {
        assert_eq!(decimals_for(0.0001), 4);
        assert_eq!(decimals_for(0.0005), 4);
        assert_eq!(decimals_for(0.001), 3);
        assert_eq!(decimals_for(1.0), 0);
        assert_eq!(decimals_for(0.0001 / 25.4), 6);
    }

    #[test]
    fn fixed_never_writes_negative_zero() {
        assert_eq!(fixed(-0.00001, 4), "0.0000");
        assert_eq!(fixed(-0.00006, 4), "-0.0001");
        assert_eq!(fixed(12.5, 3), "12.500");
        assert_eq!(fixed(-3.0, 0), "-3");
        assert_eq!(fixed(-0.4, 0), "0");
        assert_eq!(fixed(0.05, 4), "0.0500");
        assert_eq!(fixed(-0.05, 1), "-0.1");
        assert_eq!(fixed(123456.78901, 4), "123456.7890");
        assert_eq!(fixed(1e300, 2).len(), 304);
        assert_eq!(fixed(f64::NAN, 2), "NaN");
    }

    /// `m · 10^-d` as text, the slow way.
    fn scaled_text(m: i128, d: u8) -> String {
        let digits = m.unsigned_abs().to_string();
        let digits = format!("{digits:0>w$}", w = usize::from(d) + 1);
        let (int, frac) = digits.split_at(digits.len() - usize::from(d));
        let sign = if m < 0 { "-" } else { "" };
        if d == 0 {
            format!("{sign}{int}")
        } else {
            format!("{sign}{int}.{frac}")
        }
    }

    proptest::proptest! {
        #[test]
        fn fast_path_prints_what_std_prints(v in -1e6..1e6f64, d in 0u8..8) {
            let mut std = format!("{:.*}", usize::from(d), v);
            if std.starts_with('-') && std[1..].bytes().all(|b| b == b'0' || b == b'.') {
                std.remove(0);
            }
            proptest::prop_assert_eq!(fixed(v, d), std);
        }

        #[test]
        fn scaled_integers_print_their_digits(m in proptest::num::i128::ANY, d in 0u8..45) {
            let mut out = String::new();
            write_scaled(m, d, &mut out);
            proptest::prop_assert_eq!(out, scaled_text(m, d));
        }

        #[test]
        fn small_scaled_integers_print_their_digits(
            m in proptest::prop_oneof![
                proptest::num::i64::ANY.prop_map(i128::from),
                -100_000_000i128..100_000_000,
                Just(i128::from(u64::MAX)),
                Just(-i128::from(u64::MAX)),
            ],
            d in 0u8..24,
        ) {
            let mut out = String::from("kept");
            write_scaled(m, d, &mut out);
            proptest::prop_assert_eq!(out, format!("kept{}", scaled_text(m, d)));
        }

        #[test]
        fn the_value_written_is_the_value_read(v in -1e6..1e6f64, d in 0u8..14) {
            let mut text = String::new();
            let written = write_fixed_value(v, d, &mut text);
            proptest::prop_assert_eq!(&text, &fixed(v, d));
            let read: f64 = text.parse().unwrap();
            proptest::prop_assert_eq!(written.to_bits(), read.to_bits(), "{}", text);
        }

        #[test]
        fn bytes_are_the_string_s_bytes(
            m in proptest::prop_oneof![
                proptest::num::i128::ANY,
                -100_000_000i128..100_000_000,
            ],
            v in -1e6..1e6f64,
            d in 0u8..24,
        ) {
            let (mut text, mut bytes) = (String::from("kept"), b"kept".to_vec());
            write_scaled(m, d, &mut text);
            write_scaled_bytes(m, d, &mut bytes);
            proptest::prop_assert_eq!(text.as_bytes(), &bytes[..]);
            let rounded = Rounded::new(v, d);
            let (mut text, mut bytes) = (String::new(), Vec::new());
            let (a, b) = (rounded.write(&mut text), rounded.write_bytes(&mut bytes));
            proptest::prop_assert_eq!(text.as_bytes(), &bytes[..]);
            proptest::prop_assert_eq!(a.to_bits(), b.to_bits());
        }

        #[test]
        fn same_text_agrees_with_strings(a in -1e4..1e4f64, delta in -1e-3..1e-3f64, d in 0u8..6) {
            let b = a + delta;
            proptest::prop_assert_eq!(same_text(a, b, d), fixed(a, d) == fixed(b, d));
            proptest::prop_assert_eq!(Rounded::new(b, d).prints_as(a), fixed(a, d) == fixed(b, d));
        }
    }
}
