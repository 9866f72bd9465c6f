//! The measured trace: axis positions sampled in time, read from CSV.
//!
//! A header line names the columns, in any order and any case: `time` (seconds) or
//! `time_ms`, and one column per axis of the active configuration, named by the machine
//! file's axis name or program letter (`X`, `a`, or `X_act`). Commanded positions may be
//! given too, as `X_cmd`, … for every axis. Other columns are ignored (and listed). Lines
//! starting with `#` are comments. Positions are in the program's units: mm and degrees.

use crate::diag::{Error, csv_field_offsets};
use crate::kinematics::Kinematics;
use crate::model::Machine;
use crate::nc::number::write_fixed;
use csv::{ByteRecord, ReaderBuilder, Trim};
use rayon::prelude::*;
use std::fmt::Write;

/// A trace: per sample a time and the actual (and maybe commanded) axis values.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Trace {
    /// Names of the axes, in the kinematics' variable order.
    pub axes: Vec<String>,
    /// Seconds, non-decreasing.
    pub time: Vec<f64>,
    /// Actual axis values, `axes.len()` per sample.
    pub actual: Vec<f64>,
    /// Commanded axis values, if the trace has them.
    pub commanded: Option<Vec<f64>>,
    /// Header names of the columns that were not used.
    pub ignored: Vec<String>,
}

impl Trace {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.time.len()
    }

    pub fn is_empty(&self) -> bool {
        self.time.is_empty()
    }

    /// The trace as CSV in the form [`read`] takes: time in seconds, the actual positions
    /// and, if there are any, the commanded ones, to 6 decimals.
    pub fn to_csv(&self) -> String {
        let n = self.axes.len();
        let mut out = String::with_capacity(self.len() * (n + 1) * 24);
        out.push_str("time");
        for a in &self.axes {
            out.push(',');
            out.push_str(a);
        }
        if self.commanded.is_some() {
            for a in &self.axes {
                let _ = write!(out, ",{a}_cmd");
            }
        }
        out.push('\n');
        for i in 0..self.len() {
            write_fixed(self.time[i], 6, &mut out);
            let values = self.actual(i).iter().chain(
                self.commanded
                    .as_ref()
                    .map_or(&[][..], |c| &c[i * n..(i + 1) * n]),
            );
            for &v in values {
                out.push(',');
                write_fixed(v, 6, &mut out);
            }
            out.push('\n');
        }
        out
    }

    /// The actual axis values of sample `i`.
    pub fn actual(&self, i: usize) -> &[f64] {
        let n = self.axes.len();
        &self.actual[i * n..(i + 1) * n]
    }
}

/// The names of the active axes of `kin`, in its variable order.
pub fn axis_names(machine: &Machine, kin: &Kinematics) -> Vec<String> {
    kin.axes()
        .iter()
        .map(|&i| machine.axes[i].name.clone())
        .collect()
}

/// What a column holds.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Column {
    /// Time, and the factor to seconds.
    Time(f64),
    Actual(usize),
    Commanded(usize),
    Ignored,
}

/// Read a trace `text` (named `path` in messages) for the active axes of `kin`.
pub fn read(path: &str, text: &[u8], machine: &Machine, kin: &Kinematics) -> crate::Result<Trace> {
    let names: Vec<(String, char)> = kin
        .axes()
        .iter()
        .map(|&i| (machine.axes[i].name.clone(), machine.axes[i].word))
        .collect();
    let n = names.len();
    let mut reader = ReaderBuilder::new()
        .has_headers(true)
        .trim(Trim::All)
        .comment(Some(b'#'))
        .flexible(false)
        .from_reader(text);
    let header = match reader.byte_headers() {
        Ok(h) => h.clone(),
        Err(e) => return Err(csv_error(path, text, 0, &e)),
    };
    let header_at = header.position().map_or(0, |p| p.byte() as usize);
    let header_at = header_at + leading_comments(&text[header_at..]);
    let expected = || {
        let mut cols = vec!["time".to_string()];
        cols.extend(names.iter().map(|(name, _)| name.clone()));
        cols.join(", ")
    };
    if header.iter().all(|h| h.is_empty()) {
        return Err(Error::at(
            path,
            text,
            header_at,
            format!(
                "the trace is empty: expected a header line naming the columns {}",
                expected()
            ),
        ));
    }
    let offsets = csv_field_offsets(text, header_at, header.len());
    let mut columns = Vec::with_capacity(header.len());
    let mut seen: Vec<(Column, usize)> = Vec::new();
    let mut ignored = Vec::new();
    for (i, h) in header.iter().enumerate() {
        let h = String::from_utf8_lossy(h).to_ascii_lowercase();
        let column = classify(&h, &names);
        if let Some((_, first)) = seen
            .iter()
            .find(|(c, _)| *c != Column::Ignored && same_role(*c, column))
        {
            return Err(Error::at(
                path,
                text,
                offsets.get(i).copied().unwrap_or(header_at),
                format!(
                    "column `{h}` holds the same quantity as column {} (expected each axis and the time once)",
                    first + 1
                ),
            ));
        }
        if column == Column::Ignored {
            ignored.push(h.clone());
        }
        seen.push((column, i));
        columns.push(column);
    }
    let header_end = offsets.last().map_or(header_at, |&o| {
        o + text[o..]
            .iter()
            .position(|&b| b == b',' || b == b'\n' || b == b'\r')
            .unwrap_or(text.len() - o)
    });
    let missing: Vec<String> = std::iter::once("time".to_string())
        .filter(|_| !columns.iter().any(|c| matches!(c, Column::Time(_))))
        .chain(
            (0..n)
                .filter(|&v| !columns.contains(&Column::Actual(v)))
                .map(|v| names[v].0.clone()),
        )
        .collect();
    if !missing.is_empty() {
        return Err(Error::at(
            path,
            text,
            header_end,
            format!(
                "the trace has no column for {} (expected the columns {}, or time_ms for milliseconds)",
                missing
                    .iter()
                    .map(|m| format!("`{m}`"))
                    .collect::<Vec<_>>()
                    .join(", "),
                expected()
            ),
        ));
    }
    let commanded_count = (0..n)
        .filter(|&v| columns.contains(&Column::Commanded(v)))
        .count();
    if commanded_count != 0 && commanded_count != n {
        let lacking: Vec<String> = (0..n)
            .filter(|&v| !columns.contains(&Column::Commanded(v)))
            .map(|v| format!("`{}_cmd`", names[v].0))
            .collect();
        return Err(Error::at(
            path,
            text,
            header_end,
            format!(
                "the trace has commanded positions for some axes only: expected also {}",
                lacking.join(", ")
            ),
        ));
    }
    let mut trace = Trace {
        axes: names.iter().map(|(name, _)| name.clone()).collect(),
        commanded: (commanded_count == n).then(Vec::new),
        ignored,
        ..Trace::default()
    };
    // The rows, in pieces read in parallel.
    let body = reader.position().byte() as usize;
    let pieces = (rayon::current_num_threads() * 4).min((text.len() - body) / (256 << 10) + 1);
    let mut bounds = vec![body];
    for k in 1..pieces {
        let at = body + (text.len() - body) * k / pieces;
        let at = text[at..]
            .iter()
            .position(|&b| b == b'\n')
            .map_or(text.len(), |i| at + i + 1);
        if at > *bounds.last().unwrap_or(&body) && at < text.len() {
            bounds.push(at);
        }
    }
    bounds.push(text.len());
    let layout = Layout {
        path,
        text,
        columns: &columns,
        header: &header,
        n,
    };
    let chunks: Vec<Rows> = bounds
        .par_windows(2)
        .map(|w| layout.rows(w[0], w[1]))
        .collect::<crate::Result<_>>()?;
    let count = chunks.iter().map(|c| c.time.len()).sum();
    trace.time.reserve(count);
    trace.actual.reserve(count * n);
    let mut previous_time = f64::NEG_INFINITY;
    let mut last_row = header_at;
    for chunk in chunks {
        for (r, &time) in chunk.time.iter().enumerate() {
            if time < previous_time {
                let i = columns
                    .iter()
                    .position(|c| matches!(c, Column::Time(_)))
                    .unwrap_or(0);
                let at = csv_field_offsets(text, chunk.starts[r], i + 1)
                    .get(i)
                    .copied()
                    .unwrap_or(chunk.starts[r]);
                return Err(Error::at(
                    path,
                    text,
                    at,
                    format!(
                        "time goes back here ({time} s after {previous_time} s): expected the samples in time order"
                    ),
                ));
            }
            previous_time = time;
        }
        last_row = chunk.starts.last().copied().unwrap_or(last_row);
        trace.time.extend_from_slice(&chunk.time);
        trace.actual.extend_from_slice(&chunk.actual);
        if let Some(c) = trace.commanded.as_mut() {
            c.extend_from_slice(&chunk.commanded);
        }
    }
    if trace.len() < 2 {
        return Err(Error::at(
            path,
            text,
            last_row,
            format!(
                "the trace has {} sample{}: expected at least two rows of {}",
                trace.len(),
                if trace.len() == 1 { "" } else { "s" },
                expected()
            ),
        ));
    }
    Ok(trace)
}

/// The rows of one piece of a trace.
#[derive(Debug, Default)]
struct Rows {
    time: Vec<f64>,
    actual: Vec<f64>,
    commanded: Vec<f64>,
    /// Byte offset of each row in the file.
    starts: Vec<usize>,
}

/// What reading a row needs to know.
struct Layout<'a> {
    path: &'a str,
    text: &'a [u8],
    columns: &'a [Column],
    header: &'a ByteRecord,
    n: usize,
}

impl Layout<'_> {
    /// The rows in `text[from..to]` (whole lines). Fields are numbers, optionally in
    /// double quotes; a row is split at every comma.
    fn rows(&self, from: usize, to: usize) -> crate::Result<Rows> {
        let n = self.n;
        let body = std::str::from_utf8(&self.text[from..to]).map_err(|e| {
            Error::at(
                self.path,
                self.text,
                from + e.valid_up_to(),
                "this byte is not UTF-8 (expected a text file)",
            )
        })?;
        let guess = (to - from) / (16 * self.columns.len()).max(16);
        let mut rows = Rows {
            time: Vec::with_capacity(guess),
            actual: Vec::with_capacity(guess * n),
            ..Rows::default()
        };
        let commanded = self
            .columns
            .iter()
            .any(|c| matches!(c, Column::Commanded(_)));
        let mut row = vec![0.0; 2 * n];
        let bytes = body.as_bytes();
        let mut pos = 0;
        while pos < bytes.len() {
            let line_end = body[pos..].find('\n').map_or(bytes.len(), |i| pos + i);
            let mut line = &bytes[pos..line_end];
            let mut start = from + pos;
            pos = line_end + 1;
            if let [rest @ .., b'\r'] = line {
                line = rest;
            }
            while let [b' ' | b'\t', rest @ ..] = line {
                line = rest;
                start += 1;
            }
            if line.is_empty() || line[0] == b'#' {
                continue;
            }
            let mut time = 0.0;
            let mut fields = 0;
            for raw in line.split(|&b| b == b',') {
                let i = fields;
                fields += 1;
                let Some(&column) = self.columns.get(i) else {
                    continue;
                };
                if column == Column::Ignored {
                    continue;
                }
                let Some(value) = number(raw) else {
                    let field_at = start
                        + (raw.as_ptr() as usize - line.as_ptr() as usize)
                        + raw.iter().take_while(|b| matches!(b, b' ' | b'\t')).count();
                    let field = String::from_utf8_lossy(raw.trim_ascii()).into_owned();
                    let name = String::from_utf8_lossy(&self.header[i]).into_owned();
                    return Err(Error::at(
                        self.path,
                        self.text,
                        field_at,
                        if field.is_empty() {
                            format!("`{name}` is empty (expected a finite number)")
                        } else {
                            format!("`{name}` is `{field}` (expected a finite number)")
                        },
                    ));
                };
                match column {
                    Column::Time(scale) => time = value * scale,
                    Column::Actual(v) => row[v] = value,
                    Column::Commanded(v) => row[n + v] = value,
                    Column::Ignored => {}
                }
            }
            if fields != self.columns.len() {
                let expected = self.columns.len();
                return Err(Error::at(
                    self.path,
                    self.text,
                    start,
                    format!(
                        "this row has {fields} field{} but the header names {expected} column{} (expected one field per column, separated by commas)",
                        if fields == 1 { "" } else { "s" },
                        if expected == 1 { "" } else { "s" },
                    ),
                ));
            }
            rows.time.push(time);
            rows.starts.push(start);
            rows.actual.extend_from_slice(&row[..n]);
            if commanded {
                rows.commanded.extend_from_slice(&row[n..]);
            }
        }
        Ok(rows)
    }
}

/// A field as a finite number: spaces around it and a pair of double quotes are allowed.
fn number(raw: &[u8]) -> Option<f64> {
    let field = raw.trim_ascii();
    let field = match field {
        [b'"', inner @ .., b'"'] => inner,
        _ => field,
    };
    decimal(field)
        .or_else(|| std::str::from_utf8(field).ok()?.parse::<f64>().ok())
        .filter(|v| v.is_finite())
}

/// A plain decimal `[+-]digits[.digits]` of at most 15 significant digits, exactly as
/// `str::parse` reads it (the integer and the power of ten are exact, so the one division
/// rounds correctly); `None` for anything else, which `str::parse` then reads.
fn decimal(text: &[u8]) -> Option<f64> {
    const POW10: [f64; 16] = [
        1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15,
    ];
    let (negative, digits) = match text {
        [b'-', rest @ ..] => (true, rest),
        [b'+', rest @ ..] => (false, rest),
        _ => (false, text),
    };
    let (mut mantissa, mut count, mut decimals, mut point, mut any) =
        (0u64, 0u32, 0usize, false, false);
    for &b in digits {
        match b {
            b'0'..=b'9' => {
                any = true;
                if mantissa != 0 || b != b'0' {
                    count += 1;
                }
                mantissa = mantissa * 10 + u64::from(b - b'0');
                if point {
                    decimals += 1;
                }
                if count > 15 || decimals > 15 {
                    return None;
                }
            }
            b'.' if !point => point = true,
            _ => return None,
        }
    }
    if !any {
        return None;
    }
    let value = mantissa as f64 / POW10[decimals];
    Some(if negative { -value } else { value })
}

/// What a header name (lowercased) stands for.
fn classify(h: &str, names: &[(String, char)]) -> Column {
    match h {
        "time" | "t" | "time_s" => return Column::Time(1.0),
        "time_ms" => return Column::Time(1e-3),
        _ => {}
    }
    let axis = |s: &str| {
        names.iter().position(|(name, word)| {
            s.eq_ignore_ascii_case(name) || s.eq_ignore_ascii_case(&word.to_string())
        })
    };
    if let Some(v) = h.strip_suffix("_cmd").and_then(axis) {
        return Column::Commanded(v);
    }
    match axis(h.strip_suffix("_act").unwrap_or(h)) {
        Some(v) => Column::Actual(v),
        None => Column::Ignored,
    }
}

/// Whether two columns would fill the same slot.
fn same_role(a: Column, b: Column) -> bool {
    match (a, b) {
        (Column::Time(_), Column::Time(_)) => true,
        _ => a == b,
    }
}

/// The length of the blank and `#` comment lines at the start of `text` (the csv reader
/// reports a record's position before the comments it skipped).
fn leading_comments(text: &[u8]) -> usize {
    let mut at = 0;
    loop {
        let rest = &text[at..];
        let first = rest.iter().position(|b| !b" \t\r\n".contains(b));
        match first {
            Some(i) if rest[i] == b'#' || rest[..i].contains(&b'\n') => {
                let skip = if rest[i] == b'#' {
                    rest[i..]
                        .iter()
                        .position(|&b| b == b'\n')
                        .map_or(rest.len(), |e| i + e + 1)
                } else {
                    rest[..i]
                        .iter()
                        .rposition(|&b| b == b'\n')
                        .map_or(0, |e| e + 1)
                };
                if skip == 0 {
                    return at;
                }
                at += skip;
            }
            _ => return at,
        }
    }
}

/// A csv reader error in a piece of `text` starting at `from`, located.
fn csv_error(path: &str, text: &[u8], from: usize, e: &csv::Error) -> Error {
    let start = (from + e.position().map_or(0, |p| p.byte() as usize)).min(text.len());
    let at = start + leading_comments(&text[start..]);
    Error::at(path, text, at, format!("cannot read the trace: {e}"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{ErrorModel, machine_file};

    fn machine() -> Machine {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/fixtures/ac_trunnion.machine.toml"
        );
        machine_file::load(std::path::Path::new(path)).unwrap()
    }

    fn parse(text: &str) -> crate::Result<Trace> {
        let m = machine();
        let kin = Kinematics::new(&m, &ErrorModel::zero(&m), 0).unwrap();
        read("t.csv", text.as_bytes(), &m, &kin)
    }

    proptest::proptest! {
        /// The fast reading of plain decimals is `str::parse`'s, bit for bit.
        #[test]
        fn decimals_read_as_str_parse_reads_them(
            sign in proptest::sample::select(vec!["", "-", "+"]),
            int in "[0-9]{0,12}",
            point in proptest::bool::ANY,
            frac in "[0-9]{0,12}",
        ) {
            let text = format!("{sign}{int}{}{frac}", if point { "." } else { "" });
            let expected = text.parse::<f64>().ok();
            if let Some(v) = decimal(text.as_bytes()) {
                proptest::prop_assert_eq!(Some(v.to_bits()), expected.map(f64::to_bits), "{}", text);
            }
            proptest::prop_assert_eq!(
                number(text.as_bytes()).map(f64::to_bits),
                expected.map(f64::to_bits)
            );
        }
    }

    #[test]
    fn reads_columns_in_any_order_and_case() {
        let t =
            parse("# a trace\nc, a,Z,y,x,TIME_MS,load\n1,2,3,4,5,0,9\n\n# gap\n6,7,8,9,10,15,9\n")
                .unwrap();
        assert_eq!(t.axes, ["X", "Y", "Z", "A", "C"]);
        assert_eq!(t.time, [0.0, 0.015]);
        assert_eq!(t.actual(1), [10.0, 9.0, 8.0, 7.0, 6.0]);
        assert_eq!(t.ignored, ["load"]);
        assert!(t.commanded.is_none());
        let t = parse("time,X,Y,Z,A,C\r\n0, \"1.5\",2,3,4,5\r\n1,1,2,3,4,5").unwrap();
        assert_eq!(t.actual(0)[0], 1.5);
        assert_eq!(t.time, [0.0, 1.0]);
    }

    #[test]
    fn reads_commanded_positions() {
        let t = parse(
            "time,X,Y,Z,A,C,X_cmd,Y_cmd,Z_cmd,A_cmd,C_cmd\n0,1,2,3,4,5,1.5,2,3,4,5\n1,1,2,3,4,5,1,2,3,4,5\n",
        )
        .unwrap();
        assert_eq!(t.commanded.unwrap()[0], 1.5);
    }

    /// A long trace is read in pieces; places and the time order hold across them.
    #[test]
    fn long_traces_are_read_in_pieces_with_the_same_messages() {
        let rows = 60_000;
        let mut text = String::from("time,X,Y,Z,A,C\n");
        for i in 0..rows {
            text += &format!("{},1.25,2.5,3.75,-4,5\n", f64::from(i) * 0.001);
        }
        let t = parse(&text).unwrap();
        assert_eq!(t.len(), rows as usize);
        assert_eq!(t.time[rows as usize - 1], 59.999);
        assert_eq!(t.actual(45_000), [1.25, 2.5, 3.75, -4.0, 5.0]);
        // Line 50,002 holds sample 50,000.
        let bad = text.replace("\n50,1.25", "\n50,1.2x5");
        assert_eq!(
            parse(&bad).unwrap_err().to_string(),
            "t.csv:50002:4: `X` is `1.2x5` (expected a finite number)"
        );
        let back = text.replace("\n40.001,", "\n39.5,");
        assert!(
            parse(&back)
                .unwrap_err()
                .to_string()
                .starts_with("t.csv:40003:1: time goes back here (39.5 s after 40 s)")
        );
    }

    #[test]
    fn locates_bad_input() {
        let e = |s: &str| parse(s).unwrap_err().to_string();
        assert_eq!(
            e("time,X,Y,Z,A\n0,1,2,3,4\n"),
            "t.csv:1:13: the trace has no column for `C` (expected the columns time, X, Y, Z, A, C, or time_ms for milliseconds)"
        );
        assert_eq!(
            e("time,X,Y,Z,A,C\n0,1,2,3,4,5\n0.1,1,2,x3,4,5\n"),
            "t.csv:3:9: `Z` is `x3` (expected a finite number)"
        );
        assert_eq!(
            e("time,X,Y,Z,A,C\n# c\n0,1,2,3,4,5\n\n0.1,1,2,3,4\n"),
            "t.csv:5:1: this row has 5 fields but the header names 6 columns (expected one field per column, separated by commas)"
        );
        assert_eq!(
            e("time,X,Y,Z,A,C\n0.2,1,2,3,4,5\n  0.1, 1,2,3,4,5\n"),
            "t.csv:3:3: time goes back here (0.1 s after 0.2 s): expected the samples in time order"
        );
        assert_eq!(
            e("time,X,x,Y,Z,A,C\n"),
            "t.csv:1:8: column `x` holds the same quantity as column 2 (expected each axis and the time once)"
        );
        assert!(e("time,X,Y,Z,A,C,X_cmd\n0,1,2,3,4,5,6\n").contains("expected also `Y_cmd`"));
        assert!(e("").starts_with("t.csv:1:1: the trace is empty"));
        assert!(
            e("time,X,Y,Z,A,C\n0,1,2,3,4,5\n").starts_with("t.csv:2:1: the trace has 1 sample")
        );
        let m = machine();
        let kin = Kinematics::new(&m, &ErrorModel::zero(&m), 0).unwrap();
        let latin1 = read(
            "t.csv",
            b"time,X,Y,Z,A,C\n0,1,2,3,4,5\n1,1,2\xb0,3,4,5\n",
            &m,
            &kin,
        );
        assert_eq!(
            latin1.unwrap_err().to_string(),
            "t.csv:3:6: this byte is not UTF-8 (expected a text file)"
        );
        assert_eq!(
            e("time,X,Y,Z,A,C\n0,1,2,3,4,inf\n"),
            "t.csv:2:11: `C` is `inf` (expected a finite number)"
        );
    }
}
