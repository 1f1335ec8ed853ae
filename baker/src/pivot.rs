//! Rotation-pivot estimation (paper 003 §2.2), an offline calibration step: the fixed point the
//! head turns about (roughly the top of the neck), found from the head markers over a capture.
//!
//! If the head only turns about a fixed pivot O, every head marker keeps its distance lᵢ to O
//! and every angle θᵢ between OPᵢ and OPᵢ₊₁ stays the same. The objective (eq 5) sums, over all
//! frames, how much the lengths and the angles (scaled by the mean length) differ from the
//! first frame's, plus a small pull w₃‖p − p₀‖ toward the starting point, and is minimised by
//! the paper's derivative-free search (eqs 6–8): try a step along each of the six axis
//! directions, move to the best if it improves, and grow the step by ρ after a success or shrink
//! it by σ after a failure (the "bold driver").
//!
//! The least-squares fit ([`crate::stages::rigid::kabsch`]) does not need the pivot; it is reported for
//! users who drive a neck joint, and to say how much of the head's motion is a turn about it.

use crate::mesh::distance;

/// Step growth after an improving move (ρ ≥ 1).
const GROW: f64 = 1.2;
/// Step shrink after a failed move (0 < σ < 1).
const SHRINK: f64 = 0.5;
/// Most search iterations.
const MAX_ITERATIONS: usize = 2000;
/// Weight of the pull toward the start, w₃.
const PULL: f64 = 1e-3;

/// The result of [`estimate_pivot`].
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct PivotEstimate {
    /// The pivot, in the capture's space and unit.
    pub pivot: [f64; 3],
    /// The objective at the start.
    pub start_objective: f64,
    /// The objective at the pivot.
    pub objective: f64,
    /// Mean change of a marker's distance to the pivot from the first frame, capture units.
    pub mean_length_change: f64,
    /// Search iterations used.
    pub iterations: usize,
}

fn angle(o: &[f64; 3], a: &[f64; 3], b: &[f64; 3]) -> f64 {
    let u = [0, 1, 2].map(|c| a[c] - o[c]);
    let v = [0, 1, 2].map(|c| b[c] - o[c]);
    let dot: f64 = (0..3).map(|c| u[c] * v[c]).sum();
    let cross = [
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ];
    distance(&cross, &[0.0; 3]).atan2(dot)
}

/// Mean |Δl| and mean |Δθ| over frames and markers, relative to frame 0.
fn changes(frames: &[Vec<[f64; 3]>], p: &[f64; 3]) -> (f64, f64, f64) {
    let first = &frames[0];
    let n = first.len();
    let l0: Vec<f64> = first.iter().map(|q| distance(p, q)).collect();
    let t0: Vec<f64> = (0..n)
        .map(|j| angle(p, &first[j], &first[(j + 1) % n]))
        .collect();
    let (mut dl, mut dt) = (0.0, 0.0);
    for f in frames {
        for j in 0..n {
            dl += (distance(p, &f[j]) - l0[j]).abs();
            dt += (angle(p, &f[j], &f[(j + 1) % n]) - t0[j]).abs();
        }
    }
    let count = (frames.len() * n) as f64;
    let mean_l = l0.iter().sum::<f64>() / n as f64;
    (dl / count, dt / count, mean_l)
}

/// Eq 5 with w₁ = w₂ = 1, the angle term scaled by the mean length.
fn objective(frames: &[Vec<[f64; 3]>], p: &[f64; 3], start: &[f64; 3]) -> f64 {
    let (dl, dt, mean_l) = changes(frames, p);
    dl + dt * mean_l + PULL * distance(p, start)
}

/// Estimate the pivot from the head markers of every frame (`frames[f][j]`, at least three
/// markers and two frames), starting the search at `start`; `size` (the head's size, capture
/// units) sets the first step (a tenth of it) and the stopping step (10⁻⁶ of it).
pub fn estimate_pivot(
    frames: &[Vec<[f64; 3]>],
    start: [f64; 3],
    size: f64,
) -> Option<PivotEstimate> {
    if frames.len() < 2 || frames[0].len() < 3 || frames.iter().any(|f| f.len() != frames[0].len())
    {
        return None;
    }
    let e = |p: &[f64; 3]| objective(frames, p, &start);
    let mut p = start;
    let mut best = e(&p);
    let start_objective = best;
    let mut step = 0.1 * size;
    let mut iterations = 0;
    while iterations < MAX_ITERATIONS && step > 1e-6 * size {
        iterations += 1;
        let candidate = (0..6)
            .map(|d| {
                let mut q = p;
                q[d / 2] += if d % 2 == 0 { step } else { -step };
                (e(&q), q)
            })
            .min_by(|a, b| a.0.total_cmp(&b.0));
        match candidate {
            Some((value, q)) if value < best => {
                best = value;
                p = q;
                step *= GROW;
            }
            _ => step *= SHRINK,
        }
    }
    Some(PivotEstimate {
        pivot: p,
        start_objective,
        objective: best,
        mean_length_change: changes(frames, &p).0,
        iterations,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Head markers turning about a known pivot 12 cm below and behind them (with a little
    /// marker noise): the search finds it to within a few millimetres from 8 cm away.
    #[test]
    fn finds_a_known_pivot() {
        let pivot = [0.01, -0.12, -0.05];
        let head = [
            [0.0, 0.0, 0.0],
            [0.05, 0.01, -0.01],
            [-0.05, 0.01, -0.01],
            [0.0, -0.04, 0.02],
        ];
        let mut noise = crate::ground_truth::SplitMix64(3);
        let frames: Vec<Vec<[f64; 3]>> = (0..60)
            .map(|f| {
                let t = f as f64 * 0.1;
                let (a, b) = (0.3 * t.sin(), 0.2 * (1.7 * t).cos());
                head.iter()
                    .map(|h| {
                        let d = [0, 1, 2].map(|c| h[c] - pivot[c]);
                        // Turn about y by a, then about x by b.
                        let (sa, ca) = a.sin_cos();
                        let (sb, cb) = b.sin_cos();
                        let r1 = [ca * d[0] + sa * d[2], d[1], -sa * d[0] + ca * d[2]];
                        let r2 = [r1[0], cb * r1[1] - sb * r1[2], sb * r1[1] + cb * r1[2]];
                        [0, 1, 2].map(|c| {
                            pivot[c]
                                + r2[c]
                                + 1e-5 * (noise.next_u64() as f64 / u64::MAX as f64 - 0.5)
                        })
                    })
                    .collect()
            })
            .collect();
        let start = [0.0, -0.05, 0.0];
        let est = estimate_pivot(&frames, start, 0.1).expect("enough data");
        let err = distance(&est.pivot, &pivot);
        assert!(err < 0.005, "pivot {:?}, {err} m off", est.pivot);
        assert!(est.objective < 0.1 * est.start_objective);
    }

    #[test]
    fn too_little_data_is_none() {
        assert_eq!(estimate_pivot(&[vec![[0.0; 3]; 3]], [0.0; 3], 1.0), None);
        assert_eq!(
            estimate_pivot(&[vec![[0.0; 3]; 2], vec![[0.0; 3]; 2]], [0.0; 3], 1.0),
            None
        );
    }
}
