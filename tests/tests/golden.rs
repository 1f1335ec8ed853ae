//! The golden data in `fixtures/golden/`, re-derived from the baker and compared byte for byte.
//!
//! The cross-architecture test (`runtime/tests/golden.rs`) and the Cortex-M4 firmware
//! (`firmware/`) check the runtime against these files without the baker, so the files must be
//! exactly what the baker and the host runtime produce today. This test re-bakes the FaceCap
//! rigs (twice, to check the bake is deterministic), re-derives the marker sequences, re-computes
//! every frame's hash and fails on any difference. `FACEBAKE_BLESS=1` rewrites the files instead.
//!
//! | file | contents |
//! |---|---|
//! | `facecap_product.fbk` | what `facebake bake` makes with no options from FaceCap and the bundled layout (41 markers, its groups): geodesic, masked, the linear deformer with its derived markers (the mouth's projections, the followed markers' mean) |
//! | `facecap_layout_markers.bin` | frames × 41 markers × 3 `i32` LE, Q8.24: the same frames as `facecap_markers.bin`, through the layout's markers |
//! | `facecap_coefficients.fbk` | the papers' bare Euclidean RBF ([`BakeOptions::default`]: coefficients, Gaussian, K = 8) |
//! | `facecap_weights.fbk` | the weights bake (IMQ, K = 8) |
//! | `facecap_coefficients_k4.fbk` | the bare RBF at K = 4, so per-frame cost can be split into per-vertex and per-influence parts |
//! | `facecap_planar.fbk` | the planar-bones bake (K = 8, automatic control surface) |
//! | `facecap_markers.bin` | frames × 40 markers × 3 `i32` LE, Q8.24: every ground-truth frame, then [`EDGE_FRAMES`] |
//! | `jawmocap_capture.fbk` | FaceCap with the JawMoCap layout (41 markers) and the capture stages baked from JawMoCap (head markers [`JAWMOCAP_HEAD_MARKERS`], the markers smoothed) |
//! | `jawmocap_actor.bin` | frames × 41 markers × (`u8` present, 3 × `i32` LE Q8.24 actor units): every 20th JawMoCap frame with markers knocked out, then [`CAPTURE_EDGE_FRAMES`] |
//! | `hashes.txt` | per rig: FNV-1a-64 of each frame's output (`i32` LE, x y z per vertex), then of the whole sequence; for `capture`, of the character markers, the vertices and (residual, rebuilt, held) |
//! | `hashes_planar.txt` | the same for the planar-bones rig, kept apart because the Cortex-M4 firmware does not play it yet (its per-frame instruction count is not constant: docs/design.md, "Planar bones") |
//! | `hashes_normals.txt` | per rig (the planar one and `capture` included), FNV-1a-64 of each frame's unit normals from `Rig::normals` (`i16` LE, x y z per vertex), then of the whole sequence |

use std::fmt::Write as _;

use facebake::demo::JAWMOCAP_HEAD_MARKERS;
use facebake::stages::temporal::SmoothingConfig;
use facebake::stages::{HeadMarkers, SmoothingUse, StagesConfig};
use facebake::surface::evaluate::Benchmark;
use facebake::{BakeOptions, Baked};
use facebake_runtime::checksum::Fnv1a64;
use facebake_runtime::fixed::POS_ONE;
use facebake_runtime::PlayState;
use facebake_runtime::Rig;
use facebake_tests::{
    bake_scene, bake_truth, bless_or_check, facecap_default, facecap_planar, facecap_weights,
    jawmocap_rig, layout_benchmark, planar_config, weights_config, JawMoCapRig, FACECAP_MARKERS,
};

/// Markers a frame in `facecap_layout_markers.bin`: the bundled layout's.
const LAYOUT_MARKERS: usize = 41;

/// The product default: FaceCap and the bundled layout (its 41 markers and groups) baked as
/// `facebake bake --mesh FaceCapHeadGeneric.glb --layout facecap_jawmocap_layout.toml` bakes
/// ([`BakeOptions::product_default`]), with the scene that places the layout, built once.
fn product() -> &'static (Benchmark, Baked) {
    static CELL: std::sync::OnceLock<(Benchmark, Baked)> = std::sync::OnceLock::new();
    CELL.get_or_init(|| {
        let scene = layout_benchmark(true);
        let baked = bake_scene(&scene, &BakeOptions::product_default());
        (scene, baked)
    })
}

/// The capture edge frames appended after the JawMoCap frames, in order.
const CAPTURE_EDGE_FRAMES: [&str; 7] = [
    "every marker missing",
    "every head marker missing (the last fit is held)",
    "the last frame turned 90 degrees about the vertical and moved 1 m",
    "turned 5 degrees more, one head marker present (the pose tracked)",
    "one head marker 10 cm off (dropped from the fit), one marker 20 cm off (rejected)",
    "a coordinate at i32::MAX (rejected as out of range)",
    "every coordinate at +/- 60 actor units",
];

/// The capture rig, built once per test binary. The markers' smoothing is on (the default
/// bake leaves JawMoCap, a clean take, unsmoothed), so that the filter's fixed point is held
/// bit-identical on every platform and its cost is in the firmware's budget frame.
fn capture_rig() -> &'static JawMoCapRig {
    static CELL: std::sync::OnceLock<JawMoCapRig> = std::sync::OnceLock::new();
    CELL.get_or_init(|| {
        jawmocap_rig(&StagesConfig {
            head: HeadMarkers::Named(JAWMOCAP_HEAD_MARKERS.map(str::to_string).to_vec()),
            smoothing: SmoothingUse::On(SmoothingConfig::default()),
            ..StagesConfig::default()
        })
    })
}

/// The actor frames of the capture golden (Q8.24 actor units, `None` = missing).
fn actor_frames(j: &JawMoCapRig) -> Vec<Vec<Option<[i32; 3]>>> {
    let rig = Rig::from_bytes(&j.baked.blob).unwrap();
    let stages = rig.stages().unwrap();
    let space = stages.actor_space;
    let head: Vec<usize> = stages
        .head_markers()
        .iter()
        .map(|&h| usize::from(h))
        .collect();
    let to_q = |p: &[f64; 3]| space.to_rig_f64(*p).expect("capture fits actor units");
    let mut frames: Vec<Vec<Option<[i32; 3]>>> = j
        .frames
        .iter()
        .step_by(20)
        .enumerate()
        .map(|(i, f)| {
            f.iter()
                .enumerate()
                .map(|(m, p)| {
                    // Every third frame loses a few markers (a different few each time).
                    let knocked = i % 3 == 2 && (m + i) % 6 == 0;
                    if knocked {
                        None
                    } else {
                        p.as_ref().map(to_q)
                    }
                })
                .collect()
        })
        .collect();
    let last: Vec<[f64; 3]> = j
        .frames
        .last()
        .unwrap()
        .iter()
        .map(|p| p.unwrap())
        .collect();
    let n = last.len();
    let mut edge = Vec::new();
    edge.push(vec![None; n]);
    edge.push(
        (0..n)
            .map(|m| {
                if head.contains(&m) {
                    None
                } else {
                    Some(to_q(&last[m]))
                }
            })
            .collect(),
    );
    // The last frame turned `degrees` about the vertical and moved 1 m.
    let turned = |p: &[f64; 3], degrees: f64| {
        let (sin, cos) = degrees.to_radians().sin_cos();
        [
            p[0] * cos + p[2] * sin + 1.0,
            p[1],
            -p[0] * sin + p[2] * cos,
        ]
    };
    edge.push(last.iter().map(|p| Some(to_q(&turned(p, 90.0)))).collect());
    edge.push(
        last.iter()
            .enumerate()
            .map(|(m, p)| (!head[1..].contains(&m)).then(|| to_q(&turned(p, 95.0))))
            .collect(),
    );
    edge.push(
        last.iter()
            .enumerate()
            .map(|(m, p)| {
                let off = if m == head[0] {
                    0.1
                } else if m == n - 1 {
                    0.2
                } else {
                    0.0
                };
                Some(to_q(&[p[0] + off, p[1], p[2]]))
            })
            .collect(),
    );
    edge.push(
        last.iter()
            .enumerate()
            .map(|(m, p)| {
                let mut q = to_q(p);
                if m == 5 {
                    q[1] = i32::MAX;
                }
                Some(q)
            })
            .collect(),
    );
    edge.push(
        (0..n)
            .map(|m| {
                Some([0, 1, 2].map(|c| {
                    if (m + c) % 2 == 0 {
                        60 << 24
                    } else {
                        -(60 << 24)
                    }
                }))
            })
            .collect(),
    );
    assert_eq!(edge.len(), CAPTURE_EDGE_FRAMES.len());
    frames.extend(edge);
    frames
}

/// `jawmocap_actor.bin`: per frame and marker a presence byte and three `i32` LE.
fn actor_bytes(frames: &[Vec<Option<[i32; 3]>>]) -> Vec<u8> {
    let mut out = Vec::new();
    for p in frames.iter().flatten() {
        out.push(u8::from(p.is_some()));
        for c in p.unwrap_or([0; 3]) {
            out.extend_from_slice(&c.to_le_bytes());
        }
    }
    out
}

/// The `capture` lines of `hashes.txt`.
fn capture_hashes(blob: &[u8], frames: &[Vec<Option<[i32; 3]>>]) -> String {
    let rig = Rig::from_bytes(blob).expect("capture rig loads");
    let stages = rig.stages().expect("capture stages");
    let mut s = String::new();
    writeln!(
        s,
        "# capture: JawMoCap frames 0, 20, 40, ... with markers knocked out, then:"
    )
    .unwrap();
    for (i, name) in CAPTURE_EDGE_FRAMES.iter().enumerate() {
        writeln!(
            s,
            "#   {:2} {name}",
            frames.len() - CAPTURE_EDGE_FRAMES.len() + i
        )
        .unwrap();
    }
    writeln!(s, "# capture stages per frame: {:?}", stages.cost()).unwrap();
    let mut state = PlayState::new();
    let mut markers = vec![[0i32; 3]; rig.marker_count()];
    let mut out = vec![[0i32; 3]; rig.vertex_count()];
    let mut sequence = Fnv1a64::new();
    for (f, actor) in frames.iter().enumerate() {
        let report = stages.solve(&mut state, actor, &mut markers);
        rig.deform(&markers, &mut out).unwrap();
        let mut h = Fnv1a64::new();
        h.write_capture_frame(&markers, &out, &report);
        sequence.write_capture_frame(&markers, &out, &report);
        writeln!(s, "capture frame {f} {:016x}", h.finish()).unwrap();
    }
    writeln!(s, "capture sequence {:016x}", sequence.finish()).unwrap();
    s
}

/// The edge frames appended after the ground-truth frames, in order.
const EDGE_FRAMES: [&str; 7] = [
    "rest pose",
    "every coordinate i32::MAX",
    "every coordinate i32::MIN",
    "rest + 120 rig units on every coordinate",
    "rest - 120 rig units on every coordinate",
    "rest +/- 120 rig units, sign alternating by marker and axis",
    "i32::MAX / i32::MIN alternating by marker and axis",
];

/// The default configuration at K = 4.
fn k4_config() -> BakeOptions {
    BakeOptions {
        k: 4,
        ..BakeOptions::default()
    }
}

/// The default bake at K = 4, built once per test binary.
fn facecap_k4() -> &'static Baked {
    static CELL: std::sync::OnceLock<Baked> = std::sync::OnceLock::new();
    CELL.get_or_init(|| bake_truth(&facecap_default().0, &k4_config()))
}

/// The edge frames for markers at `rest` (Q8.24), one `Vec` per frame.
fn edge_frames(rest: &[[i32; 3]]) -> Vec<Vec<[i32; 3]>> {
    let big = 120 * POS_ONE;
    let alternate = |i: usize, c: usize| (i + c) % 2 == 0;
    let shifted = |f: &dyn Fn(usize, usize) -> i32| -> Vec<[i32; 3]> {
        rest.iter()
            .enumerate()
            .map(|(i, r)| [0, 1, 2].map(|c| r[c].saturating_add(f(i, c))))
            .collect()
    };
    let everywhere = |f: &dyn Fn(usize, usize) -> i32| -> Vec<[i32; 3]> {
        (0..rest.len())
            .map(|i| [0, 1, 2].map(|c| f(i, c)))
            .collect()
    };
    let frames = vec![
        rest.to_vec(),
        everywhere(&|_, _| i32::MAX),
        everywhere(&|_, _| i32::MIN),
        shifted(&|_, _| big),
        shifted(&|_, _| -big),
        shifted(&|i, c| if alternate(i, c) { big } else { -big }),
        everywhere(&|i, c| if alternate(i, c) { i32::MAX } else { i32::MIN }),
    ];
    assert_eq!(frames.len(), EDGE_FRAMES.len());
    frames
}

/// Every frame's markers in Q8.24: the ground-truth sequence through `markers_of` (a frame's
/// mesh positions to its markers), then the edge frames about `rig`'s rest markers.
fn marker_frames(
    rig: &Rig<'_>,
    markers_of: impl Fn(&[[f64; 3]]) -> Vec<[f64; 3]>,
) -> Vec<Vec<[i32; 3]>> {
    let (truth, _) = facecap_default();
    let space = rig.space();
    let mut frames: Vec<Vec<[i32; 3]>> = (0..truth.frames.len())
        .map(|f| {
            markers_of(&truth.positions(f))
                .iter()
                .map(|p| space.to_rig_f64(*p).expect("markers fit rig units"))
                .collect()
        })
        .collect();
    let rest: Vec<[i32; 3]> = (0..rig.marker_count())
        .map(|i| rig.marker_rest(i).unwrap())
        .collect();
    frames.extend(edge_frames(&rest));
    frames
}

/// A marker file: frames × markers × 3 `i32` LE.
fn marker_bytes(frames: &[Vec<[i32; 3]>]) -> Vec<u8> {
    frames
        .iter()
        .flatten()
        .flatten()
        .flat_map(|c| c.to_le_bytes())
        .collect()
}

/// A golden rig: its name in the hash files, its blob and the marker frames it plays.
type Golden<'a> = (&'a str, &'a [u8], &'a [Vec<[i32; 3]>]);

/// `hashes.txt` for the rigs played through their frames.
fn hashes_txt(rigs: &[Golden<'_>]) -> String {
    let (truth, _) = facecap_default();
    let mut s = String::from(
        "# facebake golden hashes: FNV-1a-64 of each frame's deformed vertex buffer, hashed as i32\n\
         # little-endian (x y z per vertex), then of all frames' buffers in sequence.\n\
         # Generated by tests/tests/golden.rs (FACEBAKE_BLESS=1); checked by runtime/tests/golden.rs\n\
         # on every architecture and by the Cortex-M4 firmware. Frames (facecap_markers.bin, and\n\
         # facecap_layout_markers.bin for `product`):\n",
    );
    let names = truth
        .frames
        .iter()
        .map(|f| f.name.as_str())
        .chain(EDGE_FRAMES);
    for (i, name) in names.enumerate() {
        writeln!(s, "#   {i:2} {name}").unwrap();
    }
    for &(name, blob, frames) in rigs {
        let rig = Rig::from_bytes(blob).expect("golden rig loads");
        let mut out = vec![[0i32; 3]; rig.vertex_count()];
        let mut sequence = Fnv1a64::new();
        writeln!(s, "# {name}: {}", rig.cost()).unwrap();
        for (f, markers) in frames.iter().enumerate() {
            rig.deform(markers, &mut out).unwrap();
            let mut frame = Fnv1a64::new();
            frame.write_positions(&out);
            sequence.write_positions(&out);
            writeln!(s, "{name} frame {f} {:016x}", frame.finish()).unwrap();
        }
        writeln!(s, "{name} sequence {:016x}", sequence.finish()).unwrap();
    }
    s
}

/// `hashes_normals.txt`: the normals of every frame of every rig, played as in `hashes.txt`
/// (the capture rig through `actor`).
fn normals_txt(rigs: &[Golden<'_>], capture: &[u8], actor: &[Vec<Option<[i32; 3]>>]) -> String {
    let mut s = String::from(
        "# facebake golden normals: FNV-1a-64 of each frame's unit normals from Rig::normals, hashed\n\
         # as i16 little-endian Q1.14 (x y z per vertex), then of all frames' normals in sequence.\n\
         # The frames are those of hashes.txt (and of its capture lines for `capture`).\n\
         # Generated by tests/tests/golden.rs (FACEBAKE_BLESS=1); checked by runtime/tests/golden.rs.\n",
    );
    let mut play =
        |name: &str, rig: &Rig<'_>, positions: &mut dyn FnMut(usize) -> Option<Vec<[i32; 3]>>| {
            let mut normals = vec![[0i16; 3]; rig.vertex_count()];
            let mut sequence = Fnv1a64::new();
            writeln!(s, "# {name}: {}", rig.cost().normals).unwrap();
            let mut f = 0;
            while let Some(out) = positions(f) {
                rig.normals(&out, &mut normals).unwrap();
                let mut frame = Fnv1a64::new();
                frame.write_normals(&normals);
                sequence.write_normals(&normals);
                writeln!(s, "{name} frame {f} {:016x}", frame.finish()).unwrap();
                f += 1;
            }
            writeln!(s, "{name} sequence {:016x}", sequence.finish()).unwrap();
        };
    for &(name, blob, frames) in rigs {
        let rig = Rig::from_bytes(blob).expect("golden rig loads");
        let mut out = vec![[0i32; 3]; rig.vertex_count()];
        play(name, &rig, &mut |f| {
            let markers = frames.get(f)?;
            rig.deform(markers, &mut out).unwrap();
            Some(out.clone())
        });
    }
    let rig = Rig::from_bytes(capture).expect("capture rig loads");
    let stages = rig.stages().expect("capture stages");
    let mut state = PlayState::new();
    let mut markers = vec![[0i32; 3]; rig.marker_count()];
    let mut out = vec![[0i32; 3]; rig.vertex_count()];
    play("capture", &rig, &mut |f| {
        stages.solve(&mut state, actor.get(f)?, &mut markers);
        rig.deform(&markers, &mut out).unwrap();
        Some(out.clone())
    });
    s
}

#[test]
fn bake_is_deterministic() {
    let (truth, baked) = facecap_default();
    let again = bake_truth(truth, &BakeOptions::default());
    assert!(
        again.blob == baked.blob,
        "coefficients bake differs run to run"
    );
    let again = bake_truth(truth, &weights_config());
    assert!(
        again.blob == facecap_weights().blob,
        "weights bake differs run to run"
    );
    let again = bake_truth(truth, &k4_config());
    assert!(
        again.blob == facecap_k4().blob,
        "K = 4 bake differs run to run"
    );
    let again = bake_truth(truth, &planar_config(8));
    assert!(
        again.blob == facecap_planar().blob,
        "planar bake differs run to run"
    );
    let (scene, baked) = product();
    let again = bake_scene(scene, &BakeOptions::product_default());
    assert!(again.blob == baked.blob, "product bake differs run to run");
}

#[test]
fn golden_files_match_the_baker_byte_for_byte() {
    let (truth, baked) = facecap_default();
    let coefficients = baked.blob.as_slice();
    let weights = facecap_weights().blob.as_slice();
    let k4 = facecap_k4().blob.as_slice();
    let planar = facecap_planar().blob.as_slice();
    let (scene, product) = product();
    let rig = Rig::from_bytes(coefficients).unwrap();
    assert_eq!(rig.marker_count(), FACECAP_MARKERS);
    // One marker file drives these rigs: they must agree on the markers and their units.
    for blob in [weights, k4, planar] {
        let other = Rig::from_bytes(blob).unwrap();
        assert_eq!(rig.space(), other.space());
        for i in 0..rig.marker_count() {
            assert_eq!(rig.marker_rest(i), other.marker_rest(i));
        }
    }
    let frames = marker_frames(&rig, |p| truth.markers_of(p));
    let product_rig = Rig::from_bytes(&product.blob).unwrap();
    assert_eq!(product_rig.marker_count(), LAYOUT_MARKERS);
    let layout_frames = marker_frames(&product_rig, |p| scene.markers_of(p));
    let rigs: [Golden<'_>; 4] = [
        ("coefficients", coefficients, &frames),
        ("weights", weights, &frames),
        ("coefficients_k4", k4, &frames),
        ("product", &product.blob, &layout_frames),
    ];
    let capture = capture_rig();
    let actor = actor_frames(capture);
    let hashes = hashes_txt(&rigs) + &capture_hashes(&capture.baked.blob, &actor);
    let normals = normals_txt(
        &[rigs.as_slice(), &[("planar", planar, &frames)]].concat(),
        &capture.baked.blob,
        &actor,
    );
    let files: [(&str, Vec<u8>); 12] = [
        ("facecap_coefficients.fbk", coefficients.to_vec()),
        ("facecap_weights.fbk", weights.to_vec()),
        ("facecap_coefficients_k4.fbk", k4.to_vec()),
        ("facecap_planar.fbk", planar.to_vec()),
        ("facecap_product.fbk", product.blob.clone()),
        ("facecap_markers.bin", marker_bytes(&frames)),
        ("facecap_layout_markers.bin", marker_bytes(&layout_frames)),
        ("jawmocap_capture.fbk", capture.baked.blob.clone()),
        ("jawmocap_actor.bin", actor_bytes(&actor)),
        ("hashes.txt", hashes.into_bytes()),
        (
            "hashes_planar.txt",
            hashes_txt(&[("planar", planar, &frames)]).into_bytes(),
        ),
        ("hashes_normals.txt", normals.into_bytes()),
    ];
    bless_or_check(&files);
}

/// The product rig holds both kinds of derived marker, so the golden hashes pin their
/// arithmetic on every target.
#[test]
fn the_product_rig_derives_projections_and_a_mean() {
    use facebake_runtime::deformer::linear::DerivedMarker;
    use facebake_runtime::deformer::Deformer;
    let rig = Rig::from_bytes(&product().1.blob).unwrap();
    let Deformer::Linear(linear) = rig.deformer() else {
        panic!("the product default is the linear deformer");
    };
    let derived: Vec<DerivedMarker> = linear.derived().collect();
    let projections = derived
        .iter()
        .filter(|d| matches!(d, DerivedMarker::Projection { .. }))
        .count();
    let means = derived
        .iter()
        .filter(|d| matches!(d, DerivedMarker::Mean { .. }))
        .count();
    println!("product rig: {projections} projections, {means} means");
    assert!(projections >= 2 && means == 1, "{derived:?}");
}

#[test]
fn capture_edge_frames_do_what_they_say() {
    use facebake_runtime::{FitFailure, RigidStatus};
    let capture = capture_rig();
    let frames = actor_frames(capture);
    let rig = Rig::from_bytes(&capture.baked.blob).unwrap();
    let stages = rig.stages().unwrap();
    let mut state = PlayState::new();
    let mut markers = vec![[0i32; 3]; rig.marker_count()];
    let mut solved = Vec::new();
    let reports: Vec<_> = frames
        .iter()
        .map(|a| {
            let report = stages.solve(&mut state, a, &mut markers);
            solved.push(markers.clone());
            report
        })
        .collect();
    let edge = &reports[reports.len() - CAPTURE_EDGE_FRAMES.len()..];
    let solved = &solved[solved.len() - CAPTURE_EDGE_FRAMES.len()..];
    let n = rig.marker_count();
    for r in edge {
        println!("{r:?}");
    }
    assert_eq!(edge[0].rigid, RigidStatus::Held(FitFailure::TooFew));
    assert_eq!(
        edge[0].held.len(),
        n,
        "nothing to rebuild from: every marker held"
    );
    // Every marker is missing in the frame before, so nothing was measured in both: held.
    assert_eq!(edge[1].rigid, RigidStatus::Held(FitFailure::TooFew));
    assert_eq!(
        edge[1].rebuilt.len(),
        4,
        "the four head markers rebuilt from neighbours"
    );
    assert!(matches!(
        edge[2].rigid,
        RigidStatus::Fitted { head_markers: 4 }
    ));
    assert!(edge[2].rejected.is_empty() && edge[2].rebuilt.is_empty());
    // Three of the four head markers lost as the head turns on: the pose tracked through the
    // one left and the face's markers, so the face's markers come out where they were (held,
    // the 5° turn would move the chin by several millimetres).
    assert_eq!(edge[3].rigid, RigidStatus::Tracked { head_markers: 1 });
    let moved = solved[3]
        .iter()
        .zip(&solved[2])
        .map(|(a, b)| {
            (0..3)
                .map(|c| (a[c] - b[c]).unsigned_abs())
                .max()
                .unwrap_or(0)
        })
        .max()
        .unwrap_or(0);
    let moved_mm =
        f64::from(moved) / f64::from(1u32 << 24) * f64::from(rig.space().half_extent) * 1000.0;
    println!("tracked frame: markers {moved_mm:.3} mm from the frame before");
    assert!(moved_mm < 1.0, "{moved_mm}");
    assert_eq!(edge[4].head_markers_dropped, 1);
    assert!(matches!(
        edge[4].rigid,
        RigidStatus::Fitted { head_markers: 3 }
    ));
    assert!(edge[4].rejected.contains(n - 1));
    assert!(edge[5].rejected.contains(5) && edge[5].rebuilt.contains(5));
    // Far out of the face: everything rejected, every marker held at its last value.
    assert_eq!(edge[6].held.len() + edge[6].rebuilt.len(), n);
}
