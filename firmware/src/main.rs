//! Plays the golden FaceCap rigs through the facebake runtime on a Cortex-M4 (QEMU
//! `mps2-an386`) and reports over semihosting:
//!
//! * one line per frame, `<rig> frame <n> <fnv1a64>`, and `<rig> sequence <fnv1a64>`, in the
//!   format of `fixtures/golden/hashes.txt`, so `.ci/cross.sh` can compare them line for line
//!   (each frame is also deformed again in chunks with `Rig::deform_range`, which must give the
//!   same hash);
//! * per frame the normals of the deformed mesh (`Rig::normals`), `normals <rig> frame <n>
//!   <fnv1a64>` and `normals <rig> sequence <fnv1a64>`, in the format of
//!   `fixtures/golden/hashes_normals.txt` behind the word `normals`;
//! * the rig's figures (`Rig::cost`, frames played, blob size).
//!
//! It exits with status 0 after the last rig, and non-zero on any panic (the handler reports
//! the panic over semihosting first). The blobs and markers are compiled into flash; the only
//! large RAM use is the output buffer on the stack.
//!
//! `frame_start` / `frame_end` bracket every `deform` call, and then every `normals` call, so the
//! QEMU plugin in `qemu/` can count the instructions of each (deform and normals alternate in
//! its output for the deform rigs); for the capture golden they bracket the capture stages, and
//! for the packed take first the decoding of each frame and then its capture stages and
//! deformation.
//!
//! The packed take (`fixtures/golden/jawmocap.fbt`, all 1590 JawMoCap frames, 33 KB of flash)
//! plays from flash: each frame is decoded with the runtime's `TakeReader` (a fixed state on
//! the stack, no allocation), matched to the rig's markers by name and played through the
//! capture rig's stages and deformer, printing `take frame <n> <fnv1a64>` lines that must equal
//! `fixtures/golden/hashes_take.txt`.
#![no_std]
#![no_main]

#[cfg(feature = "alloc-canary")]
extern crate alloc;

use core::hint::black_box;
use core::panic::PanicInfo;

use cortex_m_rt::entry;
use cortex_m_semihosting::{debug, hprintln};
use facebake_runtime::checksum::Fnv1a64;
use facebake_runtime::format::records::{MAX_MARKERS, SECTION_ALIGN};
use facebake_runtime::{PlayState, Rig, Take};

/// A blob placed at a multiple of `SECTION_ALIGN` in flash (`include_bytes!` gives no
/// alignment), so that the sections the baker aligns within it (`vertex_rest`, the linear
/// deformer's `pairs`) are read with aligned loads.
#[repr(C, align(4))]
struct Aligned<B: ?Sized>(B);

const _: () = assert!(core::mem::align_of::<Aligned<[u8; 1]>>() == SECTION_ALIGN);

/// `include_bytes!` at a 4-byte-aligned address, as a `&[u8]`.
macro_rules! aligned_bytes {
    ($path:literal) => {{
        static BLOB: &Aligned<[u8]> = &Aligned(*include_bytes!($path));
        &BLOB.0
    }};
}

/// The sections the baker aligns are aligned in memory here (the cycle estimate in
/// `.ci/cross.sh` assumes aligned loads): else the firmware panics.
fn assert_aligned(name: &str, rig: &Rig<'_>) {
    let pairs = match rig.deformer() {
        facebake_runtime::deformer::Deformer::Linear(l) => l.pairs.0,
        _ => &[],
    };
    for (section, bytes) in [("vertex_rest", rig.data().vertex_rest.0), ("pairs", pairs)] {
        assert!(
            bytes.is_empty() || bytes.as_ptr() as usize % SECTION_ALIGN == 0,
            "{name}: {section} is not {SECTION_ALIGN}-byte aligned"
        );
    }
}

/// Every frame's markers of the 40-marker rigs: frames × markers × 3 `i32` LE, Q8.24.
const MARKERS: &[u8] = include_bytes!("../../fixtures/golden/facecap_markers.bin");

/// The same frames through the bundled layout's 41 markers, for the product rig.
const LAYOUT_MARKERS: &[u8] = include_bytes!("../../fixtures/golden/facecap_layout_markers.bin");

/// The golden rigs, by the names `hashes.txt` uses, in its order, each with its marker frames.
const RIGS: [(&str, &[u8], &[u8]); 4] = [
    (
        "coefficients",
        aligned_bytes!("../../fixtures/golden/facecap_coefficients.fbk"),
        MARKERS,
    ),
    (
        "weights",
        aligned_bytes!("../../fixtures/golden/facecap_weights.fbk"),
        MARKERS,
    ),
    (
        "coefficients_k4",
        aligned_bytes!("../../fixtures/golden/facecap_coefficients_k4.fbk"),
        MARKERS,
    ),
    (
        "product",
        aligned_bytes!("../../fixtures/golden/facecap_product.fbk"),
        LAYOUT_MARKERS,
    ),
];

/// The capture golden: a rig with capture stages and actor frames (per marker a presence byte
/// and three `i32` LE, Q8.24 actor units).
const CAPTURE: &[u8] = aligned_bytes!("../../fixtures/golden/jawmocap_capture.fbk");
const ACTOR: &[u8] = include_bytes!("../../fixtures/golden/jawmocap_actor.bin");

/// The take golden: JawMoCap packed in the capture rig's actor space.
const TAKE: &[u8] = include_bytes!("../../fixtures/golden/jawmocap.fbt");

/// Most vertices a rig may have here: the output buffers live on the stack (12 bytes a vertex
/// for the positions, 6 for the normals).
const MAX_VERTICES: usize = 3072;

/// Marks the start of a measured frame (the instruction counter reads here). Not inlined, and
/// different in body from [`frame_end`] so the two are never merged into one address.
#[inline(never)]
fn frame_start(frame: usize) {
    black_box(frame);
}

/// Marks the end of a measured frame.
#[inline(never)]
fn frame_end(frame: usize) {
    black_box(!frame);
}

/// Markers of frame `f` of `file` into `buf`; `None` past the last frame.
fn frame_markers(
    file: &[u8],
    f: usize,
    markers: usize,
    buf: &mut [[i32; 3]; MAX_MARKERS],
) -> Option<()> {
    let bytes = file.get(f * markers * 12..(f + 1) * markers * 12)?;
    for (m, b) in buf.iter_mut().zip(bytes.chunks_exact(12)) {
        for (c, w) in m.iter_mut().zip(b.chunks_exact(4)) {
            *c = i32::from_le_bytes([w[0], w[1], w[2], w[3]]);
        }
    }
    Some(())
}

/// The normals of one frame, hashed into `sequence` and printed as `hashes_normals.txt` records
/// them (behind the word `normals`), bracketed for the instruction counter when `measured`.
fn normals_frame(
    rig: &Rig<'_>,
    name: &str,
    frame: usize,
    positions: &[[i32; 3]],
    normals: &mut [[i16; 3]],
    sequence: &mut Fnv1a64,
    measured: bool,
) {
    if measured {
        frame_start(frame);
    }
    let done = rig.normals(positions, normals);
    if measured {
        frame_end(frame);
    }
    if let Err(e) = done {
        panic!("{name} frame {frame}: normals: {e}");
    }
    let mut h = Fnv1a64::new();
    h.write_normals(normals);
    sequence.write_normals(normals);
    hprintln!("normals {} frame {} {:016x}", name, frame, h.finish());
}

/// Play the deform rig `blob` through every frame of `marker_file`: per frame the deformation
/// and its normals (both bracketed for the instruction counter), hashed as `hashes.txt` and
/// `hashes_normals.txt` record them.
fn play(
    name: &str,
    blob: &[u8],
    marker_file: &[u8],
    out: &mut [[i32; 3]; MAX_VERTICES],
    normals: &mut [[i16; 3]; MAX_VERTICES],
) {
    let rig = match Rig::from_bytes(blob) {
        Ok(rig) => rig,
        Err(e) => panic!("{name}: the golden rig does not load: {e}"),
    };
    let (m, v) = (rig.marker_count(), rig.vertex_count());
    assert!(
        v <= MAX_VERTICES,
        "{name}: {v} vertices, room for {MAX_VERTICES}"
    );
    assert_aligned(name, &rig);
    let out = &mut out[..v];
    let normals = &mut normals[..v];
    let mut markers = [[0i32; 3]; MAX_MARKERS];
    let mut sequence = Fnv1a64::new();
    let mut normals_sequence = Fnv1a64::new();
    let mut frames = 0;
    while frame_markers(marker_file, frames, m, &mut markers).is_some() {
        frame_start(frames);
        let done = rig.deform(&markers[..m], out);
        frame_end(frames);
        if let Err(e) = done {
            panic!("{name} frame {frames}: {e}");
        }
        let mut h = Fnv1a64::new();
        h.write_positions(out);
        sequence.write_positions(out);
        let hash = h.finish();
        check_chunks(&rig, name, frames, &markers[..m], out, hash);
        hprintln!("{} frame {} {:016x}", name, frames, hash);
        normals_frame(
            &rig,
            name,
            frames,
            out,
            normals,
            &mut normals_sequence,
            true,
        );
        frames += 1;
    }
    hprintln!("{} sequence {:016x}", name, sequence.finish());
    hprintln!(
        "normals {} sequence {:016x}",
        name,
        normals_sequence.finish()
    );
    hprintln!(
        "figures {}: {} frames, blob {} bytes, per frame {}; {}",
        name,
        frames,
        blob.len(),
        rig.cost(),
        rig.cost().normals
    );
}

/// The frame `out` holds (hashing to `hash`), again in three uneven chunks through
/// `Rig::deform_range` into `out`: it must hash the same, or the firmware panics. Outside the
/// instruction counter's brackets. (Not through `Rig::prepare`: a `FrameTable` is about 25 KB,
/// which does not fit beside this firmware's 87 KB of buffers in 128 KiB of RAM; the chunks run
/// the same per-vertex code and find their first influence the same way.)
#[inline(never)]
fn check_chunks(
    rig: &Rig<'_>,
    name: &str,
    frame: usize,
    markers: &[[i32; 3]],
    out: &mut [[i32; 3]],
    hash: u64,
) {
    let v = out.len();
    let cuts = [0, (frame * 389) % v, v / 2 + frame, v];
    let mut first = 0;
    for &end in &cuts[1..] {
        let end = end.clamp(first, v);
        if let Err(e) = rig.deform_range(markers, first, &mut out[first..end]) {
            panic!("{name} frame {frame}: deform_range: {e}");
        }
        first = end;
    }
    let mut h = Fnv1a64::new();
    h.write_positions(out);
    assert_eq!(
        h.finish(),
        hash,
        "{name} frame {frame}: chunks differ from Rig::deform"
    );
}

/// Play the capture golden: per frame the capture stages (bracketed for the instruction
/// counter, after the deform frames), then the deformation, hashed as `hashes.txt` records them.
fn play_capture(out: &mut [[i32; 3]; MAX_VERTICES], normals: &mut [[i16; 3]; MAX_VERTICES]) {
    let rig = match Rig::from_bytes(CAPTURE) {
        Ok(rig) => rig,
        Err(e) => panic!("capture: the golden rig does not load: {e}"),
    };
    assert_aligned("capture", &rig);
    let Some(stages) = rig.stages() else {
        panic!("capture: the golden rig has no stages")
    };
    let (m, v) = (rig.marker_count(), rig.vertex_count());
    assert!(
        v <= MAX_VERTICES,
        "capture: {v} vertices, room for {MAX_VERTICES}"
    );
    let out = &mut out[..v];
    let normals = &mut normals[..v];
    let mut normals_sequence = Fnv1a64::new();
    let mut state = PlayState::new();
    let mut actor = [None; MAX_MARKERS];
    let mut markers = [[0i32; 3]; MAX_MARKERS];
    let mut sequence = Fnv1a64::new();
    let record = 13;
    let mut frames = 0;
    for frame in ACTOR.chunks_exact(m * record) {
        for (a, r) in actor.iter_mut().zip(frame.chunks_exact(record)) {
            let w = |i: usize| i32::from_le_bytes([r[i], r[i + 1], r[i + 2], r[i + 3]]);
            *a = (r[0] == 1).then(|| [w(1), w(5), w(9)]);
        }
        frame_start(frames);
        let report = stages.solve(&mut state, &actor[..m], &mut markers[..m]);
        frame_end(frames);
        if let Err(e) = rig.deform(&markers[..m], out) {
            panic!("capture frame {frames}: {e}");
        }
        let mut h = Fnv1a64::new();
        h.write_capture_frame(&markers[..m], out, &report);
        sequence.write_capture_frame(&markers[..m], out, &report);
        hprintln!("capture frame {} {:016x}", frames, h.finish());
        normals_frame(
            &rig,
            "capture",
            frames,
            out,
            normals,
            &mut normals_sequence,
            false,
        );
        frames += 1;
    }
    hprintln!("capture sequence {:016x}", sequence.finish());
    hprintln!(
        "normals capture sequence {:016x}",
        normals_sequence.finish()
    );
    hprintln!(
        "figures capture: {} frames, blob {} bytes, per frame stages {:?}",
        frames,
        CAPTURE.len(),
        stages.cost()
    );
}

/// Play the packed take from flash through the capture rig: per frame, decode (bracketed),
/// then the stages and the deformation (the deformation bracketed), hashed as
/// `hashes_take.txt` records them.
fn play_take(out: &mut [[i32; 3]; MAX_VERTICES]) {
    let rig = match Rig::from_bytes(CAPTURE) {
        Ok(rig) => rig,
        Err(e) => panic!("take: the golden capture rig does not load: {e}"),
    };
    let take = match Take::from_bytes(TAKE) {
        Ok(take) => take,
        Err(e) => panic!("take: the golden take does not load: {e}"),
    };
    let (m, t, v) = (rig.marker_count(), take.marker_count(), rig.vertex_count());
    assert!(
        v <= MAX_VERTICES,
        "take: {v} vertices, room for {MAX_VERTICES}"
    );
    let out = &mut out[..v];
    // For each rig marker, the take's marker of that name.
    let mut map = [None; MAX_MARKERS];
    for (slot, name) in map.iter_mut().zip(rig.marker_names()) {
        *slot = take.marker_index(name);
    }
    let mut reader = take.reader();
    let mut row = [None; MAX_MARKERS];
    let mut actor = [None; MAX_MARKERS];
    let mut markers = [[0i32; 3]; MAX_MARKERS];
    let mut state = PlayState::new();
    let mut sequence = Fnv1a64::new();
    let mut frames = 0;
    while frames < take.frame_count() {
        frame_start(frames);
        let decoded = reader.next_frame(&mut row[..t]);
        frame_end(frames);
        match decoded {
            Ok(Some(_)) => {}
            Ok(None) => break,
            Err(e) => panic!("take frame {frames}: {e}"),
        }
        for (a, j) in actor.iter_mut().zip(&map).take(m) {
            *a = j.and_then(|j| row[j]);
        }
        // What the frame costs besides decoding: the capture stages and the deformation.
        frame_start(frames);
        let played = rig.play_markers(&mut state, &actor[..m], &mut markers[..m]);
        let done = rig.deform(&markers[..m], out);
        frame_end(frames);
        let report = match played {
            Ok(report) => report,
            Err(e) => panic!("take frame {frames}: {e}"),
        };
        if let Err(e) = done {
            panic!("take frame {frames}: {e}");
        }
        let mut h = Fnv1a64::new();
        for hash in [&mut h, &mut sequence] {
            hash.write_samples(&actor[..m]);
            hash.write_capture_frame(&markers[..m], out, &report);
        }
        hprintln!("take frame {} {:016x}", frames, h.finish());
        frames += 1;
    }
    hprintln!("take sequence {:016x}", sequence.finish());
    hprintln!(
        "figures take: {} frames, {} markers, take {} bytes (stream {}), key interval {}",
        frames,
        t,
        TAKE.len(),
        take.stream_len(),
        take.key_interval()
    );
}

#[entry]
fn main() -> ! {
    #[cfg(feature = "alloc-canary")]
    {
        // Must not link: there is no global allocator (see the feature's comment).
        let v = alloc::vec![0u8; 4];
        black_box(&v);
    }
    #[cfg(feature = "panic-canary")]
    if black_box(true) {
        panic!("panic-canary: a deliberate panic");
    }
    let mut out = [[0i32; 3]; MAX_VERTICES];
    let mut normals = [[0i16; 3]; MAX_VERTICES];
    for (name, blob, marker_file) in RIGS {
        play(name, blob, marker_file, &mut out, &mut normals);
    }
    play_capture(&mut out, &mut normals);
    play_take(&mut out);
    hprintln!("firmware: done");
    debug::exit(debug::EXIT_SUCCESS);
    // Without a debugger or semihosting host, exit returns: park.
    loop {
        cortex_m::asm::wfi();
    }
}

/// Report the panic over semihosting and exit non-zero, so a panic fails the check.
#[panic_handler]
fn panic(info: &PanicInfo) -> ! {
    hprintln!("FAIL: firmware panicked: {}", info);
    debug::exit(debug::EXIT_FAILURE);
    loop {
        cortex_m::asm::wfi();
    }
}
