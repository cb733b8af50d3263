//! camsim-analysis's integration tests, one module per file, linked into one test binary
//! (one link of the crate and its dependencies instead of one per file).

#[path = "../common/mod.rs"]
mod common;

mod camsim_frames;
mod emva;
mod glare;
mod qefit;
mod quality;
mod sfr;
