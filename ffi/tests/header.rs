//! The checked-in C header is what cbindgen generates from the crate now: CI fails when a
//! change to the ABI was not carried into `include/facebake.h`.

use std::path::Path;

#[test]
fn checked_in_header_is_up_to_date() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let config = cbindgen::Config::from_file(dir.join("cbindgen.toml")).expect("cbindgen.toml");
    let mut generated = Vec::new();
    cbindgen::Builder::new()
        .with_crate(dir)
        .with_config(config)
        .generate()
        .expect("cbindgen parses the crate")
        .write(&mut generated);
    let path = dir.join("include/facebake.h");
    if std::env::var_os("FACEBAKE_BLESS").is_some() {
        std::fs::write(&path, &generated).expect("write the header");
        return;
    }
    let checked_in = std::fs::read(&path).unwrap_or_default();
    assert!(
        generated == checked_in,
        "{} is stale (or missing): it differs from what cbindgen generates from ffi/src.\n\
         Regenerate it with:\n    FACEBAKE_BLESS=1 cargo test -p facebake-ffi --test header\n\
         and commit it.",
        path.display()
    );
}
