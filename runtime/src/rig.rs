//! [`Rig`]: a validated, zero-copy view of a rig blob, and the per-frame call.

use crate::cost::Cost;
#[cfg(feature = "format")]
use crate::deformer::Deformer;
use crate::deformer::{DegenerateTriangles, FrameTable, Shared};
use crate::error::LoadError;
use crate::format::header;
use crate::format::{self, RigData};
use crate::normals::NormalsPlan;
use crate::records::{
    read_names, read_position, read_rest, MAX_MARKERS, POSITION_BYTES, REST_BYTES,
};
use crate::space::Space;
use crate::stages::report::FrameReport;
use crate::stages::PlayState;
#[cfg(feature = "format")]
use crate::stages::Stages;

/// A rig loaded from a blob. It borrows the blob's bytes (which may sit in flash) and owns
/// nothing; loading validated every index and length once.
#[derive(Clone, Copy, Debug)]
pub struct Rig<'a> {
    data: RigData<'a>,
    /// The influences every vertex has, when every vertex has the same number (what bakes
    /// write), found once at load: a chunk then finds its first influence by a multiplication
    /// instead of summing the counts before it, and no frame scans the counts again.
    uniform_influences: Option<u8>,
    /// Triangles in the rig's [`NormalsPlan`], counted once at load so that checking a kept
    /// plan ([`Rig::normals_plan_from`], every frame through the C ABI) does not walk the fans.
    normals_plan_len: usize,
}

/// Why a frame could not be deformed. Nothing was written to the output when this is returned.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FrameError {
    /// The marker slice does not have one entry per rig marker.
    MarkerCount {
        /// Markers the rig has.
        expected: usize,
        /// Entries given.
        found: usize,
    },
    /// [`Rig::play`] on a rig baked without capture stages.
    NoStages,
    /// The output slice does not have one entry per vertex.
    OutputLength {
        /// Vertices the rig has.
        expected: usize,
        /// Entries given.
        found: usize,
    },
    /// [`Rig::normals`]: the position slice does not have one entry per vertex.
    PositionCount {
        /// Vertices the rig has.
        expected: usize,
        /// Entries given.
        found: usize,
    },
    /// [`Rig::deform_range`]: the vertex range runs past the rig's last vertex.
    VertexRange {
        /// First vertex asked for.
        first: usize,
        /// Vertices asked for (the output's length).
        len: usize,
        /// Vertices the rig has.
        vertices: usize,
    },
    /// [`Rig::deform_chunk`]: the [`FrameTable`] was filled by another rig, or by none.
    TableMismatch,
    /// [`Rig::normals_planned`]: the [`NormalsPlan`] was made by another rig;
    /// [`Rig::normals_plan_from`]: the triangles name a vertex the rig does not have.
    PlanMismatch,
    /// [`Rig::plan_normals`], [`Rig::normals_plan_from`] or [`Rig::normals_planned`]: a scratch
    /// slice (the plan's triangles or the sums) does not have the length the rig needs.
    ScratchLength {
        /// Entries the rig needs ([`Rig::normals_plan_len`] triangles, or one sum per vertex).
        expected: usize,
        /// Entries given.
        found: usize,
    },
}

impl core::error::Error for FrameError {}

impl core::fmt::Display for FrameError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::MarkerCount { expected, found } => {
                write!(
                    f,
                    "{found} marker positions given, the rig has {expected} markers"
                )
            }
            Self::NoStages => f.write_str("the rig has no capture stages (bake it with a capture)"),
            Self::OutputLength { expected, found } => {
                write!(
                    f,
                    "output has room for {found} vertices, the rig has {expected}"
                )
            }
            Self::PositionCount { expected, found } => {
                write!(
                    f,
                    "{found} vertex positions given, the rig has {expected} vertices"
                )
            }
            Self::VertexRange {
                first,
                len,
                vertices,
            } => write!(
                f,
                "vertices {first}..{} asked for, the rig has {vertices}",
                first.saturating_add(*len)
            ),
            Self::TableMismatch => f.write_str(
                "the frame table was not prepared by this rig (call Rig::prepare first)",
            ),
            Self::PlanMismatch => f.write_str(
                "the normals plan was made by another rig or names a vertex this one does not \
                 have (call Rig::plan_normals on this one)",
            ),
            Self::ScratchLength { expected, found } => {
                write!(f, "scratch has {found} entries, the rig needs {expected}")
            }
        }
    }
}

impl<'a> Rig<'a> {
    /// Load a rig from blob bytes: header, checksum, decoding and full validation. Never panics
    /// and never reads out of bounds, whatever the bytes; the work is linear in their length.
    pub fn from_bytes(bytes: &'a [u8]) -> Result<Self, LoadError> {
        let payload = header::open(bytes)?;
        let data = format::decode(payload)?;
        Ok(Self {
            uniform_influences: data.deformer.uniform_influences(),
            normals_plan_len: data.normals.plan_len(),
            data,
        })
    }

    /// The decoded payload (borrowed sections).
    #[cfg(feature = "format")]
    pub fn data(&self) -> &RigData<'a> {
        &self.data
    }

    /// Where rig units sit in the asset's space.
    pub fn space(&self) -> Space {
        self.data.space
    }

    /// Number of vertices the rig deforms.
    pub fn vertex_count(&self) -> usize {
        self.data.vertex_count as usize
    }

    /// Number of markers the rig reads per frame.
    pub fn marker_count(&self) -> usize {
        usize::from(self.data.marker_count)
    }

    /// Marker names, in marker order.
    pub fn marker_names(&self) -> impl Iterator<Item = &'a str> + 'a {
        read_names(self.data.marker_names.0)
    }

    /// Index of the marker called `name`.
    pub fn marker_index(&self, name: &str) -> Option<usize> {
        self.marker_names().position(|n| n == name)
    }

    /// Rest position of marker `i` on the character (Q8.24), or `None` past the last marker.
    pub fn marker_rest(&self, i: usize) -> Option<[i32; 3]> {
        self.data
            .marker_rest
            .0
            .chunks_exact(POSITION_BYTES)
            .nth(i)
            .map(read_position)
    }

    /// Rest position of vertex `i` (Q8.24), or `None` past the last vertex.
    pub fn vertex_rest(&self, i: usize) -> Option<[i32; 3]> {
        self.data
            .vertex_rest
            .0
            .chunks_exact(REST_BYTES)
            .nth(i)
            .map(read_rest)
    }

    /// The deformer section.
    #[cfg(feature = "format")]
    pub fn deformer(&self) -> &Deformer<'a> {
        &self.data.deformer
    }

    /// Fractional bits of the stored weights (linear, planar) or radial values (RBF).
    #[cfg(feature = "format")]
    pub fn weight_frac_bits(&self) -> u8 {
        self.data.deformer.weight_frac_bits()
    }

    /// The per-frame work of [`Self::deform`], and in [`Cost::normals`] that of
    /// [`Self::normals`].
    pub fn cost(&self) -> Cost {
        Cost {
            normals: self.data.normals.cost(),
            ..self.data.deformer.cost(&self.shared())
        }
    }

    /// The unit normals of the mesh at `positions` (Q8.24, one per vertex: what [`Self::deform`]
    /// or [`Self::play`] wrote) into `out`, one per vertex, Q1.14 (`i16`, 1.0 = 2¹⁴).
    ///
    /// Area-weighted normals over the mesh's triangles, recomputed from the positions in
    /// integers: bit-identical on every target, no allocation, a cost fixed by the rig
    /// ([`Cost::normals`]). Vertices split along a seam (same rest position) get identical
    /// normals; a vertex whose triangles have collapsed gets its rest normal. The mesh has no
    /// tangents in the rig. [`Self::normals_planned`] gives the same normals faster, from
    /// caller scratch.
    pub fn normals(&self, positions: &[[i32; 3]], out: &mut [[i16; 3]]) -> Result<(), FrameError> {
        self.check_normals_shapes(positions, out)?;
        self.data.normals.compute(positions, out);
        Ok(())
    }

    /// One position and one output normal per vertex.
    fn check_normals_shapes(
        &self,
        positions: &[[i32; 3]],
        out: &[[i16; 3]],
    ) -> Result<(), FrameError> {
        let expected = self.vertex_count();
        if positions.len() != expected {
            return Err(FrameError::PositionCount {
                expected,
                found: positions.len(),
            });
        }
        if out.len() != expected {
            return Err(FrameError::OutputLength {
                expected,
                found: out.len(),
            });
        }
        Ok(())
    }

    /// Triangles in this rig's [`NormalsPlan`]: the length of the buffer
    /// [`Self::plan_normals`] fills.
    pub fn normals_plan_len(&self) -> usize {
        self.normals_plan_len
    }

    /// List the mesh's triangles for [`Self::normals_planned`] into `triangles`
    /// ([`Self::normals_plan_len`] long), once per rig: the plan borrows the buffer and remembers
    /// the rig.
    pub fn plan_normals<'p>(
        &self,
        triangles: &'p mut [[u32; 3]],
    ) -> Result<NormalsPlan<'p>, FrameError> {
        scratch_length(self.normals_plan_len(), triangles.len())?;
        self.data.normals.plan(triangles);
        Ok(NormalsPlan {
            owner: self.table_owner(),
            triangles,
        })
    }

    /// A plan [`Self::plan_normals`] filled for this rig and the caller kept (across a C
    /// interface, say): checked to be as long as this rig's and to name only its vertices.
    /// A buffer altered since gives wrong normals, never a panic.
    pub fn normals_plan_from<'p>(
        &self,
        triangles: &'p [[u32; 3]],
    ) -> Result<NormalsPlan<'p>, FrameError> {
        scratch_length(self.normals_plan_len(), triangles.len())?;
        let n = self.vertex_count();
        if triangles.iter().flatten().any(|&v| v as usize >= n) {
            return Err(FrameError::PlanMismatch);
        }
        Ok(NormalsPlan {
            owner: self.table_owner(),
            triangles,
        })
    }

    /// [`Self::normals`], bit for bit, taking each triangle's cross product once instead of
    /// once per corner: `plan` is this rig's ([`Self::plan_normals`]) and `sums` one scratch
    /// entry per vertex, overwritten. For a caller that can spare the memory (24 bytes a vertex
    /// and 12 a triangle) and wants the time; poses beyond ±2 rig units take the fans as
    /// [`Self::normals`] does.
    pub fn normals_planned(
        &self,
        positions: &[[i32; 3]],
        plan: &NormalsPlan<'_>,
        sums: &mut [[i64; 3]],
        out: &mut [[i16; 3]],
    ) -> Result<(), FrameError> {
        if plan.owner != self.table_owner() {
            return Err(FrameError::PlanMismatch);
        }
        scratch_length(self.vertex_count(), sums.len())?;
        self.check_normals_shapes(positions, out)?;
        self.data
            .normals
            .compute_planned(positions, plan.triangles, sums, out);
        Ok(())
    }

    /// Rest normal of vertex `i` (Q1.14), or `None` past the last vertex.
    pub fn rest_normal(&self, i: usize) -> Option<[i16; 3]> {
        self.data.normals.rest_normal(i)
    }

    /// Deform one frame: `markers` are the current marker positions in rig units (Q8.24), one
    /// per rig marker in marker order; `out` receives one position per vertex (Q8.24).
    ///
    /// Zero marker motion gives the rest pose bit for bit (planar bones: within the rounding of
    /// the stored local coordinates, not bit for bit), and moving every marker by the same
    /// offset moves every vertex by exactly that offset (barring saturation at ±128 rig units).
    pub fn deform(&self, markers: &[[i32; 3]], out: &mut [[i32; 3]]) -> Result<(), FrameError> {
        self.deform_report(markers, out).map(|_| ())
    }

    /// The per-frame marker work of [`Self::deform`] for `markers` (as [`Self::deform`] takes
    /// them), done once into `table` for the [`Self::deform_chunk`] calls of this frame, which
    /// share it read-only (a job system fills it on one thread, then spreads the chunks over
    /// workers). Returns the planar control triangles that were degenerate in this frame (see
    /// [`Self::deform_report`]).
    pub fn prepare(
        &self,
        markers: &[[i32; 3]],
        table: &mut FrameTable,
    ) -> Result<DegenerateTriangles, FrameError> {
        self.check_marker_count(markers.len())?;
        let degenerate = self
            .data
            .deformer
            .prepare(&self.shared(), markers, &mut table.table);
        table.owner = self.table_owner();
        Ok(degenerate)
    }

    /// The vertices `first .. first + out.len()` of the frame `table` holds (filled by
    /// [`Self::prepare`] on this rig), into `out`: the same integers [`Self::deform`] writes
    /// there. Splitting a frame into many chunks costs little more than one [`Self::deform`]:
    /// each chunk only finds its first influence by summing the counts before it (one byte a
    /// vertex; on a rig whose vertices all have the same number of influences, what bakes
    /// write, by one multiplication).
    pub fn deform_chunk(
        &self,
        table: &FrameTable,
        first: usize,
        out: &mut [[i32; 3]],
    ) -> Result<(), FrameError> {
        if table.owner != self.table_owner() {
            return Err(FrameError::TableMismatch);
        }
        self.check_range(first, out.len())?;
        let shared = self.shared().vertex_range(first, out.len());
        self.data
            .deformer
            .vertex_range(first, out.len(), shared.uniform_influences)
            .deform_prepared(&shared, &table.table, out);
        Ok(())
    }

    /// The counts and sections every deformer reads, with the influence count found at load.
    fn shared(&self) -> Shared<'a> {
        Shared {
            uniform_influences: self.uniform_influences,
            ..self.data.shared()
        }
    }

    /// Who a [`FrameTable`] filled by this rig says filled it: the address of the rig's marker
    /// rest section, never 0.
    fn table_owner(&self) -> usize {
        (self.data.marker_rest.0.as_ptr() as usize).max(1)
    }

    /// `first .. first + len` is a range of this rig's vertices.
    fn check_range(&self, first: usize, len: usize) -> Result<(), FrameError> {
        let vertices = self.vertex_count();
        if first.checked_add(len).is_none_or(|end| end > vertices) {
            return Err(FrameError::VertexRange {
                first,
                len,
                vertices,
            });
        }
        Ok(())
    }

    /// [`Self::deform`] for the vertices `first .. first + out.len()` only, into `out`: the
    /// same integers [`Self::deform`] writes there. A job system can split one face over
    /// workers, each deforming its own chunk of `out` from the same `markers` (a `Rig` is
    /// `Sync`: share it read-only). Each call redoes the per-frame marker work (a table of
    /// marker displacements; the RBF deformer's coefficients, planar bones' triangle frames):
    /// for many chunks, [`Self::prepare`] it once and call [`Self::deform_chunk`].
    pub fn deform_range(
        &self,
        markers: &[[i32; 3]],
        first: usize,
        out: &mut [[i32; 3]],
    ) -> Result<(), FrameError> {
        self.check_marker_count(markers.len())?;
        let len = out.len();
        self.check_range(first, len)?;
        let shared = self.shared().vertex_range(first, len);
        self.data
            .deformer
            .vertex_range(first, len, shared.uniform_influences)
            .deform(&shared, markers, out);
        Ok(())
    }

    /// [`Self::deform`], also reporting the control triangles of a planar rig that were
    /// degenerate in this frame (collinear or coincident markers) and so kept their rest
    /// orientation. Always empty for the other deformers.
    pub fn deform_report(
        &self,
        markers: &[[i32; 3]],
        out: &mut [[i32; 3]],
    ) -> Result<DegenerateTriangles, FrameError> {
        self.check_marker_count(markers.len())?;
        if out.len() != self.vertex_count() {
            return Err(FrameError::OutputLength {
                expected: self.vertex_count(),
                found: out.len(),
            });
        }
        Ok(self.data.deformer.deform(&self.shared(), markers, out))
    }

    /// The capture stages, if the rig was baked with them.
    #[cfg(feature = "format")]
    pub fn stages(&self) -> Option<&Stages<'a>> {
        self.data.stages.as_ref()
    }

    /// Where actor units sit in the capture's space ([`Self::play`] takes actor units), if the
    /// rig was baked with capture stages.
    pub fn actor_space(&self) -> Option<Space> {
        self.data.stages.as_ref().map(|s| s.actor_space)
    }

    /// Play one captured frame through the capture stages and the deformer: `actor` holds the
    /// actor's raw markers in actor units (Q8.24, [`Self::actor_space`]; `None` where a marker
    /// is missing), one per rig marker; `out` receives one position per vertex (Q8.24 rig
    /// units). The report says which markers were rejected, rebuilt or held and how the head
    /// motion was found. `state` carries the last good values from frame to frame.
    pub fn play(
        &self,
        state: &mut PlayState,
        actor: &[Option<[i32; 3]>],
        out: &mut [[i32; 3]],
    ) -> Result<FrameReport, FrameError> {
        if out.len() != self.vertex_count() {
            return Err(FrameError::OutputLength {
                expected: self.vertex_count(),
                found: out.len(),
            });
        }
        let m = self.marker_count();
        let mut markers = [[0i32; 3]; MAX_MARKERS];
        let report = self.play_markers(state, actor, &mut markers[..m])?;
        self.deform(&markers[..m], out)?;
        Ok(report)
    }

    /// The capture stages of [`Self::play`] alone: `markers` receives the character's markers
    /// (Q8.24 rig units, one per rig marker), the input [`Self::deform`] takes. For a caller
    /// that records or hashes the character's markers (the C ABI's `fb_play` returns them), or
    /// that deforms them elsewhere. Nothing was written when this returns an error.
    pub fn play_markers(
        &self,
        state: &mut PlayState,
        actor: &[Option<[i32; 3]>],
        markers: &mut [[i32; 3]],
    ) -> Result<FrameReport, FrameError> {
        let stages = self.data.stages.as_ref().ok_or(FrameError::NoStages)?;
        self.check_marker_count(actor.len())?;
        self.check_marker_count(markers.len())?;
        Ok(stages.solve(state, actor, markers))
    }

    /// `FrameError::MarkerCount` unless `found` is the rig's marker count.
    fn check_marker_count(&self, found: usize) -> Result<(), FrameError> {
        let expected = self.marker_count();
        if found == expected {
            Ok(())
        } else {
            Err(FrameError::MarkerCount { expected, found })
        }
    }
}

/// A scratch slice of `found` entries where the rig needs `expected`.
fn scratch_length(expected: usize, found: usize) -> Result<(), FrameError> {
    if found == expected {
        Ok(())
    } else {
        Err(FrameError::ScratchLength { expected, found })
    }
}
