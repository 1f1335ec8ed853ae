//! Retargeting the actor's markers onto the character (paper 000 §5.1, eqs 13–16): an RBF map
//! from the actor's neutral marker positions (the sources U) to the same markers on the character
//! (the targets V), inverse multiquadric with per-centre radius r_i = distance to the nearest
//! other centre, plus an affine term. Every later (head-compensated) frame is pushed through the
//! same map.
//!
//! The map interpolates U → V exactly and reproduces affine maps exactly, so retargeting an actor
//! onto himself is the identity and onto a uniformly scaled copy scales the motion.

use nalgebra::DMatrix;

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
