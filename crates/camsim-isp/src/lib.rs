//! camsim stage 4: demosaic and sRGB preview.
//!
//! [`demosaic_bilinear`] turns a Bayer [`camsim_core::RawImage`] into a planar linear
//! [`RgbImage`] (the paper's bilinear interpolation); [`ColorPipeline`] fits a sensor-RGB -> XYZ
//! matrix on the Macbeth ColorChecker under the scene illuminant and renders an 8-bit sRGB preview.

#![warn(missing_docs)]
// `!(x > 0.0)` is used on purpose: it rejects NaN along with the out-of-range values.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod color;
pub mod demosaic;
pub mod preview;

pub use color::{bradford_adaptation, camera_response, ColorPipeline, Mat3};
pub use demosaic::{demosaic_bilinear, try_demosaic_bilinear, RgbImage};
