//! Machines and error models built in code, for tests that must not depend on files.
#![allow(dead_code)]

pub mod cli;
pub mod contract;
pub mod skip;

use nalgebra::Vector3;
use nccomp::model::{
    Axis, AxisErrors, AxisKind, Chain, ErrorModel, Machine, MotionTable, Resolution, Tool,
};

pub fn linear(name: &str, direction: [f64; 3]) -> Axis {
    Axis {
        name: name.into(),
        word: name.chars().next().unwrap(),
        kind: AxisKind::Linear,
        direction: Vector3::from(direction),
        point: Vector3::zeros(),
        travel: None,
        table_offset: 0.0,
        rollover: false,
    }
}

pub fn rotary(name: &str, direction: [f64; 3], point: [f64; 3]) -> Axis {
    Axis {
        name: name.into(),
        word: name.chars().next().unwrap(),
        kind: AxisKind::Rotary,
        direction: Vector3::from(direction),
        point: Vector3::from(point),
        travel: None,
        table_offset: 0.0,
        rollover: false,
    }
}

/// An AC trunnion (table-table) machine: workpiece chain Y X A C, tool chain Z, with the
/// A axis line through `a_point` and the C axis line through `c_point`.
pub fn ac_trunnion(a_point: [f64; 3], c_point: [f64; 3]) -> Machine {
    Machine {
        name: Some("test AC trunnion".into()),
        axes: vec![
            linear("X", [-1.0, 0.0, 0.0]),
            linear("Y", [0.0, -1.0, 0.0]),
            linear("Z", [0.0, 0.0, 1.0]),
            rotary("A", [-1.0, 0.0, 0.0], a_point),
            rotary("C", [0.0, 0.0, -1.0], c_point),
        ],
        workpiece_chain: vec![1, 0, 3, 4],
        tool_chains: vec![Chain {
            name: "tool".into(),
            axes: vec![2],
            tools: Vec::new(),
        }],
        resolution: Resolution::default(),
        tool: Tool::default(),
        lathe: None,
        codes: Default::default(),
        plane_solution: Default::default(),
        inch_default: false,
        cycle_r_initial: false,
        block_delete: None,
        start: Vec::new(),
        errors_file: None,
        work_offsets: None,
    }
}

/// A head-head machine: tool chain X Y Z C A with the A pivot `pivot` mm above the tip.
pub fn head_head(pivot: f64) -> Machine {
    Machine {
        name: Some("test head-head".into()),
        axes: vec![
            linear("X", [1.0, 0.0, 0.0]),
            linear("Y", [0.0, 1.0, 0.0]),
            linear("Z", [0.0, 0.0, 1.0]),
            rotary("C", [0.0, 0.0, 1.0], [0.0, 0.0, 0.0]),
            rotary("A", [1.0, 0.0, 0.0], [0.0, 0.0, pivot]),
        ],
        workpiece_chain: vec![],
        tool_chains: vec![Chain {
            name: "tool".into(),
            axes: vec![0, 1, 2, 3, 4],
            tools: Vec::new(),
        }],
        resolution: Resolution::default(),
        tool: Tool::default(),
        lathe: None,
        codes: Default::default(),
        plane_solution: Default::default(),
        inch_default: false,
        cycle_r_initial: false,
        block_delete: None,
        start: Vec::new(),
        errors_file: None,
        work_offsets: None,
    }
}

/// A small deterministic random generator (tests must not depend on a crate's stream): the
/// benchmarks' own.
#[path = "../../benches/common/random.rs"]
pub mod random;
pub use random::Lcg;

/// Errors of the size the outside checker uses: straightness ~10 µm, angles ~100 µrad,
/// location errors ~20 µm (in mm and rad).
pub fn random_errors(machine: &Machine, rng: &mut Lcg) -> ErrorModel {
    let mut model = ErrorModel::zero(machine);
    for (axis, err) in machine.axes.iter().zip(model.axes.iter_mut()) {
        let own = axis.direction.iamax();
        let (positions, periodic) = match axis.kind {
            AxisKind::Linear => (vec![-500.0, -250.0, 0.0, 250.0, 500.0], false),
            AxisKind::Rotary => (vec![0.0, 90.0, 180.0, 270.0], true),
        };
        let mut values: [Option<Vec<f64>>; 6] = Default::default();
        for (c, v) in values.iter_mut().enumerate() {
            let scale = if c < 3 { 0.010 } else { 100e-6 };
            *v = Some(positions.iter().map(|_| rng.sym(scale)).collect());
        }
        err.motion = Some(MotionTable {
            positions,
            values,
            periodic,
        });
        match axis.kind {
            AxisKind::Linear => {
                let mut s = rng.vec(100e-6);
                s[own] = 0.0;
                err.squareness = s;
            }
            AxisKind::Rotary => {
                let mut shift = rng.vec(0.020);
                shift[own] = 0.0;
                let mut tilt = rng.vec(100e-6);
                tilt[own] = 0.0;
                err.location_shift = shift;
                err.location_tilt = tilt;
                err.zero = rng.sym(100e-6);
            }
        }
    }
    let _ = AxisErrors::default();
    model
}
