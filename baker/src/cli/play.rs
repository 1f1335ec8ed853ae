//! `facebake play`: a marker capture through a rig, out to `.npy` (and optionally `.glb`).

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::Args;
use serde::Serialize;

use super::{
    deform_to_asset, emit, ensure_parent, load_rig, marker_names, markers_to_rig, parse_units,
    print_json, progress, read_file, CliError,
};
use crate::io::capture::{read_capture_with_units, Capture, Units};
use crate::io::glb::write_glb_with_morphs;
use crate::io::gltf_mesh::{load_mesh, FaceMesh};
use crate::io::npy::write_npy_f32;

/// Frames put in the `.glb` when `--frames` is not given: this many, evenly spaced.
pub const DEFAULT_GLB_FRAMES: usize = 10;

/// Arguments of `facebake play`.
#[derive(Debug, Args)]
pub struct PlayArgs {
    /// The rig blob (.fbk).
    #[arg(value_name = "RIG")]
    pub rig: PathBuf,
    /// The marker capture (.csv, .trc or .c3d). Its markers are matched to the rig's by name;
    /// it must be in the character's space (no solving for head motion yet).
    #[arg(long, value_name = "CAPTURE")]
    pub markers: PathBuf,
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
    /// Also write a .glb of the mesh with the chosen frames as morph targets (needs --mesh).
    #[arg(long, value_name = "GLB", requires = "mesh")]
    pub glb: Option<PathBuf>,
    /// The mesh the rig was baked from, for --glb.
    #[arg(long, value_name = "MESH")]
    pub mesh: Option<PathBuf>,
    /// Which mesh of the file (default: the first).
    #[arg(long, value_name = "NAME")]
    pub mesh_name: Option<String>,
    /// Frames (0-based, comma-separated) to put in the .glb (default: 10 evenly spaced).
    #[arg(long, value_name = "F,F,...", value_delimiter = ',', requires = "glb")]
    pub frames: Option<Vec<usize>>,
    /// Print a JSON summary on stdout instead of text (and no progress bar).
    #[arg(long)]
    pub json: bool,
}

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
    pub glb: Option<PathBuf>,
    /// Frames in the `.glb`.
    pub glb_frames: Vec<usize>,
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
                                capture.marker_names[m]
                            ),
                        )
                    })
                })
                .collect()
        })
        .collect()
}

/// Load a mesh and check it has the rig's vertex count.
pub fn load_matching_mesh(
    path: &Path,
    name: Option<&str>,
    vertices: usize,
) -> Result<FaceMesh, CliError> {
    let mesh = load_mesh(path, name, None)?;
    if mesh.positions.len() != vertices {
        return Err(CliError::input(
            path,
            format!(
                "mesh \"{}\" has {} vertices; the rig has {vertices} (not the mesh it was baked from?)",
                mesh.mesh_name,
                mesh.positions.len()
            ),
        ));
    }
    Ok(mesh)
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
    let capture = read_capture_with_units(&args.markers, args.capture_units)?.select(&name_refs)?;
    let frames = capture_frames(&capture, args.units)?;
    let n = rig.vertex_count();
    // Check everything the .glb needs before the long part.
    let glb = match &args.glb {
        Some(glb_path) => {
            let mesh_path = args.mesh.as_deref().ok_or_else(|| {
                CliError::input(glb_path, "writing a .glb needs the rig's mesh (--mesh)")
            })?;
            let mesh = load_matching_mesh(mesh_path, args.mesh_name.as_deref(), n)?;
            let chosen = match &args.frames {
                Some(list) => list.clone(),
                None => evenly_spaced(frames.len(), DEFAULT_GLB_FRAMES),
            };
            if let Some(&bad) = chosen.iter().find(|&&f| f >= frames.len()) {
                return Err(CliError::input(
                    &args.markers,
                    format!(
                        "--frames asks for frame {bad}; the capture has {} (0 to {})",
                        frames.len(),
                        frames.len().saturating_sub(1)
                    ),
                ));
            }
            Some((glb_path.clone(), mesh, chosen))
        }
        None => None,
    };
    let bar = progress(frames.len(), "playing", args.json);
    let mut out = vec![[0i32; 3]; n];
    let mut data: Vec<f32> = Vec::with_capacity(frames.len() * n * 3);
    for (f, markers) in frames.iter().enumerate() {
        let q = markers_to_rig(&rig, markers, f, &args.markers)?;
        let positions = deform_to_asset(&rig, &args.rig, &q, &mut out)?;
        data.extend(positions.iter().flatten().map(|&x| x as f32));
        bar.inc(1);
    }
    bar.finish_and_clear();
    ensure_parent(&args.output)?;
    write_npy_f32(&args.output, &[frames.len(), n, 3], &data)
        .map_err(|e| CliError::io(&args.output, e))?;
    let mut glb_frames = Vec::new();
    if let Some((path, mesh, chosen)) = &glb {
        let morphs: Vec<(String, Vec<[f32; 3]>)> = chosen
            .iter()
            .map(|&f| {
                let frame = &data[f * n * 3..(f + 1) * n * 3];
                (
                    format!("frame {f}"),
                    frame.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
                )
            })
            .collect();
        ensure_parent(path)?;
        write_glb_with_morphs(path, mesh, &morphs)?;
        glb_frames = chosen.clone();
    }
    let summary = PlaySummary {
        rig: args.rig.clone(),
        capture: args.markers.clone(),
        frames: frames.len(),
        vertices: n,
        markers: names.len(),
        rate_hz: capture.rate_hz,
        capture_units: capture.units.to_string(),
        mesh_units: args.units.to_string(),
        output: args.output.clone(),
        glb: glb.as_ref().map(|g| g.0.clone()),
        glb_frames,
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
        if let Some(path) = &summary.glb {
            outln!(
                out,
                "wrote {} (frames {:?} as morph targets)",
                path.display(),
                summary.glb_frames
            );
        }
        emit(&out);
    }
    Ok(ExitCode::SUCCESS)
}
