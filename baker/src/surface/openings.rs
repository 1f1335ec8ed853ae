//! The openings of a face mesh (mouth, eyes): the boundary loops of its largest piece, less the
//! longest loop, which is where the mesh is cut off (the neck of a head, the rim of a mask).

use crate::mesh::{centroid, Topology};

/// A hole in the skin.
#[derive(Debug, Clone, PartialEq)]
pub struct Opening {
    /// Its boundary loop, welded vertex ids.
    pub vertices: Vec<u32>,
    /// Mean position of the loop's vertices.
    pub centre: [f64; 3],
    /// Length of the loop.
    pub length: f64,
}

/// The openings of the largest piece of a welded mesh, longest loop first.
pub fn find_openings(topology: &Topology, welded_positions: &[[f64; 3]]) -> Vec<Opening> {
    let mut loops: Vec<_> = topology
        .boundary_loops
        .iter()
        .filter(|l| l.component == 0 && l.closed)
        .collect();
    loops.sort_by(|a, b| b.length.total_cmp(&a.length));
    loops
        .into_iter()
        .skip(1)
        .map(|l| Opening {
            vertices: l.vertices.clone(),
            centre: centroid(welded_positions, &l.vertices),
            length: l.length,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_tube_with_a_hole_has_one_opening() {
        // A square annulus: outer rim 4 × 4 (the cut), inner hole 2 × 2 (the opening).
        let mut p = Vec::new();
        for &(x, y) in &[(-2.0, -2.0), (2.0, -2.0), (2.0, 2.0), (-2.0, 2.0)] {
            p.push([x, y, 0.0]);
        }
        for &(x, y) in &[(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
            p.push([x, y, 0.0]);
        }
        let mut t = Vec::new();
        for i in 0..4u32 {
            let j = (i + 1) % 4;
            t.push([i, j, 4 + j]);
            t.push([i, 4 + j, 4 + i]);
        }
        let topo = Topology::new(&p, &t);
        let o = find_openings(&topo, &p);
        assert_eq!(o.len(), 1);
        assert!((o[0].length - 8.0).abs() < 1e-12);
        assert!(o[0].centre.iter().all(|c| c.abs() < 1e-12));
    }
}
