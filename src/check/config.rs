//! `nccomp.toml`: one config for a shop's NC library. It maps program patterns to the
//! machine, error file, set-up and options each program is checked with, so that
//! `nccomp check` with no arguments checks the whole library in one run
//! (docs/ci.md, "One config for the whole library").
//!
//! ```toml
//! library = ["**/*.h", "**/*.nc"]        # the programs of the library (default: NC files)
//!
//! [defaults]                             # options of every entry
//! max_angle = 50.0
//!
//! [[programs]]
//! paths = "dmu85/**/*.h"                 # a pattern or an array of them
//! machine = "machines/dmu85.machine.toml"
//! errors = "machines/dmu85.errors.toml"  # left out: the one the machine file names
//! setup = "setups/dmu85.setup.toml"      # a file or an array of them
//! max_error = 0.005
//! ```
//!
//! Paths and patterns are relative to the config's directory. A program goes to the
//! first entry whose `paths` match it; a program of the library that no entry claims is
//! refused.

use super::settings::Settings;
use crate::diag::Error;
use crate::model::machine_file::{Bounds, Doc};
use std::ops::Range;
use std::path::{Path, PathBuf};
use toml::Spanned;
use toml::de::{DeTable, DeValue};

/// The config's file name, looked for from the current directory upwards.
pub const FILE_NAME: &str = "nccomp.toml";

/// The library when the config does not say: files with the extensions NC programs
/// have (case does not matter), in any directory but hidden ones.
pub const LIBRARY: [&str; 13] = [
    "**/*.nc",
    "**/*.ngc",
    "**/*.tap",
    "**/*.cnc",
    "**/*.eia",
    "**/*.iso",
    "**/*.ncd",
    "**/*.gcode",
    "**/*.h",
    "**/*.i",
    "**/*.mpf",
    "**/*.spf",
    "**/*.min",
];

/// A config, read and checked.
#[derive(Debug, Clone)]
pub struct Config {
    /// The config file, as found or given.
    pub path: PathBuf,
    /// The library's patterns, relative to the config's directory.
    pub library: Vec<String>,
    pub defaults: Settings,
    pub entries: Vec<Entry>,
}

/// A `[[programs]]` entry.
#[derive(Debug, Clone)]
pub struct Entry {
    /// 1-based, in file order (as messages name it).
    pub number: usize,
    pub paths: Vec<String>,
    /// Relative to the config's directory, joined to it.
    pub machine: PathBuf,
    pub errors: Option<PathBuf>,
    pub settings: Settings,
}

/// A program of the library and the entry that claims it (an index into
/// [`Config::entries`]), or `None` when none does.
#[derive(Debug, Clone, PartialEq)]
pub struct Claim {
    pub path: PathBuf,
    pub entry: Option<usize>,
}

/// The config in `start` or the nearest directory above it, up to the repository's root
/// (the first directory with a `.git`) or the file system's root.
pub fn discover(start: &Path) -> Option<PathBuf> {
    let mut dir = start.to_path_buf();
    let mut real = std::fs::canonicalize(start).ok()?;
    loop {
        let candidate = dir.join(FILE_NAME);
        if candidate.is_file() {
            return Some(
                candidate
                    .strip_prefix("./")
                    .map_or(candidate.clone(), Path::to_path_buf),
            );
        }
        if real.join(".git").exists() || !real.pop() {
            return None;
        }
        dir = dir.join("..");
    }
}

impl Config {
    /// The directory paths in the config are relative to.
    pub fn dir(&self) -> &Path {
        self.path.parent().unwrap_or(Path::new(""))
    }

    pub fn load(path: &Path) -> crate::Result<Config> {
        let text = crate::model::read_text(path, "config")?;
        Config::parse(&text, path)
    }

    /// Check the config `text`, the file `path`.
    pub fn parse(text: &str, path: &Path) -> crate::Result<Config> {
        let name = path.display().to_string();
        let doc = Doc { path: &name, text };
        let root = doc.parse()?;
        let root = root.get_ref();
        doc.check_keys(root, &["library", "defaults", "programs"], "nccomp.toml")?;
        let dir = path.parent().unwrap_or(Path::new(""));
        let library = match root.get("library") {
            Some(v) => patterns(&doc, v, "`library`")?
                .into_iter()
                .map(|(p, _)| p)
                .collect(),
            None => LIBRARY.iter().map(|p| p.to_string()).collect(),
        };
        let defaults = match root.get("defaults") {
            Some(v) => {
                let t = doc.table(
                    v,
                    "[defaults], a table of options such as `max_angle = 50.0`",
                )?;
                doc.check_keys(t, OPTIONS, "[defaults]")?;
                settings(&doc, t, dir, "[defaults]")?
            }
            None => Settings::default(),
        };
        let Some(programs) = root.get("programs") else {
            return Err(doc.err(
                0..0,
                "no [[programs]] entry: expected at least one, such as [[programs]] paths = \"dmu85/**/*.h\" machine = \"dmu85.machine.toml\"",
            ));
        };
        let array = programs.get_ref().as_array().ok_or_else(|| {
            doc.err(
                programs.span(),
                "`programs`: expected [[programs]] entries (an array of tables)",
            )
        })?;
        let mut entries = Vec::new();
        for (i, v) in array.iter().enumerate() {
            let place = format!("[[programs]] entry {}", i + 1);
            let t = doc.table(v, &format!("{place}, a table with `paths` and `machine`"))?;
            let mut keys = vec!["paths", "machine", "errors"];
            keys.extend(OPTIONS);
            doc.check_keys(t, &keys, &place)?;
            let need = |key: &str| {
                t.get(key).ok_or_else(|| {
                    doc.err(v.span(), format!("{place} has no `{key}`: expected `paths` (patterns of the programs it claims) and `machine` (their machine file)"))
                })
            };
            let paths = patterns(&doc, need("paths")?, &format!("`paths` of {place}"))?;
            for (p, span) in &paths {
                if glob::Pattern::new(p).is_err() {
                    return Err(doc.err(
                        span.clone(),
                        format!(
                            "`{p}` is not a valid pattern: expected a glob such as \"dmu85/**/*.h\""
                        ),
                    ));
                }
            }
            let machine = dir.join(doc.string(need("machine")?, &format!("`machine` of {place}"))?);
            let errors = t
                .get("errors")
                .map(|e| {
                    doc.string(e, &format!("`errors` of {place}"))
                        .map(|e| dir.join(e))
                })
                .transpose()?;
            entries.push(Entry {
                number: i + 1,
                paths: paths.into_iter().map(|(p, _)| p).collect(),
                machine,
                errors,
                settings: settings(&doc, t, dir, &place)?,
            });
        }
        Ok(Config {
            path: path.to_path_buf(),
            library,
            defaults,
            entries,
        })
    }

    /// Every program of the library (the files the `library` patterns match) and every
    /// file an entry's `paths` match, sorted, each with the first entry that claims it.
    pub fn claims(&self) -> crate::Result<Vec<Claim>> {
        let dir = self.dir();
        let mut files: Vec<PathBuf> = Vec::new();
        let every = self
            .library
            .iter()
            .chain(self.entries.iter().flat_map(|e| e.paths.iter()));
        for pattern in every {
            let full = dir.join(pattern);
            let text = full.to_string_lossy();
            let found = glob::glob_with(&text, match_options()).map_err(|e| {
                Error::Usage(format!(
                    "`{pattern}` in {}: not a valid pattern: {e}",
                    self.path.display()
                ))
            })?;
            for entry in found {
                let path = entry.map_err(|e| {
                    let path = e.path().to_path_buf();
                    Error::io(&path, e.into())
                })?;
                if !path.is_dir() {
                    files.push(path);
                }
            }
        }
        files.sort();
        files.dedup();
        let entry_patterns: Vec<Vec<glob::Pattern>> = self
            .entries
            .iter()
            .map(|e| {
                e.paths
                    .iter()
                    .filter_map(|p| glob::Pattern::new(&dir.join(p).to_string_lossy()).ok())
                    .collect()
            })
            .collect();
        Ok(files
            .into_iter()
            .map(|path| {
                let entry = entry_patterns.iter().position(|ps| {
                    ps.iter()
                        .any(|p| p.matches_path_with(&path, match_options()))
                });
                Claim { path, entry }
            })
            .collect())
    }

    /// The entry that claims `path` (a path as given on the command line): the first whose
    /// patterns match it, compared from the config's directory.
    pub fn claim(&self, path: &Path) -> Option<usize> {
        let dir = match self.dir() {
            d if d.as_os_str().is_empty() => Path::new("."),
            d => d,
        };
        let dir = std::fs::canonicalize(dir).ok()?;
        let file = std::fs::canonicalize(path).ok()?;
        self.entries.iter().position(|e| {
            e.paths.iter().any(|p| {
                glob::Pattern::new(&dir.join(p).to_string_lossy())
                    .is_ok_and(|pat| pat.matches_path_with(&file, match_options()))
            })
        })
    }
}

/// `*` stays within a directory, `**` crosses them; hidden directories and files are
/// matched only by a pattern that names them; case does not matter (`.H` and `.h`).
fn match_options() -> glob::MatchOptions {
    glob::MatchOptions {
        case_sensitive: false,
        require_literal_separator: true,
        require_literal_leading_dot: true,
    }
}

/// The options an entry and `[defaults]` may give.
const OPTIONS: &[&str] = &[
    "tolerance",
    "angular_tolerance",
    "tool_chain",
    "hold",
    "allow_limit_violations",
    "dialect",
    "block_delete",
    "setup",
    "max_error",
    "max_angle",
    "allow_unread",
];

/// A pattern or an array of them, each with its span.
fn patterns(
    doc: &Doc,
    v: &Spanned<DeValue>,
    what: &str,
) -> crate::Result<Vec<(String, Range<usize>)>> {
    let expected =
        format!("{what}: expected a pattern or an array of patterns such as \"dmu85/**/*.h\"");
    let one = |v: &Spanned<DeValue>| match v.get_ref() {
        DeValue::String(s) if !s.is_empty() => Ok((s.to_string(), v.span())),
        _ => Err(doc.err(v.span(), expected.clone())),
    };
    match v.get_ref() {
        DeValue::Array(a) if !a.is_empty() => a.iter().map(one).collect(),
        DeValue::Array(_) => Err(doc.err(v.span(), expected.clone())),
        _ => Ok(vec![one(v)?]),
    }
}

fn positive(
    doc: &Doc,
    t: &DeTable,
    key: &str,
    place: &str,
    unit: &str,
) -> crate::Result<Option<f64>> {
    let Some(v) = t.get(key) else { return Ok(None) };
    let x = doc.number_in(
        v,
        &format!("`{key}` of {place}"),
        Bounds {
            lo: 0.0,
            hi: 1e6,
            unit,
        },
    )?;
    if x <= 0.0 {
        return Err(doc.err(
            v.span(),
            format!("`{key}` of {place}: expected a positive number ({unit})"),
        ));
    }
    Ok(Some(x))
}

fn flag(doc: &Doc, t: &DeTable, key: &str, place: &str) -> crate::Result<Option<bool>> {
    let Some(v) = t.get(key) else { return Ok(None) };
    match v.get_ref() {
        DeValue::Boolean(b) => Ok(Some(*b)),
        _ => Err(doc.err(
            v.span(),
            format!("`{key}` of {place}: expected true or false"),
        )),
    }
}

fn settings(doc: &Doc, t: &DeTable, dir: &Path, place: &str) -> crate::Result<Settings> {
    let tolerance = match t.get("tolerance") {
        Some(v) if v.get_ref().as_str() == Some("off") => Some(None),
        Some(_) => Some(positive(doc, t, "tolerance", place, "mm")?),
        None => None,
    };
    let dialect = match t.get("dialect") {
        Some(v) => Some(match doc.string(v, &format!("`dialect` of {place}"))? {
            "auto" => None,
            "iso" => Some(crate::nc::Dialect::Iso),
            "heidenhain" => Some(crate::nc::Dialect::Heidenhain),
            "sinumerik" => Some(crate::nc::Dialect::Sinumerik),
            other => {
                return Err(doc.err(v.span(), format!("`{other}` in `dialect` of {place}: expected \"auto\", \"iso\", \"heidenhain\" or \"sinumerik\"")));
            }
        }),
        None => None,
    };
    let block_delete = match t.get("block_delete") {
        Some(v) => Some(
            match doc.string(v, &format!("`block_delete` of {place}"))? {
                "on" => true,
                "off" => false,
                other => {
                    return Err(doc.err(
                        v.span(),
                        format!(
                            "`{other}` in `block_delete` of {place}: expected \"on\" or \"off\""
                        ),
                    ));
                }
            },
        ),
        None => None,
    };
    let strings = |key: &str| -> crate::Result<Option<Vec<String>>> {
        let Some(v) = t.get(key) else { return Ok(None) };
        let what = format!("`{key}` of {place}: expected a string or an array of strings");
        let one = |v: &Spanned<DeValue>| {
            v.get_ref()
                .as_str()
                .map(str::to_string)
                .ok_or_else(|| doc.err(v.span(), what.clone()))
        };
        match v.get_ref() {
            DeValue::Array(a) => a
                .iter()
                .map(one)
                .collect::<crate::Result<Vec<_>>>()
                .map(Some),
            _ => Ok(Some(vec![one(v)?])),
        }
    };
    let tool_chain = match t.get("tool_chain") {
        Some(v) => Some(
            doc.string(v, &format!("`tool_chain` of {place}"))?
                .to_string(),
        ),
        None => None,
    };
    Ok(Settings {
        tolerance,
        angular_tolerance: positive(doc, t, "angular_tolerance", place, "µrad")?,
        tool_chain,
        hold: strings("hold")?,
        allow_limit_violations: flag(doc, t, "allow_limit_violations", place)?,
        dialect,
        block_delete,
        setup: strings("setup")?.map(|s| s.iter().map(|f| dir.join(f)).collect()),
        max_error: positive(doc, t, "max_error", place, "mm")?,
        max_angle: positive(doc, t, "max_angle", place, "µrad")?,
        allow_unread: flag(doc, t, "allow_unread", place)?,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const CONFIG: &str = r#"
[defaults]
max_angle = 50.0
tolerance = "off"

[[programs]]
paths = "dmu85/**/*.h"
machine = "m/dmu85.machine.toml"
setup = ["s/a.toml", "s/b.tbl"]
max_error = 0.005

[[programs]]
paths = ["**/*.nc", "**/*.h"]
machine = "m/haas.machine.toml"
errors = "m/haas.errors.toml"
"#;

    #[test]
    fn entries_and_defaults() {
        let c = Config::parse(CONFIG, Path::new("shop/nccomp.toml")).unwrap();
        assert_eq!(c.entries.len(), 2);
        assert_eq!(c.entries[0].machine, Path::new("shop/m/dmu85.machine.toml"));
        assert_eq!(c.entries[0].errors, None);
        assert_eq!(
            c.entries[1].errors.as_deref(),
            Some(Path::new("shop/m/haas.errors.toml"))
        );
        assert_eq!(
            c.entries[0].settings.setup_files()[1],
            Path::new("shop/s/b.tbl")
        );
        let s = c.entries[0].settings.clone().over(&c.defaults);
        let t = s.thresholds().unwrap();
        assert_eq!((t.max_error_mm, t.max_angle_urad), (0.005, Some(50.0)));
        assert!(s.options().unwrap().path.is_none());
        assert_eq!(c.library.len(), LIBRARY.len());
    }

    #[test]
    fn the_first_entry_that_matches_claims_and_others_are_refused_later() {
        let dir = tempfile::tempdir().unwrap();
        for f in [
            "dmu85/a/x.h",
            "dmu85/y.H",
            "other/z.nc",
            "loose.ngc",
            ".hidden/q.nc",
            "notes.txt",
        ] {
            let p = dir.path().join(f);
            std::fs::create_dir_all(p.parent().unwrap()).unwrap();
            std::fs::write(p, "").unwrap();
        }
        let path = dir.path().join(FILE_NAME);
        std::fs::write(&path, CONFIG).unwrap();
        let c = Config::load(&path).unwrap();
        let claims: Vec<(String, Option<usize>)> = c
            .claims()
            .unwrap()
            .into_iter()
            .map(|c| {
                (
                    c.path
                        .strip_prefix(dir.path())
                        .unwrap()
                        .display()
                        .to_string(),
                    c.entry,
                )
            })
            .collect();
        assert_eq!(
            claims,
            [
                ("dmu85/a/x.h".to_string(), Some(0)),
                ("dmu85/y.H".to_string(), Some(0)),
                ("loose.ngc".to_string(), None),
                ("other/z.nc".to_string(), Some(1)),
            ]
        );
        assert_eq!(c.claim(&dir.path().join("dmu85/a/x.h")), Some(0));
        assert_eq!(c.claim(&dir.path().join("loose.ngc")), None);
        let inner = dir.path().join("dmu85/a");
        assert_eq!(discover(&inner), Some(inner.join("../..").join(FILE_NAME)));
    }

    #[test]
    fn refusals_are_located() {
        let cases = [
            (
                "[[programs]]\nmachine = \"m.toml\"\n",
                "c.toml:1:1",
                "has no `paths`",
            ),
            (
                "[[programs]]\npaths = []\nmachine = \"m\"\n",
                "c.toml:2:9",
                "expected a pattern",
            ),
            (
                "[[programs]]\npaths = \"a[\"\nmachine = \"m\"\n",
                "c.toml:2:9",
                "not a valid pattern",
            ),
            (
                "[[programs]]\npaths = \"*\"\nmachine = \"m\"\nmax_angel = 3\n",
                "c.toml:4:1",
                "did you mean `max_angle`",
            ),
            ("[defaults]\nmax_error = -1\n", "c.toml:2:13", "max_error"),
            (
                "[defaults]\nblock_delete = \"maybe\"\n",
                "c.toml:2:16",
                "expected \"on\" or \"off\"",
            ),
            (
                "library = \"*.nc\"\n",
                "c.toml:1:1",
                "no [[programs]] entry",
            ),
        ];
        for (text, at, what) in cases {
            let e = Config::parse(text, Path::new("c.toml"))
                .unwrap_err()
                .to_string();
            assert!(e.contains(at) && e.contains(what), "{text:?}: {e}");
        }
    }
}
