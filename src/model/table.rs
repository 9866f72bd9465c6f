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

/// A [`MotionTable`] made ready for the millions of look-ups of a program: each segment's
/// value differences and slopes computed once, and on evenly spaced positions (the usual
/// laser table) the segment found by one multiplication instead of a binary search. Its
/// samples are bitwise those of [`MotionTable::sample_with_slope`] (the same operations
/// on the same operands).
#[derive(Debug, Clone, PartialEq)]
pub struct IndexedTable {
    positions: Vec<f64>,
    /// Segment k runs from position k to k + 1; a periodic table's last runs from the last
    /// position to the first, a turn on.
    segments: Vec<Segment>,
    /// The values held below the first position and above the last.
    below: [f64; 6],
    above: [f64; 6],
    periodic: bool,
    /// 1 / the spacing of evenly spaced positions; 0: search.
    per_step: f64,
}

#[derive(Debug, Clone, PartialEq)]
struct Segment {
    start: f64,
    length: f64,
    /// The value at the start, the difference to the end and the slope, per component.
    value: [f64; 6],
    rise: [f64; 6],
    slope: [f64; 6],
}

impl IndexedTable {
    pub fn new(table: &MotionTable) -> Self {
        let p = &table.positions;
        let n = p.len();
        let v = |c: usize, i: usize| table.values[c].as_ref().map_or(0.0, |s| s[i]);
        let segment = |i: usize, j: usize, length: f64| {
            // As `sample_with_slope` does: a length that is not positive holds the value.
            let per = if length > 0.0 { 1.0 / length } else { 0.0 };
            let mut s = Segment {
                start: p[i],
                length,
                value: [0.0; 6],
                rise: [0.0; 6],
                slope: [0.0; 6],
            };
            for c in 0..6 {
                s.value[c] = v(c, i);
                s.rise[c] = v(c, j) - v(c, i);
                s.slope[c] = s.rise[c] * per;
            }
            s
        };
        let mut segments: Vec<Segment> =
            (1..n).map(|j| segment(j - 1, j, p[j] - p[j - 1])).collect();
        if table.periodic && n > 0 {
            segments.push(segment(n - 1, 0, p[0] + 360.0 - p[n - 1]));
        }
        let held = |i: usize| std::array::from_fn(|c| v(c, i) + (v(c, i) - v(c, i)) * 0.0);
        let (below, above) = if n > 0 {
            (held(0), held(n - 1))
        } else {
            ([0.0; 6], [0.0; 6])
        };
        let step = if n > 2 {
            (p[n - 1] - p[0]) / (n - 1) as f64
        } else {
            0.0
        };
        let even = step > 0.0
            && p.windows(2)
                .all(|w| ((w[1] - w[0]) - step).abs() <= 1e-9 * step);
        IndexedTable {
            positions: p.clone(),
            segments,
            below,
            above,
            periodic: table.periodic,
            per_step: if even { 1.0 / step } else { 0.0 },
        }
    }

    /// The segment whose positions k, k + 1 hold `x` (p[k] ≤ x < p[k + 1]), for x strictly
    /// between the first and the last position: what `partition_point` finds, found directly
    /// on evenly spaced positions.
    #[inline]
    fn segment_of(&self, x: f64) -> usize {
        let p = &self.positions;
        let last = p.len() - 2;
        if self.per_step == 0.0 {
            return p.partition_point(|&v| v <= x).saturating_sub(1);
        }
        // The guess is the segment, or its neighbour where x rounds across a position.
        let mut k = (((x - p[0]) * self.per_step) as usize).min(last);
        while k < last && p[k + 1] <= x {
            k += 1;
        }
        while k > 0 && p[k] > x {
            k -= 1;
        }
        k
    }

    /// The number of positions at or below `x` (a position starts its segment): two values
    /// with the same count lie on one affine piece.
    fn piece(&self, x: f64) -> usize {
        let p = &self.positions;
        if x < p[0] {
            0
        } else if x >= p[p.len() - 1] {
            p.len()
        } else {
            self.segment_of(x) + 1
        }
    }

    /// How many of the table's positions lie in (lo, hi] (table positions): the kinks of
    /// its values there, the ends of a table held beyond them included. `None` for a range
    /// of a turn or more on a periodic table, or NaN.
    pub fn kinks_within(&self, lo: f64, hi: f64) -> Option<usize> {
        let p = &self.positions;
        if lo.is_nan() || hi.is_nan() || lo > hi {
            return None;
        }
        if p.is_empty() || (self.periodic && p.len() == 1) {
            return Some(0);
        }
        if !self.periodic {
            return Some(self.piece(hi) - self.piece(lo));
        }
        if hi - lo >= 360.0 {
            return None;
        }
        let first = p[0];
        let l = first + (lo - first).rem_euclid(360.0);
        let h = l + (hi - lo);
        // Counted over two turns of the table.
        let count = |x: f64| {
            if x < first + 360.0 {
                self.piece(x)
            } else {
                p.len() + self.piece(x - 360.0)
            }
        };
        Some(count(h) - count(l))
    }

    /// [`MotionTable::sample_with_slope`], bitwise.
    #[inline]
    pub fn sample_with_slope(&self, x: f64) -> (MotionSample, [f64; 6]) {
        let p = &self.positions;
        let n = p.len();
        let mut out = MotionSample::default();
        if n == 0 {
            return (out, [0.0; 6]);
        }
        let (segment, w) = if self.periodic {
            let first = p[0];
            let x = first + (x - first).rem_euclid(360.0);
            let k = if n == 1 || x >= p[n - 1] || x.is_nan() {
                n - 1
            } else {
                self.segment_of(x)
            };
            let s = &self.segments[k];
            let w = if s.length > 0.0 {
                (x - s.start) / s.length
            } else {
                0.0
            };
            (s, w)
        } else if x <= p[0] || x.is_nan() {
            out.beyond = x < p[0];
            out.values = self.below;
            return (out, [0.0; 6]);
        } else if x >= p[n - 1] {
            out.beyond = x > p[n - 1];
            out.values = self.above;
            return (out, [0.0; 6]);
        } else {
            let s = &self.segments[self.segment_of(x)];
            (s, (x - s.start) / s.length)
        };
        for c in 0..6 {
            out.values[c] = segment.value[c] + segment.rise[c] * w;
        }
        (out, segment.slope)
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

    /// The indexed table gives the plain one's samples to the bit, on even and uneven
    /// positions, periodic or not, at positions, between them and beyond.
    #[test]
    fn indexed_tables_sample_bitwise_alike() {
        let mut state = 7u64;
        let mut next = move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 11) as f64) / ((1u64 << 53) as f64)
        };
        let tables = [
            table(false),
            table(true),
            MotionTable {
                positions: (0..37).map(|i| -450.0 + 25.0 * i as f64).collect(),
                values: std::array::from_fn(|c| {
                    (c != 2).then(|| (0..37).map(|i| (i * c) as f64 * 1e-3 - 0.01).collect())
                }),
                periodic: false,
            },
            MotionTable {
                positions: vec![-10.0, -3.0, 0.5, 7.25, 100.0],
                values: std::array::from_fn(|c| Some(vec![0.1 * c as f64, -0.2, 0.3, 0.0, 1e-6])),
                periodic: false,
            },
            MotionTable {
                positions: vec![10.0],
                values: std::array::from_fn(|_| Some(vec![0.25])),
                periodic: true,
            },
            MotionTable {
                positions: (0..8).map(|i| 45.0 * i as f64).collect(),
                values: std::array::from_fn(|c| {
                    Some(
                        (0..8)
                            .map(|i| (i as f64 - 3.5) * (c + 1) as f64 * 1e-5)
                            .collect(),
                    )
                }),
                periodic: true,
            },
        ];
        for t in &tables {
            let indexed = IndexedTable::new(t);
            let mut xs: Vec<f64> = t.positions.clone();
            xs.extend(t.positions.iter().map(|p| p + 360.0));
            xs.extend((0..2000).map(|_| -900.0 + 1800.0 * next()));
            for x in xs {
                let (a, sa) = t.sample_with_slope(x);
                let (b, sb) = indexed.sample_with_slope(x);
                assert_eq!(a.beyond, b.beyond, "{x}");
                for c in 0..6 {
                    assert_eq!(a.values[c].to_bits(), b.values[c].to_bits(), "{x} {c}");
                    assert_eq!(sa[c].to_bits(), sb[c].to_bits(), "{x} {c}");
                }
            }
        }
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
