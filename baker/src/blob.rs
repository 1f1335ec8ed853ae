//! Writing a rig blob through the runtime crate's own format types.

use facebake_runtime::format::{
    self, Bytes, Deformer, LinearInfluences, PlanarBones, PlanarInfluence, RbfCoefficients,
    RigData, Space, MAX_MARKERS,
};
use facebake_runtime::pipeline::{PerMarker, Retarget, RetargetForm, Stages};

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
    /// The capture stages, if any.
    pub stages: Option<&'a StagesBytes>,
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
            Deformer::Linear(LinearInfluences {
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
            Deformer::RbfCoefficients(RbfCoefficients {
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
                let b = format::write_planar_influence(r).ok_or_else(|| {
                    BlobError::Limits(format!("control triangle {} out of range", r.triangle))
                })?;
                w.extend_from_slice(&b);
            }
            words = w;
            record_bytes = format::PLANAR_INFLUENCE_BYTES;
            tris = triangles.iter().flatten().copied().collect::<Vec<u8>>();
            Deformer::PlanarBones(PlanarBones {
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
        stages: c.stages.map(stages_section),
    };
    let blob = seal(&data, c.stages.is_some())?;
    let sizes = BlobSizes {
        total: blob.len(),
        influence_bytes: words.len(),
        influences: words.len() / record_bytes,
        other_bytes_per_vertex: (blob.len() - words.len()) as f64 / c.vertices.len().max(1) as f64,
    };
    Ok((blob, sizes))
}

/// The stages' section over `stages`' bytes.
fn stages_section(stages: &StagesBytes) -> Stages<'_> {
    Stages {
        actor_space: stages.actor_space,
        actor_neutral: Bytes(&stages.actor_neutral),
        head_markers: Bytes(&stages.head_markers),
        max_displacement: stages.max_displacement,
        fill: Bytes(&stages.fill),
        anchors: Bytes(&stages.anchors),
        retarget: match &stages.proportional {
            Some((shift, matrices, rest)) => RetargetForm::PerMarker(PerMarker {
                shift: *shift,
                matrices: Bytes(matrices),
                rest: Bytes(rest),
            }),
            None => RetargetForm::Rbf(Retarget {
                radii: Bytes(&stages.radii),
                alpha_shift: stages.alpha_shift,
                alpha: Bytes(&stages.alpha),
                linear_shift: stages.linear_shift,
                linear: stages.linear,
                offset: stages.offset,
            }),
        },
    }
}

/// A sealed blob with its capture stages replaced by `stages`: the rig is decoded through the
/// runtime's own loader, so `blob` must be a valid rig. [`crate::bake()`] writes its blob once
/// with the stages in it; this is for tools and tests that put other stages on a baked rig.
pub fn with_stages(blob: &[u8], stages: &StagesBytes) -> Result<Vec<u8>, BlobError> {
    let payload =
        format::open(blob).map_err(|e| BlobError::Limits(format!("not a valid rig: {e}")))?;
    let mut data =
        format::decode(payload).map_err(|e| BlobError::Limits(format!("not a valid rig: {e}")))?;
    data.stages = Some(stages_section(stages));
    seal(&data, true)
}

/// Encode `data` behind its header; with `check_stages`, load the result through the runtime so
/// the stages pass its own checks too.
fn seal(data: &RigData<'_>, check_stages: bool) -> Result<Vec<u8>, BlobError> {
    let payload = postcard::to_allocvec(data)?;
    let header =
        format::header_for(&payload).map_err(|_| BlobError::Limits("payload over 4 GiB".into()))?;
    let mut blob = header.to_vec();
    blob.extend_from_slice(&payload);
    if check_stages {
        facebake_runtime::Rig::from_bytes(&blob)
            .map_err(|e| BlobError::Limits(format!("the capture stages do not load: {e}")))?;
    }
    Ok(blob)
}
