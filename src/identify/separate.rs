//! Paper 000's separation of total, quasi-static and dynamic errors, and its formulas.
//!
//! The part is measured twice: on the machine with its probe (x1, the paper's φ) and on a
//! CMM (x2, ω), against the nominal (x0). One formula F turns each set into an error
//! value, and
//!
//! - total = F(x2) − F(x0) (eqs. 3, 8, 13, 16, 19),
//! - quasi-static = F(x2) − F(x1) (eqs. 4, 9, 14, 17, 20),
//! - dynamic = total − quasi-static (eqs. 5, 10, 15, 18, 21).
//!
//! nccomp's F is the least-squares decoupling through the kinematics
//! ([`super::decouple`]); the paper's own F, per feature, are [`straightness`],
//! [`squareness`], [`slope_angle`], [`offset`] and [`tilt`]. Two of the paper's printed
//! equations are not what its tables hold: eq. 18 prints the dynamic offset as
//! (2·x2 − (x0 + x1))/cos 10°, which is not E − E1 = (x1 − x0)/cos 10°; and eqs. 19–21
//! take an unsigned angle, while table 2 has a negative ε_yc. nccomp follows the tables.

use nalgebra::Vector3;

/// Which of the three to use.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Part {
    Total,
    QuasiStatic,
    Dynamic,
}

/// Total, quasi-static and dynamic values of the same named quantities.
#[derive(Debug, Clone, PartialEq)]
pub struct Separation {
    pub names: Vec<String>,
    pub total: Vec<f64>,
    pub quasi_static: Vec<f64>,
    pub dynamic: Vec<f64>,
}

impl Separation {
    /// The separation from F applied to the nominal, on-machine and CMM data.
    pub fn new(names: Vec<String>, nominal: &[f64], on_machine: &[f64], cmm: &[f64]) -> Self {
        let total: Vec<f64> = cmm.iter().zip(nominal).map(|(c, n)| c - n).collect();
        let quasi_static: Vec<f64> = cmm.iter().zip(on_machine).map(|(c, m)| c - m).collect();
        let dynamic = total
            .iter()
            .zip(&quasi_static)
            .map(|(t, q)| t - q)
            .collect();
        Separation {
            names,
            total,
            quasi_static,
            dynamic,
        }
    }

    pub fn part(&self, part: Part) -> &[f64] {
        match part {
            Part::Total => &self.total,
            Part::QuasiStatic => &self.quasi_static,
            Part::Dynamic => &self.dynamic,
        }
    }
}

/// Eqs. 1–2: the deviations of a trace from its first point.
pub fn straightness(trace: &[f64]) -> Vec<f64> {
    trace.iter().map(|v| v - trace[0]).collect()
}

/// Eqs. 6–8: the angle between an X line (slope k_yx = dy/dx) and a Y line (slope
/// k_xy = dx/dy), less 90°.
pub fn squareness(k_yx: f64, k_xy: f64) -> f64 {
    k_yx.atan() - k_xy.atan()
}

/// Eqs. 11–12: the angle of a line of slope `k`.
pub fn slope_angle(k: f64) -> f64 {
    k.atan()
}

/// Eqs. 16–17: an axis offset from a fitted centre coordinate, `(x − x_ref)/cos θ`.
pub fn offset(x: f64, x_ref: f64, angle_deg: f64) -> f64 {
    (x - x_ref) / angle_deg.to_radians().cos()
}

/// Eqs. 19–20 with a sign: the tilt of normal `n` from `n_ref`, as its rotation-vector
/// components (rad) about the coordinate axes. The paper's acos(|n·n_ref|) is the norm.
pub fn tilt(n: &Vector3<f64>, n_ref: &Vector3<f64>) -> Vector3<f64> {
    let (a, b) = (n_ref.normalize(), n.normalize());
    let axis = a.cross(&b);
    let sin = axis.norm();
    if sin < 1e-300 {
        return Vector3::zeros();
    }
    axis / sin * sin.atan2(a.dot(&b))
}
