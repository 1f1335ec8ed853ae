//! facebake baker library.
pub mod io;
pub mod mesh;
