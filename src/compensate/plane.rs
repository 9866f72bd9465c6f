//! Tilted working planes (G68.2 X Y Z I J K, G53.1, G69): 3+2 work.
//!
//! G68.2 sets a frame in the part frame: its origin and its axes (Euler angles Z-X-Z, in
//! degrees). G53.1 turns the rotary axes so that the tool is perpendicular to the plane:
//! the controller computes them from the plane's normal with its nominal kinematics, and
//! of the solutions takes the one the machine file names (`[working_plane] solution`,
//! Fanuc's rule by default). No word of the program says where they go, so they stay at
//! the controller's values (design/model.md, "Output rule"): the moves after it put the tip
//! exactly where the program says with the linear axes, and the direction error the
//! rotary axes leave is reported. Those moves are tool-tip moves in the plane's frame, so
//! they go through the tool-centre-point mode ([`super::tcp`]) with the frame and the
//! rotary axes held; drilling cycles in the plane go through [`super::cycles`].

use super::pipeline::{Cx, Out};
use super::{Pass, State};
use crate::diag::Diagnostic;
use crate::kinematics::{MAX_AXES, Model, Pose, SolveOptions, angle_between};
use crate::model::{AxisKind, PlaneSolution};
use crate::program::WorkingPlane;
use crate::program::exact::{Position, Unit};
use nalgebra::Vector3;
use std::cmp::Ordering;

/// Angles closer than this (degrees) are the same solution.
const SAME: f64 = 1e-6;

impl Pass<'_> {
    /// G53.1: the rotary axes go where the controller turns them for the active plane;
    /// the linear axes stay.
    pub(super) fn to_plane(
        &self,
        cx: &Cx<'_, '_>,
        state: &mut State,
        out: &mut Out<'_>,
    ) -> Result<(), Diagnostic> {
        let col = cx.motion.arc_code.map_or(0, |i| cx.col(i));
        let Some(plane) = state.modal.working_plane else {
            return Ok(());
        };
        if state.zero != [0.0; 3] {
            return Err(cx.refuse(col, "G53.1 with a program zero other than the machine file's geometry zero (a work offset, a set-up's preset or a G52 shift) cannot be compensated: the plane's origin would need the shift in the part frame (expected the work offset the geometry is given in, `geometry` of [work_offsets])".into()));
        }
        let rotary = self.rotary_mask();
        if rotary == 0 {
            return Err(cx.refuse(
                col,
                "G53.1 turns the rotary axes to the plane, but this tool chain has none".into(),
            ));
        }
        if let Some(v) = (0..self.kin.len())
            .find(|&v| rotary & (1 << v) != 0 && state.pos.unknown & (1 << v) != 0)
        {
            return Err(cx.refuse(
                col,
                format!(
                    "the controller's choice of rotary positions for G53.1 depends on where axis {} stands, which is not known here (after G28, G30, G53 or a machine move code; program it before G53.1)",
                    self.axis_name(v)
                ),
            ));
        }
        let q = self
            .plane_rotaries(&plane, &state.emitted, state.modal.length)
            .map_err(|why| {
                let what = match state.modal.dialect {
                    crate::nc::Dialect::Heidenhain => "turning the rotary axes to the PLANE",
                    crate::nc::Dialect::Sinumerik => "CYCLE800's turn of the rotary axes",
                    crate::nc::Dialect::Iso => "G53.1",
                };
                cx.refuse(col, format!("{what} cannot be compensated: {why}"))
            })?;
        out.summary.plane_positions.push((
            cx.line.number,
            (0..self.kin.len())
                .filter(|&v| rotary & (1 << v) != 0)
                .map(|v| (self.axis_name(v).to_string(), q[v]))
                .collect(),
        ));
        for v in (0..self.kin.len()).filter(|&v| rotary & (1 << v) != 0) {
            let bit = 1u32 << v;
            state.pos.nominal[v] = q[v];
            state.emitted[v] = q[v];
            state.decimals[v] = state.decimals[v].max(self.decimals.1);
            state.written[v] = Position::Decimal {
                value: q[v],
                decimals: state.decimals[v],
                unit: Unit::MM,
            };
            state.pos.programmed |= bit;
            state.uncertain &= !bit;
            state.unsettled &= !bit;
        }
        // CYCLE800 retracts the linear axes it names to the machine's own positions first.
        state.pos.unknown |= cx.motion.homed;
        state.turned_at_rest = true;
        self.enter_plane(state);
        Ok(())
    }

    /// What a move under a tilted working plane needs: no rotary words (the rotary axes
    /// stand where G53.1 or the program's last rotary words put them, and the controller
    /// keeps them there), the controller's rotary values the programmed ones, and the tip
    /// known where the block does not give it.
    pub(super) fn plane_checks(
        &self,
        cx: &Cx<'_, '_>,
        state: &State,
        tips: &[usize; 3],
    ) -> Result<(), Diagnostic> {
        let pass = self;
        let n = pass.kin.len();
        let rotation = state.modal.working_plane.is_some_and(|p| p.rotation_only);
        // The messages' names and hints: G68.2's, or G68's.
        let (name, this, within, words_hint, unknown_hint, held_hint) = if rotation {
            (
                "a coordinate rotation (G68)",
                "this coordinate rotation",
                "under the coordinate rotation",
                "position the rotary axes before G68",
                "expected the rotary axes positioned before G68",
                "nccomp follows G68 only where the rotary axes stand at their programmed values",
            )
        } else {
            (
                "a tilted working plane (G68.2)",
                "this tilted working plane",
                "in the tilted working plane",
                "position the rotary axes with G53.1 or before G68.2",
                "expected G53.1 after G68.2",
                "expected G53.1 after G68.2, which turns the rotary axes to the plane",
            )
        };
        if let Some((v, i)) = cx.word_outside(n, tips) {
            return Err(cx.refuse(
                cx.col(i),
                format!(
                    "{} words under {name} cannot be compensated: how the controller moves the tip while a rotary axis turns under a plane is not determined (expected X, Y, Z; {words_hint})",
                    pass.letter(v) as char
                ),
            ));
        }
        let rotary = pass.rotary_mask();
        if let Some(v) =
            (0..n).find(|&v| rotary & (1 << v) != 0 && state.pos.unknown & (1 << v) != 0)
        {
            return Err(cx.refuse(
                cx.first_word_col(),
                format!(
                    "where axis {} stands under {this} is not known (after G28, G30, G53, M91, M92 or a machine move code; {unknown_hint})",
                    pass.axis_name(v)
                ),
            ));
        }
        if let Some(v) =
            (0..n).find(|&v| rotary & (1 << v) != 0 && state.emitted[v] != state.pos.nominal[v])
        {
            return Err(cx.refuse(
                cx.first_word_col(),
                format!(
                    "under {this} axis {} stands where an earlier block's corrected word put it ({:.4}, programmed {:.4}), and the controller would hold it there ({held_hint})",
                    pass.axis_name(v),
                    state.emitted[v],
                    state.pos.nominal[v]
                ),
            ));
        }
        let given = tips.iter().all(|&v| cx.motion.axis_words[v].is_some());
        if !given && state.pos.unknown != 0 {
            return Err(cx.refuse(
                cx.first_word_col(),
                format!("where the tool stands {within} before this block is not known (after G28, G30, G53, M91, M92 or a machine move code; expected X, Y and Z in this block)"),
            ));
        }
        Ok(())
    }

    /// The nominal axis values at which the tip is at words `w` (mm) of `frame`, the rotary
    /// axes as in `from`: the controller's transformation of the words.
    pub(super) fn plane_axes(
        &self,
        frame: &WorkingPlane,
        w: &Vector3<f64>,
        from: &[f64; MAX_AXES],
        length: f64,
    ) -> Option<[f64; MAX_AXES]> {
        let n = self.kin.len();
        let sol = self.kin.tcp_axes_with_rotaries(
            &frame.part(w),
            &from[..n],
            length,
            &self.options.solve,
        );
        (sol.position_residual <= 1e-6).then_some(sol.q)
    }

    /// The tip words (mm) of `frame` at which the nominal machine puts the tip at `q`.
    pub(super) fn plane_words(&self, frame: &WorkingPlane, q: &[f64], length: f64) -> Vector3<f64> {
        frame.words(
            &self
                .kin
                .pose(Model::Nominal, &q[..self.kin.len()], length)
                .0
                .p,
        )
    }

    /// A plane set or the rotary axes turned: the tip words before the next block, as
    /// programmed and as written, in the plane's frame.
    pub(super) fn enter_plane(&self, state: &mut State) {
        let Some(plane) = state.modal.working_plane else {
            return;
        };
        let n = self.kin.len();
        let (nominal, _) =
            self.kin
                .pose(Model::Nominal, &state.pos.nominal[..n], state.modal.length);
        let (written, _) = self
            .kin
            .pose(Model::Nominal, &state.emitted[..n], state.modal.length);
        state.tip_nominal = plane.words(&nominal.p).into();
        state.tip_written = plane.words(&written.p).into();
    }

    /// The rotary values (the other axes as they stand) at which the nominal machine points
    /// the tool along `normal`, the one of the solutions within travel that the machine
    /// file's rule picks. A rotary axis whose line lies along the tool there keeps its
    /// current value (it cannot turn the tool).
    pub(super) fn plane_rotaries(
        &self,
        plane: &WorkingPlane,
        from: &[f64; MAX_AXES],
        length: f64,
    ) -> Result<[f64; MAX_AXES], String> {
        let normal = &plane.normal();
        let n = self.kin.len();
        let from = *from;
        let order = self.rotary_order();
        let (here, _) = self.kin.pose(Model::Nominal, &from[..n], length);
        let target = Pose {
            p: here.p,
            o: normal.normalize(),
        };
        let far = SolveOptions {
            max_iterations: 100,
            singular_angle: 1e-7,
            ..self.options.solve
        };
        let mut found: Vec<[f64; MAX_AXES]> = Vec::new();
        // Newton's method from starts a quarter turn apart on every rotary axis reaches
        // every solution.
        let starts = 4usize.pow(order.len() as u32);
        for k in 0..starts {
            let mut start = from;
            for (j, &v) in order.iter().enumerate() {
                start[v] += 90.0 * ((k / 4usize.pow(j as u32)) % 4) as f64;
            }
            let Some(sol) = self
                .kin
                .inverse(Model::Nominal, &target, &start[..n], length, &far)
            else {
                continue;
            };
            let mut q = sol.q;
            let (pose, jac) = self.kin.pose_and_jacobian(Model::Nominal, &q[..n], length);
            let free = self.kin.singular_axes(&pose, &jac.axis_dir, 1e-7);
            let mut within = true;
            for &v in &order {
                if free & (1 << v) != 0 {
                    q[v] = from[v];
                    if plane.table_rot && self.is_table_var(v) {
                        q[v] = self.table_rot(plane, &q, v, length);
                    } else {
                        continue;
                    }
                }
                q[v] += 360.0 * ((from[v] - q[v]) / 360.0).round();
                if let Some([lo, hi]) = self.travel(v) {
                    if q[v] < lo && q[v] + 360.0 <= hi {
                        q[v] += 360.0;
                    } else if q[v] > hi && q[v] - 360.0 >= lo {
                        q[v] -= 360.0;
                    }
                    within &= (lo..=hi).contains(&q[v]);
                }
            }
            let (pose, _) = self.kin.pose(Model::Nominal, &q[..n], length);
            let mut miss = angle_between(&pose.o, &target.o);
            if !within || miss > 1e-9 {
                continue;
            }
            // Where the direction is stationary in an axis (a 45° head at its half turn)
            // Newton's method stops some µrad short of the angle the control computes in
            // closed form (the direction error left is their square); a rounder value that
            // points the tool at least as well is that angle.
            let all: u32 = order.iter().fold(0, |m, &v| m | 1 << v);
            let sets = std::iter::once(all).chain(order.iter().map(|&v| 1u32 << v));
            let grids = [1.0, 0.1, 0.01, 0.001, self.machine.resolution.rotary];
            for (set, grid) in sets.flat_map(|s| grids.iter().map(move |&g| (s, g))) {
                let mut snapped = q;
                for &v in order.iter().filter(|&&v| set & (1 << v) != 0) {
                    snapped[v] = (q[v] / grid).round() * grid;
                }
                // The other axes follow the snapped one (a C table turns with the head).
                let miss_at = |q: &[f64; MAX_AXES]| {
                    let (pose, _) = self.kin.pose(Model::Nominal, &q[..n], length);
                    angle_between(&pose.o, &target.o)
                };
                for &u in order.iter().filter(|&&u| set & (1 << u) == 0) {
                    let (mut lo, mut hi) = (snapped[u] - 0.05, snapped[u] + 0.05);
                    let ratio = (5f64.sqrt() - 1.0) / 2.0;
                    // A bounded search: at angles of 10⁶° two neighbouring floats are
                    // farther apart than 1e-10 (the interval would never close).
                    for _ in 0..64 {
                        if hi - lo <= 1e-10 {
                            break;
                        }
                        let (a, b) = (hi - ratio * (hi - lo), lo + ratio * (hi - lo));
                        let (mut qa, mut qb) = (snapped, snapped);
                        qa[u] = a;
                        qb[u] = b;
                        if miss_at(&qa) < miss_at(&qb) {
                            hi = b;
                        } else {
                            lo = a;
                        }
                    }
                    snapped[u] = (lo + hi) / 2.0;
                    let mut gridded = snapped;
                    let fine = self.machine.resolution.rotary;
                    gridded[u] = (snapped[u] / fine).round() * fine;
                    if miss_at(&gridded) <= miss_at(&snapped) {
                        snapped = gridded;
                    }
                }
                let m = miss_at(&snapped);
                if m <= miss.max(1e-13) {
                    q = snapped;
                    miss = m;
                }
            }
            if !found
                .iter()
                .any(|f| order.iter().all(|&v| (f[v] - q[v]).abs() < SAME))
            {
                found.push(q);
            }
        }
        let rule = match plane.sequence {
            Some(positive) => match self.master_axis() {
                Some(axis) => PlaneSolution::Sign { axis, positive },
                None => return Err("SEQ+/SEQ- picks the solution by the master rotary axis, and this tool chain has no rotary axis".into()),
            },
            None => self.machine.plane_solution,
        };
        let wanted = match rule {
            PlaneSolution::Shortest => None,
            PlaneSolution::Sign { axis, positive } => {
                let Some(v) = self.kin.axes().iter().position(|&a| a == axis) else {
                    return Err(format!(
                        "the machine file picks the solution by the sign of axis {}, which this tool chain does not move",
                        self.machine.axes[axis].name
                    ));
                };
                found.retain(|q| {
                    if positive {
                        q[v] >= -SAME
                    } else {
                        q[v] <= SAME
                    }
                });
                Some((self.machine.axes[axis].name.as_str(), positive))
            }
        };
        // Fanuc's rule: the least move of the first axis, then of the second, then the
        // angles nearer 0.
        let wrapped = |x: f64| (x - 360.0 * (x / 360.0).round()).abs();
        let cost = |q: &[f64; MAX_AXES]| {
            let mut key = Vec::with_capacity(2 * order.len());
            key.extend(order.iter().map(|&v| (q[v] - from[v]).abs()));
            key.extend(order.iter().map(|&v| wrapped(q[v])));
            key
        };
        let best = found.iter().min_by(|a, b| {
            let (ka, kb) = (cost(a), cost(b));
            ka.iter()
                .zip(&kb)
                .find(|(x, y)| (*x - *y).abs() >= SAME)
                .map_or(Ordering::Equal, |(x, y)| x.total_cmp(y))
        });
        best.copied().ok_or_else(|| match wanted {
            Some((name, positive)) => format!(
                "the nominal machine cannot turn the tool perpendicular to this plane with axis {name} {} within the travel",
                if positive { "at 0 or above" } else { "at 0 or below" }
            ),
            None => "the nominal machine cannot turn the tool perpendicular to this plane within the travel".into(),
        })
    }

    /// Heidenhain's master axis (the one SEQ± signs): the rotary axis nearest the tool
    /// in the head, or without head axes the table axis nearest the bed (index into
    /// [`crate::model::Machine::axes`]).
    fn master_axis(&self) -> Option<usize> {
        let rotary = |a: &&usize| self.machine.axes[**a].kind == AxisKind::Rotary;
        let chain = &self.machine.tool_chains[self.chain].axes;
        chain
            .iter()
            .rev()
            .find(rotary)
            .or_else(|| self.machine.workpiece_chain.iter().find(rotary))
            .copied()
    }

    /// Variable `v` is an axis of the workpiece chain (it turns the table).
    fn is_table_var(&self, v: usize) -> bool {
        self.machine.workpiece_chain.contains(&self.kin.axes()[v])
    }

    /// TABLE ROT: the value of table variable `v`, free at `q`, at which the machine's X
    /// axis moves the tool along the plane's X axis.
    fn table_rot(&self, plane: &WorkingPlane, q: &[f64; MAX_AXES], v: usize, length: f64) -> f64 {
        let n = self.kin.len();
        let Some(x) = self.tip_var(b'X') else {
            return q[v];
        };
        let along = |q: &[f64; MAX_AXES]| {
            let mut moved = *q;
            moved[x] += 1.0;
            let p0 = self.kin.pose(Model::Nominal, &q[..n], length).0.p;
            let p1 = self.kin.pose(Model::Nominal, &moved[..n], length).0.p;
            p1 - p0
        };
        let target = plane.rotation * Vector3::x();
        let normal = plane.normal();
        let angle = |d: Vector3<f64>| normal.dot(&d.cross(&target)).atan2(d.dot(&target));
        let phi = angle(along(q)).to_degrees();
        let mut best = q[v];
        let mut residual = phi.abs();
        for value in [q[v] + phi, q[v] - phi] {
            let mut t = *q;
            t[v] = value;
            let r = angle(along(&t)).to_degrees().abs();
            if r < residual {
                best = value;
                residual = r;
            }
        }
        best
    }

    /// The rotary variables, the controller's first (master) axis first: the table's
    /// from the bed outward, then the head's.
    fn rotary_order(&self) -> Vec<usize> {
        let axes = self.kin.axes();
        let var = |axis: usize| axes.iter().position(|&a| a == axis);
        let chain = &self.machine.tool_chains[self.chain].axes;
        self.machine
            .workpiece_chain
            .iter()
            .chain(chain.iter())
            .filter_map(|&a| var(a))
            .filter(|&v| self.kin.kind(v) == AxisKind::Rotary)
            .fold(Vec::new(), |mut list, v| {
                if !list.contains(&v) {
                    list.push(v);
                }
                list
            })
    }
}
