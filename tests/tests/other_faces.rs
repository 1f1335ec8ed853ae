//! Faces of other proportions: FaceCap warped smoothly and non-uniformly (wider and shorter,
//! narrower and longer, a heavier jaw), its morph targets warped the same way, so each is
//! another character with an exact truth. The bundled layout's points are warped with it. The
//! default bake of each must hold the skull still, close the eyes and keep the skin whole as
//! it does on FaceCap itself, on the truth and on JawMoCap retargeted onto it through `bake
//! --capture`: nothing in the default may be tuned to one face's proportions.
//!
//! `cargo test --release -p facebake-tests --test other_faces -- --nocapture` prints the
//! figures.

use facebake::ground_truth::GroundTruth;
use facebake::metrics::{Regions, TakeMetrics};
use facebake::model::FaceMesh;
use facebake::surface::evaluate::Benchmark;
use facebake::BakeOptions;
use facebake_tests::{bake_scene, fixture, guard, Pinned, FACECAP_MARKERS};

/// A map of head space in head units (see [`Warp`]).
type HeadMap = fn([f64; 3]) -> [f64; 3];

/// A smooth warp of head space, in head units about the bounding box's centre (x̂ = (x − c)/h,
/// h half the largest side).
struct Warp {
    centre: [f64; 3],
    half: f64,
    map: HeadMap,
}

impl Warp {
    fn of(mesh: &FaceMesh, map: HeadMap) -> Self {
        let (lo, hi) = mesh.bounds();
        let half = (0..3).map(|c| hi[c] - lo[c]).fold(0.0, f64::max) / 2.0;
        Self {
            centre: [0, 1, 2].map(|c| (lo[c] + hi[c]) / 2.0),
            half,
            map,
        }
    }

    fn point(&self, p: [f64; 3]) -> [f64; 3] {
        let q = [0, 1, 2].map(|c| (p[c] - self.centre[c]) / self.half);
        let w = (self.map)(q);
        [0, 1, 2].map(|c| self.centre[c] + self.half * w[c])
    }

    /// The mesh warped, each morph target's delta the warp of its deformed position less the
    /// warp of its rest position (exact, not linearised).
    fn mesh(&self, mesh: &FaceMesh) -> FaceMesh {
        let mut warped = FaceMesh::from_triangles(
            "head",
            mesh.positions.iter().map(|&p| self.point(p)).collect(),
            mesh.triangles.clone(),
        );
        warped.morph_targets = mesh.morph_targets.clone();
        for target in &mut warped.morph_targets {
            for (d, p) in target.deltas.iter_mut().zip(&mesh.positions) {
                let moved = self.point([0, 1, 2].map(|c| p[c] + d[c]));
                let rest = self.point(*p);
                *d = [0, 1, 2].map(|c| moved[c] - rest[c]);
            }
        }
        warped.source = mesh.source.clone();
        warped
    }
}

fn facecap() -> FaceMesh {
    facebake::io::gltf_mesh::load_mesh(&fixture("FaceCapHeadGeneric.glb"), Some("head"), None)
        .expect("FaceCap loads")
}

/// The warped head's truth, driven by the bundled layout's markers warped with it.
fn scene_of(map: HeadMap) -> Benchmark {
    let upright = facecap();
    let warp = Warp::of(&upright, map);
    let truth = GroundTruth::new(warp.mesh(&upright), FACECAP_MARKERS, 6).expect("truth");
    let placed = placed_on(&warp, &truth.mesh);
    Benchmark::new(truth, &placed, Vec::new(), 0).expect("scene")
}

/// The bundled layout warped by `warp`, placed on the warped head `mesh` as `bake` places it.
fn placed_on(warp: &Warp, mesh: &FaceMesh) -> Vec<facebake::model::PlacedMarker> {
    let layout = facebake::io::layout::read_layout(&fixture("facecap_jawmocap_layout.toml"))
        .expect("layout");
    facebake::model::place_markers(
        &facebake_tests::layout_mapped(&layout, |p| warp.point(p)),
        mesh,
        facebake::model::DEFAULT_MAX_SNAP_FRACTION * mesh.diagonal(),
    )
    .expect("placed")
}

/// The actor's markers (`names` at their `neutral` positions) placed on `mesh` by `facebake
/// place` (with `pins`), then on its skin as `bake` puts them.
fn auto_placed(
    mesh: &FaceMesh,
    names: &[String],
    neutral: &[[f64; 3]],
    pins: &[(String, u32)],
) -> Vec<facebake::model::PlacedMarker> {
    let layout = facebake::placement::place(mesh, names, neutral, pins).expect("placed");
    facebake::model::place_markers(
        &layout,
        mesh,
        facebake::model::DEFAULT_MAX_SNAP_FRACTION * mesh.diagonal(),
    )
    .expect("on the mesh")
}

/// The truth's frames of `scene`, its structure metrics over `played` (one per truth frame),
/// and the mean skin error and the mean error of the forehead's skin (above 40 mm, in front of
/// the head's middle), mm.
fn scored(scene: &Benchmark, played: &[Vec<[f64; 3]>]) -> (TakeMetrics, f64, f64) {
    let truth = &scene.truth;
    let truths: Vec<Vec<[f64; 3]>> = (0..truth.frames.len())
        .map(|f| truth.positions(f))
        .collect();
    let regions = Regions::for_mesh(&truth.mesh, &truth.marker_rest(), &[]).expect("regions");
    let (_, take) = regions.measure_take(played, Some(&truths), false);
    let (mut sum, mut count, mut forehead, mut forehead_count) = (0.0, 0, 0.0, 0);
    for (p, t) in played.iter().zip(&truths) {
        for (v, (a, b)) in p.iter().zip(t).enumerate() {
            if truth.skin[v] {
                let e = facebake::mesh::distance(a, b) * 1000.0;
                sum += e;
                count += 1;
                let rest = truth.mesh.positions[v];
                if rest[1] > 0.04 && rest[2] > 0.0 {
                    forehead += e;
                    forehead_count += 1;
                }
            }
        }
    }
    (take, sum / count as f64, forehead / forehead_count as f64)
}

/// The truth's 32 frames through the default rig of the warped head, measured on it:
/// (structure, skin mean error in mm).
fn truth_take(map: HeadMap) -> (TakeMetrics, f64) {
    let scene = scene_of(map);
    let baked = bake_scene(&scene, &BakeOptions::product_default());
    let (take, mean, _) = scored(&scene, &scene.play(&baked.blob));
    (take, mean)
}

/// The truth of the warped head played as a capture (its markers' 32 frames after a neutral
/// one, as `bake --capture` takes them, no smoothing): structure, skin and forehead means.
fn truth_as_capture(map: HeadMap) -> (TakeMetrics, f64, f64) {
    let scene = scene_of(map);
    let mesh = &scene.truth.mesh;
    let mut frames = vec![scene.markers_of(&mesh.positions)];
    for f in 0..scene.truth.frames.len() {
        frames.push(scene.markers_of(&scene.truth.positions(f)));
    }
    let capture = facebake::model::Capture {
        source: "truth.csv".into(),
        rate_hz: 30.0,
        units: facebake::model::Units::Metres,
        marker_names: scene.markers.iter().map(|m| m.name.clone()).collect(),
        frames: frames
            .iter()
            .map(|f| f.iter().map(|p| Some(*p)).collect())
            .collect(),
    };
    let mut options = BakeOptions::product_default();
    // The truth's frames are expressions, not a take: no filter, no bound on a frame's step.
    options.stages.smoothing = facebake::stages::SmoothingUse::Off;
    options.stages.head_smoothing = facebake::stages::SmoothingUse::Off;
    options.stages.max_step = Some(10.0);
    options.stages.max_displacement = Some(10.0);
    let mut with_capture = facebake_tests::benchmark_scene(&scene);
    with_capture.capture = Some(&capture);
    let baked = facebake::bake(&with_capture, &options).expect("bakes");
    let rig = facebake_runtime::Rig::from_bytes(&baked.blob).expect("loads");
    let played = facebake_tests::play_take(&rig, &capture.frames).0;
    scored(&scene, &played[1..])
}

fn unwarped(q: [f64; 3]) -> [f64; 3] {
    q
}

/// Wider and shorter, the face bent back about the vertical axis (the geodesic retargeting
/// test's character).
fn wide(q: [f64; 3]) -> [f64; 3] {
    [1.15 * q[0], 0.9 * q[1], q[2] + 0.08 * q[0] * q[0]]
}

/// Narrower and longer, deeper from front to back.
fn long(q: [f64; 3]) -> [f64; 3] {
    [0.88 * q[0], 1.12 * q[1], 1.1 * q[2]]
}

/// A heavier jaw: the lower face wider and pushed forward, fading out above the nose.
fn jaw(q: [f64; 3]) -> [f64; 3] {
    let t = (-(q[1] + 0.1) / 0.5).clamp(0.0, 1.0);
    let s = t * t * (3.0 - 2.0 * t);
    [q[0] * (1.0 + 0.15 * s), q[1], q[2] + 0.06 * s]
}

/// Measured 2026-12-02, masked (the default). Every face meets the bars for static
/// drift (0.5 mm), eyelids (1.5 mm) and skin mean (0.6 mm), and misses the lips as FaceCap does
/// (near the corners, which no lip marker sees part). FaceCap keeps its one sliver flip (beside
/// the right corner of the mouth in `blend 1`), the heavier jaw one flip in the open funnel and
/// the same sliver, the wider face none. The narrower, longer face is the hardest: under the
/// lower lip two 1.5 mm-high triangles, which the truth's jaw-open folds nearly flat, turn over
/// (the inner rim lags the lip's front); in the smile one cheek edge stretches 2.01× (2.04×
/// unmasked). Its surprise turned two triangles over at the outer end of the right brow, where
/// the anchoring that holds the temple met the brow marker's pull (the truth lifts that skin
/// 5.7 mm, the rig held it at 0.2 mm beside 7.4 mm), until the anchoring rose linearly
/// (`surface::anchoring::HULL_RISE`); a wider smoothstep (1.0 spacings) had moved the static
/// skin 0.48–0.80 mm and kept them. The skin means pinned since the upper lip's markers let go
/// of the skin past the lip (`surface::let_go`, 2026-12-05): FaceCap / wider / narrower /
/// heavier jaw 0.5427 / 0.5511 / 0.5746 / 0.5571 → 0.5193 / 0.5272 / 0.5557 / 0.5335 mm; since
/// the cheeks' anchoring rises three times as far across (`surface::anchoring::ACROSS_RISE`,
/// 2026-12-05) 0.5137 / 0.5223 / 0.5492 / 0.5284 mm; since the lower lip hands its depth to the
/// jaw (`surface::let_go::lower_lip_depth`, 2026-12-05) 0.5072 / 0.5174 / 0.5425 / 0.5223 mm.
#[test]
fn other_proportions_bake_as_well_as_facecap() {
    let faces: [(&str, HeadMap, Pinned, f64); 4] = [
        (
            "FaceCap",
            unwarped,
            facebake_tests::DEFAULT_ON_TRUTH,
            0.5072,
        ),
        (
            "wider and shorter",
            wide,
            Pinned {
                drift_mm: 0.32,
                lips_mm: 6.7,
                eyelids_mm: 1.0,
                stretch: 1.83,
                over_2x: 0,
                flipped: 0,
            },
            0.5174,
        ),
        (
            "narrower and longer",
            long,
            Pinned {
                drift_mm: 0.37,
                lips_mm: 8.2,
                eyelids_mm: 1.0,
                stretch: 2.01,
                over_2x: 1,
                flipped: 2,
            },
            0.5425,
        ),
        (
            "a heavier jaw",
            jaw,
            Pinned {
                drift_mm: 0.34,
                lips_mm: 6.8,
                eyelids_mm: 0.9,
                stretch: 1.84,
                over_2x: 0,
                flipped: 1,
            },
            0.5223,
        ),
    ];
    for (label, map, pinned, mean_mm) in faces {
        let (t, mean) = truth_take(map);
        guard(label, &t, &pinned);
        println!("{label}: skin mean {mean:.4} mm");
        // The bars these faces meet.
        assert!(t.static_drift_mm.0 <= 0.5, "{label}: {t}");
        assert!(t.eyelids_mm.unwrap().0 <= 1.5, "{label}: {t}");
        assert!(mean <= (mean_mm + 0.002).min(0.6), "{label}: {mean}");
    }
}

/// JawMoCap through `bake --capture`'s default rig of the warped head (retargeted onto it by
/// the capture stages), every frame measured on that head against its rest (no truth).
fn jawmocap_take(map: HeadMap) -> TakeMetrics {
    let upright = facecap();
    let warp = Warp::of(&upright, map);
    let mesh = warp.mesh(&upright);
    let placed = placed_on(&warp, &mesh);
    jawmocap_take_on(&mesh, &placed)
}

/// JawMoCap through `bake --capture`'s default rig of `mesh` with the markers `placed`, every
/// frame measured against rest.
fn jawmocap_take_on(mesh: &FaceMesh, placed: &[facebake::model::PlacedMarker]) -> TakeMetrics {
    let capture =
        facebake::io::capture::read_capture(&fixture("JawMoCap.trc")).expect("capture reads");
    let mut scene = facebake::Scene::placed(mesh, placed);
    scene.capture = Some(&capture);
    let baked = facebake::bake(&scene, &BakeOptions::product_default()).expect("bakes");
    let rig = facebake_runtime::Rig::from_bytes(&baked.blob).expect("loads");
    let frames = facebake_tests::frames_in_order(&capture, placed.iter().map(|m| m.name.as_str()));
    let played = facebake_tests::play_take(&rig, &frames).0;
    let regions = Regions::for_mesh(mesh, &[], &[]).expect("regions");
    regions.measure_take(&played, None, false).1
}

/// Measured 2026-12-02, masked (the default): every face holds the static skin within 0.1 mm
/// (0.01 / 0.08 / 0.00 / 0.01 mm since the lowered head markers joined the anchoring's hull,
/// 2026-12-04, `surface::anchoring::hull_markers`; 0.00 mm while the hull left them out; 0.37 /
/// 0.49 / 0.28 / 0.37 mm with them in it unlowered) and opens the mouth by its own proportions (37.5 to
/// 46.1 mm). The narrower, longer face stretches the lower lip beside its right corner 2.17×
/// in 107 of 1590 frames (2.12× in 104 before the still head markers shared one of the K
/// weights, `surface::anchoring::merge_held`; 2.18× in 110 before the mouth's corrections faded in linearly,
/// `surface::corners::FADE_IN`; 2.16× in 108 unmasked), with one flip: there the skin's weights pass from the corner's marker
/// (`Mouth_Rend`, 12 mm down in the jaw-open) to the lower lip's (`Mouth_DownR`, 30 mm) within
/// a few millimetres, so the lip between them must stretch about as much as their relative
/// motion over their distance, and this face's narrower mouth puts them closer for a wider
/// opening. On FaceCap the same skin reaches 1.90× (1.96× unmasked). Unmasked, the wider face
/// and the heavier jaw reach 1.77× and 1.80× (now 1.80× and 1.84×).
#[test]
fn jawmocap_plays_on_other_proportions() {
    let faces: [(&str, HeadMap, Pinned); 4] = [
        ("FaceCap", unwarped, facebake_tests::DEFAULT_ON_JAWMOCAP),
        (
            "wider and shorter",
            wide,
            Pinned {
                drift_mm: 0.08,
                lips_mm: 37.5,
                eyelids_mm: 10.8,
                stretch: 1.80,
                over_2x: 0,
                flipped: 0,
            },
        ),
        (
            "narrower and longer",
            long,
            Pinned {
                drift_mm: 0.0,
                lips_mm: 46.1,
                eyelids_mm: 13.4,
                stretch: 2.17,
                over_2x: 3,
                flipped: 1,
            },
        ),
        (
            "a heavier jaw",
            jaw,
            Pinned {
                drift_mm: 0.0,
                lips_mm: 41.0,
                eyelids_mm: 11.9,
                stretch: 1.84,
                over_2x: 0,
                flipped: 0,
            },
        ),
    ];
    for (label, map, pinned) in faces {
        let t = jawmocap_take(map);
        guard(&format!("JawMoCap on {label}"), &t, &pinned);
        // Without a truth the apertures are the widest: the mouth must open, the eyes stay open.
        assert!(t.lips_mm.unwrap().0 > 0.85 * pinned.lips_mm, "{label}: {t}");
        assert!(
            t.eyelids_mm.unwrap().0 > 0.9 * pinned.eyelids_mm,
            "{label}: {t}"
        );
        assert!(t.static_drift_mm.0 <= 0.1, "{label}: {t}");
    }
}

/// Each face's truth played as a capture ([`truth_as_capture`]: the head fitted to the
/// forehead markers and the inner eye corners), scored against the truth. Its frames are the
/// truth's expressions one after the other, not a continuous take: the head refit weighs each
/// marker by its displacement in the last frame and half its motion since together, and the
/// motion leaves out what jumped (weighed by the last displacement alone, FaceCap's skin mean
/// was 1.24 mm; with the whole motion, 0.546, but the rehearsals lost 0.016–0.025 mm and
/// JawMoCap's jitter passed more). Measured 2026-12-04 with the refit: skin mean / forehead
/// mean FaceCap 0.569 / 0.315, wider 0.576 / 0.286, longer 0.602 / 0.346, heavier jaw 0.583 /
/// 0.313, eyelids within 1.0 mm. Before
/// the refit: static drift within 0.03 mm on every face; skin mean / forehead mean FaceCap 0.545 / 0.275
/// mm, wider 0.554 / 0.246, longer 0.577 / 0.309, heavier jaw 0.559 / 0.274; the wider face's
/// eyelids 1.0 mm off, the longer's stretch 1.96× (before the held head markers shared one of
/// the K weights, `surface::anchoring::merge_held`: wider 0.553 / 0.245 and 0.8 mm, longer
/// 0.578 / 0.308 and 2.01× with an edge over 2×; before the lid
/// markers let go of the skin past the lids, `surface::lids`: 0.546 / 0.325, 0.553 / 0.273,
/// 0.577 / 0.357, 0.560 / 0.324; with the head
/// markers left out of the anchoring's hull, until 2026-12-04: 0.550 / 0.313, 0.558 / 0.259,
/// 0.582 / 0.345, 0.564 / 0.312; with the forehead's
/// three markers alone, which the truth moves in the frown and the surprise and the fit took
/// for the head's motion: 0.678 / 0.343, 0.657 / 0.278, 0.733 / 0.383, 0.693 / 0.342); the rest
/// as each face's own bake without a capture. Measured 2026-12-05 (session 12) with the anchored
/// skin following the mean of three head markers as without a capture
/// (`surface::anchoring::followed`) instead of the held markers' summed weights: skin mean
/// FaceCap 0.5685 → 0.5673 mm, wider 0.5756 → 0.5743, longer 0.6020 → 0.6008, heavier jaw
/// 0.5826 → 0.5815; the longer face's smile stretches one
/// edge 2.01× (1.96× before), as before the summed weights.
#[test]
fn the_truth_through_the_capture_stages() {
    let pin = |lips_mm, eyelids_mm, stretch, over_2x, flipped| Pinned {
        drift_mm: 0.0,
        lips_mm,
        eyelids_mm,
        stretch,
        over_2x,
        flipped,
    };
    let faces: [(&str, HeadMap, Pinned, [f64; 2]); 4] = [
        (
            "FaceCap",
            unwarped,
            pin(7.1, 1.0, 1.89, 0, 1),
            [0.5685, 0.3146],
        ),
        (
            "wider and shorter",
            wide,
            pin(6.7, 1.0, 1.83, 0, 0),
            [0.5756, 0.2861],
        ),
        (
            "narrower and longer",
            long,
            pin(8.2, 1.0, 2.01, 1, 2),
            [0.6020, 0.3464],
        ),
        (
            "a heavier jaw",
            jaw,
            pin(6.8, 0.9, 1.84, 0, 1),
            [0.5826, 0.3131],
        ),
    ];
    for (label, map, pinned, [skin_mm, forehead_mm]) in faces {
        let (take, skin, forehead) = truth_as_capture(map);
        guard(&format!("{label}, the truth as a capture"), &take, &pinned);
        println!("{label}: skin mean {skin:.4} mm, forehead mean {forehead:.4} mm");
        assert!(take.static_drift_mm.0 <= 0.05, "{label}: {take}");
        assert!(skin <= skin_mm + 0.002, "{label}: {skin}");
        assert!(forehead <= forehead_mm + 0.002, "{label}: {forehead}");
    }
}

/// `facebake place` on each face: JawMoCap's 41 markers placed automatically (landmarks from
/// the face's openings and nose, the rest warped from the actor through them, the lip and
/// eyelid markers on the lips and lids), against the bundled layout warped with the face, and
/// the default bake on them. Measured 2026-12-02: FaceCap's placement is the bundled layout;
/// on the other faces the markers land 1.3–3.2 mm from the warped ones on average, at most
/// 5.4–11.8 mm (the heavier jaw's chin: no landmark tells the warp the jaw is heavier). The
/// bake meets the eyelid bar on each (the wider face's blink 0.8 mm off since its lid markers
/// go on the lids' first vertex row, `placement::LID_OFF_RIM_COST`; 1.5 mm on the second) and
/// the static one but on the wider face (and plays JawMoCap through `bake --capture` on the
/// placed markers as on the warped ones: the skull still, 1.74–1.92×, the narrower face's lower
/// lip 2.18× as there): its placed `ForeHead_R`, 1 mm lower than the warped one, pulls the
/// skin 5 mm above it 0.54 mm in the frown (0.32 mm with the warped layout, where the worst is
/// the back of the head following the anchors' mean).
#[test]
fn placement_finds_the_markers_on_other_faces() {
    let (capture, neutral) = facebake_tests::jawmocap_neutral();
    let upright = facecap();
    // Per face: the placed markers' mean and largest distance from the warped layout's (mm),
    // and the default bake's figures on the truth and on JawMoCap.
    let faces: [(&str, HeadMap, f64, f64, Pinned, Pinned); 4] = [
        (
            "FaceCap",
            unwarped,
            0.0,
            0.0,
            facebake_tests::DEFAULT_ON_TRUTH,
            facebake_tests::DEFAULT_ON_JAWMOCAP,
        ),
        (
            "wider and shorter",
            wide,
            1.4,
            5.4,
            Pinned {
                drift_mm: 0.36,
                lips_mm: 6.5,
                eyelids_mm: 1.0,
                stretch: 1.83,
                over_2x: 0,
                flipped: 0,
            },
            Pinned {
                drift_mm: 0.05,
                lips_mm: 37.5,
                eyelids_mm: 10.8,
                stretch: 1.74,
                over_2x: 0,
                flipped: 0,
            },
        ),
        (
            "narrower and longer",
            long,
            1.3,
            6.3,
            Pinned {
                drift_mm: 0.37,
                lips_mm: 8.2,
                eyelids_mm: 1.0,
                stretch: 1.95,
                over_2x: 0,
                flipped: 2,
            },
            // As with the warped layout: the lower lip beside the right corner stretches
            // (see `jawmocap_plays_on_other_proportions`).
            Pinned {
                drift_mm: 0.0,
                lips_mm: 46.3,
                eyelids_mm: 13.5,
                stretch: 2.17,
                over_2x: 3,
                flipped: 1,
            },
        ),
        (
            "a heavier jaw",
            jaw,
            3.2,
            11.8,
            Pinned {
                drift_mm: 0.35,
                lips_mm: 6.8,
                eyelids_mm: 0.9,
                stretch: 1.85,
                over_2x: 0,
                flipped: 1,
            },
            Pinned {
                drift_mm: 0.0,
                lips_mm: 38.6,
                eyelids_mm: 11.8,
                stretch: 1.87,
                over_2x: 0,
                flipped: 0,
            },
        ),
    ];
    for (label, map, mean_mm, worst_mm, pinned, on_jawmocap) in faces {
        let warp = Warp::of(&upright, map);
        let truth = GroundTruth::new(warp.mesh(&upright), FACECAP_MARKERS, 6).expect("truth");
        let placed = auto_placed(&truth.mesh, &capture.marker_names, &neutral, &[]);
        let warped = placed_on(&warp, &truth.mesh);
        let off: Vec<(f64, &str)> = placed
            .iter()
            .zip(&warped)
            .map(|(a, b)| {
                assert_eq!(a.name, b.name);
                let d = facebake::mesh::distance(&a.position, &b.position);
                (d * 1000.0, a.name.as_str())
            })
            .collect();
        let worst = off
            .iter()
            .copied()
            .fold((0.0, ""), |a, b| if b.0 > a.0 { b } else { a });
        let mean = off.iter().map(|o| o.0).sum::<f64>() / off.len() as f64;
        println!(
            "{label}: placed markers {mean:.1} mm from the warped layout on average, at most \
             {:.1} mm ({})",
            worst.0, worst.1
        );
        assert!(
            mean <= mean_mm + 0.05 && worst.0 <= worst_mm + 0.05,
            "{label}: mean {mean:.2} mm, {worst:?}"
        );
        let jawmocap = jawmocap_take_on(&truth.mesh, &placed);
        guard(
            &format!("JawMoCap on {label}, placed"),
            &jawmocap,
            &on_jawmocap,
        );
        assert!(jawmocap.static_drift_mm.0 <= 0.5, "{label}: {jawmocap}");
        let scene = Benchmark::new(truth, &placed, Vec::new(), 0).expect("scene");
        let baked = bake_scene(&scene, &BakeOptions::product_default());
        let (t, skin, _) = scored(&scene, &scene.play(&baked.blob));
        guard(&format!("{label}, placed"), &t, &pinned);
        println!("{label}, placed: skin mean {skin:.4} mm");
        assert!(t.eyelids_mm.unwrap().0 <= 1.5, "{label}: {t}");
        assert!(skin <= 0.6, "{label}: {skin}");
    }
}

/// What no landmark sees, a pin gives: on the heavier-jawed face the chin's markers land 6.0–11.8
/// mm from the warped layout's; with `Chin` pinned to the vertex under the warped layout's (`place
/// --pin Chin=V`), which also anchors the warp, every chin marker is within 6.5 mm and `Chin`
/// itself within the vertex spacing (measured 2026-12-02: 2.0 mm; the others 5.1–6.2).
#[test]
fn a_pinned_chin_brings_the_chin_markers_onto_a_heavier_jaw() {
    let (capture, neutral) = facebake_tests::jawmocap_neutral();
    let upright = facecap();
    let warp = Warp::of(&upright, jaw);
    let mesh = warp.mesh(&upright);
    let warped = placed_on(&warp, &mesh);
    let chin = warped
        .iter()
        .find(|m| m.name == "Chin")
        .expect("Chin")
        .position;
    let nearest = (0..mesh.positions.len())
        .min_by(|&a, &b| {
            let d = |v: usize| facebake::mesh::distance(&mesh.positions[v], &chin);
            d(a).total_cmp(&d(b))
        })
        .expect("vertices");
    let chin_errors = |pins: &[(String, u32)]| -> Vec<(String, f64)> {
        let placed = auto_placed(&mesh, &capture.marker_names, &neutral, pins);
        placed
            .iter()
            .zip(&warped)
            .filter(|(a, _)| a.name.starts_with("Chin"))
            .map(|(a, b)| {
                let d = facebake::mesh::distance(&a.position, &b.position) * 1000.0;
                (a.name.clone(), d)
            })
            .collect()
    };
    let free = chin_errors(&[]);
    let pinned = chin_errors(&[("Chin".to_string(), nearest as u32)]);
    println!("chin markers from the warped layout: free {free:?}, Chin pinned {pinned:?}");
    assert!(free.iter().any(|(_, d)| *d > 8.0), "{free:?}");
    assert!(pinned.iter().all(|(_, d)| *d < 6.5), "{pinned:?}");
    assert!(pinned
        .iter()
        .find(|(n, _)| n == "Chin")
        .is_some_and(|(_, d)| *d < 3.0));
}

/// What a held-out set may bring at once, on another face: JawMoCap's markers placed by
/// `facebake place` on each warped face, the take with ±0.5 mm jitter on every coordinate, the
/// head turning (up to 20°) and moving (up to 3 cm), and 5 % of its samples dropped; the
/// default rig baked from that take (`bake --capture`) plays it. Each face holds its static skin
/// within 0.05 mm, stretches and flips no more than the clean take on the warped layout does
/// (`jawmocap_plays_on_other_proportions`: the narrower face's lower lip 2.18× and one flip)
/// and stays within 1 mm (p99) of the clean take played through the same rig. Measured
/// 2026-12-03 with the markers' filter tuned against the truth (lighter: it lets more jitter
/// through and lags less), face vs clean p99 / max and stretch: FaceCap 0.76 / 2.20 mm, 1.92×;
/// wider 0.80 / 2.16, 1.77×; narrower 0.78 / 2.41, 2.15× (one flip, as the clean take); heavier
/// jaw 0.76 / 1.97, 1.90×. Measured 2026-12-02 with the filter before: FaceCap 0.51 / 1.30 mm,
/// 1.91×; wider 0.53 / 1.23, 1.76×; narrower 0.53 / 1.47, 2.17×; heavier jaw 0.49 / 1.11, 1.88×.
#[test]
fn a_noisy_moving_take_with_dropouts_plays_on_other_faces() {
    let (capture, neutral) = facebake_tests::jawmocap_neutral();
    let noisy =
        facebake_tests::moved_and_dropped(&facebake_tests::jittered(&capture, 0.0005), 0.05, false);
    let clean = facebake_tests::moved_and_dropped(&capture.in_metres(), 0.0, false);
    let upright = facecap();
    for (label, map, stretch, flips) in [
        ("FaceCap", unwarped as HeadMap, 1.92, 0),
        ("wider and shorter", wide, 1.80, 0),
        ("narrower and longer", long, 2.18, 1),
        ("a heavier jaw", jaw, 1.90, 0),
    ] {
        let mesh = Warp::of(&upright, map).mesh(&upright);
        let placed = auto_placed(&mesh, &capture.marker_names, &neutral, &[]);
        let mut scene = facebake::Scene::placed(&mesh, &placed);
        scene.capture = Some(&noisy);
        let baked = facebake::bake(&scene, &BakeOptions::product_default()).expect("bakes");
        let rig = facebake_runtime::Rig::from_bytes(&baked.blob).expect("loads");
        let names = || placed.iter().map(|m| m.name.as_str());
        let played =
            facebake_tests::play_take(&rig, &facebake_tests::frames_in_order(&noisy, names())).0;
        let reference =
            facebake_tests::play_take(&rig, &facebake_tests::frames_in_order(&clean, names())).0;
        let regions = Regions::for_mesh(&mesh, &[], &[]).expect("regions");
        let (_, worst) = regions.measure_take(&played, None, false);
        // Past the smoothing's start-up (the first frame's jitter passes a causal filter).
        let mut errors: Vec<f64> = played[20..]
            .iter()
            .zip(&reference[20..])
            .flat_map(|(a, b)| a.iter().zip(b).map(|(p, q)| facebake::mesh::distance(p, q)))
            .collect();
        errors.sort_by(f64::total_cmp);
        let p99 = 1000.0 * errors[errors.len() * 99 / 100];
        let max = 1000.0 * errors.last().copied().unwrap_or(0.0);
        println!("{label}, noisy moving take with dropouts: face vs clean p99 {p99:.2} max {max:.2} mm; {worst}");
        assert!(worst.static_drift_mm.0 <= 0.05, "{label}: {worst}");
        assert!(worst.flipped.0 <= flips, "{label}: {worst}");
        assert!(worst.max_stretch.0 <= 1.01 * stretch, "{label}: {worst}");
        assert!(p99 <= 1.0, "{label}: p99 {p99}");
    }
}
