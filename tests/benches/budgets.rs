//! The host budgets, measured in one run (`cargo bench -p facebake-tests --bench budgets`):
//!
//! 1. **Against float skinning.** The default rig (the product's bake: linear deformer) at K = 4
//!    and K = 8 against an f32 loop that does what ozz-animation's `SkinningJob` does with
//!    positions only: per influence a 3 × 4 joint matrix (here each marker's, a translation by
//!    its displacement, as a marker-driven rig would feed a skinning library) blended by the
//!    weight (12 multiply-adds), then the vertex transformed by the blended matrix (9 + 3). The
//!    matrices are built once per frame, as a skinning library receives them. SSE on x86-64,
//!    four lanes per matrix row. (ozz-animation-rs does not build on today's toolchain, so the
//!    loop is ours; it follows SkinningJob's inner loop.) On FaceCap (2,694 vertices) and on
//!    FaceCap subdivided twice (every triangle into four: ~40k vertices).
//! 2. **Against memory bandwidth.** Bytes the default rig reads and writes per frame (influence
//!    words, rest positions, counts, outputs) over the frame time, against a `copy_from_slice`
//!    of 256 MiB measured in the same run.
//! 3. **Across cores.** The 40k face split in two halves deformed on two threads with
//!    `Rig::deform_range`, against one thread.
//!
//! Every ratio is the median over interleaved rounds of the same run (the machine is shared).

use std::hint::black_box;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::Duration;

use facebake::model::{place_markers, FaceMesh};
use facebake::{bake, BakeOptions, Scene};
use facebake_runtime::{FrameTable, Rig};
use facebake_tests::{fixture, interleaved, median, median_ratio};

const ROUNDS: usize = 7;
const SLICE: Duration = Duration::from_millis(120);

/// The FaceCap head, welded, subdivided `times` times (each triangle into four at its edges'
/// midpoints, shared between neighbours).
fn facecap(times: usize) -> FaceMesh {
    let mesh =
        facebake::io::gltf_mesh::load_mesh(&fixture("FaceCapHeadGeneric.glb"), Some("head"), None)
            .expect("FaceCap loads");
    if times == 0 {
        return mesh;
    }
    let mut positions = mesh.welded_positions.clone();
    let mut triangles: Vec<[u32; 3]> = mesh
        .triangles
        .iter()
        .map(|t| t.map(|v| mesh.weld[v as usize]))
        .filter(|t| t[0] != t[1] && t[1] != t[2] && t[0] != t[2])
        .collect();
    for _ in 0..times {
        let mut mid = std::collections::HashMap::new();
        let mut midpoint = |a: u32, b: u32, positions: &mut Vec<[f64; 3]>| {
            *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                let (p, q) = (positions[a as usize], positions[b as usize]);
                positions.push([0, 1, 2].map(|c| 0.5 * (p[c] + q[c])));
                (positions.len() - 1) as u32
            })
        };
        let mut next = Vec::with_capacity(triangles.len() * 4);
        for [a, b, c] in triangles {
            let (ab, bc, ca) = (
                midpoint(a, b, &mut positions),
                midpoint(b, c, &mut positions),
                midpoint(c, a, &mut positions),
            );
            next.extend([[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]);
        }
        triangles = next;
    }
    FaceMesh::from_triangles("head", positions, triangles)
}

/// The default bake of `mesh` with the bundled JawMoCap layout, at K = `k`.
fn default_rig(mesh: &FaceMesh, k: usize) -> Vec<u8> {
    let layout = facebake::io::layout::read_layout(&fixture("facecap_jawmocap_layout.toml"))
        .expect("layout reads");
    let placed = place_markers(&layout, mesh, 0.02).expect("layout places");
    let options = BakeOptions {
        k,
        ..BakeOptions::product_default()
    };
    bake(&Scene::placed(mesh, &placed), &options)
        .expect("bakes")
        .blob
}

/// A linear rig as a float skinning library holds it: per vertex its rest position and K
/// (joint, weight) pairs; per frame one 3 × 4 matrix per joint.
struct Skinning {
    rest: Vec<[f32; 4]>,
    joints: Vec<u8>,
    weights: Vec<f32>,
    k: usize,
}

impl Skinning {
    fn from_rig(rig: &Rig<'_>) -> Self {
        let facebake_runtime::deformer::Deformer::Linear(lin) = rig.deformer() else {
            panic!("the default bake is linear");
        };
        let scale = (1u32 << lin.weight_frac_bits) as f32;
        let k = usize::from(lin.max_influences);
        let (mut joints, mut weights) = (Vec::new(), Vec::new());
        let source = facebake_tests::skinning_joint(lin, rig.marker_count());
        for vertex in lin.vertex_influences() {
            let mut n = 0;
            for (m, q) in vertex.filter(|&(_, q)| q != 0) {
                joints.push(source(m));
                weights.push(f32::from(q) / scale);
                n += 1;
            }
            for _ in n..k {
                joints.push(0);
                weights.push(0.0);
            }
        }
        let one = (1u32 << 24) as f32;
        Self {
            rest: (0..rig.vertex_count())
                .map(|v| {
                    let r = rig.vertex_rest(v).expect("vertex");
                    [r[0] as f32 / one, r[1] as f32 / one, r[2] as f32 / one, 1.0]
                })
                .collect(),
            joints,
            weights,
            k,
        }
    }

    /// SkinningJob's loop, positions only: blend K 3 × 4 matrices (rows as 4 lanes), transform.
    #[cfg(target_arch = "x86_64")]
    fn skin(&self, matrices: &[[[f32; 4]; 3]], out: &mut [[f32; 3]]) {
        use std::arch::x86_64::*;
        // SAFETY: SSE is part of the x86-64 baseline.
        unsafe {
            for (v, (o, r)) in out.iter_mut().zip(&self.rest).enumerate() {
                let mut rows = [_mm_setzero_ps(); 3];
                for j in 0..self.k {
                    let i = v * self.k + j;
                    let w = _mm_set1_ps(self.weights[i]);
                    let m = &matrices[usize::from(self.joints[i])];
                    for (row, mr) in rows.iter_mut().zip(m) {
                        *row = _mm_add_ps(*row, _mm_mul_ps(w, _mm_loadu_ps(mr.as_ptr())));
                    }
                }
                let p = _mm_loadu_ps(r.as_ptr());
                let dot = |row: __m128| {
                    let m = _mm_mul_ps(row, p);
                    let s = _mm_add_ps(m, _mm_movehl_ps(m, m));
                    _mm_cvtss_f32(_mm_add_ss(s, _mm_shuffle_ps::<1>(s, s)))
                };
                *o = [dot(rows[0]), dot(rows[1]), dot(rows[2])];
            }
        }
    }

    #[cfg(not(target_arch = "x86_64"))]
    fn skin(&self, matrices: &[[[f32; 4]; 3]], out: &mut [[f32; 3]]) {
        for (v, (o, r)) in out.iter_mut().zip(&self.rest).enumerate() {
            let mut rows = [[0f32; 4]; 3];
            for j in 0..self.k {
                let i = v * self.k + j;
                let m = &matrices[usize::from(self.joints[i])];
                for (row, mr) in rows.iter_mut().zip(m) {
                    for c in 0..4 {
                        row[c] += self.weights[i] * mr[c];
                    }
                }
            }
            *o = rows.map(|row| (0..4).map(|c| row[c] * r[c]).sum());
        }
    }
}

/// One marker displacement per joint as a translation matrix.
fn matrices(displacements: &[[f32; 3]]) -> Vec<[[f32; 4]; 3]> {
    displacements
        .iter()
        .map(|d| {
            [
                [1.0, 0.0, 0.0, d[0]],
                [0.0, 1.0, 0.0, d[1]],
                [0.0, 0.0, 1.0, d[2]],
            ]
        })
        .collect()
}

/// The markers moved by a few millimetres (rig units), as Q8.24 and as displacements.
fn frame(rig: &Rig<'_>) -> (Vec<[i32; 3]>, Vec<[f32; 3]>) {
    let h = f64::from(rig.space().half_extent);
    let mut rng = facebake::ground_truth::SplitMix64(0xB4D6E7);
    let moved: Vec<([i32; 3], [f32; 3])> = (0..rig.marker_count())
        .map(|m| {
            let r = rig.marker_rest(m).expect("marker");
            let d = [0, 1, 2].map(|_| 0.004 / h * (2.0 * rng.unit() - 1.0));
            let q = [0, 1, 2].map(|c| r[c] + (d[c] * f64::from(1u32 << 24)).round() as i32);
            (q, d.map(|x| x as f32))
        })
        .collect();
    moved.into_iter().unzip()
}

fn main() {
    // `cargo test --benches` runs bench binaries with `--bench`-less args: do nothing then.
    if !std::env::args().any(|a| a == "--bench") {
        return;
    }
    let faces = [
        ("FaceCap", facecap(0)),
        ("FaceCap subdivided once", facecap(1)),
        ("FaceCap subdivided twice", facecap(2)),
    ];
    println!(
        "budgets: the default rig (linear deformer) vs a SkinningJob-style f32 loop, same run"
    );
    let mut big = None;
    for (name, mesh) in &faces {
        for k in [4, 8] {
            let blob = default_rig(mesh, k);
            let rig = Rig::from_bytes(&blob).expect("loads");
            let (q, d) = frame(&rig);
            let skinning = Skinning::from_rig(&rig);
            let n = rig.vertex_count();
            let mut out = vec![[0i32; 3]; n];
            let mut out_f = vec![[0f32; 3]; n];
            let times = interleaved(
                &mut [
                    &mut || rig.deform(black_box(&q), black_box(&mut out)).unwrap(),
                    &mut || skinning.skin(black_box(&matrices(&d)), black_box(&mut out_f)),
                ],
                ROUNDS,
                SLICE,
            );
            let fixed = median(&mut times[0].clone());
            let pairs = match rig.deformer() {
                facebake_runtime::deformer::Deformer::Linear(l) => l.marker_pairs.0.len() / 2,
                _ => 0,
            };
            println!(
                "  {name}, {n} vertices, K = {k}: {:.0} vertices/ms; float skinning takes {:.2}x as long ({pairs} marker pairs)",
                n as f64 / fixed / 1000.0,
                median_ratio(&times[1], &times[0])
            );
            if k == 8 && n > 20_000 {
                // Read: 3 bytes an influence (6 a pair), 6 of rest and 1 of count a vertex;
                // written: 12 a vertex.
                let cost = rig.cost();
                let bytes = cost.influences * 3 + n * (6 + 1 + 12);
                big = Some((blob.clone(), fixed, bytes, n));
                let _ = cost;
            }
        }
    }
    // Bandwidth: the 40k K = 8 rig's bytes per frame over its frame time, against a big copy.
    let (blob, fixed, bytes, n) = big.expect("a K = 8 rig");
    let src = vec![1u8; 256 << 20];
    let mut dst = vec![0u8; 256 << 20];
    let copy = interleaved(
        &mut [&mut || dst.copy_from_slice(black_box(&src))],
        3,
        SLICE,
    );
    let copy_bw = 2.0 * src.len() as f64 / median(&mut copy[0].clone());
    let rig_bw = bytes as f64 / fixed;
    println!(
        "  bandwidth: the {n}-vertex K = 8 frame moves {:.1} MB ({:.1} GB/s) against a 256 MiB copy's {:.1} GB/s (read + write): {:.0} % of it",
        bytes as f64 / 1e6,
        rig_bw / 1e9,
        copy_bw / 1e9,
        100.0 * rig_bw / copy_bw
    );
    // Many small chunks on one thread, as a job system with fine-grained jobs would run them:
    // with Rig::deform_range each chunk redoes the per-frame marker work; with Rig::prepare
    // once and Rig::deform_chunk per chunk it is shared.
    let chunk = 1024;
    let rig = Rig::from_bytes(&blob).expect("loads");
    let (q, _) = frame(&rig);
    let mut out = vec![[0i32; 3]; n];
    let mut chunked = vec![[0i32; 3]; n];
    let mut prepared = vec![[0i32; 3]; n];
    let mut table = Box::new(FrameTable::new());
    let chunk_times = interleaved(
        &mut [
            &mut || rig.deform(black_box(&q), black_box(&mut out)).unwrap(),
            &mut || {
                for (i, c) in chunked.chunks_mut(chunk).enumerate() {
                    rig.deform_range(black_box(&q), i * chunk, c).unwrap();
                }
            },
            &mut || {
                rig.prepare(black_box(&q), &mut table).unwrap();
                for (i, c) in prepared.chunks_mut(chunk).enumerate() {
                    rig.deform_chunk(&table, i * chunk, c).unwrap();
                }
            },
        ],
        ROUNDS,
        SLICE,
    );
    println!(
        "  chunks: the {n}-vertex K = 8 face in {} chunks of {chunk} vertices on one thread takes {:.3}x one Rig::deform with Rig::deform_range, {:.3}x with Rig::prepare + Rig::deform_chunk",
        n.div_ceil(chunk),
        median_ratio(&chunk_times[1], &chunk_times[0]),
        median_ratio(&chunk_times[2], &chunk_times[0])
    );
    assert_eq!(out, prepared, "the prepared chunks equal one frame");
    // Two threads over the 40k face: the frame's marker work prepared once (Rig::prepare), then
    // a worker that lives across frames and spins between them (as a job system's workers do
    // while a frame is in flight; a sleeping worker's wake-up costs more than a 40k frame's half
    // on this virtual machine) deforms the second half with Rig::deform_chunk while this thread
    // deforms the first. `posted` counts the frames handed out, `finished` the frames done.
    let half = n / 2;
    let shared = std::sync::RwLock::new(table);
    let (first, second) = (
        std::sync::Mutex::new(vec![[0i32; 3]; half]),
        std::sync::Mutex::new(vec![[0i32; 3]; n - half]),
    );
    let (posted, finished) = (AtomicU64::new(0), AtomicU64::new(0));
    let stop = AtomicBool::new(false);
    let times = std::thread::scope(|s| {
        s.spawn(|| {
            let mut seen = 0;
            while !stop.load(Ordering::Acquire) {
                let now = posted.load(Ordering::Acquire);
                if now == seen {
                    std::hint::spin_loop();
                    continue;
                }
                seen = now;
                rig.deform_chunk(&shared.read().unwrap(), half, &mut second.lock().unwrap())
                    .unwrap();
                finished.store(seen, Ordering::Release);
            }
        });
        let times = interleaved(
            &mut [
                &mut || rig.deform(black_box(&q), black_box(&mut out)).unwrap(),
                &mut || {
                    rig.prepare(black_box(&q), &mut shared.write().unwrap())
                        .unwrap();
                    let frame = posted.fetch_add(1, Ordering::AcqRel) + 1;
                    rig.deform_chunk(&shared.read().unwrap(), 0, &mut first.lock().unwrap())
                        .unwrap();
                    while finished.load(Ordering::Acquire) != frame {
                        std::hint::spin_loop();
                    }
                },
            ],
            ROUNDS,
            SLICE,
        );
        stop.store(true, Ordering::Release);
        times
    });
    assert_eq!(out, chunked, "the chunks equal one frame");
    let out2: Vec<[i32; 3]> = [first.into_inner().unwrap(), second.into_inner().unwrap()].concat();
    assert_eq!(out, out2, "two halves equal one frame");
    println!(
        "  threads: the {n}-vertex K = 8 face on 2 threads (Rig::prepare, then Rig::deform_chunk on each; a spinning worker) runs {:.2}x as fast as on one (meaningful only with 2 idle cores; load average now {})",
        median_ratio(&times[0], &times[1]),
        std::fs::read_to_string("/proc/loadavg")
            .ok()
            .and_then(|l| l.split_whitespace().next().map(str::to_string))
            .unwrap_or_else(|| "unknown".into())
    );
}
