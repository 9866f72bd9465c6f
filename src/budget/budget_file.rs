//! Budget files: what the error budget of a machine is computed from (docs/budget.md).
//!
//! ```toml
//! length_unit = "um"            # of ranges, bounds and the loss's `at`; default um
//! angle_unit = "urad"           # default urad
//! direction = [0, 0, 1]         # the error that matters (workpiece frame); default Z
//! # tool_chain = "upper"        # default the machine's first
//! # tool_length = 0.0           # mm; default the machine's reference tool
//!
//! [poses]                       # default: grid = 3
//! grid = 3                      # points per axis over its travel, every combination
//! # at = [{ X = 50, Y = 45, Z = 5 }]   # or these poses
//!
//! [ranges]                      # three levels, or [min, max] (levels min, middle, max)
//! EZZ = [5, 9, 13]
//! EBX = [2, 8]
//!
//! [ranking]                     # all optional
//! samples = 4096                # Sobol base sample
//! seed = 2016
//! alpha = 0.01                  # significance of a key error (ANOVA)
//! min_share = 0.0001            # smallest share of the variance for a key error
//!
//! [tolerance]
//! weight = 0.7                  # W
//! lambda = 1.0                  # λ, use cost per unit of quality loss
//! quality_loss = { cost = 1.0, at = 2.0 }   # K = cost / at², `at` in length_unit
//! # samples = 0                 # response-surface sample, 0: 3 per coefficient
//! # seed = 2016
//!
//! [tolerance.terms]             # bounds of the tolerance band (T = 6σ), cost curve
//! EZZ = { bounds = [5, 15], cost = "positioning" }
//! EBX = { bounds = [0, 40], cost = "plane", length = 1000 }   # 0.04/1000
//! ```
//!
//! Every problem is reported at its place in the file (`path:line:col: message`), like
//! machine and error files; term names are checked against the machine through
//! [`crate::model::terms`].

use super::ranking::RankingOptions;
use super::tolerance::{CostCurve, TolTerm, ToleranceOptions};
use super::{Poses, Term};
use crate::kinematics::Kinematics;
use crate::model::error_file::Units;
use crate::model::machine_file::{Doc, describe};
use crate::model::terms::{self, Quantity, suggest};
use crate::model::{ErrorModel, Machine};
use crate::{Error, Result};
use nalgebra::Vector3;
use std::path::Path;
use toml::Spanned;
use toml::de::{DeTable, DeValue};

/// A checked budget file, in model units (mm, rad).
#[derive(Debug, Clone)]
pub struct Budget {
    /// Index of the tool chain in [`Machine::tool_chains`].
    pub chain: usize,
    /// Machine axis indices of the active configuration.
    pub active: Vec<usize>,
    /// Active tool length, mm.
    pub tool_length: f64,
    pub poses: Poses,
    /// Terms with their three levels, in file order.
    pub ranges: Vec<(Term, [f64; 3])>,
    pub ranking: RankingOptions,
    pub tolerance: Option<ToleranceSpec>,
    /// The file's unit names, for reports: length, angle.
    pub units: [String; 2],
    /// mm and rad per file unit.
    pub factors: [f64; 2],
}

/// The [tolerance] part of a budget file.
#[derive(Debug, Clone)]
pub struct ToleranceSpec {
    pub options: ToleranceOptions,
    pub terms: Vec<(Term, TolTerm)>,
}

/// Read and check a budget file for `machine`; `tool_chain` (a chain name) overrides the
/// file's.
pub fn load(path: &Path, machine: &Machine, tool_chain: Option<&str>) -> Result<Budget> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    parse(&text, &path.display().to_string(), machine, tool_chain)
}

/// Check the budget file `text`; `path` names it in messages.
pub fn parse(
    text: &str,
    path: &str,
    machine: &Machine,
    tool_chain: Option<&str>,
) -> Result<Budget> {
    let doc = Doc { path, text };
    let root = doc.parse()?;
    let root = root.get_ref();
    doc.check_keys(
        root,
        &[
            "length_unit",
            "angle_unit",
            "direction",
            "tool_chain",
            "tool_length",
            "poses",
            "ranges",
            "ranking",
            "tolerance",
        ],
        "the budget file",
    )?;
    let units = Units::read(&doc, root)?;
    let (lf, ln) = units.of(Quantity::Length);
    let (af, an) = units.of(Quantity::Angle);
    let (lf, af, ln, an) = (lf, af, ln.to_string(), an.to_string());
    let factor = |t: &Term| if t.is_length() { lf } else { af };

    // The active configuration.
    let chain_name = |name: &str, span: std::ops::Range<usize>| {
        machine.tool_chain(name).ok_or_else(|| {
            let names: Vec<String> = machine.tool_chains.iter().map(|c| c.name.clone()).collect();
            doc.err(
                span,
                format!(
                    "the machine has no tool chain `{name}`: expected {}",
                    terms::or_list(&names)
                ),
            )
        })
    };
    let chain = match (tool_chain, root.get("tool_chain")) {
        (Some(name), _) => machine.tool_chain(name).ok_or_else(|| {
            let names: Vec<String> = machine.tool_chains.iter().map(|c| c.name.clone()).collect();
            Error::Usage(format!(
                "the machine has no tool chain `{name}`: expected {}",
                terms::or_list(&names)
            ))
        })?,
        (None, Some(v)) => chain_name(doc.string(v, "`tool_chain`")?, v.span())?,
        (None, None) => 0,
    };
    let active = Kinematics::new(machine, &ErrorModel::zero(machine), chain)
        .map_err(|e| Error::Usage(e.to_string()))?
        .axes()
        .to_vec();
    let tool_length = match root.get("tool_length") {
        Some(v) => doc.number(v, "`tool_length` (mm)")?,
        None => machine.tool.length,
    };
    let direction = match root.get("direction") {
        Some(v) => unit_vector(&doc, v, "`direction`")?,
        None => Vector3::z(),
    };

    let poses = match root.get("poses") {
        Some(v) => poses(&doc, v, machine, &active)?,
        None => Poses::Grid(3),
    };

    // Ranges.
    let mut ranges = Vec::new();
    if let Some(v) = root.get("ranges") {
        let table = doc.table(v, "[ranges], a table of term = [min, max] or [l1, l2, l3]")?;
        for (key, value) in table.iter() {
            let term = term(&doc, key, machine, &active)?;
            let unit = if term.is_length() { &ln } else { &an };
            let what = format!("the range of `{}` ({unit})", term.name);
            let values = doc.numbers(value, &what)?;
            let f = factor(&term);
            let levels = match values.as_slice() {
                [(lo, _), (hi, hs)] => {
                    if lo > hi {
                        return Err(doc.err(
                            hs.clone(),
                            format!("{what}: [{lo}, {hi}]: expected min ≤ max"),
                        ));
                    }
                    [*lo, (lo + hi) / 2.0, *hi]
                }
                [(a, _), (b, _), (c, _)] => [*a, *b, *c],
                _ => {
                    return Err(doc.err(
                        value.span(),
                        format!(
                            "{what} has {} numbers: expected [min, max] or three levels \
                             [l1, l2, l3]",
                            values.len()
                        ),
                    ));
                }
            };
            ranges.push((term, levels.map(|l| convert(l, f))));
        }
    }

    // Ranking options.
    let mut ranking = RankingOptions {
        direction,
        ..RankingOptions::default()
    };
    if let Some(v) = root.get("ranking") {
        let t = doc.table(v, "[ranking], a table of options")?;
        doc.check_keys(t, &["samples", "seed", "alpha", "min_share"], "[ranking]")?;
        if let Some(v) = t.get("samples") {
            ranking.samples = count(&doc, v, "`samples`", 2)?;
        }
        if let Some(v) = t.get("seed") {
            ranking.seed = count(&doc, v, "`seed`", 0)? as u64;
        }
        if let Some(v) = t.get("alpha") {
            ranking.alpha = open_fraction(&doc, v, "`alpha`")?;
        }
        if let Some(v) = t.get("min_share") {
            let x = doc.number(v, "`min_share`")?;
            if !(0.0..1.0).contains(&x) {
                return Err(doc.err(
                    v.span(),
                    format!("`min_share = {x}`: expected a fraction in [0, 1), such as 0.0001"),
                ));
            }
            ranking.min_share = x;
        }
    }

    let tolerance = match root.get("tolerance") {
        Some(v) => Some(tolerance(
            &doc,
            v,
            machine,
            &active,
            direction,
            [lf, af],
            [&ln, &an],
        )?),
        None => None,
    };

    Ok(Budget {
        chain,
        active,
        tool_length,
        poses,
        ranges,
        ranking,
        tolerance,
        units: [ln, an],
        factors: [lf, af],
    })
}

/// `v` file units in model units, `f` model units per file unit. A factor that is the
/// inverse of a whole number (µm, µrad) divides, so 9 µm is 0.009 mm to the last digit.
fn convert(v: f64, f: f64) -> f64 {
    let inverse = 1.0 / f;
    if f < 1.0 && (inverse - inverse.round()).abs() < 1e-6 {
        v / inverse.round()
    } else {
        v * f
    }
}

fn term(
    doc: &Doc,
    key: &Spanned<std::borrow::Cow<str>>,
    machine: &Machine,
    active: &[usize],
) -> Result<Term> {
    Term::new(machine, active, key.get_ref()).map_err(|m| doc.err(key.span(), m))
}

fn unit_vector(doc: &Doc, v: &Spanned<DeValue>, what: &str) -> Result<Vector3<f64>> {
    let d = doc.vec3(v, what)?;
    let n = d.norm();
    if n == 0.0 {
        return Err(doc.err(
            v.span(),
            format!("{what} is the zero vector: expected a direction such as [0, 0, 1]"),
        ));
    }
    Ok(d / n)
}

/// A non-negative integer at least `min`.
fn count(doc: &Doc, v: &Spanned<DeValue>, what: &str, min: usize) -> Result<usize> {
    let n = match v.get_ref() {
        DeValue::Integer(i) => i64::from_str_radix(i.as_str(), i.radix()).ok(),
        other => {
            return Err(doc.err(
                v.span(),
                format!("{what}: expected an integer, found {}", describe(other)),
            ));
        }
    };
    match n {
        Some(n) if n >= min as i64 => Ok(n as usize),
        _ => Err(doc.err(
            v.span(),
            format!(
                "{what} is {}: expected an integer of at least {min}",
                &doc.text[v.span()]
            ),
        )),
    }
}

/// A number in (0, 1).
fn open_fraction(doc: &Doc, v: &Spanned<DeValue>, what: &str) -> Result<f64> {
    let x = doc.number(v, what)?;
    if x <= 0.0 || x >= 1.0 {
        return Err(doc.err(
            v.span(),
            format!("{what} is {x}: expected a number between 0 and 1"),
        ));
    }
    Ok(x)
}

fn poses(doc: &Doc, v: &Spanned<DeValue>, machine: &Machine, active: &[usize]) -> Result<Poses> {
    let t = doc.table(v, "[poses], with `grid = N` or `at = [{ X = ..., ... }]`")?;
    doc.check_keys(t, &["grid", "at"], "[poses]")?;
    match (t.get_key_value("grid"), t.get_key_value("at")) {
        (Some(_), Some((k, _))) => Err(doc.err(
            k.span(),
            "[poses]: give either `grid = N` or `at = [...]`, not both",
        )),
        (Some((_, g)), None) => Ok(Poses::Grid(count(doc, g, "`grid`", 1)?)),
        (None, Some((_, a))) => {
            let array = a.get_ref().as_array().ok_or_else(|| {
                doc.err(
                    a.span(),
                    format!(
                        "`at`: expected an array of poses such as [{{ X = 50, Y = 45 }}], found \
                         {}",
                        describe(a.get_ref())
                    ),
                )
            })?;
            if array.is_empty() {
                return Err(doc.err(a.span(), "`at` is empty: expected at least one pose"));
            }
            let names: Vec<&str> = active
                .iter()
                .map(|&i| machine.axes[i].name.as_str())
                .collect();
            let mut out = Vec::new();
            for pose in array.iter() {
                let table: &DeTable =
                    doc.table(pose, "a pose, a table such as { X = 50, Y = 45 }")?;
                let mut q = vec![0.0; active.len()];
                for (key, value) in table.iter() {
                    let name: &str = key.get_ref();
                    let Some(k) = names.iter().position(|n| *n == name) else {
                        let hint = match suggest(name, names.iter().copied()) {
                            Some(s) => format!("did you mean {s}? "),
                            None => String::new(),
                        };
                        return Err(doc.err(
                            key.span(),
                            format!(
                                "no axis `{name}` in the active configuration: {hint}the axes \
                                 are {}",
                                names.join(", ")
                            ),
                        ));
                    };
                    q[k] = doc.number(value, &format!("the position of axis {name}"))?;
                }
                out.push(q);
            }
            Ok(Poses::At(out))
        }
        (None, None) => Ok(Poses::Grid(3)),
    }
}

fn tolerance(
    doc: &Doc,
    v: &Spanned<DeValue>,
    machine: &Machine,
    active: &[usize],
    direction: Vector3<f64>,
    factors: [f64; 2],
    units: [&str; 2],
) -> Result<ToleranceSpec> {
    let t = doc.table(
        v,
        "[tolerance], a table with `quality_loss` and [tolerance.terms]",
    )?;
    doc.check_keys(
        t,
        &[
            "weight",
            "lambda",
            "quality_loss",
            "samples",
            "seed",
            "terms",
        ],
        "[tolerance]",
    )?;
    let mut options = ToleranceOptions {
        direction,
        weight: 0.7,
        lambda: 1.0,
        loss: 0.0,
        samples: 0,
        seed: 2016,
    };
    if let Some(v) = t.get("weight") {
        options.weight = open_fraction(doc, v, "`weight` (W)")?;
    }
    if let Some(v) = t.get("lambda") {
        let x = doc.number(v, "`lambda` (λ)")?;
        if x < 0.0 {
            return Err(doc.err(v.span(), format!("`lambda` is {x}: expected λ ≥ 0")));
        }
        options.lambda = x;
    }
    if let Some(v) = t.get("samples") {
        options.samples = count(doc, v, "`samples`", 0)?;
    }
    if let Some(v) = t.get("seed") {
        options.seed = count(doc, v, "`seed`", 0)? as u64;
    }
    let loss_hint = "expected `quality_loss = { cost = A, at = Δ }`: a part whose error along \
                     the direction is Δ loses A (Taguchi's K = A/Δ²)";
    let Some(lv) = t.get("quality_loss") else {
        return Err(doc.err(
            v.span(),
            format!("[tolerance] has no `quality_loss`: {loss_hint}"),
        ));
    };
    let lt = doc.table(lv, &format!("`quality_loss`: {loss_hint}"))?;
    doc.check_keys(lt, &["cost", "at"], "`quality_loss`")?;
    let positive = |key: &str, what: &str| -> Result<f64> {
        let Some(x) = lt.get(key) else {
            return Err(doc.err(
                lv.span(),
                format!("`quality_loss` has no `{key}`: {loss_hint}"),
            ));
        };
        let value = doc.number(x, what)?;
        if value <= 0.0 {
            return Err(doc.err(
                x.span(),
                format!("{what} is {value}: expected a positive number"),
            ));
        }
        Ok(value)
    };
    let cost = positive("cost", "the quality loss `cost`")?;
    let at = convert(
        positive("at", &format!("the quality loss `at` ({})", units[0]))?,
        factors[0],
    );
    options.loss = cost / (at * at);

    let Some(tv) = t.get("terms") else {
        return Err(doc.err(
            v.span(),
            "[tolerance] has no [tolerance.terms]: expected the key errors with their bounds, \
             such as `EZZ = { bounds = [5, 15], cost = \"positioning\" }`",
        ));
    };
    let table = doc.table(tv, "[tolerance.terms], a table of term = { bounds, cost }")?;
    if table.is_empty() {
        return Err(doc.err(
            tv.span(),
            "[tolerance.terms] is empty: expected at least one key error",
        ));
    }
    let mut terms = Vec::new();
    for (key, value) in table.iter() {
        let term = term(doc, key, machine, active)?;
        let (f, unit) = if term.is_length() {
            (factors[0], units[0])
        } else {
            (factors[1], units[1])
        };
        let what = format!("[tolerance.terms] `{}`", term.name);
        let spec = doc.table(
            value,
            &format!("{what}: a table {{ bounds = [min, max], cost = \"plane\" }}"),
        )?;
        doc.check_keys(spec, &["bounds", "cost", "length", "start"], &what)?;
        let Some(bv) = spec.get("bounds") else {
            return Err(doc.err(
                value.span(),
                format!("{what} has no `bounds`: expected `bounds = [min, max]` in {unit}"),
            ));
        };
        let b = doc.numbers(bv, &format!("the bounds of `{}` ({unit})", term.name))?;
        let [(lo, _), (hi, _)] = b.as_slice() else {
            return Err(doc.err(
                bv.span(),
                format!(
                    "the bounds of `{}` have {} numbers: expected [min, max]",
                    term.name,
                    b.len()
                ),
            ));
        };
        if !(*lo >= 0.0 && lo < hi) {
            return Err(doc.err(
                bv.span(),
                format!("the bounds [{lo}, {hi}] of `{}`: expected 0 ≤ min < max (a tolerance is the width of a band)", term.name),
            ));
        }
        let curve = match spec.get("cost") {
            None => {
                return Err(doc.err(value.span(), format!("{what} has no `cost`: expected `cost = \"plane\"` or `cost = \"positioning\"`")));
            }
            Some(c) => {
                match doc.string(c, "`cost`")? {
                    "plane" => CostCurve::Plane,
                    "positioning" => CostCurve::Positioning,
                    other => {
                        return Err(doc.err(
                        c.span(),
                        format!("unknown cost curve `{other}`: expected \"plane\" or \"positioning\""),
                    ));
                    }
                }
            }
        };
        let length = match spec.get_key_value("length") {
            Some((k, _)) if term.is_length() => {
                return Err(doc.err(
                    k.span(),
                    format!("`length` is for angular terms, and `{}` is a length: its tolerance enters the cost curve as it is", term.name),
                ));
            }
            Some((_, l)) => {
                let x = doc.number(l, "`length` (mm)")?;
                if x <= 0.0 {
                    return Err(doc.err(
                        l.span(),
                        format!("`length` is {x}: expected a positive reference length in mm"),
                    ));
                }
                x
            }
            None if term.is_length() => 1.0,
            None => 1000.0,
        };
        let (lower, upper) = (convert(*lo, f), convert(*hi, f));
        let start = match spec.get("start") {
            Some(s) => {
                let x = doc.number(s, &format!("`start` ({unit})"))?;
                if x < *lo || x > *hi {
                    return Err(doc.err(
                        s.span(),
                        format!("`start = {x}` is outside the bounds [{lo}, {hi}]"),
                    ));
                }
                convert(x, f)
            }
            None => (lower + upper) / 2.0,
        };
        // lengths: mm per mm; angles: mm per rad over the reference length.
        let length = if term.is_length() { 1.0 } else { length };
        terms.push((
            term,
            TolTerm {
                lower,
                upper,
                start,
                curve,
                length,
            },
        ));
    }
    Ok(ToleranceSpec { options, terms })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::machine_file;

    fn grinder() -> Machine {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/fixtures/grinder.machine.toml");
        machine_file::load(Path::new(path)).unwrap()
    }

    fn err(text: &str) -> String {
        parse(text, "b.toml", &grinder(), None)
            .unwrap_err()
            .to_string()
    }

    #[test]
    fn reads_units_ranges_and_tolerances() {
        let b = parse(
            "length_unit = \"mm\"\n[ranges]\nEZZ = [0.005, 0.013]\nEBX = [2, 5, 8]\n\
             [poses]\nat = [{ X = 50, Y = 45, Z = 5 }]\n\
             [tolerance]\nquality_loss = { cost = 1.0, at = 0.002 }\n\
             [tolerance.terms]\nEBX = { bounds = [0, 40], cost = \"plane\" }\n",
            "b.toml",
            &grinder(),
            None,
        )
        .unwrap();
        assert_eq!(b.ranges[0].0.name, "EZZ");
        assert_eq!(b.ranges[0].1, [0.005, 0.009, 0.013]);
        let l = b.ranges[1].1;
        assert!((l[2] - 8e-6).abs() < 1e-18);
        assert_eq!(b.poses, Poses::At(vec![vec![50.0, 45.0, 5.0]]));
        let tol = b.tolerance.unwrap();
        assert!((tol.options.loss - 1.0 / 0.002f64.powi(2)).abs() < 1e-6);
        let t = &tol.terms[0].1;
        assert_eq!(
            (t.lower, t.length, t.curve),
            (0.0, 1000.0, CostCurve::Plane)
        );
        assert!((t.start - 20e-6).abs() < 1e-18);
    }

    #[test]
    fn problems_are_located() {
        let e = err("[ranges]\nEZX = [1, 2]\nEYQ = [1, 2]\n");
        assert!(
            e.starts_with("b.toml:3:1: `EYQ`: the machine has no axis Q"),
            "{e}"
        );
        let e = err("[ranges]\nEA0X = [1, 2]\n");
        assert!(
            e.starts_with("b.toml:2:1:") && e.contains("meaningless"),
            "{e}"
        );
        let e = err("[ranges]\nEZX = [2, 1]\n");
        assert!(
            e.starts_with("b.toml:2:11:") && e.contains("min ≤ max"),
            "{e}"
        );
        let e = err("[ranges]\nEZX = [1]\n");
        assert!(e.starts_with("b.toml:2:7:"), "{e}");
        let e = err("rangez = 1\n");
        assert!(e.contains("did you mean `ranges`"), "{e}");
        let e = err("[poses]\nat = [{ X = 1, Q = 2 }]\n");
        assert!(
            e.starts_with("b.toml:2:16:") && e.contains("no axis `Q`"),
            "{e}"
        );
        let e = err("[poses]\ngrid = 0\n");
        assert!(e.starts_with("b.toml:2:8:"), "{e}");
        let e = err("direction = [0, 0, 0]\n");
        assert!(e.contains("zero vector"), "{e}");
        let e =
            err("[tolerance]\n[tolerance.terms]\nEZX = { bounds = [5, 10], cost = \"plane\" }\n");
        assert!(
            e.starts_with("b.toml:1:1:") && e.contains("quality_loss"),
            "{e}"
        );
        let e = err(
            "[tolerance]\nquality_loss = { cost = 1, at = 2 }\n[tolerance.terms]\n\
             EZX = { bounds = [5, 10], cost = \"planar\" }\n",
        );
        assert!(
            e.starts_with("b.toml:4:34:") && e.contains("unknown cost curve"),
            "{e}"
        );
        let e = err(
            "[tolerance]\nquality_loss = { cost = 1, at = 2 }\n[tolerance.terms]\n\
             EZX = { bounds = [5, 10], cost = \"plane\", length = 100 }\n",
        );
        assert!(e.contains("`length` is for angular terms"), "{e}");
        let e = err(
            "[tolerance]\nquality_loss = { cost = 1, at = 2 }\n[tolerance.terms]\n\
             EZX = { bounds = [10, 5], cost = \"plane\" }\n",
        );
        assert!(e.contains("0 ≤ min < max"), "{e}");
        let e = err("tool_chain = \"upper\"\n");
        assert!(e.contains("no tool chain `upper`"), "{e}");
    }
}
