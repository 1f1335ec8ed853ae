//! The f64 references: the specification in code.
//!
//! * [`DenseRbf`]: the papers' method literally: every frame, solve the RBF system for the marker
//!   displacements (paper 000 eq 14, thesis eq 2.5) and evaluate it at every vertex (eq 2.6).
//! * [`SparseF64`]: the baked rig evaluated in f64 from the blob's own (quantised) numbers, so the
//!   runtime's fixed-point arithmetic can be compared with exact arithmetic on identical data.

use facebake_runtime::Rig;

use crate::rbf::RbfSystem;

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

/// A loaded rig's own numbers, evaluated in f64.
pub struct SparseF64 {
    rest: Vec<[f64; 3]>,
    marker_rest: Vec<[f64; 3]>,
    rows: Vec<Vec<(usize, f64)>>,
}

impl SparseF64 {
    /// Dequantise a rig: rest positions, marker rest positions and weights exactly as stored.
    pub fn from_rig(rig: &Rig<'_>) -> Self {
        let space = rig.space();
        let scale = f64::from(1u32 << rig.weight_frac_bits());
        let rest = (0..rig.vertex_count())
            .filter_map(|i| rig.vertex_rest(i))
            .map(|q| space.to_asset_f64(q))
            .collect();
        let marker_rest = (0..rig.marker_count())
            .filter_map(|i| rig.marker_rest(i))
            .map(|q| space.to_asset_f64(q))
            .collect();
        let mut rows = Vec::with_capacity(rig.vertex_count());
        let lin = rig.linear();
        let mut words = lin.influences.0.chunks_exact(4);
        for &count in lin.influence_counts.0 {
            let row = words
                .by_ref()
                .take(usize::from(count))
                .map(|w| {
                    let (m, q) = facebake_runtime::fixed::unpack_influence(u32::from_le_bytes([
                        w[0], w[1], w[2], w[3],
                    ]));
                    (usize::from(m), f64::from(q) / scale)
                })
                .collect();
            rows.push(row);
        }
        Self {
            rest,
            marker_rest,
            rows,
        }
    }

    /// Deformed positions for marker positions `markers` (asset units).
    pub fn frame(&self, markers: &[[f64; 3]]) -> Vec<[f64; 3]> {
        self.rest
            .iter()
            .zip(&self.rows)
            .map(|(v, row)| {
                let mut out = *v;
                for &(m, w) in row {
                    for c in 0..3 {
                        out[c] += w * (markers[m][c] - self.marker_rest[m][c]);
                    }
                }
                out
            })
            .collect()
    }
}
