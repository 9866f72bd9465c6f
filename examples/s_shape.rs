//! Writes paper 003's S-shaped test piece program for a machine, and a trace of a
//! simulated run of it.
//!
//!     cargo run --example s_shape -- fixtures/ac_trunnion.machine.toml fixtures/s_shape
//!
//! writes `fixtures/s_shape.nc` (the five-axis finishing program of face A, from
//! `nccomp::contour::s_shape`) and `fixtures/s_shape.trace.csv` (the program run on a
//! simulated machine whose axes follow with slightly different servo lags, sampled every
//! 15 ms as in the paper, with commanded positions). Both arguments are optional; these
//! are the defaults. A test checks that the committed program is what this writes.

use nccomp::contour::s_shape::{Finishing, SShape, finishing_program};
use nccomp::contour::simulate::{Servo, simulate};
use nccomp::kinematics::Kinematics;
use nccomp::model::{ErrorModel, machine_file};
use nccomp::program::moves::nominal_moves;
use std::path::PathBuf;
use std::process::ExitCode;

fn main() -> ExitCode {
    let mut args = std::env::args_os().skip(1);
    let machine = args.next().map_or_else(
        || PathBuf::from("fixtures/ac_trunnion.machine.toml"),
        PathBuf::from,
    );
    let stem = args
        .next()
        .map_or_else(|| PathBuf::from("fixtures/s_shape"), PathBuf::from);
    match run(&machine, &stem) {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("{message}");
            ExitCode::from(2)
        }
    }
}

fn run(machine_path: &std::path::Path, stem: &std::path::Path) -> Result<(), String> {
    let machine = machine_file::load(machine_path).map_err(|e| e.render())?;
    let program = finishing_program(&machine, &SShape::paper(), &Finishing::default())?;
    let nc = stem.with_extension("nc");
    std::fs::write(&nc, &program).map_err(|e| format!("{}: {e}", nc.display()))?;
    let (moves, chain) = nominal_moves(
        &machine,
        0,
        program.as_bytes(),
        &nc.display().to_string(),
        20,
    )
    .map_err(|e| e.render())?;
    let kin = &Kinematics::new(&machine, &ErrorModel::zero(&machine), chain)
        .map_err(|e| e.to_string())?;
    let length = machine.tool.lengths[&Finishing::default().tool];
    let trace = simulate(&machine, kin, &moves, length, &Servo::paper(kin.len()));
    let csv = stem.with_extension("trace.csv");
    let text = format!(
        "# S-shaped test piece (fixtures/s_shape.nc) on a simulated {}: 1 ms interpolation,\n# first-order servos of 8.0/8.6/7.5 ms (linear) and 9.5/10.2 ms (rotary), read every 15 ms\n# to 0.1 µm and 0.0001°; made by `cargo run --example s_shape`.\n{}",
        machine.name.as_deref().unwrap_or("machine"),
        trace.to_csv()
    );
    std::fs::write(&csv, text).map_err(|e| format!("{}: {e}", csv.display()))?;
    eprintln!(
        "wrote {} ({} lines) and {} ({} samples)",
        nc.display(),
        program.lines().count(),
        csv.display(),
        trace.len()
    );
    Ok(())
}
