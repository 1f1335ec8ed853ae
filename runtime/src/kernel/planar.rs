//! The planar-bones kernel (paper 000 §4.1–4.2): vertices ride the frames of marker triangles.
//!
//! Per frame, two stages:
//!
//! 1. **Frames**, once per control triangle (O, P, Q) = (V₀, V₁, V₂): the edges
//!    e_i = V_{i+1} − V_i (Q8.24, saturated to ±2³⁰, i.e. 64 rig units: the mesh spans ±1),
//!    the unit normal
//!    n = unit(e₀ × (V₂ − V₀)) and the unit in-plane edge normals u_i = unit(e_i × n), both Q1.30
//!    from [`normalize3`] (each component within 2 LSB of the exact unit vector). The cross
//!    products are taken on the edges shifted right until every component is below 2³⁰, so
//!    they fit `i64` whatever the marker positions; the shift only drops low bits of large
//!    edges (a relative change below 2⁻³⁰).
//! 2. **Vertices**: each of a vertex's influences places it with its region's transform
//!    (see [`PlanarBones`] for the table): products of an `i32` coordinate and a frame component
//!    of at most 2³⁰ in magnitude, so each below 2⁶¹, in `i64`: a ratio (Q6.26) times an edge
//!    is Q.50, a length (Q8.24) times a unit vector Q.54, shifted right by 4 to Q.50 where the
//!    two meet (R_A, R_B); every sum stays below 1.5 · 2⁶² (no overflow). The sum is narrowed to
//!    Q8.24 with rounding and saturation and added (saturating) to the region's origin marker. The vertex is the
//!    weighted sum of those positions with Q1.15 weights that sum to exactly 2¹⁵, so a uniform
//!    translation of every marker moves every vertex by exactly that translation. Apex regions
//!    (R_C,i) normalise their in-plane direction once more (eq 10's scaling D/d).
//!
//! # Degenerate triangles
//!
//! A control triangle is **degenerate** in a frame when twice its area is at most 2⁻¹⁰ of its
//! longest edge squared ([`DEGENERATE_LOG2`]): collinear or coincident markers, for instance a
//! marker knocked out and rebuilt onto a line. Its orientation is then meaningless, so the
//! kernel uses the triangle's **rest** frame (rest edges, normal and edge normals) placed at the
//! current markers: its vertices translate with the region's origin marker instead of flying
//! off. The frame call reports every such triangle. The loader rejects triangles degenerate at
//! rest, so the fallback always exists. The fallback costs one more frame build for that
//! triangle: per-frame work is bounded by two frame builds per triangle.
//!
//! # Cost
//!
//! `triangles × (frame build: 4 normalisations)` (twice that at worst, see above) plus
//! `influences × (12 multiply-adds, 1 narrowing)` plus one normalisation per apex influence,
//! plus per vertex three narrowings. No loop depends on marker data.

use crate::fixed::round_shift_bounded;
use crate::fixed::MAX_INFLUENCES;
use crate::format::{
    expect_len, read_planar_influence, read_position, LoadError, PlanarBones, Section,
    MAX_TRIANGLES, PLANAR_INFLUENCE_BYTES, PLANAR_REGIONS, PLANAR_WEIGHT_FRAC_BITS, POSITION_BYTES,
};
use crate::rig::Cost;
use crate::sqrt::{normalize3, UNIT_FRAC_BITS};

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

/// Which control triangles were degenerate in a frame (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DegenerateTriangles {
    bits: [u32; MAX_TRIANGLES / 32],
}

impl Default for DegenerateTriangles {
    fn default() -> Self {
        Self {
            bits: [0; MAX_TRIANGLES / 32],
        }
    }
}

impl DegenerateTriangles {
    fn mark(&mut self, t: usize) {
        if let Some(word) = self.bits.get_mut(t / 32) {
            *word |= 1 << (t % 32);
        }
    }

    /// Whether triangle `t` was degenerate (and so used its rest orientation).
    pub fn contains(&self, t: usize) -> bool {
        self.bits
            .get(t / 32)
            .is_some_and(|word| word & (1 << (t % 32)) != 0)
    }

    /// How many triangles were degenerate.
    pub fn count(&self) -> usize {
        self.bits.iter().map(|w| w.count_ones() as usize).sum()
    }

    /// The degenerate triangles, in increasing order.
    pub fn iter(&self) -> impl Iterator<Item = usize> + '_ {
        (0..MAX_TRIANGLES).filter(|&t| self.contains(t))
    }
}

/// Deform one frame. `markers` has one position per rig marker (checked by the caller),
/// `marker_rest` and `planar` were validated at load, `out` has one entry per vertex.
#[inline(never)]
pub(crate) fn deform(
    planar: &PlanarBones<'_>,
    marker_rest: &[u8],
    markers: &[[i32; 3]],
    out: &mut [[i32; 3]],
) -> DegenerateTriangles {
    let mut degenerate = DegenerateTriangles::default();
    let mut frames = [Frame::default(); MAX_TRIANGLES];
    let current = |m: usize| markers.get(m).copied().unwrap_or([0; 3]);
    let rest = |m: usize| rest_marker(marker_rest, m);
    for (t, (frame, tri)) in frames
        .iter_mut()
        .zip(planar.triangles.0.chunks_exact(3))
        .enumerate()
    {
        *frame = match build_frame(&corners(current, tri)) {
            Some(f) => f,
            None => {
                degenerate.mark(t);
                // The loader checked every rest triangle: the default is never taken.
                build_frame(&corners(rest, tri)).unwrap_or_default()
            }
        };
    }
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
            let frame = frames.get(t).unwrap_or(&NO_FRAME);
            let tri = planar.triangles.0.get(3 * t..3 * t + 3).unwrap_or(&[0; 3]);
            let corner = match inf.region {
                0 => 0,
                r => usize::from(r - 1) % 3,
            };
            let origin = current(usize::from(tri[corner]));
            let s = place(frame, inf.region, inf.coords, origin);
            let weight = i32::from(inf.weight);
            for c in 0..3 {
                // ≤ 64 products of 2^15 and 2^31: below 2^52.
                acc[c] += i64::from(weight) * i64::from(s[c]);
            }
        }
        *o = acc.map(|a| round_shift_bounded(a, frac));
    }
    degenerate
}

/// The per-frame work of [`deform`] on a rig with `vertices` vertices and `markers` markers.
pub(crate) fn cost(planar: &PlanarBones<'_>, vertices: usize, markers: usize) -> Cost {
    let records = planar.influences.0.chunks_exact(PLANAR_INFLUENCE_BYTES);
    let influences = records.len();
    let apex = records
        .filter(|r| read_planar_influence(r).region >= 4)
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
    }
}

/// Check a planar-bones deformer against the rig's counts: everything the per-frame path relies
/// on, each failure with its own [`LoadError`].
pub(crate) fn validate(
    planar: &PlanarBones<'_>,
    marker_rest: &[u8],
    vertices: usize,
    markers: usize,
) -> Result<(), LoadError> {
    let k = planar.max_influences;
    if k == 0 || k > MAX_INFLUENCES {
        return Err(LoadError::BadMaxInfluences { found: k });
    }
    let triangles = usize::from(planar.triangle_count);
    if triangles == 0 || triangles > MAX_TRIANGLES {
        return Err(LoadError::BadTriangleCount {
            found: planar.triangle_count,
        });
    }
    expect_len(Section::Triangles, planar.triangles, triangles, 3)?;
    let rest = |m: usize| rest_marker(marker_rest, m);
    for (triangle, tri) in planar.triangles.0.chunks_exact(3).enumerate() {
        if let Some(&marker) = tri.iter().find(|&&m| usize::from(m) >= markers) {
            return Err(LoadError::TriangleMarkerOutOfRange { triangle, marker });
        }
        if build_frame(&corners(rest, tri)).is_none() {
            return Err(LoadError::DegenerateRestTriangle { triangle });
        }
    }
    expect_len(
        Section::InfluenceCounts,
        planar.influence_counts,
        vertices,
        1,
    )?;
    let total: usize = planar
        .influence_counts
        .0
        .iter()
        .map(|&c| usize::from(c))
        .sum();
    expect_len(
        Section::Influences,
        planar.influences,
        total,
        PLANAR_INFLUENCE_BYTES,
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
            if inf.region >= PLANAR_REGIONS {
                return Err(LoadError::BadRegion {
                    vertex,
                    region: inf.region,
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
