//! A bake without a capture still gets capture stages, baked from the layout's own markers at
//! rest: the actor is the character, its neutral pose the markers where the layout puts them.
//!
//! [`Rig::deform`](facebake_runtime::Rig::deform) plays such a rig exactly as it did without
//! them (the deformer is the one a bake without a capture makes). Through
//! `Rig::play`, a take in the character's own space (markers on the character, at its scale) is
//! first brought into the head's frame, its gaps filled and its implausible samples rejected,
//! as a capture rig's takes are: a take with head motion plays, and the head markers, which
//! expressions move a little, no longer carry the skull with them. On the truths (the 32
//! expressions, no head motion; `cargo test --release -p facebake-tests --test at_rest -- --nocapture`):
//!
//! | | through `deform` | through `play` (these stages) |
//! |---|---|---|
//! | FaceCap, the JawMoCap layout: skin mean; static drift | 0.544 mm; 0.29 mm | 0.528; 0.00 |
//! | ICT-FaceKit, the same layout placed: skin mean; static drift | 0.695 mm; 0.98 mm | 0.685; 0.00 |
//!
//! and FaceCap's truth as a clean 30 Hz take with the head turning 20° and moving 3 cm plays
//! with a skin mean of 0.335 mm through a bake without a capture, as through `bake --capture`
//! of that take (0.336; ICT-FaceKit's, 0.424 both ways), where the rig without stages, deformed
//! by the take's markers, is 30.7 mm off.
//!
//! A capture teaches the stages its noise, its steps and its range; here there is none, so the
//! stages smooth nothing and reject only what no face does (a marker a half extent from its
//! rest or moving that far in a frame, a head marker pair straying by [`HEAD_TOLERANCE`]).

use facebake_runtime::Space;

use crate::model::{Capture, Units};
use crate::stages::{bake_stages, BakedStages, HeadMarkers, Neutral, SmoothingUse, StagesConfig};

/// Largest displacement from rest and largest step a frame, as a fraction of the half extent of
/// the markers (a head's half height, about 10 cm): a jaw open moves the chin 4–5 cm.
pub const MAX_MOTION: f64 = 1.0;

/// How far a head-marker pair's distance may stray from rest before the marker that broke the
/// head's shape is rejected, as a fraction of the markers' half extent (about 10 mm). ICT-
/// FaceKit's surprise moves its forehead's centre 3.6 mm against the inner eye corners.
pub const HEAD_TOLERANCE: f64 = 0.1;

/// The stages of a bake without a capture (module docs), from `config` (the bake's, its head
/// candidates filled in), or why there are none, for the bake's warnings: fewer than three
/// head markers to fit the head to, or markers the stages refuse as a face (a mesh that is not
/// one, or not in metres). The head markers are the ones named, else the candidates (the skull
/// markers and the inner eye corners): with no motion to measure, none can be picked as the
/// most rigid.
pub(super) fn stages(
    names: &[String],
    rest: &[[f64; 3]],
    space: &Space,
    config: &StagesConfig,
) -> Result<BakedStages, String> {
    let head = match &config.head {
        HeadMarkers::Named(named) => named.clone(),
        HeadMarkers::MostRigid(_) => config.head_candidates.clone().unwrap_or_default(),
        HeadMarkers::None => Vec::new(),
    };
    if head.len() < 3 {
        return Err(format!(
            "no capture stages: the rig plays through Rig::deform only (a head fit needs three \
             head markers; {} found: {})",
            head.len(),
            head.join(", ")
        ));
    }
    let config = StagesConfig {
        neutral: Neutral::FirstComplete,
        head: HeadMarkers::Named(head),
        max_displacement: Some(MAX_MOTION),
        max_step: Some(MAX_MOTION),
        head_tolerance: Some(HEAD_TOLERANCE),
        smoothing: SmoothingUse::Off,
        head_smoothing: SmoothingUse::Off,
        ..config.clone()
    };
    let at_rest = Capture {
        source: "the layout's markers at rest".into(),
        rate_hz: 60.0,
        units: Units::Metres,
        marker_names: names.to_vec(),
        frames: vec![rest.iter().copied().map(Some).collect()],
    };
    let mut stages = bake_stages(&at_rest, names, rest, space, &config).map_err(|e| {
        format!("no capture stages: the rig plays through Rig::deform only (the markers at rest as a capture: {e})")
    })?;
    stages.report.at_rest = true;
    Ok(stages)
}
