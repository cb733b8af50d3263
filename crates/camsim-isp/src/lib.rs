//! camsim stage 4: demosaic and sRGB preview.
//!
//! [`demosaic_bilinear`] turns a Bayer [`camsim_core::RawImage`] into a planar linear
//! [`RgbImage`] (the paper's bilinear interpolation); [`demosaic()`] adds Malvar-He-Cutler and
//! Hamilton-Adams ([`DemosaicMethod`]), [`demosaic_quality`] measures them on a zone plate.
//! [`ColorPipeline`] fits a sensor-RGB -> XYZ matrix on the Macbeth ColorChecker under the scene
//! illuminant from the sensor QE and renders an 8-bit sRGB preview; [`white_balance`] finds
//! per-channel gains (gray world, white patch, known illuminant), [`ccm`] fits a colour-correction
//! matrix on measured chart patches, [`output`] renders to sRGB or to a display model.
//! [`cfa_render`] takes every other CFA to a display image: monochrome (grey, no demosaic), RCCC
//! (clear as luminance, ISETCam's analog kernel or edge-aware), and multichannel tiles (CMY,
//! CMYG, RGB-IR, N channels: a 3 x N matrix fitted on the ColorChecker).

#![warn(missing_docs)]
// `!(x > 0.0)` is used on purpose: it rejects NaN along with the out-of-range values.

pub mod ccm;
pub mod cfa_general;
pub mod cfa_render;
pub mod color;
pub mod coring;
pub mod defect_correction;
pub mod demosaic;
pub mod demosaic_methods;
pub mod demosaic_quality;
pub mod denoise;
pub mod hdr_merge;
pub mod jpeg;
pub mod line_noise;
pub mod output;
pub mod preview;
pub mod shading_correction;
pub mod sharpen;
pub mod tone;
pub mod unprocess;
pub mod white_balance;

pub use color::{bradford_adaptation, camera_response, ColorPipeline, Mat3};
pub use coring::{
    render_display8, uncensored_offset, BlackModel, ChromaCoring, CHROMA_CORING_RADIUS_PX,
    CHROMA_CORING_SIGMAS, SRGB_LUMINANCE_WEIGHTS,
};
pub use demosaic::{demosaic_bilinear, try_demosaic_bilinear, RgbImage};
pub use demosaic_methods::{demosaic, DemosaicMethod, DEMOSAIC_METHODS};
pub use white_balance::{WhiteBalanceMethod, WHITE_BALANCE_METHODS};
