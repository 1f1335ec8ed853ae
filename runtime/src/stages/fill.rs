//! Rebuilding a missing marker from its neighbours (paper 000 §5.2): in the compensated head
//! frame, a missing marker moves by the weighted mean of the displacements of its baked
//! neighbours that are present in this frame. Neighbours that are themselves missing are
//! skipped (never chained), so the cost is fixed: [`FILL_NEIGHBOURS`] terms per marker.
//!
//! [`FILL_NEIGHBOURS`]: crate::records::FILL_NEIGHBOURS
//!
//! Formats: displacements Q8.24 (`i32`), weights Q8.16 non-negative (24-bit field of a packed
//! influence word); Σ w·d over four terms is below 2⁵⁷, one rounded division by Σ w.

use crate::fixed::unpack_influence;
use crate::error::{expect_stages_len, StagesLoadError, StagesSection};
use crate::records::{read_influence, Bytes, FILL_BYTES, INFLUENCE_BYTES};
use crate::stages::report::MarkerSet;

/// Fractional bits of a fill weight.
#[cfg(feature = "format")]
pub const FILL_FRAC_BITS: u32 = 16;

/// Check the `fill` section: [`FILL_NEIGHBOURS`] words per marker, each unused (weight 0) or
/// naming another existing marker with a positive weight.
pub(crate) fn validate(fill: Bytes<'_>, markers: usize) -> Result<(), StagesLoadError> {
    expect_stages_len(StagesSection::Fill, fill, markers, FILL_BYTES)?;
    for (marker, words) in fill.0.chunks_exact(FILL_BYTES).enumerate() {
        for w in words.chunks_exact(INFLUENCE_BYTES) {
            let (k, weight) = read_influence(w);
            let k = usize::from(k);
            if weight < 0 || (weight > 0 && (k >= markers || k == marker)) {
                return Err(StagesLoadError::BadFillNeighbour { marker });
            }
        }
    }
    Ok(())
}

/// Whether `marker` has no fill neighbours (every weight 0); `false` past the section's end.
pub(crate) fn has_no_neighbours(fill: Bytes<'_>, marker: usize) -> bool {
    fill.0
        .get(marker * FILL_BYTES..(marker + 1) * FILL_BYTES)
        .is_some_and(|w| {
            w.chunks_exact(INFLUENCE_BYTES)
                .all(|x| read_influence(x).1 == 0)
        })
}

/// The displacement of a missing marker from the present ones among its `neighbours` (packed
/// words: marker index, Q8.16 weight), or `None` if none of them is present.
pub fn rebuild(
    neighbours: &[u8],
    displacement: &[[i32; 3]],
    present: &MarkerSet,
) -> Option<[i32; 3]> {
    let mut acc = [0i64; 3];
    let mut total = 0i64;
    for w in neighbours.chunks_exact(INFLUENCE_BYTES) {
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
