//! `facebake compensate`: a capture with the head's rigid motion removed, written as CSV, with
//! the per-frame residual of the head fit and the estimated rotation pivot (paper 003 §2).

use std::ops::Range;
use std::path::PathBuf;
use std::process::ExitCode;

use clap::Args;
use serde::Serialize;

use super::bake::{parse_head, parse_neutral};
use super::{emit, parse_units, print_json, CliError};
use facebake::io::capture::{read_capture_with_units, write_csv};
use facebake::io::gltf_mesh::load_mesh;
use facebake::io::layout::read_layout;
use facebake::model::{place_markers, Capture, Units, DEFAULT_MAX_SNAP_FRACTION};
use facebake::pivot::{estimate_pivot, PivotEstimate};
use facebake::stages::rigid::{kabsch, most_rigid_subset, three_point, RigidTransform};
use facebake::stages::{neutral_pose, HeadMarkers, Neutral};
use facebake::{BakeOptions, Scene};

/// Arguments of `facebake compensate`.
#[derive(Debug, Args)]
pub struct CompensateArgs {
    /// The capture (.c3d, .trc or .csv).
    #[arg(value_name = "CAPTURE")]
    pub capture: PathBuf,
    /// Units of the capture's numbers, overriding what the file says.
    #[arg(long, value_name = "UNITS", value_parser = parse_units)]
    pub capture_units: Option<Units>,
    /// The neutral pose the frames are brought back to: `auto` (the first frame with every
    /// marker present and none a ghost, with the still frames after it averaged in), a frame
    /// `N` or a range `A..B` averaged.
    #[arg(long, value_name = "FRAMES", default_value = "auto", value_parser = parse_neutral)]
    pub neutral: Neutral,
    /// Head markers: comma-separated names, `auto` (the 5 most rigid) or `auto:N`. With
    /// `--mesh` and `--layout`, `auto` picks among the skull markers and the inner eye
    /// corners found on the mesh, as `bake` does; without them, among every marker, and a take
    /// that never raises the brows makes the brows look as rigid as the skull.
    #[arg(long, value_name = "NAMES", default_value = "auto", value_parser = parse_head)]
    pub head_markers: HeadMarkers,
    /// The face mesh the capture drives (.glb or .gltf), with `--layout`: where the skull
    /// and the eyes are, so that `auto` never picks a brow, cheek, jaw or lip marker.
    #[arg(long, value_name = "MESH", requires = "layout")]
    pub mesh: Option<PathBuf>,
    /// Which mesh of the file (default: the face's, the largest primitive of any mesh with a
    /// mouth and two eyes; else the first).
    #[arg(long, value_name = "NAME", requires = "mesh")]
    pub mesh_name: Option<String>,
    /// Which primitive of the mesh (default: the face, the largest with a mouth and two eyes;
    /// else the first triangle primitive).
    #[arg(long, value_name = "INDEX", requires = "mesh")]
    pub primitive: Option<usize>,
    /// The marker layout on `--mesh` (.toml or .json), as `bake` takes it.
    #[arg(long, value_name = "LAYOUT", requires = "mesh")]
    pub layout: Option<PathBuf>,
    /// The rigid fit: least squares over every present head marker (kabsch), or paper 003's
    /// three-point method on the first three head markers (three-point).
    #[arg(long, value_enum, default_value_t = Fit::Kabsch)]
    pub fit: Fit,
    /// Where to write the compensated capture (CSV, the capture's units).
    #[arg(short, long, value_name = "CSV")]
    pub output: PathBuf,
    /// Print a JSON summary on stdout instead of text.
    #[arg(long)]
    pub json: bool,
}

/// How each frame's head motion is fitted.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum, Serialize)]
pub enum Fit {
    /// Least squares (Kabsch/Horn), reflection-safe, any n ≥ 3.
    Kabsch,
    /// Paper 003 §2.1: unit edge vectors of three markers and their cross product; needs the
    /// first three head markers present.
    ThreePoint,
}

/// What `compensate` reports.
#[derive(Debug, Serialize)]
pub struct CompensateSummary {
    /// The capture.
    pub capture: PathBuf,
    /// Its frames.
    pub frames: usize,
    /// Its units.
    pub units: String,
    /// The frames taken as the neutral pose.
    pub neutral_frames: Range<usize>,
    /// Markers no neutral frame has, taken from the nearest frame that has them.
    pub neutral_filled: Vec<String>,
    /// Head markers used.
    pub head_markers: Vec<String>,
    /// Where they came from: as named, or the most rigid of which markers.
    pub head_markers_from: String,
    /// The fit used.
    pub fit: Fit,
    /// RMS residual of the head fit per frame, capture units (`None` where it could not be fitted
    /// and the previous fit was held).
    pub residuals: Vec<Option<f64>>,
    /// Mean and largest of those.
    pub residual_mean: f64,
    /// Largest residual.
    pub residual_max: f64,
    /// The rotation pivot, capture space and units.
    pub pivot: Option<PivotEstimate>,
    /// The compensated capture.
    pub output: PathBuf,
}

/// Run `facebake compensate`.
pub fn run(args: &CompensateArgs) -> Result<ExitCode, CliError> {
    let capture = read_capture_with_units(&args.capture, args.capture_units)?;
    let bad = |m: String| CliError::input(&args.capture, m);
    let n = capture.marker_names.len();
    let all: Vec<usize> = (0..n).collect();
    let neutral = neutral_pose(&capture, &all, &args.neutral)?;
    let neutral_filled = neutral.filled_names(&capture, &all);
    let (neutral, range) = (neutral.pose, neutral.frames);
    let candidates = head_candidates(args, &capture)?;
    // The markers `auto` picks among: the candidates found on the mesh, else every marker.
    let pool = candidates.as_ref().map_or(&all, |c| &c.0);
    let complete = facebake::stages::complete_sample(&capture, pool);
    let head: Vec<usize> = match &args.head_markers {
        HeadMarkers::Named(names) => names
            .iter()
            .map(|h| {
                capture
                    .marker_index(h)
                    .ok_or_else(|| bad(format!("no head marker named {h:?}")))
            })
            .collect::<Result<_, _>>()?,
        HeadMarkers::MostRigid(_) if complete.is_empty() => {
            return Err(bad(format!(
                "no frame has every {}, so the most rigid cannot be picked: name the head markers (--head-markers A,B,C)",
                if candidates.is_some() { "candidate head marker" } else { "marker" }
            )));
        }
        HeadMarkers::MostRigid(k) => {
            let (picked, _) = most_rigid_subset(&complete, (*k).min(pool.len()))
                .map_err(|e| bad(format!("picking head markers: {e}")))?;
            let mut head: Vec<usize> = picked.iter().map(|&i| pool[i]).collect();
            head.sort_unstable();
            head
        }
        HeadMarkers::None => return Err(bad("compensation needs head markers".into())),
    };
    let mut last = RigidTransform::identity();
    let mut residuals = Vec::with_capacity(capture.frame_count());
    let mut frames = Vec::with_capacity(capture.frame_count());
    let mut head_frames = Vec::new();
    for frame in &capture.frames {
        let present: Vec<usize> = head
            .iter()
            .copied()
            .filter(|&h| frame[h].is_some())
            .collect();
        let from: Vec<[f64; 3]> = present.iter().map(|&h| neutral[h]).collect();
        let to: Vec<[f64; 3]> = present.iter().filter_map(|&h| frame[h]).collect();
        let fitted = match args.fit {
            Fit::Kabsch => kabsch(&from, &to),
            Fit::ThreePoint if present.len() >= 3 && present[..3] == head[..3] => {
                three_point(&[from[0], from[1], from[2]], &[to[0], to[1], to[2]])
            }
            Fit::ThreePoint => Err(facebake::stages::rigid::RigidError::TooFewPoints(
                present.len(),
            )),
        };
        match fitted {
            Ok(fit) => {
                residuals.push(Some(fit.rms_residual(&from, &to)));
                last = fit;
                if present.len() == head.len() {
                    head_frames.push(to);
                }
            }
            Err(_) => residuals.push(None),
        }
        frames.push(
            frame
                .iter()
                .map(|p| p.map(|p| last.apply_inverse(&p)))
                .collect(),
        );
    }
    let fitted: Vec<f64> = residuals.iter().flatten().copied().collect();
    let centre = [0, 1, 2].map(|c| neutral.iter().map(|p| p[c]).sum::<f64>() / n as f64);
    let size = neutral
        .iter()
        .map(|p| facebake::mesh::distance(p, &centre))
        .fold(0.0, f64::max);
    let pivot = estimate_pivot(&head_frames, centre, size.max(f64::MIN_POSITIVE));
    let out = Capture {
        source: args.output.clone(),
        rate_hz: capture.rate_hz,
        units: capture.units,
        marker_names: capture.marker_names.clone(),
        frames,
    };
    write_csv(&args.output, &out)?;
    let summary = CompensateSummary {
        capture: args.capture.clone(),
        frames: capture.frame_count(),
        units: capture.units.to_string(),
        neutral_frames: range,
        neutral_filled,
        head_markers: head
            .iter()
            .map(|&h| capture.marker_names[h].clone())
            .collect(),
        head_markers_from: match (&args.head_markers, &candidates) {
            (HeadMarkers::MostRigid(_), Some((pool, mesh))) => format!(
                "the most rigid over the capture of its {} skull markers and inner eye corners found on {}",
                pool.len(),
                mesh.display()
            ),
            (HeadMarkers::MostRigid(_), None) => format!(
                "the most rigid over the capture of all its {n} markers: without --mesh and --layout, \
                 markers the take never moves (brows, a still jaw) look as rigid as the skull"
            ),
            _ => "as named".into(),
        },
        fit: args.fit,
        residual_mean: fitted.iter().sum::<f64>() / fitted.len().max(1) as f64,
        residual_max: fitted.iter().copied().fold(0.0, f64::max),
        residuals,
        pivot,
        output: args.output.clone(),
    };
    if args.json {
        print_json(&summary);
    } else {
        let mut text = String::new();
        outln!(
            text,
            "compensated {} ({} frames, {}) with head markers {}, back to the neutral frames {:?}",
            summary.capture.display(),
            summary.frames,
            summary.units,
            summary.head_markers.join(", "),
            summary.neutral_frames
        );
        outln!(text, "  head markers  {}", summary.head_markers_from);
        if !summary.neutral_filled.is_empty() {
            outln!(
                text,
                "  neutral       no frame has every marker: taken from the nearest frames that have them: {}",
                summary.neutral_filled.join(", ")
            );
        }
        outln!(
            text,
            "  head fit      RMS residual mean {:.4}, max {:.4} {}; {} frames held the previous fit",
            summary.residual_mean,
            summary.residual_max,
            summary.units,
            summary.residuals.iter().filter(|r| r.is_none()).count()
        );
        if let Some(p) = &summary.pivot {
            outln!(
                text,
                "  pivot         {:.3?} {} (paper 003 §2.2), {:.3?} from the markers' centre; distances to it vary by {:.4} on average",
                p.pivot,
                summary.units,
                [0, 1, 2].map(|c| p.pivot[c] - centre[c]),
                p.mean_length_change
            );
        }
        outln!(text, "wrote {}", summary.output.display());
        emit(&text);
    }
    Ok(ExitCode::SUCCESS)
}

/// With `--mesh` and `--layout`: the capture's columns of the markers `bake` would let its head
/// fit choose from ([`facebake::Scene::head_candidates`]), and the mesh they were found on.
fn head_candidates(
    args: &CompensateArgs,
    capture: &Capture,
) -> Result<Option<(Vec<usize>, PathBuf)>, CliError> {
    let (Some(mesh_path), Some(layout_path)) = (&args.mesh, &args.layout) else {
        return Ok(None);
    };
    if !matches!(args.head_markers, HeadMarkers::MostRigid(_)) {
        return Ok(None);
    }
    let mesh = load_mesh(mesh_path, args.mesh_name.as_deref(), args.primitive)?;
    let layout = read_layout(layout_path)?;
    let placed = place_markers(&layout, &mesh, DEFAULT_MAX_SNAP_FRACTION * mesh.diagonal())?;
    let names = Scene::placed(&mesh, &placed)
        .head_candidates(&BakeOptions::product_default().surface)
        .map_err(|e| CliError::input(mesh_path, e.to_string()))?;
    let columns: Vec<usize> = names
        .iter()
        .filter_map(|name| capture.marker_index(name))
        .collect();
    if columns.len() < 3 {
        return Err(CliError::input(
            &args.capture,
            format!(
                "a head fit needs 3 markers, and the capture has {} of the skull markers and inner eye corners found on {} ({}): name the head markers (--head-markers A,B,C)",
                columns.len(),
                mesh_path.display(),
                names.join(", ")
            ),
        ));
    }
    Ok(Some((columns, mesh_path.clone())))
}
