//! The rig blob: the one definition of the format, used by the runtime to read it and by the
//! baker to write it.
//!
//! # Layout (format version 2)
//!
//! ```text
//! offset  size  field
//!      0     8  magic  b"FACEBAKE"
//!      8     2  format version, u16 LE            (this crate reads VERSION only)
//!     10     2  reserved, u16 LE, must be 0
//!     12     4  payload length in bytes, u32 LE
//!     16     4  CRC-32 (IEEE) of the payload, u32 LE
//!     20     …  payload: [`RigData`] encoded with postcard
//! ```
//!
//! The payload's bulk sections are postcard byte strings (a varint length, then the bytes), which
//! the loader borrows in place: nothing is copied, so a blob can be read straight from flash.
//! Inside them every number is little-endian:
//!
//! | section | per item | contents |
//! |---|---|---|
//! | `marker_names` | marker | `u8` length, then that many UTF-8 bytes |
//! | `marker_rest` | marker | 3 × `i32` LE, Q8.24 rig units |
//! | `vertex_rest` | vertex | 3 × `i16` LE, Q0.15 rig units |
//! | `influence_counts` | vertex | `u8`, at most `max_influences` |
//! | `influences` | influence | `u32` LE: bits 0–7 marker index, bits 8–31 the weight as a signed 24-bit integer with `weight_frac_bits` fractional bits |
//!
//! The deformer is one of two kinds (see [`Deformer`]):
//!
//! * **Linear**: per vertex, weights on marker displacements. Influences are stored vertex after
//!   vertex, `influence_counts[v]` of them for vertex `v`. The weights of a vertex sum to exactly
//!   `2^weight_frac_bits` (or the vertex has no influences and never moves); the loader checks it,
//!   and it is what makes a uniform translation move every vertex by exactly that translation.
//!   Their magnitudes sum to at most `i16::MAX` per vertex (so `weight_frac_bits` ≤ 14): the
//!   loader checks that too, and the linear kernel's 32-bit sums rely on it.
//! * **RBF coefficients**: per frame, the RBF coefficients `c = M · D` (one row of `M` per kernel
//!   centre, plus four affine rows β₀, βx, βy, βz), then per vertex the K largest kernel terms
//!   `Σ φ_k(v) c_k` plus the affine part `β₀ + β · rest(v)`. Sections:
//!
//! | section | per item | contents |
//! |---|---|---|
//! | `row_shifts` | coefficient row | `u8` s ∈ [1, 48]: the row's entries are `q · 2^−s` |
//! | `matrix` | coefficient row × marker | `i16` LE q |
//! | `influences` | vertex × K | `u32` LE as above; the index is a kernel centre (a marker) |
//!
//! The integer entries of every kernel row and of βx, βy, βz sum to 0, and those of β₀ sum to
//! `2^s`; the loader checks it. A uniform translation then gives exactly zero kernel coefficients
//! and β₀ equal to the translation, so it too moves every vertex by exactly that translation.
//!
//! Version 2 added the optional capture stages after the deformer ([`crate::pipeline::Stages`]:
//! head-motion compensation, fill and retargeting of an actor's raw markers); version 1 blobs are
//! rejected with [`LoadError::UnsupportedVersion`] (re-bake them).
//! * **Planar bones** (paper 000 §4.1–4.2): a triangulated control surface of the markers. Per
//!   frame every control triangle gets a frame (edges, unit normal, unit in-plane edge normals);
//!   per vertex, each of its at most K triangles moves it by the transform of the region it lies
//!   in (the triangle, an edge slab or an apex wedge), and the results are blended by weights
//!   summing to exactly one. See [`PlanarBones`] and the kernel's module docs. Sections:
//!
//! | section | per item | contents |
//! |---|---|---|
//! | `triangles` | control triangle | 3 × `u8` marker indices (O, P, Q) |
//! | `influence_counts` | vertex | `u8` in [1, K] |
//! | `influences` | influence | [`PLANAR_INFLUENCE_BYTES`] bytes: `u16` LE bits 0–12 the triangle, bits 13–15 the region (0 = R_A, 1 + i = R_B,i, 4 + i = R_C,i); `u16` LE weight, Q1.15; then 4 × `i32` LE local coordinates x, y, z, w (see [`PlanarBones`]) |

use serde::de::{Deserializer, Visitor};
use serde::{Deserialize, Serialize, Serializer};

use crate::checksum::crc32;
use crate::fixed::{
    unpack_influence, widen_rest, LINEAR_MAX_WEIGHT_FRAC_BITS, LINEAR_WEIGHT_ABS_SUM_MAX,
    MAX_INFLUENCES, MAX_WEIGHT_FRAC_BITS, MIN_WEIGHT_FRAC_BITS,
};
use crate::pipeline::{Stages, StagesError};

/// The first eight bytes of every rig blob.
pub const MAGIC: [u8; 8] = *b"FACEBAKE";
/// The format version this crate reads and writes.
pub const VERSION: u16 = 2;
/// Size of the fixed header that precedes the payload.
pub const HEADER_LEN: usize = 20;
/// Most markers a rig may have (a marker index is one byte).
pub const MAX_MARKERS: usize = 256;

/// A borrowed byte string inside the payload (postcard `bytes`: varint length + raw bytes).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct Bytes<'a>(pub &'a [u8]);

impl Serialize for Bytes<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_bytes(self.0)
    }
}

impl<'de: 'a, 'a> Deserialize<'de> for Bytes<'a> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Borrowed;
        impl<'de> Visitor<'de> for Borrowed {
            type Value = Bytes<'de>;
            fn expecting(&self, f: &mut core::fmt::Formatter) -> core::fmt::Result {
                f.write_str("a borrowed byte string")
            }
            fn visit_borrowed_bytes<E: serde::de::Error>(
                self,
                v: &'de [u8],
            ) -> Result<Self::Value, E> {
                Ok(Bytes(v))
            }
        }
        d.deserialize_bytes(Borrowed)
    }
}

/// Where rig units sit in the asset's space: `rig = (asset − centre) / half_extent`, in Q8.24.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Space {
    /// Centre of the mesh bounds, asset units.
    pub centre: [f32; 3],
    /// Half the largest side of the mesh bounds (slightly enlarged so the mesh fits Q0.15),
    /// asset units per rig unit.
    pub half_extent: f32,
}

/// The linear deformer: every vertex moves by a fixed weighted sum of marker displacements.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct LinearInfluences<'a> {
    /// Fractional bits of the stored weights, in [8, 14].
    pub weight_frac_bits: u8,
    /// Most influences any vertex has (K), in [1, 64].
    pub max_influences: u8,
    /// Per vertex: how many influences it has (`u8` each).
    #[serde(borrow)]
    pub influence_counts: Bytes<'a>,
    /// The packed influences, vertex after vertex (`u32` LE each).
    #[serde(borrow)]
    pub influences: Bytes<'a>,
}

/// The RBF-coefficient deformer: a small dense map from marker displacements to RBF
/// coefficients per frame, then K kernel terms per vertex.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct RbfCoefficients<'a> {
    /// Influences of every vertex (K), in [1, 64].
    pub influences_per_vertex: u8,
    /// Fractional bits of the stored kernel values φ, in [8, 22].
    pub weight_frac_bits: u8,
    /// Whether the four affine rows (β₀, βx, βy, βz) follow the kernel rows.
    pub affine: bool,
    /// Per coefficient row: its scale exponent s (entries are `q · 2^−s`), `u8` each.
    #[serde(borrow)]
    pub row_shifts: Bytes<'a>,
    /// The map M: rows × markers, `i16` LE.
    #[serde(borrow)]
    pub matrix: Bytes<'a>,
    /// K packed influences per vertex (`u32` LE each): kernel centre index and φ.
    #[serde(borrow)]
    pub influences: Bytes<'a>,
}

/// Smallest accepted coefficient row shift.
pub const MIN_ROW_SHIFT: u8 = 1;
/// Largest accepted coefficient row shift.
pub const MAX_ROW_SHIFT: u8 = 48;

/// Most control triangles a planar-bones rig may have: bounds the per-frame frame scratch on the
/// stack (see `Cost::scratch_bytes`).
pub const MAX_TRIANGLES: usize = 256;
/// Bytes of one planar-bones influence record.
pub const PLANAR_INFLUENCE_BYTES: usize = 20;
/// Fractional bits of a planar-bones weight (Q1.15: one is 2¹⁵).
pub const PLANAR_WEIGHT_FRAC_BITS: u8 = 15;
/// Region codes of a planar-bones influence: R_A, then R_B,0..2, then R_C,0..2.
pub const PLANAR_REGIONS: u8 = 7;

/// The planar-bones deformer of paper 000 §4.1–4.2: a control surface of marker triangles.
///
/// Each influence names a triangle (O, P, Q) = (V₀, V₁, V₂), with edges e_i = V_{i+1} − V_i,
/// unit normal n = e₀ × (V₂ − V₀) / ‖…‖ and unit in-plane edge normals u_i = e_i × n / ‖…‖,
/// a region, a weight and local coordinates baked in the rest frame. In the current frame
/// (primed), the vertex's position for that triangle is:
///
/// | region | origin | position | x | y | z | w |
/// |---|---|---|---|---|---|---|
/// | R_A (eq 1) | O | O′ + x e₀′ + y (Q′ − O′) + z n′ | Q6.26 | Q6.26 | Q8.24 | 0 |
/// | R_B,i (eq 9) | V_i | V_i′ + x e_i′ + y u_i′ + z n′ | Q6.26 | Q8.24 | Q8.24 | 0 |
/// | R_C,i (eq 10) | V_i | V_i′ + w · unit(x u_i′ + y u_{i−1}′) + z n′ | Q8.24 | Q8.24 | Q8.24 | Q8.24 |
///
/// In R_C,i, w is the rest in-plane distance D_i(S) of eq 10, so the apex scaling D/d keeps it.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PlanarBones<'a> {
    /// Most influences any vertex has (K), in [1, 64].
    pub max_influences: u8,
    /// Number of control triangles, in [1, [`MAX_TRIANGLES`]].
    pub triangle_count: u16,
    /// Per triangle: three `u8` marker indices.
    #[serde(borrow)]
    pub triangles: Bytes<'a>,
    /// Per vertex: how many influences it has (`u8`, at least 1).
    #[serde(borrow)]
    pub influence_counts: Bytes<'a>,
    /// The influence records, vertex after vertex ([`PLANAR_INFLUENCE_BYTES`] each).
    #[serde(borrow)]
    pub influences: Bytes<'a>,
}

/// One decoded planar-bones influence record.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PlanarInfluence {
    /// Control triangle index.
    pub triangle: u16,
    /// Region code: 0 = R_A, 1 + i = R_B,i, 4 + i = R_C,i (anything above 6 is rejected by the
    /// loader).
    pub region: u8,
    /// Weight, Q1.15.
    pub weight: u16,
    /// Local coordinates x, y, z, w (formats per region: see [`PlanarBones`]).
    pub coords: [i32; 4],
}

/// Decode one planar influence from a [`PLANAR_INFLUENCE_BYTES`]-long chunk.
#[inline(always)]
pub fn read_planar_influence(b: &[u8]) -> PlanarInfluence {
    let b: &[u8; PLANAR_INFLUENCE_BYTES] = b.try_into().unwrap_or(&[0; PLANAR_INFLUENCE_BYTES]);
    let head = u16::from_le_bytes([b[0], b[1]]);
    let word = |at: usize| i32::from_le_bytes([b[at], b[at + 1], b[at + 2], b[at + 3]]);
    PlanarInfluence {
        triangle: head & 0x1FFF,
        region: (head >> 13) as u8,
        weight: u16::from_le_bytes([b[2], b[3]]),
        coords: [word(4), word(8), word(12), word(16)],
    }
}

/// Encode one planar influence (the inverse of [`read_planar_influence`]); `None` if the
/// triangle index does not fit 13 bits or the region 3 bits.
pub fn write_planar_influence(i: &PlanarInfluence) -> Option<[u8; PLANAR_INFLUENCE_BYTES]> {
    if i.triangle > 0x1FFF || i.region > 7 {
        return None;
    }
    let mut b = [0u8; PLANAR_INFLUENCE_BYTES];
    b[..2].copy_from_slice(&(i.triangle | (u16::from(i.region) << 13)).to_le_bytes());
    b[2..4].copy_from_slice(&i.weight.to_le_bytes());
    for (c, v) in i.coords.iter().enumerate() {
        b[4 + 4 * c..8 + 4 * c].copy_from_slice(&v.to_le_bytes());
    }
    Some(b)
}

/// How the vertices follow the markers. Chosen at bake time; one variant per runtime kernel.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Deformer<'a> {
    /// Sparse linear weights on marker displacements.
    #[serde(borrow)]
    Linear(LinearInfluences<'a>),
    /// Per-frame RBF coefficients, then K kernel terms per vertex.
    #[serde(borrow)]
    RbfCoefficients(RbfCoefficients<'a>),
    /// Planar bones: per-frame frames of marker triangles, then K region transforms per vertex.
    #[serde(borrow)]
    PlanarBones(PlanarBones<'a>),
}

/// The payload of a rig blob (format version 2).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct RigData<'a> {
    /// Rig units in the asset's space.
    pub space: Space,
    /// Number of markers, in [1, 256].
    pub marker_count: u16,
    /// Number of vertices.
    pub vertex_count: u32,
    /// Marker names: per marker a `u8` length and that many UTF-8 bytes.
    #[serde(borrow)]
    pub marker_names: Bytes<'a>,
    /// Marker rest positions on the character: 3 × `i32` LE (Q8.24) per marker.
    #[serde(borrow)]
    pub marker_rest: Bytes<'a>,
    /// Vertex rest positions: 3 × `i16` LE (Q0.15) per vertex, in the mesh's vertex order.
    #[serde(borrow)]
    pub vertex_rest: Bytes<'a>,
    /// The deformer.
    #[serde(borrow)]
    pub deformer: Deformer<'a>,
    /// Optional capture stages (compensation, fill, retargeting) that turn an actor's raw markers
    /// into this rig's markers at run time.
    #[serde(borrow)]
    pub stages: Option<Stages<'a>>,
}

/// Why a byte string is not a loadable rig. Every variant is a distinct failure.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LoadError {
    /// Shorter than its header or than the payload length the header states.
    Truncated {
        /// Bytes the header says there should be.
        expected: usize,
        /// Bytes there are.
        found: usize,
    },
    /// More bytes than header + payload.
    TrailingBytes {
        /// Bytes after the end of the payload.
        extra: usize,
    },
    /// The first eight bytes are not [`MAGIC`].
    BadMagic,
    /// A format version this crate does not read.
    UnsupportedVersion {
        /// The version in the header.
        found: u16,
    },
    /// The reserved header field is not zero.
    BadReserved,
    /// The payload's CRC-32 differs from the header's.
    ChecksumMismatch {
        /// CRC in the header.
        stored: u32,
        /// CRC of the payload.
        computed: u32,
    },
    /// The payload is not a postcard-encoded [`RigData`].
    Malformed,
    /// The payload decodes but leaves bytes unread.
    PayloadTrailingBytes,
    /// `space` holds a non-finite value or a non-positive half extent.
    BadSpace,
    /// `marker_count` is 0 or above [`MAX_MARKERS`].
    BadMarkerCount {
        /// The count in the blob.
        found: u16,
    },
    /// `max_influences` is 0 or above [`MAX_INFLUENCES`].
    BadMaxInfluences {
        /// The value in the blob.
        found: u8,
    },
    /// `weight_frac_bits` is outside [8, 22] ([8, 14] for the linear deformer).
    BadWeightFormat {
        /// The value in the blob.
        found: u8,
    },
    /// A section's length disagrees with the counts.
    SectionLength {
        /// Which section.
        section: Section,
        /// Bytes the counts imply.
        expected: usize,
        /// Bytes the section has.
        found: usize,
    },
    /// A marker name is empty, not UTF-8, or runs past its section.
    BadMarkerName {
        /// Index of the marker.
        marker: usize,
    },
    /// A vertex has more influences than `max_influences`.
    TooManyInfluences {
        /// The vertex.
        vertex: usize,
        /// Its influence count.
        count: u8,
    },
    /// An influence names a marker that does not exist.
    MarkerIndexOutOfRange {
        /// The vertex the influence belongs to.
        vertex: usize,
        /// The marker index it names.
        marker: u8,
    },
    /// A vertex's weights do not sum to exactly one (or it has no influences).
    WeightsNotNormalised {
        /// The vertex.
        vertex: usize,
    },
    /// A coefficient row's scale exponent is outside [1, 48].
    BadRowShift {
        /// The row.
        row: usize,
        /// Its shift.
        shift: u8,
    },
    /// A coefficient row does not sum to what exact translation needs (0, or 2^s for β₀).
    CoefficientsNotNormalised {
        /// The row.
        row: usize,
    },
    /// The capture stages are invalid.
    BadStages(StagesError),
    /// A vertex's linear weights have Σ|w| above [`LINEAR_WEIGHT_ABS_SUM_MAX`], the bound the
    /// linear kernel's 32-bit sums rest on.
    WeightsTooLarge {
        /// The vertex.
        vertex: usize,
    },
    /// A planar-bones rig has no control triangle or more than [`MAX_TRIANGLES`].
    BadTriangleCount {
        /// The count in the blob.
        found: u16,
    },
    /// A control triangle names a marker that does not exist.
    TriangleMarkerOutOfRange {
        /// The triangle.
        triangle: usize,
        /// The marker index it names.
        marker: u8,
    },
    /// A control triangle is degenerate at rest (repeated or collinear markers), so no rest
    /// frame exists for it.
    DegenerateRestTriangle {
        /// The triangle.
        triangle: usize,
    },
    /// A planar influence names a triangle that does not exist.
    TriangleIndexOutOfRange {
        /// The vertex the influence belongs to.
        vertex: usize,
        /// The triangle index it names.
        triangle: u16,
    },
    /// A planar influence has a region code above 6.
    BadRegion {
        /// The vertex the influence belongs to.
        vertex: usize,
        /// The region code.
        region: u8,
    },
}

/// A section of the payload, for [`LoadError::SectionLength`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Section {
    /// `marker_names`
    MarkerNames,
    /// `marker_rest`
    MarkerRest,
    /// `vertex_rest`
    VertexRest,
    /// `influence_counts`
    InfluenceCounts,
    /// `influences`
    Influences,
    /// `row_shifts`
    RowShifts,
    /// `matrix`
    Matrix,
    /// `triangles` (planar bones)
    Triangles,
}

impl core::fmt::Display for LoadError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match *self {
            Self::Truncated { expected, found } => {
                write!(f, "truncated rig blob: {found} bytes, expected {expected}")
            }
            Self::TrailingBytes { extra } => write!(f, "{extra} unexpected bytes after the rig payload"),
            Self::BadMagic => f.write_str("not a facebake rig blob (bad magic)"),
            Self::UnsupportedVersion { found } => {
                write!(f, "rig format version {found} is not supported (this runtime reads {VERSION})")
            }
            Self::BadReserved => f.write_str("reserved header field is not zero"),
            Self::ChecksumMismatch { stored, computed } => write!(
                f,
                "payload checksum mismatch: header says {stored:#010x}, payload has {computed:#010x}"
            ),
            Self::Malformed => f.write_str("payload is not a valid rig encoding"),
            Self::PayloadTrailingBytes => f.write_str("payload has unread bytes after the rig data"),
            Self::BadSpace => f.write_str("rig space has a non-finite centre or a non-positive extent"),
            Self::BadMarkerCount { found } => {
                write!(f, "marker count {found} is outside 1..={MAX_MARKERS}")
            }
            Self::BadMaxInfluences { found } => {
                write!(f, "max influences {found} is outside 1..={MAX_INFLUENCES}")
            }
            Self::BadWeightFormat { found } => write!(
                f,
                "weight fractional bits {found} outside {MIN_WEIGHT_FRAC_BITS}..={MAX_WEIGHT_FRAC_BITS}"
            ),
            Self::SectionLength { section, expected, found } => {
                write!(f, "section {section:?} has {found} bytes, expected {expected}")
            }
            Self::BadMarkerName { marker } => write!(f, "marker {marker} has an invalid name"),
            Self::TooManyInfluences { vertex, count } => {
                write!(f, "vertex {vertex} has {count} influences, above the rig's maximum")
            }
            Self::MarkerIndexOutOfRange { vertex, marker } => {
                write!(f, "vertex {vertex} is influenced by marker {marker}, which does not exist")
            }
            Self::WeightsNotNormalised { vertex } => {
                write!(f, "the weights of vertex {vertex} do not sum to one")
            }
            Self::BadRowShift { row, shift } => write!(
                f,
                "coefficient row {row} has scale exponent {shift}, outside {MIN_ROW_SHIFT}..={MAX_ROW_SHIFT}"
            ),
            Self::CoefficientsNotNormalised { row } => write!(
                f,
                "coefficient row {row} does not sum to what exact translation needs"
            ),
            Self::BadStages(e) => write!(f, "capture stages: {e}"),
            Self::WeightsTooLarge { vertex } => write!(
                f,
                "the weights of vertex {vertex} have magnitudes summing above {LINEAR_WEIGHT_ABS_SUM_MAX}"
            ),
            Self::BadTriangleCount { found } => {
                write!(f, "control triangle count {found} is outside 1..={MAX_TRIANGLES}")
            }
            Self::TriangleMarkerOutOfRange { triangle, marker } => write!(
                f,
                "control triangle {triangle} names marker {marker}, which does not exist"
            ),
            Self::DegenerateRestTriangle { triangle } => {
                write!(f, "control triangle {triangle} is degenerate at rest")
            }
            Self::TriangleIndexOutOfRange { vertex, triangle } => write!(
                f,
                "vertex {vertex} is influenced by control triangle {triangle}, which does not exist"
            ),
            Self::BadRegion { vertex, region } => {
                write!(f, "vertex {vertex} has an influence with region code {region} (0..=6)")
            }
        }
    }
}

/// The header for `payload`: magic, [`VERSION`], length and CRC. The blob is the header followed
/// by the payload.
pub fn header_for(payload: &[u8]) -> Result<[u8; HEADER_LEN], PayloadTooLarge> {
    let len = u32::try_from(payload.len()).map_err(|_| PayloadTooLarge)?;
    let mut h = [0u8; HEADER_LEN];
    h[..8].copy_from_slice(&MAGIC);
    h[8..10].copy_from_slice(&VERSION.to_le_bytes());
    h[12..16].copy_from_slice(&len.to_le_bytes());
    h[16..20].copy_from_slice(&crc32(payload).to_le_bytes());
    Ok(h)
}

/// A payload of 4 GiB or more cannot be described by the header.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PayloadTooLarge;

/// Bytes of one stored vertex rest position.
pub const REST_BYTES: usize = 6;
/// Bytes of one stored Q8.24 position (marker rest).
pub const POSITION_BYTES: usize = 12;
/// Bytes of one packed influence.
pub const INFLUENCE_BYTES: usize = 4;

/// Decode one `vertex_rest` item (3 × `i16` LE, Q0.15) as Q8.24. Takes a [`REST_BYTES`]-long
/// chunk of the section (from `chunks_exact`); each section's layout is read only here.
#[inline(always)]
pub fn read_rest(b: &[u8]) -> [i32; 3] {
    // Always six bytes: the fallback folds away, and the read is one load.
    let b: [u8; REST_BYTES] = b.try_into().unwrap_or([0; REST_BYTES]);
    [0, 1, 2].map(|c| widen_rest(i16::from_le_bytes([b[2 * c], b[2 * c + 1]])))
}

/// Decode one `marker_rest` item (3 × `i32` LE, Q8.24) from a [`POSITION_BYTES`]-long chunk.
#[inline(always)]
pub fn read_position(b: &[u8]) -> [i32; 3] {
    let b: [u8; POSITION_BYTES] = b.try_into().unwrap_or([0; POSITION_BYTES]);
    [0, 1, 2].map(|c| i32::from_le_bytes([b[4 * c], b[4 * c + 1], b[4 * c + 2], b[4 * c + 3]]))
}

/// Decode one packed influence (marker or centre index, signed 24-bit weight) from an
/// [`INFLUENCE_BYTES`]-long chunk.
#[inline(always)]
pub fn read_influence(b: &[u8]) -> (u8, i32) {
    let b: [u8; INFLUENCE_BYTES] = b.try_into().unwrap_or([0; INFLUENCE_BYTES]);
    unpack_influence(u32::from_le_bytes(b))
}

fn le_u16(b: &[u8], at: usize) -> u16 {
    u16::from_le_bytes([b[at], b[at + 1]])
}

fn le_u32(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes([b[at], b[at + 1], b[at + 2], b[at + 3]])
}

/// Check the header and checksum and return the payload.
pub fn open(bytes: &[u8]) -> Result<&[u8], LoadError> {
    if bytes.len() < HEADER_LEN {
        return Err(LoadError::Truncated {
            expected: HEADER_LEN,
            found: bytes.len(),
        });
    }
    if bytes[..8] != MAGIC {
        return Err(LoadError::BadMagic);
    }
    let version = le_u16(bytes, 8);
    if version != VERSION {
        return Err(LoadError::UnsupportedVersion { found: version });
    }
    if le_u16(bytes, 10) != 0 {
        return Err(LoadError::BadReserved);
    }
    let len = le_u32(bytes, 12) as usize;
    let rest = &bytes[HEADER_LEN..];
    if rest.len() < len {
        return Err(LoadError::Truncated {
            expected: HEADER_LEN.saturating_add(len),
            found: bytes.len(),
        });
    }
    if rest.len() > len {
        return Err(LoadError::TrailingBytes {
            extra: rest.len() - len,
        });
    }
    let stored = le_u32(bytes, 16);
    let computed = crc32(rest);
    if stored != computed {
        return Err(LoadError::ChecksumMismatch { stored, computed });
    }
    Ok(rest)
}

/// Decode and validate a payload. After this succeeds every index and length in the returned
/// data is in range, so the per-frame path needs no checks that can fail.
pub fn decode(payload: &[u8]) -> Result<RigData<'_>, LoadError> {
    let (data, rest): (RigData<'_>, &[u8]) =
        postcard::take_from_bytes(payload).map_err(|_| LoadError::Malformed)?;
    if !rest.is_empty() {
        return Err(LoadError::PayloadTrailingBytes);
    }
    validate(&data)?;
    Ok(data)
}

pub(crate) fn expect_len(
    section: Section,
    bytes: Bytes<'_>,
    count: usize,
    per_item: usize,
) -> Result<(), LoadError> {
    // On 16-bit targets a huge count could overflow; treat that as a length mismatch.
    let expected = count.saturating_mul(per_item);
    if bytes.0.len() != expected {
        return Err(LoadError::SectionLength {
            section,
            expected,
            found: bytes.0.len(),
        });
    }
    Ok(())
}

/// `x.is_finite()`, on the IEEE-754 bits: the exponent is not all ones. Integer-only, so loading
/// a rig needs no floating-point code on a core without an FPU (no soft-float routines linked).
pub(crate) fn f32_is_finite(x: f32) -> bool {
    x.to_bits() & 0x7F80_0000 != 0x7F80_0000
}

/// `x > 0.0`, on the IEEE-754 bits: sign clear, not ±0, not NaN.
pub(crate) fn f32_is_positive(x: f32) -> bool {
    let bits = x.to_bits();
    bits & 0x8000_0000 == 0 && bits != 0 && bits <= 0x7F80_0000
}

fn validate(d: &RigData<'_>) -> Result<(), LoadError> {
    let s = d.space;
    if !(s.centre.iter().all(|&c| f32_is_finite(c))
        && f32_is_finite(s.half_extent)
        && f32_is_positive(s.half_extent))
    {
        return Err(LoadError::BadSpace);
    }
    let markers = usize::from(d.marker_count);
    if markers == 0 || markers > MAX_MARKERS {
        return Err(LoadError::BadMarkerCount {
            found: d.marker_count,
        });
    }
    let vertices = usize::try_from(d.vertex_count).unwrap_or(usize::MAX);
    validate_names(d.marker_names, markers)?;
    expect_len(Section::MarkerRest, d.marker_rest, markers, 12)?;
    expect_len(Section::VertexRest, d.vertex_rest, vertices, 6)?;
    match d.deformer {
        Deformer::Linear(lin) => validate_linear(&lin, vertices, markers)?,
        Deformer::RbfCoefficients(rbf) => validate_rbf(&rbf, vertices, markers)?,
        Deformer::PlanarBones(planar) => {
            crate::kernel::planar::validate(&planar, d.marker_rest.0, vertices, markers)?
        }
    }
    if let Some(stages) = &d.stages {
        stages.validate(markers).map_err(LoadError::BadStages)?;
    }
    Ok(())
}

fn validate_names(names: Bytes<'_>, markers: usize) -> Result<(), LoadError> {
    let mut at = 0usize;
    for marker in 0..markers {
        let bad = LoadError::BadMarkerName { marker };
        let len = usize::from(*names.0.get(at).ok_or(bad)?);
        let name = names.0.get(at + 1..at + 1 + len).ok_or(bad)?;
        if len == 0 || core::str::from_utf8(name).is_err() {
            return Err(bad);
        }
        at += 1 + len;
    }
    if at != names.0.len() {
        return Err(LoadError::SectionLength {
            section: Section::MarkerNames,
            expected: at,
            found: names.0.len(),
        });
    }
    Ok(())
}

fn validate_k_and_format(k: u8, weight_frac_bits: u8) -> Result<(), LoadError> {
    if k == 0 || k > MAX_INFLUENCES {
        return Err(LoadError::BadMaxInfluences { found: k });
    }
    if !(MIN_WEIGHT_FRAC_BITS..=MAX_WEIGHT_FRAC_BITS).contains(&weight_frac_bits) {
        return Err(LoadError::BadWeightFormat {
            found: weight_frac_bits,
        });
    }
    Ok(())
}

fn validate_rbf(
    rbf: &RbfCoefficients<'_>,
    vertices: usize,
    markers: usize,
) -> Result<(), LoadError> {
    validate_k_and_format(rbf.influences_per_vertex, rbf.weight_frac_bits)?;
    let k = usize::from(rbf.influences_per_vertex);
    let rows = markers + if rbf.affine { 4 } else { 0 };
    expect_len(Section::RowShifts, rbf.row_shifts, rows, 1)?;
    expect_len(Section::Matrix, rbf.matrix, rows, 2 * markers)?;
    expect_len(
        Section::Influences,
        rbf.influences,
        vertices,
        4usize.saturating_mul(k),
    )?;
    for (row, (&shift, entries)) in rbf
        .row_shifts
        .0
        .iter()
        .zip(rbf.matrix.0.chunks_exact(2 * markers))
        .enumerate()
    {
        if !(MIN_ROW_SHIFT..=MAX_ROW_SHIFT).contains(&shift) {
            return Err(LoadError::BadRowShift { row, shift });
        }
        let sum: i64 = entries
            .chunks_exact(2)
            .map(|q| i64::from(i16::from_le_bytes([q[0], q[1]])))
            .sum();
        let want = if rbf.affine && row == markers {
            1i64 << shift
        } else {
            0
        };
        if sum != want {
            return Err(LoadError::CoefficientsNotNormalised { row });
        }
    }
    for (vertex, words) in rbf
        .influences
        .0
        .chunks_exact(INFLUENCE_BYTES * k)
        .enumerate()
    {
        for w in words.chunks_exact(INFLUENCE_BYTES) {
            let (marker, _) = read_influence(w);
            if usize::from(marker) >= markers {
                return Err(LoadError::MarkerIndexOutOfRange { vertex, marker });
            }
        }
    }
    Ok(())
}

fn validate_linear(
    lin: &LinearInfluences<'_>,
    vertices: usize,
    markers: usize,
) -> Result<(), LoadError> {
    if lin.max_influences == 0 || lin.max_influences > MAX_INFLUENCES {
        return Err(LoadError::BadMaxInfluences {
            found: lin.max_influences,
        });
    }
    if !(MIN_WEIGHT_FRAC_BITS..=LINEAR_MAX_WEIGHT_FRAC_BITS).contains(&lin.weight_frac_bits) {
        return Err(LoadError::BadWeightFormat {
            found: lin.weight_frac_bits,
        });
    }
    expect_len(Section::InfluenceCounts, lin.influence_counts, vertices, 1)?;
    let total: usize = lin.influence_counts.0.iter().map(|&c| usize::from(c)).sum();
    expect_len(Section::Influences, lin.influences, total, 4)?;
    let one = 1i64 << lin.weight_frac_bits;
    let mut words = lin.influences.0.chunks_exact(INFLUENCE_BYTES);
    for (vertex, &count) in lin.influence_counts.0.iter().enumerate() {
        if count > lin.max_influences {
            return Err(LoadError::TooManyInfluences { vertex, count });
        }
        let (mut sum, mut abs_sum) = (0i64, 0i64);
        for w in words.by_ref().take(usize::from(count)) {
            let (marker, weight) = read_influence(w);
            if usize::from(marker) >= markers {
                return Err(LoadError::MarkerIndexOutOfRange { vertex, marker });
            }
            sum += i64::from(weight);
            abs_sum += i64::from(weight).abs();
        }
        if count > 0 && sum != one {
            return Err(LoadError::WeightsNotNormalised { vertex });
        }
        if abs_sum > i64::from(LINEAR_WEIGHT_ABS_SUM_MAX) {
            return Err(LoadError::WeightsTooLarge { vertex });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::{f32_is_finite, f32_is_positive};

    /// The integer bit tests agree with the float operations they replace, on every class of
    /// value: zeros, subnormals, normals, the extremes, infinities and NaNs of both signs.
    #[test]
    fn space_checks_on_bits_match_float_semantics() {
        let special = [
            0.0,
            -0.0,
            f32::MIN_POSITIVE,
            -f32::MIN_POSITIVE,
            f32::from_bits(1),
            f32::from_bits(0x8000_0001),
            1.0,
            -1.0,
            0.25,
            f32::MAX,
            f32::MIN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            -f32::NAN,
            f32::from_bits(0x7F80_0001),
            f32::from_bits(0xFFFF_FFFF),
            f32::from_bits(0x7F7F_FFFF),
        ];
        // And a spread of bit patterns across the whole range.
        let mut bits = 0u32;
        let spread = (0..1 << 16).map(|_| {
            bits = bits.wrapping_mul(0x9E37_79B9).wrapping_add(0x7F4A_7C15);
            f32::from_bits(bits)
        });
        for x in special.into_iter().chain(spread) {
            assert_eq!(f32_is_finite(x), x.is_finite(), "{:#010x}", x.to_bits());
            assert_eq!(f32_is_positive(x), x > 0.0, "{:#010x}", x.to_bits());
        }
    }
}
