//! A harness that links exactly the runtime's load and per-frame path (`Rig::from_bytes`,
//! `Rig::deform` for every deformer, and `Rig::play`: the capture stages) and nothing else, for `.ci/cross.sh` to build for
//! `thumbv6m-none-eabi` (no FPU) and check that no soft-float routine (`__aeabi_f*`,
//! `__aeabi_d*`, `__addsf3`, …) is linked: any float operation on that path would call one.
//!
//! It is never run. The inputs go through `black_box`, so the optimiser cannot drop any path.
#![no_std]
#![no_main]

use core::hint::black_box;
use core::panic::PanicInfo;

use cortex_m_rt::entry;
use facebake_runtime::format::records::MAX_MARKERS;
use facebake_runtime::{PlayState, Rig};

/// Output room: the harness is never run, so a few vertices are enough to link the path.
const VERTICES: usize = 16;

#[entry]
fn main() -> ! {
    let blob: &[u8] = black_box(&[]);
    let markers = black_box([[0i32; 3]; MAX_MARKERS]);
    let mut out = [[0i32; 3]; VERTICES];
    if let Ok(rig) = Rig::from_bytes(blob) {
        let m = rig.marker_count().min(MAX_MARKERS);
        let v = rig.vertex_count().min(VERTICES);
        black_box(rig.deform(&markers[..m], &mut out[..v]).is_ok());
        let actor = black_box([None; MAX_MARKERS]);
        let mut state = PlayState::new();
        black_box(rig.play(&mut state, &actor[..m], &mut out[..v]).is_ok());
        black_box(&out);
    }
    #[cfg(feature = "float-canary")]
    black_box(black_box(1.5f32) * black_box(2.5f32));
    loop {
        cortex_m::asm::nop();
    }
}

#[panic_handler]
fn panic(_: &PanicInfo) -> ! {
    loop {
        cortex_m::asm::nop();
    }
}
