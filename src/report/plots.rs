//! The report's SVG plots (plotters' SVG backend; text as SVG `<text>` elements, so no
//! font is needed to make them).

use super::volume::{Map, Panel};
use crate::compensate::Sample;
use crate::model::AxisKind;
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
fn short(v: f64) -> String {
    if v == 0.0 {
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

/// What a plot along the program shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Along {
    /// The tool tip's distance from where it should be, µm.
    Tip,
    /// The angle between the tool's direction and the one it should have, µrad.
    Direction,
}

/// Tip or direction error at each compensated line, before and after compensation, on a
/// logarithmic scale (the two differ by orders of magnitude).
pub fn along_program(samples: &[Sample], what: Along) -> Result<String, String> {
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
    // under the solver's resolution are drawn at the bottom) to above the largest.
    let max = before.iter().chain(&after).map(|p| p.1).fold(0.0, f64::max);
    let min = before
        .iter()
        .chain(&after)
        .map(|p| p.1)
        .filter(|&v| v > 0.0)
        .fold(f64::INFINITY, f64::min);
    let top = 10f64.powf((max.max(1e-3) * 1.5).log10().ceil());
    let bottom = 10f64
        .powf(min.min(top / 10.0).log10().floor())
        .max(1e-4)
        .min(top / 10.0);
    let clamp = |v: Vec<(f64, f64)>| -> Vec<(f64, f64)> {
        v.into_iter().map(|(x, y)| (x, y.max(bottom))).collect()
    };
    let caption = if max > 0.0 {
        title.to_string()
    } else {
        format!("{title}: zero at every line")
    };
    svg((1100, 380), |root| {
        if samples.is_empty() {
            return no_data(root, title);
        }
        let mut chart = ChartBuilder::on(root)
            .caption(caption, font(18))
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
        for (points, colour, label) in [
            (clamp(before), BEFORE, "without compensation"),
            (clamp(after), AFTER, "compensated"),
        ] {
            chart
                .draw_series(LineSeries::new(points, colour.stroke_width(2)))?
                .label(label)
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2))
                });
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font(font(13))
            .draw()
    })
}

/// The correction nccomp writes (written minus programmed value) for every axis at each
/// compensated line: linear axes in µm, rotary axes in µrad, in two panels.
pub fn corrections(samples: &[Sample], axes: &[(String, AxisKind)]) -> Result<String, String> {
    let kinds: Vec<AxisKind> = [AxisKind::Linear, AxisKind::Rotary]
        .into_iter()
        .filter(|k| axes.iter().any(|a| a.1 == *k))
        .collect();
    let height = 60 + 320 * kinds.len().max(1) as u32;
    svg((1100, height), |root| {
        let title = "Correction per axis along the program (written minus programmed)";
        if samples.is_empty() {
            return no_data(root, title);
        }
        let (header, body) = root.split_vertically(40);
        header.draw(&Text::new(title, (12, 12), font(18)))?;
        let panels = body.split_evenly((kinds.len().max(1), 1));
        for (area, &kind) in panels.iter().zip(&kinds) {
            let (unit, scale) = match kind {
                AxisKind::Linear => ("linear axes, µm", 1e3),
                AxisKind::Rotary => ("rotary axes, µrad", std::f64::consts::PI / 180.0 * 1e6),
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
                .fold(0.0, f64::max)
                .max(1e-3)
                * 1.1;
            let mut chart = ChartBuilder::on(area)
                .margin(12)
                .x_label_area_size(36)
                .y_label_area_size(70)
                .build_cartesian_2d(line_range(samples), -extent..extent)?;
            chart
                .configure_mesh()
                .x_desc("program line")
                .y_desc(unit)
                .x_label_formatter(&|x| format!("{x:.0}"))
                .y_label_formatter(&|y| short(*y))
                .label_style(font(12))
                .draw()?;
            for (v, points) in series {
                let colour = AXIS_COLOURS[v % AXIS_COLOURS.len()];
                chart
                    .draw_series(LineSeries::new(points, colour.stroke_width(2)))?
                    .label(axes[v].0.clone())
                    .legend(move |(x, y)| {
                        PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2))
                    });
            }
            chart
                .configure_series_labels()
                .position(SeriesLabelPosition::UpperRight)
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK)
                .label_font(font(13))
                .draw()?;
        }
        Ok(())
    })
}

/// One map: a panel per level of the third linear axis, coloured by the length of the tip
/// error on the scale 0 … `scale` (mm, shared by all maps), with arrows for its components
/// along the grid axes, and a colour bar.
pub fn map(map: &Map, scale: f64) -> Result<String, String> {
    let side = 380u32;
    let bar = 110u32;
    let width = side * map.panels.len() as u32 + bar;
    svg((width, side + 70), |root| {
        let longest = map
            .panels
            .iter()
            .flat_map(|p| p.along.iter().map(|a| a[0].hypot(a[1])))
            .fold(0.0, f64::max);
        let at = if map.label.is_empty() {
            String::new()
        } else {
            format!("{}: ", map.label)
        };
        let (header, body) = root.split_vertically(60);
        header.draw(&Text::new(
            format!(
                "{at}tip error without compensation over {} and {}",
                map.u.name, map.v.name
            ),
            (12, 10),
            font(17),
        ))?;
        header.draw(&Text::new(
            format!(
                "colour: its length; arrows: its {}–{} components (longest {} µm)",
                map.u.name,
                map.v.name,
                short(longest * 1e3)
            ),
            (12, 34),
            font(13).color(&RGBColor(80, 80, 80)),
        ))?;
        let (panels, legend) = body.split_horizontally(side * map.panels.len() as u32);
        let areas = panels.split_evenly((1, map.panels.len()));
        for (area, panel) in areas.iter().zip(&map.panels) {
            draw_panel(area, map, panel, scale, longest)?;
        }
        colour_bar(&legend, scale)
    })
}

fn draw_panel(
    area: &Area<'_>,
    map: &Map,
    panel: &Panel,
    scale: f64,
    longest: f64,
) -> DrawResult<()> {
    let (us, vs) = (&map.u.positions, &map.v.positions);
    let half = |p: &[f64]| {
        if p.len() > 1 {
            (p[p.len() - 1] - p[0]) / (p.len() - 1) as f64 / 2.0
        } else {
            1.0
        }
    };
    let (hu, hv) = (half(us), half(vs));
    let (u0, u1) = (us[0] - hu, us[us.len() - 1] + hu);
    let (v0, v1) = (vs[0] - hv, vs[vs.len() - 1] + hv);
    let caption = match &panel.level {
        Some((name, z)) => format!("{name} = {} mm", short(*z)),
        None => String::new(),
    };
    let mut chart = ChartBuilder::on(area)
        .caption(caption, font(14))
        .margin(8)
        .x_label_area_size(34)
        .y_label_area_size(52)
        .build_cartesian_2d(u0..u1, v0..v1)?;
    chart
        .configure_mesh()
        .disable_mesh()
        .x_desc(format!("{} (mm)", map.u.name))
        .y_desc(format!("{} (mm)", map.v.name))
        .x_label_formatter(&|x| short(*x))
        .y_label_formatter(&|y| short(*y))
        .label_style(font(11))
        .draw()?;
    let n = us.len();
    chart.draw_series(panel.magnitude.iter().enumerate().map(|(k, &m)| {
        let (u, v) = (us[k % n], vs[k / n]);
        Rectangle::new(
            [(u - hu, v - hv), (u + hu, v + hv)],
            ramp(m / scale.max(1e-12)).filled(),
        )
    }))?;
    // Arrows: the longest is 0.9 of a cell diagonal step; heads in pixel space so they
    // keep their shape whatever the aspect of the ranges.
    let (pw, ph) = chart.plotting_area().dim_in_pixel();
    let (sx, sy) = (f64::from(pw) / (u1 - u0), f64::from(ph) / (v1 - v0));
    let reach = 1.8 * hu.min(hv);
    for (k, a) in panel.along.iter().enumerate() {
        let (u, v) = (us[k % n], vs[k / n]);
        let length = a[0].hypot(a[1]);
        if longest <= 0.0 || length <= longest * 0.02 {
            continue;
        }
        let (du, dv) = (a[0] / longest * reach, a[1] / longest * reach);
        let tip = (u + du, v + dv);
        // Unit direction in pixels.
        let (px, py) = (du * sx, dv * sy);
        let norm = px.hypot(py).max(1e-9);
        let (ex, ey) = (px / norm, py / norm);
        let head = 5.0;
        let wing = |s: f64| {
            let (c, sn) = (150f64.to_radians().cos(), s * 150f64.to_radians().sin());
            let (rx, ry) = (ex * c - ey * sn, ex * sn + ey * c);
            (tip.0 + rx * head / sx, tip.1 + ry * head / sy)
        };
        let path = vec![(u, v), tip, wing(1.0), tip, wing(-1.0)];
        chart.draw_series([
            PathElement::new(path.clone(), BLACK.stroke_width(3)),
            PathElement::new(path, WHITE.stroke_width(1)),
        ])?;
    }
    Ok(())
}

fn colour_bar(area: &Area<'_>, scale: f64) -> DrawResult<()> {
    let (_, h) = area.dim_in_pixel();
    let (top, bottom) = (30i32, h as i32 - 40);
    let steps = 60;
    for k in 0..steps {
        let y0 = bottom - (bottom - top) * (k + 1) / steps;
        let y1 = bottom - (bottom - top) * k / steps;
        area.draw(&Rectangle::new(
            [(14, y0), (34, y1)],
            ramp((f64::from(k) + 0.5) / f64::from(steps)).filled(),
        ))?;
    }
    area.draw(&Rectangle::new(
        [(14, top), (34, bottom)],
        BLACK.stroke_width(1),
    ))?;
    for k in 0..=4 {
        let y = bottom - (bottom - top) * k / 4;
        area.draw(&Text::new(
            short(scale * 1e3 * f64::from(k) / 4.0),
            (40, y - 6),
            font(11),
        ))?;
    }
    area.draw(&Text::new("µm", (14, top - 20), font(12)))
}
