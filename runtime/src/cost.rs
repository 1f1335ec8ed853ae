//! [`Cost`]: the per-frame work of a rig, as every deformer states it. A leaf: it imports
//! nothing from the crate, so every deformer can build one.

/// The work one call to [`crate::Rig::deform`] does. It depends only on the rig, never on the markers.
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
    /// Coefficient rows computed per frame (RBF rigs; 0 for linear rigs).
    pub coefficient_rows: usize,
    /// Multiply-adds: 3 per influence, plus for linear rigs 6 per derived projection and 3 per
    /// derived mean (`i32` accumulators), for RBF rigs (widening into `i64`) 3 per coefficient
    /// row and marker (stage 1) and 9 per vertex for the affine part.
    /// Planar rigs: 12 per influence (the region transform and the weighted sum), 3 more per
    /// apex influence, and 36 per control-triangle frame (cross products and the degeneracy
    /// test), besides the normalisations counted in [`Self::normalisations`].
    pub multiply_adds: usize,
    /// Saturating subtractions forming marker displacements (3 per marker).
    pub subtractions: usize,
    /// Round-shift-saturate steps narrowing an accumulator to `i32`.
    pub narrowings: usize,
    /// Stack the call uses for marker displacements (and, for RBF rigs, the
    /// coefficients), in bytes.
    pub scratch_bytes: usize,
    /// Control-triangle frames built per frame (planar rigs; 0 otherwise). A triangle that is
    /// degenerate in a frame builds its rest frame too, so at most twice this many are built.
    pub frame_builds: usize,
    /// Vector normalisations (integer square root and three divisions) per frame: four per
    /// frame build, one per apex-region influence (planar rigs; 0 otherwise).
    pub normalisations: usize,
    /// The work of one call to [`crate::Rig::normals`], which a caller makes after `deform`
    /// when it wants normals (not part of the counts above, and not in this type's `Display`:
    /// [`NormalsCost`] has its own).
    pub normals: NormalsCost,
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

/// The work one call to [`crate::Rig::normals`] does; fixed by the rig.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct NormalsCost {
    /// Normals written (one per vertex).
    pub vertices: usize,
    /// Fan corners evaluated: each an edge and (but a fan's first) a cross product with the
    /// edge before it.
    pub corners: usize,
    /// Widening multiplies: 6 per cross product, 3 per normalisation (the squared length) and 3
    /// more per normalisation (scaling by the root).
    pub multiplies: usize,
    /// Normalisations through the integer 1/√ (a table look-up and one Newton step each): one per vertex with a
    /// fan.
    pub normalisations: usize,
    /// Normals copied to welded (split) vertices.
    pub welds: usize,
}

impl core::fmt::Display for NormalsCost {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(
            f,
            "{} normals: {} fan corners, {} multiplies, {} normalisations, {} welded copies",
            self.vertices, self.corners, self.multiplies, self.normalisations, self.welds
        )
    }
}
