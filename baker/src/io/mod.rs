//! Readers and writers for the files the baker touches: parsing and writing only, into and out
//! of the types of [`crate::model`].

pub mod capture;
pub mod glb;
pub mod gltf_anim;
pub mod gltf_check;
pub mod gltf_mesh;
pub mod layout;
pub mod mask_image;
pub mod mask_sides;
pub mod npy;

/// `text` with control characters (terminal escapes, newlines) written as Rust escapes
/// (`\u{1b}`, `\n`), for printing names read from files on a terminal.
pub fn escape_control(text: &str) -> std::borrow::Cow<'_, str> {
    if !text.chars().any(char::is_control) {
        return std::borrow::Cow::Borrowed(text);
    }
    text.chars()
        .map(|c| {
            if c.is_control() {
                c.escape_default().to_string()
            } else {
                c.to_string()
            }
        })
        .collect::<String>()
        .into()
}

/// Largest input file (capture, layout, `.npy`, rig blob) read whole: 1 GiB. Every reader sizes
/// its allocations from the bytes it has, so this bounds them too.
pub const MAX_INPUT_BYTES: u64 = 1 << 30;

/// Reads a whole regular file of at most [`MAX_INPUT_BYTES`]: not a device (`/dev/zero`), a
/// pipe, or a file that would exhaust memory.
pub fn read_bounded(path: &std::path::Path) -> std::io::Result<Vec<u8>> {
    read_regular(path, MAX_INPUT_BYTES, MAX_INPUT_BYTES)
}

/// Reads the first `take` bytes of a regular file of at most `max_len` bytes (an
/// `InvalidInput` error for anything else that is not a regular file, `InvalidData` for a
/// longer file), allocating no more than it reads.
pub fn read_regular(path: &std::path::Path, max_len: u64, take: u64) -> std::io::Result<Vec<u8>> {
    use std::io::{Error, ErrorKind, Read};
    let not_regular = || Error::new(ErrorKind::InvalidInput, "not a regular file");
    // Checked before opening too: opening a pipe would block.
    if !std::fs::metadata(path)?.is_file() {
        return Err(not_regular());
    }
    let file = std::fs::File::open(path)?;
    let meta = file.metadata()?;
    if !meta.is_file() {
        return Err(not_regular());
    }
    if meta.len() > max_len {
        return Err(Error::new(
            ErrorKind::InvalidData,
            format!(
                "the file is {} bytes, more than the {max_len} bytes read",
                meta.len()
            ),
        ));
    }
    let take = take.min(meta.len());
    let mut bytes = Vec::with_capacity(take as usize);
    file.take(take).read_to_end(&mut bytes)?;
    Ok(bytes)
}
