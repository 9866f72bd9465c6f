//! Where a program cut each planned point, and what a machine does there.
//!
//! The program's G1 moves are read as a controller runs them: axis values interpolated
//! linearly. For a planned point P (outward normal n, ball radius r) the cutter location is
//! the point of the path whose nominal ball centre is nearest T = P + r·n. A machine with
//! an error model puts the ball centre at c(q) instead; to first order the surface it
//! leaves near P is displaced by the part of c(q) − T across the path (a displacement along
//! the path only slides the cutter along the surface it is cutting). That is the whole
//! model of the cut: the poses all come from [`Kinematics`].

use super::plan::{Plan, v3};
use crate::kinematics::{Kinematics, Model};
use crate::model::Machine;
use crate::nc::{self, TokenKind};
use nalgebra::Vector3;

/// The cutter location of one planned point.
#[derive(Debug, Clone)]
pub struct Cut {
    pub id: String,
    /// Axis values (kinematics variable order).
    pub q: Vec<f64>,
    /// Unit tangent of the nominal ball-centre path there.
    pub tangent: Vector3<f64>,
    /// T = P + r·n.
    pub target: Vector3<f64>,
    pub at: Vector3<f64>,
}

/// A G1 move: the axis values at its start and end.
pub type Move = (Vec<f64>, Vec<f64>);

/// The G1 moves of a program as pairs of axis-value vectors, and the active tool length.
pub fn moves(kin: &Kinematics, machine: &Machine, program: &str) -> (Vec<Move>, f64) {
    let n = kin.len();
    let letters: Vec<u8> = kin
        .axes()
        .iter()
        .map(|&a| machine.axes[a].word as u8)
        .collect();
    let mut q = vec![0.0; n];
    let mut rapid = true;
    let mut length = machine.tool.length;
    let mut out = Vec::new();
    let mut tokens = Vec::new();
    for line in nc::lines(program.as_bytes()) {
        tokens.clear();
        nc::parse_line(line.content, &mut tokens);
        let mut next = q.clone();
        let mut moved = false;
        let mut g43 = false;
        for t in &tokens {
            if let TokenKind::Word(w) = &t.kind {
                let Some(v) = w.number() else { continue };
                match w.letter {
                    b'G' if v == 0.0 => rapid = true,
                    b'G' if v == 1.0 => rapid = false,
                    b'G' if v == 43.0 => g43 = true,
                    b'H' if g43 => {
                        length = machine
                            .tool
                            .lengths
                            .get(&(v as u32))
                            .copied()
                            .unwrap_or(length)
                    }
                    l => {
                        if let Some(k) = letters.iter().position(|&c| c == l) {
                            next[k] = v;
                            moved = true;
                        }
                    }
                }
            }
        }
        if moved {
            if !rapid {
                out.push((q.clone(), next.clone()));
            }
            q = next;
        }
    }
    (out, length)
}

fn lerp(a: &[f64], b: &[f64], t: f64) -> Vec<f64> {
    a.iter().zip(b).map(|(x, y)| x + (y - x) * t).collect()
}

/// The ball centre at `q` with `model`.
pub fn centre(kin: &Kinematics, model: Model, q: &[f64], length: f64, r: f64) -> Vector3<f64> {
    kin.pose(model, q, length - r).0.p
}

/// The cutter location of every planned point on the program's path (nominal geometry).
pub fn cuts(kin: &Kinematics, machine: &Machine, plan: &Plan, program: &str) -> Vec<Cut> {
    let (moves, length) = moves(kin, machine, program);
    let r = plan.tool_radius;
    const SAMPLES: usize = 16;
    let samples: Vec<Vec<Vector3<f64>>> = moves
        .iter()
        .map(|(a, b)| {
            (0..=SAMPLES)
                .map(|i| {
                    centre(
                        kin,
                        Model::Nominal,
                        &lerp(a, b, i as f64 / SAMPLES as f64),
                        length,
                        r,
                    )
                })
                .collect()
        })
        .collect();
    let mut out = Vec::new();
    for f in &plan.features {
        for p in &f.points {
            let at = v3(p.at);
            let target = at + v3(p.normal) * r;
            // Best sample, then golden-section refinement on its neighbourhood.
            let mut best = (f64::INFINITY, 0usize, 0usize);
            for (m, s) in samples.iter().enumerate() {
                for (i, c) in s.iter().enumerate() {
                    let d = (c - target).norm();
                    if d < best.0 {
                        best = (d, m, i);
                    }
                }
            }
            let (a, b) = &moves[best.1];
            let dist =
                |t: f64| (centre(kin, Model::Nominal, &lerp(a, b, t), length, r) - target).norm();
            let step = 1.0 / SAMPLES as f64;
            let (mut lo, mut hi) = (
                (best.2 as f64 * step - step).max(0.0),
                (best.2 as f64 * step + step).min(1.0),
            );
            let g = 0.5 * (5f64.sqrt() - 1.0);
            for _ in 0..60 {
                let x1 = hi - g * (hi - lo);
                let x2 = lo + g * (hi - lo);
                if dist(x1) < dist(x2) {
                    hi = x2;
                } else {
                    lo = x1;
                }
            }
            let t = 0.5 * (lo + hi);
            let q = lerp(a, b, t);
            let h = 1e-4;
            let c1 = centre(kin, Model::Nominal, &lerp(a, b, t + h), length, r);
            let c0 = centre(kin, Model::Nominal, &lerp(a, b, t - h), length, r);
            let tangent = (c1 - c0).try_normalize(1e-15).unwrap_or_else(Vector3::x);
            out.push(Cut {
                id: p.id.clone(),
                q,
                tangent,
                target,
                at,
            });
        }
    }
    out
}

/// The tool length of the plan's tool on `machine`.
pub fn tool_length(machine: &Machine, plan: &Plan) -> f64 {
    machine
        .tool
        .lengths
        .get(&plan.tool)
        .copied()
        .unwrap_or(machine.tool.length)
}

/// The displacement across the path that `kin`'s actual model puts on the surface at `cut`
/// (relative to the target): the first-order cut.
pub fn displacement(kin: &Kinematics, cut: &Cut, length: f64, r: f64) -> Vector3<f64> {
    let d = centre(kin, Model::Actual, &cut.q, length, r) - cut.target;
    d - cut.tangent * cut.tangent.dot(&d)
}
