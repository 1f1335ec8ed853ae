//! Retargeting in fixed point: how compensated actor markers become character markers
//! ([`Retarget`]), one of
//!
//! * **rbf** ([`RbfRetarget`]): the baked RBF map from the actor's (compensated) marker space to
//!   the character's rig space (paper 000 §5.1, eqs 13–16), below;
//! * **proportional** ([`ProportionalRetarget`]): a fixed 3 × 3 matrix per marker.
//!
//! # The RBF map
//!
//!
//! `f(a) = Σᵢ α̃ᵢ · rᵢ / √(‖a − uᵢ‖² + rᵢ²) + L a + b`,
//!
//! an inverse multiquadric per actor neutral marker uᵢ with its radius rᵢ (the distance to the
//! nearest other marker), written with the normalised radial function φ̃ᵢ = rᵢ/√(·) ∈ (0, 1] so that its
//! coefficients α̃ᵢ = αᵢ / rᵢ share one scale.
//!
//! # Formats and bounds
//!
//! | quantity | format | bound |
//! |---|---|---|
//! | a, uᵢ | Q8.24 actor units | \|a\| ≤ 2³⁰ (input limit), \|uᵢ\| ≤ 2²⁶ and 0 < rᵢ ≤ 2²⁶ (loader) |
//! | ‖a − uᵢ‖² + rᵢ² | `u64`, Q16.48 | below 3 · 2⁶² + 2⁵² < 2⁶⁴ |
//! | φ̃ᵢ | Q0.30 from `sqrt::rsqrt_u64` | ≤ 2³⁰ (+ rounding) |
//! | α̃ᵢ | `i32`, scale 2^−`alpha_shift` | \|q\| < 2²³ (loader): 256 terms stay below 2⁶¹ |
//! | L | `i32`, scale 2^−`linear_shift` | any `i32`: three products with \|a\| ≤ 2³⁰ stay below 2⁶³ |
//! | b, f(a) | Q8.24 character rig units | saturated at the `i32` range |

use serde::{Deserialize, Serialize};

use crate::fixed::{round_shift_sat, POS_FRAC_BITS};
use crate::error::{expect_stages_len, StagesLoadError, StagesSection};
use crate::records::{
    read_i32, read_position, Bytes, ALPHA_BYTES, MATRIX3_BYTES, POSITION_BYTES, RADIUS_BYTES,
};
use crate::sqrt::rsqrt_u64;

/// Largest accepted actor neutral coordinate or retarget radius: 4 actor units in Q8.24.
pub const NEUTRAL_LIMIT: i32 = 1 << 26;
/// Largest accepted retarget coefficient magnitude (24-bit).
pub const ALPHA_LIMIT: i32 = (1 << 23) - 1;
/// Largest accepted `alpha_shift`.
pub const MAX_ALPHA_SHIFT: u8 = 48;
/// Accepted `linear_shift` range (and proportional `shift`).
pub const LINEAR_SHIFTS: core::ops::RangeInclusive<u8> = 1..=40;

/// How compensated actor markers become character markers. The variant order is the blob's
/// encoding: never reorder, only append.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Retarget<'a> {
    /// The RBF map of paper 000 (inverse multiquadric + affine).
    #[serde(borrow)]
    Rbf(RbfRetarget<'a>),
    /// Per-marker linear maps (paper 003 §4's proportional scaling).
    #[serde(borrow)]
    Proportional(ProportionalRetarget<'a>),
}

/// The baked RBF retargeting map (see the module docs for the formula and formats).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct RbfRetarget<'a> {
    /// Per actor neutral marker: its radius rᵢ, `i32` LE, Q8.24 actor units.
    #[serde(borrow)]
    pub radii: Bytes<'a>,
    /// Scale exponent of `alpha`: α̃ = q · 2^−alpha_shift, in character rig units.
    pub alpha_shift: u8,
    /// Per actor neutral marker: α̃ᵢ as 3 × `i32` LE, each below 2²³ in magnitude.
    #[serde(borrow)]
    pub alpha: Bytes<'a>,
    /// Scale exponent of `linear`.
    pub linear_shift: u8,
    /// L, row-major: character rig units per actor unit, q · 2^−linear_shift.
    pub linear: [i32; 9],
    /// b, Q8.24 character rig units.
    pub offset: [i32; 3],
}

/// Proportional retargeting (paper 003 §4, the simple option): each character marker moves from
/// its rest position by a fixed 3 × 3 matrix times its compensated actor displacement,
/// `f_j(a) = v_j + M_j (a − u_j)`. The baker builds `M_j` from per-region scale factors and the
/// rotation between the two faces. 9 multiply-adds per marker.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ProportionalRetarget<'a> {
    /// Scale exponent of `matrices`: entries are `q · 2^−shift`, in [1, 40].
    pub shift: u8,
    /// Per marker, M_j row-major as 9 × `i32` LE: character rig units per actor unit.
    #[serde(borrow)]
    pub matrices: Bytes<'a>,
    /// Per marker, v_j: the character marker's rest position, 3 × `i32` LE, Q8.24 rig units.
    #[serde(borrow)]
    pub rest: Bytes<'a>,
}

impl Retarget<'_> {
    /// Check the section against `markers`: lengths, shifts, radii and coefficient bounds.
    pub(crate) fn validate(&self, markers: usize) -> Result<(), StagesLoadError> {
        match self {
            Self::Rbf(r) => r.validate(markers),
            Self::Proportional(p) => p.validate(markers),
        }
    }

    /// Character marker `j` from its compensated actor displacement `d` (Q8.24 actor units) and
    /// its actor neutral position `u`; `neutral` is the `actor_neutral` section.
    pub(crate) fn map(&self, neutral: &[u8], j: usize, u: [i32; 3], d: [i32; 3]) -> [i32; 3] {
        match self {
            Self::Rbf(r) => map(r, neutral, [0, 1, 2].map(|c| u[c].saturating_add(d[c]))),
            Self::Proportional(p) => per_marker(p, j, d),
        }
    }
}

impl RbfRetarget<'_> {
    fn validate(&self, markers: usize) -> Result<(), StagesLoadError> {
        if self.alpha_shift > MAX_ALPHA_SHIFT || !LINEAR_SHIFTS.contains(&self.linear_shift) {
            return Err(StagesLoadError::BadShift);
        }
        expect_stages_len(StagesSection::Radii, self.radii, markers, RADIUS_BYTES)?;
        expect_stages_len(StagesSection::Alpha, self.alpha, markers, ALPHA_BYTES)?;
        for (marker, radius) in self.radii.0.chunks_exact(RADIUS_BYTES).enumerate() {
            if !(1..=NEUTRAL_LIMIT).contains(&read_i32(radius)) {
                return Err(StagesLoadError::BadRadius { marker });
            }
        }
        for (marker, alpha) in self.alpha.0.chunks_exact(ALPHA_BYTES).enumerate() {
            if read_position(alpha)
                .iter()
                .any(|c| c.unsigned_abs() > ALPHA_LIMIT as u32)
            {
                return Err(StagesLoadError::AlphaOutOfRange { marker });
            }
        }
        Ok(())
    }
}

impl ProportionalRetarget<'_> {
    fn validate(&self, markers: usize) -> Result<(), StagesLoadError> {
        if !LINEAR_SHIFTS.contains(&self.shift) {
            return Err(StagesLoadError::BadShift);
        }
        expect_stages_len(
            StagesSection::Matrices,
            self.matrices,
            markers,
            MATRIX3_BYTES,
        )?;
        expect_stages_len(StagesSection::Rest, self.rest, markers, POSITION_BYTES)
    }
}

/// The normalised radial function φ̃ = r / √(d² + r²) in Q0.30, for a squared distance `d2` (Q16.48) and
/// a radius `r` (Q8.24, positive).
pub(crate) fn normalised_imq(d2: u64, r: i32) -> i64 {
    let r = u64::from(r.unsigned_abs());
    let x = d2.saturating_add(r * r);
    match rsqrt_u64(x) {
        // 1/√x = y · 2^−shift with x in Q.48, so r/√x = r · y · 2^−shift; to Q0.30 shift by
        // shift − 30 ≥ 1. r < 2^27, y ≤ 2^31: the product is below 2^58.
        Some((y, shift)) => {
            let s = shift - 30;
            ((r * u64::from(y) + (1 << (s - 1))) >> s) as i64
        }
        // x = 0 only for r = 0, which the loader rejects.
        None => 0,
    }
}

/// f(a) for one compensated actor marker `a`, over the `neutral` centres ([`POSITION_BYTES`]
/// each).
pub(crate) fn map(map: &RbfRetarget<'_>, neutral: &[u8], a: [i32; 3]) -> [i32; 3] {
    let mut acc = [0i64; 3];
    for ((u, r), alpha) in neutral
        .chunks_exact(POSITION_BYTES)
        .zip(map.radii.0.chunks_exact(RADIUS_BYTES))
        .zip(map.alpha.0.chunks_exact(ALPHA_BYTES))
    {
        let u = read_position(u);
        let d2: u64 = (0..3)
            .map(|c| {
                let d = i64::from(a[c]) - i64::from(u[c]);
                (d * d) as u64
            })
            .sum();
        let r = read_i32(r);
        let phi = normalised_imq(d2, r);
        let alpha = read_position(alpha);
        for c in 0..3 {
            acc[c] += i64::from(alpha[c]) * phi;
        }
    }
    let radial_shift = u32::from(map.alpha_shift) + 30 - POS_FRAC_BITS;
    [0, 1, 2].map(|row| {
        let radial = i64::from(round_shift_sat(acc[row], radial_shift));
        let linear: i64 = (0..3)
            .map(|c| i64::from(map.linear[3 * row + c]) * i64::from(a[c]))
            .sum();
        let linear = i64::from(round_shift_sat(linear, u32::from(map.linear_shift)));
        (radial + linear + i64::from(map.offset[row]))
            .clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32
    })
}

/// Proportional retargeting of marker `j`: `v_j + M_j d` for its compensated displacement `d`
/// (actor units, |d| ≤ 2³⁰ by the plausibility bound), saturated to the `i32` range. Three
/// products of two `i32` per row stay below 2⁶³. The loader checked the sections' lengths.
pub(crate) fn per_marker(p: &ProportionalRetarget<'_>, j: usize, d: [i32; 3]) -> [i32; 3] {
    let (Some(m), Some(v)) = (
        p.matrices.0.get(MATRIX3_BYTES * j..MATRIX3_BYTES * (j + 1)),
        p.rest.0.get(POSITION_BYTES * j..POSITION_BYTES * (j + 1)),
    ) else {
        return [0; 3];
    };
    let v = read_position(v);
    [0, 1, 2].map(|row| {
        let acc: i64 = (0..3)
            .map(|c| {
                let at = 4 * (3 * row + c);
                let q = read_i32(&m[at..at + 4]);
                i64::from(q) * i64::from(d[c])
            })
            .sum();
        (i64::from(round_shift_sat(acc, u32::from(p.shift))) + i64::from(v[row]))
            .clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normalised_imq_matches_f64() {
        let mut s = 0x1234_5678_9ABC_DEF1u64;
        for _ in 0..20_000 {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            let r = 1 + (s as u32 >> 6) as i32; // up to 2^26
            let d2 = (s >> 3) % (3u64 << 60);
            let got = normalised_imq(d2, r) as f64 / f64::from(1 << 30);
            let rf = f64::from(r) / f64::from(1 << 24);
            let want = rf / (d2 as f64 / 2f64.powi(48) + rf * rf).sqrt();
            assert!((got - want).abs() < 4e-9, "d2={d2} r={r}: {got} vs {want}");
        }
        assert_eq!(normalised_imq(0, 1 << 20), 1 << 30);
    }
}
