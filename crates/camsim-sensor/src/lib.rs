//! camsim stage 3: irradiance -> electrons -> volts -> digital values, the ISETCam sensor model.
//!
//! A [`Sensor`] is built from a [`SensorConfig`] (a TOML file or a built-in preset: `imx363`
//! with every value of the paper's Table 1 and the published IMX363 QE, `pixel4a` with the paper's
//! corrected QE, `pixel4a-raw10` with the phone's own raw format (10-bit, black level 64, white
//! level 1023), `ideal` for tests, and ISETCam's own MT9V024 and AR0132AT sensor files read by
//! [`isetcam`]). [`Sensor::compute`] follows ISETCam's `sensorCompute`:
//!
//! 1. the sensor-plane irradiance is integrated over each pixel's photodetector (pitch^2 x fill factor);
//! 2. electrons = sum_lambda E QE_c lambda/(h c) d lambda x area x t for the pixel's CFA channel
//!    (QE = colour filter x IR-cut x pixel QE, then the optional correction `[r',g',b'] = [r,g,b] M`);
//! 3. dark current, photon shot noise (Poisson), PRNU gain and DSNU offset maps (fixed per sensor),
//!    read noise (per frame);
//! 4. analog gain and offset `v = (v + offset) / gain`, clipping to the voltage swing, and
//!    quantization `DN = round(v / (swing / 2^bits) + black_level_dn)` clipped to [0, 2^bits - 1]
//!    (`black_level_dn` 0 by default; `iso` sets the gain to base_iso / iso).
//!
//! [`Sensor::compute_bracket`] takes a list of exposure times (bracketing, bursts).
//!
//! Colour filter arrays: a Bayer `cfa`, the presets `RGBW` and `quad-bayer`, or any tile of up
//! to 8 x 8 named filters (`cfa_pattern`, filters from the QE's r, g, b, `w` = panchromatic,
//! or `[qe.filters]` / extra QE-file columns); [`Sensor::cfa_layout`], [`Frame::mean_electrons_by_filter`].
//! Pixel vignetting: `[pixel_vignetting]` ([`pixel_vignetting`]).
//! HDR pixels (dual conversion gain, split pixel): `[hdr]` ([`hdr`], [`Sensor::compute_hdr`]).
//! Charge and digital binning of k x k blocks: `[binning]` ([`binning`]).
//! Modulated light (LED flicker) integrated over each row's window: [`Capture::light`] ([`flicker`]).
//!
//! Randomness is keyed on (seed, stage, frame, row), so frames are bit-identical for any thread count.
//! [`Sensor::predicted_noise_dn`] gives the matching EMVA 1288 noise model and
//! [`Sensor::emva_series`] the frame stacks an EMVA 1288 analysis needs.

#![warn(missing_docs)]

pub mod binning;
mod cfa_compute;
pub mod compute;
pub mod config;
pub mod defects;
pub mod dual_pixel;
pub mod emva;
pub mod error;
pub mod flicker;
pub mod hdr;
mod hdr_config;
pub mod isetcam;
pub mod light_parts;
mod normal;
pub mod pixel_vignetting;
mod poisson;
pub mod presets;
pub mod sensor;

pub use compute::{
    exposure_in_range, Capture, Exposure, Frame, GlobalReset, MAX_EXPOSURE_S, POISSON_EXACT_BELOW_E,
};
pub use config::{BinningConfig, BinningMode, NoiseSwitches, QeConfig, SensorConfig};
pub use dual_pixel::dual_pixel_sum;
pub use emva::EmvaLevel;
pub use error::{Result, SensorError};
pub use flicker::{Flicker, LightTiming, Waveform};
pub use hdr::{HdrConfig, HdrFrame, HdrMode, HdrModel};
pub use light_parts::LightPart;
pub use sensor::{NoiseBreakdown, Sensor};
