//! Output rendering: camera RGB -> XYZ (a fitted matrix) -> a display's linear RGB -> its
//! transfer function -> 8 bits. Two displays: sRGB (IEC 61966-2-1:1999, piecewise OETF) and a
//! display model given by its primaries, white point and a pure power-law gamma (ISETCam's
//! `displayCreate`: `'rgb primaries'`, `'white point'`, `'gamma'`).
//!
//! The RGB -> XYZ matrix of a display follows SMPTE RP 177-1993 §3.3: the columns are the
//! primaries' XYZ (Y = 1) scaled so that R = G = B = 1 gives the white point (Y = 1).

use crate::color::{mat3_inverse, mat3_mul, Mat3};
use crate::coring::{render_display8, BlackModel};
use crate::demosaic::RgbImage;
use camsim_core::colorimetry;
use camsim_core::error::{CoreError, Result};

/// A display: primaries, white point and transfer function.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct DisplayModel {
    /// CIE 1931 xy chromaticities of the red, green and blue primaries.
    pub primaries_xy: [[f64; 2]; 3],
    /// CIE 1931 xy of the white (R = G = B = 1).
    pub white_xy: [f64; 2],
    /// Power-law exponent of the display (`L = V^gamma`); `None` = the sRGB piecewise curve.
    pub gamma: Option<f64>,
}

impl DisplayModel {
    /// The sRGB display (ITU-R BT.709 primaries, D65, IEC 61966-2-1 transfer function).
    pub fn srgb() -> DisplayModel {
        DisplayModel {
            primaries_xy: [[0.64, 0.33], [0.30, 0.60], [0.15, 0.06]],
            white_xy: colorimetry::SRGB_WHITE_XY,
            gamma: None,
        }
    }

    /// Display linear RGB -> XYZ (white Y = 1), SMPTE RP 177-1993. Errors on degenerate primaries.
    pub fn rgb_to_xyz(&self) -> Result<Mat3> {
        let xyz = |xy: [f64; 2]| {
            if !(xy[1] > 0.0) {
                return Err(CoreError::invalid(
                    "display model",
                    format!("chromaticity {xy:?} needs y > 0"),
                ));
            }
            Ok(colorimetry::xyy_to_xyz(xy[0], xy[1], 1.0))
        };
        let p = [
            xyz(self.primaries_xy[0])?,
            xyz(self.primaries_xy[1])?,
            xyz(self.primaries_xy[2])?,
        ];
        let w = xyz(self.white_xy)?;
        let prim: Mat3 = std::array::from_fn(|r| std::array::from_fn(|c| p[c][r]));
        let inv = mat3_inverse(&prim)
            .ok_or_else(|| CoreError::invalid("display model", "the primaries are collinear"))?;
        let s = colorimetry::mat3_mul_vec(&inv, w);
        Ok(std::array::from_fn(|r| {
            std::array::from_fn(|c| prim[r][c] * s[c])
        }))
    }

    /// XYZ -> display linear RGB.
    pub fn xyz_to_rgb(&self) -> Result<Mat3> {
        mat3_inverse(&self.rgb_to_xyz()?)
            .ok_or_else(|| CoreError::invalid("display model", "singular display matrix"))
    }

    /// Encode a linear value in [0, 1] (clipped) for this display.
    pub fn encode(&self, linear: f64) -> f64 {
        let v = if linear > 0.0 { linear.min(1.0) } else { 0.0 };
        match self.gamma {
            None => colorimetry::srgb_encode(v),
            Some(g) => v.powf(1.0 / g),
        }
    }
}

/// Render `img` to 8-bit interleaved RGB on `display`: `camera_to_xyz` (white Y = 1 under the
/// display white) then the display's XYZ -> RGB, the censored-black correction and chroma coring
/// where `black` is given ([`crate::coring`]), clip, encode.
/// `exposure_scale` multiplies first.
pub fn render_rgb8(
    img: &RgbImage,
    camera_to_xyz: &Mat3,
    display: &DisplayModel,
    exposure_scale: f64,
    black: Option<&BlackModel>,
) -> Result<Vec<u8>> {
    let m =
        mat3_mul(&display.xyz_to_rgb()?, camera_to_xyz).map(|row| row.map(|v| v * exposure_scale));
    let y_weights = display.rgb_to_xyz()?[1];
    // 4096-entry lookup of the encoding (error below half a code: the steepest slope of the
    // sRGB curve is 12.92, of a gamma curve near 0 larger, so the table is indexed finely near 0
    // by encoding sqrt-spaced entries).
    let lut: Vec<u8> = (0..=LUT_N)
        .map(|i| (display.encode((i as f64 / LUT_N as f64).powi(2)) * 255.0).round() as u8)
        .collect();
    Ok(render_display8(
        img,
        &m,
        [f64::INFINITY; 3],
        y_weights,
        black,
        crate::tone::ToneCurve::Clip,
        |v| {
            let v = if v > 0.0 { v.min(1.0) } else { 0.0 };
            lut[(v.sqrt() * LUT_N as f64).round() as usize]
        },
    ))
}

const LUT_N: usize = 1 << 14;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_display_matrix_is_the_iec_matrix() {
        // IEC 61966-2-1 XYZ -> linear sRGB (camsim-core's table, 4 decimals in the standard).
        let m = DisplayModel::srgb().xyz_to_rgb().unwrap();
        for r in 0..3 {
            for c in 0..3 {
                assert!(
                    (m[r][c] - colorimetry::XYZ_TO_LINEAR_SRGB[r][c]).abs() < 2e-3,
                    "{m:?}"
                );
            }
        }
        // White (D65, Y = 1) renders as R = G = B = 255; 18 % gray as sRGB code 118
        // (1.055 * 0.18^(1/2.4) - 0.055 = 0.4613 -> 117.6).
        let white = colorimetry::xyy_to_xyz(0.3127, 0.3290, 1.0);
        let mut img = RgbImage::zeros(1, 2);
        (img.r[0], img.g[0], img.b[0]) = (white[0] as f32, white[1] as f32, white[2] as f32);
        (img.r[1], img.g[1], img.b[1]) = ((0.18 * white[0]) as f32, 0.18, (0.18 * white[2]) as f32);
        let id: Mat3 = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        let px = render_rgb8(&img, &id, &DisplayModel::srgb(), 1.0, None).unwrap();
        assert_eq!(px, vec![255, 255, 255, 118, 118, 118]);
        // A gamma-2.2 display: 18 % gray -> 0.18^(1/2.2) = 0.4587 -> 117.
        let g22 = DisplayModel {
            gamma: Some(2.2),
            ..DisplayModel::srgb()
        };
        assert_eq!(
            render_rgb8(&img, &id, &g22, 1.0, None).unwrap()[3..],
            [117, 117, 117]
        );
    }

    #[test]
    fn collinear_primaries_are_an_error() {
        let d = DisplayModel {
            primaries_xy: [[0.3, 0.3], [0.3, 0.3], [0.2, 0.2]],
            ..DisplayModel::srgb()
        };
        assert!(d.rgb_to_xyz().is_err());
    }
}
