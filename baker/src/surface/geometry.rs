//! Everything surface-aware methods measure on the mesh once: geodesic fields from every
//! marker, marker-to-marker geodesics, the openings and the distance to each.

use crate::geodesic::{GeodesicError, GeodesicMethod, Geodesics, Source};
use crate::model::FaceMesh;

use crate::openings::{skin_openings, Opening};

/// Geodesic measurements on a face mesh for a set of markers.
pub struct SurfaceGeometry {
    /// The distance computations (welded mesh).
    pub geodesics: Geodesics,
    /// Per marker, its geodesic distance to every welded vertex (`INFINITY` if unreachable).
    pub fields: Vec<Vec<f64>>,
    /// `between[i][j]`: geodesic distance from marker `i` to marker `j`.
    pub between: Vec<Vec<f64>>,
    /// The openings of the skin.
    pub openings: Vec<Opening>,
    /// Per opening, the edge distance from its loop to every welded vertex.
    pub opening_distance: Vec<Vec<f64>>,
    /// The markers' sources on the welded mesh.
    pub sources: Vec<Source>,
    /// Per glTF vertex, its welded vertex.
    pub weld: Vec<u32>,
    /// Welded triangles (for interpolating fields at markers).
    pub welded_triangles: Vec<[u32; 3]>,
}

impl SurfaceGeometry {
    /// Measure `mesh` for markers at `sources` (on the welded mesh; glTF triangle indices are
    /// the same).
    pub fn new(
        mesh: &FaceMesh,
        sources: &[Source],
        method: GeodesicMethod,
    ) -> Result<Self, GeodesicError> {
        // A mouth closed by a bag: distances go round it as round an open mouth, and the bag,
        // which no marker then reaches, rides the skin beside it as the mouth's lining does.
        let bagless = crate::openings::skin_without_mouth_bag(
            &mesh.welded_topology(),
            &mesh.welded_positions,
            &mesh.welded_triangles,
        );
        let triangles = bagless.as_deref().unwrap_or(&mesh.welded_triangles);
        let geodesics = Geodesics::new(&mesh.welded_positions, triangles, method)?;
        let on_skin = match &bagless {
            Some(kept) => renumbered(sources, &mesh.welded_triangles, kept),
            None => sources.to_vec(),
        };
        let fields = geodesics.from_sources(&on_skin)?;
        let between = geodesics.between_fields(&on_skin, &fields)?;
        let openings = skin_openings(
            geodesics.topology(),
            &mesh.welded_positions,
            &mesh.welded_triangles,
        );
        let opening_distance = openings
            .iter()
            .map(|o| geodesics.from_vertex_set(&o.vertices))
            .collect();
        Ok(Self {
            geodesics,
            fields,
            between,
            openings,
            opening_distance,
            sources: sources.to_vec(),
            weld: mesh.weld.clone(),
            welded_triangles: mesh.welded_triangles.clone(),
        })
    }

    /// A per-welded-vertex field's value at marker `m` (barycentric over its triangle).
    pub fn at_marker(&self, field: &[f64], m: usize) -> f64 {
        self.sources[m]
            .corners(&self.welded_triangles)
            .iter()
            .map(|&(v, w)| w * field[v as usize])
            .sum()
    }

    /// Largest relative asymmetry |d(i,j) − d(j,i)| / mean of the two, over marker pairs.
    pub fn asymmetry(&self) -> f64 {
        let n = self.between.len();
        let mut worst = 0.0f64;
        for i in 0..n {
            for j in 0..i {
                let (a, b) = (self.between[i][j], self.between[j][i]);
                if a.is_finite() && b.is_finite() && a + b > 0.0 {
                    worst = worst.max(2.0 * (a - b).abs() / (a + b));
                }
            }
        }
        worst
    }
}

impl SurfaceGeometry {
    /// The mesh pieces that glTF `vertices` lie in: (component id, those of `vertices` in it).
    pub fn pieces_of(&self, vertices: &[u32]) -> Vec<(u32, Vec<u32>)> {
        let comp = &self.geodesics.topology().components.vertex_component;
        let mut out: Vec<(u32, Vec<u32>)> = Vec::new();
        for &v in vertices {
            let c = comp[self.weld[v as usize] as usize];
            match out.iter_mut().find(|e| e.0 == c) {
                Some(e) => e.1.push(v),
                None => out.push((c, vec![v])),
            }
        }
        out
    }

    /// The mesh pieces (component id, vertex count among `vertices`) that glTF `vertices` lie in.
    pub fn topology_pieces(&self, vertices: &[u32]) -> Vec<(u32, usize)> {
        let comp = &self.geodesics.topology().components.vertex_component;
        let mut out: Vec<(u32, usize)> = Vec::new();
        for &v in vertices {
            let c = comp[self.weld[v as usize] as usize];
            match out.iter_mut().find(|e| e.0 == c) {
                Some(e) => e.1 += 1,
                None => out.push((c, 1)),
            }
        }
        out
    }
}

/// `sources` on the triangles `full` as sources on `kept`, a subset of them in another order
/// (the skin without its bags): a point on a kept triangle names its index there; a point on a
/// triangle left out (a seam between skin and bag) becomes the corner it is nearest of those
/// the kept triangles still hold (the vertex itself for a marker put on a vertex).
fn renumbered(sources: &[Source], full: &[[u32; 3]], kept: &[[u32; 3]]) -> Vec<Source> {
    let index: std::collections::HashMap<[u32; 3], usize> =
        kept.iter().enumerate().map(|(i, t)| (*t, i)).collect();
    let mut held = std::collections::HashSet::new();
    held.extend(kept.iter().flatten().copied());
    sources
        .iter()
        .map(|&s| match s {
            Source::Point {
                triangle,
                barycentric,
            } => match full.get(triangle) {
                Some(t) => match index.get(t) {
                    Some(&i) => Source::Point {
                        triangle: i,
                        barycentric,
                    },
                    None => (0..3)
                        .filter(|&k| held.contains(&t[k]))
                        .max_by(|&a, &b| barycentric[a].total_cmp(&barycentric[b]))
                        .map_or(s, |k| Source::Vertex(t[k])),
                },
                None => s,
            },
            Source::Vertex(_) => s,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A marker's triangle is named by its place in the mesh's list; the skin without its bags
    /// lists fewer triangles, so a marker keeps its own triangle only if it is renumbered (a bag
    /// whose seam triangles sit among the skin's, as ICT-FaceKit's do, moved markers onto the
    /// bag before).
    #[test]
    fn sources_follow_their_triangles_into_the_skin_without_its_bags() {
        let full = [[0, 1, 2], [1, 3, 2], [2, 3, 4]];
        // The seam [1, 3, 2] is left out; vertex 3 is the bag's.
        let kept = [[2, 3, 4], [0, 1, 2]];
        let point = |triangle, barycentric| Source::Point {
            triangle,
            barycentric,
        };
        let got = renumbered(
            &[
                point(0, [0.2, 0.3, 0.5]),
                point(2, [1.0, 0.0, 0.0]),
                point(1, [0.1, 0.6, 0.3]),
                Source::Vertex(3),
            ],
            &full,
            &kept,
        );
        assert_eq!(got[0], point(1, [0.2, 0.3, 0.5]));
        assert_eq!(got[1], point(0, [1.0, 0.0, 0.0]));
        // On the seam: its nearest corner the kept triangles hold.
        assert_eq!(got[2], Source::Vertex(3));
        assert_eq!(got[3], Source::Vertex(3));
        let on_seam = renumbered(&[point(1, [0.1, 0.3, 0.6])], &full, &kept[1..]);
        assert_eq!(on_seam[0], Source::Vertex(2));
    }
}
