//! Planar bones (paper 000 §4.1–4.2): the mesh rides a triangulated control surface of the
//! markers.
//!
//! * [`triangulate`]: the control surface (Delaunay in the cylindrical projection, openings and
//!   slivers removed).
//! * [`region`]: one bone in f64: frames, regions (eqs 3–5), local coordinates, falloff (eq 12).
//! * [`influences`] (this module): per vertex, the bones within their radius, their regions,
//!   local coordinates and weights, at most K, renormalised and quantised for the blob.
//! * [`reference`]: eqs 1–12 evaluated directly in f64, the specification the runtime's
//!   fixed-point kernel is checked against.

pub mod region;
pub mod triangulate;

use facebake_runtime::deformer::planar::{PlanarInfluence, PLANAR_WEIGHT_FRAC_BITS};
use facebake_runtime::format::records::MAX_TRIANGLES;

use crate::mesh::distance;
use region::{falloff, Frame, Region, V3};

/// Default bone radius as a multiple of the closest connected-marker distance (§4.2).
pub const DEFAULT_RADIUS_FACTOR: f64 = 1.0;

/// A control triangle whose smallest angle at rest is below this (degrees) is degenerate.
pub const DEGENERATE_ANGLE_DEGREES: f64 = 0.5;

/// The planar influences could not be baked.
#[derive(Debug, thiserror::Error)]
pub enum PlanarError {
    /// The control surface.
    #[error("building the control surface: {0}")]
    Triangulate(#[from] triangulate::TriangulateError),
    /// More triangles than the runtime's scratch holds.
    #[error("{found} control triangles: the runtime holds at most {MAX_TRIANGLES}")]
    TooManyTriangles {
        /// Triangles in the control surface.
        found: usize,
    },
    /// A given triangle names a marker that does not exist or repeats one.
    #[error(
        "control triangle {triangle} ({markers:?}) must name three distinct markers below {count}"
    )]
    BadTriangle {
        /// Its index.
        triangle: usize,
        /// Its markers.
        markers: [usize; 3],
        /// Marker count.
        count: usize,
    },
    /// A control triangle has (nearly) collinear markers at rest.
    #[error("control triangle {triangle} ({markers:?}) is degenerate at rest (smallest angle {angle:.2}°)")]
    DegenerateTriangle {
        /// Its index.
        triangle: usize,
        /// Its markers.
        markers: [usize; 3],
        /// Its smallest angle.
        angle: f64,
    },
    /// A local coordinate does not fit its fixed-point format.
    #[error("vertex {vertex}: local coordinate {value} in control triangle {triangle} does not fit the blob's format")]
    CoordinateRange {
        /// The vertex.
        vertex: usize,
        /// The triangle.
        triangle: usize,
        /// The value, in its format's units.
        value: f64,
    },
}

/// One baked influence in f64: which bone, which region, and the weight.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Influence {
    /// Control triangle.
    pub triangle: usize,
    /// Region of the vertex for that triangle.
    pub region: Region,
    /// Weight (the vertex's weights sum to one).
    pub weight: f64,
}

/// The bone radius of every triangle: `factor` × the closest distance from one of its markers
/// to a marker connected to it in the control surface (§4.2).
pub fn radii(markers: &[V3], triangles: &[[usize; 3]], factor: f64) -> Vec<f64> {
    let mut closest = vec![f64::INFINITY; markers.len()];
    for t in triangles {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            let d = distance(&markers[a], &markers[b]);
            closest[a] = closest[a].min(d);
            closest[b] = closest[b].min(d);
        }
    }
    triangles
        .iter()
        .map(|t| factor * t.iter().map(|&m| closest[m]).fold(f64::INFINITY, f64::min))
        .collect()
}

/// Check given triangles and build their rest frames.
pub fn frames(markers: &[V3], triangles: &[[usize; 3]]) -> Result<Vec<Frame>, PlanarError> {
    if triangles.len() > MAX_TRIANGLES {
        return Err(PlanarError::TooManyTriangles {
            found: triangles.len(),
        });
    }
    triangles
        .iter()
        .enumerate()
        .map(|(i, t)| {
            if t.iter().any(|&m| m >= markers.len()) || t[0] == t[1] || t[1] == t[2] || t[0] == t[2]
            {
                return Err(PlanarError::BadTriangle {
                    triangle: i,
                    markers: *t,
                    count: markers.len(),
                });
            }
            let corners = t.map(|m| markers[m]);
            let angle = triangulate::smallest_angle_degrees(corners);
            match Frame::new(corners) {
                Some(f) if angle >= DEGENERATE_ANGLE_DEGREES => Ok(f),
                _ => Err(PlanarError::DegenerateTriangle {
                    triangle: i,
                    markers: *t,
                    angle,
                }),
            }
        })
        .collect()
}

/// Discontinuity masks for planar bones: per vertex, the markers it may ride only partly, each
/// with the share of eq 12's weight kept for a control triangle holding it (0: forbidden). Built
/// from the surface-aware masks' sides by [`crate::surface::masks::marker_allowance`].
pub type MarkerAllowance = Vec<Vec<(usize, f64)>>;

/// The share of eq 12's weight vertex allowance `allowed` keeps for triangle `t`: the least
/// over its markers.
fn keep(allowed: &[(usize, f64)], t: &[usize; 3]) -> f64 {
    allowed
        .iter()
        .filter(|(m, _)| t.contains(m))
        .map(|&(_, k)| k)
        .fold(1.0, f64::min)
}

/// Per vertex, its at most `k` bones by eq 12's weight (scaled by `masks`, if any),
/// renormalised to sum to one. A vertex within no bone's radius rides its closest bone alone
/// (weight one; the closest the masks allow, if any), so every vertex follows the control
/// surface (and a rigid motion of the markers moves the whole mesh rigidly).
pub fn influences(
    vertices: &[V3],
    triangles: &[[usize; 3]],
    frames: &[Frame],
    radii: &[f64],
    k: usize,
    masks: Option<&MarkerAllowance>,
) -> Vec<Vec<Influence>> {
    vertices
        .iter()
        .enumerate()
        .map(|(v, s)| {
            let allowed = masks.map_or(&[][..], |m| &m[v][..]);
            let mut all: Vec<(usize, Region, f64, f64, f64)> = frames
                .iter()
                .zip(radii)
                .enumerate()
                .map(|(t, (f, &r))| {
                    let region = f.classify(s);
                    let d = f.distance(region, s);
                    let kept = keep(allowed, &triangles[t]);
                    (t, region, d, kept * falloff(d, r), kept)
                })
                .collect();
            all.sort_by(|a, b| b.3.total_cmp(&a.3).then(a.2.total_cmp(&b.2)));
            if all.first().is_none_or(|a| a.3 <= 0.0) {
                // Nothing in range: the closest bone, preferring those the masks allow.
                all.sort_by(|a, b| (a.4 <= 0.0).cmp(&(b.4 <= 0.0)).then(a.2.total_cmp(&b.2)));
                return all
                    .first()
                    .map(|&(triangle, region, ..)| Influence {
                        triangle,
                        region,
                        weight: 1.0,
                    })
                    .into_iter()
                    .collect();
            }
            all.truncate(k);
            all.retain(|a| a.3 > 0.0);
            let total: f64 = all.iter().map(|a| a.3).sum();
            all.into_iter()
                .map(|(triangle, region, _, w, _)| Influence {
                    triangle,
                    region,
                    weight: w / total,
                })
                .collect()
        })
        .collect()
}

/// The influences of a `piece` of `vertices` as one: those of its centre, within the masks of
/// its vertex nearest the centre. `None` for an empty piece.
fn piece_influences(
    vertices: &[V3],
    piece: &[u32],
    triangles: &[[usize; 3]],
    frames: &[Frame],
    radii: &[f64],
    masks: Option<&MarkerAllowance>,
) -> Option<Vec<Influence>> {
    let piece: Vec<u32> = piece
        .iter()
        .copied()
        .filter(|&v| (v as usize) < vertices.len())
        .collect();
    let centre = crate::mesh::centroid(vertices, &piece);
    let nearest = piece.iter().copied().min_by(|&a, &b| {
        crate::mesh::distance(&centre, &vertices[a as usize])
            .total_cmp(&crate::mesh::distance(&centre, &vertices[b as usize]))
    })?;
    let allowance = masks
        .and_then(|m| m.get(nearest as usize))
        .map(|a| vec![a.clone()]);
    influences(
        &[centre],
        triangles,
        frames,
        radii,
        usize::MAX,
        allowance.as_ref(),
    )
    .pop()
}

/// Weights quantised to Q1.15 summing to exactly 2¹⁵ (largest remainders get the spare
/// units); influences whose weight rounds to zero are dropped.
pub fn quantise_weights(row: &[Influence]) -> Vec<(Influence, u16)> {
    let one = 1u32 << PLANAR_WEIGHT_FRAC_BITS;
    let scaled: Vec<f64> = row.iter().map(|i| i.weight * f64::from(one)).collect();
    let mut q: Vec<u32> = scaled.iter().map(|x| x.floor().max(0.0) as u32).collect();
    let mut order: Vec<usize> = (0..row.len()).collect();
    order.sort_by(|&a, &b| {
        (scaled[b] - scaled[b].floor()).total_cmp(&(scaled[a] - scaled[a].floor()))
    });
    let mut spare = one.saturating_sub(q.iter().sum());
    for &i in order.iter().cycle().take(row.len() * 2) {
        if spare == 0 {
            break;
        }
        q[i] += 1;
        spare -= 1;
    }
    row.iter()
        .zip(q)
        .filter(|(_, w)| *w > 0)
        .map(|(i, w)| (*i, w as u16))
        .collect()
}

/// The blob records of one vertex `s` (rig units) for its quantised influences.
pub fn records(
    vertex: usize,
    s: &V3,
    frames: &[Frame],
    row: &[(Influence, u16)],
) -> Result<Vec<PlanarInfluence>, PlanarError> {
    row.iter()
        .map(|&(inf, weight)| {
            let local = frames[inf.triangle].local(inf.region, s);
            // Fractional bits per coordinate (see the runtime's `PlanarDeformer`).
            let bits = match inf.region {
                Region::Triangle => [26, 26, 24, 24],
                Region::Edge(_) => [26, 24, 24, 24],
                Region::Apex(_) | Region::Centroid => [24, 24, 24, 24],
            };
            let mut coords = [0i32; 4];
            for ((c, x), b) in coords.iter_mut().zip(local).zip(bits) {
                let q = (x * f64::from(1u32 << b)).round();
                if !(q.is_finite() && q.abs() < f64::from(i32::MAX)) {
                    return Err(PlanarError::CoordinateRange {
                        vertex,
                        triangle: inf.triangle,
                        value: x,
                    });
                }
                *c = q as i32;
            }
            Ok(PlanarInfluence {
                triangle: inf.triangle as u16,
                region: inf.region.code(),
                weight,
                coords,
            })
        })
        .collect()
}

/// A baked control surface and its influences.
pub struct PlanarBake {
    /// Control triangles (marker indices).
    pub triangles: Vec<[usize; 3]>,
    /// Bone radius per triangle, asset units.
    pub radii: Vec<f64>,
    /// Per vertex, its influences with the quantised weights (as f64), for the reference.
    pub rows: Vec<Vec<Influence>>,
    /// Per vertex, the blob records.
    pub records: Vec<Vec<PlanarInfluence>>,
    /// Per vertex, the share of its eq-12 weight dropped by keeping K.
    pub dropped: Vec<f64>,
    /// Vertices within no bone's radius (they ride their closest bone).
    pub outside: usize,
    /// Largest weight rounding error.
    pub max_weight_rounding: f64,
}

/// What the planar bake is made of besides the mesh and markers.
pub struct PlanarOptions<'a> {
    /// The control triangles; `None` builds the automatic control surface.
    pub given: Option<&'a [[usize; 3]]>,
    /// Bones per vertex.
    pub k: usize,
    /// Bone radius as a multiple of the closest connected-marker distance.
    pub radius_factor: f64,
    /// Discontinuity masks, per vertex (see [`MarkerAllowance`]).
    pub masks: Option<&'a MarkerAllowance>,
    /// Static anchoring: a control triangle of skull markers, and per vertex the share of its
    /// weight that rides it ([`crate::surface::anchoring`]), so that the skin beyond the
    /// markers (cranium, back of the head) follows the skull instead of the nearest face bone.
    pub anchor: Option<([usize; 3], &'a [f64])>,
    /// Pieces of the mesh (glTF vertices) that move as one (teeth): every vertex takes the
    /// bones and weights of the piece's centre, so a blend of the bones' motions moves the
    /// piece as a whole instead of bending it.
    pub rigid: &'a [Vec<u32>],
}

/// Bake planar bones: the control surface (`given` triangles, or the automatic one from the
/// mesh's `vertices` and `faces`), then every vertex's influences. Positions in asset units;
/// `to_rig` maps them to rig units, where the local coordinates are stored.
pub fn bake(
    vertices: &[V3],
    faces: &[[u32; 3]],
    markers: &[V3],
    options: &PlanarOptions<'_>,
    to_rig: impl Fn(&V3) -> V3,
) -> Result<PlanarBake, PlanarError> {
    let PlanarOptions {
        given,
        k,
        radius_factor,
        masks,
        anchor,
        rigid,
    } = *options;
    let mut triangles = match given {
        Some(t) => t.to_vec(),
        None => triangulate::control_surface(vertices, faces, markers)?,
    };
    // The skull's bone, last, so that every other bone keeps its index.
    let skull = anchor.map(|(t, strength)| {
        triangles.push(t);
        (triangles.len() - 1, strength)
    });
    let rest_frames = frames(markers, &triangles)?;
    let radii = radii(markers, &triangles, radius_factor);
    // The face's bones only: the skull's is blended in below.
    let face = skull.map_or(triangles.len(), |(t, _)| t);
    let mut all = influences(
        vertices,
        &triangles[..face],
        &rest_frames[..face],
        &radii[..face],
        usize::MAX,
        masks,
    );
    for piece in rigid {
        let Some(row) = piece_influences(
            vertices,
            piece,
            &triangles[..face],
            &rest_frames[..face],
            &radii[..face],
            masks,
        ) else {
            continue;
        };
        // Over each bone's triangle region, extended: its local coordinates are affine, so
        // the blend is one affine motion of the whole piece (an apex's are not).
        let row: Vec<Influence> = row
            .into_iter()
            .map(|i| Influence {
                region: Region::Triangle,
                ..i
            })
            .collect();
        for &v in piece {
            if let Some(r) = all.get_mut(v as usize) {
                r.clone_from(&row);
            }
        }
    }
    if let Some((t, strength)) = skull {
        for (row, &strength) in all.iter_mut().zip(strength) {
            if strength <= 0.0 {
                continue;
            }
            // Room for the skull's bone within K: the face's strongest K − 1, renormalised to
            // 1 − strength.
            row.truncate(k.saturating_sub(1).max(1));
            let total: f64 = row.iter().map(|i| i.weight).sum();
            for i in row.iter_mut() {
                i.weight *= (1.0 - strength) / total.max(f64::MIN_POSITIVE);
            }
            row.retain(|i| i.weight > 0.0);
            // Translated with the skull markers' centroid, not turned with their triangle:
            // a small turn of three close markers (a brow's frown) would swing the back of
            // the head by their distance to it.
            row.push(Influence {
                triangle: t,
                region: Region::Centroid,
                weight: strength,
            });
            row.sort_by(|a, b| b.weight.total_cmp(&a.weight));
        }
    }
    let rig_markers: Vec<V3> = markers.iter().map(&to_rig).collect();
    let rig_frames = frames(&rig_markers, &triangles)?;
    let (mut rows, mut records, mut dropped) = (vec![], vec![], vec![]);
    let (mut outside, mut max_rounding) = (0, 0.0f64);
    for (v, (s, full)) in vertices.iter().zip(all).enumerate() {
        let kept: Vec<Influence> = full.iter().take(k).copied().collect();
        let kept_mass: f64 = kept.iter().map(|i| i.weight).sum();
        dropped.push(1.0 - kept_mass);
        let renormalised: Vec<Influence> = kept
            .iter()
            .map(|i| Influence {
                weight: i.weight / kept_mass,
                ..*i
            })
            .collect();
        if full.len() == 1 && full[0].weight == 1.0 {
            let f = &rest_frames[full[0].triangle];
            outside +=
                usize::from(falloff(f.distance(full[0].region, s), radii[full[0].triangle]) <= 0.0);
        }
        let q = quantise_weights(&renormalised);
        let one = f64::from(1u32 << PLANAR_WEIGHT_FRAC_BITS);
        for (i, w) in &q {
            max_rounding = max_rounding.max((i.weight - f64::from(*w) / one).abs());
        }
        records.push(self::records(v, &to_rig(s), &rig_frames, &q)?);
        rows.push(
            q.iter()
                .map(|(i, w)| Influence {
                    weight: f64::from(*w) / one,
                    ..*i
                })
                .collect(),
        );
    }
    Ok(PlanarBake {
        triangles,
        radii,
        rows,
        records,
        dropped,
        outside,
        max_weight_rounding: max_rounding,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square() -> Vec<V3> {
        vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.5, 0.0, 0.0],
        ]
    }

    #[test]
    fn given_triangles_are_checked_with_errors_naming_them() {
        let m = square();
        assert!(frames(&m, &[[0, 1, 2], [0, 2, 3]]).is_ok());
        assert!(matches!(
            frames(&m, &[[0, 1, 2], [0, 9, 3]]),
            Err(PlanarError::BadTriangle { triangle: 1, .. })
        ));
        assert!(matches!(
            frames(&m, &[[0, 0, 2]]),
            Err(PlanarError::BadTriangle { triangle: 0, .. })
        ));
        // Markers 0, 4, 1 are collinear.
        let err = frames(&m, &[[0, 1, 2], [0, 4, 1]]).unwrap_err();
        assert!(matches!(
            err,
            PlanarError::DegenerateTriangle { triangle: 1, .. }
        ));
        assert!(err.to_string().contains("degenerate at rest"), "{err}");
        let many = vec![[0, 1, 2]; MAX_TRIANGLES + 1];
        assert!(matches!(
            frames(&m, &many),
            Err(PlanarError::TooManyTriangles { .. })
        ));
    }

    #[test]
    fn influences_blend_near_bones_and_fall_back_to_the_closest() {
        let m = square();
        let tris = [[0, 1, 2], [0, 2, 3]];
        let f = frames(&m, &tris).unwrap();
        let r = radii(&m, &tris, 1.0);
        // The closest connected marker of every corner is 1 away.
        assert_eq!(r, vec![1.0, 1.0]);
        let points = [[0.7, 0.3, 0.0], [0.5, 0.5, 0.05], [0.0, 9.0, 0.0]];
        let rows = influences(&points, &tris, &f, &r, 8, None);
        // Inside triangle 0, in R_A of 0 (weight 1) and in an edge slab of 1.
        assert_eq!(rows[0][0].triangle, 0);
        assert_eq!(rows[0][0].region, Region::Triangle);
        assert!((rows[0].iter().map(|i| i.weight).sum::<f64>() - 1.0).abs() < 1e-12);
        // On the shared diagonal, just above: both bones, equal weights.
        assert_eq!(rows[1].len(), 2);
        assert!((rows[1][0].weight - 0.5).abs() < 1e-12);
        // Far away: the closest bone alone.
        assert_eq!(rows[2].len(), 1);
        assert_eq!(rows[2][0].weight, 1.0);
        // Masks: marker 1 forbidden for the first vertex, halved for the second; the third
        // may not ride marker 3, so its closest allowed bone is triangle 0.
        let masks = vec![vec![(1, 0.0)], vec![(1, 0.5)], vec![(3, 0.0)]];
        let masked = influences(&points, &tris, &f, &r, 8, Some(&masks));
        assert!(masked[0].iter().all(|i| i.triangle == 1));
        assert!((masked[1][0].weight - 2.0 / 3.0).abs() < 1e-12);
        assert_eq!(masked[1][0].triangle, 1);
        assert_eq!(masked[2].len(), 1);
        assert_eq!(masked[2][0].triangle, 0);
        // Unmasked, the far vertex rides triangle 1 (its closest); check the test means it.
        assert_eq!(rows[2][0].triangle, 1);
    }

    #[test]
    fn quantised_weights_sum_to_one_exactly() {
        let row: Vec<Influence> = [0.5, 0.3, 0.2 - 1e-9, 1e-9]
            .iter()
            .enumerate()
            .map(|(t, &w)| Influence {
                triangle: t,
                region: Region::Triangle,
                weight: w,
            })
            .collect();
        let q = quantise_weights(&row);
        assert_eq!(q.iter().map(|x| u32::from(x.1)).sum::<u32>(), 1 << 15);
        assert_eq!(q.len(), 3, "the vanishing weight is dropped");
    }
}
