//! A bake without a capture bakes capture stages from the layout's markers at rest
//! (`facebake::bake::at_rest`): `Rig::deform` plays the rig as before, bit for bit, and
//! `Rig::play` plays the character's own takes, head motion and gaps included, bringing them
//! into the head's frame first.
//!
//! `cargo test --release -p facebake-tests --test at_rest -- --nocapture` prints the figures.

use facebake::surface::evaluate::Benchmark;
use facebake::BakeOptions;
use facebake_tests::rehearsal::{Pace, Rehearsal};
use facebake_tests::{
    against_truth, bake_scene, guard, layout_benchmark, Pinned, DEFAULT_ON_TRUTH,
};

/// Frames each expression of a truth is held when played as a take (`Benchmark::play_stages`).
const HOLD: usize = 3;

fn without_stages() -> BakeOptions {
    let mut options = BakeOptions::product_default();
    options.stages.at_rest = false;
    options
}

/// FaceCap's truth (32 expressions, no head motion) through the default bake without a
/// capture: through `deform`, exactly the rig without the stages; through `play`, the head fit
/// over the face finds the head still where the expressions move the head markers, and holds
/// them, so the skull no longer follows them. Measured 2026-12-05: skin mean 0.544 → 0.528 mm,
/// static drift 0.29 → 0.00 mm; lips (7.1 mm), eyelids (0.9 mm), stretch and flips as before.
#[test]
fn a_bake_without_a_capture_plays_the_truth_through_its_own_stages() {
    let scene = layout_benchmark(true);
    let baked = bake_scene(&scene, &BakeOptions::product_default());
    let stages = baked.report.stages.as_ref().expect("stages at rest");
    assert!(stages.at_rest);
    assert_eq!(
        stages.head_markers,
        [
            "ForeHead_M",
            "ForeHead_L",
            "ForeHead_R",
            "Leye_Inside",
            "Reye_Inside"
        ]
    );
    let without = bake_scene(&scene, &without_stages());
    assert!(without.report.stages.is_none());
    let deformed = scene.play(&baked.blob);
    assert!(
        deformed == scene.play(&without.blob),
        "deform plays the rig as it was without its stages"
    );
    assert!(scene.play_stages(&without.blob, HOLD).is_none());
    let played = scene.play_stages(&baked.blob, HOLD).expect("stages");
    let (deform, play) = figures(&scene, &deformed, &played);
    guard("FaceCap truth through deform", &deform.1, &DEFAULT_ON_TRUTH);
    guard(
        "FaceCap truth through play",
        &play.1,
        &Pinned {
            drift_mm: 0.0,
            ..DEFAULT_ON_TRUTH
        },
    );
    assert!(play.1.static_drift_mm.0 <= 0.01, "{}", play.1);
    assert!(play.0 <= 0.53 && play.0 < deform.0 - 0.01, "{play:?}");
}

/// Skin mean (mm) and the structure metrics of `deformed` and `played` against the truth.
fn figures(
    scene: &Benchmark,
    deformed: &[Vec<[f64; 3]>],
    played: &[Vec<[f64; 3]>],
) -> (
    (f64, facebake::metrics::TakeMetrics),
    (f64, facebake::metrics::TakeMetrics),
) {
    let (deform, play) = (against_truth(scene, deformed), against_truth(scene, played));
    println!(
        "through deform: skin mean {:.3} mm, {}\nthrough play: skin mean {:.3} mm, {}",
        deform.0, deform.1, play.0, play.1
    );
    (deform, play)
}

/// FaceCap's truth as a clean 30 Hz take with the head turning 20° and moving 3 cm, in the
/// character's own space: a bake without a capture plays it as `bake --capture` of the take
/// does (skin mean 0.335 mm both, static drift 0.00, measured 2026-12-05), where the rig
/// without its stages, which can only `deform`, carries the head's motion into the face (the
/// rig follows the markers' translation, not their turn).
#[test]
fn a_bake_without_a_capture_plays_a_take_with_head_motion() {
    let scene = layout_benchmark(true);
    let pace = Pace {
        rate_hz: 30.0,
        ramp: 10,
        hold: 6,
        jitter: 0.0,
        dropped: 0.0,
        ..Pace::NATURAL
    };
    let take = Rehearsal::new(&scene, pace);
    let at_rest = bake_scene(&scene, &BakeOptions::product_default());
    let with_capture = take.bake(&scene, &BakeOptions::product_default());
    let (own, capture) = (
        take.score(&scene, &at_rest.blob, 3),
        take.score(&scene, &with_capture.blob, 3),
    );
    println!(
        "a take with head motion: the bake without a capture {:.3} mm ({}); with the take as its \
         capture {:.3} mm ({})",
        own.mean_mm, own.take, capture.mean_mm, capture.take
    );
    assert!(
        own.mean_mm <= capture.mean_mm + 0.005,
        "{own:?} {capture:?}"
    );
    assert!(own.take.static_drift_mm.0 <= 0.01, "{}", own.take);
    let deformed = take.score(&scene, &bake_scene(&scene, &without_stages()).blob, 3);
    println!(
        "the rig without its stages, deformed by the take's markers: {:.3} mm ({})",
        deformed.mean_mm, deformed.take
    );
    assert!(deformed.mean_mm > 5.0 * own.mean_mm, "{deformed:?}");
}
