//! camsim-io's integration tests, one module per file, linked into one test binary
//! (one link of the crate and its dependencies instead of one per file).

mod cfa_dng;
mod real_camera_dng;
mod spectra_csv_write;
