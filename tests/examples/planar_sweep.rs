//! Planar bones on the FaceCap ground truth across bone radii and K, beside the linear forms:
//! mean / p99 / max error in mm over the whole skin and over the lips (skin within 15 mm of the
//! lip opening), runtime output, every ground-truth frame.
//!
//! Run: `cargo run --release -p facebake-tests --example planar_sweep`.

use facebake::ground_truth::{stats, ErrorStats, GroundTruth};
use facebake::mesh::distance;
use facebake::{BakeOptions, Baked};
use facebake_runtime::Rig;
use facebake_tests::{bake_truth, facecap_truth, lip_vertices, planar_config, weights_config};

fn scores(truth: &GroundTruth, lips: &[bool], baked: &Baked) -> (ErrorStats, ErrorStats) {
    let rig = Rig::from_bytes(&baked.blob).expect("the bake loads");
    let space = rig.space();
    let mut out = vec![[0i32; 3]; rig.vertex_count()];
    let (mut all, mut lip) = (vec![], vec![]);
    for f in 0..truth.frames.len() {
        let t = truth.positions(f);
        let q: Vec<_> = truth
            .markers_of(&t)
            .iter()
            .map(|p| space.to_rig_f64(*p).expect("markers fit"))
            .collect();
        rig.deform(&q, &mut out).expect("the frame deforms");
        let got: Vec<[f64; 3]> = out.iter().map(|p| space.to_asset_f64(*p)).collect();
        truth.skin_errors(&got, &t, &mut all);
        for ((g, t), &l) in got.iter().zip(&t).zip(lips) {
            if l {
                lip.push(distance(g, t));
            }
        }
    }
    (stats(&mut all, 1.0), stats(&mut lip, 1.0))
}

fn main() {
    let truth = facecap_truth();
    let lips = lip_vertices(&truth);
    let mut rows: Vec<(String, BakeOptions)> = vec![
        (
            "coefficients (default), K = 8".into(),
            BakeOptions::default(),
        ),
        ("weights, IMQ, K = 8".into(), weights_config()),
    ];
    for k in [4, 8, 16] {
        for radius in [0.5, 1.0, 1.5, 2.0] {
            rows.push((
                format!("planar, radius {radius} × closest connected marker, K = {k}"),
                BakeOptions {
                    planar_radius: radius,
                    ..planar_config(k)
                },
            ));
        }
    }
    println!("| configuration | whole face mean / p99 / max (mm) | lips mean / p99 / max (mm) | influences |");
    println!("|---|---|---|---|");
    for (name, config) in rows {
        let baked = bake_truth(&truth, &config);
        let (all, lip) = scores(&truth, &lips, &baked);
        let rig = Rig::from_bytes(&baked.blob).expect("the bake loads");
        println!(
            "| {name} | {:.2} / {:.2} / {:.1} | {:.2} / {:.2} / {:.1} | {} |",
            all.mean_mm,
            all.p99_mm,
            all.max_mm,
            lip.mean_mm,
            lip.p99_mm,
            lip.max_mm,
            rig.cost().influences
        );
    }
}
