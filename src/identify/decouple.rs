//! From measured points to error terms, through the kinematics.
//!
//! A probe or a CMM touching a cut surface along its normal n measures one number per
//! point: how far the surface lies from its nominal place, n·(m − P). A feature of a real
//! machine is never sensitive to one error alone (a yaw of X moves the straightness trace
//! of X by its Abbe offset, a tilted A axis tilts the wedge), so these deviations are
//! mapped onto the terms of the model the way the machine makes them: the response of
//! every point to every unknown is computed once with the project's kinematics at the
//! program's cutter locations (a cut with one term set), and the unknowns are the least
//! squares solution of `response · θ = deviations`. The map is linear, so it commutes with
//! the paper's separation: identifying CMM − nominal gives the total, CMM − on-machine
//! the quasi-static part.

use super::cutting::{self, Cut};
use super::measure::Points;
use super::params::Params;
use super::plan::{Plan, v3};
use super::separate::Separation;
use crate::kinematics::Kinematics;
use crate::model::Machine;
use nalgebra::{DMatrix, DVector};

/// The linear map from unknowns to point deviations, and its least-squares inverse.
#[derive(Debug, Clone)]
pub struct Decoupling {
    pub params: Params,
    /// Point ids, in plan order: the rows.
    pub ids: Vec<String>,
    /// d deviation / d unknown (mm per mm, mm per rad).
    response: DMatrix<f64>,
    /// Column scales: the unknowns in mm and mrad, so that a column's size says how much
    /// the points move per unit of a similar order (a milliradian over the part's levers
    /// of some 100 mm moves them about as much as 0.1 mm), and singular values compare
    /// like with like.
    scale: Vec<f64>,
    /// The least-squares inverse of the scaled response.
    inverse: DMatrix<f64>,
    singular: Vec<f64>,
    v_t: DMatrix<f64>,
}

/// Relative singular value below which a combination of unknowns counts as unobservable.
pub const UNOBSERVABLE: f64 = 1e-6;

impl Decoupling {
    /// The response of the points `cuts` (from [`cutting::cuts`], plan order) to `params`.
    pub fn new(
        machine: &Machine,
        plan: &Plan,
        params: Params,
        cuts: &[Cut],
    ) -> crate::Result<Self> {
        let length = cutting::tool_length(machine, plan);
        let r = plan.tool_radius;
        let n = params.len();
        let usage = |e: crate::kinematics::KinematicsError| crate::Error::Usage(e.to_string());
        let base_kin =
            Kinematics::new(machine, &crate::model::ErrorModel::zero(machine), 0).map_err(usage)?;
        let base: Vec<f64> = cuts
            .iter()
            .map(|c| cutting::deviation(&base_kin, c, length, r))
            .collect();
        let mut response = DMatrix::zeros(cuts.len(), n);
        let scale: Vec<f64> = (0..n)
            .map(|j| if params.is_angle(j) { 1e3 } else { 1.0 })
            .collect();
        // The deviations are linear in the terms, and an unknown of a table acts through
        // its interpolation weight at the axis position: one cut per term is enough.
        let axes = base_kin.axes().to_vec();
        for term in params.terms() {
            let members: Vec<usize> = (0..n).filter(|&j| params.term(j) == term).collect();
            // Small enough to stay linear, large enough to be far above rounding.
            let step = 1e-3 / scale[members[0]];
            let kin = Kinematics::new(machine, &params.unit_model(machine, &term, step), 0)
                .map_err(usage)?;
            for (i, c) in cuts.iter().enumerate() {
                let unit = (cutting::deviation(&kin, c, length, r) - base[i]) / step;
                for &j in &members {
                    let w = match params.table_axis(j) {
                        None => 1.0,
                        Some(axis) => axes
                            .iter()
                            .position(|&a| a == axis)
                            .map_or(0.0, |v| params.weight(j, c.q[v])),
                    };
                    response[(i, j)] = unit * w;
                }
            }
        }
        let scaled = DMatrix::from_fn(cuts.len(), n, |i, j| response[(i, j)] / scale[j]);
        let svd = scaled.clone().svd(true, true);
        let singular: Vec<f64> = svd.singular_values.iter().copied().collect();
        let top = singular.iter().copied().fold(0.0, f64::max);
        let v_t = svd.v_t.clone().unwrap_or_else(|| DMatrix::zeros(0, n));
        let inverse = svd
            .pseudo_inverse(UNOBSERVABLE * top)
            .unwrap_or_else(|_| DMatrix::zeros(n, cuts.len()));
        Ok(Decoupling {
            params,
            ids: cuts.iter().map(|c| c.id.clone()).collect(),
            response,
            scale,
            inverse,
            singular,
            v_t,
        })
    }

    /// The deviations of `cuts` under an error model's kinematics: what a CMM would read on
    /// a part cut by it, to first order.
    pub fn predict(&self, values: &[f64]) -> Vec<f64> {
        (&self.response * DVector::from_column_slice(values))
            .iter()
            .copied()
            .collect()
    }

    /// The unknowns (mm, rad) that best explain point deviations (mm, rows in plan order).
    pub fn solve(&self, deviations: &[f64]) -> Vec<f64> {
        let theta = &self.inverse * DVector::from_column_slice(deviations);
        theta.iter().zip(&self.scale).map(|(t, s)| t / s).collect()
    }

    /// The combinations of unknowns the plan cannot tell apart (relative singular value
    /// below [`UNOBSERVABLE`]), as (name, weight) lists of their larger weights.
    pub fn unobservable(&self) -> Vec<Vec<(String, f64)>> {
        let top = self.singular.iter().copied().fold(0.0, f64::max);
        (0..self.singular.len())
            .filter(|&k| self.singular[k] < UNOBSERVABLE * top)
            .map(|k| {
                (0..self.params.len())
                    .filter(|&j| self.v_t[(k, j)].abs() > 0.05)
                    .map(|j| (self.params.names[j].clone(), self.v_t[(k, j)]))
                    .collect()
            })
            .collect()
    }

    /// The standard deviation of each unknown (mm, rad) when every deviation has noise of
    /// standard deviation `sigma` (mm): how well the plan determines it.
    pub fn uncertainty(&self, sigma: f64) -> Vec<f64> {
        (0..self.params.len())
            .map(|j| self.inverse.row(j).norm() * sigma / self.scale[j])
            .collect()
    }
}

/// The deviations n·(m − P) of measured points, in plan order (mm).
pub fn deviations(plan: &Plan, points: &Points) -> Vec<f64> {
    plan.points()
        .map(|p| {
            let at = v3(p.at);
            let n = v3(p.normal).try_normalize(1e-12).unwrap_or_default();
            points.get(&p.id).map_or(0.0, |m| n.dot(&(m - at)))
        })
        .collect()
}

/// An identification: the separation in model terms and how well the data fit them.
#[derive(Debug, Clone)]
pub struct Identified {
    pub separation: Separation,
    /// Root-mean-square residual (mm) of the fits of CMM − nominal, CMM − on-machine and
    /// on-machine − nominal: what the model does not explain (measurement noise, errors
    /// it does not have).
    pub residual: [f64; 3],
    /// The standard uncertainty of each quasi-static value (mm, rad) from its residual.
    pub uncertainty: Vec<f64>,
    pub points: usize,
}

impl Decoupling {
    /// Identify and separate from the on-machine and CMM points (paper 000 section 3.3):
    /// total = F(CMM) − F(nominal), quasi-static = F(CMM) − F(on-machine), dynamic = total −
    /// quasi-static, with F the least-squares decoupling.
    pub fn identify(&self, plan: &Plan, on_machine: &Points, cmm: &Points) -> Identified {
        let om = deviations(plan, on_machine);
        let cm = deviations(plan, cmm);
        let zero = vec![0.0; om.len()];
        let f = |d: &[f64]| self.solve(d);
        let separation = Separation::new(self.params.names.clone(), &f(&zero), &f(&om), &f(&cm));
        let rms = |data: &[f64], theta: &[f64]| {
            let fit = self.predict(theta);
            let ss: f64 = data.iter().zip(&fit).map(|(d, p)| (d - p).powi(2)).sum();
            let dof = data.len().saturating_sub(self.params.len()).max(1);
            (ss / dof as f64).sqrt()
        };
        let qs: Vec<f64> = cm.iter().zip(&om).map(|(c, o)| c - o).collect();
        let residual = [
            rms(&cm, &separation.total),
            rms(&qs, &separation.quasi_static),
            rms(&om, &separation.dynamic),
        ];
        Identified {
            uncertainty: self.uncertainty(residual[1]),
            separation,
            residual,
            points: om.len(),
        }
    }
}
