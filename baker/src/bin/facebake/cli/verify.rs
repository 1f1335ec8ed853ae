//! `facebake verify`: the fixed-point runtime against the f64 evaluation of the same rig, and
//! against the ground truth when the mesh has morph targets.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Args;
use facebake_runtime::Rig;
use serde::Serialize;

use super::play::load_matching_mesh;
use super::{
    deform_to_asset, emit, load_rig, marker_surface_points, markers_to_rig, max_distance,
    parse_units, print_json, progress, read_file, CliError, EXIT_VERIFY_FAILED,
};
use facebake::deformer::{SparseF64, TOLERANCE_FRACTION};
use facebake::ground_truth::{stats, ErrorStats, GroundTruth, SplitMix64};
use facebake::model::{FaceMesh, Units};

/// Frames of the synthetic sequence used for meshes without morph targets.
pub const SYNTHETIC_FRAMES: usize = 32;

/// Largest marker displacement of the synthetic sequence, as a fraction of the diagonal.
pub const SYNTHETIC_DISPLACEMENT: f64 = 0.02;

/// Arguments of `facebake verify`.
#[derive(Debug, Args)]
pub struct VerifyArgs {
    /// The rig blob (.fbk).
    #[arg(value_name = "RIG")]
    pub rig: PathBuf,
    /// The mesh the rig was baked from. With morph targets, the ground-truth sequence is
    /// played and scored (the rig's markers must sit at vertices); without, a synthetic one.
    #[arg(long, value_name = "MESH")]
    pub mesh: PathBuf,
    /// Which mesh of the file (default: the one with a primitive of the rig's vertex count;
    /// of several, the face's).
    #[arg(long, value_name = "NAME")]
    pub mesh_name: Option<String>,
    /// Units of the mesh, for millimetre figures: mm, cm, m or in.
    #[arg(long, value_name = "UNITS", value_parser = parse_units, default_value = "m")]
    pub units: Units,
    /// Print a JSON summary on stdout instead of text.
    #[arg(long)]
    pub json: bool,
}

/// What `verify` reports.
#[derive(Debug, Serialize)]
pub struct VerifySummary {
    /// The rig.
    pub rig: PathBuf,
    /// The mesh.
    pub mesh: PathBuf,
    /// "ground truth" (morph-target blends) or "synthetic" (random marker displacements).
    pub sequence: &'static str,
    /// Frames played.
    pub frames: usize,
    /// Bounding-box diagonal, mesh units.
    pub diagonal: f64,
    /// Largest runtime-vs-f64 vertex distance, mesh units.
    pub max_error: f64,
    /// The same as a fraction of the diagonal.
    pub max_error_fraction: f64,
    /// The same in millimetres.
    pub max_error_mm: f64,
    /// The allowed fraction of the diagonal.
    pub tolerance_fraction: f64,
    /// Whether the runtime is within tolerance.
    pub passed: bool,
    /// Runtime vs ground truth over skin vertices (meshes with morph targets only).
    pub ground_truth: Option<ErrorStats>,
    /// Structure metrics of the runtime's frames (against the truth when there is one).
    pub structure: super::render::Structure,
}

/// A sequence to play: per frame, marker positions and (if known) the true vertex positions.
struct Sequence {
    name: &'static str,
    markers: Vec<Vec<[f64; 3]>>,
    truth: Option<(GroundTruth, Vec<usize>)>,
}

/// The ground-truth sequence over the rig's markers, or a synthetic one without morph targets.
fn sequence(rig: &Rig<'_>, mesh: FaceMesh) -> Result<Sequence, CliError> {
    if mesh.morph_targets.is_empty() {
        let diagonal = mesh.diagonal();
        let space = rig.space();
        let rest: Vec<[f64; 3]> = (0..rig.marker_count())
            .map(|m| space.to_asset_f64(rig.marker_rest(m).unwrap_or_default()))
            .collect();
        let mut rng = SplitMix64(0xFACE_BA4E_0001);
        let amplitude = SYNTHETIC_DISPLACEMENT * diagonal;
        let markers = (0..SYNTHETIC_FRAMES)
            .map(|f| {
                // Frame 0 is the rest pose; frame 1 a pure translation; the rest random.
                let shift = [0.3 * amplitude, -0.2 * amplitude, 0.1 * amplitude];
                rest.iter()
                    .map(|r| match f {
                        0 => *r,
                        1 => [r[0] + shift[0], r[1] + shift[1], r[2] + shift[2]],
                        _ => r.map(|x| x + amplitude * (2.0 * rng.unit() - 1.0)),
                    })
                    .collect()
            })
            .collect();
        return Ok(Sequence {
            name: "synthetic",
            markers,
            truth: None,
        });
    }
    let surface = marker_surface_points(rig, &mesh)?;
    let source = mesh.source.clone();
    // One marker is enough to build the sequence; the rig's own markers ride the true surface.
    let truth = GroundTruth::new(mesh, 1, 0).map_err(|source_err| CliError::GroundTruth {
        path: source,
        source: source_err,
    })?;
    let frames: Vec<usize> = (0..truth.frames.len()).collect();
    let markers = frames
        .iter()
        .map(|&f| {
            let positions = truth.positions(f);
            surface.iter().map(|s| s.interpolate(&positions)).collect()
        })
        .collect();
    Ok(Sequence {
        name: "ground truth",
        markers,
        truth: Some((truth, frames)),
    })
}

/// Run `facebake verify`.
pub fn run(args: &VerifyArgs) -> Result<ExitCode, CliError> {
    let bytes = read_file(&args.rig)?;
    let rig = load_rig(&args.rig, &bytes)?;
    let mesh = load_matching_mesh(&args.mesh, args.mesh_name.as_deref(), rig.vertex_count())?;
    if let Some(w) = mesh.units_warning() {
        eprintln!("warning: {w}");
    }
    let diagonal = mesh.diagonal();
    let regions = super::render::rig_regions(&rig, &mesh)?;
    let seq = sequence(&rig, mesh)?;
    let reference = SparseF64::from_rig(&rig);
    let space = rig.space();
    let mut out = vec![[0i32; 3]; rig.vertex_count()];
    let mut max_error = 0.0f64;
    let mut truth_errors = Vec::new();
    let (mut played, mut truths) = (Vec::new(), Vec::new());
    let bar = progress(seq.markers.len(), "verifying", args.json);
    for (f, markers) in seq.markers.iter().enumerate() {
        let q = markers_to_rig(&rig, markers, f, &args.mesh)?;
        let got = deform_to_asset(&rig, &args.rig, &q, &mut out)?;
        // The f64 evaluation sees the same (quantised) marker positions as the runtime.
        let exact_markers: Vec<[f64; 3]> = q.iter().map(|p| space.to_asset_f64(*p)).collect();
        max_error = max_error.max(max_distance(&got, &reference.frame(&exact_markers)));
        if let Some((truth, frames)) = &seq.truth {
            truths.push(truth.positions(frames[f]));
            truth.skin_errors(&got, &truths[f], &mut truth_errors);
        }
        played.push(got);
        bar.inc(1);
    }
    bar.finish_and_clear();
    let metres = args.units.to_metres();
    let fraction = max_error / diagonal;
    let summary = VerifySummary {
        rig: args.rig.clone(),
        mesh: args.mesh.clone(),
        sequence: seq.name,
        frames: seq.markers.len(),
        diagonal,
        max_error,
        max_error_fraction: fraction,
        max_error_mm: max_error * metres * 1000.0,
        tolerance_fraction: TOLERANCE_FRACTION,
        passed: fraction <= TOLERANCE_FRACTION,
        ground_truth: seq.truth.as_ref().map(|_| stats(&mut truth_errors, metres)),
        structure: super::render::verify_structure(&regions, &played, &truths, &seq.truth),
    };
    if args.json {
        print_json(&summary);
    } else {
        let mut out = String::new();
        outln!(out,
            "verified {} against the f64 evaluation of its own numbers over the {} sequence ({} frames)",
            summary.rig.display(),
            summary.sequence,
            summary.frames
        );
        outln!(out,
            "  runtime vs f64  max {:.3e} of the diagonal ({:.6} mm; diagonal {:.1} mm), allowed {:.0e}",
            summary.max_error_fraction,
            summary.max_error_mm,
            diagonal * metres * 1000.0,
            TOLERANCE_FRACTION
        );
        if let Some(gt) = &summary.ground_truth {
            outln!(out, "  vs ground truth {gt} (skin vertices)");
        }
        out.push_str(&super::render::structure_text(&summary.structure, true));
        if summary.passed {
            outln!(out, "PASS: the runtime matches the f64 evaluation");
        }
        emit(&out);
    }
    if summary.passed {
        Ok(ExitCode::SUCCESS)
    } else {
        eprintln!(
            "verification failed: the runtime differs from the f64 evaluation by {:.3e} of the \
             diagonal (allowed {TOLERANCE_FRACTION:.0e}); exit code {EXIT_VERIFY_FAILED}",
            summary.max_error_fraction
        );
        Ok(ExitCode::from(EXIT_VERIFY_FAILED))
    }
}
