//! camsim-lens's integration tests, one module per file, linked into one test binary
//! (one link of the crate and its dependencies instead of one per file).

mod camera;
mod ghosts;
mod optical_path;
mod prescriptions;
mod relative_illumination;
