//! # facebake-runtime
//!
//! Plays a facebake rig: loads a rig blob from a byte slice (zero-copy, validated once) and, per
//! frame, turns marker positions into deformed vertex positions with integer arithmetic only.
//!
//! * `#![no_std]`, no `alloc`, no recursion; one `unsafe` call, the x86-64 linear deformer's
//!   entry into its SSE2 code (SSE2 is in the x86-64 baseline; a test holds it equal to the
//!   portable code, bit for bit).
//! * Per-frame cost is fixed by the rig ([`Rig::cost`]): linear in vertices × K + markers, with no
//!   branch on marker data (planar bones: bounded, with one branch per control triangle, which
//!   builds its rest frame too when the markers make it degenerate). [`Rig::normals`], the
//!   deformed mesh's unit normals, costs what `Cost::normals` says: bounded, with a cheaper loop
//!   when every position lies within ±2 rig units.
//! * Output is bit-identical on every platform: the per-frame path is pure integer arithmetic
//!   with documented fixed-point formats (`fixed.rs`).
//!
//! ```no_run
//! # fn demo(blob: &[u8], markers: &[[i32; 3]], out: &mut [[i32; 3]]) -> Result<(), ()> {
//! let rig = facebake_runtime::Rig::from_bytes(blob).map_err(|_| ())?;
//! rig.deform(markers, out).map_err(|_| ())?;
//! # Ok(()) }
//! ```
//!
//! # Layout
//!
//! | module | what |
//! |---|---|
//! | `rig` | [`Rig`]: loading, [`Rig::deform`], [`Rig::play`], [`Rig::normals`], [`Rig::normals_planned`] |
//! | `deformer/` | one module per deformer (`linear`, `rbf`, `planar`), each owning its section, validation, cost and per-frame code; `mod.rs` dispatches |
//! | `normals` | the normals section, the per-frame unit normals of the deformed mesh, [`NormalsPlan`] |
//! | `stages/` | the capture stages before the deformer: `compensate`, `fill`, `smoothing`, `retarget`, `report` |
//! | `format/` | the blob: `header` and `RigData` (the docs of every section) |
//! | `records`, `error` | every record size, named once; [`LoadError`] and the other load errors |
//! | `cost`, `space` | [`Cost`]; [`Space`] and unit conversions |
//! | `take/` | packed takes: [`Take`] (the format, loading) and [`TakeReader`] (decoding, seeking) |
//! | `fixed`, `sqrt`, `checksum` | fixed-point primitives, integer square roots, CRC-32 and FNV-1a |
//!
//! No module imports one that imports it back: `cost`, `fixed` and `sqrt` import nothing from the
//! crate; `records` imports only `fixed`, `error` only `fixed` and `records`; the
//! deformers and the stages build on those; `format` (the payload) imports the deformers and the
//! stages; `rig` sits on top; `take` (packed takes) uses `format`'s header, `records` and
//! `space`, and nothing imports it. `.ci/module-cycles.sh` checks the graph in CI.
//!
//! # Features
//!
//! * `format`: makes the format internals public, for the baker that writes blobs, the tests
//!   and the firmware harness: the modules `format` (sections, records, header writer),
//!   `deformer`, `normals` and `stages` (section types), `fixed` and `checksum`, and `Rig::data`,
//!   `Rig::deformer`, `Rig::stages`, `Rig::weight_frac_bits`. A player needs none of it.
#![no_std]
#![deny(unsafe_code)]
#![warn(missing_docs)]

/// Declares modules that are public with the `format` feature and private without it.
macro_rules! format_internals {
    ($($(#[$attr:meta])* mod $name:ident;)*) => {$(
        $(#[$attr])*
        #[cfg(feature = "format")]
        pub mod $name;
        $(#[$attr])*
        #[cfg(not(feature = "format"))]
        mod $name;
    )*};
}

format_internals! {
    mod checksum;
    mod deformer;
    mod error;
    mod fixed;
    mod format;
    mod normals;
    mod records;
    mod stages;
}
mod cost;
mod rig;
mod space;
mod sqrt;
pub mod take;

pub use cost::{Cost, NormalsCost};
pub use deformer::{DegenerateTriangles, FrameTable};
pub use error::{LoadError, Section, StagesLoadError, StagesSection};
pub use normals::NormalsPlan;
/// The most markers a rig can have (the loader rejects more): a bound for callers that keep
/// per-marker buffers of a fixed size, such as the C ABI's marker sets.
pub use records::MAX_MARKERS;
pub use rig::{FrameError, Rig};
pub use space::{ConvertError, Space};
pub use stages::compensate::{FitFailure, RigidFit};
pub use stages::report::{FrameReport, MarkerSet, RigidStatus};
pub use stages::PlayState;
pub use take::{Take, TakeFrameError, TakeLoadError, TakeReader};
