//! A volumetric error map: panels over two linear axes, a colour bar on round ticks.

use super::super::volume::{Map, Panel};
use super::{Area, DrawResult, font, notes, ramp, round_scale, short, svg};
use plotters::prelude::*;

const SIDE: u32 = 380;
const BAR: u32 = 110;
/// Below this largest error (mm) a map is one colour: it is replaced by a sentence.
const FLAT_MM: f64 = 1e-6;

/// One map: a panel per level of the third linear axis, coloured by the length of the tip
/// error on a round scale from 0 to at least `max` (mm, the largest of all maps, so that
/// they compare), with arrows for its components along the grid axes, the part's extent
/// as a dashed box, and a colour bar.
pub fn map(map: &Map, max: f64) -> Result<String, String> {
    if max.is_nan() || max < FLAT_MM {
        // One colour on a scale of nothing: a sentence says it.
        let at = if map.label.is_empty() {
            String::new()
        } else {
            format!(" at {}", map.label)
        };
        return svg((1100, 40), |root| {
            notes(
                root,
                &[format!(
                    "The error model predicts no tip error{at} over this grid of {} and {} (under {} µm everywhere).",
                    map.u.name,
                    map.v.name,
                    short(FLAT_MM * 1e3)
                )],
                (12, 10),
                16,
            )
        });
    }
    let (top, step) = round_scale(max * 1e3);
    let scale = top / 1e3;
    // At least as wide as the other plots, so that the notes fit whatever the panels.
    let width = (SIDE * map.panels.len() as u32 + BAR).max(1100);
    let longest = map
        .panels
        .iter()
        .flat_map(|p| p.along.iter().map(|a| a[0].hypot(a[1])))
        .filter(|v| v.is_finite())
        .fold(0.0, f64::max);
    let at = if map.label.is_empty() {
        String::new()
    } else {
        format!("{}: ", map.label)
    };
    let mut text = format!(
        "Colour: its length; arrows: its {}–{} components (longest {} µm).",
        map.u.name,
        map.v.name,
        short(longest * 1e3)
    );
    if let Some(over) = part_range(map) {
        text.push_str(&format!(
            " Dashed box: the part (the span of {} and {} in the feed moves). {over}",
            map.u.name, map.v.name
        ));
    }
    // 13 px notes: about 5.8 px a character.
    let lines = super::wrap(&text, (width as usize - 24) * 10 / 58);
    let head = 34 + 17 * lines.len() as u32 + 6;
    svg((width, SIDE + 10 + head), |root| {
        let (header, body) = root.split_vertically(head);
        header.draw(&Text::new(
            format!(
                "{at}tip error without compensation over {} and {}",
                map.u.name, map.v.name
            ),
            (12, 10),
            font(17),
        ))?;
        notes(&header, &lines, (12, 34), 13)?;
        let (panels, legend) = body.split_horizontally(SIDE * map.panels.len() as u32);
        let areas = panels.split_evenly((1, map.panels.len()));
        for (area, panel) in areas.iter().zip(&map.panels) {
            draw_panel(area, map, panel, scale, longest)?;
        }
        colour_bar(&legend, top, step)
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
    let (Some(&u_first), Some(&u_last), Some(&v_first), Some(&v_last)) =
        (us.first(), us.last(), vs.first(), vs.last())
    else {
        return Ok(());
    };
    let half = |p: &[f64]| {
        if p.len() > 1 {
            (p[p.len() - 1] - p[0]) / (p.len() - 1) as f64 / 2.0
        } else {
            1.0
        }
    };
    let (hu, hv) = (half(us), half(vs));
    let (u0, u1) = (u_first - hu, u_last + hu);
    let (v0, v1) = (v_first - hv, v_last + hv);
    let caption = match (&panel.level, panel.role) {
        (Some((name, z)), Some(role)) => format!("{name} = {} mm ({role} of the part)", short(*z)),
        (Some((name, z)), None) => format!("{name} = {} mm", short(*z)),
        (None, _) => String::new(),
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
        let (u, v) = (us[k % n], vs[(k / n).min(vs.len() - 1)]);
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
        let (u, v) = (us[k % n], vs[(k / n).min(vs.len() - 1)]);
        let length = a[0].hypot(a[1]);
        if longest <= 0.0 || length <= longest * 0.02 || !length.is_finite() {
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
    if let Some([[a, b], [c, d]]) = map.part {
        // The part's extent, dashed white on black so it shows on every colour.
        let outline = [(a, c), (b, c), (b, d), (a, d), (a, c)];
        chart.draw_series(std::iter::once(PathElement::new(
            outline.to_vec(),
            BLACK.stroke_width(4),
        )))?;
        chart.draw_series(DashedLineSeries::new(outline, 8, 6, WHITE.stroke_width(2)))?;
    }
    Ok(())
}

/// The error's range over the part's box and over the whole grid, all panels: where on
/// the table the part sits against the error field.
fn part_range(map: &Map) -> Option<String> {
    let [[a, b], [c, d]] = map.part?;
    let n = map.u.positions.len();
    if n == 0 || map.v.positions.is_empty() {
        return None;
    }
    let (mut inside, mut all) = ((f64::INFINITY, 0.0f64), (f64::INFINITY, 0.0f64));
    for p in &map.panels {
        for (k, &m) in p.magnitude.iter().enumerate() {
            if !m.is_finite() {
                continue;
            }
            let (u, v) = (
                map.u.positions[k % n],
                map.v.positions[(k / n).min(map.v.positions.len() - 1)],
            );
            all = (all.0.min(m), all.1.max(m));
            if (a..=b).contains(&u) && (c..=d).contains(&v) {
                inside = (inside.0.min(m), inside.1.max(m));
            }
        }
    }
    let um = |v: f64| short(v * 1e3);
    let whole = format!("{} to {} µm over the whole map", um(all.0), um(all.1));
    Some(if inside.0.is_finite() {
        format!(
            "Over the part's grid points {} to {} µm, {whole}.",
            um(inside.0),
            um(inside.1)
        )
    } else {
        format!("{whole}; no grid point falls in the part's box.")
    })
}

/// The colour bar, 0 … `top` µm, ticks every `step` µm (round values).
fn colour_bar(area: &Area<'_>, top_um: f64, step: f64) -> DrawResult<()> {
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
    // The unit first: a reader of the page's text meets it before the numbers.
    area.draw(&Text::new("µm", (14, top - 20), font(12)))?;
    let ticks = (top_um / step).round().clamp(1.0, 10.0) as i32;
    for k in 0..=ticks {
        let value = step * f64::from(k);
        let y = bottom - ((f64::from(bottom - top)) * value / top_um).round() as i32;
        area.draw(&PathElement::new(vec![(34, y), (38, y)], BLACK))?;
        area.draw(&Text::new(short(value), (40, y - 6), font(11)))?;
    }
    Ok(())
}
