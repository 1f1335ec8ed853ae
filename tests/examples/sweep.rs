//! Ground-truth sweep over deformers, radial functions, widths and K: the figures behind docs/measurements.md's "Measured figures".
//! `cargo run --release -p facebake-tests --example sweep [-- radial…]`
use facebake::ground_truth::stats;
use facebake::{BakeOptions, DeformerKind, RadialFunction};
use facebake_runtime::Rig;
use facebake_tests::{bake_truth, facecap_truth};

fn main() {
    let truth = facecap_truth();
    let truths: Vec<_> = (0..truth.frames.len())
        .map(|f| truth.positions(f))
        .collect();
    let kernels: Vec<RadialFunction> = std::env::args()
        .skip(1)
        .filter_map(|a| RadialFunction::ALL.into_iter().find(|r| r.name() == a))
        .collect();
    let kernels = if kernels.is_empty() {
        RadialFunction::ALL.to_vec()
    } else {
        kernels
    };
    for form in [DeformerKind::Rbf, DeformerKind::Linear] {
        for &kernel in &kernels {
            for width_factor in [0.6, 0.75, 1.0, 2.0] {
                for k in [4, 8, 16] {
                    let cfg = BakeOptions {
                        deformer: form,
                        radial: kernel,
                        k,
                        width_factor,
                        ..Default::default()
                    };
                    let Ok(baked) = std::panic::catch_unwind(|| bake_truth(&truth, &cfg)) else {
                        continue;
                    };
                    let rig = Rig::from_bytes(&baked.blob).unwrap();
                    let space = rig.space();
                    let (mut e_truth, mut e_dense) = (vec![], vec![]);
                    let mut out = vec![[0i32; 3]; rig.vertex_count()];
                    for t in &truths {
                        let m = truth.markers_of(t);
                        let q: Vec<_> = m.iter().map(|p| space.to_rig_f64(*p).unwrap()).collect();
                        rig.deform(&q, &mut out).unwrap();
                        let got: Vec<_> = out.iter().map(|p| space.to_asset_f64(*p)).collect();
                        truth.skin_errors(&got, t, &mut e_truth);
                        truth.skin_errors(&got, &baked.reference.deformer.frame(&m), &mut e_dense);
                    }
                    println!(
                        "{form:?} {:20} width {width_factor:4} K={k:2} | vs truth: {} | vs dense: {}",
                        kernel.name(),
                        stats(&mut e_truth, 1.0),
                        stats(&mut e_dense, 1.0)
                    );
                }
            }
        }
    }
}
