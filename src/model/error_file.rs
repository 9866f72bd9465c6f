//! Error files: a machine's calibration (design/model.md, "Files").
//!
//! ```toml
//! length_unit = "um"            # "mm" | "um"; default um
//! angle_unit = "urad"           # "rad" | "urad" | "deg" | "arcsec"; default urad
//!
//! [squareness]                  # E<A|B|C>0<linear axis> = angle
//! EC0Y = 45.5
//!
//! [location.C]                  # E<X|Y|Z>0C = length, E<A|B|C>0C = angle
//! EX0C = 2.3
//!
//! [motion.X]                    # error motions against the axis position
//! positions = [-400.0, 0.0, 400.0]   # mm or degrees (table positions), not error units
//! EYX = [0.0, 2.0, -0.3]        # lengths for EX*, EY*, EZ*; angles for EA*, EB*, EC*
//! ```
//!
//! Everything is converted to mm and rad. Names are mapped onto the model by
//! [`terms`]; a name that is unknown, misplaced or meaningless is an error
//! at its place in the file, never a silent zero. Missing terms are zero, so a file with
//! nothing but its units is the zero model.

use super::limits;
use super::machine_file::{Bounds, Doc};
use super::terms::{self, Quantity, TermName, and_list, or_list, suggest};
use super::{Axis, AxisKind, ErrorModel, Machine, MotionTable};
use crate::Result;
use std::borrow::Cow;
use std::path::Path;
use toml::Spanned;
use toml::de::{DeTable, DeValue};

/// Read and check an error file for `machine`.
pub fn load(path: &Path, machine: &Machine) -> Result<ErrorModel> {
    let text = super::read_text(path, "error file")?;
    parse(&text, &path.display().to_string(), machine)
}

/// Check the error file `text` against `machine`; `path` names it in messages.
pub fn parse(text: &str, path: &str, machine: &Machine) -> Result<ErrorModel> {
    let doc = Doc { path, text };
    let root = doc.parse()?;
    let root = root.get_ref();
    let mut model = ErrorModel::zero(machine);
    let file = ErrorFile {
        doc: &doc,
        machine,
        units: Units::read(&doc, root)?,
    };

    for (key, value) in root.iter() {
        match key.get_ref().as_ref() {
            "length_unit" | "angle_unit" => {}
            "squareness" => file.squareness(value, &mut model)?,
            "location" => {
                let sections = doc.table(value, "[location.<rotary axis>] tables")?;
                for (axis, table) in sections.iter() {
                    file.location(axis, table, &mut model)?;
                }
            }
            "motion" => {
                let sections = doc.table(value, "[motion.<axis>] tables")?;
                for (axis, table) in sections.iter() {
                    file.motion(axis, table, &mut model)?;
                }
            }
            other => {
                let hint = if terms::parse(other).is_some() {
                    "error terms go in [squareness], [location.<axis>] or [motion.<axis>]; "
                } else {
                    ""
                };
                let allowed = [
                    "length_unit",
                    "angle_unit",
                    "squareness",
                    "location",
                    "motion",
                ];
                let close = match suggest(other, allowed) {
                    Some(s) => format!("did you mean `{s}`? "),
                    None => String::new(),
                };
                return Err(doc.err(
                    key.span(),
                    format!(
                        "unknown key `{other}` in the error file: {close}{hint}expected \
                         `length_unit`, `angle_unit`, [squareness], [location.<axis>] or \
                         [motion.<axis>]"
                    ),
                ));
            }
        }
    }
    Ok(model)
}

/// Names for a message: the `positions` key in backquotes, error names as they are.
fn listed(names: &[String]) -> Vec<String> {
    names
        .iter()
        .map(|n| {
            if n == "positions" {
                format!("`{n}`")
            } else {
                n.clone()
            }
        })
        .collect()
}

/// Factors from the file's units to mm and rad.
pub(crate) struct Units {
    length: f64,
    angle: f64,
    length_name: String,
    angle_name: String,
}

impl Units {
    pub(crate) fn read(doc: &Doc, root: &DeTable) -> Result<Units> {
        let mut units = Units {
            length: 1e-3,
            angle: 1e-6,
            length_name: "um".into(),
            angle_name: "urad".into(),
        };
        if let Some(v) = root.get("length_unit") {
            let s = doc.string(v, "`length_unit`")?;
            units.length = match s {
                "mm" => 1.0,
                "um" => 1e-3,
                _ => {
                    return Err(doc.err(
                        v.span(),
                        format!("unknown length unit \"{s}\": expected \"mm\" or \"um\""),
                    ));
                }
            };
            units.length_name = s.to_string();
        }
        if let Some(v) = root.get("angle_unit") {
            let s = doc.string(v, "`angle_unit`")?;
            units.angle = match s {
                "rad" => 1.0,
                "urad" => 1e-6,
                "deg" => std::f64::consts::PI / 180.0,
                "arcsec" => std::f64::consts::PI / (180.0 * 3600.0),
                _ => {
                    return Err(doc.err(
                        v.span(),
                        format!(
                            "unknown angle unit \"{s}\": expected \"rad\", \"urad\", \"deg\" or \
                             \"arcsec\""
                        ),
                    ));
                }
            };
            units.angle_name = s.to_string();
        }
        Ok(units)
    }

    /// The largest error of this quantity, in the file's unit ([`limits::ERROR_LENGTH_MM`],
    /// [`limits::ERROR_ANGLE_RAD`]).
    pub(crate) fn limit(&self, q: Quantity) -> f64 {
        match q {
            Quantity::Length => limits::ERROR_LENGTH_MM / self.length,
            Quantity::Angle => limits::ERROR_ANGLE_RAD / self.angle,
        }
    }

    /// The factor to mm or rad for a term of this quantity, and the file's unit name.
    pub(crate) fn of(&self, q: Quantity) -> (f64, &str) {
        match q {
            Quantity::Length => (self.length, &self.length_name),
            Quantity::Angle => (self.angle, &self.angle_name),
        }
    }
}

type Key<'t> = Spanned<Cow<'t, str>>;
type Value<'t> = Spanned<DeValue<'t>>;

struct ErrorFile<'a, 't> {
    doc: &'a Doc<'t>,
    machine: &'a Machine,
    units: Units,
}

/// Which section a term was found in.
#[derive(Clone, Copy)]
enum Section<'s> {
    Squareness,
    Location(&'s str),
    Motion(&'s str),
}

impl std::fmt::Display for Section<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Section::Squareness => write!(f, "[squareness]"),
            Section::Location(a) => write!(f, "[location.{a}]"),
            Section::Motion(a) => write!(f, "[motion.{a}]"),
        }
    }
}

impl<'t> ErrorFile<'_, 't> {
    fn squareness(&self, value: &Value<'t>, model: &mut ErrorModel) -> Result<()> {
        let doc = self.doc;
        let table = doc.table(value, "[squareness], a table of squareness angles")?;
        let candidates: Vec<String> = self
            .machine
            .axes
            .iter()
            .filter(|a| a.kind == AxisKind::Linear)
            .flat_map(terms::constant_names)
            .collect();
        for (key, v) in table.iter() {
            let (i, term) = self.term(key, Section::Squareness, &candidates)?;
            let axis = &self.machine.axes[i];
            let value = self.constant(key, v, &term)?;
            terms::apply_constant(&mut model.axes[i], axis, &term, value)
                .map_err(|m| doc.err(key.span(), m))?;
        }
        Ok(())
    }

    fn location(
        &self,
        axis_key: &Key<'t>,
        value: &Value<'t>,
        model: &mut ErrorModel,
    ) -> Result<()> {
        let doc = self.doc;
        let i = self.section_axis(axis_key, "location")?;
        let axis = &self.machine.axes[i];
        if axis.kind == AxisKind::Linear {
            return Err(doc.err(
                axis_key.span(),
                format!(
                    "[location.{0}]: location errors are for rotary axes, and {0} is linear: \
                     its position-independent errors are squareness terms ({1}) under \
                     [squareness]",
                    axis.name,
                    or_list(&terms::constant_names(axis)),
                ),
            ));
        }
        let section = Section::Location(&axis.name);
        let table = doc.table(value, &format!("{section}, a table of location errors"))?;
        let candidates = terms::constant_names(axis);
        for (key, v) in table.iter() {
            let (_, term) = self.term(key, section, &candidates)?;
            let value = self.constant(key, v, &term)?;
            terms::apply_constant(&mut model.axes[i], axis, &term, value)
                .map_err(|m| doc.err(key.span(), m))?;
        }
        Ok(())
    }

    fn motion(&self, axis_key: &Key<'t>, value: &Value<'t>, model: &mut ErrorModel) -> Result<()> {
        let doc = self.doc;
        let i = self.section_axis(axis_key, "motion")?;
        let axis = &self.machine.axes[i];
        let section = Section::Motion(&axis.name);
        let table = doc.table(
            value,
            &format!("{section}, a table with `positions` and error-motion series"),
        )?;
        let (unit, reach) = match axis.kind {
            AxisKind::Linear => ("mm", limits::LENGTH_MM),
            AxisKind::Rotary => ("degrees", limits::ANGLE_DEG),
        };
        let Some(pv) = table.get("positions") else {
            return Err(doc.err(
                value.span(),
                format!(
                    "{section} has no `positions`: expected `positions = [...]`, the table \
                     positions of axis {} in {unit}",
                    axis.name
                ),
            ));
        };
        let positions = doc.numbers_in(pv, "`positions`", Bounds::within(reach, unit))?;
        if positions.is_empty() {
            return Err(doc.err(
                pv.span(),
                format!("`positions` is empty: expected at least one position in {unit}"),
            ));
        }
        for w in positions.windows(2) {
            if w[1].0 <= w[0].0 {
                return Err(doc.err(
                    w[1].1.clone(),
                    format!(
                        "position {} follows {}: expected strictly increasing positions",
                        w[1].0, w[0].0
                    ),
                ));
            }
        }
        let periodic = axis.kind == AxisKind::Rotary;
        let (first, last) = (positions[0].0, positions[positions.len() - 1].0);
        if periodic && last - first > 360.0 {
            return Err(doc.err(
                pv.span(),
                format!(
                    "the positions of rotary axis {} span {}° (from {first} to {last}): \
                     expected at most 360°, one revolution (the table repeats every 360°)",
                    axis.name,
                    last - first
                ),
            ));
        }
        let mut table_out = MotionTable {
            positions: positions.iter().map(|p| p.0).collect(),
            values: Default::default(),
            periodic,
        };
        let mut candidates = terms::motion_names(axis);
        candidates.push("positions".into());
        for (key, v) in table.iter() {
            if key.get_ref() == "positions" {
                continue;
            }
            let (_, term) = self.term(key, section, &candidates)?;
            let (factor, unit) = self.units.of(term.quantity());
            let limit = self.units.limit(term.quantity());
            let series = doc.numbers_in(
                v,
                &format!("the series `{term}`"),
                Bounds::within(limit, unit),
            )?;
            if series.len() != positions.len() {
                return Err(doc.err(
                    v.span(),
                    format!(
                        "`{term}` has {} value{}: expected {}, one per entry of `positions`",
                        series.len(),
                        if series.len() == 1 { "" } else { "s" },
                        positions.len()
                    ),
                ));
            }
            if periodic && positions.len() > 1 && last - first == 360.0 {
                let (a, b) = (&series[0], &series[series.len() - 1]);
                if a.0 != b.0 {
                    return Err(doc.err(
                        b.1.clone(),
                        format!(
                            "`{term}` is {} at {last}° but {} at {first}°, the same angle of \
                             rotary axis {}: expected equal values",
                            b.0, a.0, axis.name
                        ),
                    ));
                }
            }
            let values = series.iter().map(|s| s.0 * factor).collect();
            terms::apply_motion(&mut table_out, axis, &term, values)
                .map_err(|m| doc.err(key.span(), m))?;
        }
        model.axes[i].motion = Some(table_out);
        Ok(())
    }

    /// The machine axis a section header names (`[motion.X]` → X).
    fn section_axis(&self, key: &Key<'t>, kind: &str) -> Result<usize> {
        let name: &str = key.get_ref();
        if let Some(i) = self.machine.axis_index(name) {
            return Ok(i);
        }
        let axes: Vec<&Axis> = self
            .machine
            .axes
            .iter()
            .filter(|a| kind == "motion" || a.kind == AxisKind::Rotary)
            .collect();
        let names: Vec<String> = axes.iter().map(|a| a.name.clone()).collect();
        let hint = match suggest(name, names.iter().map(String::as_str)) {
            Some(s) => format!("did you mean [{kind}.{s}]? "),
            None => String::new(),
        };
        let expected = if names.is_empty() {
            format!(
                "the machine has no {}axes",
                if kind == "motion" { "" } else { "rotary " }
            )
        } else {
            format!(
                "expected one of the machine's {}axes: {}",
                if kind == "motion" { "" } else { "rotary " },
                or_list(&names)
            )
        };
        Err(self.doc.err(
            key.span(),
            format!("[{kind}.{name}]: the machine has no axis `{name}`; {hint}{expected}"),
        ))
    }

    /// The axis index and parsed name of a term key found in `section`, if it belongs
    /// there; otherwise an error that says where it belongs or what was expected.
    fn term<'k>(
        &self,
        key: &'k Key<'t>,
        section: Section,
        candidates: &[String],
    ) -> Result<(usize, TermName<'k>)> {
        let doc = self.doc;
        let name: &str = key.get_ref();
        let found =
            terms::parse(name).and_then(|t| self.machine.axis_index(t.axis).map(|i| (i, t)));
        let Some((i, term)) = found else {
            let close = suggest(name, candidates.iter().map(String::as_str));
            let hint = match close {
                Some(s) => format!("did you mean `{s}`? "),
                None => String::new(),
            };
            let why = match terms::parse(name) {
                Some(t) => format!(" (the machine has no axis `{}`)", t.axis),
                None => String::new(),
            };
            let expected = if candidates.is_empty() {
                format!("{section} takes no terms on this machine")
            } else {
                format!("expected one of {}", or_list(&listed(candidates)))
            };
            return Err(doc.err(
                key.span(),
                format!("unknown error name `{name}` in {section}{why}: {hint}{expected}"),
            ));
        };
        let axis = &self.machine.axes[i];
        // Where this term belongs.
        let home = match (term.constant, axis.kind) {
            (false, _) => Section::Motion(&axis.name),
            (true, AxisKind::Linear) => Section::Squareness,
            (true, AxisKind::Rotary) => Section::Location(&axis.name),
        };
        let same = match (home, section) {
            (Section::Squareness, Section::Squareness) => true,
            (Section::Location(a), Section::Location(b))
            | (Section::Motion(a), Section::Motion(b)) => a == b,
            _ => false,
        };
        // A meaningless term is reported as such wherever it stands.
        terms::role(&term, axis).map_err(|m| doc.err(key.span(), m))?;
        if !same {
            let what = match home {
                Section::Motion(_) => format!("an error motion of axis {}", axis.name),
                Section::Squareness => format!("a squareness term of linear axis {}", axis.name),
                Section::Location(_) => {
                    format!("a location error of rotary axis {}", axis.name)
                }
            };
            let close = suggest(name, candidates.iter().map(String::as_str))
                .filter(|&s| s != name)
                .map(|s| format!(" (or did you mean `{s}`?)"))
                .unwrap_or_default();
            let list = if candidates.is_empty() {
                String::new()
            } else {
                format!("; {section} takes {}", and_list(&listed(candidates)))
            };
            return Err(doc.err(
                key.span(),
                format!("`{name}` is {what}: it belongs under {home}, not {section}{close}{list}"),
            ));
        }
        Ok((i, term))
    }

    /// A single term value, converted to mm or rad.
    fn constant(&self, key: &Key<'t>, v: &Value<'t>, term: &TermName) -> Result<f64> {
        let (factor, unit) = self.units.of(term.quantity());
        if v.get_ref().as_array().is_some() {
            return Err(self.doc.err(
                v.span(),
                format!(
                    "`{}` is a position-independent term: expected one number in {unit}, not \
                     a series",
                    key.get_ref()
                ),
            ));
        }
        let limit = self.units.limit(term.quantity());
        Ok(self
            .doc
            .number_in(v, &format!("`{term}`"), Bounds::within(limit, unit))?
            * factor)
    }
}
