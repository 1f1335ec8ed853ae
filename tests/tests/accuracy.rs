//! Accuracy on the real FaceCap head against its morph-target ground truth.
//!
//! * runtime vs the f64 evaluation of the same rig: ≤ 2e-5 of the bounding-box diagonal;
//! * sparse K = 8 vs the dense per-frame RBF of the papers (same kernel);
//! * the default configuration against the truth, pinned so a regression fails.

use facebake::deformer::SparseF64;
use facebake::ground_truth::{stats, ErrorStats, GroundTruth};
use facebake::{BakeOptions, Baked};
use facebake_runtime::deformer::Deformer;
use facebake_runtime::Rig;
use facebake_tests::{bake_truth, facecap_blobs, facecap_default, facecap_weights};

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
        let dense = baked.reference.deformer.frame(&m);
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

/// [`run`], printed, with the runtime-vs-f64 bar (2e-5 of the diagonal) checked.
fn run_checked(label: &str, truth: &GroundTruth, baked: &Baked) -> Run {
    let r = run(truth, baked);
    println!(
        "{label}: runtime vs f64 {:.3e} of the diagonal",
        r.runtime_vs_f64_max
    );
    println!(
        "  vs truth {}\n  vs dense {}\n  dense vs truth {}",
        r.truth, r.vs_dense, r.dense_truth
    );
    assert!(
        r.runtime_vs_f64_max <= 2e-5,
        "{label}: runtime vs f64 {:.3e} of the diagonal",
        r.runtime_vs_f64_max
    );
    r
}

#[test]
fn default_rig_meets_both_bars_and_pinned_ground_truth() {
    let (truth, baked) = facecap_default();
    assert!(
        truth.frames.len() >= 30,
        "the sequence blends several targets per frame"
    );
    let r = run_checked("coefficients", truth, baked);
    // The brief's bar: sparse K = 8 vs the dense RBF of the same kernel, p99 ≤ 0.1 mm.
    // Measured 2026-11-22: p99 0.0906 mm, max 0.473 mm.
    assert!(r.vs_dense.p99_mm <= 0.1, "{}", r.vs_dense);
    // Pinned against the truth (Gaussian, c = 0.75 × mean marker spacing, affine, K = 8),
    // measured 2026-11-22: mean 1.204 mm, p99 9.72 mm, max 37.3 mm; margins ~2 %. Most of the p99
    // and the max is the lip opening, which Euclidean RBF cannot part (the surface-aware issue).
    assert!(r.truth.mean_mm <= 1.23, "{}", r.truth);
    assert!(r.truth.p99_mm <= 9.92, "{}", r.truth);
    assert!(r.truth.max_mm <= 38.1, "{}", r.truth);
}

#[test]
fn weights_form_figures_are_pinned() {
    let (truth, _) = facecap_default();
    let r = run_checked("weights (IMQ)", truth, facecap_weights());
    // Measured 2026-11-22: vs truth mean 0.9985 mm, p99 8.98 mm, max 36.9 mm; vs dense p99 1.10 mm.
    // Closer to the truth than the default, but not to its own dense RBF: the affine term spreads
    // inverse-multiquadric weights over every marker, so keeping 8 of 40 drops real signal.
    assert!(r.truth.mean_mm <= 1.02, "{}", r.truth);
    assert!(r.truth.p99_mm <= 9.15, "{}", r.truth);
    assert!(r.truth.max_mm <= 37.7, "{}", r.truth);
    assert!(r.vs_dense.p99_mm <= 1.15, "{}", r.vs_dense);
}

/// The bar "the sparse runtime matches its own dense f64 method, p99 ≤ 0.1 mm", on the
/// rig `bake` makes with no options (geodesic distances, exponential kernel at 1.5 spacings,
/// the linear deformer, anchored, corners reshaped, the kept weights shrunk): missed at K = 8.
/// The kernel is wide and the weights are an interpolation's, spread over many markers; the
/// largest differences are in the jaw open, at the mouth and on the jaw's sides beyond the
/// markers. Shrinking (`Refit::Shrink`: every magnitude less the (K+1)-th largest) moves
/// further from the dense weights than the prior's re-fit but nearer the truth, and it is
/// continuous where a vertex's kept set changes. Measured 2026-12-02 (masked, the default),
/// sparse vs dense p99 and mean against the truth: shrink K = 8 0.94 / 0.877 mm, K = 32 0.22;
/// prior K = 8 0.62 / 0.891, K = 32 0.084; the dense weights 0.920 (unmasked: 0.92 / 0.878,
/// 0.63 / 0.893, dense 0.922). The runtime's cost grows with K, and the
/// Cortex-M4 budget frame is at 96 % of its limit at K = 8.
#[test]
fn the_default_rig_against_its_own_dense_weights() {
    let (truth, _) = facecap_default();
    let at = |k: usize, refit: facebake::Refit| {
        let options = BakeOptions {
            k,
            refit,
            ..BakeOptions::product_default()
        };
        assert_eq!(
            BakeOptions::product_default().refit,
            facebake::Refit::Shrink
        );
        run_checked(
            &format!("the default, K = {k}, {refit:?}"),
            truth,
            &bake_truth(truth, &options),
        )
    };
    use facebake::Refit::{Prior, Shrink};
    let (k8, k32) = (at(8, Shrink), at(32, Shrink));
    let (prior8, prior32) = (at(8, Prior), at(32, Prior));
    assert!(k8.vs_dense.p99_mm <= 0.95, "{}", k8.vs_dense);
    assert!(k8.vs_dense.p99_mm > 0.1, "the bar is met: say so");
    assert!(k32.vs_dense.p99_mm <= 0.25, "{}", k32.vs_dense);
    assert!(prior8.vs_dense.p99_mm <= 0.65, "{}", prior8.vs_dense);
    assert!(prior32.vs_dense.p99_mm <= 0.1, "{}", prior32.vs_dense);
    assert!(k8.truth.mean_mm < prior8.truth.mean_mm, "{}", k8.truth);
    assert!(k8.truth.mean_mm < k8.dense_truth.mean_mm, "{}", k8.truth);
}

/// The RBF deformer anchored through its affine part (`bake --deformer rbf`: geodesic
/// distances, the exponential kernel, the anchor markers' mean translation as the affine part,
/// every radial term, `facebake::RBF_K`) plays its own f64 reference within the runtime bar and
/// its dense RBF within quantisation. Its dense form is closer to the truth than the unanchored
/// one (measured 2026-11-27: mean 0.888 against 1.008 mm). K = 8 of its terms approximated it
/// badly (measured 2026-12-02 on these 40 markers: sparse vs dense p99 7.79 mm, the truth's
/// mean error 1.77 mm); with all 40, 0.005 mm and 0.871 mm.
#[test]
fn the_anchored_rbf_deformer_matches_its_reference() {
    let (truth, _) = facecap_default();
    let anchored = BakeOptions::for_method(facebake::Method::Geodesic, false)
        .with_deformer(facebake::DeformerKind::Rbf);
    assert_eq!(anchored.k, facebake::RBF_K);
    let bare = BakeOptions {
        anchoring: None,
        ..anchored.clone()
    };
    let eight = BakeOptions {
        k: 8,
        ..anchored.clone()
    };
    let a = run_checked("anchored RBF", truth, &bake_truth(truth, &anchored));
    let u = run_checked("unanchored RBF", truth, &bake_truth(truth, &bare));
    let e = run_checked("anchored RBF, K = 8", truth, &bake_truth(truth, &eight));
    assert!(
        a.dense_truth.mean_mm < u.dense_truth.mean_mm,
        "{}",
        a.dense_truth
    );
    // Every term kept: the rig is its dense RBF but for quantisation.
    assert!(a.vs_dense.p99_mm <= 0.01, "{}", a.vs_dense);
    assert!(e.vs_dense.p99_mm > 5.0, "{}", e.vs_dense);
    assert!(a.truth.mean_mm < e.truth.mean_mm, "{}", a.truth);
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
                    &BakeOptions {
                        k,
                        ..Default::default()
                    },
                ),
            )
            .vs_dense
            .p99_mm
        })
        .collect();
    println!("coefficients: sparse vs dense p99 for K = 4, 8, 16: {p99:?} mm");
    // Measured 2026-11-22: 1.08, 0.0906, 0.0035 mm.
    assert!(p99[0] > p99[1] && p99[1] > p99[2], "{p99:?}");
    assert!(p99[2] <= 0.01, "K = 16: {} mm", p99[2]);
}

#[test]
fn blobs_meet_the_size_budget() {
    for (name, blob) in facecap_blobs() {
        let rig = Rig::from_bytes(blob).unwrap();
        let cost = rig.cost();
        let (v, i) = (rig.vertex_count(), cost.influences);
        assert_eq!(i, v * 8, "{name}: K = 8 everywhere");
        // At most 4 bytes per stored influence (3 in the linear form's pairs) plus 8 bytes per
        // vertex of everything else but the normals section, which has its own budget: 30
        // bytes per vertex (rest normal 6, fan count 1, about 5.6 fan corners of 4 bytes, welds).
        let per_influence = match rig.deformer() {
            Deformer::Linear(_) => 3,
            _ => 4,
        };
        let n = rig.data().normals;
        let normals = n.rest.0.len() + n.fan_counts.0.len() + n.corners.0.len() + n.welds.0.len();
        let other = blob.len() - per_influence * i - normals;
        println!(
            "{name}: {} bytes = {per_influence} × {i} influences + normals {:.2} bytes × {v} \
             vertices + {:.2} bytes × {v} vertices",
            blob.len(),
            normals as f64 / v as f64,
            other as f64 / v as f64
        );
        assert!(
            other <= 8 * v,
            "{name}: {:.2} bytes per vertex besides influences and normals",
            other as f64 / v as f64
        );
        assert!(
            normals <= 30 * v,
            "{name}: normals section {:.2} bytes per vertex",
            normals as f64 / v as f64
        );
    }
}
