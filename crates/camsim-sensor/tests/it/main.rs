//! camsim-sensor's integration tests, one module per file, linked into one test binary
//! (one link of the crate and its dependencies instead of one per file).

#[path = "../common/mod.rs"]
mod common;

mod bad_config;
mod binning;
mod bracket;
mod cfa;
mod defects;
mod electronics;
mod flicker;
mod global_reset;
mod hdr;
mod isetcam_presets;
mod iso_black_level;
mod mean_signal;
mod noise;
mod pixel_vignetting;
mod presets;
mod qe_file;
