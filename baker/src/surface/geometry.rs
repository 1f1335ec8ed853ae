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
        let fields = geodesics.from_sources(sources)?;
        let between = geodesics.between_fields(sources, &fields)?;
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
