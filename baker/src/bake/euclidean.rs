//! The straight-line strategy: the dense RBF solved on Euclidean distances in asset units, the
//! papers' method, for the linear deformer; the RBF deformer's system solved again in rig units.

use facebake_runtime::Space;

use crate::deformer::rbf::DenseRbf;
use crate::deformer::{self, DeformerError, DeformerOutput};
use crate::options::BakeOptions;
use crate::rbf::{RbfSystem, SolveError};
use crate::sparsify;

/// The dense RBF system of markers resting at `rest` (asset units).
pub(super) fn dense_system(
    rest: &[[f64; 3]],
    stiffness: &[f64],
    options: &BakeOptions,
) -> Result<RbfSystem, SolveError> {
    let radial = options
        .radial
        .resolve(rest, options.width, options.width_factor);
    RbfSystem::new(rest, radial, options.affine, stiffness)
}

/// The linear deformer of `vertices`: each vertex's dense weights under `system`, re-fitted
/// under the smooth-motion prior.
pub(super) fn linear(
    vertices: &[[f64; 3]],
    rest: &[[f64; 3]],
    system: &RbfSystem,
    options: &BakeOptions,
    space: &Space,
) -> Result<DeformerOutput, DeformerError> {
    let diagonal = 2.0 * f64::from(space.half_extent) * 3f64.sqrt();
    let covariance = sparsify::prior_covariance(rest, options.prior_length * diagonal);
    deformer::linear::bake(
        vertices.iter().map(|v| system.weights_at(v)),
        &[],
        [0.0, 1.0, 0.0],
        &[],
        [0.0, 0.0, 1.0],
        &[],
        None,
        options.k,
        options.refit,
        &covariance,
    )
}

/// The RBF deformer: the system solved again in rig units, where the runtime evaluates (the
/// affine part is then β · rest(v)).
pub(super) fn rbf(
    vertices: &[[f64; 3]],
    rest: &[[f64; 3]],
    stiffness: &[f64],
    options: &BakeOptions,
    space: &Space,
) -> Result<DeformerOutput, DeformerError> {
    let h = f64::from(space.half_extent);
    let centres: Vec<[f64; 3]> = rest
        .iter()
        .map(|p| crate::space::to_rig_units(space, p))
        .collect();
    let radial =
        options
            .radial
            .resolve(&centres, options.width.map(|w| w / h), options.width_factor);
    let system =
        RbfSystem::new(&centres, radial, options.affine, stiffness).map_err(DeformerError::from)?;
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
    deformer::rbf::bake(
        phi_rows,
        options.k.min(n),
        &system,
        &system.coefficient_map(),
    )
}

/// The papers' dense reference over `vertices`.
pub(super) fn reference(system: RbfSystem, vertices: &[[f64; 3]], rest: &[[f64; 3]]) -> DenseRbf {
    DenseRbf::new(system, vertices.to_vec(), rest.to_vec())
}
