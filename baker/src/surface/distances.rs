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
