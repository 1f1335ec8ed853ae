//! The capture stages in f64, unquantised: the reference the runtime is compared with. One
//! function per step of the runtime's stages, in its order:
//!
//! 1. `input`: a sample is missing when absent, when it belongs to a static anchor
//!    (whose samples are ignored, so it stays at rest) or when a coordinate lies beyond ±64 actor
//!    units (then it is also rejected);
//! 2. `fit_head`: Kabsch on the present head markers, dropping those beyond
//!    `max_displacement` and fitting once more; the last good fit held when none is possible;
//! 3. `plausibility`: a compensated marker further than `max_displacement` from
//!    neutral is rejected; the head markers hold still (zero displacement);
//! 4. `fill`: a missing marker is put where its present neighbours say, each at its
//!    displacement plus the marker's offset from it when both were last present (shrinking by
//!    a 64th a frame of the gap), weighted; else it holds its last one (zero if never seen); a
//!    head marker stays at zero;
//! 5. `retarget`: the unquantised RBF map (or proportional scaling) to the
//!    character's rig units.

use facebake_runtime::Space;

use super::retarget::{Proportional, RetargetMap};
use super::rigid::{kabsch, weighted_kabsch, RigidTransform};
use crate::mesh::distance;
use crate::space::to_rig_units;

/// The capture stages in f64, unquantised: the reference for the runtime.
pub struct StagesF64 {
    /// Actor space (metres).
    pub actor_space: Space,
    /// Neutral markers, actor units.
    pub neutral: Vec<[f64; 3]>,
    /// Head marker indices.
    pub head: Vec<usize>,
    /// Actor units.
    pub max_displacement: f64,
    /// Per marker, (neighbour, weight) pairs.
    pub fill: Vec<Vec<(usize, f64)>>,
    /// Static anchors: marker indices whose samples are ignored, so they stay at rest.
    pub anchors: Vec<usize>,
    /// Actor units → character rig units.
    pub map: RetargetMap,
    /// Proportional retargeting, used instead of `map` when present.
    pub proportional: Option<Proportional>,
    /// The head refit over the face (the runtime's `facebake_runtime::stages::refit`): its
    /// cutoff, actor units (0: none).
    pub refit_cutoff: f64,
}

/// What the reference did with one frame (mirrors the runtime's report).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FrameReportF64 {
    /// The head fit of this frame, if one was made.
    pub fit: Option<RigidTransform>,
    /// RMS residual of the fitted head markers, actor units.
    pub residual: f64,
    /// Rejected markers.
    pub rejected: Vec<usize>,
    /// Rebuilt markers.
    pub rebuilt: Vec<usize>,
    /// Held markers.
    pub held: Vec<usize>,
}

/// State the reference keeps between frames.
#[derive(Clone, Debug, Default)]
pub struct StateF64 {
    last: Vec<Option<[f64; 3]>>,
    /// Per marker, whether it was present in the last frame.
    measured: Vec<bool>,
    /// Per marker, its offset from each of its fill neighbours (in `fill`'s order).
    offsets: Vec<Vec<[f64; 3]>>,
    fit: Option<RigidTransform>,
    /// Per head marker (in `head`'s order), its residual in the head's frame when last fitted;
    /// empty until a frame has fitted every head marker (the runtime's, unsmoothed).
    head_residuals: Vec<[f64; 3]>,
}

/// The share of its offsets a missing marker loses each frame (the runtime's
/// `fill::OFFSET_DECAY_SHIFT`).
const OFFSET_DECAY: f64 = 1.0 / (1u32 << facebake_runtime::stages::fill::OFFSET_DECAY_SHIFT) as f64;

/// Largest accepted input coordinate magnitude, actor units (the runtime's `INPUT_LIMIT`).
const INPUT_LIMIT: f64 = 64.0;

fn sub(a: &[f64; 3], b: &[f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

impl StagesF64 {
    /// One frame (metres, `None` = missing) → the character's markers in rig units.
    pub fn solve(
        &self,
        state: &mut StateF64,
        frame: &[Option<[f64; 3]>],
    ) -> (Vec<[f64; 3]>, FrameReportF64) {
        let (actor, report) = self.compensate(state, frame);
        (self.retarget(&actor), report)
    }

    /// Steps 1 to 4 of [`Self::solve`]: one frame (metres) → every marker in the actor's
    /// neutral head frame (actor units), missing ones rebuilt or held.
    pub fn compensate(
        &self,
        state: &mut StateF64,
        frame: &[Option<[f64; 3]>],
    ) -> (Vec<[f64; 3]>, FrameReportF64) {
        let n = self.neutral.len();
        state.last.resize(n, None);
        state.measured.resize(n, false);
        if state.offsets.len() != n {
            state.offsets = self.fill.iter().map(|f| vec![[0.0; 3]; f.len()]).collect();
        }
        let mut report = FrameReportF64::default();
        let mut actor = self.input(frame, &mut report);
        let fit = self.fit_head(state, &actor, &mut report);
        let present = self.plausibility(&fit, &mut actor, &mut report);
        report.rejected.sort_unstable();
        let disp = self.fill(state, &present, &mut report);
        let out = (0..n)
            .map(|j| [0, 1, 2].map(|c| self.neutral[j][c] + disp[j][c]))
            .collect();
        (out, report)
    }

    /// Step 1: each marker's sample in actor units, `None` when missing, an anchor's, or
    /// beyond the input limit (rejected).
    fn input(
        &self,
        frame: &[Option<[f64; 3]>],
        report: &mut FrameReportF64,
    ) -> Vec<Option<[f64; 3]>> {
        (0..self.neutral.len())
            .map(|j| {
                if self.anchors.contains(&j) {
                    return None;
                }
                let p = frame.get(j).copied().flatten()?;
                let a = to_rig_units(&self.actor_space, &p);
                if a.iter().all(|c| c.is_finite() && c.abs() <= INPUT_LIMIT) {
                    Some(a)
                } else {
                    report.rejected.push(j);
                    None
                }
            })
            .collect()
    }

    /// Step 2: the head's rigid motion from neutral, or the one held.
    fn fit_head(
        &self,
        state: &mut StateF64,
        actor: &[Option<[f64; 3]>],
        report: &mut FrameReportF64,
    ) -> RigidTransform {
        if self.head.is_empty() {
            return RigidTransform::identity();
        }
        let mut used: Vec<usize> = self
            .head
            .iter()
            .copied()
            .filter(|&h| actor[h].is_some())
            .collect();
        // A head marker's neutral place, plus its residual when some head marker is missing.
        let target = |h: usize, all: bool| {
            let slot = self.head.iter().position(|&m| m == h);
            match (all, slot.and_then(|k| state.head_residuals.get(k))) {
                (false, Some(r)) => [0, 1, 2].map(|c| self.neutral[h][c] + r[c]),
                _ => self.neutral[h],
            }
        };
        let fit_of = |used: &[usize]| {
            let all = used.len() == self.head.len();
            let from: Vec<[f64; 3]> = used.iter().map(|&h| target(h, all)).collect();
            let to: Vec<[f64; 3]> = used.iter().filter_map(|&h| actor[h]).collect();
            kabsch(&from, &to)
        };
        let mut fitted = fit_of(&used);
        if let Ok(fit) = &fitted {
            let before = used.len();
            used.retain(|&h| {
                let q = actor[h].unwrap_or_default();
                distance(&fit.apply(&self.neutral[h]), &q) <= self.max_displacement
            });
            if used.len() < before {
                fitted = fit_of(&used);
            }
        }
        // Against the points fitted: with residuals when some head marker is missing.
        let all = used.len() == self.head.len();
        let from: Vec<[f64; 3]> = used.iter().map(|&h| target(h, all)).collect();
        let to: Vec<[f64; 3]> = used.iter().filter_map(|&h| actor[h]).collect();
        if used.len() < 3 && state.fit.is_some() {
            return self.track(state, actor, &from, &to, report);
        }
        match fitted {
            Ok(fit) => {
                let fit = self
                    .refit(state, actor, &used, &from, &to, &fit)
                    .unwrap_or(fit);
                report.residual = fit.rms_residual(&from, &to);
                report.fit = Some(fit);
                state.fit = Some(fit);
                if all || !state.head_residuals.is_empty() {
                    state.head_residuals.resize(self.head.len(), [0.0; 3]);
                    for &h in &used {
                        let (Some(k), Some(q)) = (self.head.iter().position(|&m| m == h), actor[h])
                        else {
                            continue;
                        };
                        state.head_residuals[k] = sub(&fit.apply_inverse(&q), &self.neutral[h]);
                    }
                }
                fit
            }
            Err(_) => state.fit.unwrap_or_else(RigidTransform::identity),
        }
    }

    /// The runtime's `Stages::refit`: `fit` done again, the head markers `used` (`from` →
    /// `to`) weighted by the biweight of their kept residuals (at least the floor), and every
    /// other marker present now and measured last frame by the biweight of its last
    /// displacement and of how far `fit` puts it from there, together. The weights are the
    /// runtime's, of the displacements rounded to Q8.24.
    fn refit(
        &self,
        state: &StateF64,
        actor: &[Option<[f64; 3]>],
        used: &[usize],
        from: &[[f64; 3]],
        to: &[[f64; 3]],
        fit: &RigidTransform,
    ) -> Option<RigidTransform> {
        use facebake_runtime::stages::refit::{
            Biweight, FULL_WEIGHT, HEAD_WEIGHT_FLOOR, REFIT_MARKERS,
        };
        if self.refit_cutoff <= 0.0 {
            return None;
        }
        let q824 = |v: f64| (v * f64::from(1u32 << 24)).round() as i32;
        let biweight = Biweight::new(q824(self.refit_cutoff));
        let weight = |d: &[f64; 3], moved: [i32; 3]| biweight.weight(d.map(q824), moved);
        let (mut a, mut b, mut w) = (from.to_vec(), to.to_vec(), Vec::new());
        for &h in used {
            let k = self.head.iter().position(|&m| m == h);
            w.push(match k.and_then(|k| state.head_residuals.get(k)) {
                Some(r) => weight(r, [0; 3]).max(HEAD_WEIGHT_FLOOR),
                None => FULL_WEIGHT,
            });
        }
        let face = (0..self.neutral.len())
            .filter(|j| !self.head.contains(j))
            .take(REFIT_MARKERS);
        for j in face {
            let (Some(q), Some(Some(last)), Some(true)) =
                (actor[j], state.last.get(j), state.measured.get(j))
            else {
                continue;
            };
            let d = sub(&fit.apply_inverse(&q), &self.neutral[j]);
            // Half the motion, as the runtime halves it (Q8.24, floor).
            let weight = weight(last, sub(&d, last).map(|c| q824(c) >> 1));
            if weight > 0 {
                a.push(self.neutral[j]);
                b.push(q);
                w.push(weight);
            }
        }
        let w: Vec<f64> = w.into_iter().map(f64::from).collect();
        weighted_kabsch(&a, &b, &w).ok()
    }

    /// The runtime's `Stages::track`: with fewer than three head markers
    /// present (`from` → `to`, their targets and samples), the pose tracked from the last
    /// frame: each head marker present counted `PRESENT_WEIGHT` times, and every other marker
    /// present now and in the last frame paired from its last place in the head's frame, in
    /// marker order up to `TRACKED_PAIRS` pairs, fitted. The last fit held when that fails.
    /// No residual is kept.
    fn track(
        &self,
        state: &mut StateF64,
        actor: &[Option<[f64; 3]>],
        from: &[[f64; 3]],
        to: &[[f64; 3]],
        report: &mut FrameReportF64,
    ) -> RigidTransform {
        use facebake_runtime::stages::{PRESENT_WEIGHT, TRACKED_PAIRS};
        let mut pairs: Vec<([f64; 3], [f64; 3])> = Vec::new();
        for _ in 0..PRESENT_WEIGHT {
            pairs.extend(from.iter().copied().zip(to.iter().copied()));
        }
        let others = self
            .neutral
            .iter()
            .zip(actor)
            .zip(state.last.iter().zip(&state.measured))
            .enumerate()
            .filter(|(j, _)| !self.head.contains(j));
        for (_, ((u, q), (d, measured))) in others {
            if let (Some(q), Some(d), true) = (q, d, measured) {
                pairs.push(([0, 1, 2].map(|c| u[c] + d[c]), *q));
            }
        }
        pairs.truncate(TRACKED_PAIRS);
        let (a, b): (Vec<[f64; 3]>, Vec<[f64; 3]>) = pairs.into_iter().unzip();
        let Ok(fit) = kabsch(&a, &b) else {
            return state.fit.unwrap_or_else(RigidTransform::identity);
        };
        report.residual = fit.rms_residual(&a, &b);
        report.fit = Some(fit);
        state.fit = Some(fit);
        fit
    }

    /// Step 3: each present marker's compensated displacement from neutral; those further than
    /// `max_displacement` are rejected. A head marker's is zero: once the head's rigid motion
    /// is taken out, what is left of it is the fit's residual, not expression.
    fn plausibility(
        &self,
        fit: &RigidTransform,
        actor: &mut [Option<[f64; 3]>],
        report: &mut FrameReportF64,
    ) -> Vec<Option<[f64; 3]>> {
        let mut disp: Vec<Option<[f64; 3]>> = vec![None; actor.len()];
        for (j, slot) in actor.iter_mut().enumerate() {
            let Some(a) = *slot else { continue };
            let d = sub(&fit.apply_inverse(&a), &self.neutral[j]);
            if d.iter().map(|c| c * c).sum::<f64>().sqrt() > self.max_displacement {
                report.rejected.push(j);
                *slot = None;
            } else {
                disp[j] = Some(if self.head.contains(&j) { [0.0; 3] } else { d });
            }
        }
        disp
    }

    /// Step 4: every marker's displacement, the missing ones rebuilt from their present
    /// neighbours or held.
    fn fill(
        &self,
        state: &mut StateF64,
        present: &[Option<[f64; 3]>],
        report: &mut FrameReportF64,
    ) -> Vec<[f64; 3]> {
        let limit = self.max_displacement;
        (0..present.len())
            .map(|j| {
                let offsets = &mut state.offsets[j];
                state.measured[j] = present[j].is_some();
                if let Some(d) = present[j] {
                    state.last[j] = Some(d);
                    for (o, &(k, _)) in offsets.iter_mut().zip(&self.fill[j]) {
                        if let Some(n) = present[k] {
                            *o = [0, 1, 2].map(|c| (d[c] - n[c]).clamp(-limit, limit));
                        }
                    }
                    return d;
                }
                let (mut acc, mut total) = ([0.0; 3], 0.0);
                for (o, &(k, w)) in offsets.iter().zip(&self.fill[j]) {
                    if let Some(d) = present[k] {
                        total += w;
                        (0..3).for_each(|c| acc[c] += w * (d[c] + o[c]));
                    }
                }
                for o in offsets.iter_mut() {
                    *o = o.map(|v| v * (1.0 - OFFSET_DECAY));
                }
                let d = if total > 0.0 {
                    report.rebuilt.push(j);
                    acc.map(|a| (a / total).clamp(-limit, limit))
                } else {
                    report.held.push(j);
                    state.last[j].unwrap_or([0.0; 3])
                };
                if self.head.contains(&j) {
                    [0.0; 3]
                } else {
                    d
                }
            })
            .collect()
    }

    /// Step 5: compensated actor markers (actor units) → the character's, rig units.
    pub fn retarget(&self, actor: &[[f64; 3]]) -> Vec<[f64; 3]> {
        actor
            .iter()
            .enumerate()
            .map(|(j, a)| match &self.proportional {
                Some(p) => p.map(j, &sub(a, &self.neutral[j])),
                None => self.map.map(a),
            })
            .collect()
    }
}
