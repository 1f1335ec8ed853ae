//! Sets the `facebake_smlad` cfg on Thumb-2 targets whose cores all have `SMLAD` (the DSP
//! extension of ARMv7E-M: the Cortex-M4 and M7; ARMv7-A in Thumb mode, which CI also runs
//! under qemu-user to test the same kernels), where the linear deformer uses it. Stable Rust does
//! not expose the `dsp` target feature to `cfg`, so the target name decides.
fn main() {
    println!("cargo::rustc-check-cfg=cfg(facebake_smlad)");
    println!("cargo::rerun-if-changed=build.rs");
    let target = std::env::var("TARGET").unwrap_or_default();
    if target.starts_with("thumbv7em-") || target.starts_with("thumbv7neon-") {
        println!("cargo::rustc-cfg=facebake_smlad");
    }
}
