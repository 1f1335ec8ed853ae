//! The mouth's interior: pieces of the mesh that not every marker reaches along the surface
//! (teeth, gums, tongue, a mouth's lining) ride what is beside them, and those on the jaw's
//! side ride the jaw.
//!
//! Measured on FaceCap's truth with the JawMoCap layout's 41 markers, the 14 lower-teeth pieces
//! against their truth (`cargo test --release -p facebake-tests --test interior --
//! --nocapture`): over the 32 frames error mean 3.64 mm, max 14.3 mm, worst frame's
//! mean 9.9 mm (`jaw open` 9.3 mm); over the 52 morph targets mean 1.58 mm, max 14.3 mm. Before
//! the parting line rose with the teeth and the lower lip's share (every vertex below the
//! mouth's height on the jaw's three markers): 4.86 / 23.8 / 15.9 (14.5) mm and 1.87 / 23.1 mm,
//! the back teeth of the arch riding the cheek, and a tooth that straddled the band bent. With
//! FaceCap's upper row (a mesh of its own) merged into the head mesh, the upper teeth stay within
//! 0.35 mm (mean 0.05) of still, where they rode the upper lip (6.36, max 28.06 mm).
//!
//! A mouth's bag that the mesh joins to the lips (ICT-FaceKit's) is a membrane by its seam and,
//! deeper, still above the jaw's parting line and hinged with the jaw below it ([`BagBack`]).

use super::anchoring::smoothstep;
use crate::mesh::{centroid, distance};

/// Jaw markers are at least this many mean marker spacings below the mouth's centre: the chin's,
/// not the lower lip's, which moves on its own (a funnel, a pout).
const JAW_MARGIN: f64 = 0.5;
/// Markers of a set (the jaw's, the lower lip's) a point follows: the nearest three.
const NEAREST: usize = 3;
/// Width of the band about the parting line over which an interior sheet goes from riding the
/// skin beside it to riding the jaw, in mean marker spacings.
const JAW_BAND: f64 = 0.25;
/// Steepest rise of the parting line towards the back of the head (−dy/dz): the arch of
/// FaceCap's lower teeth rises 0.23 (13°); a steeper fit is clamped.
const RISE_MAX: f64 = 0.5;
/// Share of the lower lip's markers in what a tooth on the jaw's side rides, the rest the jaw's.
/// In `jaw open` FaceCap's lower lip moves with the front teeth and the chin's skin half as far;
/// in the funnel and the pucker the lip moves on its own. Over the 32 truth frames, shares of
/// 0 / 0.1 / 0.2 / 0.25 / 0.3 / 0.4 / 0.5: error mean 3.68 / 3.59 / 3.60 / 3.64 / 3.70 / 3.90 /
/// 4.19 mm, worst frame's mean 13.4 / 11.6 / 10.0 / 9.9 / 10.3 / 11.2 / 12.2 mm (52 targets:
/// 13.4 / 11.6 / 10.0 / 9.3 / 8.9 / 11.6 / 14.3). Sheets (the tongue) ride the jaw alone: with
/// the share, its error mean 4.25 → 4.41 mm.
const TOOTH_LIP: f64 = 0.25;

/// A piece of the mesh that not every marker reaches along the surface.
pub(crate) struct Piece<'a> {
    vertices: &'a [u32],
    /// The mean of its vertices' rest positions.
    centre: [f64; 3],
    /// Wider than a marker spacing (a tongue, a mouth's lining): each vertex rides what is
    /// nearest itself. A smaller piece (a tooth) moves as one, with what is nearest its centre.
    sheet: bool,
}

impl<'a> Piece<'a> {
    /// The `pieces` (component, vertices) with their centres on `positions`, and which are
    /// sheets at marker `spacing`.
    pub(crate) fn all(
        pieces: &'a [(u32, Vec<u32>)],
        positions: &[[f64; 3]],
        spacing: f64,
    ) -> Vec<Self> {
        pieces
            .iter()
            .map(|(_, vertices)| {
                let centre = centroid(positions, vertices);
                let radius = vertices
                    .iter()
                    .map(|&v| distance(&centre, &positions[v as usize]))
                    .fold(0.0, f64::max);
                Piece {
                    vertices,
                    centre,
                    sheet: radius > spacing,
                }
            })
            .collect()
    }
}

/// The teeth of `mesh` at marker `spacing`: its pieces besides the largest (the skin) that are
/// no wider than a marker spacing, each as its glTF vertices. Deformers that cannot follow the
/// jaw as [`ride_beside`] does (planar bones) still move each one as one piece.
pub(crate) fn teeth(mesh: &crate::model::FaceMesh, spacing: f64) -> Vec<Vec<u32>> {
    let components = mesh.welded_topology().components;
    let Some(skin) = (0..components.len()).max_by_key(|&c| components.vertex_counts[c]) else {
        return Vec::new();
    };
    let mut by_component: Vec<Vec<u32>> = vec![Vec::new(); components.len()];
    for (v, &w) in mesh.weld.iter().enumerate() {
        let c = components.vertex_component[w as usize] as usize;
        if c != skin {
            by_component[c].push(v as u32);
        }
    }
    let pieces: Vec<(u32, Vec<u32>)> = by_component
        .into_iter()
        .enumerate()
        .filter(|(_, p)| !p.is_empty())
        .map(|(c, p)| (c as u32, p))
        .collect();
    Piece::all(&pieces, &mesh.positions, spacing)
        .into_iter()
        .filter(|p| !p.sheet)
        .map(|p| p.vertices.to_vec())
        .collect()
}

/// What carries the interior on the jaw's side of the parting line: a line (in the face's axes,
/// y up, z forward) through the mouth's centre that rises towards the back of the head as the
/// teeth do, so the back teeth of an arch whose front is below the mouth are on the jaw's side
/// with its front, and an upper arch above the line stays with the skull.
pub(crate) struct Jaw {
    /// A point of the line: the mouth's centre, or between two arches of teeth the middle of
    /// the gap at the mouth's depth.
    through: [f64; 3],
    /// How far the line rises per unit towards the back: the teeth's centres' least-squares
    /// slope of height on depth, 0 to [`RISE_MAX`].
    rise: f64,
    /// The skull's markers, whose mean a tooth on the skull's side rides (the upper arch is
    /// bone, not skin); empty: it rides the skin nearest it.
    skull: Vec<usize>,
    /// [`JAW_BAND`] in asset units.
    band: f64,
    /// The markers' mean spacing, in asset units.
    spacing: f64,
    /// The jaw's markers: more than [`JAW_MARGIN`] spacings below the mouth's centre.
    markers: Vec<(usize, [f64; 3])>,
    /// The lower lip's markers.
    lip: Vec<(usize, [f64; 3])>,
}

impl Jaw {
    /// The jaw of markers `rest` (spaced `spacing` apart on average) under a mouth centred at
    /// `mouth`, with the lower lip's markers `lip` and the skull's `skull` (indices into `rest`)
    /// and the parting line fitted to the teeth among `pieces`.
    pub(crate) fn new(
        rest: &[[f64; 3]],
        mouth: [f64; 3],
        spacing: f64,
        lip: &[usize],
        skull: &[usize],
        pieces: &[Piece<'_>],
    ) -> Self {
        let teeth: Vec<[f64; 3]> = pieces
            .iter()
            .filter(|p| !p.sheet)
            .map(|p| p.centre)
            .collect();
        let margin = JAW_MARGIN * spacing;
        let rise = rise_to_the_back(&teeth);
        let band = JAW_BAND * spacing;
        // Arches parted by half the band or more: each clear of the line by a quarter of it.
        let on_line = match between_arches(&teeth, rise, 0.5 * band) {
            Some(level) => [mouth[0], level - rise * mouth[2], mouth[2]],
            None => mouth,
        };
        let known = |m: &usize| *m < rest.len();
        Self {
            through: on_line,
            rise,
            skull: skull.iter().copied().filter(known).collect(),
            band,
            spacing,
            markers: rest
                .iter()
                .copied()
                .enumerate()
                .filter(|(_, p)| p[1] < mouth[1] - margin)
                .collect(),
            lip: lip
                .iter()
                .copied()
                .filter(known)
                .map(|m| (m, rest[m]))
                .collect(),
        }
    }

    /// How much of the jaw a point at `p` rides: 0 above the band about the parting line, 1
    /// below it.
    fn share(&self, p: &[f64; 3]) -> f64 {
        self.share_over(p, self.band)
    }

    /// [`Jaw::share`] over a band `band` wide (asset units) about the parting line.
    fn share_over(&self, p: &[f64; 3], band: f64) -> f64 {
        let below = self.through[1] + self.rise * (self.through[2] - p[2]) - p[1];
        smoothstep(below / band + 0.5)
    }

    /// Weights (over all `n` markers) that move a point at `p` with the jaw: `lip` of the lower
    /// lip's nearest markers and the rest of the jaw's nearest, each the 1/d²-weighted mean of
    /// its nearest [`NEAREST`] (convex, so nothing is extrapolated and a marker's jitter is not
    /// magnified). `None` without jaw markers.
    fn weights(&self, p: &[f64; 3], n: usize, lip: f64) -> Option<Vec<f64>> {
        let jaw = nearest_mean(&self.markers, p, n)?;
        Some(match nearest_mean(&self.lip, p, n) {
            Some(on_lip) => jaw
                .iter()
                .zip(&on_lip)
                .map(|(j, l)| (1.0 - lip) * j + lip * l)
                .collect(),
            None => jaw,
        })
    }
}

/// Where two arches of teeth part, if the teeth's `centres` make two: their heights with the
/// line's `rise` taken out (`y + rise · z`, the height where the line through a centre meets
/// depth 0) fall into two groups with a gap of at least `min_gap` and wider than either group's
/// spread; then the middle of that gap, in the same measure. One arch, or teeth the gap does not
/// part cleanly, give `None`.
fn between_arches(centres: &[[f64; 3]], rise: f64, min_gap: f64) -> Option<f64> {
    let mut level: Vec<f64> = centres.iter().map(|c| c[1] + rise * c[2]).collect();
    if level.len() < 2 || level.iter().any(|x| !x.is_finite()) {
        return None;
    }
    level.sort_by(f64::total_cmp);
    let (at, gap) = level
        .windows(2)
        .map(|w| w[1] - w[0])
        .enumerate()
        .max_by(|a, b| a.1.total_cmp(&b.1))?;
    let (low, high) = level.split_at(at + 1);
    let spread = |g: &[f64]| g[g.len() - 1] - g[0];
    (gap >= min_gap && gap > spread(low).max(spread(high)))
        .then(|| 0.5 * (low[low.len() - 1] + high[0]))
}

/// The 1/d²-weighted mean, as weights over `n` markers, of the [`NEAREST`] of `markers` nearest
/// `p`; `None` when there are none.
fn nearest_mean(markers: &[(usize, [f64; 3])], p: &[f64; 3], n: usize) -> Option<Vec<f64>> {
    let mut near: Vec<(f64, usize)> = markers.iter().map(|(m, q)| (distance(q, p), *m)).collect();
    near.sort_by(|a, b| a.0.total_cmp(&b.0));
    near.truncate(NEAREST);
    let total: f64 = near.iter().map(|(d, _)| 1.0 / (d * d).max(1e-12)).sum();
    if near.is_empty() || !total.is_finite() {
        return None;
    }
    let mut w = vec![0.0; n];
    for (d, m) in near {
        w[m] += 1.0 / (d * d).max(1e-12) / total;
    }
    Some(w)
}

/// The least-squares slope of height on depth of `centres` as a rise towards the back (−dy/dz),
/// clamped to 0..[`RISE_MAX`]; 0 for fewer than two centres or none spread in depth.
fn rise_to_the_back(centres: &[[f64; 3]]) -> f64 {
    if centres.len() < 2 {
        return 0.0;
    }
    let k = centres.len() as f64;
    let mean = |c: usize| centres.iter().map(|p| p[c]).sum::<f64>() / k;
    let (mz, my) = (mean(2), mean(1));
    let szz: f64 = centres.iter().map(|p| (p[2] - mz).powi(2)).sum();
    let szy: f64 = centres.iter().map(|p| (p[2] - mz) * (p[1] - my)).sum();
    if szz.is_nan() || szz <= 0.0 || !szy.is_finite() {
        return 0.0;
    }
    (-szy / szz).clamp(0.0, RISE_MAX)
}

/// Where a vertex of a bag the mesh joins to the skin hangs from ([`hanging`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Hang {
    /// The skin vertex (glTF id) a shortest edge path through the bag leads to.
    pub(crate) skin: u32,
    /// That path's length, in asset units: how deep in the bag the vertex is.
    pub(crate) depth: f64,
    /// The bag: its index in the `pieces` given to [`hanging`].
    pub(crate) bag: usize,
}

/// Per glTF vertex of `mesh`, where it hangs from when it lies in one of the `pieces` but the
/// mesh joins that piece to the skin (a mouth's bag, whose seam with the lips the distances
/// leave out, `openings::closed_mouth`). `None` elsewhere, and for pieces the mesh keeps apart
/// (teeth).
pub(crate) fn hanging(mesh: &crate::model::FaceMesh, pieces: &[Piece<'_>]) -> Vec<Option<Hang>> {
    let n = mesh.welded_positions.len();
    let mut cut = vec![false; n];
    let mut bag = vec![0; n];
    for (i, piece) in pieces.iter().enumerate() {
        for &v in piece.vertices {
            if let Some(&w) = mesh.weld.get(v as usize) {
                cut[w as usize] = true;
                bag[w as usize] = i;
            }
        }
    }
    let graph = crate::geodesic::dijkstra::Graph::new(&mesh.welded_topology());
    let seeds: Vec<(u32, f64)> = (0..n as u32)
        .filter(|&w| !cut[w as usize])
        .map(|w| (w, 0.0))
        .collect();
    let dist = crate::geodesic::dijkstra::distances(&graph, &seeds);
    let mut order: Vec<usize> = (0..n).filter(|&w| cut[w] && dist[w].is_finite()).collect();
    order.sort_by(|&a, &b| dist[a].total_cmp(&dist[b]));
    // Each cut vertex takes the label of the neighbour its shortest path comes through, which
    // is nearer the skin and so labelled already.
    let mut from: Vec<Option<u32>> = vec![None; n];
    for w in order {
        let before = graph
            .edges_of(w)
            .filter(|&(u, _)| dist[u] < dist[w])
            .min_by(|a, b| (dist[a.0] + a.1).total_cmp(&(dist[b.0] + b.1)));
        from[w] = before.and_then(|(u, _)| if cut[u] { from[u] } else { Some(u as u32) });
    }
    let original = mesh.welded_to_original();
    mesh.weld
        .iter()
        .map(|&w| {
            from[w as usize].map(|s| Hang {
                skin: original[s as usize],
                depth: dist[w as usize],
                bag: bag[w as usize],
            })
        })
        .collect()
}

/// Sweeps of [`stretch_bags`].
const BAG_SWEEPS: usize = 400;

/// The share of a bag's depth beyond which it is held to [`BagBack::row`] ([`stretch_bags`]);
/// nearer its seam with the lips it is a membrane. ICT-FaceKit's mouth bag against its truth
/// over the 32 frames (`cargo test --release -p facebake-tests --test ict_facekit its_mouth_bag
/// -- --nocapture`), shares 0.15 / **0.2** / 0.25 / 0.3: error mean 1.66 / **1.55** / 1.50 /
/// 1.51 mm, max 10.9 / **11.0** / 14.2 / 17.3 mm (the membrane alone: 3.59 / 18.2 mm).
const BAG_SEAM: f64 = 0.2;

/// Width of the band about the jaw's parting line over which a mouth bag's back goes from still
/// to hinged with the jaw, in mean marker spacings: the bag's side walls, unlike a tooth, span
/// the line. ICT-FaceKit with JawMoCap (`bake --capture`, every third frame), the bag's worst
/// edge and the most of its edges over 2× in a frame, against its truth's error mean / max over
/// the 32 frames: at [`JAW_BAND`] (0.25) 6.13×, 119 edges, 1.59 / 11.9 mm; 0.5: 3.88×, 113;
/// 1: 3.48×, 90, 1.57 / 11.5 mm; **2**: 3.44×, 65, 1.55 / 11.0 mm; 3: 3.43×, 62, 1.54 / 11.9 mm.
/// The membrane alone: 3.19×, 56, 3.59 / 18.2 mm.
const BAG_BAND: f64 = 2.0;

/// What a mouth bag does away from its seam with the lips: the palate is the skull's and the
/// floor hinges with the jaw. Truth (ICT-FaceKit's jaw open): the bag's upper half moves 0 to
/// 4 mm, its floor 1 mm at the back wall rising to 17 mm behind the teeth.
pub(crate) struct BagBack<'a> {
    /// The weights of skin that follows the head.
    pub(crate) still: &'a [f64],
    /// The jaw, if the face has a mouth.
    pub(crate) jaw: Option<&'a Jaw>,
}

impl BagBack<'_> {
    /// The weights of a bag vertex at `p`, the bag's back wall at depth `back` (its least z,
    /// the face looking along +z as [`Jaw`]'s parting line takes it): on the jaw's side of
    /// the line, the jaw's weights by how far forward from the wall towards the mouth's centre
    /// the vertex is (a hinge at the wall), the rest still.
    fn row(&self, p: &[f64; 3], back: f64) -> Vec<f64> {
        let n = self.still.len();
        let Some(jaw) = self.jaw else {
            return self.still.to_vec();
        };
        let Some(on_jaw) = jaw.weights(p, n, 0.0) else {
            return self.still.to_vec();
        };
        let front = jaw.through[2];
        let forward = if front > back {
            ((p[2] - back) / (front - back)).clamp(0.0, 1.0)
        } else {
            1.0
        };
        let t = jaw.share_over(p, BAG_BAND * jaw.spacing) * forward;
        self.still
            .iter()
            .zip(&on_jaw)
            .map(|(s, j)| (1.0 - t) * s + t * j)
            .collect()
    }
}

/// The vertices that `hung` places in a bag ([`hanging`]) start from the weights of the skin
/// vertex they hang from and take the mean of their neighbours' on `mesh`, the skin's held,
/// until they settle (Gauss-Seidel, [`BAG_SWEEPS`] sweeps): a membrane between the lips, so an
/// opening mouth stretches the whole bag a little rather than its seam or its back a lot. With
/// `back`, each bag deeper than [`BAG_SEAM`] of its deepest vertex is held to
/// [`BagBack::row`]: a membrane between the lips alone sets its back at half the jaw's travel,
/// and ICT-FaceKit's palate hung 18 mm into its open mouth.
///
/// By its seam a bag vertex also takes the `vertical` corrections of the skin vertex it hangs
/// from (the mouth corners' profile, `surface::corners`), fading out by a smoothstep over the
/// seam ([`BAG_SEAM`] of the bag's depth), and that vertex's `give_way`, so it keeps the same
/// markers. Without them the bag's first ring, under a millimetre behind the lower lip's rim,
/// lagged the rim by the correction (3 mm in ICT-FaceKit's jaw open) and the lip's inner roll
/// crumpled: 130 of the bag's triangles turned over in the jaw open, 24 with both (48 with the
/// give-way alone; a fade over half the seam or less sheared the bag against its rows, 112+).
pub(crate) fn stretch_bags(
    dense: &mut [Vec<f64>],
    vertical: &mut [Vec<(usize, f64)>],
    give_way: &mut [f64],
    mesh: &crate::model::FaceMesh,
    hung: &[Option<Hang>],
    back: Option<&BagBack<'_>>,
) {
    let n = mesh.welded_positions.len();
    let mut in_bag: Vec<Option<Hang>> = vec![None; n];
    for (v, h) in hung.iter().enumerate() {
        if h.is_some() {
            in_bag[mesh.weld[v] as usize] = *h;
        }
    }
    let bags = in_bag
        .iter()
        .flatten()
        .map(|h| h.bag + 1)
        .max()
        .unwrap_or(0);
    if bags == 0 {
        return;
    }
    // Per bag, its deepest vertex's depth and its back wall (least z).
    let mut deepest = vec![0.0f64; bags];
    let mut wall = vec![f64::INFINITY; bags];
    for (w, h) in in_bag.iter().enumerate() {
        if let Some(h) = h {
            deepest[h.bag] = deepest[h.bag].max(h.depth);
            wall[h.bag] = wall[h.bag].min(mesh.welded_positions[w][2]);
        }
    }
    let held = |h: &Hang| back.is_some() && h.depth > BAG_SEAM * deepest[h.bag];
    let free: Vec<usize> = (0..n)
        .filter(|&w| in_bag[w].is_some_and(|h| !held(&h)))
        .collect();
    let original = mesh.welded_to_original();
    let mut rows: Vec<Vec<f64>> = (0..n)
        .map(|w| dense[original[w] as usize].clone())
        .collect();
    for (w, h) in in_bag.iter().enumerate() {
        if let Some(h) = h {
            match back {
                Some(back) if held(h) => {
                    rows[w] = back.row(&mesh.welded_positions[w], wall[h.bag]);
                }
                _ => rows[w].clone_from(&dense[h.skin as usize]),
            }
        }
    }
    let neighbours = mesh.welded_topology().neighbours;
    crate::mesh::harmonic_sweeps(&mut rows, &neighbours, &free, BAG_SWEEPS);
    for (v, &w) in mesh.weld.iter().enumerate() {
        if let Some(h) = in_bag[w as usize] {
            dense[v].clone_from(&rows[w as usize]);
            // The skin's corrections, fading out over the seam, and its give-way.
            let fade = 1.0 - smoothstep(h.depth / (BAG_SEAM * deepest[h.bag]));
            if fade > 0.0 {
                let skin = h.skin as usize;
                if let Some(corrections) = vertical.get(skin) {
                    vertical[v] = corrections.iter().map(|&(m, d)| (m, d * fade)).collect();
                }
                if let Some(&g) = give_way.get(skin) {
                    give_way[v] = g;
                }
            }
        }
    }
}

/// The `pieces` ride what is beside them: the weights of the reachable vertex nearest them (a
/// tooth, moving as one, that nearest its centre; a sheet's vertex, that nearest itself), so
/// they move with that skin instead of being stretched between the lips or pulled by markers
/// across the face. With a `jaw`, what is on its side of the parting line rides it instead
/// ([`Jaw::weights`], a tooth with [`TOOTH_LIP`] of the lower lip's markers), blending across a
/// band of [`JAW_BAND`] spacings about the line, and a tooth on the skull's side rides the skull
/// markers' mean rather than the skin. A piece the mesh joins to the skin (a mouth's bag) is
/// then stretched between its sides ([`stretch_bags`]).
pub(crate) fn ride_beside(
    mut dense: Vec<Vec<f64>>,
    pieces: &[Piece<'_>],
    positions: &[[f64; 3]],
    jaw: Option<&Jaw>,
) -> Vec<Vec<f64>> {
    if pieces.is_empty() {
        return dense;
    }
    let mut cut = vec![false; positions.len()];
    for &v in pieces.iter().flat_map(|p| p.vertices) {
        cut[v as usize] = true;
    }
    let reachable: Vec<usize> = (0..positions.len()).filter(|&v| !cut[v]).collect();
    let n = dense.first().map_or(0, Vec::len);
    let nearest = |p: &[f64; 3]| {
        reachable
            .iter()
            .copied()
            .min_by(|&a, &b| distance(p, &positions[a]).total_cmp(&distance(p, &positions[b])))
    };
    // What a point rides: on the skull's side the skin nearest it (a tooth: the skull, when
    // there are skull markers) and on the jaw's side, the jaw.
    let rides = |dense: &[Vec<f64>], p: &[f64; 3], tooth: bool| -> Option<Vec<f64>> {
        let lip = if tooth { TOOTH_LIP } else { 0.0 };
        let Some((jaw, on_jaw)) = jaw.and_then(|j| Some((j, j.weights(p, n, lip)?))) else {
            return Some(dense[nearest(p)?].clone());
        };
        let skin = match (tooth, jaw.skull.len()) {
            (true, k) if k > 0 => {
                let mut w = vec![0.0; n];
                for &m in &jaw.skull {
                    w[m] += 1.0 / k as f64;
                }
                w
            }
            _ => dense[nearest(p)?].clone(),
        };
        let t = jaw.share(p);
        Some(
            skin.iter()
                .zip(&on_jaw)
                .map(|(s, j)| (1.0 - t) * s + t * j)
                .collect(),
        )
    };
    for piece in pieces {
        if piece.sheet {
            for &v in piece.vertices {
                if let Some(w) = rides(&dense, &positions[v as usize], false) {
                    dense[v as usize] = w;
                }
            }
        } else if let Some(w) = rides(&dense, &piece.centre, true) {
            for &v in piece.vertices {
                dense[v as usize].clone_from(&w);
            }
        }
    }
    dense
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A strip of `columns` columns of two vertices, a unit apart, and its rest positions.
    fn strip(columns: u32) -> (crate::model::FaceMesh, Vec<[f64; 3]>) {
        let positions: Vec<[f64; 3]> = (0..2 * columns)
            .map(|v| [f64::from(v / 2), f64::from(v % 2), 0.0])
            .collect();
        let triangles: Vec<[u32; 3]> = (0..columns - 1)
            .flat_map(|c| {
                [
                    [2 * c, 2 * c + 2, 2 * c + 1],
                    [2 * c + 1, 2 * c + 2, 2 * c + 3],
                ]
            })
            .collect();
        let mesh = crate::model::FaceMesh::from_triangles("strip", positions.clone(), triangles);
        (mesh, positions)
    }

    /// A strip of six columns of two vertices: the first and last columns skin weighted on
    /// markers 0 and 1, the four between a piece the mesh joins to both (a bag). Each bag vertex
    /// hangs from the skin its column is nearer, and the membrane spreads the two lips' weights
    /// across the bag in proportion, as a stretched sheet would.
    #[test]
    fn a_bag_hangs_from_the_skin_and_stretches_between_its_sides() {
        let (mesh, positions) = strip(6);
        let bag: Vec<u32> = (2..10).collect();
        let pieces = [(1u32, bag.clone())];
        let pieces = Piece::all(&pieces, &positions, 100.0);
        let hung = hanging(&mesh, &pieces);
        for v in 0..12u32 {
            let column = match v / 2 {
                0 | 5 => None,
                1 | 2 => Some(0),
                _ => Some(5),
            };
            assert_eq!(hung[v as usize].map(|h| h.skin / 2), column, "vertex {v}");
        }
        let mut dense: Vec<Vec<f64>> = (0..12)
            .map(|v| {
                if v < 2 {
                    vec![1.0, 0.0]
                } else if v >= 10 {
                    vec![0.0, 1.0]
                } else {
                    vec![0.5, 0.5]
                }
            })
            .collect();
        dense = ride_beside(dense, &pieces, &positions, None);
        stretch_bags(&mut dense, &mut [], &mut [], &mesh, &hung, None);
        // Convex, rising from one side to the other, and the same seen from either side (the
        // strip is the same turned half round: vertex v and 11 − v).
        for v in 2..10usize {
            assert!(
                (dense[v][0] + dense[v][1] - 1.0).abs() < 1e-9,
                "{:?}",
                dense[v]
            );
            assert!(
                (dense[v][1] + dense[11 - v][1] - 1.0).abs() < 1e-6,
                "vertex {v}"
            );
        }
        let column = |c: usize| 0.5 * (dense[2 * c][1] + dense[2 * c + 1][1]);
        let rising: Vec<f64> = (0..6).map(column).collect();
        assert!(rising.windows(2).all(|w| w[1] > w[0] + 0.05), "{rising:?}");
    }

    /// A strip of `columns` columns whose inner ones are a bag joined to the skin columns at
    /// both ends, weighted on markers 0 and 1 (of three; the bag starts at the lips' average):
    /// its mesh, where the bag hangs from and its dense weights.
    fn bag_strip(columns: u32) -> (crate::model::FaceMesh, Vec<Option<Hang>>, Vec<Vec<f64>>) {
        let (mesh, positions) = strip(columns);
        let last = 2 * columns - 2;
        let pieces = [(1u32, (2..last).collect::<Vec<u32>>())];
        let pieces = Piece::all(&pieces, &positions, 100.0);
        let hung = hanging(&mesh, &pieces);
        let dense = (0..2 * columns)
            .map(|v| match v {
                0 | 1 => vec![1.0, 0.0, 0.0],
                v if v >= last => vec![0.0, 1.0, 0.0],
                _ => vec![0.5, 0.5, 0.0],
            })
            .collect();
        (mesh, hung, dense)
    }

    /// A strip of twelve columns whose ten inner ones are a bag joined to skin columns at both
    /// ends (markers 0 and 1): with a back (no jaw: all of it still, marker 2), the bag deeper
    /// than [`BAG_SEAM`] of its deepest takes the still weights exactly, and the columns by the
    /// seams are a membrane between the skin and the still back, not the lips' average.
    #[test]
    fn a_bags_back_is_held_still_and_its_seam_stretches_to_it() {
        let (mesh, hung, mut dense) = bag_strip(12);
        let still = [0.0, 0.0, 1.0];
        let back = BagBack {
            still: &still,
            jaw: None,
        };
        stretch_bags(&mut dense, &mut [], &mut [], &mesh, &hung, Some(&back));
        for (v, row) in dense.iter().enumerate().take(20).skip(4) {
            assert_eq!(row, &still, "vertex {v}");
        }
        for (v, lip) in [(2, 0), (3, 0), (20, 1), (21, 1)] {
            let row = &dense[v];
            assert!((row.iter().sum::<f64>() - 1.0).abs() < 1e-9, "{row:?}");
            assert!(row[lip] > 0.2 && row[2] > 0.2, "vertex {v}: {row:?}");
            assert!(row[1 - lip] < 1e-9, "vertex {v}: {row:?}");
        }
    }

    /// A long strip whose inner columns are a bag joined to skin columns at both ends, the
    /// first skin column with a vertical correction and give-way (a mouth corner's): the bag's
    /// columns by that seam carry them, faded by a smoothstep over [`BAG_SEAM`] of the bag's
    /// depth, each as the skin vertex it hangs from; the rest of the bag and the other side,
    /// whose skin has none, carry nothing.
    #[test]
    fn a_bag_by_its_seam_carries_its_skins_corrections() {
        let (mesh, hung, mut dense) = bag_strip(24);
        let mut vertical = vec![Vec::new(); 48];
        let mut give_way = vec![0.0; 48];
        for v in [0, 1] {
            vertical[v] = vec![(0, 0.3), (1, -0.3)];
            give_way[v] = 1.0;
        }
        let still = [0.0, 0.0, 1.0];
        let back = BagBack {
            still: &still,
            jaw: None,
        };
        stretch_bags(
            &mut dense,
            &mut vertical,
            &mut give_way,
            &mesh,
            &hung,
            Some(&back),
        );
        let deepest = hung.iter().flatten().map(|h| h.depth).fold(0.0, f64::max);
        let mut carried = 0;
        for (v, h) in hung.iter().enumerate() {
            let Some(h) = h else { continue };
            let fade = 1.0 - smoothstep(h.depth / (BAG_SEAM * deepest));
            if h.skin < 2 && fade > 0.0 {
                assert_eq!(
                    vertical[v],
                    [(0, 0.3 * fade), (1, -0.3 * fade)],
                    "vertex {v}"
                );
                assert_eq!(give_way[v], 1.0, "vertex {v}");
                carried += 1;
            } else {
                assert!(vertical[v].is_empty(), "vertex {v}: {:?}", vertical[v]);
                assert_eq!(give_way[v], 0.0, "vertex {v}");
            }
        }
        // The two columns by the seam, fading: nearly whole beside the skin.
        assert_eq!(carried, 4);
        assert!(vertical[2][0].1 > 0.15 && vertical[4][0].1 < vertical[2][0].1);
    }

    /// An arch of six teeth centres rising 0.2 to the back, its front 4 below the mouth at 0.
    fn arch(rise: f64) -> Vec<[f64; 3]> {
        (0..6)
            .map(|i| {
                let z = 50.0 - 8.0 * f64::from(i);
                let x = if i % 2 == 0 { 10.0 } else { -10.0 };
                [x, -4.0 + rise * (50.0 - z), z]
            })
            .collect()
    }

    #[test]
    fn the_parting_line_rises_as_the_teeth_do_within_bounds() {
        assert!((rise_to_the_back(&arch(0.2)) - 0.2).abs() < 1e-12);
        assert_eq!(rise_to_the_back(&arch(2.0)), RISE_MAX);
        assert_eq!(rise_to_the_back(&arch(-0.3)), 0.0);
        assert_eq!(rise_to_the_back(&arch(0.2)[..1]), 0.0);
        assert_eq!(rise_to_the_back(&[[0.0, 1.0, 5.0], [0.0, 3.0, 5.0]]), 0.0);
        assert_eq!(rise_to_the_back(&[[f64::NAN; 3], [0.0, 3.0, 5.0]]), 0.0);
    }

    /// One-vertex pieces at `centres`.
    fn one_vertex_pieces(centres: &[[f64; 3]]) -> Vec<(u32, Vec<u32>)> {
        (0..centres.len() as u32).map(|v| (v, vec![v])).collect()
    }

    /// The jaw of [`MARKERS`] (spacing 20) under a mouth at (0, −2, 62), with one-vertex teeth
    /// at `centres`.
    fn jaw_of(centres: &[[f64; 3]]) -> Jaw {
        let pieces = one_vertex_pieces(centres);
        let pieces = Piece::all(&pieces, centres, 20.0);
        Jaw::new(&MARKERS, [0.0, -2.0, 62.0], 20.0, &[1], &[2], &pieces)
    }

    /// Markers: a chin marker, a lower-lip marker and a skull marker.
    const MARKERS: [[f64; 3]; 3] = [[0.0, -40.0, 60.0], [0.0, -6.0, 62.0], [0.0, 80.0, 40.0]];

    /// A skin of two triangles, a tooth (a small triangle) and a sheet (a wide one): the teeth
    /// are the small piece alone.
    #[test]
    fn teeth_are_the_small_pieces_besides_the_skin() {
        let positions = vec![
            [0.0, 0.0, 0.0],
            [100.0, 0.0, 0.0],
            [100.0, 100.0, 0.0],
            [0.0, 100.0, 0.0],
            [10.0, 10.0, 5.0],
            [12.0, 10.0, 5.0],
            [11.0, 12.0, 5.0],
            [0.0, 0.0, 9.0],
            [90.0, 0.0, 9.0],
            [0.0, 90.0, 9.0],
        ];
        let triangles = vec![[0, 1, 2], [0, 2, 3], [4, 5, 6], [7, 8, 9]];
        let mesh = crate::model::FaceMesh::from_triangles("t", positions, triangles);
        assert_eq!(teeth(&mesh, 20.0), vec![vec![4, 5, 6]]);
    }

    #[test]
    fn two_arches_part_in_their_gap_and_one_arch_does_not() {
        let lower = arch(0.2);
        assert_eq!(between_arches(&lower, 0.2, 2.5), None);
        let upper: Vec<[f64; 3]> = lower.iter().map(|p| [p[0], p[1] + 6.0, p[2]]).collect();
        let both = [lower.clone(), upper].concat();
        // Heights with the rise out: −4 + 0.2 · 50 = 6 for the lower arch, 12 for the upper.
        let level = between_arches(&both, 0.2, 2.5).expect("two arches");
        assert!((level - 9.0).abs() < 1e-9, "{level}");
        // Not parted cleanly: a gap no wider than a group's spread.
        let ragged = [
            [0.0, 0.0, 0.0],
            [0.0, 3.0, 0.0],
            [0.0, 5.0, 0.0],
            [0.0, 8.0, 0.0],
        ];
        assert_eq!(between_arches(&ragged, 0.0, 2.5), None);
        // Nor by less than the least gap.
        assert_eq!(between_arches(&both, 0.2, 6.5), None);
    }

    /// A lower arch rising above the mouth's height at the back rides the jaw tooth by tooth,
    /// front to back (a level line left the back of it on the skin); with an upper arch beside
    /// it whose front reaches the mouth's centre, the line parts the two, the upper riding the
    /// skull.
    #[test]
    fn an_arch_is_on_one_side_front_to_back() {
        let lower = arch(0.2);
        let jaw = jaw_of(&lower);
        assert_eq!(jaw.markers.iter().map(|m| m.0).collect::<Vec<_>>(), [0]);
        assert!((jaw.rise - 0.2).abs() < 1e-12);
        for l in &lower {
            assert!(jaw.share(l) > 0.99, "{l:?}: {}", jaw.share(l));
        }
        let level = Jaw { rise: 0.0, ..jaw };
        assert!(level.share(&lower[5]) < 0.01);
        let upper: Vec<[f64; 3]> = lower.iter().map(|p| [p[0], p[1] + 6.0, p[2]]).collect();
        let both = [lower.clone(), upper.clone()].concat();
        let pieces = one_vertex_pieces(&both);
        let jaw = jaw_of(&both);
        for (l, u) in lower.iter().zip(&upper) {
            assert!(jaw.share(l) > 0.99, "{l:?}: {}", jaw.share(l));
            assert!(jaw.share(u) < 0.01, "{u:?}: {}", jaw.share(u));
        }
        // The lower arch rides the chin and a quarter of the lower lip; the upper, the skull.
        let dense = vec![vec![0.0; 3]; both.len()];
        let rode = ride_beside(dense, &Piece::all(&pieces, &both, 20.0), &both, Some(&jaw));
        for (v, w) in rode.iter().enumerate() {
            let want = if v < lower.len() {
                [1.0 - TOOTH_LIP, TOOTH_LIP, 0.0]
            } else {
                [0.0, 0.0, 1.0]
            };
            for (a, b) in w.iter().zip(want) {
                assert!((a - b).abs() < 1e-9, "tooth {v}: {w:?}");
            }
        }
    }
}
