//! Measured points: CSV files from the on-machine probe and the CMM, matched to the plan.
//!
//! ```csv
//! feature,id,x,y,z
//! x_straightness,XS01,-90.0003,-100.0021,5.0001
//! ```
//!
//! One row per planned point (mm, part frame); order does not matter. A point the plan
//! does not know, a point under the wrong feature, a point given twice or missing, or a
//! number that does not read are errors naming the file, line and column.

use super::plan::Plan;
use crate::{Error, Result};
use nalgebra::Vector3;
use std::collections::BTreeMap;

/// Measured points by id.
pub type Points = BTreeMap<String, Vector3<f64>>;

/// Read a measurement CSV for `plan`; `path` names it in messages.
pub fn parse(text: &str, path: &str, plan: &Plan) -> Result<Points> {
    let bytes = text.as_bytes();
    let feature_of: BTreeMap<&str, &str> = plan
        .features
        .iter()
        .flat_map(|f| f.points.iter().map(|p| (p.id.as_str(), f.name.as_str())))
        .collect();
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(true)
        .trim(csv::Trim::All)
        .from_reader(bytes);
    let headers = reader
        .headers()
        .map_err(|e| Error::at(path, bytes, 0, format!("cannot read the header: {e}")))?
        .clone();
    let want = ["feature", "id", "x", "y", "z"];
    if headers.len() != 5
        || headers
            .iter()
            .zip(want)
            .any(|(h, w)| !h.eq_ignore_ascii_case(w))
    {
        return Err(Error::at(
            path,
            bytes,
            0,
            "the header must be `feature,id,x,y,z`",
        ));
    }
    let mut points = Points::new();
    for record in reader.records() {
        let record = record.map_err(|e| {
            let at = e.position().map_or(0, |p| p.byte() as usize);
            Error::at(path, bytes, at, format!("{e}"))
        })?;
        let start = record.position().map_or(0, |p| p.byte() as usize);
        // Byte offset of field k in the row (for the column of a message).
        let field_at = |k: usize| -> usize {
            let line = &text[start..];
            // The k-th comma outside quotes.
            let mut quoted = false;
            let mut commas = 0;
            let mut off = 0;
            for (i, c) in line.char_indices() {
                if commas == k || c == '\n' {
                    break;
                }
                match c {
                    '"' => quoted = !quoted,
                    ',' if !quoted => {
                        commas += 1;
                        off = i + 1;
                    }
                    _ => {}
                }
            }
            start + off + (line[off..].len() - line[off..].trim_start().len())
        };
        let err = |k: usize, m: String| Error::at(path, bytes, field_at(k), m);
        if record.len() != 5 {
            return Err(err(0, format!("expected 5 fields, found {}", record.len())));
        }
        let (feature, id) = (&record[0], &record[1]);
        let Some(&planned) = feature_of.get(id) else {
            return Err(err(1, format!("point `{id}` is not in the plan")));
        };
        if planned != feature {
            return Err(err(
                0,
                format!("point `{id}` belongs to feature `{planned}`, not `{feature}`"),
            ));
        }
        let mut v = [0.0; 3];
        for (k, value) in v.iter_mut().enumerate() {
            *value = record[k + 2]
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| err(k + 2, format!("`{}` is not a number", &record[k + 2])))?;
        }
        if points.insert(id.to_string(), Vector3::from(v)).is_some() {
            return Err(err(1, format!("point `{id}` is given twice")));
        }
    }
    let end = bytes.len();
    for f in &plan.features {
        let missing: Vec<&str> = f
            .points
            .iter()
            .filter(|p| !points.contains_key(&p.id))
            .map(|p| p.id.as_str())
            .collect();
        if !missing.is_empty() {
            return Err(Error::at(
                path,
                bytes,
                end,
                format!(
                    "feature `{}`: {} planned point(s) missing: {}",
                    f.name,
                    missing.len(),
                    missing.join(", ")
                ),
            ));
        }
    }
    Ok(points)
}

pub fn load(path: &std::path::Path, plan: &Plan) -> Result<Points> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    parse(&text, &path.display().to_string(), plan)
}

/// Write points as a measurement CSV in plan order.
pub fn to_csv(plan: &Plan, points: &Points) -> String {
    let mut out = String::from("feature,id,x,y,z\n");
    // A field with a comma or a quote is quoted, its quotes doubled.
    let field = |s: &str| {
        if s.contains([',', '"', '\n']) {
            format!("\"{}\"", s.replace('"', "\"\""))
        } else {
            s.to_string()
        }
    };
    for f in &plan.features {
        for p in &f.points {
            if let Some(v) = points.get(&p.id) {
                out.push_str(&format!(
                    "{},{},{:.6},{:.6},{:.6}\n",
                    field(&f.name),
                    field(&p.id),
                    v.x,
                    v.y,
                    v.z
                ));
            }
        }
    }
    out
}
