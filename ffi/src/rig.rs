//! Loading a rig into caller storage, what a loaded rig tells, and `fb_deform`.

use core::ffi::c_char;
use core::mem::{align_of, size_of};

use facebake_runtime::{Cost, NormalsCost, Rig, Space};

use crate::error::FbError;
use crate::memory::{
    guard, positions, positions_out, slice, slice_mut, store, stored, write, Storage, Tagged,
};

/// A loaded rig, in storage the caller provides (`fb_rig_size()` bytes aligned to
/// `fb_rig_align()`). Opaque. It borrows the blob given to `fb_rig_load`, which must stay alive
/// and unchanged while the rig is used; it owns nothing else, so there is nothing to free but
/// the storage (and it may be copied byte for byte). Immutable once loaded: share it read-only
/// across threads.
pub struct FbRig(Tagged<Rig<'static>>);

impl Storage for FbRig {
    type Value = Rig<'static>;
    const TAG: u64 = u64::from_le_bytes(*b"fbRig\0\0\x01");
    const MISSING: FbError = FbError::NotLoaded;

    unsafe fn tagged(storage: *mut Self) -> *mut Tagged<Self::Value> {
        // SAFETY: `storage` is valid (the trait's contract), so the field is in bounds.
        unsafe { core::ptr::addr_of_mut!((*storage).0) }
    }
}

/// Where rig (or actor) units sit in an asset's space: `units = (asset - centre) / half_extent`,
/// in Q8.24 (1.0 = 1 << 24).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FbSpace {
    /// Centre of the mesh (or capture) bounds, asset units.
    pub centre: [f32; 3],
    /// Asset units per rig (or actor) unit.
    pub half_extent: f32,
}

impl From<Space> for FbSpace {
    fn from(s: Space) -> Self {
        Self {
            centre: s.centre,
            half_extent: s.half_extent,
        }
    }
}

/// The per-frame work of `fb_deform`, fixed by the rig (see the runtime's `Cost`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FbCost {
    /// Vertices written.
    pub vertices: u64,
    /// Markers read.
    pub markers: u64,
    /// Influences evaluated.
    pub influences: u64,
    /// The rig's K: no vertex has more influences.
    pub max_influences: u64,
    /// Coefficient rows computed per frame (RBF rigs).
    pub coefficient_rows: u64,
    /// Multiply-adds (`facebake_runtime::Cost::multiply_adds`).
    pub multiply_adds: u64,
    /// Saturating subtractions forming marker displacements.
    pub subtractions: u64,
    /// Round-shift-saturate narrowings to 32 bits.
    pub narrowings: u64,
    /// Stack scratch of one call, bytes.
    pub scratch_bytes: u64,
    /// Control-triangle frames built (planar rigs).
    pub frame_builds: u64,
    /// Vector normalisations (planar rigs).
    pub normalisations: u64,
    /// The work of `fb_normals` (not counted above).
    pub normals: FbNormalsCost,
}

/// The per-frame work of `fb_normals`, fixed by the rig (see the runtime's `NormalsCost`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FbNormalsCost {
    /// Normals written (one per vertex).
    pub vertices: u64,
    /// Fan corners evaluated (an edge each, and but for a fan's first a cross product).
    pub corners: u64,
    /// Widening multiplies.
    pub multiplies: u64,
    /// Normalisations through the integer 1/√.
    pub normalisations: u64,
    /// Normals copied to vertices split along a seam.
    pub welds: u64,
}

impl From<NormalsCost> for FbNormalsCost {
    fn from(c: NormalsCost) -> Self {
        let n = |x: usize| x as u64;
        Self {
            vertices: n(c.vertices),
            corners: n(c.corners),
            multiplies: n(c.multiplies),
            normalisations: n(c.normalisations),
            welds: n(c.welds),
        }
    }
}

impl From<Cost> for FbCost {
    fn from(c: Cost) -> Self {
        let n = |x: usize| x as u64;
        Self {
            vertices: n(c.vertices),
            markers: n(c.markers),
            influences: n(c.influences),
            max_influences: n(c.max_influences),
            coefficient_rows: n(c.coefficient_rows),
            multiply_adds: n(c.multiply_adds),
            subtractions: n(c.subtractions),
            narrowings: n(c.narrowings),
            scratch_bytes: n(c.scratch_bytes),
            frame_builds: n(c.frame_builds),
            normalisations: n(c.normalisations),
            normals: c.normals.into(),
        }
    }
}

/// The loaded rig at `rig`.
///
/// # Safety
/// `rig` is null, misaligned, or valid for reads of `fb_rig_size()` bytes.
pub(crate) unsafe fn loaded<'a>(rig: *const FbRig) -> Result<&'a Rig<'static>, FbError> {
    // SAFETY: the caller's contract.
    unsafe { stored(rig) }
}

/// Bytes of storage an `FbRig` needs.
#[no_mangle]
pub extern "C" fn fb_rig_size() -> usize {
    size_of::<FbRig>()
}

/// Alignment the storage of an `FbRig` needs.
#[no_mangle]
pub extern "C" fn fb_rig_align() -> usize {
    align_of::<FbRig>()
}

/// Validate the rig blob `blob[0..blob_len]` (header, checksum, every index and length; linear
/// in its length) and load it into `storage` (`storage_len` bytes, at least `fb_rig_size()`,
/// aligned to `fb_rig_align()`). The blob needs no alignment; it is borrowed, not copied, and
/// must outlive every use of the rig. On error the storage holds no rig (`FB_ERROR_NOT_LOADED`
/// if used).
///
/// # Safety
/// `blob` must be valid for reads of `blob_len` bytes and `storage` for writes of `storage_len`
/// bytes (or be null). Neither may be written by anyone else during the call; the blob not
/// while the rig is in use.
#[no_mangle]
pub unsafe extern "C" fn fb_rig_load(
    blob: *const u8,
    blob_len: usize,
    storage: *mut FbRig,
    storage_len: usize,
) -> FbError {
    guard(|| {
        // SAFETY: the caller's contract.
        let bytes: &'static [u8] = unsafe { slice(blob, blob_len)? };
        // SAFETY: the caller's contract.
        unsafe { store(storage, storage_len, || Ok(Rig::from_bytes(bytes)?)) }
    })
}

/// Validate a rig blob without loading it anywhere: `FB_ERROR_NONE` if `fb_rig_load` would
/// accept it, else the reason.
///
/// # Safety
/// `blob` must be valid for reads of `blob_len` bytes (or be null).
#[no_mangle]
pub unsafe extern "C" fn fb_rig_validate(blob: *const u8, blob_len: usize) -> FbError {
    guard(|| {
        // SAFETY: the caller's contract.
        let bytes = unsafe { slice(blob, blob_len)? };
        Rig::from_bytes(bytes)?;
        Ok(())
    })
}

/// Vertices the rig deforms; 0 if `rig` is not a loaded rig.
///
/// # Safety
/// `rig` is null or valid for reads of `fb_rig_size()` bytes.
#[no_mangle]
pub unsafe extern "C" fn fb_rig_vertex_count(rig: *const FbRig) -> usize {
    // SAFETY: the caller's contract.
    unsafe { loaded(rig) }.map_or(0, |r| r.vertex_count())
}

/// Markers the rig reads per frame (1 to `FB_MAX_MARKERS`); 0 if `rig` is not a loaded rig.
///
/// # Safety
/// As `fb_rig_vertex_count`.
#[no_mangle]
pub unsafe extern "C" fn fb_rig_marker_count(rig: *const FbRig) -> usize {
    // SAFETY: the caller's contract.
    unsafe { loaded(rig) }.map_or(0, |r| r.marker_count())
}

/// Whether the rig has capture stages (so `fb_play` works on it); false if `rig` is not a
/// loaded rig.
///
/// # Safety
/// As `fb_rig_vertex_count`.
#[no_mangle]
pub unsafe extern "C" fn fb_rig_has_stages(rig: *const FbRig) -> bool {
    // SAFETY: the caller's contract.
    unsafe { loaded(rig) }.is_ok_and(|r| r.actor_space().is_some())
}

/// Write where rig units sit in the character asset's space (the units of the `_f32` calls'
/// vertices and character markers) to `*space`.
///
/// # Safety
/// `rig` as `fb_rig_vertex_count`; `space` null or valid for a write.
#[no_mangle]
pub unsafe extern "C" fn fb_rig_space(rig: *const FbRig, space: *mut FbSpace) -> FbError {
    guard(|| {
        // SAFETY: the caller's contract.
        let rig = unsafe { loaded(rig)? };
        // SAFETY: the caller's contract.
        unsafe { write(space, rig.space().into()) }
    })
}

/// Write where actor units sit in the capture's space (the units of `fb_play_f32`'s actor
/// markers) to `*space`; `FB_ERROR_NO_STAGES` if the rig has no capture stages.
///
/// # Safety
/// As `fb_rig_space`.
#[no_mangle]
pub unsafe extern "C" fn fb_rig_actor_space(rig: *const FbRig, space: *mut FbSpace) -> FbError {
    guard(|| {
        // SAFETY: the caller's contract.
        let rig = unsafe { loaded(rig)? };
        let actor = rig.actor_space().ok_or(FbError::NoStages)?;
        // SAFETY: the caller's contract.
        unsafe { write(space, actor.into()) }
    })
}

/// Write the per-frame work of `fb_deform` to `*cost`.
///
/// # Safety
/// `rig` as `fb_rig_vertex_count`; `cost` null or valid for a write.
#[no_mangle]
pub unsafe extern "C" fn fb_cost(rig: *const FbRig, cost: *mut FbCost) -> FbError {
    guard(|| {
        // SAFETY: the caller's contract.
        let rig = unsafe { loaded(rig)? };
        // SAFETY: the caller's contract.
        unsafe { write(cost, rig.cost().into()) }
    })
}

/// The name of marker `index`, UTF-8 and not NUL-terminated.
fn marker_name(rig: &Rig<'static>, index: usize) -> Result<&'static str, FbError> {
    rig.marker_names()
        .nth(index)
        .ok_or(FbError::IndexOutOfRange)
}

/// Point `*name` at the UTF-8 name of marker `index` inside the blob (NOT NUL-terminated; valid
/// while the blob is) and write its length in bytes to `*name_len`.
///
/// # Safety
/// `rig` as `fb_rig_vertex_count`; `name` and `name_len` null or valid for a write.
#[no_mangle]
pub unsafe extern "C" fn fb_marker_name(
    rig: *const FbRig,
    index: usize,
    name: *mut *const c_char,
    name_len: *mut usize,
) -> FbError {
    guard(|| {
        // SAFETY: the caller's contract.
        let rig = unsafe { loaded(rig)? };
        let found = marker_name(rig, index)?;
        // SAFETY: the caller's contract.
        unsafe {
            crate::memory::check(name)?;
            write(name_len, found.len())?;
            write(name, found.as_ptr().cast::<c_char>())
        }
    })
}

/// Copy the UTF-8 name of marker `index`, NUL-terminated, into `buffer` (`capacity` bytes) and
/// write its length without the NUL to `*name_len`. If `capacity` is under that length + 1,
/// nothing is copied, `*name_len` still says the length, and the result is
/// `FB_ERROR_BUFFER_TOO_SMALL`. Names are at most 255 bytes.
///
/// # Safety
/// `rig` as `fb_rig_vertex_count`; `buffer` null or valid for writes of `capacity` bytes;
/// `name_len` null or valid for a write.
#[no_mangle]
pub unsafe extern "C" fn fb_marker_name_copy(
    rig: *const FbRig,
    index: usize,
    buffer: *mut c_char,
    capacity: usize,
    name_len: *mut usize,
) -> FbError {
    guard(|| {
        // SAFETY: the caller's contract.
        let rig = unsafe { loaded(rig)? };
        let found = marker_name(rig, index)?.as_bytes();
        // SAFETY: the caller's contract.
        unsafe {
            crate::memory::check(buffer)?;
            write(name_len, found.len())?;
        }
        if capacity <= found.len() {
            return Err(FbError::BufferTooSmall);
        }
        // SAFETY: the caller's contract; `found.len() + 1 <= capacity`.
        let out = unsafe { slice_mut(buffer.cast::<u8>(), found.len() + 1)? };
        out[..found.len()].copy_from_slice(found);
        out[found.len()] = 0;
        Ok(())
    })
}

/// Write the index of the marker named `name[0..name_len]` (UTF-8, no NUL needed) to `*index`;
/// `FB_ERROR_NOT_FOUND` if no marker has that name.
///
/// # Safety
/// `rig` as `fb_rig_vertex_count`; `name` null or valid for reads of `name_len` bytes; `index`
/// null or valid for a write.
#[no_mangle]
pub unsafe extern "C" fn fb_marker_index(
    rig: *const FbRig,
    name: *const c_char,
    name_len: usize,
    index: *mut usize,
) -> FbError {
    guard(|| {
        // SAFETY: the caller's contract.
        let rig = unsafe { loaded(rig)? };
        // SAFETY: the caller's contract.
        let name = unsafe { slice(name.cast::<u8>(), name_len)? };
        let found = rig
            .marker_names()
            .position(|n| n.as_bytes() == name)
            .ok_or(FbError::NotFound)?;
        // SAFETY: the caller's contract.
        unsafe { write(index, found) }
    })
}

/// Which rest positions to write.
#[derive(Clone, Copy)]
enum Rest {
    Vertices,
    Markers,
}

/// The body of the `fb_*_rest*` functions: fill `out` (room for `capacity` positions) with the
/// rig's rest positions of `which`, in Q8.24 rig units or, with `asset_units`, in the character
/// asset's units (`f32` bits).
///
/// # Safety
/// As `fb_vertex_rest`, with `out` holding 4-byte values.
unsafe fn write_rest(
    rig: *const FbRig,
    out: *mut i32,
    capacity: usize,
    which: Rest,
    asset_units: bool,
) -> FbError {
    guard(|| {
        // SAFETY: the caller's contract.
        let rig = unsafe { loaded(rig)? };
        let count = match which {
            Rest::Vertices => rig.vertex_count(),
            Rest::Markers => rig.marker_count(),
        };
        // SAFETY: the caller's contract.
        let out = unsafe { positions_out(out, capacity, count)? };
        for (i, o) in out.iter_mut().enumerate() {
            let rest = match which {
                Rest::Vertices => rig.vertex_rest(i),
                Rest::Markers => rig.marker_rest(i),
            };
            *o = rest.ok_or(FbError::Internal)?;
        }
        if asset_units {
            to_asset_in_place(rig.space(), out);
        }
        Ok(())
    })
}

/// Write the rest position of every vertex (Q8.24 rig units, x y z each) to `out`, which has
/// room for `capacity` positions (at least `fb_rig_vertex_count`).
///
/// # Safety
/// `rig` as `fb_rig_vertex_count`; `out` null or valid for writes of `3 * capacity` values.
#[no_mangle]
pub unsafe extern "C" fn fb_vertex_rest(
    rig: *const FbRig,
    out: *mut i32,
    capacity: usize,
) -> FbError {
    // SAFETY: the caller's contract.
    unsafe { write_rest(rig, out, capacity, Rest::Vertices, false) }
}

/// `fb_vertex_rest` in the character asset's units (`f32`, through `fb_rig_space`).
///
/// # Safety
/// As `fb_vertex_rest`.
#[no_mangle]
pub unsafe extern "C" fn fb_vertex_rest_f32(
    rig: *const FbRig,
    out: *mut f32,
    capacity: usize,
) -> FbError {
    // SAFETY: the caller's contract; `f32` and `i32` have one size and alignment.
    unsafe { write_rest(rig, out.cast(), capacity, Rest::Vertices, true) }
}

/// Write the rest position of every marker on the character (Q8.24 rig units) to `out`, which
/// has room for `capacity` positions (at least `fb_rig_marker_count`). Zero marker motion
/// (`fb_deform` with these) gives the rest pose.
///
/// # Safety
/// As `fb_vertex_rest`.
#[no_mangle]
pub unsafe extern "C" fn fb_marker_rest(
    rig: *const FbRig,
    out: *mut i32,
    capacity: usize,
) -> FbError {
    // SAFETY: the caller's contract.
    unsafe { write_rest(rig, out, capacity, Rest::Markers, false) }
}

/// `fb_marker_rest` in the character asset's units (`f32`, through `fb_rig_space`).
///
/// # Safety
/// As `fb_vertex_rest`.
#[no_mangle]
pub unsafe extern "C" fn fb_marker_rest_f32(
    rig: *const FbRig,
    out: *mut f32,
    capacity: usize,
) -> FbError {
    // SAFETY: the caller's contract; `f32` and `i32` have one size and alignment.
    unsafe { write_rest(rig, out.cast(), capacity, Rest::Markers, true) }
}

/// Convert Q8.24 positions written into an `f32` buffer to the asset's units, in place.
pub(crate) fn to_asset_in_place(space: Space, out: &mut [[i32; 3]]) {
    for o in out {
        *o = space.to_asset(*o).map(|c| c.to_bits() as i32);
    }
}

/// Deform one frame: `markers` holds `marker_count` marker positions (Q8.24 rig units, x y z
/// each, in marker order; `marker_count` must be `fb_rig_marker_count`), `out` receives one
/// position per vertex (Q8.24) and has room for `vertex_capacity` (at least
/// `fb_rig_vertex_count`). Integer only: bit-identical on every platform. Nothing is written on
/// error. Safe to call from many threads at once on one rig.
///
/// # Safety
/// `rig` as `fb_rig_vertex_count`; `markers` null or valid for reads of `3 * marker_count`
/// values; `out` null or valid for writes of `3 * vertex_capacity` values, not overlapping
/// `markers`.
#[no_mangle]
pub unsafe extern "C" fn fb_deform(
    rig: *const FbRig,
    markers: *const i32,
    marker_count: usize,
    out: *mut i32,
    vertex_capacity: usize,
) -> FbError {
    guard(|| {
        // SAFETY: the caller's contract.
        let rig = unsafe { loaded(rig)? };
        // SAFETY: the caller's contract.
        let markers = unsafe { positions(markers, marker_count, rig.marker_count())? };
        // SAFETY: the caller's contract.
        let out = unsafe { positions_out(out, vertex_capacity, rig.vertex_count())? };
        Ok(rig.deform(markers, out)?)
    })
}

/// Deform the vertices `first_vertex .. first_vertex + vertex_count` only, into `out` (room for
/// exactly `vertex_count` positions, Q8.24): the same integers `fb_deform` writes there. For a
/// job system that splits one face over workers: each worker calls this on its own chunk of
/// the output with the same `markers`, concurrently on one rig. A range past the last vertex
/// is `FB_ERROR_VERTEX_COUNT`; nothing is written on error.
///
/// # Safety
/// `rig` as `fb_rig_vertex_count`; `markers` as in `fb_deform`; `out` null or valid for writes
/// of `3 * vertex_count` values, not overlapping `markers`.
#[no_mangle]
pub unsafe extern "C" fn fb_deform_range(
    rig: *const FbRig,
    markers: *const i32,
    marker_count: usize,
    first_vertex: usize,
    out: *mut i32,
    vertex_count: usize,
) -> FbError {
    guard(|| {
        // SAFETY: the caller's contract.
        let rig = unsafe { loaded(rig)? };
        // SAFETY: the caller's contract.
        let markers = unsafe { positions(markers, marker_count, rig.marker_count())? };
        // SAFETY: the caller's contract.
        let out = unsafe { positions_out(out, vertex_count, vertex_count)? };
        Ok(rig.deform_range(markers, first_vertex, out)?)
    })
}

/// `fb_deform` in the character asset's units: marker positions in, vertex positions out, as
/// `f32` (converted through `fb_rig_space`; the deformation itself is the integer one). A
/// marker that is not finite or lies beyond 128 half extents fails the frame
/// (`FB_ERROR_NOT_FINITE`, `FB_ERROR_OUT_OF_RANGE`) and nothing is written.
///
/// # Safety
/// As `fb_deform`, with `f32` values.
#[no_mangle]
pub unsafe extern "C" fn fb_deform_f32(
    rig: *const FbRig,
    markers: *const f32,
    marker_count: usize,
    out: *mut f32,
    vertex_capacity: usize,
) -> FbError {
    guard(|| {
        // SAFETY: the caller's contract.
        let rig = unsafe { loaded(rig)? };
        let m = rig.marker_count();
        // SAFETY: the caller's contract.
        let given = unsafe { positions(markers, marker_count, m)? };
        let space = rig.space();
        let mut q = [[0i32; 3]; facebake_runtime::MAX_MARKERS];
        for (q, p) in q.iter_mut().zip(given) {
            *q = space.to_rig(*p)?;
        }
        // SAFETY: the caller's contract; `f32` and `i32` have one size and alignment, and the
        // buffer holds `i32` values only until they are converted below.
        let out = unsafe { positions_out(out.cast::<i32>(), vertex_capacity, rig.vertex_count())? };
        rig.deform(&q[..m], out)?;
        to_asset_in_place(space, out);
        Ok(())
    })
}

/// The unit normals of the mesh at `positions` (`vertex_count` × x y z `int32_t`, Q8.24: what
/// `fb_deform` or `fb_play` wrote) into `out` (room for `out_capacity` normals of x y z
/// `int16_t`, Q1.14: 1.0 = 1 << 14), one per vertex: area-weighted over the mesh's triangles,
/// bit-identical on every target, seams welded. Nothing is written on error
/// (`FB_ERROR_VERTEX_COUNT` when `vertex_count` is not the rig's).
///
/// # Safety
/// `positions` must be valid for reads of `vertex_count` × 3 `int32_t` and `out` for writes of
/// `out_capacity` × 3 `int16_t` (or be null); they must not overlap.
#[no_mangle]
pub unsafe extern "C" fn fb_normals(
    rig: *const FbRig,
    positions: *const i32,
    vertex_count: usize,
    out: *mut i16,
    out_capacity: usize,
) -> FbError {
    guard(|| {
        // SAFETY: the caller's contract.
        let (rig, positions) = unsafe { normals_input(rig, positions, vertex_count)? };
        // SAFETY: the caller's contract.
        let out = unsafe { positions_out(out, out_capacity, positions.len())? };
        Ok(rig.normals(positions, out)?)
    })
}

/// The loaded rig and its `vertex_count` positions, for the normals calls.
///
/// # Safety
/// As `fb_normals` for `rig` and `positions`.
unsafe fn normals_input<'a>(
    rig: *const FbRig,
    positions: *const i32,
    vertex_count: usize,
) -> Result<(&'a Rig<'static>, &'a [[i32; 3]]), FbError> {
    // SAFETY: the caller's contract.
    let rig = unsafe { loaded(rig)? };
    if vertex_count != rig.vertex_count() {
        return Err(FbError::VertexCount);
    }
    // SAFETY: the caller's contract; `[i32; 3]` has `i32`'s alignment.
    let positions = unsafe { slice(positions.cast::<[i32; 3]>(), vertex_count)? };
    Ok((rig, positions))
}

/// Triangles in the rig's normals plan: `fb_plan_normals` fills `3 ×` this many `uint32_t`.
///
/// # Safety
/// `rig` must be null or point to an `FbRig` storage (0 when it holds no loaded rig).
#[no_mangle]
pub unsafe extern "C" fn fb_normals_plan_len(rig: *const FbRig) -> usize {
    // SAFETY: the caller's contract.
    unsafe { loaded(rig) }.map_or(0, |r| r.normals_plan_len())
}

/// List the rig's triangles for `fb_normals_planned` into `plan` (`plan_len` triangles of three
/// `uint32_t`: exactly `fb_normals_plan_len`), once per rig; keep it for every frame.
///
/// # Safety
/// `plan` must be valid for writes of `plan_len` × 3 `uint32_t` (or be null).
#[no_mangle]
pub unsafe extern "C" fn fb_plan_normals(
    rig: *const FbRig,
    plan: *mut u32,
    plan_len: usize,
) -> FbError {
    guard(|| {
        // SAFETY: the caller's contract.
        let rig = unsafe { loaded(rig)? };
        // SAFETY: the caller's contract; `[u32; 3]` has `u32`'s alignment.
        let plan = unsafe { slice_mut(plan.cast::<[u32; 3]>(), plan_len)? };
        rig.plan_normals(plan)?;
        Ok(())
    })
}

/// `fb_normals`, bit for bit, taking each triangle's cross product once instead of once per
/// corner (about 0.6 × its instructions): `plan` as `fb_plan_normals` filled it (`plan_len`
/// triangles; its vertices are checked), `sums` scratch of `sums_len` × 3 `int64_t`, one per
/// vertex, overwritten. For a host that can spare 24 bytes a vertex and 12 a triangle. Nothing
/// is written to `out` on error (`FB_ERROR_PLAN_MISMATCH` for a plan naming a vertex the rig
/// does not have).
///
/// # Safety
/// As `fb_normals`; `plan` must be valid for reads of `plan_len` × 3 `uint32_t` and `sums`
/// for writes of `sums_len` × 3 `int64_t` (or be null); none may overlap.
#[no_mangle]
#[allow(clippy::too_many_arguments)] // a C signature: each buffer with its length
pub unsafe extern "C" fn fb_normals_planned(
    rig: *const FbRig,
    plan: *const u32,
    plan_len: usize,
    positions: *const i32,
    vertex_count: usize,
    sums: *mut i64,
    sums_len: usize,
    out: *mut i16,
    out_capacity: usize,
) -> FbError {
    guard(|| {
        // SAFETY: the caller's contract.
        let (rig, positions) = unsafe { normals_input(rig, positions, vertex_count)? };
        let n = positions.len();
        if sums_len < n {
            return Err(FbError::BufferTooSmall);
        }
        // SAFETY: the caller's contract; `[T; 3]` has `T`'s alignment.
        let plan = unsafe { slice(plan.cast::<[u32; 3]>(), plan_len)? };
        let plan = rig.normals_plan_from(plan)?;
        // SAFETY: the caller's contract.
        let sums = unsafe { slice_mut(sums.cast::<[i64; 3]>(), n)? };
        // SAFETY: the caller's contract.
        let out = unsafe { positions_out(out, out_capacity, n)? };
        Ok(rig.normals_planned(positions, &plan, sums, out)?)
    })
}
