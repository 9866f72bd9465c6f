//! The measurement plan: which points of which feature are measured, where they nominally
//! are, how the tool met them, and which errors each set identifies (docs/identify.md).
//!
//! A plan is a TOML file the user can adapt to their own artefact:
//!
//! ```toml
//! tool_radius = 3.0          # ball end mill radius the features were finished with (mm)
//! tool = 1                   # H number of the finishing tool
//!
//! [[feature]]
//! name = "x_straightness"
//! kind = "straightness"      # straightness | angular | circle
//! axis = "X"                 # the axis that moved while the feature was cut
//! identifies = ["EYX", "EZX"]
//! points = [
//!   { id = "XS01", at = [-90.0, -100.0, 5.0], normal = [0.0, -1.0, 0.0], tool = [0.0, 0.0, 1.0] },
//! ]
//! ```
//!
//! Kinds: `straightness` (points in order along `axis`; deviations from the first point,
//! paper 000 eqs. 1–5; two such features, X and Y, also give the squareness, eqs. 6–10);
//! `angular` (a line of points along Y at the X position `at_x`; slopes, eqs. 11–15);
//! `circle` (a ring cut by one rotary axis; 3-D circle fit, offset at the plane through
//! `reference` normal to the nominal ring axis, divided by cos(`offset_angle`), and
//! tilt, eqs. 16–27).

use crate::workpiece::FeatureWorkpiece;
use crate::{Error, Result};
use nalgebra::{Rotation3, Vector3};
use serde::{Deserialize, Serialize};

/// What a feature's points are for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Kind {
    Straightness,
    Angular,
    Circle,
}

/// One planned point: id, nominal position on the surface, outward surface normal and the
/// tool direction it was cut with (all in the part frame, mm).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlanPoint {
    pub id: String,
    pub at: [f64; 3],
    pub normal: [f64; 3],
    pub tool: [f64; 3],
}

/// A set of points on one feature.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Feature {
    pub name: String,
    pub kind: Kind,
    /// Straightness: the moving axis ("X" or "Y"). Circle: the rotary axis.
    pub axis: String,
    /// Error terms this set identifies: straightness base names (EYX), or full names
    /// (ECX@-50 for pitch/yaw at X = -50, EX0C ...).
    pub identifies: Vec<String>,
    /// Angular: the X position of the line.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub at_x: Option<f64>,
    /// Circle: where the axis line is located (its point at home in the part frame).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reference: Option<[f64; 3]>,
    /// Circle: the paper's projection angle in eq. 16 (degrees; 0 when the ring's axis is
    /// the located axis in the part frame, as on the AC trunnion here).
    #[serde(default)]
    pub offset_angle: f64,
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

/// Least points per kind of feature.
pub fn min_points(kind: Kind) -> usize {
    match kind {
        Kind::Straightness => 3,
        Kind::Angular => 3,
        Kind::Circle => 6,
    }
}

impl Plan {
    /// Read a plan; `path` names it in messages.
    pub fn parse(text: &str, path: &str) -> Result<Plan> {
        let plan: Plan = toml::from_str(text).map_err(|e| {
            let at = e.span().map_or(0, |s| s.start);
            Error::at(path, text.as_bytes(), at, e.message().to_string())
        })?;
        let here = |what: &str| {
            let at = text.find(what).unwrap_or(0);
            move |m: String| Error::at(path, text.as_bytes(), at, m)
        };
        let mut ids = std::collections::BTreeSet::new();
        for f in &plan.features {
            let err = here(&format!("\"{}\"", f.name));
            if f.points.len() < min_points(f.kind) {
                return Err(err(format!(
                    "feature `{}` has {} points; a {:?} set needs at least {}",
                    f.name,
                    f.points.len(),
                    f.kind,
                    min_points(f.kind)
                )));
            }
            if f.kind == Kind::Angular && f.at_x.is_none() {
                return Err(err(format!("angular feature `{}` needs `at_x`", f.name)));
            }
            if f.kind == Kind::Circle && f.reference.is_none() {
                return Err(err(format!(
                    "circle feature `{}` needs `reference`",
                    f.name
                )));
            }
            for p in &f.points {
                if !ids.insert(p.id.clone()) {
                    return Err(here(&format!("\"{}\"", p.id))(format!(
                        "point id `{}` is used twice",
                        p.id
                    )));
                }
            }
        }
        Ok(plan)
    }

    pub fn load(path: &std::path::Path) -> Result<Plan> {
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        Plan::parse(&text, &path.display().to_string())
    }

    pub fn to_toml(&self) -> String {
        let body = toml::to_string(self).unwrap_or_default();
        format!(
            "# Measurement plan of paper 000's feature workpiece (src/workpiece.rs), finished \
with a ball end mill.\n# Written by Plan::feature_workpiece; see docs/identify.md for the format.\n\n{body}"
        )
    }

    pub fn feature(&self, name: &str) -> Option<&Feature> {
        self.features.iter().find(|f| f.name == name)
    }

    /// The plan for [`FeatureWorkpiece`] finished with a ball of radius `r` (H1).
    pub fn feature_workpiece(w: &FeatureWorkpiece, r: f64) -> Plan {
        let pt = |id: String, at: Vector3<f64>, normal: Vector3<f64>, tool: Vector3<f64>| {
            let round = |v: Vector3<f64>| [0, 1, 2].map(|i| (v[i] * 1e9).round() / 1e9 + 0.0);
            PlanPoint {
                id,
                at: round(at),
                normal: round(normal),
                tool: round(tool),
            }
        };
        let z = Vector3::z();
        let h = w.base.0 / 2.0;
        let stations: Vec<f64> = (0..10).map(|i| -90.0 + 20.0 * f64::from(i)).collect();
        let mut features = vec![
            Feature {
                name: "x_straightness".into(),
                kind: Kind::Straightness,
                axis: "X".into(),
                identifies: vec!["EYX".into(), "EZX".into()],
                at_x: None,
                reference: None,
                offset_angle: 0.0,
                points: stations
                    .iter()
                    .enumerate()
                    .map(|(i, &x)| {
                        let at = Vector3::new(x, -h, 5.0);
                        pt(format!("XS{:02}", i + 1), at, -Vector3::y(), z)
                    })
                    .collect(),
            },
            Feature {
                name: "y_straightness".into(),
                kind: Kind::Straightness,
                axis: "Y".into(),
                identifies: vec!["EXY".into(), "EZY".into()],
                at_x: None,
                reference: None,
                offset_angle: 0.0,
                points: stations
                    .iter()
                    .enumerate()
                    .map(|(i, &y)| {
                        let at = Vector3::new(-h, y, 5.0);
                        pt(format!("YS{:02}", i + 1), at, -Vector3::x(), z)
                    })
                    .collect(),
            },
        ];
        let n = w.wedge_normal();
        let up = n.cross(&Vector3::x());
        let centre = Vector3::new(0.0, 0.0, w.wedge_centre_z);
        for (tag, x) in [("m50", -50.0), ("p50", 50.0)] {
            features.push(Feature {
                name: format!("wedge_x{tag}"),
                kind: Kind::Angular,
                axis: "X".into(),
                identifies: vec![format!("EBX@{x}"), format!("ECX@{x}")],
                at_x: Some(x),
                reference: None,
                offset_angle: 0.0,
                points: (0..15)
                    .map(|i| {
                        let v = -56.0 + 8.0 * f64::from(i);
                        let at = centre + Vector3::x() * x + up * v;
                        pt(format!("W{tag}{:02}", i + 1), at, n, n)
                    })
                    .collect(),
            });
        }
        // The cylinder: C alone at A = 10 deg, ring at the middle of the band.
        let (s, c) = w.cylinder_tilt.to_radians().sin_cos();
        let zc = (w.cylinder_z.0 + w.cylinder_z.1) / 2.0;
        features.push(Feature {
            name: "cylinder".into(),
            kind: Kind::Circle,
            axis: "C".into(),
            identifies: ["EX0C", "EY0C", "EA0C", "EB0C"].map(String::from).to_vec(),
            at_x: None,
            reference: Some([0.0, 0.0, 0.0]),
            offset_angle: 0.0,
            points: (0..72)
                .map(|k| {
                    let turn = Rotation3::from_axis_angle(
                        &Vector3::z_axis(),
                        (5.0 * f64::from(k)).to_radians(),
                    );
                    let radial = turn * Vector3::new(0.0, -1.0, 0.0);
                    let dir = turn * Vector3::new(0.0, -s, c);
                    let at = radial * w.cylinder_radius + Vector3::new(0.0, 0.0, zc);
                    pt(format!("CY{:02}", k + 1), at, radial, dir)
                })
                .collect(),
        });
        // The cone: one ring of its five-axis finishing path (h = 5 mm).
        let (s, c) = w.cone_half_angle.to_radians().sin_cos();
        let hh = 5.0;
        let radius = w.cone_base_radius - hh * s / c;
        let e2 = n.cross(&Vector3::x());
        features.push(Feature {
            name: "cone".into(),
            kind: Kind::Circle,
            axis: "A".into(),
            identifies: ["EY0A", "EZ0A", "EB0A", "EC0A"].map(String::from).to_vec(),
            at_x: None,
            reference: Some((centre + n * hh).into()),
            offset_angle: 0.0,
            points: (0..72)
                .map(|k| {
                    let phi = (5.0 * f64::from(k)).to_radians();
                    let radial = Vector3::x() * phi.cos() + e2 * phi.sin();
                    let dir = radial * c + n * s;
                    let at = centre + n * hh + radial * radius;
                    pt(format!("CO{:02}", k + 1), at, dir, dir)
                })
                .collect(),
        });
        let _ = r;
        Plan {
            tool_radius: r,
            tool: 1,
            features,
        }
    }
}

pub fn v3(a: [f64; 3]) -> Vector3<f64> {
    Vector3::new(a[0], a[1], a[2])
}
