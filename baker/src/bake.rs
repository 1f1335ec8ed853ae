//! The bake: marker rest positions and mesh vertices in, a sealed rig blob out.
//!
//! Two forms of the same RBF deformation (see the runtime's `format` docs):
//! * `coefficients` (default): the RBF coefficients are computed per frame from a small dense
//!   map, then each vertex sums its K largest kernel terms plus the affine part. Kernel terms of
//!   a fast-decaying kernel vanish with distance, so this is very close to the dense method.
//! * `weights`: each vertex keeps its K largest dense weights on marker displacements,
//!   re-fitted to reproduce constants. Any linear method can bake to this form, but the affine
//!   term spreads RBF weights over every marker, so truncation costs accuracy.

use serde::{Deserialize, Serialize};

use crate::blob::{self, BlobContents, BlobError, BlobSizes, DeformerBytes};
use crate::planar::reference::PlanarReference;
use crate::rbf::{KernelKind, RbfSystem, SolveError};
use crate::reference::DenseRbf;
use crate::sparsify::{self, Refit, SparsifyError};

/// Which form the runtime evaluates.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum RigForm {
    /// Per-frame RBF coefficients, K kernel terms per vertex (needs a decaying kernel).
    Coefficients,
    /// K weights per vertex on marker displacements.
    Weights,
    /// Planar bones (paper 000 §4.1–4.2): K control-triangle transforms per vertex.
    Planar,
}

/// How to bake.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BakeConfig {
    /// Runtime form.
    pub form: RigForm,
    /// Radial kernel.
    pub kernel: KernelKind,
    /// Kernel width in asset units; `None` derives it from the marker spacing.
    pub width: Option<f64>,
    /// Width as a multiple of the mean nearest-marker distance, when `width` is `None`.
    pub width_factor: f64,
    /// Solve the affine term with the RBF coefficients.
    pub affine: bool,
    /// Influences per vertex.
    pub k: usize,
    /// Re-fit of the kept weights (`weights` form).
    pub refit: Refit,
    /// Length scale of the smooth-motion prior as a fraction of the mesh's bounding-box diagonal
    /// (`weights` form with the prior re-fit).
    pub prior_length: f64,
    /// Planar form: bone radius as a multiple of the closest connected-marker distance.
    #[serde(default = "default_planar_radius")]
    pub planar_radius: f64,
    /// Planar form: the control triangles (marker indices); `None` builds them automatically.
    #[serde(default)]
    pub control_triangles: Option<Vec<[usize; 3]>>,
}

fn default_planar_radius() -> f64 {
    crate::planar::DEFAULT_RADIUS_FACTOR
}

impl Default for BakeConfig {
    /// Gaussian kernel, width 0.75 × the mean nearest-marker distance, affine term, K = 8, in
    /// coefficient form: the configuration that keeps the sparse rig within 0.1 mm (p99) of the
    /// dense RBF on the FaceCap ground truth.
    fn default() -> Self {
        Self {
            form: RigForm::Coefficients,
            kernel: KernelKind::Gaussian,
            width: None,
            width_factor: 0.75,
            affine: true,
            k: 8,
            refit: Refit::Prior,
            prior_length: 0.05,
            planar_radius: default_planar_radius(),
            control_triangles: None,
        }
    }
}

/// What the bake is made of.
pub struct BakeInput<'a> {
    /// Vertex rest positions, mesh order, asset units.
    pub vertices: &'a [[f64; 3]],
    /// Marker names.
    pub marker_names: &'a [String],
    /// Marker rest positions on the character, asset units.
    pub marker_rest: &'a [[f64; 3]],
    /// Per-marker stiffness in [1, 9].
    pub stiffness: &'a [f64],
    /// The mesh's triangles (same vertex order as `vertices`): the planar form measures skin
    /// distances on them to keep control triangles off the mouth and eye openings.
    pub triangles: &'a [[u32; 3]],
    /// Planar form: discontinuity masks per vertex (`None`: unmasked).
    pub planar_masks: Option<&'a crate::planar::MarkerAllowance>,
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
    /// Inconsistent input or configuration.
    #[error("{0}")]
    Input(String),
    /// Planar bones.
    #[error("planar bones: {0}")]
    Planar(#[from] crate::planar::PlanarError),
}

/// What the bake measured.
#[derive(Clone, Debug, Serialize)]
pub struct BakeReport {
    /// Runtime form.
    pub form: RigForm,
    /// Kernel used.
    pub kernel: &'static str,
    /// 1-norm condition estimate of the RBF system.
    pub condition: f64,
    /// Warnings worth a user's attention.
    pub warnings: Vec<String>,
    /// Influences per vertex (K).
    pub k: usize,
    /// Fractional weight bits chosen.
    pub weight_frac_bits: u8,
    /// Mean share of the vertex's dense weight (weights form) or kernel mass (coefficients form)
    /// dropped by keeping K.
    pub mean_dropped_mass: f64,
    /// Largest such share.
    pub max_dropped_mass: f64,
    /// Largest weight rounding error.
    pub max_weight_rounding: f64,
    /// Largest coefficient-map rounding error relative to its row (coefficients form).
    pub max_matrix_rounding: f64,
    /// Blob sizes.
    pub sizes: BlobSizes,
    /// Planar form: control triangles, and vertices within no bone's radius.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub planar: Option<PlanarSummary>,
}

/// What the planar bake built.
#[derive(Clone, Debug, Serialize)]
pub struct PlanarSummary {
    /// Control triangles (marker indices).
    pub triangles: Vec<[usize; 3]>,
    /// Vertices within no bone's radius, which ride their closest bone alone.
    pub outside_radius: usize,
}

/// A finished bake.
pub struct Baked {
    /// The sealed blob.
    pub blob: Vec<u8>,
    /// Figures.
    pub report: BakeReport,
    /// The dense f64 reference of the same configuration (the papers' per-frame solve).
    pub dense: DenseRbf,
    /// Planar form: eqs 1–12 in f64 on the exact rest positions with the baked influences.
    pub planar: Option<PlanarReference>,
}

/// Bake a rig in the configured form.
pub fn bake(input: &BakeInput<'_>, config: &BakeConfig) -> Result<Baked, BakeError> {
    let n = input.marker_rest.len();
    if input.marker_names.len() != n || input.stiffness.len() != n {
        return Err(BakeError::Input(format!(
            "{} marker names, {} positions and {} stiffness values must agree",
            input.marker_names.len(),
            n,
            input.stiffness.len()
        )));
    }
    if !(1..=usize::from(facebake_runtime::fixed::MAX_INFLUENCES)).contains(&config.k) {
        return Err(SparsifyError::BadK(config.k).into());
    }
    let space = blob::space_for(input.vertices);
    let dense_kernel = config
        .kernel
        .resolve(input.marker_rest, config.width, config.width_factor);
    let dense_system = RbfSystem::new(
        input.marker_rest,
        dense_kernel,
        config.affine,
        input.stiffness,
    )?;
    let mut warnings = Vec::new();
    if dense_system.condition() > crate::rbf::system::CONDITION_WARNING {
        warnings.push(format!(
            "the RBF system is ill-conditioned (1-norm condition ≈ {:.2e}); results may be noisy: try a narrower kernel width or the affine term",
            dense_system.condition()
        ));
    }
    let condition = dense_system.condition();
    let mut planar = None;
    let form = match config.form {
        RigForm::Weights => weights_form(input, config, &dense_system, &space)?,
        RigForm::Coefficients => coefficients_form(input, config, &space)?,
        RigForm::Planar => {
            let (form, summary, reference) = planar_form(input, config, &space)?;
            planar = Some((summary, reference));
            form
        }
    };
    let (blob, sizes) = blob::write(&BlobContents {
        space,
        vertices: input.vertices,
        marker_names: input.marker_names,
        marker_rest: input.marker_rest,
        deformer: &form.deformer,
    })?;
    let dropped_max = form.dropped.iter().copied().fold(0.0, f64::max);
    let dropped_mean = form.dropped.iter().sum::<f64>() / form.dropped.len().max(1) as f64;
    let report = BakeReport {
        form: config.form,
        kernel: config.kernel.name(),
        condition,
        warnings,
        k: config.k.min(n),
        weight_frac_bits: form.frac_bits,
        mean_dropped_mass: dropped_mean,
        max_dropped_mass: dropped_max,
        max_weight_rounding: form.rounding,
        max_matrix_rounding: form.matrix_rounding,
        sizes,
        planar: planar.as_ref().map(|p| p.0.clone()),
    };
    let dense = DenseRbf::new(
        dense_system,
        input.vertices.to_vec(),
        input.marker_rest.to_vec(),
    );
    Ok(Baked {
        blob,
        report,
        dense,
        planar: planar.map(|p| p.1),
    })
}

/// What a form's bake hands back for the blob and the report.
pub(crate) struct FormOutput {
    pub(crate) deformer: DeformerBytes,
    pub(crate) frac_bits: u8,
    /// Per vertex, the share of its weight or kernel mass that keeping K dropped.
    pub(crate) dropped: Vec<f64>,
    pub(crate) rounding: f64,
    pub(crate) matrix_rounding: f64,
}

fn weights_form(
    input: &BakeInput<'_>,
    config: &BakeConfig,
    system: &RbfSystem,
    space: &facebake_runtime::Space,
) -> Result<FormOutput, BakeError> {
    let diagonal = 2.0 * f64::from(space.half_extent) * 3f64.sqrt();
    let covariance = sparsify::prior_covariance(input.marker_rest, config.prior_length * diagonal);
    linear_deformer(
        input.vertices.iter().map(|v| system.weights_at(v)),
        config.k,
        config.refit,
        &covariance,
    )
}

/// The `weights` form from each vertex's dense weights: keep K, re-fit, quantise.
pub(crate) fn linear_deformer(
    dense_rows: impl Iterator<Item = Vec<f64>>,
    k: usize,
    refit: Refit,
    covariance: &nalgebra::DMatrix<f64>,
) -> Result<FormOutput, BakeError> {
    let mut dropped = Vec::new();
    let rows: Vec<_> = dense_rows
        .map(|dense| {
            let row = sparsify::sparsify_row(&dense, k, refit, Some(covariance));
            let kept: f64 = row.iter().map(|&(i, _)| dense[i]).sum();
            dropped.push((dense.iter().sum::<f64>() - kept).abs());
            row
        })
        .collect();
    let q = sparsify::quantise(&rows, sparsify::QuantiseFor::LinearWeights)?;
    Ok(FormOutput {
        deformer: DeformerBytes::Linear {
            weight_frac_bits: q.frac_bits,
            rows: q.words,
        },
        frac_bits: q.frac_bits,
        dropped,
        rounding: q.max_rounding,
        matrix_rounding: 0.0,
    })
}

fn planar_form(
    input: &BakeInput<'_>,
    config: &BakeConfig,
    space: &facebake_runtime::Space,
) -> Result<(FormOutput, PlanarSummary, PlanarReference), BakeError> {
    let p = crate::planar::bake(
        input.vertices,
        input.triangles,
        input.marker_rest,
        &crate::planar::PlanarOptions {
            given: config.control_triangles.as_deref(),
            k: config.k,
            radius_factor: config.planar_radius,
            masks: input.planar_masks,
        },
        |x| blob::to_rig_units(space, x),
    )?;
    let triangles = p.triangles.iter().map(|t| t.map(|m| m as u8)).collect();
    let summary = PlanarSummary {
        triangles: p.triangles.clone(),
        outside_radius: p.outside,
    };
    let reference = PlanarReference::new(
        input.vertices.to_vec(),
        input.marker_rest.to_vec(),
        p.triangles,
        p.rows,
    );
    let form = FormOutput {
        deformer: DeformerBytes::Planar {
            triangles,
            rows: p.records,
        },
        frac_bits: facebake_runtime::deformer::planar::PLANAR_WEIGHT_FRAC_BITS,
        dropped: p.dropped,
        rounding: p.max_weight_rounding,
        matrix_rounding: 0.0,
    };
    Ok((form, summary, reference))
}

fn coefficients_form(
    input: &BakeInput<'_>,
    config: &BakeConfig,
    space: &facebake_runtime::Space,
) -> Result<FormOutput, BakeError> {
    if matches!(
        config.kernel,
        KernelKind::Multiquadric | KernelKind::ThinPlate
    ) {
        return Err(BakeError::Input(format!(
            "the {} kernel grows with distance, so its terms cannot be truncated to the K nearest: use --form weights",
            config.kernel.name()
        )));
    }
    // Solve in rig units, where the runtime evaluates: the affine part is then β · rest(v).
    let h = f64::from(space.half_extent);
    let centres: Vec<[f64; 3]> = input
        .marker_rest
        .iter()
        .map(|p| blob::to_rig_units(space, p))
        .collect();
    let kernel = config
        .kernel
        .resolve(&centres, config.width.map(|w| w / h), config.width_factor);
    let system = RbfSystem::new(&centres, kernel, config.affine, input.stiffness)?;
    let n = centres.len();
    let phi_rows = input.vertices.iter().map(|p| {
        let v = blob::to_rig_units(space, p);
        (0..n)
            .map(|i| {
                system
                    .kernel()
                    .phi(i, crate::mesh::distance(&v, &centres[i]))
            })
            .collect()
    });
    coefficients_deformer(phi_rows, config.k.min(n), &system)
}

/// The `coefficients` form from each vertex's kernel values (in rig units) and the system
/// solved in rig units: keep the K largest terms, quantise them and the coefficient map.
pub(crate) fn coefficients_deformer(
    phi_rows: impl Iterator<Item = Vec<f64>>,
    k: usize,
    system: &RbfSystem,
) -> Result<FormOutput, BakeError> {
    let n = system.len();
    let mut dropped = Vec::new();
    let rows: Vec<_> = phi_rows
        .map(|phi: Vec<f64>| {
            let kept = sparsify::top_k(&phi, k);
            let total: f64 = phi.iter().map(|x| x.abs()).sum();
            dropped.push(
                1.0 - kept.iter().map(|&i| phi[i].abs()).sum::<f64>()
                    / total.max(f64::MIN_POSITIVE),
            );
            kept.into_iter()
                .map(|i| (i, phi[i]))
                .collect::<sparsify::SparseRow>()
        })
        .collect();
    let q = sparsify::quantise(&rows, sparsify::QuantiseFor::KernelValues)?;
    let affine = system.affine();
    let m = sparsify::quantise_matrix(&system.coefficient_map(), affine.then_some(n));
    Ok(FormOutput {
        deformer: DeformerBytes::Rbf {
            weight_frac_bits: q.frac_bits,
            k: k as u8,
            affine,
            row_shifts: m.shifts,
            matrix: m.entries,
            rows: q.words,
        },
        frac_bits: q.frac_bits,
        dropped,
        rounding: q.max_rounding,
        matrix_rounding: m.max_relative_rounding,
    })
}
