//! Per-frame cost of the runtime's fixed-point kernel against two float baselines.
//!
//! Rigs (one criterion group each, so the figures inside a group compare like with like):
//!
//! * the FaceCap ground-truth bake (2694 vertices, 40 markers) at K = 8 and K = 4, fed the
//!   "jaw open" frame's real marker positions;
//! * a synthetic 50,000-vertex bumpy-ellipsoid "head" with 60 farthest-point markers, markers
//!   moved by up to 5 mm, at K = 4 and K = 8.
//!
//! Each is baked in both runtime forms: `weights` (the linear kernel: K weights per vertex on
//! marker displacements; IMQ, width 2 × marker spacing, as [`facebake_tests::weights_config`])
//! and `coefficients` (the default bake: per-frame RBF coefficients, K kernel terms per vertex).
//!
//! Paths:
//!
//! * `fixed`: [`Rig::deform`], the no_std Q8.24 runtime;
//! * `f32` (linear deformer): [`F32Rig`], the same sparse rig decoded once from the blob's own
//!   quantised numbers into f32 and evaluated with the same per-vertex gather, as a float
//!   linear-blend-skinning library's positions-only path would; on x86-64 hand-vectorised with
//!   SSE like the fixed-point kernel (one `[x, y, z, 0]` vector per marker, `mulps` + `addps` per
//!   influence), so the two are equally optimised;
//! * `dense_f64` (FaceCap): the papers' per-frame RBF of the same configuration
//!   ([`facebake::deformer::rbf::DenseRbf::frame`]: solve, then evaluate every vertex against every
//!   marker).
//!
//! Every benchmark's throughput is the sparse rig's influence count (Σ per-vertex counts), so
//! criterion's `elem/s` reads as vertex-influences per second (for `dense_f64`, the same work
//! delivered: the rig's output per second).
//!
//! After the criterion groups, when run by `cargo bench`, a same-run table of ratios is printed:
//! every path of a rig is timed in interleaved `Instant` loops of equal duration after a warm-up,
//! and each ratio is the median of per-round ratios, so machine noise hits both sides alike.
//!
//! Run: `cargo bench -p facebake-tests --bench runtime`.

use std::hint::black_box;
use std::time::Duration;

use criterion::{Criterion, Throughput};
use facebake::geodesic::Source;
use facebake::ground_truth::SplitMix64;
use facebake::mesh::farthest_point_sampling;
use facebake::model::FaceMesh;
use facebake::surface::SurfaceMarker;
use facebake::{bake, BakeOptions, Baked, DeformerKind, Scene};
use facebake_runtime::deformer::Deformer;
use facebake_runtime::fixed::POS_FRAC_BITS;
use facebake_runtime::format::records::MAX_MARKERS;
use facebake_runtime::Rig;
use facebake_tests::{bake_truth, facecap_truth, median, median_ratio, weights_config};

/// Vertices of the synthetic head.
const SYNTH_VERTICES: usize = 50_000;
/// Markers on the synthetic head.
const SYNTH_MARKERS: usize = 60;
/// Criterion measurement time per benchmark.
const MEASUREMENT: Duration = Duration::from_secs(3);
/// Criterion warm-up time per benchmark.
const WARM_UP: Duration = Duration::from_secs(1);
/// Criterion samples per benchmark.
const SAMPLES: usize = 30;
/// Same-run ratio table: timed rounds (after one warm-up round) and time per path per round.
const ROUNDS: usize = 9;
/// See [`ROUNDS`].
const SLICE: Duration = Duration::from_millis(80);
/// The reference point the brief quotes for a float linear-blend-skinning library on one core:
/// (K, vertices per millisecond).
const LBS_REFERENCE: [(usize, f64); 2] = [(4, 200_000.0), (8, 100_000.0)];

/// One rig unit (Q8.24 one) as f32.
const Q24: f32 = (1u32 << POS_FRAC_BITS) as f32;

/// A baked rig's sparse weights decoded to f32, evaluated the way a float skinning library does.
///
/// Everything is in rig units (the Q8.24 values divided by 2²⁴), taken from the blob's own
/// quantised numbers, so it computes the same function as [`Rig::deform`] up to f32 rounding.
struct F32Rig {
    /// Vertex rest positions.
    rest: Vec<[f32; 3]>,
    /// Influences per vertex.
    counts: Vec<u8>,
    /// Marker index of each influence, vertex after vertex.
    markers: Vec<u8>,
    /// Weight of each influence, parallel to `markers`.
    weights: Vec<f32>,
    /// Marker rest positions.
    marker_rest: Vec<[f32; 3]>,
}

impl F32Rig {
    /// Decode `rig` once: rest positions, weights and marker rest positions; `None` unless it
    /// is a weights-form (linear) rig.
    fn from_rig(rig: &Rig<'_>) -> Option<Self> {
        let Deformer::Linear(lin) = rig.deformer() else {
            return None;
        };
        let to_f32 = |q: [i32; 3]| q.map(|c| c as f32 / Q24);
        let scale = (1u32 << lin.weight_frac_bits) as f32;
        let (mut counts, mut markers, mut weights) = (Vec::new(), Vec::new(), Vec::new());
        let source = facebake_tests::skinning_joint(lin, rig.marker_count());
        for vertex in lin.vertex_influences() {
            let before = markers.len();
            for (m, q) in vertex.filter(|&(_, q)| q != 0) {
                markers.push(source(m));
                weights.push(f32::from(q) / scale);
            }
            counts.push((markers.len() - before) as u8);
        }
        Some(Self {
            rest: (0..rig.vertex_count())
                .filter_map(|i| rig.vertex_rest(i))
                .map(to_f32)
                .collect(),
            counts,
            markers,
            weights,
            marker_rest: (0..rig.marker_count())
                .filter_map(|i| rig.marker_rest(i))
                .map(to_f32)
                .collect(),
        })
    }

    /// `out[v] = rest[v] + Σ w · (m − m_rest)`, f32 throughout, one gather per influence.
    ///
    /// `markers` has one entry per rig marker, `out` one per vertex. On x86-64 this is
    /// [`Self::deform_sse`], as hand-vectorised as the fixed-point kernel; elsewhere
    /// [`Self::deform_portable`].
    fn deform(&self, markers: &[[f32; 3]], out: &mut [[f32; 3]]) {
        assert_eq!(markers.len(), self.marker_rest.len());
        assert_eq!(out.len(), self.rest.len());
        #[cfg(target_arch = "x86_64")]
        // SAFETY: SSE2 is part of the x86-64 baseline: every CPU that runs this has it.
        unsafe {
            self.deform_sse(markers, out)
        }
        #[cfg(not(target_arch = "x86_64"))]
        self.deform_portable(markers, out)
    }

    /// [`Self::deform`] in plain Rust (LLVM vectorises what it can).
    fn deform_portable(&self, markers: &[[f32; 3]], out: &mut [[f32; 3]]) {
        // A u8 index into a 256-entry table: no bounds check in the loop.
        let mut displacements = [[0f32; 3]; MAX_MARKERS];
        for ((d, m), r) in displacements.iter_mut().zip(markers).zip(&self.marker_rest) {
            *d = [m[0] - r[0], m[1] - r[1], m[2] - r[2]];
        }
        let mut influences = self.markers.iter().zip(&self.weights);
        for ((o, r), &count) in out.iter_mut().zip(&self.rest).zip(&self.counts) {
            let mut acc = [0f32; 3];
            for (&m, &w) in influences.by_ref().take(usize::from(count)) {
                let d = &displacements[usize::from(m)];
                acc[0] += w * d[0];
                acc[1] += w * d[1];
                acc[2] += w * d[2];
            }
            *o = [r[0] + acc[0], r[1] + acc[1], r[2] + acc[2]];
        }
    }

    /// [`Self::deform`] with SSE: one 128-bit `[x, y, z, 0]` displacement per marker, and per
    /// influence one broadcast weight, one `mulps` and one `addps`, the rest position as the
    /// starting sum: what a float skinning library's SIMD path does.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "sse2")]
    fn deform_sse(&self, markers: &[[f32; 3]], out: &mut [[f32; 3]]) {
        use std::arch::x86_64::{
            _mm_add_ps, _mm_castps_si128, _mm_cvtsi128_si32, _mm_cvtsi128_si64, _mm_mul_ps,
            _mm_set1_ps, _mm_set_ps, _mm_setzero_ps, _mm_shuffle_epi32,
        };
        let mut table = [_mm_setzero_ps(); MAX_MARKERS];
        for ((t, m), r) in table.iter_mut().zip(markers).zip(&self.marker_rest) {
            *t = _mm_set_ps(0.0, m[2] - r[2], m[1] - r[1], m[0] - r[0]);
        }
        let mut influences = self.markers.iter().zip(&self.weights);
        for ((o, r), &count) in out.iter_mut().zip(&self.rest).zip(&self.counts) {
            let mut acc = _mm_set_ps(0.0, r[2], r[1], r[0]);
            for (&m, &w) in influences.by_ref().take(usize::from(count)) {
                acc = _mm_add_ps(acc, _mm_mul_ps(_mm_set1_ps(w), table[usize::from(m)]));
            }
            let bits = _mm_castps_si128(acc);
            let xy = _mm_cvtsi128_si64(bits) as u64;
            *o = [
                f32::from_bits(xy as u32),
                f32::from_bits((xy >> 32) as u32),
                f32::from_bits(_mm_cvtsi128_si32(_mm_shuffle_epi32::<0b10>(bits)) as u32),
            ];
        }
    }
}

/// One baked rig with one frame of input for every path.
struct Case {
    /// Label in criterion ids and the table.
    name: String,
    /// The bake (blob and dense reference).
    baked: Baked,
    /// Marker positions in rig units (Q8.24), for [`Rig::deform`].
    markers_q: Vec<[i32; 3]>,
    /// The same in rig units as f32, for [`F32Rig::deform`].
    markers_f32: Vec<[f32; 3]>,
    /// The same in asset units, for the dense reference.
    markers_f64: Vec<[f64; 3]>,
    /// Whether to time the dense f64 RBF.
    dense: bool,
}

impl Case {
    /// A case from a bake and the frame's marker positions in asset units.
    fn new(name: String, baked: Baked, markers_f64: Vec<[f64; 3]>, dense: bool) -> Self {
        let rig = Rig::from_bytes(&baked.blob).expect("the bake loads");
        let space = rig.space();
        let markers_q: Vec<[i32; 3]> = markers_f64
            .iter()
            .map(|p| space.to_rig_f64(*p).expect("markers in range"))
            .collect();
        let markers_f32 = markers_q
            .iter()
            .map(|q| q.map(|c| c as f32 / Q24))
            .collect();
        Self {
            name,
            baked,
            markers_q,
            markers_f32,
            markers_f64,
            dense,
        }
    }
}

/// The loaded rig, its f32 decoding and output buffers: everything a timed call touches.
struct Prepared<'a> {
    case: &'a Case,
    rig: Rig<'a>,
    f32_rig: Option<F32Rig>,
    out_q: Vec<[i32; 3]>,
    out_f32: Vec<[f32; 3]>,
}

impl<'a> Prepared<'a> {
    /// Load `case` and check that the f32 path (if any) computes what the fixed path does.
    fn new(case: &'a Case) -> Self {
        let rig = Rig::from_bytes(&case.baked.blob).expect("the bake loads");
        let mut p = Self {
            case,
            rig,
            f32_rig: F32Rig::from_rig(&rig),
            out_q: vec![[0; 3]; rig.vertex_count()],
            out_f32: vec![[0.0; 3]; rig.vertex_count()],
        };
        if p.f32_rig.is_some() {
            p.fixed();
            p.float_plain();
            let plain = p.out_f32.clone();
            p.float();
            let apart = plain
                .iter()
                .zip(&p.out_f32)
                .flat_map(|(a, b)| (0..3).map(move |c| (a[c] - b[c]).abs()))
                .fold(0f32, f32::max);
            assert!(
                apart < 1e-5,
                "{}: the two f32 paths differ by {apart}",
                case.name
            );
            let worst = p
                .out_q
                .iter()
                .zip(&p.out_f32)
                .flat_map(|(q, f)| (0..3).map(move |c| (q[c] as f32 / Q24 - f[c]).abs()))
                .fold(0f32, f32::max);
            assert!(
                worst < 1e-4,
                "{}: f32 and fixed paths differ by {worst} rig units",
                case.name
            );
        }
        p
    }

    /// One fixed-point frame.
    fn fixed(&mut self) {
        self.rig
            .deform(black_box(&self.case.markers_q), &mut self.out_q)
            .expect("frame shape");
        black_box(&self.out_q);
    }

    /// One f32 frame (linear deformer only; a no-op otherwise).
    fn float(&mut self) {
        if let Some(f) = &self.f32_rig {
            f.deform(black_box(&self.case.markers_f32), &mut self.out_f32);
        }
        black_box(&self.out_f32);
    }

    /// One f32 frame of the plain-Rust evaluation (linear deformer only; a no-op otherwise).
    fn float_plain(&mut self) {
        if let Some(f) = &self.f32_rig {
            f.deform_portable(black_box(&self.case.markers_f32), &mut self.out_f32);
        }
        black_box(&self.out_f32);
    }

    /// One dense f64 frame.
    fn dense(&self) {
        black_box(
            self.case
                .baked
                .reference
                .deformer
                .frame(black_box(&self.case.markers_f64)),
        );
    }

    /// Σ per-vertex influence counts.
    fn influences(&self) -> usize {
        self.rig.cost().influences
    }
}

/// The weights-form configuration at `k`.
fn weights_at(k: usize) -> BakeOptions {
    BakeOptions {
        k,
        ..weights_config()
    }
}

/// The default (coefficients-form) configuration at `k`.
fn coefficients_at(k: usize) -> BakeOptions {
    BakeOptions {
        k,
        ..BakeOptions::default()
    }
}

/// Short name of a form, for ids.
fn form_name(form: DeformerKind) -> &'static str {
    match form {
        DeformerKind::Linear => "weights",
        DeformerKind::Rbf => "coefficients",
        DeformerKind::Planar => "planar",
    }
}

/// The FaceCap bakes, both forms at K = 8 and K = 4, fed the "jaw open" frame.
fn facecap_cases() -> Vec<Case> {
    let truth = facecap_truth();
    let markers = truth.markers_of(&truth.positions(facebake_tests::jaw_open_frame(&truth)));
    let configs = [8, 4]
        .into_iter()
        .flat_map(|k| [weights_at(k), coefficients_at(k)]);
    configs
        .map(|config| {
            let name = format!("facecap_{}_k{}", form_name(config.deformer), config.k);
            Case::new(name, bake_truth(&truth, &config), markers.clone(), true)
        })
        .collect()
}

/// A deterministic bumpy ellipsoid of `n` vertices about 0.2 m tall (a Fibonacci lattice, so
/// consecutive vertices are neighbours, as in a real mesh's vertex order).
fn synthetic_head(n: usize) -> Vec<[f64; 3]> {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..n)
        .map(|i| {
            let y = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
            let ring = (1.0 - y * y).sqrt();
            let theta = golden * i as f64;
            let (x, z) = (ring * theta.cos(), ring * theta.sin());
            let bump = 1.0 + 0.04 * (5.0 * theta).sin() * (4.0 * y).cos() + 0.02 * (9.0 * y).sin();
            [0.075 * bump * x, 0.1 * bump * y, 0.085 * bump * z]
        })
        .collect()
}

/// The synthetic 50k head, both forms at K = 4 and K = 8, markers moved by a few millimetres.
fn synthetic_cases() -> Vec<Case> {
    let vertices = synthetic_head(SYNTH_VERTICES);
    let all: Vec<u32> = (0..vertices.len() as u32).collect();
    let picks = farthest_point_sampling(&vertices, &all, SYNTH_MARKERS, 0).expect("markers");
    let marker_rest: Vec<[f64; 3]> = picks.iter().map(|&v| vertices[v as usize]).collect();
    let names: Vec<String> = (0..picks.len()).map(|i| format!("S{i:02}")).collect();
    let mut rng = SplitMix64(0x5EED_50CA);
    let markers: Vec<[f64; 3]> = marker_rest
        .iter()
        .map(|p| p.map(|c| c + 0.005 * (2.0 * rng.unit() - 1.0)))
        .collect();
    let mesh = FaceMesh::from_triangles("synthetic", vertices, Vec::new());
    let scene = Scene::new(
        &mesh,
        names
            .into_iter()
            .zip(&picks)
            .map(|(name, &v)| SurfaceMarker {
                name,
                rest: mesh.positions[v as usize],
                source: Source::Vertex(mesh.weld[v as usize]),
                stiffness: 1.0,
            })
            .collect(),
    );
    let configs = [4, 8]
        .into_iter()
        .flat_map(|k| [weights_at(k), coefficients_at(k)]);
    configs
        .map(|config| {
            let name = format!("synthetic50k_{}_k{}", form_name(config.deformer), config.k);
            let baked = bake(&scene, &config).expect("the synthetic head bakes");
            Case::new(name, baked, markers.clone(), false)
        })
        .collect()
}

/// One criterion group per rig: fixed, f32 (linear deformer) and dense f64 (FaceCap).
fn bench_case(c: &mut Criterion, case: &Case) {
    let mut p = Prepared::new(case);
    let mut group = c.benchmark_group(&case.name);
    group
        .throughput(Throughput::Elements(p.influences() as u64))
        .sample_size(SAMPLES)
        .warm_up_time(WARM_UP)
        .measurement_time(MEASUREMENT);
    group.bench_function("fixed", |b| b.iter(|| p.fixed()));
    if p.f32_rig.is_some() {
        group.bench_function("f32", |b| b.iter(|| p.float()));
        group.bench_function("f32_plain", |b| b.iter(|| p.float_plain()));
    }
    if case.dense {
        group.bench_function("dense_f64", |b| b.iter(|| p.dense()));
    }
    group.finish();
}

/// [`facebake_tests::interleaved`] with this bench's rounds and slices.
fn interleaved(paths: &mut [&mut dyn FnMut()]) -> Vec<Vec<f64>> {
    facebake_tests::interleaved(paths, ROUNDS, SLICE)
}

/// Same-run figures of one rig: median seconds per frame of each path and ratios.
struct Row {
    fixed: f64,
    f32: Option<f64>,
    f32_plain: Option<f64>,
    dense: Option<f64>,
    fixed_over_f32: Option<f64>,
    fixed_over_f32_plain: Option<f64>,
    dense_over_fixed: Option<f64>,
}

/// Time the paths of one rig interleaved.
fn measure(case: &Case) -> Row {
    let mut p = Prepared::new(case);
    let has_f32 = p.f32_rig.is_some();
    let p = std::cell::RefCell::new(&mut p);
    let mut fixed = || p.borrow_mut().fixed();
    let mut float = || p.borrow_mut().float();
    let mut float_plain = || p.borrow_mut().float_plain();
    let mut dense = || p.borrow().dense();
    let mut paths: Vec<&mut dyn FnMut()> = vec![&mut fixed];
    if has_f32 {
        paths.push(&mut float);
        paths.push(&mut float_plain);
    }
    if case.dense {
        paths.push(&mut dense);
    }
    let mut times = interleaved(&mut paths);
    let f32_at = has_f32.then_some(1);
    let plain_at = has_f32.then_some(2);
    let dense_at = case.dense.then_some(1 + 2 * usize::from(has_f32));
    let fixed_over_f32 = f32_at.map(|i| median_ratio(&times[0], &times[i]));
    let fixed_over_f32_plain = plain_at.map(|i| median_ratio(&times[0], &times[i]));
    let dense_over_fixed = dense_at.map(|i| median_ratio(&times[i], &times[0]));
    let t: Vec<f64> = times.iter_mut().map(|t| median(t)).collect();
    Row {
        fixed: t[0],
        f32: f32_at.map(|i| t[i]),
        f32_plain: plain_at.map(|i| t[i]),
        dense: dense_at.map(|i| t[i]),
        fixed_over_f32,
        fixed_over_f32_plain,
        dense_over_fixed,
    }
}

/// The same-run ratio table (see the module docs).
fn summary(cases: &[Case]) {
    println!();
    println!(
        "Same-run ratios: paths of a rig interleaved, {ROUNDS} rounds × {} ms each after a \
         warm-up round; times are medians, ratios medians of per-round ratios",
        SLICE.as_millis()
    );
    println!(
        "{:<28} {:>6} {:>2} {:>9} {:>8} {:>8} {:>9} {:>9} {:>11} {:>11} {:>13} {:>11}",
        "rig",
        "verts",
        "K",
        "fixed µs",
        "f32 µs",
        "plain µs",
        "dense µs",
        "fixed/f32",
        "fixed/plain",
        "dense/fixed",
        "fixed vert/ms",
        "f32 vert/ms"
    );
    for case in cases {
        let row = measure(case);
        let rig = Rig::from_bytes(&case.baked.blob).expect("the bake loads");
        let (vertices, cost) = (rig.vertex_count(), rig.cost());
        let us = |s: Option<f64>| s.map_or("-".into(), |s| format!("{:.1}", s * 1e6));
        let per_ms = |s: Option<f64>| {
            s.map_or("-".into(), |s| {
                format!("{:.0}", vertices as f64 / (s * 1e3))
            })
        };
        let ratio = |r: Option<f64>| r.map_or("-".into(), |r| format!("{r:.2}"));
        println!(
            "{:<28} {:>6} {:>2} {:>9} {:>8} {:>8} {:>9} {:>9} {:>11} {:>11} {:>13} {:>11}",
            case.name,
            vertices,
            cost.max_influences,
            us(Some(row.fixed)),
            us(row.f32),
            us(row.f32_plain),
            us(row.dense),
            ratio(row.fixed_over_f32),
            ratio(row.fixed_over_f32_plain),
            row.dense_over_fixed
                .map_or("-".into(), |r| format!("{r:.0}×")),
            per_ms(Some(row.fixed)),
            per_ms(row.f32),
        );
    }
    for (k, reference) in LBS_REFERENCE {
        println!(
            "reference: float linear-blend skinning, K={k}: ~{reference:.0} vertices/ms on one core"
        );
    }
}

/// Criterion groups for every rig, then (under `cargo bench`) the same-run ratio table.
fn main() {
    let mut cases = facecap_cases();
    cases.extend(synthetic_cases());
    let mut c = Criterion::default().configure_from_args();
    for case in &cases {
        bench_case(&mut c, case);
    }
    c.final_summary();
    // `cargo bench` passes `--bench`; `cargo test --benches` does not and only smoke-tests.
    if std::env::args().any(|a| a == "--bench") {
        summary(&cases);
    }
}
