//! The RBF-coefficient kernel: the papers' per-frame RBF solve, made cheap and local.
//!
//! ```text
//! c[i]   = round( Σ_j M[i,j] · D[j] / 2^s_i )            per coefficient row i (stage 1)
//! out[v] = sat( rest[v] + β₀ + round( Σ_k φ[v,k] · c[idx[v,k]] / 2^F )
//!                            + round( (βx·rest_x + βy·rest_y + βz·rest_z) / 2^24 ) )   (stage 2)
//! ```
//!
//! Stage 2 adds its four terms in `i64` and saturates once, to `i32`: the kernel sum is below
//! 2⁶⁰ (at most 64 products of a 24-bit φ and a 32-bit coefficient), the affine sum below 2⁵⁷,
//! rest and β₀ below 2³¹, so nothing before the final clamp can overflow.
//!
//! `M` is the first `n` columns of the inverse RBF system matrix, baked once; `D` are the marker
//! displacements. Stage 1 is `rows × markers` `i16 × i32 → i64` multiply-adds per axis; stage 2 is
//! K multiply-adds per vertex and axis plus three for the affine part. Products in stage 1 are
//! below 2⁴⁶ and at most 256 of them are summed, so the `i64` accumulator cannot overflow; stage 2
//! is bounded as in [`crate::fixed`]. No branch depends on marker data.

use crate::fixed::{mul_acc, round_shift_bounded, POS_FRAC_BITS};
use crate::format::{
    read_influence, read_rest, RbfCoefficients, INFLUENCE_BYTES, MAX_MARKERS, REST_BYTES,
};

/// The rounding half of the affine sum, which has 24 fractional bits more than a position.
const AFFINE_HALF: i64 = 1 << (POS_FRAC_BITS - 1);

/// Coefficient rows the scratch table holds: one per marker plus the four affine rows.
pub(crate) const MAX_ROWS: usize = MAX_MARKERS + 4;

/// Stage 1: the coefficients of this frame, one per row, from the marker displacements.
pub(crate) fn coefficients(
    rbf: &RbfCoefficients<'_>,
    markers: usize,
    displacements: &[[i32; 3]; MAX_MARKERS],
    table: &mut [[i32; 3]; MAX_ROWS],
) {
    let rows = rbf
        .row_shifts
        .0
        .iter()
        .zip(rbf.matrix.0.chunks_exact(2 * markers));
    for (c, (&shift, entries)) in table.iter_mut().zip(rows) {
        let mut acc = [0i64; 3];
        for (q, d) in entries.chunks_exact(2).zip(displacements.iter()) {
            let q = i32::from(i16::from_le_bytes([q[0], q[1]]));
            acc[0] = mul_acc(acc[0], q, d[0]);
            acc[1] = mul_acc(acc[1], q, d[1]);
            acc[2] = mul_acc(acc[2], q, d[2]);
        }
        *c = acc.map(|a| round_shift_bounded(a, u32::from(shift)));
    }
}

/// Stage 2: K kernel terms and the affine part per vertex.
pub(crate) fn deform(
    rbf: &RbfCoefficients<'_>,
    markers: usize,
    table: &[[i32; 3]; MAX_ROWS],
    rest: &[u8],
    out: &mut [[i32; 3]],
) {
    let frac = u32::from(rbf.weight_frac_bits);
    let half = 1i64 << (frac - 1);
    let k = usize::from(rbf.influences_per_vertex);
    // Without the affine rows these stay zero and add nothing.
    let (beta0, beta) = if rbf.affine {
        (
            table[markers],
            [table[markers + 1], table[markers + 2], table[markers + 3]],
        )
    } else {
        ([0; 3], [[0; 3]; 3])
    };
    let vertices = out
        .iter_mut()
        .zip(rest.chunks_exact(REST_BYTES))
        .zip(rbf.influences.0.chunks_exact(INFLUENCE_BYTES * k));
    for ((o, r), words) in vertices {
        let mut acc = [0i64; 3];
        for w in words.chunks_exact(INFLUENCE_BYTES) {
            let (centre, phi) = read_influence(w);
            // A u8 index into a 260-entry table: in range by construction.
            let c = &table[usize::from(centre)];
            acc[0] = mul_acc(acc[0], phi, c[0]);
            acc[1] = mul_acc(acc[1], phi, c[1]);
            acc[2] = mul_acc(acc[2], phi, c[2]);
        }
        let rest_v = read_rest(r);
        for c in 0..3 {
            // Affine: Σ_a β_a · rest_a, with rest in Q8.24 and |rest| ≤ 2²⁴.
            let mut lin = 0i64;
            for (b, &x) in beta.iter().zip(&rest_v) {
                lin = mul_acc(lin, b[c], x);
            }
            let total = i64::from(rest_v[c])
                + i64::from(beta0[c])
                + ((acc[c] + half) >> frac)
                + ((lin + AFFINE_HALF) >> POS_FRAC_BITS);
            o[c] = total.clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32;
        }
    }
}
