//! The runtime's arithmetic promises, on the real FaceCap rig with random marker data:
//! zero motion gives the rest pose bit for bit, a uniform translation moves every vertex by
//! that translation (exactly, or for the linear form within its 16-bit quantisation bound), and
//! the map is linear within rounding.

use facebake::ground_truth::SplitMix64;
use facebake_runtime::deformer::Deformer;
use facebake_runtime::fixed::linear_displacement_limit;
use facebake_runtime::{FrameError, Rig};
use facebake_tests::facecap_blobs;

fn rest_markers(rig: &Rig<'_>) -> Vec<[i32; 3]> {
    (0..rig.marker_count())
        .map(|i| rig.marker_rest(i).unwrap())
        .collect()
}

fn deform(rig: &Rig<'_>, m: &[[i32; 3]]) -> Vec<[i32; 3]> {
    let mut out = vec![[0; 3]; rig.vertex_count()];
    rig.deform(m, &mut out).unwrap();
    out
}

/// The linear form's documented bound on its 16-bit quantisation (`deformer::linear`): at most
/// `2^e + 1` Q8.24 units for the frame's block exponent e, found from its largest displacement
/// as the runtime finds it; 0 for the other forms.
fn quantisation_bound(rig: &Rig<'_>, displacements: impl Iterator<Item = i64>) -> i64 {
    let Deformer::Linear(lin) = rig.deformer() else {
        return 0;
    };
    let f = u32::from(lin.weight_frac_bits);
    let limit = i64::from(linear_displacement_limit(f));
    let largest = displacements
        .map(|d| d.clamp(-limit, limit).abs() << (15 - f))
        .max()
        .unwrap_or(0);
    let e = (64 - largest.leading_zeros()).saturating_sub(15).min(15);
    (1 << e) + 1
}

/// A random offset within ±`range` rig units (Q8.24).
fn offset(rng: &mut SplitMix64, range: f64) -> [i32; 3] {
    [0; 3].map(|_| ((rng.unit() * 2.0 - 1.0) * range * f64::from(1 << 24)) as i32)
}

#[test]
fn zero_motion_is_the_rest_pose_bit_for_bit() {
    for (_, blob) in facecap_blobs() {
        zero_motion(&Rig::from_bytes(blob).unwrap());
    }
}

fn zero_motion(rig: &Rig<'_>) {
    let out = deform(rig, &rest_markers(rig));
    for (v, o) in out.iter().enumerate() {
        assert_eq!(*o, rig.vertex_rest(v).unwrap(), "vertex {v}");
    }
}

#[test]
fn uniform_translation_moves_every_vertex_by_it() {
    for (_, blob) in facecap_blobs() {
        translation(&Rig::from_bytes(blob).unwrap());
    }
}

fn translation(rig: &Rig<'_>) {
    let rest = rest_markers(rig);
    let mut rng = SplitMix64(7);
    for trial in 0..200 {
        // Translations up to ±4 rig units, and tiny ones down to a few LSBs.
        let t = offset(&mut rng, if trial % 2 == 0 { 4.0 } else { 1e-6 });
        let moved: Vec<_> = rest
            .iter()
            .map(|m| [m[0] + t[0], m[1] + t[1], m[2] + t[2]])
            .collect();
        let out = deform(rig, &moved);
        let bound = quantisation_bound(rig, t.iter().map(|&x| i64::from(x)));
        for (v, o) in out.iter().enumerate() {
            let r = rig.vertex_rest(v).unwrap();
            for c in 0..3 {
                let error = (i64::from(o[c]) - i64::from(r[c] + t[c])).abs();
                assert!(
                    error <= bound,
                    "trial {trial}, vertex {v}: {error} > {bound}"
                );
            }
        }
    }
}

#[test]
fn linear_within_rounding() {
    for (_, blob) in facecap_blobs() {
        linearity(&Rig::from_bytes(blob).unwrap());
    }
}

fn linearity(rig: &Rig<'_>) {
    let rounding = match rig.deformer() {
        Deformer::Linear(_) => 1,
        Deformer::Rbf(_) => 18,
        Deformer::Planar(_) => panic!("planar bones are not linear in the markers"),
    };
    let rest = rest_markers(rig);
    let mut rng = SplitMix64(11);
    let add = |x: &[[i32; 3]]| -> Vec<[i32; 3]> {
        x.iter()
            .zip(&rest)
            .map(|(d, r)| [r[0] + d[0], r[1] + d[1], r[2] + d[2]])
            .collect()
    };
    for trial in 0..50 {
        let a: Vec<[i32; 3]> = (0..rest.len()).map(|_| offset(&mut rng, 0.1)).collect();
        let b: Vec<[i32; 3]> = (0..rest.len()).map(|_| offset(&mut rng, 0.1)).collect();
        let ab: Vec<[i32; 3]> = a
            .iter()
            .zip(&b)
            .map(|(p, q)| [p[0] + q[0], p[1] + q[1], p[2] + q[2]])
            .collect();
        let (fa, fb, fab) = (
            deform(rig, &add(&a)),
            deform(rig, &add(&b)),
            deform(rig, &add(&ab)),
        );
        // The linear form quantises each frame on its own: each of the three is within its
        // bound of the exact sum.
        let bound =
            |x: &[[i32; 3]]| quantisation_bound(rig, x.iter().flatten().map(|&d| i64::from(d)));
        let tolerance = rounding + bound(&a) + bound(&b) + bound(&ab);
        for v in 0..rig.vertex_count() {
            let r = rig.vertex_rest(v).unwrap();
            for c in 0..3 {
                // f(a+b) − rest = (f(a) − rest) + (f(b) − rest) up to rounding. Linear form: one
                // rounding per side, ≤ 1 LSB apart. Coefficient form: each coefficient rounds
                // too: ≤ 1.5 LSB per kernel term (K = 8, φ ≤ 1), 4.5 for the affine part, 1.5
                // for the narrowing, so ≤ 18 LSB (0.16 µm on this head).
                let lhs = i64::from(fab[v][c]) - i64::from(r[c]);
                let rhs = i64::from(fa[v][c]) + i64::from(fb[v][c]) - 2 * i64::from(r[c]);
                assert!(
                    (lhs - rhs).abs() <= tolerance,
                    "trial {trial} vertex {v}: {lhs} vs {rhs}"
                );
            }
        }
    }
}

#[test]
fn wrong_slice_lengths_are_errors_and_write_nothing() {
    let rig = Rig::from_bytes(facecap_blobs()[0].1).unwrap();
    let rest = rest_markers(&rig);
    let mut out = vec![[7; 3]; rig.vertex_count()];
    assert_eq!(
        rig.deform(&rest[1..], &mut out),
        Err(FrameError::MarkerCount {
            expected: 40,
            found: 39
        })
    );
    assert!(out.iter().all(|o| *o == [7; 3]));
    let mut short = vec![[0; 3]; 5];
    assert_eq!(
        rig.deform(&rest, &mut short),
        Err(FrameError::OutputLength {
            expected: 2694,
            found: 5
        })
    );
}

#[test]
fn extreme_markers_saturate_instead_of_wrapping() {
    for (_, blob) in facecap_blobs() {
        extremes(&Rig::from_bytes(blob).unwrap());
    }
}

fn extremes(rig: &Rig<'_>) {
    for extreme in [i32::MAX, i32::MIN] {
        let m = vec![[extreme; 3]; rig.marker_count()];
        let out = deform(rig, &m);
        match rig.deformer() {
            // The linear kernel clamps every displacement to ±2^(15+F) (its sums then cannot
            // overflow): a push to the edge of the range is a uniform translation by that limit,
            // so every vertex moves by the limit, towards the extreme (within the quantisation
            // bound at e = 15).
            Deformer::Linear(lin) => {
                let limit = linear_displacement_limit(u32::from(lin.weight_frac_bits));
                let t = limit * extreme.signum();
                let bound = quantisation_bound(rig, [i64::from(extreme)].into_iter());
                assert_eq!(bound, (1 << 15) + 1, "e = 15 at the clamp");
                for (v, o) in out.iter().enumerate() {
                    let r = rig.vertex_rest(v).unwrap();
                    for c in 0..3 {
                        let error = (i64::from(o[c]) - i64::from(r[c] + t)).abs();
                        assert!(error <= bound, "vertex {v}: {error} > {bound}");
                    }
                }
            }
            // Every vertex ends near that extreme (within the mesh's size, 2^24), none wraps
            // round to the other sign.
            Deformer::Rbf(_) | Deformer::Planar(_) => {
                for o in out {
                    for c in o {
                        assert_eq!(c.signum(), extreme.signum());
                        assert!(c.unsigned_abs() >= (1 << 31) - (1 << 25), "{c}");
                    }
                }
            }
        }
    }
}
