//! Designs of experiments: a seeded random number generator, Latin hypercubes and
//! three-level orthogonal arrays (the paper's L54).

/// xoshiro256++ seeded through SplitMix64. Small, fast, statistically sound, and the same
/// stream on every platform and for every version of nccomp, so a seed reproduces a run.
#[derive(Debug, Clone)]
pub struct Rng {
    s: [u64; 4],
}

impl Rng {
    pub fn new(seed: u64) -> Self {
        let mut x = seed;
        let mut next = || {
            x = x.wrapping_add(0x9e37_79b9_7f4a_7c15);
            let mut z = x;
            z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            z ^ (z >> 31)
        };
        Rng {
            s: [next(), next(), next(), next()],
        }
    }

    pub fn next_u64(&mut self) -> u64 {
        let s = &mut self.s;
        let result = s[0].wrapping_add(s[3]).rotate_left(23).wrapping_add(s[0]);
        let t = s[1] << 17;
        s[2] ^= s[0];
        s[3] ^= s[1];
        s[1] ^= s[2];
        s[0] ^= s[3];
        s[2] ^= t;
        s[3] = s[3].rotate_left(45);
        result
    }

    /// Uniform in [0, 1), 53 bits.
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Uniform in 0..n (n > 0), without modulo bias worth speaking of for small n.
    pub fn below(&mut self, n: usize) -> usize {
        ((self.next_u64() as u128 * n as u128) >> 64) as usize
    }

    pub fn shuffle<T>(&mut self, v: &mut [T]) {
        for i in (1..v.len()).rev() {
            let j = self.below(i + 1);
            v.swap(i, j);
        }
    }
}

/// A Latin hypercube of `n` points in [0, 1)^k: every dimension cut into `n` equal strata,
/// one point in each, at a random place within it.
pub fn latin_hypercube(n: usize, k: usize, rng: &mut Rng) -> Vec<Vec<f64>> {
    let mut points = vec![vec![0.0; k]; n];
    let mut order: Vec<usize> = (0..n).collect();
    for d in 0..k {
        rng.shuffle(&mut order);
        for (p, &stratum) in points.iter_mut().zip(&order) {
            p[d] = (stratum as f64 + rng.uniform()) / n as f64;
        }
    }
    points
}

/// The best of `tries` Latin hypercubes by the maximin criterion (the largest smallest
/// distance between two points): a simple stand-in for the "optimal Latin hypercube" of
/// the paper (Isight's), which spreads points the same way.
pub fn maximin_latin_hypercube(n: usize, k: usize, tries: usize, rng: &mut Rng) -> Vec<Vec<f64>> {
    let mut best = latin_hypercube(n, k, rng);
    let mut best_d = min_distance(&best);
    for _ in 1..tries {
        let cand = latin_hypercube(n, k, rng);
        let d = min_distance(&cand);
        if d > best_d {
            best = cand;
            best_d = d;
        }
    }
    best
}

fn min_distance(points: &[Vec<f64>]) -> f64 {
    let mut m = f64::INFINITY;
    for i in 0..points.len() {
        for j in i + 1..points.len() {
            let d: f64 = points[i]
                .iter()
                .zip(&points[j])
                .map(|(a, b)| (a - b) * (a - b))
                .sum();
            m = m.min(d);
        }
    }
    m
}

/// A strength-2 orthogonal array with three-level columns (levels 0, 1, 2): in any two
/// columns every pair of levels appears equally often.
#[derive(Debug, Clone, PartialEq)]
pub struct OrthogonalArray {
    /// `L54(2^1 3^25)`, `L81(3^40)`, ...
    pub name: String,
    pub runs: usize,
    /// The three-level columns, each `runs` long.
    pub columns: Vec<Vec<u8>>,
}

/// The D(6, 6, 3) difference matrix over Z3: for any two columns the differences of their
/// entries take each value 0, 1, 2 twice.
const D663: [[u8; 6]; 6] = [
    [0, 0, 0, 0, 0, 0],
    [0, 0, 1, 1, 2, 2],
    [0, 1, 0, 2, 1, 2],
    [0, 1, 2, 0, 2, 1],
    [0, 2, 1, 2, 0, 1],
    [0, 2, 2, 1, 1, 0],
];

impl OrthogonalArray {
    /// The paper's L54: 54 runs, one two-level column and 25 three-level columns
    /// (`L54(2^1 3^25)`; the paper writes L54(3^25), the three-level part). Built as the
    /// Kronecker sum of the L9(3^4) array and the D(6, 6, 3) difference matrix (24
    /// columns), plus the three-level half of the six-level column that numbers the rows of
    /// the difference matrix (the other half is the two-level column, not kept here).
    pub fn l54() -> Self {
        // L9(3^4): runs (a, b), columns a, b, a+b, a+2b.
        let l9: Vec<[u8; 4]> = (0..9u8)
            .map(|r| {
                let (a, b) = (r / 3, r % 3);
                [a, b, (a + b) % 3, (a + 2 * b) % 3]
            })
            .collect();
        let mut columns = Vec::new();
        for j in 0..6 {
            for k in 0..4 {
                let mut col = Vec::with_capacity(54);
                for row in &D663 {
                    for l in &l9 {
                        col.push((l[k] + row[j]) % 3);
                    }
                }
                columns.push(col);
            }
        }
        // Row i of the difference matrix as a six-level factor; i mod 3 is its three-level
        // part (i mod 2 would be the two-level column).
        columns.push((0..54).map(|r| ((r / 9) % 3) as u8).collect());
        OrthogonalArray {
            name: "L54(2^1 3^25)".into(),
            runs: 54,
            columns,
        }
    }

    /// The Rao–Hamming array OA(3^n, 3^((3^n - 1)/2)): runs are the vectors x of GF(3)^n,
    /// columns the non-zero vectors a whose first non-zero entry is 1, entries a·x.
    pub fn rao_hamming(n: u32) -> Self {
        let runs = 3usize.pow(n);
        let digits = |mut v: usize| {
            let mut d = vec![0u8; n as usize];
            for x in d.iter_mut() {
                *x = (v % 3) as u8;
                v /= 3;
            }
            d
        };
        let mut columns = Vec::new();
        for a in 1..runs {
            let av = digits(a);
            // Normalized: the last non-zero digit (the leading one) is 1.
            if av.iter().rev().find(|&&x| x != 0) != Some(&1) {
                continue;
            }
            columns.push(
                (0..runs)
                    .map(|x| {
                        let xv = digits(x);
                        (av.iter().zip(&xv).map(|(p, q)| p * q).sum::<u8>()) % 3
                    })
                    .collect(),
            );
        }
        OrthogonalArray {
            name: format!("L{runs}(3^{})", columns.len()),
            runs,
            columns,
        }
    }

    /// The array for `k` three-level factors with degrees of freedom to spare for the
    /// error: the paper's L54 up to 25 factors (3 are left: the two-level column and 2
    /// more), Rao–Hamming arrays beyond, with a column to spare (81 runs up to 39 factors,
    /// 243 up to 120, ...).
    pub fn for_factors(k: usize) -> Self {
        if k <= 25 {
            return Self::l54();
        }
        let mut n = 4;
        while (3usize.pow(n) - 1) / 2 < k + 1 {
            n += 1;
        }
        Self::rao_hamming(n)
    }

    /// Whether every pair of columns holds every pair of levels equally often.
    pub fn is_orthogonal(&self) -> bool {
        let c = &self.columns;
        for i in 0..c.len() {
            for j in i + 1..c.len() {
                let mut counts = [0usize; 9];
                for r in 0..self.runs {
                    counts[(c[i][r] * 3 + c[j][r]) as usize] += 1;
                }
                if counts.iter().any(|&n| n * 9 != self.runs) {
                    return false;
                }
            }
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rng_is_reproducible_and_uniform() {
        let mut a = Rng::new(7);
        let mut b = Rng::new(7);
        let xs: Vec<f64> = (0..10_000).map(|_| a.uniform()).collect();
        let ys: Vec<f64> = (0..10_000).map(|_| b.uniform()).collect();
        assert_eq!(xs, ys);
        let mean = xs.iter().sum::<f64>() / xs.len() as f64;
        assert!((mean - 0.5).abs() < 0.01, "{mean}");
        assert!(xs.iter().all(|&x| (0.0..1.0).contains(&x)));
        assert_ne!(Rng::new(8).next_u64(), Rng::new(7).next_u64());
    }

    #[test]
    fn latin_hypercubes_are_stratified() {
        let mut rng = Rng::new(1);
        let p = maximin_latin_hypercube(20, 3, 5, &mut rng);
        for d in 0..3 {
            let mut strata: Vec<usize> = p.iter().map(|x| (x[d] * 20.0) as usize).collect();
            strata.sort();
            assert_eq!(strata, (0..20).collect::<Vec<_>>());
        }
    }

    #[test]
    fn l54_is_an_orthogonal_array_with_25_three_level_columns() {
        let oa = OrthogonalArray::l54();
        assert_eq!(oa.runs, 54);
        assert_eq!(oa.columns.len(), 25);
        assert!(oa.is_orthogonal());
        // No two runs alike.
        let mut runs: Vec<Vec<u8>> = (0..54)
            .map(|r| oa.columns.iter().map(|c| c[r]).collect())
            .collect();
        runs.sort();
        runs.dedup();
        assert_eq!(runs.len(), 54);
    }

    #[test]
    fn rao_hamming_arrays_are_orthogonal() {
        let oa = OrthogonalArray::rao_hamming(3);
        assert_eq!((oa.runs, oa.columns.len()), (27, 13));
        assert!(oa.is_orthogonal());
        let oa = OrthogonalArray::for_factors(43);
        assert_eq!((oa.runs, oa.columns.len()), (243, 121));
        assert_eq!(OrthogonalArray::for_factors(21).runs, 54);
        assert_eq!(OrthogonalArray::for_factors(30).runs, 81);
    }
}
