//! Rebuilding a missing marker from its neighbours (paper 000 §5.2): in the compensated head
//! frame, a missing marker moves by the weighted mean of the displacements of its baked
//! neighbours that are present in this frame. Neighbours that are themselves missing are
//! skipped (never chained), so the cost is fixed: [`super::FILL_NEIGHBOURS`] terms per marker.
//!
//! Formats: displacements Q8.24 (`i32`), weights Q8.16 non-negative (24-bit field of a packed
//! influence word); Σ w·d over four terms is below 2⁵⁷, one rounded division by Σ w.

use super::MarkerSet;
use crate::fixed::unpack_influence;

/// The displacement of a missing marker from the present ones among its `neighbours` (packed
/// words: marker index, Q8.16 weight), or `None` if none of them is present.
pub fn rebuild(
    neighbours: &[u8],
    displacement: &[[i32; 3]],
    present: &MarkerSet,
) -> Option<[i32; 3]> {
    let mut acc = [0i64; 3];
    let mut total = 0i64;
    for w in neighbours.chunks_exact(4) {
        let (k, weight) = unpack_influence(u32::from_le_bytes([w[0], w[1], w[2], w[3]]));
        let k = usize::from(k);
        if weight <= 0 || !present.contains(k) {
            continue;
        }
        let Some(d) = displacement.get(k) else {
            continue;
        };
        total += i64::from(weight);
        for c in 0..3 {
            acc[c] += i64::from(weight) * i64::from(d[c]);
        }
    }
    if total == 0 {
        return None;
    }
    Some(acc.map(|a| {
        let half = total / 2;
        let q = if a >= 0 {
            (a + half) / total
        } else {
            -((-a + half) / total)
        };
        // A weighted mean of i32 values is within the i32 range.
        q as i32
    }))
}
