//! White balance: per-channel gains that make a neutral surface come out with R = G = B
//! (ISETCam `ipSet(ip, 'illuminant correction method', ...)`: `'gray world'`, `'white world'`,
//! `'none'`; plus the gains from a known illuminant and the sensor's QE).
//!
//! Gains are normalised so the green gain is 1 (the usual raw convention, as dcraw's multipliers
//! divided by the green one). The camera values of what the method takes to be neutral are
//! `1 / gains` (the DNG AsShotNeutral up to scale).
//!
//! - Gray world (G. Buchsbaum, "A spatial processor model for object colour perception",
//!   J. Franklin Inst. 310, 1980): the scene averages to gray, `gain_c = mean(G) / mean(c)`.
//! - White patch (E. H. Land, J. J. McCann, "Lightness and retinex theory", JOSA 61, 1971; the
//!   "white world" of ISETCam): the brightest surfaces are white. Robust form: the pixels whose
//!   R + G + B is at or above the `percentile`-th percentile, unclipped pixels only;
//!   `gain_c = mean(G) / mean(c)` over them.
//! - Illuminant: the camera response to a perfect white under the known illuminant,
//!   `w_c = sum QE_c(l) E(l) l dl` ([`crate::camera_response`]), `gain_c = w_G / w_c`; a gray
//!   surface of any reflectance under that illuminant then comes out neutral exactly.

use crate::color::camera_response;
use crate::demosaic::RgbImage;
use camsim_core::error::{CoreError, Result};
use camsim_core::names::{NameTable, Named};
use camsim_core::{Spectrum, WavelengthGrid};
use rayon::prelude::*;
use std::fmt;
use std::str::FromStr;

/// Default percentile of [`WhiteBalanceMethod::WhitePatch`].
pub const WHITE_PATCH_PERCENTILE: f64 = 99.0;

/// How the white-balance gains are found.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum WhiteBalanceMethod {
    /// No gains (camera (1, 1, 1) is taken as neutral).
    None,
    /// Gray world.
    GrayWorld,
    /// White patch (brightest percentile).
    WhitePatch,
    /// From the known scene illuminant and the sensor QE.
    #[default]
    Illuminant,
}

impl WhiteBalanceMethod {
    /// Every method, in the order of [`WHITE_BALANCE_METHODS`].
    pub const ALL: [WhiteBalanceMethod; 4] = {
        let e = WHITE_BALANCE_METHODS.entries;
        [e[0].value, e[1].value, e[2].value, e[3].value]
    };

    /// The method's name (`none`, `gray-world`, `white-patch`, `illuminant`).
    pub fn name(self) -> &'static str {
        WHITE_BALANCE_METHODS.name_of(self).unwrap_or("none")
    }
}

impl fmt::Display for WhiteBalanceMethod {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for WhiteBalanceMethod {
    type Err = CoreError;
    /// A name of [`WHITE_BALANCE_METHODS`] (ISETCam's `gray world`, `white world` too).
    fn from_str(s: &str) -> Result<Self> {
        WHITE_BALANCE_METHODS.get(s)
    }
}

/// The white-balance methods by name (`--white-balance`, Python's `method=`).
pub const WHITE_BALANCE_METHODS: NameTable<WhiteBalanceMethod> = NameTable {
    family: "white balance",
    entries: &[
        Named {
            name: "none",
            aliases: &[],
            about: "no gains: camera (1, 1, 1) is neutral",
            value: WhiteBalanceMethod::None,
        },
        Named {
            name: "gray-world",
            aliases: &["grey-world"],
            about: "the scene averages to gray (Buchsbaum 1980)",
            value: WhiteBalanceMethod::GrayWorld,
        },
        Named {
            name: "white-patch",
            aliases: &["white-world"],
            about: "the brightest unclipped pixels are white (Land and McCann 1971)",
            value: WhiteBalanceMethod::WhitePatch,
        },
        Named {
            name: "illuminant",
            aliases: &[],
            about: "from the known illuminant and the sensor QE",
            value: WhiteBalanceMethod::Illuminant,
        },
    ],
};

fn gains_from_neutral(neutral: [f64; 3], what: &str) -> Result<[f64; 3]> {
    if neutral.iter().any(|v| !(v.is_finite() && *v > 0.0)) {
        return Err(CoreError::invalid(
            "white balance",
            format!("{what}: the neutral estimate {neutral:?} needs every channel positive"),
        ));
    }
    Ok([neutral[1] / neutral[0], 1.0, neutral[1] / neutral[2]])
}

/// Gray-world gains of `img` (green = 1). Errors when a channel's mean is not positive.
pub fn gray_world_gains(img: &RgbImage) -> Result<[f64; 3]> {
    let n = img.pixels().max(1) as f64;
    let mean = |p: &[f32]| camsim_core::math::fixed_order_sum(p) / n;
    gains_from_neutral([mean(&img.r), mean(&img.g), mean(&img.b)], "gray world")
}

/// White-patch gains of `img` (green = 1): the mean colour of the pixels whose R + G + B is at or
/// above the `percentile`-th percentile (0..100), leaving out pixels with a channel at or above
/// `saturation` (black-subtracted DN; `None` keeps all). Errors on a bad percentile or when no
/// pixel qualifies.
#[allow(clippy::needless_range_loop)]
pub fn white_patch_gains(
    img: &RgbImage,
    percentile: f64,
    saturation: Option<f64>,
) -> Result<[f64; 3]> {
    if !(0.0..=100.0).contains(&percentile) {
        return Err(CoreError::invalid(
            "white balance",
            format!("white-patch percentile {percentile} is not in [0, 100]"),
        ));
    }
    let sat = saturation.unwrap_or(f64::INFINITY) as f32;
    let ok = |i: usize| img.r[i] < sat && img.g[i] < sat && img.b[i] < sat;
    let mut sums: Vec<f32> = (0..img.pixels())
        .filter(|&i| ok(i))
        .map(|i| img.r[i] + img.g[i] + img.b[i])
        .filter(|s| s.is_finite())
        .collect();
    if sums.is_empty() {
        return Err(CoreError::invalid(
            "white balance",
            "white patch: no unclipped pixel",
        ));
    }
    let k = ((sums.len() - 1) as f64 * percentile / 100.0).round() as usize;
    let (_, thr, _) = sums.select_nth_unstable_by(k, |a, b| a.total_cmp(b));
    let thr = *thr;
    let mut acc = [0.0f64; 3];
    for i in 0..img.pixels() {
        if ok(i) && img.r[i] + img.g[i] + img.b[i] >= thr {
            acc[0] += img.r[i] as f64;
            acc[1] += img.g[i] as f64;
            acc[2] += img.b[i] as f64;
        }
    }
    gains_from_neutral(acc, "white patch")
}

/// Gains from a known illuminant (relative SPD) and the sensor's per-channel QE on `grid`.
pub fn illuminant_gains(
    channel_qe: &[Vec<f64>; 3],
    grid: &WavelengthGrid,
    illuminant: &Spectrum,
) -> Result<[f64; 3]> {
    if channel_qe.iter().any(|q| q.len() != grid.len()) {
        return Err(CoreError::invalid(
            "white balance",
            "the QE curves do not match the wavelength grid",
        ));
    }
    let illum = illuminant.sample(grid);
    let white = camera_response(channel_qe, &illum, &vec![1.0; grid.len()], grid);
    gains_from_neutral(white, "illuminant")
}

/// Multiply each channel of `img` by its gain.
pub fn apply_gains(img: &mut RgbImage, gains: [f64; 3]) {
    for (plane, g) in [&mut img.r, &mut img.g, &mut img.b].into_iter().zip(gains) {
        let g = g as f32;
        plane.par_iter_mut().for_each(|v| *v *= g);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gaussian_qe(grid: &WavelengthGrid) -> [Vec<f64>; 3] {
        let g = |mu: f64, s: f64| {
            (0..grid.len())
                .map(|b| 0.6 * (-0.5 * ((grid.wavelength_nm(b) - mu) / s).powi(2)).exp())
                .collect()
        };
        [g(600.0, 30.0), g(540.0, 35.0), g(460.0, 25.0)]
    }

    #[test]
    fn a_gray_surface_under_the_illuminant_comes_out_neutral_exactly() {
        let grid = WavelengthGrid::default();
        let qe = gaussian_qe(&grid);
        for name in ["A", "D65", "F2"] {
            let illum = camsim_core::tables::illuminant(name).unwrap();
            let gains = illuminant_gains(&qe, &grid, &illum).unwrap();
            assert_eq!(gains[1], 1.0);
            for reflectance in [0.05, 0.18, 0.9] {
                let rho = vec![reflectance; grid.len()];
                let c = camera_response(&qe, &illum.sample(&grid), &rho, &grid);
                let out = [c[0] * gains[0], c[1] * gains[1], c[2] * gains[2]];
                assert!(
                    (out[0] / out[1] - 1.0).abs() < 1e-12 && (out[2] / out[1] - 1.0).abs() < 1e-12,
                    "{name} {out:?}"
                );
            }
        }
    }

    #[test]
    fn gray_world_and_white_patch_closed_forms() {
        // Two surfaces seen through channel sensitivities k = (2, 1, 0.5): a gray 0.2 on 3/4 of
        // the image and a white 0.9 on 1/4. Gray world: mean(c) = k_c (0.75 0.2 + 0.25 0.9), so
        // gains = (0.5, 1, 2) exactly; white patch (top 10 %) sees only the white: the same gains.
        let (rows, cols) = (8, 8);
        let k = [2.0f32, 1.0, 0.5];
        let mut img = RgbImage::zeros(rows, cols);
        for i in 0..rows * cols {
            let rho = if i % 4 == 0 { 0.9 } else { 0.2 };
            (img.r[i], img.g[i], img.b[i]) = (k[0] * rho, k[1] * rho, k[2] * rho);
        }
        let gw = gray_world_gains(&img).unwrap();
        let wp = white_patch_gains(&img, 90.0, None).unwrap();
        for g in [gw, wp] {
            assert!(
                (g[0] - 0.5).abs() < 1e-6 && g[1] == 1.0 && (g[2] - 2.0).abs() < 1e-6,
                "{g:?}"
            );
        }
        apply_gains(&mut img, gw);
        assert!((0..rows * cols)
            .all(|i| (img.r[i] - img.g[i]).abs() < 1e-6 && (img.b[i] - img.g[i]).abs() < 1e-6));
        // Clipped pixels are left out: saturate the white, the white patch falls back to the gray.
        let mut img2 = img.clone();
        img2.r[0] = 10.0;
        assert!(white_patch_gains(&img2, 100.0, Some(5.0)).is_ok());
    }

    #[test]
    fn bad_inputs_are_errors() {
        let img = RgbImage::zeros(4, 4);
        assert!(gray_world_gains(&img)
            .unwrap_err()
            .to_string()
            .contains("positive"));
        assert!(white_patch_gains(&img, 120.0, None).is_err());
        assert!("grey world".parse::<WhiteBalanceMethod>().is_ok());
        assert!("auto"
            .parse::<WhiteBalanceMethod>()
            .unwrap_err()
            .to_string()
            .contains("auto"));
    }
}
