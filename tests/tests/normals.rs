//! `Rig::normals` against the f64 reference ([`facebake::normals::vertex_normals`]) on every
//! frame of the bundled takes, computed from the runtime's own deformed positions: the angle
//! between the two must stay within 0.5° at the 99th percentile of vertices, on every frame.
//! Also: split vertices get identical normals, the rest pose's normals are close to the glTF
//! file's own `NORMAL` attribute (which tells the weld is right), and `Rig::normals_planned`
//! gives `Rig::normals`'s normals bit for bit on every frame.
//!
//! `cargo test --release -p facebake-tests --test normals -- --nocapture` prints the figures.

use facebake::model::FaceMesh;
use facebake::normals::{angle_degrees, vertex_normals};
use facebake::BakeOptions;
use facebake_runtime::{FrameError, PlayState, Rig};
use facebake_tests::{bake_truth, facecap_truth, jawmocap_rig, weights_config};

/// The accuracy bar: angle to the f64 normals at the 99th percentile, every frame, degrees.
const P99_BAR_DEGREES: f64 = 0.5;

/// Angles (degrees) between the runtime's normals of `positions` and the f64 reference's normals
/// of the same positions, over the vertices whose reference normal is defined; checks on the way
/// that split vertices got identical normals.
fn angles(rig: &Rig<'_>, mesh: &FaceMesh, positions: &[[i32; 3]], what: &str) -> Vec<f64> {
    let mut normals = vec![[0i16; 3]; rig.vertex_count()];
    rig.normals(positions, &mut normals)
        .expect("one per vertex");
    assert_eq!(planned(rig, positions), normals, "{what}: planned normals");
    assert_seams_identical(mesh, &normals, what);
    let f64_positions: Vec<[f64; 3]> = positions.iter().map(|p| p.map(f64::from)).collect();
    let reference = vertex_normals(mesh, &f64_positions);
    normals
        .iter()
        .zip(&reference)
        .filter(|(_, r)| **r != [0.0; 3])
        .map(|(n, r)| angle_degrees(n.map(f64::from), *r))
        .collect()
}

/// `Rig::normals_planned`'s normals of `positions`, planned afresh.
fn planned(rig: &Rig<'_>, positions: &[[i32; 3]]) -> Vec<[i16; 3]> {
    let mut triangles = vec![[0u32; 3]; rig.normals_plan_len()];
    let plan = rig
        .plan_normals(&mut triangles)
        .expect("a plan of its length");
    let mut sums = vec![[0i64; 3]; rig.vertex_count()];
    let mut normals = vec![[0i16; 3]; rig.vertex_count()];
    rig.normals_planned(positions, &plan, &mut sums, &mut normals)
        .expect("one sum and one normal per vertex");
    normals
}

/// The `q`-quantile of `x` (which it sorts).
fn quantile(x: &mut [f64], q: f64) -> f64 {
    x.sort_by(f64::total_cmp);
    x[((x.len() - 1) as f64 * q).round() as usize]
}

/// Worst p99 and worst max over the frames, and the frame of the worst p99.
struct Figures {
    p99: f64,
    max: f64,
    worst_frame: usize,
}

/// Print the figures of `take` (`frames` frames) and hold them to the bar.
fn report(take: &str, frames: usize, f: &Figures) {
    println!(
        "{take} ({frames} frames): angle to f64 normals, worst p99 {:.4}° (frame {}), max {:.3}°",
        f.p99, f.worst_frame, f.max
    );
    assert!(f.p99 <= P99_BAR_DEGREES, "{take}: p99 {:.3}°", f.p99);
}

fn figures(frames: impl Iterator<Item = Vec<f64>>) -> Figures {
    let mut f = Figures {
        p99: 0.0,
        max: 0.0,
        worst_frame: 0,
    };
    for (i, mut a) in frames.enumerate() {
        let p99 = quantile(&mut a, 0.99);
        if p99 > f.p99 {
            f.p99 = p99;
            f.worst_frame = i;
        }
        f.max = f.max.max(*a.last().expect("vertices"));
    }
    f
}

/// Every split vertex has exactly its weld group's normal.
fn assert_seams_identical(mesh: &FaceMesh, normals: &[[i16; 3]], what: &str) {
    let canonical = mesh.welded_to_original();
    let mut split = 0;
    for (v, &w) in mesh.weld.iter().enumerate() {
        let c = canonical[w as usize] as usize;
        if c != v {
            split += 1;
            assert_eq!(
                normals[v], normals[c],
                "{what}: vertex {v} and {c} share a seam"
            );
        }
    }
    assert!(split > 0, "the FaceCap head has seams");
}

#[test]
fn facecap_truth_frames_are_within_half_a_degree_of_f64() {
    let truth = facecap_truth();
    let baked = bake_truth(&truth, &BakeOptions::product_default());
    let rig = Rig::from_bytes(&baked.blob).unwrap();
    let space = rig.space();
    let mut out = vec![[0i32; 3]; rig.vertex_count()];
    let f = figures((0..truth.frames.len()).map(|f| {
        let markers: Vec<[i32; 3]> = truth
            .markers_of(&truth.positions(f))
            .iter()
            .map(|p| space.to_rig_f64(*p).unwrap())
            .collect();
        rig.deform(&markers, &mut out).unwrap();
        angles(&rig, &truth.mesh, &out, &truth.frames[f].name)
    }));
    report("FaceCap truth, default bake", truth.frames.len(), &f);
}

#[test]
fn jawmocap_frames_are_within_half_a_degree_of_f64() {
    let j = jawmocap_rig(&facebake::StagesConfig::default());
    let rig = Rig::from_bytes(&j.baked.blob).unwrap();
    let actor_space = rig.actor_space().unwrap();
    let mut state = PlayState::new();
    let mut out = vec![[0i32; 3]; rig.vertex_count()];
    let f = figures(j.frames.iter().map(|frame| {
        let actor: Vec<Option<[i32; 3]>> = frame
            .iter()
            .map(|p| p.and_then(|p| actor_space.to_rig_f64(p).ok()))
            .collect();
        rig.play(&mut state, &actor, &mut out).unwrap();
        angles(&rig, &j.mesh, &out, "JawMoCap")
    }));
    report(
        "JawMoCap, default bake with the capture stages",
        j.frames.len(),
        &f,
    );
}

#[test]
fn rest_normals_match_the_files_own_normals() {
    let truth = facecap_truth();
    let baked = bake_truth(&truth, &BakeOptions::product_default());
    let rig = Rig::from_bytes(&baked.blob).unwrap();
    let mesh = &truth.mesh;
    let file = mesh.normals.as_ref().expect("the FaceCap head has NORMAL");
    let rest: Vec<[i32; 3]> = (0..rig.vertex_count())
        .map(|v| rig.vertex_rest(v).unwrap())
        .collect();
    let mut normals = vec![[0i16; 3]; rig.vertex_count()];
    rig.normals(&rest, &mut normals).unwrap();
    let to_file: Vec<f64> = normals
        .iter()
        .zip(file)
        .map(|(n, f)| angle_degrees(n.map(f64::from), *f))
        .collect();
    // Split vertices (a weld group of more than one): the file gives both twins one normal, so
    // a weld that failed would show here first.
    let mut group_size = vec![0usize; mesh.welded_positions.len()];
    for &w in &mesh.weld {
        group_size[w as usize] += 1;
    }
    let mut at_seams: Vec<f64> = to_file
        .iter()
        .zip(&mesh.weld)
        .filter(|(_, &w)| group_size[w as usize] > 1)
        .map(|(a, _)| *a)
        .collect();
    // The baked rest normals (the fallback) are the f64 ones at rest: within a Q1.14 step and
    // the rest positions' Q0.15 rounding of the runtime's.
    let mut to_baked: Vec<f64> = normals
        .iter()
        .enumerate()
        .map(|(v, n)| angle_degrees(n.map(f64::from), rig.rest_normal(v).unwrap().map(f64::from)))
        .collect();
    let mut all = to_file.clone();
    let (median, p99, max) = (
        quantile(&mut all, 0.5),
        quantile(&mut all, 0.99),
        quantile(&mut all, 1.0),
    );
    let seams_max = quantile(&mut at_seams, 1.0);
    let baked_max = quantile(&mut to_baked, 1.0);
    println!(
        "FaceCap rest pose, runtime normals vs the glTF NORMAL attribute: median {median:.2}°, \
         p99 {p99:.1}°, max {max:.1}°; at the {} split vertices max {seams_max:.2}°; vs the baked \
         rest normals max {baked_max:.3}°",
        at_seams.len()
    );
    // The file's normals are angle-weighted, ours area-weighted: they differ most where a
    // vertex's triangles differ most in size, but the median is a few degrees. Unwelded, the
    // split vertices would be up to 7.7° from the file; welded, 4.4°.
    assert!(median < 4.0, "median {median:.2}°");
    assert!(
        !at_seams.is_empty() && seams_max < 5.0,
        "seams {seams_max:.2}°"
    );
    assert!(baked_max < 0.5, "baked rest normals {baked_max:.3}°");
}

#[test]
fn split_vertices_get_identical_normals_even_when_their_positions_differ() {
    // Move every split vertex away from its canonical twin: the normal still comes from the
    // canonical vertex's fan, so the seam stays shut in shading.
    let truth = facecap_truth();
    let baked = bake_truth(&truth, &BakeOptions::product_default());
    let rig = Rig::from_bytes(&baked.blob).unwrap();
    let canonical = truth.mesh.welded_to_original();
    let positions: Vec<[i32; 3]> = (0..rig.vertex_count())
        .map(|v| {
            let p = rig.vertex_rest(v).unwrap();
            if canonical[truth.mesh.weld[v] as usize] as usize == v {
                p
            } else {
                [p[0] + (1 << 20), p[1] - (1 << 19), p[2]]
            }
        })
        .collect();
    let mut normals = vec![[0i16; 3]; rig.vertex_count()];
    rig.normals(&positions, &mut normals).unwrap();
    assert_seams_identical(&truth.mesh, &normals, "split vertices moved apart");
}

#[test]
fn collapsed_triangles_fall_back_to_the_rest_normal_and_nothing_panics() {
    let truth = facecap_truth();
    let baked = bake_truth(&truth, &BakeOptions::product_default());
    let rig = Rig::from_bytes(&baked.blob).unwrap();
    let n = rig.vertex_count();
    let mut normals = vec![[0i16; 3]; n];
    // Every vertex at one point: no triangle has area.
    rig.normals(&vec![[7, -3, 1 << 20]; n], &mut normals)
        .unwrap();
    for (v, got) in normals.iter().enumerate() {
        assert_eq!(Some(*got), rig.rest_normal(v), "vertex {v}");
    }
    // The extremes saturate the edges and still give unit normals or the fallback.
    for extreme in [
        vec![[i32::MAX; 3]; n],
        (0..n)
            .map(|v| [0, 1, 2].map(|c| if (v + c) % 2 == 0 { i32::MAX } else { i32::MIN }))
            .collect(),
    ] {
        rig.normals(&extreme, &mut normals).unwrap();
        for got in &normals {
            let len2: i64 = got.iter().map(|&c| i64::from(c).pow(2)).sum();
            assert!(
                (len2 - (1 << 28)).abs() < 1 << 17,
                "{got:?} is not a unit normal"
            );
        }
    }
    // Wrong lengths are errors, not panics.
    assert!(rig.normals(&vec![[0; 3]; n - 1], &mut normals).is_err());
    assert!(rig.normals(&vec![[0; 3]; n], &mut normals[1..]).is_err());
}

/// The planned path's own cases: every triangle once, the fans' normals for collapsed and
/// saturated poses too (those take the fans), and a plan, sums or buffer of the wrong rig or
/// length refused.
#[test]
fn planned_normals_take_each_triangle_once_and_refuse_another_rigs_plan() {
    let truth = facecap_truth();
    let baked = bake_truth(&truth, &BakeOptions::product_default());
    let rig = Rig::from_bytes(&baked.blob).unwrap();
    let n = rig.vertex_count();
    // FaceCap's skin and interior: 5032 triangles, none of them collapsed by the weld.
    assert_eq!(rig.normals_plan_len(), truth.mesh.triangles.len());
    let mut fans = vec![[0i16; 3]; n];
    for positions in [
        vec![[7, -3, 1 << 20]; n],
        vec![[i32::MAX; 3]; n],
        (0..n)
            .map(|v| [0, 1, 2].map(|c| if (v + c) % 2 == 0 { i32::MAX } else { i32::MIN }))
            .collect(),
    ] {
        rig.normals(&positions, &mut fans).unwrap();
        assert_eq!(planned(&rig, &positions), fans);
    }
    let rest: Vec<[i32; 3]> = (0..n).map(|v| rig.vertex_rest(v).unwrap()).collect();
    let mut triangles = vec![[0u32; 3]; rig.normals_plan_len()];
    let plan = rig.plan_normals(&mut triangles).unwrap();
    let (mut sums, mut out) = (vec![[0i64; 3]; n], vec![[0i16; 3]; n]);
    let too_short = FrameError::ScratchLength {
        expected: n,
        found: n - 1,
    };
    assert_eq!(
        rig.normals_planned(&rest, &plan, &mut sums[1..], &mut out),
        Err(too_short)
    );
    assert!(rig
        .normals_planned(&rest[1..], &plan, &mut sums, &mut out)
        .is_err());
    let mut short = vec![[0u32; 3]; rig.normals_plan_len() - 1];
    assert!(matches!(
        rig.plan_normals(&mut short),
        Err(FrameError::ScratchLength { .. })
    ));
    // Another rig of the same mesh refuses this one's plan, and takes a checked copy of it.
    let other = bake_truth(&truth, &weights_config());
    let other = Rig::from_bytes(&other.blob).unwrap();
    assert_eq!(
        other.normals_planned(&rest, &plan, &mut sums, &mut out),
        Err(FrameError::PlanMismatch)
    );
    let copy = triangles.clone();
    let checked = other.normals_plan_from(&copy).unwrap();
    other
        .normals_planned(&rest, &checked, &mut sums, &mut out)
        .unwrap();
    other.normals(&rest, &mut fans).unwrap();
    assert_eq!(out, fans);
    let mut bad = copy;
    bad[17][1] = n as u32;
    assert_eq!(
        other.normals_plan_from(&bad).err(),
        Some(FrameError::PlanMismatch)
    );
}
