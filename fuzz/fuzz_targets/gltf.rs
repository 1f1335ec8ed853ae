//! The glTF/GLB mesh loader (checks in `io/gltf_check.rs`, then the `gltf` crate's readers):
//! errors, never panics or large allocations. Run under `-rss_limit_mb` to catch the latter.
#![no_main]

mod common;

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let path = common::scratch("mesh.gltf", data);
    let _ = facebake::io::gltf_mesh::load_mesh(&path, None, None);
});
