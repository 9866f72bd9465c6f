//! Exact positions for incremental programs.
//!
//! In G91 every axis word is a difference, and the machine's position is the sum of all the
//! differences it was told. Summing floats would drift over a long program, so the pass
//! keeps programmed and written positions as integers of a fixed small unit and writes
//! each increment as the exact difference between two written absolute positions: the sum
//! of the written increments is then exactly the rounded compensated position, however
//! many blocks there are.

use super::INCH;
use crate::nc::number::{fixed, scaled};

/// Positions are integers of 10^-SCALE mm (or degree). An inch word with `d` decimals is
/// exactly `254 · 10^(SCALE − d − 1)` units per last digit, so inch words are exact too
/// (and diameter words, at 5 or 127 of those).
pub const SCALE: u8 = 13;

/// The most decimals an incremental word may have (and an added one gets).
pub const MAX_DECIMALS: u8 = 12;

/// A number's text `[+-]?(digits[.digits?]|.digits)` as its digits and decimals, exactly.
pub fn parse_decimal(text: &[u8]) -> Option<(i128, u8)> {
    let (negative, digits) = match text.split_first()? {
        (b'-', rest) => (true, rest),
        (b'+', rest) => (false, rest),
        _ => (false, text),
    };
    let mut mantissa: i128 = 0;
    let mut decimals: Option<u8> = None;
    let mut any = false;
    for &b in digits {
        match b {
            b'0'..=b'9' => {
                mantissa = mantissa
                    .checked_mul(10)?
                    .checked_add(i128::from(b - b'0'))?;
                any = true;
                if let Some(d) = decimals.as_mut() {
                    *d = d.checked_add(1)?;
                }
            }
            b'.' if decimals.is_none() => decimals = Some(0),
            _ => return None,
        }
    }
    any.then_some((
        if negative { -mantissa } else { mantissa },
        decimals.unwrap_or(0),
    ))
}

/// Powers of ten up to 10^SCALE.
const POW10: [i128; SCALE as usize + 1] = {
    let mut p = [1i128; SCALE as usize + 1];
    let mut i = 1;
    while i < p.len() {
        p[i] = p[i - 1] * 10;
        i += 1;
    }
    p
};

/// What a word's number is in: mm (degrees for rotary words) or inch, and either one as a
/// diameter (a lathe's X in G7: the axis moves by half the number).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Unit {
    pub inch: bool,
    pub diameter: bool,
}

impl Unit {
    pub const MM: Unit = Unit {
        inch: false,
        diameter: false,
    };

    /// Tenths of a unit (mm or degree) in one of the word's: 10, 254 (inch), 5 (diameter),
    /// 127 (inch diameter). Whole tenths keep every word exact in units.
    fn tenths(self) -> i128 {
        match (self.inch, self.diameter) {
            (false, false) => 10,
            (true, false) => 254,
            (false, true) => 5,
            (true, true) => 127,
        }
    }

    /// Millimetres or inch, not a diameter.
    pub fn inch(inch: bool) -> Unit {
        Unit {
            inch,
            diameter: false,
        }
    }

    /// A number of this unit in mm (degrees).
    pub fn to_mm(self, x: f64) -> f64 {
        let x = if self.inch { x * INCH } else { x };
        if self.diameter { x / 2.0 } else { x }
    }

    /// A value in mm (degrees) as a number of this unit.
    pub fn of_mm(self, x: f64) -> f64 {
        let x = if self.diameter { x * 2.0 } else { x };
        if self.inch { x / INCH } else { x }
    }
}

/// Units in one step of the last digit of a word with `decimals` decimals.
pub fn step(decimals: u8, unit: Unit) -> Option<i128> {
    let e = usize::from(SCALE.checked_sub(decimals)?);
    let tenths = unit.tenths();
    if tenths % 10 == 0 {
        Some(tenths / 10 * POW10[e])
    } else {
        Some(tenths * POW10[e.checked_sub(1)?])
    }
}

/// A written number in units (mm or degrees), if it is exactly representable.
pub fn units(mantissa: i128, decimals: u8, unit: Unit) -> Option<i128> {
    mantissa.checked_mul(step(decimals, unit)?)
}

/// A number with `decimals` decimals, read as `value` from `text`, in units: from the
/// float where that is certainly exact (the common case, cheap), else from the text.
pub fn number_units(value: f64, decimals: u8, text: &[u8], unit: Unit) -> Option<i128> {
    match scaled(value, decimals) {
        Some(k) => units(k.into(), decimals, unit),
        None => parse_decimal(text).and_then(|(k, d)| units(k, d, unit)),
    }
}

/// A position kept exactly, and cheaply: a G90 word, or a value written in G90, stays the
/// decimal it is and becomes units only when a G91 block needs it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Position {
    /// The number `write_fixed(value, decimals)` prints (for a word read from a program:
    /// the word), in its unit.
    Decimal {
        value: f64,
        decimals: u8,
        unit: Unit,
    },
    Units(i128),
}

impl Position {
    /// In units; the nearest for a number with more digits than the units hold.
    pub fn units(self) -> i128 {
        match self {
            Position::Units(u) => u,
            Position::Decimal {
                value,
                decimals,
                unit,
            } => round_to(value, decimals)
                .and_then(|k| units(k, decimals, unit))
                .unwrap_or_else(|| from_f64(unit.to_mm(value))),
        }
    }

    /// Moved by `increment` units.
    #[allow(clippy::should_implement_trait)]
    pub fn add(self, increment: i128) -> Position {
        Position::Units(self.units().saturating_add(increment))
    }
}

/// Units as mm or degrees: the nearest f64, as parsing the number's text gives it (so a
/// position reached in G91 is the same number as the G90 word for it).
pub fn to_f64(units: i128) -> f64 {
    if units.unsigned_abs() < 1 << 53 {
        // Both exact, and IEEE division rounds correctly.
        units as f64 / 10f64.powi(SCALE.into())
    } else {
        let mut s = String::new();
        write_digits(units, SCALE, &mut s);
        s.parse().unwrap_or(f64::NAN)
    }
}

/// The nearest units to a value in mm or degrees (for numbers that are not exact).
pub fn from_f64(x: f64) -> i128 {
    (x * 10f64.powi(SCALE.into())).round() as i128
}

/// `x` rounded to `decimals` decimals, as the integer of its digits: exactly what
/// `write_fixed` prints (and so what a G90 word would be).
pub fn round_to(x: f64, decimals: u8) -> Option<i128> {
    match scaled(x, decimals) {
        Some(k) => Some(k.into()),
        // Within a hair of a tie, or large: std's exact formatting decides.
        None if x.is_finite() => parse_decimal(fixed(x, decimals).as_bytes()).map(|(k, _)| k),
        None => None,
    }
}

/// `a / b` rounded to the nearest integer, halves away from zero (`b` > 0).
fn div_round(a: i128, b: i128) -> i128 {
    let q = a.div_euclid(b);
    let r = a.rem_euclid(b);
    if 2 * r > b || (2 * r == b && a > 0) {
        q + 1
    } else {
        q
    }
}

/// The increment from the written position `from` (units) to `target` (in the word's own
/// unit) rounded to `decimals`, as (digits, decimals). The increment is exact when it can
/// be: if `from` has finer digits than `decimals` (a word kept with more decimals, say)
/// the increment gets as many as it needs, up to [`MAX_DECIMALS`]. Only a position mixed
/// from words of different units may have none; then the nearest at `decimals` is taken,
/// and the next block starts again from the exact position written.
pub fn increment(from: i128, target: f64, decimals: u8, unit: Unit) -> Option<(i128, u8)> {
    let t = units(round_to(target, decimals)?, decimals, unit)?;
    let delta = t - from;
    for d in decimals..=MAX_DECIMALS {
        let s = step(d, unit)?;
        if delta % s == 0 {
            return Some((delta / s, d));
        }
    }
    Some((div_round(delta, step(decimals, unit)?), decimals))
}

/// Append `mantissa · 10^-decimals` with exactly `decimals` digits after the point (no
/// point for 0), never a negative zero: as `write_fixed` writes numbers.
pub fn write_digits(mantissa: i128, decimals: u8, out: &mut String) {
    crate::nc::number::write_scaled(mantissa, decimals, out);
}

#[cfg(test)]
mod tests {
    use super::*;

    const INCH_UNIT: Unit = Unit {
        inch: true,
        diameter: false,
    };

    #[test]
    fn decimals_are_read_exactly() {
        assert_eq!(parse_decimal(b"12.50"), Some((1250, 2)));
        assert_eq!(parse_decimal(b"-.5"), Some((-5, 1)));
        assert_eq!(parse_decimal(b"+3."), Some((3, 0)));
        assert_eq!(parse_decimal(b"7"), Some((7, 0)));
        assert_eq!(parse_decimal(b"."), None);
        assert_eq!(parse_decimal(b"1.2.3"), None);
        assert_eq!(parse_decimal(b""), None);
    }

    #[test]
    fn inch_words_are_exact_in_mm() {
        // 1.000001 inch = 25.4000254 mm.
        assert_eq!(units(1_000_001, 6, INCH_UNIT), Some(254_000_254_000_000));
        assert_eq!(units(1, 12, INCH_UNIT), Some(254));
        assert_eq!(units(1, 13, INCH_UNIT), None);
        assert_eq!(units(1, 13, Unit::MM), Some(1));
    }

    #[test]
    fn diameter_words_are_exact_in_mm() {
        let d = Unit {
            inch: false,
            diameter: true,
        };
        let inch_d = Unit {
            inch: true,
            diameter: true,
        };
        // 0.0001 on a diameter is 0.00005 mm; 0.000001 inch on a diameter 0.0000127 mm.
        assert_eq!(units(1, 4, d), Some(500_000_000));
        assert_eq!(units(1, 6, inch_d), Some(127_000_000));
        assert_eq!(units(1, 13, d), None);
        assert_eq!((d.to_mm(50.0), d.of_mm(25.0)), (25.0, 50.0));
        assert_eq!(inch_d.to_mm(2.0), 25.4);
        // From X60. to X40.0001 in G91: the diameter's increment, exactly.
        let from = units(600_000, 4, d).unwrap();
        assert_eq!(increment(from, 40.0001, 4, d), Some((-199_999, 4)));
    }

    #[test]
    fn increments_land_exactly_on_the_rounded_target() {
        let from = units(100_005, 5, Unit::MM).unwrap(); // 1.00005 written before
        // Target 2.0 at 4 decimals: the increment needs the 5th decimal to land on 2.0000.
        assert_eq!(increment(from, 2.0, 4, Unit::MM), Some((99_995, 5)));
        assert_eq!(increment(0, 0.123449, 4, Unit::MM), Some((1234, 4)));
        assert_eq!(
            increment(units(1, 4, Unit::MM).unwrap(), -0.0001, 4, Unit::MM),
            Some((-2, 4))
        );
        // A position written in mm, continued in inch: no exact inch increment, nearest.
        let from = units(1, 0, Unit::MM).unwrap(); // 1 mm
        let (k, d) = increment(from, 1.0, 6, INCH_UNIT).unwrap();
        assert_eq!((k, d), (960_630, 6)); // 0.960630 inch + 1 mm = 25.400002 mm
    }

    #[test]
    fn positions_read_as_their_text() {
        for text in [
            "123.4567",
            "-899.9999",
            "1234.5678",
            "-98765.4321",
            "2067.336",
            "0.0001",
        ] {
            let (k, d) = parse_decimal(text.as_bytes()).unwrap();
            let x: f64 = text.parse().unwrap();
            assert_eq!(to_f64(units(k, d, Unit::MM).unwrap()), x, "{text}");
        }
    }

    /// The arithmetic of G91 on its own, over a million blocks: a target that wanders by
    /// small steps plus a correction of microns, written as increments; the sum of the
    /// increments is at every step exactly the rounded target.
    #[test]
    fn a_million_increments_do_not_drift() {
        let mut nominal: i128 = units(-1234567, 4, Unit::MM).unwrap();
        let mut written: i128 = 0;
        let mut words = 0usize;
        for i in 0..1_000_000u32 {
            nominal += units([13, -7, 3, 11][i as usize % 4], 4, Unit::MM).unwrap();
            let x = to_f64(nominal);
            let target = x + 0.004 * (x * 0.01).sin() + 1e-7 * f64::from(i % 97);
            let (k, d) = increment(written, target, 4, Unit::MM).unwrap();
            assert_eq!(d, 4);
            written += units(k, d, Unit::MM).unwrap();
            words += usize::from(k != 0);
            assert_eq!(
                written,
                units(round_to(target, 4).unwrap(), 4, Unit::MM).unwrap()
            );
        }
        assert!(words > 900_000);
    }

    proptest::proptest! {
        #[test]
        fn digits_print_as_write_fixed(k in -10_000_000_000i64..10_000_000_000, d in 0u8..9) {
            let mut s = String::new();
            write_digits(k.into(), d, &mut s);
            proptest::prop_assert_eq!(&s, &fixed(k as f64 / 10f64.powi(d.into()), d));
            proptest::prop_assert_eq!(parse_decimal(s.as_bytes()), Some((i128::from(k), d)));
        }
    }
}
