//! [`Rig`]: a validated, zero-copy view of a rig blob, and the per-frame call.

use crate::format::{
    self, read_position, read_rest, Deformer, LoadError, RigData, Space, MAX_MARKERS,
    POSITION_BYTES, REST_BYTES,
};
use crate::kernel;
use crate::kernel::planar::DegenerateTriangles;
use crate::pipeline::{FrameReport, PlayState, Stages};

/// A rig loaded from a blob. It borrows the blob's bytes (which may sit in flash) and owns
/// nothing; loading validated every index and length once.
#[derive(Clone, Copy, Debug)]
pub struct Rig<'a> {
    data: RigData<'a>,
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
}

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
        }
    }
}

/// The work one call to [`Rig::deform`] does. It depends only on the rig, never on the markers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Cost {
    /// Vertices written.
    pub vertices: usize,
    /// Markers read.
    pub markers: usize,
    /// Influences evaluated (Σ per-vertex counts).
    pub influences: usize,
    /// The rig's K: no vertex has more influences.
    pub max_influences: usize,
    /// Coefficient rows computed per frame (RBF-coefficient rigs; 0 for linear rigs).
    pub coefficient_rows: usize,
    /// Widening multiply-adds into `i64` accumulators: 3 per influence, plus for RBF-coefficient
    /// rigs 3 per coefficient row and marker (stage 1) and 9 per vertex for the affine part.
    /// Planar bones: 12 per influence (the region transform and the weighted sum), 3 more per
    /// apex influence, and 36 per control-triangle frame (cross products and the degeneracy
    /// test), besides the normalisations counted in [`Self::normalisations`].
    pub multiply_adds: usize,
    /// Saturating subtractions forming marker displacements (3 per marker).
    pub subtractions: usize,
    /// Round-shift-saturate steps narrowing an accumulator to `i32`.
    pub narrowings: usize,
    /// Stack the call uses for marker displacements (and, for RBF-coefficient rigs, the
    /// coefficients), in bytes.
    pub scratch_bytes: usize,
    /// Control-triangle frames built per frame (planar bones; 0 otherwise). A triangle that is
    /// degenerate in a frame builds its rest frame too, so at most twice this many are built.
    pub frame_builds: usize,
    /// Vector normalisations (integer square root and three divisions) per frame: four per
    /// frame build, one per apex-region influence (planar bones; 0 otherwise).
    pub normalisations: usize,
}

impl core::fmt::Display for Cost {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(
            f,
            "{} vertices, {} markers, {} coefficient rows, {} influences (K ≤ {}): {} multiply-adds, \
             {} subtractions, {} narrowings, {} bytes of stack scratch",
            self.vertices,
            self.markers,
            self.coefficient_rows,
            self.influences,
            self.max_influences,
            self.multiply_adds,
            self.subtractions,
            self.narrowings,
            self.scratch_bytes
        )?;
        if self.frame_builds > 0 {
            write!(
                f,
                ", {} control-triangle frames, {} normalisations",
                self.frame_builds, self.normalisations
            )?;
        }
        Ok(())
    }
}

impl<'a> Rig<'a> {
    /// Load a rig from blob bytes: header, checksum, decoding and full validation. Never panics
    /// and never reads out of bounds, whatever the bytes; the work is linear in their length.
    pub fn from_bytes(bytes: &'a [u8]) -> Result<Self, LoadError> {
        let payload = format::open(bytes)?;
        Ok(Self {
            data: format::decode(payload)?,
        })
    }

    /// The decoded payload (borrowed sections).
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
        let mut rest = self.data.marker_names.0;
        core::iter::from_fn(move || {
            let (&len, tail) = rest.split_first()?;
            let (name, tail) = tail.split_at_checked(usize::from(len))?;
            rest = tail;
            core::str::from_utf8(name).ok()
        })
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
    pub fn deformer(&self) -> &Deformer<'a> {
        &self.data.deformer
    }

    /// Fractional bits of the stored weights (linear) or kernel values (RBF coefficients).
    pub fn weight_frac_bits(&self) -> u8 {
        match &self.data.deformer {
            Deformer::Linear(l) => l.weight_frac_bits,
            Deformer::RbfCoefficients(r) => r.weight_frac_bits,
            Deformer::PlanarBones(_) => format::PLANAR_WEIGHT_FRAC_BITS,
        }
    }

    /// The per-frame work of [`Self::deform`].
    pub fn cost(&self) -> Cost {
        let (v, m) = (self.vertex_count(), self.marker_count());
        let displacement_scratch = core::mem::size_of::<[[i32; 3]; MAX_MARKERS]>();
        match &self.data.deformer {
            Deformer::Linear(l) => {
                let influences = l.influences.0.len() / 4;
                Cost {
                    vertices: v,
                    markers: m,
                    influences,
                    max_influences: usize::from(l.max_influences),
                    coefficient_rows: 0,
                    multiply_adds: 3 * influences,
                    subtractions: 3 * m,
                    narrowings: 3 * v,
                    scratch_bytes: kernel::linear::SCRATCH_BYTES,
                    frame_builds: 0,
                    normalisations: 0,
                }
            }
            Deformer::RbfCoefficients(r) => {
                let k = usize::from(r.influences_per_vertex);
                let rows = r.row_shifts.0.len();
                let affine = if r.affine { 3 * 3 * v } else { 0 };
                Cost {
                    vertices: v,
                    markers: m,
                    influences: v * k,
                    max_influences: k,
                    coefficient_rows: rows,
                    multiply_adds: 3 * rows * m + 3 * v * k + affine,
                    subtractions: 3 * m,
                    narrowings: 3 * rows + 3 * v,
                    scratch_bytes: displacement_scratch
                        + core::mem::size_of::<[[i32; 3]; kernel::rbf::MAX_ROWS]>(),
                    frame_builds: 0,
                    normalisations: 0,
                }
            }
            Deformer::PlanarBones(p) => kernel::planar::cost(p, v, m),
        }
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

    /// [`Self::deform`], also reporting the control triangles of a planar-bones rig that were
    /// degenerate in this frame (collinear or coincident markers) and so kept their rest
    /// orientation. Always empty for the other deformers.
    pub fn deform_report(
        &self,
        markers: &[[i32; 3]],
        out: &mut [[i32; 3]],
    ) -> Result<DegenerateTriangles, FrameError> {
        if markers.len() != self.marker_count() {
            return Err(FrameError::MarkerCount {
                expected: self.marker_count(),
                found: markers.len(),
            });
        }
        if out.len() != self.vertex_count() {
            return Err(FrameError::OutputLength {
                expected: self.vertex_count(),
                found: out.len(),
            });
        }
        if let Deformer::PlanarBones(planar) = &self.data.deformer {
            return Ok(kernel::planar::deform(
                planar,
                self.data.marker_rest.0,
                markers,
                out,
            ));
        }
        match &self.data.deformer {
            Deformer::Linear(lin) => kernel::linear::deform(
                markers,
                self.data.marker_rest.0,
                self.data.vertex_rest.0,
                lin.influence_counts.0,
                lin.influences.0,
                lin.weight_frac_bits,
                out,
            ),
            Deformer::RbfCoefficients(rbf) => {
                let mut displacements = [[0i32; 3]; MAX_MARKERS];
                for ((d, m), r) in displacements
                    .iter_mut()
                    .zip(markers)
                    .zip(self.data.marker_rest.0.chunks_exact(POSITION_BYTES))
                {
                    let rest = read_position(r);
                    for c in 0..3 {
                        d[c] = m[c].saturating_sub(rest[c]);
                    }
                }
                let mut table = [[0i32; 3]; kernel::rbf::MAX_ROWS];
                let m = self.marker_count();
                kernel::rbf::coefficients(rbf, m, &displacements, &mut table);
                kernel::rbf::deform(rbf, m, &table, self.data.vertex_rest.0, out);
            }
            Deformer::PlanarBones(_) => {}
        }
        Ok(DegenerateTriangles::default())
    }

    /// The capture stages, if the rig was baked with them.
    pub fn stages(&self) -> Option<&Stages<'a>> {
        self.data.stages.as_ref()
    }

    /// Play one captured frame through the capture stages and the deformer: `actor` holds the
    /// actor's raw markers in actor units (Q8.24, [`Stages::actor_space`]; `None` where a marker
    /// is missing), one per rig marker; `out` receives one position per vertex (Q8.24 rig
    /// units). The report says which markers were rejected, rebuilt or held and how the head
    /// motion was found. `state` carries the last good values from frame to frame.
    pub fn play(
        &self,
        state: &mut PlayState,
        actor: &[Option<[i32; 3]>],
        out: &mut [[i32; 3]],
    ) -> Result<FrameReport, FrameError> {
        let stages = self.data.stages.as_ref().ok_or(FrameError::NoStages)?;
        let m = self.marker_count();
        if actor.len() != m {
            return Err(FrameError::MarkerCount {
                expected: m,
                found: actor.len(),
            });
        }
        if out.len() != self.vertex_count() {
            return Err(FrameError::OutputLength {
                expected: self.vertex_count(),
                found: out.len(),
            });
        }
        let mut markers = [[0i32; 3]; MAX_MARKERS];
        let report = stages.solve(state, actor, &mut markers[..m]);
        self.deform(&markers[..m], out)?;
        Ok(report)
    }
}
