//! camsim-scene's integration tests, one module per file, linked into one test binary
//! (one link of the crate and its dependencies instead of one per file).

mod glare_target;
mod hdr_chart;
mod hdr_lights;
mod patterns;
mod rgb_dead_leaves_chart;
