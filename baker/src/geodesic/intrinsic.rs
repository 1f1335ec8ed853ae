//! Intrinsic Delaunay triangulation by edge flips (Bobenko & Springborn 2007; Sharp, Soliman
//! & Crane 2019).
//!
//! The cotangent Laplacian of a mesh with obtuse triangles has positive off-diagonal entries,
//! and then the heat method's short-time heat can oscillate in sign far from the source, which
//! turns its gradient around. Flipping every non-Delaunay edge *intrinsically* — the surface
//! and the vertices stay exactly as they are, only which pairs of vertices are joined by
//! straight paths on the surface changes — gives a triangulation of the same surface whose
//! Laplacian has no positive off-diagonal entries. Everything the heat method needs (areas,
//! gradients, their dot products) follows from edge lengths alone.

use crate::mesh::distance;

const NONE: u32 = u32::MAX;

/// A triangulation of the surface given by vertex triples and edge lengths:
/// `lengths[t][c]` is the length of the edge from corner `c` to corner `c + 1` of `triangles[t]`.
#[derive(Debug, Clone)]
pub(crate) struct Intrinsic {
    pub(crate) triangles: Vec<[u32; 3]>,
    pub(crate) lengths: Vec<[f64; 3]>,
    /// Number of edges flipped.
    pub(crate) flips: usize,
}

/// Cotangent of the angle opposite side `c` in the triangle with sides `a`, `b`, `c`.
fn cot_opposite(a: f64, b: f64, c: f64) -> f64 {
    let area4 = 4.0 * area(a, b, c);
    (a * a + b * b - c * c) / area4
}

/// Area from side lengths (Heron, in the rearrangement that is stable for thin triangles).
pub(crate) fn area(a: f64, b: f64, c: f64) -> f64 {
    let mut s = [a, b, c];
    s.sort_by(|x, y| y.total_cmp(x));
    let [a, b, c] = s;
    let p = (a + (b + c)) * (c - (a - b)) * (c + (a - b)) * (a + (b - c));
    0.25 * p.max(0.0).sqrt()
}

/// 2D position of the corner opposite side `(0,0)–(base, 0)`, at `left` from the origin and
/// `right` from `(base, 0)`, above the axis.
fn apex(base: f64, left: f64, right: f64) -> [f64; 2] {
    let x = (base * base + left * left - right * right) / (2.0 * base);
    [x, (left * left - x * x).max(0.0).sqrt()]
}

impl Intrinsic {
    /// The intrinsic Delaunay triangulation of `triangles` (all with three distinct corners
    /// and positive area) over `positions`. Edges shared by more or fewer than two triangles,
    /// or by two triangles of opposite orientation, are never flipped.
    pub(crate) fn delaunay(positions: &[[f64; 3]], triangles: &[[u32; 3]]) -> Intrinsic {
        let mut tris = triangles.to_vec();
        let mut len: Vec<f64> = tris
            .iter()
            .flat_map(|t| {
                (0..3)
                    .map(move |c| (t[c], t[(c + 1) % 3]))
                    .map(|(a, b)| distance(&positions[a as usize], &positions[b as usize]))
            })
            .collect();
        // Twin half-edges: half-edge 3t + c runs from corner c to corner c + 1 of triangle t.
        let mut keyed: Vec<(u32, u32, u32)> = (0..3 * tris.len() as u32)
            .map(|h| {
                let t = tris[(h / 3) as usize];
                let (a, b) = (t[(h % 3) as usize], t[((h + 1) % 3) as usize]);
                (a.min(b), a.max(b), h)
            })
            .collect();
        keyed.sort_unstable();
        let mut twin = vec![NONE; len.len()];
        let mut i = 0;
        while i < keyed.len() {
            let mut j = i + 1;
            while j < keyed.len() && keyed[j].0 == keyed[i].0 && keyed[j].1 == keyed[i].1 {
                j += 1;
            }
            if j - i == 2 {
                let (h, g) = (keyed[i].2, keyed[i + 1].2);
                let from = |h: u32| tris[(h / 3) as usize][(h % 3) as usize];
                if from(h) != from(g) {
                    twin[h as usize] = g;
                    twin[g as usize] = h;
                }
            }
            i = j;
        }
        let next = |h: u32| h - h % 3 + (h + 1) % 3;
        let mut stack: Vec<u32> = (0..len.len() as u32)
            .filter(|&h| twin[h as usize] != NONE && twin[h as usize] > h)
            .collect();
        let mut flips = 0;
        // Delaunay flipping terminates; the cap only guards against rounding cycling.
        let cap = 50 * len.len() + 100;
        while let Some(h) = stack.pop() {
            if flips >= cap {
                break;
            }
            let g = twin[h as usize];
            if g == NONE {
                continue;
            }
            // Triangle (i, j, k) with h = i→j; twin triangle (j, i, l) with g = j→i.
            let (hjk, hki) = (next(h), next(next(h)));
            let (gil, glj) = (next(g), next(next(g)));
            let (t, s) = ((h / 3) as usize, (g / 3) as usize);
            let vi = tris[t][(h % 3) as usize];
            let vj = tris[t][(hjk % 3) as usize];
            let vk = tris[t][(hki % 3) as usize];
            let vl = tris[s][(glj % 3) as usize];
            let (lij, ljk, lki) = (len[h as usize], len[hjk as usize], len[hki as usize]);
            let (lil, llj) = (len[gil as usize], len[glj as usize]);
            let cot_sum = cot_opposite(ljk, lki, lij) + cot_opposite(lil, llj, lij);
            if cot_sum.is_nan() || cot_sum >= -1e-12 || vk == vl {
                continue;
            }
            // Lay the two triangles out in the plane, i at the origin and j on the x axis.
            let k = apex(lij, lki, ljk);
            let l = apex(lij, lil, llj);
            let l = [l[0], -l[1]];
            let dx = k[0] - l[0];
            let dy = k[1] - l[1];
            // The new diagonal must cross i–j between i and j (the quad is convex).
            let cross_x = l[0] + dx * (-l[1]) / dy;
            if !(dy > 0.0 && cross_x > 0.0 && cross_x < lij) {
                continue;
            }
            let lkl = (dx * dx + dy * dy).sqrt();
            // New triangles (k, i, l) in t and (l, j, k) in s.
            let outer = [
                (twin[hki as usize], lki),
                (twin[gil as usize], lil),
                (twin[glj as usize], llj),
                (twin[hjk as usize], ljk),
            ];
            let t0 = 3 * t as u32;
            let s0 = 3 * s as u32;
            tris[t] = [vk, vi, vl];
            tris[s] = [vl, vj, vk];
            let slots = [t0, t0 + 1, s0, s0 + 1];
            for (&slot, &(tw, l)) in slots.iter().zip(&outer) {
                twin[slot as usize] = tw;
                len[slot as usize] = l;
                if tw != NONE {
                    twin[tw as usize] = slot;
                }
            }
            twin[(t0 + 2) as usize] = s0 + 2;
            twin[(s0 + 2) as usize] = t0 + 2;
            len[(t0 + 2) as usize] = lkl;
            len[(s0 + 2) as usize] = lkl;
            flips += 1;
            stack.extend(slots);
        }
        let lengths = (0..tris.len())
            .map(|t| [len[3 * t], len[3 * t + 1], len[3 * t + 2]])
            .collect();
        Intrinsic {
            triangles: tris,
            lengths,
            flips,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flips_the_long_diagonal_of_a_flat_kite() {
        // A flat rhombus, long in x, split along its long diagonal 0–2: that edge faces two
        // obtuse angles and flips to the short diagonal 1–3.
        let pos = [
            [-2.0, 0.0, 0.0],
            [0.0, -0.5, 0.0],
            [2.0, 0.0, 0.0],
            [0.0, 0.5, 0.0],
        ];
        let tris = [[0, 1, 2], [0, 2, 3]];
        let d = Intrinsic::delaunay(&pos, &tris);
        assert_eq!(d.flips, 1);
        let mut edges: Vec<(u32, u32, f64)> = Vec::new();
        for (t, l) in d.triangles.iter().zip(&d.lengths) {
            for c in 0..3 {
                let (a, b) = (t[c], t[(c + 1) % 3]);
                edges.push((a.min(b), a.max(b), l[c]));
            }
        }
        assert!(edges
            .iter()
            .any(|e| e.0 == 1 && e.1 == 3 && (e.2 - 1.0).abs() < 1e-12));
        assert!(!edges.iter().any(|e| e.0 == 0 && e.1 == 2));
        // Same area, every angle's cotangent sum now non-negative.
        let total: f64 = d.lengths.iter().map(|l| area(l[0], l[1], l[2])).sum();
        assert!((total - 2.0).abs() < 1e-12, "{total}");
        // Already Delaunay: nothing to do.
        let again = Intrinsic::delaunay(&pos, &d.triangles);
        assert_eq!(again.flips, 0);
    }
}
