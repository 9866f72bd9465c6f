//! The joint transforms of design/model.md evaluated as rotation matrices and
//! translations, with the sines and cosines of the rotary axes supplied by the caller.
//!
//! Every block of a program costs several pose evaluations (the target, the real machine at
//! the start, each Newton step, the pose the machine is finally told), so this is the inner
//! loop of nccomp. A rotary axis's turn is built by Rodrigues' formula from precomputed
//! cross-product matrices; its sine and cosine come from [`Angles`], which takes them by the
//! angle-addition formula from a nearby pose instead of calling `sin_cos` again; error
//! motions (micro-radians) are rotated by their series.

use super::MAX_AXES;
use crate::model::{AxisKind, IndexedTable, MotionTable};
use nalgebra::{Matrix3, Rotation3, Vector3};
use std::ops::{Add, Mul};

/// A 3×3 matrix (row-major) with its products written out: nalgebra's generic products
/// cost several times as many instructions at this size, and a block needs hundreds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct M3(pub [[f64; 3]; 3]);

impl M3 {
    pub const IDENTITY: M3 = M3([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]);

    pub fn from_matrix(m: &Matrix3<f64>) -> M3 {
        M3(std::array::from_fn(|i| std::array::from_fn(|j| m[(i, j)])))
    }

    #[cfg(test)]
    pub fn to_matrix(self) -> Matrix3<f64> {
        Matrix3::from_fn(|i, j| self.0[i][j])
    }

    /// Mᵀ·v.
    #[inline]
    pub fn tr_mul(&self, v: &Vector3<f64>) -> Vector3<f64> {
        let m = &self.0;
        Vector3::new(
            m[0][0] * v.x + m[1][0] * v.y + m[2][0] * v.z,
            m[0][1] * v.x + m[1][1] * v.y + m[2][1] * v.z,
            m[0][2] * v.x + m[1][2] * v.y + m[2][2] * v.z,
        )
    }

    #[inline]
    pub fn column(&self, j: usize) -> Vector3<f64> {
        Vector3::new(self.0[0][j], self.0[1][j], self.0[2][j])
    }

    #[inline]
    fn scaled(&self, k: f64) -> M3 {
        M3(self.0.map(|row| row.map(|x| x * k)))
    }
}

impl Mul<M3> for M3 {
    type Output = M3;
    #[inline]
    fn mul(self, b: M3) -> M3 {
        let (a, b) = (&self.0, &b.0);
        M3(std::array::from_fn(|i| {
            std::array::from_fn(|j| a[i][0] * b[0][j] + a[i][1] * b[1][j] + a[i][2] * b[2][j])
        }))
    }
}

impl Mul<Vector3<f64>> for M3 {
    type Output = Vector3<f64>;
    #[inline]
    fn mul(self, v: Vector3<f64>) -> Vector3<f64> {
        let m = &self.0;
        Vector3::new(
            m[0][0] * v.x + m[0][1] * v.y + m[0][2] * v.z,
            m[1][0] * v.x + m[1][1] * v.y + m[1][2] * v.z,
            m[2][0] * v.x + m[2][1] * v.y + m[2][2] * v.z,
        )
    }
}

impl Add<M3> for M3 {
    type Output = M3;
    #[inline]
    fn add(self, b: M3) -> M3 {
        M3(std::array::from_fn(|i| {
            std::array::from_fn(|j| self.0[i][j] + b.0[i][j])
        }))
    }
}

/// A rigid transform x ↦ r·x + t.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Rigid {
    pub r: M3,
    pub t: Vector3<f64>,
}

impl Rigid {
    pub fn identity() -> Self {
        Rigid {
            r: M3::IDENTITY,
            t: Vector3::zeros(),
        }
    }

    pub fn apply(&self, x: &Vector3<f64>) -> Vector3<f64> {
        self.r * *x + self.t
    }

    /// The transform of the parent frame's point `x` given in the frame of `self⁻¹`.
    pub fn apply_inverse(&self, x: &Vector3<f64>) -> Vector3<f64> {
        self.r.tr_mul(&(x - self.t))
    }
}

/// The sines and cosines of the rotary variables' positions, and the positions (degrees)
/// they belong to.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Angles {
    q: [f64; MAX_AXES],
    sc: [(f64, f64); MAX_AXES],
    rotary: u32,
}

thread_local! {
    /// Each variable's last angle (its bits) and its sine and cosine.
    static LAST: [std::cell::Cell<(u64, (f64, f64))>; MAX_AXES] =
        const { [const { std::cell::Cell::new((0, (0.0, 1.0))) }; MAX_AXES] };
}

/// The sine and cosine of `degrees`, variable `k`'s value: the last ones again where the
/// value is the last one's. A block's poses (the pass's, the controller's, the gate's)
/// start from the same rotary values again and again, and in a working plane or a
/// three-axis stretch every block does: `sin_cos` was a tenth of a plane block's
/// instructions.
fn sin_cos_degrees(k: usize, degrees: f64) -> (f64, f64) {
    let bits = degrees.to_bits();
    LAST.with(|last| {
        let (was, sc) = last[k].get();
        if was == bits {
            return sc;
        }
        let sc = degrees.to_radians().sin_cos();
        last[k].set((bits, sc));
        sc
    })
}

/// Below this step (rad) the sine and cosine of a step are their series to the 9th power,
/// exact in f64 (the next term is below 3·10⁻²⁵).
const SERIES_STEP: f64 = 1e-2;

impl Angles {
    /// At `q` (degrees for the variables whose bits are set in `rotary`).
    pub(super) fn new(q: &[f64], rotary: u32) -> Self {
        let mut a = Angles {
            q: [0.0; MAX_AXES],
            sc: [(0.0, 1.0); MAX_AXES],
            rotary,
        };
        let mut bits = rotary;
        while bits != 0 {
            let k = bits.trailing_zeros() as usize;
            bits &= bits - 1;
            a.q[k] = q[k];
            a.sc[k] = sin_cos_degrees(k, q[k]);
        }
        a
    }

    /// At `q`, from these angles by the angle-addition formula where `q` is near.
    pub(super) fn near(&self, q: &[f64]) -> Self {
        let mut a = *self;
        self.near_into(q, &mut a);
        a
    }

    /// [`Angles::near`] written into `out`, which holds these angles or others made from
    /// them (only the rotary entries change: no copy of the whole per Newton step).
    pub(super) fn near_into(&self, q: &[f64], out: &mut Angles) {
        let mut bits = self.rotary;
        while bits != 0 {
            let k = bits.trailing_zeros() as usize;
            bits &= bits - 1;
            let x = q[k];
            out.q[k] = x;
            let d = (x - self.q[k]).to_radians();
            out.sc[k] = if d == 0.0 {
                self.sc[k]
            } else if d.abs() <= SERIES_STEP {
                let (s, c) = self.sc[k];
                let (sd, cd) = small_sin_cos(d);
                (s * cd + c * sd, c * cd - s * sd)
            } else {
                x.to_radians().sin_cos()
            };
        }
    }

    /// Sine and cosine of variable `var` (radians).
    pub(super) fn get(&self, var: usize) -> (f64, f64) {
        self.sc[var]
    }
}

/// sin d and cos d by their series, for |d| ≤ [`SERIES_STEP`].
fn small_sin_cos(d: f64) -> (f64, f64) {
    // The coefficients as reciprocals: a chain of divisions (a dozen cycles each, one
    // waiting for the other) cost more time here than all the rest of an angle update.
    let dd = d * d;
    let s = d
        * (1.0
            - dd * (1.0 / 6.0)
                * (1.0
                    - dd * (1.0 / 20.0) * (1.0 - dd * (1.0 / 42.0) * (1.0 - dd * (1.0 / 72.0)))));
    let c = 1.0
        - dd * 0.5
            * (1.0 - dd * (1.0 / 12.0) * (1.0 - dd * (1.0 / 30.0) * (1.0 - dd * (1.0 / 56.0))));
    (s, c)
}

/// The rotation matrix whose rotation vector is `e` (Rodrigues' formula); below 1 mrad its
/// coefficients by their series (exact in f64) instead of `sin`/`cos`.
/// Taken by value: the three angles come in registers, not stored by the caller and
/// loaded back at once (a time profile showed the function waiting on that load).
pub(super) fn small_rotation(e: Vector3<f64>) -> M3 {
    let nn = e.norm_squared();
    if nn > 1e-6 {
        return M3::from_matrix(Rotation3::new(e).matrix());
    }
    // sin θ / θ and (1 − cos θ) / θ², θ² = nn.
    // Reciprocal coefficients, as in `small_sin_cos`: no chain of divisions.
    let a = 1.0 - nn * (1.0 / 6.0) * (1.0 - nn * (1.0 / 20.0) * (1.0 - nn * (1.0 / 42.0)));
    let b = 0.5 * (1.0 - nn * (1.0 / 12.0) * (1.0 - nn * (1.0 / 30.0) * (1.0 - nn * (1.0 / 56.0))));
    // I + a·[e]× + b·[e]×², with [e]×² = e·eᵀ − θ²·I.
    let (x, y, z) = (e.x, e.y, e.z);
    let d = 1.0 - nn * b;
    M3([
        [d + b * x * x, b * x * y - a * z, b * x * z + a * y],
        [b * x * y + a * z, d + b * y * y, b * y * z - a * x],
        [b * x * z - a * y, b * y * z + a * x, d + b * z * z],
    ])
}

/// How a joint moves per unit of its variable (mm or degree), in its parent's frame: a
/// point y carried by it moves at `omega × (y − c) + v`. `axis` is a rotary joint's axis
/// direction after its error motion (zero for linear joints).
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Twist {
    pub omega: Vector3<f64>,
    pub c: Vector3<f64>,
    pub v: Vector3<f64>,
    pub axis: Vector3<f64>,
}

impl Twist {
    /// The same motion seen from the frame `f` maps into.
    fn moved(&self, f: &Rigid) -> Twist {
        Twist {
            omega: f.r * self.omega,
            c: f.apply(&self.c),
            v: f.r * self.v,
            axis: f.r * self.axis,
        }
    }
}

/// One joint of a chain, with what its evaluation needs precomputed.
#[derive(Debug, Clone)]
pub(super) struct Joint {
    pub var: usize,
    pub kind: AxisKind,
    /// Linear: direction of motion d̃. Rotary: axis direction ã.
    pub dir: Vector3<f64>,
    /// Linear: error reference point r. Rotary: axis point c̃.
    pub point: Vector3<f64>,
    /// Rotary: sine and cosine of the zero-position error e0, and whether it is zero.
    pub zero: (f64, f64),
    has_zero: bool,
    /// Rotary: [ã]× and [ã]×², for Rodrigues' formula.
    k: M3,
    k2: M3,
    pub motion: Option<MotionTable>,
    /// The same, ready for look-ups.
    table: Option<IndexedTable>,
    pub table_offset: f64,
    /// Linear: added to the variable's value (a work offset other than the one the
    /// machine file's geometry is given in moves program zero along the axis).
    pub shift: f64,
}

impl Joint {
    pub fn new(
        var: usize,
        kind: AxisKind,
        dir: Vector3<f64>,
        point: Vector3<f64>,
        zero: f64,
        motion: Option<MotionTable>,
        table_offset: f64,
    ) -> Self {
        let k = M3::from_matrix(&dir.cross_matrix());
        Joint {
            var,
            kind,
            dir,
            point,
            zero: zero.sin_cos(),
            has_zero: zero != 0.0,
            k,
            k2: k * k,
            table: motion.as_ref().map(IndexedTable::new),
            motion,
            table_offset,
            shift: 0.0,
        }
    }

    /// The joint transform at position `q` (mm or degrees; `sc` the sine and cosine of a
    /// rotary joint's `q` in radians), whether it rotates at all, and, with `TWIST`, how it
    /// moves. Sets `beyond` when an error table was read past its ends.
    #[inline(always)]
    fn eval<const TWIST: bool>(
        &self,
        q: f64,
        sc: (f64, f64),
        beyond: &mut bool,
    ) -> (Rigid, bool, Twist) {
        let q = q + self.shift;
        // E(q) = Tr(δ)·Rv(ε) about the joint's reference point.
        let e = self.table.as_ref().map(|m| {
            let (s, slope) = m.sample_with_slope(q + self.table_offset);
            *beyond |= s.beyond;
            let v = s.values;
            (
                Vector3::new(v[0], v[1], v[2]),
                small_rotation(Vector3::new(v[3], v[4], v[5])),
                Vector3::new(slope[0], slope[1], slope[2]),
                Vector3::new(slope[3], slope[4], slope[5]),
            )
        });
        let mut twist = Twist::default();
        match self.kind {
            AxisKind::Linear => {
                // Tr(q·d̃) · Tr(r) · E · Tr(−r)
                let along = self.dir * q;
                match e {
                    Some((delta, rot, d_delta, d_eps)) => {
                        if TWIST {
                            twist.omega = d_eps;
                            twist.c = along + self.point + delta;
                            twist.v = self.dir + d_delta;
                        }
                        let t = along + self.point + delta - rot * self.point;
                        (Rigid { r: rot, t }, true, twist)
                    }
                    None => {
                        twist.v = self.dir;
                        (
                            Rigid {
                                r: M3::IDENTITY,
                                t: along,
                            },
                            false,
                            twist,
                        )
                    }
                }
            }
            AxisKind::Rotary => {
                // Tr(c̃) · E · Rot(ã, q + e0) · Tr(−c̃)
                let (mut s, mut c) = sc;
                if self.has_zero {
                    let (s0, c0) = self.zero;
                    (s, c) = (s * c0 + c * s0, c * c0 - s * s0);
                }
                let turn = M3::IDENTITY + self.k.scaled(s) + self.k2.scaled(1.0 - c);
                let per_degree = std::f64::consts::PI / 180.0;
                match e {
                    Some((delta, erot, d_delta, d_eps)) => {
                        let r = erot * turn;
                        if TWIST {
                            twist.axis = erot * self.dir;
                            twist.omega = d_eps + twist.axis * per_degree;
                            twist.c = self.point + delta;
                            twist.v = d_delta;
                        }
                        let t = self.point + delta - r * self.point;
                        (Rigid { r, t }, true, twist)
                    }
                    None => {
                        if TWIST {
                            twist.axis = self.dir;
                            twist.omega = self.dir * per_degree;
                            twist.c = self.point;
                        }
                        let t = self.point - turn * self.point;
                        (Rigid { r: turn, t }, true, twist)
                    }
                }
            }
        }
    }
}

/// The transform of a chain at `q`, and with `TWIST` each joint's motion in the base
/// frame, stored at its variable's index in `twists`.
#[inline]
pub(super) fn walk<const TWIST: bool>(
    joints: &[Joint],
    q: &[f64],
    angles: &Angles,
    beyond: &mut bool,
    twists: &mut [Twist; MAX_AXES],
) -> Rigid {
    let mut acc = Rigid::identity();
    for (i, j) in joints.iter().enumerate() {
        let (jt, rotates, twist) = j.eval::<TWIST>(q[j.var], angles.get(j.var), beyond);
        if TWIST {
            twists[j.var] = if i == 0 { twist } else { twist.moved(&acc) };
        }
        if i == 0 {
            acc = jt;
            continue;
        }
        // A pure translation needs no product of rotations.
        acc.t += acc.r * jt.t;
        if rotates {
            acc.r = acc.r * jt.r;
        }
    }
    acc
}

/// The vectors a pose evaluation carries through the joints: the tip `x`, the tool
/// direction `d` and, when asked for (`axes`), the directions of the rotary axes met so
/// far and perhaps the Jacobian's columns. A plain pose carries only the first two: no
/// arrays to set up or copy.
pub(super) struct Carried<'a, 'b> {
    pub x: Vector3<f64>,
    pub d: Vector3<f64>,
    pub axes: Option<&'a mut CarriedAxes<'b>>,
}

/// The per-variable vectors a pose evaluation carries: the rotary axes' directions (zero
/// for linear axes) and, with `columns`, the Jacobian's columns d p / d q and d o / d q;
/// bit k of `carried` set once variable k's are in. Bit k of `turning` clear: variable k's
/// direction and d o / d q are zero (a linear axis of the nominal machine) and are not
/// turned with the joints.
///
/// A joint's column is the velocity it gives the tip (or, for a workpiece joint, the
/// opposite of the velocity it gives the part at the tip) in its parent's frame, and the
/// joints between there and the workpiece frame carry it like any vector. That takes one
/// matrix–vector product per vector and joint instead of the products of the joints'
/// transforms a walk along the chain needs.
pub(super) struct CarriedAxes<'a> {
    pub dirs: &'a mut [Vector3<f64>; MAX_AXES],
    pub columns: Option<Columns<'a>>,
    pub carried: u32,
    pub turning: u32,
}

/// d p / d q and d o / d q, entry per variable.
pub(super) struct Columns<'a> {
    pub dp: &'a mut [Vector3<f64>; MAX_AXES],
    pub do_: &'a mut [Vector3<f64>; MAX_AXES],
}

impl<'a> CarriedAxes<'a> {
    /// Into `dirs`, which end with zeros for the linear axes.
    pub fn new(dirs: &'a mut [Vector3<f64>; MAX_AXES]) -> Self {
        *dirs = [Vector3::zeros(); MAX_AXES];
        CarriedAxes {
            dirs,
            columns: None,
            carried: 0,
            // Without columns only rotary axes are put.
            turning: u32::MAX,
        }
    }

    #[inline]
    fn rotate(&mut self, f: impl Fn(&Vector3<f64>) -> Vector3<f64>) {
        let mut bits = self.carried;
        while bits != 0 {
            let k = bits.trailing_zeros() as usize;
            bits &= bits - 1;
            if let Some(c) = &mut self.columns {
                c.dp[k] = f(&c.dp[k]);
                if self.turning & (1 << k) == 0 {
                    continue;
                }
                c.do_[k] = f(&c.do_[k]);
            }
            self.dirs[k] = f(&self.dirs[k]);
        }
    }

    #[inline]
    fn put(&mut self, var: usize, dir: Vector3<f64>) {
        self.dirs[var] = dir;
        self.carried |= 1 << var;
    }

    /// Joint `var`'s axis and columns from its motion `twist` at the tip `x` and the
    /// direction `d` (all in its parent's frame), with `sign` −1 for a workpiece joint.
    #[inline]
    fn put_columns(
        &mut self,
        var: usize,
        twist: &Twist,
        x: &Vector3<f64>,
        d: &Vector3<f64>,
        sign: f64,
    ) {
        if let Some(c) = &mut self.columns {
            c.dp[var] = (twist.omega.cross(&(x - twist.c)) + twist.v) * sign;
            c.do_[var] = twist.omega.cross(d) * sign;
        }
        self.put(var, twist.axis);
    }
}

/// The vectors given in the chain's end frame, carried out to its base frame: the joints
/// applied from the last to the first. Cheaper than forming the chain's transform when
/// only a few vectors are wanted. `AXES`: `c.axes` is given and gets the rotary axes (and
/// the columns, when it has them).
#[inline]
pub(super) fn carry_out<const AXES: bool>(
    joints: &[Joint],
    q: &[f64],
    angles: &Angles,
    beyond: &mut bool,
    c: &mut Carried<'_, '_>,
) {
    for j in joints.iter().rev() {
        let (jt, rotates, twist) = j.eval::<AXES>(q[j.var], angles.get(j.var), beyond);
        if rotates {
            c.x = jt.r * c.x + jt.t;
            c.d = jt.r * c.d;
            if AXES && let Some(axes) = c.axes.as_deref_mut() {
                axes.rotate(|a| jt.r * *a);
            }
        } else {
            c.x += jt.t;
        }
        if AXES && let Some(axes) = c.axes.as_deref_mut() {
            // In the joint's parent frame, as the joints before it will carry it.
            if axes.columns.is_some() {
                axes.put_columns(j.var, &twist, &c.x, &c.d, 1.0);
            } else if j.kind == AxisKind::Rotary {
                axes.put(j.var, twist.axis);
            }
        }
    }
}

/// The vectors given in the chain's base frame, carried in to its end frame: the inverse
/// joints applied from the first to the last.
#[inline]
pub(super) fn carry_in<const AXES: bool>(
    joints: &[Joint],
    q: &[f64],
    angles: &Angles,
    beyond: &mut bool,
    c: &mut Carried<'_, '_>,
) {
    for j in joints {
        let columns = AXES && c.axes.as_ref().is_some_and(|a| a.columns.is_some());
        let (jt, rotates, twist) = if columns {
            j.eval::<true>(q[j.var], angles.get(j.var), beyond)
        } else {
            j.eval::<false>(q[j.var], angles.get(j.var), beyond)
        };
        if columns && let Some(axes) = c.axes.as_deref_mut() {
            // In the joint's parent frame, where the tip and direction now are; its own
            // inverse and those after it carry them in.
            axes.put_columns(j.var, &twist, &c.x, &c.d, -1.0);
        }
        if rotates {
            c.x = jt.r.tr_mul(&(c.x - jt.t));
            c.d = jt.r.tr_mul(&c.d);
            if AXES && let Some(axes) = c.axes.as_deref_mut() {
                axes.rotate(|a| jt.r.tr_mul(a));
            }
        } else {
            c.x -= jt.t;
        }
        if AXES
            && !columns
            && j.kind == AxisKind::Rotary
            && let Some(axes) = c.axes.as_deref_mut()
        {
            // Its own turn leaves the axis where it is: ã in the joint's frame.
            axes.put(j.var, j.dir);
        }
    }
}
