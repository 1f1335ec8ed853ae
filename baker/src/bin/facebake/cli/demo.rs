//! `facebake demo`: the bundled FaceCap head baked and played end to end, with size, accuracy
//! and speed figures. Needs no arguments.

use std::hint::black_box;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use clap::Args;
use facebake_runtime::deformer::Deformer;
use serde::Serialize;

use super::bytes_text;
use super::inspect::CostSummary;
use super::{
    deform_to_asset, emit, load_rig, markers_to_rig, max_distance, print_json, progress,
    weight_format, write_file, CliError,
};
use facebake::deformer::{SparseF64, TOLERANCE_FRACTION};
use facebake::demo::{
    CAPTURE_RATE_HZ, JAWMOCAP_LAYOUT, MARKERS, MESH_FILE, MESH_NAME, SHEET_FRAMES, STATIC_MARKERS,
};
use facebake::ground_truth::{stats, ErrorStats, GroundTruth};
use facebake::io::capture::write_csv;
use facebake::io::gltf_mesh::load_mesh;
use facebake::io::layout::read_layout;
use facebake::io::npy::write_npy_f32;
use facebake::model::{place_markers, Capture, Units, DEFAULT_MAX_SNAP_FRACTION};
use facebake::morph_basis::{DEFAULT_MAX_ERROR_MM, DEFAULT_MAX_TARGETS};
use facebake::{BakeOptions, Scene};

/// Arguments of `facebake demo`.
#[derive(Debug, Args)]
pub struct DemoArgs {
    /// Folder for the files the demo writes.
    #[arg(long, value_name = "DIR", default_value = "out/demo")]
    pub out: PathBuf,
    /// Folder holding the bundled fixtures (default: the source tree's fixtures/).
    #[arg(long, value_name = "DIR")]
    pub fixtures: Option<PathBuf>,
    /// Times the whole sequence is played for the speed figures.
    #[arg(long, value_name = "N", default_value_t = 200, value_parser = clap::value_parser!(u32).range(1..))]
    pub repetitions: u32,
    /// A capture (C3D, TRC or CSV) with JawMoCap's 41 marker names to play on the head instead
    /// of the bundled JawMoCap.
    #[arg(long, value_name = "FILE")]
    pub mocap: Option<PathBuf>,
    /// Print a JSON summary on stdout instead of text.
    #[arg(long)]
    pub json: bool,
}

/// Indicative wall-clock speed.
#[derive(Debug, Serialize)]
pub struct Speed {
    /// Runtime frames per second.
    pub runtime_frames_per_s: f64,
    /// Runtime vertex-influences per second.
    pub runtime_influences_per_s: f64,
    /// Frames the runtime figure was timed over.
    pub runtime_frames_timed: usize,
    /// Dense f64 reference frames per second.
    pub dense_frames_per_s: f64,
    /// Frames the dense figure was timed over.
    pub dense_frames_timed: usize,
    /// Whether this was an optimised build.
    pub optimised_build: bool,
}

/// A file the demo wrote.
#[derive(Debug, Serialize)]
pub struct Written {
    /// Where.
    pub path: PathBuf,
    /// What it is.
    pub what: String,
}

/// What `demo` reports.
#[derive(Debug, Serialize)]
pub struct DemoSummary {
    /// The mesh file.
    pub mesh: PathBuf,
    /// Vertices.
    pub vertices: usize,
    /// Morph targets of the mesh.
    pub morph_targets: usize,
    /// Markers.
    pub markers: usize,
    /// The marker layout (the bundled JawMoCap layout).
    pub layout: PathBuf,
    /// Ground-truth frames.
    pub frames: usize,
    /// Blob size, bytes.
    pub blob_bytes: usize,
    /// The deformer: "rbf", "linear" or "planar".
    pub deformer: &'static str,
    /// K.
    pub k: usize,
    /// Weight format.
    pub weight_format: String,
    /// Per-frame cost.
    pub cost: CostSummary,
    /// Bounding-box diagonal, metres.
    pub diagonal: f64,
    /// Largest runtime-vs-f64 distance as a fraction of the diagonal.
    pub runtime_vs_f64_fraction: f64,
    /// Whether that is within `verify`'s tolerance.
    pub runtime_vs_f64_passed: bool,
    /// Sparse runtime vs ground truth over skin vertices.
    pub runtime_vs_truth: ErrorStats,
    /// Dense f64 reference vs ground truth over skin vertices.
    pub dense_vs_truth: ErrorStats,
    /// The sequence through the rig's stages at rest (`Rig::play`, each frame held
    /// [`PLAY_HOLD`] frames): skin error and the worst static drift, mm.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub through_play: Option<(ErrorStats, f64)>,
    /// Indicative speed.
    pub speed: Speed,
    /// Files written.
    pub files: Vec<Written>,
    /// Structure metrics of the ground-truth sequence.
    pub structure: super::render::Structure,
    /// The ground truth's animated `.glb`.
    pub glb: super::play::GlbSummary,
    /// The capture played through compensation, retargeting and deformation.
    pub mocap: super::mocap::MocapSummary,
}

/// The source tree's fixtures folder.
pub fn default_fixtures() -> PathBuf {
    let path = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../fixtures"));
    std::fs::canonicalize(&path).unwrap_or(path)
}

/// Run `facebake demo`.
pub fn run(args: &DemoArgs) -> Result<ExitCode, CliError> {
    let fixtures = args.fixtures.clone().unwrap_or_else(default_fixtures);
    let mesh_path = fixtures.join(MESH_FILE);
    let dir = &args.out;
    std::fs::create_dir_all(dir).map_err(|e| CliError::io(dir, e))?;
    let mut files = Vec::new();
    let mut wrote = |path: &Path, what: &str| {
        files.push(Written {
            path: path.to_path_buf(),
            what: what.to_string(),
        })
    };

    // Ground truth, layout, bake: the same path as `facebake bake --layout`, with the bundled
    // layout of JawMoCap's 41 markers (lips, eyelids, brows, cheeks, chin) on the head.
    let mesh = load_mesh(&mesh_path, Some(MESH_NAME), None)?;
    let truth = GroundTruth::new(mesh, MARKERS, STATIC_MARKERS).map_err(|source| {
        CliError::GroundTruth {
            path: mesh_path.clone(),
            source,
        }
    })?;
    let bundled = fixtures.join(JAWMOCAP_LAYOUT);
    let layout_path = dir.join("facecap_markers.toml");
    std::fs::copy(&bundled, &layout_path).map_err(|e| CliError::io(&layout_path, e))?;
    let layout = read_layout(&layout_path)?;
    wrote(
        &layout_path,
        &format!(
            "marker layout ({} markers, {JAWMOCAP_LAYOUT})",
            layout.markers.len()
        ),
    );
    let placed = place_markers(
        &layout,
        &truth.mesh,
        DEFAULT_MAX_SNAP_FRACTION * truth.mesh.diagonal(),
    )?;
    let scene = Scene {
        groups: layout.groups.clone(),
        ..Scene::placed(&truth.mesh, &placed)
    };
    let baked = facebake::bake(&scene, &BakeOptions::product_default()).map_err(|source| {
        CliError::Bake {
            path: layout_path.clone(),
            source,
        }
    })?;
    let rig_path = dir.join("facecap.fbk");
    write_file(&rig_path, &baked.blob)?;
    wrote(&rig_path, "rig blob");
    let rig = load_rig(&rig_path, &baked.blob)?;
    let space = rig.space();

    // The ground-truth sequence through the runtime, the f64 evaluation and the dense reference.
    let frames = truth.frames.len();
    let truths: Vec<Vec<[f64; 3]>> = (0..frames).map(|f| truth.positions(f)).collect();
    // The markers ride the true surface where they were placed.
    let markers: Vec<Vec<[f64; 3]>> = truths
        .iter()
        .map(|t| placed.iter().map(|m| m.surface.interpolate(t)).collect())
        .collect();
    let names: Vec<String> = placed.iter().map(|m| m.name.clone()).collect();
    let rest: Vec<[f64; 3]> = placed.iter().map(|m| m.surface.point).collect();
    let quantised: Vec<Vec<[i32; 3]>> = markers
        .iter()
        .enumerate()
        .map(|(f, m)| markers_to_rig(&rig, m, f, &mesh_path))
        .collect::<Result<_, _>>()?;
    let reference = SparseF64::from_rig(&rig);
    let n = rig.vertex_count();
    let mut out = vec![[0i32; 3]; n];
    let mut played = Vec::with_capacity(frames);
    let (mut max_error, mut e_runtime, mut e_dense) = (0.0f64, Vec::new(), Vec::new());
    for f in 0..frames {
        let got = deform_to_asset(&rig, &rig_path, &quantised[f], &mut out)?;
        let exact: Vec<[f64; 3]> = quantised[f]
            .iter()
            .map(|q| space.to_asset_f64(*q))
            .collect();
        max_error = max_error.max(max_distance(&got, &reference.frame(&exact)));
        truth.skin_errors(&got, &truths[f], &mut e_runtime);
        truth.skin_errors(
            &baked.reference.deformer.frame(&markers[f]),
            &truths[f],
            &mut e_dense,
        );
        played.push(got);
    }
    let diagonal = truth.mesh.diagonal();
    let through_play = play_truth(&rig, &truth, &markers, &truths, &rest);

    // Speed: whole passes over the sequence.
    let reps = args.repetitions as usize;
    let bar = progress(reps, "timing the runtime", args.json);
    let start = Instant::now();
    for _ in 0..reps {
        for q in &quantised {
            rig.deform(black_box(q), black_box(&mut out))
                .map_err(|e| CliError::input(&rig_path, e.to_string()))?;
        }
        bar.inc(1);
    }
    let runtime_s = start.elapsed().as_secs_f64().max(1e-9);
    bar.finish_and_clear();
    let start = Instant::now();
    let mut dense_passes = 0;
    while dense_passes < reps && (dense_passes == 0 || start.elapsed().as_secs_f64() < 0.5) {
        for m in &markers {
            black_box(baked.reference.deformer.frame(black_box(m)));
        }
        dense_passes += 1;
    }
    let dense_s = start.elapsed().as_secs_f64().max(1e-9);
    let cost = rig.cost();
    let runtime_fps = (reps * frames) as f64 / runtime_s;
    let speed = Speed {
        runtime_frames_per_s: runtime_fps,
        runtime_influences_per_s: runtime_fps * cost.influences as f64,
        runtime_frames_timed: reps * frames,
        dense_frames_per_s: (dense_passes * frames) as f64 / dense_s,
        dense_frames_timed: dense_passes * frames,
        optimised_build: !cfg!(debug_assertions),
    };

    // Outputs.
    let npy_path = dir.join("facecap_frames.npy");
    let flat: Vec<f32> = played
        .iter()
        .flat_map(|p| p.iter().flatten().map(|&x| x as f32))
        .collect();
    write_npy_f32(&npy_path, &[frames, n, 3], &flat).map_err(|e| CliError::io(&npy_path, e))?;
    wrote(
        &npy_path,
        &format!("all {frames} frames, {frames} × {n} × 3 float32, metres"),
    );
    let capture_path = dir.join("facecap_capture.csv");
    write_csv(
        &capture_path,
        &Capture {
            source: capture_path.clone(),
            rate_hz: CAPTURE_RATE_HZ,
            units: Units::Metres,
            marker_names: names.clone(),
            frames: markers
                .iter()
                .map(|m| m.iter().map(|p| Some(*p)).collect())
                .collect(),
        },
    )?;
    wrote(&capture_path, "the sequence's marker positions, for `play`");
    let glb_path = dir.join("facecap_demo.glb");
    let numbers: Vec<usize> = (0..frames).collect();
    let glb = super::play::write_take_glb(
        &glb_path,
        &truth.mesh,
        (&played, &numbers),
        CAPTURE_RATE_HZ,
        Units::Metres,
        (DEFAULT_MAX_ERROR_MM, DEFAULT_MAX_TARGETS),
    )?;
    wrote(
        &glb_path,
        &format!(
            "all {frames} frames animated at {CAPTURE_RATE_HZ} Hz, {} morph targets",
            glb.targets
        ),
    );

    let (structure, pictures) = super::render::demo_ground_truth(
        dir,
        &truth,
        (&played, &markers),
        (&names, &rest),
        &SHEET_FRAMES,
    )?;
    pictures.iter().for_each(|(p, w)| wrote(p, w));
    let mocap = super::mocap::run(&fixtures, args.mocap.as_deref(), dir, args.json)?;
    let summary = DemoSummary {
        mesh: mesh_path,
        vertices: n,
        morph_targets: truth.mesh.morph_targets.len(),
        markers: rig.marker_count(),
        layout: bundled,
        frames,
        blob_bytes: baked.blob.len(),
        deformer: match rig.deformer() {
            Deformer::Linear(_) => "linear",
            Deformer::Rbf(_) => "rbf",
            Deformer::Planar(_) => "planar",
        },
        k: cost.max_influences,
        weight_format: weight_format(rig.weight_frac_bits()),
        cost: cost.into(),
        diagonal,
        runtime_vs_f64_fraction: max_error / diagonal,
        runtime_vs_f64_passed: max_error / diagonal <= TOLERANCE_FRACTION,
        runtime_vs_truth: stats(&mut e_runtime, 1.0),
        dense_vs_truth: stats(&mut e_dense, 1.0),
        through_play,
        speed,
        files,
        structure,
        glb,
        mocap,
    };
    if args.json {
        print_json(&summary);
    } else {
        print_text(&summary, &rig_path);
    }
    Ok(ExitCode::SUCCESS)
}

fn print_text(s: &DemoSummary, rig_path: &Path) {
    let mut out = String::new();
    outln!(
        out,
        "facebake demo: {} (mesh \"{MESH_NAME}\", {} vertices, {} morph targets)",
        s.mesh.display(),
        s.vertices,
        s.morph_targets
    );
    outln!(
        out,
        "  markers         {} ({})",
        s.markers,
        s.layout.display()
    );
    outln!(
        out,
        "  rig             {}, {} deformer (default bake), K = {}, {} {}",
        bytes_text(s.blob_bytes),
        s.deformer,
        s.k,
        if s.deformer == "linear" {
            "weights"
        } else {
            "kernel values"
        },
        s.weight_format
    );
    outln!(out, "  per frame       {}", s.cost.text);
    outln!(
        out,
        "  runtime vs f64  max {:.2e} of the diagonal ({}, allowed {TOLERANCE_FRACTION:.0e})",
        s.runtime_vs_f64_fraction,
        if s.runtime_vs_f64_passed {
            "pass"
        } else {
            "FAIL"
        }
    );
    outln!(
        out,
        "  ground truth    {} frames of morph-target blends, skin vertices:",
        s.frames
    );
    outln!(out, "    sparse runtime   {}", s.runtime_vs_truth);
    outln!(out, "    dense f64 RBF    {}", s.dense_vs_truth);
    if let Some((e, drift)) = &s.through_play {
        outln!(
            out,
            "    through `play`   {e}; static drift {drift:.2} mm (the stages at rest)"
        );
    }
    out.push_str(&super::render::structure_text(&s.structure, false));
    outln!(out, "  .glb            {}", s.glb.text());
    let sp = &s.speed;
    outln!(
        out,
        "  speed           indicative wall-clock numbers on this machine ({}):",
        if sp.optimised_build {
            "optimised build"
        } else {
            "debug build: use --release for representative figures"
        }
    );
    outln!(
        out,
        "    runtime          {:.0} frames/s, {:.3e} vertex-influences/s ({} frames timed)",
        sp.runtime_frames_per_s,
        sp.runtime_influences_per_s,
        sp.runtime_frames_timed
    );
    outln!(
        out,
        "    dense f64 RBF    {:.0} frames/s ({} frames timed), {:.1}× slower than the runtime",
        sp.dense_frames_per_s,
        sp.dense_frames_timed,
        sp.runtime_frames_per_s / sp.dense_frames_per_s.max(f64::MIN_POSITIVE)
    );
    outln!(out, "wrote:");
    for w in &s.files {
        outln!(out, "  {:40} {}", w.path.display().to_string(), w.what);
    }
    let capture = s
        .files
        .iter()
        .find(|w| w.path.extension().is_some_and(|e| e == "csv"))
        .map(|w| w.path.display().to_string())
        .unwrap_or_default();
    out.push_str(&super::mocap::text(&s.mocap));
    outln!(out, "try:");
    outln!(out, "  facebake inspect {}", rig_path.display());
    outln!(
        out,
        "  facebake verify {} --mesh {} --mesh-name {MESH_NAME}",
        rig_path.display(),
        s.mesh.display()
    );
    outln!(
        out,
        "  facebake play {} --markers {capture} -o frames.npy",
        rig_path.display()
    );
    if let Some((rig, _)) = s.mocap.files.first() {
        outln!(
            out,
            "  facebake play {} --markers {} -o mocap.npy",
            rig.display(),
            s.mocap.capture.display()
        );
    }
    emit(&out);
}

/// Frames each truth frame is held when the sequence is played through the stages: a face
/// holds an expression, and the head refit weighs a marker by its motion since the last frame.
pub const PLAY_HOLD: usize = 3;

/// The sequence's `markers` (metres) through `rig`'s stages, each frame held [`PLAY_HOLD`]
/// frames (`facebake::surface::evaluate::play_held`): the skin's error against `truths` and the
/// worst static drift (mm); `None` for a rig without stages.
fn play_truth(
    rig: &facebake_runtime::Rig<'_>,
    truth: &GroundTruth,
    markers: &[Vec<[f64; 3]>],
    truths: &[Vec<[f64; 3]>],
    rest: &[[f64; 3]],
) -> Option<(ErrorStats, f64)> {
    let played = facebake::surface::evaluate::play_held(rig, markers, PLAY_HOLD)?;
    let regions = facebake::metrics::Regions::for_mesh(&truth.mesh, rest, &[]).ok()?;
    let mut errors = Vec::new();
    for (got, t) in played.iter().zip(truths) {
        truth.skin_errors(got, t, &mut errors);
    }
    let (_, take) = regions.measure_take(&played, Some(truths), false);
    Some((stats(&mut errors, 1.0), take.static_drift_mm.0))
}
