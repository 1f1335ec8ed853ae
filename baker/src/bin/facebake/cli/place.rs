//! `facebake place`: a capture's markers placed on a face mesh, written as a layout for `bake`.

use std::ops::Range;
use std::path::PathBuf;
use std::process::ExitCode;

use clap::Args;
use serde::Serialize;

use super::bake::parse_neutral;
use super::render::write_marker_sheet;
use super::{emit, parse_units, print_json, CliError};
use facebake::io::capture::read_capture_with_units;
use facebake::io::gltf_mesh::load_mesh;
use facebake::io::layout::write_layout;
use facebake::model::{place_markers, MarkerAnchor, Units, DEFAULT_MAX_SNAP_FRACTION};
use facebake::placement::{has_openings, place_aliased, PlacementError, FEATURE_MARKERS};
use facebake::stages::{neutral_pose, Neutral};

/// Arguments of `facebake place`.
#[derive(Debug, Args)]
pub struct PlaceArgs {
    /// The face mesh (.glb or .gltf): its mouth and eye openings give the landmarks; a face
    /// without them is placed from every landmark pinned (--pin).
    #[arg(long, value_name = "MESH")]
    pub mesh: PathBuf,
    /// Which mesh of the file (default: the face's, the largest primitive of any mesh with a
    /// mouth and two eyes; else the first).
    #[arg(long, value_name = "NAME")]
    pub mesh_name: Option<String>,
    /// Which primitive of the mesh (default: the face, the largest with a mouth and two eyes;
    /// else the first triangle primitive).
    #[arg(long, value_name = "INDEX")]
    pub primitive: Option<usize>,
    /// The actor's capture (C3D, TRC, CSV or a packed take) with the thesis' marker names: the
    /// corners of the mouth and eyes and the nose tip (`Mouth_Lend`, `Mouth_Rend`,
    /// `Leye_Outside`, `Leye_Inside`, `Reye_Outside`, `Reye_Inside`, `NoseHead`) are the
    /// landmarks, found on the mesh from its openings and its most forward point; `Mouth_Up`,
    /// `Mouth_UpL1`, `Mouth_UpR1`, `Mouth_Down`, `Mouth_DownL`, `Mouth_DownR`, `Leye_Up`,
    /// `Leye_Down`, `Reye_Up` and `Reye_Down` go on their lip or lid. A capture that names
    /// them otherwise says which is which with `--alias`.
    #[arg(long, value_name = "CAPTURE")]
    pub capture: PathBuf,
    /// Units of the capture's numbers, overriding what the file says.
    #[arg(long, value_name = "UNITS", value_parser = parse_units)]
    pub capture_units: Option<Units>,
    /// The actor's neutral pose, as `bake --capture` takes it: `auto` (the first frame with
    /// every marker present and none a ghost, else the first with half of them and the others
    /// from the nearest frames that have them), a frame `N` or a range `A..B` averaged
    /// (0-based, B excluded).
    #[arg(long, value_name = "FRAMES", default_value = "auto", value_parser = parse_neutral)]
    pub neutral: Neutral,
    /// A marker put at a glTF vertex of the mesh, as `NAME=VERTEX` (repeatable): where you know
    /// it belongs (a chin, which no landmark sees). It also anchors the warp of the others.
    #[arg(long = "pin", value_name = "NAME=VERTEX", value_parser = parse_pin)]
    pub pins: Vec<(String, u32)>,
    /// The actor's marker `ACTOR` is the thesis' `THESIS` (one of the names above), as
    /// `ACTOR=THESIS` (repeatable): for a capture with its own marker names. The layout keeps
    /// the actor's names; `--pin` takes them too.
    #[arg(long = "alias", value_name = "ACTOR=THESIS", value_parser = parse_alias)]
    pub aliases: Vec<(String, String)>,
    /// The layout to write (.toml or .json).
    #[arg(short, long, value_name = "LAYOUT")]
    pub output: PathBuf,
    /// Also draw the placed markers on the mesh here (PNG, front and side, each named), to see
    /// that each sits where the actor wore it.
    #[arg(long, value_name = "PNG")]
    pub marker_sheet: Option<PathBuf>,
    /// Print a JSON summary on stdout instead of text.
    #[arg(long)]
    pub json: bool,
}

/// Parse `--pin NAME=VERTEX`.
fn parse_pin(s: &str) -> Result<(String, u32), String> {
    let (name, vertex) = s
        .split_once('=')
        .ok_or_else(|| format!("{s:?}: expected NAME=VERTEX"))?;
    let vertex = vertex
        .trim()
        .parse::<u32>()
        .map_err(|_| format!("{s:?}: {vertex:?} is not a vertex index"))?;
    if name.trim().is_empty() {
        return Err(format!("{s:?}: no marker name"));
    }
    Ok((name.trim().to_string(), vertex))
}

/// Parse `--alias ACTOR=THESIS`.
fn parse_alias(s: &str) -> Result<(String, String), String> {
    let (actor, thesis) = s
        .split_once('=')
        .ok_or_else(|| format!("{s:?}: expected ACTOR=THESIS"))?;
    let (actor, thesis) = (actor.trim(), thesis.trim());
    if actor.is_empty() || thesis.is_empty() {
        return Err(format!("{s:?}: a name on each side of the '='"));
    }
    Ok((actor.to_string(), thesis.to_string()))
}

/// What `place` wrote.
#[derive(Debug, Serialize)]
pub struct PlaceSummary {
    /// The layout file.
    pub layout: PathBuf,
    /// Markers placed (every marker of the capture).
    pub markers: usize,
    /// Markers at a landmark's vertex, found from the mesh's shape.
    pub landmarks: Vec<String>,
    /// Markers put at the vertices `--pin` gave.
    pub pinned: Vec<String>,
    /// The actor's markers read as the thesis' names (`--alias`), as `[actor, thesis]`.
    pub aliases: Vec<(String, String)>,
    /// Lip and eyelid markers put on their lip or lid.
    pub on_features: Vec<String>,
    /// Markers warped from the actor through the landmarks onto the skin.
    pub warped: usize,
    /// The capture's markers left out of the layout: they warp too far from the skin to be the
    /// face's ([`facebake::placement::OFF_FACE`]).
    pub left_out: Vec<String>,
    /// The capture's frames taken as the actor's neutral pose.
    pub neutral_frames: Range<usize>,
    /// Markers no neutral frame has, taken from the nearest frame that has them.
    pub neutral_filled: Vec<String>,
    /// The marker sheet, if one was drawn.
    pub marker_sheet: Option<PathBuf>,
    /// What the user should know: a placement that could not do all it does on a face with
    /// its mouth and eyes open.
    pub warnings: Vec<String>,
}

/// `names` comma separated, or "none".
fn list_or_none(names: &[String]) -> String {
    if names.is_empty() {
        "none".into()
    } else {
        names.join(", ")
    }
}

/// Run `facebake place`.
pub fn run(args: &PlaceArgs) -> Result<ExitCode, CliError> {
    let mesh = load_mesh(&args.mesh, args.mesh_name.as_deref(), args.primitive)?;
    let capture = read_capture_with_units(&args.capture, args.capture_units)?;
    let columns: Vec<usize> = (0..capture.marker_names.len()).collect();
    let neutral = neutral_pose(&capture, &columns, &args.neutral)?;
    let neutral_filled = neutral.filled_names(&capture, &columns);
    let (neutral, neutral_frames) = (neutral.pose, neutral.frames);
    // A pin is a landmark: `place` checks its vertex (PlacementError::BadVertex).
    let layout = place_aliased(
        &mesh,
        &capture.marker_names,
        &neutral,
        &args.pins,
        &args.aliases,
    )
    .map_err(|e| match e {
        // The capture lacks a landmark's marker or an alias is wrong; anything else is about
        // the mesh.
        PlacementError::UnknownLandmark(ref name) => CliError::input(
            &args.capture,
            format!(
                "{e}; if the capture names that marker otherwise, say which with --alias \
                 ACTOR={name}"
            ),
        ),
        PlacementError::BadAlias { .. } => CliError::input(&args.capture, e.to_string()),
        PlacementError::LandmarksUnfound { .. } => CliError::input(
            &args.mesh,
            format!(
                "placing {}: {e}, each with --pin NAME=VERTEX (a glTF vertex index)",
                args.capture.display()
            ),
        ),
        _ => CliError::input(
            &args.mesh,
            format!("placing {}: {e}", args.capture.display()),
        ),
    })?;
    write_layout(&args.output, &layout)?;
    if let Some(path) = &args.marker_sheet {
        let placed = place_markers(&layout, &mesh, DEFAULT_MAX_SNAP_FRACTION * mesh.diagonal())?;
        let names: Vec<String> = placed.iter().map(|m| m.name.clone()).collect();
        let at: Vec<[f64; 3]> = placed.iter().map(|m| m.position).collect();
        let title = format!(
            "{} markers of {} placed on {}",
            names.len(),
            args.capture.display(),
            args.mesh.display()
        );
        write_marker_sheet(path, title, &mesh, &names, &at)?;
    }
    let mut landmarks = Vec::new();
    let mut on_features = Vec::new();
    let pinned: Vec<String> = args.pins.iter().map(|(n, _)| n.clone()).collect();
    for m in &layout.markers {
        if let MarkerAnchor::Vertex(_) = m.anchor {
            if pinned.contains(&m.name) {
                continue;
            }
            let role = args
                .aliases
                .iter()
                .find(|(actor, _)| *actor == m.name)
                .map_or(m.name.as_str(), |(_, thesis)| thesis.as_str());
            if FEATURE_MARKERS.iter().any(|f| f.0 == role) {
                on_features.push(m.name.clone());
            } else {
                landmarks.push(m.name.clone());
            }
        }
    }
    let closed = (!has_openings(&mesh)).then(|| {
        format!(
            "{}: the skin has no mouth and eye openings: the landmarks are where --pin put them \
             and the lip and eyelid markers beside the shortest path over the skin between \
             their corners, taken for the line the lips or lids meet along (look at \
             --marker-sheet; pin any that is not where the actor wore it)",
            args.mesh.display()
        )
    });
    let left_out: Vec<String> = capture
        .marker_names
        .iter()
        .filter(|n| !layout.markers.iter().any(|m| m.name == **n))
        .cloned()
        .collect();
    let left_out_warning = (!left_out.is_empty()).then(|| {
        format!(
            "{}: left out of the layout, warped further than {} of the mesh's size from its skin \
             (not the face's): {}",
            args.capture.display(),
            facebake::placement::OFF_FACE,
            left_out
                .iter()
                .map(|n| facebake::io::escape_control(n))
                .collect::<Vec<_>>()
                .join(", ")
        )
    });
    let summary = PlaceSummary {
        layout: args.output.clone(),
        markers: layout.markers.len(),
        warped: layout.markers.len() - landmarks.len() - on_features.len() - pinned.len(),
        left_out,
        pinned,
        aliases: args.aliases.clone(),
        landmarks,
        on_features,
        marker_sheet: args.marker_sheet.clone(),
        neutral_frames,
        neutral_filled,
        warnings: capture
            .units_warning()
            .into_iter()
            .chain(closed)
            .chain(left_out_warning)
            .collect(),
    };
    if args.json {
        print_json(&summary);
    } else {
        let mut out = String::new();
        outln!(
            out,
            "placed {} markers on {} → {} (the actor's neutral pose: frames {:?})",
            summary.markers,
            args.mesh.display(),
            summary.layout.display(),
            summary.neutral_frames
        );
        if !summary.neutral_filled.is_empty() {
            outln!(
                out,
                "  no frame has every marker: taken from the nearest frames that have them: {}",
                summary.neutral_filled.join(", ")
            );
        }
        outln!(
            out,
            "  landmarks (from the openings and the nose): {}",
            list_or_none(&summary.landmarks)
        );
        outln!(
            out,
            "  on their lip or lid: {}",
            list_or_none(&summary.on_features)
        );
        outln!(
            out,
            "  warped from the actor onto the skin: {}",
            summary.warped
        );
        if !summary.aliases.is_empty() {
            let aliases: Vec<String> = summary
                .aliases
                .iter()
                .map(|(actor, thesis)| format!("{actor} as {thesis}"))
                .collect();
            outln!(out, "  aliases: {}", aliases.join(", "));
        }
        if !summary.pinned.is_empty() {
            outln!(out, "  pinned: {}", summary.pinned.join(", "));
        }
        if let Some(path) = &summary.marker_sheet {
            outln!(out, "  marker sheet → {}", path.display());
        }
        for w in &summary.warnings {
            eprintln!("warning: {w}");
        }
        emit(&out);
    }
    Ok(ExitCode::SUCCESS)
}
