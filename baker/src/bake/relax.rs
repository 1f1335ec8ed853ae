//! With a capture, the weights relax where the capture folds the skin.
//!
//! A triangle turned past a right angle from its rest normal is a fold a viewer sees: a skin
//! does not turn inside out. Where the weights change too fast across the skin for the motion a
//! take gives them (a hand-over to the still head, a marker's pull on skin near it), neighbours
//! overtake each other. The bake plays the take through the rig it just made; if a frame folds
//! a skin triangle, the dense weights of the folded triangles' vertices and of a patch of skin
//! round them are replaced by their harmonic interpolation from the skin round the patch (each
//! vertex the mean of its neighbours, the patch's rim held), which spreads the change over the
//! patch. A vertex with the mouth's vertical corrections (`surface::corners`) is held as the
//! rim is. Rounds relax 2, 4 and 6 rings round the folds found so far, each played again; the
//! rig kept is the first that folds least (fewest triangles in its worst frame, then fewest
//! triangle-frames), and the unrelaxed rig unless one folds fewer. The weights stay the
//! method's everywhere else, and the relaxed dense rows are the rig's own dense reference.
//!
//! Measured 2026-12-04 (`cargo test --release -p facebake-tests --test ict_facekit --
//! --nocapture a_take`): ICT-FaceKit's jaw open through its rehearsal take folds two triangles
//! under the chin (the throat's hand-over, `surface::anchoring::THROAT_BAND`) and one below
//! the mouth's corner. Six rings (403 vertices) unfold the throat: against the truth, 3 flips
//! → 1 at 30 Hz and at 60 Hz, face mean 0.601 → 0.600 and 0.589 → 0.587 mm, stretch 1.85× and
//! 1.93 → 1.89×; lips and eyelids unchanged. Two and four rings fold more (5 triangles in a
//! frame: the held rim takes the change), and so do 8 and 12 (4 and 11, the patch reaching the
//! lips). The fold below ICT's mouth corner and FaceCap's sliver past its mouth corner are not
//! undone by any round (they sit among the corners' held vertices), so those bakes keep their
//! rig as it was; JawMoCap on FaceCap folds nothing, and its rig is unchanged.
//!
//! Since 2026-12-05 capture rigs anchor the skin as rigs without a capture do (the followed
//! markers' mean, `surface::anchoring::followed`), and the default rig folds nothing on ICT's
//! rehearsal, which it folded in 12 triangles for the relaxation to mend. `--method pbw` still
//! folds there (`cargo test --release -p facebake-tests --test ict_facekit relaxes --
//! --nocapture`): 5 triangles in the worst frame, 217 triangle-frames; two rings (112 vertices)
//! leave 1 and 23.

use serde::Serialize;

use super::BakeError;
use crate::metrics::Regions;
use crate::model::{Capture, FaceMesh};

/// The most rings of skin round the folds that a round relaxes: the rounds relax 2, 4, and 6.
pub const RINGS: usize = 6;

/// Gauss–Seidel sweeps of the harmonic interpolation (a patch is at most a few rings across,
/// so this converges to well under a thousandth of a weight).
pub const SWEEPS: usize = 60;

/// What the relaxation did.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RelaxChoice {
    /// The capture's frames.
    pub frames: usize,
    /// How the capture folded the skin before.
    pub before: Folds,
    /// The same for the rig kept.
    pub after: Folds,
    /// Rings relaxed round the folds in the rig kept (0: none kept).
    pub rings: usize,
    /// Welded skin vertices whose weights were relaxed in the rig kept.
    pub vertices: usize,
}

/// How a take folds a rig's skin.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Serialize)]
pub struct Folds {
    /// The most skin triangles turned over in one frame.
    pub worst_frame: usize,
    /// Triangle-frames turned over.
    pub triangle_frames: usize,
    /// Skin triangles turned over in some frame.
    pub triangles: usize,
}

/// The skin triangles (indices into [`Regions::triangles`]) that some frame of `capture`
/// played through `blob` turns past a right angle from rest, and how it folds the skin.
pub(crate) fn folds(
    blob: &[u8],
    regions: &Regions,
    capture: &Capture,
) -> Result<(Vec<usize>, Folds), BakeError> {
    let mut folded = vec![false; regions.triangles.len()];
    let mut f = Folds::default();
    super::playback::play(&[blob], capture, |played| {
        let mut here = 0;
        for (t, tri) in regions.triangles.iter().enumerate() {
            if regions.turned(&played[0], tri) {
                folded[t] = true;
                here += 1;
            }
        }
        f.worst_frame = f.worst_frame.max(here);
        f.triangle_frames += here;
    })?;
    let triangles: Vec<usize> = (0..folded.len()).filter(|&t| folded[t]).collect();
    f.triangles = triangles.len();
    Ok((triangles, f))
}

/// The skin's welded neighbours: per welded vertex of `mesh`, the welded vertices it shares a
/// skin edge with (`regions`' edges).
pub(crate) fn skin_neighbours(mesh: &FaceMesh, regions: &Regions) -> Vec<Vec<u32>> {
    let mut neighbours = vec![Vec::new(); mesh.welded_positions.len()];
    for &[a, b] in &regions.edges {
        let (a, b) = (mesh.weld[a as usize], mesh.weld[b as usize]);
        if a != b {
            neighbours[a as usize].push(b);
            neighbours[b as usize].push(a);
        }
    }
    for n in &mut neighbours {
        n.sort_unstable();
        n.dedup();
    }
    neighbours
}

/// The welded vertices of the skin `triangles` (indices into `regions.triangles`) and `rings`
/// rings of skin round them, sorted.
pub(crate) fn patch(
    mesh: &FaceMesh,
    regions: &Regions,
    neighbours: &[Vec<u32>],
    triangles: &[usize],
    rings: usize,
) -> Vec<u32> {
    let mut inside = vec![false; neighbours.len()];
    let mut front: Vec<u32> = Vec::new();
    for &t in triangles {
        for &v in &regions.triangles[t] {
            let w = mesh.weld[v as usize];
            if !inside[w as usize] {
                inside[w as usize] = true;
                front.push(w);
            }
        }
    }
    for _ in 0..rings {
        let mut next = Vec::new();
        for &w in &front {
            for &n in &neighbours[w as usize] {
                if !inside[n as usize] {
                    inside[n as usize] = true;
                    next.push(n);
                }
            }
        }
        front = next;
    }
    (0..inside.len() as u32)
        .filter(|&w| inside[w as usize])
        .collect()
}

/// Replace the dense weight rows (per glTF vertex) of the welded vertices in `patch` by their
/// harmonic interpolation over the skin from the rows round it: [`SWEEPS`] Gauss–Seidel sweeps,
/// each free vertex the mean of its skin neighbours. Vertices with `vertical` corrections, and
/// those without a skin neighbour, keep their rows. Every glTF vertex of a welded vertex gets
/// its row.
pub(crate) fn relax_rows(
    dense: &mut [Vec<f64>],
    vertical: &[Vec<(usize, f64)>],
    weld: &[u32],
    neighbours: &[Vec<u32>],
    patch: &[u32],
) {
    let welded = neighbours.len();
    let mut first = vec![usize::MAX; welded];
    let mut held = vec![false; welded];
    for (v, &w) in weld.iter().enumerate() {
        let w = w as usize;
        if first[w] == usize::MAX {
            first[w] = v;
        }
        held[w] |= vertical.get(v).is_some_and(|c| !c.is_empty());
    }
    let free: Vec<usize> = patch
        .iter()
        .map(|&w| w as usize)
        .filter(|&w| !held[w] && first[w] != usize::MAX && !neighbours[w].is_empty())
        .collect();
    let width = dense.first().map_or(0, Vec::len);
    let mut rows: Vec<Vec<f64>> = (0..welded)
        .map(|w| match first[w] {
            usize::MAX => vec![0.0; width],
            v => dense[v].clone(),
        })
        .collect();
    crate::mesh::harmonic_sweeps(&mut rows, neighbours, &free, SWEEPS);
    let mut is_free = vec![false; welded];
    for &w in &free {
        is_free[w] = true;
    }
    for (v, &w) in weld.iter().enumerate() {
        if is_free[w as usize] {
            dense[v].clone_from(&rows[w as usize]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A strip of 2 × 6 vertices (welded = glTF) with rows stepping from marker 0 to marker 1
    /// between columns 2 and 3: relaxed over the middle columns, the step becomes a ramp, the
    /// ends keep their rows, each row still sums to 1, and a held vertex keeps its own.
    #[test]
    fn a_step_relaxes_into_a_ramp_between_the_held_ends() {
        let index = |r: u32, c: u32| r * 6 + c;
        let mut neighbours = vec![Vec::new(); 12];
        for r in 0..2 {
            for c in 0..6 {
                let mut n = Vec::new();
                if c > 0 {
                    n.push(index(r, c - 1));
                }
                if c < 5 {
                    n.push(index(r, c + 1));
                }
                n.push(index(1 - r, c));
                n.sort_unstable();
                neighbours[index(r, c) as usize] = n;
            }
        }
        let weld: Vec<u32> = (0..12).collect();
        let step = |c: u32| {
            if c <= 2 {
                vec![1.0, 0.0]
            } else {
                vec![0.0, 1.0]
            }
        };
        let mut dense: Vec<Vec<f64>> = (0..12).map(|v| step(v % 6)).collect();
        let mut vertical = vec![Vec::new(); 12];
        vertical[index(1, 3) as usize] = vec![(0, 0.5), (1, -0.5)];
        let patch: Vec<u32> = (0..12).filter(|v| (1..=4).contains(&(v % 6))).collect();
        relax_rows(&mut dense, &vertical, &weld, &neighbours, &patch);
        assert_eq!(dense[index(0, 0) as usize], vec![1.0, 0.0]);
        assert_eq!(dense[index(0, 5) as usize], vec![0.0, 1.0]);
        assert_eq!(dense[index(1, 3) as usize], vec![0.0, 1.0], "held");
        let top: Vec<f64> = (0..6).map(|c| dense[index(0, c) as usize][1]).collect();
        assert!(top.windows(2).all(|w| w[1] > w[0]), "{top:?}");
        for row in &dense {
            assert!((row.iter().sum::<f64>() - 1.0).abs() < 1e-9, "{row:?}");
        }
    }
}
