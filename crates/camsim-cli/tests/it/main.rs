//! camsim-cli's integration tests, one module per file, linked into one test binary
//! (one link of the crate and its dependencies instead of one per file).

#[path = "../common/mod.rs"]
mod common;

mod bad_input_cli;
mod chart_cli;
mod chart_reflectances;
mod cli;
mod compare_cli;
mod config_reference;
mod docs_links;
mod documented_commands;
mod every_cfa_cli;
mod fit_mtf_cli;
mod hdr_sensor_cli;
mod import_circles;
mod isp_chain;
mod isp_doors;
mod lens_camera_simulate;
mod lens_shading_cli;
mod names_cli;
mod optics_cli;
mod pipeline_cli;
mod reliability_cli;
mod render_cli;
mod rtf_optics_cli;
mod sensor_iso_bracket_cli;
mod sfr_cli;
mod stage_chain;
mod test_layout;
mod unprocess_cli;
mod visual_noise_cli;
