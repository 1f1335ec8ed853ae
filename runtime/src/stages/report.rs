//! What the capture stages did with one frame ([`FrameReport`]), and the marker sets it is made
//! of.

use crate::records::MAX_MARKERS;
use crate::stages::compensate::FitFailure;

/// A set of marker indices (0..256), as a bitset.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MarkerSet([u32; MAX_MARKERS / 32]);

impl MarkerSet {
    /// No markers.
    pub const EMPTY: Self = Self([0; MAX_MARKERS / 32]);

    /// Whether marker `i` is in the set.
    pub fn contains(&self, i: usize) -> bool {
        self.0.get(i / 32).is_some_and(|w| w & (1 << (i % 32)) != 0)
    }

    /// Add marker `i` (ignored beyond 255).
    pub fn insert(&mut self, i: usize) {
        if let Some(w) = self.0.get_mut(i / 32) {
            *w |= 1 << (i % 32);
        }
    }

    /// Remove marker `i`.
    pub fn remove(&mut self, i: usize) {
        if let Some(w) = self.0.get_mut(i / 32) {
            *w &= !(1 << (i % 32));
        }
    }

    /// Number of markers in the set.
    pub fn len(&self) -> usize {
        self.0.iter().map(|w| w.count_ones() as usize).sum()
    }

    /// Whether the set is empty.
    pub fn is_empty(&self) -> bool {
        self.0.iter().all(|&w| w == 0)
    }

    /// The markers in the set, ascending.
    pub fn iter(&self) -> impl Iterator<Item = usize> + '_ {
        (0..MAX_MARKERS).filter(|&i| self.contains(i))
    }
}


/// How the head motion of a frame was found.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum RigidStatus {
    /// The rig has no head markers: no compensation.
    #[default]
    NotUsed,
    /// Fitted from this many head markers.
    Fitted {
        /// Head markers used.
        head_markers: u8,
    },
    /// Fewer than three head markers were present (this many): the pose was tracked from the
    /// last frame through them and the other markers present in both frames.
    Tracked {
        /// Head markers present (0 to 2).
        head_markers: u8,
    },
    /// No fit this frame; the last good one (or none) was used.
    Held(FitFailure),
}

/// What the capture stages did with one frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FrameReport {
    /// Head-motion compensation.
    pub rigid: RigidStatus,
    /// RMS distance of the fitted head markers from their rigid positions, Q8.24 actor units.
    pub rigid_residual: i32,
    /// Head markers dropped from the fit (also in [`Self::rejected`]): for breaking the head's
    /// shape, or for a residual above `head_tolerance`.
    pub head_markers_dropped: u8,
    /// Markers given but rejected (coordinates out of range, a head marker that broke the
    /// head's shape, implausibly far from neutral, or a jump).
    pub rejected: MarkerSet,
    /// Of [`Self::rejected`], the markers that moved further than `max_step` × the frames since
    /// their last good displacement (a swap or a jump).
    pub jumped: MarkerSet,
    /// Markers rebuilt from their neighbours.
    pub rebuilt: MarkerSet,
    /// Markers held at their last good displacement (or neutral if never seen).
    pub held: MarkerSet,
}

