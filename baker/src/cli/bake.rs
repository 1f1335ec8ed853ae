//! `facebake bake`: mesh + marker layout → rig blob, with a report of what the bake measured.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Args;
use serde::Serialize;

use std::ops::Range;

use super::{emit, parse_units, print_json, weight_format, write_file, CliError};
use crate::bake::{bake, BakeConfig, BakeInput, BakeReport, Baked, RigForm};
use crate::io::capture::{read_capture_with_units, Units};
use crate::io::control_triangles::{check_shapes, read_triangles};
use crate::io::gltf_mesh::{load_mesh, FaceMesh};
use crate::io::layout::{place_markers, read_layout, MarkerLayout, PlacedMarker};
use crate::io::marker_groups::{read_groups, read_vertex_sides};
use crate::rbf::KernelKind;
use crate::sparsify::Refit;
use crate::stages::temporal::SmoothingConfig;
use crate::stages::{bake_stages, HeadMarkers, RetargetKind, StagesConfig, StagesReport};
use crate::surface::{
    bake_surface, planar_allowance, Method, SideRule, SurfaceConfig, SurfaceInput, SurfaceMarker,
    SurfaceReport,
};

/// Default largest snap of a `point` marker onto the surface, as a fraction of the mesh's
/// bounding-box diagonal.
pub const DEFAULT_MAX_SNAP_FRACTION: f64 = 0.01;

/// Arguments of `facebake bake`.
#[derive(Debug, Args)]
pub struct BakeArgs {
    /// The face mesh (.glb or .gltf).
    #[arg(long, value_name = "MESH")]
    pub mesh: PathBuf,
    /// Which mesh of the file (default: the first).
    #[arg(long, value_name = "NAME")]
    pub mesh_name: Option<String>,
    /// Which primitive of the mesh (default: the first triangle primitive).
    #[arg(long, value_name = "INDEX")]
    pub primitive: Option<usize>,
    /// The marker layout (.toml or .json).
    #[arg(long, value_name = "LAYOUT")]
    pub layout: PathBuf,
    /// Distance the RBF is built on: euclidean (straight line), geodesic (along the skin, so
    /// the lips and eyelids can part) or hybrid (geodesic near the mouth and eyes, Euclidean
    /// elsewhere) or pbw (paper 002's proximity-based weighting on geodesics blended half and
    /// half with a global multiquadric RBF; weights form). Geodesic, hybrid and pbw default to
    /// the exponential kernel with width factor 1 (pbw: the multiquadric's width).
    #[arg(long, value_enum, default_value_t = Method::Euclidean)]
    pub method: Method,
    /// Apply the layout's `[groups]` masks (upper/lower lip, upper/lower eyelid): markers of one
    /// side of an opening may not move the other side. Masks need the weights form, the
    /// default with --masks.
    #[arg(long)]
    pub masks: bool,
    /// With --masks: a TOML/JSON file giving each mask's sides as glTF vertex sets,
    /// `mouth = { upper = [..], lower = [..] }`, instead of finding them from the openings.
    #[arg(long, value_name = "FILE", requires = "masks")]
    pub mask_sides: Option<PathBuf>,
    /// With --masks: a mask's sides from a grey PNG in the mesh's cylindrical projection (paper
    /// 000 §4.3; white = upper side, black = lower, grey = unmasked), as `NAME=FILE`, once per
    /// mask of the layout's `[groups]`. `facebake mask-images` writes templates.
    #[arg(
        long,
        value_name = "NAME=FILE",
        requires = "masks",
        conflicts_with = "mask_sides"
    )]
    pub mask_image: Vec<String>,
    /// With --masks: a mask's sides from a float vertex attribute of the mesh's primitive (a
    /// glTF application-specific attribute such as `_MASK_MOUTH`: above 0.5 upper side, below
    /// -0.5 lower, between unmasked), as `NAME=ATTRIBUTE`, once per mask.
    #[arg(long, value_name = "NAME=ATTRIBUTE", requires = "masks", conflicts_with_all = ["mask_sides", "mask_image"])]
    pub mask_attribute: Vec<String>,
    /// Runtime form: per-frame RBF coefficients with K kernel terms per vertex, K weights per
    /// vertex on marker displacements, or planar bones (K control triangles per vertex; the
    /// layout's `triangles = [["A", "B", "C"], ..]` when given, else built automatically)
    /// (default: coefficients; weights with --masks or pbw).
    #[arg(long, value_enum)]
    pub form: Option<RigForm>,
    /// Radial kernel (default: gaussian for euclidean, exponential for geodesic and hybrid).
    #[arg(long, value_enum)]
    pub kernel: Option<KernelKind>,
    /// Kernel width in mesh units (default: --width-factor × the mean nearest-marker distance;
    /// the inverse multiquadric uses per-marker radii and ignores it).
    #[arg(long, value_name = "W")]
    pub width: Option<f64>,
    /// Width as a multiple of the mean nearest-marker distance, when --width is not given
    /// (default: 0.75 for euclidean, 1 for geodesic and hybrid).
    #[arg(long, value_name = "F")]
    pub width_factor: Option<f64>,
    /// Leave out the affine term of the RBF system.
    #[arg(long)]
    pub no_affine: bool,
    /// Influences per vertex, 1 to 64.
    #[arg(short = 'k', long = "influences", value_name = "K", default_value_t = BakeConfig::default().k)]
    pub k: usize,
    /// How the kept weights are re-fitted after sparsifying (weights form).
    #[arg(long, value_enum, default_value_t = BakeConfig::default().refit)]
    pub refit: Refit,
    /// Largest distance a `point` marker may be snapped onto the surface, in mesh units
    /// (default: 1% of the mesh's bounding-box diagonal).
    #[arg(long, value_name = "D")]
    pub max_snap: Option<f64>,
    /// The actor's capture (.c3d, .trc or .csv): also bake the capture stages (head-motion
    /// compensation, fill, retargeting onto the layout's markers) from it, so that `play`
    /// takes this actor's raw captures. Its markers are matched to the layout's by name.
    #[arg(long, value_name = "CAPTURE")]
    pub capture: Option<PathBuf>,
    /// Units of the capture's numbers, overriding what the file says.
    #[arg(long, value_name = "UNITS", value_parser = parse_units, requires = "capture")]
    pub capture_units: Option<Units>,
    /// The actor's neutral pose: a frame `N` or a range `A..B` averaged (0-based, B excluded).
    #[arg(long, value_name = "FRAMES", default_value = "0", value_parser = parse_frames, requires = "capture")]
    pub neutral: Range<usize>,
    /// Head markers for compensation: comma-separated names, `auto` (the 4 most rigid over
    /// the capture), `auto:N`, or `none` (the capture is already head-stabilised).
    #[arg(long, value_name = "NAMES", default_value = "auto", value_parser = parse_head, requires = "capture")]
    pub head_markers: HeadMarkers,
    /// A compensated marker further than this from its neutral position is rejected and
    /// rebuilt, as a fraction of the actor's half extent.
    #[arg(long, value_name = "F", default_value_t = StagesConfig::default().max_displacement, requires = "capture")]
    pub max_displacement: f64,
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
    /// The one-euro smoothing of the compensated markers: `MIN_HZ,BETA,SPEED_HZ` (cutoff when
    /// still, Hz added per m/s of speed, cutoff of the speed estimate), or `off`. Its lag when
    /// still is rate / (2π MIN_HZ) frames.
    #[arg(long, value_name = "PARAMS", default_value = "1,10,1", value_parser = parse_smoothing, requires = "capture")]
    pub smoothing: SmoothingChoice,
    /// How the actor's markers become the character's: the RBF map (inverse multiquadric +
    /// affine, paper 000) or per-region proportional scaling (paper 003 §4).
    #[arg(long, value_enum, default_value_t = RetargetKind::Rbf, requires = "capture")]
    pub retarget: RetargetKind,
    /// Planar form: bone radius as a multiple of the closest connected-marker distance.
    #[arg(long, value_name = "F", default_value_t = BakeConfig::default().planar_radius)]
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
    /// Whether the bake needs the surface-aware path.
    pub fn surface_aware(&self) -> bool {
        self.method != Method::Euclidean || (self.masks && self.form != Some(RigForm::Planar))
    }

    /// The bake configuration: the options given, the defaults of the method for the rest.
    pub fn config(&self) -> BakeConfig {
        let d = if self.method == Method::Euclidean {
            BakeConfig::default()
        } else {
            SurfaceConfig::default().bake
        };
        let form = if self.masks || self.method == Method::Pbw {
            RigForm::Weights
        } else {
            d.form
        };
        BakeConfig {
            form: self.form.unwrap_or(form),
            kernel: self.kernel.unwrap_or(d.kernel),
            width: self.width.or(d.width),
            width_factor: self.width_factor.unwrap_or(d.width_factor),
            affine: d.affine && !self.no_affine,
            k: self.k,
            refit: self.refit,
            planar_radius: self.planar_radius,
            ..d
        }
    }

    /// The surface-aware configuration.
    pub fn surface_config(&self) -> SurfaceConfig {
        SurfaceConfig {
            method: self.method,
            masks: self.masks,
            bake: self.config(),
            ..SurfaceConfig::default()
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
    /// The bake's own report.
    pub report: BakeReport,
    /// The capture stages, if a capture was given.
    pub stages: Option<StagesReport>,
}

/// Place `layout` on `mesh` (snapping `point` markers at most `max_snap`, default 1% of the
/// diagonal) and bake it with `config`; with `planar_masks` (planar form), apply the layout's
/// `[groups]` masks with that side rule. Errors name the layout file.
pub fn bake_layout(
    mesh: &FaceMesh,
    layout: &MarkerLayout,
    config: &BakeConfig,
    max_snap: Option<f64>,
    planar_masks: Option<&SideRule>,
) -> Result<(Baked, Vec<PlacedMarker>), CliError> {
    let max_snap = max_snap.unwrap_or(DEFAULT_MAX_SNAP_FRACTION * mesh.diagonal());
    let placed = place_markers(layout, mesh, max_snap)?;
    let names: Vec<String> = placed.iter().map(|m| m.name.clone()).collect();
    let rest: Vec<[f64; 3]> = placed.iter().map(|m| m.position).collect();
    let stiffness: Vec<f64> = placed.iter().map(|m| m.stiffness).collect();
    if let Some(t) = &config.control_triangles {
        check_shapes(&layout.source, t, &names, &rest)?;
    }
    let allowance = match planar_masks {
        Some(rule) => {
            let groups = read_groups(&layout.source, &names)
                .map_err(|e| CliError::input(&layout.source, e.to_string()))?;
            if groups.is_empty() {
                return Err(CliError::input(
                    &layout.source,
                    "--masks needs a [groups] table naming the upper and lower markers of each opening",
                ));
            }
            let markers: Vec<SurfaceMarker> =
                placed.iter().map(SurfaceMarker::from_placed).collect();
            let input = SurfaceInput {
                mesh,
                markers: &markers,
                groups: &groups,
                sides: rule,
            };
            let allowance = planar_allowance(&input, &SurfaceConfig::default())
                .map_err(|e| CliError::input(&layout.source, format!("planar masks: {e}")))?;
            Some(allowance)
        }
        None => None,
    };
    let baked = bake(
        &BakeInput {
            vertices: &mesh.positions,
            marker_names: &names,
            marker_rest: &rest,
            stiffness: &stiffness,
            triangles: &mesh.triangles,
            planar_masks: allowance.as_ref(),
        },
        config,
    )
    .map_err(|source| CliError::Bake {
        path: layout.source.clone(),
        source,
    })?;
    Ok((baked, placed))
}

/// What a surface-aware `bake` reports.
#[derive(Debug, Serialize)]
pub struct SurfaceSummary {
    /// The rig written.
    pub output: PathBuf,
    /// The mesh file.
    pub mesh: PathBuf,
    /// The layout file.
    pub layout: PathBuf,
    /// Vertices of the rig.
    pub vertices: usize,
    /// Markers of the rig.
    pub markers: usize,
    /// Masks applied (group names).
    pub masks: Vec<String>,
    /// Weight format, `Q(23−F).F`.
    pub weight_format: String,
    /// The bake's own report.
    pub report: SurfaceReport,
    /// The capture stages, if a capture was given.
    pub stages: Option<StagesReport>,
}

/// `facebake bake --method geodesic|hybrid` or `--masks`.
fn run_surface(
    args: &BakeArgs,
    mesh: &FaceMesh,
    layout: &MarkerLayout,
) -> Result<ExitCode, CliError> {
    let max_snap = args
        .max_snap
        .unwrap_or(DEFAULT_MAX_SNAP_FRACTION * mesh.diagonal());
    let placed = place_markers(layout, mesh, max_snap)?;
    let names: Vec<String> = placed.iter().map(|m| m.name.clone()).collect();
    let groups = read_groups(&args.layout, &names)
        .map_err(|e| CliError::input(&args.layout, e.to_string()))?;
    if args.masks && groups.is_empty() {
        return Err(CliError::input(
            &args.layout,
            "--masks needs a [groups] table naming the upper and lower markers of each opening",
        ));
    }
    let markers: Vec<SurfaceMarker> = placed.iter().map(SurfaceMarker::from_placed).collect();
    let sides = match &args.mask_sides {
        Some(path) => SideRule::VertexSets(
            read_vertex_sides(path, &groups).map_err(|e| CliError::input(path, e.to_string()))?,
        ),
        None if !args.mask_image.is_empty() => SideRule::VertexSets(named_sides(
            "--mask-image",
            &args.mask_image,
            &groups,
            &args.layout,
            |file| image_sides(file, mesh),
        )?),
        None if !args.mask_attribute.is_empty() => SideRule::VertexSets(named_sides(
            "--mask-attribute",
            &args.mask_attribute,
            &groups,
            &args.layout,
            |attr| attribute_sides(attr, mesh),
        )?),
        None => SideRule::Auto,
    };
    let config = args.surface_config();
    let baked = bake_surface(
        &SurfaceInput {
            mesh,
            markers: &markers,
            groups: &groups,
            sides: &sides,
        },
        &config,
    )
    .map_err(|e| {
        // Mask problems with given vertex sets are about the sides file.
        let path = match (&e, &args.mask_sides) {
            (crate::surface::SurfaceError::Mask(_), Some(sides)) => sides,
            _ => &args.layout,
        };
        CliError::input(path, format!("surface-aware bake failed: {e}"))
    })?;
    let (blob, stages) = attach_stages(args, &placed, &baked.blob)?;
    write_file(&args.output, &blob)?;
    let summary = SurfaceSummary {
        output: args.output.clone(),
        mesh: args.mesh.clone(),
        layout: args.layout.clone(),
        vertices: mesh.positions.len(),
        markers: markers.len(),
        masks: if config.masks {
            groups.iter().map(|g| g.name.clone()).collect()
        } else {
            Vec::new()
        },
        weight_format: weight_format(baked.report.weight_frac_bits),
        report: baked.report,
        stages,
    };
    if args.json {
        print_json(&summary);
    } else {
        let r = &summary.report;
        let mut out = String::new();
        outln!(
            out,
            "baked {} vertices with {} markers: {} RBF, {} kernel, {}",
            summary.vertices,
            summary.markers,
            r.method.name(),
            r.kernel,
            form_text(r.form)
        );
        outln!(
            out,
            "masks: {}; openings found: {}; vertices masked: {}",
            if summary.masks.is_empty() {
                "none".to_string()
            } else {
                summary.masks.join(", ")
            },
            r.openings,
            r.masked_vertices
        );
        outln!(
            out,
            "kernel matrix smallest eigenvalue {:.3e} × mean |φ|, ridge {:.3e}, condition {:.2e}, geodesic asymmetry {:.1} %",
            r.min_eigenvalue,
            r.ridge,
            r.condition,
            100.0 * r.geodesic_asymmetry
        );
        outln!(
            out,
            "weights {}, {} → {}",
            summary.weight_format,
            bytes_text(blob.len()),
            summary.output.display()
        );
        if let Some(st) = &summary.stages {
            outln!(
                out,
                "capture stages: head markers {}, retargeting {:?}",
                st.head_markers.join(", "),
                st.retarget
            );
        }
        for w in &r.warnings {
            outln!(out, "warning: {w}");
        }
        emit(&out);
    }
    Ok(ExitCode::SUCCESS)
}

/// The vertex sides of every mask from `--mask-image NAME=FILE` or `--mask-attribute
/// NAME=ATTRIBUTE` arguments (`flag` names which), in `groups` order: `read` turns one value into
/// that mask's sides.
fn named_sides(
    flag: &str,
    args: &[String],
    groups: &[crate::io::marker_groups::MarkerGroups],
    layout: &std::path::Path,
    read: impl Fn(&str) -> Result<crate::io::marker_groups::VertexSets, CliError>,
) -> Result<Vec<crate::io::marker_groups::VertexSets>, CliError> {
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

/// A mask's sides from a mask image (see [`crate::io::mask_image`]).
fn image_sides(
    file: &str,
    mesh: &FaceMesh,
) -> Result<crate::io::marker_groups::VertexSets, CliError> {
    let path = PathBuf::from(file);
    crate::io::mask_image::read_sides(&path, &mesh.positions, &mesh.triangles).map_err(|e| {
        let text = e.to_string();
        let prefix = format!("{}: ", path.display());
        CliError::input(&path, text.strip_prefix(&prefix).unwrap_or(&text))
    })
}

/// A mask's sides from a per-vertex float attribute of the mesh: above ½ the upper side, below
/// −½ the lower side, between unmasked.
fn attribute_sides(
    name: &str,
    mesh: &FaceMesh,
) -> Result<crate::io::marker_groups::VertexSets, CliError> {
    let values = mesh.attributes.get(name).ok_or_else(|| {
        let known: Vec<&str> = mesh.attributes.keys().map(String::as_str).collect();
        CliError::input(
            &mesh.source,
            format!(
                "mesh \"{}\" has no float vertex attribute {name:?} (it has: {})",
                mesh.mesh_name,
                if known.is_empty() {
                    "none".to_string()
                } else {
                    known.join(", ")
                }
            ),
        )
    })?;
    let pick = |keep: &dyn Fn(f32) -> bool| {
        values
            .iter()
            .enumerate()
            .filter(|(_, &x)| keep(x))
            .map(|(v, _)| v as u32)
            .collect::<Vec<u32>>()
    };
    let (upper, lower) = (pick(&|x| x > 0.5), pick(&|x| x < -0.5));
    if upper.is_empty() || lower.is_empty() {
        return Err(CliError::input(
            &mesh.source,
            format!(
                "vertex attribute {name:?} puts {} vertices on the upper side (> 0.5) and {} on the lower (< -0.5): a mask needs both",
                upper.len(),
                lower.len()
            ),
        ));
    }
    Ok((upper, lower))
}

/// With `--capture`, bake the capture stages for the `placed` markers and add them to `blob`.
fn attach_stages(
    args: &BakeArgs,
    placed: &[PlacedMarker],
    blob: &[u8],
) -> Result<(Vec<u8>, Option<StagesReport>), CliError> {
    let Some(path) = &args.capture else {
        return Ok((blob.to_vec(), None));
    };
    let capture = read_capture_with_units(path, args.capture_units)?;
    let names: Vec<String> = placed.iter().map(|m| m.name.clone()).collect();
    let character: Vec<[f64; 3]> = placed.iter().map(|m| m.position).collect();
    let space = super::load_rig(&args.output, blob)?.space();
    let config = StagesConfig {
        neutral: args.neutral.clone(),
        head: args.head_markers.clone(),
        max_displacement: args.max_displacement,
        retarget: args.retarget,
        virtual_markers: args.virtual_markers.clone(),
        anchor_markers: args.anchor_markers.clone(),
        head_tolerance: args.head_tolerance,
        max_step: args.max_step,
        smoothing: args.smoothing.0,
    };
    let stages = bake_stages(&capture, &names, &character, &space, &config)
        .map_err(|e| CliError::input(path, e.to_string()))?;
    let blob = crate::blob::with_stages(blob, &stages.bytes)
        .map_err(|e| CliError::input(path, e.to_string()))?;
    Ok((blob, Some(stages.report)))
}

/// Run `facebake bake`.
pub fn run(args: &BakeArgs) -> Result<ExitCode, CliError> {
    let mesh = load_mesh(&args.mesh, args.mesh_name.as_deref(), args.primitive)?;
    let layout = read_layout(&args.layout)?;
    if args.surface_aware() {
        return run_surface(args, &mesh, &layout);
    }
    let mut config = args.config();
    if config.form == RigForm::Planar {
        let names: Vec<String> = layout.markers.iter().map(|m| m.name.clone()).collect();
        config.control_triangles = read_triangles(&args.layout, &names)?;
    }
    let sides = match &args.mask_sides {
        Some(path) => {
            let names: Vec<String> = layout.markers.iter().map(|m| m.name.clone()).collect();
            let groups = read_groups(&args.layout, &names)
                .map_err(|e| CliError::input(&args.layout, e.to_string()))?;
            SideRule::VertexSets(
                read_vertex_sides(path, &groups)
                    .map_err(|e| CliError::input(path, e.to_string()))?,
            )
        }
        None => SideRule::Auto,
    };
    let masks = (args.masks && config.form == RigForm::Planar).then_some(&sides);
    let (baked, placed) = bake_layout(&mesh, &layout, &config, args.max_snap, masks)?;
    let (blob, stages) = attach_stages(args, &placed, &baked.blob)?;
    write_file(&args.output, &blob)?;
    let mut report = baked.report;
    report.sizes.total = blob.len();
    report.sizes.other_bytes_per_vertex =
        (blob.len() - report.sizes.influence_bytes) as f64 / mesh.positions.len().max(1) as f64;
    let summary = BakeSummary {
        output: args.output.clone(),
        mesh: args.mesh.clone(),
        mesh_name: mesh.mesh_name.clone(),
        layout: args.layout.clone(),
        vertices: mesh.positions.len(),
        markers: placed.len(),
        max_snap_distance: placed
            .iter()
            .map(|m| m.surface.distance)
            .fold(0.0, f64::max),
        affine: config.affine,
        weight_format: weight_format(report.weight_frac_bits),
        bytes_per_influence: report.sizes.influence_bytes as f64
            / report.sizes.influences.max(1) as f64,
        report,
        stages,
    };
    if args.json {
        print_json(&summary);
    } else {
        print_text(&summary);
    }
    Ok(ExitCode::SUCCESS)
}

/// Bytes as "N bytes (x.y KiB)".
pub fn bytes_text(n: usize) -> String {
    format!("{n} bytes ({:.1} KiB)", n as f64 / 1024.0)
}

/// What a rig form stores per influence, for reports.
pub fn form_text(form: RigForm) -> &'static str {
    match form {
        RigForm::Coefficients => {
            "coefficients: per-frame RBF coefficients, K kernel terms per vertex"
        }
        RigForm::Weights => "weights: K weights per vertex on marker displacements",
        RigForm::Planar => "planar: K control-triangle region transforms per vertex",
    }
}

fn print_text(s: &BakeSummary) {
    let mut out = String::new();
    let r = &s.report;
    outln!(
        out,
        "baked mesh \"{}\" ({}, {} vertices) with {} markers ({})",
        s.mesh_name,
        s.mesh.display(),
        s.vertices,
        s.markers,
        s.layout.display()
    );
    outln!(out, "  form          {}", form_text(r.form));
    if r.form != RigForm::Planar {
        outln!(
            out,
            "  kernel        {}, {}",
            r.kernel,
            if s.affine {
                "with affine term"
            } else {
                "no affine term"
            }
        );
        outln!(out, "  condition     {:.3e} (1-norm estimate)", r.condition);
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
    let stored = match r.form {
        RigForm::Coefficients => "kernel values",
        RigForm::Weights => "weights",
        RigForm::Planar => "weights",
    };
    if r.form == RigForm::Planar {
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
    if r.form == RigForm::Coefficients {
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
        match r.form {
            RigForm::Coefficients => "kernel mass",
            RigForm::Weights => "dense weight",
            RigForm::Planar => "eq-12 weight",
        }
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
    if let Some(st) = &s.stages {
        outln!(
            out,
            "  capture       neutral frames {:?}, actor half extent {:.1} mm (capture in {})",
            st.neutral_frames,
            st.actor_half_extent * 1000.0,
            st.units
        );
        outln!(
            out,
            "  head markers  {} ({}; their distances vary by {:.3} mm)",
            st.head_markers.join(", "),
            if st.head_markers_picked {
                "the most rigid, picked by the baker"
            } else {
                "as named"
            },
            st.head_spread * 1000.0
        );
        outln!(
            out,
            "  retargeting   {}; RBF condition {:.3e}, largest coefficient rounding {:.2e}",
            match st.retarget {
                RetargetKind::Rbf => "IMQ + affine RBF map (paper 000)",
                RetargetKind::Proportional => "per-region proportional scaling (paper 003)",
            },
            st.retarget_condition,
            st.max_alpha_rounding
        );
        outln!(
            out,
            "  checks        head-marker distances within {:.2} mm; steps over {:.2} mm per frame rejected; smoothing {}",
            st.head_tolerance * 1000.0,
            st.max_step * 1000.0,
            match &st.smoothing {
                Some(f) => format!(
                    "one-euro {} Hz, beta {}, speed {} Hz (lag when still {} frames)",
                    f.min_cutoff_hz, f.beta, f.derivative_cutoff_hz, st.smoothing_lag_frames
                ),
                None => "off".to_string(),
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
    for w in &r.warnings {
        eprintln!("warning: {w}");
    }
    outln!(out, "wrote {}", s.output.display());
    emit(&out);
}

/// Parse `--neutral`: `N` or `A..B`.
pub fn parse_frames(s: &str) -> Result<Range<usize>, String> {
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
        None => num(s).map(|n| n..n + 1),
    }
}

/// `--smoothing`: the filter's parameters, or `None` for `off`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SmoothingChoice(pub Option<SmoothingConfig>);

/// Parse `--smoothing`: `off` or `MIN_HZ,BETA,SPEED_HZ`, each finite and non-negative.
pub fn parse_smoothing(s: &str) -> Result<SmoothingChoice, String> {
    if s.trim() == "off" {
        return Ok(SmoothingChoice(None));
    }
    let v: Vec<f64> = s
        .split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("{s:?} is not `off` or three numbers MIN_HZ,BETA,SPEED_HZ"))?;
    match v[..] {
        [min_cutoff_hz, beta, derivative_cutoff_hz]
            if v.iter().all(|x| x.is_finite() && *x >= 0.0) =>
        {
            Ok(SmoothingChoice(Some(SmoothingConfig {
                min_cutoff_hz,
                beta,
                derivative_cutoff_hz,
            })))
        }
        _ => Err(format!(
            "{s:?} is not `off` or three non-negative numbers MIN_HZ,BETA,SPEED_HZ"
        )),
    }
}

/// Parse `--head-markers`: names, `auto`, `auto:N` or `none`.
pub fn parse_head(s: &str) -> Result<HeadMarkers, String> {
    match s.trim() {
        "none" => Ok(HeadMarkers::None),
        "auto" => Ok(HeadMarkers::MostRigid(4)),
        t => match t.strip_prefix("auto:") {
            Some(n) => n
                .parse()
                .map(HeadMarkers::MostRigid)
                .map_err(|_| format!("{n:?} is not a number of head markers")),
            None => Ok(HeadMarkers::Named(
                t.split(',')
                    .map(|n| n.trim().to_string())
                    .filter(|n| !n.is_empty())
                    .collect(),
            )),
        },
    }
}
