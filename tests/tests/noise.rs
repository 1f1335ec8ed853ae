//! Issue 14, item 10: jitter is not amplified. JawMoCap with ±0.5 mm uniform jitter on every
//! coordinate of every marker (seeded); the rig is baked from the jittered take, as `bake
//! --capture` bakes from the take it plays, and plays both it and the clean take. With the
//! default smoothing (the markers' filter, and the head pose's, which the bake turns on because
//! the jittered take's three forehead head markers would carry 2 mm of noise to the face) the
//! face (every vertex, every frame) stays within 2 mm of the clean take's at the 99th
//! percentile and 4 mm at the most. The smoothing's cost is stated too: how far the clean take's
//! face moves when smoothed, and the lag when still. "Unsmoothed" is without either filter.

use facebake::model::Capture;
use facebake::BakeOptions;
use facebake::{Scene, StagesConfig};
use facebake_runtime::format::header::header_for;
use facebake_runtime::format::RigData;
use facebake_runtime::Rig;
use facebake_tests::{
    jawmocap_rig_with, moved_and_dropped, planar_product, play_take, JawMoCapRig,
};

/// Jitter amplitude: ±0.5 mm on every coordinate (JawMoCap's stages work in metres).
const JITTER: f64 = 0.0005;

/// The face error figures of one comparison, mm.
#[derive(Clone, Copy, Debug)]
struct Figures {
    p99: f64,
    max: f64,
}

/// Frames left out of the figures: the smoothing's start-up. A causal filter has no history
/// for the first frame of a take, whose jitter therefore passes; the filter's start-up running
/// mean averages it away over the next few frames.
const START_UP: usize = 20;

fn figures(a: &[Vec<[f64; 3]>], b: &[Vec<[f64; 3]>]) -> Figures {
    let (a, b) = (&a[START_UP..], &b[START_UP..]);
    let mut e: Vec<f64> = a
        .iter()
        .zip(b)
        .flat_map(|(fa, fb)| {
            fa.iter()
                .zip(fb)
                .map(|(p, q)| 1000.0 * (0..3).map(|c| (p[c] - q[c]).powi(2)).sum::<f64>().sqrt())
        })
        .collect();
    e.sort_by(f64::total_cmp);
    Figures {
        p99: e[(e.len() - 1) * 99 / 100],
        max: *e.last().unwrap(),
    }
}

/// Every frame's vertices (asset units, metres) played from `frames` (metres, `None` missing).
fn play(blob: &[u8], frames: &[Vec<Option<[f64; 3]>>]) -> Vec<Vec<[f64; 3]>> {
    play_take(&Rig::from_bytes(blob).expect("rig loads"), frames).0
}

/// The capture in metres with seeded uniform jitter of ±[`JITTER`] on every coordinate.
fn jittered(capture: &Capture) -> Capture {
    facebake_tests::jittered(capture, JITTER)
}

/// `capture`'s frames (metres) in the rig's marker order.
fn take(j: &JawMoCapRig, capture: &Capture) -> Vec<Vec<Option<[f64; 3]>>> {
    facebake_tests::frames_in_order(capture, j.placed.iter().map(|m| m.name.as_str()))
}

/// `blob` with neither smoothing filter (markers', head pose's).
fn unsmoothed(blob: &[u8]) -> Vec<u8> {
    let rig = Rig::from_bytes(blob).expect("rig loads");
    let mut data: RigData<'_> = *rig.data();
    let stages = data.stages.as_mut().expect("stages");
    stages.smoothing = None;
    stages.head_smoothing = None;
    let payload = postcard::to_allocvec(&data).unwrap();
    let mut out = header_for(&payload).unwrap().to_vec();
    out.extend_from_slice(&payload);
    out
}

struct Measured {
    smoothed: Figures,
    unsmoothed: Figures,
    lag: Figures,
    lag_frames: u32,
}

/// The rig baked from the jittered take (as `bake --capture` would be, from the take it is
/// to play), playing the clean take and the jittered one.
fn measure(j: &JawMoCapRig, bake: &BakeOptions) -> Measured {
    let noisy_capture = jittered(&j.capture);
    let mut scene = Scene::placed(&j.mesh, &j.placed);
    scene.capture = Some(&noisy_capture);
    let baked = facebake::bake(&scene, bake).expect("bakes from the jittered take");
    let rig = Rig::from_bytes(&baked.blob).unwrap();
    let stages = rig.stages().unwrap();
    let smoothing = stages
        .smoothing
        .expect("the default bake smooths a take this noisy");
    // The forehead markers and the inner eye corners pin the head well enough that the bake
    // leaves its pose unsmoothed (the forehead's three alone magnified their jitter 6.4× at the
    // chin, and the bake smoothed the pose, lagging a moving head).
    assert!(
        stages.head_smoothing.is_none(),
        "the head pose is smoothed: the head markers pin it poorly"
    );
    let on = baked.blob.clone();
    let off = unsmoothed(&baked.blob);
    let noisy = take(j, &noisy_capture);
    let clean_on = play(&on, &j.frames);
    let clean_off = play(&off, &j.frames);
    Measured {
        smoothed: figures(&clean_on, &play(&on, &noisy)),
        unsmoothed: figures(&clean_off, &play(&off, &noisy)),
        lag: figures(&clean_on, &clean_off),
        lag_frames: smoothing.still_lag_frames(),
    }
}

fn measure_and_print(name: &str, bake: &BakeOptions) -> Measured {
    let j = jawmocap_rig_with(bake, &StagesConfig::default());
    let m = measure(&j, bake);
    println!(
        "{name}: ±0.5 mm jitter, face error vs the clean take: smoothed p99 {:.2} max {:.2} mm \
         (unsmoothed p99 {:.2} max {:.2} mm); smoothing's cost on the clean take p99 {:.2} max \
         {:.2} mm, lag when still {} frames",
        m.smoothed.p99,
        m.smoothed.max,
        m.unsmoothed.p99,
        m.unsmoothed.max,
        m.lag.p99,
        m.lag.max,
        m.lag_frames
    );
    m
}

fn check(name: &str, bake: &BakeOptions) {
    let m = measure_and_print(name, bake);
    assert!(
        m.smoothed.p99 <= 2.0 && m.smoothed.max <= 4.0,
        "{name}: {:?}",
        m.smoothed
    );
}

/// The bar (p99 ≤ 2 mm, max ≤ 4 mm), met by every deformer. Measured 2026-12-03 with the
/// filter tuned against the truth (`smoothing_cuts_the_jitter`): linear 0.68 / 1.33 mm, rbf
/// 0.62 / 1.36, planar 0.67 / 1.65. Measured 2026-12-02 with the inner
/// eye corners among the head markers (the head pose no longer smoothed): linear 0.34 / 0.65 mm,
/// rbf 0.32 / 0.65, planar 0.35 / 0.88 (unsmoothed 1.18 / 1.99, 1.14 / 2.03, 1.21 / 2.66).
/// Before, with the forehead's three: measured 2026-11-27, smoothed
/// p99 / max linear (the default) 1.28 / 2.33 mm, rbf 0.74 / 2.14 mm at K = 8 (1.45 / 3.00 before
/// it was anchored; 1.23 / 2.36 mm with every radial term, measured 2026-12-02), planar 1.15 / 2.32 mm (1.38 / 2.88 before the head markers held still)
/// (before the head pose's smoothing, the learned displacement bound and proportional
/// retargeting, 1.42 / 10.05, 2.23 / 10.65 and 2.18 / 8.70 mm; planar bones before their
/// static anchoring, 1.60 / 6.78 mm at the back of the head).
#[test]
fn every_deformer_stays_within_the_jitter_bar() {
    check("linear", &BakeOptions::product_default());
    check(
        "rbf",
        &BakeOptions {
            masks: false,
            ..BakeOptions::product_default().with_deformer(facebake::DeformerKind::Rbf)
        },
    );
    check("planar", &planar_product(8));
}

/// The smoothing's effect: under 0.7 of the unsmoothed 99th percentile, for a lag of 3 frames
/// when still. Measured 2026-12-04 with the head refit over the face, which averages much of
/// the jitter before the filter sees it: linear 0.53 of 0.81 mm, planar 0.54 of 0.90 mm (the
/// ratio is higher than before because the unsmoothed face gained more). Measured 2026-12-03 with the filter tuned against the truth (3 Hz,
/// 2 Hz, the speed gain scaled to this take's noise, β 200): linear 0.68 of 1.18 mm, planar
/// 0.67 of 1.21 mm, the lag on the clean take p99 0.41 mm. With β 50, 0.55 of 1.18 for a lag
/// of p99 0.78 mm; the filter before, 1 Hz, β 10, 1 Hz, took two thirds, 0.34 of 1.18 and 0.35
/// of 1.21, for a lag of p99 1.9 mm and 10 frames. Against the truth the lag costs more than
/// the jitter (`tests/tests/rehearsal.rs`), so the lighter filter wins there.
#[test]
fn smoothing_cuts_the_jitter() {
    for (name, bake) in [
        ("linear", BakeOptions::product_default()),
        ("planar", planar_product(8)),
    ] {
        let m = measure_and_print(name, &bake);
        assert!(
            m.smoothed.p99 <= 0.7 * m.unsmoothed.p99,
            "{name}: {:?}",
            m.smoothed
        );
        assert!(m.lag_frames <= 3, "{name}: {}", m.lag_frames);
        assert!(m.lag.p99 <= 0.5, "{name}: {:?}", m.lag);
    }
}

/// What a held-out take may bring at once: ±0.5 mm jitter, the head turning (up to 20° either
/// way about the head's centre, up to 45°/s) and moving (up to 3 cm), and 5 % of the samples
/// dropped (seeded). The default rig baked from that take holds the static region within the
/// issue's 0.5 mm in every frame, with no flipped triangle: the head markers hold still once
/// the head's motion is taken out (runtime `stages`, step 3). Measured 2026-11-27: 0.49 mm;
/// with the head markers moving by their fit residuals (before blob format 8) the jitter alone
/// moved the forehead beside a head marker 1.08 mm (±0.2 mm jitter: 0.56 mm). Measured
/// 2026-12-01: 0.00 mm (0.43 mm before the anchoring's hull left out the held head markers,
/// `surface::anchoring::hull_markers`: the skin above them carried the brows' ringing weights).
#[test]
fn the_static_region_holds_under_jitter_head_motion_and_dropouts() {
    let bake = BakeOptions::product_default();
    let j = jawmocap_rig_with(&bake, &StagesConfig::default());
    let capture = moved_and_dropped(&jittered(&j.capture), 0.05, false);
    let (baked, worst) = bake_and_play(&j, &capture, &bake);
    println!("jitter, head motion and dropouts: {worst}");
    assert!(baked
        .report
        .stages
        .expect("stages")
        .neutral_filled
        .is_empty());
    assert!(worst.static_drift_mm.0 <= 0.05, "{worst}");
    assert_eq!(worst.flipped.0, 0, "{worst}");
}

/// The default rig baked from `capture` on JawMoCap's FaceCap scene, and the structure over
/// the take played through it.
fn bake_and_play(
    j: &JawMoCapRig,
    capture: &Capture,
    bake: &BakeOptions,
) -> (facebake::Baked, facebake::metrics::TakeMetrics) {
    let mut scene = Scene::placed(&j.mesh, &j.placed);
    scene.capture = Some(capture);
    let baked = facebake::bake(&scene, bake).expect("bakes from the take");
    let rig = Rig::from_bytes(&baked.blob).expect("rig loads");
    let (played, _) = play_take(&rig, &take(j, capture));
    let regions = facebake::metrics::Regions::for_mesh(&j.mesh, &[], &[]).expect("regions");
    let (_, worst) = regions.measure_take(&played, None, false);
    (baked, worst)
}

/// An optical take that never sees every marker at once: a fifth of JawMoCap's samples dropped
/// at random from every frame, frame 0 too (41 markers all there in a frame once in 10,000),
/// with the head turning and moving. The bake takes frame 0 with each missing marker from the
/// nearest frame that has it, moved rigidly onto frame 0 (`stages::neutral_pose`), says which,
/// and the face holds: that neutral pose is within 0.5 mm of the clean take's frame 0 (the
/// actor's markers move up to 0.7 mm from frame 0 to frame 1, head and all), the static skin
/// within 0.05 mm, no triangle flips and no edge stretches past 2×. Measured 2026-12-03: 9
/// markers taken from frames 1–2, at most 0.30 mm from the clean frame 0; stretch 1.90× as on
/// the clean take (2.03× unsmoothed before a frame lacking head markers fitted the others to
/// their residuals; 1.92× on 2026-12-02, smoothed) (2.00×, one edge past 2×, while a dropped marker was rebuilt at its
/// neighbours' mean rather than with its offsets from them). Before, the bake refused the take:
/// a marker missing in frame 0.
#[test]
fn a_take_that_never_has_every_marker_still_bakes() {
    let bake = BakeOptions::product_default();
    let j = jawmocap_rig_with(&bake, &StagesConfig::default());
    let clean = moved_and_dropped(&j.capture.in_metres(), 0.0, true);
    let capture = moved_and_dropped(&j.capture.in_metres(), 0.2, true);
    let columns: Vec<usize> = (0..capture.marker_names.len()).collect();
    let complete = capture
        .frames
        .iter()
        .filter(|f| f.iter().all(Option::is_some))
        .count();
    assert_eq!(complete, 0, "the take must lack a marker in every frame");
    let first = facebake::stages::Neutral::FirstComplete;
    let neutral = facebake::stages::neutral_pose(&capture, &columns, &first).expect("assembled");
    let reference = facebake::stages::neutral_pose(&clean, &columns, &first).expect("clean");
    assert_eq!(
        (neutral.frames.clone(), reference.frames.clone()),
        (0..1, 0..1)
    );
    assert!(!neutral.filled.is_empty());
    let off = neutral
        .pose
        .iter()
        .zip(&reference.pose)
        .map(|(a, b)| facebake::mesh::distance(a, b))
        .fold(0.0, f64::max);
    println!(
        "20 % dropped: {} markers filled from frames {:?}, {:.3} mm from the clean frame 0",
        neutral.filled.len(),
        neutral.filled.iter().map(|f| f.1).collect::<Vec<_>>(),
        off * 1000.0
    );
    assert!(off < 5e-4, "{off}");
    let (baked, worst) = bake_and_play(&j, &capture, &bake);
    println!("a fifth of the samples dropped, head moving: {worst}");
    let stages = baked.report.stages.expect("stages");
    assert_eq!(stages.neutral_filled.len(), neutral.filled.len());
    assert!(baked
        .report
        .warnings
        .iter()
        .any(|w| w.contains("no frame of the capture has every marker")));
    assert!(worst.static_drift_mm.0 <= 0.05, "{worst}");
    assert_eq!(worst.flipped.0, 0, "{worst}");
    assert!(worst.max_stretch.0 <= 2.0, "{worst}");
}

/// A dropped marker keeps its place among its neighbours (`facebake_runtime::stages::fill`):
/// JawMoCap with the head moving and 5 % / 20 % of the samples dropped at random, played
/// through the clean take's rig, against the clean take with the same head motion (every
/// vertex of every frame past the smoothing's start-up). The take as captured is clean, so
/// the default bake does not smooth it. Measured 2026-12-04 with the head refit over the face
/// (`facebake_runtime::stages::refit`): 5 %: 0.36 / 1.08 mm, 20 %: 0.75 / 2.35 mm: a dropped
/// marker that the refit weighed no longer pulls the head's pose, which moves the whole face a
/// little (JawMoCap's head markers stray 0.39 mm from a rigid head, median, so its refit
/// weighs markers up to 1.16 mm from neutral). Before it, 2026-12-03, p99 / max: 5 %:
/// 0.11 / 0.64 mm, 20 %: 0.39 / 2.77 mm, stretch 1.90× as the clean take (20 %: 0.49 / 2.77
/// while a frame with fewer than three head markers held the last pose instead of tracking
/// it, `RigidStatus::Tracked`). Unsmoothed, before a
/// frame lacking head markers fitted the others to their residuals (`with_residuals` in
/// `facebake_runtime::stages`), 1.28 / 4.99 and 2.67 / 12.6 mm: a fit from three of the five
/// head markers moved the chin 12 mm. Measured 2026-12-02 with the markers smoothed (1 Hz,
/// β 10, 1 Hz, which hid much of that): 5 %: 0.30 / 0.78 mm (0.41 / 2.95 when a rebuilt marker
/// took its neighbours' plain mean); 20 %: 0.75 / 2.97 mm (1.51 / 8.14).
#[test]
fn dropped_markers_keep_their_place_among_their_neighbours() {
    let bake = BakeOptions::product_default();
    let j = jawmocap_rig_with(&bake, &StagesConfig::default());
    let rig = Rig::from_bytes(&j.baked.blob).expect("rig loads");
    let clean = moved_and_dropped(&j.capture.in_metres(), 0.0, false);
    let want = play_take(&rig, &take(&j, &clean)).0;
    let regions = facebake::metrics::Regions::for_mesh(&j.mesh, &[], &[]).expect("regions");
    for (rate, p99, max) in [(0.05, 0.4, 1.2), (0.2, 0.9, 3.2)] {
        let dropped = moved_and_dropped(&j.capture.in_metres(), rate, false);
        let got = play_take(&rig, &take(&j, &dropped)).0;
        let f = figures(&want[START_UP..], &got[START_UP..]);
        let (_, worst) = regions.measure_take(&got, None, false);
        println!(
            "{:.0} % dropped: face vs the clean take p99 {:.2} max {:.2} mm; {worst}",
            rate * 100.0,
            f.p99,
            f.max
        );
        assert!(f.p99 <= p99 && f.max <= max, "{rate}: {f:?}");
        assert!(worst.max_stretch.0 <= 2.0, "{worst}");
        assert_eq!(worst.flipped.0, 0, "{worst}");
    }
}
