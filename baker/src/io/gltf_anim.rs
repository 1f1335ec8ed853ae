//! An animated glTF of a played take: the source file with everything in it kept, and the
//! deformed primitive's morph targets replaced by a small basis animated at the take's rate.
//!
//! [`write_animated_glb`] reads the file the mesh was loaded from through the hardened checks of
//! [`gltf_check`] (buffers and images only from the asset's folder, `data:` URIs decoded) and
//! writes one binary glTF that:
//!
//! - keeps every scene, node, camera, skin, mesh, primitive, material, texture, sampler and
//!   image of the source, with their attributes (normals, UVs, colours) as they were; the
//!   buffers are re-packed into the GLB `BIN` chunk (every buffer view copied whole at a 4-byte
//!   boundary, so strides and accessor offsets hold) and images given by URI are embedded as
//!   buffer views with their MIME type; accessors and views nothing references any more (the
//!   deformed primitive's own morph targets) are dropped;
//! - gives the deformed primitive the take's basis ([`crate::morph_basis`]) as its morph
//!   targets: `POSITION` deltas (with the `min`/`max` glTF requires) and, when the primitive
//!   has normals, `NORMAL` deltas (target 0 is the offset, whose weight is 1 in every frame,
//!   so every weight stays in [0, 1]); the mesh's other primitives get zero targets, as glTF
//!   requires the same target count across a mesh's primitives; `mesh.weights` are zeros and `mesh.extras.targetNames` name the targets;
//! - adds an animation `take` with one `LINEAR` sampler whose input is the frames' times in
//!   seconds and whose output is every frame's weights, on the `weights` of every node that
//!   shows the mesh (the source's own weight channels on those nodes, which would no longer
//!   fit, are dropped).
//!
//! The frames are in the mesh's own space, as the rig plays them: head motion is removed, so
//! the parts the rig does not deform (FaceCap's eyes and teeth, in nodes of their own) stay
//! where they are in the head's frame, which is where they belong. The rig does not know the
//! jaw, so lower teeth do not follow it.
//!
//! **Normal deltas**: the normals of every played frame are the area-weighted normals of its
//! positions ([`crate::normals::vertex_normals`], the f64 twin of the runtime's `Rig::normals`);
//! their change from the same normals at rest is fitted by least squares to the positions'
//! weights ([`morph_basis::fit_deltas`]), so one set of weights drives both. A viewer adds the
//! deltas to the file's own rest normals and renormalises.
//!
//! Extensions the source uses must be ones that reference no accessor, buffer view or buffer
//! ([`copies_extension`]); others (Draco, meshopt, GPU instancing) are refused rather than
//! copied wrong.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use serde_json::{json, Map, Value};
use thiserror::Error;

use crate::io::glb::{write_container, Bin, GlbError, ARRAY_BUFFER, FLOAT};
use crate::io::gltf_check::{self, BufferAccess, Checked, GltfCheckError};
use crate::model::FaceMesh;
use crate::morph_basis::{self, BasisOptions, MorphBasisError};
use crate::normals::{angle_degrees, vertex_normals};

/// A problem writing an animated GLB; each names the file it is about.
#[derive(Debug, Error)]
pub enum GltfAnimError {
    /// The source file failed the loader's checks.
    #[error("{}: {source}", path.display())]
    Source {
        /// The source file.
        path: PathBuf,
        /// What the checks found.
        source: GltfCheckError,
    },
    /// The source has something the writer cannot carry through.
    #[error("{}: {problem}", path.display())]
    Unsupported {
        /// The source file.
        path: PathBuf,
        /// What.
        problem: String,
    },
    /// The frames could not be fitted with a basis.
    #[error("{}: {source}", path.display())]
    Basis {
        /// The output file.
        path: PathBuf,
        /// Why.
        source: MorphBasisError,
    },
    /// The frame times are not one finite, strictly increasing time per frame.
    #[error("{}: {problem}", path.display())]
    Times {
        /// The output file.
        path: PathBuf,
        /// What is wrong with them.
        problem: String,
    },
    /// The file could not be written.
    #[error(transparent)]
    Glb(#[from] GlbError),
}

/// What [`write_animated_glb`] wrote.
#[derive(Debug, Clone, PartialEq)]
pub struct AnimatedGlb {
    /// Frames (animation keys).
    pub frames: usize,
    /// Morph targets of the basis.
    pub targets: usize,
    /// 99th percentile of a reconstructed vertex's distance from the played one, over every
    /// vertex of every frame, in the mesh's units.
    pub p99_error: f64,
    /// The largest such distance.
    pub max_error: f64,
    /// Whether the 99th percentile is within the options' bound.
    pub bound_met: bool,
    /// 99th percentile and largest angle, in degrees, between a frame's reconstructed normal
    /// (rest + weighted deltas) and its exact area-weighted normal; `None` without normals.
    pub normal_degrees: Option<(f64, f64)>,
    /// The file's size.
    pub bytes: usize,
    /// The size of the same file with one morph target per frame instead (positions and, if
    /// present, normals per frame, and one weight per target and key): `bytes` minus the
    /// basis, its weights and times, plus `frames × vertices × 12` bytes per attribute,
    /// `frames² × 4` bytes of weights and `frames × 4` of times.
    pub one_target_per_frame_bytes: usize,
}

/// Whether the writer copies an extension through: those that reference no accessor, buffer
/// view or buffer (materials, texture transforms, lights, quantisation, image formats, XMP).
pub fn copies_extension(name: &str) -> bool {
    name.starts_with("KHR_materials_")
        || matches!(
            name,
            "KHR_texture_transform"
                | "KHR_lights_punctual"
                | "KHR_mesh_quantization"
                | "KHR_texture_basisu"
                | "EXT_texture_webp"
                | "EXT_texture_avif"
                | "KHR_xmp_json_ld"
        )
}

/// The MIME type of image bytes, from their signature (PNG, JPEG, WebP, KTX2).
fn image_mime(bytes: &[u8]) -> Option<&'static str> {
    if bytes.starts_with(b"\x89PNG\r\n\x1a\n") {
        Some("image/png")
    } else if bytes.starts_with(&[0xFF, 0xD8, 0xFF]) {
        Some("image/jpeg")
    } else if bytes.len() >= 12 && &bytes[..4] == b"RIFF" && &bytes[8..12] == b"WEBP" {
        Some("image/webp")
    } else if bytes.starts_with(b"\xABKTX 20\xBB") {
        Some("image/ktx2")
    } else {
        None
    }
}

/// Writes the animated GLB of a take at `path`: the file `mesh` was loaded from
/// (`mesh.source`, its mesh `mesh.mesh_index` and primitive `mesh.primitive_index`), with
/// `frames` (one position per glTF vertex of the primitive, the mesh's units) at `times`
/// (seconds, strictly increasing) as a basis of morph targets within `options`. `access` says
/// where the source's external buffers and images may be read from.
pub fn write_animated_glb(
    path: &Path,
    mesh: &FaceMesh,
    frames: &[Vec<[f64; 3]>],
    times: &[f64],
    options: &BasisOptions,
    access: BufferAccess,
) -> Result<AnimatedGlb, GltfAnimError> {
    let source = &mesh.source;
    let unsupported = |problem: String| GltfAnimError::Unsupported {
        path: source.clone(),
        problem,
    };
    let bad_times = |problem: String| GltfAnimError::Times {
        path: path.to_path_buf(),
        problem,
    };
    if times.len() != frames.len() {
        return Err(bad_times(format!(
            "{} times for {} frames",
            times.len(),
            frames.len()
        )));
    }
    let keys: Vec<f32> = times.iter().map(|&t| t as f32).collect();
    if let Some(i) = keys.iter().position(|t| !t.is_finite() || *t < 0.0) {
        return Err(bad_times(format!(
            "time {i} ({}) is not finite and ≥ 0",
            times[i]
        )));
    }
    if let Some(i) = keys.windows(2).position(|w| w[1] <= w[0]) {
        return Err(bad_times(format!(
            "times {i} and {} ({} s, {} s) do not increase (as f32)",
            i + 1,
            times[i],
            times[i + 1]
        )));
    }
    let checked = gltf_check::check(source, access).map_err(|e| GltfAnimError::Source {
        path: source.clone(),
        source: e,
    })?;
    let mut root = checked.json.clone();
    if let Some(Value::Array(used)) = root.get("extensionsUsed") {
        if let Some(name) = used
            .iter()
            .filter_map(Value::as_str)
            .find(|n| !copies_extension(n))
        {
            return Err(unsupported(format!(
                "extension {} is not copied into an animated glTF (it may reference buffers)",
                crate::io::escape_control(name)
            )));
        }
    }
    let (m, p, n) = (mesh.mesh_index, mesh.primitive_index, mesh.positions.len());
    let counts = primitive_counts(&root, m);
    if counts.get(p).copied().flatten().map(|c| c.0) != Some(n) {
        return Err(unsupported(format!(
            "meshes[{m}].primitives[{p}] is not the {n}-vertex primitive the frames deform"
        )));
    }
    let nodes: Vec<usize> = array(&root, "nodes")
        .iter()
        .enumerate()
        .filter(|(_, node)| node.get("mesh").and_then(Value::as_u64) == Some(m as u64))
        .map(|(i, _)| i)
        .collect();
    if nodes.is_empty() {
        return Err(unsupported(format!(
            "no node shows meshes[{m}] (\"{}\"): there is nothing to animate",
            crate::io::escape_control(&mesh.mesh_name)
        )));
    }

    let basis =
        morph_basis::fit(&mesh.positions, frames, options).map_err(|e| GltfAnimError::Basis {
            path: path.to_path_buf(),
            source: e,
        })?;
    let normals = counts[p]
        .is_some_and(|c| c.1)
        .then(|| normal_deltas(mesh, frames, &basis.weights));

    strip_weights(&mut root, m, &nodes);
    let mut bin = Bin::default();
    copy_through(&mut root, &checked, source, &mut bin)?;

    // The basis, the other primitives' zero targets and the animation.
    let rank = basis.targets.len();
    let primitive_targets: Vec<Value> = basis
        .targets
        .iter()
        .enumerate()
        .map(|(t, target)| {
            let mut value = json!({"POSITION": bin.vec3s(target)});
            if let Some((deltas, _)) = &normals {
                let view = bin.view(
                    deltas[t].iter().flatten().map(|x| x.to_le_bytes()),
                    Some(ARRAY_BUFFER),
                );
                value["NORMAL"] = json!(bin.accessor(json!({"bufferView": view,
                    "componentType": FLOAT, "count": n, "type": "VEC3"})));
            }
            value
        })
        .collect();
    // Zeros in a buffer view of their own: readers such as the `gltf` crate refuse an accessor
    // without one.
    let mut zero_views: HashMap<usize, usize> = HashMap::new();
    let mut zeros: HashMap<(usize, bool), usize> = HashMap::new();
    let mut zero = |bin: &mut Bin, count: usize, position: bool| {
        *zeros.entry((count, position)).or_insert_with(|| {
            let view = *zero_views.entry(count).or_insert_with(|| {
                bin.view(std::iter::repeat_n([0u8; 4], 3 * count), Some(ARRAY_BUFFER))
            });
            let mut accessor = json!({"bufferView": view, "componentType": FLOAT,
                "count": count, "type": "VEC3"});
            if position {
                accessor["min"] = json!([0.0, 0.0, 0.0]);
                accessor["max"] = json!([0.0, 0.0, 0.0]);
            }
            bin.accessor(accessor)
        })
    };
    let gmesh = mesh_object(&mut root, m);
    if let Some(Value::Array(primitives)) = gmesh.get_mut("primitives") {
        for (q, primitive) in primitives.iter_mut().enumerate() {
            let targets = if q == p {
                primitive_targets.clone()
            } else {
                let Some((count, has_normal)) = counts.get(q).copied().flatten() else {
                    continue;
                };
                let mut target = json!({"POSITION": zero(&mut bin, count, true)});
                if has_normal {
                    target["NORMAL"] = json!(zero(&mut bin, count, false));
                }
                vec![target; rank]
            };
            primitive["targets"] = Value::Array(targets);
        }
    }
    gmesh.insert("weights".into(), json!(vec![0.0; rank]));
    let names: Vec<String> = std::iter::once("offset".to_string())
        .chain((1..rank).map(|t| format!("component {t}")))
        .collect();
    match gmesh.get_mut("extras") {
        Some(Value::Object(extras)) => {
            extras.insert("targetNames".into(), json!(names));
        }
        _ => {
            gmesh.insert("extras".into(), json!({ "targetNames": names }));
        }
    }
    let times_view = bin.view(keys.iter().map(|t| t.to_le_bytes()), None);
    let input = bin.accessor(json!({"bufferView": times_view, "componentType": FLOAT,
        "count": keys.len(), "type": "SCALAR",
        "min": [keys[0]], "max": [keys[keys.len() - 1]]}));
    let weights_view = bin.view(
        basis.weights.iter().flatten().map(|w| w.to_le_bytes()),
        None,
    );
    let output = bin.accessor(json!({"bufferView": weights_view, "componentType": FLOAT,
        "count": keys.len() * rank, "type": "SCALAR"}));
    let channels: Vec<Value> = nodes
        .iter()
        .map(|&node| json!({"sampler": 0, "target": {"node": node, "path": "weights"}}))
        .collect();
    let animation = json!({
        "name": "take",
        "samplers": [{"input": input, "output": output, "interpolation": "LINEAR"}],
        "channels": channels,
    });
    match root.get_mut("animations") {
        Some(Value::Array(animations)) => animations.push(animation),
        _ => {
            root.insert("animations".into(), json!([animation]));
        }
    }
    root.insert("buffers".into(), json!([{"byteLength": bin.bytes.len()}]));
    root.insert("bufferViews".into(), json!(bin.views));
    root.insert("accessors".into(), json!(bin.accessors));
    if let Some(Value::Object(asset)) = root.get_mut("asset") {
        asset.insert(
            "generator".into(),
            json!(concat!("facebake ", env!("CARGO_PKG_VERSION"))),
        );
    }
    let bytes = write_container(path, &Value::Object(root), bin.bytes)?;

    let attributes = if normals.is_some() { 2 } else { 1 };
    let frames_count = frames.len();
    let basis_bytes = rank * n * 12 * attributes + frames_count * rank * 4 + frames_count * 4;
    let per_frame_bytes =
        frames_count * n * 12 * attributes + frames_count * frames_count * 4 + frames_count * 4;
    Ok(AnimatedGlb {
        frames: frames_count,
        targets: rank,
        p99_error: basis.p99_error,
        max_error: basis.max_error,
        bound_met: basis.bound_met,
        normal_degrees: normals.map(|(_, degrees)| degrees),
        bytes,
        one_target_per_frame_bytes: bytes.saturating_sub(basis_bytes) + per_frame_bytes,
    })
}

/// The normal deltas of the basis and the (p99, max) angle of the reconstructed normals.
fn normal_deltas(
    mesh: &FaceMesh,
    frames: &[Vec<[f64; 3]>],
    weights: &[Vec<f32>],
) -> (Vec<Vec<[f32; 3]>>, (f64, f64)) {
    let n = mesh.positions.len();
    let rest = vertex_normals(mesh, &mesh.positions);
    let deltas = morph_basis::fit_deltas(weights, n, |f| {
        vertex_normals(mesh, &frames[f])
            .iter()
            .zip(&rest)
            .map(|(a, b)| [0, 1, 2].map(|k| a[k] - b[k]))
            .collect()
    });
    let mut angles = Vec::with_capacity(frames.len() * n);
    for (frame, w) in frames.iter().zip(weights) {
        for (v, exact) in vertex_normals(mesh, frame).iter().enumerate() {
            let mut normal = rest[v];
            for (target, &wt) in deltas.iter().zip(w) {
                for k in 0..3 {
                    normal[k] += f64::from(wt) * f64::from(target[v][k]);
                }
            }
            if *exact != [0.0; 3] {
                angles.push(angle_degrees(normal, *exact));
            }
        }
    }
    (deltas, morph_basis::p99_and_max(&mut angles))
}

/// The top-level array `key` of `root` (empty when absent).
fn array<'a>(root: &'a Map<String, Value>, key: &str) -> &'a [Value] {
    root.get(key)
        .and_then(Value::as_array)
        .map_or(&[], Vec::as_slice)
}

/// `meshes[m]` as an object (the checks made it one).
fn mesh_object(root: &mut Map<String, Value>, m: usize) -> &mut Map<String, Value> {
    root.get_mut("meshes")
        .and_then(|v| v.get_mut(m))
        .and_then(Value::as_object_mut)
        .expect("the mesh was loaded from this file")
}

/// For each primitive of `meshes[m]`: its `POSITION` count and whether it has `NORMAL`.
fn primitive_counts(root: &Map<String, Value>, m: usize) -> Vec<Option<(usize, bool)>> {
    let accessors = array(root, "accessors");
    let primitives = array(root, "meshes")
        .get(m)
        .and_then(|mesh| mesh.get("primitives"))
        .and_then(Value::as_array)
        .map_or(&[][..], Vec::as_slice);
    primitives
        .iter()
        .map(|prim| {
            let attributes = prim.get("attributes")?;
            let position = attributes.get("POSITION")?.as_u64()? as usize;
            let count = accessors.get(position)?.get("count")?.as_u64()? as usize;
            Some((count, attributes.get("NORMAL").is_some()))
        })
        .collect()
}

/// Removes what the new targets replace: `meshes[m]`'s targets and weights, the weights of the
/// nodes showing it, and the animation channels on those weights (with samplers and animations
/// left unused).
fn strip_weights(root: &mut Map<String, Value>, m: usize, nodes: &[usize]) {
    let gmesh = mesh_object(root, m);
    gmesh.remove("weights");
    if let Some(Value::Array(primitives)) = gmesh.get_mut("primitives") {
        for prim in primitives.iter_mut().filter_map(Value::as_object_mut) {
            prim.remove("targets");
        }
    }
    if let Some(Value::Array(all)) = root.get_mut("nodes") {
        for &i in nodes {
            if let Some(Value::Object(node)) = all.get_mut(i) {
                node.remove("weights");
            }
        }
    }
    let Some(Value::Array(animations)) = root.get_mut("animations") else {
        return;
    };
    for animation in animations.iter_mut() {
        let replaced = |channel: &Value| {
            let target = &channel["target"];
            target["path"] == "weights"
                && target["node"]
                    .as_u64()
                    .is_some_and(|node| nodes.contains(&(node as usize)))
        };
        let (Some(Value::Array(channels)), Some(Value::Array(samplers))) = (
            animation.get("channels").cloned(),
            animation.get("samplers").cloned(),
        ) else {
            continue;
        };
        let kept: Vec<Value> = channels.into_iter().filter(|c| !replaced(c)).collect();
        let mut map = vec![None; samplers.len()];
        let mut new_samplers = Vec::new();
        let mut new_channels = Vec::new();
        for mut channel in kept {
            let Some(s) = channel["sampler"].as_u64().map(|s| s as usize) else {
                continue;
            };
            let Some(sampler) = samplers.get(s) else {
                continue;
            };
            let index = *map[s].get_or_insert_with(|| {
                new_samplers.push(sampler.clone());
                new_samplers.len() - 1
            });
            channel["sampler"] = json!(index);
            new_channels.push(channel);
        }
        animation["channels"] = Value::Array(new_channels);
        animation["samplers"] = Value::Array(new_samplers);
    }
    animations.retain(|a| a["channels"].as_array().is_some_and(|c| !c.is_empty()));
    if animations.is_empty() {
        root.remove("animations");
    }
}

/// The objects in the array `key` of each of `items` (a mesh's primitives, an animation's
/// samplers).
fn nested<'a>(
    items: &'a mut [Value],
    key: &'a str,
) -> impl Iterator<Item = &'a mut Map<String, Value>> + 'a {
    items
        .iter_mut()
        .filter_map(move |item| item.get_mut(key).and_then(Value::as_array_mut))
        .flatten()
        .filter_map(Value::as_object_mut)
}

/// Every accessor reference of the core specification in `root`, as mutable index values.
fn accessor_refs(root: &mut Map<String, Value>) -> Vec<&mut Value> {
    let mut refs = Vec::new();
    for (key, value) in root.iter_mut() {
        let Value::Array(items) = value else { continue };
        match key.as_str() {
            "meshes" => {
                for prim in nested(items, "primitives") {
                    for (key, value) in prim.iter_mut() {
                        match (key.as_str(), value) {
                            ("indices", v) => refs.push(v),
                            ("attributes", Value::Object(attributes)) => {
                                refs.extend(attributes.values_mut());
                            }
                            ("targets", Value::Array(targets)) => {
                                for target in targets.iter_mut().filter_map(Value::as_object_mut) {
                                    refs.extend(target.values_mut());
                                }
                            }
                            _ => {}
                        }
                    }
                }
            }
            "skins" => {
                for skin in items.iter_mut().filter_map(Value::as_object_mut) {
                    refs.extend(skin.get_mut("inverseBindMatrices"));
                }
            }
            "animations" => {
                for sampler in nested(items, "samplers") {
                    for (key, value) in sampler.iter_mut() {
                        if key == "input" || key == "output" {
                            refs.push(value);
                        }
                    }
                }
            }
            _ => {}
        }
    }
    refs
}

/// Copies the accessors, buffer views and images `root` still uses into `bin` (images given by
/// URI embedded), renumbering every reference; the rest is dropped.
fn copy_through(
    root: &mut Map<String, Value>,
    checked: &Checked,
    source: &Path,
    bin: &mut Bin,
) -> Result<(), GltfAnimError> {
    let source_accessors = array(&checked.json, "accessors").to_vec();
    let source_views = array(&checked.json, "bufferViews").to_vec();
    let mut used = vec![false; source_accessors.len()];
    for r in accessor_refs(root) {
        if let Some(a) = r.as_u64().and_then(|a| used.get_mut(a as usize)) {
            *a = true;
        }
    }
    let mut view_map: Vec<Option<usize>> = vec![None; source_views.len()];
    let mut copy_view = |bin: &mut Bin, v: usize| -> Option<usize> {
        if view_map.get(v)?.is_none() {
            let view = source_views.get(v)?;
            let buffer = checked.buffers.get(view["buffer"].as_u64()? as usize)?;
            let offset = view.get("byteOffset").and_then(Value::as_u64).unwrap_or(0) as usize;
            let length = view["byteLength"].as_u64()? as usize;
            let mut copy = view.clone();
            if let Some(obj) = copy.as_object_mut() {
                obj.remove("uri");
            }
            view_map[v] = Some(bin.bytes_view(buffer.get(offset..offset + length)?, copy));
        }
        view_map[v]
    };
    let remap_view = |value: &mut Value,
                      bin: &mut Bin,
                      copy: &mut dyn FnMut(&mut Bin, usize) -> Option<usize>| {
        if let Some(new) = value.as_u64().and_then(|v| copy(bin, v as usize)) {
            *value = json!(new);
        }
    };
    let mut accessor_map: Vec<Option<usize>> = vec![None; source_accessors.len()];
    for (a, accessor) in source_accessors.iter().enumerate() {
        if !used[a] {
            continue;
        }
        let mut accessor = accessor.clone();
        if let Some(v) = accessor.get_mut("bufferView") {
            remap_view(v, bin, &mut copy_view);
        }
        for part in ["indices", "values"] {
            if let Some(v) = accessor
                .get_mut("sparse")
                .and_then(|s| s.get_mut(part))
                .and_then(|p| p.get_mut("bufferView"))
            {
                remap_view(v, bin, &mut copy_view);
            }
        }
        accessor_map[a] = Some(bin.accessor(accessor));
    }
    for r in accessor_refs(root) {
        if let Some(new) = r
            .as_u64()
            .and_then(|a| accessor_map.get(a as usize).copied().flatten())
        {
            *r = json!(new);
        }
    }
    if let Some(Value::Array(images)) = root.get_mut("images") {
        for (i, image) in images.iter_mut().enumerate() {
            let Some(image) = image.as_object_mut() else {
                continue;
            };
            if let Some(v) = image.get_mut("bufferView") {
                remap_view(v, bin, &mut copy_view);
                continue;
            }
            let Some(Value::String(uri)) = image.remove("uri") else {
                continue;
            };
            let place = format!("images[{i}].uri");
            let bytes = checked
                .read_uri(&uri, &place)
                .map_err(|e| GltfAnimError::Source {
                    path: source.to_path_buf(),
                    source: e,
                })?;
            let mime = match image.get("mimeType").and_then(Value::as_str) {
                Some(m) => m.to_string(),
                None => image_mime(&bytes)
                    .ok_or_else(|| GltfAnimError::Unsupported {
                        path: source.to_path_buf(),
                        problem: format!(
                            "{place}: the image is neither PNG, JPEG, WebP nor KTX2 and has no mimeType"
                        ),
                    })?
                    .to_string(),
            };
            image.insert("mimeType".into(), json!(mime));
            image.insert(
                "bufferView".into(),
                json!(bin.bytes_view(&bytes, json!({}))),
            );
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::gltf_mesh::load_mesh;
    use crate::io::gltf_mesh::tests::{head, scratch};

    fn options(max_targets: usize) -> BasisOptions {
        BasisOptions {
            max_error: 1e-4,
            max_targets,
        }
    }

    /// `count` frames of FaceCap blends: the jaw opening and closing, a blink, a smile.
    fn facecap_take(count: usize) -> Vec<Vec<[f64; 3]>> {
        let m = head();
        let [jaw, blink, smile] =
            ["jawOpen", "eyeBlink_L", "mouthSmile_R"].map(|n| m.morph_index(n).unwrap());
        (0..count)
            .map(|f| {
                let t = f as f64 / count as f64;
                m.morphed(&[
                    (jaw, (t * 6.0).sin().abs()),
                    (blink, (t * 17.0).sin().max(0.0)),
                    (smile, t),
                ])
            })
            .collect()
    }

    fn reader_of<'a>(
        buffers: &'a [gltf::buffer::Data],
    ) -> impl Clone + Fn(gltf::Buffer<'_>) -> Option<&'a [u8]> {
        |b| buffers.get(b.index()).map(|d| &d.0[..])
    }

    #[test]
    fn facecap_take_keeps_the_file_and_plays_at_its_rate() {
        let frames = facecap_take(90);
        let times: Vec<f64> = (0..90).map(|f| (f * 2) as f64 / 60.0).collect();
        let path = scratch("take.glb");
        let written = write_animated_glb(
            &path,
            head(),
            &frames,
            &times,
            &options(16),
            BufferAccess::AssetFolder,
        )
        .unwrap();
        assert!(written.bound_met && written.targets <= 5, "{written:?}");
        assert!(written.bytes < written.one_target_per_frame_bytes / 5);
        let (p99, max) = written.normal_degrees.unwrap();
        // Three weights fit the blink's turning lids only roughly (measured 3.9° / 38°).
        assert!(p99 < 5.0 && max < 60.0, "{p99} {max}");

        let (source, source_buffers) =
            gltf_check::import(&head().source, BufferAccess::AssetFolder).unwrap();
        let (doc, buffers) = gltf_check::import(&path, BufferAccess::AssetFolder).unwrap();
        assert_eq!(doc.buffers().count(), 1);
        // Every node and mesh kept, with the same attributes.
        let names = |d: &gltf::Document| -> Vec<Option<String>> {
            d.nodes().map(|n| n.name().map(str::to_owned)).collect()
        };
        assert_eq!(names(&doc), names(&source));
        assert_eq!(doc.meshes().count(), source.meshes().count());
        for (a, b) in doc.meshes().zip(source.meshes()) {
            assert_eq!(a.name(), b.name());
            for (pa, pb) in a.primitives().zip(b.primitives()) {
                let (ra, rb) = (
                    pa.reader(reader_of(&buffers)),
                    pb.reader(reader_of(&source_buffers)),
                );
                let uv = |r: &gltf::mesh::Reader<'_, '_, _>| -> Vec<[f32; 2]> {
                    r.read_tex_coords(0).unwrap().into_f32().collect()
                };
                assert_eq!(uv(&ra), uv(&rb));
                assert!(ra
                    .read_positions()
                    .unwrap()
                    .eq(rb.read_positions().unwrap()));
                assert!(ra.read_normals().unwrap().eq(rb.read_normals().unwrap()));
                let indices = |r: &gltf::mesh::Reader<'_, '_, _>| -> Vec<u32> {
                    r.read_indices().unwrap().into_u32().collect()
                };
                assert_eq!(indices(&ra), indices(&rb));
                assert_eq!(pa.material().index(), pb.material().index());
            }
        }
        let gmesh = doc.meshes().next().unwrap();
        assert_eq!(gmesh.weights().unwrap(), vec![0.0; written.targets]);
        let prim = gmesh.primitives().next().unwrap();
        assert_eq!(prim.morph_targets().len(), written.targets);
        assert!(prim.morph_targets().all(|t| t.normals().is_some()));

        // LINEAR keys at the frames' times, on the head's node.
        let animation = doc.animations().next().unwrap();
        let channel = animation.channels().next().unwrap();
        assert_eq!(channel.target().node().name(), Some("head"));
        assert_eq!(
            channel.sampler().interpolation(),
            gltf::animation::Interpolation::Linear
        );
        let r = channel.reader(reader_of(&buffers));
        let keys: Vec<f32> = r.read_inputs().unwrap().collect();
        assert_eq!(keys, times.iter().map(|&t| t as f32).collect::<Vec<_>>());
        let gltf::animation::util::ReadOutputs::MorphTargetWeights(w) = r.read_outputs().unwrap()
        else {
            panic!("a weights channel")
        };
        let weights: Vec<f32> = w.into_f32().collect();
        // Every weight in [0, 1], as viewers that clamp them need; the offset's is 1.
        assert!(weights.iter().all(|w| (0.0..=1.0).contains(w)));
        assert!(weights.iter().step_by(written.targets).all(|&w| w == 1.0));

        // Frame f rebuilt from the file is within the reported error of the frame played.
        let reader = prim.reader(reader_of(&buffers));
        let rest: Vec<[f32; 3]> = reader.read_positions().unwrap().collect();
        let targets: Vec<Vec<[f32; 3]>> = reader
            .read_morph_targets()
            .map(|(p, _, _)| p.unwrap().collect())
            .collect();
        let mut worst = 0.0f64;
        for (f, frame) in frames.iter().enumerate() {
            let w = &weights[f * targets.len()..(f + 1) * targets.len()];
            for (v, played) in frame.iter().enumerate() {
                let mut q = rest[v].map(f64::from);
                for (t, target) in targets.iter().enumerate() {
                    for k in 0..3 {
                        q[k] += f64::from(w[t]) * f64::from(target[v][k]);
                    }
                }
                worst = worst.max(crate::mesh::distance(&q, played));
            }
        }
        assert!(
            worst <= written.max_error * 1.0001 + 1e-9,
            "{worst} {written:?}"
        );
        assert!(written.max_error < 1e-4);
    }

    /// A `.gltf` with an external PNG, a material, and a mesh of two primitives (a quad and a
    /// triangle) in a folder of its own.
    fn textured_gltf(dir: &Path) -> PathBuf {
        std::fs::create_dir_all(dir).unwrap();
        let mut png = Vec::new();
        {
            let mut encoder = png::Encoder::new(&mut png, 1, 1);
            encoder.set_color(png::ColorType::Rgb);
            let mut writer = encoder.write_header().unwrap();
            writer.write_image_data(&[200, 100, 50]).unwrap();
        }
        std::fs::write(dir.join("skin.png"), &png).unwrap();
        let floats = |v: &[f32]| -> Vec<u8> { v.iter().flat_map(|x| x.to_le_bytes()).collect() };
        let mut bin = floats(&[0., 0., 0., 1., 0., 0., 1., 1., 0., 0., 1., 0.]); // 48
        bin.extend(floats(&[0., 0., 1., 0., 0., 1., 0., 0., 1., 0., 0., 1.])); // 48
        bin.extend(floats(&[0., 0., 1., 0., 1., 1., 0., 1.])); // 32
        bin.extend([0u16, 1, 2, 0, 2, 3].iter().flat_map(|i| i.to_le_bytes())); // 12
        std::fs::write(dir.join("quad.bin"), &bin).unwrap();
        let json = json!({
            "asset": {"version": "2.0"},
            "scene": 0,
            "scenes": [{"nodes": [0, 1]}],
            "nodes": [{"name": "face", "mesh": 0}, {"name": "lamp", "translation": [0, 1, 0]}],
            "materials": [{"name": "skin", "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}],
            "textures": [{"sampler": 0, "source": 0}],
            "samplers": [{"magFilter": 9729}],
            "images": [{"uri": "skin.png"}],
            "buffers": [{"uri": "quad.bin", "byteLength": bin.len()}],
            "bufferViews": [
                {"buffer": 0, "byteOffset": 0, "byteLength": 48, "target": 34962},
                {"buffer": 0, "byteOffset": 48, "byteLength": 48, "target": 34962},
                {"buffer": 0, "byteOffset": 96, "byteLength": 32, "target": 34962},
                {"buffer": 0, "byteOffset": 128, "byteLength": 12, "target": 34963}
            ],
            "accessors": [
                {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
                 "min": [0, 0, 0], "max": [1, 1, 0]},
                {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"},
                {"bufferView": 2, "componentType": 5126, "count": 4, "type": "VEC2"},
                {"bufferView": 3, "componentType": 5123, "count": 6, "type": "SCALAR"},
                {"bufferView": 3, "componentType": 5123, "count": 3, "type": "SCALAR"}
            ],
            "meshes": [{"name": "face", "primitives": [
                {"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}, "indices": 3, "material": 0},
                {"attributes": {"POSITION": 0, "TEXCOORD_0": 2}, "indices": 4, "material": 0}
            ]}]
        });
        let path = dir.join("face.gltf");
        std::fs::write(&path, serde_json::to_vec(&json).unwrap()).unwrap();
        path
    }

    #[test]
    fn a_textured_gltf_keeps_its_material_and_embeds_its_image() {
        let dir = scratch("textured");
        let source = textured_gltf(&dir);
        let mesh = load_mesh(&source, Some("face"), Some(0)).unwrap();
        let frames: Vec<Vec<[f64; 3]>> = (0..30)
            .map(|f| {
                let mut p = mesh.positions.clone();
                p[2][2] += 0.01 * f as f64;
                p
            })
            .collect();
        let times: Vec<f64> = (0..30).map(|f| f as f64 / 30.0).collect();
        let path = dir.join("out").join("face.glb");
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        let write = || {
            write_animated_glb(
                &path,
                &mesh,
                &frames,
                &times,
                &options(4),
                BufferAccess::AssetFolder,
            )
        };
        assert_eq!(write().unwrap().targets, 2, "the offset and one component");
        let (doc, buffers) = gltf_check::import(&path, BufferAccess::AssetFolder).unwrap();
        assert_eq!(doc.nodes().count(), 2);
        assert_eq!(doc.materials().next().unwrap().name(), Some("skin"));
        let image = doc.images().next().unwrap();
        let gltf::image::Source::View { view, mime_type } = image.source() else {
            panic!("the image is embedded")
        };
        assert_eq!(mime_type, "image/png");
        let start = view.offset();
        assert_eq!(
            &buffers[0].0[start..start + view.length()],
            &std::fs::read(dir.join("skin.png")).unwrap()[..]
        );
        let texture = doc.textures().next().unwrap();
        assert_eq!(texture.source().index(), 0);
        // Both primitives carry two targets; the second's are zero.
        let gmesh = doc.meshes().next().unwrap();
        let prims: Vec<_> = gmesh.primitives().collect();
        assert_eq!(prims[0].morph_targets().len(), 2);
        assert_eq!(prims[1].morph_targets().len(), 2);
        let reader = prims[1].reader(reader_of(&buffers));
        let zero: Vec<[f32; 3]> = reader
            .read_morph_targets()
            .next()
            .unwrap()
            .0
            .unwrap()
            .collect();
        assert_eq!(zero, vec![[0.0; 3]; 4]);
        let indices: Vec<u32> = reader.read_indices().unwrap().into_u32().collect();
        assert_eq!(indices, [0, 1, 2]);

        // An extension that may reference buffers is refused, naming the source.
        let mut json: Value = serde_json::from_slice(&std::fs::read(&source).unwrap()).unwrap();
        json["extensionsUsed"] = json!(["KHR_materials_unlit", "KHR_draco_mesh_compression"]);
        std::fs::write(&source, serde_json::to_vec(&json).unwrap()).unwrap();
        let e = write().unwrap_err().to_string();
        assert!(
            e.contains("face.gltf") && e.contains("extension KHR_draco_mesh_compression"),
            "{e}"
        );
        // An image outside the asset's folder is refused.
        json["extensionsUsed"] = json!(["KHR_materials_unlit"]);
        json["images"][0]["uri"] = json!("../skin.png");
        std::fs::write(&source, serde_json::to_vec(&json).unwrap()).unwrap();
        let e = write().unwrap_err().to_string();
        assert!(e.contains("images[0].uri") && e.contains("\"..\""), "{e}");
    }

    #[test]
    fn bad_times_and_extensions_are_errors() {
        let frames = facecap_take(3);
        let path = scratch("bad-times.glb");
        let write = |times: &[f64]| {
            write_animated_glb(
                &path,
                head(),
                &frames,
                times,
                &options(4),
                BufferAccess::AssetFolder,
            )
            .unwrap_err()
            .to_string()
        };
        assert!(write(&[0.0, 1.0]).contains("2 times for 3 frames"));
        assert!(write(&[0.0, 1.0, 1.0]).contains("do not increase"));
        assert!(write(&[0.0, f64::NAN, 1.0]).contains("not finite"));
        assert!(copies_extension("KHR_materials_clearcoat"));
        assert!(!copies_extension("KHR_draco_mesh_compression"));
        assert!(!copies_extension("EXT_mesh_gpu_instancing"));
    }
}
