//! The `nccomp` command: a thin layer over [`nccomp::cli`], which holds every command.

use clap::Parser;
use std::process::ExitCode;

fn main() -> ExitCode {
    nccomp::cli::run(nccomp::cli::Cli::parse())
}
