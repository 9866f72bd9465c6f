//! The measurement plan: which points of which feature are measured, where they nominally
//! are, and which error terms the plan identifies (docs/identify.md).
//!
//! A plan is a TOML file the user can adapt to their own artefact:
//!
//! ```toml
//! tool_radius = 3.0          # ball end mill radius the features were finished with (mm)
//! tool = 1                   # H number of the finishing tool
//!
//! [[feature]]
//! name = "base walls along X"
//! identifies = ["EYX"]       # error terms this feature is for (docs/identify.md)
//! stations = [-90.0, -70.0, -50.0, -30.0, -10.0, 10.0, 30.0, 50.0, 70.0, 90.0]
//! points = [
//!   { id = "BX001", at = [-97.5, -100.0, 5.0], normal = [0.0, -1.0, 0.0] },
//! ]
//! ```
//!
//! Points are in the part frame (mm): `at` is the nominal point on the finished surface,
//! `normal` its outward normal, the direction a probe touches it along. Every point must
//! lie on the finishing program's path (the ball's centre passes over it at `tool_radius`
//! along the normal). The terms are solved for from all points together, through the
//! kinematics; `identifies` only says which terms the plan provides and where the
//! straightness stations are.

use crate::workpiece::FeatureWorkpiece;
use crate::{Error, Result};
use nalgebra::{Rotation3, Vector3};
use serde::{Deserialize, Serialize};

/// One planned point: id, nominal position on the surface and outward surface normal,
/// in the part frame (mm).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlanPoint {
    pub id: String,
    pub at: [f64; 3],
    pub normal: [f64; 3],
}

/// A set of points on one feature.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Feature {
    pub name: String,
    /// Error terms: position-independent names (EC0Y, EX0C), error motions at a position
    /// (EBX@-50), or straightness over `stations` (EYX). See [`super::params`].
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub identifies: Vec<String>,
    /// Table positions of the straightness terms in `identifies` (axis values, program
    /// coordinates); the two ends are the reference line (0).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub stations: Vec<f64>,
    pub points: Vec<PlanPoint>,
}

/// A measurement plan.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Plan {
    pub tool_radius: f64,
    pub tool: u32,
    #[serde(rename = "feature")]
    pub features: Vec<Feature>,
}

impl Plan {
    /// Read a plan; `path` names it in messages.
    pub fn parse(text: &str, path: &str) -> Result<Plan> {
        let plan: Plan = toml::from_str(text).map_err(|e| {
            let at = e.span().map_or(0, |s| s.start);
            Error::at(path, text.as_bytes(), at, e.message().to_string())
        })?;
        let err = |needle: &str, m: String| Error::at(path, text.as_bytes(), find(text, needle), m);
        if !(plan.tool_radius.is_finite() && plan.tool_radius >= 0.0) {
            return Err(err(
                "tool_radius",
                format!(
                    "tool_radius = {}: expected the ball radius in mm (0 or more)",
                    plan.tool_radius
                ),
            ));
        }
        if plan.features.is_empty() {
            return Err(err("", "the plan has no [[feature]]".into()));
        }
        let mut ids = std::collections::BTreeSet::new();
        for f in &plan.features {
            if f.points.is_empty() {
                return Err(err(
                    &format!("\"{}\"", f.name),
                    format!("feature `{}` has no points", f.name),
                ));
            }
            for p in &f.points {
                let here = format!("\"{}\"", p.id);
                if !ids.insert(p.id.clone()) {
                    let second = text.match_indices(&here).nth(1).map_or(0, |(i, _)| i);
                    return Err(Error::at(
                        path,
                        text.as_bytes(),
                        second,
                        format!("point id `{}` is used twice", p.id),
                    ));
                }
                let n = v3(p.normal);
                let finite = n.iter().chain(&p.at).all(|c| c.is_finite());
                if !(finite && n.norm() > 1e-9) {
                    return Err(err(
                        &here,
                        format!(
                            "point `{}`: expected finite coordinates and a non-zero normal",
                            p.id
                        ),
                    ));
                }
            }
        }
        Ok(plan)
    }

    pub fn load(path: &std::path::Path) -> Result<Plan> {
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        Plan::parse(&text, &path.display().to_string())
    }

    /// The plan as a TOML file (one point per line).
    pub fn to_toml(&self) -> String {
        let mut out = String::from(
            "# Measurement plan of paper 000's feature workpiece (src/workpiece.rs) with its index\n\
             # faces, finished with a ball end mill. Written by Plan::feature_workpiece; see\n\
             # docs/identify.md for the format.\n\n",
        );
        out.push_str(&format!(
            "tool_radius = {:?}\ntool = {}\n",
            self.tool_radius, self.tool
        ));
        let list = |v: &[f64]| {
            v.iter()
                .map(|x| format!("{x:?}"))
                .collect::<Vec<_>>()
                .join(", ")
        };
        for f in &self.features {
            out.push_str(&format!("\n[[feature]]\nname = {:?}\n", f.name));
            if !f.identifies.is_empty() {
                let names: Vec<String> = f.identifies.iter().map(|n| format!("{n:?}")).collect();
                out.push_str(&format!("identifies = [{}]\n", names.join(", ")));
            }
            if !f.stations.is_empty() {
                out.push_str(&format!("stations = [{}]\n", list(&f.stations)));
            }
            out.push_str("points = [\n");
            for p in &f.points {
                out.push_str(&format!(
                    "  {{ id = {:?}, at = [{}], normal = [{}] }},\n",
                    p.id,
                    list(&p.at),
                    list(&p.normal)
                ));
            }
            out.push_str("]\n");
        }
        out
    }

    /// All planned points, in plan order.
    pub fn points(&self) -> impl Iterator<Item = &PlanPoint> {
        self.features.iter().flat_map(|f| f.points.iter())
    }

    /// The plan for [`FeatureWorkpiece`] with its index faces, finished with a ball of
    /// radius `r` (H1): lines of points 2.5 mm apart on every pass of the walls, strips
    /// and faces, a grid on the wedge, rings on the cylinder and the cone.
    pub fn feature_workpiece(w: &FeatureWorkpiece, r: f64) -> Plan {
        let round = |v: Vector3<f64>| v.map(|c| (c * 1e6).round() / 1e6 + 0.0).into();
        let line = |prefix: &str,
                    first: usize,
                    at: &dyn Fn(f64) -> Vector3<f64>,
                    normal: Vector3<f64>,
                    half: f64| {
            let n = (2.0 * half / SPACING).round() as usize;
            (0..=n)
                .map(|k| PlanPoint {
                    id: format!("{prefix}{:03}", first + k + 1),
                    at: round(at(-half + SPACING * k as f64)),
                    normal: round(normal),
                })
                .collect::<Vec<_>>()
        };
        let stations = |half: f64| -> Vec<f64> {
            let n = (2.0 * half / 20.0).round() as usize;
            (0..=n).map(|k| -half + 20.0 * k as f64).collect()
        };
        let (z, x, y) = (Vector3::z(), Vector3::x(), Vector3::y());
        let mut features = Vec::new();
        // The walls of both blocks: lines at the two contour heights (ball centre).
        let walls = |name: &str, prefix: &str, size: f64, levels: [f64; 2], along_x: bool| {
            let h = size / 2.0;
            let mut points = Vec::new();
            for level in levels {
                for sign in [-1.0, 1.0] {
                    let at = |t: f64| {
                        if along_x {
                            Vector3::new(t, sign * h, level)
                        } else {
                            Vector3::new(sign * h, t, level)
                        }
                    };
                    let normal = if along_x { y * sign } else { x * sign };
                    let first = points.len();
                    points.extend(line(prefix, first, &at, normal, h - SPACING));
                }
            }
            Feature {
                name: name.into(),
                identifies: Vec::new(),
                stations: Vec::new(),
                points,
            }
        };
        // The wall contours' tips are 2 and 6 mm above each block's bottom; the ball
        // touches the wall at its centre's height.
        let base = [2.0 + r, 6.0 + r];
        let upper = base.map(|l| l + w.base.1);
        let mut f = walls(
            "base block walls along X (X alone)",
            "BX",
            w.base.0,
            base,
            true,
        );
        f.identifies = vec!["EYX".into()];
        f.stations = stations(w.base.0 / 2.0 - 10.0);
        features.push(f);
        let mut f = walls(
            "base block walls along Y (Y alone)",
            "BY",
            w.base.0,
            base,
            false,
        );
        f.identifies = vec!["EXY".into(), "EC0Y".into()];
        f.stations = stations(w.base.0 / 2.0 - 10.0);
        features.push(f);
        let mut f = walls(
            "upper block walls along X (X alone)",
            "UX",
            w.upper.0,
            upper,
            true,
        );
        f.identifies = vec!["ECX@-50".into(), "ECX@50".into()];
        features.push(f);
        features.push(walls(
            "upper block walls along Y (Y alone)",
            "UY",
            w.upper.0,
            upper,
            false,
        ));
        // The wedge: a grid on every other pass of its raster.
        let n = w.wedge_normal();
        let up = n.cross(&x);
        let centre = Vector3::new(0.0, 0.0, w.wedge_centre_z);
        let mut points = Vec::new();
        for pass in 0..15 {
            let v = -56.0 + 8.0 * f64::from(pass);
            let first = points.len();
            points.extend(line("WE", first, &|t| centre + x * t + up * v, n, 56.0));
        }
        features.push(Feature {
            name: "wedge (3+2 at A = 10)".into(),
            identifies: vec!["EBX@-50".into(), "EBX@50".into()],
            stations: Vec::new(),
            points,
        });
        // The cylinder: C alone, its one ring.
        let zc = (w.cylinder_z.0 + w.cylinder_z.1) / 2.0;
        features.push(Feature {
            name: "cylinder (C alone)".into(),
            identifies: ["EX0C", "EY0C"].map(String::from).to_vec(),
            stations: Vec::new(),
            points: (0..72)
                .map(|k| {
                    let turn = Rotation3::from_axis_angle(
                        &Vector3::z_axis(),
                        (5.0 * f64::from(k)).to_radians(),
                    );
                    let radial = turn * -y;
                    PlanPoint {
                        id: format!("CY{:03}", k + 1),
                        at: round(radial * w.cylinder_radius + z * zc),
                        normal: round(radial),
                    }
                })
                .collect(),
        });
        // The cone: its six rings (five axes at once).
        let (s, c) = w.cone_half_angle.to_radians().sin_cos();
        let e2 = n.cross(&x);
        let mut points = Vec::new();
        for ring in 0..6 {
            let hh = w.cone_height * (f64::from(ring) + 0.5) / 6.0;
            let radius = w.cone_base_radius - hh * s / c;
            for k in 0..36 {
                let phi = (10.0 * f64::from(k)).to_radians();
                let radial = x * phi.cos() + e2 * phi.sin();
                points.push(PlanPoint {
                    id: format!("CO{:03}", points.len() + 1),
                    at: round(centre + n * hh + radial * radius),
                    normal: round(radial * c + n * s),
                });
            }
        }
        features.push(Feature {
            name: "cone (five axes)".into(),
            identifies: ["EY0A", "EZ0A"].map(String::from).to_vec(),
            stations: Vec::new(),
            points,
        });
        // Index faces (FeatureWorkpiece::index_faces). Points stay 5 mm clear of where
        // two passes cross.
        let top = w.base.1 + w.upper.1;
        let strip = (w.upper.0 + w.wedge_size) / 4.0;
        let step = (w.base.0 + w.upper.0) / 4.0;
        let mut points = Vec::new();
        for k in 0..4 {
            let turn =
                Rotation3::from_axis_angle(&Vector3::z_axis(), (90.0 * f64::from(k)).to_radians());
            let (out, along) = (turn * -y, turn * x);
            let first = points.len();
            let at = |t: f64| out * strip + along * t + z * top;
            points.extend(line("IS", first, &at, z, strip - 5.0));
        }
        features.push(Feature {
            name: "index strips (X alone at C 0 / 90 / 180 / -90)".into(),
            identifies: ["EZX", "EA0C", "EB0C"].map(String::from).to_vec(),
            stations: stations(strip - 10.0),
            points,
        });
        let mut points = Vec::new();
        for sign in [-1.0, 1.0] {
            let first = points.len();
            let at = |t: f64| Vector3::new(sign * step, t, w.base.1);
            points.extend(line("SY", first, &at, z, step - 5.0));
        }
        features.push(Feature {
            name: "step strips along Y (Y alone)".into(),
            identifies: vec!["EZY".into()],
            stations: stations(step - 10.0),
            points,
        });
        let mut points = Vec::new();
        for sign in [-1.0, 1.0] {
            let first = points.len();
            let at = |t: f64| Vector3::new(t, sign * step, w.base.1);
            points.extend(line("SX", first, &at, z, step - 5.0));
        }
        let face = w.base.1 + 4.0 + r;
        for sign in [-1.0, 1.0] {
            let first = points.len();
            let at = |t: f64| Vector3::new(t, sign * w.upper.0 / 2.0, face);
            points.extend(line("FY", first, &at, y * sign, w.upper.0 / 2.0 - SPACING));
        }
        features.push(Feature {
            name: "step strips and upper walls at A = -90 (X alone)".into(),
            identifies: ["EB0A", "EC0A"].map(String::from).to_vec(),
            stations: Vec::new(),
            points,
        });
        Plan {
            tool_radius: r,
            tool: 1,
            features,
        }
    }
}

/// Spacing of the points along a line (mm).
const SPACING: f64 = 2.5;

/// Byte offset of the first `needle` in `text` (0 when absent).
fn find(text: &str, needle: &str) -> usize {
    if needle.is_empty() {
        return 0;
    }
    text.find(needle).unwrap_or(0)
}

pub fn v3(a: [f64; 3]) -> Vector3<f64> {
    Vector3::new(a[0], a[1], a[2])
}
