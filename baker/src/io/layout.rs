//! Marker layout files: where each motion-capture marker sits on the face mesh.
//!
//! A layout is TOML (`.toml`) or JSON (`.json`), chosen by the file extension. It has one
//! table, `markers`, mapping each marker name to its anchor and optional stiffness:
//!
//! ```toml
//! [markers]
//! ForeHead_M = { vertex = 1234 }
//! Nose_Tip = { point = [0.0, 0.01, 0.1] }
//! Chin_M = { vertex = 12, stiffness = 3 }
//! ```
//!
//! ```json
//! {"markers": {"ForeHead_M": {"vertex": 1234},
//!              "Nose_Tip": {"point": [0.0, 0.01, 0.1]},
//!              "Chin_M": {"vertex": 12, "stiffness": 3}}}
//! ```
//!
//! - `vertex`: a vertex index in the glTF file's own vertex order (before welding).
//! - `point`: a position in the mesh's units; [`place_markers`] snaps it to the closest point
//!   on the surface, and refuses it if that is farther than the caller's `max_snap`.
//! - `stiffness`: a number from 1 to 9 (default 1), how firmly the marker pins the surface.
//!
//! An optional `groups` table names the marker groups of discontinuity masks (see
//! [`crate::io::marker_groups`]); `read_layout` skips it, and so the optional `triangles` list
//! of planar bones' control triangles (see [`crate::io::control_triangles`]).
//!
//! Each marker has exactly one of `vertex` and `point`; no other keys are allowed. Marker
//! names must be unique, and no two markers may sit on the same (welded) vertex or point.
//! Markers keep their file order.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use serde::de::{Deserializer, MapAccess, Visitor};
use serde::ser::{SerializeMap, Serializer};
use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::io::gltf_mesh::FaceMesh;
use crate::mesh::{closest_point, distance, SurfacePoint};

/// Where a marker is anchored on the mesh.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum MarkerAnchor {
    /// On this vertex (glTF vertex order, before welding).
    Vertex(u32),
    /// At the surface point closest to this position (mesh units).
    Point([f64; 3]),
}

/// One marker of a layout.
#[derive(Debug, Clone, PartialEq)]
pub struct LayoutMarker {
    /// Marker name, as the capture files name it.
    pub name: String,
    /// Where it sits.
    pub anchor: MarkerAnchor,
    /// How firmly it pins the surface, 1 to 9.
    pub stiffness: f64,
}

/// A marker layout, markers in file order.
#[derive(Debug, Clone, PartialEq)]
pub struct MarkerLayout {
    /// The file it was read from (used in error messages).
    pub source: PathBuf,
    /// The markers, in file order.
    pub markers: Vec<LayoutMarker>,
}

/// A marker placed on a mesh.
#[derive(Debug, Clone, PartialEq)]
pub struct PlacedMarker {
    /// Marker name.
    pub name: String,
    /// Its rest position on the surface (mesh units).
    pub position: [f64; 3],
    /// Where on the surface it is, in the mesh's ORIGINAL glTF triangles and vertex indices,
    /// so morph deltas interpolate directly with [`SurfacePoint::interpolate`]. `distance` is
    /// how far a `point` anchor was snapped (0 for `vertex` anchors).
    pub surface: SurfacePoint,
    /// Stiffness, 1 to 9.
    pub stiffness: f64,
}

/// A problem with a layout file or with placing it on a mesh; each names the file.
#[derive(Debug, Error)]
pub enum LayoutError {
    /// The file could not be read or written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The extension is neither `.toml` nor `.json`.
    #[error("{}: a layout file must end in .toml or .json", path.display())]
    UnknownFormat {
        /// The file.
        path: PathBuf,
    },
    /// Syntax or shape error in the file.
    #[error("{}:{line}:{column}: {message}", path.display())]
    Parse {
        /// The file.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// 1-based column.
        column: usize,
        /// What the parser said.
        message: String,
    },
    /// The layout has no markers.
    #[error("{}: the layout has no markers", path.display())]
    NoMarkers {
        /// The file.
        path: PathBuf,
    },
    /// A marker has both or neither of `vertex` and `point`.
    #[error("{}: marker \"{marker}\" needs exactly one of `vertex` and `point`", path.display())]
    AnchorMissing {
        /// The file.
        path: PathBuf,
        /// The marker.
        marker: String,
    },
    /// Two markers have the same name.
    #[error("{}: marker name \"{marker}\" is used twice", path.display())]
    DuplicateName {
        /// The file.
        path: PathBuf,
        /// The name.
        marker: String,
    },
    /// A stiffness outside 1..=9.
    #[error("{}: marker \"{marker}\" has stiffness {value}; it must be from 1 to 9", path.display())]
    Stiffness {
        /// The file.
        path: PathBuf,
        /// The marker.
        marker: String,
        /// The value given.
        value: f64,
    },
    /// A point with a NaN or infinite coordinate.
    #[error("{}: marker \"{marker}\" has a non-finite point {point:?}", path.display())]
    NotFinite {
        /// The file.
        path: PathBuf,
        /// The marker.
        marker: String,
        /// The point.
        point: [f64; 3],
    },
    /// A vertex index beyond the mesh.
    #[error(
        "{}: marker \"{marker}\" is on vertex {vertex}, but mesh \"{mesh}\" has only {vertex_count} vertices",
        path.display()
    )]
    UnknownVertex {
        /// The file.
        path: PathBuf,
        /// The marker.
        marker: String,
        /// The vertex given.
        vertex: u32,
        /// The mesh's name.
        mesh: String,
        /// The mesh's vertex count.
        vertex_count: usize,
    },
    /// A vertex that no triangle uses, so the marker would not be on the surface.
    #[error("{}: marker \"{marker}\" is on vertex {vertex}, which no triangle of mesh \"{mesh}\" uses", path.display())]
    LooseVertex {
        /// The file.
        path: PathBuf,
        /// The marker.
        marker: String,
        /// The vertex given.
        vertex: u32,
        /// The mesh's name.
        mesh: String,
    },
    /// Two markers on the same spot.
    #[error("{}: markers \"{other}\" and \"{marker}\" are on the same spot {position:?}{}", path.display(),
        welded_vertex.map(|v| format!(" (welded vertex {v})")).unwrap_or_default())]
    DuplicateAnchor {
        /// The file.
        path: PathBuf,
        /// The later marker.
        marker: String,
        /// The earlier marker on the same spot.
        other: String,
        /// The shared position.
        position: [f64; 3],
        /// The shared welded vertex, when both are vertex anchors.
        welded_vertex: Option<u32>,
    },
    /// A point farther from the surface than allowed.
    #[error(
        "{}: marker \"{marker}\" point {point:?} is {distance:.6} from the surface of mesh \"{mesh}\" (at most {max_snap:.6} allowed)",
        path.display()
    )]
    TooFar {
        /// The file.
        path: PathBuf,
        /// The marker.
        marker: String,
        /// The point given.
        point: [f64; 3],
        /// Its distance to the surface.
        distance: f64,
        /// The allowed distance.
        max_snap: f64,
        /// The mesh's name.
        mesh: String,
    },
}

/// One marker as written in the file.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMarker {
    vertex: Option<u32>,
    point: Option<[f64; 3]>,
    stiffness: Option<f64>,
}

/// The markers table, in file order (duplicates kept, so they can be reported by name).
struct RawMarkers(Vec<(String, RawMarker)>);

impl<'de> Deserialize<'de> for RawMarkers {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Ordered;
        impl<'de> Visitor<'de> for Ordered {
            type Value = RawMarkers;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a table of markers, name = { vertex = N } or { point = [x, y, z] }")
            }
            fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<RawMarkers, A::Error> {
                let mut out = Vec::new();
                while let Some(entry) = map.next_entry()? {
                    out.push(entry);
                }
                Ok(RawMarkers(out))
            }
        }
        d.deserialize_map(Ordered)
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawLayout {
    markers: RawMarkers,
    /// Marker groups for discontinuity masks, read by [`crate::io::marker_groups`].
    #[serde(default, rename = "groups")]
    _groups: Option<serde::de::IgnoredAny>,
    /// Control triangles of planar bones, read by [`crate::io::control_triangles`].
    #[serde(default, rename = "triangles")]
    _triangles: Option<serde::de::IgnoredAny>,
}

#[derive(Clone, Copy)]
enum Format {
    Toml,
    Json,
}

fn format_of(path: &Path) -> Result<Format, LayoutError> {
    match path.extension().and_then(|e| e.to_str()) {
        Some(e) if e.eq_ignore_ascii_case("toml") => Ok(Format::Toml),
        Some(e) if e.eq_ignore_ascii_case("json") => Ok(Format::Json),
        _ => Err(LayoutError::UnknownFormat {
            path: path.to_path_buf(),
        }),
    }
}

/// 1-based line and column of byte `offset` in `text`.
fn line_column(text: &str, offset: usize) -> (usize, usize) {
    let before = &text[..offset.min(text.len())];
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    (
        before.matches('\n').count() + 1,
        before[line_start..].chars().count() + 1,
    )
}

/// Reads and checks a layout file (TOML or JSON by extension).
///
/// Checks everything that does not need the mesh: syntax, one anchor per marker, unique
/// names, stiffness range, finite points.
pub fn read_layout(path: &Path) -> Result<MarkerLayout, LayoutError> {
    let format = format_of(path)?;
    let text = crate::io::read_bounded(path)
        .and_then(|b| {
            String::from_utf8(b)
                .map_err(|e| std::io::Error::new(std::io::ErrorKind::InvalidData, e))
        })
        .map_err(|source| LayoutError::Io {
            path: path.to_path_buf(),
            source,
        })?;
    let parse_error = |line, column, message: &str| LayoutError::Parse {
        path: path.to_path_buf(),
        line,
        column,
        message: message.trim().to_owned(),
    };
    let raw: RawLayout = match format {
        Format::Toml => toml::from_str(&text).map_err(|e| {
            let (line, column) = line_column(&text, e.span().map_or(0, |s| s.start));
            parse_error(line, column, e.message())
        })?,
        Format::Json => serde_json::from_str(&text).map_err(|e| {
            // serde_json puts " at line L column C" at the end of its message; keep the rest.
            let full = e.to_string();
            let message = full.split(" at line ").next().unwrap_or(&full);
            parse_error(e.line(), e.column(), message)
        })?,
    };
    let mut markers = Vec::with_capacity(raw.markers.0.len());
    for (name, m) in raw.markers.0 {
        let anchor = match (m.vertex, m.point) {
            (Some(v), None) => MarkerAnchor::Vertex(v),
            (None, Some(p)) => MarkerAnchor::Point(p),
            _ => {
                return Err(LayoutError::AnchorMissing {
                    path: path.to_path_buf(),
                    marker: name,
                })
            }
        };
        markers.push(LayoutMarker {
            name,
            anchor,
            stiffness: m.stiffness.unwrap_or(1.0),
        });
    }
    let layout = MarkerLayout {
        source: path.to_path_buf(),
        markers,
    };
    check(&layout)?;
    Ok(layout)
}

/// The checks that need no mesh; errors name `layout.source`.
fn check(layout: &MarkerLayout) -> Result<(), LayoutError> {
    let path = || layout.source.clone();
    if layout.markers.is_empty() {
        return Err(LayoutError::NoMarkers { path: path() });
    }
    let mut names = std::collections::HashSet::new();
    for m in &layout.markers {
        if !names.insert(m.name.as_str()) {
            return Err(LayoutError::DuplicateName {
                path: path(),
                marker: m.name.clone(),
            });
        }
        if !(1.0..=9.0).contains(&m.stiffness) {
            return Err(LayoutError::Stiffness {
                path: path(),
                marker: m.name.clone(),
                value: m.stiffness,
            });
        }
        if let MarkerAnchor::Point(point) = m.anchor {
            if point.iter().any(|x| !x.is_finite()) {
                return Err(LayoutError::NotFinite {
                    path: path(),
                    marker: m.name.clone(),
                    point,
                });
            }
        }
    }
    Ok(())
}

/// One marker's fields, for writing.
struct MarkerFields<'a>(&'a LayoutMarker);

impl Serialize for MarkerFields<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let m = self.0;
        let mut map = s.serialize_map(None)?;
        match &m.anchor {
            MarkerAnchor::Vertex(v) => map.serialize_entry("vertex", v)?,
            MarkerAnchor::Point(p) => map.serialize_entry("point", p)?,
        }
        if m.stiffness != 1.0 {
            map.serialize_entry("stiffness", &m.stiffness)?;
        }
        map.end()
    }
}

/// The markers in order, as a map, for writing.
struct MarkerMap<'a>(&'a [LayoutMarker]);

impl Serialize for MarkerMap<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut map = s.serialize_map(Some(self.0.len()))?;
        for m in self.0 {
            map.serialize_entry(&m.name, &MarkerFields(m))?;
        }
        map.end()
    }
}

/// Writes a layout as TOML or JSON (by `path`'s extension) that [`read_layout`] reads back
/// to the same markers. Refuses layouts that [`read_layout`] would reject.
pub fn write_layout(path: &Path, layout: &MarkerLayout) -> Result<(), LayoutError> {
    let format = format_of(path)?;
    check(&MarkerLayout {
        source: path.to_path_buf(),
        markers: layout.markers.clone(),
    })?;
    let text = match format {
        Format::Json => {
            #[derive(Serialize)]
            struct Out<'a> {
                markers: MarkerMap<'a>,
            }
            let mut text = serde_json::to_string_pretty(&Out {
                markers: MarkerMap(&layout.markers),
            })
            .expect("a layout of finite numbers and strings always serialises");
            text.push('\n');
            text
        }
        Format::Toml => {
            // One inline table per marker, as in the module docs.
            let mut text = String::from("[markers]\n");
            for m in &layout.markers {
                let bare = !m.name.is_empty()
                    && m.name
                        .chars()
                        .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-');
                let key = if bare {
                    m.name.clone()
                } else {
                    toml::Value::String(m.name.clone()).to_string()
                };
                let fields = toml::Value::try_from(MarkerFields(m))
                    .expect("a marker of finite numbers always converts to TOML");
                writeln!(text, "{key} = {fields}").expect("writing to a String");
            }
            text
        }
    };
    std::fs::write(path, text).map_err(|source| LayoutError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// Places a layout's markers on `mesh`.
///
/// `vertex` anchors sit exactly on their vertex; `point` anchors snap to the closest point
/// of the surface, which must be within `max_snap` (mesh units). Surface points refer to the
/// mesh's original triangles and vertex indices. Errors name the layout file and the marker.
pub fn place_markers(
    layout: &MarkerLayout,
    mesh: &FaceMesh,
    max_snap: f64,
) -> Result<Vec<PlacedMarker>, LayoutError> {
    check(layout)?;
    let path = || layout.source.clone();
    // A triangle and corner for each vertex that some triangle uses.
    let mut corner_of: Vec<Option<(usize, usize)>> = vec![None; mesh.positions.len()];
    for (t, tri) in mesh.triangles.iter().enumerate().rev() {
        for (c, &v) in tri.iter().enumerate() {
            corner_of[v as usize] = Some((t, c));
        }
    }
    let mut placed: Vec<PlacedMarker> = Vec::with_capacity(layout.markers.len());
    let tolerance = 1e-9 * mesh.diagonal();
    for m in &layout.markers {
        let surface = match m.anchor {
            MarkerAnchor::Vertex(vertex) => {
                let corner =
                    corner_of
                        .get(vertex as usize)
                        .ok_or_else(|| LayoutError::UnknownVertex {
                            path: path(),
                            marker: m.name.clone(),
                            vertex,
                            mesh: mesh.mesh_name.clone(),
                            vertex_count: mesh.positions.len(),
                        })?;
                let (t, c) = corner.ok_or_else(|| LayoutError::LooseVertex {
                    path: path(),
                    marker: m.name.clone(),
                    vertex,
                    mesh: mesh.mesh_name.clone(),
                })?;
                SurfacePoint::at_corner(&mesh.positions, &mesh.triangles, t, c)
            }
            MarkerAnchor::Point(point) => {
                let sp = closest_point(&mesh.positions, &mesh.triangles, point);
                match sp {
                    Some(sp) if sp.distance <= max_snap => sp,
                    _ => {
                        return Err(LayoutError::TooFar {
                            path: path(),
                            marker: m.name.clone(),
                            point,
                            distance: sp.map_or(f64::INFINITY, |sp| sp.distance),
                            max_snap,
                            mesh: mesh.mesh_name.clone(),
                        })
                    }
                }
            }
        };
        if let Some(other) = placed
            .iter()
            .find(|o| distance(&o.position, &surface.point) <= tolerance)
        {
            let welded = |a: &MarkerAnchor| match a {
                MarkerAnchor::Vertex(v) => Some(mesh.weld[*v as usize]),
                MarkerAnchor::Point(_) => None,
            };
            let other_anchor = layout
                .markers
                .iter()
                .find(|o| o.name == other.name)
                .map(|o| o.anchor);
            let welded_vertex =
                welded(&m.anchor).filter(|&w| other_anchor.and_then(|a| welded(&a)) == Some(w));
            return Err(LayoutError::DuplicateAnchor {
                path: path(),
                marker: m.name.clone(),
                other: other.name.clone(),
                position: surface.point,
                welded_vertex,
            });
        }
        placed.push(PlacedMarker {
            name: m.name.clone(),
            position: surface.point,
            surface,
            stiffness: m.stiffness,
        });
    }
    Ok(placed)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::gltf_mesh::tests::{head, scratch};
    use crate::mesh::farthest_point_sampling;

    /// 40 skin markers by farthest-point sampling, as original glTF vertex indices.
    fn sampled_layout(path: &Path) -> MarkerLayout {
        let m = head();
        let topo = m.welded_topology();
        let skin = topo.components.vertices_of(0);
        let picks = farthest_point_sampling(&m.welded_positions, &skin, 40, skin[0]).unwrap();
        let original = m.welded_to_original();
        let markers = picks
            .iter()
            .enumerate()
            .map(|(i, &w)| LayoutMarker {
                name: format!("M{i:02}"),
                anchor: MarkerAnchor::Vertex(original[w as usize]),
                stiffness: 1.0 + (i % 9) as f64,
            })
            .collect();
        MarkerLayout {
            source: path.to_path_buf(),
            markers,
        }
    }

    fn write(name: &str, text: &str) -> PathBuf {
        let path = scratch(name);
        std::fs::write(&path, text).unwrap();
        path
    }

    fn read_err(name: &str, text: &str) -> (LayoutError, String) {
        let e = read_layout(&write(name, text)).unwrap_err();
        let s = e.to_string();
        assert!(s.contains(name), "{s}");
        (e, s)
    }

    #[test]
    fn reads_documented_examples_in_order() {
        let toml = write(
            "doc.toml",
            "[markers]\nForeHead_M = { vertex = 1234 }\nNose_Tip = { point = [0.0, 0.01, 0.1] }\n\
             Chin_M = { vertex = 12, stiffness = 3 }\n",
        );
        let json = write(
            "doc.json",
            r#"{"markers": {"ForeHead_M": {"vertex": 1234}, "Nose_Tip": {"point": [0.0, 0.01, 0.1]},
                "Chin_M": {"vertex": 12, "stiffness": 3}}}"#,
        );
        let want = vec![
            LayoutMarker {
                name: "ForeHead_M".into(),
                anchor: MarkerAnchor::Vertex(1234),
                stiffness: 1.0,
            },
            LayoutMarker {
                name: "Nose_Tip".into(),
                anchor: MarkerAnchor::Point([0.0, 0.01, 0.1]),
                stiffness: 1.0,
            },
            LayoutMarker {
                name: "Chin_M".into(),
                anchor: MarkerAnchor::Vertex(12),
                stiffness: 3.0,
            },
        ];
        for path in [toml, json] {
            let layout = read_layout(&path).unwrap();
            assert_eq!(layout.markers, want, "{}", path.display());
            assert_eq!(layout.source, path);
        }
    }

    #[test]
    fn round_trips_through_both_formats() {
        for name in ["rt.toml", "rt.json"] {
            let path = scratch(name);
            let mut layout = sampled_layout(&path);
            layout.markers[3].anchor = MarkerAnchor::Point([0.001, -0.25, 1e-7]);
            layout.markers[4].name = "needs quoting \"here\"".into();
            write_layout(&path, &layout).unwrap();
            let back = read_layout(&path).unwrap();
            assert_eq!(back, layout, "{name}");
        }
        let text = std::fs::read_to_string(scratch("rt.toml")).unwrap();
        assert!(text.starts_with("[markers]\nM00 = { vertex = "), "{text}");
    }

    #[test]
    fn places_sampled_vertices_on_facecap() {
        let m = head();
        let layout = sampled_layout(Path::new("sampled.toml"));
        let placed = place_markers(&layout, m, 0.0).unwrap();
        assert_eq!(placed.len(), 40);
        let jaw = &m.morph_targets[m.morph_index("jawOpen").unwrap()].deltas;
        for (p, l) in placed.iter().zip(&layout.markers) {
            let MarkerAnchor::Vertex(v) = l.anchor else {
                unreachable!()
            };
            assert_eq!(p.name, l.name);
            assert_eq!(p.stiffness, l.stiffness);
            assert_eq!(p.position, m.positions[v as usize]);
            assert_eq!(p.surface.distance, 0.0);
            assert_eq!(p.surface.vertices, m.triangles[p.surface.triangle]);
            // Surface points use original indices, so deltas interpolate to the vertex's own.
            assert_eq!(p.surface.interpolate(jaw), jaw[v as usize]);
        }
    }

    #[test]
    fn snaps_points_onto_facecap() {
        let m = head();
        // 1 mm off the middle of a forehead triangle (the frontmost one whose centre is
        // above y = 6 cm, near x = 0, where the skin is smooth), along its normal.
        let centre_of = |t: &[u32; 3]| -> [f64; 3] {
            let [a, b, c] = t.map(|v| m.positions[v as usize]);
            std::array::from_fn(|k| (a[k] + b[k] + c[k]) / 3.0)
        };
        let t = (0..m.triangles.len())
            .filter(|&t| {
                let c = centre_of(&m.triangles[t]);
                c[1] > 0.06 && c[0].abs() < 0.02
            })
            .max_by(|&s, &t| {
                centre_of(&m.triangles[s])[2].total_cmp(&centre_of(&m.triangles[t])[2])
            })
            .unwrap();
        let [a, b, c] = m.triangles[t].map(|v| m.positions[v as usize]);
        let centre = centre_of(&m.triangles[t]);
        let (u, w) = (crate::mesh::sub(&b, &a), crate::mesh::sub(&c, &a));
        let n = [
            u[1] * w[2] - u[2] * w[1],
            u[2] * w[0] - u[0] * w[2],
            u[0] * w[1] - u[1] * w[0],
        ];
        let len = crate::mesh::norm(&n);
        let p: [f64; 3] = std::array::from_fn(|k| centre[k] + 0.001 * n[k] / len);
        let layout = MarkerLayout {
            source: "snap.toml".into(),
            markers: vec![LayoutMarker {
                name: "Cheek".into(),
                anchor: MarkerAnchor::Point(p),
                stiffness: 2.0,
            }],
        };
        let placed = place_markers(&layout, m, 0.002).unwrap();
        let s = &placed[0].surface;
        assert_eq!(s.triangle, t);
        assert!((s.distance - 0.001).abs() < 1e-9, "{s:?}");
        assert!(distance(&placed[0].position, &centre) < 1e-9, "{s:?}");
        let e = place_markers(&layout, m, 0.0005).unwrap_err().to_string();
        assert!(
            e.contains("snap.toml")
                && e.contains("\"Cheek\"")
                && e.contains("is 0.001000 from")
                && e.contains("0.000500"),
            "{e}"
        );
        // The interpolated morph of the snapped point is the morph of its position.
        let jaw = m.morph_index("jawOpen").unwrap();
        let moved = s.interpolate(&m.morphed(&[(jaw, 1.0)]));
        let delta = s.interpolate(&m.morph_targets[jaw].deltas);
        for k in 0..3 {
            assert!((moved[k] - placed[0].position[k] - delta[k]).abs() < 1e-12);
        }
    }

    #[test]
    fn placement_errors() {
        let m = head();
        let marker = |name: &str, anchor| LayoutMarker {
            name: name.into(),
            anchor,
            stiffness: 1.0,
        };
        let layout = |markers| MarkerLayout {
            source: "place.json".into(),
            markers,
        };
        let e = place_markers(
            &layout(vec![marker("Far", MarkerAnchor::Vertex(9999))]),
            m,
            1.0,
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("place.json") && e.contains("\"Far\"") && e.contains("only 2694 vertices"),
            "{e}"
        );
        // Two glTF vertices on one UV seam weld to the same vertex.
        let (i, j) = (0..m.weld.len())
            .flat_map(|i| (i + 1..m.weld.len()).map(move |j| (i, j)))
            .find(|&(i, j)| m.weld[i] == m.weld[j])
            .unwrap();
        let seam = layout(vec![
            marker("A", MarkerAnchor::Vertex(i as u32)),
            marker("B", MarkerAnchor::Vertex(j as u32)),
        ]);
        let e = place_markers(&seam, m, 1.0).unwrap_err();
        assert!(
            matches!(&e, LayoutError::DuplicateAnchor { marker, other, welded_vertex: Some(w), .. }
                if marker == "B" && other == "A" && *w == m.weld[i]),
            "{e}"
        );
        // A point that snaps onto an existing vertex marker.
        let onto = layout(vec![
            marker("A", MarkerAnchor::Vertex(i as u32)),
            marker("P", MarkerAnchor::Point(m.positions[i])),
        ]);
        let e = place_markers(&onto, m, 1.0).unwrap_err().to_string();
        assert!(e.contains("\"A\" and \"P\""), "{e}");
        // A point a metre away.
        let far = layout(vec![marker("Away", MarkerAnchor::Point([0.0, 0.0, 1.0]))]);
        let e = place_markers(&far, m, 0.01).unwrap_err();
        assert!(
            matches!(e, LayoutError::TooFar { distance, .. } if distance > 0.9 && distance < 1.0),
            "{e}"
        );
    }

    /// Line, column and message of the parse error `text` gives.
    fn parse_error_at(name: &str, text: &str) -> (usize, usize, String) {
        match read_err(name, text) {
            (
                LayoutError::Parse {
                    line,
                    column,
                    message,
                    ..
                },
                _,
            ) => (line, column, message),
            (e, _) => panic!("not a parse error: {e}"),
        }
    }

    #[test]
    fn parse_errors_have_line_and_column() {
        let json = "{\"markers\": {\n  \"A\": {\"vertex\": 1},\n  \"B\": {\"vertex\": }\n}}";
        let (_, s) = read_err("bad.json", json);
        assert!(
            s.starts_with(&format!("{}:3:19: ", scratch("bad.json").display())),
            "{s}"
        );
        let (line, column, _) = parse_error_at(
            "bad.toml",
            "[markers]\nA = { vertex = 1 }\nB = { vertex = -4 }\n",
        );
        assert_eq!((line, column), (3, 16));
        let (line, _, message) = parse_error_at("typo.toml", "[markers]\nA = { vertx = 1 }\n");
        assert!(
            line == 2 && message.contains("unknown field `vertx`"),
            "{message}"
        );
        let (line, column, message) = parse_error_at(
            "dup.toml",
            "[markers]\nA = { vertex = 1 }\nA = { vertex = 2 }\n",
        );
        assert!(
            (line, column) == (3, 1) && message.contains("duplicate key"),
            "{message}"
        );
        let (line, _, message) =
            parse_error_at("short.json", "{\"markers\": {\"A\": {\"point\": [1, 2]}}}");
        assert!(
            line == 1 && message.contains("invalid length 2"),
            "{message}"
        );
    }

    #[test]
    fn semantic_errors_name_the_marker() {
        let (e, s) = read_err(
            "dup.json",
            r#"{"markers": {"A": {"vertex": 1}, "B": {"vertex": 2}, "A": {"vertex": 3}}}"#,
        );
        assert!(
            matches!(e, LayoutError::DuplicateName { .. }) && s.contains("\"A\""),
            "{s}"
        );
        for bad in ["0", "9.5", "nan"] {
            let (e, s) = read_err(
                "stiff.toml",
                &format!(
                    "[markers]\nA = {{ vertex = 1 }}\nB = {{ vertex = 2, stiffness = {bad} }}\n"
                ),
            );
            assert!(
                matches!(e, LayoutError::Stiffness { .. }) && s.contains("\"B\""),
                "{s}"
            );
        }
        let (e, s) = read_err(
            "both.toml",
            "[markers]\nA = { vertex = 1, point = [0, 0, 0] }\n",
        );
        assert!(
            matches!(e, LayoutError::AnchorMissing { .. }) && s.contains("\"A\""),
            "{s}"
        );
        let (e, s) = read_err("none.json", r#"{"markers": {"A": {"stiffness": 2}}}"#);
        assert!(matches!(e, LayoutError::AnchorMissing { .. }), "{s}");
        let (e, s) = read_err("inf.toml", "[markers]\nA = { point = [0, inf, 0] }\n");
        assert!(matches!(e, LayoutError::NotFinite { .. }), "{s}");
        let (e, s) = read_err("empty.json", r#"{"markers": {}}"#);
        assert!(matches!(e, LayoutError::NoMarkers { .. }), "{s}");
        let (e, s) = read_err("layout.yaml", "markers: {}");
        assert!(matches!(e, LayoutError::UnknownFormat { .. }), "{s}");
        let e = read_layout(&scratch("absent.toml")).unwrap_err();
        assert!(matches!(e, LayoutError::Io { .. }), "{e}");
    }
}
