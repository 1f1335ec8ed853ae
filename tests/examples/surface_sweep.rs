//! The surface-aware methods on the FaceCap ground truth: per method, with and without masks,
//! the error over the whole skin, the lip band and the eyelid band, and the share of lip /
//! eyelid vertices pulled across the opening.
//!
//! `cargo run --release -p facebake-tests --example surface_sweep [all]` (`all`: four kernels).
//! Environment: `LIPS` (lip-marker offset from the mouth line, metres; 0 keeps the JawMoCap
//! layout), `MASK_PLATEAU`, `MASK_DECAY`, `REGION`, `DECAY` (× mean marker spacing), `ALPHA` (PBW), `RIDGE`,
//! `VERBOSE` (warnings), `DIAG` (worst lip vertices on "jaw open").

use facebake::{BakeOptions, DeformerKind, Method, RadialFunction};
use facebake_tests::bake_scene;

fn main() {
    let lips: f64 = std::env::var("LIPS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(facebake_tests::LIP_MARKER_OFFSET);
    let scene = facebake_tests::facecap_scene_with(lips);
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
    let kernels: Vec<(RadialFunction, f64)> = std::env::args()
        .nth(1)
        .map(|_| {
            vec![
                (RadialFunction::Gaussian, 0.75),
                (RadialFunction::Gaussian, 1.0),
                (RadialFunction::InverseMultiquadric, 1.0),
                (RadialFunction::Exponential, 1.0),
            ]
        })
        .unwrap_or(vec![
            (RadialFunction::Gaussian, 0.75),
            (RadialFunction::Exponential, 1.0),
        ]);
    println!(
        "| method | masks | deformer | radial | face mean | face p99 | face max | lips mean | lips p99 | lips max | eyelids mean | eyelids p99 | eyelids max | lips crossed | eyelids crossed | λmin/mean φ |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    for &(kernel, width_factor) in &kernels {
        for method in Method::ALL {
            for (masks, form) in [
                (false, DeformerKind::Rbf),
                (false, DeformerKind::Linear),
                (true, DeformerKind::Linear),
            ] {
                if method == Method::Pbw && form == DeformerKind::Rbf {
                    continue;
                }
                let mut config = BakeOptions::for_method(method, masks);
                let env = |name: &str, default: f64| {
                    std::env::var(name)
                        .ok()
                        .and_then(|v| v.parse().ok())
                        .unwrap_or(default)
                };
                let surface = &mut config.surface;
                surface.mask_decay_factor = env("MASK_DECAY", surface.mask_decay_factor);
                surface.mask_plateau_factor = env("MASK_PLATEAU", surface.mask_plateau_factor);
                surface.region_factor = env("REGION", surface.region_factor);
                surface.decay_factor = env("DECAY", surface.decay_factor);
                surface.pbw_alpha = env("ALPHA", surface.pbw_alpha);
                if let Ok(r) = std::env::var("RIDGE") {
                    surface.ridge = r.parse().ok();
                }
                config.deformer = form;
                config.radial = kernel;
                config.width_factor = width_factor;
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
                    r.surface.as_ref().map_or(f64::NAN, |f| f.min_eigenvalue),
                );
                if std::env::var("VERBOSE").is_ok() {
                    for w in &r.warnings {
                        eprintln!(
                            "  {} masks={masks} {form:?}: {w} (bake {bake_s:.2} s)",
                            method.name()
                        );
                    }
                }
                if std::env::var("DIAG").is_ok() {
                    diagnose(&scene, &baked.blob);
                }
            }
        }
    }
}

/// The worst lip-band vertices of the "jaw open" frame: side, error, true displacement.
fn diagnose(scene: &facebake::surface::evaluate::Benchmark, blob: &[u8]) {
    let rig = facebake_runtime::Rig::from_bytes(blob).unwrap();
    let space = rig.space();
    let f = facebake_tests::jaw_open_frame(&scene.truth);
    let t = scene.truth.positions(f);
    let q: Vec<[i32; 3]> = scene
        .markers_of(&t)
        .iter()
        .map(|p| space.to_rig_f64(*p).unwrap())
        .collect();
    let mut out = vec![[0i32; 3]; rig.vertex_count()];
    rig.deform(&q, &mut out).unwrap();
    let rest = &scene.truth.mesh.positions;
    let mut worst: Vec<(f64, usize)> = scene.bands[0]
        .iter()
        .enumerate()
        .filter(|(_, s)| s.is_some())
        .map(|(v, _)| {
            (
                facebake::mesh::distance(&space.to_asset_f64(out[v]), &t[v]),
                v,
            )
        })
        .collect();
    worst.sort_by(|a, b| b.0.total_cmp(&a.0));
    for &(e, v) in worst.iter().take(6) {
        let got = space.to_asset_f64(out[v]);
        println!(
            "    v{v} {:?} err {:.1} mm, true disp {:.1} mm, got disp {:.1} mm, rest {:?}",
            scene.bands[0][v].unwrap(),
            e * 1000.0,
            facebake::mesh::distance(&t[v], &rest[v]) * 1000.0,
            facebake::mesh::distance(&got, &rest[v]) * 1000.0,
            rest[v].map(|x| (x * 1000.0).round())
        );
    }
}
