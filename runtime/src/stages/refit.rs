//! Step 2's last part: the head fit done again over the face.
//!
//! The head markers are skin over the skull: a brow raise lifts the forehead's, and a fit from
//! them alone reads it as the head pitching back and takes that out of every marker
//! (ICT-FaceKit's surprise: the chin 3 mm off). A fit from a few markers also passes their
//! jitter, magnified by the lever arm, to the whole face. The rest of the face mostly holds
//! still in the head's frame, so once the head markers' fit is known it is done again over
//! every marker, each weighted by how still it was ([`Biweight`], Tukey's biweight, of its
//! displacement in the last frame and half its motion since, together): what moved on its own
//! (a jaw, a smile, a brow, a jump) weighs little or nothing, and the still markers pull the
//! head back and average their jitter. The weights are smooth, so a marker that drops out or
//! comes back moves the fit only by what it pulled, never by a switch; the head markers keep at
//! least [`HEAD_WEIGHT_FLOOR`], so the fit never rests on the face alone. The stages call it
//! from `Stages::refit` (in the stages' module, with the other head-fit steps); this module
//! holds the weight and the weighted fit.

use crate::stages::compensate::{
    centred, dominant_quaternion, rotation_from, RigidFit, MAX_HEAD_MARKERS,
};

/// Most face markers (not head markers) the refit pairs: the first ones in marker order,
/// whether present or not, so the set does not change with dropouts.
pub const REFIT_MARKERS: usize = 64;

/// Bits of a pair's weight: `1 << WEIGHT_BITS` is a marker that held still. Sixteen: the
/// refit must match its f64 reference to 2e-7, and a unit of a 12-bit weight on a marker near
/// the cutoff moved the fit 1e-6.
pub const WEIGHT_BITS: u32 = 16;

/// The weight of a marker that held still.
pub const FULL_WEIGHT: u32 = 1 << WEIGHT_BITS;

/// The least weight of a head marker: a quarter of a still marker's, so that a brow raise
/// (the forehead's head markers off their places) barely moves the fit of thirty still
/// markers, and a face that moves everywhere still has the head markers' fit to rest on.
pub const HEAD_WEIGHT_FLOOR: u32 = FULL_WEIGHT / 4;

/// Smallest refit cutoff a rig may carry, Q8.24 actor units: the weights are computed from
/// displacements at 2⁻¹⁶ units, and the cutoff must span some of them.
pub const MIN_REFIT_CUTOFF: i32 = 1 << 12;

/// Largest refit cutoff a rig may carry: one actor unit (the actor's half extent), Q8.24.
pub const MAX_REFIT_CUTOFF: i32 = 1 << 24;

/// Tukey's biweight with a cutoff: the weight (1 − |d|²/cut²)² of a displacement `d`, 0 from
/// the cutoff on, in [`WEIGHT_BITS`] bits. Built once per frame (one 64-bit division); each
/// weight is then three squares, a multiplication by the reciprocal and a square, exact to
/// about one unit of the weight: d² (below 2⁵⁰ once every |dᵢ| is below the cutoff, ≤ 2²⁴)
/// and cut² are taken at 2⁻⁸ of their units (cut² at least 2¹⁶ of them), and their ratio
/// Q0.24.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Biweight {
    /// The cutoff, Q8.24 actor units.
    pub(crate) cut: u32,
    /// cut² >> 8, in [2¹⁶, 2⁴⁰].
    cut2: u64,
    /// ⌊2⁶² / cut2⌋, in [2²², 2⁴⁶].
    reciprocal: u64,
}

impl Biweight {
    /// The biweight with cutoff `cut`, Q8.24 actor units, clamped to [[`MIN_REFIT_CUTOFF`],
    /// [`MAX_REFIT_CUTOFF`]].
    pub fn new(cut: i32) -> Self {
        let cut = cut.clamp(MIN_REFIT_CUTOFF, MAX_REFIT_CUTOFF).unsigned_abs();
        let cut2 = (u64::from(cut) * u64::from(cut)) >> 8;
        Self {
            cut,
            cut2,
            reciprocal: (1u64 << 62) / cut2,
        }
    }

    /// The weight of a marker displaced by `d` and moved by `moved` since (Q8.24 actor units),
    /// of the length of the two together, √(|d|² + |moved|²): [`FULL_WEIGHT`] at 0, falling
    /// smoothly to 0 at the cutoff.
    pub fn weight(&self, d: [i32; 3], moved: [i32; 3]) -> u32 {
        let both = [d[0], d[1], d[2], moved[0], moved[1], moved[2]];
        if both.iter().any(|&c| c.unsigned_abs() >= self.cut) {
            return 0;
        }
        // Each |cᵢ| < 2^24: the squares sum below 6 · 2^48.
        let r2 = both
            .iter()
            .map(|&c| (i64::from(c) * i64::from(c)) as u64)
            .sum::<u64>()
            >> 8;
        if r2 >= self.cut2 {
            return 0;
        }
        // r2 < cut2: the product is below 2^62, and t (Q0.24) at most 2^24.
        let t = ((r2 * self.reciprocal) >> 38).min(1 << 24);
        let v = (1u64 << 24) - t;
        // v ≤ 2^24: v² ≤ 2^48, shifted to [0, 2^16].
        ((v * v) >> (48 - WEIGHT_BITS)) as u32
    }
}

/// Pairs of the refit: a neutral point, the current one and a weight, at most the head markers
/// and [`REFIT_MARKERS`].
pub(crate) struct WeightedPairs {
    neutral: [[i32; 3]; PAIRS],
    current: [[i32; 3]; PAIRS],
    weight: [u32; PAIRS],
    len: usize,
}

/// Capacity of [`WeightedPairs`].
const PAIRS: usize = MAX_HEAD_MARKERS + REFIT_MARKERS;

impl WeightedPairs {
    /// No pairs.
    pub const fn new() -> Self {
        Self {
            neutral: [[0; 3]; PAIRS],
            current: [[0; 3]; PAIRS],
            weight: [0; PAIRS],
            len: 0,
        }
    }

    /// Add a pair of weight `weight` (at most [`FULL_WEIGHT`]); a pair of weight 0, or one
    /// beyond the capacity, is ignored.
    pub fn push(&mut self, neutral: [i32; 3], current: [i32; 3], weight: u32) {
        if weight > 0 && self.len < PAIRS {
            self.neutral[self.len] = neutral;
            self.current[self.len] = current;
            self.weight[self.len] = weight.min(FULL_WEIGHT);
            self.len += 1;
        }
    }

    /// The weighted least-squares rigid motion carrying the neutral points onto the current
    /// ones (Horn's method, as [`crate::stages::compensate`]'s fit): centroids weighted, and
    /// the cross-covariance Σ (wᵢ pᵢ) qᵢᵀ of the centred points, wᵢ pᵢ taken to the nearest
    /// unit below of Q8.24 (|wᵢ pᵢ| ≤ |pᵢ| ≤ 2²⁸, an `i32`, so each product is one 32 × 32 →
    /// 64-bit multiply-add; 96 of them below 2⁶³). `None` when Horn's
    /// matrix vanishes. The caller ensures the points are not collinear (the head markers',
    /// checked by the head fit, are among them).
    pub fn fit(&self) -> Option<RigidFit> {
        let n = self.len;
        // Weights are at most 2^16: `i32`s.
        let total: i64 = self.weight[..n].iter().map(|&w| i64::from(w)).sum();
        if total == 0 {
            return None;
        }
        let centroid = |points: &[[i32; 3]]| {
            [0, 1, 2].map(|c| {
                // |p| < 2^31, w ≤ 2^16: each term below 2^47, 96 below 2^54.
                let sum: i64 = points[..n]
                    .iter()
                    .zip(&self.weight[..n])
                    .map(|(p, &w)| i64::from(p[c]) * i64::from(w as i32))
                    .sum();
                let half = if sum >= 0 { total / 2 } else { -(total / 2) };
                ((sum + half) / total) as i32
            })
        };
        let (cn, cq) = (centroid(&self.neutral), centroid(&self.current));
        let mut s = [[0i64; 3]; 3];
        for i in 0..n {
            let w = i64::from(self.weight[i] as i32);
            // |p| ≤ 2^28 and w ≤ 2^16: |w p| >> 16 ≤ 2^28.
            let p = centred(self.neutral[i], cn).map(|v| ((i64::from(v) * w) >> WEIGHT_BITS) as i32);
            let q = centred(self.current[i], cq);
            for a in 0..3 {
                for b in 0..3 {
                    // |p q| ≤ 2^56.
                    s[a][b] += i64::from(p[a]) * i64::from(q[b]);
                }
            }
        }
        let quaternion = dominant_quaternion(&s)?;
        Some(RigidFit {
            rotation: rotation_from(quaternion),
            neutral_centroid: cn,
            current_centroid: cq,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_biweight_falls_from_full_to_zero_at_the_cutoff() {
        let cut = 1 << 20;
        let biweight = |d: [i32; 3], cut: i32| Biweight::new(cut).weight(d, [0; 3]);
        assert_eq!(biweight([0; 3], cut), FULL_WEIGHT);
        assert_eq!(biweight([cut, 0, 0], cut), 0);
        assert_eq!(biweight([0, -cut, 0], cut), 0);
        assert_eq!(biweight([i32::MIN, 0, 0], cut), 0);
        // Half the cutoff: (1 − 1/4)² = 9/16.
        assert_eq!(biweight([0, 0, cut / 2], cut), FULL_WEIGHT / 16 * 9);
        // Diagonally past the cutoff, within it on every axis.
        assert_eq!(biweight([cut * 3 / 4, cut * 3 / 4, 0], cut), 0);
        // The displacement and the motion since count together.
        let w = Biweight::new(cut);
        assert_eq!(w.weight([cut / 2, 0, 0], [0, cut / 2, 0]), FULL_WEIGHT / 4);
        assert_eq!(w.weight([0; 3], [0, 0, -cut]), 0);
        let mut last = FULL_WEIGHT;
        for k in 0..=64 {
            let w = biweight([cut / 64 * k, 0, 0], cut);
            assert!(w <= last, "{k}: {w} after {last}");
            last = w;
        }
        assert_eq!(last, 0);
    }

    #[test]
    fn equal_weights_fit_as_the_head_fit_does() {
        use crate::stages::compensate::HeadPairs;
        let neutral = [
            [0, 0, 0],
            [1 << 24, 0, 0],
            [0, 1 << 24, 0],
            [0, 0, 1 << 24],
            [1 << 23, 1 << 23, 0],
        ];
        // A quarter turn about z and a shift.
        let moved = |p: [i32; 3]| [-p[1] + (1 << 20), p[0], p[2] - (3 << 20)];
        let mut head = HeadPairs::new();
        let mut weighted = WeightedPairs::new();
        for p in neutral {
            head.push(p, moved(p));
            weighted.push(p, moved(p), FULL_WEIGHT / 2);
        }
        let (a, b) = (head.fit().expect("fits"), weighted.fit().expect("fits"));
        for p in neutral {
            let (x, y) = (a.apply(p), b.apply(p));
            for c in 0..3 {
                assert!((x[c] - y[c]).abs() <= 2, "{x:?} {y:?}");
                assert!((y[c] - moved(p)[c]).abs() <= 2, "{y:?}");
            }
        }
    }

    #[test]
    fn a_pair_without_weight_does_not_pull() {
        let neutral = [[0, 0, 0], [1 << 24, 0, 0], [0, 1 << 24, 0], [0, 0, 1 << 24]];
        let mut pairs = WeightedPairs::new();
        for p in neutral {
            pairs.push(p, p, FULL_WEIGHT);
        }
        pairs.push([1 << 24; 3], [0; 3], 0);
        assert_eq!(pairs.len, 4);
        let fit = pairs.fit().expect("fits");
        for p in neutral {
            assert_eq!(fit.apply(p), p);
        }
        pairs.push([1 << 24; 3], [0; 3], 1);
        assert_ne!(pairs.fit().expect("fits").apply([1 << 24; 3]), [1 << 24; 3]);
    }
}
