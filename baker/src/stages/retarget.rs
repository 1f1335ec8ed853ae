//! Retargeting the actor's markers onto the character (paper 000 §5.1, eqs 13–16): an RBF map
//! from the actor's neutral marker positions (the sources U) to the same markers on the character
//! (the targets V), inverse multiquadric with per-centre radius r_i = distance to the nearest
//! other centre, plus an affine term. Every later (head-compensated) frame is pushed through the
//! same map.
//!
//! The map interpolates U → V exactly and reproduces affine maps exactly, so retargeting an actor
//! onto himself is the identity and onto a uniformly scaled copy scales the motion.

use nalgebra::DMatrix;

use super::rigid::kabsch;
use super::StagesError;
use crate::frame::FaceFrame;
use crate::mesh::distance;
use crate::rbf::{Kernel, RadialFunction, RbfSystem, SolveError};

/// An RBF map from actor space to character space.
pub struct RetargetMap {
    system: RbfSystem,
    /// Coefficients `[α; β]` for the three target coordinates.
    coefficients: DMatrix<f64>,
}

impl RetargetMap {
    /// The map carrying `actor_neutral[i]` to `character[i]` for every marker.
    pub fn new(actor_neutral: &[[f64; 3]], character: &[[f64; 3]]) -> Result<Self, SolveError> {
        let kernel = RadialFunction::InverseMultiquadric.resolve(actor_neutral, None, 1.0);
        let system = RbfSystem::new(actor_neutral, kernel, true, &vec![1.0; actor_neutral.len()])?;
        // Interpolate the target positions themselves (not displacements): f(U_i) = V_i.
        let coefficients = system.solve(character);
        Ok(Self {
            system,
            coefficients,
        })
    }

    /// A point of actor space in character space.
    pub fn map(&self, p: &[f64; 3]) -> [f64; 3] {
        self.system.evaluate(&self.coefficients, p)
    }

    /// The per-centre kernel radii rᵢ (actor units): φᵢ(d) = 1/√(d² + rᵢ²).
    pub fn radii(&self) -> &[f64] {
        match self.system.kernel() {
            Kernel::InverseMultiquadric { radii } => radii,
            _ => &[],
        }
    }

    /// The coefficients `[α; β₀; βx; βy; βz]`, one column per output coordinate:
    /// f(p) = Σᵢ αᵢ φᵢ(‖p − uᵢ‖) + β₀ + βx pₓ + βy p_y + βz p_z.
    pub fn coefficients(&self) -> &DMatrix<f64> {
        &self.coefficients
    }

    /// 1-norm condition estimate of the map's system.
    pub fn condition(&self) -> f64 {
        self.system.condition()
    }
}

/// Paper 003 §4's proportional retargeting, in f64: `v_j + M_j d_j`.
#[derive(Clone, Debug, PartialEq)]
pub struct Proportional {
    /// Per marker, M_j (character rig units per actor unit).
    pub matrices: Vec<[[f64; 3]; 3]>,
    /// Per marker, v_j (character rig units).
    pub rest: Vec<[f64; 3]>,
    /// Per-axis scales of the upper face (character markers at or above their median height)
    /// and of the lower face, along the character face's own axes (right, up, front).
    pub scales: [[f64; 3]; 2],
}

impl Proportional {
    /// Build it from the actor's neutral markers (actor units) and the character's (rig units):
    /// the rotation between the faces (Kabsch on the centred marker sets), then per region and
    /// axis the ratio of the character's marker extent to the turned actor's, both read in the
    /// character face's own axes (`face`: [`FaceFrame::of`] the mesh; [`FaceFrame::FILE`] for an
    /// upright face), so a head rolled or pitched in its file scales its width as a width. The
    /// regions split at the median height of the character's markers along the face's up.
    pub fn new(
        neutral: &[[f64; 3]],
        character: &[[f64; 3]],
        face: &FaceFrame,
    ) -> Result<Self, StagesError> {
        let fit = kabsch(neutral, character)?;
        let r = fit.rotation;
        let mean = |p: &[[f64; 3]]| {
            [0, 1, 2].map(|c| p.iter().map(|q| q[c]).sum::<f64>() / p.len() as f64)
        };
        let (cu, cv) = (mean(neutral), mean(character));
        let turned: Vec<[f64; 3]> = neutral
            .iter()
            .map(|u| {
                let d = nalgebra::Vector3::new(u[0] - cu[0], u[1] - cu[1], u[2] - cu[2]);
                let w = r * d;
                [w.x, w.y, w.z]
            })
            .collect();
        let (local_character, local_turned) = (face.points(character), face.points(&turned));
        let mut heights: Vec<f64> = local_character.iter().map(|v| v[1]).collect();
        heights.sort_by(f64::total_cmp);
        let median = heights[heights.len() / 2];
        let upper = |j: usize| local_character[j][1] >= median;
        let extent = |pts: &mut dyn Iterator<Item = f64>| {
            let (lo, hi) = pts.fold((f64::MAX, f64::MIN), |(lo, hi), x| (lo.min(x), hi.max(x)));
            hi - lo
        };
        let n = neutral.len();
        let overall = {
            let spread = |p: &[[f64; 3]], c: [f64; 3]| {
                p.iter().map(|q| distance(q, &c).powi(2)).sum::<f64>()
            };
            (spread(character, cv) / spread(neutral, cu).max(f64::MIN_POSITIVE)).sqrt()
        };
        let scales = [true, false].map(|up| {
            [0, 1, 2].map(|c| {
                let ev = extent(
                    &mut (0..n)
                        .filter(|&j| upper(j) == up)
                        .map(|j| local_character[j][c]),
                );
                let ew = extent(
                    &mut (0..n)
                        .filter(|&j| upper(j) == up)
                        .map(|j| local_turned[j][c]),
                );
                if ew > 1e-9 && ev > 1e-9 {
                    ev / ew
                } else {
                    overall
                }
            })
        });
        // M_j = Fᵀ · diag(s) · F · R, with F the face's axes (rows): diag(s) · R when F = I.
        let f = face.axes();
        let fr =
            [0, 1, 2].map(|a| [0, 1, 2].map(|c| (0..3).map(|b| f[a][b] * r[(b, c)]).sum::<f64>()));
        let matrices = (0..n)
            .map(|j| {
                let s = scales[usize::from(!upper(j))];
                [0, 1, 2].map(|row| {
                    [0, 1, 2].map(|c| (0..3).map(|a| f[a][row] * s[a] * fr[a][c]).sum::<f64>())
                })
            })
            .collect();
        Ok(Self {
            matrices,
            rest: character.to_vec(),
            scales,
        })
    }

    /// Character marker `j` for the compensated actor displacement `d`.
    pub fn map(&self, j: usize, d: &[f64; 3]) -> [f64; 3] {
        let m = &self.matrices[j];
        [0, 1, 2].map(|row| self.rest[j][row] + (0..3).map(|c| m[row][c] * d[c]).sum::<f64>())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::capture::read_capture;
    use crate::mesh::distance;

    fn frames() -> Vec<Vec<[f64; 3]>> {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../fixtures/JawMoCap.trc");
        let cap = read_capture(std::path::Path::new(path)).expect("JawMoCap reads");
        cap.frames
            .iter()
            .map(|f| f.iter().map(|p| p.expect("complete capture")).collect())
            .collect()
    }

    #[test]
    fn onto_himself_is_the_identity() {
        let f = frames();
        let map = RetargetMap::new(&f[0], &f[0]).unwrap();
        let mut worst = 0.0f64;
        for frame in f.iter().step_by(10) {
            for p in frame {
                worst = worst.max(distance(&map.map(p), p));
            }
        }
        // JawMoCap is in centimetres: 1e-9 cm.
        assert!(
            worst < 1e-9,
            "identity retarget moved a marker by {worst} cm"
        );
    }

    #[test]
    fn onto_a_scaled_copy_scales_the_motion() {
        let f = frames();
        let s = 0.37;
        let scaled: Vec<[f64; 3]> = f[0].iter().map(|p| p.map(|x| s * x)).collect();
        let map = RetargetMap::new(&f[0], &scaled).unwrap();
        let mut worst = 0.0f64;
        for frame in f.iter().step_by(10) {
            for (p, p0) in frame.iter().zip(&f[0]) {
                let moved = map.map(p);
                let want = [0, 1, 2].map(|c| s * p0[c] + s * (p[c] - p0[c]));
                worst = worst.max(distance(&moved, &want));
            }
        }
        assert!(worst < 1e-9, "scaled retarget is off by {worst} cm");
    }

    #[test]
    fn a_non_affine_target_is_interpolated_exactly_at_the_markers() {
        // A target the affine part cannot explain (the neutral bent by a bump): the RBF part
        // must carry every neutral marker exactly onto its target.
        let f = frames();
        let target: Vec<[f64; 3]> = f[0]
            .iter()
            .map(|p| [p[0], p[1] * (1.0 + 0.05 * (p[0] * 0.3).sin()), p[2]])
            .collect();
        let map = RetargetMap::new(&f[0], &target).unwrap();
        for (p, t) in f[0].iter().zip(&target) {
            assert!(distance(&map.map(p), t) < 1e-8);
        }
        assert!(map.condition().is_finite());
    }
}
