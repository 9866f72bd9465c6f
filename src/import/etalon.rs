//! The Etalon exchange format ("Vendor" variant), as ISG's kernel documentation ("Etalon
//! Exchange Format", TF5280 Volumetric Compensation) describes it: INI-like, one section
//! per parameter, named in square brackets. A position error has `VALUE = number`; a
//! component error has a lookup table `Gridpoints = { ... }`, one record per line, each
//! the axis position and the value. `//` starts a comment. Values are mm and rad, axis
//! positions mm or degrees.
//!
//! The description's comment calls the records "Parameter argument", but its numbers
//! (−280, −270, … against values of a few µm) are argument first; nccomp reads the first
//! number of a record as the axis position and requires it to increase.

use super::{Data, Entry, number};
use crate::model::terms;
use crate::{Error, Result};

/// A section being read: its name, where the name is, and what it has so far.
struct Section<'t> {
    name: &'t str,
    offset: usize,
    constant: bool,
    data: Option<Data>,
}

/// The entries of the Etalon exchange file `text`.
pub fn read(text: &str, path: &str) -> Result<Vec<Entry>> {
    let at = |offset: usize, message: String| Error::at(path, text.as_bytes(), offset, message);
    let mut entries: Vec<Entry> = Vec::new();
    let mut section: Option<Section> = None;
    // Inside `Gridpoints = {`: where the brace is, the records so far.
    let mut grid: Option<(usize, Vec<f64>, Vec<f64>)> = None;
    let mut start = 0;
    let finish = |s: Section, entries: &mut Vec<Entry>| -> Result<()> {
        let Some(data) = s.data else {
            let want = if s.constant {
                "`VALUE = number`"
            } else {
                "`Gridpoints = { ... }`"
            };
            return Err(at(
                s.offset,
                format!("section [{}] has no value: expected {want} in it", s.name),
            ));
        };
        entries.push(Entry {
            name: s.name.to_string(),
            offset: s.offset,
            data,
        });
        Ok(())
    };
    for line in text.split_inclusive('\n') {
        let offset = start;
        start += line.len();
        let content = line.split("//").next().unwrap_or("");
        let body = content.trim();
        if body.is_empty() {
            continue;
        }
        // Every slice below is part of `line`: its place in the file.
        let pos = |part: &str| offset + (part.as_ptr() as usize - line.as_ptr() as usize);
        let lead = pos(body);
        if let Some((_, positions, values)) = &mut grid {
            let (records, rest) = match body.split_once('}') {
                Some((records, rest)) => (records, Some(rest.trim())),
                None => (body, None),
            };
            let words: Vec<&str> = records.split_whitespace().collect();
            if !words.is_empty() {
                if words.len() != 2 {
                    return Err(at(
                        pos(words.get(2).unwrap_or(&words[0])),
                        format!(
                            "{} number{} in this record: expected two, the axis position and the \
                             value",
                            words.len(),
                            if words.len() == 1 { "" } else { "s" }
                        ),
                    ));
                }
                let mut pair = [0.0; 2];
                for (k, w) in words.iter().enumerate() {
                    pair[k] = number(w).ok_or_else(|| {
                        at(
                            pos(w),
                            format!(
                                "`{w}` is not a number: expected {}",
                                if k == 0 {
                                    "the axis position (mm or degrees)"
                                } else {
                                    "the value (mm for lengths, rad for angles)"
                                }
                            ),
                        )
                    })?;
                }
                if let Some(&last) = positions.last()
                    && pair[0] <= last
                {
                    return Err(at(
                        pos(words[0]),
                        format!(
                            "position {} follows {last}: expected the first number of each \
                             record, the axis position, to increase strictly",
                            pair[0]
                        ),
                    ));
                }
                positions.push(pair[0]);
                values.push(pair[1]);
            }
            if let Some(rest) = rest {
                if !rest.is_empty() {
                    return Err(at(
                        pos(rest),
                        format!("`{rest}` after `}}`: expected the end of the line"),
                    ));
                }
                let (brace, positions, values) = grid.take().unwrap_or_default();
                if positions.is_empty() {
                    return Err(at(
                        brace,
                        "an empty Gridpoints list: expected records `position value`".into(),
                    ));
                }
                if let Some(s) = &mut section {
                    s.data = Some(Data::Series { positions, values });
                }
            }
            continue;
        }
        if let Some(inner) = body.strip_prefix('[') {
            let Some(name) = inner.strip_suffix(']') else {
                return Err(at(
                    lead + body.len(),
                    "a section header without `]`: expected `[NAME]`".into(),
                ));
            };
            let name = name.trim();
            let name_offset = pos(name);
            if let Some(s) = section.take() {
                finish(s, &mut entries)?;
            }
            let Some(term) = terms::parse_field(name) else {
                return Err(at(
                    name_offset,
                    format!(
                        "unknown section [{name}]: expected an error parameter, a position error \
                         such as [C0B] or a component error such as [EXY]"
                    ),
                ));
            };
            section = Some(Section {
                name,
                offset: name_offset,
                constant: term.constant,
                data: None,
            });
            continue;
        }
        let Some(s) = &mut section else {
            return Err(at(
                lead,
                "text before the first section: expected a section header such as [C0B]".into(),
            ));
        };
        let Some((key, value)) = body.split_once('=') else {
            return Err(at(
                lead,
                format!(
                    "expected `KEY = value` in section [{}] (VALUE or Gridpoints)",
                    s.name
                ),
            ));
        };
        let key = key.trim();
        let value = value.trim();
        let value_offset = pos(value);
        if s.data.is_some() {
            return Err(at(
                lead,
                format!(
                    "section [{}] has its value already: expected one VALUE or Gridpoints",
                    s.name
                ),
            ));
        }
        match (key.to_ascii_lowercase().as_str(), s.constant) {
            ("value", true) => {
                let v = number(value).ok_or_else(|| {
                    at(
                        value_offset,
                        format!(
                            "`{value}` is not a number: expected the value of {} (mm for lengths, \
                             rad for angles)",
                            s.name
                        ),
                    )
                })?;
                s.data = Some(Data::Constant(v));
            }
            ("gridpoints", false) => {
                let Some(rest) = value.strip_prefix('{') else {
                    return Err(at(
                        value_offset,
                        "expected `{` to open the Gridpoints list".into(),
                    ));
                };
                if !rest.trim().is_empty() {
                    return Err(at(
                        value_offset + 1,
                        "expected the records of the Gridpoints list on the lines after `{`".into(),
                    ));
                }
                grid = Some((value_offset, Vec::new(), Vec::new()));
            }
            ("value", false) => {
                return Err(at(
                    lead,
                    format!(
                        "[{}] is a component error, a function of the axis position: expected \
                         `Gridpoints = {{ ... }}`, not a single VALUE",
                        s.name
                    ),
                ));
            }
            ("gridpoints", true) => {
                return Err(at(
                    lead,
                    format!(
                        "[{}] is a position error, one value: expected `VALUE = number`, not a \
                         Gridpoints table",
                        s.name
                    ),
                ));
            }
            _ => {
                return Err(at(
                    lead,
                    format!(
                        "unknown key `{key}` in section [{}]: expected `{}`",
                        s.name,
                        if s.constant {
                            "VALUE = number"
                        } else {
                            "Gridpoints = { ... }"
                        }
                    ),
                ));
            }
        }
    }
    if let Some((brace, _, _)) = grid {
        return Err(at(
            brace,
            "this Gridpoints list is not closed: expected `}` after its records".into(),
        ));
    }
    if let Some(s) = section.take() {
        finish(s, &mut entries)?;
    }
    if entries.is_empty() {
        return Err(at(
            0,
            "the file holds no section: expected sections such as [C0B] with `VALUE = ...`".into(),
        ));
    }
    Ok(entries)
}
