//! Fixed-point formats and the primitives the per-frame path is built from.
//!
//! # Formats
//!
//! | quantity | type | format | meaning |
//! |---|---|---|---|
//! | position (markers in, vertices out, marker rest) | `i32` | Q8.24 | rig units: `(p − centre) / half_extent`, so the mesh spans ±1.0 (±2²⁴) with headroom to ±128 |
//! | vertex rest position (stored) | `i16` | Q0.15 | the same rig units at 2⁻¹⁵ resolution; widened by `<< 9` ([`REST_SHIFT`]) to Q8.24 |
//! | radial value φ (stored) | `i24` in a `u32` | Q(23−F).F, F = `weight_frac_bits` ∈ [8, 22] | chosen by the baker as the finest F that holds the largest value |
//! | linear weight (stored) | `i24` in a `u32`, Σ\|w\| ≤ [`LINEAR_WEIGHT_ABS_SUM_MAX`] per vertex | Q(15−F).F, F ∈ [8, [`LINEAR_MAX_WEIGHT_FRAC_BITS`]] | the finest F whose weights meet the bound |
//! | accumulator | `i64` | Q(39−F).(24+F) | Σ weight × value over at most [`MAX_INFLUENCES`] terms |
//! | unit normal (out, and the stored rest normal) | `i16` | Q1.14 ([`NORMAL_FRAC_BITS`]) | 1.0 is 2¹⁴, each component within ±2¹⁴ |
//! | triangle edge (normals) | `i64` (`i32` on 32-bit targets) | Q8.24 | a difference of two positions, saturated to ±[`NORMAL_EDGE_LIMIT`] per axis |
//! | normal accumulator | `i64` | Q16.48 | Σ of edge × edge cross products over a fan of at most 255 corners (254 products) |
//!
//! # Overflow by design
//!
//! A radial value is below 2²³ in magnitude and a coefficient below 2³¹, so one product is below
//! 2⁵⁴ and a sum of at most 64 products below 2⁶⁰: the `i64` accumulator cannot overflow. The
//! linear deformer's bounds (Σ|w| < 2¹⁵, displacements clamped to
//! [`linear_displacement_limit`]) keep every sum it forms, and its output, inside 32 bits (the
//! proof is in the linear deformer's module docs, `runtime/src/deformer/linear.rs`). The only saturations are at the edges: narrowing a result back to
//! `i32` ([`round_shift_bounded`]) and clamping a displacement. Rounding is "half up" (add ½,
//! arithmetic shift), identical on every platform because it is pure integer arithmetic.

/// Fractional bits of a unit normal (Q1.14: 1.0 is 2¹⁴), as [`crate::Rig::normals`] writes it.
pub const NORMAL_FRAC_BITS: u32 = 14;
/// Largest magnitude of one axis of a triangle edge in the normals' cross products: 2²⁶, four
/// rig units (twice the mesh's whole extent). A longer edge saturates to it, so one cross
/// component is below 2⁵³ and a sum over a fan of at most 255 corners (254 products) below 2⁶¹: the `i64`
/// accumulator cannot overflow, whatever the positions.
pub const NORMAL_EDGE_LIMIT: i64 = 1 << 26;
/// Fractional bits of a position (Q8.24).
pub const POS_FRAC_BITS: u32 = 24;
/// One rig unit (the mesh's half extent) in Q8.24.
pub const POS_ONE: i32 = 1 << POS_FRAC_BITS;
/// Left shift that widens a stored Q0.15 rest coordinate to Q8.24.
pub const REST_SHIFT: u32 = POS_FRAC_BITS - 15;
/// Smallest accepted number of fractional weight bits.
pub const MIN_WEIGHT_FRAC_BITS: u8 = 8;
/// Largest accepted number of fractional weight bits.
pub const MAX_WEIGHT_FRAC_BITS: u8 = 22;
/// Most influences one vertex may have; bounds the accumulator (see the module docs).
pub const MAX_INFLUENCES: u8 = 64;
/// Bits of a packed influence word that hold the marker index.
pub const INFLUENCE_INDEX_BITS: u32 = 8;
#[cfg(feature = "format")]
/// Largest weight magnitude a packed influence can hold, as an integer (2²³ − 1).
pub const WEIGHT_INT_MAX: i32 = (1 << 23) - 1;
#[cfg(feature = "format")]
/// Smallest packed weight (−2²³).
pub const WEIGHT_INT_MIN: i32 = -(1 << 23);
/// Largest Σ|w| over one vertex's weights, as integers, that the linear deformer accepts
/// (`i16::MAX`). Every weight then fits in an `i16`, and every partial sum of products of the
/// weights with a 16-bit value stays below 2³⁰: the linear deformer evaluates it in 32-bit lanes.
pub const LINEAR_WEIGHT_ABS_SUM_MAX: i32 = i16::MAX as i32;
/// Largest number of fractional weight bits of the linear deformer: its weights sum to `2^F` and
/// their magnitudes to at most [`LINEAR_WEIGHT_ABS_SUM_MAX`], so F ≤ 14.
pub const LINEAR_MAX_WEIGHT_FRAC_BITS: u8 = 14;
/// Smallest accepted scale exponent s of an RBF coefficient row (entries are `q · 2^−s`).
pub const MIN_ROW_SHIFT: u8 = 1;
/// Largest accepted scale exponent of an RBF coefficient row.
pub const MAX_ROW_SHIFT: u8 = 48;

/// Largest marker displacement magnitude the linear deformer uses with weights of `frac`
/// fractional bits: `2^(15 + frac)` (at F = 14, 32 rig units); larger displacements saturate to it.
///
/// With Σ|w| ≤ 2¹⁵ it bounds every weighted sum to `2^30` after the shift by F, so adding the
/// rest position (|rest| ≤ 2²⁴) cannot overflow an `i32` and needs no saturation.
#[inline(always)]
pub fn linear_displacement_limit(frac: u32) -> i32 {
    1 << (15 + frac)
}

/// Multiply-accumulate: `acc + w · d`, exact (see the module docs for why it cannot overflow).
#[inline(always)]
pub fn mul_acc(acc: i64, w: i32, d: i32) -> i64 {
    acc + i64::from(w) * i64::from(d)
}

/// Narrow an accumulator with `frac` fractional bits back to `i32`: round half up, saturate.
///
/// `frac` must be in 1..=62; the rig loader guarantees it for the weight formats it accepts.
#[inline(always)]
pub fn round_shift_sat(acc: i64, frac: u32) -> i32 {
    let half = 1i64 << (frac - 1);
    let shifted = acc.saturating_add(half) >> frac;
    if shifted > i64::from(i32::MAX) {
        i32::MAX
    } else if shifted < i64::from(i32::MIN) {
        i32::MIN
    } else {
        shifted as i32
    }
}

/// [`round_shift_sat`] for a deformer's accumulator, whose magnitude is bounded by design:
/// `(acc + 2^(frac−1)) >> frac`, saturated to `i32`, with no saturation check on the addition.
///
/// Every accumulator the deformers form is below 2⁶² in magnitude (sums of at most 64 products of a
/// 24-bit and a 32-bit value, or of at most 256 products of a 16-bit and a 32-bit value, or three
/// products of two 32-bit values with |rest| ≤ 2²⁴), and `frac` ≤ 48, so adding the half cannot
/// overflow and the result is bit for bit that of [`round_shift_sat`]; the golden vectors check it.
#[inline(always)]
pub fn round_shift_bounded(acc: i64, frac: u32) -> i32 {
    let shifted = (acc + (1i64 << (frac - 1))) >> frac;
    shifted.clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32
}

/// Unpack an influence word: (marker index, weight as a sign-extended 24-bit integer).
#[inline(always)]
pub fn unpack_influence(word: u32) -> (u8, i32) {
    (word as u8, (word as i32) >> INFLUENCE_INDEX_BITS)
}

#[cfg(feature = "format")]
/// Pack a marker index and a 24-bit weight into an influence word; `None` if the weight does not
/// fit in 24 bits.
pub fn pack_influence(marker: u8, weight: i32) -> Option<u32> {
    if (WEIGHT_INT_MIN..=WEIGHT_INT_MAX).contains(&weight) {
        Some(((weight as u32) << INFLUENCE_INDEX_BITS) | u32::from(marker))
    } else {
        None
    }
}

/// Widen a stored Q0.15 rest coordinate to Q8.24.
#[inline(always)]
pub fn widen_rest(q15: i16) -> i32 {
    i32::from(q15) << REST_SHIFT
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Golden vectors at the edges of every primitive's range: these values are the contract,
    /// identical on every target.
    #[test]
    fn round_shift_golden() {
        let cases: [(i64, u32, i32); 12] = [
            (0, 20, 0),
            (1 << 19, 20, 1),       // exactly ½ rounds up
            ((1 << 19) - 1, 20, 0), // just below ½
            (-(1 << 19), 20, 0),    // −½ rounds up to 0
            (-(1 << 19) - 1, 20, -1),
            (3 << 20, 20, 3),
            (-(3 << 20), 20, -3),
            (i64::from(i32::MAX) << 20, 20, i32::MAX),
            ((i64::from(i32::MAX) + 1) << 20, 20, i32::MAX), // saturates
            (i64::from(i32::MIN) << 20, 20, i32::MIN),
            ((i64::from(i32::MIN) - 1) << 20, 20, i32::MIN), // saturates
            (i64::MAX, 8, i32::MAX),                         // no overflow adding ½
        ];
        for (acc, frac, want) in cases {
            assert_eq!(round_shift_sat(acc, frac), want, "acc={acc} frac={frac}");
        }
        assert_eq!(round_shift_sat(i64::MIN, 22), i32::MIN);
    }

    #[test]
    fn bounded_round_shift_equals_the_saturating_one_within_its_bound() {
        let bound = (1i64 << 62) - 1;
        let mut x = 0x9E37_79B9_7F4A_7C15u64;
        for frac in [1u32, 8, 20, 22, 24, 30, 48] {
            for acc in [
                0,
                1,
                -1,
                bound,
                -bound,
                1 << 61,
                -(1 << 61),
                (1 << (frac - 1)) - 1,
                -(1 << (frac - 1)),
            ] {
                assert_eq!(
                    round_shift_bounded(acc, frac),
                    round_shift_sat(acc, frac),
                    "{acc} >> {frac}"
                );
            }
            for _ in 0..1000 {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                let acc = (x as i64) >> 2; // |acc| < 2^62
                assert_eq!(
                    round_shift_bounded(acc, frac),
                    round_shift_sat(acc, frac),
                    "{acc} >> {frac}"
                );
            }
        }
    }

    #[test]
    fn mul_acc_golden_at_the_edges() {
        let w_max = WEIGHT_INT_MAX;
        let w_min = WEIGHT_INT_MIN;
        assert_eq!(mul_acc(0, w_max, i32::MAX), 18_014_396_353_609_729);
        assert_eq!(mul_acc(0, w_min, i32::MIN), 18_014_398_509_481_984);
        assert_eq!(mul_acc(0, w_min, i32::MAX), -18_014_398_501_093_376);
        // 64 worst-case products still fit: the accumulator bound of the module docs.
        let mut acc = 0i64;
        for _ in 0..MAX_INFLUENCES {
            acc = mul_acc(acc, w_min, i32::MIN);
        }
        assert_eq!(acc, 64 * 18_014_398_509_481_984);
    }

    #[test]
    fn pack_unpack_round_trips_at_the_edges() {
        for (m, w) in [
            (0u8, 0i32),
            (255, WEIGHT_INT_MAX),
            (7, WEIGHT_INT_MIN),
            (1, -1),
            (2, 1),
        ] {
            let word = pack_influence(m, w).unwrap();
            assert_eq!(unpack_influence(word), (m, w));
        }
        assert_eq!(pack_influence(0, WEIGHT_INT_MAX + 1), None);
        assert_eq!(pack_influence(0, WEIGHT_INT_MIN - 1), None);
        assert_eq!(pack_influence(0x12, -2), Some(0xFFFF_FE12));
    }

    #[test]
    fn widen_rest_golden() {
        assert_eq!(widen_rest(i16::MAX), 32767 << 9);
        assert_eq!(widen_rest(i16::MIN), -(1 << 24));
        assert_eq!(widen_rest(-1), -512);
    }
}
