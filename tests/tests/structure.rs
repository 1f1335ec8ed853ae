//! Structure metrics (issue 11) on the bundled takes: static-region drift, lip aperture and
//! eyelid closure against the truth, edge stretch and flipped triangles, worst over each take.
//!
//! The figures pinned here are today's, measured 2026-11-28, as regression guards: a change that
//! makes any of them worse fails. Of the bars (static drift ≤ 0.5 mm, lips within 2 mm, eyelids
//! within 1.5 mm, no edge over 2×, no flip), the default bake meets every one on JawMoCap
//! (asserted: 0.37 mm, 1.97×, no flip), the static drift and the stretch on the truth
//! (0.34 mm, anchored on the inner corners of the eyes as well as the forehead markers, whose
//! mean the frown moves 0.59 mm, `surface::anchoring::anchor_markers`; 1.98×, with the kept
//! weights shrunk, `sparsify::Refit::Shrink`) and the eyelids on the truth (asserted: 0.91 mm,
//! with the corners of the lids and lips reshaped, `surface::corners`, and the rims riding their
//! markers, `surface::distances`), and misses the rest on the truth (lips off by up to 6.8 mm,
//! one sliver flipped beside a corner of the mouth in `blend 1`); tighten them as the bake
//! improves. Planar bones as `bake --deformer planar` bakes them (masked) keep every JawMoCap
//! edge under 2× with no
//! flip. Run with `-- --nocapture` to see them all.

use facebake::ground_truth::GroundTruth;
use facebake::metrics::{FrameMetrics, Regions, TakeMetrics};
use facebake::surface::evaluate::Benchmark;
use facebake::{BakeOptions, Method};
use facebake_runtime::{PlayState, Rig};
use facebake_tests::{
    bake_scene, facecap_default, fixture, guard, jawmocap_rig_with, layout_benchmark, Pinned,
    DEFAULT_ON_JAWMOCAP, DEFAULT_ON_TRUTH,
};

/// The FaceCap regions, found once per test binary.
fn regions() -> &'static Regions {
    static CELL: std::sync::OnceLock<Regions> = std::sync::OnceLock::new();
    CELL.get_or_init(|| {
        let truth = &facecap_default().0;
        Regions::for_mesh(&truth.mesh, &truth.marker_rest(), &[]).expect("regions")
    })
}

fn truths(truth: &GroundTruth) -> Vec<Vec<[f64; 3]>> {
    (0..truth.frames.len())
        .map(|f| truth.positions(f))
        .collect()
}

fn frame(truth: &GroundTruth, name: &str) -> usize {
    truth
        .frames
        .iter()
        .position(|f| f.name == name)
        .expect("frame")
}

#[test]
fn facecap_regions_and_the_truth_measured_against_itself() {
    let r = regions();
    let truth = &facecap_default().0;
    // The skin no morph target moves; the mouth's rim and the two eyes' rims.
    assert_eq!(r.static_vertices.len(), 675);
    assert_eq!(r.lips.len(), 15);
    assert_eq!(r.eyes.iter().map(Vec::len).collect::<Vec<_>>(), [11, 11]);
    let all = truths(truth);
    for (f, t) in all.iter().enumerate() {
        let m = r.measure(t, Some(t), false);
        // The truth is its own truth: apertures exact; its static skin moves only by the
        // sub-threshold deltas the rule allows.
        assert_eq!(m.lips.unwrap().error_mm, Some(0.0));
        assert_eq!(m.eyelids.unwrap().error_mm, Some(0.0));
        assert!(m.static_drift_mm < 0.3, "{}: {m}", truth.frames[f].name);
        assert_eq!(m.flipped, 0, "{}: {m}", truth.frames[f].name);
    }
    let rest = r.measure(r.rest(), None, false);
    let jaw = r.measure(&all[frame(truth, "jaw open")], None, false);
    // Why stretch and flips the truth has too do not count: the truth's own jaw-open stretches
    // an inner-lip edge 18.6× from rest and turns 6 skin triangles over; 28 of its 32 frames
    // stretch some edge over 2× from rest (up to 49 edges, in `blend 2`). Against rest alone, as
    // a take without a truth (JawMoCap) is measured, the bar is stricter than the artist's face.
    assert!((jaw.max_stretch - 18.62).abs() < 0.01, "{jaw}");
    assert_eq!(jaw.flipped, 6, "{jaw}");
    let from_rest: Vec<usize> = all
        .iter()
        .map(|t| r.measure(t, None, false).edges_over_limit)
        .collect();
    assert_eq!(from_rest.iter().filter(|&&e| e > 0).count(), 28);
    assert_eq!(from_rest.iter().max(), Some(&49));
    // Against the longest the face's own shapes (each target at full weight) make each edge,
    // the jaw open is one of them, and the truth's blends of several stay within 1.27×: what
    // goes beyond 2× of it is no stretch the asset makes.
    assert!(
        (jaw.beyond_shapes.expect("shapes") - 1.0).abs() < 1e-9,
        "{jaw}"
    );
    let beyond = all
        .iter()
        .map(|t| r.measure(t, None, false).beyond_shapes.expect("shapes"))
        .fold(0.0, f64::max);
    assert!((beyond - 1.27).abs() < 0.01, "{beyond}");
    let blink = r.measure(&all[frame(truth, "blink")], None, false);
    // FaceCap's lips are closed at rest, 47 mm apart with the jaw open; the eyes 9.5 mm open
    // at rest and 1 mm in the blink.
    assert!((rest.lips.unwrap().widest_mm - 1.1).abs() < 0.1, "{rest}");
    assert!((jaw.lips.unwrap().widest_mm - 47.1).abs() < 0.1, "{jaw}");
    assert!(
        (rest.eyelids.unwrap().widest_mm - 9.5).abs() < 0.1,
        "{rest}"
    );
    assert!(
        (blink.eyelids.unwrap().widest_mm - 1.0).abs() < 0.1,
        "{blink}"
    );
}

/// The ground truth's frames played through a rig baked on its own 40 markers.
fn play_truth(truth: &GroundTruth, blob: &[u8]) -> Vec<Vec<[f64; 3]>> {
    let rig = Rig::from_bytes(blob).expect("rig loads");
    let space = rig.space();
    let mut out = vec![[0i32; 3]; rig.vertex_count()];
    truths(truth)
        .iter()
        .map(|t| {
            let q: Vec<[i32; 3]> = truth
                .markers_of(t)
                .iter()
                .map(|p| space.to_rig_f64(*p).expect("in range"))
                .collect();
            rig.deform(&q, &mut out).expect("deforms");
            out.iter().map(|p| space.to_asset_f64(*p)).collect()
        })
        .collect()
}

#[test]
fn facecap_ground_truth_default_bake() {
    let (truth, baked) = facecap_default();
    let played = play_truth(truth, &baked.blob);
    let (frames, take) = regions().measure_take(&played, Some(&truths(truth)), false);
    for (f, m) in frames.iter().enumerate() {
        println!("{:>12}: {m}", truth.frames[f].name);
    }
    let at = |name: &str| -> FrameMetrics { frames[frame(truth, name)] };
    // Jaw open: the lips stay sealed (1.4 mm apart where the truth parts them 47 mm) and the
    // crown moves 12.6 mm; the blink leaves the eyes 9.4 mm open where the truth closes them.
    assert!(at("jaw open").lips.unwrap().widest_mm < 2.0);
    assert!(at("blink").eyelids.unwrap().error_mm.unwrap() > 8.0);
    assert_eq!(take.static_drift_mm.1, frame(truth, "jaw open"));
    guard(
        "FaceCap truth, 40 sampled markers, Euclidean RBF (the library's reference configuration)",
        &take,
        &Pinned {
            drift_mm: 12.63,
            lips_mm: 47.0,
            eyelids_mm: 8.4,
            stretch: 2.19,
            over_2x: 16,
            flipped: 0,
        },
    );
}

/// The ground truth driven by the bundled JawMoCap layout's 41 markers as placed on FaceCap
/// (lip and eyelid markers on the lips and lids, groups, no anchors): what `bake --layout`
/// bakes.
fn layout_scene() -> &'static Benchmark {
    static CELL: std::sync::OnceLock<Benchmark> = std::sync::OnceLock::new();
    CELL.get_or_init(|| layout_benchmark(true))
}

/// A bake of the layout scene's markers with `options`.
fn bake_layout_scene(options: &BakeOptions) -> Vec<u8> {
    bake_scene(layout_scene(), options).blob
}

fn layout_take(blob: &[u8]) -> TakeMetrics {
    let s = layout_scene();
    let played = s.play(blob);
    regions()
        .measure_take(&played, Some(&truths(&s.truth)), false)
        .1
}

#[test]
fn facecap_layout_default_and_planar() {
    guard(
        "FaceCap truth, JawMoCap layout, the papers' Euclidean RBF (--method euclidean --no-masks \
         --no-anchoring --deformer rbf --radial gaussian --width-factor 0.75 -k 8)",
        &layout_take(&bake_layout_scene(&BakeOptions::default())),
        &Pinned {
            drift_mm: 26.45,
            lips_mm: 45.7,
            eyelids_mm: 1.9,
            stretch: 12.59,
            over_2x: 479,
            flipped: 246,
        },
    );
    guard(
        "FaceCap truth, JawMoCap layout, --method euclidean (masked, anchored, exponential)",
        &layout_take(&bake_layout_scene(&BakeOptions::for_method(
            Method::Euclidean,
            true,
        ))),
        // Before the kept weights were shrunk (sparsify::Refit::Shrink): 0.62 mm, 7.3 mm,
        // 2.45× (3 edges). Before the masks faded out at the openings' corners
        // (options::MASK_SIDE_EUCLIDEAN): eyelids 1.2 mm, 1.99×, 3 flips. Before the anchoring
        // rose linearly (surface::anchoring::HULL_RISE): 0.51 mm, 1.92×.
        &Pinned {
            drift_mm: 0.34,
            lips_mm: 7.0,
            eyelids_mm: 1.0,
            stretch: 1.89,
            over_2x: 0,
            flipped: 2,
        },
    );
    guard(
        "FaceCap truth, JawMoCap layout, --deformer planar --no-masks",
        &layout_take(&bake_layout_scene(&facebake_tests::planar_config(8))),
        // Anchored to a bone of skull markers (before: drift 33.58 mm, stretch 7.77×, 82 edges
        // over 2×, 81 flips); 1.50 mm while that bone turned with its triangle.
        &Pinned {
            drift_mm: 0.43,
            lips_mm: 47.0,
            eyelids_mm: 4.7,
            stretch: 3.98,
            over_2x: 54,
            flipped: 26,
        },
    );
    let planar = layout_take(&bake_layout_scene(&facebake_tests::planar_product(8)));
    assert!(planar.static_drift_mm.0 <= 0.5, "{planar}");
    guard(
        "FaceCap truth, JawMoCap layout, --deformer planar (masked by the layout's groups)",
        &planar,
        // The skull's bone translates with the inner eye corners and the middle forehead
        // marker (1.50 mm while it turned with the side forehead markers and a canthus).
        &Pinned {
            drift_mm: 0.43,
            lips_mm: 16.8,
            eyelids_mm: 1.7,
            stretch: 2.28,
            over_2x: 4,
            flipped: 2,
        },
    );
}

/// A layout without `[groups]`: masks find the groups from the mouth and eye openings, the lip
/// and eyelid markers split as the bundled layout's groups split them.
#[test]
fn masks_without_groups_find_them_from_the_openings() {
    let s = layout_scene();
    let scene = facebake::Scene::new(&s.truth.mesh, s.markers.clone());
    let auto = scene
        .with_groups_from_openings()
        .expect("FaceCap has a mouth and two eyes");
    let names = |list: &[usize]| -> Vec<&str> {
        list.iter().map(|&m| s.markers[m].name.as_str()).collect()
    };
    let groups: Vec<(&str, Vec<&str>, Vec<&str>)> = auto
        .groups
        .iter()
        .map(|g| (g.name.as_str(), names(&g.upper), names(&g.lower)))
        .collect();
    assert_eq!(
        groups,
        [
            (
                "mouth",
                vec!["Mouth_Up", "Mouth_UpL1", "Mouth_UpR1"],
                vec!["Mouth_Down", "Mouth_DownL", "Mouth_DownR"]
            ),
            (
                "eyes",
                vec!["Leye_Up", "Reye_Up"],
                vec!["Leye_Down", "Reye_Down"]
            ),
        ]
    );
    // They are the bundled layout's groups, so a layout without them bakes the same rig.
    assert_eq!(auto.groups, s.groups);
    let bare = layout_benchmark(false);
    let options = facebake_tests::planar_product(8);
    assert!(bake_scene(&bare, &options).blob == bake_layout_scene(&options));
}

#[test]
fn facecap_layout_surface_aware() {
    let pinned = [
        (
            "the default",
            Method::Geodesic,
            true,
            // Before the masks faded out at the openings' corners (options::MASK_SIDE_SURFACE),
            // masked: lips 6.7, eyelids 1.1 mm, 2.07× (1 edge), 5 flips at the corners of the
            // mouth and the eyes. 2.06× before the kept weights were shrunk.
            DEFAULT_ON_TRUTH,
        ),
        (
            "--no-masks",
            Method::Geodesic,
            false,
            // Lips 12.5 and eyelids 1.74 mm before the corner reshaping (surface::corners),
            // 6.8 and 1.12 mm before the rims rode their markers
            // (surface::distances::shorten_across_rims); static drift 0.59 mm anchored on the
            // forehead markers alone. Before the kept weights were shrunk
            // (sparsify::Refit::Shrink): lips 6.7 mm, 2.17× (2 edges in the smile), no flip;
            // 1.98× before the skin beside the mouth's corrections gave way to them
            // (sparsify::sparsify_row_giving_way). Lips 6.8 mm, 1.93× until the mouth's
            // corrections faded in linearly (surface::corners::FADE_IN).
            Pinned {
                drift_mm: 0.34,
                lips_mm: 7.1,
                eyelids_mm: 0.91,
                stretch: 1.91,
                over_2x: 0,
                flipped: 1,
            },
        ),
        (
            "--method hybrid",
            Method::Hybrid,
            true,
            // The default's one sliver. With the geodesic region and its decay half as wide
            // (options::HYBRID_REACH): the same, eyelids 0.8 mm. Lips 6.8 mm, 1.92× until the
            // mouth's corrections faded in linearly.
            Pinned {
                drift_mm: 0.34,
                lips_mm: 7.0,
                eyelids_mm: 0.9,
                stretch: 1.88,
                over_2x: 0,
                flipped: 1,
            },
        ),
        (
            "--method hybrid --no-masks",
            Method::Hybrid,
            false,
            // Geodesic near the openings, Euclidean beyond. With the geodesic region and its
            // decay half as wide (options::HYBRID_REACH) the Euclidean part flipped 15
            // triangles about the jaw-open mouth (1.94×); with the prior's re-fit besides (before
            // the skin beside the mouth's corrections gave way to them): drift 0.60 mm, 2.24×
            // (2 edges), 18 flips. Lips 6.8 mm, 1.93× until the mouth's corrections faded in
            // linearly.
            Pinned {
                drift_mm: 0.34,
                lips_mm: 7.1,
                eyelids_mm: 0.9,
                stretch: 1.90,
                over_2x: 0,
                flipped: 1,
            },
        ),
        (
            "--method pbw",
            Method::Pbw,
            true,
            // Local share options::PBW_ALPHA, shrunk. At α = 0.5 with the prior's re-fit: drift
            // 0.49 mm (0.54 before the anchoring rose linearly), lips 9.1, eyelids 1.6 mm,
            // 2.89× (6 edges), 13 flips; with paper 002's global part besides, a multiquadric on
            // Euclidean distances: drift 0.42, lips 10.7, eyelids 1.3 mm, 14.21× (419 edges), 357
            // flips (the nose thrown out by up to 80 mm in the jaw open). Lips 7.2 mm until the
            // mouth's corrections faded in linearly.
            Pinned {
                drift_mm: 0.35,
                lips_mm: 7.4,
                eyelids_mm: 1.0,
                stretch: 1.94,
                over_2x: 0,
                flipped: 2,
            },
        ),
    ];
    for (label, method, masks, pins) in &pinned {
        let baked = bake_scene(layout_scene(), &BakeOptions::for_method(*method, *masks));
        let take = layout_take(&baked.blob);
        guard(
            &format!("FaceCap truth, JawMoCap layout, {label}"),
            &take,
            pins,
        );
        // The static-region bar (no skin beyond the markers moves more than 0.5 mm) and
        // its eyelid bar (closure within 1.5 mm of the truth in every frame), which every
        // method meets.
        assert!(take.static_drift_mm.0 <= 0.5, "{label}: {take}");
        assert!(take.eyelids_mm.unwrap().0 <= 1.5, "{label}: {take}");
        // The error bars on this marker set (the 41 layout markers alone): face mean
        // ≤ 0.6 mm and max ≤ 12 mm, met by the default (0.556 and 9.07 mm; 0.578 before the
        // kept weights were shrunk); lip band (8 mm from the mouth) p99 ≤ 4 mm, missed (4.24
        // mm, pinned; 4.11 with the prior's re-fit).
        if *method == Method::Geodesic {
            let scores = layout_scene().score(&baked.blob);
            let (face, lips) = (scores.whole, scores.bands[0]);
            println!(
                "FaceCap truth, JawMoCap layout, {label}: face mean / p99 / max {:.3} / {:.2} / \
                 {:.2} mm, lip band p99 {:.2} mm",
                face.mean_mm, face.p99_mm, face.max_mm, lips.p99_mm
            );
            assert!(face.mean_mm <= 0.6 && face.max_mm <= 12.0, "{face:?}");
            assert!(lips.p99_mm <= 4.22, "{lips:?}");
            // 0.543 mm before the upper lip's markers let go of the skin past the lip
            // (`surface::let_go`, 2026-12-05), 0.519 before the cheeks' anchoring rose three
            // times as far across (`surface::anchoring::ACROSS_RISE`), 0.514 before the lower
            // lip handed its depth to the jaw (`surface::let_go::lower_lip_depth`).
            assert!(face.mean_mm <= 0.508, "{face:?}");
        }
    }
}

/// The default on denser faces: FaceCap subdivided once (10,406 vertices, edges half as long,
/// the same expressions) and twice (40,926), the JawMoCap layout placed on them. A re-fit of
/// the kept weights jumps where a vertex's kept set changes, and a jump stretches an edge in
/// proportion to the markers' relative motion over the edge's length, so halving the edges
/// doubles it; shrinking (`Refit::Shrink`, the default) is continuous there. Measured
/// 2026-11-28, worst over the 32 frames, shrunk against re-fitted (prior):
///
/// | face | static drift | stretch (edges; frames) | flips | face mean |
/// |---|---|---|---|---|
/// | subdivided once | 0.45 / 0.91 mm | 2.23× (11; 3) / 2.30× (7; 6) | 1 / 8 | 0.554 / 0.585 mm |
/// | subdivided twice | 0.50 / 0.93 mm | 2.37× (37; 4) / 4.71× (74; 16) | 3 / 98 | – |
///
/// Masked (the default since 2026-12-02) and with the anchoring's linear rise
/// (`surface::anchoring::HULL_RISE`), shrunk: once 0.42 mm, 2.25× (10; 1), no flip, 0.550 mm;
/// twice 0.43 mm, 2.38× (37; 4), 2 flips. With the hull lowered from the anchor markers
/// (`surface::anchoring::HULL_LOWERING`), the static drift once 0.34 mm and twice 0.35 mm, and
/// the prior's re-fit's once 0.34 mm too (it was over 0.2 mm above the shrink's): the shrink's
/// lead is now its flips and its mean.
///
/// The mouth's corners keep K less their 2 derived vertical influences
/// (`deformer::linear::bake`), so the kept set changed where the corrections begin: twice
/// subdivided, 2.72× (49 edges) there. The skin beside them now gives way over a ring
/// (`surface::corners::RING`, `sparsify::sparsify_row_giving_way`) and keeps the rig's
/// uniform influence count (which the Cortex-M4's unrolled kernel needs); keeping all K markers
/// besides the corrections gave the same 2.37× but broke that count (the capture rig's frame
/// 241k → 386k instructions). The blinks folded the last millimetres before the inner corners
/// of the eyes (14 flips) until the eyes' corner profile was straight near its tip
/// (`surface::corners::EYE_TIP`); then 3 flips were left beside a brow in the surprise (and 2
/// at the jaw's side, 2 below the lower lip, in other frames).
///
/// The funnel's tear on the denser faces (a 0.88 mm lower-lip edge 1.4 mm in from each corner,
/// 2.25× once subdivided; 0.44 mm and 2.38× twice) was the mouth's vertical correction fading in
/// from the corner by a smoothstep, whose middle a finer mesh samples; fading in linearly
/// (`surface::corners::FADE_IN`, 2026-12-03): once 1.99× with no edge over 2×, twice 2.16× (5
/// edges beside the jaw in `blend 22`), lips 7.0 / 6.9 → 6.7 / 6.6 mm. Twice 2.03× (1 edge)
/// since the lid markers let go of the skin past the lids (`surface::lids`, 2026-12-04).
#[test]
fn denser_faces_keep_their_skull_still_with_shrunk_weights() {
    let layout = facebake::io::layout::read_layout(&fixture("facecap_jawmocap_layout.toml"))
        .expect("the layout reads");
    let measure = |times: usize, refit| {
        let truth = facebake_tests::facecap_truth_subdivided(times);
        let placed = facebake::model::place_markers(&layout, &truth.mesh, 0.02).expect("placed");
        let scene = Benchmark::new(truth, &placed, layout.groups.clone(), 0).expect("scene");
        let regions =
            Regions::for_mesh(&scene.truth.mesh, &scene.truth.marker_rest(), &[]).expect("regions");
        let options = BakeOptions {
            refit,
            ..BakeOptions::product_default()
        };
        let blob = bake_scene(&scene, &options).blob;
        let (_, take) =
            regions.measure_take(&scene.play(&blob), Some(&truths(&scene.truth)), false);
        (take, scene.score(&blob).whole)
    };
    let (shrunk, shrunk_face) = measure(1, facebake::Refit::Shrink);
    let (prior, prior_face) = measure(1, facebake::Refit::Prior);
    println!("FaceCap subdivided, the default: {shrunk}; face {shrunk_face}");
    println!("FaceCap subdivided, the prior's re-fit: {prior}; face {prior_face}");
    assert!(shrunk.static_drift_mm.0 <= 0.5, "{shrunk}");
    assert!(
        prior.static_drift_mm.0 >= shrunk.static_drift_mm.0 - 0.01,
        "{prior}"
    );
    assert!(
        shrunk.flipped.0 < prior.flipped.0,
        "{shrunk} against {prior}"
    );
    assert!(shrunk_face.mean_mm < prior_face.mean_mm, "{shrunk_face}");
    guard(
        "FaceCap subdivided, JawMoCap layout, the default",
        &shrunk,
        &Pinned {
            drift_mm: 0.34,
            lips_mm: 6.7,
            eyelids_mm: 0.9,
            stretch: 1.99,
            over_2x: 0,
            flipped: 0,
        },
    );
    let (twice, _) = measure(2, facebake::Refit::Shrink);
    guard(
        "FaceCap subdivided twice (40,926 vertices), JawMoCap layout, the default",
        &twice,
        &Pinned {
            drift_mm: 0.35,
            lips_mm: 6.6,
            eyelids_mm: 1.0,
            stretch: 2.03,
            over_2x: 1,
            flipped: 2,
        },
    );
}

/// Every vertex of the default rigs has the same number of influences, so the runtime's
/// uniform-count kernel serves them (`facebake_runtime`'s linear deformer: 241k against 386k
/// instructions a frame on the Cortex-M4 for the FaceCap capture rig, docs/measurements.md).
#[test]
fn the_default_rigs_keep_one_influence_count() {
    let counts = |blob: &[u8]| -> std::collections::BTreeSet<usize> {
        let rig = Rig::from_bytes(blob).expect("loads");
        let facebake_runtime::deformer::Deformer::Linear(linear) = rig.deformer() else {
            panic!("the default deformer is linear")
        };
        linear.vertex_influences().map(Iterator::count).collect()
    };
    let scene = layout_benchmark(false);
    let truth = counts(&bake_scene(&scene, &BakeOptions::product_default()).blob);
    let capture = counts(
        &jawmocap_rig_with(&BakeOptions::product_default(), &Default::default())
            .baked
            .blob,
    );
    assert_eq!(truth.len(), 1, "{truth:?}");
    assert_eq!(capture.len(), 1, "{capture:?}");
}

/// JawMoCap played through a capture rig baked with `options` (the default stages), measured per
/// frame and over the take on the character (no truth).
fn jawmocap_take(options: &BakeOptions) -> (Vec<FrameMetrics>, TakeMetrics) {
    let j = jawmocap_rig_with(options, &facebake::StagesConfig::default());
    let rig = Rig::from_bytes(&j.baked.blob).expect("rig loads");
    let (space, actor) = (rig.space(), rig.stages().expect("stages").actor_space);
    let mut state = PlayState::new();
    let mut out = vec![[0i32; 3]; rig.vertex_count()];
    let played: Vec<Vec<[f64; 3]>> = j
        .frames
        .iter()
        .map(|f| {
            let q: Vec<Option<[i32; 3]>> = f
                .iter()
                .map(|p| p.and_then(|p| actor.to_rig_f64(p).ok()))
                .collect();
            rig.play(&mut state, &q, &mut out).expect("plays");
            out.iter().map(|p| space.to_asset_f64(*p)).collect()
        })
        .collect();
    let r = Regions::for_mesh(&j.mesh, &[], &[]).expect("regions");
    r.measure_take(&played, None, false)
}

/// Every method `bake --capture --method` accepts, on JawMoCap, as the CLI bakes it (the linear
/// deformer, anchored, corners reshaped, rims riding their markers, masked). The default meets
/// every bar there (static drift 0.00 mm, no edge over 2×, no flip; 1.90×, 1.96× unmasked), and
/// so do hybrid (1.91×), PBW (1.83×) and Euclidean (1.89×; 1.90×, 1.80× and 1.89× before the
/// still head markers shared one of the K weights, `surface::anchoring::merge_held`, which
/// opens Euclidean's lips 35.6 → 36.7 mm); before the mouth's corrections faded
/// in linearly (`surface::corners::FADE_IN`), 1.92×, 1.93×, 1.85× and 1.86×.
/// Every one held the skull within 0.13–0.23 mm before the anchoring's hull left out the held
/// head markers (`surface::anchoring::hull_markers`); now 0.00 mm.
#[test]
fn jawmocap_every_method() {
    for (method, masks, pins) in [
        (
            Method::Euclidean,
            true,
            // The masks part the lips. With the prior's re-fit (before the kept weights were
            // shrunk) straight lines moved the skull 0.73 mm; 2.33× (6 edges) in 117 frames.
            // 2.36× (4 edges) in 118 frames before the masks faded out at the corners; 2.18×
            // (1 edge beside the right corner) in 108 before the skin past the mouth's corners
            // was balanced over 0.4 spacings for Euclidean distances, not 0.3
            // (surface::corners::PAST_CORNER_REACH_EUCLIDEAN).
            Pinned {
                drift_mm: 0.0,
                lips_mm: 36.7,
                eyelids_mm: 11.9,
                stretch: 1.89,
                over_2x: 0,
                flipped: 0,
            },
        ),
        (
            Method::Geodesic,
            true,
            // The default. 1.98× before the masks faded out at the corners.
            DEFAULT_ON_JAWMOCAP,
        ),
        (
            Method::Hybrid,
            true,
            // With the geodesic region and its decay half as wide (options::HYBRID_REACH):
            // 2.01×, one edge past 2× in 67 frames; unmasked besides, 1.99× and 4 flips; with the
            // prior's re-fit, unmasked: drift 0.70 mm, 1.93×, 5 flips.
            Pinned {
                drift_mm: 0.0,
                lips_mm: 40.9,
                eyelids_mm: 12.0,
                stretch: 1.90,
                over_2x: 0,
                flipped: 0,
            },
        ),
        (
            Method::Pbw,
            true,
            // At α = 0.5 with the prior's re-fit its local weights stretched the lips' corners
            // in the jaw open: open 37.9 mm, 2.72× (2 edges; 118 frames), 6 flips.
            Pinned {
                drift_mm: 0.0,
                lips_mm: 40.2,
                eyelids_mm: 12.0,
                stretch: 1.83,
                over_2x: 0,
                flipped: 0,
            },
        ),
    ] {
        let (_, take) = jawmocap_take(&BakeOptions::for_method(method, masks));
        let label = format!(
            "JawMoCap, bake --capture --method {}{}",
            method.name(),
            if masks { "" } else { " --no-masks" }
        );
        guard(&label, &take, &pins);
    }
}

#[test]
fn jawmocap_planar() {
    let (frames, take) = jawmocap_take(&facebake_tests::planar_product(8));
    println!("JawMoCap frame 388 (mouth open), planar: {}", frames[388]);
    // The skull bone's three forehead markers are the head markers, which hold still once the
    // head's motion is taken out (1.98 mm when they moved by their fit residuals).
    assert!(take.static_drift_mm.0 <= 0.5, "{take}");
    guard(
        "JawMoCap, bake --capture --deformer planar",
        &take,
        // 0.33 mm before the anchoring rose linearly (surface::anchoring::HULL_RISE).
        &Pinned {
            drift_mm: 0.28,
            lips_mm: 40.5,
            eyelids_mm: 11.6,
            stretch: 1.91,
            over_2x: 0,
            flipped: 0,
        },
    );
    let (_, bare) = jawmocap_take(&facebake_tests::planar_config(8));
    guard(
        "JawMoCap, bake --capture --deformer planar --no-masks",
        &bare,
        // Lips sealed (at most 1.2 mm apart) and 39 edges over 2× at the widest mouth.
        &Pinned {
            drift_mm: 0.28,
            lips_mm: 1.2,
            eyelids_mm: 10.7,
            stretch: 3.58,
            over_2x: 39,
            flipped: 0,
        },
    );
}

#[test]
fn jawmocap_through_the_demo_rig() {
    // What `bake --capture` bakes with no other flag: head markers picked among the skull markers.
    let (frames, take) = jawmocap_take(&BakeOptions::product_default());
    let open = frames[388];
    println!("JawMoCap frame 388 (mouth open): {open}");
    // Mouth open: the lips part (the actor's lip markers part by 43.7 mm more than at rest;
    // proportional retargeting carries 41.7 mm of it to the character's). The bars on
    // the static region and on flips hold over the take.
    assert!(open.lips.unwrap().widest_mm > 30.0, "{open}");
    assert!(take.static_drift_mm.0 <= 0.5, "{take}");
    assert_eq!(take.flipped.0, 0, "{take}");
    guard(
        "JawMoCap, the default capture rig (no truth: lips and eyelids are the widest aperture)",
        &take,
        // Static drift 0.42 mm before the kept weights were shrunk (sparsify::Refit::Shrink),
        // 0.37 before the anchoring's hull left out the held head markers
        // (surface::anchoring::hull_markers); lips open 36.0 mm before the rims rode their
        // markers; eyelids open 11.7 mm before the lids near their corners took more of the lid
        // markers' motion (surface::corners); 2.03× (1 edge, in 80 frames) before the skin past
        // the mouth's corners was balanced between the lips
        // (surface::corners::balance_past_mouth_corners).
        &DEFAULT_ON_JAWMOCAP,
    );
    // The bars on JawMoCap: no edge over 2× and no flip in any frame.
    assert_eq!(take.frames_over_limit, 0, "{take}");
    assert!(take.max_stretch.0 <= 2.0, "{take}");
}

/// The best linear rig these markers allow, fitted to the truth itself: per vertex, the weights
/// on the 41 layout markers' displacements that best reproduce the vertex's own displacement
/// over `frames` (least squares, ridge `lambda` × the mean diagonal), used on `predict`.
fn fitted_linear_rig(
    s: &Benchmark,
    truth: &[Vec<[f64; 3]>],
    frames: &[usize],
    predict: &[usize],
    lambda: f64,
    out: &mut [Vec<[f64; 3]>],
) {
    use nalgebra::{DMatrix, DVector};
    let rest = &s.truth.mesh.positions;
    let at_rest = s.markers_of(rest);
    let moved: Vec<Vec<[f64; 3]>> = truth
        .iter()
        .map(|t| {
            let m = s.markers_of(t);
            m.iter()
                .zip(&at_rest)
                .map(|(a, b)| [0, 1, 2].map(|c| a[c] - b[c]))
                .collect()
        })
        .collect();
    let n = at_rest.len();
    let a = DMatrix::from_fn(3 * frames.len(), n, |row, i| {
        moved[frames[row / 3]][i][row % 3]
    });
    let mut normal = a.transpose() * &a;
    let ridge = lambda * normal.trace() / n as f64;
    for i in 0..n {
        normal[(i, i)] += ridge;
    }
    let solver = normal.cholesky().expect("ridge makes it positive definite");
    for (v, p) in rest.iter().enumerate() {
        let b = DVector::from_fn(3 * frames.len(), |row, _| {
            truth[frames[row / 3]][v][row % 3] - p[row % 3]
        });
        let w = solver.solve(&(a.transpose() * b));
        for &f in predict {
            out[f][v] =
                [0, 1, 2].map(|c| p[c] + (0..n).map(|i| w[i] * moved[f][i][c]).sum::<f64>());
        }
    }
}

/// Why the lip bar (within 2 mm of the truth's aperture in every frame) is out of reach of a
/// rig that gives each vertex one fixed weight per marker (the linear deformer's form, its few
/// per-axis mouth corrections aside), on these 41 markers:
/// fitted to all 32 truth frames themselves, the best such weights still miss a lip pair by
/// more than 2 mm (measured 2026-11-27: 2.4 mm, with 4 flipped triangles), and fitted to 31
/// frames to predict the 32nd (the honest figure for an expression the fit did not see) they
/// miss by 6.4 mm, face mean 0.48 mm (ridge 1e-4; ridge 1e-2: 4.5 mm, 3.0× stretch and 6
/// flips), against the default bake's 6.7 mm and 0.58 mm. The bar needs a deformation that is
/// not linear in the markers (a lip model); more lip markers meet the lip band's bar but not
/// this one (`more_lip_markers_meet_the_lip_band_bar_but_not_the_aperture_bar`).
#[test]
fn a_fixed_weight_rig_cannot_meet_the_lip_bar_with_these_markers() {
    let s = layout_scene();
    let truth = truths(&s.truth);
    let all: Vec<usize> = (0..truth.len()).collect();
    let mut fitted = truth.clone();
    fitted_linear_rig(s, &truth, &all, &all, 1e-4, &mut fitted);
    let (_, best) = regions().measure_take(&fitted, Some(&truth), false);
    println!("the best fixed weights, fitted to every frame: {best}");
    let mut unseen = truth.clone();
    for &f in &all {
        let others: Vec<usize> = all.iter().copied().filter(|&g| g != f).collect();
        fitted_linear_rig(s, &truth, &others, &[f], 1e-4, &mut unseen);
    }
    let (_, predicted) = regions().measure_take(&unseen, Some(&truth), false);
    let face = s.score_positions(&unseen).whole;
    println!(
        "fitted to the other 31 frames: {predicted}; face mean {:.2} mm",
        face.mean_mm
    );
    let lips = best.lips_mm.unwrap().0;
    assert!(lips > 2.0, "{best}");
    assert!(predicted.lips_mm.unwrap().0 > 4.0, "{predicted}");
}

/// Where the default misses the truth's lips, pair by pair across the mouth (the rim pairs
/// ordered by their x, the middle at 0). Measured 2026-12-03 in the jaw open (mm, rig − truth,
/// right half; the left mirrors it):
///
/// | x | 21.8 | 20.1 | 17.5 | 14.4 | 11.0 | 7.5 | 3.8 | 0 |
/// |---|---|---|---|---|---|---|---|---|
/// | truth's opening | 13.3 | 20.3 | 30.4 | 35.9 | 40.7 | 44.3 | 46.4 | 47.1 |
/// | rig − truth | −6.6 | −5.4 | −5.0 | −3.9 | −1.8 | −2.8 | −1.9 | 0.0 |
///
/// (−6.4 at 21.8 mm before the mouth's corrections faded in linearly, `surface::corners::FADE_IN`.)
///
/// The middle pair, with a marker in front of each rim, is exact; between the markers (at 0 and
/// 12 mm) the rig interpolates nearly in proportion while the truth opens as an ellipse over
/// the mouth's width (0.987, 0.946, 0.880 of the middle at 3.8, 7.5, 11 mm, the truth 0.985,
/// 0.941, 0.864), 2–3 mm short; within 6 mm of a corner the rim follows the corner's marker,
/// 5–6.6 mm short. Reshaping the weights between lip markers to the ellipse (tried, not kept)
/// closes the middle's gap in the jaw open (−0.2, −0.8, −1.0) but carries the funnel's own
/// overshoot at the middle pair (its lip markers part 4.5 mm more than its rims) outwards
/// (+1.7, −0.2, +0.3 → +4.3, +2.8, +1.4): over all 32 frames × 15 pairs the mean error moved
/// 1.098 → 1.085 mm and the pairs over 2 mm 76 → 81, so fixed weights cannot have both.
#[test]
fn the_jaw_open_lips_are_exact_in_the_middle_and_short_towards_the_corners() {
    let s = layout_scene();
    let jaw = frame(&s.truth, "jaw open");
    let played = &s.play(&bake_layout_scene(&BakeOptions::product_default()))[jaw];
    let truth = s.truth.positions(jaw);
    let r = regions();
    let gap = |p: &[[f64; 3]], [u, l]: [u32; 2]| {
        1000.0 * facebake::mesh::distance(&p[u as usize], &p[l as usize])
    };
    let mut pairs: Vec<(f64, f64)> = r
        .lips
        .iter()
        .map(|&q| {
            (
                1000.0 * r.rest()[q[0] as usize][0],
                gap(played, q) - gap(&truth, q),
            )
        })
        .collect();
    pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
    let text: Vec<String> = pairs
        .iter()
        .map(|(x, e)| format!("{x:.1}: {e:+.1}"))
        .collect();
    println!(
        "jaw open, rig − truth per lip pair (x mm: mm): {}",
        text.join(", ")
    );
    let (middle, _) = pairs
        .iter()
        .enumerate()
        .min_by(|a, b| a.1 .0.abs().total_cmp(&b.1 .0.abs()))
        .expect("lip pairs");
    assert!(pairs[middle].1.abs() <= 0.5, "{text:?}");
    // Short everywhere else, most within 3 mm of each corner.
    assert!(pairs.iter().all(|&(_, e)| e <= 0.5), "{text:?}");
    let worst = pairs.iter().map(|&(_, e)| e).fold(0.0, f64::min);
    for end in [pairs[0].1, pairs[pairs.len() - 1].1] {
        assert!(end <= worst + 0.5, "{text:?}");
    }
}

/// Four more lip markers (upper and lower, 19 mm each side of the middle, between the layout's
/// lip markers and the corners, 2 mm off the rim as the others) meet the lip band's bar (p99 of
/// the skin within 8 mm of the mouth 4.21 → 3.38 mm, bar 4; face mean 0.553 → 0.526 mm) but not
/// the aperture's: the worst pair is still `blend 2`'s (a jaw open among other targets), 7.0 mm
/// short 1.4 mm from a corner, where the rim follows the corner's marker (measured 2026-12-03;
/// in the jaw open the new markers part by 26.7 mm, the rim between them and the corner by
/// 20.3 in the truth and 14.5 in the rig), and the jaw open turns 2 triangles over (1 sliver
/// with the 41).
#[test]
fn more_lip_markers_meet_the_lip_band_bar_but_not_the_aperture_bar() {
    let truth = facebake_tests::facecap_truth();
    let mut layout = facebake::io::layout::read_layout(&fixture("facecap_jawmocap_layout.toml"))
        .expect("the layout reads");
    // FaceCap's skin vertices at (∓19.4, −42.6, 57.3) and (∓18.6, −45.8, 55.8) mm.
    let extra = [
        ("Mouth_UpR2", 1740, true),
        ("Mouth_DownR2", 622, false),
        ("Mouth_UpL2", 1301, true),
        ("Mouth_DownL2", 1290, false),
    ];
    for (name, vertex, upper) in extra {
        let index = layout.markers.len();
        layout.markers.push(facebake::model::LayoutMarker {
            name: name.into(),
            anchor: facebake::model::MarkerAnchor::Vertex(vertex),
            stiffness: 1.0,
        });
        let mouth = layout
            .groups
            .iter_mut()
            .find(|g| g.name == "mouth")
            .expect("the layout's mouth group");
        if upper {
            mouth.upper.push(index);
        } else {
            mouth.lower.push(index);
        }
    }
    let placed = facebake::model::place_markers(&layout, &truth.mesh, 0.02).expect("placed");
    let scene = Benchmark::new(truth, &placed, layout.groups.clone(), 0).expect("scene");
    let blob = bake_scene(&scene, &BakeOptions::product_default()).blob;
    let (_, take) = regions().measure_take(&scene.play(&blob), Some(&truths(&scene.truth)), false);
    let scores = scene.score(&blob);
    let (face, band) = (scores.whole, scores.bands[0]);
    println!(
        "45 markers: {take}; face mean {:.3} mm, lip band p99 {:.2} mm",
        face.mean_mm, band.p99_mm
    );
    assert!(band.p99_mm <= 4.0, "{band:?}");
    assert!(face.mean_mm < 0.553, "{face:?}");
    assert!(take.lips_mm.expect("lips").0 > 6.0, "{take}");
}

/// The forms and methods `bake` accepts that the other tests do not measure, pinned so that
/// their figures are reported too. The RBF deformer (`bake --deformer rbf`) has no masks and no
/// corner reshaping; anchored, its affine part is the anchor markers' mean translation
/// (`RbfSystem::anchored_coefficient_map`) and its radial terms fade by the static anchoring's
/// strength. It keeps every radial term (`facebake::RBF_K`): at K = 8 (the bake warns) the
/// kept terms of neighbouring vertices differ while the coefficients alternate in sign, and the
/// skin tore (measured 2026-12-02 on the truth: 3.47×, 38 edges over 2×, 58 flips, static
/// drift 1.76 mm beside `ForeHead_M`; JawMoCap 5.27×, 104 edges, 11 flips); with all of them the
/// truth 2.16× and 2 flips, JawMoCap 2.01× (in 58 frames) and 1 flip, the lips still 12 mm off
/// without the linear deformer's corners. Unanchored, the skull moves 33 mm. `--method
/// euclidean --no-masks` keeps the default's anchoring (the bake used to drop it on this path:
/// static drift 20.3 mm, 45 flips) but ties the lips together.
#[test]
fn the_rbf_deformer_and_unmasked_euclidean() {
    let rbf =
        BakeOptions::for_method(Method::Geodesic, false).with_deformer(facebake::DeformerKind::Rbf);
    guard(
        "FaceCap truth, JawMoCap layout, --deformer rbf",
        &layout_take(&bake_layout_scene(&rbf)),
        // The smile stretches a 0.6 mm edge inside each corner of the mouth, and `blend 22` turns
        // a triangle over there, where the linear deformer reshapes the weights.
        &Pinned {
            drift_mm: 0.34,
            lips_mm: 12.4,
            eyelids_mm: 1.6,
            stretch: 2.16,
            over_2x: 2,
            flipped: 2,
        },
    );
    guard(
        "JawMoCap, bake --capture --deformer rbf",
        &jawmocap_take(&rbf).1,
        &Pinned {
            drift_mm: 0.0,
            lips_mm: 39.3,
            eyelids_mm: 11.8,
            stretch: 2.01,
            over_2x: 1,
            flipped: 1,
        },
    );
    guard(
        "FaceCap truth, JawMoCap layout, --deformer rbf -k 8",
        &layout_take(&bake_layout_scene(&BakeOptions {
            k: 8,
            ..rbf.clone()
        })),
        // With full distances across the rims (until it kept every term): 1.9 mm, 3.48×, 39
        // edges, 57 flips.
        &Pinned {
            drift_mm: 1.76,
            lips_mm: 11.3,
            eyelids_mm: 1.8,
            stretch: 3.47,
            over_2x: 38,
            flipped: 58,
        },
    );
    guard(
        "FaceCap truth, JawMoCap layout, --deformer rbf --no-anchoring",
        &layout_take(&bake_layout_scene(&BakeOptions {
            anchoring: None,
            ..rbf
        })),
        &Pinned {
            drift_mm: 33.25,
            lips_mm: 12.6,
            eyelids_mm: 1.6,
            stretch: 2.18,
            over_2x: 2,
            flipped: 1,
        },
    );
    let euclidean = BakeOptions {
        masks: false,
        ..BakeOptions::for_method(Method::Euclidean, false)
    };
    guard(
        "FaceCap truth, JawMoCap layout, --method euclidean --no-masks (anchored)",
        &layout_take(&bake_layout_scene(&euclidean)),
        // Anchored since the bake no longer drops the anchoring on this path; straight lines
        // still tie the lips together across the closed mouth.
        &Pinned {
            drift_mm: 0.62,
            lips_mm: 46.4,
            eyelids_mm: 3.0,
            stretch: 8.13,
            over_2x: 107,
            flipped: 56,
        },
    );
}

/// The jaw transform the issue suggests, measured under the default bake: per frame, the rigid
/// motion that best carries the five chin and jaw-line markers (`Chin`, `Chin_L1/L2/R1/R2`) from
/// rest, applied to the lower face in proportion to a jaw weight, with the default rig moving
/// what is left. The jaw weight is the rig's own interpolation of 1 on the jaw markers (and the
/// lower lip's three with `lower_lip`, ½ on the mouth's corners) and 0 elsewhere, so every
/// marker is still reproduced: a marker's residual is its displacement less its jaw weight
/// times the jaw's motion there.
fn rigid_jaw_take(blob: &[u8], lower_lip: bool) -> (TakeMetrics, f64, f64) {
    let s = layout_scene();
    let rig = Rig::from_bytes(blob).expect("loads");
    let space = rig.space();
    let rest = &s.truth.mesh.positions;
    let at_rest = s.markers_of(rest);
    // The rig's displacement of every vertex for marker displacements `moved`.
    let deform = |moved: &[[f64; 3]]| -> Vec<[f64; 3]> {
        let q: Vec<[i32; 3]> = at_rest
            .iter()
            .zip(moved)
            .map(|(p, d)| {
                space
                    .to_rig_f64([0, 1, 2].map(|c| p[c] + d[c]))
                    .expect("in")
            })
            .collect();
        let mut out = vec![[0i32; 3]; rig.vertex_count()];
        rig.deform(&q, &mut out).expect("deforms");
        out.iter()
            .zip(rest)
            .map(|(p, r)| {
                let p = space.to_asset_f64(*p);
                [0, 1, 2].map(|c| p[c] - r[c])
            })
            .collect()
    };
    let jaw_markers = ["Chin", "Chin_L1", "Chin_L2", "Chin_R1", "Chin_R2"];
    let share = |name: &str| match name {
        n if jaw_markers.contains(&n) => 1.0,
        "Mouth_Down" | "Mouth_DownL" | "Mouth_DownR" if lower_lip => 1.0,
        "Mouth_Lend" | "Mouth_Rend" if lower_lip => 0.5,
        _ => 0.0,
    };
    let marker_share: Vec<f64> = s.markers.iter().map(|m| share(&m.name)).collect();
    let unit = 0.001;
    let lift: Vec<[f64; 3]> = marker_share.iter().map(|&w| [0.0, w * unit, 0.0]).collect();
    let vertex_share: Vec<f64> = deform(&lift).iter().map(|d| d[1] / unit).collect();
    let jaw: Vec<usize> = (0..s.markers.len())
        .filter(|&i| jaw_markers.contains(&s.markers[i].name.as_str()))
        .collect();
    let from: Vec<[f64; 3]> = jaw.iter().map(|&i| at_rest[i]).collect();
    let truth = truths(&s.truth);
    let played: Vec<Vec<[f64; 3]>> = truth
        .iter()
        .map(|t| {
            let now = s.markers_of(t);
            let to: Vec<[f64; 3]> = jaw.iter().map(|&i| now[i]).collect();
            let motion = facebake::stages::rigid::kabsch(&from, &to).expect("five markers");
            let swing = |p: &[f64; 3]| {
                let q = motion.apply(p);
                [0, 1, 2].map(|c| q[c] - p[c])
            };
            let residual: Vec<[f64; 3]> = (0..at_rest.len())
                .map(|i| {
                    let j = swing(&at_rest[i]);
                    [0, 1, 2].map(|c| now[i][c] - at_rest[i][c] - marker_share[i] * j[c])
                })
                .collect();
            deform(&residual)
                .iter()
                .enumerate()
                .map(|(v, d)| {
                    let j = swing(&rest[v]);
                    [0, 1, 2].map(|c| rest[v][c] + vertex_share[v] * j[c] + d[c])
                })
                .collect()
        })
        .collect();
    let take = regions().measure_take(&played, Some(&truth), false).1;
    let face = s.score_positions(&played).whole;
    (take, face.mean_mm, face.max_mm)
}

/// A rigid jaw does not part the lips better on these markers: the five chin and jaw-line
/// markers slide with the skin (the smile and the pucker move them too), so their rigid fit
/// swings the lower face where the jaw does not turn, and in the jaw open it turns the inner
/// rims about an axis behind them, which parts them less, not more. Measured 2026-11-28 against
/// the default (lips 6.8 mm, face mean 0.556, max 9.07 mm): jaw markers alone, lips 6.8, face
/// mean 0.602, max 12.05 mm (with the prior's re-fit before the kept weights were shrunk:
/// 6.7, 0.625, 14.4 against the default's 6.7, 0.578, 9.07). Measured 2026-12-06 against the
/// default (lips 7.1 mm, face mean 0.507, max 8.49 mm): jaw markers alone 7.1, 0.570, 16.47;
/// the lower lip on the jaw too 7.5, 0.545, 11.15.
#[test]
fn a_rigid_jaw_under_the_default_rig_parts_the_lips_no_better() {
    let blob = bake_layout_scene(&BakeOptions::product_default());
    let default = layout_take(&blob);
    let default_face = layout_scene().score(&blob).whole;
    for lower_lip in [false, true] {
        let (take, mean, max) = rigid_jaw_take(&blob, lower_lip);
        println!(
            "a rigid jaw (lower lip on it: {lower_lip}) under the default rig: {take}; face mean {mean:.3}, max {max:.2} mm"
        );
        assert!(take.lips_mm.unwrap().0 >= default.lips_mm.unwrap().0 - 0.05);
        assert!(
            mean > default_face.mean_mm,
            "{mean} vs {}",
            default_face.mean_mm
        );
        assert!(
            max > default_face.max_mm + 2.5,
            "{max} vs {}",
            default_face.max_mm
        );
    }
}

/// The lips curve through their markers (`facebake::surface::lip_curve`, the default): the rim
/// between the middle lip markers no longer runs straight from marker to marker, so in the jaw
/// open the lower lip is no V. FaceCap's truth with the JawMoCap layout, the rim vertices
/// between `Mouth_DownR` and `Mouth_DownL` (and the upper lip's between `Mouth_UpR1` and
/// `Mouth_UpL1`), their vertical error against the truth. Measured 2026-12-05: mean over the 32
/// frames 0.479 → 0.454 mm; the jaw open's worst lower rim vertex between its markers 1.80 →
/// 0.70 mm (3.8 and 7.5 mm from the middle: 1.3 / 1.8 → 0.7 / 0.7 mm); face mean 0.5437 →
/// 0.5427 mm, every structure figure as before (`facecap_layout_default_and_planar`).
#[test]
fn the_lips_curve_through_their_markers() {
    let scene = layout_scene();
    let x_of = |name: &str| {
        let m = scene.markers.iter().find(|m| m.name == name).expect(name);
        m.rest[0].abs()
    };
    let lower_reach = x_of("Mouth_DownL").min(x_of("Mouth_DownR"));
    let upper_reach = x_of("Mouth_UpL1").min(x_of("Mouth_UpR1"));
    let rest = &scene.truth.mesh.positions;
    // Rim vertices strictly between the middle markers, each with its lip.
    let mut rim: Vec<(u32, bool)> = Vec::new();
    for &[upper, lower] in &regions().lips {
        if rest[upper as usize][0].abs() < upper_reach - 1e-4 {
            rim.push((upper, false));
        }
        if rest[lower as usize][0].abs() < lower_reach - 1e-4 {
            rim.push((lower, true));
        }
    }
    rim.sort_unstable();
    rim.dedup();
    assert!(rim.len() >= 8, "{rim:?}");
    let jaw_open = frame(&scene.truth, "jaw open");
    let measure = |curve: bool| {
        let mut options = BakeOptions::product_default();
        options.surface.lip_curve = curve;
        let played = scene.play(&bake_scene(scene, &options).blob);
        let truths = truths(&scene.truth);
        let error =
            |f: usize, v: u32| 1000.0 * (played[f][v as usize][1] - truths[f][v as usize][1]).abs();
        let all: Vec<f64> = (0..played.len())
            .flat_map(|f| rim.iter().map(move |&(v, _)| (f, v)))
            .map(|(f, v)| error(f, v))
            .collect();
        let mean = all.iter().sum::<f64>() / all.len() as f64;
        let lower_worst = rim
            .iter()
            .filter(|r| r.1)
            .map(|&(v, _)| error(jaw_open, v))
            .fold(0.0, f64::max);
        (mean, lower_worst)
    };
    let (curved, straight) = (measure(true), measure(false));
    println!(
        "the middle lips' vertical error: mean {:.3} mm (straight {:.3}), the jaw open's lower \
         lip at worst {:.2} mm (straight {:.2})",
        curved.0, straight.0, curved.1, straight.1
    );
    assert!(curved.0 < straight.0 - 0.015, "{curved:?} vs {straight:?}");
    assert!(
        curved.1 <= 0.8 && straight.1 >= 1.5,
        "{curved:?} vs {straight:?}"
    );
}
