//! nccomp: compensate five-axis NC programs for a machine's geometric errors.
//!
//! The modules are the pipeline, in order: the NC document ([`nc`], lossless parse and
//! emit) → the machine and its error model ([`model`]) → kinematics and the solve
//! ([`kinematics`]) → the compensation pass ([`compensate`]). The command-line interface
//! is a thin layer over these in the binary. Beside the pipeline, [`probe`] compensates a
//! touch probe's pre-travel by choosing the probing speed per direction (paper 001), and
//! [`check`] runs the pass over many programs as a CI gate.

pub mod budget;
pub mod check;
pub mod compensate;
pub mod contour;
pub mod diag;
pub mod identify;
pub mod import;
pub mod kinematics;
pub mod model;
pub mod nc;
pub mod probe;
pub mod program;
pub mod report;
pub mod workpiece;

pub use diag::{Diagnostic, Error, Result};
