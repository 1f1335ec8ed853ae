//! Control triangles of planar bones, from the optional `triangles` list of a layout file.
//!
//! Each entry is one control triangle, by marker names:
//!
//! ```toml
//! triangles = [["Nose_Tip", "Mouth_UpL1", "Mouth_Up"], ["Mouth_Up", "Mouth_UpR1", "Nose_Tip"]]
//! ```
//!
//! The JSON form is the same list under `"triangles"`. The key must come before the layout's
//! tables in TOML (a TOML key after `[markers]` belongs to that table). A layout without the
//! list leaves the planar bake to build the control surface automatically.

use std::path::{Path, PathBuf};

use serde::Deserialize;
use thiserror::Error;

use super::marker_groups::read_text;
use crate::planar::{triangulate::smallest_angle_degrees, DEGENERATE_ANGLE_DEGREES};

/// A problem with a layout's `triangles` list; each names the file and the triangle.
#[derive(Debug, Error)]
pub enum TrianglesError {
    /// The file could not be read.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The list is malformed.
    #[error("{}: triangles: {message}", path.display())]
    Parse {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// The list is present but empty.
    #[error("{}: triangles: the list is empty (leave it out to build the control surface automatically)", path.display())]
    Empty {
        /// The file.
        path: PathBuf,
    },
    /// A triangle names a marker the layout does not have.
    #[error("{}: triangles[{index}] {names} names marker \"{marker}\", which the layout does not have", path.display())]
    UnknownMarker {
        /// The file.
        path: PathBuf,
        /// The triangle's place in the list (0-based).
        index: usize,
        /// The triangle as written, `["A", "B", "C"]`.
        names: String,
        /// The marker.
        marker: String,
    },
    /// A triangle names a marker twice, or repeats an earlier triangle.
    #[error("{}: triangles[{index}] {names} {problem}", path.display())]
    Repeated {
        /// The file.
        path: PathBuf,
        /// The triangle's place in the list (0-based).
        index: usize,
        /// The triangle as written, `["A", "B", "C"]`.
        names: String,
        /// What repeats.
        problem: String,
    },
    /// A triangle's markers are (nearly) collinear where they sit on the mesh.
    #[error("{}: triangles[{index}] {names} is degenerate on the mesh: its smallest angle is {angle:.3}° (at least {DEGENERATE_ANGLE_DEGREES}° needed)", path.display())]
    Degenerate {
        /// The file.
        path: PathBuf,
        /// The triangle's place in the list (0-based).
        index: usize,
        /// The triangle as written, `["A", "B", "C"]`.
        names: String,
        /// Its smallest angle, degrees.
        angle: f64,
    },
}

#[derive(Deserialize)]
struct RawFile {
    #[serde(default)]
    triangles: Option<Vec<[String; 3]>>,
}

/// Reads the `triangles` list of layout file `path` (TOML or JSON by extension), resolving
/// marker names against `marker_names` (the layout's markers, in order): `None` when the file
/// has no list. Checks names and repeats; [`check_shapes`] checks them on the mesh.
pub fn read_triangles(
    path: &Path,
    marker_names: &[String],
) -> Result<Option<Vec<[usize; 3]>>, TrianglesError> {
    let (text, json) = read_text(path).map_err(|e| match e {
        super::marker_groups::GroupsError::Io { path, source } => {
            TrianglesError::Io { path, source }
        }
        other => TrianglesError::Parse {
            path: path.to_path_buf(),
            message: other.to_string(),
        },
    })?;
    let parse = |message: String| TrianglesError::Parse {
        path: path.to_path_buf(),
        message,
    };
    let raw: RawFile = if json {
        serde_json::from_str(&text).map_err(|e| parse(e.to_string()))?
    } else {
        toml::from_str(&text).map_err(|e| parse(e.message().trim().to_owned()))?
    };
    let Some(raw) = raw.triangles else {
        return Ok(None);
    };
    if raw.is_empty() {
        return Err(TrianglesError::Empty {
            path: path.to_path_buf(),
        });
    }
    let mut seen = std::collections::HashMap::new();
    let mut out = Vec::with_capacity(raw.len());
    for (index, names) in raw.into_iter().enumerate() {
        let mut tri = [0usize; 3];
        for (slot, marker) in tri.iter_mut().zip(&names) {
            *slot = marker_names
                .iter()
                .position(|m| m == marker)
                .ok_or_else(|| TrianglesError::UnknownMarker {
                    path: path.to_path_buf(),
                    index,
                    names: format!("{names:?}"),
                    marker: marker.clone(),
                })?;
        }
        let repeated = |problem: String| TrianglesError::Repeated {
            path: path.to_path_buf(),
            index,
            names: format!("{names:?}"),
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
    Ok(Some(out))
}

/// Checks that no triangle of `triangles` (read from layout `path` with [`read_triangles`]) is
/// degenerate with its markers at `positions` (the placed markers, layout order).
pub fn check_shapes(
    path: &Path,
    triangles: &[[usize; 3]],
    marker_names: &[String],
    positions: &[[f64; 3]],
) -> Result<(), TrianglesError> {
    for (index, t) in triangles.iter().enumerate() {
        let angle = smallest_angle_degrees(t.map(|m| positions[m]));
        if angle.is_nan() || angle < DEGENERATE_ANGLE_DEGREES {
            return Err(TrianglesError::Degenerate {
                path: path.to_path_buf(),
                index,
                names: format!("{:?}", t.map(|m| &marker_names[m])),
                angle,
            });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(name: &str, text: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("facebake-triangles-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    #[test]
    fn reads_triangles_by_name_and_names_bad_ones() {
        let names: Vec<String> = ["A", "B", "C", "D"].iter().map(|s| s.to_string()).collect();
        let t = write(
            "t.toml",
            "triangles = [[\"A\", \"B\", \"C\"], [\"A\", \"C\", \"D\"]]\n[markers]\nA = { vertex = 0 }\n",
        );
        assert_eq!(
            read_triangles(&t, &names).unwrap(),
            Some(vec![[0, 1, 2], [0, 2, 3]])
        );
        let j = write(
            "t.json",
            r#"{"markers": {}, "triangles": [["D", "B", "A"]]}"#,
        );
        assert_eq!(read_triangles(&j, &names).unwrap(), Some(vec![[3, 1, 0]]));
        let none = write("n.toml", "[markers]\nA = { vertex = 0 }\n");
        assert_eq!(read_triangles(&none, &names).unwrap(), None);
        let unknown = write(
            "u.toml",
            "triangles = [[\"A\", \"B\", \"C\"], [\"A\", \"Z\", \"C\"]]\n",
        );
        let e = read_triangles(&unknown, &names).unwrap_err().to_string();
        assert!(
            e.contains("u.toml") && e.contains("triangles[1]") && e.contains("\"Z\""),
            "{e}"
        );
        let twice = write("r.toml", "triangles = [[\"A\", \"B\", \"A\"]]\n");
        let e = read_triangles(&twice, &names).unwrap_err().to_string();
        assert!(e.contains("triangles[0]") && e.contains("twice"), "{e}");
        let again = write(
            "a.toml",
            "triangles = [[\"A\", \"B\", \"C\"], [\"C\", \"A\", \"B\"]]\n",
        );
        let e = read_triangles(&again, &names).unwrap_err().to_string();
        assert!(
            e.contains("triangles[1]") && e.contains("repeats triangles[0]"),
            "{e}"
        );
        let short = write("s.toml", "triangles = [[\"A\", \"B\"]]\n");
        assert!(matches!(
            read_triangles(&short, &names),
            Err(TrianglesError::Parse { .. })
        ));
        let empty = write("e.toml", "triangles = []\n");
        assert!(matches!(
            read_triangles(&empty, &names),
            Err(TrianglesError::Empty { .. })
        ));
        let flat = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [2.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
        ];
        assert!(check_shapes(&t, &[[0, 1, 3]], &names, &flat).is_ok());
        let e = check_shapes(&t, &[[0, 1, 3], [0, 1, 2]], &names, &flat)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("t.toml") && e.contains("triangles[1]") && e.contains("degenerate"),
            "{e}"
        );
    }
}
