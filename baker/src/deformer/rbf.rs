//! The RBF deformer: per-frame RBF coefficients, K radial terms per vertex plus the affine part.
//!
//! Its f64 references: [`DenseRbf`], the papers' method literally (every frame, solve the RBF
//! system for the marker displacements, paper 000 eq 14, thesis eq 2.5, and evaluate it at every
//! vertex, eq 2.6); and `RbfF64`, the rig's own quantised numbers in exact arithmetic.

use facebake_runtime::deformer::rbf::RbfDeformer;
use facebake_runtime::deformer::Deformer;
use facebake_runtime::format::records::{Bytes, INFLUENCE_BYTES};

use super::{dequantise_rows, le_words, DeformerBytes, DeformerOutput, Section, SectionError};
use crate::rbf::RbfSystem;
use crate::sparsify;

/// The RBF section, encoded: the coefficient map's row shifts and entries, and exactly K packed
/// radial terms per vertex.
pub struct RbfBytes {
    weight_frac_bits: u8,
    k: u8,
    affine: bool,
    row_shifts: Vec<u8>,
    matrix: Vec<u8>,
    words: Vec<u8>,
}

impl RbfBytes {
    /// The section from its parts; every row must hold exactly `k` terms.
    fn new(
        weight_frac_bits: u8,
        k: u8,
        affine: bool,
        row_shifts: Vec<u8>,
        matrix: &[i16],
        rows: &[Vec<u32>],
    ) -> Result<Self, SectionError> {
        if let Some(r) = rows.iter().find(|r| r.len() != usize::from(k)) {
            return Err(SectionError(format!(
                "a vertex has {} radial terms, the rig has K = {k}",
                r.len()
            )));
        }
        Ok(Self {
            weight_frac_bits,
            k,
            affine,
            row_shifts,
            matrix: matrix.iter().flat_map(|q| q.to_le_bytes()).collect(),
            words: le_words(rows),
        })
    }

    /// The runtime's section over these bytes.
    pub(super) fn section(&self) -> Section<'_> {
        Section {
            deformer: Deformer::Rbf(RbfDeformer {
                influences_per_vertex: self.k,
                weight_frac_bits: self.weight_frac_bits,
                affine: self.affine,
                row_shifts: Bytes(&self.row_shifts),
                matrix: Bytes(&self.matrix),
                influences: Bytes(&self.words),
            }),
            influence_bytes: self.words.len(),
            influences: self.words.len() / INFLUENCE_BYTES,
        }
    }
}

/// The RBF deformer from each vertex's radial values (in rig units), the system solved in rig
/// units and its coefficient `map` (the system's own, or anchored): keep the K largest terms,
/// quantise them and the map.
pub(crate) fn bake(
    phi_rows: impl Iterator<Item = Vec<f64>>,
    k: usize,
    system: &RbfSystem,
    map: &nalgebra::DMatrix<f64>,
) -> Result<DeformerOutput, super::DeformerError> {
    let n = system.len();
    let mut dropped = Vec::new();
    let rows: Vec<_> = phi_rows
        .map(|phi: Vec<f64>| {
            let kept = sparsify::top_k(&phi, k);
            let total: f64 = phi.iter().map(|x| x.abs()).sum();
            // A vertex whose radial terms the anchoring faded out entirely drops nothing.
            dropped.push(if total > 0.0 {
                1.0 - kept.iter().map(|&i| phi[i].abs()).sum::<f64>() / total
            } else {
                0.0
            });
            kept.into_iter()
                .map(|i| (i, phi[i]))
                .collect::<sparsify::SparseRow>()
        })
        .collect();
    let q = sparsify::quantise(&rows, sparsify::QuantiseFor::KernelValues)?;
    let affine = system.affine();
    let m = sparsify::quantise_matrix(map, affine.then_some(n));
    Ok(DeformerOutput {
        bytes: DeformerBytes::Rbf(RbfBytes::new(
            q.frac_bits,
            k as u8,
            affine,
            m.shifts,
            &m.entries,
            &q.words,
        )?),
        frac_bits: q.frac_bits,
        dropped,
        rounding: q.max_rounding,
        matrix_rounding: m.max_relative_rounding,
    })
}

/// The dense per-frame RBF deformation of the papers.
pub struct DenseRbf {
    system: RbfSystem,
    rest: Vec<[f64; 3]>,
    marker_rest: Vec<[f64; 3]>,
}

impl DenseRbf {
    /// Over `rest` vertices, with markers resting at `marker_rest` (the system's centres).
    pub fn new(system: RbfSystem, rest: Vec<[f64; 3]>, marker_rest: Vec<[f64; 3]>) -> Self {
        Self {
            system,
            rest,
            marker_rest,
        }
    }

    /// Deformed positions for marker positions `markers` (asset units).
    pub fn frame(&self, markers: &[[f64; 3]]) -> Vec<[f64; 3]> {
        let d: Vec<[f64; 3]> = markers
            .iter()
            .zip(&self.marker_rest)
            .map(|(m, r)| [m[0] - r[0], m[1] - r[1], m[2] - r[2]])
            .collect();
        let coefficients = self.system.solve(&d);
        self.rest
            .iter()
            .map(|v| {
                let dv = self.system.evaluate(&coefficients, v);
                [v[0] + dv[0], v[1] + dv[1], v[2] + dv[2]]
            })
            .collect()
    }
}

/// A loaded RBF rig's section in f64: per vertex its kept radial values, and the dequantised
/// coefficient map (rows × markers) with or without its affine rows.
pub(crate) struct RbfF64 {
    /// Per vertex: (marker, φ).
    rows: Vec<Vec<(usize, f64)>>,
    /// The coefficient map.
    matrix: Vec<Vec<f64>>,
    affine: bool,
}

impl RbfF64 {
    /// The section `r` of a rig with `vertices` vertices and `markers` markers, radial values
    /// scaled by `scale`.
    pub(crate) fn new(r: &RbfDeformer<'_>, vertices: usize, markers: usize, scale: f64) -> Self {
        let k = usize::from(r.influences_per_vertex);
        let rows = dequantise_rows(r.influences.0, (0..vertices).map(|_| k), scale);
        let matrix = r
            .row_shifts
            .0
            .iter()
            .zip(r.matrix.0.chunks_exact(2 * markers))
            .map(|(&s, e)| {
                let unit = 2f64.powi(i32::from(s));
                e.chunks_exact(2)
                    .map(|q| f64::from(i16::from_le_bytes([q[0], q[1]])) / unit)
                    .collect()
            })
            .collect();
        Self {
            rows,
            matrix,
            affine: r.affine,
        }
    }

    /// Each vertex's displacement (rig units) for marker displacements `d` (rig units): this
    /// frame's coefficients from the map, then the vertex's K radial terms and the affine part.
    pub(crate) fn displacements(&self, rest: &[[f64; 3]], d: &[[f64; 3]]) -> Vec<[f64; 3]> {
        let c: Vec<[f64; 3]> = self
            .matrix
            .iter()
            .map(|row| {
                let mut c = [0.0; 3];
                for (q, dj) in row.iter().zip(d) {
                    for a in 0..3 {
                        c[a] += q * dj[a];
                    }
                }
                c
            })
            .collect();
        let n = d.len();
        rest.iter()
            .zip(&self.rows)
            .map(|(v, row)| {
                let mut out = [0.0; 3];
                for &(i, w) in row {
                    for a in 0..3 {
                        out[a] += w * c[i][a];
                    }
                }
                if self.affine {
                    for a in 0..3 {
                        out[a] += c[n][a] + (0..3).map(|b| c[n + 1 + b][a] * v[b]).sum::<f64>();
                    }
                }
                out
            })
            .collect()
    }
}
