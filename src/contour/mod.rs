//! Contour error from a program and a measured trace (paper 003).
//!
//! The program is the reference: its moves are followed on the nominal machine as the
//! controller interpolates them ([`reference`]) and sampled into tool poses. The trace
//! ([`trace`]) holds the axis positions the machine reached, sampled in time; through the
//! same kinematics they become the actual path. For each reference point the **tool-tip
//! contour error** is the shortest distance to the actual path and the **tool-axis contour
//! error** the angle between the tool directions there ([`search`]). [`report`] and
//! [`plot`] present the result. [`s_shape`] makes the paper's S-shaped test piece and its
//! finishing program, [`simulate`] a trace of a machine with servo lag to try it on.

pub mod plot;
pub mod reference;
pub mod report;
pub mod s_shape;
pub mod search;
pub mod simulate;
pub mod trace;

use crate::diag::Error;
use crate::kinematics::Kinematics;
use crate::model::{ErrorModel, Machine};
use crate::program::moves::{NominalMove, Shape, nominal_moves};
use reference::RefPoint;
use report::Summary;
use search::{ActualPath, Match, SearchOptions};
use trace::Trace;

/// How the analysis runs.
#[derive(Debug, Clone, PartialEq)]
pub struct Options {
    /// Name of the active tool chain; `None`: the machine's first.
    pub tool_chain: Option<String>,
    /// Sample the program every this many mm of tool tip travel; `None`: as densely as
    /// the trace samples (the median distance between its samples).
    pub step: Option<f64>,
    /// The search window's margin (mm); `None`: the step.
    pub window: Option<f64>,
    pub capture: f64,
    pub noise: f64,
    /// Report points on rapid (G0) moves too.
    pub rapids: bool,
}

impl Default for Options {
    fn default() -> Self {
        let search = SearchOptions::default();
        Options {
            tool_chain: None,
            step: None,
            window: None,
            capture: search.capture,
            noise: search.noise,
            rapids: false,
        }
    }
}

/// The contour error at one reference point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointError {
    pub reference: RefPoint,
    /// Against the actual positions.
    pub actual: Match,
    /// Against the commanded positions, if the trace has them.
    pub commanded: Option<Errors>,
}

/// The two contour errors at a point: tool tip (mm) and tool axis (rad).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Errors {
    pub tip: f64,
    pub axis: f64,
}

/// The result of an analysis.
#[derive(Debug, Clone, PartialEq)]
pub struct Analysis {
    /// Every reference point (rapid moves included), and where each meets the actual path
    /// and, if the trace has them, the commanded positions.
    pub reference: Vec<RefPoint>,
    pub actual: Vec<Match>,
    pub commanded: Option<Vec<Errors>>,
    /// The reported points, as indices into those, in path order (points on rapid moves
    /// only with [`Options::rapids`]; points the trace does not reach are left out).
    pub reported: Vec<usize>,
    pub summary: Summary,
    /// The sampling step used (mm) and the tool length (mm).
    pub step: f64,
    pub tool_length: f64,
    /// Length of the reference path (mm).
    pub path_length: f64,
    /// Feed moves followed.
    pub feed_moves: usize,
    /// Trace samples, and their time span (s).
    pub samples: usize,
    pub duration: f64,
    /// Points the trace does not reach (first and last program line among them).
    pub beyond: usize,
    pub beyond_lines: Option<(usize, usize)>,
    /// Trace columns that were not used.
    pub ignored_columns: Vec<String>,
}

impl Analysis {
    /// The `k`-th reported point.
    pub fn point(&self, k: usize) -> PointError {
        let i = self.reported[k];
        PointError {
            reference: self.reference[i],
            actual: self.actual[i],
            commanded: self.commanded.as_ref().map(|c| c[i]),
        }
    }

    /// The reported points, in path order.
    pub fn points(&self) -> impl ExactSizeIterator<Item = PointError> + '_ {
        (0..self.reported.len()).map(|k| self.point(k))
    }
}

/// Read a machine's program and trace and compute their contour errors.
pub fn analyse(
    machine: &Machine,
    (program_path, program): (&str, &[u8]),
    (trace_path, trace_text): (&str, &[u8]),
    options: &Options,
) -> crate::Result<Analysis> {
    let start = machine.start_chain(options.tool_chain.as_deref())?;
    // Analysing, not writing: a value beyond a travel limit is what it is.
    let (moves, chain) = nominal_moves(machine, start, program, program_path, 20)?;
    let kin = Kinematics::new(machine, &ErrorModel::zero(machine), chain)
        .map_err(|e| Error::Usage(e.to_string()))?;
    let trace = trace::read(trace_path, trace_text, machine, &kin)?;
    analyse_trace(&kin, &moves, &trace, (program_path, program), options)
}

/// Compute the contour errors of `trace` against the program's `moves` (the program's
/// path and text name it in messages).
pub fn analyse_trace(
    kin: &Kinematics,
    moves: &[NominalMove],
    trace: &Trace,
    (program_path, program): (&str, &[u8]),
    options: &Options,
) -> crate::Result<Analysis> {
    let at =
        |mv_offset: usize, message: String| Error::at(program_path, program, mv_offset, message);
    let feed = |m: &&NominalMove| m.start.is_some() && m.shape != Shape::Rapid;
    let Some(first_feed) = moves.iter().find(feed) else {
        return Err(Error::Usage(format!(
            "{program_path}: the program has no feed moves (G1, G2, G3) to measure a contour along"
        )));
    };
    let length = first_feed.tool_length;
    if let Some(other) = moves.iter().filter(feed).find(|m| m.tool_length != length) {
        return Err(at(
            other.offset,
            format!(
                "this move cuts with a tool length of {} mm, the ones before with {} mm: the trace is followed with one tool (expected a program for one tool; split it at the tool change)",
                other.tool_length, length
            ),
        ));
    }
    let actual = ActualPath::new(kin, &trace.actual, &trace.time, length);
    let step = match options.step {
        Some(s) => s,
        None => median_spacing(actual.tips()).unwrap_or(0.01).max(0.001),
    };
    let search = SearchOptions {
        window: options.window.unwrap_or(step),
        capture: options.capture,
        noise: options.noise,
    };
    let refs = reference::sample(kin, moves, length, step).map_err(|i| {
        at(
            moves[i].offset,
            format!(
                "sampling the program every {step} mm makes more than {} points by this block (expected a coarser --step)",
                reference::MAX_POINTS
            ),
        )
    })?;
    let not_captured = |i: usize, what: &str| {
        let r: &RefPoint = &refs[i];
        at(
            r.offset,
            format!(
                "the {what} never comes within {} mm of where this move {} (tool tip {:.4}, {:.4}, {:.4} on the part): expected the trace of this program, machine and tool (--capture widens the search)",
                search.capture,
                if r.s >= 1.0 { "ends" } else { "passes" },
                r.p.x,
                r.p.y,
                r.p.z
            ),
        )
    };
    let matches = actual
        .match_points(&refs, &search)
        .map_err(|i| not_captured(i, "trace"))?;
    let commanded = match &trace.commanded {
        Some(q) => {
            let path = ActualPath::new(kin, q, &trace.time, length);
            Some(
                path.match_points(&refs, &search)
                    .map_err(|i| not_captured(i, "commanded path of the trace"))?,
            )
        }
        None => None,
    };
    let commanded = commanded.map(|c| {
        c.iter()
            .map(|m| Errors {
                tip: m.tip,
                axis: m.axis,
            })
            .collect::<Vec<_>>()
    });
    let mut reported = Vec::with_capacity(refs.len());
    let mut beyond = 0;
    let mut beyond_lines: Option<(usize, usize)> = None;
    for (i, (r, m)) in refs.iter().zip(&matches).enumerate() {
        if r.rapid && !options.rapids {
            continue;
        }
        if m.beyond {
            beyond += 1;
            beyond_lines = Some(beyond_lines.map_or((r.line, r.line), |(a, _)| (a, r.line)));
            continue;
        }
        reported.push(i);
    }
    let mut a = Analysis {
        path_length: refs.last().map_or(0.0, |r| r.along),
        reference: refs,
        actual: matches,
        commanded,
        reported,
        summary: Summary::default(),
        step,
        tool_length: length,
        feed_moves: moves.iter().filter(feed).count(),
        samples: trace.len(),
        duration: trace.time.last().unwrap_or(&0.0) - trace.time.first().unwrap_or(&0.0),
        beyond,
        beyond_lines,
        ignored_columns: trace.ignored.clone(),
    };
    a.summary = Summary::of(&a);
    Ok(a)
}

/// The median distance between consecutive tips that differ.
fn median_spacing(tips: &[nalgebra::Vector3<f64>]) -> Option<f64> {
    let mut d: Vec<f64> = tips
        .windows(2)
        .map(|w| (w[1] - w[0]).norm())
        .filter(|&d| d > 0.0)
        .collect();
    if d.is_empty() {
        return None;
    }
    let mid = d.len() / 2;
    let (_, m, _) = d.select_nth_unstable_by(mid, f64::total_cmp);
    Some(*m)
}
