//! The runtime never allocates: loading a rig, asking its cost and marker names, and deforming
//! many frames of both golden rigs (computing their normals, fanned and planned, and again in
//! chunks from one prepared `FrameTable`) make no heap allocation.
//!
//! A counting global allocator wraps the system one and counts allocations made by this thread
//! while a thread-local flag is set, so the test harness's other threads do not disturb it.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

use facebake_runtime::Rig;

struct Counting;

thread_local! {
    static COUNTING: Cell<bool> = const { Cell::new(false) };
    static ALLOCATIONS: Cell<usize> = const { Cell::new(0) };
}

fn note_allocation() {
    // `try_with`: thread-local storage may already be gone while a thread shuts down.
    let _ = COUNTING.try_with(|on| {
        if on.get() {
            let _ = ALLOCATIONS.try_with(|n| n.set(n.get() + 1));
        }
    });
}

// SAFETY: every call is forwarded unchanged to `System`, which upholds `GlobalAlloc`'s contract;
// the counting touches only thread-local `Cell`s and never allocates.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        note_allocation();
        // SAFETY: forwarded with the caller's layout.
        unsafe { System.alloc(layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        note_allocation();
        // SAFETY: forwarded with the caller's layout.
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        note_allocation();
        // SAFETY: `ptr` came from this allocator, i.e. from `System`, with `layout`.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: `ptr` came from this allocator, i.e. from `System`, with `layout`.
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// Allocations `f` makes on this thread.
fn allocations_in<R>(f: impl FnOnce() -> R) -> (usize, R) {
    ALLOCATIONS.with(|n| n.set(0));
    COUNTING.with(|on| on.set(true));
    let r = f();
    COUNTING.with(|on| on.set(false));
    (ALLOCATIONS.with(Cell::get), r)
}

const MARKERS: &[u8] = include_bytes!("../../fixtures/golden/facecap_markers.bin");
const LAYOUT_MARKERS: &[u8] = include_bytes!("../../fixtures/golden/facecap_layout_markers.bin");
/// The golden deform rigs, each with its marker frames.
const BLOBS: [(&[u8], &[u8]); 5] = [
    (
        include_bytes!("../../fixtures/golden/facecap_coefficients.fbk"),
        MARKERS,
    ),
    (
        include_bytes!("../../fixtures/golden/facecap_weights.fbk"),
        MARKERS,
    ),
    (
        include_bytes!("../../fixtures/golden/facecap_coefficients_k4.fbk"),
        MARKERS,
    ),
    (
        include_bytes!("../../fixtures/golden/facecap_product.fbk"),
        LAYOUT_MARKERS,
    ),
    (
        include_bytes!("../../fixtures/golden/facecap_planar.fbk"),
        MARKERS,
    ),
];

/// A marker file's frames, as one run of markers.
fn marker_words(file: &[u8]) -> Vec<[i32; 3]> {
    let words: Vec<i32> = file
        .chunks_exact(4)
        .map(|b| i32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect();
    words.chunks_exact(3).map(|p| [p[0], p[1], p[2]]).collect()
}

#[test]
fn the_counter_sees_an_allocation() {
    // The control: without it, a broken counter would make the real test pass vacuously.
    let (n, v) = allocations_in(|| vec![0u8; 4]);
    assert_eq!(n, 1);
    assert_eq!(v.len(), 4);
}

#[test]
fn loading_and_deforming_never_allocate() {
    // Inputs and outputs are prepared before counting starts.
    let mut out = vec![[0i32; 3]; 4096];
    let mut normals = vec![[0i16; 3]; 4096];
    let mut table = Box::new(facebake_runtime::FrameTable::new());
    let mut sums = vec![[0i64; 3]; 4096];
    let mut triangles = vec![[0u32; 3]; 16384];
    let mut played = 0usize;
    for (blob, marker_file) in BLOBS {
        let frames = marker_words(marker_file);
        let (n, ()) = allocations_in(|| {
            let rig = Rig::from_bytes(blob).expect("golden rig loads");
            let (m, v) = (rig.marker_count(), rig.vertex_count());
            assert!(rig.cost().influences > 0);
            assert_eq!(rig.marker_names().count(), m);
            let last = rig.marker_names().last().expect("named markers");
            assert_eq!(rig.marker_index(last), Some(m - 1));
            let out = &mut out[..v];
            let normals = &mut normals[..v];
            let sums = &mut sums[..v];
            let plan = rig
                .plan_normals(&mut triangles[..rig.normals_plan_len()])
                .unwrap();
            // Every frame of the golden sequence, three times over, with its normals.
            for markers in frames.chunks_exact(m).cycle().take(3 * frames.len() / m) {
                rig.deform_report(markers, out).unwrap();
                rig.normals(out, normals).unwrap();
                rig.normals_planned(out, &plan, sums, normals).unwrap();
                // The same frame in two chunks from one prepared table.
                rig.prepare(markers, &mut table).unwrap();
                let (a, b) = out.split_at_mut(v / 2);
                rig.deform_chunk(&table, 0, a).unwrap();
                rig.deform_chunk(&table, v / 2, b).unwrap();
                played += 1;
            }
        });
        assert_eq!(n, 0, "the runtime allocated {n} times");
    }
    assert_eq!(played, BLOBS.len() * 3 * 39);
}

const CAPTURE: &[u8] = include_bytes!("../../fixtures/golden/jawmocap_capture.fbk");
const ACTOR: &[u8] = include_bytes!("../../fixtures/golden/jawmocap_actor.bin");

/// `Rig::play` on the capture golden (compensation with the head-marker distance check and
/// smoothing, the step gate, fill, smoothing, retargeting, deformation) never allocates, the
/// `PlayState` included.
#[test]
fn playing_captured_frames_never_allocates() {
    let record = 13;
    let m = Rig::from_bytes(CAPTURE).unwrap().marker_count();
    let frames: Vec<Vec<Option<[i32; 3]>>> = ACTOR
        .chunks_exact(m * record)
        .map(|f| {
            f.chunks_exact(record)
                .map(|r| {
                    let w = |i: usize| i32::from_le_bytes([r[i], r[i + 1], r[i + 2], r[i + 3]]);
                    (r[0] == 1).then(|| [w(1), w(5), w(9)])
                })
                .collect()
        })
        .collect();
    let mut out = vec![[0i32; 3]; 4096];
    let mut normals = vec![[0i16; 3]; 4096];
    let mut played = 0usize;
    let (n, ()) = allocations_in(|| {
        let rig = Rig::from_bytes(CAPTURE).expect("capture golden loads");
        let out = &mut out[..rig.vertex_count()];
        let normals = &mut normals[..rig.vertex_count()];
        let mut state = facebake_runtime::PlayState::new();
        for actor in frames.iter().cycle().take(3 * frames.len()) {
            rig.play(&mut state, actor, out).unwrap();
            rig.normals(out, normals).unwrap();
            played += 1;
        }
    });
    assert_eq!(n, 0, "the runtime allocated {n} times");
    assert_eq!(played, 3 * frames.len());
}

const TAKE: &[u8] = include_bytes!("../../fixtures/golden/jawmocap.fbt");

/// Loading a packed take, decoding every frame and seeking never allocate.
#[test]
fn decoding_and_seeking_a_packed_take_never_allocates() {
    let mut row = vec![None; facebake_runtime::MAX_MARKERS];
    let mut decoded = 0usize;
    let (n, ()) = allocations_in(|| {
        let take = facebake_runtime::Take::from_bytes(TAKE).expect("golden take loads");
        let row = &mut row[..take.marker_count()];
        let mut reader = take.reader();
        while reader.next_frame(row).unwrap().is_some() {
            decoded += 1;
        }
        for f in [1000, 3, 1589, 0] {
            reader.seek(f).unwrap();
            reader.next_frame(row).unwrap();
        }
    });
    assert_eq!(n, 0, "the take reader allocated {n} times");
    assert_eq!(decoded, 1590);
}
