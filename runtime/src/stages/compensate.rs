//! Head-motion compensation in fixed point: the least-squares rotation and translation carrying
//! the neutral head markers onto the current ones (Horn's quaternion method), so that every
//! marker can be brought back into the neutral head's frame.
//!
//! # Method, and why it is bounded
//!
//! With the centred neutral points pᵢ and current points qᵢ, the cross-covariance
//! S = Σ pᵢ qᵢᵀ gives Horn's symmetric 4 × 4 matrix N; the rotation's quaternion is N's
//! eigenvector of the largest eigenvalue. Shifting N by its Gershgorin bound σ makes every
//! eigenvalue of A = N + σI non-negative, so that eigenvector is A's dominant one, and
//! [`SQUARINGS`] repeated squarings A ← A² (each renormalised by a power of two) raise A to the
//! power 2³²: every other direction shrinks by (λ₂/λ₁)^(2³²). Any column of the result is then
//! the eigenvector up to scale; the one with the largest diagonal entry is taken and normalised
//! (`sqrt::normalize`). No loop depends on the data; the cost is fixed.
//!
//! Formats: positions Q8.24 (actor units), centred coordinates clamped to ±2²⁸ (16 units: a head
//! is at most a few units across), S in `i64` (at most 32 products below 2⁵⁶), N and A
//! renormalised to entries below 2³⁰ (products of four below 2⁶²), the quaternion and the
//! rotation matrix Q1.30.

use crate::fixed::round_shift_sat;
use crate::error::StagesLoadError;
use crate::records::Bytes;
use crate::sqrt::{isqrt_u64, normalize, UNIT_FRAC_BITS};

/// Most head markers a rig may name.
pub const MAX_HEAD_MARKERS: usize = 32;
/// Fewest head markers a rig may name when it names any, and a rigid fit needs: three.
pub const MIN_HEAD_MARKERS: usize = 3;

/// Check the `head_markers` section: `u8` indices below `markers`, strictly ascending; none (no
/// compensation) or 3 to [`MAX_HEAD_MARKERS`].
pub(crate) fn validate(head_markers: Bytes<'_>, markers: usize) -> Result<(), StagesLoadError> {
    let head = head_markers.0;
    let ascending = head.windows(2).all(|w| w[0] < w[1]);
    let in_range = head.iter().all(|&h| usize::from(h) < markers);
    let count_ok = head.is_empty() || (MIN_HEAD_MARKERS..=MAX_HEAD_MARKERS).contains(&head.len());
    if ascending && in_range && count_ok {
        Ok(())
    } else {
        Err(StagesLoadError::BadHeadMarkers)
    }
}

/// Squarings of Horn's shifted matrix: it is raised to the power 2^SQUARINGS. Its two largest
/// eigenvalues are closest for markers nearly on a line; for those the collinearity check
/// still lets through, 12 squarings give the rotation to the inputs' rounding and 8 do not
/// (`nearly_collinear_markers_fit_after_the_squarings`): 16 leave a margin of 2^4 in the
/// exponent. (32 until 2026-12-04: each squaring costs a Cortex-M4 about 250 instructions.)
pub const SQUARINGS: usize = 16;
/// Centred coordinates are clamped to this magnitude (16 actor units in Q8.24) before products.
const CENTRED_LIMIT: i64 = 1 << 28;
/// Output positions are clamped to this magnitude (64 actor units), the input limit.
const POSITION_LIMIT: i64 = 1 << 30;

/// A rigid motion from the neutral head to the current frame: `q = R (p − c_n) + c_q`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RigidFit {
    /// R, row-major, Q1.30.
    pub rotation: [[i32; 3]; 3],
    /// Centroid of the fitted neutral head markers, Q8.24.
    pub neutral_centroid: [i32; 3],
    /// Centroid of the same markers in the current frame, Q8.24.
    pub current_centroid: [i32; 3],
}

impl RigidFit {
    /// No motion.
    pub const IDENTITY: Self = Self {
        rotation: [[1 << 30, 0, 0], [0, 1 << 30, 0], [0, 0, 1 << 30]],
        neutral_centroid: [0; 3],
        current_centroid: [0; 3],
    };

    /// A current-frame point in the neutral head's frame: `Rᵀ (q − c_q) + c_n`, saturated to
    /// ±64 actor units.
    pub fn compensate(&self, q: [i32; 3]) -> [i32; 3] {
        let r = &self.rotation;
        transform(
            |i, j| r[j][i],
            q,
            self.current_centroid,
            self.neutral_centroid,
        )
    }

    /// A neutral-frame point moved with the head: `R (p − c_n) + c_q`, saturated like
    /// [`Self::compensate`].
    pub fn apply(&self, p: [i32; 3]) -> [i32; 3] {
        let r = &self.rotation;
        transform(
            |i, j| r[i][j],
            p,
            self.neutral_centroid,
            self.current_centroid,
        )
    }
}

/// `M (p − from) + to` for a Q1.30 matrix given entry by entry, saturated to ±64 units.
fn transform(
    m: impl Fn(usize, usize) -> i32,
    p: [i32; 3],
    from: [i32; 3],
    to: [i32; 3],
) -> [i32; 3] {
    // Clamped into the i32 range, so each product is one 32 × 32 → 64-bit multiply.
    let d = [0, 1, 2].map(|c| {
        (i64::from(p[c]) - i64::from(from[c])).clamp(-i64::from(i32::MAX), i64::from(i32::MAX))
            as i32
    });
    [0, 1, 2].map(|i| {
        // |d| < 2^31, |m| ≤ 2^30: three products below 2^63.
        let acc: i64 = (0..3).map(|j| i64::from(m(i, j)) * i64::from(d[j])).sum();
        let v = i64::from(round_shift_sat(acc, UNIT_FRAC_BITS)) + i64::from(to[i]);
        v.clamp(-POSITION_LIMIT, POSITION_LIMIT) as i32
    })
}

/// Why no rigid motion could be fitted.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FitFailure {
    /// Fewer than three head markers present.
    TooFew,
    /// The present head markers are (nearly) collinear or coincident, in the neutral frame or
    /// in this one: a rotation about their line is undetermined.
    Collinear,
    /// Fewer than three of the present head markers kept their mutual distances from the
    /// neutral frame (within the rig's `head_tolerance`): the others were swapped, jumped or
    /// ghosts, and no rigid motion can be trusted.
    NotRigid,
}

/// Corresponding head-marker positions: neutral and current, Q8.24, at most
/// [`MAX_HEAD_MARKERS`].
pub(crate) struct HeadPairs {
    neutral: [[i32; 3]; MAX_HEAD_MARKERS],
    current: [[i32; 3]; MAX_HEAD_MARKERS],
    len: usize,
}

impl Default for HeadPairs {
    fn default() -> Self {
        Self::new()
    }
}

impl HeadPairs {
    /// No pairs.
    pub const fn new() -> Self {
        Self {
            neutral: [[0; 3]; MAX_HEAD_MARKERS],
            current: [[0; 3]; MAX_HEAD_MARKERS],
            len: 0,
        }
    }

    /// Add a pair; ignored beyond [`MAX_HEAD_MARKERS`] (the loader caps head markers
    /// there, so it never happens with a loaded rig).
    pub fn push(&mut self, neutral: [i32; 3], current: [i32; 3]) {
        if self.len < MAX_HEAD_MARKERS {
            self.neutral[self.len] = neutral;
            self.current[self.len] = current;
            self.len += 1;
        }
    }

    /// Add a copy of pair `i` (a pair counted twice weighs twice in the fit); ignored like
    /// [`Self::push`].
    pub fn push_copy(&mut self, i: usize) {
        if i < self.len {
            self.push(self.neutral[i], self.current[i]);
        }
    }

    /// Pair `i`'s neutral point.
    pub fn neutral(&self, i: usize) -> [i32; 3] {
        self.neutral[i]
    }

    /// Pair `i`'s current point.
    pub fn current(&self, i: usize) -> [i32; 3] {
        self.current[i]
    }

    /// Move pair `i`'s neutral point by `by` (within ±64 units: the sum stays in range for
    /// neutral points within ±4).
    pub fn shift_neutral(&mut self, i: usize, by: [i32; 3]) {
        if let Some(p) = self.neutral.get_mut(i) {
            *p = [0, 1, 2].map(|c| p[c].saturating_add(by[c]));
        }
    }

    /// Number of pairs.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Keep only the pairs for which `keep(index)` holds, in order.
    pub fn retain(&mut self, mut keep: impl FnMut(usize) -> bool) {
        let mut out = 0;
        for i in 0..self.len {
            if keep(i) {
                self.neutral[out] = self.neutral[i];
                self.current[out] = self.current[i];
                out += 1;
            }
        }
        self.len = out;
    }

    /// The pair whose leaving out gives the fit of the others with the smallest largest
    /// residual, or `None` when no fit of the others is possible. One fit per pair.
    pub fn best_left_out(&self) -> Option<usize> {
        (0..self.len)
            .filter_map(|out| {
                let mut others = HeadPairs::new();
                for i in (0..self.len).filter(|&i| i != out) {
                    others.push(self.neutral[i], self.current[i]);
                }
                let fit = others.fit().ok()?;
                let worst = (0..others.len)
                    .map(|i| others.squared_residual(&fit, i))
                    .max()?;
                Some((worst, out))
            })
            .min()
            .map(|(_, out)| out)
    }

    /// Whether the current points are (nearly) collinear or coincident (see [`Self::fit`]).
    pub fn current_collinear(&self) -> bool {
        let cq = centroid(&self.current[..self.len]);
        collinear(
            self.current[..self.len]
                .iter()
                .map(|&q| centred(q, cq).map(i64::from)),
        )
    }

    /// Which pairs keep the shape of the neutral head: pair `i` is kept unless the distances
    /// from it to more than half of the other pairs changed by more than `tolerance` (Q8.24)
    /// from the neutral frame. A rigid motion keeps every distance, so a swapped, jumped or
    /// ghost head marker breaks most of its own distances and few of anyone else's. Bit `i` of
    /// the result is set for a kept pair. Cost: one comparison of two integer distances per
    /// pair of pairs (at most 32 · 31 / 2).
    pub fn rigid(&self, tolerance: i32) -> u32 {
        let n = self.len;
        let mut broken = [0u8; MAX_HEAD_MARKERS];
        for i in 0..n {
            for k in i + 1..n {
                let dn = distance(self.neutral[i], self.neutral[k]);
                let dc = distance(self.current[i], self.current[k]);
                if (i64::from(dc) - i64::from(dn)).abs() > i64::from(tolerance) {
                    broken[i] += 1;
                    broken[k] += 1;
                }
            }
        }
        (0..n)
            .filter(|&i| 2 * usize::from(broken[i]) < n)
            .fold(0, |mask, i| mask | (1 << i))
    }

    /// Per pair, the squared distance between the fitted neutral point and the current one,
    /// Q16.48 (each coordinate's difference saturated to 2²⁸: below 3 · 2⁵⁶). Compared squared,
    /// residuals need no square root.
    pub fn squared_residual(&self, fit: &RigidFit, i: usize) -> u64 {
        let moved = fit.apply(self.neutral[i]);
        (0..3)
            .map(|c| {
                let d = (i64::from(moved[c]) - i64::from(self.current[i][c]))
                    .clamp(-CENTRED_LIMIT, CENTRED_LIMIT) as i32;
                (i64::from(d) * i64::from(d)) as u64
            })
            .sum()
    }

    /// Whether some pair lies further than `tolerance` (Q8.24, ≥ 0) from `fit`.
    pub fn any_beyond(&self, fit: &RigidFit, tolerance: i32) -> bool {
        let t = u64::from(tolerance.unsigned_abs());
        (0..self.len).any(|i| self.squared_residual(fit, i) > t * t)
    }

    /// Root-mean-square residual over all pairs, Q8.24.
    pub fn rms_residual(&self, fit: &RigidFit) -> i32 {
        if self.len == 0 {
            return 0;
        }
        // Each squared residual is below 3 · 2^56; 32 of them fit a u64.
        let sum: u64 = (0..self.len).map(|i| self.squared_residual(fit, i)).sum();
        isqrt_u64(sum / self.len as u64) as i32
    }

    /// The least-squares rigid motion carrying the neutral points onto the current ones.
    pub fn fit(&self) -> Result<RigidFit, FitFailure> {
        let n = self.len;
        if n < MIN_HEAD_MARKERS {
            return Err(FitFailure::TooFew);
        }
        let cn = centroid(&self.neutral[..n]);
        let cq = centroid(&self.current[..n]);
        // `centred` keeps 32 bits, so each product below is one 32 × 32 → 64-bit multiply-add.
        let wide = |p: [i32; 3]| p.map(i64::from);
        if collinear(self.neutral[..n].iter().map(|&p| wide(centred(p, cn))))
            || collinear(self.current[..n].iter().map(|&q| wide(centred(q, cq))))
        {
            return Err(FitFailure::Collinear);
        }
        let mut s = [[0i64; 3]; 3];
        for (p, q) in self.neutral[..n].iter().zip(&self.current[..n]) {
            let p = centred(*p, cn);
            let q = centred(*q, cq);
            for a in 0..3 {
                for b in 0..3 {
                    // |p q| ≤ 2^56, at most 32 of them.
                    s[a][b] += i64::from(p[a]) * i64::from(q[b]);
                }
            }
        }
        let quaternion = dominant_quaternion(&s).ok_or(FitFailure::Collinear)?;
        Ok(RigidFit {
            rotation: rotation_from(quaternion),
            neutral_centroid: cn,
            current_centroid: cq,
        })
    }
}

/// `p − c`, each coordinate clamped to ±[`CENTRED_LIMIT`] (16 actor units): saturated in 32
/// bits, then clamped, which is the exact difference clamped.
pub(crate) fn centred(p: [i32; 3], c: [i32; 3]) -> [i32; 3] {
    let limit = CENTRED_LIMIT as i32;
    [0, 1, 2].map(|k| p[k].saturating_sub(c[k]).clamp(-limit, limit))
}

/// ⌊‖a − b‖⌋ for positions within the `i32` range: each squared difference is below 2⁶², their
/// sum below 3 · 2⁶² < 2⁶⁴.
fn distance(a: [i32; 3], b: [i32; 3]) -> u32 {
    let sq: u64 = (0..3)
        .map(|c| {
            let d = i64::from(a[c]) - i64::from(b[c]);
            (d * d) as u64
        })
        .sum();
    isqrt_u64(sq)
}

/// Mean of at most 32 points, rounded to nearest.
fn centroid(points: &[[i32; 3]]) -> [i32; 3] {
    let n = points.len().max(1) as i64;
    [0, 1, 2].map(|c| {
        let sum: i64 = points.iter().map(|p| i64::from(p[c])).sum();
        let half = if sum >= 0 { n / 2 } else { -(n / 2) };
        ((sum + half) / n) as i32
    })
}

/// Whether centred points lie within about 3.6° of one line through their centroid: every
/// point's cross product with the farthest point is below 1/16 of that point's squared length.
fn collinear(points: impl Iterator<Item = [i64; 3]> + Clone) -> bool {
    // Coarse coordinates (2^-10 units) keep the products small; a head spans thousands of them.
    // Centred coordinates within ±2^28 give coarse ones within ±2^14: products below 2^28, a
    // cross product's coordinates below 2^29, their squares' sum below 2^60, and so is the
    // farthest point's squared length squared: all in 64 bits.
    let coarse = |p: [i64; 3]| p.map(|c| (c.clamp(-CENTRED_LIMIT, CENTRED_LIMIT) >> 14) as i32);
    let sq = |p: [i32; 3]| p.iter().map(|&c| i64::from(c) * i64::from(c)).sum::<i64>();
    let Some(far) = points.clone().map(coarse).max_by_key(|&p| sq(p)) else {
        return true;
    };
    let far_sq = sq(far) as u64;
    if far_sq == 0 {
        return true;
    }
    let cross = |a: i32, b: i32, c: i32, d: i32| i64::from(a) * i64::from(b) - i64::from(c) * i64::from(d);
    let widest = points
        .map(coarse)
        .map(|p| {
            let x = [
                cross(far[1], p[2], far[2], p[1]),
                cross(far[2], p[0], far[0], p[2]),
                cross(far[0], p[1], far[1], p[0]),
            ];
            x.iter().map(|c| c * c).sum::<i64>() as u64
        })
        .max()
        .unwrap_or(0);
    // widest · 256 < far_sq², without the 2^68 product: widest < ⌈far_sq² / 256⌉.
    widest < (far_sq * far_sq).div_ceil(256)
}

/// Horn's quaternion (w, x, y, z) of the rotation maximising Σ qᵢ · R pᵢ, Q1.30, w ≥ 0.
pub(crate) fn dominant_quaternion(s: &[[i64; 3]; 3]) -> Option<[i32; 4]> {
    // Bring S to entries below 2^28 so N's sums of three stay below 2^30.
    let s = renormalise(s, 28)?;
    let [[sxx, sxy, sxz], [syx, syy, syz], [szx, szy, szz]] = s;
    let n = [
        [sxx + syy + szz, syz - szy, szx - sxz, sxy - syx],
        [syz - szy, sxx - syy - szz, sxy + syx, szx + sxz],
        [szx - sxz, sxy + syx, -sxx + syy - szz, syz + szy],
        [sxy - syx, szx + sxz, syz + szy, -sxx - syy + szz],
    ];
    // Gershgorin: every eigenvalue is at least −max_i Σ_j |N_ij|.
    let sigma = n
        .iter()
        .map(|row| row.iter().map(|v| v.abs()).sum::<i64>())
        .max()
        .unwrap_or(0);
    let mut a = n;
    for (i, row) in a.iter_mut().enumerate() {
        row[i] += sigma;
    }
    let a = renormalise(&a, 30)?;
    // A is symmetric (N is, σ is on the diagonal, the shifts are common), and so is every
    // power: only its ten upper entries are kept, row by row.
    let mut u = UPPER.map(|(i, j)| a[i][j] as i32);
    for _ in 0..SQUARINGS {
        // Entries below 2^30 after renormalising: each product is a 32 × 32 → 64-bit multiply
        // (one SMULL or SMLAL on a 32-bit core instead of a 64 × 64 multiply), and the sums
        // of four below 2^62. The same integers as squaring all sixteen and renormalising
        // them: the largest magnitude is among the ten. Written out entry by entry, so every
        // index is a constant.
        let m = [
            [u[0], u[1], u[2], u[3]],
            [u[1], u[4], u[5], u[6]],
            [u[2], u[5], u[7], u[8]],
            [u[3], u[6], u[8], u[9]],
        ];
        let dot = |i: usize, j: usize| -> i64 {
            i64::from(m[i][0]) * i64::from(m[0][j])
                + i64::from(m[i][1]) * i64::from(m[1][j])
                + i64::from(m[i][2]) * i64::from(m[2][j])
                + i64::from(m[i][3]) * i64::from(m[3][j])
        };
        let sq = [
            dot(0, 0),
            dot(0, 1),
            dot(0, 2),
            dot(0, 3),
            dot(1, 1),
            dot(1, 2),
            dot(1, 3),
            dot(2, 2),
            dot(2, 3),
            dot(3, 3),
        ];
        // The square of a symmetric matrix is positive semi-definite, so its largest magnitude
        // is on its diagonal (|bᵢⱼ| ≤ √(bᵢᵢ bⱼⱼ)): the same shift as over all ten. Its
        // largest entry is at least 2^58 (the square of A's, 2^29 or more, is a term of it)
        // and below 2^62, so the shift is 29 to 32, done in 32-bit words.
        let largest = [sq[0], sq[4], sq[7], sq[9]]
            .iter()
            .map(|v| v.unsigned_abs())
            .max()
            .unwrap_or(0);
        let shift = shift_for(largest, 30)?;
        u = if (29..=32).contains(&shift) {
            let s = shift as u32;
            sq.map(|v| ((v >> 32) as i32) << (32 - s) | ((v as u32 >> 29) >> (s - 29)) as i32)
        } else {
            sq.map(|v| apply_shift(v, shift) as i32)
        };
    }
    let a: [[i64; 4]; 4] =
        core::array::from_fn(|i| core::array::from_fn(|j| i64::from(u[UPPER_AT[i][j]])));
    let col = (0..4).max_by_key(|&j| a[j][j]).unwrap_or(0);
    let mut q = normalize([a[0][col], a[1][col], a[2][col], a[3][col]])?;
    if q[0] < 0 {
        q = q.map(|c| -c);
    }
    Some(q)
}

/// The upper triangle of a symmetric 4 × 4 matrix, row by row: (row, column) of each kept entry.
const UPPER: [(usize, usize); 10] = [
    (0, 0),
    (0, 1),
    (0, 2),
    (0, 3),
    (1, 1),
    (1, 2),
    (1, 3),
    (2, 2),
    (2, 3),
    (3, 3),
];

/// Where entry (row, column) of a symmetric 4 × 4 matrix is kept in [`UPPER`].
const UPPER_AT: [[usize; 4]; 4] = [[0, 1, 2, 3], [1, 4, 5, 6], [2, 5, 7, 8], [3, 6, 8, 9]];

/// Shift so the largest magnitude has its top bit at `bits − 1` (exact for left shifts, floor
/// for right shifts); `None` for an all-zero matrix.
fn shift_for(largest: u64, bits: i32) -> Option<i32> {
    if largest == 0 {
        return None;
    }
    Some((64 - largest.leading_zeros() as i32) - bits)
}

fn apply_shift(v: i64, shift: i32) -> i64 {
    if shift >= 0 {
        v >> shift
    } else {
        v << -shift
    }
}

/// Shift every entry so the largest has its top bit at `bits − 1`; `None` for all zeros.
fn renormalise<const N: usize>(m: &[[i64; N]; N], bits: i32) -> Option<[[i64; N]; N]> {
    let largest = m
        .iter()
        .flatten()
        .map(|v| v.unsigned_abs())
        .max()
        .unwrap_or(0);
    let shift = shift_for(largest, bits)?;
    Some(m.map(|row| row.map(|v| apply_shift(v, shift))))
}

/// The rotation matrix of a unit quaternion (w, x, y, z), both Q1.30.
pub(crate) fn rotation_from(q: [i32; 4]) -> [[i32; 3]; 3] {
    let [w, x, y, z] = q.map(i64::from);
    // Products are Q2.60 below 2^60; sums of four below 2^62.
    let r = |acc: i64| round_shift_sat(acc, UNIT_FRAC_BITS);
    [
        [
            r(w * w + x * x - y * y - z * z),
            r(2 * (x * y - w * z)),
            r(2 * (x * z + w * y)),
        ],
        [
            r(2 * (x * y + w * z)),
            r(w * w - x * x + y * y - z * z),
            r(2 * (y * z - w * x)),
        ],
        [
            r(2 * (x * z - w * y)),
            r(2 * (y * z + w * x)),
            r(w * w - x * x - y * y + z * z),
        ],
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The rotation of the quaternion (w, x, y, z), normalised here. No trigonometry: glibc's
    /// sin/cos use an instruction qemu-ppc does not emulate, and this test runs there too.
    fn rot(q: [f64; 4]) -> [[f64; 3]; 3] {
        let n = q.iter().map(|c| c * c).sum::<f64>().sqrt();
        let [w, x, y, z] = q.map(|c| c / n);
        [
            [
                w * w + x * x - y * y - z * z,
                2.0 * (x * y - w * z),
                2.0 * (x * z + w * y),
            ],
            [
                2.0 * (x * y + w * z),
                w * w - x * x + y * y - z * z,
                2.0 * (y * z - w * x),
            ],
            [
                2.0 * (x * z - w * y),
                2.0 * (y * z + w * x),
                w * w - x * x - y * y + z * z,
            ],
        ]
    }

    fn q824(v: f64) -> i32 {
        (v * f64::from(1 << 24)).round() as i32
    }

    /// Known rotations (up to 166°) and translations are recovered to a few LSB of Q1.30.
    #[test]
    fn recovers_known_rigid_motions() {
        let head = [
            [0.10, 0.90, 0.30],
            [0.45, 0.80, 0.20],
            [-0.35, 0.85, 0.25],
            [0.00, 0.55, 0.50],
            [0.30, 0.50, 0.40],
        ];
        let cases = [
            ([1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0]),
            ([0.99, 0.0, 0.15, 0.0], [0.5, -0.2, 1.0]),
            ([0.85, -0.45, -0.09, 0.18], [-3.0, 2.0, 0.1]),
            ([0.12, 0.3, -0.8, 0.5], [10.0, 0.0, -7.5]),
            ([1.0, 0.0, 0.0, 5e-5], [0.0, 1e-5, 0.0]),
        ];
        for (quaternion, t) in cases {
            let r = rot(quaternion);
            let mut pairs = HeadPairs::new();
            for p in head {
                let q = [0, 1, 2].map(|i| (0..3).map(|j| r[i][j] * p[j]).sum::<f64>() + t[i]);
                pairs.push(p.map(q824), q.map(q824));
            }
            let fit = pairs.fit().expect("five spread markers fit");
            for (i, (row, got_row)) in r.iter().zip(&fit.rotation).enumerate() {
                for (j, (want, got)) in row.iter().zip(got_row).enumerate() {
                    let want = want * f64::from(1 << 30);
                    let got = f64::from(*got);
                    // The inputs are rounded to 2^-24, which alone moves R by ~2^-23.
                    assert!(
                        (got - want).abs() < 2f64.powi(9),
                        "{quaternion:?}: R[{i}][{j}]"
                    );
                }
            }
            // Every marker maps back to its neutral position within a few LSB of Q8.24.
            for k in 0..pairs.len() {
                let back = fit.compensate(pairs.current[k]);
                for c in 0..3 {
                    assert!((back[c] - pairs.neutral[k][c]).abs() <= 4, "{back:?}");
                }
            }
            assert!(pairs.rms_residual(&fit) <= 4);
        }
    }

    /// Horn's matrix converges slowest when the markers are nearly collinear (its two largest
    /// eigenvalues close): markers barely wide enough to pass the collinearity check (one
    /// 1/11 of the longest arm off the line; 1/16 is refused) still give the rotation to the
    /// inputs' own rounding after [`SQUARINGS`] (12 were enough, 8 were not).
    #[test]
    fn nearly_collinear_markers_fit_after_the_squarings() {
        let head = [
            [-0.5, 0.0, 0.0],
            [0.5, 0.0, 0.0],
            [0.0, 0.05, 0.0],
            [0.25, -0.01, 0.004],
        ];
        for quaternion in [
            [0.99, 0.0, 0.15, 0.0],
            [0.85, -0.45, -0.09, 0.18],
            [0.12, 0.3, -0.8, 0.5],
            [0.97, 0.2, 0.0, 0.1],
        ] {
            let r = rot(quaternion);
            let mut pairs = HeadPairs::new();
            for p in head {
                let q = [0, 1, 2].map(|i| (0..3).map(|j| r[i][j] * p[j]).sum::<f64>());
                pairs.push(p.map(q824), q.map(q824));
            }
            let fit = pairs.fit().expect("not collinear");
            for (row, got_row) in r.iter().zip(&fit.rotation) {
                for (want, got) in row.iter().zip(got_row) {
                    // 2^-24 of rounding over a 0.035 arm: about 2^-19 of R.
                    let err = (f64::from(*got) - want * f64::from(1 << 30)).abs();
                    assert!(err < 2f64.powi(13), "{quaternion:?}: {err}");
                }
            }
        }
    }

    #[test]
    fn too_few_or_collinear_head_markers_are_reported() {
        let mut pairs = HeadPairs::new();
        pairs.push([0; 3], [0; 3]);
        pairs.push([1 << 24, 0, 0], [1 << 24, 0, 0]);
        assert_eq!(pairs.fit(), Err(FitFailure::TooFew));
        pairs.push([2 << 24, 1, 0], [2 << 24, 0, 0]);
        assert_eq!(pairs.fit(), Err(FitFailure::Collinear));
        pairs.push([0, 1 << 24, 0], [0, 1 << 24, 0]);
        assert!(pairs.fit().is_ok());
    }

    /// Spread neutral markers whose current positions lie on one line (or on one point) are
    /// refused: the neutral check alone let them through.
    #[test]
    fn collinear_or_coincident_current_markers_are_reported() {
        let neutral = [[0, 0, 0], [1 << 24, 0, 0], [0, 1 << 24, 0], [0, 0, 1 << 24]];
        for current in [
            [[0, 0, 0], [1 << 24, 0, 0], [2 << 24, 0, 0], [3 << 24, 1, 0]],
            [[5 << 20, 0, 0]; 4],
        ] {
            let mut pairs = HeadPairs::new();
            for (p, q) in neutral.iter().zip(&current) {
                pairs.push(*p, *q);
            }
            assert!(pairs.current_collinear());
            assert_eq!(pairs.fit(), Err(FitFailure::Collinear));
        }
    }

    /// A head marker moved off the rigid shape is the only one the distance check drops, for
    /// four markers and for three; under a rigid motion every marker is kept.
    #[test]
    fn the_distance_check_drops_the_marker_that_broke_the_shape() {
        let neutral = [
            [0, 0, 0],
            [1 << 24, 0, 0],
            [0, 1 << 24, 0],
            [0, 0, 1 << 24],
        ];
        let tolerance = 1 << 20;
        for n in [3, 4] {
            for moved in 0..n {
                let mut pairs = HeadPairs::new();
                for (i, p) in neutral.iter().enumerate().take(n) {
                    // Turned 90° about z and shifted; marker `moved` also jumps 0.5 units.
                    let mut q = [-p[1] + (3 << 24), p[0], p[2] - (1 << 23)];
                    if i == moved {
                        q[2] += 8 << 20;
                    }
                    pairs.push(*p, q);
                }
                assert_eq!(pairs.rigid(tolerance), ((1 << n) - 1) & !(1 << moved), "{n} {moved}");
            }
        }
        let mut pairs = HeadPairs::new();
        for p in neutral {
            pairs.push(p, [p[2], p[0], p[1]]);
        }
        assert_eq!(pairs.rigid(tolerance), 0b1111);
    }

    #[test]
    fn identity_compensation_is_exact() {
        let p = [123_456, -7_654_321, 1 << 29];
        assert_eq!(RigidFit::IDENTITY.compensate(p), p);
        assert_eq!(RigidFit::IDENTITY.apply(p), p);
    }
}
