//! Writing a rig blob through the runtime crate's own format types.

use facebake_runtime::format::{
    self, Bytes, Deformer, LinearInfluences, RigData, Space, MAX_MARKERS,
};

use crate::sparsify::Quantised;

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
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in positions {
        for c in 0..3 {
            lo[c] = lo[c].min(p[c]);
            hi[c] = hi[c].max(p[c]);
        }
    }
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
    /// Quantised influences, one row per vertex.
    pub influences: &'a Quantised,
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

/// Encode and seal a linear rig.
pub fn write_linear(c: &BlobContents<'_>) -> Result<(Vec<u8>, BlobSizes), BlobError> {
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
    let mut counts = Vec::with_capacity(c.vertices.len());
    let mut words = Vec::new();
    let mut max_k = 0u8;
    for row in &c.influences.words {
        let n = u8::try_from(row.len())
            .map_err(|_| BlobError::Limits(format!("a vertex has {} influences", row.len())))?;
        max_k = max_k.max(n);
        counts.push(n);
        row.iter()
            .for_each(|w| words.extend_from_slice(&w.to_le_bytes()));
    }
    let data = RigData {
        space: c.space,
        marker_count: c.marker_names.len() as u16,
        vertex_count: u32::try_from(c.vertices.len())
            .map_err(|_| BlobError::Limits("too many vertices".into()))?,
        marker_names: Bytes(&names),
        marker_rest: Bytes(&marker_rest),
        vertex_rest: Bytes(&vertex_rest),
        deformer: Deformer::Linear(LinearInfluences {
            weight_frac_bits: c.influences.frac_bits,
            max_influences: max_k.max(1),
            influence_counts: Bytes(&counts),
            influences: Bytes(&words),
        }),
    };
    let payload = postcard::to_allocvec(&data)?;
    let header =
        format::header_for(&payload).map_err(|_| BlobError::Limits("payload over 4 GiB".into()))?;
    let mut blob = header.to_vec();
    blob.extend_from_slice(&payload);
    let sizes = BlobSizes {
        total: blob.len(),
        influence_bytes: words.len(),
        influences: words.len() / 4,
        other_bytes_per_vertex: (blob.len() - words.len()) as f64 / c.vertices.len().max(1) as f64,
    };
    Ok((blob, sizes))
}
