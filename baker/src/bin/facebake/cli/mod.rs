//! The `facebake` command line: one module per subcommand, shared error type and helpers here.
//!
//! Every subcommand computes a summary (a `Serialize` struct), then prints it either as text or,
//! with `--json`, as one JSON document on stdout. Errors go to stderr as one line,
//! `error: <file>: <problem>`, and map to the exit codes in [`EXIT_CODES`].

/// Append one formatted line to a `String` (text output is built whole, then [`emit`]ted).
macro_rules! outln {
    ($out:expr, $($arg:tt)*) => {{
        use std::fmt::Write as _;
        let _ = writeln!($out, $($arg)*);
    }};
}

mod bake;
mod compensate;
mod demo;
mod frame_selection;
mod inspect;
mod mask_images;
mod mocap;
mod pack;
mod place;
mod play;
mod render;
mod values;
mod verify;

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Parser, Subcommand};
use facebake_runtime::{LoadError, Rig};

use facebake::bake::BakeError;
use facebake::ground_truth::GroundTruthError;
use facebake::io::capture::CaptureError;
use facebake::io::glb::GlbError;
use facebake::io::gltf_anim::GltfAnimError;
use facebake::io::gltf_mesh::MeshLoadError;
use facebake::model::LayoutError;
use facebake::model::Units;

/// The exit codes, as documented in `--help`.
pub const EXIT_CODES: &str = "\
Exit codes:
  0  success
  1  verification failed (`verify`: the runtime differs from the f64 evaluation by more than
     2e-5 of the mesh's bounding-box diagonal)
  2  bad input: a file that cannot be read, parsed or used, or bad arguments";

/// Exit code of a failed verification.
pub const EXIT_VERIFY_FAILED: u8 = 1;
/// Exit code of bad input.
pub const EXIT_BAD_INPUT: u8 = 2;

/// facebake: bake a face mesh and a marker layout into a small fixed-point rig, and play marker
/// captures through it.
#[derive(Debug, Parser)]
#[command(name = "facebake", version, after_help = EXIT_CODES)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands.
#[derive(Debug, Subcommand)]
// Parsed once per process: the size of the largest variant (bake's options) does not matter.
#[allow(clippy::large_enum_variant)]
pub enum Command {
    /// Bake a mesh and a marker layout into a rig blob (.fbk).
    #[command(after_help = EXIT_CODES)]
    Bake(bake::BakeArgs),
    /// Play a marker capture through a rig and write the deformed vertices (.npy, .glb).
    #[command(after_help = EXIT_CODES)]
    Play(play::PlayArgs),
    /// Compress a capture into a packed take (.fbt) that the runtime plays from flash.
    #[command(after_help = EXIT_CODES)]
    Pack(pack::PackArgs),
    /// Describe a rig blob: formats, counts, sizes, per-frame cost.
    #[command(after_help = EXIT_CODES)]
    Inspect(inspect::InspectArgs),
    /// Check a rig's fixed-point runtime against the f64 evaluation of the same rig (and, for
    /// meshes with morph targets, against the ground truth).
    #[command(after_help = EXIT_CODES)]
    Verify(verify::VerifyArgs),
    /// Bake and play the bundled FaceCap head end to end and report size, accuracy and speed.
    #[command(after_help = EXIT_CODES)]
    Demo(demo::DemoArgs),
    /// Remove the head's rigid motion from a capture (offline), report the head-fit residual
    /// per frame and estimate the rotation pivot.
    #[command(after_help = EXIT_CODES)]
    Compensate(compensate::CompensateArgs),
    /// Render a layout's mask sides (lips, eyelids) as PNGs in the mesh's cylindrical
    /// projection, to inspect or paint over for `bake --mask-image`.
    #[command(after_help = EXIT_CODES)]
    MaskImages(mask_images::MaskImagesArgs),
    /// Draw played frames (and a rig's markers) as PNG contact sheets; report structure metrics.
    Render(render::RenderArgs),
    /// Place a capture's markers on a face mesh (landmarks from its openings and nose, the rest
    /// warped from the actor, lip and eyelid markers on the lips and lids): a layout for `bake`.
    #[command(after_help = EXIT_CODES)]
    Place(place::PlaceArgs),
}

/// Why a command failed. Every variant's message names the file it is about.
#[derive(Debug, thiserror::Error)]
pub enum CliError {
    /// A mesh could not be loaded.
    #[error(transparent)]
    Mesh(#[from] MeshLoadError),
    /// A layout could not be read, written or placed.
    #[error(transparent)]
    Layout(#[from] LayoutError),
    /// A capture could not be read or written.
    #[error(transparent)]
    Capture(#[from] CaptureError),
    /// A GLB could not be written.
    #[error(transparent)]
    Glb(#[from] GlbError),
    /// An animated GLB could not be written.
    #[error(transparent)]
    GltfAnim(#[from] GltfAnimError),
    /// A capture's neutral pose is unusable (the message names the capture).
    #[error(transparent)]
    NeutralPose(#[from] facebake::stages::StagesError),
    /// A file could not be read or written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// A rig blob did not load.
    #[error("{}: not a loadable rig: {problem}", path.display())]
    Rig {
        /// The file.
        path: PathBuf,
        /// What the loader found (the runtime's error is `no_std` and has no `Error` impl).
        problem: LoadError,
    },
    /// The bake failed.
    #[error("{}: bake failed: {source}", path.display())]
    Bake {
        /// The layout that was baked.
        path: PathBuf,
        /// The cause.
        source: BakeError,
    },
    /// The mesh cannot serve as a ground truth.
    #[error("{}: no ground truth: {source}", path.display())]
    GroundTruth {
        /// The mesh.
        path: PathBuf,
        /// The cause.
        source: GroundTruthError,
    },
    /// Anything else wrong with an input file.
    #[error("{}: {message}", path.display())]
    Input {
        /// The file.
        path: PathBuf,
        /// The problem.
        message: String,
    },
}

impl CliError {
    /// An [`CliError::Input`] about `path`.
    pub fn input(path: &Path, message: impl Into<String>) -> Self {
        Self::Input {
            path: path.to_path_buf(),
            message: message.into(),
        }
    }

    /// An [`CliError::Io`] about `path`.
    pub fn io(path: &Path, source: std::io::Error) -> Self {
        Self::Io {
            path: path.to_path_buf(),
            source,
        }
    }
}

/// Parse the process arguments, run, print any error as one line and return the exit code.
pub fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(EXIT_BAD_INPUT)
        }
    }
}

/// Run one parsed command line. `Ok` carries the exit code (0, or 1 for a failed
/// verification); `Err` is bad input (exit code 2).
pub fn run(cli: Cli) -> Result<ExitCode, CliError> {
    match cli.command {
        Command::Bake(a) => bake::run(&a),
        Command::Play(a) => play::run(&a),
        Command::Pack(a) => pack::run(&a),
        Command::Inspect(a) => inspect::run(&a),
        Command::Verify(a) => verify::run(&a),
        Command::Demo(a) => demo::run(&a),
        Command::Compensate(a) => compensate::run(&a),
        Command::MaskImages(a) => mask_images::run(&a),
        Command::Render(a) => render::run(&a),
        Command::Place(a) => place::run(&a),
    }
}

/// Read a whole file.
pub fn read_file(path: &Path) -> Result<Vec<u8>, CliError> {
    facebake::io::read_bounded(path).map_err(|e| CliError::io(path, e))
}

/// Load a rig from blob bytes read from `path`.
pub fn load_rig<'a>(path: &Path, bytes: &'a [u8]) -> Result<Rig<'a>, CliError> {
    Rig::from_bytes(bytes).map_err(|problem| CliError::Rig {
        path: path.to_path_buf(),
        problem,
    })
}

/// Create the parent directory of an output file if it is missing.
pub fn ensure_parent(path: &Path) -> Result<(), CliError> {
    match path.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => {
            std::fs::create_dir_all(dir).map_err(|e| CliError::io(dir, e))
        }
        _ => Ok(()),
    }
}

/// Write `bytes` to `path`, creating its directory.
pub fn write_file(path: &Path, bytes: &[u8]) -> Result<(), CliError> {
    ensure_parent(path)?;
    std::fs::write(path, bytes).map_err(|e| CliError::io(path, e))
}

/// Write text to stdout. A closed pipe (`facebake inspect rig.fbk | head`) is not an error:
/// the reader has what it wanted, so the rest is dropped quietly instead of panicking.
pub fn emit(text: &str) {
    use std::io::Write as _;
    let mut stdout = std::io::stdout().lock();
    let _ = stdout
        .write_all(text.as_bytes())
        .and_then(|()| stdout.flush());
}

/// Bytes as "N bytes (x.y KiB)".
pub fn bytes_text(n: usize) -> String {
    format!("{n} bytes ({:.1} KiB)", n as f64 / 1024.0)
}

/// Print a summary as pretty JSON on stdout.
pub fn print_json(value: &impl serde::Serialize) {
    let mut text =
        serde_json::to_string_pretty(value).expect("summaries hold only finite numbers and text");
    text.push('\n');
    emit(&text);
}

/// A progress bar over `len` steps on stderr; hidden when stderr is not a terminal or `quiet`.
pub fn progress(len: usize, message: &'static str, quiet: bool) -> indicatif::ProgressBar {
    if quiet || !std::io::stderr().is_terminal() {
        return indicatif::ProgressBar::hidden();
    }
    let bar = indicatif::ProgressBar::new(len as u64);
    if let Ok(style) = indicatif::ProgressStyle::with_template(
        "{msg} [{bar:40}] {pos}/{len} frames ({per_sec}, eta {eta})",
    ) {
        bar.set_style(style.progress_chars("=> "));
    }
    bar.set_message(message);
    bar
}

/// Parse a length unit on the command line (`mm`, `cm`, `m`, `in`, or a long name).
pub fn parse_units(s: &str) -> Result<Units, String> {
    s.parse::<Units>().map_err(|e| e.to_string())
}

/// Convert one frame of marker positions (asset units) to rig units. `frame` is used in the
/// error, which names `path` and the marker.
pub fn markers_to_rig(
    rig: &Rig<'_>,
    markers: &[[f64; 3]],
    frame: usize,
    path: &Path,
) -> Result<Vec<[i32; 3]>, CliError> {
    let space = rig.space();
    markers
        .iter()
        .enumerate()
        .map(|(m, p)| {
            space.to_rig_f64(*p).map_err(|e| {
                let name = facebake::io::escape_control(rig.marker_names().nth(m).unwrap_or("?"));
                CliError::input(
                    path,
                    format!("frame {frame} (counting from 0), marker \"{name}\" at {p:?}: {e}"),
                )
            })
        })
        .collect()
}

/// Deform one frame with the rig loaded from `path` and return the vertices in asset units.
pub fn deform_to_asset(
    rig: &Rig<'_>,
    path: &Path,
    markers: &[[i32; 3]],
    out: &mut [[i32; 3]],
) -> Result<Vec<[f64; 3]>, CliError> {
    rig.deform(markers, out)
        .map_err(|e| CliError::input(path, e.to_string()))?;
    let space = rig.space();
    Ok(out.iter().map(|q| space.to_asset_f64(*q)).collect())
}

/// The rig's marker names, in marker order.
pub fn marker_names(rig: &Rig<'_>) -> Vec<String> {
    rig.marker_names().map(str::to_string).collect()
}

/// Largest distance between corresponding points.
pub fn max_distance(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(p, q)| facebake::mesh::distance(p, q))
        .fold(0.0, f64::max)
}

/// The weight format `Q(23−F).F` as text.
pub fn weight_format(frac_bits: u8) -> String {
    format!("Q{}.{}", 23 - i32::from(frac_bits), frac_bits)
}

/// The points of the mesh's surface at the rig's marker rest positions (markers at vertices
/// or placed on triangles by a layout): the closest surface point, within `1e-6 ×` the mesh's
/// diagonal, else an error naming the marker.
pub fn marker_surface_points(
    rig: &Rig<'_>,
    mesh: &facebake::model::FaceMesh,
) -> Result<Vec<facebake::mesh::SurfacePoint>, CliError> {
    let space = rig.space();
    let tolerance = 1e-6 * mesh.diagonal();
    let names = marker_names(rig);
    (0..rig.marker_count())
        .map(|m| {
            let p = space.to_asset_f64(rig.marker_rest(m).unwrap_or_default());
            match facebake::mesh::closest_point(&mesh.positions, &mesh.triangles, p) {
                Some(s) if s.distance <= tolerance => Ok(s),
                found => Err(CliError::input(
                    &mesh.source,
                    format!(
                        "the rig's marker \"{}\" is {:.3e} from the surface of mesh \"{}\"; a \
                         ground-truth check needs markers on it",
                        facebake::io::escape_control(&names[m]),
                        found.map_or(f64::INFINITY, |s| s.distance),
                        mesh.mesh_name
                    ),
                )),
            }
        })
        .collect()
}
