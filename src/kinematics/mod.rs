//! Forward kinematics of the two chains, with and without the error model.
//!
//! A machine is a workpiece chain and a tool chain, each a product of joint transforms
//! from the bed outward (design/model.md). The pose the part is cut by is the tool tip
//! and tool direction seen from the workpiece: `p = W⁻¹·T·t`, `o = R(W⁻¹·T)·u`.
//! Nothing else in nccomp evaluates a machine: compensation, checks and analysis tools
//! all come through [`Kinematics`].

pub mod path;
mod solve;
pub mod tcp;
mod turning;

pub use solve::{Solution, SolveOptions};

use crate::model::{AxisKind, ErrorModel, Machine, MotionTable};
use nalgebra::{Isometry3, Rotation3, Translation3, UnitQuaternion, Vector3};

/// The most axes one active configuration (workpiece chain + one tool chain) may have.
pub const MAX_AXES: usize = 9;

/// The tool tip and tool direction seen from the workpiece (mm, unit vector).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    pub p: Vector3<f64>,
    pub o: Vector3<f64>,
}

impl Pose {
    /// Distance between the tips (mm) and angle between the directions (rad).
    pub fn deviation(&self, other: &Pose) -> (f64, f64) {
        ((self.p - other.p).norm(), angle_between(&self.o, &other.o))
    }
}

/// The angle between two unit vectors, accurate for tiny angles too.
pub fn angle_between(a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    a.cross(b).norm().atan2(a.dot(b))
}

/// Which model to evaluate: the ideal machine or the machine with its errors.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Model {
    Nominal,
    Actual,
}

/// The derivative of the pose with respect to each axis (per mm or per degree), in the
/// workpiece frame, and for rotary axes the direction of their line in that frame.
#[derive(Debug, Clone, Copy)]
pub struct Jacobian {
    pub n: usize,
    /// d p / d q_k.
    pub dp: [Vector3<f64>; MAX_AXES],
    /// d o / d q_k.
    pub do_: [Vector3<f64>; MAX_AXES],
    /// Rotary axes: unit direction of the axis line in the workpiece frame; zero for linear.
    pub axis_dir: [Vector3<f64>; MAX_AXES],
    /// Whether an error table was read beyond its ends.
    pub beyond: bool,
}

#[derive(Debug, Clone)]
struct Joint {
    var: usize,
    kind: AxisKind,
    /// Linear: direction of motion d̃. Rotary: axis direction ã.
    dir: Vector3<f64>,
    /// Linear: error reference point r. Rotary: axis point c̃.
    point: Vector3<f64>,
    /// Rotary: zero-position error e0 (rad).
    zero: f64,
    motion: Option<MotionTable>,
    table_offset: f64,
}

impl Joint {
    /// The joint transform at position q (mm or degrees); sets `beyond` when an error
    /// table was read past its ends.
    fn transform(&self, q: f64, beyond: &mut bool) -> Isometry3<f64> {
        // E(q) = Tr(δ)·Rv(ε), about the joint's reference point.
        let e = self.motion.as_ref().map(|m| {
            let s = m.sample(q + self.table_offset);
            *beyond |= s.beyond;
            let v = s.values;
            (
                Vector3::new(v[0], v[1], v[2]),
                small_rotation(Vector3::new(v[3], v[4], v[5])),
            )
        });
        match self.kind {
            AxisKind::Linear => {
                // Tr(q·d̃) · Tr(r) · E · Tr(−r)
                let mut t = self.dir * q;
                let rot = match e {
                    Some((delta, rot)) => {
                        t += self.point + delta - rot * self.point;
                        rot
                    }
                    None => UnitQuaternion::identity(),
                };
                Isometry3::from_parts(Translation3::from(t), rot)
            }
            AxisKind::Rotary => {
                // Tr(c̃) · E · Rot(ã, q + e0) · Tr(−c̃)
                let turn =
                    UnitQuaternion::from_scaled_axis(self.dir * (q.to_radians() + self.zero));
                let (delta, rot) = match e {
                    Some((delta, erot)) => (delta, erot * turn),
                    None => (Vector3::zeros(), turn),
                };
                let t = self.point + delta - rot * self.point;
                Isometry3::from_parts(Translation3::from(t), rot)
            }
        }
    }
}

/// `UnitQuaternion::from_scaled_axis(v)` for the micro-radians of error motions without
/// the sine and cosine: below 1 mrad their series to the fourth term are exact in f64.
/// As nalgebra does, a half angle of at most machine epsilon is no rotation.
fn small_rotation(v: Vector3<f64>) -> UnitQuaternion<f64> {
    let h = v / 2.0;
    let nn = h.norm_squared();
    if nn > 0.25e-6 {
        return UnitQuaternion::from_scaled_axis(v);
    }
    if nn <= f64::EPSILON * f64::EPSILON {
        return UnitQuaternion::identity();
    }
    // cos n and sin n / n for the half angle n, by their series in n².
    let w = 1.0 - nn * (0.5 - nn * (1.0 / 24.0 - nn / 720.0));
    let k = 1.0 - nn * (1.0 / 6.0 - nn * (1.0 / 120.0 - nn / 5040.0));
    UnitQuaternion::new_unchecked(nalgebra::Quaternion::from_parts(w, h * k))
}

#[derive(Debug, Clone)]
struct Chains {
    workpiece: Vec<Joint>,
    tool: Vec<Joint>,
}

/// The kinematics of one active configuration of a machine: its workpiece chain and one
/// tool chain, nominal and with errors.
#[derive(Debug, Clone)]
pub struct Kinematics {
    /// Machine axis index of each variable, in the machine file's axis order.
    axes: Vec<usize>,
    kinds: Vec<AxisKind>,
    nominal: Chains,
    actual: Chains,
    reference_tool: f64,
    /// Set: poses are turning poses (see [`Kinematics::turning`]).
    turning: Option<turning::Turning>,
}

/// Problems setting up kinematics.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum KinematicsError {
    #[error("machine has no tool chain named `{0}`")]
    NoSuchToolChain(String),
    #[error("the active configuration has {0} axes; at most {MAX_AXES} are supported")]
    TooManyAxes(usize),
    #[error("variable {0} is not a rotary axis of the workpiece chain: it cannot be a spindle")]
    NotASpindle(usize),
    #[error("variable {0} is not a linear axis")]
    NotLinear(usize),
}

impl Kinematics {
    /// Kinematics of `machine` with `errors`, using the tool chain at index `tool_chain`.
    pub fn new(
        machine: &Machine,
        errors: &ErrorModel,
        tool_chain: usize,
    ) -> Result<Self, KinematicsError> {
        let tool = machine
            .tool_chains
            .get(tool_chain)
            .ok_or_else(|| KinematicsError::NoSuchToolChain(tool_chain.to_string()))?;
        // Variables in the machine file's axis order, whichever chain moves them.
        let mut axes: Vec<usize> = machine
            .workpiece_chain
            .iter()
            .chain(tool.axes.iter())
            .copied()
            .collect();
        axes.sort_unstable();
        axes.dedup();
        if axes.len() > MAX_AXES {
            return Err(KinematicsError::TooManyAxes(axes.len()));
        }
        let zero = ErrorModel::zero(machine);
        let build = |model: &ErrorModel| {
            let joint = |i: usize| {
                let var = axes.iter().position(|&a| a == i).unwrap_or(0);
                let axis = &machine.axes[i];
                let err = &model.axes[i];
                match axis.kind {
                    AxisKind::Linear => Joint {
                        var,
                        kind: AxisKind::Linear,
                        dir: Rotation3::new(err.squareness) * axis.direction,
                        point: axis.point,
                        zero: 0.0,
                        motion: err.motion.clone(),
                        table_offset: axis.table_offset,
                    },
                    AxisKind::Rotary => Joint {
                        var,
                        kind: AxisKind::Rotary,
                        dir: Rotation3::new(err.location_tilt) * axis.direction,
                        point: axis.point + err.location_shift,
                        zero: err.zero,
                        motion: err.motion.clone(),
                        table_offset: axis.table_offset,
                    },
                }
            };
            Chains {
                workpiece: machine.workpiece_chain.iter().map(|&i| joint(i)).collect(),
                tool: tool.axes.iter().map(|&i| joint(i)).collect(),
            }
        };
        Ok(Kinematics {
            kinds: axes.iter().map(|&i| machine.axes[i].kind).collect(),
            nominal: build(&zero),
            actual: build(errors),
            axes,
            reference_tool: machine.tool.length,
            turning: None,
        })
    }

    /// Number of variables (axes of the active configuration).
    pub fn len(&self) -> usize {
        self.axes.len()
    }

    pub fn is_empty(&self) -> bool {
        self.axes.is_empty()
    }

    /// The machine axis index of each variable.
    pub fn axes(&self) -> &[usize] {
        &self.axes
    }

    pub fn kind(&self, var: usize) -> AxisKind {
        self.kinds[var]
    }

    fn chains(&self, model: Model) -> &Chains {
        match model {
            Model::Nominal => &self.nominal,
            Model::Actual => &self.actual,
        }
    }

    /// The tool tip in the tool chain's end frame for an active tool length `length`.
    pub fn tip(&self, length: f64) -> Vector3<f64> {
        Vector3::new(0.0, 0.0, -(length - self.reference_tool))
    }

    /// The pose at axis values `q` (mm, degrees) with the tool of length `length` (a
    /// turning pose for kinematics made by [`Kinematics::turning`]).
    /// The flag tells whether an error table was read beyond its ends.
    pub fn pose(&self, model: Model, q: &[f64], length: f64) -> (Pose, bool) {
        if self.turning.is_some() {
            let (pose, jac) = self.pose_and_jacobian(model, q, length);
            return (pose, jac.beyond);
        }
        let chains = self.chains(model);
        let mut beyond = false;
        let w = chains
            .workpiece
            .iter()
            .fold(Isometry3::identity(), |acc, j| {
                acc * j.transform(q[j.var], &mut beyond)
            });
        let t = chains.tool.iter().fold(Isometry3::identity(), |acc, j| {
            acc * j.transform(q[j.var], &mut beyond)
        });
        let x = w.inv_mul(&t);
        let p = x.transform_point(&self.tip(length).into()).coords;
        let o = x.rotation * Vector3::z();
        (Pose { p, o }, beyond)
    }

    /// The pose and its Jacobian at `q`. The Jacobian leaves out the (tiny) change of the
    /// error motions with position; the solve only needs it to point the way.
    pub fn pose_and_jacobian(&self, model: Model, q: &[f64], length: f64) -> (Pose, Jacobian) {
        let chains = self.chains(model);
        let mut beyond = false;
        // Per joint: its kind, the world direction (of motion or of the rotation axis)
        // and, for rotary joints, a world point on the axis line.
        let mut frames = [(AxisKind::Linear, Vector3::zeros(), Vector3::zeros(), 0.0); MAX_AXES];
        let mut walk = |joints: &[Joint], sign: f64| {
            let mut acc = Isometry3::identity();
            for j in joints {
                let jt = j.transform(q[j.var], &mut beyond);
                match j.kind {
                    AxisKind::Linear => {
                        frames[j.var] = (j.kind, acc.rotation * j.dir, Vector3::zeros(), sign);
                    }
                    AxisKind::Rotary => {
                        // The axis line is carried by everything before the turn, including
                        // the joint's own error motion: evaluate the joint at q with the
                        // turn removed.
                        let turn = UnitQuaternion::from_scaled_axis(
                            j.dir * (q[j.var].to_radians() + j.zero),
                        );
                        let turn_inv = turn.inverse();
                        let undo_turn = Isometry3::from_parts(
                            Translation3::from(j.point - turn_inv * j.point),
                            turn_inv,
                        );
                        let before = jt * undo_turn;
                        let m = acc * before;
                        frames[j.var] = (
                            j.kind,
                            m.rotation * j.dir,
                            m.transform_point(&j.point.into()).coords,
                            sign,
                        );
                    }
                }
                acc *= jt;
            }
            acc
        };
        let w = walk(&chains.workpiece, -1.0);
        let t = walk(&chains.tool, 1.0);
        let x = w.inv_mul(&t);
        let tip = self.tip(length);
        let p = x.transform_point(&tip.into()).coords;
        let o = x.rotation * Vector3::z();
        // World tip and direction, to take velocities of.
        let pw = t.transform_point(&tip.into()).coords;
        let ow = t.rotation * Vector3::z();
        let winv = w.rotation.inverse();
        let mut jac = Jacobian {
            n: self.axes.len(),
            dp: [Vector3::zeros(); MAX_AXES],
            do_: [Vector3::zeros(); MAX_AXES],
            axis_dir: [Vector3::zeros(); MAX_AXES],
            beyond,
        };
        for (k, &(kind, dir, point, sign)) in frames.iter().enumerate().take(self.axes.len()) {
            match kind {
                AxisKind::Linear => {
                    jac.dp[k] = winv * (dir * sign);
                }
                AxisKind::Rotary => {
                    let w_rad = dir * (sign * std::f64::consts::PI / 180.0);
                    jac.dp[k] = winv * w_rad.cross(&(pw - point));
                    jac.do_[k] = winv * w_rad.cross(&ow);
                    jac.axis_dir[k] = winv * dir;
                }
            }
        }
        if let Some(turning) = &self.turning {
            let (_, dir, point, _) = frames[turning.spindle];
            let line = (w.inverse_transform_point(&point.into()).coords, winv * dir);
            return turning.pose(&p, line, jac);
        }
        (Pose { p, o }, jac)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    proptest::proptest! {
        #[test]
        fn small_rotations_are_the_scaled_axis_rotations(
            x in -1e-3..1e-3f64, y in -1e-3..1e-3f64, z in -1e-3..1e-3f64, scale in -12i32..1,
        ) {
            let v = Vector3::new(x, y, z) * 10f64.powi(scale);
            let ours = small_rotation(v);
            let std = UnitQuaternion::from_scaled_axis(v);
            for (a, b) in ours.coords.iter().zip(std.coords.iter()) {
                proptest::prop_assert!((a - b).abs() <= 2.0 * f64::EPSILON * b.abs().max(1e-300), "{v:?}: {ours:?} {std:?}");
            }
        }
    }

    #[test]
    fn no_rotation_is_the_identity() {
        assert_eq!(small_rotation(Vector3::zeros()), UnitQuaternion::identity());
    }
}
