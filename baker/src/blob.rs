//! Writing a rig blob through the runtime crate's own format types.

use facebake_runtime::deformer::Deformer;
use facebake_runtime::format::header::header_for;
use facebake_runtime::format::records::{Bytes, HEADER_LEN, MAX_MARKERS, SECTION_ALIGN};
use facebake_runtime::format::{self, RigData};
use facebake_runtime::stages::retarget::{ProportionalRetarget, RbfRetarget, Retarget};
use facebake_runtime::stages::Stages;
use facebake_runtime::Space;

use facebake_runtime::normals::Normals;

use crate::deformer::DeformerBytes;
use crate::normals::NormalsBytes;
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
    /// The normals section.
    pub normals: &'a NormalsBytes,
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
    let section = c.deformer.section();
    let data = RigData {
        space: c.space,
        marker_count: c.marker_names.len() as u16,
        vertex_count: u32::try_from(c.vertices.len())
            .map_err(|_| BlobError::Limits("too many vertices".into()))?,
        marker_names: Bytes(&names),
        marker_rest: Bytes(&marker_rest),
        vertex_rest_align: Bytes(&[]),
        vertex_rest: Bytes(&vertex_rest),
        normals: Normals {
            index_bytes: c.normals.index_bytes,
            rest: Bytes(&c.normals.rest),
            fan_counts: Bytes(&c.normals.fan_counts),
            corners: Bytes(&c.normals.corners),
            welds: Bytes(&c.normals.welds),
        },
        deformer: section.deformer,
        stages: c.stages.map(stages_section),
    };
    let blob = seal(&data, c.stages.is_some())?;
    let sizes = BlobSizes {
        total: blob.len(),
        influence_bytes: section.influence_bytes,
        influences: section.influences,
        other_bytes_per_vertex: (blob.len() - section.influence_bytes) as f64
            / c.vertices.len().max(1) as f64,
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
        head_tolerance: stages.head_tolerance,
        max_step: stages.max_step,
        smoothing: stages.smoothing,
        head_smoothing: stages.head_smoothing,
        refit_cutoff: stages.refit_cutoff,
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
    }
}

/// The payload of `data` with its alignment sections sized so that `vertex_rest` and a linear
/// rig's `pairs` start at a multiple of [`SECTION_ALIGN`] from the blob's first byte (the
/// header's length is one): encoded, measured where each section landed, padded, encoded again,
/// in the order the sections come (padding one moves every later one).
fn aligned(data: &RigData<'_>) -> Result<Vec<u8>, BlobError> {
    const ZEROS: [u8; SECTION_ALIGN] = [0; SECTION_ALIGN];
    let pad = |at: usize| {
        let n = (SECTION_ALIGN - (HEADER_LEN + at) % SECTION_ALIGN) % SECTION_ALIGN;
        Bytes(&ZEROS[..n])
    };
    let mut d = *data;
    d.vertex_rest_align = Bytes(&[]);
    if let Deformer::Linear(l) = &mut d.deformer {
        l.pairs_align = Bytes(&[]);
    }
    let payload = postcard::to_allocvec(&d)?;
    d.vertex_rest_align = pad(offset(&payload, vertex_rest_of)?);
    let mut payload = postcard::to_allocvec(&d)?;
    if let Deformer::Linear(l) = &mut d.deformer {
        l.pairs_align = pad(offset(&payload, pairs_of)?);
        payload = postcard::to_allocvec(&d)?;
    }
    Ok(payload)
}

/// Where in `payload` the section that `of` picks begins.
fn offset(payload: &[u8], of: for<'x> fn(&RigData<'x>) -> &'x [u8]) -> Result<usize, BlobError> {
    let decoded = format::decode(payload)
        .map_err(|e| BlobError::Limits(format!("the encoded rig does not load: {e}")))?;
    Ok(of(&decoded).as_ptr() as usize - payload.as_ptr() as usize)
}

/// The `vertex_rest` section.
fn vertex_rest_of<'x>(r: &RigData<'x>) -> &'x [u8] {
    r.vertex_rest.0
}

/// A linear rig's `pairs` section (empty for the other deformers).
fn pairs_of<'x>(r: &RigData<'x>) -> &'x [u8] {
    match r.deformer {
        Deformer::Linear(l) => l.pairs.0,
        _ => &[],
    }
}

/// A sealed blob with its capture stages replaced by `stages`: the rig is decoded through the
/// runtime's own loader, so `blob` must be a valid rig. [`crate::bake()`] writes its blob once
/// with the stages in it; this is for tools and tests that put other stages on a baked rig.
pub fn with_stages(blob: &[u8], stages: &StagesBytes) -> Result<Vec<u8>, BlobError> {
    let payload = format::header::open(blob)
        .map_err(|e| BlobError::Limits(format!("not a valid rig: {e}")))?;
    let mut data =
        format::decode(payload).map_err(|e| BlobError::Limits(format!("not a valid rig: {e}")))?;
    data.stages = Some(stages_section(stages));
    seal(&data, true)
}

/// Encode `data` behind its header, its hot sections aligned ([`aligned`]); with
/// `check_stages`, load the result through the runtime so the stages pass its own checks too.
fn seal(data: &RigData<'_>, check_stages: bool) -> Result<Vec<u8>, BlobError> {
    let payload = aligned(data)?;
    let header =
        header_for(&payload).map_err(|_| BlobError::Limits("payload over 4 GiB".into()))?;
    let mut blob = header.to_vec();
    blob.extend_from_slice(&payload);
    if check_stages {
        facebake_runtime::Rig::from_bytes(&blob)
            .map_err(|e| BlobError::Limits(format!("the capture stages do not load: {e}")))?;
    }
    Ok(blob)
}
