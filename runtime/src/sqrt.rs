//! Integer square roots and vector normalisation, in a fixed number of steps.
//!
//! `rsqrt_table` is the cheap 1/√ of the per-frame normals: a table of 384 values computed at
//! compile time and one Newton step.
//!
//! The per-frame stages that need lengths (rigid fits, retargeting radial functions, planar-bone frames)
//! build on these two primitives. Both are pure integer arithmetic, so they give the same bits on
//! every platform, and both run a fixed number of iterations whatever their input.

/// Fractional bits of a unit vector returned by [`normalize3`] (Q1.30: 1.0 is 2³⁰).
pub const UNIT_FRAC_BITS: u32 = 30;

/// ⌊√x⌋, exact for every `u64`, in a fixed number of steps whatever `x` is, on 32-bit
/// arithmetic but for two 32 × 32 → 64-bit products.
///
/// `x` is shifted left by an even count `s` so that `y = x·2^s` lies in [2⁶², 2⁶⁴) (its root
/// `t = √y` in [2³¹, 2³²)), and `⌊√x⌋ = ⌊t⌋ >> s/2`. With `y = hi·2³² + lo`:
///
/// 1. `r = ⌊√hi⌋` ([`isqrt_u32`]: a table's start and two Newton steps), so `r ≥ 2¹⁵`,
///    `a = r·2¹⁶ ≤ t < a + 2¹⁶` and `hi − r² ≤ 2r < 2¹⁷`.
/// 2. One Newton step from `a`: exactly `N = a + (y − a²)/(2a) = t + (t − a)²/(2a)`, so
///    `t ≤ N < t + 1` (`(t − a)² < 2³²`, `2a ≥ 2³²`). It is computed as
///    `a + ⌊((hi − r²)·2¹⁵ + ⌊lo/2¹⁷⌋) / r⌋`: the numerator is below 2³² (one `u32`
///    division), and the two floors lose less than `1 + 2⁻¹⁵`, so the result `R` lies in
///    `(t − 1.0001, t + 1)`: `⌊t⌋ − 1 ≤ R ≤ ⌊t⌋ + 1`.
/// 3. One step down if `R² > y`, one up if `y − R² > 2R` (that is, `(R + 1)² ≤ y`).
///
/// (The digit-by-digit method on all 64 bits takes 32 steps of 64-bit arithmetic and a branch
/// each: about five times the cycles on a Cortex-M4.)
pub fn isqrt_u64(x: u64) -> u32 {
    if x == 0 {
        return 0;
    }
    let s = x.leading_zeros() & !1;
    let y = x << s;
    let (hi, lo) = ((y >> 32) as u32, y as u32);
    let r = isqrt_u32(hi);
    // hi ≥ 2^30, so r ≥ 2^15 (never zero) and hi − r² ≤ 2r < 2^17: the numerator fits a u32.
    let numerator = ((hi - r * r) << 15) + (lo >> 17);
    let mut root = (u64::from(r) << 16) + u64::from(numerator / r);
    // ⌊t⌋ ≤ 2^32 − 1, so R ≤ 2^32 and R² ≤ 2^64: clamp to 2^32 − 1 first (R would step down
    // from 2^32 anyway) so the square fits a u64.
    root = root.min(u64::from(u32::MAX));
    root -= u64::from(root * root > y);
    // Now R² ≤ y; (R + 1)² ≤ y exactly when the remainder exceeds 2R (below 2^33).
    root += u64::from(y - root * root > 2 * root);
    // ⌊√x⌋ = ⌊t / 2^(s/2)⌋ = ⌊⌊t⌋ / 2^(s/2)⌋; ⌊t⌋ < 2^32.
    (root >> (s / 2)) as u32
}

/// ⌊√x⌋ for `x` in [2³⁰, 2³²) (the root in [2¹⁵, 2¹⁶]), in a fixed number of steps: a start
/// from a table of 48 roots by `x`'s top six bits, two Newton steps, then one step down and
/// one up. The start `r₀` is at least √x and at most (1 + 1/32)·√x (the bucket's top, rounded
/// up); a Newton step from `r ≥ √x` leaves `r − √x` at most `(r − √x)²/(2r)` above the root and
/// the integer divisions lose less than 1 more, so the first step is within `[√x − 1, √x + 31)`
/// and the second within `[√x − 1, √x + 0.03)` (from below √x a step lands at or above it, by
/// under 2⁻¹⁶): within one of ⌊√x⌋, which the two checks make exact. Two hardware divisions on
/// a Cortex-M4 where the digit-by-digit method took 16 rounds of a compare and two selects
/// ([`isqrt_u64`] as the smoothing calls it for a marker's speed: 233 instructions, now 130).
fn isqrt_u32(x: u32) -> u32 {
    let start = ISQRT_START[((x >> 26) as usize).saturating_sub(16).min(47)];
    let mut r = (start + x / start) / 2;
    r = (r + x / r) / 2;
    // r ≤ 2^16 + 1: the squares fit a u64.
    let x = u64::from(x);
    r -= u32::from(u64::from(r) * u64::from(r) > x);
    r += u32::from((u64::from(r) + 1) * (u64::from(r) + 1) <= x);
    r
}

/// [`isqrt_u32`]'s starts: for each top-six-bits bucket `i` (16 to 63) of [2³⁰, 2³²), the root
/// of its top, rounded up: ⌈√((i + 1)·2²⁶)⌉.
const ISQRT_START: [u32; 48] = {
    let mut table = [0u32; 48];
    let mut i = 0;
    while i < 48 {
        let top = (i as u64 + 17) << 26;
        let root = isqrt_const(top);
        table[i] = (root + (root * root < top) as u64) as u32;
        i += 1;
    }
    table
};

/// The unit vector along `v` in Q1.30 ([`UNIT_FRAC_BITS`]), or `None` for the zero vector.
///
/// `v` may have any scale: it is first shifted (exactly, by a power of two chosen from its
/// largest component) so that the largest component lies in [2³⁰, 2³¹), then divided by its
/// length ⌊√(x² + y² + z²)⌋ with rounding to nearest. The length is at least 2³⁰ and the floor
/// loses less than one unit of it, so each component is within 2 LSB (2⁻²⁹) of the exact unit
/// vector of the shifted input; a right shift of a very large input drops at most its low bits,
/// a relative change below 2⁻³⁰.
pub fn normalize3(v: [i64; 3]) -> Option<[i32; 3]> {
    normalize(v)
}

/// [`normalize3`] for vectors of up to four components (quaternions), with the same error bound.
pub fn normalize<const N: usize>(v: [i64; N]) -> Option<[i32; N]> {
    const { assert!(N >= 1 && N <= 4, "normalize takes 1 to 4 components") };
    let largest = v.iter().map(|c| c.unsigned_abs()).max().unwrap_or(0);
    if largest == 0 {
        return None;
    }
    // Bring the largest magnitude into [2^30, 2^31): its highest set bit to bit 30.
    let top = 63 - largest.leading_zeros() as i32;
    let shift = top - 30;
    let scaled = v.map(|c| if shift >= 0 { c >> shift } else { c << -shift });
    // |c| < 2^31 for every component, so the sum of at most four squares is below 2^64.
    let sum = scaled
        .iter()
        .map(|&c| (c * c) as u64)
        .fold(0u64, u64::wrapping_add);
    let len = i64::from(isqrt_u64(sum));
    // len ≥ 2^30 (the largest component alone gives it) and |c| · 2^30 < 2^61: no overflow.
    let half = len / 2;
    Some(scaled.map(|c| {
        let num = c << UNIT_FRAC_BITS;
        let q = if num >= 0 {
            (num + half) / len
        } else {
            -((-num + half) / len)
        };
        // |c| ≤ len, so |q| ≤ 2^30: fits i32.
        q as i32
    }))
}

/// Newton steps [`rsqrt_u64`] takes from its linear first guess.
pub const RSQRT_STEPS: usize = 5;

/// 1/√x as `(y, shift)` with 1/√x ≈ y · 2^−shift, y in [2³⁰, 2³¹] and shift in [31, 62];
/// `None` for x = 0.
///
/// x is shifted by an even count so that X = x · 2^(e−64) lies in [¼, 1); from the chord
/// 2 − 4/3 (X − ¼) (at most 18 % high), [`RSQRT_STEPS`] Newton steps y ← y (3 − X y²) / 2 in Q2.30
/// reach the limit of the format. Measured over 10⁵ random inputs and the edges (see the tests):
/// relative error below 2⁻²⁸, never above the true value by more than that.
pub fn rsqrt_u64(x: u64) -> Option<(u32, u32)> {
    if x == 0 {
        return None;
    }
    let e = x.leading_zeros() & !1;
    // X in Q0.32, in [2^30, 2^32).
    let big_x = (x << e) >> 32;
    // Chord through (¼, 2) and (1, 1), in Q2.30: 2 − 4/3 · (X − ¼).
    let two = 2u64 << 30;
    let mut y = two - (((big_x - (1 << 30)) * 4 / 3) >> 2);
    for _ in 0..RSQRT_STEPS {
        // X y² in Q.30: y < 2^31 so y² < 2^62; y² >> 30 ≤ 2^32 and X < 2^32, X y² stays below
        // 1.4 · 2^62 from the first guess on.
        let y2 = (y * y) >> 30;
        let xy2 = (big_x * y2) >> 32;
        let t = (3u64 << 30).saturating_sub(xy2);
        y = (y * t) >> 31;
    }
    Some((y as u32, 62 - e / 2))
}

/// Index bits of [`RSQRT_TABLE`]: the table covers X ∈ [¼, 1) in buckets of 2⁻⁹.
const RSQRT_TABLE_BITS: u32 = 9;
/// First entry of the table's index range: X ≥ ¼ means X · 2⁹ ≥ 128.
const RSQRT_TABLE_START: usize = 1 << (RSQRT_TABLE_BITS - 2);

/// 1/√ at the midpoint of each bucket of X ∈ [¼, 1), Q2.30: entry `i` is
/// ⌊2⁵¹ / ⌊√((2(i + 128) + 1) · 2³²)⌋⌋ ≈ 2³⁰ / √((2(i + 128) + 1) / 2¹⁰), computed at compile
/// time in integers, so it is the same table on every target.
const RSQRT_TABLE: [u32; 384] = {
    let mut table = [0u32; 384];
    let mut i = 0;
    while i < table.len() {
        let m = (2 * (i + RSQRT_TABLE_START) + 1) as u64;
        table[i] = ((1u64 << 51) / isqrt_const(m << 32)) as u32;
        i += 1;
    }
    table
};

/// [`isqrt_u64`] for the compile-time table (a `while` loop: `for` is not allowed in `const`).
const fn isqrt_const(x: u64) -> u64 {
    let (mut rem, mut root, mut bit) = (x, 0u64, 1u64 << 62);
    while bit != 0 {
        if rem >= root + bit {
            rem -= root + bit;
            root = (root >> 1) + bit;
        } else {
            root >>= 1;
        }
        bit >>= 2;
    }
    root
}

/// 1/√x as [`rsqrt_u64`] gives it (`(y, shift)`, 1/√x ≈ y · 2^−shift), but from a 384-entry
/// table of 1/√ (relative error at most 2⁻⁹ at a bucket's edge) and one Newton step: relative
/// error below 2⁻¹⁷ (tested over 10⁵ inputs), enough for a Q1.14 unit vector, at a fraction of
/// the cost. `None` for x = 0. The per-frame normals use it.
pub fn rsqrt_table(x: u64) -> Option<(u32, u32)> {
    if x == 0 {
        return None;
    }
    let e = x.leading_zeros() & !1;
    // X in Q0.32, in [2^30, 2^32); its top nine bits pick the bucket.
    let big_x = (x << e) >> 32;
    let bucket = (big_x >> (32 - RSQRT_TABLE_BITS)) as usize - RSQRT_TABLE_START;
    let mut y = u64::from(RSQRT_TABLE.get(bucket).copied().unwrap_or(1 << 30));
    // One Newton step, as in `rsqrt_u64`.
    let y2 = (y * y) >> 30;
    let xy2 = (big_x * y2) >> 32;
    let t = (3u64 << 30).saturating_sub(xy2);
    y = (y * t) >> 31;
    Some((y as u32, 62 - e / 2))
}

#[cfg(test)]
mod tests {
    extern crate std;
    use std::vec;

    use super::*;

    #[test]
    fn isqrt_is_exact_at_the_edges_and_on_squares() {
        for (x, want) in [
            (0u64, 0u32),
            (1, 1),
            (2, 1),
            (3, 1),
            (4, 2),
            (15, 3),
            (16, 4),
            (u64::MAX, u32::MAX),
            ((1u64 << 62) - 1, (1u32 << 31) - 1),
            (1u64 << 62, 1u32 << 31),
        ] {
            assert_eq!(isqrt_u64(x), want, "isqrt({x})");
        }
        let mut s = 0x2545_F491_4F6C_DD1Du64;
        for _ in 0..10_000 {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            let r = u64::from(isqrt_u64(s));
            assert!(r * r <= s, "isqrt({s}) = {r} too large");
            assert!(
                (r + 1).checked_mul(r + 1).is_none_or(|sq| sq > s),
                "isqrt({s}) = {r} too small"
            );
            let root = (s >> 32) as u32;
            assert_eq!(isqrt_u64(u64::from(root) * u64::from(root)), root);
        }
    }

    /// [`isqrt_u32`] on every square from 2¹⁵ to 2¹⁶ and its neighbours, every bucket's edges,
    /// and 2²⁰ values spread over its whole range [2³⁰, 2³²), against the digit-by-digit
    /// method. (Run once over all 3·2³⁰ inputs too, 2026-12-05: no difference.)
    #[test]
    fn isqrt_u32_is_exact() {
        let mut cases = vec![u32::MAX];
        for k in 1u64 << 15..=1 << 16 {
            let sq = k * k;
            cases.extend(
                [sq - 1, sq, sq + 1]
                    .iter()
                    .filter_map(|&x| u32::try_from(x).ok()),
            );
        }
        for i in 16u32..64 {
            cases.extend([(i << 26).saturating_sub(1), i << 26, (i << 26) + 1]);
        }
        let mut s = 0x9E37_79B9u32;
        for i in 0..1u32 << 20 {
            s ^= s << 13;
            s ^= s >> 17;
            s ^= s << 5;
            cases.push((1 << 30) + (i << 11) + (s & 0x7FF));
            cases.push(s | 1 << 30);
        }
        for x in cases.into_iter().filter(|&x| x >= 1 << 30) {
            assert_eq!(
                u64::from(isqrt_u32(x)),
                isqrt_const(u64::from(x)),
                "isqrt({x})"
            );
        }
    }

    #[test]
    fn isqrt_equals_the_digit_by_digit_method() {
        // Every power of two and its neighbours, every square of a power of two's neighbours and
        // its neighbours, and random values of every bit length.
        let mut cases = vec![0u64, 1, 2, 3, u64::MAX, u64::MAX - 1];
        for k in 0..64 {
            let p = 1u64 << k;
            cases.extend([p - 1, p, p + 1]);
        }
        for r in (0..32).flat_map(|k| {
            let p = 1u64 << k;
            [p - 1, p, p + 1]
        }) {
            let sq = r * r;
            cases.extend([sq.saturating_sub(1), sq, sq + 1]);
        }
        let mut s = 0x9E37_79B9_7F4A_7C15u64;
        for i in 0..400_000 {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            cases.push(s >> (i % 64));
            let r = (s >> 32) >> (i % 32);
            cases.extend([(r * r).saturating_sub(1), r * r, r * r + 1, r * r + 2 * r]);
        }
        for x in cases {
            assert_eq!(u64::from(isqrt_u64(x)), isqrt_const(x), "isqrt({x})");
        }
    }

    #[test]
    fn normalize3_gives_unit_vectors_within_two_lsb() {
        assert_eq!(normalize3([0, 0, 0]), None);
        assert_eq!(normalize3([5, 0, 0]), Some([1 << 30, 0, 0]));
        assert_eq!(normalize3([0, -7 << 40, 0]), Some([0, -(1 << 30), 0]));
        assert_eq!(normalize3([i64::MIN, 0, 0]), Some([-(1 << 30), 0, 0]));
        let mut s = 0x9E37_79B9_7F4A_7C15u64;
        for _ in 0..10_000 {
            let mut v = [0i64; 3];
            for c in &mut v {
                s ^= s << 13;
                s ^= s >> 7;
                s ^= s << 17;
                *c = (s as i64) >> (s % 60);
            }
            let Some(u) = normalize3(v) else {
                assert_eq!(v, [0, 0, 0]);
                continue;
            };
            let len = v.iter().map(|&c| (c as f64).powi(2)).sum::<f64>().sqrt();
            for (c, q) in v.iter().zip(u) {
                let exact = *c as f64 / len * f64::from(1u32 << 30);
                assert!((f64::from(q) - exact).abs() <= 2.0, "{v:?} → {u:?}");
            }
        }
    }

    #[test]
    fn table_rsqrt_is_within_two_to_the_minus_17() {
        assert_eq!(rsqrt_table(0), None);
        let check = |x: u64| {
            let (y, shift) = rsqrt_table(x).unwrap();
            let got = f64::from(y) * 2f64.powi(-(shift as i32));
            let rel = got * (x as f64).sqrt() - 1.0;
            assert!(rel.abs() < 2f64.powi(-17), "rsqrt_table({x}): {rel:e}");
        };
        for x in [1u64, 2, 3, 4, 5, (1 << 62) - 1, 1 << 62, u64::MAX] {
            check(x);
        }
        let mut s = 0x2545_F491_4F6C_DD1Du64;
        for _ in 0..100_000 {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            check((s >> (s % 64)).max(1));
        }
    }

    #[test]
    fn rsqrt_is_within_two_to_the_minus_28() {
        assert_eq!(rsqrt_u64(0), None);
        let check = |x: u64| {
            let (y, shift) = rsqrt_u64(x).unwrap();
            assert!((31..=62).contains(&shift), "{x}: shift {shift}");
            let got = f64::from(y) * 2f64.powi(-(shift as i32));
            let want = 1.0 / (x as f64).sqrt();
            let rel = (got - want) / want;
            assert!(
                rel.abs() < 2f64.powi(-28),
                "rsqrt({x}) = {got}, want {want} ({rel:e})"
            );
        };
        for x in [
            1u64,
            2,
            3,
            4,
            5,
            1 << 20,
            (1 << 62) - 1,
            1 << 62,
            u64::MAX,
            u64::MAX - 1,
        ] {
            check(x);
        }
        let mut s = 0xD1B5_4A32_D192_ED03u64;
        for _ in 0..100_000 {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            check((s >> (s % 64)).max(1));
        }
    }
}
