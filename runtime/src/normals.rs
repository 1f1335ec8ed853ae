//! Deformed vertex normals: [`Normals`], the blob's normals section, and the per-frame call
//! behind [`crate::Rig::normals`].
//!
//! # Method
//!
//! Area-weighted vertex normals recomputed from the deformed positions, over the mesh's
//! triangles baked as per-vertex **fans**: for each vertex that owns its normal, the other
//! corners of the triangles around it as one **chain** c₀, c₁, …, cₙ in which every two
//! consecutive corners (cᵢ₋₁, cᵢ) are one triangle's other two corners in winding order (around
//! an inside vertex the triangles link up, so n triangles take n + 1 corners; runs that do not
//! link are separated by the vertex itself, whose edge is zero), so that
//!
//! ```text
//! eᵢ = clamp(p[cᵢ] − p[v], ±2²⁶)                                       Q8.24, i64
//! s  = Σᵢ₌₁..ₙ eᵢ₋₁ × eᵢ                                                i64, exact
//! n[v] = s / |s|                                                       Q1.14, via 1/√
//! ```
//!
//! `eᵢ₋₁ × eᵢ` is twice the triangle's area along its normal, so `s` weights each triangle by
//! its area (as the baker's f64 reference does). The cross products are exact integers: every
//! corner of a triangle gives bit for bit the same vector, so computing it once per corner
//! instead of once per triangle costs multiplies but needs no scratch buffer (the runtime has
//! no heap) and no scattered writes, and each vertex's normal depends on its own fan only.
//! Chained, each corner's edge is taken once (a fan of triangle pairs took two per triangle).
//! The fans of 16 vertices are summed before they are normalised (384 bytes of stack), so the
//! processor overlaps the normalisations' multiply chains.

//! **Seams** (vertices split for UVs or hard edges but sharing a rest position) are welded: the
//! baker gives the fan to one vertex of each group, the canonical one, over the canonical
//! vertices of its neighbours; every other vertex of the group is listed in `welds` and gets a
//! copy of its canonical vertex's normal, so split vertices get identical normals.
//!
//! **Overflow, by design**: an edge's axis saturates at ±[`NORMAL_EDGE_LIMIT`] (four rig units,
//! twice the mesh's extent; only an absurd pose gets there), so a cross component is below 2⁵³
//! and a fan of at most 255 corners sums below 2⁶¹.
//!
//! **Normalisation**: `s` is shifted (exactly, by a power of two) so that its largest component
//! lies in [2³⁰, 2³¹), its squared length (below 3 · 2⁶², a `u64`) goes through a table-seeded
//! integer 1/√ (`sqrt::rsqrt_table`: 384 values and one Newton step, relative error
//! below 2⁻¹⁷; the capture stages' five-step `rsqrt_u64` cost twice the whole normals pass for
//! precision Q1.14 cannot hold) and each component is multiplied by the root, rounded half up
//! to Q1.14 and clamped to ±1: within ⅝ LSB of the exact unit vector. No division, no loop.
//!
//! **Degenerate fans**: a vertex whose fan sums to the zero vector (its triangles collapsed to
//! lines or points), and a vertex in no triangle, gets its baked rest normal.
//!
//! **Planned** ([`crate::Rig::normals_planned`]): a caller that can spare a sum per vertex
//! (24 bytes) and a triangle list (12 bytes a triangle) takes each triangle's cross product
//! once instead of once per corner. [`crate::Rig::plan_normals`] lists every triangle once,
//! from the fan of its lowest-numbered vertex (`v < a` and `v < b` for a consecutive pair
//! `a`, `b`), as `(v, a, b)`; a frame zeroes the sums, adds each triangle's
//! `(p[a] − p[v]) × (p[b] − p[v])` to its three vertices' sums and normalises them as above.
//! A triangle's cross product is the same integer vector from each of its corners, and integer
//! sums do not depend on their order, so in a rig `bake` writes (every triangle in the fan of
//! each of its vertices) every vertex sums the very terms its fan does and the normals are bit
//! for bit those of [`crate::Rig::normals`]. A third of the multiplies, but scattered writes:
//! poses beyond ±2 rig units, whose clamped edges differ by corner, take the fans.
//!
//! Cost per call ([`NormalsCost`]): per fan corner one edge subtraction and clamp per axis and
//! (but for the first) one cross product (6 multiplies); per vertex with a fan one normalisation (a table look-up,
//! one Newton step and six multiplies); per weld one copy. The cost is bounded, not constant:
//! it branches on the positions twice, once per call (the clamp-free loop when every position
//! is within ±2 rig units) and once per vertex (the degenerate-fan fallback).

use serde::{Deserialize, Serialize};

use crate::cost::NormalsCost;
use crate::error::{expect_len, LoadError, Section};
use crate::fixed::{NORMAL_EDGE_LIMIT, NORMAL_FRAC_BITS};
use crate::records::{Bytes, COUNT_BYTES, NORMAL_BYTES, VERTEX_INDEX_BYTES};
use crate::sqrt::rsqrt_table;

/// A rig's triangles, each once, for [`crate::Rig::normals_planned`]: made by
/// [`crate::Rig::plan_normals`] in a buffer the caller owns, and refused by any other rig.
#[derive(Clone, Copy, Debug)]
pub struct NormalsPlan<'p> {
    /// The rig that made it (as [`crate::FrameTable`] remembers its rig).
    pub(crate) owner: usize,
    /// `(v, a, b)` per triangle, in winding order, `v` its lowest-numbered vertex.
    pub(crate) triangles: &'p [[u32; 3]],
}

/// The normals section: what [`crate::Rig::normals`] needs besides the positions (layout:
/// [`crate::format::RigData`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Normals<'a> {
    /// Bytes of one vertex index in `corners` and `welds`: 2 (`u16`) or 4 (`u32`), LE.
    pub index_bytes: u8,
    /// Per vertex, the rest pose's unit normal, 3 × `i16` LE, Q1.14: the fallback for a vertex
    /// without area.
    #[serde(borrow)]
    pub rest: Bytes<'a>,
    /// Per vertex, how many corners its chained fan has (`u8`); 0 for a welded vertex and a
    /// vertex in no triangle.
    #[serde(borrow)]
    pub fan_counts: Bytes<'a>,
    /// The fans, vertex after vertex, one vertex index per corner: each two consecutive corners
    /// of a fan are one triangle's other two corners in winding order, or include the vertex
    /// itself (a break between runs of linked triangles, which adds nothing).
    #[serde(borrow)]
    pub corners: Bytes<'a>,
    /// Per welded vertex, two vertex indices: the vertex (strictly ascending) and the vertex
    /// whose normal it copies (which has a fan).
    #[serde(borrow)]
    pub welds: Bytes<'a>,
}

impl Normals<'_> {
    /// Check the section against the vertex count: everything [`Self::compute`] relies on.
    pub(crate) fn validate(&self, vertices: usize) -> Result<(), LoadError> {
        if !VERTEX_INDEX_BYTES.contains(&self.index_bytes) {
            return Err(LoadError::BadIndexWidth {
                found: self.index_bytes,
            });
        }
        let width = usize::from(self.index_bytes);
        expect_len(Section::RestNormals, self.rest, vertices, NORMAL_BYTES)?;
        let one = 1i16 << NORMAL_FRAC_BITS;
        for (vertex, n) in self.rest.0.chunks_exact(NORMAL_BYTES).enumerate() {
            if read_normal(n).iter().any(|c| !(-one..=one).contains(c)) {
                return Err(LoadError::BadRestNormal { vertex });
            }
        }
        expect_len(Section::FanCounts, self.fan_counts, vertices, COUNT_BYTES)?;
        let corners: usize = self.fan_counts.0.iter().map(|&c| usize::from(c)).sum();
        expect_len(Section::Corners, self.corners, corners, width)?;
        let mut fan = self.corners.0.chunks_exact(width);
        for (vertex, &count) in self.fan_counts.0.iter().enumerate() {
            for corner in fan.by_ref().take(usize::from(count)) {
                let corner = read_index(corner);
                if corner as usize >= vertices {
                    return Err(LoadError::CornerOutOfRange { vertex, corner });
                }
            }
        }
        if !self.welds.0.len().is_multiple_of(2 * width) {
            return Err(LoadError::SectionLength {
                section: Section::Welds,
                expected: self.welds.0.len() / (2 * width) * 2 * width,
                found: self.welds.0.len(),
            });
        }
        let fan_count = |v: u32| self.fan_counts.0.get(v as usize).copied();
        let mut last = None;
        for (entry, pair) in self.welds.0.chunks_exact(2 * width).enumerate() {
            let (vertex, canonical) = (read_index(&pair[..width]), read_index(&pair[width..]));
            let ok = last.is_none_or(|l| vertex > l)
                && fan_count(vertex) == Some(0)
                && fan_count(canonical).is_some_and(|c| c > 0);
            if !ok {
                return Err(LoadError::BadWeld { entry });
            }
            last = Some(vertex);
        }
        Ok(())
    }

    /// The work of [`Self::compute`].
    pub(crate) fn cost(&self) -> NormalsCost {
        let width = usize::from(self.index_bytes).max(1);
        let corners = self.corners.0.len() / width;
        let normalisations = self.fan_counts.0.iter().filter(|&&c| c > 0).count();
        NormalsCost {
            vertices: self.fan_counts.0.len(),
            corners,
            // A fan of c corners has c − 1 cross products (6 each) and one normalisation (6).
            multiplies: 6 * corners,
            normalisations,
            welds: self.welds.0.len() / (2 * width),
        }
    }

    /// The unit normal of every vertex of the mesh at `positions` (Q8.24, one per vertex) into
    /// `out` (Q1.14, one per vertex): both have the rig's vertex count (the caller checked), and
    /// the section was validated against it. Never fails.
    pub(crate) fn compute(&self, positions: &[[i32; 3]], out: &mut [[i16; 3]]) {
        // Within ±2 rig units no edge exceeds the limit, so the clamp cannot bind: the same
        // integers without it.
        match (self.index_bytes == 2, clamp_free(positions)) {
            (true, true) => self.compute_with::<2, false>(positions, out),
            (true, false) => self.compute_with::<2, true>(positions, out),
            (false, true) => self.compute_with::<4, false>(positions, out),
            (false, false) => self.compute_with::<4, true>(positions, out),
        }
    }

    /// [`Self::compute`] with `W`-byte vertex indices, clamping the edges when `CLAMP`.
    #[inline(always)]
    fn compute_with<const W: usize, const CLAMP: bool>(
        &self,
        positions: &[[i32; 3]],
        out: &mut [[i16; 3]],
    ) {
        let at = |i: u32| positions.get(i as usize).copied().unwrap_or_default();
        let mut corners = self.corners.0;
        // Sums for a block of vertices, then their normalisations: each normalisation is one
        // long chain of dependent multiplies, and a block's are independent of each other, so
        // the processor overlaps them (a third less time than normalising after each fan).
        for (((out, counts), positions_), rest) in out
            .chunks_mut(NORMALS_BLOCK)
            .zip(self.fan_counts.0.chunks(NORMALS_BLOCK))
            .zip(positions.chunks(NORMALS_BLOCK))
            .zip(self.rest.0.chunks(NORMALS_BLOCK * NORMAL_BYTES))
        {
            let mut sums = [[0i64; 3]; NORMALS_BLOCK];
            for ((total, &count), p) in sums.iter_mut().zip(counts).zip(positions_) {
                let (fan, others) = corners
                    .split_at_checked(W * usize::from(count))
                    .unwrap_or_default();
                corners = others;
                let Some((first, fan)) = fan.split_at_checked(W) else {
                    continue;
                };
                // Each corner's edge is taken once and crossed with the one before it.
                let mut previous = edge::<CLAMP>(at(read_index(first)), *p);
                let mut sum = [0i64; 3];
                for corner in fan.chunks_exact(W) {
                    let e = edge::<CLAMP>(at(read_index(corner)), *p);
                    let c = cross(previous, e);
                    sum = [sum[0] + c[0], sum[1] + c[1], sum[2] + c[2]];
                    previous = e;
                }
                *total = sum;
            }
            for ((n, sum), rest) in out
                .iter_mut()
                .zip(&sums)
                .zip(rest.chunks_exact(NORMAL_BYTES))
            {
                *n = unit_q14(*sum).unwrap_or_else(|| read_normal(rest));
            }
        }
        self.copy_welds(out);
    }

    /// Triangles [`Self::plan`] lists: the consecutive corner pairs of the fans that are a
    /// triangle whose lowest-numbered vertex is the fan's own.
    pub(crate) fn plan_len(&self) -> usize {
        let mut triangles = 0;
        self.owned_triangles(|_| triangles += 1);
        triangles
    }

    /// Every triangle once, as `(v, a, b)` in winding order with `v` its lowest-numbered vertex,
    /// into `plan` ([`Self::plan_len`] long: the caller checked).
    pub(crate) fn plan(&self, plan: &mut [[u32; 3]]) {
        let mut slots = plan.iter_mut();
        self.owned_triangles(|t| {
            if let Some(slot) = slots.next() {
                *slot = t;
            }
        });
    }

    /// Call `f` with each triangle of the fans whose lowest-numbered vertex is the fan's own.
    fn owned_triangles(&self, mut f: impl FnMut([u32; 3])) {
        let width = usize::from(self.index_bytes).max(1);
        let mut corners = self.corners.0;
        for (v, &count) in (0u32..).zip(self.fan_counts.0) {
            let (fan, others) = corners
                .split_at_checked(width * usize::from(count))
                .unwrap_or_default();
            corners = others;
            let mut fan = fan.chunks_exact(width).map(read_index);
            let Some(mut a) = fan.next() else {
                continue;
            };
            for b in fan {
                if v < a && v < b {
                    f([v, a, b]);
                }
                a = b;
            }
        }
    }

    /// [`Self::compute`] over the triangles of `plan` (made by [`Self::plan`] for this section)
    /// with one sum per vertex in `sums`; `positions`, `sums` and `out` have the vertex count
    /// (the caller checked). The same normals (see the module docs).
    pub(crate) fn compute_planned(
        &self,
        positions: &[[i32; 3]],
        plan: &[[u32; 3]],
        sums: &mut [[i64; 3]],
        out: &mut [[i16; 3]],
    ) {
        if !clamp_free(positions) {
            self.compute(positions, out);
            return;
        }
        sums.fill([0; 3]);
        // The plan's indices are this rig's vertices (`Rig::normals_planned` checked whose plan
        // it is): clamping them to the last vertex changes none and lets the compiler drop the
        // bounds checks (a third fewer instructions than checked look-ups).
        let n = positions.len().min(sums.len());
        let Some(last) = n.checked_sub(1) else {
            return;
        };
        let (positions, sums) = (&positions[..n], &mut sums[..n]);
        for &[v, a, b] in plan {
            let [v, a, b] = [v, a, b].map(|i| (i as usize).min(last));
            let p = positions[v];
            let c = cross(edge::<false>(positions[a], p), edge::<false>(positions[b], p));
            for i in [v, a, b] {
                // A rig `bake` writes lists each triangle in the fan of each of its vertices, so
                // a sum takes its fan's terms (at most 254, below 2⁶¹); wrapping keeps a crafted
                // plan or blob, with a vertex in more triangles, from overflowing.
                let s = &mut sums[i];
                *s = [0, 1, 2].map(|k| s[k].wrapping_add(c[k]));
            }
        }
        for ((n, sum), rest) in out
            .iter_mut()
            .zip(sums.iter())
            .zip(self.rest.0.chunks_exact(NORMAL_BYTES))
        {
            *n = unit_q14(*sum).unwrap_or_else(|| read_normal(rest));
        }
        self.copy_welds(out);
    }

    /// Give every welded vertex its canonical vertex's normal.
    fn copy_welds(&self, out: &mut [[i16; 3]]) {
        let width = usize::from(self.index_bytes).max(1);
        for pair in self.welds.0.chunks_exact(2 * width) {
            let (vertex, canonical) = (read_index(&pair[..width]), read_index(&pair[width..]));
            if let Some(&copy) = out.get(canonical as usize) {
                if let Some(n) = out.get_mut(vertex as usize) {
                    *n = copy;
                }
            }
        }
    }

    /// The stored rest normal of vertex `i` (Q1.14), or `None` past the last vertex.
    pub(crate) fn rest_normal(&self, i: usize) -> Option<[i16; 3]> {
        self.rest.0.chunks_exact(NORMAL_BYTES).nth(i).map(read_normal)
    }
}

/// Every position within ±2 rig units (half [`NORMAL_EDGE_LIMIT`]), so that no edge reaches
/// the limit and the clamp cannot bind.
fn clamp_free(positions: &[[i32; 3]]) -> bool {
    let half = NORMAL_EDGE_LIMIT / 2;
    positions
        .iter()
        .flatten()
        .all(|&c| (-half..=half).contains(&i64::from(c)))
}

/// Vertices whose fan sums [`Normals::compute`] takes before it normalises them.
const NORMALS_BLOCK: usize = 16;

/// `b − a` per axis, saturated to ±[`NORMAL_EDGE_LIMIT`] when `CLAMP` (the caller
/// leaves it out only where it cannot bind).
#[inline(always)]
#[allow(clippy::useless_conversion)] // the identity where `Edge` is `i32`
fn edge<const CLAMP: bool>(b: [i32; 3], a: [i32; 3]) -> [Edge; 3] {
    [0, 1, 2].map(|c| {
        if CLAMP {
            // A difference beyond the `Edge` saturates with its sign (only an `i32` can), so
            // the clamp gives what clamping the exact difference gives; one `QSUB` on a
            // Cortex-M4 instead of 64-bit arithmetic.
            let limit = NORMAL_EDGE_LIMIT as Edge;
            Edge::from(b[c])
                .saturating_sub(Edge::from(a[c]))
                .clamp(-limit, limit)
        } else {
            // Both within ±2^25 (the caller checked): the difference is within ±2^26.
            Edge::from(b[c]).wrapping_sub(Edge::from(a[c]))
        }
    })
}

/// One axis of an edge, within ±[`NORMAL_EDGE_LIMIT`]: `i64` on 64-bit targets (x86-64 and
/// AArch64 multiply 64-bit registers as fast as 32-bit ones, and skip the sign extensions),
/// `i32` on 32-bit ones (each product one widening `SMULL` on a Cortex-M4: a quarter fewer
/// instructions there). The same values either way, so the same normals.
#[cfg(target_pointer_width = "64")]
type Edge = i64;
/// See the 64-bit definition.
#[cfg(not(target_pointer_width = "64"))]
type Edge = i32;

/// `u × v` in `i64`, exact for edges within ±[`NORMAL_EDGE_LIMIT`] (each product below 2⁵²,
/// each component below 2⁵³).
#[inline(always)]
#[allow(clippy::useless_conversion)] // the identity where `Edge` is `i64`
fn cross(u: [Edge; 3], v: [Edge; 3]) -> [i64; 3] {
    let m = |a: Edge, b: Edge| i64::from(a) * i64::from(b);
    [
        m(u[1], v[2]) - m(u[2], v[1]),
        m(u[2], v[0]) - m(u[0], v[2]),
        m(u[0], v[1]) - m(u[1], v[0]),
    ]
}

/// The unit vector along `s` in Q1.14, or `None` for the zero vector (see the module docs).
#[inline(always)]
pub(crate) fn unit_q14(s: [i64; 3]) -> Option<[i16; 3]> {
    let largest = s.iter().map(|c| c.unsigned_abs()).max().unwrap_or(0);
    // Bring the largest magnitude into [2^30, 2^31): its highest set bit to bit 30.
    let shift = (63 - largest.leading_zeros() as i32) - 30;
    let scaled = s.map(|c| if shift >= 0 { c >> shift } else { c << -shift });
    // |c| < 2^31: three squares sum below 3 · 2^62 < 2^64.
    let sum = scaled.iter().map(|&c| (c * c) as u64).sum::<u64>();
    // None exactly when s is zero: a non-zero s has a scaled component of at least 2^30.
    let (root, root_shift) = rsqrt_table(sum)?;
    // |c| · root < 2^31 · 2^31; the sum is at least 2^60, so root_shift ≥ 60 and the shift to
    // Q1.14 is at least 46.
    let down = root_shift - NORMAL_FRAC_BITS;
    let half = 1i64 << (down - 1);
    // |c| ≤ |s| and the root is within 2^−17 of 1/√sum: the result is within 2^14 + 1, and
    // clamped to the unit.
    let one = 1i64 << NORMAL_FRAC_BITS;
    Some(scaled.map(|c| ((c * i64::from(root) + half) >> down).clamp(-one, one) as i16))
}

/// Decode one vertex index of `W` = `b.len()` bytes (2 or 4, LE).
#[inline(always)]
fn read_index(b: &[u8]) -> u32 {
    match *b {
        [lo, hi] => u32::from(u16::from_le_bytes([lo, hi])),
        [b0, b1, b2, b3] => u32::from_le_bytes([b0, b1, b2, b3]),
        _ => u32::MAX,
    }
}

/// Decode one stored normal (3 × `i16` LE, Q1.14) from a [`NORMAL_BYTES`]-long chunk.
#[inline(always)]
pub(crate) fn read_normal(b: &[u8]) -> [i16; 3] {
    let b: [u8; NORMAL_BYTES] = b.try_into().unwrap_or([0; NORMAL_BYTES]);
    [0, 1, 2].map(|c| i16::from_le_bytes([b[2 * c], b[2 * c + 1]]))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unit_q14_is_within_five_eighths_of_an_lsb_of_the_exact_unit_vector() {
        assert_eq!(unit_q14([0, 0, 0]), None);
        assert_eq!(unit_q14([5, 0, 0]), Some([1 << 14, 0, 0]));
        assert_eq!(unit_q14([0, 0, -(1 << 61)]), Some([0, 0, -(1 << 14)]));
        assert_eq!(unit_q14([3, 4, 0]), Some([9830, 13107, 0]));
        let mut s = 0x9E37_79B9_7F4A_7C15u64;
        for _ in 0..20_000 {
            let mut v = [0i64; 3];
            for c in &mut v {
                s ^= s << 13;
                s ^= s >> 7;
                s ^= s << 17;
                *c = (s as i64) >> (3 + s % 60);
            }
            let Some(u) = unit_q14(v) else {
                assert_eq!(v, [0, 0, 0]);
                continue;
            };
            let len = v.iter().map(|&c| (c as f64).powi(2)).sum::<f64>().sqrt();
            for (c, q) in v.iter().zip(u) {
                let exact = *c as f64 / len * 16384.0;
                assert!((f64::from(q) - exact).abs() <= 0.625, "{v:?} → {u:?}");
            }
        }
    }

    #[test]
    fn edges_saturate_and_cross_products_stay_in_range() {
        let far = edge::<true>([i32::MAX; 3], [i32::MIN; 3]);
        const L: Edge = NORMAL_EDGE_LIMIT as Edge;
        assert_eq!(far, [L; 3]);
        let near = edge::<false>([1 << 25; 3], [-(1 << 25); 3]);
        assert_eq!(near, [L; 3]);
        let c = cross([L, -L, L], [-L, -L, L]);
        assert!(c.iter().all(|x| x.unsigned_abs() <= 1 << 53));
        // A full fan of 255 such corners sums without overflow.
        let worst = cross([L, L, 0], [-L, L, 0])[2];
        assert_eq!(worst, 1 << 53);
        let fan = (0..u8::MAX).try_fold(0i64, |acc, _| acc.checked_add(worst));
        assert!(fan.is_some_and(|s| s < 1 << 61));
    }
}
