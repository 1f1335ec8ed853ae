//! The linear deformer: K weights per vertex on marker displacements.

use super::DeformerOutput;
use crate::blob::DeformerBytes;
use crate::sparsify::{self, Refit, SparsifyError};

/// The linear deformer from each vertex's dense weights: keep K, re-fit, quantise.
pub(crate) fn bake(
    dense_rows: impl Iterator<Item = Vec<f64>>,
    k: usize,
    refit: Refit,
    covariance: &nalgebra::DMatrix<f64>,
) -> Result<DeformerOutput, SparsifyError> {
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
    Ok(DeformerOutput {
        bytes: DeformerBytes::Linear {
            weight_frac_bits: q.frac_bits,
            rows: q.words,
        },
        frac_bits: q.frac_bits,
        dropped,
        rounding: q.max_rounding,
        matrix_rounding: 0.0,
    })
}
