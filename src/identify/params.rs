//! The unknowns of an identification: which error terms, at which table positions, and
//! the error model and error file they make.
//!
//! A plan names the terms it identifies (docs/identify.md):
//!
//! - a position-independent term by its name: `EC0Y`, `EX0C`, ...;
//! - an error motion at one table position: `EBX@-50` (positions are axis values in
//!   program coordinates; between the positions the model interpolates linearly and it
//!   holds the end values beyond, as every motion table does);
//! - a straightness over a feature's `stations`: `EYX`. ISO 230-1 refers straightness to
//!   a reference line, here the line through its two end stations: the ends are 0 and
//!   the stations between them are the unknowns (`EYX@-70`, ...). A linear trend of a
//!   trace is therefore never straightness; it is a squareness or an angular error,
//!   which other terms carry.
//!
//! ISO 230 names are mapped onto the model only by [`crate::model::terms`].

use super::plan::Plan;
use crate::model::{ErrorModel, Machine, MotionTable, terms};
use std::collections::BTreeMap;

/// One axis's table positions and each of its terms' series on them.
type AxisSeries = (Vec<f64>, Vec<(String, Vec<f64>)>);

/// One unknown.
#[derive(Debug, Clone, PartialEq)]
enum Slot {
    /// A position-independent term.
    Constant(String),
    /// Table term `name` (EYX), entry `index` of its positions.
    Table(String, usize),
}

/// An error motion's table: axis, positions (program coordinates, increasing) and for
/// each position the unknown it takes (`None`: held at 0, a straightness end).
#[derive(Debug, Clone, PartialEq)]
struct Table {
    axis: usize,
    positions: Vec<f64>,
    unknown: Vec<Option<usize>>,
}

/// The unknowns of an identification and the model they make.
#[derive(Debug, Clone, PartialEq)]
pub struct Params {
    /// The unknowns' names: `EC0Y`, `EYX@-70`, `EBX@-50`, in plan order.
    pub names: Vec<String>,
    slots: Vec<Slot>,
    tables: BTreeMap<String, Table>,
    /// For each unknown of a table, its table with 1 at its own position and 0 elsewhere:
    /// its weight at any position, as the model interpolates.
    units: Vec<Option<MotionTable>>,
}

/// A term of the plan that cannot be identified, and why.
#[derive(Debug, Clone, PartialEq)]
pub struct TermError {
    /// The term as the plan writes it (empty when no term is to blame).
    pub term: String,
    pub message: String,
}

impl std::fmt::Display for TermError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.message)
    }
}

/// `-50` for -50.0, `12.5` for 12.5: positions as they read in names.
pub fn position_text(x: f64) -> String {
    format!("{}", x + 0.0)
}

impl Params {
    /// The unknowns `plan` identifies on `machine`; the message says which term of which
    /// feature is wrong.
    pub fn new(plan: &Plan, machine: &Machine) -> Result<Params, TermError> {
        let mut p = Params {
            names: Vec::new(),
            slots: Vec::new(),
            tables: BTreeMap::new(),
            units: Vec::new(),
        };
        // Whole straightness tables first, then single positions, so that a term given
        // both ways is caught whatever the order.
        let mut points: Vec<(String, f64, String, String)> = Vec::new();
        for f in &plan.features {
            for term in &f.identifies {
                let at = |m: String| TermError {
                    term: term.clone(),
                    message: format!("feature `{}`, term `{term}`: {m}", f.name),
                };
                let (base, position) = match term.split_once('@') {
                    Some((b, x)) => {
                        let x: f64 = x.trim().parse().map_err(|_| {
                            at(format!(
                                "`{x}` is not a position: expected e.g. {b}@-50 (mm or degrees)"
                            ))
                        })?;
                        (b, Some(x))
                    }
                    None => (term.as_str(), None),
                };
                let name = terms::parse(base).ok_or_else(|| {
                    at("expected an ISO 230 error name such as EYX, EBX@-50 or EC0Y".into())
                })?;
                let axis = machine
                    .axis_index(name.axis)
                    .ok_or_else(|| at(format!("the machine has no axis {}", name.axis)))?;
                let role = terms::role(&name, &machine.axes[axis]).map_err(at)?;
                let motion = matches!(role, terms::Role::Motion(_));
                match (motion, position) {
                    (false, Some(_)) => {
                        return Err(at(format!(
                            "{base} is position-independent, a single value: drop `@`"
                        )));
                    }
                    (false, None) => {
                        if p.names.iter().any(|n| n == base) {
                            return Err(at("the plan identifies it twice".into()));
                        }
                        p.names.push(base.to_string());
                        p.slots.push(Slot::Constant(base.to_string()));
                    }
                    (true, Some(x)) => points.push((
                        base.to_string(),
                        x,
                        term.clone(),
                        format!("feature `{}`, term `{term}`: ", f.name),
                    )),
                    (true, None) => {
                        let mut stations = f.stations.clone();
                        if stations.len() < 3
                            || stations.windows(2).any(|w| w[1] <= w[0])
                            || stations.iter().any(|s| !s.is_finite())
                        {
                            return Err(at(
                                "a straightness needs `stations`: at least 3 increasing \
                                 positions (its ends are the reference line, 0)"
                                    .into(),
                            ));
                        }
                        if p.tables.contains_key(base) {
                            return Err(at("the plan identifies it twice".into()));
                        }
                        let mut unknown = vec![None; stations.len()];
                        for (k, s) in stations.iter_mut().enumerate().skip(1) {
                            if k + 1 == unknown.len() {
                                break;
                            }
                            unknown[k] = Some(p.names.len());
                            p.names.push(format!("{base}@{}", position_text(*s)));
                            p.slots.push(Slot::Table(base.to_string(), k));
                        }
                        p.tables.insert(
                            base.to_string(),
                            Table {
                                axis,
                                positions: stations,
                                unknown,
                            },
                        );
                    }
                }
            }
        }
        for (base, x, term, at) in points {
            let fail = |m: String| TermError {
                term: term.clone(),
                message: format!("{at}{m}"),
            };
            let axis = machine
                .axis_index(terms::parse(&base).map_or("", |t| t.axis))
                .unwrap_or(0);
            let t = p.tables.entry(base.clone()).or_insert(Table {
                axis,
                positions: Vec::new(),
                unknown: Vec::new(),
            });
            if t.unknown.iter().any(Option::is_none) {
                return Err(fail(format!(
                    "{base} is identified as a straightness over stations elsewhere in the \
                     plan: give it one way"
                )));
            }
            if t.positions.contains(&x) {
                return Err(fail("the plan identifies it twice".into()));
            }
            let k = t.positions.partition_point(|&v| v < x);
            t.positions.insert(k, x);
            t.unknown.insert(k, Some(p.names.len()));
            p.names.push(format!("{base}@{}", position_text(x)));
            p.slots.push(Slot::Table(base.clone(), usize::MAX));
        }
        // Table slots of single positions: their index in the sorted positions.
        for (name, t) in &p.tables {
            for (k, u) in t.unknown.iter().enumerate() {
                if let Some(j) = u {
                    p.slots[*j] = Slot::Table(name.clone(), k);
                }
            }
        }
        if p.names.is_empty() {
            return Err(TermError {
                term: String::new(),
                message: "the plan identifies no terms: list them in the features' `identifies`"
                    .into(),
            });
        }
        p.units = p
            .slots
            .iter()
            .map(|slot| {
                let Slot::Table(name, k) = slot else {
                    return None;
                };
                let t = p.tables.get(name)?;
                Some(MotionTable {
                    positions: t.positions.clone(),
                    values: [
                        Some((0..t.positions.len()).map(|i| f64::from(i == *k)).collect()),
                        None,
                        None,
                        None,
                        None,
                        None,
                    ],
                    periodic: machine.axes[t.axis].kind == crate::model::AxisKind::Rotary,
                })
            })
            .collect();
        Ok(p)
    }

    pub fn len(&self) -> usize {
        self.names.len()
    }

    pub fn is_empty(&self) -> bool {
        self.names.is_empty()
    }

    /// Whether unknown `j` is an angle (rad) rather than a length (mm).
    pub fn is_angle(&self, j: usize) -> bool {
        let base = match &self.slots[j] {
            Slot::Constant(n) | Slot::Table(n, _) => n,
        };
        terms::parse(base).is_some_and(|t| t.quantity() == terms::Quantity::Angle)
    }

    /// The model term unknown `j` sets: `EC0Y`, or `EYX` for `EYX@-70`.
    pub fn term(&self, j: usize) -> &str {
        match &self.slots[j] {
            Slot::Constant(n) | Slot::Table(n, _) => n,
        }
    }

    /// The model terms, each once, in the order of their first unknown.
    pub fn terms(&self) -> Vec<String> {
        let mut out: Vec<String> = Vec::new();
        for j in 0..self.len() {
            if !out.iter().any(|t| t == self.term(j)) {
                out.push(self.term(j).to_string());
            }
        }
        out
    }

    /// The model with `term` alone set to `value` (mm or rad): an error motion at the same
    /// value at every position.
    pub fn unit_model(&self, machine: &Machine, term: &str, value: f64) -> ErrorModel {
        let mut model = ErrorModel::zero(machine);
        if let Some(t) = terms::parse(term)
            && let Some(i) = machine.axis_index(t.axis)
        {
            let a = &machine.axes[i];
            if self.tables.contains_key(term) {
                let mut table = MotionTable {
                    positions: vec![0.0],
                    values: Default::default(),
                    periodic: a.kind == crate::model::AxisKind::Rotary,
                };
                let _ = terms::apply_motion(&mut table, a, &t, vec![value]);
                model.axes[i].motion = Some(table);
            } else {
                let _ = terms::apply_constant(&mut model.axes[i], a, &t, value);
            }
        }
        model
    }

    /// The machine axis of unknown `j`'s table (`None` for a position-independent term).
    pub fn table_axis(&self, j: usize) -> Option<usize> {
        match &self.slots[j] {
            Slot::Constant(_) => None,
            Slot::Table(name, _) => self.tables.get(name).map(|t| t.axis),
        }
    }

    /// How much of unknown `j` its term takes at axis position `q` (program coordinates):
    /// its weight in the table's interpolation; 1 for a position-independent term.
    pub fn weight(&self, j: usize, q: f64) -> f64 {
        self.units[j]
            .as_ref()
            .map_or(1.0, |t| t.sample(q).values[0])
    }

    /// Each axis's table positions (the union over its terms) and each term's series on
    /// them, in mm and rad.
    fn series(&self, machine: &Machine, values: &[f64]) -> BTreeMap<usize, AxisSeries> {
        let mut out: BTreeMap<usize, AxisSeries> = BTreeMap::new();
        for t in self.tables.values() {
            let entry = out.entry(t.axis).or_default();
            entry.0.extend(&t.positions);
        }
        for (_, (positions, _)) in out.iter_mut() {
            positions.sort_by(f64::total_cmp);
            positions.dedup();
        }
        for (name, t) in &self.tables {
            let periodic = machine.axes[t.axis].kind == crate::model::AxisKind::Rotary;
            let own = MotionTable {
                positions: t.positions.clone(),
                values: [
                    Some(
                        t.unknown
                            .iter()
                            .map(|u| u.map_or(0.0, |j| values[j]))
                            .collect(),
                    ),
                    None,
                    None,
                    None,
                    None,
                    None,
                ],
                periodic,
            };
            let entry = out
                .get_mut(&t.axis)
                .expect("every table's axis has an entry");
            let series = entry.0.iter().map(|&x| own.sample(x).values[0]).collect();
            entry.1.push((name.clone(), series));
        }
        out
    }

    /// The error model of `values` (mm, rad; one per unknown).
    pub fn model(&self, machine: &Machine, values: &[f64]) -> ErrorModel {
        let mut model = ErrorModel::zero(machine);
        for (j, slot) in self.slots.iter().enumerate() {
            if let Slot::Constant(name) = slot
                && let Some(t) = terms::parse(name)
                && let Some(i) = machine.axis_index(t.axis)
            {
                // Checked in `new`.
                let _ = terms::apply_constant(&mut model.axes[i], &machine.axes[i], &t, values[j]);
            }
        }
        for (axis, (positions, series)) in self.series(machine, values) {
            let a = &machine.axes[axis];
            let mut table = MotionTable {
                positions: positions.iter().map(|x| x + a.table_offset).collect(),
                values: Default::default(),
                periodic: a.kind == crate::model::AxisKind::Rotary,
            };
            for (name, s) in series {
                if let Some(t) = terms::parse(&name) {
                    let _ = terms::apply_motion(&mut table, a, &t, s);
                }
            }
            model.axes[axis].motion = Some(table);
        }
        model
    }

    /// An error file (design/model.md, µm and µrad) of `values` (mm, rad).
    pub fn error_toml(&self, machine: &Machine, values: &[f64], title: &str) -> String {
        let scale = |j: usize| if self.is_angle(j) { 1e6 } else { 1e3 };
        let mut out = format!(
            "# {title}\n# Written by nccomp identify (docs/identify.md).\nlength_unit = \"um\"\nangle_unit = \"urad\"\n"
        );
        let mut squareness = String::new();
        let mut location: BTreeMap<usize, String> = BTreeMap::new();
        for (j, slot) in self.slots.iter().enumerate() {
            if let Slot::Constant(name) = slot {
                let line = format!("{name} = {:.4}\n", values[j] * scale(j));
                let axis = terms::parse(name)
                    .and_then(|t| machine.axis_index(t.axis))
                    .unwrap_or(0);
                if machine.axes[axis].kind == crate::model::AxisKind::Rotary {
                    location.entry(axis).or_default().push_str(&line);
                } else {
                    squareness.push_str(&line);
                }
            }
        }
        if !squareness.is_empty() {
            out.push_str(&format!("\n[squareness]\n{squareness}"));
        }
        for (axis, lines) in &location {
            out.push_str(&format!(
                "\n[location.{}]\n{lines}",
                machine.axes[*axis].name
            ));
        }
        for (axis, (positions, series)) in self.series(machine, values) {
            let a = &machine.axes[axis];
            let list = |v: Vec<String>| format!("[{}]", v.join(", "));
            out.push_str(&format!(
                "\n[motion.{}]\npositions = {}\n",
                a.name,
                list(
                    positions
                        .iter()
                        .map(|x| position_text(x + a.table_offset))
                        .collect()
                )
            ));
            for (name, s) in series {
                let k = if terms::parse(&name)
                    .is_some_and(|t| t.quantity() == terms::Quantity::Angle)
                {
                    1e6
                } else {
                    1e3
                };
                out.push_str(&format!(
                    "{name} = {}\n",
                    list(s.iter().map(|v| format!("{:.4}", v * k)).collect())
                ));
            }
        }
        out
    }
}
