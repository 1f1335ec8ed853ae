//! The capture pipeline: per frame, an actor's raw markers become the character's markers.
//!
//! A live stream has no baker between the camera and the face, so a rig may carry these stages
//! ([`Stages`], optional in the blob) and the runtime runs them before deforming:
//!
//! 1. **Input check.** A marker is missing when the caller says so (`None`) or when a coordinate
//!    lies beyond ±64 actor units ([`INPUT_LIMIT`]); the latter is reported as rejected.
//! 2. **Head-motion compensation** ([`rigid`]): the least-squares rigid motion of the present
//!    head markers from the neutral frame (Horn's quaternion method in fixed point). A head
//!    marker whose residual exceeds `max_displacement` is dropped and the fit done once more.
//!    With fewer than three usable head markers, or collinear ones, the last good fit is held.
//! 3. **Plausibility.** A compensated marker further than `max_displacement` from its neutral
//!    position is rejected (a swapped or ghost marker).
//! 4. **Fill** ([`fill`]): a missing or rejected marker moves with the weighted mean displacement
//!    of its present baked neighbours; with none present it holds its last good displacement
//!    (zero if it was never seen).
//! 5. **Retargeting** ([`retarget`]): the baked RBF map carries each compensated actor marker into
//!    the character's rig space.
//!
//! Every loop runs a number of times fixed by the rig; [`Stages::cost`] states it.

pub mod fill;
pub mod retarget;
pub mod rigid;

use serde::{Deserialize, Serialize};

use crate::format::{
    f32_is_finite, f32_is_positive, read_position, Bytes, Space, MAX_MARKERS, POSITION_BYTES,
};
use rigid::{HeadPairs, RigidFit};

/// Most head markers a rig may name.
pub const MAX_HEAD_MARKERS: usize = 32;
/// Neighbours stored per marker for rebuilding it.
pub const FILL_NEIGHBOURS: usize = 4;
/// Fractional bits of a fill weight.
pub const FILL_FRAC_BITS: u32 = 16;
/// Largest accepted input coordinate magnitude: 64 actor units in Q8.24.
pub const INPUT_LIMIT: i32 = 1 << 30;
/// Largest accepted neutral coordinate or retarget radius: 4 actor units in Q8.24.
pub const NEUTRAL_LIMIT: i32 = 1 << 26;
/// Largest accepted retarget coefficient magnitude (24-bit).
pub const ALPHA_LIMIT: i32 = (1 << 23) - 1;
/// Largest accepted `alpha_shift`.
pub const MAX_ALPHA_SHIFT: u8 = 48;
/// Accepted `linear_shift` range.
pub const LINEAR_SHIFTS: core::ops::RangeInclusive<u8> = 1..=40;

/// The baked retargeting map (see [`retarget`] for the formula and formats).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Retarget<'a> {
    /// Per actor neutral marker: its kernel radius rᵢ, `i32` LE, Q8.24 actor units.
    #[serde(borrow)]
    pub radii: Bytes<'a>,
    /// Scale exponent of `alpha`: α̃ = q · 2^−alpha_shift, in character rig units.
    pub alpha_shift: u8,
    /// Per actor neutral marker: α̃ᵢ as 3 × `i32` LE, each below 2²³ in magnitude.
    #[serde(borrow)]
    pub alpha: Bytes<'a>,
    /// Scale exponent of `linear`.
    pub linear_shift: u8,
    /// L, row-major: character rig units per actor unit, q · 2^−linear_shift.
    pub linear: [i32; 9],
    /// b, Q8.24 character rig units.
    pub offset: [i32; 3],
}

/// Proportional retargeting (paper 003 §4, the simple option): each character marker moves from
/// its rest position by a fixed 3 × 3 matrix times its compensated actor displacement,
/// `f_j(a) = v_j + M_j (a − u_j)`. The baker builds `M_j` from per-region scale factors and the
/// rotation between the two faces. 9 multiply-adds per marker.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PerMarker<'a> {
    /// Scale exponent of `matrices`: entries are `q · 2^−shift`, in [1, 40].
    pub shift: u8,
    /// Per marker, M_j row-major as 9 × `i32` LE: character rig units per actor unit.
    #[serde(borrow)]
    pub matrices: Bytes<'a>,
    /// Per marker, v_j: the character marker's rest position, 3 × `i32` LE, Q8.24 rig units.
    #[serde(borrow)]
    pub rest: Bytes<'a>,
}

/// How compensated actor markers become character markers.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum RetargetForm<'a> {
    /// The RBF map of paper 000 (inverse multiquadric + affine).
    #[serde(borrow)]
    Rbf(Retarget<'a>),
    /// Per-marker linear maps (paper 003 §4's proportional scaling).
    #[serde(borrow)]
    PerMarker(PerMarker<'a>),
}

/// The capture stages of a rig (see the module docs). Markers are the rig's markers, in the
/// rig's order: actor marker `j` drives character marker `j`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Stages<'a> {
    /// Actor units in the capture's space: `actor = (capture − centre) / half_extent`, Q8.24.
    pub actor_space: Space,
    /// The actor's neutral markers, 3 × `i32` LE (Q8.24 actor units) each, within ±4 units.
    #[serde(borrow)]
    pub actor_neutral: Bytes<'a>,
    /// Head markers for compensation: `u8` indices, strictly ascending; none (no
    /// compensation) or 3 to [`MAX_HEAD_MARKERS`].
    #[serde(borrow)]
    pub head_markers: Bytes<'a>,
    /// Largest plausible displacement of a compensated marker from its neutral position,
    /// Q8.24 actor units, in (0, [`INPUT_LIMIT`]].
    pub max_displacement: i32,
    /// Per marker, [`FILL_NEIGHBOURS`] packed words (neighbour index, Q8.16 weight ≥ 0; weight 0
    /// marks an unused slot), `u32` LE.
    #[serde(borrow)]
    pub fill: Bytes<'a>,
    /// The retargeting map.
    #[serde(borrow)]
    pub retarget: RetargetForm<'a>,
    /// Static anchors (paper 003): `u8` marker indices, strictly ascending, none of them a head
    /// marker. Their samples are ignored and, having no fill neighbours, they are held at zero
    /// displacement: the character's markers stay at rest and pin the skin around them.
    #[serde(borrow)]
    pub anchors: Bytes<'a>,
}

/// Why a rig's capture stages are invalid. Every variant is a distinct failure.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StagesError {
    /// `actor_space` holds a non-finite value or a non-positive half extent.
    BadActorSpace,
    /// A section's length disagrees with the marker count.
    SectionLength {
        /// Which section.
        section: StagesSection,
        /// Bytes the counts imply.
        expected: usize,
        /// Bytes the section has.
        found: usize,
    },
    /// An actor neutral coordinate lies beyond ±[`NEUTRAL_LIMIT`].
    NeutralOutOfRange {
        /// The marker.
        marker: usize,
    },
    /// Head markers: a count other than 0 or 3..=32, an index out of range, or not ascending.
    BadHeadMarkers,
    /// Anchors: an index out of range, not ascending, a head marker, or one with fill neighbours.
    BadAnchors,
    /// `max_displacement` is not in (0, [`INPUT_LIMIT`]].
    BadMaxDisplacement,
    /// A fill neighbour names a missing marker or the marker itself, or has a negative weight.
    BadFillNeighbour {
        /// The marker being rebuilt.
        marker: usize,
    },
    /// A retarget radius is not in (0, [`NEUTRAL_LIMIT`]].
    BadRadius {
        /// The marker.
        marker: usize,
    },
    /// A retarget coefficient is beyond ±[`ALPHA_LIMIT`].
    AlphaOutOfRange {
        /// The marker.
        marker: usize,
    },
    /// `alpha_shift` above [`MAX_ALPHA_SHIFT`] or `linear_shift` outside [`LINEAR_SHIFTS`].
    BadShift,
}

/// A section of the capture stages, for [`StagesError::SectionLength`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StagesSection {
    /// `actor_neutral`
    ActorNeutral,
    /// `fill`
    Fill,
    /// `retarget.radii`
    Radii,
    /// `retarget.alpha`
    Alpha,
    /// per-marker `matrices`
    Matrices,
    /// per-marker `rest`
    Rest,
}

impl core::fmt::Display for StagesError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match *self {
            Self::BadActorSpace => {
                f.write_str("actor space has a non-finite centre or a non-positive extent")
            }
            Self::SectionLength {
                section,
                expected,
                found,
            } => {
                write!(
                    f,
                    "capture section {section:?} has {found} bytes, expected {expected}"
                )
            }
            Self::NeutralOutOfRange { marker } => {
                write!(
                    f,
                    "actor neutral marker {marker} lies beyond ±4 actor units"
                )
            }
            Self::BadHeadMarkers => f.write_str(
                "head markers must be none or 3 to 32 distinct marker indices in ascending order",
            ),
            Self::BadAnchors => f.write_str(
                "anchors must be distinct marker indices in ascending order, not head markers, without fill neighbours",
            ),
            Self::BadMaxDisplacement => {
                f.write_str("max displacement must be in (0, 64] actor units")
            }
            Self::BadFillNeighbour { marker } => {
                write!(f, "marker {marker} has a fill neighbour that is invalid")
            }
            Self::BadRadius { marker } => {
                write!(
                    f,
                    "retarget radius of marker {marker} is not in (0, 4] actor units"
                )
            }
            Self::AlphaOutOfRange { marker } => {
                write!(
                    f,
                    "retarget coefficient of marker {marker} is beyond 24 bits"
                )
            }
            Self::BadShift => f.write_str("retarget scale exponent out of range"),
        }
    }
}

fn expect_len(
    section: StagesSection,
    bytes: Bytes<'_>,
    expected: usize,
) -> Result<(), StagesError> {
    if bytes.0.len() == expected {
        Ok(())
    } else {
        Err(StagesError::SectionLength {
            section,
            expected,
            found: bytes.0.len(),
        })
    }
}

fn le_i32(b: &[u8]) -> i32 {
    i32::from_le_bytes([b[0], b[1], b[2], b[3]])
}

impl<'a> Stages<'a> {
    /// Check every length, index and range against `markers` (the rig's marker count, already
    /// validated to 1..=256).
    pub fn validate(&self, markers: usize) -> Result<(), StagesError> {
        let s = self.actor_space;
        if !(s.centre.iter().all(|&c| f32_is_finite(c))
            && f32_is_finite(s.half_extent)
            && f32_is_positive(s.half_extent))
        {
            return Err(StagesError::BadActorSpace);
        }
        expect_len(
            StagesSection::ActorNeutral,
            self.actor_neutral,
            markers * POSITION_BYTES,
        )?;
        for (marker, p) in self
            .actor_neutral
            .0
            .chunks_exact(POSITION_BYTES)
            .enumerate()
        {
            if read_position(p)
                .iter()
                .any(|c| c.unsigned_abs() > NEUTRAL_LIMIT as u32)
            {
                return Err(StagesError::NeutralOutOfRange { marker });
            }
        }
        let head = self.head_markers.0;
        let ascending = head.windows(2).all(|w| w[0] < w[1]);
        let in_range = head.iter().all(|&h| usize::from(h) < markers);
        let count_ok = head.is_empty() || (3..=MAX_HEAD_MARKERS).contains(&head.len());
        if !(ascending && in_range && count_ok) {
            return Err(StagesError::BadHeadMarkers);
        }
        let anchors = self.anchors.0;
        let anchor_fill_empty = |a: u8| {
            self.fill
                .0
                .get(
                    usize::from(a) * FILL_NEIGHBOURS * 4
                        ..(usize::from(a) + 1) * FILL_NEIGHBOURS * 4,
                )
                .is_some_and(|w| {
                    w.chunks_exact(4)
                        .all(|x| crate::fixed::unpack_influence(le_i32(x) as u32).1 == 0)
                })
        };
        if !(anchors.windows(2).all(|w| w[0] < w[1])
            && anchors
                .iter()
                .all(|&a| usize::from(a) < markers && !head.contains(&a)))
        {
            return Err(StagesError::BadAnchors);
        }
        if !(1..=INPUT_LIMIT).contains(&self.max_displacement) {
            return Err(StagesError::BadMaxDisplacement);
        }
        expect_len(
            StagesSection::Fill,
            self.fill,
            markers * FILL_NEIGHBOURS * 4,
        )?;
        for (marker, words) in self.fill.0.chunks_exact(FILL_NEIGHBOURS * 4).enumerate() {
            for w in words.chunks_exact(4) {
                let (k, weight) = crate::fixed::unpack_influence(le_i32(w) as u32);
                let k = usize::from(k);
                if weight < 0 || (weight > 0 && (k >= markers || k == marker)) {
                    return Err(StagesError::BadFillNeighbour { marker });
                }
            }
        }
        if !anchors.iter().all(|&a| anchor_fill_empty(a)) {
            return Err(StagesError::BadAnchors);
        }
        let r = match &self.retarget {
            RetargetForm::Rbf(r) => r,
            RetargetForm::PerMarker(p) => {
                if !LINEAR_SHIFTS.contains(&p.shift) {
                    return Err(StagesError::BadShift);
                }
                expect_len(StagesSection::Matrices, p.matrices, markers * 36)?;
                return expect_len(StagesSection::Rest, p.rest, markers * POSITION_BYTES);
            }
        };
        if r.alpha_shift > MAX_ALPHA_SHIFT || !LINEAR_SHIFTS.contains(&r.linear_shift) {
            return Err(StagesError::BadShift);
        }
        expect_len(
            StagesSection::Radii,
            r.radii,
            markers * retarget::RADIUS_BYTES,
        )?;
        expect_len(
            StagesSection::Alpha,
            r.alpha,
            markers * retarget::ALPHA_BYTES,
        )?;
        for (marker, radius) in r.radii.0.chunks_exact(4).enumerate() {
            if !(1..=NEUTRAL_LIMIT).contains(&le_i32(radius)) {
                return Err(StagesError::BadRadius { marker });
            }
        }
        for (marker, alpha) in r.alpha.0.chunks_exact(12).enumerate() {
            if read_position(alpha)
                .iter()
                .any(|c| c.unsigned_abs() > ALPHA_LIMIT as u32)
            {
                return Err(StagesError::AlphaOutOfRange { marker });
            }
        }
        Ok(())
    }

    /// Number of markers.
    pub fn marker_count(&self) -> usize {
        self.actor_neutral.0.len() / POSITION_BYTES
    }

    /// The actor's neutral position of marker `i` (Q8.24 actor units); `None` out of range.
    pub fn neutral(&self, i: usize) -> Option<[i32; 3]> {
        self.actor_neutral
            .0
            .get(i * POSITION_BYTES..(i + 1) * POSITION_BYTES)
            .map(read_position)
    }

    /// The head markers used for compensation.
    pub fn head_markers(&self) -> &'a [u8] {
        self.head_markers.0
    }

    /// The work of one frame, fixed by the rig.
    pub fn cost(&self) -> StagesCost {
        let markers = self.marker_count();
        let head = self.head_markers.0.len();
        StagesCost {
            markers,
            head_markers: head,
            rigid_fits: if head > 0 { 2 } else { 0 },
            horn_squarings: if head > 0 { 2 * rigid::SQUARINGS } else { 0 },
            fill_terms: markers * FILL_NEIGHBOURS,
            retarget_kernels: match self.retarget {
                RetargetForm::Rbf(_) => markers * markers,
                RetargetForm::PerMarker(_) => 0,
            },
            retarget_multiply_adds: match self.retarget {
                RetargetForm::Rbf(_) => 3 * markers * markers + 9 * markers,
                RetargetForm::PerMarker(_) => 9 * markers,
            },
        }
    }

    /// Run the stages on one frame (see the module docs): `actor` holds one entry per marker
    /// (Q8.24 actor units, `None` when missing); `out` receives the character's markers (Q8.24
    /// rig units). The caller checks the slice lengths ([`crate::Rig::play`] does).
    pub fn solve(
        &self,
        state: &mut PlayState,
        actor: &[Option<[i32; 3]>],
        out: &mut [[i32; 3]],
    ) -> FrameReport {
        let markers = self.marker_count().min(actor.len()).min(out.len());
        let mut report = FrameReport::default();
        let mut present = MarkerSet::EMPTY;
        for (j, p) in actor.iter().enumerate().take(markers) {
            match p {
                _ if self.anchors.0.contains(&(j as u8)) => {}
                Some(p) if p.iter().all(|c| c.unsigned_abs() <= INPUT_LIMIT as u32) => {
                    present.insert(j)
                }
                Some(_) => report.rejected.insert(j),
                None => {}
            }
        }

        let fit = self.fit_head(state, actor, &present, &mut report);

        let mut displacement = [[0i32; 3]; MAX_MARKERS];
        let limit = i64::from(self.max_displacement);
        for (j, slot) in displacement.iter_mut().enumerate().take(markers) {
            let (Some(Some(p)), Some(u)) = (
                actor.get(j).filter(|_| present.contains(j)),
                self.neutral(j),
            ) else {
                continue;
            };
            let a = fit.compensate(*p);
            let d = [0, 1, 2].map(|c| i64::from(a[c]) - i64::from(u[c]));
            // The squares are only formed once every |d| ≤ limit ≤ 2^30: below 2^62 in all.
            let far = d.iter().any(|v| v.abs() > limit)
                || d.iter().map(|v| v * v).sum::<i64>() > limit * limit;
            if far {
                present.remove(j);
                report.rejected.insert(j);
            } else {
                // |d| ≤ max_displacement ≤ 2^30.
                *slot = d.map(|v| v as i32);
            }
        }

        for j in 0..markers {
            if present.contains(j) {
                state.last[j] = displacement[j];
                state.seen.insert(j);
                continue;
            }
            let words = self
                .fill
                .0
                .get(j * FILL_NEIGHBOURS * 4..(j + 1) * FILL_NEIGHBOURS * 4)
                .unwrap_or(&[]);
            if let Some(d) = fill::rebuild(words, &displacement[..markers], &present) {
                displacement[j] = d;
                report.rebuilt.insert(j);
            } else {
                displacement[j] = if state.seen.contains(j) {
                    state.last[j]
                } else {
                    [0; 3]
                };
                report.held.insert(j);
            }
        }

        for (j, (o, d)) in out.iter_mut().zip(&displacement).enumerate().take(markers) {
            *o = match &self.retarget {
                RetargetForm::Rbf(r) => {
                    let u = self.neutral(j).unwrap_or([0; 3]);
                    let a = [0, 1, 2].map(|c| u[c].saturating_add(d[c]));
                    retarget::map(r, self.actor_neutral.0, a)
                }
                RetargetForm::PerMarker(p) => retarget::per_marker(p, j, *d),
            };
        }
        report
    }

    /// Step 2 of the module docs: the head fit of this frame, or the one held.
    fn fit_head(
        &self,
        state: &mut PlayState,
        actor: &[Option<[i32; 3]>],
        present: &MarkerSet,
        report: &mut FrameReport,
    ) -> RigidFit {
        if self.head_markers.0.is_empty() {
            report.rigid = RigidStatus::NotUsed;
            return RigidFit::IDENTITY;
        }
        let mut pairs = HeadPairs::new();
        for &h in self.head_markers.0 {
            let h = usize::from(h);
            if let (true, Some(Some(q)), Some(p)) =
                (present.contains(h), actor.get(h), self.neutral(h))
            {
                pairs.push(p, *q);
            }
        }
        let mut fitted = pairs.fit();
        if let Ok(fit) = fitted {
            let limit = self.max_displacement;
            let before = pairs.len();
            let residuals: [i32; MAX_HEAD_MARKERS] = core::array::from_fn(|i| {
                if i < before {
                    pairs.residual(&fit, i)
                } else {
                    0
                }
            });
            pairs.retain(|i| residuals[i] <= limit);
            if pairs.len() < before {
                report.head_markers_dropped = (before - pairs.len()) as u8;
                fitted = pairs.fit();
            }
        }
        match fitted {
            Ok(fit) => {
                report.rigid = RigidStatus::Fitted {
                    head_markers: pairs.len() as u8,
                };
                report.rigid_residual = pairs.rms_residual(&fit);
                state.fit = Some(fit);
                fit
            }
            Err(why) => {
                report.rigid = RigidStatus::Held(why);
                state.fit.unwrap_or(RigidFit::IDENTITY)
            }
        }
    }
}

/// The work of one frame of the capture stages.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StagesCost {
    /// Markers in and out.
    pub markers: usize,
    /// Head markers.
    pub head_markers: usize,
    /// Rigid fits at most (one, plus one after dropping outlying head markers).
    pub rigid_fits: usize,
    /// 4 × 4 matrix squarings at most.
    pub horn_squarings: usize,
    /// Fill terms at most (markers × neighbours).
    pub fill_terms: usize,
    /// Inverse-multiquadric kernel evaluations (markers² for the RBF map, 0 per-marker), each
    /// one `rsqrt_u64`.
    pub retarget_kernels: usize,
    /// Multiply-adds: the RBF map's kernel terms (3 per kernel) and affine part, or the
    /// per-marker matrices.
    pub retarget_multiply_adds: usize,
}

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
    /// No fit this frame; the last good one (or none) was used.
    Held(rigid::FitFailure),
}

/// What the capture stages did with one frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FrameReport {
    /// Head-motion compensation.
    pub rigid: RigidStatus,
    /// RMS distance of the fitted head markers from their rigid positions, Q8.24 actor units.
    pub rigid_residual: i32,
    /// Head markers dropped from the fit for a residual above `max_displacement`.
    pub head_markers_dropped: u8,
    /// Markers given but rejected (coordinates out of range, or implausibly far from neutral).
    pub rejected: MarkerSet,
    /// Markers rebuilt from their neighbours.
    pub rebuilt: MarkerSet,
    /// Markers held at their last good displacement (or neutral if never seen).
    pub held: MarkerSet,
}

/// What the capture stages remember between frames: the last good displacement of every marker
/// and the last good head fit. About 3 KB; no allocation.
#[derive(Clone, Debug)]
pub struct PlayState {
    last: [[i32; 3]; MAX_MARKERS],
    seen: MarkerSet,
    fit: Option<RigidFit>,
}

impl Default for PlayState {
    fn default() -> Self {
        Self::new()
    }
}

impl PlayState {
    /// A fresh state: nothing seen yet.
    pub const fn new() -> Self {
        Self {
            last: [[0; 3]; MAX_MARKERS],
            seen: MarkerSet::EMPTY,
            fit: None,
        }
    }

    /// The last good head fit.
    pub fn last_fit(&self) -> Option<RigidFit> {
        self.fit
    }
}
