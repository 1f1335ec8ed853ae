//! Surface-aware deformation: RBFs on distances along the skin, so the lips and the eyelids can
//! part, all baked into the runtime's existing forms.
//!
//! * [`Method::Geodesic`] (thesis §5.2, paper 002 §2.1): the kernel of the geodesic distance.
//! * [`Method::Hybrid`] (thesis §5.3): geodesic near the openings, Euclidean elsewhere, blended
//!   by a Gaussian decay ([`distances`]).
//! * [`Method::Euclidean`]: the straight-line RBF of [`crate::bake`], for comparison and masks.
//! * Masks ([`masks`]) on any of them: marker groups either side of an opening that may move only
//!   their own side. Masks need the `weights` form (one RBF per side; the coefficient form has
//!   one coefficient map).
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
pub mod distances;
pub mod evaluate;
pub mod geometry;
pub mod masks;
pub mod openings;
pub mod pbw;

use nalgebra::DMatrix;

use crate::bake::{self, BakeConfig, BakeError, RigForm};
use crate::blob::{self, BlobContents, BlobSizes};
use crate::geodesic::{GeodesicError, GeodesicMethod, Source};
use crate::io::gltf_mesh::FaceMesh;
use crate::io::marker_groups::MarkerGroups;
use crate::rbf::{Kernel, KernelKind, RbfSystem};
use crate::sparsify;

pub use distances::DistanceKind;
pub use geometry::SurfaceGeometry;
pub use masks::{MaskError, Side, SideRule};

/// Ridge margin (fraction of the mean |φ|) added beyond the most negative eigenvalue.
pub const RIDGE_MARGIN: f64 = 1e-3;

/// Which distance the RBF is built on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum Method {
    /// Straight-line distance.
    Euclidean,
    /// Distance along the surface.
    Geodesic,
    /// Geodesic near the mouth and eyes, Euclidean elsewhere.
    Hybrid,
    /// Proximity-based weighting on geodesics blended with a global multiquadric RBF
    /// (paper 002 §2.2; weights form only).
    Pbw,
}

impl Method {
    /// Every method, for sweeps.
    pub const ALL: [Method; 4] = [Self::Euclidean, Self::Geodesic, Self::Hybrid, Self::Pbw];

    /// Name on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            Self::Euclidean => "euclidean",
            Self::Geodesic => "geodesic",
            Self::Hybrid => "hybrid",
            Self::Pbw => "pbw",
        }
    }
}

/// How to bake a surface-aware rig.
#[derive(Clone, Debug)]
pub struct SurfaceConfig {
    /// Distance function.
    pub method: Method,
    /// How geodesics are computed.
    pub geodesic: GeodesicMethod,
    /// Form, kernel, width, affine term, K and re-fit, as for [`crate::bake::bake`].
    pub bake: BakeConfig,
    /// Apply the marker groups' masks.
    pub masks: bool,
    /// Hybrid: radius of the geodesic region around the openings, × mean marker spacing.
    pub region_factor: f64,
    /// Hybrid: width of the Gaussian decay outside the region, × mean marker spacing.
    pub decay_factor: f64,
    /// Masks: distance from the openings within which a mask is at full strength, × mean
    /// marker spacing.
    pub mask_plateau_factor: f64,
    /// Masks: width of the Gaussian fade beyond it, × mean marker spacing.
    pub mask_decay_factor: f64,
    /// PBW: α of paper 002's eq 11, the share of the local (proximity) weights; the rest is the
    /// global multiquadric RBF.
    pub pbw_alpha: f64,
    /// Ridge on the kernel diagonal as a fraction of the mean |φ|; `None`: just enough to make
    /// the kernel block positive semi-definite, plus [`RIDGE_MARGIN`] when it is not.
    pub ridge: Option<f64>,
    /// Static anchoring (weights form): the skin beyond the markers' hull follows the head
    /// markers over this distance, × mean marker spacing ([`anchoring`]); `None`: off.
    pub anchoring_margin_factor: Option<f64>,
}

impl Default for SurfaceConfig {
    /// The bake's default: geodesic distances (heat method) with the exponential kernel
    /// `exp(−r/c)` (the thesis' eq 2.3a; its geodesic kernel matrix stays positive definite on
    /// FaceCap where the Gaussian's does not), c = 1.5 × the mean marker spacing, affine term,
    /// K = 8, in the weights form with static anchoring over 0.8 × spacing ([`anchoring`]); no
    /// masks. Hybrid region and decay: 0.5 × spacing; masks at full strength within 0.5 ×
    /// spacing of the opening, fading over 1 × spacing.
    fn default() -> Self {
        Self {
            method: Method::Geodesic,
            geodesic: GeodesicMethod::Heat,
            bake: BakeConfig {
                form: RigForm::Weights,
                kernel: KernelKind::Exponential,
                width_factor: 1.5,
                ..BakeConfig::default()
            },
            masks: false,
            region_factor: 0.5,
            decay_factor: 0.5,
            mask_plateau_factor: 0.5,
            mask_decay_factor: 1.0,
            pbw_alpha: 0.5,
            ridge: None,
            anchoring_margin_factor: Some(0.8),
        }
    }
}

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
    pub fn from_placed(p: &crate::io::layout::PlacedMarker) -> Self {
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
    /// Head markers that anchored skin follows (empty: [`anchoring::skull_markers`]).
    pub head: &'a [usize],
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
    /// The RBF, sparsification or blob.
    #[error(transparent)]
    Bake(#[from] BakeError),
    /// Planar bones blend control-triangle frames, not RBF distances: no surface-aware method
    /// applies to them (masks do, through [`planar_allowance`]).
    #[error(
        "planar bones take no surface-aware method: bake them with --method euclidean (masks apply with --form planar --masks)"
    )]
    PlanarForm,
}

/// What a surface-aware bake measured.
#[derive(Clone, Debug, serde::Serialize)]
pub struct SurfaceReport {
    /// Distance function.
    pub method: Method,
    /// Runtime form.
    pub form: RigForm,
    /// Kernel.
    pub kernel: &'static str,
    /// Smallest eigenvalue of the symmetric part of the kernel block, over its mean |φ|.
    pub min_eigenvalue: f64,
    /// Ridge added (fraction of the mean |φ|).
    pub ridge: f64,
    /// 1-norm condition estimate of the full system.
    pub condition: f64,
    /// Largest relative asymmetry of the marker-to-marker geodesics.
    pub geodesic_asymmetry: f64,
    /// Openings found on the skin.
    pub openings: usize,
    /// glTF vertices no marker reaches along the surface (Euclidean distances used).
    pub unreachable_vertices: usize,
    /// Vertices a mask touched.
    pub masked_vertices: usize,
    /// Static anchoring: the head markers followed (names), vertices anchored at all and fully.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub anchoring: Option<AnchoringReport>,
    /// Fractional weight bits.
    pub weight_frac_bits: u8,
    /// Mean share of dense weight / kernel mass dropped by keeping K.
    pub mean_dropped_mass: f64,
    /// Blob sizes.
    pub sizes: BlobSizes,
    /// Warnings worth a user's attention.
    pub warnings: Vec<String>,
}

/// What static anchoring did.
#[derive(Clone, Debug, serde::Serialize)]
pub struct AnchoringReport {
    /// The head markers anchored skin follows.
    pub head_markers: Vec<String>,
    /// glTF vertices with some anchoring.
    pub anchored_vertices: usize,
    /// glTF vertices that follow the head markers alone.
    pub still_vertices: usize,
}

/// A finished surface-aware bake.
pub struct SurfaceBaked {
    /// The sealed blob.
    pub blob: Vec<u8>,
    /// Figures.
    pub report: SurfaceReport,
    /// Per glTF vertex, its dense f64 weights on the marker displacements (masks applied): the
    /// reference the sparse rig approximates.
    pub dense: Vec<Vec<f64>>,
    /// Marker-to-marker distances under the method's distance (asset units): along the skin
    /// for the geodesic methods.
    pub marker_distances: Vec<Vec<f64>>,
}

/// The kernel in rig units; the inverse multiquadric's radii are each marker's distance to its
/// nearest other marker under the method's distance (paper 002 §2.1).
fn resolve_kernel(
    config: &BakeConfig,
    centres: &[[f64; 3]],
    between: &DMatrix<f64>,
    h: f64,
) -> Kernel {
    let kernel = config
        .kernel
        .resolve(centres, config.width.map(|w| w / h), config.width_factor);
    match config.kernel {
        KernelKind::InverseMultiquadric => Kernel::InverseMultiquadric {
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
    config: &SurfaceConfig,
) -> Result<Vec<masks::MaskSides>, SurfaceError> {
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
    config: &SurfaceConfig,
) -> Result<crate::planar::MarkerAllowance, SurfaceError> {
    let sides = mask_sides(input, config)?;
    Ok(masks::marker_allowance(&sides, input.mesh.positions.len()))
}

/// Every mask's sides and strengths with `config`'s plateau and decay (× `spacing`).
fn sides_of(
    input: &SurfaceInput<'_>,
    config: &SurfaceConfig,
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
    )?)
}

/// Vertices that not every marker reaches along the surface (mouth-interior pieces) take the
/// weights of the nearest vertex every marker reaches, so they ride the skin beside them instead
/// of being pulled by markers across the face through Euclidean distances.
fn follow_nearest_reachable(
    mut dense: Vec<Vec<f64>>,
    unreachable: &[u32],
    positions: &[[f64; 3]],
) -> Vec<Vec<f64>> {
    if unreachable.is_empty() {
        return dense;
    }
    let mut cut = vec![false; positions.len()];
    for &v in unreachable {
        cut[v as usize] = true;
    }
    let reachable: Vec<usize> = (0..positions.len()).filter(|&v| !cut[v]).collect();
    for &v in unreachable {
        let p = &positions[v as usize];
        if let Some(&near) = reachable.iter().min_by(|&&a, &&b| {
            crate::mesh::distance(p, &positions[a])
                .total_cmp(&crate::mesh::distance(p, &positions[b]))
        }) {
            dense[v as usize] = dense[near].clone();
        }
    }
    dense
}

/// Mean nearest-marker distance.
fn mean_spacing(rest: &[[f64; 3]]) -> f64 {
    let r = crate::rbf::kernel::nearest_distances(rest);
    r.iter().sum::<f64>() / r.len().max(1) as f64
}

/// Bake a surface-aware rig.
pub fn bake_surface(
    input: &SurfaceInput<'_>,
    config: &SurfaceConfig,
) -> Result<SurfaceBaked, SurfaceError> {
    let mesh = input.mesh;
    let n = input.markers.len();
    let k = config.bake.k;
    if !(1..=usize::from(facebake_runtime::fixed::MAX_INFLUENCES)).contains(&k) {
        return Err(BakeError::from(sparsify::SparsifyError::BadK(k)).into());
    }
    let masked = config.masks && !input.groups.is_empty();
    if masked && config.bake.form == RigForm::Coefficients {
        return Err(BakeError::Input(
            "masks need the weights form (--form weights): the coefficient form has one RBF for the whole face"
                .into(),
        )
        .into());
    }
    if config.method == Method::Pbw && config.bake.form == RigForm::Coefficients {
        return Err(BakeError::Input(
            "PBW weights are not an RBF: it needs the weights form (--form weights)".into(),
        )
        .into());
    }
    if config.bake.form == RigForm::Coefficients
        && matches!(
            config.bake.kernel,
            KernelKind::Multiquadric | KernelKind::ThinPlate
        )
    {
        return Err(BakeError::Input(format!(
            "the {} kernel grows with distance, so its terms cannot be truncated to the K nearest: use --form weights",
            config.bake.kernel.name()
        ))
        .into());
    }
    let rest: Vec<[f64; 3]> = input.markers.iter().map(|m| m.rest).collect();
    let names: Vec<String> = input.markers.iter().map(|m| m.name.clone()).collect();
    let stiffness: Vec<f64> = input.markers.iter().map(|m| m.stiffness).collect();
    let sources: Vec<Source> = input.markers.iter().map(|m| m.source).collect();
    let spacing = mean_spacing(&rest);
    let geometry = SurfaceGeometry::new(mesh, &sources, config.geodesic)?;
    let kind = match config.method {
        Method::Euclidean => DistanceKind::Euclidean,
        Method::Geodesic | Method::Pbw => DistanceKind::Geodesic,
        Method::Hybrid => DistanceKind::Hybrid {
            region: config.region_factor * spacing,
            decay: config.decay_factor * spacing,
        },
    };
    let d = distances::marker_distances(
        kind,
        &geometry,
        &mesh.welded_positions,
        &mesh.positions,
        &rest,
    );
    let mut warnings = Vec::new();
    if !d.fallback.is_empty() {
        let mut pieces = geometry.topology_pieces(&d.fallback);
        pieces.sort_by_key(|p| std::cmp::Reverse(p.1));
        let listed: Vec<String> = pieces
            .iter()
            .take(3)
            .map(|(c, count)| format!("component {c}: {count}"))
            .collect();
        warnings.push(format!(
            "{} vertices in {} piece(s) of the mesh that not every marker reaches along the surface use Euclidean distances (largest: {}{})",
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
    let space = blob::space_for(&mesh.positions);
    let h = f64::from(space.half_extent);
    let centres: Vec<[f64; 3]> = rest.iter().map(|p| blob::to_rig_units(&space, p)).collect();
    let points: Vec<[f64; 3]> = mesh
        .positions
        .iter()
        .map(|p| blob::to_rig_units(&space, p))
        .collect();
    let between = &d.between / h;
    let rows: Vec<Vec<f64>> = d
        .vertices
        .iter()
        .map(|r| r.iter().map(|x| x / h).collect())
        .collect();
    // PBW's local weights use the geodesic rows; its RBF part is paper 002's global
    // multiquadric on Euclidean distances.
    let geodesic_rows = (config.method == Method::Pbw).then(|| rows.clone());
    let (between, rows, kernel) = if config.method == Method::Pbw {
        let e = DMatrix::from_fn(n, n, |j, i| crate::mesh::distance(&centres[j], &centres[i]));
        let r: Vec<Vec<f64>> = points
            .iter()
            .map(|p| {
                centres
                    .iter()
                    .map(|c| crate::mesh::distance(p, c))
                    .collect()
            })
            .collect();
        let k = KernelKind::Multiquadric.resolve(&centres, None, config.bake.width_factor);
        (e, r, k)
    } else {
        let k = resolve_kernel(&config.bake, &centres, &between, h);
        (between, rows, k)
    };
    let (min_eig, mean_phi) = kernel_spectrum(&kernel, &between);
    let min_eigenvalue = min_eig / mean_phi;
    // Euclidean kernels are (conditionally) positive definite by theory, with the affine term
    // for the multiquadric and thin-plate kernels, whose blocks have negative eigenvalues.
    let euclidean = matches!(config.method, Method::Euclidean | Method::Pbw);
    let ridge = config
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
        config.bake.affine,
        &stiffness,
        ridge,
    )
    .map_err(BakeError::from)?;
    let condition = system.condition();
    if condition > crate::rbf::system::CONDITION_WARNING {
        warnings.push(format!(
            "the RBF system is ill-conditioned (1-norm condition ≈ {condition:.2e}): try a narrower kernel or a ridge"
        ));
    }
    let (dense, masked_vertices) = if masked {
        let sides = sides_of(input, config, &geometry, &rest, spacing)?;
        masks::masked_weights(
            &masks::MaskedSolve {
                full: &system,
                centres: &centres,
                between: &between,
                kernel: &kernel,
                stiffness: &stiffness,
                ridge,
            },
            &sides,
            &rows,
            &points,
        )?
    } else {
        (
            rows.iter()
                .zip(&points)
                .map(|(r, p)| system.weights_from_distances(r, p))
                .collect(),
            0,
        )
    };
    let dense = match geodesic_rows {
        Some(g) => {
            let nb = pbw::neighbours(&(&d.between / h));
            let a = config.pbw_alpha;
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
    let mut dense = follow_nearest_reachable(dense, &d.fallback, &mesh.positions);
    let anchoring = match (config.anchoring_margin_factor, config.bake.form) {
        (Some(factor), RigForm::Weights) => {
            let head = if input.head.is_empty() {
                let rims: Vec<Vec<[f64; 3]>> = geometry
                    .openings
                    .iter()
                    .map(|o| {
                        o.vertices
                            .iter()
                            .map(|&v| mesh.welded_positions[v as usize])
                            .collect()
                    })
                    .collect();
                anchoring::skull_markers(&rest, &rims, spacing)
            } else {
                input.head.to_vec()
            };
            let mean_height = rest.iter().map(|p| p[1]).sum::<f64>() / n.max(1) as f64;
            let floor = geometry
                .openings
                .iter()
                .map(|o| o.centre[1])
                .fold(None, |low: Option<f64>, y| {
                    Some(low.map_or(y, |l| l.min(y)))
                })
                .filter(|&y| y < mean_height);
            let a =
                anchoring::static_anchoring(&mesh.positions, &rest, &head, floor, factor * spacing);
            a.apply(&mut dense);
            Some(AnchoringReport {
                head_markers: head.iter().map(|&h| names[h].clone()).collect(),
                anchored_vertices: a.anchored_vertices(),
                still_vertices: a.still_vertices(),
            })
        }
        _ => None,
    };
    let form = match config.bake.form {
        RigForm::Weights => {
            // The prior's covariance under the method's own distances, so re-fitting a dropped
            // lower-lip marker does not lean on the upper lip.
            let length = config.bake.prior_length * 2.0 * 3f64.sqrt();
            let sym = (&between + between.transpose()) * 0.5;
            let mut cov = sym.map(|r| (-(r * r) / (2.0 * length * length)).exp());
            let lift = (-cov.clone().symmetric_eigenvalues().min()).max(0.0);
            for i in 0..n {
                cov[(i, i)] += 1e-9 + lift;
            }
            bake::linear_deformer(dense.iter().cloned(), k, config.bake.refit, &cov)?
        }
        RigForm::Coefficients => {
            let phi_rows = rows.iter().map(|r| {
                r.iter()
                    .enumerate()
                    .map(|(i, &x)| kernel.phi(i, x))
                    .collect()
            });
            bake::coefficients_deformer(phi_rows, k.min(n), &system)?
        }
        RigForm::Planar => return Err(SurfaceError::PlanarForm),
    };
    let (blob, sizes) = blob::write(&BlobContents {
        space,
        vertices: &mesh.positions,
        marker_names: &names,
        marker_rest: &rest,
        deformer: &form.deformer,
    })
    .map_err(BakeError::from)?;
    let report = SurfaceReport {
        method: config.method,
        form: config.bake.form,
        kernel: if config.method == Method::Pbw {
            KernelKind::Multiquadric.name()
        } else {
            config.bake.kernel.name()
        },
        min_eigenvalue,
        ridge,
        condition,
        geodesic_asymmetry: geometry.asymmetry(),
        openings: geometry.openings.len(),
        unreachable_vertices: d.fallback.len(),
        masked_vertices,
        anchoring,
        weight_frac_bits: form.frac_bits,
        mean_dropped_mass: form.dropped.iter().sum::<f64>() / form.dropped.len().max(1) as f64,
        sizes,
        warnings,
    };
    let marker_distances = (0..n)
        .map(|i| (0..n).map(|j| d.between[(i, j)]).collect())
        .collect();
    Ok(SurfaceBaked {
        blob,
        report,
        dense,
        marker_distances,
    })
}
