//! Touch-probe pre-travel: variable-speed compensation of probing programs (paper 001).
//!
//! A touch-trigger probe latches its position a little after the stylus touches the part:
//! the **pre-travel** in a direction (α, β) is `w = wT(α, β) + v(α, β)·τ`, a part that
//! belongs to the transducer (three-lobed on a kinematic probe) and a part that grows with
//! the probing speed v through the delay τ between trigger and latch. Choosing the speed
//! per direction so that the total is the same everywhere removes the systematic probing
//! error without any controller arithmetic:
//!
//! ```text
//! v(α, β) = v0(α, β) + s·(R − r(α, β)) / τ
//! ```
//!
//! where `r` is the trigger radius (or pre-travel) measured at `v0`, `R` the common value
//! it is brought to and `s` the sign with which it grows with pre-travel.
//!
//! The modules follow the work: [`delay`] fits τ from ring-gauge radii at several
//! speeds; [`map`] reads the direction map and interpolates it; [`speeds`] applies the
//! speed law (iterating when trigger radius stands in for pre-travel); [`rewrite`] sets
//! the F words of a probing program's G31/G38.x moves; [`report`] and [`plot`] show the
//! result.
//!
//! # Conventions
//!
//! * Probe frame: `z` is the probe axis (the tool direction, from the stylus tip towards
//!   the spindle); `x` is the program's +X projected onto the plane normal to `z` (the
//!   program's +Y if the axis is within about 25° of X), `y = z × x`.
//! * α is the azimuth of a direction in the probe's XY plane, counted from +x towards +y,
//!   in degrees, 0 ≤ α < 360. β is the elevation from that plane, positive towards +z
//!   (the spindle), −90 ≤ β ≤ 90.
//! * A probing direction is the direction the stylus tip travels relative to the part: a
//!   move straight down onto a surface has β = −90°.
//! * Lengths are mm, speeds mm/min, τ in ms; `v·τ` in mm is `v · τ / 60000`.

mod csvio;
pub mod delay;
pub mod map;
pub mod plot;
pub mod report;
pub mod rewrite;
pub mod speeds;

use nalgebra::{Rotation3, Vector3};
use std::fmt;

pub use delay::{DelayFit, RingPoint};
pub use map::{DirectionMap, MapPoint};
pub use rewrite::{FrameSource, ProbingMove, RewriteOptions, RewriteSummary};
pub use speeds::{SpeedOptions, SpeedPlan};

/// The speed-dependent part of pre-travel, mm, for a speed in mm/min and a delay in ms.
pub fn speed_term(speed: f64, tau_ms: f64) -> f64 {
    speed * tau_ms / 60_000.0
}

/// The speed change (mm/min) that changes pre-travel by `length` mm with delay `tau_ms`.
pub fn speed_for(length: f64, tau_ms: f64) -> f64 {
    length * 60_000.0 / tau_ms
}

/// Whether `x` is a positive finite number.
pub fn positive(x: f64) -> bool {
    x > 0.0 && x.is_finite()
}

/// A direction in the probe frame, in degrees (see the module's conventions).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Direction {
    /// Azimuth from +x, 0 ≤ α < 360.
    pub alpha: f64,
    /// Elevation from the probe's XY plane, −90 ≤ β ≤ 90, positive towards the spindle.
    pub beta: f64,
}

impl Direction {
    /// A direction with α brought into [0, 360).
    pub fn new(alpha: f64, beta: f64) -> Self {
        Direction {
            alpha: normalise_alpha(alpha),
            beta,
        }
    }

    /// The unit vector in the probe frame.
    pub fn unit(&self) -> Vector3<f64> {
        let (a, b) = (self.alpha.to_radians(), self.beta.to_radians());
        Vector3::new(b.cos() * a.cos(), b.cos() * a.sin(), b.sin())
    }

    /// The direction of a vector given in the probe frame (`None` for a zero vector).
    pub fn from_vector(v: &Vector3<f64>) -> Option<Self> {
        let n = v.norm();
        if !positive(n) {
            return None;
        }
        let u = v / n;
        let beta = u.z.clamp(-1.0, 1.0).asin().to_degrees();
        let alpha = if u.x.hypot(u.y) < 1e-12 {
            0.0
        } else {
            u.y.atan2(u.x).to_degrees()
        };
        Some(Direction::new(alpha, beta))
    }

    /// Whether the direction is along the probe axis (α means nothing there).
    pub fn is_pole(&self) -> bool {
        self.beta.abs() >= 90.0 - POLE_TOLERANCE
    }
}

/// Elevations this close to ±90° are taken as the pole.
pub const POLE_TOLERANCE: f64 = 1e-6;

/// α in [0, 360).
pub fn normalise_alpha(alpha: f64) -> f64 {
    let a = alpha.rem_euclid(360.0);
    if a >= 360.0 - 1e-12 { 0.0 } else { a }
}

impl fmt::Display for Direction {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "α = {:.1}°, β = {:.1}°", self.alpha, self.beta)
    }
}

/// The probe frame: its axes as unit vectors in program (or workpiece) coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProbeFrame {
    pub x: Vector3<f64>,
    pub y: Vector3<f64>,
    /// The probe axis, from the stylus tip towards the spindle.
    pub z: Vector3<f64>,
}

impl ProbeFrame {
    /// The frame of a probe whose axis is `axis` (need not be a unit vector): x is the
    /// program's +X projected onto the plane normal to the axis, or, for an axis within
    /// about 25° of X, y is the program's +Y projected and x = y × z.
    pub fn from_axis(axis: &Vector3<f64>) -> Option<Self> {
        let n = axis.norm();
        if !positive(n) {
            return None;
        }
        let z = axis / n;
        let (x, y) = if z.x.abs() < 0.9 {
            let x = (Vector3::x() - z * z.x).normalize();
            (x, z.cross(&x))
        } else {
            let y = (Vector3::y() - z * z.y).normalize();
            (y.cross(&z), y)
        };
        Some(ProbeFrame { x, y, z })
    }

    /// The frame whose axes are the columns of `r` (the probe frame carried by a rotation).
    pub fn from_rotation(r: &Rotation3<f64>) -> Self {
        ProbeFrame {
            x: r * Vector3::x(),
            y: r * Vector3::y(),
            z: r * Vector3::z(),
        }
    }

    /// The standard frame: probe axis +Z, α from +X.
    pub fn vertical() -> Self {
        ProbeFrame {
            x: Vector3::x(),
            y: Vector3::y(),
            z: Vector3::z(),
        }
    }

    /// The direction, in this frame, of a vector given in program coordinates.
    pub fn direction_of(&self, v: &Vector3<f64>) -> Option<Direction> {
        Direction::from_vector(&Vector3::new(
            v.dot(&self.x),
            v.dot(&self.y),
            v.dot(&self.z),
        ))
    }
}

/// Which way the measured radius moves when pre-travel grows.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Surface {
    /// An inside surface (ring gauge, bore; the paper's test rig): the probe triggers
    /// later, further out, so the radius grows with pre-travel and with speed.
    #[default]
    Inside,
    /// An outside surface (sphere, plug): the radius shrinks as pre-travel grows.
    Outside,
}

impl Surface {
    /// +1 when the radius grows with pre-travel, −1 when it shrinks.
    pub fn sign(self) -> f64 {
        match self {
            Surface::Inside => 1.0,
            Surface::Outside => -1.0,
        }
    }
}

/// What the map's `radius` column holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum MapKind {
    /// Trigger radius: the distance from the best-fit centre of the trigger points to each
    /// trigger point (what a ring gauge or a reference sphere gives). The speeds are found
    /// by iterating: predict the trigger points at the new speeds, refit the centre,
    /// correct the speeds, until the radius is the same in every direction.
    #[default]
    Radius,
    /// Pre-travel itself (the paper's `w`, from the probe's rest position): the speed law
    /// is applied once and is exact.
    PreTravel,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn directions_round_trip() {
        for &(a, b) in &[(0.0, 0.0), (120.0, 30.0), (359.0, -45.0), (210.0, 80.0)] {
            let d = Direction::new(a, b);
            let back = Direction::from_vector(&(d.unit() * 3.0)).unwrap();
            assert!((back.alpha - a).abs() < 1e-9 && (back.beta - b).abs() < 1e-9);
        }
        let down = Direction::from_vector(&Vector3::new(0.0, 0.0, -2.0)).unwrap();
        assert_eq!((down.alpha, down.beta), (0.0, -90.0));
        assert!(down.is_pole());
        assert_eq!(Direction::new(-90.0, 0.0).alpha, 270.0);
        assert_eq!(Direction::new(720.0, 0.0).alpha, 0.0);
    }

    #[test]
    fn frames_from_an_axis() {
        let f = ProbeFrame::from_axis(&Vector3::new(0.0, 0.0, 5.0)).unwrap();
        assert_eq!(f, ProbeFrame::vertical());
        // A horizontal probe along +X: x is taken from +Y's side.
        let f = ProbeFrame::from_axis(&Vector3::x()).unwrap();
        assert!((f.z - Vector3::x()).norm() < 1e-12);
        assert!((f.y - Vector3::y()).norm() < 1e-12);
        assert!((f.x.cross(&f.y) - f.z).norm() < 1e-12);
        // A probe along −Y: x stays +X.
        let f = ProbeFrame::from_axis(&-Vector3::y()).unwrap();
        assert!((f.x - Vector3::x()).norm() < 1e-12);
        let d = f.direction_of(&Vector3::new(0.0, -1.0, 0.0)).unwrap();
        assert_eq!(d.beta, 90.0);
        assert!(ProbeFrame::from_axis(&Vector3::zeros()).is_none());
    }

    #[test]
    fn speed_term_in_mm() {
        // The paper's OMP40-2: τ = 12.68 ms at 50 mm/min is 10.57 µm of pre-travel.
        assert!((speed_term(50.0, 12.68) - 0.010_566_7).abs() < 1e-7);
        assert!((speed_for(speed_term(37.0, 12.68), 12.68) - 37.0).abs() < 1e-9);
    }
}
