//! Per-frame cost of the planar-bones kernel against the linear kernel at the same K.
//!
//! The FaceCap ground-truth head (2694 vertices, 40 markers) baked three ways at K = 8: planar
//! bones, the linear deformer (IMQ as [`facebake_tests::weights_config`]) and
//! the default RBF deformer, all fed the "jaw open" frame's markers. One criterion group,
//! then a same-run table: the three paths timed in interleaved rounds of equal duration after
//! a warm-up, each ratio the median of per-round ratios, so machine noise hits both sides alike.
//!
//! Run: `cargo bench -p facebake-tests --bench planar`.

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::Criterion;
use facebake::{BakeOptions, Baked};
use facebake_runtime::Rig;
use facebake_tests::{bake_truth, facecap_truth, median, planar_config, weights_config};

/// Timed rounds of the same-run table (after one warm-up round).
const ROUNDS: usize = 9;
/// Time per path per round.
const SLICE: Duration = Duration::from_millis(100);

/// A loaded rig with its frame's markers and an output buffer.
struct Case<'a> {
    name: &'static str,
    rig: Rig<'a>,
    markers: Vec<[i32; 3]>,
    out: Vec<[i32; 3]>,
}

impl<'a> Case<'a> {
    fn new(name: &'static str, baked: &'a Baked, markers: &[[f64; 3]]) -> Self {
        let rig = Rig::from_bytes(&baked.blob).expect("the bake loads");
        let space = rig.space();
        let markers = markers
            .iter()
            .map(|p| space.to_rig_f64(*p).expect("markers fit"))
            .collect();
        let out = vec![[0; 3]; rig.vertex_count()];
        Self {
            name,
            rig,
            markers,
            out,
        }
    }

    fn frame(&mut self) {
        self.rig
            .deform(black_box(&self.markers), &mut self.out)
            .expect("the frame deforms");
        black_box(&self.out);
    }
}

/// The three bakes and the jaw-open frame's markers (asset units).
fn bakes() -> (Vec<(&'static str, Baked)>, Vec<[f64; 3]>) {
    let truth = facecap_truth();
    let markers = truth.markers_of(&truth.positions(facebake_tests::jaw_open_frame(&truth)));
    let configs: [(&str, BakeOptions); 3] = [
        ("planar_k8", planar_config(8)),
        ("weights_k8", weights_config()),
        (
            "coefficients_k8",
            BakeOptions {
                k: 8,
                ..BakeOptions::default()
            },
        ),
    ];
    let baked = configs
        .into_iter()
        .map(|(name, config)| (name, bake_truth(&truth, &config)))
        .collect();
    (baked, markers)
}

fn main() {
    let (baked, markers) = bakes();
    let mut cases: Vec<Case<'_>> = baked
        .iter()
        .map(|(name, b)| Case::new(name, b, &markers))
        .collect();
    let mut c = Criterion::default().configure_from_args();
    {
        let mut group = c.benchmark_group("facecap_planar_vs_linear");
        group
            .sample_size(30)
            .warm_up_time(Duration::from_secs(1))
            .measurement_time(Duration::from_secs(3));
        for case in &mut cases {
            group.bench_function(case.name, |b| b.iter(|| case.frame()));
        }
        group.finish();
    }
    // Same-run table.
    let mut times = vec![Vec::new(); cases.len()];
    for round in 0..=ROUNDS {
        for (case, t) in cases.iter_mut().zip(&mut times) {
            let start = Instant::now();
            let mut calls = 0u32;
            while start.elapsed() < SLICE {
                case.frame();
                calls += 1;
            }
            if round > 0 {
                t.push(start.elapsed().as_secs_f64() / f64::from(calls));
            }
        }
    }
    println!("\nsame-run medians over {ROUNDS} interleaved rounds (FaceCap, K = 8, jaw open):");
    println!("rig | µs per frame | influences | planar / this");
    let planar = times[0].clone();
    for (case, t) in cases.iter().zip(&times) {
        let mut ratios: Vec<f64> = planar.iter().zip(t).map(|(p, x)| p / x).collect();
        println!(
            "{} | {:.1} | {} | {:.2}",
            case.name,
            median(&mut t.clone()) * 1e6,
            case.rig.cost().influences,
            median(&mut ratios)
        );
    }
}
