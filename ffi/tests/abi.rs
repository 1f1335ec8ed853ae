//! The C ABI driven through its `extern "C"` functions, as a C caller would: golden frames hash
//! as the Rust API's (and as `hashes.txt` records), the `f32` paths agree with the Rust
//! conversions, and every misuse the ABI can detect returns its error code and writes nothing.

use std::ptr::{null, null_mut};

use facebake_ffi::*;
use facebake_runtime::checksum::Fnv1a64;
use facebake_runtime::{PlayState, Rig};

const COEFFICIENTS: &[u8] = include_bytes!("../../fixtures/golden/facecap_coefficients.fbk");
const MARKERS: &[u8] = include_bytes!("../../fixtures/golden/facecap_markers.bin");
const CAPTURE: &[u8] = include_bytes!("../../fixtures/golden/jawmocap_capture.fbk");
const ACTOR: &[u8] = include_bytes!("../../fixtures/golden/jawmocap_actor.bin");
const HASHES: &str = include_str!("../../fixtures/golden/hashes.txt");
const NORMALS: &str = include_str!("../../fixtures/golden/hashes_normals.txt");
const TAKE: &[u8] = include_bytes!("../../fixtures/golden/jawmocap.fbt");
const TAKE_HASHES: &str = include_str!("../../fixtures/golden/hashes_take.txt");

/// Storage aligned to 16 bytes (more than any `_align` function asks; checked).
struct Storage(Vec<u128>);

impl Storage {
    fn new(size: usize, align: usize) -> Self {
        assert!(align <= 16 && align.is_power_of_two());
        Self(vec![0; size.div_ceil(16) + 1])
    }
    fn ptr<T>(&mut self) -> *mut T {
        self.0.as_mut_ptr().cast()
    }
    fn len(&self) -> usize {
        self.0.len() * 16
    }
}

/// A rig loaded through the ABI, in its own storage.
struct Loaded {
    storage: Storage,
}

impl Loaded {
    fn new(blob: &'static [u8]) -> Self {
        let mut storage = Storage::new(fb_rig_size(), fb_rig_align());
        let len = storage.len();
        let status = unsafe { fb_rig_load(blob.as_ptr(), blob.len(), storage.ptr(), len) };
        assert_eq!(status, FbError::None);
        Self { storage }
    }
    fn rig(&mut self) -> *const FbRig {
        self.storage.ptr::<FbRig>()
    }
}

fn new_state() -> Storage {
    let mut s = Storage::new(fb_play_state_size(), fb_play_state_align());
    let len = s.len();
    assert_eq!(unsafe { fb_play_state_init(s.ptr(), len) }, FbError::None);
    s
}

fn expected(rig: &str, what: &str) -> u64 {
    let key = format!("{rig} {what} ");
    let line = HASHES
        .lines()
        .find(|l| l.starts_with(&key))
        .unwrap_or_else(|| panic!("hashes.txt has no line for {rig} {what}"));
    u64::from_str_radix(&line[key.len()..], 16).expect("a 64-bit hex hash")
}

fn le_words(bytes: &[u8]) -> Vec<i32> {
    bytes
        .chunks_exact(4)
        .map(|b| i32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect()
}

/// The actor frames of the capture golden: per frame, flat x y z words and presence bytes.
fn actor_frames(markers: usize) -> Vec<(Vec<i32>, Vec<u8>)> {
    let record = 1 + 12;
    ACTOR
        .chunks_exact(markers * record)
        .map(|frame| {
            let present = frame.chunks_exact(record).map(|r| r[0]).collect();
            let xyz = frame
                .chunks_exact(record)
                .flat_map(|r| le_words(&r[1..]))
                .collect();
            (xyz, present)
        })
        .collect()
}

fn triples(flat: &[i32]) -> Vec<[i32; 3]> {
    flat.chunks_exact(3).map(|p| [p[0], p[1], p[2]]).collect()
}

#[test]
fn every_golden_deform_frame_hashes_as_the_rust_api_and_hashes_txt() {
    let mut loaded = Loaded::new(COEFFICIENTS);
    let ffi = loaded.rig();
    let rig = Rig::from_bytes(COEFFICIENTS).unwrap();
    let (n, m) = unsafe { (fb_rig_vertex_count(ffi), fb_rig_marker_count(ffi)) };
    assert_eq!((n, m), (rig.vertex_count(), rig.marker_count()));
    let mut out = vec![0i32; 3 * n];
    let mut rust_out = vec![[0i32; 3]; n];
    for (f, markers) in le_words(MARKERS).chunks_exact(3 * m).enumerate() {
        let status = unsafe { fb_deform(ffi, markers.as_ptr(), m, out.as_mut_ptr(), n) };
        assert_eq!(status, FbError::None);
        rig.deform(&triples(markers), &mut rust_out).unwrap();
        let (mut h, mut rust) = (Fnv1a64::new(), Fnv1a64::new());
        h.write_positions(&triples(&out));
        rust.write_positions(&rust_out);
        assert_eq!(h.finish(), rust.finish(), "frame {f}");
        assert_eq!(h.finish(), expected("coefficients", &format!("frame {f}")));
    }
}

/// Two halves deformed by `fb_deform_range` (as two workers would) equal one `fb_deform`; a
/// range past the last vertex is an error and writes nothing.
#[test]
fn deform_range_halves_equal_the_whole_frame() {
    let mut loaded = Loaded::new(COEFFICIENTS);
    let ffi = loaded.rig();
    let (n, m) = unsafe { (fb_rig_vertex_count(ffi), fb_rig_marker_count(ffi)) };
    let (mut whole, mut split) = (vec![0i32; 3 * n], vec![7i32; 3 * n]);
    let half = n / 2;
    for markers in le_words(MARKERS).chunks_exact(3 * m) {
        let p = markers.as_ptr();
        assert_eq!(
            unsafe { fb_deform(ffi, p, m, whole.as_mut_ptr(), n) },
            FbError::None
        );
        let (a, b) = split.split_at_mut(3 * half);
        assert_eq!(
            unsafe { fb_deform_range(ffi, p, m, 0, a.as_mut_ptr(), half) },
            FbError::None
        );
        let rest = n - half;
        assert_eq!(
            unsafe { fb_deform_range(ffi, p, m, half, b.as_mut_ptr(), rest) },
            FbError::None
        );
        assert_eq!(whole, split);
    }
    let before = split.clone();
    let markers = le_words(MARKERS);
    assert_eq!(
        unsafe { fb_deform_range(ffi, markers.as_ptr(), m, n - 1, split.as_mut_ptr(), 2) },
        FbError::VertexCount
    );
    assert_eq!(split, before);
}

/// One frame prepared by `fb_prepare` and deformed in two chunks by `fb_deform_chunk` (as two
/// workers would) equals one `fb_deform`; a table another rig filled, or none, and a range past
/// the last vertex are errors that write nothing.
#[test]
fn prepared_chunks_equal_the_whole_frame() {
    let mut loaded = Loaded::new(COEFFICIENTS);
    let mut other = Loaded::new(CAPTURE);
    let ffi = loaded.rig();
    let (n, m) = unsafe { (fb_rig_vertex_count(ffi), fb_rig_marker_count(ffi)) };
    let mut table = Storage::new(fb_frame_table_size(), fb_frame_table_align());
    let len = table.len();
    let (mut whole, mut split) = (vec![0i32; 3 * n], vec![7i32; 3 * n]);
    let half = n / 3;
    let status = unsafe { fb_deform_chunk(ffi, table.ptr(), 0, split.as_mut_ptr(), 1) };
    assert_eq!(status, FbError::TableMismatch);
    for markers in le_words(MARKERS).chunks_exact(3 * m) {
        let p = markers.as_ptr();
        assert_eq!(
            unsafe { fb_deform(ffi, p, m, whole.as_mut_ptr(), n) },
            FbError::None
        );
        assert_eq!(
            unsafe { fb_prepare(ffi, p, m, table.ptr(), len) },
            FbError::None
        );
        let (a, b) = split.split_at_mut(3 * half);
        let t = table.ptr::<FbFrameTable>().cast_const();
        assert_eq!(
            unsafe { fb_deform_chunk(ffi, t, 0, a.as_mut_ptr(), half) },
            FbError::None
        );
        assert_eq!(
            unsafe { fb_deform_chunk(ffi, t, half, b.as_mut_ptr(), n - half) },
            FbError::None
        );
        assert_eq!(whole, split);
    }
    let before = split.clone();
    let t = table.ptr::<FbFrameTable>().cast_const();
    assert_eq!(
        unsafe { fb_deform_chunk(ffi, t, n - 1, split.as_mut_ptr(), 2) },
        FbError::VertexCount
    );
    let o = other.rig();
    assert_eq!(
        unsafe { fb_deform_chunk(o, t, 0, split.as_mut_ptr(), 1) },
        FbError::TableMismatch
    );
    assert_eq!(
        unsafe { fb_prepare(ffi, le_words(MARKERS).as_ptr(), m, table.ptr(), 8) },
        FbError::BufferTooSmall
    );
    assert_eq!(split, before);
}

#[test]
fn every_golden_normals_frame_hashes_as_hashes_normals_txt() {
    let mut loaded = Loaded::new(COEFFICIENTS);
    let ffi = loaded.rig();
    let (n, m) = unsafe { (fb_rig_vertex_count(ffi), fb_rig_marker_count(ffi)) };
    let mut out = vec![0i32; 3 * n];
    let mut normals = vec![0i16; 3 * n];
    for (f, markers) in le_words(MARKERS).chunks_exact(3 * m).enumerate() {
        assert_eq!(
            unsafe { fb_deform(ffi, markers.as_ptr(), m, out.as_mut_ptr(), n) },
            FbError::None
        );
        let status = unsafe { fb_normals(ffi, out.as_ptr(), n, normals.as_mut_ptr(), n) };
        assert_eq!(status, FbError::None);
        let mut h = Fnv1a64::new();
        h.write_normals(
            &normals
                .chunks_exact(3)
                .map(|c| [c[0], c[1], c[2]])
                .collect::<Vec<_>>(),
        );
        let key = format!("coefficients frame {f} ");
        let line = NORMALS.lines().find(|l| l.starts_with(&key)).unwrap();
        assert_eq!(
            h.finish(),
            u64::from_str_radix(&line[key.len()..], 16).unwrap(),
            "frame {f}"
        );
    }
    // Misuse: the wrong vertex count, a short output, null pointers; nothing written.
    let before = normals.clone();
    for status in [
        unsafe { fb_normals(ffi, out.as_ptr(), n - 1, normals.as_mut_ptr(), n) },
        unsafe { fb_normals(ffi, out.as_ptr(), n, normals.as_mut_ptr(), n - 1) },
        unsafe { fb_normals(ffi, null(), n, normals.as_mut_ptr(), n) },
        unsafe { fb_normals(ffi, out.as_ptr(), n, null_mut(), n) },
    ]
    .into_iter()
    .zip([
        FbError::VertexCount,
        FbError::BufferTooSmall,
        FbError::NullPointer,
        FbError::NullPointer,
    ]) {
        assert_eq!(status.0, status.1);
    }
    assert_eq!(normals, before);
    // Planned: the same normals; a plan of the wrong length, naming a vertex the rig lacks, or
    // too few sums is refused and nothing written.
    let t = unsafe { fb_normals_plan_len(ffi) };
    let mut plan = vec![0u32; 3 * t];
    assert_eq!(
        unsafe { fb_plan_normals(ffi, plan.as_mut_ptr(), t - 1) },
        FbError::BufferTooSmall
    );
    assert_eq!(
        unsafe { fb_plan_normals(ffi, plan.as_mut_ptr(), t) },
        FbError::None
    );
    let mut sums = vec![0i64; 3 * n];
    let mut planned = vec![0i16; 3 * n];
    let positions = out.clone();
    let call = |plan: &[u32], len: usize, sums: &mut [i64], sums_len: usize, out: &mut [i16]| unsafe {
        fb_normals_planned(
            ffi,
            plan.as_ptr(),
            len,
            positions.as_ptr(),
            n,
            sums.as_mut_ptr(),
            sums_len,
            out.as_mut_ptr(),
            n,
        )
    };
    assert_eq!(call(&plan, t, &mut sums, n, &mut planned), FbError::None);
    assert_eq!(planned, normals);
    let mut bad = plan.clone();
    bad[4] = n as u32;
    let untouched = vec![7i16; 3 * n];
    for (status, want) in [
        (
            call(&plan, t - 1, &mut sums, n, &mut planned),
            FbError::BufferTooSmall,
        ),
        (
            call(&bad, t, &mut sums, n, &mut planned),
            FbError::PlanMismatch,
        ),
        (
            call(&plan, t, &mut sums, n - 1, &mut planned),
            FbError::BufferTooSmall,
        ),
    ] {
        assert_eq!(status, want);
    }
    let mut fresh = untouched.clone();
    assert_eq!(
        call(&bad, t, &mut sums, n, &mut fresh),
        FbError::PlanMismatch
    );
    assert_eq!(fresh, untouched);
    let mut cost = FbCost::default();
    assert_eq!(unsafe { fb_cost(ffi, &mut cost) }, FbError::None);
    assert_eq!(cost.normals.vertices, n as u64);
    assert!(cost.normals.corners > 0);
}

#[test]
fn every_golden_capture_frame_hashes_as_the_rust_api_and_hashes_txt() {
    let mut loaded = Loaded::new(CAPTURE);
    let ffi = loaded.rig();
    let rig = Rig::from_bytes(CAPTURE).unwrap();
    let stages = rig.stages().unwrap();
    let (n, m) = (rig.vertex_count(), rig.marker_count());
    let mut state = new_state();
    let mut rust_state = PlayState::new();
    let (mut markers, mut out) = (vec![0i32; 3 * m], vec![0i32; 3 * n]);
    let (mut rust_markers, mut rust_out) = (vec![[0i32; 3]; m], vec![[0i32; 3]; n]);
    let mut sequence = Fnv1a64::new();
    for (f, (actor, present)) in actor_frames(m).iter().enumerate() {
        let mut report = std::mem::MaybeUninit::<FbFrameReport>::uninit();
        let status = unsafe {
            fb_play(
                ffi,
                state.ptr(),
                actor.as_ptr(),
                present.as_ptr(),
                m,
                markers.as_mut_ptr(),
                out.as_mut_ptr(),
                n,
                report.as_mut_ptr(),
            )
        };
        assert_eq!(status, FbError::None, "frame {f}");
        let report = unsafe { report.assume_init() };
        let given: Vec<_> = triples(actor)
            .into_iter()
            .zip(present)
            .map(|(p, &k)| (k != 0).then_some(p))
            .collect();
        let rust_report = stages.solve(&mut rust_state, &given, &mut rust_markers);
        rig.deform(&rust_markers, &mut rust_out).unwrap();
        assert_eq!(report, FbFrameReport::from(&rust_report), "frame {f}");
        assert_eq!(triples(&markers), rust_markers, "frame {f}");
        assert_eq!(triples(&out), rust_out, "frame {f}");
        let mut h = Fnv1a64::new();
        h.write_capture_frame(&rust_markers, &rust_out, &rust_report);
        sequence.write_capture_frame(&rust_markers, &rust_out, &rust_report);
        assert_eq!(h.finish(), expected("capture", &format!("frame {f}")));
    }
    assert_eq!(sequence.finish(), expected("capture", "sequence"));
}

#[test]
fn f32_paths_convert_through_the_rigs_spaces() {
    let mut loaded = Loaded::new(CAPTURE);
    let ffi = loaded.rig();
    let rig = Rig::from_bytes(CAPTURE).unwrap();
    let (n, m) = (rig.vertex_count(), rig.marker_count());
    let (space, actor_space) = (rig.space(), rig.actor_space().unwrap());
    let mut fb_space = FbSpace::default();
    assert_eq!(unsafe { fb_rig_space(ffi, &mut fb_space) }, FbError::None);
    assert_eq!(fb_space.centre, space.centre);
    assert_eq!(fb_space.half_extent, space.half_extent);

    // fb_deform_f32 = to_rig, the integer deform, to_asset.
    let frame = &le_words(MARKERS)[..3 * 40];
    let markers_f32: Vec<f32> = triples(frame)
        .iter()
        .chain(std::iter::once(&[0, 1 << 20, -(1 << 22)]))
        .flat_map(|q| space.to_asset(*q))
        .collect();
    let mut out = vec![0f32; 3 * n];
    let status = unsafe { fb_deform_f32(ffi, markers_f32.as_ptr(), m, out.as_mut_ptr(), n) };
    assert_eq!(status, FbError::None);
    let q: Vec<[i32; 3]> = markers_f32
        .chunks_exact(3)
        .map(|p| space.to_rig([p[0], p[1], p[2]]).unwrap())
        .collect();
    let mut want = vec![[0i32; 3]; n];
    rig.deform(&q, &mut want).unwrap();
    let want: Vec<f32> = want.iter().flat_map(|p| space.to_asset(*p)).collect();
    assert_eq!(out, want);

    // A non-finite marker fails fb_deform_f32 and writes nothing.
    let mut bad = markers_f32.clone();
    bad[4] = f32::NAN;
    let mut untouched = vec![7f32; 3 * n];
    let status = unsafe { fb_deform_f32(ffi, bad.as_ptr(), m, untouched.as_mut_ptr(), n) };
    assert_eq!(status, FbError::NotFinite);
    bad[4] = 1e30;
    let status = unsafe { fb_deform_f32(ffi, bad.as_ptr(), m, untouched.as_mut_ptr(), n) };
    assert_eq!(status, FbError::OutOfRange);
    assert!(untouched.iter().all(|&v| v == 7.0));

    // fb_play_f32: actor units from the actor space; a NaN marker is missing, a far one
    // rejected.
    let (actor, _) = &actor_frames(m)[0];
    let mut actor_f32: Vec<f32> = triples(actor)
        .iter()
        .flat_map(|q| actor_space.to_asset(*q))
        .collect();
    actor_f32[3 * 10] = f32::NAN;
    actor_f32[3 * 20 + 1] = 1e30;
    let mut state = new_state();
    let (mut markers, mut out) = (vec![0f32; 3 * m], vec![0f32; 3 * n]);
    let mut report = std::mem::MaybeUninit::<FbFrameReport>::uninit();
    let status = unsafe {
        fb_play_f32(
            ffi,
            state.ptr(),
            actor_f32.as_ptr(),
            null(),
            m,
            markers.as_mut_ptr(),
            out.as_mut_ptr(),
            n,
            report.as_mut_ptr(),
        )
    };
    assert_eq!(status, FbError::None);
    let report = unsafe { report.assume_init() };
    let bit = |set: &[u32; FB_MARKER_WORDS], j: usize| set[j / 32] >> (j % 32) & 1 == 1;
    assert!(bit(&report.rejected, 20) && !bit(&report.rejected, 10));
    assert!(bit(&report.rebuilt, 10) || bit(&report.held, 10));
    let given: Vec<Option<[i32; 3]>> = actor_f32
        .chunks_exact(3)
        .map(|p| match actor_space.to_rig([p[0], p[1], p[2]]) {
            Ok(q) => Some(q),
            Err(facebake_runtime::ConvertError::NotFinite) => None,
            Err(facebake_runtime::ConvertError::OutOfRange) => Some([i32::MAX; 3]),
        })
        .collect();
    let (mut want_markers, mut want_out) = (vec![[0i32; 3]; m], vec![[0i32; 3]; n]);
    let mut rust_state = PlayState::new();
    let rust_report = rig
        .play_markers(&mut rust_state, &given, &mut want_markers)
        .unwrap();
    rig.deform(&want_markers, &mut want_out).unwrap();
    assert_eq!(report, FbFrameReport::from(&rust_report));
    let to_f32 =
        |v: &[[i32; 3]]| -> Vec<f32> { v.iter().flat_map(|p| space.to_asset(*p)).collect() };
    assert_eq!(markers, to_f32(&want_markers));
    assert_eq!(out, to_f32(&want_out));
}

#[test]
fn rest_markers_deform_to_the_rest_vertices_and_names_round_trip() {
    let mut loaded = Loaded::new(COEFFICIENTS);
    let ffi = loaded.rig();
    let rig = Rig::from_bytes(COEFFICIENTS).unwrap();
    let (n, m) = (rig.vertex_count(), rig.marker_count());
    let (mut markers, mut rest, mut out) = (vec![0; 3 * m], vec![0; 3 * n], vec![0; 3 * n]);
    unsafe {
        assert_eq!(fb_marker_rest(ffi, markers.as_mut_ptr(), m), FbError::None);
        assert_eq!(fb_vertex_rest(ffi, rest.as_mut_ptr(), n), FbError::None);
        assert_eq!(
            fb_deform(ffi, markers.as_ptr(), m, out.as_mut_ptr(), n),
            FbError::None
        );
    }
    assert_eq!(
        out, rest,
        "zero marker motion gives the rest pose bit for bit"
    );
    let mut rest_f32 = vec![0f32; 3 * n];
    assert_eq!(
        unsafe { fb_vertex_rest_f32(ffi, rest_f32.as_mut_ptr(), n) },
        FbError::None
    );
    let want: Vec<f32> = triples(&rest)
        .iter()
        .flat_map(|q| rig.space().to_asset(*q))
        .collect();
    assert_eq!(rest_f32, want);

    let mut cost = FbCost::default();
    assert_eq!(unsafe { fb_cost(ffi, &mut cost) }, FbError::None);
    assert_eq!(cost, FbCost::from(rig.cost()));

    for (i, name) in rig.marker_names().enumerate() {
        let (mut ptr, mut len) = (null(), 0usize);
        assert_eq!(
            unsafe { fb_marker_name(ffi, i, &mut ptr, &mut len) },
            FbError::None
        );
        let got = unsafe { std::slice::from_raw_parts(ptr.cast::<u8>(), len) };
        assert_eq!(got, name.as_bytes());
        let mut buf = [0x55 as std::ffi::c_char; 256];
        let mut copied = 0usize;
        let status =
            unsafe { fb_marker_name_copy(ffi, i, buf.as_mut_ptr(), buf.len(), &mut copied) };
        assert_eq!(status, FbError::None);
        let c = unsafe { std::ffi::CStr::from_ptr(buf.as_ptr()) };
        assert_eq!((c.to_bytes(), copied), (name.as_bytes(), name.len()));
        let mut index = usize::MAX;
        let status = unsafe { fb_marker_index(ffi, name.as_ptr().cast(), name.len(), &mut index) };
        assert_eq!((status, index), (FbError::None, i));
    }
}

#[test]
fn misuse_returns_its_error_code_and_writes_nothing() {
    let mut loaded = Loaded::new(COEFFICIENTS);
    let ffi = loaded.rig();
    let (n, m) = unsafe { (fb_rig_vertex_count(ffi), fb_rig_marker_count(ffi)) };
    let markers = vec![0i32; 3 * m];
    let mut out = vec![7i32; 3 * n];
    let untouched = |out: &[i32]| out.iter().all(|&v| v == 7);
    unsafe {
        // Null and misaligned pointers.
        assert_eq!(
            fb_deform(null(), markers.as_ptr(), m, out.as_mut_ptr(), n),
            FbError::NullPointer
        );
        assert_eq!(
            fb_deform(ffi, null(), m, out.as_mut_ptr(), n),
            FbError::NullPointer
        );
        assert_eq!(
            fb_deform(ffi, markers.as_ptr(), m, null_mut(), n),
            FbError::NullPointer
        );
        let odd = markers.as_ptr().cast::<u8>().add(1).cast::<i32>();
        assert_eq!(
            fb_deform(ffi, odd, m, out.as_mut_ptr(), n),
            FbError::Misaligned
        );
        // Wrong counts and short buffers.
        assert_eq!(
            fb_deform(ffi, markers.as_ptr(), m - 1, out.as_mut_ptr(), n),
            FbError::MarkerCount
        );
        assert_eq!(
            fb_deform(ffi, markers.as_ptr(), m, out.as_mut_ptr(), n - 1),
            FbError::BufferTooSmall
        );
        assert!(untouched(&out));
        assert_eq!(fb_cost(ffi, null_mut()), FbError::NullPointer);
        assert_eq!(fb_rig_vertex_count(null()), 0);

        // Names: out of range, too small a buffer (the length is still reported), not found.
        let (mut ptr, mut len) = (null(), 0usize);
        assert_eq!(
            fb_marker_name(ffi, m, &mut ptr, &mut len),
            FbError::IndexOutOfRange
        );
        assert_eq!(
            fb_marker_name(ffi, 0, null_mut(), &mut len),
            FbError::NullPointer
        );
        let mut small = [0x55 as std::ffi::c_char; 3];
        let status = fb_marker_name_copy(ffi, 0, small.as_mut_ptr(), small.len(), &mut len);
        assert_eq!((status, len), (FbError::BufferTooSmall, 3)); // "M00" needs 4 bytes
        assert!(small.iter().all(|&c| c == 0x55));
        let mut index = 0usize;
        assert_eq!(
            fb_marker_index(ffi, c"nope".as_ptr(), 4, &mut index),
            FbError::NotFound
        );

        // Playing a rig without capture stages, or with a state never initialised.
        let mut state = new_state();
        assert_eq!(
            fb_play(
                ffi,
                state.ptr(),
                markers.as_ptr(),
                null(),
                m,
                null_mut(),
                out.as_mut_ptr(),
                n,
                null_mut()
            ),
            FbError::NoStages
        );
        let mut capture = Loaded::new(CAPTURE);
        let cap = capture.rig();
        let (cm, cn) = (fb_rig_marker_count(cap), fb_rig_vertex_count(cap));
        let actor = vec![0i32; 3 * cm];
        let mut out = vec![7i32; 3 * cn];
        let mut raw = Storage::new(fb_play_state_size(), fb_play_state_align());
        assert_eq!(
            fb_play(
                cap,
                raw.ptr(),
                actor.as_ptr(),
                null(),
                cm,
                null_mut(),
                out.as_mut_ptr(),
                cn,
                null_mut()
            ),
            FbError::NotInitialised
        );
        assert_eq!(
            fb_play(
                cap,
                state.ptr(),
                actor.as_ptr(),
                null(),
                cm,
                null_mut(),
                out.as_mut_ptr(),
                cn - 1,
                null_mut()
            ),
            FbError::BufferTooSmall
        );
        assert!(untouched(&out));
        assert_eq!(
            fb_play_state_init(raw.ptr(), fb_play_state_size() - 1),
            FbError::BufferTooSmall
        );
    }
}

#[test]
fn bad_blobs_and_storage_are_refused_and_leave_no_rig() {
    let mut storage = Storage::new(fb_rig_size(), fb_rig_align());
    let len = storage.len();
    let load = |blob: &[u8], storage: &mut Storage, len: usize| unsafe {
        fb_rig_load(blob.as_ptr(), blob.len(), storage.ptr(), len)
    };
    // A loaded storage whose next load fails holds no rig.
    assert_eq!(load(COEFFICIENTS, &mut storage, len), FbError::None);
    let mut corrupt = COEFFICIENTS.to_vec();
    corrupt[100] ^= 1;
    assert_eq!(load(&corrupt, &mut storage, len), FbError::ChecksumMismatch);
    assert_eq!(
        unsafe { fb_rig_validate(corrupt.as_ptr(), corrupt.len()) },
        FbError::ChecksumMismatch
    );
    assert_eq!(unsafe { fb_rig_vertex_count(storage.ptr()) }, 0);
    let mut space = FbSpace::default();
    assert_eq!(
        unsafe { fb_rig_space(storage.ptr(), &mut space) },
        FbError::NotLoaded
    );
    assert_eq!(
        load(&COEFFICIENTS[..COEFFICIENTS.len() - 1], &mut storage, len),
        FbError::Truncated
    );
    let mut trailing = COEFFICIENTS.to_vec();
    trailing.push(0);
    assert_eq!(load(&trailing, &mut storage, len), FbError::TrailingBytes);
    assert_eq!(
        load(b"not a rig at all, but long enough", &mut storage, len),
        FbError::BadMagic
    );
    assert_eq!(
        unsafe { fb_rig_load(null(), 10, storage.ptr(), len) },
        FbError::NullPointer
    );
    // Storage: null, too small, misaligned.
    assert_eq!(
        unsafe { fb_rig_load(COEFFICIENTS.as_ptr(), COEFFICIENTS.len(), null_mut(), len) },
        FbError::NullPointer
    );
    assert_eq!(
        load(COEFFICIENTS, &mut storage, fb_rig_size() - 1),
        FbError::BufferTooSmall
    );
    if fb_rig_align() > 1 {
        let odd = unsafe { storage.ptr::<u8>().add(1) }.cast::<FbRig>();
        let status =
            unsafe { fb_rig_load(COEFFICIENTS.as_ptr(), COEFFICIENTS.len(), odd, len - 1) };
        assert_eq!(status, FbError::Misaligned);
    }
    // A zeroed storage was never loaded.
    let mut zeroed = Storage::new(fb_rig_size(), fb_rig_align());
    assert_eq!(unsafe { fb_rig_marker_count(zeroed.ptr()) }, 0);
}

#[test]
fn error_messages_are_static_distinct_and_total() {
    let message = |code: i32| unsafe { std::ffi::CStr::from_ptr(fb_error_message(code)) };
    let known: Vec<_> = (0..=FbError::PlanMismatch as i32).map(message).collect();
    for (i, m) in known.iter().enumerate() {
        assert!(!m.to_bytes().is_empty());
        assert!(!known[..i].contains(m), "code {i} repeats a message");
    }
    assert_eq!(message(0).to_str().unwrap(), "no error");
    for unknown in [-1, FbError::PlanMismatch as i32 + 1, i32::MIN, i32::MAX] {
        assert_eq!(
            message(unknown).to_str().unwrap(),
            "unknown facebake error code"
        );
    }
}

#[test]
fn one_rig_is_shared_by_threads_with_one_state_each() {
    let mut loaded = Loaded::new(CAPTURE);
    let rig = loaded.rig() as usize; // a loaded rig is immutable: share its address
    let m = unsafe { fb_rig_marker_count(rig as *const FbRig) };
    let n = unsafe { fb_rig_vertex_count(rig as *const FbRig) };
    let frames = actor_frames(m);
    let hashes: Vec<u64> = std::thread::scope(|s| {
        let workers: Vec<_> = (0..4)
            .map(|_| {
                let frames = &frames;
                s.spawn(move || {
                    let mut state = new_state();
                    let mut out = vec![0i32; 3 * n];
                    let mut h = Fnv1a64::new();
                    for (actor, present) in frames {
                        let status = unsafe {
                            fb_play(
                                rig as *const FbRig,
                                state.ptr(),
                                actor.as_ptr(),
                                present.as_ptr(),
                                m,
                                null_mut(),
                                out.as_mut_ptr(),
                                n,
                                null_mut(),
                            )
                        };
                        assert_eq!(status, FbError::None);
                        h.write_positions(&triples(&out));
                    }
                    h.finish()
                })
            })
            .collect();
        workers.into_iter().map(|w| w.join().unwrap()).collect()
    });
    assert!(hashes.windows(2).all(|w| w[0] == w[1]));
}

/// A packed take loaded through the ABI, in its own storage.
fn load_take(bytes: &'static [u8]) -> Storage {
    let mut storage = Storage::new(fb_take_size(), fb_take_align());
    let len = storage.len();
    let status = unsafe { fb_take_load(bytes.as_ptr(), bytes.len(), storage.ptr(), len) };
    assert_eq!(status, FbError::None);
    storage
}

/// `fb_take_next_frame` into whole buffers (one sample and one presence byte per marker).
fn next_frame(
    t: *mut FbTake,
    samples: &mut [i32],
    present: &mut [u8],
    frame: &mut usize,
) -> FbError {
    unsafe {
        fb_take_next_frame(
            t,
            samples.as_mut_ptr(),
            present.as_mut_ptr(),
            present.len(),
            frame,
        )
    }
}

/// The marker names of a rig or a take, through their `_marker_name` call.
fn names(
    count: usize,
    name: impl Fn(usize, *mut *const std::ffi::c_char, *mut usize) -> FbError,
) -> Vec<String> {
    (0..count)
        .map(|j| {
            let (mut at, mut len) = (null(), 0usize);
            assert_eq!(name(j, &mut at, &mut len), FbError::None);
            let bytes = unsafe { std::slice::from_raw_parts(at.cast::<u8>(), len) };
            String::from_utf8(bytes.to_vec()).unwrap()
        })
        .collect()
}

/// The golden take decoded through `fb_take_next_frame` and played through `fb_play` hashes as
/// `hashes_take.txt` records it; a seek then decodes the same frames again.
#[test]
fn the_golden_take_decodes_and_plays_as_hashes_take_txt() {
    let mut take = load_take(TAKE);
    let t = take.ptr::<FbTake>();
    let mut loaded = Loaded::new(CAPTURE);
    let rig = loaded.rig();
    let (n, m) = unsafe { (fb_rig_vertex_count(rig), fb_rig_marker_count(rig)) };
    let (frames, tm) = unsafe { (fb_take_frame_count(t), fb_take_marker_count(t)) };
    assert_eq!((frames, tm), (1590, m));
    assert_eq!(unsafe { fb_take_rate(t) }, 60.0);
    let mut space = FbSpace::default();
    let mut actor_space = FbSpace::default();
    unsafe {
        assert_eq!(fb_take_space(t, &mut space), FbError::None);
        assert_eq!(fb_rig_actor_space(rig, &mut actor_space), FbError::None);
    }
    assert_eq!(
        space, actor_space,
        "packed with --rig: the rig's actor units"
    );
    let rig_names = names(m, |j, a, l| unsafe { fb_marker_name(rig, j, a, l) });
    let take_names = names(tm, |j, a, l| unsafe { fb_take_marker_name(t, j, a, l) });
    let map: Vec<usize> = rig_names
        .iter()
        .map(|r| take_names.iter().position(|t| t == r).unwrap())
        .collect();

    let mut state = new_state();
    let (mut samples, mut present) = (vec![0i32; 3 * tm], vec![0u8; tm]);
    let (mut actor, mut given) = (vec![0i32; 3 * m], vec![0u8; m]);
    let (mut markers, mut out) = (vec![0i32; 3 * m], vec![0i32; 3 * n]);
    let mut lines = TAKE_HASHES.lines().filter(|l| l.starts_with("take "));
    let mut sequence = Fnv1a64::new();
    let mut decoded = Vec::new();
    let mut frame = usize::MAX;
    loop {
        assert_eq!(unsafe { fb_take_position(t) }, decoded.len());
        let status = next_frame(t, &mut samples, &mut present, &mut frame);
        if status == FbError::EndOfTake {
            break;
        }
        assert_eq!(status, FbError::None);
        assert_eq!(frame, decoded.len());
        decoded.push((samples.clone(), present.clone()));
        for (j, &k) in map.iter().enumerate() {
            actor[3 * j..3 * j + 3].copy_from_slice(&samples[3 * k..3 * k + 3]);
            given[j] = present[k];
        }
        let mut report = std::mem::MaybeUninit::<FbFrameReport>::uninit();
        let status = unsafe {
            fb_play(
                rig,
                state.ptr(),
                actor.as_ptr(),
                given.as_ptr(),
                m,
                markers.as_mut_ptr(),
                out.as_mut_ptr(),
                n,
                report.as_mut_ptr(),
            )
        };
        assert_eq!(status, FbError::None);
        let report = unsafe { report.assume_init() };
        let rows: Vec<Option<[i32; 3]>> = triples(&actor)
            .into_iter()
            .zip(&given)
            .map(|(p, &k)| (k != 0).then_some(p))
            .collect();
        let tail = [
            report.rigid_residual,
            report.rebuilt_count as i32,
            report.held_count as i32,
        ];
        let mut h = Fnv1a64::new();
        for hash in [&mut h, &mut sequence] {
            hash.write_samples(&rows);
            hash.write_positions(&triples(&markers));
            hash.write_positions(&triples(&out));
            hash.write_positions(&[tail]);
        }
        let line = format!("take frame {frame} {:016x}", h.finish());
        assert_eq!(lines.next(), Some(line.as_str()));
    }
    assert_eq!(decoded.len(), frames);
    let line = format!("take sequence {:016x}", sequence.finish());
    assert_eq!(lines.next(), Some(line.as_str()));
    // The end writes nothing; a seek anywhere decodes the same frames as the sequential read.
    samples.fill(7);
    let status = next_frame(t, &mut samples, &mut present, &mut frame);
    assert_eq!(status, FbError::EndOfTake);
    assert!(samples.iter().all(|&s| s == 7));
    for start in [0, 1, 127, 128, 700, 1589] {
        assert_eq!(unsafe { fb_take_seek(t, start) }, FbError::None);
        for (f, want) in decoded.iter().enumerate().skip(start).take(3) {
            let status = next_frame(t, &mut samples, &mut present, &mut frame);
            assert_eq!((status, frame), (FbError::None, f));
            assert_eq!(
                (&samples, &present),
                (&want.0, &want.1),
                "frame {f} after a seek to {start}"
            );
        }
    }
}

/// Every misuse of the take calls returns its code and leaves outputs and position unchanged.
#[test]
fn take_misuse_returns_its_error_code_and_writes_nothing() {
    let mut take = load_take(TAKE);
    let t = take.ptr::<FbTake>();
    let m = unsafe { fb_take_marker_count(t) };
    let (mut samples, mut present, mut frame) = (vec![7i32; 3 * m], vec![7u8; m], 7usize);
    let next = |t: *mut FbTake, s: *mut i32, p: *mut u8, count: usize, f: *mut usize| unsafe {
        fb_take_next_frame(t, s, p, count, f)
    };
    let (s, p) = (samples.as_mut_ptr(), present.as_mut_ptr());
    assert_eq!(next(t, s, p, m + 1, &mut frame), FbError::MarkerCount);
    assert_eq!(next(t, null_mut(), p, m, &mut frame), FbError::NullPointer);
    assert_eq!(next(t, s, null_mut(), m, &mut frame), FbError::NullPointer);
    assert_eq!(next(t, s, p, m, null_mut()), FbError::NullPointer);
    assert_eq!(
        next(t, unsafe { s.cast::<u8>().add(1) }.cast(), p, m, &mut frame),
        FbError::Misaligned
    );
    assert_eq!(next(null_mut(), s, p, m, &mut frame), FbError::NullPointer);
    assert_eq!(unsafe { fb_take_seek(t, 1591) }, FbError::IndexOutOfRange);
    assert_eq!(unsafe { fb_take_position(t) }, 0);
    assert!(samples.iter().all(|&x| x == 7) && present.iter().all(|&x| x == 7) && frame == 7);
    let (mut at, mut len) = (null(), 0usize);
    assert_eq!(
        unsafe { fb_take_marker_name(t, m, &mut at, &mut len) },
        FbError::IndexOutOfRange
    );

    // Storage never loaded, too small, misaligned; bad bytes leave no take behind.
    let mut zeroed = Storage::new(fb_take_size(), fb_take_align());
    let z = zeroed.ptr::<FbTake>();
    assert_eq!(next(z, s, p, m, &mut frame), FbError::TakeNotLoaded);
    assert_eq!(unsafe { fb_take_seek(z, 0) }, FbError::TakeNotLoaded);
    assert_eq!(
        unsafe {
            (
                fb_take_frame_count(z),
                fb_take_marker_count(z),
                fb_take_rate(z),
            )
        },
        (0, 0, 0.0)
    );
    assert_eq!(
        unsafe { fb_take_load(TAKE.as_ptr(), TAKE.len(), z, fb_take_size() - 1) },
        FbError::BufferTooSmall
    );
    let misaligned = unsafe { zeroed.ptr::<u8>().add(1) }.cast::<FbTake>();
    assert_eq!(
        unsafe { fb_take_load(TAKE.as_ptr(), TAKE.len(), misaligned, fb_take_size()) },
        FbError::Misaligned
    );
    let len = zeroed.len();
    let mut corrupt = TAKE.to_vec();
    corrupt[30] ^= 1;
    let cases: [(&[u8], FbError); 4] = [
        (&TAKE[..TAKE.len() - 1], FbError::Truncated),
        (&corrupt, FbError::ChecksumMismatch),
        (CAPTURE, FbError::BadMagic),
        (&[], FbError::Truncated),
    ];
    for (bytes, want) in cases {
        let bytes: &'static [u8] = Box::leak(bytes.to_vec().into_boxed_slice());
        assert_eq!(
            unsafe { fb_take_load(bytes.as_ptr(), bytes.len(), z, len) },
            want
        );
        assert_eq!(next(z, s, p, m, &mut frame), FbError::TakeNotLoaded);
    }
}
