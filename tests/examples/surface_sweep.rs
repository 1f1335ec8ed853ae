//! The surface-aware methods on the FaceCap ground truth: per method, with and without masks,
//! the error over the whole skin, the lip band and the eyelid band, and the share of lip /
//! eyelid vertices pulled across the opening.
//!
//! `cargo run --release -p facebake-tests --example surface_sweep`

use facebake::bake::RigForm;
use facebake::rbf::KernelKind;
use facebake::surface::{Method, SurfaceConfig};
use facebake_tests::{bake_scene, facecap_scene};

fn main() {
    let scene = facecap_scene();
    println!(
        "FaceCap: {} markers ({} from the JawMoCap layout + anchors), {} frames, band vertices {:?}",
        scene.markers.len(),
        scene.markers.len() - facebake_tests::FACECAP_STATIC_MARKERS,
        scene.truth.frames.len(),
        scene
            .bands
            .iter()
            .map(|b| b.iter().filter(|s| s.is_some()).count())
            .collect::<Vec<_>>()
    );
    let kernels: Vec<(KernelKind, f64)> = std::env::args()
        .nth(1)
        .map(|_| {
            vec![
                (KernelKind::Gaussian, 0.75),
                (KernelKind::Gaussian, 1.0),
                (KernelKind::InverseMultiquadric, 1.0),
                (KernelKind::Exponential, 1.0),
            ]
        })
        .unwrap_or(vec![(KernelKind::Gaussian, 0.75)]);
    println!(
        "| method | masks | form | kernel | face mean | face p99 | face max | lips mean | lips p99 | lips max | eyelids mean | eyelids p99 | eyelids max | lips crossed | eyelids crossed | λmin/mean φ |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    for &(kernel, width_factor) in &kernels {
        for method in Method::ALL {
            for (masks, form) in [
                (false, RigForm::Coefficients),
                (false, RigForm::Weights),
                (true, RigForm::Weights),
            ] {
                let mut config = SurfaceConfig {
                    method,
                    masks,
                    ..SurfaceConfig::default()
                };
                config.bake.form = form;
                config.bake.kernel = kernel;
                config.bake.width_factor = width_factor;
                let t = std::time::Instant::now();
                let baked = bake_scene(&scene, &config);
                let bake_s = t.elapsed().as_secs_f64();
                let s = scene.score(&baked.blob);
                let r = &baked.report;
                println!(
                    "| {} | {} | {:?} | {} {width_factor} | {:.3} | {:.2} | {:.2} | {:.3} | {:.2} | {:.2} | {:.3} | {:.2} | {:.2} | {:.1} % | {:.1} % | {:.2e} |",
                    method.name(),
                    if masks { "yes" } else { "no" },
                    form,
                    kernel.name(),
                    s.whole.mean_mm,
                    s.whole.p99_mm,
                    s.whole.max_mm,
                    s.bands[0].mean_mm,
                    s.bands[0].p99_mm,
                    s.bands[0].max_mm,
                    s.bands[1].mean_mm,
                    s.bands[1].p99_mm,
                    s.bands[1].max_mm,
                    100.0 * s.crossed[0],
                    100.0 * s.crossed[1],
                    r.min_eigenvalue,
                );
                for w in &r.warnings {
                    eprintln!(
                        "  {} masks={masks} {form:?}: {w} (bake {bake_s:.2} s)",
                        method.name()
                    );
                }
            }
        }
    }
}
