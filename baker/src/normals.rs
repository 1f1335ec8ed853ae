//! Vertex normals: the blob's normals section built from the mesh, and the f64 reference the
//! runtime's `Rig::normals` is tested against.
//!
//! Both weld the mesh the same way ([`FaceMesh::weld`]: vertices with bit-identical rest
//! positions are one vertex), so vertices split along a seam share one normal, and both weight
//! each triangle by its area (the cross product of two of its edges). The runtime's method and
//! its fixed-point bounds are documented in `facebake-runtime`'s `normals` module.
//!
//! * [`bake`]: the section. Each welded vertex's fan (the other two corners of every triangle
//!   around it, in winding order, as welded vertices), chained so that consecutive corners are
//!   one triangle's (`chain`), goes to its canonical vertex, the first glTF vertex of its weld
//!   group; the group's other vertices copy its normal; triangles that
//!   collapse under the weld are left out; the rest normals are the reference's at rest.
//! * [`vertex_normals`]: the reference, one triangle pass in f64, independent of the fans.

use facebake_runtime::fixed::NORMAL_FRAC_BITS;

use crate::mesh::{cross, dot, norm, sub};
use crate::model::FaceMesh;

/// The normals section could not be built.
#[derive(Debug, thiserror::Error)]
pub enum NormalsError {
    /// A welded vertex sits in more triangles than a fan holds.
    #[error("vertex {vertex} of mesh \"{mesh}\" has a fan of {count} corners (its triangles' other corners, chained); a rig's normals allow at most 255")]
    FanTooLarge {
        /// The mesh's name.
        mesh: String,
        /// The glTF vertex (the first of its weld group).
        vertex: u32,
        /// Corners in its chained fan.
        count: usize,
    },
}

/// The normals section's bytes, as [`facebake_runtime::normals::Normals`] borrows them.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct NormalsBytes {
    /// Bytes per vertex index: 2 or 4.
    pub index_bytes: u8,
    /// Rest normals, 3 × `i16` LE Q1.14 per vertex.
    pub rest: Vec<u8>,
    /// Corners in each vertex's chained fan, `u8` per vertex.
    pub fan_counts: Vec<u8>,
    /// The chained fans' corners, one index each.
    pub corners: Vec<u8>,
    /// (welded vertex, canonical vertex) index pairs.
    pub welds: Vec<u8>,
}

/// The f64 unit normal of every glTF vertex of `mesh` at `positions` (one per glTF vertex, any
/// units): area-weighted over the triangles around its welded vertex, taken at the positions of
/// each weld group's first vertex. A vertex in no triangle, or whose triangles have no area,
/// gets the zero vector.
pub fn vertex_normals(mesh: &FaceMesh, positions: &[[f64; 3]]) -> Vec<[f64; 3]> {
    let canonical = mesh.welded_to_original();
    let at = |w: u32| positions[canonical[w as usize] as usize];
    let mut sums = vec![[0.0f64; 3]; mesh.welded_positions.len()];
    for t in &mesh.welded_triangles {
        if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
            continue;
        }
        let [a, b, c] = t.map(at);
        let n = cross(&sub(&b, &a), &sub(&c, &a));
        for &w in t {
            for k in 0..3 {
                sums[w as usize][k] += n[k];
            }
        }
    }
    let units: Vec<[f64; 3]> = sums
        .iter()
        .map(|s| {
            let len = s.iter().map(|c| c * c).sum::<f64>().sqrt();
            if len > 0.0 {
                s.map(|c| c / len)
            } else {
                [0.0; 3]
            }
        })
        .collect();
    mesh.weld.iter().map(|&w| units[w as usize]).collect()
}

/// The normals section of `mesh` (see the module docs).
pub fn bake(mesh: &FaceMesh) -> Result<NormalsBytes, NormalsError> {
    let vertices = mesh.positions.len();
    let index_bytes: u8 = if vertices <= 1 << 16 { 2 } else { 4 };
    let index = |v: u32, out: &mut Vec<u8>| {
        if index_bytes == 2 {
            out.extend_from_slice(&(v as u16).to_le_bytes());
        } else {
            out.extend_from_slice(&v.to_le_bytes());
        }
    };
    let canonical = mesh.welded_to_original();
    // Per welded vertex, its fan: the other two corners of each triangle, in winding order.
    let mut fans: Vec<Vec<[u32; 2]>> = vec![Vec::new(); mesh.welded_positions.len()];
    for t in &mesh.welded_triangles {
        if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
            continue;
        }
        for i in 0..3 {
            let (a, b) = (t[(i + 1) % 3], t[(i + 2) % 3]);
            fans[t[i] as usize].push([canonical[a as usize], canonical[b as usize]]);
        }
    }
    let chains: Vec<Vec<u32>> = fans
        .iter()
        .enumerate()
        .map(|(w, fan)| chain(fan, canonical[w]))
        .collect();
    let mut fan_counts = vec![0u8; vertices];
    let mut corners = Vec::new();
    for (w, chain) in chains.iter().enumerate() {
        let owner = canonical[w];
        fan_counts[owner as usize] =
            u8::try_from(chain.len()).map_err(|_| NormalsError::FanTooLarge {
                mesh: mesh.mesh_name.clone(),
                vertex: owner,
                count: chain.len(),
            })?;
    }
    for v in 0..vertices {
        let w = mesh.weld[v] as usize;
        if canonical[w] as usize == v {
            for &c in &chains[w] {
                index(c, &mut corners);
            }
        }
    }
    let mut welds = Vec::new();
    for (v, &w) in mesh.weld.iter().enumerate() {
        let owner = canonical[w as usize];
        if owner as usize != v && !fans[w as usize].is_empty() {
            index(v as u32, &mut welds);
            index(owner, &mut welds);
        }
    }
    let reference = vertex_normals(mesh, &mesh.positions);
    let one = f64::from(1u32 << NORMAL_FRAC_BITS);
    let mut rest = Vec::with_capacity(6 * vertices);
    for (v, n) in reference.iter().enumerate() {
        // A vertex without area keeps the file's normal, or +z.
        let n = if *n != [0.0; 3] {
            *n
        } else {
            mesh.normals
                .as_ref()
                .and_then(|ns| crate::mesh::unit(&ns[v]))
                .unwrap_or([0.0, 0.0, 1.0])
        };
        for c in n {
            let q = (c * one).round().clamp(-one, one) as i16;
            rest.extend_from_slice(&q.to_le_bytes());
        }
    }
    Ok(NormalsBytes {
        index_bytes,
        rest,
        fan_counts,
        corners,
        welds,
    })
}

/// A fan's corner pairs (each triangle's other two corners, in winding order) as one **chain**
/// of corners in which every two consecutive corners are one pair: around an inside vertex the
/// pairs link up (`b` of one triangle is `a` of the next) and n triangles take n + 1 corners
/// instead of 2n. Runs of linked pairs are chained from a pair no other pair leads to (a
/// boundary) where there is one; two runs are separated by `owner` itself, whose edge is zero,
/// so its two cross products add nothing. Every pair is consecutive exactly once, so the
/// runtime's sum over consecutive corners is the sum over the fan's triangles.
fn chain(pairs: &[[u32; 2]], owner: u32) -> Vec<u32> {
    let mut used = vec![false; pairs.len()];
    let mut out = Vec::with_capacity(pairs.len() + 1);
    while let Some(start) = (0..pairs.len()).filter(|&i| !used[i]).min_by_key(|&i| {
        let led_to = (0..pairs.len()).any(|j| !used[j] && j != i && pairs[j][1] == pairs[i][0]);
        (led_to, i)
    }) {
        if !out.is_empty() {
            out.push(owner);
        }
        used[start] = true;
        out.extend_from_slice(&pairs[start]);
        let mut last = pairs[start][1];
        while let Some(next) = (0..pairs.len()).find(|&j| !used[j] && pairs[j][0] == last) {
            used[next] = true;
            last = pairs[next][1];
            out.push(last);
        }
    }
    out
}

/// Angle between two vectors, in degrees (0 when either is zero).
pub fn angle_degrees(a: [f64; 3], b: [f64; 3]) -> f64 {
    if norm(&a) == 0.0 || norm(&b) == 0.0 {
        return 0.0;
    }
    norm(&cross(&a, &b)).atan2(dot(&a, &b)).to_degrees()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A unit square split along a seam: two triangles sharing an edge whose vertices are
    /// duplicated, so the seam's vertices are welded.
    fn seam_square() -> FaceMesh {
        let positions = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 0.0, 0.0], // = 0
            [1.0, 1.0, 0.0], // = 2
            [0.0, 1.0, 0.5],
        ];
        FaceMesh::from_triangles("square", positions, vec![[0, 1, 2], [3, 4, 5]])
    }

    #[test]
    fn fans_go_to_the_first_vertex_of_each_weld_group_and_seams_copy_it() {
        let mesh = seam_square();
        let b = bake(&mesh).unwrap();
        assert_eq!(b.index_bytes, 2);
        // Chained: vertex 0's two triangles share the corner 2, vertex 2's share 0.
        assert_eq!(b.fan_counts, vec![3, 2, 3, 0, 0, 2]);
        // Vertex 3 copies 0, vertex 4 copies 2.
        assert_eq!(b.welds, vec![3, 0, 0, 0, 4, 0, 2, 0]);
        // The fan of vertex 5 is the second triangle's other corners, as canonical vertices.
        assert_eq!(&b.corners[b.corners.len() - 4..], &[0, 0, 2, 0]);
        let n = vertex_normals(&mesh, &mesh.positions);
        assert_eq!(n[0], n[3]);
        assert_eq!(n[2], n[4]);
        assert_eq!(n[1], [0.0, 0.0, 1.0]);
    }

    /// The consecutive pairs of a chain that do not include the owner.
    fn links(chain: &[u32], owner: u32) -> Vec<[u32; 2]> {
        let mut l: Vec<[u32; 2]> = chain
            .windows(2)
            .filter(|w| w[0] != owner && w[1] != owner)
            .map(|w| [w[0], w[1]])
            .collect();
        l.sort_unstable();
        l
    }

    #[test]
    fn a_chain_holds_every_triangle_once_in_n_plus_one_corners_per_run() {
        // Inside: a closed ring of five triangles.
        let ring = [[1, 2], [3, 4], [2, 3], [5, 1], [4, 5]];
        let c = chain(&ring, 9);
        assert_eq!(c.len(), 6);
        assert_eq!(c.first(), c.last());
        let mut sorted = ring.to_vec();
        sorted.sort_unstable();
        assert_eq!(links(&c, 9), sorted);
        // A boundary vertex starts where no triangle leads in.
        assert_eq!(chain(&[[2, 3], [1, 2]], 9), vec![1, 2, 3]);
        // Two runs that do not link (a non-manifold vertex): split by the owner, whose edge is
        // zero, so the two cross products it takes part in add nothing.
        let bowtie = [[1, 2], [5, 6], [2, 3], [6, 7]];
        let c = chain(&bowtie, 9);
        assert_eq!(c, vec![1, 2, 3, 9, 5, 6, 7]);
        let mut sorted = bowtie.to_vec();
        sorted.sort_unstable();
        assert_eq!(links(&c, 9), sorted);
        assert!(chain(&[], 9).is_empty());
    }

    #[test]
    fn angles_in_degrees() {
        assert!((angle_degrees([1.0, 0.0, 0.0], [0.0, 2.0, 0.0]) - 90.0).abs() < 1e-12);
        assert_eq!(angle_degrees([1.0, 0.0, 0.0], [0.0; 3]), 0.0);
        assert!(angle_degrees([1.0, 0.0, 0.0], [1.0, 1e-9, 0.0]) < 1e-6);
    }
}
