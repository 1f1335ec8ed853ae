//! The TOML and JSON layout readers; a layout that reads must write and read back unchanged.
#![no_main]

mod common;

use facebake::io::layout::{read_layout, write_layout};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((&which, body)) = data.split_first() else {
        return;
    };
    let name = if which % 2 == 0 {
        "layout.toml"
    } else {
        "layout.json"
    };
    let path = common::scratch(name, body);
    if let Ok(layout) = read_layout(&path) {
        let out = common::scratch(name.replace("layout", "back").as_str(), b"");
        if write_layout(&out, &layout).is_ok() {
            let back = read_layout(&out).expect("a written layout reads back");
            assert_eq!(back.markers, layout.markers);
        }
    }
});
