//! The feature workpiece of paper 000 and the path that finishes it.
//!
//! Paper 000 cuts an artefact whose features each involve few axes, so that each feature
//! is sensitive to few errors: two stacked blocks (X, Y), a 10° wedge (3+2 at A = 10°), a
//! cone tilted 10° (five axes at once) and a cylinder turned by C alone at A = 10°. The
//! paper gives sizes, not a drawing; the layout here is our reading (docs/feature-workpiece.md):
//! everything is centred on the C axis, the part's origin is the centre of its underside on
//! the table, z up:
//!
//! - base block 200 × 200 × 10 (z 0–10) and upper block 160 × 160 × 10 (z 10–20);
//! - the wedge: a 120 × 120 plane rising 10° towards +Y through (0, 0, 31);
//! - the cone: axis along the wedge normal (10° from Z) through (0, 0, 31), base radius 40
//!   on the wedge, half angle 15° (cone angle 30°), 12 high;
//! - the cylinder: radius 25, coaxial with C, its finished band at z 45–55, cut with the tool
//!   tilted 10° while only C turns.
//!
//! The path is given in the part frame as tool-tip points and tool directions for a ball
//! end mill; turning it into axis values is the machine's inverse kinematics.

use nalgebra::{Rotation3, Vector3};

/// One point of a tool path: tip position and tool direction (tip towards spindle) in
/// the part frame, and whether the move to it is a rapid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathPoint {
    pub tip: Vector3<f64>,
    pub dir: Vector3<f64>,
    pub rapid: bool,
}

/// A named part of the path (one feature).
#[derive(Debug, Clone, PartialEq)]
pub struct Operation {
    pub name: &'static str,
    pub points: Vec<PathPoint>,
    /// Rotary axis values, by program word, the operation starts from where its path
    /// leaves them free (C while the tool is along C on an AC trunnion). Empty: the
    /// previous operation's values.
    pub index: Vec<(char, f64)>,
}

/// The artefact's dimensions (mm, degrees).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FeatureWorkpiece {
    pub base: (f64, f64),
    pub upper: (f64, f64),
    pub wedge_size: f64,
    pub wedge_angle: f64,
    pub wedge_centre_z: f64,
    pub cone_base_radius: f64,
    pub cone_half_angle: f64,
    pub cone_height: f64,
    pub cylinder_radius: f64,
    pub cylinder_z: (f64, f64),
    pub cylinder_tilt: f64,
}

impl Default for FeatureWorkpiece {
    /// The sizes of paper 000.
    fn default() -> Self {
        FeatureWorkpiece {
            base: (200.0, 10.0),
            upper: (160.0, 10.0),
            wedge_size: 120.0,
            wedge_angle: 10.0,
            wedge_centre_z: 31.0,
            cone_base_radius: 40.0,
            cone_half_angle: 15.0,
            cone_height: 12.0,
            cylinder_radius: 25.0,
            cylinder_z: (45.0, 55.0),
            cylinder_tilt: 10.0,
        }
    }
}

/// Clearance (mm) for approach and retract moves, along the tool.
const CLEARANCE: f64 = 30.0;

impl FeatureWorkpiece {
    /// Unit normal of the wedge plane (10° from Z, leaning towards −Y as the plane rises
    /// towards +Y).
    pub fn wedge_normal(&self) -> Vector3<f64> {
        let (s, c) = self.wedge_angle.to_radians().sin_cos();
        Vector3::new(0.0, -s, c)
    }

    /// The finishing path for a ball end mill of radius `r`, feature by feature.
    pub fn finishing_path(&self, r: f64) -> Vec<Operation> {
        vec![
            self.block_walls("base block walls", self.base.0, &[2.0, 6.0], r),
            self.block_walls(
                "upper block walls",
                self.upper.0,
                &[self.base.1 + 2.0, self.base.1 + 6.0],
                r,
            ),
            self.wedge(),
            self.cone(),
            self.cylinder(r),
        ]
        .into_iter()
        .chain(self.index_faces(r))
        .collect()
    }

    /// Index faces, our extension for identification (docs/feature-workpiece.md): single
    /// passes cut by X or Y alone at several rotary indexes, so that the location errors
    /// of A and C, which tilt the part as a whole, show on long lines:
    ///
    /// - the four top strips of the upper block (between it and the wedge), each cut by X
    ///   at A = 0 with C turned so that the strip faces the front (C 0, 90, 180, −90);
    /// - the ±X strips of the base block's step, cut by Y at A = 0, C = 0;
    /// - the ±Y strips of the base block's step, cut by X with the ball's side at
    ///   A = −90° (the tool along the part's ∓Y);
    /// - the ±Y walls of the upper block, cut face-on by X at A = −90°, between the two
    ///   contours of the wall operation.
    pub fn index_faces(&self, r: f64) -> Vec<Operation> {
        let z = Vector3::z();
        let top = self.base.1 + self.upper.1;
        let strip = (self.upper.0 + self.wedge_size) / 4.0;
        let step = (self.base.0 + self.upper.0) / 4.0;
        let half = self.upper.0 / 2.0 + 5.0;
        let long = self.base.0 / 2.0 + 5.0;
        let pass = |from: Vector3<f64>, to: Vector3<f64>, dir: Vector3<f64>| {
            [from, to].map(|tip| PathPoint {
                tip,
                dir,
                rapid: false,
            })
        };
        let mut ops = Vec::new();
        let names = [
            "index strip -Y: X alone, A = 0, C = 0",
            "index strip +X: X alone, A = 0, C = 90",
            "index strip +Y: X alone, A = 0, C = 180",
            "index strip -X: X alone, A = 0, C = -90",
        ];
        for (k, name) in names.into_iter().enumerate() {
            let turn =
                Rotation3::from_axis_angle(&Vector3::z_axis(), (90.0 * k as f64).to_radians());
            let out = turn * -Vector3::y();
            let along = turn * Vector3::x();
            let centre = out * strip + z * top;
            let mut op = with_approach(
                name,
                pass(centre - along * half, centre + along * half, z).to_vec(),
            );
            let c = if k == 3 { -90.0 } else { 90.0 * k as f64 };
            op.index = vec![('C', c)];
            ops.push(op);
        }
        for (name, x) in [
            ("step strip -X: Y alone, A = 0", -step),
            ("step strip +X: Y alone, A = 0", step),
        ] {
            let mut op = with_approach(
                name,
                pass(
                    Vector3::new(x, -long, self.base.1),
                    Vector3::new(x, long, self.base.1),
                    z,
                )
                .to_vec(),
            );
            op.index = vec![('C', 0.0)];
            ops.push(op);
        }
        for (name, sign) in [
            ("step strip -Y: X alone, ball side, A = -90", -1.0),
            ("step strip +Y: X alone, ball side, A = -90", 1.0),
        ] {
            let dir = Vector3::y() * sign;
            let centre = |x: f64| Vector3::new(x, sign * step, self.base.1 + r);
            ops.push(with_approach(
                name,
                pass(centre(-long) - dir * r, centre(long) - dir * r, dir).to_vec(),
            ));
        }
        let face = self.base.1 + 4.0 + r;
        for (name, sign) in [
            ("upper wall -Y face-on: X alone, A = -90", -1.0),
            ("upper wall +Y face-on: X alone, A = -90", 1.0),
        ] {
            let dir = Vector3::y() * sign;
            let y = sign * self.upper.0 / 2.0;
            ops.push(with_approach(
                name,
                pass(
                    Vector3::new(-half, y, face),
                    Vector3::new(half, y, face),
                    dir,
                )
                .to_vec(),
            ));
        }
        ops
    }

    /// Contours around a square block with the tool vertical, the ball's side on the wall.
    fn block_walls(&self, name: &'static str, size: f64, levels: &[f64], r: f64) -> Operation {
        let z = Vector3::z();
        let h = size / 2.0 + r;
        let mut points = Vec::new();
        for &level in levels {
            let corners = [(-h, -h), (h, -h), (h, h), (-h, h), (-h, -h)];
            for (x, y) in corners {
                points.push(PathPoint {
                    tip: Vector3::new(x, y, level),
                    dir: z,
                    rapid: false,
                });
            }
        }
        with_approach(name, points)
    }

    /// Raster over the wedge plane, tool normal to it (3+2 at A = 10°).
    fn wedge(&self) -> Operation {
        let n = self.wedge_normal();
        let along = Vector3::x();
        let up_slope = n.cross(&along);
        let centre = Vector3::new(0.0, 0.0, self.wedge_centre_z);
        let half = self.wedge_size / 2.0;
        let passes = 31;
        let mut points = Vec::new();
        for i in 0..passes {
            let v = -half + self.wedge_size * i as f64 / (passes - 1) as f64;
            let (from, to) = if i % 2 == 0 {
                (-half, half)
            } else {
                (half, -half)
            };
            for u in [from, to] {
                points.push(PathPoint {
                    tip: centre + along * u + up_slope * v,
                    dir: n,
                    rapid: false,
                });
            }
        }
        with_approach("wedge: 3+2, tool tilted 10 deg", points)
    }

    /// Rings around the tilted cone, tool normal to its surface: A and C move together.
    fn cone(&self) -> Operation {
        let n = self.wedge_normal();
        let e1 = Vector3::x();
        let e2 = n.cross(&e1);
        let base = Vector3::new(0.0, 0.0, self.wedge_centre_z);
        let (s, c) = self.cone_half_angle.to_radians().sin_cos();
        let mut points = Vec::new();
        let rings = 6;
        let steps = 72;
        for ring in 0..rings {
            let h = self.cone_height * (ring as f64 + 0.5) / rings as f64;
            let radius = self.cone_base_radius - h * s / c;
            for k in 0..=steps {
                let phi = std::f64::consts::TAU * k as f64 / steps as f64;
                let radial = e1 * phi.cos() + e2 * phi.sin();
                points.push(PathPoint {
                    tip: base + n * h + radial * radius,
                    dir: radial * c + n * s,
                    rapid: false,
                });
            }
        }
        with_approach("tilted cone: five axes at once", points)
    }

    /// The cylinder, cut by C alone: the tool tilted 10° away from the cylinder's axis, the
    /// ball's centre on a circle of radius R + r.
    fn cylinder(&self, r: f64) -> Operation {
        let (s, c) = self.cylinder_tilt.to_radians().sin_cos();
        let mut points = Vec::new();
        let z = (self.cylinder_z.0 + self.cylinder_z.1) / 2.0;
        for k in 0..=180 {
            let turn =
                Rotation3::from_axis_angle(&Vector3::z_axis(), (2.0 * k as f64).to_radians());
            let radial = turn * Vector3::new(0.0, -1.0, 0.0);
            let dir = turn * Vector3::new(0.0, -s, c);
            let centre = radial * (self.cylinder_radius + r) + Vector3::new(0.0, 0.0, z);
            points.push(PathPoint {
                tip: centre - dir * r,
                dir,
                rapid: false,
            });
        }
        with_approach("cylinder: C alone, tool tilted 10 deg", points)
    }
}

/// Rapid to a point clear of the first cutting point along the tool, and back out after
/// the last.
fn with_approach(name: &'static str, cut: Vec<PathPoint>) -> Operation {
    let mut points = Vec::with_capacity(cut.len() + 2);
    if let (Some(first), Some(last)) = (cut.first().copied(), cut.last().copied()) {
        points.push(PathPoint {
            tip: first.tip + first.dir * CLEARANCE,
            dir: first.dir,
            rapid: true,
        });
        points.extend(cut);
        points.push(PathPoint {
            tip: last.tip + last.dir * CLEARANCE,
            dir: last.dir,
            rapid: true,
        });
    }
    Operation {
        name,
        points,
        index: Vec::new(),
    }
}

/// Why a path could not be turned into a program.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ProgramError {
    #[error("{operation}: point {index} ({tip:?}) is out of the machine's reach")]
    OutOfReach {
        operation: &'static str,
        index: usize,
        tip: [f64; 3],
    },
}

/// How the program is written.
#[derive(Debug, Clone, PartialEq)]
pub struct ProgramStyle {
    pub title: String,
    /// H number of the tool (its length is looked up in the machine file).
    pub tool: u32,
    pub feed: f64,
    pub spindle: f64,
    pub decimals: u8,
}

/// Turn operations into a G0/G1 program in machine axes with the nominal inverse
/// kinematics of `kin`; axis words are modal (written only when they change), blocks are
/// numbered N10, N20, ...
pub fn to_program(
    kin: &crate::kinematics::Kinematics,
    machine: &crate::model::Machine,
    operations: &[Operation],
    style: &ProgramStyle,
) -> Result<String, ProgramError> {
    use crate::kinematics::{Model, Pose, SolveOptions};
    use crate::model::AxisKind;
    use std::fmt::Write;

    let length = machine
        .tool
        .lengths
        .get(&style.tool)
        .copied()
        .unwrap_or(machine.tool.length);
    let n = kin.len();
    let options = SolveOptions::default();
    let within = |q: &[f64]| {
        (0..n).all(|k| {
            machine.axes[kin.axes()[k]]
                .travel
                .is_none_or(|[lo, hi]| q[k] >= lo - 1e-9 && q[k] <= hi + 1e-9)
        })
    };
    // Rotary guesses spread over each rotary axis's travel.
    let rotary: Vec<usize> = (0..n)
        .filter(|&k| kin.kind(k) == AxisKind::Rotary)
        .collect();
    let spread = |k: usize| -> Vec<f64> {
        let [lo, hi] = machine.axes[kin.axes()[k]]
            .travel
            .unwrap_or([-180.0, 180.0]);
        (0..=8)
            .map(|i| lo + (hi - lo) * f64::from(i) / 8.0)
            .collect()
    };
    let mut grid: Vec<Vec<f64>> = vec![vec![0.0; n]];
    for &k in &rotary {
        grid = grid
            .into_iter()
            .flat_map(|g| {
                spread(k).into_iter().map(move |v| {
                    let mut g = g.clone();
                    g[k] = v;
                    g
                })
            })
            .collect();
    }
    let rotary_distance =
        |a: &[f64], b: &[f64]| -> f64 { rotary.iter().map(|&k| (a[k] - b[k]).abs()).sum() };

    let mut out = String::new();
    let mut number = 0u32;
    let mut block = |out: &mut String, text: &str| {
        number += 10;
        let _ = writeln!(out, "N{number} {text}");
    };
    let _ = writeln!(out, "%");
    let _ = writeln!(out, "O0001 ({})", style.title);
    block(&mut out, "G21 G90 G94 G17 G40 G80");
    block(&mut out, &format!("T{} M6", style.tool));
    block(&mut out, &format!("G43 H{}", style.tool));
    block(&mut out, &format!("S{} M3", style.spindle));
    let mut previous: Vec<f64> = vec![0.0; n];
    let mut written: Vec<Option<String>> = vec![None; n];
    let mut feed_written = false;
    let mut rapid_mode = None;
    for op in operations {
        let _ = writeln!(out, "({})", op.name.to_uppercase());
        for (index, point) in op.points.iter().enumerate() {
            let target = Pose {
                p: point.tip,
                o: point.dir.normalize(),
            };
            if index == 0 {
                // A new operation starts from a clear position: unwind continuous rotary
                // axes so their values stay near the usual range.
                for &k in &rotary {
                    if machine.axes[kin.axes()[k]].travel.is_none() {
                        previous[k] = (previous[k] + 180.0).rem_euclid(360.0) - 180.0;
                    }
                    let word = machine.axes[kin.axes()[k]].word;
                    if let Some(&(_, v)) = op.index.iter().find(|(w, _)| *w == word) {
                        previous[k] = v;
                    }
                }
            }
            let mut best: Option<Vec<f64>> = None;
            let guesses = std::iter::once(previous.clone()).chain(if index == 0 {
                grid.clone()
            } else {
                Vec::new()
            });
            for guess in guesses {
                if let Some(sol) = kin.inverse(Model::Nominal, &target, &guess, length, &options) {
                    let q = sol.values().to_vec();
                    let better = best.as_ref().is_none_or(|b| {
                        rotary_distance(&q, &previous) < rotary_distance(b, &previous)
                    });
                    if within(&q) && better {
                        best = Some(q);
                    }
                }
                if index > 0 && best.is_some() {
                    break;
                }
            }
            let q = match best {
                Some(q) => q,
                None if index > 0 => {
                    // Continuity failed (a branch change): search the whole grid.
                    grid.iter()
                        .filter_map(|g| kin.inverse(Model::Nominal, &target, g, length, &options))
                        .map(|s| s.values().to_vec())
                        .filter(|q| within(q))
                        .min_by(|a, b| {
                            rotary_distance(a, &previous).total_cmp(&rotary_distance(b, &previous))
                        })
                        .ok_or(ProgramError::OutOfReach {
                            operation: op.name,
                            index,
                            tip: point.tip.into(),
                        })?
                }
                None => {
                    return Err(ProgramError::OutOfReach {
                        operation: op.name,
                        index,
                        tip: point.tip.into(),
                    });
                }
            };
            let mut text = String::new();
            if rapid_mode != Some(point.rapid) {
                text.push_str(if point.rapid { "G0" } else { "G1" });
                rapid_mode = Some(point.rapid);
            }
            for k in 0..n {
                let value = crate::nc::number::fixed(q[k], style.decimals);
                if written[k].as_deref() != Some(value.as_str()) {
                    let letter = machine.axes[kin.axes()[k]].word;
                    if !text.is_empty() {
                        text.push(' ');
                    }
                    let _ = write!(text, "{letter}{value}");
                    written[k] = Some(value);
                }
            }
            if !point.rapid && !feed_written {
                let _ = write!(text, " F{}", style.feed);
                feed_written = true;
            }
            if !text.is_empty() {
                block(&mut out, &text);
            }
            previous = q;
        }
    }
    block(&mut out, "M5");
    block(&mut out, "M30");
    let _ = writeln!(out, "%");
    Ok(out)
}

impl ProgramStyle {
    /// The style of the shipped fixture program (fixtures/feature_workpiece.nc).
    pub fn feature_workpiece() -> Self {
        ProgramStyle {
            title: "FEATURE WORKPIECE FINISH, PAPER 000 - WRITTEN BY examples/feature_workpiece.rs"
                .into(),
            tool: 1,
            feed: 1200.0,
            spindle: 12000.0,
            decimals: 4,
        }
    }
}
