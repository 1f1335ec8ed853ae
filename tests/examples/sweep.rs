//! Exploratory sweep while tuning (not a test): ground-truth error per kernel, re-fit and K.
//! `cargo run --release -p facebake-tests --example sweep`
use facebake::bake::BakeConfig;
use facebake::ground_truth::stats;
use facebake::rbf::KernelKind;
use facebake::sparsify::Refit;
use facebake_runtime::Rig;
use facebake_tests::{bake_truth, facecap_truth};

fn main() {
    let truth = facecap_truth();
    let truths: Vec<_> = (0..truth.frames.len())
        .map(|f| truth.positions(f))
        .collect();
    let kernels: Vec<KernelKind> = std::env::args()
        .skip(1)
        .filter_map(|a| <KernelKind as clap::ValueEnum>::from_str(&a, true).ok())
        .collect();
    let kernels = if kernels.is_empty() {
        KernelKind::ALL.to_vec()
    } else {
        kernels
    };
    for kernel in kernels {
        for (refit, pl) in [(Refit::Uniform, 0.0), (Refit::Prior, 0.05)] {
            for k in [4, 8, 16] {
                let cfg = BakeConfig {
                    kernel,
                    k,
                    refit,
                    prior_length: pl,
                    ..Default::default()
                };
                let baked = bake_truth(&truth, &cfg);
                let rig = Rig::from_bytes(&baked.blob).unwrap();
                let space = rig.space();
                let (mut e_truth, mut e_dense) = (vec![], vec![]);
                let mut out = vec![[0i32; 3]; rig.vertex_count()];
                for t in &truths {
                    let m = truth.markers_of(t);
                    let q: Vec<_> = m.iter().map(|p| space.to_rig_f64(*p).unwrap()).collect();
                    rig.deform(&q, &mut out).unwrap();
                    let got: Vec<_> = out.iter().map(|p| space.to_asset_f64(*p)).collect();
                    let dense = baked.dense.frame(&m);
                    truth.skin_errors(&got, t, &mut e_truth);
                    truth.skin_errors(&got, &dense, &mut e_dense);
                }
                println!(
                    "{:22} {refit:?} l={pl} K={k:2}  truth: {}  | vs dense: {}",
                    kernel.name(),
                    stats(&mut e_truth, 1.0),
                    stats(&mut e_dense, 1.0)
                );
            }
        }
    }
}
