//! camsim-scene3d's integration tests, one module per file, linked into one test binary
//! (one link of the crate and its dependencies instead of one per file).

mod builtin;
mod uplift;
