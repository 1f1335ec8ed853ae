//! facebake baker library: everything expensive, solved once in f64, written as a rig blob for
//! the `facebake-runtime` crate.
//!
//! One entry: [`bake()`] turns a [`Scene`] (mesh, placed markers, their groups, control
//! triangles, optionally the actor's capture) and [`BakeOptions`] into a [`Baked`] rig: the blob,
//! its rig space, a report and the f64 references the runtime is tested against.
pub mod bake;
pub mod blob;
pub mod deformer;
pub mod demo;
pub mod frame;
pub mod geodesic;
pub mod ground_truth;
pub mod io;
pub mod mesh;
pub mod metrics;
pub mod model;
pub mod morph_basis;
pub mod normals;
pub mod openings;
mod options;
pub mod pivot;
pub mod placement;
pub mod planar;
mod rbf;
pub mod render;
mod space;
mod sparsify;
pub mod stages;
pub mod surface;

pub use bake::{bake, BakeError, BakeReport, Baked, Reference, Scene};
pub use deformer::DeformerKind;
pub use options::{
    default_k, BakeOptions, Method, SurfaceOptions, ANCHORING_MARGIN, DEFAULT_K, HYBRID_REACH,
    MASK_SIDE_EUCLIDEAN, MASK_SIDE_SURFACE, PAST_CORNER_REACH, PAST_CORNER_REACH_EUCLIDEAN,
    PBW_ALPHA, RBF_K, RIM_ACROSS,
};
pub use rbf::{RadialFunction, SolveError};
pub use sparsify::{Refit, SparsifyError};
pub use stages::{HeadMarkers, RetargetKind, StagesConfig};
