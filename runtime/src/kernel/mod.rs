//! Per-frame deformation kernels, one module per method.

pub mod linear;
pub mod planar;
pub mod rbf;
