//! The control surface: a triangulation of the markers on the character (paper 000 §4).
//!
//! Built automatically as the Delaunay triangulation of the markers in the cylindrical
//! projection of the face (axis vertical through the markers' centroid: angle around it times
//! the mean radius, and height), then pruned of the triangles that do not lie on the skin:
//!
//! * triangles spanning an opening (mouth, eyes): an edge whose distance along the skin (edge
//!   Dijkstra on the welded mesh) is more than [`OPENING_RATIO`] times its straight length
//!   crosses a hole (on FaceCap the lips are 0.17 mm apart in space and 54 mm along the skin;
//!   with the 40 ground-truth markers the edge across the mouth has ratio 1.86, and every
//!   other edge at most 1.48, edge Dijkstra's zig-zag included);
//! * slivers: a smallest angle below [`MIN_ANGLE_DEGREES`] (the thin triangles Delaunay leaves
//!   along the projection's convex hull), whose frames would be ill-conditioned.
//!
//! The Delaunay step is Bowyer–Watson on at most 256 points, O(n²), done once per bake.

use std::collections::HashMap;

use crate::geodesic::{GeodesicMethod, Geodesics, Source};
use crate::mesh::{distance, dot, norm, sub};

/// An edge whose skin distance exceeds this multiple of its straight length spans an opening
/// (see the module docs for the FaceCap figures it separates).
pub const OPENING_RATIO: f64 = 1.6;
/// Triangles with a smaller angle than this are dropped as slivers. At 8° JawMoCap's three
/// right-brow markers (angles 12°, 15° and 153°) made a bone whose normal turned with every
/// twitch of the brow: a forehead vertex 15 mm above it moved by up to 10.9 mm while its
/// neighbours moved 2.7 mm (2.3 mm without that bone). 15° loses bones the lips need (JawMoCap's
/// widest mouth 40.5 → 32.5 mm, 51 frames with an edge over 2×).
pub const MIN_ANGLE_DEGREES: f64 = 12.5;

/// The triangulation could not be built.
#[derive(Debug, thiserror::Error)]
pub enum TriangulateError {
    /// Fewer than three markers, or all on one line in the projection.
    #[error("the {0} markers do not span a surface: no control triangle remains")]
    NoTriangles(usize),
    /// The mesh is unusable for skin distances.
    #[error("measuring distances along the skin: {0}")]
    Geodesic(#[from] crate::geodesic::GeodesicError),
}

/// The markers projected onto the unrolled cylinder around the vertical (y) axis through their
/// centroid: (mean radius × angle, height).
pub fn cylindrical(markers: &[[f64; 3]]) -> Vec<[f64; 2]> {
    let n = markers.len().max(1) as f64;
    let cx = markers.iter().map(|p| p[0]).sum::<f64>() / n;
    let cz = markers.iter().map(|p| p[2]).sum::<f64>() / n;
    let radius = markers
        .iter()
        .map(|p| (p[0] - cx).hypot(p[2] - cz))
        .sum::<f64>()
        / n;
    markers
        .iter()
        .map(|p| [radius * (p[0] - cx).atan2(p[2] - cz), p[1]])
        .collect()
}

fn circumcircle_contains(t: [[f64; 2]; 3], p: [f64; 2]) -> bool {
    let [a, b, c] = t.map(|q| [q[0] - p[0], q[1] - p[1]]);
    let det = (a[0] * a[0] + a[1] * a[1]) * (b[0] * c[1] - c[0] * b[1])
        - (b[0] * b[0] + b[1] * b[1]) * (a[0] * c[1] - c[0] * a[1])
        + (c[0] * c[0] + c[1] * c[1]) * (a[0] * b[1] - b[0] * a[1]);
    let orient =
        (t[1][0] - t[0][0]) * (t[2][1] - t[0][1]) - (t[1][1] - t[0][1]) * (t[2][0] - t[0][0]);
    if orient > 0.0 {
        det > 0.0
    } else {
        det < 0.0
    }
}

/// The Delaunay triangulation of 2-D points (Bowyer–Watson), counter-clockwise triangles.
pub fn delaunay(points: &[[f64; 2]]) -> Vec<[usize; 3]> {
    let n = points.len();
    if n < 3 {
        return Vec::new();
    }
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for p in points {
        for c in 0..2 {
            lo[c] = lo[c].min(p[c]);
            hi[c] = hi[c].max(p[c]);
        }
    }
    let span = (hi[0] - lo[0]).max(hi[1] - lo[1]).max(f64::MIN_POSITIVE);
    let mid = [0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1])];
    // A super-triangle far around every point: indices n, n + 1, n + 2.
    let mut all = points.to_vec();
    all.push([mid[0] - 40.0 * span, mid[1] - 20.0 * span]);
    all.push([mid[0] + 40.0 * span, mid[1] - 20.0 * span]);
    all.push([mid[0], mid[1] + 40.0 * span]);
    let mut tris: Vec<[usize; 3]> = vec![[n, n + 1, n + 2]];
    for (i, &p) in points.iter().enumerate() {
        let (bad, keep): (Vec<[usize; 3]>, Vec<[usize; 3]>) = tris
            .into_iter()
            .partition(|t| circumcircle_contains(t.map(|k| all[k]), p));
        // The hole's boundary: edges of exactly one bad triangle.
        let mut edges: HashMap<(usize, usize), usize> = HashMap::new();
        for t in &bad {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                *edges.entry((a.min(b), a.max(b))).or_default() += 1;
            }
        }
        tris = keep;
        for t in &bad {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                if edges[&(a.min(b), a.max(b))] == 1 {
                    tris.push([a, b, i]);
                }
            }
        }
    }
    tris.retain(|t| t.iter().all(|&k| k < n));
    for t in &mut tris {
        let [a, b, c] = t.map(|k| points[k]);
        if (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]) < 0.0 {
            t.swap(1, 2);
        }
    }
    tris.sort_unstable();
    tris
}

/// The smallest interior angle of a 3-D triangle, in degrees.
pub fn smallest_angle_degrees(p: [[f64; 3]; 3]) -> f64 {
    (0..3)
        .map(|i| {
            let a = sub(&p[(i + 1) % 3], &p[i]);
            let b = sub(&p[(i + 2) % 3], &p[i]);
            let c = dot(&a, &b) / (norm(&a) * norm(&b));
            c.clamp(-1.0, 1.0).acos().to_degrees()
        })
        .fold(f64::INFINITY, f64::min)
        .min(if p.iter().any(|q| q.iter().any(|x| !x.is_finite())) {
            0.0
        } else {
            f64::INFINITY
        })
}

/// Skin distances between every pair of markers: each marker at its closest mesh vertex, edge
/// Dijkstra on the welded mesh (`f64::INFINITY` across separate pieces).
pub fn skin_distances(
    vertices: &[[f64; 3]],
    triangles: &[[u32; 3]],
    markers: &[[f64; 3]],
) -> Result<Vec<Vec<f64>>, TriangulateError> {
    let (map, welded) = crate::model::weld_positions(vertices);
    let faces: Vec<[u32; 3]> = triangles
        .iter()
        .map(|t| t.map(|v| map.get(v as usize).copied().unwrap_or(u32::MAX)))
        .filter(|t| t[0] != t[1] && t[1] != t[2] && t[0] != t[2])
        .collect();
    let geodesics = Geodesics::new(&welded, &faces, GeodesicMethod::EdgeDijkstra)?;
    let sources: Vec<Source> = markers
        .iter()
        .map(|m| {
            let closest = welded
                .iter()
                .enumerate()
                .min_by(|a, b| distance(a.1, m).total_cmp(&distance(b.1, m)))
                .map_or(0, |(i, _)| i);
            Source::Vertex(closest as u32)
        })
        .collect();
    Ok(geodesics.between(&sources)?)
}

/// The control surface of `markers` on the mesh (`vertices`, `triangles` in the same vertex
/// order): Delaunay in the cylindrical projection, without opening-spanning triangles and
/// slivers. Triangles are wound with their normals pointing out of the head.
pub fn control_surface(
    vertices: &[[f64; 3]],
    triangles: &[[u32; 3]],
    markers: &[[f64; 3]],
) -> Result<Vec<[usize; 3]>, TriangulateError> {
    let skin = skin_distances(vertices, triangles, markers)?;
    let spans_opening = |a: usize, b: usize| {
        let straight = distance(&markers[a], &markers[b]);
        skin[a][b].is_nan() || skin[a][b] > OPENING_RATIO * straight
    };
    let kept: Vec<[usize; 3]> = delaunay(&cylindrical(markers))
        .into_iter()
        .filter(|t| {
            (0..3).all(|k| !spans_opening(t[k], t[(k + 1) % 3]))
                && smallest_angle_degrees(t.map(|k| markers[k])) >= MIN_ANGLE_DEGREES
        })
        .collect();
    if kept.is_empty() {
        return Err(TriangulateError::NoTriangles(markers.len()));
    }
    Ok(kept)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn delaunay_of_a_square_grid_tiles_it() {
        let pts: Vec<[f64; 2]> = (0..16)
            .map(|i| [f64::from(i % 4) + 0.01 * f64::from(i / 4), f64::from(i / 4)])
            .collect();
        let t = delaunay(&pts);
        // 9 cells, two triangles each; total area 9 (the shear keeps area).
        assert_eq!(t.len(), 18);
        let area: f64 = t
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|k| pts[k]);
                0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]))
            })
            .sum();
        assert!((area - 9.0).abs() < 1e-9, "{area}");
    }

    #[test]
    fn delaunay_is_empty_circle() {
        let mut s = 0x1234_5678_9ABC_DEF0u64;
        let mut next = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        let pts: Vec<[f64; 2]> = (0..60).map(|_| [next(), next()]).collect();
        let tris = delaunay(&pts);
        for t in &tris {
            for (i, &p) in pts.iter().enumerate() {
                if !t.contains(&i) {
                    assert!(!circumcircle_contains(t.map(|k| pts[k]), p));
                }
            }
        }
        // Euler: 2n − 2 − hull triangles; at least n − 2.
        assert!(tris.len() >= pts.len() - 2);
    }
}
