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

/// Append `value` with exactly `decimals` digits after the point (no point for 0) and never
/// a negative zero.
pub fn write_fixed(value: f64, decimals: u8, out: &mut String) {
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

/// `value` with exactly `decimals` digits after the point.
pub fn fixed(value: f64, decimals: u8) -> String {
    let mut s = String::new();
    write_fixed(value, decimals, &mut s);
    s
}

#[cfg(test)]
mod tests {
    use super::*;

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
    }
}
