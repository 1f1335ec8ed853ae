//! One planar bone in f64: its frames (paper 000 eqs 2, 6–8), the region a point falls in
//! (eqs 3–5), the point's local coordinates in that region's rest frame, its distance to the
//! bone and its falloff weight (eq 12).
//!
//! Conventions: the triangle is (O, P, Q) = (V₀, V₁, V₂), indices modulo 3, edges
//! e_i = V_{i+1} − V_i (eq 6), n = unit((P − O) × (Q − O)) (eq 2), u_i = unit(e_i × n) (the
//! second row of B_i, eq 7), which points out of the triangle across edge i.
//!
//! Eq 3 is read with (u, v) the affine coordinates of the projection Π(S) along P − O and Q − O
//! and w = u + v: the triangle is u ≥ 0, v ≥ 0, w ≤ 1, and a point is beyond edge 0 when v < 0,
//! beyond edge 1 when w > 1 and beyond edge 2 when u < 0. A point beyond one edge i is a
//! candidate R′_B,i and eq 4 settles it; a point beyond the two edges that meet at V_i
//! (edges i − 1 and i) is a candidate R′_C,i and eq 5 settles it.

use facebake_runtime::deformer::planar::CENTROID_REGION;

use crate::mesh::{dot, norm, sub};

/// A 3-vector.
pub type V3 = [f64; 3];

pub(crate) fn cross(a: &V3, b: &V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

pub(crate) fn add(a: &V3, b: &V3) -> V3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

pub(crate) fn scale(a: &V3, s: f64) -> V3 {
    [a[0] * s, a[1] * s, a[2] * s]
}

fn unit(a: &V3) -> Option<V3> {
    let l = norm(a);
    (l > 0.0 && l.is_finite()).then(|| scale(a, 1.0 / l))
}

/// The region of a planar bone a point belongs to (eqs 3–5).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Region {
    /// Over the triangle: R_A.
    Triangle,
    /// The slab beyond edge i: R_B,i.
    Edge(usize),
    /// The wedge beyond apex V_i: R_C,i.
    Apex(usize),
    /// Anywhere, translated with the triangle's centroid without turning: R_T (not in the
    /// paper; the static anchoring's skull bone, never found by [`Frame::classify`]).
    Centroid,
}

impl Region {
    /// The blob's region code: 0 = R_A, 1 + i = R_B,i, 4 + i = R_C,i, 7 = R_T.
    pub fn code(self) -> u8 {
        match self {
            Self::Triangle => 0,
            Self::Edge(i) => 1 + i as u8,
            Self::Apex(i) => 4 + i as u8,
            Self::Centroid => CENTROID_REGION,
        }
    }

    /// The region of a blob code (3 bits: every code names a region).
    pub fn from_code(code: u8) -> Self {
        match code {
            0 => Self::Triangle,
            1..=3 => Self::Edge(usize::from(code - 1)),
            CENTROID_REGION => Self::Centroid,
            _ => Self::Apex(usize::from(code - 4) % 3),
        }
    }

    /// The corner the region's frame is anchored at: O for R_A, V_i for R_B,i and R_C,i, none
    /// for R_T (its origin is the centroid).
    pub fn origin(self) -> Option<usize> {
        match self {
            Self::Triangle => Some(0),
            Self::Edge(i) | Self::Apex(i) => Some(i),
            Self::Centroid => None,
        }
    }
}

/// A triangle's frame vectors (eqs 2, 6, 7, 8).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    /// Corners O, P, Q.
    pub v: [V3; 3],
    /// Edges e_i = V_{i+1} − V_i.
    pub e: [V3; 3],
    /// Unit normal n.
    pub n: V3,
    /// Unit edge normals u_i = unit(e_i × n).
    pub u: [V3; 3],
}

impl Frame {
    /// The frame of the triangle `v`, or `None` if it has no normal (collinear corners).
    pub fn new(v: [V3; 3]) -> Option<Frame> {
        let e = [0, 1, 2].map(|i| sub(&v[(i + 1) % 3], &v[i]));
        let n = unit(&cross(&e[0], &sub(&v[2], &v[0])))?;
        let u = [
            unit(&cross(&e[0], &n))?,
            unit(&cross(&e[1], &n))?,
            unit(&cross(&e[2], &n))?,
        ];
        Some(Frame { v, e, n, u })
    }

    /// c_i(S) of eq 6: the position of S along edge i, from V_i, in length units.
    pub fn along(&self, i: usize, s: &V3) -> f64 {
        dot(&sub(s, &self.v[i]), &self.e[i]) / norm(&self.e[i])
    }

    /// Affine coordinates (a, b) of the projection of `s` along P − O and Q − O.
    fn affine(&self, s: &V3) -> (f64, f64) {
        let d = sub(s, &self.v[0]);
        let (p, q) = (self.e[0], sub(&self.v[2], &self.v[0]));
        let (pp, pq, qq) = (dot(&p, &p), dot(&p, &q), dot(&q, &q));
        let (dp, dq) = (dot(&d, &p), dot(&d, &q));
        let det = pp * qq - pq * pq;
        ((dp * qq - dq * pq) / det, (dq * pp - dp * pq) / det)
    }

    /// The region of `s` (eqs 3–5).
    pub fn classify(&self, s: &V3) -> Region {
        let (a, b) = self.affine(s);
        let beyond = [b < 0.0, a + b > 1.0, a < 0.0];
        let len = |i: usize| norm(&self.e[i]);
        match beyond {
            [false, false, false] => Region::Triangle,
            // Beyond one edge i: eq 4.
            [true, false, false] | [false, true, false] | [false, false, true] => {
                let i = beyond.iter().position(|&x| x).unwrap_or(0);
                let c = self.along(i, s);
                if c < 0.0 {
                    Region::Apex(i)
                } else if c <= len(i) {
                    Region::Edge(i)
                } else {
                    Region::Apex((i + 1) % 3)
                }
            }
            // Beyond the two edges meeting at V_i (i − 1 and i): eq 5.
            _ => {
                let i = if !beyond[1] {
                    0
                } else if !beyond[2] {
                    1
                } else {
                    2
                };
                let h = (i + 2) % 3;
                if self.along(h, s) <= len(h) {
                    Region::Edge(h)
                } else if self.along(i, s) < 0.0 {
                    Region::Apex(i)
                } else {
                    Region::Edge(i)
                }
            }
        }
    }

    /// The centroid of the corners, R_T's origin.
    pub fn centroid(&self) -> V3 {
        scale(&add(&add(&self.v[0], &self.v[1]), &self.v[2]), 1.0 / 3.0)
    }

    /// Distance from `s` to the part of the bone its region is measured from: the plane over
    /// the triangle (R_A), edge i's segment (R_B,i), corner V_i (R_C,i) or the centroid (R_T).
    pub fn distance(&self, region: Region, s: &V3) -> f64 {
        match region {
            Region::Centroid => norm(&sub(s, &self.centroid())),
            Region::Triangle => dot(&sub(s, &self.v[0]), &self.n).abs(),
            Region::Edge(i) => {
                let l = norm(&self.e[i]);
                let t = (self.along(i, s) / l).clamp(0.0, 1.0);
                norm(&sub(s, &add(&self.v[i], &scale(&self.e[i], t))))
            }
            Region::Apex(i) => norm(&sub(s, &self.v[i])),
        }
    }

    /// Local coordinates of `s` in its region's rest frame, as the blob stores them (x, y, z, w;
    /// see the runtime's `PlanarDeformer`): R_A the affine coordinates along P − O and Q − O and the
    /// height; R_B,i the fraction along e_i, the distance along u_i and the height; R_C,i the
    /// components along u_i and u_{i−1}, the height and the in-plane distance D_i(S) of eq 10;
    /// R_T the offset from the centroid.
    pub fn local(&self, region: Region, s: &V3) -> [f64; 4] {
        match region {
            Region::Centroid => {
                let d = sub(s, &self.centroid());
                [d[0], d[1], d[2], 0.0]
            }
            Region::Triangle => {
                let (a, b) = self.affine(s);
                [a, b, dot(&sub(s, &self.v[0]), &self.n), 0.0]
            }
            Region::Edge(i) => {
                let d = sub(s, &self.v[i]);
                let e = self.e[i];
                [
                    dot(&d, &e) / dot(&e, &e),
                    dot(&d, &self.u[i]),
                    dot(&d, &self.n),
                    0.0,
                ]
            }
            Region::Apex(i) => {
                let d = sub(s, &self.v[i]);
                let h = dot(&d, &self.n);
                let planar = sub(&d, &scale(&self.n, h));
                let (p, q) = (self.u[i], self.u[(i + 2) % 3]);
                let (pp, pq, qq) = (dot(&p, &p), dot(&p, &q), dot(&q, &q));
                let (dp, dq) = (dot(&planar, &p), dot(&planar, &q));
                let det = pp * qq - pq * pq;
                [
                    (dp * qq - dq * pq) / det,
                    (dq * pp - dp * pq) / det,
                    h,
                    norm(&planar),
                ]
            }
        }
    }
}

/// The cosine falloff of eq 12: 1 at distance 0, 0 from the radius on.
pub fn falloff(distance: f64, radius: f64) -> f64 {
    if distance < radius {
        0.5 * (1.0 + (distance / radius * std::f64::consts::PI).cos())
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn right() -> Frame {
        Frame::new([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]).unwrap()
    }

    #[test]
    fn regions_split_the_plane_around_a_right_triangle() {
        let f = right();
        let cases = [
            ([0.2, 0.2, 0.3], Region::Triangle),
            ([0.5, -0.5, 0.0], Region::Edge(0)),
            ([0.7, 0.7, 0.0], Region::Edge(1)),
            ([-0.5, 0.5, 0.0], Region::Edge(2)),
            ([-0.2, -0.1, 0.0], Region::Apex(0)),
            ([1.5, -0.1, 0.0], Region::Apex(1)),
            ([1.5, 0.2, 0.0], Region::Apex(1)),
            ([-0.1, 1.5, 0.0], Region::Apex(2)),
            ([0.2, 1.5, 0.0], Region::Apex(2)),
        ];
        for (s, want) in cases {
            assert_eq!(f.classify(&s), want, "{s:?}");
        }
    }

    #[test]
    fn local_coordinates_rebuild_the_point() {
        let f = Frame::new([[0.1, 0.0, 0.2], [1.0, 0.3, 0.0], [0.2, 0.9, 0.4]]).unwrap();
        for s in [
            [0.4, 0.4, 0.5],
            [0.6, -0.5, 0.1],
            [1.2, 1.0, -0.2],
            [-0.6, 0.6, 0.3],
            [-0.3, -0.4, 0.0],
            [1.6, 0.0, 0.3],
            [0.1, 1.6, -0.3],
        ] {
            let [dx, dy, dz, _] = f.local(Region::Centroid, &s);
            let back = add(&f.centroid(), &[dx, dy, dz]);
            assert!(norm(&sub(&back, &s)) < 1e-12, "{s:?} R_T → {back:?}");
            let region = f.classify(&s);
            let [x, y, z, w] = f.local(region, &s);
            let o = f.v[region.origin().expect("classify finds a bone region")];
            let back = match region {
                Region::Centroid => unreachable!("classify never finds R_T"),
                Region::Triangle => add(
                    &add(&o, &scale(&f.e[0], x)),
                    &add(&scale(&sub(&f.v[2], &f.v[0]), y), &scale(&f.n, z)),
                ),
                Region::Edge(i) => add(
                    &add(&o, &scale(&f.e[i], x)),
                    &add(&scale(&f.u[i], y), &scale(&f.n, z)),
                ),
                Region::Apex(i) => {
                    let p = add(&scale(&f.u[i], x), &scale(&f.u[(i + 2) % 3], y));
                    assert!((norm(&p) - w).abs() < 1e-12);
                    add(&add(&o, &p), &scale(&f.n, z))
                }
            };
            assert!(norm(&sub(&back, &s)) < 1e-12, "{s:?} {region:?} → {back:?}");
        }
    }

    #[test]
    fn falloff_is_one_at_the_bone_and_zero_at_the_radius() {
        assert_eq!(falloff(0.0, 2.0), 1.0);
        assert!((falloff(1.0, 2.0) - 0.5).abs() < 1e-15);
        assert_eq!(falloff(2.0, 2.0), 0.0);
        assert_eq!(falloff(3.0, 2.0), 0.0);
    }
}
