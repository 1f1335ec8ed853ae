//! Static anchoring: the skin beyond the markers rides the head instead of being dragged.
//!
//! An RBF with an affine term extrapolates: past the last marker the cranium, the back of the
//! head, the ears and the neck move with whatever trend the face markers have (an open jaw lifts
//! the skull by centimetres). Paper 003 pins such regions with static points. Here the region
//! is found from the markers themselves, so no layout has to name it:
//!
//! * The face is seen in a cylindrical projection about the vertical axis (glTF's +Y) through
//!   the centre of the mesh's bounding box: `u` = angle × the markers' median radius, `v` = height.
//! * A vertex is *outside* by its distance beyond the convex hull of the markers in that plane.
//!   Its anchoring strength rises linearly from 0 on the hull to 1 at [`HULL_RISE`] × `margin`
//!   outside.
//! * Below the eyes and in front of the ears the rise runs [`ACROSS_RISE`] times as far across
//!   the face: a smile takes the cheek's skin back towards the ear, while above the brows the
//!   scalp holds.
//! * Below the mouth the skin beyond the markers is the jaw's and the neck's, which follow the
//!   chin rather than the skull: the strength fades out over one `margin`-sized band under the
//!   mouth opening's height (or, on a mesh without a mouth opening, under the markers' mean
//!   height), a height raised by [`JAW_LIFT`] near the jaw's markers (those under it) so that
//!   the jaw's sides stay the jaw's.
//! * Skin under that height but farther than [`JAW_REACH`] from every jaw marker is the neck's
//!   or the nape's and stays anchored. Without that, a head pitched a few degrees in its file
//!   dropped its nape under the mouth's height and the jaw dragged it (FaceCap pitched 8.6°:
//!   4.4 mm where the truth is still).
//! * Between the jaw's sides, though, the skin under the jaw is the throat's, which an open jaw
//!   stretches a long way down: there the hand-over starts nearer ([`THROAT_REACH`]) and runs
//!   longer ([`THROAT_BAND`]), or the skin folds along the jaw's underside.
//!
//! An anchored vertex's dense weights become `(1 − s)·w + s·h`, with `h` the mean of the head
//! markers it follows: the weights still sum to one (uniform translation stays exact) and with
//! the head markers still (a head-stabilised take, or a capture whose head fit removed the
//! motion, leaving the followed markers their residual: JawMoCap's static skin within 0.01 mm)
//! the anchored skin stays still. A vertex keeps K weights, so the share `s·h` takes as few of them as will
//! do: the skin follows three markers ([`followed`]) whose mean one derived marker carries
//! (`deformer::linear::FollowedMean`), with a capture or without.

use crate::mesh::distance;

/// How the skin beyond the markers follows the head.
#[derive(Clone, Debug, PartialEq)]
pub struct Anchoring {
    /// The head markers whose mean displacement anchored vertices follow.
    pub head: Vec<usize>,
    /// Per vertex, the anchoring strength in [0, 1].
    pub strength: Vec<f64>,
}

impl Anchoring {
    /// Blend each vertex's dense weights towards the head markers' mean by its strength.
    pub fn apply(&self, dense: &mut [Vec<f64>]) {
        let Some(n) = dense.first().map(Vec::len) else {
            return;
        };
        let still = still_row(&self.head, n);
        for (w, &s) in dense.iter_mut().zip(&self.strength) {
            if s <= 0.0 {
                continue;
            }
            for (x, t) in w.iter_mut().zip(&still) {
                *x = *x * (1.0 - s) + s * t;
            }
        }
    }

    /// Vertices with any anchoring.
    pub fn anchored_vertices(&self) -> usize {
        self.strength.iter().filter(|&&s| s > 0.0).count()
    }

    /// Vertices fully anchored (strength 1).
    pub fn still_vertices(&self) -> usize {
        self.strength.iter().filter(|&&s| s >= 1.0).count()
    }
}

/// The weights (over `n` markers) of fully anchored skin, which follows the mean of `head`:
/// what [`Anchoring::apply`] blends towards.
pub fn still_row(head: &[usize], n: usize) -> Vec<f64> {
    let mut row = vec![0.0; n];
    for &h in head {
        row[h] += 1.0 / head.len() as f64;
    }
    row
}

/// Markers that ride the skull, found from the face's openings: those above the openings'
/// highest centre whose distance from every point of every opening's rim (mouth, eyes) is at
/// least [`SKULL_CLEARANCE`] × `spacing` and [`SKULL_SHARE`] × the largest such distance, so
/// never a lip, jaw, cheek, eyelid or brow marker. With fewer than three such markers, the three
/// above the openings that are farthest from them; on a mesh without openings, the three
/// highest. Ascending indices.
pub fn skull_markers(markers: &[[f64; 3]], rims: &[Vec<[f64; 3]>], spacing: f64) -> Vec<usize> {
    if rims.iter().all(|r| r.is_empty()) {
        let mut order: Vec<usize> = (0..markers.len()).collect();
        order.sort_by(|&a, &b| markers[b][1].total_cmp(&markers[a][1]).then(a.cmp(&b)));
        order.truncate(3);
        order.sort_unstable();
        return order;
    }
    let top = rims
        .iter()
        .filter(|r| !r.is_empty())
        .map(|r| r.iter().map(|p| p[1]).sum::<f64>() / r.len() as f64)
        .fold(f64::NEG_INFINITY, f64::max);
    let clearance = |m: &[f64; 3]| {
        rims.iter()
            .flatten()
            .map(|p| distance(m, p))
            .fold(f64::INFINITY, f64::min)
    };
    let mut above: Vec<(usize, f64)> = markers
        .iter()
        .enumerate()
        .filter(|(_, m)| m[1] > top)
        .map(|(i, m)| (i, clearance(m)))
        .collect();
    above.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
    let farthest = above.first().map_or(0.0, |p| p.1);
    let needed = (SKULL_CLEARANCE * spacing).max(SKULL_SHARE * farthest);
    let clear = above.iter().filter(|(_, c)| *c >= needed).count();
    let mut chosen: Vec<usize> = above.iter().take(clear.max(3)).map(|p| p.0).collect();
    chosen.sort_unstable();
    chosen
}

/// The markers the linear deformer's anchored skin follows: of the `anchors`
/// ([`anchor_markers`], or a capture's held head markers), those off the `skull` (of the head
/// candidates, each eye's inner corner: the medial canthi, tied to the bone by their tendons)
/// and the one `skull` marker nearest the face's middle (the forehead's centre). The anchored share `s·h` is spread over the markers it
/// follows, one derived marker carries their mean (`deformer::linear::FollowedMean`), and the
/// other anchors keep their own weights.
///
/// Without a head fit (a bake with no capture, whose markers come with the expressions' motion
/// on every marker) five followed markers took five of a vertex's eight weights where the skin
/// hands over from the jaw to the neck, and cut the jaw's markers off in a line (ICT's jaw
/// open: 6 triangles turned over on the jaw's side). With a head fit the held markers are
/// still, and until 2026-12-05 their weights were summed onto one instead: the sum kept the
/// side forehead markers' negative weights under the chin, so the still share there shrank to
/// 0.21 of the row where the mean keeps 0.46, and a capture whose take has no wide jaw open
/// left ICT-FaceKit's truth 11 folded triangles under the chin in its jaw open (none
/// following the three; docs/measurements.md, session 12). `anchors` as they are when none is
/// off the skull.
pub fn followed(markers: &[[f64; 3]], anchors: &[usize], skull: &[usize]) -> Vec<usize> {
    let corners: Vec<usize> = anchors
        .iter()
        .copied()
        .filter(|i| !skull.contains(i))
        .collect();
    if corners.is_empty() {
        return anchors.to_vec();
    }
    let middle = middle_x(markers);
    let centre = anchors
        .iter()
        .copied()
        .filter(|i| skull.contains(i))
        .min_by(|&a, &b| {
            (markers[a][0] - middle)
                .abs()
                .total_cmp(&(markers[b][0] - middle).abs())
                .then(a.cmp(&b))
        });
    let mut followed: Vec<usize> = corners.into_iter().chain(centre).collect();
    followed.sort_unstable();
    followed
}

/// The face's middle across it: the markers' median x (0 without markers).
pub(crate) fn middle_x(markers: &[[f64; 3]]) -> f64 {
    let mut xs: Vec<f64> = markers.iter().map(|p| p[0]).collect();
    xs.sort_by(f64::total_cmp);
    xs.get(xs.len() / 2).copied().unwrap_or(0.0)
}

/// The markers anchored skin follows: the `skull` markers and, unless the rig fits the head
/// itself (`head_fit`), each eye's inner-corner marker. (Planar bones' anchor takes it so; the
/// surface-aware bake with a capture follows the markers its head fit holds,
/// `surface::SurfaceInput::held`, by default these with the inner corners.)
///
/// With a head fit (a bake with a capture) the stages fit the head to the skull markers every
/// frame, which leaves their mean displacement at zero, so skin that follows it stays still.
/// Without one the markers arrive as they are, and the skull markers are skin too: FaceCap's
/// frown moves its left forehead marker 1.48 mm and the three forehead markers' mean 0.59 mm.
/// The inner corners of the eyes (the medial canthi, tied to the bone by their tendons) move
/// least of all the face's markers: 0.03 mm in that frown, at most 0.68 mm over its 32 truth
/// frames (the forehead's: 1.48). An eye's inner-corner marker is the marker nearest the end of
/// its rim closer to the face's middle (the markers' median x), within `reach` × the rim's
/// width (the corners' own reach, `surface::corners::CORNER_REACH`). Ascending indices.
pub fn anchor_markers(
    markers: &[[f64; 3]],
    skull: &[usize],
    eye_rims: &[&[[f64; 3]]],
    head_fit: bool,
    reach: f64,
) -> Vec<usize> {
    let mut chosen = skull.to_vec();
    if head_fit || markers.is_empty() {
        return chosen;
    }
    let middle = middle_x(markers);
    for rim in eye_rims {
        let ends = [
            rim.iter().min_by(|a, b| a[0].total_cmp(&b[0])),
            rim.iter().max_by(|a, b| a[0].total_cmp(&b[0])),
        ];
        let [Some(low), Some(high)] = ends else {
            continue;
        };
        let inner = if (low[0] - middle).abs() <= (high[0] - middle).abs() {
            low
        } else {
            high
        };
        let width = distance(low, high);
        let nearest = markers
            .iter()
            .map(|m| distance(m, inner))
            .enumerate()
            .min_by(|a, b| a.1.total_cmp(&b.1));
        if let Some((m, distance_to_corner)) = nearest {
            if distance_to_corner <= reach * width && !chosen.contains(&m) {
                chosen.push(m);
            }
        }
    }
    chosen.sort_unstable();
    chosen
}

/// How far the hull comes in from each anchor marker towards its nearest other marker (a
/// brow's, for a forehead marker): the skin just beyond a forehead marker that an expression
/// moves is anchored a little, not dragged with it. With `facebake place`'s markers on the
/// wider face the frown moved `ForeHead_R` and the static skin 5 mm above it 0.54 mm; the skull
/// markers left out of the hull (1) held it (0.36 mm) but anchored the skin right above the
/// brows, and the surprise, which lifts that skin 9–14 mm, folded two triangles over the
/// heavier jaw's right brow. Measured 2026-12-02 (`--test other_faces`, `--test structure`),
/// placed markers, static drift: wider 0.54 / **0.36** / 0.36 mm, heavier jaw 0.44 / **0.35**
/// / 0.35, narrower 0.37 throughout, at 0 / **0.3** / 0.5, with no flip added and FaceCap's
/// own truth unchanged (0.34 mm, mean 0.553).
pub const HULL_LOWERING: f64 = 0.3;

/// The markers whose hull bounds the skin left to the face ([`static_anchoring`]): every
/// marker, each of the `anchors` moved [`HULL_LOWERING`] of the way towards its nearest other
/// marker (the nearest that is not an anchor, when there is one).
///
/// A rig with its own head fit (a bake with a capture) holds its head markers still, and it
/// once left them out of the hull: the skin past the brows then faded to the still head over
/// [`HULL_RISE`] of a margin. ICT-FaceKit's surprise lifts its brows 5.5–7.8 mm while its
/// forehead markers, 30 mm above, move 1–2.5 mm down: squeezed into 12 mm, the skin folded in
/// a line across the forehead (5 triangles turned over in its rehearsal). With the lowered
/// head markers in the hull, the skin between brows and forehead is the markers' to share out,
/// as the truth shares it. Measured 2026-12-04 (`--test ict_facekit`, `--test rehearsal`,
/// `--test other_faces`, `-- --nocapture`), left out / lowered 0.15 / **0.3** / 0.4:
///
/// | | left out | 0.15 | **0.3** | 0.4 |
/// |---|---|---|---|---|
/// | ICT's rehearsal: flips in its worst frame; face mean | 5; 0.631 mm | 1; 0.636 | **1; 0.636** | 2 |
/// | FaceCap's rehearsal: static drift; face mean | 0.01; 0.525 mm | 0.14; 0.529 | **0.01; 0.528** | – |
/// | FaceCap's truth as a capture: skin mean; forehead mean | 0.548; 0.311 mm | – | **0.546; 0.325** | – |
/// | JawMoCap on the wider face: static drift | 0.00 mm | – | **0.08** | – |
pub fn hull_markers(markers: &[[f64; 3]], anchors: &[usize]) -> Vec<[f64; 3]> {
    let face: Vec<[f64; 3]> = markers
        .iter()
        .enumerate()
        .filter(|(i, _)| !anchors.contains(i))
        .map(|(_, p)| *p)
        .collect();
    markers
        .iter()
        .enumerate()
        .map(|(i, p)| {
            if !anchors.contains(&i) {
                return *p;
            }
            face.iter()
                .min_by(|a, b| distance(a, p).total_cmp(&distance(b, p)))
                .map_or(*p, |q| {
                    [0, 1, 2].map(|c| p[c] + HULL_LOWERING * (q[c] - p[c]))
                })
        })
        .collect()
}

/// How far from every opening a skull marker sits, at least: × the mean marker spacing.
pub const SKULL_CLEARANCE: f64 = 2.0;
/// How far from every opening a skull marker sits, at least: × the clearance of the marker
/// farthest from them (brows are about half as far from the eyes as the forehead's markers).
pub const SKULL_SHARE: f64 = 0.75;

/// How far from the nearest of the jaw's markers (those under the mouth), in anchoring margins,
/// the skin under the mouth is still the jaw's; beyond it, over one more margin, it becomes the
/// neck's and the nape's and rides the head. On FaceCap's truth with the JawMoCap layout the
/// static skin stays within 0.34 mm with the head pitched 8.6° either way in its file for a
/// reach from 2.5 to 3 margins; at 2 the jaw's sides are held (face max 9.07 → 11.45 mm), at
/// 3.5 the nape is left to the jaw again (3.95 mm pitched 8.6° down, `tests/tests/pose.rs`).
pub const JAW_REACH: f64 = 3.0;

/// Between the jaw's sides (no farther from the face's middle than the jaw's widest marker),
/// how far from the nearest of the jaw's markers, in anchoring margins, the skin under the mouth
/// is still wholly the jaw's; over the next [`THROAT_BAND`] margins it becomes the throat's and
/// rides the head. Outside the jaw's sides (the neck's sides, the nape) [`JAW_REACH`] and one
/// margin hold. A jaw open pulls the skin under the chin down 25–30 mm and the throat below it
/// still follows some way: ICT-FaceKit's own jaw open moves its throat 16 / 8.5 / 3.7 / 1.6 mm
/// at 5 / 6.5 / 8 / 10 cm from the chin. Handed over within one margin (14.5 mm on that head)
/// the skin turned over in a line along the jaw's underside. FaceCap's skin stops at the jaw's
/// underside, so only its neck's sides, which its shapes keep still, lie under the mouth.
/// Measured 2026-12-03 (`--test ict_facekit`, `--test pose`, `-- --nocapture`): ICT's truth
/// through JawMoCap's placed markers, flips / face mean / max:
///
/// | reach, band (margins) | flips | face mean | max |
/// |---|---|---|---|
/// | 3, 1 (as the neck's sides) | 112 | 0.744 mm | 14.21 mm |
/// | 3, 3 | 13 | 0.753 | 15.58 |
/// | 3, 4 | 7 | 0.763 | 15.24 |
/// | 2, 3 | 91 | 0.737 | 12.31 |
/// | **2, 5** | **7** | **0.749** | **14.89** |
/// | 2, 6 | 5 | 0.759 | 15.00 |
///
/// JawMoCap played on ICT through `bake --capture`: 76 → 12 flips, frames with an edge over
/// 2×: 216 → 135 of 1590. FaceCap pitched ±5.7° and ±8.6° keeps its static skin within
/// 0.34 mm as before; with the band widened all round instead (1.5 / 2 / 3 margins), FaceCap
/// pitched 8.6° down (`--test pose`'s −8.6°) moved the neck's sides under its ears 1.47 / 4.35 /
/// 6.99 mm.
pub const THROAT_REACH: f64 = 2.0;

/// Over how many anchoring margins the skin under the jaw between its sides becomes the
/// throat's (see [`THROAT_REACH`]).
pub const THROAT_BAND: f64 = 5.0;

/// How far the floor rises near the jaw's markers (within [`JAW_REACH`]), in anchoring
/// margins. On FaceCap's truth with the JawMoCap layout (`--test structure`, `--test pose`):
/// face mean / max 0.556 / 9.07 → 0.550 / 8.85 mm upright, max 10.94 → 9.02 mm pitched 8.6°
/// up (the jaw's sides rising into the anchored band); 0.75 and more fold the twice-subdivided
/// head in the smile (4 flipped triangles at 0.75, 10 at 1.25, 16 at 1.5).
pub const JAW_LIFT: f64 = 0.5;

/// How tall, in anchoring margins, the band over which the skin above the floor is anchored
/// near the jaw's markers (within [`JAW_REACH`]; one margin far from them). The jaw open drags
/// the skin beside the jaw down by a centimetre and more while the anchored cheek above holds,
/// and within one margin that showed as a crease along the mouth's height from the mouth to
/// below the ear on ICT-FaceKit's head (edges there stretched 1.6–1.9×); the truth fades it out
/// up to the ear. Measured 2026-12-03 (`--test ict_facekit`, `--test other_faces`, `--test
/// structure`, `--test pose`, `-- --nocapture`), ICT's jaw open:
///
/// | fade (margins) | crease edges over 1.6× | ICT face mean; rehearsal mean | narrower and longer face, JawMoCap: static drift |
/// |---|---|---|---|
/// | 1 (before) | 12, up to 1.88× | 0.749; 0.632 mm | 0.00 mm |
/// | **2** | **0** (1.68× at the jaw's reach, below the ear) | **0.745; 0.631 mm** | **0.00 mm** |
/// | 3 | 0 | 0.744; 0.630 | 0.06 |
/// | 4 | 0 | 0.743; 0.631 | – |
///
/// FaceCap's figures barely move (its skin beside the jaw lies within the markers' hull).
pub const JAW_FLOOR_FADE: f64 = 2.0;

/// Over what share of the anchoring margin the strength rises beyond the markers' hull, linearly
/// from 0 on the hull. A brow raise moves the skin at the hull by centimetres while the skin a
/// margin out holds still, so the rise compresses the skin between them, and where the fade is
/// steepest a triangle can turn over; a linear rise is nowhere steeper than its mean, where a
/// smoothstep over the whole margin was 1.5× steeper in its middle. Measured 2026-12-02 against
/// that smoothstep (`--test structure`, `--test other_faces`, `-- --nocapture`), worst over the
/// truth's 32 frames:
///
/// | | smoothstep, 1 margin | linear, 1 | **linear, 0.8** |
/// |---|---|---|---|
/// | FaceCap: static drift; skin mean | 0.34; 0.551 mm | 0.36; 0.550 | 0.34; 0.553 |
/// | `--method euclidean` / `hybrid` / `pbw`: static drift | 0.51 / 0.52 / 0.54 mm | 0.52 / 0.53 / 0.51 | **0.44 / 0.45 / 0.49** |
/// | the longer face: flips in the surprise | 2 | 0 | **0** |
/// | FaceCap subdivided once: static drift, flips | 0.45 mm, 1 | 0.44, 0 | **0.42, 0** |
/// | JawMoCap, planar bones: static drift | 0.33 mm | 0.30 | **0.28** |
///
/// With a short ease-in before the linear part (0.1–0.3 of the margin) its slope is steeper and
/// FaceCap's own surprise flipped a triangle at the outer end of a brow.
pub const HULL_RISE: f64 = 0.8;

/// Below the eyes and in front of the ears ([`FRONT`]), how many times as far across the face
/// as up or down the anchoring's strength takes to rise beyond the markers' hull. A smile and a
/// jaw move the cheek's skin back towards the ear, while above the brows the scalp holds: in
/// both truths' smiles the skin 14–30 mm behind the outer cheek marker rises 4–6.5 mm
/// (ICT-FaceKit 4.9–6.5 mm, FaceCap 4.1–6.0), where the rig moved it 0–2.4 mm. Measured
/// 2026-12-05 (`--test structure`, `--test ict_facekit`, `--test other_faces`, `--test
/// accuracy`, `-- --nocapture`), face mean on the truths with the JawMoCap layout, and on
/// FaceCap's 40 sampled markers (which reach round behind the ears):
///
/// | across | FaceCap | ICT-FaceKit | FaceCap's sampled markers |
/// |---|---|---|---|
/// | 1 (as up or down) | 0.5193 mm | 0.6829 | 0.8666 |
/// | 2.5 | 0.5143 | 0.6778 | – |
/// | **3** | **0.5137** | **0.6768** | **0.8666** |
/// | 4 / 5 | 0.5132 / 0.5129 | 0.6756 / 0.6750 | – |
/// | 3, all round the head | 0.5129 | 0.6764 | 0.8703 (the back of the head 0.3 mm worse) |
/// | 3, all round and up to a margin over the eyes | 0.5139 | 0.6751 | – |
/// | 2.5 / 3 at every height | 0.5141 / 0.5134 | 0.6712 / 0.6686 | – |
///
/// At every height the forehead's sides follow the brows: FaceCap's static drift 0.29 → 0.40
/// mm at 3, and subdivided once 0.57 mm at 2.5 (beside `ForeHead_R` in the surprise).
///
/// No structure figure moves on any truth, take or head, and JawMoCap's static drift stays
/// 0.01 mm.
pub const ACROSS_RISE: f64 = 3.0;

/// The angles round the head from the face's front (about the vertical axis through the mesh's
/// bounding box), in degrees, within which [`ACROSS_RISE`] holds fully and beyond which not at
/// all: the ears and the back of the head keep the rise up or down.
pub const FRONT: [f64; 2] = [60.0, 90.0];

/// Anchoring strengths of `positions` (glTF vertices) beyond the hull of `markers` (see
/// [`hull_markers`]), with the skin under `floor` (a height: the mouth's) left to the face
/// markers; `margin` is the distance over which the strength rises, in asset units, and
/// [`ACROSS_RISE`] times as far across the cheeks, below `eyes` (a height: the eyes' rims').
pub fn static_anchoring(
    positions: &[[f64; 3]],
    markers: &[[f64; 3]],
    head: &[usize],
    floor: Option<f64>,
    eyes: Option<f64>,
    margin: f64,
) -> Anchoring {
    let (lo, hi) = crate::model::bounds(positions.iter().copied());
    let axis = [0.5 * (lo[0] + hi[0]), 0.5 * (lo[2] + hi[2])];
    let mut radii: Vec<f64> = markers
        .iter()
        .map(|m| (m[0] - axis[0]).hypot(m[2] - axis[1]))
        .collect();
    radii.sort_by(f64::total_cmp);
    let radius = radii.get(radii.len() / 2).copied().unwrap_or(1.0);
    let angle = |p: &[f64; 3]| (p[0] - axis[0]).atan2(p[2] - axis[1]);
    let project = |p: &[f64; 3]| [angle(p) * radius, p[1]];
    // The hull seen with distances across the face shrunk by `ACROSS_RISE`: its outside
    // distances are those of a rise that runs that many times as far across.
    let across = |q: [f64; 2]| [q[0] / ACROSS_RISE, q[1]];
    let wide = convex_hull(markers.iter().map(|m| across(project(m))).collect());
    // Where the longer rise across holds: below the eyes (fully a margin under them) and in
    // front of the ears (fully within `FRONT[0]` of the face's front, not at all past `FRONT[1]`).
    let [full, none] = FRONT.map(f64::to_radians);
    let cheek = |p: &[f64; 3]| {
        let below = eyes.map_or(0.0, |eyes| smoothstep((eyes - p[1]) / margin));
        below * (1.0 - smoothstep((angle(p).abs() - full) / (none - full)))
    };
    let hull = convex_hull(markers.iter().map(project).collect());
    let floor = floor
        .unwrap_or_else(|| markers.iter().map(|m| m[1]).sum::<f64>() / markers.len().max(1) as f64);
    // The jaw's markers: those under the floor. Skin under the floor but far from all of them
    // is the neck's and the nape's, not the jaw's.
    let jaw: Vec<&[f64; 3]> = markers.iter().filter(|m| m[1] < floor).collect();
    let middle = middle_x(markers);
    let jaw_half_width = jaw
        .iter()
        .map(|m| (m[0] - middle).abs())
        .fold(0.0, f64::max);

    let strength = positions
        .iter()
        .map(|p| {
            if hull.len() < 3 || margin <= 0.0 {
                return 0.0;
            }
            let c = cheek(p);
            let outside = (1.0 - c) * outside_distance(&hull, project(p))
                + c * outside_distance(&wide, across(project(p)));
            let near = jaw
                .iter()
                .map(|m| distance(m, p))
                .fold(f64::INFINITY, f64::min);
            // Between the jaw's sides (fading out over a margin beyond them) the skin under
            // the jaw is the throat's, which the jaw's markers stretch a long way down.
            let between = 1.0 - smoothstep(((p[0] - middle).abs() - jaw_half_width) / margin);
            let reach = margin * (JAW_REACH + (THROAT_REACH - JAW_REACH) * between);
            let band = margin * (1.0 + (THROAT_BAND - 1.0) * between);
            let behind = if jaw.is_empty() {
                0.0
            } else {
                smoothstep((near - reach) / band)
            };
            // Near the jaw's markers the floor is higher: the jaw's sides, just above the
            // mouth's height, are the jaw's too,
            let raised = floor + JAW_LIFT * margin * (1.0 - behind);
            // and there the anchored skin above fades in over a taller band.
            let height = margin * (1.0 + (JAW_FLOOR_FADE - 1.0) * (1.0 - behind));
            let above = smoothstep((p[1] - (raised - margin)) / height);
            (outside / (HULL_RISE * margin)).clamp(0.0, 1.0) * above.max(behind)
        })
        .collect();
    Anchoring {
        head: head.to_vec(),
        strength,
    }
}

/// `3t² − 2t³` on `t` clamped to [0, 1].
pub(crate) fn smoothstep(t: f64) -> f64 {
    let t = t.clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// Convex hull, counter-clockwise, by Andrew's monotone chain.
fn convex_hull(mut points: Vec<[f64; 2]>) -> Vec<[f64; 2]> {
    points.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
    points.dedup();
    if points.len() < 3 {
        return points;
    }
    let cross = |o: [f64; 2], a: [f64; 2], b: [f64; 2]| {
        (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])
    };
    let mut hull: Vec<[f64; 2]> = Vec::with_capacity(2 * points.len());
    for pass in 0..2 {
        let start = hull.len();
        let iter: Box<dyn Iterator<Item = &[f64; 2]>> = if pass == 0 {
            Box::new(points.iter())
        } else {
            Box::new(points.iter().rev())
        };
        for &p in iter {
            while hull.len() >= start + 2
                && cross(hull[hull.len() - 2], hull[hull.len() - 1], p) <= 0.0
            {
                hull.pop();
            }
            hull.push(p);
        }
        hull.pop();
    }
    hull
}

/// Signed distance of `p` beyond a counter-clockwise convex polygon: the largest distance in
/// front of an edge's line (positive outside, negative inside).
fn outside_distance(hull: &[[f64; 2]], p: [f64; 2]) -> f64 {
    (0..hull.len())
        .map(|i| {
            let a = hull[i];
            let b = hull[(i + 1) % hull.len()];
            let e = [b[0] - a[0], b[1] - a[1]];
            let len = (e[0] * e[0] + e[1] * e[1]).sqrt().max(f64::MIN_POSITIVE);
            // Outward normal of a counter-clockwise edge: (e.y, −e.x).
            ((p[0] - a[0]) * e[1] - (p[1] - a[1]) * e[0]) / len
        })
        .fold(f64::NEG_INFINITY, f64::max)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Three forehead markers (skull) and two inner eye corners: the skin
    /// follows the corners and the forehead marker nearest the face's middle; with no corner
    /// among the anchors, all of them.
    #[test]
    fn the_skin_follows_the_inner_corners_and_the_forehead_centre() {
        let markers = [
            [0.04, 0.10, 0.08],
            [0.001, 0.10, 0.09],
            [-0.04, 0.10, 0.08],
            [0.015, 0.03, 0.09],
            [-0.015, 0.03, 0.09],
            [0.0, -0.03, 0.10],
        ];
        let skull = [0, 1, 2];
        assert_eq!(followed(&markers, &[0, 1, 2, 3, 4], &skull), vec![1, 3, 4]);
        assert_eq!(followed(&markers, &[0, 1, 2], &skull), vec![0, 1, 2]);
    }

    #[test]
    fn hull_of_a_square_with_an_inner_point() {
        let h = convex_hull(vec![
            [0.0, 0.0],
            [1.0, 0.0],
            [1.0, 1.0],
            [0.0, 1.0],
            [0.5, 0.5],
        ]);
        assert_eq!(h.len(), 4);
        assert!((outside_distance(&h, [2.0, 0.5]) - 1.0).abs() < 1e-12);
        assert!((outside_distance(&h, [0.5, 0.5]) + 0.5).abs() < 1e-12);
        assert!((outside_distance(&h, [0.5, -0.25]) - 0.25).abs() < 1e-12);
    }

    #[test]
    fn skin_beyond_the_markers_follows_the_head_and_weights_still_sum_to_one() {
        // Markers on the front of a unit cylinder (a "face"), vertices all around it.
        let markers: Vec<[f64; 3]> = (0..5)
            .flat_map(|i| {
                let a = (i as f64 - 2.0) * 0.3;
                [[a.sin(), -0.5, a.cos()], [a.sin(), 0.5, a.cos()]]
            })
            .collect();
        let mut positions = Vec::new();
        for j in 0..24 {
            let a = j as f64 / 24.0 * std::f64::consts::TAU;
            positions.push([a.sin(), 0.2, a.cos()]);
        }
        let head = skull_markers(&markers, &[], 1.0);
        assert!(head.iter().all(|&h| markers[h][1] == 0.5));
        let anchoring = static_anchoring(&positions, &markers, &head, Some(-0.5), None, 0.2);
        // The front vertex (angle 0) is among the markers, the back one (angle π) far beyond.
        assert_eq!(anchoring.strength[0], 0.0);
        assert_eq!(anchoring.strength[12], 1.0);
        let mut dense = vec![vec![0.1; markers.len()]; positions.len()];
        anchoring.apply(&mut dense);
        for w in &dense {
            assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-12);
        }
        assert!(dense[12]
            .iter()
            .enumerate()
            .all(|(i, &w)| if head.contains(&i) {
                (w - 1.0 / 3.0).abs() < 1e-12
            } else {
                w == 0.0
            }));
    }

    #[test]
    fn the_hull_is_the_face_markers_and_the_lowered_anchors() {
        let markers = [
            [0.0, 0.0, 1.0],
            [1.0, 0.0, 1.0],
            [0.0, 1.0, 1.0],
            [0.0, 2.0, 1.0],
        ];
        // Every marker, an anchor marker lowered towards its nearest other marker: marker 3
        // towards marker 2, 1 below it.
        let towards =
            |p: [f64; 3], q: [f64; 3]| [0, 1, 2].map(|c| p[c] + HULL_LOWERING * (q[c] - p[c]));
        let mut expected = markers.to_vec();
        expected[3] = towards(markers[3], markers[2]);
        assert_eq!(hull_markers(&markers, &[3]), expected);
        // Two anchors: markers 2 and 3 each towards its nearest face marker, marker 0.
        let mut expected = markers.to_vec();
        expected[2] = towards(markers[2], markers[0]);
        expected[3] = towards(markers[3], markers[0]);
        assert_eq!(hull_markers(&markers, &[2, 3]), expected);
    }

    #[test]
    fn skull_markers_keep_clear_of_the_openings() {
        // An "eye" rim at height 0; markers beside it, above it, far above it.
        let rim = vec![vec![[-0.1, 0.0, 0.0], [0.1, 0.0, 0.0]]];
        let markers = [
            [0.0, 1.5, 0.0], // a brow: above, clear of the rim by 1.5, but half the forehead's
            [0.0, 3.0, 0.0],
            [1.0, 3.0, 0.0],
            [-1.0, 3.0, 0.0],
            [0.0, -3.0, 0.0], // far, but below the opening (a chin)
        ];
        assert_eq!(skull_markers(&markers, &rim, 1.0), vec![1, 2, 3]);
        // Too few clear markers: the three above that are farthest from the rim.
        assert_eq!(skull_markers(&markers[..3], &rim, 1.0), vec![0, 1, 2]);
    }

    #[test]
    fn without_a_head_fit_the_inner_corners_of_the_eyes_anchor_too() {
        // Two eyes 20 wide either side of the middle (x = 0), a forehead above them.
        let left: Vec<[f64; 3]> = (0..=10)
            .map(|i| [10.0 + 2.0 * f64::from(i), 0.0, 0.0])
            .collect();
        let right: Vec<[f64; 3]> = left.iter().map(|p| [-p[0], p[1], p[2]]).collect();
        let markers = [
            [0.0, 40.0, 0.0],  // 0: forehead
            [9.0, 0.5, 0.0],   // 1: left inner corner (1.1 from the rim's inner end)
            [31.0, 0.5, 0.0],  // 2: left outer corner
            [-12.0, 0.0, 0.0], // 3: right inner corner, 2 from the rim's end
            [20.0, 3.0, 0.0],  // 4: left upper lid
            [0.0, -40.0, 0.0], // 5: chin
        ];
        let eyes = [left.as_slice(), right.as_slice()];
        assert_eq!(
            anchor_markers(&markers, &[0], &eyes, false, 0.2),
            vec![0, 1, 3]
        );
        // With the rig's own head fit, the skull markers alone.
        assert_eq!(anchor_markers(&markers, &[0], &eyes, true, 0.2), vec![0]);
        // A corner marker beyond the reach (2 > 0.05 × 20) is not an eye's corner.
        assert_eq!(
            anchor_markers(&markers, &[0], &eyes, false, 0.06),
            vec![0, 1]
        );
    }

    /// A patch of four markers on the front of a unit cylinder, from height 0 to 1.
    const PATCH: [[f64; 3]; 4] = [
        [0.0, 0.0, 1.0],
        [0.3, 0.0, 0.95],
        [0.0, 1.0, 1.0],
        [0.3, 1.0, 0.95],
    ];

    #[test]
    fn the_strength_rises_linearly_beyond_the_hull() {
        // The patch, its top edge at height 1; skin straight above it, and three points that
        // centre the mesh's box on the axis.
        let markers = PATCH.to_vec();
        let (x, margin) = (0.15f64, 0.5);
        let z = (1.0 - x * x).sqrt();
        let above: Vec<f64> = (0..=10).map(|k| 0.05 * f64::from(k)).collect();
        let mut positions: Vec<[f64; 3]> = above.iter().map(|d| [x, 1.0 + d, z]).collect();
        positions.extend([[0.0, 0.5, -1.0], [0.6, 0.5, 0.0], [-0.6, 0.5, 0.0]]);
        let a = static_anchoring(&positions, &markers, &[2, 3], Some(-10.0), None, margin);
        for (d, s) in above.iter().zip(&a.strength) {
            // Outside by d × (1 − the projection's small stretch): the rise is linear.
            let expected = (d / (HULL_RISE * margin)).min(1.0);
            assert!((s - expected).abs() < 0.02, "{d}: {s} against {expected}");
        }
        // Nowhere steeper than its mean.
        for w in a.strength[..above.len()].windows(2) {
            assert!(w[1] - w[0] <= 0.05 / (HULL_RISE * margin) + 1e-9, "{w:?}");
        }
    }

    #[test]
    fn below_the_eyes_and_in_front_of_the_ears_the_rise_runs_further_across() {
        let markers = PATCH.to_vec();
        // A margin long enough that skin far round the head is not yet wholly anchored.
        let margin = 2.5;
        // Skin beside the patch at its middle height, a little way round (in front of the
        // ears) and far round (behind them); three points that centre the mesh's box.
        let round = |degrees: f64| {
            let a = f64::to_radians(degrees);
            [a.sin(), 0.5, a.cos()]
        };
        let mut positions = vec![round(22.0), round(30.0), round(120.0)];
        positions.extend([[0.0, 0.5, -1.0], [1.0, 0.5, 0.0], [-1.0, 0.5, 0.0]]);
        let with_eyes = |eyes| {
            static_anchoring(&positions, &markers, &[2, 3], Some(-10.0), eyes, margin).strength
        };
        let plain = with_eyes(None);
        // The eyes two margins above the skin: beside the face the rise runs three times as
        // far across; behind the ears it does not.
        let cheeks = with_eyes(Some(0.5 + 2.0 * margin));
        for v in 0..2 {
            assert!(plain[v] > 0.0 && plain[v] < 1.0, "{plain:?}");
            assert!(
                (cheeks[v] - plain[v] / ACROSS_RISE).abs() < 1e-12,
                "{cheeks:?}"
            );
            assert!(cheeks[v] < plain[v], "{cheeks:?}");
        }
        assert!(
            plain[2] < 1.0 && cheeks[2] == plain[2],
            "{plain:?} {cheeks:?}"
        );
        // The eyes two margins below it (a forehead): the rise up or down.
        assert_eq!(with_eyes(Some(0.5 - 2.0 * margin)), plain);
    }

    #[test]
    fn skin_below_the_floor_is_left_to_the_face() {
        let markers = PATCH.to_vec();
        let positions = vec![[0.0, 3.0, 1.0], [0.0, -3.0, 1.0]];
        let a = static_anchoring(&positions, &markers, &[2, 3], Some(0.0), None, 0.5);
        assert_eq!(a.strength, vec![1.0, 0.0]);
    }

    #[test]
    fn skin_below_the_floor_far_from_the_jaw_rides_the_head() {
        // A face on the front of a cylinder of radius 1: a "jaw" marker under the floor (0).
        let markers = vec![
            [0.0, -0.5, 1.0],
            [0.3, 0.0, 0.95],
            [-0.3, 0.0, 0.95],
            [0.0, 1.0, 1.0],
            [0.3, 1.0, 0.95],
        ];
        // Under the floor: beside the jaw marker (outside the hull), and round at the nape.
        let positions = vec![[0.35, -0.7, 0.94], [-0.35, -0.7, 0.94], [0.0, -1.0, -1.0]];
        let a = static_anchoring(&positions, &markers, &[3, 4], Some(0.0), None, 0.2);
        assert_eq!(a.strength, vec![0.0, 0.0, 1.0]);
    }

    #[test]
    fn the_throat_between_the_jaws_sides_is_handed_over_longer() {
        // A jaw 0.4 wide under the floor (0) on the front of a cylinder of radius 1.
        let markers = vec![
            [0.0, -0.5, 1.0],
            [0.2, -0.5, 0.98],
            [-0.2, -0.5, 0.98],
            [0.3, 0.0, 0.95],
            [-0.3, 0.0, 0.95],
            [0.0, 1.0, 1.0],
            [0.3, 1.0, 0.95],
        ];
        let margin = 0.2;
        // Under the chin (between the jaw's sides), and as far under the jaw's side but well
        // beside it (more than a margin beyond its widest marker).
        let positions = vec![[0.0, -1.2, 1.0], [0.75, -0.9, 0.66]];
        let a = static_anchoring(&positions, &markers, &[5, 6], Some(0.0), None, margin);
        let near = |p: &[f64; 3]| {
            markers[..3]
                .iter()
                .map(|m| distance(m, p))
                .fold(f64::INFINITY, f64::min)
                / margin
        };
        let throat = smoothstep((near(&positions[0]) - THROAT_REACH) / THROAT_BAND);
        let side = smoothstep(near(&positions[1]) - JAW_REACH);
        assert!((a.strength[0] - throat).abs() < 1e-12, "{:?}", a.strength);
        assert!((a.strength[1] - side).abs() < 1e-12, "{:?}", a.strength);
        // 3.5 margins from the chin the throat still follows it by more than half; as far
        // from the jaw, the neck's side is mostly the head's.
        assert!(
            a.strength[0] < 0.5 && a.strength[1] > 0.5,
            "{:?}",
            a.strength
        );
    }

    #[test]
    fn the_floor_rises_near_the_jaw() {
        // Beside the face at the floor's height: near the jaw marker (under the floor), and as
        // far to the side but with no marker under the floor within reach.
        let face = |jaw: f64| {
            vec![
                [0.3, jaw, 0.95],
                [0.3, 0.0, 0.95],
                [-0.3, 0.0, 0.95],
                [0.0, 1.0, 1.0],
                [0.3, 1.0, 0.95],
            ]
        };
        let positions = vec![[0.6, 0.0, 0.8], [-0.6, 0.0, 0.8], [0.0, 0.5, -1.0]];
        let near = static_anchoring(&positions, &face(-0.2), &[3, 4], Some(0.0), None, 0.2);
        let far = static_anchoring(&positions, &face(-50.0), &[3, 4], Some(0.0), None, 0.2);
        // At the floor: anchored by the band (smoothstep(1) = 1) away from the jaw; within its
        // reach the floor stands half a margin higher and the band is two margins tall, so
        // a quarter of the way up it: smoothstep(0.25) = 0.15625 (the points are far outside
        // the hull).
        assert_eq!(far.strength[0], 1.0);
        assert!(
            (near.strength[0] - 0.15625).abs() < 1e-12,
            "{:?}",
            near.strength
        );
        assert_eq!(near.strength[2], 1.0);
    }
}
