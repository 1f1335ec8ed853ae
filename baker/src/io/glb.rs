//! Writing a face mesh with per-frame morph targets as binary glTF 2.0 (`.glb`), so baked or
//! solved frames can be looked at in any glTF viewer. A played take is written by
//! [`crate::io::gltf_anim`] instead: the source file kept whole, the take as a few morph
//! targets animated at its rate.
//!
//! [`write_glb_with_morphs`] writes one node with one mesh: the rest positions (glTF vertex
//! order), the normals if the mesh has them, the triangles, and one morph target per frame
//! whose `POSITION` deltas are `frame - rest`. Target names go in `mesh.extras.targetNames`;
//! default weights are 0. An animation on the node's `weights` steps through the frames, one
//! per second (`STEP` interpolation; the last frame holds for a second too), so viewers play
//! it. The JSON chunk is padded with spaces and the `BIN` chunk with zeros to 4 bytes, as the
//! GLB container requires; every buffer view is 4-byte aligned.

use std::path::{Path, PathBuf};

use serde_json::{json, Value};
use thiserror::Error;

use crate::model::{bounds, FaceMesh};

/// A named frame: one position per glTF vertex of the mesh, in mesh units.
pub type Frame = (String, Vec<[f32; 3]>);

/// A problem writing a GLB; each names the output file.
#[derive(Debug, Error)]
pub enum GlbError {
    /// A frame does not have one position per mesh vertex.
    #[error("{}: frame {index} (\"{name}\") has {actual} positions; mesh \"{mesh}\" has {expected} vertices", path.display())]
    FrameLength {
        /// The output file.
        path: PathBuf,
        /// Frame number.
        index: usize,
        /// Frame name.
        name: String,
        /// The mesh's name.
        mesh: String,
        /// Vertex count.
        expected: usize,
        /// Positions in the frame.
        actual: usize,
    },
    /// A frame position is NaN or infinite.
    #[error("{}: frame {index} (\"{name}\") position of vertex {vertex} is not finite", path.display())]
    NotFinite {
        /// The output file.
        path: PathBuf,
        /// Frame number.
        index: usize,
        /// Frame name.
        name: String,
        /// The vertex.
        vertex: usize,
    },
    /// The file would exceed the 4 GiB a GLB can hold.
    #[error("{}: {bytes} bytes is more than a GLB file can hold", path.display())]
    TooLarge {
        /// The output file.
        path: PathBuf,
        /// The size it would have.
        bytes: usize,
    },
    /// The file could not be written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The output file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
}

pub(crate) const ARRAY_BUFFER: u32 = 34962;
const ELEMENT_ARRAY_BUFFER: u32 = 34963;
pub(crate) const FLOAT: u32 = 5126;
const UNSIGNED_INT: u32 = 5125;

/// The binary chunk being assembled, with its buffer views and accessors.
#[derive(Default)]
pub(crate) struct Bin {
    pub(crate) bytes: Vec<u8>,
    pub(crate) views: Vec<Value>,
    pub(crate) accessors: Vec<Value>,
}

impl Bin {
    /// Appends `bytes` at the next 4-byte boundary as the buffer view `view` (whose buffer,
    /// offset and length are set here); returns the view index.
    pub(crate) fn bytes_view(&mut self, bytes: &[u8], mut view: Value) -> usize {
        self.bytes.resize(self.bytes.len().next_multiple_of(4), 0);
        view["buffer"] = json!(0);
        view["byteOffset"] = json!(self.bytes.len());
        view["byteLength"] = json!(bytes.len());
        self.bytes.extend_from_slice(bytes);
        self.views.push(view);
        self.views.len() - 1
    }

    /// Appends little-endian 4-byte values as a new buffer view; returns the view index.
    pub(crate) fn view(
        &mut self,
        words: impl IntoIterator<Item = [u8; 4]>,
        target: Option<u32>,
    ) -> usize {
        self.bytes.resize(self.bytes.len().next_multiple_of(4), 0);
        let offset = self.bytes.len();
        self.bytes.extend(words.into_iter().flatten());
        let mut view =
            json!({"buffer": 0, "byteOffset": offset, "byteLength": self.bytes.len() - offset});
        if let Some(t) = target {
            view["target"] = json!(t);
        }
        self.views.push(view);
        self.views.len() - 1
    }

    /// Adds an accessor; returns its index.
    pub(crate) fn accessor(&mut self, accessor: Value) -> usize {
        self.accessors.push(accessor);
        self.accessors.len() - 1
    }

    /// A `VEC3` float accessor with the exact `min`/`max` the spec requires for positions.
    pub(crate) fn vec3s(&mut self, values: &[[f32; 3]]) -> usize {
        // Exact: f32 -> f64 -> f32 round-trips, and min/max pick one of the values.
        let (lo, hi) = bounds(values.iter().map(|v| v.map(f64::from)));
        let (lo, hi) = (lo.map(|x| x as f32), hi.map(|x| x as f32));
        let view = self.view(
            values.iter().flatten().map(|x| x.to_le_bytes()),
            Some(ARRAY_BUFFER),
        );
        self.accessor(
            json!({"bufferView": view, "componentType": FLOAT, "count": values.len(),
                             "type": "VEC3", "min": lo, "max": hi}),
        )
    }
}

/// Writes `mesh` (with its application-specific `_` attributes) with one morph target per frame
/// (delta = frame − rest) as a GLB at `path`.
///
/// Each frame is `(name, positions)` with one position per glTF vertex of `mesh`.
pub fn write_glb_with_morphs(
    path: &Path,
    mesh: &FaceMesh,
    frames: &[Frame],
) -> Result<(), GlbError> {
    let n = mesh.positions.len();
    for (index, (name, frame)) in frames.iter().enumerate() {
        if frame.len() != n {
            return Err(GlbError::FrameLength {
                path: path.to_path_buf(),
                index,
                name: name.clone(),
                mesh: mesh.mesh_name.clone(),
                expected: n,
                actual: frame.len(),
            });
        }
        if let Some(vertex) = frame.iter().position(|p| p.iter().any(|x| !x.is_finite())) {
            return Err(GlbError::NotFinite {
                path: path.to_path_buf(),
                index,
                name: name.clone(),
                vertex,
            });
        }
    }
    let to_f32 =
        |v: &[[f64; 3]]| -> Vec<[f32; 3]> { v.iter().map(|p| p.map(|x| x as f32)).collect() };

    let mut bin = Bin::default();
    let mut attributes = json!({"POSITION": bin.vec3s(&to_f32(&mesh.positions))});
    if let Some(normals) = &mesh.normals {
        let view = bin.view(
            to_f32(normals).iter().flatten().map(|x| x.to_le_bytes()),
            Some(ARRAY_BUFFER),
        );
        attributes["NORMAL"] = json!(bin.accessor(json!({"bufferView": view,
            "componentType": FLOAT, "count": n, "type": "VEC3"})));
    }
    for (name, values) in &mesh.attributes {
        if values.len() == n {
            let view = bin.view(values.iter().map(|x| x.to_le_bytes()), Some(ARRAY_BUFFER));
            attributes[name] = json!(bin.accessor(json!({"bufferView": view,
                "componentType": FLOAT, "count": n, "type": "SCALAR"})));
        }
    }
    let view = bin.view(
        mesh.triangles.iter().flatten().map(|i| i.to_le_bytes()),
        Some(ELEMENT_ARRAY_BUFFER),
    );
    let indices = bin.accessor(json!({"bufferView": view, "componentType": UNSIGNED_INT,
                                      "count": 3 * mesh.triangles.len(), "type": "SCALAR"}));
    let targets: Vec<Value> = frames
        .iter()
        .map(|(_, frame)| {
            let deltas: Vec<[f32; 3]> = frame
                .iter()
                .zip(&mesh.positions)
                .map(|(f, r)| std::array::from_fn(|k| (f64::from(f[k]) - r[k]) as f32))
                .collect();
            json!({"POSITION": bin.vec3s(&deltas)})
        })
        .collect();

    let mut primitive = json!({"attributes": attributes, "indices": indices, "mode": 4});
    let mut gmesh = json!({"name": mesh.mesh_name, "primitives": []});
    let mut root = json!({
        "asset": {"version": "2.0", "generator": concat!("facebake ", env!("CARGO_PKG_VERSION"))},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"name": mesh.mesh_name, "mesh": 0}],
    });
    if !frames.is_empty() {
        let f = frames.len();
        primitive["targets"] = json!(targets);
        gmesh["weights"] = json!(vec![0.0; f]);
        gmesh["extras"] =
            json!({"targetNames": frames.iter().map(|(name, _)| name).collect::<Vec<_>>()});
        // Key i (at i seconds) shows frame i; one more key at f seconds holds the last frame.
        let times = bin.view((0..=f).map(|i| (i as f32).to_le_bytes()), None);
        let input = bin.accessor(json!({"bufferView": times, "componentType": FLOAT,
            "count": f + 1, "type": "SCALAR", "min": [0.0], "max": [f as f32]}));
        let weights = bin.view(
            (0..=f).flat_map(|key| {
                (0..f).map(move |t| (if t == key.min(f - 1) { 1.0f32 } else { 0.0 }).to_le_bytes())
            }),
            None,
        );
        let output = bin.accessor(json!({"bufferView": weights, "componentType": FLOAT,
            "count": (f + 1) * f, "type": "SCALAR"}));
        root["animations"] = json!([{
            "name": "frames",
            "samplers": [{"input": input, "output": output, "interpolation": "STEP"}],
            "channels": [{"sampler": 0, "target": {"node": 0, "path": "weights"}}],
        }]);
    }
    gmesh["primitives"] = json!([primitive]);
    root["meshes"] = json!([gmesh]);
    root["buffers"] = json!([{"byteLength": bin.bytes.len()}]);
    root["bufferViews"] = json!(bin.views);
    root["accessors"] = json!(bin.accessors);

    write_container(path, &root, bin.bytes).map(|_| ())
}

/// Writes `root` and `bin` as a GLB file at `path`: the JSON chunk padded with spaces and the
/// `BIN` chunk with zeros to 4 bytes; returns the file's size.
pub(crate) fn write_container(path: &Path, root: &Value, bin: Vec<u8>) -> Result<usize, GlbError> {
    let mut json_chunk =
        serde_json::to_vec(root).expect("a glTF document of finite numbers serialises");
    json_chunk.resize(json_chunk.len().next_multiple_of(4), b' ');
    let mut bin_chunk = bin;
    bin_chunk.resize(bin_chunk.len().next_multiple_of(4), 0);
    let total = 12 + 8 + json_chunk.len() + 8 + bin_chunk.len();
    let too_large = || GlbError::TooLarge {
        path: path.to_path_buf(),
        bytes: total,
    };
    let total_u32 = u32::try_from(total).map_err(|_| too_large())?;
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&total_u32.to_le_bytes());
    for (chunk, kind) in [(&json_chunk, b"JSON"), (&bin_chunk, b"BIN\0")] {
        // Each chunk is shorter than the total, which fits in u32.
        out.extend_from_slice(&(chunk.len() as u32).to_le_bytes());
        out.extend_from_slice(kind);
        out.extend_from_slice(chunk);
    }
    std::fs::write(path, out).map_err(|source| GlbError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    Ok(total)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::gltf_mesh::load_mesh;
    use crate::io::gltf_mesh::tests::{head, scratch};

    fn frame(m: &FaceMesh, shapes: &[(&str, f64)]) -> Vec<[f32; 3]> {
        let weights: Vec<(usize, f64)> = shapes
            .iter()
            .map(|&(name, w)| (m.morph_index(name).unwrap(), w))
            .collect();
        m.morphed(&weights)
            .iter()
            .map(|p| p.map(|x| x as f32))
            .collect()
    }

    fn facecap_frames() -> Vec<Frame> {
        let m = head();
        vec![
            ("open".to_string(), frame(m, &[("jawOpen", 1.0)])),
            (
                "blink".to_string(),
                frame(m, &[("eyeBlink_L", 1.0), ("eyeBlink_R", 1.0)]),
            ),
            (
                "smile".to_string(),
                frame(m, &[("mouthSmile_L", 0.7), ("mouthSmile_R", 0.5)]),
            ),
        ]
    }

    /// Writes the Face Cap head with [`facecap_frames`] to scratch file `name`.
    fn write_facecap(name: &str) -> (&'static FaceMesh, Vec<Frame>, PathBuf) {
        let (m, frames, path) = (head(), facecap_frames(), scratch(name));
        write_glb_with_morphs(&path, m, &frames).unwrap();
        (m, frames, path)
    }

    #[test]
    fn facecap_frames_read_back_with_gltf_crate() {
        let (m, frames, path) = write_facecap("frames.glb");

        let bytes = std::fs::read(&path).unwrap();
        assert_eq!(&bytes[..4], b"glTF");
        assert_eq!(
            u32::from_le_bytes(bytes[8..12].try_into().unwrap()) as usize,
            bytes.len()
        );
        let json_len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
        assert_eq!(json_len % 4, 0);
        assert_eq!(bytes.len() % 4, 0);

        let (doc, buffers, _) = gltf::import(&path).unwrap();
        let gmesh = doc.meshes().next().unwrap();
        assert_eq!(gmesh.name(), Some("head"));
        assert_eq!(gmesh.weights(), Some(&[0.0f32, 0.0, 0.0][..]));
        let extras: Value = serde_json::from_str(gmesh.extras().as_ref().unwrap().get()).unwrap();
        assert_eq!(extras["targetNames"], json!(["open", "blink", "smile"]));
        let prim = gmesh.primitives().next().unwrap();
        assert_eq!(prim.morph_targets().len(), 3);
        let reader = prim.reader(|b| Some(&buffers[b.index()]));
        let rest: Vec<[f32; 3]> = reader.read_positions().unwrap().collect();
        assert_eq!(rest.len(), 2694);
        let indices: Vec<u32> = reader.read_indices().unwrap().into_u32().collect();
        assert_eq!(indices.len(), 3 * 5032);
        assert_eq!(indices[..3], m.triangles[0]);
        assert_eq!(reader.read_normals().unwrap().count(), 2694);
        let mut moved_most = 0.0f32;
        for ((deltas, _, _), (target, (_, frame))) in reader
            .read_morph_targets()
            .zip(prim.morph_targets().zip(&frames))
        {
            let deltas: Vec<[f32; 3]> = deltas.unwrap().collect();
            for ((r, d), f) in rest.iter().zip(&deltas).zip(frame) {
                for k in 0..3 {
                    assert!((r[k] + d[k] - f[k]).abs() <= 1e-7, "{r:?} + {d:?} != {f:?}");
                    moved_most = moved_most.max(d[k].abs());
                }
            }
            // min/max are the exact bounds of the deltas written.
            let acc = target.positions().unwrap();
            let lo: Vec<f32> = serde_json::from_value(acc.min().unwrap()).unwrap();
            for k in 0..3 {
                assert_eq!(
                    lo[k],
                    deltas.iter().map(|d| d[k]).fold(f32::INFINITY, f32::min)
                );
            }
        }
        assert!(moved_most > 0.005, "{moved_most}");

        let anim = doc.animations().next().unwrap();
        let channel = anim.channels().next().unwrap();
        assert_eq!(channel.target().node().index(), 0);
        assert_eq!(
            channel.sampler().interpolation(),
            gltf::animation::Interpolation::Step
        );
        let r = channel.reader(|b| Some(&buffers[b.index()]));
        let times: Vec<f32> = r.read_inputs().unwrap().collect();
        assert_eq!(times, [0.0, 1.0, 2.0, 3.0]);
        let gltf::animation::util::ReadOutputs::MorphTargetWeights(w) = r.read_outputs().unwrap()
        else {
            panic!("weights channel expected")
        };
        let w: Vec<f32> = w.into_f32().collect();
        assert_eq!(w, [1., 0., 0., 0., 1., 0., 0., 0., 1., 0., 0., 1.]);
    }

    #[test]
    fn written_glb_loads_as_a_face_mesh() {
        let (m, frames, path) = write_facecap("reload.glb");
        let back = load_mesh(&path, None, None).unwrap();
        assert_eq!(back.positions, m.positions);
        assert_eq!(back.triangles, m.triangles);
        assert_eq!(back.normals, m.normals);
        assert_eq!(back.welded_positions.len(), 2659);
        let names: Vec<&str> = back.morph_targets.iter().map(|t| t.name.as_str()).collect();
        assert_eq!(names, ["open", "blink", "smile"]);
        let open = back.morphed(&[(0, 1.0)]);
        for (p, f) in open.iter().zip(&frames[0].1) {
            for k in 0..3 {
                assert!((p[k] - f64::from(f[k])).abs() <= 1e-7);
            }
        }
    }

    #[test]
    fn no_frames_writes_a_plain_mesh() {
        let m = head();
        let path = scratch("plain.glb");
        write_glb_with_morphs(&path, m, &[]).unwrap();
        let (doc, _, _) = gltf::import(&path).unwrap();
        assert_eq!(doc.animations().count(), 0);
        let prim = doc.meshes().next().unwrap().primitives().next().unwrap();
        assert_eq!(prim.morph_targets().len(), 0);
    }

    #[test]
    fn rejects_bad_frames() {
        let m = head();
        let path = scratch("bad.glb");
        let short = vec![("short".to_string(), vec![[0.0f32; 3]; 10])];
        let e = write_glb_with_morphs(&path, m, &short)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("bad.glb")
                && e.contains("\"short\"")
                && e.contains("10 positions")
                && e.contains("2694"),
            "{e}"
        );
        let mut frames = facecap_frames();
        frames[1].1[77][2] = f32::NAN;
        let e = write_glb_with_morphs(&path, m, &frames).unwrap_err();
        assert!(
            matches!(&e, GlbError::NotFinite { index: 1, vertex: 77, name, .. } if name == "blink"),
            "{e}"
        );
    }
}
