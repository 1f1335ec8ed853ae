//! Shared helpers for the cross-crate tests: fixture paths and the FaceCap ground-truth rig.

use std::path::PathBuf;

use facebake::bake::{bake, BakeConfig, BakeInput, Baked};
use facebake::ground_truth::GroundTruth;
use facebake::io::gltf_mesh::load_mesh;

/// Path of a file in `fixtures/`.
pub fn fixture(name: &str) -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../fixtures")).join(name)
}

/// Markers on the FaceCap head, as in the README's figures: 40, of which 6 on still skin.
pub const FACECAP_MARKERS: usize = 40;
/// Of [`FACECAP_MARKERS`], how many sit where no morph target moves the skin.
pub const FACECAP_STATIC_MARKERS: usize = 6;

/// The FaceCap ground truth (head mesh, 40 markers, the blend sequence).
pub fn facecap_truth() -> GroundTruth {
    let mesh = load_mesh(&fixture("FaceCapHeadGeneric.glb"), Some("head"), None)
        .expect("FaceCap head loads");
    GroundTruth::new(mesh, FACECAP_MARKERS, FACECAP_STATIC_MARKERS).expect("ground truth builds")
}

/// Bake the ground truth's markers with `config`.
pub fn bake_truth(truth: &GroundTruth, config: &BakeConfig) -> Baked {
    let names = truth.marker_names();
    let rest = truth.marker_rest();
    let stiffness = vec![1.0; names.len()];
    bake(
        &BakeInput {
            vertices: &truth.mesh.positions,
            marker_names: &names,
            marker_rest: &rest,
            stiffness: &stiffness,
            triangles: &truth.mesh.triangles,
            planar_masks: None,
        },
        config,
    )
    .expect("bake succeeds")
}

/// Index of the ground truth's "jaw open" frame, the frame the benches feed their rigs.
pub fn jaw_open_frame(truth: &GroundTruth) -> usize {
    truth
        .frames
        .iter()
        .position(|f| f.name == "jaw open")
        .expect("the FaceCap sequence has a jaw-open frame")
}

/// The FaceCap truth and its default bake, built once per test binary.
pub fn facecap_default() -> &'static (GroundTruth, Baked) {
    static CELL: std::sync::OnceLock<(GroundTruth, Baked)> = std::sync::OnceLock::new();
    CELL.get_or_init(|| {
        let truth = facecap_truth();
        let baked = bake_truth(&truth, &BakeConfig::default());
        (truth, baked)
    })
}

/// The FaceCap truth baked in the weights form (IMQ, K = 8), built once per test binary.
pub fn facecap_weights() -> &'static Baked {
    static CELL: std::sync::OnceLock<Baked> = std::sync::OnceLock::new();
    CELL.get_or_init(|| bake_truth(&facecap_default().0, &weights_config()))
}

/// The weights-form configuration the tests use: paper 000's inverse multiquadric, K = 8.
pub fn weights_config() -> BakeConfig {
    BakeConfig {
        form: facebake::bake::RigForm::Weights,
        kernel: facebake::rbf::KernelKind::InverseMultiquadric,
        width_factor: 2.0,
        ..BakeConfig::default()
    }
}

/// The FaceCap truth baked as planar bones (K = 8), built once per test binary.
pub fn facecap_planar() -> &'static Baked {
    static CELL: std::sync::OnceLock<Baked> = std::sync::OnceLock::new();
    CELL.get_or_init(|| bake_truth(&facecap_default().0, &planar_config(8)))
}

/// Both FaceCap rigs: (name, blob).
pub fn facecap_blobs() -> [(&'static str, &'static [u8]); 2] {
    [
        ("coefficients", &facecap_default().1.blob),
        ("weights", &facecap_weights().blob),
    ]
}

/// Reseal a blob whose payload was edited, so the structural validation (not the CRC) is what
/// a test exercises.
pub fn reseal(blob: &mut [u8]) {
    let header_len = facebake_runtime::format::records::HEADER_LEN;
    let crc = facebake_runtime::checksum::crc32(&blob[header_len..]);
    blob[16..20].copy_from_slice(&crc.to_le_bytes());
}

/// The JawMoCap capture on the FaceCap head: everything the capture tests and benches need.
pub struct JawMoCapRig {
    /// The FaceCap head.
    pub mesh: facebake::io::gltf_mesh::FaceMesh,
    /// The capture (JawMoCap.trc, centimetres).
    pub capture: facebake::io::capture::Capture,
    /// The capture's frames in rig marker order, metres.
    pub frames: Vec<Vec<Option<[f64; 3]>>>,
    /// The deformation bake (default configuration, the layout's 41 markers).
    pub baked: Baked,
    /// The capture stages and their f64 reference.
    pub stages: facebake::stages::BakedStages,
    /// The blob with the stages.
    pub blob: Vec<u8>,
}

/// Bake FaceCap with `fixtures/facecap_jawmocap_layout.toml` and the JawMoCap capture's stages
/// (neutral frame 0, the baker's own choice of head markers).
pub fn jawmocap_rig(stages: &facebake::stages::StagesConfig) -> JawMoCapRig {
    jawmocap_rig_with(&BakeConfig::default(), stages)
}

/// [`jawmocap_rig`] with the deformation baked by `bake` (any form, planar bones included).
pub fn jawmocap_rig_with(
    bake: &BakeConfig,
    stages: &facebake::stages::StagesConfig,
) -> JawMoCapRig {
    use facebake::cli::bake::bake_layout;
    let mesh = load_mesh(&fixture("FaceCapHeadGeneric.glb"), Some("head"), None)
        .expect("FaceCap head loads");
    let layout = facebake::io::layout::read_layout(&fixture("facecap_jawmocap_layout.toml"))
        .expect("layout reads");
    let capture =
        facebake::io::capture::read_capture(&fixture("JawMoCap.trc")).expect("capture reads");
    let (baked, placed) = bake_layout(&mesh, &layout, bake, None, None).expect("FaceCap bakes");
    let names: Vec<String> = placed.iter().map(|m| m.name.clone()).collect();
    let character: Vec<[f64; 3]> = placed.iter().map(|m| m.position).collect();
    let rig = facebake_runtime::Rig::from_bytes(&baked.blob).expect("rig loads");
    let space = rig.space();
    let stages = facebake::stages::bake_stages(&capture, &names, &character, &space, stages)
        .expect("stages bake");
    let blob = facebake::blob::with_stages(&baked.blob, &stages.bytes).expect("stages attach");
    let columns: Vec<usize> = names
        .iter()
        .map(|n| capture.marker_index(n).expect("capture has the marker"))
        .collect();
    let frames = capture
        .in_metres()
        .frames
        .iter()
        .map(|f| columns.iter().map(|&c| f[c]).collect())
        .collect();
    JawMoCapRig {
        mesh,
        capture,
        frames,
        baked,
        stages,
        blob,
    }
}
/// The planar-bones configuration the tests use at `k` (default bone radius).
pub fn planar_config(k: usize) -> BakeConfig {
    BakeConfig {
        form: facebake::bake::RigForm::Planar,
        k,
        ..BakeConfig::default()
    }
}

/// Per glTF vertex of `truth`'s mesh: a skin vertex within 15 mm of the lip opening (the skin's
/// second-longest boundary loop), where the methods' p99 and max errors sit.
pub fn lip_vertices(truth: &GroundTruth) -> Vec<bool> {
    let mesh = &truth.mesh;
    let topo = mesh.welded_topology();
    let loops = topo.loops_of(0);
    let lip_loop = &loops[1].vertices;
    mesh.positions
        .iter()
        .zip(&truth.skin)
        .map(|(p, &skin)| {
            skin && lip_loop
                .iter()
                .any(|&w| facebake::mesh::distance(p, &mesh.welded_positions[w as usize]) < 0.015)
        })
        .collect()
}

/// The FaceCap ground truth with the bundled JawMoCap layout (41 markers, lip and eyelid
/// groups) and the truth's 6 static markers as anchors: the surface-aware methods' proof.
///
/// The layout's lip markers sit 13 mm above and 22 mm below the mouth line (Mouth_Down on the
/// chin crease, where `jawOpen` moves it half as far as the lower lip), so no RBF can move the
/// lip rims right; the proof moves them onto the lips ([`LIP_MARKER_OFFSET`]).
pub fn facecap_scene() -> facebake::surface::evaluate::Scene {
    facecap_scene_with(LIP_MARKER_OFFSET)
}

/// How far from the mouth's opening line the proof puts the lip markers: 5 mm, on the lips.
pub const LIP_MARKER_OFFSET: f64 = 0.005;

/// [`facecap_scene`] with the six lip markers moved `lip_offset` (metres) from the mouth's
/// opening line (y = −43 mm on FaceCap) onto the lips, keeping their x; 0 keeps the layout.
pub fn facecap_scene_with(lip_offset: f64) -> facebake::surface::evaluate::Scene {
    let truth = facecap_truth();
    let path = fixture("facecap_jawmocap_layout.toml");
    let mut layout = facebake::io::layout::read_layout(&path).expect("layout reads");
    if lip_offset > 0.0 {
        use facebake::io::layout::MarkerAnchor;
        for m in &mut layout.markers {
            let sign = match m.name.as_str() {
                "Mouth_Up" | "Mouth_UpL1" | "Mouth_UpR1" => 1.0,
                "Mouth_Down" | "Mouth_DownL" | "Mouth_DownR" => -1.0,
                _ => continue,
            };
            if let MarkerAnchor::Point(p) = m.anchor {
                m.anchor = MarkerAnchor::Point([p[0], -0.043 + sign * lip_offset, p[2] + 0.01]);
            }
        }
    }
    let placed = facebake::io::layout::place_markers(&layout, &truth.mesh, 0.02)
        .expect("layout places on the FaceCap head");
    let names: Vec<String> = layout.markers.iter().map(|m| m.name.clone()).collect();
    let groups = facebake::io::marker_groups::read_groups(&path, &names).expect("groups read");
    facebake::surface::evaluate::Scene::new(truth, &placed, groups, FACECAP_STATIC_MARKERS)
        .expect("scene builds")
}

/// Bake the scene's markers with a surface-aware configuration.
pub fn bake_scene(
    scene: &facebake::surface::evaluate::Scene,
    config: &facebake::surface::SurfaceConfig,
) -> facebake::surface::SurfaceBaked {
    facebake::surface::bake_surface(
        &facebake::surface::SurfaceInput {
            mesh: &scene.truth.mesh,
            markers: &scene.markers,
            groups: &scene.groups,
            sides: &facebake::surface::SideRule::Auto,
            head: &[],
        },
        config,
    )
    .expect("surface bake succeeds")
}

/// Bake planar bones (K = `k`, automatic control surface) on the scene's markers, with the
/// layout's lip and eyelid masks (automatic sides, the surface-aware defaults) when `masked`.
pub fn bake_scene_planar(
    scene: &facebake::surface::evaluate::Scene,
    k: usize,
    masked: bool,
) -> Baked {
    let allowance = masked.then(|| {
        facebake::surface::planar_allowance(
            &facebake::surface::SurfaceInput {
                mesh: &scene.truth.mesh,
                markers: &scene.markers,
                groups: &scene.groups,
                sides: &facebake::surface::SideRule::Auto,
                head: &[],
            },
            &facebake::surface::SurfaceConfig::default(),
        )
        .expect("planar masks build")
    });
    let names: Vec<String> = scene.markers.iter().map(|m| m.name.clone()).collect();
    let rest: Vec<[f64; 3]> = scene.markers.iter().map(|m| m.rest).collect();
    let stiffness: Vec<f64> = scene.markers.iter().map(|m| m.stiffness).collect();
    bake(
        &BakeInput {
            vertices: &scene.truth.mesh.positions,
            marker_names: &names,
            marker_rest: &rest,
            stiffness: &stiffness,
            triangles: &scene.truth.mesh.triangles,
            planar_masks: allowance.as_ref(),
        },
        &planar_config(k),
    )
    .expect("planar bake succeeds")
}
