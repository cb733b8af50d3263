//! Display models: how RGB code values become spectral radiance (ISETCam's `displayCreate` /
//! `sceneFromFile` with a display): each primary has a spectral power distribution at full
//! drive, and a transfer function maps code values to primary intensities. The radiance of a pixel
//! is `L(lambda) = sum_i t(v_i) spd_i(lambda)` (ISETCam `displayGet(d, 'spd')` times the linear
//! primary levels from the gamma table).
//!
//! Built in: `srgb`, a display calibrated to IEC 61966-2-1 (sRGB): its three primaries have
//! exactly the sRGB primaries' chromaticities and sum to the D65 white, with the sRGB transfer
//! function. A real display's primaries are narrow-band; ours are smooth: each is a non-negative
//! mix of three Gaussian bands (462 nm / 10 nm, 540 nm / 18 nm, 620 nm / 15 nm, our choice, not a
//! measured display), solved on the scene's wavelength grid so that the CIE 1931 tristimulus
//! values of every primary are the sRGB matrix's columns. An sRGB image therefore reproduces its
//! own colours (XYZ) exactly; the spectra under them are one of many metamers.
//!
//! From a file: a CSV `wavelength_nm,r,g,b` with each primary's spectral radiance at full drive,
//! W/(sr m^2 nm) (a measured display), and a transfer function given in the scene config.

use camsim_core::colorimetry::{linear_srgb_to_xyz, srgb_decode, Cmfs};
use camsim_core::error::{CoreError, Result};
use camsim_core::spectrum::Extrapolation;
use camsim_core::units::LUMINOUS_EFFICACY_LM_PER_W;
use camsim_core::WavelengthGrid;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// A display's transfer function: code value in [0, 1] -> linear primary level in [0, 1].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(untagged)]
pub enum Transfer {
    /// A power law `level = v^gamma` (ISETCam's gamma table of a CRT-like display).
    Gamma(f64),
    /// `"srgb"` (IEC 61966-2-1 piecewise curve) or `"linear"` (code values are levels).
    Named(String),
}

impl Transfer {
    /// Check the transfer function; `key` names the config key in errors.
    pub fn validate(&self, key: &str) -> Result<()> {
        match self {
            Transfer::Gamma(g) if !(*g > 0.0 && g.is_finite()) => Err(CoreError::invalid(
                key,
                format!("gamma {g} is not a positive number"),
            )),
            Transfer::Named(s) if !matches!(s.to_ascii_lowercase().as_str(), "srgb" | "linear") => {
                Err(CoreError::invalid(
                    key,
                    format!("'{s}' is not 'srgb', 'linear' or a gamma exponent"),
                ))
            }
            _ => Ok(()),
        }
    }

    /// The linear level of code value `v` (clipped to [0, 1] first).
    #[inline]
    pub fn level(&self, v: f32) -> f32 {
        let v = v.clamp(0.0, 1.0);
        match self {
            Transfer::Gamma(g) => v.powf(*g as f32),
            Transfer::Named(s) if s.eq_ignore_ascii_case("linear") => v,
            Transfer::Named(_) => srgb_decode(v as f64) as f32,
        }
    }
}

/// A display on a wavelength grid: the spectral radiance of each primary at full drive,
/// W/(sr m^2 nm), one value per band.
#[derive(Debug, Clone, PartialEq)]
pub struct Display {
    /// Red, green and blue primaries' spectral radiance at full drive, W/(sr m^2 nm).
    pub primaries_w_per_sr_m2_nm: [Vec<f64>; 3],
}

/// The Gaussian bands the built-in `srgb` display mixes: (centre nm, standard deviation nm).
const SRGB_BANDS_NM: [(f64, f64); 3] = [(462.0, 10.0), (540.0, 18.0), (620.0, 15.0)];

impl Display {
    /// The built-in sRGB display on `grid`, white (R = G = B = 1) at `white_luminance_cd_m2`.
    pub fn srgb(grid: &WavelengthGrid, white_luminance_cd_m2: f64) -> Result<Display> {
        let cmfs = Cmfs::on(grid);
        let bands: Vec<Vec<f64>> = SRGB_BANDS_NM
            .iter()
            .map(|(c, s)| {
                (0..grid.len())
                    .map(|i| (-0.5 * ((grid.wavelength_nm(i) - c) / s).powi(2)).exp())
                    .collect()
            })
            .collect();
        // Columns: XYZ of each band; solve T a_i = XYZ of primary i (white Y = L / 683).
        let t = nalgebra::Matrix3::from_fn(|k, j| cmfs.xyz(&bands[j])[k]);
        let inv = t.try_inverse().filter(|m| m.iter().all(|v| v.is_finite())).ok_or_else(|| {
            CoreError::invalid(
                "scene.display",
                format!("the built-in sRGB display needs the 420-650 nm range; the grid is {}-{} nm", grid.start_nm, grid.end_nm()),
            )
        })?;
        let y_white = white_luminance_cd_m2 / LUMINOUS_EFFICACY_LM_PER_W;
        let mut primaries: [Vec<f64>; 3] = Default::default();
        for (i, p) in primaries.iter_mut().enumerate() {
            let mut e = [0.0; 3];
            e[i] = 1.0;
            let target = linear_srgb_to_xyz(e).map(|v| v * y_white);
            let a = inv * nalgebra::Vector3::from(target);
            if a.iter().any(|w| *w < 0.0) {
                return Err(CoreError::invalid(
                    "scene.display",
                    format!("on the grid {}-{} nm the sRGB primaries cannot be made from non-negative spectra (weights {a:?})", grid.start_nm, grid.end_nm()),
                ));
            }
            *p = (0..grid.len())
                .map(|b| (0..3).map(|j| a[j] * bands[j][b]).sum())
                .collect();
        }
        Ok(Display {
            primaries_w_per_sr_m2_nm: primaries,
        })
    }

    /// A display from a CSV of primaries (`wavelength_nm` and three columns found by name: `r`/
    /// `red`, `g`/`green`, `b`/`blue`, or else the first three), spectral radiance at full drive in
    /// W/(sr m^2 nm), sampled on `grid` (zero outside the file's range).
    pub fn from_file(path: &Path, grid: &WavelengthGrid) -> Result<Display> {
        let key = format!("scene.display ({})", path.display());
        let table = camsim_core::spectrum_csv::load_spectra(path)
            .map_err(|e| CoreError::invalid(&key, e.to_string()))?;
        if table.len() < 3 {
            return Err(CoreError::invalid(
                &key,
                format!(
                    "has {} spectra; a display needs three primaries (r, g, b)",
                    table.len()
                ),
            ));
        }
        let pick = |names: &[&str], fallback: usize| {
            names
                .iter()
                .find_map(|n| table.index_of(n))
                .unwrap_or(fallback)
        };
        let idx = [
            pick(&["r", "red"], 0),
            pick(&["g", "green"], 1),
            pick(&["b", "blue"], 2),
        ];
        let mut primaries: [Vec<f64>; 3] = Default::default();
        for ((p, i), name) in primaries.iter_mut().zip(idx).zip(["r", "g", "b"]) {
            let s = table
                .spectrum_at(i)
                .map_err(|e| CoreError::invalid(&key, e.to_string()))?
                .with_extrapolation(Extrapolation::Zero);
            *p = s.sample(grid);
            if let Some((b, v)) = p
                .iter()
                .enumerate()
                .find(|(_, v)| !(v.is_finite() && **v >= 0.0))
            {
                return Err(CoreError::invalid(
                    &key,
                    format!(
                        "primary {name} is {v} at {} nm: radiance must be >= 0",
                        grid.wavelength_nm(b)
                    ),
                ));
            }
        }
        if primaries.iter().all(|p| p.iter().all(|v| *v == 0.0)) {
            return Err(CoreError::invalid(
                &key,
                format!(
                    "no primary emits between {} and {} nm",
                    grid.start_nm,
                    grid.end_nm()
                ),
            ));
        }
        Ok(Display {
            primaries_w_per_sr_m2_nm: primaries,
        })
    }

    /// Luminance of each primary at full drive, cd/m^2.
    pub fn primary_luminance_cd_m2(&self, grid: &WavelengthGrid) -> [f64; 3] {
        let cmfs = Cmfs::on(grid);
        [0, 1, 2].map(|i| cmfs.luminance_cd_m2(&self.primaries_w_per_sr_m2_nm[i]))
    }
}
