//! Rigid head-motion estimation (paper 003 §2, paper 000 §5.1): the rotation and translation that
//! carry the head markers of the neutral frame onto a frame, so the frame can be brought back into
//! the neutral head's space and only facial motion remains.
//!
//! * [`kabsch`]: least squares over any n ≥ 3 markers (Kabsch/Horn via SVD), reflection-safe.
//! * [`three_point`]: paper 003's translation-invariant linear method (eqs 1–3): unit edge vectors
//!   m̂₁, m̂₂ of three markers plus the pseudo-correspondence m̂₃ = m̂₁ × m̂₂ give R by one 3 × 3
//!   solve, then t by substitution. As the paper states it, R is not forced to be orthonormal.
//! * [`most_rigid_subset`]: when the head markers are not named, the markers whose mutual
//!   distances vary least over a neutral range.

use nalgebra::{Matrix3, Vector3};

/// A rigid motion `p ↦ R p + t`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RigidTransform {
    /// Rotation R.
    pub rotation: Matrix3<f64>,
    /// Translation t.
    pub translation: Vector3<f64>,
}

/// The head markers cannot determine a rigid motion.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum RigidError {
    /// Fewer than three point pairs.
    #[error("a rigid fit needs at least 3 markers, got {0}")]
    TooFewPoints(usize),
    /// The two point lists differ in length.
    #[error("{from} neutral markers but {to} frame markers")]
    LengthMismatch {
        /// Neutral markers.
        from: usize,
        /// Frame markers.
        to: usize,
    },
    /// The markers are (nearly) collinear or coincident, so the rotation is undetermined.
    #[error("the head markers are collinear or coincident; the rotation is undetermined")]
    Degenerate,
}

fn v(p: &[f64; 3]) -> Vector3<f64> {
    Vector3::new(p[0], p[1], p[2])
}

impl RigidTransform {
    /// The identity.
    pub fn identity() -> Self {
        Self {
            rotation: Matrix3::identity(),
            translation: Vector3::zeros(),
        }
    }

    /// `R p + t`.
    pub fn apply(&self, p: &[f64; 3]) -> [f64; 3] {
        let q = self.rotation * v(p) + self.translation;
        [q.x, q.y, q.z]
    }

    /// `R⁻¹ (p − t)`: a frame's point brought back into the neutral space (paper 003 eq 9).
    /// Uses Rᵀ, so it assumes R is a rotation (true for [`kabsch`]).
    pub fn apply_inverse(&self, p: &[f64; 3]) -> [f64; 3] {
        let q = self.rotation.transpose() * (v(p) - self.translation);
        [q.x, q.y, q.z]
    }

    /// Root-mean-square distance between the transformed `from` points and `to`.
    pub fn rms_residual(&self, from: &[[f64; 3]], to: &[[f64; 3]]) -> f64 {
        let sum: f64 = from
            .iter()
            .zip(to)
            .map(|(p, q)| crate::mesh::distance(&self.apply(p), q).powi(2))
            .sum();
        (sum / from.len().max(1) as f64).sqrt()
    }
}

fn check(from: &[[f64; 3]], to: &[[f64; 3]]) -> Result<(), RigidError> {
    if from.len() != to.len() {
        return Err(RigidError::LengthMismatch {
            from: from.len(),
            to: to.len(),
        });
    }
    if from.len() < 3 {
        return Err(RigidError::TooFewPoints(from.len()));
    }
    Ok(())
}

fn centroid(points: &[[f64; 3]]) -> Vector3<f64> {
    points.iter().map(v).sum::<Vector3<f64>>() / points.len() as f64
}

/// The least-squares rigid motion carrying `from` onto `to` (n ≥ 3, not collinear).
/// Reflection-safe: the result is always a proper rotation (det R = +1).
pub fn kabsch(from: &[[f64; 3]], to: &[[f64; 3]]) -> Result<RigidTransform, RigidError> {
    check(from, to)?;
    let (cf, ct) = (centroid(from), centroid(to));
    let mut h = Matrix3::zeros();
    for (p, q) in from.iter().zip(to) {
        h += (v(p) - cf) * (v(q) - ct).transpose();
    }
    rotation_of(h, cf, ct)
}

/// [`kabsch`] with a weight per pair (finite, ≥ 0, not all 0): the rigid motion minimising
/// Σ wᵢ |R pᵢ + t − qᵢ|², centroids weighted. The points of positive weight must not be
/// collinear.
pub fn weighted_kabsch(
    from: &[[f64; 3]],
    to: &[[f64; 3]],
    weights: &[f64],
) -> Result<RigidTransform, RigidError> {
    check(from, to)?;
    let total: f64 = weights.iter().sum();
    if weights.len() != from.len() || !(total > 0.0 && total.is_finite()) {
        return Err(RigidError::Degenerate);
    }
    let mean = |points: &[[f64; 3]]| {
        points
            .iter()
            .zip(weights)
            .map(|(p, &w)| v(p) * w)
            .sum::<Vector3<f64>>()
            / total
    };
    let (cf, ct) = (mean(from), mean(to));
    let mut h = Matrix3::zeros();
    for ((p, q), &w) in from.iter().zip(to).zip(weights) {
        h += (v(p) - cf) * (v(q) - ct).transpose() * w;
    }
    rotation_of(h, cf, ct)
}

/// The proper rotation maximising tr(R H) for the cross-covariance `h` of points centred on
/// `cf` (from) and `ct` (to), and the translation that carries `cf` onto `ct`.
fn rotation_of(
    h: Matrix3<f64>,
    cf: Vector3<f64>,
    ct: Vector3<f64>,
) -> Result<RigidTransform, RigidError> {
    let svd = h.svd(true, true);
    let (Some(u), Some(vt)) = (svd.u, svd.v_t) else {
        return Err(RigidError::Degenerate);
    };
    // Two vanishing singular values: the points lie on a line (or on one point).
    let s = svd.singular_values;
    let scale = s.max().max(f64::MIN_POSITIVE);
    let mut sorted = [s[0], s[1], s[2]];
    sorted.sort_by(f64::total_cmp);
    if sorted[1] <= 1e-12 * scale {
        return Err(RigidError::Degenerate);
    }
    let vm = vt.transpose();
    let d = (vm * u.transpose()).determinant().signum();
    let rotation = vm * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, d)) * u.transpose();
    Ok(RigidTransform {
        rotation,
        translation: ct - rotation * cf,
    })
}

/// Paper 003's three-point linear method: R from the unit edge vectors m̂₁ = (p₂ − p₁)/|·|,
/// m̂₂ = (p₃ − p₂)/|·| and the pseudo-correspondence m̂₃ = m̂₁ × m̂₂ / |·| (eq 3 solved for each
/// row of R), then t = mean(p′ − R p) (eq 1).
pub fn three_point(from: &[[f64; 3]; 3], to: &[[f64; 3]; 3]) -> Result<RigidTransform, RigidError> {
    let frame = |p: &[[f64; 3]; 3]| -> Result<Matrix3<f64>, RigidError> {
        let m1 = (v(&p[1]) - v(&p[0]))
            .try_normalize(1e-15)
            .ok_or(RigidError::Degenerate)?;
        let m2 = (v(&p[2]) - v(&p[1]))
            .try_normalize(1e-15)
            .ok_or(RigidError::Degenerate)?;
        let m3 = m1
            .cross(&m2)
            .try_normalize(1e-12)
            .ok_or(RigidError::Degenerate)?;
        // Rows m̂ᵢᵀ, as in eq 3.
        Ok(Matrix3::from_rows(&[
            m1.transpose(),
            m2.transpose(),
            m3.transpose(),
        ]))
    };
    let (m, m_prime) = (frame(from)?, frame(to)?);
    // R m̂ᵢ = m̂′ᵢ for i = 1..3  ⇔  M Rᵀ = M′  ⇔  R = (M⁻¹ M′)ᵀ.
    let rotation = (m.try_inverse().ok_or(RigidError::Degenerate)? * m_prime).transpose();
    let translation = (0..3)
        .map(|i| v(&to[i]) - rotation * v(&from[i]))
        .sum::<Vector3<f64>>()
        / 3.0;
    Ok(RigidTransform {
        rotation,
        translation,
    })
}

/// Captures with more markers than this have their head-marker candidates pre-selected (see
/// [`most_rigid_subset`]); the exact search then looks at this many.
pub const RIGID_CANDIDATES: usize = 48;
/// Neighbours (nearest in the first frame) each marker's pre-selection score looks at.
pub const RIGID_NEIGHBOURS: usize = 12;

/// The `size` markers whose pairwise distances vary least (standard deviation over `frames`):
/// the best-scoring triple, then greedily the marker adding the least variation. Returns marker
/// indices in ascending order and the mean standard deviation of their pairwise distances.
///
/// The exact search is cubic in the markers, so with more than [`RIGID_CANDIDATES`] markers it
/// runs on that many candidates only: the markers with the smallest sum of their two least
/// varying distances to their [`RIGID_NEIGHBOURS`] nearest neighbours (a marker of a rigid
/// group has at least two rigid partners close by, as head markers on the forehead, the nose
/// bridge or a headband have; a group spread so thinly that each marker's nearest neighbours
/// all move may be missed), the neighbours found on a uniform grid. The
/// pre-selection costs O(n · [`RIGID_NEIGHBOURS`] · frames) plus the grid's cells visited,
/// linear for markers filling their box, more for markers bunched in a few cells; up to
/// [`RIGID_CANDIDATES`] markers the result is the exact search's.
pub fn most_rigid_subset(
    frames: &[Vec<[f64; 3]>],
    size: usize,
) -> Result<(Vec<usize>, f64), RigidError> {
    let n = frames.first().map_or(0, Vec::len);
    if size < 3 || n < size {
        return Err(RigidError::TooFewPoints(n.min(size)));
    }
    let candidates: Vec<usize> = if n <= RIGID_CANDIDATES.max(size) {
        (0..n).collect()
    } else {
        rigid_candidates(frames, RIGID_CANDIDATES.max(size))
    };
    let (chosen, spread) = exact_most_rigid(frames, &candidates, size)?;
    let mut chosen: Vec<usize> = chosen.iter().map(|&c| candidates[c]).collect();
    chosen.sort_unstable();
    Ok((chosen, spread))
}

/// Standard deviation over `frames` of the distance between markers `i` and `j`.
fn distance_spread(frames: &[Vec<[f64; 3]>], i: usize, j: usize) -> f64 {
    let d: Vec<f64> = frames
        .iter()
        .map(|f| crate::mesh::distance(&f[i], &f[j]))
        .collect();
    let mean = d.iter().sum::<f64>() / d.len() as f64;
    let var = d.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / d.len() as f64;
    var.sqrt()
}

/// The `count` markers most likely to belong to a rigid group (see [`most_rigid_subset`]), in
/// ascending score.
fn rigid_candidates(frames: &[Vec<[f64; 3]>], count: usize) -> Vec<usize> {
    let first = &frames[0];
    let grid = Grid::new(first);
    let mut score: Vec<(f64, usize)> = (0..first.len())
        .map(|i| {
            let mut spreads: Vec<f64> = grid
                .nearest(first, i, RIGID_NEIGHBOURS)
                .into_iter()
                .map(|j| distance_spread(frames, i, j))
                .collect();
            spreads.sort_by(f64::total_cmp);
            (spreads.iter().take(2).sum(), i)
        })
        .collect();
    score.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    score.truncate(count);
    score.into_iter().map(|(_, i)| i).collect()
}

/// A uniform grid over points' bounding box, about [`RIGID_NEIGHBOURS`] points a cell when they
/// fill the box, for nearest-neighbour queries that visit the cells in shells around the query.
struct Grid {
    lo: [f64; 3],
    cell: [f64; 3],
    side: usize,
    /// Point indices per cell, cells in x-major order.
    cells: Vec<Vec<usize>>,
}

impl Grid {
    fn new(points: &[[f64; 3]]) -> Self {
        let (lo, hi) = crate::model::bounds(points.iter().copied());
        let side = ((points.len() / RIGID_NEIGHBOURS).max(1) as f64)
            .cbrt()
            .ceil() as usize;
        let cell = [0, 1, 2].map(|k| ((hi[k] - lo[k]) / side as f64).max(f64::MIN_POSITIVE));
        let mut grid = Self {
            lo,
            cell,
            side,
            cells: vec![Vec::new(); side * side * side],
        };
        for (i, p) in points.iter().enumerate() {
            let c = grid.cell_of(p);
            grid.cells[(c[0] * side + c[1]) * side + c[2]].push(i);
        }
        grid
    }

    fn cell_of(&self, p: &[f64; 3]) -> [usize; 3] {
        [0, 1, 2].map(|k| (((p[k] - self.lo[k]) / self.cell[k]) as usize).min(self.side - 1))
    }

    /// The `m` points nearest to `points[i]` (itself excluded).
    fn nearest(&self, points: &[[f64; 3]], i: usize, m: usize) -> Vec<usize> {
        let centre = self.cell_of(&points[i]);
        let min_cell = self.cell.iter().copied().fold(f64::INFINITY, f64::min);
        let mut near: Vec<(f64, usize)> = Vec::with_capacity(m + 1);
        for r in 0..self.side {
            let range = |k: usize| centre[k].saturating_sub(r)..=(centre[k] + r).min(self.side - 1);
            for x in range(0) {
                for y in range(1) {
                    for z in range(2) {
                        let ring = [x, y, z]
                            .iter()
                            .zip(centre)
                            .map(|(&a, c)| a.abs_diff(c))
                            .max()
                            .unwrap_or(0);
                        if ring != r {
                            continue;
                        }
                        for &j in &self.cells[(x * self.side + y) * self.side + z] {
                            if j == i {
                                continue;
                            }
                            let d = crate::mesh::distance(&points[i], &points[j]);
                            if near.len() < m || d < near[near.len() - 1].0 {
                                let at = near.partition_point(|e| e.0 <= d);
                                near.insert(at, (d, j));
                                near.truncate(m);
                            }
                        }
                    }
                }
            }
            // Points in further shells are at least r cells away.
            if near.len() == m && near[m - 1].0 <= r as f64 * min_cell {
                break;
            }
        }
        near.into_iter().map(|(_, j)| j).collect()
    }
}

/// The exact search over the markers `among`; indices into `among`.
fn exact_most_rigid(
    frames: &[Vec<[f64; 3]>],
    among: &[usize],
    size: usize,
) -> Result<(Vec<usize>, f64), RigidError> {
    let n = among.len();
    let mut spread = vec![vec![0.0f64; n]; n];
    for i in 0..n {
        for j in i + 1..n {
            let s = distance_spread(frames, among[i], among[j]);
            spread[i][j] = s;
            spread[j][i] = s;
        }
    }
    let mut best = (f64::INFINITY, [0, 1, 2]);
    for a in 0..n {
        for b in a + 1..n {
            for c in b + 1..n {
                let s = spread[a][b] + spread[a][c] + spread[b][c];
                if s < best.0 {
                    best = (s, [a, b, c]);
                }
            }
        }
    }
    let mut chosen = best.1.to_vec();
    while chosen.len() < size {
        let next = (0..n)
            .filter(|m| !chosen.contains(m))
            .min_by(|&x, &y| {
                let cost = |m: usize| chosen.iter().map(|&c| spread[m][c]).sum::<f64>();
                cost(x).total_cmp(&cost(y))
            })
            .ok_or(RigidError::TooFewPoints(chosen.len()))?;
        chosen.push(next);
    }
    let pairs = chosen.len() * (chosen.len() - 1) / 2;
    let total: f64 = chosen
        .iter()
        .enumerate()
        .flat_map(|(k, &i)| chosen[k + 1..].iter().map(move |&j| (i, j)))
        .map(|(i, j)| spread[i][j])
        .sum();
    Ok((chosen, total / pairs as f64))
}

/// How much a least-squares rigid fit to the `head` points magnifies their measurement noise at
/// the `at` points, to first order: with independent isotropic noise of the same size on every
/// head point, the largest ratio over `at` of a compensated point's noise to one head point's.
/// The fit's translation carries 1/n of the noise; its rotation ω, whose covariance is the
/// noise's times M⁻¹ with M = Σ (|rᵢ|² I − rᵢ rᵢᵀ) (rᵢ the head points about their centroid),
/// moves a point at d from the centroid by ω × d. `None` when the head points are fewer than
/// three or collinear (M singular).
pub fn fit_noise_gain(head: &[[f64; 3]], at: &[[f64; 3]]) -> Option<f64> {
    if head.len() < 3 {
        return None;
    }
    let n = head.len() as f64;
    let c = head.iter().map(v).sum::<Vector3<f64>>() / n;
    let m = head.iter().fold(Matrix3::zeros(), |m, p| {
        let r = v(p) - c;
        m + Matrix3::identity() * r.norm_squared() - r * r.transpose()
    });
    // Collinear points leave M (nearly) singular: the rotation about their line is unknown.
    let scale = m.trace();
    if scale.is_nan() || scale <= 0.0 || m.determinant() <= 1e-9 * scale.powi(3) {
        return None;
    }
    let inverse = m.try_inverse()?;
    at.iter()
        .map(|p| {
            let d = (v(p) - c).cross_matrix();
            // E|t|² = 3σ²/n; E|ω × d|² = σ² tr([d]ₓ M⁻¹ [d]ₓᵀ); a head point's own: 3σ².
            ((3.0 / n + (d * inverse * d.transpose()).trace()) / 3.0).sqrt()
        })
        .reduce(f64::max)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::capture::read_capture;
    use nalgebra::Rotation3;

    fn jaw() -> crate::model::Capture {
        read_capture(std::path::Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../fixtures/JawMoCap.trc"
        )))
        .expect("JawMoCap reads")
    }

    fn known(angle_deg: f64, axis: [f64; 3], t: [f64; 3]) -> RigidTransform {
        let axis = nalgebra::Unit::new_normalize(v(&axis));
        RigidTransform {
            rotation: Rotation3::from_axis_angle(&axis, angle_deg.to_radians()).into_inner(),
            translation: v(&t),
        }
    }

    const HEAD: [&str; 4] = ["ForeHead_M", "ForeHead_L", "ForeHead_R", "NoseTop"];

    #[test]
    fn recovers_known_motions_of_the_real_capture() {
        let cap = jaw();
        let idx: Vec<usize> = HEAD.iter().map(|n| cap.marker_index(n).unwrap()).collect();
        for (f, motion) in [
            (0, known(25.0, [0.2, 1.0, 0.1], [3.0, -7.0, 12.0])),
            (800, known(-90.0, [1.0, 0.0, 0.3], [0.0, 0.5, 0.0])),
        ] {
            let from: Vec<[f64; 3]> = idx.iter().map(|&i| cap.frames[f][i].unwrap()).collect();
            let to: Vec<[f64; 3]> = from.iter().map(|p| motion.apply(p)).collect();
            let fit = kabsch(&from, &to).unwrap();
            assert!(
                (fit.rotation - motion.rotation).abs().max() < 1e-12,
                "frame {f}"
            );
            assert!((fit.translation - motion.translation).abs().max() < 1e-10);
            let tri = three_point(&[from[0], from[1], from[2]], &[to[0], to[1], to[2]]).unwrap();
            assert!(
                (tri.rotation - motion.rotation).abs().max() < 1e-12,
                "three-point, frame {f}"
            );
            assert!((tri.translation - motion.translation).abs().max() < 1e-10);
            // Inverse brings every marker of the moved frame back.
            for p in &from {
                let back = fit.apply_inverse(&motion.apply(p));
                assert!(crate::mesh::distance(&back, p) < 1e-10);
            }
        }
    }

    #[test]
    fn reflections_and_degenerate_sets_are_handled() {
        let from = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
        ];
        let mirrored: Vec<[f64; 3]> = from.iter().map(|p| [-p[0], p[1], p[2]]).collect();
        let fit = kabsch(&from, &mirrored).unwrap();
        assert!(
            (fit.rotation.determinant() - 1.0).abs() < 1e-12,
            "a proper rotation, never a mirror"
        );
        let line = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]];
        assert_eq!(kabsch(&line, &line), Err(RigidError::Degenerate));
        assert_eq!(three_point(&line, &line), Err(RigidError::Degenerate));
        assert_eq!(
            kabsch(&from[..2], &from[..2]),
            Err(RigidError::TooFewPoints(2))
        );
        assert_eq!(
            kabsch(&from, &from[..3]),
            Err(RigidError::LengthMismatch { from: 4, to: 3 })
        );
    }

    #[test]
    fn jawmocap_head_fit_residual_is_real_and_small() {
        // The forehead / nose-top markers are not a rigid jig: the best fit leaves about a
        // millimetre (the data's README). Measured per frame against frame 0, in cm.
        let cap = jaw();
        let idx: Vec<usize> = HEAD.iter().map(|n| cap.marker_index(n).unwrap()).collect();
        let pick = |f: usize| -> Vec<[f64; 3]> {
            idx.iter().map(|&i| cap.frames[f][i].unwrap()).collect()
        };
        let neutral = pick(0);
        let residuals: Vec<f64> = (0..cap.frame_count())
            .map(|f| {
                let to = pick(f);
                kabsch(&neutral, &to).unwrap().rms_residual(&neutral, &to)
            })
            .collect();
        let mean = residuals.iter().sum::<f64>() / residuals.len() as f64;
        let max = residuals.iter().copied().fold(0.0, f64::max);
        println!(
            "JawMoCap head fit vs frame 0: mean RMS residual {:.3} mm, max {:.3} mm",
            mean * 10.0,
            max * 10.0
        );
        assert!(max > 0.0 && mean > 0.01, "real data is not perfectly rigid");
        assert!(
            max < 0.3,
            "residual {max} cm: the head markers should fit within 3 mm"
        );
    }

    #[test]
    fn most_rigid_subset_finds_a_rigid_group_among_many_markers() {
        // 400 markers jittering at random (a small LCG), 4 of them a rigid group turning with
        // the head: more than RIGID_CANDIDATES, so the pre-selection runs.
        let mut seed = 12345u64;
        let mut random = move || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let n = 400;
        let rigid = [17, 123, 250, 399];
        // The group is close together (a headband's markers), the others fill a 100-unit box.
        let base: Vec<[f64; 3]> = (0..n)
            .map(|i| {
                let (origin, size) = if rigid.contains(&i) {
                    (50.0, 5.0)
                } else {
                    (0.0, 100.0)
                };
                [0, 1, 2].map(|_| origin + random() * size)
            })
            .collect();
        let frames: Vec<Vec<[f64; 3]>> = (0..20)
            .map(|f| {
                let turn = Rotation3::from_euler_angles(0.02 * f as f64, 0.01 * f as f64, 0.0);
                base.iter()
                    .enumerate()
                    .map(|(i, p)| {
                        if rigid.contains(&i) {
                            let q = turn * Vector3::new(p[0], p[1], p[2]);
                            [q.x + f as f64, q.y, q.z]
                        } else {
                            [0, 1, 2].map(|k| p[k] + 3.0 * (random() - 0.5))
                        }
                    })
                    .collect()
            })
            .collect();
        let (chosen, spread) = most_rigid_subset(&frames, 4).unwrap();
        assert_eq!(chosen, rigid);
        assert!(spread < 1e-9, "{spread}");
        // The grid's neighbours are the brute-force ones.
        let grid = Grid::new(&frames[0]);
        for i in [0, 17, 200, 399] {
            let mut brute: Vec<(f64, usize)> = (0..n)
                .filter(|&j| j != i)
                .map(|j| (crate::mesh::distance(&frames[0][i], &frames[0][j]), j))
                .collect();
            brute.sort_by(|a, b| a.0.total_cmp(&b.0));
            let want: Vec<usize> = brute[..RIGID_NEIGHBOURS].iter().map(|e| e.1).collect();
            assert_eq!(
                grid.nearest(&frames[0], i, RIGID_NEIGHBOURS),
                want,
                "marker {i}"
            );
        }
    }

    #[test]
    fn most_rigid_subset_of_jawmocap_avoids_the_jaw() {
        let cap = jaw();
        let frames: Vec<Vec<[f64; 3]>> = cap
            .frames
            .iter()
            .map(|f| f.iter().map(|p| p.unwrap()).collect())
            .collect();
        let (chosen, spread) = most_rigid_subset(&frames, 4).unwrap();
        let names: Vec<&str> = chosen
            .iter()
            .map(|&i| cap.marker_names[i].as_str())
            .collect();
        println!(
            "most rigid 4 of JawMoCap: {names:?}, mean pairwise-distance std {:.3} mm",
            spread * 10.0
        );
        assert!(
            names
                .iter()
                .all(|n| !n.starts_with("Chin") && !n.starts_with("Mouth")),
            "{names:?}"
        );
    }

    /// The first-order gain agrees with the spread of many noisy fits.
    #[test]
    fn fit_noise_gain_matches_noisy_fits() {
        let head = [
            [0.0, 0.0, 0.0],
            [0.07, -0.01, -0.006],
            [-0.065, -0.008, -0.005],
        ];
        let at = [[0.0, -0.15, 0.02], [0.0, -0.05, 0.01]];
        let gain = fit_noise_gain(&head, &at).expect("three points");
        let sigma = 1e-5;
        let mut rng = crate::ground_truth::SplitMix64(7);
        let trials = 4000;
        let mut sum = [0.0; 2];
        for _ in 0..trials {
            let noisy: Vec<[f64; 3]> = head
                .iter()
                .map(|p| p.map(|c| c + sigma * 3f64.sqrt() * (2.0 * rng.unit() - 1.0)))
                .collect();
            let fit = kabsch(&head, &noisy).unwrap();
            for (k, p) in at.iter().enumerate() {
                let q = fit.apply_inverse(p);
                sum[k] += (0..3).map(|c| (q[c] - p[c]).powi(2)).sum::<f64>();
            }
        }
        // A head point's own noise: 3σ² (uniform on ±√3σ has variance σ²).
        let measured = sum
            .iter()
            .map(|s| (s / trials as f64 / (3.0 * sigma * sigma)).sqrt())
            .fold(0.0, f64::max);
        assert!((measured / gain - 1.0).abs() < 0.05, "{measured} vs {gain}");
        assert!(gain > 2.0, "{gain}");
        let line = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]];
        assert_eq!(fit_noise_gain(&line, &at), None);
        assert_eq!(fit_noise_gain(&head[..2], &at), None);
    }
}
