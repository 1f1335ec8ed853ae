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
//! the f64 references the runtime is tested against; [`SparseF64`] evaluates any loaded rig's
//! own numbers in f64 through them.

pub mod linear;
pub mod planar;
pub mod rbf;

use facebake_runtime::deformer::Deformer;
use facebake_runtime::fixed::POS_FRAC_BITS;
use facebake_runtime::format::records::{read_influence, INFLUENCE_BYTES};
use facebake_runtime::{Rig, Space};

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
    /// Every deformer, in the format's order.
    pub const ALL: [DeformerKind; 3] = [Self::Rbf, Self::Linear, Self::Planar];

    /// Name on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            Self::Rbf => "rbf",
            Self::Linear => "linear",
            Self::Planar => "planar",
        }
    }

    /// The deformer called `name` ([`Self::name`]).
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|d| d.name() == name)
    }

    /// What it stores per vertex, for help and reports.
    pub fn description(self) -> &'static str {
        match self {
            Self::Rbf => "per-frame RBF coefficients, K radial terms per vertex",
            Self::Linear => "K weights per vertex on marker displacements",
            Self::Planar => "K control-triangle region transforms per vertex (planar bones)",
        }
    }

    /// What its influences hold, for reports.
    pub fn stored(self) -> &'static str {
        match self {
            Self::Rbf => "radial values",
            Self::Linear | Self::Planar => "weights",
        }
    }

    /// What keeping K of each vertex's influences drops a share of, for reports.
    pub fn dropped(self) -> &'static str {
        match self {
            Self::Rbf => "radial mass",
            Self::Linear => "dense weight",
            Self::Planar => "eq-12 weight",
        }
    }
}

/// The runtime may differ from the f64 evaluation of the same rig ([`SparseF64`]) by at most
/// this fraction of the mesh's bounding-box diagonal: what `facebake verify` checks.
pub const TOLERANCE_FRACTION: f64 = 2e-5;

/// A deformer could not be baked.
#[derive(Debug, thiserror::Error)]
pub enum DeformerError {
    /// Sparsification / quantisation.
    #[error("sparsifying the weights: {0}")]
    Sparsify(#[from] crate::sparsify::SparsifyError),
    /// The section does not fit the format.
    #[error("writing the rig: {0}")]
    Section(#[from] SectionError),
    /// Planar bones.
    #[error("planar bones: {0}")]
    Planar(#[from] crate::planar::PlanarError),
    /// The RBF system of the RBF deformer.
    #[error("solving the RBF system: {0}")]
    Solve(#[from] crate::rbf::SolveError),
}

/// A deformer's section could not be encoded.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct SectionError(pub String);

/// A baked deformer's section, encoded as the blob stores it.
pub enum DeformerBytes {
    /// See [`rbf`].
    Rbf(rbf::RbfBytes),
    /// See [`linear`].
    Linear(linear::LinearBytes),
    /// See [`planar`].
    Planar(planar::PlanarBytes),
}

/// The runtime's section over a deformer's bytes, and its influence sizes.
pub struct Section<'a> {
    /// The section.
    pub deformer: Deformer<'a>,
    /// Bytes in the influence records.
    pub influence_bytes: usize,
    /// Stored influences.
    pub influences: usize,
}

impl DeformerBytes {
    /// The runtime's section over these bytes.
    pub fn section(&self) -> Section<'_> {
        match self {
            Self::Rbf(b) => b.section(),
            Self::Linear(b) => b.section(),
            Self::Planar(b) => b.section(),
        }
    }
}

/// Per vertex, its influence count as a byte (at most 64 influences, the runtime's limit).
pub(crate) fn influence_counts(lens: impl Iterator<Item = usize>) -> Result<Vec<u8>, SectionError> {
    lens.map(|n| {
        u8::try_from(n)
            .map_err(|_| SectionError(format!("a vertex has {n} influences; at most 64")))
    })
    .collect()
}

/// Packed influences, little-endian, vertex after vertex.
pub(crate) fn le_words(rows: &[Vec<u32>]) -> Vec<u8> {
    rows.iter()
        .flatten()
        .flat_map(|w| w.to_le_bytes())
        .collect()
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

/// A loaded rig's own numbers, evaluated in f64 in rig units: the same formula as the runtime
/// on the same quantised data, with exact arithmetic instead of fixed point.
pub struct SparseF64 {
    space: Space,
    rest: Vec<[f64; 3]>,
    marker_rest: Vec<[f64; 3]>,
    deformer: SparseDeformer,
}

/// The deformer part of [`SparseF64`].
enum SparseDeformer {
    Rbf(rbf::RbfF64),
    Linear(linear::LinearF64),
    /// Eqs 1–12 on the rig's own rest positions and influences (`None`: a section the
    /// reference cannot read, which the runtime refuses too).
    Planar(Option<planar::reference::PlanarReference>),
}

/// Per vertex, `counts` packed influences of `words` as (marker, value / `scale`).
pub(crate) fn dequantise_rows(
    words: &[u8],
    counts: impl Iterator<Item = usize>,
    scale: f64,
) -> Vec<Vec<(usize, f64)>> {
    let mut words = words.chunks_exact(INFLUENCE_BYTES);
    counts
        .map(|count| {
            words
                .by_ref()
                .take(count)
                .map(|w| {
                    let (m, q) = read_influence(w);
                    (usize::from(m), f64::from(q) / scale)
                })
                .collect()
        })
        .collect()
}

impl SparseF64 {
    /// Dequantise a rig: rest positions, marker rest positions and the deformer's numbers
    /// exactly as stored.
    pub fn from_rig(rig: &Rig<'_>) -> Self {
        let scale = f64::from(1u32 << rig.weight_frac_bits());
        let one = f64::from(1u32 << POS_FRAC_BITS);
        let to_f64 = |q: [i32; 3]| q.map(|x| f64::from(x) / one);
        let rest = (0..rig.vertex_count())
            .filter_map(|i| rig.vertex_rest(i))
            .map(to_f64)
            .collect();
        let marker_rest = (0..rig.marker_count())
            .filter_map(|i| rig.marker_rest(i))
            .map(to_f64)
            .collect();
        let deformer = match rig.deformer() {
            Deformer::Linear(l) => SparseDeformer::Linear(linear::LinearF64::new(l, scale)),
            Deformer::Rbf(r) => SparseDeformer::Rbf(rbf::RbfF64::new(
                r,
                rig.vertex_count(),
                rig.marker_count(),
                scale,
            )),
            Deformer::Planar(_) => {
                SparseDeformer::Planar(planar::reference::PlanarReference::from_rig(rig))
            }
        };
        Self {
            space: rig.space(),
            rest,
            marker_rest,
            deformer,
        }
    }

    /// Deformed positions for marker positions `markers` (asset units).
    pub fn frame(&self, markers: &[[f64; 3]]) -> Vec<[f64; 3]> {
        let d: Vec<[f64; 3]> = markers
            .iter()
            .zip(&self.marker_rest)
            .map(|(m, r)| {
                let m = crate::space::to_rig_units(&self.space, m);
                [m[0] - r[0], m[1] - r[1], m[2] - r[2]]
            })
            .collect();
        let displacements = match &self.deformer {
            SparseDeformer::Planar(Some(planar)) => return planar.frame(markers).0,
            SparseDeformer::Planar(None) => vec![[0.0; 3]; self.rest.len()],
            SparseDeformer::Linear(l) => l.displacements(&d),
            SparseDeformer::Rbf(r) => r.displacements(&self.rest, &d),
        };
        let h = f64::from(self.space.half_extent);
        self.rest
            .iter()
            .zip(&displacements)
            .map(|(v, dv)| [0, 1, 2].map(|a| f64::from(self.space.centre[a]) + (v[a] + dv[a]) * h))
            .collect()
    }
}
