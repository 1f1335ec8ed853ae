//! The distance function of each method, between markers and from every vertex to every
//! marker: Euclidean, geodesic (thesis §5.2, paper 002 §2.1), or the thesis' hybrid (§5.3):
//! geodesic inside a region around the openings, Euclidean elsewhere, blended by a Gaussian
//! decay of the Euclidean distance to the region.

use nalgebra::DMatrix;

use crate::mesh::distance;

use super::geometry::SurfaceGeometry;

/// Which distance an RBF uses: the distance strategies the dense weights come from (PBW is a
/// weighting on the geodesic one, [`crate::options::Method::Pbw`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Distance {
    /// Straight-line distance.
    Euclidean,
    /// Distance along the surface.
    Geodesic,
    /// `w · geodesic + (1 − w) · Euclidean` with `w` = 1 within `region` (edge distance) of an
    /// opening and `exp(−(e/decay)²)` outside it, `e` the Euclidean distance to the region
    /// (the weight of the point the distance is measured at).
    Hybrid {
        /// Radius of the geodesic region around the openings, asset units.
        region: f64,
        /// Width of the Gaussian decay outside it, asset units.
        decay: f64,
    },
}

/// Distances of one method.
#[derive(Debug, Clone)]
pub struct MarkerDistances {
    /// `(j, i)`: marker `i`'s distance as seen at marker `j`.
    pub between: DMatrix<f64>,
    /// Per glTF vertex, its distance to each marker.
    pub vertices: Vec<Vec<f64>>,
    /// glTF vertices some marker cannot reach along the surface (another piece of the mesh):
    /// they use Euclidean distances.
    pub fallback: Vec<u32>,
    /// Marker pairs with no path along the surface (Euclidean used).
    pub fallback_pairs: usize,
    /// Per glTF vertex, the weight of the geodesic distance (1 geodesic, 0 Euclidean).
    pub geodesic_weight: Vec<f64>,
}

/// The hybrid's geodesic weight per welded vertex.
pub fn hybrid_weights(
    geometry: &SurfaceGeometry,
    welded: &[[f64; 3]],
    region: f64,
    decay: f64,
) -> Vec<f64> {
    let inside: Vec<usize> = (0..welded.len())
        .filter(|&v| geometry.opening_distance.iter().any(|d| d[v] <= region))
        .collect();
    (0..welded.len())
        .map(|v| {
            if inside.binary_search(&v).is_ok() {
                return 1.0;
            }
            let e = inside
                .iter()
                .map(|&r| distance(&welded[v], &welded[r]))
                .fold(f64::INFINITY, f64::min);
            if e.is_finite() {
                (-(e / decay) * (e / decay)).exp()
            } else {
                0.0
            }
        })
        .collect()
}

/// Distances of `kind` for markers at `markers` (rest positions) and glTF vertices `vertices`.
pub fn marker_distances(
    kind: Distance,
    geometry: &SurfaceGeometry,
    welded: &[[f64; 3]],
    vertices: &[[f64; 3]],
    markers: &[[f64; 3]],
) -> MarkerDistances {
    let n = markers.len();
    let welded_weight = match kind {
        Distance::Euclidean => vec![0.0; welded.len()],
        Distance::Geodesic => vec![1.0; welded.len()],
        Distance::Hybrid { region, decay } => hybrid_weights(geometry, welded, region, decay),
    };
    let blend = |w: f64, g: f64, e: f64| if w > 0.0 { w * g + (1.0 - w) * e } else { e };
    let mut fallback_pairs = 0;
    let marker_weight: Vec<f64> = (0..n)
        .map(|m| geometry.at_marker(&welded_weight, m))
        .collect();
    let between = DMatrix::from_fn(n, n, |j, i| {
        let e = distance(&markers[j], &markers[i]);
        let g = geometry.between[i][j];
        if marker_weight[j] > 0.0 && !g.is_finite() {
            fallback_pairs += 1;
            return e;
        }
        blend(marker_weight[j], g, e)
    });
    let mut fallback = Vec::new();
    let mut geodesic_weight = Vec::with_capacity(vertices.len());
    let rows = vertices
        .iter()
        .enumerate()
        .map(|(v, p)| {
            let w = geometry
                .weld
                .get(v)
                .map_or(0.0, |&x| welded_weight[x as usize]);
            let x = geometry.weld.get(v).copied().unwrap_or(0) as usize;
            let reachable = geometry.fields.iter().all(|f| f[x].is_finite());
            if w > 0.0 && !reachable {
                fallback.push(v as u32);
            }
            let w = if reachable { w } else { 0.0 };
            geodesic_weight.push(w);
            (0..n)
                .map(|i| blend(w, geometry.fields[i][x], distance(p, &markers[i])))
                .collect()
        })
        .collect();
    MarkerDistances {
        between,
        vertices: rows,
        fallback,
        fallback_pairs,
        geodesic_weight,
    }
}

/// Markers within this many mean marker spacings of an opening's rim are worn on its lip or
/// lid (FaceCap's lip and eyelid markers are within 0.21 spacings of their rims, the next
/// marker 1.2 spacings away).
pub const RIM_MARKER_REACH: f64 = 0.4;

/// A marker within this many mean marker spacings of an opening's rim sits on the rim itself:
/// at a corner, the end of both lips (or lids) rather than on one of them.
pub const RIM_END: f64 = 0.05;

/// Around a marker on the rim itself, the shortening fades in over this many mean marker
/// spacings (from none at the marker), so that the rig still reproduces it.
pub const RIM_END_FADE: f64 = 0.1;

/// The lips and lids are ribbons: between an opening's rim and a marker worn on it (within
/// [`RIM_MARKER_REACH`] × `spacing` of the rim along the skin), the skin moves with the marker
/// across the ribbon's width, and varies along it. So for such a marker, the part of a point's
/// distance to it that runs towards the rim counts `across` of its length: with `o` the edge
/// distance to the rim, `Δ = max(0, o(marker) − o(point))` and `d' = √(d² − (1 − across²) Δ²)`
/// (at least `across · Δ`). Points no nearer the rim than the marker, and markers away from
/// every rim, keep their distances; near a marker on the rim itself (a corner's) `Δ` fades in
/// over [`RIM_END_FADE`]. Marker-to-marker distances change the same way, so that the rig still
/// reproduces every marker. For surface distances only: a straight line runs through the
/// opening, and the other lip is as near the rim as this one.
///
/// FaceCap's truth, the JawMoCap layout's 41 markers, worst over its 32 frames (`--test
/// structure`): lips 6.8 → 6.7 mm (the jaw-open's middle 3.1 → 1.6 mm), eyelids 1.12 →
/// 0.91 mm, stretch 2.19 → 2.16×, lip band p99 4.19 → 4.11 mm; JawMoCap's frames with an edge
/// over 2× 82 → 80. Without the fade at the corners (their markers then not reproduced, by
/// 0.1 mm) the truth's one flipped triangle goes too; with the corners' own distances shortened
/// as well, every figure but the lip band's is worse than without shortening.
pub fn shorten_across_rims(
    d: &mut MarkerDistances,
    geometry: &SurfaceGeometry,
    spacing: f64,
    across: f64,
) {
    if !(spacing > 0.0 && spacing.is_finite()) {
        return;
    }
    let shorten = |x: f64, delta: f64| -> f64 {
        if delta <= 0.0 || !x.is_finite() {
            return x;
        }
        (x * x - (1.0 - across * across) * delta * delta)
            .max((across * delta).powi(2))
            .sqrt()
    };
    let fade =
        |from_end: f64| crate::surface::anchoring::smoothstep(from_end / (RIM_END_FADE * spacing));
    let n = geometry.sources.len();
    for rim in &geometry.opening_distance {
        let at_marker: Vec<f64> = (0..n).map(|m| geometry.at_marker(rim, m)).collect();
        let worn: Vec<usize> = (0..n)
            .filter(|&m| at_marker[m] <= RIM_MARKER_REACH * spacing)
            .collect();
        let ends: Vec<usize> = worn
            .iter()
            .copied()
            .filter(|&m| at_marker[m] <= RIM_END * spacing)
            .collect();
        let nearest_end = |distance_to: &dyn Fn(usize) -> f64| {
            ends.iter()
                .map(|&e| distance_to(e))
                .fold(f64::INFINITY, f64::min)
        };
        for (v, row) in d.vertices.iter_mut().enumerate() {
            let Some(&x) = geometry.weld.get(v) else {
                continue;
            };
            if d.geodesic_weight[v] <= 0.0 {
                continue;
            }
            let x = x as usize;
            let f = fade(nearest_end(&|e| geometry.fields[e][x]));
            for &m in &worn {
                row[m] = shorten(row[m], f * (at_marker[m] - rim[x]));
            }
        }
        for j in 0..n {
            let f = fade(nearest_end(&|e| geometry.between[e][j]));
            for &m in &worn {
                d.between[(j, m)] = shorten(d.between[(j, m)], f * (at_marker[m] - at_marker[j]));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geodesic::{GeodesicMethod, Source};
    use crate::model::FaceMesh;

    /// [`crate::surface::slit`] and the vertex id of its grid point (x, y), centred.
    fn slit() -> (FaceMesh, impl Fn(i32, i32) -> usize) {
        let vertex = |x: i32, y: i32| ((y + 10) * 41 + x + 20) as usize;
        (crate::surface::slit(), vertex)
    }

    #[test]
    fn the_rim_behind_a_lid_marker_comes_near_it_and_the_rest_keeps_its_distances() {
        let (mesh, vertex) = slit();
        // A corner marker on the rim's end, a lid marker 3 mm above the rim, one far out.
        let at = [vertex(-11, 0), vertex(0, 4), vertex(0, 9)];
        let sources: Vec<Source> = at.iter().map(|&v| Source::Vertex(v as u32)).collect();
        let geometry = SurfaceGeometry::new(&mesh, &sources, GeodesicMethod::EdgeDijkstra).unwrap();
        let rest: Vec<[f64; 3]> = at.iter().map(|&v| mesh.positions[v]).collect();
        let spacing = 10.0;
        let measure = || {
            marker_distances(
                Distance::Geodesic,
                &geometry,
                &mesh.welded_positions,
                &mesh.positions,
                &rest,
            )
        };
        let before = measure();
        let mut after = measure();
        shorten_across_rims(&mut after, &geometry, spacing, crate::options::RIM_ACROSS);
        // The rim vertex straight below the lid marker: 3 mm along the skin, now 0.6.
        let rim = vertex(0, 1);
        assert!((before.vertices[rim][1] - 3.0).abs() < 1e-9);
        assert!(
            (after.vertices[rim][1] - 0.6).abs() < 1e-9,
            "{}",
            after.vertices[rim][1]
        );
        // Beside it along the rim, the distance is mostly along the lid and shrinks less.
        let beside = vertex(6, 1);
        let ratio = after.vertices[beside][1] / before.vertices[beside][1];
        assert!((0.6..0.95).contains(&ratio), "{ratio}");
        for v in 0..mesh.positions.len() {
            // Skin no nearer the rim than the lid marker, and every distance to the markers
            // off the lid, are as they were; the other lid's (around the slit's end) within
            // 3 %; nothing grows.
            let p = mesh.positions[v];
            let (a, b) = (after.vertices[v][1], before.vertices[v][1]);
            if p[1] >= 4.0 {
                assert_eq!(a, b, "{p:?}");
            }
            if p[1] <= -1.0 {
                assert!(a > 0.97 * b, "{p:?}: {b} → {a}");
            }
            assert_eq!(after.vertices[v][2], before.vertices[v][2]);
            for m in 0..2 {
                assert!(after.vertices[v][m] <= before.vertices[v][m]);
            }
        }
        // At the corner marker the shortening has faded out, and every marker's distances as
        // seen at it are its vertex's: the rig still reproduces the markers.
        assert_eq!(after.vertices[at[0]][1], before.vertices[at[0]][1]);
        for (j, &v) in at.iter().enumerate() {
            for m in 0..at.len() {
                assert!((after.between[(j, m)] - after.vertices[v][m]).abs() < 1e-9);
            }
        }
    }
}
