//! The throughput benchmark's inputs (issue 26): a program of random five-axis finishing
//! moves on the AC trunnion and a full random calibration of it. Both come from a fixed-seed
//! generator, so every run, and `examples/gen_program.rs`, writes the same bytes. The
//! tests take their generator from here too (`tests/common`).

use std::fmt::Write as _;
use std::io::Write;

/// A 64-bit linear congruential generator (Knuth's MMIX constants): reproducible, no crate.
pub struct Lcg(pub u64);

impl Lcg {
    /// Uniform in [0, 1).
    pub fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((self.0 >> 11) as f64) / ((1u64 << 53) as f64)
    }

    /// Uniform in [-s, s].
    pub fn sym(&mut self, s: f64) -> f64 {
        (2.0 * self.next() - 1.0) * s
    }

    /// Each component uniform in [-s, s].
    #[allow(dead_code)]
    pub fn vec(&mut self, s: f64) -> nalgebra::Vector3<f64> {
        nalgebra::Vector3::new(self.sym(s), self.sym(s), self.sym(s))
    }
}

/// `blocks` random five-axis G1 moves, every axis moving in every block: the tip steps
/// 0.05–1 mm in a random direction, A up to ±0.2° and C up to ±0.5°, within X ±150, Y ±150,
/// Z 0…100, A −90…10 (a step that would leave the box turns back). N numbers, a comment
/// every 100 blocks, four decimals.
pub fn write_random_program(blocks: usize, out: &mut impl Write) -> std::io::Result<()> {
    let mut rng = Lcg(0x5eed_0026);
    out.write_all(b"%\nO0026 (RANDOM FIVE-AXIS)\nN10 G21 G90 G94\nN20 G0 X0 Y0 Z50. A-30. C0\n")?;
    let mut q = [0.0, 0.0, 50.0, -30.0, 0.0];
    let bounds = [
        (-150.0, 150.0),
        (-150.0, 150.0),
        (0.0, 100.0),
        (-90.0, 10.0),
    ];
    for i in 0..blocks {
        let step = 0.05 + 0.95 * rng.next();
        let (mut d, mut norm) = ([0.0; 3], 0.0f64);
        while norm < 1e-3 {
            d = [rng.sym(1.0), rng.sym(1.0), rng.sym(1.0)];
            norm = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        }
        let delta = [
            d[0] / norm * step,
            d[1] / norm * step,
            d[2] / norm * step,
            rng.sym(0.2),
            rng.sym(0.5),
        ];
        for k in 0..5 {
            let mut v = q[k] + delta[k];
            if k < 4 && (v < bounds[k].0 || v > bounds[k].1) {
                v = q[k] - delta[k];
            }
            q[k] = v;
        }
        if q[4] >= 180.0 {
            q[4] -= 360.0;
        } else if q[4] < -180.0 {
            q[4] += 360.0;
        }
        if i % 100 == 0 {
            out.write_all(b"(PASS)\n")?;
        }
        let feed = if i == 0 { " F2000" } else { "" };
        writeln!(
            out,
            "N{} G1 X{:.4} Y{:.4} Z{:.4} A{:.4} C{:.4}{feed}",
            30 + i,
            q[0],
            q[1],
            q[2],
            q[3],
            q[4]
        )?;
    }
    out.write_all(b"M30\n%\n")
}

/// The random program of `blocks` moves in memory.
#[allow(dead_code)]
pub fn random_program(blocks: usize) -> Vec<u8> {
    let mut out = Vec::new();
    write_random_program(blocks, &mut out).expect("writing to memory");
    out
}

/// A full calibration of the AC trunnion (`fixtures/ac_trunnion.machine.toml`), random but
/// of a real machine's size: the six error motions of X, Y and Z tabulated every 25 mm over
/// their travel (smooth random walks: positioning and straightness within about ±10 µm,
/// pitch, yaw and roll within about ±40 µrad), the three squareness terms, and every
/// location error of A and C (shifts of 5–20 µm, tilts of 10–60 µrad, zero errors).
pub fn random_errors() -> String {
    let mut rng = Lcg(0xca1_1b7a7e);
    let mut s = String::from(
        "# A full random calibration of the AC trunnion (benches/common/random.rs, issue 26).\n\
         length_unit = \"um\"\nangle_unit = \"urad\"\n\n[squareness]\n",
    );
    for name in ["EC0Y", "EB0Z", "EA0Z"] {
        let _ = writeln!(s, "{name} = {:.2}", rng.sym(40.0));
    }
    let _ = writeln!(s, "\n[location.A]");
    for (name, size) in [
        ("EY0A", 20.0),
        ("EZ0A", 20.0),
        ("EA0A", 30.0),
        ("EB0A", 60.0),
        ("EC0A", 60.0),
    ] {
        let _ = writeln!(s, "{name} = {:.2}", rng.sym(size));
    }
    let _ = writeln!(s, "\n[location.C]");
    for (name, size) in [
        ("EX0C", 20.0),
        ("EY0C", 20.0),
        ("EA0C", 60.0),
        ("EB0C", 60.0),
        ("EC0C", 30.0),
    ] {
        let _ = writeln!(s, "{name} = {:.2}", rng.sym(size));
    }
    for (axis, lo, hi) in [
        ("X", -450.0, 450.0),
        ("Y", -400.0, 400.0),
        ("Z", -100.0, 400.0),
    ] {
        let n = ((hi - lo) / 25.0) as usize + 1;
        let positions: Vec<String> = (0..n)
            .map(|i| format!("{:.1}", lo + 25.0 * i as f64))
            .collect();
        let _ = writeln!(
            s,
            "\n[motion.{axis}]\npositions = [{}]",
            positions.join(", ")
        );
        for (c, size) in [
            ("X", 1.5),
            ("Y", 1.5),
            ("Z", 1.5),
            ("A", 6.0),
            ("B", 6.0),
            ("C", 6.0),
        ] {
            let mut v = 0.0f64;
            let values: Vec<String> = (0..n)
                .map(|_| {
                    v = (v + rng.sym(size)).clamp(-6.0 * size, 6.0 * size);
                    format!("{v:.3}")
                })
                .collect();
            let _ = writeln!(s, "E{c}{axis} = [{}]", values.join(", "));
        }
    }
    s
}
