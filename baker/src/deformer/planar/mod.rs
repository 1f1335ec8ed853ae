//! The planar deformer: planar bones (paper 000 §4.1–4.2), K control-triangle transforms per
//! vertex. The control surface, regions and weights are built in [`crate::planar`].

use facebake_runtime::Space;

pub mod reference;

use super::DeformerOutput;
use crate::blob::DeformerBytes;
use crate::planar::{PlanarError, PlanarOptions};
use reference::PlanarReference;

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
) -> Result<(DeformerOutput, PlanarSummary, PlanarReference), PlanarError> {
    let p = crate::planar::bake(vertices, faces, rest, options, |x| {
        crate::space::to_rig_units(space, x)
    })?;
    let triangles = p.triangles.iter().map(|t| t.map(|m| m as u8)).collect();
    let summary = PlanarSummary {
        triangles: p.triangles.clone(),
        outside_radius: p.outside,
    };
    let reference = PlanarReference::new(vertices.to_vec(), rest.to_vec(), p.triangles, p.rows);
    let output = DeformerOutput {
        bytes: DeformerBytes::Planar {
            triangles,
            rows: p.records,
        },
        frac_bits: facebake_runtime::format::PLANAR_WEIGHT_FRAC_BITS,
        dropped: p.dropped,
        rounding: p.max_weight_rounding,
        matrix_rounding: 0.0,
    };
    Ok((output, summary, reference))
}
