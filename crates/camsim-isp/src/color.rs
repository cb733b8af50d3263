//! The sRGB preview pipeline: white balance, a 3x3 sensor-RGB -> XYZ matrix fitted by least
//! squares on the Macbeth ColorChecker under the scene illuminant, chromatic adaptation to D65,
//! XYZ -> linear sRGB (IEC 61966-2-1:1999) and the sRGB transfer function.
//!
//! Camera space. Sensor responses are photon counts (ISETCam `sensorCompute`): for a surface of
//! reflectance rho under illuminant E, channel c responds `c = sum QE_c(l) E(l) rho(l) l dl` (the
//! common factor 1/(h c) and the exposure are dropped: the camera space is defined up to one scale).
//! The fit works in camera values normalised so that a perfect white reflector's largest channel
//! is 1; that white's camera values are [`ColorPipeline::as_shot_neutral`] (the DNG AsShotNeutral).
//!
//! Fit. `camera_to_xyz` is the 3x3 matrix M minimising `sum_i |M c_i - X_i|^2` over the 24
//! ColorChecker patches (N. Ohta 1997 reflectances), where `X_i` are the patches' CIE 1931 XYZ under
//! the same illuminant, normalised so the perfect white has Y = 1, subject to M mapping the
//! perfect white exactly onto the illuminant's XYZ ("white-point preserving least squares",
//! Finlayson & Drew 1996). Applying M therefore includes the white balance: it is the product of
//! the white-balance gains `diag(1 / as_shot_neutral)` and a matrix that takes (1, 1, 1) to the
//! illuminant's white. When the QE curves are linear combinations of `x_bar(l) / l`, `y_bar / l`,
//! `z_bar / l` (the Luther condition for photon-counting sensors), M is exact.
//!
//! Adaptation. XYZ under the scene illuminant is adapted to D65 (the sRGB white, x = 0.3127,
//! y = 0.3290) with the linearised Bradford transform (Lam 1985; as tabulated by B. Lindbloom),
//! so the perfect white renders as R = G = B under any illuminant.

use crate::coring::{render_display8, BlackModel, SRGB_LUMINANCE_WEIGHTS};
use crate::demosaic::RgbImage;
use camsim_core::colorimetry::{self, Cmfs};
use camsim_core::error::{CoreError, Result};
use camsim_core::{tables, Spectrum, WavelengthGrid};
use nalgebra::{Matrix3, Matrix4, Vector3, Vector4};

/// 3x3 matrix, row-major (`m[row][col]`), acting on column vectors.
pub type Mat3 = [[f64; 3]; 3];

pub use camsim_core::colorimetry::{bradford_adaptation, mat3_inverse, BRADFORD};

/// Target luminance of the 99th-percentile pixel under automatic exposure (Y of the white = 1).
pub const AUTO_EXPOSURE_P99_Y: f64 = 0.9;

fn to_na(m: &Mat3) -> Matrix3<f64> {
    Matrix3::from_fn(|r, c| m[r][c])
}

fn from_na(m: &Matrix3<f64>) -> Mat3 {
    let mut o = [[0.0; 3]; 3];
    for (r, row) in o.iter_mut().enumerate() {
        for (c, v) in row.iter_mut().enumerate() {
            *v = m[(r, c)];
        }
    }
    o
}

/// Product of two 3x3 matrices.
pub fn mat3_mul(a: &Mat3, b: &Mat3) -> Mat3 {
    from_na(&(to_na(a) * to_na(b)))
}

/// Relative camera responses (photon counts) of a surface: `sum QE_c(l) E(l) rho(l) l dl` for the
/// three channels, with every spectrum sampled on `grid` (ISETCam `sensorCompute` up to the constant
/// 1/(h c) and the exposure).
pub fn camera_response(
    channel_qe: &[Vec<f64>; 3],
    illuminant: &[f64],
    reflectance: &[f64],
    grid: &WavelengthGrid,
) -> [f64; 3] {
    let mut out = [0.0; 3];
    for (c, qe) in channel_qe.iter().enumerate() {
        out[c] = (0..grid.len())
            .map(|b| qe[b] * illuminant[b] * reflectance[b] * grid.wavelength_nm(b))
            .sum::<f64>()
            * grid.step_nm;
    }
    out
}

/// The preview colour pipeline of one sensor under one illuminant.
#[derive(Debug, Clone, PartialEq)]
pub struct ColorPipeline {
    /// Camera (normalised, see module docs) -> XYZ under the scene illuminant (white Y = 1).
    camera_to_xyz: Mat3,
    /// Camera values of a perfect white reflector, largest = 1.
    as_shot_neutral: [f64; 3],
    /// XYZ of the scene illuminant's white, Y = 1.
    illuminant_white_xyz: [f64; 3],
    /// Bradford adaptation from the illuminant's white to D65.
    adaptation: Mat3,
    /// Camera -> linear sRGB: `XYZ_TO_LINEAR_SRGB * adaptation * camera_to_xyz`.
    camera_to_srgb: Mat3,
    /// RMS error of the fitted XYZ over the 24 patches (white Y = 1).
    fit_rms_xyz: f64,
}

impl ColorPipeline {
    /// Fit the pipeline for a sensor with per-channel QE `channel_qe` (R, G, B; fractions sampled on
    /// `grid`) under `illuminant` (relative SPD, resampled onto `grid`). Errors when the QE does not
    /// match the grid, the illuminant gives no signal or no luminance, or the fit is singular.
    pub fn fit(
        channel_qe: &[Vec<f64>; 3],
        grid: &WavelengthGrid,
        illuminant: &Spectrum,
    ) -> Result<ColorPipeline> {
        for (c, qe) in channel_qe.iter().enumerate() {
            if qe.len() != grid.len() {
                return Err(CoreError::invalid(
                    "colour pipeline",
                    format!(
                        "channel {} QE has {} values for a {}-band grid",
                        ['R', 'G', 'B'][c],
                        qe.len(),
                        grid.len()
                    ),
                ));
            }
            if qe.iter().any(|v| !v.is_finite()) {
                return Err(CoreError::invalid(
                    "colour pipeline",
                    format!("channel {} QE is not finite", ['R', 'G', 'B'][c]),
                ));
            }
        }
        let illum = illuminant.sample(grid);
        let cmfs = Cmfs::on(grid);
        let ones = vec![1.0; grid.len()];
        let white_cam = camera_response(channel_qe, &illum, &ones, grid);
        let cam_norm = white_cam.iter().cloned().fold(0.0, f64::max);
        if !(cam_norm > 0.0) || white_cam.iter().any(|v| *v <= 0.0) {
            return Err(CoreError::invalid(
                "colour pipeline",
                format!("a white surface under this illuminant gives camera response {white_cam:?}; every channel must see light"),
            ));
        }
        let white_xyz_raw = cmfs.xyz(&illum);
        if !(white_xyz_raw[1] > 0.0) {
            return Err(CoreError::invalid(
                "colour pipeline",
                "the illuminant has no luminance on this wavelength grid",
            ));
        }
        let y_norm = white_xyz_raw[1];
        let as_shot_neutral = [
            white_cam[0] / cam_norm,
            white_cam[1] / cam_norm,
            white_cam[2] / cam_norm,
        ];
        let illuminant_white_xyz = [white_xyz_raw[0] / y_norm, 1.0, white_xyz_raw[2] / y_norm];

        // Patch responses and targets.
        let mut cam = Vec::with_capacity(24);
        let mut xyz = Vec::with_capacity(24);
        for r in tables::macbeth_reflectances() {
            let rho = r.sample(grid);
            let c = camera_response(channel_qe, &illum, &rho, grid);
            cam.push(Vector3::new(
                c[0] / cam_norm,
                c[1] / cam_norm,
                c[2] / cam_norm,
            ));
            let radiance: Vec<f64> = illum.iter().zip(&rho).map(|(e, p)| e * p).collect();
            let t = cmfs.xyz(&radiance);
            xyz.push(Vector3::new(t[0] / y_norm, t[1] / y_norm, t[2] / y_norm));
        }
        // White-point-preserving least squares, one row of M at a time (KKT system):
        // [C^T C  w] [m]   [C^T x]
        // [w^T    0] [mu] = [x_w ]
        let mut ctc = Matrix3::zeros();
        for c in &cam {
            ctc += c * c.transpose();
        }
        let w = Vector3::from(as_shot_neutral);
        let mut kkt = Matrix4::zeros();
        kkt.fixed_view_mut::<3, 3>(0, 0).copy_from(&ctc);
        kkt.fixed_view_mut::<3, 1>(0, 3).copy_from(&w);
        kkt.fixed_view_mut::<1, 3>(3, 0).copy_from(&w.transpose());
        let lu = kkt.lu();
        let mut m = [[0.0; 3]; 3];
        for (row, m_row) in m.iter_mut().enumerate() {
            let mut rhs = Vector4::zeros();
            for (c, x) in cam.iter().zip(&xyz) {
                rhs.fixed_view_mut::<3, 1>(0, 0).axpy(x[row], c, 1.0);
            }
            rhs[3] = illuminant_white_xyz[row];
            let sol = lu.solve(&rhs).ok_or_else(|| {
                CoreError::invalid(
                    "colour pipeline",
                    "the ColorChecker responses do not determine a 3x3 matrix (degenerate QE)",
                )
            })?;
            *m_row = [sol[0], sol[1], sol[2]];
        }
        if mat3_inverse(&m).is_none() {
            return Err(CoreError::invalid(
                "colour pipeline",
                "the fitted camera -> XYZ matrix is singular",
            ));
        }
        let mn = to_na(&m);
        let fit_rms_xyz = (cam
            .iter()
            .zip(&xyz)
            .map(|(c, x)| (mn * c - x).norm_squared())
            .sum::<f64>()
            / 24.0)
            .sqrt();
        let d65 = colorimetry::xyy_to_xyz(
            colorimetry::SRGB_WHITE_XY[0],
            colorimetry::SRGB_WHITE_XY[1],
            1.0,
        );
        let adaptation = bradford_adaptation(illuminant_white_xyz, d65);
        let camera_to_srgb = mat3_mul(&colorimetry::XYZ_TO_LINEAR_SRGB, &mat3_mul(&adaptation, &m));
        Ok(ColorPipeline {
            camera_to_xyz: m,
            as_shot_neutral,
            illuminant_white_xyz,
            adaptation,
            camera_to_srgb,
            fit_rms_xyz,
        })
    }

    /// The fitted matrix from normalised camera RGB to CIE XYZ under the scene illuminant (white
    /// Y = 1), white balance included.
    pub fn camera_to_xyz(&self) -> Mat3 {
        self.camera_to_xyz
    }

    /// Inverse of [`ColorPipeline::camera_to_xyz`]: XYZ under the scene illuminant -> camera. This is
    /// the DNG ColorMatrix1 for this illuminant, normalised so that the illuminant's white (Y = 1)
    /// maps to camera values whose largest component is 1 ([`ColorPipeline::as_shot_neutral`]).
    pub fn xyz_to_camera(&self) -> Mat3 {
        mat3_inverse(&self.camera_to_xyz).expect("checked invertible in fit")
    }

    /// Camera values of a perfect white reflector under the scene illuminant, largest = 1 (DNG
    /// AsShotNeutral).
    pub fn as_shot_neutral(&self) -> [f64; 3] {
        self.as_shot_neutral
    }

    /// White-balance gains `1 / as_shot_neutral` (largest-channel-normalised: the channel with the
    /// strongest white response has gain 1).
    pub fn white_balance_gains(&self) -> [f64; 3] {
        [
            1.0 / self.as_shot_neutral[0],
            1.0 / self.as_shot_neutral[1],
            1.0 / self.as_shot_neutral[2],
        ]
    }

    /// XYZ of the scene illuminant's white, Y = 1.
    pub fn illuminant_white_xyz(&self) -> [f64; 3] {
        self.illuminant_white_xyz
    }

    /// The Bradford matrix adapting XYZ under the scene illuminant to D65.
    pub fn adaptation_to_d65(&self) -> Mat3 {
        self.adaptation
    }

    /// Camera -> linear sRGB (D65), the whole colour chain as one matrix.
    pub fn camera_to_srgb(&self) -> Mat3 {
        self.camera_to_srgb
    }

    /// RMS error of the fit over the 24 patches, in XYZ with the white's Y = 1.
    pub fn fit_rms_xyz(&self) -> f64 {
        self.fit_rms_xyz
    }

    /// Exposure scale that puts the 99th percentile of the adapted luminance Y at
    /// [`AUTO_EXPOSURE_P99_Y`]. Uses at most about a million evenly strided pixels. Returns 1 when
    /// the image has no positive luminance.
    pub fn auto_exposure_scale(&self, img: &RgbImage) -> f64 {
        let row = mat3_mul(&self.adaptation, &self.camera_to_xyz)[1];
        p99_exposure_scale(img, row)
    }

    /// Render an 8-bit sRGB preview, interleaved R, G, B, row-major (`rows * cols * 3` bytes):
    /// camera -> XYZ (fitted matrix, white balance included) -> Bradford to D65 -> linear sRGB
    /// (IEC 61966-2-1) -> clip to [0, 1] -> sRGB transfer function. The planes of `img` must hold
    /// `rows * cols` values each. `exposure_scale` multiplies the
    /// camera values first (camera values of 1 in the largest channel of a perfect white render it
    /// at Y = 1); `None` chooses it automatically ([`ColorPipeline::auto_exposure_scale`]).
    pub fn render_srgb8(&self, img: &RgbImage, exposure_scale: Option<f64>) -> Vec<u8> {
        self.render_srgb8_clipped(img, exposure_scale, None, None)
    }

    /// [`ColorPipeline::render_srgb8`] with highlight clipping: where a channel reached the
    /// sensor's saturation level `saturation_dn` (black-subtracted DN), white balance would
    /// lift the other channels past it and paint clipped highlights in a false colour (a
    /// saturated lamp turns magenta). Each camera channel c is therefore clipped at
    /// `saturation_dn * as_shot_neutral[c]`, the level at which it equals the saturated channel
    /// after white balance, so clipped highlights render neutral (dcraw's default highlight mode).
    /// `black`, what is known of the values at black (noise, a clip below), turns on chroma
    /// coring and the censored-black correction ([`crate::coring`]) so that black renders
    /// black and noise around it grey, not tinted.
    pub fn render_srgb8_clipped(
        &self,
        img: &RgbImage,
        exposure_scale: Option<f64>,
        saturation_dn: Option<f64>,
        black: Option<&BlackModel>,
    ) -> Vec<u8> {
        self.render_srgb8_toned(
            img,
            exposure_scale,
            saturation_dn,
            black,
            crate::tone::ToneCurve::Clip,
        )
    }

    /// [`ColorPipeline::render_srgb8_clipped`] with a tone curve applied to the luminance of each
    /// linear sRGB pixel before the encoding, its chromaticity kept ([`crate::tone`];
    /// `ToneCurve::Clip` is the plain clip).
    pub fn render_srgb8_toned(
        &self,
        img: &RgbImage,
        exposure_scale: Option<f64>,
        saturation_dn: Option<f64>,
        black: Option<&BlackModel>,
        curve: crate::tone::ToneCurve,
    ) -> Vec<u8> {
        let clip = match saturation_dn {
            Some(s) if s > 0.0 => self.as_shot_neutral.map(|n| s * n),
            _ => [f64::INFINITY; 3],
        };
        let k = exposure_scale.unwrap_or_else(|| self.auto_exposure_scale(img));
        let m = self.camera_to_srgb.map(|row| row.map(|v| v * k));
        let encoder = Srgb8Encoder::new();
        render_display8(img, &m, clip, SRGB_LUMINANCE_WEIGHTS, black, curve, |v| {
            encoder.encode(v)
        })
    }

    /// The weights of the adapted luminance (D65, Y of linear sRGB) of a camera pixel: what
    /// auto-exposure and tone mapping measure.
    pub fn luminance_weights(&self) -> [f64; 3] {
        mat3_mul(&self.adaptation, &self.camera_to_xyz)[1]
    }

    /// Adapted luminance (D65, white = 1 at exposure scale 1) of one camera pixel.
    pub fn luminance_of(&self, rgb: [f32; 3]) -> f64 {
        let row = mat3_mul(&self.adaptation, &self.camera_to_xyz)[1];
        row[0] * rgb[0] as f64 + row[1] * rgb[1] as f64 + row[2] * rgb[2] as f64
    }
}

/// Linear value -> 8-bit sRGB code without a `powf` per value: code k is the number of decision
/// thresholds below the value, threshold k being the linear value whose encoding is (k + 1/2) / 255
/// (the inverse transfer function, IEC 61966-2-1 eq. 5.2-5.3). Gives the same code as
/// rounding [`colorimetry::srgb_encode`] except where a value lies within rounding error of a
/// threshold.
pub(crate) struct Srgb8Encoder {
    thresholds: [f64; 256],
    /// Code of the lower end of each of `BINS` equal bins of [0, 1] (a start for the search).
    start: Vec<u8>,
}

const BINS: usize = 4096;

impl Srgb8Encoder {
    pub(crate) fn new() -> Self {
        let mut thresholds = [f64::INFINITY; 256];
        for (k, t) in thresholds.iter_mut().take(255).enumerate() {
            *t = colorimetry::srgb_decode((k as f64 + 0.5) / 255.0);
        }
        let start = (0..BINS)
            .map(|i| thresholds[..255].partition_point(|t| *t <= i as f64 / BINS as f64) as u8)
            .collect();
        Srgb8Encoder { thresholds, start }
    }

    #[inline]
    pub(crate) fn encode(&self, linear: f64) -> u8 {
        if !(linear > 0.0) {
            return 0; // also NaN
        }
        if linear >= 1.0 {
            return 255;
        }
        // Start at the code of the bin's lower end and step up past the thresholds below `linear`
        // (a bin spans at most about one code: the steepest slope is 12.92 * 255 / BINS < 1).
        let mut k = self.start[(linear * BINS as f64) as usize] as usize;
        while linear >= self.thresholds[k] {
            k += 1;
        }
        k as u8
    }
}

/// The exposure scale that puts the 99th percentile of `weights . (r, g, b)` (a luminance) at
/// [`AUTO_EXPOSURE_P99_Y`], at most 2^20 pixels sampled; 1 when no luminance is positive.
pub(crate) fn p99_exposure_scale(img: &RgbImage, weights: [f64; 3]) -> f64 {
    let n = img.pixels();
    if n == 0 {
        return 1.0;
    }
    let w = weights;
    let stride = n.div_ceil(1 << 20).max(1);
    let mut ys: Vec<f64> = (0..n)
        .step_by(stride)
        .map(|i| w[0] * img.r[i] as f64 + w[1] * img.g[i] as f64 + w[2] * img.b[i] as f64)
        .filter(|y| y.is_finite())
        .collect();
    if ys.is_empty() {
        return 1.0;
    }
    let k = ((ys.len() - 1) as f64 * 0.99).round() as usize;
    let (_, p99, _) = ys.select_nth_unstable_by(k, |a, b| a.total_cmp(b));
    if *p99 > 0.0 {
        AUTO_EXPOSURE_P99_Y / *p99
    } else {
        1.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lookup_encoder_agrees_with_the_transfer_function() {
        let e = Srgb8Encoder::new();
        let mut mismatches = 0;
        for i in 0..=100_000 {
            let v = i as f64 / 100_000.0;
            let (a, b) = (e.encode(v), colorimetry::srgb_encode_u8(v));
            assert!((a as i32 - b as i32).abs() <= 1);
            mismatches += (a != b) as u32;
        }
        assert!(mismatches <= 2, "{mismatches} values differ");
        assert_eq!(e.encode(-0.5), 0);
        assert_eq!(e.encode(f64::NAN), 0);
        assert_eq!(e.encode(7.0), 255);
        assert_eq!(e.encode(1.0), 255);
        // Exactly the threshold count everywhere (the plain search).
        for i in 0..=200_000 {
            let v = i as f64 / 200_000.0;
            assert_eq!(
                e.encode(v) as usize,
                e.thresholds[..255].partition_point(|t| *t <= v),
                "{v}"
            );
        }
    }
}
