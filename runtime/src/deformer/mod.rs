//! The deformers: the per-frame routines that move the vertices with the markers, one module
//! each. A deformer's module owns its section type (what the blob stores), its validation, its
//! cost and its per-frame `deform`, all with the one signature shape of the crate-private trait
//! `DeformerSection` (`deformer/contract.rs`). [`Deformer`] is the blob's choice of deformer and
//! dispatches to it: one arm per deformer, in `Deformer::section`, here and nowhere else, but
//! for a frame split into chunks (`Deformer::prepare`, `Deformer::deform_prepared`), whose
//! per-frame data ([`FrameTable`]) has a type per deformer and so no common signature.
//!
//! * [`linear`]: K weights per vertex on marker displacements;
//! * [`rbf`]: per-frame RBF coefficients, then K radial terms per vertex plus an affine part;
//! * [`planar`]: planar bones, per-frame frames of marker triangles (paper 000 §4.1–4.2).
//!
//! A new deformer is a new module implementing `DeformerSection` and its own `prepare` and
//! `deform_prepared`, and a variant here and in `Table` (appended: the variant index is the
//! blob's encoding).

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

pub(crate) use contract::{check, DeformerSection, Shared};
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
    pub(crate) fn vertex_range(&self, first: usize, len: usize, uniform: Option<u8>) -> Self {
        match self {
            Self::Linear(d) => Self::Linear(d.vertex_range(first, len, uniform)),
            Self::Rbf(d) => Self::Rbf(d.vertex_range(first, len)),
            Self::Planar(d) => Self::Planar(d.vertex_range(first, len, uniform)),
        }
    }

    /// The number of influences every vertex has, if they all have the same (see
    /// [`contract::counted_range`]); the RBF deformer's are always K and need no count.
    pub(crate) fn uniform_influences(&self) -> Option<u8> {
        match self {
            Self::Linear(d) => contract::uniform(d.pair_counts.0),
            Self::Rbf(_) => None,
            Self::Planar(d) => contract::uniform(d.influence_counts.0),
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

    /// The per-frame marker work of [`Self::deform`] into `table` (the deformer's variant).
    pub(crate) fn prepare(
        &self,
        rig: &Shared<'_>,
        markers: &[[i32; 3]],
        table: &mut Table,
    ) -> DegenerateTriangles {
        match self {
            Self::Linear(d) => {
                if !matches!(table, Table::Linear(_)) {
                    *table = Table::Linear(linear::Prepared::EMPTY);
                }
                if let Table::Linear(p) = table {
                    d.prepare(rig, markers, p);
                }
            }
            Self::Rbf(d) => *table = Table::Rbf(d.prepare(rig, markers)),
            Self::Planar(d) => {
                let frames = d.prepare(rig, markers);
                *table = Table::Planar(frames);
                return frames.degenerate();
            }
        }
        DegenerateTriangles::default()
    }

    /// The vertices of `rig` into `out` from a `table` that [`Self::prepare`] filled: the
    /// integers [`Self::deform`] writes. A table of another deformer writes nothing (the caller
    /// checked that this rig filled it).
    pub(crate) fn deform_prepared(&self, rig: &Shared<'_>, table: &Table, out: &mut [[i32; 3]]) {
        match (self, table) {
            (Self::Linear(d), Table::Linear(p)) => d.deform_prepared(rig, p, out),
            (Self::Rbf(d), Table::Rbf(p)) => d.deform_prepared(rig, p, out),
            (Self::Planar(d), Table::Planar(p)) => d.deform_prepared(p, out),
            _ => {}
        }
    }
}

/// The per-frame marker work of one frame of a rig, done once by [`crate::Rig::prepare`] and
/// shared by every [`crate::Rig::deform_chunk`] of that frame, so that a job system can split a
/// face into many chunks without redoing it per chunk: the linear deformer's clamped marker
/// displacements, the RBF deformer's coefficients, planar bones' triangle frames and markers.
///
/// It is plain data of a fixed size (the largest variant: planar bones' frames for 256 control
/// triangles and the positions of 256 markers, about 25 KB), made once with [`FrameTable::new`]
/// and refilled every frame; nothing allocates. It remembers which rig filled it, and
/// [`crate::Rig::deform_chunk`] refuses a table that another rig filled, or none.
#[derive(Clone, Copy, Debug)]
pub struct FrameTable {
    /// The rig that filled it: the address of its marker rest section (0: not filled).
    pub(crate) owner: usize,
    /// The deformer's per-frame data.
    pub(crate) table: Table,
}

/// A deformer's per-frame data, one variant per deformer.
// A fixed-size scratch the caller owns: the runtime has no heap to box the big variant into.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug)]
pub(crate) enum Table {
    /// Not filled.
    Empty,
    /// The linear deformer's marker pair table.
    Linear(linear::Prepared),
    /// The RBF deformer's coefficients.
    Rbf(rbf::Prepared),
    /// Planar bones' frames and markers.
    Planar(planar::Frames),
}

impl FrameTable {
    /// An empty table, to fill with [`crate::Rig::prepare`].
    pub const fn new() -> Self {
        Self {
            owner: 0,
            table: Table::Empty,
        }
    }
}

impl Default for FrameTable {
    fn default() -> Self {
        Self::new()
    }
}
