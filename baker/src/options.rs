//! How to bake: every choice of [`crate::bake()`] in one value, with the defaults of each method.

use crate::deformer::DeformerKind;
use crate::geodesic::GeodesicMethod;
use crate::rbf::RadialFunction;
use crate::sparsify::Refit;
use crate::stages::StagesConfig;

/// Which distance the RBF is built on, or PBW's weighting: the strategy the deformation's dense
/// weights come from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Method {
    /// Straight-line distance.
    Euclidean,
    /// Distance along the surface.
    Geodesic,
    /// Geodesic near the mouth and eyes, Euclidean elsewhere.
    Hybrid,
    /// Proximity-based weighting on geodesics blended with the geodesic RBF (paper 002 §2.2,
    /// whose global RBF is a Euclidean multiquadric, see `surface::pbw`; linear deformer only).
    Pbw,
}

impl Method {
    /// Every method, for sweeps.
    pub const ALL: [Method; 4] = [Self::Euclidean, Self::Geodesic, Self::Hybrid, Self::Pbw];

    /// Name on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            Self::Euclidean => "euclidean",
            Self::Geodesic => "geodesic",
            Self::Hybrid => "hybrid",
            Self::Pbw => "pbw",
        }
    }
}

/// The surface-aware choices: geodesics, the hybrid's region, the masks' fade, PBW's blend and
/// the ridge.
#[derive(Clone, Debug, PartialEq)]
pub struct SurfaceOptions {
    /// How geodesics are computed.
    pub geodesic: GeodesicMethod,
    /// Hybrid: radius of the geodesic region around the openings, × mean marker spacing.
    pub region_factor: f64,
    /// Hybrid: width of the Gaussian decay outside the region, × mean marker spacing.
    pub decay_factor: f64,
    /// Masks: distance from the openings within which a mask is at full strength, × mean
    /// marker spacing.
    pub mask_plateau_factor: f64,
    /// Masks: width of the Gaussian fade beyond it, × mean marker spacing.
    pub mask_decay_factor: f64,
    /// Masks (linear deformer): where a vertex is nearly as near one side's markers as the
    /// other's (at and past an opening's corners), the mask fades out over this difference of
    /// the two distances, × mean marker spacing ([`crate::surface::masks::vertex_sides`]); 0
    /// switches sides abruptly there.
    pub mask_side_factor: f64,
    /// PBW: α of paper 002's eq 11, the share of the local (proximity) weights; the rest is the
    /// global RBF (on geodesic distances).
    pub pbw_alpha: f64,
    /// Ridge on the kernel diagonal as a fraction of the mean |φ|; `None`: just enough to make
    /// the kernel block positive semi-definite, plus [`crate::surface::RIDGE_MARGIN`] when it is
    /// not.
    pub ridge: Option<f64>,
    /// Reshape the weights near the openings' corners so that lips and lids part as a crack
    /// opens ([`crate::surface::corners`]; linear deformer).
    pub corners: bool,
    /// Correct the weights beside the mouth's rim so that each lip curves through its markers
    /// rather than running straight between them ([`crate::surface::lip_curve`]; with the
    /// masks and the corners, linear deformer).
    pub lip_curve: bool,
    /// Across a lip or lid, between the opening's rim and a marker worn on it, distances count
    /// this fraction of their length, so that the rim moves with the marker in front of it
    /// ([`crate::surface::distances::shorten_across_rims`]; 1 leaves distances as measured;
    /// surface distances, the linear and RBF deformers).
    pub rim_across: f64,
    /// How far from each corner of the mouth the skin past it is balanced between the lips, ×
    /// mean marker spacing ([`crate::surface::corners::balance_past_mouth_corners`]; linear
    /// deformer, with the corners reshaped).
    pub past_corner_reach: f64,
    /// At the mouth, the share of the corners' square-root profile taken ([`MOUTH_SHARE`];
    /// with a capture the bake may take less, `bake::mouth_share`).
    pub mouth_share: f64,
    /// With a capture, relax the weights where the capture folds the skin (`bake::relax`;
    /// linear deformer, surface path).
    pub relax: bool,
}

/// At the mouth, the share of the corners' square-root profile taken (`surface::corners`) (the
/// rest stays linear): the largest step of 0.1 that stretches no edge past 2×, on FaceCap's
/// truth with the JawMoCap layout, on it subdivided once, or on JawMoCap. Measured 2026-12-04
/// (`--test structure`; docs/measurements.md):
///
/// | share | truth lips, lip band p99 | truth stretch (edges > 2×) | subdivided once | JawMoCap |
/// |---|---|---|---|---|
/// | **0.7** | **7.1 mm, 4.21 mm** | **1.89× (0)** | **1.99× (0)** | **1.90×** |
/// | 0.8 | 6.6, 4.19 | 1.97× (0) | 2.10× (4) | 1.99× |
/// | 0.9 | 6.3, 4.16 | 2.09× (2) | – | – |
/// | 1.0 | 6.2, 4.16 | 2.21× (4) | – | – |
///
/// With the linear profile alone (0) the truth's lips were 12.5 mm off (2026-12-01). Past 0.7
/// the corners' short edges stretch where the truth keeps the corners shut while the lip
/// markers part.
pub const MOUTH_SHARE: f64 = 0.7;

impl Default for SurfaceOptions {
    /// Heat-method geodesics; hybrid region and decay [`HYBRID_REACH`] × spacing; masks at
    /// full strength within 0.5 × spacing of the opening, fading over 1 × spacing; PBW's local
    /// share [`PBW_ALPHA`]; across the rims, [`RIM_ACROSS`]; the balance past the mouth's
    /// corners over [`PAST_CORNER_REACH`] × spacing.
    fn default() -> Self {
        Self {
            geodesic: GeodesicMethod::Heat,
            region_factor: HYBRID_REACH,
            decay_factor: HYBRID_REACH,
            mask_plateau_factor: 0.5,
            mask_decay_factor: 1.0,
            mask_side_factor: 0.0,
            pbw_alpha: PBW_ALPHA,
            ridge: None,
            corners: true,
            lip_curve: true,
            rim_across: RIM_ACROSS,
            past_corner_reach: PAST_CORNER_REACH,
            mouth_share: MOUTH_SHARE,
            relax: true,
        }
    }
}

/// The hybrid distances' geodesic region about the openings and its decay beyond, each × the
/// mean marker spacing. On FaceCap's truth with the JawMoCap layout and on JawMoCap, masked
/// (`--test structure`), region / decay 0.5 / 0.5: truth flips 1, face mean 0.568 mm, JawMoCap
/// 2.01× (67 frames over 2×); 1 / 0.5: 1, 0.563, 1.98×; 0.5 / 1: 1, 0.559, 1.96×; **1 / 1**: 1,
/// 0.558, 1.93× (unmasked 1 flip, not 15); 1.5 / 1: 1, 0.553, 1.92×, the geodesic default's
/// figures, which a wider region tends to.
pub const HYBRID_REACH: f64 = 1.0;

/// PBW's share of its local (proximity) weights in paper 002's blend (eq 11), the rest the
/// global RBF on geodesics; the paper leaves α open. On FaceCap's truth with the JawMoCap
/// layout and on JawMoCap, masked (`--test structure`), α = 0.25 / 0.5 / 0.75 with the prior's
/// re-fit: truth 2.17× / 2.89× / 4.11×, flips 4 / 13 / 18, eyelids 1.2 / 1.6 / 2.0 mm, face
/// mean 0.605 / 0.654 / 0.716 mm; JawMoCap 1.91× / 2.72× / 3.27×, flips 2 / 6 / 13. Shrunk,
/// α = **0.25** / 0.5: truth **1.94×** / 3.15×, flips **2** / 12, eyelids 1.0 / 1.4 mm, face
/// mean 0.581 / 0.628 mm; JawMoCap **1.85×** / 2.30×, flips **0** / 2. The local weights
/// interpolate linearly between a vertex's nearest markers, so their share is what folds.
pub const PBW_ALPHA: f64 = 0.25;

/// How far a mask fades out at an opening's corners for distances along the skin, × the mean
/// marker spacing (see [`SurfaceOptions::mask_side_factor`]). Where the two sides' distances
/// differ by less (at a corner and past it), the unmasked weights take over, which distances
/// along the skin already keep apart across the opening. On FaceCap's truth with the JawMoCap
/// layout, the masked default (`--test structure`): 0 / 0.25 / 0.5 / 1: flips 5 / 1 / 1 / 1,
/// stretch 2.07× / 1.90× / 1.90× / 1.92×, eyelids 1.1 / 0.9 / 0.9 / 0.9 mm, lips 6.7 / 6.7 /
/// 6.7 / 6.8 mm; JawMoCap 1.98× / 2.26× (115 frames over 2×) / 1.99× / **1.92×** (0). Hybrid
/// with masks at 1: truth flips 5 → 1, JawMoCap frames over 2× 86 → 67.
pub const MASK_SIDE_SURFACE: f64 = 1.0;

/// [`MASK_SIDE_SURFACE`] for Euclidean distances, which do not keep the lips apart unmasked, so
/// the hand-over is short: `bake --method euclidean` at 0 / 0.1 / 0.25 / 0.5 / 1: truth flips
/// 3 / 2 / 2 / 2 / 2, lips 7.0 / 7.0 / 7.0 / 8.8 / 13.6 mm; JawMoCap 2.36× (118 frames) / 2.74×
/// (129) / **2.18× (108)** / 2.15× (106) / 2.02× (77), before the balance past the mouth's
/// corners reached [`PAST_CORNER_REACH_EUCLIDEAN`] (1.86× (0) at 0.25).
pub const MASK_SIDE_EUCLIDEAN: f64 = 0.25;

/// How far from a mouth corner (its rim's end), in mean marker spacings, the skin past it is
/// balanced between the lips ([`crate::surface::corners::balance_past_mouth_corners`]), for
/// distances along the skin ([`SurfaceOptions::past_corner_reach`]). At 0.4 the default
/// measured the same on both takes but for the lip band's p99 (4.21 → 4.24 mm, `--test
/// structure`).
pub const PAST_CORNER_REACH: f64 = 0.3;

/// [`PAST_CORNER_REACH`] for Euclidean distances, whose masks fade over a quarter of the
/// spacing the surface distances' do ([`MASK_SIDE_EUCLIDEAN`]), so that more of the skin
/// wrapping round a corner is left to the balance. Measured 2026-12-02 (`--test
/// structure`): at 0.3 `--method euclidean` stretched a 1 mm edge just past FaceCap's right
/// corner of the mouth 2.18× in 108 of JawMoCap's frames, at 0.35 1.99×, at **0.4**–0.45
/// 1.86× (none over 2×), the truth unchanged (1.89×, 2 flips); at 0.5 the truth flips one more.
pub const PAST_CORNER_REACH_EUCLIDEAN: f64 = 0.4;

/// How much of a distance measured across a lip or lid (from a marker worn on it towards the
/// opening's rim) counts, by default. On FaceCap's truth the inner rim of the lower lip moves
/// within 0.1 mm of the lip marker 4 mm in front of it when the jaw opens 43 mm; on full
/// distances the kernel gave that rim vertex 75 % of the marker and the rest to the lip markers
/// 12 mm to each side, which drop less, and the rims parted 3 mm less than the truth's. At 0.2
/// the middle of the rims parts within 1.6 mm (figures in
/// [`crate::surface::distances::shorten_across_rims`]).
pub const RIM_ACROSS: f64 = 0.2;

/// Static anchoring's fade-in distance, × the mean marker spacing, in the surface-aware
/// methods' defaults.
pub const ANCHORING_MARGIN: f64 = 0.8;

/// Influences per vertex of the linear deformer and of planar bones when the user names none:
/// the runtime's cost is K multiply-adds per vertex and axis, and the Cortex-M4 budget frame
/// (`firmware/`) is at 96 % of its goal at 8.
pub const DEFAULT_K: usize = 8;

/// Radial terms per vertex of the RBF deformer when the user names none: all of them, up to the
/// format's 64, so that the rig plays the dense RBF it was solved for (to quantisation). The
/// radial function its defaults use (the exponential at 1.5 mean marker spacings) is still a
/// quarter of its peak at two spacings, and the coefficients it multiplies alternate in sign, so
/// keeping the largest few terms of a vertex drops real signal and, where the kept set
/// changes between neighbours, tears the skin. Measured 2026-12-02 (`--test structure`,
/// `bake --deformer rbf` on FaceCap's truth with the JawMoCap layout / on JawMoCap):
/// K = 8: 3.48× stretch, 57 flipped triangles / 5.27×, 11 flips; 16: 2.59×, 3 / 2.10×, 1;
/// 24: 2.39×, 2 / 1.97×, 1; 32: 2.17×, 2; **all 41**: 2.17×, 2 / 2.01×, 1, face mean error
/// 1.03 → 0.575 mm (then with distances shortened across the rims, as the linear deformer's:
/// 2.16×, 2 / 2.01×, 1). The cost: K multiply-adds per vertex and axis (`facebake inspect`:
/// 361,143 a frame on FaceCap with 41 markers, against 94,437 at K = 8 and the linear
/// deformer's 64,656). The papers' narrow Gaussian (0.75 spacings, [`BakeOptions::default`])
/// decays fast enough for K = 8 (within 0.1 mm of its dense RBF, p99).
pub const RBF_K: usize = 64;

/// A deformer's influences per vertex when the user names none: [`RBF_K`] for the RBF
/// deformer, else [`DEFAULT_K`].
pub fn default_k(deformer: DeformerKind) -> usize {
    match deformer {
        DeformerKind::Rbf => RBF_K,
        DeformerKind::Linear | DeformerKind::Planar => DEFAULT_K,
    }
}

/// How to bake.
#[derive(Clone, Debug, PartialEq)]
pub struct BakeOptions {
    /// The runtime's deformer.
    pub deformer: DeformerKind,
    /// The distance (or PBW weighting) the dense weights come from.
    pub method: Method,
    /// The radial function φ.
    pub radial: RadialFunction,
    /// Radial width in asset units; `None` derives it from the marker spacing.
    pub width: Option<f64>,
    /// Width as a multiple of the mean nearest-marker distance, when `width` is `None`.
    pub width_factor: f64,
    /// Solve the affine term with the RBF coefficients.
    pub affine: bool,
    /// Influences per vertex.
    pub k: usize,
    /// Re-fit of the kept weights (linear deformer).
    pub refit: Refit,
    /// Length scale of the smooth-motion prior as a fraction of the mesh's bounding-box diagonal
    /// (linear deformer with the prior re-fit).
    pub prior_length: f64,
    /// Planar deformer: bone radius as a multiple of the closest connected-marker distance.
    pub planar_radius: f64,
    /// Apply the scene's marker groups as masks (linear and planar deformers).
    pub masks: bool,
    /// Geodesics, hybrid region, mask fade, PBW blend, ridge.
    pub surface: SurfaceOptions,
    /// The capture stages, baked from the scene's capture, or at rest without one
    /// ([`StagesConfig::at_rest`]).
    pub stages: StagesConfig,
    /// Static anchoring (the linear deformer, on any method, and planar bones): the skin beyond
    /// the markers' hull above the mouth follows the skull markers, fading in over this
    /// distance × the mean marker spacing ([`crate::surface::anchoring`]); `None`: off. The RBF
    /// deformer's affine part is then the anchor markers' mean translation
    /// (`RbfSystem::anchored_coefficient_map`), which the skin there follows as its radial terms
    /// fade by the same strength; it needs the affine term for it.
    pub anchoring: Option<f64>,
}

impl Default for BakeOptions {
    /// Gaussian radial function, width 0.75 × the mean nearest-marker distance, affine term,
    /// K = 8, Euclidean distances, RBF deformer: the configuration that keeps the sparse rig
    /// within 0.1 mm (p99) of the dense RBF on the FaceCap ground truth.
    fn default() -> Self {
        Self {
            deformer: DeformerKind::Rbf,
            method: Method::Euclidean,
            radial: RadialFunction::Gaussian,
            width: None,
            width_factor: 0.75,
            affine: true,
            k: DEFAULT_K,
            refit: Refit::Prior,
            prior_length: 0.05,
            planar_radius: crate::planar::DEFAULT_RADIUS_FACTOR,
            masks: false,
            surface: SurfaceOptions::default(),
            // The papers bake no stages without a capture.
            stages: StagesConfig {
                at_rest: false,
                ..StagesConfig::default()
            },
            anchoring: None,
        }
    }
}

impl BakeOptions {
    /// What `facebake bake` bakes with no flags: geodesic distances, masked, in the linear
    /// deformer ([`BakeOptions::for_method`]); the rig that keeps the skull still, lets the lips
    /// part and closes the eyes (docs/figures.md).
    pub fn product_default() -> Self {
        Self::for_method(Method::Geodesic, true)
    }

    /// `self` with the runtime's `deformer` and its default K ([`default_k`]): what `bake
    /// --deformer DEFORMER` bakes.
    pub fn with_deformer(self, deformer: DeformerKind) -> Self {
        Self {
            deformer,
            k: default_k(deformer),
            ..self
        }
    }

    /// The defaults of `method`, with or without `masks`: every method in the linear deformer
    /// with static anchoring over 0.8 × the mean marker spacing and the exponential radial
    /// function `exp(−r/c)` (thesis eq 2.3a; its geodesic kernel matrix stays positive definite
    /// on FaceCap where the Gaussian's does not), c = 1.5 × the mean marker spacing; the method
    /// picks the distance. (The papers' bare Euclidean RBF, which the golden rigs pin, is
    /// [`Default`].) `for_method(method, true)` is `bake --method METHOD`; what `bake` uses
    /// when given no method is [`BakeOptions::product_default`].
    pub fn for_method(method: Method, masks: bool) -> Self {
        Self {
            method,
            masks,
            deformer: DeformerKind::Linear,
            radial: RadialFunction::Exponential,
            width_factor: 1.5,
            anchoring: Some(ANCHORING_MARGIN),
            // Measured on both takes (docs/measurements.md): shrinking is continuous where a
            // vertex's kept set changes and keeps the skull stiller. Since the skin beside the
            // mouth's corrections gives way to them, the hybrid distances gain from it too
            // (JawMoCap drift 0.70 → 0.13 mm, truth 2.24× → 1.99×, 18 → 15 flips); so do the
            // PBW weights at their share of [`PBW_ALPHA`] (at half, they stretched more with
            // it: truth 2.89 → 3.15×).
            refit: Refit::Shrink,
            surface: SurfaceOptions {
                mask_side_factor: match method {
                    Method::Euclidean => MASK_SIDE_EUCLIDEAN,
                    Method::Geodesic | Method::Hybrid | Method::Pbw => MASK_SIDE_SURFACE,
                },
                past_corner_reach: match method {
                    Method::Euclidean => PAST_CORNER_REACH_EUCLIDEAN,
                    Method::Geodesic | Method::Hybrid | Method::Pbw => PAST_CORNER_REACH,
                },
                ..SurfaceOptions::default()
            },
            // Stages at rest without a capture (`bake::at_rest`), which the papers lack.
            stages: StagesConfig::default(),
            ..Self::default()
        }
    }
}
