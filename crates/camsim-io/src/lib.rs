//! camsim-io: the file formats of camsim.
//!
//! - [`atomic`]: every output file is written to a temporary name in its folder and renamed
//!   when complete (no partial files); output folders are staged and swapped in whole, and
//!   replaced only when their marker lists everything in them.
//! - [`claim`]: a single output file is replaced only when camsim wrote it (its signature,
//!   [`software`]) or the user forces it; [`lock`]: one run at a time per output, and the
//!   temporaries of killed runs removed.
//! - [`exr`]: spectral OpenEXR (Fichet et al. 2021 layout, as pbrt-v4 writes it) and
//!   single-channel EXR.
//! - [`dng`]: raw CFA DNG: write (uncompressed 16-bit) and read (camsim's and real cameras':
//!   uncompressed or lossless JPEG, strips or tiles, linearization, black/white levels, active area).
//! - [`ljpeg`]: the lossless JPEG (ITU-T T.81 process 14) decoder DNG needs.
//! - [`raster`]: 16-bit PNG/TIFF mosaics and 8-bit RGB PNG.
//! - [`rgb_image`]: colour photographs (PNG, JPEG, TIFF code values; OpenEXR linear) as f32 RGB.
//! - [`measurements`]: CSV inputs of the analyses (EMVA 1288 series lists, `sfr.csv` curves,
//!   chart patch means for the QE fit).
//! - [`spectra`]: spectra tables written as CSV.
//! - [`plot`]: line and scatter plots as PNG, with an embedded font (no system fonts needed).

pub mod atomic;
pub mod claim;
pub mod dng;
pub mod error;
pub mod exr;
pub mod ljpeg;
pub mod lock;
pub mod measurements;
pub mod plot;
pub mod ply;
pub mod raster;
mod registry;
pub mod rgb_image;
pub mod software;
pub mod spectra;
pub mod tiff;

pub use error::{IoError, Result};
