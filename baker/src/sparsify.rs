//! Dense per-vertex weights → at most K per vertex that still reproduce constants exactly, then
//! quantised to the runtime's 24-bit weights.
//!
//! Three ways to keep K weights, each summing to one:
//! * `shrink` (the product's default, [`crate::BakeOptions::for_method`]): every magnitude less
//!   the (K+1)-th largest, the K largest kept, rescaled to sum to one. A marker enters or leaves
//!   a vertex's set at weight zero, so the weights stay continuous across the skin where the set
//!   changes; the others re-fit the kept set, which jumps there (a seam of up to the dropped
//!   weight times the markers' relative motion, which stretched 0.6 mm smile-fold edges 2.17× on
//!   the FaceCap truth). Small far-field weights go to zero, so the skull follows its anchors
//!   more closely too (JawMoCap static drift 0.42 → 0.37 mm; `docs/measurements.md`);
//! * `uniform`: the smallest change to the kept weights (spread the dropped mass evenly);
//! * `prior` (the papers' configuration, [`crate::BakeOptions::default`]): the kept weights that minimise the expected squared difference from the
//!   dense result when marker displacements are a smooth random field with covariance
//!   `exp(−‖x_i − x_j‖² / 2ℓ²)`. The dropped markers' motion is then predicted from the kept
//!   ones instead of ignored: for a vertex with kept set S, solve
//!   `[Σ_SS 1; 1ᵀ 0] [u; μ] = [Σ_S· w; 1]`.

use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

use crate::rbf::radial::distance;
use facebake_runtime::fixed::{
    pack_influence, LINEAR_MAX_WEIGHT_FRAC_BITS, LINEAR_WEIGHT_ABS_SUM_MAX, MAX_WEIGHT_FRAC_BITS,
    MIN_WEIGHT_FRAC_BITS, WEIGHT_INT_MAX,
};

/// How the kept weights are re-fitted after dropping all but the K largest.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Refit {
    /// Spread the dropped mass evenly over the kept weights.
    Uniform,
    /// Best prediction of the dropped markers under a smooth-motion prior.
    Prior,
    /// Shrink every magnitude by the (K+1)-th largest and rescale: continuous over the skin (a
    /// row heavier than twice an all-positive one after it is re-fitted by `Prior` instead).
    Shrink,
}

/// One vertex's sparse weights: (marker index, weight), summing to one.
pub type SparseRow = Vec<(usize, f64)>;

/// Sparsification or quantisation failed.
#[derive(Debug, thiserror::Error)]
pub enum SparsifyError {
    /// A weight too large for the 24-bit format even at the coarsest resolution.
    #[error("a weight of {weight:.3} (vertex {vertex}) does not fit the rig's 24-bit weights even with {MIN_WEIGHT_FRAC_BITS} fractional bits; the RBF system is probably ill-conditioned")]
    WeightTooLarge {
        /// The vertex.
        vertex: usize,
        /// The weight.
        weight: f64,
    },
    /// K outside what the runtime accepts.
    #[error("K = {0} is outside 1..=64")]
    BadK(usize),
}

/// The prior covariance over the markers' displacements: `exp(−d²/2ℓ²)` plus a 1e-9 nugget.
pub fn prior_covariance(markers: &[[f64; 3]], length: f64) -> DMatrix<f64> {
    let n = markers.len();
    DMatrix::from_fn(n, n, |i, j| {
        let d = distance(&markers[i], &markers[j]);
        (-(d * d) / (2.0 * length * length)).exp() + if i == j { 1e-9 } else { 0.0 }
    })
}

/// Indices of the K largest-magnitude values (ties to the lower index), ascending.
pub fn top_k(values: &[f64], k: usize) -> Vec<usize> {
    let mut order: Vec<usize> = (0..values.len()).collect();
    order.sort_by(|&a, &b| values[b].abs().total_cmp(&values[a].abs()).then(a.cmp(&b)));
    order.truncate(k);
    order.sort_unstable();
    order
}

/// Keep the K largest-magnitude weights of `dense` (ties to the lower index) and re-fit them.
pub fn sparsify_row(
    dense: &[f64],
    k: usize,
    refit: Refit,
    covariance: Option<&DMatrix<f64>>,
) -> SparseRow {
    let order = top_k(dense, k);
    let refit = match refit {
        Refit::Shrink if order.len() < dense.len() => match shrink(dense, &order) {
            Some(row) => return row,
            None => Refit::Prior,
        },
        other => other,
    };
    let uniform = || {
        let kept: f64 = order.iter().map(|&i| dense[i]).sum();
        let share = (1.0 - kept) / order.len() as f64;
        order
            .iter()
            .map(|&i| (i, dense[i] + share))
            .collect::<SparseRow>()
    };
    match (refit, covariance) {
        (Refit::Prior, Some(cov)) if order.len() < dense.len() => {
            let m = order.len();
            let mut a = DMatrix::<f64>::zeros(m + 1, m + 1);
            let mut b = DVector::<f64>::zeros(m + 1);
            let w = DVector::from_column_slice(dense);
            for (r, &i) in order.iter().enumerate() {
                for (c, &j) in order.iter().enumerate() {
                    a[(r, c)] = cov[(i, j)];
                }
                a[(r, m)] = 1.0;
                a[(m, r)] = 1.0;
                b[r] = cov.row(i).transpose().dot(&w);
            }
            b[m] = 1.0;
            match a.lu().solve(&b) {
                Some(u) if u.iter().all(|x| x.is_finite()) => {
                    order.iter().enumerate().map(|(r, &i)| (i, u[r])).collect()
                }
                _ => uniform(),
            }
        }
        _ => uniform(),
    }
}

/// [`sparsify_row`] for a vertex beside influences that take `ranks` of its K elsewhere (the
/// mouth's corrections, `surface::corners`): with [`Refit::Shrink`], its K kept weights are
/// shrunk by a threshold that moves, as `give_way` goes from 0 to 1, from the (K+1)-th largest
/// magnitude to the (K − ranks + 1)-th, so its `ranks` weakest fade to zero and the row meets,
/// continuously, the K − `ranks` that a vertex with those influences keeps. Other re-fits, or
/// `give_way` 0, keep K as [`sparsify_row`] does.
pub fn sparsify_row_giving_way(
    dense: &[f64],
    k: usize,
    ranks: usize,
    give_way: f64,
    refit: Refit,
    covariance: Option<&DMatrix<f64>>,
) -> SparseRow {
    if refit != Refit::Shrink || give_way <= 0.0 || ranks == 0 || k <= ranks || k >= dense.len() {
        return sparsify_row(dense, k, refit, covariance);
    }
    let mut magnitudes: Vec<f64> = dense.iter().map(|w| w.abs()).collect();
    magnitudes.sort_by(|a, b| b.total_cmp(a));
    let a = give_way.min(1.0);
    let threshold = (1.0 - a) * magnitudes[k] + a * magnitudes[k - ranks];
    shrink_by(dense, &top_k(dense, k), threshold)
        .unwrap_or_else(|| sparsify_row(dense, k, refit, covariance))
}

/// The heaviest row [`Refit::Shrink`] keeps: Σ|w| at most twice an all-positive row's.
const SHRINK_MAX_ABS_SUM: f64 = 2.0;

/// `dense`'s weights at `order` (its K largest magnitudes), each magnitude less the (K+1)-th
/// largest, rescaled to sum to one; `None` where that row is heavier than
/// [`SHRINK_MAX_ABS_SUM`] (large weights of both signs, from an ill-conditioned kernel, which
/// the rescale would amplify), which the caller re-fits instead.
fn shrink(dense: &[f64], order: &[usize]) -> Option<SparseRow> {
    let threshold = (0..dense.len())
        .filter(|i| order.binary_search(i).is_err())
        .map(|i| dense[i].abs())
        .fold(0.0, f64::max);
    shrink_by(dense, order, threshold)
}

/// `dense`'s weights at `order`, each magnitude less `threshold` (those under it zero),
/// rescaled to sum to one; `None` for a row heavier than [`SHRINK_MAX_ABS_SUM`].
fn shrink_by(dense: &[f64], order: &[usize], threshold: f64) -> Option<SparseRow> {
    let row: SparseRow = order
        .iter()
        .map(|&i| (i, dense[i].signum() * (dense[i].abs() - threshold).max(0.0)))
        .collect();
    let sum: f64 = row.iter().map(|&(_, w)| w).sum();
    let abs_sum: f64 = row.iter().map(|&(_, w)| w.abs()).sum();
    (sum > 0.0 && abs_sum <= SHRINK_MAX_ABS_SUM * sum)
        .then(|| row.into_iter().map(|(i, w)| (i, w / sum)).collect())
}

/// Weights quantised for the blob.
pub struct Quantised {
    /// Fractional bits F: every vertex's weights sum to exactly 2^F.
    pub frac_bits: u8,
    /// Per vertex: (marker index, packed influence word).
    pub words: Vec<Vec<u32>>,
    /// Largest |quantised − sparse| weight error.
    pub max_rounding: f64,
}

/// How [`quantise`] may scale a set of rows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum QuantiseFor {
    /// Linear-deformer weights: each row's rounding is fixed so it sums to exactly 2^F (the
    /// residual goes to the row's largest weight), and F is the finest that keeps every row's
    /// Σ|q| within [`LINEAR_WEIGHT_ABS_SUM_MAX`] (F ≤ [`LINEAR_MAX_WEIGHT_FRAC_BITS`]), what the
    /// runtime's 16-bit linear kernel needs and its loader checks.
    LinearWeights,
    /// Radial values φ of the RBF deformer: plain rounding, the finest F that holds every
    /// value in 24 bits.
    KernelValues,
}

/// Quantise sparse rows with the finest F that `target` allows (see [`QuantiseFor`]).
pub fn quantise(rows: &[SparseRow], target: QuantiseFor) -> Result<Quantised, SparsifyError> {
    let normalise = target == QuantiseFor::LinearWeights;
    let (mut vertex, mut largest) = (0, 0.0f64);
    for (v, row) in rows.iter().enumerate() {
        for &(_, w) in row {
            if w.abs() > largest {
                (vertex, largest) = (v, w.abs());
            }
        }
    }
    // Leave room for the per-row residual (at most K/2 units) on top of the rounded weight.
    let margin = 64.0;
    // Linear weights: Σ|q| ≤ Σ|w|·2^F + (rounding, ≤ ½ per weight) + (residual, ≤ ½ per weight).
    let (mut heaviest_row, mut heaviest) = (0, 0.0f64);
    for (v, row) in rows.iter().enumerate() {
        let abs_sum = row.iter().map(|&(_, w)| w.abs()).sum::<f64>() + row.len() as f64;
        if abs_sum > heaviest {
            (heaviest_row, heaviest) = (v, abs_sum);
        }
    }
    let (max_frac, fits): (u8, &dyn Fn(u8) -> bool) = match target {
        QuantiseFor::LinearWeights => (LINEAR_MAX_WEIGHT_FRAC_BITS, &|f| {
            heaviest * f64::from(1u32 << f) <= f64::from(LINEAR_WEIGHT_ABS_SUM_MAX)
        }),
        QuantiseFor::KernelValues => (MAX_WEIGHT_FRAC_BITS, &|_| true),
    };
    let frac_bits = (MIN_WEIGHT_FRAC_BITS..=max_frac)
        .rev()
        .find(|&f| largest * f64::from(1u32 << f) + margin <= f64::from(WEIGHT_INT_MAX) && fits(f))
        .ok_or(SparsifyError::WeightTooLarge {
            vertex: if fits(MIN_WEIGHT_FRAC_BITS) {
                vertex
            } else {
                heaviest_row
            },
            weight: largest,
        })?;
    let scale = f64::from(1u32 << frac_bits);
    let mut words = Vec::with_capacity(rows.len());
    let mut max_rounding = 0.0f64;
    for (v, row) in rows.iter().enumerate() {
        let mut q: Vec<i64> = row
            .iter()
            .map(|&(_, w)| (w * scale).round() as i64)
            .collect();
        let residual = if normalise {
            (1i64 << frac_bits) - q.iter().sum::<i64>()
        } else {
            0
        };
        if let Some(big) = (0..row.len()).max_by(|&a, &b| row[a].1.abs().total_cmp(&row[b].1.abs()))
        {
            q[big] += residual;
        }
        let mut packed = Vec::with_capacity(row.len());
        for (&(m, w), &qi) in row.iter().zip(&q) {
            max_rounding = max_rounding.max((qi as f64 / scale - w).abs());
            let word = i32::try_from(qi)
                .ok()
                .and_then(|qi| pack_influence(m as u8, qi))
                .ok_or(SparsifyError::WeightTooLarge {
                    vertex: v,
                    weight: w,
                })?;
            packed.push(word);
        }
        words.push(packed);
    }
    Ok(Quantised {
        frac_bits,
        words,
        max_rounding,
    })
}

/// A coefficient map quantised row by row to `i16 · 2^−shift`.
pub struct QuantisedMatrix {
    /// Per row, its shift in [1, 48].
    pub shifts: Vec<u8>,
    /// Rows × columns entries, row-major.
    pub entries: Vec<i16>,
    /// Largest |quantised − exact| entry error relative to its row's largest entry.
    pub max_relative_rounding: f64,
}

/// Quantise each row of `m` with the finest shift that holds it in `i16`, then fix the rounding
/// so the row sums to exactly `2^shift` (row `unit_row`, the β₀ row) or 0 (every other row):
/// what exact translation needs, and what the runtime's loader checks.
pub fn quantise_matrix(m: &DMatrix<f64>, unit_row: Option<usize>) -> QuantisedMatrix {
    let (mut shifts, mut entries) = (Vec::new(), Vec::new());
    let mut max_relative_rounding = 0.0f64;
    for (i, row) in m.row_iter().enumerate() {
        let largest = row.iter().fold(0.0f64, |a, x| a.max(x.abs()));
        // Room for the residual fix (at most half a unit per entry) on top of the largest entry.
        let headroom = f64::from(i16::MAX) - row.len() as f64;
        let shift = (1..=48u8)
            .rev()
            .find(|&s| largest * 2f64.powi(i32::from(s)) <= headroom)
            .unwrap_or(1);
        let scale = 2f64.powi(i32::from(shift));
        let mut q: Vec<i64> = row.iter().map(|x| (x * scale).round() as i64).collect();
        let target = if unit_row == Some(i) {
            1i64 << shift
        } else {
            0
        };
        let residual = target - q.iter().sum::<i64>();
        if let Some(big) = (0..q.len()).max_by_key(|&j| q[j].abs()) {
            q[big] += residual;
        }
        for (qj, x) in q.iter().zip(row.iter()) {
            if largest > 0.0 {
                max_relative_rounding =
                    max_relative_rounding.max((*qj as f64 / scale - x).abs() / largest);
            }
            entries.push(i16::try_from(*qj).unwrap_or(if *qj > 0 { i16::MAX } else { i16::MIN }));
        }
        shifts.push(shift);
    }
    QuantisedMatrix {
        shifts,
        entries,
        max_relative_rounding,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keeps_the_largest_and_sums_to_one() {
        let dense = [0.5, -0.3, 0.05, 0.6, 0.1, 0.05];
        for refit in [Refit::Uniform, Refit::Prior, Refit::Shrink] {
            let pts: Vec<[f64; 3]> = (0..6).map(|i| [i as f64, 0.0, 0.0]).collect();
            let cov = prior_covariance(&pts, 2.0);
            let row = sparsify_row(&dense, 3, refit, Some(&cov));
            let idx: Vec<usize> = row.iter().map(|r| r.0).collect();
            assert_eq!(idx, vec![0, 1, 3]);
            let sum: f64 = row.iter().map(|r| r.1).sum();
            assert!((sum - 1.0).abs() < 1e-12, "{refit:?}");
        }
        let row = sparsify_row(&dense, 3, Refit::Uniform, None);
        assert!((row[0].1 - (0.5 + 0.2 / 3.0)).abs() < 1e-12);
        // Shrink: 0.5, −0.3, 0.6 less 0.1 each in magnitude: 0.4, −0.2, 0.5, summing to 0.7.
        let row = sparsify_row(&dense, 3, Refit::Shrink, None);
        let want = [(0, 0.4 / 0.7), (1, -0.2 / 0.7), (3, 0.5 / 0.7)];
        for (got, want) in row.iter().zip(want) {
            assert_eq!(got.0, want.0);
            assert!((got.1 - want.1).abs() < 1e-12, "{row:?}");
        }
    }

    #[test]
    fn shrunk_weights_are_continuous_where_the_kept_set_changes() {
        // Markers 2 and 3 swap ranks as t crosses 0.25: the refits jump, the shrink does not.
        let row_at = |t: f64, refit: Refit| {
            let dense = [0.5, 0.3, 0.1 + 0.05 * t, 0.125 - 0.05 * t, -0.025];
            let pts: Vec<[f64; 3]> = (0..5).map(|i| [i as f64, 0.0, 0.0]).collect();
            let cov = prior_covariance(&pts, 2.0);
            let mut full = [0.0; 5];
            for (i, w) in sparsify_row(&dense, 3, refit, Some(&cov)) {
                full[i] = w;
            }
            full
        };
        let jump = |refit| {
            let (a, b) = (row_at(0.25 - 1e-9, refit), row_at(0.25 + 1e-9, refit));
            a.iter()
                .zip(b)
                .map(|(x, y)| (x - y).abs())
                .fold(0.0, f64::max)
        };
        assert!(jump(Refit::Shrink) < 1e-6, "{}", jump(Refit::Shrink));
        assert!(jump(Refit::Prior) > 0.01, "{}", jump(Refit::Prior));
        assert!(jump(Refit::Uniform) > 0.01, "{}", jump(Refit::Uniform));
    }

    #[test]
    fn giving_way_goes_from_k_to_k_less_the_ranks_with_k_pairs() {
        let dense = [0.4, 0.25, 0.15, 0.1, 0.06, 0.04];
        let full = |row: SparseRow| {
            let mut out = [0.0; 6];
            for (i, w) in row {
                out[i] = w;
            }
            out
        };
        let at = |a: f64| sparsify_row_giving_way(&dense, 4, 2, a, Refit::Shrink, None);
        // Nothing given: the shrink of K = 4. All given: the shrink of K − 2, padded with zeros.
        assert_eq!(at(0.0), sparsify_row(&dense, 4, Refit::Shrink, None));
        let given = full(at(1.0));
        let fewer = full(sparsify_row(&dense, 2, Refit::Shrink, None));
        assert!(given.iter().zip(&fewer).all(|(a, b)| (a - b).abs() < 1e-12));
        // Always K pairs (the uniform count), summing to one, moving smoothly in between.
        let mut last = full(at(0.0));
        for step in 1..=100 {
            let row = at(f64::from(step) / 100.0);
            assert_eq!(row.len(), 4);
            assert!((row.iter().map(|p| p.1).sum::<f64>() - 1.0).abs() < 1e-12);
            let now = full(row);
            let moved = now.iter().zip(&last).map(|(a, b)| (a - b).abs());
            assert!(moved.fold(0.0, f64::max) < 0.01);
            last = now;
        }
        // Other re-fits keep K as they were.
        let prior = sparsify_row(&dense, 4, Refit::Uniform, None);
        assert_eq!(
            sparsify_row_giving_way(&dense, 4, 2, 0.5, Refit::Uniform, None),
            prior
        );
    }

    #[test]
    fn quantised_rows_sum_exactly() {
        let rows = vec![
            vec![(0, 0.3333333), (1, 0.3333333), (2, 0.3333334)],
            vec![(4, 2.5), (5, -1.5)],
        ];
        let q = quantise(&rows, QuantiseFor::KernelValues).unwrap();
        assert_eq!(
            q.frac_bits, 21,
            "2.5 · 2^22 exceeds the 24-bit range, so one fewer fractional bit"
        );
        let q = quantise(&rows, QuantiseFor::LinearWeights).unwrap();
        assert_eq!(
            q.frac_bits, 12,
            "Σ|w| + 2 = 6 for the second row: 6 · 2^12 ≤ 32767 < 6 · 2^13"
        );
        for row in &q.words {
            let sum: i64 = row
                .iter()
                .map(|&w| i64::from(facebake_runtime::fixed::unpack_influence(w).1))
                .sum();
            assert_eq!(sum, 1 << q.frac_bits);
        }
        for row in &q.words {
            let abs_sum: i32 = row
                .iter()
                .map(|&w| facebake_runtime::fixed::unpack_influence(w).1.abs())
                .sum();
            assert!(abs_sum <= LINEAR_WEIGHT_ABS_SUM_MAX);
        }
        assert!(q.max_rounding < 2.0 / f64::from(1u32 << 12));
        assert!(matches!(
            quantise(&[vec![(0, 1e6)]], QuantiseFor::LinearWeights),
            Err(SparsifyError::WeightTooLarge { .. })
        ));
    }
}
