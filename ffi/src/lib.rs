//! # facebake-ffi
//!
//! The C ABI of the facebake runtime, for game engines (Unity native plugins, Unreal modules,
//! any C or C++ host) and firmware. The header `include/facebake.h` is generated from this
//! crate by cbindgen (`tests/header.rs` fails when it is stale); `README.md` shows how to call
//! it.
//!
//! # Memory: nothing allocates behind the caller's back
//!
//! The caller provides every byte: the rig blob (borrowed, never copied: it must outlive the
//! rig), the storage of a loaded rig (`fb_rig_size`, `fb_rig_align`), the storage of each play
//! state (`fb_play_state_size`, `fb_play_state_align`), of each packed take being read
//! (`fb_take_size`, `fb_take_align`), and every output buffer and scratch (sized by
//! `fb_rig_vertex_count`, `fb_rig_marker_count` and `fb_normals_plan_len`). The library keeps
//! no global state.
//!
//! # Checks
//!
//! Every pointer is checked for null and alignment, every stated length against what the rig
//! needs, and a rig or play state storage for the tag its initialiser wrote, before anything is
//! written; every failure is an [`FbError`] code with a static message
//! ([`fb_error_message`]). What cannot be checked is the caller's side of the contract: that a
//! pointer really addresses as many bytes as its length says.
//!
//! # Panics
//!
//! None are expected: the runtime never panics and this crate indexes nothing unchecked (every
//! slice it cuts is bounded by the rig's marker count, at most `FB_MAX_MARKERS`). With the
//! default `std` feature every function that does work still runs inside `catch_unwind`, so a
//! bug would return `FB_ERROR_INTERNAL` instead of unwinding into C.
//!
//! # Firmware
//!
//! Without the `std` feature the crate is `#![no_std]` and allocation-free, for firmware written
//! in C: `cargo build -p facebake-ffi --release --no-default-features --target
//! thumbv7em-none-eabihf` builds `libfacebake_ffi.a` for a Cortex-M4F, with a panic handler that
//! halts (it cannot be reached by construction). `.ci/ffi.sh` builds it. The same build for
//! `wasm32-unknown-unknown` is the runtime in a browser (`web/`, `.ci/browser.sh`): a module
//! with no imports whose caller reserves every buffer in its linear memory above `__heap_base`.
//!
//! # Threads
//!
//! A loaded `FbRig` is immutable: any number of threads may call `fb_deform`, `fb_normals`,
//! `fb_play` and the queries on one rig at once. A `FbPlayState` belongs to one character (one stream of frames)
//! and must not be used by two threads at once; give every character its own. Functions that
//! fill a storage (`fb_rig_load`, `fb_play_state_init`) need it to themselves.

#![cfg_attr(not(feature = "std"), no_std)]
#![warn(missing_docs)]
#![deny(unsafe_op_in_unsafe_fn)]

pub mod error;
mod memory;
pub mod play;
pub mod rig;
pub mod table;
pub mod take;

pub use error::{fb_error_message, FbError};
pub use play::{
    fb_play, fb_play_f32, fb_play_state_align, fb_play_state_init, fb_play_state_size,
    FbFrameReport, FbPlayState, FbRigidStatus,
};
pub use rig::{
    fb_cost, fb_deform, fb_deform_f32, fb_deform_range, fb_marker_index, fb_marker_name,
    fb_marker_name_copy, fb_marker_rest, fb_marker_rest_f32, fb_normals, fb_normals_plan_len,
    fb_normals_planned, fb_plan_normals, fb_rig_actor_space, fb_rig_align, fb_rig_has_stages,
    fb_rig_load, fb_rig_marker_count, fb_rig_size, fb_rig_space, fb_rig_validate,
    fb_rig_vertex_count, fb_vertex_rest, fb_vertex_rest_f32, FbCost, FbNormalsCost, FbRig, FbSpace,
};
pub use table::{
    fb_deform_chunk, fb_frame_table_align, fb_frame_table_size, fb_prepare, FbFrameTable,
};
pub use take::{
    fb_take_align, fb_take_frame_count, fb_take_load, fb_take_marker_count, fb_take_marker_name,
    fb_take_next_frame, fb_take_position, fb_take_rate, fb_take_seek, fb_take_size, fb_take_space,
    FbTake,
};

/// The version of this ABI, which `fb_abi_version` returns: a host built against one header
/// can check that the library it loaded matches (bumped on any incompatible change).
///
/// Version 2: `FbCost` gained `normals` (`FbNormalsCost`), and `fb_normals` and
/// `FB_ERROR_VERTEX_COUNT` were added. Version 3: packed takes (`FbTake`, the `fb_take_`
/// functions, `FB_ERROR_INVALID_TAKE`, `FB_ERROR_TAKE_NOT_LOADED`, `FB_ERROR_END_OF_TAKE`). Version 4:
/// splitting a frame over workers (`FbFrameTable`, `fb_prepare`, `fb_deform_chunk`,
/// `FB_ERROR_TABLE_MISMATCH`). Version 5: planned normals (`fb_normals_plan_len`,
/// `fb_plan_normals`, `fb_normals_planned`, `FB_ERROR_PLAN_MISMATCH`).
pub const FB_ABI_VERSION: u32 = 5;

/// The most markers a rig can have.
pub const FB_MAX_MARKERS: usize = 256;

/// Words of a marker bitset in `FbFrameReport` (`FB_MAX_MARKERS` / 32).
pub const FB_MARKER_WORDS: usize = 8;

const _: () = assert!(FB_MAX_MARKERS == facebake_runtime::MAX_MARKERS);
const _: () = assert!(FB_MARKER_WORDS * 32 == FB_MAX_MARKERS);

/// Without `std` (firmware, WebAssembly), a panic halts the core, or traps in a WebAssembly
/// engine (the JavaScript call throws a `RuntimeError` instead of hanging the page): none can
/// happen by construction (see "Panics" above), and none may unwind into C. Rust firmware uses
/// the runtime crate directly rather than this one.
#[cfg(all(not(feature = "std"), not(test)))]
#[panic_handler]
fn halt(_: &core::panic::PanicInfo) -> ! {
    #[cfg(target_arch = "wasm32")]
    core::arch::wasm32::unreachable();
    #[cfg(not(target_arch = "wasm32"))]
    loop {
        core::hint::spin_loop();
    }
}

/// `FB_ABI_VERSION` of the library actually linked or loaded.
#[no_mangle]
pub extern "C" fn fb_abi_version() -> u32 {
    FB_ABI_VERSION
}
