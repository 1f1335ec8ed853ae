//! A whole take as a few morph targets: the principal components of the per-frame displacements
//! from rest, so a glTF viewer plays thousands of frames from a small basis animated by weights.
//!
//! [`fit`] stacks every frame's displacement from the rest pose as a column of the `3·vertices
//! × frames` matrix `A` and finds its leading left singular vectors by **subspace iteration**:
//! start from the displacements of `k` evenly spaced frames (`k` = the target cap plus
//! [`OVERSAMPLING`], or every frame when there are fewer), then [`POWER_ITERATIONS`] times
//! `Q ← orth(A Aᵀ Q)`, and finally the SVD of the small `frames × k` matrix `Aᵀ Q`. That costs
//! a few passes of `frames × 3·vertices × k` multiply-adds, where the Gram matrix route
//! (`frames²` entries, then a dense eigensolver) would cost `frames²·3·vertices`; when `k`
//! covers every frame the basis spans them all and the result is the exact SVD. The basis is
//! not centred on the take's mean: `rest + Σ wₖ·targetₖ` must give the rest pose at zero
//! weights, which glTF viewers show by default, and an uncentred rank r+1 fits at least as
//! well as the mean plus r centred components.
//!
//! **Weights in [0, 1].** Viewers and engines clamp morph weights: Blender's importer to its
//! shape keys' [0, 1] slider range, Godot to [−1, 1], Unity (by default) to [0, 100] %. So each
//! component's weights, which span some `[lo, hi]`, are rewritten as `lo + (hi − lo)·u` with
//! `u` in [0, 1]: the component's target is scaled by `hi − lo`, and the constant part
//! `Σ lo·component` becomes one more target, the **offset** (target 0), whose weight is 1 in
//! every frame. Zero weights still give the rest pose.
//!
//! The **rank** is the smallest whose reconstruction keeps the 99th percentile of the vertex
//! error (the distance between a reconstructed and a played vertex, over every vertex of every
//! frame) within [`BasisOptions::max_error`], capped at [`BasisOptions::max_targets`] targets
//! (the offset included). Each
//! frame's weights are its least-squares projection onto the basis, so the error measured is
//! the real one whatever the accuracy of the iteration. The error reported in [`MorphBasis`]
//! is measured once more on the `f32` targets and weights as a glTF file stores them.
//!
//! [`fit_deltas`] fits per-vertex deltas of another quantity (the normals) to the same weights
//! by least squares, so one set of weights animates positions and normals together.

use nalgebra::{DMatrix, DVector};
use thiserror::Error;

/// The 99th-percentile bound on a reconstructed vertex's distance from the played one that
/// `play --glb` and the demo use by default, in millimetres.
pub const DEFAULT_MAX_ERROR_MM: f64 = 0.1;
/// The most targets `play --glb` and the demo use by default.
pub const DEFAULT_MAX_TARGETS: usize = 64;
/// Directions iterated beyond the target cap, so the leading ones converge.
pub const OVERSAMPLING: usize = 16;
/// Subspace iterations `Q ← orth(A Aᵀ Q)`.
pub const POWER_ITERATIONS: usize = 4;

/// How small a basis [`fit`] looks for.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BasisOptions {
    /// The bound on the 99th percentile of the vertex error, in the frames' units.
    pub max_error: f64,
    /// The most targets, the offset included (at least 2); when even these miss the bound,
    /// [`MorphBasis::bound_met`] is false.
    pub max_targets: usize,
}

/// The basis of a take and each frame's weights, as `f32` values a glTF file stores.
#[derive(Debug, Clone)]
pub struct MorphBasis {
    /// Each target's position delta per vertex: the offset first, then the components.
    pub targets: Vec<Vec<[f32; 3]>>,
    /// Each frame's weight per target, each in [0, 1]; the offset's is 1.
    pub weights: Vec<Vec<f32>>,
    /// The 99th percentile of the distance between `rest + Σ wₖ·targetₖ` and the frame, over
    /// every vertex of every frame (the frames' units).
    pub p99_error: f64,
    /// The largest such distance.
    pub max_error: f64,
    /// Whether the 99th percentile is within [`BasisOptions::max_error`].
    pub bound_met: bool,
}

/// Frames a basis cannot be fitted to.
#[derive(Debug, Error, PartialEq)]
pub enum MorphBasisError {
    /// No frames, or no vertices.
    #[error("no frames to fit a basis to (or no vertices)")]
    Empty,
    /// A frame does not have one position per rest vertex.
    #[error("frame {frame} has {actual} positions; the rest pose has {expected}")]
    FrameLength {
        /// The frame (its place in the list).
        frame: usize,
        /// Vertices at rest.
        expected: usize,
        /// Positions in the frame.
        actual: usize,
    },
    /// A position is NaN or infinite.
    #[error("frame {frame}: vertex {vertex} is not finite")]
    NotFinite {
        /// The frame (its place in the list).
        frame: usize,
        /// The vertex.
        vertex: usize,
    },
    /// The options ask for fewer than two targets, or a negative or NaN bound.
    #[error("a basis needs at least two targets (the offset and one component) and a bound ≥ 0 (got {max_targets} targets, bound {max_error})")]
    Options {
        /// The cap asked for.
        max_targets: usize,
        /// The bound asked for.
        max_error: f64,
    },
}

/// `(99th percentile, max)` of `values` (reordered); `(0, 0)` when empty.
pub fn p99_and_max(values: &mut [f64]) -> (f64, f64) {
    if values.is_empty() {
        return (0.0, 0.0);
    }
    let index = ((values.len() as f64 * 0.99).ceil() as usize).clamp(1, values.len()) - 1;
    let max = values.iter().copied().fold(0.0, f64::max);
    let (_, p99, _) = values.select_nth_unstable_by(index, f64::total_cmp);
    (*p99, max)
}

/// Fits the smallest basis of `frames` (one position per vertex of `rest`) within `options`.
pub fn fit(
    rest: &[[f64; 3]],
    frames: &[Vec<[f64; 3]>],
    options: &BasisOptions,
) -> Result<MorphBasis, MorphBasisError> {
    let (n, count) = (rest.len(), frames.len());
    if options.max_targets < 2 || options.max_error.is_nan() || options.max_error < 0.0 {
        return Err(MorphBasisError::Options {
            max_targets: options.max_targets,
            max_error: options.max_error,
        });
    }
    if n == 0 || count == 0 {
        return Err(MorphBasisError::Empty);
    }
    for (frame, positions) in frames.iter().enumerate() {
        if positions.len() != n {
            return Err(MorphBasisError::FrameLength {
                frame,
                expected: n,
                actual: positions.len(),
            });
        }
        if let Some(vertex) = positions
            .iter()
            .position(|p| p.iter().any(|x| !x.is_finite()))
        {
            return Err(MorphBasisError::NotFinite { frame, vertex });
        }
    }
    let rows = 3 * n;
    let mut a = DMatrix::<f64>::zeros(rows, count);
    for (f, positions) in frames.iter().enumerate() {
        let mut column = a.column_mut(f);
        for (v, (p, r)) in positions.iter().zip(rest).enumerate() {
            for k in 0..3 {
                column[3 * v + k] = p[k] - r[k];
            }
        }
    }
    let (basis, weights) = principal_directions(&a, options.max_targets - 1);

    // The smallest rank within the bound: peel one component at a time off the residual.
    let mut errors = vec![0.0f64; n * count];
    let mut rank = 0;
    let cap = (options.max_targets - 1).min(basis.ncols());
    while rank < cap {
        a.ger(-1.0, &basis.column(rank), &weights.column(rank), 1.0);
        rank += 1;
        for (f, column) in a.column_iter().enumerate() {
            for v in 0..n {
                let d = [0, 1, 2].map(|k| column[3 * v + k]);
                errors[f * n + v] = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            }
        }
        if p99_and_max(&mut errors).0 <= options.max_error {
            break;
        }
    }
    let rank = rank.max(1);
    // Weights in [0, 1]: w = lo + span·u per component, the lo parts summed into the offset.
    let mut offset = DVector::<f64>::zeros(rows);
    let mut columns = Vec::with_capacity(rank + 1);
    let mut unit_weights = DMatrix::<f64>::zeros(count, rank + 1);
    unit_weights.column_mut(0).fill(1.0);
    for t in 0..rank {
        let w = weights.column(t);
        let (lo, hi) = (w.min(), w.max());
        let span = if hi > lo { hi - lo } else { 1.0 };
        offset.axpy(lo, &basis.column(t), 1.0);
        columns.push(basis.column(t) * span);
        unit_weights
            .column_mut(t + 1)
            .copy_from(&w.map(|x| ((x - lo) / span).clamp(0.0, 1.0)));
    }
    columns.insert(0, offset);
    let targets: Vec<Vec<[f32; 3]>> = columns
        .iter()
        .map(|b| {
            (0..n)
                .map(|v| [0, 1, 2].map(|k| b[3 * v + k] as f32))
                .collect()
        })
        .collect();
    let weights: Vec<Vec<f32>> = (0..count)
        .map(|f| (0..=rank).map(|t| unit_weights[(f, t)] as f32).collect())
        .collect();

    // The error of the stored f32 values.
    errors.clear();
    for (f, positions) in frames.iter().enumerate() {
        for (v, (p, r)) in positions.iter().zip(rest).enumerate() {
            let mut q = r.map(|x| f64::from(x as f32));
            for (target, &w) in targets.iter().zip(&weights[f]) {
                for k in 0..3 {
                    q[k] += f64::from(w) * f64::from(target[v][k]);
                }
            }
            errors.push(crate::mesh::distance(&q, p));
        }
    }
    let (p99_error, max_error) = p99_and_max(&mut errors);
    Ok(MorphBasis {
        targets,
        weights,
        p99_error,
        max_error,
        bound_met: p99_error <= options.max_error,
    })
}

/// The leading `rows × r` orthonormal directions of `a`'s columns (largest singular value
/// first) and each column's coordinates on them (`columns × r`), `r ≤ cap`, by subspace
/// iteration (see the module docs).
fn principal_directions(a: &DMatrix<f64>, cap: usize) -> (DMatrix<f64>, DMatrix<f64>) {
    let (rows, count) = a.shape();
    let k = (cap + OVERSAMPLING).min(count).min(rows);
    let start: Vec<usize> = (0..k).map(|i| i * count / k).collect();
    let mut q = orthonormal(a.select_columns(&start));
    // With every frame in the start the span is exact; otherwise iterate towards the leading
    // directions.
    if k < count {
        for _ in 0..POWER_ITERATIONS {
            q = orthonormal(a * a.tr_mul(&q));
        }
    }
    let projected = a.tr_mul(&q);
    let svd = nalgebra::linalg::SVD::new(projected, true, true);
    let (Some(u), Some(v_t)) = (svd.u, svd.v_t) else {
        unreachable!("the SVD was asked for both factors")
    };
    let r = svd.singular_values.len().min(cap);
    let basis = &q * v_t.transpose().columns(0, r);
    let mut weights = u.columns(0, r).into_owned();
    for (mut column, s) in weights.column_iter_mut().zip(svd.singular_values.iter()) {
        column *= *s;
    }
    (basis, weights)
}

/// An orthonormal basis of `m`'s column space (thin QR).
fn orthonormal(m: DMatrix<f64>) -> DMatrix<f64> {
    nalgebra::linalg::QR::new(m).q()
}

/// Least-squares deltas of a per-vertex quantity for given weights: the `targets` minimising
/// `Σ_f ‖Σ_k w_fk · target_k − delta_f‖²`, `delta(f)` giving frame `f`'s change of the quantity
/// from rest (one vector per vertex, `vertices` of them). Directions no frame uses (a weight
/// that is zero throughout) get zero deltas.
pub fn fit_deltas(
    weights: &[Vec<f32>],
    vertices: usize,
    mut delta: impl FnMut(usize) -> Vec<[f64; 3]>,
) -> Vec<Vec<[f32; 3]>> {
    let rank = weights.first().map_or(0, Vec::len);
    let mut gram = DMatrix::<f64>::zeros(rank, rank);
    let mut rhs = DMatrix::<f64>::zeros(rank, 3 * vertices);
    for (f, w) in weights.iter().enumerate() {
        let w = DVector::from_iterator(rank, w.iter().map(|&x| f64::from(x)));
        gram.ger(1.0, &w, &w, 1.0);
        let d = delta(f);
        let d = DVector::from_iterator(3 * vertices, d.iter().flatten().copied());
        rhs.ger(1.0, &w, &d, 1.0);
    }
    // The pseudo-inverse leaves unused directions at zero rather than failing on them.
    let scale = gram.diagonal().max().max(f64::MIN_POSITIVE);
    let inverse = gram
        .pseudo_inverse(scale * 1e-12)
        .unwrap_or_else(|_| DMatrix::zeros(rank, rank));
    let solved = inverse * rhs;
    (0..rank)
        .map(|t| {
            (0..vertices)
                .map(|v| [0, 1, 2].map(|k| solved[(t, 3 * v + k)] as f32))
                .collect()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `frames` frames of `n` vertices moving along `modes` independent patterns.
    fn take(n: usize, frames: usize, modes: usize) -> (Vec<[f64; 3]>, Vec<Vec<[f64; 3]>>) {
        let rest: Vec<[f64; 3]> = (0..n)
            .map(|v| [v as f64, (v * v % 7) as f64, 1.0])
            .collect();
        let pattern = |m: usize, v: usize| {
            [0, 1, 2].map(|k| (((m * 31 + v * 7 + k * 3).pow(2)) as f64 * 0.37).sin() * 0.01)
        };
        let frames = (0..frames)
            .map(|f| {
                (0..n)
                    .map(|v| {
                        let mut p = rest[v];
                        for m in 0..modes {
                            let w = ((f * (m + 1)) as f64 * 0.05).cos() / (m + 1) as f64;
                            for (c, d) in p.iter_mut().zip(pattern(m, v)) {
                                *c += w * d;
                            }
                        }
                        p
                    })
                    .collect()
            })
            .collect();
        (rest, frames)
    }

    #[test]
    fn a_low_rank_take_needs_its_rank_and_no_more() {
        let (rest, frames) = take(50, 200, 5);
        let options = BasisOptions {
            max_error: 1e-6,
            max_targets: 12,
        };
        let basis = fit(&rest, &frames, &options).unwrap();
        assert_eq!(basis.targets.len(), 6, "the offset and 5 components");
        assert!(basis.bound_met && basis.max_error < 1e-6, "{basis:?}");
        assert_eq!(basis.weights.len(), 200);
        // Every weight in [0, 1], the offset's 1; each component spans the whole range.
        for w in &basis.weights {
            assert_eq!(w[0], 1.0);
            assert!(w.iter().all(|x| (0.0..=1.0).contains(x)), "{w:?}");
        }
        for t in 1..6 {
            let (lo, hi) = basis
                .weights
                .iter()
                .fold((1.0f32, 0.0f32), |(lo, hi), w| (lo.min(w[t]), hi.max(w[t])));
            assert!(lo == 0.0 && hi == 1.0, "{t}: {lo} {hi}");
        }
        // rest + Σ w·target reproduces each frame within the reported error.
        for (f, frame) in frames.iter().enumerate() {
            for (v, p) in frame.iter().enumerate() {
                let mut q = rest[v];
                for (t, w) in basis.targets.iter().zip(&basis.weights[f]) {
                    for k in 0..3 {
                        q[k] += f64::from(*w) * f64::from(t[v][k]);
                    }
                }
                assert!(crate::mesh::distance(&q, p) <= basis.max_error + 1e-12);
            }
        }
    }

    #[test]
    fn the_cap_wins_over_the_bound_and_says_so() {
        let (rest, frames) = take(40, 60, 8);
        let basis = fit(
            &rest,
            &frames,
            &BasisOptions {
                max_error: 0.0,
                max_targets: 3,
            },
        )
        .unwrap();
        assert_eq!(basis.targets.len(), 3);
        assert!(!basis.bound_met && basis.p99_error > 0.0);
        // A looser bound needs fewer targets.
        let loose = fit(
            &rest,
            &frames,
            &BasisOptions {
                max_error: basis.p99_error * 4.0,
                max_targets: 8,
            },
        )
        .unwrap();
        assert!(
            loose.targets.len() <= 3 && loose.bound_met,
            "{}",
            loose.targets.len()
        );
    }

    #[test]
    fn few_frames_are_reproduced_exactly() {
        let (rest, frames) = take(30, 4, 8);
        let basis = fit(
            &rest,
            &frames,
            &BasisOptions {
                max_error: 1e-9,
                max_targets: 10,
            },
        )
        .unwrap();
        assert!(basis.targets.len() <= 5);
        assert!(basis.max_error < 1e-8, "{}", basis.max_error);
    }

    #[test]
    fn deltas_fitted_to_the_weights() {
        let (rest, frames) = take(20, 50, 3);
        let basis = fit(
            &rest,
            &frames,
            &BasisOptions {
                max_error: 1e-7,
                max_targets: 6,
            },
        )
        .unwrap();
        // A quantity that is exactly twice the displacement gets twice the targets.
        let deltas = fit_deltas(&basis.weights, 20, |f| {
            frames[f]
                .iter()
                .zip(&rest)
                .map(|(p, r)| [0, 1, 2].map(|k| 2.0 * (p[k] - r[k])))
                .collect()
        });
        for (d, t) in deltas.iter().zip(&basis.targets) {
            for (a, b) in d.iter().zip(t) {
                for k in 0..3 {
                    assert!((a[k] - 2.0 * b[k]).abs() < 1e-4, "{a:?} {b:?}");
                }
            }
        }
    }

    #[test]
    fn bad_frames_and_options_are_errors() {
        let (rest, mut frames) = take(10, 5, 2);
        let options = BasisOptions {
            max_error: 0.0,
            max_targets: 4,
        };
        assert_eq!(
            fit(&rest, &[], &options).unwrap_err(),
            MorphBasisError::Empty
        );
        frames[3][7][1] = f64::NAN;
        assert_eq!(
            fit(&rest, &frames, &options).unwrap_err(),
            MorphBasisError::NotFinite {
                frame: 3,
                vertex: 7
            }
        );
        frames[2].pop();
        assert!(matches!(
            fit(&rest, &frames, &options).unwrap_err(),
            MorphBasisError::FrameLength { frame: 2, .. }
        ));
        let zero = BasisOptions {
            max_targets: 1,
            ..options
        };
        assert!(matches!(
            fit(&rest, &frames, &zero).unwrap_err(),
            MorphBasisError::Options { .. }
        ));
    }
}
