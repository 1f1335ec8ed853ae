//! The rig blob: the one definition of the format, used by the runtime to read it and by the
//! baker to write it.
//!
//! A blob is a fixed [`header`] (magic, version, length, CRC-32) followed by the payload,
//! [`RigData`] encoded with postcard; [`RigData`]'s docs describe every section. The payload's
//! bulk sections are postcard byte strings ([`records::Bytes`]: a varint length, then the bytes),
//! which the loader borrows in place: nothing is copied, so a blob can be read straight from
//! flash. Inside them every number is little-endian, in fixed-size [`records`].
//!
//! * [`header`]: the header, read ([`header::open`]) and written.
//! * [`records`]: every record size, named once, and the shared record readers (a leaf).
//! * [`error`]: [`LoadError`], every way a blob can fail to load.
//! * this module: [`RigData`], its decoding and the validation of the sections every deformer
//!   shares; each deformer validates its own section ([`crate::deformer`]), the capture stages
//!   theirs ([`crate::stages`]).

pub mod header;
/// The blob's errors and byte records, leaves that the deformers and the stages build on, so
/// that `format` (the payload over them) imports them and none of them imports `format`.
#[cfg(feature = "format")]
pub use crate::{error, records};

use serde::{Deserialize, Serialize};

use crate::deformer::{check, Deformer, Shared};
use crate::error::{expect_len, LoadError, Section};
use crate::normals::Normals;
use crate::records::{Bytes, MAX_MARKERS, POSITION_BYTES, REST_BYTES};
use crate::space::Space;
use crate::stages::Stages;

/// The payload of a rig blob (format version 9; version 8 is read too): every section, in encoding order.
///
/// # Shared sections
///
/// | section | per item | contents |
/// |---|---|---|
/// | `space` | — | [`Space`]: centre (3 × `f32`) and half extent (`f32`) |
/// | `marker_count` | — | varint, in [1, [`MAX_MARKERS`]] |
/// | `vertex_count` | — | varint |
/// | `marker_names` | marker | `u8` length, then that many UTF-8 bytes |
/// | `marker_rest` | marker | 3 × `i32` LE, Q8.24 rig units ([`POSITION_BYTES`]) |
/// | `vertex_rest_align` | — | fewer than [`records::SECTION_ALIGN`] zero bytes: `vertex_rest` starts at a multiple of it from the blob's first byte |
/// | `vertex_rest` | vertex | 3 × `i16` LE, Q0.15 rig units ([`REST_BYTES`]) |
/// | `normals` | — | [`Normals`], below |
/// | `deformer` | — | one of [`Deformer`] (a varint variant index, then its section) |
/// | `stages` | — | `0`, or `1` then [`Stages`] |
///
/// A packed influence word ([`records::INFLUENCE_BYTES`]) is a `u32` LE: bits 0–7 a marker (or
/// RBF centre) index, bits 8–31 the weight as a signed 24-bit integer.
///
/// # Normals section
///
/// [`Normals`]: the mesh's triangles as per-vertex fans over welded vertices, for
/// [`crate::Rig::normals`] (method and bounds in the `normals` module's docs).
///
/// | section | per item | contents |
/// |---|---|---|
/// | `index_bytes` | — | `u8` W, 2 or 4: the width of a vertex index below |
/// | `rest` | vertex | 3 × `i16` LE, Q1.14 unit rest normal, each component within ±2¹⁴ ([`records::NORMAL_BYTES`]) |
/// | `fan_counts` | vertex | `u8`: corners of the vertex's chained fan; 0 for a welded vertex or one in no triangle |
/// | `corners` | fan corner | W-byte LE vertex index; each two consecutive corners of a fan are a triangle's other two corners in winding order, or include the vertex itself (a break) |
/// | `welds` | welded vertex | 2 × W-byte LE vertex indices: the vertex (strictly ascending, fan count 0) and the vertex whose normal it copies (fan count > 0) |
///
/// # Deformer sections
///
/// Variant 0, **linear** ([`crate::deformer::linear::LinearDeformer`]): per vertex, weights on
/// marker displacements, two influences at a time.
///
/// | section | per item | contents |
/// |---|---|---|
/// | `weight_frac_bits` | — | `u8` F in [8, 14] |
/// | `max_influences` | — | `u8` K in [1, 64] |
/// | `derived_markers` | derived marker | 8 bytes, marker M + j (`crate::deformer::linear`). A projection: `u8` source marker (below the marker count M), a zero byte, a direction `a` (3 × `i16` LE, Q1.14, `1 ≤ Σ|a_c| ≤ 2¹⁴`), the source's displacement projected on it. A mean: `u8` first source, `u8` count n in [2, 7], n − 1 more `u8` sources, zero bytes; all sources below M. M plus their count at most [`MAX_MARKERS`] |
/// | `marker_pairs` | marker pair | 2 × `u8` marker indices (a, b) below M plus the derived markers; at most [`records::MAX_MARKER_PAIRS`] |
/// | `pair_counts` | vertex | `u8` n, at most K (bakes write ⌈K/2⌉, more only where the marker pairs ran out) |
/// | `pairs_align` | — | fewer than [`records::SECTION_ALIGN`] zero bytes: `pairs` starts at a multiple of it from the blob's first byte |
/// | `pairs` | vertex | its n weight pairs (2 × `i16` LE: w_a, w_b), then its n marker pair indices (`u16` LE) |
///
/// The weights of a vertex sum to exactly `2^F` (or it has no influences and never moves), and
/// their magnitudes to at most `i16::MAX`: the linear deformer's 32-bit sums rely on it. A
/// vertex with an odd number of influences has one pair with a zero weight.
///
/// Variant 1, **rbf** ([`crate::deformer::rbf::RbfDeformer`]): per frame, the RBF coefficients
/// `c = M · D` (one row of `M` per radial centre, plus four affine rows β₀, βx, βy, βz), then per
/// vertex the K largest radial terms `Σ φ_k(v) c_k` plus the affine part `β₀ + β · rest(v)`.
///
/// | section | per item | contents |
/// |---|---|---|
/// | `influences_per_vertex` | — | `u8` K in [1, 64] |
/// | `weight_frac_bits` | — | `u8` F in [8, 22]: φ is Q(23−F).F |
/// | `affine` | — | `bool`: whether the four affine rows follow |
/// | `row_shifts` | coefficient row | `u8` s ∈ [1, 48]: the row's entries are `q · 2^−s` |
/// | `matrix` | coefficient row × marker | `i16` LE q |
/// | `influences` | vertex × K | packed influence word; the index is a radial centre (a marker) |
///
/// The integer entries of every radial row and of βx, βy, βz sum to 0, those of β₀ to `2^s`:
/// a uniform translation gives exactly zero radial coefficients and β₀ equal to the translation,
/// so it moves every vertex by exactly that translation.
///
/// Variant 2, **planar** ([`crate::deformer::planar::PlanarDeformer`], paper 000 §4.1–4.2): a
/// triangulated control surface of the markers; per vertex, each of its at most K triangles moves
/// it by the transform of the region it lies in, blended by weights summing to exactly one.
///
/// | section | per item | contents |
/// |---|---|---|
/// | `max_influences` | — | `u8` K in [1, 64] |
/// | `triangle_count` | — | varint, in [1, [`records::MAX_TRIANGLES`]] |
/// | `triangles` | control triangle | 3 × `u8` marker indices (O, P, Q) |
/// | `influence_counts` | vertex | `u8` in [1, K] |
/// | `influences` | influence | [`records::PLANAR_INFLUENCE_BYTES`] bytes: `u16` LE bits 0–12 the triangle, bits 13–15 the region (0 = R_A, 1 + i = R_B,i, 4 + i = R_C,i); `u16` LE weight, Q1.15; then 4 × `i32` LE local coordinates x, y, z, w |
///
/// # Capture stages section (optional)
///
/// [`Stages`], which turn an actor's raw markers into this rig's markers at run time; the
/// markers are the rig's, in the rig's order.
///
/// | section | per item | contents |
/// |---|---|---|
/// | `actor_space` | — | [`Space`] of the capture |
/// | `actor_neutral` | marker | 3 × `i32` LE, Q8.24 actor units, within ±4 |
/// | `head_markers` | head marker | `u8` marker index, strictly ascending; none or 3 to 32 |
/// | `max_displacement` | — | varint `i32`, Q8.24 actor units, in (0, 64] |
/// | `fill` | marker | [`records::FILL_NEIGHBOURS`] packed words: neighbour index, Q8.16 weight ≥ 0 (0: unused) |
/// | `retarget` | — | one of [`crate::stages::retarget::Retarget`], below |
/// | `anchors` | anchor | `u8` marker index, strictly ascending, not a head marker, no fill neighbours |
/// | `head_tolerance` | — | varint `i32`, Q8.24 actor units, in (0, 64]: how far a head-marker pair's distance may stray from neutral |
/// | `max_step` | — | varint `i32`, Q8.24 actor units per frame, in (0, 64]: the step gate |
/// | `smoothing` | — | `0`, or `1` then [`crate::stages::smoothing::Smoothing`], below: the markers' filter |
/// | `head_smoothing` | — | `0`, or `1` then [`crate::stages::smoothing::Smoothing`]: the head pose's filter |
/// | `refit_cutoff` | — | varint `i32`, Q8.24 actor units, 0 or in [2⁻¹², 1]: the head fit done again over the face, weighted by Tukey's biweight with this cutoff ([`crate::stages::refit`]; 0: not) |
///
/// Retargeting, variant 0, **rbf** ([`crate::stages::retarget::RbfRetarget`]):
///
/// | section | per item | contents |
/// |---|---|---|
/// | `radii` | marker | `i32` LE radius, Q8.24 actor units, in (0, 4] |
/// | `alpha_shift` | — | `u8`, at most 48 |
/// | `alpha` | marker | 3 × `i32` LE, each below 2²³ in magnitude, scale `2^−alpha_shift` |
/// | `linear_shift` | — | `u8` in [1, 40] |
/// | `linear` | — | 9 × varint `i32`, row-major, scale `2^−linear_shift` |
/// | `offset` | — | 3 × varint `i32`, Q8.24 rig units |
///
/// Retargeting, variant 1, **proportional** ([`crate::stages::retarget::ProportionalRetarget`]):
///
/// | section | per item | contents |
/// |---|---|---|
/// | `shift` | — | `u8` in [1, 40] |
/// | `matrices` | marker | 9 × `i32` LE, row-major, scale `2^−shift` ([`records::MATRIX3_BYTES`]) |
/// | `rest` | marker | 3 × `i32` LE, Q8.24 rig units |
///
/// Smoothing ([`crate::stages::smoothing::Smoothing`], per frame at the capture's rate):
///
/// | section | per item | contents |
/// |---|---|---|
/// | `min_cutoff` | — | varint `u32`, Q16.16, in [1, 2²⁴]: 2π f_min / rate |
/// | `speed_gain` | — | varint `u32`, Q16.16, at most 2³⁰: cutoff added per actor unit per frame of speed |
/// | `derivative_cutoff` | — | varint `u32`, Q16.16, in [1, 2²⁴]: 2π f_d / rate |
///
/// Version 2 added the optional capture stages, version 3 their `head_tolerance`, `max_step`
/// and `smoothing`, version 4 the `normals` section and the stages' `head_smoothing`, version
/// 9 the planar deformer's centroid region (nothing else: version 8 blobs load as they are),
/// version 12 the stages' `refit_cutoff`;
/// blobs older than [`crate::records::OLDEST_VERSION`] are rejected with
/// [`LoadError::UnsupportedVersion`] (re-bake them).
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
    /// Zero bytes (fewer than [`records::SECTION_ALIGN`]) that start `vertex_rest` at a multiple of
    /// [`records::SECTION_ALIGN`] from the blob's first byte.
    #[serde(borrow)]
    pub vertex_rest_align: Bytes<'a>,
    /// Vertex rest positions: 3 × `i16` LE (Q0.15) per vertex, in the mesh's vertex order.
    #[serde(borrow)]
    pub vertex_rest: Bytes<'a>,
    /// The mesh's triangles and welds, for the deformed normals.
    #[serde(borrow)]
    pub normals: Normals<'a>,
    /// The deformer.
    #[serde(borrow)]
    pub deformer: Deformer<'a>,
    /// Optional capture stages (compensation, fill, retargeting) that turn an actor's raw markers
    /// into this rig's markers at run time.
    #[serde(borrow)]
    pub stages: Option<Stages<'a>>,
}

impl<'a> RigData<'a> {
    /// The counts and shared sections every deformer reads (without the influence count a
    /// loaded [`crate::Rig`] notes once: see `Rig::shared`).
    pub(crate) fn shared(&self) -> Shared<'a> {
        Shared {
            vertices: usize::try_from(self.vertex_count).unwrap_or(usize::MAX),
            markers: usize::from(self.marker_count),
            marker_rest: self.marker_rest.0,
            vertex_rest: self.vertex_rest.0,
            uniform_influences: None,
        }
    }
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

fn validate(d: &RigData<'_>) -> Result<(), LoadError> {
    if !d.space.is_valid() {
        return Err(LoadError::BadSpace);
    }
    let markers = usize::from(d.marker_count);
    if markers == 0 || markers > MAX_MARKERS {
        return Err(LoadError::BadMarkerCount {
            found: d.marker_count,
        });
    }
    let shared = d.shared();
    validate_names(d.marker_names, markers)?;
    expect_len(Section::MarkerRest, d.marker_rest, markers, POSITION_BYTES)?;
    check::alignment(d.vertex_rest_align, Section::VertexRest)?;
    expect_len(
        Section::VertexRest,
        d.vertex_rest,
        shared.vertices,
        REST_BYTES,
    )?;
    d.normals.validate(shared.vertices)?;
    d.deformer.validate(&shared)?;
    if let Some(stages) = &d.stages {
        stages.validate(markers).map_err(LoadError::Stages)?;
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
