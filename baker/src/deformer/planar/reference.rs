//! The f64 planar-bones reference: paper 000 eqs 1–12 evaluated directly, as matrices.
//!
//! For every influence (triangle, region, weight) of a vertex S, the deformed position is
//!
//! * R_A (eq 1): `s = o + (S − O) (A^OPQ)⁻¹ A^opq`, rows of A = (P − O, Q − O, n);
//! * R_B,i (eq 9): `s = v_i + (S − V_i) (B_i^OPQ)⁻¹ B_i^opq`, rows of B_i = (e_i, u_i, n);
//! * R_C,i (eq 10): `s = v_i + (S − V_i) (C_i^OPQ)⁻¹ Diag(D/d, D/d, 1) C_i^opq`, rows of
//!   C_i = (u_i, u_{i−1}, n), D = ‖Π(S) − V_i‖, d = ‖(Π(S) − V_i)(C_i^OPQ)⁻¹ C_i^opq‖;
//! * R_T (not in the paper): `s = c + (S − C)`, C and c the rest and current centroids;
//!
//! blended by the weights (eq 11). Row vectors times matrices, as in the paper. Nothing here is
//! shared with the baker's local-coordinate code except the frame vectors, so the runtime (which
//! applies stored local coordinates) is checked against an independent evaluation.
//!
//! A triangle that is degenerate in a frame (2 · area ≤ 2⁻¹⁰ of its longest edge squared, the
//! runtime's test) uses its rest frame at the current markers, as the runtime does.

use facebake_runtime::deformer::planar::{read_planar_influence, PLANAR_WEIGHT_FRAC_BITS};
use facebake_runtime::deformer::Deformer;
use facebake_runtime::fixed::POS_FRAC_BITS;
use facebake_runtime::format::records::PLANAR_INFLUENCE_BYTES;
use facebake_runtime::Rig;

use crate::mesh::{dot, norm, sub};
use crate::planar::region::{add, cross, scale, Frame, Region, V3};
use crate::planar::Influence;

type M3 = [V3; 3];

fn inverse(m: &M3) -> Option<M3> {
    let [a, b, c] = *m;
    let det = dot(&a, &cross(&b, &c));
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    // Columns of the inverse are the cross products of the rows, over the determinant.
    let cols = [cross(&b, &c), cross(&c, &a), cross(&a, &b)].map(|v| scale(&v, 1.0 / det));
    Some([0, 1, 2].map(|r| [cols[0][r], cols[1][r], cols[2][r]]))
}

/// Row vector times matrix.
fn row_times(r: &V3, m: &M3) -> V3 {
    add(
        &add(&scale(&m[0], r[0]), &scale(&m[1], r[1])),
        &scale(&m[2], r[2]),
    )
}

fn matrix(f: &Frame, region: Region) -> M3 {
    match region {
        // A translation: the identity frame.
        Region::Centroid => [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        // Q − O = −e₂ (taken from the edges, so a degenerate triangle's rest fallback holds).
        Region::Triangle => [f.e[0], scale(&f.e[2], -1.0), f.n],
        Region::Edge(i) => [f.e[i], f.u[i], f.n],
        Region::Apex(i) => [f.u[i], f.u[(i + 2) % 3], f.n],
    }
}

/// Whether the runtime calls the triangle degenerate: 2 · area ≤ 2⁻¹⁰ · (longest edge)².
pub fn is_degenerate(v: &[V3; 3]) -> bool {
    let e = [0, 1, 2].map(|i| sub(&v[(i + 1) % 3], &v[i]));
    let area2 = norm(&cross(&e[2], &e[0]));
    let longest = e.iter().map(|x| dot(x, x)).fold(0.0, f64::max);
    area2.is_nan() || area2 <= longest / 1024.0
}

/// Where one bone puts `s` (eqs 1, 9, 10): `rest` and `now` are the triangle's frames.
pub fn place(rest: &Frame, now: &Frame, region: Region, s: &V3) -> V3 {
    let centroid = |f: &Frame| {
        let [a, b, c] = f.v;
        [0, 1, 2].map(|k| (a[k] + b[k] + c[k]) / 3.0)
    };
    let Some(i) = region.origin() else {
        return add(&centroid(now), &sub(s, &centroid(rest)));
    };
    let (m_rest, m_now) = (matrix(rest, region), matrix(now, region));
    let Some(inv) = inverse(&m_rest) else {
        return add(&now.v[i], &sub(s, &rest.v[i]));
    };
    let d = sub(s, &rest.v[i]);
    let mut r = row_times(&d, &inv);
    if let Region::Apex(_) = region {
        let planar = sub(&d, &scale(&rest.n, dot(&d, &rest.n)));
        let big_d = norm(&planar);
        let small_d = norm(&row_times(&[r[0], r[1], 0.0], &m_now));
        let ratio = if small_d > 0.0 { big_d / small_d } else { 0.0 };
        r = [r[0] * ratio, r[1] * ratio, r[2]];
    }
    add(&now.v[i], &row_times(&r, &m_now))
}

/// A planar-bones rig in f64.
pub struct PlanarReference {
    triangles: Vec<[usize; 3]>,
    marker_rest: Vec<V3>,
    rest: Vec<V3>,
    rows: Vec<Vec<Influence>>,
}

impl PlanarReference {
    /// From exact inputs: vertex and marker rest positions (asset units), control triangles and
    /// per-vertex influences.
    pub fn new(
        rest: Vec<V3>,
        marker_rest: Vec<V3>,
        triangles: Vec<[usize; 3]>,
        rows: Vec<Vec<Influence>>,
    ) -> Self {
        Self {
            triangles,
            marker_rest,
            rest,
            rows,
        }
    }

    /// The influences a planar-bones rig stores (triangles, regions, dequantised weights), with
    /// the given vertex and marker rest positions (asset units), or `None` for another deformer.
    /// Pass the bake's exact positions to check the runtime against the equations; pass the
    /// rig's own ([`Self::from_rig`]) when only the blob is at hand.
    pub fn with_positions(rig: &Rig<'_>, rest: Vec<V3>, marker_rest: Vec<V3>) -> Option<Self> {
        let Deformer::Planar(p) = rig.deformer() else {
            return None;
        };
        let triangles = p
            .triangles
            .0
            .chunks_exact(3)
            .map(|t| [0, 1, 2].map(|k| usize::from(t[k])))
            .collect();
        let one = f64::from(1u32 << PLANAR_WEIGHT_FRAC_BITS);
        let mut records = p.influences.0.chunks_exact(PLANAR_INFLUENCE_BYTES);
        let rows = p
            .influence_counts
            .0
            .iter()
            .map(|&count| {
                records
                    .by_ref()
                    .take(usize::from(count))
                    .map(|r| {
                        let i = read_planar_influence(r);
                        Influence {
                            triangle: usize::from(i.triangle),
                            region: Region::from_code(i.region),
                            weight: f64::from(i.weight) / one,
                        }
                    })
                    .collect()
            })
            .collect();
        Some(Self::new(rest, marker_rest, triangles, rows))
    }

    /// [`Self::with_positions`] with the rig's own (quantised) rest positions.
    pub fn from_rig(rig: &Rig<'_>) -> Option<Self> {
        let space = rig.space();
        let one = f64::from(1u32 << POS_FRAC_BITS);
        let to_asset = |q: [i32; 3]| {
            [0, 1, 2].map(|c| {
                f64::from(space.centre[c]) + f64::from(q[c]) / one * f64::from(space.half_extent)
            })
        };
        let rest = (0..rig.vertex_count())
            .filter_map(|i| rig.vertex_rest(i))
            .map(to_asset)
            .collect();
        let markers = (0..rig.marker_count())
            .filter_map(|i| rig.marker_rest(i))
            .map(to_asset)
            .collect();
        Self::with_positions(rig, rest, markers)
    }

    /// Deformed positions for marker positions `markers` (asset units), and which triangles were
    /// degenerate.
    pub fn frame(&self, markers: &[V3]) -> (Vec<V3>, Vec<usize>) {
        let mut degenerate = Vec::new();
        let frames: Vec<(Frame, Frame)> = self
            .triangles
            .iter()
            .enumerate()
            .map(|(t, tri)| {
                let rest_corners = tri.map(|m| self.marker_rest[m]);
                let now_corners = tri.map(|m| markers[m]);
                let rest = Frame::new(rest_corners).unwrap_or(Frame {
                    v: rest_corners,
                    e: [[0.0; 3]; 3],
                    n: [0.0; 3],
                    u: [[0.0; 3]; 3],
                });
                let now = match Frame::new(now_corners) {
                    Some(f) if !is_degenerate(&now_corners) => f,
                    _ => {
                        degenerate.push(t);
                        Frame {
                            v: now_corners,
                            ..rest
                        }
                    }
                };
                (rest, now)
            })
            .collect();
        let out = self
            .rest
            .iter()
            .zip(&self.rows)
            .map(|(s, row)| {
                row.iter().fold([0.0; 3], |acc, inf| {
                    let (rest, now) = &frames[inf.triangle];
                    add(&acc, &scale(&place(rest, now, inf.region, s), inf.weight))
                })
            })
            .collect();
        (out, degenerate)
    }
}
