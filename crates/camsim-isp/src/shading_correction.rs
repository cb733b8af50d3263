//! Lens-shading correction (flat-field correction) of a raw frame: each pixel's signal above
//! black multiplied by a gain, 1 / the relative illumination of its filter at its place (the
//! gain map comes from a flat-field fit, `camsim fit-shading`; ISETCam and every camera ISP call
//! it lens-shading or vignetting correction). It brightens the corners back to the centre's
//! level, and their noise with them: it runs after the raw-domain denoising, which needs the
//! sensor's own noise statistics, and before the demosaic.

use camsim_core::error::{CoreError, Result};
use camsim_core::RawImage;
use rayon::prelude::*;

/// `raw` with each pixel's DN above black multiplied by `gain` (row-major, one per pixel),
/// rounded to the nearest DN and clipped to [0, white level]. A pixel at or above the white level
/// (saturated: its true signal is unknown) stays at white. Errors when `gain` does not have one
/// finite positive value per pixel.
pub fn correct_shading(raw: &RawImage, gain: &[f32]) -> Result<RawImage> {
    if gain.len() != raw.rows * raw.cols {
        return Err(CoreError::invalid(
            "lens-shading correction",
            format!(
                "{} gains for a {} x {} frame",
                gain.len(),
                raw.rows,
                raw.cols
            ),
        ));
    }
    if let Some(i) = gain.iter().position(|g| !(*g > 0.0 && g.is_finite())) {
        return Err(CoreError::invalid(
            "lens-shading correction",
            format!(
                "gain {} at row {}, column {} is not a positive number",
                gain[i],
                i / raw.cols.max(1),
                i % raw.cols.max(1)
            ),
        ));
    }
    let mut out = raw.clone();
    let black = raw.black_level_dn;
    let white = raw.white_level_dn.max(0.0).min(u16::MAX as f64);
    out.dn
        .par_chunks_mut(raw.cols.max(1))
        .zip(gain.par_chunks(raw.cols.max(1)))
        .for_each(|(line, g)| {
            for (v, &g) in line.iter_mut().zip(g) {
                let dn = *v as f64;
                if dn < white {
                    *v = (black + (dn - black) * g as f64).round().clamp(0.0, white) as u16;
                }
            }
        });
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use camsim_core::CfaPattern;

    #[test]
    fn gains_multiply_the_signal_above_black_and_keep_saturation() {
        let mut raw = RawImage::new(2, 3, CfaPattern::Rggb, 12).unwrap();
        raw.black_level_dn = 64.0;
        raw.white_level_dn = 4095.0;
        raw.dn = vec![64, 164, 1064, 4095, 3000, 40];
        let gain = [2.0, 2.0, 1.5, 2.0, 2.0, 3.0];
        let out = correct_shading(&raw, &gain).unwrap();
        // 64 + 0 x 2; 64 + 100 x 2; 64 + 1000 x 1.5; saturated stays; 64 + 2936 x 2 clips at
        // white; below black: 64 - 24 x 3 = -8 clips at 0.
        assert_eq!(out.dn, vec![64, 264, 1564, 4095, 4095, 0]);
        assert!(correct_shading(&raw, &gain[..5]).is_err());
        let bad = [1.0, f32::NAN, 1.0, 1.0, 1.0, 1.0];
        let e = correct_shading(&raw, &bad).unwrap_err().to_string();
        assert!(e.contains("row 0, column 1"), "{e}");
    }
}
