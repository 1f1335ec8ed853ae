//! The fixed header before the payload: magic, format version, payload length and CRC-32.
//!
//! ```text
//! offset  size  field
//!      0     8  magic  b"FACEBAKE"                 (MAGIC)
//!      8     2  format version, u16 LE            (OLDEST_VERSION..=VERSION)
//!     10     2  reserved, u16 LE, must be 0
//!     12     4  payload length in bytes, u32 LE
//!     16     4  CRC-32 (IEEE) of the payload, u32 LE
//!     20     …  payload                           (HEADER_LEN = 20)
//! ```
//!
//! A packed take (`crate::take`) is sealed the same way under its own magic and version:
//! [`open_sealed`] and [`sealed_header`] take those as arguments.

use crate::checksum::crc32;
use crate::error::LoadError;
use crate::records::{HEADER_LEN, MAGIC, OLDEST_VERSION, VERSION};
use core::ops::RangeInclusive;

// Where each header field starts.
const VERSION_AT: usize = MAGIC.len();
const RESERVED_AT: usize = VERSION_AT + 2;
const LENGTH_AT: usize = RESERVED_AT + 2;
const CRC_AT: usize = LENGTH_AT + 4;
const _: () = assert!(CRC_AT + 4 == HEADER_LEN);

/// The header for `payload`: magic, [`VERSION`], length and CRC. The blob is the header followed
/// by the payload.
#[cfg(feature = "format")]
pub fn header_for(payload: &[u8]) -> Result<[u8; HEADER_LEN], PayloadTooLarge> {
    sealed_header(&MAGIC, VERSION, payload)
}

/// The header for `payload` under another file's `magic` and `version` (a packed take's).
#[cfg(feature = "format")]
pub fn sealed_header(
    magic: &[u8; 8],
    version: u16,
    payload: &[u8],
) -> Result<[u8; HEADER_LEN], PayloadTooLarge> {
    let len = u32::try_from(payload.len()).map_err(|_| PayloadTooLarge)?;
    let mut h = [0u8; HEADER_LEN];
    h[..VERSION_AT].copy_from_slice(magic);
    h[VERSION_AT..RESERVED_AT].copy_from_slice(&version.to_le_bytes());
    h[LENGTH_AT..CRC_AT].copy_from_slice(&len.to_le_bytes());
    h[CRC_AT..].copy_from_slice(&crc32(payload).to_le_bytes());
    Ok(h)
}

/// A payload of 4 GiB or more cannot be described by the header.
#[cfg(feature = "format")]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PayloadTooLarge;

fn le_u16(b: &[u8], at: usize) -> u16 {
    u16::from_le_bytes([b[at], b[at + 1]])
}

fn le_u32(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes([b[at], b[at + 1], b[at + 2], b[at + 3]])
}

/// Check the header and checksum of a blob and return its payload.
pub fn open(bytes: &[u8]) -> Result<&[u8], LoadError> {
    open_sealed(bytes, &MAGIC, OLDEST_VERSION..=VERSION)
}

/// [`open`] for another file sealed the same way under `magic` and one of `versions` (a packed
/// take): the errors are the header variants of [`LoadError`].
pub fn open_sealed<'b>(
    bytes: &'b [u8],
    magic: &[u8; 8],
    versions: RangeInclusive<u16>,
) -> Result<&'b [u8], LoadError> {
    if bytes.len() < HEADER_LEN {
        return Err(LoadError::Truncated {
            expected: HEADER_LEN,
            found: bytes.len(),
        });
    }
    if bytes[..VERSION_AT] != magic[..] {
        return Err(LoadError::BadMagic);
    }
    let found = le_u16(bytes, VERSION_AT);
    if !versions.contains(&found) {
        return Err(LoadError::UnsupportedVersion { found });
    }
    if le_u16(bytes, RESERVED_AT) != 0 {
        return Err(LoadError::BadReserved);
    }
    let len = le_u32(bytes, LENGTH_AT) as usize;
    let rest = &bytes[HEADER_LEN..];
    if rest.len() < len {
        return Err(LoadError::Truncated {
            expected: HEADER_LEN.saturating_add(len),
            found: bytes.len(),
        });
    }
    if rest.len() > len {
        return Err(LoadError::TrailingBytes {
            extra: rest.len() - len,
        });
    }
    let stored = le_u32(bytes, CRC_AT);
    let computed = crc32(rest);
    if stored != computed {
        return Err(LoadError::ChecksumMismatch { stored, computed });
    }
    Ok(rest)
}
