//! The path between block ends.
//!
//! A controller interpolates axis values linearly between blocks, on the nominal machine
//! and on the real one alike. Compensating the ends of a move does not make its middle
//! right: the errors vary along the move and the kinematics is not linear. This module
//! measures how far the compensated path strays from the nominal one, and splits a move
//! where it strays too far. (Wiring it into the pass is issue 3's subdivision.)

use super::{Kinematics, MAX_AXES, Model, Solution, SolveOptions, angle_between};

/// How far a compensated move strays from its nominal move, sampled at equal parameter
/// s ∈ (0, 1): the controller is at nominal `q(s)` on the ideal machine and at `q*(s)` on
/// the real one.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Deviation {
    /// Largest tip distance (mm) and where (s).
    pub position: f64,
    pub position_at: f64,
    /// Largest direction angle (rad) at non-singular samples, and where.
    pub direction: f64,
    pub direction_at: f64,
}

/// One piece of a subdivided move: its end parameter and the compensated axis values there.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Piece {
    pub s: f64,
    pub q: [f64; MAX_AXES],
    pub solution: Option<Solution>,
}

/// Tolerances of a path: tip distance (mm) and tool direction (rad).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathTolerance {
    pub position: f64,
    pub direction: f64,
    /// Pieces are halved at most this many times (2^depth pieces per move).
    pub max_depth: u32,
}

impl Default for PathTolerance {
    fn default() -> Self {
        PathTolerance {
            position: 0.001,
            direction: 10e-6,
            max_depth: 10,
        }
    }
}

/// A move is split into at most this many times 2^max_depth pieces, transitions across
/// the singular cone included (see [`Kinematics::subdivide`]).
pub const MOVE_PIECES: usize = 4;

fn lerp(a: &[f64], b: &[f64], s: f64, out: &mut [f64; MAX_AXES]) {
    for k in 0..a.len() {
        out[k] = a[k] + (b[k] - a[k]) * s;
    }
}

impl Kinematics {
    /// The deviation along the move from nominal `qa` → `qb`, executed as `ca` → `cb` on
    /// the real machine, sampled at parameters `samples`.
    #[allow(clippy::too_many_arguments)]
    pub fn deviation(
        &self,
        (qa, qb): (&[f64], &[f64]),
        (ca, cb): (&[f64], &[f64]),
        length: f64,
        samples: &[f64],
        options: &SolveOptions,
    ) -> Deviation {
        let n = self.len();
        let mut dev = Deviation::default();
        let (mut qn, mut qc) = ([0.0; MAX_AXES], [0.0; MAX_AXES]);
        let mut dirs = [nalgebra::Vector3::zeros(); MAX_AXES];
        for &s in samples {
            lerp(&qa[..n], &qb[..n], s, &mut qn);
            lerp(&ca[..n], &cb[..n], s, &mut qc);
            // Only the axis directions of the Jacobian are needed (the singular test), and
            // the real pose is near the nominal one: its sines and cosines by addition.
            let angles = self.angles(&qn[..n]);
            let (target, _) = self.axes_at(Model::Nominal, &qn[..n], length, &angles, &mut dirs);
            let (actual, _) = self.pose_near(Model::Actual, &qc[..n], length, &angles);
            let dp = (actual.p - target.p).norm();
            if dp > dev.position {
                dev.position = dp;
                dev.position_at = s;
            }
            // At a singular pose the direction is not held to the tolerance (the free
            // axis is never swung to chase it).
            if self.singular_axes(&target, &dirs, options.singular_angle) == 0 {
                let dd = angle_between(&actual.o, &target.o);
                if dd > dev.direction {
                    dev.direction = dd;
                    dev.direction_at = s;
                }
            }
        }
        dev
    }

    /// Split the move nominal `qa` → `qb` (compensated ends `ca`, `cb`) into pieces whose
    /// compensated paths stay within `tol` at their quarter points. Returns the pieces
    /// after the start, in order, the last ending at s = 1 with `cb`; a move that needs no
    /// split gives one piece. Axes in `hold` keep their nominal values at inserted points.
    /// Transitions stop refining once the move has about [`MOVE_PIECES`]·2^max_depth
    /// pieces (a bound on the work and the output for any program).
    #[allow(clippy::too_many_arguments)]
    pub fn subdivide(
        &self,
        moves: (&[f64], &[f64]),
        compensated: (&[f64], &[f64]),
        length: f64,
        hold: u32,
        tol: &PathTolerance,
        options: &SolveOptions,
    ) -> Vec<Piece> {
        let mut pieces = Vec::new();
        self.subdivide_into(moves, compensated, length, hold, tol, options, &mut pieces);
        pieces
    }

    /// [`Kinematics::subdivide`] into `pieces` (cleared first): a pass that checks every
    /// move reuses one list instead of allocating one per block.
    #[allow(clippy::too_many_arguments)]
    pub fn subdivide_into(
        &self,
        (qa, qb): (&[f64], &[f64]),
        (ca, cb): (&[f64], &[f64]),
        length: f64,
        hold: u32,
        tol: &PathTolerance,
        options: &SolveOptions,
        pieces: &mut Vec<Piece>,
    ) {
        let n = self.len();
        let mut end = [0.0; MAX_AXES];
        end[..n].copy_from_slice(&cb[..n]);
        let mut start = [0.0; MAX_AXES];
        start[..n].copy_from_slice(&ca[..n]);
        pieces.clear();
        self.split(
            (qa, qb),
            (0.0, start),
            (1.0, end, None),
            length,
            hold,
            tol,
            options,
            0,
            pieces,
        );
    }

    #[allow(clippy::too_many_arguments)]
    fn split(
        &self,
        (qa, qb): (&[f64], &[f64]),
        (s0, c0): (f64, [f64; MAX_AXES]),
        (s1, c1, sol1): (f64, [f64; MAX_AXES], Option<Solution>),
        length: f64,
        hold: u32,
        tol: &PathTolerance,
        options: &SolveOptions,
        depth: u32,
        out: &mut Vec<Piece>,
    ) {
        let n = self.len();
        let (mut n0, mut n1) = ([0.0; MAX_AXES], [0.0; MAX_AXES]);
        lerp(&qa[..n], &qb[..n], s0, &mut n0);
        lerp(&qa[..n], &qb[..n], s1, &mut n1);
        let dev = self.deviation(
            (&n0[..n], &n1[..n]),
            (&c0[..n], &c1[..n]),
            length,
            &[0.25, 0.5, 0.75],
            options,
        );
        let mut fine = dev.position <= tol.position && dev.direction <= tol.direction;
        // Only a move's first piece starts from a written point (its other ends are
        // solutions): only there can the ends leave the position off.
        if !fine && (dev.position <= tol.position || s0 == 0.0) {
            // What the ends leave is the floor: halving cannot take the path below it. In
            // direction: a machine with fewer than five axes, a held rotary axis; in
            // position: the start as written, rounded to a resolution coarser than the
            // tolerance (0.0001 in is 2.54 µm), or left uncompensated.
            // Where the position is off, the start alone (the end is a solution).
            let ends: &[f64] = if dev.position <= tol.position {
                &[0.0, 1.0]
            } else {
                &[0.0]
            };
            let floor = self.deviation(
                (&n0[..n], &n1[..n]),
                (&c0[..n], &c1[..n]),
                length,
                ends,
                options,
            );
            fine = dev.position <= floor.position + tol.position
                && dev.direction <= floor.direction + tol.direction;
        }
        if fine {
            out.push(Piece {
                s: s1,
                q: c1,
                solution: sol1,
            });
            return;
        }
        if depth >= tol.max_depth {
            // Halving does not help where the solution jumps: a rotary axis entering or
            // leaving the singular cone goes from corrected to held within any interval
            // around the edge. Swing it across in steps with the tip kept on the path.
            let (p0, j0) = self.pose_and_jacobian(Model::Nominal, &n0[..n], length);
            let (p1, j1) = self.pose_and_jacobian(Model::Nominal, &n1[..n], length);
            let switching = (self.singular_axes(&p0, &j0.axis_dir, options.singular_angle)
                ^ self.singular_axes(&p1, &j1.axis_dir, options.singular_angle))
                & !hold;
            if switching != 0 {
                self.transition(
                    (qa, qb),
                    (s0, c0),
                    (s1, c1, sol1),
                    length,
                    hold | switching,
                    tol,
                    options,
                    out,
                );
            } else {
                out.push(Piece {
                    s: s1,
                    q: c1,
                    solution: sol1,
                });
            }
            return;
        }
        let mid = 0.5 * (s0 + s1);
        let mut qm = [0.0; MAX_AXES];
        lerp(&qa[..n], &qb[..n], mid, &mut qm);
        let sol = self.compensate(&qm[..n], length, hold, options);
        // The solve starts at the nominal point, so a rotary axis stays on its side.
        let cm = sol.q;
        self.split(
            (qa, qb),
            (s0, c0),
            (mid, cm, Some(sol)),
            length,
            hold,
            tol,
            options,
            depth + 1,
            out,
        );
        self.split(
            (qa, qb),
            (mid, cm),
            (s1, c1, sol1),
            length,
            hold,
            tol,
            options,
            depth + 1,
            out,
        );
    }

    /// Pieces from `c0` to `c1` across a jump of the axes in `swing` (held on one side,
    /// corrected on the other): the swung axes step linearly from their value at `c0` to
    /// that at `c1` while the other axes are solved to keep the tip on the nominal path,
    /// with as many steps as the position tolerance needs. The direction is not held to
    /// its tolerance here: at the cone's edge it is what the hold leaves anyway.
    #[allow(clippy::too_many_arguments)]
    fn transition(
        &self,
        (qa, qb): (&[f64], &[f64]),
        (s0, c0): (f64, [f64; MAX_AXES]),
        (s1, c1, sol1): (f64, [f64; MAX_AXES], Option<Solution>),
        length: f64,
        swing: u32,
        tol: &PathTolerance,
        options: &SolveOptions,
        out: &mut Vec<Piece>,
    ) {
        let n = self.len();
        let position_only = PathTolerance {
            direction: f64::INFINITY,
            ..*tol
        };
        let mut steps = 2usize;
        loop {
            let mut pieces = Vec::with_capacity(steps);
            let mut prev = (s0, c0);
            let mut within = true;
            for k in 1..=steps {
                let f = k as f64 / steps as f64;
                let (s, q, sol) = if k == steps {
                    (s1, c1, sol1)
                } else {
                    let s = s0 + (s1 - s0) * f;
                    let mut qn = [0.0; MAX_AXES];
                    lerp(&qa[..n], &qb[..n], s, &mut qn);
                    let mut start = qn;
                    for v in 0..n {
                        if swing & (1 << v) != 0 {
                            start[v] = c0[v] + (c1[v] - c0[v]) * f;
                        }
                    }
                    let (target, _) = self.pose(Model::Nominal, &qn[..n], length);
                    let sol =
                        self.solve(Model::Actual, &target, &start[..n], length, swing, options);
                    (s, sol.q, Some(sol))
                };
                let (mut n0, mut n1) = ([0.0; MAX_AXES], [0.0; MAX_AXES]);
                lerp(&qa[..n], &qb[..n], prev.0, &mut n0);
                lerp(&qa[..n], &qb[..n], s, &mut n1);
                let dev = self.deviation(
                    (&n0[..n], &n1[..n]),
                    (&prev.1[..n], &q[..n]),
                    length,
                    &[0.25, 0.5, 0.75],
                    options,
                );
                within &= dev.position <= position_only.position;
                pieces.push(Piece {
                    s,
                    q,
                    solution: sol,
                });
                prev = (s, q);
            }
            // A move swung through the cone thousands of times (an absurd rotary value
            // written with --allow-limit-violations) would otherwise take minutes and
            // millions of blocks: no move gets more than MOVE_PIECES times the halving's
            // 2^max_depth pieces.
            let budget = MOVE_PIECES << tol.max_depth;
            if within || steps >= 1 << tol.max_depth || out.len() + 2 * steps > budget {
                out.extend(pieces);
                return;
            }
            steps *= 2;
        }
    }
}
