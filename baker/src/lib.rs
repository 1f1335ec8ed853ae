//! facebake baker library: everything expensive, solved once in f64, written as a rig blob for
//! the `facebake-runtime` crate.
pub mod bake;
pub mod blob;
pub mod cli;
pub mod geodesic;
pub mod ground_truth;
pub mod io;
pub mod mesh;
pub mod metrics;
pub mod pivot;
pub mod placement;
pub mod planar;
pub mod rbf;
pub mod reference;
pub mod render;
pub mod retarget;
pub mod rigid;
pub mod sparsify;
pub mod stages;
pub mod surface;
