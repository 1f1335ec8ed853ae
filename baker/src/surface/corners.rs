//! Opening corners: eyelids close and lips part the way a crack opens.
//!
//! An interpolation between the marker at a mouth corner and the next lip marker moves the lip
//! in proportion to the distance from the corner, so the lips stay nearly shut for a third of
//! the way in when the jaw drops. Real openings do not: near the end of a slit in an elastic
//! sheet the opening grows as the square root of the distance from the end (the crack-opening
//! displacement of linear elastic fracture mechanics, `u ∝ √r`), and FaceCap's own `jawOpen`
//! follows it along both lips (its lower lip's drop beyond the corner marker's, 1.4, 2.8, 6.4
//! and 10.9 mm across from it, is 0.34, 0.48, 0.76 and 1.0 of the next lip marker's;
//! √(r/10.9) gives 0.36, 0.51, 0.77, 1.0, and a straight line 0.13, 0.26, 0.59, 1.0).
//!
//! So the weights near each corner are reshaped ([`reshape`]): where a vertex's weight on the
//! corner's marker is `w` (about `1 − r/R` between the corner and the next marker along the
//! opening), it becomes `1 − √(1 − w)` (about `1 − √(r/R)`), and what it gives up goes to the
//! vertex's other markers, so the weights still sum to what they did. The reshaping is full on
//! the rim and fades out over a band of skin beside the opening ([`BAND`] of its width) and
//! towards the outside of either corner (skin past a corner is not part of either lid or lip),
//! so the field stays continuous.
//!
//! * **Eyes** (the upper lids; the lower lids too without vertical corrections, K < 6): the
//!   weights themselves are reshaped, the freed weight shared by the vertex's other markers in
//!   proportion. On FaceCap's truth with the JawMoCap layout the worst
//!   eyelid-closure error goes from 1.74 to 1.12 mm (the blink closes), with no new flipped
//!   triangle or stretched edge, and the figures do not move when the band is 0.2 to 0.5 of the
//!   width or the fade 0.05 to 0.15. The lids meet at an angle, so near the corner (the first
//!   [`EYE_TIP`] of the way to the next marker) the profile is straight: the square root there
//!   moved the closing lid past the other on a dense mesh.
//! * **Eyes' lower lids: the vertical axis only**, as at the mouth (below). A crack's √ profile
//!   is its opening, not a slide along it, and a lower lid slides: ICT-FaceKit's blink moves its
//!   lower lid 3.0 mm towards the nose in its middle (the marker) and 0.45 mm at its outer part,
//!   which whole weights moved 2.0 mm, so the lids sheared past each other (eyelids 1.55 mm off
//!   the truth; 1.3 mm with the vertical axis only, FaceCap's 0.9 mm unchanged, measured
//!   2026-12-05, `--test ict_facekit`, `--test structure`). The upper lid keeps whole weights:
//!   it closes over the eyeball, in depth too, and its vertical alone stretched 1.76 mm edges
//!   above ICT's lids 2.30× in the blink and turned 2 triangles at FaceCap's inner corners
//!   (subdivided twice). The lower lid is the skin below the line between the eye's corners.
//! * **Mouth: the vertical axis only.** The mouth's corners slide sideways against the lips
//!   (inwards when the jaw drops or the lips funnel, while the lip markers move out), so
//!   reshaping whole weights there folds the corner's triangles (55 flips over the truth) as
//!   lip vertices near a corner take the lip markers' sideways motion across the corner's. The
//!   freed weight moves instead between the corner marker's and the vertex's strongest other
//!   marker's *vertical* displacement ([`Corrections::vertical`], baked as derived markers of the
//!   linear section that keep one axis), for [`MOUTH_SHARE`] of the square-root profile and
//!   over the corner's half of the mouth (fading out over [`MIDDLE_FADE`] of the width before
//!   the middle, so that a vertex takes one corner's correction, one influence pair of its K).
//!   On the truth the worst lip-aperture error goes from 12.5 to 6.8 mm with no new flipped
//!   triangle or stretched edge, on the truth or on JawMoCap.
//!
//! * **Past the mouth's corners** the skin belongs to neither lip; its weights on the upper and
//!   lower lips' markers are balanced ([`balance_past_mouth_corners`]), so a dropping jaw does not
//!   tear the mouth line's extension.
//!
//! Corners are a rim's two ends across the face (x, the glTF convention the metrics use too);
//! a corner's marker is the marker nearest the rim's end, when it is within [`CORNER_REACH`] of
//! the opening's width. An opening without a marker at a corner is left as it is there.

use crate::mesh::x_extremes;
use crate::openings::Opening;
use crate::surface::anchoring::smoothstep;
use crate::surface::geometry::SurfaceGeometry;

/// A corner's marker is at most this fraction of the opening's width from the rim's end.
pub const CORNER_REACH: f64 = 0.2;
/// Width of the skin band beside an opening that is reshaped (fading to nothing at its edge),
/// as a fraction of the opening's width.
pub const BAND: f64 = 0.3;
/// Distance inwards from a corner, as a fraction of the opening's width, over which the
/// reshaping fades in (it is nothing past the corner): at the mouth linearly, at the eyes by a
/// smoothstep. The mouth's vertical correction is steepest within this fade, and a finer mesh
/// samples its steepest part: under a smoothstep, FaceCap subdivided once stretched a 0.88 mm
/// lower-lip edge 1.4 mm in from each corner 2.25× in the funnel (10 edges over 2×), twice
/// subdivided 2.38× (37), the coarse mesh 1.92×. Linearly (measured 2026-12-03, `--test
/// structure`): once 1.99× (none over 2×; the smile's 0.29 mm edge), twice 2.16× (5, beside the
/// jaw in `blend 22`), JawMoCap 1.92× → 1.90×, the coarse truth 1.92× → 1.89×, its worst lip pair
/// 6.8 → 7.1 mm (the denser meshes' 7.0 → 6.7 and 6.9 → 6.6), face mean and lip band unchanged.
/// A wider fade opens the lips less (0.08: truth 8.7 mm), a narrower one tears JawMoCap (0.04:
/// 2.03×, 0.03: 2.28×), a square-root ramp the twice-subdivided face (2.82×, 10 flips).
pub const FADE_IN: f64 = 0.05;

/// What the corner reshaping did.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct CornerFigures {
    /// Corners with a marker, of the openings' corners.
    pub corners: usize,
    /// The corner markers' names.
    pub markers: Vec<String>,
    /// glTF vertices whose weights were reshaped.
    pub reshaped_vertices: usize,
    /// glTF vertices past the mouth's corners whose upper and lower weights were balanced
    /// ([`balance_past_mouth_corners`]).
    pub balanced_vertices: usize,
}

pub use crate::options::MOUTH_SHARE;

/// The shares a bake with a capture tries, in order, until the capture plays through the rig
/// without tearing where the linear profile does not (`bake::mouth_share`).
pub const MOUTH_SHARES: [f64; 4] = [MOUTH_SHARE, 0.5, 0.35, 0.0];

/// The vertical corrections (the mouth's and the lower lids') need K of at least this (they take
/// one influence pair).
pub const VERTICAL_MIN_K: usize = 6;

/// The share of an opening's width from its middle over which a corner's vertical correction
/// fades out (a vertex takes one corner's).
pub const MIDDLE_FADE: f64 = 0.2;

/// Width of the ring round the vertical corrections, as a fraction of the opening's width, over
/// which the skin's weakest kept markers give way to them ([`Corrections::give_way`]). On
/// FaceCap's truth with the JawMoCap layout (`--test structure`, `--test surface`): without
/// the ring, 1.98× and lip band p99 4.24 mm, 2.72× (49 edges) twice subdivided; with it,
/// 1.93× and 2.37× (37) for rings of 0.05 to 0.3, lip band p99 4.24 / **4.20** / 4.27 /
/// 4.25 mm at 0.05 / **0.1** / 0.2 / 0.3.
pub const RING: f64 = 0.1;

/// The mouth.
pub struct Mouth {
    /// The mouth's opening, an index into the geometry's.
    pub opening: usize,
    /// The share of the square-root profile taken ([`MOUTH_SHARE`] by default).
    pub share: f64,
}

/// The vertical corrections (the mouth's and the eyes' lower lids'), one entry per glTF vertex.
pub struct Corrections<'a> {
    /// `(marker, Δ)` on the markers' vertical axes, summing to zero (empty where there is none).
    pub vertical: &'a mut [Vec<(usize, f64)>],
    /// How far the vertex's two weakest kept markers (as many as the corrections take) give
    /// way to the corrections: 1 over the skin where they may be, fading to 0 over [`RING`]
    /// outside, so the kept set does not jump where the corrections begin.
    pub give_way: &'a mut [f64],
}

/// The markers of a reshaping: their rest positions and names.
pub struct CornerMarkers<'a> {
    /// Rest positions, asset units.
    pub rest: &'a [[f64; 3]],
    /// Names, in the same order.
    pub names: &'a [&'a str],
}

/// Reshape `dense` (per glTF vertex at `positions`, in the face's axes, y up: its weights on
/// the markers) near every corner of `geometry`'s openings that has a marker (see the module
/// docs). The `mouth` is left alone without `vertical` corrections to take its reshaping; an
/// eye's lower lid then takes whole weights as its upper lid does.
pub fn reshape(
    dense: &mut [Vec<f64>],
    geometry: &SurfaceGeometry,
    welded_positions: &[[f64; 3]],
    positions: &[[f64; 3]],
    markers: &CornerMarkers<'_>,
    mouth: Option<Mouth>,
    mut vertical: Option<Corrections<'_>>,
) -> CornerFigures {
    let rest = markers.rest;
    let mut figures = CornerFigures::default();
    let mut touched = vec![false; dense.len()];
    let (mouth, mouth_share) = mouth.map_or((None, MOUTH_SHARE), |m| (Some(m.opening), m.share));
    let openings = geometry.openings.iter().zip(&geometry.opening_distance);
    for (index, (opening, from_rim)) in openings.enumerate() {
        let at_mouth = Some(index) == mouth;
        if at_mouth && vertical.is_none() {
            continue;
        }
        let Some(rim) = RimEnds::of(opening, welded_positions) else {
            continue;
        };
        let width = rim.width;
        for (corner, axis) in rim.corners() {
            let Some(marker) = rim.corner_marker(&corner, rest) else {
                continue;
            };
            figures.corners += 1;
            figures.markers.push(markers.names[marker].to_string());
            let other = rim.ends[usize::from(corner == rim.ends[0])];
            for (v, weights) in dense.iter_mut().enumerate() {
                let welded = geometry.weld[v] as usize;
                let band = smoothstep(1.0 - from_rim[welded] / (BAND * width));
                let along = rim.along(&positions[v], &corner, &axis);
                // The mouth moves on the vertical alone, and so does an eye's lower lid: the
                // skin below the line between its corners.
                let corners_line = corner[1] + along.clamp(0.0, 1.0) * (other[1] - corner[1]);
                let split = vertical.is_some() && (at_mouth || positions[v][1] < corners_line);
                // Nothing past this corner or past the other one; where the vertical moves
                // alone, nothing past the middle either (one corner's correction a vertex).
                let far = if split {
                    smoothstep((0.5 - along) / MIDDLE_FADE)
                } else {
                    smoothstep((1.0 - along) / FADE_IN)
                };
                if let (true, Some(c)) = (split, vertical.as_mut()) {
                    // Where the corrections may be (band, along and far all positive) this is 1.
                    let ring = |outside: f64| smoothstep(1.0 - outside / RING);
                    let beside =
                        ring(from_rim[welded] / width - BAND) * ring(-along) * ring(along - 0.5);
                    c.give_way[v] = c.give_way[v].max(beside);
                }
                let share = if at_mouth { mouth_share } else { 1.0 };
                // The mouth's correction fades in linearly from each corner: a smoothstep's
                // middle is 1.5 times as steep, and finer meshes sample it (see `FADE_IN`).
                let fade_in = if at_mouth {
                    (along / FADE_IN).clamp(0.0, 1.0)
                } else {
                    smoothstep(along / FADE_IN)
                };
                let strength = share * band * fade_in * far;
                let w = weights[marker];
                if strength <= 0.0 || w <= 0.0 || w >= 1.0 {
                    continue;
                }
                // A mouth opens like a crack; an eye's corner is a wedge near its tip.
                let tip = if at_mouth { 0.0 } else { EYE_TIP };
                let shaped = w + strength * ((1.0 - profile(1.0 - w, tip)) - w);
                let freed = w - shaped;
                if split {
                    // The vertical axis only: the freed weight moves from the corner's vertical
                    // to the vertex's strongest other marker's.
                    let partner = strongest_other(weights, marker);
                    if let (Some(c), Some(partner)) = (vertical.as_mut(), partner) {
                        c.vertical[v] = vec![(marker, -freed), (partner, freed)];
                        touched[v] = true;
                    }
                } else if give_to_others(weights, marker, freed) {
                    weights[marker] = shaped;
                    touched[v] = true;
                }
            }
        }
    }
    figures.reshaped_vertices = touched.iter().filter(|&&t| t).count();
    figures
}

/// Past a corner of the mouth the skin belongs to neither lip, but a surface interpolation
/// still gives the skin just below the mouth line's extension more of the lower lip's markers
/// and the skin just above more of the upper's: when the jaw drops 40 mm, a 1 mm edge there
/// stretched 2.03× on JawMoCap (in 80 of its 1590 frames). So within `reach` of each corner
/// ([`crate::PAST_CORNER_REACH`] × the mean marker spacing by default), and past it (fading in
/// over [`FADE_IN`] of the mouth's width as the reshaping fades out), a vertex's total weight on the `upper` markers and on the `lower`
/// ones are made equal, each the mean of the two, scaling the markers within each side alike;
/// the weights still sum to what they did. JawMoCap then stretched no edge past 2× (1.97×, the
/// default of the time); Euclidean distances take the wider
/// [`crate::PAST_CORNER_REACH_EUCLIDEAN`]. Returns the vertices changed.
pub fn balance_past_mouth_corners(
    dense: &mut [Vec<f64>],
    opening: &Opening,
    welded_positions: &[[f64; 3]],
    positions: &[[f64; 3]],
    (upper, lower): (&[usize], &[usize]),
    reach: f64,
) -> usize {
    let rim = match RimEnds::of(opening, welded_positions) {
        Some(rim) if !upper.is_empty() && !lower.is_empty() && reach > 0.0 => rim,
        _ => return 0,
    };
    let mut changed = 0;
    for (corner, axis) in rim.corners() {
        for (weights, p) in dense.iter_mut().zip(positions) {
            let along = rim.along(p, &corner, &axis);
            let near = crate::mesh::distance(p, &corner);
            let strength = smoothstep(-along / FADE_IN) * smoothstep(1.0 - near / reach);
            let total = |side: &[usize]| side.iter().map(|&m| weights[m]).sum::<f64>();
            let (u, l) = (total(upper), total(lower));
            if strength <= 0.0 || u <= 0.0 || l <= 0.0 {
                continue;
            }
            let mean = 0.5 * (u + l);
            for (side, sum) in [(upper, u), (lower, l)] {
                let scale = 1.0 + strength * (mean / sum - 1.0);
                for &m in side {
                    weights[m] *= scale;
                }
            }
            changed += 1;
        }
    }
    changed
}

/// An opening's two ends across the face (its rim's x extremes) and its width, measured once
/// for the reshaping and the balance past the mouth's corners.
pub(crate) struct RimEnds {
    /// The rim's two ends across the face (its lowest and highest x).
    pub(crate) ends: [[f64; 3]; 2],
    /// The distance between them.
    pub(crate) width: f64,
}

impl RimEnds {
    /// The ends of `opening` on the welded mesh; `None` for an empty or zero-width rim.
    pub(crate) fn of(opening: &Opening, welded_positions: &[[f64; 3]]) -> Option<Self> {
        if opening.vertices.is_empty() {
            return None;
        }
        let (low, high) = x_extremes(&opening.vertices, welded_positions);
        let ends = [low, high].map(|i| welded_positions[opening.vertices[i] as usize]);
        let width = crate::mesh::distance(&ends[0], &ends[1]);
        (width > 0.0).then_some(Self { ends, width })
    }

    /// The marker of `rest` nearest `end` (one of [`RimEnds::ends`]), if it is within
    /// [`CORNER_REACH`] of the width: that corner's marker.
    pub(crate) fn corner_marker(&self, end: &[f64; 3], rest: &[[f64; 3]]) -> Option<usize> {
        rest.iter()
            .map(|m| crate::mesh::distance(m, end))
            .enumerate()
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .filter(|&(_, d)| d <= CORNER_REACH * self.width)
            .map(|(i, _)| i)
    }

    /// Each end with the direction to the other one.
    fn corners(&self) -> [([f64; 3], [f64; 3]); 2] {
        let [low, high] = self.ends;
        [
            (low, crate::mesh::sub(&high, &low)),
            (high, crate::mesh::sub(&low, &high)),
        ]
    }

    /// How far `p` is from `corner` towards the other end along `axis`, in widths (0 at the
    /// corner, 1 at the other end, negative past the corner).
    fn along(&self, p: &[f64; 3], corner: &[f64; 3], axis: &[f64; 3]) -> f64 {
        crate::mesh::dot(&crate::mesh::sub(p, corner), axis) / (self.width * self.width)
    }
}

/// At an eye's corner, the share of the way from the corner's marker to the next marker (by
/// the corner marker's weight) over which the profile is straight rather than a square root
/// (`profile`). On FaceCap subdivided twice (`--test structure`), the blinks fold the last
/// 1.3–4 mm before the inner corners (14 flipped triangles in `blink`): the lids meet there at
/// an angle, so the gap between them closes in proportion to the distance, faster than the
/// square root moves the closing lid. Flips in the blinks at 0 / 0.1 / 0.2 / 0.25 / **0.3 to
/// 0.5**: 14 / 14 / 13 / 6 / **0**; the truth's eyelid closure stays 0.91 mm to 0.5 (1.2 mm at
/// 0.7, 1.6 mm straight throughout), and the twice-subdivided head's passes 0.8 mm past 0.4.
pub const EYE_TIP: f64 = 0.35;

/// How far a point moves with the next marker rather than the corner's, for `x` = 1 − the
/// corner marker's weight: `√x`, straight (and continuous with it) under `tip`.
fn profile(x: f64, tip: f64) -> f64 {
    if x >= tip {
        x.sqrt()
    } else {
        x / tip.sqrt()
    }
}

/// The marker other than `marker` with the largest weight.
fn strongest_other(weights: &[f64], marker: usize) -> Option<usize> {
    weights
        .iter()
        .enumerate()
        .filter(|&(m, _)| m != marker)
        .max_by(|a, b| a.1.total_cmp(b.1))
        .map(|(m, _)| m)
}

/// Share `freed` among the positive weights other than `marker`'s, in proportion to them;
/// false (and nothing changed) when there are none.
fn give_to_others(weights: &mut [f64], marker: usize, freed: f64) -> bool {
    let others: f64 = weights
        .iter()
        .enumerate()
        .filter(|&(m, &x)| m != marker && x > 0.0)
        .map(|(_, &x)| x)
        .sum();
    if others <= 0.0 {
        return false;
    }
    for (m, x) in weights.iter_mut().enumerate() {
        if m != marker && *x > 0.0 {
            *x += freed * *x / others;
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geodesic::{GeodesicMethod, Source};
    use crate::model::FaceMesh;

    #[test]
    fn the_profile_is_a_square_root_with_a_straight_tip() {
        assert_eq!(profile(0.49, 0.0), 0.7);
        assert_eq!(profile(0.49, EYE_TIP), 0.7);
        // Straight under the tip, meeting the root there, and never above it.
        assert!((profile(EYE_TIP - 1e-12, EYE_TIP) - EYE_TIP.sqrt()).abs() < 1e-9);
        assert!((profile(0.1, EYE_TIP) - 0.1 / EYE_TIP.sqrt()).abs() < 1e-15);
        assert!((profile(0.05, EYE_TIP) * 2.0 - profile(0.1, EYE_TIP)).abs() < 1e-15);
        assert!((1..100).all(
            |i| profile(f64::from(i) / 100.0, EYE_TIP) <= (f64::from(i) / 100.0).sqrt() + 1e-15
        ));
        assert_eq!(profile(0.0, EYE_TIP), 0.0);
    }

    /// [`crate::surface::slit`]'s eye-like slit and its markers
    /// ([`crate::surface::slit_markers`]).
    fn eye() -> (FaceMesh, Vec<usize>) {
        (crate::surface::slit(), crate::surface::slit_markers())
    }

    /// The slit, its geometry with the markers as sources, their rest positions and names.
    fn eye_with_markers() -> (FaceMesh, SurfaceGeometry, Vec<[f64; 3]>, Vec<String>) {
        let (mesh, vertices) = eye();
        let sources: Vec<Source> = vertices.iter().map(|&v| Source::Vertex(v as u32)).collect();
        let geometry = SurfaceGeometry::new(&mesh, &sources, GeodesicMethod::EdgeDijkstra).unwrap();
        let rest: Vec<[f64; 3]> = vertices.iter().map(|&v| mesh.positions[v]).collect();
        let names = (0..rest.len()).map(|i| format!("M{i}")).collect();
        (mesh, geometry, rest, names)
    }

    /// Inverse-square-distance weights on the markers, summing to one.
    fn weights(p: &[[f64; 3]], rest: &[[f64; 3]]) -> Vec<Vec<f64>> {
        p.iter()
            .map(|v| {
                let raw: Vec<f64> = rest
                    .iter()
                    .map(|m| 1.0 / (crate::mesh::distance(v, m).powi(2) + 1e-3))
                    .collect();
                let sum: f64 = raw.iter().sum();
                raw.iter().map(|r| r / sum).collect()
            })
            .collect()
    }

    #[test]
    fn lids_near_a_corner_take_the_square_root_profile_and_nothing_else_moves() {
        let (mesh, geometry, rest, names) = eye_with_markers();
        assert_eq!(geometry.openings.len(), 1);
        let names: Vec<&str> = names.iter().map(String::as_str).collect();
        let markers = CornerMarkers {
            rest: &rest,
            names: &names,
        };
        let before = weights(&mesh.positions, &rest);
        let mut after = before.clone();
        let figures = reshape(
            &mut after,
            &geometry,
            &mesh.welded_positions,
            &mesh.positions,
            &markers,
            None,
            None,
        );
        assert_eq!(
            (figures.corners, figures.markers.clone()),
            (2, vec!["M0".to_string(), "M1".to_string()])
        );
        assert!(figures.reshaped_vertices > 0);
        let rim: Vec<u32> = geometry.openings[0].vertices.clone();
        let mut checked = 0;
        for (v, (b, a)) in before.iter().zip(&after).enumerate() {
            // Every vertex's weights sum to what they did.
            assert!((b.iter().sum::<f64>() - a.iter().sum::<f64>()).abs() < 1e-12);
            let p = mesh.positions[v];
            // Past the corners and beyond the band, nothing changes.
            if p[0].abs() > 13.0 || p[1].abs() > BAND * 24.0 + 1.0 {
                assert_eq!(a, b, "vertex {v} at {p:?}");
            }
            // On the rim, well inside a corner: the corner weight is 1 − √(1 − w) (plus its
            // share of what the other corner gave up, a little).
            if rim.contains(&(v as u32)) && (6.0..10.0).contains(&p[0].abs()) {
                let corner = if p[0] < 0.0 { 0 } else { 1 };
                let w = b[corner];
                let target = 1.0 - (1.0 - w).sqrt();
                assert!(
                    (a[corner] - target).abs() < 0.01 * w,
                    "vertex {v}: {w} → {}, not {target}",
                    a[corner]
                );
                assert!(a[corner] < w);
                checked += 1;
            }
        }
        assert!(checked >= 4, "{checked} rim vertices checked");
        // The mouth is left alone.
        let mut mouth = before.clone();
        let figures = reshape(
            &mut mouth,
            &geometry,
            &mesh.welded_positions,
            &mesh.positions,
            &markers,
            Some(Mouth {
                opening: 0,
                share: MOUTH_SHARE,
            }),
            None,
        );
        assert_eq!((figures.corners, mouth), (0, before));
    }

    #[test]
    fn an_eyes_lower_lid_takes_the_profile_on_the_vertical_alone() {
        let (mesh, geometry, rest, names) = eye_with_markers();
        let names: Vec<&str> = names.iter().map(String::as_str).collect();
        let markers = CornerMarkers {
            rest: &rest,
            names: &names,
        };
        let before = weights(&mesh.positions, &rest);
        let mut whole = before.clone();
        let args = (&geometry, &mesh.welded_positions, &mesh.positions, &markers);
        reshape(&mut whole, args.0, args.1, args.2, args.3, None, None);
        let mut after = before.clone();
        let mut vertical = vec![Vec::new(); before.len()];
        let mut give_way = vec![0.0; before.len()];
        let corrections = Corrections {
            vertical: &mut vertical,
            give_way: &mut give_way,
        };
        reshape(
            &mut after,
            args.0,
            args.1,
            args.2,
            args.3,
            None,
            Some(corrections),
        );
        let (mut lower, mut upper) = (0, 0);
        for (v, p) in mesh.positions.iter().enumerate() {
            // The slit's corners are at y = 0.
            if p[1] < -1e-9 {
                // Below: whole weights kept; what the profile moves, on the vertical alone,
                // from the nearer corner's marker to one other, summing to zero.
                assert_eq!(after[v], before[v], "vertex {v}");
                if let [(from, d), (to, e)] = vertical[v][..] {
                    assert!(from < 2 && to != from && d < 0.0 && (d + e).abs() < 1e-15);
                    if p[0].abs() > 1.0 {
                        assert_eq!(from, usize::from(p[0] > 0.0), "vertex {v} at {p:?}");
                    }
                    lower += 1;
                }
            } else if p[1] > 1e-9 {
                // Above: whole weights, as without corrections (each vertex from both corners).
                assert_eq!(after[v], whole[v], "vertex {v}");
                assert!(vertical[v].is_empty());
                upper += usize::from(after[v] != before[v]);
            }
        }
        assert!(lower >= 4 && upper >= 4, "{lower} below, {upper} above");
    }

    #[test]
    fn skin_past_a_mouth_corner_is_balanced_between_the_lips_and_nothing_else_moves() {
        let (mesh, vertices) = eye();
        let sources: Vec<Source> = vertices.iter().map(|&v| Source::Vertex(v as u32)).collect();
        let geometry = SurfaceGeometry::new(&mesh, &sources, GeodesicMethod::EdgeDijkstra).unwrap();
        let rest: Vec<[f64; 3]> = vertices.iter().map(|&v| mesh.positions[v]).collect();
        let before = weights(&mesh.positions, &rest);
        let mut after = before.clone();
        // The markers on the upper lid (2, 3) and on the lower (4, 5); spacing 10.
        let (upper, lower) = ([2, 3], [4, 5]);
        let changed = balance_past_mouth_corners(
            &mut after,
            &geometry.openings[0],
            &mesh.welded_positions,
            &mesh.positions,
            (&upper, &lower),
            crate::PAST_CORNER_REACH * 10.0,
        );
        assert!(changed > 0);
        let side = |w: &[f64], s: &[usize]| s.iter().map(|&m| w[m]).sum::<f64>();
        let mut balanced = 0;
        for (v, (b, a)) in before.iter().zip(&after).enumerate() {
            assert!((b.iter().sum::<f64>() - a.iter().sum::<f64>()).abs() < 1e-12);
            let p = mesh.positions[v];
            let from_corner = ((p[0].abs() - 11.0).powi(2) + p[1] * p[1]).sqrt();
            // Inside the slit's span and beyond the reach (3, from a rim end that may be any
            // of the three vertices at x = ±11) nothing changes.
            if p[0].abs() <= 10.0 || from_corner >= 4.0 {
                assert_eq!(a, b, "vertex {v} at {p:?}");
            }
            // Past a corner and near it, the lids' totals move towards their mean (fully at the
            // corner, fading with the distance from it), their sum kept.
            if p[0].abs() >= 12.0 && from_corner <= 2.5 {
                let (u, l) = (side(a, &upper), side(a, &lower));
                let (u0, l0) = (side(b, &upper), side(b, &lower));
                assert!((u + l - u0 - l0).abs() < 1e-12);
                assert!((u - l).abs() <= (u0 - l0).abs(), "vertex {v} at {p:?}");
                balanced += usize::from((u - l).abs() < 0.5 * (u0 - l0).abs());
            }
        }
        assert!(balanced >= 4, "{balanced}");
    }
}
