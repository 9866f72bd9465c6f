//! The report's SVG plots (plotters' SVG backend; text as SVG `<text>` elements, so no
//! font is needed to make them). Each plot carries its own notes: a plot is read on its
//! own, often as a screenshot, so what it needs to be read right is written on it.

mod along;
mod corrections;
mod map;

pub use along::{Along, Limit, along_program};
pub use corrections::corrections;
pub use map::map;

use crate::compensate::Sample;
use plotters::coord::Shift;
use plotters::prelude::*;

/// The colour of "before compensation" series.
pub const BEFORE: RGBColor = RGBColor(214, 39, 40);
/// The colour of "after compensation" series.
pub const AFTER: RGBColor = RGBColor(31, 119, 180);
/// Colours of the axes in the correction plot (neither of the two above).
pub const AXIS_COLOURS: [RGBColor; 8] = [
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
    RGBColor(127, 127, 127),
];
/// The colour map of the volumetric error, from zero to the largest error (viridis).
const RAMP: [(u8, u8, u8); 5] = [
    (68, 1, 84),
    (59, 82, 139),
    (33, 145, 140),
    (94, 201, 98),
    (253, 231, 37),
];
/// Grey of notes written on a plot.
const NOTE: RGBColor = RGBColor(70, 70, 70);

type Area<'a> = DrawingArea<SVGBackend<'a>, Shift>;
type DrawResult<T> = Result<T, DrawingAreaErrorKind<std::io::Error>>;

fn font(size: u32) -> TextStyle<'static> {
    ("sans-serif", size).into_font().color(&BLACK)
}

/// Draw into a fresh SVG document of `size` pixels.
fn svg(size: (u32, u32), draw: impl FnOnce(&Area<'_>) -> DrawResult<()>) -> Result<String, String> {
    let mut text = String::new();
    {
        let root = SVGBackend::with_string(&mut text, size).into_drawing_area();
        root.fill(&WHITE)
            .and_then(|()| draw(&root))
            .and_then(|()| root.present())
            .map_err(|e| format!("cannot draw a plot: {e}"))?;
    }
    Ok(text)
}

/// Lines of notes from (x, y) down.
fn notes(area: &Area<'_>, lines: &[String], (x, y): (i32, i32), size: u32) -> DrawResult<()> {
    for (k, line) in lines.iter().enumerate() {
        area.draw(&Text::new(
            line.clone(),
            (x, y + (size as i32 + 4) * k as i32),
            font(size).color(&NOTE),
        ))?;
    }
    Ok(())
}

/// A legend entry: its label, colour and whether its line is dashed.
pub(super) struct Key {
    pub label: String,
    pub colour: RGBColor,
    pub dashed: bool,
}

/// A legend in one row ending at `right`, above the plot rather than on it, so that it
/// hides no data.
fn legend(area: &Area<'_>, keys: &[Key], right: i32, y: i32) -> DrawResult<()> {
    // 13 px sans-serif: about 7 px a character; 26 px of line and gap before each label,
    // 18 px after it.
    let width = |k: &Key| 26 + 7 * k.label.chars().count() as i32 + 18;
    let mut x = right - keys.iter().map(width).sum::<i32>();
    for k in keys {
        let style = k.colour.stroke_width(2);
        if k.dashed {
            for d in 0..3 {
                let a = x + d * 8;
                area.draw(&PathElement::new(vec![(a, y), (a + 4, y)], style))?;
            }
        } else {
            area.draw(&PathElement::new(vec![(x, y), (x + 20, y)], style))?;
        }
        area.draw(&Text::new(k.label.clone(), (x + 26, y - 7), font(13)))?;
        x += width(k);
    }
    Ok(())
}

/// `text` broken at spaces into lines of at most `width` characters (SVG text does not
/// wrap; 14 px sans-serif is about 6 px a character).
fn wrap(text: &str, width: usize) -> Vec<String> {
    let mut lines: Vec<String> = Vec::new();
    let mut line = String::new();
    for word in text.split_whitespace() {
        if !line.is_empty() && line.chars().count() + 1 + word.chars().count() > width {
            lines.push(std::mem::take(&mut line));
        }
        if !line.is_empty() {
            line.push(' ');
        }
        line.push_str(word);
    }
    if !line.is_empty() {
        lines.push(line);
    }
    lines
}

/// The colour of `t` in 0..=1 on the ramp.
pub fn ramp(t: f64) -> RGBColor {
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let x = t * (RAMP.len() - 1) as f64;
    let k = (x.floor() as usize).min(RAMP.len() - 2);
    let f = x - k as f64;
    let mix = |a: u8, b: u8| (f64::from(a) + (f64::from(b) - f64::from(a)) * f).round() as u8;
    let (a, b) = (RAMP[k], RAMP[k + 1]);
    RGBColor(mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2))
}

/// A number for an axis label: few digits, no trailing zeros.
pub(crate) fn short(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return "0".into();
    }
    let digits = (2 - v.abs().log10().floor() as i32).clamp(0, 8) as usize;
    let s = format!("{v:.digits$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// A round step (1, 2 or 5 × 10ⁿ) and the first multiple of it at or above `max`, with
/// three to six steps from 0 to the top and the top as close above `max` as that allows:
/// a scale whose ticks read as round numbers.
pub fn round_scale(max: f64) -> (f64, f64) {
    if !(max.is_finite() && max > 0.0) {
        return (1.0, 1.0);
    }
    let decade = 10f64.powf(max.log10().floor());
    let mut best: Option<(f64, f64, f64)> = None;
    for exp in -2..=1 {
        for m in [1.0, 2.0, 5.0] {
            let step = m * decade * 10f64.powi(exp);
            let steps = (max / step - 1e-9).ceil().max(1.0);
            if !(3.0..=6.0).contains(&steps) {
                continue;
            }
            let top = steps * step;
            if best.is_none_or(|(t, _, n)| top < t || (top == t && steps < n)) {
                best = Some((top, step, steps));
            }
        }
    }
    best.map_or((max, max), |(top, step, _)| (top, step))
}

/// The x range of plots along the program: the lines of the first and last sample.
fn line_range(samples: &[Sample]) -> std::ops::Range<f64> {
    let first = samples.first().map_or(0, |s| s.line) as f64;
    let last = samples.last().map_or(1, |s| s.line) as f64;
    if last > first {
        first..last
    } else {
        first - 1.0..first + 1.0
    }
}

fn no_data(area: &Area<'_>, what: &str) -> DrawResult<()> {
    area.draw(&Text::new(
        format!("{what}: no block was compensated"),
        (20, 40),
        font(16),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_scales_end_on_a_round_tick() {
        let close = |(a, b): (f64, f64), (c, d): (f64, f64)| {
            assert!(
                (a - c).abs() < 1e-9 * c && (b - d).abs() < 1e-9 * d,
                "{a} {b}"
            );
        };
        // The odd ticks (4.4 / 8.79 / 13.2 / 17.6) come from a top of 17.6 µm.
        close(round_scale(17.6), (20.0, 5.0));
        close(round_scale(352.0), (400.0, 100.0));
        close(round_scale(100.0), (100.0, 20.0));
        close(round_scale(0.113), (0.12, 0.02));
        close(round_scale(1.0), (1.0, 0.2));
        assert_eq!(round_scale(0.0), (1.0, 1.0));
        assert_eq!(round_scale(f64::NAN), (1.0, 1.0));
        for k in 1..2000 {
            let max = f64::from(k) * 0.37;
            let (top, step) = round_scale(max);
            let n = top / step;
            assert!(
                top >= max && (3.0 - 1e-9..=6.0 + 1e-9).contains(&n),
                "{max}: {top} {step}"
            );
        }
    }

    #[test]
    fn notes_wrap_at_spaces() {
        assert_eq!(wrap("aa bb cc", 5), vec!["aa bb", "cc"]);
        assert_eq!(wrap("", 5), Vec::<String>::new());
        assert_eq!(wrap("abcdefgh ij", 5), vec!["abcdefgh", "ij"]);
    }
}
