//! The bake: a [`Scene`] and [`BakeOptions`] in, a sealed rig blob out, written once.
//!
//! [`bake()`] checks the options against each other once, then the distance strategy gives each
//! vertex its dense weights (Euclidean: `euclidean`; geodesic, hybrid, PBW and masks:
//! [`crate::surface`]) and the deformer ([`crate::deformer`]) keeps, re-fits and quantises K of
//! them; with a capture, the stages ([`crate::stages`]) are baked in the same rig space (without
//! one, from the markers at rest: `at_rest`); then the blob is written with everything in it.

mod at_rest;
mod euclidean;
pub mod mouth_share;
pub mod own_shapes;
mod playback;
pub mod relax;

use facebake_runtime::Space;
use serde::Serialize;

use crate::blob::{self, BlobContents, BlobError, BlobSizes};
use crate::deformer::planar::reference::PlanarReference;
use crate::deformer::planar::PlanarSummary;
use crate::deformer::rbf::DenseRbf;
use crate::deformer::DeformerError;
use crate::deformer::{self, DeformerKind, DeformerOutput};
use crate::model::Capture;
use crate::model::FaceMesh;
use crate::model::MarkerGroups;
use crate::model::PlacedMarker;
use crate::options::{BakeOptions, Method, SurfaceOptions};
use crate::planar::{PlanarError, PlanarOptions, DEGENERATE_ANGLE_DEGREES};
use crate::rbf::SolveError;
use crate::sparsify::SparsifyError;
use crate::stages::reference::StagesF64;
use crate::stages::{bake_stages, StagesError, StagesReport};
use crate::surface::{SideRule, SurfaceError, SurfaceFigures, SurfaceInput, SurfaceMarker};

/// What a rig is baked from: the mesh, the markers placed on it, their groups either side of the
/// openings and the control triangles given in the layout, and the actor's capture when the
/// rig should also run the capture stages.
pub struct Scene<'a> {
    /// The mesh; the rig deforms its glTF vertices.
    pub mesh: &'a FaceMesh,
    /// The markers, in rig order.
    pub markers: Vec<SurfaceMarker>,
    /// Marker groups, one per mask ([`BakeOptions::masks`]).
    pub groups: Vec<MarkerGroups>,
    /// How the masks' vertex sides are found.
    pub sides: SideRule,
    /// Planar deformer: the control triangles (marker indices); `None` builds them.
    pub control_triangles: Option<Vec<[usize; 3]>>,
    /// The actor's capture: when given, the capture stages are baked into the rig.
    pub capture: Option<&'a Capture>,
}

impl<'a> Scene<'a> {
    /// `markers` on `mesh`, without groups, control triangles or capture.
    pub fn new(mesh: &'a FaceMesh, markers: Vec<SurfaceMarker>) -> Self {
        Self {
            mesh,
            markers,
            groups: Vec::new(),
            sides: SideRule::Auto,
            control_triangles: None,
            capture: None,
        }
    }

    /// Layout markers placed on `mesh`.
    pub fn placed(mesh: &'a FaceMesh, placed: &[PlacedMarker]) -> Self {
        Self::new(
            mesh,
            placed.iter().map(SurfaceMarker::from_placed).collect(),
        )
    }

    /// Marker names, in rig order.
    pub fn marker_names(&self) -> Vec<String> {
        self.markers.iter().map(|m| m.name.clone()).collect()
    }

    /// Marker rest positions, asset units.
    pub fn marker_rest(&self) -> Vec<[f64; 3]> {
        self.markers.iter().map(|m| m.rest).collect()
    }

    /// This scene with the mask groups found from the mesh's mouth and eye openings
    /// ([`crate::surface::masks::groups_from_openings`]), as a bake with masks and no groups
    /// uses.
    pub fn with_groups_from_openings(&self) -> Result<Self, SurfaceError> {
        // In the face's own axes: "above" and "below" the openings are the face's.
        let frame = crate::frame::FaceFrame::of(self.mesh);
        let groups = crate::surface::masks::groups_from_openings(
            &frame.mesh(self.mesh),
            &frame.points(&self.marker_rest()),
        )?;
        Ok(Self {
            mesh: self.mesh,
            markers: self.markers.clone(),
            groups,
            sides: self.sides.clone(),
            control_triangles: self.control_triangles.clone(),
            capture: self.capture,
        })
    }

    /// The markers a capture's head fit may choose from (`--head-markers auto`): the skull
    /// markers and each eye's inner-corner marker, found from the mesh's openings; never a
    /// brow, cheek, jaw or lip marker, however rigid a take without those expressions makes
    /// them look. In rig order, by name.
    pub fn head_candidates(&self, options: &SurfaceOptions) -> Result<Vec<String>, SurfaceError> {
        let (_, candidates) = crate::surface::skin_markers(&self.surface_input(), options)?;
        Ok(candidates
            .iter()
            .map(|&i| self.markers[i].name.clone())
            .collect())
    }

    fn surface_input(&self) -> SurfaceInput<'_> {
        SurfaceInput {
            mesh: self.mesh,
            markers: &self.markers,
            groups: &self.groups,
            sides: &self.sides,
            head_fit: self.capture.is_some(),
            held: None,
        }
    }
}

/// The bake failed.
#[derive(Debug, thiserror::Error)]
pub enum BakeError {
    /// The RBF system.
    #[error("solving the RBF system: {0}")]
    Solve(#[from] SolveError),
    /// Sparsification / quantisation.
    #[error("sparsifying the weights: {0}")]
    Sparsify(#[from] SparsifyError),
    /// Writing the blob.
    #[error("writing the rig: {0}")]
    Blob(#[from] BlobError),
    /// Inconsistent input or options.
    #[error("{0}")]
    Input(String),
    /// The deformer.
    #[error(transparent)]
    Deformer(#[from] crate::deformer::DeformerError),
    /// A surface-aware method (geodesics, masks).
    #[error("surface-aware bake failed: {0}")]
    Surface(#[from] SurfaceError),
    /// The capture stages.
    #[error("{0}")]
    Stages(#[from] StagesError),
    /// The normals section.
    #[error("{0}")]
    Normals(#[from] crate::normals::NormalsError),
}

/// What the bake measured.
#[derive(Clone, Debug, Serialize)]
pub struct BakeReport {
    /// The runtime's deformer.
    pub deformer: DeformerKind,
    /// The distance (or weighting) the dense weights came from.
    pub method: Method,
    /// Radial function used (none for planar bones).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub radial: Option<&'static str>,
    /// 1-norm condition estimate of the RBF system (none for planar bones).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub condition: Option<f64>,
    /// Warnings worth a user's attention.
    pub warnings: Vec<String>,
    /// Influences per vertex (K).
    pub k: usize,
    /// Fractional weight bits chosen.
    pub weight_frac_bits: u8,
    /// Mean share of the vertex's dense weight (linear), radial mass (RBF) or eq-12 weight
    /// (planar) dropped by keeping K.
    pub mean_dropped_mass: f64,
    /// Largest such share.
    pub max_dropped_mass: f64,
    /// Largest weight rounding error.
    pub max_weight_rounding: f64,
    /// Largest coefficient-map rounding error relative to its row (RBF deformer).
    pub max_matrix_rounding: f64,
    /// Blob sizes, the stages included.
    pub sizes: BlobSizes,
    /// Planar deformer: control triangles, and vertices within no bone's radius.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub planar: Option<PlanarSummary>,
    /// Surface-aware methods and masks: spectrum, ridge, openings, masks.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub surface: Option<SurfaceFigures>,
    /// The capture stages, from the scene's capture or at rest ([`StagesReport::at_rest`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stages: Option<StagesReport>,
    /// With the mouth's corners reshaped, on a mesh with morph targets or with a capture: the
    /// share of their crack profile kept so that neither the mesh's own shapes nor the capture
    /// tear the rig (`mouth_share`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mouth_share: Option<mouth_share::MouthShareChoice>,
    /// With a capture (linear deformer, surface path): the skin triangles the capture folded
    /// and how the weights were relaxed round them (`relax`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub relaxed: Option<relax::RelaxChoice>,
    /// On a mesh with morph targets: the rig measured against them (`own_shapes`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub shapes: Option<own_shapes::ShapesCheck>,
}

/// A patch of skin whose dense weights are relaxed (`relax`): the skin's welded neighbours and
/// the patch's welded vertices.
struct Relaxed<'a> {
    neighbours: &'a [Vec<u32>],
    patch: &'a [u32],
}

/// The f64 twin of a baked deformer: what the runtime approximates.
pub enum DeformerReference {
    /// The papers' dense RBF, solved every frame (Euclidean RBF and linear bakes).
    Rbf(DenseRbf),
    /// Per vertex, its dense weights on the marker displacements, masks applied (surface-aware
    /// bakes).
    Weights(DenseWeights),
    /// Planar bones: eqs 1–12 on the exact rest positions with the baked influences.
    Planar(PlanarReference),
}

impl DeformerReference {
    /// Deformed positions for marker positions `markers` (asset units).
    pub fn frame(&self, markers: &[[f64; 3]]) -> Vec<[f64; 3]> {
        match self {
            Self::Rbf(r) => r.frame(markers),
            Self::Weights(w) => w.frame(markers),
            Self::Planar(p) => p.frame(markers).0,
        }
    }

    /// The planar bones' reference, for a planar bake.
    pub fn planar(&self) -> Option<&PlanarReference> {
        match self {
            Self::Planar(p) => Some(p),
            _ => None,
        }
    }
}

/// Dense per-vertex weights on marker displacements.
pub struct DenseWeights {
    /// Vertex rest positions, asset units.
    pub rest: Vec<[f64; 3]>,
    /// Marker rest positions, asset units.
    pub marker_rest: Vec<[f64; 3]>,
    /// Per vertex, one weight per marker.
    pub weights: Vec<Vec<f64>>,
    /// Per vertex, `(marker, weight)` on markers' displacements along `up` alone (the mouth's
    /// corners, `surface::corners`; empty elsewhere).
    pub vertical: Vec<Vec<(usize, f64)>>,
    /// The face's vertical in file coordinates, a unit vector: the direction the rig's derived
    /// markers store ([`crate::deformer::linear::derived_direction`]).
    pub up: [f64; 3],
    /// Per vertex, `(marker, weight)` on markers' displacements along `ahead` alone (the lower
    /// lip's depth, `surface::let_go::lower_lip_depth`; empty elsewhere).
    pub forward: Vec<Vec<(usize, f64)>>,
    /// The face's forward axis in file coordinates, as the rig's derived markers store it.
    pub ahead: [f64; 3],
}

impl DenseWeights {
    /// Deformed positions for marker positions `markers` (asset units).
    pub fn frame(&self, markers: &[[f64; 3]]) -> Vec<[f64; 3]> {
        let d: Vec<[f64; 3]> = markers
            .iter()
            .zip(&self.marker_rest)
            .map(|(m, r)| [0, 1, 2].map(|c| m[c] - r[c]))
            .collect();
        let none = Vec::new();
        self.rest
            .iter()
            .zip(&self.weights)
            .enumerate()
            .map(|(i, (v, w))| {
                let mut p =
                    [0, 1, 2].map(|c| v[c] + w.iter().zip(&d).map(|(w, d)| w * d[c]).sum::<f64>());
                let axial = [(&self.vertical, self.up), (&self.forward, self.ahead)];
                for (corrections, axis) in axial {
                    for &(m, w) in corrections.get(i).unwrap_or(&none) {
                        let d = d.get(m).copied().unwrap_or([0.0; 3]);
                        let along: f64 = (0..3).map(|c| d[c] * axis[c]).sum();
                        for (p, u) in p.iter_mut().zip(axis) {
                            *p += w * along * u;
                        }
                    }
                }
                p
            })
            .collect()
    }
}

/// The f64 references of everything baked.
pub struct Reference {
    /// The deformer's.
    pub deformer: DeformerReference,
    /// The capture stages', when the rig has them.
    pub stages: Option<StagesF64>,
}

/// A finished bake.
pub struct Baked {
    /// The sealed blob.
    pub blob: Vec<u8>,
    /// The rig space of the blob: asset units to rig units.
    pub space: Space,
    /// Figures.
    pub report: BakeReport,
    /// The f64 references.
    pub reference: Reference,
}

/// The deformer's output with what the strategy measured besides it.
struct DeformerBake {
    output: DeformerOutput,
    radial: Option<&'static str>,
    condition: Option<f64>,
    warnings: Vec<String>,
    planar: Option<PlanarSummary>,
    surface: Option<SurfaceFigures>,
    reference: DeformerReference,
    /// Surface-aware methods: marker-to-marker distances along the skin and the skull markers,
    /// for the capture stages' fill neighbours and head-marker candidates.
    surface_markers: Option<(Vec<Vec<f64>>, Vec<String>)>,
}

/// Bake `scene` with `options` into a sealed rig: deformer, and capture stages, from the
/// scene's capture or, without one, from the markers at rest (`at_rest`).
pub fn bake(scene: &Scene<'_>, options: &BakeOptions) -> Result<Baked, BakeError> {
    let auto;
    let mut unmasked = Vec::new();
    let scene = if options.masks && scene.groups.is_empty() {
        auto = scene.with_groups_from_openings()?;
        unmasked = crate::surface::masks::unmasked_openings(&auto.groups);
        &auto
    } else {
        scene
    };
    check(options)?;
    let names = scene.marker_names();
    let rest = scene.marker_rest();
    let space = crate::space::space_for(&scene.mesh.positions);
    let mut d = bake_deformer(scene, options, &rest, &space, None, None)?;
    let mut at_rest_warning = None;
    let stages = match scene.capture {
        Some(capture) => {
            let config = stages_config(scene, options, &d, &names)?;
            Some(bake_stages(capture, &names, &rest, &space, &config)?)
        }
        None if options.stages.at_rest => {
            let stages = stages_config(scene, options, &d, &names)
                .map_err(|e| {
                    format!("no capture stages: the rig plays through Rig::deform only ({e})")
                })
                .and_then(|config| at_rest::stages(&names, &rest, &space, &config));
            match stages {
                Ok(stages) => Some(stages),
                Err(why) => {
                    at_rest_warning = Some(why);
                    None
                }
            }
        }
        None => None,
    };
    // The skin beyond the markers follows the markers the head fit holds still. The first bake
    // took the head candidates, which the stages pick all of unless there are more of them
    // than they keep or the user named others: then the deformer is baked again.
    let mut held = None;
    if let (Some(st), Some(_)) = (&stages, scene.capture) {
        let markers: Vec<usize> = st
            .report
            .head_markers
            .iter()
            .filter_map(|h| names.iter().position(|n| n == h))
            .collect();
        // The first bake took the head candidates as the markers held still (the anchoring
        // follows three of them, `surface::anchoring::followed`).
        let candidates = d.surface_markers.as_ref().map(|(_, c)| c);
        if candidates.is_some_and(|c| !same_markers(c, &st.report.head_markers)) {
            d = bake_deformer(scene, options, &rest, &space, Some(&markers), None)?;
            held = Some(markers);
        }
    }
    let normals = crate::normals::bake(scene.mesh)?;
    let write = |d: &DeformerBake| {
        blob::write(&BlobContents {
            space,
            vertices: &scene.mesh.positions,
            normals: &normals,
            marker_names: &names,
            marker_rest: &rest,
            deformer: &d.output.bytes,
            stages: stages.as_ref().map(|s| &s.bytes),
        })
    };
    let (mut blob, mut sizes) = write(&d)?;
    // As much of the mouth's corner profile as the mesh's own shapes and the capture do not
    // tear (`mouth_share`).
    let mut mouth_share = None;
    let corners = d.surface.as_ref().and_then(|s| s.corners.as_ref());
    let at_mouth = corners.is_some_and(|c| c.balanced_vertices > 0);
    let judged = at_mouth && options.surface.mouth_share > 0.0;
    let shapes = own_shapes::Shapes::new(scene.mesh, &scene.markers, &space);
    if judged && (shapes.is_some() || scene.capture.is_some()) {
        let with_share = |share: f64| {
            let mut o = options.clone();
            o.surface.mouth_share = share;
            bake_deformer(scene, &o, &rest, &space, held.as_deref(), None)
        };
        // The linear profile's rig, baked when a probe first needs it.
        let mut linear: Option<(DeformerBake, Vec<u8>, BlobSizes)> = None;
        let mut shares = mouth_share::MOUTH_SHARES
            .iter()
            .copied()
            .filter(|&s| s < options.surface.mouth_share && s > 0.0);
        let mut choice = mouth_share::MouthShareChoice {
            share: options.surface.mouth_share,
            shapes: shapes.as_ref().map_or(0, own_shapes::Shapes::count),
            frames: scene.capture.map_or(0, |c| c.frames.len()),
            tried: Vec::new(),
        };
        let torn = |blob: &[u8], linear: Option<&[u8]>| {
            shapes.as_ref().map_or(Ok(0), |s| s.torn(blob, linear))
        };
        loop {
            // The shapes first (against the linear profile's rig once there is one), then the
            // capture, only if they pass.
            let mut shapes_torn = torn(&blob, linear.as_ref().map(|(_, b, _)| b.as_slice()))?;
            if linear.is_none() && (shapes_torn > 0 || scene.capture.is_some()) {
                let l = with_share(0.0)?;
                let (b, s) = write(&l)?;
                if shapes_torn > 0 {
                    shapes_torn = torn(&blob, Some(&b))?;
                }
                linear = Some((l, b, s));
            }
            let frames_torn = match (scene.capture, &linear) {
                (Some(capture), Some((_, l, _))) if shapes_torn == 0 => {
                    Some(mouth_share::frames_torn(&blob, l, scene.mesh, capture)?.0)
                }
                _ => None,
            };
            let too_many_frames = frames_torn
                .is_some_and(|t| t as f64 > mouth_share::TORN_SHARE * choice.frames as f64);
            if shapes_torn == 0 && !too_many_frames {
                break;
            }
            choice.tried.push(mouth_share::TriedShare {
                share: choice.share,
                shapes_torn,
                frames_torn,
            });
            match shares.next() {
                Some(next) => {
                    choice.share = next;
                    d = with_share(next)?;
                    (blob, sizes) = write(&d)?;
                }
                None => {
                    // Every share tore: the linear profile (baked, since a probe tore).
                    if let Some((l, b, s)) = linear.take() {
                        (d, blob, sizes) = (l, b, s);
                        choice.share = 0.0;
                    }
                    break;
                }
            }
        }
        mouth_share = Some(choice);
    }
    // With a capture, the weights relax where it folds the skin.
    let mut relaxed = None;
    if let (Some(capture), true) = (
        scene.capture,
        options.surface.relax && options.deformer == DeformerKind::Linear && d.surface.is_some(),
    ) {
        let regions = crate::metrics::Regions::for_mesh(scene.mesh, &[], &[])
            .map_err(|e| BakeError::Input(format!("{}: {e}", scene.mesh.source.display())))?;
        let (mut folded, before) = relax::folds(&blob, &regions, capture)?;
        let mut choice = relax::RelaxChoice {
            frames: capture.frames.len(),
            before,
            after: before,
            rings: 0,
            vertices: 0,
        };
        if before.worst_frame > 0 {
            let neighbours = relax::skin_neighbours(scene.mesh, &regions);
            let mut o = options.clone();
            o.surface.mouth_share = mouth_share
                .as_ref()
                .map_or(o.surface.mouth_share, |m| m.share);
            for rings in (2..=relax::RINGS).step_by(2) {
                let patch = relax::patch(scene.mesh, &regions, &neighbours, &folded, rings);
                let r = Relaxed {
                    neighbours: &neighbours,
                    patch: &patch,
                };
                let candidate = bake_deformer(scene, &o, &rest, &space, held.as_deref(), Some(&r))?;
                let (candidate_blob, candidate_sizes) = write(&candidate)?;
                let (now, count) = relax::folds(&candidate_blob, &regions, capture)?;
                if count < choice.after {
                    choice.after = count;
                    choice.rings = rings;
                    choice.vertices = patch.len();
                    (d, blob, sizes) = (candidate, candidate_blob, candidate_sizes);
                }
                if count.worst_frame == 0 {
                    break;
                }
                folded.extend(now);
                folded.sort_unstable();
                folded.dedup();
            }
        }
        relaxed = Some(choice);
    }
    // The finished rig against the mesh's own shapes.
    let shapes = shapes.map(|s| s.check(&blob)).transpose()?;
    let dropped = &d.output.dropped;
    let mean_dropped_mass = dropped.iter().sum::<f64>() / dropped.len().max(1) as f64;
    let mut warnings: Vec<String> = scene.mesh.units_warning().into_iter().collect();
    warnings.extend(scene.capture.and_then(Capture::units_warning));
    warnings.extend(d.warnings);
    warnings.extend(unmasked);
    warnings.extend(at_rest_warning);
    if let Some(check) = &shapes {
        if !check.torn.is_empty() {
            warnings.push(check.tears());
        }
        if !check.left_out.is_empty() {
            warnings.push(format!(
                "morph targets left out of the rig's check against the mesh's own shapes (they move a marker out of the rig's range): {}",
                check.left_out.join(", ")
            ));
        }
    }
    if let Some(st) = &stages {
        for name in &st.report.unsampled_markers {
            warnings.push(format!(
                "marker {name:?} has no sample in the capture: it is rebuilt from its neighbours every frame (as --virtual-markers does)"
            ));
        }
        let first = st.report.neutral_frames.start;
        let filled = &st.report.neutral_filled;
        if !filled.is_empty() {
            warnings.push(format!(
                "no frame of the capture has every marker: its neutral pose starts at frame {first}, with {} marker(s) it lacks taken from the nearest frames that have them, moved rigidly onto it: {}",
                filled.len(),
                filled.join(", ")
            ));
        } else if options.stages.neutral == crate::stages::Neutral::FirstComplete && first > 0 {
            warnings.push(format!(
                "the capture's first {first} frame(s) lack a marker or hold a ghost: its neutral pose starts at frame {first} (--neutral chooses others)"
            ));
        }
    }
    if options.deformer == DeformerKind::Rbf {
        warnings.push(
            if options.anchoring.is_some() {
                "the RBF deformer has no masks and no corner reshaping (on FaceCap's truth with every radial term: 2.2x stretch, 2 flipped triangles, the lips 12 mm off, against 1.9x, 1 and 6.8 mm with the linear deformer; on JawMoCap 2.0x and 1 flip, against 1.9x and none)"
            } else {
                "the RBF deformer without static anchoring: the skin beyond the markers follows the RBF's far field (the skull moves 33 mm on FaceCap's truth)"
            }
            .into(),
        );
        if mean_dropped_mass > RBF_DROPPED_WARNING {
            warnings.push(format!(
                "keeping K = {} radial terms per vertex drops {:.0} % of a vertex's radial mass on average: the coefficients alternate in sign, so the skin tears where neighbours keep different terms (on FaceCap's truth at K = 8: 3.5x stretch, 58 flipped triangles); leave out -k to keep every term",
                options.k,
                100.0 * mean_dropped_mass
            ));
        }
    }
    let report = BakeReport {
        deformer: options.deformer,
        method: options.method,
        radial: d.radial,
        condition: d.condition,
        warnings,
        k: options.k.min(rest.len()),
        weight_frac_bits: d.output.frac_bits,
        mean_dropped_mass,
        max_dropped_mass: dropped.iter().copied().fold(0.0, f64::max),
        max_weight_rounding: d.output.rounding,
        max_matrix_rounding: d.output.matrix_rounding,
        sizes,
        planar: d.planar,
        surface: d.surface,
        stages: stages.as_ref().map(|s| s.report.clone()),
        mouth_share,
        relaxed,
        shapes,
    };
    Ok(Baked {
        blob,
        space,
        report,
        reference: Reference {
            deformer: d.reference,
            stages: stages.map(|s| s.reference),
        },
    })
}

/// The stages' configuration for `scene`: the options' own, with fill neighbours along the skin
/// (lip markers across a closed mouth are millimetres apart in space), head markers among the
/// skull markers and the inner eye corners and the face's axes, unless given.
fn stages_config(
    scene: &Scene<'_>,
    options: &BakeOptions,
    d: &DeformerBake,
    names: &[String],
) -> Result<crate::stages::StagesConfig, BakeError> {
    let (distances, candidates) = match &d.surface_markers {
        Some(m) => m.clone(),
        None => {
            let (distances, candidates) =
                crate::surface::skin_markers(&scene.surface_input(), &options.surface)?;
            (
                distances,
                candidates.iter().map(|&i| names[i].clone()).collect(),
            )
        }
    };
    let mut config = options.stages.clone();
    config.marker_distances.get_or_insert(distances);
    config.head_candidates.get_or_insert(candidates);
    config
        .face_axes
        .get_or_insert_with(|| crate::frame::FaceFrame::of(scene.mesh));
    if config.retarget == crate::stages::RetargetKind::Geodesic {
        config.character_surface.get_or_insert_with(|| {
            crate::stages::geodesic_retarget::CharacterSurface {
                positions: scene.mesh.welded_positions.clone(),
                triangles: scene.mesh.welded_triangles.clone(),
                sources: scene.markers.iter().map(|m| m.source).collect(),
            }
        });
    }
    Ok(config)
}

/// The mean share of radial mass the RBF deformer may drop by keeping K before the bake warns
/// (on FaceCap with the JawMoCap layout at K = 8, the papers' Gaussian at 0.75 spacings drops
/// 0.1 %, the exponential at 1.5 spacings 29 %; at K = 24, 5.4 %).
const RBF_DROPPED_WARNING: f64 = 0.05;

/// The options' refusals, each in one place.
fn check(options: &BakeOptions) -> Result<(), BakeError> {
    if !(1..=usize::from(facebake_runtime::fixed::MAX_INFLUENCES)).contains(&options.k) {
        return Err(SparsifyError::BadK(options.k).into());
    }
    if options.deformer == DeformerKind::Rbf {
        if options.masks {
            return Err(BakeError::Input(
                "masks need the linear or planar deformer: the RBF deformer has one RBF for the \
                 whole face (leave out --masks and the masks' sides, or use --deformer linear)"
                    .into(),
            ));
        }
        if options.method == Method::Pbw {
            return Err(BakeError::Input(
                "PBW weights are not an RBF: it needs the linear deformer (--deformer linear)"
                    .into(),
            ));
        }
        if options.radial.grows() {
            return Err(BakeError::Input(format!(
                "the {} radial function grows with distance, so its terms cannot be truncated to the K nearest: use --deformer linear",
                options.radial.name()
            )));
        }
    }
    if options.deformer == DeformerKind::Planar && options.method != Method::Euclidean {
        return Err(SurfaceError::Planar.into());
    }
    Ok(())
}

/// Planar bones' static anchoring: the markers the linear deformer's anchoring follows (the
/// skull markers found from the mesh's mouth and eyes, and without the rig's own head fit the
/// inner corners of the eyes), the three of them spanning the largest triangle as the skull's
/// bone, and every vertex's anchoring strength beyond the markers' hull above the mouth. `None`
/// on a mesh whose openings are not a mouth and two eyes, or with fewer than three such markers.
/// The bone translates with its corners' centroid. Without the rig's own head fit its corners
/// are the two inner eye corners and the skull marker nearest the face's middle: on the truth
/// (`--test structure`, 2026-12-02) static drift 0.43 mm, against 0.55 for the largest
/// triangle of anchors (the side forehead markers and a canthus) and 0.45–0.59 for the other
/// triangles (1.50 when the bone turned with the largest). A capture rig keeps the largest
/// triangle of the head markers, which hold still (JawMoCap 0.28 mm).
fn planar_anchor(
    mesh: &crate::model::FaceMesh,
    rest: &[[f64; 3]],
    factor: f64,
    head_fit: bool,
) -> Option<([usize; 3], Vec<f64>)> {
    // In the face's own axes: "above the mouth" is the face's.
    let frame = crate::frame::FaceFrame::of(mesh);
    let (local_mesh, local_rest) = (frame.mesh(mesh), frame.points(rest));
    let (mesh, rest) = (&local_mesh, local_rest.as_slice());
    let openings = crate::placement::face_openings(mesh).ok()?;
    let rims: Vec<Vec<[f64; 3]>> = openings
        .iter()
        .map(|l| {
            l.iter()
                .map(|&v| mesh.welded_positions[v as usize])
                .collect()
        })
        .collect();
    let spacing = crate::metrics::mean_spacing(rest);
    let skull = crate::surface::anchoring::skull_markers(rest, &rims, spacing);
    let eyes: Vec<&[[f64; 3]]> = rims.iter().skip(1).map(Vec::as_slice).collect();
    let anchors = crate::surface::anchoring::anchor_markers(
        rest,
        &skull,
        &eyes,
        head_fit,
        crate::surface::corners::CORNER_REACH,
    );
    let area = |t: &[usize; 3]| {
        use crate::mesh::{cross, norm, sub};
        let [a, b, c] = t.map(|m| rest[m]);
        norm(&cross(&sub(&b, &a), &sub(&c, &a)))
    };
    let mut best: Option<([usize; 3], f64)> = None;
    for (i, &a) in anchors.iter().enumerate() {
        for (j, &b) in anchors.iter().enumerate().skip(i + 1) {
            for &c in &anchors[j + 1..] {
                let t = [a, b, c];
                let s = area(&t);
                if best.is_none_or(|(_, x)| s > x) {
                    best = Some((t, s));
                }
            }
        }
    }
    let (largest, _) = best.filter(|(_, s)| *s > 0.0)?;
    // The bone only translates with its triangle's centroid (`Region::Centroid`), so its
    // corners are picked for how little expressions move them, not for the triangle's
    // shape: with both eyes' inner corners anchored, the two corners and the skull marker
    // nearest the face's middle.
    let canthi: Vec<usize> = anchors
        .iter()
        .copied()
        .filter(|m| !skull.contains(m))
        .collect();
    let middle = crate::surface::anchoring::middle_x(rest);
    let central = skull.iter().copied().min_by(|&a, &b| {
        (rest[a][0] - middle)
            .abs()
            .total_cmp(&(rest[b][0] - middle).abs())
    });
    let triangle = match (canthi.as_slice(), central) {
        (&[l, r], Some(m)) if area(&[m, l, r]) > 0.0 => [m, l, r],
        _ => largest,
    };
    let mouth = rims[0].iter().map(|p| p[1]).sum::<f64>() / rims[0].len().max(1) as f64;
    let strength = crate::surface::anchoring::static_anchoring(
        &mesh.positions,
        rest,
        &anchors,
        Some(mouth),
        crate::surface::eyes_height(&eyes),
        factor * spacing,
    )
    .strength;
    Some((triangle, strength))
}

/// Whether two lists name the same markers, in any order.
fn same_markers(a: &[String], b: &[String]) -> bool {
    let mut a: Vec<&String> = a.iter().collect();
    let mut b: Vec<&String> = b.iter().collect();
    a.sort_unstable();
    b.sort_unstable();
    a == b
}

/// The deformer by the options' strategy; with a capture, `held` names the markers its head
/// fit holds still (`None`: the head candidates).
fn bake_deformer(
    scene: &Scene<'_>,
    options: &BakeOptions,
    rest: &[[f64; 3]],
    space: &Space,
    held: Option<&[usize]>,
    relaxed: Option<&Relaxed<'_>>,
) -> Result<DeformerBake, BakeError> {
    let mesh = scene.mesh;
    if options.deformer == DeformerKind::Planar {
        let allowance = if options.masks {
            Some(crate::surface::planar_allowance(
                &scene.surface_input(),
                &options.surface,
            )?)
        } else {
            None
        };
        let anchor = options
            .anchoring
            .and_then(|factor| planar_anchor(mesh, rest, factor, scene.capture.is_some()));
        let teeth = crate::surface::interior::teeth(mesh, crate::surface::mean_spacing(rest));
        let (output, summary, reference) = deformer::planar::bake(
            &mesh.positions,
            &mesh.triangles,
            rest,
            &PlanarOptions {
                given: scene.control_triangles.as_deref(),
                k: options.k,
                radius_factor: options.planar_radius,
                masks: allowance.as_ref(),
                anchor: anchor.as_ref().map(|(t, s)| (*t, s.as_slice())),
                rigid: &teeth,
            },
            space,
        )
        .map_err(|e| named_triangle(scene, e))?;
        return Ok(DeformerBake {
            output,
            radial: None,
            condition: None,
            warnings: Vec::new(),
            planar: Some(summary),
            surface: None,
            reference: DeformerReference::Planar(reference),
            surface_markers: None,
        });
    }
    let stiffness: Vec<f64> = scene.markers.iter().map(|m| m.stiffness).collect();
    // The straight-line RBF as the papers bake it; with static anchoring (linear deformer) the
    // surface path, which anchors.
    if options.method == Method::Euclidean && !options.masks && options.anchoring.is_none() {
        let system = euclidean::dense_system(rest, &stiffness, options)?;
        let condition = system.condition();
        let output = match options.deformer {
            DeformerKind::Linear => {
                euclidean::linear(&mesh.positions, rest, &system, options, space)?
            }
            DeformerKind::Rbf => euclidean::rbf(&mesh.positions, rest, &stiffness, options, space)?,
            DeformerKind::Planar => return Err(SurfaceError::Planar.into()),
        };
        return Ok(DeformerBake {
            output,
            radial: Some(options.radial.name()),
            condition: Some(condition),
            warnings: condition_warning(condition).into_iter().collect(),
            planar: None,
            surface: None,
            reference: DeformerReference::Rbf(euclidean::reference(system, &mesh.positions, rest)),
            surface_markers: None,
        });
    }
    let input = SurfaceInput {
        held,
        ..scene.surface_input()
    };
    let mut s = crate::surface::dense_weights(&input, options, space)?;
    if let Some(r) = relaxed {
        // Vertices with corrections on either axis are held.
        let corrected: Vec<Vec<(usize, f64)>> = s
            .vertical
            .iter()
            .zip(&s.forward)
            .map(|(v, f)| v.iter().chain(f).copied().collect())
            .collect();
        relax::relax_rows(&mut s.dense, &corrected, &mesh.weld, r.neighbours, r.patch);
    }
    let output = match options.deformer {
        DeformerKind::Linear => s.linear(options)?,
        DeformerKind::Rbf => s.rbf(options)?,
        DeformerKind::Planar => return Err(SurfaceError::Planar.into()),
    };
    let mut warnings = s.warnings;
    warnings.extend(condition_warning(s.condition));
    let head_candidates = s
        .head_candidates
        .iter()
        .map(|&i| scene.markers[i].name.clone())
        .collect();
    Ok(DeformerBake {
        output,
        radial: Some(s.radial.name()),
        condition: Some(s.condition),
        warnings,
        planar: None,
        surface: Some(s.figures),
        reference: DeformerReference::Weights(DenseWeights {
            rest: mesh.positions.clone(),
            marker_rest: rest.to_vec(),
            weights: s.dense,
            vertical: s.vertical,
            up: crate::deformer::linear::derived_direction(s.up).1,
            forward: s.forward,
            ahead: crate::deformer::linear::derived_direction(s.ahead).1,
        }),
        surface_markers: Some((s.marker_distances, head_candidates)),
    })
}

/// A degenerate control triangle the scene gave, named by its markers as the layout names it.
fn named_triangle(scene: &Scene<'_>, e: DeformerError) -> BakeError {
    match e {
        DeformerError::Planar(PlanarError::DegenerateTriangle {
            triangle,
            markers,
            angle,
        }) if scene.control_triangles.is_some() => {
            let names = markers.map(|m| scene.markers.get(m).map_or("?", |x| x.name.as_str()));
            BakeError::Input(format!(
                "triangles[{triangle}] {names:?} is degenerate on the mesh: its smallest angle is {angle:.3}° (at least {DEGENERATE_ANGLE_DEGREES}° needed)"
            ))
        }
        e => e.into(),
    }
}

/// The warning of an ill-conditioned RBF system.
fn condition_warning(condition: f64) -> Option<String> {
    (condition > crate::rbf::system::CONDITION_WARNING).then(|| {
        format!(
            "the RBF system is ill-conditioned (1-norm condition ≈ {condition:.2e}); results may be noisy: try a narrower radial width, the affine term or a ridge"
        )
    })
}
