//! Retargeting in fixed point: the baked RBF map from the actor's (compensated) marker space to
//! the character's rig space (paper 000 §5.1, eqs 13–16),
//!
//! `f(a) = Σᵢ α̃ᵢ · rᵢ / √(‖a − uᵢ‖² + rᵢ²) + L a + b`,
//!
//! an inverse multiquadric per actor neutral marker uᵢ with its radius rᵢ (the distance to the
//! nearest other marker), written with the normalised kernel φ̃ᵢ = rᵢ/√(·) ∈ (0, 1] so that its
//! coefficients α̃ᵢ = αᵢ / rᵢ share one scale.
//!
//! # Formats and bounds
//!
//! | quantity | format | bound |
//! |---|---|---|
//! | a, uᵢ | Q8.24 actor units | \|a\| ≤ 2³⁰ (input limit), \|uᵢ\| ≤ 2²⁶ and 0 < rᵢ ≤ 2²⁶ (loader) |
//! | ‖a − uᵢ‖² + rᵢ² | `u64`, Q16.48 | below 3 · 2⁶² + 2⁵² < 2⁶⁴ |
//! | φ̃ᵢ | Q0.30 from [`crate::sqrt::rsqrt_u64`] | ≤ 2³⁰ (+ rounding) |
//! | α̃ᵢ | `i32`, scale 2^−`alpha_shift` | \|q\| < 2²³ (loader): 256 terms stay below 2⁶¹ |
//! | L | `i32`, scale 2^−`linear_shift` | any `i32`: three products with \|a\| ≤ 2³⁰ stay below 2⁶³ |
//! | b, f(a) | Q8.24 character rig units | saturated at the `i32` range |

use super::{PerMarker, Retarget};
use crate::fixed::round_shift_sat;
use crate::format::read_position;
use crate::sqrt::rsqrt_u64;

/// Bytes per stored radius (`i32` LE).
pub const RADIUS_BYTES: usize = 4;
/// Bytes per centre's stored coefficients (3 × `i32` LE).
pub const ALPHA_BYTES: usize = 12;

/// The normalised kernel φ̃ = r / √(d² + r²) in Q0.30, for a squared distance `d2` (Q16.48) and
/// a radius `r` (Q8.24, positive).
pub fn normalised_imq(d2: u64, r: i32) -> i64 {
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

/// f(a) for one compensated actor marker `a`, over the `neutral` centres (12 bytes each).
pub fn map(map: &Retarget<'_>, neutral: &[u8], a: [i32; 3]) -> [i32; 3] {
    let mut acc = [0i64; 3];
    for ((u, r), alpha) in neutral
        .chunks_exact(12)
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
        let r = i32::from_le_bytes([r[0], r[1], r[2], r[3]]);
        let phi = normalised_imq(d2, r);
        let alpha = read_position(alpha);
        for c in 0..3 {
            acc[c] += i64::from(alpha[c]) * phi;
        }
    }
    let kernel_shift = u32::from(map.alpha_shift) + 30 - crate::fixed::POS_FRAC_BITS;
    [0, 1, 2].map(|row| {
        let kernel = i64::from(round_shift_sat(acc[row], kernel_shift));
        let linear: i64 = (0..3)
            .map(|c| i64::from(map.linear[3 * row + c]) * i64::from(a[c]))
            .sum();
        let linear = i64::from(round_shift_sat(linear, u32::from(map.linear_shift)));
        (kernel + linear + i64::from(map.offset[row]))
            .clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32
    })
}

/// Proportional retargeting of marker `j`: `v_j + M_j d` for its compensated displacement `d`
/// (actor units, |d| ≤ 2³⁰ by the plausibility bound), saturated to the `i32` range. Three
/// products of two `i32` per row stay below 2⁶³. The loader checked the sections' lengths.
pub fn per_marker(p: &PerMarker<'_>, j: usize, d: [i32; 3]) -> [i32; 3] {
    let (Some(m), Some(v)) = (
        p.matrices.0.get(36 * j..36 * j + 36),
        p.rest.0.get(12 * j..12 * j + 12),
    ) else {
        return [0; 3];
    };
    let v = read_position(v);
    [0, 1, 2].map(|row| {
        let acc: i64 = (0..3)
            .map(|c| {
                let at = 4 * (3 * row + c);
                let q = i32::from_le_bytes([m[at], m[at + 1], m[at + 2], m[at + 3]]);
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
