//! The RBF interpolation system (paper 000 eq 14): kernel block, optional affine block, and
//! per-centre stiffness on the diagonal.

use nalgebra::{DMatrix, DVector};

use super::radial::{distance, Kernel};

/// Diagonal regulariser for stiffness 9, as a fraction of the mean |φ| of the kernel block.
/// Stiffness s ∈ [1, 9] adds `(s − 1)/8 × STIFFNESS_AT_9 × mean|Φ|` to centre i's diagonal:
/// 1 interpolates the marker exactly (the default), higher values let the surface lag the marker,
/// smoothing its neighbourhood (the thesis' "1 most flexible, 9 stiffest").
pub const STIFFNESS_AT_9: f64 = 0.5;

/// Condition numbers (1-norm) above this get a warning.
pub const CONDITION_WARNING: f64 = 1e10;

/// The system could not be solved.
#[derive(Debug, thiserror::Error)]
pub enum SolveError {
    /// Fewer centres than the system needs.
    #[error("{found} markers are too few: the RBF needs at least {needed}")]
    TooFewCentres {
        /// Centres given.
        found: usize,
        /// Centres needed.
        needed: usize,
    },
    /// The matrix is singular (coincident markers, or coplanar markers with the affine term).
    #[error("the RBF system is singular (coincident markers, or all markers on one plane with the affine term)")]
    Singular,
    /// The thin-plate kernel without the affine term.
    #[error("the {0} kernel needs the affine term")]
    NeedsAffine(&'static str),
    /// Static anchoring of the RBF deformer without the affine term it prescribes.
    #[error("static anchoring of the RBF deformer needs the affine term (drop --no-affine, or bake with --no-anchoring)")]
    AnchoringNeedsAffine,
    /// Static anchoring of the RBF deformer with no marker to anchor on.
    #[error("static anchoring of the RBF deformer found no marker clear of the mouth and eyes to anchor on (bake with --no-anchoring)")]
    NoAnchors,
}

/// A factored RBF system over fixed centres (the markers' rest positions on the character).
pub struct RbfSystem {
    centres: Vec<[f64; 3]>,
    kernel: Kernel,
    affine: bool,
    /// The system matrix A (for the reference's per-frame solve).
    matrix: DMatrix<f64>,
    /// A⁻¹, from which the per-vertex weights come.
    inverse: DMatrix<f64>,
    /// ‖A‖₁ ‖A⁻¹‖₁.
    condition: f64,
}

fn one_norm(m: &DMatrix<f64>) -> f64 {
    m.column_iter()
        .map(|c| c.iter().map(|x| x.abs()).sum::<f64>())
        .fold(0.0, f64::max)
}

impl RbfSystem {
    /// Build and factor the system. `stiffness` has one value in [1, 9] per centre.
    pub fn new(
        centres: &[[f64; 3]],
        kernel: Kernel,
        affine: bool,
        stiffness: &[f64],
    ) -> Result<Self, SolveError> {
        let distances = DMatrix::from_fn(centres.len(), centres.len(), |j, i| {
            distance(&centres[j], &centres[i])
        });
        Self::with_distances(centres, &distances, kernel, affine, stiffness, 0.0)
    }

    /// Build and factor the system from given centre-to-centre distances (geodesic, hybrid):
    /// `distances[(j, i)]` is centre `i`'s distance as seen at centre `j`, so the interpolant
    /// reproduces the markers exactly when vertices use the same distance function. The
    /// affine block still uses the centres' positions. `ridge`, a fraction of the mean |φ|, is
    /// added to every diagonal entry of the kernel block (on top of the stiffness), to keep an
    /// indefinite kernel matrix away from singularity.
    pub fn with_distances(
        centres: &[[f64; 3]],
        distances: &DMatrix<f64>,
        kernel: Kernel,
        affine: bool,
        stiffness: &[f64],
        ridge: f64,
    ) -> Result<Self, SolveError> {
        let n = centres.len();
        let needed = if affine { 5 } else { 2 };
        if n < needed {
            return Err(SolveError::TooFewCentres { found: n, needed });
        }
        if kernel.requires_affine() && !affine {
            return Err(SolveError::NeedsAffine("thin-plate"));
        }
        let size = n + if affine { 4 } else { 0 };
        let mut a = DMatrix::<f64>::zeros(size, size);
        for j in 0..n {
            for i in 0..n {
                a[(j, i)] = kernel.phi(i, distances[(j, i)]);
            }
        }
        let mean_phi = a.view((0, 0), (n, n)).iter().map(|x| x.abs()).sum::<f64>() / (n * n) as f64;
        for (i, s) in stiffness.iter().enumerate().take(n) {
            a[(i, i)] += ((s - 1.0) / 8.0 * STIFFNESS_AT_9 + ridge) * mean_phi;
        }
        if affine {
            for (j, x) in centres.iter().enumerate() {
                let p = [1.0, x[0], x[1], x[2]];
                for k in 0..4 {
                    a[(j, n + k)] = p[k];
                    a[(n + k, j)] = p[k];
                }
            }
        }
        let inverse = a.clone().lu().try_inverse().ok_or(SolveError::Singular)?;
        if inverse.iter().any(|x| !x.is_finite()) {
            return Err(SolveError::Singular);
        }
        let condition = one_norm(&a) * one_norm(&inverse);
        Ok(Self {
            centres: centres.to_vec(),
            kernel,
            affine,
            matrix: a,
            inverse,
            condition,
        })
    }

    /// Number of centres.
    pub fn len(&self) -> usize {
        self.centres.len()
    }

    /// Whether there are no centres (never, for a built system).
    pub fn is_empty(&self) -> bool {
        self.centres.is_empty()
    }

    /// 1-norm condition estimate ‖A‖₁‖A⁻¹‖₁.
    pub fn condition(&self) -> f64 {
        self.condition
    }

    /// The kernel.
    pub fn kernel(&self) -> &Kernel {
        &self.kernel
    }

    /// The map from marker displacements to coefficients `[α; β]`: the first `n` columns of
    /// A⁻¹, one row per coefficient (`n` kernel rows, then β₀, βx, βy, βz with the affine term).
    pub fn coefficient_map(&self) -> DMatrix<f64> {
        self.inverse.columns(0, self.len()).into_owned()
    }

    /// The coefficient map with the affine part prescribed instead of fitted: β₀ the mean
    /// displacement of the `anchors` (centre indices), βx = βy = βz = 0, and the radial
    /// coefficients interpolating the rest, α = Φ⁻¹ (D − P β) (Φ the kernel block with its
    /// diagonal terms, P the centres' `[1, x]` rows). The interpolant still reproduces every
    /// centre (Φ α + P β = D), and far from the centres, where the radial terms have decayed, it
    /// is the anchors' mean translation: static anchoring for the RBF deformer. Needs the affine
    /// block and at least one anchor.
    pub fn anchored_coefficient_map(&self, anchors: &[usize]) -> Result<DMatrix<f64>, SolveError> {
        let n = self.len();
        if !self.affine {
            return Err(SolveError::AnchoringNeedsAffine);
        }
        if anchors.is_empty() || anchors.iter().any(|&a| a >= n) {
            return Err(SolveError::NoAnchors);
        }
        let phi = self.matrix.view((0, 0), (n, n)).into_owned();
        let p = self.matrix.view((0, n), (n, 4)).into_owned();
        let mut beta = DMatrix::<f64>::zeros(4, n);
        for &a in anchors {
            beta[(0, a)] += 1.0 / anchors.len() as f64;
        }
        let alpha = phi
            .lu()
            .solve(&(DMatrix::<f64>::identity(n, n) - &p * &beta))
            .ok_or(SolveError::Singular)?;
        if alpha.iter().any(|x| !x.is_finite()) {
            return Err(SolveError::Singular);
        }
        let mut map = DMatrix::<f64>::zeros(n + 4, n);
        map.view_mut((0, 0), (n, n)).copy_from(&alpha);
        map.view_mut((n, 0), (4, n)).copy_from(&beta);
        Ok(map)
    }

    /// The dense weights of point `v` (distances `d[i]` to the centres) under a coefficient
    /// `map` whose first `n` columns are shaped as [`Self::coefficient_map`]'s (A⁻¹ itself
    /// serves).
    pub fn weights_with_map(&self, map: &DMatrix<f64>, d: &[f64], v: &[f64; 3]) -> Vec<f64> {
        let g = DVector::from_vec(self.basis_from(d, v));
        (0..self.len()).map(|i| map.column(i).dot(&g)).collect()
    }

    /// Whether the system has the affine block.
    pub fn affine(&self) -> bool {
        self.affine
    }

    /// g(v): the kernel values at `v`, then `[1, v]` with the affine term.
    fn basis(&self, v: &[f64; 3]) -> Vec<f64> {
        let d: Vec<f64> = self.centres.iter().map(|x| distance(v, x)).collect();
        self.basis_from(&d, v)
    }

    /// g(v) from the distances `d[i]` of point `v` to each centre.
    fn basis_from(&self, d: &[f64], v: &[f64; 3]) -> Vec<f64> {
        let mut g: Vec<f64> = d
            .iter()
            .enumerate()
            .map(|(i, &r)| self.kernel.phi(i, r))
            .collect();
        if self.affine {
            g.extend_from_slice(&[1.0, v[0], v[1], v[2]]);
        }
        g
    }

    /// The dense weights of point `v`: displacement(v) = Σ_i w_i D_i.
    pub fn weights_at(&self, v: &[f64; 3]) -> Vec<f64> {
        let d: Vec<f64> = self.centres.iter().map(|x| distance(v, x)).collect();
        self.weights_from_distances(&d, v)
    }

    /// The dense weights of point `v` whose distance to centre `i` is `d[i]` (the distance
    /// function the system was built with).
    pub fn weights_from_distances(&self, d: &[f64], v: &[f64; 3]) -> Vec<f64> {
        self.weights_with_map(&self.inverse, d, v)
    }

    /// The kernel block Φ (without stiffness or ridge), `n × n`.
    pub fn kernel_block(&self, distances: &DMatrix<f64>) -> DMatrix<f64> {
        DMatrix::from_fn(self.len(), self.len(), |j, i| {
            self.kernel.phi(i, distances[(j, i)])
        })
    }

    /// Solve for the coefficients [α; β] of one frame's marker displacements, per axis
    /// (the papers' per-frame solve, eq 14). Returns a (n [+4]) × 3 matrix.
    pub fn solve(&self, displacements: &[[f64; 3]]) -> DMatrix<f64> {
        let size = self.matrix.nrows();
        let mut rhs = DMatrix::<f64>::zeros(size, 3);
        for (i, d) in displacements.iter().enumerate() {
            for c in 0..3 {
                rhs[(i, c)] = d[c];
            }
        }
        self.matrix
            .clone()
            .lu()
            .solve(&rhs)
            .unwrap_or_else(|| &self.inverse * rhs)
    }

    /// Evaluate the interpolant with coefficients from [`Self::solve`] at `v`.
    pub fn evaluate(&self, coefficients: &DMatrix<f64>, v: &[f64; 3]) -> [f64; 3] {
        let g = self.basis(v);
        let mut out = [0.0; 3];
        for (k, gk) in g.iter().enumerate() {
            for c in 0..3 {
                out[c] += gk * coefficients[(k, c)];
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rbf::RadialFunction;

    fn centres() -> Vec<[f64; 3]> {
        (0..12)
            .map(|i| {
                let t = i as f64 * 0.7;
                [t.cos(), t.sin() * 0.8, (1.3 * t).sin() * 0.5]
            })
            .collect()
    }

    #[test]
    fn interpolates_and_reproduces_affine_motion() {
        let c = centres();
        for kind in RadialFunction::ALL {
            let k = kind.resolve(&c, None, 1.0);
            let sys = RbfSystem::new(&c, k, true, &vec![1.0; c.len()]).unwrap();
            // Weights at a centre select that centre.
            let w = sys.weights_at(&c[3]);
            for (i, wi) in w.iter().enumerate() {
                let want = if i == 3 { 1.0 } else { 0.0 };
                assert!((wi - want).abs() < 1e-7, "{kind:?} w[{i}] = {wi}");
            }
            // Weights anywhere reproduce constants and linear functions (the affine block).
            let v = [0.2, -0.1, 0.3];
            let w = sys.weights_at(&v);
            let sum: f64 = w.iter().sum();
            assert!((sum - 1.0).abs() < 1e-8, "{kind:?} Σw = {sum}");
            for axis in 0..3 {
                let lin: f64 = w.iter().zip(&c).map(|(wi, x)| wi * x[axis]).sum();
                assert!((lin - v[axis]).abs() < 1e-8, "{kind:?} linear precision");
            }
            // Weights agree with the per-frame solve.
            let d: Vec<[f64; 3]> = c.iter().map(|x| [x[1] * x[1], x[0] * x[2], 0.1]).collect();
            let coef = sys.solve(&d);
            let direct = sys.evaluate(&coef, &v);
            for axis in 0..3 {
                let via_w: f64 = w.iter().zip(&d).map(|(wi, di)| wi * di[axis]).sum();
                assert!((via_w - direct[axis]).abs() < 1e-9);
            }
        }
    }

    #[test]
    fn stiffness_relaxes_interpolation_and_singular_is_an_error() {
        let c = centres();
        let k = RadialFunction::Gaussian.resolve(&c, None, 1.5);
        let mut s = vec![1.0; c.len()];
        s[3] = 9.0;
        let sys = RbfSystem::new(&c, k.clone(), true, &s).unwrap();
        assert!(
            sys.weights_at(&c[3])[3] < 0.999,
            "a stiff marker no longer interpolates exactly"
        );
        let mut dup = c.clone();
        dup[1] = dup[0];
        assert!(matches!(
            RbfSystem::new(&dup, k, true, &vec![1.0; c.len()]),
            Err(SolveError::Singular)
        ));
        let tps = RadialFunction::ThinPlate.resolve(&c, None, 1.0);
        assert!(matches!(
            RbfSystem::new(&c, tps, false, &vec![1.0; c.len()]),
            Err(SolveError::NeedsAffine(_))
        ));
    }
}
