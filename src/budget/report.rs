//! Reports of the budget: tables for people, CSV, JSON, and an SVG bar chart of the
//! ranking.
//!
//! Human tables give lengths in µm or mm and angles in µrad, as the paper does; CSV and
//! JSON give model units (mm, rad) at full precision. CSV output of several tables puts
//! one block per table, each with its header row, separated by an empty line.

use super::ranking::Ranking;
use super::study::{Mode, Study};
use super::tolerance::Design;
use plotters::prelude::*;
use serde::Serialize;
use std::fmt::Write;

/// A number in the paper's style: three significant digits, `1.00e-03`; `0` for 0.
pub fn sci(v: f64) -> String {
    if !v.is_finite() {
        return if v.is_nan() { "-".into() } else { "inf".into() };
    }
    if v == 0.0 {
        return "0".into();
    }
    let s = format!("{v:.2e}");
    // Rust writes 1.00e-3: pad the exponent to two digits.
    match s.split_once('e') {
        Some((m, e)) => {
            let (sign, digits) = match e.strip_prefix('-') {
                Some(d) => ('-', d),
                None => ('+', e),
            };
            format!("{m}e{sign}{digits:0>2}")
        }
        None => s,
    }
}

/// A percentage with enough digits to tell small shares apart.
pub fn percent(v: f64) -> String {
    let p = v * 100.0;
    if p.abs() >= 10.0 {
        format!("{p:.1} %")
    } else if p.abs() >= 0.01 {
        format!("{p:.3} %")
    } else if p == 0.0 {
        "0 %".into()
    } else {
        format!("{} %", sci(p))
    }
}

/// `v` (mm or rad, per `unit`) in µm or µrad, four decimals at most.
fn in_micro(v: f64, unit: &str) -> String {
    let k = if unit == "mm" { 1e3 } else { 1e6 };
    let s = format!("{:.4}", v * k);
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" { "0".into() } else { s.into() }
}

fn micro_unit(unit: &str) -> &'static str {
    if unit == "mm" { "µm" } else { "µrad" }
}

/// Columns padded to their widest cell; `right[i]` aligns column i to the right.
fn table(headers: &[&str], rows: &[Vec<String>], right: &[bool]) -> String {
    let n = headers.len();
    let mut width: Vec<usize> = headers.iter().map(|h| h.chars().count()).collect();
    for r in rows {
        for (i, c) in r.iter().enumerate() {
            width[i] = width[i].max(c.chars().count());
        }
    }
    let line = |cells: &mut dyn Iterator<Item = &str>| {
        let mut s = String::new();
        for (i, c) in cells.enumerate() {
            let pad = width[i] - c.chars().count();
            if i > 0 {
                s.push_str("  ");
            }
            if right.get(i).copied().unwrap_or(false) {
                s.push_str(&" ".repeat(pad));
                s.push_str(c);
            } else {
                s.push_str(c);
                if i + 1 < n {
                    s.push_str(&" ".repeat(pad));
                }
            }
        }
        s.trim_end().to_string() + "\n"
    };
    let mut out = line(&mut headers.iter().copied());
    for r in rows {
        out.push_str(&line(&mut r.iter().map(String::as_str)));
    }
    out
}

fn direction(d: &[f64; 3]) -> String {
    let f = |v: f64| {
        let s = format!("{v:.4}");
        let s = s.trim_end_matches('0').trim_end_matches('.').to_string();
        if s == "-0" { "0".to_string() } else { s }
    };
    format!("[{}, {}, {}]", f(d[0]), f(d[1]), f(d[2]))
}

// ---------------------------------------------------------------- parameter study

/// The parameter study as a table for people (the paper's table 6).
pub fn study_human(study: &Study) -> String {
    let mut out = String::new();
    match study.mode {
        Mode::AtPose => {
            let _ = writeln!(
                out,
                "Parameter study at {}: change of the tool tip (mm) and of the tool direction \
                 for one unit of each error term",
                study.poses[0]
            );
        }
        Mode::WorstCase => {
            let _ = writeln!(
                out,
                "Parameter study, worst case over {} poses: change of the tool tip (mm) and of \
                 the tool direction for one unit of each error term; each value is the largest \
                 in magnitude over the poses, sign kept",
                study.poses.len()
            );
        }
    }
    out.push('\n');
    let worst = study.mode == Mode::WorstCase;
    let mut headers = vec![
        "term", "unit", "ΔEx/mm", "ΔEy/mm", "ΔEz/mm", "ΔOx", "ΔOy", "ΔOz",
    ];
    if worst {
        headers.push("largest tip change at");
    }
    let rows: Vec<Vec<String>> = study
        .rows
        .iter()
        .map(|r| {
            let mut cells = vec![r.term.clone(), r.unit_label.clone()];
            cells.extend(first_order(&r.exact.dp));
            cells.extend(first_order(&r.exact.do_));
            if worst {
                cells.push(study.poses[r.worst_pose].clone());
            }
            cells
        })
        .collect();
    let right = [false, false, true, true, true, true, true, true, false];
    out.push_str(&table(&headers, &rows, &right));
    let _ = writeln!(
        out,
        "\nvalues: the finite change for one unit (eq. 4), shown as 0 below 1e-12 or below \
         1e-4 of the largest of their group (tip, direction) in the row, which is the \
         second-order part of one unit (CSV and JSON give every digit);\nlinear (Jacobian × \
         unit) and exact agree within {} mm (tip) and {} (direction)",
        sci(study.max_difference[0]),
        sci(study.max_difference[1])
    );
    out
}

/// A group of three values for the human table: those below 1e-12, or below 1e-4 of the
/// largest of the group, as 0.
fn first_order(v: &[f64; 3]) -> Vec<String> {
    let max = v.iter().fold(0.0f64, |a, x| a.max(x.abs()));
    v.iter()
        .map(|&x| {
            if x.abs() < 1e-12 || x.abs() < 1e-4 * max {
                "0".to_string()
            } else {
                sci(x)
            }
        })
        .collect()
}

pub fn study_csv(study: &Study) -> String {
    let mut out = String::from(
        "term,unit,unit_label,pose,exact_dx,exact_dy,exact_dz,exact_ox,exact_oy,exact_oz,\
         linear_dx,linear_dy,linear_dz,linear_ox,linear_oy,linear_oz\n",
    );
    for r in &study.rows {
        let pose = &study.poses[r.worst_pose];
        let _ = write!(out, "{},{},{},{}", r.term, r.unit, r.unit_label, pose);
        for v in r.exact.dp.iter().chain(&r.exact.do_) {
            let _ = write!(out, ",{v}");
        }
        for v in r.linear.dp.iter().chain(&r.linear.do_) {
            let _ = write!(out, ",{v}");
        }
        out.push('\n');
    }
    out
}

// ---------------------------------------------------------------- ranking

/// The ranking as tables for people: the ANOVA (the paper's table 5), the Sobol indices,
/// the key errors and where the two rankings differ.
pub fn ranking_human(r: &Ranking) -> String {
    let mut out = String::new();
    let a = &r.anova;
    let s = &r.sobol;
    let _ = writeln!(
        out,
        "Key errors: contribution to the error along {} over {} pose{}",
        direction(&r.direction),
        a.poses,
        if a.poses == 1 { "" } else { "s" }
    );
    let _ = writeln!(
        out,
        "ANOVA: {} array, {} runs per pose; F critical {:.4} (α = 0.05) and {:.4} (α = 0.01) \
         for ({}, {}) degrees of freedom",
        a.array,
        a.runs,
        a.f_critical[0],
        a.f_critical[1],
        a.rows.first().map_or(0, |row| row.dof),
        a.residual.dof
    );
    let _ = writeln!(
        out,
        "Sobol: {} base samples ({} evaluations), seed {}; variance of the error {} mm²",
        s.samples,
        s.evaluations,
        s.seed,
        sci(s.variance)
    );
    out.push('\n');
    let headers = [
        "rank",
        "term",
        "levels",
        "SS/mm²",
        "F",
        "p",
        "share",
        "Sobol total",
        "first",
        "Sobol rank",
        "key",
    ];
    let rows: Vec<Vec<String>> = r
        .rows
        .iter()
        .map(|row| {
            let i = a.rows.iter().position(|x| x.term == row.term).unwrap_or(0);
            let ar = &a.rows[i];
            let levels = format!(
                "{} / {} / {} {}",
                in_micro(ar.levels[0], ar.unit),
                in_micro(ar.levels[1], ar.unit),
                in_micro(ar.levels[2], ar.unit),
                micro_unit(ar.unit)
            );
            let key = match (row.key_anova, row.key_sobol) {
                (true, true) => "*",
                (true, false) => "* (ANOVA only)",
                (false, true) => "(Sobol only)",
                (false, false) => "",
            };
            vec![
                row.anova_rank.to_string(),
                row.term.clone(),
                levels,
                sci(ar.ss),
                sci(ar.f),
                sci(ar.p),
                percent(row.anova_share),
                format!(
                    "{} ± {}",
                    percent(row.sobol_total),
                    percent(row.sobol_total_se)
                ),
                percent(row.sobol_first),
                row.sobol_rank.to_string(),
                key.to_string(),
            ]
        })
        .collect();
    let right = [
        true, false, false, true, true, true, true, true, true, true, false,
    ];
    out.push_str(&table(&headers, &rows, &right));
    let _ = writeln!(
        out,
        "\nempty columns: SS {} mm², {} dof; residual: SS {} mm², {} dof; total: SS {} mm², {} dof",
        sci(a.empty_columns.ss),
        a.empty_columns.dof,
        sci(a.residual.ss),
        a.residual.dof,
        sci(a.total.ss),
        a.total.dof
    );
    let _ = writeln!(
        out,
        "key errors (significant at α = {} with at least {} of the variance): {}",
        r.alpha,
        percent(r.min_share),
        if r.key.is_empty() {
            "none".to_string()
        } else {
            r.key.join(", ")
        }
    );
    if r.differences.is_empty() {
        let _ = writeln!(
            out,
            "the ANOVA and Sobol rankings agree on the key errors and their order"
        );
    } else {
        let _ = writeln!(out, "where the ANOVA and Sobol rankings differ:");
        for d in &r.differences {
            let _ = writeln!(out, "  {d}");
        }
    }
    out
}

pub fn ranking_csv(r: &Ranking) -> String {
    let mut out = String::from(
        "term,unit,level1,level2,level3,anova_rank,ss,dof,f,p,anova_share,sobol_rank,\
         sobol_first,sobol_first_se,sobol_total,sobol_total_se,key_anova,key_sobol\n",
    );
    for row in &r.rows {
        let a = r.anova.rows.iter().find(|x| x.term == row.term);
        let s = r.sobol.rows.iter().find(|x| x.term == row.term);
        let (Some(a), Some(s)) = (a, s) else { continue };
        let _ = writeln!(
            out,
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
            row.term,
            row.unit,
            a.levels[0],
            a.levels[1],
            a.levels[2],
            row.anova_rank,
            a.ss,
            a.dof,
            a.f,
            a.p,
            row.anova_share,
            row.sobol_rank,
            s.first,
            s.first_se,
            s.total,
            s.total_se,
            row.key_anova,
            row.key_sobol
        );
    }
    out
}

/// Colours of the chart's bars (ANOVA share, Sobol total index).
pub const ANOVA_COLOUR: RGBColor = RGBColor(0x1f, 0x77, 0xb4);
pub const SOBOL_COLOUR: RGBColor = RGBColor(0xff, 0x7f, 0x0e);

/// An SVG bar chart of the ranking: per term, in ANOVA order, a bar of its ANOVA share and
/// one of its Sobol total index, each labelled with its value. Text is SVG text: no font
/// is needed to write it, the viewer renders it with its own sans-serif font.
pub fn ranking_svg(r: &Ranking, title: &str) -> Result<String, String> {
    let row_h = 26u32;
    let top = 70u32;
    let (w, h) = (900u32, top + row_h * r.rows.len() as u32 + 20);
    let label_w = 80i32;
    let bar_x = label_w + 10;
    let bar_max = (w as i32 - bar_x - 120) as f64;
    let max_share = r
        .rows
        .iter()
        .flat_map(|row| [row.anova_share, row.sobol_total])
        .fold(0.0f64, f64::max)
        .max(1e-300);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (w, h)).into_drawing_area();
        let e = |e: DrawingAreaErrorKind<_>| e.to_string();
        root.fill(&WHITE).map_err(e)?;
        let font = |size: u32| ("sans-serif", size).into_font().color(&BLACK);
        root.draw(&Text::new(title.to_string(), (10, 8), font(16)))
            .map_err(e)?;
        // Legend.
        for (k, (colour, name)) in [
            (ANOVA_COLOUR, "ANOVA share of the sum of squares"),
            (SOBOL_COLOUR, "Sobol total index"),
        ]
        .into_iter()
        .enumerate()
        {
            let x = 10 + 320 * k as i32;
            root.draw(&Rectangle::new([(x, 38), (x + 14, 50)], colour.filled()))
                .map_err(e)?;
            root.draw(&Text::new(name.to_string(), (x + 20, 38), font(12)))
                .map_err(e)?;
        }
        for (i, row) in r.rows.iter().enumerate() {
            let y = (top + row_h * i as u32) as i32;
            let label = if row.key_anova {
                format!("{} *", row.term)
            } else {
                row.term.clone()
            };
            root.draw(&Text::new(label, (10, y + 6), font(13)))
                .map_err(e)?;
            for (k, (value, colour)) in [
                (row.anova_share, ANOVA_COLOUR),
                (row.sobol_total.max(0.0), SOBOL_COLOUR),
            ]
            .into_iter()
            .enumerate()
            {
                let y0 = y + 11 * k as i32;
                let len = if value > 0.0 {
                    ((value / max_share * bar_max).round() as i32).max(1)
                } else {
                    0
                };
                if len > 0 {
                    root.draw(&Rectangle::new(
                        [(bar_x, y0), (bar_x + len, y0 + 10)],
                        colour.filled(),
                    ))
                    .map_err(e)?;
                }
                root.draw(&Text::new(percent(value), (bar_x + len + 6, y0), font(10)))
                    .map_err(e)?;
            }
        }
        root.present().map_err(e)?;
    }
    Ok(svg)
}

// ---------------------------------------------------------------- tolerance design

/// The tolerance design as tables for people (the paper's tables 9 and 10).
pub fn design_human(d: &Design) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "Tolerance design along {}: QC = W·Cq + (1 − W)·(Cm + λ·Cq), W = {}, λ = {}, \
         quality loss K = {} per mm²",
        direction(&d.direction),
        d.weight,
        d.lambda,
        sci(d.loss)
    );
    let _ = writeln!(
        out,
        "response surface of the quality loss: {} coefficients from {} samples, R² = {:.6}, \
         adjusted R² = {:.6}",
        d.surface.coefficients, d.surface.samples, d.surface.r2, d.surface.r2_adjusted
    );
    out.push('\n');
    let headers = [
        "term",
        "cost curve",
        "bounds",
        "start",
        "tolerance",
        "as in the paper",
        "cost",
        "quality",
        "at",
    ];
    let rows: Vec<Vec<String>> = d
        .rows
        .iter()
        .map(|r| {
            let u = micro_unit(r.unit);
            let paper = if r.unit == "mm" {
                format!("{:.4} mm", r.tolerance)
            } else {
                format!("{:.4}/{}", r.tolerance * r.length, trim(r.length))
            };
            vec![
                r.term.clone(),
                r.curve.name().to_string(),
                format!(
                    "{} – {} {u}",
                    in_micro(r.lower, r.unit),
                    in_micro(r.upper, r.unit)
                ),
                in_micro(r.start, r.unit),
                format!("{} {u}", in_micro(r.tolerance, r.unit)),
                paper,
                format!("{:.4}", r.cost),
                sci(r.quality),
                r.at.to_string(),
            ]
        })
        .collect();
    let right = [false, false, true, true, true, true, true, true, false];
    out.push_str(&table(&headers, &rows, &right));
    out.push('\n');
    let obj = [
        vec![
            "Cq (quality level)".to_string(),
            sci(d.start.cq),
            sci(d.optimum.cq),
        ],
        vec![
            "Cm (manufacturing)".to_string(),
            format!("{:.4}", d.start.cm),
            format!("{:.4}", d.optimum.cm),
        ],
        vec![
            "Cu (use, λ·Cq)".to_string(),
            sci(d.start.cu),
            sci(d.optimum.cu),
        ],
        vec![
            "QC (objective)".to_string(),
            format!("{:.4}", d.start.qc),
            format!("{:.4}", d.optimum.qc),
        ],
    ];
    out.push_str(&table(&["", "start", "design"], &obj, &[false, true, true]));
    let _ = writeln!(
        out,
        "\ncoordinate search: {} cycle{}, {} evaluations of the objective",
        d.cycles,
        if d.cycles == 1 { "" } else { "s" },
        d.evaluations
    );
    out
}

fn trim(v: f64) -> String {
    let s = format!("{v:.3}");
    s.trim_end_matches('0').trim_end_matches('.').to_string()
}

pub fn design_csv(d: &Design) -> String {
    let mut out = String::from(
        "term,unit,curve,length_mm,lower,upper,start,tolerance,cost_start,cost,quality,d,at\n",
    );
    for r in &d.rows {
        let _ = writeln!(
            out,
            "{},{},{},{},{},{},{},{},{},{},{},{},{}",
            r.term,
            r.unit,
            r.curve.name(),
            r.length,
            r.lower,
            r.upper,
            r.start,
            r.tolerance,
            r.cost_start,
            r.cost,
            r.quality,
            r.d,
            r.at
        );
    }
    let _ = writeln!(out);
    let _ = writeln!(out, "objective,cq,cm,cu,qc");
    for (name, o) in [("start", &d.start), ("design", &d.optimum)] {
        let _ = writeln!(out, "{name},{},{},{},{}", o.cq, o.cm, o.cu, o.qc);
    }
    out
}

// ---------------------------------------------------------------- JSON

/// Everything a command computed, for `--format json`.
#[derive(Debug, Serialize, Default)]
pub struct Report<'a> {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub study: Option<&'a Study>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ranking: Option<&'a Ranking>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tolerance: Option<&'a Design>,
}

impl Report<'_> {
    pub fn json(&self) -> String {
        serde_json::to_string_pretty(self).expect("reports serialize") + "\n"
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_read_like_the_paper() {
        assert_eq!(sci(1e-3), "1.00e-03");
        assert_eq!(sci(-4.5e-4), "-4.50e-04");
        assert_eq!(sci(3.0e12), "3.00e+12");
        assert_eq!(sci(0.0), "0");
        assert_eq!(
            first_order(&[1e-3, -2.5e-10, 1e-13]),
            ["1.00e-03", "0", "0"]
        );
        assert_eq!(percent(0.912), "91.2 %");
        assert_eq!(percent(0.00123), "0.123 %");
        assert_eq!(in_micro(0.0125, "mm"), "12.5");
        assert_eq!(in_micro(4e-5, "rad"), "40");
    }

    #[test]
    fn tables_align() {
        let t = table(
            &["a", "bb"],
            &[
                vec!["xyz".into(), "1".into()],
                vec!["q".into(), "22".into()],
            ],
            &[false, true],
        );
        assert_eq!(t, "a    bb\nxyz   1\nq    22\n");
    }
}
