//! Paper 000's identification and separation formulas.
//!
//! Each feature gives "raw" quantities by the paper's formulas (eqs. 1–27): straightness
//! as deviations from the first point, squareness `atan(k_yx) − atan(k_xy)`, pitch and yaw
//! as line-fit slopes, axis offsets `(x2 − x0)/cos θ` and tilts from 3-D circle fits. The
//! same formula applied to nominal (x0), on-machine (x1) and CMM (x2) points separates:
//! total = F(CMM) − F(nominal), quasi-static = F(CMM) − F(on-machine), dynamic = total −
//! quasi-static.
//!
//! Features of a real machine are never sensitive to one error alone (a yaw of X tilts
//! the straightness trace of X by its Abbe offset, a tilted C axis moves the cylinder's
//! centre with its height). [`Decoupling`] maps the raw quantities onto the model's terms
//! through the project's kinematics: the response of every raw quantity to every term is
//! computed once (by "cutting" with a one-term error model), and the square system is
//! solved. The model values are what goes into the error file.

use super::fit;
use super::measure::Points;
use super::plan::{Kind, Plan, v3};
use nalgebra::{DMatrix, DVector, Point2, Point3, Vector3};

/// Raw quantities by name, in plan order (mm and rad).
#[derive(Debug, Clone, PartialEq)]
pub struct Raw {
    pub names: Vec<String>,
    pub values: Vec<f64>,
}

fn pts(points: &Points, ids: impl Iterator<Item = String>) -> Result<Vec<Vector3<f64>>, String> {
    ids.map(|id| {
        points
            .get(&id)
            .copied()
            .ok_or(format!("point {id} missing"))
    })
    .collect()
}

/// Paper eq. 16: `(x − x_ref)/cos θ`.
pub fn offset(x: f64, x_ref: f64, angle_deg: f64) -> f64 {
    (x - x_ref) / angle_deg.to_radians().cos()
}

/// Paper eq. 19: the unsigned angle between two normals.
pub fn tilt_angle(a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    (a.dot(b).abs() / (a.norm() * b.norm())).min(1.0).acos()
}

/// Paper eqs. 6–8: the angle between an X line (slope k_yx = dy/dx) and a Y line (slope
/// k_xy = dx/dy), less 90°.
pub fn squareness(k_yx: f64, k_xy: f64) -> f64 {
    k_yx.atan() - k_xy.atan()
}

/// The paper's formulas applied to one set of points (absolute values, not yet differences).
pub fn formulas(plan: &Plan, points: &Points) -> Result<Raw, String> {
    let mut names = Vec::new();
    let mut values = Vec::new();
    let mut slopes = std::collections::BTreeMap::new();
    for f in &plan.features {
        let p = pts(points, f.points.iter().map(|p| p.id.clone()))?;
        match f.kind {
            Kind::Straightness => {
                let along = if f.axis == "X" { 0 } else { 1 };
                for base in &f.identifies {
                    let c = match base.as_bytes().get(1) {
                        Some(b'X') => 0,
                        Some(b'Y') => 1,
                        _ => 2,
                    };
                    for (i, q) in p.iter().enumerate().skip(1) {
                        names.push(format!("{base}@{}", f.points[i].at[along]));
                        values.push(q[c] - p[0][c]);
                    }
                }
                let xy: Vec<Point2<f64>> = p
                    .iter()
                    .map(|q| {
                        if along == 0 {
                            Point2::new(q.x, q.y)
                        } else {
                            Point2::new(q.y, q.x)
                        }
                    })
                    .collect();
                let line = fit::line2(&xy).map_err(|e| format!("{}: {e}", f.name))?;
                slopes.insert(along, line.slope());
            }
            Kind::Angular => {
                let p3: Vec<Point3<f64>> = p.iter().map(|q| Point3::from(*q)).collect();
                let line = fit::line3(&p3).map_err(|e| format!("{}: {e}", f.name))?;
                let d = line.direction * line.direction.y.signum();
                let x = f.at_x.unwrap_or(0.0);
                names.push(format!("EBX@{x}"));
                values.push((d.z / d.y).atan());
                names.push(format!("ECX@{x}"));
                values.push((d.x / d.y).atan());
            }
            Kind::Circle => {
                let p3: Vec<Point3<f64>> = p.iter().map(|q| Point3::from(*q)).collect();
                let circle = fit::circle3(&p3).map_err(|e| format!("{}: {e}", f.name))?;
                let n0: Vector3<f64> = f
                    .points
                    .iter()
                    .map(|q| v3(q.tool))
                    .sum::<Vector3<f64>>()
                    .normalize();
                // The ring's nominal axis: the mean tool direction of a C-only cylinder is
                // along its axis; for the cone, the normal of the nominal ring.
                let nominal: Vec<Point3<f64>> =
                    f.points.iter().map(|q| Point3::from(v3(q.at))).collect();
                let n0 =
                    fit::circle3(&nominal).map_or(n0, |c| c.normal * c.normal.dot(&n0).signum());
                let n = circle.normal * circle.normal.dot(&n0).signum();
                let r = v3(f.reference.unwrap_or_default());
                let t = (r - circle.centre.coords).dot(&n0) / n.dot(&n0);
                let at = circle.centre.coords + n * t;
                let e1 = if n0.x.abs() < 0.9 {
                    Vector3::x()
                } else {
                    Vector3::y()
                };
                let e1 = (e1 - n0 * e1.dot(&n0)).normalize();
                let e2 = n0.cross(&e1);
                let tilt = n0.cross(&n);
                let cos = f.offset_angle.to_radians().cos();
                for (k, name) in f.identifies.iter().enumerate() {
                    names.push(name.clone());
                    values.push(match k {
                        0 => at.dot(&e1) / cos,
                        1 => at.dot(&e2) / cos,
                        2 => tilt.dot(&e1),
                        _ => tilt.dot(&e2),
                    });
                }
            }
        }
    }
    if let (Some(kyx), Some(kxy)) = (slopes.get(&0), slopes.get(&1)) {
        names.push("EC0Y".into());
        values.push(squareness(*kyx, *kxy));
    }
    Ok(Raw { names, values })
}

/// The planned (nominal) points as measured points.
pub fn nominal_points(plan: &Plan) -> Points {
    plan.features
        .iter()
        .flat_map(|f| f.points.iter())
        .map(|p| (p.id.clone(), v3(p.at)))
        .collect()
}

/// Total, quasi-static and dynamic values of the same quantities.
#[derive(Debug, Clone, PartialEq)]
pub struct Separation {
    pub names: Vec<String>,
    pub total: Vec<f64>,
    pub quasi_static: Vec<f64>,
    pub dynamic: Vec<f64>,
}

/// Which of the three to use.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Part {
    Total,
    QuasiStatic,
    Dynamic,
}

impl Separation {
    /// The paper's separation from the three formula results.
    pub fn from_raw(nominal: &Raw, on_machine: &Raw, cmm: &Raw) -> Separation {
        let n = nominal.values.len();
        let total: Vec<f64> = (0..n).map(|i| cmm.values[i] - nominal.values[i]).collect();
        let quasi_static: Vec<f64> = (0..n)
            .map(|i| cmm.values[i] - on_machine.values[i])
            .collect();
        let dynamic = (0..n).map(|i| total[i] - quasi_static[i]).collect();
        Separation {
            names: nominal.names.clone(),
            total,
            quasi_static,
            dynamic,
        }
    }

    pub fn part(&self, part: Part) -> &[f64] {
        match part {
            Part::Total => &self.total,
            Part::QuasiStatic => &self.quasi_static,
            Part::Dynamic => &self.dynamic,
        }
    }

    /// The table of the paper's tables 2–3: µm and µrad.
    pub fn table(&self, title: &str) -> String {
        let mut out = format!(
            "{title}\n{:<12} {:>12} {:>14} {:>12}\n",
            "term", "total", "quasi-static", "dynamic"
        );
        for (i, name) in self.names.iter().enumerate() {
            let unit = if is_angle(name) { "urad" } else { "um" };
            out.push_str(&format!(
                "{:<12} {:>12.3} {:>14.3} {:>12.3}  {unit}\n",
                name,
                self.total[i] * 1e3_f64.powi(if is_angle(name) { 2 } else { 1 }),
                self.quasi_static[i] * 1e3_f64.powi(if is_angle(name) { 2 } else { 1 }),
                self.dynamic[i] * 1e3_f64.powi(if is_angle(name) { 2 } else { 1 }),
            ));
        }
        out
    }
}

/// Whether a term (`EC0Y`, `EBX@-50`) is an angle.
pub fn is_angle(name: &str) -> bool {
    matches!(name.as_bytes().get(1), Some(b'A' | b'B' | b'C'))
}

/// The linear map from model terms to raw quantities, and its inverse.
#[derive(Debug, Clone)]
pub struct Decoupling {
    pub names: Vec<String>,
    response: DMatrix<f64>,
}

impl Decoupling {
    /// `response(term index, step)` gives the raw quantities (differences from nominal) of a
    /// cut with only that term set to `step`.
    pub fn new(names: Vec<String>, mut response: impl FnMut(usize, f64) -> Vec<f64>) -> Self {
        let n = names.len();
        let mut m = DMatrix::zeros(n, n);
        for j in 0..n {
            let step = if is_angle(&names[j]) { 1e-4 } else { 1e-3 };
            let r = response(j, step);
            for i in 0..n {
                m[(i, j)] = r[i] / step;
            }
        }
        Decoupling { names, response: m }
    }

    /// Smallest and largest singular value of the normalised response (its conditioning).
    pub fn singular_values(&self) -> (f64, f64) {
        let sv = self.response.clone().svd(false, false).singular_values;
        (sv.min(), sv.max())
    }

    /// Terms no raw quantity responds to (unobservable with this plan).
    pub fn unobserved(&self) -> Vec<String> {
        (0..self.names.len())
            .filter(|&j| self.response.column(j).norm() < 1e-6)
            .map(|j| self.names[j].clone())
            .collect()
    }

    /// The combinations of terms the plan cannot tell apart: right singular vectors with a
    /// singular value below `tol` of the largest, as (term, weight) lists.
    pub fn null_space(&self, tol: f64) -> Vec<Vec<(String, f64)>> {
        let svd = self.response.clone().svd(false, true);
        let top = svd.singular_values.max();
        let vt = svd.v_t.unwrap_or_else(|| DMatrix::zeros(0, 0));
        (0..svd.singular_values.len())
            .filter(|&k| svd.singular_values[k] < tol * top)
            .map(|k| {
                (0..self.names.len())
                    .filter(|&j| vt[(k, j)].abs() > 0.05)
                    .map(|j| (self.names[j].clone(), vt[(k, j)]))
                    .collect()
            })
            .collect()
    }

    /// Model terms from raw quantities.
    pub fn solve(&self, raw: &[f64]) -> Vec<f64> {
        let svd = self.response.clone().svd(true, true);
        svd.solve(&DVector::from_column_slice(raw), 1e-12)
            .map(|v| v.iter().copied().collect())
            .unwrap_or_else(|_| vec![0.0; raw.len()])
    }

    /// The separation in model terms.
    pub fn separate(&self, raw: &Separation) -> Separation {
        let total = self.solve(&raw.total);
        let quasi_static = self.solve(&raw.quasi_static);
        let dynamic = total
            .iter()
            .zip(&quasi_static)
            .map(|(t, q)| t - q)
            .collect();
        Separation {
            names: self.names.clone(),
            total,
            quasi_static,
            dynamic,
        }
    }
}

/// An error file (design/model.md schema, µm and µrad) for model terms `names` = `values`
/// (mm, rad). Straightness terms `EYX@x` are tabulated with 0 at the first station;
/// pitch/yaw `EBX@x` tables are interpolated linearly between their positions and held
/// beyond (as a two-point table is).
pub fn error_toml(names: &[String], values: &[f64], title: &str) -> String {
    use std::collections::BTreeMap;
    let mut constant: BTreeMap<(bool, char), Vec<(String, f64)>> = BTreeMap::new();
    let mut motion: BTreeMap<char, BTreeMap<String, Vec<(f64, f64)>>> = BTreeMap::new();
    for (name, &v) in names.iter().zip(values) {
        let scaled = v * if is_angle(name) { 1e6 } else { 1e3 };
        if let Some((base, at)) = name.split_once('@') {
            let axis = base.chars().last().unwrap_or('X');
            let x: f64 = at.parse().unwrap_or(0.0);
            motion
                .entry(axis)
                .or_default()
                .entry(base.to_string())
                .or_default()
                .push((x, scaled));
        } else {
            let axis = name.chars().last().unwrap_or('C');
            let rotary = matches!(axis, 'A' | 'B' | 'C');
            constant
                .entry((rotary, axis))
                .or_default()
                .push((name.clone(), scaled));
        }
    }
    let mut out = format!(
        "# {title}\n# Written by nccomp identify (docs/identify.md).\nlength_unit = \"um\"\nangle_unit = \"urad\"\n"
    );
    for ((rotary, axis), terms) in &constant {
        if *rotary {
            out.push_str(&format!("\n[location.{axis}]\n"));
        } else {
            out.push_str("\n[squareness]\n");
        }
        for (n, v) in terms {
            out.push_str(&format!("{n} = {v:.4}\n"));
        }
    }
    for (axis, terms) in &motion {
        let mut positions: Vec<f64> = terms.values().flatten().map(|(x, _)| *x).collect();
        let lowest = positions.iter().copied().fold(f64::INFINITY, f64::min);
        positions.push(lowest - 20.0);
        positions.sort_by(f64::total_cmp);
        positions.dedup();
        out.push_str(&format!("\n[motion.{axis}]\npositions = {positions:?}\n"));
        for (base, samples) in terms {
            let mut s = samples.clone();
            if !is_angle(base) {
                // Straightness: the first station is the reference, 0.
                s.push((lowest - 20.0, 0.0));
            }
            s.sort_by(|a, b| a.0.total_cmp(&b.0));
            let at = |x: f64| -> f64 {
                if x <= s[0].0 {
                    return s[0].1;
                }
                for w in s.windows(2) {
                    if x <= w[1].0 {
                        return w[0].1 + (w[1].1 - w[0].1) * (x - w[0].0) / (w[1].0 - w[0].0);
                    }
                }
                s[s.len() - 1].1
            };
            let vals: Vec<String> = positions.iter().map(|&x| format!("{:.4}", at(x))).collect();
            out.push_str(&format!("{base} = [{}]\n", vals.join(", ")));
        }
    }
    out
}
