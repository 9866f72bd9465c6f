//! The `identify` and `simulate-cut` commands over files: everything is read and checked
//! here, problems name file:line:column, and the outputs come back as text for the
//! command line to write.

use super::decouple::{self, Decoupling};
use super::measure::{self, Points};
use super::params::Params;
use super::plan::Plan;
use super::report;
use super::separate::Part;
use super::simulate::{Cutting, CuttingError};
use crate::model::{ErrorModel, Machine, error_file, machine_file};
use crate::{Error, Result};
use std::path::Path;

fn read(path: &Path) -> Result<(String, String)> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    Ok((text, path.display().to_string()))
}

/// The byte offset of `"needle"` in a TOML text (0 when it is not there).
fn quoted(text: &str, needle: &str) -> usize {
    text.find(&format!("\"{needle}\"")).unwrap_or(0)
}

/// The machine, the plan and where the program cut each planned point.
pub struct Workpiece {
    pub machine: Machine,
    pub plan: Plan,
    plan_path: String,
    plan_text: String,
    program: String,
    program_path: String,
}

impl Workpiece {
    pub fn load(machine: &Path, plan: &Path, program: &Path) -> Result<Self> {
        let machine = machine_file::load(machine)?;
        let (plan_text, plan_path) = read(plan)?;
        let plan = Plan::parse(&plan_text, &plan_path)?;
        let (program, program_path) = read(program)?;
        Ok(Workpiece {
            machine,
            plan,
            plan_path,
            plan_text,
            program,
            program_path,
        })
    }

    /// Where the program cuts the plan's points; a point it does not cut is an error at
    /// the point in the plan.
    pub fn cutting(&self) -> Result<Cutting<'_>> {
        Cutting::new(&self.machine, &self.plan, &self.program, &self.program_path).map_err(|e| {
            match e {
                CuttingError::Program(e) => e,
                CuttingError::Point(id, m) => Error::at(
                    &self.plan_path,
                    self.plan_text.as_bytes(),
                    quoted(&self.plan_text, &id),
                    m,
                ),
            }
        })
    }

    /// The unknowns of the plan; a term that cannot be identified is an error at the term.
    pub fn params(&self) -> Result<Params> {
        Params::new(&self.plan, &self.machine).map_err(|e| {
            Error::at(
                &self.plan_path,
                self.plan_text.as_bytes(),
                quoted(&self.plan_text, &e.term),
                e.message,
            )
        })
    }
}

/// What `nccomp identify` produces.
pub struct Identification {
    /// The separation table (paper 000 tables 2–3).
    pub table: String,
    /// The error file of the chosen part.
    pub errors: String,
}

/// Identify from the two measurement files and separate (docs/identify.md).
pub fn identify(
    work: &Workpiece,
    on_machine: &Path,
    cmm: &Path,
    part: Part,
) -> Result<Identification> {
    let points = |path: &Path| -> Result<Points> { measure::load(path, &work.plan) };
    let (om, cm) = (points(on_machine)?, points(cmm)?);
    let params = work.params()?;
    let cutting = work.cutting()?;
    let dec = Decoupling::new(&work.machine, &work.plan, params, &cutting.cuts)?;
    if let Some(combination) = dec.unobservable().first() {
        // Values along it would be arbitrary: no error file from such a plan.
        let terms: Vec<String> = combination
            .iter()
            .map(|(n, w)| format!("{w:+.2}·{n}"))
            .collect();
        let first = combination.first().map_or("", |(n, _)| n.as_str());
        let term = dec
            .params
            .names
            .iter()
            .position(|n| n == first)
            .map_or("", |j| dec.params.term(j));
        return Err(Error::at(
            &work.plan_path,
            work.plan_text.as_bytes(),
            quoted(&work.plan_text, term),
            format!(
                "the plan cannot tell these terms apart: any amount of {} fits the points \
                 equally well; add points that see them differently, or identify fewer terms",
                terms.join(" ")
            ),
        ));
    }
    let id = dec.identify(&work.plan, &om, &cm);
    let name = match part {
        Part::Total => "total (CMM - nominal)",
        Part::QuasiStatic => "quasi-static (CMM - on-machine)",
        Part::Dynamic => "dynamic (total - quasi-static)",
    };
    let title = format!(
        "{name} errors identified from {} and {} with plan {}",
        on_machine.display(),
        cmm.display(),
        work.plan_path
    );
    Ok(Identification {
        table: report::table(&dec, &id),
        errors: dec
            .params
            .error_toml(&work.machine, id.separation.part(part), &title),
    })
}

/// What `nccomp simulate-cut` produces: the two measurement files and a summary.
pub struct Simulation {
    pub on_machine: String,
    pub cmm: String,
    pub summary: String,
}

/// Cut the program on the machine with the quasi-static error file plus the dynamic one
/// (active only while cutting) and measure both ways with noise of standard deviation
/// `noise_um` (µm) from `seed`.
pub fn simulate_cut(
    work: &Workpiece,
    quasi_static: &Path,
    dynamic: Option<&Path>,
    noise_um: f64,
    seed: u64,
) -> Result<Simulation> {
    if !(noise_um.is_finite() && noise_um >= 0.0) {
        return Err(Error::Usage(format!(
            "--noise {noise_um}: expected a standard deviation in µm, 0 or more"
        )));
    }
    let quasi = error_file::load(quasi_static, &work.machine)?;
    let dynamic = match dynamic {
        Some(p) => error_file::load(p, &work.machine)?,
        None => ErrorModel::zero(&work.machine),
    };
    let cutting = work.cutting()?;
    let m = cutting.measure(&quasi, &dynamic, noise_um * 1e-3, seed)?;
    let mut summary = format!(
        "{:<52} {:>6} {:>14} {:>14}\n",
        "feature", "points", "CMM max |dev|", "probe max |dev|"
    );
    let (cmm, om) = (
        decouple::deviations(&work.plan, &m.cmm),
        decouple::deviations(&work.plan, &m.on_machine),
    );
    let mut i = 0;
    for f in &work.plan.features {
        let n = f.points.len();
        let worst = |d: &[f64]| d[i..i + n].iter().fold(0.0f64, |a, v| a.max(v.abs())) * 1e3;
        summary.push_str(&format!(
            "{:<52} {n:>6} {:>11.3} µm {:>11.3} µm\n",
            f.name,
            worst(&cmm),
            worst(&om)
        ));
        i += n;
    }
    Ok(Simulation {
        on_machine: measure::to_csv(&work.plan, &m.on_machine),
        cmm: measure::to_csv(&work.plan, &m.cmm),
        summary,
    })
}
