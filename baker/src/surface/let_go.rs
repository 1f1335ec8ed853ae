//! Lids and the upper lip let go: a marker worn on an eyelid or on the upper lip moves it, not
//! the skin past it.
//!
//! **Eyelids.** A blink moves the upper lid's margin 9 mm while the skin a centimetre above it,
//! past the lid's crease, stays where it is (on FaceCap's truth 0.1–0.5 mm at 8–16 mm above the
//! rim, on ICT-FaceKit's 1–2 mm). An interpolation between the lid's marker, on the margin, and
//! the brow's, 2 cm above, moves that skin in proportion to the distance instead: 5–7 mm, so the
//! closed lid dragged the skin under the brow down with it and the lid kept its crease.
//!
//! So a lid marker's weight fades with the vertex's distance from the eye's rim along the skin
//! ([`reshape`], [`Fade::keep`]): whole within [`LIDS`]' `hold` of the eye's width, nothing at
//! its `reach`, a smoothstep between; what it gives up goes to the vertex's other markers in
//! proportion (the brow's, the eye's corners', the cheek's), so the weights still sum to what
//! they did and the skin past the fold follows them. The rim and the marker's own spot keep
//! their weights, so the lids still close. Past `reach` the weights come back to what they were
//! over `back` of the width: a lid marker's far field is small, and handing it to other markers
//! across the whole face moved the chin (a third triangle there turned over in `blend 2` on
//! FaceCap subdivided twice).
//!
//! A lid marker is a marker within [`LID_REACH`] of an eye's rim that is not at either of its
//! corners (those are `surface::corners`').
//!
//! Measured 2026-12-04 (`--test structure`, `--test other_faces`, `--test rehearsal`, `--test
//! ict_facekit`, `-- --nocapture`; the blink's bins by a scratch harness): the skin 8–10 mm
//! above the upper rim in the blink, FaceCap / ICT-FaceKit, truth 0.5 / 1.0 mm, before 7.1 /
//! 5.7 mm, now 3.9 / 2.9 mm; FaceCap's truth face mean / p99 / max 0.547 / 4.48 / 8.85 →
//! 0.546 / 4.41 / 8.41 mm; its truth as a capture, forehead mean 0.325 → 0.275 mm; ICT's truth
//! 0.745 / 4.66 → 0.734 / 4.54 mm; its rehearsal 0.601 / 3.75 → 0.594 / 3.65 mm; FaceCap
//! subdivided twice 2.16× (5 edges over 2×) → 2.03× (1). A steeper fade tears: hold 0.1, reach
//! 0.3 stretched FaceCap's JawMoCap take 2.15× and flipped 9 triangles in ICT's rehearsal;
//! 0.12 / 0.35, 2.07× and 4 flips there; 0.12 / 0.5, ICT's rehearsal 1.90× (1.85× now). The
//! rim pairs' eyelid figures do not move (they are on the rim).
//!
//! **The upper lip.** A pucker or a funnel pushes the upper lip forwards while the nose stays:
//! ICT-FaceKit's truth moves the skin 23 mm above its upper rim (under the nose) 0.5 mm back in
//! its pucker, where the rig, interpolating between the upper lip's markers and the nose's,
//! moved it 2.3 mm forwards. So the upper lip's markers (the mouth's upper group within
//! [`LID_REACH`] of its rim, not at its corners) let go of the skin past the lip the same way,
//! over [`UPPER_LIP`]'s distances in the mouth's width. The lower lip keeps its reach: its drop
//! spreads down the chin (FaceCap's funnel drops the skin between the lower lip and the chin in
//! proportion, 35 mm at the rim to 14 at the chin), and letting it go there folded the funnel's
//! chin (26 triangles turned over on FaceCap's truth).
//!
//! **The lower lip's depth.** Its drop spreads down the chin, its depth does not: along
//! FaceCap's midline the truth's depth leaves the lip within about 20 mm of the rim (in the
//! funnel a share of the lip's 0.84 / 0.49 / 0.32 / 0.0 at 3 / 9.5 / 15.6 / 23.7 mm below it;
//! `blend 22`, the jaw open and the pucker alike), its drop over about 35 mm, where the rig's
//! lower-lip markers carried 0.98 / 0.85 / 0.72 / 0.53 of the weight on every axis. So past the
//! corners' band a share of the lower lip's weight moves to the jaw on the face's forward axis
//! alone ([`lower_lip_depth`]): derived markers projecting the lip's middle marker and the jaw's
//! on that axis, one pair for every vertex.

use crate::mesh::distance;
use crate::surface::anchoring::smoothstep;
use crate::surface::corners::{self, RimEnds, CORNER_REACH};
use crate::surface::geometry::SurfaceGeometry;

/// How a marker's weight fades with a vertex's distance from its opening's rim along the skin,
/// in the opening's widths ([`Fade::keep`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fade {
    /// Within this the weight is kept whole.
    pub hold: f64,
    /// Here it is gone.
    pub reach: f64,
    /// Past `reach`, over how much of the width the weight returns to what it was.
    pub back: f64,
}

/// The eyes' lid markers, in the eye's width (measured in the module docs).
pub const LIDS: Fade = Fade {
    hold: 0.15,
    reach: 0.6,
    back: 1.2,
};

/// The upper lip's markers, in the mouth's width. Measured 2026-12-05 (session 18, `--test
/// structure`, `--test ict_facekit`; a scratch sweep), the face mean on FaceCap's truth with
/// the JawMoCap layout / ICT-FaceKit's with its placed layout (0.543 / 0.694 mm without):
///
/// | hold – reach | FaceCap | ICT-FaceKit | flipped triangles, worst frame |
/// |---|---|---|---|
/// | 0.25 – 0.55 | 0.524 | 0.699 | 1 (FaceCap's sliver, as without) |
/// | 0.3 – 0.6 / 1.0 | 0.522 / 0.518 | 0.694 / 0.683 | 1 |
/// | 0.35 – 0.85 | 0.519 | 0.684 | 1 |
/// | **0.4 – 0.9** | **0.519** | **0.683** | **1** |
/// | 0.4 – 0.55 / 0.7 / 1.1 | 0.522 / 0.520 / 0.521 | 0.692 / 0.686 / 0.682 | 2 / 1 / 1 |
/// | 0.45 – 0.95; 0.5 – 1.0 | 0.521; 0.522 | 0.682; 0.682 | 1 |
/// | 0.5 – 0.8; 0.6 – 0.9 | 0.521; 0.525 | 0.682; 0.683 | 8 (FaceCap's `blend 22`) |
///
/// The return past `reach` is the lids' (0.6 / 1.2 / 2.5 widths or none give the same means
/// within 0.0002 mm). No structure figure moves at the kept values, on either truth or on
/// JawMoCap.
pub const UPPER_LIP: Fade = Fade {
    hold: 0.4,
    reach: 0.9,
    back: 1.2,
};

impl Fade {
    /// The share of a marker's weight kept at `r` widths from the rim: 1 to `hold`, falling by
    /// a smoothstep to 0 at `reach`, rising by a smoothstep back to 1 over `back` past it.
    pub fn keep(&self, r: f64) -> f64 {
        let fade = smoothstep((r - self.hold) / (self.reach - self.hold));
        let back = smoothstep((r - self.reach) / self.back);
        1.0 - fade * (1.0 - back)
    }
}

/// A lid's marker, or the upper lip's, lies within this fraction of its opening's width of a
/// rim vertex.
pub const LID_REACH: f64 = 0.15;

/// What letting go did.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct LetGoFigures {
    /// The lid markers' names.
    pub lid_markers: Vec<String>,
    /// glTF vertices whose weights on them were reshaped.
    pub lid_vertices: usize,
    /// The upper lip's markers' names.
    pub lip_markers: Vec<String>,
    /// glTF vertices whose weights on them were reshaped.
    pub lip_vertices: usize,
    /// The lower lip's markers whose depth lets go ([`lower_lip_depth`]).
    pub depth_markers: Vec<String>,
    /// The jaw's markers that take it.
    pub jaw_markers: Vec<String>,
    /// glTF vertices with depth corrections.
    pub depth_vertices: usize,
}

/// The mouth, for [`reshape`].
#[derive(Clone, Copy, Debug)]
pub struct Mouth<'a> {
    /// Its opening, an index into the geometry's.
    pub opening: usize,
    /// The markers of its upper side (the mouth mask's upper group).
    pub upper: &'a [usize],
}

/// The markers of `rest` worn on `opening`'s rim: within [`LID_REACH`] of the rim's width of
/// a rim vertex, and not at either of its `ends` (those are `surface::corners`').
fn worn_on<'a>(
    opening: &'a crate::openings::Opening,
    welded_positions: &'a [[f64; 3]],
    rest: &'a [[f64; 3]],
    (ends, width): (&'a [[f64; 3]; 2], f64),
) -> impl Iterator<Item = usize> + 'a {
    let near_rim = move |p: &[f64; 3]| {
        opening
            .vertices
            .iter()
            .map(|&v| distance(&welded_positions[v as usize], p))
            .fold(f64::INFINITY, f64::min)
    };
    (0..rest.len())
        .filter(move |&m| near_rim(&rest[m]) <= LID_REACH * width)
        .filter(move |&m| {
            ends.iter()
                .all(|e| distance(e, &rest[m]) > CORNER_REACH * width)
        })
}

/// Fade the lid markers' weights in `dense` (per glTF vertex, its weights on the markers at
/// `rest`, named `names`) with the distance from their eye's rim, for every opening of
/// `geometry` but the `mouth`, and the upper lip's markers' with the distance from the mouth's
/// rim (see the module docs).
pub fn reshape(
    dense: &mut [Vec<f64>],
    geometry: &SurfaceGeometry,
    welded_positions: &[[f64; 3]],
    rest: &[[f64; 3]],
    names: &[&str],
    mouth: Option<Mouth<'_>>,
) -> LetGoFigures {
    let mut figures = LetGoFigures::default();
    let mut touched = [vec![false; dense.len()], vec![false; dense.len()]];
    let openings = geometry.openings.iter().zip(&geometry.opening_distance);
    for (index, (opening, from_rim)) in openings.enumerate() {
        let upper = mouth.filter(|m| m.opening == index).map(|m| m.upper);
        let Some(RimEnds { ends, width }) = RimEnds::of(opening, welded_positions) else {
            continue;
        };
        let worn: Vec<usize> = worn_on(opening, welded_positions, rest, (&ends, width))
            .filter(|m| upper.is_none_or(|upper| upper.contains(m)))
            .collect();
        let (fade, markers, touched) = match upper {
            None => (LIDS, &mut figures.lid_markers, &mut touched[0]),
            Some(_) => (UPPER_LIP, &mut figures.lip_markers, &mut touched[1]),
        };
        markers.extend(worn.iter().map(|&m| names[m].to_string()));
        for (v, weights) in dense.iter_mut().enumerate() {
            let keep = fade.keep(from_rim[geometry.weld[v] as usize] / width);
            if keep >= 1.0 {
                continue;
            }
            // What the worn markers free goes to the others, in proportion.
            let freed: f64 = worn
                .iter()
                .map(|&m| weights[m].max(0.0) * (1.0 - keep))
                .sum();
            let others: f64 = weights
                .iter()
                .enumerate()
                .filter(|&(o, &x)| !worn.contains(&o) && x > 0.0)
                .map(|(_, &x)| x)
                .sum();
            if freed <= 0.0 || others <= 0.0 {
                continue;
            }
            for (o, x) in weights.iter_mut().enumerate() {
                if worn.contains(&o) {
                    if *x > 0.0 {
                        *x *= keep;
                    }
                } else if *x > 0.0 {
                    *x += freed * *x / others;
                }
            }
            touched[v] = true;
        }
    }
    let count = |t: &[bool]| t.iter().filter(|&&t| t).count();
    figures.lid_vertices = count(&touched[0]);
    figures.lip_vertices = count(&touched[1]);
    figures
}

/// The lower lip's depth ([`lower_lip_depth`]): the share of the lower lip's markers' weight
/// that moves to the jaw's on the face's forward axis, from `hold` of the mouth's width from the
/// rim to all of it at `reach`, back to none over `back` past it.
pub const LOWER_LIP_DEPTH: Fade = Fade {
    hold: 0.2,
    reach: 0.8,
    back: 0.5,
};

/// A marker at least this share of the mouth's width below the rim's lowest point is the jaw's.
pub const JAW_BELOW: f64 = 0.3;

/// Over how much of the mouth's width above its jaw's markers a vertex's depth correction fades
/// in: below, the skin is the chin's underside and the throat's.
pub const ABOVE_JAW: f64 = 0.4;

/// Over how much of the mouth's width past the corners' vertical band ([`corners::BAND`]) the
/// depth corrections fade in. Inside the band a vertex takes no depth correction; starting at
/// full strength where the band's patchwork ends stretched FaceCap subdivided twice 2.14× (7
/// edges over 2×) in the jaw open, with the pair taken on top of K (the fade-in alone gives
/// main's one edge). Measured 2026-12-05 on that scaffold (`--test structure`, `--test
/// ict_facekit`, face mean on FaceCap's truth / ICT-FaceKit's): none 0.5067 / 0.6679 mm, **0.2**
/// 0.5074 / 0.6684, 0.3 0.5080 / 0.6690.
pub const DEPTH_FADE_IN: f64 = 0.2;

/// Over how much of the mouth's width past the corrections' far end (`reach + back` of
/// [`LOWER_LIP_DEPTH`]) the skin still gives way, so that its kept markers meet the corrected
/// skin's (which keeps two fewer) instead of jumping where the corrections end.
pub const DEPTH_RING_PAST: f64 = 0.3;

/// Where [`lower_lip_depth`] reads and writes, per glTF vertex.
pub struct Depth<'a> {
    /// The mouth's vertical corrections (`surface::corners`): a vertex with them takes none.
    pub vertical: &'a [Vec<(usize, f64)>],
    /// How far the vertex's two weakest kept markers give way (`surface::corners`): the depth
    /// correction fades in as the skin stops giving way to the vertical corrections, and the
    /// skin it corrects, or ends beside, gives way to it.
    pub give_way: &'a mut [f64],
    /// `(marker, Δ)` on the markers' forward axes, summing to zero.
    pub forward: &'a mut [Vec<(usize, f64)>],
}

/// The lower lip's depth corrections: for each glTF vertex below the `mouth`'s rim with no
/// vertical correction, the share of its weights on the lower lip's markers (the mouth's markers
/// within [`LID_REACH`] of the rim, not at its corners or in its upper group) that
/// [`LOWER_LIP_DEPTH`] frees moves, on the forward axis alone, from the lower lip's middle
/// marker to the jaw's ([`JAW_BELOW`]; of those as near the middle, the highest). One pair for
/// every vertex, so the correction varies with the weights and the distances alone: a pair from
/// each vertex's strongest markers jumped where the strongest changed. The pair takes two of a
/// vertex's K, so a corrected vertex gives way fully (the followed mean's share too) and the skin
/// past the far end over [`DEPTH_RING_PAST`]: the kept set does not jump where the corrections
/// begin or end (within the corners' band it gives way already). Returns the lower lip's and the
/// jaw's markers and the vertices corrected.
pub fn lower_lip_depth(
    dense: &[Vec<f64>],
    geometry: &SurfaceGeometry,
    welded_positions: &[[f64; 3]],
    rest: &[[f64; 3]],
    mouth: Mouth<'_>,
    depth: Depth<'_>,
) -> (Vec<usize>, Vec<usize>, usize) {
    let opening = &geometry.openings[mouth.opening];
    let from_rim = &geometry.opening_distance[mouth.opening];
    let Some(RimEnds { ends, width }) = RimEnds::of(opening, welded_positions) else {
        return (Vec::new(), Vec::new(), 0);
    };
    let heights = || {
        opening
            .vertices
            .iter()
            .map(|&v| welded_positions[v as usize][1])
    };
    let lowest = heights().fold(f64::INFINITY, f64::min);
    let centre = heights().sum::<f64>() / opening.vertices.len().max(1) as f64;
    let lip: Vec<usize> = worn_on(opening, welded_positions, rest, (&ends, width))
        .filter(|m| !mouth.upper.contains(m) && rest[*m][1] < centre)
        .collect();
    let jaw: Vec<usize> = (0..rest.len())
        .filter(|&m| rest[m][1] < lowest - JAW_BELOW * width)
        .collect();
    // The marker nearest the mouth's middle across the face, in steps of a tenth of its width
    // (a throat marker under the chin's is as near: the higher wins).
    let middle = (ends[0][0] + ends[1][0]) / 2.0;
    let off_middle = |m: usize| ((rest[m][0] - middle).abs() / (0.1 * width)).floor();
    let middle_marker = |among: &[usize]| {
        among.iter().copied().min_by(|&a, &b| {
            off_middle(a)
                .total_cmp(&off_middle(b))
                .then(rest[b][1].total_cmp(&rest[a][1]))
        })
    };
    let (Some(from), Some(to)) = (middle_marker(&lip), middle_marker(&jaw)) else {
        return (lip, jaw, 0);
    };
    let mut corrected = 0;
    for (v, weights) in dense.iter().enumerate() {
        let w = geometry.weld[v] as usize;
        if welded_positions[w][1] >= centre || depth.vertical.get(v).is_some_and(|c| !c.is_empty())
        {
            continue;
        }
        let r = from_rim[w] / width;
        let on_lip: f64 = lip.iter().map(|&m| weights[m].max(0.0)).sum();
        let on_jaw: f64 = jaw.iter().map(|&m| weights[m].max(0.0)).sum();
        if on_jaw <= 0.0 {
            continue;
        }
        // Only between the lip and the jaw's markers (at this vertex's weights' height on them):
        // under the chin the skin is the throat's.
        let height = jaw
            .iter()
            .map(|&m| weights[m].max(0.0) * rest[m][1])
            .sum::<f64>()
            / on_jaw;
        let above = (welded_positions[w][1] - height) / (ABOVE_JAW * width);
        // Fading in past the corners' band and as the skin stops giving way to its corrections.
        let fade_in =
            smoothstep((r - corners::BAND) / DEPTH_FADE_IN) * (1.0 - depth.give_way[v].min(1.0));
        let strength = (1.0 - LOWER_LIP_DEPTH.keep(r)) * smoothstep(above) * fade_in;
        if strength > 0.0 {
            depth.give_way[v] = 1.0;
            let freed = on_lip * strength;
            if freed > 0.0 {
                depth.forward[v] = vec![(from, -freed), (to, freed)];
                corrected += 1;
            }
        } else {
            // Past the far end the skin gives way over a ring. Not under the jaw's markers: a
            // ring there turned 89 triangles of ICT-FaceKit's chin over in its jaw open.
            let past = r - (LOWER_LIP_DEPTH.reach + LOWER_LIP_DEPTH.back);
            if past > 0.0 {
                let beside = smoothstep(1.0 - past / DEPTH_RING_PAST);
                depth.give_way[v] = depth.give_way[v].max(beside);
            }
        }
    }
    (lip, jaw, corrected)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geodesic::{GeodesicMethod, Source};

    /// Markers on `vertices` of `mesh`: its geometry, their rest positions and every vertex's
    /// inverse-square-distance weights on them.
    fn markers_on(
        mesh: &crate::model::FaceMesh,
        vertices: &[usize],
    ) -> (SurfaceGeometry, Vec<[f64; 3]>, Vec<Vec<f64>>) {
        let sources: Vec<Source> = vertices.iter().map(|&v| Source::Vertex(v as u32)).collect();
        let geometry = SurfaceGeometry::new(mesh, &sources, GeodesicMethod::EdgeDijkstra).unwrap();
        let rest: Vec<[f64; 3]> = vertices.iter().map(|&v| mesh.positions[v]).collect();
        let weights = mesh
            .positions
            .iter()
            .map(|p| {
                let raw: Vec<f64> = rest
                    .iter()
                    .map(|m| 1.0 / (distance(p, m).powi(2) + 1e-3))
                    .collect();
                let sum: f64 = raw.iter().sum();
                raw.iter().map(|r| r / sum).collect()
            })
            .collect();
        (geometry, rest, weights)
    }

    /// The width of `mesh`'s one opening.
    fn rim_width(geometry: &SurfaceGeometry, mesh: &crate::model::FaceMesh) -> f64 {
        RimEnds::of(&geometry.openings[0], &mesh.welded_positions)
            .expect("a rim")
            .width
    }

    /// `before` reshaped for `mouth` (every opening a pair of lids without one), its markers
    /// named `M0`, `M1`, …: the weights after and the figures.
    fn reshaped(
        mesh: &crate::model::FaceMesh,
        geometry: &SurfaceGeometry,
        rest: &[[f64; 3]],
        before: &[Vec<f64>],
        mouth: Option<Mouth<'_>>,
    ) -> (Vec<Vec<f64>>, LetGoFigures) {
        let names: Vec<String> = (0..rest.len()).map(|i| format!("M{i}")).collect();
        let names: Vec<&str> = names.iter().map(String::as_str).collect();
        let mut after = before.to_vec();
        let figures = reshape(
            &mut after,
            geometry,
            &mesh.welded_positions,
            rest,
            &names,
            mouth,
        );
        (after, figures)
    }

    #[test]
    fn the_kept_share_holds_fades_and_returns() {
        assert_eq!(LIDS.keep(0.0), 1.0);
        assert_eq!(LIDS.keep(LIDS.hold), 1.0);
        assert_eq!(LIDS.keep(LIDS.reach), 0.0);
        assert_eq!(LIDS.keep(LIDS.reach + LIDS.back), 1.0);
        assert_eq!(LIDS.keep(f64::INFINITY), 1.0);
        let at = |i: u32| LIDS.keep(f64::from(i) / 1000.0);
        let fall = (LIDS.hold * 1000.0) as u32..(LIDS.reach * 1000.0) as u32;
        assert!(fall.into_iter().all(|i| at(i + 1) <= at(i)));
        let rise = (LIDS.reach * 1000.0) as u32..((LIDS.reach + LIDS.back) * 1000.0) as u32;
        assert!(rise.into_iter().all(|i| at(i + 1) >= at(i)));
    }

    /// `surface::slit`'s eye-like slit (22 wide) with `surface::slit_markers`: at its corners,
    /// two on each lid and four far out; inverse-square-distance weights.
    #[test]
    fn lid_markers_let_go_of_the_skin_away_from_the_rim_and_nothing_else_changes() {
        let (mesh, vertices) = (crate::surface::slit(), crate::surface::slit_markers());
        let (geometry, rest, before) = markers_on(&mesh, &vertices);
        let (after, figures) = reshaped(&mesh, &geometry, &rest, &before, None);
        assert_eq!(figures.lid_markers, ["M2", "M3", "M4", "M5"]);
        assert!(figures.lid_vertices > 100, "{figures:?}");
        let width = rim_width(&geometry, &mesh);
        let mut faded = 0;
        for (v, (b, a)) in before.iter().zip(&after).enumerate() {
            assert!((b.iter().sum::<f64>() - a.iter().sum::<f64>()).abs() < 1e-12);
            let r = geometry.opening_distance[0][geometry.weld[v] as usize];
            if r / width <= LIDS.hold - 0.02 {
                assert_eq!(a, b, "vertex {v}");
                continue;
            }
            for m in 2..6 {
                assert!(
                    a[m] <= b[m] * LIDS.keep(r / width) + 1e-12,
                    "vertex {v} marker {m}"
                );
            }
            for m in [0, 1, 6, 7, 8, 9] {
                assert!(a[m] >= b[m], "vertex {v} marker {m}");
            }
            faded += usize::from(a[2] < 0.5 * b[2]);
        }
        assert!(faded > 50, "{faded}");
    }

    #[test]
    fn the_upper_lips_markers_let_go_past_the_lip_and_the_lower_lips_keep_their_reach() {
        // `surface::slit`'s slit (about 24 wide, as a mouth) in a sheet 30 high either side.
        let mesh = crate::surface::slit_in(30);
        // The corners, the upper lip, the lower lip, four far out.
        let at = crate::surface::slit_markers_in(30, 25);
        let (geometry, rest, before) = markers_on(&mesh, &at);
        // The mask's upper group holds a far marker too; only the lip's are worn on the rim.
        let upper = [2, 3, 6];
        let mouth = Mouth {
            opening: 0,
            upper: &upper,
        };
        let (after, figures) = reshaped(&mesh, &geometry, &rest, &before, Some(mouth));
        assert_eq!(figures.lip_markers, ["M2", "M3"]);
        assert!(figures.lid_markers.is_empty(), "{figures:?}");
        assert!(figures.lip_vertices > 100, "{figures:?}");
        let width = rim_width(&geometry, &mesh);
        let mut gone = 0;
        for (v, (b, a)) in before.iter().zip(&after).enumerate() {
            assert!((b.iter().sum::<f64>() - a.iter().sum::<f64>()).abs() < 1e-12);
            let r = geometry.opening_distance[0][geometry.weld[v] as usize] / width;
            if r <= UPPER_LIP.hold {
                assert_eq!(a, b, "vertex {v}");
                continue;
            }
            for m in [2, 3] {
                assert!(a[m] <= b[m] * UPPER_LIP.keep(r) + 1e-12, "vertex {v}");
            }
            // The lower lip's markers never let go; they and the others take what was freed.
            for m in [0, 1, 4, 5, 6, 7, 8, 9] {
                assert!(a[m] >= b[m], "vertex {v} marker {m}");
            }
            gone += usize::from(r >= UPPER_LIP.reach && a[2] < 0.01 * b[2]);
        }
        assert!(gone > 20, "{gone}");
    }

    #[test]
    fn the_lower_lips_depth_moves_to_the_jaw_past_the_lip_smoothly() {
        // `surface::slit`'s slit (about 24 wide, as a mouth) in a sheet 30 high either side:
        // the corners, the upper lip, the lower lip, two far above and two far below (the jaw).
        let mesh = crate::surface::slit_in(30);
        let at = crate::surface::slit_markers_in(30, 25);
        let (geometry, rest, weights) = markers_on(&mesh, &at);
        let n = mesh.positions.len();
        let (mut forward, mut give_way) = (vec![Vec::new(); n], vec![0.0; n]);
        // A vertex with a vertical correction takes no depth correction.
        let mut vertical = vec![Vec::new(); n];
        let held = (30 - 16) * 41 + 20;
        vertical[held] = vec![(0, 0.1), (4, -0.1)];
        let (lip, jaw, corrected) = lower_lip_depth(
            &weights,
            &geometry,
            &mesh.welded_positions,
            &rest,
            Mouth {
                opening: 0,
                upper: &[2, 3, 6],
            },
            Depth {
                vertical: &vertical,
                give_way: &mut give_way,
                forward: &mut forward,
            },
        );
        assert_eq!(
            (lip.as_slice(), jaw.as_slice()),
            ([4, 5].as_slice(), [8, 9].as_slice())
        );
        assert!(corrected > 100, "{corrected}");
        assert!(forward[held].is_empty());
        let width = rim_width(&geometry, &mesh);
        let mut pairs = std::collections::BTreeSet::new();
        let shift = |f: &[(usize, f64)]| f.last().map_or(0.0, |&(_, into)| into);
        for (v, f) in forward.iter().enumerate() {
            let p = mesh.positions[v];
            let r = geometry.opening_distance[0][geometry.weld[v] as usize] / width;
            if p[1] >= 0.0 || r <= corners::BAND {
                assert!(f.is_empty(), "vertex {v}: {f:?}");
                continue;
            }
            let [(from, out), (to, into)] = f.as_slice() else {
                continue;
            };
            // Its pair takes two of its K: its weakest kept markers give way.
            assert_eq!(give_way[v], 1.0, "vertex {v}");
            // From the lower lip's marker to the jaw's, summing to zero, at most the share of
            // the lip's weight that the fade frees.
            pairs.insert((*from, *to));
            assert!(
                (out + into).abs() < 1e-15 && *into > 0.0,
                "vertex {v}: {f:?}"
            );
            let on_lip: f64 = lip.iter().map(|&m| weights[v][m]).sum();
            let freed = on_lip * (1.0 - LOWER_LIP_DEPTH.keep(r));
            assert!(*into <= freed + 1e-12, "vertex {v}: {f:?} against {freed}");
        }
        // One pair everywhere (each vertex's strongest markers' pair jumped where they
        // changed), and no step between neighbours: on this sheet (a unit apart, the mouth 24
        // wide) the steepest fade, above the jaw over 0.4 widths, moves the shift by about a
        // sixth of its largest a unit; a correction starting at full strength, by all of it.
        assert_eq!(pairs.len(), 1, "{pairs:?}");
        let largest = forward.iter().map(|f| shift(f)).fold(0.0, f64::max);
        let step = mesh
            .triangles
            .iter()
            .flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])])
            .filter(|&(a, b)| a as usize != held && b as usize != held)
            .map(|(a, b)| (shift(&forward[a as usize]) - shift(&forward[b as usize])).abs())
            .fold(0.0, f64::max);
        assert!(step < 0.3 * largest, "{step} against {largest}");
    }
}
