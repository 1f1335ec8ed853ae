//! The radial kernels φ and how their widths are chosen.

use serde::{Deserialize, Serialize};

pub use crate::mesh::distance;

/// Which radial function, before its width is resolved against the marker layout.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum RadialFunction {
    /// φ(r) = exp(−(r/c)²).
    Gaussian,
    /// φ_i(r) = 1/√(r² + r_i²), r_i = distance from centre i to its nearest other centre
    /// (paper 000 eqs 15–16).
    InverseMultiquadric,
    /// φ(r) = √(r² + c²) (thesis eq 2.3b with a width).
    Multiquadric,
    /// φ(r) = exp(−r/c) (thesis eq 2.3a, paper 003's e^(−r/64)).
    Exponential,
    /// φ(r) = (r/c)² ln(r/c), 0 at r = 0 (thesis eq 2.3c); needs the affine term.
    ThinPlate,
}

impl RadialFunction {
    /// Every kernel, for sweeps.
    pub const ALL: [RadialFunction; 5] = [
        Self::Gaussian,
        Self::InverseMultiquadric,
        Self::Multiquadric,
        Self::Exponential,
        Self::ThinPlate,
    ];

    /// The name used on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            Self::Gaussian => "gaussian",
            Self::InverseMultiquadric => "inverse-multiquadric",
            Self::Multiquadric => "multiquadric",
            Self::Exponential => "exponential",
            Self::ThinPlate => "thin-plate",
        }
    }

    /// Whether φ grows with distance (multiquadric, thin plate): its terms cannot be truncated
    /// to the K nearest centres, so it bakes only to the linear deformer.
    pub fn grows(self) -> bool {
        matches!(self, Self::Multiquadric | Self::ThinPlate)
    }

    /// Resolve the width: `width` if given, else `width_factor × mean nearest-centre distance`.
    /// The inverse multiquadric ignores both and uses per-centre radii.
    pub fn resolve(self, centres: &[[f64; 3]], width: Option<f64>, width_factor: f64) -> Kernel {
        let radii = nearest_distances(centres);
        let mean = radii.iter().sum::<f64>() / radii.len().max(1) as f64;
        let c = width.unwrap_or(width_factor * mean);
        match self {
            Self::Gaussian => Kernel::Gaussian { c },
            Self::InverseMultiquadric => Kernel::InverseMultiquadric { radii },
            Self::Multiquadric => Kernel::Multiquadric { c },
            Self::Exponential => Kernel::Exponential { c },
            Self::ThinPlate => Kernel::ThinPlate { c },
        }
    }
}

/// A kernel with its widths resolved.
#[derive(Clone, Debug, PartialEq)]
pub enum Kernel {
    /// exp(−(r/c)²)
    Gaussian {
        /// Width, asset units.
        c: f64,
    },
    /// 1/√(r² + r_i²)
    InverseMultiquadric {
        /// Per-centre radius r_i, asset units.
        radii: Vec<f64>,
    },
    /// √(r² + c²)
    Multiquadric {
        /// Width, asset units.
        c: f64,
    },
    /// exp(−r/c)
    Exponential {
        /// Width, asset units.
        c: f64,
    },
    /// (r/c)² ln(r/c)
    ThinPlate {
        /// Length unit, asset units.
        c: f64,
    },
}

impl Kernel {
    /// φ of centre `i` at distance `r`.
    pub fn phi(&self, i: usize, r: f64) -> f64 {
        match self {
            Self::Gaussian { c } => (-(r / c) * (r / c)).exp(),
            Self::InverseMultiquadric { radii } => 1.0 / (r * r + radii[i] * radii[i]).sqrt(),
            Self::Multiquadric { c } => (r * r + c * c).sqrt(),
            Self::Exponential { c } => (-r / c).exp(),
            Self::ThinPlate { c } => {
                let s = r / c;
                if s > 0.0 {
                    s * s * s.ln()
                } else {
                    0.0
                }
            }
        }
    }

    /// Whether the kernel needs the affine term for a solvable system.
    pub fn requires_affine(&self) -> bool {
        matches!(self, Self::ThinPlate { .. })
    }
}

/// For each centre, the distance to its nearest other centre (paper 000 eq 16).
pub fn nearest_distances(centres: &[[f64; 3]]) -> Vec<f64> {
    centres
        .iter()
        .enumerate()
        .map(|(i, a)| {
            centres
                .iter()
                .enumerate()
                .filter(|&(j, _)| j != i)
                .map(|(_, b)| distance(a, b))
                .fold(f64::INFINITY, f64::min)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kernels_match_their_formulas() {
        let centres = [[0.0, 0.0, 0.0], [3.0, 0.0, 0.0], [0.0, 4.0, 0.0]];
        assert_eq!(nearest_distances(&centres), vec![3.0, 3.0, 4.0]);
        let imq = RadialFunction::InverseMultiquadric.resolve(&centres, None, 1.0);
        assert!((imq.phi(2, 3.0) - 0.2).abs() < 1e-15);
        let g = Kernel::Gaussian { c: 2.0 };
        assert!((g.phi(0, 2.0) - (-1.0f64).exp()).abs() < 1e-15);
        let tps = Kernel::ThinPlate { c: 1.0 };
        assert_eq!(tps.phi(0, 0.0), 0.0);
        assert!((tps.phi(0, std::f64::consts::E) - std::f64::consts::E.powi(2)).abs() < 1e-12);
        let mq = RadialFunction::Multiquadric.resolve(&centres, Some(4.0), 1.0);
        assert_eq!(mq.phi(0, 3.0), 5.0);
        let e = RadialFunction::Exponential.resolve(&centres, None, 1.5);
        assert!(
            (e.phi(0, 5.0) - (-1.0f64).exp()).abs() < 1e-15,
            "mean spacing 10/3 × 1.5 = 5"
        );
    }
}
