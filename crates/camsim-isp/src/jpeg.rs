//! JPEG output of an 8-bit sRGB image at a quality setting (the `image` crate's baseline
//! encoder: ITU-T T.81 with the Annex K tables scaled by the IJG rule, 4:2:2 chroma).
//!
//! The IJG quality q scales each table entry Q_k to clamp((Q_k s + 50) / 100, 1, 255), s = 5000 /
//! q below 50 and 200 - 2 q from 50. The DCT of an 8 x 8 block is orthonormal (up to its fixed-
//! point arithmetic), so by Parseval the mean squared error of a block is the mean of the
//! coefficients' quantisation errors squared, each at most (step_k / 2)^2: a grey image's RMS
//! error is at most sqrt(mean_k step_k^2) / 2 ([`luma_rms_error_bound`]) plus the 8-bit
//! rounding of the colour conversions.

use camsim_core::error::{CoreError, Result};
use image::codecs::jpeg::JpegEncoder;
use image::ExtendedColorType;
use std::path::Path;

/// ITU-T T.81 Annex K, Table K.1: the luminance quantisation table (row-major).
pub const ANNEX_K_LUMA_TABLE: [u16; 64] = [
    16, 11, 10, 16, 24, 40, 51, 61, 12, 12, 14, 19, 26, 58, 60, 55, 14, 13, 16, 24, 40, 57, 69, 56,
    14, 17, 22, 29, 51, 87, 80, 62, 18, 22, 37, 56, 68, 109, 103, 77, 24, 35, 55, 64, 81, 104, 113,
    92, 49, 64, 78, 87, 103, 121, 120, 101, 72, 92, 95, 98, 112, 100, 103, 99,
];

/// The quantisation steps of the luminance table at IJG quality `quality` (1..=100).
pub fn luma_steps(quality: u8) -> [u16; 64] {
    let q = quality.clamp(1, 100) as u32;
    let s = if q < 50 { 5000 / q } else { 200 - 2 * q };
    ANNEX_K_LUMA_TABLE.map(|v| ((v as u32 * s + 50) / 100).clamp(1, 255) as u16)
}

/// Upper bound of the RMS error (8-bit codes) of a grey image `luma` (`rows x cols`, both
/// multiples of 8) after the luminance quantisation at `quality`: each orthonormal DCT-II
/// coefficient c_k of each level-shifted 8 x 8 block is rounded to a multiple of step_k, an
/// error of at most min(|c_k|, step_k / 2) (a coefficient below half a step becomes 0), so by
/// Parseval the MSE is at most the mean of min(c_k^2, step_k^2 / 4).
pub fn luma_rms_error_bound_of(luma: &[u8], rows: usize, cols: usize, quality: u8) -> f64 {
    let steps = luma_steps(quality);
    let basis = |k: usize, x: usize| {
        let a = if k == 0 {
            (1.0f64 / 8.0).sqrt()
        } else {
            (2.0f64 / 8.0).sqrt()
        };
        a * ((2 * x + 1) as f64 * k as f64 * std::f64::consts::PI / 16.0).cos()
    };
    let (mut sum, mut n) = (0.0, 0usize);
    for br in (0..rows / 8 * 8).step_by(8) {
        for bc in (0..cols / 8 * 8).step_by(8) {
            for u in 0..8 {
                for v in 0..8 {
                    let mut c = 0.0;
                    for y in 0..8 {
                        for x in 0..8 {
                            let p = luma[(br + y) * cols + bc + x] as f64 - 128.0;
                            c += basis(u, y) * basis(v, x) * p;
                        }
                    }
                    let half = steps[u * 8 + v] as f64 / 2.0;
                    sum += (c * c).min(half * half);
                    n += 1;
                }
            }
        }
    }
    if n == 0 {
        return 0.0;
    }
    (sum / n as f64).sqrt()
}

/// Upper bound of the RMS error (8-bit codes) that the luminance quantisation at `quality` can
/// cause: sqrt(mean_k step_k^2) / 2 (see the module docs).
pub fn luma_rms_error_bound(quality: u8) -> f64 {
    let steps = luma_steps(quality);
    (steps.iter().map(|s| (*s as f64).powi(2)).sum::<f64>() / 64.0).sqrt() / 2.0
}

fn check(rows: usize, cols: usize, rgb8: &[u8], quality: u8) -> Result<()> {
    if !(1..=100).contains(&quality) {
        return Err(CoreError::invalid(
            "jpeg_quality",
            format!("{quality}: must be 1 to 100"),
        ));
    }
    if rows == 0 || cols == 0 || rows > 65_535 || cols > 65_535 || rgb8.len() != rows * cols * 3 {
        return Err(CoreError::invalid(
            "jpeg output",
            format!(
                "{} bytes for {rows} x {cols} RGB pixels (JPEG takes 1 to 65535 per side)",
                rgb8.len()
            ),
        ));
    }
    Ok(())
}

/// The JPEG file bytes of an interleaved 8-bit sRGB image (`rows x cols x 3`, row-major) at IJG
/// quality `quality` (1..=100).
pub fn encode_jpeg(rows: usize, cols: usize, rgb8: &[u8], quality: u8) -> Result<Vec<u8>> {
    check(rows, cols, rgb8, quality)?;
    let mut out = Vec::new();
    JpegEncoder::new_with_quality(&mut out, quality)
        .encode(rgb8, cols as u32, rows as u32, ExtendedColorType::Rgb8)
        .map_err(|e| CoreError::invalid("jpeg output", e.to_string()))?;
    Ok(out)
}

/// [`encode_jpeg`] written to `path`; errors name the file.
pub fn write_jpeg(
    path: impl AsRef<Path>,
    rows: usize,
    cols: usize,
    rgb8: &[u8],
    quality: u8,
) -> Result<()> {
    let bytes = encode_jpeg(rows, cols, rgb8, quality)?;
    let p = path.as_ref();
    std::fs::write(p, bytes)
        .map_err(|e| CoreError::invalid("jpeg output", format!("{}: {e}", p.display())))
}

/// Decode JPEG bytes to interleaved 8-bit RGB: (rows, cols, data).
pub fn decode_jpeg(bytes: &[u8]) -> Result<(usize, usize, Vec<u8>)> {
    let img = image::load_from_memory_with_format(bytes, image::ImageFormat::Jpeg)
        .map_err(|e| CoreError::invalid("jpeg input", e.to_string()))?
        .to_rgb8();
    Ok((img.height() as usize, img.width() as usize, img.into_raw()))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A grey test image (R = G = B, so chroma subsampling changes nothing): a ramp, a disc and
    /// fine stripes.
    fn grey(rows: usize, cols: usize) -> Vec<u8> {
        let mut v = Vec::with_capacity(rows * cols * 3);
        for r in 0..rows {
            for c in 0..cols {
                let mut g = 40.0 + 150.0 * c as f64 / cols as f64;
                let (dr, dc) = (r as f64 - 24.0, c as f64 - 40.0);
                if dr * dr + dc * dc < 144.0 {
                    g = 230.0;
                }
                if r > 40 && (c / 2) % 2 == 0 {
                    g -= 30.0;
                }
                v.extend([g as u8; 3]);
            }
        }
        v
    }

    fn rms(a: &[u8], b: &[u8]) -> f64 {
        (a.iter()
            .zip(b)
            .map(|(x, y)| (*x as f64 - *y as f64).powi(2))
            .sum::<f64>()
            / a.len() as f64)
            .sqrt()
    }

    #[test]
    fn decoded_jpeg_is_within_the_quantisation_bound() {
        let (rows, cols) = (64, 96);
        let img = grey(rows, cols);
        // The PNG of the same image is lossless: it decodes to `img` exactly.
        let mut png = Vec::new();
        image::codecs::png::PngEncoder::new(&mut png)
            .write_image(&img, cols as u32, rows as u32, ExtendedColorType::Rgb8)
            .unwrap();
        let from_png = image::load_from_memory(&png).unwrap().to_rgb8().into_raw();
        assert_eq!(from_png, img);
        let mut last = f64::INFINITY;
        for q in [25u8, 50, 75, 90, 98] {
            let (r, c, dec) = decode_jpeg(&encode_jpeg(rows, cols, &img, q).unwrap()).unwrap();
            assert_eq!((r, c), (rows, cols));
            let e = rms(&dec, &from_png);
            // + 1 code: the 8-bit rounding of RGB -> YCbCr and back and of the fixed-point DCT.
            let luma: Vec<u8> = img.iter().step_by(3).cloned().collect();
            let bound = luma_rms_error_bound_of(&luma, rows, cols, q) + 1.0;
            assert!(bound <= luma_rms_error_bound(q) + 1.0);
            eprintln!("jpeg q {q}: RMS {e:.3} codes, bound {bound:.3}");
            assert!(e < bound, "quality {q}: RMS {e} codes, bound {bound}");
            assert!(
                e <= last + 0.05,
                "quality {q}: RMS {e} above quality below's {last}"
            );
            last = e;
        }
        assert!(encode_jpeg(rows, cols, &img, 0).is_err());
        assert!(encode_jpeg(rows, cols, &img, 101).is_err());
        assert!(encode_jpeg(rows, cols + 1, &img, 90).is_err());
    }

    use image::ImageEncoder as _;
}
