//! The RBF deformer: the papers' per-frame RBF solve, made cheap and local.
//!
//! ```text
//! D[j]   = sat( m[j] − m_rest[j] )                       per marker (displacements)
//! c[i]   = round( Σ_j M[i,j] · D[j] / 2^s_i )            per coefficient row i (stage 1)
//! out[v] = sat( rest[v] + β₀ + round( Σ_k φ[v,k] · c[idx[v,k]] / 2^F )
//!                            + round( (βx·rest_x + βy·rest_y + βz·rest_z) / 2^24 ) )   (stage 2)
//! ```
//!
//! Stage 2 adds its four terms in `i64` and saturates once, to `i32`: the radial sum is below
//! 2⁶⁰ (at most 64 products of a 24-bit φ and a 32-bit coefficient), the affine sum below 2⁵⁷,
//! rest and β₀ below 2³¹, so nothing before the final clamp can overflow.
//!
//! `M` is the first `n` columns of the inverse RBF system matrix, baked once; `D` are the marker
//! displacements, each coordinate a saturating `i32` subtraction. Stage 1 is `rows × markers` `i16 × i32 → i64` multiply-adds per axis; stage 2 is
//! K multiply-adds per vertex and axis plus three for the affine part. Products in stage 1 are
//! below 2⁴⁶ and at most 256 of them are summed, so the `i64` accumulator cannot overflow; stage 2
//! is bounded as in [`crate::fixed`]. No branch depends on marker data.

use serde::{Deserialize, Serialize};

use crate::cost::{Cost, NormalsCost};
use crate::deformer::contract::{check, DeformerSection, DegenerateTriangles, Shared};
use crate::fixed::{
    mul_acc, round_shift_bounded, MAX_ROW_SHIFT, MAX_WEIGHT_FRAC_BITS, MIN_ROW_SHIFT,
    POS_FRAC_BITS,
};
use crate::error::{expect_len, LoadError, Section};
use crate::records::{
    read_influence, read_matrix_entry, read_position, read_rest, Bytes, INFLUENCE_BYTES,
    MATRIX_ENTRY_BYTES, MAX_MARKERS, POSITION_BYTES, REST_BYTES, ROW_SHIFT_BYTES,
};

/// The RBF deformer's section: a small dense map from marker displacements to RBF coefficients
/// per frame, then K radial terms per vertex (layout: [`crate::format::RigData`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct RbfDeformer<'a> {
    /// Influences of every vertex (K), in [1, 64].
    pub influences_per_vertex: u8,
    /// Fractional bits of the stored radial values φ, in [8, 22].
    pub weight_frac_bits: u8,
    /// Whether the four affine rows (β₀, βx, βy, βz) follow the radial rows.
    pub affine: bool,
    /// Per coefficient row: its scale exponent s (entries are `q · 2^−s`), `u8` each.
    #[serde(borrow)]
    pub row_shifts: Bytes<'a>,
    /// The map M: rows × markers, `i16` LE.
    #[serde(borrow)]
    pub matrix: Bytes<'a>,
    /// K packed influences per vertex (`u32` LE each): radial centre index and φ.
    #[serde(borrow)]
    pub influences: Bytes<'a>,
}

/// Number of affine rows (β₀, βx, βy, βz) after the radial rows, when present.
const AFFINE_ROWS: usize = 4;

/// The rounding half of the affine sum, which has 24 fractional bits more than a position.
const AFFINE_HALF: i64 = 1 << (POS_FRAC_BITS - 1);

/// Coefficient rows the scratch table holds: one per marker plus the four affine rows.
const MAX_ROWS: usize = MAX_MARKERS + AFFINE_ROWS;

impl RbfDeformer<'_> {
    /// Coefficient rows: one per marker, plus the affine rows.
    fn rows(&self, markers: usize) -> usize {
        markers + if self.affine { AFFINE_ROWS } else { 0 }
    }
}

impl<'a> RbfDeformer<'a> {
    /// The section for vertices `first .. first + len` only (see [`super::Deformer::vertex_range`]):
    /// every vertex has `influences_per_vertex` records.
    pub(crate) fn vertex_range(&self, first: usize, len: usize) -> Self {
        let per_vertex = INFLUENCE_BYTES * usize::from(self.influences_per_vertex);
        Self {
            influences: Bytes(
                self.influences
                    .0
                    .get(first * per_vertex..(first + len) * per_vertex)
                    .unwrap_or(&[]),
            ),
            ..*self
        }
    }
}

impl DeformerSection for RbfDeformer<'_> {
    fn validate(&self, rig: &Shared<'_>) -> Result<(), LoadError> {
        let markers = rig.markers;
        check::max_influences(self.influences_per_vertex)?;
        check::weight_format(self.weight_frac_bits, MAX_WEIGHT_FRAC_BITS)?;
        let k = usize::from(self.influences_per_vertex);
        let rows = self.rows(markers);
        let row_bytes = MATRIX_ENTRY_BYTES * markers;
        expect_len(Section::RowShifts, self.row_shifts, rows, ROW_SHIFT_BYTES)?;
        expect_len(Section::Matrix, self.matrix, rows, row_bytes)?;
        expect_len(
            Section::Influences,
            self.influences,
            rig.vertices,
            INFLUENCE_BYTES.saturating_mul(k),
        )?;
        for (row, (&shift, entries)) in self
            .row_shifts
            .0
            .iter()
            .zip(self.matrix.0.chunks_exact(row_bytes))
            .enumerate()
        {
            if !(MIN_ROW_SHIFT..=MAX_ROW_SHIFT).contains(&shift) {
                return Err(LoadError::BadRowShift { row, shift });
            }
            let sum: i64 = entries
                .chunks_exact(MATRIX_ENTRY_BYTES)
                .map(|q| i64::from(read_matrix_entry(q)))
                .sum();
            let want = if self.affine && row == markers {
                1i64 << shift
            } else {
                0
            };
            if sum != want {
                return Err(LoadError::CoefficientsNotNormalised { row });
            }
        }
        for (vertex, words) in self
            .influences
            .0
            .chunks_exact(INFLUENCE_BYTES * k)
            .enumerate()
        {
            for w in words.chunks_exact(INFLUENCE_BYTES) {
                let (marker, _) = read_influence(w);
                if usize::from(marker) >= markers {
                    return Err(LoadError::MarkerIndexOutOfRange { vertex, marker });
                }
            }
        }
        Ok(())
    }

    fn cost(&self, rig: &Shared<'_>) -> Cost {
        let (v, m) = (rig.vertices, rig.markers);
        let k = usize::from(self.influences_per_vertex);
        let rows = self.row_shifts.0.len() / ROW_SHIFT_BYTES;
        let affine = if self.affine { 3 * 3 * v } else { 0 };
        Cost {
            vertices: v,
            markers: m,
            influences: v * k,
            max_influences: k,
            coefficient_rows: rows,
            multiply_adds: 3 * rows * m + 3 * v * k + affine,
            subtractions: 3 * m,
            narrowings: 3 * rows + 3 * v,
            scratch_bytes: core::mem::size_of::<[[i32; 3]; MAX_MARKERS]>()
                + core::mem::size_of::<[[i32; 3]; MAX_ROWS]>(),
            frame_builds: 0,
            normalisations: 0,
            normals: NormalsCost::default(),
        }
    }

    fn weight_frac_bits(&self) -> u8 {
        self.weight_frac_bits
    }

    fn deform(
        &self,
        rig: &Shared<'_>,
        markers: &[[i32; 3]],
        out: &mut [[i32; 3]],
    ) -> DegenerateTriangles {
        let displacements = displacements(markers, rig.marker_rest);
        let mut table = [[0i32; 3]; MAX_ROWS];
        coefficients(self, rig.markers, &displacements, &mut table);
        radial_terms(self, rig.markers, &table, rig.vertex_rest, out);
        DegenerateTriangles::default()
    }
}

/// The RBF deformer's per-frame work in a [`crate::FrameTable`]: this frame's coefficients.
pub(crate) type Prepared = [[i32; 3]; MAX_ROWS];

impl RbfDeformer<'_> {
    /// The per-frame marker work of [`DeformerSection::deform`] for `markers` (one per rig
    /// marker, the caller checked), for [`Self::deform_prepared`].
    pub(crate) fn prepare(&self, rig: &Shared<'_>, markers: &[[i32; 3]]) -> Prepared {
        let displacements = displacements(markers, rig.marker_rest);
        let mut table = [[0i32; 3]; MAX_ROWS];
        coefficients(self, rig.markers, &displacements, &mut table);
        table
    }

    /// The vertices of `rig` into `out` (one entry each, the caller checked) from this frame's
    /// `prepared` coefficients: the integers [`DeformerSection::deform`] writes.
    pub(crate) fn deform_prepared(&self, rig: &Shared<'_>, prepared: &Prepared, out: &mut [[i32; 3]]) {
        radial_terms(self, rig.markers, prepared, rig.vertex_rest, out);
    }
}

/// The displacement of every marker from its rest position (Q8.24, saturating), in marker
/// order; later entries stay zero.
fn displacements(markers: &[[i32; 3]], marker_rest: &[u8]) -> [[i32; 3]; MAX_MARKERS] {
    let mut displacements = [[0i32; 3]; MAX_MARKERS];
    for ((d, m), r) in displacements
        .iter_mut()
        .zip(markers)
        .zip(marker_rest.chunks_exact(POSITION_BYTES))
    {
        let rest = read_position(r);
        for c in 0..3 {
            d[c] = m[c].saturating_sub(rest[c]);
        }
    }
    displacements
}

/// Stage 1: the coefficients of this frame, one per row, from the marker displacements.
fn coefficients(
    rbf: &RbfDeformer<'_>,
    markers: usize,
    displacements: &[[i32; 3]; MAX_MARKERS],
    table: &mut [[i32; 3]; MAX_ROWS],
) {
    let rows = rbf
        .row_shifts
        .0
        .iter()
        .zip(rbf.matrix.0.chunks_exact(MATRIX_ENTRY_BYTES * markers));
    for (c, (&shift, entries)) in table.iter_mut().zip(rows) {
        let mut acc = [0i64; 3];
        for (q, d) in entries
            .chunks_exact(MATRIX_ENTRY_BYTES)
            .zip(displacements.iter())
        {
            let q = i32::from(i16::from_le_bytes([q[0], q[1]]));
            acc[0] = mul_acc(acc[0], q, d[0]);
            acc[1] = mul_acc(acc[1], q, d[1]);
            acc[2] = mul_acc(acc[2], q, d[2]);
        }
        *c = acc.map(|a| round_shift_bounded(a, u32::from(shift)));
    }
}

/// Stage 2: K radial terms and the affine part per vertex.
fn radial_terms(
    rbf: &RbfDeformer<'_>,
    markers: usize,
    table: &[[i32; 3]; MAX_ROWS],
    rest: &[u8],
    out: &mut [[i32; 3]],
) {
    let frac = u32::from(rbf.weight_frac_bits);
    let half = 1i64 << (frac - 1);
    let k = usize::from(rbf.influences_per_vertex);
    // Without the affine rows these stay zero and add nothing.
    let (beta0, beta) = if rbf.affine {
        (
            table[markers],
            [table[markers + 1], table[markers + 2], table[markers + 3]],
        )
    } else {
        ([0; 3], [[0; 3]; 3])
    };
    let vertices = out
        .iter_mut()
        .zip(rest.chunks_exact(REST_BYTES))
        .zip(rbf.influences.0.chunks_exact(INFLUENCE_BYTES * k));
    for ((o, r), words) in vertices {
        let mut acc = [0i64; 3];
        for w in words.chunks_exact(INFLUENCE_BYTES) {
            let (centre, phi) = read_influence(w);
            // A u8 index into a 260-entry table: in range by construction.
            let c = &table[usize::from(centre)];
            acc[0] = mul_acc(acc[0], phi, c[0]);
            acc[1] = mul_acc(acc[1], phi, c[1]);
            acc[2] = mul_acc(acc[2], phi, c[2]);
        }
        let rest_v = read_rest(r);
        for c in 0..3 {
            // Affine: Σ_a β_a · rest_a, with rest in Q8.24 and |rest| ≤ 2²⁴.
            let mut lin = 0i64;
            for (b, &x) in beta.iter().zip(&rest_v) {
                lin = mul_acc(lin, b[c], x);
            }
            let total = i64::from(rest_v[c])
                + i64::from(beta0[c])
                + ((acc[c] + half) >> frac)
                + ((lin + AFFINE_HALF) >> POS_FRAC_BITS);
            o[c] = total.clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32;
        }
    }
}
