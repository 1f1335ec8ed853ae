//! Checking a glTF file before the `gltf` crate sees it, and loading its buffers safely.
//!
//! [`import`] replaces `gltf::Gltf::open` + `gltf::import_buffers` for files the user hands us.
//! Those two calls trust the file: `gltf` 1.4 allocates the GLB header's length before reading
//! (a 17-byte file asks for 3.6 GB, a length of 0 underflows to 4 GB), reads buffer URIs from
//! anywhere (`file:///etc/passwd`, `../../dev/zero`), unwraps invalid percent-encoding, and its
//! JSON validation and accessor readers index and assert on values they have not checked (a
//! `POSITION` naming a missing accessor, a `byteStride` smaller than the element, an indices
//! accessor of FLOAT type all panic), while a sparse accessor without a buffer view decodes
//! `count` zeros whatever the count. So this module validates, with checked arithmetic and
//! against the bytes actually present, everything the loader
//! ([`load_mesh`](crate::io::gltf_mesh::load_mesh)) later asks the crate to read, and only then
//! hands the crate a document and buffers it can read without panicking:
//!
//! - the file is a regular file of at most [`MAX_FILE_BYTES`]; a GLB's header length equals the
//!   file's length and every chunk lies inside it;
//! - buffers come from the GLB `BIN` chunk, a base64 `data:` URI, or a file in the asset's folder
//!   (no absolute paths, `file:` URIs, `..` components, or links resolving outside it) unless
//!   [`BufferAccess::Anywhere`] is asked for; external files are regular files read up to their
//!   declared `byteLength` only;
//! - every buffer view lies inside its buffer, every accessor (and sparse part) inside its view,
//!   every stride holds its element, every index names an existing object, and the accessors the
//!   loader reads have the component type and shape it reads them as;
//! - the bytes the loader will decode for a primitive (with its morph targets) stay within
//!   [`DECODE_FACTOR`] times the input's size (plus [`DECODE_SLACK`]), and an accessor without
//!   a buffer view (all zeros but for its sparse values) holds no more bytes than the file's
//!   buffers do.
//!
//! Every problem is a [`GltfCheckError`] naming the place in the file (`accessors[3]`,
//! `meshes[0].primitives[0].attributes.POSITION`, `GLB header`).

use std::path::{Component, Path, PathBuf};

use serde_json::{Map, Value};
use thiserror::Error;

/// Largest glTF/GLB file, or external buffer file, read (512 MiB).
pub const MAX_FILE_BYTES: u64 = 512 << 20;
/// A primitive may decode (positions, normals, morph deltas and indices, as the loader stores
/// them) at most this many times the bytes of the file and its external buffers…
pub const DECODE_FACTOR: u64 = 64;
/// …plus this many bytes.
pub const DECODE_SLACK: u64 = 1 << 20;

/// Where a `.gltf` file's external buffers may be read from.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum BufferAccess {
    /// Only files inside the folder of the `.gltf` (after resolving links): relative URIs
    /// without `..` components. The default.
    #[default]
    AssetFolder,
    /// Any path the URI names, absolute and `file:` URIs included (an explicit opt-in).
    Anywhere,
}

/// A problem with a glTF file, found before the `gltf` crate reads it.
#[derive(Debug, Error)]
pub enum GltfCheckError {
    /// The file itself could not be opened or read.
    #[error("cannot read the file: {0}")]
    Read(#[source] std::io::Error),
    /// A buffer is declared larger than the reader accepts.
    #[error("{what} is {bytes} bytes, more than the {limit} bytes accepted")]
    TooLarge {
        /// Which buffer.
        what: String,
        /// Its size.
        bytes: u64,
        /// The limit.
        limit: u64,
    },
    /// The JSON is not valid JSON.
    #[error("invalid glTF JSON: {0}")]
    Json(#[source] serde_json::Error),
    /// A value in the file is malformed, out of range or inconsistent.
    #[error("{place}: {problem}")]
    Invalid {
        /// Where in the file (`accessors[3]`, `GLB header`, ...).
        place: String,
        /// What is wrong.
        problem: String,
    },
    /// A buffer URI points outside the asset's folder and reading there was not allowed.
    #[error(
        "{place}: uri \"{uri}\" {reason}; buffers are only read from the asset's folder \
         (opt in with `bake --allow-outside-asset`)"
    )]
    OutsideAsset {
        /// Where in the file (`buffers[0].uri`).
        place: String,
        /// The URI, with control characters escaped.
        uri: String,
        /// Why it is outside.
        reason: &'static str,
    },
    /// An external buffer file could not be read.
    #[error("{place}: cannot read {}: {source}", file.display())]
    Buffer {
        /// Where in the file (`buffers[0].uri`).
        place: String,
        /// The buffer file.
        file: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// The `gltf` crate's own validation rejected the checked document.
    #[error("invalid glTF: {0}")]
    Document(#[source] gltf::Error),
}

fn invalid(place: impl Into<String>, problem: impl Into<String>) -> GltfCheckError {
    GltfCheckError::Invalid {
        place: place.into(),
        problem: problem.into(),
    }
}

type Result<T> = std::result::Result<T, GltfCheckError>;

const GLB_MAGIC: &[u8; 4] = b"glTF";
const CHUNK_JSON: u32 = 0x4E4F_534A;
const CHUNK_BIN: u32 = 0x004E_4942;

/// Reads, checks and loads a `.gltf` or `.glb` file: the document and one data block per
/// buffer, ready for `gltf::Primitive::reader`. See the module docs for what is checked.
pub fn import(
    path: &Path,
    access: BufferAccess,
) -> Result<(gltf::Document, Vec<gltf::buffer::Data>)> {
    let checked = check(path, access)?;
    let json_root: gltf::json::Root =
        gltf::json::deserialize::from_value(Value::Object(checked.json))
            .map_err(|e| GltfCheckError::Document(gltf::Error::Deserialize(e)))?;
    let document = gltf::Document::from_json(json_root).map_err(GltfCheckError::Document)?;
    Ok((
        document,
        checked
            .buffers
            .into_iter()
            .map(gltf::buffer::Data)
            .collect(),
    ))
}

/// A glTF file that passed the checks: its JSON and its buffers' bytes.
#[derive(Debug, Clone)]
pub struct Checked {
    /// The top-level JSON object.
    pub json: Map<String, Value>,
    /// Each buffer's bytes (its declared `byteLength`, zero-padded to 4).
    pub buffers: Vec<Vec<u8>>,
    /// The folder the file's relative URIs are read from.
    pub folder: PathBuf,
    /// Where its URIs may be read from.
    pub access: BufferAccess,
}

/// Reads and checks a `.gltf` or `.glb` file as [`import`] does, returning its JSON and buffers
/// instead of a `gltf::Document`, for a writer that copies the file through.
pub fn check(path: &Path, access: BufferAccess) -> Result<Checked> {
    let bytes = crate::io::read_regular(path, MAX_FILE_BYTES, MAX_FILE_BYTES)
        .map_err(GltfCheckError::Read)?;
    let (json, bin) = split_glb(&bytes)?;
    let root: Value = serde_json::from_slice(json).map_err(GltfCheckError::Json)?;
    let Value::Object(root) = root else {
        return Err(invalid("glTF JSON", "the top level is not an object"));
    };
    let folder = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let (data, external_bytes) = load_buffers(&root, bin, folder, access)?;
    let input_bytes = bytes.len() as u64 + external_bytes;
    check_structure(&root, &data, input_bytes)?;
    Ok(Checked {
        json: root,
        buffers: data,
        folder: folder.to_path_buf(),
        access,
    })
}

impl Checked {
    /// The bytes an image's (or any) `uri` names: a base64 `data:` URI, or a file read under
    /// the same rules as buffers (in the asset's folder unless [`BufferAccess::Anywhere`]), at
    /// most [`MAX_FILE_BYTES`]. `place` names the property in errors (`images[0].uri`).
    pub fn read_uri(&self, uri: &str, place: &str) -> Result<Vec<u8>> {
        if let Some(rest) = uri.strip_prefix("data:") {
            return decode_data_uri(rest, place);
        }
        let file = resolve_uri(uri, &self.folder, self.access, place)?;
        crate::io::read_regular(&file, MAX_FILE_BYTES, MAX_FILE_BYTES).map_err(|source| {
            GltfCheckError::Buffer {
                place: place.to_owned(),
                file,
                source,
            }
        })
    }
}

fn le_u32(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes([b[at], b[at + 1], b[at + 2], b[at + 3]])
}

/// The JSON text and, for a GLB, its `BIN` chunk.
fn split_glb(bytes: &[u8]) -> Result<(&[u8], Option<&[u8]>)> {
    if !bytes.starts_with(GLB_MAGIC) {
        return Ok((bytes, None));
    }
    let header = "GLB header";
    if bytes.len() < 12 {
        return Err(invalid(
            header,
            format!(
                "the file has {} bytes, fewer than the 12-byte header",
                bytes.len()
            ),
        ));
    }
    let version = le_u32(bytes, 4);
    if version != 2 {
        return Err(invalid(
            header,
            format!("version {version}, only 2 is read"),
        ));
    }
    let length = le_u32(bytes, 8) as usize;
    if length != bytes.len() {
        return Err(invalid(
            header,
            format!(
                "length {length} differs from the file's {} bytes",
                bytes.len()
            ),
        ));
    }
    let mut json = None;
    let mut bin = None;
    let mut at = 12;
    let mut index = 0;
    while at < length {
        let place = format!("GLB chunk {index} at byte {at}");
        if length - at < 8 {
            return Err(invalid(place, "truncated chunk header"));
        }
        let chunk_length = le_u32(bytes, at) as usize;
        let kind = le_u32(bytes, at + 4);
        let start = at + 8;
        if chunk_length > length - start {
            return Err(invalid(
                place,
                format!(
                    "chunk length {chunk_length} runs past the end of the file ({} bytes left)",
                    length - start
                ),
            ));
        }
        let body = &bytes[start..start + chunk_length];
        match (index, kind) {
            (0, CHUNK_JSON) => json = Some(body),
            (0, _) => return Err(invalid(place, "the first chunk is not JSON")),
            (1, CHUNK_BIN) => bin = Some(body),
            (_, CHUNK_JSON | CHUNK_BIN) => {
                return Err(invalid(
                    place,
                    "a second JSON chunk or a misplaced BIN chunk",
                ))
            }
            // Unknown chunk types are skipped, as the GLB specification asks.
            _ => {}
        }
        at = start + chunk_length;
        index += 1;
    }
    let json = json.ok_or_else(|| invalid(header, "no JSON chunk"))?;
    Ok((json, bin))
}

/// An optional non-negative integer property.
fn uint(obj: &Map<String, Value>, key: &str, place: &str) -> Result<Option<u64>> {
    match obj.get(key) {
        None => Ok(None),
        Some(v) => v.as_u64().map(Some).ok_or_else(|| {
            invalid(
                format!("{place}.{key}"),
                format!("{} is not a non-negative integer", short_json(v)),
            )
        }),
    }
}

fn required_uint(obj: &Map<String, Value>, key: &str, place: &str) -> Result<u64> {
    uint(obj, key, place)?.ok_or_else(|| invalid(place, format!("missing {key}")))
}

/// An index property naming one of `len` objects of `array`.
fn index(
    obj: &Map<String, Value>,
    key: &str,
    place: &str,
    array: &str,
    len: usize,
) -> Result<Option<usize>> {
    match uint(obj, key, place)? {
        None => Ok(None),
        Some(i) if i < len as u64 => Ok(Some(i as usize)),
        Some(i) => Err(invalid(
            format!("{place}.{key}"),
            format!("{array}[{i}] does not exist (the file has {len})"),
        )),
    }
}

fn short_json(v: &Value) -> String {
    let mut s = v.to_string();
    if s.len() > 40 {
        let mut end = 40;
        while !s.is_char_boundary(end) {
            end -= 1;
        }
        s.truncate(end);
        s.push('…');
    }
    s
}

/// The objects of an optional top-level (or nested) array.
fn objects<'a>(
    obj: &'a Map<String, Value>,
    key: &str,
    place: &str,
) -> Result<Vec<&'a Map<String, Value>>> {
    match obj.get(key) {
        None => Ok(Vec::new()),
        Some(Value::Array(items)) => items
            .iter()
            .enumerate()
            .map(|(i, v)| {
                v.as_object()
                    .ok_or_else(|| invalid(format!("{place}{key}[{i}]"), "is not an object"))
            })
            .collect(),
        Some(v) => Err(invalid(
            format!("{place}{key}"),
            format!("{} is not an array", short_json(v)),
        )),
    }
}

/// Loads every buffer; returns the data (declared `byteLength` bytes, padded to 4) and the
/// number of bytes read from external files.
fn load_buffers(
    root: &Map<String, Value>,
    bin: Option<&[u8]>,
    folder: &Path,
    access: BufferAccess,
) -> Result<(Vec<Vec<u8>>, u64)> {
    let mut external = 0u64;
    let mut out = Vec::new();
    for (i, buffer) in objects(root, "buffers", "")?.into_iter().enumerate() {
        let place = format!("buffers[{i}]");
        let length = required_uint(buffer, "byteLength", &place)?;
        if length > MAX_FILE_BYTES {
            return Err(GltfCheckError::TooLarge {
                what: format!("{place}.byteLength"),
                bytes: length,
                limit: MAX_FILE_BYTES,
            });
        }
        let uri_place = format!("{place}.uri");
        let mut data = match buffer.get("uri") {
            None => match (i, bin) {
                (0, Some(bin)) => bin.to_vec(),
                _ => {
                    return Err(invalid(
                        place,
                        "has no uri and is not the first buffer of a GLB with a BIN chunk",
                    ))
                }
            },
            Some(Value::String(uri)) => {
                if let Some(rest) = uri.strip_prefix("data:") {
                    decode_data_uri(rest, &uri_place)?
                } else {
                    let file = resolve_uri(uri, folder, access, &uri_place)?;
                    // Only the declared bytes: a longer file is not read to its end.
                    let data = crate::io::read_regular(&file, MAX_FILE_BYTES, length).map_err(
                        |source| GltfCheckError::Buffer {
                            place: uri_place.clone(),
                            file: file.clone(),
                            source,
                        },
                    )?;
                    external += data.len() as u64;
                    data
                }
            }
            Some(v) => {
                return Err(invalid(
                    uri_place,
                    format!("{} is not a string", short_json(v)),
                ))
            }
        };
        if (data.len() as u64) < length {
            return Err(invalid(
                place,
                format!(
                    "byteLength {length}, but only {} bytes are there",
                    data.len()
                ),
            ));
        }
        data.truncate(length as usize);
        while data.len() % 4 != 0 {
            data.push(0);
        }
        out.push(data);
    }
    Ok((out, external))
}

/// Decodes the part of a `data:` URI after `data:` (`<media type>;base64,<payload>`).
fn decode_data_uri(rest: &str, place: &str) -> Result<Vec<u8>> {
    let payload = rest
        .split_once(";base64,")
        .map(|(_, p)| p)
        .ok_or_else(|| invalid(place, "a data: URI that is not base64"))?;
    base64::decode(payload)
        .map_err(|e| invalid(place, format!("invalid base64 in the data: URI: {e}")))
}

/// Percent-decodes a URI; `None` if an escape is malformed or the result is not UTF-8.
fn percent_decode(uri: &str) -> Option<String> {
    let bytes = uri.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' {
            let hex = bytes.get(i + 1..i + 3)?;
            let hex = std::str::from_utf8(hex).ok()?;
            out.push(u8::from_str_radix(hex, 16).ok()?);
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    String::from_utf8(out).ok()
}

/// `Some(scheme)` if `s` starts with a URI scheme (`letter (letter|digit|+|-|.)* :`).
fn scheme(s: &str) -> Option<&str> {
    let (head, _) = s.split_once(':')?;
    let mut chars = head.chars();
    let first = chars.next()?;
    (first.is_ascii_alphabetic() && chars.all(|c| c.is_ascii_alphanumeric() || "+-.".contains(c)))
        .then_some(head)
}

/// The file a (non-`data:`) buffer URI names, refused if it leaves `folder` under
/// [`BufferAccess::AssetFolder`].
fn resolve_uri(uri: &str, folder: &Path, access: BufferAccess, place: &str) -> Result<PathBuf> {
    let shown = crate::io::escape_control(uri).into_owned();
    let decoded = percent_decode(uri).ok_or_else(|| {
        invalid(
            place,
            format!("uri \"{shown}\" has invalid percent-encoding"),
        )
    })?;
    let outside = |reason| GltfCheckError::OutsideAsset {
        place: place.to_owned(),
        uri: shown.clone(),
        reason,
    };
    let relative = match scheme(&decoded) {
        Some(s) if s.eq_ignore_ascii_case("file") => {
            if access == BufferAccess::AssetFolder {
                return Err(outside("is a file: URI"));
            }
            let path = &decoded[5..];
            let path = path.strip_prefix("//").unwrap_or(path);
            return Ok(PathBuf::from(path));
        }
        // A single letter is a Windows drive (`C:`), an absolute path.
        Some(s) if s.len() > 1 => {
            return Err(invalid(
                place,
                format!("uri \"{shown}\": scheme \"{s}:\" is not read (only data: and file paths)"),
            ))
        }
        _ => PathBuf::from(&decoded),
    };
    if access == BufferAccess::Anywhere {
        return Ok(folder.join(relative));
    }
    let absolute = scheme(&decoded).is_some()
        || relative
            .components()
            .any(|c| matches!(c, Component::RootDir | Component::Prefix(_)));
    if absolute {
        return Err(outside("is an absolute path"));
    }
    if relative.components().any(|c| c == Component::ParentDir) {
        return Err(outside("has a \"..\" component"));
    }
    let file = folder.join(&relative);
    let io = |source| GltfCheckError::Buffer {
        place: place.to_owned(),
        file: file.clone(),
        source,
    };
    let canonical = file.canonicalize().map_err(io)?;
    let base = folder.canonicalize().map_err(io)?;
    if !canonical.starts_with(&base) {
        return Err(outside(
            "resolves (through a link) outside the asset's folder",
        ));
    }
    Ok(canonical)
}

/// An accessor's shape, as checked.
#[derive(Clone, Copy, Debug)]
struct AccessorInfo {
    count: u64,
    component_type: u64,
    components: u64,
    element: u64,
}

fn component_size(component_type: u64) -> Option<u64> {
    match component_type {
        5120 | 5121 => Some(1),
        5122 | 5123 => Some(2),
        5125 | 5126 => Some(4),
        _ => None,
    }
}

fn component_count(kind: &str) -> Option<u64> {
    Some(match kind {
        "SCALAR" => 1,
        "VEC2" => 2,
        "VEC3" => 3,
        "VEC4" => 4,
        "MAT2" => 4,
        "MAT3" => 9,
        "MAT4" => 16,
        _ => return None,
    })
}

/// `offset + stride · (count − 1) + element`, the bytes `count` strided elements span.
fn span(offset: u64, stride: u64, count: u64, element: u64) -> Option<u64> {
    stride
        .checked_mul(count.checked_sub(1)?)?
        .checked_add(element)?
        .checked_add(offset)
}

struct View {
    buffer: usize,
    offset: u64,
    length: u64,
    stride: Option<u64>,
}

fn check_structure(root: &Map<String, Value>, buffers: &[Vec<u8>], input_bytes: u64) -> Result<()> {
    let buffer_bytes: u64 = buffers.iter().map(|b| b.len() as u64).sum();
    let mut views = Vec::new();
    let view_objects = objects(root, "bufferViews", "")?;
    for (i, view) in view_objects.iter().enumerate() {
        let place = format!("bufferViews[{i}]");
        let buffer = index(view, "buffer", &place, "buffers", buffers.len())?
            .ok_or_else(|| invalid(&place, "missing buffer"))?;
        let offset = uint(view, "byteOffset", &place)?.unwrap_or(0);
        let length = required_uint(view, "byteLength", &place)?;
        let available = buffers[buffer].len() as u64;
        if offset.checked_add(length).is_none_or(|end| end > available) {
            return Err(invalid(
                place,
                format!("byteOffset {offset} + byteLength {length} runs past buffers[{buffer}] ({available} bytes)"),
            ));
        }
        let stride = uint(view, "byteStride", &place)?;
        if let Some(s) = stride {
            if !(4..=252).contains(&s) || s % 4 != 0 {
                return Err(invalid(
                    place,
                    format!("byteStride {s} is not a multiple of 4 in 4..=252"),
                ));
            }
        }
        views.push(View {
            buffer,
            offset,
            length,
            stride,
        });
    }

    let accessor_objects = objects(root, "accessors", "")?;
    let mut accessors = Vec::with_capacity(accessor_objects.len());
    for (i, acc) in accessor_objects.iter().enumerate() {
        accessors.push(check_accessor(i, acc, &views, buffers, buffer_bytes)?);
    }

    let budget = input_bytes
        .saturating_mul(DECODE_FACTOR)
        .saturating_add(DECODE_SLACK);
    for (m, mesh) in objects(root, "meshes", "")?.iter().enumerate() {
        let place = format!("meshes[{m}]");
        for (p, prim) in objects(mesh, "primitives", &format!("{place}."))?
            .iter()
            .enumerate()
        {
            check_primitive(
                &format!("{place}.primitives[{p}]"),
                prim,
                &accessors,
                budget,
            )?;
        }
    }
    Ok(())
}

fn check_accessor(
    i: usize,
    acc: &Map<String, Value>,
    views: &[View],
    buffers: &[Vec<u8>],
    buffer_bytes: u64,
) -> Result<AccessorInfo> {
    let place = format!("accessors[{i}]");
    let component_type = required_uint(acc, "componentType", &place)?;
    let size = component_size(component_type).ok_or_else(|| {
        invalid(
            &place,
            format!("componentType {component_type} is not a glTF component type"),
        )
    })?;
    let kind = acc
        .get("type")
        .and_then(Value::as_str)
        .ok_or_else(|| invalid(&place, "missing or non-string type"))?;
    let components = component_count(kind).ok_or_else(|| {
        invalid(
            &place,
            format!(
                "type \"{}\" is not a glTF accessor type",
                crate::io::escape_control(kind)
            ),
        )
    })?;
    let count = required_uint(acc, "count", &place)?;
    if count == 0 {
        return Err(invalid(place, "count 0 (glTF requires at least 1)"));
    }
    let element = size * components;
    let offset = uint(acc, "byteOffset", &place)?.unwrap_or(0);
    match index(acc, "bufferView", &place, "bufferViews", views.len())? {
        Some(v) => {
            let view = &views[v];
            let stride = view.stride.unwrap_or(element);
            if stride < element {
                return Err(invalid(
                    place,
                    format!("byteStride {stride} of bufferViews[{v}] is smaller than the element ({element} bytes)"),
                ));
            }
            if span(offset, stride, count, element).is_none_or(|end| end > view.length) {
                return Err(invalid(
                    place,
                    format!(
                        "{count} elements of {element} bytes (stride {stride}) from byteOffset {offset} run past bufferViews[{v}] ({} bytes)",
                        view.length
                    ),
                ));
            }
        }
        None => {
            // All zeros but for the sparse values: bounded by the buffer data the file carries,
            // as any real use (sparse morph targets) has an attribute of that size in a buffer.
            if count.checked_mul(element).is_none_or(|b| b > buffer_bytes) {
                return Err(invalid(
                    place,
                    format!(
                        "count {count} without a bufferView would decode {} bytes, more than the file's {buffer_bytes} bytes of buffers",
                        count.saturating_mul(element)
                    ),
                ));
            }
        }
    }
    if let Some(sparse) = acc.get("sparse") {
        let sparse = sparse
            .as_object()
            .ok_or_else(|| invalid(format!("{place}.sparse"), "is not an object"))?;
        check_sparse(
            &format!("{place}.sparse"),
            sparse,
            count,
            element,
            views,
            buffers,
        )?;
    }
    Ok(AccessorInfo {
        count,
        component_type,
        components,
        element,
    })
}

fn check_sparse(
    place: &str,
    sparse: &Map<String, Value>,
    accessor_count: u64,
    element: u64,
    views: &[View],
    buffers: &[Vec<u8>],
) -> Result<()> {
    let count = required_uint(sparse, "count", place)?;
    if count == 0 || count > accessor_count {
        return Err(invalid(
            place,
            format!("count {count} is not in 1..={accessor_count}"),
        ));
    }
    let part = |key: &str| -> Result<(String, &Map<String, Value>, usize, u64)> {
        let p = format!("{place}.{key}");
        let obj = sparse
            .get(key)
            .and_then(Value::as_object)
            .ok_or_else(|| invalid(&p, "missing or not an object"))?;
        let v = index(obj, "bufferView", &p, "bufferViews", views.len())?
            .ok_or_else(|| invalid(&p, "missing bufferView"))?;
        let offset = uint(obj, "byteOffset", &p)?.unwrap_or(0);
        Ok((p, obj, v, offset))
    };
    let (p, obj, v, offset) = part("indices")?;
    let component_type = required_uint(obj, "componentType", &p)?;
    let index_size = match component_type {
        5121 => 1,
        5123 => 2,
        5125 => 4,
        t => {
            return Err(invalid(
                p,
                format!("componentType {t} is not an unsigned index type"),
            ))
        }
    };
    let view = &views[v];
    let stride = view.stride.unwrap_or(index_size);
    if span(offset, stride, count, index_size).is_none_or(|end| end > view.length) {
        return Err(invalid(
            p,
            format!(
                "{count} indices run past bufferViews[{v}] ({} bytes)",
                view.length
            ),
        ));
    }
    // The crate pairs indices with values in order: they must rise strictly and stay in range.
    let data = &buffers[view.buffer][(view.offset + offset) as usize..];
    let mut previous = None;
    for k in 0..count as usize {
        let at = k * stride as usize;
        let value = match index_size {
            1 => u64::from(data[at]),
            2 => u64::from(u16::from_le_bytes([data[at], data[at + 1]])),
            _ => u64::from(le_u32(data, at)),
        };
        if value >= accessor_count || previous.is_some_and(|q| value <= q) {
            return Err(invalid(
                p,
                format!("index {k} is {value}: sparse indices must rise strictly and stay below {accessor_count}"),
            ));
        }
        previous = Some(value);
    }
    let (p, _, v, offset) = part("values")?;
    let view = &views[v];
    let stride = view.stride.unwrap_or(element);
    if stride < element || span(offset, stride, count, element).is_none_or(|end| end > view.length)
    {
        return Err(invalid(
            p,
            format!("{count} values of {element} bytes (stride {stride}) run past bufferViews[{v}] ({} bytes)", view.length),
        ));
    }
    Ok(())
}

/// Checks an accessor the loader reads as `want_components` floats (or, for indices, unsigned
/// scalars) and returns its count.
fn typed_accessor(
    place: &str,
    obj: &Map<String, Value>,
    key: &str,
    accessors: &[AccessorInfo],
    indices: bool,
    want_components: Option<u64>,
) -> Result<Option<AccessorInfo>> {
    let Some(a) = index(obj, key, place, "accessors", accessors.len())? else {
        return Ok(None);
    };
    let info = accessors[a];
    let place = format!("{place}.{key}");
    if indices {
        if info.components != 1 || !matches!(info.component_type, 5121 | 5123 | 5125) {
            return Err(invalid(
                place,
                format!("accessors[{a}] must be SCALAR of an unsigned integer type (5121, 5123, 5125), not componentType {} with {} components", info.component_type, info.components),
            ));
        }
    } else if let Some(n) = want_components {
        if info.components != n || info.component_type != 5126 {
            return Err(invalid(
                place,
                format!("accessors[{a}] must be {n} FLOAT (5126) components, not componentType {} with {} components", info.component_type, info.components),
            ));
        }
    }
    Ok(Some(info))
}

/// An attribute's accessor must have one element per vertex.
fn same_count(place: &str, info: &AccessorInfo, vertex_count: u64) -> Result<()> {
    if info.count == vertex_count {
        Ok(())
    } else {
        Err(invalid(
            place,
            format!(
                "count {} differs from POSITION's {vertex_count}",
                info.count
            ),
        ))
    }
}

fn check_primitive(
    place: &str,
    prim: &Map<String, Value>,
    accessors: &[AccessorInfo],
    budget: u64,
) -> Result<()> {
    let attributes = prim
        .get("attributes")
        .and_then(Value::as_object)
        .ok_or_else(|| invalid(place, "missing attributes object"))?;
    let attr_place = format!("{place}.attributes");
    let mut read = Vec::new();
    let mut decoded = 0u64;
    for key in attributes.keys() {
        let want = match key.as_str() {
            "POSITION" | "NORMAL" => Some(3),
            "TANGENT" => Some(4),
            _ => None,
        };
        if let Some(info) = typed_accessor(&attr_place, attributes, key, accessors, false, want)? {
            // The loader stores positions and normals as f64 triples, `_` attributes as f32.
            decoded = decoded.saturating_add(info.count.saturating_mul(info.element * 2));
            read.push((format!("{attr_place}.{key}"), key == "POSITION", info));
        }
    }
    let vertex_count = read
        .iter()
        .find(|r| r.1)
        .map(|r| r.2.count)
        .ok_or_else(|| invalid(&attr_place, "no POSITION"))?;
    for (place, _, info) in &read {
        same_count(place, info, vertex_count)?;
    }
    if let Some(info) = typed_accessor(place, prim, "indices", accessors, true, None)? {
        decoded = decoded.saturating_add(info.count.saturating_mul(4));
    }
    if let Some(mode) = uint(prim, "mode", place)? {
        if mode > 6 {
            return Err(invalid(
                format!("{place}.mode"),
                format!("{mode} is not a glTF primitive mode"),
            ));
        }
    }
    for (t, target) in objects(prim, "targets", &format!("{place}."))?
        .iter()
        .enumerate()
    {
        let tplace = format!("{place}.targets[{t}]");
        for key in target.keys() {
            if !matches!(key.as_str(), "POSITION" | "NORMAL" | "TANGENT") {
                continue;
            }
            if let Some(info) = typed_accessor(&tplace, target, key, accessors, false, Some(3))? {
                same_count(&format!("{tplace}.{key}"), &info, vertex_count)?;
            }
        }
        // Each target is stored as one f64 triple per vertex, whatever it carries.
        decoded = decoded.saturating_add(vertex_count.saturating_mul(24));
    }
    if decoded > budget {
        return Err(invalid(
            place,
            format!("would decode {decoded} bytes, more than {DECODE_FACTOR} × the input's size + {DECODE_SLACK} ({budget} bytes)"),
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percent_decoding() {
        assert_eq!(percent_decode("a%20b.bin").as_deref(), Some("a b.bin"));
        assert_eq!(percent_decode("%FF%FE.bin"), None);
        assert_eq!(percent_decode("x%2"), None);
        assert_eq!(percent_decode("%2e%2e/x").as_deref(), Some("../x"));
    }

    #[test]
    fn uri_schemes() {
        assert_eq!(scheme("file:///etc/passwd"), Some("file"));
        assert_eq!(scheme("C:/x.bin"), Some("C"));
        assert_eq!(scheme("dir/x.bin"), None);
        assert_eq!(scheme("a b:c"), None);
    }

    #[test]
    fn glb_header_lengths() {
        let mut glb = b"glTF".to_vec();
        glb.extend(2u32.to_le_bytes());
        glb.extend(0u32.to_le_bytes());
        let e = split_glb(&glb).unwrap_err().to_string();
        assert!(
            e.contains("GLB header: length 0 differs from the file's 12 bytes"),
            "{e}"
        );
        let e = split_glb(&glb[..9]).unwrap_err().to_string();
        assert!(e.contains("fewer than the 12-byte header"), "{e}");
        glb[8..12].copy_from_slice(&30u32.to_le_bytes());
        glb.extend(100u32.to_le_bytes());
        glb.extend(CHUNK_JSON.to_le_bytes());
        glb.extend([b' '; 10]);
        let e = split_glb(&glb).unwrap_err().to_string();
        assert!(e.contains("chunk length 100 runs past the end"), "{e}");
    }

    /// A one-triangle `.gltf` in `dir` whose buffer `uri` is given; the buffer file holds the
    /// positions and indices and is written at `bin` (if given).
    fn triangle(dir: &Path, uri: &str, bin: Option<&Path>) -> PathBuf {
        let mut data: Vec<u8> = [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]
            .iter()
            .flat_map(|x| x.to_le_bytes())
            .collect();
        data.extend([0u16, 1, 2, 0].iter().flat_map(|i| i.to_le_bytes()));
        if let Some(bin) = bin {
            std::fs::write(bin, &data).unwrap();
        }
        let json = serde_json::json!({
            "asset": {"version": "2.0"},
            "buffers": [{"uri": uri, "byteLength": data.len()}],
            "bufferViews": [
                {"buffer": 0, "byteOffset": 0, "byteLength": 36},
                {"buffer": 0, "byteOffset": 36, "byteLength": 6}
            ],
            "accessors": [
                {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                 "min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 0.0]},
                {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"}
            ],
            "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}]
        });
        let path = dir.join("t.gltf");
        std::fs::write(&path, serde_json::to_vec(&json).unwrap()).unwrap();
        path
    }

    fn scratch_dir(name: &str) -> PathBuf {
        let dir =
            std::env::temp_dir().join(format!("facebake-gltf-check-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(dir.join("asset")).unwrap();
        dir
    }

    #[test]
    fn buffers_stay_in_the_asset_folder_unless_allowed() {
        let dir = scratch_dir("uris");
        let asset = dir.join("asset");
        let outside = dir.join("outside.bin");
        // Inside the folder: read.
        let ok = triangle(&asset, "t.bin", Some(&asset.join("t.bin")));
        let (_, data) = import(&ok, BufferAccess::AssetFolder).unwrap();
        assert_eq!(data[0].0.len(), 44);
        // `..`, absolute and file: URIs: refused, then read when allowed.
        triangle(&dir, "x", Some(&outside));
        let absolute = outside.to_str().unwrap().to_owned();
        for (uri, reason) in [
            ("../outside.bin".to_owned(), "has a \"..\" component"),
            ("%2e%2e/outside.bin".to_owned(), "has a \"..\" component"),
            (absolute.clone(), "is an absolute path"),
            (format!("file://{absolute}"), "is a file: URI"),
        ] {
            let path = triangle(&asset, &uri, None);
            let e = import(&path, BufferAccess::AssetFolder)
                .unwrap_err()
                .to_string();
            assert!(
                e.contains("buffers[0].uri") && e.contains(reason),
                "{uri}: {e}"
            );
            assert!(import(&path, BufferAccess::Anywhere).is_ok(), "{uri}");
        }
        // A link inside the folder that leads out of it.
        #[cfg(unix)]
        {
            std::os::unix::fs::symlink(&outside, asset.join("link.bin")).unwrap();
            let path = triangle(&asset, "link.bin", None);
            let e = import(&path, BufferAccess::AssetFolder)
                .unwrap_err()
                .to_string();
            assert!(e.contains("outside the asset's folder"), "{e}");
        }
        // Other schemes are never fetched.
        let path = triangle(&asset, "https://example.com/t.bin", None);
        let e = import(&path, BufferAccess::Anywhere)
            .unwrap_err()
            .to_string();
        assert!(e.contains("scheme \"https:\" is not read"), "{e}");
        // A buffer file shorter than its byteLength.
        std::fs::write(asset.join("short.bin"), [0u8; 10]).unwrap();
        let path = triangle(&asset, "short.bin", None);
        let e = import(&path, BufferAccess::AssetFolder)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("buffers[0]: byteLength 44, but only 10 bytes are there"),
            "{e}"
        );
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn sparse_indices_must_rise_and_stay_in_range() {
        let dir = scratch_dir("sparse");
        let asset = dir.join("asset");
        let path = triangle(&asset, "t.bin", Some(&asset.join("t.bin")));
        let mut json: Value = serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
        // Sparse POSITION values from view 0, indices from view 1 (u16 0, 1, 2 then 0).
        json["accessors"][0]["sparse"] = serde_json::json!({
            "count": 3,
            "indices": {"bufferView": 1, "componentType": 5123},
            "values": {"bufferView": 0}
        });
        std::fs::write(&path, serde_json::to_vec(&json).unwrap()).unwrap();
        assert!(import(&path, BufferAccess::AssetFolder).is_ok());
        json["accessors"][0]["sparse"]["count"] = 4.into();
        std::fs::write(&path, serde_json::to_vec(&json).unwrap()).unwrap();
        let e = import(&path, BufferAccess::AssetFolder)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("accessors[0].sparse: count 4 is not in 1..=3"),
            "{e}"
        );
        json["accessors"][0]["sparse"]["count"] = 3.into();
        json["bufferViews"][1]["byteOffset"] = 38.into();
        json["bufferViews"][1]["byteLength"] = 6.into();
        std::fs::write(&path, serde_json::to_vec(&json).unwrap()).unwrap();
        let e = import(&path, BufferAccess::AssetFolder)
            .unwrap_err()
            .to_string();
        assert!(e.contains("sparse indices must rise strictly"), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn fixtures_still_load() {
        for name in [
            "FaceCapHeadGeneric.glb",
            "mediapipe_canonical_face_model.glb",
        ] {
            let path = Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("../fixtures")
                .join(name);
            let (doc, data) = import(&path, BufferAccess::AssetFolder).unwrap();
            assert_eq!(doc.buffers().count(), data.len());
        }
    }

    #[test]
    fn spans_never_overflow() {
        assert_eq!(span(0, 12, 1, 12), Some(12));
        assert_eq!(span(4, 16, 3, 12), Some(48));
        assert_eq!(span(0, 12, 0, 12), None);
        assert_eq!(span(u64::MAX, 12, 2, 12), None);
        assert_eq!(span(0, u64::MAX, 3, 12), None);
    }
}
