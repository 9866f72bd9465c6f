//! nccomp: compensate five-axis NC programs for a machine's geometric errors.
//!
//! The modules are the pipeline, in order: the NC document ([`nc`], lossless parse and
//! emit) → what each block means ([`program`], one reader for every command) → the
//! machine and its error model ([`model`]) → kinematics and the solve ([`kinematics`]) →
//! the compensation pass ([`compensate`]). Beside the pipeline:
//!
//! - [`check`]: the pass over many programs as a CI gate;
//! - [`report`]: an HTML report on a program's predicted errors and corrections;
//! - [`import`]: calibration files from the field (ISG CSV, Etalon) as error files;
//! - [`probe`]: a touch probe's pre-travel compensated by the probing speed per direction
//!   (paper 001);
//! - [`budget`]: the error budget, which terms matter and how tight each must be (paper 002);
//! - [`contour`]: the contour error of a program from a trace of the machine's axes
//!   (paper 003);
//! - [`identify`]: the errors identified from a cut and measured workpiece (paper 000);
//! - [`workpiece`]: paper 000's feature workpiece and the path that finishes it;
//! - [`diag`]: errors that point at a file, line and column;
//! - [`cli`]: the `nccomp` command line, one module a command; the binary only calls it.

pub mod budget;
pub mod check;
pub mod cli;
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
pub mod verify;
pub mod workpiece;

pub use diag::{Diagnostic, Error, Result};
