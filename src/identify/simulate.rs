//! The twin: cut the feature workpiece on a machine with known errors and measure it.
//!
//! - Cutting: the machine runs the program with its quasi-static error model plus a
//!   dynamic error model that acts only while cutting (cutting forces, servo lag: here an
//!   extra set of the same terms). The surface near each planned point is where that
//!   machine put the ball ([`cutting::displacement`]).
//! - On-machine probing: the probe is driven to the planned point through the same
//!   machine, now unloaded, so only the quasi-static errors act; it reports the nominal
//!   coordinates of where it touched: cut surface − quasi-static displacement.
//! - CMM: sees the cut surface itself.
//!
//! Both measurements get seeded Gaussian noise (σ per coordinate).

use super::cutting::{self, Cut};
use super::measure::Points;
use super::plan::Plan;
use super::separate::{self, Decoupling, Separation, error_toml, formulas, nominal_points};
use crate::kinematics::Kinematics;
use crate::model::{ErrorModel, Machine, error_file};

/// Error terms by name (the decoupling's names), mm and rad.
#[derive(Debug, Clone, PartialEq)]
pub struct Terms {
    pub names: Vec<String>,
    pub values: Vec<f64>,
}

impl Terms {
    /// The error model of these terms, through the contract's error file.
    pub fn model(&self, machine: &Machine) -> crate::Result<ErrorModel> {
        let text = error_toml(&self.names, &self.values, "simulated");
        error_file::parse(&text, "<terms>", machine)
    }

    pub fn plus(&self, other: &Terms) -> Terms {
        Terms {
            names: self.names.clone(),
            values: self
                .values
                .iter()
                .zip(&other.values)
                .map(|(a, b)| a + b)
                .collect(),
        }
    }
}

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

/// The term names a plan identifies (its formulas' names).
pub fn term_names(plan: &Plan) -> Vec<String> {
    formulas(plan, &nominal_points(plan))
        .map(|r| r.names)
        .unwrap_or_default()
}

/// Random terms: straightness up to `length` mm, angles up to `angle` rad.
pub fn random_terms(plan: &Plan, rng: &mut Rng, length: f64, angle: f64) -> Terms {
    let names = term_names(plan);
    let values = names
        .iter()
        .map(|n| {
            let scale = if separate::is_angle(n) { angle } else { length };
            scale * (2.0 * rng.uniform() - 1.0)
        })
        .collect();
    Terms { names, values }
}

/// Paper 000's quasi-static and dynamic columns (tables 2–3) on the model's terms, with
/// random straightness (the paper gives straightness only as a figure).
pub fn paper_terms(plan: &Plan, rng: &mut Rng) -> (Terms, Terms) {
    let deg = 1f64.to_radians();
    // (name, quasi-static, dynamic) in mm and degrees.
    let table: [(&str, f64, f64, bool); 13] = [
        ("EBX@-50", 0.0031, 0.0031, true),
        ("EBX@50", 0.0021, 0.0072, true),
        ("ECX@-50", 0.0199, 0.0150, true),
        ("ECX@50", 0.0387, 0.0060, true),
        ("EA0C", 0.0039, 0.0018, true),
        ("EB0C", 0.0021, -0.0076, true),
        ("EB0A", 0.0019, 0.0029, true),
        ("EC0A", 0.0052, 0.0027, true),
        ("EC0Y", 0.0295, 0.0160, true),
        ("EX0C", 0.0056, -0.0033, false),
        ("EY0C", 0.0060, 0.0025, false),
        ("EY0A", 0.0036, 0.0023, false),
        ("EZ0A", 0.0043, 0.0038, false),
    ];
    let mut quasi = random_terms(plan, rng, 0.003, 0.0);
    let mut dynamic = random_terms(plan, rng, 0.002, 0.0);
    for (name, q, d, angle) in table {
        let scale = if angle { deg } else { 1.0 };
        if let Some(i) = quasi.names.iter().position(|n| n == name) {
            quasi.values[i] = q * scale;
            dynamic.values[i] = d * scale;
        }
    }
    (quasi, dynamic)
}

/// The simulated measurements of one cut.
#[derive(Debug, Clone)]
pub struct Measured {
    pub on_machine: Points,
    pub cmm: Points,
}

/// Cut `program` on `machine` with `quasi_static` + `dynamic` errors and measure it. The
/// probe goes to the cutter locations of `planned` (the uncompensated program's).
#[allow(clippy::too_many_arguments)]
pub fn cut_and_measure(
    machine: &Machine,
    plan: &Plan,
    program: &str,
    planned: &[Cut],
    quasi_static: &Terms,
    dynamic: &Terms,
    noise: f64,
    seed: u64,
) -> crate::Result<Measured> {
    let nominal = Kinematics::new(machine, &ErrorModel::zero(machine), 0)
        .map_err(|e| crate::Error::Usage(e.to_string()))?;
    let kin = |t: &Terms| -> crate::Result<Kinematics> {
        Kinematics::new(machine, &t.model(machine)?, 0)
            .map_err(|e| crate::Error::Usage(e.to_string()))
    };
    let cutting = kin(&quasi_static.plus(dynamic))?;
    let probing = kin(quasi_static)?;
    let cuts = cutting::cuts(&nominal, machine, plan, program);
    let length = cutting::tool_length(machine, plan);
    let r = plan.tool_radius;
    let mut rng = Rng::new(seed);
    let mut noisy = |v: nalgebra::Vector3<f64>| {
        v + nalgebra::Vector3::new(rng.gauss(), rng.gauss(), rng.gauss()) * noise
    };
    let mut on_machine = Points::new();
    let mut cmm = Points::new();
    for (cut, probe) in cuts.iter().zip(planned) {
        let surface = cut.at + cutting::displacement(&cutting, cut, length, r);
        let read = surface - cutting::displacement(&probing, probe, length, r);
        cmm.insert(cut.id.clone(), noisy(surface));
        on_machine.insert(cut.id.clone(), noisy(read));
    }
    Ok(Measured { on_machine, cmm })
}

/// The identification: the paper's formulas on the three point sets, then the
/// decoupling onto model terms through the kinematics at the program's cutter locations.
pub struct Identification {
    pub raw: Separation,
    pub model: Separation,
    pub conditioning: (f64, f64),
}

/// Build the decoupling for `plan` cut by `planned` on `machine`.
pub fn decoupling(machine: &Machine, plan: &Plan, planned: &[Cut]) -> crate::Result<Decoupling> {
    let names = term_names(plan);
    let base = formulas(plan, &nominal_points(plan)).map_err(crate::Error::Usage)?;
    let length = cutting::tool_length(machine, plan);
    let mut failure = None;
    let dec = Decoupling::new(names.clone(), |j, step| {
        let mut values = vec![0.0; names.len()];
        values[j] = step;
        let t = Terms {
            names: names.clone(),
            values,
        };
        let result = t.model(machine).and_then(|m| {
            Kinematics::new(machine, &m, 0).map_err(|e| crate::Error::Usage(e.to_string()))
        });
        match result {
            Ok(kin) => {
                let pts: Points = planned
                    .iter()
                    .map(|c| {
                        (
                            c.id.clone(),
                            c.at + cutting::displacement(&kin, c, length, plan.tool_radius),
                        )
                    })
                    .collect();
                let raw = formulas(plan, &pts).unwrap_or_else(|_| base.clone());
                raw.values
                    .iter()
                    .zip(&base.values)
                    .map(|(a, b)| a - b)
                    .collect()
            }
            Err(e) => {
                failure = Some(e);
                vec![0.0; names.len()]
            }
        }
    });
    match failure {
        Some(e) => Err(e),
        None => Ok(dec),
    }
}

/// Identify from measured points.
pub fn identify(
    dec: &Decoupling,
    plan: &Plan,
    on_machine: &Points,
    cmm: &Points,
) -> crate::Result<Identification> {
    let f = |p: &Points| formulas(plan, p).map_err(crate::Error::Usage);
    let raw = Separation::from_raw(&f(&nominal_points(plan))?, &f(on_machine)?, &f(cmm)?);
    let model = dec.separate(&raw);
    Ok(Identification {
        raw,
        model,
        conditioning: dec.singular_values(),
    })
}
