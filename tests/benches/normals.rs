//! The cost of deformed normals against the positions-only frame, in one run.
//!
//! For FaceCap baked the way `facebake bake` does with no options (geodesic, linear deformer,
//! K = 8) and with the linear deformer on paper 000's inverse multiquadric (K = 8), fed the
//! "jaw open" frame: a frame of [`Rig::deform`] alone, a frame of [`Rig::deform`] then
//! [`Rig::normals`], and one of [`Rig::deform`] then [`Rig::normals_planned`], timed in
//! interleaved rounds of equal duration after a warm-up round; each ratio is the median of
//! per-round ratios, so machine noise hits every path alike.
//!
//! Run: `cargo bench -p facebake-tests --bench normals`.

use std::hint::black_box;
use std::time::{Duration, Instant};

use facebake::{BakeOptions, Baked};
use facebake_runtime::Rig;
use facebake_tests::{bake_truth, facecap_truth, jaw_open_frame, median, weights_config};

/// Timed rounds (after one warm-up round).
const ROUNDS: usize = 15;
/// Time per path per round.
const SLICE: Duration = Duration::from_millis(100);

/// Seconds per call of `f`, calling it for [`SLICE`].
fn time(f: &mut dyn FnMut()) -> f64 {
    let start = Instant::now();
    let mut calls = 0u32;
    while start.elapsed() < SLICE {
        f();
        calls += 1;
    }
    start.elapsed().as_secs_f64() / f64::from(calls)
}

/// Median seconds per frame of positions alone, of positions + normals and of positions +
/// planned normals, and the median per-round ratios of the last two to the first.
fn measure(baked: &Baked, markers: &[[i32; 3]]) -> [f64; 5] {
    let rig = Rig::from_bytes(&baked.blob).expect("the bake loads");
    let n = rig.vertex_count();
    let mut out = vec![[0i32; 3]; n];
    let mut normals = vec![[0i16; 3]; n];
    let mut triangles = vec![[0u32; 3]; rig.normals_plan_len()];
    let plan = rig
        .plan_normals(&mut triangles)
        .expect("a plan of its length");
    let mut sums = vec![[0i64; 3]; n];
    let mut rounds: [Vec<f64>; 5] = Default::default();
    for round in 0..=ROUNDS {
        let p = time(&mut || {
            rig.deform(black_box(markers), &mut out)
                .expect("frame shape");
            black_box(&out);
        });
        let b = time(&mut || {
            rig.deform(black_box(markers), &mut out)
                .expect("frame shape");
            rig.normals(&out, &mut normals).expect("frame shape");
            black_box(&normals);
        });
        let q = time(&mut || {
            rig.deform(black_box(markers), &mut out)
                .expect("frame shape");
            rig.normals_planned(&out, &plan, &mut sums, &mut normals)
                .expect("frame shape");
            black_box(&normals);
        });
        if round > 0 {
            for (r, x) in rounds.iter_mut().zip([p, b, q, b / p, q / p]) {
                r.push(x);
            }
        }
    }
    rounds.map(|mut r| median(&mut r))
}

fn main() {
    // `cargo test --benches` passes no `--bench`: only check that everything runs.
    let timed = std::env::args().any(|a| a == "--bench");
    let truth = facecap_truth();
    let frame = truth.markers_of(&truth.positions(jaw_open_frame(&truth)));
    println!(
        "{:<34} {:>6} {:>2} {:>12} {:>14} {:>14} {:>10} {:>10}",
        "rig", "verts", "K", "positions µs", "+ normals µs", "+ planned µs", "normals", "planned"
    );
    for (name, options) in [
        (
            "facecap default (geodesic linear)",
            BakeOptions::product_default(),
        ),
        ("facecap linear IMQ", weights_config()),
    ] {
        let baked = bake_truth(&truth, &options);
        let rig = Rig::from_bytes(&baked.blob).expect("the bake loads");
        let markers: Vec<[i32; 3]> = frame
            .iter()
            .map(|p| rig.space().to_rig_f64(*p).expect("markers in range"))
            .collect();
        if !timed {
            let mut out = vec![[0i32; 3]; rig.vertex_count()];
            let mut normals = vec![[0i16; 3]; rig.vertex_count()];
            rig.deform(&markers, &mut out).expect("frame shape");
            rig.normals(&out, &mut normals).expect("frame shape");
            let mut triangles = vec![[0u32; 3]; rig.normals_plan_len()];
            let plan = rig.plan_normals(&mut triangles).expect("a plan");
            let mut sums = vec![[0i64; 3]; rig.vertex_count()];
            rig.normals_planned(&out, &plan, &mut sums, &mut normals)
                .expect("frame shape");
            continue;
        }
        let [p, b, q, normals, planned] = measure(&baked, &markers);
        let cost = rig.cost();
        println!(
            "{name:<34} {:>6} {:>2} {:>12.1} {:>14.1} {:>14.1} {:>9.2}× {:>9.2}×",
            cost.vertices,
            cost.max_influences,
            p * 1e6,
            b * 1e6,
            q * 1e6,
            normals,
            planned
        );
    }
}
