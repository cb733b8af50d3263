//! camsim-compose's integration tests, one module per file, linked into one test binary
//! (one link of the crate and its dependencies instead of one per file).

#[path = "../common/mod.rs"]
mod common;

mod bad_input;
mod camera_sampler;
mod determinism;
mod environment;
mod keypoints;
mod materials;
mod settle_stack;
mod spec_schema;
mod tabletop;
