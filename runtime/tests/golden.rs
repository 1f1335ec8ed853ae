//! Bit-identical output on every architecture: the committed golden rigs and marker sequence
//! (`fixtures/golden/`, derived from the baker by `tests/tests/golden.rs`) must give exactly the
//! frame hashes in `hashes.txt` and `hashes_planar.txt`, and their normals ([`Rig::normals`])
//! those in `hashes_normals.txt`.
//!
//! This test needs only the runtime crate, so it cross-builds in seconds and runs under
//! qemu-user on aarch64, 32-bit big-endian PowerPC and i686 (`.ci/cross.sh`). The data is
//! compiled in, so the test binary needs no file access on the emulated target.

use facebake_runtime::checksum::Fnv1a64;
use facebake_runtime::Rig;

const COEFFICIENTS: &[u8] = include_bytes!("../../fixtures/golden/facecap_coefficients.fbk");
const WEIGHTS: &[u8] = include_bytes!("../../fixtures/golden/facecap_weights.fbk");
const COEFFICIENTS_K4: &[u8] = include_bytes!("../../fixtures/golden/facecap_coefficients_k4.fbk");
const PLANAR: &[u8] = include_bytes!("../../fixtures/golden/facecap_planar.fbk");
const PRODUCT: &[u8] = include_bytes!("../../fixtures/golden/facecap_product.fbk");
const MARKERS: &[u8] = include_bytes!("../../fixtures/golden/facecap_markers.bin");
const LAYOUT_MARKERS: &[u8] = include_bytes!("../../fixtures/golden/facecap_layout_markers.bin");
const HASHES: &str = include_str!("../../fixtures/golden/hashes.txt");
const PLANAR_HASHES: &str = include_str!("../../fixtures/golden/hashes_planar.txt");
const NORMALS_HASHES: &str = include_str!("../../fixtures/golden/hashes_normals.txt");

/// Ground-truth frames (32) plus edge frames (7): what the golden generator writes.
const EXPECTED_FRAMES: usize = 39;

/// The expected hash of `rig`'s frame `what` ("frame N" or "sequence") from `hashes.txt`.
fn expected(rig: &str, what: &str) -> u64 {
    let key = format!("{rig} {what} ");
    let line = HASHES
        .lines()
        .chain(PLANAR_HASHES.lines())
        .find(|l| l.starts_with(&key))
        .unwrap_or_else(|| panic!("hashes.txt has no line for {rig} {what}"));
    u64::from_str_radix(&line[key.len()..], 16).expect("a 64-bit hex hash")
}

/// The expected hash of `rig`'s normals at frame `what` from `hashes_normals.txt`.
fn expected_normals(rig: &str, what: &str) -> u64 {
    let key = format!("{rig} {what} ");
    let line = NORMALS_HASHES
        .lines()
        .find(|l| l.starts_with(&key))
        .unwrap_or_else(|| panic!("hashes_normals.txt has no line for {rig} {what}"));
    u64::from_str_radix(&line[key.len()..], 16).expect("a 64-bit hex hash")
}

/// The marker sequence in `file`: frames of `markers` × 3 `i32` LE.
fn frames(file: &[u8], markers: usize) -> Vec<Vec<[i32; 3]>> {
    let words: Vec<i32> = file
        .chunks_exact(4)
        .map(|b| i32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect();
    assert_eq!(words.len() % (3 * markers), 0, "whole frames only");
    words
        .chunks_exact(3 * markers)
        .map(|f| f.chunks_exact(3).map(|p| [p[0], p[1], p[2]]).collect())
        .collect()
}

/// Per-frame and sequence hashes of a rig's positions and of their normals, against
/// `hashes.txt` (or `hashes_planar.txt`) and `hashes_normals.txt`.
struct Hashes<'a> {
    name: &'a str,
    rig: Rig<'a>,
    positions: Fnv1a64,
    normals: Fnv1a64,
    normal_buffer: Vec<[i16; 3]>,
    wrong: Vec<String>,
}

impl<'a> Hashes<'a> {
    fn new(name: &'a str, rig: Rig<'a>) -> Self {
        Self {
            name,
            rig,
            positions: Fnv1a64::new(),
            normals: Fnv1a64::new(),
            normal_buffer: vec![[0; 3]; rig.vertex_count()],
            wrong: Vec::new(),
        }
    }

    /// Check frame `f`'s normals of `out`, whose own hash `h` the caller computed.
    fn frame(&mut self, f: usize, h: u64, out: &[[i32; 3]]) {
        let want = expected(self.name, &format!("frame {f}"));
        if h != want {
            self.wrong
                .push(format!("frame {f}: {h:016x}, want {want:016x}"));
        }
        self.rig.normals(out, &mut self.normal_buffer).unwrap();
        let mut n = Fnv1a64::new();
        n.write_normals(&self.normal_buffer);
        self.normals.write_normals(&self.normal_buffer);
        let want = expected_normals(self.name, &format!("frame {f}"));
        if n.finish() != want {
            self.wrong.push(format!(
                "normals frame {f}: {:016x}, want {want:016x}",
                n.finish()
            ));
        }
    }

    fn finish(self, sequence: u64) {
        assert!(
            self.wrong.is_empty(),
            "{}: frames differ on this target:\n{}",
            self.name,
            self.wrong.join("\n")
        );
        assert_eq!(sequence, expected(self.name, "sequence"), "{}", self.name);
        assert_eq!(
            self.normals.finish(),
            expected_normals(self.name, "sequence"),
            "{} normals",
            self.name
        );
    }
}

/// Play `blob` through the marker frames in `markers` and compare every hash.
fn check(name: &str, blob: &[u8], markers: &[u8]) {
    let rig = Rig::from_bytes(blob).expect("golden rig loads");
    let frames = frames(markers, rig.marker_count());
    assert_eq!(frames.len(), EXPECTED_FRAMES);
    let mut out = vec![[0i32; 3]; rig.vertex_count()];
    let mut chunked = vec![[0i32; 3]; rig.vertex_count()];
    let mut table = Box::new(facebake_runtime::FrameTable::new());
    let mut hashes = Hashes::new(name, rig);
    for (f, markers) in frames.iter().enumerate() {
        rig.deform(markers, &mut out).unwrap();
        // The same frame prepared once and deformed in uneven chunks: the same integers.
        rig.prepare(markers, &mut table).unwrap();
        let cut = (f * 389) % chunked.len();
        let (a, b) = chunked.split_at_mut(cut);
        rig.deform_chunk(&table, 0, a).unwrap();
        rig.deform_chunk(&table, cut, b).unwrap();
        assert_eq!(
            out, chunked,
            "{name} frame {f}: chunks from a prepared table"
        );
        let mut h = Fnv1a64::new();
        h.write_positions(&out);
        hashes.positions.write_positions(&out);
        hashes.frame(f, h.finish(), &out);
    }
    let sequence = hashes.positions.finish();
    hashes.finish(sequence);
}

#[test]
fn coefficients_rig_is_bit_identical_to_the_golden_hashes() {
    check("coefficients", COEFFICIENTS, MARKERS);
}

#[test]
fn weights_rig_is_bit_identical_to_the_golden_hashes() {
    check("weights", WEIGHTS, MARKERS);
}

#[test]
fn k4_coefficients_rig_is_bit_identical_to_the_golden_hashes() {
    check("coefficients_k4", COEFFICIENTS_K4, MARKERS);
}

/// What `facebake bake` makes with no options: the linear deformer with derived markers (the
/// mouth's projections and the followed markers' mean), played through the layout's markers.
#[test]
fn product_rig_is_bit_identical_to_the_golden_hashes() {
    check("product", PRODUCT, LAYOUT_MARKERS);
}

#[test]
fn planar_rig_is_bit_identical_to_the_golden_hashes() {
    check("planar", PLANAR, MARKERS);
}

/// The fixed-point primitives at their range edges, beyond the unit tests in `fixed.rs`
/// (which run on every target too): the extreme shifts and bit patterns.
#[test]
fn fixed_point_primitives_at_the_extremes() {
    use facebake_runtime::fixed::{
        mul_acc, pack_influence, round_shift_sat, unpack_influence, widen_rest,
    };
    assert_eq!(round_shift_sat(1, 1), 1); // ½ rounds up
    assert_eq!(round_shift_sat(-1, 1), 0); // −½ rounds up
    assert_eq!(round_shift_sat(-3, 1), -1);
    assert_eq!(round_shift_sat(i64::MAX, 1), i32::MAX);
    assert_eq!(round_shift_sat(i64::MIN, 1), i32::MIN);
    // Adding ½ saturates at i64::MAX, so the very top rounds down (accumulators stay below 2⁶⁰,
    // so the deformers never get there); pinned because it is still the contract on every target.
    assert_eq!(round_shift_sat(i64::MAX, 62), 1);
    assert_eq!(round_shift_sat(i64::MIN, 62), -2);
    assert_eq!(round_shift_sat(1 << 61, 62), 1);
    assert_eq!(round_shift_sat((1 << 61) - 1, 62), 0);
    assert_eq!(unpack_influence(0xFFFF_FFFF), (255, -1));
    assert_eq!(unpack_influence(0x8000_0000), (0, -(1 << 23)));
    assert_eq!(unpack_influence(0x7FFF_FF00), (0, (1 << 23) - 1));
    assert_eq!(pack_influence(255, -1), Some(0xFFFF_FFFF));
    assert_eq!(widen_rest(0), 0);
    assert_eq!(widen_rest(1), 512);
    assert_eq!(widen_rest(i16::MIN + 1), -(1 << 24) + 512);
    assert_eq!(mul_acc(i64::MAX - 1, 1, 1), i64::MAX);
    assert_eq!(mul_acc(0, -1, i32::MIN), 1 << 31);
    assert_eq!(mul_acc(-5, 3, -7), -26);
}

const CAPTURE: &[u8] = include_bytes!("../../fixtures/golden/jawmocap_capture.fbk");
const ACTOR: &[u8] = include_bytes!("../../fixtures/golden/jawmocap_actor.bin");

/// The capture golden: actor frames through compensation, fill, retargeting and deformation.
#[test]
fn capture_stages_are_bit_identical_to_the_golden_hashes() {
    let rig = Rig::from_bytes(CAPTURE).expect("golden capture rig loads");
    let stages = rig.stages().expect("the golden capture rig has stages");
    let m = rig.marker_count();
    let record = 1 + 12;
    assert_eq!(ACTOR.len() % (m * record), 0, "whole frames only");
    let mut state = facebake_runtime::PlayState::new();
    let mut markers = vec![[0i32; 3]; m];
    let mut out = vec![[0i32; 3]; rig.vertex_count()];
    let mut hashes = Hashes::new("capture", rig);
    for (f, frame) in ACTOR.chunks_exact(m * record).enumerate() {
        let actor: Vec<Option<[i32; 3]>> = frame
            .chunks_exact(record)
            .map(|r| {
                let w = |i: usize| i32::from_le_bytes([r[i], r[i + 1], r[i + 2], r[i + 3]]);
                (r[0] == 1).then(|| [w(1), w(5), w(9)])
            })
            .collect();
        let report = stages.solve(&mut state, &actor, &mut markers);
        rig.deform(&markers, &mut out).unwrap();
        let mut h = Fnv1a64::new();
        h.write_capture_frame(&markers, &out, &report);
        hashes
            .positions
            .write_capture_frame(&markers, &out, &report);
        hashes.frame(f, h.finish(), &out);
    }
    let sequence = hashes.positions.finish();
    hashes.finish(sequence);
}

const TAKE: &[u8] = include_bytes!("../../fixtures/golden/jawmocap.fbt");
const TAKE_HASHES: &str = include_str!("../../fixtures/golden/hashes_take.txt");

/// The take golden: JawMoCap packed, decoded frame by frame and played through the capture rig.
#[test]
fn packed_take_plays_bit_identical_to_the_golden_hashes() {
    use facebake_runtime::Take;
    let rig = Rig::from_bytes(CAPTURE).expect("golden capture rig loads");
    let take = Take::from_bytes(TAKE).expect("golden take loads");
    let map: Vec<Option<usize>> = rig.marker_names().map(|n| take.marker_index(n)).collect();
    let mut reader = take.reader();
    let mut row = vec![None; take.marker_count()];
    let mut actor = vec![None; rig.marker_count()];
    let mut state = facebake_runtime::PlayState::new();
    let mut markers = vec![[0i32; 3]; rig.marker_count()];
    let mut out = vec![[0i32; 3]; rig.vertex_count()];
    let mut sequence = Fnv1a64::new();
    let mut lines = TAKE_HASHES.lines().filter(|l| l.starts_with("take "));
    let mut wrong = Vec::new();
    while let Some(f) = reader.next_frame(&mut row).expect("golden take decodes") {
        for (a, j) in actor.iter_mut().zip(&map) {
            *a = j.and_then(|j| row[j]);
        }
        let report = rig.play_markers(&mut state, &actor, &mut markers).unwrap();
        rig.deform(&markers, &mut out).unwrap();
        let mut h = Fnv1a64::new();
        for hash in [&mut h, &mut sequence] {
            hash.write_samples(&actor);
            hash.write_capture_frame(&markers, &out, &report);
        }
        let line = format!("take frame {f} {:016x}", h.finish());
        if lines.next() != Some(line.as_str()) {
            wrong.push(line);
        }
    }
    assert!(
        wrong.is_empty(),
        "take: frames differ on this target:\n{}",
        wrong[..wrong.len().min(10)].join("\n")
    );
    assert_eq!(
        lines.next(),
        Some(format!("take sequence {:016x}", sequence.finish()).as_str())
    );
    assert_eq!(lines.next(), None);
}
