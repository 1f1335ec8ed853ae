//! Reading a face mesh (rest positions, triangles, morph targets) from glTF 2.0.
//!
//! [`load_mesh`] reads a `.glb` or `.gltf` file (buffers embedded, in the GLB `BIN` chunk,
//! or in external files next to the `.gltf`), picks one primitive of one mesh (by name and
//! index, else the face: the largest with a mouth and two eyes) and returns a [`FaceMesh`]:
//! positions and triangles in the file's own vertex order and units, optional normals, the
//! morph targets (named from `mesh.extras.targetNames`, the convention Blender and most
//! exporters follow), and a *welded* copy of the topology where vertices with bit-identical
//! positions (UV and normal seams) are merged into one.
//!
//! Node transforms are not applied: positions are in the mesh's own coordinate system.
//! Images are never decoded.

use std::path::{Path, PathBuf};

use gltf::mesh::Mode;
use thiserror::Error;

use crate::io::gltf_check::{self, BufferAccess, GltfCheckError};
use crate::model::{weld_pieces, FaceMesh, MorphTarget};

/// Failure to load a mesh: the file and what is wrong with it.
#[derive(Debug, Error)]
#[error("{}: {kind}", path.display())]
pub struct MeshLoadError {
    /// The file being read.
    pub path: PathBuf,
    /// What went wrong.
    pub kind: MeshLoadErrorKind,
}

/// The problems [`load_mesh`] reports.
#[derive(Debug, Error)]
pub enum MeshLoadErrorKind {
    /// The file failed the checks made before the glTF crate reads it (see `gltf_check`).
    #[error(transparent)]
    Check(#[from] GltfCheckError),
    /// No primitive allowed has the vertex count asked for ([`load_mesh_with_vertices`]).
    #[error(
        "no mesh primitive has {vertices} vertices, as the rig has (not the mesh it was baked \
         from?); the file's: {available}"
    )]
    NoVertexMatch {
        /// The count asked for.
        vertices: usize,
        /// Each primitive of the meshes allowed and its vertex count.
        available: String,
    },
    /// The file contains no mesh at all.
    #[error("the file contains no meshes")]
    NoMeshes,
    /// No mesh has the requested name.
    #[error("no mesh named \"{name}\"; the file has: {available}")]
    NoSuchMesh {
        /// The requested name.
        name: String,
        /// The meshes in the file, comma separated.
        available: String,
    },
    /// The requested primitive index does not exist.
    #[error("mesh \"{mesh}\" has no primitive {index} (it has {count})")]
    NoSuchPrimitive {
        /// Mesh name.
        mesh: String,
        /// Requested primitive index.
        index: usize,
        /// Number of primitives in the mesh.
        count: usize,
    },
    /// The mesh has no `TRIANGLES` primitive.
    #[error("mesh \"{mesh}\" has no TRIANGLES primitive (its primitives' modes: {modes})")]
    NoTrianglePrimitive {
        /// Mesh name.
        mesh: String,
        /// Modes of its primitives.
        modes: String,
    },
    /// The requested primitive is not in `TRIANGLES` mode.
    #[error("mesh \"{mesh}\" primitive {primitive} has mode {mode}; only TRIANGLES is supported")]
    NotTriangles {
        /// Mesh name.
        mesh: String,
        /// Primitive index.
        primitive: usize,
        /// Its mode.
        mode: String,
    },
    /// The primitive lacks the `POSITION` attribute.
    #[error("mesh \"{mesh}\" primitive {primitive} has no POSITION attribute")]
    NoPositions {
        /// Mesh name.
        mesh: String,
        /// Primitive index.
        primitive: usize,
    },
    /// An accessor's data could not be read in full.
    #[error(
        "mesh \"{mesh}\" primitive {primitive}: {what}: expected {expected} items, the buffer holds {actual}"
    )]
    ShortData {
        /// Mesh name.
        mesh: String,
        /// Primitive index.
        primitive: usize,
        /// Which data (e.g. `NORMAL`, `morph target 3 POSITION`).
        what: String,
        /// Items expected (the vertex or index count).
        expected: usize,
        /// Items actually read.
        actual: usize,
    },
    /// The number of indices is not a multiple of three.
    #[error("mesh \"{mesh}\" primitive {primitive}: {count} indices is not a multiple of 3")]
    IndexCount {
        /// Mesh name.
        mesh: String,
        /// Primitive index.
        primitive: usize,
        /// Number of indices.
        count: usize,
    },
    /// A triangle refers to a vertex that does not exist.
    #[error(
        "mesh \"{mesh}\" primitive {primitive}: triangle {triangle} uses vertex {index}, but there are only {vertex_count} vertices"
    )]
    IndexOutOfRange {
        /// Mesh name.
        mesh: String,
        /// Primitive index.
        primitive: usize,
        /// Triangle number.
        triangle: usize,
        /// The bad vertex index.
        index: u32,
        /// Number of vertices.
        vertex_count: usize,
    },
    /// The primitive has no vertices or no triangles.
    #[error("mesh \"{mesh}\" primitive {primitive} is empty ({vertices} vertices, {triangles} triangles)")]
    Empty {
        /// Mesh name.
        mesh: String,
        /// Primitive index.
        primitive: usize,
        /// Number of vertices.
        vertices: usize,
        /// Number of triangles.
        triangles: usize,
    },
    /// A position, normal or morph delta is NaN or infinite.
    #[error("mesh \"{mesh}\" primitive {primitive}: {what} of vertex {vertex} is not finite")]
    NotFinite {
        /// Mesh name.
        mesh: String,
        /// Primitive index.
        primitive: usize,
        /// Which data.
        what: String,
        /// The vertex.
        vertex: usize,
    },
    /// `mesh.extras.targetNames` is present but unusable.
    #[error("mesh \"{mesh}\": extras.targetNames {problem}")]
    BadTargetNames {
        /// Mesh name.
        mesh: String,
        /// What is wrong with it.
        problem: String,
    },
}

/// Loads one triangle primitive of one mesh from a `.glb` or `.gltf` file.
///
/// `mesh` selects a mesh by name and `primitive` a primitive of it by index. Whatever they leave
/// open is the file's face: of the triangle primitives they allow (every one of every mesh when
/// neither is given), the one with the most vertices whose skin has a mouth and two eyes
/// ([`crate::frame::has_face`]); if none has, the first of them. A primitive without indices is
/// read as consecutive vertex triples.
pub fn load_mesh(
    path: &Path,
    mesh: Option<&str>,
    primitive: Option<usize>,
) -> Result<FaceMesh, MeshLoadError> {
    load_mesh_with(path, mesh, primitive, BufferAccess::AssetFolder)
}

/// [`load_mesh`] for a rig of `vertices` vertices (`play --mesh`, `verify`, `render`): of the
/// primitives `mesh` and `primitive` allow, only those with that many vertices, so a rig baked
/// from any primitive of the file finds it. No such primitive is an error that lists each
/// primitive's count.
pub fn load_mesh_with_vertices(
    path: &Path,
    mesh: Option<&str>,
    primitive: Option<usize>,
    vertices: usize,
) -> Result<FaceMesh, MeshLoadError> {
    load(
        path,
        mesh,
        primitive,
        Some(vertices),
        BufferAccess::AssetFolder,
    )
    .map_err(|kind| MeshLoadError {
        path: path.to_path_buf(),
        kind,
    })
}

/// [`load_mesh`], choosing where a `.gltf`'s external buffers may be read from.
pub fn load_mesh_with(
    path: &Path,
    mesh: Option<&str>,
    primitive: Option<usize>,
    access: BufferAccess,
) -> Result<FaceMesh, MeshLoadError> {
    load(path, mesh, primitive, None, access).map_err(|kind| MeshLoadError {
        path: path.to_path_buf(),
        kind,
    })
}

fn load(
    path: &Path,
    mesh_name: Option<&str>,
    primitive_index: Option<usize>,
    vertices: Option<usize>,
    access: BufferAccess,
) -> Result<FaceMesh, MeshLoadErrorKind> {
    // Checked first: the gltf crate trusts the file (see `gltf_check`).
    let (document, buffers) = gltf_check::import(path, access)?;
    let meshes: Vec<gltf::Mesh<'_>> = match mesh_name {
        Some(name) => vec![document
            .meshes()
            .find(|m| m.name() == Some(name))
            .ok_or_else(|| MeshLoadErrorKind::NoSuchMesh {
                name: name.to_owned(),
                available: document
                    .meshes()
                    .map(|m| format!("\"{}\"", display_name(&m)))
                    .collect::<Vec<_>>()
                    .join(", "),
            })?],
        None => document.meshes().collect(),
    };
    let first = meshes.first().cloned().ok_or(MeshLoadErrorKind::NoMeshes)?;
    // The candidates: the given primitive of each mesh, else every triangle primitive of each;
    // of those, the ones with `vertices` vertices if that is asked.
    let count = |p: &gltf::Primitive<'_>| p.get(&gltf::Semantic::Positions).map(|a| a.count());
    let candidates: Vec<(gltf::Mesh<'_>, usize)> = meshes
        .iter()
        .flat_map(|m| {
            m.primitives()
                .filter(|p| match primitive_index {
                    Some(index) => p.index() == index,
                    None => p.mode() == Mode::Triangles,
                })
                .filter(|p| vertices.is_none_or(|n| count(p) == Some(n)))
                .map(|p| (m.clone(), p.index()))
                .collect::<Vec<_>>()
        })
        .collect();
    if let (Some(wanted), true) = (vertices, candidates.is_empty()) {
        return Err(MeshLoadErrorKind::NoVertexMatch {
            vertices: wanted,
            available: meshes
                .iter()
                .flat_map(|m| {
                    m.primitives().map(|p| {
                        format!(
                            "\"{}\" primitive {}: {}",
                            display_name(m),
                            p.index(),
                            count(&p).unwrap_or(0)
                        )
                    })
                })
                .collect::<Vec<_>>()
                .join(", "),
        });
    }
    if candidates.len() > 1 {
        // The file's face: of the primitives that read, the largest whose skin has a mouth and
        // two eyes (an exporter writes one primitive per material, so the skin may sit beside
        // eyelashes, teeth or eyes in the same mesh); else the first.
        let face = candidates
            .iter()
            .filter_map(|(m, p)| read_mesh(path, &buffers, m.clone(), Some(*p)).ok())
            .filter(crate::frame::has_face)
            .max_by_key(|m| {
                (
                    m.positions.len(),
                    std::cmp::Reverse((m.mesh_index, m.primitive_index)),
                )
            });
        if let Some(face) = face {
            return Ok(face);
        }
    }
    match candidates.into_iter().next() {
        Some((m, p)) => read_mesh(path, &buffers, m, Some(p)),
        // No primitive allowed: the first mesh's read says why.
        None => read_mesh(path, &buffers, first, primitive_index),
    }
}

/// A mesh's name as messages give it: its own, else `#index`.
fn display_name(m: &gltf::Mesh) -> String {
    m.name()
        .map(str::to_owned)
        .unwrap_or_else(|| format!("#{}", m.index()))
}

/// One primitive of `gmesh` (`primitive_index`, else its first triangle primitive) as a
/// [`FaceMesh`].
fn read_mesh(
    path: &Path,
    buffers: &[gltf::buffer::Data],
    gmesh: gltf::Mesh<'_>,
    primitive_index: Option<usize>,
) -> Result<FaceMesh, MeshLoadErrorKind> {
    let name = display_name(&gmesh);

    let prim = match primitive_index {
        Some(index) => {
            let prim = gmesh.primitives().nth(index).ok_or_else(|| {
                MeshLoadErrorKind::NoSuchPrimitive {
                    mesh: name.clone(),
                    index,
                    count: gmesh.primitives().len(),
                }
            })?;
            if prim.mode() != Mode::Triangles {
                return Err(MeshLoadErrorKind::NotTriangles {
                    mesh: name,
                    primitive: index,
                    mode: format!("{:?}", prim.mode()),
                });
            }
            prim
        }
        None => gmesh
            .primitives()
            .find(|p| p.mode() == Mode::Triangles)
            .ok_or_else(|| MeshLoadErrorKind::NoTrianglePrimitive {
                mesh: name.clone(),
                modes: gmesh
                    .primitives()
                    .map(|p| format!("{:?}", p.mode()))
                    .collect::<Vec<_>>()
                    .join(", "),
            })?,
    };
    let pi = prim.index();
    let reader = prim.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));

    let position_accessor =
        prim.get(&gltf::Semantic::Positions)
            .ok_or_else(|| MeshLoadErrorKind::NoPositions {
                mesh: name.clone(),
                primitive: pi,
            })?;
    let vertex_count = position_accessor.count();
    let short = |what: &str, expected: usize, actual: usize| MeshLoadErrorKind::ShortData {
        mesh: name.clone(),
        primitive: pi,
        what: what.to_owned(),
        expected,
        actual,
    };
    // `count` 0 accessors are invalid glTF and would make the reader misbehave.
    if vertex_count == 0 {
        return Err(MeshLoadErrorKind::Empty {
            mesh: name,
            primitive: pi,
            vertices: 0,
            triangles: 0,
        });
    }
    let read_vec3s = |it: Option<Box<dyn Iterator<Item = [f32; 3]> + '_>>,
                      what: &str|
     -> Result<Vec<[f64; 3]>, MeshLoadErrorKind> {
        let v: Vec<[f64; 3]> = it
            .map(|it| it.map(|p| p.map(f64::from)).collect())
            .unwrap_or_default();
        if v.len() != vertex_count {
            return Err(short(what, vertex_count, v.len()));
        }
        if let Some(vertex) = v.iter().position(|p| p.iter().any(|x| !x.is_finite())) {
            return Err(MeshLoadErrorKind::NotFinite {
                mesh: name.clone(),
                primitive: pi,
                what: what.to_owned(),
                vertex,
            });
        }
        Ok(v)
    };
    let positions = read_vec3s(
        reader.read_positions().map(|it| Box::new(it) as Box<_>),
        "POSITION",
    )?;
    let normals = match prim.get(&gltf::Semantic::Normals) {
        None => None,
        Some(_) => Some(read_vec3s(
            reader.read_normals().map(|it| Box::new(it) as Box<_>),
            "NORMAL",
        )?),
    };

    let indices: Vec<u32> = match prim.indices() {
        None => (0..vertex_count as u32).collect(),
        Some(acc) => {
            let expected = acc.count();
            let v: Vec<u32> = if expected == 0 {
                Vec::new()
            } else {
                reader
                    .read_indices()
                    .map(|it| it.into_u32().collect())
                    .unwrap_or_default()
            };
            if v.len() != expected {
                return Err(short("indices", expected, v.len()));
            }
            v
        }
    };
    if indices.len() % 3 != 0 {
        return Err(MeshLoadErrorKind::IndexCount {
            mesh: name,
            primitive: pi,
            count: indices.len(),
        });
    }
    let triangles: Vec<[u32; 3]> = indices
        .chunks_exact(3)
        .map(|c| [c[0], c[1], c[2]])
        .collect();
    if triangles.is_empty() {
        return Err(MeshLoadErrorKind::Empty {
            mesh: name,
            primitive: pi,
            vertices: vertex_count,
            triangles: 0,
        });
    }
    for (triangle, t) in triangles.iter().enumerate() {
        if let Some(&index) = t.iter().find(|&&i| i as usize >= vertex_count) {
            return Err(MeshLoadErrorKind::IndexOutOfRange {
                mesh: name,
                primitive: pi,
                triangle,
                index,
                vertex_count,
            });
        }
    }

    let target_count = prim.morph_targets().len();
    let names = target_names(&gmesh, &name, target_count)?;
    let mut morph_targets = Vec::with_capacity(target_count);
    for (i, ((deltas, _, _), name_i)) in reader.read_morph_targets().zip(names).enumerate() {
        let deltas = match prim.morph_targets().nth(i).and_then(|t| t.positions()) {
            None => vec![[0.0; 3]; vertex_count],
            Some(_) => read_vec3s(
                deltas.map(|it| Box::new(it) as Box<_>),
                &format!("morph target {i} (\"{name_i}\") POSITION"),
            )?,
        };
        morph_targets.push(MorphTarget {
            name: name_i,
            deltas,
        });
    }

    let mut attributes = std::collections::BTreeMap::new();
    for (semantic, accessor) in prim.attributes() {
        let gltf::Semantic::Extras(name) = semantic else {
            continue;
        };
        if accessor.dimensions() != gltf::accessor::Dimensions::Scalar
            || accessor.data_type() != gltf::accessor::DataType::F32
        {
            continue;
        }
        let values: Vec<f32> = gltf::accessor::Iter::<f32>::new(accessor, |b| {
            buffers.get(b.index()).map(|d| &d.0[..])
        })
        .map(|it| it.collect())
        .unwrap_or_default();
        let what = format!("_{name}");
        if values.len() != vertex_count {
            return Err(short(&what, vertex_count, values.len()));
        }
        attributes.insert(what, values);
    }

    let (weld, welded_positions) = weld_pieces(&positions, &triangles);
    let welded_triangles = triangles
        .iter()
        .map(|t| t.map(|v| weld[v as usize]))
        .collect();
    Ok(FaceMesh {
        source: path.to_path_buf(),
        mesh_name: name,
        mesh_index: gmesh.index(),
        primitive_index: pi,
        positions,
        normals,
        triangles,
        weld,
        welded_positions,
        welded_triangles,
        morph_targets,
        attributes,
    })
}

/// Target names from `mesh.extras.targetNames`, or `target_<i>` if absent.
fn target_names(
    mesh: &gltf::Mesh,
    mesh_name: &str,
    count: usize,
) -> Result<Vec<String>, MeshLoadErrorKind> {
    let bad = |problem: String| MeshLoadErrorKind::BadTargetNames {
        mesh: mesh_name.to_owned(),
        problem,
    };
    let from_extras = match mesh.extras() {
        None => None,
        Some(raw) => {
            let value: serde_json::Value = serde_json::from_str(raw.get())
                .map_err(|e| bad(format!("cannot be parsed: {e}")))?;
            match value.get("targetNames") {
                None => None,
                Some(v) => Some(
                    serde_json::from_value::<Vec<String>>(v.clone())
                        .map_err(|e| bad(format!("is not a list of strings: {e}")))?,
                ),
            }
        }
    };
    match from_extras {
        None => Ok((0..count).map(|i| format!("target_{i}")).collect()),
        Some(names) if names.len() != count => Err(bad(format!(
            "has {} names but the primitive has {count} morph targets",
            names.len()
        ))),
        Some(names) => Ok(names),
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// The Face Cap head fixture.
    pub(crate) const FACECAP: &str = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../fixtures/FaceCapHeadGeneric.glb"
    );
    /// The MediaPipe canonical face fixture.
    pub(crate) const MEDIAPIPE: &str = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../fixtures/mediapipe_canonical_face_model.glb"
    );

    /// The Face Cap `head` mesh, loaded once per test binary.
    pub(crate) fn head() -> &'static FaceMesh {
        static HEAD: std::sync::OnceLock<FaceMesh> = std::sync::OnceLock::new();
        HEAD.get_or_init(|| load_mesh(Path::new(FACECAP), Some("head"), None).unwrap())
    }

    /// A scratch path unique to this process and `name`.
    pub(crate) fn scratch(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("facebake-mesh-tests-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        dir.join(name)
    }

    #[test]
    fn facecap_head_counts() {
        let m = head();
        assert_eq!(m.mesh_name, "head");
        assert_eq!(m.positions.len(), 2694);
        assert_eq!(m.welded_positions.len(), 2659);
        assert_eq!(m.triangles.len(), 5032);
        assert_eq!(m.welded_triangles.len(), 5032);
        assert_eq!(m.weld.len(), 2694);
        assert_eq!(m.normals.as_ref().map(Vec::len), Some(2694));
        assert!(m.degenerate_welded_triangles().is_empty());
        // Welding keeps geometry: every original vertex sits on its welded vertex.
        for (i, &w) in m.weld.iter().enumerate() {
            assert_eq!(m.positions[i], m.welded_positions[w as usize]);
        }
        let rep = m.welded_to_original();
        assert!(rep.iter().all(|&o| (o as usize) < 2694));
        assert_eq!(m.weld[rep[100] as usize], 100);
    }

    #[test]
    fn facecap_head_morph_targets() {
        let m = head();
        assert_eq!(m.morph_targets.len(), 52);
        // ARKit's 52 shapes in ARKit order, but with Face Cap's `_L`/`_R` suffixes
        // (`eyeBlink_L`, not ARKit's `eyeBlinkLeft`).
        assert_eq!(m.morph_targets[0].name, "browInnerUp");
        assert_eq!(m.morph_index("eyeBlink_L"), Some(13));
        assert_eq!(m.morph_index("jawOpen"), Some(24));
        assert_eq!(m.morph_index("mouthSmile_R"), Some(38));
        assert_eq!(m.morph_index("tongueOut"), Some(51));
        assert_eq!(m.morph_index("eyeBlinkLeft"), None);
        let tongue = &m.morph_targets[m.morph_index("tongueOut").unwrap()];
        assert!(tongue.deltas.iter().all(|d| *d == [0.0; 3]));
        let jaw = m.morph_index("jawOpen").unwrap();
        let max_jaw = m.morph_targets[jaw]
            .deltas
            .iter()
            .map(crate::mesh::norm)
            .fold(0.0, f64::max);
        // The jaw opens by centimetres, and the file is in metres.
        assert!(max_jaw > 0.005 && max_jaw < 0.1, "{max_jaw}");
        // Every other target moves something.
        let still: Vec<&str> = m
            .morph_targets
            .iter()
            .filter(|t| t.deltas.iter().all(|d| *d == [0.0; 3]))
            .map(|t| t.name.as_str())
            .collect();
        assert_eq!(still, ["tongueOut"]);
    }

    #[test]
    fn seam_duplicates_move_together() {
        // Vertices welded together must carry identical morph deltas, or welding would tear
        // the surface when morphed.
        let m = head();
        let rep = m.welded_to_original();
        for t in &m.morph_targets {
            for (i, &w) in m.weld.iter().enumerate() {
                assert_eq!(
                    t.deltas[i], t.deltas[rep[w as usize] as usize],
                    "{}",
                    t.name
                );
            }
        }
    }

    #[test]
    fn facecap_bounds_and_morphing() {
        let m = head();
        let (lo, hi) = m.bounds();
        assert!((lo[0] + 0.0951516).abs() < 1e-6 && (hi[0] - 0.0951516).abs() < 1e-6);
        assert!((hi[1] - 0.1385095).abs() < 1e-6);
        let d = m.diagonal();
        assert!(d > 0.3 && d < 0.4, "{d}");
        let jaw = m.morph_index("jawOpen").unwrap();
        let half = m.morphed(&[(jaw, 0.5)]);
        let full = m.morphed(&[(jaw, 0.25), (jaw, 0.75)]);
        assert_eq!(m.morphed(&[]), m.positions);
        for i in 0..m.positions.len() {
            for k in 0..3 {
                let want = m.positions[i][k] + m.morph_targets[jaw].deltas[i][k];
                assert!((full[i][k] - want).abs() < 1e-12);
                let want = m.positions[i][k] + 0.5 * m.morph_targets[jaw].deltas[i][k];
                assert!((half[i][k] - want).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn other_facecap_meshes() {
        let path = Path::new(FACECAP);
        let first = load_mesh(path, None, None).unwrap();
        assert_eq!(first.mesh_name, "head");
        for name in ["eyeLeft", "eyeRight", "teeth"] {
            let m = load_mesh(path, Some(name), None).unwrap();
            assert_eq!(m.mesh_name, name);
            assert!(m.morph_targets.is_empty());
            assert!(!m.triangles.is_empty());
        }
    }

    /// A mesh for a test file: its name, positions and triangles.
    type Named<'a> = (&'a str, &'a [[f64; 3]], &'a [[u32; 3]]);

    /// A file whose first mesh is not the face: with no name given, the face is read (the
    /// largest mesh with a mouth and two eyes), not the first mesh nor the largest; a file
    /// without a face reads its first mesh.
    #[test]
    fn the_face_is_found_among_a_files_meshes() {
        let head = head();
        let eye = load_mesh(Path::new(FACECAP), Some("eyeLeft"), None).unwrap();
        // A flat sheet larger than the head, without openings: a "body".
        let n = 60u32;
        let sheet: Vec<[f64; 3]> = (0..n * n)
            .map(|i| [f64::from(i % n), f64::from(i / n), 0.0])
            .collect();
        let sheet_triangles: Vec<[u32; 3]> = (0..n - 1)
            .flat_map(|y| (0..n - 1).map(move |x| (x, y)))
            .flat_map(|(x, y)| {
                let v = y * n + x;
                [[v, v + 1, v + n], [v + 1, v + n + 1, v + n]]
            })
            .collect();
        let meshes: [Named<'_>; 3] = [
            ("eye", &eye.positions, &eye.triangles),
            ("body", &sheet, &sheet_triangles),
            ("face", &head.positions, &head.triangles),
        ];
        let write = |name: &str, meshes: &[Named<'_>]| {
            let (mut bin, mut views, mut accessors, mut gltf_meshes) =
                (vec![], vec![], vec![], vec![]);
            for (mesh_name, positions, triangles) in meshes {
                let start = bin.len();
                bin.extend(
                    positions
                        .iter()
                        .flatten()
                        .flat_map(|&x| (x as f32).to_le_bytes()),
                );
                views.push(serde_json::json!({"buffer": 0, "byteOffset": start, "byteLength": bin.len() - start}));
                let (lo, hi) =
                    (0..3).fold(([f64::MAX; 3], [f64::MIN; 3]), |(mut lo, mut hi), c| {
                        for p in positions.iter() {
                            lo[c] = lo[c].min(f64::from(p[c] as f32));
                            hi[c] = hi[c].max(f64::from(p[c] as f32));
                        }
                        (lo, hi)
                    });
                accessors.push(
                    serde_json::json!({"bufferView": views.len() - 1, "componentType": 5126,
                    "count": positions.len(), "type": "VEC3", "min": lo, "max": hi}),
                );
                let start = bin.len();
                bin.extend(triangles.iter().flatten().flat_map(|i| i.to_le_bytes()));
                views.push(serde_json::json!({"buffer": 0, "byteOffset": start, "byteLength": bin.len() - start}));
                accessors.push(
                    serde_json::json!({"bufferView": views.len() - 1, "componentType": 5125,
                    "count": 3 * triangles.len(), "type": "SCALAR"}),
                );
                gltf_meshes.push(serde_json::json!({"name": mesh_name, "primitives": [
                    {"attributes": {"POSITION": accessors.len() - 2}, "indices": accessors.len() - 1}
                ]}));
            }
            std::fs::write(scratch(&format!("{name}.bin")), &bin).unwrap();
            let json = serde_json::json!({
                "asset": {"version": "2.0"},
                "buffers": [{"uri": format!("{name}.bin"), "byteLength": bin.len()}],
                "bufferViews": views, "accessors": accessors, "meshes": gltf_meshes
            });
            let path = scratch(&format!("{name}.gltf"));
            std::fs::write(&path, serde_json::to_vec(&json).unwrap()).unwrap();
            path
        };
        let found = load_mesh(&write("with_face", &meshes), None, None).unwrap();
        assert_eq!((found.mesh_name.as_str(), found.mesh_index), ("face", 2));
        assert_eq!(found.triangles, head.triangles);
        // Named, the named one; without a face, the first.
        let named = load_mesh(&write("named", &meshes), Some("body"), None).unwrap();
        assert_eq!(named.mesh_name, "body");
        let first = load_mesh(&write("no_face", &meshes[..2]), None, None).unwrap();
        assert_eq!(first.mesh_name, "eye");
    }

    #[test]
    fn mediapipe_counts() {
        let m = load_mesh(Path::new(MEDIAPIPE), None, Some(0)).unwrap();
        assert_eq!(m.mesh_name, "mediapipe_canonical_face_model");
        assert_eq!(m.positions.len(), 468);
        assert_eq!(m.welded_positions.len(), 468);
        assert_eq!(m.triangles.len(), 898);
        assert!(m.morph_targets.is_empty());
        // Centimetres: the face is about 15 cm wide.
        let (lo, hi) = m.bounds();
        assert!((hi[0] - lo[0] - 15.486).abs() < 1e-2, "{}", hi[0] - lo[0]);
    }

    #[test]
    fn errors_name_file_and_problem() {
        let path = Path::new(FACECAP);
        let e = load_mesh(path, Some("nose"), None).unwrap_err().to_string();
        assert!(e.contains("FaceCapHeadGeneric.glb"), "{e}");
        assert!(
            e.contains("no mesh named \"nose\"")
                && e.contains("\"head\", \"eyeLeft\", \"eyeRight\", \"teeth\""),
            "{e}"
        );
        let e = load_mesh(path, Some("head"), Some(1)).unwrap_err();
        assert!(
            matches!(
                e.kind,
                MeshLoadErrorKind::NoSuchPrimitive {
                    index: 1,
                    count: 1,
                    ..
                }
            ),
            "{e}"
        );
        let e = load_mesh(Path::new("/nonexistent/face.glb"), None, None).unwrap_err();
        assert!(
            matches!(e.kind, MeshLoadErrorKind::Check(GltfCheckError::Read(_))),
            "{e}"
        );
        assert!(e.to_string().contains("/nonexistent/face.glb"));
    }

    /// Writes a small `.gltf` with an external buffer; `mode` and `indices` vary per test.
    fn write_tiny_gltf(name: &str, mode: u32, indices: &[u32]) -> PathBuf {
        let positions: [[f32; 3]; 3] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        let mut bin: Vec<u8> = positions
            .iter()
            .flatten()
            .flat_map(|x| x.to_le_bytes())
            .collect();
        bin.extend(indices.iter().flat_map(|i| i.to_le_bytes()));
        let bin_path = scratch(&format!("{name}.bin"));
        std::fs::write(&bin_path, &bin).unwrap();
        let json = serde_json::json!({
            "asset": {"version": "2.0"},
            "buffers": [{"uri": format!("{name}.bin"), "byteLength": bin.len()}],
            "bufferViews": [
                {"buffer": 0, "byteOffset": 0, "byteLength": 36},
                {"buffer": 0, "byteOffset": 36, "byteLength": 4 * indices.len()}
            ],
            "accessors": [
                {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                 "min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 0.0]},
                {"bufferView": 1, "componentType": 5125, "count": indices.len(), "type": "SCALAR"}
            ],
            "meshes": [{"name": "tiny", "primitives": [
                {"attributes": {"POSITION": 0}, "indices": 1, "mode": mode}
            ]}]
        });
        let path = scratch(&format!("{name}.gltf"));
        std::fs::write(&path, serde_json::to_vec(&json).unwrap()).unwrap();
        path
    }

    #[test]
    fn reads_gltf_with_external_buffer() {
        let path = write_tiny_gltf("ok", 4, &[0, 1, 2]);
        let m = load_mesh(&path, Some("tiny"), None).unwrap();
        assert_eq!(m.triangles, [[0, 1, 2]]);
        assert_eq!(m.positions[1], [1.0, 0.0, 0.0]);
        assert!(m.normals.is_none());
        assert!(m.morph_targets.is_empty());
    }

    #[test]
    fn rejects_bad_primitives() {
        let lines = write_tiny_gltf("lines", 1, &[0, 1, 1, 2]);
        let e = load_mesh(&lines, None, None).unwrap_err();
        assert!(
            matches!(e.kind, MeshLoadErrorKind::NoTrianglePrimitive { .. }),
            "{e}"
        );
        let e = load_mesh(&lines, None, Some(0)).unwrap_err().to_string();
        assert!(e.contains("lines.gltf") && e.contains("mode Lines"), "{e}");

        let out_of_range = write_tiny_gltf("oor", 4, &[0, 1, 2, 2, 1, 7]);
        let e = load_mesh(&out_of_range, None, None).unwrap_err();
        assert!(
            matches!(
                e.kind,
                MeshLoadErrorKind::IndexOutOfRange {
                    triangle: 1,
                    index: 7,
                    vertex_count: 3,
                    ..
                }
            ),
            "{e}"
        );
        let ragged = write_tiny_gltf("ragged", 4, &[0, 1, 2, 2]);
        let e = load_mesh(&ragged, None, None).unwrap_err();
        assert!(
            matches!(e.kind, MeshLoadErrorKind::IndexCount { count: 4, .. }),
            "{e}"
        );
    }
}
