//! The planar deformer: planar bones (paper 000 §4.1–4.2), K control-triangle transforms per
//! vertex. The control surface, regions and weights are built in [`crate::planar`].

use facebake_runtime::deformer::planar::{
    write_planar_influence, PlanarDeformer, PlanarInfluence, PLANAR_WEIGHT_FRAC_BITS,
};
use facebake_runtime::deformer::Deformer;
use facebake_runtime::format::records::{Bytes, PLANAR_INFLUENCE_BYTES};
use facebake_runtime::Space;

pub mod reference;

use super::{
    influence_counts, DeformerBytes, DeformerError, DeformerOutput, Section, SectionError,
};
use crate::planar::PlanarOptions;
use reference::PlanarReference;

/// The planar section, encoded: the control triangles, per vertex its influence count, and
/// the influence records.
pub struct PlanarBytes {
    triangles: Vec<u8>,
    triangle_count: u16,
    counts: Vec<u8>,
    records: Vec<u8>,
}

impl PlanarBytes {
    /// The section from the control `triangles` and each vertex's records (at most 64).
    fn new(triangles: &[[u8; 3]], rows: &[Vec<PlanarInfluence>]) -> Result<Self, SectionError> {
        let mut records = Vec::new();
        for r in rows.iter().flatten() {
            let b = write_planar_influence(r).ok_or_else(|| {
                SectionError(format!("control triangle {} out of range", r.triangle))
            })?;
            records.extend_from_slice(&b);
        }
        Ok(Self {
            triangles: triangles.iter().flatten().copied().collect(),
            triangle_count: u16::try_from(triangles.len())
                .map_err(|_| SectionError("too many control triangles".into()))?,
            counts: influence_counts(rows.iter().map(Vec::len))?,
            records,
        })
    }

    /// The runtime's section over these bytes.
    pub(super) fn section(&self) -> Section<'_> {
        Section {
            deformer: Deformer::Planar(PlanarDeformer {
                max_influences: self.counts.iter().copied().max().unwrap_or(0).max(1),
                triangle_count: self.triangle_count,
                triangles: Bytes(&self.triangles),
                influence_counts: Bytes(&self.counts),
                influences: Bytes(&self.records),
            }),
            influence_bytes: self.records.len(),
            influences: self.records.len() / PLANAR_INFLUENCE_BYTES,
        }
    }
}

/// What the planar bake built.
#[derive(Clone, Debug, serde::Serialize)]
pub struct PlanarSummary {
    /// Control triangles (marker indices).
    pub triangles: Vec<[usize; 3]>,
    /// Vertices within no bone's radius, which ride their closest bone alone.
    pub outside_radius: usize,
}

/// The planar deformer of `vertices` (mesh `faces`) driven by markers resting at `rest`, its
/// summary and its f64 reference (eqs 1–12 on the exact rest positions with the baked
/// influences).
pub(crate) fn bake(
    vertices: &[[f64; 3]],
    faces: &[[u32; 3]],
    rest: &[[f64; 3]],
    options: &PlanarOptions<'_>,
    space: &Space,
) -> Result<(DeformerOutput, PlanarSummary, PlanarReference), DeformerError> {
    let p = crate::planar::bake(vertices, faces, rest, options, |x| {
        crate::space::to_rig_units(space, x)
    })?;
    let triangles: Vec<[u8; 3]> = p.triangles.iter().map(|t| t.map(|m| m as u8)).collect();
    let summary = PlanarSummary {
        triangles: p.triangles.clone(),
        outside_radius: p.outside,
    };
    let reference = PlanarReference::new(vertices.to_vec(), rest.to_vec(), p.triangles, p.rows);
    let output = DeformerOutput {
        bytes: DeformerBytes::Planar(PlanarBytes::new(&triangles, &p.records)?),
        frac_bits: PLANAR_WEIGHT_FRAC_BITS,
        dropped: p.dropped,
        rounding: p.max_weight_rounding,
        matrix_rounding: 0.0,
    };
    Ok((output, summary, reference))
}
