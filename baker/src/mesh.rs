//! Mesh utilities: topology of a triangle mesh (adjacency, edges, connected components,
//! boundary loops), closest points on the surface, and farthest-point sampling.
//!
//! Everything here works on plain `positions` / `triangles` slices, so it applies to the
//! welded mesh (topology) as well as to the original glTF vertex order (surface points whose
//! barycentric weights interpolate per-vertex data such as morph deltas).

use thiserror::Error;

/// Difference `a - b`.
pub fn sub(a: &[f64; 3], b: &[f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// Dot product.
pub fn dot(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Euclidean length.
pub fn norm(a: &[f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

/// `a` scaled to length one; `None` for a zero or non-finite vector.
pub fn unit(a: &[f64; 3]) -> Option<[f64; 3]> {
    let l = norm(a);
    (l > 0.0 && l.is_finite()).then(|| a.map(|c| c / l))
}

/// Cross product `a × b`.
pub fn cross(a: &[f64; 3], b: &[f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// Euclidean distance between two points.
pub fn distance(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    norm(&sub(a, b))
}

/// The corners of an opening's rim (welded ids into `welded`): the positions in `rim` of its
/// lowest and its highest x (the last of equals), the ends of the mouth and of the eyes across
/// the face (glTF's x).
pub fn x_extremes(rim: &[u32], welded: &[[f64; 3]]) -> (usize, usize) {
    let x = |i: usize| welded[rim[i] as usize][0];
    let extreme = |max: bool| {
        (0..rim.len())
            .max_by(|&a, &b| {
                let o = x(a).total_cmp(&x(b));
                if max {
                    o
                } else {
                    o.reverse()
                }
            })
            .unwrap_or(0)
    };
    (extreme(false), extreme(true))
}

/// Mean position of `vertices` (the origin when there are none).
///
/// # Panics
/// If a vertex id is beyond `positions`.
pub fn centroid(positions: &[[f64; 3]], vertices: &[u32]) -> [f64; 3] {
    let mut sum = [0.0; 3];
    for &v in vertices {
        let p = positions[v as usize];
        sum = [sum[0] + p[0], sum[1] + p[1], sum[2] + p[2]];
    }
    let n = vertices.len().max(1) as f64;
    sum.map(|x| x / n)
}

/// Mean of `points` (the origin for none): for a head's skin, where its bulk is, behind its
/// face.
pub fn mean(points: &[[f64; 3]]) -> [f64; 3] {
    let n = points.len().max(1) as f64;
    [0, 1, 2].map(|c| points.iter().map(|p| p[c]).sum::<f64>() / n)
}

/// The triangles of an `n` × `n` grid of vertices numbered row by row: two per cell, each cell
/// split along the diagonal from its first vertex (for tests and benches on sheets).
pub fn grid_triangles(n: usize) -> Vec<[u32; 3]> {
    let mut triangles = Vec::with_capacity(2 * n.saturating_sub(1).pow(2));
    for y in 0..n.saturating_sub(1) {
        for x in 0..n - 1 {
            let v = (y * n + x) as u32;
            let n = n as u32;
            triangles.push([v, v + 1, v + n + 1]);
            triangles.push([v, v + n + 1, v + n]);
        }
    }
    triangles
}

/// Errors from the mesh utilities (bad arguments, not bad files).
#[derive(Debug, Error, PartialEq)]
pub enum MeshError {
    /// A vertex id is not below the vertex count.
    #[error("vertex {vertex} does not exist (the mesh has {vertex_count} vertices)")]
    VertexOutOfRange {
        /// The bad id.
        vertex: u32,
        /// Number of vertices.
        vertex_count: usize,
    },
    /// Farthest-point sampling was seeded with a vertex outside the subset.
    #[error("start vertex {start} is not in the subset being sampled")]
    StartNotInSubset {
        /// The start vertex.
        start: u32,
    },
}

/// An undirected edge of the mesh.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Edge {
    /// Smaller vertex id.
    pub a: u32,
    /// Larger vertex id.
    pub b: u32,
    /// Euclidean length.
    pub length: f64,
    /// Number of triangles using the edge: 1 on a boundary, 2 inside a manifold surface.
    pub triangles: u32,
}

/// Connected components of a mesh, numbered from the largest (most vertices) down;
/// ties go to the component holding the smaller vertex id. A vertex used by no triangle is
/// a component of its own.
#[derive(Debug, Clone, PartialEq)]
pub struct Components {
    /// Component id of each vertex.
    pub vertex_component: Vec<u32>,
    /// Number of vertices in each component.
    pub vertex_counts: Vec<usize>,
    /// Number of triangles in each component.
    pub triangle_counts: Vec<usize>,
}

impl Components {
    /// Number of components.
    pub fn len(&self) -> usize {
        self.vertex_counts.len()
    }

    /// True when the mesh has no vertices.
    pub fn is_empty(&self) -> bool {
        self.vertex_counts.is_empty()
    }

    /// The vertices of component `c`, ascending.
    pub fn vertices_of(&self, c: u32) -> Vec<u32> {
        (0..self.vertex_component.len() as u32)
            .filter(|&v| self.vertex_component[v as usize] == c)
            .collect()
    }
}

/// A chain of boundary edges (edges used by exactly one triangle).
#[derive(Debug, Clone, PartialEq)]
pub struct BoundaryLoop {
    /// Vertices in order; for a closed loop the last connects back to the first. The direction
    /// follows the winding of the triangle on the loop's first edge.
    pub vertices: Vec<u32>,
    /// False if the walk dead-ended (possible only on non-manifold boundaries).
    pub closed: bool,
    /// Total edge length (including the closing edge of a closed loop).
    pub length: f64,
    /// Component the loop belongs to.
    pub component: u32,
}

/// Topology of a triangle mesh, built once.
#[derive(Debug, Clone)]
pub struct Topology {
    /// Sorted neighbour list of each vertex.
    pub neighbours: Vec<Vec<u32>>,
    /// Every undirected edge once, sorted by `(a, b)`.
    pub edges: Vec<Edge>,
    /// Connected components.
    pub components: Components,
    /// Boundary loops, longest first.
    pub boundary_loops: Vec<BoundaryLoop>,
}

impl Topology {
    /// Builds the topology of `triangles` over `positions`.
    ///
    /// # Panics
    /// If a triangle refers to a vertex beyond `positions` (meshes from
    /// [`load_mesh`](crate::io::gltf_mesh::load_mesh) are checked).
    pub fn new(positions: &[[f64; 3]], triangles: &[[u32; 3]]) -> Topology {
        let n = positions.len();
        // Each triangle edge with whether it runs a->b (low to high id) in the triangle's winding.
        let mut half: Vec<(u32, u32, bool)> = triangles
            .iter()
            .flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])])
            .filter(|(u, v)| u != v)
            .map(|(u, v)| (u.min(v), u.max(v), u < v))
            .collect();
        half.sort_unstable();
        let mut edges: Vec<Edge> = Vec::new();
        // For a boundary edge: whether its one triangle runs a->b.
        let mut forward: Vec<bool> = Vec::new();
        for &(a, b, fwd) in &half {
            match edges.last_mut() {
                Some(e) if e.a == a && e.b == b => e.triangles += 1,
                _ => {
                    edges.push(Edge {
                        a,
                        b,
                        length: distance(&positions[a as usize], &positions[b as usize]),
                        triangles: 1,
                    });
                    forward.push(fwd);
                }
            }
        }
        let mut neighbours = vec![Vec::new(); n];
        for e in &edges {
            neighbours[e.a as usize].push(e.b);
            neighbours[e.b as usize].push(e.a);
        }
        for list in &mut neighbours {
            list.sort_unstable();
        }
        let components = components(n, &edges, triangles);
        let boundary_loops = boundary_loops(n, &edges, &forward, &components);
        Topology {
            neighbours,
            edges,
            components,
            boundary_loops,
        }
    }

    /// Boundary loops of component `c`, longest first.
    pub fn loops_of(&self, c: u32) -> Vec<&BoundaryLoop> {
        self.boundary_loops
            .iter()
            .filter(|l| l.component == c)
            .collect()
    }

    /// Edges used by more than two triangles.
    pub fn non_manifold_edges(&self) -> Vec<&Edge> {
        self.edges.iter().filter(|e| e.triangles > 2).collect()
    }
}

/// The root of `v` in a union-find forest `parent` (path halving on the way).
pub(crate) fn find(parent: &mut [u32], mut v: u32) -> u32 {
    while parent[v as usize] != v {
        parent[v as usize] = parent[parent[v as usize] as usize];
        v = parent[v as usize];
    }
    v
}

fn components(n: usize, edges: &[Edge], triangles: &[[u32; 3]]) -> Components {
    let mut parent: Vec<u32> = (0..n as u32).collect();
    for e in edges {
        let (ra, rb) = (find(&mut parent, e.a), find(&mut parent, e.b));
        // Keep the smaller id as root so roots are each component's smallest vertex.
        parent[ra.max(rb) as usize] = ra.min(rb);
    }
    let roots: Vec<u32> = (0..n as u32).map(|v| find(&mut parent, v)).collect();
    let mut size = vec![0usize; n];
    for &r in &roots {
        size[r as usize] += 1;
    }
    let mut order: Vec<u32> = (0..n as u32).filter(|&v| roots[v as usize] == v).collect();
    order.sort_by_key(|&r| (std::cmp::Reverse(size[r as usize]), r));
    let mut id_of_root = vec![0u32; n];
    for (id, &r) in order.iter().enumerate() {
        id_of_root[r as usize] = id as u32;
    }
    let vertex_component: Vec<u32> = roots.iter().map(|&r| id_of_root[r as usize]).collect();
    let mut triangle_counts = vec![0usize; order.len()];
    for t in triangles {
        triangle_counts[vertex_component[t[0] as usize] as usize] += 1;
    }
    Components {
        vertex_counts: order.iter().map(|&r| size[r as usize]).collect(),
        vertex_component,
        triangle_counts,
    }
}

fn boundary_loops(
    n: usize,
    edges: &[Edge],
    forward: &[bool],
    components: &Components,
) -> Vec<BoundaryLoop> {
    let boundary: Vec<usize> = (0..edges.len())
        .filter(|&i| edges[i].triangles == 1)
        .collect();
    // Boundary edges at each vertex.
    let mut at: Vec<Vec<usize>> = vec![Vec::new(); n];
    for &i in &boundary {
        at[edges[i].a as usize].push(i);
        at[edges[i].b as usize].push(i);
    }
    let mut used = vec![false; edges.len()];
    let mut loops = Vec::new();
    for &first in &boundary {
        if used[first] {
            continue;
        }
        used[first] = true;
        let (start, mut cur) = if forward[first] {
            (edges[first].a, edges[first].b)
        } else {
            (edges[first].b, edges[first].a)
        };
        let mut vertices = vec![start];
        let mut length = edges[first].length;
        let mut closed = true;
        while cur != start {
            vertices.push(cur);
            let Some(&next) = at[cur as usize].iter().find(|&&i| !used[i]) else {
                closed = false;
                break;
            };
            used[next] = true;
            length += edges[next].length;
            let e = &edges[next];
            cur = if e.a == cur { e.b } else { e.a };
        }
        loops.push(BoundaryLoop {
            component: components.vertex_component[start as usize],
            vertices,
            closed,
            length,
        });
    }
    loops.sort_by(|a, b| b.length.total_cmp(&a.length));
    loops
}

/// A point on a triangle of a mesh.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfacePoint {
    /// Index into the triangle list the point was found on.
    pub triangle: usize,
    /// That triangle's vertex ids (so the point can be evaluated without the triangle list).
    pub vertices: [u32; 3],
    /// Barycentric weights of `vertices` (non-negative, summing to 1).
    pub barycentric: [f64; 3],
    /// The point itself.
    pub point: [f64; 3],
    /// Distance from the query point (0 for points made from a vertex).
    pub distance: f64,
}

impl SurfacePoint {
    /// The surface point exactly at corner `corner` (0..3) of triangle `triangle`.
    pub fn at_corner(
        positions: &[[f64; 3]],
        triangles: &[[u32; 3]],
        triangle: usize,
        corner: usize,
    ) -> SurfacePoint {
        let vertices = triangles[triangle];
        let mut barycentric = [0.0; 3];
        barycentric[corner] = 1.0;
        SurfacePoint {
            triangle,
            vertices,
            barycentric,
            point: positions[vertices[corner] as usize],
            distance: 0.0,
        }
    }

    /// Evaluates a per-vertex field (positions, morphed positions, morph deltas...) at this
    /// point by barycentric interpolation.
    ///
    /// # Panics
    /// If the field is shorter than the mesh the point was found on.
    pub fn interpolate(&self, field: &[[f64; 3]]) -> [f64; 3] {
        let mut out = [0.0; 3];
        for (&v, &w) in self.vertices.iter().zip(&self.barycentric) {
            for k in 0..3 {
                out[k] += w * field[v as usize][k];
            }
        }
        out
    }
}

/// The closest point to `p` on the triangle `(a, b, c)`, as barycentric weights of a, b, c.
///
/// Exact: classifies `p` against the Voronoi regions of the triangle's vertices, edges and face.
/// Degenerate (zero-area) triangles fall back to the closest of their three edges.
pub fn closest_on_triangle(p: &[f64; 3], a: &[f64; 3], b: &[f64; 3], c: &[f64; 3]) -> [f64; 3] {
    let ab = sub(b, a);
    let ac = sub(c, a);
    let ap = sub(p, a);
    let d1 = dot(&ab, &ap);
    let d2 = dot(&ac, &ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return [1.0, 0.0, 0.0];
    }
    let bp = sub(p, b);
    let d3 = dot(&ab, &bp);
    let d4 = dot(&ac, &bp);
    if d3 >= 0.0 && d4 <= d3 {
        return [0.0, 1.0, 0.0];
    }
    let cp = sub(p, c);
    let d5 = dot(&ab, &cp);
    let d6 = dot(&ac, &cp);
    if d6 >= 0.0 && d5 <= d6 {
        return [0.0, 0.0, 1.0];
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 && d1 > d3 {
        let v = d1 / (d1 - d3);
        return [1.0 - v, v, 0.0];
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 && d2 > d6 {
        let w = d2 / (d2 - d6);
        return [1.0 - w, 0.0, w];
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 >= d3 && d5 >= d6 && (d4 - d3) + (d5 - d6) > 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return [0.0, 1.0 - w, w];
    }
    let denom = va + vb + vc;
    if denom > 0.0 && va >= 0.0 && vb >= 0.0 && vc >= 0.0 {
        let v = vb / denom;
        let w = vc / denom;
        return [1.0 - v - w, v, w];
    }
    closest_on_edges(p, [a, b, c])
}

/// Fallback for degenerate triangles: the closest point over the three edges.
fn closest_on_edges(p: &[f64; 3], corners: [&[f64; 3]; 3]) -> [f64; 3] {
    let mut best = ([1.0, 0.0, 0.0], f64::INFINITY);
    for (i, j) in [(0, 1), (1, 2), (2, 0)] {
        let (u, v) = (corners[i], corners[j]);
        let uv = sub(v, u);
        let len2 = dot(&uv, &uv);
        let t = if len2 > 0.0 {
            (dot(&sub(p, u), &uv) / len2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let q = [u[0] + t * uv[0], u[1] + t * uv[1], u[2] + t * uv[2]];
        let d = distance(p, &q);
        if d < best.1 {
            let mut bary = [0.0; 3];
            bary[i] = 1.0 - t;
            bary[j] = t;
            best = (bary, d);
        }
    }
    best.0
}

/// The closest point to `p` on the surface `triangles` over `positions`, or `None` when there
/// are no triangles. Ties go to the lower triangle index.
///
/// Exact point–triangle distances over all triangles; each triangle's bounding box is tested
/// first so far triangles cost a few comparisons.
///
/// # Panics
/// If a triangle refers to a vertex beyond `positions`.
pub fn closest_point(
    positions: &[[f64; 3]],
    triangles: &[[u32; 3]],
    p: [f64; 3],
) -> Option<SurfacePoint> {
    let mut best: Option<(usize, [f64; 3], [f64; 3])> = None;
    let mut best_d2 = f64::INFINITY;
    for (t, tri) in triangles.iter().enumerate() {
        let [a, b, c] = tri.map(|v| &positions[v as usize]);
        // Squared distance from p to the triangle's bounding box: a lower bound.
        let mut box_d2 = 0.0;
        for k in 0..3 {
            let lo = a[k].min(b[k]).min(c[k]);
            let hi = a[k].max(b[k]).max(c[k]);
            let gap = (lo - p[k]).max(p[k] - hi).max(0.0);
            box_d2 += gap * gap;
        }
        if box_d2 >= best_d2 {
            continue;
        }
        let bary = closest_on_triangle(&p, a, b, c);
        let q: [f64; 3] = std::array::from_fn(|k| bary[0] * a[k] + bary[1] * b[k] + bary[2] * c[k]);
        let d = sub(&p, &q);
        let d2 = dot(&d, &d);
        if d2 < best_d2 {
            best_d2 = d2;
            best = Some((t, bary, q));
        }
    }
    best.map(|(triangle, barycentric, point)| SurfacePoint {
        triangle,
        vertices: triangles[triangle],
        barycentric,
        point,
        distance: best_d2.sqrt(),
    })
}

/// Farthest-point sampling of up to `k` vertices of `subset`, seeded with `start`.
///
/// The first sample is `start`; each next one is the subset vertex farthest (Euclidean) from
/// all samples so far, the earliest in `subset` order on ties, so the result is deterministic.
/// Stops early when every remaining vertex coincides with a sample.
pub fn farthest_point_sampling(
    positions: &[[f64; 3]],
    subset: &[u32],
    k: usize,
    start: u32,
) -> Result<Vec<u32>, MeshError> {
    if let Some(&vertex) = subset
        .iter()
        .chain([&start])
        .find(|&&v| v as usize >= positions.len())
    {
        return Err(MeshError::VertexOutOfRange {
            vertex,
            vertex_count: positions.len(),
        });
    }
    if !subset.contains(&start) {
        return Err(MeshError::StartNotInSubset { start });
    }
    let mut samples = Vec::with_capacity(k.min(subset.len()));
    let mut nearest = vec![f64::INFINITY; subset.len()];
    let mut next = start;
    while samples.len() < k {
        samples.push(next);
        let s = positions[next as usize];
        let mut far = (0.0, None);
        for (d, &v) in nearest.iter_mut().zip(subset) {
            *d = d.min(distance(&positions[v as usize], &s));
            if *d > far.0 {
                far = (*d, Some(v));
            }
        }
        match far.1 {
            Some(v) => next = v,
            None => break,
        }
    }
    Ok(samples)
}

/// Harmonic interpolation of per-vertex rows over a graph: `sweeps` Gauss–Seidel sweeps in
/// which each vertex of `free` (in that order) takes the mean of its `neighbours`' rows; every
/// other row is held. A free vertex without neighbours keeps its row. A mouth's bag stretched
/// between the lips (`surface::interior`) and weights relaxed round a fold (`bake::relax`).
pub(crate) fn harmonic_sweeps(
    rows: &mut [Vec<f64>],
    neighbours: &[Vec<u32>],
    free: &[usize],
    sweeps: usize,
) {
    for _ in 0..sweeps {
        for &w in free {
            let around = &neighbours[w];
            if around.is_empty() {
                continue;
            }
            let mut mean = vec![0.0; rows[w].len()];
            for &u in around {
                for (m, r) in mean.iter_mut().zip(&rows[u as usize]) {
                    *m += r / around.len() as f64;
                }
            }
            rows[w] = mean;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::gltf_mesh::load_mesh;
    use crate::io::gltf_mesh::tests::{head, MEDIAPIPE};
    use std::path::Path;

    #[test]
    fn facecap_components() {
        let m = head();
        let topo = m.welded_topology();
        let c = &topo.components;
        // The skin plus 15 separate mouth-interior pieces (one of 166 vertices and 14 small
        // ones in mirrored pairs); every welded vertex is used by some triangle.
        assert_eq!(
            c.vertex_counts,
            [1919, 166, 49, 49, 49, 49, 41, 41, 41, 41, 39, 39, 34, 34, 34, 34]
        );
        assert_eq!(
            c.triangle_counts,
            [3706, 308, 88, 88, 88, 88, 72, 72, 72, 72, 69, 69, 60, 60, 60, 60]
        );
        assert_eq!(c.triangle_counts.iter().sum::<usize>(), 5032);
        assert_eq!(c.vertices_of(0).len(), c.vertex_counts[0]);
        assert!(topo.non_manifold_edges().is_empty());
        // Each interior piece is a cup with one opening.
        for piece in 1..16 {
            assert_eq!(topo.loops_of(piece).len(), 1, "piece {piece}");
        }
    }

    #[test]
    fn facecap_skin_has_four_boundary_loops_neck_longest() {
        let m = head();
        let topo = m.welded_topology();
        let loops = topo.loops_of(0);
        assert_eq!(loops.len(), 4);
        assert!(loops.iter().all(|l| l.closed));
        let centroid = |l: &BoundaryLoop| centroid(&m.welded_positions, &l.vertices);
        // The neck: longest by far, and the only one behind the face (negative z).
        let neck = centroid(loops[0]);
        assert!(neck[2] < -0.03, "{neck:?}");
        assert!(loops[1..].iter().all(|l| centroid(l)[2] > 0.03));
        assert!(loops[0].length > 4.0 * loops[1].length);
        // The other three: two eye openings mirrored in x, and the lip opening below them.
        let mut rest: Vec<[f64; 3]> = loops[1..].iter().map(|l| centroid(l)).collect();
        rest.sort_by(|a, b| a[0].total_cmp(&b[0]));
        let (right, mouth, left) = (rest[0], rest[1], rest[2]);
        assert!(mouth[0].abs() < 1e-3, "{mouth:?}");
        assert!(
            (right[0] + left[0]).abs() < 1e-3 && left[0] > 0.02,
            "{left:?} {right:?}"
        );
        assert!(mouth[1] < left[1] - 0.03 && mouth[1] < right[1] - 0.03);
        // Each boundary edge is in exactly one loop.
        let boundary_edges = topo.edges.iter().filter(|e| e.triangles == 1).count();
        let in_loops: usize = topo.boundary_loops.iter().map(|l| l.vertices.len()).sum();
        assert_eq!(boundary_edges, in_loops);
    }

    #[test]
    fn adjacency_and_edges_agree() {
        let m = head();
        let topo = m.welded_topology();
        let degree_sum: usize = topo.neighbours.iter().map(Vec::len).sum();
        assert_eq!(degree_sum, 2 * topo.edges.len());
        // Euler: E = (3F + B) / 2 for a mesh whose edges are used once or twice.
        let boundary = topo.edges.iter().filter(|e| e.triangles == 1).count();
        assert_eq!(2 * topo.edges.len(), 3 * 5032 + boundary);
        let e = topo.edges[10];
        assert!(topo.neighbours[e.a as usize].binary_search(&e.b).is_ok());
        let len = distance(
            &m.welded_positions[e.a as usize],
            &m.welded_positions[e.b as usize],
        );
        assert_eq!(e.length, len);
    }

    #[test]
    fn mediapipe_is_one_disk() {
        let m = load_mesh(Path::new(MEDIAPIPE), None, None).unwrap();
        let topo = m.welded_topology();
        assert_eq!(topo.components.len(), 1);
        assert_eq!(topo.boundary_loops.len(), 1);
        assert!(topo.boundary_loops[0].closed);
        assert!(topo.non_manifold_edges().is_empty());
        // A disk: V - E + F = 1.
        let euler = 468 - topo.edges.len() as i64 + 898;
        assert_eq!(euler, 1);
    }

    #[test]
    fn closest_point_on_single_triangle() {
        let pos = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        let tri = [[0u32, 1, 2]];
        let cases: [([f64; 3], [f64; 3], f64); 5] = [
            ([0.25, 0.25, 2.0], [0.25, 0.25, 0.0], 2.0),       // face
            ([-1.0, -1.0, 0.0], [0.0, 0.0, 0.0], 2f64.sqrt()), // vertex a
            ([0.5, -3.0, 4.0], [0.5, 0.0, 0.0], 5.0),          // edge ab
            ([1.0, 1.0, 0.0], [0.5, 0.5, 0.0], 0.5f64.sqrt()), // edge bc
            ([3.0, -1.0, 0.0], [1.0, 0.0, 0.0], 5f64.sqrt()),  // vertex b
        ];
        for (p, want, d) in cases {
            let sp = closest_point(&pos, &tri, p).unwrap();
            assert!(distance(&sp.point, &want) < 1e-12, "{p:?} -> {sp:?}");
            assert!((sp.distance - d).abs() < 1e-12, "{p:?} -> {sp:?}");
            assert!(distance(&sp.interpolate(&pos), &want) < 1e-12);
            assert!((sp.barycentric.iter().sum::<f64>() - 1.0).abs() < 1e-12);
        }
        assert!(closest_point(&pos, &[], [0.0; 3]).is_none());
        // Degenerate triangles (collinear, and all three corners equal) stay finite.
        let line = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]];
        let sp = closest_point(&line, &tri, [1.5, 1.0, 0.0]).unwrap();
        assert!(distance(&sp.point, &[1.5, 0.0, 0.0]) < 1e-12, "{sp:?}");
        let dot_tri = [[1.0, 1.0, 1.0]; 3];
        let sp = closest_point(&dot_tri, &tri, [1.0, 1.0, 3.0]).unwrap();
        assert!((sp.distance - 2.0).abs() < 1e-12, "{sp:?}");
    }

    #[test]
    fn closest_point_matches_brute_force_on_facecap() {
        let m = head();
        let topo = m.welded_topology();
        let skin = topo.components.vertices_of(0);
        for (i, &v) in skin.iter().step_by(97).enumerate() {
            // Push each vertex off the surface by a varying offset.
            let o = 0.002 * (i % 5) as f64;
            let q = m.welded_positions[v as usize];
            let p = [q[0] + o, q[1] - 0.5 * o, q[2] + 0.7 * o];
            let sp = closest_point(&m.positions, &m.triangles, p).unwrap();
            let brute = m
                .triangles
                .iter()
                .map(|t| {
                    let [a, b, c] = t.map(|v| &m.positions[v as usize]);
                    let w = closest_on_triangle(&p, a, b, c);
                    let r: [f64; 3] =
                        std::array::from_fn(|k| w[0] * a[k] + w[1] * b[k] + w[2] * c[k]);
                    distance(&p, &r)
                })
                .fold(f64::INFINITY, f64::min);
            assert!((sp.distance - brute).abs() < 1e-12);
            assert!(sp.distance <= distance(&p, &q) + 1e-12);
            assert!(distance(&sp.interpolate(&m.positions), &sp.point) < 1e-12);
            assert!(sp.barycentric.iter().all(|&w| (0.0..=1.0).contains(&w)));
        }
        // A point on a vertex snaps onto it.
        let v = skin[500];
        let sp = closest_point(
            &m.welded_positions,
            &m.welded_triangles,
            m.welded_positions[v as usize],
        )
        .unwrap();
        assert_eq!(sp.distance, 0.0);
    }

    #[test]
    fn farthest_point_sampling_on_skin() {
        let m = head();
        let topo = m.welded_topology();
        let skin = topo.components.vertices_of(0);
        let picks = farthest_point_sampling(&m.welded_positions, &skin, 40, skin[0]).unwrap();
        assert_eq!(picks.len(), 40);
        assert_eq!(picks[0], skin[0]);
        let again = farthest_point_sampling(&m.welded_positions, &skin, 40, skin[0]).unwrap();
        assert_eq!(picks, again);
        let mut unique = picks.clone();
        unique.sort_unstable();
        unique.dedup();
        assert_eq!(unique.len(), 40);
        assert!(picks
            .iter()
            .all(|v| topo.components.vertex_component[*v as usize] == 0));
        // Spread: the closest pair of 40 samples on a ~30 cm head is centimetres apart.
        let mut min_gap = f64::INFINITY;
        for (i, &a) in picks.iter().enumerate() {
            for &b in &picks[i + 1..] {
                min_gap = min_gap.min(distance(
                    &m.welded_positions[a as usize],
                    &m.welded_positions[b as usize],
                ));
            }
        }
        assert!(min_gap > 0.02, "{min_gap}");
        // The second sample is the skin vertex farthest from the first.
        let far = skin
            .iter()
            .map(|&v| {
                distance(
                    &m.welded_positions[v as usize],
                    &m.welded_positions[skin[0] as usize],
                )
            })
            .fold(0.0, f64::max);
        let second = distance(
            &m.welded_positions[picks[1] as usize],
            &m.welded_positions[skin[0] as usize],
        );
        assert_eq!(second, far);
    }

    #[test]
    fn farthest_point_sampling_errors_and_limits() {
        let pos = [[0.0; 3], [1.0, 0.0, 0.0], [1.0, 0.0, 0.0], [5.0, 0.0, 0.0]];
        assert_eq!(
            farthest_point_sampling(&pos, &[0, 1], 2, 3),
            Err(MeshError::StartNotInSubset { start: 3 })
        );
        assert_eq!(
            farthest_point_sampling(&pos, &[0, 9], 2, 0),
            Err(MeshError::VertexOutOfRange {
                vertex: 9,
                vertex_count: 4
            })
        );
        // Vertices 1 and 2 coincide: only three distinct positions can be sampled.
        assert_eq!(
            farthest_point_sampling(&pos, &[0, 1, 2, 3], 10, 1),
            Ok(vec![1, 3, 0])
        );
        assert_eq!(
            farthest_point_sampling(&pos, &[0, 1, 2, 3], 0, 1),
            Ok(vec![])
        );
    }
}
