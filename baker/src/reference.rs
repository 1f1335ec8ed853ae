//! The f64 references: the specification in code.
//!
//! * [`DenseRbf`]: the papers' method literally: every frame, solve the RBF system for the marker
//!   displacements (paper 000 eq 14, thesis eq 2.5) and evaluate it at every vertex (eq 2.6).
//! * [`SparseF64`]: the baked rig evaluated in f64 from the blob's own (quantised) numbers, so the
//!   runtime's fixed-point arithmetic can be compared with exact arithmetic on identical data.

use facebake_runtime::deformer::Deformer;
use facebake_runtime::fixed::POS_FRAC_BITS;
use facebake_runtime::format::records::{read_influence, INFLUENCE_BYTES};
use facebake_runtime::{Rig, Space};

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

/// A loaded rig's own numbers, evaluated in f64 in rig units: the same formula as the runtime
/// on the same quantised data, with exact arithmetic instead of fixed point.
pub struct SparseF64 {
    space: Space,
    rest: Vec<[f64; 3]>,
    marker_rest: Vec<[f64; 3]>,
    /// Per vertex: (table index, weight).
    rows: Vec<Vec<(usize, f64)>>,
    /// RBF-coefficient rigs: the dequantised map (rows × markers) and whether it has affine rows.
    coefficients: Option<(Vec<Vec<f64>>, bool)>,
    /// Planar-bones rigs: eqs 1–12 on the rig's own rest positions and influences.
    planar: Option<crate::planar::reference::PlanarReference>,
}

fn dequantise_rows(
    words: &[u8],
    counts: impl Iterator<Item = usize>,
    scale: f64,
) -> Vec<Vec<(usize, f64)>> {
    let mut words = words.chunks_exact(INFLUENCE_BYTES);
    counts
        .map(|count| {
            words
                .by_ref()
                .take(count)
                .map(|w| {
                    let (m, q) = read_influence(w);
                    (usize::from(m), f64::from(q) / scale)
                })
                .collect()
        })
        .collect()
}

impl SparseF64 {
    /// Dequantise a rig: rest positions, marker rest positions, weights and coefficient map
    /// exactly as stored.
    pub fn from_rig(rig: &Rig<'_>) -> Self {
        let scale = f64::from(1u32 << rig.weight_frac_bits());
        let one = f64::from(1u32 << POS_FRAC_BITS);
        let to_f64 = |q: [i32; 3]| q.map(|x| f64::from(x) / one);
        let rest = (0..rig.vertex_count())
            .filter_map(|i| rig.vertex_rest(i))
            .map(to_f64)
            .collect();
        let marker_rest = (0..rig.marker_count())
            .filter_map(|i| rig.marker_rest(i))
            .map(to_f64)
            .collect();
        let (rows, coefficients) = match rig.deformer() {
            Deformer::Linear(l) => (
                dequantise_rows(
                    l.influences.0,
                    l.influence_counts.0.iter().map(|&c| usize::from(c)),
                    scale,
                ),
                None,
            ),
            Deformer::Rbf(r) => {
                let k = usize::from(r.influences_per_vertex);
                let rows =
                    dequantise_rows(r.influences.0, (0..rig.vertex_count()).map(|_| k), scale);
                let m = rig.marker_count();
                let matrix = r
                    .row_shifts
                    .0
                    .iter()
                    .zip(r.matrix.0.chunks_exact(2 * m))
                    .map(|(&s, e)| {
                        let unit = 2f64.powi(i32::from(s));
                        e.chunks_exact(2)
                            .map(|q| f64::from(i16::from_le_bytes([q[0], q[1]])) / unit)
                            .collect()
                    })
                    .collect();
                (rows, Some((matrix, r.affine)))
            }
            Deformer::Planar(_) => (Vec::new(), None),
        };
        Self {
            space: rig.space(),
            rest,
            marker_rest,
            rows,
            coefficients,
            planar: crate::planar::reference::PlanarReference::from_rig(rig),
        }
    }

    /// Deformed positions for marker positions `markers` (asset units).
    pub fn frame(&self, markers: &[[f64; 3]]) -> Vec<[f64; 3]> {
        if let Some(planar) = &self.planar {
            return planar.frame(markers).0;
        }
        let d: Vec<[f64; 3]> = markers
            .iter()
            .zip(&self.marker_rest)
            .map(|(m, r)| {
                let m = crate::blob::to_rig_units(&self.space, m);
                [m[0] - r[0], m[1] - r[1], m[2] - r[2]]
            })
            .collect();
        // The table the per-vertex sums index: displacements, or this frame's coefficients.
        let (table, affine) = match &self.coefficients {
            None => (d, false),
            Some((matrix, affine)) => {
                let c = matrix
                    .iter()
                    .map(|row| {
                        let mut c = [0.0; 3];
                        for (q, dj) in row.iter().zip(&d) {
                            for a in 0..3 {
                                c[a] += q * dj[a];
                            }
                        }
                        c
                    })
                    .collect();
                (c, *affine)
            }
        };
        let n = self.marker_rest.len();
        self.rest
            .iter()
            .zip(&self.rows)
            .map(|(v, row)| {
                let mut out = *v;
                for &(i, w) in row {
                    for a in 0..3 {
                        out[a] += w * table[i][a];
                    }
                }
                if affine {
                    for a in 0..3 {
                        out[a] +=
                            table[n][a] + (0..3).map(|b| table[n + 1 + b][a] * v[b]).sum::<f64>();
                    }
                }
                let h = f64::from(self.space.half_extent);
                [0, 1, 2].map(|a| f64::from(self.space.centre[a]) + out[a] * h)
            })
            .collect()
    }
}
