//! The reference: the program's path sampled into tool poses on the nominal machine.
//!
//! Each move is followed as the controller interpolates it (joint-linear for G0/G1, the
//! arc in its plane for G2/G3) and sampled at equal parameter steps fine enough that the
//! tool tip moves at most `step` mm and the tool direction at most `step / 50 mm` rad
//! between points.

use crate::kinematics::{Kinematics, MAX_AXES, Model, angle_between};
use crate::model::AxisKind;
use crate::program::moves::{NominalMove, Shape};
use nalgebra::Vector3;
use rayon::prelude::*;

/// One point of the reference path.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RefPoint {
    /// The program line of the move, and the byte offset of that line.
    pub line: usize,
    pub offset: usize,
    /// Parameter within the move (0 … 1).
    pub s: f64,
    /// Length of the reference path (mm of tool tip travel) from its first point.
    pub along: f64,
    /// Tool tip (mm) and tool direction in the workpiece frame.
    pub p: Vector3<f64>,
    pub o: Vector3<f64>,
    /// On a rapid (G0) move.
    pub rapid: bool,
    /// The path does not come here from the point before (the program's first point, or
    /// the first after a break): the trace is searched for it afresh.
    pub first: bool,
}

/// The sampling refuses to make more points than this (a step far too fine for a long
/// program).
pub const MAX_POINTS: usize = 50_000_000;

/// Millimetres that one radian of tool turn counts as: the sampling step in angle is
/// `step / LEVER`.
pub const LEVER: f64 = 50.0;

/// Sample `moves` every `step` mm of tip travel. Moves whose tool length is not `length`
/// are left out (the path breaks there). `Err` gives the index of the move at which the
/// sampling would exceed [`MAX_POINTS`].
pub fn sample(
    kin: &Kinematics,
    moves: &[NominalMove],
    length: f64,
    step: f64,
) -> Result<Vec<RefPoint>, usize> {
    // The moves followed, and whether each continues the path from the one before.
    let mut plan: Vec<(usize, bool)> = Vec::with_capacity(moves.len());
    let mut broken = true;
    for (i, mv) in moves.iter().enumerate() {
        if mv.tool_length != length {
            broken = true;
            continue;
        }
        plan.push((i, mv.start.is_some() && !broken));
        broken = false;
    }
    let counts: Vec<f64> = plan
        .par_iter()
        .map(|&(i, joined)| {
            if joined {
                pieces(kin, &moves[i], length, step)
            } else {
                1.0
            }
        })
        .collect();
    // Where each move's points start in the list.
    let mut starts = Vec::with_capacity(plan.len() + 1);
    let mut total = 0usize;
    for (&(i, _), &c) in plan.iter().zip(&counts) {
        starts.push(total);
        if c > (MAX_POINTS - total) as f64 {
            return Err(i);
        }
        total += c as usize;
    }
    starts.push(total);
    let n = kin.len();
    let mut points = Vec::with_capacity(total);
    (0..total)
        .into_par_iter()
        .map(|index| {
            let m = starts.partition_point(|&s| s <= index) - 1;
            let (i, joined) = plan[m];
            let mv = &moves[i];
            let (k, count) = (index - starts[m] + 1, starts[m + 1] - starts[m]);
            let s = k as f64 / count as f64;
            let q = if k == count { mv.end } else { mv.at(s, n) };
            let (pose, _) = kin.pose(Model::Nominal, &q[..n], length);
            RefPoint {
                line: mv.line,
                offset: mv.offset,
                s: if joined { s } else { 1.0 },
                along: 0.0,
                p: pose.p,
                o: pose.o,
                rapid: mv.shape == Shape::Rapid,
                first: !joined,
            }
        })
        .collect_into_vec(&mut points);
    let mut along = 0.0;
    for i in 1..points.len() {
        if !points[i].first {
            along += (points[i].p - points[i - 1].p).norm();
        }
        points[i].along = along;
    }
    Ok(points)
}

/// Into how many pieces a move is cut: enough that the tip moves at most `step` and the
/// direction at most `step / LEVER` between points (0 for a move that stays put). The tip
/// path is measured over the chord, or over four chords where the tool turns or the move
/// is an arc.
fn pieces(kin: &Kinematics, mv: &NominalMove, length: f64, step: f64) -> f64 {
    let n = kin.len();
    let Some(start) = mv.start else {
        return 1.0;
    };
    let pose = |q: &[f64; MAX_AXES]| kin.pose(Model::Nominal, &q[..n], length).0;
    let turns = (0..n).any(|v| kin.kind(v) == AxisKind::Rotary && start[v] != mv.end[v]);
    let chords = if turns || matches!(mv.shape, Shape::Arc(_)) {
        4
    } else {
        1
    };
    let mut previous = pose(&start);
    let (mut travel, mut turn) = (0.0, 0.0);
    for k in 1..=chords {
        let next = pose(&mv.at(f64::from(k) / f64::from(chords), n));
        travel += (next.p - previous.p).norm();
        turn += angle_between(&previous.o, &next.o);
        previous = next;
    }
    if travel == 0.0 && turn == 0.0 {
        return 0.0;
    }
    (travel / step).max(turn * LEVER / step).ceil().max(1.0)
}
