//! The linear kernel: each vertex moves by a weighted sum of at most K marker displacements.
//!
//! ```text
//! out[v] = rest[v] + round( Σ_k w[v,k] · (m[idx[v,k]] − m_rest[idx[v,k]]) / 2^F )
//! ```
//!
//! Cost per frame: `markers` saturating 3-vector subtractions, then per influence one word decode
//! and three `i32 × i32 → i64` multiply-adds, then per vertex three round-shifts and three
//! saturating adds. There is no branch on marker data and no check that can fail: the loader has
//! validated every index and count.
//!
//! The loop is shaped for the code it compiles to (it is instruction-bound): each vertex's
//! influences are split off as one slice, so the inner loop has a single trip counter; each
//! influence word is read as one `[u8; 4]`, so it is one 32-bit load rather than byte loads; and
//! the rounding half is added without a saturation check, which cannot be reached (see
//! [`round_shift_bounded`]).

use crate::fixed::{mul_acc, round_shift_bounded};
use crate::format::{read_influence, read_rest, INFLUENCE_BYTES, MAX_MARKERS, REST_BYTES};

/// Write deformed positions for every vertex.
///
/// `displacements` has one entry per possible marker index (unused ones are never read),
/// `rest` is the vertex rest section (6 bytes a vertex), `counts` one byte a vertex, `influences`
/// four bytes an influence, all validated at load. `out` has one entry per vertex.
pub(crate) fn deform(
    displacements: &[[i32; 3]; MAX_MARKERS],
    rest: &[u8],
    counts: &[u8],
    influences: &[u8],
    weight_frac_bits: u8,
    out: &mut [[i32; 3]],
) {
    let frac = u32::from(weight_frac_bits);
    let mut words = influences;
    for ((o, r), &count) in out
        .iter_mut()
        .zip(rest.chunks_exact(REST_BYTES))
        .zip(counts)
    {
        // The loader checked that the counts add up to the section; the fallback is never taken.
        let (mine, tail) = words
            .split_at_checked(4 * usize::from(count))
            .unwrap_or((words, &[]));
        words = tail;
        let mut acc = [0i64; 3];
        for w in mine.chunks_exact(INFLUENCE_BYTES) {
            let (marker, weight) = read_influence(w);
            // A u8 index into a 256-entry array: in range by construction.
            let d = &displacements[usize::from(marker)];
            acc[0] = mul_acc(acc[0], weight, d[0]);
            acc[1] = mul_acc(acc[1], weight, d[1]);
            acc[2] = mul_acc(acc[2], weight, d[2]);
        }
        let rest = read_rest(r);
        for c in 0..3 {
            o[c] = rest[c].saturating_add(round_shift_bounded(acc[c], frac));
        }
    }
}
