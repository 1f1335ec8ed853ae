//! The command line's value enums: the library's choices as `clap` sees them (the library does
//! not depend on `clap`).

use clap::ValueEnum;

/// `--deformer`: the library's deformers by name, each with its description as help.
pub fn deformer_parser() -> impl clap::builder::TypedValueParser<Value = facebake::DeformerKind> {
    use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};
    use facebake::DeformerKind;
    PossibleValuesParser::new(
        DeformerKind::ALL.map(|d| PossibleValue::new(d.name()).help(d.description())),
    )
    .try_map(|name: String| {
        DeformerKind::from_name(&name).ok_or_else(|| format!("no deformer named {name:?}"))
    })
}

/// `--method`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum MethodArg {
    /// Straight-line distance.
    Euclidean,
    /// Distance along the surface.
    Geodesic,
    /// Geodesic near the mouth and eyes, Euclidean elsewhere.
    Hybrid,
    /// Proximity-based weighting on geodesics blended with the geodesic RBF.
    Pbw,
}

impl From<MethodArg> for facebake::Method {
    fn from(a: MethodArg) -> Self {
        match a {
            MethodArg::Euclidean => Self::Euclidean,
            MethodArg::Geodesic => Self::Geodesic,
            MethodArg::Hybrid => Self::Hybrid,
            MethodArg::Pbw => Self::Pbw,
        }
    }
}

/// `--radial`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum RadialArg {
    /// φ(r) = exp(−(r/c)²).
    Gaussian,
    /// φ_i(r) = 1/√(r² + r_i²), r_i the distance to the nearest other marker.
    InverseMultiquadric,
    /// φ(r) = √(r² + c²).
    Multiquadric,
    /// φ(r) = exp(−r/c).
    Exponential,
    /// φ(r) = (r/c)² ln(r/c); needs the affine term.
    ThinPlate,
}

impl From<RadialArg> for facebake::RadialFunction {
    fn from(a: RadialArg) -> Self {
        match a {
            RadialArg::Gaussian => Self::Gaussian,
            RadialArg::InverseMultiquadric => Self::InverseMultiquadric,
            RadialArg::Multiquadric => Self::Multiquadric,
            RadialArg::Exponential => Self::Exponential,
            RadialArg::ThinPlate => Self::ThinPlate,
        }
    }
}

/// `--refit`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum RefitArg {
    /// Spread the dropped mass evenly over the kept weights.
    Uniform,
    /// Best prediction of the dropped markers under a smooth-motion prior.
    Prior,
    /// Every magnitude less the (K+1)-th largest, rescaled: continuous over the skin.
    Shrink,
}

impl From<RefitArg> for facebake::Refit {
    fn from(a: RefitArg) -> Self {
        match a {
            RefitArg::Uniform => Self::Uniform,
            RefitArg::Prior => Self::Prior,
            RefitArg::Shrink => Self::Shrink,
        }
    }
}

/// `--retarget`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum RetargetArg {
    /// The RBF map of paper 000 §5.1: inverse multiquadric with per-centre radii plus affine.
    Rbf,
    /// Paper 003 §4's per-region proportional scaling.
    Proportional,
    /// Paper 002 §2.1's RBF map with distances along the skin, linearised per marker.
    Geodesic,
}

impl From<RetargetArg> for facebake::RetargetKind {
    fn from(a: RetargetArg) -> Self {
        match a {
            RetargetArg::Rbf => Self::Rbf,
            RetargetArg::Proportional => Self::Proportional,
            RetargetArg::Geodesic => Self::Geodesic,
        }
    }
}
