//! facebake baker library (skeleton, filled in next).
pub mod io;
