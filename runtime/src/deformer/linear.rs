//! The linear deformer: each vertex moves by a weighted sum of at most K marker displacements,
//! its influences stored in pairs so that one dual 16 × 16-bit multiply-add serves two of them
//! (`SMLAD` on a Cortex-M4, `pmaddwd` on x86-64).
//!
//! ```text
//! s[j]   = clamp(m[j] − m_rest[j], ±2^(15+F)) · 2^(15−F),  |s| ≤ 2^30             per marker, axis
//! e      = min(15, max(0, bits − 15)), bits the bit length of the frame's largest |s|  per frame
//! q[j]   = clamp((s[j] + ⌊2^e/2⌋) >> e, ±(2^15 − 1))                               per marker, axis
//! out[v] = rest[v] + (Σ_k w[v,k] · q[idx[v,k]]) >> (15 − e)                        per vertex
//! ```
//!
//! `s` is the clamped displacement in Q8.24 scaled so that the weights' F fractional bits and the
//! final shift no longer depend on F; `q` is `s` in 16 bits with a block exponent `e` shared by
//! the whole frame, the smallest that holds the frame's largest displacement (|s| < 2^(15+e)):
//! rounding can still reach ±2¹⁵ (the clamp takes it back by one).
//!
//! # Why it cannot overflow
//!
//! The loader guarantees that every vertex's weights are `i16` with `Σ_k |w[v,k]| ≤ 2¹⁵ − 1`
//! and F ≤ 14. Then `|Σ w · q| ≤ (2¹⁵ − 1)²  < 2³⁰` for the whole sum and every partial sum:
//! every multiply-add is exact in an `i32`. After the shift the
//! sum is below 2³⁰ in magnitude and the rest position (Q0.15 widened to Q8.24) below 2²⁴: the
//! output fits an `i32` with no saturation. The only saturations are the displacement clamp and
//! the 16-bit clamp of `q`, which moves a rounded ±2¹⁵ (a value within half a step of the top
//! of its exponent's range) by one step.
//!
//! # Precision
//!
//! `q · 2^e` differs from `s` by at most 2^(e−1), or 2^e where the clamp moved it, so the output
//! differs from the exact sum `rest + (Σ w · s + 2¹⁴) >> 15` by at most
//! `Σ|w| · 2^e / 2¹⁵ + 1 ≤ 2^e + 1` Q8.24 units (the final shift truncates, for one Q8.24 unit
//! at most: no rounding term to add per vertex). As `2^e ≤ max|s| / 2¹⁴` when e > 0, that is
//! at most about `2^−14 · Σ|w|/2^F` of the frame's largest marker displacement, typically a
//! quarter of it (rounding errors of both signs): on FaceCap within 4.4e-6 of the diagonal of
//! the f64 evaluation (`demo`). A uniform translation of every marker moves every vertex by the
//! same amount, within that bound.
//!
//! # Pairs
//!
//! A vertex's influences are stored two by two: each pair holds its two weights (`i16`
//! each) and the index of a *marker pair* `(a, b)`. Per frame, each marker pair's table entry
//! holds `q[a]` and `q[b]` side by side for each axis (16-bit lanes `[x_a, x_b, y_a, y_b, z_a,
//! z_b, 0, 0]`), so a pair's three multiply-adds are three dual multiply-adds of its weight word
//! with the entry's words. A vertex with an odd count has one pair whose second weight is zero.
//!
//! Three implementations compute exactly these integers, so their outputs are bit for bit equal:
//!
//! * `portable` (every target but x86-64): one `i32` accumulator per axis, one dual
//!   multiply-add per pair and axis, written so that LLVM's ARM backend emits `SMLAD` where the
//!   target has the DSP extension (a Cortex-M4: three single-cycle `SMLAD` a pair);
//! * `sse2` (x86-64): the accumulators in one 128-bit register; per pair one `pmaddwd` of the
//!   entry by the broadcast weight word and one `paddd`.
//!
//! Cost per frame: per marker a subtraction, a clamp, a shift and a rounding; per derived
//! marker six multiply-adds and four roundings (a projection) or n − 1 additions, three
//! multiplies and three roundings (a mean of n); per marker pair three packings; per influence pair three dual
//! multiply-adds; per vertex one shift and one addition per axis. There is no branch on marker
//! data and no check that can fail: the loader has validated every index, count and bound.
//!
//! # Derived markers
//!
//! A rig may list derived markers after its M markers, marker `M + j` computed each frame from
//! the rig's markers. A record's second byte says which kind it is:
//!
//! * `0`, a **projection**: a source marker's `q` projected on a direction `a` (three `i16` in
//!   Q1.14, `Σ|a_c| ≤ 2¹⁴`), so a vertex can weigh one direction of a marker's motion apart
//!   from the others (the baker uses it for the opening of the mouth near its corners, along
//!   the face's own vertical):
//!
//!   ```text
//!   p        = (Σ_c q[s,c] · a[c] + 2^13) >> 14        |p| ≤ max_c |q[s,c]| ≤ 2^15 − 1
//!   q[M+j,c] = (p · a[c] + 2^13) >> 14                 |q[M+j,c]| ≤ |p|
//!   ```
//!
//!   Since `Σ|a_c| ≤ 2¹⁴`, both sums stay within `(2¹⁵ − 1) · 2¹⁴` in magnitude and the
//!   results within ±(2¹⁵ − 1): no clamp, and the bound above holds as it is. The projection
//!   on a unit vector `u` is `(q·a)a / |a|²` for `a` along `u`; the baker folds the `1 / |a|²`
//!   into the weights. A direction along an axis (`a = 2¹⁴ e_y`) gives that axis of `q`
//!   exactly.
//! * `n` in [2, [`MEAN_MAX_SOURCES`]], a **mean**: of the n markers named by the record's first
//!   byte and its bytes 2 to n (the bytes after them zero), so that a share spread evenly over
//!   n markers takes one of a vertex's K influences (the baker's anchored skin follows the mean
//!   of the head markers, `surface::anchoring`):
//!
//!   ```text
//!   r        = ⌊2^16 / n⌋
//!   q[M+j,c] = ((Σ_i q[s_i,c]) · r + 2^15) >> 16       |Σ_i q| · r ≤ (2^15 − 1) · 2^16
//!   ```
//!
//!   `n · r ≤ 2¹⁶`, so the sum and its rounding stay within an `i32` and the result within
//!   ±(2¹⁵ − 1), with no clamp. It is the mean scaled by `n r / 2¹⁶`: exactly 1 for n = 2
//!   or 4, otherwise within 2⁻¹⁵ of 1 (`1 − 2⁻¹⁶` for n = 3), a relative error below the
//!   16-bit `q`'s own rounding; the weights sum to `2^F` as they do without it.

use serde::{Deserialize, Serialize};

use crate::cost::{Cost, NormalsCost};
use crate::deformer::contract::{
    check, counted_range, DeformerSection, DegenerateTriangles, Shared,
};
use crate::error::{LoadError, Section};
use crate::fixed::{
    linear_displacement_limit, LINEAR_MAX_WEIGHT_FRAC_BITS, LINEAR_WEIGHT_ABS_SUM_MAX,
};
use crate::records::{
    read_position, read_rest, Bytes, DERIVED_MARKER_BYTES, INFLUENCE_PAIR_BYTES,
    MARKER_PAIR_BYTES, MAX_MARKERS, MAX_MARKER_PAIRS, POSITION_BYTES, REST_BYTES,
};

/// The linear deformer's section: every vertex moves by a fixed weighted sum of marker
/// displacements, its influences stored in pairs (layout: [`crate::format::RigData`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct LinearDeformer<'a> {
    /// Fractional bits of the stored weights, in [8, 14].
    pub weight_frac_bits: u8,
    /// Most influences any vertex has (K), in [1, 64]: a vertex has at most K pairs (bakes
    /// write ⌈K/2⌉ unless the rig ran out of marker pairs).
    pub max_influences: u8,
    /// Derived markers ([`DERIVED_MARKER_BYTES`] each), the markers `M, M + 1, …` after the
    /// rig's M, each frame computed from the rig's markers (module docs): a projection (a
    /// source marker, a zero byte and a direction, 3 × `i16` LE in Q1.14 with `Σ|a_c| ≤
    /// 2¹⁴`), so that a vertex can weigh one direction of a marker's motion differently from
    /// the others; or a mean (its first source, its count n in [2, [`MEAN_MAX_SOURCES`]],
    /// its other n − 1 sources, zero bytes), so that a share spread evenly over n markers
    /// takes one influence.
    #[serde(borrow)]
    pub derived_markers: Bytes<'a>,
    /// The marker pairs the influence pairs name: [`MARKER_PAIR_BYTES`] each (two `u8` marker
    /// indices), at most [`MAX_MARKER_PAIRS`].
    #[serde(borrow)]
    pub marker_pairs: Bytes<'a>,
    /// Per vertex: how many influence pairs it has (`u8` each).
    #[serde(borrow)]
    pub pair_counts: Bytes<'a>,
    /// Zero bytes (fewer than [`crate::records::SECTION_ALIGN`]) that start `pairs` at a
    /// multiple of it from the blob's first byte.
    #[serde(borrow)]
    pub pairs_align: Bytes<'a>,
    /// The influence pairs, vertex after vertex ([`INFLUENCE_PAIR_BYTES`] each): a vertex with
    /// n pairs stores its n weight pairs (2 × `i16` LE), then its n marker pair indices (`u16`
    /// LE).
    #[serde(borrow)]
    pub pairs: Bytes<'a>,
}

/// Largest magnitude of a 16-bit displacement `q` (and of a weight).
const Q_MAX: i32 = i16::MAX as i32;
/// Fractional bits of every weighted sum of scaled displacements at e = 0: the largest shift.
const SUM_SHIFT: u32 = LINEAR_MAX_WEIGHT_FRAC_BITS as u32 + 1;

impl<'a> LinearDeformer<'a> {
    /// The section for vertices `first .. first + len` only (see [`super::Deformer::vertex_range`]).
    pub(crate) fn vertex_range(&self, first: usize, len: usize, uniform: Option<u8>) -> Self {
        let (counts, pairs) = counted_range(
            self.pair_counts.0,
            self.pairs.0,
            INFLUENCE_PAIR_BYTES,
            first,
            len,
            uniform,
        );
        Self {
            pair_counts: Bytes(counts),
            pairs: Bytes(pairs),
            ..*self
        }
    }

    /// Each vertex's influences in order, as `(marker, weight)` (the second influence of a pair
    /// included when its weight is zero): what the pairs encode, for tools and references.
    /// Indices out of range (an unvalidated section) read as marker 0.
    #[cfg_attr(not(any(feature = "format", test)), allow(dead_code))]
    pub fn vertex_influences(&self) -> impl Iterator<Item = impl Iterator<Item = (u8, i16)> + 'a> + 'a {
        let table = self.marker_pairs.0;
        per_vertex(self.pair_counts.0, self.pairs.0).map(move |words| {
            let (weights, ids) = split_pairs(words);
            weights
                .chunks_exact(4)
                .zip(ids.chunks_exact(2))
                .flat_map(move |(w, id)| {
                    let [wa, wb] = read_weights(w);
                    let [a, b] = marker_pair(table, read_u16(id));
                    [(a, wa), (b, wb)]
                })
        })
    }

    /// The derived markers in order: derived marker `j` is marker `M + j` of the influences
    /// ([`Self::vertex_influences`]).
    pub fn derived(&self) -> impl Iterator<Item = DerivedMarker> + 'a {
        self.derived_markers
            .0
            .chunks_exact(DERIVED_MARKER_BYTES)
            .map(DerivedMarker::read)
    }
}

/// Most markers a derived mean may have: its record holds them in its first byte and its last
/// six.
pub const MEAN_MAX_SOURCES: usize = DERIVED_MARKER_BYTES - 1;

/// A derived marker (module docs), as its record encodes it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DerivedMarker {
    /// Its source's displacement projected on `direction` (Q1.14): `(q·a)a`.
    Projection {
        /// The source marker.
        source: u8,
        /// The direction `a`, Q1.14, `1 ≤ Σ|a_c| ≤ 2¹⁴` in a validated rig.
        direction: [i16; 3],
    },
    /// The mean of `sources[..count]`, scaled by `count · ⌊2¹⁶/count⌋ / 2¹⁶`.
    Mean {
        /// The source markers (those past `count` are zero).
        sources: [u8; MEAN_MAX_SOURCES],
        /// How many sources, in [2, [`MEAN_MAX_SOURCES`]] in a validated rig.
        count: u8,
    },
}

impl DerivedMarker {
    /// The marker a record (at least [`DERIVED_MARKER_BYTES`] long, else its missing bytes read
    /// as zero) encodes.
    fn read(d: &[u8]) -> Self {
        let byte = |at: usize| d.get(at).copied().unwrap_or(0);
        match byte(1) {
            0 => Self::Projection {
                source: byte(0),
                direction: read_direction(d),
            },
            count => Self::Mean {
                sources: core::array::from_fn(|i| if i == 0 { byte(0) } else { byte(i + 1) }),
                count,
            },
        }
    }

    /// Its record (what the baker writes).
    #[cfg_attr(not(any(feature = "format", test)), allow(dead_code))]
    pub fn record(&self) -> [u8; DERIVED_MARKER_BYTES] {
        let mut r = [0u8; DERIVED_MARKER_BYTES];
        match *self {
            Self::Projection { source, direction } => {
                r[0] = source;
                for (c, a) in direction.iter().enumerate() {
                    r[2 + 2 * c..4 + 2 * c].copy_from_slice(&a.to_le_bytes());
                }
            }
            Self::Mean { sources, count } => {
                r[0] = sources[0];
                r[1] = count;
                r[2..].copy_from_slice(&sources[1..]);
            }
        }
        r
    }

    /// What a mean of `count` markers multiplies their sum by, in Q0.16: `⌊2¹⁶/count⌋`.
    pub fn mean_factor(count: u8) -> i32 {
        MEAN_ONE / i32::from(count.max(2))
    }

    /// Whether a rig with `markers` markers may hold it: its sources below `markers`, a
    /// projection's direction with `1 ≤ Σ|a_c| ≤ 2¹⁴`, a mean's count in [2,
    /// [`MEAN_MAX_SOURCES`]] with zeros past its sources.
    fn valid(&self, markers: usize) -> bool {
        match *self {
            Self::Projection { source, direction } => {
                let norm: i32 = direction.iter().map(|&a| i32::from(a).abs()).sum();
                usize::from(source) < markers && (1..=DIRECTION_ONE).contains(&norm)
            }
            Self::Mean { sources, count } => {
                let n = usize::from(count);
                (2..=MEAN_MAX_SOURCES).contains(&n)
                    && sources[..n].iter().all(|&s| usize::from(s) < markers)
                    && sources[n..].iter().all(|&s| s == 0)
            }
        }
    }
}

/// The two markers of marker pair `p` of `table` (`[0, 0]` out of range).
#[cfg_attr(not(any(feature = "format", test)), allow(dead_code))]
fn marker_pair(table: &[u8], p: u16) -> [u8; 2] {
    let at = usize::from(p) * MARKER_PAIR_BYTES;
    match table.get(at..at + MARKER_PAIR_BYTES) {
        Some(&[a, b]) => [a, b],
        _ => [0, 0],
    }
}

/// A weight pair (2 × `i16` LE) from a four-byte chunk.
#[inline(always)]
fn read_weights(b: &[u8]) -> [i16; 2] {
    let b: [u8; 4] = b.try_into().unwrap_or([0; 4]);
    [i16::from_le_bytes([b[0], b[1]]), i16::from_le_bytes([b[2], b[3]])]
}

/// A derived marker's direction (3 × `i16` LE after its source and zero byte).
#[inline(always)]
fn read_direction(d: &[u8]) -> [i16; 3] {
    [2, 4, 6].map(|at| match d.get(at..at + 2) {
        Some(&[lo, hi]) => i16::from_le_bytes([lo, hi]),
        _ => 0,
    })
}

/// `1.0` in a derived marker's Q1.14 direction, and the most `Σ|a_c|` may be.
pub const DIRECTION_ONE: i32 = 1 << 14;

/// `1.0` in a derived mean's Q0.16 factor ([`DerivedMarker::mean_factor`]).
pub const MEAN_ONE: i32 = 1 << 16;

/// A `u16` LE from a two-byte chunk.
#[inline(always)]
fn read_u16(b: &[u8]) -> u16 {
    u16::from_le_bytes(b.try_into().unwrap_or([0; 2]))
}

/// A vertex's pair bytes split into its weight pairs and its marker pair indices.
#[inline(always)]
fn split_pairs(words: &[u8]) -> (&[u8], &[u8]) {
    words.split_at(words.len() / INFLUENCE_PAIR_BYTES * 4)
}

impl DeformerSection for LinearDeformer<'_> {
    fn validate(&self, rig: &Shared<'_>) -> Result<(), LoadError> {
        check::max_influences(self.max_influences)?;
        check::weight_format(self.weight_frac_bits, LINEAR_MAX_WEIGHT_FRAC_BITS)?;
        let derived = self.derived_markers.0;
        if !derived.len().is_multiple_of(DERIVED_MARKER_BYTES) {
            return Err(LoadError::SectionLength {
                section: Section::DerivedMarkers,
                expected: derived.len() / DERIVED_MARKER_BYTES * DERIVED_MARKER_BYTES,
                found: derived.len(),
            });
        }
        for (index, d) in derived.chunks_exact(DERIVED_MARKER_BYTES).enumerate() {
            if !DerivedMarker::read(d).valid(rig.markers) || rig.markers + index >= MAX_MARKERS {
                return Err(LoadError::BadDerivedMarker { derived: index });
            }
        }
        // Marker pairs name the rig's markers and the derived ones after them.
        let all_markers = rig.markers + derived.len() / DERIVED_MARKER_BYTES;
        if !self.marker_pairs.0.len().is_multiple_of(MARKER_PAIR_BYTES) {
            return Err(LoadError::SectionLength {
                section: Section::MarkerPairs,
                expected: self.marker_pairs.0.len() / MARKER_PAIR_BYTES * MARKER_PAIR_BYTES,
                found: self.marker_pairs.0.len(),
            });
        }
        let marker_pairs = self.marker_pairs.0.len() / MARKER_PAIR_BYTES;
        if marker_pairs > MAX_MARKER_PAIRS {
            return Err(LoadError::TooManyMarkerPairs {
                found: marker_pairs,
            });
        }
        for (pair, markers) in self.marker_pairs.0.chunks_exact(MARKER_PAIR_BYTES).enumerate() {
            if let Some(&marker) = markers.iter().find(|&&m| usize::from(m) >= all_markers) {
                return Err(LoadError::PairMarkerOutOfRange { pair, marker });
            }
        }
        check::alignment(self.pairs_align, Section::Pairs)?;
        check::counted_records(
            self.pair_counts,
            self.pairs,
            rig.vertices,
            INFLUENCE_PAIR_BYTES,
            [Section::PairCounts, Section::Pairs],
        )?;
        let one = 1i64 << self.weight_frac_bits;
        // Bakes give a vertex ⌈K/2⌉ pairs, more where a dense rig ran out of marker pairs and
        // some influences went alone (with a zero partner): never more than K.
        let most_pairs = self.max_influences;
        let vertices = per_vertex(self.pair_counts.0, self.pairs.0);
        for (vertex, (&count, words)) in self.pair_counts.0.iter().zip(vertices).enumerate() {
            if count > most_pairs {
                return Err(LoadError::TooManyInfluencePairs { vertex, count });
            }
            let (weights, ids) = split_pairs(words);
            if let Some(pair) = ids
                .chunks_exact(2)
                .map(read_u16)
                .find(|&p| usize::from(p) >= marker_pairs)
            {
                return Err(LoadError::PairIndexOutOfRange { vertex, pair });
            }
            let (mut sum, mut abs_sum) = (0i64, 0i64);
            for w in weights.chunks_exact(4).flat_map(read_weights) {
                sum += i64::from(w);
                abs_sum += i64::from(w).abs();
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

    fn cost(&self, rig: &Shared<'_>) -> Cost {
        let (v, m) = (rig.vertices, rig.markers);
        let pairs = self.pairs.0.len() / INFLUENCE_PAIR_BYTES;
        Cost {
            vertices: v,
            markers: m,
            influences: 2 * pairs,
            max_influences: usize::from(self.max_influences),
            coefficient_rows: 0,
            multiply_adds: 3 * 2 * pairs
                + self
                    .derived()
                    .map(|d| match d {
                        DerivedMarker::Projection { .. } => 6,
                        DerivedMarker::Mean { .. } => 3,
                    })
                    .sum::<usize>(),
            subtractions: 3 * m,
            narrowings: 3 * v,
            scratch_bytes: SCRATCH_BYTES,
            frame_builds: 0,
            normalisations: 0,
            normals: NormalsCost::default(),
        }
    }

    fn weight_frac_bits(&self) -> u8 {
        self.weight_frac_bits
    }

    fn deform(
        &self,
        rig: &Shared<'_>,
        markers: &[[i32; 3]],
        out: &mut [[i32; 3]],
    ) -> DegenerateTriangles {
        let mut table = Prepared::EMPTY;
        self.prepare(rig, markers, &mut table);
        deform_prepared(&table, self.sections(rig), out);
        DegenerateTriangles::default()
    }
}

impl LinearDeformer<'_> {
    /// The per-frame marker work of [`DeformerSection::deform`] for `markers` (one per rig
    /// marker, the caller checked) into `table`, for [`Self::deform_prepared`]. In place: the
    /// table is 6 to 8 KB, and a copy costs more than filling it.
    pub(crate) fn prepare(&self, rig: &Shared<'_>, markers: &[[i32; 3]], table: &mut Prepared) {
        let q = quantised(markers, rig.marker_rest, self.weight_frac_bits, self.derived_markers.0);
        table.fill(&q, self.marker_pairs.0);
    }

    /// The vertices of `rig` into `out` (one entry each, the caller checked) from this frame's
    /// `prepared` work: the integers [`DeformerSection::deform`] writes.
    pub(crate) fn deform_prepared(&self, rig: &Shared<'_>, prepared: &Prepared, out: &mut [[i32; 3]]) {
        deform_prepared(prepared, self.sections(rig), out);
    }

    /// The per-vertex sections of `rig` (validated at load, including Σ|w| ≤ 2¹⁵ − 1 per vertex,
    /// F ≤ 14 and every marker pair index) as the per-frame loops read them.
    fn sections<'s>(&'s self, rig: &Shared<'s>) -> Sections<'s> {
        Sections {
            rest: rig.vertex_rest,
            counts: self.pair_counts.0,
            pairs: self.pairs.0,
            uniform: rig.uniform_influences,
        }
    }
}

/// A frame's markers as 16-bit displacements: `q` per marker index (later entries zero) and the
/// block exponent e (module docs).
pub(crate) struct Quantised {
    /// `q[j]` for axes x, y, z.
    q: [[i16; 3]; MAX_MARKERS],
    /// The block exponent, in [0, 15].
    exponent: u32,
}

/// The scaled, clamped displacement `s` of every marker (module docs), in marker order.
fn scaled<'m>(
    markers: &'m [[i32; 3]],
    marker_rest: &'m [u8],
    weight_frac_bits: u8,
) -> impl Iterator<Item = [i32; 3]> + 'm {
    let limit = i64::from(linear_displacement_limit(u32::from(weight_frac_bits)));
    // F ≤ 14 (validated), so the scale is a left shift by at least one bit.
    let scale = SUM_SHIFT - u32::from(weight_frac_bits);
    markers
        .iter()
        .zip(marker_rest.chunks_exact(POSITION_BYTES))
        .map(move |(m, r)| {
            let rest = read_position(r);
            // In i64 the difference is exact; the clamp bounds it by ±2^(15+F) (so it fits an
            // i32), the scale by ±2^30. `max`/`min` rather than `clamp`, which asserts that its
            // bounds are ordered: a panic path.
            [0, 1, 2].map(|c| {
                let difference = i64::from(m[c]) - i64::from(rest[c]);
                (difference.max(-limit).min(limit) as i32) << scale
            })
        })
}

/// The frame's 16-bit displacements (module docs): two passes over the markers, one for the
/// exponent, one to round. Neither branches on the data (the host's instruction counts are the
/// same for every frame): the exponent comes from the bit length of all the magnitudes ORed
/// together (the bit length of the largest), and the only rounded values past ±(2¹⁵ − 1) are
/// ±2¹⁵, brought in by one comparison each.
/// `derived` (validated) are the rig's derived markers, appended after `markers`
/// ([`Quantised::derive`]).
pub(crate) fn quantised(
    markers: &[[i32; 3]],
    marker_rest: &[u8],
    weight_frac_bits: u8,
    derived: &[u8],
) -> Quantised {
    let bits = scaled(markers, marker_rest, weight_frac_bits)
        .flatten()
        .fold(0u32, |all, s| all | s.unsigned_abs());
    // |s| ≤ 2^30: at most 31 bits, so e ≤ 16, capped at 15.
    let exponent = (u32::BITS - bits.leading_zeros()).saturating_sub(15).min(15);
    let half = (1i32 << exponent) >> 1;
    let mut q = [[0i16; 3]; MAX_MARKERS];
    for (q, s) in q.iter_mut().zip(scaled(markers, marker_rest, weight_frac_bits)) {
        // |s| < 2^(15+e) (or ≤ 2^30 at e = 15) and half ≤ 2^14: the sum fits an i32, and the
        // rounded value lies in [−2^15, 2^15].
        *q = s.map(|s| {
            let v = (s + half) >> exponent;
            (v + i32::from(v < -Q_MAX) - i32::from(v > Q_MAX)) as i16
        });
    }
    let mut quantised = Quantised { q, exponent };
    quantised.derive(markers.len(), derived);
    quantised
}

impl Quantised {
    /// Append the `derived` markers (validated: [`DerivedMarker`]'s rules, `markers` + their
    /// count ≤ [`MAX_MARKERS`]) after the rig's `markers` (module docs): a projection in six
    /// multiply-adds and four roundings, a mean of n in n − 1 additions, three multiplies and
    /// three roundings; no branch on the markers' data.
    fn derive(&mut self, markers: usize, derived: &[u8]) {
        let (sources, targets) = self.q.split_at_mut(markers.min(MAX_MARKERS));
        let q = |s: u8| sources.get(usize::from(s)).copied().unwrap_or([0; 3]).map(i32::from);
        let half = DIRECTION_ONE >> 1;
        for (target, d) in targets.iter_mut().zip(derived.chunks_exact(DERIVED_MARKER_BYTES)) {
            *target = match DerivedMarker::read(d) {
                DerivedMarker::Projection { source, direction } => {
                    let (q, a) = (q(source), direction.map(i32::from));
                    // |q_c| ≤ 2^15 − 1 and Σ|a_c| ≤ 2^14: |Σ q_c a_c| + 2^13 < 2^29 + 2^13.
                    let along = (0..3).map(|c| q[c] * a[c]).sum::<i32>() + half;
                    let p = along >> 14;
                    // |p| ≤ 2^15 − 1 and |a_c| ≤ 2^14: each result is within ±(2^15 − 1).
                    a.map(|a| ((p * a + half) >> 14) as i16)
                }
                DerivedMarker::Mean { sources, count } => {
                    let sum = sources[..usize::from(count).min(MEAN_MAX_SOURCES)]
                        .iter()
                        .fold([0i32; 3], |sum, &s| {
                            let q = q(s);
                            [0, 1, 2].map(|c| sum[c] + q[c])
                        });
                    let r = DerivedMarker::mean_factor(count);
                    // |Σ q| ≤ n (2^15 − 1) and n r ≤ 2^16: |Σ q · r| + 2^15 < 2^31, and the
                    // rounded result within ±(2^15 − 1).
                    sum.map(|s| ((s * r + (MEAN_ONE >> 1)) >> 16) as i16)
                }
            };
        }
    }
}

/// One marker pair's table entry: three words x, y, z (and a zero word), each with marker a's
/// value in its low half and marker b's in its high half (16-bit lanes `[x_a, x_b, y_a, y_b,
/// z_a, z_b, 0, 0]` in memory): one aligned 128-bit load on x86-64.
#[cfg(not(facebake_smlad))]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(C, align(16))]
pub(crate) struct Entry(pub(crate) [u32; 4]);

/// The linear deformer's per-frame data (in a [`crate::FrameTable`], or on the stack): one
/// [`Entry`] per marker pair, and the frame's final shift.
#[cfg(not(facebake_smlad))]
#[derive(Clone, Copy, Debug)]
pub(crate) struct Prepared {
    /// One entry per marker pair of the rig (the slots past them are never read).
    entries: [Entry; MAX_MARKER_PAIRS],
    /// `15 − e`: the per-vertex shift, in [0, 15].
    shift: u32,
}

/// The linear deformer's per-frame data (in a [`crate::FrameTable`], or on the stack): per axis,
/// one word per marker pair (marker a's value in the low half, b's in the high half), and the
/// frame's final shift. One array per axis, so that the Cortex-M4 kernel reads a pair's three
/// words with three register-offset loads from three bases, without an address computation.
#[cfg(facebake_smlad)]
#[derive(Clone, Copy, Debug)]
#[repr(C)]
pub(crate) struct Prepared {
    /// Per axis x, y, z: one word per marker pair of the rig (the slots past them are never
    /// read).
    axes: [[u32; MAX_MARKER_PAIRS]; 3],
    /// `15 − e`: the per-vertex shift, in [0, 15].
    shift: u32,
}

impl Prepared {
    /// A table of zeros, to [`Self::fill`].
    #[cfg(not(facebake_smlad))]
    pub(crate) const EMPTY: Self = Self {
        entries: [Entry([0; 4]); MAX_MARKER_PAIRS],
        shift: 0,
    };
    /// A table of zeros, to [`Self::fill`].
    #[cfg(facebake_smlad)]
    pub(crate) const EMPTY: Self = Self {
        axes: [[0; MAX_MARKER_PAIRS]; 3],
        shift: 0,
    };

    /// This frame's table from its quantised displacements `q`, for the rig's `marker_pairs`
    /// (at most [`MAX_MARKER_PAIRS`], validated): the entries past them are left as they were
    /// (no index reads them).
    fn fill(&mut self, q: &Quantised, marker_pairs: &[u8]) {
        self.shift = SUM_SHIFT - q.exponent;
        let pairs = marker_pairs.chunks_exact(MARKER_PAIR_BYTES).map(|pair| {
            // u8 indices into a 256-entry array: in range by construction.
            let [a, b] = [pair[0], pair[1]].map(|m| q.q[usize::from(m)]);
            [0, 1, 2].map(|c| u32::from(a[c] as u16) | u32::from(b[c] as u16) << 16)
        });
        #[cfg(not(facebake_smlad))]
        for (e, words) in self.entries.iter_mut().zip(pairs) {
            *e = Entry([words[0], words[1], words[2], 0]);
        }
        #[cfg(facebake_smlad)]
        {
            let [x, y, z] = &mut self.axes;
            for (((x, y), z), words) in x.iter_mut().zip(y.iter_mut()).zip(z.iter_mut()).zip(pairs) {
                [*x, *y, *z] = words;
            }
        }
    }

    /// The table slot of marker pair `p`: validated below the rig's pair count at load; the
    /// mask keeps the read in the table without a branch whatever the bytes.
    #[inline(always)]
    fn slot(p: u16) -> usize {
        usize::from(p) & (MAX_MARKER_PAIRS - 1)
    }

    /// The words x, y, z of marker pair `p`.
    #[inline(always)]
    fn words(&self, p: u16) -> [u32; 3] {
        let p = Self::slot(p);
        #[cfg(not(facebake_smlad))]
        return [0, 1, 2].map(|c| self.entries[p].0[c]);
        #[cfg(facebake_smlad)]
        return [0, 1, 2].map(|c| self.axes[c][p]);
    }

    /// The entry of marker pair `p`, for the SSE2 path's vector loads.
    #[cfg(all(target_arch = "x86_64", target_feature = "sse2"))]
    #[inline(always)]
    fn entry(&self, p: u16) -> &Entry {
        &self.entries[Self::slot(p)]
    }
}

const _: () = assert!(MAX_MARKER_PAIRS.is_power_of_two());

/// Stack the deformer uses per frame: the 16-bit displacements and the pair table.
pub(crate) const SCRATCH_BYTES: usize =
    core::mem::size_of::<Quantised>() + core::mem::size_of::<Prepared>();

/// Every vertex of `rig` from this frame's [`Prepared`] table.
fn deform_prepared(p: &Prepared, rig: Sections<'_>, out: &mut [[i32; 3]]) {
    #[cfg(all(target_arch = "x86_64", target_feature = "sse2"))]
    sse2::deform_checked(p, rig, out);
    #[cfg(not(all(target_arch = "x86_64", target_feature = "sse2")))]
    portable::deform(p, rig, out);
}

/// A linear rig's per-vertex sections, validated at load.
#[derive(Clone, Copy)]
pub(crate) struct Sections<'a> {
    /// Vertex rest positions, [`REST_BYTES`] a vertex.
    rest: &'a [u8],
    /// Influence pairs per vertex, one byte a vertex.
    counts: &'a [u8],
    /// The influence pairs, [`INFLUENCE_PAIR_BYTES`] each, vertex after vertex.
    pairs: &'a [u8],
    /// The pair count every vertex has, when all have the same ([`Shared::uniform_influences`]).
    uniform: Option<u8>,
}

impl<'a> Sections<'a> {
    /// Call `f(pair bytes, rest bytes, output slot)` for every vertex in turn.
    ///
    /// Bakes give every vertex exactly ⌈K/2⌉ pairs. When a rig's counts are all 2 or all 4 (K =
    /// 4 or 8; a property of the rig, never of the markers), each vertex's bytes come as a
    /// fixed-size chunk, so an inlined `f` compiles for exactly that count.
    #[inline(always)]
    fn for_each_vertex(self, out: &mut [[i32; 3]], mut f: impl FnMut(&[u8], &[u8], &mut [i32; 3])) {
        match self.common_count() {
            Some(2) => self.uniform::<{ 2 * INFLUENCE_PAIR_BYTES }>(out, &mut f),
            Some(4) => self.uniform::<{ 4 * INFLUENCE_PAIR_BYTES }>(out, &mut f),
            _ => {
                for (o, r, words) in self.vertices(out) {
                    f(words, r, o);
                }
            }
        }
    }

    /// [`Self::for_each_vertex`] when every vertex has `N / INFLUENCE_PAIR_BYTES` pairs.
    #[inline(always)]
    fn uniform<const N: usize>(
        self,
        out: &mut [[i32; 3]],
        f: &mut impl FnMut(&[u8], &[u8], &mut [i32; 3]),
    ) {
        for (o, r, words) in self.uniform_vertices(out, N / INFLUENCE_PAIR_BYTES) {
            let words: &[u8; N] = words.try_into().unwrap_or(&[0; N]);
            f(words, r, o);
        }
    }

    /// The number of pairs of every vertex, if all have the same (as bakes write them) and it
    /// is not zero: found once when the rig was loaded, not scanned per frame.
    fn common_count(self) -> Option<usize> {
        self.uniform.map(usize::from)
    }

    /// [`Self::vertices`] when every vertex has `n ≥ 1` pairs ([`Self::common_count`]).
    fn uniform_vertices<'o>(
        self,
        out: &'o mut [[i32; 3]],
        n: usize,
    ) -> impl Iterator<Item = (&'o mut [i32; 3], &'a [u8], &'a [u8])> + use<'a, 'o> {
        out.iter_mut()
            .zip(self.rest.chunks_exact(REST_BYTES))
            .zip(self.pairs.chunks_exact(n * INFLUENCE_PAIR_BYTES))
            .map(|((o, r), words)| (o, r, words))
    }

    /// Each output slot with its vertex's rest bytes and pair bytes.
    fn vertices<'o>(
        self,
        out: &'o mut [[i32; 3]],
    ) -> impl Iterator<Item = (&'o mut [i32; 3], &'a [u8], &'a [u8])> + use<'a, 'o> {
        out.iter_mut()
            .zip(self.rest.chunks_exact(REST_BYTES))
            .zip(per_vertex(self.counts, self.pairs))
            .map(|((o, r), words)| (o, r, words))
    }
}

/// The pair bytes of each vertex in turn.
///
/// The loader checked that the counts add up to the section, so the fallback (an empty slice)
/// is never taken on a loaded rig.
fn per_vertex<'a>(counts: &'a [u8], pairs: &'a [u8]) -> impl Iterator<Item = &'a [u8]> + 'a {
    let mut words = pairs;
    counts.iter().map(move |&count| {
        let (mine, tail) = words
            .split_at_checked(INFLUENCE_PAIR_BYTES * usize::from(count))
            .unwrap_or((&[], &[]));
        words = tail;
        mine
    })
}

/// The reference implementation, used on every target without SSE2 (and tested against the SSE2
/// one on x86-64).
#[cfg_attr(all(target_arch = "x86_64", target_feature = "sse2"), allow(dead_code))]
pub(crate) mod portable {
    use super::*;

    /// Every vertex of `rig` from the frame's table `t`.
    ///
    /// Not inlined: `Rig::deform` and `Rig::deform_chunk` share this one copy of the loop.
    #[inline(never)]
    pub(crate) fn deform(t: &Prepared, rig: Sections<'_>, out: &mut [[i32; 3]]) {
        #[cfg(facebake_smlad)]
        match rig.common_count() {
            Some(2) => return m4::two_pairs(t, rig, out),
            Some(4) => return m4::four_pairs(t, rig, out),
            _ => {}
        }
        rig.for_each_vertex(out, |words, r, o| vertex(t, words, r, o));
    }

    /// `acc + a.lo · b.lo + a.hi · b.hi`, the halves of each word signed 16-bit: exact within
    /// the module's bounds (neither the products nor the sums can overflow).
    #[cfg(not(facebake_smlad))]
    #[inline(always)]
    fn dual_mul_add(acc: i32, a: u32, b: u32) -> i32 {
        let lo = i32::from(a as i16) * i32::from(b as i16);
        let hi = i32::from((a >> 16) as i16) * i32::from((b >> 16) as i16);
        acc.wrapping_add(lo).wrapping_add(hi)
    }

    /// `acc + a.lo · b.lo + a.hi · b.hi` in one `SMLAD` (Cortex-M4/M7: a single cycle), which
    /// LLVM does not form from the portable expression (it emits an `SMLABB` and an `SMLATB`).
    /// The same integer: `SMLAD` multiplies the signed halves and adds both products and the
    /// accumulator, exactly, as long as the sum fits 32 bits (the module's bounds).
    #[cfg(facebake_smlad)]
    #[inline(always)]
    #[allow(unsafe_code)]
    fn dual_mul_add(acc: i32, a: u32, b: u32) -> i32 {
        let sum: i32;
        // SAFETY: one register-only instruction: it reads three registers and writes one,
        // touches no memory and no stack; it may only set the sticky Q flag on an overflow,
        // which the module's bounds rule out (and nothing reads Q).
        unsafe {
            core::arch::asm!(
                "smlad {sum}, {a}, {b}, {acc}",
                sum = lateout(reg) sum,
                a = in(reg) a,
                b = in(reg) b,
                acc = in(reg) acc,
                options(pure, nomem, nostack),
            );
        }
        sum
    }

    /// One vertex: its pair bytes and rest bytes in, its position out.
    #[inline(always)]
    fn vertex(t: &Prepared, words: &[u8], r: &[u8], o: &mut [i32; 3]) {
        let (weights, ids) = split_pairs(words);
        let mut acc = [0i32; 3];
        for (w, id) in weights.chunks_exact(4).zip(ids.chunks_exact(2)) {
            let w = u32::from_le_bytes(w.try_into().unwrap_or([0; 4]));
            for (a, e) in acc.iter_mut().zip(t.words(read_u16(id))) {
                *a = dual_mul_add(*a, w, e);
            }
        }
        // Below 2^30 in magnitude after the shift, and below 2^31 with the rest position, by the
        // module's bounds: the addition is exact (wrapping is never reached, and cannot panic).
        let rest = read_rest(r);
        *o = [0, 1, 2].map(|c| rest[c].wrapping_add(acc[c] >> t.shift));
    }
}

/// The Cortex-M4/M7 kernels for rigs whose vertices all have two or four pairs (K = 4 or 8, what
/// bakes write): the whole vertex loop in Thumb-2 assembly, four vertices a pass, computing
/// exactly the integers of [`portable`] (tested against the exact reference on ARMv7 under
/// qemu-arm, and by the firmware's golden hashes on the Cortex-M4 under QEMU).
///
/// LLVM compiles the portable loop for four pairs into about 90 instructions a vertex with a
/// dozen spills to the stack. The loop needs every register: three section pointers, three
/// table bases (one per axis), three accumulators, the weight word, two pair indices (the next
/// pair's is loaded while this one's words are), two loaded words; the shift and the loop end
/// live on the stack. Per pair: `LDR` weights, three register-offset `LDR` (x, y, z of the
/// pair, the index register reused for z), `LDRH` the next pair's index, three `SMLAD` (the
/// first pair `SMUAD`): one run of loads that the Cortex-M4 pipelines, 9 cycles a pair by its
/// TRM. Per vertex: `LDRH` its first index, three `LDRSH` rest and the shift, three `ASR` and
/// three `ADD` (the rest widened by the shifted operand), three `STR`; per pass the loop end's
/// `LDR`, `CMP`, `BNE`.
#[cfg(facebake_smlad)]
mod m4 {
    use super::*;

    /// One vertex loop with `$stride` bytes of pairs a vertex, its lines in `$vertex`.
    macro_rules! kernel {
        ($name:ident, $n:literal, $stride:literal, [$($vertex:expr),* $(,)?]) => {
            /// Every vertex of `rig` (each with
            #[doc = stringify!($n)]
            /// pairs) from the frame's table `t`.
            #[allow(unsafe_code)]
            pub(super) fn $name(t: &Prepared, rig: Sections<'_>, out: &mut [[i32; 3]]) {
                let vertices = out
                    .len()
                    .min(rig.rest.len() / REST_BYTES)
                    .min(rig.pairs.len() / $stride);
                if vertices == 0 {
                    return;
                }
                let out = &mut out[..vertices];
                let end = out.as_mut_ptr_range().end;
                // SAFETY: the loop writes `vertices` ≥ 1 outputs, four a pass (`vertices % 4` in
                // the first pass when that is not zero, which enters at a later copy), and for
                // each reads REST_BYTES of `rig.rest` and `$stride` bytes of `rig.pairs`, its own
                // (no index is read ahead past the vertex): all in bounds by the minimum above.
                // The table reads are at the pair indices of the rig, which the loader
                // validated below its marker pair count, itself at most MAX_MARKER_PAIRS: in
                // bounds of each axis array. Unaligned section bytes are fine for
                // LDR/LDRH/LDRSH on ARMv7E-M (the baker aligns them, for speed). r6, r7 and r9
                // (reserved by LLVM), r12 (the shift, read back from the stack) and lr (the loop
                // end) are pushed and popped around the loop; every other register written is
                // an output or a clobber. The flags are clobbered (`cmp`).
                unsafe {
                    core::arch::asm!(
                        "push {{r6, r7, r9, r12, lr}}",
                        "cmp r8, #1",
                        "beq 5f",
                        "cmp r8, #2",
                        "beq 4f",
                        "cmp r8, #3",
                        "beq 3f",
                        "2:",
                        $($vertex,)*
                        "3:",
                        $($vertex,)*
                        "4:",
                        $($vertex,)*
                        "5:",
                        $($vertex,)*
                        "ldr r9, [sp, #16]",
                        "cmp r2, r9",
                        "bne 2b",
                        "pop {{r6, r7, r9, r12, lr}}",
                        inout("r0") rig.rest.as_ptr() => _,
                        inout("r1") rig.pairs.as_ptr() => _,
                        inout("r2") out.as_mut_ptr() => _,
                        in("r3") t.axes[0].as_ptr(),
                        in("r4") t.axes[1].as_ptr(),
                        in("r5") t.axes[2].as_ptr(),
                        inout("r8") vertices % 4 => _,
                        out("r10") _,
                        out("r11") _,
                        in("r12") t.shift,
                        in("lr") end,
                    );
                }
            }
        };
    }

    /// The first pair: its index (at `$index`), its weights (advancing the pointer past the
    /// vertex by `$stride`), its three words, the second pair's index (at `$next`, from the
    /// advanced pointer) into r12; the products by `SMUAD`.
    macro_rules! first_pair {
        ($index:literal, $stride:literal, $next:literal) => {
            concat!(
                "ldrh r10, [r1, #", $index, "]\n",
                "ldr r9, [r1], #", $stride, "\n",
                "ldr r11, [r3, r10, lsl #2]\n",
                "ldr lr, [r4, r10, lsl #2]\n",
                "ldr r10, [r5, r10, lsl #2]\n",
                "ldrh r12, [r1, #", $next, "]\n",
                "smuad r6, r9, r11\n",
                "smuad r7, r9, lr\n",
                "smuad r8, r9, r10",
            )
        };
    }

    /// A later pair whose index is in `$i`: its weights at `$w`, its three words (z into `$i`),
    /// the next pair's index at `$next` into `$j` (none for the last pair); the products added
    /// by `SMLAD`.
    macro_rules! pair {
        ($w:literal, $i:literal, $j:literal, $next:literal) => {
            concat!(
                "ldr r9, [r1, #", $w, "]\n",
                "ldr r11, [r3, ", $i, ", lsl #2]\n",
                "ldr lr, [r4, ", $i, ", lsl #2]\n",
                "ldr ", $i, ", [r5, ", $i, ", lsl #2]\n",
                "ldrh ", $j, ", [r1, #", $next, "]\n",
                "smlad r6, r9, r11, r6\n",
                "smlad r7, r9, lr, r7\n",
                "smlad r8, r9, ", $i, ", r8",
            )
        };
        ($w:literal, $i:literal) => {
            concat!(
                "ldr r9, [r1, #", $w, "]\n",
                "ldr r11, [r3, ", $i, ", lsl #2]\n",
                "ldr lr, [r4, ", $i, ", lsl #2]\n",
                "ldr ", $i, ", [r5, ", $i, ", lsl #2]\n",
                "smlad r6, r9, r11, r6\n",
                "smlad r7, r9, lr, r7\n",
                "smlad r8, r9, ", $i, ", r8",
            )
        };
    }

    /// A vertex's last lines: its rest position (x, y, z; the pointer advanced) and the shift
    /// (from the stack), each axis's sum shifted and added to the widened rest, the three
    /// outputs stored (the pointer advanced).
    macro_rules! vertex_out {
        () => {
            concat!(
                "ldrsh r11, [r0, #2]\n",
                "ldrsh lr, [r0, #4]\n",
                "ldrsh r10, [r0], #6\n",
                "ldr r9, [sp, #12]\n",
                "asr r6, r6, r9\n",
                "add r6, r6, r10, lsl #9\n",
                "asr r7, r7, r9\n",
                "add r7, r7, r11, lsl #9\n",
                "asr r8, r8, r9\n",
                "add r8, r8, lr, lsl #9\n",
                "str r7, [r2, #4]\n",
                "str r8, [r2, #8]\n",
                "str r6, [r2], #12",
            )
        };
    }

    // Two pairs, 12 bytes: weights at 0 and 4, indices at 8 and 10 (−4 and −2 once advanced).
    kernel!(
        two_pairs,
        2,
        12,
        [concat!(first_pair!(8, 12, -2), "\n", pair!(-8, "r12"), "\n", vertex_out!())]
    );
    // Four pairs, 24 bytes: weights at 0, 4, 8, 12, indices at 16, 18, 20, 22 (−8 … −2 once
    // advanced); the indices alternate between r10 and r12.
    kernel!(
        four_pairs,
        4,
        24,
        [concat!(
            first_pair!(16, 24, -6),
            "\n",
            pair!(-20, "r12", "r10", -4),
            "\n",
            pair!(-16, "r10", "r12", -2),
            "\n",
            pair!(-12, "r12"),
            "\n",
            vertex_out!(),
        )]
    );
}

/// The x86-64 implementation (SSE2 is part of the x86-64 baseline).
#[cfg(all(target_arch = "x86_64", target_feature = "sse2"))]
pub(crate) mod sse2 {
    use core::arch::x86_64::{
        __m128i, _mm_add_epi32, _mm_cvtsi128_si32, _mm_cvtsi128_si64, _mm_cvtsi32_si128,
        _mm_cvtsi64_si128, _mm_madd_epi16, _mm_set1_epi32, _mm_set_epi32, _mm_setzero_si128,
        _mm_shuffle_epi32, _mm_sra_epi32, _mm_srai_epi32, _mm_unpacklo_epi16,
    };

    use super::*;

    /// [`deform`], callable from code compiled without the `sse2` attribute.
    #[allow(unsafe_code)]
    pub(crate) fn deform_checked(t: &Prepared, rig: Sections<'_>, out: &mut [[i32; 3]]) {
        // SAFETY: `deform` is safe Rust whose only requirement is the SSE2 target feature, and
        // this module is compiled only when SSE2 is enabled for the whole build (the x86-64
        // baseline), so every CPU that runs this code has it.
        unsafe { deform(t, rig, out) }
    }

    /// An entry as a vector (LLVM makes the four word reads one aligned load).
    #[target_feature(enable = "sse2")]
    #[inline]
    fn vector(e: &Entry) -> __m128i {
        let e = e.0.map(|w| w as i32);
        _mm_set_epi32(e[3], e[2], e[1], e[0])
    }

    /// One vertex: its pair bytes and rest bytes in, its position out.
    #[target_feature(enable = "sse2")]
    #[inline]
    fn vertex(t: &Prepared, shift: __m128i, words: &[u8], r: &[u8], o: &mut [i32; 3]) {
        let (weights, ids) = split_pairs(words);
        let mut acc = _mm_setzero_si128();
        for (w, id) in weights.chunks_exact(4).zip(ids.chunks_exact(2)) {
            let w = _mm_set1_epi32(i32::from_le_bytes(w.try_into().unwrap_or([0; 4])));
            let e = vector(t.entry(read_u16(id)));
            acc = _mm_add_epi32(acc, _mm_madd_epi16(e, w));
        }
        // rest (Q0.15) in the high halves of 32-bit lanes, shifted down to Q8.24.
        let r: &[u8; REST_BYTES] = r.try_into().unwrap_or(&[0; REST_BYTES]);
        let rest16 = _mm_cvtsi64_si128(i64::from_le_bytes([
            r[0], r[1], r[2], r[3], r[4], r[5], 0, 0,
        ]));
        let rest = _mm_srai_epi32::<{ 16 - crate::fixed::REST_SHIFT as i32 }>(
            _mm_unpacklo_epi16(_mm_setzero_si128(), rest16),
        );
        let sum = _mm_add_epi32(_mm_sra_epi32(acc, shift), rest);
        let xy = _mm_cvtsi128_si64(sum);
        *o = [
            xy as i32,
            (xy >> 32) as i32,
            _mm_cvtsi128_si32(_mm_shuffle_epi32::<0b10>(sum)),
        ];
    }

    /// Every vertex of `rig` from the frame's table `t`.
    #[target_feature(enable = "sse2")]
    fn deform(t: &Prepared, rig: Sections<'_>, out: &mut [[i32; 3]]) {
        let shift = _mm_cvtsi32_si128(t.shift as i32);
        rig.for_each_vertex(out, |words, r, o| vertex(t, shift, words, r, o));
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use std::{vec, vec::Vec};

    use super::*;
    use crate::fixed::widen_rest;

    /// xorshift64: deterministic test data.
    struct Rng(u64);
    impl Rng {
        fn next(&mut self) -> u64 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            self.0
        }
        fn below(&mut self, n: u64) -> u64 {
            self.next() % n
        }
    }

    /// A random valid linear rig: `vertices` vertices of 0..=`k` influences over `markers`
    /// markers, weights summing to 2^F with Σ|w| as large as the loader allows, in pairs over
    /// `marker_pairs` random marker pairs.
    struct Case {
        frac: u8,
        rest: Vec<u8>,
        marker_pairs: Vec<u8>,
        counts: Vec<u8>,
        pairs: Vec<u8>,
        /// Per vertex, its influences as (marker, weight): what the pairs encode.
        influences: Vec<Vec<(u8, i32)>>,
        markers: usize,
    }

    /// With `uniform`, every vertex has exactly `k` influences (what bakes write), else 0..=`k`.
    fn case(
        rng: &mut Rng,
        frac: u8,
        markers: usize,
        vertices: usize,
        k: u8,
        uniform: bool,
    ) -> Case {
        let one = 1i32 << frac;
        let table: Vec<[u8; 2]> = (0..1 + rng.below(MAX_MARKER_PAIRS as u64))
            .map(|_| [0; 2].map(|_| rng.below(markers as u64) as u8))
            .collect();
        let (mut rest, mut counts, mut pairs, mut influences) = (vec![], vec![], vec![], vec![]);
        for _ in 0..vertices {
            for _ in 0..3 {
                rest.extend_from_slice(&(rng.next() as i16).to_le_bytes());
            }
            let n = if uniform {
                usize::from(k)
            } else {
                rng.below(u64::from(k) + 1) as usize
            };
            // Weights with large magnitudes of both signs, fixed up to sum to 2^F and kept
            // within the Σ|w| bound (scaled down until they fit); an odd count's last pair has
            // a zero second weight.
            let mut w: Vec<i32> = (0..n)
                .map(|_| (rng.below(2 * 32767) as i32 - 32767) / n.max(1) as i32)
                .collect();
            if n > 0 {
                let s: i32 = w.iter().sum();
                w[0] += one - s;
                while w.iter().map(|x| x.abs()).sum::<i32>() > LINEAR_WEIGHT_ABS_SUM_MAX {
                    for x in &mut w {
                        *x /= 2;
                    }
                    let s: i32 = w.iter().sum();
                    w[0] += one - s;
                }
            }
            if n % 2 == 1 {
                w.push(0);
            }
            let ids: Vec<u16> = (0..w.len() / 2)
                .map(|_| rng.below(table.len() as u64) as u16)
                .collect();
            counts.push(ids.len() as u8);
            for x in &w {
                pairs.extend_from_slice(&(*x as i16).to_le_bytes());
            }
            let mut mine = vec![];
            for (i, &id) in ids.iter().enumerate() {
                pairs.extend_from_slice(&id.to_le_bytes());
                let [a, b] = table[usize::from(id)];
                mine.extend([(a, w[2 * i]), (b, w[2 * i + 1])]);
            }
            influences.push(mine);
        }
        Case {
            frac,
            rest,
            marker_pairs: table.concat(),
            counts,
            pairs,
            influences,
            markers,
        }
    }

    impl Case {
        fn sections(&self) -> Sections<'_> {
            Sections {
                rest: &self.rest,
                counts: &self.counts,
                pairs: &self.pairs,
                uniform: crate::deformer::contract::uniform(&self.counts),
            }
        }
    }

    /// The clamped, scaled displacements `s` (module docs) in i128, with no cleverness.
    fn scaled_exact(c: &Case, markers: &[[i32; 3]], marker_rest: &[u8]) -> Vec<[i128; 3]> {
        let limit = i128::from(linear_displacement_limit(u32::from(c.frac)));
        markers
            .iter()
            .zip(marker_rest.chunks_exact(POSITION_BYTES))
            .map(|(m, r)| {
                let r = read_position(r);
                [0, 1, 2].map(|a| {
                    (i128::from(m[a]) - i128::from(r[a])).clamp(-limit, limit) << (15 - c.frac)
                })
            })
            .collect()
    }

    /// Each vertex as `rest + (Σ w · x + half) >> shift` over per-marker values `x`, with
    /// `half = 2^(shift−1)` when `rounded`, else 0.
    fn weighted(c: &Case, x: &[[i128; 3]], shift: u32, rounded: bool) -> Vec<[i32; 3]> {
        c.rest
            .chunks_exact(REST_BYTES)
            .zip(&c.influences)
            .map(|(r, row)| {
                [0, 1, 2].map(|a| {
                    let sum: i128 = row
                        .iter()
                        .map(|&(m, w)| i128::from(w) * x[usize::from(m)][a])
                        .sum();
                    let rest = widen_rest(i16::from_le_bytes([r[2 * a], r[2 * a + 1]]));
                    let half = if rounded { (1i128 << shift) >> 1 } else { 0 };
                    i32::try_from(i128::from(rest) + ((sum + half) >> shift))
                        .expect("the module's bound: no overflow")
                })
            })
            .collect()
    }

    /// The deformer's formula (module docs) evaluated in i128 from the markers: the contract
    /// every implementation must meet bit for bit. Also returns the exponent.
    fn reference(c: &Case, markers: &[[i32; 3]], marker_rest: &[u8]) -> (Vec<[i32; 3]>, u32) {
        let s = scaled_exact(c, markers, marker_rest);
        let largest = s.iter().flatten().map(|x| x.abs()).max().unwrap_or(0);
        let bits = 128 - largest.leading_zeros();
        let e = bits.saturating_sub(15).min(15);
        let q: Vec<[i128; 3]> = s
            .iter()
            .map(|v| {
                v.map(|x| {
                    ((x + ((1 << e) >> 1)) >> e).clamp(-i128::from(Q_MAX), i128::from(Q_MAX))
                })
            })
            .collect();
        (weighted(c, &q, 15 - e, false), e)
    }

    /// Marker positions: extreme, large and small displacements from random rest positions; with
    /// `small`, only small ones (a face's frame).
    fn frame(rng: &mut Rng, c: &Case, small: bool) -> (Vec<[i32; 3]>, Vec<u8>) {
        let mut rest = vec![];
        let mut markers = vec![];
        for j in 0..c.markers {
            let r = [0; 3].map(|_| (rng.next() as i32) >> 6);
            for x in r {
                rest.extend_from_slice(&x.to_le_bytes());
            }
            let m = r.map(|x| match (j + rng.below(4) as usize) % 4 {
                _ if small => x.wrapping_add((rng.next() as i32) >> 10),
                0 => rng.next() as i32,
                1 => x.wrapping_add((rng.next() as i32) >> 3),
                2 => x.wrapping_add((rng.next() as i32) >> 20),
                _ => [i32::MIN, i32::MAX][rng.below(2) as usize],
            });
            markers.push(m);
        }
        (markers, rest)
    }

    fn prepared(c: &Case, m: &[[i32; 3]], mrest: &[u8]) -> Prepared {
        let mut t = Prepared::EMPTY;
        t.fill(&quantised(m, mrest, c.frac, &[]), &c.marker_pairs);
        t
    }

    #[test]
    fn every_implementation_matches_the_exact_formula() {
        let mut rng = Rng(0x1234_5678_9ABC_DEF1);
        for trial in 0..80 {
            let frac = [8u8, 11, 13, 14][trial % 4];
            let markers = [1, 7, 40, 256][(trial % 4) ^ ((trial / 4) % 4)];
            // Every third trial has K = 4 or 8 everywhere: the specialised loops.
            let (k, uniform) = match trial % 3 {
                0 => ([4, 8][trial % 2], true),
                _ => ([1, 3, 4, 8, 9, 64][trial % 6], false),
            };
            let c = case(&mut rng, frac, markers, 297 + trial % 4, k, uniform);
            let (m, mrest) = frame(&mut rng, &c, trial % 2 == 0);
            let (want, _) = reference(&c, &m, &mrest);
            let t = prepared(&c, &m, &mrest);
            let mut got = vec![[0; 3]; want.len()];
            portable::deform(&t, c.sections(), &mut got);
            assert_eq!(got, want, "portable, trial {trial}");
            #[cfg(all(target_arch = "x86_64", target_feature = "sse2"))]
            {
                let mut simd = vec![[1; 3]; want.len()];
                sse2::deform_checked(&t, c.sections(), &mut simd);
                assert_eq!(simd, want, "sse2, trial {trial}");
            }
        }
    }

    #[test]
    fn sixteen_bits_stay_within_the_documented_bound_of_the_exact_sum() {
        let mut rng = Rng(0x0DDB_A11C_AFE0_0001);
        for trial in 0..40 {
            let frac = [8u8, 14][trial % 2];
            let c = case(&mut rng, frac, 41, 500, 8, true);
            let (m, mrest) = frame(&mut rng, &c, trial % 4 != 0);
            let (got, e) = reference(&c, &m, &mrest);
            let exact = weighted(&c, &scaled_exact(&c, &m, &mrest), 15, true);
            let bound = (1i64 << e) + 1;
            for (v, (g, x)) in got.iter().zip(&exact).enumerate() {
                for a in 0..3 {
                    let error = (i64::from(g[a]) - i64::from(x[a])).abs();
                    assert!(error <= bound, "trial {trial} vertex {v}: {error} > {bound} (e = {e})");
                }
            }
        }
    }

    #[test]
    fn the_exponent_is_the_least_that_holds_the_largest_displacement() {
        let rest: Vec<u8> = [0i32; 6].iter().flat_map(|x| x.to_le_bytes()).collect();
        let frac = 14; // s = d · 2
        let of = |d: i32| quantised(&[[d, 0, 0], [0, -3, 0]], &rest, frac, &[]);
        // Small displacements need no exponent and are exact.
        let q = of(1000);
        assert_eq!((q.exponent, q.q[0], q.q[1]), (0, [2000, 0, 0], [0, -6, 0]));
        assert_eq!(q.q[2], [0; 3]);
        // 2 · 16383 = 32766 has 15 bits; 2 · 16384 = 32768 has 16: e = 1.
        assert_eq!(of(16383).exponent, 0);
        let q = of(16384);
        assert_eq!((q.exponent, q.q[0][0], q.q[1][1]), (1, 16384, -3));
        // 2 · 32767 = 65534 (16 bits) rounds to 32767 at e = 1.
        assert_eq!(of(32767).q[0][0], 32767);
        // At the clamp (2^29 · 2 = 2^30: 31 bits) e = 15, and the rounded ±2^15 comes back to
        // ±(2^15 − 1).
        let q = of(i32::MAX);
        assert_eq!((q.exponent, q.q[0][0]), (15, Q_MAX as i16));
        let q = of(i32::MIN);
        assert_eq!((q.exponent, q.q[0][0]), (15, -Q_MAX as i16));
        // Just below a power of two, rounding reaches 2^15 and the clamp takes it back by one:
        // s = 2 · 65535 = 2^17 − 2 (17 bits, e = 2), (s + 2) >> 2 = 2^15.
        let q = of(65535);
        assert_eq!((q.exponent, q.q[0][0]), (2, Q_MAX as i16));
        let q = of(-65535);
        assert_eq!((q.exponent, q.q[0][0]), (2, -Q_MAX as i16));
    }

    /// A derived projection's record: source, zero byte, direction.
    fn record(source: u8, direction: [i16; 3]) -> [u8; DERIVED_MARKER_BYTES] {
        DerivedMarker::Projection { source, direction }.record()
    }

    /// A derived marker along an axis is its source's `q` on that axis exactly, 0 on the
    /// others; along a tilted direction it is the projection `(q·a)a` to within the two
    /// roundings; nothing past the derived markers changes.
    #[test]
    fn derived_markers_project_their_sources_on_their_directions() {
        let rest: Vec<u8> = [[0i32; 3]; 3]
            .iter()
            .flat_map(|p| p.iter().flat_map(|c| c.to_le_bytes()))
            .collect();
        let markers = [[1 << 20, -(3 << 20), 5 << 20], [7 << 19, 3 << 19, -(1 << 22)], [0; 3]];
        let before = quantised(&markers, &rest, 12, &[]).q;
        // Rolled 20° about z, then scaled to Σ|a| = 2^14.
        let tilted = [-4_178, 12_206, 0];
        let derived = [
            record(1, [0, 1 << 14, 0]),
            record(0, [-(1 << 14), 0, 0]),
            record(0, tilted),
        ]
        .concat();
        let q = quantised(&markers, &rest, 12, &derived);
        let [a, b] = [before[0], before[1]];
        assert_eq!(q.q[3], [0, b[1], 0]);
        assert_eq!(q.q[4], [a[0], 0, 0]);
        let along: f64 = (0..3).map(|c| f64::from(a[c]) * f64::from(tilted[c])).sum();
        for (got, a) in q.q[5].iter().zip(tilted) {
            let exact = along * f64::from(a) / f64::from(1 << 28);
            assert!((f64::from(*got) - exact).abs() <= 1.0, "{:?}", q.q[5]);
        }
        assert_ne!(q.q[5][0], 0);
        assert_eq!(q.q[..3], before[..3]);
        assert!(q.q[6..].iter().all(|v| *v == [0; 3]));
        assert!(a.iter().chain(&b).all(|&v| v != 0));
    }

    /// The largest displacements on the longest directions of every sign stay within
    /// ±(2¹⁵ − 1): no overflow, no clamp needed.
    #[test]
    fn derived_markers_cannot_overflow() {
        let big = Q_MAX as i16;
        for signs in 0..64u32 {
            let s = |bit: u32| if signs >> bit & 1 == 1 { -1 } else { 1 };
            let source = [s(0) * big, s(1) * big, s(2) * big];
            for a in [[5_462, 5_461, 5_461], [1 << 14, 0, 0], [8_192, 8_192, 0]] {
                let a = [0, 1, 2].map(|c| a[c] * s(3 + c as u32));
                let mut q = Quantised {
                    q: [[0; 3]; MAX_MARKERS],
                    exponent: 0,
                };
                q.q[0] = source;
                q.derive(1, &record(0, a));
                let along: i64 = (0..3).map(|c| i64::from(source[c]) * i64::from(a[c])).sum();
                let p = (along + 8_192) >> 14;
                for c in 0..3 {
                    let want = (p * i64::from(a[c]) + 8_192) >> 14;
                    assert_eq!(i64::from(q.q[1][c]), want, "{source:?} {a:?}");
                    assert!(want.abs() <= i64::from(Q_MAX));
                }
            }
        }
    }

    /// A derived mean is its sources' sum times `⌊2¹⁶/n⌋ / 2¹⁶`, rounded, for every count;
    /// at the largest displacements of either sign it stays within ±(2¹⁵ − 1); and its record
    /// reads back as written.
    #[test]
    fn derived_means_sum_their_sources_and_cannot_overflow() {
        let big = Q_MAX as i16;
        for count in 2..=MEAN_MAX_SOURCES as u8 {
            for fill in [big, -big, 12_345, -7] {
                let mut q = Quantised {
                    q: [[0; 3]; MAX_MARKERS],
                    exponent: 0,
                };
                for (m, v) in q.q[..8].iter_mut().enumerate() {
                    *v = [fill, -fill, if m % 2 == 0 { fill } else { 3 }];
                }
                let sources = core::array::from_fn(|i| {
                    if i < usize::from(count) {
                        7 - i as u8
                    } else {
                        0
                    }
                });
                let mean = DerivedMarker::Mean { sources, count };
                let record = mean.record();
                assert_eq!(DerivedMarker::read(&record), mean);
                assert!(mean.valid(8) && !mean.valid(7 - usize::from(count) + 1));
                q.derive(8, &record);
                let r = i64::from(DerivedMarker::mean_factor(count));
                for c in 0..3 {
                    let sum: i64 = sources[..usize::from(count)]
                        .iter()
                        .map(|&s| i64::from(q.q[usize::from(s)][c]))
                        .sum();
                    let want = (sum * r + 32_768) >> 16;
                    assert_eq!(i64::from(q.q[8][c]), want, "{count} {fill}");
                    assert!(want.abs() <= i64::from(Q_MAX));
                }
            }
        }
        // Golden vectors, the same on every target (`.ci/cross.sh` runs these tests there).
        let mut q = Quantised {
            q: [[0; 3]; MAX_MARKERS],
            exponent: 0,
        };
        q.q[..3].copy_from_slice(&[[big, -big, 1], [big, -big, 2], [-5, 7, big]]);
        let three = DerivedMarker::Mean {
            sources: [0, 1, 2, 0, 0, 0, 0],
            count: 3,
        };
        q.derive(3, &three.record());
        assert_eq!(q.q[3], [21_843, -21_842, 10_923]);
        q.q[..7].fill([big, -big, 0]);
        q.q[6][2] = 1;
        let seven = DerivedMarker::Mean {
            sources: [0, 1, 2, 3, 4, 5, 6],
            count: 7,
        };
        q.derive(7, &seven.record());
        assert_eq!(q.q[7], [32_766, -32_766, 0]);
        // Neither one source nor a stray byte past the count passes the loader's check.
        let mut one = [0u8; DERIVED_MARKER_BYTES];
        one[1] = 1;
        assert!(!DerivedMarker::read(&one).valid(8));
        let mut stray = DerivedMarker::Mean {
            sources: [1, 2, 0, 0, 0, 0, 0],
            count: 2,
        }
        .record();
        stray[7] = 3;
        assert!(!DerivedMarker::read(&stray).valid(8));
    }

    #[test]
    fn the_pairs_decode_to_the_influences_they_encode() {
        let mut rng = Rng(77);
        let c = case(&mut rng, 12, 40, 50, 9, false);
        let l = LinearDeformer {
            weight_frac_bits: c.frac,
            max_influences: 10,
            derived_markers: Bytes(&[]),
            marker_pairs: Bytes(&c.marker_pairs),
            pair_counts: Bytes(&c.counts),
            pairs_align: Bytes(&[]),
            pairs: Bytes(&c.pairs),
        };
        let decoded: Vec<Vec<(u8, i32)>> = l
            .vertex_influences()
            .map(|v| v.map(|(m, w)| (m, i32::from(w))).collect())
            .collect();
        assert_eq!(decoded, c.influences);
    }

    #[test]
    fn common_count_is_the_count_every_vertex_has() {
        let of = |counts: &[u8]| {
            Sections {
                rest: &[],
                counts,
                pairs: &[],
                uniform: crate::deformer::contract::uniform(counts),
            }
            .common_count()
        };
        assert_eq!(of(&[4; 7]), Some(4));
        assert_eq!(of(&[2; 8]), Some(2));
        assert_eq!(of(&[3]), Some(3));
        for at in 0..7 {
            let mut counts = [4; 7];
            counts[at] = 3;
            assert_eq!(of(&counts), None, "differs at {at}");
        }
        assert_eq!(of(&[0; 5]), None);
        assert_eq!(of(&[]), None);
    }
}

