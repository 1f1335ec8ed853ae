//! The planar deformer, planar bones (paper 000 §4.1–4.2): vertices ride the frames of marker
//! triangles.
//!
//! Per frame, two stages:
//!
//! 1. **Frames**, once per control triangle (O, P, Q) = (V₀, V₁, V₂): the edges
//!    e_i = V_{i+1} − V_i (Q8.24, saturated to ±2³⁰, i.e. 64 rig units: the mesh spans ±1),
//!    the unit normal
//!    n = unit(e₀ × (V₂ − V₀)) and the unit in-plane edge normals u_i = unit(e_i × n), both Q1.30
//!    from `sqrt::normalize3` (each component within 2 LSB of the exact unit vector). The cross
//!    products are taken on the edges shifted right until every component is below 2³⁰, so
//!    they fit `i64` whatever the marker positions; the shift only drops low bits of large
//!    edges (a relative change below 2⁻³⁰).
//! 2. **Vertices**: each of a vertex's influences places it with its region's transform
//!    (see [`PlanarDeformer`] for the table): products of an `i32` coordinate and a frame component
//!    of at most 2³⁰ in magnitude, so each below 2⁶¹, in `i64`: a ratio (Q6.26) times an edge
//!    is Q.50, a length (Q8.24) times a unit vector Q.54, shifted right by 4 to Q.50 where the
//!    two meet (R_A, R_B); every sum stays below 1.5 · 2⁶² (no overflow). The sum is narrowed to
//!    Q8.24 with rounding and saturation and added (saturating) to the region's origin marker. The vertex is the
//!    weighted sum of those positions with Q1.15 weights that sum to exactly 2¹⁵, so a uniform
//!    translation of every marker moves every vertex by exactly that translation. Apex regions
//!    (R_C,i) normalise their in-plane direction once more (eq 10's scaling D/d). The centroid
//!    region (R_T, not in the paper) only translates: the sum of the triangle's three markers
//!    (each below 2³¹ in magnitude) plus three times the stored offset, below 6 · 2³¹ in `i64`,
//!    divided by three with rounding to nearest, saturated to `i32`.
//!
//! # Degenerate triangles
//!
//! A control triangle is **degenerate** in a frame when twice its area is at most 2⁻¹⁰ of its
//! longest edge squared ([`DEGENERATE_LOG2`]): collinear or coincident markers, for instance a
//! marker knocked out and rebuilt onto a line. Its orientation is then meaningless, so the
//! deformer uses the triangle's **rest** frame (rest edges, normal and edge normals) placed at the
//! current markers: its vertices translate with the region's origin marker instead of flying
//! off. The frame call reports every such triangle. The loader rejects triangles degenerate at
//! rest, so the fallback always exists. The fallback costs one more frame build for that
//! triangle: per-frame work is bounded by two frame builds per triangle.
//!
//! # Cost
//!
//! `triangles × (frame build: 4 normalisations)` (twice that at worst, see above) plus
//! `influences × (12 multiply-adds, 1 narrowing)` (a centroid influence takes fewer: additions
//! and a division by three) plus one normalisation per apex influence, plus per vertex three
//! narrowings. No loop depends on marker data.

use serde::{Deserialize, Serialize};

use crate::cost::{Cost, NormalsCost};
use crate::deformer::contract::{
    check, counted_range, DeformerSection, DegenerateTriangles, Shared,
};
use crate::fixed::round_shift_bounded;
use crate::error::{expect_len, LoadError, Section};
use crate::records::{
    read_position, Bytes, MAX_MARKERS, MAX_TRIANGLES, PLANAR_INFLUENCE_BYTES, POSITION_BYTES,
    TRIANGLE_BYTES,
};
use crate::sqrt::{normalize3, UNIT_FRAC_BITS};

/// Fractional bits of a planar weight (Q1.15: one is 2¹⁵).
pub const PLANAR_WEIGHT_FRAC_BITS: u8 = 15;
/// The region code of R_T, the triangle's centroid translated (no rotation): the last of the
/// codes R_A = 0, R_B,i = 1 + i, R_C,i = 4 + i, R_T = 7, which fill the record's 3 bits.
pub const CENTROID_REGION: u8 = 7;

/// The planar deformer's section (planar bones, paper 000 §4.1–4.2): a control surface of marker
/// triangles (layout: [`crate::format::RigData`]).
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
/// | R_T | C = (O + P + Q) / 3 | C′ + (x, y, z) | Q8.24 | Q8.24 | Q8.24 | 0 |
///
/// In R_C,i, w is the rest in-plane distance D_i(S) of eq 10, so the apex scaling D/d keeps it.
/// R_T is not in the paper: the point keeps its rest offset from the triangle's centroid and
/// does not turn with the triangle. The static anchoring's skull bone uses it, so that the
/// skin beyond the markers follows the skull markers' mean motion and a small turn of a
/// triangle of close markers is not magnified across the head.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PlanarDeformer<'a> {
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

/// One decoded planar influence record.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PlanarInfluence {
    /// Control triangle index.
    pub triangle: u16,
    /// Region code: 0 = R_A, 1 + i = R_B,i, 4 + i = R_C,i, 7 = R_T (3 bits: every code is
    /// valid).
    pub region: u8,
    /// Weight, Q1.15.
    pub weight: u16,
    /// Local coordinates x, y, z, w (formats per region: see [`PlanarDeformer`]).
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
#[cfg(feature = "format")]
pub fn write_planar_influence(i: &PlanarInfluence) -> Option<[u8; PLANAR_INFLUENCE_BYTES]> {
    if i.triangle > 0x1FFF || i.region > CENTROID_REGION {
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

/// A triangle is degenerate when 2 · area ≤ 2^−DEGENERATE_LOG2 · (longest edge)².
pub const DEGENERATE_LOG2: u32 = 10;

/// Fractional bits of a stored ratio coordinate (Q6.26: x and y of R_A, x of R_B).
pub const RATIO_FRAC_BITS: u32 = 26;
/// A ratio times an edge is Q.50 (26 + 24 fractional bits); a length times a unit vector is
/// Q.54 (24 + 30) and is shifted right by this much to join it.
const ALIGN: u32 = UNIT_FRAC_BITS - RATIO_FRAC_BITS;

/// Largest edge component magnitude in a frame (64 rig units): keeps every product of a frame
/// component and an `i32` coordinate below 2⁶¹.
const EDGE_LIMIT: i64 = 1 << 30;

/// The frame of an unused slot (never read: the loader checked every triangle index).
const NO_FRAME: Frame = Frame {
    e: [[0; 3]; 3],
    n: [0; 3],
    u: [[0; 3]; 3],
};

/// One control triangle's frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Frame {
    /// Edges e_i = V_{i+1} − V_i, Q8.24, saturated to ±2³⁰.
    pub e: [[i32; 3]; 3],
    /// Unit normal, Q1.30.
    pub n: [i32; 3],
    /// Unit in-plane edge normals u_i = unit(e_i × n) (outward for a counter-clockwise
    /// triangle seen from n), Q1.30.
    pub u: [[i32; 3]; 3],
}

fn cross(a: [i64; 3], b: [i64; 3]) -> [i64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn squared_norm(v: [i64; 3]) -> u128 {
    v.iter()
        .map(|&c| u128::from(c.unsigned_abs()) * u128::from(c.unsigned_abs()))
        .sum()
}

/// The frame of the triangle with corners `p` (Q8.24), or `None` if it is degenerate (see the
/// module docs). Fixed work: no loop depends on the positions.
pub fn build_frame(p: &[[i32; 3]; 3]) -> Option<Frame> {
    let wide: [[i64; 3]; 3] = [0, 1, 2].map(|i| {
        let (a, b) = (p[i], p[(i + 1) % 3]);
        [0, 1, 2].map(|c| i64::from(b[c]) - i64::from(a[c]))
    });
    let largest = wide
        .iter()
        .flatten()
        .map(|c| c.unsigned_abs())
        .max()
        .unwrap_or(0);
    // Differences of i32 are below 2^32: shift so every component is below 2^30.
    let bits = 64 - largest.leading_zeros();
    let shift = bits.saturating_sub(30);
    let r = wide.map(|e| e.map(|c| c >> shift));
    // n ∝ e0 × (V2 − V0) = e2 × e0; components below 2^61.
    let normal = cross(r[2], r[0]);
    let longest = r.iter().map(|&e| squared_norm(e)).max().unwrap_or(0);
    // |normal|² < 3 · 2^122 and longest² < 9 · 2^120: both fit u128.
    if squared_norm(normal) <= (longest * longest) >> (2 * DEGENERATE_LOG2) {
        return None;
    }
    let n = normalize3(normal)?;
    let n_wide = n.map(i64::from);
    let mut u = [[0i32; 3]; 3];
    for (ui, &ei) in u.iter_mut().zip(&r) {
        // |e| components < 2^30, |n| ≤ 2^30: each component below 2^61.
        *ui = normalize3(cross(ei, n_wide))?;
    }
    let e = wide.map(|e| e.map(|c| c.clamp(-EDGE_LIMIT, EDGE_LIMIT) as i32));
    Some(Frame { e, n, u })
}

/// Where a centroid influence (R_T) puts its vertex: the mean of the triangle's current
/// corners `p` plus the stored offset (Q8.24), rounded to nearest (a third is never halfway),
/// saturated.
#[inline(always)]
fn place_at_centroid(p: &[[i32; 3]; 3], coords: [i32; 4]) -> [i32; 3] {
    [0, 1, 2].map(|c| {
        // Four terms below 2^31 in magnitude, three of them counted thrice: below 6 · 2^31.
        let sum = p.iter().map(|q| i64::from(q[c])).sum::<i64>() + 3 * i64::from(coords[c]);
        // round(sum / 3) = floor((2 · sum + 3) / 6); 2 · sum + 3 < 2^35.
        (2 * sum + 3)
            .div_euclid(6)
            .clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32
    })
}

/// Rest position of marker `m` from the `marker_rest` section (validated: always present).
fn rest_marker(marker_rest: &[u8], m: usize) -> [i32; 3] {
    marker_rest
        .chunks_exact(POSITION_BYTES)
        .nth(m)
        .map(read_position)
        .unwrap_or([0; 3])
}

/// The triangle's corner positions, read from `points` by the triangle's marker indices.
fn corners(points: impl Fn(usize) -> [i32; 3], tri: &[u8]) -> [[i32; 3]; 3] {
    [0, 1, 2].map(|k| points(usize::from(tri.get(k).copied().unwrap_or(0))))
}

#[inline(always)]
fn mul(a: i32, b: i32) -> i64 {
    i64::from(a) * i64::from(b)
}

/// Where one influence puts its vertex: the region transform applied to the local coordinates
/// (Q8.24 out). `origin` is the current position of the region's origin marker.
#[inline(always)]
fn place(frame: &Frame, region: u8, coords: [i32; 4], origin: [i32; 3]) -> [i32; 3] {
    let [x, y, z, w] = coords;
    let n = frame.n;
    // Every frame component is at most 2^30 in magnitude: each product below 2^61; in R_A and
    // R_B the ratio terms (Q6.26 × Q8.24 = Q.50) add at most two such products and the Q.54
    // terms enter shifted down by 4 (below 2^58), in R_C two Q.54 products: every sum is below
    // 1.5 · 2^62, so plain adds cannot overflow (see the module docs).
    let (acc, frac): ([i64; 3], u32) = match region {
        0 => {
            // O + x e0 + y (Q − O) + z n, with Q − O = −e2: Q.50, the Q.54 term shifted down.
            let (e0, e2) = (frame.e[0], frame.e[2]);
            let acc = [0, 1, 2].map(|c| mul(x, e0[c]) - mul(y, e2[c]) + (mul(z, n[c]) >> ALIGN));
            (acc, RATIO_FRAC_BITS)
        }
        1..=3 => {
            let i = usize::from(region - 1);
            let (e, u) = (frame.e[i], frame.u[i]);
            let acc = [0, 1, 2].map(|c| mul(x, e[c]) + ((mul(y, u[c]) + mul(z, n[c])) >> ALIGN));
            (acc, RATIO_FRAC_BITS)
        }
        _ => {
            // Apex: direction from the two edge normals, length w (eq 10's D/d scaling): Q.54.
            let i = usize::from(region - 4) % 3;
            let (ui, uj) = (frame.u[i], frame.u[(i + 2) % 3]);
            let dir = [0, 1, 2].map(|c| mul(x, ui[c]) + mul(y, uj[c]));
            let unit = normalize3(dir).unwrap_or([0; 3]);
            let acc = [0, 1, 2].map(|c| mul(w, unit[c]) + mul(z, n[c]));
            (acc, UNIT_FRAC_BITS)
        }
    };
    // |acc| < 2^63 − 2^62 (see above), so adding the rounding half cannot overflow.
    [0, 1, 2].map(|c| origin[c].saturating_add(round_shift_bounded(acc[c], frac)))
}

/// The per-frame work of planar bones, shared by every vertex: each control triangle's frame
/// (its rest frame placed at the current markers when degenerate) and the current markers.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Frames {
    /// Per control triangle, its frame in this frame.
    frames: [Frame; MAX_TRIANGLES],
    /// The current markers, in rig order (later entries zero).
    markers: [[i32; 3]; MAX_MARKERS],
    /// The triangles that were degenerate.
    degenerate: DegenerateTriangles,
}

impl Frames {
    /// The triangles that were degenerate in this frame.
    pub(crate) fn degenerate(&self) -> DegenerateTriangles {
        self.degenerate
    }

    /// The frames of `planar`'s triangles at `markers` (one position per rig marker, checked by
    /// the caller); `marker_rest` and `planar` were validated at load.
    fn new(planar: &PlanarDeformer<'_>, marker_rest: &[u8], markers: &[[i32; 3]]) -> Self {
        let mut this = Self {
            frames: [Frame::default(); MAX_TRIANGLES],
            markers: [[0; 3]; MAX_MARKERS],
            degenerate: DegenerateTriangles::default(),
        };
        for (m, p) in this.markers.iter_mut().zip(markers) {
            *m = *p;
        }
        let current = |m: usize| markers.get(m).copied().unwrap_or([0; 3]);
        let rest = |m: usize| rest_marker(marker_rest, m);
        for (t, (frame, tri)) in this
            .frames
            .iter_mut()
            .zip(planar.triangles.0.chunks_exact(TRIANGLE_BYTES))
            .enumerate()
        {
            *frame = match build_frame(&corners(current, tri)) {
                Some(f) => f,
                None => {
                    this.degenerate.mark(t);
                    // The loader checked every rest triangle: the default is never taken.
                    build_frame(&corners(rest, tri)).unwrap_or_default()
                }
            };
        }
        this
    }
}

impl PlanarDeformer<'_> {
    /// The per-frame marker work of [`DeformerSection::deform`] for `markers` (one per rig
    /// marker, the caller checked), for [`Self::deform_prepared`].
    pub(crate) fn prepare(&self, rig: &Shared<'_>, markers: &[[i32; 3]]) -> Frames {
        Frames::new(self, rig.marker_rest, markers)
    }

    /// The vertices into `out` (one entry each, the caller checked) from this frame's
    /// `frames`: the integers [`DeformerSection::deform`] writes.
    pub(crate) fn deform_prepared(&self, frames: &Frames, out: &mut [[i32; 3]]) {
        place_vertices(self, frames, out);
    }
}

/// Deform one frame. `markers` has one position per rig marker (checked by the caller),
/// `marker_rest` and `planar` were validated at load, `out` has one entry per vertex.
#[inline(never)]
fn deform(
    planar: &PlanarDeformer<'_>,
    marker_rest: &[u8],
    markers: &[[i32; 3]],
    out: &mut [[i32; 3]],
) -> DegenerateTriangles {
    let frames = Frames::new(planar, marker_rest, markers);
    place_vertices(planar, &frames, out);
    frames.degenerate
}

/// Every vertex of `planar` (`out`: one entry each) from this frame's `frames`.
fn place_vertices(planar: &PlanarDeformer<'_>, frames: &Frames, out: &mut [[i32; 3]]) {
    let current = |m: usize| frames.markers.get(m).copied().unwrap_or([0; 3]);
    let frac = u32::from(PLANAR_WEIGHT_FRAC_BITS);
    let mut records = planar.influences.0;
    for (o, &count) in out.iter_mut().zip(planar.influence_counts.0) {
        let (mine, tail) = records
            .split_at_checked(PLANAR_INFLUENCE_BYTES * usize::from(count))
            .unwrap_or((records, &[]));
        records = tail;
        let mut acc = [0i64; 3];
        for r in mine.chunks_exact(PLANAR_INFLUENCE_BYTES) {
            let inf = read_planar_influence(r);
            let t = usize::from(inf.triangle);
            let frame = frames.frames.get(t).unwrap_or(&NO_FRAME);
            let tri = planar
                .triangles
                .0
                .get(TRIANGLE_BYTES * t..TRIANGLE_BYTES * (t + 1))
                .unwrap_or(&[0; TRIANGLE_BYTES]);
            let s = if inf.region == CENTROID_REGION {
                place_at_centroid(&corners(current, tri), inf.coords)
            } else {
                let corner = match inf.region {
                    0 => 0,
                    r => usize::from(r - 1) % 3,
                };
                place(frame, inf.region, inf.coords, current(usize::from(tri[corner])))
            };
            let weight = i32::from(inf.weight);
            for c in 0..3 {
                // ≤ 64 products of 2^15 and 2^31: below 2^52.
                acc[c] += i64::from(weight) * i64::from(s[c]);
            }
        }
        *o = acc.map(|a| round_shift_bounded(a, frac));
    }
}

/// The per-frame work of [`deform`] on a rig with `vertices` vertices and `markers` markers.
fn cost(planar: &PlanarDeformer<'_>, vertices: usize, markers: usize) -> Cost {
    let records = planar.influences.0.chunks_exact(PLANAR_INFLUENCE_BYTES);
    let influences = records.len();
    let apex = records
        .filter(|r| (4..CENTROID_REGION).contains(&read_planar_influence(r).region))
        .count();
    let triangles = usize::from(planar.triangle_count);
    Cost {
        vertices,
        markers,
        influences,
        max_influences: usize::from(planar.max_influences),
        coefficient_rows: 0,
        // Per influence: three products per axis and one weighted add per axis; an apex's
        // direction takes two products per axis before its two; per frame build: four cross
        // products (24) and the degeneracy test's squares (12).
        multiply_adds: 12 * influences + 3 * apex + 36 * triangles,
        subtractions: 9 * triangles,
        narrowings: 3 * influences + 3 * vertices,
        scratch_bytes: core::mem::size_of::<[Frame; MAX_TRIANGLES]>(),
        frame_builds: triangles,
        normalisations: 4 * triangles + apex,
        normals: NormalsCost::default(),
    }
}

/// Check a planar section against the rig's counts: everything the per-frame path relies on,
/// each failure with its own [`LoadError`].
fn validate(
    planar: &PlanarDeformer<'_>,
    marker_rest: &[u8],
    vertices: usize,
    markers: usize,
) -> Result<(), LoadError> {
    let k = planar.max_influences;
    check::max_influences(k)?;
    let triangles = usize::from(planar.triangle_count);
    if triangles == 0 || triangles > MAX_TRIANGLES {
        return Err(LoadError::BadTriangleCount {
            found: planar.triangle_count,
        });
    }
    expect_len(
        Section::Triangles,
        planar.triangles,
        triangles,
        TRIANGLE_BYTES,
    )?;
    let rest = |m: usize| rest_marker(marker_rest, m);
    for (triangle, tri) in planar.triangles.0.chunks_exact(TRIANGLE_BYTES).enumerate() {
        if let Some(&marker) = tri.iter().find(|&&m| usize::from(m) >= markers) {
            return Err(LoadError::TriangleMarkerOutOfRange { triangle, marker });
        }
        if build_frame(&corners(rest, tri)).is_none() {
            return Err(LoadError::DegenerateRestTriangle { triangle });
        }
    }
    check::counted_records(
        planar.influence_counts,
        planar.influences,
        vertices,
        PLANAR_INFLUENCE_BYTES,
        [Section::InfluenceCounts, Section::Influences],
    )?;
    let one = 1u32 << PLANAR_WEIGHT_FRAC_BITS;
    let mut records = planar.influences.0.chunks_exact(PLANAR_INFLUENCE_BYTES);
    for (vertex, &count) in planar.influence_counts.0.iter().enumerate() {
        if count > k {
            return Err(LoadError::TooManyInfluences { vertex, count });
        }
        let mut sum = 0u32;
        for r in records.by_ref().take(usize::from(count)) {
            let inf = read_planar_influence(r);
            if usize::from(inf.triangle) >= triangles {
                return Err(LoadError::TriangleIndexOutOfRange {
                    vertex,
                    triangle: inf.triangle,
                });
            }
            sum += u32::from(inf.weight);
        }
        // Every vertex rides at least one triangle: count 0 sums to 0 and is rejected too.
        if sum != one {
            return Err(LoadError::WeightsNotNormalised { vertex });
        }
    }
    Ok(())
}

impl<'a> PlanarDeformer<'a> {
    /// The section for vertices `first .. first + len` only (see [`super::Deformer::vertex_range`]).
    pub(crate) fn vertex_range(&self, first: usize, len: usize, uniform: Option<u8>) -> Self {
        let (counts, influences) = counted_range(
            self.influence_counts.0,
            self.influences.0,
            PLANAR_INFLUENCE_BYTES,
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

impl DeformerSection for PlanarDeformer<'_> {
    fn validate(&self, rig: &Shared<'_>) -> Result<(), LoadError> {
        validate(self, rig.marker_rest, rig.vertices, rig.markers)
    }

    fn cost(&self, rig: &Shared<'_>) -> Cost {
        cost(self, rig.vertices, rig.markers)
    }

    fn weight_frac_bits(&self) -> u8 {
        PLANAR_WEIGHT_FRAC_BITS
    }

    fn deform(
        &self,
        rig: &Shared<'_>,
        markers: &[[i32; 3]],
        out: &mut [[i32; 3]],
    ) -> DegenerateTriangles {
        deform(self, rig.marker_rest, markers, out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const ONE: i32 = 1 << 24;

    #[test]
    fn frame_of_a_right_triangle_is_exact() {
        let f = build_frame(&[[0, 0, 0], [ONE, 0, 0], [0, ONE, 0]]).unwrap();
        assert_eq!(f.e, [[ONE, 0, 0], [-ONE, ONE, 0], [0, -ONE, 0]]);
        assert_eq!(f.n, [0, 0, 1 << 30]);
        assert_eq!(f.u[0], [0, -(1 << 30), 0]);
        assert_eq!(f.u[2], [-(1 << 30), 0, 0]);
    }

    #[test]
    fn collinear_and_coincident_triangles_are_degenerate() {
        assert_eq!(build_frame(&[[0; 3]; 3]), None);
        assert_eq!(
            build_frame(&[[0, 0, 0], [ONE, ONE, 0], [2 * ONE, 2 * ONE, 0]]),
            None
        );
        assert_eq!(build_frame(&[[5, 5, 5], [5, 5, 5], [ONE, 0, 0]]), None);
        // Thin but not degenerate: height 2^-8 of the edge.
        assert!(build_frame(&[[0, 0, 0], [ONE, 0, 0], [ONE / 2, ONE >> 8, 0]]).is_some());
        // Extreme positions do not overflow.
        let far = [
            [i32::MIN; 3],
            [i32::MAX, i32::MIN, 0],
            [0, i32::MAX, i32::MAX],
        ];
        assert!(build_frame(&far).is_some());
    }

    #[test]
    fn the_centroid_region_translates_with_the_corners_mean() {
        let tri = [[3 * ONE, 0, -6], [0, 3 * ONE, 0], [0, 0, 3 * ONE]];
        // The centroid (ONE, ONE, ONE − 2) plus the offset.
        assert_eq!(
            place_at_centroid(&tri, [5, -7, 2, 0]),
            [ONE + 5, ONE - 7, ONE]
        );
        // Means of a third round to the nearest integer, either sign.
        assert_eq!(place_at_centroid(&[[1, -1, 2], [1, -1, 0], [0; 3]], [0; 4]), [1, -1, 1]);
        assert_eq!(place_at_centroid(&[[1, -1, 0], [0; 3], [0; 3]], [0; 4]), [0, 0, 0]);
        // Extreme corners and offsets saturate instead of wrapping.
        let far = [[i32::MAX; 3]; 3];
        assert_eq!(place_at_centroid(&far, [i32::MAX; 4]), [i32::MAX; 3]);
        let near = [[i32::MIN; 3]; 3];
        assert_eq!(place_at_centroid(&near, [i32::MIN; 4]), [i32::MIN; 3]);
    }

    #[test]
    fn regions_place_points_on_the_rest_frame_exactly() {
        let f = build_frame(&[[0, 0, 0], [ONE, 0, 0], [0, ONE, 0]]).unwrap();
        let r = 1 << RATIO_FRAC_BITS;
        // R_A: (¼, ½) affine, 0.1 above the plane.
        let z = ONE / 10;
        let s = place(&f, 0, [r / 4, r / 2, z, 0], [0; 3]);
        assert_eq!(s, [ONE / 4, ONE / 2, z]);
        // R_B,0: halfway along e0, 0.25 outward (−y).
        let s = place(&f, 1, [r / 2, ONE / 4, 0, 0], [0; 3]);
        assert_eq!(s, [ONE / 2, -ONE / 4, 0]);
        // R_C,1 at V1 = (1, 0): along u1 only, distance ½.
        let s = place(&f, 5, [ONE, 0, 0, ONE / 2], [ONE, 0, 0]);
        let h = (f64::from(ONE) * 0.5 / 2f64.sqrt()).round() as i32;
        assert!(
            (s[0] - (ONE + h)).abs() <= 1 && (s[1] - h).abs() <= 1,
            "{s:?}"
        );
    }
}
