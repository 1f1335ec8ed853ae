//! The capture stages: per frame, an actor's raw markers become the character's markers.
//!
//! A live stream has no baker between the camera and the face, so a rig may carry these stages
//! ([`Stages`], optional in the blob) and the runtime runs them before deforming:
//!
//! 1. **Input check.** A marker is missing when the caller says so (`None`) or when a coordinate
//!    lies beyond ±64 actor units ([`INPUT_LIMIT`]); the latter is reported as rejected. Static
//!    anchors ignore their samples.
//! 2. **Head-motion compensation** ([`compensate`]): the present head markers must keep the
//!    neutral head's shape: one whose distances to more than half of the others changed by more
//!    than `head_tolerance` is rejected (a swapped, jumped or ghost head marker). Then the
//!    least-squares rigid motion of the rest from the neutral frame (Horn's quaternion method in
//!    fixed point); the head marker furthest from the fit, if further than `head_tolerance`, is
//!    rejected and the fit done once more. Then, when the rig carries a refit cutoff, the fit
//!    is done again over the face ([`refit`]): every marker weighted by how still it held
//!    (Tukey's biweight of its displacement in the last frame and half its motion since), the
//!    head markers among them, so a brow raise lifting the forehead's head markers is not read
//!    as the head pitching and the head markers' jitter is averaged over the still skin. With
//!    fewer than three head markers present, the pose is tracked from the last frame through
//!    the head markers present and every other marker present in both frames
//!    ([`RigidStatus::Tracked`]). With too few for that, or collinear or
//!    coincident head markers (in the neutral frame or in this one), the last good fit is held
//!    and the report says why ([`RigidStatus::Held`]).
//! 3. **Plausibility.** A compensated marker further than `max_displacement` from its neutral
//!    position is rejected (a ghost marker), and so is one that moved further than
//!    `max_step` × the frames since its last good displacement (a swap or a jump: reported in
//!    [`FrameReport::jumped`] too). The growing bound lets a marker that really moved that far
//!    back in after a few frames. **The head markers hold still**: what is left of a head
//!    marker's motion once the head's rigid motion is taken out is the fit's residual (noise,
//!    skin sliding over the skull), not expression, so its displacement is zero from here on,
//!    present or not. Otherwise the skin around it would carry its noise: JawMoCap with ±0.5 mm
//!    jitter moved the forehead beside a head marker 1.08 mm, against 0.46 mm held still.
//! 4. **Fill** ([`fill`]): a missing or rejected marker is put where its present baked
//!    neighbours say, each at its displacement plus the marker's offset from it when both were
//!    last seen (decaying while the marker is missing), weighted; with none present it holds
//!    its last good displacement (zero if it was never seen).
//! 5. **Smoothing** ([`smoothing`], optional): a one-euro filter on every marker's displacement,
//!    in the head's frame; its lag when still is [`smoothing::Smoothing::still_lag_frames`]. The
//!    head fit's own jitter moves every compensated marker rigidly and is filtered here with the
//!    rest, so it is not multiplied by the lever arm into the face; the head markers themselves
//!    are not smoothed before the fit, so head motion is compensated without lag (smoothing them
//!    lagged a moving head by up to 8 mm of face on JawMoCap).
//! 6. **Retargeting** ([`retarget`]): the baked map carries each compensated actor marker into
//!    the character's rig space.
//!
//! `max_step` and the smoothing are per frame at the rate of the capture the stages were baked
//! from; a stream at another rate plays, with the bound and the lag scaled by the ratio.
//!
//! [`report`] says what happened to each marker. Each step's module validates its part of the
//! section at load ([`crate::error::StagesLoadError`]). Every loop runs a number of times
//! fixed by the rig; [`Stages::cost`] states it.

pub mod compensate;
pub mod fill;
pub mod report;
pub mod retarget;
pub mod refit;
pub mod smoothing;

use serde::{Deserialize, Serialize};

use crate::error::{expect_stages_len, StagesLoadError, StagesSection};
use crate::records::{
    read_position, Bytes, FILL_BYTES, MAX_MARKERS, POSITION_BYTES,
};
use crate::space::Space;
use crate::stages::compensate::{
    FitFailure, HeadPairs, RigidFit, MAX_HEAD_MARKERS, MIN_HEAD_MARKERS,
};
use crate::stages::refit::{Biweight, WeightedPairs, FULL_WEIGHT, HEAD_WEIGHT_FLOOR, REFIT_MARKERS};
use crate::stages::report::{FrameReport, MarkerSet, RigidStatus};
use crate::stages::retarget::{Retarget, NEUTRAL_LIMIT};
use crate::fixed::POS_FRAC_BITS;
use crate::stages::smoothing::{MarkerFilter, Smoothing};

/// How many times a present head marker counts in a frame whose pose is tracked from the last
/// frame (`Stages::track`), and how many pairs such a frame fits at most. FaceCap rehearsal
/// with occlusions in runs, face error over the 70 tracked frames against the same take
/// without the runs (`docs/measurements.md`), (pairs, times): (32, 1) 0.54, (32, 4) 0.53,
/// (32, 8) 0.36, (32, 12) 0.41, (24, 6) 0.43, **(16, 4) 0.35**, (16, 2) 0.40, (16, 6) 0.49,
/// (12, 3) 0.39, (8, 2) 0.46 mm. Each pair costs the Cortex-M4 about 1,400 instructions
/// (the fit's sums and the residual): 32 pairs took the budget frame to 25.9 % of a 60 fps
/// frame, 16 keep it at 24.9 % (`.ci/cross.sh`).
pub const PRESENT_WEIGHT: usize = 4;

/// Most pairs a tracked frame fits (see [`PRESENT_WEIGHT`]).
pub const TRACKED_PAIRS: usize = 16;

/// Largest accepted input coordinate magnitude: 64 actor units in Q8.24.
pub const INPUT_LIMIT: i32 = 1 << 30;

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
    /// Per marker, [`FILL_NEIGHBOURS`](crate::records::FILL_NEIGHBOURS) packed words (neighbour index, Q8.16 weight ≥ 0; weight 0
    /// marks an unused slot), `u32` LE.
    #[serde(borrow)]
    pub fill: Bytes<'a>,
    /// The retargeting map.
    #[serde(borrow)]
    pub retarget: Retarget<'a>,
    /// Static anchors (paper 003): `u8` marker indices, strictly ascending, none of them a head
    /// marker. Their samples are ignored and, having no fill neighbours, they are held at zero
    /// displacement: the character's markers stay at rest and pin the skin around them.
    #[serde(borrow)]
    pub anchors: Bytes<'a>,
    /// Largest change of a head-marker pair's distance from the neutral frame that keeps the
    /// pair rigid, Q8.24 actor units, in (0, [`INPUT_LIMIT`]].
    pub head_tolerance: i32,
    /// Largest plausible movement of a compensated marker from one frame to the next, Q8.24
    /// actor units per frame, in (0, [`INPUT_LIMIT`]].
    pub max_step: i32,
    /// The smoothing filter, or none.
    pub smoothing: Option<Smoothing>,
    /// The head pose's smoothing filter, or none: step 2's fit, filtered as the motion of four
    /// points of the head ([`HEAD_FRAME_POINTS`]) and fitted again, so that a head fit from a
    /// few close head markers does not pass their jitter, magnified, to every marker.
    pub head_smoothing: Option<Smoothing>,
    /// Step 2's refit over the face ([`refit`]): the cutoff of its weights, Q8.24 actor units,
    /// 0 (no refit) or in [[`refit::MIN_REFIT_CUTOFF`], [`refit::MAX_REFIT_CUTOFF`]].
    pub refit_cutoff: i32,
}


impl<'a> Stages<'a> {
    /// Check every length, index and range against `markers` (the rig's marker count, already
    /// validated to 1..=256).
    pub(crate) fn validate(&self, markers: usize) -> Result<(), StagesLoadError> {
        if !self.actor_space.is_valid() {
            return Err(StagesLoadError::BadActorSpace);
        }
        expect_stages_len(
            StagesSection::ActorNeutral,
            self.actor_neutral,
            markers,
            POSITION_BYTES,
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
                return Err(StagesLoadError::NeutralOutOfRange { marker });
            }
        }
        compensate::validate(self.head_markers, markers)?;
        let head = self.head_markers.0;
        let anchors = self.anchors.0;
        if !(anchors.windows(2).all(|w| w[0] < w[1])
            && anchors
                .iter()
                .all(|&a| usize::from(a) < markers && !head.contains(&a)))
        {
            return Err(StagesLoadError::BadAnchors);
        }
        if !(1..=INPUT_LIMIT).contains(&self.max_displacement) {
            return Err(StagesLoadError::BadMaxDisplacement);
        }
        if !(1..=INPUT_LIMIT).contains(&self.head_tolerance) {
            return Err(StagesLoadError::BadHeadTolerance);
        }
        if !(1..=INPUT_LIMIT).contains(&self.max_step) {
            return Err(StagesLoadError::BadMaxStep);
        }
        if self.refit_cutoff != 0
            && !(refit::MIN_REFIT_CUTOFF..=refit::MAX_REFIT_CUTOFF).contains(&self.refit_cutoff)
        {
            return Err(StagesLoadError::BadRefitCutoff);
        }
        for smoothing in [&self.smoothing, &self.head_smoothing].into_iter().flatten() {
            smoothing.validate()?;
        }
        fill::validate(self.fill, markers)?;
        if !anchors
            .iter()
            .all(|&a| fill::has_no_neighbours(self.fill, usize::from(a)))
        {
            return Err(StagesLoadError::BadAnchors);
        }
        self.retarget.validate(markers)
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
    #[cfg(feature = "format")]
    pub fn head_markers(&self) -> &'a [u8] {
        self.head_markers.0
    }

    /// Rigid fits per frame at most: one, then with a head marker off it one per head marker
    /// left out and one without the worst, one over the face ([`refit`]) and one of the
    /// smoothed head points.
    #[cfg(feature = "format")]
    fn rigid_fits(&self) -> usize {
        match self.head_markers.0.len() {
            0 => 0,
            head => {
                head + 2
                    + usize::from(self.refit_cutoff > 0)
                    + usize::from(self.head_smoothing.is_some())
            }
        }
    }

    /// The work of one frame, fixed by the rig.
    #[cfg(feature = "format")]
    pub fn cost(&self) -> StagesCost {
        let markers = self.marker_count();
        let head = self.head_markers.0.len();
        StagesCost {
            markers,
            head_markers: head,
            head_distance_checks: head * head.saturating_sub(1) / 2,
            rigid_fits: self.rigid_fits(),
            horn_squarings: self.rigid_fits() * compensate::SQUARINGS,
            fill_terms: markers * crate::records::FILL_NEIGHBOURS,
            retarget_kernels: match self.retarget {
                Retarget::Rbf(_) => markers * markers,
                Retarget::Proportional(_) => 0,
            },
            retarget_multiply_adds: match self.retarget {
                Retarget::Rbf(_) => 3 * markers * markers + 9 * markers,
                Retarget::Proportional(_) => 9 * markers,
            },
            step_checks: markers,
            refit_markers: if self.refit_cutoff > 0 && head > 0 {
                (markers - head).min(refit::REFIT_MARKERS)
            } else {
                0
            },
            smoothed_markers: if self.smoothing.is_some() { markers } else { 0 }
                + if self.head_smoothing.is_some() && head > 0 {
                    HEAD_FRAME_POINTS.len()
                } else {
                    0
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

        let fit = self.fit_head(state, actor, &mut present, &mut report);

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
            let far = beyond(d, limit);
            // The bound grows with the frames since the last good displacement, so a marker
            // that really moved that far is let back in after a few frames.
            let gap = i64::from(state.gap[j]) + 1;
            let step = (i64::from(self.max_step) * gap).min(i64::from(INPUT_LIMIT));
            let last = state.last[j];
            // Both |d| and |last| are at most max_displacement ≤ 2^30 here.
            let jumped = !far
                && state.seen.contains(j)
                && beyond([0, 1, 2].map(|c| d[c] - i64::from(last[c])), step);
            if far || jumped {
                present.remove(j);
                report.rejected.insert(j);
                if jumped {
                    report.jumped.insert(j);
                }
            } else {
                // |d| ≤ max_displacement ≤ 2^30.
                *slot = d.map(|v| v as i32);
            }
        }
        self.hold_head_markers(&mut displacement[..markers]);

        for j in 0..markers {
            let words = self
                .fill
                .0
                .get(j * FILL_BYTES..(j + 1) * FILL_BYTES)
                .unwrap_or(&[]);
            if present.contains(j) {
                state.last[j] = displacement[j];
                state.seen.insert(j);
                state.gap[j] = 0;
                // Rebuilt markers are not in `present`: offsets are between measured markers.
                state.offsets[j].record(
                    words,
                    displacement[j],
                    &displacement[..markers],
                    &present,
                    self.max_displacement,
                );
                continue;
            }
            state.gap[j] = state.gap[j].saturating_add(1);
            let offsets = &mut state.offsets[j];
            let rebuilt = fill::rebuild(words, &displacement[..markers], &present, offsets, limit);
            offsets.decay();
            if let Some(d) = rebuilt {
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
        // A missing head marker too (fill may have rebuilt it from its neighbours).
        self.hold_head_markers(&mut displacement[..markers]);

        if let Some(smoothing) = &self.smoothing {
            let alpha_d = smoothing.derivative_alpha();
            for (j, (d, filter)) in displacement
                .iter_mut()
                .zip(state.filters.iter_mut())
                .enumerate()
                .take(markers)
            {
                if self.head_markers.0.contains(&(j as u8)) {
                    // Held at zero; its filter smooths its residual (`keep_residuals`).
                    continue;
                }
                *d = smoothing.step(alpha_d, filter, *d, !state.filtering.contains(j));
                state.filtering.insert(j);
            }
        }

        for (j, (o, d)) in out.iter_mut().zip(&displacement).enumerate().take(markers) {
            let u = self.neutral(j).unwrap_or([0; 3]);
            *o = self.retarget.map(self.actor_neutral.0, j, u, *d);
        }
        report
    }

    /// Step 3's last part: every head marker's displacement is zero (they hold still once the
    /// head's motion is taken out).
    fn hold_head_markers(&self, displacement: &mut [[i32; 3]]) {
        for &h in self.head_markers.0 {
            if let Some(d) = displacement.get_mut(usize::from(h)) {
                *d = [0; 3];
            }
        }
    }

    /// Step 2 of the module docs: the head fit of this frame, or the one held. Head markers that
    /// broke the head's shape are taken out of `present` and reported as rejected.
    fn fit_head(
        &self,
        state: &mut PlayState,
        actor: &[Option<[i32; 3]>],
        present: &mut MarkerSet,
        report: &mut FrameReport,
    ) -> RigidFit {
        if self.head_markers.0.is_empty() {
            report.rigid = RigidStatus::NotUsed;
            return RigidFit::IDENTITY;
        }
        let mut pairs = HeadPairs::new();
        // Per pair: its marker.
        let mut which = [0usize; MAX_HEAD_MARKERS];
        for &h in self.head_markers.0 {
            let h = usize::from(h);
            if let (true, Some(Some(q)), Some(p)) =
                (present.contains(h), actor.get(h), self.neutral(h))
            {
                if let Some(slot) = which.get_mut(pairs.len()) {
                    *slot = h;
                }
                pairs.push(p, *q);
            }
        }
        // Whether the pairs' neutral points carry the residuals (`fit_to_residuals`).
        let mut corrected = false;
        // The head markers present when the pose is tracked from the last frame (`track`).
        let mut tracked = None;
        let mut fitted = if pairs.len() >= 3 && pairs.current_collinear() {
            Err(FitFailure::Collinear)
        } else {
            let given = pairs.len();
            let kept = pairs.rigid(self.head_tolerance);
            for (i, &h) in which.iter().enumerate().take(given) {
                if kept & (1 << i) == 0 {
                    present.remove(h);
                    report.rejected.insert(h);
                }
            }
            pairs.retain(|i| kept & (1 << i) != 0);
            let mut at = 0;
            for i in 0..given {
                if kept & (1 << i) != 0 {
                    which[at] = which[i];
                    at += 1;
                }
            }
            report.head_markers_dropped = (given - pairs.len()) as u8;
            corrected = self.fit_to_residuals(state, &mut pairs, &which);
            match pairs.fit() {
                Err(FitFailure::TooFew) if given >= 3 => Err(FitFailure::NotRigid),
                Err(FitFailure::TooFew) => {
                    let head_present = pairs.len();
                    if self.track(state, &mut pairs, actor, present) {
                        tracked = Some(head_present as u8);
                        pairs.fit()
                    } else {
                        Err(FitFailure::TooFew)
                    }
                }
                other => other,
            }
        };
        // A tracked pose (`track`) is not checked against the head tolerance (it is one fit
        // of mostly the face's markers) and gives no residual.
        if let (Ok(fit), None) = (fitted, tracked) {
            // A head marker off the fit by more than the head tolerance (a jump across the
            // other markers' distances barely changes them, but it does not move with the
            // rest): the one whose leaving out fits the others best is dropped, and the fit
            // done once more. The least-squares fit spreads one marker's error over all, so the
            // furthest marker is not always the culprit.
            let off = pairs.any_beyond(&fit, self.head_tolerance);
            if let Some(w) = off.then(|| pairs.best_left_out()).flatten() {
                let h = which[w];
                present.remove(h);
                report.rejected.insert(h);
                pairs.retain(|i| i != w);
                which.copy_within(w + 1.., w);
                report.head_markers_dropped += 1;
                if !corrected {
                    self.fit_to_residuals(state, &mut pairs, &which);
                }
                fitted = match pairs.fit() {
                    Err(FitFailure::TooFew) => Err(FitFailure::NotRigid),
                    other => other,
                };
            }
        }
        if let (Ok(fit), None) = (&fitted, tracked) {
            if let Some(refit) = self.refit(state, actor, present, &pairs, &which, fit) {
                fitted = Ok(refit);
            }
        }
        if let (Ok(fit), None) = (&fitted, tracked) {
            self.keep_residuals(state, &pairs, &which, fit);
        }
        let fit = match fitted {
            Ok(fit) => {
                report.rigid = match tracked {
                    Some(head_markers) => RigidStatus::Tracked { head_markers },
                    None => RigidStatus::Fitted {
                        head_markers: pairs.len() as u8,
                    },
                };
                report.rigid_residual = pairs.rms_residual(&fit);
                state.fit = Some(fit);
                fit
            }
            Err(why) => {
                report.rigid = RigidStatus::Held(why);
                state.fit.unwrap_or(RigidFit::IDENTITY)
            }
        };
        self.smooth_head(state, fit)
    }

    /// The head markers are not quite rigid (skin over the skull: a brow raise moves the
    /// forehead's markers), so a fit from some of them is not the fit from all: on JawMoCap
    /// with a fifth of the samples dropped, a fit from three of the five moved the chin 12 mm.
    /// So each head marker's residual (its place in the head's frame less its neutral one) is
    /// kept from the last frame that fitted it ([`Self::keep_residuals`]), and a frame that
    /// lacks some head markers fits the others to their neutral places plus their residuals:
    /// the fit they would have with the missing ones where they were. This moves `pairs`'
    /// neutral points so (`which`: each pair's marker) when they are fewer than the head
    /// markers and residuals are known (a frame has fitted every head marker), and says
    /// whether it did. No fit of its own: the frame's fits use the moved points.
    fn fit_to_residuals(
        &self,
        state: &PlayState,
        pairs: &mut HeadPairs,
        which: &[usize; MAX_HEAD_MARKERS],
    ) -> bool {
        let head = self.head_markers.0;
        if pairs.len() >= head.len() || !state.head_residuals_known {
            return false;
        }
        for (i, &h) in which.iter().enumerate().take(pairs.len()) {
            if let Some(k) = self.head_slot(h) {
                // Within ± the head tolerance (≤ 64 units).
                pairs.shift_neutral(i, state.head_residuals[k]);
            }
        }
        true
    }

    /// The head fit `fit` (from the head markers `pairs`, `which`: each pair's marker) done
    /// again over the face (see the module docs): each head pair weighted by the biweight of
    /// its marker's kept residual (at least [`HEAD_WEIGHT_FLOOR`]; [`FULL_WEIGHT`] before
    /// residuals are known), and each of the first [`REFIT_MARKERS`] other markers that is
    /// present now and was measured last frame by the biweight of its last displacement and of
    /// half how far `fit` puts it from there, together: a marker that moved on its own in the last
    /// frame, or since, weighs little or nothing (a jump, a ghost, the first frame of a blink,
    /// or a take whose frames are not consecutive). `None` without a refit cutoff, or when the
    /// fit fails (the head markers' fit stands).
    fn refit(
        &self,
        state: &PlayState,
        actor: &[Option<[i32; 3]>],
        present: &MarkerSet,
        pairs: &HeadPairs,
        which: &[usize; MAX_HEAD_MARKERS],
        fit: &RigidFit,
    ) -> Option<RigidFit> {
        if self.refit_cutoff == 0 {
            return None;
        }
        let biweight = Biweight::new(self.refit_cutoff);
        let mut weighted = WeightedPairs::new();
        for (i, &h) in which.iter().enumerate().take(pairs.len()) {
            let w = match self.head_slot(h) {
                Some(k) if state.head_residuals_known => {
                    biweight.weight(state.head_residuals[k], [0; 3]).max(HEAD_WEIGHT_FLOOR)
                }
                _ => FULL_WEIGHT,
            };
            weighted.push(pairs.neutral(i), pairs.current(i), w);
        }
        let mut head = MarkerSet::EMPTY;
        for &h in self.head_markers.0 {
            head.insert(usize::from(h));
        }
        let face = (0..self.marker_count().min(actor.len()))
            .filter(|&j| !head.contains(j))
            .take(REFIT_MARKERS);
        for j in face {
            let measured_last = state.seen.contains(j) && state.gap[j] == 0;
            let (true, true, Some(Some(q)), Some(u)) =
                (present.contains(j), measured_last, actor.get(j), self.neutral(j))
            else {
                continue;
            };
            let last = state.last[j];
            if last.iter().any(|c| c.unsigned_abs() >= biweight.cut) {
                continue;
            }
            // Where the head markers' fit puts it against where it was last frame, halved
            // (saturated: beyond the cutoff either way). Halved: the motion between two frames
            // carries the jitter twice, and the head markers' fit's own error once more.
            let a = fit.compensate(*q);
            let moved = [0, 1, 2].map(|c| a[c].saturating_sub(u[c]).saturating_sub(last[c]) >> 1);
            weighted.push(u, *q, biweight.weight(last, moved));
        }
        weighted.fit()
    }

    /// With fewer than three head markers present the head's pose cannot be fitted from them,
    /// but every marker present in this frame and the last one says where the head went since:
    /// between two frames a face changes little and the head may turn a lot. So `pairs` (the
    /// head markers present, their neutral points moved by their residuals) count
    /// [`PRESENT_WEIGHT`] times each, and every other marker present now and measured last
    /// frame is paired from its place in the head's frame last frame (its neutral place plus
    /// its last displacement) to its place now, in marker order up to [`TRACKED_PAIRS`]
    /// pairs. Their fit is the head's pose (one fit: dropping the pairs far from it and
    /// fitting again never changed a frame of the rehearsals). On the FaceCap rehearsal with
    /// occlusions in runs, 70 frames lacked three head markers; holding the last pose
    /// through them put the face 1.80 mm off (mean over them; up to 18 mm at the end of a run
    /// of 20 while the head turned), against 0.35 mm tracked. Predicting the missing head
    /// markers from the last pose instead gave 1.51 mm: two head markers on a vertical line
    /// (`ForeHead_L`, `Leye_Inside`) do not see the head turning about it. Returns whether
    /// there are pairs enough to fit (none before a first fit: a last frame in the head's frame
    /// is needed).
    fn track(
        &self,
        state: &PlayState,
        pairs: &mut HeadPairs,
        actor: &[Option<[i32; 3]>],
        present: &MarkerSet,
    ) -> bool {
        if pairs.len() >= MIN_HEAD_MARKERS || state.fit.is_none() {
            return false;
        }
        for i in 0..pairs.len() {
            for _ in 1..PRESENT_WEIGHT {
                pairs.push_copy(i);
            }
        }
        for j in 0..self.marker_count().min(actor.len()) {
            if pairs.len() >= TRACKED_PAIRS {
                break;
            }
            let measured_last = state.seen.contains(j) && state.gap[j] == 0;
            if self.head_slot(j).is_some() || !present.contains(j) || !measured_last {
                continue;
            }
            let (Some(Some(q)), Some(u)) = (actor.get(j), self.neutral(j)) else {
                continue;
            };
            // |u| ≤ 4 units and |last| ≤ max_displacement ≤ 2^30: the sum saturates at worst.
            let d = state.last[j];
            pairs.push([0, 1, 2].map(|c| u[c].saturating_add(d[c])), *q);
        }
        pairs.len() >= MIN_HEAD_MARKERS
    }

    /// Marker `h`'s place among the head markers (the index of its residual), if it is one.
    fn head_slot(&self, h: usize) -> Option<usize> {
        self.head_markers.0.iter().position(|&m| usize::from(m) == h)
    }

    /// After a fit from `pairs` (`which`: each pair's marker), each fitted head marker's
    /// residual: its current place brought into the head's frame less its neutral place,
    /// within ± the head tolerance, through the markers' smoothing filter when there is one
    /// (in the head marker's own filter: its displacement is held at zero and not smoothed),
    /// so a noisy capture's residuals are averaged and a clean one's taken as they are.
    /// Residuals are known from the first frame that fits every head marker.
    fn keep_residuals(
        &self,
        state: &mut PlayState,
        pairs: &HeadPairs,
        which: &[usize; MAX_HEAD_MARKERS],
        fit: &RigidFit,
    ) {
        let head = self.head_markers.0;
        if pairs.len() < head.len() && !state.head_residuals_known {
            return;
        }
        let limit = i64::from(self.head_tolerance);
        for (i, &h) in which.iter().enumerate().take(pairs.len()) {
            let (Some(k), Some(p)) = (self.head_slot(h), self.neutral(h)) else {
                continue;
            };
            let a = fit.compensate(pairs.current(i));
            // |a − p| ≤ 2^31: clamped to ± the head tolerance (≤ 2^30).
            let now =
                [0, 1, 2].map(|c| (i64::from(a[c]) - i64::from(p[c])).clamp(-limit, limit) as i32);
            state.head_residuals[k] = match (&self.smoothing, state.filters.get_mut(h)) {
                (Some(smoothing), Some(filter)) => {
                    let first = !state.filtering.contains(h);
                    state.filtering.insert(h);
                    // A convex combination of values within ± the tolerance.
                    smoothing.step(smoothing.derivative_alpha(), filter, now, first)
                }
                _ => now,
            };
        }
        state.head_residuals_known = true;
    }

    /// The head fit smoothed: the four [`HEAD_FRAME_POINTS`] around the head markers' neutral
    /// centroid, moved by `fit`, each go through the head smoothing filter, and the fit of the
    /// filtered points is the head's pose. Still, the pose is averaged like a still marker; a
    /// turning head raises the filter's cutoff with the points' speed. `fit` itself without
    /// head smoothing.
    fn smooth_head(&self, state: &mut PlayState, fit: RigidFit) -> RigidFit {
        let Some(smoothing) = &self.head_smoothing else {
            return fit;
        };
        let centre = self.head_centroid();
        let mut pairs = HeadPairs::new();
        let alpha_d = smoothing.derivative_alpha();
        for (filter, offset) in state.head_filters.iter_mut().zip(HEAD_FRAME_POINTS) {
            // |centre| ≤ 4 units and |offset| ≤ 1: the sum is far inside the i32 range.
            let p = [0, 1, 2].map(|c| centre[c] + offset[c]);
            let q = smoothing.step(alpha_d, filter, fit.apply(p), !state.head_filtering);
            pairs.push(p, q);
        }
        state.head_filtering = true;
        // Four points a unit apart are never collinear; should the filtered ones ever fail to
        // fit, the unsmoothed fit is used.
        pairs.fit().unwrap_or(fit)
    }

    /// The centroid of the head markers' neutral positions (Q8.24 actor units, within ±4).
    fn head_centroid(&self) -> [i32; 3] {
        let head = self.head_markers.0;
        let mut sum = [0i64; 3];
        for p in head.iter().filter_map(|&h| self.neutral(usize::from(h))) {
            for c in 0..3 {
                sum[c] += i64::from(p[c]);
            }
        }
        // At most 32 head markers (validated): never a division by zero when called.
        let n = head.len().max(1) as i64;
        sum.map(|s| (s / n) as i32)
    }
}


/// The points whose motion the head smoothing filters, as offsets from the head markers'
/// neutral centroid (Q8.24 actor units): the centroid and one actor unit (the actor's half
/// extent) along each axis, so that they move as fast as the face's markers when the head turns.
pub const HEAD_FRAME_POINTS: [[i32; 3]; 4] = [
    [0, 0, 0],
    [1 << POS_FRAC_BITS, 0, 0],
    [0, 1 << POS_FRAC_BITS, 0],
    [0, 0, 1 << POS_FRAC_BITS],
];

/// Whether the vector `d` is longer than `limit` (at most 2³⁰). The squares are only formed
/// once every |dᵢ| ≤ limit: below 2⁶² in all.
fn beyond(d: [i64; 3], limit: i64) -> bool {
    if d.iter().any(|v| v.abs() > limit) {
        return true;
    }
    // Each |dᵢ| ≤ limit ≤ 2^30 now: an `i32`, squared by one 32 × 32 → 64-bit multiply.
    let d = d.map(|v| v as i32);
    d.iter().map(|&v| i64::from(v) * i64::from(v)).sum::<i64>() > limit * limit
}

/// The work of one frame of the capture stages.
#[cfg(feature = "format")]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StagesCost {
    /// Markers in and out.
    pub markers: usize,
    /// Head markers.
    pub head_markers: usize,
    /// Head-marker pairs whose current and neutral distances are compared (two integer square
    /// roots each).
    pub head_distance_checks: usize,
    /// Rigid fits at most: one, then with a head marker off it, one per head marker left out
    /// and one without the worst; one more with head smoothing.
    pub rigid_fits: usize,
    /// 4 × 4 matrix squarings at most.
    pub horn_squarings: usize,
    /// Fill terms at most (markers × neighbours).
    pub fill_terms: usize,
    /// Radial function (inverse multiquadric) evaluations: markers² for the RBF map, 0 for the
    /// proportional one; each one integer reciprocal square root. (The field keeps its old name:
    /// `fixtures/golden/hashes.txt` records this struct's `Debug` form.)
    pub retarget_kernels: usize,
    /// Multiply-adds: the RBF map's radial terms (3 per evaluation) and affine part, or the
    /// per-marker matrices.
    pub retarget_multiply_adds: usize,
    /// Markers checked against `max_step` (one squared distance each).
    pub step_checks: usize,
    /// Face markers weighed into the refit over the face ([`refit`]): one compensation, one
    /// weight (a 64-bit multiplication by the cutoff's reciprocal) and nine weighted products
    /// each; 0 without a refit.
    pub refit_markers: usize,
    /// Markers and head points smoothed (one integer square root and four 32-bit divisions each; 0
    /// without smoothing).
    pub smoothed_markers: usize,
}

/// What the capture stages remember between frames: the last good displacement of every marker,
/// its offsets from its fill neighbours, the frames since it, the smoothing filter's state and
/// the last good head fit, the head markers' residuals. 23,668 bytes on a 64-bit host; no
/// allocation.
#[derive(Clone, Debug)]
pub struct PlayState {
    last: [[i32; 3]; MAX_MARKERS],
    /// Per marker, its offsets from its fill neighbours ([`fill::Offsets`]).
    offsets: [fill::Offsets; MAX_MARKERS],
    seen: MarkerSet,
    /// Per marker, frames since its last good displacement (saturating).
    gap: [u16; MAX_MARKERS],
    filters: [MarkerFilter; MAX_MARKERS],
    filtering: MarkerSet,
    fit: Option<RigidFit>,
    head_filters: [MarkerFilter; HEAD_FRAME_POINTS.len()],
    head_filtering: bool,
    /// Per head marker (in the rig's head-marker order), its residual in the head's frame
    /// (Q8.24 actor units, within ± the head tolerance), smoothed like a marker.
    head_residuals: [[i32; 3]; MAX_HEAD_MARKERS],
    /// Whether a frame has fitted every head marker yet.
    head_residuals_known: bool,
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
            offsets: [fill::Offsets::ZERO; MAX_MARKERS],
            seen: MarkerSet::EMPTY,
            gap: [0; MAX_MARKERS],
            filters: [MarkerFilter::ZERO; MAX_MARKERS],
            filtering: MarkerSet::EMPTY,
            fit: None,
            head_filters: [MarkerFilter::ZERO; HEAD_FRAME_POINTS.len()],
            head_filtering: false,
            head_residuals: [[0; 3]; MAX_HEAD_MARKERS],
            head_residuals_known: false,
        }
    }

    /// The last good head fit.
    pub fn last_fit(&self) -> Option<RigidFit> {
        self.fit
    }
}


#[cfg(test)]
mod tests {
    use super::*;

    /// The play state is fixed-size and small enough for a microcontroller's stack or a static
    /// buffer: its size is what `fb_play_state_size()` reports (the C ABI adds an 8-byte tag).
    #[test]
    fn the_play_state_fits_in_24_kib() {
        let size = core::mem::size_of::<PlayState>();
        assert!(size <= 24 * 1024, "{size} bytes");
        assert!(size >= MAX_MARKERS * (12 + 12 * crate::records::FILL_NEIGHBOURS), "{size}");
    }
}
