//! The SVG polar plot: trigger radius per β ring, measured and predicted.
//!
//! Two panels side by side, as the paper's figures 6 and 7: the deviation of each
//! direction's value from the mean, drawn around a base circle against α, one closed
//! line per ring of equal β, at the same scale in both panels. Grid circles mark the mean
//! and ± one grid step. Text is written as SVG `<text>` elements (plotters' SVG backend
//! with its built-in font metrics), so no font is needed to make the file.

use super::map::DirectionMap;
use super::speeds::SpeedPlan;
use plotters::prelude::*;

/// Colours of the rings, in order of increasing β.
const PALETTE: [RGBColor; 12] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
    RGBColor(0, 0, 128),
    RGBColor(128, 0, 0),
];

/// A grid step (µm) of 1, 2 or 5 × 10^k, about a third of `max`.
fn grid_step(max: f64) -> f64 {
    let target = (max / 2.0).max(1e-6);
    let p = 10f64.powf(target.log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * p)
        .find(|&s| s >= target)
        .unwrap_or(10.0 * p)
}

/// The SVG document of the plot. `what` names the quantity ("trigger radius").
pub fn polar_svg(map: &DirectionMap, plan: &SpeedPlan, what: &str) -> Result<String, String> {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (1200, 560)).into_drawing_area();
        draw(&root, map, plan, what).map_err(|e| format!("cannot draw the plot: {e}"))?;
        root.present()
            .map_err(|e| format!("cannot draw the plot: {e}"))?;
    }
    Ok(svg)
}

type Area<'a> = DrawingArea<SVGBackend<'a>, plotters::coord::Shift>;

fn draw(
    root: &Area<'_>,
    map: &DirectionMap,
    plan: &SpeedPlan,
    what: &str,
) -> Result<(), DrawingAreaErrorKind<std::io::Error>> {
    root.fill(&WHITE)?;
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
    let (m0, m1) = (mean(&plan.before), mean(&plan.predicted));
    let dev0: Vec<f64> = plan.before.iter().map(|x| (x - m0) * 1000.0).collect();
    let dev1: Vec<f64> = plan.predicted.iter().map(|x| (x - m1) * 1000.0).collect();
    let max = dev0
        .iter()
        .chain(&dev1)
        .fold(0.0f64, |m, d| m.max(d.abs()))
        .max(1e-3);
    let step = grid_step(max);
    // Plot radius 1 is the mean; the largest deviation reaches ±0.4.
    let k = 0.4 / (step * (max / step).ceil()).max(step);
    let (header, body) = root.split_vertically(70);
    let title = format!(
        "{what}: variation {:.2} µm measured → {:.2} µm predicted; speeds {:.2} … {:.2} mm/min",
        plan.variation_before * 1000.0,
        plan.variation_after * 1000.0,
        plan.min_speed(),
        plan.max_speed()
    );
    header.draw(&Text::new(
        title,
        (20, 18),
        ("sans-serif", 20).into_font().color(&BLACK),
    ))?;
    header.draw(&Text::new(
        format!("grid circles: mean and ±{step} µm steps; α counted from +X, counter-clockwise"),
        (20, 44),
        ("sans-serif", 14).into_font().color(&RGBColor(90, 90, 90)),
    ))?;
    let (panels, legend) = body.split_horizontally(1000);
    let (left, right) = panels.split_horizontally(500);
    let betas = map.ring_betas();
    let drawn: Vec<(usize, f64)> = betas
        .iter()
        .copied()
        .enumerate()
        .filter(|&(_, b)| map.ring(b).len() >= 3)
        .collect();
    for (area, dev, label) in [
        (&left, &dev0, "measured"),
        (&right, &dev1, "predicted at the new speeds"),
    ] {
        // Equal scales in x and y, so that circles stay round.
        let (w, h) = area.dim_in_pixel();
        let margin = 30;
        let half = 1.55;
        let half_x = half * f64::from(w.saturating_sub(2 * margin))
            / f64::from(h.saturating_sub(2 * margin).max(1));
        let mut chart = ChartBuilder::on(area)
            .margin(margin)
            .build_cartesian_2d(-half_x..half_x, -half..half)?;
        // Grid: circles at the mean and ± steps, spokes every 30°.
        let n_steps = (0.4 / (k * step)).round().max(1.0) as i32;
        for j in -n_steps..=n_steps {
            let r = 1.0 + f64::from(j) * step * k;
            if r <= 0.0 {
                continue;
            }
            let colour = if j == 0 {
                RGBColor(120, 120, 120)
            } else {
                RGBColor(215, 215, 215)
            };
            chart.draw_series(std::iter::once(PathElement::new(
                circle(r),
                colour.stroke_width(1),
            )))?;
        }
        for s in 0..12 {
            let a = f64::from(s * 30).to_radians();
            let r = 1.0 + 0.45;
            chart.draw_series(std::iter::once(PathElement::new(
                vec![(0.0, 0.0), (r * a.cos(), r * a.sin())],
                RGBColor(230, 230, 230).stroke_width(1),
            )))?;
        }
        for &(ring_no, beta) in &drawn {
            let members = map.ring(beta);
            let mut line: Vec<(f64, f64)> = members
                .iter()
                .map(|&i| {
                    let a = map.points()[i].direction.alpha.to_radians();
                    let r = 1.0 + k * dev[i];
                    (r * a.cos(), r * a.sin())
                })
                .collect();
            line.push(line[0]);
            let colour = PALETTE[ring_no % PALETTE.len()];
            chart.draw_series(std::iter::once(PathElement::new(
                line,
                colour.stroke_width(2),
            )))?;
        }
        area.draw(&Text::new(
            label.to_string(),
            (20, 8),
            ("sans-serif", 16).into_font().color(&BLACK),
        ))?;
        // α labels at the ends of the spokes, every 90°.
        for (deg, dx, dy) in [(0, 4, -6), (90, -10, -18), (180, -34, -6), (270, -14, 4)] {
            let a = f64::from(deg).to_radians();
            chart.draw_series(std::iter::once(
                EmptyElement::at((1.45 * a.cos(), 1.45 * a.sin()))
                    + Text::new(
                        format!("{deg}°"),
                        (dx, dy),
                        ("sans-serif", 12).into_font().color(&RGBColor(90, 90, 90)),
                    ),
            ))?;
        }
    }
    legend.draw(&Text::new(
        "rings".to_string(),
        (10, 40),
        ("sans-serif", 14).into_font().color(&BLACK),
    ))?;
    for (row, &(ring_no, beta)) in drawn.iter().enumerate() {
        let y = 70 + 22 * row as i32;
        let colour = PALETTE[ring_no % PALETTE.len()];
        legend.draw(&PathElement::new(
            vec![(10, y), (40, y)],
            colour.stroke_width(2),
        ))?;
        legend.draw(&Text::new(
            format!("β = {beta}°"),
            (48, y - 7),
            ("sans-serif", 13).into_font().color(&BLACK),
        ))?;
    }
    Ok(())
}

/// A closed polyline approximating the circle of radius `r` about the origin.
fn circle(r: f64) -> Vec<(f64, f64)> {
    (0..=120)
        .map(|i| {
            let a = f64::from(i) * std::f64::consts::TAU / 120.0;
            (r * a.cos(), r * a.sin())
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::probe::map::MapPoint;
    use crate::probe::speeds::{SpeedOptions, equalise};

    #[test]
    fn grid_steps_are_round() {
        assert_eq!(grid_step(5.5), 5.0);
        assert_eq!(grid_step(11.0), 10.0);
        assert_eq!(grid_step(1.0), 0.5);
        assert_eq!(grid_step(0.3), 0.2);
    }

    #[test]
    fn svg_has_one_line_per_ring_and_panel() {
        let mut pts = Vec::new();
        for &b in &[0.0, 40.0] {
            for k in 0..24 {
                let a = 15.0 * f64::from(k);
                let w = 26.0 + 0.004 * (3.0 * a.to_radians()).cos() * (1.0 - b / 90.0);
                pts.push(MapPoint::new(a, b, w, 50.0));
            }
        }
        let map = DirectionMap::new(pts).unwrap();
        let plan = equalise(&map, &SpeedOptions::default()).unwrap();
        let svg = polar_svg(&map, &plan, "trigger radius").unwrap();
        assert!(svg.starts_with("<svg"), "{}", &svg[..100]);
        assert!(svg.contains("β = 40°"));
        assert!(svg.contains("variation 8.00 µm measured"));
        // Each ring is a closed line of 25 points in each panel, in its colour.
        let rings = svg.matches("<polyline").filter(|_| true).count();
        assert!(rings >= 4, "{rings}");
        let blue = svg.matches("stroke=\"#1F77B4\"").count();
        assert!(blue >= 2, "{blue}");
    }
}
