//! Is a committed compensated program what nccomp writes now? (`nccomp compensate
//! --check`, the way `rustfmt --check` works.)

use similar::TextDiff;
use std::fmt::Write;

/// Hunks of the diff shown; the rest are counted.
const MAX_HUNKS: usize = 3;
/// Unchanged lines shown around each change.
const CONTEXT: usize = 2;

/// `None` when `expected` (the committed file, named `name`) is byte for byte `actual`
/// (what nccomp writes now); otherwise a report: where they first differ and a unified
/// diff of the first differing blocks (`-` committed, `+` now).
pub fn compare(name: &str, expected: &[u8], actual: &[u8]) -> Option<String> {
    if expected == actual {
        return None;
    }
    let old = String::from_utf8_lossy(expected);
    let new = String::from_utf8_lossy(actual);
    let diff = TextDiff::from_lines(old.as_ref(), new.as_ref());
    let first = expected
        .iter()
        .zip(actual)
        .position(|(a, b)| a != b)
        .unwrap_or(expected.len().min(actual.len()));
    // Lines as `nc::lines` cuts them (a CR alone ends one).
    let line = crate::nc::line_at(expected, first).0;
    let (removed, added) = diff
        .ops()
        .iter()
        .fold((0, 0), |(r, a), op| match op.as_tag_tuple() {
            (similar::DiffTag::Equal, _, _) => (r, a),
            (_, old, new) => (r + old.len(), a + new.len()),
        });
    let mut out = format!(
        "{name} is not what nccomp writes now (first difference at line {line}; {removed} line{} removed, {added} added)\n",
        if removed == 1 { "" } else { "s" },
    );
    let mut unified = diff.unified_diff();
    unified.context_radius(CONTEXT);
    let hunks: Vec<_> = unified.iter_hunks().collect();
    if hunks.is_empty() {
        // Bytes that differ but read the same as text: invalid UTF-8.
        out.push_str("(the difference is in bytes that are not valid UTF-8 text)\n");
        return Some(out);
    }
    let _ = writeln!(out, "--- {name} (committed)\n+++ {name} (nccomp now)");
    for hunk in hunks.iter().take(MAX_HUNKS) {
        let _ = write!(out, "{hunk}");
    }
    if hunks.len() > MAX_HUNKS {
        let _ = writeln!(
            out,
            "… and {} more differing places",
            hunks.len() - MAX_HUNKS
        );
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identical_bytes_are_up_to_date() {
        assert_eq!(compare("a.nc", b"G1 X1\n", b"G1 X1\n"), None);
    }

    #[test]
    fn a_line_ending_or_a_digit_is_a_difference() {
        let report = compare("a.nc", b"G1 X1\r\nG1 X2\n", b"G1 X1\nG1 X2\n").unwrap();
        assert!(report.contains("first difference at line 1"), "{report}");
        // A carriage return alone ends a line (as nccomp reads the program).
        let report = compare("a.nc", b"G0 Z5\rG1 X1\r", b"G0 Z5\rG1 X2\r").unwrap();
        assert!(report.contains("first difference at line 2"), "{report}");
        let report = compare("a.nc", b"G0 Z5\r\nG1 X1", b"G0 Z5\rG1 X1").unwrap();
        assert!(report.contains("first difference at line 1"), "{report}");
        let report = compare(
            "a.nc",
            b"G0 Z5\nG1 X1.0001\nM30\n",
            b"G0 Z5\nG1 X1.0002\nM30\n",
        )
        .unwrap();
        assert!(
            report.ends_with(
                "--- a.nc (committed)\n+++ a.nc (nccomp now)\n@@ -1,3 +1,3 @@\n G0 Z5\n-G1 X1.0001\n+G1 X1.0002\n M30\n"
            ),
            "{report}"
        );
    }

    #[test]
    fn only_the_first_places_are_shown() {
        let old: String = (0..100).map(|i| format!("G1 X{i}\n")).collect();
        let new = old.replace('5', "6");
        let report = compare("a.nc", old.as_bytes(), new.as_bytes()).unwrap();
        assert_eq!(report.matches("@@ -").count(), MAX_HUNKS, "{report}");
        assert!(report.contains("more differing places"), "{report}");
    }
}
