//! The runtime's deformers, baked: one module per deformer, as in the runtime's `deformer/`.
//!
//! * [`rbf`] (default): the RBF coefficients are computed per frame from a small dense map, then
//!   each vertex sums its K largest radial terms plus the affine part. Terms of a fast-decaying
//!   radial function vanish with distance, so this is very close to the dense method.
//! * [`linear`]: each vertex keeps its K largest dense weights on marker displacements,
//!   re-fitted to reproduce constants. Any linear method can bake to this deformer, but the
//!   affine term spreads RBF weights over every marker, so truncation costs accuracy.
//! * [`planar`]: planar bones (paper 000 §4.1–4.2), K control-triangle transforms per vertex.
//!
//! Each module turns f64 rows into the blob's section ([`DeformerBytes`]) and, beside it, holds
//! the f64 reference the runtime is tested against.

pub mod linear;
pub mod planar;
pub mod rbf;

use crate::blob::DeformerBytes;

/// Which deformer the runtime runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum DeformerKind {
    /// Per-frame RBF coefficients, K radial terms per vertex plus the affine part (needs a
    /// decaying radial function).
    Rbf,
    /// K weights per vertex on marker displacements.
    Linear,
    /// Planar bones: K control-triangle transforms per vertex.
    Planar,
}

impl DeformerKind {
    /// Name on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            Self::Rbf => "rbf",
            Self::Linear => "linear",
            Self::Planar => "planar",
        }
    }
}

/// What a deformer's bake hands back for the blob and the report.
pub(crate) struct DeformerOutput {
    pub(crate) bytes: DeformerBytes,
    pub(crate) frac_bits: u8,
    /// Per vertex, the share of its weight or radial mass that keeping K dropped.
    pub(crate) dropped: Vec<f64>,
    pub(crate) rounding: f64,
    pub(crate) matrix_rounding: f64,
}
