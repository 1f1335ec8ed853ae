//! The capture stages' checks across frames and their smoothing (issue 14): the head-marker
//! distance tolerance, the step gate and the one-euro filter's parameters, learned from the
//! capture's own frames or set by options, in the runtime's formats.
//!
//! * **Head tolerance**: [`HEAD_TOLERANCE_FACTOR`] × the largest change, over the capture's
//!   complete frames, of a head-marker pair's distance from the neutral frame; at least
//!   [`MIN_HEAD_TOLERANCE`] of the actor's half extent (measurement jitter moves a distance by up
//!   to twice a marker's error).
//! * **Max step**: [`STEP_FACTOR`] × the [`STEP_PERCENTILE`]th percentile of the compensated
//!   markers' movement from one frame to the next over the whole capture (the f64 reference's
//!   compensation); at least [`MIN_STEP`] of the half extent.
//! * **Smoothing** ([`SmoothingConfig`]): the one-euro filter's cutoffs in Hz and its speed
//!   coefficient, turned into per-frame quantities at the capture's rate.
//!
//! The f64 reference ([`super::StagesF64`]) has none of these; the tests that compare the runtime
//! with it bake without smoothing, and on the capture the stages were learned from the distance
//! check and the step gate never fire.

use facebake_runtime::stages::smoothing::{
    Smoothing, CUTOFF_FRAC_BITS, MAX_CUTOFF, MAX_SPEED_GAIN,
};

use super::reference::{StagesF64, StateF64};
use super::StagesError;
use crate::mesh::distance;

/// The learned head tolerance is this many times the capture's largest distance change.
pub const HEAD_TOLERANCE_FACTOR: f64 = 2.0;
/// Smallest learned head tolerance, as a fraction of the actor's half extent (about 2 mm on
/// JawMoCap).
pub const MIN_HEAD_TOLERANCE: f64 = 0.02;
/// The learned max step is this many times the capture's [`STEP_PERCENTILE`]th percentile step.
pub const STEP_FACTOR: f64 = 8.0;
/// Percentile of the capture's per-frame marker steps the max step is learned from.
pub const STEP_PERCENTILE: f64 = 99.9;
/// Smallest learned max step, as a fraction of the actor's half extent per frame (about 2 mm
/// on JawMoCap).
pub const MIN_STEP: f64 = 0.02;

/// The one-euro filter's parameters in the units of its paper.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct SmoothingConfig {
    /// Cutoff when still, Hz: the lag when still is rate / (2π · this) frames.
    pub min_cutoff_hz: f64,
    /// Cutoff added per metre per second of (filtered) marker speed, Hz·s/m.
    pub beta: f64,
    /// Cutoff of the speed estimate, Hz.
    pub derivative_cutoff_hz: f64,
}

impl Default for SmoothingConfig {
    /// Tuned on JawMoCap with ±0.5 mm jitter (`tests/tests/noise.rs`).
    fn default() -> Self {
        Self {
            min_cutoff_hz: 1.0,
            beta: 10.0,
            derivative_cutoff_hz: 1.0,
        }
    }
}

impl SmoothingConfig {
    /// The runtime's per-frame parameters at `rate_hz` for an actor of `half_extent` metres.
    pub fn encode(&self, rate_hz: f64, half_extent: f64) -> Result<Smoothing, StagesError> {
        let one = f64::from(1u32 << CUTOFF_FRAC_BITS);
        let per_frame = |hz: f64, what: &str| {
            let c = (std::f64::consts::TAU * hz / rate_hz * one).round();
            if c.is_finite() && c >= 1.0 && c <= f64::from(MAX_CUTOFF) {
                Ok(c as u32)
            } else {
                Err(StagesError::OutOfRange(format!(
                    "smoothing {what} {hz} Hz at {rate_hz} frames/s is outside the runtime's range \
                     (2π f / rate in (0, 256])"
                )))
            }
        };
        // fc = f_min + β · speed (m/s); speed = s · half_extent · rate for s in actor units per
        // frame, so c = 2π fc / rate gains 2π β · half_extent per actor unit per frame.
        let gain = (std::f64::consts::TAU * self.beta * half_extent * one).round();
        if !(gain.is_finite() && gain >= 0.0 && gain <= f64::from(MAX_SPEED_GAIN)) {
            return Err(StagesError::OutOfRange(format!(
                "smoothing beta {} is outside the runtime's range",
                self.beta
            )));
        }
        Ok(Smoothing {
            min_cutoff: per_frame(self.min_cutoff_hz, "minimum cutoff")?,
            speed_gain: gain as u32,
            derivative_cutoff: per_frame(self.derivative_cutoff_hz, "speed cutoff")?,
        })
    }
}

/// The largest change of a head-marker pair's distance from `neutral` over `frames` (any unit;
/// `head` indexes both), or 0 for fewer than two head markers.
pub fn head_distance_change(frames: &[Vec<[f64; 3]>], neutral: &[[f64; 3]], head: &[usize]) -> f64 {
    let mut worst = 0.0f64;
    for (a, &i) in head.iter().enumerate() {
        for &k in &head[a + 1..] {
            let d0 = distance(&neutral[i], &neutral[k]);
            for f in frames {
                worst = worst.max((distance(&f[i], &f[k]) - d0).abs());
            }
        }
    }
    worst
}

/// The `percentile`th percentile of the compensated markers' movement between consecutive
/// frames (actor units per frame), through `reference`'s compensation of `frames` (metres, rig
/// marker order). Only markers measured (not rebuilt, held or rejected) in both frames count;
/// 0 if none does.
pub fn step_percentile(
    reference: &StagesF64,
    frames: &[Vec<Option<[f64; 3]>>],
    percentile: f64,
) -> f64 {
    let mut state = StateF64::default();
    let mut steps = Vec::new();
    let mut previous: Option<Vec<Option<[f64; 3]>>> = None;
    for frame in frames {
        let (actor, report) = reference.compensate(&mut state, frame);
        let measured: Vec<Option<[f64; 3]>> = actor
            .iter()
            .enumerate()
            .map(|(j, a)| {
                let fresh = frame.get(j).is_some_and(Option::is_some)
                    && !report.rejected.contains(&j)
                    && !report.rebuilt.contains(&j)
                    && !report.held.contains(&j);
                fresh.then_some(*a)
            })
            .collect();
        if let Some(before) = &previous {
            for (a, b) in measured.iter().zip(before) {
                if let (Some(a), Some(b)) = (a, b) {
                    steps.push(distance(a, b));
                }
            }
        }
        previous = Some(measured);
    }
    if steps.is_empty() {
        return 0.0;
    }
    steps.sort_by(f64::total_cmp);
    let at = ((percentile / 100.0) * (steps.len() - 1) as f64).round() as usize;
    steps[at.min(steps.len() - 1)]
}

/// A bound in actor units as the runtime's Q8.24, checked against (0, 64].
pub fn encode_bound(v: f64, what: &str) -> Result<i32, StagesError> {
    if v > 0.0 && v <= 64.0 {
        Ok(((v * f64::from(1u32 << 24)).round() as i32).max(1))
    } else {
        Err(StagesError::OutOfRange(format!(
            "{what} {v} must be in (0, 64] actor units"
        )))
    }
}
