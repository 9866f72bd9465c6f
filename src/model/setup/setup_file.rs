//! nccomp's set-up file (TOML): a job's work offsets and tool lengths, and the control's
//! tables to read them from.
//!
//! ```toml
//! [tables]                      # read first; the file's own values go over them
//! tools = "TOOL.T"              # relative to this file; format by extension, or
//! offsets = { path = "presets.txt", format = "heidenhain-preset-pr" }
//! preset = 3                    # PRESET.PR: the row the program runs in (its G54)
//! basis = { X = 0, Y = 0, Z = 0 }   # PRESET.PR: the B-CS origin in machine coordinates
//!
//! [work_offsets]
//! G54 = { X = -312.5, Y = -180.0, Z = -402.1 }
//!
//! [tool]
//! lengths = { 1 = 95.3 }
//! named_lengths = { "BALL D10" = 120.0 }
//! ```

use super::{Format, Given, Place, Setup};
use crate::Result;
use crate::model::machine_file::{Bounds, Doc};
use crate::model::{Machine, WorkOffsets, limits};
use std::path::Path;
use toml::Spanned;
use toml::de::DeValue;

/// Read and check the set-up file at `path` for `machine`.
pub fn load(path: &Path, machine: &Machine) -> Result<Setup> {
    let text = crate::model::read_text(path, "set-up file")?;
    parse(&text, &path.display().to_string(), machine)
}

/// Check the set-up file `text`; `path` names it in messages and places the tables it
/// names (relative to its directory).
pub fn parse(text: &str, path: &str, machine: &Machine) -> Result<Setup> {
    let doc = Doc { path, text };
    let root = doc.parse()?;
    let root = root.get_ref();
    doc.check_keys(root, &["tables", "work_offsets", "tool"], "the set-up file")?;
    let mut setup = Setup::default();
    if let Some(v) = root.get("tables") {
        setup = tables(&doc, v, machine)?;
    }
    if let Some(v) = root.get("work_offsets") {
        setup = setup.then(work_offsets(&doc, v)?);
    }
    if let Some(v) = root.get("tool") {
        setup = setup.then(tool(&doc, v)?);
    }
    Ok(setup)
}

fn place(doc: &Doc, span: std::ops::Range<usize>) -> Place {
    Place::at(doc.path, doc.text, span.start)
}

fn tables(doc: &Doc, v: &Spanned<DeValue>, machine: &Machine) -> Result<Setup> {
    let t = doc.table(
        v,
        "[tables], the control's tables such as `tools = \"TOOL.T\"`",
    )?;
    doc.check_keys(
        t,
        &["tools", "offsets", "preset", "basis", "units"],
        "[tables]",
    )?;
    let inch = match t.get("units") {
        Some(u) => match doc.string(u, "`units` of [tables]")? {
            "mm" => false,
            "inch" => true,
            other => {
                return Err(doc.err(
                    u.span(),
                    format!("`{other}` in `units` of [tables]: expected \"mm\" or \"inch\", the unit of the LinuxCNC tables (the machine's LINEAR_UNITS)"),
                ));
            }
        },
        None => machine.inch_default,
    };
    let preset = match t.get("preset") {
        Some(p) => {
            let n = doc.number_in(
                p,
                "`preset` of [tables]",
                Bounds {
                    lo: 0.0,
                    hi: 99_999_999.0,
                    unit: "",
                },
            )?;
            if n.fract() != 0.0 {
                return Err(doc.err(
                    p.span(),
                    "`preset` of [tables]: expected a row number of the preset table (0, 1, 2, …)",
                ));
            }
            let Some(b) = t.get("basis") else {
                return Err(doc.err(
                    p.span(),
                    "`preset` without `basis`: expected `basis = { X = …, Y = …, Z = … }` beside it, where the control's basic coordinate system (B-CS) lies in machine coordinates (the machine manual says; { X = 0, Y = 0, Z = 0 } when it is the machine datum)",
                ));
            };
            Some((n as u64, xyz(doc, b, "`basis` of [tables]")?))
        }
        None => None,
    };
    if let (Some(b), None) = (t.get("basis"), &preset) {
        return Err(doc.err(b.span(), "`basis` without `preset`: expected `preset = N`, the preset table's row the program runs in"));
    }
    let dir = Path::new(doc.path).parent().unwrap_or(Path::new(""));
    let mut setup = Setup::default();
    for key in ["offsets", "tools"] {
        let Some(v) = t.get(key) else { continue };
        let (file, format) = table_ref(doc, v, key)?;
        let file = dir.join(file);
        let wants = match key {
            "offsets" => [Format::LinuxcncVar, Format::TncPresets],
            _ => [Format::LinuxcncTools, Format::TncTools],
        };
        if !wants.contains(&format) {
            return Err(doc.err(
                v.span(),
                format!(
                    "`{key}` of [tables] names a {}: expected {}",
                    describe(format),
                    match key {
                        "offsets" => "a LinuxCNC parameter file (.var) or a Heidenhain PRESET.PR",
                        _ => "a LinuxCNC tool table (.tbl) or a Heidenhain TOOL.T",
                    }
                ),
            ));
        }
        if format == Format::TncPresets && preset.is_none() {
            return Err(doc.err(
                v.span(),
                "a PRESET.PR without `preset`: expected `preset = N` (the row the program runs in) and `basis` in [tables]",
            ));
        }
        setup = setup.then(super::table(&file, format, inch, preset)?);
    }
    Ok(setup)
}

fn describe(format: Format) -> &'static str {
    match format {
        Format::Setup => "set-up file",
        Format::LinuxcncVar => "LinuxCNC parameter file",
        Format::LinuxcncTools => "LinuxCNC tool table",
        Format::TncTools => "Heidenhain TOOL.T",
        Format::TncPresets => "Heidenhain PRESET.PR",
    }
}

/// `"FILE"` (format by extension) or `{ path = "FILE", format = "…" }`.
fn table_ref(doc: &Doc, v: &Spanned<DeValue>, key: &str) -> Result<(String, Format)> {
    let what = format!("`{key}` of [tables], a file name or {{ path = \"…\", format = \"…\" }}");
    let names = Format::NAMES.map(|n| format!("\"{n}\"")).join(", ");
    match v.get_ref() {
        DeValue::String(s) => {
            let format = Format::of(Path::new(s.as_ref())).filter(|f| *f != Format::Setup).ok_or_else(|| {
                doc.err(
                    v.span(),
                    format!("`{s}`: the table's format is told by its extension (.var, .tbl, .t, .pr): expected one of those, or {{ path = \"{s}\", format = … }} with one of {names}"),
                )
            })?;
            Ok((s.to_string(), format))
        }
        DeValue::Table(t) => {
            doc.check_keys(t, &["path", "format"], &format!("`{key}` of [tables]"))?;
            let (Some(p), Some(f)) = (t.get("path"), t.get("format")) else {
                return Err(doc.err(
                    v.span(),
                    format!("{what}: expected both `path` and `format`"),
                ));
            };
            let p = doc.string(p, &format!("`path` of `{key}`"))?;
            let name = doc.string(f, &format!("`format` of `{key}`"))?;
            let format = Format::named(name).ok_or_else(|| {
                doc.err(
                    f.span(),
                    format!("`{name}` in `format` of `{key}`: expected one of {names}"),
                )
            })?;
            Ok((p.to_string(), format))
        }
        _ => Err(doc.err(v.span(), format!("expected {what}"))),
    }
}

fn xyz(doc: &Doc, v: &Spanned<DeValue>, place: &str) -> Result<[f64; 3]> {
    let entry = doc.table(
        v,
        &format!("{place}, a table such as {{ X = 0, Y = 0, Z = 0 }}"),
    )?;
    doc.check_keys(entry, &["X", "Y", "Z"], place)?;
    let mut out = [0.0; 3];
    for (c, letter) in ["X", "Y", "Z"].iter().enumerate() {
        if let Some(n) = entry.get(*letter) {
            out[c] = doc.number_in(
                n,
                &format!("{letter} of {place}"),
                Bounds::within(limits::LENGTH_MM, "mm"),
            )?;
        }
    }
    Ok(out)
}

/// `[work_offsets]`: offsets as the machine file gives them (a missing axis is 0); each
/// replaces the machine file's offset of that name whole.
fn work_offsets(doc: &Doc, v: &Spanned<DeValue>) -> Result<Setup> {
    let t = doc.table(
        v,
        "[work_offsets], a table of offsets such as `G54 = { X = -250.0, Y = -180.0, Z = -420.0 }`",
    )?;
    let mut setup = Setup::default();
    for (key, value) in t.iter() {
        let k: &str = key.get_ref();
        let Some(code) = WorkOffsets::code(k) else {
            let why = if k == "geometry" || k == "M92" {
                " (where the geometry is given and the M92 reference are the machine's: the machine file gives them)"
            } else {
                ""
            };
            return Err(doc.err(
                key.span(),
                format!("unknown key `{k}` in [work_offsets] of a set-up file{why}: expected G54 … G59, G59.1 … G59.3 or \"G54.1 P1\" … \"G54.1 P300\""),
            ));
        };
        let value = xyz(doc, value, &format!("[work_offsets] {k}"))?;
        setup.offsets.push(Given {
            key: code,
            value,
            from: place(doc, key.span()),
        });
    }
    Ok(setup)
}

/// `[tool]`: `lengths` by number and `named_lengths` by name, as in the machine file.
fn tool(doc: &Doc, v: &Spanned<DeValue>) -> Result<Setup> {
    let t = doc.table(v, "[tool], a table with `lengths` and `named_lengths`")?;
    let why = |k: &str| {
        (k == "length" || k == "change_moves").then_some(
            " (the reference length and what a tool change moves are the machine's: the machine file gives them)",
        )
    };
    for key in t.keys() {
        if let Some(w) = why(key.get_ref()) {
            return Err(doc.err(
                key.span(),
                format!(
                    "`{}` in [tool] of a set-up file{w}: expected `lengths` or `named_lengths`",
                    key.get_ref()
                ),
            ));
        }
    }
    doc.check_keys(t, &["lengths", "named_lengths"], "[tool]")?;
    let mut setup = Setup::default();
    let range = Bounds::within(limits::LENGTH_MM, "mm");
    if let Some(v) = t.get("lengths") {
        let table = doc.table(
            v,
            "tool `lengths`, a table of lengths by number such as `{ 1 = 95.3 }`",
        )?;
        for (key, value) in table.iter() {
            let n: u32 = key.get_ref().parse().map_err(|_| {
                doc.err(
                    key.span(),
                    format!(
                        "tool length key `{}`: expected a tool number (0, 1, 2, ...)",
                        key.get_ref()
                    ),
                )
            })?;
            setup.lengths.push(Given {
                key: n,
                value: doc.number_in(value, &format!("the length of tool {n}"), range)?,
                from: place(doc, key.span()),
            });
        }
    }
    if let Some(v) = t.get("named_lengths") {
        let table = doc.table(v, "tool `named_lengths`, a table of lengths by tool name such as `{ \"BALL D10\" = 95.3 }`")?;
        for (key, value) in table.iter() {
            let name = key.get_ref().to_string();
            if name.is_empty() {
                return Err(doc.err(key.span(), "an empty tool name in `named_lengths`: expected the name a program calls the tool by"));
            }
            setup.named_lengths.push(Given {
                value: doc.number_in(value, &format!("the length of tool \"{name}\""), range)?,
                key: name,
                from: place(doc, key.span()),
            });
        }
    }
    Ok(setup)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn machine() -> Machine {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/fixtures/head_head.machine.toml"
        );
        crate::model::machine_file::load(Path::new(path)).unwrap()
    }

    #[test]
    fn values_with_their_lines() {
        let text = "[work_offsets]\nG55 = { X = -1.5, Z = 2 }\n\n[tool]\nlengths = { 3 = 95.3 }\nnamed_lengths = { \"BALL D10\" = 120.0 }\n";
        let s = parse(text, "job.toml", &machine()).unwrap();
        assert_eq!(s.offsets[0].key, 550);
        assert_eq!(s.offsets[0].value, [-1.5, 0.0, 2.0]);
        assert_eq!(s.offsets[0].from.to_string(), "job.toml:2");
        assert_eq!((s.lengths[0].key, s.lengths[0].value), (3, 95.3));
        assert_eq!(s.named_lengths[0].from.line, 6);
    }

    #[test]
    fn refusals_are_located() {
        let cases = [
            (
                "[work_offsets]\ngeometry = \"G54\"\n",
                "job.toml:2:1",
                "the machine file gives them",
            ),
            (
                "[tool]\nlength = 3\n",
                "job.toml:2:1",
                "the machine file gives them",
            ),
            (
                "[tool]\nlengths = { x = 3 }\n",
                "job.toml:2:13",
                "expected a tool number",
            ),
            (
                "[tables]\ntools = \"tool.txt\"\n",
                "job.toml:2:9",
                "told by its extension",
            ),
            (
                "[tables]\ntools = \"emc.var\"\n",
                "job.toml:2:9",
                "names a LinuxCNC parameter file",
            ),
            (
                "[tables]\noffsets = \"PRESET.PR\"\n",
                "job.toml:2:11",
                "without `preset`",
            ),
            ("[tables]\npreset = 3\n", "job.toml:2:10", "without `basis`"),
            (
                "[tables]\noffsets = { path = \"p\", format = \"fanuc\" }\n",
                "job.toml:2:34",
                "`fanuc`",
            ),
            ("[jobs]\n", "job.toml:1:2", "unknown key `jobs`"),
            (
                "[work_offsets]\nG54 = { X = 1e9 }\n",
                "job.toml:2:13",
                "within ±100000 mm",
            ),
        ];
        for (text, at, what) in cases {
            let e = parse(text, "job.toml", &machine()).unwrap_err().to_string();
            assert!(e.contains(at) && e.contains(what), "{text:?}: {e}");
        }
    }

    #[test]
    fn tables_are_read_relative_to_the_file_and_its_own_values_go_over_them() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("tool.tbl"), "T1 P1 Z50\nT2 P2 Z60\n").unwrap();
        std::fs::write(
            dir.path().join("PRESET.PR"),
            "BEGIN PRESET.PR MM\nNR  X     Y     Z\n1   -10   -20   -30\n[END]\n",
        )
        .unwrap();
        let job = dir.path().join("job.toml");
        std::fs::write(
            &job,
            "[tables]\ntools = \"tool.tbl\"\noffsets = \"PRESET.PR\"\npreset = 1\nbasis = { X = 1, Y = 0, Z = 0 }\n\n[tool]\nlengths = { 2 = 61 }\n",
        )
        .unwrap();
        let mut m = machine();
        m.work_offsets = Some(WorkOffsets::default());
        let s = load(&job, &m).unwrap();
        let used = s.apply(&mut m).unwrap();
        assert_eq!(m.tool.lengths[&1], 50.0);
        assert_eq!(m.tool.lengths[&2], 61.0);
        assert_eq!(
            m.work_offsets.as_ref().unwrap().values[&540],
            [-9.0, -20.0, -30.0]
        );
        let two = used.iter().find(|u| u.name == "tool 2").unwrap();
        assert!(two.from.ends_with("job.toml:8"), "{two:?}");
    }
}
