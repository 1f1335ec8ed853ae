//! The mask image reader on a small mesh (two triangles): errors, never panics or large
//! allocations.
#![no_main]

mod common;

use libfuzzer_sys::fuzz_target;

const POSITIONS: [[f64; 3]; 4] = [
    [-1.0, -1.0, 1.0],
    [1.0, -1.0, 1.0],
    [1.0, 1.0, 1.0],
    [-1.0, 1.0, 1.0],
];
const TRIANGLES: [[u32; 3]; 2] = [[0, 1, 2], [0, 2, 3]];

fuzz_target!(|data: &[u8]| {
    let path = common::scratch("mask.png", data);
    let _ = facebake::io::mask_image::read_sides(&path, &POSITIONS, &TRIANGLES);
});
