//! Writes the finishing program of paper 000's feature workpiece for a machine.
//!
//!     cargo run --example feature_workpiece -- fixtures/ac_trunnion.machine.toml \
//!         > fixtures/feature_workpiece.nc
//!
//! The path (src/workpiece.rs) is in the part frame; the machine's nominal inverse
//! kinematics turns it into axis values. A test checks that the committed fixture is what
//! this writes.

use nccomp::kinematics::Kinematics;
use nccomp::model::{ErrorModel, machine_file};
use nccomp::workpiece::{FeatureWorkpiece, ProgramStyle, to_program};
use std::path::PathBuf;
use std::process::ExitCode;

fn main() -> ExitCode {
    let path = std::env::args_os()
        .nth(1)
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from("fixtures/ac_trunnion.machine.toml"));
    match run(&path) {
        Ok(program) => {
            print!("{program}");
            ExitCode::SUCCESS
        }
        Err(message) => {
            eprintln!("{message}");
            ExitCode::from(2)
        }
    }
}

fn run(path: &std::path::Path) -> Result<String, String> {
    let machine = machine_file::load(path).map_err(|e| e.render())?;
    let kin =
        Kinematics::new(&machine, &ErrorModel::zero(&machine), 0).map_err(|e| e.to_string())?;
    let ops = FeatureWorkpiece::default().finishing_path(3.0);
    to_program(&kin, &machine, &ops, &ProgramStyle::feature_workpiece()).map_err(|e| e.to_string())
}
