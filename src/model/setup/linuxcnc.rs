//! LinuxCNC's own tables as set-ups: the parameter file (`.var`) for the work offsets and
//! the tool table (`.tbl`) for the tool lengths.
//!
//! The parameter numbers are LinuxCNC's (`interp_parameter_def.hh`, "Named global
//! parameters used by the interpreter"): 5220 the coordinate system in force (1 = G54),
//! 5221–5230 G54's X Y Z A B C U V W and its XY rotation R, 5241–5250 G55, … every 20 up
//! to 5381–5390 G59.3; 5210 whether G92 is on and 5211–5219 its offsets. Both files are
//! in the machine's units (the INI's LINEAR_UNITS).

use super::{Given, Place, Setup, length};
use crate::Result;
use crate::model::WorkOffsets;
use std::collections::BTreeMap;

const G54_X: u32 = 5221;
const SYSTEMS: [&str; 9] = [
    "G54", "G55", "G56", "G57", "G58", "G59", "G59.1", "G59.2", "G59.3",
];
const AXES: [&str; 10] = ["X", "Y", "Z", "A", "B", "C", "U", "V", "W", "R"];

/// The work offsets of a LinuxCNC parameter file (`5221 -312.5` lines; other lines are
/// comments, as LinuxCNC reads them). Offsets of other axes than X, Y, Z, a rotation, a
/// G92 offset in force or a start in another system than G54 are refused at their line:
/// nccomp follows none of them.
pub fn parse_var(text: &str, path: &str, inch: bool) -> Result<Setup> {
    let scale = if inch { 25.4 } else { 1.0 };
    let mut values: BTreeMap<u32, (f64, Place)> = BTreeMap::new();
    let mut offset = 0;
    for line in text.split_inclusive('\n') {
        let start = offset;
        offset += line.len();
        let content = line.trim_end_matches(['\n', '\r']);
        let trimmed = content.trim_start();
        if !trimmed.starts_with(|c: char| c.is_ascii_digit()) {
            continue;
        }
        let at = |col: usize| Place::at(path, text, start + col);
        let lead = content.len() - trimmed.len();
        let mut fields = trimmed.split_whitespace();
        let (Some(n), value) = (fields.next(), fields.next()) else {
            continue;
        };
        let Ok(number) = n.parse::<u32>() else {
            return Err(at(lead).error(format!(
                "`{n}`: expected a parameter number (such as 5221) and its value"
            )));
        };
        let after = &trimmed[n.len()..];
        let value_col = lead + n.len() + after.find(value.unwrap_or("")).unwrap_or(after.len());
        let Some(v) = value.and_then(|v| v.parse::<f64>().ok().filter(|v| v.is_finite())) else {
            return Err(at(value_col).error(format!(
                "parameter {number}: expected a number after it, found `{}`",
                value.unwrap_or("")
            )));
        };
        if let Some(extra) = fields.next() {
            let col = lead + trimmed.rfind(extra).unwrap_or(0);
            return Err(at(col).error(format!(
                "`{extra}` after parameter {number}'s value: expected one number a line"
            )));
        }
        if let Some((_, first)) = values.get(&number) {
            return Err(at(lead).error(format!(
                "parameter {number} again (first at line {}): expected each parameter once",
                first.line
            )));
        }
        values.insert(number, (v, at(value_col)));
    }
    let mut setup = Setup::default();
    if let Some((v, from)) = values.get(&5220)
        && *v != 1.0
    {
        return Err(from.error(format!(
            "5220 is {v}: LinuxCNC starts in coordinate system {v}, and nccomp follows a program from G54 (expected 1, G54; set it on the control or start the program with its G code)"
        )));
    }
    if let Some((v, _)) = values.get(&5210)
        && *v != 0.0
    {
        for n in 5211..=5219 {
            if let Some((g, from)) = values.get(&n)
                && *g != 0.0
            {
                return Err(from.error(format!(
                    "parameter {n} is {g} with G92 on (5210 = {v}): nccomp does not follow G92 offsets (expected them cleared, G92.1)"
                )));
            }
        }
    }
    for (s, system) in SYSTEMS.iter().enumerate() {
        let base = G54_X + 20 * s as u32;
        let Some(code) = WorkOffsets::code(system) else {
            continue;
        };
        let mut xyz = [0.0; 3];
        let mut first: Option<&Place> = None;
        for (a, axis) in AXES.iter().enumerate() {
            let Some((v, from)) = values.get(&(base + a as u32)) else {
                continue;
            };
            if a >= 3 {
                if *v != 0.0 {
                    return Err(from.error(format!(
                        "{system} {axis} is {v} (parameter {}): nccomp follows work offsets of X, Y and Z only (expected 0)",
                        base + a as u32
                    )));
                }
                continue;
            }
            xyz[a] = length(v * scale, &format!("{system} {axis}"), from)?;
            first.get_or_insert(from);
        }
        if let Some(from) = first {
            setup.offsets.push(Given {
                key: code,
                value: xyz,
                from: from.clone(),
            });
        }
    }
    Ok(setup)
}

/// The tool lengths of a LinuxCNC tool table: `T1 P1 Z+50.000 D10 ;comment`, the length
/// the Z offset (0 when left out, as LinuxCNC takes it). An offset of another axis is
/// refused: nccomp's tools have a length only.
pub fn parse_tbl(text: &str, path: &str, inch: bool) -> Result<Setup> {
    let scale = if inch { 25.4 } else { 1.0 };
    let mut setup = Setup::default();
    let mut seen: BTreeMap<u32, usize> = BTreeMap::new();
    let mut offset = 0;
    for (i, line) in text.split_inclusive('\n').enumerate() {
        let start = offset;
        offset += line.len();
        let content = line.trim_end_matches(['\n', '\r']);
        let content = content.split(';').next().unwrap_or("");
        let at = |col: usize| Place::at(path, text, start + col);
        let mut tool: Option<(u32, Place)> = None;
        let mut z = 0.0;
        let mut words = 0;
        let mut col = 0;
        for word in content.split_whitespace() {
            col += content[col..].find(word).unwrap_or(0);
            let place = at(col);
            col += word.len();
            words += 1;
            let letter = word.as_bytes()[0].to_ascii_uppercase();
            let rest = &word[1..];
            let expected = "expected words such as T1 P1 Z+50.000 D10 (T, P, X, Y, Z, A, B, C, U, V, W, D, I, J, Q)";
            if !b"TPXYZABCUVWDIJQ".contains(&letter) {
                return Err(place.error(format!("`{word}`: {expected}")));
            }
            let Some(v) = rest.parse::<f64>().ok().filter(|v| v.is_finite()) else {
                return Err(place.error(format!(
                    "`{word}`: expected a number after {}",
                    letter as char
                )));
            };
            match letter {
                b'T' => {
                    if v < 0.0 || v.fract() != 0.0 || v > u32::MAX as f64 {
                        return Err(
                            place.error(format!("`{word}`: expected a tool number (T0, T1, ...)"))
                        );
                    }
                    tool = Some((v as u32, place));
                }
                b'Z' => z = length(v * scale, "a tool length (Z)", &place)?,
                b'X' | b'Y' | b'A' | b'B' | b'C' | b'U' | b'V' | b'W' if v != 0.0 => {
                    return Err(place.error(format!(
                        "`{word}`: an offset of {} in the tool table: nccomp follows a tool's length (Z) only (expected 0 or no {} word)",
                        letter as char, letter as char
                    )));
                }
                _ => {}
            }
        }
        if words == 0 {
            continue;
        }
        let Some((t, place)) = tool else {
            return Err(at(0).error(
                "a tool table line without a T word: expected `T<number>` on every line (such as T1 P1 Z+50.000)",
            ));
        };
        if let Some(first) = seen.insert(t, i + 1) {
            return Err(place.error(format!(
                "tool {t} again (first at line {first}): expected each tool once"
            )));
        }
        setup.lengths.push(Given {
            key: t,
            value: z,
            from: place,
        });
    }
    Ok(setup)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn var_offsets_by_linuxcnc_numbers() {
        let text = "5161\t0.0\n5220\t1.000000\n5221\t-312.500000\n5222\t-180.0\n5223\t-402.1\n5224\t0\n5241\t-100\n5242\t0\n5243\t0\n";
        let s = parse_var(text, "emc.var", false).unwrap();
        assert_eq!(s.offsets.len(), 2);
        assert_eq!(s.offsets[0].key, 540);
        assert_eq!(s.offsets[0].value, [-312.5, -180.0, -402.1]);
        assert_eq!(s.offsets[0].from.line, 3);
        assert_eq!(s.offsets[1].key, 550);
        let inch = parse_var("5221 1.0\n", "emc.var", true).unwrap();
        assert_eq!(inch.offsets[0].value, [25.4, 0.0, 0.0]);
    }

    #[test]
    fn var_refusals_are_located() {
        let cases = [
            (
                "5221 -1\n5221 -2\n",
                "emc.var:2:1",
                "again (first at line 1)",
            ),
            ("5221 abc\n", "emc.var:1:6", "expected a number"),
            ("5221 1 2\n", "emc.var:1:8", "expected one number a line"),
            ("5226 90\n", "emc.var:1:6", "X, Y and Z only"),
            ("5230 15\n", "emc.var:1:6", "G54 R is 15"),
            ("5220 2\n", "emc.var:1:6", "starts in coordinate system 2"),
            ("5210 1\n5211 4\n", "emc.var:2:6", "G92 offsets"),
            ("5221 1e300\n", "emc.var:1:6", "within ±100000 mm"),
        ];
        for (text, at, what) in cases {
            let e = parse_var(text, "emc.var", false).unwrap_err().to_string();
            assert!(e.contains(at) && e.contains(what), "{text:?}: {e}");
        }
        // Comments and the G92 values with G92 off pass.
        assert!(parse_var("# saved\n5210 0\n5211 4\n", "emc.var", false).is_ok());
    }

    #[test]
    fn tbl_lengths_by_tool() {
        let text = "T1 P1 Z+50.000 D10 ;end mill\n\n;only a comment\nT2 P2 D6 Z-0.5\nT3 P3 X0 D1\n";
        let s = parse_tbl(text, "tool.tbl", false).unwrap();
        let lengths: Vec<(u32, f64, usize)> = s
            .lengths
            .iter()
            .map(|g| (g.key, g.value, g.from.line))
            .collect();
        assert_eq!(lengths, [(1, 50.0, 1), (2, -0.5, 4), (3, 0.0, 5)]);
        let inch = parse_tbl("T1 Z2\n", "tool.tbl", true).unwrap();
        assert_eq!(inch.lengths[0].value, 50.8);
    }

    #[test]
    fn tbl_refusals_are_located() {
        let cases = [
            ("T1 P1 Z+50 K3\n", "tool.tbl:1:12", "`K3`"),
            ("T1 Zabc\n", "tool.tbl:1:4", "a number after Z"),
            ("P1 Z50\n", "tool.tbl:1:1", "without a T word"),
            ("T1 Z1\nT1 Z2\n", "tool.tbl:2:1", "tool 1 again"),
            ("T1.5 Z1\n", "tool.tbl:1:1", "a tool number"),
            ("T4 X2.5 Z1\n", "tool.tbl:1:4", "length (Z) only"),
        ];
        for (text, at, what) in cases {
            let e = parse_tbl(text, "tool.tbl", false).unwrap_err().to_string();
            assert!(e.contains(at) && e.contains(what), "{text:?}: {e}");
        }
    }
}
