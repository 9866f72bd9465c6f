//! The delay τ between trigger and latch, from trigger radii at several constant speeds.
//!
//! With `r = r0 + s·v·τ` (s = +1 on an inside surface such as a ring gauge, −1 on an
//! outside one such as a sphere), τ is the magnitude of the slope of the least-squares
//! line of radius on speed, and the slope's sign tells the kind of surface.
//! When the rows say in which direction each radius was taken, the fit keeps one
//! intercept per direction and a common slope, so the probe's lobing (the same at every
//! speed) drops out of the residuals instead of inflating τ's uncertainty.
//!
//! Ring-gauge data (CSV, header required, columns in any order):
//!
//! | column      | unit   | meaning                                                    |
//! |-------------|--------|------------------------------------------------------------|
//! | `speed`     | mm/min | the constant probing speed                                 |
//! | `radius`    | mm     | a trigger radius (one point) or a fitted ring radius       |
//! | `direction` | any    | optional: a label of the direction (e.g. its α in degrees) |

use super::csvio::{Row, read_rows};
use super::{Surface, positive};
use crate::diag::Error;
use serde::Deserialize;

/// One row of ring-gauge data.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RingPoint {
    /// mm/min.
    pub speed: f64,
    /// mm.
    pub radius: f64,
    /// The direction label, when the file has a `direction` column.
    pub direction: Option<f64>,
}

#[derive(Debug, Deserialize)]
struct RingRow {
    speed: f64,
    radius: f64,
    direction: Option<f64>,
}

/// The mean radius at one speed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpeedLevel {
    pub speed: f64,
    pub count: usize,
    pub mean_radius: f64,
}

/// The fitted delay.
#[derive(Debug, Clone, PartialEq)]
pub struct DelayFit {
    /// τ, ms.
    pub tau_ms: f64,
    /// Standard uncertainty of τ from the fit (k = 1), ms.
    pub u_tau_ms: f64,
    /// The surface the slope's sign says the radii were measured on.
    pub surface: Surface,
    /// Slope of radius on speed as measured, mm per mm/min (minutes).
    pub slope: f64,
    /// The fitted radius at speed 0, mm (the mean over directions when there are several).
    pub intercept: f64,
    pub points: usize,
    /// Directions with their own intercept (1 without a `direction` column).
    pub groups: usize,
    /// Degrees of freedom of the residuals.
    pub dof: usize,
    /// Standard deviation of the residuals, mm.
    pub residual_std: f64,
    /// The speeds, in increasing order, with their mean radii.
    pub speeds: Vec<SpeedLevel>,
}

/// Fit τ to `points`. With `expect`, the slope's sign must match that kind of surface.
/// The error says what is wrong with the data as a whole (too few points, one speed, a
/// slope of the wrong sign).
pub fn fit_delay(points: &[RingPoint], expect: Option<Surface>) -> Result<DelayFit, String> {
    let n = points.len();
    // Groups: one per direction label, or one for all.
    let mut keys: Vec<u64> = Vec::new();
    let mut group_of = Vec::with_capacity(n);
    for p in points {
        let key = p.direction.map_or(0, |d| (d + 0.0).to_bits());
        let g = match keys.iter().position(|&k| k == key) {
            Some(g) => g,
            None => {
                keys.push(key);
                keys.len() - 1
            }
        };
        group_of.push(g);
    }
    let groups = keys.len().max(1);
    let mut speeds: Vec<SpeedLevel> = Vec::new();
    for p in points {
        match speeds
            .iter_mut()
            .find(|s| (s.speed - p.speed).abs() <= 1e-9 * p.speed.abs().max(1.0))
        {
            Some(s) => {
                s.count += 1;
                s.mean_radius += p.radius;
            }
            None => speeds.push(SpeedLevel {
                speed: p.speed,
                count: 1,
                mean_radius: p.radius,
            }),
        }
    }
    for s in &mut speeds {
        s.mean_radius /= s.count as f64;
    }
    speeds.sort_by(|a, b| a.speed.total_cmp(&b.speed));
    if let Some(p) = points.iter().find(|p| p.speed <= 0.0) {
        return Err(format!(
            "a speed of {} mm/min: speeds must be positive",
            p.speed
        ));
    }
    if n < groups + 2 {
        return Err(format!(
            "too few points to fit τ: {n} row{}{}; at least {} are needed, at two speeds or more",
            if n == 1 { "" } else { "s" },
            if groups > 1 {
                format!(" in {groups} directions")
            } else {
                String::new()
            },
            groups + 2
        ));
    }
    if speeds.len() < 2 {
        return Err(format!(
            "every row is at {} mm/min: τ needs radii measured at two speeds or more",
            speeds[0].speed
        ));
    }
    // Group means.
    let mut sum_v = vec![0.0; groups];
    let mut sum_r = vec![0.0; groups];
    let mut count = vec![0usize; groups];
    for (p, &g) in points.iter().zip(&group_of) {
        sum_v[g] += p.speed;
        sum_r[g] += p.radius;
        count[g] += 1;
    }
    let mean_v: Vec<f64> = (0..groups).map(|g| sum_v[g] / count[g] as f64).collect();
    let mean_r: Vec<f64> = (0..groups).map(|g| sum_r[g] / count[g] as f64).collect();
    let (mut sxx, mut sxy) = (0.0, 0.0);
    for (p, &g) in points.iter().zip(&group_of) {
        let dv = p.speed - mean_v[g];
        sxx += dv * dv;
        sxy += dv * (p.radius - mean_r[g]);
    }
    if !positive(sxx) {
        return Err(
            "no direction was measured at two speeds or more: τ needs the same direction at several speeds"
                .into(),
        );
    }
    let slope = sxy / sxx;
    let mut ssr = 0.0;
    for (p, &g) in points.iter().zip(&group_of) {
        let e = p.radius - mean_r[g] - slope * (p.speed - mean_v[g]);
        ssr += e * e;
    }
    let dof = n - groups - 1;
    let residual_std = (ssr / dof as f64).sqrt();
    let u_slope = residual_std / sxx.sqrt();
    let intercept = (0..groups)
        .map(|g| mean_r[g] - slope * mean_v[g])
        .sum::<f64>()
        / groups as f64;
    let surface = if slope >= 0.0 {
        Surface::Inside
    } else {
        Surface::Outside
    };
    let tau_ms = slope.abs() * 60_000.0;
    if let Some(expected) = expect
        && expected != surface
    {
        let (grows, other) = match expected {
            Surface::Inside => ("shrinks", "an outside surface (a sphere or plug)"),
            Surface::Outside => ("grows", "an inside surface (a ring or bore)"),
        };
        return Err(format!(
            "the radius {grows} as the speed rises (slope {:.4} µm per mm/min), as on {other}",
            slope * 1000.0
        ));
    }
    if !positive(tau_ms) {
        return Err("the radius does not change with the speed: τ = 0".into());
    }
    Ok(DelayFit {
        tau_ms,
        u_tau_ms: u_slope * 60_000.0,
        surface,
        slope,
        intercept,
        points: n,
        groups,
        dof,
        residual_std,
        speeds,
    })
}

/// Read ring-gauge data (CSV, see the module documentation).
pub fn read_ring(path: &str, text: &[u8]) -> crate::Result<Vec<Row<RingPoint>>> {
    let rows = read_rows(
        path,
        text,
        "ring-gauge data",
        &["speed", "radius"],
        |r: &RingRow| {
            vec![
                ("speed", Some(r.speed)),
                ("radius", Some(r.radius)),
                ("direction", r.direction),
            ]
        },
    )?;
    let has_direction = rows
        .first()
        .is_some_and(|r| r.columns.iter().any(|c| c == "direction"));
    rows.into_iter()
        .map(|row| {
            if has_direction && row.value.direction.is_none() {
                return Err(Error::at(
                    path,
                    text,
                    row.offset_of("direction"),
                    "`direction` is empty (expected a number: give every row its direction, or leave the column out)",
                ));
            }
            if row.value.speed <= 0.0 {
                return Err(Error::at(
                    path,
                    text,
                    row.offset_of("speed"),
                    format!("`speed` is {}, expected a positive speed in mm/min", row.value.speed),
                ));
            }
            Ok(Row {
                value: RingPoint {
                    speed: row.value.speed,
                    radius: row.value.radius,
                    direction: row.value.direction,
                },
                line: row.line,
                offset: row.offset,
                field_offsets: row.field_offsets,
                columns: row.columns,
            })
        })
        .collect()
}

/// Read ring-gauge data and fit τ (see [`fit_delay`]); a problem with the data as a whole
/// is reported at the last row (or the header when there is none).
pub fn delay_from_csv(path: &str, text: &[u8], expect: Option<Surface>) -> crate::Result<DelayFit> {
    let rows = read_ring(path, text)?;
    let points: Vec<RingPoint> = rows.iter().map(|r| r.value).collect();
    fit_delay(&points, expect).map_err(|m| {
        let offset = rows.last().map_or(0, |r| r.offset);
        Error::at(path, text, offset, format!("ring-gauge data: {m}"))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(speed: f64, radius: f64, direction: Option<f64>) -> RingPoint {
        RingPoint {
            speed,
            radius,
            direction,
        }
    }

    #[test]
    fn exact_line_gives_tau_with_zero_uncertainty() {
        let tau = 12.68;
        let pts: Vec<_> = [50.0, 100.0, 150.0]
            .iter()
            .map(|&v| p(v, 25.99 + v * tau / 60_000.0, None))
            .collect();
        let f = fit_delay(&pts, None).unwrap();
        assert_eq!(f.surface, Surface::Inside);
        assert!((f.tau_ms - tau).abs() < 1e-9, "{}", f.tau_ms);
        assert!(f.u_tau_ms < 1e-9);
        assert!((f.intercept - 25.99).abs() < 1e-12);
        assert_eq!((f.points, f.groups, f.dof, f.speeds.len()), (3, 1, 1, 3));
        assert!(
            fit_delay(&pts, Some(Surface::Outside))
                .unwrap_err()
                .contains("grows")
        );
    }

    #[test]
    fn per_direction_intercepts_remove_lobing() {
        let tau = 25.35;
        let mut pts = Vec::new();
        for &v in &[50.0, 100.0, 150.0] {
            for k in 0..12 {
                let a = k as f64 * 30.0;
                let lobe = 0.004 * (3.0 * a.to_radians()).cos();
                pts.push(p(v, 12.5 - v * tau / 60_000.0 + lobe, Some(a)));
            }
        }
        let f = fit_delay(&pts, Some(Surface::Outside)).unwrap();
        assert!((f.tau_ms - tau).abs() < 1e-9);
        assert_eq!(f.groups, 12);
        assert!(f.residual_std < 1e-12);
        // Without the labels the lobing is noise, but the slope is still unbiased here.
        for q in &mut pts {
            q.direction = None;
        }
        let g = fit_delay(&pts, None).unwrap();
        assert_eq!(g.surface, Surface::Outside);
        assert!((g.tau_ms - tau).abs() < 1e-6);
        assert!(g.residual_std > 0.002);
    }

    #[test]
    fn too_little_data() {
        let e = fit_delay(&[p(50.0, 1.0, None), p(100.0, 1.0, None)], None);
        assert!(e.unwrap_err().starts_with("too few points"));
        let e = fit_delay(
            &[p(50.0, 1.0, None), p(50.0, 1.1, None), p(50.0, 1.2, None)],
            None,
        );
        assert!(e.unwrap_err().contains("two speeds"));
    }

    #[test]
    fn csv_errors_are_located() {
        let e = delay_from_csv("r.csv", b"speed,radius\n50,26.0\n100,26.01\n", None)
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("r.csv:3:1: ring-gauge data: too few points"),
            "{e}"
        );
        let e = delay_from_csv("r.csv", b"speed,radius,direction\n50,26.0,\n", None)
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("r.csv:2:9: `direction` is empty"), "{e}");
        let e = delay_from_csv("r.csv", b"speed,radius\n-50,26.0\n", None)
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("r.csv:2:1: `speed` is -50"), "{e}");
    }
}
