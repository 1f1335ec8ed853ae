//! `facebake render`: PNG contact sheets of played frames (and of the markers on the rest mesh),
//! with the structure metrics; plus the hooks through which `demo` and `verify` draw and measure.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::Args;
use facebake_runtime::Rig;
use serde::Serialize;

use super::play::evenly_spaced;
use super::play::load_matching_mesh;
use super::{emit, load_rig, marker_names, print_json, read_file, CliError};
use facebake::io::npy::read_npy_f32;
use facebake::metrics::{FrameMetrics, Regions, TakeMetrics};
use facebake::model::FaceMesh;
use facebake::render::{write_png, MarkerSheet, Sheet, SheetFrame, PANEL};

/// One frame's positions (vertices or markers).
pub type Positions = Vec<[f64; 3]>;

/// The demo's ground-truth frames drawn in its close-up of the eyes; its other frames go to the
/// close-up of the mouth.
pub const CLOSE_UP_EYES: [&str; 2] = ["blink", "surprise"];

/// Rows of a sheet when `--frames` is not given: this many, evenly spaced.
pub const DEFAULT_ROWS: usize = 6;

/// Arguments of `facebake render`.
#[derive(Debug, Args)]
pub(crate) struct RenderArgs {
    /// The played frames: a float32 `.npy`, frames × vertices × 3, as `play` writes it.
    #[arg(value_name = "NPY")]
    pub frames_npy: PathBuf,
    /// The mesh the frames deform (its triangles and rest pose), glTF/GLB.
    #[arg(long, value_name = "MESH")]
    pub mesh: PathBuf,
    /// Which mesh of the file (default: the one with a primitive of the frames' vertex count;
    /// of several, the face's).
    #[arg(long, value_name = "NAME")]
    pub mesh_name: Option<String>,
    /// The true frames, same shape: the sheet then shows truth, result and error.
    #[arg(long, value_name = "NPY")]
    pub truth: Option<PathBuf>,
    /// The rig that played them: its markers are drawn on the marker sheet and pick the static
    /// region of a mesh without morph targets.
    #[arg(long, value_name = "RIG")]
    pub rig: Option<PathBuf>,
    /// Frames (0-based) to draw, one row each, in increasing order (default: 6 evenly
    /// spaced): frames and ranges, comma-separated, as `play --frames` takes them (`0,388`,
    /// `0..1590:300`).
    #[arg(long, value_name = "RANGES", value_parser = super::frame_selection::parse_frames)]
    pub frames: Option<super::frame_selection::FrameSelection>,
    /// Where to write the contact sheet (PNG).
    #[arg(short, long, value_name = "PNG")]
    pub output: PathBuf,
    /// Also write the rest mesh with the rig's markers here (PNG; needs --rig).
    #[arg(long, value_name = "PNG", requires = "rig")]
    pub marker_sheet: Option<PathBuf>,
    /// What the panels frame: the whole head, or close up the mouth (its lips' rims wherever
    /// the frames take them) or the eyes (both lids' rims).
    #[arg(long, value_enum, default_value_t = Focus::Head)]
    pub focus: Focus,
    /// Panel size in pixels.
    #[arg(long, value_name = "PX", default_value_t = PANEL as u32, value_parser = clap::value_parser!(u32).range(64..=2048))]
    pub panel: u32,
    /// The top of the heat maps' colour scale, mm (default: the drawn frames' 95th-percentile
    /// error, or their largest displacement, rounded up): give two sheets the same to compare
    /// them, or a small one to see the skin's errors beside a mouth interior's large ones.
    #[arg(long, value_name = "MM", value_parser = parse_scale_mm)]
    pub scale_mm: Option<f64>,
    /// Remove each frame's best rigid motion (over the static region) before measuring: for
    /// frames that carry head motion.
    #[arg(long)]
    pub remove_rigid: bool,
    /// Print a JSON summary on stdout instead of text.
    #[arg(long)]
    pub json: bool,
}

/// `--scale-mm`: a positive, finite number of millimetres.
fn parse_scale_mm(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(mm) if mm > 0.0 && mm.is_finite() => Ok(mm),
        _ => Err(format!("{text:?} is not a positive number of millimetres")),
    }
}

/// What a sheet's panels frame (`render --focus`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum Focus {
    /// The whole head.
    Head,
    /// The mouth, close up.
    Mouth,
    /// Both eyes, close up.
    Eyes,
}

impl Focus {
    /// Its name in titles.
    fn title(self) -> &'static str {
        match self {
            Self::Head => "",
            Self::Mouth => ", MOUTH",
            Self::Eyes => ", EYES",
        }
    }

    /// The vertices a close-up frames: the rims' vertices of the mouth or of the eyes that
    /// `regions` found on `mesh` (empty for the whole head). A close-up of an opening the mesh
    /// does not have is an error naming it.
    fn vertices(self, regions: &Regions, mesh: &Path) -> Result<Vec<u32>, CliError> {
        let pairs: Vec<&[u32; 2]> = match self {
            Self::Head => return Ok(Vec::new()),
            Self::Mouth => regions.lips.iter().collect(),
            Self::Eyes => regions.eyes.iter().flatten().collect(),
        };
        if pairs.is_empty() {
            let what = if self == Self::Mouth {
                "a mouth"
            } else {
                "eyes"
            };
            return Err(CliError::input(
                mesh,
                format!("--focus: no rim pairs across {what} were found on this mesh's skin (its openings: see `facebake place`)"),
            ));
        }
        Ok(pairs.into_iter().flatten().copied().collect())
    }
}

/// Structure metrics of a take: per frame, and the worst over it.
#[derive(Debug, Serialize)]
pub(crate) struct Structure {
    /// How the static region was chosen, and its size.
    pub static_rule: facebake::metrics::StaticRule,
    /// Vertices in the static region.
    pub static_vertices: usize,
    /// Rim pairs across the mouth, and across the eyes.
    pub rim_pairs: (usize, usize),
    /// Per frame (frame label, metrics).
    pub frames: Vec<(String, FrameMetrics)>,
    /// The worst over the take.
    pub take: TakeMetrics,
}

/// What `render` reports.
#[derive(Debug, Serialize)]
pub(crate) struct RenderSummary {
    /// The sheets written.
    pub files: Vec<PathBuf>,
    /// Frames drawn.
    pub frames: Vec<usize>,
    /// The top of the heat maps' colour scale, mm (`--scale-mm`, or the drawn frames').
    pub scale_mm: f64,
    /// Whether some drawn value lies above it (drawn in the top colour).
    pub clipped: bool,
    /// The structure metrics over every frame of the `.npy`.
    pub structure: Structure,
}

/// Frames of vertex positions.
type Frames = Vec<Vec<[f64; 3]>>;

/// The frames of a `play` output and their vertex count: `vertices` if given, else as many as
/// the file says (then at least one).
fn read_frames(path: &Path, vertices: Option<usize>) -> Result<(Frames, usize), CliError> {
    let (shape, data) = read_npy_f32(path).map_err(|e| CliError::input(path, e.to_string()))?;
    match (shape.as_slice(), vertices) {
        ([_, n, 3], Some(v)) if *n == v => {}
        ([_, n, 3], None) if *n > 0 => {}
        (_, Some(v)) => {
            return Err(CliError::input(
                path,
                format!("shape {shape:?}: expected frames × {v} × 3 (the mesh's vertices)"),
            ))
        }
        (_, None) => {
            return Err(CliError::input(
                path,
                format!("shape {shape:?}: expected frames × vertices × 3"),
            ))
        }
    }
    let n = shape[1];
    let frames = data
        .chunks_exact(3 * n)
        .map(|f| {
            f.chunks_exact(3)
                .map(|p| [p[0], p[1], p[2]].map(f64::from))
                .collect()
        })
        .collect();
    Ok((frames, n))
}

/// The rig's markers at rest (asset units) and its head markers.
fn rig_markers(rig: &Rig<'_>) -> (Vec<[f64; 3]>, Vec<usize>) {
    let space = rig.space();
    let rest = (0..rig.marker_count())
        .map(|m| space.to_asset_f64(rig.marker_rest(m).unwrap_or_default()))
        .collect();
    let head = rig
        .stages()
        .map(|s| s.head_markers().iter().map(|&h| usize::from(h)).collect())
        .unwrap_or_default();
    (rest, head)
}

/// The regions of `mesh` (errors name it).
pub(crate) fn regions(
    mesh: &FaceMesh,
    markers: &[[f64; 3]],
    head: &[usize],
) -> Result<Regions, CliError> {
    Regions::for_mesh(mesh, markers, head).map_err(|e| CliError::input(&mesh.source, e.to_string()))
}

/// The regions of the mesh a rig was baked from, with the rig's markers.
pub(crate) fn rig_regions(rig: &Rig<'_>, mesh: &FaceMesh) -> Result<Regions, CliError> {
    let (markers, head) = rig_markers(rig);
    regions(mesh, &markers, &head)
}

/// `verify`'s structure metrics: `played` frames against `truths` (empty: none), labelled with
/// the ground truth's frame names when there is one.
pub(crate) fn verify_structure(
    regions: &Regions,
    played: &[Vec<[f64; 3]>],
    truths: &[Vec<[f64; 3]>],
    truth: &Option<(facebake::ground_truth::GroundTruth, Vec<usize>)>,
) -> Structure {
    let label = |f: usize| match truth {
        Some((t, frames)) => t.frames[frames[f]].name.clone(),
        None => format!("frame {f}"),
    };
    let truths = (!truths.is_empty()).then_some(truths);
    structure(regions, played, truths, label, false)
}

/// Measure every frame and the take; `labels` name the frames.
pub(crate) fn structure(
    regions: &Regions,
    frames: &[Vec<[f64; 3]>],
    truth: Option<&[Vec<[f64; 3]>]>,
    labels: impl Fn(usize) -> String,
    remove_rigid: bool,
) -> Structure {
    let (per_frame, take) = regions.measure_take(frames, truth, remove_rigid);
    Structure {
        static_rule: regions.static_rule.clone(),
        static_vertices: regions.static_vertices.len(),
        rim_pairs: (regions.lips.len(), regions.eyes.iter().map(Vec::len).sum()),
        frames: per_frame
            .into_iter()
            .enumerate()
            .map(|(f, m)| (labels(f), m))
            .collect(),
        take,
    }
}

/// The text report of a [`Structure`]: the take's worst, then one line per frame if `per_frame`.
pub(crate) fn structure_text(s: &Structure, per_frame: bool) -> String {
    let mut out = String::new();
    let region = match s.static_rule {
        facebake::metrics::StaticRule::NoMarkers => {
            "no static region (the mesh has no morph targets: --rig finds it from the rig's markers)"
                .to_string()
        }
        ref rule => format!("static region {} vertices ({rule:?})", s.static_vertices),
    };
    outln!(
        out,
        "  structure       {region}, {} lip and {} eyelid rim pairs",
        s.rim_pairs.0,
        s.rim_pairs.1
    );
    outln!(out, "    worst over {} frames: {}", s.take.frames, s.take);
    if per_frame {
        for (label, m) in &s.frames {
            outln!(out, "    {label:>16}: {m}");
        }
    }
    out
}

/// The played frames a sheet draws from: the frames, the true ones and the markers (per
/// frame), the last two if known.
type Played<'a> = (
    &'a [Vec<[f64; 3]>],
    Option<&'a [Vec<[f64; 3]>]>,
    Option<&'a [Vec<[f64; 3]>]>,
);

/// A sheet of `rows` (label, frame index) of the `played` frames over `mesh`, the truth beside
/// them if given, in `panel`-pixel panels framing `focus` ([`Sheet::focus`]).
fn sheet_of(
    title: String,
    mesh: &FaceMesh,
    (frames, truth, markers): Played<'_>,
    rows: &[(String, usize)],
    (panel, focus): (usize, Vec<u32>),
) -> Sheet {
    Sheet {
        title,
        rest: mesh.positions.clone(),
        triangles: mesh.triangles.clone(),
        frames: rows
            .iter()
            .filter(|(_, f)| *f < frames.len())
            .map(|(label, f)| SheetFrame {
                label: label.clone(),
                positions: frames[*f].clone(),
                truth: truth.and_then(|t| t.get(*f).cloned()),
                markers: markers.and_then(|m| m.get(*f).cloned()).unwrap_or_default(),
            })
            .collect(),
        panel,
        focus,
        scale_mm: None,
    }
}

/// Write `sheet` to `path`.
fn write_sheet(path: &Path, image: &facebake::render::Image) -> Result<(), CliError> {
    super::ensure_parent(path)?;
    write_png(path, image).map_err(|e| CliError::input(path, e.to_string()))
}

/// The marker sheet of `names` at `rest` on `mesh`, written to `path`.
pub(crate) fn write_marker_sheet(
    path: &Path,
    title: String,
    mesh: &FaceMesh,
    names: &[String],
    rest: &[[f64; 3]],
) -> Result<(), CliError> {
    let sheet = MarkerSheet {
        title,
        rest: mesh.positions.clone(),
        triangles: mesh.triangles.clone(),
        markers: names.iter().cloned().zip(rest.iter().copied()).collect(),
        panel: 2 * PANEL,
    };
    write_sheet(path, &sheet.render())
}

/// Run `facebake render`.
pub(crate) fn run(args: &RenderArgs) -> Result<ExitCode, CliError> {
    let (frames, n) = read_frames(&args.frames_npy, None)?;
    let mesh = load_matching_mesh(&args.mesh, args.mesh_name.as_deref(), n)?;
    if let Some(w) = mesh.units_warning() {
        eprintln!("warning: {w}");
    }
    let truth = args
        .truth
        .as_deref()
        .map(|p| {
            let (t, _) = read_frames(p, Some(n))?;
            if t.len() == frames.len() {
                Ok(t)
            } else {
                Err(CliError::input(
                    p,
                    format!("{} true frames for {} played frames", t.len(), frames.len()),
                ))
            }
        })
        .transpose()?;
    let bytes = args.rig.as_deref().map(read_file).transpose()?;
    let rig = match (&args.rig, &bytes) {
        (Some(path), Some(b)) => Some(load_rig(path, b)?),
        _ => None,
    };
    let (markers, head) = rig.as_ref().map(rig_markers).unwrap_or_default();
    let regions = regions(&mesh, &markers, &head)?;
    if args.remove_rigid && regions.static_vertices.len() < 3 {
        return Err(CliError::input(
            &args.mesh,
            "--remove-rigid fits each frame's rigid motion over the static region, and this mesh \
             has none to fit it on (no morph targets: give --rig, whose markers find it)",
        ));
    }
    let chosen = match &args.frames {
        Some(selection) => selection
            .resolve(frames.len())
            .map_err(|e| CliError::input(&args.frames_npy, e))?,
        None => evenly_spaced(frames.len(), DEFAULT_ROWS),
    };
    let rows: Vec<(String, usize)> = chosen.iter().map(|&f| (format!("FRAME {f}"), f)).collect();
    let title = format!(
        "{} ON {}{}",
        file_name(&args.frames_npy),
        file_name(&args.mesh),
        args.focus.title()
    );
    let focus = args.focus.vertices(&regions, &args.mesh)?;
    let played = (frames.as_slice(), truth.as_deref(), None);
    let sheet = Sheet {
        scale_mm: args.scale_mm,
        ..sheet_of(title, &mesh, played, &rows, (args.panel as usize, focus))
    };
    let (scale_mm, clipped) = sheet.scale();
    write_sheet(&args.output, &sheet.render())?;
    let mut files = vec![args.output.clone()];
    if let (Some(path), Some(rig)) = (&args.marker_sheet, &rig) {
        let title = format!(
            "MARKERS OF {}",
            file_name(args.rig.as_deref().unwrap_or(path))
        );
        write_marker_sheet(path, title, &mesh, &marker_names(rig), &markers)?;
        files.push(path.clone());
    }
    let structure = structure(
        &regions,
        &frames,
        truth.as_deref(),
        |f| format!("frame {f}"),
        args.remove_rigid,
    );
    let summary = RenderSummary {
        files,
        frames: chosen,
        scale_mm,
        clipped,
        structure,
    };
    if args.json {
        print_json(&summary);
    } else {
        let mut out = String::new();
        for f in &summary.files {
            outln!(out, "wrote {}", f.display());
        }
        let above = if summary.clipped {
            " (larger values in its top colour)"
        } else {
            ""
        };
        outln!(out, "  colour scale   0 to {} mm{above}", summary.scale_mm);
        out.push_str(&structure_text(&summary.structure, false));
        emit(&out);
    }
    Ok(ExitCode::SUCCESS)
}

fn file_name(path: &Path) -> String {
    path.file_name().map_or_else(
        || path.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    )
}

/// The demo's ground-truth pictures and metrics: the true frames (`.npy`), the contact sheet of
/// `rows` (truth, result, error) and the marker sheet, written into `dir`. Returns the metrics and (file, what) pairs.
pub(crate) fn demo_ground_truth(
    dir: &Path,
    truth: &facebake::ground_truth::GroundTruth,
    (played, markers): (&[Positions], &[Positions]),
    (names, rest): (&[String], &[[f64; 3]]),
    rows: &[&str],
) -> Result<(Structure, Vec<(PathBuf, String)>), CliError> {
    let truths: Vec<Vec<[f64; 3]>> = (0..truth.frames.len())
        .map(|f| truth.positions(f))
        .collect();
    let rows: Vec<(String, usize)> = rows
        .iter()
        .filter_map(|name| {
            let f = truth.frames.iter().position(|fr| fr.name == *name)?;
            Some((name.to_string(), f))
        })
        .collect();
    let mesh = &truth.mesh;
    let truth_path = dir.join("facecap_truth.npy");
    let flat: Vec<f32> = truths
        .iter()
        .flatten()
        .flatten()
        .map(|&x| x as f32)
        .collect();
    let shape = [truths.len(), mesh.positions.len(), 3];
    facebake::io::npy::write_npy_f32(&truth_path, &shape, &flat)
        .map_err(|e| CliError::io(&truth_path, e))?;
    let regions = regions(mesh, &truth.marker_rest(), &[])?;
    let draw = |rows: &[(String, usize)], focus: Focus| -> Result<Sheet, CliError> {
        let title = format!(
            "FACECAP GROUND TRUTH{}, DEFAULT BAKE: TRUTH / RESULT / ERROR",
            focus.title()
        );
        let focus = focus.vertices(&regions, &mesh.source)?;
        let played = (played, Some(truths.as_slice()), Some(markers));
        Ok(sheet_of(title, mesh, played, rows, (PANEL, focus)))
    };
    let sheet_path = dir.join("facecap_sheet.png");
    let whole = draw(&rows, Focus::Head)?;
    write_sheet(&sheet_path, &whole.render())?;
    // Close-ups where the eye goes: the mouth in the frames that move it, the eyes in the rest.
    let at_eyes = |(name, _): &&(String, usize)| CLOSE_UP_EYES.contains(&name.as_str());
    let (eye_rows, mouth_rows): (Vec<_>, Vec<_>) = rows.iter().partition(at_eyes);
    let mut close_ups = Vec::new();
    for (file, part, rows) in [
        ("facecap_mouth_sheet.png", Focus::Mouth, mouth_rows),
        ("facecap_eyes_sheet.png", Focus::Eyes, eye_rows),
    ] {
        let rows: Vec<(String, usize)> = rows.into_iter().cloned().collect();
        let path = dir.join(file);
        let close_up = Sheet {
            scale_mm: Some(whole.scale().0),
            ..draw(&rows, part)?
        };
        write_sheet(&path, &close_up.render())?;
        close_ups.push(path);
    }
    let marker_path = dir.join("facecap_markers.png");
    let title = format!("FACECAP: {} LAYOUT MARKERS", rest.len());
    write_marker_sheet(&marker_path, title, mesh, names, rest)?;
    let s = structure(
        &regions,
        played,
        Some(&truths),
        |f| truth.frames[f].name.clone(),
        false,
    );
    Ok((
        s,
        vec![
            (truth_path, "the true frames, for `render --truth`".into()),
            (sheet_path, "ground truth: truth, result, error".into()),
            (
                close_ups[0].clone(),
                "the same, the mouth close up (jaw open, funnel, smile, blend)".into(),
            ),
            (
                close_ups[1].clone(),
                "the same, the eyes close up (blink, surprise)".into(),
            ),
            (
                marker_path,
                "the ground truth's markers on the rest mesh".into(),
            ),
        ],
    ))
}

/// The demo's capture pictures and metrics: the contact sheet of `rows` of the `played` frames
/// (result with the retargeted `markers`, and displacement) and the marker sheet of the
/// capture's layout, written into `dir`.
pub(crate) fn demo_capture(
    dir: &Path,
    mesh: &FaceMesh,
    (played, markers): (&[Positions], &[Positions]),
    rows: &[(String, usize)],
    names: &[String],
    rest: &[[f64; 3]],
    head: &[usize],
) -> Result<(Structure, Vec<(PathBuf, String)>), CliError> {
    let rows: Vec<(String, usize)> = rows.iter().map(|(l, f)| (l.to_uppercase(), *f)).collect();
    let regions = regions(mesh, rest, head)?;
    let mut paths = Vec::new();
    let mut scale_mm = None;
    for (file, focus) in [
        ("jawmocap_sheet.png", Focus::Head),
        ("jawmocap_mouth_sheet.png", Focus::Mouth),
    ] {
        let title = format!(
            "JAWMOCAP ON FACECAP{}, DEFAULT BAKE: RESULT / DISPLACEMENT",
            focus.title()
        );
        let focus = focus.vertices(&regions, &mesh.source)?;
        let sheet = Sheet {
            scale_mm,
            ..sheet_of(
                title,
                mesh,
                (played, None, Some(markers)),
                &rows,
                (PANEL, focus),
            )
        };
        // The close-up shares the whole head's scale.
        scale_mm = scale_mm.or(Some(sheet.scale().0));
        let path = dir.join(file);
        write_sheet(&path, &sheet.render())?;
        paths.push(path);
    }
    let sheet_path = paths[0].clone();
    let marker_path = dir.join("jawmocap_markers.png");
    let title = format!("JAWMOCAP LAYOUT ON FACECAP: {} MARKERS", names.len());
    write_marker_sheet(&marker_path, title, mesh, names, rest)?;
    let s = structure(&regions, played, None, |f| format!("frame {f}"), false);
    Ok((
        s,
        vec![
            (sheet_path, "capture: result and displacement".into()),
            (paths[1].clone(), "the same, the mouth close up".into()),
            (marker_path, "the capture's markers on the rest mesh".into()),
        ],
    ))
}
