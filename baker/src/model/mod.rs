//! What the baker works on, in memory: the face mesh, the marker layout and its placement on
//! the mesh, and the actor's capture. [`crate::io`] reads and writes them.

mod capture;
pub(crate) mod layout;
mod mesh;

pub use capture::{Capture, ParseUnitsError, Units, FACE_SPAN_M};
pub use layout::{
    place_markers, LayoutError, LayoutMarker, MarkerAnchor, MarkerGroups, MarkerLayout,
    PlacedMarker, Side, VertexSets, DEFAULT_MAX_SNAP_FRACTION,
};
pub use mesh::{bounds, AttributeSidesError, FaceMesh, MorphTarget, HEAD_DIAGONAL_M};
pub(crate) use mesh::{weld_pieces, weld_positions};
