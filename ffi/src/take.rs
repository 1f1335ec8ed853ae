//! Packed takes (`.fbt`, `facebake pack`) from C: load one into caller storage with its reader,
//! then decode its frames in order or seek. Packed with `--rig`, the samples are that rig's
//! actor units, which `fb_play` takes as they are.

use core::ffi::c_char;
use core::mem::{align_of, size_of};

use facebake_runtime::{Take, TakeFrameError, TakeLoadError, TakeReader, MAX_MARKERS};

use crate::error::FbError;
use crate::memory::{guard, slice, slice_mut, store, stored, stored_mut, write, Storage, Tagged};
use crate::rig::FbSpace;

/// Storage of a loaded packed take and its read position (`fb_take_size()` bytes, aligned to
/// `fb_take_align()`, about 8 KB), filled by `fb_take_load`. It borrows the take's bytes and
/// owns nothing. Decoding moves its position, so one reader serves one consumer at a time;
/// load the same bytes into a second storage to read from two places.
pub struct FbTake(Tagged<TakeReader<'static>>);

impl Storage for FbTake {
    type Value = TakeReader<'static>;
    const TAG: u64 = u64::from_le_bytes(*b"fbTake\0\x01");
    const MISSING: FbError = FbError::TakeNotLoaded;

    unsafe fn tagged(storage: *mut Self) -> *mut Tagged<Self::Value> {
        // SAFETY: `storage` is valid (the trait's contract), so the field is in bounds.
        unsafe { core::ptr::addr_of_mut!((*storage).0) }
    }
}

impl From<TakeLoadError> for FbError {
    fn from(e: TakeLoadError) -> Self {
        match e {
            TakeLoadError::Header(e) => e.into(),
            TakeLoadError::Truncated { .. } => Self::Truncated,
            TakeLoadError::TrailingBytes => Self::TrailingBytes,
            _ => Self::InvalidTake,
        }
    }
}

impl From<TakeFrameError> for FbError {
    fn from(e: TakeFrameError) -> Self {
        match e {
            TakeFrameError::NoFrame { .. } => Self::IndexOutOfRange,
            TakeFrameError::OutputLength { .. } => Self::MarkerCount,
            TakeFrameError::StreamEnd { .. } | TakeFrameError::OutOfRange { .. } => {
                Self::InvalidTake
            }
        }
    }
}

/// The reader in `take`, if it holds a loaded take.
///
/// # Safety
/// `take` is null or valid for reads of `fb_take_size()` bytes, not written during the borrow.
unsafe fn loaded<'a>(take: *const FbTake) -> Result<&'a TakeReader<'static>, FbError> {
    // SAFETY: the caller's contract.
    unsafe { stored(take) }
}

/// Bytes of storage an `FbTake` needs.
#[no_mangle]
pub extern "C" fn fb_take_size() -> usize {
    size_of::<FbTake>()
}

/// Alignment the storage of an `FbTake` needs.
#[no_mangle]
pub extern "C" fn fb_take_align() -> usize {
    align_of::<FbTake>()
}

/// Validate the packed take `bytes[0..len]` (header, checksum, every count, field and key frame
/// offset) and load it into `storage` (`storage_len` bytes, at least `fb_take_size()`, aligned
/// to `fb_take_align()`), positioned at its first frame. The bytes need no alignment; they are
/// borrowed, not copied, and must outlive every use of the take. On error the storage holds no
/// take (`FB_ERROR_TAKE_NOT_LOADED` if used).
///
/// # Safety
/// `bytes` must be valid for reads of `len` bytes and `storage` for writes of `storage_len`
/// bytes (or be null). Neither may be written by anyone else during the call; the bytes not
/// while the take is in use.
#[no_mangle]
pub unsafe extern "C" fn fb_take_load(
    bytes: *const u8,
    len: usize,
    storage: *mut FbTake,
    storage_len: usize,
) -> FbError {
    guard(|| {
        // SAFETY: the caller's contract.
        let bytes: &'static [u8] = unsafe { slice(bytes, len)? };
        // SAFETY: the caller's contract.
        unsafe {
            store(storage, storage_len, || {
                Ok(TakeReader::new(Take::from_bytes(bytes)?))
            })
        }
    })
}

/// Frames in the take; 0 if `take` is not a loaded take.
///
/// # Safety
/// `take` is null or valid for reads of `fb_take_size()` bytes.
#[no_mangle]
pub unsafe extern "C" fn fb_take_frame_count(take: *const FbTake) -> usize {
    // SAFETY: the caller's contract.
    unsafe { loaded(take) }.map_or(0, |r| r.take().frame_count())
}

/// Markers per frame (1 to `FB_MAX_MARKERS`); 0 if `take` is not a loaded take.
///
/// # Safety
/// As `fb_take_frame_count`.
#[no_mangle]
pub unsafe extern "C" fn fb_take_marker_count(take: *const FbTake) -> usize {
    // SAFETY: the caller's contract.
    unsafe { loaded(take) }.map_or(0, |r| r.take().marker_count())
}

/// Frames per second of the capture; 0 if `take` is not a loaded take.
///
/// # Safety
/// As `fb_take_frame_count`.
#[no_mangle]
pub unsafe extern "C" fn fb_take_rate(take: *const FbTake) -> f64 {
    // SAFETY: the caller's contract.
    unsafe { loaded(take) }.map_or(0.0, |r| r.take().rate_hz())
}

/// The frame `fb_take_next_frame` decodes next (the frame count once the take has ended); 0 if
/// `take` is not a loaded take.
///
/// # Safety
/// As `fb_take_frame_count`.
#[no_mangle]
pub unsafe extern "C" fn fb_take_position(take: *const FbTake) -> usize {
    // SAFETY: the caller's contract.
    unsafe { loaded(take) }.map_or(0, |r| r.frame())
}

/// Write where the take's units sit in the capture's space to `*space` (for a take packed with
/// `--rig`, the rig's actor space: `fb_rig_actor_space`).
///
/// # Safety
/// `take` as `fb_take_frame_count`; `space` null or valid for a write.
#[no_mangle]
pub unsafe extern "C" fn fb_take_space(take: *const FbTake, space: *mut FbSpace) -> FbError {
    guard(|| {
        // SAFETY: the caller's contract.
        let reader = unsafe { loaded(take)? };
        // SAFETY: the caller's contract.
        unsafe { write(space, reader.take().space().into()) }
    })
}

/// Point `*name` at the UTF-8 name of the take's marker `index` inside its bytes (NOT
/// NUL-terminated; valid while the bytes are) and write its length in bytes to `*name_len`.
/// Match these to `fb_marker_name`'s to feed a rig the take's markers in its own order.
///
/// # Safety
/// `take` as `fb_take_frame_count`; `name` and `name_len` null or valid for a write.
#[no_mangle]
pub unsafe extern "C" fn fb_take_marker_name(
    take: *const FbTake,
    index: usize,
    name: *mut *const c_char,
    name_len: *mut usize,
) -> FbError {
    guard(|| {
        // SAFETY: the caller's contract.
        let reader = unsafe { loaded(take)? };
        let found = reader
            .take()
            .marker_names()
            .nth(index)
            .ok_or(FbError::IndexOutOfRange)?;
        // SAFETY: the caller's contract.
        unsafe {
            crate::memory::check(name)?;
            write(name_len, found.len())?;
            write(name, found.as_ptr().cast::<c_char>())
        }
    })
}

/// Decode the next frame: `samples` gets `marker_count` (= `fb_take_marker_count`) positions,
/// Q8.24 in the take's space, x y z each, in the take's marker order, and `present` one byte
/// per marker, 0 where the sample is missing (its position is then written as 0 0 0); `*frame`
/// gets the frame's index. Once every frame has been decoded: `FB_ERROR_END_OF_TAKE`, nothing
/// written (`fb_take_seek` starts again). A corrupt stream behind a valid checksum gives
/// `FB_ERROR_INVALID_TAKE` and ends the take. Allocates nothing; decoding costs at most a few
/// bit reads per marker.
///
/// # Safety
/// `take` null or valid for reads and writes of `fb_take_size()` bytes and used by no one else
/// during the call; `samples`, `present` and `frame` null or valid for the writes their counts
/// imply, overlapping nothing else.
#[no_mangle]
pub unsafe extern "C" fn fb_take_next_frame(
    take: *mut FbTake,
    samples: *mut i32,
    present: *mut u8,
    marker_count: usize,
    frame: *mut usize,
) -> FbError {
    guard(|| {
        // SAFETY: the caller's contract.
        let reader = unsafe { stored_mut(take)? };
        let m = reader.take().marker_count();
        if marker_count != m {
            return Err(FbError::MarkerCount);
        }
        // SAFETY: the caller's contract; `[i32; 3]` has `i32`'s alignment.
        let samples = unsafe { slice_mut(samples.cast::<[i32; 3]>(), m)? };
        // SAFETY: the caller's contract.
        let present = unsafe { slice_mut(present, m)? };
        crate::memory::check(frame)?;
        if reader.frame() >= reader.take().frame_count() {
            return Err(FbError::EndOfTake);
        }
        let mut row = [None; MAX_MARKERS];
        let Some(f) = reader.next_frame(&mut row[..m])? else {
            return Err(FbError::EndOfTake);
        };
        for ((s, p), r) in samples.iter_mut().zip(present.iter_mut()).zip(&row[..m]) {
            *s = r.unwrap_or([0; 3]);
            *p = u8::from(r.is_some());
        }
        // SAFETY: checked above; valid for a write by the caller's contract.
        unsafe { write(frame, f) }
    })
}

/// Position the take so that `fb_take_next_frame` decodes `frame` next (0 ≤ `frame` ≤ the frame
/// count; `FB_ERROR_INDEX_OUT_OF_RANGE` beyond). Decodes forward from the key frame at or before
/// it, at most one key interval; the frames then decoded are bit-identical to a sequential read.
///
/// # Safety
/// As `fb_take_next_frame`, for `take`.
#[no_mangle]
pub unsafe extern "C" fn fb_take_seek(take: *mut FbTake, frame: usize) -> FbError {
    guard(|| {
        // SAFETY: the caller's contract.
        let reader = unsafe { stored_mut(take)? };
        Ok(reader.seek(frame)?)
    })
}
