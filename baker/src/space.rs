//! The rig space of a mesh, and asset units to rig units in f64: where the runtime evaluates.

use facebake_runtime::Space;

/// The rig space for a mesh: centre of its bounds and half its largest side, enlarged by 2⁻¹⁰
/// so every vertex fits Q0.15 after rounding to f32.
pub fn space_for(positions: &[[f64; 3]]) -> Space {
    let (lo, hi) = crate::model::bounds(positions.iter().copied());
    let centre = [0, 1, 2].map(|c| (0.5 * (lo[c] + hi[c])) as f32);
    let half = (0..3)
        .map(|c| 0.5 * (hi[c] - lo[c]))
        .fold(0.0, f64::max)
        .max(f64::MIN_POSITIVE);
    Space {
        centre,
        half_extent: (half * (1.0 + 1.0 / 1024.0)) as f32,
    }
}

/// A point in rig units (f64, unquantised): `(p − centre) / half_extent`.
pub fn to_rig_units(space: &Space, p: &[f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|c| (p[c] - f64::from(space.centre[c])) / f64::from(space.half_extent))
}
