//! The bundled demo's data and choices: the FaceCap head with its morph-target ground truth, and
//! the JawMoCap capture with its layout on the same head. `facebake demo`, the tests and the
//! benches use these names, so they bake the same rigs.

/// The demo's mesh file, in the fixtures folder.
pub const MESH_FILE: &str = "FaceCapHeadGeneric.glb";
/// The mesh inside it.
pub const MESH_NAME: &str = "head";
/// Markers placed on the head for the ground truth.
pub const MARKERS: usize = 40;
/// Of those, on skin that no morph target moves.
pub const STATIC_MARKERS: usize = 6;
/// Ground-truth frames drawn on the demo's contact sheet, by name.
pub const SHEET_FRAMES: [&str; 6] = [
    "jaw open",
    "open funnel",
    "blink",
    "smile",
    "surprise",
    "blend 0",
];
/// The JawMoCap capture's head markers: forehead and the top of the nose, which no expression
/// moves much.
pub const JAWMOCAP_HEAD_MARKERS: [&str; 4] = ["ForeHead_M", "ForeHead_L", "ForeHead_R", "NoseTop"];
/// The JawMoCap capture, in the fixtures folder.
pub const JAWMOCAP_FILE: &str = "JawMoCap.trc";
/// FaceCap's marker layout for the JawMoCap markers, in the fixtures folder.
pub const JAWMOCAP_LAYOUT: &str = "facecap_jawmocap_layout.toml";
/// Frame rate written to the demo's capture file.
pub const CAPTURE_RATE_HZ: f64 = 30.0;
