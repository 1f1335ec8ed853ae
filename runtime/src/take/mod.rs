//! Packed takes: a captured marker sequence compressed to play from flash ([`Take`], decoded
//! frame by frame by [`TakeReader`]).
//!
//! A take is a separate file from the rig blob (`.fbt`, written by `facebake pack`). Every
//! sample is quantised per marker to a step chosen at pack time from an error bound
//! (|error| ≤ step / 2) and predicted from the marker's previous decoded values, first order
//! (the last value) or second order (`2 q[t−1] − q[t−2]`), chosen per marker and block of frames:
//! JawMoCap (a face at 60 Hz) packs smaller at first order, the C3D sample (a walk) at second.
//! The residuals are bit-packed with widths stored per marker, axis and block. Every
//! `key_interval` frames a key frame stores absolute values, so [`TakeReader::seek`] decodes at
//! most one key interval. Missing samples stay missing: a presence mask is stored on key frames
//! and whenever it changes.
//!
//! Samples decode to Q8.24 units of the take's [`Space`] (metres): packed for a rig
//! (`facebake pack --rig`), that is the rig's actor space, and the samples go to
//! [`crate::Rig::play`] as they are, so every platform plays the same integers.
//!
//! # Layout
//!
//! The header is the rig blob's (`format::header`) under the magic `b"FACETAKE"` and
//! [`TAKE_VERSION`]; the payload, little-endian:
//!
//! ```text
//! offset  size  field
//!      0     2  marker count M, u16, 1 ..= MAX_MARKERS
//!      2     4  frame count F, u32, ≥ 1
//!      6     2  key interval N, u16, ≥ 1: frames 0, N, 2N, … are key frames
//!      8     2  block length B, u16, 1 ..= N: predicted frames come in blocks of B, each
//!               block (restarting after every key frame) headed by its residual widths
//!     10     1  source units: 0 mm, 1 cm, 2 m, 3 in (what the capture was recorded in)
//!     11     1  reserved, 0
//!     12     8  frame rate, Hz, f64 bits: finite and positive
//!     20    16  space: centre f32 × 3, half extent f32 (metres); samples are
//!               (p − centre) / half_extent in Q8.24
//!     36     3  key widths per axis, u8 ≤ 32
//!     39     1  reserved, 0
//!     40    12  key minimum per axis, i32 × 3
//!     52     …  marker names: M × (u8 length ≥ 1, UTF-8), distinct
//!      …  4 M   quantisation step per marker, u32 ≥ 1, in Q8.24 units
//!      …  4 K   byte offset of each key frame in the stream, u32, K = ⌈F / N⌉: the first is 0,
//!               then increasing, each below the stream length
//!      …     4  stream length S, u32
//!      …     S  the stream: nothing follows it
//! ```
//!
//! The stream is read least significant bit first within each byte. A marker's decoded value
//! is `q × step` with `q` an integer per marker and axis:
//!
//! * **key frame** (byte-aligned at its offset): M presence bits (marker order), then for every
//!   present marker and axis `key width[axis]` bits `u`, `q = key minimum[axis] + u`. A missing
//!   marker's `q` is 0. Both of a marker's last values are set to `q`.
//! * **predicted frame**: at the start of each block, per marker one bit (1: second-order
//!   prediction over this block) and 5 bits per axis: the width `w` (0 ..= 31) of that residual
//!   over the block. Then one bit: 1 when the presence mask changed (M presence bits follow).
//!   Then for every present marker with some `w > 0`: one bit, 1 when any of its residuals is
//!   not zero; if so, for every axis with `w > 0`: one bit, 1 when the residual `r` is not
//!   zero, and then its sign bit (1 negative) and `w − 1` bits of `|r| − 1`. Every present
//!   marker's `q` becomes its prediction plus `r` (0 where no bits say otherwise). A missing
//!   marker keeps its last two values (the prediction when it comes back).
//!
//! Decoding a frame reads at most `1 + M + M · (1 + 3 · 32)` bits (a key frame at most
//! `M · (1 + 3 · 32)`), plus `16 · M` bits of orders and widths at the start of a block, in
//! loops over the markers and axes only, and writes no memory but the [`TakeReader`]'s fixed
//! state.
//! Loading checks every count, offset and field against the bytes present; a stream that runs
//! out or decodes beyond `i32` fails that frame with a [`TakeFrameError`].

mod reader;

use crate::error::LoadError;
use crate::format::header;
use crate::records::{read_names, MAX_MARKERS};
use crate::space::Space;

pub use reader::{TakeFrameError, TakeReader};

/// The first eight bytes of every packed take.
pub const TAKE_MAGIC: [u8; 8] = *b"FACETAKE";
/// The take format version this crate reads and writes.
pub const TAKE_VERSION: u16 = 1;
/// Bits of each residual width at the head of a block.
pub const WIDTH_BITS: u32 = 5;
/// The widest residual: sign and 30 bits of magnitude (so `|r| ≤ 2³⁰`).
pub const MAX_WIDTH: u32 = 31;
/// Widest key value, bits.
pub const MAX_KEY_WIDTH: u8 = 32;
/// Bytes of the fixed fields before the marker names.
pub const FIXED_LEN: usize = 52;

/// Why a byte string is not a loadable take. Every variant is a distinct failure.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TakeLoadError {
    /// The header: truncated, trailing bytes, wrong magic, unknown version, reserved field or
    /// checksum (the header variants of [`LoadError`], which the rig blob shares).
    Header(LoadError),
    /// The payload ends before the field at this payload offset.
    Truncated {
        /// Offset of the field that does not fit.
        at: usize,
    },
    /// Bytes after the stream.
    TrailingBytes,
    /// The marker count is 0 or above `MAX_MARKERS`.
    MarkerCount {
        /// The count in the take.
        found: u16,
    },
    /// The frame count is 0.
    NoFrames,
    /// The key interval is 0, or the block length 0 or longer than the key interval.
    Interval,
    /// The units code is not 0 to 3, or a reserved byte is not 0.
    Units,
    /// The frame rate is not finite and positive.
    Rate,
    /// The space has a non-finite value or a non-positive half extent.
    Space,
    /// A key width is above 32 bits, or the reserved byte after the widths is not 0.
    KeyWidth,
    /// Marker `index`'s name is empty, not UTF-8, or the name of an earlier marker.
    MarkerName {
        /// Which marker.
        index: usize,
    },
    /// Marker `index`'s quantisation step is 0.
    Step {
        /// Which marker.
        index: usize,
    },
    /// Key frame `index`'s offset is not increasing from 0 or not inside the stream.
    KeyOffset {
        /// Which key frame (frame `index × N`).
        index: usize,
    },
}

impl core::error::Error for TakeLoadError {}

impl core::fmt::Display for TakeLoadError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Header(e) => write!(f, "take header: {e}"),
            Self::Truncated { at } => write!(f, "take ends inside the field at payload byte {at}"),
            Self::TrailingBytes => f.write_str("bytes after the take's stream"),
            Self::MarkerCount { found } => {
                write!(f, "take has {found} markers (1 to {MAX_MARKERS})")
            }
            Self::NoFrames => f.write_str("take has no frames"),
            Self::Interval => {
                f.write_str("key interval is 0, or block length is 0 or longer than it")
            }
            Self::Units => f.write_str("unknown units code or a reserved byte set"),
            Self::Rate => f.write_str("frame rate is not finite and positive"),
            Self::Space => f.write_str("space is not finite with a positive half extent"),
            Self::KeyWidth => write!(f, "a key width is above {MAX_KEY_WIDTH} bits"),
            Self::MarkerName { index } => {
                write!(f, "marker {index}: name empty, not UTF-8 or repeated")
            }
            Self::Step { index } => write!(f, "marker {index}: quantisation step 0"),
            Self::KeyOffset { index } => write!(f, "key frame {index}: offset out of order"),
        }
    }
}

/// A packed take, validated: a zero-copy view of its bytes (which may sit in flash).
#[derive(Clone, Copy, Debug)]
pub struct Take<'a> {
    marker_count: u16,
    frame_count: u32,
    key_interval: u16,
    block: u16,
    units: u8,
    rate_bits: u64,
    space: Space,
    key_width: [u8; 3],
    key_min: [i32; 3],
    names: &'a [u8],
    steps: &'a [u8],
    keys: &'a [u8],
    stream: &'a [u8],
}

/// Reads fields in order, each checked against the bytes present.
struct Cursor<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Cursor<'a> {
    fn take(&mut self, n: usize) -> Result<&'a [u8], TakeLoadError> {
        let at = self.at;
        let end = at.checked_add(n).ok_or(TakeLoadError::Truncated { at })?;
        let out = self
            .bytes
            .get(at..end)
            .ok_or(TakeLoadError::Truncated { at })?;
        self.at = end;
        Ok(out)
    }

    fn array<const N: usize>(&mut self) -> Result<[u8; N], TakeLoadError> {
        let mut out = [0u8; N];
        out.copy_from_slice(self.take(N)?);
        Ok(out)
    }

    fn u8(&mut self) -> Result<u8, TakeLoadError> {
        Ok(self.array::<1>()?[0])
    }

    fn u16(&mut self) -> Result<u16, TakeLoadError> {
        Ok(u16::from_le_bytes(self.array()?))
    }

    fn u32(&mut self) -> Result<u32, TakeLoadError> {
        Ok(u32::from_le_bytes(self.array()?))
    }
}

/// Little-endian `u32` number `i` of `bytes` (0 past the end; callers index within bounds).
pub(crate) fn le_u32_at(bytes: &[u8], i: usize) -> u32 {
    let mut w = [0u8; 4];
    if let Some(b) = i.checked_mul(4).and_then(|at| bytes.get(at..at + 4)) {
        w.copy_from_slice(b);
    }
    u32::from_le_bytes(w)
}

/// `x` is finite and positive, on the IEEE-754 bits (no float code on a core without an FPU).
fn f64_is_finite_positive(bits: u64) -> bool {
    bits & (1 << 63) == 0 && bits != 0 && bits & 0x7FF0_0000_0000_0000 != 0x7FF0_0000_0000_0000
}

impl<'a> Take<'a> {
    /// Load a take: header, checksum and every field, count and offset checked against the
    /// bytes present. Never panics; the work is linear in the bytes before the stream plus
    /// M² name comparisons.
    pub fn from_bytes(bytes: &'a [u8]) -> Result<Self, TakeLoadError> {
        let payload = header::open_sealed(bytes, &TAKE_MAGIC, TAKE_VERSION..=TAKE_VERSION)
            .map_err(TakeLoadError::Header)?;
        let mut c = Cursor {
            bytes: payload,
            at: 0,
        };
        let marker_count = c.u16()?;
        if marker_count == 0 || usize::from(marker_count) > MAX_MARKERS {
            return Err(TakeLoadError::MarkerCount {
                found: marker_count,
            });
        }
        let frame_count = c.u32()?;
        if frame_count == 0 {
            return Err(TakeLoadError::NoFrames);
        }
        let key_interval = c.u16()?;
        let block = c.u16()?;
        if key_interval == 0 || block == 0 || block > key_interval {
            return Err(TakeLoadError::Interval);
        }
        let units = c.u8()?;
        if units > 3 || c.u8()? != 0 {
            return Err(TakeLoadError::Units);
        }
        let rate_bits = u64::from_le_bytes(c.array()?);
        if !f64_is_finite_positive(rate_bits) {
            return Err(TakeLoadError::Rate);
        }
        let mut f = [0f32; 4];
        for x in &mut f {
            *x = f32::from_bits(c.u32()?);
        }
        let space = Space {
            centre: [f[0], f[1], f[2]],
            half_extent: f[3],
        };
        if !space.is_valid() {
            return Err(TakeLoadError::Space);
        }
        let key_width: [u8; 3] = c.array()?;
        if key_width.iter().any(|&w| w > MAX_KEY_WIDTH) || c.u8()? != 0 {
            return Err(TakeLoadError::KeyWidth);
        }
        let mut key_min = [0i32; 3];
        for k in &mut key_min {
            *k = c.u32()? as i32;
        }
        let m = usize::from(marker_count);
        let names_at = c.at;
        for index in 0..m {
            let len = usize::from(c.u8()?);
            let name = c.take(len)?;
            if len == 0 || core::str::from_utf8(name).is_err() {
                return Err(TakeLoadError::MarkerName { index });
            }
        }
        let names = payload
            .get(names_at..c.at)
            .ok_or(TakeLoadError::Truncated { at: names_at })?;
        let steps = c.take(4 * m)?;
        if let Some(index) = (0..m).find(|&i| le_u32_at(steps, i) == 0) {
            return Err(TakeLoadError::Step { index });
        }
        let key_count = frame_count.div_ceil(u32::from(key_interval)) as usize;
        let keys = c.take(
            key_count
                .checked_mul(4)
                .ok_or(TakeLoadError::Truncated { at: c.at })?,
        )?;
        let stream_len = c.u32()? as usize;
        let stream = c.take(stream_len)?;
        if c.at != payload.len() {
            return Err(TakeLoadError::TrailingBytes);
        }
        let mut previous = None;
        for index in 0..key_count {
            let at = le_u32_at(keys, index);
            let ordered = match previous {
                None => at == 0,
                Some(p) => at > p,
            };
            if !ordered || at as usize >= stream.len() {
                return Err(TakeLoadError::KeyOffset { index });
            }
            previous = Some(at);
        }
        let take = Self {
            marker_count,
            frame_count,
            key_interval,
            block,
            units,
            rate_bits,
            space,
            key_width,
            key_min,
            names,
            steps,
            keys,
            stream,
        };
        // Distinct names: a player matches markers by name.
        for (i, a) in take.marker_names().enumerate() {
            if take.marker_names().take(i).any(|b| a == b) {
                return Err(TakeLoadError::MarkerName { index: i });
            }
        }
        Ok(take)
    }

    /// Markers per frame.
    pub fn marker_count(&self) -> usize {
        usize::from(self.marker_count)
    }

    /// Frames in the take.
    pub fn frame_count(&self) -> usize {
        self.frame_count as usize
    }

    /// Frames from one key frame to the next: the most a seek decodes.
    pub fn key_interval(&self) -> usize {
        usize::from(self.key_interval)
    }

    /// Predicted frames per block of residual widths.
    pub fn block_frames(&self) -> usize {
        usize::from(self.block)
    }

    /// Frames per second.
    pub fn rate_hz(&self) -> f64 {
        f64::from_bits(self.rate_bits)
    }

    /// The unit the capture was recorded in: 0 mm, 1 cm, 2 m, 3 in (samples are in the
    /// space's metres whatever this says).
    pub fn source_units(&self) -> u8 {
        self.units
    }

    /// Where the samples' Q8.24 units sit, in metres: a rig's [`crate::Rig::actor_space`] when
    /// the take was packed for that rig.
    pub fn space(&self) -> Space {
        self.space
    }

    /// Marker names, in marker order.
    pub fn marker_names(&self) -> impl Iterator<Item = &'a str> + 'a {
        read_names(self.names)
    }

    /// Index of the marker called `name`.
    pub fn marker_index(&self, name: &str) -> Option<usize> {
        self.marker_names().position(|n| n == name)
    }

    /// Quantisation step of marker `i` (Q8.24 units; the error bound is half of it), or `None`
    /// past the last marker.
    pub fn step(&self, i: usize) -> Option<u32> {
        (i < self.marker_count()).then(|| le_u32_at(self.steps, i))
    }

    /// Bytes of the bit stream (everything but the header, names, steps and key offsets).
    pub fn stream_len(&self) -> usize {
        self.stream.len()
    }

    /// A reader at frame 0.
    pub fn reader(&self) -> TakeReader<'a> {
        TakeReader::new(*self)
    }
}

#[cfg(feature = "format")]
/// The fields a take's writer puts before the marker names, in layout order.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TakeFields {
    /// Markers per frame.
    pub marker_count: u16,
    /// Frames.
    pub frame_count: u32,
    /// Key interval N.
    pub key_interval: u16,
    /// Block length B.
    pub block_frames: u16,
    /// Source units code.
    pub units: u8,
    /// Frame rate, Hz.
    pub rate_hz: f64,
    /// The samples' space.
    pub space: Space,
    /// Key widths per axis.
    pub key_width: [u8; 3],
    /// Key minimum per axis.
    pub key_min: [i32; 3],
}

#[cfg(feature = "format")]
impl TakeFields {
    /// The [`FIXED_LEN`] bytes of these fields.
    pub fn to_bytes(&self) -> [u8; FIXED_LEN] {
        let mut out = [0u8; FIXED_LEN];
        let mut at = 0;
        let mut put = |b: &[u8]| {
            out[at..at + b.len()].copy_from_slice(b);
            at += b.len();
        };
        put(&self.marker_count.to_le_bytes());
        put(&self.frame_count.to_le_bytes());
        put(&self.key_interval.to_le_bytes());
        put(&self.block_frames.to_le_bytes());
        put(&[self.units, 0]);
        put(&self.rate_hz.to_bits().to_le_bytes());
        for c in self.space.centre {
            put(&c.to_bits().to_le_bytes());
        }
        put(&self.space.half_extent.to_bits().to_le_bytes());
        put(&self.key_width);
        put(&[0]);
        for k in self.key_min {
            put(&k.to_le_bytes());
        }
        out
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use crate::format::header::sealed_header;
    use std::vec;
    use std::vec::Vec;

    /// Bits appended least significant first.
    #[derive(Default)]
    struct Bits(Vec<u8>, usize);

    impl Bits {
        fn put(&mut self, value: u32, n: u32) -> &mut Self {
            for i in 0..n {
                if self.1.is_multiple_of(8) {
                    self.0.push(0);
                }
                let last = self.0.len() - 1;
                self.0[last] |= (((value >> i) & 1) as u8) << (self.1 % 8);
                self.1 += 1;
            }
            self
        }

        fn align(&mut self) -> usize {
            self.1 = self.0.len() * 8;
            self.0.len()
        }
    }

    fn fields() -> TakeFields {
        TakeFields {
            marker_count: 2,
            frame_count: 3,
            key_interval: 2,
            block_frames: 1,
            units: 1,
            rate_hz: 60.0,
            space: Space {
                centre: [0.0, 1.0, 0.0],
                half_extent: 0.125,
            },
            key_width: [4, 4, 4],
            key_min: [-8, 0, 0],
        }
    }

    /// The payload of a hand-made take: markers A (step 8) and B (step 16), frames 0 and 2
    /// keys, frame 1 predicted (A first order with r = (−2, 0, 0), B second order at rest),
    /// B missing in frame 2.
    fn payload(fields: &TakeFields, names: &[&[u8]], steps: [u32; 2]) -> Vec<u8> {
        let mut b = Bits::default();
        b.put(0b11, 2); // frame 0: both present
        for u in [3, 2, 1, 0, 0, 15] {
            b.put(u, 4);
        }
        // Frame 1: A first order, widths (2, 0, 0); B second order, widths 0.
        b.put(0, 1).put(2, 5).put(0, 5).put(0, 5);
        b.put(1, 1).put(0, 15);
        b.put(0, 1); // presence unchanged
        b.put(1, 1).put(1, 1).put(1, 1).put(1, 1); // A: some residual, x ≠ 0, negative, |r| − 1 = 1
        let second = b.align();
        b.put(0b01, 2).put(0, 12); // frame 2: A present at the key minimum
        let mut p = fields.to_bytes().to_vec();
        for n in names {
            p.push(n.len() as u8);
            p.extend_from_slice(n);
        }
        for s in steps {
            p.extend_from_slice(&s.to_le_bytes());
        }
        p.extend_from_slice(&0u32.to_le_bytes());
        p.extend_from_slice(&(second as u32).to_le_bytes());
        p.extend_from_slice(&(b.0.len() as u32).to_le_bytes());
        p.extend_from_slice(&b.0);
        p
    }

    fn seal(payload: &[u8]) -> Vec<u8> {
        let mut out = sealed_header(&TAKE_MAGIC, TAKE_VERSION, payload)
            .unwrap()
            .to_vec();
        out.extend_from_slice(payload);
        out
    }

    fn good() -> Vec<u8> {
        seal(&payload(&fields(), &[b"A", b"B"], [8, 16]))
    }

    const FRAMES: [[Option<[i32; 3]>; 2]; 3] = [
        [Some([-40, 16, 8]), Some([-128, 0, 240])],
        [Some([-56, 16, 8]), Some([-128, 0, 240])],
        [Some([-64, 0, 0]), None],
    ];

    #[test]
    fn a_hand_made_take_decodes_and_seeks() {
        let bytes = good();
        let take = Take::from_bytes(&bytes).unwrap();
        assert_eq!(take.marker_names().collect::<Vec<_>>(), ["A", "B"]);
        assert_eq!(
            (take.frame_count(), take.key_interval(), take.rate_hz()),
            (3, 2, 60.0)
        );
        assert_eq!(
            (take.step(1), take.step(2), take.source_units()),
            (Some(16), None, 1)
        );
        let mut reader = take.reader();
        let mut row = [None; 2];
        for (f, want) in FRAMES.iter().enumerate() {
            assert_eq!(reader.next_frame(&mut row), Ok(Some(f)));
            assert_eq!(&row, want, "frame {f}");
        }
        assert_eq!(reader.next_frame(&mut row), Ok(None));
        for f in [1, 0, 2, 1] {
            reader.seek(f).unwrap();
            reader.next_frame(&mut row).unwrap();
            assert_eq!(row, FRAMES[f], "seek to {f}");
        }
        assert_eq!(
            reader.seek(4),
            Err(TakeFrameError::NoFrame {
                frame: 4,
                frames: 3
            })
        );
    }

    /// Every field out of range gives its own error; a stream cut short fails its frame.
    #[test]
    fn every_bad_field_is_its_own_error() {
        let with = |f: &dyn Fn(&mut TakeFields)| {
            let mut fields = fields();
            f(&mut fields);
            Take::from_bytes(&seal(&payload(&fields, &[b"A", b"B"], [8, 16]))).map(|_| ())
        };
        assert_eq!(
            with(&|f| f.marker_count = 0),
            Err(TakeLoadError::MarkerCount { found: 0 })
        );
        assert_eq!(with(&|f| f.frame_count = 0), Err(TakeLoadError::NoFrames));
        assert_eq!(with(&|f| f.key_interval = 0), Err(TakeLoadError::Interval));
        assert_eq!(with(&|f| f.block_frames = 3), Err(TakeLoadError::Interval));
        assert_eq!(with(&|f| f.units = 4), Err(TakeLoadError::Units));
        assert_eq!(with(&|f| f.rate_hz = f64::NAN), Err(TakeLoadError::Rate));
        assert_eq!(with(&|f| f.rate_hz = -1.0), Err(TakeLoadError::Rate));
        assert_eq!(
            with(&|f| f.space.half_extent = 0.0),
            Err(TakeLoadError::Space)
        );
        assert_eq!(with(&|f| f.key_width[2] = 33), Err(TakeLoadError::KeyWidth));
        // Three frames at interval 1 need three key offsets: the stream length is read as one.
        assert!(with(&|f| f.key_interval = 1).is_err());
        let names =
            |n: &[&[u8]]| Take::from_bytes(&seal(&payload(&fields(), n, [8, 16]))).map(|_| ());
        assert_eq!(
            names(&[b"A", b""]),
            Err(TakeLoadError::MarkerName { index: 1 })
        );
        assert_eq!(
            names(&[b"A", b"A"]),
            Err(TakeLoadError::MarkerName { index: 1 })
        );
        assert_eq!(
            names(&[b"\xff", b"B"]),
            Err(TakeLoadError::MarkerName { index: 0 })
        );
        assert_eq!(
            Take::from_bytes(&seal(&payload(&fields(), &[b"A", b"B"], [8, 0]))).map(|_| ()),
            Err(TakeLoadError::Step { index: 1 })
        );
        let good_payload = payload(&fields(), &[b"A", b"B"], [8, 16]);
        let keys_at = FIXED_LEN + 4 + 8;
        let mut p = good_payload.clone();
        p[keys_at + 4..keys_at + 8].copy_from_slice(&0u32.to_le_bytes());
        assert_eq!(
            Take::from_bytes(&seal(&p)).map(|_| ()),
            Err(TakeLoadError::KeyOffset { index: 1 })
        );
        let mut p = good_payload.clone();
        p.push(0);
        assert_eq!(
            Take::from_bytes(&seal(&p)).map(|_| ()),
            Err(TakeLoadError::TrailingBytes)
        );
        for n in 0..good_payload.len() {
            assert!(
                Take::from_bytes(&seal(&good_payload[..n])).is_err(),
                "{n} bytes"
            );
        }
        let mut bad = good();
        bad[0] = b'X';
        assert_eq!(
            Take::from_bytes(&bad).map(|_| ()),
            Err(TakeLoadError::Header(LoadError::BadMagic))
        );
        let mut bad = good();
        let last = bad.len() - 1;
        bad[last] ^= 1;
        assert!(matches!(
            Take::from_bytes(&bad),
            Err(TakeLoadError::Header(LoadError::ChecksumMismatch { .. }))
        ));
        // The stream cut to 4 bytes: frame 0 (26 bits) decodes, frame 1 runs out of bits.
        let mut p = good_payload;
        let len_at = keys_at + 8;
        p[len_at..len_at + 4].copy_from_slice(&4u32.to_le_bytes());
        p.truncate(len_at + 4 + 4);
        p[keys_at + 4..keys_at + 8].copy_from_slice(&3u32.to_le_bytes());
        let bytes = seal(&p);
        let take = Take::from_bytes(&bytes).unwrap();
        let mut reader = take.reader();
        let mut row = [None; 2];
        assert_eq!(reader.next_frame(&mut row), Ok(Some(0)));
        assert_eq!(
            reader.next_frame(&mut row),
            Err(TakeFrameError::StreamEnd { frame: 1 })
        );
        assert_eq!(
            reader.next_frame(&mut row),
            Ok(None),
            "at the end after an error"
        );
        // A huge step makes the key value leave i32.
        let bytes = seal(&payload(&fields(), &[b"A", b"B"], [1 << 30, 16]));
        let take = Take::from_bytes(&bytes).unwrap();
        assert_eq!(
            take.reader().next_frame(&mut row),
            Err(TakeFrameError::OutOfRange { frame: 0 })
        );
    }

    /// The format's decoding as the module docs state it, bit by bit in `i64`: every frame's
    /// samples from the start (stopping at the first error). A frame fails when a marker's
    /// value does not fit (checked after the marker's three values), and with `StreamEnd`
    /// instead when its reads had run past the stream by then.
    fn reference(take: &Take<'_>) -> Vec<Result<Vec<Option<[i64; 3]>>, TakeFrameError>> {
        let (m, n, b) = (
            take.marker_count(),
            take.key_interval(),
            take.block_frames(),
        );
        let stream = take.stream;
        let mut pos = 0usize;
        let read = |pos: &mut usize, bits: u32| -> i64 {
            let mut v = 0i64;
            for i in 0..bits {
                let byte = stream.get(*pos / 8).copied().unwrap_or(0);
                v |= i64::from((byte >> (*pos % 8)) & 1) << i;
                *pos += 1;
            }
            v
        };
        let step = |i: usize| i64::from(take.step(i).unwrap());
        let fits = |i: usize, v: i64| v * step(i) >= -(1 << 31) && v * step(i) < (1 << 31);
        let (mut q, mut q2) = (vec![[0i64; 3]; m], vec![[0i64; 3]; m]);
        let (mut present, mut head) = (vec![false; m], vec![0i64; m]);
        let mut frames = Vec::new();
        for f in 0..take.frame_count() {
            let k = f % n;
            let mut bad = false;
            if k == 0 {
                pos = 8 * le_u32_at(take.keys, f / n) as usize;
                for p in present.iter_mut() {
                    *p = read(&mut pos, 1) == 1;
                }
                for i in 0..m {
                    q[i] = [0; 3];
                    if present[i] {
                        for (a, q) in q[i].iter_mut().enumerate() {
                            let u = read(&mut pos, u32::from(take.key_width[a]));
                            *q = i64::from(take.key_min[a]) + u;
                        }
                    }
                    q2[i] = q[i];
                    if q[i].iter().any(|&v| !fits(i, v)) {
                        bad = true;
                        break;
                    }
                }
            } else {
                if (k - 1) % b == 0 {
                    for h in head.iter_mut() {
                        *h = read(&mut pos, 16);
                    }
                }
                if read(&mut pos, 1) == 1 {
                    for p in present.iter_mut() {
                        *p = read(&mut pos, 1) == 1;
                    }
                }
                for i in (0..m).filter(|&i| present[i]) {
                    let mut r = [0i64; 3];
                    if head[i] >> 1 != 0 && read(&mut pos, 1) == 1 {
                        for (a, r) in r.iter_mut().enumerate() {
                            let w = ((head[i] >> (1 + 5 * a)) & 31) as u32;
                            if w > 0 && read(&mut pos, 1) == 1 {
                                let negative = read(&mut pos, 1) == 1;
                                let magnitude = read(&mut pos, w - 1) + 1;
                                *r = if negative { -magnitude } else { magnitude };
                            }
                        }
                    }
                    for a in 0..3 {
                        let slope = if head[i] & 1 == 1 {
                            q[i][a] - q2[i][a]
                        } else {
                            0
                        };
                        q2[i][a] = q[i][a];
                        q[i][a] += slope + r[a];
                    }
                    if q[i].iter().any(|&v| !fits(i, v)) {
                        bad = true;
                        break;
                    }
                }
            }
            if pos > 8 * stream.len() {
                frames.push(Err(TakeFrameError::StreamEnd { frame: f }));
                break;
            }
            if bad {
                frames.push(Err(TakeFrameError::OutOfRange { frame: f }));
                break;
            }
            let row = (0..m).map(|i| present[i].then(|| q[i].map(|v| v * step(i))));
            frames.push(Ok(row.collect()));
        }
        frames
    }

    /// Random takes, most of them valid for a while before they fail (sparse bits: narrow
    /// widths, few residuals), some not: the reader's every path (`i32` and `i64` values and
    /// keys, short and long residual reads, block heads by words and near the end, the word
    /// and byte refills) gives the reference's samples and errors, read in order and after
    /// seeks.
    #[test]
    fn random_takes_decode_as_the_format_says() {
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            seed
        };
        let mut decoded_frames = 0;
        for case in 0..600 {
            // Every fifth take is a few bytes long: block heads near the end of the stream.
            let tiny = case % 5 == 1;
            let m = 1 + (next() % if tiny { 3 } else { 41 }) as usize;
            let frame_count = 1 + (next() % if tiny { 12 } else { 200 }) as u32;
            let key_interval = if tiny {
                frame_count as u16
            } else {
                1 + (next() % 70) as u16
            };
            let block_frames = 1 + (next() % u64::from(key_interval)) as u16;
            // Every fourth take has values beyond `i32` arithmetic (steps below 8) and key
            // widths beyond a refill (one axis 25 to 32 bits, its minimum at −2^(w−1)).
            let wide = case % 4 == 0;
            let key_width = [0; 3].map(|_| (next() % 20) as u8);
            let mut key_min = [0; 3].map(|_| (next() % 4096) as i32 - 2048);
            let mut key_width = key_width;
            if wide {
                let axis = (next() % 3) as usize;
                key_width[axis] = 25 + (next() % 8) as u8;
                key_min[axis] = (-(1i64 << (key_width[axis] - 1))) as i32;
            }
            let fields = TakeFields {
                marker_count: m as u16,
                frame_count,
                key_interval,
                block_frames,
                key_width,
                key_min,
                ..fields()
            };
            // One bit in 2, 8 or 32 set.
            let sparsity = [1, 3, 5][case % 3];
            let len = if tiny {
                1 + (next() % 12) as usize
            } else {
                64 + (next() % 6000) as usize
            };
            let stream: Vec<u8> = (0..len)
                .map(|_| {
                    (0..8).fold(0u8, |byte, i| {
                        byte | (u8::from(next() % (1 << sparsity) == 0) << i)
                    })
                })
                .collect();
            let keys = frame_count.div_ceil(u32::from(key_interval)) as usize;
            let mut offsets: Vec<u32> = (0..keys).map(|k| (k * len / keys) as u32).collect();
            offsets[0] = 0;
            let mut p = fields.to_bytes().to_vec();
            for i in 0..m {
                let name = std::format!("M{i}");
                p.push(name.len() as u8);
                p.extend_from_slice(name.as_bytes());
            }
            for _ in 0..m {
                let step = if wide {
                    1 + next() % 8
                } else {
                    1 + next() % 4000
                };
                p.extend_from_slice(&(step as u32).to_le_bytes());
            }
            offsets.sort_unstable();
            for o in &offsets {
                p.extend_from_slice(&o.to_le_bytes());
            }
            p.extend_from_slice(&(len as u32).to_le_bytes());
            p.extend_from_slice(&stream);
            let bytes = seal(&p);
            let take = Take::from_bytes(&bytes).expect("a valid header");
            let want = reference(&take);
            let mut reader = take.reader();
            let mut row = vec![None; m];
            for (f, want) in want.iter().enumerate() {
                let got = reader.next_frame(&mut row).map(|_| row.clone());
                let want = want.clone().map(|w| {
                    w.into_iter()
                        .map(|s| s.map(|s| s.map(|v| v as i32)))
                        .collect::<Vec<_>>()
                });
                assert_eq!(got, want, "case {case}, frame {f}");
                decoded_frames += usize::from(got.is_ok());
            }
            // Seek back to frames the reference decoded.
            let good = want.iter().take_while(|w| w.is_ok()).count();
            for _ in 0..4.min(good) {
                let f = (next() % good as u64) as usize;
                reader.seek(f).unwrap();
                reader.next_frame(&mut row).unwrap();
                let want: Vec<_> = want[f].clone().unwrap();
                let want: Vec<_> = want
                    .iter()
                    .map(|s| s.map(|s| s.map(|v| v as i32)))
                    .collect();
                assert_eq!(row, want, "case {case}, seek to {f}");
            }
        }
        // Enough of it decodes for the comparison to mean something.
        assert!(decoded_frames > 5000, "{decoded_frames} frames decoded");
    }

    /// The reader's state is fixed: a 40-byte record per marker and a few words (the figure
    /// docs/measurements.md gives for a microcontroller's RAM).
    #[test]
    fn the_reader_state_is_a_record_per_marker() {
        let size = core::mem::size_of::<TakeReader<'static>>();
        assert!(
            (40 * MAX_MARKERS..40 * MAX_MARKERS + 256).contains(&size),
            "{size} bytes"
        );
        std::println!("TakeReader: {size} bytes");
    }
}
