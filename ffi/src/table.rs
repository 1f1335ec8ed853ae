//! Splitting one frame of a face over workers: `fb_prepare` does the frame's marker work once
//! into an `FbFrameTable`, and every worker's `fb_deform_chunk` reads it.

use core::mem::{align_of, size_of};

use facebake_runtime::FrameTable;

use crate::error::FbError;
use crate::memory::{guard, positions, positions_out, store, stored, stored_mut, Storage, Tagged};
use crate::rig::{loaded, FbRig};

/// One frame's marker work (the runtime's `FrameTable`), in storage the caller provides
/// (`fb_frame_table_size()` bytes aligned to `fb_frame_table_align()`, about 25 KB). Opaque;
/// nothing to free but the storage. Fill it with `fb_prepare` on one thread, then let any
/// number of threads read it through `fb_deform_chunk` until the next `fb_prepare`.
pub struct FbFrameTable(Tagged<FrameTable>);

impl Storage for FbFrameTable {
    type Value = FrameTable;
    const TAG: u64 = u64::from_le_bytes(*b"fbTable");
    const MISSING: FbError = FbError::TableMismatch;

    unsafe fn tagged(storage: *mut Self) -> *mut Tagged<Self::Value> {
        // SAFETY: `storage` is valid (the trait's contract), so the field is in bounds.
        unsafe { core::ptr::addr_of_mut!((*storage).0) }
    }
}

/// Bytes of storage an `FbFrameTable` needs.
#[no_mangle]
pub extern "C" fn fb_frame_table_size() -> usize {
    size_of::<FbFrameTable>()
}

/// Alignment the storage of an `FbFrameTable` needs.
#[no_mangle]
pub extern "C" fn fb_frame_table_align() -> usize {
    align_of::<FbFrameTable>()
}

/// Do one frame's marker work for `rig` into `table`'s storage (`table_len` bytes, at least
/// `fb_frame_table_size()`, aligned to `fb_frame_table_align()`): `markers` as `fb_deform`
/// takes them. Then `fb_deform_chunk` deforms any range of the vertices from it, on any thread.
/// On error the table holds no frame (`fb_deform_chunk` refuses it).
///
/// # Safety
/// `rig` as `fb_rig_vertex_count`; `markers` as in `fb_deform`; `table` null or valid for
/// writes of `table_len` bytes and used by no one else during the call.
#[no_mangle]
pub unsafe extern "C" fn fb_prepare(
    rig: *const FbRig,
    markers: *const i32,
    marker_count: usize,
    table: *mut FbFrameTable,
    table_len: usize,
) -> FbError {
    guard(|| {
        // SAFETY: the caller's contract.
        let rig = unsafe { loaded(rig)? };
        // SAFETY: the caller's contract.
        let markers = unsafe { positions(markers, marker_count, rig.marker_count())? };
        // SAFETY: the caller's contract.
        unsafe { store(table, table_len, || Ok(FrameTable::new()))? };
        // SAFETY: just stored; exclusive by the caller's contract.
        let table = unsafe { stored_mut(table)? };
        rig.prepare(markers, table)?;
        Ok(())
    })
}

/// Deform the vertices `first_vertex .. first_vertex + vertex_count` of the frame `table`
/// holds (filled by `fb_prepare` on this `rig`) into `out` (room for exactly `vertex_count`
/// positions, Q8.24): the same integers `fb_deform` writes there. Workers may call it at once
/// on one table, each on its own chunk. A table another rig filled, or none, is
/// `FB_ERROR_TABLE_MISMATCH`; a range past the last vertex `FB_ERROR_VERTEX_COUNT`; nothing is
/// written on error.
///
/// # Safety
/// `rig` as `fb_rig_vertex_count`; `table` null or valid for reads of `fb_frame_table_size()`
/// bytes and not written during the call; `out` null or valid for writes of `3 * vertex_count`
/// values.
#[no_mangle]
pub unsafe extern "C" fn fb_deform_chunk(
    rig: *const FbRig,
    table: *const FbFrameTable,
    first_vertex: usize,
    out: *mut i32,
    vertex_count: usize,
) -> FbError {
    guard(|| {
        // SAFETY: the caller's contract.
        let rig = unsafe { loaded(rig)? };
        // SAFETY: the caller's contract.
        let table = unsafe { stored(table)? };
        // SAFETY: the caller's contract.
        let out = unsafe { positions_out(out, vertex_count, vertex_count)? };
        Ok(rig.deform_chunk(table, first_vertex, out)?)
    })
}
