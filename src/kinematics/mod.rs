//! Forward kinematics of the two chains, with and without the error model.
//!
//! A machine is a workpiece chain and a tool chain, each a product of joint transforms
//! from the bed outward (design/model.md). The pose the part is cut by is the tool tip
//! and tool direction seen from the workpiece: `p = W⁻¹·T·t`, `o = R(W⁻¹·T)·u`.
//! Nothing else in nccomp evaluates a machine: compensation, checks and analysis tools
//! all come through [`Kinematics`].

mod bound;
mod chain;
pub mod path;
mod solve;
pub mod tcp;
mod turning;

pub use bound::Sag;
pub use chain::Angles;
pub use solve::{Solution, SolveOptions, Written};

use crate::model::{AxisKind, ErrorModel, Machine};
use chain::{Joint, Twist};
use nalgebra::{Rotation3, Vector3};

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
    let (y, x) = (a.cross(b).norm(), a.dot(b));
    if x > 0.0 && y <= 1e-2 * x {
        // The micro-radians between a real and a nominal pose, twice per block: atan's
        // series to the 9th power is exact there (the next term is below 10⁻²⁰·t).
        let t = y / x;
        let tt = t * t;
        return t
            * (1.0 - tt * (1.0 / 3.0 - tt * (1.0 / 5.0 - tt * (1.0 / 7.0 - tt * (1.0 / 9.0)))));
    }
    y.atan2(x)
}

/// Which model to evaluate: the ideal machine or the machine with its errors.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Model {
    Nominal,
    Actual,
}

/// The rotary axes' directions in the workpiece frame, entry per variable (zero for linear
/// axes).
pub type AxisDirs = [Vector3<f64>; MAX_AXES];

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

impl Jacobian {
    pub(crate) fn zero(n: usize, beyond: bool) -> Self {
        Jacobian {
            n,
            dp: [Vector3::zeros(); MAX_AXES],
            do_: [Vector3::zeros(); MAX_AXES],
            axis_dir: [Vector3::zeros(); MAX_AXES],
            beyond,
        }
    }
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
    /// Bit k set: variable k is a rotary axis.
    rotary: u32,
    nominal: Chains,
    actual: Chains,
    reference_tool: f64,
    /// Set: poses are turning poses (see [`Kinematics::turning`]).
    turning: Option<turning::Turning>,
    /// The error model's size, for [`Kinematics::path_sag`].
    bound: bound::PathBound,
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
        let axes = machine.variables(tool_chain);
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
                    AxisKind::Linear => Joint::new(
                        var,
                        AxisKind::Linear,
                        Rotation3::new(err.squareness) * axis.direction,
                        axis.point,
                        0.0,
                        err.motion.clone(),
                        axis.table_offset,
                    ),
                    AxisKind::Rotary => Joint::new(
                        var,
                        AxisKind::Rotary,
                        Rotation3::new(err.location_tilt) * axis.direction,
                        axis.point + err.location_shift,
                        err.zero,
                        err.motion.clone(),
                        axis.table_offset,
                    ),
                }
            };
            Chains {
                workpiece: machine.workpiece_chain.iter().map(|&i| joint(i)).collect(),
                tool: tool.axes.iter().map(|&i| joint(i)).collect(),
            }
        };
        let kinds: Vec<AxisKind> = axes.iter().map(|&i| machine.axes[i].kind).collect();
        let rotary = kinds
            .iter()
            .enumerate()
            .filter(|(_, k)| **k == AxisKind::Rotary)
            .fold(0, |m, (v, _)| m | 1 << v);
        let (nominal, actual) = (build(&zero), build(errors));
        let bound = bound::PathBound::new(
            actual.workpiece.iter().chain(&actual.tool),
            nominal.workpiece.iter().chain(&nominal.tool),
        );
        Ok(Kinematics {
            kinds,
            rotary,
            nominal,
            actual,
            axes,
            reference_tool: machine.tool.length,
            turning: None,
            bound,
        })
    }

    /// These kinematics with the linear variables' values shifted by `shift` (mm): a
    /// program zero `shift` away from the one the machine file's geometry is given in.
    pub fn shifted(&self, shift: &[f64]) -> Kinematics {
        let mut kin = self.clone();
        for chains in [&mut kin.nominal, &mut kin.actual] {
            for joint in chains.workpiece.iter_mut().chain(chains.tool.iter_mut()) {
                if joint.kind == AxisKind::Linear {
                    joint.shift = shift.get(joint.var).copied().unwrap_or(0.0);
                }
            }
        }
        kin.bound = self.bound.shifted(shift);
        kin
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

    /// The sines and cosines of the rotary axes at `q`, for [`Kinematics::pose_near`].
    pub fn angles(&self, q: &[f64]) -> Angles {
        Angles::new(&q[..self.len()], self.rotary)
    }

    /// The pose at axis values `q` (mm, degrees) with the tool of length `length` (a
    /// turning pose for kinematics made by [`Kinematics::turning`]).
    /// The flag tells whether an error table was read beyond its ends.
    pub fn pose(&self, model: Model, q: &[f64], length: f64) -> (Pose, bool) {
        self.pose_at(model, q, length, &self.angles(q))
    }

    /// [`Kinematics::pose`] at `q` near the axis values `near` was made for: the rotary
    /// axes' sines and cosines by angle addition instead of anew (the same values to the
    /// last bit or two).
    pub fn pose_near(&self, model: Model, q: &[f64], length: f64, near: &Angles) -> (Pose, bool) {
        self.pose_at(model, q, length, &near.near(&q[..self.len()]))
    }

    pub(crate) fn pose_at(
        &self,
        model: Model,
        q: &[f64],
        length: f64,
        angles: &Angles,
    ) -> (Pose, bool) {
        if self.turning.is_some() {
            let (pose, jac) = self.jacobian_at(model, q, length, angles);
            return (pose, jac.beyond);
        }
        self.carry::<false>(model, q, length, angles, None)
    }

    /// p = W⁻¹·T·t and o = R(W⁻¹·T)·u, applied joint by joint to t and u (and with `AXES`
    /// the rotary axes' directions, into `axes`, to the workpiece frame).
    #[inline]
    fn carry<const AXES: bool>(
        &self,
        model: Model,
        q: &[f64],
        length: f64,
        angles: &Angles,
        axes: Option<&mut chain::CarriedAxes<'_>>,
    ) -> (Pose, bool) {
        let chains = self.chains(model);
        let mut beyond = false;
        let mut c = chain::Carried {
            x: self.tip(length),
            d: Vector3::z(),
            axes,
        };
        chain::carry_out::<AXES>(&chains.tool, q, angles, &mut beyond, &mut c);
        chain::carry_in::<AXES>(&chains.workpiece, q, angles, &mut beyond, &mut c);
        (Pose { p: c.x, o: c.d }, beyond)
    }

    /// The pose and its Jacobian at `q`. The Jacobian includes the error motions' change
    /// with position (their tables' slopes), to first order in the error angles.
    pub fn pose_and_jacobian(&self, model: Model, q: &[f64], length: f64) -> (Pose, Jacobian) {
        self.jacobian_at(model, q, length, &self.angles(q))
    }

    /// The pose, and of its Jacobian only the rotary axes' directions (entry per variable,
    /// zero for linear axes), written into `dirs`. The flag: an error table was read
    /// beyond its ends.
    pub(crate) fn axes_at(
        &self,
        model: Model,
        q: &[f64],
        length: f64,
        angles: &Angles,
        dirs: &mut AxisDirs,
    ) -> (Pose, bool) {
        if self.turning.is_some() {
            let (pose, jac) = self.jacobian_at(model, q, length, angles);
            *dirs = jac.axis_dir;
            return (pose, jac.beyond);
        }
        let mut axes = chain::CarriedAxes::new(dirs);
        self.carry::<true>(model, q, length, angles, Some(&mut axes))
    }

    /// [`Kinematics::pose_and_jacobian`] with the rotary axes' sines and cosines given:
    /// the columns carried with the tip and direction (see [`chain::CarriedAxes`]), or for
    /// turning poses, which need the spindle's line, by a walk along the chains.
    pub(crate) fn jacobian_at(
        &self,
        model: Model,
        q: &[f64],
        length: f64,
        angles: &Angles,
    ) -> (Pose, Jacobian) {
        if self.turning.is_some() {
            return self.walk_jacobian(model, q, length, angles);
        }
        let mut jac = Jacobian::zero(self.len(), false);
        let pose = self.jacobian_into(model, q, length, angles, &mut jac);
        (pose, jac)
    }

    /// [`Kinematics::jacobian_at`] written into `jac`: a Jacobian is 650 bytes, and
    /// returned it is copied (a time profile put that copy at 2 % of a compensation run).
    /// `jac` comes from [`Jacobian::zero`] (or an earlier call) for these kinematics: every
    /// entry a joint moves is written, and the others stay zero, so it is not cleared again.
    pub(crate) fn jacobian_into(
        &self,
        model: Model,
        q: &[f64],
        length: f64,
        angles: &Angles,
        jac: &mut Jacobian,
    ) -> Pose {
        if self.turning.is_some() {
            let pose;
            (pose, *jac) = self.walk_jacobian(model, q, length, angles);
            return pose;
        }
        debug_assert_eq!(jac.n, self.len());
        let mut axes = chain::CarriedAxes {
            dirs: &mut jac.axis_dir,
            columns: Some(chain::Columns {
                dp: &mut jac.dp,
                do_: &mut jac.do_,
            }),
            carried: 0,
            // On the nominal machine a linear axis turns nothing: 12 of the 30 products
            // a joint of a five-axis chain would take are of zeros.
            turning: match model {
                Model::Nominal => self.rotary,
                Model::Actual => u32::MAX,
            },
        };
        let (pose, beyond) = self.carry::<true>(model, q, length, angles, Some(&mut axes));
        jac.beyond = beyond;
        pose
    }

    /// The pose and Jacobian by products of the joints' transforms along each chain.
    fn walk_jacobian(
        &self,
        model: Model,
        q: &[f64],
        length: f64,
        angles: &Angles,
    ) -> (Pose, Jacobian) {
        let chains = self.chains(model);
        let mut beyond = false;
        // Each variable moves one joint of one chain: one table of motions serves both.
        let mut twists = [Twist::default(); MAX_AXES];
        let w = chain::walk::<true>(&chains.workpiece, q, angles, &mut beyond, &mut twists);
        let t = chain::walk::<true>(&chains.tool, q, angles, &mut beyond, &mut twists);
        // The world tip and direction, to take velocities of.
        let pw = t.apply(&self.tip(length));
        let ow = t.r.column(2);
        let p = w.apply_inverse(&pw);
        let o = w.r.tr_mul(&ow);
        let mut jac = Jacobian::zero(self.len(), beyond);
        // The tool's motion moves the tip; the workpiece's moves the part the other way.
        let mut column = |k: usize, sign: f64| {
            let tw = &twists[k];
            if self.kinds[k] == AxisKind::Rotary {
                jac.axis_dir[k] = w.r.tr_mul(&tw.axis);
            }
            let v = tw.omega.cross(&(pw - tw.c)) + tw.v;
            jac.dp[k] = w.r.tr_mul(&(v * sign));
            jac.do_[k] = w.r.tr_mul(&(tw.omega.cross(&ow) * sign));
        };
        for j in &chains.workpiece {
            column(j.var, -1.0);
        }
        for j in &chains.tool {
            column(j.var, 1.0);
        }
        if let Some(turning) = &self.turning {
            let tw = &twists[turning.spindle];
            let line = (w.apply_inverse(&tw.c), w.r.tr_mul(&tw.axis));
            return turning.pose(&p, line, jac);
        }
        (Pose { p, o }, jac)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{error_file, machine_file};
    use nalgebra::{Isometry3, Translation3, UnitQuaternion};
    use std::path::Path;

    fn fixture(name: &str) -> (Machine, ErrorModel) {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures");
        let machine = machine_file::load(&dir.join(format!("{name}.machine.toml"))).unwrap();
        let errors = error_file::load(&dir.join(format!("{name}.errors.toml")), &machine).unwrap();
        (machine, errors)
    }

    /// design/model.md's joint transforms word for word, with nalgebra's isometries.
    fn reference_pose(
        machine: &Machine,
        errors: &ErrorModel,
        chain: usize,
        vars: &[usize],
        q: &[f64],
        length: f64,
    ) -> Pose {
        let joint = |i: usize| {
            let axis = &machine.axes[i];
            let err = &errors.axes[i];
            let x = q[vars.iter().position(|&a| a == i).unwrap()];
            let e = err.motion.as_ref().map_or(Isometry3::identity(), |m| {
                let v = m.sample(x + axis.table_offset).values;
                Isometry3::from_parts(
                    Translation3::new(v[0], v[1], v[2]),
                    UnitQuaternion::from_scaled_axis(Vector3::new(v[3], v[4], v[5])),
                )
            });
            match axis.kind {
                AxisKind::Linear => {
                    let d = Rotation3::new(err.squareness) * axis.direction;
                    let r = axis.point;
                    Isometry3::translation(d.x * x, d.y * x, d.z * x)
                        * Isometry3::translation(r.x, r.y, r.z)
                        * e
                        * Isometry3::translation(-r.x, -r.y, -r.z)
                }
                AxisKind::Rotary => {
                    let a = Rotation3::new(err.location_tilt) * axis.direction;
                    let c = axis.point + err.location_shift;
                    let turn = UnitQuaternion::from_scaled_axis(a * (x.to_radians() + err.zero));
                    Isometry3::translation(c.x, c.y, c.z)
                        * e
                        * Isometry3::from_parts(Translation3::identity(), turn)
                        * Isometry3::translation(-c.x, -c.y, -c.z)
                }
            }
        };
        let product = |axes: &[usize]| {
            axes.iter()
                .fold(Isometry3::identity(), |acc, &i| acc * joint(i))
        };
        let w = product(&machine.workpiece_chain);
        let t = product(&machine.tool_chains[chain].axes);
        let x = w.inv_mul(&t);
        let tip = Vector3::new(0.0, 0.0, -(length - machine.tool.length));
        Pose {
            p: x.transform_point(&tip.into()).coords,
            o: x.rotation * Vector3::z(),
        }
    }

    const MACHINES: [&str; 5] = [
        "ac_trunnion",
        "bc_trunnion",
        "head_head",
        "grinder",
        "mill_turn",
    ];

    /// Axis values within (or a little beyond) each axis's travel, from unit numbers.
    fn axis_values(machine: &Machine, kin: &Kinematics, u: &[f64]) -> Vec<f64> {
        kin.axes()
            .iter()
            .zip(u)
            .map(|(&i, &u)| {
                let [lo, hi] = machine.axes[i].travel.unwrap_or([-200.0, 200.0]);
                lo - 5.0 + u * (hi - lo + 10.0)
            })
            .collect()
    }

    proptest::proptest! {
        #[test]
        fn poses_follow_the_contract_formulas(
            m in 0..MACHINES.len(),
            u in proptest::collection::vec(0.0..1.0f64, MAX_AXES),
            length in 0.0..150.0f64,
            near in proptest::collection::vec(-0.4..0.4f64, MAX_AXES),
        ) {
            let (machine, errors) = fixture(MACHINES[m]);
            for chain in 0..machine.tool_chains.len() {
                let kin = Kinematics::new(&machine, &errors, chain).unwrap();
                let q = axis_values(&machine, &kin, &u);
                let want = reference_pose(&machine, &errors, chain, kin.axes(), &q, length);
                let nominal = reference_pose(
                    &machine, &ErrorModel::zero(&machine), chain, kin.axes(), &q, length,
                );
                let base: Vec<f64> = q.iter().zip(&near).map(|(x, d)| x + d).collect();
                let angles = kin.angles(&base);
                for (model, want) in [(Model::Actual, want), (Model::Nominal, nominal)] {
                    let poses = [
                        kin.pose(model, &q, length).0,
                        kin.pose_and_jacobian(model, &q, length).0,
                        kin.pose_near(model, &q, length, &angles).0,
                    ];
                    for got in poses {
                        let (dp, da) = got.deviation(&want);
                        proptest::prop_assert!(dp < 1e-11 && da < 1e-14, "{} {model:?} q={q:?}: {dp} mm, {da} rad", MACHINES[m]);
                    }
                }
            }
        }

        #[test]
        fn carried_jacobians_and_axes_are_the_walked_ones(
            m in 0..MACHINES.len(),
            u in proptest::collection::vec(0.0..1.0f64, MAX_AXES),
            length in 0.0..150.0f64,
        ) {
            let (machine, errors) = fixture(MACHINES[m]);
            for chain in 0..machine.tool_chains.len() {
                let kin = Kinematics::new(&machine, &errors, chain).unwrap();
                let q = axis_values(&machine, &kin, &u);
                let angles = kin.angles(&q);
                for model in [Model::Actual, Model::Nominal] {
                    let (pose, jac) = kin.jacobian_at(model, &q, length, &angles);
                    let (want, walked) = kin.walk_jacobian(model, &q, length, &angles);
                    let (dp, da) = pose.deviation(&want);
                    proptest::prop_assert!(dp < 1e-11 && da < 1e-14);
                    proptest::prop_assert_eq!(jac.beyond, walked.beyond);
                    // The plain pose with only the rotary axes' directions carried.
                    let mut dirs = [Vector3::zeros(); MAX_AXES];
                    let (pose, beyond) = kin.axes_at(model, &q, length, &angles, &mut dirs);
                    let (dp, da) = pose.deviation(&want);
                    proptest::prop_assert!(dp < 1e-11 && da < 1e-14);
                    proptest::prop_assert_eq!(beyond, walked.beyond);
                    for (k, dir) in dirs.iter().enumerate().take(kin.len()) {
                        let off = (dir - walked.axis_dir[k]).norm();
                        proptest::prop_assert!(off < 1e-14, "{} {model:?} var {k}: {:?} {:?}", MACHINES[m], dir, walked.axis_dir[k]);
                    }
                    for k in 0..kin.len() {
                        let scale = walked.dp[k].norm().max(1.0);
                        let pairs = [
                            (jac.dp[k], walked.dp[k], 1e-13 * scale),
                            (jac.do_[k], walked.do_[k], 1e-14),
                            (jac.axis_dir[k], walked.axis_dir[k], 1e-14),
                        ];
                        for (got, want, tolerance) in pairs {
                            proptest::prop_assert!((got - want).norm() < tolerance, "{} {model:?} var {k}: {got:?} vs {want:?}", MACHINES[m]);
                        }
                    }
                }
            }
        }

        #[test]
        fn jacobians_are_the_derivatives_including_the_error_tables(
            m in 0..4usize,
            u in proptest::collection::vec(0.0..1.0f64, MAX_AXES),
        ) {
            let (machine, errors) = fixture(MACHINES[m]);
            let kin = Kinematics::new(&machine, &errors, 0).unwrap();
            let q = axis_values(&machine, &kin, &u);
            let (_, jac) = kin.pose_and_jacobian(Model::Actual, &q, 50.0);
            for k in 0..kin.len() {
                // Central differences over 1 µm or 1 µ°: well inside one table segment
                // almost always, and truncation far below the tolerance.
                let h = 1e-3;
                let mut up = q.clone();
                up[k] += h;
                let mut down = q.clone();
                down[k] -= h;
                let (a, _) = kin.pose(Model::Actual, &up, 50.0);
                let (b, _) = kin.pose(Model::Actual, &down, 50.0);
                let dp = (a.p - b.p) / (2.0 * h);
                let do_ = (a.o - b.o) / (2.0 * h);
                // Relative to the column's size: first order in the error angles.
                let scale = jac.dp[k].norm().max(1.0);
                let fits = |dp: &Vector3<f64>, do_: &Vector3<f64>| {
                    (dp - jac.dp[k]).norm() < 1e-6 * scale && (do_ - jac.do_[k]).norm() < 1e-8
                };
                // Where a table's knot lies within ±h the central difference averages the
                // slopes of two segments: the Jacobian is then one side's derivative, which
                // a one-sided difference over a step short of the knot gives.
                let one_sided = |step: f64| {
                    let (c, _) = kin.pose(Model::Actual, &q, 50.0);
                    let mut moved = q.clone();
                    moved[k] += step;
                    let (d, _) = kin.pose(Model::Actual, &moved, 50.0);
                    ((d.p - c.p) / step, (d.o - c.o) / step)
                };
                let (fp, fo) = one_sided(1e-6);
                let (bp, bo) = one_sided(-1e-6);
                proptest::prop_assert!(
                    fits(&dp, &do_) || fits(&fp, &fo) || fits(&bp, &bo),
                    "{} var {k}: {dp:?}, {do_:?} vs {:?}, {:?}",
                    MACHINES[m],
                    jac.dp[k],
                    jac.do_[k]
                );
            }
        }

        #[test]
        fn small_rotations_are_rodrigues_rotations(
            x in -1e-3..1e-3f64, y in -1e-3..1e-3f64, z in -1e-3..1e-3f64, scale in -12i32..1,
        ) {
            let v = Vector3::new(x, y, z) * 10f64.powi(scale);
            let ours = chain::small_rotation(v).to_matrix();
            let std = Rotation3::new(v).into_inner();
            for (a, b) in ours.iter().zip(std.iter()) {
                proptest::prop_assert!((a - b).abs() <= 4.0 * f64::EPSILON, "{v:?}: {ours:?} {std:?}");
            }
        }
    }

    proptest::proptest! {
        #[test]
        fn angles_between_are_atan2s(
            x in -1.0..1.0f64, y in -1.0..1.0f64, z in 0.01..1.0f64, scale in -12i32..1,
        ) {
            let a = Vector3::new(0.3, -0.2, 1.0).normalize();
            let b = (a + Vector3::new(x, y, z - 0.5) * 10f64.powi(scale)).normalize();
            let want = a.cross(&b).norm().atan2(a.dot(&b));
            let got = angle_between(&a, &b);
            proptest::prop_assert!((got - want).abs() <= 4.0 * f64::EPSILON * want, "{got} {want}");
        }
    }

    #[test]
    fn no_rotation_is_the_identity() {
        assert_eq!(chain::small_rotation(Vector3::zeros()), chain::M3::IDENTITY);
    }
}
