//! Error motions tabulated against axis position, interpolated linearly.

/// The six error motions of one axis against its position: δx, δy, δz in mm and εx, εy, εz
/// in rad (component order X Y Z A B C). Components that were not given are `None` (zero).
#[derive(Debug, Clone, PartialEq)]
pub struct MotionTable {
    /// Strictly increasing table positions (program position + the axis's table offset), mm
    /// or degrees.
    pub positions: Vec<f64>,
    /// One series per component, each as long as `positions`.
    pub values: [Option<Vec<f64>>; 6],
    /// Rotary axes: the table repeats every 360°.
    pub periodic: bool,
}

/// Six error-motion components at one position, and whether the position lay beyond the
/// table's ends (values then held constant).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct MotionSample {
    pub values: [f64; 6],
    pub beyond: bool,
}

impl MotionTable {
    pub fn is_zero(&self) -> bool {
        self.values
            .iter()
            .flatten()
            .all(|series| series.iter().all(|&v| v == 0.0))
    }

    /// The six components at position `x` (mm or degrees, table offset included).
    pub fn sample(&self, x: f64) -> MotionSample {
        self.sample_with_slope(x).0
    }

    /// [`MotionTable::sample`] and the slope of each component there (per mm or per
    /// degree): the interpolating segment's, zero where the ends are held.
    pub fn sample_with_slope(&self, x: f64) -> (MotionSample, [f64; 6]) {
        let p = &self.positions;
        let mut out = MotionSample::default();
        let mut slope = [0.0; 6];
        if p.is_empty() {
            return (out, slope);
        }
        let n = p.len();
        // Segment ends i, j, the weight of j and 1 / the segment's length (0: held).
        let (i, j, w, per) = if self.periodic {
            let first = p[0];
            let x = first + (x - first).rem_euclid(360.0);
            if n == 1 || x >= p[n - 1] {
                let span = first + 360.0 - p[n - 1];
                if span > 0.0 {
                    (n - 1, 0, (x - p[n - 1]) / span, 1.0 / span)
                } else {
                    (n - 1, 0, 0.0, 0.0)
                }
            } else {
                let k = p.partition_point(|&v| v <= x);
                let (i, j) = (k - 1, k);
                (i, j, (x - p[i]) / (p[j] - p[i]), 1.0 / (p[j] - p[i]))
            }
        } else if x <= p[0] {
            out.beyond = x < p[0];
            (0, 0, 0.0, 0.0)
        } else if x >= p[n - 1] {
            out.beyond = x > p[n - 1];
            (n - 1, n - 1, 0.0, 0.0)
        } else {
            let k = p.partition_point(|&v| v <= x);
            let (i, j) = (k - 1, k);
            (i, j, (x - p[i]) / (p[j] - p[i]), 1.0 / (p[j] - p[i]))
        };
        for (c, series) in self.values.iter().enumerate() {
            if let Some(v) = series {
                out.values[c] = v[i] + (v[j] - v[i]) * w;
                slope[c] = (v[j] - v[i]) * per;
            }
        }
        (out, slope)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table(periodic: bool) -> MotionTable {
        MotionTable {
            positions: vec![0.0, 90.0, 180.0, 270.0],
            values: [
                Some(vec![0.0, 0.5, 0.0, -0.5]),
                None,
                None,
                None,
                None,
                None,
            ],
            periodic,
        }
    }

    #[test]
    fn interpolates_between_entries() {
        let s = table(false).sample(45.0);
        assert!((s.values[0] - 0.25).abs() < 1e-15);
        assert!(!s.beyond);
    }

    #[test]
    fn holds_ends_and_reports() {
        let t = table(false);
        let s = t.sample(300.0);
        assert_eq!(s.values[0], -0.5);
        assert!(s.beyond);
        let s = t.sample(-1.0);
        assert_eq!(s.values[0], 0.0);
        assert!(s.beyond);
        assert!(!t.sample(270.0).beyond);
    }

    #[test]
    fn periodic_tables_wrap() {
        let t = table(true);
        // Between 270 (-0.5) and 360 (= 0, value 0.0).
        assert!((t.sample(315.0).values[0] + 0.25).abs() < 1e-15);
        assert!((t.sample(-45.0).values[0] + 0.25).abs() < 1e-15);
        assert!((t.sample(405.0).values[0] - 0.25).abs() < 1e-15);
        assert!(!t.sample(-45.0).beyond);
    }
}
