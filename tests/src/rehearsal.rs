//! Rehearsals of the held-out set on a face with a truth: the truth's expressions played as a
//! capture take (the markers' paths between the neutral and each expression), with what a real
//! take brings (jitter, head motion, dropouts), baked with `bake --capture` and scored against
//! the truth on the frames in between as well as on the held expressions, so that the marker
//! smoothing's lag is charged as well as the jitter it removes.

use facebake::ground_truth::Frame;
use facebake::metrics::{FrameMetrics, Regions, TakeMetrics};
use facebake::model::{Capture, Units};
use facebake::surface::evaluate::Benchmark;
use facebake::{BakeOptions, Baked};
use facebake_runtime::{PlayState, Rig};

use crate::{jittered, moved_and_dropped};

/// How the take is paced and spoilt.
#[derive(Clone, Copy, Debug)]
pub struct Pace {
    /// Frames per second.
    pub rate_hz: f64,
    /// Frames to ease into each expression (a half cosine, as a face starts and stops) and out.
    pub ramp: usize,
    /// Frames each expression is held.
    pub hold: usize,
    /// Uniform jitter on every coordinate, ± metres.
    pub jitter: f64,
    /// Share of the samples dropped (seeded), the head turning and moving as in
    /// [`moved_and_dropped`].
    pub dropped: f64,
    /// Chance, per marker and frame, that the marker is lost for a run of 12 to 120 frames
    /// (seeded): occlusions as a real take has them. 0.00125 loses about 7 % of the samples
    /// in runs of 0.2 to 2 s at 60 Hz.
    pub occlusion_starts: f64,
}

impl Pace {
    /// 60 frames a second, each expression eased in over a third of a second, held for a fifth
    /// and eased out; ±0.5 mm of jitter and 5 % of the samples dropped.
    pub const NATURAL: Self = Self {
        rate_hz: 60.0,
        ramp: 20,
        hold: 12,
        jitter: 0.0005,
        dropped: 0.05,
        occlusion_starts: 0.0,
    };
}

/// Frames at rest before the first expression; they are left out of the score, which starts
/// with the first expression. (Until 2026-12-04 the score skipped 30 frames, so a take eased
/// over 10 frames and held 6 was never scored on its first expression, the jaw open.)
pub const REST_FRAMES: usize = 10;

/// A take made of a truth, and where the truth is at each of its frames.
pub struct Rehearsal {
    /// The take (metres), spoilt as its [`Pace`] says.
    pub capture: Capture,
    /// Per take frame: the truth frame it heads to (`None`: at rest) and how far, 0 to 1.
    keys: Vec<(Option<usize>, f64)>,
}

/// A rig's figures on a rehearsal.
#[derive(Clone, Debug)]
pub struct Score {
    /// Mean error over the skin's vertices and the scored frames, mm.
    pub mean_mm: f64,
    /// 99th percentile of the same errors, mm.
    pub p99_mm: f64,
    /// The structure metrics, worst over the scored frames.
    pub take: TakeMetrics,
}

impl Rehearsal {
    /// The truth of `scene` played at `pace` through its markers.
    pub fn new(scene: &Benchmark, pace: Pace) -> Self {
        let mut keys = vec![(None, 0.0); REST_FRAMES];
        let ease =
            |k: usize| 0.5 - 0.5 * (std::f64::consts::PI * k as f64 / pace.ramp as f64).cos();
        for f in 0..scene.truth.frames.len() {
            keys.extend((1..=pace.ramp).map(|k| (Some(f), ease(k))));
            keys.extend((0..pace.hold).map(|_| (Some(f), 1.0)));
            keys.extend((1..=pace.ramp).map(|k| (Some(f), ease(pace.ramp - k))));
        }
        let rest = scene.markers_of(&scene.truth.mesh.positions);
        let frames = keys
            .iter()
            .map(|&(f, t)| {
                let to = f.map_or_else(
                    || rest.clone(),
                    |f| scene.markers_of(&scene.truth.positions(f)),
                );
                lerp(&rest, &to, t).into_iter().map(Some).collect()
            })
            .collect();
        let clean = Capture {
            source: "rehearsal.csv".into(),
            rate_hz: pace.rate_hz,
            units: Units::Metres,
            marker_names: scene.markers.iter().map(|m| m.name.clone()).collect(),
            frames,
        };
        let mut capture = moved_and_dropped(&jittered(&clean, pace.jitter), pace.dropped, false);
        occlude(&mut capture, pace.occlusion_starts);
        Self { capture, keys }
    }

    /// Bake the scene with this take as its capture.
    pub fn bake(&self, scene: &Benchmark, options: &BakeOptions) -> Baked {
        let mut with_capture = crate::benchmark_scene(scene);
        with_capture.capture = Some(&self.capture);
        facebake::bake(&with_capture, options).expect("the rehearsal bakes")
    }

    /// Play the take through `blob` and score every `every`-th frame past the rest ([`REST_FRAMES`]) against
    /// the truth where the take has it (frame by frame: nothing but the errors is kept).
    pub fn score(&self, scene: &Benchmark, blob: &[u8], every: usize) -> Score {
        let regions =
            Regions::for_mesh(&scene.truth.mesh, &scene.truth.marker_rest(), &[]).expect("regions");
        let (mut errors, mut metrics) = (Vec::new(), Vec::<FrameMetrics>::new());
        self.play(
            scene,
            blob,
            |i| i % every == 0,
            |played, truth, skin| {
                metrics.push(regions.measure(played, Some(truth), false));
                errors.extend(skin);
            },
        );
        let mean_mm = errors.iter().sum::<f64>() / errors.len() as f64;
        errors.sort_by(f64::total_cmp);
        Score {
            mean_mm,
            p99_mm: errors[(errors.len() - 1) * 99 / 100],
            take: TakeMetrics::of(&metrics),
        }
    }

    /// Play the take through `blob` and score the last held frame of each expression (where a
    /// face holds it, after the smoothing has caught up): the skin's mean error against the
    /// truth per expression, in the truth's order, and over them all, mm.
    pub fn score_held(&self, scene: &Benchmark, blob: &[u8]) -> (f64, Vec<f64>) {
        let last_held = |i: usize| {
            matches!(self.keys[i], (Some(_), t) if t == 1.0)
                && self.keys.get(i + 1) != Some(&self.keys[i])
        };
        let (mut all, mut each) = (Vec::new(), Vec::new());
        self.play(scene, blob, last_held, |_, _, skin| {
            let before = all.len();
            all.extend(skin);
            each.push(all[before..].iter().sum::<f64>() / (all.len() - before) as f64);
        });
        (all.iter().sum::<f64>() / all.len() as f64, each)
    }

    /// Play every frame of the take through `blob` (a capture rig) and measure it as `bake`
    /// measures its own take: without a truth, stretch and flips read from rest and beside
    /// them against the mesh's own shapes.
    pub fn measure_from_rest(&self, scene: &Benchmark, blob: &[u8]) -> TakeMetrics {
        let regions =
            Regions::for_mesh(&scene.truth.mesh, &scene.truth.marker_rest(), &[]).expect("regions");
        let mut metrics = Vec::with_capacity(self.capture.frames.len());
        self.each_frame(
            blob,
            |_| true,
            |_, played| {
                metrics.push(regions.measure(played, None, false));
            },
        );
        TakeMetrics::of(&metrics)
    }

    /// Play the take through `blob` (its capture stages; a rig without them deformed by the
    /// take's markers as they are, a missing one at rest); on each frame past the rest that
    /// `keep` takes, call `visit` with the played positions, the truth's and the skin's errors
    /// (mm).
    fn play(
        &self,
        scene: &Benchmark,
        blob: &[u8],
        keep: impl Fn(usize) -> bool,
        mut visit: impl FnMut(&[[f64; 3]], &[[f64; 3]], Vec<f64>),
    ) {
        let keep = |i: usize| i >= REST_FRAMES && keep(i);
        self.each_frame(blob, keep, |i, played| {
            let rest = &scene.truth.mesh.positions;
            let truth = match self.keys[i] {
                (None, _) => rest.clone(),
                (Some(f), t) => lerp(rest, &scene.truth.positions(f), t),
            };
            let skin = (0..played.len())
                .filter(|&v| scene.truth.skin[v])
                .map(|v| 1000.0 * facebake::mesh::distance(&played[v], &truth[v]))
                .collect();
            visit(played, &truth, skin);
        });
    }

    /// Play every frame of the take through `blob` (its capture stages; a rig without them
    /// deformed by the take's markers as they are, a missing one at rest) and call `visit`
    /// with the frame's index and its played positions (asset units) on each frame `keep`
    /// takes.
    fn each_frame(
        &self,
        blob: &[u8],
        keep: impl Fn(usize) -> bool,
        mut visit: impl FnMut(usize, &[[f64; 3]]),
    ) {
        let rig = Rig::from_bytes(blob).expect("the rehearsal's rig loads");
        let (space, actor_space) = (rig.space(), rig.actor_space());
        let mut state = PlayState::new();
        let mut out = vec![[0i32; 3]; rig.vertex_count()];
        for (i, frame) in self.capture.frames.iter().enumerate() {
            match actor_space {
                Some(actor) => {
                    let markers: Vec<Option<[i32; 3]>> = frame
                        .iter()
                        .map(|p| p.and_then(|p| actor.to_rig_f64(p).ok()))
                        .collect();
                    rig.play(&mut state, &markers, &mut out).expect("plays");
                }
                None => {
                    let markers: Vec<[i32; 3]> = frame
                        .iter()
                        .enumerate()
                        .map(|(m, p)| match p {
                            Some(p) => space.to_rig_f64(*p).expect("in the rig's space"),
                            None => rig.marker_rest(m).expect("a marker of the rig"),
                        })
                        .collect();
                    rig.deform(&markers, &mut out).expect("deforms");
                }
            }
            if keep(i) {
                let played: Vec<[f64; 3]> = out.iter().map(|q| space.to_asset_f64(*q)).collect();
                visit(i, &played);
            }
        }
    }
}

/// Blends of targets both faces have, in [`share_expressions`]: as many as the truth's own.
pub const SHARED_BLENDS: usize = 24;

/// Targets mixed in each of those blends, as in the truth's own.
pub const TARGETS_PER_SHARED_BLEND: usize = 4;

/// Make two faces' truths tell the same story, frame by frame, so that one face's take can
/// drive the other and be scored against the other's own shapes: the named expressions both
/// truths hold (each face's as its own truth built it, a side-split target standing for the
/// whole), then [`SHARED_BLENDS`] seeded blends of targets whose names both meshes have. Returns
/// the number of frames.
pub fn share_expressions(actor: &mut Benchmark, character: &mut Benchmark) -> usize {
    let named = |f: &Frame| !f.name.starts_with("blend");
    let (mut ours, mut theirs): (Vec<Frame>, Vec<Frame>) = actor
        .truth
        .frames
        .iter()
        .filter(|f| named(f))
        .filter_map(|f| {
            let other = character.truth.frames.iter().find(|g| g.name == f.name)?;
            Some((f.clone(), other.clone()))
        })
        .unzip();
    let (from, to) = (&actor.truth.mesh, &character.truth.mesh);
    let shared: Vec<(usize, usize)> = (0..from.morph_targets.len())
        .filter(|&i| {
            from.morph_targets[i]
                .deltas
                .iter()
                .flatten()
                .any(|&x| x != 0.0)
        })
        .filter_map(|i| Some((i, to.morph_index(&from.morph_targets[i].name)?)))
        .collect();
    let mut rng = facebake::ground_truth::SplitMix64(0x5EA7_ED00);
    for b in 0..SHARED_BLENDS {
        let mut picked: Vec<((usize, usize), f64)> = Vec::new();
        while picked.len() < TARGETS_PER_SHARED_BLEND.min(shared.len()) {
            let pair = shared[(rng.next_u64() % shared.len() as u64) as usize];
            if picked.iter().all(|p| p.0 != pair) {
                picked.push((pair, 0.2 + 0.8 * rng.unit()));
            }
        }
        let name = format!("blend {b}");
        let weights = |side: fn(&(usize, usize)) -> usize| {
            picked.iter().map(|(pair, w)| (side(pair), *w)).collect()
        };
        ours.push(Frame {
            name: name.clone(),
            weights: weights(|p| p.0),
        });
        theirs.push(Frame {
            name,
            weights: weights(|p| p.1),
        });
    }
    actor.truth.frames = ours;
    character.truth.frames = theirs;
    character.truth.frames.len()
}

/// Lose each marker of `capture` in runs of 12 to 120 frames, a run starting at each frame
/// with chance `starts` (seeded; never in frame 0).
fn occlude(capture: &mut Capture, starts: f64) {
    if starts <= 0.0 {
        return;
    }
    let mut rng = facebake::ground_truth::SplitMix64(0x0CC1);
    let frames = capture.frames.len();
    for marker in 0..capture.marker_names.len() {
        let mut f = 1;
        while f < frames {
            if rng.unit() < starts {
                let run = 12 + (rng.unit() * 108.0) as usize;
                for frame in &mut capture.frames[f..(f + run).min(frames)] {
                    frame[marker] = None;
                }
                f += run;
            }
            f += 1;
        }
    }
}

/// `from` moved `t` of the way to `to`, point by point.
fn lerp(from: &[[f64; 3]], to: &[[f64; 3]], t: f64) -> Vec<[f64; 3]> {
    from.iter()
        .zip(to)
        .map(|(p, q)| [0, 1, 2].map(|c| p[c] + t * (q[c] - p[c])))
        .collect()
}
