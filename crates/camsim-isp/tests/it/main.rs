//! camsim-isp's integration tests, one module per file, linked into one test binary
//! (one link of the crate and its dependencies instead of one per file).

mod cfa_general;
mod color;
mod every_cfa;
mod hdr_merge;
