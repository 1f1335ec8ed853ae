//! The rig loader and the per-frame calls: a blob that loads must deform, give normals and play
//! any frame without panicking. The first bytes choose the markers, the rest is the blob.
#![no_main]

use facebake_runtime::{PlayState, Rig};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if data.len() < 8 {
        return;
    }
    let (seed, blob) = data.split_at(8);
    let Ok(rig) = Rig::from_bytes(blob) else {
        return;
    };
    if rig.vertex_count() > 1 << 16 || rig.marker_count() > 1 << 10 {
        return;
    }
    let value = |i: usize| {
        i32::from_le_bytes([
            seed[i % 8],
            seed[(i + 1) % 8],
            seed[(i + 2) % 8],
            seed[(i + 3) % 8],
        ])
    };
    let markers: Vec<[i32; 3]> = (0..rig.marker_count())
        .map(|m| [value(3 * m), value(3 * m + 1), value(3 * m + 2)])
        .collect();
    let mut out = vec![[0i32; 3]; rig.vertex_count()];
    let _ = rig.deform(&markers, &mut out);
    // Normals of whatever came out, fanned and planned (a crafted blob's fans need not agree
    // with each other, so only the absence of a panic is asked).
    let mut normals = vec![[0i16; 3]; rig.vertex_count()];
    let _ = rig.normals(&out, &mut normals);
    let mut triangles = vec![[0u32; 3]; rig.normals_plan_len()];
    if let Ok(plan) = rig.plan_normals(&mut triangles) {
        let mut sums = vec![[0i64; 3]; rig.vertex_count()];
        let _ = rig.normals_planned(&out, &plan, &mut sums, &mut normals);
    }
    let actor: Vec<Option<[i32; 3]>> = markers
        .iter()
        .enumerate()
        .map(|(m, p)| (seed[m % 8] & 1 == 0).then_some(*p))
        .collect();
    let mut state = PlayState::new();
    for _ in 0..3 {
        let _ = rig.play(&mut state, &actor, &mut out);
    }
});
