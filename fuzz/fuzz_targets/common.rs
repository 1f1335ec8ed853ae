//! Shared by the targets: the readers take paths, so each input is written to a scratch file
//! (one per process and name) first.

use std::path::PathBuf;

/// Writes `data` to this process's scratch file `name` and returns its path.
pub fn scratch(name: &str, data: &[u8]) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("facebake-fuzz-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("scratch dir");
    let path = dir.join(name);
    std::fs::write(&path, data).expect("scratch file");
    path
}
