//! The linear deformer: each vertex moves by a weighted sum of at most K marker displacements.
//!
//! ```text
//! d[j]   = clamp(m[j] − m_rest[j], ±2^(15+F))                          per marker
//! out[v] = rest[v] + ( Σ_k w[v,k] · d[idx[v,k]] + 2^(F−1) ) >> F       per vertex
//! ```
//!
//! # Why it cannot overflow, and why it fits 16-bit lanes
//!
//! The loader guarantees `Σ_k |w[v,k]| ≤ 2¹⁵ − 1` for every vertex (so every weight is an `i16`)
//! and F ≤ 14. Both implementations first scale every clamped displacement by `2^(15−F)`:
//!
//! ```text
//! s[j]   = d[j] · 2^(15−F),  |s| ≤ 2^30                                 per marker
//! out[v] = rest[v] + ( Σ_k w[v,k] · s[idx[v,k]] + 2^14 ) >> 15          per vertex
//! ```
//!
//! which is the same integer as the formula above: the sum and the rounding term are both scaled
//! by `2^(15−F)` (an integer, as F ≤ 15), and `⌊2^(15−F) · X / 2^15⌋ = ⌊X / 2^F⌋`. The shift and
//! the rounding term no longer depend on F: they are constants in the per-vertex code.
//!
//! Every partial sum is within `(2¹⁵ − 1) · 2³⁰ < 2⁴⁵`, so an `i64` accumulator is exact. Split a
//! scaled displacement into 16-bit halves, `s = hi · 2¹⁶ + lo` with `lo = s as i16` (signed) and
//! `hi = (s − lo) >> 16`: |lo| ≤ 2¹⁵ and |hi| ≤ 2¹⁴, both `i16`. Then
//!
//! ```text
//! H = Σ w · hi,  |H| < 2^29           L = Σ w · lo,  |L| < 2^30        (every partial sum too)
//! Σ w · s = H · 2^16 + L
//! (Σ w · s + 2^14) >> 15 = 2 · H + ((L + 2^14) >> 15)                 exactly
//! ```
//!
//! so |2 · H| < 2³⁰, |(L + 2¹⁴) >> 15| ≤ 2¹⁵, and with |rest| ≤ 2²⁴ the output is below 2³¹: no
//! step overflows an `i32` and none needs saturation. The only saturation is the displacement
//! clamp, which keeps a uniform translation exact (every displacement clamps alike, and the weights
//! sum to exactly 2^F).
//!
//! Two implementations compute exactly this integer, so their outputs are bit for bit equal:
//!
//! * `portable`: one `i64` accumulator per axis, started at the rounding term (a 32 × 32 → 64-bit
//!   multiply-add per influence and axis: one single-cycle `SMLAL` on a Cortex-M4, which beats the
//!   16-bit halves there, as they need two multiplies per axis);
//! * `sse2` (x86-64): the halves of every marker's displacement in one 128-bit table entry; two
//!   influences at a time, their halves are interleaved (`punpcklwd`/`punpckhwd`) and multiplied by
//!   the weight pair with `pmaddwd` into 32-bit lanes, which the bounds above make exact.
//!
//! Cost per frame: per marker a subtraction, a clamp and a shift; per influence a word decode and
//! three multiply-adds (two `pmaddwd` per two influences on x86-64); per vertex one rounding shift
//! and one addition per axis. There is no branch on marker data and no check that can fail: the
//! loader has validated every index, count and bound.

use serde::{Deserialize, Serialize};

use crate::cost::{Cost, NormalsCost};
use crate::deformer::contract::{
    check, counted_range, DeformerSection, DegenerateTriangles, Shared,
};
use crate::fixed::{
    linear_displacement_limit, LINEAR_MAX_WEIGHT_FRAC_BITS,
    LINEAR_WEIGHT_ABS_SUM_MAX,
};
use crate::error::LoadError;
use crate::records::{
    read_influence, read_position, read_rest, Bytes, INFLUENCE_BYTES, MAX_MARKERS,
    POSITION_BYTES, REST_BYTES,
};

/// The linear deformer's section: every vertex moves by a fixed weighted sum of marker
/// displacements (layout: [`crate::format::RigData`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct LinearDeformer<'a> {
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

impl<'a> LinearDeformer<'a> {
    /// The section for vertices `first .. first + len` only (see [`super::Deformer::vertex_range`]).
    pub(crate) fn vertex_range(&self, first: usize, len: usize, uniform: Option<u8>) -> Self {
        let (counts, influences) = counted_range(
            self.influence_counts.0,
            self.influences.0,
            INFLUENCE_BYTES,
            first,
            len,
            uniform,
        );
        Self {
            influence_counts: Bytes(counts),
            influences: Bytes(influences),
            ..*self
        }
    }
}

impl DeformerSection for LinearDeformer<'_> {
    fn validate(&self, rig: &Shared<'_>) -> Result<(), LoadError> {
        check::max_influences(self.max_influences)?;
        check::weight_format(self.weight_frac_bits, LINEAR_MAX_WEIGHT_FRAC_BITS)?;
        check::counted_records(
            self.influence_counts,
            self.influences,
            rig.vertices,
            INFLUENCE_BYTES,
        )?;
        let one = 1i64 << self.weight_frac_bits;
        let mut words = self.influences.0.chunks_exact(INFLUENCE_BYTES);
        for (vertex, &count) in self.influence_counts.0.iter().enumerate() {
            if count > self.max_influences {
                return Err(LoadError::TooManyInfluences { vertex, count });
            }
            let (mut sum, mut abs_sum) = (0i64, 0i64);
            for w in words.by_ref().take(usize::from(count)) {
                let (marker, weight) = read_influence(w);
                if usize::from(marker) >= rig.markers {
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

    fn cost(&self, rig: &Shared<'_>) -> Cost {
        let (v, m) = (rig.vertices, rig.markers);
        let influences = self.influences.0.len() / INFLUENCE_BYTES;
        Cost {
            vertices: v,
            markers: m,
            influences,
            max_influences: usize::from(self.max_influences),
            coefficient_rows: 0,
            multiply_adds: 3 * influences,
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
        let d = displacements(markers, rig.marker_rest, self.weight_frac_bits);
        deform_with(&d, self.sections(rig), out);
        DegenerateTriangles::default()
    }

}

impl LinearDeformer<'_> {
    /// The per-frame marker work of [`DeformerSection::deform`] for `markers` (one per rig
    /// marker, the caller checked), for [`Self::deform_prepared`].
    pub(crate) fn prepare(&self, rig: &Shared<'_>, markers: &[[i32; 3]]) -> Prepared {
        prepared(&displacements(markers, rig.marker_rest, self.weight_frac_bits))
    }

    /// The vertices of `rig` into `out` (one entry each, the caller checked) from this frame's
    /// `prepared` work: the integers [`DeformerSection::deform`] writes.
    pub(crate) fn deform_prepared(&self, rig: &Shared<'_>, prepared: &Prepared, out: &mut [[i32; 3]]) {
        deform_prepared(prepared, self.sections(rig), out);
    }

    /// The per-vertex sections of `rig` (validated at load, including Σ|w| ≤ 2¹⁵ − 1 per vertex
    /// and F ≤ 14) as the per-frame loops read them.
    fn sections<'s>(&'s self, rig: &Shared<'s>) -> Sections<'s> {
        Sections {
            rest: rig.vertex_rest,
            counts: self.influence_counts.0,
            influences: self.influences.0,
            uniform: rig.uniform_influences,
        }
    }
}

/// Per marker index, its clamped displacement scaled by `2^(15−F)` ([`SUM_SHIFT`]), in lanes
/// `[0, x, y, z]`. Four lanes rather than three: an entry is 16 bytes, so its address is one
/// shifted addition (a 12-byte entry takes two on a Cortex-M4). Lane 0 is unused so that every
/// lane read is at a non-zero offset from that address: with `x` at offset 0, LLVM forms its
/// address a second time, as a register offset (one instruction more per influence).
pub(crate) type Displacements = [[i32; 4]; MAX_MARKERS];

/// Fractional bits of every weighted sum of scaled displacements: the per-vertex shift. The
/// rounding term is half of its unit.
const SUM_SHIFT: u32 = LINEAR_MAX_WEIGHT_FRAC_BITS as u32 + 1;
/// `2^(SUM_SHIFT − 1)`: added before the shift, so it rounds half up.
const SUM_HALF: i32 = 1 << (SUM_SHIFT - 1);

/// Stack the deformer uses per frame: the displacement table, plus on x86-64 its 16-bit halves
/// (one 128-bit entry per marker index).
pub(crate) const SCRATCH_BYTES: usize = core::mem::size_of::<Displacements>()
    + if cfg!(all(target_arch = "x86_64", target_feature = "sse2")) {
        16 * MAX_MARKERS
    } else {
        0
    };

/// The clamped displacement of every marker (Q8.24) times `2^(15−F)`, in marker order; later
/// entries stay zero.
///
/// `markers` are the current positions, `marker_rest` the rest section ([`POSITION_BYTES`] a
/// marker).
pub(crate) fn displacements(
    markers: &[[i32; 3]],
    marker_rest: &[u8],
    weight_frac_bits: u8,
) -> Displacements {
    let limit = i64::from(linear_displacement_limit(u32::from(weight_frac_bits)));
    // F ≤ 14 (validated), so the scale is a left shift by at least one bit.
    let scale = SUM_SHIFT - u32::from(weight_frac_bits);
    let mut table = [[0i32; 4]; MAX_MARKERS];
    for ((d, m), r) in table
        .iter_mut()
        .zip(markers)
        .zip(marker_rest.chunks_exact(POSITION_BYTES))
    {
        let rest = read_position(r);
        for c in 0..3 {
            // In i64 the difference is exact; the clamp bounds it by ±2^(15+F) (so it fits an
            // i32), the scale by ±2^30. `max`/`min` rather than `clamp`, which asserts that its
            // bounds are ordered: a panic path, and with it the Cortex-M4 build copied the 4 KiB
            // table once a frame.
            let difference = i64::from(m[c]) - i64::from(rest[c]);
            d[c + 1] = (difference.max(-limit).min(limit) as i32) << scale;
        }
    }
    table
}

/// The linear deformer's per-frame data in a [`crate::FrameTable`]: the scaled displacement
/// table, on x86-64 as the SSE2 path's table of 16-bit halves.
#[cfg(all(target_arch = "x86_64", target_feature = "sse2"))]
pub(crate) type Prepared = sse2::Frame;
/// The linear deformer's per-frame data in a [`crate::FrameTable`]: the scaled displacement
/// table, on x86-64 as the SSE2 path's table of 16-bit halves.
#[cfg(not(all(target_arch = "x86_64", target_feature = "sse2")))]
pub(crate) type Prepared = Displacements;

/// This frame's [`Prepared`] data from the scaled displacement table `d`.
fn prepared(d: &Displacements) -> Prepared {
    #[cfg(all(target_arch = "x86_64", target_feature = "sse2"))]
    return sse2::frame_checked(d);
    #[cfg(not(all(target_arch = "x86_64", target_feature = "sse2")))]
    *d
}

/// Every vertex of `rig` from this frame's [`Prepared`] data.
fn deform_prepared(p: &Prepared, rig: Sections<'_>, out: &mut [[i32; 3]]) {
    #[cfg(all(target_arch = "x86_64", target_feature = "sse2"))]
    sse2::deform_vertices_checked(p, rig, out);
    #[cfg(not(all(target_arch = "x86_64", target_feature = "sse2")))]
    portable::deform(p, rig, out);
}

/// Write deformed positions for every vertex of `rig` from the scaled displacement table `d`.
fn deform_with(d: &Displacements, rig: Sections<'_>, out: &mut [[i32; 3]]) {
    #[cfg(all(target_arch = "x86_64", target_feature = "sse2"))]
    sse2::deform_checked(d, rig, out);
    #[cfg(not(all(target_arch = "x86_64", target_feature = "sse2")))]
    portable::deform(d, rig, out);
}

/// A linear rig's per-vertex sections, validated at load.
#[derive(Clone, Copy)]
pub(crate) struct Sections<'a> {
    /// Vertex rest positions, [`REST_BYTES`] a vertex.
    rest: &'a [u8],
    /// Influences per vertex, one byte a vertex.
    counts: &'a [u8],
    /// Packed influences, [`INFLUENCE_BYTES`] each, vertex after vertex.
    influences: &'a [u8],
    /// The count every vertex has, when all have the same ([`Shared::uniform_influences`]).
    uniform: Option<u8>,
}

impl<'a> Sections<'a> {
    /// Call `f(words, rest bytes, output slot)` for every vertex in turn.
    ///
    /// Bakes give every vertex exactly K influences. When a rig's counts are all 4 or all 8 (a
    /// property of the rig, never of the markers), each vertex's words come as a fixed-size
    /// chunk, so an inlined `f` compiles for exactly that K, without per-vertex tail handling.
    #[inline(always)]
    fn for_each_vertex(self, out: &mut [[i32; 3]], mut f: impl FnMut(&[u8], &[u8], &mut [i32; 3])) {
        match self.common_count() {
            Some(4) => self.uniform::<{ 4 * INFLUENCE_BYTES }>(out, &mut f),
            Some(8) => self.uniform::<{ 8 * INFLUENCE_BYTES }>(out, &mut f),
            _ => {
                for (o, r, words) in self.vertices(out) {
                    f(words, r, o);
                }
            }
        }
    }

    /// [`Self::for_each_vertex`] when every vertex has `N / INFLUENCE_BYTES` influences.
    #[inline(always)]
    fn uniform<const N: usize>(
        self,
        out: &mut [[i32; 3]],
        f: &mut impl FnMut(&[u8], &[u8], &mut [i32; 3]),
    ) {
        for (o, r, words) in self.uniform_vertices(out, N / INFLUENCE_BYTES) {
            let words: &[u8; N] = words.try_into().unwrap_or(&[0; N]);
            f(words, r, o);
        }
    }

    /// [`Self::for_each_vertex`] with one loop for every common K: `f` sees slices whose length
    /// is known only at run time, so it compiles once, for every K alike.
    #[inline(always)]
    fn for_each_vertex_rolled(
        self,
        out: &mut [[i32; 3]],
        mut f: impl FnMut(&[u8], &[u8], &mut [i32; 3]),
    ) {
        match self.common_count() {
            Some(k) => {
                for (o, r, words) in self.uniform_vertices(out, k) {
                    f(words, r, o);
                }
            }
            None => {
                for (o, r, words) in self.vertices(out) {
                    f(words, r, o);
                }
            }
        }
    }

    /// The number of influences of every vertex, if all have the same (as bakes write them)
    /// and it is not zero: found once when the rig was loaded, not scanned per frame.
    fn common_count(self) -> Option<usize> {
        self.uniform.map(usize::from)
    }

    /// [`Self::vertices`] when every vertex has `k ≥ 1` influences ([`Self::common_count`]).
    fn uniform_vertices<'o>(
        self,
        out: &'o mut [[i32; 3]],
        k: usize,
    ) -> impl Iterator<Item = (&'o mut [i32; 3], &'a [u8], &'a [u8])> + use<'a, 'o> {
        out.iter_mut()
            .zip(self.rest.chunks_exact(REST_BYTES))
            .zip(self.influences.chunks_exact(k * INFLUENCE_BYTES))
            .map(|((o, r), words)| (o, r, words))
    }

    /// Each output slot with its vertex's rest bytes and influence words.
    fn vertices<'o>(
        self,
        out: &'o mut [[i32; 3]],
    ) -> impl Iterator<Item = (&'o mut [i32; 3], &'a [u8], &'a [u8])> + use<'a, 'o> {
        out.iter_mut()
            .zip(self.rest.chunks_exact(REST_BYTES))
            .zip(per_vertex(self.counts, self.influences))
            .map(|((o, r), words)| (o, r, words))
    }
}

/// The influences of each vertex in turn, as one slice of words per vertex.
///
/// The loader checked that the counts add up to the section, so the fallback (an empty slice)
/// is never taken.
fn per_vertex<'a>(counts: &'a [u8], influences: &'a [u8]) -> impl Iterator<Item = &'a [u8]> {
    let mut words = influences;
    counts.iter().map(move |&count| {
        let (mine, tail) = words
            .split_at_checked(INFLUENCE_BYTES * usize::from(count))
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

    /// See [`super::deform`]; `d` is the scaled displacement table.
    ///
    /// On 32-bit ARM, one rolled loop over a vertex's influences whatever K (so a K = 4 and a
    /// K = 8 rig cost the same per influence and per vertex): on a Cortex-M4 the loop fully
    /// unrolled for K = 8, or unrolled four influences a pass, keeps more values live than the
    /// registers hold and spills them to the stack (up to 34 instructions per influence), where
    /// the rolled loop takes 11 (`LDR` word, `UXTB` index, `ASR` weight, entry address, `LDRD` +
    /// `LDR`, three `SMLAL`, count and branch). Elsewhere (aarch64, i686, 32-bit PowerPC) the
    /// loops fully unrolled for K = 4 and 8 take 6 to 28% fewer instructions than the rolled one.
    ///
    /// Not inlined: `Rig::deform` and `Rig::deform_chunk` share this one copy of the loop.
    #[inline(never)]
    pub(crate) fn deform(d: &Displacements, rig: Sections<'_>, out: &mut [[i32; 3]]) {
        #[cfg(target_arch = "arm")]
        rolled(d, rig, out);
        #[cfg(not(target_arch = "arm"))]
        unrolled(d, rig, out);
    }

    /// [`deform`] through [`Sections::for_each_vertex_rolled`] (32-bit ARM).
    #[cfg_attr(not(any(target_arch = "arm", test)), allow(dead_code))]
    pub(crate) fn rolled(d: &Displacements, rig: Sections<'_>, out: &mut [[i32; 3]]) {
        rig.for_each_vertex_rolled(out, |words, r, o| vertex(d, words, r, o));
    }

    /// [`deform`] through [`Sections::for_each_vertex`] (every other target).
    #[cfg_attr(all(target_arch = "arm", not(test)), allow(dead_code))]
    pub(crate) fn unrolled(d: &Displacements, rig: Sections<'_>, out: &mut [[i32; 3]]) {
        rig.for_each_vertex(out, |words, r, o| vertex(d, words, r, o));
    }

    /// One vertex: its influence words and rest bytes in, its position out.
    #[inline(always)]
    fn vertex(d: &Displacements, words: &[u8], r: &[u8], o: &mut [i32; 3]) {
        // The rounding term first: the sum is the same integer in any order.
        let mut acc = [i64::from(SUM_HALF); 3];
        for w in words.chunks_exact(INFLUENCE_BYTES) {
            let (marker, weight) = read_influence(w);
            // A u8 index into a 256-entry array: in range by construction.
            let [_, x, y, z] = d[usize::from(marker)];
            for (a, s) in acc.iter_mut().zip([x, y, z]) {
                *a += i64::from(weight) * i64::from(s);
            }
            // LLVM's ARM cost model unrolls small loops four times over (and fully for a
            // constant K), which spills (see `deform`); an opaque no-op in the body keeps the
            // loop rolled and costs no instruction.
            #[cfg(target_arch = "arm")]
            core::hint::black_box(());
        }
        // Below 2^30 in magnitude after the shift, and below 2^31 with the rest position, by the
        // module's bounds: the narrowing and the addition are exact (wrapping is never reached,
        // and cannot panic).
        let rest = read_rest(r);
        *o = [0, 1, 2].map(|c| rest[c].wrapping_add((acc[c] >> SUM_SHIFT) as i32));
    }
}

/// The x86-64 implementation (SSE2 is part of the x86-64 baseline).
#[cfg(all(target_arch = "x86_64", target_feature = "sse2"))]
pub(crate) mod sse2 {
    use core::arch::x86_64::{
        __m128i, _mm_add_epi32, _mm_cvtsi128_si32, _mm_cvtsi128_si64, _mm_cvtsi32_si128,
        _mm_cvtsi64_si128, _mm_madd_epi16, _mm_packs_epi32, _mm_set1_epi32, _mm_set_epi16,
        _mm_set_epi32, _mm_setzero_si128, _mm_shuffle_epi32, _mm_slli_epi32,
        _mm_srai_epi32, _mm_unpackhi_epi16, _mm_unpacklo_epi16,
    };

    use super::*;

    /// [`Frame::new`], callable from code compiled without the `sse2` attribute.
    #[allow(unsafe_code)]
    pub(crate) fn frame_checked(d: &Displacements) -> Frame {
        // SAFETY: as in `deform_checked`.
        unsafe { Frame::new(d) }
    }

    /// [`deform_vertices`], callable from code compiled without the `sse2` attribute.
    #[allow(unsafe_code)]
    pub(crate) fn deform_vertices_checked(frame: &Frame, rig: Sections<'_>, out: &mut [[i32; 3]]) {
        // SAFETY: as in `deform_checked`.
        unsafe { deform_vertices(frame, rig, out) }
    }

    /// [`deform`], callable from code compiled without the `sse2` attribute.
    #[allow(unsafe_code)]
    pub(crate) fn deform_checked(d: &Displacements, rig: Sections<'_>, out: &mut [[i32; 3]]) {
        // SAFETY: `deform` is safe Rust whose only requirement is the SSE2 target feature, and
        // this module is compiled only when SSE2 is enabled for the whole build (the x86-64
        // baseline), so every CPU that runs this code has it.
        unsafe { deform(d, rig, out) }
    }

    /// One marker's scaled displacement `[0, x, y, z]` as a table entry: lanes `[hi x, hi y,
    /// hi z, 0, lo x, lo y, lo z, 0]` (16-bit), with `s = hi · 2^16 + lo` and `lo` signed.
    #[target_feature(enable = "sse2")]
    fn entry(s: [i32; 4]) -> __m128i {
        let lo = s.map(|x| x as i16);
        // |s| ≤ 2^30 (the clamp and the scale), so |hi| ≤ 2^14.
        let hi = [1, 2, 3].map(|c| ((s[c] - i32::from(lo[c])) >> 16) as i16);
        _mm_set_epi16(0, lo[3], lo[2], lo[1], 0, hi[2], hi[1], hi[0])
    }

    /// `acc_hi += hi halves · weights`, `acc_lo += lo halves · weights` for two influences:
    /// `pair` holds their two weights as 16-bit lanes, repeated.
    #[target_feature(enable = "sse2")]
    #[inline]
    fn madd_pair(acc: &mut [__m128i; 2], a: __m128i, b: __m128i, pair: __m128i) {
        acc[0] = _mm_add_epi32(acc[0], _mm_madd_epi16(_mm_unpacklo_epi16(a, b), pair));
        acc[1] = _mm_add_epi32(acc[1], _mm_madd_epi16(_mm_unpackhi_epi16(a, b), pair));
    }

    /// The weights of the (up to four) words in lanes 0–3 of `words`, as 16-bit lanes
    /// `[w0, w1, w2, w3, w0, w1, w2, w3]`: the weight is the word's top 24 bits, which fit 16.
    #[target_feature(enable = "sse2")]
    #[inline]
    fn weights16(words: __m128i) -> __m128i {
        let w = _mm_srai_epi32::<8>(words);
        _mm_packs_epi32(w, w)
    }

    /// The little-endian word at byte `at` of a chunk (in range: the callers' chunks are
    /// fixed-size arrays).
    #[inline(always)]
    fn word<const N: usize>(chunk: &[u8; N], at: usize) -> u32 {
        u32::from_le_bytes([chunk[at], chunk[at + 1], chunk[at + 2], chunk[at + 3]])
    }

    /// What every vertex of a frame reads: the displacement table and the rounding constants.
    #[derive(Clone, Copy, Debug)]
    pub(crate) struct Frame {
        /// One [`entry`] per marker index.
        table: [__m128i; MAX_MARKERS],
        /// [`SUM_HALF`] in every 32-bit lane.
        half: __m128i,
    }

    impl Frame {
        #[target_feature(enable = "sse2")]
        fn new(d: &Displacements) -> Self {
            let mut table = [_mm_setzero_si128(); MAX_MARKERS];
            for (t, &d) in table.iter_mut().zip(d) {
                *t = entry(d);
            }
            Self {
                table,
                half: _mm_set1_epi32(SUM_HALF),
            }
        }

        /// The table entry of marker `i`: a u8 index into a 256-entry array, in range by
        /// construction.
        #[target_feature(enable = "sse2")]
        #[inline]
        fn t(&self, i: u8) -> __m128i {
            self.table[usize::from(i)]
        }

        /// One vertex: its influence words and rest bytes in, its position out.
        #[target_feature(enable = "sse2")]
        #[inline]
        fn vertex(&self, words: &[u8], r: &[u8], o: &mut [i32; 3]) {
            let mut acc = [_mm_setzero_si128(); 2];
            let mut quads = words.chunks_exact(16);
            for q in &mut quads {
                let q: &[u8; 16] = q.try_into().unwrap_or(&[0; 16]);
                let u = [word(q, 0), word(q, 4), word(q, 8), word(q, 12)];
                let w = weights16(_mm_set_epi32(
                    u[3] as i32,
                    u[2] as i32,
                    u[1] as i32,
                    u[0] as i32,
                ));
                let m = [u[0] as u8, u[1] as u8, u[2] as u8, u[3] as u8];
                let pair01 = _mm_shuffle_epi32::<0b00_00_00_00>(w);
                let pair23 = _mm_shuffle_epi32::<0b01_01_01_01>(w);
                madd_pair(&mut acc, self.t(m[0]), self.t(m[1]), pair01);
                madd_pair(&mut acc, self.t(m[2]), self.t(m[3]), pair23);
            }
            let mut pairs = quads.remainder().chunks_exact(8);
            for p in &mut pairs {
                let p: &[u8; 8] = p.try_into().unwrap_or(&[0; 8]);
                let u = [word(p, 0), word(p, 4)];
                let w = weights16(_mm_set_epi32(0, 0, u[1] as i32, u[0] as i32));
                let (a, b) = (self.t(u[0] as u8), self.t(u[1] as u8));
                madd_pair(&mut acc, a, b, _mm_shuffle_epi32::<0>(w));
            }
            if let Ok(single) = <&[u8; 4]>::try_from(pairs.remainder()) {
                // The odd influence, paired with a zero weight on a zero entry.
                let u = u32::from_le_bytes(*single);
                let w = _mm_shuffle_epi32::<0>(weights16(_mm_cvtsi32_si128(u as i32)));
                madd_pair(&mut acc, self.t(u as u8), _mm_setzero_si128(), w);
            }
            // rest (Q0.15) in the high halves of 32-bit lanes, shifted down to Q8.24.
            let r: &[u8; REST_BYTES] = r.try_into().unwrap_or(&[0; REST_BYTES]);
            let rest16 = _mm_cvtsi64_si128(i64::from_le_bytes([
                r[0], r[1], r[2], r[3], r[4], r[5], 0, 0,
            ]));
            let rest = _mm_srai_epi32::<{ 16 - crate::fixed::REST_SHIFT as i32 }>(
                _mm_unpacklo_epi16(_mm_setzero_si128(), rest16),
            );
            // (H · 2^16 + L + 2^14) >> 15 = 2 · H + ((L + 2^14) >> 15) (the module docs).
            let lo = _mm_srai_epi32::<{ SUM_SHIFT as i32 }>(_mm_add_epi32(acc[1], self.half));
            let hi = _mm_slli_epi32::<{ 16 - SUM_SHIFT as i32 }>(acc[0]);
            let sum = _mm_add_epi32(_mm_add_epi32(hi, lo), rest);
            let xy = _mm_cvtsi128_si64(sum);
            *o = [
                xy as i32,
                (xy >> 32) as i32,
                _mm_cvtsi128_si32(_mm_shuffle_epi32::<0b10>(sum)),
            ];
        }
    }

    /// See [`super::deform`]; `d` is the scaled displacement table.
    #[target_feature(enable = "sse2")]
    pub(crate) fn deform(d: &Displacements, rig: Sections<'_>, out: &mut [[i32; 3]]) {
        deform_vertices(&Frame::new(d), rig, out);
    }

    /// Every vertex of `rig` from this frame's `frame`.
    #[target_feature(enable = "sse2")]
    fn deform_vertices(frame: &Frame, rig: Sections<'_>, out: &mut [[i32; 3]]) {
        rig.for_each_vertex(out, |words, r, o| frame.vertex(words, r, o));
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use std::{vec, vec::Vec};

    use super::*;
    use crate::fixed::{pack_influence, unpack_influence, widen_rest, LINEAR_WEIGHT_ABS_SUM_MAX};

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
    /// markers, weights summing to 2^F with Σ|w| as large as the loader allows.
    struct Case {
        frac: u8,
        rest: Vec<u8>,
        counts: Vec<u8>,
        words: Vec<u8>,
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
        let (mut rest, mut counts, mut words) = (vec![], vec![], vec![]);
        for _ in 0..vertices {
            for _ in 0..3 {
                rest.extend_from_slice(&(rng.next() as i16).to_le_bytes());
            }
            let n = if uniform {
                usize::from(k)
            } else {
                rng.below(u64::from(k) + 1) as usize
            };
            counts.push(n as u8);
            // Weights with large magnitudes of both signs, fixed up to sum to 2^F and kept
            // within the Σ|w| bound (scaled down until they fit).
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
            for x in w {
                let m = rng.below(markers as u64) as u8;
                words.extend_from_slice(&pack_influence(m, x).unwrap().to_le_bytes());
            }
        }
        Case {
            frac,
            rest,
            counts,
            words,
            markers,
        }
    }

    /// The deformer's formula (the first one in the module docs) evaluated in i128 from the
    /// markers, with no cleverness: the contract both implementations must meet bit for bit.
    fn reference(c: &Case, markers: &[[i32; 3]], marker_rest: &[u8]) -> Vec<[i32; 3]> {
        let limit = i128::from(linear_displacement_limit(u32::from(c.frac)));
        let d: Vec<[i128; 3]> = markers
            .iter()
            .zip(marker_rest.chunks_exact(POSITION_BYTES))
            .map(|(m, r)| {
                let r = read_position(r);
                [0, 1, 2].map(|a| (i128::from(m[a]) - i128::from(r[a])).clamp(-limit, limit))
            })
            .collect();
        let mut out = vec![];
        let mut words = c.words.chunks_exact(INFLUENCE_BYTES);
        for (r, &n) in c.rest.chunks_exact(REST_BYTES).zip(&c.counts) {
            let mut acc = [0i128; 3];
            for w in words.by_ref().take(usize::from(n)) {
                let (m, w) = unpack_influence(u32::from_le_bytes([w[0], w[1], w[2], w[3]]));
                for a in 0..3 {
                    acc[a] += i128::from(w) * d[usize::from(m)][a];
                }
            }
            let v = [0, 1, 2].map(|a| {
                let rest = widen_rest(i16::from_le_bytes([r[2 * a], r[2 * a + 1]]));
                let x = i128::from(rest) + ((acc[a] + (1 << (c.frac - 1))) >> c.frac);
                i32::try_from(x).expect("the module's bound: no overflow")
            });
            out.push(v);
        }
        out
    }

    /// Marker positions: extreme, large and small displacements from random rest positions.
    fn frame(rng: &mut Rng, c: &Case) -> (Vec<[i32; 3]>, Vec<u8>) {
        let mut rest = vec![];
        let mut markers = vec![];
        for j in 0..c.markers {
            let r = [0; 3].map(|_| (rng.next() as i32) >> 6);
            for x in r {
                rest.extend_from_slice(&x.to_le_bytes());
            }
            let m = r.map(|x| match (j + rng.below(4) as usize) % 4 {
                0 => rng.next() as i32,
                1 => x.wrapping_add((rng.next() as i32) >> 3),
                2 => x.wrapping_add((rng.next() as i32) >> 20),
                _ => [i32::MIN, i32::MAX][rng.below(2) as usize],
            });
            markers.push(m);
        }
        (markers, rest)
    }

    #[test]
    fn every_implementation_matches_the_exact_formula() {
        let mut rng = Rng(0x1234_5678_9ABC_DEF1);
        for trial in 0..60 {
            let frac = [8u8, 11, 13, 14][trial % 4];
            let markers = [1, 7, 40, 256][(trial % 4) ^ ((trial / 4) % 4)];
            // Every third trial has K = 4 or 8 everywhere: the specialised loops.
            let (k, uniform) = match trial % 3 {
                0 => ([4, 8][trial % 2], true),
                _ => ([1, 3, 4, 8, 9, 64][trial % 6], false),
            };
            // Vertex counts of every remainder modulo 4 (the count scan reads four at a time).
            let c = case(&mut rng, frac, markers, 297 + trial % 4, k, uniform);
            let (m, mrest) = frame(&mut rng, &c);
            let d = displacements(&m, &mrest, frac);
            let want = reference(&c, &m, &mrest);
            let mut got = vec![[0; 3]; want.len()];
            let rig = Sections {
                rest: &c.rest,
                counts: &c.counts,
                influences: &c.words,
                uniform: crate::deformer::contract::uniform(&c.counts),
            };
            portable::unrolled(&d, rig, &mut got);
            assert_eq!(got, want, "portable, trial {trial}");
            let mut rolled = vec![[2; 3]; want.len()];
            portable::rolled(&d, rig, &mut rolled);
            assert_eq!(rolled, want, "portable rolled, trial {trial}");
            #[cfg(all(target_arch = "x86_64", target_feature = "sse2"))]
            {
                let mut simd = vec![[1; 3]; want.len()];
                sse2::deform_checked(&d, rig, &mut simd);
                assert_eq!(simd, want, "sse2, trial {trial}");
            }
        }
    }

    #[test]
    fn common_count_is_the_count_every_vertex_has() {
        let of = |counts: &[u8]| {
            Sections {
                rest: &[],
                counts,
                influences: &[],
                uniform: crate::deformer::contract::uniform(counts),
            }
            .common_count()
        };
        assert_eq!(of(&[8; 7]), Some(8));
        assert_eq!(of(&[4; 8]), Some(4));
        assert_eq!(of(&[3]), Some(3));
        // One different count anywhere, in the words read four at a time or in the tail.
        for at in 0..7 {
            let mut counts = [8; 7];
            counts[at] = 7;
            assert_eq!(of(&counts), None, "differs at {at}");
        }
        assert_eq!(of(&[0; 5]), None);
        assert_eq!(of(&[]), None);
    }

    #[test]
    fn displacements_clamp_at_the_limit() {
        let rest: Vec<u8> = [5i32, -5, 0].iter().flat_map(|x| x.to_le_bytes()).collect();
        for frac in [8u8, 14] {
            // The limit 2^(15+F), scaled by 2^(15−F): 2^30 whatever F.
            let scale = 1 << (15 - frac);
            let d = displacements(&[[i32::MAX, i32::MIN, 77]], &rest, frac);
            assert_eq!(d[0], [0, 1 << 30, -(1 << 30), 77 * scale]);
            assert_eq!(d[1], [0; 4]);
        }
    }
}
