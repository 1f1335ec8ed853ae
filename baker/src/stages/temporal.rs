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
//! * **Max displacement**: [`DISPLACEMENT_FACTOR`] × the largest of the markers'
//!   [`DISPLACEMENT_PERCENTILE`]th percentile distances from neutral over the capture; at least
//!   [`MIN_DISPLACEMENT`] of the half extent. A fixed bound cut JawMoCap's widest mouth, whose
//!   lower-lip marker comes within 1 mm of half the half extent: ±0.5 mm of jitter then threw
//!   it out and rebuilt it from its neighbours.
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
/// The learned max displacement is this many times the largest of the markers'
/// [`DISPLACEMENT_PERCENTILE`]th percentile distances from neutral.
pub const DISPLACEMENT_FACTOR: f64 = 1.5;
/// Percentile of each marker's distances from neutral the max displacement is learned from.
pub const DISPLACEMENT_PERCENTILE: f64 = 99.0;
/// Smallest learned max displacement, as a fraction of the actor's half extent.
pub const MIN_DISPLACEMENT: f64 = 0.5;

/// The head pose is smoothed when the head fit would carry more than this much of the
/// capture's own noise to the face (metres): the fit's noise gain
/// ([`super::rigid::fit_noise_gain`]) times the capture's noise ([`capture_noise`]). JawMoCap's
/// three forehead markers magnify noise 6.4×: as captured (noise 0.003 mm) its pose needs no
/// smoothing, with ±0.5 mm of jitter (0.32 mm) it does (2 mm).
pub const HEAD_NOISE_LIMIT: f64 = 0.001;

/// The largest speed gain [`SmoothingConfig::for_noise`] gives, Hz·s/m: the gain at
/// [`MARKER_NOISE_LIMIT`] by the rule, 882, rounded up.
pub const MAX_BETA: f64 = 1000.0;

/// The capture noise (metres) at which the default filter's speed gain is its configured β;
/// at another noise σ the bake uses β (this / σ)² ([`SmoothingConfig::for_noise`]). A quiet
/// take's speed estimate is quiet, so a larger gain lets fast moves (a blink) through sooner
/// without letting jitter through; a noisy one needs a smaller gain. FaceCap's rehearsal
/// (`tests/tests/rehearsal.rs`), face mean and eyelids, by β: at 0.189 mm of noise, β 50
/// 0.455 / 1.7 mm, 330 0.437 / 1.1, 555 (the rule) 0.438 / 1.0; at 0.315 mm, 50 0.533 / 1.8,
/// 100 0.527 / 1.6, 200 (the rule) 0.526 / 1.4, 400 0.526 / 1.4 (lips 7.1); at 0.63 mm, 50 (the
/// rule) 0.771 / 2.2, 100 0.778 / 2.1, 200 0.794 / 2.0, 400 0.819 / 2.0.
pub const SPEED_GAIN_NOISE: f64 = 0.000_63;

/// The markers are smoothed by default when the capture's noise ([`capture_noise`], metres)
/// is over this. Against the truth (`tests/tests/rehearsal.rs`, FaceCap at 60 Hz with the head
/// moving and 5 % of the samples dropped), the default filter's lag costs more than the jitter
/// it removes below about 0.13 mm of noise: face mean error smoothed (β 50) / unsmoothed 0.396 / 0.369
/// mm at 0.064 mm of noise, 0.422 / 0.419 at 0.126, 0.455 / 0.477 at 0.189, 0.533 / 0.609 at
/// 0.315 (±0.5 mm); the eyelids favour no filter a little longer (1.7 / 1.2 mm off at 0.189),
/// but not with the speed gain scaled to the noise ([`SPEED_GAIN_NOISE`]: 1.0 mm).
/// JawMoCap as captured has 0.003 mm.
pub const MARKER_NOISE_LIMIT: f64 = 0.000_15;

/// The capture's measurement noise, metres: a robust estimate of the standard deviation of
/// white noise on each coordinate, from every sample's distance to the midpoint of its
/// neighbours in time (1.5 σ² for white noise; smooth motion adds little at capture rates):
/// 1.4826 × the median |x_t − (x_{t−1} + x_{t+1})/2| / √1.5. 0 when no marker has three
/// consecutive samples.
pub fn capture_noise(frames: &[Vec<Option<[f64; 3]>>]) -> f64 {
    let mut e: Vec<f64> = frames
        .windows(3)
        .flat_map(|w| {
            (0..w[1].len()).filter_map(move |m| match (w[0].get(m), w[1].get(m), w[2].get(m)) {
                (Some(Some(a)), Some(Some(b)), Some(Some(c))) => Some((a, b, c)),
                _ => None,
            })
        })
        .flat_map(|(a, b, c)| (0..3).map(move |k| (b[k] - 0.5 * (a[k] + c[k])).abs()))
        .collect();
    if e.is_empty() {
        return 0.0;
    }
    let mid = e.len() / 2;
    let (_, median, _) = e.select_nth_unstable_by(mid, f64::total_cmp);
    1.4826 * *median / 1.5f64.sqrt()
}

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
    /// Tuned against the truth (`tests/tests/rehearsal.rs`): FaceCap's expressions played as a
    /// take with the head moving, jitter and dropouts, scored on every third frame. Its β is
    /// the gain at [`SPEED_GAIN_NOISE`]; the bake scales it to the capture's noise
    /// ([`Self::for_noise`]). Heavier
    /// filters average more jitter away when the face is still but lag every expression: with
    /// ±0.5 mm of jitter at 60 Hz, (1 Hz, β 10, 1 Hz) had the face's mean error 0.645 mm, lips
    /// 11.6 mm and eyelids 3.9 mm off at worst; this one 0.533, 7.2 and 1.8 (none: 0.609, 7.1
    /// and 1.5).
    fn default() -> Self {
        Self {
            min_cutoff_hz: 3.0,
            beta: 50.0,
            derivative_cutoff_hz: 2.0,
        }
    }
}

impl SmoothingConfig {
    /// These parameters for a capture of noise `noise` (metres, [`capture_noise`]): the speed
    /// gain scaled by ([`SPEED_GAIN_NOISE`] / noise)², at most [`MAX_BETA`].
    pub fn for_noise(&self, noise: f64) -> Self {
        let scale = (SPEED_GAIN_NOISE / noise).powi(2);
        Self {
            beta: (self.beta * scale).min(MAX_BETA),
            ..*self
        }
    }

    /// The head pose's filter: the points it filters move only when the head does, so it can
    /// smooth harder when still than the markers' filter and let a turn through sooner.
    pub const HEAD: Self = Self {
        min_cutoff_hz: 0.5,
        beta: 40.0,
        derivative_cutoff_hz: 1.0,
    };

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

/// The median over `frames` (metres, rig marker order) of the head markers' RMS residual from
/// `reference`'s head fit, actor units (0 without a frame that fits them): how far the head
/// markers stray from a rigid head, skin sliding and jitter alike.
pub fn head_residual(reference: &StagesF64, frames: &[Vec<Option<[f64; 3]>>]) -> f64 {
    let mut state = StateF64::default();
    let mut residuals: Vec<f64> = frames
        .iter()
        .filter_map(|frame| {
            let (_, report) = reference.compensate(&mut state, frame);
            report.fit.map(|_| report.residual)
        })
        .collect();
    residuals.sort_by(f64::total_cmp);
    residuals.get(residuals.len() / 2).copied().unwrap_or(0.0)
}

/// Every frame of `frames` (metres, rig marker order) through `reference`'s compensation: per
/// marker its compensated position (actor units) when it was measured (present, not rebuilt,
/// held or rejected), else `None`.
pub fn measured_frames(
    reference: &StagesF64,
    frames: &[Vec<Option<[f64; 3]>>],
) -> Vec<Vec<Option<[f64; 3]>>> {
    let mut state = StateF64::default();
    frames
        .iter()
        .map(|frame| {
            let (actor, report) = reference.compensate(&mut state, frame);
            actor
                .iter()
                .enumerate()
                .map(|(j, a)| {
                    let fresh = frame.get(j).is_some_and(Option::is_some)
                        && !report.rejected.contains(&j)
                        && !report.rebuilt.contains(&j)
                        && !report.held.contains(&j);
                    fresh.then_some(*a)
                })
                .collect()
        })
        .collect()
}

/// The `percentile`th percentile of `values`, or 0 for none.
fn percentile_of(mut values: Vec<f64>, percentile: f64) -> f64 {
    if values.is_empty() {
        return 0.0;
    }
    values.sort_by(f64::total_cmp);
    let at = ((percentile / 100.0) * (values.len() - 1) as f64).round() as usize;
    values[at.min(values.len() - 1)]
}

/// The `percentile`th percentile of the markers' movement between consecutive frames of
/// `measured` ([`measured_frames`], actor units per frame). Only markers measured in both
/// frames count; 0 if none does.
pub fn step_percentile(measured: &[Vec<Option<[f64; 3]>>], percentile: f64) -> f64 {
    let steps = measured
        .windows(2)
        .flat_map(|w| {
            w[1].iter().zip(&w[0]).filter_map(|(a, b)| match (a, b) {
                (Some(a), Some(b)) => Some(distance(a, b)),
                _ => None,
            })
        })
        .collect();
    percentile_of(steps, percentile)
}

/// The largest, over the markers, of a marker's `percentile`th percentile distance from its
/// `neutral` position over `measured` ([`measured_frames`], actor units): how far the capture's
/// own expressions take its markers, a stray sample in a hundred aside.
pub fn displacement_percentile(
    measured: &[Vec<Option<[f64; 3]>>],
    neutral: &[[f64; 3]],
    percentile: f64,
) -> f64 {
    (0..neutral.len())
        .map(|j| {
            let d = measured
                .iter()
                .filter_map(|f| f.get(j).copied().flatten())
                .map(|p| distance(&p, &neutral[j]))
                .collect();
            percentile_of(d, percentile)
        })
        .fold(0.0, f64::max)
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Smooth motion at a capture rate with uniform noise of known σ (±√3 σ): the estimate is
    /// within 10 % of σ, and near zero without the noise; missing samples are skipped.
    #[test]
    fn capture_noise_finds_the_noise_under_smooth_motion() {
        let sigma = 0.0003;
        let mut rng = crate::ground_truth::SplitMix64(11);
        let frames =
            |noise: f64, rng: &mut crate::ground_truth::SplitMix64| -> Vec<Vec<Option<[f64; 3]>>> {
                (0..600)
                    .map(|t| {
                        let time = t as f64 / 60.0;
                        (0..5)
                            .map(|m| {
                                (t % 97 != m).then(|| {
                                    let base = 0.02 * (time * (1.0 + m as f64)).sin();
                                    [base, 0.5 * base, 0.1]
                                        .map(|c| c + noise * 3f64.sqrt() * (2.0 * rng.unit() - 1.0))
                                })
                            })
                            .collect()
                    })
                    .collect()
            };
        let noisy = capture_noise(&frames(sigma, &mut rng));
        assert!((noisy / sigma - 1.0).abs() < 0.1, "{noisy}");
        let clean = capture_noise(&frames(0.0, &mut rng));
        assert!(clean < 0.05 * sigma, "{clean}");
        assert_eq!(capture_noise(&[]), 0.0);
    }
}
