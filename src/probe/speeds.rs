//! The speed law: the probing speed per direction that makes the total pre-travel equal.
//!
//! With pre-travel `w = wT + v·τ`, the speed `v = (W − wT)/τ` gives every direction the
//! same total `W`. From a map measured at speeds `u` (usually one speed v0 for all):
//!
//! ```text
//! v_i = u_i + (W − w_i) / τ          (pre-travel map, exact in one step)
//! ```
//!
//! `W` is chosen so that the mean of the new speeds is the mean of the measured ones (or
//! `--mean-feed`).
//!
//! A trigger-radius map is what a ring gauge or a sphere gives: each radius is measured
//! from the best-fit centre of all the trigger points, and that centre moves when the
//! speeds change. The paper then repeats the mapping with the new speeds as v0. Here the
//! repetition is predicted: each trigger point moves along its probing direction by
//! `s·(v_i − u_i)·τ` (s = +1 inside, −1 outside), the centre is refitted (least-squares
//! sphere, or circle when the directions lie in a plane), the radii about it are
//! equalised, and so on until the radius varies by less than the tolerance.

use super::map::DirectionMap;
use super::{MapKind, Surface, positive, speed_for, speed_term};
use crate::diag::Error;
use nalgebra::{DMatrix, DVector, Vector3};

/// How to compute the speeds.
#[derive(Debug, Clone, PartialEq)]
pub struct SpeedOptions {
    /// The probe's delay, ms.
    pub tau_ms: f64,
    pub kind: MapKind,
    pub surface: Surface,
    /// The mean of the new speeds, mm/min; `None`: the mean of the measured speeds.
    pub mean_feed: Option<f64>,
    /// Bounds on the new speeds, mm/min (speeds must be positive in any case).
    pub min_feed: Option<f64>,
    pub max_feed: Option<f64>,
    /// The new speeds are rounded to this step, mm/min, as a program will hold them
    /// (0: not rounded).
    pub feed_step: f64,
    /// Stop iterating when the predicted radius varies by less than this, mm.
    pub tolerance: f64,
    pub max_iterations: usize,
}

impl Default for SpeedOptions {
    fn default() -> Self {
        SpeedOptions {
            tau_ms: 12.68,
            kind: MapKind::Radius,
            surface: Surface::Inside,
            mean_feed: None,
            min_feed: None,
            max_feed: None,
            feed_step: 0.1,
            tolerance: 1e-7,
            max_iterations: 50,
        }
    }
}

/// The new speeds and what they are predicted to do.
#[derive(Debug, Clone, PartialEq)]
pub struct SpeedPlan {
    /// The new speed per map point, mm/min (rounded to the feed step).
    pub speeds: Vec<f64>,
    /// The map's value per point as measured, mm.
    pub before: Vec<f64>,
    /// The value per point predicted at the new speeds, mm: pre-travel, or trigger radius
    /// about the refitted centre.
    pub predicted: Vec<f64>,
    /// Variation (max − min) of the measured values, mm; for a trigger-radius map, of the
    /// radii about the best-fit centre of the measured points.
    pub variation_before: f64,
    /// Variation of the predicted values, mm.
    pub variation_after: f64,
    /// Refits of the centre (0 for a pre-travel map).
    pub iterations: usize,
    /// Where the best-fit centre moved to, relative to the map's centre, mm (probe frame).
    pub centre_shift: Vector3<f64>,
}

impl SpeedPlan {
    pub fn min_speed(&self) -> f64 {
        self.speeds.iter().copied().fold(f64::INFINITY, f64::min)
    }

    pub fn max_speed(&self) -> f64 {
        self.speeds
            .iter()
            .copied()
            .fold(f64::NEG_INFINITY, f64::max)
    }

    pub fn mean_speed(&self) -> f64 {
        self.speeds.iter().sum::<f64>() / self.speeds.len().max(1) as f64
    }
}

/// Max − min.
pub fn variation(values: &[f64]) -> f64 {
    let (lo, hi) = values
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        });
    if values.is_empty() { 0.0 } else { hi - lo }
}

/// Compute the speeds for `map`. Fails, naming the direction and the speed it needs,
/// when a speed falls outside the bounds (or is not positive).
pub fn equalise(map: &DirectionMap, opts: &SpeedOptions) -> crate::Result<SpeedPlan> {
    if !positive(opts.tau_ms) {
        return Err(Error::Usage(format!(
            "τ = {} ms: the delay must be positive",
            opts.tau_ms
        )));
    }
    let pts = map.points();
    let n = pts.len();
    if n == 0 {
        return Err(Error::Usage("the direction map is empty".into()));
    }
    let tau = speed_term(1.0, opts.tau_ms); // mm per mm/min
    let u: Vec<f64> = pts.iter().map(|p| p.speed).collect();
    let r: Vec<f64> = pts.iter().map(|p| p.radius).collect();
    let target = opts
        .mean_feed
        .unwrap_or_else(|| u.iter().sum::<f64>() / n as f64);
    let round = |v: f64| {
        if opts.feed_step > 0.0 {
            (v / opts.feed_step).round() * opts.feed_step
        } else {
            v
        }
    };
    let recentre = |v: &mut [f64]| {
        let shift = target - v.iter().sum::<f64>() / n as f64;
        v.iter_mut().for_each(|x| *x += shift);
    };
    match opts.kind {
        MapKind::PreTravel => {
            // wT = w − u·τ; v = (W − wT)/τ with mean v = target.
            let wt: Vec<f64> = (0..n).map(|i| r[i] - u[i] * tau).collect();
            let mut v: Vec<f64> = wt.iter().map(|w| -w / tau).collect();
            recentre(&mut v);
            check_bounds(map, &v, opts)?;
            let speeds: Vec<f64> = v.iter().map(|&x| round(x)).collect();
            let predicted: Vec<f64> = (0..n).map(|i| wt[i] + speeds[i] * tau).collect();
            Ok(SpeedPlan {
                variation_before: variation(&r),
                variation_after: variation(&predicted),
                before: r,
                predicted,
                speeds,
                iterations: 0,
                centre_shift: Vector3::zeros(),
            })
        }
        MapKind::Radius => {
            let s = opts.surface.sign();
            // Outward normal of the surface at each trigger point.
            let normals: Vec<Vector3<f64>> = pts.iter().map(|p| p.direction.unit() * s).collect();
            let radius_at = |v: &[f64]| -> Vec<f64> {
                (0..n).map(|i| r[i] + s * (v[i] - u[i]) * tau).collect()
            };
            let points = |rho: &[f64]| -> Vec<Vector3<f64>> {
                (0..n).map(|i| normals[i] * rho[i]).collect()
            };
            let first = fit_sphere(&points(&r), Vector3::zeros());
            if n <= first.rank {
                return Err(Error::Usage(format!(
                    "a trigger-radius map of {n} directions says nothing: the best-fit {} absorbs {} values; measure more directions, or give pre-travel (--map-kind pre-travel)",
                    if first.rank == 4 { "sphere" } else { "circle" },
                    first.rank
                )));
            }
            let variation_before = variation(&first.residuals);
            let mut v = u.clone();
            let mut centre = first.centre;
            let mut iterations = 0;
            for _ in 0..opts.max_iterations {
                let fit = fit_sphere(&points(&radius_at(&v)), centre);
                iterations += 1;
                centre = fit.centre;
                if variation(&fit.residuals) < opts.tolerance {
                    break;
                }
                for (vi, e) in v.iter_mut().zip(&fit.residuals) {
                    *vi -= s * speed_for(*e, opts.tau_ms);
                }
                recentre(&mut v);
            }
            check_bounds(map, &v, opts)?;
            let speeds: Vec<f64> = v.iter().map(|&x| round(x)).collect();
            let fit = fit_sphere(&points(&radius_at(&speeds)), centre);
            let predicted: Vec<f64> = fit.residuals.iter().map(|e| fit.radius + e).collect();
            Ok(SpeedPlan {
                variation_before,
                variation_after: variation(&fit.residuals),
                before: r,
                predicted,
                speeds,
                iterations,
                centre_shift: fit.centre,
            })
        }
    }
}

/// A least-squares sphere through points.
#[derive(Debug, Clone)]
pub struct SphereFit {
    pub centre: Vector3<f64>,
    pub radius: f64,
    /// Distance from the centre minus the radius, per point.
    pub residuals: Vec<f64>,
    /// How many of the four parameters (centre, radius) the points determine.
    pub rank: usize,
}

/// Fit a sphere to `points` by Gauss–Newton from `start`. Directions the points do not
/// determine (the centre's height for points in one plane or on one circle) are left
/// where they start: the pseudo-inverse takes the smallest step.
pub fn fit_sphere(points: &[Vector3<f64>], start: Vector3<f64>) -> SphereFit {
    let n = points.len();
    let mut c = start;
    let dist = |c: &Vector3<f64>| -> Vec<f64> { points.iter().map(|p| (p - c).norm()).collect() };
    let mut radius = dist(&c).iter().sum::<f64>() / n.max(1) as f64;
    let mut rank = 0;
    for _ in 0..20 {
        let d = dist(&c);
        let mut j = DMatrix::<f64>::zeros(n, 4);
        let mut e = DVector::<f64>::zeros(n);
        for i in 0..n {
            let unit = if d[i] > 0.0 {
                (points[i] - c) / d[i]
            } else {
                Vector3::zeros()
            };
            j[(i, 0)] = -unit.x;
            j[(i, 1)] = -unit.y;
            j[(i, 2)] = -unit.z;
            j[(i, 3)] = -1.0;
            e[i] = d[i] - radius;
        }
        let svd = j.svd(true, true);
        let eps = svd.singular_values.max() * 1e-9;
        rank = svd.singular_values.iter().filter(|&&x| x > eps).count();
        let Ok(step) = svd.solve(&(-e), eps) else {
            break;
        };
        c += Vector3::new(step[0], step[1], step[2]);
        radius += step[3];
        if step.norm() < 1e-15 * radius.abs().max(1.0) {
            break;
        }
    }
    let residuals = dist(&c).iter().map(|d| d - radius).collect();
    SphereFit {
        centre: c,
        radius,
        residuals,
        rank,
    }
}

/// The bounds check: every speed within [min, max] and positive.
fn check_bounds(map: &DirectionMap, v: &[f64], opts: &SpeedOptions) -> crate::Result<()> {
    let pts = map.points();
    let (imin, imax) = (0..v.len()).fold((0, 0), |(a, b), i| {
        (
            if v[i] < v[a] { i } else { a },
            if v[i] > v[b] { i } else { b },
        )
    });
    let (lo, hi) = (v[imin], v[imax]);
    let min_ok = opts.min_feed.is_none_or(|m| lo >= m - 1e-9) && lo > 0.0;
    let max_ok = opts.max_feed.is_none_or(|m| hi <= m + 1e-9);
    if min_ok && max_ok {
        return Ok(());
    }
    let place = |i: usize| {
        let p = &pts[i];
        if p.line > 0 {
            format!("{} (map line {})", p.direction, p.line)
        } else {
            p.direction.to_string()
        }
    };
    let count = |pred: &dyn Fn(f64) -> bool| v.iter().filter(|&&x| pred(x)).count();
    let mut msg = String::new();
    if !min_ok {
        let (bound, what) = match opts.min_feed {
            Some(m) if m > 0.0 => (m, format!("below --min-feed {m} mm/min")),
            _ => (0.0, "but a probing speed must be positive".to_string()),
        };
        let k = count(&|x| x < bound.max(f64::MIN_POSITIVE) - 1e-9);
        msg += &format!(
            "the equalisation needs {lo:.2} mm/min in direction {}, {what}{}",
            place(imin),
            if k > 1 {
                format!(" ({k} directions need less than that bound)")
            } else {
                String::new()
            }
        );
    }
    if !max_ok {
        let m = opts.max_feed.unwrap_or(f64::INFINITY);
        let k = count(&|x| x > m + 1e-9);
        if !msg.is_empty() {
            msg += "; and ";
        } else {
            msg += "the equalisation needs ";
        }
        msg += &format!(
            "{}{hi:.2} mm/min in direction {}, above --max-feed {m} mm/min{}",
            if min_ok { "" } else { "it needs " },
            place(imax),
            if k > 1 {
                format!(" ({k} directions need more than that bound)")
            } else {
                String::new()
            }
        );
    }
    let span = hi - lo;
    msg += &format!(
        ". In all it needs {lo:.2} … {hi:.2} mm/min (a span of {span:.2} mm/min: a variation of {:.2} µm ÷ τ = {} ms)",
        speed_term(span, opts.tau_ms) * 1000.0,
        // At most three decimals, none trailing: 12.68, 12.615.
        format!("{:.3}", opts.tau_ms)
            .trim_end_matches('0')
            .trim_end_matches('.')
    );
    let lo_bound = opts.min_feed.unwrap_or(0.0).max(0.0);
    let hi_bound = opts.max_feed.unwrap_or(f64::INFINITY);
    let mean = v.iter().sum::<f64>() / v.len() as f64;
    // Shifting every speed by δ keeps the equalisation: δ ∈ [lo_bound − lo, hi_bound − hi].
    let (d0, d1) = (lo_bound - lo, hi_bound - hi);
    if d0 <= d1 && (lo_bound > 0.0 || d0 < d1) {
        let a = mean + d0 + if lo_bound > 0.0 { 0.0 } else { 0.01 };
        if d1.is_finite() {
            msg += &format!(
                "; a --mean-feed from {a:.2} to {:.2} mm/min keeps every speed within the bounds",
                mean + d1
            );
        } else {
            msg += &format!(
                "; a --mean-feed of {a:.2} mm/min or more keeps every speed within the bounds"
            );
        }
    } else {
        msg += &format!(
            "; the bounds {} … {} mm/min are narrower than that span: widen them",
            lo_bound,
            if hi_bound.is_finite() {
                hi_bound.to_string()
            } else {
                "∞".into()
            }
        );
    }
    Err(Error::Usage(msg))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::probe::map::MapPoint;

    fn lobed(amplitude_um: f64, speed: f64, radius: f64) -> DirectionMap {
        let mut pts = Vec::new();
        for k in 0..36 {
            let a = k as f64 * 10.0;
            let w = radius + amplitude_um / 1000.0 * (3.0 * a.to_radians()).cos();
            pts.push(MapPoint::new(a, 0.0, w, speed));
        }
        DirectionMap::new(pts).unwrap()
    }

    #[test]
    fn pre_travel_law_is_exact() {
        let map = lobed(5.0, 50.0, 0.02);
        let opts = SpeedOptions {
            kind: MapKind::PreTravel,
            feed_step: 0.0,
            ..SpeedOptions::default()
        };
        let plan = equalise(&map, &opts).unwrap();
        assert!((plan.variation_before - 0.010).abs() < 1e-12);
        assert!(plan.variation_after < 1e-12);
        assert!((plan.mean_speed() - 50.0).abs() < 1e-9);
        // The span is the variation over τ: 10 µm / 12.68 ms = 47.32 mm/min.
        let span = plan.max_speed() - plan.min_speed();
        assert!((span - speed_for(0.010, 12.68)).abs() < 1e-9, "{span}");
        // The lobe's peak (α = 0) gets the lowest speed.
        assert_eq!(plan.speeds[0], plan.min_speed());
    }

    #[test]
    fn radius_iteration_matches_the_law_on_a_centred_map_and_ignores_an_offset_centre() {
        let opts = SpeedOptions {
            feed_step: 0.0,
            ..SpeedOptions::default()
        };
        let map = lobed(5.0, 50.0, 26.0);
        let plan = equalise(&map, &opts).unwrap();
        assert!(plan.variation_after < 1e-6, "{}", plan.variation_after);
        assert!((plan.max_speed() - plan.min_speed() - speed_for(0.010, 12.68)).abs() < 0.01);
        // The same probe measured about a centre 3 µm off: the radii carry a first
        // harmonic that is only a centre shift. The speeds must not chase it.
        let mut pts = map.points().to_vec();
        for p in &mut pts {
            let d = p.direction.unit();
            p.radius = (d * p.radius - Vector3::new(0.003, 0.0, 0.0)).norm();
        }
        let shifted = DirectionMap::new(pts).unwrap();
        let plan2 = equalise(&shifted, &opts).unwrap();
        assert!((plan2.variation_before - 0.010).abs() < 1e-6);
        for (a, b) in plan.speeds.iter().zip(&plan2.speeds) {
            assert!((a - b).abs() < 1e-3, "{a} {b}");
        }
        assert!(plan2.iterations <= 4, "{}", plan2.iterations);
    }

    #[test]
    fn outside_surfaces_reverse_the_sign() {
        let map = lobed(5.0, 50.0, 10.0);
        let inside = equalise(&map, &SpeedOptions::default()).unwrap();
        let outside = equalise(
            &map,
            &SpeedOptions {
                surface: Surface::Outside,
                ..SpeedOptions::default()
            },
        )
        .unwrap();
        // On a sphere a large radius means little pre-travel: it is probed faster.
        assert!(inside.speeds[0] < 50.0 && outside.speeds[0] > 50.0);
    }

    #[test]
    fn bounds_are_enforced_with_the_direction_and_the_speed() {
        let map = lobed(5.0, 50.0, 26.0);
        let e = equalise(
            &map,
            &SpeedOptions {
                min_feed: Some(30.0),
                max_feed: Some(100.0),
                ..SpeedOptions::default()
            },
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.starts_with("the equalisation needs 26.34 mm/min in direction α = 240.0°, β = 0.0°, below --min-feed 30 mm/min (9 directions need less than that bound). In all it needs 26.34 … 73.66 mm/min (a span of 47.32 mm/min: a variation of 10.00 µm ÷ τ = 12.68 ms)"),
            "{e}"
        );
        assert!(
            e.contains("a --mean-feed from 53.66 to 76.34 mm/min"),
            "{e}"
        );
        let e = equalise(
            &map,
            &SpeedOptions {
                min_feed: Some(30.0),
                max_feed: Some(60.0),
                ..SpeedOptions::default()
            },
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("above --max-feed 60 mm/min"), "{e}");
        assert!(e.contains("narrower than that span"), "{e}");
        let e = equalise(
            &map,
            &SpeedOptions {
                mean_feed: Some(10.0),
                ..SpeedOptions::default()
            },
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("a probing speed must be positive"), "{e}");
    }

    #[test]
    fn a_radius_map_needs_more_directions_than_the_fit_absorbs() {
        let pts = (0..3)
            .map(|k| MapPoint::new(120.0 * f64::from(k), 0.0, 26.0 + 0.001 * f64::from(k), 50.0))
            .collect();
        let map = DirectionMap::new(pts).unwrap();
        let e = equalise(&map, &SpeedOptions::default())
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("a trigger-radius map of 3 directions says nothing: the best-fit circle absorbs 3 values"), "{e}");
        let plan = equalise(
            &map,
            &SpeedOptions {
                kind: MapKind::PreTravel,
                ..SpeedOptions::default()
            },
        )
        .unwrap();
        assert!(plan.variation_after < 1e-4);
    }

    #[test]
    fn sphere_fit_of_a_circle_leaves_the_height() {
        let pts: Vec<_> = (0..8)
            .map(|k| {
                let a = (k as f64 * 45.0).to_radians();
                Vector3::new(1.0 + 5.0 * a.cos(), 2.0 + 5.0 * a.sin(), 0.0)
            })
            .collect();
        let f = fit_sphere(&pts, Vector3::zeros());
        assert!((f.centre - Vector3::new(1.0, 2.0, 0.0)).norm() < 1e-9);
        assert!((f.radius - 5.0).abs() < 1e-9);
        assert_eq!(f.rank, 3);
    }
}
