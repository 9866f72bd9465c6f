//! The correction nccomp writes, per axis, along the program.

use super::{
    AXIS_COLOURS, Area, DrawResult, Key, font, legend, line_range, no_data, notes, short, svg, wrap,
};
use crate::compensate::Sample;
use crate::model::AxisKind;
use plotters::prelude::*;

/// Below this (µm or µrad) a panel would show rounding noise on an absurd scale: it is
/// replaced by a sentence saying there is no correction.
const FLAT: f64 = 1e-3;
const PANEL: u32 = 320;
const NOTE_HEIGHT: u32 = 22;

/// One panel: a kind of axis, its unit and scale, and its series.
struct Panel<'a> {
    kind: AxisKind,
    unit: &'static str,
    series: Vec<(usize, Vec<(f64, f64)>)>,
    extent: f64,
    axes: &'a [(String, AxisKind)],
}

impl Panel<'_> {
    fn names(&self) -> String {
        self.series
            .iter()
            .map(|(v, _)| self.axes[*v].0.as_str())
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// Why a panel is empty, for a process engineer: in a tilted working plane the rotary
    /// axes are the control's; elsewhere the correction rounded to nothing.
    fn flat_note(&self, samples: &[Sample]) -> String {
        let names = self.names();
        let planes = samples.iter().filter(|s| s.plane).count();
        let what = match self.kind {
            AxisKind::Linear => "linear",
            AxisKind::Rotary => "rotary",
        };
        let why = if self.kind == AxisKind::Rotary && planes == samples.len() {
            ": every compensated line is in a tilted working plane, where the control turns \
             the rotary axes itself (nccomp corrects the tip with the linear axes)"
                .to_string()
        } else if self.kind == AxisKind::Rotary && planes > 0 {
            format!(
                " ({planes} of {} lines are in tilted working planes, where the control turns \
                 the rotary axes itself)",
                samples.len()
            )
        } else {
            String::new()
        };
        format!(
            "No {what} correction: {names} written as programmed at every line (under {} {}){why}.",
            short(FLAT),
            self.unit
        )
    }
}

/// The correction nccomp writes (written minus programmed value) for every axis at each
/// compensated line: linear axes in µm, rotary axes in µrad, in two panels; a kind of axis
/// with no correction anywhere gets a sentence instead of a flat line.
pub fn corrections(samples: &[Sample], axes: &[(String, AxisKind)]) -> Result<String, String> {
    let panels: Vec<Panel<'_>> = [AxisKind::Linear, AxisKind::Rotary]
        .into_iter()
        .filter(|k| axes.iter().any(|a| a.1 == *k))
        .map(|kind| {
            let (unit, scale) = match kind {
                AxisKind::Linear => ("µm", 1e3),
                AxisKind::Rotary => ("µrad", std::f64::consts::PI / 180.0 * 1e6),
            };
            let series: Vec<(usize, Vec<(f64, f64)>)> = axes
                .iter()
                .enumerate()
                .filter(|(_, a)| a.1 == kind)
                .map(|(v, _)| {
                    let points = samples
                        .iter()
                        .filter(|s| s.written.len() > v && s.nominal.len() > v)
                        .map(|s| (s.line as f64, (s.written[v] - s.nominal[v]) * scale))
                        .collect();
                    (v, points)
                })
                .collect();
            let extent = series
                .iter()
                .flat_map(|(_, p)| p.iter().map(|q| q.1.abs()))
                .filter(|v| v.is_finite())
                .fold(0.0, f64::max);
            Panel {
                kind,
                unit,
                series,
                extent,
                axes,
            }
        })
        .collect();
    let flat: Vec<Vec<String>> = panels
        .iter()
        .map(|p| {
            if p.extent < FLAT {
                wrap(&p.flat_note(samples), 155)
            } else {
                Vec::new()
            }
        })
        .collect();
    let heights: Vec<u32> = panels
        .iter()
        .zip(&flat)
        .map(|(p, f)| {
            if p.extent < FLAT {
                NOTE_HEIGHT * f.len().max(1) as u32 + 8
            } else {
                PANEL
            }
        })
        .collect();
    let planes = samples.iter().filter(|s| s.plane).count();
    // Rotary corrections drawn, and lines where they are the control's: say why those are 0.
    let plane_note = (planes > 0
        && panels
            .iter()
            .any(|p| p.kind == AxisKind::Rotary && p.extent >= FLAT))
    .then(|| {
        format!(
            "Rotary axes: no correction in the {planes} lines in tilted working planes (grey), \
             where the control turns them itself."
        )
    });
    let head = if plane_note.is_some() { 58 } else { 40 };
    let height = head + heights.iter().sum::<u32>().max(PANEL);
    svg((1100, height), |root| {
        let title = "Correction per axis along the program (written minus programmed)";
        if samples.is_empty() {
            return no_data(root, title);
        }
        let (header, mut rest) = root.split_vertically(head);
        header.draw(&Text::new(title, (12, 12), font(17)))?;
        let keys: Vec<Key> = panels
            .iter()
            .filter(|p| p.extent >= FLAT)
            .flat_map(|p| &p.series)
            .map(|(v, _)| Key {
                label: axes[*v].0.clone(),
                colour: AXIS_COLOURS[v % AXIS_COLOURS.len()],
                dashed: false,
            })
            .collect();
        legend(&header, &keys, 1088, 21)?;
        if let Some(note) = &plane_note {
            notes(&header, std::slice::from_ref(note), (12, 38), 14)?;
        }
        for ((panel, note), h) in panels.iter().zip(&flat).zip(&heights) {
            let (area, below) = rest.split_vertically(*h);
            if note.is_empty() {
                draw_panel(&area, panel, samples)?;
            } else {
                notes(&area, note, (24, 4), 15)?;
            }
            rest = below;
        }
        Ok(())
    })
}

fn draw_panel(area: &Area<'_>, panel: &Panel<'_>, samples: &[Sample]) -> DrawResult<()> {
    let extent = panel.extent * 1.1;
    let what = match panel.kind {
        AxisKind::Linear => "linear axes",
        AxisKind::Rotary => "rotary axes",
    };
    let mut chart = ChartBuilder::on(area)
        .margin(12)
        .x_label_area_size(36)
        .y_label_area_size(70)
        .build_cartesian_2d(line_range(samples), -extent..extent)?;
    chart
        .configure_mesh()
        .x_desc("program line")
        .y_desc(format!("{what}, {}", panel.unit))
        .x_label_formatter(&|x| format!("{x:.0}"))
        .y_label_formatter(&|y| short(*y))
        .label_style(font(12))
        .draw()?;
    if panel.kind == AxisKind::Rotary {
        // The lines in tilted working planes, grey as in the direction plot: the rotary
        // axes are the control's there.
        let shade = super::along::PLANE_SHADE;
        chart.draw_series(
            super::along::runs(samples, |s| s.plane)
                .into_iter()
                .map(|(a, b)| {
                    Rectangle::new(
                        [(a as f64 - 0.5, -extent), (b as f64 + 0.5, extent)],
                        shade.filled(),
                    )
                }),
        )?;
    }
    for (v, points) in &panel.series {
        let colour = AXIS_COLOURS[v % AXIS_COLOURS.len()];
        chart.draw_series(LineSeries::new(points.clone(), colour.stroke_width(2)))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_kind_of_axis_without_correction_gets_a_sentence_not_a_flat_line() {
        let axes = vec![
            ("X".to_string(), AxisKind::Linear),
            ("A".to_string(), AxisKind::Rotary),
        ];
        let samples: Vec<Sample> = (1..20)
            .map(|line| Sample {
                line,
                nominal: vec![line as f64, -30.0],
                written: vec![line as f64 + 0.004, -30.0],
                plane: true,
                ..Sample::default()
            })
            .collect();
        let svg = corrections(&samples, &axes).unwrap();
        assert!(
            svg.contains("No rotary correction: A written as programmed"),
            "{svg}"
        );
        assert!(svg.contains("every compensated line is in a tilted working plane"));
        // The linear panel is drawn, on a scale of its own values (4 µm), with round ticks.
        assert!(svg.contains("linear axes, µm"));
        assert!(!svg.contains("rotary axes, µrad"));
        assert!(!svg.contains(">0.0002<") && !svg.contains(">-0.001<"));
    }
}
