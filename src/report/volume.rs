//! The machine's volumetric error: the tool tip's deviation, without compensation, over a
//! grid of the linear axes' travel at fixed positions of the other axes.
//!
//! Every number comes from [`Kinematics`]: the deviation is the actual pose's tip minus the
//! nominal pose's tip, in the workpiece frame. For the arrows it is expressed in the
//! coordinates of the linear axes (the axis motion that would move the tip as the error
//! does, from the nominal Jacobian), so that it reads in the map's own axes whichever
//! body an axis moves and however the rotary axes turn the workpiece.

use crate::kinematics::{Kinematics, Model};
use crate::model::{AxisKind, Machine};
use nalgebra::{DMatrix, DVector};

/// One grid axis of a map: its name and the positions sampled (mm).
#[derive(Debug, Clone, PartialEq)]
pub struct GridAxis {
    pub name: String,
    pub positions: Vec<f64>,
}

/// One panel: the tip error over the grid of two linear axes, at fixed values of the rest.
#[derive(Debug, Clone, PartialEq)]
pub struct Panel {
    /// The third linear axis and its value, if the machine has one.
    pub level: Option<(String, f64)>,
    /// Where the level lies in the part's feed moves ("lowest", "middle", "highest"), when
    /// the levels come from the part.
    pub role: Option<&'static str>,
    /// Per grid point, `j * u.len() + i` for u position i and v position j: the length of
    /// the tip error (mm) ...
    pub magnitude: Vec<f64>,
    /// ... and its components along the u and v axes (mm).
    pub along: Vec<[f64; 2]>,
    /// An error table was read beyond its ends somewhere on the grid.
    pub beyond: bool,
}

/// The maps at one set of fixed axis values (`--at`).
#[derive(Debug, Clone, PartialEq)]
pub struct Map {
    /// The fixed axes and their values, e.g. "A = 30°, C = 90°" (empty on a machine with
    /// linear axes only).
    pub label: String,
    pub u: GridAxis,
    pub v: GridAxis,
    pub panels: Vec<Panel>,
    /// The span of the u and v axes over the program's feed moves: where the part is.
    pub part: Option<[[f64; 2]; 2]>,
}

impl Map {
    /// The largest error of all panels (mm).
    pub fn max_magnitude(&self) -> f64 {
        self.panels
            .iter()
            .flat_map(|p| p.magnitude.iter().copied())
            .fold(0.0, f64::max)
    }
}

/// Where the grid goes: the variables of the map's axes and their ranges (mm).
#[derive(Debug, Clone, PartialEq)]
pub struct Layout {
    /// Variables of the two grid axes and, if there is one, the level axis.
    pub u: usize,
    pub v: usize,
    pub w: Option<usize>,
    /// Range of every variable (only the grid and level axes' are used).
    pub ranges: Vec<[f64; 2]>,
    /// Where the part is: the span of every variable over the program's feed moves (over
    /// all its moves when it has none), where the program gives it.
    pub part: Vec<Option<[f64; 2]>>,
}

/// The margin around the program's working volume on the grid axes: a tenth of its larger
/// span, at least this (mm), so the map shows the error field around it too.
const MARGIN_MIN: f64 = 10.0;

/// The span of every variable over `points`, where they give it.
fn spans(n: usize, points: &[Vec<f64>]) -> Vec<Option<[f64; 2]>> {
    (0..n)
        .map(|k| {
            let (lo, hi) = points
                .iter()
                .filter_map(|q| q.get(k))
                .filter(|x| x.is_finite())
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &x| {
                    (lo.min(x), hi.max(x))
                });
            (lo <= hi).then_some([lo, hi])
        })
        .collect()
}

impl Layout {
    /// The first two linear axes of the active configuration (machine file order) span the
    /// grid, the third gives the levels. The grid covers the program's working volume: the
    /// span of `program` (the programmed values, per variable) on the grid axes with a
    /// margin, within the axis's travel; the levels are the bottom, middle and top of the
    /// part (the span of `feed`, the values of the feed moves). An axis the program does
    /// not give spans its travel, else ±100 mm. `None`: fewer than two linear axes.
    pub fn new(
        machine: &Machine,
        kin: &Kinematics,
        program: &[Vec<f64>],
        feed: &[Vec<f64>],
    ) -> Option<Self> {
        let linear: Vec<usize> = (0..kin.len())
            .filter(|&v| kin.kind(v) == AxisKind::Linear)
            .collect();
        if linear.len() < 2 {
            return None;
        }
        let (u, v, w) = (linear[0], linear[1], linear.get(2).copied());
        let volume = spans(kin.len(), program);
        let part: Vec<Option<[f64; 2]>> = spans(kin.len(), feed)
            .into_iter()
            .zip(&volume)
            .map(|(f, p)| f.or(*p))
            .collect();
        let span = |k: usize| volume[k].map_or(0.0, |[lo, hi]| hi - lo);
        let margin = (0.1 * span(u).max(span(v))).max(MARGIN_MIN);
        let ranges = (0..kin.len())
            .map(|k| {
                let travel = machine.axes[kin.axes()[k]].travel;
                let Some([lo, hi]) = volume[k] else {
                    return travel.unwrap_or([-100.0, 100.0]);
                };
                let pad = if k == u || k == v || hi - lo <= 1e-6 {
                    margin
                } else {
                    0.0
                };
                let (lo, hi) = (lo - pad, hi + pad);
                match travel {
                    // Within the travel, unless the program lies outside it (the map then
                    // shows where the program goes).
                    Some([a, b]) if lo.max(a) < hi.min(b) => [lo.max(a), hi.min(b)],
                    _ => [lo, hi],
                }
            })
            .collect();
        Some(Layout {
            u,
            v,
            w,
            ranges,
            part,
        })
    }
}

/// `n` positions evenly over `range` (at least two).
fn spread(range: [f64; 2], n: usize) -> Vec<f64> {
    let n = n.max(2);
    (0..n)
        .map(|k| range[0] + (range[1] - range[0]) * k as f64 / (n - 1) as f64)
        .collect()
}

/// The maps at the fixed values `at` (one value per variable; the grid axes' are
/// overwritten), with `n` points per grid axis. The level axis takes its value from `at`
/// when `level_given`, else three levels: the bottom, middle and top of the part (one when
/// the part has one level), or the ends and middle of its range without a part.
pub fn map(
    machine: &Machine,
    kin: &Kinematics,
    layout: &Layout,
    at: &[f64],
    level_given: bool,
    n: usize,
) -> Map {
    let name = |v: usize| machine.axes[kin.axes()[v]].name.clone();
    let u = GridAxis {
        name: name(layout.u),
        positions: spread(layout.ranges[layout.u], n),
    };
    let v = GridAxis {
        name: name(layout.v),
        positions: spread(layout.ranges[layout.v], n),
    };
    let levels: Vec<(Option<f64>, Option<&'static str>)> = match layout.w {
        None => vec![(None, None)],
        Some(w) if level_given => vec![(Some(at[w]), None)],
        Some(w) => match layout.part[w] {
            Some([lo, hi]) if hi - lo > 1e-6 => vec![
                (Some(lo), Some("lowest")),
                (Some((lo + hi) / 2.0), Some("middle")),
                (Some(hi), Some("highest")),
            ],
            Some([lo, _]) => vec![(Some(lo), None)],
            None => {
                let [lo, hi] = layout.ranges[w];
                vec![
                    (Some(lo), None),
                    (Some((lo + hi) / 2.0), None),
                    (Some(hi), None),
                ]
            }
        },
    };
    let label = (0..kin.len())
        .filter(|&k| k != layout.u && k != layout.v && Some(k) != layout.w)
        .map(|k| {
            let unit = match kin.kind(k) {
                AxisKind::Linear => " mm",
                AxisKind::Rotary => "°",
            };
            format!("{} = {}{unit}", name(k), at[k])
        })
        .collect::<Vec<_>>()
        .join(", ");
    let length = machine.tool.length;
    let linear: Vec<usize> = (0..kin.len())
        .filter(|&k| kin.kind(k) == AxisKind::Linear)
        .collect();
    let iu = linear.iter().position(|&k| k == layout.u).unwrap_or(0);
    let iv = linear.iter().position(|&k| k == layout.v).unwrap_or(1);
    let panels = levels
        .into_iter()
        .map(|(level, role)| {
            let mut q = at.to_vec();
            if let (Some(w), Some(z)) = (layout.w, level) {
                q[w] = z;
            }
            let mut panel = Panel {
                level: layout.w.zip(level).map(|(w, z)| (name(w), z)),
                role,
                magnitude: Vec::with_capacity(n * n),
                along: Vec::with_capacity(n * n),
                beyond: false,
            };
            for &y in &v.positions {
                for &x in &u.positions {
                    q[layout.u] = x;
                    q[layout.v] = y;
                    let (nominal, jac) = kin.pose_and_jacobian(Model::Nominal, &q, length);
                    let (actual, beyond) = kin.pose(Model::Actual, &q, length);
                    panel.beyond |= beyond;
                    let e = actual.p - nominal.p;
                    let j = DMatrix::from_fn(3, linear.len(), |r, c| jac.dp[linear[c]][r]);
                    let x_axes = j
                        .svd(true, true)
                        .solve(&DVector::from_column_slice(e.as_slice()), 1e-12)
                        .unwrap_or_else(|_| DVector::zeros(linear.len()));
                    panel.magnitude.push(e.norm());
                    panel.along.push([x_axes[iu], x_axes[iv]]);
                }
            }
            panel
        })
        .collect();
    Map {
        label,
        u,
        v,
        panels,
        part: layout.part[layout.u]
            .zip(layout.part[layout.v])
            .map(|(a, b)| [a, b]),
    }
}
