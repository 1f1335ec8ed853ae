//! The linear deformer: K weights per vertex on marker displacements; its f64 reference,
//! `LinearF64`, is the rig's own quantised weights in exact arithmetic.

use std::collections::HashMap;

use facebake_runtime::deformer::linear::{
    DerivedMarker, LinearDeformer, DIRECTION_ONE, MEAN_MAX_SOURCES, MEAN_ONE,
};
use facebake_runtime::deformer::Deformer;
use facebake_runtime::fixed::unpack_influence;
use facebake_runtime::format::records::{
    Bytes, INFLUENCE_PAIR_BYTES, MAX_MARKERS, MAX_MARKER_PAIRS,
};

use super::{influence_counts, DeformerBytes, DeformerOutput, Section, SectionError};
use crate::sparsify::{self, Refit};

/// The linear section, encoded: the marker pairs, per vertex its influence pair count, and the
/// influence pairs.
pub struct LinearBytes {
    weight_frac_bits: u8,
    max_influences: u8,
    derived: Vec<u8>,
    marker_pairs: Vec<u8>,
    counts: Vec<u8>,
    pairs: Vec<u8>,
}

impl LinearBytes {
    /// Per vertex, its packed influences (at most 64), stored in pairs ([`pair_up`]), over the
    /// markers and then the `derived` markers.
    fn new(
        weight_frac_bits: u8,
        rows: &[Vec<u32>],
        derived: &[DerivedMarker],
    ) -> Result<Self, SectionError> {
        let lens = influence_counts(rows.iter().map(Vec::len))?;
        let paired = pair_up(rows)?;
        Ok(Self {
            weight_frac_bits,
            max_influences: lens.iter().copied().max().unwrap_or(0).max(1),
            derived: derived.iter().flat_map(DerivedMarker::record).collect(),
            marker_pairs: paired.marker_pairs.concat(),
            counts: paired.counts,
            pairs: paired.bytes,
        })
    }

    /// The runtime's section over these bytes.
    pub(super) fn section(&self) -> Section<'_> {
        Section {
            deformer: Deformer::Linear(LinearDeformer {
                weight_frac_bits: self.weight_frac_bits,
                max_influences: self.max_influences,
                derived_markers: Bytes(&self.derived),
                marker_pairs: Bytes(&self.marker_pairs),
                pair_counts: Bytes(&self.counts),
                pairs_align: Bytes(&[]),
                pairs: Bytes(&self.pairs),
            }),
            influence_bytes: self.pairs.len(),
            influences: 2 * self.pairs.len() / INFLUENCE_PAIR_BYTES,
        }
    }
}

/// Every vertex's influences in pairs, as the linear section stores them.
struct Paired {
    /// The distinct marker pairs, each `(a, b)` with `a ≤ b`.
    marker_pairs: Vec<[u8; 2]>,
    /// Per vertex, its pair count.
    counts: Vec<u8>,
    /// Per vertex, its weight pairs then its marker pair indices.
    bytes: Vec<u8>,
}

/// Pairs each vertex's influences so that vertices share marker pairs: the per-frame table has
/// one entry per distinct pair, so fewer pairs is less marker work and a smaller table. Per
/// vertex (influences in marker order), first the pairs already in the table, then neighbours
/// in marker order; an influence left alone joins a pair that holds its marker with a zero weight
/// on the other side, else the pair of its marker with itself.
///
/// The table holds at most [`MAX_MARKER_PAIRS`]. Room for every marker's pair with itself is
/// kept free, so when the two-marker pairs run out (dense layouts: 60 markers over a whole head
/// at K = 8 need more), a vertex's influences that would need a new one go alone, each with a
/// zero partner: every rig bakes, at the price of more pairs for those vertices (and, as their
/// counts then differ, the general per-vertex loop instead of the fixed-K ones).
fn pair_up(rows: &[Vec<u32>]) -> Result<Paired, SectionError> {
    let mut used = [false; 256];
    for &w in rows.iter().flatten() {
        used[usize::from(unpack_influence(w).0)] = true;
    }
    let mut table = PairTable {
        selves_left: used.iter().filter(|&&u| u).count(),
        ..PairTable::default()
    };
    let (mut counts, mut bytes) = (Vec::with_capacity(rows.len()), Vec::new());
    for row in rows {
        let mut influences: Vec<(u8, i16)> = row
            .iter()
            .map(|&w| {
                let (m, q) = unpack_influence(w);
                i16::try_from(q)
                    .map(|q| (m, q))
                    .map_err(|_| SectionError(format!("linear weight {q} does not fit 16 bits")))
            })
            .collect::<Result<_, _>>()?;
        influences.sort_by_key(|&(m, _)| m);
        let mut chosen: Vec<[(u8, i16); 2]> = Vec::new();
        let mut taken = vec![false; influences.len()];
        // Pairs the table already has.
        for i in 0..influences.len() {
            for j in i + 1..influences.len() {
                if !taken[i] && !taken[j] && table.get([influences[i].0, influences[j].0]).is_some()
                {
                    taken[i] = true;
                    taken[j] = true;
                    chosen.push([influences[i], influences[j]]);
                }
            }
        }
        // Neighbours in marker order, while the table has room; then each alone.
        let rest: Vec<(u8, i16)> = influences
            .iter()
            .zip(&taken)
            .filter(|(_, &t)| !t)
            .map(|(&x, _)| x)
            .collect();
        let mut twos = rest.chunks_exact(2);
        for two in &mut twos {
            if table.has_room() {
                chosen.push([two[0], two[1]]);
            } else {
                chosen.extend(two.iter().map(|&(m, w)| table.with_marker(m, w)));
            }
        }
        if let [(m, w)] = *twos.remainder() {
            chosen.push(table.with_marker(m, w));
        }
        let mut ids = Vec::with_capacity(chosen.len());
        for [(a, wa), (b, wb)] in &chosen {
            bytes.extend(wa.to_le_bytes());
            bytes.extend(wb.to_le_bytes());
            ids.push(table.id([*a, *b])?);
        }
        bytes.extend(ids.iter().flat_map(|id| id.to_le_bytes()));
        counts.push(chosen.len() as u8);
    }
    Ok(Paired {
        marker_pairs: table.pairs,
        counts,
        bytes,
    })
}

/// The distinct marker pairs so far, with their indices.
#[derive(Default)]
struct PairTable {
    pairs: Vec<[u8; 2]>,
    index: HashMap<[u8; 2], u16>,
    /// Markers in use whose pair with themselves is not in the table yet: room kept for them.
    selves_left: usize,
}

impl PairTable {
    /// The index of `pair`, if the table has it.
    fn get(&self, pair: [u8; 2]) -> Option<u16> {
        self.index.get(&pair).copied()
    }

    /// Whether a new pair of two markers fits beside the room kept for the self pairs.
    fn has_room(&self) -> bool {
        self.pairs.len() + self.selves_left < MAX_MARKER_PAIRS
    }

    /// The index of `pair`, added if new (a pair of two markers only if [`Self::has_room`]).
    fn id(&mut self, pair: [u8; 2]) -> Result<u16, SectionError> {
        if let Some(id) = self.get(pair) {
            return Ok(id);
        }
        let alone = pair[0] == pair[1];
        if self.pairs.len() == MAX_MARKER_PAIRS || (!alone && !self.has_room()) {
            return Err(SectionError(format!(
                "the linear rig needs more than {MAX_MARKER_PAIRS} distinct marker pairs"
            )));
        }
        if alone {
            self.selves_left = self.selves_left.saturating_sub(1);
        }
        let id = self.pairs.len() as u16;
        self.pairs.push(pair);
        self.index.insert(pair, id);
        Ok(id)
    }

    /// A pair for marker `m` with weight `w` alone: one the table has that holds `m`, with a
    /// zero weight on its other side, else `m` with itself.
    fn with_marker(&self, m: u8, w: i16) -> [(u8, i16); 2] {
        self.pairs
            .iter()
            .find_map(|&[a, b]| match (a == m, b == m) {
                (true, _) => Some([(m, w), (b, 0)]),
                (_, true) => Some([(a, 0), (m, w)]),
                _ => None,
            })
            .unwrap_or([(m, w), (m, 0)])
    }
}

/// A derived marker's direction as the runtime stores it: `up` (file coordinates, non-zero)
/// scaled to `Σ|a_c| = 1` in Q1.14, and that stored direction as a unit vector, which the
/// rig's projection `(q·a)a / |a|²` follows exactly. An axis gives that axis exactly.
pub fn derived_direction(up: [f64; 3]) -> ([i16; 3], [f64; 3]) {
    let norm: f64 = up.iter().map(|c| c.abs()).sum();
    let one = f64::from(DIRECTION_ONE);
    let mut a = up.map(|c| (c / norm * one).round() as i32);
    // Rounding three components may leave Σ|a_c| one or two steps over 2^14: take them from the
    // largest.
    let excess = a.iter().map(|c| c.abs()).sum::<i32>() - DIRECTION_ONE;
    if excess > 0 {
        let (big, _) = a
            .iter()
            .enumerate()
            .max_by_key(|(_, c)| c.abs())
            .expect("three components");
        a[big] -= excess * a[big].signum();
    }
    let a = a.map(|c| c as i16);
    let length = a.iter().map(|&c| f64::from(c).powi(2)).sum::<f64>().sqrt();
    (a, a.map(|c| f64::from(c) / length))
}

/// The head markers whose mean the anchored skin follows (`surface::anchoring`).
pub(crate) struct FollowedMean<'a> {
    /// The followed markers, at most [`MEAN_MAX_SOURCES`].
    pub(crate) markers: &'a [usize],
}

impl FollowedMean<'_> {
    /// `dense` with the part its followed markers share moved onto their mean, a column after
    /// the markers: `amount` × the median `c` of the row's weights on them comes off each and
    /// `n c` goes to the mean, which moves the skin the same (`Σ c d_f = n c · mean d`). Where
    /// the skin is anchored, one of its K influences then carries the share that took one per
    /// followed marker, and at least one followed marker's own weight is zero.
    ///
    /// Every row is split, not only the anchored ones, so the sparse rows stay continuous over
    /// the skin: splitting only where the anchoring strength is above zero turned 35 of
    /// ICT-FaceKit's triangles over in its jaw open. The caller passes `amount` 0 where the
    /// mouth's corrections take two of the K (`give_way`, fading from there): the kept set there
    /// is shaped to meet theirs, and the split's column, entering it, moved FaceCap's middle
    /// lips 1 mm off the truth in the jaw open (docs/measurements.md).
    fn split(&self, dense: &[f64], amount: f64) -> Vec<f64> {
        let mut on: Vec<f64> = self.markers.iter().map(|&m| dense[m]).collect();
        on.sort_by(f64::total_cmp);
        let c = on[on.len() / 2] * amount;
        let mut row = dense.to_vec();
        for &m in self.markers {
            row[m] -= c;
        }
        row.push(c * self.markers.len() as f64);
        row
    }

    /// `covariance` with the mean's row and column after the markers'.
    fn covariance(&self, covariance: &nalgebra::DMatrix<f64>) -> nalgebra::DMatrix<f64> {
        let n = covariance.nrows();
        let share = 1.0 / self.markers.len() as f64;
        let mut c = covariance.clone().resize(n + 1, n + 1, 0.0);
        for i in 0..n {
            let with: f64 = self
                .markers
                .iter()
                .map(|&f| covariance[(i, f)])
                .sum::<f64>()
                * share;
            c[(i, n)] = with;
            c[(n, i)] = with;
        }
        c[(n, n)] = self.markers.iter().map(|&f| c[(n, f)]).sum::<f64>() * share;
        c
    }
}

/// The linear deformer from each vertex's dense weights: keep K, re-fit, quantise. A vertex
/// with `vertical` weights (on markers' displacements along the face's `up` alone, a unit
/// vector in file coordinates, summing to zero; empty for most) or `forward` ones (the same
/// along `ahead`, the face's forward axis) keeps K less their count on the markers and takes
/// them on derived markers, one per source marker and axis, after the markers (the
/// covariance's order). Every vertex then has K influences, the
/// uniform count the Cortex-M4's unrolled kernel needs (keeping all K markers besides the
/// derived ones costs 60 % more instructions on the M4, docs/measurements.md). So that the kept
/// set does not jump where the corrections begin, a vertex without them gives way by
/// `give_way` (1 beside them, fading out over a ring): its two weakest kept markers shrink
/// towards zero ([`sparsify::sparsify_row_giving_way`]). With `followed` (two or more
/// markers), the anchored skin's share of them is carried by one derived mean after those
/// ([`FollowedMean::split`]).
#[allow(clippy::too_many_arguments)]
pub(crate) fn bake(
    dense_rows: impl Iterator<Item = Vec<f64>>,
    vertical: &[Vec<(usize, f64)>],
    up: [f64; 3],
    forward: &[Vec<(usize, f64)>],
    ahead: [f64; 3],
    give_way: &[f64],
    followed: Option<FollowedMean<'_>>,
    k: usize,
    refit: Refit,
    covariance: &nalgebra::DMatrix<f64>,
) -> Result<DeformerOutput, super::DeformerError> {
    let markers = covariance.nrows();
    let sources_of = |rows: &[Vec<(usize, f64)>]| {
        let mut sources: Vec<usize> = rows.iter().flatten().map(|&(m, _)| m).collect();
        sources.sort_unstable();
        sources.dedup();
        sources
    };
    let (sources, sources_ahead) = (sources_of(vertical), sources_of(forward));
    let followed = followed.filter(|f| (2..=MEAN_MAX_SOURCES).contains(&f.markers.len()));
    let derived_count = sources.len() + sources_ahead.len() + usize::from(followed.is_some());
    if markers + derived_count > MAX_MARKERS {
        return Err(SectionError(format!(
            "{markers} markers and {derived_count} derived ones: at most {MAX_MARKERS} in all",
        ))
        .into());
    }
    let derived_index = |m: usize| markers + sources.binary_search(&m).unwrap_or(0);
    let ahead_index =
        |m: usize| markers + sources.len() + sources_ahead.binary_search(&m).unwrap_or(0);
    // The mean's column follows the markers' in the rows and the covariance; its derived
    // marker follows the vertical ones and the forward ones.
    let mean_index = markers + sources.len() + sources_ahead.len();
    let covariance = match &followed {
        Some(f) => std::borrow::Cow::Owned(f.covariance(covariance)),
        None => std::borrow::Cow::Borrowed(covariance),
    };
    let length2_of = |direction: [i16; 3]| {
        direction
            .iter()
            .map(|&c| (f64::from(c) / f64::from(DIRECTION_ONE)).powi(2))
            .sum::<f64>()
    };
    let (direction, _) = derived_direction(up);
    let (direction_ahead, _) = derived_direction(ahead);
    let (length2, length2_ahead) = (length2_of(direction), length2_of(direction_ahead));
    let mean_scale = followed.as_ref().map_or(1.0, |f| {
        let n = f.markers.len() as u8;
        f64::from(n) * f64::from(DerivedMarker::mean_factor(n)) / f64::from(MEAN_ONE)
    });
    // How many of the K the corrections take where they are: what the skin beside them gives way.
    let extra_len =
        |v: usize| vertical.get(v).map_or(0, Vec::len) + forward.get(v).map_or(0, Vec::len);
    let ranks = (0..vertical.len().max(forward.len()))
        .map(extra_len)
        .max()
        .unwrap_or(0);
    let mut dropped = Vec::new();
    let rows: Vec<_> = dense_rows
        .enumerate()
        .map(|(v, dense)| {
            let dense = match &followed {
                Some(f) => f.split(&dense, 1.0 - give_way.get(v).map_or(0.0, |g| g.min(1.0))),
                None => dense,
            };
            let extra = vertical.get(v).map_or(&[][..], Vec::as_slice);
            let extra_ahead = forward.get(v).map_or(&[][..], Vec::as_slice);
            let mut row = if extra.is_empty() && extra_ahead.is_empty() {
                let a = give_way.get(v).copied().unwrap_or(0.0);
                sparsify::sparsify_row_giving_way(&dense, k, ranks, a, refit, Some(&covariance))
            } else {
                let keep = k.saturating_sub(extra.len() + extra_ahead.len()).max(1);
                sparsify::sparsify_row(&dense, keep, refit, Some(&covariance))
            };
            let kept: f64 = row.iter().map(|&(i, _)| dense[i]).sum();
            dropped.push((dense.iter().sum::<f64>() - kept).abs());
            // The rig's mean is `mean_scale` × the mean.
            for (i, w) in row.iter_mut() {
                if *i == markers {
                    (*i, *w) = (mean_index, *w / mean_scale);
                }
            }
            // The stored direction `a` projects as (q·a)a = |a|² (q·u)u.
            row.extend(extra.iter().map(|&(m, w)| (derived_index(m), w / length2)));
            row.extend(
                extra_ahead
                    .iter()
                    .map(|&(m, w)| (ahead_index(m), w / length2_ahead)),
            );
            row
        })
        .collect();
    let q = sparsify::quantise(&rows, sparsify::QuantiseFor::LinearWeights)?;
    let mut derived: Vec<DerivedMarker> = sources
        .iter()
        .map(|&m| DerivedMarker::Projection {
            source: m as u8,
            direction,
        })
        .chain(sources_ahead.iter().map(|&m| DerivedMarker::Projection {
            source: m as u8,
            direction: direction_ahead,
        }))
        .collect();
    if let Some(f) = &followed {
        derived.push(DerivedMarker::Mean {
            sources: std::array::from_fn(|i| f.markers.get(i).map_or(0, |&m| m as u8)),
            count: f.markers.len() as u8,
        });
    }
    Ok(DeformerOutput {
        bytes: DeformerBytes::Linear(LinearBytes::new(q.frac_bits, &q.words, &derived)?),
        frac_bits: q.frac_bits,
        dropped,
        rounding: q.max_rounding,
        matrix_rounding: 0.0,
    })
}

/// A loaded linear rig's section in f64: per vertex, its (marker, weight) pairs, and the
/// derived markers the indices past the markers name.
pub(crate) struct LinearF64 {
    rows: Vec<Vec<(usize, f64)>>,
    derived: Vec<DerivedMarker>,
}

impl LinearF64 {
    /// The section `l`, weights scaled by `scale`.
    pub(crate) fn new(l: &LinearDeformer<'_>, scale: f64) -> Self {
        Self {
            rows: l
                .vertex_influences()
                .map(|v| {
                    v.map(|(m, w)| (usize::from(m), f64::from(w) / scale))
                        .collect()
                })
                .collect(),
            derived: l.derived().collect(),
        }
    }

    /// Each vertex's displacement for marker displacements `d` (rig units): Σ w · d, a derived
    /// marker's `d` its source's projected on its direction `a`, `(d·a)a`, or its sources' sum
    /// times the mean's factor.
    pub(crate) fn displacements(&self, d: &[[f64; 3]]) -> Vec<[f64; 3]> {
        let mut d = d.to_vec();
        let at = |d: &[[f64; 3]], s: u8| d.get(usize::from(s)).copied().unwrap_or([0.0; 3]);
        let extra: Vec<[f64; 3]> = self
            .derived
            .iter()
            .map(|derived| match *derived {
                DerivedMarker::Projection { source, direction } => {
                    let p = at(&d, source);
                    let a = direction.map(|c| f64::from(c) / f64::from(DIRECTION_ONE));
                    let along: f64 = (0..3).map(|c| p[c] * a[c]).sum();
                    a.map(|a| along * a)
                }
                DerivedMarker::Mean { sources, count } => {
                    let r = f64::from(DerivedMarker::mean_factor(count)) / f64::from(MEAN_ONE);
                    let n = usize::from(count).min(MEAN_MAX_SOURCES);
                    let sum = sources[..n].iter().fold([0.0; 3], |sum, &s| {
                        let p = at(&d, s);
                        [0, 1, 2].map(|c| sum[c] + p[c])
                    });
                    sum.map(|s| s * r)
                }
            })
            .collect();
        d.extend(extra);
        self.rows
            .iter()
            .map(|row| {
                let mut out = [0.0; 3];
                for &(i, w) in row {
                    for a in 0..3 {
                        out[a] += w * d[i][a];
                    }
                }
                out
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use facebake_runtime::fixed::pack_influence;

    /// An axis is stored exactly; any other direction with `Σ|a_c| = 2¹⁴` (the runtime's bound)
    /// and its stored unit vector within a step of the one asked for.
    #[test]
    fn derived_directions_fit_the_runtime_bound() {
        assert_eq!(
            derived_direction([0.0, 1.0, 0.0]),
            ([0, 1 << 14, 0], [0.0, 1.0, 0.0])
        );
        assert_eq!(derived_direction([0.0, -2.0, 0.0]).0, [0, -(1 << 14), 0]);
        let mut s = 0x9E37_79B9_7F4A_7C15u64;
        let mut next = move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        for _ in 0..10_000 {
            let v = [next(), next(), next()];
            let length = v.iter().map(|c| c * c).sum::<f64>().sqrt();
            if length < 1e-3 {
                continue;
            }
            let (a, unit) = derived_direction(v);
            let sum: i32 = a.iter().map(|&c| i32::from(c).abs()).sum();
            assert!(
                (DIRECTION_ONE - 2..=DIRECTION_ONE).contains(&sum),
                "{v:?}: {a:?}"
            );
            let off = (0..3)
                .map(|c| (unit[c] - v[c] / length).abs())
                .fold(0.0, f64::max);
            assert!(off < 3e-4, "{v:?}: {unit:?}");
        }
    }

    /// The split row moves the skin as the dense row does (its mean column on the followed
    /// markers' mean), sums to the same, leaves the median followed marker at zero; with
    /// `amount` 0 it is the dense row and a zero column.
    #[test]
    fn the_split_moves_the_followed_share_onto_their_mean() {
        let followed = FollowedMean {
            markers: &[1, 3, 4],
        };
        let dense = [0.4, 0.1, -0.05, 0.3, 0.2, 0.05];
        let d = [
            [0.5, -1.0, 2.0],
            [1.5, 0.25, -0.75],
            [-2.0, 1.0, 0.0],
            [0.3, 0.7, -0.2],
            [1.0, 1.0, 1.0],
            [0.0, -0.5, 0.4],
        ];
        let moved = |row: &[f64]| {
            let mean = [0, 1, 2].map(|c| [1, 3, 4].iter().map(|&m| d[m][c]).sum::<f64>() / 3.0);
            [0, 1, 2].map(|c| {
                row[..6].iter().zip(&d).map(|(w, p)| w * p[c]).sum::<f64>() + row[6] * mean[c]
            })
        };
        let split = followed.split(&dense, 1.0);
        assert_eq!(split.len(), 7);
        assert_eq!(
            split[4], 0.0,
            "the median, 0.2, is off each followed weight"
        );
        assert!((split[6] - 0.6).abs() < 1e-15);
        assert!((split.iter().sum::<f64>() - dense.iter().sum::<f64>()).abs() < 1e-15);
        let (a, b) = (moved(&split), moved(&[dense.as_slice(), &[0.0]].concat()));
        assert!((0..3).all(|c| (a[c] - b[c]).abs() < 1e-12), "{a:?} {b:?}");
        assert_eq!(
            followed.split(&dense, 0.0),
            [dense.as_slice(), &[0.0]].concat()
        );
        // The mean's covariance is the followed markers' mean covariance.
        let cov = nalgebra::DMatrix::from_fn(6, 6, |i, j| (-((i as f64 - j as f64).powi(2))).exp());
        let ext = followed.covariance(&cov);
        assert_eq!(ext.nrows(), 7);
        assert!((ext[(0, 6)] - (cov[(0, 1)] + cov[(0, 3)] + cov[(0, 4)]) / 3.0).abs() < 1e-15);
        let var: f64 = [1, 3, 4]
            .iter()
            .flat_map(|&i| [1, 3, 4].map(|j| cov[(i, j)]))
            .sum::<f64>()
            / 9.0;
        assert!((ext[(6, 6)] - var).abs() < 1e-15);
    }

    /// Rows of K = 8 influences over `markers` markers, each vertex's set drawn at random (no
    /// locality: the worst case for sharing pairs).
    fn random_rows(markers: u64, vertices: usize) -> Vec<Vec<u32>> {
        let mut s = 0x1234_5678_9ABC_DEF1u64;
        let mut next = move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            s
        };
        (0..vertices)
            .map(|_| {
                let mut set: Vec<u8> = Vec::new();
                while set.len() < 8 {
                    let m = (next() % markers) as u8;
                    if !set.contains(&m) {
                        set.push(m);
                    }
                }
                set.iter()
                    .enumerate()
                    .map(|(i, &m)| pack_influence(m, 100 + i as i32 - 3).unwrap())
                    .collect()
            })
            .collect()
    }

    #[test]
    fn every_rig_pairs_within_the_table_and_keeps_its_influences() {
        for (markers, vertices) in [(20, 500), (200, 3000)] {
            let rows = random_rows(markers, vertices);
            let bytes = LinearBytes::new(11, &rows, &[]).unwrap();
            let Deformer::Linear(l) = bytes.section().deformer else {
                unreachable!()
            };
            let pairs = l.marker_pairs.0.len() / 2;
            assert!(pairs <= MAX_MARKER_PAIRS, "{pairs} pairs");
            let mut spilled = 0;
            for ((row, vertex), &count) in
                rows.iter().zip(l.vertex_influences()).zip(l.pair_counts.0)
            {
                let mut want: Vec<(u8, i16)> = row
                    .iter()
                    .map(|&w| {
                        let (m, q) = unpack_influence(w);
                        (m, q as i16)
                    })
                    .collect();
                let mut got: Vec<(u8, i16)> = vertex.filter(|&(_, w)| w != 0).collect();
                want.sort();
                got.sort();
                assert_eq!(got, want);
                spilled += usize::from(count > 4);
            }
            // 20 markers fit in pairs; 200 random ones run out, and some vertices go alone.
            assert_eq!(
                spilled > 0,
                markers == 200,
                "{markers} markers: {spilled} vertices spilled"
            );
        }
    }
}
