//! `facebake play`: a marker capture through a rig, out to `.npy` (and optionally `.glb`).

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::Args;
use serde::Serialize;

use super::frame_selection::{parse_frames, FrameSelection};
use super::{
    deform_to_asset, emit, ensure_parent, load_rig, marker_names, markers_to_rig, parse_units,
    print_json, progress, read_file, CliError,
};
use facebake::io::capture::read_capture_with_units;
use facebake::io::gltf_anim::write_animated_glb;
use facebake::io::gltf_check::BufferAccess;
use facebake::io::gltf_mesh::load_mesh_with_vertices;
use facebake::io::npy::write_npy_f32;
use facebake::model::{Capture, FaceMesh, Units};
use facebake::morph_basis::{BasisOptions, DEFAULT_MAX_ERROR_MM, DEFAULT_MAX_TARGETS};

/// Arguments of `facebake play`.
#[derive(Debug, Args)]
pub struct PlayArgs {
    /// The rig blob (.fbk).
    #[arg(value_name = "RIG")]
    pub rig: PathBuf,
    /// The marker capture (.csv, .trc, .c3d, or a packed take from `facebake pack`, known by
    /// its magic). Its markers are matched to the rig's by name.
    /// A rig baked with a capture (`bake --capture`) takes the actor's raw capture: head motion,
    /// missing samples and retargeting are solved per frame by the runtime. A rig baked without
    /// one takes markers in the character's own space, its stages at rest taking out head
    /// motion and filling gaps; a rig without stages (or `--deform-only`) takes markers
    /// already in the character's space, with none missing.
    #[arg(long, value_name = "CAPTURE")]
    pub markers: PathBuf,
    /// Play the markers through the deformer alone, as `Rig::deform` does, skipping the rig's
    /// capture stages: markers in the character's space and the head's frame, none missing.
    #[arg(long)]
    pub deform_only: bool,
    /// Units of the capture's numbers, overriding what the file says (needed for a CSV
    /// without a `# units=` line).
    #[arg(long, value_name = "UNITS", value_parser = parse_units)]
    pub capture_units: Option<Units>,
    /// Units of the mesh (and so of the rig and the outputs): mm, cm, m or in.
    #[arg(long, value_name = "UNITS", value_parser = parse_units, default_value = "m")]
    pub units: Units,
    /// Where to write the frames: a float32 NumPy array, frames × vertices × 3, glTF vertex
    /// order, mesh units.
    #[arg(short, long, value_name = "NPY")]
    pub output: PathBuf,
    /// Also write an animated .glb (needs --mesh): the mesh's file with everything in it kept
    /// (other meshes, materials, textures) and the played frames as a few morph targets (a PCA
    /// basis) animated at the capture's rate, LINEAR between frames.
    #[arg(long, value_name = "GLB", requires = "mesh")]
    pub glb: Option<PathBuf>,
    /// The bound on the .glb's reconstruction error: the smallest basis whose 99th-percentile
    /// vertex error is within it, in millimetres.
    #[arg(long, value_name = "MM", default_value_t = DEFAULT_MAX_ERROR_MM, requires = "glb")]
    pub glb_max_error_mm: f64,
    /// The most morph targets in the .glb (the offset included, so at least 2), bound met or
    /// not.
    #[arg(long, value_name = "N", default_value_t = DEFAULT_MAX_TARGETS,
          value_parser = clap::builder::TypedValueParser::map(
              clap::value_parser!(u32).range(2..), |n| n as usize), requires = "glb")]
    pub glb_max_targets: usize,
    /// The mesh the rig was baked from, for --glb.
    #[arg(long, value_name = "MESH")]
    pub mesh: Option<PathBuf>,
    /// Which mesh of the file (default: the one with a primitive of the rig's vertex count;
    /// of several, the face's).
    #[arg(long, value_name = "NAME")]
    pub mesh_name: Option<String>,
    /// Frames (0-based) to put in the .glb, each at its time in the take (default: all):
    /// frames and ranges, comma-separated: `0..100` (end excluded), `0..1590:10` (every tenth),
    /// `100..` (to the end), `0,388,1122`.
    #[arg(long, value_name = "RANGES", value_parser = parse_frames, requires = "glb")]
    pub frames: Option<FrameSelection>,
    /// Rig markers the capture may lack, comma-separated (rebuilt or held every frame). Any
    /// other rig marker missing from the capture is an error, except the rig's virtual markers
    /// and anchors.
    #[arg(long, value_name = "NAMES", value_delimiter = ',')]
    pub allow_missing: Vec<String>,
    /// Print a JSON summary on stdout instead of text (and no progress bar).
    #[arg(long)]
    pub json: bool,
}

/// A raw take is refused on a rig without capture stages (or played `--deform-only`) when its
/// markers sit, at the median frame, further than this fraction of the rig's marker extent
/// (bounding-box diagonal) from the rig's rest markers after the best rigid fit, or the best fit
/// turns them by more than [`RAW_TAKE_TURN_DEGREES`]; on a rig with stages at rest, which take
/// the head's motion out, by the first alone.
pub const RAW_TAKE_RESIDUAL_FRACTION: f64 = 0.03;
/// See [`RAW_TAKE_RESIDUAL_FRACTION`].
pub const RAW_TAKE_TURN_DEGREES: f64 = 3.0;

/// Rig markers a rig's capture stages never expect in a take: its anchors (samples ignored) and
/// its virtual markers, recognised as the markers no other marker is filled from (the baker
/// fills only from markers the actor's capture had).
fn never_captured(stages: &facebake_runtime::stages::Stages<'_>, markers: usize) -> Vec<bool> {
    let mut referenced = vec![false; markers];
    for w in stages.fill.0.chunks_exact(4) {
        let (k, weight) =
            facebake_runtime::fixed::unpack_influence(u32::from_le_bytes([w[0], w[1], w[2], w[3]]));
        if weight > 0 {
            if let Some(r) = referenced.get_mut(usize::from(k)) {
                *r = true;
            }
        }
    }
    let mut out: Vec<bool> = referenced.iter().map(|r| !r).collect();
    for &a in stages.anchors.0 {
        if let Some(o) = out.get_mut(usize::from(a)) {
            *o = true;
        }
    }
    out
}

/// Levenshtein distance between two names, by characters.
fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut diagonal = row[0];
        row[0] = i + 1;
        for (j, &cb) in b.iter().enumerate() {
            let next = (diagonal + usize::from(ca != cb))
                .min(row[j] + 1)
                .min(row[j + 1] + 1);
            diagonal = row[j + 1];
            row[j + 1] = next;
        }
    }
    row[b.len()]
}

/// Up to three of `candidates` nearest to `name` by edit distance, quoted and escaped.
pub fn nearest_names(name: &str, candidates: &[&str]) -> String {
    let mut scored: Vec<(usize, &str)> = candidates
        .iter()
        .map(|c| (edit_distance(&name.to_lowercase(), &c.to_lowercase()), *c))
        .collect();
    scored.sort();
    scored
        .iter()
        .take(3)
        .map(|(_, c)| format!("\"{}\"", facebake::io::escape_control(c)))
        .collect::<Vec<_>>()
        .join(", ")
}

/// Refuses a take that looks like an actor's raw capture (another face; head motion too unless
/// `turned`, for stages at rest) on a rig that plays character-space markers: without capture
/// stages, or with stages at rest.
fn check_character_space(
    rig: &facebake_runtime::Rig<'_>,
    path: &Path,
    frames: &[Vec<[f64; 3]>],
    turned: bool,
) -> Result<(), CliError> {
    let space = rig.space();
    let rest: Vec<[f64; 3]> = (0..rig.marker_count())
        .filter_map(|i| rig.marker_rest(i))
        .map(|q| space.to_asset_f64(q))
        .collect();
    if frames.is_empty() || rest.len() < 3 || frames[0].len() != rest.len() {
        return Ok(());
    }
    let (lo, hi) = facebake::model::bounds(rest.iter().copied());
    let extent = facebake::mesh::distance(&lo, &hi).max(f64::MIN_POSITIVE);
    // At most 200 frames evenly spread: the median frame decides.
    let mut fits: Vec<(f64, f64)> = evenly_spaced(frames.len(), 200)
        .into_iter()
        .filter_map(|f| {
            let fit = facebake::stages::rigid::kabsch(&frames[f], &rest).ok()?;
            let residual = fit.rms_residual(&frames[f], &rest);
            let cos = ((fit.rotation.trace() - 1.0) / 2.0).clamp(-1.0, 1.0);
            Some((residual / extent, cos.acos().to_degrees()))
        })
        .collect();
    if fits.is_empty() {
        return Ok(());
    }
    fits.sort_by(|a, b| a.0.total_cmp(&b.0));
    let residual = fits[fits.len() / 2].0;
    fits.sort_by(|a, b| a.1.total_cmp(&b.1));
    let turn = fits[fits.len() / 2].1;
    if residual > RAW_TAKE_RESIDUAL_FRACTION || (!turned && turn > RAW_TAKE_TURN_DEGREES) {
        let rig_kind = if turned {
            "A rig baked without a capture plays markers in the character's own space (its \
             stages take the head's motion out)"
        } else {
            "A rig without capture stages plays markers already in the character's space"
        };
        return Err(CliError::input(
            path,
            format!(
                "the markers do not look like the character's: at the median frame they are {:.1}% \
                 of the rig's marker extent off its rest markers after the best rigid fit, turned by \
                 {turn:.1}°. {rig_kind}; for an actor's raw take bake the rig with `bake --capture \
                 <a take of this actor>` (or check --capture-units / --units)",
                100.0 * residual
            ),
        ));
    }
    Ok(())
}

/// Whether `rig`'s capture stages were baked without a capture, from its own markers at rest
/// (`facebake::bake::at_rest`): the actor's neutral pose is then the rig's rest markers, to
/// within [`AT_REST_TOLERANCE`] of their extent.
pub fn stages_at_rest(rig: &facebake_runtime::Rig<'_>) -> bool {
    let Some(stages) = rig.stages() else {
        return false;
    };
    let (space, actor) = (rig.space(), stages.actor_space);
    let rest: Vec<[f64; 3]> = (0..rig.marker_count())
        .filter_map(|i| rig.marker_rest(i))
        .map(|q| space.to_asset_f64(q))
        .collect();
    let (lo, hi) = facebake::model::bounds(rest.iter().copied());
    let extent = facebake::mesh::distance(&lo, &hi);
    rest.len() == rig.marker_count()
        && rest.iter().enumerate().all(|(i, r)| {
            stages.neutral(i).is_some_and(|n| {
                facebake::mesh::distance(r, &actor.to_asset_f64(n)) <= AT_REST_TOLERANCE * extent
            })
        })
}

/// See [`stages_at_rest`]: a capture's neutral pose is an actor's, centimetres from the
/// character's markers; stages at rest hold the rig's own, rounded to Q8.24 actor units.
pub const AT_REST_TOLERANCE: f64 = 1e-5;

/// What `play` reports.
#[derive(Debug, Serialize)]
pub struct PlaySummary {
    /// The rig.
    pub rig: PathBuf,
    /// The capture.
    pub capture: PathBuf,
    /// Frames played.
    pub frames: usize,
    /// Vertices per frame.
    pub vertices: usize,
    /// Markers read per frame.
    pub markers: usize,
    /// Capture rate.
    pub rate_hz: f64,
    /// Units of the capture's numbers.
    pub capture_units: String,
    /// Units of the mesh and the outputs.
    pub mesh_units: String,
    /// The `.npy` written.
    pub output: PathBuf,
    /// The `.glb` written, if any.
    pub glb: Option<GlbSummary>,
    /// Frames in the `.glb`.
    pub glb_frames: Vec<usize>,
    /// What the capture stages did, for a rig that has them.
    pub stages: Option<StagesSummary>,
}

/// What an animated `.glb` holds and how well it reproduces the frames.
#[derive(Debug, Serialize)]
pub struct GlbSummary {
    /// The file.
    pub path: PathBuf,
    /// Frames (animation keys).
    pub frames: usize,
    /// Their rate: key `i` is at frame number / rate seconds.
    pub rate_hz: f64,
    /// Morph targets: the offset and the PCA components.
    pub targets: usize,
    /// 99th-percentile vertex error of the reconstruction against the played frames, mm.
    pub p99_error_mm: f64,
    /// Largest vertex error, mm.
    pub max_error_mm: f64,
    /// The bound on the 99th percentile, mm.
    pub bound_mm: f64,
    /// Whether the 99th percentile is within it (else the target cap was reached).
    pub bound_met: bool,
    /// 99th-percentile angle between reconstructed and exact normals, degrees.
    pub normal_p99_degrees: Option<f64>,
    /// Largest such angle, degrees.
    pub normal_max_degrees: Option<f64>,
    /// The file's size, bytes.
    pub bytes: usize,
    /// Its size with one morph target per frame instead, bytes.
    pub one_target_per_frame_bytes: usize,
}

impl GlbSummary {
    /// One line for the text output.
    pub fn text(&self) -> String {
        let normals = match (self.normal_p99_degrees, self.normal_max_degrees) {
            (Some(p99), Some(max)) => format!("; normals p99 {p99:.2}°, max {max:.1}°"),
            _ => String::new(),
        };
        format!(
            "{}: {} frames at {} Hz as {} morph targets (an offset and {} PCA components; p99 \
             error {:.3} mm, max {:.3} mm, bound {} mm{}{normals}); {} against {} with one \
             target per frame",
            self.path.display(),
            self.frames,
            self.rate_hz,
            self.targets,
            self.targets.saturating_sub(1),
            self.p99_error_mm,
            self.max_error_mm,
            self.bound_mm,
            if self.bound_met {
                ""
            } else {
                " NOT MET: more targets needed"
            },
            super::bytes_text(self.bytes),
            super::bytes_text(self.one_target_per_frame_bytes),
        )
    }
}

/// Writes the animated `.glb` of `frames` (played frames `numbers` of a take at `rate_hz`, mesh
/// units `units`) for `mesh` at `path`, with at most `max_targets` targets and a p99 bound of
/// `max_error_mm`.
pub fn write_take_glb(
    path: &Path,
    mesh: &FaceMesh,
    (frames, numbers): (&[Vec<[f64; 3]>], &[usize]),
    rate_hz: f64,
    units: Units,
    (max_error_mm, max_targets): (f64, usize),
) -> Result<GlbSummary, CliError> {
    if !(rate_hz.is_finite() && rate_hz > 0.0) {
        return Err(CliError::input(
            path,
            format!("the capture's rate {rate_hz} Hz gives no frame times"),
        ));
    }
    let mm_per_unit = units.to_metres() * 1000.0;
    let times: Vec<f64> = numbers.iter().map(|&f| f as f64 / rate_hz).collect();
    let options = BasisOptions {
        max_error: max_error_mm / mm_per_unit,
        max_targets,
    };
    ensure_parent(path)?;
    let written = write_animated_glb(
        path,
        mesh,
        frames,
        &times,
        &options,
        BufferAccess::AssetFolder,
    )?;
    Ok(GlbSummary {
        path: path.to_path_buf(),
        frames: written.frames,
        rate_hz,
        targets: written.targets,
        p99_error_mm: written.p99_error * mm_per_unit,
        max_error_mm: written.max_error * mm_per_unit,
        bound_mm: max_error_mm,
        bound_met: written.bound_met,
        normal_p99_degrees: written.normal_degrees.map(|d| d.0),
        normal_max_degrees: written.normal_degrees.map(|d| d.1),
        bytes: written.bytes,
        one_target_per_frame_bytes: written.one_target_per_frame_bytes,
    })
}

/// What the runtime's capture stages did over a whole capture.
#[derive(Debug, Default, Serialize)]
pub struct StagesSummary {
    /// Samples missing in the capture.
    pub missing_samples: usize,
    /// Samples given but rejected (out of range, or implausibly far from neutral).
    pub rejected_samples: usize,
    /// Samples rebuilt from neighbouring markers.
    pub rebuilt_samples: usize,
    /// Samples held at their last good value.
    pub held_samples: usize,
    /// Frames whose head fit was held from an earlier frame.
    pub frames_head_held: usize,
    /// Frames with fewer than three head markers, the pose tracked from the last frame.
    pub frames_head_tracked: usize,
    /// Mean RMS residual of the head fit, mm (over fitted frames).
    pub head_residual_mean_mm: f64,
    /// Largest RMS residual of the head fit, mm.
    pub head_residual_max_mm: f64,
}

/// Play an actor's capture (metres) through a rig's capture stages: vertices per frame (asset
/// units) and the summary.
pub fn play_stages(
    rig: &facebake_runtime::Rig<'_>,
    path: &Path,
    frames: &[Vec<Option<[f64; 3]>>],
    mut each: impl FnMut(usize, &[[f64; 3]]),
) -> Result<StagesSummary, CliError> {
    use facebake_runtime::RigidStatus;
    let stages = rig
        .stages()
        .ok_or_else(|| CliError::input(path, "the rig has no capture stages"))?;
    let actor_space = stages.actor_space;
    let unit = f64::from(actor_space.half_extent) * 1000.0 / f64::from(1u32 << 24);
    let space = rig.space();
    let mut state = facebake_runtime::PlayState::new();
    let mut out = vec![[0i32; 3]; rig.vertex_count()];
    let mut s = StagesSummary::default();
    let mut fitted = 0usize;
    for (f, frame) in frames.iter().enumerate() {
        let mut unconvertible = 0;
        let actor: Vec<Option<[i32; 3]>> = frame
            .iter()
            .map(|p| {
                let q = p.and_then(|p| actor_space.to_rig_f64(p).ok());
                unconvertible += usize::from(p.is_some() && q.is_none());
                q
            })
            .collect();
        let report = rig
            .play(&mut state, &actor, &mut out)
            .map_err(|e| CliError::input(path, format!("frame {f}: {e}")))?;
        s.missing_samples += frame.iter().filter(|p| p.is_none()).count();
        s.rejected_samples += report.rejected.len() + unconvertible;
        s.rebuilt_samples += report.rebuilt.len();
        s.held_samples += report.held.len();
        match report.rigid {
            RigidStatus::Held(_) => s.frames_head_held += 1,
            RigidStatus::Tracked { .. } => s.frames_head_tracked += 1,
            RigidStatus::Fitted { .. } => {
                let r = f64::from(report.rigid_residual) * unit;
                s.head_residual_mean_mm += r;
                s.head_residual_max_mm = s.head_residual_max_mm.max(r);
                fitted += 1;
            }
            RigidStatus::NotUsed => {}
        }
        let positions: Vec<[f64; 3]> = out.iter().map(|q| space.to_asset_f64(*q)).collect();
        each(f, &positions);
    }
    s.head_residual_mean_mm /= fitted.max(1) as f64;
    Ok(s)
}

/// Marker positions per frame in mesh units, from a capture whose markers are already in the
/// rig's order. Errors at the first missing sample, naming the frame and the marker.
pub fn capture_frames(
    capture: &Capture,
    mesh_units: Units,
) -> Result<Vec<Vec<[f64; 3]>>, CliError> {
    let scale = capture.units.to_metres() / mesh_units.to_metres();
    let missing = capture.missing_count();
    capture
        .frames
        .iter()
        .enumerate()
        .map(|(f, frame)| {
            frame
                .iter()
                .enumerate()
                .map(|(m, s)| {
                    s.map(|p| p.map(|x| x * scale)).ok_or_else(|| {
                        CliError::input(
                            &capture.source,
                            format!(
                                "frame {f} (counting from 0): marker \"{}\" has no sample ({missing} missing samples \
                                 in all; filling gaps is not supported yet)",
                                facebake::io::escape_control(&capture.marker_names[m])
                            ),
                        )
                    })
                })
                .collect()
        })
        .collect()
}

/// The mesh's primitive with the rig's vertex count (the face, if several have it).
pub fn load_matching_mesh(
    path: &Path,
    name: Option<&str>,
    vertices: usize,
) -> Result<FaceMesh, CliError> {
    Ok(load_mesh_with_vertices(path, name, None, vertices)?)
}

/// `count` frame indices evenly spaced over `0..frames`, first and last included.
pub fn evenly_spaced(frames: usize, count: usize) -> Vec<usize> {
    match (frames, count) {
        (0, _) | (_, 0) => Vec::new(),
        (n, c) if c >= n => (0..n).collect(),
        (_, 1) => vec![0],
        (n, c) => (0..c).map(|i| i * (n - 1) / (c - 1)).collect(),
    }
}

/// Run `facebake play`.
pub fn run(args: &PlayArgs) -> Result<ExitCode, CliError> {
    let bytes = read_file(&args.rig)?;
    let rig = load_rig(&args.rig, &bytes)?;
    let names = marker_names(&rig);
    let name_refs: Vec<&str> = names.iter().map(String::as_str).collect();
    let full = read_capture_with_units(&args.markers, args.capture_units)?;
    if let Some(w) = full.units_warning() {
        eprintln!("warning: {w}");
    }
    let stages_used = rig.stages().filter(|_| !args.deform_only);
    // A rig with capture stages rebuilds markers the capture lacks (virtual markers); without
    // stages every rig marker must be in the capture.
    let absent: Vec<&str> = name_refs
        .iter()
        .copied()
        .filter(|n| full.marker_index(n).is_none())
        .collect();
    if let Some(stages) = stages_used {
        let never = never_captured(stages, name_refs.len());
        let unexpected: Vec<&str> = absent
            .iter()
            .copied()
            .filter(|n| {
                let j = name_refs.iter().position(|r| r == n).unwrap_or(0);
                !never[j] && !args.allow_missing.iter().any(|a| a == n)
            })
            .collect();
        if !unexpected.is_empty() && absent.len() < name_refs.len() {
            let others: Vec<&str> = full
                .marker_names
                .iter()
                .map(String::as_str)
                .filter(|c| !name_refs.contains(c))
                .collect();
            let list = unexpected
                .iter()
                .map(|n| {
                    format!(
                        "\"{}\" (nearest names in the capture: {})",
                        facebake::io::escape_control(n),
                        nearest_names(
                            n,
                            if others.is_empty() {
                                &name_refs
                            } else {
                                &others
                            }
                        )
                    )
                })
                .collect::<Vec<_>>()
                .join("; ");
            return Err(CliError::input(
                &args.markers,
                format!(
                    "the capture lacks {} of the rig's markers: {list}. Rename them in the \
                     capture, or pass --allow-missing {} to rebuild them every frame",
                    unexpected.len(),
                    unexpected.join(",")
                ),
            ));
        }
    }
    let capture = if stages_used.is_some() && absent.len() < name_refs.len() {
        let present: Vec<&str> = name_refs
            .iter()
            .copied()
            .filter(|n| !absent.contains(n))
            .collect();
        let mut selected = full.select(&present)?;
        let columns: Vec<Option<usize>> = name_refs
            .iter()
            .map(|n| present.iter().position(|p| p == n))
            .collect();
        selected.frames = selected
            .frames
            .iter()
            .map(|f| columns.iter().map(|c| c.and_then(|c| f[c])).collect())
            .collect();
        selected.marker_names = names.clone();
        selected
    } else {
        full.select(&name_refs)?
    };
    let raw = capture.in_metres().frames;
    let frames = match stages_used {
        Some(_) => Vec::new(),
        None => capture_frames(&capture, args.units)?,
    };
    if stages_used.is_some() && stages_at_rest(&rig) {
        // Stages baked without a capture play the character's own takes, turned or not: the
        // frames that have every marker decide.
        let complete: Vec<Vec<[f64; 3]>> = raw
            .iter()
            .filter_map(|f| f.iter().copied().collect::<Option<Vec<_>>>())
            .collect();
        check_character_space(&rig, &args.markers, &complete, true)?;
    } else {
        check_character_space(&rig, &args.markers, &frames, false)?;
    }
    let frame_count = capture.frame_count();
    let n = rig.vertex_count();
    // Check everything the .glb needs before the long part.
    let glb = match &args.glb {
        Some(glb_path) => {
            let mesh_path = args.mesh.as_deref().ok_or_else(|| {
                CliError::input(glb_path, "writing a .glb needs the rig's mesh (--mesh)")
            })?;
            let mesh = load_matching_mesh(mesh_path, args.mesh_name.as_deref(), n)?;
            if !(args.glb_max_error_mm.is_finite() && args.glb_max_error_mm >= 0.0) {
                return Err(CliError::input(
                    glb_path,
                    format!(
                        "--glb-max-error-mm {} is not a distance ≥ 0",
                        args.glb_max_error_mm
                    ),
                ));
            }
            let chosen = args
                .frames
                .clone()
                .unwrap_or_else(FrameSelection::all)
                .resolve(frame_count)
                .map_err(|e| CliError::input(&args.markers, e))?;
            Some((glb_path.clone(), mesh, chosen))
        }
        None => None,
    };
    let bar = progress(frame_count, "playing", args.json);
    let mut out = vec![[0i32; 3]; n];
    let mut data: Vec<f32> = Vec::with_capacity(frame_count * n * 3);
    let stages = if stages_used.is_some() {
        let summary = play_stages(&rig, &args.rig, &raw, |_, positions| {
            data.extend(positions.iter().flatten().map(|&x| x as f32));
            bar.inc(1);
        })?;
        let given =
            frame_count * names.len() - summary.missing_samples.min(frame_count * names.len());
        if given > 0 && 2 * summary.rejected_samples > given {
            return Err(CliError::input(
                &args.markers,
                format!(
                    "{} of the capture's {given} samples were rejected as outside the rig's \
                     plausible range: is the capture in {} (the units it was read in)? \
                     (--capture-units)",
                    summary.rejected_samples, capture.units
                ),
            ));
        }
        Some(summary)
    } else {
        for (f, markers) in frames.iter().enumerate() {
            let q = markers_to_rig(&rig, markers, f, &args.markers)?;
            let positions = deform_to_asset(&rig, &args.rig, &q, &mut out)?;
            data.extend(positions.iter().flatten().map(|&x| x as f32));
            bar.inc(1);
        }
        None
    };
    bar.finish_and_clear();
    ensure_parent(&args.output)?;
    write_npy_f32(&args.output, &[frame_count, n, 3], &data)
        .map_err(|e| CliError::io(&args.output, e))?;
    let mut glb_frames = Vec::new();
    let mut glb_summary = None;
    if let Some((path, mesh, chosen)) = &glb {
        let frames: Vec<Vec<[f64; 3]>> = chosen
            .iter()
            .map(|&f| {
                data[f * n * 3..(f + 1) * n * 3]
                    .chunks_exact(3)
                    .map(|c| [c[0], c[1], c[2]].map(f64::from))
                    .collect()
            })
            .collect();
        glb_summary = Some(write_take_glb(
            path,
            mesh,
            (&frames, chosen),
            capture.rate_hz,
            args.units,
            (args.glb_max_error_mm, args.glb_max_targets),
        )?);
        glb_frames = chosen.clone();
    }
    let summary = PlaySummary {
        rig: args.rig.clone(),
        capture: args.markers.clone(),
        frames: frame_count,
        vertices: n,
        markers: names.len(),
        rate_hz: capture.rate_hz,
        capture_units: capture.units.to_string(),
        mesh_units: args.units.to_string(),
        output: args.output.clone(),
        glb: glb_summary,
        glb_frames,
        stages,
    };
    if args.json {
        print_json(&summary);
    } else {
        let mut out = String::new();
        outln!(out,
            "played {} frames ({} Hz, {} markers, capture in {}, mesh in {}) through {} ({} vertices)",
            summary.frames,
            summary.rate_hz,
            summary.markers,
            summary.capture_units,
            summary.mesh_units,
            summary.rig.display(),
            summary.vertices
        );
        outln!(
            out,
            "wrote {} ({} × {} × 3 float32)",
            summary.output.display(),
            summary.frames,
            summary.vertices
        );
        if !absent.is_empty() && summary.stages.is_some() {
            outln!(
                out,
                "not in the capture, rebuilt or held every frame: {}",
                facebake::io::escape_control(&absent.join(", "))
            );
        }
        if let Some(st) = &summary.stages {
            outln!(
                out,
                "capture stages: {} samples missing, {} rejected; {} rebuilt from neighbours, {} held; \
                 head fit held in {} frames, tracked in {}, \
                 head residual mean {:.3} mm, max {:.3} mm",
                st.missing_samples,
                st.rejected_samples,
                st.rebuilt_samples,
                st.held_samples,
                st.frames_head_held,
                st.frames_head_tracked,
                st.head_residual_mean_mm,
                st.head_residual_max_mm
            );
        }
        if let Some(glb) = &summary.glb {
            outln!(out, "wrote {}", glb.text());
        }
        emit(&out);
    }
    Ok(ExitCode::SUCCESS)
}
