//! Surface-aware deformation: RBFs on distances along the skin, so the lips and the eyelids can
//! part, all baked into the runtime's RBF and linear deformers.
//!
//! * [`Method::Geodesic`] (thesis §5.2, paper 002 §2.1): the kernel of the geodesic distance.
//! * [`Method::Hybrid`] (thesis §5.3): geodesic near the openings, Euclidean elsewhere, blended
//!   by a Gaussian decay ([`distances`]).
//! * [`Method::Euclidean`] with masks: the straight-line RBF in rig units.
//! * Masks ([`masks`]) on any of them: marker groups either side of an opening that may move only
//!   their own side. Masks need the linear deformer (one RBF per side; the RBF deformer has one
//!   coefficient map).
//!
//! Static anchors (paper 003's back-of-head and neck points) are markers like any other whose
//! captured position is their rest position: they pin their region through the RBF.
//!
//! A geodesic kernel matrix need not be positive definite (a Gaussian of a non-Euclidean metric).
//! The bake computes the smallest eigenvalue of the symmetric part of the kernel block, warns
//! when it is negative and, unless told otherwise, adds a ridge to the diagonal that lifts it to
//! zero plus a margin ([`RIDGE_MARGIN`]). With the affine term the system then stays solvable;
//! the ridge relaxes interpolation of the markers by about the same relative amount.

pub mod anchoring;
pub mod corners;
pub mod distances;
pub mod evaluate;
pub mod geometry;
pub(crate) mod interior;
pub mod let_go;
pub mod lip_curve;
pub mod masks;
pub mod pbw;

use nalgebra::DMatrix;

use crate::deformer::{self, DeformerError, DeformerOutput};
use crate::frame::FaceFrame;
use crate::geodesic::{GeodesicError, Source};
use crate::model::FaceMesh;
use crate::model::MarkerGroups;
use crate::options::{BakeOptions, Method, SurfaceOptions};
use crate::rbf::{Kernel, RadialFunction, RbfSystem, SolveError};

pub use distances::Distance;
pub use geometry::SurfaceGeometry;
pub use masks::{MaskError, SideRule};

/// Ridge margin (fraction of the mean |φ|) added beyond the most negative eigenvalue.
pub const RIDGE_MARGIN: f64 = 1e-3;

/// A marker of a surface-aware bake.
#[derive(Clone, Debug)]
pub struct SurfaceMarker {
    /// Its name.
    pub name: String,
    /// Rest position, asset units.
    pub rest: [f64; 3],
    /// Where it sits on the welded mesh (glTF triangle indices are the same).
    pub source: Source,
    /// Stiffness in [1, 9].
    pub stiffness: f64,
}

impl SurfaceMarker {
    /// A layout marker placed on the mesh.
    pub fn from_placed(p: &crate::model::PlacedMarker) -> Self {
        Self {
            name: p.name.clone(),
            rest: p.position,
            source: Source::Point {
                triangle: p.surface.triangle,
                barycentric: p.surface.barycentric,
            },
            stiffness: p.stiffness,
        }
    }
}

/// What a surface-aware bake is made of.
pub struct SurfaceInput<'a> {
    /// The mesh; the rig deforms its glTF vertices.
    pub mesh: &'a FaceMesh,
    /// The markers.
    pub markers: &'a [SurfaceMarker],
    /// Marker groups, one per mask.
    pub groups: &'a [MarkerGroups],
    /// How vertex sides are found.
    pub sides: &'a SideRule,
    /// The rig fits the head every frame (a bake with a capture) and holds its head markers
    /// still: the skin beyond the markers then follows them (see [`SurfaceInput::held`]).
    pub head_fit: bool,
    /// With `head_fit`, the markers the fit holds (the capture stages' head markers, rig order);
    /// `None` before the stages have picked them: the head candidates, all of which they pick
    /// when there are at most [`crate::stages::DEFAULT_HEAD_MARKERS`]. Empty: none held, as
    /// without a head fit.
    pub held: Option<&'a [usize]>,
}

/// A surface-aware bake failed.
#[derive(Debug, thiserror::Error)]
pub enum SurfaceError {
    /// Geodesic distances.
    #[error("geodesic distances: {0}")]
    Geodesic(#[from] GeodesicError),
    /// Masks.
    #[error("masks: {0}")]
    Mask(#[from] MaskError),
    /// The RBF system.
    #[error("solving the RBF system: {0}")]
    Solve(#[from] SolveError),
    /// The deformer.
    #[error(transparent)]
    Deformer(#[from] crate::deformer::DeformerError),
    /// Planar bones blend control-triangle frames, not RBF distances: no surface-aware method
    /// applies to them (masks do, through [`planar_allowance`]).
    #[error(
        "planar bones take no surface-aware method: bake them with --method euclidean (masks apply with --deformer planar --masks)"
    )]
    Planar,
}

/// What a surface-aware bake measured.
#[derive(Clone, Debug, serde::Serialize)]
pub struct SurfaceFigures {
    /// Smallest eigenvalue of the symmetric part of the kernel block, over its mean |φ|.
    pub min_eigenvalue: f64,
    /// Ridge added (fraction of the mean |φ|).
    pub ridge: f64,
    /// Largest relative asymmetry of the marker-to-marker geodesics.
    pub geodesic_asymmetry: f64,
    /// Openings found on the skin.
    pub openings: usize,
    /// How far the face's own axes (read from its eyes and mouth, [`crate::frame::FaceFrame`]) are
    /// turned from the file's, in degrees; the bake's directional rules use the face's.
    pub face_turn_degrees: f64,
    /// glTF vertices no marker reaches along the surface (Euclidean distances used).
    pub unreachable_vertices: usize,
    /// Vertices a mask touched.
    pub masked_vertices: usize,
    /// Masks applied (group names).
    pub masks: Vec<String>,
    /// Static anchoring, when applied.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub anchoring: Option<AnchoringFigures>,
    /// The opening corners' reshaping, when applied ([`corners`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub corners: Option<corners::CornerFigures>,
    /// The lid and upper lip markers letting go of the skin past them, when applied
    /// ([`let_go`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub let_go: Option<let_go::LetGoFigures>,
    /// glTF vertices whose weights the lips' curve corrected ([`lip_curve`]).
    pub lip_curve_vertices: usize,
}

/// What static anchoring did.
#[derive(Clone, Debug, serde::Serialize)]
pub struct AnchoringFigures {
    /// The markers anchored skin follows: the skull markers, and without the rig's own head fit
    /// the inner corners of the eyes ([`anchoring::anchor_markers`]).
    pub markers: Vec<String>,
    /// glTF vertices with some anchoring.
    pub anchored_vertices: usize,
    /// glTF vertices that follow the anchor markers alone.
    pub still_vertices: usize,
}

/// What the surface-aware strategies hand back to [`crate::bake()`]: the dense weights and the
/// RBF system, in rig units, for the linear or the RBF deformer.
pub(crate) struct SurfaceBake {
    /// Marker-to-marker distances.
    between: DMatrix<f64>,
    /// Per vertex, its distances to the markers.
    rows: Vec<Vec<f64>>,
    kernel: Kernel,
    system: RbfSystem,
    pub(crate) figures: SurfaceFigures,
    /// 1-norm condition estimate of the full system.
    pub(crate) condition: f64,
    /// The radial function actually used (PBW's global part is the multiquadric).
    pub(crate) radial: RadialFunction,
    /// Per glTF vertex, its dense f64 weights on the marker displacements (masks applied): the
    /// reference the sparse rig approximates.
    pub(crate) dense: Vec<Vec<f64>>,
    /// Per glTF vertex, weights on the markers' vertical displacements alone, summing to zero
    /// (the mouth's corners and the eyes' lower lids, [`corners`]; empty elsewhere).
    pub(crate) vertical: Vec<Vec<(usize, f64)>>,
    /// The face's vertical in file coordinates ([`FaceFrame`]), along which `vertical` acts.
    pub(crate) up: [f64; 3],
    /// Per glTF vertex, weights on the markers' displacements along the face's forward axis
    /// alone, summing to zero (the lower lip's depth, [`let_go::lower_lip_depth`]; empty
    /// elsewhere).
    pub(crate) forward: Vec<Vec<(usize, f64)>>,
    /// The face's forward axis in file coordinates, along which `forward` acts.
    pub(crate) ahead: [f64; 3],
    /// Per glTF vertex, how far its two weakest kept markers give way to the vertical
    /// corrections (1 where it has them, fading to 0 over a ring outside; [`corners`]).
    pub(crate) give_way: Vec<f64>,
    pub(crate) warnings: Vec<String>,
    /// Marker-to-marker distances under the method's distance, asset units (rig marker order):
    /// along the skin for the geodesic methods.
    pub(crate) marker_distances: Vec<Vec<f64>>,
    /// The markers a capture's head fit may use ([`head_candidates`]).
    pub(crate) head_candidates: Vec<usize>,
    /// The RBF deformer's static anchoring (`None`: unanchored, the system's own map).
    pub(crate) rbf_anchoring: Option<RbfAnchoring>,
    /// The linear deformer's anchoring: the markers whose mean the anchored skin follows,
    /// carried by one derived mean ([`deformer::linear::FollowedMean`]; [`anchoring::followed`]).
    pub(crate) followed_mean: Option<Vec<usize>>,
}

/// How the RBF deformer anchors the skin beyond the markers.
pub(crate) struct RbfAnchoring {
    /// Its coefficient map, the affine part the anchor markers' mean translation
    /// ([`RbfSystem::anchored_coefficient_map`]).
    map: DMatrix<f64>,
    /// Per glTF vertex, the static anchoring's strength `s`, by which its radial terms fade
    /// (× (1 − s)), leaving that affine part, as the linear deformer's blend does.
    fade: Vec<f64>,
}

/// The kernel in rig units; the inverse multiquadric's radii are each marker's distance to its
/// nearest other marker under the method's distance (paper 002 §2.1).
fn resolve_kernel(
    config: &BakeOptions,
    centres: &[[f64; 3]],
    between: &DMatrix<f64>,
    h: f64,
) -> Kernel {
    let kernel = config
        .radial
        .resolve(centres, config.width.map(|w| w / h), config.width_factor);
    match config.radial {
        RadialFunction::InverseMultiquadric => Kernel::InverseMultiquadric {
            radii: (0..centres.len())
                .map(|i| {
                    (0..centres.len())
                        .filter(|&j| j != i)
                        .map(|j| 0.5 * (between[(i, j)] + between[(j, i)]))
                        .fold(f64::INFINITY, f64::min)
                })
                .collect(),
        },
        _ => kernel,
    }
}

/// Smallest eigenvalue of the symmetric part of the kernel block, and the block's mean |φ|.
fn kernel_spectrum(kernel: &Kernel, between: &DMatrix<f64>) -> (f64, f64) {
    let n = between.nrows();
    let phi = DMatrix::from_fn(n, n, |j, i| kernel.phi(i, between[(j, i)]));
    let mean = phi.iter().map(|x| x.abs()).sum::<f64>() / (n * n).max(1) as f64;
    let sym = (&phi + phi.transpose()) * 0.5;
    let min = sym.symmetric_eigenvalues().min();
    (min, mean)
}

/// The sides and strengths of every mask of `input` (its groups, by its side rule), as a masked
/// bake computes them: what `facebake mask-images` renders.
pub fn mask_sides(
    input: &SurfaceInput<'_>,
    config: &SurfaceOptions,
) -> Result<Vec<masks::MaskSides>, SurfaceError> {
    let local = LocalInput::of(input);
    let input = &local.input();
    let rest: Vec<[f64; 3]> = input.markers.iter().map(|m| m.rest).collect();
    let sources: Vec<Source> = input.markers.iter().map(|m| m.source).collect();
    let geometry = SurfaceGeometry::new(input.mesh, &sources, config.geodesic)?;
    sides_of(input, config, &geometry, &rest, mean_spacing(&rest))
}

/// The discontinuity masks of `input` for planar bones (see
/// [`masks::marker_allowance`]): the same sides and strengths the masked RBF uses, from
/// `config`'s geodesics, plateau and decay.
pub fn planar_allowance(
    input: &SurfaceInput<'_>,
    config: &SurfaceOptions,
) -> Result<crate::planar::MarkerAllowance, SurfaceError> {
    // Planar bones switch sides at a corner: fading a mask there let the lips' bones reach
    // across (truth lips 16.8 → 19.9 mm, JawMoCap 1.91× → 2.13× at a fade of one spacing).
    let abrupt = SurfaceOptions {
        mask_side_factor: 0.0,
        ..config.clone()
    };
    let sides = mask_sides(input, &abrupt)?;
    Ok(masks::marker_allowance(&sides, input.mesh.positions.len()))
}

/// Every mask's sides and strengths with `config`'s plateau and decay (× `spacing`).
fn sides_of(
    input: &SurfaceInput<'_>,
    config: &SurfaceOptions,
    geometry: &SurfaceGeometry,
    rest: &[[f64; 3]],
    spacing: f64,
) -> Result<Vec<masks::MaskSides>, SurfaceError> {
    Ok(masks::vertex_sides(
        input.groups,
        input.sides,
        geometry,
        rest,
        config.mask_plateau_factor * spacing,
        config.mask_decay_factor * spacing,
        config.mask_side_factor * spacing,
    )?)
}

/// Mean nearest-marker distance.
pub(crate) fn mean_spacing(rest: &[[f64; 3]]) -> f64 {
    let r = crate::rbf::radial::nearest_distances(rest);
    r.iter().sum::<f64>() / r.len().max(1) as f64
}

/// The dense weights of a surface-aware method (with masks when `options.masks`) and its RBF
/// system, in rig `space`. [`crate::bake()`] has checked the options.
pub(crate) fn dense_weights(
    input: &SurfaceInput<'_>,
    options: &BakeOptions,
    space: &facebake_runtime::Space,
) -> Result<SurfaceBake, SurfaceError> {
    let config = options;
    // The bake's directional rules read the face in its own axes (`frame`); the rig's affine
    // part and the runtime keep the file's (`world`).
    let world = input;
    let local = LocalInput::of(world);
    let input = &local.input();
    let mesh = input.mesh;
    let n = input.markers.len();
    let masked = config.masks && !input.groups.is_empty();
    let rest: Vec<[f64; 3]> = input.markers.iter().map(|m| m.rest).collect();
    let stiffness: Vec<f64> = input.markers.iter().map(|m| m.stiffness).collect();
    let sources: Vec<Source> = input.markers.iter().map(|m| m.source).collect();
    let spacing = mean_spacing(&rest);
    let geometry = SurfaceGeometry::new(mesh, &sources, config.surface.geodesic)?;
    let kind = match config.method {
        Method::Euclidean => Distance::Euclidean,
        Method::Geodesic | Method::Pbw => Distance::Geodesic,
        Method::Hybrid => Distance::Hybrid {
            region: config.surface.region_factor * spacing,
            decay: config.surface.decay_factor * spacing,
        },
    };
    let mut d = distances::marker_distances(
        kind,
        &geometry,
        &mesh.welded_positions,
        &mesh.positions,
        &rest,
    );
    // The lips and lids as ribbons. The RBF deformer too since it keeps every radial term
    // (measured 2026-12-02, `--test structure`: on the truth the lip band's p99 4.91 → 4.72 mm,
    // eyelids 1.66 → 1.55 mm, 2.17× → 2.16×, 2 flips; JawMoCap's widest lip opening 36.0 →
    // 39.3 mm, 2.01×); at K = 8 it had turned one more triangle over (57 → 58).
    if kind != Distance::Euclidean
        && config.deformer != crate::DeformerKind::Planar
        && config.surface.rim_across < 1.0
    {
        distances::shorten_across_rims(&mut d, &geometry, spacing, config.surface.rim_across);
    }
    let mut warnings = Vec::new();
    if !d.fallback.is_empty() {
        let mut pieces = geometry.topology_pieces(&d.fallback);
        pieces.sort_by_key(|p| std::cmp::Reverse(p.1));
        let listed: Vec<String> = pieces
            .iter()
            .take(3)
            .map(|(c, count)| format!("component {c}: {count}"))
            .collect();
        // The linear deformer's weights for them are those of the skin beside them
        // ([`interior::ride_beside`]); the RBF deformer evaluates their distances.
        let how = if config.deformer == crate::DeformerKind::Rbf {
            "use Euclidean distances"
        } else {
            "ride the skin beside them (a tooth as one piece; on the jaw's side, the jaw)"
        };
        warnings.push(format!(
            "{} vertices in {} piece(s) of the mesh that not every marker reaches along the surface {how} (largest: {}{})",
            d.fallback.len(),
            pieces.len(),
            listed.join(", "),
            if pieces.len() > 3 { ", …" } else { "" }
        ));
    }
    if d.fallback_pairs > 0 {
        warnings.push(format!(
            "{} marker pairs have no path along the surface: Euclidean distances used between them",
            d.fallback_pairs
        ));
    }
    // Rig units, where the runtime evaluates.
    let h = f64::from(space.half_extent);
    let centres: Vec<[f64; 3]> = world
        .markers
        .iter()
        .map(|m| crate::space::to_rig_units(space, &m.rest))
        .collect();
    let points: Vec<[f64; 3]> = world
        .mesh
        .positions
        .iter()
        .map(|p| crate::space::to_rig_units(space, p))
        .collect();
    let between = &d.between / h;
    let rows: Vec<Vec<f64>> = d
        .vertices
        .iter()
        .map(|r| r.iter().map(|x| x / h).collect())
        .collect();
    // PBW's local weights use the geodesic rows, and so does its global RBF part: paper 002's
    // is a multiquadric on Euclidean distances, which across the closed mouth interpolates the
    // jaw's 43 mm between lip markers 3.6 mm apart and throws the nose out by 80 mm (FaceCap's
    // truth, JawMoCap layout: max error 115 mm, 471 flipped triangles); on the skin's distances
    // with the bake's radial function, 12.5 mm and 12 (see `surface::pbw`).
    let geodesic_rows = (config.method == Method::Pbw).then(|| rows.clone());
    let kernel = resolve_kernel(config, &centres, &between, h);
    let (min_eig, mean_phi) = kernel_spectrum(&kernel, &between);
    let min_eigenvalue = min_eig / mean_phi;
    // Euclidean kernels are (conditionally) positive definite by theory, with the affine term
    // for the multiquadric and thin-plate kernels, whose blocks have negative eigenvalues.
    let euclidean = config.method == Method::Euclidean;
    let ridge = config
        .surface
        .ridge
        .unwrap_or(if min_eigenvalue < 0.0 && !euclidean {
            -min_eigenvalue + RIDGE_MARGIN
        } else {
            0.0
        });
    if min_eigenvalue < 0.0 && !euclidean {
        warnings.push(format!(
            "the {} kernel matrix is indefinite (smallest eigenvalue {:.3e} of the mean |φ|); a ridge of {:.3e} × mean |φ| is added to its diagonal",
            config.method.name(),
            min_eigenvalue,
            ridge
        ));
    }
    let system = RbfSystem::with_distances(
        &centres,
        &between,
        kernel.clone(),
        config.affine,
        &stiffness,
        ridge,
    )?;
    let condition = system.condition();
    let mouth = mouth_opening(&geometry, &rest);
    if mouth.is_none() {
        warnings.push(
            "the skin has no mouth opening (no boundary loop below the markers' mean height): distances along it cannot tell the lips apart, so they move together; cut the mouth open in the mesh, or give the lips' sides with --masks and --mask-sides or --mask-image"
                .into(),
        );
    }
    let floor = mouth.map(|i| geometry.openings[i].centre[1]);
    let rims = rims_of(&geometry, mesh);
    let skull = anchoring::skull_markers(&rest, &rims, spacing);
    // The skin beyond the markers follows the head candidates: the skull markers and the inner
    // corners of the eyes, which expressions move least (see `anchoring::anchor_markers`).
    let eyes = eye_rims(&rims, mouth);
    // With the rig's own head fit, the markers it holds still, whose displacement is then
    // zero: ICT-FaceKit's truth played as a capture with the skull markers alone anchoring (the
    // stages held the inner eye corners too) moved its throat twice as far as the truth in the
    // jaw open (13.8 mm off where the bake without a capture is 6.2) and flipped 20 triangles
    // where that bake flips 7: the eight weights a vertex keeps went to the markers the
    // anchored share was not split over (`--test ict_facekit`).
    let head_fit = input.head_fit && input.held.is_none_or(|h| !h.is_empty());
    let anchors = match input.held.filter(|_| head_fit) {
        Some(held) => held.to_vec(),
        None => head_candidates(&rest, &skull, &eyes),
    };
    // The RBF deformer cannot blend weights towards the anchor markers as the linear one does;
    // its affine part is prescribed as the anchor markers' mean displacement instead
    // (`RbfSystem::anchored_coefficient_map`), so its far field follows them, and its radial
    // terms fade by the anchoring's strength (`RbfAnchoring`).
    let anchored_map = match (config.deformer, config.anchoring) {
        (crate::DeformerKind::Rbf, Some(_)) => Some(system.anchored_coefficient_map(&anchors)?),
        _ => None,
    };
    let sides = if masked {
        Some(sides_of(input, &config.surface, &geometry, &rest, spacing)?)
    } else {
        None
    };
    let (dense, masked_vertices) = if let Some(sides) = &sides {
        masks::masked_weights(
            &masks::MaskedSolve {
                full: &system,
                centres: &centres,
                between: &between,
                kernel: &kernel,
                stiffness: &stiffness,
                ridge,
            },
            sides,
            &rows,
            &points,
        )?
    } else {
        (
            rows.iter()
                .zip(&points)
                .map(|(r, p)| match &anchored_map {
                    Some(map) => system.weights_with_map(map, r, p),
                    None => system.weights_from_distances(r, p),
                })
                .collect(),
            0,
        )
    };
    let dense = match geodesic_rows {
        Some(g) => {
            let nb = pbw::neighbours(&(&d.between / h));
            let a = config.surface.pbw_alpha;
            dense
                .iter()
                .zip(g.iter().zip(&points))
                .map(|(global, (gd, p))| {
                    let local = pbw::local_weights(p, gd, &centres, &nb);
                    local
                        .iter()
                        .zip(global)
                        .map(|(l, g)| a * l + (1.0 - a) * g)
                        .collect()
                })
                .collect()
        }
        None => dense,
    };
    let mut dense = dense;
    // The lips' markers found from the openings, as masks without a layout's groups find them:
    // the corners' balance and the jaw's lower lip.
    let (upper_lip, lower_lip) = masks::lips_from_openings(mesh, &rest);
    // The lips curve through their markers (with the masks' sides, where the corners are
    // reshaped).
    let mouth_sides = sides
        .iter()
        .flatten()
        .find(|s| mouth.is_some_and(|m| s.openings.contains(&m)));
    let rounded = match (mouth, mouth_sides) {
        (Some(opening), Some(mouth_sides))
            if config.surface.lip_curve
                && config.surface.corners
                && config.deformer == crate::DeformerKind::Linear =>
        {
            lip_curve::round(
                &mut dense,
                &lip_curve::MouthRim {
                    opening: &geometry.openings[opening],
                    from_rim: &geometry.opening_distance[opening],
                    sides: &mouth_sides.side,
                },
                &geometry.weld,
                &mesh.welded_positions,
                &mesh.positions,
                &rest,
                [&upper_lip, &lower_lip],
                spacing,
            )
        }
        _ => 0,
    };
    let mut vertical = vec![Vec::new(); dense.len()];
    let mut give_way = vec![0.0; dense.len()];
    let names: Vec<&str> = input.markers.iter().map(|m| m.name.as_str()).collect();
    let corners =
        (config.surface.corners && config.deformer == crate::DeformerKind::Linear).then(|| {
            let markers = corners::CornerMarkers {
                rest: &rest,
                names: &names,
            };
            let mouth_corners = mouth.map(|opening| corners::Mouth {
                opening,
                share: config.surface.mouth_share,
            });
            // The vertical corrections take an influence pair of the K.
            let corrections =
                (config.k >= corners::VERTICAL_MIN_K).then_some(corners::Corrections {
                    vertical: vertical.as_mut_slice(),
                    give_way: give_way.as_mut_slice(),
                });
            let (welded, positions) = (&mesh.welded_positions, &mesh.positions);
            let mut figures = corners::reshape(
                &mut dense,
                &geometry,
                welded,
                positions,
                &markers,
                mouth_corners,
                corrections,
            );
            // The skin past the mouth's corners, balanced between the lips' markers.
            if let Some(opening) = mouth {
                let lips = (upper_lip.as_slice(), lower_lip.as_slice());
                figures.balanced_vertices = corners::balance_past_mouth_corners(
                    &mut dense,
                    &geometry.openings[opening],
                    welded,
                    positions,
                    lips,
                    config.surface.past_corner_reach * spacing,
                );
            }
            figures
        });
    let mut let_go = (config.surface.corners && config.deformer == crate::DeformerKind::Linear)
        .then(|| {
            let_go::reshape(
                &mut dense,
                &geometry,
                &mesh.welded_positions,
                &rest,
                &names,
                // Not for PBW: its local weights turned the nose's underside over where the
                // upper lip's let go (FaceCap's truth, `blend 22`: 2 → 5 flips).
                mouth.map(|opening| let_go::Mouth {
                    opening,
                    upper: if config.method == Method::Pbw {
                        &[]
                    } else {
                        &upper_lip
                    },
                }),
            )
        });
    let mut forward = vec![Vec::new(); dense.len()];
    if let (Some(figures), Some(opening)) = (let_go.as_mut(), mouth) {
        // The depth corrections take an influence pair of the K, as the vertical ones do. Not
        // for PBW: with their first form (docs/measurements.md, session 19) its local weights
        // stretched an edge past the chin 2.06× and turned two triangles over in FaceCap's
        // funnel.
        if config.k >= corners::VERTICAL_MIN_K && config.method != Method::Pbw {
            let (lip, jaw, corrected) = let_go::lower_lip_depth(
                &dense,
                &geometry,
                &mesh.welded_positions,
                &rest,
                let_go::Mouth {
                    opening,
                    upper: &upper_lip,
                },
                let_go::Depth {
                    vertical: &vertical,
                    give_way: &mut give_way,
                    forward: &mut forward,
                },
            );
            figures.depth_markers = lip.iter().map(|&m| names[m].to_string()).collect();
            figures.jaw_markers = jaw.iter().map(|&m| names[m].to_string()).collect();
            figures.depth_vertices = corrected;
        }
    }
    let unreachable = geometry.pieces_of(&d.fallback);
    let pieces = interior::Piece::all(&unreachable, &mesh.positions, spacing);
    let jaw = mouth.map(|opening| {
        interior::Jaw::new(
            &rest,
            geometry.openings[opening].centre,
            spacing,
            &lower_lip,
            &anchors,
            &pieces,
        )
    });
    let hung = interior::hanging(mesh, &pieces);
    let mut dense = interior::ride_beside(dense, &pieces, &mesh.positions, jaw.as_ref());
    let mut rbf_anchoring = None;
    let mut followed_mean = None;
    // The weights of fully anchored skin, which a mouth bag's back takes.
    let mut still = None;
    let anchoring = match (config.anchoring, config.deformer) {
        (Some(factor), crate::DeformerKind::Linear | crate::DeformerKind::Rbf) => {
            // The linear deformer's anchored skin follows three of them, whose mean takes one
            // of a vertex's K weights, with or without a head fit (`anchoring::followed`).
            let followed = if config.deformer == crate::DeformerKind::Linear {
                anchoring::followed(&rest, &anchors, &skull)
            } else {
                anchors.clone()
            };
            let a = anchoring::static_anchoring(
                &mesh.positions,
                &anchoring::hull_markers(&rest, &anchors),
                &followed,
                floor,
                eyes_height(&eyes),
                factor * spacing,
            );
            // The RBF deformer's affine part is the anchor markers' mean translation, so fading
            // its radial terms by the strength is this same blend (its dense reference).
            a.apply(&mut dense);
            still = (!followed.is_empty()).then(|| anchoring::still_row(&followed, n));
            rbf_anchoring = anchored_map.map(|map| RbfAnchoring {
                map,
                fade: a.strength.clone(),
            });
            if config.deformer == crate::DeformerKind::Linear {
                followed_mean = Some(a.head.clone());
            }
            Some(AnchoringFigures {
                markers: followed
                    .iter()
                    .map(|&h| input.markers[h].name.clone())
                    .collect(),
                anchored_vertices: a.anchored_vertices(),
                still_vertices: a.still_vertices(),
            })
        }
        _ => None,
    };
    // After the anchoring, so the bags' rows are the membrane's alone: the anchoring's strength,
    // from where a vertex lies round the head, means nothing inside the mouth.
    let back = still.as_deref().map(|still| interior::BagBack {
        still,
        jaw: jaw.as_ref(),
    });
    interior::stretch_bags(
        &mut dense,
        &mut vertical,
        &mut give_way,
        mesh,
        &hung,
        back.as_ref(),
    );
    let marker_distances = (0..n)
        .map(|i| (0..n).map(|j| d.between[(i, j)]).collect())
        .collect();
    let figures = SurfaceFigures {
        min_eigenvalue,
        ridge,
        geodesic_asymmetry: geometry.asymmetry(),
        openings: geometry.openings.len(),
        face_turn_degrees: local.frame.turn_degrees(),
        unreachable_vertices: d.fallback.len(),
        masked_vertices,
        masks: if masked {
            input.groups.iter().map(|g| g.name.clone()).collect()
        } else {
            Vec::new()
        },
        anchoring,
        corners,
        let_go,
        lip_curve_vertices: rounded,
    };
    Ok(SurfaceBake {
        between,
        rows,
        kernel,
        system,
        figures,
        condition,
        radial: config.radial,
        dense,
        vertical,
        up: local.frame.axes()[1],
        forward,
        ahead: local.frame.axes()[2],
        give_way,
        warnings,
        marker_distances,
        head_candidates: head_candidates(&rest, &skull, &eyes),
        rbf_anchoring,
        followed_mean,
    })
}

/// The mouth: the lowest of `geometry`'s openings, when it is below the markers' (`rest`) mean
/// height.
fn mouth_opening(geometry: &SurfaceGeometry, rest: &[[f64; 3]]) -> Option<usize> {
    let mean_height = rest.iter().map(|p| p[1]).sum::<f64>() / rest.len().max(1) as f64;
    geometry
        .openings
        .iter()
        .enumerate()
        .min_by(|a, b| a.1.centre[1].total_cmp(&b.1.centre[1]))
        .filter(|(_, o)| o.centre[1] < mean_height)
        .map(|(i, _)| i)
}

/// The markers a capture's head fit may use: the skull markers
/// ([`anchoring::skull_markers`]) and each eye's inner-corner marker
/// ([`anchoring::anchor_markers`]). The medial canthi are tied to the bone by their tendons: on
/// FaceCap's truth they move at most 0.68 mm over its 32 frames, the forehead markers 1.48 mm,
/// and below the forehead they widen the fit's base: JawMoCap's three forehead markers alone
/// magnified their jitter into the face (±0.5 mm: p99 4.52 mm unsmoothed, 1.28 mm with the head
/// pose smoothed, which lags a moving head), with the inner eye corners 1.18 mm unsmoothed.
fn head_candidates(rest: &[[f64; 3]], skull: &[usize], eyes: &[&[[f64; 3]]]) -> Vec<usize> {
    anchoring::anchor_markers(rest, skull, eyes, false, corners::CORNER_REACH)
}

/// The openings' rims but the `mouth`'s: the eyes'.
/// The eyes' height: the mean height of their rims' points (`None` without eyes).
pub(crate) fn eyes_height(eyes: &[&[[f64; 3]]]) -> Option<f64> {
    let points: Vec<f64> = eyes.iter().flat_map(|r| r.iter().map(|p| p[1])).collect();
    (!points.is_empty()).then(|| points.iter().sum::<f64>() / points.len() as f64)
}

fn eye_rims(rims: &[Vec<[f64; 3]>], mouth: Option<usize>) -> Vec<&[[f64; 3]]> {
    rims.iter()
        .enumerate()
        .filter(|&(i, _)| Some(i) != mouth)
        .map(|(_, r)| r.as_slice())
        .collect()
}

/// A bake's input read in the face's own axes ([`crate::frame::FaceFrame`]); the input itself where
/// those are the file's.
struct LocalInput<'a> {
    world: &'a SurfaceInput<'a>,
    frame: FaceFrame,
    local: Option<(FaceMesh, Vec<SurfaceMarker>)>,
}

impl<'a> LocalInput<'a> {
    fn of(world: &'a SurfaceInput<'a>) -> Self {
        let frame = FaceFrame::of(world.mesh);
        let local = (frame != FaceFrame::FILE).then(|| {
            let markers = world
                .markers
                .iter()
                .map(|m| SurfaceMarker {
                    rest: frame.local(&m.rest),
                    ..m.clone()
                })
                .collect();
            (frame.mesh(world.mesh), markers)
        });
        Self {
            world,
            frame,
            local,
        }
    }

    fn input(&self) -> SurfaceInput<'_> {
        match &self.local {
            Some((mesh, markers)) => SurfaceInput {
                mesh,
                markers,
                ..*self.world
            },
            None => SurfaceInput { ..*self.world },
        }
    }
}

/// What the capture stages need from the skin for any deformer: the markers' distances to each
/// other along the skin (asset units, symmetric; straight-line where no path joins them) and
/// the markers the head fit may use ([`head_candidates`]).
pub(crate) fn skin_markers(
    input: &SurfaceInput<'_>,
    options: &SurfaceOptions,
) -> Result<(Vec<Vec<f64>>, Vec<usize>), SurfaceError> {
    let local = LocalInput::of(input);
    let input = &local.input();
    let rest: Vec<[f64; 3]> = input.markers.iter().map(|m| m.rest).collect();
    let sources: Vec<Source> = input.markers.iter().map(|m| m.source).collect();
    let geometry = SurfaceGeometry::new(input.mesh, &sources, options.geodesic)?;
    let n = rest.len();
    let distances = (0..n)
        .map(|i| {
            (0..n)
                .map(|j| {
                    let d = 0.5 * (geometry.between[i][j] + geometry.between[j][i]);
                    if d.is_finite() {
                        d
                    } else {
                        crate::mesh::distance(&rest[i], &rest[j])
                    }
                })
                .collect()
        })
        .collect();
    let rims = rims_of(&geometry, input.mesh);
    let skull = anchoring::skull_markers(&rest, &rims, mean_spacing(&rest));
    let eyes = eye_rims(&rims, mouth_opening(&geometry, &rest));
    Ok((distances, head_candidates(&rest, &skull, &eyes)))
}

/// The openings' rims, as positions.
fn rims_of(geometry: &SurfaceGeometry, mesh: &FaceMesh) -> Vec<Vec<[f64; 3]>> {
    geometry
        .openings
        .iter()
        .map(|o| {
            o.vertices
                .iter()
                .map(|&v| mesh.welded_positions[v as usize])
                .collect()
        })
        .collect()
}

impl SurfaceBake {
    /// The linear deformer of the dense weights, re-fitted under a prior whose covariance uses
    /// the method's own distances, so re-fitting a dropped lower-lip marker does not lean on the
    /// upper lip.
    pub(crate) fn linear(&self, options: &BakeOptions) -> Result<DeformerOutput, DeformerError> {
        let n = self.between.nrows();
        let length = options.prior_length * 2.0 * 3f64.sqrt();
        let sym = (&self.between + self.between.transpose()) * 0.5;
        let mut cov = sym.map(|r| (-(r * r) / (2.0 * length * length)).exp());
        let lift = (-cov.clone().symmetric_eigenvalues().min()).max(0.0);
        for i in 0..n {
            cov[(i, i)] += 1e-9 + lift;
        }
        deformer::linear::bake(
            self.dense.iter().cloned(),
            &self.vertical,
            self.up,
            &self.forward,
            self.ahead,
            &self.give_way,
            self.followed_mean
                .as_ref()
                .map(|head| deformer::linear::FollowedMean { markers: head }),
            options.k,
            options.refit,
            &cov,
        )
    }

    /// The RBF deformer: each vertex's radial values under the method's distances.
    pub(crate) fn rbf(&self, options: &BakeOptions) -> Result<DeformerOutput, DeformerError> {
        let n = self.between.nrows();
        let phi_rows = self.rows.iter().enumerate().map(|(v, r)| {
            let keep = self.rbf_anchoring.as_ref().map_or(1.0, |a| 1.0 - a.fade[v]);
            r.iter()
                .enumerate()
                .map(|(i, &x)| keep * self.kernel.phi(i, x))
                .collect()
        });
        let k = options.k.min(n);
        match &self.rbf_anchoring {
            Some(a) => deformer::rbf::bake(phi_rows, k, &self.system, &a.map),
            None => deformer::rbf::bake(phi_rows, k, &self.system, &self.system.coefficient_map()),
        }
    }
}

/// Markers on [`slit`] (its vertices): the slit's two corners (just past its ends), two on
/// each lid and four far out.
#[cfg(test)]
pub(crate) fn slit_markers() -> Vec<usize> {
    slit_markers_in(10, 8)
}

/// [`slit_markers`] on [`slit_in`]`(half)`, the four far out `far` above and below the slit.
#[cfg(test)]
pub(crate) fn slit_markers_in(half: i32, far: i32) -> Vec<usize> {
    let vertex = |x: i32, y: i32| ((y + half) * 41 + x + 20) as usize;
    [
        (-13, 0),
        (13, 0),
        (-5, 2),
        (5, 2),
        (-5, -2),
        (5, -2),
        (-18, far),
        (18, far),
        (-18, -far),
        (18, -far),
    ]
    .iter()
    .map(|&(x, y)| vertex(x, y))
    .collect()
}

/// A 41 × 21 grid (1 mm spacing, z = 0, y up, centred; vertex `(y + 10) · 41 + x + 20` at
/// (x, y)) with an eye-like slit: the cells inside the ellipse (x/12)² + (y/1.2)² < 1 left out,
/// so the rims run from x = −11 to 11 at y = ±1. For the tests of what happens at openings.
#[cfg(test)]
pub(crate) fn slit() -> crate::model::FaceMesh {
    slit_in(10)
}

/// [`slit`]'s slit in a grid 41 wide and `half` high either side (vertex `(y + half) · 41 + x
/// + 20` at (x, y)).
#[cfg(test)]
pub(crate) fn slit_in(half: u32) -> crate::model::FaceMesh {
    let (w, h) = (41u32, 2 * half + 1);
    let at = |x: u32, y: u32| [f64::from(x) - 20.0, f64::from(y) - f64::from(half), 0.0];
    let p: Vec<[f64; 3]> = (0..h).flat_map(|y| (0..w).map(move |x| at(x, y))).collect();
    let mut t = Vec::new();
    for y in 0..h - 1 {
        for x in 0..w - 1 {
            let c = [f64::from(x) - 19.5, f64::from(y) - f64::from(half) + 0.5];
            if (c[0] / 12.0).powi(2) + (c[1] / 1.2).powi(2) < 1.0 {
                continue;
            }
            let i = y * w + x;
            t.push([i, i + 1, i + w + 1]);
            t.push([i, i + w + 1, i + w]);
        }
    }
    crate::model::FaceMesh::from_triangles("slit", p, t)
}
