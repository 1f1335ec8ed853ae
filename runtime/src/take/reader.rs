//! [`TakeReader`]: decodes a [`Take`] frame by frame into a fixed state, no allocation.

use super::{le_u32_at, Take, MAX_WIDTH, WIDTH_BITS};
use crate::records::MAX_MARKERS;

// A width field holds every width up to the widest: no width needs clamping.
const _: () = assert!((1 << WIDTH_BITS) - 1 == MAX_WIDTH);

/// Why a frame could not be decoded or a seek not done.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TakeFrameError {
    /// The stream ends inside frame `frame` (a corrupt take whose checksum was resealed).
    StreamEnd {
        /// The frame being decoded.
        frame: usize,
    },
    /// Frame `frame` decodes a sample beyond `i32` (a corrupt take).
    OutOfRange {
        /// The frame being decoded.
        frame: usize,
    },
    /// A seek past the end of the take.
    NoFrame {
        /// The frame asked for.
        frame: usize,
        /// Frames in the take.
        frames: usize,
    },
    /// The output slice does not have one entry per take marker.
    OutputLength {
        /// Markers the take has.
        expected: usize,
        /// Entries given.
        found: usize,
    },
}

impl core::error::Error for TakeFrameError {}

impl core::fmt::Display for TakeFrameError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::StreamEnd { frame } => write!(f, "frame {frame}: the take's stream ends"),
            Self::OutOfRange { frame } => write!(f, "frame {frame}: a sample beyond i32"),
            Self::NoFrame { frame, frames } => {
                write!(f, "no frame {frame}: the take has {frames}")
            }
            Self::OutputLength { expected, found } => {
                write!(f, "room for {found} markers, the take has {expected}")
            }
        }
    }
}

/// Decodes a [`Take`]: sequentially with [`Self::next_frame`], from anywhere with
/// [`Self::seek`]. Its whole state is fixed-size (10 KiB and a few bytes): a `Marker` record
/// per marker and the position in the stream.
#[derive(Clone, Debug)]
pub struct TakeReader<'a> {
    take: Take<'a>,
    /// The frame the next call decodes.
    next: u32,
    /// Bit position in the stream.
    pos: usize,
    /// Each marker's decoding state, in one record so that the frame loop walks one array.
    markers: [Marker; MAX_MARKERS],
    /// Every step is at least [`NARROW_STEP`]: then every value is within ±2²⁸, and a
    /// prediction plus a residual (|r| ≤ 2³⁰) is at most 3 · 2²⁸ + 2³⁰ < 2³¹ in magnitude, so
    /// frames decode in `i32` with no overflow check. Else in `i64`.
    narrow: bool,
    /// Every key value `key_min + u` (`u` of its key width) is within `i32`, and every key
    /// width at most [`Bits::REFILLED`]: key frames decode in `i32` with one buffer check a
    /// value.
    short_keys: bool,
}

/// The smallest step for which values decode in `i32` ([`TakeReader`]'s `narrow`). Packed
/// takes have steps in the thousands (0.1 mm of a 0.2 m half extent is 8,389 Q8.24 units).
const NARROW_STEP: u32 = 8;

/// One marker's decoding state (40 bytes).
#[derive(Clone, Copy, Debug, Default)]
struct Marker {
    /// The last quantised value,
    q: [i32; 3],
    /// and the one before it (second-order prediction).
    q2: [i32; 3],
    /// The smallest quantised value whose sample `q · step` fits `i32`: `−⌊2³¹/step⌋`;
    low: i32,
    /// the largest is `low + span`, `⌊(2³¹ − 1)/step⌋` (found once per take instead of
    /// multiplying per sample).
    span: u32,
    /// Its quantisation step (from the take's `steps`, read once). A step is at least 1 (the
    /// loader checks it).
    step: u32,
    /// Over the current block, as read at its start: bit 0 second-order prediction, then the
    /// three residual widths, [`WIDTH_BITS`] each.
    head: u16,
    /// Whether the marker is present.
    present: bool,
}

impl Marker {
    /// A missing marker at 0 with step `step`.
    fn new(step: u32) -> Self {
        let s = i64::from(step.max(1));
        let low = -((1i64 << 31) / s);
        let high = i64::from(i32::MAX) / s;
        Self {
            low: low as i32,
            span: (high - low) as u32,
            step,
            ..Self::default()
        }
    }

    /// Whether `q` is a value whose sample fits: one unsigned comparison of its offset from
    /// `low`.
    #[inline(always)]
    fn holds(&self, q: i32) -> bool {
        (q.wrapping_sub(self.low) as u32) <= self.span
    }

    /// [`Self::holds`] for a value computed in `i64`.
    #[inline(always)]
    fn holds_wide(&self, q: i64) -> bool {
        // |q − low| < 2⁶³ for every q the reader computes (below 2³⁴ in magnitude).
        (q.wrapping_sub(i64::from(self.low)) as u64) <= u64::from(self.span)
    }
}

impl<'a> TakeReader<'a> {
    /// A reader at frame 0 of `take`.
    pub fn new(take: Take<'a>) -> Self {
        let m = take.marker_count();
        let steps: [u32; MAX_MARKERS] = core::array::from_fn(|i| le_u32_at(take.steps, i));
        Self {
            take,
            next: 0,
            pos: 0,
            markers: steps.map(Marker::new),
            narrow: steps.iter().take(m).all(|&s| s >= NARROW_STEP),
            short_keys: (0..3).all(|axis| {
                let width = u32::from(take.key_width[axis]);
                width <= Bits::REFILLED
                    && i64::from(take.key_min[axis]) + (1i64 << width) - 1 <= i64::from(i32::MAX)
            }),
        }
    }

    /// The take being read.
    pub fn take(&self) -> &Take<'a> {
        &self.take
    }

    /// The frame the next [`Self::next_frame`] decodes (the frame count at the end).
    pub fn frame(&self) -> usize {
        self.next as usize
    }

    /// Decode the next frame into `out`, one entry per take marker (Q8.24 units of
    /// [`Take::space`], `None` for a missing sample): `Some(frame index)`, or `None` after the
    /// last frame. After an error the reader is at the end until the next [`Self::seek`].
    pub fn next_frame(
        &mut self,
        out: &mut [Option<[i32; 3]>],
    ) -> Result<Option<usize>, TakeFrameError> {
        let m = self.take.marker_count();
        if out.len() != m {
            return Err(TakeFrameError::OutputLength {
                expected: m,
                found: out.len(),
            });
        }
        if self.next >= self.take.frame_count {
            return Ok(None);
        }
        let frame = self.next as usize;
        if let Err(e) = self.advance(out.iter_mut().map(Some)) {
            self.next = self.take.frame_count;
            return Err(e);
        }
        Ok(Some(frame))
    }

    /// Position the reader so that [`Self::next_frame`] decodes `frame`: decodes from the key
    /// frame at or before it, at most one key interval. `frame` may be the frame count (the
    /// end).
    pub fn seek(&mut self, frame: usize) -> Result<(), TakeFrameError> {
        let frames = self.take.frame_count();
        if frame > frames {
            return Err(TakeFrameError::NoFrame { frame, frames });
        }
        let n = self.take.key_interval();
        self.next = (frame - frame % n) as u32;
        while (self.next as usize) < frame {
            if let Err(e) = self.advance(core::iter::repeat_with(|| None)) {
                self.next = self.take.frame_count;
                return Err(e);
            }
        }
        self.next = frame as u32;
        Ok(())
    }

    /// Decode frame `self.next` into the state and move on, writing each marker's sample to
    /// its item of `out` that is `Some` (see [`emit`]).
    fn advance<'o>(&mut self, out: impl Outputs<'o>) -> Result<(), TakeFrameError> {
        let f = self.next as usize;
        let n = self.take.key_interval();
        let k = f % n;
        let start = if k == 0 {
            (le_u32_at(self.take.keys, f / n) as usize).saturating_mul(8)
        } else {
            self.pos
        };
        let (end, decoded) = self.decode(start, f, k, out);
        // Reading past the end only loads zeros (see `Bits`): whether it happened is checked
        // once, here, and it is this frame's error whatever else the zeros decoded to.
        if end > self.take.stream.len().saturating_mul(8) {
            return Err(TakeFrameError::StreamEnd { frame: f });
        }
        decoded?;
        self.pos = end;
        self.next += 1;
        Ok(())
    }

    /// Decode frame `f`, frame `k` of its key interval, from bit `start` of the stream: the bit
    /// position where it stopped (at the end, or at the value that failed) and the outcome.
    /// The cursor is a local here, so that its fields live in registers.
    #[inline(never)]
    fn decode<'o>(
        &mut self,
        start: usize,
        f: usize,
        k: usize,
        out: impl Outputs<'o>,
    ) -> (usize, Result<(), TakeFrameError>) {
        let mut bits = Bits::at(self.take.stream, start, f);
        let decoded = if k == 0 {
            self.key_frame(&mut bits, out)
        } else {
            self.predicted_frame(&mut bits, k, out)
        };
        (bits.position(), decoded)
    }

    /// A key frame: presence, then absolute values.
    #[inline(always)]
    fn key_frame<'o>(
        &mut self,
        bits: &mut Bits<'_>,
        out: impl Outputs<'o>,
    ) -> Result<(), TakeFrameError> {
        let markers = &mut self.markers[..self.take.marker_count()];
        for marker in markers.iter_mut() {
            marker.present = bits.bit();
        }
        let (key_min, key_width) = (self.take.key_min, self.take.key_width.map(u32::from));
        // The two loops are written out: sharing their body through a helper made the
        // predicted frames 20 % slower on the M4 (the one decode function's code layout).
        let fits = if self.short_keys {
            // Every key value is `key_min + u` within `i32`, its bits fewer than a refill's.
            markers.iter_mut().zip(out).all(|(marker, out)| {
                marker.q = [0; 3];
                let mut fits = true;
                if marker.present {
                    let mut axis = |a: usize| {
                        let v = key_min[a].wrapping_add(bits.narrow(key_width[a]) as i32);
                        fits &= marker.holds(v);
                        v
                    };
                    marker.q = [axis(0), axis(1), axis(2)];
                }
                marker.q2 = marker.q;
                emit(out, marker);
                fits
            })
        } else {
            markers.iter_mut().zip(out).all(|(marker, out)| {
                marker.q = [0; 3];
                let mut fits = true;
                if marker.present {
                    for axis in 0..3 {
                        let v = i64::from(key_min[axis]) + i64::from(bits.bits(key_width[axis]));
                        fits &= marker.holds_wide(v);
                        // Within `i32` when it fits; a value that does not fit fails the frame.
                        marker.q[axis] = v as i32;
                    }
                }
                marker.q2 = marker.q;
                emit(out, marker);
                fits
            })
        };
        bits.outcome(fits)
    }

    /// Frame `k` (≥ 1) of a key interval: block heads at a block's start, presence if it
    /// changed, then each present marker's residuals over its prediction.
    #[inline(always)]
    fn predicted_frame<'o>(
        &mut self,
        bits: &mut Bits<'_>,
        k: usize,
        out: impl Outputs<'o>,
    ) -> Result<(), TakeFrameError> {
        let markers = &mut self.markers[..self.take.marker_count()];
        if (k - 1).is_multiple_of(self.take.block_frames()) {
            bits.heads(markers);
        }
        if bits.bit() {
            for marker in markers.iter_mut() {
                marker.present = bits.bit();
            }
        }
        let markers = markers.iter_mut().zip(out);
        let fits = if self.narrow {
            markers.into_iter().all(|(marker, out)| {
                let fits = step_narrow(marker, bits);
                emit(out, marker);
                fits
            })
        } else {
            markers.into_iter().all(|(marker, out)| {
                let fits = step_wide(marker, bits);
                emit(out, marker);
                fits
            })
        };
        bits.outcome(fits)
    }
}

/// Where a frame's samples go: one item per marker, `Some` slot to write, or `None` to
/// decode into the state only (seeking).
trait Outputs<'o>: Iterator<Item = Option<&'o mut Option<[i32; 3]>>> {}

impl<'o, I: Iterator<Item = Option<&'o mut Option<[i32; 3]>>>> Outputs<'o> for I {}

/// Write `marker`'s decoded sample to `out` (if it is a slot): `q · step` per axis, `None` if
/// the marker is missing. Written as the frame decodes, while the values are in registers.
#[inline(always)]
fn emit(out: Option<&mut Option<[i32; 3]>>, marker: &Marker) {
    if let Some(out) = out {
        // A value that fits its bounds has a product within `i32`; one that does not fails the
        // frame (the call returns the error), so its wrapped product is not a sample.
        let step = marker.step as i32;
        *out = marker
            .present
            .then(|| marker.q.map(|q| q.wrapping_mul(step)));
    }
}

/// A marker's residuals for one predicted frame, read from `bits` (none if it is missing or
/// every width of its block is 0; else a flag, and when it is set a [`Bits::residual`] per axis
/// of non-zero width).
#[inline(always)]
fn residuals(marker: &Marker, bits: &mut Bits<'_>) -> [i32; 3] {
    let widths = u32::from(marker.head) >> 1;
    if !marker.present || widths == 0 {
        return [0; 3];
    }
    let mask = (1 << WIDTH_BITS) - 1;
    let (w0, w1, w2) = (
        widths & mask,
        (widths >> WIDTH_BITS) & mask,
        widths >> (2 * WIDTH_BITS),
    );
    // A flag, and per axis a flag, a sign and w − 1 bits: at most 4 + w0 + w1 + w2.
    if 4 + w0 + w1 + w2 <= Bits::REFILLED {
        return bits.short_residuals([w0, w1, w2]);
    }
    if !bits.bit() {
        return [0; 3];
    }
    // The three axes written out: a loop kept `r` in memory.
    let mut axis = |w: u32| if w > 0 { bits.residual(w - 1) } else { 0 };
    [axis(w0), axis(w1), axis(w2)]
}

/// One predicted frame of a present marker of a narrow take (every step ≥ [`NARROW_STEP`]): its
/// prediction plus its residuals, in `i32`; whether every value fits. A missing marker keeps
/// its values.
#[inline(always)]
fn step_narrow(marker: &mut Marker, bits: &mut Bits<'_>) -> bool {
    let r = residuals(marker, bits);
    if !marker.present {
        return true;
    }
    // All ones for second order: the slope counts, else it is masked out.
    let second = 0i32.wrapping_sub(i32::from(marker.head & 1));
    // The largest offset of a value from `low` ([`Marker::holds`] of all three at once).
    let mut offset = 0u32;
    // Indexing the three arrays in step (an iterator over `r` made slower code on the M4).
    #[allow(clippy::needless_range_loop)]
    for axis in 0..3 {
        let last = marker.q[axis];
        // |last|, |q2| ≤ 2²⁸ and |r| ≤ 2³⁰ (see `narrow`): no sum wraps.
        let slope = last.wrapping_sub(marker.q2[axis]) & second;
        let v = last.wrapping_add(slope).wrapping_add(r[axis]);
        offset = offset.max(v.wrapping_sub(marker.low) as u32);
        marker.q2[axis] = last;
        marker.q[axis] = v;
    }
    offset <= marker.span
}

/// [`step_narrow`] for any take: in `i64`.
#[inline(always)]
fn step_wide(marker: &mut Marker, bits: &mut Bits<'_>) -> bool {
    let r = residuals(marker, bits);
    if !marker.present {
        return true;
    }
    let second = marker.head & 1 == 1;
    let mut fits = true;
    for (axis, r) in r.into_iter().enumerate() {
        let last = i64::from(marker.q[axis]);
        let slope = if second {
            last - i64::from(marker.q2[axis])
        } else {
            0
        };
        let v = last + slope + i64::from(r);
        fits &= marker.holds_wide(v);
        marker.q2[axis] = marker.q[axis];
        // Within `i32` when it fits; a value that does not fit fails the frame.
        marker.q[axis] = v as i32;
    }
    fits
}

/// A cursor in a take's bit stream, for the frame being decoded (which its errors name).
///
/// Bits are read least significant first through a 32-bit buffer refilled four bytes at a time
/// ([`Self::refill`]), so a flag is a shift and a mask. Bytes past the end of the stream load as
/// zeros: the caller checks [`Self::position`] against the stream's length once the frame is
/// decoded.
struct Bits<'s> {
    stream: &'s [u8],
    /// The next byte to load into `buf`.
    next_byte: usize,
    /// Loaded bits not yet read, the next one lowest.
    buf: u32,
    /// How many bits `buf` holds, at most 32.
    held: u32,
    frame: usize,
}

impl<'s> Bits<'s> {
    /// A cursor at bit `pos` of `stream`, decoding frame `frame`.
    fn at(stream: &'s [u8], pos: usize, frame: usize) -> Self {
        let mut bits = Self {
            stream,
            next_byte: pos / 8,
            buf: 0,
            held: 0,
            frame,
        };
        bits.refill();
        let skip = (pos % 8) as u32;
        bits.buf >>= skip;
        bits.held -= skip;
        bits
    }

    /// The bit position of the next read.
    fn position(&self) -> usize {
        self.next_byte * 8 - self.held as usize
    }

    /// Load bytes until at least 24 bits are held. Called with at most 23 held. Four bytes at
    /// once while they are in the stream: the word goes in above the held bits and only the
    /// whole bytes that fit are counted; the bits of a partly fitting byte are the stream's own,
    /// which the next load ORs in again. Near the end, a byte at a time.
    #[inline(always)]
    fn refill(&mut self) {
        if let Some(word) = self.stream.get(self.next_byte..self.next_byte + 4) {
            let word = u32::from_le_bytes([word[0], word[1], word[2], word[3]]);
            // held ≤ 23: the shift is defined, and at least one byte fits.
            self.buf |= word << self.held;
            let bytes = (31 - self.held) >> 3;
            self.next_byte += bytes as usize;
            self.held += 8 * bytes;
            return;
        }
        while self.held <= 24 {
            let byte = self.stream.get(self.next_byte).copied().unwrap_or(0);
            self.buf |= u32::from(byte) << self.held;
            self.held += 8;
            self.next_byte += 1;
        }
    }

    /// `n` ≤ 32 bits, least significant first.
    #[inline(always)]
    fn bits(&mut self, n: u32) -> u32 {
        if n > 24 {
            let low = self.narrow(16);
            return low | self.narrow(n - 16) << 16;
        }
        self.narrow(n)
    }

    /// `n` ≤ 24 bits (not recursive, so that it inlines).
    #[inline(always)]
    fn narrow(&mut self, n: u32) -> u32 {
        if self.held < n {
            self.refill();
        }
        let value = self.buf & ((1u32 << n) - 1);
        // n ≤ 24 < 32: the shift is defined.
        self.buf >>= n;
        self.held -= n;
        value
    }

    /// A residual whose magnitude has `width` ≤ 30 bits: a flag (0: zero), then the sign and
    /// the magnitude less one. The three reads at once when they fit the buffer (the same bits).
    #[inline(always)]
    fn residual(&mut self, width: u32) -> i32 {
        let n = 2 + width;
        if n > 24 {
            if !self.bit() {
                return 0;
            }
            let negative = self.bit();
            // At most 30 bits, plus one: an i32.
            let magnitude = self.bits(width) as i32 + 1;
            return if negative { -magnitude } else { magnitude };
        }
        if self.held < n {
            self.refill();
        }
        let v = self.buf;
        if v & 1 == 0 {
            self.buf >>= 1;
            self.held -= 1;
            return 0;
        }
        let magnitude = ((v >> 2) & ((1u32 << width) - 1)) as i32 + 1;
        // n ≤ 24 < 32: the shift is defined.
        self.buf >>= n;
        self.held -= n;
        if v & 2 != 0 {
            -magnitude
        } else {
            magnitude
        }
    }

    /// Each marker's head at the start of a block: its order bit and three widths, 16 bits
    /// ([`Marker::head`]). The heads lie at one bit offset within every pair of bytes, so
    /// while the stream holds them whole each is a 32-bit load and a shift, and the cursor
    /// then moves past them; near the end, one [`Self::bits`] each.
    #[inline(always)]
    fn heads(&mut self, markers: &mut [Marker]) {
        const HEAD_BITS: usize = 1 + 3 * WIDTH_BITS as usize;
        const _: () = assert!(HEAD_BITS == 16);
        let start = self.position();
        let first = start / 8;
        // Head i is in bytes first + 2i ..= first + 2i + 2 (of a 4-byte load).
        let window = self.stream.get(first..first + 2 * markers.len() + 2);
        let Some(window) = window else {
            for marker in markers.iter_mut() {
                marker.head = self.bits(HEAD_BITS as u32) as u16;
            }
            return;
        };
        let shift = (start % 8) as u32;
        for (marker, bytes) in markers.iter_mut().zip(window.windows(4).step_by(2)) {
            let word = u32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]);
            marker.head = (word >> shift) as u16;
        }
        *self = Self::at(self.stream, start + HEAD_BITS * markers.len(), self.frame);
    }

    /// The frame's outcome: every value fits, or it is out of range.
    #[inline(always)]
    fn outcome(&self, fits: bool) -> Result<(), TakeFrameError> {
        if fits {
            Ok(())
        } else {
            Err(TakeFrameError::OutOfRange { frame: self.frame })
        }
    }

    /// Bits held after a [`Self::refill`], at least.
    const REFILLED: u32 = 24;

    /// A marker's residuals when all of them fit the buffer (at most [`Self::REFILLED`] bits
    /// over the axes' `widths`): one refill check, then a flag and each axis's bits taken from
    /// a copy of the buffer, with no further check.
    #[inline(always)]
    fn short_residuals(&mut self, widths: [u32; 3]) -> [i32; 3] {
        if self.held < Self::REFILLED {
            self.refill();
        }
        let mut v = self.buf;
        if v & 1 == 0 {
            self.buf = v >> 1;
            self.held -= 1;
            return [0; 3];
        }
        v >>= 1;
        let mut used = 1;
        let mut axis = |w: u32| {
            if w == 0 {
                return 0;
            }
            if v & 1 == 0 {
                v >>= 1;
                used += 1;
                return 0;
            }
            // w − 1 bits of |r| − 1 after the flag and the sign.
            let magnitude = ((v >> 2) & ((1u32 << w) >> 1).wrapping_sub(1)) as i32 + 1;
            let negative = v & 2 != 0;
            // w + 1 ≤ 24 bits in all (the caller checked): the shift is defined.
            v >>= w + 1;
            used += w + 1;
            if negative {
                -magnitude
            } else {
                magnitude
            }
        };
        let r = [axis(widths[0]), axis(widths[1]), axis(widths[2])];
        self.buf = v;
        self.held -= used;
        r
    }

    /// One bit.
    #[inline(always)]
    fn bit(&mut self) -> bool {
        if self.held == 0 {
            self.refill();
        }
        let bit = self.buf & 1;
        self.buf >>= 1;
        self.held -= 1;
        bit == 1
    }
}
