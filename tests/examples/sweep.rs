//! Exploratory sweep while tuning (not a test): ground-truth error per kernel and K.
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
    for kernel in KernelKind::ALL {
        for wf in [1.0, 2.0, 4.0] {
            for refit in [Refit::Uniform, Refit::Prior] {
                for k in [4, 8, 16] {
                    let cfg = BakeConfig {
                        kernel,
                        k,
                        refit,
                        width_factor: wf,
                        ..Default::default()
                    };
                    let baked = bake_truth(&truth, &cfg);
                    let rig = Rig::from_bytes(&baked.blob).unwrap();
                    let space = rig.space();
                    let (mut e_truth, mut e_dense, mut e_dtruth) = (vec![], vec![], vec![]);
                    let mut out = vec![[0i32; 3]; rig.vertex_count()];
                    for t in &truths {
                        let m = truth.markers_of(t);
                        let q: Vec<_> = m.iter().map(|p| space.to_rig_f64(*p).unwrap()).collect();
                        rig.deform(&q, &mut out).unwrap();
                        let got: Vec<_> = out.iter().map(|p| space.to_asset_f64(*p)).collect();
                        let dense = baked.dense.frame(&m);
                        truth.skin_errors(&got, t, &mut e_truth);
                        truth.skin_errors(&got, &dense, &mut e_dense);
                        truth.skin_errors(&dense, t, &mut e_dtruth);
                    }
                    println!("{:22} wf {wf} {refit:?} K={k:2} cond {:.1e}  truth: {}  | vs dense: {} | dense truth: {}",
                    kernel.name(), baked.report.condition, stats(&mut e_truth, 1.0), stats(&mut e_dense, 1.0), stats(&mut e_dtruth, 1.0));
                    if kernel == KernelKind::InverseMultiquadric && wf > 1.0 {
                        break;
                    }
                }
            }
            if kernel == KernelKind::InverseMultiquadric {
                break;
            }
        }
    }
}
