//! [`FbError`], the status every `fb_` function returns, its messages, and the mapping from the
//! runtime's error types.

use core::ffi::c_char;

use facebake_runtime::{ConvertError, FrameError, LoadError};

/// The status of an `fb_` call: `FB_ERROR_NONE` (0) on success, a positive code otherwise.
/// [`fb_error_message`] describes each. The values are stable: new codes are only appended.
#[repr(i32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FbError {
    /// Success.
    None = 0,
    /// A pointer argument that must not be null is null.
    NullPointer = 1,
    /// A pointer argument is not aligned for its type (see the `_align` functions).
    Misaligned = 2,
    /// A caller-provided buffer or storage is shorter than needed (see the `_size` functions
    /// and the counts).
    BufferTooSmall = 3,
    /// The marker count given is not the rig's marker count.
    MarkerCount = 4,
    /// The `FbRig` storage does not hold a rig loaded by `fb_rig_load` (never loaded, or its
    /// last load failed).
    NotLoaded = 5,
    /// The `FbPlayState` storage was not initialised by `fb_play_state_init`.
    NotInitialised = 6,
    /// `fb_play` on a rig baked without capture stages.
    NoStages = 7,
    /// A marker index at or past the rig's marker count.
    IndexOutOfRange = 8,
    /// An `f32` coordinate is NaN or infinite.
    NotFinite = 9,
    /// An `f32` position lies outside the rig's range (128 half extents of the mesh).
    OutOfRange = 10,
    /// The blob is shorter than its header, or than the payload length the header states.
    Truncated = 11,
    /// The blob has bytes after its payload.
    TrailingBytes = 12,
    /// The blob does not start with the facebake magic bytes (of a rig, or of a take for
    /// `fb_take_load`).
    BadMagic = 13,
    /// The blob's format version is not the one this library reads.
    UnsupportedVersion = 14,
    /// The blob's payload does not match its CRC-32 (corrupted or truncated in transit).
    ChecksumMismatch = 15,
    /// The payload does not decode as a rig.
    Malformed = 16,
    /// The payload decodes but fails validation (a count, index, length or weight is wrong).
    InvalidRig = 17,
    /// The rig's capture stages fail validation.
    InvalidStages = 18,
    /// No marker has the name given.
    NotFound = 19,
    /// An internal error was caught at the boundary (a bug in this library: please report it).
    /// Nothing is known to have been written.
    Internal = 20,
    /// The vertex count given is not the rig's vertex count (`fb_normals`' positions).
    VertexCount = 21,
    /// The packed take fails validation (a count, field, name, step or key frame offset is
    /// wrong), or its stream is corrupt behind a valid checksum.
    InvalidTake = 22,
    /// The `FbTake` storage does not hold a take loaded by `fb_take_load` (never loaded, or its
    /// last load failed).
    TakeNotLoaded = 23,
    /// `fb_take_next_frame` after the take's last frame: nothing was written.
    EndOfTake = 24,
    /// `fb_deform_chunk`: the `FbFrameTable` was not filled by `fb_prepare` on this rig (never
    /// filled, or filled by another rig).
    TableMismatch = 25,
    /// `fb_normals_planned`: the plan names a vertex the rig does not have (it was not filled
    /// by `fb_plan_normals` on a rig of this mesh).
    PlanMismatch = 26,
}

impl FbError {
    /// Every code, in value order.
    pub(crate) const ALL: [FbError; 27] = [
        Self::None,
        Self::NullPointer,
        Self::Misaligned,
        Self::BufferTooSmall,
        Self::MarkerCount,
        Self::NotLoaded,
        Self::NotInitialised,
        Self::NoStages,
        Self::IndexOutOfRange,
        Self::NotFinite,
        Self::OutOfRange,
        Self::Truncated,
        Self::TrailingBytes,
        Self::BadMagic,
        Self::UnsupportedVersion,
        Self::ChecksumMismatch,
        Self::Malformed,
        Self::InvalidRig,
        Self::InvalidStages,
        Self::NotFound,
        Self::Internal,
        Self::VertexCount,
        Self::InvalidTake,
        Self::TakeNotLoaded,
        Self::EndOfTake,
        Self::TableMismatch,
        Self::PlanMismatch,
    ];

    /// The static, NUL-terminated message of this code.
    pub const fn message(self) -> &'static core::ffi::CStr {
        match self {
            Self::None => c"no error",
            Self::NullPointer => c"a required pointer is null",
            Self::Misaligned => c"a pointer is not aligned for its type",
            Self::BufferTooSmall => c"a caller-provided buffer or storage is too small",
            Self::MarkerCount => c"the marker count given is not the rig's marker count",
            Self::NotLoaded => c"the FbRig storage does not hold a loaded rig",
            Self::NotInitialised => c"the FbPlayState storage was not initialised",
            Self::NoStages => c"the rig has no capture stages (bake it with a capture)",
            Self::IndexOutOfRange => c"the marker index is out of range",
            Self::NotFinite => c"a coordinate is NaN or infinite",
            Self::OutOfRange => c"a position is outside the rig's range (128 half extents)",
            Self::Truncated => c"the blob is truncated",
            Self::TrailingBytes => c"the blob has trailing bytes after its payload",
            Self::BadMagic => c"the blob is not a facebake rig or take (bad magic)",
            Self::UnsupportedVersion => c"the blob's format version is not supported",
            Self::ChecksumMismatch => c"the blob's checksum does not match its payload",
            Self::Malformed => c"the blob's payload is malformed",
            Self::InvalidRig => c"the rig fails validation",
            Self::InvalidStages => c"the rig's capture stages fail validation",
            Self::NotFound => c"no marker has that name",
            Self::Internal => c"internal error in facebake-ffi (please report it)",
            Self::VertexCount => c"the vertex count given is not the rig's vertex count",
            Self::InvalidTake => c"the packed take fails validation or its stream is corrupt",
            Self::TakeNotLoaded => c"the FbTake storage does not hold a loaded take",
            Self::EndOfTake => c"the take has no more frames",
            Self::TableMismatch => c"the frame table was not filled by fb_prepare on this rig",
            Self::PlanMismatch => c"the normals plan names a vertex the rig does not have",
        }
    }
}

/// The message for a status code: a static, NUL-terminated ASCII string that the caller must
/// not free. Takes a plain integer so that any value is safe to pass; an unknown code gives
/// "unknown facebake error code".
#[no_mangle]
pub extern "C" fn fb_error_message(code: i32) -> *const c_char {
    FbError::ALL
        .iter()
        .find(|e| **e as i32 == code)
        .map_or(c"unknown facebake error code", |e| e.message())
        .as_ptr()
}

impl From<LoadError> for FbError {
    fn from(e: LoadError) -> Self {
        match e {
            LoadError::Truncated { .. } => Self::Truncated,
            LoadError::TrailingBytes { .. } => Self::TrailingBytes,
            LoadError::BadMagic => Self::BadMagic,
            LoadError::UnsupportedVersion { .. } => Self::UnsupportedVersion,
            LoadError::ChecksumMismatch { .. } => Self::ChecksumMismatch,
            LoadError::BadReserved | LoadError::Malformed | LoadError::PayloadTrailingBytes => {
                Self::Malformed
            }
            LoadError::Stages(_) => Self::InvalidStages,
            _ => Self::InvalidRig,
        }
    }
}

impl From<FrameError> for FbError {
    fn from(e: FrameError) -> Self {
        match e {
            FrameError::MarkerCount { .. } => Self::MarkerCount,
            FrameError::NoStages => Self::NoStages,
            FrameError::OutputLength { .. } | FrameError::ScratchLength { .. } => {
                Self::BufferTooSmall
            }
            FrameError::PositionCount { .. } | FrameError::VertexRange { .. } => Self::VertexCount,
            FrameError::TableMismatch => Self::TableMismatch,
            FrameError::PlanMismatch => Self::PlanMismatch,
        }
    }
}

impl From<ConvertError> for FbError {
    fn from(e: ConvertError) -> Self {
        match e {
            ConvertError::NotFinite => Self::NotFinite,
            ConvertError::OutOfRange => Self::OutOfRange,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn codes_are_dense_and_messages_distinct() {
        for (i, e) in FbError::ALL.iter().enumerate() {
            assert_eq!(*e as i32, i as i32);
            let m = e.message().to_bytes();
            assert!(m.is_ascii() && !m.is_empty());
            assert!(FbError::ALL[..i].iter().all(|o| o.message() != e.message()));
        }
    }
}
