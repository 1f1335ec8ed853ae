//! C3D: the binary biomechanics capture format (<https://www.c3d.org>), 3D point data only.
//!
//! Reads the header block, the parameter section and the point samples of each frame, for all
//! three processor formats (Intel: little-endian IEEE; DEC: little-endian words, VAX F-floating
//! reals; SGI/MIPS: big-endian IEEE) and both storage kinds (scaled 16-bit integers when
//! `POINT:SCALE` is positive, 32-bit reals when it is negative). Marker names are the trimmed
//! `POINT:LABELS` (continued in `LABELS2`, `LABELS3`, … past 255), the rate `POINT:RATE` (the
//! header's when absent), the units `POINT:UNITS`. A point whose fourth (residual) word is
//! negative is invalid and read as missing, and so is a real coordinate that is not finite.
//! Analog samples are skipped, events and other groups ignored.
//!
//! # Why not `c3dio`
//!
//! The brief was to use the `c3dio` crate (0.8) unless it failed a case. It reads the six
//! Sample02 variants correctly, but fails these:
//!
//! * **It panics on corrupt input.** A parameter whose dimensions multiply past `usize` (a few
//!   random bytes in the parameter section are enough) hits an unchecked multiplication in its
//!   parameter parser: "attempt to multiply with overflow" in debug builds, a wrapped size in
//!   release ones. Our readers must return an error on every input, never panic: changing 4
//!   random bytes among the first 6000 of `pc_int.c3d` made `c3dio::C3d::from_bytes` panic in 7
//!   of 300 tries, where this reader passes the fuzz test below (and 360 000 such tries over
//!   the six files).
//! * **A truncated data section is silently shortened** to the frames that fit, not reported.
//! * **Its invalid-point test reads the residual byte, not the word's sign**: an integer point
//!   whose fourth word is negative but whose low byte is positive comes back valid, and a valid
//!   real point whose residual byte is 128 or more comes back invalid.
//! * **Its errors carry no position** (`InvalidParameterData`, with no byte offset or parameter).
//! * It also parses analog, force-plate and event data, so a corrupt analog parameter rejects a
//!   file whose marker data is fine.
//!
//! So this module reads C3D itself, from the public specification, in a few hundred lines.

use super::{Capture, CaptureError, Units};
use std::collections::HashMap;
use std::path::Path;

const BLOCK: usize = 512;

/// The number formats of the three processor types a C3D file can be written by.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Processor {
    Intel,
    Dec,
    Sgi,
}

impl Processor {
    fn i16(self, b: [u8; 2]) -> i16 {
        match self {
            Processor::Sgi => i16::from_be_bytes(b),
            Processor::Intel | Processor::Dec => i16::from_le_bytes(b),
        }
    }

    fn u16(self, b: [u8; 2]) -> u16 {
        self.i16(b) as u16
    }

    fn f32(self, b: [u8; 4]) -> f32 {
        match self {
            Processor::Intel => f32::from_le_bytes(b),
            Processor::Sgi => f32::from_be_bytes(b),
            // VAX F-floating: two little-endian 16-bit words, the one with sign and exponent
            // first; with the words swapped the bits read as IEEE, except that the exponent bias
            // is 128 rather than 127 and the hidden bit stands at 0.5 rather than 1, so the IEEE
            // reading is 4 times too large. A zero exponent is zero.
            Processor::Dec if b[1] & 0x7f == 0 && b[0] & 0x80 == 0 => 0.0,
            Processor::Dec => f32::from_le_bytes([b[2], b[3], b[0], b[1]]) / 4.0,
        }
    }
}

/// The storage type of a parameter's elements.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    Char,
    Byte,
    Int,
    Real,
}

impl Kind {
    fn size(self) -> usize {
        match self {
            Kind::Char | Kind::Byte => 1,
            Kind::Int => 2,
            Kind::Real => 4,
        }
    }
}

/// One parameter: its element kind, dimensions and raw data.
#[derive(Debug)]
struct Param<'a> {
    /// `GROUP:NAME`, for errors.
    key: String,
    kind: Kind,
    dims: Vec<usize>,
    data: &'a [u8],
}

/// A C3D file being read: its bytes, processor format and parsed parameters.
struct Reader<'a> {
    path: &'a Path,
    bytes: &'a [u8],
    processor: Processor,
    params: HashMap<String, Param<'a>>,
}

/// Builds a [`CaptureError::Binary`].
fn error(path: &Path, location: impl Into<String>, message: impl Into<String>) -> CaptureError {
    CaptureError::Binary {
        path: path.to_path_buf(),
        location: location.into(),
        message: message.into(),
    }
}

/// `len` bytes of `bytes` from `offset`, or an error saying the file ends before `what`.
fn slice<'a>(
    path: &Path,
    bytes: &'a [u8],
    offset: usize,
    len: usize,
    what: &str,
) -> Result<&'a [u8], CaptureError> {
    offset
        .checked_add(len)
        .and_then(|end| bytes.get(offset..end))
        .ok_or_else(|| {
            error(
                path,
                format!("byte {}", bytes.len()),
                format!(
                    "truncated file: it ends before {what} (bytes {offset}..{})",
                    offset.saturating_add(len)
                ),
            )
        })
}

impl<'a> Reader<'a> {
    fn take(&self, offset: usize, len: usize, what: &str) -> Result<&'a [u8], CaptureError> {
        slice(self.path, self.bytes, offset, len, what)
    }

    fn i16_at(&self, offset: usize, what: &str) -> Result<i16, CaptureError> {
        let b = self.take(offset, 2, what)?;
        Ok(self.processor.i16([b[0], b[1]]))
    }

    fn u16_at(&self, offset: usize, what: &str) -> Result<u16, CaptureError> {
        Ok(self.i16_at(offset, what)? as u16)
    }

    fn f32_at(&self, offset: usize, what: &str) -> Result<f32, CaptureError> {
        let b = self.take(offset, 4, what)?;
        Ok(self.processor.f32([b[0], b[1], b[2], b[3]]))
    }

    /// Reads the parameter section that starts at `start`: its 4-byte preamble, then the group
    /// and parameter records, each linked to the next by a relative offset.
    fn read_parameters(&mut self, start: usize) -> Result<(), CaptureError> {
        let blocks = self.take(start, 4, "the parameter section")?[2] as usize;
        let end = start + blocks.max(1) * BLOCK;
        let section = self.take(start, end - start, "the end of the parameter section")?;
        let mut groups: HashMap<u8, String> = HashMap::new();
        let mut params: Vec<(u8, String, Param<'a>)> = Vec::new();
        let mut pos = 4;
        loop {
            let at = start + pos;
            let record = |len: usize| self.take(at, len, "the end of a parameter record");
            let head = record(2)?;
            let name_len = (head[0] as i8).unsigned_abs() as usize;
            let id = head[1] as i8;
            if name_len == 0 {
                break;
            }
            let raw_name = &record(2 + name_len + 2)?[2..2 + name_len];
            let name = String::from_utf8_lossy(raw_name)
                .trim()
                .to_ascii_uppercase();
            let offset_at = pos + 2 + name_len;
            let next = self.i16_at(start + offset_at, "a parameter record")?;
            let body = offset_at + 2;
            if id < 0 {
                groups.insert(id.unsigned_abs(), name.clone());
            } else if id > 0 {
                params.push((
                    id as u8,
                    name.clone(),
                    self.read_param(section, body, &name, at)?,
                ));
            }
            // The offset counts from the offset word itself; 0 marks the last record.
            if next == 0 {
                break;
            }
            if next < 0 {
                return Err(error(
                    self.path,
                    format!("byte {}", start + offset_at),
                    format!("parameter record {name:?} links backwards ({next})"),
                ));
            }
            pos = offset_at + next as usize;
            if pos + 2 > section.len() {
                break;
            }
        }
        for (id, name, mut param) in params {
            // A parameter of a group that is not declared is unreachable by name: skip it.
            if let Some(group) = groups.get(&id) {
                param.key = format!("{group}:{name}");
                self.params.insert(param.key.clone(), param);
            }
        }
        Ok(())
    }

    /// Reads one parameter's type, dimensions and data from `section[body..]`.
    fn read_param(
        &self,
        section: &'a [u8],
        body: usize,
        name: &str,
        at: usize,
    ) -> Result<Param<'a>, CaptureError> {
        let bad = |message: String| {
            error(
                self.path,
                format!("byte {at}"),
                format!("parameter {name:?}: {message}"),
            )
        };
        let too_short = || bad("runs past the end of the parameter section".into());
        let head = section.get(body..body + 2).ok_or_else(too_short)?;
        let kind = match head[0] as i8 {
            -1 => Kind::Char,
            1 => Kind::Byte,
            2 => Kind::Int,
            4 => Kind::Real,
            other => return Err(bad(format!("unknown element type {other}"))),
        };
        let ndims = head[1] as usize;
        let dims: Vec<usize> = section
            .get(body + 2..body + 2 + ndims)
            .ok_or_else(too_short)?
            .iter()
            .map(|&d| d as usize)
            .collect();
        // At most 255 dimensions of at most 255: checked, as the product can overflow.
        let len = dims
            .iter()
            .try_fold(kind.size(), |n, &d| n.checked_mul(d))
            .ok_or_else(too_short)?;
        let data_at = body + 2 + ndims;
        let data = data_at
            .checked_add(len)
            .and_then(|end| section.get(data_at..end))
            .ok_or_else(too_short)?;
        Ok(Param {
            key: name.to_string(),
            kind,
            dims,
            data,
        })
    }

    fn param(&self, key: &str) -> Option<&Param<'a>> {
        self.params.get(key)
    }

    fn param_error(&self, param: &Param, message: impl Into<String>) -> CaptureError {
        error(self.path, format!("parameter {}", param.key), message)
    }

    /// The parameter's elements as numbers (integers read as unsigned 16-bit, as the
    /// specification asks for counts).
    fn numbers(&self, param: &Param) -> Result<Vec<f64>, CaptureError> {
        let p = self.processor;
        Ok(match param.kind {
            Kind::Byte => param.data.iter().map(|&b| b as f64).collect(),
            Kind::Int => param
                .data
                .chunks_exact(2)
                .map(|b| p.u16([b[0], b[1]]) as f64)
                .collect(),
            Kind::Real => param
                .data
                .chunks_exact(4)
                .map(|b| p.f32([b[0], b[1], b[2], b[3]]) as f64)
                .collect(),
            Kind::Char => {
                return Err(self.param_error(param, "is text where a number was expected"))
            }
        })
    }

    /// The parameter's first element as a number, if it is present.
    fn number(&self, key: &str) -> Result<Option<f64>, CaptureError> {
        let Some(param) = self.param(key) else {
            return Ok(None);
        };
        match self.numbers(param)?.first() {
            Some(&v) => Ok(Some(v)),
            None => Err(self.param_error(param, "has no value")),
        }
    }

    /// A text parameter as its strings (the first dimension is the string length), trimmed.
    fn strings(&self, param: &Param) -> Result<Vec<String>, CaptureError> {
        if param.kind != Kind::Char {
            return Err(self.param_error(param, "is a number where text was expected"));
        }
        let width = param.dims.first().copied().unwrap_or(1).max(1);
        Ok(param
            .data
            .chunks(width)
            .map(|s| {
                String::from_utf8_lossy(s)
                    .trim_matches([' ', '\0'])
                    .to_string()
            })
            .collect())
    }

    /// `used` marker labels from POINT:LABELS, LABELS2, LABELS3, …
    fn labels(&self, used: usize) -> Result<Vec<String>, CaptureError> {
        let mut labels = Vec::with_capacity(used);
        for n in 1.. {
            if labels.len() >= used {
                break;
            }
            let key = if n == 1 {
                "POINT:LABELS".to_string()
            } else {
                format!("POINT:LABELS{n}")
            };
            let Some(param) = self.param(&key) else {
                return Err(error(
                    self.path,
                    format!("parameter {key}"),
                    format!("missing: {} labels found for {used} points", labels.len()),
                ));
            };
            labels.extend(self.strings(param)?);
        }
        labels.truncate(used);
        if let Some(i) = labels.iter().position(String::is_empty) {
            return Err(error(
                self.path,
                "parameter POINT:LABELS",
                format!("point {} has an empty label", i + 1),
            ));
        }
        if let Some(name) = super::first_duplicate(&labels) {
            return Err(error(
                self.path,
                "parameter POINT:LABELS",
                format!("duplicate marker name {name:?}"),
            ));
        }
        Ok(labels)
    }
}

/// Checks the header's key byte, finds the processor format and reads the parameter section.
fn open<'a>(path: &'a Path, bytes: &'a [u8]) -> Result<(Reader<'a>, usize), CaptureError> {
    let header = slice(path, bytes, 0, BLOCK, "the end of the 512-byte header")?;
    if header[1] != 0x50 {
        return Err(error(
            path,
            "byte 1",
            format!("not a C3D file: key byte 0x{:02x}, not 0x50", header[1]),
        ));
    }
    let parameter_block = header[0] as usize;
    if parameter_block == 0 {
        return Err(error(path, "byte 0", "parameter section block number is 0"));
    }
    let params_at = (parameter_block - 1) * BLOCK;
    let processor_at = params_at + 3;
    let processor = match slice(path, bytes, processor_at, 1, "the parameter section")?[0] {
        84 => Processor::Intel,
        85 => Processor::Dec,
        86 => Processor::Sgi,
        other => {
            return Err(error(
                path,
                format!("byte {processor_at}"),
                format!(
                    "unknown processor type {other} (expected 84 Intel, 85 DEC or 86 SGI/MIPS)"
                ),
            ))
        }
    };
    let mut r = Reader {
        path,
        bytes,
        processor,
        params: HashMap::new(),
    };
    r.read_parameters(params_at)?;
    Ok((r, params_at))
}

/// Parses the bytes of a C3D file; `units` is the caller's override, needed when the file has no
/// `POINT:UNITS`. `path` is only used in errors and as the capture's source.
pub(super) fn parse(
    path: &Path,
    bytes: &[u8],
    units: Option<Units>,
) -> Result<Capture, CaptureError> {
    let (r, params_at) = open(path, bytes)?;
    let processor = r.processor;
    // Header words (1-based in the specification): 2 points, 3 analog samples per frame,
    // 4-5 first and last frame, 7-8 scale, 9 data start block, 11-12 frame rate.
    let points = r.u16_at(2, "the header")? as usize;
    if points == 0 {
        return Err(error(path, "byte 2", "the file holds no 3D points"));
    }
    let analog_per_frame = r.u16_at(4, "the header")? as usize;
    let (first, last) = (r.u16_at(6, "the header")?, r.u16_at(8, "the header")?);
    let header_scale = r.f32_at(12, "the header")?;
    let header_rate = r.f32_at(20, "the header")?;

    if let Some(used) = r.number("POINT:USED")? {
        if used as usize != points {
            return Err(error(
                path,
                "parameter POINT:USED",
                format!("{used} points, but the header (byte 2) says {points}"),
            ));
        }
    }
    let scale = r.number("POINT:SCALE")?.unwrap_or(header_scale as f64);
    if (scale < 0.0) != (header_scale < 0.0) || !scale.is_finite() || scale == 0.0 {
        return Err(error(
            path,
            "parameter POINT:SCALE",
            format!("{scale} does not match the header's {header_scale} (byte 12)"),
        ));
    }
    let rate_hz = match r.number("POINT:RATE")? {
        Some(rate) => rate,
        None => header_rate as f64,
    };
    if !super::valid_rate(rate_hz) {
        return Err(error(
            path,
            "parameter POINT:RATE",
            format!(
                "invalid rate {rate_hz} Hz (expected {} to {} Hz)",
                super::RATE_RANGE_HZ.start(),
                super::RATE_RANGE_HZ.end()
            ),
        ));
    }
    let units = match (units, r.param("POINT:UNITS")) {
        (Some(units), _) => units,
        (None, Some(param)) => {
            let text = r.strings(param)?.into_iter().next().unwrap_or_default();
            text.parse::<Units>()
                .map_err(|e| r.param_error(param, e.to_string()))?
        }
        (None, None) => {
            return Err(error(
                path,
                "parameter POINT:UNITS",
                "missing: units are not guessed; pass the units explicitly",
            ))
        }
    };
    let marker_names = r.labels(points)?;

    // Frame count: the header's range, or POINT:FRAMES when that is larger (the header's 16-bit
    // frame numbers cannot count past 65535).
    if last < first {
        return Err(error(
            path,
            "byte 8",
            format!("last frame {last} is before the first frame {first}"),
        ));
    }
    let mut frame_count = (last - first) as usize + 1;
    if let Some(frames) = r.number("POINT:FRAMES")? {
        frame_count = frame_count.max(frames as usize);
    }
    let data_block = match r.u16_at(16, "the header")? {
        0 => r.number("POINT:DATA_START")?.unwrap_or(0.0) as usize,
        block => block as usize,
    };
    if data_block.saturating_mul(BLOCK) <= params_at {
        return Err(error(
            path,
            "byte 16",
            format!("data start block {data_block} is not after the parameter section"),
        ));
    }
    let data_at = (data_block - 1).saturating_mul(BLOCK);

    let real = scale < 0.0;
    let word = if real { 4 } else { 2 };
    let point_bytes = 4 * word;
    let frame_bytes = (points * 4 + analog_per_frame) * word;
    let data_len = frame_count.saturating_mul(frame_bytes);
    let what = format!("the data of {frame_count} frames of {points} points");
    let data = slice(path, bytes, data_at, data_len, &what)?;
    let sample = |p: &[u8]| {
        let mut xyzw = [0.0f64; 4];
        for (k, v) in xyzw.iter_mut().enumerate() {
            *v = if real {
                processor.f32([p[4 * k], p[4 * k + 1], p[4 * k + 2], p[4 * k + 3]]) as f64
            } else {
                processor.i16([p[2 * k], p[2 * k + 1]]) as f64 * scale
            };
        }
        let valid = xyzw[3] >= 0.0 && xyzw[..3].iter().all(|v| v.is_finite());
        valid.then_some([xyzw[0], xyzw[1], xyzw[2]])
    };
    // `points` is at least 1, so `frame_bytes` is too and the data slice bounds `frame_count`.
    let frames = data
        .chunks_exact(frame_bytes)
        .map(|frame| {
            frame[..points * point_bytes]
                .chunks_exact(point_bytes)
                .map(sample)
                .collect()
        })
        .collect();
    Ok(Capture {
        source: path.to_path_buf(),
        rate_hz,
        units,
        marker_names,
        frames,
    })
}

#[cfg(test)]
mod tests {
    use super::super::read_capture;
    use super::*;

    const DIR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../fixtures/c3d/");
    const VARIANTS: [&str; 6] = [
        "pc_int", "pc_real", "sgi_int", "sgi_real", "dec_int", "dec_real",
    ];

    fn file(name: &str) -> std::path::PathBuf {
        Path::new(DIR).join(format!("{name}.c3d"))
    }

    fn bytes(name: &str) -> Vec<u8> {
        std::fs::read(file(name)).unwrap()
    }

    fn err(bytes: &[u8]) -> String {
        parse(Path::new("bad.c3d"), bytes, None)
            .unwrap_err()
            .to_string()
    }

    #[test]
    fn sample02_reads_in_all_six_variants_alike() {
        let reference = read_capture(&file("pc_real")).unwrap();
        assert_eq!(reference.marker_names.len(), 36);
        assert_eq!(reference.frame_count(), 89);
        assert_eq!(reference.rate_hz, 50.0);
        assert_eq!(reference.units, Units::Millimetres);
        assert_eq!(reference.marker_names[0], "RFT1");
        let missing = reference.missing_count();
        assert!(
            missing > 0 && missing < 89 * 36 / 4,
            "{missing} missing samples"
        );
        // The header's integer scale factor: the precision of the integer variants. dec_int
        // agrees with the reals to f32 rounding; pc_int and sgi_int hold the same integers as
        // each other but one step off dec_int at 58 samples (the files' own rounding: the
        // c3dio crate reads the same values).
        let scale = 0.281_181_87;
        for name in VARIANTS {
            let c = read_capture(&file(name)).unwrap();
            assert_eq!(c.source, file(name));
            assert_eq!(c.marker_names, reference.marker_names, "{name}");
            assert_eq!(
                (c.rate_hz, c.units, c.frame_count()),
                (50.0, Units::Millimetres, 89),
                "{name}"
            );
            let mut worst = 0.0f64;
            for (f, (a, b)) in c.frames.iter().zip(&reference.frames).enumerate() {
                assert_eq!(a.len(), 36);
                for (m, (a, b)) in a.iter().zip(b).enumerate() {
                    match (a, b) {
                        (Some(a), Some(b)) => {
                            (0..3).for_each(|k| worst = worst.max((a[k] - b[k]).abs()))
                        }
                        (None, None) => {}
                        _ => panic!("{name}: frame {f} marker {m}: {a:?} vs {b:?}"),
                    }
                }
            }
            assert!(worst <= scale, "{name}: differs from pc_real by {worst}");
            if name == "sgi_int" {
                assert_eq!(c.frames, read_capture(&file("pc_int")).unwrap().frames);
            }
            if name.ends_with("_real") {
                assert_eq!(
                    c.frames, reference.frames,
                    "{name}: the real variants hold the same floats"
                );
            }
        }
    }

    #[test]
    fn sample02_positions_are_plausible_millimetres() {
        let c = read_capture(&file("pc_int")).unwrap();
        // Markers on a walking subject: within a few metres of the origin, and moving.
        let valid: Vec<[f64; 3]> = c.frames.iter().flatten().flatten().copied().collect();
        assert!(valid.iter().all(|p| p.iter().all(|v| v.abs() < 5000.0)));
        let first = c.frames.iter().find_map(|f| f[0]).unwrap();
        let last = c.frames.iter().rev().find_map(|f| f[0]).unwrap();
        assert!((0..3).map(|k| (first[k] - last[k]).abs()).sum::<f64>() > 10.0);
    }

    #[test]
    fn dec_reals_decode() {
        // 1.0 in VAX F-floating is 0x4080_0000 stored as the words 0x4080, 0x0000.
        assert_eq!(Processor::Dec.f32([0x80, 0x40, 0, 0]), 1.0);
        assert_eq!(Processor::Dec.f32([0x80, 0xc0, 0, 0]), -1.0);
        assert_eq!(Processor::Dec.f32([0, 0, 0, 0]), 0.0);
        // 50.0 is IEEE 0x4248_0000; in VAX F-floating the exponent is 2 more: 0x4348_0000.
        assert_eq!(Processor::Dec.f32([0x48, 0x43, 0, 0]), 50.0);
    }

    #[test]
    fn errors_name_file_place_and_problem() {
        let good = bytes("pc_int");
        let e = err(&good[..300]);
        assert!(e.contains("bad.c3d: byte 300: truncated file"), "{e}");
        // Sample02's data ends at byte 43168 (block 13 on, 89 frames of 416 bytes), padded after.
        assert!(parse(Path::new("x.c3d"), &good[..43168], None).is_ok());
        let e = err(&good[..43167]);
        assert!(e.contains("bad.c3d: byte 43167: truncated file: it ends before the data of 89 frames of 36 points"), "{e}");

        let mut b = good.clone();
        b[1] = 0x51;
        assert!(err(&b).contains("bad.c3d: byte 1: not a C3D file"));
        let mut b = good.clone();
        b[512 + 3] = 99;
        assert!(err(&b).contains("bad.c3d: byte 515: unknown processor type 99"));

        let (at, _) = param_data(&good, "POINT:UNITS");
        assert_eq!(&good[at..at + 2], b"mm");
        let mut b = good.clone();
        b[at..at + 2].copy_from_slice(b"ft");
        let e = err(&b);
        assert!(
            e.contains("bad.c3d: parameter POINT:UNITS: unknown units \"ft\""),
            "{e}"
        );
        // With an explicit override the bad unit is not consulted.
        assert_eq!(
            parse(Path::new("x.c3d"), &b, Some(Units::Metres))
                .unwrap()
                .units,
            Units::Metres
        );

        // Copy the first label over the second.
        let (at, width) = param_data(&good, "POINT:LABELS");
        let mut b = good.clone();
        b.copy_within(at..at + width, at + width);
        let e = err(&b);
        assert!(
            e.contains("bad.c3d: parameter POINT:LABELS: duplicate marker name \"RFT1\""),
            "{e}"
        );
    }

    /// Where the data of parameter `key` starts in `bytes`, and its first dimension.
    fn param_data(bytes: &[u8], key: &str) -> (usize, usize) {
        let (r, _) = open(Path::new("x.c3d"), bytes).unwrap();
        let p = &r.params[key];
        (
            p.data.as_ptr() as usize - bytes.as_ptr() as usize,
            p.dims[0],
        )
    }

    #[test]
    fn no_panic_on_truncation_or_corruption() {
        for name in ["pc_int", "sgi_real"] {
            let b = bytes(name);
            super::super::tests::assert_no_panics(&b, |b| {
                parse(Path::new("x.c3d"), b, None).map(drop)
            });
        }
    }
}
