//! camsim-optics's integration tests, one module per file, linked into one test binary
//! (one link of the crate and its dependencies instead of one per file).

mod aperture;
mod flare;
mod ghosts;
mod image;
mod measured_psf;
mod mtf_fit;
mod olpf;
mod rtf_shift_variant;
mod shading_config;
mod shift_variant;
mod wavefront;
