//! Where a program cut each planned point, and what a machine does there.
//!
//! The program's feed moves are read by the one reader as a controller runs them: axis
//! values interpolated linearly (arcs on their circles). For a planned point P (outward normal n, ball radius r) the cutter location is
//! the point of the path whose nominal ball centre is nearest T = P + r·n. A machine with
//! an error model puts the ball centre at c(q) instead; to first order the surface it
//! leaves near P is moved along n by n·(c(q) − T). That is the whole model of the cut: the
//! poses all come from [`Kinematics`]. A probe or a CMM touching the surface along n sees
//! exactly that, and nothing of a move along the surface.

use super::plan::{Plan, v3};
use crate::kinematics::{Kinematics, Model};
use crate::model::Machine;
use crate::program::moves::{NominalMove, Shape, nominal_moves};
use nalgebra::Vector3;

/// The cutter location of one planned point.
#[derive(Debug, Clone)]
pub struct Cut {
    pub id: String,
    /// Axis values (kinematics variable order).
    pub q: Vec<f64>,
    /// Unit outward normal of the surface at the planned point.
    pub normal: Vector3<f64>,
    /// The nominal ball centre over the point, T = P + r·n.
    pub target: Vector3<f64>,
    /// The planned point P.
    pub at: Vector3<f64>,
    /// How far the program's nominal ball centre passes from T (mm): 0 when the program
    /// cuts the point; more means the plan and the program disagree.
    pub miss: f64,
}

/// The feed moves (G1, G2, G3) of a program on the nominal machine, as the one reader reads
/// them (G90/G91, mm/inch, tool lengths), and the tool length they cut with; a program in
/// another tool chain than the machine's first, or cutting with two tool lengths, is
/// refused.
pub fn moves(
    machine: &Machine,
    program: &str,
    path: &str,
) -> crate::Result<(Vec<NominalMove>, f64)> {
    let (moves, chain) = nominal_moves(machine, 0, program.as_bytes(), path, 20)?;
    if chain != 0 {
        return Err(crate::Error::Usage(format!(
            "{path}: the program cuts in tool chain `{}`; expected the machine's first",
            machine.tool_chains[chain].name
        )));
    }
    let feed: Vec<NominalMove> = moves
        .into_iter()
        .filter(|m| m.start.is_some() && m.shape != Shape::Rapid)
        .collect();
    let length = feed.first().map_or(machine.tool.length, |m| m.tool_length);
    if let Some(other) = feed.iter().find(|m| m.tool_length != length) {
        return Err(crate::Error::at(
            path,
            program.as_bytes(),
            other.offset,
            format!(
                "this move cuts with a tool length of {} mm, the ones before with {length} mm: expected one tool",
                other.tool_length
            ),
        ));
    }
    Ok((feed, length))
}

/// The ball centre at `q` with `model`.
pub fn centre(kin: &Kinematics, model: Model, q: &[f64], length: f64, r: f64) -> Vector3<f64> {
    kin.pose(model, q, length - r).0.p
}

/// The cutter location of every planned point on the program's path (nominal geometry),
/// in plan order; the program is named `path` in messages.
pub fn cuts(
    kin: &Kinematics,
    machine: &Machine,
    plan: &Plan,
    program: &str,
    path: &str,
) -> crate::Result<Vec<Cut>> {
    let (moves, length) = moves(machine, program, path)?;
    let n = kin.len();
    let r = plan.tool_radius;
    const SAMPLES: usize = 16;
    let samples: Vec<Vec<Vector3<f64>>> = moves
        .iter()
        .map(|m| {
            (0..=SAMPLES)
                .map(|i| {
                    centre(
                        kin,
                        Model::Nominal,
                        &m.at(i as f64 / SAMPLES as f64, n)[..n],
                        length,
                        r,
                    )
                })
                .collect()
        })
        .collect();
    // Plain arrays: the search below runs for every point over every move.
    let polylines: Vec<Vec<[f64; 3]>> = samples
        .iter()
        .map(|s| s.iter().map(|c| [c.x, c.y, c.z]).collect())
        .collect();
    // A box around each move's samples: a point far from a box skips its samples.
    let boxes: Vec<([f64; 3], [f64; 3])> = polylines
        .iter()
        .map(|s| {
            let mut lo = [f64::INFINITY; 3];
            let mut hi = [f64::NEG_INFINITY; 3];
            for c in s {
                for k in 0..3 {
                    lo[k] = lo[k].min(c[k]);
                    hi[k] = hi[k].max(c[k]);
                }
            }
            (lo, hi)
        })
        .collect();
    let mut out = Vec::new();
    for f in &plan.features {
        for p in &f.points {
            let at = v3(p.at);
            let normal = v3(p.normal).try_normalize(1e-12).unwrap_or_else(Vector3::z);
            let target = at + normal * r;
            // The nominal path is nearly straight between samples: the nearest point of
            // the sampled polyline, then refinement on the path's local tangent.
            let best = nearest(&polylines, &boxes, [target.x, target.y, target.z]);
            let Some(m) = moves.get(best.1) else {
                continue;
            };
            let c = |t: f64| centre(kin, Model::Nominal, &m.at(t, n)[..n], length, r);
            let step = 1.0 / SAMPLES as f64;
            let mut t = best.2;
            let h = 1e-4 * step;
            let mut here = c(t);
            for _ in 0..4 {
                let tangent = if t + h <= 1.0 {
                    (c(t + h) - here) / h
                } else {
                    (here - c(t - h)) / h
                };
                let dt = (target - here).dot(&tangent) / tangent.norm_squared().max(1e-30);
                let next = (t + dt).clamp(0.0, 1.0);
                if (next - t).abs() < 1e-9 {
                    break;
                }
                t = next;
                here = c(t);
            }
            let q = m.at(t, n)[..n].to_vec();
            let miss = (here - target).norm();
            out.push(Cut {
                id: p.id.clone(),
                q,
                normal,
                target,
                at,
                miss,
            });
        }
    }
    Ok(out)
}

/// The nearest point to `x` on sampled polylines: (distance, polyline, parameter 0…1).
fn nearest(
    polylines: &[Vec<[f64; 3]>],
    boxes: &[([f64; 3], [f64; 3])],
    x: [f64; 3],
) -> (f64, usize, f64) {
    let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let gap = |m: usize| {
        let (lo, hi) = boxes[m];
        (0..3)
            .map(|k| (lo[k] - x[k]).max(x[k] - hi[k]).max(0.0).powi(2))
            .sum::<f64>()
    };
    // Squared distances; nearest boxes first, so that the first move sets a tight bound.
    let mut order: Vec<(f64, usize)> = (0..polylines.len()).map(|m| (gap(m), m)).collect();
    order.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
    let mut best = (f64::INFINITY, 0usize, 0.0);
    for (g, m) in order {
        if g >= best.0 {
            break;
        }
        let s = &polylines[m];
        let n = (s.len() - 1) as f64;
        for i in 0..s.len() - 1 {
            let d = sub(s[i + 1], s[i]);
            let u = (dot(sub(x, s[i]), d) / dot(d, d).max(1e-30)).clamp(0.0, 1.0);
            let e = sub(
                [s[i][0] + d[0] * u, s[i][1] + d[1] * u, s[i][2] + d[2] * u],
                x,
            );
            let dist = dot(e, e);
            if dist < best.0 {
                best = (dist, m, (i as f64 + u) / n);
            }
        }
    }
    (best.0.sqrt(), best.1, best.2)
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

/// How far `kin`'s actual model moves the cut surface at `cut` along its outward normal
/// (mm): the first-order cut. A ball cuts with its centre; moved by d, it leaves the
/// surface near the planned point moved by n·d (a move along the surface only slides the
/// ball along what it is cutting).
pub fn deviation(kin: &Kinematics, cut: &Cut, length: f64, r: f64) -> f64 {
    cut.normal
        .dot(&(centre(kin, Model::Actual, &cut.q, length, r) - cut.target))
}
