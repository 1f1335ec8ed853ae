//! The lips' curve between their markers: a lip passes through its markers smoothly.
//!
//! The exponential kernel's interpolant is only continuous at its markers and, with a width
//! about twice the lip markers' spacing, nearly straight between them: in a jaw open the lower
//! lip hangs in a V from its middle marker and the upper lip rises to a tent at its own
//! (docs/design.md, "The lips curve through their markers"). A lip through the same markers
//! with a continuous slope is rounder: FaceCap's truth is flat for 4 mm each side of the middle.
//!
//! So each lip's rim, and the skin beside it, takes a correction between its middle markers:
//! the difference between a cubic Hermite curve through the lip markers' displacements (slopes
//! from each marker's neighbours along the lip, `Chain::slope`) and the straight line between
//! the two markers of its segment. The difference is nothing at every marker, so the markers
//! are still reproduced, and nothing for a straight lip; it is linear in the markers'
//! displacements, so it is a change of weights (summing to zero) and the runtime is untouched.
//! It applies between the lip markers only, not between the last one and a mouth corner, where
//! the corners' crack profile shapes the lip (`surface::corners`), and it fades with the
//! distance from the rim over [`REACH`] mean marker spacings.
//!
//! At the last lip marker before a corner the curve's slope is [`END_SLOPE_SHARE`] of the
//! slope through its neighbours (the corner's marker one of them) and the rest of its segment's
//! own; there the correction stops, and a full share kinks the rim beside the marker on a dense
//! mesh (FaceCap subdivided twice: 4 triangles of the lips' inner roll turn over in the funnel,
//! none at half).
//!
//! Measured on FaceCap's truth with the JawMoCap layout (`--test structure`, docs/measurements.md):
//! the jaw open's lower lip 3.8 and 7.5 mm from the middle 0.7 mm above its truth where it was
//! 1.3 and 1.8 mm, the face mean 0.544 → 0.543 mm, every structure figure unchanged.

use super::anchoring::smoothstep;
use super::corners::RimEnds;
use crate::model::Side;
use crate::openings::Opening;

/// The correction fades out over this many mean marker spacings from the mouth's rim (along
/// the skin), by a smoothstep.
pub const REACH: f64 = 0.5;
/// A lip marker is one of its group within this many mean marker spacings of the rim.
pub const ON_THE_RIM: f64 = 0.3;
/// At the last lip marker before a mouth corner, the share of the slope through its neighbours
/// (the rest: its inner segment's own). FaceCap's truth with the JawMoCap layout, the mean
/// |vertical error| over the middle rim vertices and the 32 frames, and flips on the head
/// subdivided twice: 0 (the segment's own) 0.486 mm, 0 flips; **0.5** 0.468 mm, 0; 0.7 0.461 mm,
/// 2; 1 0.461 mm, 4 (the correction's kink beside the marker; without the correction 0.492 mm).
pub const END_SLOPE_SHARE: f64 = 0.5;

/// One lip's markers across the mouth (by their position along the rim's axis), with the
/// corners' markers at its ends where the mouth has them.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Chain {
    /// Marker indices, across the mouth.
    pub(crate) markers: Vec<usize>,
    /// Their positions along the rim's axis.
    pub(crate) along: Vec<f64>,
    /// The first and last lip marker (not a corner's) in `markers`.
    pub(crate) lip: [usize; 2],
}

impl Chain {
    /// The chain of `lip` markers with the `corners`' markers at its ends; `None` with fewer
    /// than two lip markers (no segment to curve).
    pub(crate) fn new(
        mut lip: Vec<(usize, f64)>,
        corners: [Option<(usize, f64)>; 2],
    ) -> Option<Self> {
        lip.sort_by(|a, b| a.1.total_cmp(&b.1));
        if lip.len() < 2 {
            return None;
        }
        let first = usize::from(corners[0].is_some());
        let nodes: Vec<(usize, f64)> = corners[0]
            .into_iter()
            .chain(lip.iter().copied())
            .chain(corners[1])
            .collect();
        // Two markers at one place (or a corner inside the lip) leave no segment to curve.
        if nodes.windows(2).any(|w| w[1].1 <= w[0].1) {
            return None;
        }
        Some(Self {
            markers: nodes.iter().map(|n| n.0).collect(),
            along: nodes.iter().map(|n| n.1).collect(),
            lip: [first, first + lip.len() - 1],
        })
    }

    /// The curve's slope at node `k`, as coefficients of the nodes' displacements.
    pub(crate) fn slope(&self, k: usize) -> Vec<(usize, f64)> {
        let x = &self.along;
        let last = x.len() - 1;
        let own = |a: usize, b: usize| {
            let h = x[b] - x[a];
            vec![(a, -1.0 / h), (b, 1.0 / h)]
        };
        if k == 0 {
            return own(0, 1);
        }
        if k == last {
            return own(last - 1, last);
        }
        let through = slope(x[k - 1], x[k], x[k + 1]);
        let through = [(k - 1, through[0]), (k, through[1]), (k + 1, through[2])];
        let inner = if k == self.lip[0] && k > 0 {
            Some(own(k, k + 1))
        } else if k == self.lip[1] && k < last {
            Some(own(k - 1, k))
        } else {
            None
        };
        match inner {
            None => through.to_vec(),
            Some(segment) => through
                .iter()
                .map(|&(j, c)| (j, END_SLOPE_SHARE * c))
                .chain(
                    segment
                        .into_iter()
                        .map(|(j, c)| (j, (1.0 - END_SLOPE_SHARE) * c)),
                )
                .collect(),
        }
    }

    /// The correction at `t` along the rim's axis, as coefficients of the chain's nodes (indices
    /// into [`Chain::markers`]): the Hermite curve less the straight line of its segment, for a
    /// `t` between two lip markers; `None` elsewhere.
    pub(crate) fn correction(&self, t: f64) -> Option<Vec<(usize, f64)>> {
        let x = &self.along;
        let k = (self.lip[0]..self.lip[1]).find(|&k| x[k] <= t && t <= x[k + 1])?;
        let h = x[k + 1] - x[k];
        let s = (t - x[k]) / h;
        // Hermite's slope bases; its value bases less the straight line's are h00 − (1 − s) =
        // h10 + h11 at the segment's start and h01 − s = −(h10 + h11) at its end.
        let (h10, h11) = (s * (1.0 - s) * (1.0 - s), s * s * (s - 1.0));
        let mut out: Vec<(usize, f64)> = Vec::new();
        for (j, c) in self.slope(k) {
            out.push((j, h10 * h * c));
        }
        for (j, c) in self.slope(k + 1) {
            out.push((j, h11 * h * c));
        }
        out.push((k, (h10 + h11)));
        out.push((k + 1, -(h10 + h11)));
        Some(out)
    }
}

/// The slope at the middle of three points along a line, as coefficients of their values: the
/// derivative of the parabola through them.
fn slope(a: f64, b: f64, c: f64) -> [f64; 3] {
    let (h0, h1) = (b - a, c - b);
    let t = h0 + h1;
    [-h1 / (h0 * t), (h1 / h0 - h0 / h1) / t, h0 / (h1 * t)]
}

/// The mouth as the correction sees it.
pub(crate) struct MouthRim<'a> {
    /// Its opening.
    pub(crate) opening: &'a Opening,
    /// Per welded vertex, the distance from its rim along the skin.
    pub(crate) from_rim: &'a [f64],
    /// Per glTF vertex, which lip's side it is on (the mouth mask's sides).
    pub(crate) sides: &'a [Option<Side>],
}

/// Correct `dense` (per glTF vertex, a weight per marker) so that each lip curves smoothly
/// through its markers; `lips` are the upper and lower lip's markers (their groups), `rest`
/// the markers' rest positions, `spacing` the mean marker spacing. Returns how many vertices
/// were corrected.
#[allow(clippy::too_many_arguments)]
pub(crate) fn round(
    dense: &mut [Vec<f64>],
    mouth: &MouthRim<'_>,
    weld: &[u32],
    welded_positions: &[[f64; 3]],
    positions: &[[f64; 3]],
    rest: &[[f64; 3]],
    lips: [&[usize]; 2],
    spacing: f64,
) -> usize {
    let Some(rim) = RimEnds::of(mouth.opening, welded_positions) else {
        return 0;
    };
    let [low, high] = rim.ends;
    let axis = crate::mesh::sub(&high, &low);
    let along = |p: &[f64; 3]| {
        crate::mesh::dot(&crate::mesh::sub(p, &low), &axis) / (rim.width * rim.width)
    };
    let rim_points: Vec<&[f64; 3]> = mouth
        .opening
        .vertices
        .iter()
        .map(|&w| &welded_positions[w as usize])
        .collect();
    let from_rim = |p: &[f64; 3]| {
        rim_points
            .iter()
            .map(|q| crate::mesh::distance(p, q))
            .fold(f64::INFINITY, f64::min)
    };
    let on_rim = |i: usize| from_rim(&rest[i]) <= ON_THE_RIM * spacing;
    let corner = |end: &[f64; 3]| rim.corner_marker(end, rest).map(|i| (i, along(&rest[i])));
    let corners = [corner(&low), corner(&high)];
    let is_corner = |i: usize| corners.iter().flatten().any(|c| c.0 == i);
    let mut corrected = 0;
    for (side, group) in [Side::Upper, Side::Lower].into_iter().zip(lips) {
        let lip: Vec<(usize, f64)> = group
            .iter()
            .copied()
            .filter(|&i| i < rest.len() && !is_corner(i) && on_rim(i))
            .map(|i| (i, along(&rest[i])))
            .collect();
        let Some(chain) = Chain::new(lip, corners) else {
            continue;
        };
        for (v, weights) in dense.iter_mut().enumerate() {
            if mouth.sides.get(v).copied().flatten() != Some(side) {
                continue;
            }
            let fade = smoothstep(1.0 - mouth.from_rim[weld[v] as usize] / (REACH * spacing));
            if fade <= 0.0 {
                continue;
            }
            let Some(terms) = chain.correction(along(&positions[v])) else {
                continue;
            };
            for (node, c) in terms {
                if let Some(w) = weights.get_mut(chain.markers[node]) {
                    *w += fade * c;
                }
            }
            corrected += 1;
        }
    }
    corrected
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A lip of three markers at 0, 1 and 3 across, corners at −1 and 4.
    fn chain() -> Chain {
        Chain::new(
            vec![(11, 1.0), (10, 0.0), (12, 3.0)],
            [Some((20, -1.0)), Some((21, 4.0))],
        )
        .expect("a chain")
    }

    /// The correction's value for node displacements `d` (one per chain node).
    fn value(chain: &Chain, t: f64, d: &[f64]) -> Option<f64> {
        chain
            .correction(t)
            .map(|terms| terms.iter().map(|&(j, c)| c * d[j]).sum())
    }

    #[test]
    fn the_chain_orders_the_lip_between_its_corners() {
        let c = chain();
        assert_eq!(c.markers, vec![20, 10, 11, 12, 21]);
        assert_eq!(c.lip, [1, 3]);
        // No segment with one lip marker, nor with two markers at one place.
        assert_eq!(Chain::new(vec![(1, 0.0)], [None, None]), None);
        assert_eq!(Chain::new(vec![(1, 0.0), (2, 0.0)], [None, None]), None);
    }

    #[test]
    fn the_correction_keeps_the_markers_and_straight_lips_and_moves_no_weight() {
        let c = chain();
        for t in [0.0, 0.3, 1.0, 1.7, 3.0] {
            let terms = c.correction(t).expect("between lip markers");
            let sum: f64 = terms.iter().map(|t| t.1).sum();
            assert!(sum.abs() < 1e-12, "{t}: {sum}");
            // A straight lip (displacement linear along the mouth) is left as it is.
            let straight: Vec<f64> = c.along.iter().map(|x| 2.0 - 0.5 * x).collect();
            assert!(value(&c, t, &straight).unwrap().abs() < 1e-12, "{t}");
        }
        // At the markers, nothing, whatever they do; past the lip markers, nothing.
        let v = [0.0, -30.0, -20.0, -25.0, -10.0];
        for t in [0.0, 1.0, 3.0] {
            assert!(value(&c, t, &v).unwrap().abs() < 1e-12, "{t}");
        }
        assert_eq!(c.correction(-0.5), None);
        assert_eq!(c.correction(3.5), None);
    }

    #[test]
    fn a_v_becomes_round_at_its_middle_marker() {
        // Symmetric lip markers at −1, 0, 1, corners at ±2: the middle drops 40, its
        // neighbours 30, the corners 10 (a V through straight segments).
        let c = Chain::new(
            vec![(0, -1.0), (1, 0.0), (2, 1.0)],
            [Some((3, -2.0)), Some((4, 2.0))],
        )
        .unwrap();
        let d = [-10.0, -30.0, -40.0, -30.0, -10.0];
        let line = |t: f64| -40.0 + 10.0 * t.abs();
        let at = |t: f64| line(t) + value(&c, t, &d).unwrap();
        // The curve's slope at the middle is nothing: as low just beside it as at it.
        assert!((at(0.01) - at(0.0)).abs() < 0.01, "{}", at(0.01));
        // Below the straight line between the markers: rounder.
        assert!(at(0.5) < line(0.5) - 1.0, "{} vs {}", at(0.5), line(0.5));
        // Symmetric.
        assert!((at(0.5) - at(-0.5)).abs() < 1e-9);
    }
}
