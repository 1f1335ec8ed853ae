//! How much of the crack's profile the mouth's corners take, chosen so that what the bake can
//! play through the rig does not tear it. The corners open as a crack does (`surface::corners`),
//! and at the mouth the bake takes [`MOUTH_SHARE`] of the square-root profile, which FaceCap's
//! truth wants (its worst lip pair 7.1 mm, 12.5 without). ICT-FaceKit's mouth, rounded where
//! its lips roll into the corner, is pinched by it into a crack's tip and tears (JawMoCap
//! through `bake --capture`: 3.20×, 5 flips; with the linear profile 1.95×, none).
//!
//! Two probes judge a share, in this order, and the bake keeps the first share of
//! [`MOUTH_SHARES`] (from the options' down) that both pass, else the linear profile:
//!
//! 1. **The mesh's own shapes** ([`super::own_shapes::Shapes`]), when it has morph targets:
//!    each target that moves the skin, at full weight, its markers read off it and played
//!    through the rig. The shape is a truth, so a share fails where the rig stretches a skin
//!    edge past twice its length in the shape (or at rest, if longer: the stretch bar's own
//!    reading) and the linear profile's rig keeps that edge within it, in any shape. Flips are
//!    not counted: a shape at full weight need not be a face (FaceCap's `mouthClose` alone
//!    pushes the lips through each other, and turns 4 skin triangles over with the linear
//!    profile, 6 with any share from 0.5). Measured 2026-12-06 (session 22), the default bake
//!    with the JawMoCap layout, against the 32-frame truth (`cargo test --release -p
//!    facebake-tests --test ict_facekit --test structure -- --nocapture`):
//!
//!    | head | shapes that tear 0.7 / 0.5 / 0.35 | kept | truth: lips, stretch (edges > 2×), face mean |
//!    |---|---|---|---|
//!    | FaceCap | none | 0.7 | 7.1 mm, 1.89× (0), 0.507 mm, as before |
//!    | ICT-FaceKit | `jawOpen` (2.33×) / none | **0.5** | 5.9 → 6.5 mm, **2.33× (2) → 1.97× (0)**, 0.6750 → 0.6753 mm |
//!
//! 2. **The capture**, with one: a take has no truth to measure against, and rest is not one:
//!    FaceCap's own expressions stretch some edges past twice their rest length (a bake that
//!    judged against rest lowered FaceCap's share and lost its lips, 7.1 → 12.3 mm). The
//!    linear profile (share 0) is: it is the plain rig, smooth at the corners. So the bake plays
//!    the take through the rig and through the share-0 rig side by side, and a frame is torn
//!    where the rig flips a skin triangle the share-0 rig keeps upright or stretches a skin edge
//!    past twice its length there (or at rest, if longer) and past the longest the mesh's own
//!    shapes make it (a stretch the asset itself makes is not a tear; without morph targets
//!    every stretch is judged). A share passes when it tears at most [`TORN_SHARE`] of the
//!    frames. Measured 2026-12-04, before the shapes probe and with every stretch judged
//!    (`--test ict_facekit`, `--test other_faces`, `--test rehearsal`):
//!
//!    | take | frames torn at 0.7 / 0.5 / 0.35 | kept |
//!    |---|---|---|
//!    | JawMoCap on FaceCap and on its wider, narrower and heavier-jawed warps; FaceCap's truth as takes and rehearsals | at most a tenth at 0.7 | 0.7 (nothing changes) |
//!    | the narrower FaceCap's truth as a 33-frame take | 3 of 33 (9 %) | 0.7 |
//!    | JawMoCap placed on ICT-FaceKit | at most a tenth | 0.7 (0.5 since its shapes tear 0.7) |
//!    | ICT-FaceKit's truth as a 30 Hz rehearsal | 109 of 842 (12.9 %) / 92 (10.9 %) / at most 84 | 0.35 |
//!
//!    At 5 % the narrower FaceCap's short take dropped to 0.5 and lost 1.2 mm of lip for no
//!    less stretch. Since 2026-12-06 (session 23) a stretch within the head's own shapes is
//!    not a tear, and ICT-FaceKit's rehearsal keeps 0.5: of the 89 frames of 842 that tore it,
//!    71 stretched only edges that the head's own shapes stretch further, so it tears 18 (2 %).
//!    Against its truth: lips 7.0 → 6.5 mm, stretch 1.80× → 1.97× (no edge over 2×), face mean
//!    0.485 mm either way, no flip. Every other bundled take keeps its share with the default
//!    bake (`--method pbw` on ICT's rehearsal keeps 0.5 as well, and folds more before the
//!    relaxation: `--test ict_facekit relaxes`). Until
//!    2026-12-04, with the eye corners' markers placed on the lids' lining, ICT kept 0.35 on its
//!    rehearsal and 0.5 on JawMoCap (2.63×, 2 flips against 3.20×, 5 at 0.7).
//!
//! Both probes leave out the edges of near-degenerate slivers ([`TEAR_EDGE_FLOOR`]). Judging
//! ICT's sub-0.1 mm sliver edges too, its rehearsal tore every share (144 / 130 / 106 frames)
//! and kept the linear profile, its lips 8.3 mm off (`docs/measurements.md`, "Other files").

use serde::Serialize;

use super::BakeError;
use crate::mesh::distance;
use crate::metrics::{Regions, STRETCH_LIMIT};
use crate::model::{Capture, FaceMesh};
pub use crate::surface::corners::{MOUTH_SHARE, MOUTH_SHARES};

/// The share of a take's frames a mouth share may tear and be kept (see the module docs).
pub const TORN_SHARE: f64 = 0.1;

/// Skin edges shorter at rest than this fraction of the skin's median edge are not judged for
/// tears: a mesh's near-degenerate slivers, whose stretch no one can see (ICT-FaceKit's
/// 0.058–0.066 mm edges just outside its mouth's corners, 2 % of its 3.36 mm median edge, which
/// its truth stretches as far). Every share tore ICT's rehearsal by them alone; without them it
/// keeps 0.35, and its lips are 6.9 mm off instead of 8.3 with the same 1.83× and no flip
/// (`--test ict_facekit a_take_with_head_motion`). Anything from 0.020 to 0.039 makes the same
/// choices on every bundled face: ICT's next edges there, 0.13 mm, are 4 % and are judged (at
/// 0.05, 0.7 passed and turned 3 triangles over against the truth), and FaceCap's shortest
/// skin edge is 4 % of its median.
pub const TEAR_EDGE_FLOOR: f64 = 0.025;

/// What the bake chose for the mouth's corner profile, and why.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MouthShareChoice {
    /// The share kept.
    pub share: f64,
    /// The mesh's own shapes played ([`super::own_shapes::Shapes`]; 0 without morph targets).
    pub shapes: usize,
    /// The capture's frames played (0 without a capture).
    pub frames: usize,
    /// Each share tried before it, in order, with what tore it.
    pub tried: Vec<TriedShare>,
}

/// A share the bake tried and did not keep.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TriedShare {
    /// The share.
    pub share: f64,
    /// The mesh's own shapes it tore.
    pub shapes_torn: usize,
    /// The capture's frames it tore, when the capture was played (the shapes passed).
    pub frames_torn: Option<usize>,
}

/// Frames of `capture` that the rig in `blob` tears where the rig in `linear` (the same bake
/// with the mouth's linear profile) does not (see the module docs), and the frames played.
/// Both are played frame by frame through the runtime; nothing per frame is kept.
pub fn frames_torn(
    blob: &[u8],
    linear: &[u8],
    mesh: &FaceMesh,
    capture: &Capture,
) -> Result<(usize, usize), BakeError> {
    let regions = Regions::for_mesh(mesh, &[], &[])
        .map_err(|e| BakeError::Input(format!("{}: {e}", mesh.source.display())))?;
    let judged_at = judged_indices(&regions);
    let judged: Vec<[u32; 2]> = judged_at.iter().map(|&i| regions.edges[i]).collect();
    // The longest the mesh's own shapes make each judged edge (0 without morph targets: every
    // stretch is then judged).
    let longest = regions.shapes_longest();
    let own: Vec<f64> = judged_at
        .iter()
        .map(|&i| longest.map_or(0.0, |l| l[i]))
        .collect();
    let mut torn = 0;
    super::playback::play(&[blob, linear], capture, |played| {
        torn += usize::from(tears(&regions, &judged, &own, &played[0], &played[1]));
    })?;
    Ok((torn, capture.frames.len()))
}

/// The length of skin edge `[a, b]` in `p`.
pub(super) fn length(p: &[[f64; 3]], [a, b]: [u32; 2]) -> f64 {
    distance(&p[a as usize], &p[b as usize])
}

/// The skin edges judged for tears: all but those shorter at rest than [`TEAR_EDGE_FLOOR`] of
/// the median.
pub(super) fn judged_edges(regions: &Regions) -> Vec<[u32; 2]> {
    judged_indices(regions)
        .into_iter()
        .map(|i| regions.edges[i])
        .collect()
}

/// [`judged_edges`] as indices into [`Regions::edges`].
fn judged_indices(regions: &Regions) -> Vec<usize> {
    let rest = regions.rest();
    let mut lengths: Vec<f64> = regions.edges.iter().map(|&e| length(rest, e)).collect();
    if lengths.is_empty() {
        return Vec::new();
    }
    let mid = lengths.len() / 2;
    let (_, median, _) = lengths.select_nth_unstable_by(mid, f64::total_cmp);
    let floor = TEAR_EDGE_FLOOR * *median;
    (0..regions.edges.len())
        .filter(|&i| length(rest, regions.edges[i]) >= floor)
        .collect()
}

/// Whether `got` flips a skin triangle that `base` keeps upright or stretches one of the
/// `judged` skin edges past twice its length in `base` (or at rest, if longer) and past the
/// longest the mesh's own shapes make it (`own`, per judged edge).
fn tears(
    regions: &Regions,
    judged: &[[u32; 2]],
    own: &[f64],
    got: &[[f64; 3]],
    base: &[[f64; 3]],
) -> bool {
    let rest = regions.rest();
    regions
        .triangles
        .iter()
        .any(|t| regions.turned(got, t) && !regions.turned(base, t))
        || judged.iter().zip(own).any(|(&e, &own)| {
            let l = length(got, e);
            l > STRETCH_LIMIT * length(base, e).max(length(rest, e)) && l > own
        })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metrics::StaticRule;

    /// A stretch past twice the linear rig's counts as a tear unless the mesh's own shapes
    /// stretch that edge further; a flip counts either way.
    #[test]
    fn a_stretch_the_shapes_make_is_no_tear() {
        let rest = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [1.0, 1.0, 0.0],
        ];
        let regions =
            Regions::new(&rest, &[[0, 1, 2], [1, 3, 2]], vec![], StaticRule::Given).unwrap();
        let judged = judged_edges(&regions);
        // Vertex 1 pulled out along x: edges 0–1, 1–2 and 1–3 past twice their rest (and the
        // base's) length, no triangle turned.
        let mut got = rest;
        got[1] = [3.0, 0.0, 0.0];
        let stretched: Vec<f64> = judged.iter().map(|&e| length(&got, e)).collect();
        assert!(tears(
            &regions,
            &judged,
            &vec![0.0; judged.len()],
            &got,
            &rest
        ));
        // The shapes stretch every edge as far: no tear.
        assert!(!tears(&regions, &judged, &stretched, &got, &rest));
        // All but one as far: a tear again.
        let mut short = stretched.clone();
        let most = (0..judged.len())
            .max_by(|&a, &b| {
                let ratio = |i: usize| stretched[i] / length(&rest, judged[i]);
                ratio(a).total_cmp(&ratio(b))
            })
            .unwrap();
        short[most] *= 0.9;
        assert!(tears(&regions, &judged, &short, &got, &rest));
        // Vertex 0 pushed past 1 and 2 turns triangle 0–1–2 over: a tear whatever the shapes.
        let mut folded = rest;
        folded[0] = [1.2, 1.2, 0.0];
        let all = vec![f64::INFINITY; judged.len()];
        assert!(tears(&regions, &judged, &all, &folded, &rest));
    }
}
