//! What every deformer provides, with one signature shape ([`DeformerSection`]), what it is given
//! ([`Shared`]) and what a frame reports ([`DegenerateTriangles`]). Each deformer's module
//! implements the trait for its section type; [`super::Deformer`] dispatches to it.
//!
//! Kept apart from `deformer/mod.rs` so that the deformers import it and `mod.rs` imports them,
//! with no cycle between the files.

use crate::cost::Cost;
use crate::fixed::{MAX_INFLUENCES, MIN_WEIGHT_FRAC_BITS};
use crate::error::{expect_len, LoadError, Section};
use crate::records::{read_i32, Bytes, COUNT_BYTES, MAX_TRIANGLES, REST_BYTES, SECTION_ALIGN};

/// The rig's counts and the sections every deformer reads besides its own.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Shared<'a> {
    /// Number of vertices (`vertex_count`).
    pub vertices: usize,
    /// Number of markers (`marker_count`).
    pub markers: usize,
    /// The `marker_rest` section (validated before the deformer).
    pub marker_rest: &'a [u8],
    /// The `vertex_rest` section (validated before the deformer).
    pub vertex_rest: &'a [u8],
    /// The number of influences every vertex has, when all have the same ([`uniform`]), found
    /// once when the rig is loaded; `None` when they differ or it is not known (validation).
    pub uniform_influences: Option<u8>,
}

impl<'a> Shared<'a> {
    /// The same rig seen as its vertices `first .. first + len` only (in range: the caller
    /// checked).
    pub(crate) fn vertex_range(&self, first: usize, len: usize) -> Self {
        Self {
            vertices: len,
            vertex_rest: self
                .vertex_rest
                .get(first * REST_BYTES..(first + len) * REST_BYTES)
                .unwrap_or(&[]),
            ..*self
        }
    }
}

/// One deformer's operations. Each section type implements it in its own module.
pub(crate) trait DeformerSection {
    /// Check the section against the rig's counts and shared sections: everything the per-frame
    /// path relies on, each failure with its own [`LoadError`].
    fn validate(&self, rig: &Shared<'_>) -> Result<(), LoadError>;

    /// The per-frame work of [`Self::deform`], fixed by the rig.
    fn cost(&self, rig: &Shared<'_>) -> Cost;

    /// Fractional bits of the stored weights (or radial values).
    #[cfg_attr(not(feature = "format"), allow(dead_code))]
    fn weight_frac_bits(&self) -> u8;

    /// Deform one frame: `markers` has one position per rig marker and `out` one entry per
    /// vertex (the caller checked both), `rig` and `self` were validated at load. Never fails.
    fn deform(
        &self,
        rig: &Shared<'_>,
        markers: &[[i32; 3]],
        out: &mut [[i32; 3]],
    ) -> DegenerateTriangles;
}

/// Validation steps more than one deformer shares.
pub(crate) mod check {
    use super::*;

    /// K is in [1, [`MAX_INFLUENCES`]].
    pub(crate) fn max_influences(k: u8) -> Result<(), LoadError> {
        if k == 0 || k > MAX_INFLUENCES {
            return Err(LoadError::BadMaxInfluences { found: k });
        }
        Ok(())
    }

    /// `weight_frac_bits` is in [[`MIN_WEIGHT_FRAC_BITS`], `max`].
    pub(crate) fn weight_format(weight_frac_bits: u8, max: u8) -> Result<(), LoadError> {
        if !(MIN_WEIGHT_FRAC_BITS..=max).contains(&weight_frac_bits) {
            return Err(LoadError::BadWeightFormat {
                found: weight_frac_bits,
            });
        }
        Ok(())
    }

    /// `align`, the alignment section before `section`, is fewer than [`SECTION_ALIGN`] zero
    /// bytes.
    pub(crate) fn alignment(align: Bytes<'_>, section: Section) -> Result<(), LoadError> {
        if align.0.len() >= SECTION_ALIGN || align.0.iter().any(|&b| b != 0) {
            return Err(LoadError::BadAlignment { section });
        }
        Ok(())
    }

    /// `counts` has one `u8` per vertex and `records` exactly as many `record_bytes`-long
    /// records as the counts add up to (vertex after vertex); `names` are the two sections'.
    pub(crate) fn counted_records(
        counts: Bytes<'_>,
        records: Bytes<'_>,
        vertices: usize,
        record_bytes: usize,
        names: [Section; 2],
    ) -> Result<(), LoadError> {
        expect_len(names[0], counts, vertices, COUNT_BYTES)?;
        let total: usize = counts.0.iter().map(|&c| usize::from(c)).sum();
        expect_len(names[1], records, total, record_bytes)
    }
}

/// The counts and records of vertices `first .. first + len` of a section that stores, vertex
/// after vertex, a count (`u8`) and that many `record_bytes`-long records (validated at load; an
/// out-of-range request gives empty slices). `uniform` is the count every vertex has, when they
/// all have the same ([`Shared::uniform_influences`]): the records before `first` are then
/// `first` times it; otherwise the counts before `first` are summed.
pub(crate) fn counted_range<'a>(
    counts: &'a [u8],
    records: &'a [u8],
    record_bytes: usize,
    first: usize,
    len: usize,
    uniform: Option<u8>,
) -> (&'a [u8], &'a [u8]) {
    let mine = counts.get(first..first + len).unwrap_or(&[]);
    let (before, count) = match uniform {
        Some(k) => (first * usize::from(k), mine.len() * usize::from(k)),
        None => (
            count_sum(counts.get(..first).unwrap_or(counts)),
            count_sum(mine),
        ),
    };
    let records = records
        .get(before * record_bytes..(before + count) * record_bytes)
        .unwrap_or(&[]);
    (mine, records)
}

/// The number of influences of every vertex, if all have the same (as bakes write them) and it
/// is not zero: what a rig notes once at load ([`Shared::uniform_influences`]).
pub(crate) fn uniform(counts: &[u8]) -> Option<u8> {
    let &k = counts.first()?;
    // Four counts a comparison.
    let four = read_i32(&[k; 4]);
    let mut quads = counts.chunks_exact(4);
    let same = quads.by_ref().all(|q| read_i32(q) == four)
        && quads.remainder().iter().all(|&c| c == k);
    (same && k > 0).then_some(k)
}

/// The sum of `counts`, in blocks whose `u32` sums cannot overflow (255 · 2¹⁶ < 2³²), so the
/// compiler vectorises it: a chunk far into a big face sums the counts before it this way.
fn count_sum(counts: &[u8]) -> usize {
    counts
        .chunks(1 << 16)
        .map(|block| block.iter().map(|&c| u32::from(c)).sum::<u32>() as usize)
        .sum()
}

/// Which control triangles of a planar rig were degenerate in a frame (collinear or coincident
/// markers) and so kept their rest orientation; always empty for the other deformers. See
/// [`crate::Rig::deform_report`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DegenerateTriangles {
    bits: [u32; MAX_TRIANGLES / 32],
}

impl Default for DegenerateTriangles {
    fn default() -> Self {
        Self {
            bits: [0; MAX_TRIANGLES / 32],
        }
    }
}

impl DegenerateTriangles {
    /// Record triangle `t` as degenerate.
    pub(crate) fn mark(&mut self, t: usize) {
        if let Some(word) = self.bits.get_mut(t / 32) {
            *word |= 1 << (t % 32);
        }
    }

    /// Whether triangle `t` was degenerate (and so used its rest orientation).
    pub fn contains(&self, t: usize) -> bool {
        self.bits
            .get(t / 32)
            .is_some_and(|word| word & (1 << (t % 32)) != 0)
    }

    /// How many triangles were degenerate.
    pub fn count(&self) -> usize {
        self.bits.iter().map(|w| w.count_ones() as usize).sum()
    }

    /// The degenerate triangles, in increasing order.
    pub fn iter(&self) -> impl Iterator<Item = usize> + '_ {
        (0..MAX_TRIANGLES).filter(|&t| self.contains(t))
    }
}
