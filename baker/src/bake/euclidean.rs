//! The straight-line strategy: the dense RBF solved on Euclidean distances in asset units, the
//! papers' method, baked into the RBF or linear deformer.

use facebake_runtime::Space;

use super::BakeError;
use crate::deformer::rbf::DenseRbf;
use crate::deformer::{self, DeformerKind, DeformerOutput};
use crate::options::BakeOptions;
use crate::rbf::RbfSystem;
use crate::sparsify;

/// What the Euclidean strategy hands back.
pub(super) struct EuclideanBake {
    pub(super) output: DeformerOutput,
    pub(super) condition: f64,
    pub(super) reference: DenseRbf,
}

/// The RBF or linear deformer of `vertices` driven by markers resting at `rest`.
pub(super) fn bake(
    vertices: &[[f64; 3]],
    rest: &[[f64; 3]],
    stiffness: &[f64],
    options: &BakeOptions,
    space: &Space,
) -> Result<EuclideanBake, BakeError> {
    let dense_radial = options
        .radial
        .resolve(rest, options.width, options.width_factor);
    let dense_system = RbfSystem::new(rest, dense_radial, options.affine, stiffness)?;
    let condition = dense_system.condition();
    let output = match options.deformer {
        DeformerKind::Linear => {
            let diagonal = 2.0 * f64::from(space.half_extent) * 3f64.sqrt();
            let covariance = sparsify::prior_covariance(rest, options.prior_length * diagonal);
            deformer::linear::bake(
                vertices.iter().map(|v| dense_system.weights_at(v)),
                options.k,
                options.refit,
                &covariance,
            )?
        }
        DeformerKind::Rbf => rbf_deformer(vertices, rest, stiffness, options, space)?,
        DeformerKind::Planar => {
            return Err(BakeError::Input(
                "planar bones blend control-triangle frames, not an RBF".into(),
            ))
        }
    };
    let reference = DenseRbf::new(dense_system, vertices.to_vec(), rest.to_vec());
    Ok(EuclideanBake {
        output,
        condition,
        reference,
    })
}

/// The RBF deformer: the system solved again in rig units, where the runtime evaluates (the
/// affine part is then β · rest(v)).
fn rbf_deformer(
    vertices: &[[f64; 3]],
    rest: &[[f64; 3]],
    stiffness: &[f64],
    options: &BakeOptions,
    space: &Space,
) -> Result<DeformerOutput, BakeError> {
    let h = f64::from(space.half_extent);
    let centres: Vec<[f64; 3]> = rest
        .iter()
        .map(|p| crate::space::to_rig_units(space, p))
        .collect();
    let radial =
        options
            .radial
            .resolve(&centres, options.width.map(|w| w / h), options.width_factor);
    let system = RbfSystem::new(&centres, radial, options.affine, stiffness)?;
    let n = centres.len();
    let phi_rows = vertices.iter().map(|p| {
        let v = crate::space::to_rig_units(space, p);
        (0..n)
            .map(|i| {
                system
                    .kernel()
                    .phi(i, crate::mesh::distance(&v, &centres[i]))
            })
            .collect()
    });
    Ok(deformer::rbf::bake(phi_rows, options.k.min(n), &system)?)
}
