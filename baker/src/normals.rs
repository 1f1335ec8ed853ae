//! Vertex normals: the blob's normals section built from the mesh, and the f64 reference the
//! runtime's `Rig::normals` is tested against.
//!
//! Both weld the mesh the same way ([`FaceMesh::weld`]: vertices with bit-identical rest
//! positions are one vertex), so vertices split along a seam share one normal, and both weight
//! each triangle by its area (the cross product of two of its edges). The runtime's method and
//! its fixed-point bounds are documented in `facebake-runtime`'s `normals` module.
//!
//! * [`bake`]: the section. Each welded vertex's fan (the other two corners of every triangle
//!   around it, in winding order, as welded vertices) goes to its canonical vertex, the first
//!   glTF vertex of its weld group; the group's other vertices copy its normal; triangles that
//!   collapse under the weld are left out; the rest normals are the reference's at rest.
//! * [`vertex_normals`]: the reference, one triangle pass in f64, independent of the fans.

use facebake_runtime::fixed::NORMAL_FRAC_BITS;

use crate::mesh::{cross, dot, norm, sub};
use crate::model::FaceMesh;

/// The normals section could not be built.
#[derive(Debug, thiserror::Error)]
pub enum NormalsError {
    /// A welded vertex sits in more triangles than a fan holds.
    #[error("vertex {vertex} of mesh \"{mesh}\" is a corner of {count} triangles; a rig's normals allow at most 255")]
    FanTooLarge {
        /// The mesh's name.
        mesh: String,
        /// The glTF vertex (the first of its weld group).
        vertex: u32,
        /// Triangles around it.
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
    /// Fan corner counts, `u8` per vertex.
    pub fan_counts: Vec<u8>,
    /// Fan corners, two indices each.
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
    let mut fan_counts = vec![0u8; vertices];
    let mut corners = Vec::new();
    for (w, fan) in fans.iter().enumerate() {
        let owner = canonical[w];
        fan_counts[owner as usize] =
            u8::try_from(fan.len()).map_err(|_| NormalsError::FanTooLarge {
                mesh: mesh.mesh_name.clone(),
                vertex: owner,
                count: fan.len(),
            })?;
    }
    for v in 0..vertices {
        let w = mesh.weld[v] as usize;
        if canonical[w] as usize == v {
            for &[a, b] in &fans[w] {
                index(a, &mut corners);
                index(b, &mut corners);
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
                .and_then(|ns| unit(ns[v]))
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

/// Angle between two vectors, in degrees (0 when either is zero).
pub fn angle_degrees(a: [f64; 3], b: [f64; 3]) -> f64 {
    if norm(&a) == 0.0 || norm(&b) == 0.0 {
        return 0.0;
    }
    norm(&cross(&a, &b)).atan2(dot(&a, &b)).to_degrees()
}

fn unit(v: [f64; 3]) -> Option<[f64; 3]> {
    let len = norm(&v);
    (len > 0.0 && len.is_finite()).then(|| v.map(|c| c / len))
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
        assert_eq!(b.fan_counts, vec![2, 1, 2, 0, 0, 1]);
        // Vertex 3 copies 0, vertex 4 copies 2.
        assert_eq!(b.welds, vec![3, 0, 0, 0, 4, 0, 2, 0]);
        // The fan of vertex 5 is the second triangle's other corners, as canonical vertices.
        assert_eq!(&b.corners[b.corners.len() - 4..], &[0, 0, 2, 0]);
        let n = vertex_normals(&mesh, &mesh.positions);
        assert_eq!(n[0], n[3]);
        assert_eq!(n[2], n[4]);
        assert_eq!(n[1], [0.0, 0.0, 1.0]);
    }

    #[test]
    fn angles_in_degrees() {
        assert!((angle_degrees([1.0, 0.0, 0.0], [0.0, 2.0, 0.0]) - 90.0).abs() < 1e-12);
        assert_eq!(angle_degrees([1.0, 0.0, 0.0], [0.0; 3]), 0.0);
        assert!(angle_degrees([1.0, 0.0, 0.0], [1.0, 1e-9, 0.0]) < 1e-6);
    }
}
