//! A check run for people (rustc-style diagnostics) and for programs (JSON, its schema
//! in docs/check.schema.json).

use super::{Errors, Peak, ProgramCheck, Run, Status, Thresholds};
use crate::diag::{Severity, render_message};
use serde::Serialize;
use std::fmt::Write;

/// The version of the JSON output's schema: raised on any change that could break a
/// reader (a field removed, renamed or changing meaning); new fields may come without.
pub const SCHEMA_VERSION: u32 = 2;

#[derive(Serialize)]
struct Json<'a> {
    format: &'static str,
    schema_version: u32,
    nccomp_version: &'static str,
    config: Option<&'a str>,
    machine: Option<&'a str>,
    errors: Option<&'a str>,
    thresholds: Option<Thresholds>,
    status: Status,
    exit_code: u8,
    totals: Totals,
    programs: &'a [ProgramCheck],
}

#[derive(Serialize)]
struct Totals {
    programs: usize,
    clean: usize,
    findings: usize,
    unusable: usize,
    /// Programs the pass did not read (a zero error model): nothing was checked in them.
    unread: usize,
}

impl Run {
    fn totals(&self) -> Totals {
        let count = |s: Status| self.programs.iter().filter(|p| p.status == s).count();
        Totals {
            programs: self.programs.len(),
            clean: count(Status::Clean),
            findings: count(Status::Findings),
            unusable: count(Status::Unusable),
            unread: self
                .programs
                .iter()
                .filter(|p| !p.checked && p.status != Status::Unusable)
                .count(),
        }
    }

    /// The run as one JSON document (pretty-printed, with a final newline).
    pub fn json(&self) -> String {
        let status = self.status();
        let doc = Json {
            format: "nccomp-check",
            schema_version: SCHEMA_VERSION,
            nccomp_version: env!("CARGO_PKG_VERSION"),
            config: self.config.as_deref(),
            machine: self.machine.as_deref(),
            errors: self.errors.as_deref(),
            thresholds: self.thresholds,
            status,
            exit_code: status.exit_code(),
            totals: self.totals(),
            programs: &self.programs,
        };
        let mut text = serde_json::to_string_pretty(&doc).expect("plain data serializes");
        text.push('\n');
        text
    }

    /// The run for a person: per program its predictions, notes and findings (as
    /// rustc-style diagnostics, coloured when `color` is set), then the totals. With
    /// `failures_only`, clean programs are left out.
    pub fn human(&self, color: bool, failures_only: bool) -> String {
        let mut out = String::new();
        for p in &self.programs {
            if failures_only && p.status == Status::Clean {
                continue;
            }
            program(&mut out, p, self.machine.is_none(), color);
            out.push('\n');
        }
        let t = self.totals();
        let against = match (&self.config, &self.machine, &self.errors) {
            (_, Some(m), Some(e)) => format!("{m} and {e}"),
            (Some(c), _, _) => c.clone(),
            _ => "its machine".to_string(),
        };
        let limits = self
            .thresholds
            .as_ref()
            .map_or(String::new(), |th| format!(" ({})", limits(th)));
        let _ = write!(
            out,
            "checked {} against {against}: {} clean, {} with findings, {} unusable{limits}",
            plural(t.programs, "program"),
            t.clean,
            t.findings,
            t.unusable,
        );
        if t.unread > 0 {
            let _ = write!(
                out,
                "; {} not read (a zero error model): nothing was checked in {}",
                t.unread,
                if t.unread == 1 { "it" } else { "them" }
            );
        }
        out.push('\n');
        out
    }
}

fn plural(n: usize, noun: &str) -> String {
    if n == 1 {
        format!("1 {noun}")
    } else {
        format!("{n} {noun}s")
    }
}

fn limits(t: &Thresholds) -> String {
    match t.max_angle_urad {
        Some(a) => format!("--max-error {} mm, --max-angle {a} µrad", t.max_error_mm),
        None => format!("--max-error {} mm", t.max_error_mm),
    }
}

fn at(peak: &Peak) -> String {
    peak.line.map_or(String::new(), |l| format!(" (line {l})"))
}

fn program(out: &mut String, p: &ProgramCheck, each_machine: bool, color: bool) {
    let status = match p.status {
        Status::Clean => "clean".to_string(),
        Status::Findings => plural(p.findings.len(), "finding"),
        Status::Unusable => "unusable".to_string(),
    };
    let _ = writeln!(out, "{}: {status}", p.path);
    if each_machine && let (Some(m), Some(e)) = (&p.machine, &p.errors) {
        let limits = p
            .thresholds
            .as_ref()
            .map_or(String::new(), |t| format!(" ({})", limits(t)));
        let _ = writeln!(out, "  against {m} and {e}{limits}");
    }
    if let Some(line) = crate::model::setup::summary_line(&p.setup) {
        let _ = writeln!(out, "  {line}");
    }
    if let Some(error) = &p.error {
        let _ = writeln!(out, "{}", render_message(Severity::Error, error, color));
        return;
    }
    let _ = writeln!(
        out,
        "  {}, {}",
        plural(p.lines, "line"),
        plural(p.motion_blocks, "motion block")
    );
    if let (Some(before), Some(after)) = (&p.before, &p.after) {
        predictions(out, before, after);
    }
    match (p.lands_every_pose, &p.thresholds) {
        (Some(true), Some(t)) => {
            let _ = writeln!(
                out,
                "  compensation lands every pose within the thresholds ({})",
                limits(t)
            );
        }
        (Some(false), _) => {
            let _ = writeln!(out, "  compensation does not land every pose");
        }
        _ if !p.checked => {
            let _ = writeln!(out, "  nothing was checked: the program was not read");
        }
        _ => {}
    }
    for note in &p.notes {
        let _ = writeln!(out, "  note: {note}");
    }
    if p.stopped_early {
        let _ = writeln!(
            out,
            "  note: the pass stopped at its limit of refused blocks; later blocks were not checked"
        );
    }
    for f in &p.findings {
        let _ = writeln!(
            out,
            "\n{}",
            f.diagnostic().render_as(Severity::Error, color)
        );
    }
}

fn predictions(out: &mut String, before: &Errors, after: &Errors) {
    let mean = |p: &Peak, scale: f64, decimals: usize, unit: &str| {
        p.mean.map_or(String::new(), |m| {
            format!(", mean {:.*} {unit}", decimals, m * scale)
        })
    };
    let _ = writeln!(
        out,
        "  before compensation: tip error up to {:.3} µm{}{}; direction error up to {:.2} µrad{}{}",
        before.tip_mm.max * 1e3,
        at(&before.tip_mm),
        mean(&before.tip_mm, 1e3, 3, "µm"),
        before.direction_urad.max,
        at(&before.direction_urad),
        mean(&before.direction_urad, 1.0, 2, "µrad"),
    );
    let singular = after
        .singular_direction_urad
        .as_ref()
        .map_or(String::new(), |p| {
            format!("; at singular poses up to {:.2} µrad{}", p.max, at(p))
        });
    let _ = writeln!(
        out,
        "  after compensation:  tip error up to {:.3} µm{}; direction error up to {:.2} µrad{}{singular}",
        after.tip_mm.max * 1e3,
        at(&after.tip_mm),
        after.direction_urad.max,
        at(&after.direction_urad),
    );
}
