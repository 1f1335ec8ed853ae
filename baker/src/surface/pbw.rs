//! Proximity-based weighting (paper 002 §2.2.1): each vertex follows its dominant marker (the
//! nearest along the surface) and that marker's neighbours, weighted by sines of their geodesic
//! distances over a reach `d` from the two neighbours best aligned with the vertex (eqs 5–7) and
//! by inverse squared distance (eq 8). Paper 002 measures eq 8's distances in the current frame;
//! the bake uses the rest-pose geodesic distances so the weights are fixed (linear) and bake to
//! the runtime's linear deformer. The global RBF and the α blend (eqs 9–11) are in
//! [`crate::bake()`]. Paper 002's global RBF (eqs 9–10) is a multiquadric on Euclidean
//! distances; across a closed mouth it interpolates the jaw's drop between lip markers a few
//! millimetres apart, and on FaceCap's truth (JawMoCap layout, `--masks`) it threw the nose out
//! by up to 80 mm in the jaw open (max error 86 mm, edges stretched 14.21×, 357 flipped
//! triangles). The global part here is the geodesic RBF with the bake's radial function (the
//! exponential by default): max 12.5 mm, 2.89×, 13 flips, lips off by 10.4 mm instead of 10.7;
//! static drift 0.54 instead of 0.42 mm and eyelids 1.7 instead of 1.3 mm (`--test structure`).

use nalgebra::DMatrix;

use crate::mesh::{distance, dot, norm, sub};

/// Neighbours of each marker: the markers this many nearest along the surface.
pub const NEIGHBOURS: usize = 6;

/// Each marker's [`NEIGHBOURS`] nearest other markers under `between` (symmetrised).
pub fn neighbours(between: &DMatrix<f64>) -> Vec<Vec<usize>> {
    let n = between.nrows();
    (0..n)
        .map(|i| {
            let mut others: Vec<usize> = (0..n).filter(|&j| j != i).collect();
            let d = |j: usize| 0.5 * (between[(i, j)] + between[(j, i)]);
            others.sort_by(|&a, &b| d(a).total_cmp(&d(b)));
            others.truncate(NEIGHBOURS);
            others
        })
        .collect()
}

/// The local PBW weights of a vertex at `p` whose geodesic distance to marker `i` is `d[i]`
/// (summing to one; all on the dominant marker when no neighbour lies ahead of it).
pub fn local_weights(
    p: &[f64; 3],
    d: &[f64],
    markers: &[[f64; 3]],
    neighbours: &[Vec<usize>],
) -> Vec<f64> {
    let n = markers.len();
    let mut out = vec![0.0; n];
    let Some(f1) = (0..n).min_by(|&a, &b| d[a].total_cmp(&d[b])) else {
        return out;
    };
    let to_p = sub(p, &markers[f1]);
    let len_p = norm(&to_p);
    // Step 2: the two smallest angles θ between F1P and F1Fi below π/2, as cosines.
    let mut ahead: Vec<(f64, usize)> = neighbours[f1]
        .iter()
        .map(|&i| {
            let to_i = sub(&markers[i], &markers[f1]);
            let cos = dot(&to_p, &to_i) / (len_p * norm(&to_i)).max(f64::MIN_POSITIVE);
            (cos, i)
        })
        .filter(|&(cos, _)| cos > 0.0)
        .collect();
    ahead.sort_by(|a, b| b.0.total_cmp(&a.0));
    ahead.truncate(2);
    if ahead.is_empty() || d[f1] <= 0.0 {
        out[f1] = 1.0;
        return out;
    }
    // Step 3, eq 5: the reach d from the Euclidean marker distances d_1i.
    let d12 = |i: usize| distance(&markers[f1], &markers[i]);
    let reach = if ahead.len() == 2 {
        (d12(ahead[0].1) * ahead[0].0 + d12(ahead[1].1) * ahead[1].0) / (ahead[0].0 + ahead[1].0)
    } else {
        d12(ahead[0].1) / ahead[0].0
    };
    // Steps 4, eqs 6–7 (w = cos(π/2 (1 − d_ip/d)), held at 1 beyond d), then eq 8.
    let mut total = 0.0;
    for &i in std::iter::once(&f1).chain(&neighbours[f1]) {
        if !d[i].is_finite() || d[i] <= 0.0 {
            continue;
        }
        let x = (d[i] / reach).min(1.0);
        let w = (std::f64::consts::FRAC_PI_2 * (1.0 - x)).cos();
        out[i] = w / (d[i] * d[i]);
        total += out[i];
    }
    if total > 0.0 {
        out.iter_mut().for_each(|w| *w /= total);
    } else {
        out[f1] = 1.0;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dominant_marker_leads_and_weights_sum_to_one() {
        let markers = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [-1.0, 0.0, 0.0],
        ];
        let between = DMatrix::from_fn(4, 4, |i, j| distance(&markers[i], &markers[j]));
        let nb = neighbours(&between);
        assert_eq!(nb[0].len(), 3);
        let p = [0.2, 0.1, 0.0];
        let d: Vec<f64> = markers.iter().map(|m| distance(&p, m)).collect();
        let w = local_weights(&p, &d, &markers, &nb);
        assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-12);
        let top = (0..4).max_by(|&a, &b| w[a].total_cmp(&w[b])).unwrap();
        assert_eq!(top, 0, "{w:?}");
        assert!(
            w[1] > w[3],
            "the marker ahead of the vertex counts more: {w:?}"
        );
        // On a marker: all weight there.
        let d0: Vec<f64> = markers.iter().map(|m| distance(&markers[2], m)).collect();
        assert_eq!(local_weights(&markers[2], &d0, &markers, &nb)[2], 1.0);
    }
}
