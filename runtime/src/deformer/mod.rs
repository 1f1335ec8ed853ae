//! The deformers: the per-frame routines that move the vertices with the markers, one module
//! each. A deformer's module owns its section type (what the blob stores), its validation, its
//! cost and its per-frame `deform`, all with the one signature shape of the crate-private trait
//! `DeformerSection` (`deformer/contract.rs`). [`Deformer`] is the blob's choice of deformer and
//! dispatches to it: one arm per deformer, in `Deformer::section`, here and nowhere else.
//!
//! * [`linear`]: K weights per vertex on marker displacements;
//! * [`rbf`]: per-frame RBF coefficients, then K radial terms per vertex plus an affine part;
//! * [`planar`]: planar bones, per-frame frames of marker triangles (paper 000 §4.1–4.2).
//!
//! A new deformer is a new module implementing `DeformerSection` and a variant here (appended:
//! the variant index is the blob's encoding).

mod contract;
pub mod linear;
pub mod planar;
pub mod rbf;

use serde::{Deserialize, Serialize};

use crate::cost::Cost;
use crate::deformer::linear::LinearDeformer;
use crate::deformer::planar::PlanarDeformer;
use crate::deformer::rbf::RbfDeformer;
use crate::error::LoadError;

pub(crate) use contract::{DeformerSection, Shared};
pub use contract::DegenerateTriangles;

/// How the vertices follow the markers. Chosen at bake time; one variant per deformer module.
/// The variant order is the blob's encoding: never reorder, only append.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Deformer<'a> {
    /// Sparse linear weights on marker displacements ([`linear`]).
    #[serde(borrow)]
    Linear(LinearDeformer<'a>),
    /// Per-frame RBF coefficients, then K radial terms per vertex ([`rbf`]).
    #[serde(borrow)]
    Rbf(RbfDeformer<'a>),
    /// Planar bones: per-frame frames of marker triangles, then K region transforms per vertex
    /// ([`planar`]).
    #[serde(borrow)]
    Planar(PlanarDeformer<'a>),
}

impl<'a> Deformer<'a> {
    /// The section as its deformer's operations.
    #[inline(always)]
    fn section(&self) -> &dyn DeformerSection {
        match self {
            Self::Linear(d) => d,
            Self::Rbf(d) => d,
            Self::Planar(d) => d,
        }
    }

    /// See [`DeformerSection::validate`].
    pub(crate) fn validate(&self, rig: &Shared<'_>) -> Result<(), LoadError> {
        self.section().validate(rig)
    }

    /// See [`DeformerSection::cost`].
    pub(crate) fn cost(&self, rig: &Shared<'_>) -> Cost {
        self.section().cost(rig)
    }

    /// See [`DeformerSection::weight_frac_bits`].
    #[cfg_attr(not(feature = "format"), allow(dead_code))]
    pub(crate) fn weight_frac_bits(&self) -> u8 {
        self.section().weight_frac_bits()
    }

    /// The section seen as its vertices `first .. first + len` only (in range: the caller
    /// checked): the per-vertex sections sliced, everything else shared.
    pub(crate) fn vertex_range(&self, first: usize, len: usize) -> Self {
        match self {
            Self::Linear(d) => Self::Linear(d.vertex_range(first, len)),
            Self::Rbf(d) => Self::Rbf(d.vertex_range(first, len)),
            Self::Planar(d) => Self::Planar(d.vertex_range(first, len)),
        }
    }

    /// See [`DeformerSection::deform`].
    pub(crate) fn deform(
        &self,
        rig: &Shared<'_>,
        markers: &[[i32; 3]],
        out: &mut [[i32; 3]],
    ) -> DegenerateTriangles {
        self.section().deform(rig, markers, out)
    }
}
