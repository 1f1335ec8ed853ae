//! Vertex-sides files: each mask's sides given as glTF vertex sets (`bake --mask-sides`), for
//! the masks a layout's `groups` table names.

use std::path::{Path, PathBuf};

use serde::Deserialize;
use thiserror::Error;

use crate::model::{MarkerGroups, VertexSets};

/// A problem with a vertex-sides file; each names the file.
#[derive(Debug, Error)]
pub enum SidesError {
    /// The file could not be read.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// A vertex-sides file misses a mask or names one the layout does not have.
    #[error("{}: {message}", path.display())]
    Sides {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
}

/// The text of `path` and whether it is JSON (by extension; TOML otherwise).
fn read_text(path: &Path) -> Result<(String, bool), SidesError> {
    let text = std::fs::read_to_string(path).map_err(|source| SidesError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let json = path
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("json"));
    Ok((text, json))
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
) -> Result<Vec<VertexSets>, SidesError> {
    let (text, json) = read_text(path)?;
    let sides_error = |message: String| SidesError::Sides {
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
        let dir = std::env::temp_dir().join(format!("facebake-sides-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    #[test]
    fn reads_sides_per_mask_and_names_missing_and_extra_masks() {
        let g = vec![MarkerGroups {
            name: "mouth".into(),
            upper: vec![0],
            lower: vec![2, 3],
        }];
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
    }
}
