//! The bake: marker rest positions and mesh vertices in, a sealed linear rig blob out.

use serde::{Deserialize, Serialize};

use crate::blob::{self, BlobContents, BlobError, BlobSizes};
use crate::rbf::{KernelKind, RbfSystem, SolveError};
use crate::reference::DenseRbf;
use crate::sparsify::{self, Refit, SparsifyError};

/// How to bake linear weights.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BakeConfig {
    /// Radial kernel.
    pub kernel: KernelKind,
    /// Kernel width in asset units; `None` derives it from the marker spacing.
    pub width: Option<f64>,
    /// Width as a multiple of the mean nearest-marker distance, when `width` is `None`.
    pub width_factor: f64,
    /// Solve the affine term with the RBF coefficients.
    pub affine: bool,
    /// Most influences per vertex.
    pub k: usize,
    /// Re-fit of the kept weights.
    pub refit: Refit,
    /// Length scale of the smooth-motion prior as a fraction of the mesh's bounding-box diagonal.
    pub prior_length: f64,
}

impl Default for BakeConfig {
    fn default() -> Self {
        Self {
            kernel: KernelKind::InverseMultiquadric,
            width: None,
            width_factor: 2.0,
            affine: true,
            k: 8,
            refit: Refit::Prior,
            prior_length: 0.05,
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
    /// Inconsistent input.
    #[error("{0}")]
    Input(String),
}

/// What the bake measured.
#[derive(Clone, Debug, Serialize)]
pub struct BakeReport {
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
    /// Mean |Σ dropped dense weights| per vertex before the re-fit.
    pub mean_dropped_mass: f64,
    /// Largest |Σ dropped dense weights|.
    pub max_dropped_mass: f64,
    /// Largest weight rounding error.
    pub max_weight_rounding: f64,
    /// Blob sizes.
    pub sizes: BlobSizes,
}

/// A finished bake.
pub struct Baked {
    /// The sealed blob.
    pub blob: Vec<u8>,
    /// Figures.
    pub report: BakeReport,
    /// The dense f64 reference of the same configuration.
    pub dense: DenseRbf,
}

/// Bake a linear rig.
pub fn bake_linear(input: &BakeInput<'_>, config: &BakeConfig) -> Result<Baked, BakeError> {
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
    let kernel = config
        .kernel
        .resolve(input.marker_rest, config.width, config.width_factor);
    let system = RbfSystem::new(input.marker_rest, kernel, config.affine, input.stiffness)?;
    let mut warnings = Vec::new();
    if system.condition() > crate::rbf::system::CONDITION_WARNING {
        warnings.push(format!(
            "the RBF system is ill-conditioned (1-norm condition ≈ {:.2e}); weights may be noisy: try a narrower kernel width or the affine term",
            system.condition()
        ));
    }
    let space = blob::space_for(input.vertices);
    let diagonal = 2.0 * f64::from(space.half_extent) * 3f64.sqrt();
    let covariance = sparsify::prior_covariance(input.marker_rest, config.prior_length * diagonal);
    let (mut dropped_sum, mut dropped_max) = (0.0, 0.0f64);
    let rows: Vec<_> = input
        .vertices
        .iter()
        .map(|v| {
            let dense = system.weights_at(v);
            let row = sparsify::sparsify_row(&dense, config.k, config.refit, Some(&covariance));
            let kept: f64 = row.iter().map(|&(i, _)| dense[i]).sum();
            let dropped = (dense.iter().sum::<f64>() - kept).abs();
            dropped_sum += dropped;
            dropped_max = dropped_max.max(dropped);
            row
        })
        .collect();
    let quantised = sparsify::quantise(&rows)?;
    let (blob, sizes) = blob::write_linear(&BlobContents {
        space,
        vertices: input.vertices,
        marker_names: input.marker_names,
        marker_rest: input.marker_rest,
        influences: &quantised,
    })?;
    let report = BakeReport {
        kernel: config.kernel.name(),
        condition: system.condition(),
        warnings,
        k: config.k,
        weight_frac_bits: quantised.frac_bits,
        mean_dropped_mass: dropped_sum / input.vertices.len().max(1) as f64,
        max_dropped_mass: dropped_max,
        max_weight_rounding: quantised.max_rounding,
        sizes,
    };
    let dense = DenseRbf::new(system, input.vertices.to_vec(), input.marker_rest.to_vec());
    Ok(Baked {
        blob,
        report,
        dense,
    })
}
