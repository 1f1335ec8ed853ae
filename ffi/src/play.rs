//! Playing captured frames: the play state in caller storage, `fb_play` and its report.

use core::mem::{align_of, size_of};

use facebake_runtime::{
    ConvertError, FitFailure, FrameReport, MarkerSet, PlayState, RigidStatus, Space,
};

use crate::error::FbError;
use crate::memory::{guard, positions, positions_out, slice, store, stored_mut, Storage, Tagged};
use crate::rig::{loaded, to_asset_in_place, FbRig};
use crate::{FB_MARKER_WORDS, FB_MAX_MARKERS};

/// What the capture stages carry from frame to frame for ONE character (last good marker
/// displacements, each marker's offsets from its fill neighbours, last head fit), in storage
/// the caller provides (`fb_play_state_size()` bytes aligned to `fb_play_state_align()`, about
/// 23 KB). Opaque; nothing to free but the storage.
/// Give each character (each stream of frames) its own, and do not use one from two threads at
/// once.
pub struct FbPlayState(Tagged<PlayState>);

impl Storage for FbPlayState {
    type Value = PlayState;
    const TAG: u64 = u64::from_le_bytes(*b"fbPlay\0\x01");
    const MISSING: FbError = FbError::NotInitialised;

    unsafe fn tagged(storage: *mut Self) -> *mut Tagged<Self::Value> {
        // SAFETY: `storage` is valid (the trait's contract), so the field is in bounds.
        unsafe { core::ptr::addr_of_mut!((*storage).0) }
    }
}

/// How the head motion of a frame was found.
#[repr(i32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FbRigidStatus {
    /// The rig has no head markers: no compensation.
    NotUsed = 0,
    /// Fitted from `head_markers_fitted` head markers.
    Fitted = 1,
    /// Fewer than three head markers present and no pose to track from (no fit yet, or too
    /// few markers present in this frame and the last): the last good fit (or none) was held.
    HeldTooFew = 2,
    /// The present head markers are (nearly) collinear: the last good fit (or none) was held.
    HeldCollinear = 3,
    /// Fewer than three head markers kept their mutual distances from the neutral frame (the
    /// others swapped, jumped or ghosts): the last good fit (or none) was held.
    HeldNotRigid = 4,
    /// Fewer than three head markers were present (`head_markers_fitted` of them): the pose was
    /// tracked from the last frame through them and the other markers present in both frames.
    Tracked = 5,
}

/// What the capture stages did with one frame. Marker sets are bitsets: marker `j` is in the
/// set when `(set[j / 32] >> (j % 32)) & 1`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FbFrameReport {
    /// Head-motion compensation.
    pub rigid: FbRigidStatus,
    /// Head markers the fit used (when `rigid` is `FB_RIGID_STATUS_FITTED`), or present (when
    /// it is `FB_RIGID_STATUS_TRACKED`).
    pub head_markers_fitted: u32,
    /// RMS distance of the fitted head markers from their rigid positions, Q8.24 actor units.
    pub rigid_residual: i32,
    /// Head markers dropped from the fit as outliers.
    pub head_markers_dropped: u32,
    /// Markers in `rejected`.
    pub rejected_count: u32,
    /// Markers in `rebuilt`.
    pub rebuilt_count: u32,
    /// Markers in `held`.
    pub held_count: u32,
    /// Markers given but rejected (out of range, or implausibly far from neutral).
    pub rejected: [u32; FB_MARKER_WORDS],
    /// Markers rebuilt from their neighbours.
    pub rebuilt: [u32; FB_MARKER_WORDS],
    /// Markers held at their last good displacement (or neutral if never seen).
    pub held: [u32; FB_MARKER_WORDS],
}

/// A marker set as bitset words.
fn words(set: &MarkerSet) -> [u32; FB_MARKER_WORDS] {
    let mut w = [0u32; FB_MARKER_WORDS];
    for j in set.iter() {
        w[j / 32] |= 1 << (j % 32);
    }
    w
}

impl From<&FrameReport> for FbFrameReport {
    fn from(r: &FrameReport) -> Self {
        let (rigid, head_markers_fitted) = match r.rigid {
            RigidStatus::NotUsed => (FbRigidStatus::NotUsed, 0),
            RigidStatus::Fitted { head_markers } => (FbRigidStatus::Fitted, head_markers),
            RigidStatus::Held(FitFailure::TooFew) => (FbRigidStatus::HeldTooFew, 0),
            RigidStatus::Held(FitFailure::Collinear) => (FbRigidStatus::HeldCollinear, 0),
            RigidStatus::Held(FitFailure::NotRigid) => (FbRigidStatus::HeldNotRigid, 0),
            RigidStatus::Tracked { head_markers } => (FbRigidStatus::Tracked, head_markers),
        };
        let count = |s: &MarkerSet| s.len() as u32;
        Self {
            rigid,
            head_markers_fitted: u32::from(head_markers_fitted),
            rigid_residual: r.rigid_residual,
            head_markers_dropped: u32::from(r.head_markers_dropped),
            rejected_count: count(&r.rejected),
            rebuilt_count: count(&r.rebuilt),
            held_count: count(&r.held),
            rejected: words(&r.rejected),
            rebuilt: words(&r.rebuilt),
            held: words(&r.held),
        }
    }
}

/// Bytes of storage an `FbPlayState` needs.
#[no_mangle]
pub extern "C" fn fb_play_state_size() -> usize {
    size_of::<FbPlayState>()
}

/// Alignment the storage of an `FbPlayState` needs.
#[no_mangle]
pub extern "C" fn fb_play_state_align() -> usize {
    align_of::<FbPlayState>()
}

/// Initialise (or reset, at a cut in the take) a play state in `storage` (`storage_len` bytes,
/// at least `fb_play_state_size()`, aligned to `fb_play_state_align()`): nothing seen yet.
///
/// # Safety
/// `storage` null or valid for writes of `storage_len` bytes, not used by anyone else during
/// the call.
#[no_mangle]
pub unsafe extern "C" fn fb_play_state_init(
    storage: *mut FbPlayState,
    storage_len: usize,
) -> FbError {
    // SAFETY: the caller's contract.
    guard(|| unsafe { store(storage, storage_len, || Ok(PlayState::new())) })
}

/// The shared body of `fb_play` and `fb_play_f32`, on Q8.24 buffers: `read` turns one given
/// actor marker into Q8.24 actor units (`None`: missing), given the actor space; with
/// `asset_units`, the outputs (`f32` buffers reinterpreted) are converted to the character
/// asset's units at the end.
///
/// # Safety
/// As `fb_play`, with `actor` holding values of `T`.
#[allow(clippy::too_many_arguments)]
unsafe fn play<T: Copy>(
    rig: *const FbRig,
    state: *mut FbPlayState,
    actor: *const T,
    read: impl Fn(Space, [T; 3]) -> Option<[i32; 3]>,
    present: *const u8,
    marker_count: usize,
    markers_out: *mut i32,
    out: *mut i32,
    vertex_capacity: usize,
    report: *mut FbFrameReport,
    asset_units: bool,
) -> Result<(), FbError> {
    // SAFETY (every block below): the caller's contract, as documented on `fb_play`.
    let rig = unsafe { loaded(rig)? };
    let state = unsafe { stored_mut(state)? };
    let m = rig.marker_count();
    let space = rig.actor_space().ok_or(FbError::NoStages)?;
    let actor = unsafe { positions(actor, marker_count, m)? };
    let mut given = [None; FB_MAX_MARKERS];
    for (g, p) in given.iter_mut().zip(actor) {
        *g = read(space, *p);
    }
    if !present.is_null() {
        let present = unsafe { slice(present, m)? };
        for (g, p) in given.iter_mut().zip(present) {
            if *p == 0 {
                *g = None;
            }
        }
    }
    let markers_out = if markers_out.is_null() {
        None
    } else {
        Some(unsafe { positions_out(markers_out, m, m)? })
    };
    let out = unsafe { positions_out(out, vertex_capacity, rig.vertex_count())? };
    if !report.is_null() {
        crate::memory::check(report)?;
    }
    // Every argument is checked: from here on the call succeeds.
    let mut markers = [[0i32; 3]; FB_MAX_MARKERS];
    let frame = rig.play_markers(state, &given[..m], &mut markers[..m])?;
    rig.deform(&markers[..m], out)?;
    if let Some(markers_out) = markers_out {
        markers_out.copy_from_slice(&markers[..m]);
        if asset_units {
            to_asset_in_place(rig.space(), markers_out);
        }
    }
    if asset_units {
        to_asset_in_place(rig.space(), out);
    }
    if !report.is_null() {
        unsafe { report.write(FbFrameReport::from(&frame)) };
    }
    Ok(())
}

/// Play one captured frame through the rig's capture stages (head-motion compensation, fill,
/// retargeting) and its deformer, for the character whose state is `state`.
///
/// * `actor`: `marker_count` (= `fb_rig_marker_count`) raw actor markers, Q8.24 actor units
///   (`fb_rig_actor_space`), x y z each, in the rig's marker order.
/// * `present`: one byte per marker, 0 where the marker is missing this frame (its `actor`
///   values are then ignored); null means every marker is present.
/// * `markers_out`: null, or room for `marker_count` positions: the character's markers
///   (Q8.24 rig units), the input `fb_deform` would take.
/// * `out`: room for `vertex_capacity` (at least `fb_rig_vertex_count`) positions: the deformed
///   vertices, Q8.24 rig units.
/// * `report`: null, or where to write what the stages did (rejected, rebuilt, held markers;
///   the head fit).
///
/// Every argument is checked before anything is written: on error neither the outputs nor the
/// state have changed. `FB_ERROR_NO_STAGES` if the rig was baked without capture stages.
///
/// # Safety
/// `rig` null or valid for reads of `fb_rig_size()` bytes; `state` null or valid for reads and
/// writes of `fb_play_state_size()` bytes and used by no one else during the call; every other
/// non-null pointer valid for the reads or writes its count implies; the outputs overlapping
/// nothing else.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn fb_play(
    rig: *const FbRig,
    state: *mut FbPlayState,
    actor: *const i32,
    present: *const u8,
    marker_count: usize,
    markers_out: *mut i32,
    out: *mut i32,
    vertex_capacity: usize,
    report: *mut FbFrameReport,
) -> FbError {
    // SAFETY: the caller's contract.
    guard(|| unsafe {
        play(
            rig,
            state,
            actor,
            |_, p| Some(p),
            present,
            marker_count,
            markers_out,
            out,
            vertex_capacity,
            report,
            false,
        )
    })
}

/// `fb_play` in asset units, as `f32`: `actor` in the capture's units (converted through
/// `fb_rig_actor_space`), `markers_out` and `out` in the character asset's units
/// (`fb_rig_space`). An actor marker that is not finite counts as missing; one beyond the
/// actor space's range is passed on as out of range, so the stages reject it (and report it).
///
/// # Safety
/// As `fb_play`, with `f32` values.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn fb_play_f32(
    rig: *const FbRig,
    state: *mut FbPlayState,
    actor: *const f32,
    present: *const u8,
    marker_count: usize,
    markers_out: *mut f32,
    out: *mut f32,
    vertex_capacity: usize,
    report: *mut FbFrameReport,
) -> FbError {
    // An unconvertible marker is missing (not finite) or passed on to be rejected (too far).
    let read = |space: Space, p: [f32; 3]| match space.to_rig(p) {
        Ok(q) => Some(q),
        Err(ConvertError::NotFinite) => None,
        Err(ConvertError::OutOfRange) => Some([i32::MAX; 3]),
    };
    // SAFETY: the caller's contract; `f32` and `i32` have one size and alignment, and the
    // outputs hold `i32` values only until `play` converts them.
    guard(|| unsafe {
        play(
            rig,
            state,
            actor,
            read,
            present,
            marker_count,
            markers_out.cast(),
            out.cast(),
            vertex_capacity,
            report,
            true,
        )
    })
}
