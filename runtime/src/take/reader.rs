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
}

impl<'a> TakeReader<'a> {
    /// A reader at frame 0 of `take`.
    pub fn new(take: Take<'a>) -> Self {
        Self {
            take,
            next: 0,
            pos: 0,
            q: [[0; 3]; MAX_MARKERS],
            q2: [[0; 3]; MAX_MARKERS],
            present: [false; MAX_MARKERS],
            second_order: [false; MAX_MARKERS],
            width: [[0; 3]; MAX_MARKERS],
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
        for (i, o) in out.iter_mut().enumerate() {
            let step = le_u32_at(self.take.steps, i) as i32;
            // `advance` checked that every present value fits: the products cannot wrap.
            *o = self.present[i].then(|| self.q[i].map(|q| q.wrapping_mul(step)));
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

    /// `n` ≤ 32 bits from the stream, least significant first.
    fn bits(&mut self, n: u32) -> Result<u32, TakeFrameError> {
        let stream = self.take.stream;
        let end = self.pos + n as usize;
        if end > stream.len().saturating_mul(8) {
            return Err(TakeFrameError::StreamEnd {
                frame: self.next as usize,
            });
        }
        let at = self.pos / 8;
        let mut word = 0u64;
        for i in 0..5 {
            if let Some(&b) = stream.get(at + i) {
                word |= u64::from(b) << (8 * i);
            }
        }
        let value = (word >> (self.pos % 8)) & ((1u64 << n) - 1);
        self.pos = end;
        Ok(value as u32)
    }

    fn bit(&mut self) -> Result<bool, TakeFrameError> {
        Ok(self.bits(1)? == 1)
    }

    /// Marker `i`'s quantised value `q` on `axis`, after checking that `q × step` fits `i32`.
    fn set(&mut self, i: usize, axis: usize, q: i64) -> Result<(), TakeFrameError> {
        // q first narrowed to 32 bits, so the product is one 32 × 32 → 64-bit multiply (a
        // 64-bit saturating one costs a Cortex-M4 several): |q| < 2³¹ and step < 2³², so it
        // cannot overflow, and it fits 32 bits exactly when the saturating product of the wide
        // q did.
        let q = i32::try_from(q).ok();
        let value = q.map(|q| i64::from(q) * i64::from(le_u32_at(self.take.steps, i)));
        match (q, value.map(i32::try_from)) {
            (Some(q), Some(Ok(_))) => {
                self.q[i][axis] = q;
                Ok(())
            }
            _ => Err(TakeFrameError::OutOfRange {
                frame: self.next as usize,
            }),
        }
    }

    /// Decode frame `self.next` into the state and move on.
    fn advance(&mut self) -> Result<(), TakeFrameError> {
        let m = self.take.marker_count();
        let f = self.next as usize;
        let n = self.take.key_interval();
        let k = f % n;
        if k == 0 {
            self.pos = (le_u32_at(self.take.keys, f / n) as usize).saturating_mul(8);
            for i in 0..m {
                self.present[i] = self.bit()?;
            }
            for i in 0..m {
                self.q[i] = [0; 3];
                if self.present[i] {
                    for axis in 0..3 {
                        let u = self.bits(u32::from(self.take.key_width[axis]))?;
                        self.set(i, axis, i64::from(self.take.key_min[axis]) + i64::from(u))?;
                    }
                }
                self.q2[i] = self.q[i];
            }
        } else {
            if (k - 1).is_multiple_of(self.take.block_frames()) {
                for i in 0..m {
                    self.second_order[i] = self.bit()?;
                    for axis in 0..3 {
                        self.width[i][axis] = self.bits(WIDTH_BITS)? as u8;
                    }
                }
            }
            if self.bit()? {
                for i in 0..m {
                    self.present[i] = self.bit()?;
                }
            }
            for i in 0..m {
                if !self.present[i] {
                    continue;
                }
                let w = self.width[i];
                let any = w != [0; 3] && self.bit()?;
                for (axis, &w) in w.iter().enumerate() {
                    let mut r = 0;
                    if any && w > 0 && self.bit()? {
                        let negative = self.bit()?;
                        let magnitude = i64::from(self.bits(u32::from(w).min(MAX_WIDTH) - 1)?) + 1;
                        r = if negative { -magnitude } else { magnitude };
                    }
                    let last = i64::from(self.q[i][axis]);
                    let prediction = if self.second_order[i] {
                        2 * last - i64::from(self.q2[i][axis])
                    } else {
                        last
                    };
                    self.q2[i][axis] = self.q[i][axis];
                    self.set(i, axis, prediction + r)?;
                }
            }
        }
        self.next += 1;
        Ok(())
    }
}
