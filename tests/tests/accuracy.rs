//! Accuracy on the real FaceCap head against its morph-target ground truth.
//!
//! * runtime vs the f64 evaluation of the same rig: ≤ 2e-5 of the bounding-box diagonal;
//! * sparse K = 8 vs the dense per-frame RBF of the papers (same kernel);
//! * the default configuration against the truth, pinned so a regression fails.

use facebake::bake::{BakeConfig, Baked};
use facebake::ground_truth::{stats, ErrorStats, GroundTruth};
use facebake::reference::SparseF64;
use facebake_runtime::Rig;
use facebake_tests::{bake_truth, facecap_default};

struct Run {
    runtime_vs_f64_max: f64,
    truth: ErrorStats,
    vs_dense: ErrorStats,
    dense_truth: ErrorStats,
}

fn run(truth: &GroundTruth, baked: &Baked) -> Run {
    let rig = Rig::from_bytes(&baked.blob).unwrap();
    let space = rig.space();
    let f64_rig = SparseF64::from_rig(&rig);
    let mut out = vec![[0i32; 3]; rig.vertex_count()];
    let (mut e_truth, mut e_dense, mut e_dense_truth) = (vec![], vec![], vec![]);
    let mut worst = 0.0f64;
    for f in 0..truth.frames.len() {
        let t = truth.positions(f);
        let m = truth.markers_of(&t);
        let q: Vec<_> = m.iter().map(|p| space.to_rig_f64(*p).unwrap()).collect();
        rig.deform(&q, &mut out).unwrap();
        let got: Vec<_> = out.iter().map(|p| space.to_asset_f64(*p)).collect();
        for (g, r) in got.iter().zip(f64_rig.frame(&m)) {
            worst = worst.max(facebake::mesh::distance(g, &r));
        }
        let dense = baked.dense.frame(&m);
        truth.skin_errors(&got, &t, &mut e_truth);
        truth.skin_errors(&got, &dense, &mut e_dense);
        truth.skin_errors(&dense, &t, &mut e_dense_truth);
    }
    // FaceCap is in metres.
    Run {
        runtime_vs_f64_max: worst / truth.mesh.diagonal(),
        truth: stats(&mut e_truth, 1.0),
        vs_dense: stats(&mut e_dense, 1.0),
        dense_truth: stats(&mut e_dense_truth, 1.0),
    }
}

#[test]
fn default_rig_meets_the_runtime_bar_and_pinned_ground_truth() {
    let (truth, baked) = facecap_default();
    assert!(
        truth.frames.len() >= 30,
        "the sequence blends several targets per frame"
    );
    let r = run(truth, baked);
    println!(
        "runtime vs f64 of the same rig: {:.3e} of the diagonal",
        r.runtime_vs_f64_max
    );
    println!(
        "default vs truth: {}\nvs dense: {}\ndense vs truth: {}",
        r.truth, r.vs_dense, r.dense_truth
    );
    assert!(
        r.runtime_vs_f64_max <= 2e-5,
        "runtime vs f64: {:.3e} of the diagonal",
        r.runtime_vs_f64_max
    );
    // Pinned figures of the default configuration (IMQ + affine, K = 8, prior re-fit), measured
    // 2026-11-22: mean 0.998 mm, p99 8.98 mm, max 36.9 mm. Most of the p99 and the max is the
    // lip opening, which Euclidean RBF cannot part (the surface-aware issue). Margins ~2 %.
    assert!(r.truth.mean_mm <= 1.02, "{}", r.truth);
    assert!(r.truth.p99_mm <= 9.15, "{}", r.truth);
    assert!(r.truth.max_mm <= 37.7, "{}", r.truth);
    // The sparse rig is no worse against the truth than the dense RBF it approximates.
    assert!(r.truth.mean_mm <= r.dense_truth.mean_mm * 1.02);
    // Sparse K = 8 vs dense: measured p99 1.10 mm. The brief's bar is 0.1 mm, which weight-space
    // truncation cannot reach for any kernel with the affine term (its weights are global);
    // pinned here as a regression bound, see the README's "Known gaps".
    assert!(r.vs_dense.p99_mm <= 1.15, "{}", r.vs_dense);
}

#[test]
fn more_influences_approach_the_dense_reference() {
    let (truth, _) = facecap_default();
    let p99: Vec<f64> = [4, 8, 16]
        .iter()
        .map(|&k| {
            run(
                truth,
                &bake_truth(
                    truth,
                    &BakeConfig {
                        k,
                        ..Default::default()
                    },
                ),
            )
            .vs_dense
            .p99_mm
        })
        .collect();
    println!("sparse vs dense p99 for K = 4, 8, 16: {p99:?} mm");
    assert!(p99[0] > p99[1] && p99[1] > p99[2], "{p99:?}");
    assert!(p99[2] <= 0.3, "K = 16: {} mm", p99[2]);
}

#[test]
fn blob_meets_the_size_budget() {
    let (_, baked) = facecap_default();
    let s = baked.report.sizes;
    let vertices = 2694;
    assert_eq!(s.influences, vertices * 8);
    assert!(s.total <= 4 * s.influences + 8 * vertices, "{s:?}");
    assert!(s.other_bytes_per_vertex <= 8.0, "{s:?}");
}
