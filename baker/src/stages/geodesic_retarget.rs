//! Geodesic retargeting (paper 002 §2.1): the inverse-multiquadric RBF map of [`super::retarget`]
//! with distances along the skin instead of straight lines, linearised at the neutral so that
//! the runtime plays it as [`Proportional`] matrices.
//!
//! 1. The character's mesh is warped onto the actor by the Euclidean RBF map from the
//!    character's markers to the actor's ([`RetargetMap`]): a mesh in actor space whose markers
//!    sit (nearly) at the actor's neutral markers, with the character's connectivity.
//! 2. Heat-method distance fields along the warped mesh from every marker's surface point (the
//!    same triangle and barycentric weights as on the character): g_i.
//! 3. An IMQ RBF with per-centre radius r_i = min_{j≠i} G_ij plus affine, fitted so that
//!    f(w_j) = v_j, w_j the marker's point on the warped mesh and v_j the character's marker:
//!    f(x) = Σ_i α_i φ_i(g_i(x)) + β₀ + Bx, a map of the warped skin onto the character.
//! 4. Markers leave the skin and geodesic distances cannot be taken per frame in fixed point, so
//!    the map is linearised at each marker: M_j = Σ_{i≠j} α_i φ_i'(G_ij) ∇g_i(w_j)ᵀ + B, with
//!    ∇g_i the gradient of the piecewise-linear field on the warped triangles about w_j. The
//!    i = j term drops: φ_j(g_j(x)) ≈ φ_j(|x − w_j|) is flat at its centre. Motion along the
//!    skin's normal sees only the affine part.

use nalgebra::DMatrix;

use super::retarget::{Proportional, RetargetMap};
use super::StagesError;
use crate::geodesic::{GeodesicMethod, Geodesics, Source};
use crate::mesh::{cross, distance, dot, sub};
use crate::rbf::{Kernel, RbfSystem};

/// The character's skin for geodesic retargeting: its welded mesh and where each rig marker
/// sits on it.
#[derive(Clone, Debug, PartialEq)]
pub struct CharacterSurface {
    /// Welded vertex positions, asset units.
    pub positions: Vec<[f64; 3]>,
    /// Welded triangles.
    pub triangles: Vec<[u32; 3]>,
    /// Per rig marker (rig order), its place on the welded mesh.
    pub sources: Vec<Source>,
}

/// The geodesic RBF map from the warped character skin (actor space) to the character.
pub struct GeodesicRetarget {
    skin: WarpedSkin,
    system: RbfSystem,
    /// Coefficients `[α; β₀; βx; βy; βz]`, one column per output coordinate.
    coefficients: DMatrix<f64>,
    /// `between[(j, i)]`: field `i` at marker `j`.
    between: DMatrix<f64>,
}

/// The character's skin warped onto the actor, with every marker's distance field on it.
struct WarpedSkin {
    /// The character's welded vertices warped onto the actor.
    warped: Vec<[f64; 3]>,
    triangles: Vec<[u32; 3]>,
    sources: Vec<Source>,
    /// Per marker, its geodesic distance field over the warped welded vertices.
    fields: Vec<Vec<f64>>,
    /// The markers' points on the warped mesh, w_j.
    centres: Vec<[f64; 3]>,
    /// Per marker, the triangles holding its point: its own, or every one sharing its edge or
    /// vertex when it lies on one.
    holders: Vec<Vec<usize>>,
}

impl GeodesicRetarget {
    /// The map carrying the actor's neutral markers `actor_neutral` onto `character` (one per
    /// marker, any units) through distances along `surface` (its positions in `character`'s
    /// units).
    pub fn new(
        actor_neutral: &[[f64; 3]],
        character: &[[f64; 3]],
        surface: &CharacterSurface,
    ) -> Result<Self, StagesError> {
        let n = character.len();
        if surface.sources.len() != n || actor_neutral.len() != n {
            return Err(StagesError::OutOfRange(format!(
                "geodesic retargeting: {} marker places on the character's skin for {n} markers \
                 ({} actor markers)",
                surface.sources.len(),
                actor_neutral.len()
            )));
        }
        let back = RetargetMap::new(character, actor_neutral)?;
        let warped: Vec<[f64; 3]> = surface.positions.iter().map(|p| back.map(p)).collect();
        let geodesics = Geodesics::new(&warped, &surface.triangles, GeodesicMethod::Heat)?;
        let fields = geodesics.from_sources(&surface.sources)?;
        let mut skin = WarpedSkin {
            warped,
            triangles: surface.triangles.clone(),
            sources: surface.sources.clone(),
            fields,
            centres: Vec::new(),
            holders: Vec::new(),
        };
        skin.centres = skin.sources.iter().map(|s| skin.position(s)).collect();
        skin.holders = skin.sources.iter().map(|s| skin.holders_of(s)).collect();
        let between = DMatrix::from_fn(n, n, |j, i| skin.distance_at(i, &skin.sources[j]));
        let radii = (0..n)
            .map(|i| {
                (0..n)
                    .filter(|&j| j != i)
                    .map(|j| 0.5 * (between[(i, j)] + between[(j, i)]))
                    .fold(f64::INFINITY, f64::min)
            })
            .collect();
        let system = RbfSystem::with_distances(
            &skin.centres,
            &between,
            Kernel::InverseMultiquadric { radii },
            true,
            &vec![1.0; n],
            0.0,
        )?;
        let coefficients = system.solve(character);
        Ok(Self {
            skin,
            system,
            coefficients,
            between,
        })
    }

    /// The character's welded vertices warped onto the actor.
    pub fn warped(&self) -> &[[f64; 3]] {
        &self.skin.warped
    }

    /// The markers' points on the warped mesh, w_j (actor space).
    pub fn centres(&self) -> &[[f64; 3]] {
        &self.skin.centres
    }

    /// 1-norm condition estimate of the geodesic system.
    pub fn condition(&self) -> f64 {
        self.system.condition()
    }

    /// The per-centre kernel radii rᵢ: the geodesic distance to the nearest other marker.
    pub fn radii(&self) -> &[f64] {
        match self.system.kernel() {
            Kernel::InverseMultiquadric { radii } => radii,
            _ => &[],
        }
    }

    /// The (f64, nonlinear) map at a point of the warped skin, given as a place on the welded
    /// mesh; `None` if the place is not on the mesh.
    pub fn map_point(&self, place: &Source) -> Option<[f64; 3]> {
        let valid = match *place {
            Source::Vertex(v) => (v as usize) < self.skin.warped.len(),
            Source::Point {
                triangle,
                barycentric,
            } => {
                triangle < self.skin.triangles.len()
                    && barycentric.iter().all(|w| w.is_finite() && *w >= 0.0)
                    && barycentric.iter().sum::<f64>() > 0.0
            }
        };
        valid.then(|| {
            let d: Vec<f64> = (0..self.skin.centres.len())
                .map(|i| self.skin.distance_at(i, place))
                .collect();
            self.evaluate(&d, &self.skin.position(place))
        })
    }

    /// The map at marker `j`'s point w_j: the character's marker `j`, up to rounding.
    pub fn map_marker(&self, j: usize) -> [f64; 3] {
        let d: Vec<f64> = self.between.row(j).iter().copied().collect();
        self.evaluate(&d, &self.skin.centres[j])
    }

    /// M_j, the map's derivative at marker `j` (rows: character coordinates; columns: actor).
    pub fn jacobian(&self, j: usize) -> [[f64; 3]; 3] {
        let n = self.skin.centres.len();
        let radii = self.radii();
        let c = &self.coefficients;
        let mut m = [0, 1, 2].map(|row| [0, 1, 2].map(|k| c[(n + 1 + k, row)]));
        for i in (0..n).filter(|&i| i != j) {
            let d = self.between[(j, i)];
            let slope = -d / (d * d + radii[i] * radii[i]).powf(1.5);
            let g = self.skin.gradient(i, j);
            for (row, out) in m.iter_mut().enumerate() {
                for k in 0..3 {
                    out[k] += c[(i, row)] * slope * g[k];
                }
            }
        }
        m
    }

    /// The linearised map as the runtime's proportional retargeting: per marker M_j and the
    /// character's marker. `scales` are, per region (character markers at or above their
    /// median height, and below) and character axis, the mean length of the matrices' rows:
    /// what [`Proportional::new`]'s per-axis scales are for its matrices.
    pub fn proportional(&self, character: &[[f64; 3]]) -> Proportional {
        let n = self.skin.centres.len();
        let matrices: Vec<[[f64; 3]; 3]> = (0..n).map(|j| self.jacobian(j)).collect();
        let mut heights: Vec<f64> = character.iter().map(|v| v[1]).collect();
        heights.sort_by(f64::total_cmp);
        let median = heights.get(heights.len() / 2).copied().unwrap_or(0.0);
        let scales = [true, false].map(|up| {
            let region: Vec<usize> = (0..n)
                .filter(|&j| (character[j][1] >= median) == up)
                .collect();
            [0, 1, 2].map(|row| {
                let total: f64 = region
                    .iter()
                    .map(|&j| dot(&matrices[j][row], &matrices[j][row]).sqrt())
                    .sum();
                total / region.len().max(1) as f64
            })
        });
        Proportional {
            matrices,
            rest: character.to_vec(),
            scales,
        }
    }

    /// Σ_i α_i φ_i(d_i) + β₀ + B x.
    fn evaluate(&self, d: &[f64], x: &[f64; 3]) -> [f64; 3] {
        let n = self.skin.centres.len();
        let kernel = self.system.kernel();
        let c = &self.coefficients;
        [0, 1, 2].map(|row| {
            let radial: f64 = (0..n).map(|i| c[(i, row)] * kernel.phi(i, d[i])).sum();
            radial + c[(n, row)] + (0..3).map(|k| c[(n + 1 + k, row)] * x[k]).sum::<f64>()
        })
    }
}

impl WarpedSkin {
    /// A place's corners on the welded mesh with normalised weights.
    fn corners(&self, place: &Source) -> Vec<(usize, f64)> {
        place
            .corners(&self.triangles)
            .into_iter()
            .map(|(v, w)| (v as usize, w))
            .collect()
    }

    /// A place's position on the warped mesh.
    fn position(&self, place: &Source) -> [f64; 3] {
        let mut p = [0.0; 3];
        for (v, w) in self.corners(place) {
            for (c, x) in p.iter_mut().enumerate() {
                *x += w * self.warped[v][c];
            }
        }
        p
    }

    /// Field `i` at a place (barycentric interpolation, as the heat method's marker-to-marker
    /// distances); the straight line to w_i where the skin does not join them.
    fn distance_at(&self, i: usize, place: &Source) -> f64 {
        let d: f64 = self
            .corners(place)
            .iter()
            .map(|&(v, w)| w * self.fields[i][v])
            .sum();
        if d.is_finite() {
            d
        } else {
            distance(&self.position(place), &self.centres[i])
        }
    }

    /// The triangles holding a place: those with every corner of nonzero weight.
    fn holders_of(&self, place: &Source) -> Vec<usize> {
        let corners: Vec<usize> = self.corners(place).iter().map(|c| c.0).collect();
        (0..self.triangles.len())
            .filter(|&t| {
                corners
                    .iter()
                    .all(|&v| self.triangles[t].contains(&(v as u32)))
            })
            .collect()
    }

    /// ∇g_i at marker `j`: the area-weighted mean gradient of the piecewise-linear field over
    /// the warped triangles holding marker `j`'s point (one, or those sharing its edge or
    /// vertex); the straight line's gradient where the field does not reach them.
    fn gradient(&self, i: usize, j: usize) -> [f64; 3] {
        let field = &self.fields[i];
        let mut sum = [0.0; 3];
        let mut area = 0.0;
        for &t in &self.holders[j] {
            let t = self.triangles[t].map(|v| v as usize);
            let f = t.map(|v| field[v]);
            if f.iter().any(|x| !x.is_finite()) {
                continue;
            }
            let [p0, p1, p2] = t.map(|v| self.warped[v]);
            let (e1, e2) = (sub(&p1, &p0), sub(&p2, &p0));
            let normal = cross(&e1, &e2);
            let nn = dot(&normal, &normal);
            if nn <= f64::MIN_POSITIVE {
                continue;
            }
            let (a, b) = (cross(&e2, &normal), cross(&normal, &e1));
            let a2 = nn.sqrt();
            for c in 0..3 {
                // Gradient × twice the area: the weight is the area.
                sum[c] += ((f[1] - f[0]) * a[c] + (f[2] - f[0]) * b[c]) / a2;
            }
            area += a2;
        }
        if area > 0.0 {
            sum.map(|x| x / area)
        } else {
            let d = sub(&self.centres[j], &self.centres[i]);
            let len = dot(&d, &d).sqrt();
            if len > 0.0 {
                d.map(|x| x / len)
            } else {
                [0.0; 3]
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A bumped sheet, 21 × 21 vertices over [−1, 1]², and 16 markers inside its triangles.
    fn sheet() -> (CharacterSurface, Vec<[f64; 3]>) {
        const N: usize = 21;
        let positions: Vec<[f64; 3]> = (0..N * N)
            .map(|k| {
                let (x, y) = (
                    -1.0 + 2.0 * (k % N) as f64 / (N - 1) as f64,
                    -1.0 + 2.0 * (k / N) as f64 / (N - 1) as f64,
                );
                [x, y, 0.4 * (-(x * x + 2.0 * y * y)).exp()]
            })
            .collect();
        let triangles = crate::mesh::grid_triangles(N);
        let sources: Vec<Source> = (0..16)
            .map(|m| {
                let (r, c) = (2 + 5 * (m / 4), 2 + 5 * (m % 4) - (m / 4) % 2);
                Source::Point {
                    triangle: 2 * (r * (N - 1) + c) + m % 2,
                    barycentric: [0.2, 0.3 + 0.01 * m as f64, 0.5 - 0.01 * m as f64],
                }
            })
            .collect();
        let surface = CharacterSurface {
            positions,
            triangles,
            sources,
        };
        let markers = surface
            .sources
            .iter()
            .map(|s| match *s {
                Source::Point {
                    triangle,
                    barycentric,
                } => {
                    let t = surface.triangles[triangle];
                    [0, 1, 2].map(|c| {
                        (0..3)
                            .map(|k| barycentric[k] * surface.positions[t[k] as usize][c])
                            .sum()
                    })
                }
                Source::Vertex(v) => surface.positions[v as usize],
            })
            .collect();
        (surface, markers)
    }

    /// The sheet's markers and mesh carried by `f` (the character), and the map from the
    /// sheet's markers (the actor) onto it.
    fn retarget(f: impl Fn(&[f64; 3]) -> [f64; 3]) -> (GeodesicRetarget, Vec<[f64; 3]>) {
        let (surface, actor) = sheet();
        let character: Vec<[f64; 3]> = actor.iter().map(&f).collect();
        let surface = CharacterSurface {
            positions: surface.positions.iter().map(&f).collect(),
            ..surface
        };
        let map = GeodesicRetarget::new(&actor, &character, &surface).expect("solves");
        (map, character)
    }

    fn worst_matrix_error(map: &GeodesicRetarget, want: [[f64; 3]; 3]) -> f64 {
        (0..map.centres().len())
            .flat_map(|j| {
                let m = map.jacobian(j);
                (0..9).map(move |k| (m[k / 3][k % 3] - want[k / 3][k % 3]).abs())
            })
            .fold(0.0, f64::max)
    }

    #[test]
    fn onto_the_actor_himself_every_matrix_is_the_identity() {
        let (map, character) = retarget(|p| *p);
        let worst = worst_matrix_error(&map, [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]);
        assert!(
            worst < 1e-8,
            "identity retarget: a matrix entry is off by {worst}"
        );
        let p = map.proportional(&character);
        assert_eq!(p.rest, character);
        assert!(p.scales.iter().flatten().all(|s| (s - 1.0).abs() < 1e-8));
    }

    #[test]
    fn onto_a_scaled_copy_every_matrix_is_the_scale() {
        let s = 0.37;
        let (map, _) = retarget(|p| p.map(|x| s * x + 0.1));
        let worst = worst_matrix_error(&map, [[s, 0.0, 0.0], [0.0, s, 0.0], [0.0, 0.0, s]]);
        assert!(
            worst < 1e-8,
            "scaled retarget: a matrix entry is off by {worst}"
        );
    }

    #[test]
    fn onto_an_affine_copy_every_matrix_is_the_affine_map() {
        let a = [[1.15, 0.1, 0.0], [0.0, 0.9, -0.2], [0.05, 0.0, 1.3]];
        let (map, _) = retarget(|p| [0, 1, 2].map(|r| dot(&a[r], p) + 0.3 * r as f64));
        let worst = worst_matrix_error(&map, a);
        assert!(
            worst < 1e-8,
            "affine retarget: a matrix entry is off by {worst}"
        );
    }

    /// A bend the affine part cannot explain.
    fn bend(p: &[f64; 3]) -> [f64; 3] {
        [
            1.1 * p[0],
            p[1] * (1.0 + 0.2 * (2.0 * p[0]).sin()),
            p[2] + 0.3 * p[0] * p[0],
        ]
    }

    #[test]
    fn a_non_affine_target_is_interpolated_exactly_at_the_markers() {
        let (map, character) = retarget(bend);
        for (j, v) in character.iter().enumerate() {
            assert!(distance(&map.map_marker(j), v) < 1e-9);
            let place = map.skin.sources[j];
            let at = map.map_point(&place).expect("on the mesh");
            assert!(distance(&at, v) < 1e-9);
        }
        assert!(map.condition().is_finite());
        // The bend is not affine: some matrix is not the mean one.
        let m0 = map.jacobian(0);
        assert!((1..character.len()).any(|j| {
            let m = map.jacobian(j);
            (0..9).any(|k| (m[k / 3][k % 3] - m0[k / 3][k % 3]).abs() > 1e-3)
        }));
    }

    #[test]
    fn the_matrices_are_the_maps_derivative_along_the_skin() {
        // Within a marker's triangle the fields are linear, so a small step along the skin
        // moves f by M_j times the step, up to second order and the dropped own-centre term.
        let (map, _) = retarget(bend);
        let mut worst = 0.0f64;
        for (j, place) in map.skin.sources.iter().enumerate() {
            let Source::Point {
                triangle,
                barycentric,
            } = *place
            else {
                continue;
            };
            for step in [[1e-3, -1e-3, 0.0], [0.0, 1e-3, -1e-3]] {
                let moved = Source::Point {
                    triangle,
                    barycentric: [0, 1, 2].map(|c| barycentric[c] + step[c]),
                };
                let from = map.skin.position(place);
                let to = map.skin.position(&moved);
                let d = sub(&to, &from);
                let m = map.jacobian(j);
                let predicted: [f64; 3] = [0, 1, 2].map(|r| dot(&m[r], &d));
                let df = sub(
                    &map.map_point(&moved).expect("on the mesh"),
                    &map.map_marker(j),
                );
                let error = distance(&df, &predicted) / dot(&d, &d).sqrt();
                worst = worst.max(error);
            }
        }
        assert!(worst < 0.02, "derivative off by {worst} per unit step");
    }
}
