//! The parameter study (paper 002, section 3.2 and table 6): the change of the tool tip and
//! tool direction when one error term goes from 0 to one unit (1 µm for lengths, 10 µrad
//! for angles by default), all others staying 0.
//!
//! Two versions, which must agree:
//!
//! - **exact**: the finite change `F(u·e_i) − F(0)` of the pose computed by the kinematics
//!   with the term at one unit (the paper's eq. 4);
//! - **linear**: the Jacobian of the pose with respect to the term times one unit. The
//!   derivative is taken by a central difference with a step of a hundredth of the unit,
//!   so it is the tangent, free of the second-order part the exact change holds.
//!
//! They differ by the second-order effect of one unit (for an angle ε and a lever arm L,
//! about ε²·L/2: 10 µrad at 500 mm gives 2.5e-8 mm against a first-order 5e-3 mm).

use super::{Deviation, Probe};
use serde::Serialize;

/// The units of the study, in model units (mm, rad).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StudyOptions {
    pub unit_length: f64,
    pub unit_angle: f64,
}

impl Default for StudyOptions {
    /// The paper's: 0.001 mm and 10 µrad.
    fn default() -> Self {
        StudyOptions {
            unit_length: 1e-3,
            unit_angle: 1e-5,
        }
    }
}

/// One pose, or the worst case over several.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Mode {
    /// The study at one pose.
    AtPose,
    /// Each component is its value of largest magnitude over the poses (sign kept).
    WorstCase,
}

/// The effect of one unit of one term.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StudyRow {
    pub term: String,
    /// The unit in model units (mm or rad).
    pub unit: f64,
    /// `1 µm`, `10 µrad`.
    pub unit_label: String,
    /// The finite change for one unit.
    pub exact: Deviation,
    /// Jacobian × unit.
    pub linear: Deviation,
    /// The pose (index into [`Study::poses`]) of the largest tip change.
    pub worst_pose: usize,
}

/// The parameter study of a machine.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Study {
    pub mode: Mode,
    /// The poses looked at, `X=50 Y=45 Z=5`.
    pub poses: Vec<String>,
    pub rows: Vec<StudyRow>,
    /// The largest |linear − exact| over every term, pose and component: tip (mm) and
    /// direction.
    pub max_difference: [f64; 2],
}

/// Run the study for the probe's terms at the probe's poses.
pub fn run(probe: &Probe, options: &StudyOptions) -> Study {
    let n = probe.terms.len();
    let mut rows = Vec::with_capacity(n);
    let mut max_difference = [0.0f64; 2];
    for (i, term) in probe.terms.iter().enumerate() {
        let unit = if term.is_length() {
            options.unit_length
        } else {
            options.unit_angle
        };
        let at = |v: f64| {
            let mut values = vec![0.0; n];
            values[i] = v;
            probe.deviations(&values)
        };
        let exact = at(unit);
        let h = unit * 1e-2;
        let (plus, minus) = (at(h), at(-h));
        let linear: Vec<Deviation> = plus
            .iter()
            .zip(&minus)
            .map(|(p, m)| p.minus(m).scaled(unit / (2.0 * h)))
            .collect();
        for (e, l) in exact.iter().zip(&linear) {
            let (dp, d_o) = e.minus(l).max_abs();
            max_difference[0] = max_difference[0].max(dp);
            max_difference[1] = max_difference[1].max(d_o);
        }
        // Per component, the pose where the exact change is largest.
        let mut row_exact = Deviation::default();
        let mut row_linear = Deviation::default();
        for c in 0..6 {
            let get = |d: &Deviation| if c < 3 { d.dp[c] } else { d.do_[c - 3] };
            let k = (0..exact.len())
                .max_by(|&a, &b| get(&exact[a]).abs().total_cmp(&get(&exact[b]).abs()))
                .unwrap_or(0);
            let (e, l) = (get(&exact[k]), get(&linear[k]));
            if c < 3 {
                row_exact.dp[c] = e;
                row_linear.dp[c] = l;
            } else {
                row_exact.do_[c - 3] = e;
                row_linear.do_[c - 3] = l;
            }
        }
        let norm = |d: &Deviation| d.dp.iter().map(|v| v * v).sum::<f64>();
        let worst_pose = (0..exact.len())
            .max_by(|&a, &b| norm(&exact[a]).total_cmp(&norm(&exact[b])))
            .unwrap_or(0);
        rows.push(StudyRow {
            term: term.name.clone(),
            unit,
            unit_label: unit_label(unit, term.is_length()),
            exact: row_exact,
            linear: row_linear,
            worst_pose,
        });
    }
    Study {
        mode: if probe.poses.len() == 1 {
            Mode::AtPose
        } else {
            Mode::WorstCase
        },
        poses: (0..probe.poses.len())
            .map(|k| probe.describe_pose(k))
            .collect(),
        rows,
        max_difference,
    }
}

/// `1 µm`, `10 µrad`, `0.5 mm`.
pub fn unit_label(unit: f64, length: bool) -> String {
    let (v, name) = if length {
        if unit >= 0.1 {
            (unit, "mm")
        } else {
            (unit * 1e3, "µm")
        }
    } else if unit >= 0.1 {
        (unit, "rad")
    } else {
        (unit * 1e6, "µrad")
    };
    let s = format!("{v:.6}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    format!("{s} {name}")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::budget::{Poses, Term, default_terms};
    use crate::model::machine_file;

    #[test]
    fn unit_labels() {
        assert_eq!(unit_label(1e-3, true), "1 µm");
        assert_eq!(unit_label(1e-5, false), "10 µrad");
        assert_eq!(unit_label(0.5, true), "0.5 mm");
        assert_eq!(unit_label(2.5e-6, false), "2.5 µrad");
    }

    #[test]
    fn a_linear_unit_maps_one_to_one_and_linear_agrees_with_exact() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/fixtures/grinder.machine.toml");
        let m = machine_file::load(std::path::Path::new(path)).unwrap();
        let active: Vec<usize> = (0..3).collect();
        let terms = vec![
            Term::new(&m, &active, "EZZ").unwrap(),
            Term::new(&m, &active, "EBX").unwrap(),
        ];
        let probe = Probe::new(&m, 0, 0.0, &Poses::At(vec![vec![50.0, 45.0, 5.0]]), terms).unwrap();
        let s = run(&probe, &StudyOptions::default());
        assert_eq!(s.mode, Mode::AtPose);
        // Z carries the wheel: +1 µm of EZZ lifts the tip 1 µm.
        let ezz = &s.rows[0].exact.dp;
        assert!(
            (ezz[2] - 1e-3).abs() < 1e-12 && ezz[0].abs() < 1e-12,
            "{ezz:?}"
        );
        // X carries the part: pitch EBX tips it about Y at program zero; the tip, 50 mm
        // away along X, sees the part move by +ε·50 mm in Z.
        let ebx = &s.rows[1].exact.dp;
        assert!((ebx[2] - 5e-4).abs() < 1e-9, "{ebx:?}");
        // The second-order part of 10 µrad at 67 mm: ε²·L/2 ≈ 3e-9 mm.
        assert!(s.max_difference[0] < 1e-8, "{:?}", s.max_difference);
    }

    #[test]
    fn worst_case_keeps_the_sign_and_the_pose() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/fixtures/grinder.machine.toml");
        let m = machine_file::load(std::path::Path::new(path)).unwrap();
        let active: Vec<usize> = (0..3).collect();
        let terms = default_terms(&m, &active);
        let probe = Probe::new(&m, 0, 0.0, &Poses::Grid(3), terms).unwrap();
        let s = run(&probe, &StudyOptions::default());
        assert_eq!(s.mode, Mode::WorstCase);
        let ebx = s.rows.iter().find(|r| r.term == "EBX").unwrap();
        // Largest at the end of X travel, 350 mm: 10 µrad × 350 mm.
        assert!((ebx.exact.dp[2].abs() - 3.5e-3).abs() < 1e-8, "{ebx:?}");
        assert!(
            s.poses[ebx.worst_pose].starts_with("X=-350")
                || s.poses[ebx.worst_pose].starts_with("X=350")
        );
        assert!(s.max_difference[0] < 1e-7 && s.max_difference[1] < 1e-9);
    }
}
