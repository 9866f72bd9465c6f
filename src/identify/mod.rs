//! Identifying a machine's errors from a cut and measured workpiece (paper 000).
//!
//! The pipeline: [`plan`] (the measured points and the terms to identify) → [`params`]
//! (the unknowns and the error model they make) → [`cutting`] (where the program cut each
//! point) → [`decouple`] (point deviations onto the unknowns through the kinematics, and
//! the paper's [`separate`]ion of total, quasi-static and dynamic errors) → [`report`].
//! [`measure`] reads measured points; [`fit`] holds geometric fits; [`simulate`] is the
//! twin that cuts and measures a workpiece on a machine with known errors; [`files`] runs
//! the `identify` and `simulate-cut` commands over files.

pub mod cutting;
pub mod decouple;
pub mod files;
pub mod fit;
pub mod measure;
pub mod params;
pub mod plan;
pub mod report;
pub mod separate;
pub mod simulate;
