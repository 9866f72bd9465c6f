//! The analysis in numbers: statistics, the text summary and the per-point CSV.

use super::{Analysis, PointError};
use crate::nc::number::write_fixed;
use std::fmt::Write;

/// Largest, mean and RMS of one error over the reported points.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Stat {
    pub max: f64,
    /// Index of the point with the largest error.
    pub at: usize,
    pub mean: f64,
    pub rms: f64,
}

impl Stat {
    fn of(values: impl Iterator<Item = f64>) -> Stat {
        let (mut s, mut count, mut sum, mut sq) = (Stat::default(), 0usize, 0.0, 0.0);
        for (i, v) in values.enumerate() {
            if v > s.max || count == 0 {
                s.max = v;
                s.at = i;
            }
            count += 1;
            sum += v;
            sq += v * v;
        }
        if count > 0 {
            s.mean = sum / count as f64;
            s.rms = (sq / count as f64).sqrt();
        }
        s
    }
}

/// The statistics of an analysis: tip errors in mm, axis errors in rad.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Summary {
    pub tip: Stat,
    pub axis: Stat,
    /// The same against the commanded positions, if the trace has them.
    pub commanded: Option<(Stat, Stat)>,
}

impl Summary {
    pub fn of(a: &Analysis) -> Summary {
        let values = |f: fn(PointError) -> f64| a.points().map(f);
        Summary {
            tip: Stat::of(values(|p| p.actual.tip)),
            axis: Stat::of(values(|p| p.actual.axis)),
            commanded: a.commanded.as_ref().map(|_| {
                (
                    Stat::of(values(|p| p.commanded.map_or(0.0, |c| c.tip))),
                    Stat::of(values(|p| p.commanded.map_or(0.0, |c| c.axis))),
                )
            }),
        }
    }
}

/// The text summary. `program`, `trace` and `machine` name the inputs.
pub fn summary_text(a: &Analysis, program: &str, trace: &str, machine: &str) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "contour error of {program} on {machine}, against the trace {trace}"
    );
    let period = if a.samples > 1 {
        a.duration / (a.samples - 1) as f64
    } else {
        0.0
    };
    let _ = writeln!(
        out,
        "trace:     {} samples over {:.3} s (every {:.1} ms on average){}",
        a.samples,
        a.duration,
        period * 1e3,
        if a.summary.commanded.is_some() {
            ", with commanded positions"
        } else {
            ""
        }
    );
    let _ = writeln!(
        out,
        "reference: {} feed moves ({:.3} mm of tool tip path, rapids included), sampled every {:.4} mm: {} points reported",
        a.feed_moves,
        a.path_length,
        a.step,
        a.reported.len()
    );
    if a.reported.is_empty() {
        out.push_str("no reference point was reached by the trace\n");
    } else {
        let line = |label: &str, s: &Stat, scale: f64, unit: &str, decimals: usize| {
            let p = a.point(s.at);
            format!(
                "{label} max {:.*} {unit} at line {} (path {:.3} mm, t = {:.3} s); mean {:.*} {unit}, RMS {:.*} {unit}\n",
                decimals,
                s.max * scale,
                p.reference.line,
                p.reference.along,
                p.actual.time,
                decimals,
                s.mean * scale,
                decimals,
                s.rms * scale,
            )
        };
        out += &line("tool-tip contour error: ", &a.summary.tip, 1e3, "µm", 3);
        out += &line("tool-axis contour error:", &a.summary.axis, 1e6, "µrad", 2);
        if let Some((tip, axis)) = &a.summary.commanded {
            out += &line("commanded, tool tip:    ", tip, 1e3, "µm", 3);
            out += &line("commanded, tool axis:   ", axis, 1e6, "µrad", 2);
        }
    }
    if let Some((first, last)) = a.beyond_lines {
        let _ = writeln!(
            out,
            "note: the trace does not reach {} reference point{} (lines {first}–{last}); they are left out",
            a.beyond,
            if a.beyond == 1 { "" } else { "s" }
        );
    }
    if !a.ignored_columns.is_empty() {
        let _ = writeln!(
            out,
            "note: trace columns not used: {}",
            a.ignored_columns.join(", ")
        );
    }
    out
}

/// The per-point CSV: one row per reported reference point.
pub fn points_csv(a: &Analysis, rapids: bool) -> String {
    let commanded = a.summary.commanded.is_some();
    let mut out = String::with_capacity(a.reported.len() * 120 + 200);
    out.push_str(
        "line,s,along_mm,x_mm,y_mm,z_mm,time_s,tip_error_um,ex_um,ey_um,ez_um,axis_error_urad",
    );
    if commanded {
        out.push_str(",cmd_tip_error_um,cmd_axis_error_urad");
    }
    if rapids {
        out.push_str(",rapid");
    }
    out.push('\n');
    let num = |out: &mut String, v: f64, d: u8| {
        out.push(',');
        write_fixed(v, d, out);
    };
    for p in a.points() {
        let r = &p.reference;
        let _ = write!(out, "{}", r.line);
        num(&mut out, r.s, 4);
        num(&mut out, r.along, 4);
        for c in 0..3 {
            num(&mut out, r.p[c], 5);
        }
        num(&mut out, p.actual.time, 4);
        num(&mut out, p.actual.tip * 1e3, 4);
        let e = p.actual.foot - r.p;
        for c in 0..3 {
            num(&mut out, e[c] * 1e3, 4);
        }
        num(&mut out, p.actual.axis * 1e6, 3);
        if let Some(c) = &p.commanded {
            num(&mut out, c.tip * 1e3, 4);
            num(&mut out, c.axis * 1e6, 3);
        }
        if rapids {
            out.push_str(if r.rapid { ",1" } else { ",0" });
        }
        out.push('\n');
    }
    out
}
