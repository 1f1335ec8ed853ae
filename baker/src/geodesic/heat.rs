//! The heat method (Crane, Weischedel & Wardetzky 2013): diffuse heat from the source for a
//! short time `t = h²`, normalise the heat's negative gradient per triangle into a unit field
//! `X` pointing away from the source, and find the distance `φ` whose gradient best fits `X`
//! (the Poisson problem `∫∇φ·∇ψᵢ = ∫X·∇ψᵢ` for every hat function `ψᵢ`).
//!
//! Linear finite elements: stiffness `K` (the cotangent Laplacian with the sign that makes it
//! positive semidefinite, `K = -L`), lumped mass `M` (a third of each triangle's area per
//! corner). Both matrices are factored once per mesh:
//! * heat, Neumann: `M + tK`;
//! * heat, Dirichlet (only if the mesh has a boundary): the same with the boundary vertices
//!   held at zero; the heat step uses the average of the two, as the paper recommends;
//! * Poisson: `K` with one vertex per piece held at zero (the distance is then shifted so
//!   that it is zero at the source, which removes the constant `K` cannot see).
//!
//! Triangles with no area (fewer than three distinct corners, collinear corners) take no part:
//! they have no gradient. A vertex used by no such triangle has no mass and is held at zero;
//! the caller fills its distance from its neighbours along edges.

use super::intrinsic::{self, Intrinsic};
use super::ldlt::{nested_dissection, Ldlt, NotPositiveDefinite};
use crate::mesh::{dot, find, sub, Topology};

/// Marks a vertex in no triangle with area.
pub(crate) const NO_PIECE: u32 = u32::MAX;

/// A triangle with area, ready for gradients: `∇u = Σ uᵢ grad[i]` on it.
#[derive(Debug, Clone)]
struct Element {
    corners: [u32; 3],
    area: f64,
    /// Gradient of each corner's hat function.
    grad: [[f64; 3]; 3],
}

/// Everything the heat method needs per mesh, factored once.
#[derive(Debug, Clone)]
pub(crate) struct Heat {
    elements: Vec<Element>,
    /// Connected piece of each vertex over the triangles with area, or [`NO_PIECE`].
    pub(crate) piece: Vec<u32>,
    heat_neumann: Ldlt,
    /// Heat with the boundary at zero, when there is a boundary vertex with mass.
    heat_dirichlet: Option<(Ldlt, Vec<bool>)>,
    /// Poisson matrix and its held vertices (one per piece, and the massless ones).
    poisson: Ldlt,
    poisson_held: Vec<bool>,
    /// The diffusion time `t`.
    pub(crate) time: f64,
    /// Edges flipped to make the triangulation intrinsically Delaunay.
    pub(crate) flips: usize,
}

fn cross(a: &[f64; 3], b: &[f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// Whether triangle `t` has three distinct corners and an area worth the name: relative to
/// its longest edge, so slivers whose angles cannot be trusted drop out too.
fn has_area(positions: &[[f64; 3]], t: &[u32; 3]) -> bool {
    if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
        return false;
    }
    let p = t.map(|v| positions[v as usize]);
    let n = cross(&sub(&p[1], &p[0]), &sub(&p[2], &p[0]));
    let longest2 = (0..3)
        .map(|i| {
            let e = sub(&p[(i + 1) % 3], &p[i]);
            dot(&e, &e)
        })
        .fold(0.0, f64::max);
    dot(&n, &n).sqrt() > 1e-12 * longest2
}

/// The element of an intrinsic triangle from its edge lengths, laid out in its own plane
/// (corner 0 at the origin, corner 1 on the x axis); `None` if it has no area.
fn element(corners: [u32; 3], lengths: [f64; 3]) -> Option<Element> {
    let area = intrinsic::area(lengths[0], lengths[1], lengths[2]);
    if !(area > 0.0 && lengths[0] > 0.0) {
        return None;
    }
    let x = (lengths[0] * lengths[0] + lengths[2] * lengths[2] - lengths[1] * lengths[1])
        / (2.0 * lengths[0]);
    let p = [[0.0, 0.0], [lengths[0], 0.0], [x, 2.0 * area / lengths[0]]];
    // ∇ψᵢ is the opposite edge (counter-clockwise) turned a quarter left, over twice the area.
    let grad = std::array::from_fn(|i| {
        let (a, b) = (p[(i + 1) % 3], p[(i + 2) % 3]);
        [
            -(b[1] - a[1]) / (2.0 * area),
            (b[0] - a[0]) / (2.0 * area),
            0.0,
        ]
    });
    Some(Element {
        corners,
        area,
        grad,
    })
}

/// Matrix `diag`, `off` with the `held` vertices' rows and columns replaced by identity.
fn hold(diag: &[f64], off: &[(u32, u32, f64)], held: &[bool]) -> (Vec<f64>, Vec<(u32, u32, f64)>) {
    let diag = diag
        .iter()
        .zip(held)
        .map(|(&d, &h)| if h { 1.0 } else { d })
        .collect();
    let off = off
        .iter()
        .filter(|(i, j, _)| !held[*i as usize] && !held[*j as usize])
        .copied()
        .collect();
    (diag, off)
}

impl Heat {
    /// Builds and factors the matrices. `topology` must be that of `positions`/`triangles`.
    pub(crate) fn new(
        positions: &[[f64; 3]],
        triangles: &[[u32; 3]],
        topology: &Topology,
    ) -> Result<Heat, NotPositiveDefinite> {
        let n = positions.len();
        let with_area: Vec<[u32; 3]> = triangles
            .iter()
            .filter(|t| has_area(positions, t))
            .copied()
            .collect();
        let intrinsic = Intrinsic::delaunay(positions, &with_area);
        let elements: Vec<Element> = intrinsic
            .triangles
            .iter()
            .zip(&intrinsic.lengths)
            .filter_map(|(&t, &l)| element(t, l))
            .collect();
        let mut mass = vec![0.0; n];
        let mut stiff_diag = vec![0.0; n];
        let mut stiff_off = Vec::with_capacity(3 * elements.len());
        let mut parent: Vec<u32> = (0..n as u32).collect();
        let mut live = vec![false; n];
        let mut edge_sum = 0.0;
        let mut edge_count = 0usize;
        for el in &elements {
            for i in 0..3 {
                let v = el.corners[i];
                live[v as usize] = true;
                mass[v as usize] += el.area / 3.0;
                stiff_diag[v as usize] += el.area * dot(&el.grad[i], &el.grad[i]);
                let j = (i + 1) % 3;
                let w = el.corners[j];
                stiff_off.push((v, w, el.area * dot(&el.grad[i], &el.grad[j])));
                let (rv, rw) = (find(&mut parent, v), find(&mut parent, w));
                parent[rv.max(rw) as usize] = rv.min(rw);
            }
        }
        for e in &topology.edges {
            if live[e.a as usize] && live[e.b as usize] {
                edge_sum += e.length;
                edge_count += 1;
            }
        }
        let h = if edge_count > 0 {
            edge_sum / edge_count as f64
        } else {
            1.0
        };
        let time = h * h;
        let piece: Vec<u32> = (0..n as u32)
            .map(|v| {
                if live[v as usize] {
                    find(&mut parent, v)
                } else {
                    NO_PIECE
                }
            })
            .collect();
        let order = nested_dissection(positions, &topology.neighbours);

        let heat_diag: Vec<f64> = (0..n).map(|v| mass[v] + time * stiff_diag[v]).collect();
        let heat_off: Vec<(u32, u32, f64)> = stiff_off
            .iter()
            .map(|&(i, j, k)| (i, j, time * k))
            .collect();
        let massless: Vec<bool> = live.iter().map(|h| !h).collect();
        let mut on_boundary = massless.clone();
        let mut any_boundary = false;
        for e in topology.edges.iter().filter(|e| e.triangles == 1) {
            for v in [e.a, e.b] {
                if live[v as usize] {
                    on_boundary[v as usize] = true;
                    any_boundary = true;
                }
            }
        }
        // Hold each piece's root (its smallest vertex) and the massless vertices.
        let poisson_held: Vec<bool> = (0..n)
            .map(|v| piece[v] == NO_PIECE || piece[v] == v as u32)
            .collect();
        let factor = |diag: &[f64], off: &[(u32, u32, f64)], held: &[bool]| {
            let (d, o) = hold(diag, off, held);
            Ldlt::new(&d, &o, order.clone())
        };
        // The three factorisations are independent: the Poisson one on a second thread.
        let (heat_neumann, heat_dirichlet, poisson) = std::thread::scope(|scope| {
            let poisson = scope.spawn(|| factor(&stiff_diag, &stiff_off, &poisson_held));
            let neumann = factor(&heat_diag, &heat_off, &massless);
            let dirichlet = any_boundary.then(|| factor(&heat_diag, &heat_off, &on_boundary));
            let poisson = poisson
                .join()
                .unwrap_or_else(|e| std::panic::resume_unwind(e));
            (neumann, dirichlet, poisson)
        });
        let heat_neumann = heat_neumann?;
        let heat_dirichlet = match heat_dirichlet {
            Some(f) => Some((f?, on_boundary)),
            None => None,
        };
        let poisson = poisson?;
        Ok(Heat {
            elements,
            piece,
            heat_neumann,
            heat_dirichlet,
            poisson,
            poisson_held,
            time,
            flips: intrinsic.flips,
        })
    }

    /// Distances from `W` sources at once, each given as heat at vertices (`(vertex, weight)`,
    /// all in one piece; an empty list gives an unused column). Returns `φ` per vertex and
    /// source, zero at the source; entries outside the source's piece are meaningless (the
    /// caller masks them).
    pub(crate) fn solve<const W: usize>(
        &self,
        sources: &[Vec<(u32, f64)>; W],
        work: &mut Vec<[f64; W]>,
    ) -> Vec<[f64; W]> {
        let n = self.piece.len();
        let mut heat = vec![[0.0; W]; n];
        for (c, src) in sources.iter().enumerate() {
            for &(v, w) in src {
                heat[v as usize][c] += w;
            }
        }
        let mut u = heat.clone();
        self.heat_neumann.solve(&mut u, work);
        if let Some((dirichlet, held)) = &self.heat_dirichlet {
            for (h, &held) in heat.iter_mut().zip(held) {
                if held {
                    *h = [0.0; W];
                }
            }
            dirichlet.solve(&mut heat, work);
            for (a, b) in u.iter_mut().zip(&heat) {
                for c in 0..W {
                    a[c] = 0.5 * (a[c] + b[c]);
                }
            }
        }
        // Divergence of the normalised field: rhs_i = Σ_T A_T X_T·∇ψᵢ.
        let mut rhs = vec![[0.0; W]; n];
        for el in &self.elements {
            let uc = el.corners.map(|v| u[v as usize]);
            for c in 0..W {
                let g: [f64; 3] =
                    std::array::from_fn(|k| (0..3).map(|i| uc[i][c] * el.grad[i][k]).sum());
                let len = dot(&g, &g).sqrt();
                if !(len > 0.0 && len.is_finite()) {
                    continue;
                }
                let scale = -el.area / len;
                for i in 0..3 {
                    rhs[el.corners[i] as usize][c] += scale * dot(&g, &el.grad[i]);
                }
            }
        }
        for (r, &held) in rhs.iter_mut().zip(&self.poisson_held) {
            if held {
                *r = [0.0; W];
            }
        }
        self.poisson.solve(&mut rhs, work);
        for (c, src) in sources.iter().enumerate() {
            let total: f64 = src.iter().map(|s| s.1).sum();
            if total > 0.0 {
                let at_source: f64 = src.iter().map(|&(v, w)| w * rhs[v as usize][c]).sum();
                let shift = at_source / total;
                for r in rhs.iter_mut() {
                    r[c] -= shift;
                }
            }
        }
        rhs
    }
}
