//! The capture half of `facebake demo`: a real actor's capture (JawMoCap by default, or any
//! capture with the same marker names) played on the bundled FaceCap head through the runtime's
//! head-motion compensation, fill, retargeting and deformation.

use std::hint::black_box;
use std::path::{Path, PathBuf};
use std::time::Instant;

use serde::Serialize;

use super::play::{play_stages, StagesSummary};
use super::{load_rig, max_distance, write_file, CliError};
use facebake::deformer::SparseF64;
use facebake::demo::{JAWMOCAP_FILE, JAWMOCAP_LAYOUT, MESH_FILE, MESH_NAME};
use facebake::io::capture::read_capture;
use facebake::io::gltf_mesh::load_mesh;
use facebake::io::layout::read_layout;
use facebake::io::npy::write_npy_f32;
use facebake::model::{place_markers, Units, DEFAULT_MAX_SNAP_FRACTION};
use facebake::morph_basis::{DEFAULT_MAX_ERROR_MM, DEFAULT_MAX_TARGETS};
use facebake::stages::reference::StateF64;
use facebake::{BakeError, BakeOptions, Scene};

/// Frames of the capture drawn on the contact sheet besides the chosen expressions.
const EXTRA_SHEET_FRAMES: usize = 3;

/// What the capture demo reports.
#[derive(Debug, Serialize)]
pub struct MocapSummary {
    /// The capture.
    pub capture: PathBuf,
    /// Its frames.
    pub frames: usize,
    /// Its rate.
    pub rate_hz: f64,
    /// Markers driving the head.
    pub markers: usize,
    /// Head markers used for compensation.
    pub head_markers: Vec<String>,
    /// How the actor's markers become the character's.
    pub retarget: facebake::RetargetKind,
    /// Blob size with the stages.
    pub blob_bytes: usize,
    /// What the runtime's stages did.
    pub stages: StagesSummary,
    /// Largest distance between the runtime's vertices and the f64 pipeline's (Kabsch,
    /// unquantised retargeting, f64 evaluation of the rig), as a fraction of the diagonal, on
    /// the rig's twin without smoothing (the f64 stages have none).
    pub runtime_vs_f64_fraction: f64,
    /// Indicative speed of `Rig::play` (stages + deformation), frames per second.
    pub play_frames_per_s: f64,
    /// Indicative speed of the stages alone, frames per second.
    pub stages_frames_per_s: f64,
    /// Frames on the contact sheet: (name, frame).
    pub sheet_frames: Vec<(String, usize)>,
    /// The whole take's animated `.glb`.
    pub glb: super::play::GlbSummary,
    /// Files written: (path, what).
    pub files: Vec<(PathBuf, String)>,
    /// Structure metrics of the played capture.
    pub structure: super::render::Structure,
}

/// Bake the FaceCap head for the capture at `mocap` (default JawMoCap), play every frame through
/// the runtime and write the rig, the frames and a `.glb` into `dir`.
pub fn run(
    fixtures: &Path,
    mocap: Option<&Path>,
    dir: &Path,
    quiet: bool,
) -> Result<MocapSummary, CliError> {
    let mesh_path = fixtures.join(MESH_FILE);
    let capture_path = mocap.map_or_else(|| fixtures.join(JAWMOCAP_FILE), Path::to_path_buf);
    let layout_path = fixtures.join(JAWMOCAP_LAYOUT);
    let mesh = load_mesh(&mesh_path, Some(MESH_NAME), None)?;
    let layout = read_layout(&layout_path)?;
    let capture = read_capture(&capture_path)?;
    let placed = place_markers(&layout, &mesh, DEFAULT_MAX_SNAP_FRACTION * mesh.diagonal())?;
    let names: Vec<String> = placed.iter().map(|m| m.name.clone()).collect();
    let mut scene = Scene::placed(&mesh, &placed);
    scene.groups = layout.groups.clone();
    scene.capture = Some(&capture);
    // What `facebake bake --capture` does with no other flag: the product's default rig, head
    // markers picked among the skull markers, the capture smoothed. Everything the demo shows
    // comes from it.
    let options = BakeOptions::product_default();
    let bake = |options: &BakeOptions| {
        facebake::bake(&scene, options).map_err(|e| match e {
            BakeError::Stages(_) => CliError::input(&capture_path, e.to_string()),
            _ => CliError::Bake {
                path: layout_path.clone(),
                source: e,
            },
        })
    };
    let baked = bake(&options)?;
    // Its twin without smoothing, for the runtime-against-f64 figure alone: the f64 reference
    // of the stages has no smoothing.
    let mut unsmoothed = options.clone();
    unsmoothed.stages.smoothing = facebake::stages::SmoothingUse::Off;
    unsmoothed.stages.head_smoothing = facebake::stages::SmoothingUse::Off;
    let twin = bake(&unsmoothed)?;
    let space = twin.space;
    let (Some(stages), Some(stages_report)) = (&twin.reference.stages, &baked.report.stages) else {
        return Err(CliError::input(
            &capture_path,
            "the bake made no capture stages",
        ));
    };
    let blob = &baked.blob;
    let mut files = Vec::new();
    let rig_path = dir.join("jawmocap.fbk");
    write_file(&rig_path, blob)?;
    files.push((
        rig_path.clone(),
        "rig blob with the capture stages".to_string(),
    ));
    let rig = load_rig(&rig_path, blob)?;

    // The capture in rig marker order, metres.
    let metres = capture.in_metres();
    let columns: Vec<usize> = names
        .iter()
        .map(|n| capture.marker_index(n).unwrap_or(usize::MAX))
        .collect();
    let frames: Vec<Vec<Option<[f64; 3]>>> = metres
        .frames
        .iter()
        .map(|f| {
            columns
                .iter()
                .map(|&c| f.get(c).copied().flatten())
                .collect()
        })
        .collect();

    // The unsmoothed twin through the runtime, and through the f64 reference beside it.
    let n = rig.vertex_count();
    let twin_rig = load_rig(&rig_path, &twin.blob)?;
    let sparse = SparseF64::from_rig(&twin_rig);
    let mut ref_state = StateF64::default();
    let mut compensated = Vec::with_capacity(frames.len());
    let mut retargeted = Vec::with_capacity(frames.len());
    let mut worst = 0.0f64;
    let bar = super::progress(2 * frames.len(), "playing the capture", quiet);
    play_stages(&twin_rig, &rig_path, &frames, |f, positions| {
        let (actor, _) = stages.compensate(&mut ref_state, &frames[f]);
        let markers: Vec<[f64; 3]> = stages
            .retarget(&actor)
            .iter()
            .map(|m| {
                [0, 1, 2].map(|c| f64::from(space.centre[c]) + m[c] * f64::from(space.half_extent))
            })
            .collect();
        worst = worst.max(max_distance(positions, &sparse.frame(&markers)));
        retargeted.push(markers);
        compensated.push(actor);
        bar.inc(1);
    })?;
    // The product rig: what the sheet, the metrics, the frames and the .glb show.
    let mut played: Vec<Vec<[f64; 3]>> = Vec::with_capacity(frames.len());
    let summary = play_stages(&rig, &rig_path, &frames, |_, positions| {
        played.push(positions.to_vec());
        bar.inc(1);
    })?;
    bar.finish_and_clear();

    // Speed: the whole capture, through play and through the stages alone.
    let actor_space = rig.stages().map(|s| s.actor_space);
    let quantised: Vec<Vec<Option<[i32; 3]>>> = frames
        .iter()
        .map(|f| {
            f.iter()
                .map(|p| p.and_then(|p| actor_space?.to_rig_f64(p).ok()))
                .collect()
        })
        .collect();
    let mut state = facebake_runtime::PlayState::new();
    let mut out = vec![[0i32; 3]; n];
    let start = Instant::now();
    for q in &quantised {
        black_box(rig.play(&mut state, black_box(q), &mut out).ok());
    }
    let play_fps = quantised.len() as f64 / start.elapsed().as_secs_f64().max(1e-9);
    let mut markers = vec![[0i32; 3]; rig.marker_count()];
    let start = Instant::now();
    if let Some(st) = rig.stages() {
        for q in &quantised {
            black_box(st.solve(&mut state, black_box(q), &mut markers));
        }
    }
    let stages_fps = quantised.len() as f64 / start.elapsed().as_secs_f64().max(1e-9);

    // Frames for the .glb: neutral, mouth widest open, jaw furthest sideways, a few more.
    let index = |name: &str| names.iter().position(|n| n == name);
    let dist = |a: &[f64; 3], b: &[f64; 3]| facebake::mesh::distance(a, b);
    let mut chosen: Vec<(String, usize)> = vec![("neutral (frame 0)".to_string(), 0)];
    if let (Some(up), Some(down)) = (index("Mouth_Up"), index("Mouth_Down")) {
        let f = (0..compensated.len())
            .max_by(|&a, &b| {
                let gap = |f: usize| dist(&compensated[f][up], &compensated[f][down]);
                gap(a).total_cmp(&gap(b))
            })
            .unwrap_or(0);
        chosen.push((format!("mouth open (frame {f})"), f));
    }
    if let (Some(chin), Some(l), Some(r)) =
        (index("Chin"), index("ForeHead_L"), index("ForeHead_R"))
    {
        let n0 = &compensated[0];
        let axis = [0, 1, 2].map(|c| n0[l][c] - n0[r][c]);
        let len = dist(&axis, &[0.0; 3]).max(f64::MIN_POSITIVE);
        let lateral = |f: usize| {
            (0..3)
                .map(|c| (compensated[f][chin][c] - n0[chin][c]) * axis[c] / len)
                .sum::<f64>()
                .abs()
        };
        let f = (0..compensated.len())
            .max_by(|&a, &b| lateral(a).total_cmp(&lateral(b)))
            .unwrap_or(0);
        chosen.push((format!("jaw sideways (frame {f})"), f));
    }
    for f in super::play::evenly_spaced(frames.len(), EXTRA_SHEET_FRAMES + 2)
        .into_iter()
        .skip(1)
        .take(EXTRA_SHEET_FRAMES)
    {
        chosen.push((format!("frame {f}"), f));
    }

    let character: Vec<[f64; 3]> = placed.iter().map(|m| m.position).collect();
    let head: Vec<usize> = (stages_report.head_markers.iter())
        .filter_map(|h| names.iter().position(|n| n == h))
        .collect();
    let (structure, pictures) = super::render::demo_capture(
        dir,
        &mesh,
        (&played, &retargeted),
        &chosen,
        &names,
        &character,
        &head,
    )?;
    files.extend(pictures);
    let npy_path = dir.join("jawmocap_frames.npy");
    let flat: Vec<f32> = played
        .iter()
        .flat_map(|p| p.iter().flatten().map(|&x| x as f32))
        .collect();
    write_npy_f32(&npy_path, &[played.len(), n, 3], &flat)
        .map_err(|e| CliError::io(&npy_path, e))?;
    files.push((
        npy_path,
        format!(
            "all {} frames, {} × {n} × 3 float32, metres",
            played.len(),
            played.len()
        ),
    ));
    let glb_path = dir.join("jawmocap_demo.glb");
    let numbers: Vec<usize> = (0..played.len()).collect();
    let glb = super::play::write_take_glb(
        &glb_path,
        &mesh,
        (&played, &numbers),
        capture.rate_hz,
        Units::Metres,
        (DEFAULT_MAX_ERROR_MM, DEFAULT_MAX_TARGETS),
    )?;
    files.push((
        glb_path,
        format!(
            "the whole take animated at {} Hz, {} morph targets",
            capture.rate_hz, glb.targets
        ),
    ));

    Ok(MocapSummary {
        capture: capture_path,
        frames: frames.len(),
        rate_hz: capture.rate_hz,
        markers: names.len(),
        head_markers: stages_report.head_markers.clone(),
        retarget: stages_report.retarget,
        blob_bytes: blob.len(),
        stages: summary,
        runtime_vs_f64_fraction: worst / mesh.diagonal(),
        play_frames_per_s: play_fps,
        stages_frames_per_s: stages_fps,
        sheet_frames: chosen,
        glb,
        files,
        structure,
    })
}

/// The capture part of the demo's text report.
pub fn text(s: &MocapSummary) -> String {
    let mut out = String::new();
    outln!(
        out,
        "capture: {} ({} frames at {} Hz, {} markers) on the same head",
        s.capture.display(),
        s.frames,
        s.rate_hz,
        s.markers
    );
    outln!(
        out,
        "  stages          head markers {}; retargeting {}; rig {} bytes",
        s.head_markers.join(", "),
        match s.retarget {
            facebake::RetargetKind::Proportional => "proportional (paper 003)",
            facebake::RetargetKind::Rbf => "IMQ + affine RBF map (paper 000)",
            facebake::RetargetKind::Geodesic => "geodesic, linearised (paper 002)",
        },
        s.blob_bytes
    );
    let st = &s.stages;
    outln!(
        out,
        "  head fit        residual mean {:.3} mm, max {:.3} mm; held in {} frames, \
         tracked in {}",
        st.head_residual_mean_mm,
        st.head_residual_max_mm,
        st.frames_head_held,
        st.frames_head_tracked
    );
    outln!(
        out,
        "  missing data    {} samples missing, {} rejected, {} rebuilt, {} held",
        st.missing_samples,
        st.rejected_samples,
        st.rebuilt_samples,
        st.held_samples
    );
    outln!(
        out,
        "  runtime vs f64  max {:.2e} of the diagonal (compensation, retargeting and deformation; the rig without smoothing)",
        s.runtime_vs_f64_fraction
    );
    outln!(
        out,
        "  speed           play {:.0} frames/s, capture stages alone {:.0} frames/s",
        s.play_frames_per_s,
        s.stages_frames_per_s
    );
    let names: Vec<&str> = s.sheet_frames.iter().map(|(n, _)| n.as_str()).collect();
    outln!(out, "  sheet frames    {}", names.join(", "));
    outln!(out, "  .glb            {}", s.glb.text());
    for (path, what) in &s.files {
        outln!(out, "  {:40} {}", path.display().to_string(), what);
    }
    out.push_str(&super::render::structure_text(&s.structure, false));
    out
}
