//! Tip or direction error at each compensated line, before and after compensation.

use super::{
    AFTER, BEFORE, DrawResult, Key, font, legend, line_range, no_data, notes, short, svg, wrap,
};
use crate::compensate::Sample;
use plotters::prelude::*;

/// What a plot along the program shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Along {
    /// The tool tip's distance from where it should be, µm.
    Tip,
    /// The angle between the tool's direction and the one it should have, µrad.
    Direction,
}

/// A threshold drawn across the plot, in the plot's unit, and its label.
#[derive(Debug, Clone, PartialEq)]
pub struct Limit {
    pub value: f64,
    pub label: String,
}

/// Shading of lines whose direction error is left, not corrected.
pub(super) const PLANE_SHADE: RGBColor = RGBColor(225, 225, 225);
const SINGULAR_SHADE: RGBColor = RGBColor(232, 222, 245);
const LIMIT: RGBColor = RGBColor(20, 20, 20);
/// Below this (µm or µrad) at every line, before and after, there is nothing to plot.
const FLAT: f64 = 1e-3;

/// Runs of consecutive samples for which `held` is true, as line ranges.
pub(super) fn runs(samples: &[Sample], held: impl Fn(&Sample) -> bool) -> Vec<(usize, usize)> {
    let mut out: Vec<(usize, usize)> = Vec::new();
    let mut open = false;
    for s in samples {
        match (held(s), open) {
            (true, true) => {
                if let Some(r) = out.last_mut() {
                    r.1 = s.line;
                }
            }
            (true, false) => out.push((s.line, s.line)),
            (false, _) => {}
        }
        open = held(s);
    }
    out
}

/// The notes over the direction plot: why the two lines coincide where they do.
fn held_notes(samples: &[Sample]) -> Vec<String> {
    let mut text = Vec::new();
    let planes = samples.iter().filter(|s| s.plane).count();
    let singular = samples.iter().filter(|s| s.singular && !s.plane).count();
    if planes > 0 {
        text.push(format!(
            "Grey band: {planes} line{} in a tilted working plane (PLANE, G68.2, CYCLE800). The \
             control turns the rotary axes there itself; nccomp corrects the tip with X, Y, Z \
             but cannot correct the direction, so the blue line lies on the red one (red dashes \
             over blue). To correct the direction too, program these lines under \
             tool-centre-point control (M128, FUNCTION TCPM, G43.4), where nccomp writes \
             corrected rotary words.",
            if planes == 1 { "" } else { "s" }
        ));
    }
    if singular > 0 {
        text.push(format!(
            "Violet band: {singular} line{} at a singular pose (the tool along a rotary axis): \
             that axis is held at its programmed value and the direction error about it \
             stays.",
            if singular == 1 { "" } else { "s" }
        ));
    }
    text.iter().flat_map(|t| wrap(t, 165)).collect()
}

/// Tip or direction error at each compensated line, before and after compensation, on a
/// logarithmic scale (the two differ by orders of magnitude), with `limit` across it.
pub fn along_program(
    samples: &[Sample],
    what: Along,
    limit: Option<&Limit>,
) -> Result<String, String> {
    let (title, unit, scale) = match what {
        Along::Tip => ("Predicted tool-tip error along the program", "µm", 1e3),
        Along::Direction => (
            "Predicted tool-direction error along the program",
            "µrad",
            1e6,
        ),
    };
    let series = |after: bool| -> Vec<(f64, f64)> {
        samples
            .iter()
            .map(|s| {
                let v = match (what, after) {
                    (Along::Tip, false) => s.before_position,
                    (Along::Tip, true) => s.after_position,
                    (Along::Direction, false) => s.before_direction,
                    (Along::Direction, true) => s.after_direction,
                };
                (s.line as f64, v * scale)
            })
            .collect()
    };
    let (before, after) = (series(false), series(true));
    // Decades from below the smallest non-zero value (at most 1e-4 of the unit: values
    // under the solver's resolution are drawn at the bottom) to above the largest and the
    // limit.
    let max = before.iter().chain(&after).map(|p| p.1).fold(0.0, f64::max);
    let min = before
        .iter()
        .chain(&after)
        .map(|p| p.1)
        .filter(|&v| v > 0.0)
        .fold(f64::INFINITY, f64::min);
    let reach = limit.map_or(max, |l| max.max(l.value));
    let top = 10f64.powf((reach.max(1e-3) * 1.5).log10().ceil());
    let bottom = 10f64
        .powf(min.min(top / 10.0).log10().floor())
        .max(1e-4)
        .min(top / 10.0);
    let clamp = |v: &[(f64, f64)]| -> Vec<(f64, f64)> {
        v.iter().map(|&(x, y)| (x, y.max(bottom))).collect()
    };
    if !samples.is_empty() && max < FLAT {
        // A plot of nothing on a scale of thousandths says nothing: a sentence does.
        let what = match what {
            Along::Tip => "tool-tip",
            Along::Direction => "tool-direction",
        };
        let text = format!(
            "{title}: under {} {unit} at every line, without compensation and with it: the \
             error model predicts no {what} error for this program, and there is nothing to \
             correct.",
            short(FLAT)
        );
        let lines = wrap(&text, 130);
        return svg((1100, 12 + 22 * lines.len() as u32), |root| {
            notes(root, &lines, (12, 8), 16)
        });
    }
    let mut header = vec![title.to_string()];
    let held = match what {
        Along::Direction => held_notes(samples),
        Along::Tip => Vec::new(),
    };
    header.extend(held);
    let head = 34 + 18 * (header.len() as u32 - 1) + 6;
    svg((1100, 360 + head), |root| {
        if samples.is_empty() {
            return no_data(root, title);
        }
        let (top_area, body) = root.split_vertically(head);
        top_area.draw(&Text::new(header[0].clone(), (12, 8), font(17)))?;
        notes(&top_area, &header[1..], (12, 34), 14)?;
        let mut chart = ChartBuilder::on(&body)
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d(line_range(samples), (bottom..top).log_scale())?;
        chart
            .configure_mesh()
            .x_desc("program line")
            .y_desc(unit)
            .x_label_formatter(&|x| format!("{x:.0}"))
            .y_label_formatter(&|y| short(*y))
            .label_style(font(12))
            .draw()?;
        if what == Along::Direction {
            shade(&mut chart, samples, bottom, top)?;
        }
        for (points, colour) in [(clamp(&before), BEFORE), (clamp(&after), AFTER)] {
            chart.draw_series(LineSeries::new(points, colour.stroke_width(2)))?;
        }
        if what == Along::Direction {
            // Where the direction is left as it is, the blue line covers the red: the red
            // is drawn again over it, dashed, so both show.
            let red = clamp(&before);
            for (a, b) in runs(samples, |s| s.plane || s.singular) {
                let part: Vec<(f64, f64)> = red
                    .iter()
                    .copied()
                    .filter(|p| p.0 >= a as f64 && p.0 <= b as f64)
                    .collect();
                chart.draw_series(DashedLineSeries::new(part, 6, 6, BEFORE.stroke_width(2)))?;
            }
        }
        let mut keys = vec![
            Key {
                label: "without compensation".into(),
                colour: BEFORE,
                dashed: false,
            },
            Key {
                label: "compensated".into(),
                colour: AFTER,
                dashed: false,
            },
        ];
        if let Some(l) = limit {
            let range = line_range(samples);
            chart.draw_series(DashedLineSeries::new(
                [(range.start, l.value), (range.end, l.value)],
                10,
                5,
                LIMIT.stroke_width(1),
            ))?;
            keys.push(Key {
                label: l.label.clone(),
                colour: LIMIT,
                dashed: true,
            });
        }
        legend(&top_area, &keys, 1088, 17)
    })
}

type LogChart<'a, 'b> = ChartContext<
    'a,
    SVGBackend<'b>,
    Cartesian2d<
        plotters::coord::types::RangedCoordf64,
        plotters::coord::combinators::LogCoord<f64>,
    >,
>;

/// Bands behind the lines whose direction error is left: grey for tilted working planes,
/// violet for singular poses.
fn shade(
    chart: &mut LogChart<'_, '_>,
    samples: &[Sample],
    bottom: f64,
    top: f64,
) -> DrawResult<()> {
    for (held, colour) in [
        (
            &(|s: &Sample| s.plane) as &dyn Fn(&Sample) -> bool,
            PLANE_SHADE,
        ),
        (&|s: &Sample| s.singular && !s.plane, SINGULAR_SHADE),
    ] {
        chart.draw_series(runs(samples, held).into_iter().map(|(a, b)| {
            Rectangle::new(
                [(a as f64 - 0.5, bottom), (b as f64 + 0.5, top)],
                colour.filled(),
            )
        }))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn s(line: usize, plane: bool) -> Sample {
        Sample {
            line,
            plane,
            ..Sample::default()
        }
    }

    #[test]
    fn runs_join_consecutive_samples() {
        let samples = [s(1, true), s(3, true), s(4, false), s(7, true)];
        assert_eq!(runs(&samples, |s| s.plane), vec![(1, 3), (7, 7)]);
        assert!(runs(&[], |s: &Sample| s.plane).is_empty());
    }
}
