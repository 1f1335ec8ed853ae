//! A marker layout: where each motion-capture marker sits on the face mesh, which markers
//! lie either side of the openings (the masks' groups) and, optionally, planar bones' control
//! triangles; and placing it on a mesh. [`crate::io::layout`] reads and writes the files.

use std::path::PathBuf;

use thiserror::Error;

use crate::mesh::{closest_point, distance, SurfacePoint};
use crate::model::FaceMesh;

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

/// A marker layout: markers in file order, the marker groups of the masks and the control
/// triangles of planar bones.
#[derive(Debug, Clone, PartialEq)]
pub struct MarkerLayout {
    /// The file it was read from (used in error messages).
    pub source: PathBuf,
    /// The markers, in file order.
    pub markers: Vec<LayoutMarker>,
    /// Marker groups either side of the openings, one per mask, in file order.
    pub groups: Vec<MarkerGroups>,
    /// Planar bones' control triangles (marker indices); `None` builds them automatically.
    pub triangles: Option<Vec<[usize; 3]>>,
}

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

/// One mask's sides as glTF vertex sets: (upper, lower).
pub type VertexSets = (Vec<u32>, Vec<u32>);

/// A side of an opening.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Side {
    /// Upper lip / upper eyelid side.
    Upper,
    /// Lower lip / jaw / lower eyelid side.
    Lower,
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
    /// A group names a marker the layout does not have.
    #[error("{}: group \"{group}\" names marker \"{marker}\", which the layout does not have", path.display())]
    GroupMarker {
        /// The file.
        path: PathBuf,
        /// The group.
        group: String,
        /// The marker.
        marker: String,
    },
    /// A marker on both sides, or twice, within one mask.
    #[error("{}: group \"{group}\" lists marker \"{marker}\" more than once (a marker is on one side)", path.display())]
    GroupRepeated {
        /// The file.
        path: PathBuf,
        /// The group.
        group: String,
        /// The marker.
        marker: String,
    },
    /// A side with no markers.
    #[error("{}: group \"{group}\" has no {side} markers", path.display())]
    GroupEmptySide {
        /// The file.
        path: PathBuf,
        /// The group.
        group: String,
        /// `upper` or `lower`.
        side: &'static str,
    },
    /// The triangles list is present but empty.
    #[error("{}: triangles: the list is empty (leave it out to build the control surface automatically)", path.display())]
    TrianglesEmpty {
        /// The file.
        path: PathBuf,
    },
    /// A triangle names a marker the layout does not have.
    #[error("{}: triangles[{index}] {names} names marker \"{marker}\", which the layout does not have", path.display())]
    TriangleMarker {
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
    TriangleRepeated {
        /// The file.
        path: PathBuf,
        /// The triangle's place in the list (0-based).
        index: usize,
        /// The triangle as written, `["A", "B", "C"]`.
        names: String,
        /// What repeats.
        problem: String,
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

/// The checks that need no mesh; errors name `layout.source`.
pub(crate) fn check(layout: &MarkerLayout) -> Result<(), LayoutError> {
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

/// Default largest snap of a `point` marker onto the surface, as a fraction of the mesh's
/// bounding-box diagonal.
pub const DEFAULT_MAX_SNAP_FRACTION: f64 = 0.01;

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
