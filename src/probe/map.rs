//! The direction map: trigger radius (or pre-travel) and the speed it was measured at, per
//! direction, and interpolation between the measured directions.
//!
//! Map file (CSV, header required, columns in any order, extra columns ignored):
//!
//! | column   | unit   | meaning                                                         |
//! |----------|--------|-----------------------------------------------------------------|
//! | `alpha`  | degree | azimuth in the probe's XY plane from +X (any value; taken mod 360) |
//! | `beta`   | degree | elevation from that plane, −90 … 90, positive towards the spindle |
//! | `radius` | mm     | trigger radius (or pre-travel, see [`super::MapKind`])           |
//! | `speed`  | mm/min | the probing speed the radius was measured at                    |
//!
//! Rows with the same direction (repeated measurements) are averaged; at β = ±90° every α
//! is the same direction. The directions are grouped into rings of equal β. Between
//! measured directions the map is interpolated linearly in α within a ring (periodically,
//! across 360°) and linearly in β between the two rings around a direction. A direction
//! outside the β range of the rings is refused rather than extrapolated.

use super::csvio::read_rows;
use super::{Direction, POLE_TOLERANCE, positive};
use crate::diag::Error;
use serde::Deserialize;

/// One measured direction of the map (rows of the same direction averaged).
#[derive(Debug, Clone, PartialEq)]
pub struct MapPoint {
    pub direction: Direction,
    /// mm (trigger radius or pre-travel).
    pub radius: f64,
    /// mm/min.
    pub speed: f64,
    /// The file line of the direction's first row (0 for a map built in code).
    pub line: usize,
    /// How many rows were averaged.
    pub rows: usize,
}

impl MapPoint {
    pub fn new(alpha: f64, beta: f64, radius: f64, speed: f64) -> Self {
        MapPoint {
            direction: Direction::new(alpha, beta),
            radius,
            speed,
            line: 0,
            rows: 1,
        }
    }
}

#[derive(Debug, Deserialize)]
struct MapRow {
    alpha: f64,
    beta: f64,
    radius: f64,
    speed: f64,
}

/// One ring of equal β: the members' α (sorted) and their indices in the map.
#[derive(Debug, Clone, PartialEq)]
struct Ring {
    beta: f64,
    members: Vec<(f64, usize)>,
}

/// The measured directions, grouped for interpolation.
#[derive(Debug, Clone, PartialEq)]
pub struct DirectionMap {
    points: Vec<MapPoint>,
    rings: Vec<Ring>,
}

/// Interpolation weights: up to four (map index, weight) pairs summing to 1.
pub type Weights = Vec<(usize, f64)>;

impl DirectionMap {
    /// A map from measured points: rows with the same direction are averaged (their
    /// speeds must agree). The error names the offending point's index and what is wrong.
    pub fn new(points: Vec<MapPoint>) -> Result<Self, (usize, String)> {
        let mut merged: Vec<MapPoint> = Vec::new();
        for (i, p) in points.into_iter().enumerate() {
            if !(-90.0..=90.0).contains(&p.direction.beta) {
                return Err((
                    i,
                    format!(
                        "β = {}° is outside −90° … 90° (β is the elevation from the probe's XY plane)",
                        p.direction.beta
                    ),
                ));
            }
            if !positive(p.speed) {
                return Err((
                    i,
                    format!("a speed of {} mm/min: speeds must be positive", p.speed),
                ));
            }
            let same = |q: &MapPoint| {
                if p.direction.is_pole() || q.direction.is_pole() {
                    p.direction.is_pole()
                        && q.direction.is_pole()
                        && p.direction.beta.signum() == q.direction.beta.signum()
                } else {
                    q.direction == p.direction
                }
            };
            match merged.iter_mut().find(|q| same(q)) {
                Some(q) => {
                    if (q.speed - p.speed).abs() > 1e-9 * q.speed {
                        return Err((
                            i,
                            format!(
                                "direction {} is measured again at {} mm/min, but at {} mm/min at line {}: repeated rows of one direction must share their speed",
                                q.direction, p.speed, q.speed, q.line
                            ),
                        ));
                    }
                    q.radius += p.radius;
                    q.rows += 1;
                }
                None => {
                    let mut p = p;
                    if p.direction.is_pole() {
                        p.direction = Direction::new(0.0, 90f64.copysign(p.direction.beta));
                    }
                    merged.push(p);
                }
            }
        }
        for q in &mut merged {
            q.radius /= q.rows as f64;
        }
        let mut rings: Vec<Ring> = Vec::new();
        for (i, p) in merged.iter().enumerate() {
            match rings.iter_mut().find(|r| r.beta == p.direction.beta) {
                Some(r) => r.members.push((p.direction.alpha, i)),
                None => rings.push(Ring {
                    beta: p.direction.beta,
                    members: vec![(p.direction.alpha, i)],
                }),
            }
        }
        for r in &mut rings {
            r.members.sort_by(|a, b| a.0.total_cmp(&b.0));
        }
        rings.sort_by(|a, b| a.beta.total_cmp(&b.beta));
        Ok(DirectionMap {
            points: merged,
            rings,
        })
    }

    /// The measured directions (duplicates merged), in file order.
    pub fn points(&self) -> &[MapPoint] {
        &self.points
    }

    pub fn len(&self) -> usize {
        self.points.len()
    }

    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// The β of the rings, increasing.
    pub fn ring_betas(&self) -> Vec<f64> {
        self.rings.iter().map(|r| r.beta).collect()
    }

    /// The map indices of the ring at `beta`, by increasing α.
    pub fn ring(&self, beta: f64) -> Vec<usize> {
        self.rings
            .iter()
            .find(|r| r.beta == beta)
            .map(|r| r.members.iter().map(|m| m.1).collect())
            .unwrap_or_default()
    }

    /// The β range the map covers.
    pub fn beta_range(&self) -> (f64, f64) {
        (
            self.rings.first().map_or(0.0, |r| r.beta),
            self.rings.last().map_or(0.0, |r| r.beta),
        )
    }

    /// Interpolation weights for `dir` (see the module documentation), or why there are
    /// none.
    pub fn weights(&self, dir: Direction) -> Result<Weights, String> {
        let (lo, hi) = self.beta_range();
        if self.rings.is_empty() {
            return Err("the map is empty".into());
        }
        let tol = POLE_TOLERANCE;
        if dir.beta < lo - tol || dir.beta > hi + tol {
            return Err(format!(
                "direction {dir} is outside the map, which covers β from {lo}° to {hi}° (extend the map or check the probe axis)"
            ));
        }
        let beta = dir.beta.clamp(lo, hi);
        let k = self.rings.iter().rposition(|r| r.beta <= beta).unwrap_or(0);
        let mut w = Weights::new();
        if k + 1 >= self.rings.len() || self.rings[k].beta == beta {
            ring_weights(&self.rings[k], dir.alpha, 1.0, &mut w);
        } else {
            let (a, b) = (&self.rings[k], &self.rings[k + 1]);
            let t = (beta - a.beta) / (b.beta - a.beta);
            ring_weights(a, dir.alpha, 1.0 - t, &mut w);
            ring_weights(b, dir.alpha, t, &mut w);
        }
        w.retain(|&(_, x)| x != 0.0);
        Ok(w)
    }

    /// `values` (one per map point) interpolated at `dir`.
    pub fn interpolate(&self, dir: Direction, values: &[f64]) -> Result<f64, String> {
        Ok(self.weights(dir)?.iter().map(|&(i, w)| w * values[i]).sum())
    }
}

/// Linear weights within a ring, periodic in α.
fn ring_weights(ring: &Ring, alpha: f64, scale: f64, out: &mut Weights) {
    let m = &ring.members;
    if m.len() == 1 {
        out.push((m[0].1, scale));
        return;
    }
    // The first member at or after α, wrapping.
    let j = m.iter().position(|&(a, _)| a >= alpha);
    let (prev, next, a0, a1) = match j {
        Some(j) if m[j].0 == alpha => {
            out.push((m[j].1, scale));
            return;
        }
        Some(0) | None => {
            let (p, n) = (m[m.len() - 1], m[0]);
            let a0 = p.0;
            let a1 = n.0 + 360.0;
            let alpha = if alpha < a0 { alpha + 360.0 } else { alpha };
            let t = (alpha - a0) / (a1 - a0);
            out.push((p.1, scale * (1.0 - t)));
            out.push((n.1, scale * t));
            return;
        }
        Some(j) => (m[j - 1], m[j], m[j - 1].0, m[j].0),
    };
    let t = (alpha - a0) / (a1 - a0);
    out.push((prev.1, scale * (1.0 - t)));
    out.push((next.1, scale * t));
}

/// Read a map file (CSV, see the module documentation). Every problem is located.
pub fn read_map(path: &str, text: &[u8]) -> crate::Result<DirectionMap> {
    let rows = read_rows(
        path,
        text,
        "the direction map",
        &["alpha", "beta", "radius", "speed"],
        |r: &MapRow| {
            vec![
                ("alpha", Some(r.alpha)),
                ("beta", Some(r.beta)),
                ("radius", Some(r.radius)),
                ("speed", Some(r.speed)),
            ]
        },
    )?;
    let points = rows
        .iter()
        .map(|r| MapPoint {
            direction: Direction::new(r.value.alpha, r.value.beta),
            radius: r.value.radius,
            speed: r.value.speed,
            line: r.line,
            rows: 1,
        })
        .collect();
    // Direction::new keeps β as given, so the range check below sees the file's value.
    for r in &rows {
        if !(-90.0..=90.0).contains(&r.value.beta) {
            return Err(Error::at(
                path,
                text,
                r.offset_of("beta"),
                format!(
                    "`beta` is {}°, outside −90° … 90° (β is the elevation from the probe's XY plane)",
                    r.value.beta
                ),
            ));
        }
        if !positive(r.value.speed) {
            return Err(Error::at(
                path,
                text,
                r.offset_of("speed"),
                format!(
                    "`speed` is {}, expected a positive speed in mm/min",
                    r.value.speed
                ),
            ));
        }
    }
    let map = DirectionMap::new(points).map_err(|(i, m)| {
        Error::at(
            path,
            text,
            rows[i].offset,
            format!("the direction map: {m}"),
        )
    })?;
    if map.len() < 3 {
        let offset = rows.last().map_or(0, |r| r.offset);
        return Err(Error::at(
            path,
            text,
            offset,
            format!(
                "the direction map: too few points: {} direction{}; at least 3 are needed",
                map.len(),
                if map.len() == 1 { "" } else { "s" }
            ),
        ));
    }
    Ok(map)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid() -> DirectionMap {
        let mut pts = Vec::new();
        for &b in &[0.0, 30.0] {
            for k in 0..4 {
                let a = 90.0 * k as f64;
                pts.push(MapPoint::new(a, b, a + b, 50.0));
            }
        }
        pts.push(MapPoint::new(0.0, 90.0, 1000.0, 50.0));
        DirectionMap::new(pts).unwrap()
    }

    #[test]
    fn interpolates_periodically_in_alpha_and_linearly_in_beta() {
        let m = grid();
        let v: Vec<f64> = m.points().iter().map(|p| p.radius).collect();
        let at = |a, b| m.interpolate(Direction::new(a, b), &v).unwrap();
        assert_eq!(at(90.0, 0.0), 90.0);
        assert_eq!(at(45.0, 0.0), 45.0);
        // Across 360°: between 270 (270) and 360 ≡ 0 (0).
        assert!((at(315.0, 0.0) - 135.0).abs() < 1e-12);
        assert!((at(-45.0, 0.0) - 135.0).abs() < 1e-12);
        assert!((at(90.0, 15.0) - 105.0).abs() < 1e-12);
        // Towards the pole.
        assert!((at(0.0, 60.0) - (30.0 + 1000.0) / 2.0).abs() < 1e-9);
        assert_eq!(at(123.0, 90.0), 1000.0);
        let e = m.weights(Direction::new(0.0, -10.0)).unwrap_err();
        assert!(e.contains("covers β from 0° to 90°"), "{e}");
    }

    #[test]
    fn duplicates_are_averaged_and_poles_merged() {
        let m = DirectionMap::new(vec![
            MapPoint::new(0.0, 0.0, 1.0, 50.0),
            MapPoint::new(360.0, 0.0, 3.0, 50.0),
            MapPoint::new(10.0, 90.0, 5.0, 50.0),
            MapPoint::new(200.0, 90.0, 7.0, 50.0),
        ])
        .unwrap();
        assert_eq!(m.len(), 2);
        assert_eq!((m.points()[0].radius, m.points()[0].rows), (2.0, 2));
        assert_eq!(m.points()[1].radius, 6.0);
        let e = DirectionMap::new(vec![
            MapPoint::new(0.0, 0.0, 1.0, 50.0),
            MapPoint::new(0.0, 0.0, 1.0, 60.0),
        ])
        .unwrap_err();
        assert_eq!(e.0, 1);
    }

    #[test]
    fn map_files_are_checked() {
        let ok = b"alpha,beta,radius,speed\n0,0,25,50\n120,0,25.001,50\n240,0,25.002,50\n";
        assert_eq!(read_map("m.csv", ok).unwrap().len(), 3);
        let e = read_map("m.csv", b"alpha,beta,radius\n0,0,25\n")
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("m.csv:1:18: the direction map: missing column `speed`"),
            "{e}"
        );
        let e = read_map(
            "m.csv",
            b"alpha,beta,radius,speed\n0,0,25,50\n120,x,25,50\n",
        )
        .unwrap_err()
        .to_string();
        assert_eq!(e, "m.csv:3:5: `beta` is `x`, not a number");
        let e = read_map(
            "m.csv",
            b"alpha,beta,radius,speed\n0,0,25,50\n120,0,25,50\n",
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.starts_with("m.csv:3:1: the direction map: too few points: 2"),
            "{e}"
        );
        let e = read_map("m.csv", b"alpha,beta,radius,speed\n0,95,25,50\n")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("m.csv:2:3: `beta` is 95°"), "{e}");
    }
}
