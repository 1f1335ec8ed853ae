//! `facebake bake`: mesh + marker layout → rig blob, with a report of what the bake measured.

use std::ops::Range;
use std::path::PathBuf;
use std::process::ExitCode;

use clap::Args;
use serde::Serialize;

use super::values::{deformer_parser, MethodArg, RadialArg, RefitArg, RetargetArg};
use super::{bytes_text, emit, parse_units, print_json, weight_format, write_file, CliError};
use facebake::io::capture::read_capture_with_units;
use facebake::io::gltf_check::BufferAccess;
use facebake::io::gltf_mesh::load_mesh_with;
use facebake::io::layout::read_layout;
use facebake::io::mask_sides::read_vertex_sides;
use facebake::metrics::TakeMetrics;
use facebake::model::{
    place_markers, FaceMesh, MarkerGroups, Units, VertexSets, DEFAULT_MAX_SNAP_FRACTION,
};
use facebake::stages::temporal::SmoothingConfig;
use facebake::stages::{Neutral, SmoothingUse};
use facebake::surface::SideRule;
use facebake::{
    BakeError, BakeOptions, BakeReport, DeformerKind, HeadMarkers, RetargetKind, Scene,
    StagesConfig,
};

/// Arguments of `facebake bake`.
#[derive(Debug, Args)]
pub struct BakeArgs {
    /// The face mesh (.glb or .gltf).
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
    /// The marker layout (.toml or .json).
    #[arg(long, value_name = "LAYOUT")]
    pub layout: PathBuf,
    /// Let a `.gltf` read its buffers from anywhere (absolute paths, `file:` URIs, `..`);
    /// by default only files inside the mesh's folder are read.
    #[arg(long)]
    pub allow_outside_asset: bool,
    /// Distance the RBF is built on: euclidean (straight line), geodesic (along the skin, so
    /// the lips and eyelids can part) or hybrid (geodesic within a marker spacing of the mouth
    /// and eyes, Euclidean beyond) or pbw (paper 002's proximity-based weighting on geodesics,
    /// a quarter, blended with three quarters of the geodesic RBF). Default: geodesic
    /// (euclidean with `--deformer planar`, whose bones blend triangle frames, not distances).
    /// Every method bakes the linear deformer
    /// masked, with static anchoring and the exponential radial function, width factor 1.5 (the
    /// papers' bare Euclidean RBF: `--method euclidean --no-masks --no-anchoring --deformer rbf
    /// --radial gaussian --width-factor 0.75 -k 8`).
    #[arg(long, value_enum)]
    pub method: Option<MethodArg>,
    /// Leave out static anchoring: by default the skin beyond the markers' hull above the mouth
    /// (cranium, back of the head, ears) follows the skull markers instead of the face.
    #[arg(long)]
    pub no_anchoring: bool,
    /// Leave the corners of the eyes and the mouth as the RBF makes them: by default the lids
    /// and lips near each corner that has a marker open and close as a crack does (the
    /// displacement across the opening growing as the square root of the distance from the
    /// corner; at the mouth 70 % of it, on the vertical axis alone), so a blink closes the eye
    /// and the lips part near their corners; and the lid markers' weights fade from the eye's
    /// rim, so a blink does not drag the skin under the brow. Linear deformer; the mouth's part
    /// needs K ≥ 6.
    #[arg(long)]
    pub no_corners: bool,
    /// Leave each lip straight between its markers: by default the skin beside the mouth's rim
    /// takes a correction so that a lip curves through its markers (no V hanging from the
    /// middle marker in a jaw open). With the masks and the corners; linear deformer.
    #[arg(long)]
    pub no_lip_curve: bool,
    /// Leave the weights as the method makes them where the capture folds the skin: by default
    /// a bake with a capture plays it through the rig, and where a frame turns a skin triangle
    /// over, the weights of a patch of skin round it are relaxed (each vertex the mean of its
    /// neighbours, up to three rings out) if that folds fewer. Linear deformer.
    #[arg(long)]
    pub no_relax: bool,
    /// Write the rig even where it tears the mesh's own shapes. On a mesh with morph targets the
    /// bake plays each target through the rig it made; a `--method` or `--deformer` other than
    /// the default's that stretches a skin edge past twice its length in a target is refused
    /// (the default warns instead).
    #[arg(long)]
    pub allow_tears: bool,
    /// Across a lip or lid, between the opening's rim and a marker worn on it, count this
    /// fraction of a distance, so that the rim moves with the marker in front of it rather than
    /// with the next one along (default 0.2; 1 measures distances as they are). Linear and RBF
    /// deformers, surface distances.
    #[arg(long, value_name = "F", value_parser = parse_fraction)]
    pub rim_across: Option<f64>,
    /// Mask (upper/lower lip, upper/lower eyelid): markers of one side of an opening may not
    /// move the other side. On by default for the linear and planar deformers, every method;
    /// the RBF deformer takes no masks, so with it `--masks` is refused. The groups are the
    /// layout's `[groups]`, else found from the mouth and eye openings (markers over an
    /// opening's span, above or below its rim).
    #[arg(long)]
    pub masks: bool,
    /// No masks: a vertex may then follow markers across the lips or eyelids (with
    /// `--method euclidean` or planar bones the lips then stay tied together).
    #[arg(long, conflicts_with = "masks")]
    pub no_masks: bool,
    /// A TOML/JSON file giving each mask's sides as glTF vertex sets,
    /// `mouth = { upper = [..], lower = [..] }`, instead of finding them from the openings.
    #[arg(long, value_name = "FILE", conflicts_with = "no_masks")]
    pub mask_sides: Option<PathBuf>,
    /// A mask's sides from a grey PNG in the mesh's cylindrical projection (paper
    /// 000 §4.3; white = upper side, black = lower, grey = unmasked), as `NAME=FILE`, once per
    /// mask of the layout's `[groups]`. `facebake mask-images` writes templates.
    #[arg(
        long,
        value_name = "NAME=FILE",
        conflicts_with_all = ["mask_sides", "no_masks"]
    )]
    pub mask_image: Vec<String>,
    /// A mask's sides from a float vertex attribute of the mesh's primitive (a
    /// glTF application-specific attribute such as `_MASK_MOUTH`: above 0.5 upper side, below
    /// -0.5 lower, between unmasked), as `NAME=ATTRIBUTE`, once per mask.
    #[arg(long, value_name = "NAME=ATTRIBUTE", conflicts_with_all = ["mask_sides", "mask_image", "no_masks"])]
    pub mask_attribute: Vec<String>,
    /// The runtime's deformer: rbf (per-frame RBF coefficients with K radial terms per vertex),
    /// linear (K weights per vertex on marker displacements) or planar (planar bones, K control
    /// triangles per vertex; the layout's `triangles = [["A", "B", "C"], ..]` when given, else
    /// built automatically) (default: linear). The RBF deformer has no masks and no corner
    /// reshaping; anchored, its affine part is the anchor markers' mean translation and its
    /// radial terms fade beyond the markers (33 mm of skull motion on FaceCap's truth
    /// unanchored); it keeps every radial term unless -k says otherwise (on the truth 2.16× and
    /// 2 flipped triangles, at K = 8 3.47× and 58).
    #[arg(long, value_parser = deformer_parser())]
    pub deformer: Option<DeformerKind>,
    /// Radial function φ (default: exponential, every method; the papers' RBF is gaussian).
    #[arg(long, value_enum)]
    pub radial: Option<RadialArg>,
    /// Radial width in mesh units (default: --width-factor × the mean nearest-marker distance;
    /// the inverse multiquadric uses per-marker radii and ignores it).
    #[arg(long, value_name = "W", value_parser = parse_positive)]
    pub width: Option<f64>,
    /// Width as a multiple of the mean nearest-marker distance, when --width is not given
    /// (default: 1.5, every method; the papers' RBF is 0.75).
    #[arg(long, value_name = "F", value_parser = parse_positive)]
    pub width_factor: Option<f64>,
    /// Leave out the affine term of the RBF system.
    #[arg(long)]
    pub no_affine: bool,
    /// Influences per vertex, 1 to 64 (default: 8; the RBF deformer keeps every radial term, up
    /// to 64, since its wide default radial function does not decay within 8).
    #[arg(short = 'k', long = "influences", value_name = "K")]
    pub k: Option<usize>,
    /// How the K kept weights are found from the dense ones (linear deformer; default: shrink,
    /// which is continuous over the skin where a vertex's kept set changes; prior for pbw).
    #[arg(long, value_enum)]
    pub refit: Option<RefitArg>,
    /// Largest distance a `point` marker may be snapped onto the surface, in mesh units
    /// (default: 1% of the mesh's bounding-box diagonal).
    #[arg(long, value_name = "D", value_parser = parse_positive)]
    pub max_snap: Option<f64>,
    /// The actor's capture (.c3d, .trc or .csv): also bake the capture stages (head-motion
    /// compensation, fill, retargeting onto the layout's markers) from it, so that `play`
    /// takes this actor's raw captures. Its markers are matched to the layout's by name.
    #[arg(long, value_name = "CAPTURE")]
    pub capture: Option<PathBuf>,
    /// Units of the capture's numbers, overriding what the file says.
    #[arg(long, value_name = "UNITS", value_parser = parse_units, requires = "capture")]
    pub capture_units: Option<Units>,
    /// The actor's neutral pose: `auto` (the capture's first frame with every marker present
    /// and none a ghost; if no frame has them all, the first with half of them, each missing
    /// one taken from the nearest frame that has it, moved rigidly onto it; with the still
    /// frames that follow it, up to half a second, moved onto it and averaged), a frame `N` or
    /// a range `A..B` averaged (0-based, B excluded).
    #[arg(long, value_name = "FRAMES", default_value = "auto", value_parser = parse_neutral, requires = "capture")]
    pub neutral: Neutral,
    /// Head markers for compensation: comma-separated names, `auto` (the 5 most rigid over
    /// the capture of the skull markers and the inner eye corners), `auto:N`, or `none` (the
    /// capture is already head-stabilised). Once the
    /// head's motion is taken out, the head markers hold still: the rig does not deform the
    /// skin around them by their fit residuals (noise, skin sliding over the skull).
    #[arg(long, value_name = "NAMES", default_value = "auto", value_parser = parse_head, requires = "capture")]
    pub head_markers: HeadMarkers,
    /// A compensated marker further than this from its neutral position is rejected and
    /// rebuilt, as a fraction of the actor's half extent (default: learned, 1.5 × the largest
    /// of the markers' 99th-percentile distances from neutral over the capture, at least 0.5).
    #[arg(long, value_name = "F", value_parser = parse_positive, requires = "capture")]
    pub max_displacement: Option<f64>,
    /// How far a head-marker pair's distance may stray from the neutral frame before the head
    /// marker that broke the head's shape is rejected, as a fraction of the actor's half extent
    /// (default: learned, twice the capture's largest such change, at least 0.02).
    #[arg(long, value_name = "F", requires = "capture")]
    pub head_tolerance: Option<f64>,
    /// A compensated marker that moves further than this in one frame (a swap or a jump) is
    /// rejected and rebuilt, as a fraction of the actor's half extent (default: learned, 8 × the
    /// capture's 99.9th percentile per-frame movement, at least 0.02).
    #[arg(long, value_name = "F", requires = "capture")]
    pub max_step: Option<f64>,
    /// The one-euro smoothing of the compensated markers: `auto` (when the capture's noise σ
    /// is over 0.15 mm: 3 Hz, β 50 (0.63 mm / σ)², 2 Hz; a clean capture is not smoothed, since
    /// the filter's lag costs more than it removes), `off`, or `MIN_HZ,BETA,SPEED_HZ` (cutoff
    /// when still, Hz added per m/s of speed, cutoff of the speed estimate) for always with
    /// these parameters. Its lag when still is rate / (2π MIN_HZ) frames.
    #[arg(long, value_name = "PARAMS", default_value = "auto", value_parser = parse_smoothing, requires = "capture")]
    pub smoothing: SmoothingUse,
    /// The one-euro smoothing of the head's pose: `auto` (when the head fit would carry more
    /// than 1 mm of the capture's own noise to the face: a few close head markers on a noisy
    /// capture), `off`, or `MIN_HZ,BETA,SPEED_HZ` for always with these parameters. It lags
    /// the pose while the head moves.
    #[arg(long, value_name = "PARAMS", default_value = "auto", value_parser = parse_head_smoothing, requires = "capture")]
    pub head_smoothing: SmoothingUse,
    /// The head fit done again every frame over the face's markers, each weighted by how still
    /// it held (Tukey's biweight of its displacement in the last frame and half its motion since,
    /// zero from the cutoff on), so a brow raise (which lifts the forehead's head markers) is
    /// not read as the head pitching and the head markers' jitter is averaged away: `auto`
    /// (1 mm, or 3 × the capture's noise or the head markers' residual from a rigid head,
    /// the largest), `off` (the head markers' fit alone), or the cutoff in mm.
    #[arg(long, value_name = "MM", default_value = "auto", value_parser = parse_head_refit, requires = "capture")]
    pub head_refit: facebake::stages::RefitUse,
    /// How the actor's markers become the character's: per-region proportional scaling (paper
    /// 003 §4; the default: it keeps the actor's jaw opening, where the RBF map of a layout
    /// whose lip markers sit closer on the character than on the actor exaggerates it), the
    /// RBF map (inverse multiquadric + affine, paper 000) or the geodesic map (paper 002 §2.1:
    /// the same map with distances along the character's skin warped onto the actor,
    /// linearised per marker and played as proportional retargeting).
    #[arg(long, value_enum, default_value_t = RetargetArg::Proportional, requires = "capture")]
    pub retarget: RetargetArg,
    /// Planar deformer: bone radius as a multiple of the closest connected-marker distance.
    #[arg(long, value_name = "F", default_value_t = BakeOptions::default().planar_radius, value_parser = parse_positive)]
    pub planar_radius: f64,
    /// Layout markers the capture never has (e.g. inner lips), comma-separated: rebuilt from
    /// their nearest captured markers every frame (paper 000 §5.2). Any other layout marker
    /// missing from the capture is an error.
    #[arg(
        long,
        value_name = "NAMES",
        value_delimiter = ',',
        requires = "capture"
    )]
    pub virtual_markers: Vec<String>,
    /// Static anchors, comma-separated: layout markers (back of the head, neck) pinned at rest
    /// every frame, whatever the capture says of them (paper 003).
    #[arg(
        long,
        value_name = "NAMES",
        value_delimiter = ',',
        requires = "capture"
    )]
    pub anchor_markers: Vec<String>,
    /// Where to write the rig blob.
    #[arg(short, long, value_name = "RIG")]
    pub output: PathBuf,
    /// Print the report as JSON on stdout instead of text.
    #[arg(long)]
    pub json: bool,
}

impl BakeArgs {
    /// The bake options: the options given, the defaults of the method for the rest.
    /// The distance method: as given, else geodesic (euclidean for planar bones).
    fn method(&self) -> facebake::Method {
        match (self.method, self.deformer) {
            (Some(m), _) => m.into(),
            (None, Some(DeformerKind::Planar)) => facebake::Method::Euclidean,
            (None, _) => facebake::Method::Geodesic,
        }
    }

    /// Whether masks were asked for: `--masks` or given sides (which the RBF deformer refuses).
    fn masks_asked(&self) -> bool {
        self.masks
            || self.mask_sides.is_some()
            || !self.mask_image.is_empty()
            || !self.mask_attribute.is_empty()
    }

    /// Whether to mask: asked for, or unless `--no-masks` on the deformers that take masks
    /// (linear and planar).
    fn masks(&self) -> bool {
        self.masks_asked() || (!self.no_masks && self.deformer != Some(DeformerKind::Rbf))
    }

    pub fn options(&self) -> BakeOptions {
        let d = BakeOptions::for_method(self.method(), self.masks());
        let deformer = self.deformer.unwrap_or(d.deformer);
        let d = d.with_deformer(deformer);
        BakeOptions {
            radial: self.radial.map_or(d.radial, Into::into),
            width: self.width.or(d.width),
            width_factor: self.width_factor.unwrap_or(d.width_factor),
            affine: d.affine && !self.no_affine,
            k: self.k.unwrap_or(d.k),
            refit: self.refit.map_or(d.refit, Into::into),
            planar_radius: self.planar_radius,
            stages: StagesConfig {
                neutral: self.neutral.clone(),
                head: self.head_markers.clone(),
                max_displacement: self.max_displacement,
                retarget: self.retarget.into(),
                virtual_markers: self.virtual_markers.clone(),
                anchor_markers: self.anchor_markers.clone(),
                head_tolerance: self.head_tolerance,
                max_step: self.max_step,
                smoothing: self.smoothing,
                head_smoothing: self.head_smoothing,
                head_refit: self.head_refit,
                ..StagesConfig::default()
            },
            // Planar bones bake Euclidean distances, whose default has no anchoring: they anchor
            // the skin beyond the markers to a bone of skull markers.
            anchoring: if self.no_anchoring {
                None
            } else {
                d.anchoring.or((self.deformer == Some(DeformerKind::Planar))
                    .then_some(facebake::ANCHORING_MARGIN))
            },
            surface: facebake::SurfaceOptions {
                corners: d.surface.corners && !self.no_corners,
                lip_curve: d.surface.lip_curve && !self.no_lip_curve,
                rim_across: self.rim_across.unwrap_or(d.surface.rim_across),
                relax: d.surface.relax && !self.no_relax,
                ..d.surface
            },
            ..d
        }
    }
}

/// What `bake` reports.
#[derive(Debug, Serialize)]
pub struct BakeSummary {
    /// The rig written.
    pub output: PathBuf,
    /// The mesh file.
    pub mesh: PathBuf,
    /// The mesh's name in the file.
    pub mesh_name: String,
    /// The primitive of that mesh the rig deforms.
    pub primitive: usize,
    /// The layout file.
    pub layout: PathBuf,
    /// Vertices of the rig.
    pub vertices: usize,
    /// Markers of the rig.
    pub markers: usize,
    /// Largest snap of a marker onto the surface, mesh units.
    pub max_snap_distance: f64,
    /// Whether the affine term was solved.
    pub affine: bool,
    /// Weight format, `Q(23−F).F`.
    pub weight_format: String,
    /// Bytes per stored influence.
    pub bytes_per_influence: f64,
    /// The masks' marker groups, when masked.
    pub mask_groups: Vec<MaskGroupSummary>,
    /// With a capture: its every frame played through the rig just baked, measured (static
    /// drift, apertures, stretch against rest, flips), worst over the take.
    pub on_capture: Option<TakeMetrics>,
    /// The bake's own report (the capture stages' included).
    pub report: BakeReport,
}

/// One mask's marker groups, by name.
#[derive(Debug, Serialize)]
pub struct MaskGroupSummary {
    /// The mask.
    pub name: String,
    /// Where the groups come from: the layout's `[groups]` or the mesh's openings.
    pub source: &'static str,
    /// Markers of the upper side.
    pub upper: Vec<String>,
    /// Markers of the lower side.
    pub lower: Vec<String>,
}

/// The masks' vertex sides: from `--mask-sides`, `--mask-image` or `--mask-attribute`, else
/// found from the openings.
fn side_rule(
    args: &BakeArgs,
    mesh: &FaceMesh,
    groups: &[MarkerGroups],
) -> Result<SideRule, CliError> {
    Ok(match &args.mask_sides {
        Some(path) => SideRule::VertexSets(
            read_vertex_sides(path, groups).map_err(|e| CliError::input(path, e.to_string()))?,
        ),
        None if !args.mask_image.is_empty() => SideRule::VertexSets(named_sides(
            "--mask-image",
            &args.mask_image,
            groups,
            &args.layout,
            |file| image_sides(file, mesh),
        )?),
        None if !args.mask_attribute.is_empty() => SideRule::VertexSets(named_sides(
            "--mask-attribute",
            &args.mask_attribute,
            groups,
            &args.layout,
            |attr| attribute_sides(attr, mesh),
        )?),
        None => SideRule::Auto,
    })
}

/// The vertex sides of every mask from `--mask-image NAME=FILE` or `--mask-attribute
/// NAME=ATTRIBUTE` arguments (`flag` names which), in `groups` order: `read` turns one value into
/// that mask's sides.
fn named_sides(
    flag: &str,
    args: &[String],
    groups: &[MarkerGroups],
    layout: &std::path::Path,
    read: impl Fn(&str) -> Result<VertexSets, CliError>,
) -> Result<Vec<VertexSets>, CliError> {
    let mut given = std::collections::BTreeMap::new();
    for a in args {
        let (name, value) = a
            .split_once('=')
            .ok_or_else(|| CliError::input(layout, format!("{flag} {a:?}: expected NAME=VALUE")))?;
        if !groups.iter().any(|g| g.name == name) {
            return Err(CliError::input(
                layout,
                format!("{flag} names mask \"{name}\", which the layout's [groups] does not have"),
            ));
        }
        given.insert(name.to_string(), value.to_string());
    }
    groups
        .iter()
        .map(|g| {
            let value = given.get(&g.name).ok_or_else(|| {
                CliError::input(layout, format!("no {flag} for mask \"{}\"", g.name))
            })?;
            read(value)
        })
        .collect()
}

/// A mask's sides from a mask image (see [`facebake::io::mask_image`]).
fn image_sides(file: &str, mesh: &FaceMesh) -> Result<VertexSets, CliError> {
    let path = PathBuf::from(file);
    facebake::io::mask_image::read_sides(&path, &mesh.positions, &mesh.triangles).map_err(|e| {
        let text = e.to_string();
        let prefix = format!("{}: ", path.display());
        CliError::input(&path, text.strip_prefix(&prefix).unwrap_or(&text))
    })
}

/// A mask's sides from a per-vertex float attribute of the mesh (see
/// [`FaceMesh::attribute_sides`]), errors naming the mesh file.
fn attribute_sides(name: &str, mesh: &FaceMesh) -> Result<VertexSets, CliError> {
    mesh.attribute_sides(name)
        .map_err(|e| CliError::input(&mesh.source, e.to_string()))
}

/// Run `facebake bake`.
pub fn run(args: &BakeArgs) -> Result<ExitCode, CliError> {
    let access = if args.allow_outside_asset {
        BufferAccess::Anywhere
    } else {
        BufferAccess::AssetFolder
    };
    let mesh = load_mesh_with(
        &args.mesh,
        args.mesh_name.as_deref(),
        args.primitive,
        access,
    )?;
    let layout = read_layout(&args.layout)?;
    let max_snap = args
        .max_snap
        .unwrap_or(DEFAULT_MAX_SNAP_FRACTION * mesh.diagonal());
    let placed = place_markers(&layout, &mesh, max_snap)?;
    let mut options = args.options();
    let mut scene = Scene::placed(&mesh, &placed);
    if options.deformer == DeformerKind::Planar {
        scene.control_triangles = layout.triangles.clone();
    }
    let mut mask_groups = Vec::new();
    let mut unmasked = Vec::new();
    if options.masks {
        scene.groups = layout.groups.clone();
        scene.sides = side_rule(args, &mesh, &scene.groups)?;
        let source = if scene.groups.is_empty() {
            match scene.with_groups_from_openings() {
                Ok(found) => {
                    // Said here, since the bake is then given the groups found.
                    unmasked = facebake::surface::masks::unmasked_openings(&found.groups);
                    options.masks &= !found.groups.is_empty();
                    scene = found;
                }
                Err(e) if !args.masks_asked() => {
                    // The default's masks need groups; a mesh without the openings to find
                    // them from bakes unmasked, and says so.
                    options.masks = false;
                    unmasked.push(format!(
                        "baked without masks (the lips and lids may move together): the layout \
                         has no [groups] and {e}"
                    ));
                }
                Err(e) => return Err(CliError::input(&args.mesh, e.to_string())),
            }
            "found from the openings"
        } else {
            "the layout's"
        };
        let names = |list: &[usize]| list.iter().map(|&m| placed[m].name.clone()).collect();
        mask_groups = scene
            .groups
            .iter()
            .map(|g| MaskGroupSummary {
                name: g.name.clone(),
                source,
                upper: names(&g.upper),
                lower: names(&g.lower),
            })
            .collect();
    }
    let capture = match &args.capture {
        Some(path) => Some(read_capture_with_units(path, args.capture_units)?),
        None => None,
    };
    scene.capture = capture.as_ref();
    let baked = facebake::bake(&scene, &options).map_err(|e| bake_error(args, e))?;
    if let Some(check) = &baked.report.shapes {
        if check.refuses(&options) && !args.allow_tears {
            return Err(CliError::input(
                &args.mesh,
                format!(
                    "{}, where the mesh itself does not: `bake` without --method and --deformer bakes the default's form, --allow-tears writes this rig anyway",
                    check.tears()
                ),
            ));
        }
    }
    write_file(&args.output, &baked.blob)?;
    let mut report = baked.report;
    report.warnings.extend(unmasked);
    // The rig is written; a capture it cannot be measured on is said, not fatal.
    let on_capture = match (&capture, &args.capture) {
        (Some(capture), Some(path)) => {
            match measure_on_capture(&baked.blob, &mesh, capture, path) {
                Ok(t) => Some(t),
                Err(e) => {
                    report.warnings.push(format!(
                        "the capture could not be played through the rig: {e}"
                    ));
                    None
                }
            }
        }
        _ => None,
    };
    report
        .warnings
        .extend(capture_warnings(on_capture.as_ref()));
    let summary = BakeSummary {
        output: args.output.clone(),
        mesh: args.mesh.clone(),
        mesh_name: mesh.mesh_name.clone(),
        primitive: mesh.primitive_index,
        layout: args.layout.clone(),
        vertices: mesh.positions.len(),
        markers: placed.len(),
        max_snap_distance: placed
            .iter()
            .map(|m| m.surface.distance)
            .fold(0.0, f64::max),
        affine: options.affine,
        weight_format: weight_format(report.weight_frac_bits),
        bytes_per_influence: report.sizes.influence_bytes as f64
            / report.sizes.influences.max(1) as f64,
        mask_groups,
        on_capture,
        report,
    };
    if args.json {
        print_json(&summary);
    } else {
        print_text(&summary);
    }
    Ok(ExitCode::SUCCESS)
}

/// Play `capture` (the take the rig was baked from) through the rig in `blob`, frame by frame,
/// and measure each frame as it comes (nothing per frame is kept but its metrics), so the bake
/// says what the rig does to this actor's own take: a tear, a flip or a drifting skull shows
/// here rather than in the engine. Stretch is against rest, as for any take without a truth,
/// and beside it against the longest the mesh's own morph targets make each edge.
fn measure_on_capture(
    blob: &[u8],
    mesh: &FaceMesh,
    capture: &facebake::model::Capture,
    path: &std::path::Path,
) -> Result<TakeMetrics, CliError> {
    let rig = facebake_runtime::Rig::from_bytes(blob)
        .map_err(|e| CliError::input(path, format!("the rig just baked does not load: {e}")))?;
    let regions = super::render::rig_regions(&rig, mesh)?;
    let metres = capture.in_metres();
    let columns: Vec<Option<usize>> = rig.marker_names().map(|n| metres.marker_index(n)).collect();
    let frames: Vec<Vec<Option<[f64; 3]>>> = metres
        .frames
        .iter()
        .map(|f| columns.iter().map(|c| c.and_then(|c| f[c])).collect())
        .collect();
    let mut per_frame = Vec::with_capacity(frames.len());
    super::play::play_stages(&rig, path, &frames, |_, positions| {
        per_frame.push(regions.measure(positions, None, false));
    })?;
    Ok(TakeMetrics::of(&per_frame))
}

/// A failed bake as a command-line error naming the file it is about: the capture for the
/// stages, the sides file for masks with given sides, else the layout.
fn bake_error(args: &BakeArgs, e: BakeError) -> CliError {
    match (&e, &args.capture, &args.mask_sides) {
        (BakeError::Stages(_), Some(capture), _) => {
            // Most stage errors name the capture already; the CLI error names it once.
            let message = e.to_string();
            let prefix = format!("{}: ", capture.display());
            CliError::input(capture, message.strip_prefix(&prefix).unwrap_or(&message))
        }
        (BakeError::Surface(facebake::surface::SurfaceError::Mask(_)), _, Some(sides)) => {
            CliError::input(sides, e.to_string())
        }
        (BakeError::Surface(_), _, _) => CliError::input(&args.layout, e.to_string()),
        _ => CliError::Bake {
            path: args.layout.clone(),
            source: e,
        },
    }
}

fn print_text(s: &BakeSummary) {
    let mut out = String::new();
    let r = &s.report;
    outln!(
        out,
        "baked mesh \"{}\" primitive {} ({}, {} vertices) with {} markers ({})",
        s.mesh_name,
        s.primitive,
        s.mesh.display(),
        s.vertices,
        s.markers,
        s.layout.display()
    );
    outln!(
        out,
        "  deformer      {}: {}",
        r.deformer.name(),
        r.deformer.description()
    );
    if let Some(radial) = r.radial {
        outln!(
            out,
            "  radial        {radial} on {} distances, {}",
            r.method.name(),
            if s.affine {
                "with affine term"
            } else {
                "no affine term"
            }
        );
    }
    if let Some(c) = r.condition {
        outln!(out, "  condition     {c:.3e} (1-norm estimate)");
    }
    if let Some(f) = &r.surface {
        outln!(
            out,
            "  surface       openings found: {}; kernel matrix smallest eigenvalue {:.3e} × mean |φ|, ridge {:.3e}, geodesic asymmetry {:.1} %",
            f.openings,
            f.min_eigenvalue,
            f.ridge,
            100.0 * f.geodesic_asymmetry
        );
        if f.face_turn_degrees > 0.05 {
            outln!(
                out,
                "  face axes     turned {:.1}° from the file's (read from the eyes and the mouth); above, below and across are the face's",
                f.face_turn_degrees
            );
        }
        outln!(
            out,
            "  masks         {}; vertices masked: {}",
            if f.masks.is_empty() {
                "none".to_string()
            } else {
                f.masks.join(", ")
            },
            f.masked_vertices
        );
        if let Some(a) = &f.anchoring {
            outln!(
                out,
                "  anchoring     {} vertices follow the mean of {} ({} of them alone)",
                a.anchored_vertices,
                a.markers.join(", "),
                a.still_vertices
            );
        }
        if let Some(c) = &f.corners {
            outln!(
                out,
                "  corners       {} corners of the eyes and mouth with a marker ({}): {} vertices reshaped; {} past the mouth's corners balanced between the lips",
                c.corners,
                c.markers.join(", "),
                c.reshaped_vertices,
                c.balanced_vertices
            );
        }
        if let Some(l) = &f.let_go {
            let worn = [
                (
                    "lids",
                    "the lid markers",
                    "the lids' fold",
                    &l.lid_markers,
                    l.lid_vertices,
                ),
                (
                    "upper lip",
                    "the upper lip's markers",
                    "the lip",
                    &l.lip_markers,
                    l.lip_vertices,
                ),
            ];
            for (label, whose, past, markers, vertices) in worn {
                if !markers.is_empty() {
                    outln!(
                        out,
                        "  {label:<14}{whose} ({}) let go of the skin past {past}: {vertices} vertices",
                        markers.join(", ")
                    );
                }
            }
            if l.depth_vertices > 0 {
                outln!(
                    out,
                    "  lower lip     the lower lip's markers ({}) hand their depth to the jaw's ({}) past the lip: {} vertices",
                    l.depth_markers.join(", "),
                    l.jaw_markers.join(", "),
                    l.depth_vertices
                );
            }
        }
        if f.lip_curve_vertices > 0 {
            outln!(
                out,
                "  lip curve     the lips curve through their markers: {} vertices beside the mouth",
                f.lip_curve_vertices
            );
        }
    }
    for g in &s.mask_groups {
        outln!(
            out,
            "  mask groups   {} ({}): upper {}; lower {}",
            g.name,
            g.source,
            g.upper.join(", "),
            g.lower.join(", ")
        );
    }
    outln!(
        out,
        "  markers       largest snap onto the surface {:.3e} mesh units",
        s.max_snap_distance
    );
    outln!(
        out,
        "  influences    K = {} per vertex, {} in all",
        r.k,
        r.sizes.influences
    );
    let stored = r.deformer.stored();
    if r.deformer == DeformerKind::Planar {
        outln!(
            out,
            "  weights       Q1.15 (unsigned 16-bit, each vertex's sum exactly 2^15), largest rounding {:.2e}",
            r.max_weight_rounding
        );
    } else {
        outln!(
            out,
            "  {stored:13} {} (signed 24-bit, F = {} fractional bits), largest rounding {:.2e}",
            s.weight_format,
            r.weight_frac_bits,
            r.max_weight_rounding
        );
    }
    if r.deformer == DeformerKind::Rbf {
        outln!(
            out,
            "  coefficients  largest rounding of the coefficient map {:.2e} (relative to its row)",
            r.max_matrix_rounding
        );
    }
    outln!(
        out,
        "  dropped mass  mean {:.4}, max {:.4} (share of each vertex's {} dropped by keeping K)",
        r.mean_dropped_mass,
        r.max_dropped_mass,
        r.deformer.dropped()
    );
    if let Some(p) = &r.planar {
        outln!(
            out,
            "  control       {} triangles; {} vertices within no bone's radius ride their closest bone",
            p.triangles.len(),
            p.outside_radius
        );
    }
    outln!(
        out,
        "  blob          {}: influences {} bytes ({} bytes/influence), other {:.2} bytes/vertex",
        bytes_text(r.sizes.total),
        r.sizes.influence_bytes,
        s.bytes_per_influence,
        r.sizes.other_bytes_per_vertex
    );
    if let Some(st) = &r.stages {
        if st.at_rest {
            outln!(
                out,
                "  stages        no capture: the markers at rest are the neutral pose, so `play` accepts takes in the character's own space (head motion removed, gaps filled; `bake --capture` retargets an actor and smooths)"
            );
        } else {
            outln!(
                out,
                "  capture       neutral frames {:?}, actor half extent {:.1} mm (capture in {})",
                st.neutral_frames,
                st.actor_half_extent * 1000.0,
                st.units
            );
        }
        let how = if st.at_rest {
            "the skull markers and the inner eye corners unless named".to_string()
        } else if st.head_markers_picked {
            format!(
                "the most rigid, picked by the baker; their distances vary by {:.3} mm",
                st.head_spread * 1000.0
            )
        } else {
            format!(
                "as named; their distances vary by {:.3} mm",
                st.head_spread * 1000.0
            )
        };
        outln!(
            out,
            "  head markers  {} ({how})",
            st.head_markers.join(", ")
        );
        outln!(
            out,
            "  retargeting   {}; RBF condition {:.3e}{}, largest coefficient rounding {:.2e}",
            match st.retarget {
                RetargetKind::Rbf => "IMQ + affine RBF map (paper 000)",
                RetargetKind::Proportional => "per-region proportional scaling (paper 003)",
                RetargetKind::Geodesic =>
                    "geodesic IMQ + affine map, linearised per marker (paper 002)",
            },
            st.retarget_condition,
            st.geodesic_condition
                .map_or(String::new(), |c| format!(", geodesic condition {c:.3e}")),
            st.max_alpha_rounding
        );
        outln!(
            out,
            "  checks        head-marker distances within {:.2} mm; displacements over {:.1} mm and steps over {:.2} mm per frame rejected",
            st.head_tolerance * 1000.0,
            st.max_displacement * 1000.0,
            st.max_step * 1000.0,
        );
        let filter = |f: &Option<facebake::stages::temporal::SmoothingConfig>| match f {
            Some(f) => format!(
                "one-euro {} Hz, beta {}, speed {} Hz",
                f.min_cutoff_hz, f.beta, f.derivative_cutoff_hz
            ),
            None => "off".to_string(),
        };
        if st.at_rest {
            outln!(out, "  smoothing     off (no capture to measure noise on)");
        } else {
            outln!(
            out,
            "  smoothing     the capture's noise {:.3} mm{} (markers smoothed by default over {:.2} mm); markers {}{}; head pose {}{}",
            st.capture_noise * 1000.0,
            if st.head_markers_noise > st.capture_noise {
                format!(", its head markers' {:.3} mm", st.head_markers_noise * 1000.0)
            } else {
                String::new()
            },
            facebake::stages::temporal::MARKER_NOISE_LIMIT * 1000.0,
            filter(&st.smoothing),
            if st.smoothing.is_some() {
                format!(" (lag when still {} frames)", st.smoothing_lag_frames)
            } else {
                String::new()
            },
            filter(&st.head_smoothing),
            match st.head_noise_gain {
                Some(g) => format!(" (the head fit magnifies marker noise {g:.1}×)"),
                None => String::new(),
            }
        );
        }
        outln!(
            out,
            "  head refit    {}",
            match st.head_refit {
                Some(c) => format!(
                    "over the face's markers, each weighted by how still it held (cutoff {:.2} mm; the head markers stray {:.2} mm from a rigid head)",
                    c * 1000.0,
                    st.head_residual * 1000.0
                ),
                None => "off (the head markers' fit alone)".to_string(),
            }
        );
        if !st.virtual_markers.is_empty() {
            outln!(
                out,
                "  virtual       not in the capture, rebuilt from neighbours every frame: {}",
                st.virtual_markers.join(", ")
            );
        }
        if !st.anchor_markers.is_empty() {
            outln!(
                out,
                "  anchors       pinned at rest every frame: {}",
                st.anchor_markers.join(", ")
            );
        }
        if !st.unused_capture_markers.is_empty() {
            outln!(
                out,
                "  not used      capture markers without a place on the character: {}",
                st.unused_capture_markers.join(", ")
            );
        }
    }
    if let Some(m) = &r.mouth_share {
        let mut judged = Vec::new();
        if m.shapes > 0 {
            judged.push(format!("the mesh's {} shapes", m.shapes));
        }
        if m.frames > 0 {
            judged.push(format!("the capture's {} frames", m.frames));
        }
        let tried: Vec<String> = m
            .tried
            .iter()
            .map(|t| match t.frames_torn {
                Some(f) => format!("{} tore {f} of {} frames", t.share, m.frames),
                None => format!("{} tore {} of {} shapes", t.share, t.shapes_torn, m.shapes),
            })
            .collect();
        outln!(
            out,
            "  mouth corners {} of the crack's profile, judged on {}{}",
            m.share,
            judged.join(" and "),
            if tried.is_empty() {
                String::new()
            } else {
                format!(" (against the linear profile, {})", tried.join(", "))
            }
        );
    }
    if let Some(c) = &r.shapes {
        let torn = match c.torn.len() {
            0 => "no edge past 2×".to_string(),
            n => format!("an edge past 2× in {n} of them"),
        };
        let flipped = match c.max_flipped.0 {
            0 => "no skin triangle turned over".to_string(),
            n => format!(
                "at most {n} skin triangle(s) turned over ({})",
                c.max_flipped.1
            ),
        };
        outln!(
            out,
            "  own shapes    {} morph targets played through the rig: stretch at most {:.2}× ({}), {torn}; {flipped}",
            c.shapes,
            c.max_stretch.0,
            c.max_stretch.1,
        );
    }
    if let Some(r) = &r.relaxed {
        let folds = |f: &facebake::bake::relax::Folds| {
            format!(
                "{} skin triangle(s) turned over (at most {} in a frame, {} triangle-frames)",
                f.triangles, f.worst_frame, f.triangle_frames
            )
        };
        if r.before.worst_frame == 0 {
            outln!(
                out,
                "  folds         none in the capture's {} frames",
                r.frames
            );
        } else if r.rings == 0 {
            outln!(
                out,
                "  folds         in the capture's {} frames, {}; relaxing the weights round them folded no fewer: left as they are",
                r.frames,
                folds(&r.before)
            );
        } else {
            outln!(
                out,
                "  folds         in the capture's {} frames, {}; weights relaxed over {} vertices ({} rings round them): {}",
                r.frames,
                folds(&r.before),
                r.vertices,
                r.rings,
                folds(&r.after)
            );
        }
    }
    if let Some(t) = &s.on_capture {
        outln!(
            out,
            "  on the capture played through this rig, worst of {} frames: {t}",
            t.frames
        );
    }
    for w in &r.warnings {
        eprintln!("warning: {w}");
    }
    outln!(out, "wrote {}", s.output.display());
    emit(&out);
}

/// What the capture played through the rig shows that a face should not do: skin beyond the
/// markers that moves more than 0.5 mm, triangles turned over, edges stretched past twice their
/// rest length (a face's own jaw open can, so the notes say whether the mesh's own morph targets
/// turn those triangles over and stretch those edges as far).
fn capture_warnings(t: Option<&TakeMetrics>) -> Vec<String> {
    let Some(t) = t else {
        return Vec::new();
    };
    let mut out = Vec::new();
    if t.static_drift_mm.0 > 0.5 {
        out.push(format!(
            "on the capture, the skin no marker should move (cranium, back of the head, neck, ears) moves up to {:.2} mm (frame {}): check the head markers (--head-markers)",
            t.static_drift_mm.0, t.static_drift_mm.1
        ));
    }
    if t.flipped.0 > 0 {
        let verdict = match t.flipped_beyond_shapes {
            Some((0, _)) => {
                "; each is one the mesh's own morph targets turn over too, so the asset folds it itself".to_string()
            }
            Some((b, frame)) => format!(
                "; up to {b} that no morph target of the mesh turns over (frame {frame}): look at that frame (facebake render)"
            ),
            None => String::new(),
        };
        out.push(format!(
            "on the capture, up to {} triangles turn over (frame {}){verdict}",
            t.flipped.0, t.flipped.1
        ));
    }
    if t.frames_over_limit > 0 {
        let verdict = match t.beyond_shapes {
            Some((b, _)) if b <= facebake::metrics::STRETCH_LIMIT => format!(
                "measured against the longest the mesh's own morph targets make each edge, none passes twice it (worst {b:.2}x): the asset stretches these edges itself"
            ),
            Some((b, frame)) => format!(
                "an edge goes {b:.2}x beyond the longest the mesh's own morph targets make it (frame {frame}): look at that frame (facebake render)"
            ),
            None => "a face's own jaw open stretches the skin at the mouth's corners as far, so look at that frame (facebake render) before calling it a tear".to_string(),
        };
        out.push(format!(
            "on the capture, {} of {} frames stretch an edge past twice its rest length (worst {:.2}x, frame {}); {verdict}",
            t.frames_over_limit, t.frames, t.max_stretch.0, t.max_stretch.1
        ));
    }
    out
}

/// Parse `--neutral`: `auto` (the capture's first complete frame), `N` or `A..B`.
pub fn parse_neutral(s: &str) -> Result<Neutral, String> {
    if s.trim() == "auto" {
        return Ok(Neutral::FirstComplete);
    }
    parse_frames(s).map(Neutral::Frames)
}

/// Parse a frame `N` or a range `A..B` (0-based, B excluded, not empty).
fn parse_frames(s: &str) -> Result<Range<usize>, String> {
    let num = |t: &str| {
        t.trim()
            .parse::<usize>()
            .map_err(|_| format!("{t:?} is not a frame number"))
    };
    match s.split_once("..") {
        Some((a, b)) => {
            let (a, b) = (num(a)?, num(b)?);
            if a < b {
                Ok(a..b)
            } else {
                Err(format!("{s}: an empty range of frames"))
            }
        }
        None => {
            let n = num(s)?;
            let end = n
                .checked_add(1)
                .ok_or_else(|| format!("{s}: frame number too large"))?;
            Ok(n..end)
        }
    }
}

/// Parse `--head-refit`: `auto`, `off` or a cutoff in millimetres (finite, above 0).
pub fn parse_head_refit(s: &str) -> Result<facebake::stages::RefitUse, String> {
    use facebake::stages::RefitUse;
    match s.trim() {
        "auto" => Ok(RefitUse::Auto),
        "off" => Ok(RefitUse::Off),
        mm => match mm.parse::<f64>() {
            Ok(v) if v.is_finite() && v > 0.0 => Ok(RefitUse::Cutoff(v / 1000.0)),
            _ => Err(format!(
                "{s:?} is not `auto`, `off` or a cutoff in mm above 0"
            )),
        },
    }
}

/// Parse `--head-smoothing`: `auto`, `off` or `MIN_HZ,BETA,SPEED_HZ`.
pub fn parse_head_smoothing(s: &str) -> Result<SmoothingUse, String> {
    parse_use(s, SmoothingConfig::HEAD)
}

/// Parse `--smoothing`: `auto`, `off` or `MIN_HZ,BETA,SPEED_HZ`.
pub fn parse_smoothing(s: &str) -> Result<SmoothingUse, String> {
    parse_use(s, SmoothingConfig::default())
}

/// `auto` (with `auto`'s parameters), `off` or `MIN_HZ,BETA,SPEED_HZ`, each finite and
/// non-negative, for always.
fn parse_use(s: &str, auto: SmoothingConfig) -> Result<SmoothingUse, String> {
    match s.trim() {
        "auto" => return Ok(SmoothingUse::Auto(auto)),
        "off" => return Ok(SmoothingUse::Off),
        _ => {}
    }
    let v: Vec<f64> = s
        .split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("{s:?} is not `auto`, `off` or three numbers MIN_HZ,BETA,SPEED_HZ"))?;
    match v[..] {
        [min_cutoff_hz, beta, derivative_cutoff_hz]
            if v.iter().all(|x| x.is_finite() && *x >= 0.0) =>
        {
            Ok(SmoothingUse::On(SmoothingConfig {
                min_cutoff_hz,
                beta,
                derivative_cutoff_hz,
            }))
        }
        _ => Err(format!(
            "{s:?} is not `auto`, `off` or three non-negative numbers MIN_HZ,BETA,SPEED_HZ"
        )),
    }
}

/// Parse `--head-markers`: names, `auto`, `auto:N` or `none`.
pub fn parse_head(s: &str) -> Result<HeadMarkers, String> {
    match s.trim() {
        "none" => Ok(HeadMarkers::None),
        "auto" => Ok(HeadMarkers::MostRigid(
            facebake::stages::DEFAULT_HEAD_MARKERS,
        )),
        t => match t.strip_prefix("auto:") {
            Some(n) => n
                .parse()
                .map(HeadMarkers::MostRigid)
                .map_err(|_| format!("{n:?} is not a number of head markers")),
            None => {
                let names: Vec<String> = t
                    .split(',')
                    .map(|n| n.trim().to_string())
                    .filter(|n| !n.is_empty())
                    .collect();
                if let Some((_, n)) = names
                    .iter()
                    .enumerate()
                    .find(|(i, n)| names[..*i].contains(n))
                {
                    return Err(format!("head marker {n:?} is named twice"));
                }
                Ok(HeadMarkers::Named(names))
            }
        },
    }
}

/// Parse a number that must be positive and finite (widths, radii, fractions): `nan`, `inf`,
/// zero, negatives and subnormals are refused as bad arguments.
pub fn parse_positive(s: &str) -> Result<f64, String> {
    let x: f64 = s
        .trim()
        .parse()
        .map_err(|_| format!("{s:?} is not a number"))?;
    if x.is_normal() && x > 0.0 {
        Ok(x)
    } else {
        Err(format!("{s:?} must be a positive finite number"))
    }
}

/// A number in (0, 1].
pub fn parse_fraction(s: &str) -> Result<f64, String> {
    let x = parse_positive(s)?;
    if x <= 1.0 {
        Ok(x)
    } else {
        Err(format!("{s:?} must be at most 1"))
    }
}

#[cfg(test)]
mod tests {
    /// The capture's stretch warning reads the stretch against the mesh's own shapes three
    /// ways: within twice their longest (ICT-FaceKit's JawMoCap take, 3.82× from rest and 1.42×
    /// of its shapes'), past it, and without shapes to read it against.
    #[test]
    fn the_stretch_warning_says_what_the_meshs_own_shapes_make_of_it() {
        let t = facebake::metrics::TakeMetrics {
            frames: 1590,
            max_stretch: (3.82, 376),
            frames_over_limit: 136,
            beyond_shapes: Some((1.42, 433)),
            ..Default::default()
        };
        let w = super::capture_warnings(Some(&t));
        assert_eq!(w.len(), 1, "{w:?}");
        assert!(w[0].contains("136 of 1590 frames"), "{w:?}");
        assert!(w[0].contains("none passes twice it (worst 1.42x)"), "{w:?}");
        let past = facebake::metrics::TakeMetrics {
            beyond_shapes: Some((2.8, 400)),
            ..t
        };
        let w = super::capture_warnings(Some(&past));
        assert!(w[0].contains("an edge goes 2.80x beyond"), "{w:?}");
        let none = facebake::metrics::TakeMetrics {
            beyond_shapes: None,
            ..t
        };
        let w = super::capture_warnings(Some(&none));
        assert!(w[0].contains("before calling it a tear"), "{w:?}");
        assert!(super::capture_warnings(Some(&Default::default())).is_empty());
    }

    #[test]
    fn fractions_are_in_zero_to_one() {
        assert_eq!(super::parse_fraction("0.2"), Ok(0.2));
        assert_eq!(super::parse_fraction("1"), Ok(1.0));
        for bad in ["0", "1.5", "-0.2", "nan", "x"] {
            assert!(super::parse_fraction(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn head_refit_is_auto_off_or_a_cutoff_in_mm() {
        use facebake::stages::RefitUse;
        assert_eq!(super::parse_head_refit("auto"), Ok(RefitUse::Auto));
        assert_eq!(super::parse_head_refit(" off "), Ok(RefitUse::Off));
        assert_eq!(super::parse_head_refit("1.5"), Ok(RefitUse::Cutoff(0.0015)));
        for bad in ["0", "-1", "nan", "inf", "x", ""] {
            assert!(super::parse_head_refit(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn neutral_frame_numbers_never_overflow() {
        assert!(super::parse_frames("18446744073709551615").is_err());
        assert_eq!(super::parse_frames("7"), Ok(7..8));
        assert_eq!(
            super::parse_neutral("auto"),
            Ok(super::Neutral::FirstComplete)
        );
        assert_eq!(
            super::parse_neutral("2..5"),
            Ok(super::Neutral::Frames(2..5))
        );
        assert!(super::parse_neutral("5..5").is_err());
    }
}
