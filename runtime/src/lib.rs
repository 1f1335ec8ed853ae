//! # facebake-runtime
//!
//! Plays a facebake rig: loads a rig blob from a byte slice (zero-copy, validated once) and, per
//! frame, turns marker positions into deformed vertex positions with integer arithmetic only.
//!
//! * `#![no_std]`, no `alloc`, no recursion; one `unsafe` call, the x86-64 linear kernel's entry
//!   into its SSE2 code (SSE2 is in the x86-64 baseline; a test holds it equal to the portable
//!   code, bit for bit).
//! * Per-frame cost is fixed by the rig ([`Rig::cost`]): linear in vertices × K + markers, with no
//!   branch on marker data (planar bones: bounded, with one branch per control triangle, which
//!   builds its rest frame too when the markers make it degenerate).
//! * Output is bit-identical on every platform: the per-frame path is pure integer arithmetic
//!   with documented fixed-point formats ([`fixed`]).
//!
//! ```no_run
//! # fn demo(blob: &[u8], markers: &[[i32; 3]], out: &mut [[i32; 3]]) -> Result<(), ()> {
//! let rig = facebake_runtime::Rig::from_bytes(blob).map_err(|_| ())?;
//! rig.deform(markers, out).map_err(|_| ())?;
//! # Ok(()) }
//! ```
#![no_std]
#![deny(unsafe_code)]
#![warn(missing_docs)]

pub mod checksum;
pub mod fixed;
pub mod format;
mod kernel;
pub mod pipeline;
pub mod rig;
pub mod space;
pub mod sqrt;

pub use format::{LoadError, Space};
pub use kernel::planar::DegenerateTriangles;
pub use pipeline::{FrameReport, PlayState};
pub use rig::{Cost, FrameError, Rig};
pub use space::ConvertError;
