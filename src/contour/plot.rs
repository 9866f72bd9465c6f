//! The SVG plot: tool-tip and tool-axis contour error along the path, one panel each.
//!
//! A trace of a million samples would make an SVG nobody can open, so each curve is drawn
//! as its envelope: per pixel column the smallest and largest value there, which keeps
//! every peak. Text is plain SVG `<text>` (plotters' SVG backend), so no font is needed.

use super::{Analysis, PointError};
use plotters::prelude::*;

const WIDTH: u32 = 1200;
const ACTUAL: RGBColor = RGBColor(31, 119, 180);
const COMMANDED: RGBColor = RGBColor(255, 127, 14);
const MAXIMUM: RGBColor = RGBColor(214, 39, 40);

type Area<'a> = DrawingArea<SVGBackend<'a>, plotters::coord::Shift>;

/// The SVG document. `title` heads it (the program and trace names).
pub fn svg(a: &Analysis, title: &str) -> Result<String, String> {
    let mut out = String::new();
    {
        let root = SVGBackend::with_string(&mut out, (WIDTH, 720)).into_drawing_area();
        draw(&root, a, title).map_err(|e| format!("cannot draw the plot: {e}"))?;
        root.present()
            .map_err(|e| format!("cannot draw the plot: {e}"))?;
    }
    Ok(out)
}

/// The envelope of `len` points, `point(k)` giving the k-th as (path length, value) in
/// path order: at most two points per pixel column of `columns`, the smallest and the
/// largest value there.
fn envelope(len: usize, point: impl Fn(usize) -> (f64, f64), columns: usize) -> Vec<(f64, f64)> {
    if len == 0 {
        return Vec::new();
    }
    let (x0, x1) = (point(0).0, point(len - 1).0);
    if len <= 2 * columns || x1 <= x0 {
        return (0..len).map(point).collect();
    }
    let width = (x1 - x0) / columns as f64;
    let column = |x: f64| ((x - x0) / width).floor().min(columns as f64 - 1.0);
    let mut out = Vec::with_capacity(2 * columns + 2);
    let mut k = 0;
    while k < len {
        let first = point(k);
        let here = column(first.0);
        let (mut lo, mut hi) = (first, first);
        k += 1;
        while k < len {
            let v = point(k);
            if column(v.0) != here {
                break;
            }
            if v.1 < lo.1 {
                lo = v;
            }
            if v.1 > hi.1 {
                hi = v;
            }
            k += 1;
        }
        if lo.0 <= hi.0 {
            out.push(lo);
            if hi != lo {
                out.push(hi);
            }
        } else {
            out.push(hi);
            out.push(lo);
        }
    }
    out
}

/// One panel: where, what, its largest value and the point where it is.
struct Panel<'a, 'b> {
    area: &'a Area<'b>,
    label: &'static str,
    max: f64,
    value: fn(&PointError) -> f64,
    commanded: fn(&PointError) -> Option<f64>,
    at: usize,
}

fn draw(
    root: &Area<'_>,
    a: &Analysis,
    title: &str,
) -> Result<(), DrawingAreaErrorKind<std::io::Error>> {
    root.fill(&WHITE)?;
    let (header, body) = root.split_vertically(60);
    header.draw(&Text::new(
        title.to_string(),
        (20, 14),
        ("sans-serif", 18).into_font().color(&BLACK),
    ))?;
    let mut legend = format!(
        "blue: against the actual positions; red dot: the largest; {} points, step {:.4} mm",
        a.reported.len(),
        a.step
    );
    if a.summary.commanded.is_some() {
        legend = format!("orange: against the commanded positions; {legend}");
    }
    header.draw(&Text::new(
        legend,
        (20, 38),
        ("sans-serif", 13).into_font().color(&RGBColor(90, 90, 90)),
    ))?;
    let (top, bottom) = body.split_vertically(330);
    let along = |k: usize| a.point(k).reference.along;
    let count = a.reported.len();
    let x_start = if count > 0 { along(0) } else { 0.0 };
    let x_end = if count > 0 { along(count - 1) } else { 1.0 }.max(x_start + 1e-6);
    let panels = [
        Panel {
            area: &top,
            label: "tool-tip contour error (µm)",
            max: a.summary.tip.max * 1e3,
            value: |p| p.actual.tip * 1e3,
            commanded: |p| p.commanded.map(|c| c.tip * 1e3),
            at: a.summary.tip.at,
        },
        Panel {
            area: &bottom,
            label: "tool-axis contour error (µrad)",
            max: a.summary.axis.max * 1e6,
            value: |p| p.actual.axis * 1e6,
            commanded: |p| p.commanded.map(|c| c.axis * 1e6),
            at: a.summary.axis.at,
        },
    ];
    for Panel {
        area,
        label,
        max,
        value,
        commanded,
        at,
    } in panels
    {
        let cmd_max = a
            .points()
            .filter_map(|p| commanded(&p))
            .fold(0.0f64, f64::max);
        let y_top = (max.max(cmd_max) * 1.1).max(1e-3);
        let mut chart = ChartBuilder::on(area)
            .margin(12)
            .x_label_area_size(36)
            .y_label_area_size(64)
            .caption(label, ("sans-serif", 15))
            .build_cartesian_2d(x_start..x_end, 0.0..y_top)?;
        chart
            .configure_mesh()
            .x_desc("tool tip path along the program (mm)")
            .light_line_style(RGBColor(235, 235, 235))
            .draw()?;
        let columns = (WIDTH - 100) as usize;
        if a.summary.commanded.is_some() {
            let line = envelope(
                count,
                |k| {
                    let p = a.point(k);
                    (p.reference.along, commanded(&p).unwrap_or(0.0))
                },
                columns,
            );
            chart.draw_series(LineSeries::new(line, COMMANDED.stroke_width(1)))?;
        }
        chart.draw_series(LineSeries::new(
            envelope(
                count,
                |k| {
                    let p = a.point(k);
                    (p.reference.along, value(&p))
                },
                columns,
            ),
            ACTUAL.stroke_width(1),
        ))?;
        if at < count {
            let p = a.point(at);
            chart.draw_series(std::iter::once(Circle::new(
                (p.reference.along, value(&p)),
                4,
                MAXIMUM.filled(),
            )))?;
            // The label goes left of the dot in the right part of the plot.
            let right = p.reference.along > x_start + 0.75 * (x_end - x_start);
            chart.draw_series(std::iter::once(
                EmptyElement::at((p.reference.along, value(&p)))
                    + Text::new(
                        format!("{:.2} at line {}", value(&p), p.reference.line),
                        (if right { -130 } else { 8 }, -4),
                        ("sans-serif", 12).into_font().color(&MAXIMUM),
                    ),
            ))?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_envelope_keeps_every_peak_in_few_points() {
        let point = |k: usize| {
            let v = if k == 54_321 { 9.0 } else { (k % 7) as f64 };
            (k as f64 * 0.01, v)
        };
        let e = envelope(100_000, point, 500);
        assert!(e.len() <= 1000, "{}", e.len());
        assert!(e.contains(&(543.21, 9.0)));
        assert!(e.windows(2).all(|w| w[0].0 <= w[1].0));
        assert_eq!(e.iter().map(|p| p.1).fold(f64::INFINITY, f64::min), 0.0);
        assert_eq!(
            envelope(3, point, 500),
            [(0.0, 0.0), (0.01, 1.0), (0.02, 2.0)]
        );
    }
}
