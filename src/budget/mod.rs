//! The error budget of a machine (paper 002): which error terms matter, and how tight
//! each must be made.
//!
//! - [`study`]: the parameter study, the change of the tool tip (and direction) per unit of
//!   each error term, at a pose or as the worst case over a grid of poses (the paper's
//!   table 6, for any machine);
//! - [`ranking`]: key errors, ranked by their contribution to the error in one direction,
//!   from ranges per term: an orthogonal-array design with ANOVA (the paper's), and a
//!   variance-based (Sobol) ranking;
//! - [`tolerance`]: the cost–quality model of the paper, solved for the tolerances of the
//!   key errors within bounds;
//! - [`report`]: the tables (human, CSV, JSON) and an SVG bar chart of the ranking;
//! - [`budget_file`]: the budget file (ranges, bounds, costs) that feeds them.
//!
//! Every number comes from [`crate::kinematics`]: a term's effect is the difference of the
//! pose computed with an error model that holds that term (and only the terms asked for)
//! and the nominal pose. Terms are set on the model through [`crate::model::terms`], the one
//! place where ISO 230 names are mapped onto the model. Error motions are taken as constant
//! over the travel (the value of the term at the pose), as the paper does.

pub mod budget_file;
pub mod ranking;
pub mod report;
pub mod sampling;
pub mod study;
pub mod tolerance;

use crate::kinematics::{Kinematics, Model, Pose};
use crate::model::terms::{self, Quantity, Role};
use crate::model::{AxisKind, ErrorModel, Machine, MotionTable};
use nalgebra::Vector3;
use serde::Serialize;
use std::fmt;

/// One error term of the budget, by its ISO 230 name (`EZX`, `EC0Y`, `EX0C`, ...).
#[derive(Debug, Clone, PartialEq)]
pub struct Term {
    pub name: String,
    /// Index of its axis in [`Machine::axes`].
    pub axis: usize,
    pub quantity: Quantity,
}

impl Term {
    /// The term `name` of `machine`, if it is a meaningful term of an axis of the active
    /// configuration `active` (machine axis indices).
    pub fn new(machine: &Machine, active: &[usize], name: &str) -> Result<Term, String> {
        let parsed = terms::parse(name).ok_or_else(|| {
            format!(
                "`{name}` is not an error name: expected `E` + X|Y|Z|A|B|C + an axis name, with \
                 a `0` before the axis for a position-independent term (EZX, EC0Y, EX0C)"
            )
        })?;
        let Some(axis) = machine.axis_index(parsed.axis) else {
            let names: Vec<String> = active
                .iter()
                .flat_map(|&i| terms::valid_names(&machine.axes[i]))
                .collect();
            let hint = match terms::suggest(name, names.iter().map(String::as_str)) {
                Some(s) => format!("; did you mean {s}?"),
                None => String::new(),
            };
            return Err(format!(
                "`{name}`: the machine has no axis {}{hint}",
                parsed.axis
            ));
        };
        if !active.contains(&axis) {
            return Err(format!(
                "`{name}`: axis {} is not in the active configuration (the workpiece chain and \
                 the chosen tool chain)",
                parsed.axis
            ));
        }
        terms::role(&parsed, &machine.axes[axis])?;
        Ok(Term {
            name: name.to_string(),
            axis,
            quantity: parsed.quantity(),
        })
    }

    /// Whether the term is a length (mm) or an angle (rad).
    pub fn is_length(&self) -> bool {
        self.quantity == Quantity::Length
    }

    /// The model unit of its values: `mm` or `rad`.
    pub fn model_unit(&self) -> &'static str {
        if self.is_length() { "mm" } else { "rad" }
    }

    /// Set the term to `value` (mm or rad) on `model`. An error motion becomes a motion
    /// table that holds the value at every position.
    pub fn apply(&self, machine: &Machine, model: &mut ErrorModel, value: f64) {
        let parsed = terms::parse(&self.name).expect("a term is checked when it is made");
        let axis = &machine.axes[self.axis];
        let errors = &mut model.axes[self.axis];
        let done = if parsed.constant {
            terms::apply_constant(errors, axis, &parsed, value)
        } else {
            let table = errors.motion.get_or_insert_with(|| MotionTable {
                positions: vec![0.0],
                values: Default::default(),
                periodic: axis.kind == AxisKind::Rotary,
            });
            terms::apply_motion(table, axis, &parsed, vec![value])
        };
        done.expect("a term is checked when it is made");
    }
}

impl fmt::Display for Term {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.name)
    }
}

/// The default terms of the active configuration: every error motion of every axis, the
/// location errors of rotary axes, and one squareness per pair of linear axes in the ISO
/// 230-1 convention (the later axis against the earlier one in X, Y, Z order: EC0Y, EB0Z,
/// EA0Z). For a three-axis machine that is the paper's 21 errors; for a five-axis machine
/// with two rotary axes, 43.
///
/// Ordered as the paper's table 6: translations by direction then axis (EXX, EXY, EXZ,
/// EYX, ...), rotations by direction then axis (EAX, EAY, ...), then the position-
/// independent terms axis by axis.
pub fn default_terms(machine: &Machine, active: &[usize]) -> Vec<Term> {
    let mut names: Vec<String> = Vec::new();
    for c in terms::Component::ALL {
        for &i in active {
            names.push(format!("E{}{}", c.letter(), machine.axes[i].name));
        }
    }
    for &i in active {
        let axis = &machine.axes[i];
        let own = terms::own_direction(axis);
        for name in terms::constant_names(axis) {
            let parsed = terms::parse(&name).expect("constant_names are valid names");
            // Of a linear axis, keep the squareness against an earlier direction only
            // (about k, the pair is own and the third direction 3 - own - k).
            let keep = match terms::role(&parsed, axis) {
                Ok(Role::Squareness(k)) => 3 - own - k < own,
                Ok(_) => true,
                Err(_) => false,
            };
            if keep {
                names.push(name);
            }
        }
    }
    names
        .iter()
        .filter_map(|n| Term::new(machine, active, n).ok())
        .collect()
}

/// The change of the pose an error model makes: tip (mm) and tool direction (unit-vector
/// components, rad for small changes), actual minus nominal, in the workpiece frame.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct Deviation {
    pub dp: [f64; 3],
    pub do_: [f64; 3],
}

impl Deviation {
    fn between(actual: &Pose, nominal: &Pose) -> Self {
        let dp = actual.p - nominal.p;
        let d_o = actual.o - nominal.o;
        Deviation {
            dp: [dp.x, dp.y, dp.z],
            do_: [d_o.x, d_o.y, d_o.z],
        }
    }

    /// The tip deviation along `direction` (a unit vector).
    pub fn along(&self, direction: &Vector3<f64>) -> f64 {
        Vector3::from(self.dp).dot(direction)
    }

    fn scaled(&self, k: f64) -> Self {
        Deviation {
            dp: self.dp.map(|v| v * k),
            do_: self.do_.map(|v| v * k),
        }
    }

    fn minus(&self, other: &Self) -> Self {
        Deviation {
            dp: [0, 1, 2].map(|i| self.dp[i] - other.dp[i]),
            do_: [0, 1, 2].map(|i| self.do_[i] - other.do_[i]),
        }
    }

    /// The largest |component| of the tip part (mm) and of the direction part.
    fn max_abs(&self) -> (f64, f64) {
        let m = |v: &[f64; 3]| v.iter().fold(0.0f64, |a, x| a.max(x.abs()));
        (m(&self.dp), m(&self.do_))
    }
}

/// Where the machine is looked at: axis values of the active configuration, one set per
/// pose, in the order of [`Kinematics::axes`].
#[derive(Debug, Clone, PartialEq)]
pub enum Poses {
    /// `n` points per axis spread over its travel (both ends included; a continuous rotary
    /// axis: `n` points a full turn apart), every combination.
    Grid(usize),
    /// These poses.
    At(Vec<Vec<f64>>),
}

/// The evaluator everything in the budget goes through: a machine, an active
/// configuration, a tool length, a list of poses and a list of terms. It turns a vector of
/// term values into pose deviations, one per pose, through [`Kinematics`].
#[derive(Debug, Clone)]
pub struct Probe<'m> {
    pub machine: &'m Machine,
    pub chain: usize,
    /// Active tool length (mm).
    pub length: f64,
    /// Machine axis index of each variable of a pose.
    pub axes: Vec<usize>,
    pub poses: Vec<Vec<f64>>,
    pub terms: Vec<Term>,
    nominal: Vec<Pose>,
}

impl<'m> Probe<'m> {
    /// A probe of `machine` with tool chain `chain` and tool length `length` (mm) at
    /// `poses`. Fails on a chain that does not exist, on a grid over an axis without
    /// travel, and on a linear axis without travel.
    pub fn new(
        machine: &'m Machine,
        chain: usize,
        length: f64,
        poses: &Poses,
        terms: Vec<Term>,
    ) -> crate::Result<Self> {
        let kin = Kinematics::new(machine, &ErrorModel::zero(machine), chain)
            .map_err(|e| crate::Error::Usage(e.to_string()))?;
        let axes = kin.axes().to_vec();
        let poses = match poses {
            Poses::At(list) => list.clone(),
            Poses::Grid(n) => grid(machine, &axes, *n)?,
        };
        if poses.is_empty() {
            return Err(crate::Error::Usage("no poses to evaluate".into()));
        }
        let nominal = poses
            .iter()
            .map(|q| kin.pose(Model::Nominal, q, length).0)
            .collect();
        Ok(Probe {
            machine,
            chain,
            length,
            axes,
            poses,
            terms,
            nominal,
        })
    }

    /// The error model with `values` (mm, rad; parallel to the terms).
    pub fn model(&self, values: &[f64]) -> ErrorModel {
        let mut model = ErrorModel::zero(self.machine);
        for (term, &v) in self.terms.iter().zip(values) {
            if v != 0.0 {
                term.apply(self.machine, &mut model, v);
            }
        }
        model
    }

    fn kinematics(&self, values: &[f64]) -> Kinematics {
        Kinematics::new(self.machine, &self.model(values), self.chain)
            .expect("the chain was checked when the probe was made")
    }

    /// The pose deviation at every pose for term values `values` (mm, rad).
    pub fn deviations(&self, values: &[f64]) -> Vec<Deviation> {
        let kin = self.kinematics(values);
        self.poses
            .iter()
            .zip(&self.nominal)
            .map(|(q, nominal)| {
                Deviation::between(&kin.pose(Model::Actual, q, self.length).0, nominal)
            })
            .collect()
    }

    /// The tip deviation along `direction` at every pose, written into `out`.
    pub fn along(&self, values: &[f64], direction: &Vector3<f64>, out: &mut [f64]) {
        let kin = self.kinematics(values);
        for ((q, nominal), y) in self.poses.iter().zip(&self.nominal).zip(out.iter_mut()) {
            let actual = kin.pose(Model::Actual, q, self.length).0;
            *y = (actual.p - nominal.p).dot(direction);
        }
    }

    /// `X=50 Y=45 Z=5` for pose `k`.
    pub fn describe_pose(&self, k: usize) -> String {
        describe_pose(self.machine, &self.axes, &self.poses[k])
    }
}

/// `X=50 Y=45 Z=5`: axis values of a pose by axis name.
pub fn describe_pose(machine: &Machine, axes: &[usize], q: &[f64]) -> String {
    axes.iter()
        .zip(q)
        .map(|(&i, v)| format!("{}={}", machine.axes[i].name, trim_number(*v)))
        .collect::<Vec<_>>()
        .join(" ")
}

/// A number without trailing zeros, rounded to 6 decimals.
fn trim_number(v: f64) -> String {
    let s = format!("{:.6}", v);
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" { "0".into() } else { s.into() }
}

/// `n` points per axis over the travel of each axis in `axes`, every combination (the
/// first axis varies slowest).
fn grid(machine: &Machine, axes: &[usize], n: usize) -> crate::Result<Vec<Vec<f64>>> {
    if n == 0 {
        return Err(crate::Error::Usage(
            "a grid needs at least one point per axis".into(),
        ));
    }
    let mut values: Vec<Vec<f64>> = Vec::new();
    for &i in axes {
        let axis = &machine.axes[i];
        let points = match (axis.travel, axis.kind) {
            (Some([lo, hi]), _) if n == 1 => vec![(lo + hi) / 2.0],
            (Some([lo, hi]), _) => (0..n)
                .map(|k| lo + (hi - lo) * k as f64 / (n - 1) as f64)
                .collect(),
            (None, AxisKind::Rotary) => (0..n).map(|k| 360.0 * k as f64 / n as f64).collect(),
            (None, AxisKind::Linear) => {
                return Err(crate::Error::Usage(format!(
                    "linear axis {} has no travel in the machine file, so there is no grid \
                     over it: give the poses instead (--at {}=...)",
                    axis.name, axis.name
                )));
            }
        };
        values.push(points);
    }
    let mut poses = vec![Vec::new()];
    for points in &values {
        poses = poses
            .iter()
            .flat_map(|p: &Vec<f64>| {
                points.iter().map(move |&v| {
                    let mut q = p.clone();
                    q.push(v);
                    q
                })
            })
            .collect();
    }
    Ok(poses)
}

/// Read a pose such as `X=50,Y=45,Z=5` (axis names of the active configuration; axes left
/// out are at 0).
pub fn parse_pose(machine: &Machine, axes: &[usize], text: &str) -> Result<Vec<f64>, String> {
    let mut q = vec![0.0; axes.len()];
    let mut seen = vec![false; axes.len()];
    for part in text.split([',', ' ']).filter(|s| !s.is_empty()) {
        let Some((name, value)) = part.split_once('=') else {
            return Err(format!(
                "pose `{text}`: `{part}` is not AXIS=VALUE (e.g. X=50,Y=45,Z=5)"
            ));
        };
        let name = name.trim();
        let Some(k) = axes.iter().position(|&i| machine.axes[i].name == name) else {
            let names: Vec<&str> = axes
                .iter()
                .map(|&i| machine.axes[i].name.as_str())
                .collect();
            let hint = match terms::suggest(name, names.iter().copied()) {
                Some(s) => format!("did you mean {s}? "),
                None => String::new(),
            };
            return Err(format!(
                "pose `{text}`: no axis `{name}` in the active configuration: {hint}the axes \
                 are {}",
                names.join(", ")
            ));
        };
        let v: f64 = value
            .trim()
            .parse()
            .ok()
            .filter(|v: &f64| v.is_finite())
            .ok_or_else(|| format!("pose `{text}`: `{value}` is not a number"))?;
        if seen[k] {
            return Err(format!("pose `{text}`: axis {name} is given twice"));
        }
        seen[k] = true;
        q[k] = v;
    }
    Ok(q)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::machine_file;

    fn grinder() -> Machine {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/fixtures/grinder.machine.toml");
        machine_file::load(std::path::Path::new(path)).unwrap()
    }

    #[test]
    fn default_terms_of_a_three_axis_machine_are_the_papers_21() {
        let m = grinder();
        let active: Vec<usize> = (0..m.axes.len()).collect();
        let names: Vec<String> = default_terms(&m, &active)
            .into_iter()
            .map(|t| t.name)
            .collect();
        assert_eq!(names.len(), 21);
        assert_eq!(&names[..4], ["EXX", "EXY", "EXZ", "EYX"]);
        assert_eq!(&names[18..], ["EC0Y", "EA0Z", "EB0Z"]);
    }

    #[test]
    fn terms_are_checked() {
        let m = grinder();
        let active: Vec<usize> = (0..m.axes.len()).collect();
        assert!(Term::new(&m, &active, "EZX").is_ok());
        let e = Term::new(&m, &active, "EA0X").unwrap_err();
        assert!(e.contains("meaningless"), "{e}");
        let e = Term::new(&m, &active, "EZQ").unwrap_err();
        assert!(e.contains("no axis Q"), "{e}");
        assert!(Term::new(&m, &active, "ezx").is_err());
    }

    #[test]
    fn poses_parse_and_grid() {
        let m = grinder();
        let probe = Probe::new(&m, 0, 0.0, &Poses::Grid(3), vec![]).unwrap();
        assert_eq!(probe.poses.len(), 27);
        assert_eq!(probe.describe_pose(0), "X=-350 Y=-175 Z=-200");
        let q = parse_pose(&m, &probe.axes, "X=50, Z=-5.5").unwrap();
        assert_eq!(q, vec![50.0, 0.0, -5.5]);
        assert!(
            parse_pose(&m, &probe.axes, "Q=1")
                .unwrap_err()
                .contains("no axis")
        );
        assert!(parse_pose(&m, &probe.axes, "X=a").is_err());
        assert!(parse_pose(&m, &probe.axes, "X=1,X=2").is_err());
    }
}
