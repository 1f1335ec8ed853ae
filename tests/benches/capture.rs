//! Per-frame cost of the runtime's capture stages (head-motion compensation, fill,
//! retargeting), for 41 markers (JawMoCap on FaceCap) and 100 markers (FaceCap ground truth with
//! 100 markers, moved rigidly and scaled as an actor would be), beside the deformation of the
//! same rig.
//!
//! `cargo bench -p facebake-tests --bench capture` runs criterion groups `capture_41` and
//! `capture_100` (paths `stages`, `deform`, `play`), then prints a same-run table: the stages'
//! time per frame and its ratio to the deformation's, medians of interleaved rounds.

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::Criterion;
use facebake::ground_truth::GroundTruth;
use facebake::io::gltf_mesh::load_mesh;
use facebake::model::{Capture, Units};
use facebake::{bake, BakeOptions, HeadMarkers, Scene, StagesConfig};
use facebake_runtime::{PlayState, Rig};
use facebake_tests::{fixture, jawmocap_rig, truth_markers};

/// A rig with stages and the actor frames (Q8.24 actor units) that drive it.
struct Case {
    name: String,
    blob: Vec<u8>,
    frames: Vec<Vec<Option<[i32; 3]>>>,
}

fn quantise(rig: &Rig<'_>, frames: &[Vec<Option<[f64; 3]>>]) -> Vec<Vec<Option<[i32; 3]>>> {
    let space = rig.stages().expect("stages").actor_space;
    frames
        .iter()
        .map(|f| {
            f.iter()
                .map(|p| p.and_then(|p| space.to_rig_f64(p).ok()))
                .collect()
        })
        .collect()
}

fn jawmocap() -> Case {
    let j = jawmocap_rig(&StagesConfig::default());
    let rig = Rig::from_bytes(&j.baked.blob).unwrap();
    let frames = quantise(&rig, &j.frames);
    Case {
        name: "capture_41".into(),
        blob: j.baked.blob.clone(),
        frames,
    }
}

/// 100 markers on FaceCap; the actor is the character scaled by 1.1, turning and moving.
fn hundred() -> Case {
    let mesh = load_mesh(&fixture("FaceCapHeadGeneric.glb"), Some("head"), None).unwrap();
    let truth = GroundTruth::new(mesh, 100, 6).unwrap();
    let names = truth.marker_names();
    let frames: Vec<Vec<Option<[f64; 3]>>> = (0..truth.frames.len())
        .map(|f| {
            let (s, c) = (0.05 * f as f64).sin_cos();
            truth
                .markers_of(&truth.positions(f))
                .iter()
                .map(|p| {
                    let p = p.map(|x| 1.1 * x);
                    Some([
                        c * p[0] + s * p[2] + 0.01 * f as f64,
                        p[1],
                        -s * p[0] + c * p[2],
                    ])
                })
                .collect()
        })
        .collect();
    let capture = Capture {
        source: "synthetic".into(),
        rate_hz: 60.0,
        units: Units::Metres,
        marker_names: names.clone(),
        frames: frames.clone(),
    };
    let mut scene = Scene::new(&truth.mesh, truth_markers(&truth));
    scene.capture = Some(&capture);
    let options = BakeOptions {
        stages: StagesConfig {
            head: HeadMarkers::MostRigid(4),
            ..StagesConfig::default()
        },
        ..BakeOptions::default()
    };
    let blob = bake(&scene, &options).unwrap().blob;
    let rig = Rig::from_bytes(&blob).unwrap();
    let frames = quantise(&rig, &frames);
    Case {
        name: "capture_100".into(),
        blob,
        frames,
    }
}

/// The three paths of a case, each over every frame in turn.
struct Paths<'a> {
    rig: Rig<'a>,
    frames: &'a [Vec<Option<[i32; 3]>>],
    state: PlayState,
    markers: Vec<[i32; 3]>,
    out: Vec<[i32; 3]>,
    next: usize,
}

impl<'a> Paths<'a> {
    fn new(case: &'a Case) -> Self {
        let rig = Rig::from_bytes(&case.blob).unwrap();
        let mut p = Self {
            rig,
            frames: &case.frames,
            state: PlayState::new(),
            markers: vec![[0; 3]; rig.marker_count()],
            out: vec![[0; 3]; rig.vertex_count()],
            next: 0,
        };
        p.stages(); // character markers of frame 0 for `deform`
        p
    }
    fn frame(&mut self) -> &'a [Option<[i32; 3]>] {
        let f = &self.frames[self.next % self.frames.len()];
        self.next += 1;
        f
    }
    fn stages(&mut self) {
        let f = self.frame();
        let st = self.rig.stages().unwrap();
        black_box(st.solve(&mut self.state, black_box(f), &mut self.markers));
    }
    fn deform(&mut self) {
        self.rig
            .deform(black_box(&self.markers), &mut self.out)
            .unwrap();
    }
    fn play(&mut self) {
        let f = self.frame();
        black_box(
            self.rig
                .play(&mut self.state, black_box(f), &mut self.out)
                .unwrap(),
        );
    }
}

fn median(mut x: Vec<f64>) -> f64 {
    x.sort_by(f64::total_cmp);
    x[x.len() / 2]
}

fn main() {
    let cases = [jawmocap(), hundred()];
    let mut c = Criterion::default().configure_from_args();
    for case in &cases {
        let mut g = c.benchmark_group(&case.name);
        g.sample_size(30).measurement_time(Duration::from_secs(2));
        let mut p = Paths::new(case);
        g.bench_function("stages", |b| b.iter(|| p.stages()));
        g.bench_function("deform", |b| b.iter(|| p.deform()));
        g.bench_function("play", |b| b.iter(|| p.play()));
        g.finish();
    }
    c.final_summary();
    if !std::env::args().any(|a| a == "--bench") {
        return;
    }
    println!("\ncapture stages per frame (medians of 15 interleaved rounds of 50 ms each):");
    println!(
        "{:12} {:>8} {:>12} {:>12} {:>16}",
        "rig", "markers", "stages µs", "deform µs", "stages / deform"
    );
    for case in &cases {
        let mut p = Paths::new(case);
        let (mut st, mut de) = (Vec::new(), Vec::new());
        for round in 0..16 {
            for (which, times) in [(0, &mut st), (1, &mut de)] {
                let start = Instant::now();
                let mut n = 0u32;
                while start.elapsed() < Duration::from_millis(50) {
                    if which == 0 {
                        p.stages()
                    } else {
                        p.deform()
                    }
                    n += 1;
                }
                if round > 0 {
                    times.push(start.elapsed().as_secs_f64() / f64::from(n));
                }
            }
        }
        let ratio = median(st.iter().zip(&de).map(|(a, b)| a / b).collect());
        println!(
            "{:12} {:>8} {:>12.2} {:>12.2} {:>16.3}",
            case.name,
            p.rig.marker_count(),
            median(st) * 1e6,
            median(de) * 1e6,
            ratio
        );
    }
}
