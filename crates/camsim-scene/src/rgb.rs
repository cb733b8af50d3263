//! `kind = "rgb"`: a colour photograph (PNG, JPEG, TIFF or OpenEXR) shown on a display model
//! becomes a spectral radiance scene, as ISETCam's `sceneFromFile(file, 'rgb', meanLuminance,
//! display)`: per pixel, code values -> the display's transfer function -> primary levels ->
//! `L(lambda) = sum_i level_i spd_i(lambda)` ([`crate::display`]). OpenEXR values are linear
//! levels already (no transfer function; values above 1 are kept: an HDR image drives the display
//! beyond its white).

use crate::display::{Display, Transfer};
use camsim_core::error::{CoreError, Result};
use camsim_core::{Quantity, SpectralImage, WavelengthGrid};
use camsim_io::rgb_image::{read_rgb_image, RgbEncoding};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

fn default_display() -> String {
    "srgb".to_string()
}
fn default_white() -> f64 {
    // IEC 61966-2-1's reference display luminance.
    80.0
}
fn default_fov() -> f64 {
    10.0
}
fn default_distance() -> f64 {
    1.2
}

/// An RGB image shown on a display (ISETCam `sceneFromFile`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct RgbScene {
    /// The image: PNG, JPEG or TIFF (8/16-bit code values) or OpenEXR (linear `R`, `G`, `B`).
    pub path: PathBuf,
    /// The display: `"srgb"` (built in: sRGB primaries and D65 white with smooth spectra) or a
    /// CSV of measured primaries (`wavelength_nm,r,g,b`, spectral radiance at full drive,
    /// W/(sr m^2 nm)).
    #[serde(default = "default_display")]
    pub display: String,
    /// Transfer function of code values: `"srgb"`, `"linear"` or a gamma exponent (e.g. 2.2).
    /// Default: `"srgb"` for the built-in display, 2.2 for a display file. Not used for OpenEXR.
    #[serde(default)]
    pub transfer: Option<Transfer>,
    /// Luminance of the built-in display's white (R = G = B = 1), cd/m^2 (default 80, the sRGB
    /// reference display). A display file's primaries are absolute already.
    #[serde(default = "default_white")]
    pub white_luminance_cd_m2: f64,
    /// Rescale to this mean luminance, cd/m^2 (ISETCam's `meanLuminance`); absent = the display's
    /// own levels.
    #[serde(default)]
    pub mean_luminance_cd_m2: Option<f64>,
    /// Horizontal field of view, degrees, in (0, 180); default 10.
    #[serde(default = "default_fov")]
    pub fov_deg: f64,
    /// Distance from the lens to the display, m; default 1.2.
    #[serde(default = "default_distance")]
    pub distance_m: f64,
    /// Wavelength grid, nm (optional; the default is 400-700 nm every 10 nm).
    #[serde(default)]
    pub wavelengths: Option<WavelengthGrid>,
}

impl RgbScene {
    /// The display model on `grid`.
    pub fn display_on(&self, grid: &WavelengthGrid) -> Result<Display> {
        if self.display.eq_ignore_ascii_case("srgb") {
            if !(self.white_luminance_cd_m2 > 0.0 && self.white_luminance_cd_m2.is_finite()) {
                return Err(CoreError::invalid(
                    "scene.white_luminance_cd_m2",
                    format!("{} is not a positive luminance", self.white_luminance_cd_m2),
                ));
            }
            Display::srgb(grid, self.white_luminance_cd_m2)
        } else if crate::looks_like_file(&self.display) {
            Display::from_file(std::path::Path::new(&self.display), grid)
        } else {
            Err(CoreError::invalid(
                "scene.display",
                format!(
                    "'{}' is neither 'srgb' nor a display file (.csv)",
                    self.display
                ),
            ))
        }
    }

    /// The transfer function in use.
    pub fn transfer_fn(&self) -> Result<Transfer> {
        let t = match &self.transfer {
            Some(t) => t.clone(),
            None if self.display.eq_ignore_ascii_case("srgb") => Transfer::Named("srgb".into()),
            None => Transfer::Gamma(2.2),
        };
        t.validate("scene.transfer")?;
        Ok(t)
    }
}

/// Build the radiance image of an RGB scene on `grid`.
pub(crate) fn create_rgb(c: &RgbScene, grid: &WavelengthGrid) -> Result<SpectralImage> {
    let display = c.display_on(grid)?;
    let transfer = c.transfer_fn()?;
    let file =
        read_rgb_image(&c.path).map_err(|e| CoreError::invalid("scene.path", e.to_string()))?;
    let n = file.rows * file.cols;
    // The photo's pixels and their linear levels (3 f32 each) beside the radiance cube.
    crate::check_memory(
        file.rows,
        file.cols,
        grid.len(),
        &[("RGB pixels and levels", (n as u64).saturating_mul(24))],
    )?;
    let levels: Vec<f32> = match file.encoding {
        RgbEncoding::CodeValues => file.rgb.par_iter().map(|v| transfer.level(*v)).collect(),
        RgbEncoding::Linear => {
            if let Some(i) = file.rgb.iter().position(|v| *v < 0.0) {
                let p = i / 3;
                return Err(CoreError::invalid(
                    "scene.path",
                    format!(
                        "{}: pixel (row {}, col {}) has a negative level {}",
                        c.path.display(),
                        p / file.cols,
                        p % file.cols,
                        file.rgb[i]
                    ),
                ));
            }
            file.rgb
        }
    };
    let mut img = crate::blank_radiance(c.fov_deg, c.distance_m, file.rows, file.cols, grid)?;
    img.data
        .par_chunks_mut(n)
        .enumerate()
        .for_each(|(b, plane)| {
            let spd = display
                .primaries_w_per_sr_m2_nm
                .each_ref()
                .map(|p| p[b] as f32);
            for (o, px) in plane.iter_mut().zip(levels.chunks_exact(3)) {
                *o = px[0] * spd[0] + px[1] * spd[1] + px[2] * spd[2];
            }
        });
    debug_assert_eq!(img.quantity, Quantity::Radiance);
    if let Some(l) = c.mean_luminance_cd_m2 {
        crate::scale_to_luminance(&mut img, l)?;
    }
    Ok(img)
}
