//! Byte records: the size of every fixed-size item a section is made of, named once, the limits
//! the records imply, and the readers of the records more than one module reads.
//!
//! This module depends on nothing else in the crate but [`crate::fixed`] (itself a leaf): every
//! other module may use it. Nowhere else does a record size appear as a literal.

use serde::de::{Deserializer, Visitor};
use serde::{Deserialize, Serialize, Serializer};

use crate::fixed::{unpack_influence, widen_rest};

/// A borrowed byte string inside the payload (postcard `bytes`: varint length + raw bytes).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct Bytes<'a>(pub &'a [u8]);

impl Serialize for Bytes<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_bytes(self.0)
    }
}

impl<'de: 'a, 'a> Deserialize<'de> for Bytes<'a> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Borrowed;
        impl<'de> Visitor<'de> for Borrowed {
            type Value = Bytes<'de>;
            fn expecting(&self, f: &mut core::fmt::Formatter) -> core::fmt::Result {
                f.write_str("a borrowed byte string")
            }
            fn visit_borrowed_bytes<E: serde::de::Error>(
                self,
                v: &'de [u8],
            ) -> Result<Self::Value, E> {
                Ok(Bytes(v))
            }
        }
        d.deserialize_bytes(Borrowed)
    }
}

/// The first eight bytes of every rig blob.
pub const MAGIC: [u8; 8] = *b"FACEBAKE";
/// The format version this crate writes (and the newest it reads).
pub const VERSION: u16 = 12;
/// The oldest format version this crate reads: version 12 added the capture stages' head refit
/// over the face (`Stages::refit_cutoff`, after the stages' last field), so older blobs must be
/// baked again. (Version 10 gave the linear deformer's derived markers a direction, version 11
/// the derived mean.)
pub const OLDEST_VERSION: u16 = 12;
/// Bytes of the fixed header that precedes the payload (see [`crate::format::header`]).
pub const HEADER_LEN: usize = 20;

/// Most markers a rig may have (a marker index is one byte).
pub const MAX_MARKERS: usize = 256;
/// Most control triangles a planar rig may have: bounds the per-frame frame scratch on the
/// stack (see [`crate::Cost::scratch_bytes`]).
pub const MAX_TRIANGLES: usize = 256;

/// The sections a frame reads most (`vertex_rest`, the linear deformer's `pairs`) start at a
/// multiple of this many bytes from the blob's first byte, each after an alignment section of
/// fewer zero bytes: a blob placed at an aligned address (what an allocator or a linker gives)
/// reads them with aligned loads, which a Cortex-M4 does in one bus access and an unaligned one
/// in two.
pub const SECTION_ALIGN: usize = 4;

/// Bytes of one stored vertex rest position: 3 × `i16` LE, Q0.15.
pub const REST_BYTES: usize = 6;
/// Bytes of one stored position (marker rest, actor neutral, proportional rest): 3 × `i32` LE,
/// Q8.24.
pub const POSITION_BYTES: usize = 12;
/// Bytes of one packed influence word (`u32` LE: bits 0–7 an index, bits 8–31 a signed 24-bit
/// weight); fill neighbours use the same word.
pub const INFLUENCE_BYTES: usize = 4;
/// Bytes of one influence pair of the linear deformer: its two weights (2 × `i16` LE) and its
/// marker pair's index (`u16` LE), stored as all of a vertex's weight pairs, then all of its
/// indices.
pub const INFLUENCE_PAIR_BYTES: usize = 6;
/// Bytes of one marker pair of the linear deformer: 2 × `u8` marker indices.
pub const MARKER_PAIR_BYTES: usize = 2;
/// Bytes of a linear rig's derived marker: a projection's source marker (`u8`), a zero byte and
/// its direction (3 × `i16` LE, Q1.14), or a mean's first source, its count and its other
/// sources (`crate::deformer::linear`).
pub const DERIVED_MARKER_BYTES: usize = 8;
/// Most marker pairs a linear rig may have: bounds its per-frame pair table (16 bytes a pair,
/// see [`crate::Cost::scratch_bytes`]).
pub const MAX_MARKER_PAIRS: usize = 512;
/// Bytes of one per-vertex influence count (`u8`).
pub const COUNT_BYTES: usize = 1;
/// Bytes of one RBF coefficient row's scale exponent (`u8`).
pub const ROW_SHIFT_BYTES: usize = 1;
/// Bytes of one RBF coefficient matrix entry (`i16` LE).
pub const MATRIX_ENTRY_BYTES: usize = 2;
/// Bytes of one control triangle: 3 × `u8` marker indices.
pub const TRIANGLE_BYTES: usize = 3;
/// Bytes of one planar influence record: `u16` triangle and region, `u16` weight, 4 × `i32`
/// local coordinates.
pub const PLANAR_INFLUENCE_BYTES: usize = 20;
/// Bytes of one retargeting radius (`i32` LE, Q8.24).
pub const RADIUS_BYTES: usize = 4;
/// Bytes of one retargeting coefficient α̃ (3 × `i32` LE): the layout of a position.
pub const ALPHA_BYTES: usize = POSITION_BYTES;
/// Bytes of one proportional retargeting matrix: 9 × `i32` LE, row-major.
pub const MATRIX3_BYTES: usize = 36;
/// Bytes of one stored unit normal: 3 × `i16` LE, Q1.14 ([`crate::fixed::NORMAL_FRAC_BITS`]).
pub const NORMAL_BYTES: usize = 6;
/// Widths a vertex index of the normals section may have, in bytes: `u16` when the rig has at
/// most 2¹⁶ vertices, else `u32`.
pub const VERTEX_INDEX_BYTES: [u8; 2] = [2, 4];
/// Neighbours stored per marker for rebuilding it.
pub const FILL_NEIGHBOURS: usize = 4;
/// Bytes of one marker's fill neighbours: [`FILL_NEIGHBOURS`] influence words.
pub const FILL_BYTES: usize = FILL_NEIGHBOURS * INFLUENCE_BYTES;

/// Decode one `vertex_rest` item (3 × `i16` LE, Q0.15) as Q8.24. Takes a [`REST_BYTES`]-long
/// chunk of the section (from `chunks_exact`).
#[inline(always)]
pub fn read_rest(b: &[u8]) -> [i32; 3] {
    // Always six bytes: the fallback folds away, and the read is one load.
    let b: [u8; REST_BYTES] = b.try_into().unwrap_or([0; REST_BYTES]);
    [0, 1, 2].map(|c| widen_rest(i16::from_le_bytes([b[2 * c], b[2 * c + 1]])))
}

/// Decode one position (3 × `i32` LE, Q8.24) from a [`POSITION_BYTES`]-long chunk.
#[inline(always)]
pub fn read_position(b: &[u8]) -> [i32; 3] {
    let b: [u8; POSITION_BYTES] = b.try_into().unwrap_or([0; POSITION_BYTES]);
    [0, 1, 2].map(|c| i32::from_le_bytes([b[4 * c], b[4 * c + 1], b[4 * c + 2], b[4 * c + 3]]))
}

/// Decode one packed influence (marker or centre index, signed 24-bit weight) from an
/// [`INFLUENCE_BYTES`]-long chunk.
#[inline(always)]
pub fn read_influence(b: &[u8]) -> (u8, i32) {
    let b: [u8; INFLUENCE_BYTES] = b.try_into().unwrap_or([0; INFLUENCE_BYTES]);
    unpack_influence(u32::from_le_bytes(b))
}

/// Decode one `i32` LE from a four-byte chunk (a radius, or an entry of a 3 × 3 matrix).
#[inline(always)]
pub fn read_i32(b: &[u8]) -> i32 {
    i32::from_le_bytes(b.try_into().unwrap_or([0; 4]))
}

/// Decode one RBF matrix entry (`i16` LE) from a [`MATRIX_ENTRY_BYTES`]-long chunk.
#[inline(always)]
pub fn read_matrix_entry(b: &[u8]) -> i16 {
    i16::from_le_bytes(b.try_into().unwrap_or([0; MATRIX_ENTRY_BYTES]))
}

/// The names of a section of length-prefixed names (`u8` length, then UTF-8 bytes), in order:
/// the rig's marker names and a packed take's. Stops at the first that does not fit or is not
/// UTF-8 (loading rejects both).
pub fn read_names<'a>(bytes: &'a [u8]) -> impl Iterator<Item = &'a str> + 'a {
    let mut rest = bytes;
    core::iter::from_fn(move || {
        let (&len, tail) = rest.split_first()?;
        let (name, tail) = tail.split_at_checked(usize::from(len))?;
        rest = tail;
        core::str::from_utf8(name).ok()
    })
}
