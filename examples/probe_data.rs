//! Writes the synthetic probe data behind `docs/probe.md` and the CLI tests:
//!
//!     cargo run --example probe_data -- fixtures
//!
//! * `probe_ring.csv`: a 52 mm ring gauge probed at 36 points at 50, 100 and 150 mm/min
//!   (τ = 12.68 ms, the paper's OMP40-2), 0.5 µm random error per point;
//! * `probe_map.csv`: a 25.4 mm reference sphere probed from above with a 6 mm stylus tip,
//!   rings β = 0°, −10°, … −80° of 36 directions and the pole, at 50 mm/min: three lobes
//!   of 11.0 µm in the plane falling to 2.3 µm at β = −80°, 0.15 µm random error;
//! * `probe_demo.nc`: a probing program for a bore, a top face and a chamfer (G31).
//!
//! The random errors come from a fixed-seed generator, so the files are reproducible.

use nccomp::nc::number::fixed;
use std::path::PathBuf;

const TAU_MS: f64 = 12.68;

/// SplitMix64 with Box–Muller.
struct Noise(u64);

impl Noise {
    fn uniform(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        ((z >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }

    fn normal(&mut self, sigma: f64) -> f64 {
        let (u1, u2) = (self.uniform(), self.uniform());
        sigma * (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }
}

/// Pre-travel at speed `v` (mm): 20 µm mean, three lobes of `size` µm peak to valley.
fn pre_travel(alpha: f64, size: f64, v: f64) -> f64 {
    0.020 + size / 2.0 * (3.0 * alpha.to_radians()).cos() / 1000.0 + v * TAU_MS / 60_000.0
}

fn ring() -> String {
    let mut noise = Noise(52);
    let mut s = String::from(
        "# 52 mm ring gauge, 6 mm stylus tip: trigger radius of the tip centre, mm\nspeed,radius,direction\n",
    );
    for speed in [50.0, 100.0, 150.0] {
        for k in 0..36 {
            let alpha = 10.0 * f64::from(k);
            let r = 26.0 - 3.0 + pre_travel(alpha, 11.0, speed) + noise.normal(0.0005);
            s += &format!("{speed},{r:.5},{alpha}\n");
        }
    }
    s
}

fn map() -> String {
    let mut noise = Noise(254);
    let mut s = String::from(
        "# 25.4 mm sphere probed from above with a 6 mm tip at 50 mm/min: trigger radius about\n# the best-fit centre (mean of 10 runs), mm\nalpha,beta,radius,speed\n",
    );
    for b in 0..9 {
        let beta = if b == 0 { 0.0 } else { -10.0 * f64::from(b) };
        let size = 11.0 - (11.0 - 2.3) * beta.abs() / 80.0;
        for k in 0..36 {
            let alpha = 10.0 * f64::from(k);
            let r = 12.7 + 3.0 - pre_travel(alpha, size, 50.0) + noise.normal(0.00015);
            s += &format!("{alpha},{beta},{r:.6},50\n");
        }
    }
    let r = 12.7 + 3.0 - pre_travel(0.0, 0.0, 50.0) + noise.normal(0.00015);
    s += &format!("0,-90,{r:.6},50\n");
    s
}

fn program() -> String {
    let mut s = String::from(
        "%\nO0100 (PROBE A BORE, A FACE AND A CHAMFER - OMP40-2)\nN10 G21 G90 G94 G17 G40 G49 G80\nN20 G54\nN30 G0 X0. Y0. Z20.\nN40 G1 Z-5. F1000.\n(bore, radius 25: eight points 45 degrees apart)\n",
    );
    let mut n = 50;
    for k in 0..8 {
        let a = f64::from(k) * 45.0_f64.to_radians();
        let (x, y) = (fixed(30.0 * a.cos(), 4), fixed(30.0 * a.sin(), 4));
        let f = if k == 2 { "" } else { " F50." };
        s += &format!("N{n} G31 X{x} Y{y}{f}\n");
        s += &format!("N{} G0 X0. Y0.\n", n + 10);
        n += 20;
    }
    s += &format!("N{n} G0 Z20.\n(top face: three points straight down)\n");
    n += 10;
    for (x, y) in [(40.0, 0.0), (-20.0, 34.641), (-20.0, -34.641)] {
        s += &format!(
            "N{n} G0 X{x:.3} Y{y:.3}\nN{} G31 Z-10. F50.\nN{} G0 Z20.\n",
            n + 10,
            n + 20
        );
        n += 30;
    }
    s += &format!(
        "(chamfer at 45 degrees)\nN{n} G0 X60. Y0. Z10.\nN{} G31 X50. Z0. F50.\nN{} G0 Z20.\nN{} G1 X0. Y0. (back over the bore at the modal feed)\nN{} M30\n%\n",
        n + 10,
        n + 20,
        n + 30,
        n + 40
    );
    s
}

fn main() -> std::io::Result<()> {
    let dir = std::env::args_os()
        .nth(1)
        .map_or_else(|| PathBuf::from("fixtures"), PathBuf::from);
    std::fs::write(dir.join("probe_ring.csv"), ring())?;
    std::fs::write(dir.join("probe_map.csv"), map())?;
    std::fs::write(dir.join("probe_demo.nc"), program())?;
    Ok(())
}
