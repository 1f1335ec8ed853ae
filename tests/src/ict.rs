//! ICT-FaceKit's generic head (`fixtures/ict_facekit/`), the second real face, as the tests
//! load it: its skin, JawMoCap's 41 markers placed on it by `facebake place`, and its truth.

use facebake::ground_truth::GroundTruth;
use facebake::model::{FaceMesh, PlacedMarker};
use facebake::openings::seen_topology;
use facebake::surface::evaluate::Benchmark;

use crate::{fixture, jawmocap_neutral};

/// The head's skin mesh.
pub fn head() -> FaceMesh {
    facebake::io::gltf_mesh::load_mesh(&fixture("ict_facekit/ICTFaceKitSkin.glb"), None, None)
        .expect("ICT-FaceKit's head loads")
}

/// JawMoCap's markers as `facebake place` puts them on `mesh`, each asserted on the skin that
/// is seen, none on a socket (a marker on a rim vertex may name a triangle of the seam, with no
/// weight on the bag's corners).
pub fn placed_on_seen_skin(mesh: &FaceMesh) -> Vec<PlacedMarker> {
    let (capture, neutral) = jawmocap_neutral();
    let layout =
        facebake::placement::place(mesh, &capture.marker_names, &neutral, &[]).expect("placed");
    let placed = facebake::model::place_markers(
        &layout,
        mesh,
        facebake::model::DEFAULT_MAX_SNAP_FRACTION * mesh.diagonal(),
    )
    .expect("on the mesh");
    let seen = seen_topology(&mesh.welded_positions, &mesh.welded_triangles);
    for m in &placed {
        let corners = m.surface.vertices.iter().zip(m.surface.barycentric);
        for (&v, _) in corners.filter(|(_, w)| *w > 0.0) {
            let piece = seen.components.vertex_component[mesh.weld[v as usize] as usize];
            assert_eq!(piece, 0, "{} is on piece {piece}", m.name);
        }
    }
    placed
}

/// The head's truth (32 frames) with JawMoCap's markers placed on it.
pub fn placed_scene() -> Benchmark {
    let mesh = head();
    let placed = placed_on_seen_skin(&mesh);
    let truth = GroundTruth::new(mesh, 40, 6).expect("a truth");
    Benchmark::new(truth, &placed, Vec::new(), 0).expect("benchmark")
}
