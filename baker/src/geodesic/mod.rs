//! Distances along the surface of a triangle mesh, from markers to every vertex and between
//! markers.
//!
//! Two methods, chosen with [`GeodesicMethod`]:
//! * [`GeodesicMethod::EdgeDijkstra`]: the shortest path along mesh edges (what the thesis
//!   computed). Never shorter than the true distance on the polyhedral surface; longer by a
//!   few percent where the path has to zig-zag across the triangles.
//! * [`GeodesicMethod::Heat`]: the heat method of Crane, Weischedel & Wardetzky (2013), which
//!   cuts across triangles. Its sparse factorisations are computed once in
//!   [`Geodesics::new`]; each source then costs three triangular solves (two on meshes without
//!   a boundary) and a pass over the triangles.
//!
//! Use the welded mesh ([`FaceMesh::welded_positions`](crate::model::FaceMesh) and
//! `welded_triangles`): the glTF vertex order splits the surface at UV seams.
//!
//! A mesh may have several connected pieces (a face and the inside of its mouth); a vertex in
//! another piece than the source gets `f64::INFINITY`, and
//! [`Geodesics::unreachable`] lists those pieces.

pub(crate) mod dijkstra;
mod heat;
mod intrinsic;
mod ldlt;

use thiserror::Error;

use crate::mesh::{distance, Topology};

/// How distances along the surface are computed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GeodesicMethod {
    /// Shortest path along mesh edges (Dijkstra).
    EdgeDijkstra,
    /// The heat method, with the paper's `t = h²` (`h` the mean edge length), the average of
    /// the Neumann and Dirichlet heat solutions on meshes with a boundary.
    Heat,
}

/// Where distances are measured from (or to).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Source {
    /// A vertex of the mesh.
    Vertex(u32),
    /// A point on a triangle: barycentric weights of its three corners (non-negative, not all
    /// zero; they are normalised to sum to 1).
    Point {
        /// Index into the triangle list.
        triangle: usize,
        /// Weights of the triangle's corners, in the triangle's order.
        barycentric: [f64; 3],
    },
}

impl Source {
    /// Its corners on the mesh of `triangles` with their weights, normalised to sum to 1;
    /// corners of zero weight left out. The source must be valid for that mesh (as
    /// [`Geodesics`] checks it).
    pub fn corners(&self, triangles: &[[u32; 3]]) -> Vec<(u32, f64)> {
        match *self {
            Source::Vertex(v) => vec![(v, 1.0)],
            Source::Point {
                triangle,
                barycentric,
            } => {
                let total: f64 = barycentric.iter().sum();
                let t = triangles[triangle];
                (0..3)
                    .filter(|&k| barycentric[k] > 0.0)
                    .map(|k| (t[k], barycentric[k] / total))
                    .collect()
            }
        }
    }
}

/// What is wrong with a mesh or a source.
#[derive(Debug, Clone, Error, PartialEq)]
pub enum GeodesicError {
    /// A vertex position is NaN or infinite.
    #[error("vertex {vertex} has a non-finite position {position:?}")]
    NonFinitePosition {
        /// The vertex.
        vertex: usize,
        /// Its position.
        position: [f64; 3],
    },
    /// A triangle names a vertex the mesh does not have.
    #[error("triangle {triangle} uses vertex {vertex}, but the mesh has {vertex_count} vertices")]
    TriangleVertexOutOfRange {
        /// The triangle.
        triangle: usize,
        /// The bad vertex id.
        vertex: u32,
        /// Number of vertices.
        vertex_count: usize,
    },
    /// A source names a vertex the mesh does not have.
    #[error("source {source_index} is vertex {vertex}, but the mesh has {vertex_count} vertices")]
    SourceVertexOutOfRange {
        /// Position of the source in the list given.
        source_index: usize,
        /// The bad vertex id.
        vertex: u32,
        /// Number of vertices.
        vertex_count: usize,
    },
    /// A source names a triangle the mesh does not have.
    #[error(
        "source {source_index} is on triangle {triangle}, but the mesh has {triangle_count} triangles"
    )]
    SourceTriangleOutOfRange {
        /// Position of the source in the list given.
        source_index: usize,
        /// The bad triangle index.
        triangle: usize,
        /// Number of triangles.
        triangle_count: usize,
    },
    /// A source's barycentric weights are negative, non-finite or all zero.
    #[error(
        "source {source_index} has barycentric weights {barycentric:?}: they must be finite, \
         non-negative and not all zero"
    )]
    BadBarycentric {
        /// Position of the source in the list given.
        source_index: usize,
        /// The weights given.
        barycentric: [f64; 3],
    },
    /// A heat-method matrix could not be factored (a pivot at or below zero): the mesh's
    /// geometry is too badly conditioned for the heat method; use edge Dijkstra.
    #[error(
        "the heat method's matrices are not positive definite at vertex {vertex} \
         (pivot {pivot:e}); the mesh is too badly shaped for it, use edge Dijkstra"
    )]
    NotPositiveDefinite {
        /// The vertex where factorisation broke down.
        vertex: u32,
        /// The pivot found there.
        pivot: f64,
    },
}

/// A connected piece of the mesh that a source cannot reach.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct UnreachableComponent {
    /// Component id, as in [`Topology::components`] (0 is the largest piece).
    pub component: u32,
    /// Number of vertices in it.
    pub vertex_count: usize,
}

impl std::fmt::Display for UnreachableComponent {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "component {} ({} vertices)",
            self.component, self.vertex_count
        )
    }
}

/// Right-hand sides solved together by the heat method (one pass over the factor per block).
const BLOCK: usize = 4;

/// Distance computations on one mesh: the mesh's topology and, for the heat method, its
/// factored matrices, built once and reused for every source.
#[derive(Debug, Clone)]
pub struct Geodesics {
    positions: Vec<[f64; 3]>,
    triangles: Vec<[u32; 3]>,
    topology: Topology,
    graph: dijkstra::Graph,
    heat: Option<heat::Heat>,
    method: GeodesicMethod,
}

/// A checked source: weighted corners, with the Euclidean distance from the point to each.
struct Seeds {
    point: [f64; 3],
    /// `(vertex, weight, distance from the point)`, weights summing to 1.
    corners: Vec<(u32, f64, f64)>,
    triangle: Option<usize>,
}

impl Geodesics {
    /// Prepares distance computations on `triangles` over `positions` (use the welded mesh).
    ///
    /// Checks every index and position. For [`GeodesicMethod::Heat`] this factors the heat
    /// and Poisson matrices, the expensive part.
    pub fn new(
        positions: &[[f64; 3]],
        triangles: &[[u32; 3]],
        method: GeodesicMethod,
    ) -> Result<Geodesics, GeodesicError> {
        if let Some((vertex, &position)) = positions
            .iter()
            .enumerate()
            .find(|(_, p)| p.iter().any(|x| !x.is_finite()))
        {
            return Err(GeodesicError::NonFinitePosition { vertex, position });
        }
        for (triangle, t) in triangles.iter().enumerate() {
            if let Some(&vertex) = t.iter().find(|&&v| v as usize >= positions.len()) {
                return Err(GeodesicError::TriangleVertexOutOfRange {
                    triangle,
                    vertex,
                    vertex_count: positions.len(),
                });
            }
        }
        let topology = Topology::new(positions, triangles);
        let graph = dijkstra::Graph::new(&topology);
        let heat = match method {
            GeodesicMethod::EdgeDijkstra => None,
            GeodesicMethod::Heat => Some(
                heat::Heat::new(positions, triangles, &topology).map_err(|e| {
                    GeodesicError::NotPositiveDefinite {
                        vertex: e.vertex,
                        pivot: e.pivot,
                    }
                })?,
            ),
        };
        Ok(Geodesics {
            positions: positions.to_vec(),
            triangles: triangles.to_vec(),
            topology,
            graph,
            heat,
            method,
        })
    }

    /// The method these distances use.
    pub fn method(&self) -> GeodesicMethod {
        self.method
    }

    /// The mesh's topology (components, boundary loops, edges).
    pub fn topology(&self) -> &Topology {
        &self.topology
    }

    /// The heat method's diffusion time `t` (`None` for edge Dijkstra).
    pub fn heat_time(&self) -> Option<f64> {
        self.heat.as_ref().map(|h| h.time)
    }

    /// For the heat method, how many edges were flipped to make the triangulation
    /// intrinsically Delaunay (the surface is unchanged; the Laplacian loses its positive
    /// off-diagonal entries). `None` for edge Dijkstra.
    pub fn heat_flipped_edges(&self) -> Option<usize> {
        self.heat.as_ref().map(|h| h.flips)
    }

    fn seeds(&self, source_index: usize, source: &Source) -> Result<Seeds, GeodesicError> {
        match *source {
            Source::Vertex(vertex) => match self.positions.get(vertex as usize) {
                Some(&point) => Ok(Seeds {
                    point,
                    corners: vec![(vertex, 1.0, 0.0)],
                    triangle: None,
                }),
                None => Err(GeodesicError::SourceVertexOutOfRange {
                    source_index,
                    vertex,
                    vertex_count: self.positions.len(),
                }),
            },
            Source::Point {
                triangle,
                barycentric,
            } => {
                let Some(&corners) = self.triangles.get(triangle) else {
                    return Err(GeodesicError::SourceTriangleOutOfRange {
                        source_index,
                        triangle,
                        triangle_count: self.triangles.len(),
                    });
                };
                let total: f64 = barycentric.iter().sum();
                if barycentric.iter().any(|w| !(w.is_finite() && *w >= 0.0))
                    || !(total > 0.0 && total.is_finite())
                {
                    return Err(GeodesicError::BadBarycentric {
                        source_index,
                        barycentric,
                    });
                }
                let w = barycentric.map(|w| w / total);
                let point: [f64; 3] = std::array::from_fn(|k| {
                    (0..3)
                        .map(|i| w[i] * self.positions[corners[i] as usize][k])
                        .sum()
                });
                let corners = (0..3)
                    .map(|i| {
                        let v = corners[i];
                        (v, w[i], distance(&point, &self.positions[v as usize]))
                    })
                    .collect();
                Ok(Seeds {
                    point,
                    corners,
                    triangle: Some(triangle),
                })
            }
        }
    }

    fn all_seeds(&self, sources: &[Source]) -> Result<Vec<Seeds>, GeodesicError> {
        sources
            .iter()
            .enumerate()
            .map(|(i, s)| self.seeds(i, s))
            .collect()
    }

    /// The component (as in [`Topology::components`]) a source lies in.
    pub fn component_of(&self, source: &Source) -> Result<u32, GeodesicError> {
        let seeds = self.seeds(0, source)?;
        Ok(self.topology.components.vertex_component[seeds.corners[0].0 as usize])
    }

    /// The components `source` cannot reach (every one but its own), largest first.
    pub fn unreachable(&self, source: &Source) -> Result<Vec<UnreachableComponent>, GeodesicError> {
        let own = self.component_of(source)?;
        let counts = &self.topology.components.vertex_counts;
        Ok((0..counts.len() as u32)
            .filter(|&c| c != own)
            .map(|component| UnreachableComponent {
                component,
                vertex_count: counts[component as usize],
            })
            .collect())
    }

    /// Distance from each source to every vertex: one `Vec` per source, indexed by vertex,
    /// `f64::INFINITY` for vertices in other components. Sources are spread over the
    /// machine's cores.
    pub fn from_sources(&self, sources: &[Source]) -> Result<Vec<Vec<f64>>, GeodesicError> {
        let seeds = self.all_seeds(sources)?;
        let threads = std::thread::available_parallelism()
            .map(|n| n.get())
            .unwrap_or(1);
        let per_thread = seeds.len().div_ceil(threads.max(1)).max(1);
        // Whole heat blocks per thread, so no block is split between threads.
        let per_thread = per_thread.div_ceil(BLOCK) * BLOCK;
        let mut out = vec![Vec::new(); seeds.len()];
        std::thread::scope(|scope| {
            for (chunk, slots) in seeds.chunks(per_thread).zip(out.chunks_mut(per_thread)) {
                scope.spawn(move || {
                    for (slot, field) in slots.iter_mut().zip(self.fields(chunk)) {
                        *slot = field;
                    }
                });
            }
        });
        Ok(out)
    }

    /// Distance fields for `seeds`, on the current thread.
    fn fields(&self, seeds: &[Seeds]) -> Vec<Vec<f64>> {
        match &self.heat {
            None => seeds
                .iter()
                .map(|s| {
                    let starts: Vec<(u32, f64)> = s.corners.iter().map(|c| (c.0, c.2)).collect();
                    dijkstra::distances(&self.graph, &starts)
                })
                .collect(),
            Some(heat) => {
                let mut work = Vec::new();
                let mut out = Vec::with_capacity(seeds.len());
                for block in seeds.chunks(BLOCK) {
                    out.extend(self.heat_block(heat, block, &mut work));
                }
                out
            }
        }
    }

    /// Heat-method distances for up to [`BLOCK`] sources.
    fn heat_block(
        &self,
        heat: &heat::Heat,
        block: &[Seeds],
        work: &mut Vec<[f64; BLOCK]>,
    ) -> Vec<Vec<f64>> {
        // Each source diffuses in the piece of its heaviest corner that has area.
        let pieces: Vec<u32> = block
            .iter()
            .map(|s| {
                s.corners
                    .iter()
                    .filter(|c| heat.piece[c.0 as usize] != heat::NO_PIECE)
                    .max_by(|a, b| a.1.total_cmp(&b.1))
                    .map_or(heat::NO_PIECE, |c| heat.piece[c.0 as usize])
            })
            .collect();
        let heat_sources: [Vec<(u32, f64)>; BLOCK] = std::array::from_fn(|c| match block.get(c) {
            Some(s) if pieces[c] != heat::NO_PIECE => s
                .corners
                .iter()
                .filter(|corner| heat.piece[corner.0 as usize] == pieces[c] && corner.1 > 0.0)
                .map(|corner| (corner.0, corner.1))
                .collect(),
            _ => Vec::new(),
        });
        let phi = heat.solve(&heat_sources, work);
        let components = &self.topology.components.vertex_component;
        block
            .iter()
            .enumerate()
            .map(|(c, s)| {
                let piece = pieces[c];
                if heat_sources[c].is_empty() {
                    // No corner with area (a source on a degenerate triangle): edge paths.
                    let starts: Vec<(u32, f64)> = s.corners.iter().map(|c| (c.0, c.2)).collect();
                    return dijkstra::distances(&self.graph, &starts);
                }
                let own = components[s.corners[0].0 as usize];
                let mut dist: Vec<f64> = phi
                    .iter()
                    .zip(&heat.piece)
                    .map(|(p, &q)| {
                        if q == piece {
                            p[c].max(0.0)
                        } else {
                            f64::INFINITY
                        }
                    })
                    .collect();
                // Vertices of the same component outside the heat's piece (joined to it only
                // through triangles without area): fill in along edges.
                let stranded = |v: usize| components[v] == own && heat.piece[v] != piece;
                if (0..dist.len()).any(stranded) {
                    dijkstra::relax(&self.graph, &mut dist, |v| !stranded(v));
                }
                dist
            })
            .collect()
    }

    /// Distance along mesh edges from the nearest of `vertices` to every vertex
    /// (`f64::INFINITY` where none of them is reachable). Indices beyond the mesh are ignored.
    pub fn from_vertex_set(&self, vertices: &[u32]) -> Vec<f64> {
        let starts: Vec<(u32, f64)> = vertices
            .iter()
            .filter(|&&v| (v as usize) < self.positions.len())
            .map(|&v| (v, 0.0))
            .collect();
        dijkstra::distances(&self.graph, &starts)
    }

    /// The value of the distance field `field` (from [`Geodesics::from_sources`]) at `target`.
    ///
    /// Edge Dijkstra: the shortest way onto the target's triangle through a corner (or straight
    /// across, if `from` lies on the same triangle). Heat: barycentric interpolation.
    fn at(&self, field: &[f64], from: &Seeds, target: &Seeds) -> f64 {
        match self.method {
            GeodesicMethod::EdgeDijkstra => {
                let through_corner = target
                    .corners
                    .iter()
                    .map(|&(v, _, d)| field[v as usize] + d)
                    .fold(f64::INFINITY, f64::min);
                let same_triangle = from.triangle.is_some() && from.triangle == target.triangle;
                if same_triangle {
                    through_corner.min(distance(&from.point, &target.point))
                } else {
                    through_corner
                }
            }
            GeodesicMethod::Heat => target
                .corners
                .iter()
                .filter(|c| c.1 > 0.0)
                .map(|&(v, w, _)| w * field[v as usize])
                .sum(),
        }
    }

    /// Distances between every pair of sources (markers): row `i` holds the distances from
    /// source `i` to each source. Edge Dijkstra gives a symmetric matrix (up to rounding); the
    /// heat method's is nearly symmetric. Sources in different components are `f64::INFINITY`
    /// apart.
    pub fn between(&self, sources: &[Source]) -> Result<Vec<Vec<f64>>, GeodesicError> {
        let fields = self.from_sources(sources)?;
        self.between_fields(sources, &fields)
    }

    /// [`Geodesics::between`] from fields already computed by [`Geodesics::from_sources`]
    /// for the same `sources`.
    pub fn between_fields(
        &self,
        sources: &[Source],
        fields: &[Vec<f64>],
    ) -> Result<Vec<Vec<f64>>, GeodesicError> {
        let seeds = self.all_seeds(sources)?;
        Ok(fields
            .iter()
            .zip(&seeds)
            .map(|(field, from)| seeds.iter().map(|to| self.at(field, from, to)).collect())
            .collect())
    }
}

#[cfg(test)]
pub(crate) mod tests;
