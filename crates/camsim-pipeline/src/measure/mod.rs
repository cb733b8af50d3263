//! The measurements, each on a plain request struct and returning a result struct that can write
//! its files: slanted-edge SFR of any image ([`sfr`]), ColorChecker chart statistics ([`chart`]),
//! region statistics ([`roi`]), EMVA 1288 series ([`emva`]: simulate and write a series, read and
//! analyse one), demosaicking quality on a zone plate ([`demosaic`]), a dual-pixel capture's
//! disparity ([`dual_pixel`]), the visual noise of a display image ([`visual_noise`]) and the QE correction fit ([`qe_fit`]). `camsim analyze`, `camsim fit` and the Python package call these.

pub mod chart;
pub mod demosaic;
pub mod dual_pixel;
pub mod emva;
pub mod mtf_fit;
pub mod psf;
pub mod qe_fit;
pub mod roi;
pub mod sfr;
pub mod visual_noise;

use crate::Result;
use camsim_io::atomic::write_bytes_atomic;
use std::path::Path;

/// Write text to `path` atomically.
pub(crate) fn write_text(path: &Path, text: &str) -> Result<()> {
    Ok(write_bytes_atomic(path, text.as_bytes())?)
}
