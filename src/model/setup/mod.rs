//! Set-ups: the values a shop changes per job rather than per machine (work offsets and
//! presets, tool lengths), layered over the machine file's (docs/file-formats.md,
//! "Set-up files").
//!
//! A set-up comes from nccomp's set-up file (TOML) or from the control's own tables:
//! LinuxCNC's parameter file (`.var`) and tool table (`.tbl`), Heidenhain's tool table
//! (`TOOL.T`) and preset table (`PRESET.PR`, through a set-up file that names the row).
//! Every value keeps the place it came from, so the summary can say which values a pass
//! used and from where.

pub mod linuxcnc;
pub mod setup_file;
pub mod tnc_tables;

use super::{Machine, WorkOffsets};
use crate::diag::Diagnostic;
use crate::{Error, Result};
use serde::Serialize;
use std::path::Path;

/// Where a value was read: a line of a file.
#[derive(Debug, Clone, PartialEq)]
pub struct Place {
    pub path: String,
    pub line: usize,
    pub column: usize,
    pub source_line: String,
}

impl Place {
    /// The place of byte `offset` of `text`, the file `path`.
    pub fn at(path: &str, text: &str, offset: usize) -> Self {
        let d = Diagnostic::at(path, text.as_bytes(), offset, "");
        Place {
            path: d.path,
            line: d.line,
            column: d.column,
            source_line: d.source_line,
        }
    }

    /// An error at this place.
    pub fn error(&self, message: impl Into<String>) -> Error {
        Error::Input(Box::new(Diagnostic {
            path: self.path.clone(),
            line: self.line,
            column: self.column,
            message: message.into(),
            source_line: self.source_line.clone(),
            code: None,
        }))
    }
}

impl std::fmt::Display for Place {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}:{}", self.path, self.line)
    }
}

/// A value a set-up gives for `key`, and where it was read.
#[derive(Debug, Clone, PartialEq)]
pub struct Given<K, V> {
    pub key: K,
    pub value: V,
    pub from: Place,
}

/// The values of one or more set-up files, in the order they were read: a later value of
/// the same key wins.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Setup {
    /// Work offsets (presets) by code ([`WorkOffsets::code`]), X Y Z in mm, machine
    /// coordinates.
    pub offsets: Vec<Given<i64, [f64; 3]>>,
    /// Tool lengths by number (G43 H, TOOL CALL n, T… D…), mm.
    pub lengths: Vec<Given<u32, f64>>,
    /// Tool lengths by name (TOOL CALL "name", T="name"), mm.
    pub named_lengths: Vec<Given<String, f64>>,
}

impl Setup {
    /// This set-up with `later`'s values over it.
    pub fn then(mut self, later: Setup) -> Setup {
        self.offsets.extend(later.offsets);
        self.lengths.extend(later.lengths);
        self.named_lengths.extend(later.named_lengths);
        self
    }

    pub fn is_empty(&self) -> bool {
        self.offsets.is_empty() && self.lengths.is_empty() && self.named_lengths.is_empty()
    }

    /// Put the set-up's values into `machine`, and say what each one replaced. Work
    /// offsets need the machine file's `[work_offsets]` (it says where the machine's
    /// geometry is given, which a set-up cannot); the geometry stays at the machine
    /// file's value of its offset.
    pub fn apply(&self, machine: &mut Machine) -> Result<Vec<Used>> {
        let mut used: Vec<Used> = Vec::new();
        let mut record = |u: Used| {
            // A later value of the same key replaces an earlier one in the summary too.
            used.retain(|e| e.name != u.name);
            used.push(u);
        };
        for g in &self.offsets {
            let Some(table) = machine.work_offsets.as_mut() else {
                return Err(g.from.error(format!(
                    "the set-up gives {}, but the machine file has no [work_offsets]: expected [work_offsets] in the machine file, with `geometry` naming the offset its geometry is given in (docs/file-formats.md)",
                    WorkOffsets::name(&g.key)
                )));
            };
            let before = table.values.insert(g.key, g.value);
            record(Used {
                name: WorkOffsets::name(&g.key),
                value: xyz(&g.value),
                from: g.from.to_string(),
                replaces: before.map(|v| xyz(&v)),
            });
        }
        for g in &self.lengths {
            let before = machine.tool.lengths.insert(g.key, g.value);
            record(Used {
                name: format!("tool {}", g.key),
                value: format!("{} mm", mm(g.value)),
                from: g.from.to_string(),
                replaces: before.map(|v| format!("{} mm", mm(v))),
            });
        }
        for g in &self.named_lengths {
            let before = machine.tool.named_lengths.insert(g.key.clone(), g.value);
            record(Used {
                name: format!("tool \"{}\"", g.key),
                value: format!("{} mm", mm(g.value)),
                from: g.from.to_string(),
                replaces: before.map(|v| format!("{} mm", mm(v))),
            });
        }
        Ok(used)
    }
}

/// A value a pass took from a set-up: what it is, its value, the file and line it came
/// from, and the machine file's (or an earlier set-up's) value it replaced, if any.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Used {
    pub name: String,
    pub value: String,
    pub from: String,
    pub replaces: Option<String>,
}

impl std::fmt::Display for Used {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} = {} ({}", self.name, self.value, self.from)?;
        match &self.replaces {
            Some(r) => write!(f, ", over {r})"),
            None => write!(f, ", not in the machine file)"),
        }
    }
}

/// The set-up values of a pass as one line of its summary (`set-up: …`): every value
/// given, at most `shown` of each file listed, the rest counted.
pub fn summary_line(used: &[Used]) -> Option<String> {
    if used.is_empty() {
        return None;
    }
    const SHOWN: usize = 8;
    let mut parts: Vec<String> = used.iter().take(SHOWN).map(|u| u.to_string()).collect();
    if used.len() > SHOWN {
        let mut files: Vec<&str> = used[SHOWN..]
            .iter()
            .map(|u| u.from.rsplit_once(':').map_or(u.from.as_str(), |(p, _)| p))
            .collect();
        files.dedup();
        parts.push(format!(
            "and {} more from {}",
            used.len() - SHOWN,
            files.join(", ")
        ));
    }
    Some(format!("set-up: {}", parts.join("; ")))
}

fn mm(v: f64) -> String {
    super::limits::shown(v)
}

fn xyz(v: &[f64; 3]) -> String {
    format!("X{} Y{} Z{}", mm(v[0]), mm(v[1]), mm(v[2]))
}

/// The kind of a set-up file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// nccomp's set-up file (`.toml`).
    Setup,
    /// LinuxCNC's parameter file (`.var`): the work offsets.
    LinuxcncVar,
    /// LinuxCNC's tool table (`.tbl`).
    LinuxcncTools,
    /// Heidenhain's tool table (`TOOL.T`, `.t`).
    TncTools,
    /// Heidenhain's preset table (`PRESET.PR`, `.pr`).
    TncPresets,
}

impl Format {
    /// The names a set-up file's `format` takes.
    pub const NAMES: [&'static str; 4] = [
        "linuxcnc-var",
        "linuxcnc-tbl",
        "heidenhain-tool-t",
        "heidenhain-preset-pr",
    ];

    /// The format of a file by its extension (case does not matter).
    pub fn of(path: &Path) -> Option<Format> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        Some(match ext.as_str() {
            "toml" => Format::Setup,
            "var" => Format::LinuxcncVar,
            "tbl" => Format::LinuxcncTools,
            "t" => Format::TncTools,
            "pr" => Format::TncPresets,
            _ => return None,
        })
    }

    /// The format a set-up file's `format = "…"` names.
    pub fn named(name: &str) -> Option<Format> {
        Some(match name {
            "linuxcnc-var" => Format::LinuxcncVar,
            "linuxcnc-tbl" => Format::LinuxcncTools,
            "heidenhain-tool-t" => Format::TncTools,
            "heidenhain-preset-pr" => Format::TncPresets,
            _ => return None,
        })
    }
}

/// The set-up in the file at `path` (its format by its extension), for `machine` (a
/// LinuxCNC table is in the machine file's `units`, as LinuxCNC's tables are in the
/// machine's units).
pub fn load(path: &Path, machine: &Machine) -> Result<Setup> {
    let name = path.display().to_string();
    let Some(format) = Format::of(path) else {
        return Err(Error::Usage(format!(
            "{name}: a set-up file's format is told by its extension: expected .toml (nccomp's set-up file), .var or .tbl (LinuxCNC's parameter file or tool table), .t (Heidenhain TOOL.T) or .pr (Heidenhain PRESET.PR, through a set-up file naming the row)"
        )));
    };
    let inch = machine.inch_default;
    match format {
        Format::Setup => setup_file::load(path, machine),
        Format::TncPresets => {
            let text = super::read_text(path, "preset table")?;
            Err(Error::at(
                &name,
                text.as_bytes(),
                0,
                "a preset table holds many presets: expected a set-up file naming the row the program runs in and where the control's basic coordinate system lies (`[tables] offsets = \"PRESET.PR\"`, `preset = N`, `basis = { X = …, Y = …, Z = … }`; docs/file-formats.md)",
            ))
        }
        other => table(path, other, inch, None),
    }
}

/// A control's table: `inch` for LinuxCNC tables in inches; for a preset table, the row
/// and the basis (the basic coordinate system's origin in machine coordinates).
pub(crate) fn table(
    path: &Path,
    format: Format,
    inch: bool,
    preset: Option<(u64, [f64; 3])>,
) -> Result<Setup> {
    let name = path.display().to_string();
    let text = super::read_text(path, "set-up table")?;
    match format {
        Format::LinuxcncVar => linuxcnc::parse_var(&text, &name, inch),
        Format::LinuxcncTools => linuxcnc::parse_tbl(&text, &name, inch),
        Format::TncTools => tnc_tables::parse_tool_t(&text, &name),
        Format::TncPresets => {
            let Some((row, basis)) = preset else {
                return Err(Error::at(
                    &name,
                    text.as_bytes(),
                    0,
                    "a preset table needs the row the program runs in: expected `preset = N` and `basis` beside it in the set-up file",
                ));
            };
            tnc_tables::parse_preset_pr(&text, &name, row, basis)
        }
        Format::Setup => Err(Error::Usage(format!(
            "{name}: a set-up file cannot name another set-up file as a table: expected a control's table (.var, .tbl, .t, .pr)"
        ))),
    }
}

/// The set-up files `paths`, in order (a later file's values over an earlier's).
pub fn load_all(paths: &[impl AsRef<Path>], machine: &Machine) -> Result<Setup> {
    let mut setup = Setup::default();
    for p in paths {
        setup = setup.then(load(p.as_ref(), machine)?);
    }
    Ok(setup)
}

/// A number as a control's table writes it (`+95.3`, `-0.5`, `12`), or `None`.
pub(crate) fn number(text: &str) -> Option<f64> {
    let t = text.strip_prefix('+').unwrap_or(text);
    if t.is_empty()
        || !t
            .bytes()
            .all(|b| b.is_ascii_digit() || b == b'.' || b == b'-')
    {
        return None;
    }
    t.parse::<f64>().ok().filter(|v| v.is_finite())
}

/// A length from a table, within the machine file's limits (mm).
pub(crate) fn length(v: f64, what: &str, from: &Place) -> Result<f64> {
    let l = super::limits::LENGTH_MM;
    if v.abs() > l {
        return Err(from.error(format!(
            "{what} is {v} mm: expected a number within ±{} mm (docs/file-formats.md, \"Limits\")",
            super::limits::shown(l)
        )));
    }
    Ok(v)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn machine() -> Machine {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/fixtures/head_head.machine.toml"
        );
        super::super::machine_file::load(Path::new(path)).unwrap()
    }

    fn place(line: usize) -> Place {
        Place {
            path: "a.toml".into(),
            line,
            column: 1,
            source_line: String::new(),
        }
    }

    #[test]
    fn a_later_value_wins_and_the_summary_says_what_it_replaced() {
        let mut m = machine();
        let first = Setup {
            lengths: vec![Given {
                key: 7,
                value: 100.0,
                from: place(1),
            }],
            ..Setup::default()
        };
        let second = Setup {
            lengths: vec![Given {
                key: 7,
                value: 101.5,
                from: place(4),
            }],
            ..Setup::default()
        };
        let used = first.then(second).apply(&mut m).unwrap();
        assert_eq!(m.tool.lengths[&7], 101.5);
        assert_eq!(used.len(), 1, "{used:?}");
        assert_eq!(used[0].from, "a.toml:4");
        let line = summary_line(&used).unwrap();
        assert!(
            line.starts_with("set-up: tool 7 = 101.5 mm (a.toml:4"),
            "{line}"
        );
    }

    #[test]
    fn offsets_without_a_work_offset_table_are_refused_at_their_place() {
        let mut m = machine();
        m.work_offsets = None;
        let setup = Setup {
            offsets: vec![Given {
                key: 540,
                value: [1.0, 2.0, 3.0],
                from: place(3),
            }],
            ..Setup::default()
        };
        let e = setup.apply(&mut m).unwrap_err().to_string();
        assert!(e.contains("a.toml:3:1"), "{e}");
        assert!(e.contains("has no [work_offsets]"), "{e}");
    }

    #[test]
    fn formats_by_extension() {
        assert_eq!(Format::of(Path::new("TOOL.T")), Some(Format::TncTools));
        assert_eq!(
            Format::of(Path::new("x/preset.pr")),
            Some(Format::TncPresets)
        );
        assert_eq!(Format::of(Path::new("emc.VAR")), Some(Format::LinuxcncVar));
        assert_eq!(Format::of(Path::new("a.tbl")), Some(Format::LinuxcncTools));
        assert_eq!(Format::of(Path::new("job.toml")), Some(Format::Setup));
        assert_eq!(Format::of(Path::new("job.txt")), None);
        for n in Format::NAMES {
            assert!(Format::named(n).is_some());
        }
    }

    #[test]
    fn table_numbers() {
        assert_eq!(number("+95.3"), Some(95.3));
        assert_eq!(number("-0.5"), Some(-0.5));
        assert_eq!(number("12"), Some(12.0));
        assert_eq!(number("1e3"), None);
        assert_eq!(number(""), None);
        assert_eq!(number("abc"), None);
    }
}
