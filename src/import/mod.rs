//! Calibration files from the field, converted into nccomp's error file: Beckhoff/ISG
//! `ISG_CSV` volumetric compensation tables ([`isg_csv`]) and the Etalon exchange format
//! ([`etalon`]).
//!
//! A reader turns its file into [`Entry`]s: an error name as the file writes it, and a
//! value or a series against the axis position, in the formats' units (mm, rad; axis
//! positions in mm or degrees). [`convert`] maps the names onto the contract's through
//! [`terms`] (nowhere else), merges the series of each axis onto one set of positions,
//! and writes an error file that the error-file loader reads back before it is handed
//! out. The mapping, signs and units are documented in docs/import.md.

pub mod etalon;
pub mod isg_csv;

use crate::model::terms::{self, Role, TermName};
use crate::model::{Axis, AxisKind, Chain, Machine, MotionTable, Resolution, Tool, error_file};
use crate::{Error, Result};
use nalgebra::Vector3;
use std::collections::BTreeMap;
use std::fmt::Write;

/// A calibration file format.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// Beckhoff/ISG volumetric compensation table (`file_format ISG_CSV`).
    IsgCsv,
    /// Etalon exchange format, "Vendor" variant (`file_format ETALON_EXCHANGE`).
    Etalon,
}

impl Format {
    pub fn name(self) -> &'static str {
        match self {
            Format::IsgCsv => "ISG_CSV",
            Format::Etalon => "Etalon exchange",
        }
    }

    /// The format of `text`: Etalon when its first line that is neither blank nor a
    /// comment opens a `[section]`, ISG CSV otherwise.
    pub fn detect(text: &str) -> Format {
        let first = text
            .lines()
            .map(|l| l.split("//").next().unwrap_or("").trim())
            .find(|l| !l.is_empty());
        match first {
            Some(l) if l.starts_with('[') => Format::Etalon,
            _ => Format::IsgCsv,
        }
    }
}

/// One error term as a file gives it.
#[derive(Debug, Clone, PartialEq)]
pub struct Entry {
    /// The name as written (`X0B`, `EYX`).
    pub name: String,
    /// Byte offset of the name in the file.
    pub offset: usize,
    pub data: Data,
}

/// A position-independent value, or a series against the axis position.
#[derive(Debug, Clone, PartialEq)]
pub enum Data {
    /// mm or rad.
    Constant(f64),
    /// Strictly increasing axis positions (mm or degrees) and the values there (mm or rad).
    Series {
        positions: Vec<f64>,
        values: Vec<f64>,
    },
}

impl Data {
    fn is_zero(&self) -> bool {
        match self {
            Data::Constant(v) => *v == 0.0,
            Data::Series { values, .. } => values.iter().all(|&v| v == 0.0),
        }
    }
}

/// How to convert.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Options {
    /// The input's format; `None`: [`Format::detect`].
    pub format: Option<Format>,
    /// Axes whose error motions change sign (files that give the tool's deviation
    /// relative to the workpiece for axes that carry the workpiece; docs/import.md).
    pub reverse: Vec<String>,
}

/// The converted error file.
#[derive(Debug, Clone, PartialEq)]
pub struct Converted {
    pub format: Format,
    /// The error file (TOML).
    pub toml: String,
    /// What a user should know: terms skipped, series resampled.
    pub notes: Vec<String>,
    /// A one-line account of what was converted.
    pub summary: String,
}

/// A number as a word in a file: how [`Entry`] readers parse values.
pub(crate) fn number(word: &str) -> Option<f64> {
    word.parse::<f64>().ok().filter(|v| v.is_finite())
}

/// The ISO 841 axes X, Y, Z (linear) and A, B, C (rotary about X, Y, Z): the machine the
/// names are checked against when no machine file is given.
fn iso_machine() -> Machine {
    let axes = ["X", "Y", "Z", "A", "B", "C"]
        .iter()
        .enumerate()
        .map(|(k, name)| {
            let mut direction = Vector3::zeros();
            direction[k % 3] = 1.0;
            Axis {
                name: (*name).to_string(),
                word: name.chars().next().unwrap_or('X'),
                kind: if k < 3 {
                    AxisKind::Linear
                } else {
                    AxisKind::Rotary
                },
                direction,
                point: Vector3::zeros(),
                travel: None,
                table_offset: 0.0,
                rollover: false,
            }
        })
        .collect();
    Machine {
        name: None,
        axes,
        workpiece_chain: Vec::new(),
        tool_chains: vec![Chain {
            name: "tool".into(),
            axes: Vec::new(),
            tools: Vec::new(),
        }],
        resolution: Resolution::default(),
        tool: Tool::default(),
        lathe: None,
        codes: Default::default(),
        plane_solution: Default::default(),
        inch_default: false,
        block_delete: None,
        start: Vec::new(),
        errors_file: None,
        cycle_r_initial: false,
        work_offsets: None,
    }
}

/// The series of one axis, as read.
struct Motion {
    term: String,
    index: usize,
    positions: Vec<f64>,
    values: Vec<f64>,
    line: usize,
    offset: usize,
}

/// Convert the calibration file `text` (named `path` in messages) into an error file. With
/// `machine` the names are checked against its axes, otherwise against the ISO axes X, Y,
/// Z, A, B, C; either way the result is read back by the error-file loader.
pub fn convert(
    text: &str,
    path: &str,
    machine: Option<&Machine>,
    options: &Options,
) -> Result<Converted> {
    let format = options.format.unwrap_or_else(|| Format::detect(text));
    let entries = match format {
        Format::IsgCsv => isg_csv::read(text, path)?,
        Format::Etalon => etalon::read(text, path)?,
    };
    let iso;
    let given = machine.is_some();
    let machine = match machine {
        Some(m) => m,
        None => {
            iso = iso_machine();
            &iso
        }
    };
    let at = |offset: usize, message: String| Error::at(path, text.as_bytes(), offset, message);
    let line_of = |offset: usize| crate::Diagnostic::at(path, text.as_bytes(), offset, "").line;
    let mut reverse = vec![false; machine.axes.len()];
    for name in &options.reverse {
        let i = machine.axis_index(name.trim()).ok_or_else(|| {
            Error::Usage(format!(
                "--reverse {name}: no such axis; expected one of {}",
                terms::or_list(
                    &machine
                        .axes
                        .iter()
                        .map(|a| a.name.clone())
                        .collect::<Vec<_>>()
                )
            ))
        })?;
        reverse[i] = true;
    }

    let mut notes = Vec::new();
    let mut seen: BTreeMap<String, usize> = BTreeMap::new();
    // Per axis: constants (term, value, line) and series.
    let mut constants: Vec<Vec<(String, usize, f64, usize)>> = vec![Vec::new(); machine.axes.len()];
    let mut motions: Vec<Vec<Motion>> = (0..machine.axes.len()).map(|_| Vec::new()).collect();
    for entry in &entries {
        let Some(term) = terms::parse_field(&entry.name) else {
            return Err(at(
                entry.offset,
                format!(
                    "`{}` is not an error name: expected one such as EXX or X0B",
                    entry.name
                ),
            ));
        };
        let Some(i) = machine.axis_index(term.axis) else {
            let names: Vec<String> = machine.axes.iter().map(|a| a.name.clone()).collect();
            return Err(at(
                entry.offset,
                format!(
                    "`{}` is an error of axis {}, which the machine does not have: expected \
                     an axis among {}{}",
                    entry.name,
                    term.axis,
                    terms::or_list(&names),
                    if !given {
                        " (give --machine for a machine with other axis names)"
                    } else {
                        ""
                    }
                ),
            ));
        };
        let axis = &machine.axes[i];
        let canonical = term.to_string();
        let line = line_of(entry.offset);
        if let Some(first) = seen.insert(canonical.clone(), line) {
            return Err(at(
                entry.offset,
                format!(
                    "`{}` ({canonical}) is given a second time (first at line {first}): expected \
                     each error once",
                    entry.name
                ),
            ));
        }
        let role = match terms::role(&term, axis) {
            Ok(role) => role,
            Err(why) if entry.data.is_zero() => {
                notes.push(format!(
                    "{path}:{line}: `{}` skipped: {why} (its value is zero)",
                    entry.name
                ));
                continue;
            }
            Err(why) => {
                return Err(at(
                    entry.offset,
                    format!(
                        "`{}` cannot be converted: {why}; nccomp's model has no place for it, \
                         and its value is not zero (remove it, or map it by hand)",
                        entry.name
                    ),
                ));
            }
        };
        match (role, &entry.data) {
            (Role::Motion(c), Data::Series { positions, values }) => {
                check_series(&term, axis, positions, values).map_err(|m| at(entry.offset, m))?;
                let sign = if reverse[i] { -1.0 } else { 1.0 };
                motions[i].push(Motion {
                    term: canonical,
                    index: c.index(),
                    positions: positions.clone(),
                    values: values.iter().map(|v| sign * v + 0.0).collect(),
                    line,
                    offset: entry.offset,
                });
            }
            (Role::Motion(_), Data::Constant(_)) => {
                return Err(at(
                    entry.offset,
                    format!(
                        "`{}` is an error motion of axis {}: expected a table of values \
                         against its position, not a single value",
                        entry.name, axis.name
                    ),
                ));
            }
            (_, Data::Constant(v)) => {
                constants[i].push((canonical, term.component.index(), *v, line))
            }
            (_, Data::Series { .. }) => {
                return Err(at(
                    entry.offset,
                    format!(
                        "`{}` is a position-independent error of axis {}: expected one value, \
                         not a table",
                        entry.name, axis.name
                    ),
                ));
            }
        }
    }

    let mut toml = format!(
        "# Converted by `nccomp errors convert` from {} file {path}.\n\
         # Names mapped onto ISO 230 names as nccomp writes them (X0B is EX0B); values and\n\
         # signs as the file gives them, in its units (docs/import.md). `# line N`: where\n\
         # the file names the term.\n\
         length_unit = \"mm\"\nangle_unit = \"rad\"\n",
        format.name()
    );
    let reversed: Vec<&str> = (0..machine.axes.len())
        .filter(|&i| reverse[i])
        .map(|i| machine.axes[i].name.as_str())
        .collect();
    if !reversed.is_empty() {
        let _ = writeln!(
            toml,
            "# The error motions of {} have their signs reversed (--reverse).",
            reversed.join(", ")
        );
    }
    let squareness: Vec<_> = machine
        .axes
        .iter()
        .enumerate()
        .filter(|(_, a)| a.kind == AxisKind::Linear)
        .flat_map(|(i, _)| sorted(&constants[i]))
        .collect();
    if !squareness.is_empty() {
        toml.push_str("\n[squareness]\n");
        for (name, _, value, line) in squareness {
            let _ = writeln!(toml, "{name} = {}   # line {line}", write_number(value));
        }
    }
    for (i, axis) in machine.axes.iter().enumerate() {
        if axis.kind == AxisKind::Rotary && !constants[i].is_empty() {
            let _ = writeln!(toml, "\n[location.{}]", axis.name);
            for (name, _, value, line) in sorted(&constants[i]) {
                let _ = writeln!(toml, "{name} = {}   # line {line}", write_number(value));
            }
        }
    }
    let mut counts: (usize, usize) = (constants.iter().map(Vec::len).sum(), 0);
    for (i, axis) in machine.axes.iter().enumerate() {
        let list = &mut motions[i];
        if list.is_empty() {
            continue;
        }
        list.sort_by_key(|m| m.index);
        counts.1 += list.len();
        let positions = union(list);
        if axis.kind == AxisKind::Rotary && positions[positions.len() - 1] - positions[0] > 360.0 {
            return Err(at(
                list[0].offset,
                format!(
                    "the error motions of rotary axis {} together span {}° (from {} to {}): \
                     expected at most 360°, one revolution",
                    axis.name,
                    positions[positions.len() - 1] - positions[0],
                    positions[0],
                    positions[positions.len() - 1]
                ),
            ));
        }
        let _ = writeln!(toml, "\n[motion.{}]", axis.name);
        let unit = if axis.kind == AxisKind::Linear {
            "mm"
        } else {
            "degrees"
        };
        let _ = writeln!(toml, "positions = {}   # {unit}", write_list(&positions));
        for m in list.iter() {
            let values = if m.positions == positions {
                m.values.clone()
            } else {
                notes.push(format!(
                    "{} (line {}) resampled onto the {} positions of axis {} that its error \
                     motions have together (linear interpolation: the same values)",
                    m.term,
                    m.line,
                    positions.len(),
                    axis.name
                ));
                resample(m, &positions, axis.kind == AxisKind::Rotary)
            };
            let _ = writeln!(
                toml,
                "{} = {}   # line {}",
                m.term,
                write_list(&values),
                m.line
            );
        }
    }
    // The file must load: a failure here is nccomp's bug, not the input's.
    error_file::parse(&toml, "<converted>", machine).map_err(|e| {
        Error::Usage(format!(
            "the converted error file does not load ({e}); this is a bug in nccomp, please \
             report it with the input file"
        ))
    })?;
    let summary = format!(
        "{path}: {} → {} position-independent term{} and {} error motion{}",
        format.name(),
        counts.0,
        if counts.0 == 1 { "" } else { "s" },
        counts.1,
        if counts.1 == 1 { "" } else { "s" },
    );
    Ok(Converted {
        format,
        toml,
        notes,
        summary,
    })
}

fn sorted(list: &[(String, usize, f64, usize)]) -> Vec<(String, usize, f64, usize)> {
    let mut v = list.to_vec();
    v.sort_by_key(|t| t.1);
    v
}

/// Checks the loader makes, made here so that the message points into the input.
fn check_series(
    term: &TermName,
    axis: &Axis,
    positions: &[f64],
    values: &[f64],
) -> Result<(), String> {
    if axis.kind == AxisKind::Rotary && positions.len() > 1 {
        let (first, last) = (positions[0], positions[positions.len() - 1]);
        if last - first > 360.0 {
            return Err(format!(
                "the positions of `{term}` span {}° (from {first} to {last}): expected at most \
                 360°, one revolution of rotary axis {}",
                last - first,
                axis.name
            ));
        }
        if last - first == 360.0 && values[0] != values[values.len() - 1] {
            return Err(format!(
                "`{term}` is {} at {last}° but {} at {first}°, the same angle of rotary axis {}: \
                 expected equal values",
                values[values.len() - 1],
                values[0],
                axis.name
            ));
        }
    }
    Ok(())
}

/// The positions of all series of an axis, in order, each once.
fn union(list: &[Motion]) -> Vec<f64> {
    let mut all: Vec<f64> = list
        .iter()
        .flat_map(|m| m.positions.iter().copied())
        .collect();
    all.sort_by(f64::total_cmp);
    all.dedup();
    all
}

/// A series at other positions, read as the error-file loader reads tables: linear between
/// entries, held beyond the ends (periodic over 360° for a rotary axis), so the values are
/// the same function.
fn resample(m: &Motion, positions: &[f64], periodic: bool) -> Vec<f64> {
    let mut values: [Option<Vec<f64>>; 6] = Default::default();
    values[0] = Some(m.values.clone());
    let table = MotionTable {
        positions: m.positions.clone(),
        values,
        periodic,
    };
    positions
        .iter()
        .map(|&x| table.sample(x).values[0])
        .collect()
}

/// A TOML float that reads back as the same f64 (shortest round-trip digits).
fn write_number(v: f64) -> String {
    let s = format!("{v}");
    if s.contains(['.', 'e', 'E', 'n', 'i']) {
        s
    } else {
        s + ".0"
    }
}

fn write_list(values: &[f64]) -> String {
    let words: Vec<String> = values.iter().map(|&v| write_number(v)).collect();
    if words.len() <= 8 {
        return format!("[{}]", words.join(", "));
    }
    let rows: Vec<String> = words
        .chunks(8)
        .map(|c| format!("    {},", c.join(", ")))
        .collect();
    format!("[\n{}\n]", rows.join("\n"))
}
