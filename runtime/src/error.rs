//! Why a byte string is not a loadable rig: [`LoadError`], with [`StagesLoadError`] for the
//! capture stages section. Both implement [`core::error::Error`].
//!
//! Depends only on the leaves `fixed` and `records` (for the bounds its messages state),
//! so every module that validates a section can use it.

use crate::fixed::{
    LINEAR_WEIGHT_ABS_SUM_MAX, MAX_INFLUENCES, MAX_ROW_SHIFT, MAX_WEIGHT_FRAC_BITS,
    MIN_ROW_SHIFT, MIN_WEIGHT_FRAC_BITS,
};
use crate::records::{Bytes, MAX_MARKERS, MAX_MARKER_PAIRS, MAX_TRIANGLES, OLDEST_VERSION, SECTION_ALIGN, VERSION};

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
    /// The first eight bytes are not `MAGIC`.
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
    /// The payload is not a postcard-encoded `RigData`.
    Malformed,
    /// The payload decodes but leaves bytes unread.
    PayloadTrailingBytes,
    /// `space` holds a non-finite value or a non-positive half extent.
    BadSpace,
    /// `marker_count` is 0 or above `MAX_MARKERS`.
    BadMarkerCount {
        /// The count in the blob.
        found: u16,
    },
    /// `max_influences` is 0 or above `MAX_INFLUENCES`.
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
    /// An alignment section is not fewer than `SECTION_ALIGN` zero bytes.
    BadAlignment {
        /// The section it aligns.
        section: Section,
    },
    /// A vertex has more influence pairs than `max_influences` (K).
    TooManyInfluencePairs {
        /// The vertex.
        vertex: usize,
        /// Its influence pair count.
        count: u8,
    },
    /// A linear rig has more marker pairs than `MAX_MARKER_PAIRS`.
    TooManyMarkerPairs {
        /// How many it has.
        found: usize,
    },
    /// A linear rig's derived marker names a marker that does not exist (or one past the
    /// markers); is a projection with a zero direction or one with `Σ|a_c|` above 2¹⁴, or a
    /// mean of fewer than 2 or more than 7 markers or with non-zero bytes past its sources; or
    /// the rig has more markers and derived markers together than `MAX_MARKERS`.
    BadDerivedMarker {
        /// The derived marker (0 for the first; its index among the markers is the marker
        /// count plus this).
        derived: usize,
    },
    /// A marker pair names a marker that does not exist.
    PairMarkerOutOfRange {
        /// The marker pair.
        pair: usize,
        /// The marker index it names.
        marker: u8,
    },
    /// An influence pair names a marker pair that does not exist.
    PairIndexOutOfRange {
        /// The vertex the influence pair belongs to.
        vertex: usize,
        /// The marker pair index it names.
        pair: u16,
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
    Stages(StagesLoadError),
    /// A vertex's linear weights have Σ|w| above `LINEAR_WEIGHT_ABS_SUM_MAX`, the bound the
    /// linear deformer's 32-bit sums rest on.
    WeightsTooLarge {
        /// The vertex.
        vertex: usize,
    },
    /// A planar rig has no control triangle or more than `MAX_TRIANGLES`.
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
    /// The normals section's vertex index width is neither 2 nor 4 bytes.
    BadIndexWidth {
        /// The width in the blob.
        found: u8,
    },
    /// A stored rest normal has a component beyond ±1.0 (±2¹⁴ in Q1.14).
    BadRestNormal {
        /// The vertex.
        vertex: usize,
    },
    /// A corner of a vertex's fan names a vertex that does not exist.
    CornerOutOfRange {
        /// The vertex whose fan holds the corner.
        vertex: usize,
        /// The vertex index it names.
        corner: u32,
    },
    /// A weld entry names a vertex out of range, is not in ascending order, welds a vertex to
    /// itself or to a vertex that is welded in turn, or welds a vertex that has its own fan.
    BadWeld {
        /// The entry's position in `welds`.
        entry: usize,
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
    /// `derived_markers`
    DerivedMarkers,
    /// `marker_pairs`
    MarkerPairs,
    /// `pair_counts`
    PairCounts,
    /// `pairs`
    Pairs,
    /// `row_shifts`
    RowShifts,
    /// `matrix`
    Matrix,
    /// `triangles` (planar bones)
    Triangles,
    /// `normals.rest`
    RestNormals,
    /// `normals.fan_counts`
    FanCounts,
    /// `normals.corners`
    Corners,
    /// `normals.welds`
    Welds,
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
                write!(
                    f,
                    "rig format version {found} is not supported (this runtime reads {OLDEST_VERSION} to {VERSION})"
                )
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
            Self::BadAlignment { section } => write!(
                f,
                "the alignment before {section:?} is not {SECTION_ALIGN} zero bytes at most"
            ),
            Self::TooManyInfluencePairs { vertex, count } => write!(
                f,
                "vertex {vertex} has {count} influence pairs, above the rig's maximum influences"
            ),
            Self::TooManyMarkerPairs { found } => write!(
                f,
                "the rig has {found} marker pairs, above the limit of {MAX_MARKER_PAIRS}"
            ),
            Self::BadDerivedMarker { derived } => write!(
                f,
                "derived marker {derived} names no marker, is a projection on a zero direction or one longer than 1 (the sum of its components' magnitudes in Q1.14), is a mean of fewer than 2 or more than 7 markers or has non-zero bytes past its sources, or is one past the {MAX_MARKERS} markers a rig may have"
            ),
            Self::PairMarkerOutOfRange { pair, marker } => {
                write!(f, "marker pair {pair} names marker {marker}, which does not exist")
            }
            Self::PairIndexOutOfRange { vertex, pair } => {
                write!(f, "vertex {vertex} names marker pair {pair}, which does not exist")
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
            Self::Stages(e) => write!(f, "capture stages: {e}"),
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
            Self::BadIndexWidth { found } => {
                write!(f, "normals section vertex indices are {found} bytes wide, not 2 or 4")
            }
            Self::BadRestNormal { vertex } => {
                write!(f, "the rest normal of vertex {vertex} has a component beyond ±1")
            }
            Self::CornerOutOfRange { vertex, corner } => write!(
                f,
                "the fan of vertex {vertex} names vertex {corner}, which does not exist"
            ),
            Self::BadWeld { entry } => write!(
                f,
                "weld entry {entry} is out of range, out of order, or welds a vertex that has its own triangles"
            ),
        }
    }
}


/// Why a rig's capture stages are invalid. Every variant is a distinct failure.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StagesLoadError {
    /// `actor_space` holds a non-finite value or a non-positive half extent.
    BadActorSpace,
    /// A section's length disagrees with the marker count.
    SectionLength {
        /// Which section.
        section: StagesSection,
        /// Bytes the counts imply.
        expected: usize,
        /// Bytes the section has.
        found: usize,
    },
    /// An actor neutral coordinate lies beyond ±`NEUTRAL_LIMIT`.
    NeutralOutOfRange {
        /// The marker.
        marker: usize,
    },
    /// Head markers: a count other than 0 or 3..=32, an index out of range, or not ascending.
    BadHeadMarkers,
    /// Anchors: an index out of range, not ascending, a head marker, or one with fill neighbours.
    BadAnchors,
    /// `max_displacement` is not in (0, `INPUT_LIMIT`].
    BadMaxDisplacement,
    /// A fill neighbour names a missing marker or the marker itself, or has a negative weight.
    BadFillNeighbour {
        /// The marker being rebuilt.
        marker: usize,
    },
    /// A retarget radius is not in (0, `NEUTRAL_LIMIT`].
    BadRadius {
        /// The marker.
        marker: usize,
    },
    /// A retarget coefficient is beyond ±`ALPHA_LIMIT`.
    AlphaOutOfRange {
        /// The marker.
        marker: usize,
    },
    /// `alpha_shift` above `MAX_ALPHA_SHIFT` or `linear_shift` outside `LINEAR_SHIFTS`.
    BadShift,
    /// `head_tolerance` is not in (0, `INPUT_LIMIT`].
    BadHeadTolerance,
    /// `max_step` is not in (0, `INPUT_LIMIT`].
    BadMaxStep,
    /// The refit cutoff is neither 0 nor in [`MIN_REFIT_CUTOFF`, `MAX_REFIT_CUTOFF`]
    /// (`crate::stages::refit`).
    BadRefitCutoff,
    /// The smoothing's `min_cutoff` is not in [1, `MAX_CUTOFF`].
    BadMinCutoff,
    /// The smoothing's `speed_gain` is above `MAX_SPEED_GAIN`.
    BadSpeedGain,
    /// The smoothing's `derivative_cutoff` is not in [1, `MAX_CUTOFF`].
    BadDerivativeCutoff,
}

/// A section of the capture stages, for [`StagesLoadError::SectionLength`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StagesSection {
    /// `actor_neutral`
    ActorNeutral,
    /// `fill`
    Fill,
    /// `retarget.radii`
    Radii,
    /// `retarget.alpha`
    Alpha,
    /// per-marker `matrices`
    Matrices,
    /// per-marker `rest`
    Rest,
}

impl core::fmt::Display for StagesLoadError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match *self {
            Self::BadActorSpace => {
                f.write_str("actor space has a non-finite centre or a non-positive extent")
            }
            Self::SectionLength {
                section,
                expected,
                found,
            } => {
                write!(
                    f,
                    "capture section {section:?} has {found} bytes, expected {expected}"
                )
            }
            Self::NeutralOutOfRange { marker } => {
                write!(
                    f,
                    "actor neutral marker {marker} lies beyond ±4 actor units"
                )
            }
            Self::BadHeadMarkers => f.write_str(
                "head markers must be none or 3 to 32 distinct marker indices in ascending order",
            ),
            Self::BadAnchors => f.write_str(
                "anchors must be distinct marker indices in ascending order, not head markers, without fill neighbours",
            ),
            Self::BadMaxDisplacement => {
                f.write_str("max displacement must be in (0, 64] actor units")
            }
            Self::BadFillNeighbour { marker } => {
                write!(f, "marker {marker} has a fill neighbour that is invalid")
            }
            Self::BadRadius { marker } => {
                write!(
                    f,
                    "retarget radius of marker {marker} is not in (0, 4] actor units"
                )
            }
            Self::AlphaOutOfRange { marker } => {
                write!(
                    f,
                    "retarget coefficient of marker {marker} is beyond 24 bits"
                )
            }
            Self::BadShift => f.write_str("retarget scale exponent out of range"),
            Self::BadHeadTolerance => {
                f.write_str("head-marker distance tolerance must be in (0, 64] actor units")
            }
            Self::BadMaxStep => f.write_str("max step must be in (0, 64] actor units per frame"),
            Self::BadRefitCutoff => {
                f.write_str("the head refit's cutoff must be 0 or in [2^-12, 1] actor unit")
            }
            Self::BadMinCutoff => f.write_str("smoothing minimum cutoff must be in (0, 256]"),
            Self::BadSpeedGain => f.write_str("smoothing speed gain must be at most 2^14"),
            Self::BadDerivativeCutoff => {
                f.write_str("smoothing speed cutoff must be in (0, 256]")
            }
        }
    }
}


impl core::error::Error for LoadError {
    fn source(&self) -> Option<&(dyn core::error::Error + 'static)> {
        match self {
            Self::Stages(e) => Some(e),
            _ => None,
        }
    }
}

impl core::error::Error for StagesLoadError {}

/// `Ok` if `bytes` holds exactly `count` records of `per_item` bytes, else
/// [`LoadError::SectionLength`] naming `section`.
pub(crate) fn expect_len(
    section: Section,
    bytes: Bytes<'_>,
    count: usize,
    per_item: usize,
) -> Result<(), LoadError> {
    check_len(bytes, count, per_item).map_err(|(expected, found)| LoadError::SectionLength {
        section,
        expected,
        found,
    })
}

/// [`expect_len`] for a section of the capture stages.
pub(crate) fn expect_stages_len(
    section: StagesSection,
    bytes: Bytes<'_>,
    count: usize,
    per_item: usize,
) -> Result<(), StagesLoadError> {
    check_len(bytes, count, per_item).map_err(|(expected, found)| {
        StagesLoadError::SectionLength {
            section,
            expected,
            found,
        }
    })
}

/// `Err((expected, found))` unless `bytes` holds exactly `count` records of `per_item` bytes.
fn check_len(bytes: Bytes<'_>, count: usize, per_item: usize) -> Result<(), (usize, usize)> {
    // On 16-bit targets a huge count could overflow; treat that as a length mismatch.
    let expected = count.saturating_mul(per_item);
    match bytes.0.len() {
        found if found == expected => Ok(()),
        found => Err((expected, found)),
    }
}
