//! Openings closed by a bag or a socket. A mouth whose lips are joined to a mouth bag: the skin
//! runs on from the lips into the mouth and has no hole there, so only the eyes (and the neck)
//! are boundary loops. A head whose eyes are closed by sockets too has no opening at all; its
//! mouth and eyes are found the same way, from views all round the front
//! ([`face_behind_skin`]). The lips' line is
//! where the skin stops being seen: [`mouth_behind_lips`] looks at the face from the front and
//! from around it, takes the triangles with a vertex no view sees (the bag, hidden behind the
//! lips) off the skin, and the new boundary loop below the eyes is the mouth's opening.
//!
//! The front is read from the eyes and the head's bulk (the skin's centroid, behind the face):
//! from the bulk towards the eyes' midpoint, square to the line between the eyes. Views: the
//! front and [`VIEWS`] directions [`VIEW_TILT`] degrees around it, each an orthographic depth
//! buffer of every triangle with cells of [`CELLS_PER_EYE_SPACING`]⁻¹ of the eyes' spacing. A
//! vertex is seen in a view when no cell around it holds anything more than
//! [`DEPTH_TOLERANCE`] cells in front of it.

use crate::mesh::{cross, distance, dot, sub, unit, Topology};
use crate::openings::{find_openings, lid_margin, Opening};

/// Views around the front, besides the front itself.
pub const VIEWS: usize = 8;
/// How far those views turn from the front, in degrees.
pub const VIEW_TILT: f64 = 30.0;
/// Depth-buffer cells across the eyes' spacing.
pub const CELLS_PER_EYE_SPACING: f64 = 40.0;
/// How far behind the nearest surface (in cells) a vertex still counts as seen.
pub const DEPTH_TOLERANCE: f64 = 1.5;
/// Most cells a depth buffer has on a side (a larger mesh takes larger cells).
const MAX_CELLS: usize = 1024;
/// Most cells a view's triangles may cover between them (their bounding boxes) when a mouth is
/// looked for behind its lips: a face's triangles cover a few cells each, so a mesh past this is
/// not looked at (no mouth is found behind its lips) rather than taking unbounded time.
const MAX_RASTER_CELLS: f64 = 64.0 * 1024.0 * 1024.0;
/// Most cells the up to 8 × 17 views of a skin closed all round ([`face_behind_skin`]) may cover
/// between them: as many as the 9 views of a closed mouth may. ICT-FaceKit's head (28,068
/// triangles) takes 0.43 Mi cells a view, 7.3 Mi for the 17 views of its front.
const MAX_CLOSED_FACE_CELLS: f64 = MAX_RASTER_CELLS * (VIEWS + 1) as f64;

/// A mouth found behind its lips: its opening and the skin without the mouth's bag.
pub struct ClosedMouth {
    /// The loop where the skin stops being seen, welded vertex ids.
    pub opening: Opening,
    /// The mesh's triangles less the seam between the skin and the mouth's bag
    /// (`without_bag`).
    pub triangles: Vec<[u32; 3]>,
}

/// The mouth of a skin whose only openings are `eyes` (two loops alike in length, among
/// `openings`), found behind its lips (see the module docs); `None` when there is no such
/// mouth: no unseen skin, or no new loop about as far from either eye, 0.5 to 3 eye spacings
/// from their midpoint.
pub fn mouth_behind_lips(
    positions: &[[f64; 3]],
    triangles: &[[u32; 3]],
    eyes: [&Opening; 2],
) -> Option<ClosedMouth> {
    let [a, b] = eyes.map(|e| e.centre);
    let spacing = distance(&a, &b);
    let right = unit(&sub(&b, &a))?;
    let middle = [0, 1, 2].map(|c| 0.5 * (a[c] + b[c]));
    let bulk = crate::mesh::mean(positions);
    let towards = sub(&middle, &bulk);
    let front = unit(&sub(&towards, &right.map(|r| r * dot(&towards, &right))))?;
    let cell = spacing / CELLS_PER_EYE_SPACING;
    let mut seen = vec![false; positions.len()];
    for view in views(front, right, &[VIEW_TILT]) {
        mark_seen(
            positions,
            triangles,
            view,
            cell,
            MAX_RASTER_CELLS,
            &mut seen,
        )?;
    }
    let opened = loops_of_seen(positions, triangles, &seen)?;
    let old: Vec<u32> = eyes
        .iter()
        .flat_map(|e| e.vertices.iter().copied())
        .collect();
    let opening = opened
        .into_iter()
        .filter(|o| !o.vertices.iter().any(|v| old.contains(v)))
        .filter(|o| crate::openings::below_eyes(&o.centre, [&a, &b]))
        .max_by(|p, q| p.length.total_cmp(&q.length))?;
    Some(ClosedMouth {
        triangles: without_bag(triangles, &seen, &opening.vertices),
        opening,
    })
}

/// Views of a skin with no opening at all, besides the front: [`VIEWS`] at [`VIEW_TILT`] and as
/// many at [`WIDE_TILT`] degrees around it.
pub const WIDE_TILT: f64 = 50.0;
/// Of those 17 views, how many must see a vertex of a skin closed all round for it to be skin
/// rather than a bag or a socket. An eye's socket, unlike a mouth's bag, is open to the front
/// through the lids, so "seen by any view" keeps most of it; its walls are seen through the
/// fissure by a few views near the front only. On the ICT-FaceKit head (skin, mouth socket and
/// eye sockets in one piece), seen by 3 of 17 views the eyes' loops ran deep on the sockets'
/// walls (25 cm long, with the ears' hollows as long); by 6, along the lids' lining just
/// behind their margin (which [`lid_margin`] then finds), 8.5 and 8.9 cm round, and the
/// mouth's along the lips (10.8 cm); by 9, the ears' hollows came first.
pub const SEEN_BY: usize = 6;
/// Depth-buffer cells across the skin's bounding-box diagonal when no eyes give a scale (about
/// 1.5 mm on a head).
pub const CELLS_PER_DIAGONAL: f64 = 300.0;

/// The fronts tried for a skin closed all round, each with its up: the glTF convention (+Z,
/// +Y up) first, then turned or with +Z up.
const FRONTS: [([f64; 3], [f64; 3]); 8] = [
    ([0.0, 0.0, 1.0], [0.0, 1.0, 0.0]),
    ([0.0, 0.0, -1.0], [0.0, 1.0, 0.0]),
    ([1.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
    ([-1.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
    ([0.0, -1.0, 0.0], [0.0, 0.0, 1.0]),
    ([0.0, 1.0, 0.0], [0.0, 0.0, 1.0]),
    ([1.0, 0.0, 0.0], [0.0, 0.0, 1.0]),
    ([-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]),
];

/// A face found behind its skin: its mouth and two eyes, and the skin without their bags.
pub struct ClosedFace {
    /// The mouth's loop, then the eyes', welded vertex ids.
    pub openings: [Opening; 3],
    /// The mesh's triangles less the seams between the skin and the bags (`without_bag`).
    pub triangles: Vec<[u32; 3]>,
}

/// The mouth and eyes of a skin with no opening at all (a head whose mouth is closed by a bag
/// and whose eyes by sockets, as the ICT-FaceKit head's are), found where the skin stops being
/// seen: for each of `FRONTS` in turn, the front and 16 views round it (at [`VIEW_TILT`] and
/// [`WIDE_TILT`]), each vertex skin where [`SEEN_BY`] of them see it, and the loops of the skin
/// so seen. The eyes are the two loops in front of the bulk, alike in length, side by side and
/// level, the longest such pair with a mouth: the longest loop about as far from either,
/// below them ([`crate::openings::below_eyes`]). Each eye's skin then ends at its lids' margin
/// ([`lid_margin`]), the narrowest loop round its socket. `None` when no front gives one.
pub fn face_behind_skin(positions: &[[f64; 3]], triangles: &[[u32; 3]]) -> Option<ClosedFace> {
    let (lo, hi) = crate::model::bounds(positions.iter().copied());
    let cell = distance(&lo, &hi) / CELLS_PER_DIAGONAL;
    if cell.is_nan() || cell <= 0.0 {
        return None;
    }
    let bulk = crate::mesh::mean(positions);
    let mut spent = 0.0;
    FRONTS.iter().find_map(|&(front, up)| {
        let right = cross(&up, &front);
        let mut count = vec![0usize; positions.len()];
        for view in views(front, right, &[VIEW_TILT, WIDE_TILT]) {
            let mut seen = vec![false; positions.len()];
            spent += mark_seen(
                positions,
                triangles,
                view,
                cell,
                MAX_CLOSED_FACE_CELLS - spent,
                &mut seen,
            )?;
            for (c, s) in count.iter_mut().zip(&seen) {
                *c += usize::from(*s);
            }
        }
        let seen: Vec<bool> = count.iter().map(|&c| c >= SEEN_BY).collect();
        let loops = loops_of_seen(positions, triangles, &seen)?;
        let found = face_among(&loops, bulk, front, up)?.map(Opening::clone);
        // The eyes' loops run on the lids' lining, behind their margin: end the skin there.
        let mut seen = seen;
        let mut grown = false;
        let neighbours = Topology::new(positions, triangles).neighbours;
        for eye in &found[1..] {
            grown |= lid_margin::grow_to_margin(positions, triangles, &neighbours, &mut seen, eye);
        }
        let openings = if grown {
            let loops = loops_of_seen(positions, triangles, &seen)?;
            let nearest = |o: &Opening| {
                loops
                    .iter()
                    .min_by(|p, q| {
                        distance(&p.centre, &o.centre).total_cmp(&distance(&q.centre, &o.centre))
                    })
                    .cloned()
            };
            let [mouth, a, b] = &found;
            [nearest(mouth)?, nearest(a)?, nearest(b)?]
        } else {
            found
        };
        let rims: Vec<u32> = openings
            .iter()
            .flat_map(|o| o.vertices.iter().copied())
            .collect();
        Some(ClosedFace {
            triangles: without_bag(triangles, &seen, &rims),
            openings,
        })
    })
}

/// The boundary loops (less the cut, [`find_openings`]) of the `triangles` whose vertices are
/// all `seen`; `None` when every triangle is.
fn loops_of_seen(
    positions: &[[f64; 3]],
    triangles: &[[u32; 3]],
    seen: &[bool],
) -> Option<Vec<Opening>> {
    let shown: Vec<[u32; 3]> = triangles
        .iter()
        .copied()
        .filter(|t| t.iter().all(|&v| seen[v as usize]))
        .collect();
    (shown.len() < triangles.len())
        .then(|| find_openings(&Topology::new(positions, &shown), positions))
}

/// The mouth and the eyes among `loops` of a face towards `front` with its head's bulk at
/// `bulk` (see [`face_behind_skin`]).
fn face_among(
    loops: &[Opening],
    bulk: [f64; 3],
    front: [f64; 3],
    up: [f64; 3],
) -> Option<[&Opening; 3]> {
    let ahead = |o: &Opening| dot(&sub(&o.centre, &bulk), &front);
    let mut pairs: Vec<(&Opening, &Opening)> = Vec::new();
    for (i, a) in loops.iter().enumerate() {
        for b in &loops[i + 1..] {
            let apart = sub(&b.centre, &a.centre);
            let spacing = distance(&a.centre, &b.centre);
            let alike = (a.length - b.length).abs() <= 0.25 * a.length.max(b.length);
            let level = dot(&apart, &up).abs() <= 0.25 * spacing;
            let in_front = ahead(a).min(ahead(b)) > 0.25 * spacing;
            if alike && level && in_front && spacing > 0.0 {
                pairs.push((a, b));
            }
        }
    }
    pairs.sort_by(|p, q| {
        q.0.length
            .min(q.1.length)
            .total_cmp(&p.0.length.min(p.1.length))
    });
    pairs.into_iter().find_map(|(a, b)| {
        let middle = [0, 1, 2].map(|c| 0.5 * (a.centre[c] + b.centre[c]));
        loops
            .iter()
            .filter(|m| !std::ptr::eq(*m, a) && !std::ptr::eq(*m, b))
            .filter(|m| dot(&sub(&m.centre, &middle), &up) < 0.0)
            .filter(|m| crate::openings::below_eyes(&m.centre, [&a.centre, &b.centre]))
            .max_by(|p, q| p.length.total_cmp(&q.length))
            .map(|m| [m, a, b])
    })
}

/// `triangles` less the seam between the skin and the mouth's bag: of the unseen triangles (a
/// vertex no view sees) reached from the `rim` through unseen vertices (the bag), those with a
/// vertex the views see. The rest of the bag stays whole, a piece of its own like a mouth's
/// lining; other unseen triangles (a nostril's inside, the teeth, a tongue) stay too.
fn without_bag(triangles: &[[u32; 3]], seen: &[bool], rim: &[u32]) -> Vec<[u32; 3]> {
    let hidden = |t: &[u32; 3]| t.iter().any(|&v| !seen[v as usize]);
    let mut touching: Vec<Vec<usize>> = vec![Vec::new(); seen.len()];
    for (i, t) in triangles.iter().enumerate() {
        if hidden(t) {
            for &v in t {
                touching[v as usize].push(i);
            }
        }
    }
    let mut in_bag = vec![false; triangles.len()];
    let mut reached = vec![false; seen.len()];
    let mut stack: Vec<u32> = rim.to_vec();
    for &v in rim {
        reached[v as usize] = true;
    }
    while let Some(v) = stack.pop() {
        for &i in &touching[v as usize] {
            if std::mem::replace(&mut in_bag[i], true) {
                continue;
            }
            for &w in &triangles[i] {
                if !seen[w as usize] && !std::mem::replace(&mut reached[w as usize], true) {
                    stack.push(w);
                }
            }
        }
    }
    triangles
        .iter()
        .zip(&in_bag)
        .filter(|(t, &bag)| !bag || t.iter().all(|&v| !seen[v as usize]))
        .map(|(t, _)| *t)
        .collect()
}

/// The front and [`VIEWS`] directions around it at each of `tilts` (degrees).
fn views(front: [f64; 3], right: [f64; 3], tilts: &[f64]) -> Vec<[f64; 3]> {
    let up = cross(&front, &right);
    let mut out = vec![front];
    for tilt in tilts {
        let (sin, cos) = tilt.to_radians().sin_cos();
        for k in 0..VIEWS {
            let (s, c) = (std::f64::consts::TAU * k as f64 / VIEWS as f64).sin_cos();
            out.push([0, 1, 2].map(|i| cos * front[i] + sin * (c * right[i] + s * up[i])));
        }
    }
    out
}

/// Marks in `seen` the vertices a view along `view` (looking back along it: depth grows
/// towards the viewer) sees, with cells of side `cell`, and returns how many cells its
/// triangles covered; `None` (nothing marked) when they would cover more than `budget`.
fn mark_seen(
    positions: &[[f64; 3]],
    triangles: &[[u32; 3]],
    view: [f64; 3],
    cell: f64,
    budget: f64,
    seen: &mut [bool],
) -> Option<f64> {
    let u = unit(&cross(
        &view,
        &if view[0].abs() < 0.9 {
            [1.0, 0.0, 0.0]
        } else {
            [0.0, 1.0, 0.0]
        },
    ))?;
    let w = cross(&view, &u);
    let projected: Vec<[f64; 3]> = positions
        .iter()
        .map(|p| [dot(p, &u), dot(p, &w), dot(p, &view)])
        .collect();
    let (mut lo, mut hi) = ([f64::MAX; 2], [f64::MIN; 2]);
    for p in &projected {
        for c in 0..2 {
            lo[c] = lo[c].min(p[c]);
            hi[c] = hi[c].max(p[c]);
        }
    }
    let side = ((hi[0] - lo[0]).max(hi[1] - lo[1]) / MAX_CELLS as f64).max(cell);
    let [nx, ny] = [0, 1].map(|c| (((hi[c] - lo[c]) / side) as usize + 1).min(MAX_CELLS));
    let at = |p: &[f64; 3]| [0, 1].map(|c| (p[c] - lo[c]) / side);
    let boxes: f64 = triangles
        .iter()
        .map(|t| {
            let q = t.map(|v| at(&projected[v as usize]));
            let span = |c: usize| {
                let (lo, hi) = q
                    .iter()
                    .fold((f64::MAX, f64::MIN), |(l, h), p| (l.min(p[c]), h.max(p[c])));
                (hi - lo).min(MAX_CELLS as f64) + 2.0
            };
            span(0) * span(1)
        })
        .sum();
    if boxes.is_nan() || boxes > budget {
        return None;
    }
    let mut depth = vec![f64::MIN; nx * ny];
    for t in triangles {
        let [p, q, r] = t.map(|v| projected[v as usize]);
        let [pa, qa, ra] = [at(&p), at(&q), at(&r)];
        let area = (qa[0] - pa[0]) * (ra[1] - pa[1]) - (ra[0] - pa[0]) * (qa[1] - pa[1]);
        if area.abs() < 1e-12 {
            continue;
        }
        let x0 = pa[0].min(qa[0]).min(ra[0]).floor().max(0.0) as usize;
        let x1 = (pa[0].max(qa[0]).max(ra[0]).ceil() as usize).min(nx - 1);
        let y0 = pa[1].min(qa[1]).min(ra[1]).floor().max(0.0) as usize;
        let y1 = (pa[1].max(qa[1]).max(ra[1]).ceil() as usize).min(ny - 1);
        for y in y0..=y1 {
            for x in x0..=x1 {
                let (cx, cy) = (x as f64 + 0.5, y as f64 + 0.5);
                let l1 = ((qa[0] - cx) * (ra[1] - cy) - (ra[0] - cx) * (qa[1] - cy)) / area;
                let l2 = ((ra[0] - cx) * (pa[1] - cy) - (pa[0] - cx) * (ra[1] - cy)) / area;
                let l3 = 1.0 - l1 - l2;
                if l1 < 0.0 || l2 < 0.0 || l3 < 0.0 {
                    continue;
                }
                let d = l1 * p[2] + l2 * q[2] + l3 * r[2];
                let slot = &mut depth[y * nx + x];
                *slot = slot.max(d);
            }
        }
    }
    let tolerance = DEPTH_TOLERANCE * side;
    for (v, p) in projected.iter().enumerate() {
        let [x, y] = at(p).map(|c| c.max(0.0) as usize);
        let front_most = (y.saturating_sub(1)..=(y + 1).min(ny - 1))
            .flat_map(|y| (x.saturating_sub(1)..=(x + 1).min(nx - 1)).map(move |x| (x, y)))
            .map(|(x, y)| depth[y * nx + x])
            .fold(f64::MAX, f64::min);
        if p[2] >= front_most - tolerance {
            seen[v] = true;
        }
    }
    Some(boxes)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A view sees the corners of a triangle facing it, and refuses (marks nothing) when the
    /// triangles would cover more cells than [`MAX_RASTER_CELLS`].
    #[test]
    fn views_see_what_faces_them_within_a_bounded_cost() {
        let positions = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.2, 0.2, -0.5],
        ];
        let look = |triangles: &[[u32; 3]], seen: &mut [bool; 4]| {
            mark_seen(
                &positions,
                triangles,
                [0.0, 0.0, 1.0],
                1e-3,
                MAX_RASTER_CELLS,
                seen,
            )
        };
        let mut seen = [false; 4];
        // The triangle's box: 1000 cells a side, and one more at each end.
        assert_eq!(look(&[[0, 1, 2]], &mut seen), Some(1002.0 * 1002.0));
        // The fourth vertex is behind the triangle and in no triangle: unseen.
        assert_eq!(seen, [true, true, true, false]);
        // About 2^20 cells each: a hundred of them is past the budget.
        let mut seen = [false; 4];
        assert_eq!(look(&[[0, 1, 2]; 100], &mut seen), None);
        assert_eq!(seen, [false; 4]);
    }
}
