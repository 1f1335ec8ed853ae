//! facebake runtime (skeleton, filled in next).
#![no_std]
#![forbid(unsafe_code)]
