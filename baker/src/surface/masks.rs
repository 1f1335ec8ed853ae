//! Discontinuity masks (paper 000 §4.3, paper 003 §4.2): the markers of one side of an opening
//! (upper lip, upper eyelid) may not move the other side.
//!
//! Each vertex gets, per mask, a side and a strength in [0, 1]. The side comes from (a) given
//! vertex sets (nearest set along the mesh edges) or (c) automatically, from the marker group
//! nearest along the surface: the geodesic runs around the opening, so the lower lip is nearer
//! the lower-lip markers even where the upper lip is closer in space. The strength decays as a
//! Gaussian of the distance to the mask's openings (automatic) or to its vertex sets, so the
//! mask fades out away from the opening instead of cutting the cheek. A masked vertex's weights
//! are `s · w_masked + (1 − s) · w_all`, `w_masked` from an RBF over the markers its side may see.

use std::collections::HashMap;

use nalgebra::DMatrix;
use thiserror::Error;

use crate::model::{MarkerGroups, Side};
use crate::rbf::{Kernel, RbfSystem, SolveError};

use super::geometry::SurfaceGeometry;

/// Strengths below this leave a vertex unmasked.
const MIN_STRENGTH: f64 = 1e-6;

/// How vertex sides are found.
#[derive(Debug, Clone, PartialEq, Default)]
pub enum SideRule {
    /// From the nearest marker group along the surface, fading with the distance from the
    /// openings nearest the mask's markers.
    #[default]
    Auto,
    /// Per mask (in group order), the glTF vertices of its upper and of its lower side.
    VertexSets(Vec<(Vec<u32>, Vec<u32>)>),
}

/// Masks could not be set up.
#[derive(Debug, Error)]
pub enum MaskError {
    /// Automatic sides need an opening near the mask's markers.
    #[error("mask \"{0}\": the mesh has no opening (boundary loop) to separate its sides; give vertex sets")]
    NoOpening(String),
    /// Groups from the openings need a mouth and two eyes.
    #[error(
        "masks without a layout [groups] table are found from the mouth and eye openings: {0}"
    )]
    NoFaceOpenings(String),
    /// Vertex sets for a different number of masks.
    #[error("{sets} vertex-set pairs for {masks} masks")]
    SetCount {
        /// Pairs given.
        sets: usize,
        /// Masks.
        masks: usize,
    },
    /// A vertex set names a vertex the mesh does not have.
    #[error("mask \"{mask}\": vertex {vertex} is beyond the mesh's {vertex_count} vertices")]
    VertexOutOfRange {
        /// The mask.
        mask: String,
        /// The vertex.
        vertex: u32,
        /// Vertices in the mesh.
        vertex_count: usize,
    },
    /// A masked sub-system failed.
    #[error("mask \"{mask}\": {source}")]
    Solve {
        /// The mask.
        mask: String,
        /// Why.
        source: SolveError,
    },
}

/// One mask's side and strength at every glTF vertex.
#[derive(Debug, Clone)]
pub struct MaskSides {
    /// The mask's groups.
    pub groups: MarkerGroups,
    /// Per glTF vertex, its side (`None`: unreachable).
    pub side: Vec<Option<Side>>,
    /// Per glTF vertex, the mask's strength.
    pub strength: Vec<f64>,
    /// Openings (indices into the geometry's) this mask separates (automatic rule).
    pub openings: Vec<usize>,
}

/// Per mask, the openings whose loop centre is nearer one of its markers than any other
/// mask's markers.
pub fn assign_openings(
    groups: &[MarkerGroups],
    geometry: &SurfaceGeometry,
    markers: &[[f64; 3]],
) -> Vec<Vec<usize>> {
    let mut out = vec![Vec::new(); groups.len()];
    for (o, opening) in geometry.openings.iter().enumerate() {
        let nearest = groups
            .iter()
            .enumerate()
            .map(|(g, grp)| {
                let d = grp
                    .upper
                    .iter()
                    .chain(&grp.lower)
                    .map(|&m| crate::mesh::distance(&markers[m], &opening.centre))
                    .fold(f64::INFINITY, f64::min);
                (g, d)
            })
            .min_by(|a, b| a.1.total_cmp(&b.1));
        if let Some((g, _)) = nearest {
            out[g].push(o);
        }
    }
    out
}

/// A marker joins an opening's automatic group when it is within this many opening widths of
/// the opening's rim.
pub const AUTO_GROUP_REACH: f64 = 0.75;

/// A marker joins an opening's automatic group only when it lies over the opening's span less
/// this share of its width at each corner (markers at the corners move both sides).
pub const AUTO_GROUP_CORNER: f64 = 0.1;

/// Mask groups found from the mesh's own openings, for a layout without a `[groups]` table: a
/// `mouth` mask over the lip opening and an `eyes` mask over the two eye openings (y up, as
/// [`crate::placement::face_openings`] finds them). A marker belongs to an opening's group when
/// it lies over the opening's span (clear of its corners by [`AUTO_GROUP_CORNER`] of its width)
/// within [`AUTO_GROUP_REACH`] widths of its rim; it is on the upper side when it is above the
/// rim's middle at its x. So lip markers, and the chin's and nose's near the mouth, split into
/// upper and lower as a layout's groups would; brow and cheek markers join the eyes' groups.
pub fn groups_from_openings(
    mesh: &crate::model::FaceMesh,
    markers: &[[f64; 3]],
) -> Result<Vec<MarkerGroups>, MaskError> {
    let [lips, left, right] = crate::placement::face_openings(mesh)
        .map_err(|e| MaskError::NoFaceOpenings(e.to_string()))?;
    let rim = |l: &[u32]| -> Vec<[f64; 3]> {
        l.iter()
            .map(|&v| mesh.welded_positions[v as usize])
            .collect()
    };
    let mouth = rim(&lips);
    let eyes = [rim(&left), rim(&right)];
    let mut groups = vec![
        MarkerGroups {
            name: "mouth".into(),
            upper: Vec::new(),
            lower: Vec::new(),
        },
        MarkerGroups {
            name: "eyes".into(),
            upper: Vec::new(),
            lower: Vec::new(),
        },
    ];
    for (m, p) in markers.iter().enumerate() {
        let openings = std::iter::once((0, &mouth)).chain(eyes.iter().map(|e| (1, e)));
        for (g, rim) in openings {
            if let Some(side) = side_of_opening(rim, p) {
                let group = &mut groups[g];
                match side {
                    Side::Upper => group.upper.push(m),
                    Side::Lower => group.lower.push(m),
                }
            }
        }
    }
    // A mask keeps one side's markers off the other side: with no marker on a side it has
    // nothing to keep apart (see [`unmasked_openings`]).
    groups.retain(|g| !g.upper.is_empty() && !g.lower.is_empty());
    Ok(groups)
}

/// The lips' markers found from the openings, upper and lower ([`groups_from_openings`]'s
/// "mouth"); both empty when the mesh has no openings or no marker sits on both lips.
pub fn lips_from_openings(
    mesh: &crate::model::FaceMesh,
    markers: &[[f64; 3]],
) -> (Vec<usize>, Vec<usize>) {
    groups_from_openings(mesh, markers)
        .ok()
        .and_then(|g| g.into_iter().find(|g| g.name == "mouth"))
        .map_or_else(Default::default, |g| (g.upper, g.lower))
}

/// The masks [`groups_from_openings`] can find ("mouth", "eyes") that `groups` lacks, each
/// with why: no marker above or below the opening's rim.
pub fn unmasked_openings(groups: &[MarkerGroups]) -> Vec<String> {
    [
        ("mouth", "the lips are not masked: no marker sits over the mouth's span both above and below its rim"),
        ("eyes", "the eyelids are not masked: no marker sits over the eyes' span both above and below their rims"),
    ]
    .into_iter()
    .filter(|(name, _)| !groups.iter().any(|g| g.name == *name))
    .map(|(_, why)| format!("{why} (a layout's [groups] can name the markers of each side)"))
    .collect()
}

/// Which side of the opening with rim `rim` the point `p` is on, if it is in the opening's
/// group (see [`groups_from_openings`]).
fn side_of_opening(rim: &[[f64; 3]], p: &[f64; 3]) -> Option<Side> {
    let (lo, hi) = rim
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), q| {
            (lo.min(q[0]), hi.max(q[0]))
        });
    let width = hi - lo;
    let corner = AUTO_GROUP_CORNER * width;
    if !(width > 0.0 && p[0] > lo + corner && p[0] < hi - corner) {
        return None;
    }
    let near = rim
        .iter()
        .map(|q| crate::mesh::distance(p, q))
        .fold(f64::INFINITY, f64::min);
    if near > AUTO_GROUP_REACH * width {
        return None;
    }
    // The rim's middle at p's x: the mean height of its vertices within a band around x.
    let band = 0.15 * width;
    let (sum, count) = rim
        .iter()
        .filter(|q| (q[0] - p[0]).abs() <= band)
        .fold((0.0, 0usize), |(s, c), q| (s + q[1], c + 1));
    let middle = if count > 0 {
        sum / count as f64
    } else {
        rim.iter().map(|q| q[1]).sum::<f64>() / rim.len() as f64
    };
    Some(if p[1] > middle {
        Side::Upper
    } else {
        Side::Lower
    })
}

fn gaussian(d: f64, width: f64) -> f64 {
    if d.is_finite() {
        (-(d / width) * (d / width)).exp()
    } else {
        0.0
    }
}

/// Sides and strengths of every mask: full strength within `plateau` of the openings (or the
/// vertex sets), then a Gaussian fade of width `decay`; and where a vertex's distances to the
/// two sides differ by less than `side_band`, fading to nothing as they meet (at and past an
/// opening's corners, which belong to neither side; 0: no fade). Asset units.
pub fn vertex_sides(
    groups: &[MarkerGroups],
    rule: &SideRule,
    geometry: &SurfaceGeometry,
    markers: &[[f64; 3]],
    plateau: f64,
    decay: f64,
    side_band: f64,
) -> Result<Vec<MaskSides>, MaskError> {
    let vertex_count = geometry.weld.len();
    let openings = assign_openings(groups, geometry, markers);
    if let SideRule::VertexSets(sets) = rule {
        if sets.len() != groups.len() {
            return Err(MaskError::SetCount {
                sets: sets.len(),
                masks: groups.len(),
            });
        }
    }
    groups
        .iter()
        .enumerate()
        .map(|(g, grp)| {
            // Per welded vertex: distance to the upper side, to the lower side, to the mask.
            let nearest = |list: &[usize], x: usize| {
                list.iter()
                    .map(|&m| geometry.fields[m][x])
                    .fold(f64::INFINITY, f64::min)
            };
            let (up, low, reach): (Vec<f64>, Vec<f64>, Vec<f64>) = match rule {
                SideRule::Auto => {
                    if openings[g].is_empty() {
                        return Err(MaskError::NoOpening(grp.name.clone()));
                    }
                    let welded = geometry.fields.first().map_or(0, Vec::len);
                    let reach = (0..welded)
                        .map(|x| {
                            openings[g]
                                .iter()
                                .map(|&o| geometry.opening_distance[o][x])
                                .fold(f64::INFINITY, f64::min)
                        })
                        .collect();
                    (
                        (0..welded).map(|x| nearest(&grp.upper, x)).collect(),
                        (0..welded).map(|x| nearest(&grp.lower, x)).collect(),
                        reach,
                    )
                }
                SideRule::VertexSets(sets) => {
                    let welded_set = |set: &[u32]| {
                        set.iter()
                            .map(|&v| {
                                geometry.weld.get(v as usize).copied().ok_or_else(|| {
                                    MaskError::VertexOutOfRange {
                                        mask: grp.name.clone(),
                                        vertex: v,
                                        vertex_count,
                                    }
                                })
                            })
                            .collect::<Result<Vec<u32>, _>>()
                    };
                    let up = geometry.geodesics.from_vertex_set(&welded_set(&sets[g].0)?);
                    let low = geometry.geodesics.from_vertex_set(&welded_set(&sets[g].1)?);
                    let reach = up.iter().zip(&low).map(|(a, b)| a.min(*b)).collect();
                    (up, low, reach)
                }
            };
            let side = geometry
                .weld
                .iter()
                .map(|&x| {
                    let (u, l) = (up[x as usize], low[x as usize]);
                    match (u.is_finite(), l.is_finite()) {
                        (false, false) => None,
                        _ if u <= l => Some(Side::Upper),
                        _ => Some(Side::Lower),
                    }
                })
                .collect();
            let strength = geometry
                .weld
                .iter()
                .map(|&x| {
                    let (u, l) = (up[x as usize], low[x as usize]);
                    let apart = if side_band > 0.0 && u.is_finite() && l.is_finite() {
                        super::anchoring::smoothstep((u - l).abs() / side_band)
                    } else {
                        1.0
                    };
                    apart * gaussian((reach[x as usize] - plateau).max(0.0), decay)
                })
                .collect();
            Ok(MaskSides {
                groups: grp.clone(),
                side,
                strength,
                openings: openings[g].clone(),
            })
        })
        .collect()
}

/// The other side's markers of one mask at one vertex, if the mask touches it there: the
/// markers the vertex may not see, and the mask's strength.
fn other_side(mask: &MaskSides, v: usize) -> Option<(&[usize], f64)> {
    let s = mask.strength[v];
    let side = mask.side[v]?;
    if s <= MIN_STRENGTH {
        return None;
    }
    let other = match side {
        Side::Upper => &mask.groups.lower,
        Side::Lower => &mask.groups.upper,
    };
    Some((other, s))
}

/// The masks for planar bones: per vertex, each marker of another side's group with the share
/// `1 − strength` of eq 12's weight a control triangle holding it keeps (0 at full strength, so
/// a vertex on one side does not ride a triangle with a marker of the other side).
pub fn marker_allowance(
    masks: &[MaskSides],
    vertex_count: usize,
) -> crate::planar::MarkerAllowance {
    (0..vertex_count)
        .map(|v| {
            let mut row: Vec<(usize, f64)> = Vec::new();
            for (other, s) in masks.iter().filter_map(|m| other_side(m, v)) {
                for &m in other {
                    match row.iter_mut().find(|e| e.0 == m) {
                        Some(e) => e.1 = e.1.min(1.0 - s),
                        None => row.push((m, 1.0 - s)),
                    }
                }
            }
            row
        })
        .collect()
}

/// What a masked solve needs besides the sides: the system over every marker and the inputs
/// to rebuild it over a subset.
pub struct MaskedSolve<'a> {
    /// The system over every marker.
    pub full: &'a RbfSystem,
    /// Marker positions the system uses (rig units).
    pub centres: &'a [[f64; 3]],
    /// Marker-to-marker distances the system uses.
    pub between: &'a DMatrix<f64>,
    /// The kernel over every marker.
    pub kernel: &'a Kernel,
    /// Stiffness per marker.
    pub stiffness: &'a [f64],
    /// Ridge of the full system.
    pub ridge: f64,
}

/// A kernel restricted to `kept` centres.
fn kernel_subset(kernel: &Kernel, kept: &[usize]) -> Kernel {
    match kernel {
        Kernel::InverseMultiquadric { radii } => Kernel::InverseMultiquadric {
            radii: kept.iter().map(|&i| radii[i]).collect(),
        },
        other => other.clone(),
    }
}

/// Dense weights of every vertex (`distances[v]` its distances, `points[v]` its position in the
/// system's units) with the masks applied. Returns the rows and how many vertices a mask
/// touched.
pub fn masked_weights(
    solve: &MaskedSolve<'_>,
    masks: &[MaskSides],
    distances: &[Vec<f64>],
    points: &[[f64; 3]],
) -> Result<(Vec<Vec<f64>>, usize), MaskError> {
    let n = solve.full.len();
    let mut systems: HashMap<Vec<bool>, (Vec<usize>, RbfSystem)> = HashMap::new();
    let mut touched = 0;
    let mut rows = Vec::with_capacity(points.len());
    for (v, (d, p)) in distances.iter().zip(points).enumerate() {
        let full = solve.full.weights_from_distances(d, p);
        let mut excluded = vec![false; n];
        let mut strength = 0.0f64;
        let mut name = "";
        for mask in masks {
            let Some((other, s)) = other_side(mask, v) else {
                continue;
            };
            for &m in other {
                excluded[m] = true;
            }
            strength = strength.max(s);
            name = &mask.groups.name;
        }
        if strength == 0.0 {
            rows.push(full);
            continue;
        }
        touched += 1;
        if !systems.contains_key(&excluded) {
            let kept: Vec<usize> = (0..n).filter(|&i| !excluded[i]).collect();
            let centres: Vec<[f64; 3]> = kept.iter().map(|&i| solve.centres[i]).collect();
            let between = DMatrix::from_fn(kept.len(), kept.len(), |j, i| {
                solve.between[(kept[j], kept[i])]
            });
            let stiffness: Vec<f64> = kept.iter().map(|&i| solve.stiffness[i]).collect();
            let system = RbfSystem::with_distances(
                &centres,
                &between,
                kernel_subset(solve.kernel, &kept),
                solve.full.affine(),
                &stiffness,
                solve.ridge,
            )
            .map_err(|source| MaskError::Solve {
                mask: name.to_owned(),
                source,
            })?;
            systems.insert(excluded.clone(), (kept, system));
        }
        let (kept, system) = &systems[&excluded];
        let sub_d: Vec<f64> = kept.iter().map(|&i| d[i]).collect();
        let sub = system.weights_from_distances(&sub_d, p);
        let mut row: Vec<f64> = full.iter().map(|w| (1.0 - strength) * w).collect();
        for (&i, w) in kept.iter().zip(sub) {
            row[i] += strength * w;
        }
        rows.push(row);
    }
    Ok((rows, touched))
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::*;
    use crate::io::gltf_mesh::load_mesh;
    use crate::io::gltf_mesh::tests::{head, MEDIAPIPE};

    /// Points above, below, beside and far from a unit-wide opening (a circle of rim points in
    /// the xy plane centred at the origin).
    #[test]
    fn a_marker_joins_the_side_of_the_rim_it_is_on_within_reach() {
        let rim: Vec<[f64; 3]> = (0..32)
            .map(|i| {
                let a = f64::from(i) / 32.0 * std::f64::consts::TAU;
                [0.5 * a.cos(), 0.2 * a.sin(), 0.0]
            })
            .collect();
        assert_eq!(side_of_opening(&rim, &[0.0, 0.3, 0.0]), Some(Side::Upper));
        assert_eq!(side_of_opening(&rim, &[0.1, -0.5, 0.1]), Some(Side::Lower));
        // At a corner, beyond the span, or further than the reach: in no group.
        assert_eq!(side_of_opening(&rim, &[0.48, 0.05, 0.0]), None);
        assert_eq!(side_of_opening(&rim, &[0.7, 0.0, 0.0]), None);
        assert_eq!(side_of_opening(&rim, &[0.0, 1.2, 0.0]), None);
    }

    /// A mesh without a mouth and two eyes (MediaPipe's canonical face is one disk) has no
    /// openings to find groups from: an error that says so, not empty masks.
    #[test]
    fn a_face_without_openings_is_an_error() {
        let disk = load_mesh(Path::new(MEDIAPIPE), None, None).unwrap();
        let err = groups_from_openings(&disk, &[[0.0; 3]]).unwrap_err();
        assert!(matches!(err, MaskError::NoFaceOpenings(_)), "{err}");
        assert!(err.to_string().contains("openings"), "{err}");
        // FaceCap has them; with no marker on either side of them, there is nothing to mask.
        let face = head();
        let none = groups_from_openings(face, &[]).unwrap();
        assert!(none.is_empty());
        assert_eq!(unmasked_openings(&none).len(), 2);
        assert_eq!(lips_from_openings(face, &[]), (Vec::new(), Vec::new()));
    }
}
