use facebake::ground_truth::SplitMix64;
use facebake::{Scene, StagesConfig};
use facebake_runtime::Rig;
use facebake_tests::{jawmocap_rig_with, planar_config, play_take};

#[test]
fn scratch_planar_jitter() {
    let bake = planar_config(8);
    let j = jawmocap_rig_with(&bake, &StagesConfig::default());
    let mut rng = SplitMix64(0x0015_5E14);
    let mut noisy = j.capture.in_metres();
    for s in noisy.frames.iter_mut().flatten().flatten() {
        for c in s {
            *c += 0.0005 * (2.0 * rng.unit() - 1.0);
        }
    }
    let mut scene = Scene::placed(&j.mesh, &j.placed);
    scene.capture = Some(&noisy);
    let baked = facebake::bake(&scene, &bake).unwrap();
    let rig = Rig::from_bytes(&baked.blob).unwrap();
    let nf = facebake_tests::frames_in_order(&noisy, j.placed.iter().map(|m| m.name.as_str()));
    let a = play_take(&rig, &j.frames).0;
    let b = play_take(&rig, &nf).0;
    let mut worst = vec![(0.0f64, 0usize); a[0].len()];
    for f in 20..a.len() {
        for v in 0..a[f].len() {
            let e = 1000.0
                * (0..3)
                    .map(|c| (a[f][v][c] - b[f][v][c]).powi(2))
                    .sum::<f64>()
                    .sqrt();
            if e > worst[v].0 {
                worst[v] = (e, f);
            }
        }
    }
    let mut order: Vec<usize> = (0..worst.len()).collect();
    order.sort_by(|&x, &y| worst[y].0.total_cmp(&worst[x].0));
    for &v in order.iter().take(12) {
        println!(
            "v {v} at {:?} max {:.2} mm frame {}",
            j.mesh.positions[v].map(|x| (x * 1000.0).round()),
            worst[v].0,
            worst[v].1
        );
    }
    let over = worst.iter().filter(|w| w.0 > 4.0).count();
    println!("vertices over 4 mm: {over}");
}
