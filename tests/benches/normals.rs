//! The cost of deformed normals against the positions-only frame, in one run.
//!
//! For FaceCap baked the way `facebake bake` does with no options (geodesic, linear deformer,
//! K = 8) and with the linear deformer on paper 000's inverse multiquadric (K = 8), fed the
//! "jaw open" frame: a frame of [`Rig::deform`] alone and a frame of [`Rig::deform`] then
//! [`Rig::normals`], timed in interleaved rounds of equal duration after a warm-up round; the
//! ratio is the median of per-round ratios, so machine noise hits both sides alike.
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

/// Median seconds per frame of positions alone and of positions + normals, and the median
/// per-round ratio.
fn measure(baked: &Baked, markers: &[[i32; 3]]) -> (f64, f64, f64) {
    let rig = Rig::from_bytes(&baked.blob).expect("the bake loads");
    let mut out = vec![[0i32; 3]; rig.vertex_count()];
    let mut normals = vec![[0i16; 3]; rig.vertex_count()];
    let (mut positions_t, mut both_t, mut ratios) = (Vec::new(), Vec::new(), Vec::new());
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
        if round > 0 {
            positions_t.push(p);
            both_t.push(b);
            ratios.push(b / p);
        }
    }
    (
        median(&mut positions_t),
        median(&mut both_t),
        median(&mut ratios),
    )
}

fn main() {
    // `cargo test --benches` passes no `--bench`: only check that everything runs.
    let timed = std::env::args().any(|a| a == "--bench");
    let truth = facecap_truth();
    let frame = truth.markers_of(&truth.positions(jaw_open_frame(&truth)));
    println!(
        "{:<34} {:>6} {:>2} {:>12} {:>14} {:>22}",
        "rig", "verts", "K", "positions µs", "+ normals µs", "positions+normals / positions"
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
            continue;
        }
        let (p, b, ratio) = measure(&baked, &markers);
        let cost = rig.cost();
        println!(
            "{name:<34} {:>6} {:>2} {:>12.1} {:>14.1} {:>22.2}",
            cost.vertices,
            cost.max_influences,
            p * 1e6,
            b * 1e6,
            ratio
        );
    }
}
