//! The openings of a face mesh (mouth, eyes): the boundary loops of its largest piece, less the
//! loop where the mesh is cut off (the neck of a head, the rim of a mask), if it has one: the
//! longest loop, when it is at least half the mesh's bounding-box diagonal or
//! [`CUT_RATIO`] × the next longest. A head closed at the neck has no such loop, and its mouth
//! (FaceCap's: 108 mm of rim against a 555 mm neck and a diagonal of about 410 mm) stays an
//! opening.

pub mod closed_mouth;
pub mod lid_margin;

use crate::mesh::{centroid, distance, Topology};

/// How many times longer than the next loop the longest must be to be taken as the mesh's cut
/// when it is shorter than half the diagonal (a small mesh's rim).
pub const CUT_RATIO: f64 = 2.5;

/// A hole in the skin.
#[derive(Debug, Clone, PartialEq)]
pub struct Opening {
    /// Its boundary loop, welded vertex ids.
    pub vertices: Vec<u32>,
    /// Mean position of the loop's vertices.
    pub centre: [f64; 3],
    /// Length of the loop.
    pub length: f64,
}

/// The openings of the largest piece of a welded mesh, longest first.
pub fn find_openings(topology: &Topology, welded_positions: &[[f64; 3]]) -> Vec<Opening> {
    let mut loops: Vec<_> = topology
        .boundary_loops
        .iter()
        .filter(|l| l.component == 0 && l.closed)
        .collect();
    loops.sort_by(|a, b| b.length.total_cmp(&a.length));
    let (lo, hi) = crate::model::bounds(welded_positions.iter().copied());
    let diagonal = distance(&lo, &hi);
    let cut = match loops.as_slice() {
        [longest, next, ..] => {
            longest.length >= 0.5 * diagonal || longest.length >= CUT_RATIO * next.length
        }
        [_] => true,
        [] => false,
    };
    loops
        .into_iter()
        .skip(usize::from(cut))
        .map(|l| Opening {
            vertices: l.vertices.clone(),
            centre: centroid(welded_positions, &l.vertices),
            length: l.length,
        })
        .collect()
}

/// The openings of a face's skin: [`find_openings`]; where they are two eyes and no mouth, the
/// mouth found behind its lips ([`closed_mouth::mouth_behind_lips`]), if there is one; where
/// there are none at all, the mouth and eyes found behind the skin
/// ([`closed_mouth::face_behind_skin`]), if there are any.
pub fn skin_openings(
    topology: &Topology,
    welded_positions: &[[f64; 3]],
    welded_triangles: &[[u32; 3]],
) -> Vec<Opening> {
    let mut openings = find_openings(topology, welded_positions);
    if let Some(closed) = closed_of(&openings, welded_positions, welded_triangles) {
        openings.extend(closed.openings);
        openings.sort_by(|a, b| b.length.total_cmp(&a.length));
    }
    openings
}

/// The skin's triangles less the bags closing its mouth (and eyes), when [`skin_openings`]
/// finds them behind the skin: distances along the skin then go round them as they do round
/// open ones. `None`: the skin as it is.
pub fn skin_without_mouth_bag(
    topology: &Topology,
    welded_positions: &[[f64; 3]],
    welded_triangles: &[[u32; 3]],
) -> Option<Vec<[u32; 3]>> {
    let openings = find_openings(topology, welded_positions);
    closed_of(&openings, welded_positions, welded_triangles).map(|c| c.triangles)
}

/// The topology of the skin as it is seen: `triangles` over `welded`, less the seams between
/// the skin and the bags closing its mouth and eyes ([`skin_without_mouth_bag`]), so that a
/// bag, like FaceCap's own separate mouth bag, is a piece of its own, neither measured as skin
/// nor a place for a marker.
pub fn seen_topology(welded: &[[f64; 3]], triangles: &[[u32; 3]]) -> Topology {
    let full = Topology::new(welded, triangles);
    match skin_without_mouth_bag(&full, welded, triangles) {
        Some(seen) => Topology::new(welded, &seen),
        None => full,
    }
}

/// Openings found behind the skin and the skin's triangles without their bags.
struct Closed {
    openings: Vec<Opening>,
    triangles: Vec<[u32; 3]>,
}

/// What closes the skin whose `openings` are two eyes alike in length (the mouth), or that has
/// none (mouth and eyes), if anything is found.
fn closed_of(
    openings: &[Opening],
    welded_positions: &[[f64; 3]],
    welded_triangles: &[[u32; 3]],
) -> Option<Closed> {
    match openings {
        [] => closed_mouth::face_behind_skin(welded_positions, welded_triangles).map(|f| Closed {
            openings: f.openings.to_vec(),
            triangles: f.triangles,
        }),
        [a, b] => {
            let alike = (a.length - b.length).abs() <= 0.25 * a.length.max(b.length);
            if !alike {
                return None;
            }
            closed_mouth::mouth_behind_lips(welded_positions, welded_triangles, [a, b]).map(|m| {
                Closed {
                    openings: vec![m.opening],
                    triangles: m.triangles,
                }
            })
        }
        _ => None,
    }
}

/// Whether an opening centred at `mouth` can be the mouth of eyes centred at `eyes`: about as
/// far from either (within a quarter), 0.5 to 3 eye spacings from their midpoint.
pub fn below_eyes(mouth: &[f64; 3], [a, b]: [&[f64; 3]; 2]) -> bool {
    let spacing = distance(a, b);
    let middle = [0, 1, 2].map(|c| 0.5 * (a[c] + b[c]));
    let (to_a, to_b) = (distance(mouth, a), distance(mouth, b));
    (0.5 * spacing..=3.0 * spacing).contains(&distance(mouth, &middle))
        && (to_a - to_b).abs() <= 0.25 * to_a.max(to_b)
}

/// The mouth and the two eyes among `openings`: of the three longest, the eyes are the two
/// whose rims are most alike in length and about whose bisector the third, the mouth, is most
/// symmetric (the sum of the two relative differences is least: a face is mirror-symmetric, and
/// loops found where the skin stops being seen, [`closed_mouth::face_behind_skin`], can make a
/// mouth's rim about as long as an eye's); eyes in order of x. `None` with fewer than three
/// openings.
pub fn mouth_and_eyes(openings: &[Opening]) -> Option<(&Opening, [&Opening; 2])> {
    let mut largest: Vec<&Opening> = openings.iter().collect();
    largest.sort_by(|a, b| b.length.total_cmp(&a.length));
    let [a, b, c] = match largest.as_slice() {
        [a, b, c, ..] => [*a, *b, *c],
        _ => return None,
    };
    let unlike = |p: f64, q: f64| (p - q).abs() / p.max(q);
    let score = |(mouth, [p, q]): &(&Opening, [&Opening; 2])| {
        let (to_p, to_q) = (
            distance(&mouth.centre, &p.centre),
            distance(&mouth.centre, &q.centre),
        );
        unlike(p.length, q.length) + unlike(to_p, to_q)
    };
    let (mouth, mut eyes) = [(a, [b, c]), (b, [a, c]), (c, [a, b])]
        .into_iter()
        .min_by(|x, y| score(x).total_cmp(&score(y)))?;
    eyes.sort_by(|p, q| p.centre[0].total_cmp(&q.centre[0]));
    Some((mouth, eyes))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// ICT-FaceKit's loops where its skin stops being seen (`closed_mouth::face_behind_skin`),
    /// as its face frame turns them: the mouth's rim (10.6 cm) is nearer in length to one eye's
    /// (10.0) than the eyes' are to each other (9.1), but only about the eyes' bisector is the
    /// mouth symmetric.
    #[test]
    fn the_mouth_is_the_loop_the_eyes_are_mirrored_about() {
        let opening = |centre: [f64; 3], length: f64| Opening {
            vertices: Vec::new(),
            centre,
            length,
        };
        let mouth = opening([0.0, -0.0335, 0.1049], 0.1057);
        let right = opening([-0.0327, 0.0342, 0.0893], 0.0997);
        let left = opening([0.0325, 0.0345, 0.0892], 0.0906);
        let openings = [mouth.clone(), right.clone(), left.clone()];
        let (m, [a, b]) = mouth_and_eyes(&openings).unwrap();
        assert_eq!((m, a, b), (&mouth, &right, &left));
    }

    #[test]
    fn a_tube_with_a_hole_has_one_opening() {
        // A square annulus: outer rim 4 × 4 (the cut), inner hole 2 × 2 (the opening).
        let mut p = Vec::new();
        for &(x, y) in &[(-2.0, -2.0), (2.0, -2.0), (2.0, 2.0), (-2.0, 2.0)] {
            p.push([x, y, 0.0]);
        }
        for &(x, y) in &[(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
            p.push([x, y, 0.0]);
        }
        let mut t = Vec::new();
        for i in 0..4u32 {
            let j = (i + 1) % 4;
            t.push([i, j, 4 + j]);
            t.push([i, 4 + j, 4 + i]);
        }
        let topo = Topology::new(&p, &t);
        let o = find_openings(&topo, &p);
        assert_eq!(o.len(), 1);
        assert!((o[0].length - 8.0).abs() < 1e-12);
        assert!(o[0].centre.iter().all(|c| c.abs() < 1e-12));
    }

    #[test]
    fn the_eyes_are_the_two_most_alike_and_the_mouth_the_third() {
        let opening = |x: f64, length: f64| Opening {
            vertices: Vec::new(),
            centre: [x, 0.0, 0.0],
            length,
        };
        let openings = [
            opening(0.03, 0.069),
            opening(0.0, 0.108),
            opening(-0.03, 0.07),
            opening(0.0, 0.02),
        ];
        let (mouth, [right, left]) = mouth_and_eyes(&openings).expect("three openings");
        assert_eq!(mouth.length, 0.108);
        assert_eq!((right.centre[0], left.centre[0]), (-0.03, 0.03));
        assert!(mouth_and_eyes(&openings[..2]).is_none());
    }
}
