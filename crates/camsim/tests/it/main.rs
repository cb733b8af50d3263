//! camsim's integration tests, one module per file, linked into one test binary
//! (one link of the crate and its dependencies instead of one per file).

mod library;
mod motion;
mod pbrt_v4_output;
