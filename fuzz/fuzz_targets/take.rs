//! The take loader and decoder: a take that loads must decode every frame and seek anywhere
//! without panicking. The first byte chooses: 0, the rest is a whole take file; otherwise the
//! rest is a payload sealed with a fresh header, so the checksum passes and the fields and the
//! stream are what is fuzzed. The second byte picks frames to seek to.
#![no_main]

mod common;

use facebake_runtime::format::header::sealed_header;
use facebake_runtime::take::{TAKE_MAGIC, TAKE_VERSION};
use facebake_runtime::Take;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let [mode, seed, rest @ ..] = data else {
        return;
    };
    let bytes = if *mode == 0 {
        rest.to_vec()
    } else {
        let Ok(header) = sealed_header(&TAKE_MAGIC, TAKE_VERSION, rest) else {
            return;
        };
        [&header[..], rest].concat()
    };
    let Ok(take) = Take::from_bytes(&bytes) else {
        return;
    };
    let mut row = vec![None; take.marker_count()];
    let mut reader = take.reader();
    // A crafted take may hold billions of frames: a few thousand show the decoder's paths.
    for _ in 0..4096 {
        if !matches!(reader.next_frame(&mut row), Ok(Some(_))) {
            break;
        }
    }
    let frames = take.frame_count();
    for f in [
        0,
        usize::from(*seed),
        frames / 2,
        frames.saturating_sub(1),
        frames,
        frames + 1,
    ] {
        if reader.seek(f % (frames + 2)).is_ok() {
            let _ = reader.next_frame(&mut row);
            let _ = reader.next_frame(&mut row);
        }
    }
    // The baker's reader of takes goes through the same decoder (small takes only: it
    // decodes every frame).
    if frames <= 4096 {
        let _ = facebake::io::capture::read_capture(&common::scratch("take.fbt", &bytes));
    }
});
