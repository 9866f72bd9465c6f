//! The twin: cut the feature workpiece on a machine with known errors and measure it.
//!
//! - Cutting: the machine runs the program with its quasi-static error model plus a
//!   dynamic error model that acts only while cutting (cutting forces, servo lag; here an
//!   extra model of the same kind). The surface near each planned point is where that
//!   machine put the ball ([`cutting::deviation`]).
//! - On-machine probing: the probe touches each planned point in the pose the program
//!   cut it in, through the same machine, now unloaded, so only the quasi-static errors
//!   act; it reports the nominal coordinates of where it touched: along the normal, the
//!   cut deviation less the quasi-static one.
//! - CMM: sees the cut surface itself, in the part frame.
//!
//! Both measurements get seeded Gaussian noise (σ per coordinate); a probe touching along
//! the normal reports nothing else of the surface.

use super::cutting::{self, Cut};
use super::measure::Points;
use super::params::Params;
use super::plan::Plan;
use crate::kinematics::Kinematics;
use crate::model::{ErrorModel, Machine, MotionTable};
use nalgebra::Vector3;

/// A small seeded generator (SplitMix64) with Gaussian draws.
#[derive(Debug, Clone)]
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Rng(seed ^ 0x9e37_79b9_7f4a_7c15)
    }
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    /// Uniform in (0, 1).
    pub fn uniform(&mut self) -> f64 {
        ((self.next_u64() >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }
    pub fn gauss(&mut self) -> f64 {
        (-2.0 * self.uniform().ln()).sqrt() * (std::f64::consts::TAU * self.uniform()).cos()
    }
}

/// The sum of two error models of the same machine (tables on the union of positions).
pub fn sum(a: &ErrorModel, b: &ErrorModel) -> ErrorModel {
    let mut out = a.clone();
    for (o, e) in out.axes.iter_mut().zip(&b.axes) {
        o.squareness += e.squareness;
        o.location_shift += e.location_shift;
        o.location_tilt += e.location_tilt;
        o.zero += e.zero;
        o.motion = match (o.motion.take(), &e.motion) {
            (m, None) => m,
            (None, Some(m)) => Some(m.clone()),
            (Some(x), Some(y)) => {
                let mut positions: Vec<f64> =
                    x.positions.iter().chain(&y.positions).copied().collect();
                positions.sort_by(f64::total_cmp);
                positions.dedup();
                let mut values: [Option<Vec<f64>>; 6] = Default::default();
                for (c, v) in values.iter_mut().enumerate() {
                    if x.values[c].is_some() || y.values[c].is_some() {
                        *v = Some(
                            positions
                                .iter()
                                .map(|&p| x.sample(p).values[c] + y.sample(p).values[c])
                                .collect(),
                        );
                    }
                }
                Some(MotionTable {
                    positions,
                    values,
                    periodic: x.periodic,
                })
            }
        };
    }
    out
}

/// The simulated measurements of one cut.
#[derive(Debug, Clone)]
pub struct Measured {
    pub on_machine: Points,
    pub cmm: Points,
}

/// A cut of `program` on `machine`: where each planned point was cut.
pub struct Cutting<'a> {
    machine: &'a Machine,
    plan: &'a Plan,
    pub cuts: Vec<Cut>,
}

/// Why a program's cut of a plan cannot be followed.
#[derive(Debug)]
pub enum CuttingError {
    /// The program cannot be read.
    Program(crate::Error),
    /// A planned point (its id) the program does not cut, and why.
    Point(String, String),
}

/// How far (mm) a program's ball centre may pass from a planned point's: farther, the
/// program does not cut it (a compensated program passes up to its corrections away).
pub const MISS: f64 = 0.5;

impl<'a> Cutting<'a> {
    /// Find where `program` (named `path` in messages) cuts every point of `plan`; a
    /// program that cannot be read, or a point it does not cut, is an error.
    pub fn new(
        machine: &'a Machine,
        plan: &'a Plan,
        program: &str,
        path: &str,
    ) -> Result<Self, CuttingError> {
        let nominal = Kinematics::new(machine, &ErrorModel::zero(machine), 0)
            .map_err(|e| CuttingError::Program(crate::Error::Usage(e.to_string())))?;
        let cuts =
            cutting::cuts(&nominal, machine, plan, program, path).map_err(CuttingError::Program)?;
        if cuts.len() != plan.points().count() {
            return Err(CuttingError::Program(crate::Error::Usage(format!(
                "{path}: the program has no cutting (G1, G2, G3) moves"
            ))));
        }
        if let Some(c) = cuts.iter().find(|c| c.miss > MISS) {
            return Err(CuttingError::Point(
                c.id.clone(),
                format!(
                    "planned point `{}` at {:?} is not on the program's path: the ball centre \
                 passes {:.3} mm from it at best (expected the point on a finished surface, \
                 `tool_radius` along its normal from the ball centre)",
                    c.id,
                    [c.at.x, c.at.y, c.at.z],
                    c.miss
                ),
            ));
        }
        Ok(Cutting {
            machine,
            plan,
            cuts,
        })
    }

    /// Cut with `quasi_static` + `dynamic` errors and measure, with noise of standard
    /// deviation `noise` (mm) per coordinate, from `seed`.
    pub fn measure(
        &self,
        quasi_static: &ErrorModel,
        dynamic: &ErrorModel,
        noise: f64,
        seed: u64,
    ) -> crate::Result<Measured> {
        let kin = |m: &ErrorModel| {
            Kinematics::new(self.machine, m, 0).map_err(|e| crate::Error::Usage(e.to_string()))
        };
        let cutting = kin(&sum(quasi_static, dynamic))?;
        let probing = kin(quasi_static)?;
        let length = cutting::tool_length(self.machine, self.plan);
        let r = self.plan.tool_radius;
        let mut rng = Rng::new(seed);
        let mut noisy =
            |v: Vector3<f64>| v + Vector3::new(rng.gauss(), rng.gauss(), rng.gauss()) * noise;
        let mut on_machine = Points::new();
        let mut cmm = Points::new();
        for c in &self.cuts {
            let cut = cutting::deviation(&cutting, c, length, r);
            let probe = cutting::deviation(&probing, c, length, r);
            cmm.insert(c.id.clone(), noisy(c.at + c.normal * cut));
            on_machine.insert(c.id.clone(), noisy(c.at + c.normal * (cut - probe)));
        }
        Ok(Measured { on_machine, cmm })
    }
}

/// Random values for `params`: lengths uniform in ±`length` (mm), angles in ±`angle`
/// (rad).
pub fn random_values(params: &Params, rng: &mut Rng, length: f64, angle: f64) -> Vec<f64> {
    (0..params.len())
        .map(|j| {
            let scale = if params.is_angle(j) { angle } else { length };
            scale * (2.0 * rng.uniform() - 1.0)
        })
        .collect()
}

/// Paper 000's errors (tables 2–3) as the model's terms: the paper's symbol, the term,
/// and the total, quasi-static and dynamic values in the paper's units (mm, degrees).
pub const PAPER: [(&str, &str, f64, f64, f64); 13] = [
    ("eps_yx (X = -50)", "EBX@-50", 0.0062, 0.0031, 0.0031),
    ("eps_yx (X = 50)", "EBX@50", 0.0093, 0.0021, 0.0072),
    ("eps_zx (X = -50)", "ECX@-50", 0.0349, 0.0199, 0.0150),
    ("eps_zx (X = 50)", "ECX@50", 0.0447, 0.0387, 0.0060),
    ("eps_xc", "EA0C", 0.0057, 0.0039, 0.0018),
    ("eps_yc", "EB0C", -0.0055, 0.0021, -0.0076),
    ("eps_ya", "EB0A", 0.0048, 0.0019, 0.0029),
    ("eps_za", "EC0A", 0.0079, 0.0052, 0.0027),
    ("S_yx", "EC0Y", 0.0455, 0.0295, 0.0160),
    ("XOC", "EX0C", 0.0023, 0.0056, -0.0033),
    ("YOC", "EY0C", 0.0085, 0.0060, 0.0025),
    ("XOA", "EY0A", 0.0059, 0.0036, 0.0023),
    ("YOA", "EZ0A", 0.0081, 0.0043, 0.0038),
];

/// The paper's symbol for a term (`EC0Y` → `S_yx`, `EYX@-70` → `delta_yx`).
pub fn paper_symbol(name: &str) -> &'static str {
    let base = name.split('@').next().unwrap_or(name);
    match base {
        "EYX" => "delta_yx",
        "EZX" => "delta_zx",
        "EXY" => "delta_xy",
        "EZY" => "delta_zy",
        "EBX" => "eps_yx",
        "ECX" => "eps_zx",
        _ => PAPER.iter().find(|p| p.1 == base).map_or("", |p| p.0),
    }
}

/// Paper 000's quasi-static and dynamic columns on `params` (mm, rad); the straightness,
/// which the paper gives only as a figure, is random: up to 3 µm quasi-static and 2 µm
/// dynamic.
pub fn paper_values(params: &Params, rng: &mut Rng) -> (Vec<f64>, Vec<f64>) {
    let deg = 1f64.to_radians();
    let mut quasi = random_values(params, rng, 0.003, 0.0);
    let mut dynamic = random_values(params, rng, 0.002, 0.0);
    for (_, term, _, q, d) in PAPER {
        if let Some(j) = params.names.iter().position(|n| n == term) {
            let scale = if params.is_angle(j) { deg } else { 1.0 };
            quasi[j] = q * scale;
            dynamic[j] = d * scale;
        }
    }
    (quasi, dynamic)
}
