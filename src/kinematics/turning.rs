//! Turning poses: what a part is cut by while the spindle that carries it turns.
//!
//! While the spindle turns, the tool tip sweeps a circle about the spindle's line (the real
//! machine's line, location errors included) and the part becomes the surface of
//! revolution of those circles. The spindle's angle does not matter; two numbers do: how
//! far the tip is from the line and where it is along it, measured from the plane through
//! the line's point at right angles to it (the chuck face). A turning pose holds them in
//! place of the tip, `p = (u, 0, ζ)`: u the tip's distance from the line along the X
//! axis's direction (so u is the X value a radius-mode program writes, negative past the
//! centre), ζ the position along the line. The direction is fixed, `o = +Z`: a turning
//! tool's direction does not shape the part.
//!
//! Left out is the tip's height v off the line (across the X direction): X and Z cannot
//! change it. The radius turned is √(u² + v²), so it adds v²/2r to a radius r (0.008 µm
//! for v = 4 µm at r = 1 mm) and leaves a pip of radius |v| at the centre.

use super::{Jacobian, Kinematics, KinematicsError, Pose};
use crate::model::AxisKind;
use nalgebra::Vector3;

/// Which variables turning is about.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Turning {
    /// The spindle: a rotary variable of the workpiece chain.
    pub spindle: usize,
    /// The linear variable driven by X words: it sets the sign of the radius.
    x: usize,
}

impl Turning {
    /// The turning pose and its Jacobian from the tip `p` and the spindle line (a point and
    /// unit direction) in the workpiece frame, and the Jacobian of the tip.
    pub(super) fn pose(
        &self,
        p: &Vector3<f64>,
        (point, axis): (Vector3<f64>, Vector3<f64>),
        mut jac: Jacobian,
    ) -> (Pose, Jacobian) {
        let d = p - point;
        let zeta = axis.dot(&d);
        // The X axis's direction, square to the line.
        let x = jac.dp[self.x];
        let across = (x - axis * axis.dot(&x))
            .try_normalize(1e-12)
            .unwrap_or_else(Vector3::x);
        let u = across.dot(&d);
        for k in 0..jac.n {
            let dp = jac.dp[k];
            jac.dp[k] = Vector3::new(across.dot(&dp), 0.0, axis.dot(&dp));
            jac.do_[k] = Vector3::zeros();
        }
        (
            Pose {
                p: Vector3::new(u, 0.0, zeta),
                o: Vector3::z(),
            },
            jac,
        )
    }
}

impl Kinematics {
    /// The same kinematics evaluated as turning: every pose ([`Kinematics::pose`],
    /// [`Kinematics::pose_and_jacobian`], and so the solves and path checks built on them)
    /// is a turning pose about the line of the rotary variable `spindle`, its radius
    /// signed along the linear variable `x` (see the module's text).
    pub fn turning(&self, spindle: usize, x: usize) -> Result<Kinematics, KinematicsError> {
        let in_workpiece = self.nominal.workpiece.iter().any(|j| j.var == spindle);
        if spindle >= self.len() || self.kind(spindle) != AxisKind::Rotary || !in_workpiece {
            return Err(KinematicsError::NotASpindle(spindle));
        }
        if x >= self.len() || self.kind(x) != AxisKind::Linear {
            return Err(KinematicsError::NotLinear(x));
        }
        let mut kin = self.clone();
        kin.turning = Some(Turning { spindle, x });
        Ok(kin)
    }

    /// Whether poses are turning poses.
    pub fn is_turning(&self) -> bool {
        self.turning.is_some()
    }
}
