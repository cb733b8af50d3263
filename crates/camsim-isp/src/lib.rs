//! camsim stage 4: demosaic and sRGB preview.
//!
//! [`demosaic_bilinear`] turns a Bayer [`camsim_core::RawImage`] into a planar linear
//! [`RgbImage`] (the paper's bilinear interpolation); [`ColorPipeline`] fits a sensor-RGB -> XYZ
//! matrix on the Macbeth ColorChecker under the scene illuminant and renders an 8-bit sRGB preview.

pub mod demosaic;

pub use demosaic::{demosaic_bilinear, RgbImage};
