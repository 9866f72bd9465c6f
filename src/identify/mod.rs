//! Identifying a machine's errors from measured points (paper 000's feature workpiece).
//!
//! [`fit`] holds the geometric least-squares fits; [`plan`] the measurement plan (features,
//! points, which errors each set identifies); [`measure`] reads the measured points;
//! [`separate`] applies the paper's formulas and separates total, quasi-static and dynamic
//! errors; [`cutting`] finds where a program cut each planned point; [`simulate`] is the
//! twin that cuts and measures a workpiece on a machine with known errors.

pub mod cutting;
pub mod fit;
pub mod measure;
pub mod plan;
pub mod separate;
pub mod simulate;
