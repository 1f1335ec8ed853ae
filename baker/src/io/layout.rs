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
//! - `point`: a position in the mesh's units; [`crate::model::place_markers`] snaps it to the closest point
//!   on the surface, and refuses it if that is farther than the caller's `max_snap`.
//! - `stiffness`: a number from 1 to 9 (default 1), how firmly the marker pins the surface.
//!
//! An optional `groups` table names the marker groups of discontinuity masks: each entry is one
//! mask, the markers on the upper side of an opening and those on the lower side (markers in
//! neither list influence both sides):
//!
//! ```toml
//! [groups]
//! mouth = { upper = ["Mouth_Up", "Mouth_UpL1"], lower = ["Mouth_Down", "Chin"] }
//! eyes = { upper = ["Leye_Up", "Reye_Up"], lower = ["Leye_Down", "Reye_Down"] }
//! ```
//!
//! An optional `triangles` list gives planar bones' control triangles by marker names (a layout
//! without it leaves the planar bake to build the control surface automatically). In TOML the
//! key must come before the tables (a key after `[markers]` belongs to that table):
//!
//! ```toml
//! triangles = [["Nose_Tip", "Mouth_UpL1", "Mouth_Up"], ["Mouth_Up", "Mouth_UpR1", "Nose_Tip"]]
//! ```
//!
//! The JSON forms are the same object under `"groups"` and the same list under `"triangles"`.
//!
//! Each marker has exactly one of `vertex` and `point`; no other keys are allowed. Marker
//! names must be unique, and no two markers may sit on the same (welded) vertex or point.
//! Markers keep their file order.

use std::fmt::Write as _;
use std::path::Path;

use serde::de::{Deserializer, MapAccess, Visitor};
use serde::ser::{SerializeMap, Serializer};
use serde::{Deserialize, Serialize};

use crate::model::layout::check;
use crate::model::{LayoutError, LayoutMarker, MarkerAnchor, MarkerGroups, MarkerLayout};

/// One marker as written in the file.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMarker {
    vertex: Option<u32>,
    point: Option<[f64; 3]>,
    stiffness: Option<f64>,
}

/// A table in file order (duplicates kept, so they can be reported by name).
struct Ordered<T>(Vec<(String, T)>);

impl<'de, T: Deserialize<'de>> Deserialize<'de> for Ordered<T> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Entries<T>(std::marker::PhantomData<T>);
        impl<'de, T: Deserialize<'de>> Visitor<'de> for Entries<T> {
            type Value = Ordered<T>;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a table of named entries")
            }
            fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Ordered<T>, A::Error> {
                let mut out = Vec::new();
                while let Some(entry) = map.next_entry()? {
                    out.push(entry);
                }
                Ok(Ordered(out))
            }
        }
        d.deserialize_map(Entries(std::marker::PhantomData))
    }
}

/// One mask's groups as written in the file.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSides {
    upper: Vec<String>,
    lower: Vec<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawLayout {
    markers: Ordered<RawMarker>,
    /// Marker groups for discontinuity masks.
    #[serde(default)]
    groups: Option<Ordered<RawSides>>,
    /// Control triangles of planar bones.
    #[serde(default)]
    triangles: Option<Vec<[String; 3]>>,
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

/// Reads and checks a layout file (TOML or JSON by extension): markers, groups and control
/// triangles in one parse.
///
/// Checks everything that does not need the mesh: syntax, one anchor per marker, unique
/// names, stiffness range, finite points, groups and triangles naming the layout's markers.
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
    let names: Vec<&str> = markers.iter().map(|m| m.name.as_str()).collect();
    let groups = raw.groups.map_or(Ok(Vec::new()), |g| {
        g.0.into_iter()
            .map(|(name, sides)| resolve_group(path, &names, name, sides))
            .collect()
    })?;
    let triangles = raw
        .triangles
        .map(|t| resolve_triangles(path, &names, t))
        .transpose()?;
    let layout = MarkerLayout {
        source: path.to_path_buf(),
        markers,
        groups,
        triangles,
    };
    check(&layout)?;
    Ok(layout)
}

/// One mask's groups by marker index; errors name the file, the group and the marker.
fn resolve_group(
    path: &Path,
    names: &[&str],
    name: String,
    sides: RawSides,
) -> Result<MarkerGroups, LayoutError> {
    let mut seen = std::collections::HashSet::new();
    let mut index = |marker: &String| {
        let i = names
            .iter()
            .position(|m| m == marker)
            .ok_or_else(|| LayoutError::GroupMarker {
                path: path.to_path_buf(),
                group: name.clone(),
                marker: marker.clone(),
            })?;
        if !seen.insert(i) {
            return Err(LayoutError::GroupRepeated {
                path: path.to_path_buf(),
                group: name.clone(),
                marker: marker.clone(),
            });
        }
        Ok(i)
    };
    let upper = sides
        .upper
        .iter()
        .map(&mut index)
        .collect::<Result<Vec<_>, _>>()?;
    let lower = sides
        .lower
        .iter()
        .map(&mut index)
        .collect::<Result<Vec<_>, _>>()?;
    for (side, list) in [("upper", &upper), ("lower", &lower)] {
        if list.is_empty() {
            return Err(LayoutError::GroupEmptySide {
                path: path.to_path_buf(),
                group: name.clone(),
                side,
            });
        }
    }
    Ok(MarkerGroups { name, upper, lower })
}

/// The control triangles by marker index; errors name the file and the triangle. Their shapes
/// on the mesh are checked by the planar bake.
fn resolve_triangles(
    path: &Path,
    names: &[&str],
    raw: Vec<[String; 3]>,
) -> Result<Vec<[usize; 3]>, LayoutError> {
    if raw.is_empty() {
        return Err(LayoutError::TrianglesEmpty {
            path: path.to_path_buf(),
        });
    }
    let mut seen = std::collections::HashMap::new();
    let mut out = Vec::with_capacity(raw.len());
    for (index, written) in raw.into_iter().enumerate() {
        let mut tri = [0usize; 3];
        for (slot, marker) in tri.iter_mut().zip(&written) {
            *slot = names.iter().position(|m| m == marker).ok_or_else(|| {
                LayoutError::TriangleMarker {
                    path: path.to_path_buf(),
                    index,
                    names: format!("{written:?}"),
                    marker: marker.clone(),
                }
            })?;
        }
        let repeated = |problem: String| LayoutError::TriangleRepeated {
            path: path.to_path_buf(),
            index,
            names: format!("{written:?}"),
            problem,
        };
        if tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2] {
            return Err(repeated(
                "names a marker twice (a triangle needs three distinct markers)".into(),
            ));
        }
        let mut key = tri;
        key.sort_unstable();
        if let Some(first) = seen.insert(key, index) {
            return Err(repeated(format!("repeats triangles[{first}]")));
        }
        out.push(tri);
    }
    Ok(out)
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
/// to the same markers, groups and triangles. Refuses layouts that [`read_layout`] would
/// reject.
pub fn write_layout(path: &Path, layout: &MarkerLayout) -> Result<(), LayoutError> {
    let format = format_of(path)?;
    check(&MarkerLayout {
        source: path.to_path_buf(),
        ..layout.clone()
    })?;
    let name = |i: &usize| layout.markers.get(*i).map_or("?", |m| m.name.as_str());
    let triangles: Option<Vec<[&str; 3]>> = layout
        .triangles
        .as_ref()
        .map(|t| t.iter().map(|t| t.each_ref().map(name)).collect());
    let groups: Vec<(&str, Vec<&str>, Vec<&str>)> = layout
        .groups
        .iter()
        .map(|g| {
            (
                g.name.as_str(),
                g.upper.iter().map(name).collect(),
                g.lower.iter().map(name).collect(),
            )
        })
        .collect();
    let text = match format {
        Format::Json => {
            #[derive(Serialize)]
            struct Sides<'a> {
                upper: &'a [&'a str],
                lower: &'a [&'a str],
            }
            #[derive(Serialize)]
            struct Out<'a> {
                markers: MarkerMap<'a>,
                #[serde(skip_serializing_if = "serde_json::Map::is_empty")]
                groups: serde_json::Map<String, serde_json::Value>,
                #[serde(skip_serializing_if = "Option::is_none")]
                triangles: Option<Vec<[&'a str; 3]>>,
            }
            let groups = groups
                .iter()
                .map(|(n, upper, lower)| {
                    let sides = serde_json::to_value(Sides { upper, lower })
                        .expect("names always serialise");
                    (n.to_string(), sides)
                })
                .collect();
            let mut text = serde_json::to_string_pretty(&Out {
                markers: MarkerMap(&layout.markers),
                groups,
                triangles,
            })
            .expect("a layout of finite numbers and strings always serialises");
            text.push('\n');
            text
        }
        Format::Toml => {
            // One inline table per marker and per group, as in the module docs; the triangles
            // before the tables.
            let mut text = String::new();
            if let Some(t) = &triangles {
                let list = toml::Value::try_from(t).expect("names always convert to TOML");
                writeln!(text, "triangles = {list}").expect("writing to a String");
            }
            text.push_str("[markers]\n");
            for m in &layout.markers {
                let fields = toml::Value::try_from(MarkerFields(m))
                    .expect("a marker of finite numbers always converts to TOML");
                writeln!(text, "{} = {fields}", toml_key(&m.name)).expect("writing to a String");
            }
            if !groups.is_empty() {
                text.push_str("[groups]\n");
                for (n, upper, lower) in &groups {
                    let list = |l: &[&str]| {
                        toml::Value::try_from(l).expect("names always convert to TOML")
                    };
                    writeln!(
                        text,
                        "{} = {{ upper = {}, lower = {} }}",
                        toml_key(n),
                        list(upper),
                        list(lower)
                    )
                    .expect("writing to a String");
                }
            }
            text
        }
    };
    std::fs::write(path, text).map_err(|source| LayoutError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// `name` as a TOML key: bare when it can be, else quoted.
fn toml_key(name: &str) -> String {
    let bare = !name.is_empty()
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-');
    if bare {
        name.to_string()
    } else {
        toml::Value::String(name.to_string()).to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::gltf_mesh::tests::{head, scratch};
    use crate::mesh::distance;
    use crate::mesh::farthest_point_sampling;
    use crate::model::place_markers;
    use std::path::PathBuf;

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
            groups: vec![MarkerGroups {
                name: "mouth".into(),
                upper: vec![0, 1],
                lower: vec![2],
            }],
            triangles: Some(vec![[0, 1, 2], [3, 2, 1]]),
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
        assert!(
            text.starts_with("triangles = [[\"M00\", \"M01\", \"M02\"]"),
            "{text}"
        );
        assert!(text.contains("\n[markers]\nM00 = { vertex = "), "{text}");
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
            groups: Vec::new(),
            triangles: None,
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
            groups: Vec::new(),
            triangles: None,
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

    #[test]
    fn reads_groups_by_name_and_names_bad_ones() {
        let t = write(
            "g.toml",
            "[markers]\nA = { vertex = 0 }\nB = { vertex = 1 }\nC = { vertex = 2 }\nD = { vertex = 3 }\n\
             [groups]\nmouth = { upper = [\"A\"], lower = [\"C\", \"D\"] }\neyes = { upper = [\"B\"], lower = [\"A\"] }\n",
        );
        let g = read_layout(&t).unwrap().groups;
        assert_eq!(
            g[0],
            MarkerGroups {
                name: "mouth".into(),
                upper: vec![0],
                lower: vec![2, 3]
            }
        );
        assert_eq!(g[1].name, "eyes", "file order");
        let j = write(
            "g.json",
            r#"{"markers": {"A": {"vertex": 0}, "B": {"vertex": 1}},
                "groups": {"eyes": {"upper": ["B"], "lower": ["A"]}}}"#,
        );
        assert_eq!(read_layout(&j).unwrap().groups[0].upper, vec![1]);
        let markers = "[markers]\nA = { vertex = 0 }\nB = { vertex = 1 }\n";
        assert!(read_layout(&write("n.toml", markers))
            .unwrap()
            .groups
            .is_empty());
        let (e, s) = read_err(
            "b.toml",
            &format!("{markers}[groups]\nmouth = {{ upper = [\"Z\"], lower = [\"A\"] }}\n"),
        );
        assert!(
            matches!(e, LayoutError::GroupMarker { .. }) && s.contains("\"Z\""),
            "{s}"
        );
        let (e, _) = read_err(
            "t.toml",
            &format!("{markers}[groups]\nm = {{ upper = [\"A\"], lower = [\"A\"] }}\n"),
        );
        assert!(matches!(e, LayoutError::GroupRepeated { .. }));
        let (e, _) = read_err(
            "e.toml",
            &format!("{markers}[groups]\nm = {{ upper = [], lower = [\"A\"] }}\n"),
        );
        assert!(matches!(e, LayoutError::GroupEmptySide { .. }));
    }

    #[test]
    fn reads_triangles_by_name_and_names_bad_ones() {
        let markers = "[markers]\nA = { vertex = 0 }\nB = { vertex = 1 }\nC = { vertex = 2 }\nD = { vertex = 3 }\n";
        let t = write(
            "tri.toml",
            &format!("triangles = [[\"A\", \"B\", \"C\"], [\"A\", \"C\", \"D\"]]\n{markers}"),
        );
        assert_eq!(
            read_layout(&t).unwrap().triangles,
            Some(vec![[0, 1, 2], [0, 2, 3]])
        );
        let j = write(
            "tri.json",
            r#"{"markers": {"A": {"vertex": 0}, "B": {"vertex": 1}, "D": {"vertex": 3}},
                "triangles": [["D", "B", "A"]]}"#,
        );
        assert_eq!(read_layout(&j).unwrap().triangles, Some(vec![[2, 1, 0]]));
        assert_eq!(
            read_layout(&write("tn.toml", markers)).unwrap().triangles,
            None
        );
        let (_, s) = read_err(
            "u.toml",
            &format!("triangles = [[\"A\", \"B\", \"C\"], [\"A\", \"Z\", \"C\"]]\n{markers}"),
        );
        assert!(s.contains("triangles[1]") && s.contains("\"Z\""), "{s}");
        let (_, s) = read_err(
            "r.toml",
            &format!("triangles = [[\"A\", \"B\", \"A\"]]\n{markers}"),
        );
        assert!(s.contains("triangles[0]") && s.contains("twice"), "{s}");
        let (_, s) = read_err(
            "a.toml",
            &format!("triangles = [[\"A\", \"B\", \"C\"], [\"C\", \"A\", \"B\"]]\n{markers}"),
        );
        assert!(
            s.contains("triangles[1]") && s.contains("repeats triangles[0]"),
            "{s}"
        );
        let (e, _) = read_err(
            "s.toml",
            &format!("triangles = [[\"A\", \"B\"]]\n{markers}"),
        );
        assert!(matches!(e, LayoutError::Parse { .. }));
        let (e, _) = read_err("te.toml", &format!("triangles = []\n{markers}"));
        assert!(matches!(e, LayoutError::TrianglesEmpty { .. }));
    }
}
