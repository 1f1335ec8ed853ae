//! The face mesh: rest positions, triangles, morph targets and a welded copy of the topology,
//! as [`crate::io::gltf_mesh::load_mesh`] reads it from glTF.

use std::collections::HashMap;
use std::path::PathBuf;

use crate::mesh::{find, Topology};
use crate::model::VertexSets;

/// A mask's sides could not be read from a vertex attribute.
#[derive(Debug, thiserror::Error)]
pub enum AttributeSidesError {
    /// The mesh has no such attribute.
    #[error("mesh \"{mesh}\" has no float vertex attribute {name:?} (it has: {known})")]
    Missing {
        /// The mesh's name.
        mesh: String,
        /// The attribute asked for.
        name: String,
        /// The attributes it has, comma-separated, or `none`.
        known: String,
    },
    /// The attribute leaves a side empty.
    #[error("vertex attribute {name:?} puts {upper} vertices on the upper side (> 0.5) and {lower} on the lower (< -0.5): a mask needs both")]
    OneSided {
        /// The attribute.
        name: String,
        /// Vertices on the upper side.
        upper: usize,
        /// Vertices on the lower side.
        lower: usize,
    },
}

/// One morph target (blend shape) of a [`FaceMesh`].
#[derive(Debug, Clone, PartialEq)]
pub struct MorphTarget {
    /// Name from `mesh.extras.targetNames`, or `target_<i>` when the file names none.
    pub name: String,
    /// Per-vertex position offsets, in glTF vertex order and asset units
    /// (all zero when the target carries no `POSITION` attribute).
    pub deltas: Vec<[f64; 3]>,
}

/// The bounding-box diagonals, in metres, within which a mesh is taken to be a head in metres
/// ([`FaceMesh::units_warning`]): a generous band round the 0.2 to 0.5 m of real heads.
pub const HEAD_DIAGONAL_M: (f64, f64) = (0.05, 3.0);

/// A triangle mesh read from glTF, with its morph targets and a welded copy of its topology.
#[derive(Debug, Clone)]
pub struct FaceMesh {
    /// The file the mesh was read from.
    pub source: PathBuf,
    /// The mesh's name in the file (`#<index>` when it has none).
    pub mesh_name: String,
    /// The mesh's index in the file's `meshes` (0 for a mesh made in code).
    pub mesh_index: usize,
    /// The primitive's index in the mesh's `primitives` (0 for a mesh made in code).
    pub primitive_index: usize,
    /// Rest positions, in glTF vertex order and asset units.
    pub positions: Vec<[f64; 3]>,
    /// Vertex normals as stored in the file, if the primitive has `NORMAL`.
    pub normals: Option<Vec<[f64; 3]>>,
    /// Triangles in original glTF vertex indices, in file order.
    pub triangles: Vec<[u32; 3]>,
    /// For each original vertex, the id of its welded vertex (vertices with bit-identical
    /// positions on one piece share one id, `weld_pieces`; ids are numbered in order of first
    /// appearance).
    pub weld: Vec<u32>,
    /// Position of each welded vertex.
    pub welded_positions: Vec<[f64; 3]>,
    /// The same triangles as [`FaceMesh::triangles`] (same order, none dropped) in welded ids;
    /// see [`FaceMesh::degenerate_welded_triangles`] for those that collapse.
    pub welded_triangles: Vec<[u32; 3]>,
    /// Morph targets in file order.
    pub morph_targets: Vec<MorphTarget>,
    /// Application-specific vertex attributes (glTF names starting with `_`) holding one float
    /// per vertex, by name (e.g. `_MASK_MOUTH`); others are not read.
    pub attributes: std::collections::BTreeMap<String, Vec<f32>>,
}

/// Welds vertices with bit-identical positions; returns (original -> welded id, welded positions).
pub(crate) fn weld_positions(positions: &[[f64; 3]]) -> (Vec<u32>, Vec<[f64; 3]>) {
    weld_by(positions, |_| 0)
}

/// Welds the vertices of `triangles` (over `positions`) that have bit-identical positions and lie
/// on one piece: pieces are the triangles joined through edges that exactly two of them share
/// (after the positions are welded), so a UV seam welds while a piece that only touches another
/// along a seam shared by three or more triangles, or at a point, keeps its own vertices there
/// (ICT-FaceKit's eyelashes, tear films and eye-occlusion shells sit on its lids' rims: welded by
/// position alone they hung off the lids and their free edges read as openings). A mesh in one
/// manifold piece welds as [`weld_positions`] does. Returns (original -> welded id, welded
/// positions), ids in order of first appearance.
pub(crate) fn weld_pieces(
    positions: &[[f64; 3]],
    triangles: &[[u32; 3]],
) -> (Vec<u32>, Vec<[f64; 3]>) {
    let (by_position, _) = weld_positions(positions);
    let at = |v: u32| by_position.get(v as usize).copied();
    let mut edges: HashMap<(u32, u32), Vec<u32>> = HashMap::new();
    for (i, t) in triangles.iter().enumerate() {
        let Some(w) = t.iter().map(|&v| at(v)).collect::<Option<Vec<u32>>>() else {
            continue;
        };
        if w[0] == w[1] || w[1] == w[2] || w[0] == w[2] {
            continue;
        }
        for k in 0..3 {
            let (a, b) = (w[k], w[(k + 1) % 3]);
            edges
                .entry((a.min(b), a.max(b)))
                .or_default()
                .push(i as u32);
        }
    }
    let mut parent: Vec<u32> = (0..triangles.len() as u32).collect();
    for pair in edges.values().filter(|t| t.len() == 2) {
        let (a, b) = (find(&mut parent, pair[0]), find(&mut parent, pair[1]));
        parent[a.max(b) as usize] = a.min(b);
    }
    let mut piece = vec![u32::MAX; positions.len()];
    for (i, t) in triangles.iter().enumerate() {
        let r = find(&mut parent, i as u32);
        for &v in t {
            if let Some(slot) = piece.get_mut(v as usize) {
                *slot = (*slot).min(r);
            }
        }
    }
    weld_by(positions, |v| piece[v] as usize)
}

/// Welds vertices with bit-identical positions and the same `key`.
fn weld_by(positions: &[[f64; 3]], key: impl Fn(usize) -> usize) -> (Vec<u32>, Vec<[f64; 3]>) {
    let mut ids: HashMap<([u64; 3], usize), u32> = HashMap::with_capacity(positions.len());
    let mut welded = Vec::new();
    let weld = positions
        .iter()
        .enumerate()
        .map(|(v, p)| {
            *ids.entry((p.map(f64::to_bits), key(v))).or_insert_with(|| {
                welded.push(*p);
                (welded.len() - 1) as u32
            })
        })
        .collect();
    (weld, welded)
}

impl FaceMesh {
    /// A mesh made in code (no file, no morph targets, normals or attributes): `positions` and
    /// `triangles` as given, the weld computed as
    /// [`crate::io::gltf_mesh::load_mesh`] does.
    pub fn from_triangles(name: &str, positions: Vec<[f64; 3]>, triangles: Vec<[u32; 3]>) -> Self {
        let (weld, welded_positions) = weld_pieces(&positions, &triangles);
        let welded_triangles = triangles
            .iter()
            .map(|t| t.map(|v| weld[v as usize]))
            .collect();
        FaceMesh {
            source: PathBuf::new(),
            mesh_name: name.to_string(),
            mesh_index: 0,
            primitive_index: 0,
            positions,
            normals: None,
            triangles,
            weld,
            welded_positions,
            welded_triangles,
            morph_targets: Vec::new(),
            attributes: std::collections::BTreeMap::new(),
        }
    }

    /// Positions with morph targets applied: rest + Σ weight · delta, in glTF vertex order.
    ///
    /// `weights` pairs a morph target index with its weight.
    ///
    /// # Panics
    /// If a target index is out of range (use [`FaceMesh::morph_index`] to look names up).
    pub fn morphed(&self, weights: &[(usize, f64)]) -> Vec<[f64; 3]> {
        let mut out = self.positions.clone();
        for &(t, w) in weights {
            let target = self.morph_targets.get(t).unwrap_or_else(|| {
                panic!(
                    "morph target {t} out of range: mesh \"{}\" has {}",
                    self.mesh_name,
                    self.morph_targets.len()
                )
            });
            for (p, d) in out.iter_mut().zip(&target.deltas) {
                for k in 0..3 {
                    p[k] += w * d[k];
                }
            }
        }
        out
    }

    /// Index of the morph target with this exact name.
    pub fn morph_index(&self, name: &str) -> Option<usize> {
        self.morph_targets.iter().position(|t| t.name == name)
    }

    /// Axis-aligned bounds `(min, max)` of the rest positions.
    pub fn bounds(&self) -> ([f64; 3], [f64; 3]) {
        bounds(self.positions.iter().copied())
    }

    /// Length of the bounding box diagonal of the rest positions (a scale for tolerances).
    pub fn diagonal(&self) -> f64 {
        let (lo, hi) = self.bounds();
        crate::mesh::distance(&lo, &hi)
    }

    /// A warning if the mesh is not head-sized in metres (glTF's unit), naming the unit its
    /// size suggests: every figure in millimetres reads its positions as metres, so a head in
    /// centimetres reads 100 × too large. Heads are 0.2 to 0.5 m across their bounding box
    /// (FaceCap's 0.38, ICT-FaceKit's 0.48); outside [`HEAD_DIAGONAL_M`] this says so.
    pub fn units_warning(&self) -> Option<String> {
        let d = self.diagonal();
        if (HEAD_DIAGONAL_M.0..=HEAD_DIAGONAL_M.1).contains(&d) || !d.is_finite() {
            return None;
        }
        let (unit, per_metre) = [
            ("centimetres", 100.0),
            ("millimetres", 1000.0),
            ("inches", 39.37),
        ]
        .into_iter()
        .min_by(|a, b| {
            let off = |per: f64| (d / (0.35 * per)).ln().abs();
            off(a.1).total_cmp(&off(b.1))
        })
        .unwrap_or(("centimetres", 100.0));
        let guess = if d > HEAD_DIAGONAL_M.1 {
            format!("it is likely in {unit}, and the figures in mm read {per_metre} × too large")
        } else {
            "the figures in mm read it as metres".to_string()
        };
        Some(format!(
            "{}: the mesh is {d:.3} units across its bounding box, and glTF's unit is the metre \
             (a head is 0.2 to 0.5 m): {guess}; scale the file to metres",
            self.source.display()
        ))
    }

    /// Indices of triangles whose welded vertices are not three distinct ids.
    pub fn degenerate_welded_triangles(&self) -> Vec<usize> {
        self.welded_triangles
            .iter()
            .enumerate()
            .filter(|(_, [a, b, c])| a == b || b == c || a == c)
            .map(|(i, _)| i)
            .collect()
    }

    /// For each welded vertex, the first original glTF vertex that maps to it.
    pub fn welded_to_original(&self) -> Vec<u32> {
        let mut out = vec![u32::MAX; self.welded_positions.len()];
        for (orig, &w) in self.weld.iter().enumerate().rev() {
            out[w as usize] = orig as u32;
        }
        out
    }

    /// A mask's sides from the float vertex attribute `name` (such as `_MASK_MOUTH`): above ½
    /// the upper side, below −½ the lower side, between unmasked. Both sides must have
    /// vertices.
    pub fn attribute_sides(&self, name: &str) -> Result<VertexSets, AttributeSidesError> {
        let values = self.attributes.get(name).ok_or_else(|| {
            let known: Vec<&str> = self.attributes.keys().map(String::as_str).collect();
            AttributeSidesError::Missing {
                mesh: self.mesh_name.clone(),
                name: name.to_string(),
                known: if known.is_empty() {
                    "none".to_string()
                } else {
                    known.join(", ")
                },
            }
        })?;
        let pick = |keep: &dyn Fn(f32) -> bool| {
            values
                .iter()
                .enumerate()
                .filter(|(_, &x)| keep(x))
                .map(|(v, _)| v as u32)
                .collect::<Vec<u32>>()
        };
        let (upper, lower) = (pick(&|x| x > 0.5), pick(&|x| x < -0.5));
        if upper.is_empty() || lower.is_empty() {
            return Err(AttributeSidesError::OneSided {
                name: name.to_string(),
                upper: upper.len(),
                lower: lower.len(),
            });
        }
        Ok((upper, lower))
    }

    /// Topology (adjacency, edges, components, boundary loops) of the welded mesh.
    pub fn welded_topology(&self) -> Topology {
        Topology::new(&self.welded_positions, &self.welded_triangles)
    }
}

/// Axis-aligned bounds `(min, max)` of a point set (`(+inf, -inf)` when empty).
pub fn bounds(points: impl IntoIterator<Item = [f64; 3]>) -> ([f64; 3], [f64; 3]) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in points {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    (lo, hi)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A head-sized box says nothing of its units; the same box in centimetres, millimetres or
    /// inches is named so, and one a thousandth of a head's size is said to be read as metres.
    #[test]
    fn a_mesh_not_head_sized_in_metres_is_named_by_its_likely_unit() {
        let boxed = |size: f64| {
            let p = [[0.0, 0.0, 0.0], [size, 0.0, 0.0], [0.0, size, size]];
            FaceMesh::from_triangles("box", p.to_vec(), vec![[0, 1, 2]])
        };
        // A 0.25 m cube's corners span 0.35 m: FaceCap's head is 0.38 m across.
        assert_eq!(boxed(0.25).units_warning(), None);
        for (scale, unit) in [
            (100.0, "centimetres"),
            (1000.0, "millimetres"),
            (39.37, "inches"),
        ] {
            let w = boxed(0.25 * scale).units_warning().expect("a warning");
            assert!(w.contains(&format!("likely in {unit}")), "{w}");
        }
        let w = boxed(0.000_25).units_warning().expect("a warning");
        assert!(w.contains("read it as metres"), "{w}");
    }

    /// A square of two triangles cut by a UV seam along its diagonal (the diagonal's vertices
    /// written twice) welds whole; a third triangle on that diagonal (a fin, as an eyelash strip
    /// on a lid's rim) makes the diagonal an edge of three, and keeps its own vertices (so do the
    /// square's halves, which have no other edge between them; a lid and its socket do).
    #[test]
    fn a_seam_welds_and_a_piece_touching_along_it_does_not() {
        let p = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.5, 0.5, 1.0],
        ];
        let square = [[0, 1, 2], [3, 4, 5]];
        let (weld, welded) = weld_pieces(&p[..6], &square);
        assert_eq!(weld, [0, 1, 2, 0, 2, 3]);
        assert_eq!(welded.len(), 4);
        let with_fin = [[0, 1, 2], [3, 4, 5], [6, 7, 8]];
        let (weld, _) = weld_pieces(&p, &with_fin);
        assert_eq!(&weld[..6], &[0, 1, 2, 3, 4, 5]);
        assert_eq!(&weld[6..], &[6, 7, 8]);
        // By position alone, all three share the diagonal.
        assert_eq!(&weld_positions(&p).0[6..8], &[0, 2]);
    }
}
