//! Rebuilding a missing marker from its neighbours (paper 000 §5.2): in the compensated head
//! frame, a missing marker is put where its baked neighbours that are present in this frame say,
//! weighted: each neighbour at its displacement plus the marker's *offset* from it when both
//! were last seen together ([`Offsets`]; zero if never), so a marker lost for a few frames keeps
//! its place among its neighbours instead of jumping to their mean (JawMoCap with 5 % of the
//! samples dropped: the face's worst error against the clean take 2.95 → 0.96 mm). While
//! the marker is missing its offsets shrink by a 2^−[`OFFSET_DECAY_SHIFT`] share a frame, so
//! one lost for good settles at its neighbours' mean over seconds. Neighbours that are
//! themselves missing are skipped (never chained), so the cost is fixed: [`FILL_NEIGHBOURS`]
//! terms per marker and frame, present (the offsets are kept) or not.
//!
//!
//! Formats: displacements Q8.24 (`i32`), weights Q8.16 non-negative (24-bit field of a packed
//! influence word); Σ w·d over four terms is below 2⁵⁷, one rounded division by Σ w.

use crate::fixed::unpack_influence;
use crate::error::{expect_stages_len, StagesLoadError, StagesSection};
use crate::records::{read_influence, Bytes, FILL_BYTES, FILL_NEIGHBOURS, INFLUENCE_BYTES};
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

/// A marker lost for good drifts back to its neighbours' mean: each frame of its gap its
/// offsets lose a 2^−this share (1/256: half is left after 177 frames, 3 s at 60 Hz). Over
/// JawMoCap's frames, a gap's mean error by its length (5 / 30 / 120 / 600 frames): 1/64
/// 0.190 / 0.643 / 1.238 / 1.726 mm, 1/256 0.169 / 0.560 / 1.039 / 1.566, 1/1024 0.167 /
/// 0.559 / 1.057 / 1.538, none 0.168 / 0.563 / 1.085 / 1.674: the offset when last seen is
/// worth keeping for seconds.
pub const OFFSET_DECAY_SHIFT: u32 = 8;

/// One marker's offsets from its [`FILL_NEIGHBOURS`] fill neighbours (in the order of its fill
/// words), Q8.24 like the displacements: its displacement less the neighbour's when both were
/// last present, each within ±`limit` (the stages' `max_displacement`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Offsets(pub [[i32; 3]; FILL_NEIGHBOURS]);

impl Offsets {
    /// No offset known: the neighbours' plain weighted mean.
    pub const ZERO: Self = Self([[0; 3]; FILL_NEIGHBOURS]);

    /// A present marker at `d`: its offset from each present neighbour (`neighbours`, packed
    /// words), clamped to ±`limit`; the others keep theirs.
    pub fn record(
        &mut self,
        neighbours: &[u8],
        d: [i32; 3],
        displacement: &[[i32; 3]],
        present: &MarkerSet,
        limit: i32,
    ) {
        for (o, w) in self.0.iter_mut().zip(neighbours.chunks_exact(INFLUENCE_BYTES)) {
            let (k, weight) = unpack_influence(u32::from_le_bytes([w[0], w[1], w[2], w[3]]));
            let k = usize::from(k);
            if weight <= 0 || !present.contains(k) {
                continue;
            }
            if let Some(n) = displacement.get(k) {
                // 32-bit saturation then the clamp: the same value as the exact difference
                // clamped, since `limit` < i32::MAX, and cheaper on a 32-bit core.
                *o = [0, 1, 2].map(|c| d[c].saturating_sub(n[c]).clamp(-limit, limit));
            }
        }
    }

    /// A frame of the marker's gap: every offset a 2^−[`OFFSET_DECAY_SHIFT`] share nearer zero
    /// (an arithmetic shift: it settles within 2^6 units of zero, 4e-6 actor units).
    pub fn decay(&mut self) {
        for o in &mut self.0 {
            *o = o.map(|v| v - (v >> OFFSET_DECAY_SHIFT));
        }
    }
}

/// The displacement of a missing marker from the present ones among its `neighbours` (packed
/// words: marker index, Q8.16 weight), each at its displacement plus the marker's offset from
/// it, weighted; `None` if none of them is present. The result is clamped to ±`limit`.
pub fn rebuild(
    neighbours: &[u8],
    displacement: &[[i32; 3]],
    present: &MarkerSet,
    offsets: &Offsets,
    limit: i64,
) -> Option<[i32; 3]> {
    let mut acc = [0i64; 3];
    let mut total = 0i64;
    for (o, w) in offsets.0.iter().zip(neighbours.chunks_exact(INFLUENCE_BYTES)) {
        let (k, weight) = unpack_influence(u32::from_le_bytes([w[0], w[1], w[2], w[3]]));
        let k = usize::from(k);
        if weight <= 0 || !present.contains(k) {
            continue;
        }
        let Some(d) = displacement.get(k) else {
            continue;
        };
        total += i64::from(weight);
        // |d + o| ≤ 2^31 and weight < 2^24: four terms stay below 2^57.
        for c in 0..3 {
            acc[c] += i64::from(weight) * (i64::from(d[c]) + i64::from(o[c]));
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
        // A weighted mean of values within ±2^31, clamped into the i32 range.
        q.clamp(-limit, limit) as i32
    }))
}
