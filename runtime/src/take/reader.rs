//! [`TakeReader`]: decodes a [`Take`] frame by frame into a fixed state, no allocation.

use super::{le_u32_at, Take, MAX_WIDTH, WIDTH_BITS};
use crate::records::MAX_MARKERS;

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
/// [`Self::seek`]. Its whole state is fixed-size (about 7 KiB): each marker's last two quantised
/// values, presence, prediction order and residual widths, and the position in the stream.
#[derive(Clone, Debug)]
pub struct TakeReader<'a> {
    take: Take<'a>,
    /// The frame the next call decodes.
    next: u32,
    /// Bit position in the stream.
    pos: usize,
    /// Each marker's last quantised value,
    q: [[i32; 3]; MAX_MARKERS],
    /// and the one before it (second-order prediction).
    q2: [[i32; 3]; MAX_MARKERS],
    present: [bool; MAX_MARKERS],
    /// Per marker over the current block: second-order prediction, and the residual widths.
    second_order: [bool; MAX_MARKERS],
    width: [[u8; 3]; MAX_MARKERS],
    /// Each marker's quantisation step (from the take's `steps`, read once).
    steps: [u32; MAX_MARKERS],
    /// Each marker's range of quantised values whose product with its step fits `i32`.
    bounds: [Bounds; MAX_MARKERS],
}

/// The quantised values `q` of a marker with step `s` whose sample `q · s` fits `i32`:
/// `−⌊2³¹/s⌋ ≤ q ≤ ⌊(2³¹ − 1)/s⌋`, found once per take instead of multiplying per sample.
#[derive(Clone, Copy, Debug, Default)]
struct Bounds {
    low: i32,
    high: i32,
}

impl Bounds {
    fn of(step: u32) -> Self {
        // A step is at least 1 (the loader checks it); 0 would make every value fit only as 0.
        let s = i64::from(step.max(1));
        Self {
            low: (-((1i64 << 31) / s)) as i32,
            high: (i64::from(i32::MAX) / s) as i32,
        }
    }
}

impl<'a> TakeReader<'a> {
    /// A reader at frame 0 of `take`.
    pub fn new(take: Take<'a>) -> Self {
        let steps = core::array::from_fn(|i| le_u32_at(take.steps, i));
        Self {
            take,
            next: 0,
            pos: 0,
            q: [[0; 3]; MAX_MARKERS],
            q2: [[0; 3]; MAX_MARKERS],
            present: [false; MAX_MARKERS],
            second_order: [false; MAX_MARKERS],
            width: [[0; 3]; MAX_MARKERS],
            steps,
            bounds: steps.map(Bounds::of),
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
        if let Err(e) = self.advance() {
            self.next = self.take.frame_count;
            return Err(e);
        }
        let state = out
            .iter_mut()
            .zip(&self.present)
            .zip(&self.q)
            .zip(&self.steps);
        for (((o, &present), q), &step) in state {
            // `advance` checked that every present value fits: the products cannot wrap.
            *o = present.then(|| q.map(|q| q.wrapping_mul(step as i32)));
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
            if let Err(e) = self.advance() {
                self.next = self.take.frame_count;
                return Err(e);
            }
        }
        self.next = frame as u32;
        Ok(())
    }

    /// Decode frame `self.next` into the state and move on.
    fn advance(&mut self) -> Result<(), TakeFrameError> {
        let f = self.next as usize;
        let n = self.take.key_interval();
        let k = f % n;
        let start = if k == 0 {
            (le_u32_at(self.take.keys, f / n) as usize).saturating_mul(8)
        } else {
            self.pos
        };
        let mut bits = Bits::at(self.take.stream, start, f);
        let decoded = self.decode(&mut bits, k);
        // Reading past the end only loads zeros (see `Bits`): whether it happened is checked
        // once, here, and it is this frame's error whatever else the zeros decoded to.
        if bits.position() > self.take.stream.len().saturating_mul(8) {
            return Err(TakeFrameError::StreamEnd { frame: f });
        }
        decoded?;
        self.pos = bits.position();
        self.next += 1;
        Ok(())
    }

    /// The body of [`Self::advance`] for frame `k` of its key interval, reading `bits`.
    #[inline(never)]
    fn decode(&mut self, bits: &mut Bits<'_>, k: usize) -> Result<(), TakeFrameError> {
        let m = self.take.marker_count();
        // The per-marker state in step, so that no index is checked in the loops.
        if k == 0 {
            for present in self.present.iter_mut().take(m) {
                *present = bits.bit();
            }
            let (key_min, key_width) = (self.take.key_min, self.take.key_width);
            let markers = self.q.iter_mut().zip(self.q2.iter_mut()).zip(&self.present);
            for (((q, q2), &present), &bounds) in markers.zip(&self.bounds).take(m) {
                *q = [0; 3];
                if present {
                    for (axis, v) in q.iter_mut().enumerate() {
                        let u = bits.bits(u32::from(key_width[axis]));
                        *v = bits.fits(i64::from(key_min[axis]) + i64::from(u), bounds)?;
                    }
                }
                *q2 = *q;
            }
        } else {
            if (k - 1).is_multiple_of(self.take.block_frames()) {
                let blocks = self.second_order.iter_mut().zip(self.width.iter_mut());
                for (second, width) in blocks.take(m) {
                    // The order bit and the three widths in one read (first bit lowest).
                    let head = bits.bits(1 + 3 * WIDTH_BITS);
                    *second = head & 1 == 1;
                    for (axis, w) in width.iter_mut().enumerate() {
                        *w = ((head >> (1 + WIDTH_BITS * axis as u32)) & ((1 << WIDTH_BITS) - 1))
                            as u8;
                    }
                }
            }
            if bits.bit() {
                for present in self.present.iter_mut().take(m) {
                    *present = bits.bit();
                }
            }
            let markers = self.q.iter_mut().zip(self.q2.iter_mut()).zip(&self.present);
            let blocks = self.second_order.iter().zip(&self.width).zip(&self.bounds);
            for (((q, q2), &present), ((&second, &w), &bounds)) in markers.zip(blocks).take(m) {
                if !present {
                    continue;
                }
                let any = w != [0; 3] && bits.bit();
                for axis in 0..3 {
                    let r = if any && w[axis] > 0 {
                        bits.residual(u32::from(w[axis]).min(MAX_WIDTH) - 1)
                    } else {
                        0
                    };
                    let last = i64::from(q[axis]);
                    let prediction = if second {
                        2 * last - i64::from(q2[axis])
                    } else {
                        last
                    };
                    q2[axis] = q[axis];
                    q[axis] = bits.fits(prediction + i64::from(r), bounds)?;
                }
            }
        }
        Ok(())
    }
}

/// A cursor in a take's bit stream, for the frame being decoded (which its errors name).
///
/// Bits are read least significant first through a 32-bit buffer refilled a byte at a time, so a
/// flag is a shift and a mask. Bytes past the end of the stream load as zeros: the caller checks
/// [`Self::position`] against the stream's length once the frame is decoded.
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

    /// Load bytes until more than 24 bits are held (at most four, each a bounded step).
    #[inline(always)]
    fn refill(&mut self) {
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

    /// `q` as a marker's quantised value, after checking that its sample `q × step` fits
    /// `i32` ([`Bounds`]).
    #[inline(always)]
    fn fits(&self, q: i64, bounds: Bounds) -> Result<i32, TakeFrameError> {
        if q < i64::from(bounds.low) || q > i64::from(bounds.high) {
            return Err(TakeFrameError::OutOfRange { frame: self.frame });
        }
        // Within ±2^31 by the bounds: exact.
        Ok(q as i32)
    }
}
