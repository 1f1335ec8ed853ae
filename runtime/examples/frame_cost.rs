//! Per-frame cost on the host, for `valgrind --tool=callgrind --toggle-collect='*deform_frame*'`:
//! plays one golden rig through `FRAMES` frames of one pose class, each frame through
//! [`deform_frame`], so callgrind counts exactly the instructions of the per-frame call. With
//! `normals`, each frame's normals are computed too, through [`normals_frame`]
//! (`--toggle-collect='*normals_frame*'` counts them alone); with `planned`, through
//! [`planned_frame`] (`Rig::normals_planned`, `--toggle-collect='*planned_frame*'`).
//!
//! `cargo run --release -p facebake-runtime --example frame_cost -- <rig> <poses> [normals|planned]`
//!
//! * `<rig>`: `coefficients`, `weights`, `coefficients_k4`, `product` or `planar` (the golden
//!   rigs; `product` plays the layout's 41 markers);
//! * `<poses>`: `truth` (the 32 ground-truth frames), `rest` (the rest pose, 32 times) or
//!   `extreme` (the 6 saturated and ±120-unit edge frames, cycled to 32).
//!
//! Every class plays the same number of frames, so if the cost does not depend on the marker
//! data, callgrind's totals are equal across classes. `.ci/cross.sh` checks that.

use std::hint::black_box;

use facebake_runtime::{NormalsPlan, Rig};

/// Frames played per run, whatever the pose class.
const FRAMES: usize = 32;
/// Ground-truth frames at the start of the marker file; the edge frames follow (rest first).
const TRUTH_FRAMES: usize = 32;

const MARKERS: &[u8] = include_bytes!("../../fixtures/golden/facecap_markers.bin");
/// The same frames through the bundled layout's 41 markers, for the product rig.
const LAYOUT_MARKERS: &[u8] = include_bytes!("../../fixtures/golden/facecap_layout_markers.bin");

/// One frame: the call callgrind measures.
#[inline(never)]
fn deform_frame(rig: &Rig<'_>, markers: &[[i32; 3]], out: &mut [[i32; 3]]) {
    rig.deform(black_box(markers), out)
        .expect("a golden frame deforms");
    black_box(out);
}

/// One frame's normals: the call callgrind measures with `normals`.
#[inline(never)]
fn normals_frame(rig: &Rig<'_>, positions: &[[i32; 3]], out: &mut [[i16; 3]]) {
    rig.normals(black_box(positions), out)
        .expect("one normal per vertex");
    black_box(out);
}

/// One frame's planned normals: the call callgrind measures with `planned`.
#[inline(never)]
fn planned_frame(
    rig: &Rig<'_>,
    positions: &[[i32; 3]],
    plan: &NormalsPlan<'_>,
    sums: &mut [[i64; 3]],
    out: &mut [[i16; 3]],
) {
    rig.normals_planned(black_box(positions), plan, sums, out)
        .expect("one normal and one sum per vertex");
    black_box(out);
}

/// Which normals each frame computes besides its positions.
#[derive(Clone, Copy, PartialEq)]
enum NormalsCall {
    None,
    Fans,
    Planned,
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (rig_name, poses, normals) = match args.as_slice() {
        [rig, poses] => (rig, poses, NormalsCall::None),
        [rig, poses, n] if n == "normals" => (rig, poses, NormalsCall::Fans),
        [rig, poses, n] if n == "planned" => (rig, poses, NormalsCall::Planned),
        _ => {
            eprintln!(
                "usage: frame_cost <coefficients|weights|coefficients_k4|product|planar> <truth|rest|extreme> [normals|planned]"
            );
            std::process::exit(2);
        }
    };
    let (blob, marker_file): (&[u8], &[u8]) = match rig_name.as_str() {
        "coefficients" => (
            include_bytes!("../../fixtures/golden/facecap_coefficients.fbk"),
            MARKERS,
        ),
        "weights" => (
            include_bytes!("../../fixtures/golden/facecap_weights.fbk"),
            MARKERS,
        ),
        "coefficients_k4" => (
            include_bytes!("../../fixtures/golden/facecap_coefficients_k4.fbk"),
            MARKERS,
        ),
        "product" => (
            include_bytes!("../../fixtures/golden/facecap_product.fbk"),
            LAYOUT_MARKERS,
        ),
        "planar" => (
            include_bytes!("../../fixtures/golden/facecap_planar.fbk"),
            MARKERS,
        ),
        other => panic!("unknown rig {other}"),
    };
    let rig = Rig::from_bytes(blob).expect("golden rig loads");
    let m = rig.marker_count();
    let words: Vec<i32> = marker_file
        .chunks_exact(4)
        .map(|b| i32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect();
    let all: Vec<&[i32]> = words.chunks_exact(3 * m).collect();
    let chosen: Vec<&[i32]> = match poses.as_str() {
        "truth" => all[..TRUTH_FRAMES].to_vec(),
        "rest" => vec![all[TRUTH_FRAMES]; FRAMES],
        "extreme" => all[TRUTH_FRAMES + 1..]
            .iter()
            .copied()
            .cycle()
            .take(FRAMES)
            .collect(),
        other => panic!("unknown pose class {other}"),
    };
    assert_eq!(chosen.len(), FRAMES);
    let frames: Vec<Vec<[i32; 3]>> = chosen
        .iter()
        .map(|f| f.chunks_exact(3).map(|p| [p[0], p[1], p[2]]).collect())
        .collect();
    let mut out = vec![[0i32; 3]; rig.vertex_count()];
    let mut unit = vec![[0i16; 3]; rig.vertex_count()];
    let mut sums = vec![[0i64; 3]; rig.vertex_count()];
    let mut triangles = vec![[0u32; 3]; rig.normals_plan_len()];
    let plan = rig
        .plan_normals(&mut triangles)
        .expect("a plan of its length");
    for markers in &frames {
        deform_frame(&rig, markers, &mut out);
        match normals {
            NormalsCall::None => {}
            NormalsCall::Fans => normals_frame(&rig, &out, &mut unit),
            NormalsCall::Planned => planned_frame(&rig, &out, &plan, &mut sums, &mut unit),
        }
    }
    let cost = rig.cost();
    println!(
        "{rig_name} {poses}: {FRAMES} frames, {} vertices, {} influences",
        cost.vertices, cost.influences
    );
}
