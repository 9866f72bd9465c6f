//! The compensation solve: axis values q* at which the machine with its errors reaches
//! the pose the nominal machine reaches at q.
//!
//! Newton's method on five equations (three of position, two of direction). Position is a
//! hard requirement; direction is met in the least-squares sense in what freedom remains.
//! A rotary axis whose line lies (nearly) along the tool direction cannot turn the tool;
//! it is held at its nominal value instead of being swung to chase the few micro-radians
//! of direction error it cannot fix anyway.

use super::{Angles, AxisDirs, Jacobian, Kinematics, MAX_AXES, Model, Pose};
use crate::model::AxisKind;
use nalgebra::{DMatrix, SMatrix, Vector3, Vector5};

/// How the solve behaves.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SolveOptions {
    /// A rotary axis whose line lies within this angle (rad) of the tool direction is
    /// singular and keeps its nominal value.
    pub singular_angle: f64,
    /// Newton iterations at most.
    pub max_iterations: usize,
    /// Stop when the tip is this close (mm) ...
    pub position_tolerance: f64,
    /// ... and the direction this close (rad), or when steps no longer change anything.
    pub angle_tolerance: f64,
    /// [`Kinematics::compensate`] only: the decimals rotary values are written with, and
    /// how far (mm) their rounding may move the tip before the linear axes take it up.
    pub rotary_rounding: Option<(u8, f64)>,
    /// [`Kinematics::compensate`] only: the decimals linear (mm) and rotary (°) values are
    /// written with, where the words are the axis values. The solve then evaluates its
    /// last pose at the values as written ([`Solution::written`]): the pass needs that
    /// pose anyway, and it checks the step too.
    pub written: Option<(u8, u8)>,
}

impl Default for SolveOptions {
    fn default() -> Self {
        SolveOptions {
            singular_angle: 3f64.to_radians(),
            max_iterations: 25,
            position_tolerance: 1e-10,
            angle_tolerance: 1e-12,
            rotary_rounding: None,
            written: None,
        }
    }
}

impl SolveOptions {
    /// For writing programs: the default's limits on the angle and the iterations, and
    /// stopping tolerances a tenth of design/model.md's target residual (1e-6 mm, 1e-8
    /// rad). That is still a thousandth of the finest resolution a program is written in
    /// (0.1 µm), and it saves the default's third Newton step, which only takes the residual
    /// from about 1e-8 to 1e-11 mm: 7 % of a block's work. The default's tighter
    /// tolerances stay for the analysis tools, which difference solves.
    pub fn compensation() -> Self {
        SolveOptions {
            position_tolerance: 1e-7,
            angle_tolerance: 1e-9,
            ..SolveOptions::default()
        }
    }
}

/// How far the real machine's Jacobian at the solution may differ from the nominal one at
/// the programmed values, relative: the errors' angles and slopes and the correction, each
/// a few hundred micro-radians or less. A chord step with the nominal Jacobian leaves
/// that share of the residual: 2.4·10⁻⁴ and 1.9·10⁻³ on the spiral (docs/performance.md),
/// so twice the larger.
const MISMATCH: f64 = 4e-3;

/// `x` as a word with `decimals` reads back (the writer's rounding, `nc::number`).
fn as_written(x: f64, decimals: u8) -> Option<f64> {
    let n = crate::nc::number::scaled(x, decimals)?;
    let v = n.unsigned_abs() as f64 / 10f64.powi(decimals.into());
    (n.unsigned_abs() <= 1 << 53).then_some(if n < 0 { -v } else { v })
}

/// A step that leaves more than this share of the residual (position or direction) makes
/// the solve take a fresh Jacobian (at most every fourth step).
const SLOW: f64 = 0.25;

/// Where a solve starts: the pose at the start values (and whether an error table was read
/// beyond its ends there), and the Jacobian it steps with at first: `own` when it is the
/// solved model's own there, not the other model's.
struct Start<'a> {
    pose: Pose,
    beyond: bool,
    jac: &'a Jacobian,
    own: bool,
}

/// The result of a solve.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Solution {
    /// Axis values, one per variable (first `n` entries used).
    pub q: [f64; MAX_AXES],
    pub n: usize,
    /// Remaining tip distance (mm) and direction angle (rad) to the target.
    pub position_residual: f64,
    pub direction_residual: f64,
    /// Tip distance (mm) and direction angle (rad) at the start values: the error
    /// without compensation when starting from the programmed values.
    pub start_position_error: f64,
    pub start_direction_error: f64,
    /// The pose solved for.
    pub target: Pose,
    pub iterations: usize,
    /// Bit k set: variable k was held at its start value.
    pub held: u32,
    /// Bit k set: variable k was held because it is a rotary axis at a singular pose (set
    /// by [`Kinematics::compensate`]).
    pub singular: u32,
    /// Whether an error table was read beyond its ends at the solution.
    pub beyond: bool,
    /// The rotary axes' sines and cosines at the start values, to evaluate poses near the
    /// solution with ([`Kinematics::pose_near`]).
    pub angles: Angles,
    /// The solution's values rounded as [`SolveOptions::written`] asks, and the real pose
    /// there (`pose_near` with `angles`, bit for bit), where the solve evaluated it.
    pub written: Option<Written>,
}

/// The real machine's pose at the solution as written.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Written {
    pub q: [f64; MAX_AXES],
    pub pose: Pose,
    pub beyond: bool,
}

impl Solution {
    pub fn values(&self) -> &[f64] {
        &self.q[..self.n]
    }
}

/// Two unit vectors perpendicular to `o` and to each other.
fn tangent_basis(o: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let helper = if o.x.abs() < 0.6 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let b1 = o.cross(&helper).normalize();
    (b1, o.cross(&b1))
}

impl Kinematics {
    /// Compensate one pose: the axis values at which the machine with its errors reaches
    /// the pose the nominal machine reaches at `q`, with a tool of length `length`. The
    /// variables whose bits are set in `hold` keep their values (and so do rotary axes at a
    /// singular pose).
    pub fn compensate(
        &self,
        q: &[f64],
        length: f64,
        hold: u32,
        options: &SolveOptions,
    ) -> Solution {
        // Whether a pose is singular is a property of the programmed (nominal) pose: the
        // real machine's axis lines are off by up to a few hundred micro-radians, which
        // would move the edge of the singular cone by that much.
        let angles = self.angles(q);
        let mut nominal = Jacobian::zero(self.len(), false);
        let target = self.jacobian_into(Model::Nominal, q, length, &angles, &mut nominal);
        let singular =
            self.singular_axes(&target, &nominal.axis_dir, options.singular_angle) & !hold;
        // Newton's method with the nominal machine's Jacobian, which comes with the target
        // pose: the errors change it by about their own size (a thousandth), so a step
        // leaves about a thousandth of the residual, as the real machine's Jacobian at the
        // programmed values does (that one is off by the correction instead), without the
        // error tables' look-ups and slopes. So from tens of microns two steps reach the
        // compensation tolerance (1e-7 mm) and three the default's (1e-10 mm). Where the
        // errors are too large for that, the first slow step takes the real machine's.
        let (pose, beyond) = self.pose_at(Model::Actual, q, length, &angles);
        let fixed = hold | singular;
        if let Some(sol) =
            self.written_steps(q, length, fixed, options, &target, &nominal, &pose, &angles)
        {
            return Solution { singular, ..sol };
        }
        let start = Start {
            pose,
            beyond,
            jac: &nominal,
            own: false,
        };
        let mut sol = self.solve_from(
            Model::Actual,
            &target,
            q,
            length,
            hold | singular,
            options,
            start,
            &angles,
        );
        sol.singular = singular;
        if let Some((decimals, tolerance)) = options.rotary_rounding {
            self.absorb_rounding(&mut sol.q, &nominal, fixed, decimals, tolerance);
        }
        sol
    }

    /// Chord steps checked at the values as written ([`SolveOptions::written`]):
    /// design/model.md asks the solve to land within a tenth of the resolution, and from
    /// a start tens of microns off one step with the nominal Jacobian leaves a few
    /// nanometres to tens of nanometres (the errors change the Jacobian by a thousandth
    /// or less). The pose at the written values w is the one the pass records; the
    /// residual at the step's values q is read from it to first order,
    /// r(q) ≈ r(w) − J·(w − q), with the Jacobian's own error on that small difference as
    /// a margin. Where that falls short, the next step starts from w, whose residual the
    /// pose gives exactly; it moves the values by a fraction of the last digit, so their
    /// written values are mostly w again and need no new pose. `None` where three steps
    /// fall short or the check does not apply (held axes, whose direction residual only
    /// the full solve settles): the full solve then runs.
    #[allow(clippy::too_many_arguments)]
    fn written_steps(
        &self,
        q: &[f64],
        length: f64,
        fixed: u32,
        options: &SolveOptions,
        target: &Pose,
        nominal: &Jacobian,
        pose: &Pose,
        angles: &Angles,
    ) -> Option<Solution> {
        let (linear_decimals, rotary_decimals) = options.written?;
        let n = self.len();
        if fixed != 0 || n != 5 || self.turning.is_some() {
            return None;
        }
        let (b1, b2) = tangent_basis(&target.o);
        let map = step_map(nominal, &[0, 1, 2, 3, 4], &b1, &b2, true);
        // Where the step starts, and the real pose there.
        let mut from = [0.0; MAX_AXES];
        from[..n].copy_from_slice(&q[..n]);
        let mut at = *pose;
        let mut last: Option<([f64; MAX_AXES], Pose, bool)> = None;
        for steps in 1..=3 {
            let rp = at.p - target.p;
            let step = map.step(&[rp.x, rp.y, rp.z, b1.dot(&at.o), b2.dot(&at.o)]);
            let mut solved = from;
            for k in 0..n {
                solved[k] -= step[k];
            }
            // The values to write: the rotary rounding taken up where it must be. The
            // residual checked is the solve's, before that (design/model.md).
            let mut q1 = solved;
            if let Some((decimals, tolerance)) = options.rotary_rounding {
                self.absorb_rounding(&mut q1, nominal, fixed, decimals, tolerance);
            }
            let mut w = q1;
            for (k, x) in w.iter_mut().enumerate().take(n) {
                let decimals = if self.rotary & (1 << k) != 0 {
                    rotary_decimals
                } else {
                    linear_decimals
                };
                *x = as_written(*x, decimals)?;
            }
            let (at_w, beyond) = match last {
                Some((was, pose, beyond)) if was[..n] == w[..n] => (pose, beyond),
                _ => self.pose_at(Model::Actual, &w[..n], length, &angles.near(&w[..n])),
            };
            // The terms one by one for the margin: the take-up's cancel in the sum, their
            // errors need not.
            let (mut dp, mut do_) = (Vector3::zeros(), Vector3::zeros());
            let (mut dp_size, mut do_size) = (0.0, 0.0);
            for k in 0..n {
                let d = w[k] - solved[k];
                dp += nominal.dp[k] * d;
                do_ += nominal.do_[k] * d;
                dp_size += (nominal.dp[k] * d).norm();
                do_size += (nominal.do_[k] * d).norm();
            }
            let rp1 = at_w.p - target.p - dp;
            let o1 = at_w.o - do_;
            let (ep, ea) = (rp1.norm(), o1.cross(&target.o).norm() / o1.norm());
            if ep + MISMATCH * dp_size <= options.position_tolerance
                && ea + MISMATCH * do_size <= options.angle_tolerance
            {
                let (start_position_error, start_direction_error) = pose.deviation(target);
                return Some(Solution {
                    q: q1,
                    n,
                    position_residual: ep,
                    direction_residual: ea,
                    start_position_error,
                    start_direction_error,
                    target: *target,
                    iterations: steps,
                    held: fixed,
                    singular: 0,
                    beyond,
                    angles: *angles,
                    written: Some(Written {
                        q: w,
                        pose: at_w,
                        beyond,
                    }),
                });
            }
            from = w;
            at = at_w;
            last = Some((w, at_w, beyond));
        }
        None
    }

    /// A rotary value is written with `decimals`, which moves the tip by the rounding times
    /// the distance from the axis (0.001° at 100 mm is 1.7 µm): where that is more than
    /// `tolerance`, the rotary values become the rounded ones and the three linear
    /// variables (when there are exactly three free) take the tip back. The step comes
    /// from the nominal Jacobian the solve started with: the errors and the correction
    /// change it by a thousandth, and the rounding is a fraction of a micron, so it is right
    /// to picometres, without a pose.
    fn absorb_rounding(
        &self,
        q: &mut [f64; MAX_AXES],
        nominal: &Jacobian,
        fixed: u32,
        decimals: u8,
        tolerance: f64,
    ) {
        let n = self.len();
        let scale = 10f64.powi(decimals.into());
        let mut rounded = *q;
        let mut linear = [0usize; 3];
        let mut m = 0;
        for v in (0..n).filter(|&v| fixed & (1 << v) == 0) {
            if self.rotary & (1 << v) != 0 {
                rounded[v] = (q[v] * scale).round() / scale;
            } else if m < 3 {
                linear[m] = v;
                m += 1;
            } else {
                return;
            }
        }
        if m != 3 {
            return;
        }
        let shift = (0..n)
            .filter(|&v| self.rotary & (1 << v) != 0)
            .fold(Vector3::zeros(), |p, v| {
                p + nominal.dp[v] * (rounded[v] - q[v])
            });
        if shift.norm() <= tolerance {
            return;
        }
        let j = nalgebra::Matrix3::from_columns(&[
            nominal.dp[linear[0]],
            nominal.dp[linear[1]],
            nominal.dp[linear[2]],
        ]);
        if let Some(step) = j.lu().solve(&-shift) {
            for (k, &v) in linear.iter().enumerate() {
                rounded[v] += step[k];
            }
            *q = rounded;
        }
    }

    /// Rotary variables whose axis line lies within `limit` (rad) of the tool direction.
    pub fn singular_axes(&self, pose: &Pose, dirs: &AxisDirs, limit: f64) -> u32 {
        // Within `limit` of the line, either way: |cos| above cos(limit) (unit vectors).
        let cos_limit = limit.cos();
        let mut held = 0;
        for (k, dir) in dirs.iter().enumerate().take(self.len()) {
            if self.kind(k) == AxisKind::Rotary && dir.dot(&pose.o).abs() > cos_limit {
                held |= 1 << k;
            }
        }
        held
    }

    /// Solve `model`'s axis values to reach `target`, starting from `start`, holding the
    /// variables whose bits are set in `held`.
    ///
    /// The Jacobian is taken once at the start and reused (the pose changes by microns, so
    /// it hardly changes); it is taken again only after a step that left more than a
    /// quarter of the residual, and at most every fourth step.
    pub fn solve(
        &self,
        model: Model,
        target: &Pose,
        start: &[f64],
        length: f64,
        held: u32,
        options: &SolveOptions,
    ) -> Solution {
        let angles = self.angles(start);
        let (pose, jac) = self.jacobian_at(model, &start[..self.len()], length, &angles);
        let from = Start {
            pose,
            beyond: jac.beyond,
            jac: &jac,
            own: true,
        };
        self.solve_from(model, target, start, length, held, options, from, &angles)
    }

    /// The nominal machine's linear axes that put the tip at `tip`, the rotary axes held
    /// at `start`'s values (the controller's solve under TCP and in a working plane). The
    /// direction follows from the rotary values alone: the pose at `start` that comes
    /// with the Jacobian gives it (a second pose there, and the rotary axes' sines and
    /// cosines again, were a third of a plane block's solve).
    pub(super) fn solve_to_tip(
        &self,
        tip: &Vector3<f64>,
        start: &[f64],
        length: f64,
        options: &SolveOptions,
    ) -> Solution {
        let angles = self.angles(start);
        let (pose, jac) = self.jacobian_at(Model::Nominal, &start[..self.len()], length, &angles);
        let target = Pose { p: *tip, o: pose.o };
        let from = Start {
            pose,
            beyond: jac.beyond,
            jac: &jac,
            own: true,
        };
        self.solve_from(
            Model::Nominal,
            &target,
            start,
            length,
            self.rotary,
            options,
            from,
            &angles,
        )
    }

    /// [`Kinematics::solve`] with the pose at `start` already evaluated and a Jacobian to
    /// step with at first.
    #[allow(clippy::too_many_arguments)]
    fn solve_from(
        &self,
        model: Model,
        target: &Pose,
        start: &[f64],
        length: f64,
        held: u32,
        options: &SolveOptions,
        from: Start<'_>,
        angles: &Angles,
    ) -> Solution {
        let Start {
            mut pose,
            mut beyond,
            jac,
            own,
        } = from;
        let n = self.len();
        let mut q = [0.0; MAX_AXES];
        q[..n].copy_from_slice(&start[..n]);
        let (b1, b2) = tangent_basis(&target.o);
        let mut free = [0usize; MAX_AXES];
        let mut m = 0;
        for k in (0..n).filter(|k| held & (1 << k) == 0) {
            free[m] = k;
            m += 1;
        }
        let free = &free[..m];
        let mut map = step_map(jac, free, &b1, &b2, !own);
        let (start_position_error, start_direction_error) = pose.deviation(target);
        let mut iterations = 0;
        let mut near = *angles;
        // The residual before the last step, to see how well the Jacobian still serves, and
        // the first step that may take a fresh one (after a borrowed one, the first).
        let mut last = (f64::INFINITY, f64::INFINITY);
        let mut next_fresh = if own { 4 } else { 1 };
        loop {
            let rp = pose.p - target.p;
            let rd = [b1.dot(&pose.o), b2.dot(&pose.o)];
            let (ep, ea) = (rp.norm(), pose.o.cross(&target.o).norm());
            let facing = pose.o.dot(&target.o);
            // atan(y/x) ≤ y/x: within the angle tolerance without an atan2.
            let done = ep <= options.position_tolerance && ea <= options.angle_tolerance * facing;
            if done || iterations >= options.max_iterations {
                break;
            }
            // The Jacobian taken at the start leaves about a thousandth of the residual a
            // step (the axes move by the correction, hundreds of micro-radians, and it
            // with them): it is taken again only where a step fell well short of that, and
            // at most every fourth step (where even a fresh one does not help, as for a
            // target out of reach, a Jacobian a step would cost four poses a step).
            let slow = (ep > options.position_tolerance && ep > SLOW * last.0)
                || (ea > options.angle_tolerance && ea > SLOW * last.1);
            last = (ep, ea);
            iterations += 1;
            let refresh = slow && iterations >= next_fresh;
            let step = map.step(&[rp.x, rp.y, rp.z, rd[0], rd[1]]);
            let mut biggest: f64 = 0.0;
            for (i, &k) in free.iter().enumerate() {
                q[k] -= step[i];
                biggest = biggest.max(step[i].abs());
            }
            angles.near_into(&q[..n], &mut near);
            if refresh {
                next_fresh = iterations + 4;
                let jac;
                (pose, jac) = self.jacobian_at(model, &q[..n], length, &near);
                beyond = jac.beyond;
                map = step_map(&jac, free, &b1, &b2, false);
            } else {
                (pose, beyond) = self.pose_at(model, &q[..n], length, &near);
            }
            if biggest < 1e-13 {
                break;
            }
        }
        let (position_residual, direction_residual) = pose.deviation(target);
        Solution {
            q,
            n,
            position_residual,
            direction_residual,
            start_position_error,
            start_direction_error,
            target: *target,
            iterations,
            held,
            singular: 0,
            beyond,
            angles: *angles,
            written: None,
        }
    }
}

/// The Newton step for a residual: with five free variables the square Jacobian solved in
/// blocks where its structure allows, or by its LU factors; otherwise an explicit map
/// (below).
enum StepMap {
    Split(Split5),
    Square(Lu5),
    General(SMatrix<f64, MAX_AXES, 5>),
}

impl StepMap {
    /// Δ on the free variables (entry i for free variable i) with J·Δ ≈ r.
    fn step(&self, r: &[f64; 5]) -> [f64; MAX_AXES] {
        let mut out = [0.0; MAX_AXES];
        match self {
            StepMap::Split(split) => out[..5].copy_from_slice(&split.solve(r)),
            StepMap::Square(lu) => out[..5].copy_from_slice(&lu.solve(r)),
            StepMap::General(map) => {
                out.copy_from_slice((map * Vector5::from_column_slice(r)).as_slice());
            }
        }
        out
    }
}

/// A square Jacobian whose direction rows (3 and 4) vanish on three of its columns, as the
/// nominal machine's do on its linear axes (they move the tip and leave the direction
/// alone), solved in blocks: the direction rows give the other two variables (a 2×2
/// solve), the position rows then the three (a 3×3 solve). The same step as the LU's for a
/// third of its work; `None` where the structure is not there or a block is near singular
/// (the LU then decides).
#[derive(Debug, Clone, Copy)]
struct Split5 {
    /// Columns that leave the direction alone, and the two that turn it.
    still: [usize; 3],
    turning: [usize; 2],
    /// Inverse of the direction rows on `turning`.
    d_inv: [[f64; 2]; 2],
    /// The position rows on `turning`.
    p_turning: [[f64; 2]; 3],
    /// Inverse of the position rows on `still`.
    p_inv: [[f64; 3]; 3],
}

impl Split5 {
    /// A block's determinant below this share of the product of its columns' lengths
    /// (their largest possible determinant) counts as singular.
    const SINGULAR: f64 = 1e-8;

    /// Whether a determinant is clear of singular against the largest one its columns'
    /// lengths allow (false for a NaN too).
    fn regular(det: f64, largest: f64) -> bool {
        det.abs() > Self::SINGULAR * largest
    }

    fn new(m: &[[f64; 5]; 5]) -> Option<Self> {
        let (mut still, mut turning) = ([0; 3], [0; 2]);
        let (mut s, mut t) = (0, 0);
        for (j, (&d1, &d2)) in m[3].iter().zip(&m[4]).enumerate() {
            if d1 == 0.0 && d2 == 0.0 {
                *still.get_mut(s)? = j;
                s += 1;
            } else {
                *turning.get_mut(t)? = j;
                t += 1;
            }
        }
        if s != 3 {
            return None;
        }
        let [a, b] = [m[3][turning[0]], m[3][turning[1]]];
        let [c, d] = [m[4][turning[0]], m[4][turning[1]]];
        let det = a * d - b * c;
        // Jacobian entries are far from overflow: no `hypot` (a library call) needed.
        if !Self::regular(det, ((a * a + c * c) * (b * b + d * d)).sqrt()) {
            return None;
        }
        let d_inv = [[d / det, -b / det], [-c / det, a / det]];
        let p = |i: usize, k: usize| m[i][still[k]];
        // Cofactors of the 3×3 block; its inverse is their transpose over the determinant.
        let cof = |i: usize, j: usize| {
            let (r0, r1) = ((i + 1) % 3, (i + 2) % 3);
            let (c0, c1) = ((j + 1) % 3, (j + 2) % 3);
            p(r0, c0) * p(r1, c1) - p(r0, c1) * p(r1, c0)
        };
        let det3 = p(0, 0) * cof(0, 0) + p(0, 1) * cof(0, 1) + p(0, 2) * cof(0, 2);
        let length = |k: usize| (p(0, k).powi(2) + p(1, k).powi(2) + p(2, k).powi(2)).sqrt();
        if !Self::regular(det3, length(0) * length(1) * length(2)) {
            return None;
        }
        Some(Split5 {
            still,
            turning,
            d_inv,
            p_turning: std::array::from_fn(|i| [m[i][turning[0]], m[i][turning[1]]]),
            p_inv: std::array::from_fn(|i| std::array::from_fn(|j| cof(j, i) / det3)),
        })
    }

    /// x with M·x = r.
    fn solve(&self, r: &[f64; 5]) -> [f64; 5] {
        let d = &self.d_inv;
        let turn = [
            d[0][0] * r[3] + d[0][1] * r[4],
            d[1][0] * r[3] + d[1][1] * r[4],
        ];
        let rest: [f64; 3] = std::array::from_fn(|i| {
            r[i] - self.p_turning[i][0] * turn[0] - self.p_turning[i][1] * turn[1]
        });
        let mut x = [0.0; 5];
        x[self.turning[0]] = turn[0];
        x[self.turning[1]] = turn[1];
        for (k, &j) in self.still.iter().enumerate() {
            let row = &self.p_inv[k];
            x[j] = row[0] * rest[0] + row[1] * rest[1] + row[2] * rest[2];
        }
        x
    }
}

/// The LU factors of a 5×5 matrix by Gaussian elimination with partial pivoting, for the
/// two or three solves of a block (a generic decomposition costs several times more).
#[derive(Debug, Clone, Copy)]
struct Lu5 {
    /// L below the diagonal (unit diagonal implied), U on and above it, rows permuted.
    a: [[f64; 5]; 5],
    /// Row i of the factors is row `perm[i]` of the matrix.
    perm: [usize; 5],
}

impl Lu5 {
    /// `None` when a pivot is lost in the rounding noise of the largest or is not finite.
    fn new(mut a: [[f64; 5]; 5]) -> Option<Self> {
        let mut perm = [0, 1, 2, 3, 4];
        let (mut smallest, mut largest) = (f64::INFINITY, 0.0f64);
        for k in 0..5 {
            let mut p = k;
            for i in k + 1..5 {
                if a[i][k].abs() > a[p][k].abs() {
                    p = i;
                }
            }
            a.swap(k, p);
            perm.swap(k, p);
            let pivot = a[k][k];
            smallest = smallest.min(pivot.abs());
            largest = largest.max(pivot.abs());
            if pivot == 0.0 || !pivot.is_finite() {
                return None;
            }
            let pivot_row = a[k];
            for row in &mut a[k + 1..] {
                let f = row[k] / pivot;
                row[k] = f;
                for (x, p) in row[k + 1..].iter_mut().zip(&pivot_row[k + 1..]) {
                    *x -= f * p;
                }
            }
        }
        (smallest > largest * f64::EPSILON).then_some(Lu5 { a, perm })
    }

    /// x with M·x = r.
    fn solve(&self, r: &[f64; 5]) -> [f64; 5] {
        let a = &self.a;
        let mut x = self.perm.map(|i| r[i]);
        for i in 1..5 {
            for j in 0..i {
                x[i] -= a[i][j] * x[j];
            }
        }
        for i in (0..5).rev() {
            for j in i + 1..5 {
                x[i] -= a[i][j] * x[j];
            }
            x[i] /= a[i][i];
        }
        x
    }
}

/// The step map for the Jacobian `jac` on the variables `free`: position rows exactly
/// (least squares if out of reach), direction rows (along `b1`, `b2`) as well as the
/// remaining freedom allows. Computed once per Jacobian and applied at every iteration.
///
/// `split`: solve in blocks where the structure allows ([`Split5`]). The compensation solve
/// asks for it: it starts microns from its solution with the nominal machine's Jacobian,
/// whose blocks are well conditioned outside the singular cone (held). Solves that may
/// start far from their solution (inverse kinematics from a guess) keep the LU, whose
/// pivoting is steadier there.
fn step_map(
    jac: &Jacobian,
    free: &[usize],
    b1: &Vector3<f64>,
    b2: &Vector3<f64>,
    split: bool,
) -> StepMap {
    let row = |i: usize, k: usize| match i {
        0..=2 => jac.dp[k][i],
        3 => b1.dot(&jac.do_[k]),
        _ => b2.dot(&jac.do_[k]),
    };
    if free.len() == 5 {
        let m = std::array::from_fn(|i| std::array::from_fn(|j| row(i, free[j])));
        if split && let Some(split) = Split5::new(&m) {
            return StepMap::Split(split);
        }
        if let Some(lu) = Lu5::new(m) {
            return StepMap::Square(lu);
        }
    }
    StepMap::General(general_map(free, &row))
}

/// The linear map from the residual r = [position (3); direction (2)] to the Newton step
/// Δ on the free variables (row i is free variable i) with J·Δ ≈ r, for any number of free
/// variables: position rows exactly (least squares if out of reach), direction rows as
/// well as the remaining freedom allows.
fn general_map(free: &[usize], row: &dyn Fn(usize, usize) -> f64) -> SMatrix<f64, MAX_AXES, 5> {
    let m = free.len();
    let mut out = SMatrix::<f64, MAX_AXES, 5>::zeros();
    // Every variable held: there is no step to take (and no matrix to decompose).
    if m == 0 {
        return out;
    }
    // Three free variables with well-conditioned position rows (the linear axes of a TCP
    // block or a plane, the rotary ones held): the map below reduces to the position rows'
    // inverse, with no null space for the direction rows. Found directly, it costs a
    // fortieth of the decompositions, which allocate.
    if m == 3
        && let Some(inv) = inverse3(&std::array::from_fn(|i| {
            std::array::from_fn(|j| row(i, free[j]))
        }))
    {
        for (i, inv_row) in inv.iter().enumerate() {
            for (j, &x) in inv_row.iter().enumerate() {
                out[(i, j)] = x;
            }
        }
        return out;
    }
    decomposed_map(free, row)
}

/// [`general_map`] by decompositions, for any number of free variables.
fn decomposed_map(free: &[usize], row: &dyn Fn(usize, usize) -> f64) -> SMatrix<f64, MAX_AXES, 5> {
    let m = free.len();
    let mut out = SMatrix::<f64, MAX_AXES, 5>::zeros();
    // Position as a hard constraint: Δ = Jp⁺·rp + N·z, N a basis of what the position rows
    // cannot see, z the least-squares fit of the direction rows within it:
    // Δ = [Jp⁺ − N·A⁺·Jd·Jp⁺ | N·A⁺]·r with A = Jd·N.
    let jp = DMatrix::from_fn(3, m, |i, j| row(i, free[j]));
    let jd = DMatrix::from_fn(2, m, |i, j| row(i + 3, free[j]));
    // Singular values below this share of the largest count as zero: a combination of axes
    // that moves the tip a millionth as much as the others does not move it at all.
    const RANK: f64 = 1e-6;
    // A non-finite Jacobian (axis values beyond any travel) would keep the iterative
    // decompositions from converging: no step, and the solve reports it did not land.
    if !(jp.iter().chain(jd.iter()).all(|x| x.is_finite())) {
        return out;
    }
    // (Bounded iterations: a decomposition that does not converge gives no step.)
    const ITERATIONS: usize = 10_000;
    let pinv = |a: &DMatrix<f64>| {
        let Some(svd) = nalgebra::SVD::try_new(a.clone(), true, true, f64::EPSILON, ITERATIONS)
        else {
            return DMatrix::zeros(a.ncols(), a.nrows());
        };
        let top = svd.singular_values.max();
        svd.pseudo_inverse((top * RANK).max(1e-300))
            .unwrap_or_else(|_| DMatrix::zeros(a.ncols(), a.nrows()))
    };
    let jp_pinv = pinv(&jp);
    // Null space of Jp from the eigenvectors of JpᵀJp (a full basis, unlike a thin SVD).
    let gram = jp.transpose() * &jp;
    let Some(eigen) = gram.clone().try_symmetric_eigen(f64::EPSILON, ITERATIONS) else {
        return out;
    };
    let top = eigen.eigenvalues.max().max(0.0);
    let null_cols: Vec<usize> = (0..m)
        .filter(|&i| eigen.eigenvalues[i] <= top * RANK * RANK)
        .collect();
    let null = DMatrix::from_fn(m, null_cols.len(), |i, j| {
        eigen.eigenvectors[(i, null_cols[j])]
    });
    let n_a_pinv = if null_cols.is_empty() {
        DMatrix::zeros(m, 2)
    } else {
        &null * pinv(&(&jd * &null))
    };
    let position_part = &jp_pinv - &n_a_pinv * &jd * &jp_pinv;
    for i in 0..m {
        for j in 0..3 {
            out[(i, j)] = position_part[(i, j)];
        }
        for j in 0..2 {
            out[(i, 3 + j)] = n_a_pinv[(i, j)];
        }
    }
    out
}

/// The inverse of `a` when its smallest singular value exceeds a thousandth of its largest
/// (σ₃ ≥ |det| / ‖a‖²_F and σ₁ ≤ ‖a‖_F, so |det| > 10⁻³·‖a‖³_F shows it), by cofactors.
/// `None` otherwise: [`general_map`]'s rank decisions (at 10⁻⁶) then take over.
fn inverse3(a: &[[f64; 3]; 3]) -> Option<[[f64; 3]; 3]> {
    let c =
        |r0: usize, r1: usize, c0: usize, c1: usize| a[r0][c0] * a[r1][c1] - a[r0][c1] * a[r1][c0];
    let cof = [
        [c(1, 2, 1, 2), -c(1, 2, 0, 2), c(1, 2, 0, 1)],
        [-c(0, 2, 1, 2), c(0, 2, 0, 2), -c(0, 2, 0, 1)],
        [c(0, 1, 1, 2), -c(0, 1, 0, 2), c(0, 1, 0, 1)],
    ];
    let det = a[0][0] * cof[0][0] + a[0][1] * cof[0][1] + a[0][2] * cof[0][2];
    let frobenius = a.iter().flatten().map(|x| x * x).sum::<f64>().sqrt();
    // Written so that NaN fails it too.
    let regular = det.abs() > 1e-3 * frobenius.powi(3);
    if !regular {
        return None;
    }
    // inverse = adjugate / det, the adjugate the cofactors transposed.
    Some(std::array::from_fn(|i| {
        std::array::from_fn(|j| cof[j][i] / det)
    }))
}

impl Kinematics {
    /// Inverse kinematics: axis values at which `model` reaches `target`, by Newton's
    /// method from `guess` (which picks the branch). A rotary axis that is singular at the
    /// target keeps its guessed value. `None` when the solve does not land within the
    /// options' tolerances, or 1e-9 mm and 1e-9 rad where those are tighter (a target out
    /// of reach, or a guess too far away).
    pub fn inverse(
        &self,
        model: Model,
        target: &Pose,
        guess: &[f64],
        length: f64,
        options: &SolveOptions,
    ) -> Option<Solution> {
        // One Jacobian at the guess serves the singular test and the solve's first steps.
        let angles = self.angles(guess);
        let (pose, jac) = self.jacobian_at(model, &guess[..self.len()], length, &angles);
        let held = self.singular_axes(target, &jac.axis_dir, options.singular_angle);
        let from = Start {
            pose,
            beyond: jac.beyond,
            jac: &jac,
            own: true,
        };
        let sol = self.solve_from(model, target, guess, length, held, options, from, &angles);
        let direction_ok = held != 0 || sol.direction_residual <= options.angle_tolerance.max(1e-9);
        (sol.position_residual <= options.position_tolerance.max(1e-9) && direction_ok)
            .then_some(sol)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    proptest::proptest! {
        #[test]
        fn lu_solves_are_nalgebras(
            m in proptest::collection::vec(-10.0..10.0f64, 25),
            r in proptest::collection::vec(-1.0..1.0f64, 5),
        ) {
            let matrix = nalgebra::Matrix5::from_row_slice(&m);
            let want = matrix.lu().solve(&Vector5::from_column_slice(&r));
            let lu = Lu5::new(std::array::from_fn(|i| std::array::from_fn(|j| m[i * 5 + j])));
            if let (Some(want), Some(lu)) = (want, lu) {
                let got = lu.solve(&[r[0], r[1], r[2], r[3], r[4]]);
                // Relative to how much the matrix amplifies: the residual M·x − r.
                let x = Vector5::from_column_slice(&got);
                let residual = (matrix * x - Vector5::from_column_slice(&r)).norm();
                proptest::prop_assert!(residual < 1e-10 * (1.0 + matrix.norm() * x.norm()), "{got:?} {want:?}");
                proptest::prop_assert!((x - want).norm() <= 1e-8 * (1.0 + want.norm()), "{got:?} {want:?}");
            }
        }
    }

    proptest::proptest! {
        #[test]
        fn split_solves_are_the_lus(
            m in proptest::collection::vec(-10.0..10.0f64, 25),
            r in proptest::collection::vec(-1.0..1.0f64, 5),
            order in proptest::sample::subsequence(vec![0usize, 1, 2, 3, 4], 3),
        ) {
            // Direction rows zero on three columns, anywhere.
            let mut a: [[f64; 5]; 5] = std::array::from_fn(|i| std::array::from_fn(|j| m[i * 5 + j]));
            for &j in &order {
                a[3][j] = 0.0;
                a[4][j] = 0.0;
            }
            let r = [r[0], r[1], r[2], r[3], r[4]];
            let split = Split5::new(&a);
            // Only a (near) singular matrix goes without the split.
            let det = nalgebra::Matrix5::from_fn(|i, j| a[i][j]).determinant();
            let split_or_near_singular = split.is_some() || det.abs() < 1e-3;
            proptest::prop_assert!(split_or_near_singular, "{a:?}: det {det}");
            if let (Some(split), Some(lu)) = (split, Lu5::new(a)) {
                let (x, want) = (split.solve(&r), lu.solve(&r));
                let matrix = nalgebra::Matrix5::from_fn(|i, j| a[i][j]);
                let xv = Vector5::from_column_slice(&x);
                let residual = (matrix * xv - Vector5::from_column_slice(&r)).norm();
                proptest::prop_assert!(residual < 1e-9 * (1.0 + matrix.norm() * xv.norm()), "{x:?} {want:?}");
                let wv = Vector5::from_column_slice(&want);
                proptest::prop_assert!((xv - wv).norm() <= 1e-7 * (1.0 + wv.norm()), "{x:?} {want:?}");
            }
        }
    }

    proptest::proptest! {
        /// Three free variables: the direct inverse is the decompositions' map, where it
        /// is taken (well-conditioned position rows), to rounding.
        #[test]
        fn three_free_variables_map_as_the_decompositions(
            m in proptest::array::uniform5(proptest::array::uniform5(-2.0f64..2.0)),
        ) {
            let free = [0usize, 2, 4];
            let row = |i: usize, k: usize| m[i][k];
            let a: [[f64; 3]; 3] = std::array::from_fn(|i| std::array::from_fn(|j| m[i][free[j]]));
            let fast = general_map(&free, &row);
            let decomposed = decomposed_map(&free, &row);
            if inverse3(&a).is_some() {
                for i in 0..3 {
                    for j in 0..5 {
                        let (x, y) = (fast[(i, j)], decomposed[(i, j)]);
                        proptest::prop_assert!((x - y).abs() <= 1e-9 * (1.0 + y.abs()), "{} {} {} {}", i, j, x, y);
                    }
                }
            } else {
                proptest::prop_assert_eq!(fast, decomposed);
            }
        }
    }

    #[test]
    fn split_needs_the_structure() {
        let mut m = [[1.0, 2.0, 0.5, 0.3, 0.7]; 5];
        for (i, row) in m.iter_mut().enumerate() {
            row[i] += 3.0;
        }
        // Direction rows nonzero everywhere: no split, the LU.
        assert!(Split5::new(&m).is_none());
        m[3][..3].fill(0.0);
        m[4][..3].fill(0.0);
        assert!(Split5::new(&m).is_some());
        // Four columns without direction: the two-by-two block would need three.
        m[3][3] = 0.0;
        m[4][3] = 0.0;
        assert!(Split5::new(&m).is_none());
    }

    #[test]
    fn singular_matrices_have_no_lu() {
        let mut m = [[1.0, 2.0, 0.0, 0.0, 0.0]; 5];
        for (i, row) in m.iter_mut().enumerate() {
            row[2 + i % 3] = i as f64;
        }
        m[4] = m[3];
        assert!(Lu5::new(m).is_none());
    }
}
