//! Packed takes (`.fbt`): a capture compressed into the runtime's take format
//! (`facebake_runtime::take`, whose docs give the byte layout), and read back.
//!
//! [`pack`] quantises every marker to the step its error bound allows (|error| ≤ bound),
//! predicts each sample from the marker's previous ones (first or second order, whichever codes
//! each marker's block of frames in fewer bits), and bit-packs the residuals with widths chosen
//! per block; [`parse`] decodes a take with the runtime's
//! [`TakeReader`] into a [`Capture`] in the units it was recorded in. A file is a take when it
//! starts with the take magic, whatever its name (`read_capture` checks that first).

use std::path::Path;

use facebake_runtime::format::header::sealed_header;
use facebake_runtime::take::{
    TakeFields, MAX_KEY_WIDTH, MAX_WIDTH, TAKE_MAGIC, TAKE_VERSION, WIDTH_BITS,
};
use facebake_runtime::{Space, Take, TakeReader, MAX_MARKERS};

use super::{Capture, CaptureError};
use crate::model::Units;

/// Q8.24: units of the samples per unit of the space.
const POS_ONE: f64 = (1u64 << 24) as f64;

/// The smallest quantisation step, Q8.24 units: with it every `q` is within ±2²⁸, so every
/// residual, first or second order, is within the ±2³⁰ of the widest width.
pub const MIN_STEP: u32 = 8;

/// How to pack a take.
#[derive(Debug, Clone, PartialEq)]
pub struct PackOptions {
    /// The largest error of any decoded sample, millimetres.
    pub max_error_mm: f64,
    /// Tighter (or looser) bounds for named markers, millimetres.
    pub marker_max_error_mm: Vec<(String, f64)>,
    /// Frames from one key frame to the next (the most a seek decodes).
    pub key_interval: u16,
    /// Predicted frames per block of residual widths.
    pub block_frames: u16,
    /// The samples' space: a rig's actor space, so the runtime plays the decoded integers as
    /// they are; `None` for the take's own bounds.
    pub space: Option<Space>,
}

impl Default for PackOptions {
    fn default() -> Self {
        Self {
            max_error_mm: 0.1,
            marker_max_error_mm: Vec::new(),
            key_interval: 128,
            block_frames: 32,
            space: None,
        }
    }
}

/// A packed take and what it measured.
#[derive(Debug, Clone, PartialEq)]
pub struct Packed {
    /// The `.fbt` bytes.
    pub bytes: Vec<u8>,
    /// Frames.
    pub frames: usize,
    /// Markers.
    pub markers: usize,
    /// Samples missing (kept missing).
    pub missing: usize,
    /// The raw size: frames × markers × 3 × 4 bytes (32-bit coordinates).
    pub raw_bytes: usize,
    /// The largest error of a decoded sample against the capture, millimetres (measured by
    /// decoding the bytes with the runtime).
    pub max_error_mm: f64,
}

impl Packed {
    /// How many times smaller than the raw 32-bit markers.
    pub fn ratio(&self) -> f64 {
        self.raw_bytes as f64 / self.bytes.len() as f64
    }
}

/// The units code of the take format.
fn units_code(units: Units) -> u8 {
    match units {
        Units::Millimetres => 0,
        Units::Centimetres => 1,
        Units::Metres => 2,
        Units::Inches => 3,
    }
}

fn units_of(code: u8) -> Units {
    match code {
        0 => Units::Millimetres,
        1 => Units::Centimetres,
        2 => Units::Metres,
        _ => Units::Inches,
    }
}

/// Bits needed for `x`.
fn bit_len(x: u64) -> u32 {
    64 - x.leading_zeros()
}

/// Bits appended least significant first, as the runtime reads them.
#[derive(Default)]
struct BitWriter {
    bytes: Vec<u8>,
    bits: usize,
}

impl BitWriter {
    fn put(&mut self, value: u64, n: u32) {
        for i in 0..n {
            if self.bits % 8 == 0 {
                self.bytes.push(0);
            }
            if (value >> i) & 1 == 1 {
                if let Some(b) = self.bytes.last_mut() {
                    *b |= 1 << (self.bits % 8);
                }
            }
            self.bits += 1;
        }
    }

    fn flag(&mut self, on: bool) {
        self.put(u64::from(on), 1);
    }

    /// Pad to a byte boundary.
    fn align(&mut self) {
        self.bits = self.bytes.len() * 8;
    }
}

/// A frame as the stream codes it.
enum Coded {
    /// A key frame: absolute values (missing: `None`).
    Key(Vec<Option<[i64; 3]>>),
    /// A predicted frame: per marker the residuals from its first- and second-order
    /// predictions (missing: `None`).
    Predicted(Vec<Option<[[i64; 3]; 2]>>),
}

/// The width that codes every residual of `largest` magnitude or less.
fn width_for(largest: u64) -> u32 {
    if largest == 0 {
        0
    } else {
        1 + bit_len(largest - 1)
    }
}

/// Widths and bits of one marker's residuals `rows` (its present frames of a block) at one
/// prediction order.
fn block_cost(rows: &[[i64; 3]]) -> ([u32; 3], u64) {
    let widths =
        [0, 1, 2].map(|c| width_for(rows.iter().map(|r| r[c].unsigned_abs()).max().unwrap_or(0)));
    if widths == [0; 3] {
        return (widths, 0);
    }
    let bits = rows
        .iter()
        .map(|r| {
            1 + if *r == [0; 3] {
                0
            } else {
                (0..3)
                    .filter(|&c| widths[c] > 0)
                    .map(|c| 1 + if r[c] == 0 { 0 } else { u64::from(widths[c]) })
                    .sum()
            }
        })
        .sum();
    (widths, bits)
}

/// Pack `capture` (any units): see the module docs. Errors name the capture's file and, for a
/// sample that does not fit, the frame and marker.
pub fn pack(capture: &Capture, options: &PackOptions) -> Result<Packed, CaptureError> {
    let path = &capture.source;
    let err = |message: String| CaptureError::File {
        path: path.clone(),
        message,
    };
    let m = capture.marker_names.len();
    let frames = capture.frame_count();
    if m == 0 || m > MAX_MARKERS || frames == 0 || frames > u32::MAX as usize {
        return Err(err(format!(
            "a take holds 1 to {MAX_MARKERS} markers and at least one frame; this capture has {m} markers and {frames} frames"
        )));
    }
    if options.key_interval == 0
        || options.block_frames == 0
        || options.block_frames > options.key_interval
    {
        return Err(err(format!(
            "key interval {} and block {}: both must be at least 1, the block no longer than the interval",
            options.key_interval, options.block_frames
        )));
    }
    capture.check_writable(path)?;
    if let Some(name) = capture.marker_names.iter().find(|n| n.len() > 255) {
        return Err(err(format!(
            "marker name {name:?} is longer than 255 bytes"
        )));
    }
    let metres = capture.in_metres();
    let space = match options.space {
        Some(s) => s,
        None => {
            let present: Vec<[f64; 3]> =
                metres.frames.iter().flatten().filter_map(|s| *s).collect();
            let s = crate::space::space_for(&present);
            if s.half_extent > 0.0 && s.half_extent.is_finite() {
                s
            } else {
                Space {
                    half_extent: 1.0,
                    ..s
                }
            }
        }
    };
    let lsb_mm = f64::from(space.half_extent) * 1000.0 / POS_ONE;
    let steps: Vec<u32> = capture
        .marker_names
        .iter()
        .map(|name| {
            let bound = options
                .marker_max_error_mm
                .iter()
                .rev()
                .find(|(n, _)| n == name)
                .map_or(options.max_error_mm, |(_, b)| *b);
            // Just under twice the bound, so rounding keeps every error within it.
            let step = (2.0 * bound / lsb_mm * (1.0 - 1e-9)).floor();
            if step.is_nan() || step < f64::from(MIN_STEP) {
                return Err(err(format!(
                    "marker {name:?}: an error bound of {bound} mm is below this take's resolution \
                     (the bound must be at least {} mm)",
                    f64::from(MIN_STEP) * lsb_mm / 2.0
                )));
            }
            Ok(step.min(f64::from(1u32 << 30)) as u32)
        })
        .collect::<Result<_, _>>()?;

    // Quantise.
    let mut q: Vec<Vec<Option<[i64; 3]>>> = Vec::with_capacity(frames);
    for (f, frame) in metres.frames.iter().enumerate() {
        let mut row = Vec::with_capacity(m);
        for (i, sample) in frame.iter().enumerate() {
            row.push(match sample {
                None => None,
                Some(p) => {
                    let mut out = [0i64; 3];
                    for c in 0..3 {
                        let x = (p[c] - f64::from(space.centre[c])) / f64::from(space.half_extent)
                            * POS_ONE;
                        let k = (x / f64::from(steps[i])).round();
                        let value = k * f64::from(steps[i]);
                        if !value.is_finite() || value.abs() > f64::from(i32::MAX) {
                            return Err(err(format!(
                                "frame {f} (counting from 0), marker {:?}: the sample lies outside \
                                 the take's space (±128 half extents of {} m around {:?})",
                                capture.marker_names[i], space.half_extent, space.centre
                            )));
                        }
                        out[c] = k as i64;
                    }
                    Some(out)
                }
            });
        }
        q.push(row);
    }

    // Code every frame: keys absolute, the rest as residuals from each marker's last two
    // values (held while it is missing; both set to the key value at a key frame).
    let n = usize::from(options.key_interval);
    let mut last = vec![[[0i64; 3]; 2]; m];
    let mut coded = Vec::with_capacity(frames);
    for (f, row) in q.iter().enumerate() {
        if f % n == 0 {
            for (l, v) in last.iter_mut().zip(row) {
                *l = [v.unwrap_or([0; 3]); 2];
            }
            coded.push(Coded::Key(row.clone()));
        } else {
            let residuals = row
                .iter()
                .zip(last.iter_mut())
                .map(|(v, l)| {
                    v.map(|v| {
                        let [q1, q2] = *l;
                        let r = [
                            [0, 1, 2].map(|c| v[c] - q1[c]),
                            [0, 1, 2].map(|c| v[c] - (2 * q1[c] - q2[c])),
                        ];
                        *l = [v, q1];
                        r
                    })
                })
                .collect();
            coded.push(Coded::Predicted(residuals));
        }
    }
    let keyed = coded.iter().filter_map(|c| match c {
        Coded::Key(row) => Some(row),
        Coded::Predicted(_) => None,
    });
    let mut key_min = [i64::MAX; 3];
    let mut key_max = [i64::MIN; 3];
    for v in keyed.flatten().flatten() {
        for c in 0..3 {
            key_min[c] = key_min[c].min(v[c]);
            key_max[c] = key_max[c].max(v[c]);
        }
    }
    let mut key_width = [0u8; 3];
    for c in 0..3 {
        if key_min[c] > key_max[c] {
            (key_min[c], key_max[c]) = (0, 0);
        }
        key_width[c] = bit_len((key_max[c] - key_min[c]) as u64) as u8;
    }
    debug_assert!(key_width.iter().all(|&w| w <= MAX_KEY_WIDTH));

    let block = usize::from(options.block_frames);
    let mut w = BitWriter::default();
    let mut offsets = Vec::new();
    let mut widths = vec![[0u32; 3]; m];
    let mut order = vec![0usize; m];
    let mut present = vec![false; m];
    for (f, frame) in coded.iter().enumerate() {
        match frame {
            Coded::Key(row) => {
                w.align();
                offsets.push(w.bytes.len() as u32);
                for (p, v) in present.iter_mut().zip(row) {
                    *p = v.is_some();
                    w.flag(*p);
                }
                for v in row.iter().flatten() {
                    for c in 0..3 {
                        w.put((v[c] - key_min[c]) as u64, u32::from(key_width[c]));
                    }
                }
            }
            Coded::Predicted(row) => {
                if (f % n - 1) % block == 0 {
                    // Per marker, the prediction order that codes this block in fewer bits.
                    let end = (f + block).min(frames).min(f - f % n + n);
                    for i in 0..m {
                        let [first, second] = [0, 1].map(|o| {
                            let rows: Vec<[i64; 3]> = coded[f..end]
                                .iter()
                                .filter_map(|x| match x {
                                    Coded::Predicted(r) => r[i].map(|r| r[o]),
                                    Coded::Key(_) => None,
                                })
                                .collect();
                            block_cost(&rows)
                        });
                        (order[i], widths[i]) = if second.1 < first.1 {
                            (1, second.0)
                        } else {
                            (0, first.0)
                        };
                        w.flag(order[i] == 1);
                        for wc in widths[i] {
                            debug_assert!(wc <= MAX_WIDTH);
                            w.put(u64::from(wc), WIDTH_BITS);
                        }
                    }
                }
                let changed = row.iter().zip(&present).any(|(v, p)| v.is_some() != *p);
                w.flag(changed);
                if changed {
                    for (p, v) in present.iter_mut().zip(row) {
                        *p = v.is_some();
                        w.flag(*p);
                    }
                }
                for ((r, wi), o) in row.iter().zip(&widths).zip(&order) {
                    let Some(r) = r.map(|r| r[*o]) else { continue };
                    if *wi == [0; 3] {
                        continue;
                    }
                    let any = r != [0; 3];
                    w.flag(any);
                    if !any {
                        continue;
                    }
                    for c in 0..3 {
                        if wi[c] == 0 {
                            continue;
                        }
                        w.flag(r[c] != 0);
                        if r[c] != 0 {
                            w.flag(r[c] < 0);
                            w.put(r[c].unsigned_abs() - 1, wi[c] - 1);
                        }
                    }
                }
            }
        }
    }

    let fields = TakeFields {
        marker_count: m as u16,
        frame_count: frames as u32,
        key_interval: options.key_interval,
        block_frames: options.block_frames,
        units: units_code(capture.units),
        rate_hz: capture.rate_hz,
        space,
        key_width,
        key_min: key_min.map(|k| k as i32),
    };
    let mut payload = fields.to_bytes().to_vec();
    for name in &capture.marker_names {
        payload.push(name.len() as u8);
        payload.extend_from_slice(name.as_bytes());
    }
    for s in &steps {
        payload.extend_from_slice(&s.to_le_bytes());
    }
    for o in &offsets {
        payload.extend_from_slice(&o.to_le_bytes());
    }
    let stream_len = u32::try_from(w.bytes.len())
        .map_err(|_| err("the packed stream is over 4 GiB".to_string()))?;
    payload.extend_from_slice(&stream_len.to_le_bytes());
    payload.extend_from_slice(&w.bytes);
    let header = sealed_header(&TAKE_MAGIC, TAKE_VERSION, &payload)
        .map_err(|_| err("the packed take is over 4 GiB".to_string()))?;
    let mut bytes = header.to_vec();
    bytes.extend_from_slice(&payload);

    // Measure by decoding.
    let decoded = parse(path, &bytes)?;
    let k = capture.units.to_metres() * 1000.0;
    let mut max_error_mm = 0.0f64;
    for (a, b) in capture.frames.iter().zip(&decoded.frames) {
        for (x, y) in a.iter().zip(b) {
            match (x, y) {
                (Some(x), Some(y)) => {
                    for c in 0..3 {
                        max_error_mm = max_error_mm.max((x[c] - y[c]).abs() * k);
                    }
                }
                (None, None) => {}
                _ => {
                    return Err(err(
                        "decoding the packed take changed which samples are missing (a bug)"
                            .to_string(),
                    ))
                }
            }
        }
    }
    Ok(Packed {
        bytes,
        frames,
        markers: m,
        missing: capture.missing_count(),
        raw_bytes: frames * m * 12,
        max_error_mm,
    })
}

/// Whether `bytes` start like a packed take.
pub fn is_take(bytes: &[u8]) -> bool {
    bytes.starts_with(&TAKE_MAGIC)
}

/// Decode a packed take into a capture in the units it was recorded in; `path` is only used in
/// errors and as the capture's source.
pub fn parse(path: &Path, bytes: &[u8]) -> Result<Capture, CaptureError> {
    let err = |location: String, message: String| CaptureError::Binary {
        path: path.to_path_buf(),
        location,
        message,
    };
    let take = Take::from_bytes(bytes).map_err(|e| err("take".into(), e.to_string()))?;
    let units = units_of(take.source_units());
    let space = take.space();
    let scale = 1.0 / units.to_metres();
    let mut reader = TakeReader::new(take);
    let mut row = vec![None; take.marker_count()];
    let mut frames = Vec::with_capacity(take.frame_count());
    while let Some(f) = reader
        .next_frame(&mut row)
        .map_err(|e| err(format!("frame {}", reader.frame()), e.to_string()))?
    {
        debug_assert_eq!(f, frames.len());
        frames.push(
            row.iter()
                .map(|s| s.map(|q| space.to_asset_f64(q).map(|x| x * scale)))
                .collect(),
        );
    }
    Ok(Capture {
        source: path.to_path_buf(),
        rate_hz: take.rate_hz(),
        units,
        marker_names: take.marker_names().map(str::to_string).collect(),
        frames,
    })
}

#[cfg(test)]
mod tests {
    use super::super::tests::{assert_no_panics, JAW_TRC};
    use super::super::{read_capture, write_trc};
    use super::*;

    const C3D: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../fixtures/c3d/pc_real.c3d");

    fn decode_all(bytes: &[u8]) -> Vec<Vec<Option<[i32; 3]>>> {
        let take = Take::from_bytes(bytes).unwrap();
        let mut reader = take.reader();
        let mut row = vec![None; take.marker_count()];
        let mut out = Vec::new();
        while let Some(f) = reader.next_frame(&mut row).unwrap() {
            assert_eq!(f, out.len());
            out.push(row.clone());
        }
        out
    }

    /// The error bound holds on the real captures. JawMoCap (a face, smooth at 60 Hz) packs
    /// 24× smaller than raw 32-bit markers at 0.1 mm; the C3D sample (a walk: markers move up
    /// to 100 mm a frame with millimetre noise) 3.4×, where even an ideal entropy coder of its
    /// second-order residuals would stop at 5.5× (docs/measurements.md).
    #[test]
    fn real_captures_round_trip_within_the_bound_and_pack_small() {
        for (path, min_ratio) in [(JAW_TRC, 20.0), (C3D, 3.0)] {
            let capture = read_capture(Path::new(path)).unwrap();
            let packed = pack(&capture, &PackOptions::default()).unwrap();
            eprintln!(
                "{path}: {} frames × {} markers, {} missing: raw {} bytes, packed {} bytes ({:.1}×), max error {:.4} mm",
                packed.frames,
                packed.markers,
                packed.missing,
                packed.raw_bytes,
                packed.bytes.len(),
                packed.ratio(),
                packed.max_error_mm
            );
            assert!(
                packed.max_error_mm <= 0.1 * (1.0 + 1e-9),
                "{}",
                packed.max_error_mm
            );
            assert!(
                packed.max_error_mm > 0.05,
                "the bound is used: {}",
                packed.max_error_mm
            );
            assert!(
                packed.ratio() >= min_ratio,
                "{path}: {:.1}×",
                packed.ratio()
            );
            let back = parse(Path::new("x.fbt"), &packed.bytes).unwrap();
            assert_eq!(back.marker_names, capture.marker_names);
            assert_eq!(back.units, capture.units);
            assert_eq!(back.rate_hz, capture.rate_hz);
            for (a, b) in capture.frames.iter().zip(&back.frames) {
                for (x, y) in a.iter().zip(b) {
                    assert_eq!(x.is_some(), y.is_some());
                }
            }
        }
    }

    /// Seeking to any frame and decoding from there gives what sequential decoding gives.
    #[test]
    fn seek_equals_sequential_decoding() {
        let capture = read_capture(Path::new(C3D)).unwrap();
        let options = PackOptions {
            key_interval: 16,
            block_frames: 5,
            ..PackOptions::default()
        };
        let bytes = pack(&capture, &options).unwrap().bytes;
        let all = decode_all(&bytes);
        let take = Take::from_bytes(&bytes).unwrap();
        let mut reader = take.reader();
        let mut row = vec![None; take.marker_count()];
        for f in (0..all.len()).rev().chain([0, 17, 16, 15, 88]) {
            reader.seek(f).unwrap();
            assert_eq!(reader.next_frame(&mut row).unwrap(), Some(f));
            assert_eq!(row, all[f], "frame {f}");
            if f + 1 < all.len() {
                reader.next_frame(&mut row).unwrap();
                assert_eq!(row, all[f + 1], "frame {} after a seek to {f}", f + 1);
            }
        }
        reader.seek(all.len()).unwrap();
        assert_eq!(reader.next_frame(&mut row).unwrap(), None);
        assert!(matches!(
            reader.seek(all.len() + 1),
            Err(facebake_runtime::TakeFrameError::NoFrame { .. })
        ));
        let mut short = vec![None; 3];
        assert!(matches!(
            reader.next_frame(&mut short),
            Err(facebake_runtime::TakeFrameError::OutputLength { .. })
        ));
    }

    /// Missing samples stay missing, present ones within the bound, through a write as TRC and a
    /// pack with per-marker bounds; writing the decoded take as TRC and packing that again in
    /// the same space gives the same bytes (the decoded values are on the quantisation grid).
    #[test]
    fn missing_samples_and_marker_bounds_survive() {
        let mut capture = read_capture(Path::new(C3D)).unwrap();
        capture.frames[0][0] = None;
        capture.frames[40] = vec![None; capture.marker_names.len()];
        let name = capture.marker_names[3].clone();
        let options = PackOptions {
            marker_max_error_mm: vec![(name, 0.01)],
            ..PackOptions::default()
        };
        let packed = pack(&capture, &options).unwrap();
        let back = parse(Path::new("x.fbt"), &packed.bytes).unwrap();
        let mut worst = [0.0f64; 2];
        for (a, b) in capture.frames.iter().zip(&back.frames) {
            for (i, (x, y)) in a.iter().zip(b).enumerate() {
                assert_eq!(x.is_some(), y.is_some());
                if let (Some(x), Some(y)) = (x, y) {
                    for c in 0..3 {
                        let e = (x[c] - y[c]).abs();
                        let slot = usize::from(i != 3);
                        worst[slot] = worst[slot].max(e);
                    }
                }
            }
        }
        assert!(worst[0] <= 0.01 && worst[1] <= 0.1, "{worst:?}");
        assert!(worst[1] > 0.05);
        let dir = std::env::temp_dir().join(format!("facebake-take-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let trc = dir.join("back.trc");
        write_trc(&trc, &back).unwrap();
        let again = read_capture(&trc).unwrap();
        let same_space = PackOptions {
            space: Some(Take::from_bytes(&packed.bytes).unwrap().space()),
            ..options
        };
        assert!(pack(&again, &same_space).unwrap().bytes == packed.bytes);
        // A take is read by its magic whatever its name.
        let disguised = dir.join("take.trc");
        std::fs::write(&disguised, &packed.bytes).unwrap();
        assert_eq!(read_capture(&disguised).unwrap().frames, back.frames);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// Truncated and corrupted takes are errors, never panics; so are bad options.
    #[test]
    fn corrupt_takes_and_bad_options_are_errors() {
        let capture = read_capture(Path::new(C3D)).unwrap();
        let bytes = pack(&capture, &PackOptions::default()).unwrap().bytes;
        assert_no_panics(&bytes, |b| parse(Path::new("x.fbt"), b).map(|_| ()));
        // Resealed after corruption, so the checksum passes and the decoder meets the damage.
        let header = facebake_runtime::format::records::HEADER_LEN;
        let mut state = 7u64;
        let mut decode_errors = 0;
        for round in 0..2000 {
            let mut payload = bytes[header..].to_vec();
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let at = (state >> 33) as usize % payload.len();
            payload[at] ^= 1 << (round % 8);
            let mut b = sealed_header(&TAKE_MAGIC, TAKE_VERSION, &payload)
                .unwrap()
                .to_vec();
            b.extend_from_slice(&payload);
            decode_errors += usize::from(parse(Path::new("x.fbt"), &b).is_err());
        }
        assert!(decode_errors > 0);
        let e = pack(
            &capture,
            &PackOptions {
                key_interval: 4,
                block_frames: 5,
                ..PackOptions::default()
            },
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("key interval 4 and block 5"), "{e}");
        let e = pack(
            &capture,
            &PackOptions {
                max_error_mm: 1e-9,
                ..PackOptions::default()
            },
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("below this take's resolution"), "{e}");
    }
}
