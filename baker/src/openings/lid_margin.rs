//! The lids' margin of an eye closed by a socket. Where the skin stops being seen
//! ([`super::closed_mouth::face_behind_skin`]) is a loop inside the socket: through the open
//! fissure the views round the front see the lids' inner lining some way in, so on
//! ICT-FaceKit's head that loop ran on the lining up to 4 mm behind the margin, deepest at the
//! corners. Everything read from the loop took the lining for the margin: `place` put the eye
//! corners' markers on it, the masks and the rims met there, the blink drew the upper lid's
//! edge wavy, and the eyelid figure compared pairs that the truth's own blink leaves 3.5 to
//! 9.6 mm apart.
//!
//! The margin is the narrowest loop round the socket: inside it the lining widens round the
//! eyeball, outside it the lids widen towards the brow and the cheek. So it is found as the
//! shortest closed path on the surface that winds once round the seen loop's axis, within
//! [`BAND`] of that loop ([`margin`]), and the lining between the two loops goes to the socket
//! ([`grow_to_margin`]). On ICT-FaceKit's head the margin found is the mesh's own edge loop
//! along the lids, mirror-symmetric between the eyes (the seen loops were not), and the truth's
//! blink brings its pairs to 0.6–2.4 mm.

use std::collections::{BinaryHeap, HashMap, HashSet};

use crate::geodesic::dijkstra::Entry;
use crate::mesh::{cross, distance, dot, sub, unit};
use crate::openings::Opening;

/// How far from the loop where the skin stops being seen the margin is looked for, along the
/// surface: × that loop's length (8.5–8.9 cm round ICT-FaceKit's eyes: about 1 cm).
pub const BAND: f64 = 0.12;

/// Most start vertices tried for the shortest loop (those beside the cut it must cross): a
/// bound on the cost, each a Dijkstra over the band.
const MAX_STARTS: usize = 64;

/// Marks the skin of an eye closed by a socket as ending at its lids' margin: `seen` (per
/// welded vertex, whether the views see it) on entry, the skin with everything behind the
/// margin unseen on return. `eye` is the loop where the seen skin stops, `neighbours` each
/// vertex's through `triangles` ([`crate::mesh::Topology::neighbours`]). Returns whether it
/// changed anything; `false` (and `seen` untouched) when no margin is found in the band, or
/// the loop found does not close the socket off (a pouch shallower than the band, or a socket
/// that is not a pouch).
pub fn grow_to_margin(
    positions: &[[f64; 3]],
    triangles: &[[u32; 3]],
    neighbours: &[Vec<u32>],
    seen: &mut [bool],
    eye: &Opening,
) -> bool {
    let rim = &eye.vertices;
    // Along the surface from the rim: through the socket (unseen) as deep as it goes, over the
    // seen skin within the band.
    let reach = BAND * eye.length;
    let from_rim = spread(positions, neighbours, rim, |v, d| !seen[v] || d <= reach);
    let Some(cycle) = margin(positions, neighbours, rim, |v| {
        from_rim[v].is_some_and(|d| d <= reach)
    }) else {
        return false;
    };
    // The socket's deepest vertex, farther in than any of the margin's: the flood from it that
    // does not cross the margin is the socket.
    let farthest_on_cycle = cycle
        .iter()
        .filter_map(|&v| from_rim[v as usize])
        .fold(0.0, f64::max);
    let Some(deepest) = (0..positions.len())
        .filter(|&v| !seen[v])
        .filter_map(|v| from_rim[v].map(|d| (v, d)))
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .filter(|&(_, d)| d > farthest_on_cycle)
        .map(|(v, _)| v)
    else {
        return false;
    };
    let Some(socket) = flood_inside(triangles, &cycle, deepest, |v| from_rim[v].is_some()) else {
        return false;
    };
    let on_cycle: HashSet<u32> = cycle.iter().copied().collect();
    let mut inside = vec![false; positions.len()];
    for t in socket {
        for &v in &triangles[t] {
            if !on_cycle.contains(&v) {
                inside[v as usize] = true;
            }
        }
    }
    // Skin out to the margin, the socket behind it; farther from the rim than the band (the
    // socket's depths, or whatever else unseen it leads to) as it was.
    let mut changed = false;
    for v in 0..positions.len() {
        let near = from_rim[v].is_some_and(|d| d <= reach);
        if (near || inside[v]) && seen[v] == inside[v] {
            seen[v] = !inside[v];
            changed = true;
        }
    }
    changed
}

/// The shortest closed path over the vertices `in_band` that winds once round the axis of the
/// loop `rim` (the normal of its plane through its centre), as welded ids in order; `None`
/// when there is none.
pub fn margin(
    positions: &[[f64; 3]],
    neighbours: &[Vec<u32>],
    rim: &[u32],
    in_band: impl Fn(usize) -> bool,
) -> Option<Vec<u32>> {
    let centre = crate::mesh::centroid(positions, rim);
    // Newell's normal of the loop: its plane's, whatever its shape.
    let mut newell = [0.0; 3];
    for i in 0..rim.len() {
        let a = sub(&positions[rim[i] as usize], &centre);
        let b = sub(&positions[rim[(i + 1) % rim.len()] as usize], &centre);
        let c = cross(&a, &b);
        for k in 0..3 {
            newell[k] += c[k];
        }
    }
    let axis = unit(&newell)?;
    let first = sub(&positions[*rim.first()? as usize], &centre);
    let across = unit(&sub(&first, &axis.map(|a| a * dot(&first, &axis))))?;
    let other = cross(&axis, &across);
    let angle = |v: usize| {
        let d = sub(&positions[v], &centre);
        dot(&d, &other).atan2(dot(&d, &across))
    };
    let band: Vec<usize> = (0..positions.len()).filter(|&v| in_band(v)).collect();
    let theta: HashMap<usize, f64> = band.iter().map(|&v| (v, angle(v))).collect();
    // Crossing the cut at ±π counter-clockwise (from + to −) goes up a sheet.
    let step = |a: usize, b: usize| -> i8 {
        let (ta, tb) = (theta[&a], theta[&b]);
        if (tb - ta).abs() <= std::f64::consts::PI {
            0
        } else if ta > 0.0 {
            1
        } else {
            -1
        }
    };
    let mut starts: Vec<usize> = band
        .iter()
        .copied()
        .filter(|&a| {
            neighbours[a]
                .iter()
                .any(|&b| theta.contains_key(&(b as usize)) && step(a, b as usize) != 0)
        })
        .collect();
    if starts.len() > MAX_STARTS {
        let stride = starts.len().div_ceil(MAX_STARTS);
        starts = starts.into_iter().step_by(stride).collect();
    }
    // A state of the search: a vertex on sheet 0 or 1, numbered `2 × vertex + sheet`.
    let state = |v: usize, sheet: u8| (2 * v + usize::from(sheet)) as u32;
    let mut best: Option<(f64, Vec<u32>)> = None;
    for s in starts {
        // Dijkstra over the states, from (s, 0) to (s, 1).
        let (from, to) = (state(s, 0), state(s, 1));
        let mut dist: HashMap<u32, f64> = HashMap::from([(from, 0.0)]);
        let mut parent: HashMap<u32, u32> = HashMap::new();
        let mut heap = BinaryHeap::from([Entry(0.0, from)]);
        let bound = best.as_ref().map_or(f64::INFINITY, |b| b.0);
        while let Some(Entry(d, at)) = heap.pop() {
            if d >= bound {
                break;
            }
            if at == to {
                let mut path = vec![s as u32];
                let mut back = at;
                while let Some(&p) = parent.get(&back).filter(|&&p| p != from) {
                    path.push(p / 2);
                    back = p;
                }
                path.reverse();
                best = Some((d, path));
                break;
            }
            if dist.get(&at).is_some_and(|&x| d > x) {
                continue;
            }
            let (v, sheet) = (at as usize / 2, (at % 2) as u8);
            for &w in &neighbours[v] {
                let w = w as usize;
                if !theta.contains_key(&w) {
                    continue;
                }
                let next = i16::from(sheet) + i16::from(step(v, w));
                let Ok(next @ 0..=1) = u8::try_from(next) else {
                    continue;
                };
                let (into, nd) = (state(w, next), d + distance(&positions[v], &positions[w]));
                if dist.get(&into).is_none_or(|&x| nd < x) {
                    dist.insert(into, nd);
                    parent.insert(into, at);
                    heap.push(Entry(nd, into));
                }
            }
        }
    }
    best.map(|(_, path)| path).filter(|p| p.len() >= 3)
}

/// Distances along edges from `sources`, entering a vertex only while `enter(vertex,
/// distance)` holds.
fn spread(
    positions: &[[f64; 3]],
    neighbours: &[Vec<u32>],
    sources: &[u32],
    enter: impl Fn(usize, f64) -> bool,
) -> Vec<Option<f64>> {
    let mut dist: Vec<Option<f64>> = vec![None; positions.len()];
    let mut heap = BinaryHeap::new();
    for &s in sources {
        dist[s as usize] = Some(0.0);
        heap.push(Entry(0.0, s));
    }
    while let Some(Entry(d, v)) = heap.pop() {
        let v = v as usize;
        if dist[v].is_some_and(|x| d > x) {
            continue;
        }
        for &w in &neighbours[v] {
            let w = w as usize;
            let nd = d + distance(&positions[v], &positions[w]);
            if dist[w].is_none_or(|x| nd < x) && enter(w, nd) {
                dist[w] = Some(nd);
                heap.push(Entry(nd, w as u32));
            }
        }
    }
    dist
}

/// The triangles reached from those round `seed` through edges not on `cycle`; `None` when
/// that reaches a vertex not `within` (the cycle does not close the region off).
fn flood_inside(
    triangles: &[[u32; 3]],
    cycle: &[u32],
    seed: usize,
    within: impl Fn(usize) -> bool,
) -> Option<Vec<usize>> {
    let key = |a: u32, b: u32| (a.min(b), a.max(b));
    let walls: HashSet<(u32, u32)> = (0..cycle.len())
        .map(|i| key(cycle[i], cycle[(i + 1) % cycle.len()]))
        .collect();
    let mut by_edge: HashMap<(u32, u32), Vec<usize>> = HashMap::new();
    for (i, t) in triangles.iter().enumerate() {
        for k in 0..3 {
            by_edge
                .entry(key(t[k], t[(k + 1) % 3]))
                .or_default()
                .push(i);
        }
    }
    let mut reached = vec![false; triangles.len()];
    let mut stack: Vec<usize> = triangles
        .iter()
        .enumerate()
        .filter(|(_, t)| t.contains(&(seed as u32)))
        .map(|(i, _)| i)
        .collect();
    for &i in &stack {
        reached[i] = true;
    }
    let mut out = Vec::new();
    while let Some(i) = stack.pop() {
        let t = triangles[i];
        if t.iter().any(|&v| !within(v as usize)) {
            return None;
        }
        out.push(i);
        for k in 0..3 {
            let e = key(t[k], t[(k + 1) % 3]);
            if walls.contains(&e) {
                continue;
            }
            for &j in &by_edge[&e] {
                if !std::mem::replace(&mut reached[j], true) {
                    stack.push(j);
                }
            }
        }
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A tube of `rings` rings of `around` vertices, radius `radius(ring)`, rings 1 apart.
    fn tube(
        rings: usize,
        around: usize,
        radius: impl Fn(usize) -> f64,
    ) -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
        crate::geodesic::tests::tube(rings, around, radius, |r| r as f64)
    }

    /// On a tube with a waist, the shortest loop round it from its first ring is the waist,
    /// wherever the band starts it.
    #[test]
    fn the_margin_is_the_waist() {
        let waist = 4;
        let (positions, triangles) = tube(9, 24, |r| 1.0 + 0.5 * (r as f64 - waist as f64).powi(2));
        let neighbours = crate::mesh::Topology::new(&positions, &triangles).neighbours;
        let rim: Vec<u32> = (0..24).collect();
        let found = margin(&positions, &neighbours, &rim, |_| true).expect("a loop");
        let mut rings: Vec<usize> = found.iter().map(|&v| v as usize / 24).collect();
        rings.dedup();
        assert_eq!(rings, [waist], "{found:?}");
        assert_eq!(found.len(), 24);
    }

    /// With no loop round the axis inside the band (a band too narrow to close), none is found.
    #[test]
    fn no_loop_in_a_band_that_does_not_go_round() {
        let (positions, triangles) = tube(5, 16, |_| 1.0);
        let neighbours = crate::mesh::Topology::new(&positions, &triangles).neighbours;
        let rim: Vec<u32> = (0..16).collect();
        let half = |v: usize| positions[v][1] >= 0.0;
        assert!(margin(&positions, &neighbours, &rim, half).is_none());
    }
}
