//! Reading the probe's CSV files with errors that name `file:line:column`.
//!
//! Both files have a header line naming the columns (any order, any case, extra columns
//! ignored), comma-separated fields, surrounding spaces ignored, and `#` comment lines.
//! Rows are read through serde; a field serde cannot read, a field that is not a finite
//! number, a row with the wrong number of fields or a missing column is reported at its
//! place in the file.

use crate::diag::{Error, csv_field_offsets};
use csv::{ByteRecord, ReaderBuilder, StringRecord, Trim};
use serde::de::DeserializeOwned;

/// One row read from a CSV file, with where it is.
#[derive(Debug, Clone)]
pub struct Row<T> {
    pub value: T,
    /// 1-based line of the row in the file.
    pub line: usize,
    /// Byte offset of the row's first byte in the file.
    pub offset: usize,
    /// Byte offset of each field (of the columns as the header lists them), for messages.
    pub field_offsets: Vec<usize>,
    /// Lowercased header names, parallel to `field_offsets`.
    pub columns: std::sync::Arc<Vec<String>>,
}

impl<T> Row<T> {
    /// Byte offset of the field in column `name` (the row's start if there is none).
    pub fn offset_of(&self, name: &str) -> usize {
        self.columns
            .iter()
            .position(|c| c == name)
            .and_then(|i| self.field_offsets.get(i).copied())
            .unwrap_or(self.offset)
    }
}

/// Read all rows of `text` (named `path` in messages) as `T`, after checking that the
/// header has every column in `required`. `what` names the file's kind in messages
/// ("ring-gauge data"). Each row's numbers are checked to be finite: `finite` lists the
/// columns that must hold numbers, and is called with the row to get their values.
pub fn read_rows<T: DeserializeOwned>(
    path: &str,
    text: &[u8],
    what: &str,
    required: &[&str],
    finite: impl Fn(&T) -> Vec<(&'static str, Option<f64>)>,
) -> crate::Result<Vec<Row<T>>> {
    // Comment and blank lines become empty lines of the same length, which the reader
    // skips, so its byte positions are positions in `text`.
    let cleaned = blank_comments(text);
    let mut reader = ReaderBuilder::new()
        .has_headers(true)
        .trim(Trim::All)
        .flexible(false)
        .from_reader(&cleaned[..]);
    let header_offset = first_content_line(text);
    let headers: StringRecord = match reader.headers() {
        Ok(h) => h.clone(),
        Err(e) => return Err(csv_error(path, text, &cleaned, &e, what)),
    };
    if headers.is_empty() || headers.iter().all(str::is_empty) {
        return Err(Error::at(
            path,
            text,
            header_offset,
            format!(
                "{what} is empty: expected a header line naming the columns {}",
                required.join(", ")
            ),
        ));
    }
    let columns: Vec<String> = headers.iter().map(|h| h.to_ascii_lowercase()).collect();
    let missing: Vec<&str> = required
        .iter()
        .copied()
        .filter(|r| !columns.iter().any(|c| c == r))
        .collect();
    if !missing.is_empty() {
        let header_end = header_offset
            + text[header_offset..]
                .iter()
                .position(|&b| b == b'\n' || b == b'\r')
                .unwrap_or(text.len() - header_offset);
        return Err(Error::at(
            path,
            text,
            header_end,
            format!(
                "{what}: missing column{} {} (the header names {}; expected the columns {})",
                if missing.len() == 1 { "" } else { "s" },
                missing
                    .iter()
                    .map(|m| format!("`{m}`"))
                    .collect::<Vec<_>>()
                    .join(", "),
                columns
                    .iter()
                    .map(|c| format!("`{c}`"))
                    .collect::<Vec<_>>()
                    .join(", "),
                required.join(", ")
            ),
        ));
    }
    let lower = StringRecord::from(columns.clone()).into_byte_record();
    let columns = std::sync::Arc::new(columns);
    let mut rows = Vec::new();
    let mut record = ByteRecord::new();
    loop {
        match reader.read_byte_record(&mut record) {
            Ok(false) => break,
            Ok(true) => {}
            Err(e) => return Err(csv_error(path, text, &cleaned, &e, what)),
        }
        // The reader's position is where it began looking, before skipped empty lines.
        let offset = record.position().map_or(0, |p| p.byte() as usize);
        let offset = skip_blank(&cleaned, offset);
        let field_offsets = csv_field_offsets(text, offset, columns.len());
        let at_field = |i: usize| field_offsets.get(i).copied().unwrap_or(offset);
        let value: T = match record.deserialize(Some(&lower)) {
            Ok(v) => v,
            Err(e) => {
                let field = match e.kind() {
                    csv::ErrorKind::Deserialize { err, .. } => err.field().map(|f| f as usize),
                    _ => None,
                };
                let message = match field {
                    Some(i) => {
                        let found = String::from_utf8_lossy(record.get(i).unwrap_or_default());
                        let name = columns.get(i).map_or("?", String::as_str);
                        if found.is_empty() {
                            format!("`{name}` is empty (expected a number)")
                        } else {
                            format!("`{name}` is `{found}`, not a number")
                        }
                    }
                    None => format!("cannot read this row of the {what}: {e}"),
                };
                return Err(Error::at(
                    path,
                    text,
                    field.map_or(offset, at_field),
                    message,
                ));
            }
        };
        for (name, v) in finite(&value) {
            if let Some(v) = v
                && !v.is_finite()
            {
                let i = columns.iter().position(|c| c == name).unwrap_or(0);
                return Err(Error::at(
                    path,
                    text,
                    at_field(i),
                    format!("`{name}` is {v}, expected a finite number"),
                ));
            }
        }
        rows.push(Row {
            value,
            line: text[..offset.min(text.len())]
                .iter()
                .filter(|&&b| b == b'\n')
                .count()
                + 1,
            offset,
            field_offsets,
            columns: columns.clone(),
        });
    }
    Ok(rows)
}

/// A csv reader error, located.
fn csv_error(path: &str, text: &[u8], cleaned: &[u8], e: &csv::Error, what: &str) -> Error {
    let start =
        |pos: Option<&csv::Position>| skip_blank(cleaned, pos.map_or(0, |p| p.byte() as usize));
    match e.kind() {
        csv::ErrorKind::UnequalLengths {
            pos,
            expected_len,
            len,
        } => {
            let offset = start(pos.as_ref());
            Error::at(
                path,
                text,
                offset,
                format!(
                    "this row has {len} field{} but the header names {expected_len} column{}",
                    if *len == 1 { "" } else { "s" },
                    if *expected_len == 1 { "" } else { "s" },
                ),
            )
        }
        csv::ErrorKind::Utf8 { pos, err } => {
            let offset = start(pos.as_ref());
            let offset = csv_field_offsets(text, offset, err.field() + 1)
                .get(err.field())
                .copied()
                .unwrap_or(offset);
            Error::at(path, text, offset, "this field is not valid UTF-8")
        }
        _ => Error::at(
            path,
            text,
            start(e.position()),
            format!("cannot read the {what}: {e}"),
        ),
    }
}

/// The first offset at or after `offset` that is not a line ending in `cleaned`.
fn skip_blank(cleaned: &[u8], mut offset: usize) -> usize {
    while offset < cleaned.len() && (cleaned[offset] == b'\n' || cleaned[offset] == b'\r') {
        offset += 1;
    }
    offset
}

/// `text` with every line that is blank or starts (after spaces) with `#` turned into
/// newlines, byte for byte.
fn blank_comments(text: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(text.len());
    for line in text.split_inclusive(|&b| b == b'\n') {
        let first = line.iter().position(|b| !b" \t\r\n".contains(b));
        match first {
            Some(i) if line[i] != b'#' => out.extend_from_slice(line),
            _ => out.extend(std::iter::repeat_n(b'\n', line.len())),
        }
    }
    out
}

/// The offset of the first byte of the first line that is not blank or a comment.
fn first_content_line(text: &[u8]) -> usize {
    let mut offset = 0;
    for line in text.split_inclusive(|&b| b == b'\n') {
        let trimmed = line.iter().position(|b| !b" \t\r\n".contains(b));
        match trimmed {
            Some(i) if line[i] != b'#' => return offset + i,
            _ => offset += line.len(),
        }
    }
    offset.min(text.len())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(serde::Deserialize, Debug)]
    struct R {
        a: f64,
        b: f64,
    }

    fn read(text: &str) -> crate::Result<Vec<Row<R>>> {
        read_rows(
            "t.csv",
            text.as_bytes(),
            "test data",
            &["a", "b"],
            |r: &R| vec![("a", Some(r.a)), ("b", Some(r.b))],
        )
    }

    #[test]
    fn reads_rows_in_any_column_order_with_comments() {
        let rows = read("# c\nB, A ,note\n2, 1, x\n\n  # more\n \t\r\n 4,3,y\n").unwrap();
        assert_eq!(rows.len(), 2);
        assert_eq!(
            (rows[0].value.a, rows[0].value.b, rows[0].line),
            (1.0, 2.0, 3)
        );
        assert_eq!((rows[1].value.a, rows[1].line), (3.0, 7));
        let e = read("a,b\n# c\n1,2\n\n3, x\n").unwrap_err().to_string();
        assert_eq!(e, "t.csv:5:4: `b` is `x`, not a number");
    }

    #[test]
    fn locates_bad_fields() {
        let e = read("a,b\n1,2\n3, x\n").unwrap_err().to_string();
        assert_eq!(e, "t.csv:3:4: `b` is `x`, not a number");
        let e = read("a,b\n1,\n").unwrap_err().to_string();
        assert_eq!(e, "t.csv:2:3: `b` is empty (expected a number)");
        let e = read("a,b\n1,inf\n").unwrap_err().to_string();
        assert_eq!(e, "t.csv:2:3: `b` is inf, expected a finite number");
        let e = read("a,c\n1,2\n").unwrap_err().to_string();
        assert!(
            e.starts_with("t.csv:1:4: test data: missing column `b`"),
            "{e}"
        );
        let e = read("a,b\n1,2\n\n# x\n1,2,3\n").unwrap_err().to_string();
        assert!(e.starts_with("t.csv:5:1: this row has 3 fields"), "{e}");
        let e = read("").unwrap_err().to_string();
        assert!(e.starts_with("t.csv:1:1: test data is empty"), "{e}");
    }
}
