//! Marker groups for discontinuity masks, from the optional `groups` table of a layout file.
//!
//! Each entry is one mask: the markers on the upper side of an opening and those on the lower
//! side. Markers in neither list influence both sides.
//!
//! ```toml
//! [groups]
//! mouth = { upper = ["Mouth_Up", "Mouth_UpL1"], lower = ["Mouth_Down", "Chin"] }
//! eyes = { upper = ["Leye_Up", "Reye_Up"], lower = ["Leye_Down", "Reye_Down"] }
//! ```
//!
//! The JSON form is the same object under `"groups"`.

use std::path::{Path, PathBuf};

use serde::Deserialize;
use thiserror::Error;

/// One mask's marker groups, as marker indices into the layout.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MarkerGroups {
    /// The mask's name (`mouth`, `eyes`, …).
    pub name: String,
    /// Markers that may move only the upper side.
    pub upper: Vec<usize>,
    /// Markers that may move only the lower side.
    pub lower: Vec<usize>,
}

/// A problem with a layout's `groups` table; each names the file.
#[derive(Debug, Error)]
pub enum GroupsError {
    /// The file could not be read.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The table is malformed.
    #[error("{}: groups: {message}", path.display())]
    Parse {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// A group names a marker the layout does not have.
    #[error("{}: group \"{group}\" names marker \"{marker}\", which the layout does not have", path.display())]
    UnknownMarker {
        /// The file.
        path: PathBuf,
        /// The group.
        group: String,
        /// The marker.
        marker: String,
    },
    /// A marker on both sides, or twice, within one mask.
    #[error("{}: group \"{group}\" lists marker \"{marker}\" more than once (a marker is on one side)", path.display())]
    Repeated {
        /// The file.
        path: PathBuf,
        /// The group.
        group: String,
        /// The marker.
        marker: String,
    },
    /// A vertex-sides file misses a mask or names one the layout does not have.
    #[error("{}: {message}", path.display())]
    Sides {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// A side with no markers.
    #[error("{}: group \"{group}\" has no {side} markers", path.display())]
    EmptySide {
        /// The file.
        path: PathBuf,
        /// The group.
        group: String,
        /// `upper` or `lower`.
        side: &'static str,
    },
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSides {
    upper: Vec<String>,
    lower: Vec<String>,
}

#[derive(Deserialize)]
struct RawFile {
    #[serde(default)]
    groups: Option<toml::Table>,
}

#[derive(Deserialize)]
struct RawJsonFile {
    #[serde(default)]
    groups: Option<serde_json::Map<String, serde_json::Value>>,
}

/// The text of `path` and whether it is JSON (by extension; TOML otherwise).
pub(crate) fn read_text(path: &Path) -> Result<(String, bool), GroupsError> {
    let text = std::fs::read_to_string(path).map_err(|source| GroupsError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let json = path
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("json"));
    Ok((text, json))
}

/// One mask's sides as glTF vertex sets: (upper, lower).
pub type VertexSets = (Vec<u32>, Vec<u32>);

/// Reads the `groups` table of layout file `path` (TOML or JSON by extension), resolving
/// marker names against `marker_names` (the layout's markers, in order). A file without the
/// table has no masks.
pub fn read_groups(path: &Path, marker_names: &[String]) -> Result<Vec<MarkerGroups>, GroupsError> {
    let (text, json) = read_text(path)?;
    let parse = |message: String| GroupsError::Parse {
        path: path.to_path_buf(),
        message,
    };
    let raw: Vec<(String, RawSides)> = if json {
        let file: RawJsonFile = serde_json::from_str(&text).map_err(|e| parse(e.to_string()))?;
        file.groups
            .unwrap_or_default()
            .into_iter()
            .map(|(k, v)| {
                serde_json::from_value(v)
                    .map(|s| (k.clone(), s))
                    .map_err(|e| parse(format!("\"{k}\": {e}")))
            })
            .collect::<Result<_, _>>()?
    } else {
        let file: RawFile = toml::from_str(&text).map_err(|e| parse(e.message().to_owned()))?;
        file.groups
            .unwrap_or_default()
            .into_iter()
            .map(|(k, v)| {
                v.try_into()
                    .map(|s| (k.clone(), s))
                    .map_err(|e: toml::de::Error| parse(format!("\"{k}\": {}", e.message())))
            })
            .collect::<Result<_, _>>()?
    };
    raw.into_iter()
        .map(|(name, sides)| resolve(path, marker_names, name, sides))
        .collect()
}

fn resolve(
    path: &Path,
    marker_names: &[String],
    name: String,
    sides: RawSides,
) -> Result<MarkerGroups, GroupsError> {
    let mut seen = std::collections::HashSet::new();
    let mut index = |marker: &String| {
        let i = marker_names
            .iter()
            .position(|m| m == marker)
            .ok_or_else(|| GroupsError::UnknownMarker {
                path: path.to_path_buf(),
                group: name.clone(),
                marker: marker.clone(),
            })?;
        if !seen.insert(i) {
            return Err(GroupsError::Repeated {
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
            return Err(GroupsError::EmptySide {
                path: path.to_path_buf(),
                group: name.clone(),
                side,
            });
        }
    }
    Ok(MarkerGroups { name, upper, lower })
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawVertexSides {
    upper: Vec<u32>,
    lower: Vec<u32>,
}

/// Reads a vertex-sides file (TOML or JSON by extension): for each mask in `groups`, the glTF
/// vertices of its upper and of its lower side, in `groups` order.
///
/// ```toml
/// mouth = { upper = [10, 11, 12], lower = [20, 21] }
/// eyes = { upper = [30], lower = [40] }
/// ```
pub fn read_vertex_sides(
    path: &Path,
    groups: &[MarkerGroups],
) -> Result<Vec<VertexSets>, GroupsError> {
    let (text, json) = read_text(path)?;
    let sides_error = |message: String| GroupsError::Sides {
        path: path.to_path_buf(),
        message,
    };
    let mut raw: std::collections::BTreeMap<String, RawVertexSides> = if json {
        serde_json::from_str(&text).map_err(|e| sides_error(e.to_string()))?
    } else {
        toml::from_str(&text).map_err(|e| sides_error(e.message().to_owned()))?
    };
    let out = groups
        .iter()
        .map(|g| {
            raw.remove(&g.name)
                .map(|r| (r.upper, r.lower))
                .ok_or_else(|| sides_error(format!("no vertex sides for mask \"{}\"", g.name)))
        })
        .collect::<Result<Vec<_>, _>>()?;
    if let Some(name) = raw.keys().next() {
        return Err(sides_error(format!(
            "mask \"{name}\" is not in the layout's [groups]"
        )));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(name: &str, text: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("facebake-groups-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    #[test]
    fn reads_toml_and_json_and_names_bad_markers() {
        let names: Vec<String> = ["A", "B", "C", "D"].iter().map(|s| s.to_string()).collect();
        let t = write(
            "g.toml",
            "[markers]\nA = { vertex = 0 }\n[groups]\nmouth = { upper = [\"A\"], lower = [\"C\", \"D\"] }\n",
        );
        let g = read_groups(&t, &names).unwrap();
        assert_eq!(
            g,
            vec![MarkerGroups {
                name: "mouth".into(),
                upper: vec![0],
                lower: vec![2, 3]
            }]
        );
        let j = write(
            "g.json",
            r#"{"markers": {}, "groups": {"eyes": {"upper": ["B"], "lower": ["A"]}}}"#,
        );
        assert_eq!(read_groups(&j, &names).unwrap()[0].upper, vec![1]);
        let none = write("n.toml", "[markers]\nA = { vertex = 0 }\n");
        assert!(read_groups(&none, &names).unwrap().is_empty());
        let bad = write(
            "b.toml",
            "[groups]\nmouth = { upper = [\"Z\"], lower = [\"A\"] }\n",
        );
        let e = read_groups(&bad, &names).unwrap_err().to_string();
        assert!(e.contains("b.toml") && e.contains("\"Z\""), "{e}");
        let twice = write(
            "t.toml",
            "[groups]\nm = { upper = [\"A\"], lower = [\"A\"] }\n",
        );
        assert!(matches!(
            read_groups(&twice, &names),
            Err(GroupsError::Repeated { .. })
        ));
        let sides = write("s.toml", "mouth = { upper = [1, 2], lower = [3] }\n");
        assert_eq!(
            read_vertex_sides(&sides, &g).unwrap(),
            vec![(vec![1, 2], vec![3])]
        );
        let extra = write(
            "x.json",
            r#"{"mouth": {"upper": [1], "lower": [2]}, "nose": {"upper": [], "lower": []}}"#,
        );
        let e = read_vertex_sides(&extra, &g).unwrap_err().to_string();
        assert!(e.contains("x.json") && e.contains("\"nose\""), "{e}");
        let missing = write("m.toml", "");
        let e = read_vertex_sides(&missing, &g).unwrap_err().to_string();
        assert!(e.contains("\"mouth\""), "{e}");
        let empty = write("e.toml", "[groups]\nm = { upper = [], lower = [\"A\"] }\n");
        assert!(matches!(
            read_groups(&empty, &names),
            Err(GroupsError::EmptySide { .. })
        ));
    }
}
