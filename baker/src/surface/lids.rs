//! Eyelids: a lid marker moves its lid, not the skin past the lid's fold.
//!
//! A blink moves the upper lid's margin 9 mm while the skin a centimetre above it, past the
//! lid's crease, stays where it is (on FaceCap's truth 0.1–0.5 mm at 8–16 mm above the rim, on
//! ICT-FaceKit's 1–2 mm). An interpolation between the lid's marker, on the margin, and the
//! brow's, 2 cm above, moves that skin in proportion to the distance instead: 5–7 mm, so the
//! closed lid dragged the skin under the brow down with it and the lid kept its crease.
//!
//! So a lid marker's weight fades with the vertex's distance from the eye's rim along the skin
//! ([`reshape`], [`keep`]): whole within [`HOLD`] of the eye's width, nothing at [`REACH`], a
//! smoothstep between; what it gives up goes to the vertex's other markers in proportion (the
//! brow's, the eye's corners', the cheek's), so the weights still sum to what they did and the
//! skin past the fold follows them. The rim and the marker's own spot keep their weights, so
//! the lids still close. Past [`REACH`] the weights come back to what they were over
//! [`RETURN`] of the width: a lid marker's far field is small, and handing it to other markers
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

use crate::mesh::distance;
use crate::surface::anchoring::smoothstep;
use crate::surface::corners::{RimEnds, CORNER_REACH};
use crate::surface::geometry::SurfaceGeometry;

/// Distance from the rim, as a fraction of the eye's width, within which a lid marker's weight
/// is kept whole.
pub const HOLD: f64 = 0.15;

/// Distance from the rim, as a fraction of the eye's width, at which a lid marker's weight is
/// gone.
pub const REACH: f64 = 0.6;

/// Past [`REACH`], over how much of the eye's width the weights return to what they were.
pub const RETURN: f64 = 1.2;

/// A lid marker lies within this fraction of the eye's width of a rim vertex.
pub const LID_REACH: f64 = 0.15;

/// What the lids' reshaping did.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct LidFigures {
    /// The lid markers' names.
    pub markers: Vec<String>,
    /// glTF vertices whose weights were reshaped.
    pub reshaped_vertices: usize,
}

/// Fade the lid markers' weights in `dense` (per glTF vertex, its weights on the markers at
/// `rest`, named `names`) with the distance from their eye's rim, for every opening of
/// `geometry` but the `mouth` (see the module docs).
pub fn reshape(
    dense: &mut [Vec<f64>],
    geometry: &SurfaceGeometry,
    welded_positions: &[[f64; 3]],
    rest: &[[f64; 3]],
    names: &[&str],
    mouth: Option<usize>,
) -> LidFigures {
    let mut figures = LidFigures::default();
    let mut touched = vec![false; dense.len()];
    let openings = geometry.openings.iter().zip(&geometry.opening_distance);
    for (index, (opening, from_rim)) in openings.enumerate() {
        if Some(index) == mouth {
            continue;
        }
        let Some(RimEnds { ends, width }) = RimEnds::of(opening, welded_positions) else {
            continue;
        };
        let near_rim = |p: &[f64; 3]| {
            opening
                .vertices
                .iter()
                .map(|&v| distance(&welded_positions[v as usize], p))
                .fold(f64::INFINITY, f64::min)
        };
        let lids: Vec<usize> = (0..rest.len())
            .filter(|&m| near_rim(&rest[m]) <= LID_REACH * width)
            .filter(|&m| {
                ends.iter()
                    .all(|e| distance(e, &rest[m]) > CORNER_REACH * width)
            })
            .collect();
        for &m in &lids {
            figures.markers.push(names[m].to_string());
        }
        for (v, weights) in dense.iter_mut().enumerate() {
            let keep = keep(from_rim[geometry.weld[v] as usize] / width);
            if keep >= 1.0 {
                continue;
            }
            // What the lid markers free goes to the others, in proportion.
            let freed: f64 = lids
                .iter()
                .map(|&m| weights[m].max(0.0) * (1.0 - keep))
                .sum();
            let others: f64 = weights
                .iter()
                .enumerate()
                .filter(|&(o, &x)| !lids.contains(&o) && x > 0.0)
                .map(|(_, &x)| x)
                .sum();
            if freed <= 0.0 || others <= 0.0 {
                continue;
            }
            for (o, x) in weights.iter_mut().enumerate() {
                if lids.contains(&o) {
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
    figures.reshaped_vertices = touched.iter().filter(|&&t| t).count();
    figures
}

/// The share of a lid marker's weight kept at `r` eye widths from the rim: 1 to [`HOLD`],
/// falling by a smoothstep to 0 at [`REACH`], rising by a smoothstep back to 1 over
/// [`RETURN`] past it.
pub fn keep(r: f64) -> f64 {
    let fade = smoothstep((r - HOLD) / (REACH - HOLD));
    let back = smoothstep((r - REACH) / RETURN);
    1.0 - fade * (1.0 - back)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geodesic::{GeodesicMethod, Source};

    #[test]
    fn the_kept_share_holds_fades_and_returns() {
        assert_eq!(keep(0.0), 1.0);
        assert_eq!(keep(HOLD), 1.0);
        assert_eq!(keep(REACH), 0.0);
        assert_eq!(keep(REACH + RETURN), 1.0);
        assert_eq!(keep(f64::INFINITY), 1.0);
        let at = |i: u32| keep(f64::from(i) / 1000.0);
        let fall = (HOLD * 1000.0) as u32..(REACH * 1000.0) as u32;
        assert!(fall.into_iter().all(|i| at(i + 1) <= at(i)));
        let rise = (REACH * 1000.0) as u32..((REACH + RETURN) * 1000.0) as u32;
        assert!(rise.into_iter().all(|i| at(i + 1) >= at(i)));
    }

    /// `surface::slit`'s eye-like slit (22 wide) with `surface::slit_markers`: at its corners,
    /// two on each lid and four far out; inverse-square-distance weights.
    #[test]
    fn lid_markers_let_go_of_the_skin_away_from_the_rim_and_nothing_else_changes() {
        let (mesh, vertices) = (crate::surface::slit(), crate::surface::slit_markers());
        let sources: Vec<Source> = vertices.iter().map(|&v| Source::Vertex(v as u32)).collect();
        let geometry = SurfaceGeometry::new(&mesh, &sources, GeodesicMethod::EdgeDijkstra).unwrap();
        let rest: Vec<[f64; 3]> = vertices.iter().map(|&v| mesh.positions[v]).collect();
        let names: Vec<String> = (0..rest.len()).map(|i| format!("M{i}")).collect();
        let names: Vec<&str> = names.iter().map(String::as_str).collect();
        let before: Vec<Vec<f64>> = mesh
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
        let mut after = before.clone();
        let figures = reshape(
            &mut after,
            &geometry,
            &mesh.welded_positions,
            &rest,
            &names,
            None,
        );
        assert_eq!(figures.markers, ["M2", "M3", "M4", "M5"]);
        assert!(figures.reshaped_vertices > 100, "{figures:?}");
        let width = RimEnds::of(&geometry.openings[0], &mesh.welded_positions)
            .expect("a rim")
            .width;
        let mut faded = 0;
        for (v, (b, a)) in before.iter().zip(&after).enumerate() {
            assert!((b.iter().sum::<f64>() - a.iter().sum::<f64>()).abs() < 1e-12);
            let r = geometry.opening_distance[0][geometry.weld[v] as usize];
            if r / width <= HOLD - 0.02 {
                assert_eq!(a, b, "vertex {v}");
                continue;
            }
            for m in 2..6 {
                assert!(
                    a[m] <= b[m] * keep(r / width) + 1e-12,
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
}
