//! `nccomp identify` and `nccomp simulate-cut`: errors from a measured feature workpiece,
//! and the simulator that produces such measurements.

use super::files::{destinations, print, write_all};
use std::path::PathBuf;

/// Inputs the identification commands share.
#[derive(clap::Args)]
struct WorkpieceArgs {
    /// Machine file (TOML).
    #[arg(long, short = 'm', value_name = "MACHINE.toml")]
    machine: PathBuf,
    /// Measurement plan (TOML): the points, their features and the terms to identify.
    #[arg(long, value_name = "PLAN.toml")]
    plan: PathBuf,
    /// The NC program that cut the workpiece.
    #[arg(long, value_name = "PROGRAM.nc")]
    program: PathBuf,
}

#[derive(clap::Args)]
pub(super) struct IdentifyArgs {
    #[command(flatten)]
    work: WorkpieceArgs,
    /// The points the machine's probe measured (CSV: feature,id,x,y,z).
    #[arg(long, value_name = "A.csv")]
    on_machine: PathBuf,
    /// The points the CMM measured (CSV: feature,id,x,y,z).
    #[arg(long, value_name = "B.csv")]
    cmm: PathBuf,
    /// Which errors go into the error file.
    #[arg(long, value_enum, default_value = "quasi-static")]
    part: crate::identify::separate::Part,
    /// Where to write the error file (left out: only the table is printed).
    #[arg(long, short = 'o', value_name = "ERRORS.toml")]
    output: Option<PathBuf>,
}

#[derive(clap::Args)]
pub(super) struct SimulateCutArgs {
    #[command(flatten)]
    work: WorkpieceArgs,
    /// The machine's quasi-static errors (error file).
    #[arg(long, short = 'e', value_name = "ERRORS.toml")]
    errors: PathBuf,
    /// Errors that act only while cutting (error file).
    #[arg(long, value_name = "ERRORS.toml")]
    dynamic: Option<PathBuf>,
    /// Measurement noise, standard deviation per coordinate (µm).
    #[arg(
        long,
        value_name = "UM",
        default_value_t = 0.5,
        allow_negative_numbers = true
    )]
    noise: f64,
    /// Seed of the noise.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Where to write the on-machine probe's points (CSV).
    #[arg(long, value_name = "A.csv")]
    on_machine: PathBuf,
    /// Where to write the CMM's points (CSV).
    #[arg(long, value_name = "B.csv")]
    cmm: PathBuf,
}

pub(super) fn identify(args: &IdentifyArgs) -> crate::Result<()> {
    use crate::identify::files::{self, Workpiece};
    let w = &args.work;
    let [output] = destinations(
        &[
            ("the machine file", Some(&w.machine)),
            ("the plan", Some(&w.plan)),
            ("the program", Some(&w.program)),
            ("the on-machine measurements", Some(&args.on_machine)),
            ("the CMM measurements", Some(&args.cmm)),
        ],
        [("-o", args.output.as_deref())],
    )?;
    let work = Workpiece::load(&w.machine, &w.plan, &w.program)?;
    let id = files::identify(&work, &args.on_machine, &args.cmm, args.part)?;
    if let Some(output) = &output {
        write_all(&[(output, id.errors.as_bytes())])?;
    }
    print(&id.table)
}

pub(super) fn simulate_cut(args: &SimulateCutArgs) -> crate::Result<()> {
    use crate::identify::files::{self, Workpiece};
    let w = &args.work;
    let [Some(on_machine), Some(cmm)] = destinations(
        &[
            ("the machine file", Some(&w.machine)),
            ("the plan", Some(&w.plan)),
            ("the program", Some(&w.program)),
            ("the error file", Some(&args.errors)),
            ("the dynamic error file", args.dynamic.as_deref()),
        ],
        [
            ("--on-machine", Some(&args.on_machine)),
            ("--cmm", Some(&args.cmm)),
        ],
    )?
    else {
        return Err(crate::Error::Usage(
            "simulate-cut writes --on-machine and --cmm: give both".into(),
        ));
    };
    let work = Workpiece::load(&w.machine, &w.plan, &w.program)?;
    let sim = files::simulate_cut(
        &work,
        &args.errors,
        args.dynamic.as_deref(),
        args.noise,
        args.seed,
    )?;
    write_all(&[
        (&on_machine, sim.on_machine.as_bytes()),
        (&cmm, sim.cmm.as_bytes()),
    ])?;
    print(&sim.summary)
}
