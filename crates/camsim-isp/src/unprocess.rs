//! The inverse ISP, "unprocessing" (Brooks, Mildenhall, Xue, Chen, Sharlet and Barron,
//! "Unprocessing Images for Learned Raw Denoising", CVPR 2019, sec. 3): an 8-bit sRGB photo ->
//! inverse sRGB transfer function (IEC 61966-2-1) -> inverse tone curve -> inverse colour matrix
//! -> inverse white balance and exposure -> the mosaic of the sensor's CFA: the camera's
//! expected signal, DN above black, to which the sensor's noise is then added (Brooks et al.
//! add shot and read noise; here [`add_sensor_noise`]: Poisson electrons plus Gaussian read
//! noise, the EMVA 1288 linear model, then the ADC's rounding and clip).
//!
//! The forward ISP this inverts ([`crate::ColorPipeline::render_srgb8_toned`] and
//! [`crate::coring::render_display8`]): camera c -> v = M (s c / w) (M camera -> linear sRGB,
//! s the exposure scale, w the white-balance gains that are not in M) -> the tone curve on the
//! luminance Y (v tone(Y) / Y) -> clip to [0, 1] -> sRGB encoding -> 8 bits. Clipping is not
//! invertible: a code of 0 or 255 unprocesses to the clip level. Chroma coring (near black only)
//! and the rounding to 8 bits (half a code) are the other losses.

use crate::color::{mat3_inverse, Mat3};
use crate::tone::ToneCurve;
use camsim_core::colorimetry;
use camsim_core::error::{CoreError, Result};
use camsim_core::rng::{keyed, stage};
use camsim_core::{CfaLayout, RawImage};
use rand_distr::{Distribution, Poisson, StandardNormal};
use rayon::prelude::*;

/// Frame key of [`add_sensor_noise`]'s streams within the sensor's temporal-noise stage (far
/// from any capture's frame index).
const UNPROCESS_FRAME_KEY: u64 = 1 << 48;

/// What the forward ISP did, to be undone.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Unprocess {
    /// Camera RGB (after `white_balance_gains`) -> linear sRGB (D65): the Isp's colour matrix.
    pub camera_to_linear_srgb: Mat3,
    /// Gains the ISP applied per channel before the matrix (1 where the matrix holds them).
    pub white_balance_gains: [f64; 3],
    /// The exposure scale the ISP multiplied the camera values by.
    pub exposure_scale: f64,
    /// The tone curve applied to the luminance.
    pub tone: ToneCurve,
}

/// Inverse of the tone curve: the linear value whose display value is `d` in [0, 1].
/// Reinhard's v (1 + v / w^2) / (1 + v) = d and the ACES fit are quadratics in v (their positive
/// root); clip is the identity.
pub fn inverse_tone(curve: ToneCurve, d: f64) -> f64 {
    let d = d.clamp(0.0, 1.0);
    let root = |a: f64, b: f64, c: f64| {
        // Positive root of a v^2 + b v + c = 0 (c <= 0 < a or a < 0 with the root in range).
        if a.abs() < 1e-15 {
            return -c / b;
        }
        let disc = (b * b - 4.0 * a * c).max(0.0).sqrt();
        let (r1, r2) = ((-b + disc) / (2.0 * a), (-b - disc) / (2.0 * a));
        if r1 >= 0.0 && (r2 < 0.0 || r1 <= r2) {
            r1
        } else {
            r2.max(0.0)
        }
    };
    match curve {
        ToneCurve::Clip => d,
        // v^2 / w^2 + v (1 - d) - d = 0.
        ToneCurve::Reinhard { white } => root(1.0 / (white * white), 1.0 - d, -d),
        // d (2.43 v^2 + 0.59 v + 0.14) = 2.51 v^2 + 0.03 v.
        ToneCurve::Filmic => {
            if d >= 1.0 {
                // The fit reaches 1 at v = 10.2 (and saturates at 2.51 / 2.43 > 1): take that.
                return root(2.43 - 2.51, 0.59 - 0.03, 0.14);
            }
            root(2.43 * d - 2.51, 0.59 * d - 0.03, 0.14 * d)
        }
    }
}

impl Unprocess {
    /// Camera RGB (DN above black, before white balance) of each pixel of an interleaved 8-bit
    /// sRGB image, as three planes.
    pub fn camera_rgb(&self, rows: usize, cols: usize, srgb8: &[u8]) -> Result<crate::RgbImage> {
        if srgb8.len() != rows * cols * 3 || rows == 0 || cols == 0 {
            return Err(CoreError::invalid(
                "unprocess",
                format!("{} bytes for {rows} x {cols} RGB pixels", srgb8.len()),
            ));
        }
        if !(self.exposure_scale > 0.0) || !self.exposure_scale.is_finite() {
            return Err(CoreError::invalid(
                "unprocess",
                format!("exposure scale {}: must be positive", self.exposure_scale),
            ));
        }
        if self
            .white_balance_gains
            .iter()
            .any(|g| !(*g > 0.0) || !g.is_finite())
        {
            return Err(CoreError::invalid(
                "unprocess",
                format!(
                    "white-balance gains {:?}: must be positive",
                    self.white_balance_gains
                ),
            ));
        }
        let inv = mat3_inverse(&self.camera_to_linear_srgb)
            .ok_or_else(|| CoreError::invalid("unprocess", "the colour matrix is singular"))?;
        // Inverse sRGB transfer of each code (IEC 61966-2-1).
        let lut: Vec<f64> = (0..256)
            .map(|i| colorimetry::srgb_decode(i as f64 / 255.0))
            .collect();
        let y_w = crate::coring::SRGB_LUMINANCE_WEIGHTS;
        let mut out = crate::RgbImage::zeros(rows, cols);
        let k = [0, 1, 2].map(|c| 1.0 / (self.exposure_scale * self.white_balance_gains[c]));
        let toned = self.tone != ToneCurve::Clip;
        let camera: Vec<[f32; 3]> = srgb8
            .par_chunks_exact(3)
            .map(|px| {
                let mut v = [
                    lut[px[0] as usize],
                    lut[px[1] as usize],
                    lut[px[2] as usize],
                ];
                if toned {
                    let yd = y_w[0] * v[0] + y_w[1] * v[1] + y_w[2] * v[2];
                    if yd > 0.0 {
                        let f = inverse_tone(self.tone, yd) / yd;
                        v = v.map(|x| x * f);
                    }
                }
                let cam = colorimetry::mat3_mul_vec(&inv, v);
                [0, 1, 2].map(|c| (cam[c] * k[c]) as f32)
            })
            .collect();
        for (i, c) in camera.iter().enumerate() {
            (out.r[i], out.g[i], out.b[i]) = (c[0], c[1], c[2]);
        }
        Ok(out)
    }

    /// The linear mosaic of `layout` (filters r, g, b) of an 8-bit sRGB image: at each site the
    /// camera value of its filter's channel, DN above black, row-major. Errors on a CFA with
    /// other filters (an RGBW or multichannel tile has no 3 x 3 inverse).
    pub fn mosaic_dn(
        &self,
        rows: usize,
        cols: usize,
        srgb8: &[u8],
        layout: &CfaLayout,
    ) -> Result<Vec<f32>> {
        let channel: Vec<usize> = layout
            .filters()
            .iter()
            .map(|f| match f.as_str() {
                "r" => Ok(0),
                "g" => Ok(1),
                "b" => Ok(2),
                other => Err(CoreError::invalid(
                    "unprocess",
                    format!(
                        "the CFA {} has a filter '{other}': unprocessing takes r, g, b filters only",
                        layout.name()
                    ),
                )),
            })
            .collect::<Result<_>>()?;
        let rgb = self.camera_rgb(rows, cols, srgb8)?;
        let mut out = vec![0f32; rows * cols];
        out.par_chunks_mut(cols).enumerate().for_each(|(r, line)| {
            for (c, o) in line.iter_mut().enumerate() {
                *o = rgb.plane(channel[layout.filter_at(r, c)])[r * cols + c];
            }
        });
        Ok(out)
    }
}

/// Expected electrons of a mosaic in DN above black: DN / K (K DN per electron).
pub fn dn_to_electrons(mosaic_dn: &[f32], k_dn_per_e: f64) -> Result<Vec<f32>> {
    if !(k_dn_per_e > 0.0) || !k_dn_per_e.is_finite() {
        return Err(CoreError::invalid(
            "unprocess",
            format!("conversion gain {k_dn_per_e} DN/e: must be positive"),
        ));
    }
    Ok(mosaic_dn
        .iter()
        .map(|v| (*v as f64 / k_dn_per_e).max(0.0) as f32)
        .collect())
}

/// The sensor's noise on expected electrons: Poisson shot noise of each pixel's electrons,
/// Gaussian read noise `read_noise_dn` (DN, after the gain), then DN = black + K e + read,
/// rounded and clipped to [0, white]: a raw frame with `like`'s CFA, size, levels, exposure and
/// pitch. Seeded per row on the sensor's temporal stage (its own frame key), so the same seed
/// gives the same frame for any thread count.
pub fn add_sensor_noise(
    electrons: &[f32],
    like: &RawImage,
    k_dn_per_e: f64,
    read_noise_dn: f64,
    seed: u64,
) -> Result<RawImage> {
    if electrons.len() != like.rows * like.cols {
        return Err(CoreError::invalid(
            "unprocess noise",
            format!(
                "{} electron values for {} x {}",
                electrons.len(),
                like.rows,
                like.cols
            ),
        ));
    }
    if !(k_dn_per_e > 0.0) || !(read_noise_dn >= 0.0) || !read_noise_dn.is_finite() {
        return Err(CoreError::invalid(
            "unprocess noise",
            format!("K {k_dn_per_e} DN/e, read noise {read_noise_dn} DN: K > 0, read >= 0"),
        ));
    }
    let mut raw = like.clone();
    let (black, white) = (
        like.black_level_dn,
        like.white_level_dn.clamp(0.0, 65_535.0),
    );
    let cols = like.cols;
    raw.dn
        .par_chunks_mut(cols)
        .enumerate()
        .for_each(|(r, line)| {
            let mut rng = keyed(seed, stage::SENSOR_TEMPORAL, UNPROCESS_FRAME_KEY, r as u64);
            for (c, o) in line.iter_mut().enumerate() {
                let lambda = electrons[r * cols + c] as f64;
                let e = if lambda > 0.0 && lambda.is_finite() {
                    Poisson::new(lambda).map_or(lambda, |p| p.sample(&mut rng))
                } else {
                    0.0
                };
                let z: f64 = StandardNormal.sample(&mut rng);
                *o = (black + k_dn_per_e * e + read_noise_dn * z)
                    .round()
                    .clamp(0.0, white) as u16;
            }
        });
    Ok(raw)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inverse_tone_undoes_each_curve() {
        for curve in [
            ToneCurve::Clip,
            ToneCurve::Reinhard { white: 8.0 },
            ToneCurve::Filmic,
        ] {
            for v in [0.001, 0.05, 0.18, 0.5, 0.9] {
                let d = curve.apply(v);
                let back = inverse_tone(curve, d);
                assert!(
                    (back - v).abs() < 1e-9 * v.max(1.0),
                    "{curve:?} {v} -> {d} -> {back}"
                );
            }
        }
    }

    #[test]
    fn identity_pipeline_round_trips_codes() {
        // M = identity, s = 0.5, gains (2, 1, 1.5): code 255 -> linear 1 -> camera (1, 2, 4/3).
        let u = Unprocess {
            camera_to_linear_srgb: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            white_balance_gains: [2.0, 1.0, 1.5],
            exposure_scale: 0.5,
            tone: ToneCurve::Clip,
        };
        let rgb = u.camera_rgb(1, 2, &[255, 255, 255, 118, 0, 0]).unwrap();
        assert!((rgb.r[0] - 1.0).abs() < 1e-6 && (rgb.g[0] - 2.0).abs() < 1e-6);
        assert!((rgb.b[0] - 4.0 / 3.0).abs() < 1e-6);
        // Code 118 is sRGB 0.4627 -> linear 0.1812.
        assert!((rgb.r[1] as f64 - colorimetry::srgb_decode(118.0 / 255.0)).abs() < 1e-6);
        let layout = CfaLayout::from_bayer(camsim_core::CfaPattern::Rggb);
        let m = u
            .mosaic_dn(1, 2, &[255, 255, 255, 118, 0, 0], &layout)
            .unwrap();
        // (0, 0) is R, (0, 1) is G.
        assert!((m[0] - 1.0).abs() < 1e-6 && m[1] == 0.0);
        assert!(u.mosaic_dn(1, 2, &[0; 5], &layout).is_err());
        let rgbw = CfaLayout::parse("rgbw").unwrap();
        assert!(u.mosaic_dn(1, 2, &[0; 6], &rgbw).is_err());
    }
}
