//! camsim-pipeline's integration tests, one module per file, linked into one test binary
//! (one link of the crate and its dependencies instead of one per file).

mod adaptive;
mod assets;
mod capture_quality;
mod chart;
mod compose;
mod config_door;
mod config_fuzz;
mod dual_pixel;
mod every_cfa;
mod flicker;
mod hdr_simulate;
mod isp_unprocess;
mod labels;
mod light_flicker;
mod light_groups;
mod preview_jpeg;
