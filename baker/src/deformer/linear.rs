//! The linear deformer: K weights per vertex on marker displacements; its f64 reference,
//! `LinearF64`, is the rig's own quantised weights in exact arithmetic.

use facebake_runtime::deformer::linear::LinearDeformer;
use facebake_runtime::deformer::Deformer;
use facebake_runtime::format::records::{Bytes, INFLUENCE_BYTES};

use super::{
    dequantise_rows, influence_counts, le_words, DeformerBytes, DeformerOutput, Section,
    SectionError,
};
use crate::sparsify::{self, Refit};

/// The linear section, encoded: per vertex its influence count, and the packed influences.
pub struct LinearBytes {
    weight_frac_bits: u8,
    counts: Vec<u8>,
    words: Vec<u8>,
}

impl LinearBytes {
    /// Per vertex, its packed influences (at most 64).
    fn new(weight_frac_bits: u8, rows: &[Vec<u32>]) -> Result<Self, SectionError> {
        Ok(Self {
            weight_frac_bits,
            counts: influence_counts(rows.iter().map(Vec::len))?,
            words: le_words(rows),
        })
    }

    /// The runtime's section over these bytes.
    pub(super) fn section(&self) -> Section<'_> {
        Section {
            deformer: Deformer::Linear(LinearDeformer {
                weight_frac_bits: self.weight_frac_bits,
                max_influences: self.counts.iter().copied().max().unwrap_or(0).max(1),
                influence_counts: Bytes(&self.counts),
                influences: Bytes(&self.words),
            }),
            influence_bytes: self.words.len(),
            influences: self.words.len() / INFLUENCE_BYTES,
        }
    }
}

/// The linear deformer from each vertex's dense weights: keep K, re-fit, quantise.
pub(crate) fn bake(
    dense_rows: impl Iterator<Item = Vec<f64>>,
    k: usize,
    refit: Refit,
    covariance: &nalgebra::DMatrix<f64>,
) -> Result<DeformerOutput, super::DeformerError> {
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
        bytes: DeformerBytes::Linear(LinearBytes::new(q.frac_bits, &q.words)?),
        frac_bits: q.frac_bits,
        dropped,
        rounding: q.max_rounding,
        matrix_rounding: 0.0,
    })
}

/// A loaded linear rig's section in f64: per vertex, its (marker, weight) pairs.
pub(crate) struct LinearF64 {
    rows: Vec<Vec<(usize, f64)>>,
}

impl LinearF64 {
    /// The section `l`, weights scaled by `scale`.
    pub(crate) fn new(l: &LinearDeformer<'_>, scale: f64) -> Self {
        Self {
            rows: dequantise_rows(
                l.influences.0,
                l.influence_counts.0.iter().map(|&c| usize::from(c)),
                scale,
            ),
        }
    }

    /// Each vertex's displacement for marker displacements `d` (rig units): Σ w · d.
    pub(crate) fn displacements(&self, d: &[[f64; 3]]) -> Vec<[f64; 3]> {
        self.rows
            .iter()
            .map(|row| {
                let mut out = [0.0; 3];
                for &(i, w) in row {
                    for a in 0..3 {
                        out[a] += w * d[i][a];
                    }
                }
                out
            })
            .collect()
    }
}
