//! Identifying a machine's errors from measured points (paper 000's feature workpiece).
//!
//! [`fit`] holds the geometric least-squares fits the identification is built on.

pub mod fit;
