//! The C3D, TRC and CSV capture readers, chosen by the first byte; a capture that reads must
//! write and read back (the writers' promise).
#![no_main]

mod common;

use facebake::io::capture::{read_capture_with_units, write_csv};
use facebake::model::Units;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((&which, body)) = data.split_first() else {
        return;
    };
    let name = match which % 3 {
        0 => "take.c3d",
        1 => "take.trc",
        _ => "take.csv",
    };
    let path = common::scratch(name, body);
    let units = (which & 4 != 0).then_some(Units::Millimetres);
    if let Ok(capture) = read_capture_with_units(&path, units) {
        let out = common::scratch("back.csv", b"");
        if write_csv(&out, &capture).is_ok() {
            let back = read_capture_with_units(&out, None).expect("a written capture reads back");
            assert_eq!(back.frame_count(), capture.frame_count());
        }
    }
});
