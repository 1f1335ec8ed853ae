//! The boundary: turning the caller's pointers into slices after checking them, caller-provided
//! storage, and the guard that keeps a panic from crossing into C.

use core::mem::size_of;

use crate::error::FbError;

/// Run `body`, turning a panic into [`FbError::Internal`]. The library is written not to panic
/// (every index is checked, the runtime never panics); this is the last line of defence, so
/// that no unwind ever crosses the C boundary.
#[cfg(feature = "std")]
pub(crate) fn guard(body: impl FnOnce() -> Result<(), FbError>) -> FbError {
    match std::panic::catch_unwind(core::panic::AssertUnwindSafe(body)) {
        Ok(Ok(())) => FbError::None,
        Ok(Err(e)) => e,
        Err(_) => FbError::Internal,
    }
}

/// Run `body` (`no_std`: panics abort through the crate's panic handler, so none unwinds).
#[cfg(not(feature = "std"))]
pub(crate) fn guard(body: impl FnOnce() -> Result<(), FbError>) -> FbError {
    match body() {
        Ok(()) => FbError::None,
        Err(e) => e,
    }
}

/// Check that `ptr` is non-null and aligned for `T`.
pub(crate) fn check<T>(ptr: *const T) -> Result<(), FbError> {
    if ptr.is_null() {
        Err(FbError::NullPointer)
    } else if !ptr.is_aligned() {
        Err(FbError::Misaligned)
    } else {
        Ok(())
    }
}

/// `len` elements at `ptr`, read-only.
///
/// # Safety
/// If `ptr` is non-null and aligned, it must be valid for reads of `len` elements of `T`, not
/// written during the returned borrow. Callers pass only lengths the rig fixes (at most its
/// vertex or marker count), after checking that the caller's stated length covers them.
pub(crate) unsafe fn slice<'a, T>(ptr: *const T, len: usize) -> Result<&'a [T], FbError> {
    check(ptr)?;
    // SAFETY: non-null and aligned (checked); valid for `len` reads by the caller's contract.
    Ok(unsafe { core::slice::from_raw_parts(ptr, len) })
}

/// `len` elements at `ptr`, writable.
///
/// # Safety
/// As [`slice`], for reads and writes, and not otherwise accessed during the borrow.
pub(crate) unsafe fn slice_mut<'a, T>(ptr: *mut T, len: usize) -> Result<&'a mut [T], FbError> {
    check(ptr)?;
    // SAFETY: non-null and aligned (checked); valid for `len` reads and writes by the caller's
    // contract.
    Ok(unsafe { core::slice::from_raw_parts_mut(ptr, len) })
}

/// `count` positions (x y z each) at `ptr`, which the caller says holds `given` positions; the
/// rig needs exactly `count` of them.
///
/// # Safety
/// As [`slice`], for `given` positions of three `T`.
pub(crate) unsafe fn positions<'a, T>(
    ptr: *const T,
    given: usize,
    count: usize,
) -> Result<&'a [[T; 3]], FbError> {
    if given != count {
        return Err(FbError::MarkerCount);
    }
    // SAFETY: `[T; 3]` has `T`'s alignment; the caller's contract covers `count` positions.
    unsafe { slice(ptr.cast::<[T; 3]>(), count) }
}

/// Room for `count` positions at `ptr`, which the caller says has room for `capacity`.
///
/// # Safety
/// As [`slice_mut`], for `capacity` positions of three `T`.
pub(crate) unsafe fn positions_out<'a, T>(
    ptr: *mut T,
    capacity: usize,
    count: usize,
) -> Result<&'a mut [[T; 3]], FbError> {
    check(ptr)?;
    if capacity < count {
        return Err(FbError::BufferTooSmall);
    }
    // SAFETY: as `positions`.
    unsafe { slice_mut(ptr.cast::<[T; 3]>(), count) }
}

/// Write `value` through an out-pointer.
///
/// # Safety
/// If `ptr` is non-null and aligned, it must be valid for a write of `T`.
pub(crate) unsafe fn write<T>(ptr: *mut T, value: T) -> Result<(), FbError> {
    check(ptr)?;
    // SAFETY: non-null and aligned (checked); valid for a write by the caller's contract.
    unsafe { ptr.write(value) };
    Ok(())
}

/// Caller-provided storage for a value that this library writes (`FbRig`, `FbPlayState`): an
/// opaque type around a [`Tagged`] value. The tag says the value was written by [`store`], so a
/// never-initialised storage, or one whose last load failed, is refused instead of read. (The tag
/// catches mistakes; it cannot prove that arbitrary memory holds a value.)
pub(crate) trait Storage: Sized {
    /// What the storage holds.
    type Value;
    /// The tag of a filled storage.
    const TAG: u64;
    /// The error for a storage without the tag.
    const MISSING: FbError;

    /// The tagged value inside the storage.
    ///
    /// # Safety
    /// `storage` is non-null, aligned and valid for `size_of::<Self>()` bytes.
    unsafe fn tagged(storage: *mut Self) -> *mut Tagged<Self::Value>;
}

/// A value and the tag that says it is there.
#[repr(C)]
pub(crate) struct Tagged<T> {
    tag: u64,
    value: T,
}

/// Write `make()`'s value into `storage` (non-null, aligned, at least `len` ≥ `size_of::<S>()`
/// bytes). The tag is cleared first, so on any error the storage reads as empty.
///
/// # Safety
/// If `storage` passes the checks, it must be valid for writes of `len` bytes and not be
/// accessed by anyone else during the call.
pub(crate) unsafe fn store<S: Storage>(
    storage: *mut S,
    len: usize,
    make: impl FnOnce() -> Result<S::Value, FbError>,
) -> Result<(), FbError> {
    check(storage)?;
    if len < size_of::<S>() {
        return Err(FbError::BufferTooSmall);
    }
    // SAFETY: non-null, aligned and large enough (checked above).
    let tagged = unsafe { S::tagged(storage) };
    // SAFETY: `tagged` lies inside the storage; the tag is a plain integer.
    unsafe { core::ptr::addr_of_mut!((*tagged).tag).write(0) };
    let value = make()?;
    // SAFETY: as above; `write` drops nothing (the old bytes are not a value).
    unsafe { tagged.write(Tagged { tag: S::TAG, value }) };
    Ok(())
}

/// The value in `storage`, if [`store`] put one there.
///
/// # Safety
/// If `storage` is non-null and aligned, it must be valid for reads of `size_of::<S>()` bytes,
/// and not be written during the borrow.
pub(crate) unsafe fn stored<'a, S: Storage>(storage: *const S) -> Result<&'a S::Value, FbError> {
    check(storage)?;
    // SAFETY: non-null and aligned; valid by the caller's contract. Only read through.
    let tagged = unsafe { S::tagged(storage.cast_mut()) };
    // SAFETY: inside the storage; the tag is a plain integer at the start of a `repr(C)` struct.
    if unsafe { core::ptr::addr_of!((*tagged).tag).read() } != S::TAG {
        return Err(S::MISSING);
    }
    // SAFETY: the tag says `store` wrote the value.
    Ok(unsafe { &(*tagged).value })
}

/// [`stored`], writable.
///
/// # Safety
/// As [`stored`], and not otherwise accessed during the borrow.
pub(crate) unsafe fn stored_mut<'a, S: Storage>(
    storage: *mut S,
) -> Result<&'a mut S::Value, FbError> {
    // SAFETY: as `stored`.
    unsafe { stored(storage)? };
    // SAFETY: checked by `stored`; exclusive by the caller's contract.
    Ok(unsafe { &mut (*S::tagged(storage)).value })
}
