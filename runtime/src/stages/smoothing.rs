//! Smoothing: a causal filter on every marker's compensated displacement, the one-euro filter
//! (Casiez, Roussel and Vogel, CHI 2012) in fixed point.
//!
//! Per marker and frame, with x the displacement given by the earlier stages (measured, rebuilt
//! or held), x̂ the filtered one and ŵ the filtered speed:
//!
//! ```text
//! v  = x − x̂₋₁                         raw step (actor units per frame)
//! ŵ  = ŵ₋₁ + α(c_d) (v − ŵ₋₁)          speed estimate, a fixed low-pass
//! c  = min(c_min + b ‖ŵ‖, MAX_CUTOFF)   cutoff: low when still, higher when moving
//! x̂  = x̂₋₁ + α(c) v                     α(c) = c / (1 + c)
//! ```
//!
//! c is the cutoff frequency times 2π over the frame rate (a per-frame quantity, so the baker
//! converts Hz at the capture's rate). Still, the filter is an exponential smoother of
//! α = c_min/(1 + c_min): it averages the jitter away and lags a slow drift by 1/c_min frames;
//! moving at speed s, the cutoff rises with b·s and the lag falls to 1/(c_min + b s) frames. The
//! filter runs in the head's frame, after compensation: head motion is not lagged, and the head
//! fit's own jitter, which moves every compensated marker, is filtered with the rest.
//!
//! The first displacement a marker gets is taken as it is (no lag from a zero start), and while
//! 1/n is larger than α the n-th frame gets weight 1/n: the filter starts as the running mean of
//! the frames so far, so the first frame's noise is averaged away at once rather than decaying
//! over the lag.
//!
//! Formats: displacements Q8.24 actor units (|x| ≤ 2³⁰: the plausibility bound), cutoffs and
//! the speed gain Q16.16, α Q0.30; v·α below 2⁶², ‖ŵ‖² below 3 · 2⁶² (a `u64`).

use serde::{Deserialize, Serialize};

use crate::fixed::round_shift_sat;
use crate::error::StagesLoadError;
use crate::sqrt::isqrt_u64;

/// Fractional bits of a cutoff and of the speed gain.
pub const CUTOFF_FRAC_BITS: u32 = 16;
/// Largest accepted cutoff: 256 (α = 256/257, nearly no smoothing), Q16.16.
pub const MAX_CUTOFF: u32 = 1 << 24;
/// Largest accepted speed gain: 2¹⁴ per actor unit per frame, Q16.16.
pub const MAX_SPEED_GAIN: u32 = 1 << 30;
/// Fractional bits of α.
const ALPHA_FRAC_BITS: u32 = 30;

/// The smoothing filter's parameters (see the module docs), all per frame at the rate of the
/// capture the stages were baked from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Smoothing {
    /// c_min = 2π f_min / rate, Q16.16, in [1, [`MAX_CUTOFF`]]: the cutoff when still. The
    /// filter's lag when still is 1/c_min frames.
    pub min_cutoff: u32,
    /// b: cutoff added per actor unit per frame of filtered speed, Q16.16, in
    /// [0, [`MAX_SPEED_GAIN`]].
    pub speed_gain: u32,
    /// c_d = 2π f_d / rate of the speed estimate, Q16.16, in [1, [`MAX_CUTOFF`]].
    pub derivative_cutoff: u32,
}

/// One marker's filter state: the filtered displacement and speed (Q8.24 actor units, per
/// frame).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MarkerFilter {
    value: [i32; 3],
    speed: [i32; 3],
    /// Frames filtered since the start, saturating.
    frames: u16,
}

impl MarkerFilter {
    /// A filter at rest at zero (it starts at its first input anyway).
    pub const ZERO: Self = Self {
        value: [0; 3],
        speed: [0; 3],
        frames: 0,
    };
}

impl Smoothing {
    /// Check every field's range.
    pub(crate) fn validate(&self) -> Result<(), StagesLoadError> {
        if !(1..=MAX_CUTOFF).contains(&self.min_cutoff) {
            return Err(StagesLoadError::BadMinCutoff);
        }
        if self.speed_gain > MAX_SPEED_GAIN {
            return Err(StagesLoadError::BadSpeedGain);
        }
        if !(1..=MAX_CUTOFF).contains(&self.derivative_cutoff) {
            return Err(StagesLoadError::BadDerivativeCutoff);
        }
        Ok(())
    }

    /// The filter's lag when still, in frames (1/c_min), rounded to the nearest frame.
    #[cfg(feature = "format")]
    pub fn still_lag_frames(&self) -> u32 {
        let c = self.min_cutoff.max(1);
        ((1u32 << CUTOFF_FRAC_BITS) + c / 2) / c
    }

    /// The derivative filter's α, the same for every marker and frame: computed once per frame
    /// by the caller of [`Self::step`] rather than once per marker (a 64-bit division).
    pub fn derivative_alpha(&self) -> i64 {
        alpha(self.derivative_cutoff)
    }

    /// One frame of the filter for one marker: the filtered displacement of `x`. `first` starts
    /// the filter at `x`. `alpha_d` is [`Self::derivative_alpha`].
    pub fn step(&self, alpha_d: i64, state: &mut MarkerFilter, x: [i32; 3], first: bool) -> [i32; 3] {
        if first {
            *state = MarkerFilter {
                value: x,
                speed: [0; 3],
                frames: 1,
            };
            return x;
        }
        let v = [0, 1, 2].map(|c| i64::from(x[c]) - i64::from(state.value[c]));
        let speed = [0, 1, 2].map(|c| {
            let w = i64::from(state.speed[c]);
            // |v − w| < 2^33, α ≤ 2^30: below 2^63.
            let s = w + i64::from(round_shift_sat(alpha_d * (v[c] - w), ALPHA_FRAC_BITS));
            s.clamp(-i64::from(i32::MAX), i64::from(i32::MAX)) as i32
        });
        let norm: u64 = speed
            .iter()
            .map(|&s| {
                let s = i64::from(s);
                (s * s) as u64
            })
            .sum();
        let s = u64::from(isqrt_u64(norm));
        // Q16.16 × Q8.24 → Q16.16 after the shift by 24; saturated, then capped.
        let boost = u64::from(self.speed_gain).saturating_mul(s) >> 24;
        let cutoff = (u64::from(self.min_cutoff) + boost).min(u64::from(MAX_CUTOFF)) as u32;
        // Start-up: the running mean of the n frames so far while 1/n is the larger weight.
        // n ≤ 2^16: a 32-bit division (one UDIV on a Cortex-M4; a 64-bit one is a library call).
        let n = u32::from(state.frames) + 1;
        let a = alpha(cutoff).max(i64::from((1u32 << ALPHA_FRAC_BITS) / n));
        let value = [0, 1, 2].map(|c| {
            let step = i64::from(round_shift_sat(a * v[c], ALPHA_FRAC_BITS));
            (i64::from(state.value[c]) + step).clamp(i64::from(i32::MIN), i64::from(i32::MAX))
                as i32
        });
        *state = MarkerFilter {
            value,
            speed,
            frames: state.frames.saturating_add(1),
        };
        value
    }
}

/// α = c / (1 + c) in Q0.30 for a cutoff c in Q16.16 (at most [`MAX_CUTOFF`]): ⌊c·2³⁰ / d⌋
/// with d = c + 2¹⁶, which is 2³⁰ − ⌈2⁴⁶ / d⌉ (c·2³⁰ = d·2³⁰ − 2⁴⁶). The quotient of the
/// constant 2⁴⁶ is found in three 32-bit divisions (2³² = q d + r, then twice r·2⁷ by d),
/// not one 64-bit division: a Cortex-M has a 32-bit divide instruction and calls a routine
/// for 64 bits (205 instructions of a marker's 743 in the smoothing on the Cortex-M4, now 47).
/// The same integers as the 64-bit quotient for every cutoff (`alpha_is_the_64_bit_quotient`).
fn alpha(cutoff: u32) -> i64 {
    // d in [2^16, 2^24 + 2^16]: below 2^25.
    let d = cutoff.min(MAX_CUTOFF) + (1 << CUTOFF_FRAC_BITS);
    // 2^32 = q d + r with 0 ≤ r < d: from 2^32 − 1 = q d + (r − 1).
    let mut q = u32::MAX / d;
    let mut r = u32::MAX - q * d + 1;
    if r == d {
        q += 1;
        r = 0;
    }
    // Twice: 2^(32 + 7k) = q d + r becomes 2^(39 + 7k) = (q·2^7 + t) d + (r·2^7 − t d), with
    // r·2^7 < 2^32 (r < d < 2^25) and q below 2^16, 2^23, then 2^30 (2^46 / 2^16).
    for _ in 0..2 {
        let x = r << 7;
        let t = x / d;
        q = (q << 7) + t;
        r = x - t * d;
    }
    let ceiling = q + u32::from(r != 0);
    i64::from((1u32 << ALPHA_FRAC_BITS) - ceiling)
}

#[cfg(test)]
mod tests {
    use super::*;

    const ONE: f64 = (1u32 << CUTOFF_FRAC_BITS) as f64;

    fn params(c_min: f64, b: f64, c_d: f64) -> Smoothing {
        Smoothing {
            min_cutoff: (c_min * ONE).round() as u32,
            speed_gain: (b * ONE).round() as u32,
            derivative_cutoff: (c_d * ONE).round() as u32,
        }
    }

    /// The same filter in f64: (value, speed) after input `x`, the `n`-th frame (from 1).
    fn reference(p: &Smoothing, state: (f64, f64), x: f64, n: i32) -> (f64, f64) {
        let (c_min, b, c_d) = (
            f64::from(p.min_cutoff) / ONE,
            f64::from(p.speed_gain) / ONE,
            f64::from(p.derivative_cutoff) / ONE,
        );
        let a = |c: f64| c / (1.0 + c);
        let (value, speed) = state;
        let v = x - value;
        let speed = speed + a(c_d) * (v - speed);
        let c = (c_min + b * speed.abs()).min(256.0);
        (value + a(c).max(1.0 / f64::from(n)) * v, speed)
    }

    /// Every cutoff from 0 to [`MAX_CUTOFF`] (and one past it, clamped) gives the 64-bit
    /// quotient ⌊c·2³⁰ / (c + 2¹⁶)⌋ exactly.
    #[test]
    fn alpha_is_the_64_bit_quotient() {
        for cutoff in 0..=MAX_CUTOFF + 1 {
            let c = u64::from(cutoff.min(MAX_CUTOFF));
            let want = ((c << ALPHA_FRAC_BITS) / (c + (1 << CUTOFF_FRAC_BITS))) as i64;
            assert_eq!(alpha(cutoff), want, "cutoff {cutoff}");
        }
    }

    /// On one axis the fixed-point filter follows the f64 one to a few LSB over a noisy wave.
    #[test]
    fn matches_the_f64_filter() {
        let p = params(0.1, 40.0, 0.1);
        let mut seed = 0x1234_5678u64;
        let mut state = MarkerFilter::default();
        let mut want = (0.0, 0.0);
        for i in 0..2000 {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            let noise = (seed % 1000) as f64 / 1000.0 - 0.5;
            // A slow wave: no sin in core, so a triangle wave of period 120 frames.
            let phase = f64::from(i % 120) / 60.0;
            let x = 0.2 * (if phase < 1.0 { phase } else { 2.0 - phase }) + 0.005 * noise;
            let q = (x * f64::from(1 << 24)).round() as i32;
            let got = p.step(p.derivative_alpha(), &mut state, [q, 0, 0], i == 0);
            let xq = f64::from(q) / f64::from(1 << 24);
            want = if i == 0 {
                (xq, 0.0)
            } else {
                reference(&p, want, xq, i + 1)
            };
            let got = f64::from(got[0]) / f64::from(1 << 24);
            assert!((got - want.0).abs() < 1e-5, "frame {i}: {got} vs {}", want.0);
            assert_eq!(state.value[1], 0);
        }
    }

    /// A constant input is a fixed point, the first frame passes unchanged, and a step is
    /// followed monotonically, within the lag the docs state.
    #[test]
    fn settles_without_overshoot() {
        let p = params(0.1, 0.0, 0.1);
        assert_eq!(p.still_lag_frames(), 10);
        let mut state = MarkerFilter::default();
        assert_eq!(p.step(p.derivative_alpha(), &mut state, [5, -7, 1 << 30], true), [5, -7, 1 << 30]);
        assert_eq!(p.step(p.derivative_alpha(), &mut state, [5, -7, 1 << 30], false), [5, -7, 1 << 30]);
        let mut last = 0;
        let mut state = MarkerFilter::default();
        p.step(p.derivative_alpha(), &mut state, [0; 3], true);
        let target = 1 << 24;
        for f in 1..=200 {
            let y = p.step(p.derivative_alpha(), &mut state, [target, 0, 0], false)[0];
            assert!(y >= last && y <= target, "frame {f}");
            // The running mean of the first frames (f of f + 1 frames at the target), then an
            // exponential smoother of α = c/(1+c), which loses 1 − α of the gap each frame.
            let c = f64::from(p.min_cutoff) / ONE;
            let start = (1.0 + c) / c; // the frame from which α beats 1/n
            let want = if f64::from(f + 1) <= start {
                f64::from(f) / f64::from(f + 1)
            } else {
                let n0 = start.floor() as i32;
                let at = f64::from(n0 - 1) / f64::from(n0);
                1.0 - (1.0 - at) * (1.0 / (1.0 + c)).powi(f - (n0 - 1))
            };
            assert!((f64::from(y) / f64::from(target) - want).abs() < 1e-6);
            last = y;
        }
    }

    /// Extreme inputs saturate, never overflow.
    #[test]
    fn extreme_inputs_do_not_overflow() {
        let p = Smoothing {
            min_cutoff: 1,
            speed_gain: MAX_SPEED_GAIN,
            derivative_cutoff: MAX_CUTOFF,
        };
        let mut state = MarkerFilter::default();
        let mut last = p.step(p.derivative_alpha(), &mut state, [i32::MIN; 3], true)[0];
        for x in [i32::MAX, i32::MIN, 0, i32::MAX, i32::MAX] {
            let y = p.step(p.derivative_alpha(), &mut state, [x; 3], false)[0];
            // Each output lies between the last one and the input: a convex combination.
            assert!(y >= last.min(x) && y <= last.max(x), "{last} → {x}: {y}");
            last = y;
        }
    }
}
