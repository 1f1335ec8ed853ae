//! Readers and writers for the files the baker touches.

pub mod capture;
pub mod control_triangles;
pub mod glb;
pub mod gltf_check;
pub mod gltf_mesh;
pub mod layout;
pub mod marker_groups;
pub mod mask_image;
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
