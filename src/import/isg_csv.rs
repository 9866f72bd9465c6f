//! Beckhoff/ISG `ISG_CSV` volumetric compensation tables.
//!
//! As ISG's kernel documentation ("ISG CSV format", TF5280 Volumetric Compensation)
//! describes them: a header row names the columns, the rows below hold the records;
//! `//` starts a comment; a line starting with `#` is a "file break" after which a new
//! header and its records follow. A header holds argument names (axis positions: X, Y, Z
//! in mm, A, B, C in degrees) and parameter names: position errors such as `C0Y` or `X0B`
//! (one row, no argument) or component errors such as `EXX` (against the argument of
//! their own axis). Values are mm and rad. Columns are separated by blanks or tabs (commas
//! and semicolons are taken as separators too).
//!
//! nccomp's error motions depend on their own axis only, so a block has at most one
//! argument; the functional dependencies ISG allows beyond that (EXX against Z and X) are
//! refused with a message.

use super::{Data, Entry, number};
use crate::model::terms;
use crate::{Error, Result};

/// A word of a line and its byte offset in the file.
#[derive(Debug, Clone, Copy)]
struct Word<'t> {
    text: &'t str,
    offset: usize,
}

/// ISG's kinematic parameters: machine geometry, not errors.
fn kinematic_parameter(name: &str) -> Option<&'static str> {
    let b = name.as_bytes();
    let xyz = |c: u8| matches!(c, b'X' | b'Y' | b'Z');
    let any = |c: u8| matches!(c, b'X' | b'Y' | b'Z' | b'A' | b'B' | b'C');
    match b {
        [b'P', b'0', c] if xyz(*c) => Some("the zero position of the tool"),
        [b'N', b'0', c] if xyz(*c) => Some("the zero orientation of the tool"),
        [b'P', c, r] if xyz(*c) && matches!(r, b'A' | b'B' | b'C') => {
            Some("the centre of rotation of a rotary axis")
        }
        [b'V', c, a] if xyz(*c) && any(*a) => Some("a modified orientation of an axis"),
        [b'I', b'D', a] if any(*a) => Some("an additive offset to the programmed axis value"),
        _ => None,
    }
}

fn is_logical_axis_number(name: &str) -> bool {
    matches!(name.as_bytes(), [b'L', b'N', a] if b"XYZABC".contains(a))
}

/// The words of `line` (starting at byte `start` of the file), comment removed.
fn words(line: &str, start: usize) -> Vec<Word<'_>> {
    let content = line.split("//").next().unwrap_or("");
    let mut out = Vec::new();
    let mut begin = None;
    for (k, c) in content.char_indices().chain([(content.len(), ' ')]) {
        let sep = c.is_whitespace() || c == ',' || c == ';';
        match (sep, begin) {
            (false, None) => begin = Some(k),
            (true, Some(b)) => {
                out.push(Word {
                    text: &content[b..k],
                    offset: start + b,
                });
                begin = None;
            }
            _ => {}
        }
    }
    out
}

/// A header and the rows below it, each its words.
struct Block<'t> {
    header: Vec<Word<'t>>,
    rows: Vec<Vec<Word<'t>>>,
}

/// What a header column is.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Column<'t> {
    Argument(&'t str),
    Parameter { constant: bool, axis: &'t str },
    Ignored,
}

/// The entries of the ISG CSV file `text`.
pub fn read(text: &str, path: &str) -> Result<Vec<Entry>> {
    let at = |offset: usize, message: String| Error::at(path, text.as_bytes(), offset, message);
    let mut blocks: Vec<Block> = Vec::new();
    let mut open = false;
    let mut start = 0;
    for line in text.split_inclusive('\n') {
        let offset = start;
        start += line.len();
        let trimmed = line.trim_start();
        if trimmed.starts_with('#') {
            open = false;
            continue;
        }
        let w = words(line, offset);
        if w.is_empty() {
            continue;
        }
        if open {
            if let Some(block) = blocks.last_mut() {
                block.rows.push(w);
            }
        } else {
            blocks.push(Block {
                header: w,
                rows: Vec::new(),
            });
            open = true;
        }
    }
    if blocks.is_empty() {
        return Err(at(
            0,
            "the file holds no table: expected a header row such as `X EXX EYX EZX` and rows of \
             numbers below it"
                .into(),
        ));
    }
    let mut entries = Vec::new();
    for b in &blocks {
        block(&b.header, &b.rows, text, &at, &mut entries)?;
    }
    Ok(entries)
}

fn block(
    header: &[Word],
    rows: &[Vec<Word>],
    text: &str,
    at: &dyn Fn(usize, String) -> Error,
    entries: &mut Vec<Entry>,
) -> Result<()> {
    let mut columns = Vec::with_capacity(header.len());
    for w in header {
        let column = if terms::is_axis_name(w.text) && w.text.len() == 1 {
            Column::Argument(w.text)
        } else if let Some(t) = terms::parse_field(w.text) {
            Column::Parameter {
                constant: t.constant,
                axis: t.axis,
            }
        } else if is_logical_axis_number(w.text) {
            Column::Ignored
        } else if let Some(what) = kinematic_parameter(w.text) {
            return Err(at(
                w.offset,
                format!(
                    "`{}` is an ISG kinematic parameter ({what}): that is the machine's geometry, \
                     which nccomp takes from the machine file; expected error parameters only \
                     (remove this column)",
                    w.text
                ),
            ));
        } else if number(w.text).is_some() {
            return Err(at(
                w.offset,
                "a number where the header was expected: a table starts with a header row \
                 naming its columns (e.g. `X EXX EYX`)"
                    .into(),
            ));
        } else {
            let hint = match terms::suggest(w.text, ["EXX", "EYX", "EZX", "EAX", "EBX", "ECX"]) {
                Some(s) => format!("did you mean `{s}`? "),
                None => String::new(),
            };
            return Err(at(
                w.offset,
                format!(
                    "unknown column `{}`: {hint}expected an argument (an axis: X, Y, Z, A, B, C) \
                     or an error parameter (a component error such as EXX or EYC, a position \
                     error such as C0Y or X0B)",
                    w.text
                ),
            ));
        };
        columns.push(column);
    }
    let arguments: Vec<usize> = (0..columns.len())
        .filter(|&k| matches!(columns[k], Column::Argument(_)))
        .collect();
    if arguments.len() > 1 {
        let w = header[arguments[1]];
        return Err(at(
            w.offset,
            format!(
                "a second argument `{}`: nccomp's error motions depend on their own axis only, \
                 so a table has at most one argument column (tables against two or more axes, \
                 such as sag against Z, cannot be converted)",
                w.text
            ),
        ));
    }
    let argument = arguments.first().map(|&k| (k, header[k].text));
    for (k, column) in columns.iter().enumerate() {
        let Column::Parameter { constant, axis } = *column else {
            continue;
        };
        let w = header[k];
        match (constant, argument) {
            (true, Some((_, arg))) => {
                return Err(at(
                    w.offset,
                    format!(
                        "`{}` is a position error, one value: it cannot depend on {arg}; expected \
                         it in a table without an argument column (a header of position errors \
                         and one row)",
                        w.text
                    ),
                ));
            }
            (false, None) => {
                return Err(at(
                    w.offset,
                    format!(
                        "`{}` is a component error, a function of the position of axis {axis}: \
                         expected the argument column {axis} in this header",
                        w.text
                    ),
                ));
            }
            (false, Some((_, arg))) if arg != axis => {
                return Err(at(
                    w.offset,
                    format!(
                        "`{}` is a function of the position of axis {axis}, but this table's \
                         argument is {arg}: expected component errors of axis {arg} (E…{arg}) \
                         only",
                        w.text
                    ),
                ));
            }
            _ => {}
        }
    }
    if !columns
        .iter()
        .any(|c| matches!(c, Column::Parameter { .. }))
    {
        return Err(at(
            header[0].offset,
            "this header names no error parameter: expected e.g. `X EXX EYX` or `C0Y X0B`".into(),
        ));
    }
    // The numbers, row by row.
    let end_of_header = header[header.len() - 1].offset + header[header.len() - 1].text.len();
    if rows.is_empty() {
        return Err(at(
            end_of_header,
            "a header without rows: expected rows of numbers below it".into(),
        ));
    }
    let mut table: Vec<Vec<f64>> = Vec::with_capacity(rows.len());
    for row in rows {
        if row.len() != header.len() {
            let place = row.get(header.len()).map_or_else(
                || {
                    let last = row[row.len() - 1];
                    last.offset + last.text.len()
                },
                |w| w.offset,
            );
            return Err(at(
                place,
                format!(
                    "{} value{} in this row: expected {}, one per column of the header `{}` \
                     (line {})",
                    row.len(),
                    if row.len() == 1 { "" } else { "s" },
                    header.len(),
                    header.iter().map(|w| w.text).collect::<Vec<_>>().join(" "),
                    crate::Diagnostic::at("", text.as_bytes(), header[0].offset, "").line
                ),
            ));
        }
        let mut values = Vec::with_capacity(row.len());
        for (k, w) in row.iter().enumerate() {
            let v = number(w.text).ok_or_else(|| {
                at(
                    w.offset,
                    format!(
                        "`{}` is not a number: expected the value of `{}` ({})",
                        w.text,
                        header[k].text,
                        match columns[k] {
                            Column::Argument(_) => "an axis position in mm or degrees",
                            _ => "mm for lengths, rad for angles",
                        }
                    ),
                )
            })?;
            values.push(v);
        }
        table.push(values);
    }
    match argument {
        None => {
            if rows.len() > 1 {
                return Err(at(
                    rows[1][0].offset,
                    "a second row of position errors: they are constants, so a table without \
                     an argument column has one row"
                        .into(),
                ));
            }
            for (k, w) in header.iter().enumerate() {
                if matches!(columns[k], Column::Parameter { .. }) {
                    entries.push(Entry {
                        name: w.text.to_string(),
                        offset: w.offset,
                        data: Data::Constant(table[0][k]),
                    });
                }
            }
        }
        Some((a, name)) => {
            for r in 1..rows.len() {
                if table[r][a] <= table[r - 1][a] {
                    return Err(at(
                        rows[r][a].offset,
                        format!(
                            "{name} = {} follows {name} = {}: expected the argument to increase \
                             strictly from row to row",
                            table[r][a],
                            table[r - 1][a]
                        ),
                    ));
                }
            }
            let positions: Vec<f64> = table.iter().map(|r| r[a]).collect();
            for (k, w) in header.iter().enumerate() {
                if matches!(columns[k], Column::Parameter { .. }) {
                    entries.push(Entry {
                        name: w.text.to_string(),
                        offset: w.offset,
                        data: Data::Series {
                            positions: positions.clone(),
                            values: table.iter().map(|r| r[k]).collect(),
                        },
                    });
                }
            }
        }
    }
    Ok(())
}
