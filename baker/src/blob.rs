//! Writing a rig blob through the runtime crate's own format types.

use facebake_runtime::deformer::linear::LinearDeformer;
use facebake_runtime::deformer::planar::{self, PlanarDeformer, PlanarInfluence};
use facebake_runtime::deformer::rbf::RbfDeformer;
use facebake_runtime::deformer::Deformer;
use facebake_runtime::format::header::header_for;
use facebake_runtime::format::records::{Bytes, MAX_MARKERS, PLANAR_INFLUENCE_BYTES};
use facebake_runtime::format::{self, RigData};
use facebake_runtime::stages::retarget::{ProportionalRetarget, RbfRetarget, Retarget};
use facebake_runtime::stages::Stages;
use facebake_runtime::Space;

use crate::stages::StagesBytes;

/// The blob could not be written.
#[derive(Debug, thiserror::Error)]
pub enum BlobError {
    /// Marker count outside 1..=256.
    #[error("{0} markers: a rig holds 1 to {MAX_MARKERS}")]
    MarkerCount(usize),
    /// A marker name the format cannot hold.
    #[error("marker name {0:?} must be 1 to 255 bytes of UTF-8")]
    MarkerName(String),
    /// A position outside the rig's range.
    #[error("{what} {index} at {position:?} lies outside the rig's range")]
    OutOfRange {
        /// "vertex" or "marker".
        what: &'static str,
        /// Its index.
        index: usize,
        /// Its position, asset units.
        position: [f64; 3],
    },
    /// Too many influences on a vertex or too many vertices.
    #[error("{0}")]
    Limits(String),
    /// Encoding failed.
    #[error("encoding the rig failed: {0}")]
    Encode(#[from] postcard::Error),
}

/// The rig space for a mesh: centre of its bounds and half its largest side, enlarged by 2⁻¹⁰
/// so every vertex fits Q0.15 after rounding to f32.
pub fn space_for(positions: &[[f64; 3]]) -> Space {
    let (lo, hi) = crate::io::gltf_mesh::bounds(positions.iter().copied());
    let centre = [0, 1, 2].map(|c| (0.5 * (lo[c] + hi[c])) as f32);
    let half = (0..3)
        .map(|c| 0.5 * (hi[c] - lo[c]))
        .fold(0.0, f64::max)
        .max(f64::MIN_POSITIVE);
    Space {
        centre,
        half_extent: (half * (1.0 + 1.0 / 1024.0)) as f32,
    }
}

/// A point in rig units (f64, unquantised): `(p − centre) / half_extent`.
pub fn to_rig_units(space: &Space, p: &[f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|c| (p[c] - f64::from(space.centre[c])) / f64::from(space.half_extent))
}

/// The deformer's sections, already encoded as bytes.
pub enum DeformerBytes {
    /// Linear weights: per-vertex counts and packed influences.
    Linear {
        /// Fractional weight bits.
        weight_frac_bits: u8,
        /// Per vertex, its packed influences.
        rows: Vec<Vec<u32>>,
    },
    /// RBF coefficients.
    Rbf {
        /// Fractional bits of φ.
        weight_frac_bits: u8,
        /// Influences per vertex.
        k: u8,
        /// Affine rows present.
        affine: bool,
        /// Per coefficient row: shift.
        row_shifts: Vec<u8>,
        /// Rows × markers entries.
        matrix: Vec<i16>,
        /// Per vertex, exactly `k` packed influences.
        rows: Vec<Vec<u32>>,
    },
    /// Planar bones.
    Planar {
        /// Control triangles (marker indices).
        triangles: Vec<[u8; 3]>,
        /// Per vertex, its influence records (1 to 64).
        rows: Vec<Vec<PlanarInfluence>>,
    },
}

/// Everything the blob holds, in asset units.
pub struct BlobContents<'a> {
    /// Rig space.
    pub space: Space,
    /// Vertex rest positions in the mesh's vertex order.
    pub vertices: &'a [[f64; 3]],
    /// Marker names.
    pub marker_names: &'a [String],
    /// Marker rest positions on the character.
    pub marker_rest: &'a [[f64; 3]],
    /// The deformer.
    pub deformer: &'a DeformerBytes,
}

/// Sizes of a written blob.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct BlobSizes {
    /// Whole blob.
    pub total: usize,
    /// Bytes in the influence section.
    pub influence_bytes: usize,
    /// Stored influences.
    pub influences: usize,
    /// Bytes per vertex of everything but the influences.
    pub other_bytes_per_vertex: f64,
}

fn le_words(rows: &[Vec<u32>]) -> Vec<u8> {
    rows.iter()
        .flatten()
        .flat_map(|w| w.to_le_bytes())
        .collect()
}

/// Encode and seal a rig.
pub fn write(c: &BlobContents<'_>) -> Result<(Vec<u8>, BlobSizes), BlobError> {
    if c.marker_names.is_empty() || c.marker_names.len() > MAX_MARKERS {
        return Err(BlobError::MarkerCount(c.marker_names.len()));
    }
    let mut names = Vec::new();
    for n in c.marker_names {
        let len = u8::try_from(n.len())
            .ok()
            .filter(|&l| l > 0)
            .ok_or_else(|| BlobError::MarkerName(n.clone()))?;
        names.push(len);
        names.extend_from_slice(n.as_bytes());
    }
    let mut marker_rest = Vec::with_capacity(12 * c.marker_rest.len());
    for (index, p) in c.marker_rest.iter().enumerate() {
        let q = c.space.to_rig_f64(*p).map_err(|_| BlobError::OutOfRange {
            what: "marker",
            index,
            position: *p,
        })?;
        q.iter()
            .for_each(|x| marker_rest.extend_from_slice(&x.to_le_bytes()));
    }
    let mut vertex_rest = Vec::with_capacity(6 * c.vertices.len());
    for (index, p) in c.vertices.iter().enumerate() {
        let q = c.space.to_rest_q15(*p).map_err(|_| BlobError::OutOfRange {
            what: "vertex",
            index,
            position: *p,
        })?;
        q.iter()
            .for_each(|x| vertex_rest.extend_from_slice(&x.to_le_bytes()));
    }
    let too_many = |n: usize| BlobError::Limits(format!("a vertex has {n} influences; at most 64"));
    let (counts, words, shifts, matrix, tris);
    let mut record_bytes = 4;
    let deformer = match c.deformer {
        DeformerBytes::Linear {
            weight_frac_bits,
            rows,
        } => {
            counts = rows
                .iter()
                .map(|r| u8::try_from(r.len()).map_err(|_| too_many(r.len())))
                .collect::<Result<Vec<u8>, _>>()?;
            words = le_words(rows);
            Deformer::Linear(LinearDeformer {
                weight_frac_bits: *weight_frac_bits,
                max_influences: counts.iter().copied().max().unwrap_or(0).max(1),
                influence_counts: Bytes(&counts),
                influences: Bytes(&words),
            })
        }
        DeformerBytes::Rbf {
            weight_frac_bits,
            k,
            affine,
            row_shifts,
            matrix: m,
            rows,
        } => {
            if let Some(r) = rows.iter().find(|r| r.len() != usize::from(*k)) {
                return Err(BlobError::Limits(format!(
                    "a vertex has {} kernel terms, the rig has K = {k}",
                    r.len()
                )));
            }
            words = le_words(rows);
            shifts = row_shifts.clone();
            matrix = m.iter().flat_map(|q| q.to_le_bytes()).collect::<Vec<u8>>();
            Deformer::Rbf(RbfDeformer {
                influences_per_vertex: *k,
                weight_frac_bits: *weight_frac_bits,
                affine: *affine,
                row_shifts: Bytes(&shifts),
                matrix: Bytes(&matrix),
                influences: Bytes(&words),
            })
        }
        DeformerBytes::Planar { triangles, rows } => {
            counts = rows
                .iter()
                .map(|r| u8::try_from(r.len()).map_err(|_| too_many(r.len())))
                .collect::<Result<Vec<u8>, _>>()?;
            let mut w = Vec::new();
            for r in rows.iter().flatten() {
                let b = planar::write_planar_influence(r).ok_or_else(|| {
                    BlobError::Limits(format!("control triangle {} out of range", r.triangle))
                })?;
                w.extend_from_slice(&b);
            }
            words = w;
            record_bytes = PLANAR_INFLUENCE_BYTES;
            tris = triangles.iter().flatten().copied().collect::<Vec<u8>>();
            Deformer::Planar(PlanarDeformer {
                max_influences: counts.iter().copied().max().unwrap_or(0).max(1),
                triangle_count: u16::try_from(triangles.len())
                    .map_err(|_| BlobError::Limits("too many control triangles".into()))?,
                triangles: Bytes(&tris),
                influence_counts: Bytes(&counts),
                influences: Bytes(&words),
            })
        }
    };
    let data = RigData {
        space: c.space,
        marker_count: c.marker_names.len() as u16,
        vertex_count: u32::try_from(c.vertices.len())
            .map_err(|_| BlobError::Limits("too many vertices".into()))?,
        marker_names: Bytes(&names),
        marker_rest: Bytes(&marker_rest),
        vertex_rest: Bytes(&vertex_rest),
        deformer,
        stages: None,
    };
    let payload = postcard::to_allocvec(&data)?;
    let header =
        header_for(&payload).map_err(|_| BlobError::Limits("payload over 4 GiB".into()))?;
    let mut blob = header.to_vec();
    blob.extend_from_slice(&payload);
    let sizes = BlobSizes {
        total: blob.len(),
        influence_bytes: words.len(),
        influences: words.len() / record_bytes,
        other_bytes_per_vertex: (blob.len() - words.len()) as f64 / c.vertices.len().max(1) as f64,
    };
    Ok((blob, sizes))
}

/// A sealed blob with the capture stages `stages` added (or replaced): the rig is decoded through
/// the runtime's own loader, so `blob` must be a valid rig.
pub fn with_stages(blob: &[u8], stages: &StagesBytes) -> Result<Vec<u8>, BlobError> {
    let payload = format::header::open(blob)
        .map_err(|e| BlobError::Limits(format!("not a valid rig: {e}")))?;
    let mut data =
        format::decode(payload).map_err(|e| BlobError::Limits(format!("not a valid rig: {e}")))?;
    data.stages = Some(Stages {
        actor_space: stages.actor_space,
        actor_neutral: Bytes(&stages.actor_neutral),
        head_markers: Bytes(&stages.head_markers),
        max_displacement: stages.max_displacement,
        fill: Bytes(&stages.fill),
        anchors: Bytes(&stages.anchors),
        head_tolerance: stages.head_tolerance,
        max_step: stages.max_step,
        smoothing: stages.smoothing,
        retarget: match &stages.proportional {
            Some((shift, matrices, rest)) => Retarget::Proportional(ProportionalRetarget {
                shift: *shift,
                matrices: Bytes(matrices),
                rest: Bytes(rest),
            }),
            None => Retarget::Rbf(RbfRetarget {
                radii: Bytes(&stages.radii),
                alpha_shift: stages.alpha_shift,
                alpha: Bytes(&stages.alpha),
                linear_shift: stages.linear_shift,
                linear: stages.linear,
                offset: stages.offset,
            }),
        },
    });
    let payload = postcard::to_allocvec(&data)?;
    let header =
        header_for(&payload).map_err(|_| BlobError::Limits("payload over 4 GiB".into()))?;
    let mut out = header.to_vec();
    out.extend_from_slice(&payload);
    // The stages must pass the runtime's own checks too.
    facebake_runtime::Rig::from_bytes(&out)
        .map_err(|e| BlobError::Limits(format!("the capture stages do not load: {e}")))?;
    Ok(out)
}
