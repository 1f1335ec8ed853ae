//! End-to-end tests of the `facebake` command: the built binary run as a user would.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::OnceLock;

use facebake::io::capture::write_csv;
use facebake::io::gltf_mesh::load_mesh;
use facebake::io::npy::read_npy_f32;
use facebake::model::{Capture, Units};
use facebake_runtime::Rig;
use serde_json::Value;

const VERTICES: usize = 2694;

fn fixture(name: &str) -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../fixtures")).join(name)
}

fn mesh_path() -> PathBuf {
    fixture("FaceCapHeadGeneric.glb")
}

/// A fresh, empty directory path for one test.
fn fresh_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("facebake-cli-test-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir
}

/// A fresh directory that is removed when the test ends.
struct TempDir(PathBuf);

impl std::ops::Deref for TempDir {
    type Target = Path;
    fn deref(&self) -> &Path {
        &self.0
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn temp_dir(name: &str) -> TempDir {
    TempDir(fresh_dir(name))
}

/// Run `facebake` with `args`.
fn facebake(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_facebake"))
        .args(args)
        .output()
        .expect("the binary runs")
}

/// `facebake bake` of `layout` on the FaceCap head (or on `mesh`), writing `rig`.
fn bake(mesh: &Path, layout: &Path, rig: &Path, extra: &[&str]) -> Output {
    let mut args = vec![
        "bake",
        "--mesh",
        s(mesh),
        "--layout",
        s(layout),
        "-o",
        s(rig),
    ];
    args.extend_from_slice(extra);
    facebake(&args)
}

/// The blob `bake` writes to `rig` for the FaceCap head and `layout` with `extra` options,
/// failing the test if the bake does.
fn baked_rig(rig: &Path, layout: &Path, extra: &[&str]) -> Vec<u8> {
    let out = bake(&mesh_path(), layout, rig, extra);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    std::fs::read(rig).unwrap()
}

fn s(p: &Path) -> &str {
    p.to_str().expect("UTF-8 temp paths")
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// Parse stdout as JSON, after checking the run succeeded.
fn json_ok(out: &Output) -> Value {
    assert_eq!(out.status.code(), Some(0), "stderr: {}", stderr(out));
    serde_json::from_slice(&out.stdout).expect("stdout is JSON")
}

/// The demo, run once for all tests (with one timing repetition, to keep it quick).
fn demo() -> &'static (PathBuf, Value) {
    static DEMO: OnceLock<(PathBuf, Value)> = OnceLock::new();
    DEMO.get_or_init(|| {
        // Shared by every test and left for inspection (statics are never dropped).
        let dir = fresh_dir("demo");
        let out = facebake(&["demo", "--out", s(&dir), "--repetitions", "1", "--json"]);
        let summary = json_ok(&out);
        (dir, summary)
    })
}

#[test]
fn demo_writes_its_files() {
    let (dir, summary) = demo();
    let frames = summary["frames"].as_u64().unwrap() as usize;
    assert!(frames >= 6, "{summary}");
    assert_eq!(summary["vertices"], VERTICES);
    assert_eq!(summary["runtime_vs_f64_passed"], true);
    for name in [
        "facecap_markers.toml",
        "facecap.fbk",
        "facecap_frames.npy",
        "facecap_capture.csv",
        "facecap_demo.glb",
        "facecap_truth.npy",
        "facecap_sheet.png",
        "facecap_mouth_sheet.png",
        "facecap_eyes_sheet.png",
        "facecap_markers.png",
        "jawmocap_sheet.png",
        "jawmocap_mouth_sheet.png",
        "jawmocap_markers.png",
    ] {
        assert!(dir.join(name).is_file(), "{name} missing");
    }
    let npy = std::fs::read(dir.join("facecap_frames.npy")).unwrap();
    let header = String::from_utf8_lossy(&npy[10..128]);
    assert!(
        header.contains(&format!("'shape': ({frames}, {VERTICES}, 3)")),
        "{header}"
    );
    let (shape, values) = read_npy_f32(&dir.join("facecap_frames.npy")).unwrap();
    assert_eq!(shape, [frames, VERTICES, 3]);
    assert!(values.iter().all(|x| x.is_finite()));
    let (doc, _, _) = gltf::import(dir.join("facecap_demo.glb")).expect("the GLB loads");
    let mesh = doc.meshes().next().expect("a mesh");
    let primitive = mesh.primitives().next().expect("a primitive");
    let glb = &summary["glb"];
    assert_eq!(
        primitive.morph_targets().count() as u64,
        glb["targets"].as_u64().unwrap()
    );
    // Every frame within the bound, eyes and teeth kept beside the head.
    assert_eq!(glb["frames"], frames);
    assert_eq!(glb["bound_met"], true, "{glb}");
    assert!(glb["p99_error_mm"].as_f64().unwrap() <= 0.1, "{glb}");
    assert_eq!(doc.meshes().count(), 4);
    assert_eq!(doc.animations().count(), 1);
    // The rig loads and the text output names every file.
    let blob = std::fs::read(dir.join("facecap.fbk")).unwrap();
    assert_eq!(Rig::from_bytes(&blob).unwrap().vertex_count(), VERTICES);
    assert_eq!(summary["files"].as_array().unwrap().len(), 10);
    // The structure metrics of the ground truth: the lips part, still 7.4 mm short of the truth
    // at worst (jaw open; 12.5 before the corner reshaping), the eyelids within 1.5 mm.
    let take = &summary["structure"]["take"];
    assert_eq!(take["frames"], frames);
    assert!(
        (5.0..10.0).contains(&take["lips_mm"][0].as_f64().unwrap()),
        "{take}"
    );
    assert!(take["eyelids_mm"][0].as_f64().unwrap() <= 1.5, "{take}");
}

/// Width and height of a PNG file.
fn png_size(path: &Path) -> (u32, u32) {
    let file = std::fs::File::open(path).expect("the PNG opens");
    let reader = png::Decoder::new(std::io::BufReader::new(file))
        .read_info()
        .expect("a PNG");
    let info = reader.info();
    (info.width, info.height)
}

#[test]
fn render_draws_the_demo_frames_and_measures_them() {
    let (demo_dir, _) = demo();
    let dir = temp_dir("render");
    let (sheet, markers) = (dir.join("sheet.png"), dir.join("markers.png"));
    let out = facebake(&[
        "render",
        s(&demo_dir.join("facecap_frames.npy")),
        "--mesh",
        s(&mesh_path()),
        "--truth",
        s(&demo_dir.join("facecap_truth.npy")),
        "--rig",
        s(&demo_dir.join("facecap.fbk")),
        "--frames",
        "0,2",
        "--panel",
        "128",
        "-o",
        s(&sheet),
        "--marker-sheet",
        s(&markers),
        "--json",
    ]);
    let summary = json_ok(&out);
    // Truth, result and error, front and side: six panels and the colour bar; two rows.
    let (w, h) = png_size(&sheet);
    assert_eq!(w, 6 * 128 + 120);
    assert!(h > 2 * 128 && h < 2 * 128 + 120, "{h}");
    assert!(png_size(&markers).0 > 2 * 256);
    assert_eq!(summary["frames"], serde_json::json!([0, 2]));
    let take = &summary["structure"]["take"];
    assert_eq!(take["against_truth"], true);
    // The demo's default bake (static anchoring, following the inner corners of the eyes and
    // the forehead's centre) on the bundled 41-marker layout: 0.29 mm (0.34 following the
    // skull markers and the inner corners, 0.59 the forehead markers alone, whose mean the
    // frown moves 0.59 mm), where the Euclidean RBF moved the crown 26.5 mm; the same figure as
    // `tests/tests/structure.rs`.
    let drift = take["static_drift_mm"][0].as_f64().unwrap();
    assert!((drift - 0.29).abs() < 0.01, "{take}");
    // The colour scale tops at the drawn frames' 95th-percentile error, rounded up; `--scale-mm`
    // sets it, and the skin's errors then fill the error panels' top colour.
    let own = summary["scale_mm"].as_f64().unwrap();
    assert!(own >= 1.0, "{}", summary["scale_mm"]);
    let (frames, truth) = (
        demo_dir.join("facecap_frames.npy"),
        demo_dir.join("facecap_truth.npy"),
    );
    let (mesh, fixed) = (mesh_path(), dir.join("fixed.png"));
    let render_at = |scale: &str| {
        facebake(&[
            "render",
            s(&frames),
            "--mesh",
            s(&mesh),
            "--truth",
            s(&truth),
            "--frames",
            "0,2",
            "--panel",
            "128",
            "--scale-mm",
            scale,
            "-o",
            s(&fixed),
            "--json",
        ])
    };
    let small = json_ok(&render_at("0.5"));
    assert_eq!(
        (&small["scale_mm"], &small["clipped"]),
        (&0.5.into(), &true.into())
    );
    // Yellow, the scale's top, shaded or not.
    let in_top_colour = |path: &Path| {
        let yellow = |p: &&[u8; 3]| p[0] > 180 && p[1] > 180 && p[2] < 120;
        png_pixels(path).0.iter().filter(yellow).count()
    };
    let (at_own, at_small) = (in_top_colour(&sheet), in_top_colour(&fixed));
    assert!(at_small > 4 * at_own, "{at_small} against {at_own}");
    let out = render_at("0");
    assert_eq!(out.status.code(), Some(2));
    assert!(
        stderr(&out).contains("not a positive number of millimetres"),
        "{}",
        stderr(&out)
    );
    // Without a truth: result and displacement only, four square panels and the colour bar.
    assert_eq!(draw_mouth_open(&sheet, "head"), 4 * 128 + 120);
    // A frame the file does not have is bad input, named.
    let out = facebake(&[
        "render",
        s(&demo_dir.join("facecap_frames.npy")),
        "--mesh",
        s(&mesh_path()),
        "--frames",
        "99",
        "-o",
        s(&sheet),
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        stderr(&out).contains("--frames 99: the take has"),
        "{}",
        stderr(&out)
    );
}

/// Pixels of a PNG file (RGB), row by row, and its width.
fn png_pixels(path: &Path) -> (Vec<[u8; 3]>, usize) {
    let file = std::fs::File::open(path).expect("the PNG opens");
    let mut reader = png::Decoder::new(std::io::BufReader::new(file))
        .read_info()
        .expect("a PNG");
    let mut data = vec![0; reader.output_buffer_size().expect("a size")];
    let info = reader.next_frame(&mut data).expect("a frame");
    assert_eq!(info.color_type, png::ColorType::Rgb);
    let pixels = data[..info.buffer_size()]
        .chunks_exact(3)
        .map(|c| [c[0], c[1], c[2]])
        .collect();
    (pixels, info.width as usize)
}

/// Draw the demo's JawMoCap frame 388 (the mouth open, no truth) in 128-pixel panels framing
/// `focus` into `sheet`: result and displacement, front and side. Returns the sheet's width.
fn draw_mouth_open(sheet: &Path, focus: &str) -> u32 {
    let (demo_dir, _) = demo();
    let out = facebake(&[
        "render",
        s(&demo_dir.join("jawmocap_frames.npy")),
        "--mesh",
        s(&mesh_path()),
        "--frames",
        "388",
        "--panel",
        "128",
        "--focus",
        focus,
        "-o",
        s(sheet),
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    png_size(sheet).0
}

/// `render --focus mouth` frames the lips wherever the frames take them: in the mouth-open frame
/// the face fills the close-up's result panel, where the whole head's leaves the paper round
/// it; `--focus eyes` frames both eyes in panels wider than tall; a close-up of an opening the mesh does not have is bad input, named.
#[test]
fn render_frames_the_mouth_close_up() {
    let dir = temp_dir("render_focus");
    let paper_in_first_panel = |focus: &str| {
        let sheet = dir.join(format!("{focus}.png"));
        let width = draw_mouth_open(&sheet, focus);
        // Four panels (result and displacement, front and side) and the colour bar: square
        // for the whole head, as wide as a close-up's box needs, twice as wide as tall at
        // most; both eyes' front panels are the widest.
        let squares = 4 * 128 + 120;
        match focus {
            "head" => assert_eq!(width, squares),
            "eyes" => assert!(
                width > squares + 2 * 64 && width <= squares + 4 * 128,
                "{width}"
            ),
            _ => assert!((squares..squares + 2 * 64).contains(&width), "{width}"),
        }
        // The result's front panel: the first 128 columns under the title and label strips.
        let (pixels, width) = png_pixels(&sheet);
        let rows = pixels.len() / width;
        let panel = (rows - 128 - 6..rows - 6).flat_map(|y| (1..127).map(move |x| (x, y)));
        let paper = panel.filter(|&(x, y)| pixels[y * width + x] == [236, 236, 232]);
        paper.count() as f64 / (126.0 * 128.0)
    };
    let (head, mouth) = (paper_in_first_panel("head"), paper_in_first_panel("mouth"));
    assert!(
        head > 0.3 && mouth < 0.02,
        "paper: head {head:.3}, mouth {mouth:.3}"
    );
    paper_in_first_panel("eyes");
    // The canonical face has no mouth opening to frame.
    let disk = fixture("mediapipe_canonical_face_model.glb");
    let mesh = load_mesh(&disk, None, None).expect("loads");
    let npy = dir.join("disk.npy");
    let flat: Vec<f32> = mesh.positions.iter().flatten().map(|&x| x as f32).collect();
    let shape = [1, mesh.positions.len(), 3];
    facebake::io::npy::write_npy_f32(&npy, &shape, &flat).expect("writes");
    let out = facebake(&[
        "render",
        s(&npy),
        "--mesh",
        s(&disk),
        "--focus",
        "mouth",
        "-o",
        s(&dir.join("disk.png")),
    ]);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    let err = stderr(&out);
    assert!(
        err.contains("mediapipe_canonical_face_model.glb") && err.contains("--focus"),
        "{err}"
    );
}

#[test]
fn bake_inspect_verify_round_trip() {
    let (demo_dir, _) = demo();
    let dir = temp_dir("roundtrip");
    let rig = dir.join("rig.fbk");
    let layout = demo_dir.join("facecap_markers.toml");
    let baked = json_ok(&bake(
        &mesh_path(),
        &layout,
        &rig,
        &["--mesh-name", "head", "--json"],
    ));
    assert_eq!(baked["markers"], 41);
    assert_eq!(baked["report"]["k"], 8);
    // The demo bakes its layout with the default configuration: the same blob.
    assert_eq!(
        std::fs::read(&rig).unwrap(),
        std::fs::read(demo_dir.join("facecap.fbk")).unwrap()
    );
    // The lips curve through their markers unless told not to; the report says over how many
    // vertices.
    let curved = baked["report"]["surface"]["lip_curve_vertices"].as_u64();
    assert!(curved.is_some_and(|n| n > 20), "{curved:?}");
    let straight_rig = dir.join("straight.fbk");
    let straight = json_ok(&bake(
        &mesh_path(),
        &layout,
        &straight_rig,
        &["--mesh-name", "head", "--no-lip-curve", "--json"],
    ));
    assert_eq!(straight["report"]["surface"]["lip_curve_vertices"], 0);
    assert_ne!(
        std::fs::read(&straight_rig).unwrap(),
        std::fs::read(&rig).unwrap()
    );

    let info = json_ok(&facebake(&["inspect", s(&rig), "--json"]));
    assert_eq!(info["vertices"], VERTICES);
    assert_eq!(info["markers"], 41);
    assert_eq!(info["k"], 8);
    assert_eq!(info["marker_names"][0], "ForeHead_M");
    assert_eq!(info["position_format"], "Q8.24");
    // The linear form stores influences in pairs of two weights and one index: 6 bytes a pair.
    assert_eq!(info["bytes_per_influence"], 3.0);
    // The default rig's derived markers: the mouth's openings along the face's vertical, and
    // the mean of the three head markers the anchored skin follows.
    let derived: Vec<&str> = info["derived"]
        .as_array()
        .expect("derived markers")
        .iter()
        .filter_map(|d| d.as_str())
        .collect();
    assert!(
        derived
            .iter()
            .any(|d| d.starts_with("Mouth_") && d.contains(" along [")),
        "{derived:?}"
    );
    assert_eq!(
        derived.last(),
        Some(&"mean of ForeHead_M, Leye_Inside, Reye_Inside"),
        "{derived:?}"
    );
    assert_eq!(info["blob_bytes"], baked["report"]["sizes"]["total"]);
    // FaceCap's 5032 triangles, each once in the normals plan: 12 bytes each and 24 a vertex.
    assert_eq!(info["normals_plan_triangles"], 5032);
    assert_eq!(
        info["normals_planned_scratch_bytes"],
        12 * 5032 + 24 * VERTICES
    );
    let text = facebake(&["inspect", s(&rig)]);
    assert_eq!(text.status.code(), Some(0));
    let text = String::from_utf8_lossy(&text.stdout);
    assert!(
        text.contains("Q8.24")
            && text.contains("multiply-adds")
            && text.contains("Rig::normals_planned"),
        "{text}"
    );

    let verified = json_ok(&facebake(&[
        "verify",
        s(&rig),
        "--mesh",
        s(&mesh_path()),
        "--mesh-name",
        "head",
        "--json",
    ]));
    assert_eq!(verified["passed"], true);
    assert_eq!(verified["sequence"], "ground truth");
    assert!(verified["max_error_fraction"].as_f64().unwrap() <= 2e-5);
    assert!(verified["ground_truth"]["mean_mm"].as_f64().unwrap() > 0.0);
}

#[test]
fn play_reproduces_the_runtime() {
    let (demo_dir, _) = demo();
    let dir = temp_dir("play");
    let rig_path = demo_dir.join("facecap.fbk");
    // The demo's capture of the ground-truth markers, rewritten in millimetres and with the
    // columns reversed, so units and marker order both have to be handled.
    let demo_capture =
        facebake::io::capture::read_capture(&demo_dir.join("facecap_capture.csv")).unwrap();
    let frames: Vec<Vec<[f64; 3]>> = demo_capture
        .frames
        .iter()
        .map(|f| f.iter().map(|p| p.expect("complete")).collect())
        .collect();
    let csv = dir.join("capture.csv");
    let mut names = demo_capture.marker_names.clone();
    names.reverse();
    write_csv(
        &csv,
        &Capture {
            source: csv.clone(),
            rate_hz: 60.0,
            units: Units::Millimetres,
            marker_names: names,
            frames: frames
                .iter()
                .map(|m| {
                    m.iter()
                        .rev()
                        .map(|p| Some(p.map(|x| x * 1000.0)))
                        .collect()
                })
                .collect(),
        },
    )
    .unwrap();
    let npy = dir.join("frames.npy");
    let glb = dir.join("frames.glb");
    let mesh = mesh_path();
    let play = |more: &[&str]| {
        let mut args = vec![
            "play",
            s(&rig_path),
            "--markers",
            s(&csv),
            "-o",
            s(&npy),
            "--glb",
            s(&glb),
            "--mesh",
            s(&mesh),
        ];
        args.extend_from_slice(more);
        facebake(&args)
    };
    let played = json_ok(&play(&[
        "--mesh-name",
        "head",
        "--frames",
        "0,2,5",
        "--json",
    ]));
    assert_eq!(played["frames"], frames.len());
    assert_eq!(played["glb_frames"], serde_json::json!([0, 2, 5]));

    // The runtime, called directly on the same markers: through the stages the rig baked at
    // rest (it has no capture).
    let blob = std::fs::read(&rig_path).unwrap();
    let rig = Rig::from_bytes(&blob).unwrap();
    let (space, actor) = (rig.space(), rig.actor_space().expect("stages at rest"));
    let mut out = vec![[0i32; 3]; rig.vertex_count()];
    let mut expected = Vec::new();
    let mut state = facebake_runtime::PlayState::new();
    for m in &frames {
        let q: Vec<Option<[i32; 3]>> = m.iter().map(|p| actor.to_rig_f64(*p).ok()).collect();
        rig.play(&mut state, &q, &mut out).unwrap();
        expected.extend(
            out.iter()
                .flat_map(|p| space.to_asset_f64(*p))
                .map(|x| x as f32),
        );
    }
    let (shape, values) = read_npy_f32(&npy).unwrap();
    assert_eq!(shape, [frames.len(), VERTICES, 3]);
    // Millimetres → metres may move a marker by one Q8.24 step; far below a micrometre.
    let worst = values
        .iter()
        .zip(&expected)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0f32, f32::max);
    assert!(worst < 1e-6, "largest difference {worst} m");
    let (doc, buffers, _) = gltf::import(&glb).expect("the GLB loads");
    let primitive = doc.meshes().next().unwrap().primitives().next().unwrap();
    assert_eq!(
        primitive.morph_targets().count() as u64,
        played["glb"]["targets"].as_u64().unwrap()
    );
    assert_eq!(doc.nodes().count(), 4, "eyes and teeth kept");
    // Frames 0, 2 and 5 at their times in the 60 Hz take.
    let channel = doc.animations().next().unwrap().channels().next().unwrap();
    assert_eq!(
        channel.sampler().interpolation(),
        gltf::animation::Interpolation::Linear
    );
    let keys: Vec<f32> = channel
        .reader(|b| Some(&buffers[b.index()]))
        .read_inputs()
        .unwrap()
        .collect();
    assert_eq!(keys, [0.0, 2.0 / 60.0, 5.0 / 60.0]);
    // A range beyond the take is bad input naming the capture and the range.
    let beyond = |frames: &str| play(&["--frames", frames]);
    let out = beyond("0..100:2");
    assert_bad_input(&out, "capture.csv");
    assert!(stderr(&out).contains("--frames 0..100:2: the take has"));
    let out = beyond("3..1");
    assert_eq!(out.status.code(), Some(2));
    assert!(
        stderr(&out).contains("the range is empty"),
        "{}",
        stderr(&out)
    );
}

#[test]
fn a_missing_sample_is_bad_input_naming_frame_and_marker() {
    let (demo_dir, _) = demo();
    let dir = temp_dir("gap");
    let text = std::fs::read_to_string(demo_dir.join("facecap_capture.csv")).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let row = lines.iter().position(|l| l.starts_with("3,")).unwrap();
    let mut cells: Vec<&str> = lines[row].split(',').collect();
    cells[2 + 3 * 7] = ""; // the eighth marker's (Reyebrow_M) x in frame index 2
    lines[row] = cells.join(",");
    let csv = dir.join("gap.csv");
    std::fs::write(&csv, lines.join("\n") + "\n").unwrap();
    let (rig, npy) = (demo_dir.join("facecap.fbk"), dir.join("x.npy"));
    let play = |more: &[&str]| {
        let mut args = vec!["play", s(&rig), "--markers", s(&csv), "-o", s(&npy)];
        args.extend_from_slice(more);
        facebake(&args)
    };
    // The rig's stages at rest fill the gap from the marker's neighbours.
    let filled = play(&["--json"]);
    assert_eq!(filled.status.code(), Some(0), "{}", stderr(&filled));
    assert_eq!(json_ok(&filled)["stages"]["missing_samples"], 1);
    // The deformer alone takes every marker.
    let out = play(&["--deform-only"]);
    assert_eq!(out.status.code(), Some(2));
    let err = stderr(&out);
    assert!(
        err.starts_with("error: ") && err.contains("gap.csv") && err.contains("frame 2"),
        "{err}"
    );
    assert!(err.contains("\"Reyebrow_M\""), "{err}");
}

/// Exit code 2, one `error:` line naming `file`, no panic.
fn assert_bad_input(out: &Output, file: &str) {
    let err = stderr(out);
    assert_eq!(out.status.code(), Some(2), "stderr: {err}");
    assert!(err.starts_with("error: "), "{err}");
    assert!(err.contains(file), "{file} not named in: {err}");
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
}

#[test]
fn bad_input_exits_2_naming_the_file() {
    let dir = temp_dir("bad");
    let missing_mesh = dir.join("no-such-mesh.glb");
    let layout = dir.join("layout.toml");
    std::fs::write(
        &layout,
        "[markers]\nA = { vertex = 1 }\nB = { vertex = 2 }\n",
    )
    .unwrap();
    let rig = dir.join("rig.fbk");
    assert_bad_input(&bake(&missing_mesh, &layout, &rig, &[]), "no-such-mesh.glb");
    let malformed = dir.join("malformed.toml");
    std::fs::write(&malformed, "[markers\nA = { vertex = 1 }\n").unwrap();
    assert_bad_input(
        &bake(&mesh_path(), &malformed, &rig, &["--mesh-name", "head"]),
        "malformed.toml",
    );
    let not_a_rig = dir.join("not-a-rig.fbk");
    std::fs::write(&not_a_rig, b"FACEBAKE but not really").unwrap();
    assert_bad_input(&facebake(&["inspect", s(&not_a_rig)]), "not-a-rig.fbk");
    assert_bad_input(
        &facebake(&["inspect", s(&dir.join("absent.fbk"))]),
        "absent.fbk",
    );
    assert!(!rig.exists(), "nothing is written on bad input");
}

#[test]
fn help_documents_the_exit_codes() {
    let out = facebake(&["--help"]);
    assert_eq!(out.status.code(), Some(0));
    let help = String::from_utf8_lossy(&out.stdout);
    assert!(help.contains("Exit codes:") && help.contains("verification failed"));
    for command in ["bake", "play", "inspect", "verify", "demo", "render"] {
        assert!(help.contains(command), "{command} missing from --help");
    }
}

/// FaceCap's skull markers (with JawMoCap's layout) and its inner eye corners: what the anchoring
/// follows without a capture, and the head markers a capture's fit uses.
const SKULL_AND_CANTHI: [&str; 5] = [
    "ForeHead_M",
    "ForeHead_L",
    "ForeHead_R",
    "Leye_Inside",
    "Reye_Inside",
];

#[test]
fn demo_plays_the_capture_through_the_runtime_stages() {
    let (dir, summary) = demo();
    let m = &summary["mocap"];
    assert_eq!(m["frames"], 1590, "{m}");
    assert_eq!(m["markers"], 41);
    assert!(m["runtime_vs_f64_fraction"].as_f64().unwrap() < 2e-5, "{m}");
    // The head markers the default picks among the skull markers and the inner eye corners:
    // the forehead's three and both canthi.
    assert_eq!(m["head_markers"], serde_json::json!(SKULL_AND_CANTHI));
    // The inner eye corners are not as rigid to the forehead as its markers to each other:
    // the fit's residual is 0.45 mm on average (0.13 mm with the forehead's three alone), and
    // the head markers hold still, so it moves no skin.
    let residual = m["stages"]["head_residual_mean_mm"].as_f64().unwrap();
    assert!((0.3..0.6).contains(&residual), "{m}");
    let (doc, buffers, _) = gltf::import(dir.join("jawmocap_demo.glb")).expect("the GLB loads");
    let primitive = doc.meshes().next().unwrap().primitives().next().unwrap();
    let glb = &m["glb"];
    assert_eq!(
        primitive.morph_targets().count() as u64,
        glb["targets"].as_u64().unwrap()
    );
    assert!(glb["targets"].as_u64().unwrap() <= 64, "{glb}");
    assert!(glb["p99_error_mm"].as_f64().unwrap() <= 0.1, "{glb}");
    assert!(
        glb["bytes"].as_u64().unwrap() * 10 < glb["one_target_per_frame_bytes"].as_u64().unwrap(),
        "{glb}"
    );
    // The whole take, one key per frame at 60 Hz.
    let channel = doc.animations().next().unwrap().channels().next().unwrap();
    let keys: Vec<f32> = channel
        .reader(|b| Some(&buffers[b.index()]))
        .read_inputs()
        .unwrap()
        .collect();
    assert_eq!(keys.len(), 1590);
    assert_eq!(keys[1589], 1589.0f32 / 60.0);
    let names: Vec<&str> = m["sheet_frames"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f[0].as_str().unwrap())
        .collect();
    assert!(
        names.iter().any(|n| n.starts_with("mouth open")),
        "{names:?}"
    );
    assert!(
        names.iter().any(|n| n.starts_with("jaw sideways")),
        "{names:?}"
    );
    let (shape, _) = read_npy_f32(&dir.join("jawmocap_frames.npy")).unwrap();
    assert_eq!(shape, [1590, VERTICES, 3]);
}

#[test]
fn bake_with_a_capture_then_play_a_take_with_gaps() {
    let dir = temp_dir("capture");
    let rig = dir.join("jaw.fbk");
    let layout = fixture("facecap_jawmocap_layout.toml");
    let trc = fixture("JawMoCap.trc");
    let out = bake(
        &mesh_path(),
        &layout,
        &rig,
        &[
            "--mesh-name",
            "head",
            "--capture",
            s(&trc),
            "--head-markers",
            "ForeHead_M,ForeHead_L,ForeHead_R,NoseTop",
            "--json",
        ],
    );
    let summary = json_ok(&out);
    assert_eq!(
        summary["report"]["stages"]["head_markers"][3], "NoseTop",
        "{summary}"
    );
    // The take folds no skin triangle, so nothing is relaxed.
    let relaxed = &summary["report"]["relaxed"];
    assert_eq!(relaxed["frames"], 1590, "{summary}");
    assert_eq!(relaxed["before"]["worst_frame"], 0, "{summary}");
    assert_eq!(relaxed["rings"], 0, "{summary}");
    // The same take with marker 7's sample blanked in frames 3 to 5.
    let text = std::fs::read_to_string(&trc).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    for frame in 3..6 {
        let row = lines
            .iter()
            .position(|l| l.split('\t').next() == Some(&frame.to_string()))
            .unwrap();
        let mut cells: Vec<String> = lines[row].split('\t').map(str::to_string).collect();
        for c in 0..3 {
            cells[2 + 3 * 7 + c].clear();
        }
        lines[row] = cells.join("\t");
    }
    let gappy = dir.join("gappy.trc");
    std::fs::write(&gappy, lines.join("\n") + "\n").unwrap();
    let out = facebake(&[
        "play",
        s(&rig),
        "--markers",
        s(&gappy),
        "-o",
        s(&dir.join("gappy.npy")),
        "--json",
    ]);
    let played = json_ok(&out);
    assert_eq!(played["frames"], 1590);
    assert_eq!(played["stages"]["missing_samples"], 3, "{played}");
    assert_eq!(played["stages"]["rebuilt_samples"], 3, "{played}");
    // A head marker the rig does not have is bad input naming the capture.
    let out = bake(
        &mesh_path(),
        &layout,
        &rig,
        &[
            "--mesh-name",
            "head",
            "--capture",
            s(&trc),
            "--head-markers",
            "Nose,Chin,Ear",
        ],
    );
    assert_bad_input(&out, "JawMoCap.trc");
}

#[test]
fn bake_with_geodesic_retargeting_then_play() {
    let dir = temp_dir("geodesic_retarget");
    let rig = dir.join("jaw.fbk");
    let trc = fixture("JawMoCap.trc");
    let out = bake(
        &mesh_path(),
        &fixture("facecap_jawmocap_layout.toml"),
        &rig,
        &[
            "--mesh-name",
            "head",
            "--capture",
            s(&trc),
            "--retarget",
            "geodesic",
            "--json",
        ],
    );
    let summary = json_ok(&out);
    let stages = &summary["report"]["stages"];
    assert_eq!(stages["retarget"], "Geodesic", "{summary}");
    assert!(stages["geodesic_condition"].as_f64().is_some(), "{summary}");
    let out = facebake(&[
        "play",
        s(&rig),
        "--markers",
        s(&trc),
        "-o",
        s(&dir.join("frames.npy")),
        "--json",
    ]);
    assert_eq!(json_ok(&out)["frames"], 1590);
}

#[test]
fn compensate_writes_a_head_stabilised_capture() {
    let dir = temp_dir("compensate");
    let out_csv = dir.join("still.csv");
    let out = facebake(&[
        "compensate",
        s(&fixture("JawMoCap.trc")),
        "--head-markers",
        "ForeHead_M,ForeHead_L,ForeHead_R,NoseTop",
        "-o",
        s(&out_csv),
        "--json",
    ]);
    let summary = json_ok(&out);
    assert_eq!(summary["frames"], 1590);
    // Centimetres: 0.29 mm mean RMS residual, as the runtime reports.
    let mean = summary["residual_mean"].as_f64().unwrap();
    assert!((0.02..0.04).contains(&mean), "{summary}");
    assert!(summary["pivot"]["pivot"].is_array(), "{summary}");
    // Played back through the compensation, the head markers barely move.
    let out = facebake(&[
        "compensate",
        s(&out_csv),
        "--head-markers",
        "ForeHead_M,ForeHead_L,ForeHead_R,NoseTop",
        "-o",
        s(&dir.join("again.csv")),
        "--json",
    ]);
    let again = json_ok(&out);
    assert!(
        again["residual_max"].as_f64().unwrap() <= summary["residual_max"].as_f64().unwrap() + 1e-9
    );
}

/// `compensate --head-markers auto` on JawMoCap (which never raises a brow) takes brow markers
/// for the skull when it only has the capture, and says so; given the mesh and the layout it
/// picks among the skull markers and the inner eye corners found on the mesh, as `bake` does.
#[test]
fn compensate_picks_head_markers_on_the_skull_when_given_the_mesh() {
    let dir = temp_dir("compensate_mesh");
    let (take, out_csv) = (fixture("JawMoCap.trc"), dir.join("still.csv"));
    let picked = |extra: &[&str]| {
        let mut args = vec!["compensate", s(&take), "-o", s(&out_csv), "--json"];
        args.extend_from_slice(extra);
        let summary = json_ok(&facebake(&args));
        let names: Vec<String> = summary["head_markers"]
            .as_array()
            .unwrap()
            .iter()
            .map(|n| n.as_str().unwrap().to_string())
            .collect();
        (
            names,
            summary["head_markers_from"].as_str().unwrap().to_string(),
        )
    };
    let (alone, why) = picked(&[]);
    assert!(alone.iter().any(|n| n.contains("brow")), "{alone:?}");
    assert!(why.contains("without --mesh and --layout"), "{why}");
    let layout = fixture("facecap_jawmocap_layout.toml");
    let (on_mesh, why) = picked(&["--mesh", s(&mesh_path()), "--layout", s(&layout)]);
    assert_eq!(
        on_mesh,
        [
            "ForeHead_M",
            "ForeHead_L",
            "ForeHead_R",
            "Leye_Inside",
            "Reye_Inside"
        ],
        "{why}"
    );
    assert!(why.contains("skull markers and inner eye corners"), "{why}");
    // The layout alone is refused by the argument parser: it needs the mesh.
    let out = facebake(&[
        "compensate",
        s(&take),
        "--layout",
        s(&layout),
        "-o",
        s(&out_csv),
    ]);
    assert!(!out.status.success());
}

/// The default bake masks the lips and the eyelids (the layout's groups), every method does,
/// and `--no-masks` leaves them out.
#[test]
fn the_default_bake_is_masked_unless_told_otherwise() {
    let dir = temp_dir("default_masks");
    let layout = fixture("facecap_jawmocap_layout.toml");
    let masks = |name: &str, extra: &[&str]| {
        let mut args = vec!["--json"];
        args.extend_from_slice(extra);
        let j = json_ok(&bake(&mesh_path(), &layout, &dir.join(name), &args));
        let groups: Vec<String> = j["mask_groups"]
            .as_array()
            .expect("mask groups")
            .iter()
            .map(|g| {
                format!(
                    "{} ({})",
                    g["name"].as_str().unwrap(),
                    g["source"].as_str().unwrap()
                )
            })
            .collect();
        (
            groups,
            j["report"]["surface"]["masked_vertices"]
                .as_u64()
                .unwrap_or(0),
        )
    };
    let (groups, masked) = masks("default.fbk", &[]);
    assert_eq!(groups, ["mouth (the layout's)", "eyes (the layout's)"]);
    assert!(masked > 0);
    for method in ["hybrid", "pbw"] {
        let (groups, masked) = masks(&format!("{method}.fbk"), &["--method", method]);
        assert_eq!(groups.len(), 2, "{method}");
        assert!(masked > 0, "{method}");
    }
    let (groups, masked) = masks("bare.fbk", &["--no-masks"]);
    assert!(groups.is_empty());
    assert_eq!(masked, 0);
}

/// A layout with no marker on the lips (or the lids) still bakes by default: that opening is
/// not masked, and the bake says so.
#[test]
fn an_opening_without_markers_either_side_is_left_unmasked_and_said() {
    let dir = temp_dir("unmasked_openings");
    let text = std::fs::read_to_string(fixture("facecap_jawmocap_layout.toml")).unwrap();
    let markers = text.split("[groups]").next().unwrap();
    let without = |prefixes: &[&str]| -> String {
        markers
            .lines()
            .filter(|l| !prefixes.iter().any(|p| l.starts_with(p)))
            .map(|l| format!("{l}\n"))
            .collect()
    };
    let warnings = |name: &str, layout: String| {
        let path = dir.join(format!("{name}.toml"));
        std::fs::write(&path, layout).unwrap();
        let out = bake(
            &mesh_path(),
            &path,
            &dir.join(format!("{name}.fbk")),
            &["--json"],
        );
        json_ok(&out)["report"]["warnings"].to_string()
    };
    let lips = warnings("no_lips", without(&["Mouth_"]));
    assert!(lips.contains("the lips are not masked"), "{lips}");
    assert!(!lips.contains("the eyelids are not masked"), "{lips}");
    let lids = ["Mouth_", "Leye_Up", "Leye_Down", "Reye_Up", "Reye_Down"];
    let neither = warnings("neither", without(&lids));
    assert!(neither.contains("the lips are not masked"), "{neither}");
    assert!(neither.contains("the eyelids are not masked"), "{neither}");
    assert_eq!(
        neither.matches("not masked").count(),
        2,
        "said once each: {neither}"
    );
    // The bundled layout's groups mask both: no such warning.
    let all = warnings("all", text.clone());
    assert!(!all.contains("not masked"), "{all}");
}

/// `--method euclidean` keeps the default's anchoring and kernel and masks the openings; the
/// papers' bare Euclidean RBF is still there with the flags that undo each.
#[test]
fn euclidean_is_masked_and_anchored_unless_told_otherwise() {
    let dir = temp_dir("euclidean");
    let layout = fixture("facecap_jawmocap_layout.toml");
    let out = bake(
        &mesh_path(),
        &layout,
        &dir.join("euclidean.fbk"),
        &["--method", "euclidean", "--json"],
    );
    let j = json_ok(&out);
    assert_eq!(j["report"]["method"], "euclidean");
    assert_eq!(j["report"]["radial"], "exponential");
    assert_eq!(j["report"]["deformer"], "linear");
    assert!(j["report"]["surface"]["masked_vertices"].as_u64().unwrap() > 0);
    assert!(j["report"]["surface"]["anchoring"]["anchored_vertices"]
        .as_u64()
        .is_some_and(|n| n > 0));
    let papers = [
        "--method",
        "euclidean",
        "--no-masks",
        "--no-anchoring",
        "--deformer",
        "rbf",
        "--radial",
        "gaussian",
        "--width-factor",
        "0.75",
        "--json",
    ];
    // The papers' bare RBF tears FaceCap's own shapes (its jawOpen 12.6×): refused, nothing
    // written, the error naming the mesh, the worst shape and the way round.
    let refused = bake(&mesh_path(), &layout, &dir.join("papers.fbk"), &papers);
    assert_eq!(refused.status.code(), Some(2));
    let err = stderr(&refused);
    assert!(
        err.contains("FaceCapHeadGeneric.glb")
            && err.contains("of the mesh's 51 own shapes (jawOpen ")
            && err.contains("--allow-tears"),
        "{err}"
    );
    assert!(!dir.join("papers.fbk").exists());
    let out = bake(
        &mesh_path(),
        &layout,
        &dir.join("papers.fbk"),
        &[&papers[..], &["--allow-tears"]].concat(),
    );
    let j = json_ok(&out);
    assert_eq!(j["report"]["shapes"]["shapes"], 51);
    assert_eq!(j["report"]["shapes"]["max_stretch"][1], "jawOpen");
    assert!(j["report"]["warnings"]
        .to_string()
        .contains("own shapes (jawOpen "));
    assert_eq!(j["report"]["radial"], "gaussian");
    assert_eq!(j["report"]["deformer"], "rbf");
    // The RBF deformer takes no masks, so `--deformer rbf` alone does not mask either.
    let out = bake(
        &mesh_path(),
        &layout,
        &dir.join("rbf.fbk"),
        &[
            "--method",
            "euclidean",
            "--deformer",
            "rbf",
            "--allow-tears",
            "--json",
        ],
    );
    let j = json_ok(&out);
    assert_eq!(j["report"]["deformer"], "rbf");
    // Every radial term (41 markers): its wide default kernel does not decay within 8, and the
    // bake says what keeping 8 drops.
    assert_eq!(j["report"]["k"], 41);
    assert_eq!(j["report"]["max_dropped_mass"], 0.0);
    assert!(!j["report"]["warnings"].to_string().contains("radial mass"));
    let out = bake(
        &mesh_path(),
        &layout,
        &dir.join("rbf8.fbk"),
        &["--deformer", "rbf", "-k", "8", "--allow-tears", "--json"],
    );
    let j = json_ok(&out);
    assert_eq!(j["report"]["k"], 8);
    let warnings = j["report"]["warnings"].to_string();
    assert!(
        warnings.contains("keeping K = 8 radial terms per vertex drops 29 %"),
        "{warnings}"
    );
}

#[test]
fn surface_aware_bakes_report_their_method_and_masks() {
    let dir = temp_dir("surface");
    let layout = fixture("facecap_jawmocap_layout.toml");
    let rig = dir.join("geodesic.fbk");
    let out = bake(
        &mesh_path(),
        &layout,
        &rig,
        &["--method", "geodesic", "--json"],
    );
    let j = json_ok(&out);
    assert_eq!(j["report"]["method"], "geodesic");
    assert_eq!(j["report"]["radial"], "exponential");
    assert_eq!(j["report"]["deformer"], "linear");
    // Without a capture the anchored skin follows the inner eye corners and the forehead's
    // centre (`surface::anchoring::followed`).
    assert_eq!(
        j["report"]["surface"]["anchoring"]["markers"],
        serde_json::json!(["ForeHead_M", "Leye_Inside", "Reye_Inside"])
    );
    assert_eq!(j["report"]["surface"]["openings"], 3);
    assert_eq!(j["report"]["surface"]["unreachable_vertices"], 740);
    assert!(j["report"]["surface"]["min_eigenvalue"].as_f64().unwrap() > 0.0);
    let blob = std::fs::read(&rig).unwrap();
    assert_eq!(Rig::from_bytes(&blob).unwrap().vertex_count(), VERTICES);

    let masked = dir.join("hybrid.fbk");
    let out = bake(
        &mesh_path(),
        &layout,
        &masked,
        &["--method", "hybrid", "--masks", "--json"],
    );
    let j = json_ok(&out);
    assert_eq!(
        j["report"]["deformer"], "linear",
        "masks pick the linear deformer"
    );
    assert_eq!(
        j["report"]["surface"]["masks"],
        serde_json::json!(["mouth", "eyes"])
    );
    assert!(j["report"]["surface"]["masked_vertices"].as_u64().unwrap() > 0);
    assert!(Rig::from_bytes(&std::fs::read(&masked).unwrap()).is_ok());

    let out = bake(
        &mesh_path(),
        &layout,
        &dir.join("pbw.fbk"),
        &["--method", "pbw", "--json"],
    );
    // Its global part is the geodesic RBF with the bake's radial function.
    assert_eq!(json_ok(&out)["report"]["radial"], "exponential");

    // Masks with the RBF deformer, or without groups: bad input naming the layout.
    let out = bake(
        &mesh_path(),
        &layout,
        &dir.join("x.fbk"),
        &["--masks", "--deformer", "rbf"],
    );
    assert_bad_input(&out, "facecap_jawmocap_layout.toml");
    assert!(
        stderr(&out).contains("linear or planar deformer"),
        "{}",
        stderr(&out)
    );
    // Without groups, masks find them from the mouth and eye openings, and say so: the lip and
    // eyelid markers, as the bundled layout's groups name them.
    let plain = dir.join("plain.toml");
    let text = std::fs::read_to_string(&layout).unwrap();
    std::fs::write(&plain, text.split("[groups]").next().unwrap()).unwrap();
    let out = bake(
        &mesh_path(),
        &plain,
        &dir.join("y.fbk"),
        &["--masks", "--json"],
    );
    let j = json_ok(&out);
    assert_eq!(j["mask_groups"][0]["name"], "mouth");
    assert_eq!(j["mask_groups"][0]["source"], "found from the openings");
    assert_eq!(
        j["mask_groups"][0]["lower"],
        serde_json::json!(["Mouth_Down", "Mouth_DownL", "Mouth_DownR"])
    );
    assert_eq!(
        j["mask_groups"][1]["upper"],
        serde_json::json!(["Leye_Up", "Reye_Up"])
    );
    let out = bake(&mesh_path(), &plain, &dir.join("y.fbk"), &["--masks"]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("mask groups   mouth (found from the openings): upper Mouth_Up"),
        "{text}"
    );
    // The mouth corners' share, judged on FaceCap's own 51 shapes, none of which tears it.
    assert!(
        text.contains("mouth corners 0.7 of the crack's profile, judged on the mesh's 51 shapes\n"),
        "{text}"
    );
    assert_eq!(j["report"]["mouth_share"]["share"], 0.7);
    assert_eq!(j["report"]["mouth_share"]["shapes"], 51);
    assert_eq!(j["report"]["mouth_share"]["tried"], serde_json::json!([]));
    // The finished rig against those shapes: the most any stretches an edge, where, no tear.
    assert!(
        text.contains(
            "own shapes    51 morph targets played through the rig: stretch at most 1.81× \
             (mouthSmile_R), no edge past 2×;"
        ),
        "{text}"
    );
}

#[test]
fn masks_take_vertex_sides_from_a_file() {
    let dir = temp_dir("mask-sides");
    let layout = fixture("facecap_jawmocap_layout.toml");
    // Vertices on the lower lip (1351) and next to it, and the eye corners: the plumbing is what
    // is tested here; `tests/tests/surface.rs` checks masks from vertex sets on real sides.
    let sides = dir.join("sides.toml");
    let bake_with = |text: &str, extra: &[&str]| {
        std::fs::write(&sides, text).unwrap();
        let mut args = vec!["--masks", "--mask-sides", s(&sides)];
        args.extend_from_slice(extra);
        bake(&mesh_path(), &layout, &dir.join("r.fbk"), &args)
    };
    let out = bake_with(
        "mouth = { upper = [1350], lower = [1351] }\neyes = { upper = [1795], lower = [1807] }\n",
        &["--json"],
    );
    let j = json_ok(&out);
    assert!(
        j["report"]["surface"]["masked_vertices"].as_u64().unwrap() > 0,
        "{j}"
    );
    let out = bake_with(
        "mouth = { upper = [9999999], lower = [1] }\neyes = { upper = [1], lower = [2] }\n",
        &[],
    );
    assert_bad_input(&out, "sides.toml");
    assert!(stderr(&out).contains("9999999"), "{}", stderr(&out));
    let out = bake_with("mouth = { upper = [1], lower = [2] }\n", &[]);
    assert_bad_input(&out, "sides.toml");
    assert!(stderr(&out).contains("\"eyes\""), "{}", stderr(&out));
}

#[test]
fn mask_images_render_and_bake_back() {
    let dir = temp_dir("mask-images");
    let layout = fixture("facecap_jawmocap_layout.toml");
    let out = facebake(&[
        "mask-images",
        "--mesh",
        s(&mesh_path()),
        "--mesh-name",
        "head",
        "--layout",
        s(&layout),
        "-o",
        s(&dir),
        "--json",
    ]);
    let written = json_ok(&out);
    assert_eq!(written.as_array().unwrap().len(), 2, "{written}");
    let (mouth, eyes) = (dir.join("mouth.png"), dir.join("eyes.png"));
    assert!(mouth.is_file() && eyes.is_file());
    let rig = dir.join("masked.fbk");
    let mouth_arg = format!("mouth={}", s(&mouth));
    let eyes_arg = format!("eyes={}", s(&eyes));
    let extra = [
        "--mesh-name",
        "head",
        "--masks",
        "--mask-image",
        &mouth_arg,
        "--mask-image",
        &eyes_arg,
        "--json",
    ];
    let summary = json_ok(&bake(&mesh_path(), &layout, &rig, &extra));
    assert!(
        summary["report"]["surface"]["masked_vertices"]
            .as_u64()
            .unwrap()
            > 0,
        "{summary}"
    );
    // A mask the layout does not have, and a file that is not a PNG, are bad input.
    let nose = format!("nose={}", s(&mouth));
    let out = bake(
        &mesh_path(),
        &layout,
        &rig,
        &["--mesh-name", "head", "--masks", "--mask-image", &nose],
    );
    assert_bad_input(&out, "facecap_jawmocap_layout.toml");
    let not_png = dir.join("not.png");
    std::fs::write(&not_png, b"not an image").unwrap();
    let bad = format!("mouth={}", s(&not_png));
    let out = bake(
        &mesh_path(),
        &layout,
        &rig,
        &[
            "--mesh-name",
            "head",
            "--masks",
            "--mask-image",
            &bad,
            "--mask-image",
            &eyes_arg,
        ],
    );
    assert_bad_input(&out, "not.png");
}

/// Side rule (a) from a glTF vertex attribute: a copy of FaceCap carrying `_MASK_MOUTH` and
/// `_MASK_EYES` (+1 above the lip / eye line, −1 below, 0 elsewhere) round-trips through the GLB
/// writer and loader, and masks a bake; a missing attribute is bad input naming the mesh.
#[test]
fn masks_from_gltf_vertex_attributes() {
    let dir = temp_dir("mask-attribute");
    let mut mesh = load_mesh(&mesh_path(), Some("head"), None).unwrap();
    let side = |y: f64, line: f64| if y > line { 1.0f32 } else { -1.0 };
    let mouth: Vec<f32> = mesh
        .positions
        .iter()
        .map(|p| {
            let near = p[0].abs() < 0.03 && (-0.07..-0.02).contains(&p[1]) && p[2] > 0.03;
            if near {
                side(p[1], -0.043)
            } else {
                0.0
            }
        })
        .collect();
    let eyes: Vec<f32> = mesh
        .positions
        .iter()
        .map(|p| {
            let near =
                (0.01..0.06).contains(&p[0].abs()) && (0.015..0.045).contains(&p[1]) && p[2] > 0.02;
            if near {
                side(p[1], 0.029)
            } else {
                0.0
            }
        })
        .collect();
    mesh.attributes.insert("_MASK_MOUTH".into(), mouth.clone());
    mesh.attributes.insert("_MASK_EYES".into(), eyes);
    let glb = dir.join("masked_head.glb");
    facebake::io::glb::write_glb_with_morphs(&glb, &mesh, &[]).unwrap();
    let back = load_mesh(&glb, Some("head"), None).unwrap();
    assert_eq!(back.attributes.get("_MASK_MOUTH"), Some(&mouth));
    let layout = fixture("facecap_jawmocap_layout.toml");
    let rig = dir.join("rig.fbk");
    let args = [
        "--mesh-name",
        "head",
        "--masks",
        "--mask-attribute",
        "mouth=_MASK_MOUTH",
        "--mask-attribute",
        "eyes=_MASK_EYES",
        "--json",
    ];
    let summary = json_ok(&bake(&glb, &layout, &rig, &args));
    assert!(
        summary["report"]["surface"]["masked_vertices"]
            .as_u64()
            .unwrap()
            > 0,
        "{summary}"
    );
    let missing = [
        "--mesh-name",
        "head",
        "--masks",
        "--mask-attribute",
        "mouth=_NOPE",
        "--mask-attribute",
        "eyes=_MASK_EYES",
    ];
    assert_bad_input(&bake(&glb, &layout, &rig, &missing), "masked_head.glb");
}

#[test]
fn planar_bakes_take_control_triangles_from_the_layout() {
    let dir = temp_dir("planar-triangles");
    let text = std::fs::read_to_string(fixture("facecap_jawmocap_layout.toml")).unwrap();
    let layout = dir.join("layout.toml");
    let with = |triangles: &str| {
        // A top-level key must come before the layout's tables.
        std::fs::write(&layout, format!("triangles = {triangles}\n{text}")).unwrap();
        bake(
            &mesh_path(),
            &layout,
            &dir.join("planar.fbk"),
            &["--deformer", "planar", "--allow-tears", "--json"],
        )
    };
    let out = with(
        r#"[["ForeHead_M", "ForeHead_L", "Leyebrow_M"], ["ForeHead_M", "Leyebrow_M", "Eyebrow_Center"],
            ["Mouth_Up", "Mouth_UpL1", "NoseHead_L"], ["Mouth_Down", "Mouth_DownL", "Chin"]]"#,
    );
    let j = json_ok(&out);
    assert_eq!(j["report"]["deformer"], "planar");
    assert_eq!(
        j["report"]["planar"]["triangles"],
        serde_json::json!([
            [0, 1, 3],
            [0, 3, 6],
            [28, 30, 12],
            [29, 34, 36],
            [0, 16, 20]
        ]),
        "the layout's triangles by marker index, then the skull's bone (the middle forehead \
         marker and the inner corners of the eyes: ForeHead_M, Leye_Inside, Reye_Inside)"
    );
    let blob = std::fs::read(dir.join("planar.fbk")).unwrap();
    assert_eq!(Rig::from_bytes(&blob).unwrap().vertex_count(), VERTICES);

    // Without the list, the automatic control surface (many more triangles).
    let out = bake(
        &mesh_path(),
        &fixture("facecap_jawmocap_layout.toml"),
        &dir.join("auto.fbk"),
        &["--deformer", "planar", "--allow-tears", "--json"],
    );
    let auto = json_ok(&out)["report"]["planar"]["triangles"]
        .as_array()
        .unwrap()
        .len();
    assert!(auto > 4, "{auto} automatic triangles");

    let out = with(r#"[["ForeHead_M", "ForeHead_L", "Leyebrow_M"], ["Mouth_Up", "Nope", "Chin"]]"#);
    assert_bad_input(&out, "layout.toml");
    let e = stderr(&out);
    assert!(e.contains("triangles[1]") && e.contains("\"Nope\""), "{e}");
    let out = with(r#"[["Chin", "ForeHead_L", "Chin"]]"#);
    assert_bad_input(&out, "layout.toml");
    assert!(stderr(&out).contains("twice"), "{}", stderr(&out));

    // Planar bones are masked by default; `--no-masks` leaves them bare: the same control
    // surface, other influences.
    let bare = dir.join("bare.fbk");
    let out = bake(
        &mesh_path(),
        &fixture("facecap_jawmocap_layout.toml"),
        &bare,
        &[
            "--deformer",
            "planar",
            "--no-masks",
            "--allow-tears",
            "--json",
        ],
    );
    let j = json_ok(&out);
    assert_eq!(j["report"]["deformer"], "planar");
    assert_eq!(
        j["report"]["planar"]["triangles"].as_array().unwrap().len(),
        auto
    );
    assert_ne!(
        std::fs::read(&bare).unwrap(),
        std::fs::read(dir.join("auto.fbk")).unwrap(),
        "masks change which triangles the lips ride"
    );
    // A surface-aware method does not apply to planar bones: refused, not ignored.
    let out = bake(
        &mesh_path(),
        &fixture("facecap_jawmocap_layout.toml"),
        &dir.join("geodesic.fbk"),
        &[
            "--deformer",
            "planar",
            "--method",
            "geodesic",
            "--masks",
            "--allow-tears",
        ],
    );
    assert_bad_input(&out, "facecap_jawmocap_layout.toml");
    assert!(
        stderr(&out).contains("no surface-aware method"),
        "{}",
        stderr(&out)
    );
}

#[test]
fn pack_writes_a_take_that_plays_like_its_decoded_capture() {
    let dir = temp_dir("pack");
    let take = dir.join("jaw.fbt");
    let rig = fixture("golden/jawmocap_capture.fbk");
    let jaw = fixture("JawMoCap.trc");
    let summary = json_ok(&facebake(&[
        "pack",
        s(&jaw),
        "-o",
        s(&take),
        "--rig",
        s(&rig),
        "--json",
    ]));
    assert_eq!(summary["frames"], 1590);
    assert!(summary["ratio"].as_f64().unwrap() >= 20.0, "{summary}");
    assert!(summary["measured_max_error_mm"].as_f64().unwrap() <= 0.1 * (1.0 + 1e-9));
    // The decoded take written as TRC plays to the same frames as the take.
    let decoded = facebake::io::capture::read_capture(&take).unwrap();
    let trc = dir.join("decoded.trc");
    facebake::io::capture::write_trc(&trc, &decoded).unwrap();
    let npy = [dir.join("take.npy"), dir.join("trc.npy")];
    for (input, out) in [(&take, &npy[0]), (&trc, &npy[1])] {
        let run = facebake(&["play", s(&rig), "--markers", s(input), "-o", s(out)]);
        assert_eq!(run.status.code(), Some(0), "{}", stderr(&run));
    }
    assert!(std::fs::read(&npy[0]).unwrap() == std::fs::read(&npy[1]).unwrap());
    // An error bound below the take's resolution, a marker bound for an unknown marker, and a
    // corrupt take are bad input naming the file.
    let zero = facebake(&["pack", s(&jaw), "-o", s(&take), "--max-error-mm", "0"]);
    assert_bad_input(&zero, "JawMoCap.trc");
    let unknown = facebake(&[
        "pack",
        s(&jaw),
        "-o",
        s(&take),
        "--marker-max-error",
        "Nose=0.05",
    ]);
    assert_bad_input(&unknown, "JawMoCap.trc");
    let mut bytes = std::fs::read(&take).unwrap();
    let last = bytes.len() - 1;
    bytes[last] ^= 0x55;
    let corrupt = dir.join("corrupt.fbt");
    std::fs::write(&corrupt, &bytes).unwrap();
    let run = facebake(&["play", s(&rig), "--markers", s(&corrupt), "-o", s(&npy[0])]);
    assert_bad_input(&run, "corrupt.fbt");
}

/// `--rim-across` sets how much of a distance across a lip or lid counts (the default's rims
/// ride their markers; 1 measures distances as they are), and takes only fractions in (0, 1].
#[test]
fn rim_across_changes_the_rig_and_takes_only_fractions() {
    let dir = temp_dir("rim_across");
    let layout = fixture("facecap_jawmocap_layout.toml");
    let baked = |name: &str, extra: &[&str]| baked_rig(&dir.join(name), &layout, extra);
    let default = baked("default.fbk", &[]);
    assert_eq!(default, baked("fifth.fbk", &["--rim-across", "0.2"]));
    assert_ne!(default, baked("full.fbk", &["--rim-across", "1"]));
    let out = bake(
        &mesh_path(),
        &layout,
        &dir.join("bad.fbk"),
        &["--rim-across", "1.5"],
    );
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("must be at most 1"));
}

/// The default shrinks the kept weights (`--refit shrink`), as every method does; `--refit
/// prior` re-fits them.
#[test]
fn the_default_shrinks_the_kept_weights() {
    let dir = temp_dir("refit");
    let layout = fixture("facecap_jawmocap_layout.toml");
    // Some of these forms tear FaceCap's own shapes (`--method pbw --refit prior`: the smiles,
    // 2.15×); written anyway, since only the weights are compared.
    let baked = |name: &str, extra: &[&str]| {
        baked_rig(
            &dir.join(name),
            &layout,
            &[extra, &["--allow-tears"]].concat(),
        )
    };
    let default = baked("default.fbk", &[]);
    assert_eq!(default, baked("shrink.fbk", &["--refit", "shrink"]));
    assert_ne!(default, baked("prior.fbk", &["--refit", "prior"]));
    let hybrid = baked("hybrid.fbk", &["--method", "hybrid"]);
    assert_eq!(
        hybrid,
        baked(
            "hybrid_shrink.fbk",
            &["--method", "hybrid", "--refit", "shrink"]
        )
    );
    // Every method shrinks them, PBW too (at its quarter share, options::PBW_ALPHA).
    let pbw = baked("pbw.fbk", &["--method", "pbw"]);
    assert_eq!(
        pbw,
        baked("pbw_shrink.fbk", &["--method", "pbw", "--refit", "shrink"])
    );
    assert_ne!(
        pbw,
        baked("pbw_prior.fbk", &["--method", "pbw", "--refit", "prior"])
    );
}

/// A layout of ten markers at vertices of MediaPipe's canonical face, written in `dir`.
fn disk_layout(dir: &Path) -> PathBuf {
    let layout = dir.join("disk.toml");
    let markers: String = [0, 13, 61, 105, 152, 199, 234, 291, 334, 454]
        .iter()
        .enumerate()
        .map(|(i, v)| format!("M{i} = {{ vertex = {v} }}\n"))
        .collect();
    std::fs::write(&layout, format!("[markers]\n{markers}")).unwrap();
    layout
}

/// A face whose mouth is not cut open (MediaPipe's canonical face is one disk) bakes, but the
/// bake says the lips cannot part, rather than tying them together silently.
#[test]
fn a_mesh_without_a_mouth_opening_is_said_to_tie_the_lips() {
    let dir = temp_dir("no_mouth");
    let layout = disk_layout(&dir);
    let out = bake(
        &fixture("mediapipe_canonical_face_model.glb"),
        &layout,
        &dir.join("disk.fbk"),
        &["--json"],
    );
    let j = json_ok(&out);
    let warnings = j["report"]["warnings"].to_string();
    assert!(warnings.contains("no mouth opening"), "{warnings}");
    assert!(warnings.contains("baked without masks"), "{warnings}");
    // The file is in centimetres, against glTF's metres: the figures in mm would mislead.
    assert!(warnings.contains("likely in centimetres"), "{warnings}");
    // FaceCap's mouth is open and its file in metres: no such warnings.
    let out = bake(
        &mesh_path(),
        &fixture("facecap_jawmocap_layout.toml"),
        &dir.join("facecap.fbk"),
        &["--json"],
    );
    let warnings = json_ok(&out)["report"]["warnings"].to_string();
    assert!(
        !warnings.contains("no mouth opening") && !warnings.contains("units across"),
        "{warnings}"
    );
}

/// FaceCap's head, eyes and teeth as the primitives of one mesh, the skin third (an exporter
/// writes one primitive per material, in its own order), written to `path`. The head's morph
/// targets are left out: a mesh's primitives must all have as many.
fn one_mesh_of_primitives(path: &Path) {
    let bytes = std::fs::read(mesh_path()).unwrap();
    let json_len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    let mut json: Value = serde_json::from_slice(&bytes[20..20 + json_len]).unwrap();
    let bin = &bytes[20 + json_len..];
    let meshes = json["meshes"].as_array().unwrap().clone();
    let primitive = |mesh: usize| {
        let mut p = meshes[mesh]["primitives"][0].clone();
        p.as_object_mut().unwrap().remove("targets");
        p
    };
    json["meshes"] = serde_json::json!([{
        "name": "character",
        "primitives": [primitive(1), primitive(3), primitive(0), primitive(2)],
    }]);
    json["nodes"] = serde_json::json!([{ "name": "character", "mesh": 0 }]);
    json["scenes"] = serde_json::json!([{ "nodes": [0] }]);
    let mut text = serde_json::to_vec(&json).unwrap();
    text.resize(text.len().next_multiple_of(4), b' ');
    let total = u32::try_from(12 + 8 + text.len() + bin.len()).unwrap();
    let mut glb = b"glTF".to_vec();
    glb.extend(2u32.to_le_bytes());
    glb.extend(total.to_le_bytes());
    glb.extend(u32::try_from(text.len()).unwrap().to_le_bytes());
    glb.extend(b"JSON");
    glb.extend(&text);
    glb.extend(bin);
    std::fs::write(path, glb).unwrap();
}

/// A character whose skin is one primitive among its eyes' and teeth's in the same mesh: every
/// command finds the face without being told (`bake` makes the rig it makes from FaceCap's own
/// file, byte for byte), and the commands that take a rig find the primitive with its vertex
/// count, or say which counts the file has.
#[test]
fn the_face_is_found_among_a_meshs_primitives() {
    let dir = temp_dir("primitives");
    let glb = dir.join("character.glb");
    one_mesh_of_primitives(&glb);
    let mesh = load_mesh(&glb, None, None).unwrap();
    assert_eq!((mesh.primitive_index, mesh.positions.len()), (2, VERTICES));
    let layout = fixture("facecap_jawmocap_layout.toml");
    let rig = dir.join("rig.fbk");
    let j = json_ok(&bake(&glb, &layout, &rig, &["--json"]));
    assert_eq!(
        (&j["mesh_name"], &j["primitive"]),
        (&serde_json::json!("character"), &serde_json::json!(2))
    );
    assert_eq!(
        std::fs::read(&rig).unwrap(),
        std::fs::read(fixture("golden/facecap_product.fbk")).unwrap(),
        "the same rig as from FaceCap's own file"
    );
    // `place` finds the skin's openings and nose: the same layout as on FaceCap's file.
    let placed = |mesh: &Path, to: &Path| {
        let out = facebake(&[
            "place",
            "--mesh",
            s(mesh),
            "--capture",
            s(&fixture("JawMoCap.trc")),
            "-o",
            s(to),
        ]);
        assert!(out.status.success(), "{}", stderr(&out));
        std::fs::read_to_string(to).unwrap()
    };
    assert_eq!(
        placed(&glb, &dir.join("character.toml")),
        placed(&mesh_path(), &dir.join("facecap.toml"))
    );
    // `verify`, `play --glb` and `render` take the primitive with the rig's vertex count.
    let out = facebake(&["verify", s(&rig), "--mesh", s(&glb)]);
    assert!(out.status.success(), "{}", stderr(&out));
    let (demo_dir, _) = demo();
    let (npy, played) = (dir.join("frames.npy"), dir.join("played.glb"));
    let out = facebake(&[
        "play",
        s(&rig),
        "--markers",
        s(&demo_dir.join("facecap_capture.csv")),
        "-o",
        s(&npy),
        "--glb",
        s(&played),
        "--mesh",
        s(&glb),
        "--frames",
        "0..3",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let out = facebake(&[
        "render",
        s(&npy),
        "--mesh",
        s(&glb),
        "--frames",
        "1",
        "-o",
        s(&dir.join("sheet.png")),
        "--json",
    ]);
    // This mesh has no morph targets, so without the rig's markers there is no static region,
    // and the report says so rather than a drift of 0; --remove-rigid has nothing to fit on.
    let j = json_ok(&out);
    assert_eq!(j["structure"]["static_rule"], "NoMarkers", "{j}");
    assert_eq!(j["structure"]["take"]["static_measured"], false, "{j}");
    let sheet = dir.join("sheet.png");
    let render = |extra: &[&str]| {
        let mut args = vec!["render", s(&npy), "--mesh", s(&glb), "-o", s(&sheet)];
        args.extend_from_slice(extra);
        facebake(&args)
    };
    assert_bad_input(&render(&["--remove-rigid"]), "--remove-rigid");
    let j = json_ok(&render(&["--remove-rigid", "--rig", s(&rig), "--json"]));
    assert_eq!(j["structure"]["take"]["static_measured"], true, "{j}");
    assert!(
        j["structure"]["static_vertices"].as_u64().unwrap() > 500,
        "{j}"
    );
    // A rig of another face: no primitive has its vertex count, and the error lists theirs.
    let disk = dir.join("disk.fbk");
    let out = bake(
        &fixture("mediapipe_canonical_face_model.glb"),
        &disk_layout(&dir),
        &disk,
        &[],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let out = facebake(&["verify", s(&disk), "--mesh", s(&glb)]);
    assert_bad_input(&out, "character.glb");
    let e = stderr(&out);
    assert!(
        e.contains("no mesh primitive has 468 vertices")
            && e.contains(&format!("\"character\" primitive 2: {VERTICES}")),
        "{e}"
    );
}

/// With a capture, the bake plays it through the rig it made and reports what the face does on
/// it (static drift, apertures, stretch, flips), warning where a face should not go.
#[test]
fn bake_with_a_capture_measures_the_rig_on_it() {
    let dir = temp_dir("on_capture");
    let layout = fixture("facecap_jawmocap_layout.toml");
    let capture = fixture("JawMoCap.trc");
    let run = |name: &str, extra: &[&str]| {
        let mut args = vec!["--capture", s(&capture), "--json"];
        args.extend_from_slice(extra);
        let out = bake(&mesh_path(), &layout, &dir.join(name), &args);
        json_ok(&out)
    };
    let j = run("default.fbk", &[]);
    let t = &j["on_capture"];
    assert_eq!(t["frames"], 1590);
    assert!(t["static_drift_mm"][0].as_f64().unwrap() <= 0.5, "{t}");
    assert_eq!(t["flipped"][0], 0, "{t}");
    assert!(t["lips_mm"][0].as_f64().unwrap() > 30.0, "{t}");
    // FaceCap's own shapes stretch the lips' edges further than this take does (1.89× from
    // rest, 1.30× of the longest its morph targets make an edge).
    assert!(t["beyond_shapes"][0].as_f64().unwrap() < 1.5, "{t}");
    // Unmasked planar bones keep the lips shut and stretch the corners: the bake says so, and
    // that no shape of the face stretches them as far (2.80×).
    let j = run(
        "bare_planar.fbk",
        &["--deformer", "planar", "--no-masks", "--allow-tears"],
    );
    assert!(j["on_capture"]["lips_mm"][0].as_f64().unwrap() < 2.0);
    assert!(j["on_capture"]["beyond_shapes"][0].as_f64().unwrap() > 2.0);
    let warnings = j["report"]["warnings"].to_string();
    assert!(
        warnings.contains("frames stretch an edge past twice its rest length"),
        "{warnings}"
    );
    assert!(
        warnings.contains("beyond the longest the mesh's own morph targets make it"),
        "{warnings}"
    );
    // Played through the rig, the mesh's own shapes show the tear too.
    assert!(
        warnings.contains("of the mesh's 51 own shapes"),
        "{warnings}"
    );
    // Without a capture there is nothing to play.
    let out = bake(&mesh_path(), &layout, &dir.join("none.fbk"), &["--json"]);
    assert!(json_ok(&out)["on_capture"].is_null());
}

/// `place` puts a capture's markers on a face mesh: on FaceCap, JawMoCap's markers land where
/// the bundled layout has them (which `place` made), and the layout bakes. A capture with other
/// names places the same through `--alias`, and bakes and plays the same frames. Bad input names
/// the file: a capture without the landmarks' names, a bad alias, neutral frames past the take,
/// a mesh without openings.
#[test]
fn place_writes_the_layout_bake_takes() {
    let dir = temp_dir("place");
    let layout = dir.join("placed.toml");
    let capture = fixture("JawMoCap.trc");
    let out = facebake(&[
        "place",
        "--mesh",
        s(&mesh_path()),
        "--capture",
        s(&capture),
        "-o",
        s(&layout),
        "--marker-sheet",
        s(&dir.join("markers.png")),
        "--json",
    ]);
    let j = json_ok(&out);
    assert_eq!(j["markers"], 41);
    // The picture of where they went: the rest mesh front and side, twice the panel size.
    let (w, h) = png_size(&dir.join("markers.png"));
    assert!(w >= 1000 && h >= 500, "{w}×{h}");
    assert_eq!(j["landmarks"].as_array().unwrap().len(), 7);
    assert_eq!(j["on_features"].as_array().unwrap().len(), 10);
    assert_eq!(j["warped"], 24);
    let placed = facebake::io::layout::read_layout(&layout).unwrap();
    let bundled =
        facebake::io::layout::read_layout(&fixture("facecap_jawmocap_layout.toml")).unwrap();
    assert_eq!(placed.markers.len(), bundled.markers.len());
    for (a, b) in placed.markers.iter().zip(&bundled.markers) {
        assert_eq!((&a.name, a.anchor), (&b.name, b.anchor), "{}", a.name);
    }
    // No groups: the bake finds them from the openings.
    assert!(placed.groups.is_empty());
    json_ok(&bake(
        &mesh_path(),
        &layout,
        &dir.join("rig.fbk"),
        &["--json"],
    ));

    // A capture whose markers are not the thesis' names has no landmarks.
    let renamed = dir.join("renamed.csv");
    let mut cap = facebake::io::capture::read_capture(&capture).unwrap();
    for n in &mut cap.marker_names {
        n.insert_str(0, "X_");
    }
    write_csv(&renamed, &cap).unwrap();
    let run = |mesh: &Path, capture: &Path, extra: &[&str]| {
        let mut args = vec!["place", "--mesh", s(mesh), "--capture", s(capture), "-o"];
        args.push(s(&layout));
        args.extend_from_slice(extra);
        facebake(&args)
    };
    let out = run(&mesh_path(), &renamed, &[]);
    assert_bad_input(&out, "renamed.csv");
    assert!(stderr(&out).contains("Mouth_Lend"), "{}", stderr(&out));
    assert!(stderr(&out).contains("--alias"), "{}", stderr(&out));
    // Told which of its markers are the thesis' landmarks, lips and lids, it places them as
    // the thesis' names place: the same anchors, under the capture's own names.
    let aliases: Vec<String> = bundled
        .markers
        .iter()
        .filter(|m| facebake::placement::has_role(&m.name))
        .flat_map(|m| ["--alias".to_string(), format!("X_{0}={0}", m.name)])
        .collect();
    let mut extra: Vec<&str> = aliases.iter().map(String::as_str).collect();
    extra.push("--json");
    let j = json_ok(&run(&mesh_path(), &renamed, &extra));
    assert_eq!(j["landmarks"].as_array().unwrap().len(), 7);
    assert_eq!(j["on_features"].as_array().unwrap().len(), 10);
    assert_eq!(j["aliases"].as_array().unwrap().len(), 17);
    let aliased = facebake::io::layout::read_layout(&layout).unwrap();
    for (a, b) in aliased.markers.iter().zip(&bundled.markers) {
        assert_eq!(a.name, format!("X_{}", b.name));
        assert_eq!(a.anchor, b.anchor, "{}", a.name);
    }
    // The bake and the play go by the capture's names: the renamed take through the aliased
    // layout plays the same frames as the thesis-named take through the bundled layout.
    let frames = |layout: &Path, capture: &Path, name: &str| {
        let rig = dir.join(format!("{name}.fbk"));
        baked_rig(&rig, layout, &["--capture", s(capture)]);
        let npy = dir.join(format!("{name}.npy"));
        let out = facebake(&["play", s(&rig), "--markers", s(capture), "-o", s(&npy)]);
        assert!(out.status.success(), "{}", stderr(&out));
        std::fs::read(npy).unwrap()
    };
    assert!(
        frames(&layout, &renamed, "aliased")
            == frames(&fixture("facecap_jawmocap_layout.toml"), &capture, "thesis"),
        "the renamed capture plays other frames"
    );
    let out = run(&mesh_path(), &renamed, &["--alias", "X_Chin=Jaw"]);
    assert_bad_input(&out, "renamed.csv");
    assert!(stderr(&out).contains("X_Chin=Jaw"), "{}", stderr(&out));
    let out = run(&mesh_path(), &renamed, &["--alias", "X_Chin"]);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    let out = run(&mesh_path(), &capture, &["--neutral", "5000"]);
    assert_bad_input(&out, "JawMoCap.trc");
    assert!(stderr(&out).contains("not inside"), "{}", stderr(&out));
    // A pin puts a marker at a vertex (and anchors the warp); a pin past the mesh's vertices or
    // naming no marker of the capture is bad input.
    let j = json_ok(&run(
        &mesh_path(),
        &capture,
        &["--pin", "Chin=802", "--json"],
    ));
    assert_eq!(j["pinned"], serde_json::json!(["Chin"]));
    let pinned = facebake::io::layout::read_layout(&layout).unwrap();
    let chin = pinned.markers.iter().find(|m| m.name == "Chin").unwrap();
    assert_eq!(chin.anchor, facebake::model::MarkerAnchor::Vertex(802));
    let out = run(&mesh_path(), &capture, &["--pin", "Chin=99999999"]);
    assert_bad_input(&out, "FaceCapHeadGeneric.glb");
    let out = run(&mesh_path(), &capture, &["--pin", "Nope=5"]);
    assert_bad_input(&out, "JawMoCap.trc");
    assert!(stderr(&out).contains("Nope"), "{}", stderr(&out));
}

/// A capture with a marker that is not the face's (a shoulder, 40 cm below the forehead): `place`
/// leaves it out rather than pull it onto the skin, says so, and places the face's markers as
/// without it; the layout bakes with the capture, whose extra column it does not use.
#[test]
fn a_marker_off_the_face_is_left_out_of_the_placed_layout() {
    let dir = temp_dir("place_off_face");
    let mut cap = facebake::io::capture::read_capture(&fixture("JawMoCap.trc")).unwrap();
    let forehead = cap.marker_index("ForeHead_M").unwrap();
    cap.marker_names.push("LShoulder".into());
    for frame in &mut cap.frames {
        let p = frame[forehead].expect("JawMoCap has every sample");
        frame.push(Some([p[0] + 15.0, p[1] - 35.0, p[2] - 5.0]));
    }
    let csv = dir.join("with_shoulder.csv");
    write_csv(&csv, &cap).unwrap();
    let layout = dir.join("placed.toml");
    let j = json_ok(&facebake(&[
        "place",
        "--mesh",
        s(&mesh_path()),
        "--capture",
        s(&csv),
        "-o",
        s(&layout),
        "--json",
    ]));
    assert_eq!(j["left_out"], serde_json::json!(["LShoulder"]));
    assert!(
        j["warnings"].to_string().contains("LShoulder"),
        "{}",
        j["warnings"]
    );
    let placed = facebake::io::layout::read_layout(&layout).unwrap();
    let bundled =
        facebake::io::layout::read_layout(&fixture("facecap_jawmocap_layout.toml")).unwrap();
    assert_eq!(placed.markers.len(), bundled.markers.len());
    for (a, b) in placed.markers.iter().zip(&bundled.markers) {
        assert_eq!((&a.name, a.anchor), (&b.name, b.anchor));
    }
    json_ok(&bake(
        &mesh_path(),
        &layout,
        &dir.join("rig.fbk"),
        &["--capture", s(&csv), "--json"],
    ));
}

/// A face without mouth and eye openings (MediaPipe's canonical face, one disk, centimetres)
/// has no landmarks to find: `place` says so and asks for every one pinned; pinned, it places
/// the others by the warp and the lip and eyelid markers beside the seams between the pinned
/// corners, says how, and the layout bakes with the capture.
#[test]
fn a_face_without_openings_is_placed_from_pinned_landmarks() {
    let dir = temp_dir("place_disk");
    let disk = fixture("mediapipe_canonical_face_model.glb");
    let capture = fixture("JawMoCap.trc");
    let layout = dir.join("disk.toml");
    let run = |pins: &[(&str, u32)]| {
        let pins: Vec<String> = pins
            .iter()
            .flat_map(|(n, v)| ["--pin".to_string(), format!("{n}={v}")])
            .collect();
        let mut args = vec!["place", "--mesh", s(&disk), "--capture", s(&capture), "-o"];
        args.push(s(&layout));
        args.extend(pins.iter().map(String::as_str));
        args.push("--json");
        facebake(&args)
    };
    // The corners of its mouth and eyes and its nose tip, by their glTF vertices.
    let landmarks = [
        ("Mouth_Lend", 142),
        ("Mouth_Rend", 143),
        ("Leye_Outside", 9),
        ("Leye_Inside", 7),
        ("Reye_Outside", 4),
        ("Reye_Inside", 0),
        ("NoseHead", 182),
    ];
    let out = run(&[]);
    assert_bad_input(&out, "mediapipe_canonical_face_model.glb");
    assert!(
        stderr(&out).contains("0 openings") && stderr(&out).contains("--pin NAME=VERTEX"),
        "{}",
        stderr(&out)
    );
    let out = run(&landmarks[..6]);
    assert_bad_input(&out, "mediapipe_canonical_face_model.glb");
    assert!(
        stderr(&out).contains("not pinned: NoseHead)"),
        "{}",
        stderr(&out)
    );
    let j = json_ok(&run(&landmarks));
    assert_eq!(j["pinned"].as_array().unwrap().len(), 7);
    assert_eq!(j["on_features"].as_array().unwrap().len(), 10);
    assert_eq!(j["warped"], 24);
    assert!(
        j["warnings"]
            .to_string()
            .contains("no mouth and eye openings")
            && j["warnings"].to_string().contains("between their corners"),
        "{}",
        j["warnings"]
    );
    // The warp puts the others where a face has them: the forehead's middle on the midline
    // above the eyes, the chin's below the mouth, each side's cheek on its side.
    let placed = facebake::io::layout::read_layout(&layout).unwrap();
    let anchor = |name: &str| {
        placed
            .markers
            .iter()
            .find(|m| m.name == name)
            .unwrap()
            .anchor
    };
    let at = |name: &str| match anchor(name) {
        facebake::model::MarkerAnchor::Point(p) => p,
        a => panic!("{name} is {a:?}, not warped"),
    };
    let mesh = load_mesh(&disk, None, None).unwrap();
    let vertex = |v: usize| mesh.positions[v];
    assert!(at("ForeHead_M")[0].abs() < 0.5 && at("ForeHead_M")[1] > vertex(7)[1] + 2.0);
    assert!(at("Chin")[0].abs() < 0.5 && at("Chin")[1] < vertex(142)[1] - 2.0);
    assert!(at("Lcheek_Outside")[0] > vertex(9)[0] && at("Rcheek_Outside")[0] < vertex(4)[0]);
    // The lips' middle markers on the lips: the upper above the line the lips meet along, the
    // lower below it, each within a centimetre of the corners' height (the warp alone put
    // `Mouth_Up` on the philtrum and `Mouth_Down` on the chin's crease).
    let on_vertex = |name: &str| match anchor(name) {
        facebake::model::MarkerAnchor::Vertex(v) => vertex(v as usize),
        a => panic!("{name} is {a:?}, not on its lip or lid"),
    };
    let corners = 0.5 * (vertex(142)[1] + vertex(143)[1]);
    let (up, down) = (on_vertex("Mouth_Up"), on_vertex("Mouth_Down"));
    assert!(up[0].abs() < 0.3 && down[0].abs() < 0.3, "{up:?} {down:?}");
    assert!(up[1] > corners && up[1] < corners + 1.0, "{up:?}");
    assert!(down[1] < corners && down[1] > corners - 1.0, "{down:?}");
    assert!(on_vertex("Leye_Up")[1] > on_vertex("Leye_Down")[1]);
    let rig = dir.join("disk.fbk");
    let j = json_ok(&bake(
        &disk,
        &layout,
        &rig,
        &["--capture", s(&capture), "--json"],
    ));
    assert!(j["report"]["warnings"]
        .to_string()
        .contains("no mouth opening"));
}

/// A take whose first frames miss a marker (a dropout at the start, as real captures have)
/// still bakes by default: the neutral pose is its first complete frame, and the bake says so.
/// Asked for frame 0, it refuses, naming the marker and the frame. A marker never seen is
/// rebuilt from its neighbours.
#[test]
fn a_take_starting_with_a_dropout_bakes_from_its_first_complete_frame() {
    let dir = temp_dir("dropout");
    let mut cap = facebake::io::capture::read_capture(&fixture("JawMoCap.trc")).unwrap();
    cap.frames[0][5] = None;
    cap.frames[1][7] = None;
    let csv = dir.join("dropout.csv");
    write_csv(&csv, &cap).unwrap();
    let layout = fixture("facecap_jawmocap_layout.toml");
    let rig = dir.join("rig.fbk");
    let out = bake(
        &mesh_path(),
        &layout,
        &rig,
        &["--capture", s(&csv), "--json"],
    );
    let j = json_ok(&out);
    let warnings = j["report"]["warnings"].to_string();
    assert!(
        warnings.contains("its neutral pose starts at frame 2"),
        "{warnings}"
    );
    let neutral = &j["report"]["stages"]["neutral_frames"];
    assert_eq!((&neutral["start"], &neutral["end"]), (&2.into(), &3.into()));
    let out = bake(
        &mesh_path(),
        &layout,
        &rig,
        &["--capture", s(&csv), "--neutral", "0"],
    );
    assert_bad_input(&out, "dropout.csv");
    assert!(
        stderr(&out).contains("missing in neutral frame 0"),
        "{}",
        stderr(&out)
    );

    // A marker lost for the whole take is rebuilt from its neighbours, as a virtual one, and
    // said; a marker the take does not have at all is an error that says what to do.
    let name = cap.marker_names[9].clone();
    for f in &mut cap.frames {
        f[9] = None;
    }
    write_csv(&csv, &cap).unwrap();
    let j = json_ok(&bake(
        &mesh_path(),
        &layout,
        &rig,
        &["--capture", s(&csv), "--json"],
    ));
    assert_eq!(
        j["report"]["stages"]["unsampled_markers"],
        serde_json::json!([name])
    );
    assert!(j["report"]["warnings"]
        .to_string()
        .contains("no sample in the capture"));
    cap.marker_names.remove(9);
    for f in &mut cap.frames {
        f.remove(9);
    }
    write_csv(&csv, &cap).unwrap();
    let out = bake(&mesh_path(), &layout, &rig, &["--capture", s(&csv)]);
    assert_bad_input(&out, "dropout.csv");
    assert!(
        stderr(&out).contains("--virtual-markers"),
        "{}",
        stderr(&out)
    );
}
