//! The RBF deformer: per-frame RBF coefficients, K radial terms per vertex plus the affine part.

use super::DeformerOutput;
use crate::blob::DeformerBytes;
use crate::rbf::RbfSystem;
use crate::sparsify::{self, SparsifyError};

/// The RBF deformer from each vertex's radial values (in rig units) and the system solved in rig
/// units: keep the K largest terms, quantise them and the coefficient map.
pub(crate) fn bake(
    phi_rows: impl Iterator<Item = Vec<f64>>,
    k: usize,
    system: &RbfSystem,
) -> Result<DeformerOutput, SparsifyError> {
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
    Ok(DeformerOutput {
        bytes: DeformerBytes::Rbf {
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
