//! Heidenhain's tables as set-ups: the tool table `TOOL.T` and the preset table
//! `PRESET.PR`.
//!
//! Both are the control's fixed-width tables: a first line `BEGIN TOOL.T MM` (or `INCH`),
//! a line of column names, one row a line under them (each value where its column's name
//! starts), and `[END]`. In TOOL.T a tool's length is L, "with respect to the tool
//! carrier reference point", plus DL, its oversize, which "is added to the parameter L";
//! T is the tool number (an index after a period names an indexed tool) and NAME the name
//! a TOOL CALL may use (HEIDENHAIN TNC7 User's Manual 81762x-17, "Tool table tool.t").
//! In PRESET.PR a row (NO, or NR on older controls) gives a preset's X, Y, Z in the basic
//! coordinate system B-CS, with a basic rotation (ROT), a spatial rotation (SPA, SPB, SPC)
//! and rotary-axis presets beside them (ibid., "Preset table"); the B-CS origin is the
//! machine builder's (the rotary table's centre on many table machines: iTNC 530 User's
//! Manual, "Explanation of values saved in the preset table"), so the set-up file says
//! where it lies.

use super::{Given, Place, Setup, length, number};
use crate::Result;

/// A table's columns: each name and the byte its values start at.
struct Columns {
    names: Vec<(String, usize)>,
}

impl Columns {
    fn parse(line: &str) -> Columns {
        let mut names = Vec::new();
        let mut at = 0;
        for word in line.split_whitespace() {
            at += line[at..].find(word).unwrap_or(0);
            names.push((word.to_ascii_uppercase(), at));
            at += word.len();
        }
        Columns { names }
    }

    fn index(&self, name: &str) -> Option<usize> {
        self.names.iter().position(|(n, _)| n == name)
    }

    /// The value of column `i` in `row` (trimmed) and its byte in the row; `None` where the
    /// row does not split at the columns' places (a name or number out of its column).
    fn cell<'r>(&self, row: &'r str, i: usize) -> Option<(&'r str, usize)> {
        let start = self.names[i].1.min(row.len());
        let end = self
            .names
            .get(i + 1)
            .map_or(row.len(), |(_, s)| (*s).min(row.len()));
        let cell = row.get(start..end)?;
        let lead = cell.len() - cell.trim_start().len();
        Some((cell.trim(), start + lead))
    }
}

/// A table's text: its unit scale (mm), columns and rows (each with its byte offset).
struct Table<'t> {
    scale: f64,
    columns: Columns,
    rows: Vec<(&'t str, usize)>,
}

fn table<'t>(text: &'t str, path: &str, name: &str) -> Result<Table<'t>> {
    let mut lines = Vec::new();
    let mut offset = 0;
    for line in text.split_inclusive('\n') {
        lines.push((line.trim_end_matches(['\n', '\r']), offset));
        offset += line.len();
    }
    let expected = format!(
        "expected `BEGIN {name} MM` (or INCH) on the first line, as the control writes the table"
    );
    let Some(&(first, _)) = lines.first() else {
        return Err(Place::at(path, text, 0).error(format!("an empty file: {expected}")));
    };
    let words: Vec<&str> = first.split_whitespace().collect();
    if words.len() < 2
        || !words[0].eq_ignore_ascii_case("BEGIN")
        || !words[1].eq_ignore_ascii_case(name)
    {
        return Err(Place::at(path, text, 0).error(format!("`{}`: {expected}", first.trim())));
    }
    let scale = match words.get(2).map(|w| w.to_ascii_uppercase()) {
        Some(u) if u == "MM" => 1.0,
        Some(u) if u == "INCH" => 25.4,
        _ => {
            let at = first
                .len()
                .min(first.find(words[1]).unwrap_or(0) + words[1].len() + 1);
            return Err(Place::at(path, text, at).error(format!(
                "the table's unit: {expected} (its values are in that unit)"
            )));
        }
    };
    let Some(&(header, _)) = lines.get(1) else {
        return Err(Place::at(path, text, text.len()).error(format!(
            "no column names after `{}`: expected the line of column names the control writes",
            first.trim()
        )));
    };
    let columns = Columns::parse(header);
    let mut rows = Vec::new();
    let mut ended = false;
    for &(line, at) in &lines[2..] {
        if line.trim().eq_ignore_ascii_case("[END]") {
            ended = true;
            break;
        }
        if !line.trim().is_empty() {
            rows.push((line, at));
        }
    }
    if !ended {
        return Err(Place::at(path, text, text.len()).error(
            "the table ends without `[END]`: expected the last line `[END]` (a table cut short is not read)",
        ));
    }
    Ok(Table {
        scale,
        columns,
        rows,
    })
}

fn column(table: &Table, text: &str, path: &str, names: &[&str]) -> Result<usize> {
    names
        .iter()
        .find_map(|n| table.columns.index(n))
        .ok_or_else(|| {
            let header_at = text.find('\n').map_or(0, |n| n + 1);
            Place::at(path, text, header_at).error(format!(
                "no column {}: expected it among the column names",
                names.join(" or ")
            ))
        })
}

/// A cell of `row` in column `i`, and its place.
fn cell<'r>(
    table: &Table,
    text: &str,
    path: &str,
    (row, at): (&'r str, usize),
    i: usize,
) -> Result<(&'r str, Place)> {
    match table.columns.cell(row, i) {
        Some((v, col)) => Ok((v, Place::at(path, text, at + col))),
        None => Err(Place::at(path, text, at).error(format!(
            "the row does not split at the columns' places (column {}): expected each value under its column's name",
            table.columns.names[i].0
        ))),
    }
}

/// The tool lengths of a Heidenhain TOOL.T: by number and, where a row has a NAME, by
/// name; each L + DL. Indexed tools (`1.1`) are left out: no program word of nccomp's
/// selects them, so a call of one is refused as a tool without a length.
pub fn parse_tool_t(text: &str, path: &str) -> Result<Setup> {
    let table = table(text, path, "TOOL.T")?;
    let t = column(&table, text, path, &["T"])?;
    let l = column(&table, text, path, &["L"])?;
    let name = table.columns.index("NAME");
    let dl = table.columns.index("DL");
    let mut setup = Setup::default();
    for &row in &table.rows {
        let (number, from) = cell(&table, text, path, row, t)?;
        if number.contains('.')
            && number
                .split('.')
                .all(|p| p.bytes().all(|b| b.is_ascii_digit()) && !p.is_empty())
        {
            continue;
        }
        let Ok(number) = number.parse::<u32>() else {
            return Err(from.error(format!(
                "`{number}` in column T: expected a tool number (0 … 32767)"
            )));
        };
        let (l_text, l_at) = cell(&table, text, path, row, l)?;
        let Some(base) = number_of(l_text) else {
            return Err(l_at.error(format!(
                "`{l_text}` in column L of tool {number}: expected its length, a number such as +95.3"
            )));
        };
        let oversize = match dl {
            Some(i) => {
                let (d, at) = cell(&table, text, path, row, i)?;
                if d.is_empty() {
                    0.0
                } else {
                    number_of(d).ok_or_else(|| {
                        at.error(format!(
                            "`{d}` in column DL of tool {number}: expected a number such as +0.02, or nothing"
                        ))
                    })?
                }
            }
            None => 0.0,
        };
        let value = length(
            (base + oversize) * table.scale,
            &format!("the length of tool {number} (L + DL)"),
            &l_at,
        )?;
        setup.lengths.push(Given {
            key: number,
            value,
            from: from.clone(),
        });
        if let Some(i) = name {
            let (n, _) = cell(&table, text, path, row, i)?;
            if !n.is_empty() {
                setup.named_lengths.push(Given {
                    key: n.to_string(),
                    value,
                    from,
                });
            }
        }
    }
    Ok(setup)
}

/// The preset in row `row` of a Heidenhain PRESET.PR as the G54 the program runs in:
/// its X, Y, Z plus `basis`, the B-CS origin in machine coordinates. A rotation, a
/// rotary-axis preset or an axis offset other than 0 is refused at its cell: nccomp
/// follows a translation of program zero only.
pub fn parse_preset_pr(text: &str, path: &str, row: u64, basis: [f64; 3]) -> Result<Setup> {
    let table = table(text, path, "PRESET.PR")?;
    let nr = column(&table, text, path, &["NO", "NR"])?;
    let mut found = None;
    for &r in &table.rows {
        let (n, from) = cell(&table, text, path, r, nr)?;
        if n.parse::<u64>().ok() == Some(row) {
            found = Some((r, from));
            break;
        }
    }
    let Some((r, from)) = found else {
        let header_at = text.find('\n').map_or(0, |n| n + 1);
        return Err(Place::at(path, text, header_at).error(format!(
            "no row {row} in the preset table: expected the row the set-up's `preset` names"
        )));
    };
    let mut xyz = [0.0; 3];
    for (c, axis) in ["X", "Y", "Z"].iter().enumerate() {
        let i = column(&table, text, path, &[axis])?;
        let (v, at) = cell(&table, text, path, r, i)?;
        let Some(v) = number_of(v) else {
            return Err(at.error(format!(
                "`{v}` in column {axis} of preset {row}: expected the preset's {axis}, a number"
            )));
        };
        xyz[c] = length(
            v * table.scale + basis[c],
            &format!("{axis} of preset {row}"),
            &at,
        )?;
    }
    for (i, (name, _)) in table.columns.names.iter().enumerate() {
        let turns = ["ROT", "SPA", "SPB", "SPC", "A", "B", "C", "U", "V", "W"]
            .contains(&name.as_str())
            || name.ends_with("_OFFS");
        if !turns {
            continue;
        }
        let (v, at) = cell(&table, text, path, r, i)?;
        if v.is_empty() || number_of(v) == Some(0.0) {
            continue;
        }
        return Err(at.error(format!(
            "{name} of preset {row} is {v}: nccomp follows a preset's X, Y and Z only (a rotation, a rotary axis's preset or an axis offset is not followed; expected 0)"
        )));
    }
    Ok(Setup {
        offsets: vec![Given {
            key: 540,
            value: xyz,
            from,
        }],
        ..Setup::default()
    })
}

fn number_of(text: &str) -> Option<f64> {
    number(text)
}

#[cfg(test)]
mod tests {
    use super::*;

    const TOOL_T: &str = "BEGIN TOOL.T MM
T      NAME                 L          R        DL       DR
0      NULLTOOL             +0         +0       +0       +0
1      MILL_D10             +95.3      +5       +0.02    +0
1.1    MILL_D10_B           +96        +5       +0       +0
7                           +120.25    +3                +0
[END]
";

    #[test]
    fn tool_t_lengths_are_l_plus_dl_by_number_and_name() {
        let s = parse_tool_t(TOOL_T, "TOOL.T").unwrap();
        let lengths: Vec<(u32, f64, usize)> = s
            .lengths
            .iter()
            .map(|g| (g.key, g.value, g.from.line))
            .collect();
        assert_eq!(lengths, [(0, 0.0, 3), (1, 95.32, 4), (7, 120.25, 6)]);
        let names: Vec<&str> = s.named_lengths.iter().map(|g| g.key.as_str()).collect();
        assert_eq!(names, ["NULLTOOL", "MILL_D10"]);
        let inch = parse_tool_t(&TOOL_T.replace("MM", "INCH"), "TOOL.T").unwrap();
        assert!((inch.lengths[2].value - 120.25 * 25.4).abs() < 1e-9);
    }

    #[test]
    fn tool_t_refusals_are_located() {
        let cases = [
            (
                TOOL_T.replace("BEGIN TOOL.T MM", "BEGIN TOOL.X MM"),
                "TOOL.T:1:1",
                "expected `BEGIN TOOL.T MM`",
            ),
            (
                TOOL_T.replace("BEGIN TOOL.T MM", "BEGIN TOOL.T CM"),
                "TOOL.T:1:14",
                "the table's unit",
            ),
            (
                TOOL_T.replace("[END]\n", ""),
                "TOOL.T:7:1",
                "without `[END]`",
            ),
            (
                TOOL_T.replace("+120.25", "+12O.25"),
                "TOOL.T:6:29",
                "column L of tool 7",
            ),
            (
                TOOL_T.replace("+0.02", "+0.0x"),
                "TOOL.T:4:49",
                "column DL of tool 1",
            ),
            (
                TOOL_T.replace("\n7     ", "\nT7    "),
                "TOOL.T:6:1",
                "column T",
            ),
            (
                TOOL_T.replace("L          R", "LEN        R"),
                "TOOL.T:2:1",
                "no column L",
            ),
        ];
        for (text, at, what) in cases {
            let e = parse_tool_t(&text, "TOOL.T").unwrap_err().to_string();
            assert!(e.contains(at) && e.contains(what), "{at}: {e}");
        }
    }

    const PRESET_PR: &str = "BEGIN PRESET.PR MM
NR   DOC          ROT      X          Y          Z          SPC      C
0                 +0       +0         +0         +0         +0       +0
3    JOB 4711     +0       -312.5     -180       -402.1     +0       +0
4                 +1.5     -10        -10        -10        +0       +0
[END]
";

    #[test]
    fn a_preset_row_is_g54_from_the_basis() {
        let s = parse_preset_pr(PRESET_PR, "PRESET.PR", 3, [0.0, 0.0, 10.0]).unwrap();
        assert_eq!(s.offsets.len(), 1);
        assert_eq!(s.offsets[0].key, 540);
        assert_eq!(s.offsets[0].value, [-312.5, -180.0, -392.1]);
        assert_eq!(s.offsets[0].from.line, 4);
    }

    #[test]
    fn preset_refusals_are_located() {
        let e = parse_preset_pr(PRESET_PR, "PRESET.PR", 4, [0.0; 3])
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("PRESET.PR:5:19") && e.contains("ROT of preset 4 is +1.5"),
            "{e}"
        );
        let e = parse_preset_pr(PRESET_PR, "PRESET.PR", 9, [0.0; 3])
            .unwrap_err()
            .to_string();
        assert!(e.contains("PRESET.PR:2:1") && e.contains("no row 9"), "{e}");
        // A TNC7 table numbers its rows in NO; an axis offset is refused like a rotation.
        let tnc7 = "BEGIN PRESET.PR MM\nNO   X      Y      Z      X_OFFS\n1    -1     -2     -3     +0.5\n[END]\n";
        let e = parse_preset_pr(tnc7, "PRESET.PR", 1, [0.0; 3])
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("PRESET.PR:3:27") && e.contains("X_OFFS of preset 1"),
            "{e}"
        );
        let ok = parse_preset_pr(&tnc7.replace("+0.5", "+0  "), "PRESET.PR", 1, [0.0; 3]).unwrap();
        assert_eq!(ok.offsets[0].value, [-1.0, -2.0, -3.0]);
        let text = PRESET_PR.replace("-180  ", "?     ");
        let e = parse_preset_pr(&text, "PRESET.PR", 3, [0.0; 3])
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("PRESET.PR:4:39") && e.contains("column Y of preset 3"),
            "{e}"
        );
    }
}
