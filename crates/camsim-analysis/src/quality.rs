//! Full-reference image quality: PSNR and SSIM of a test image against a reference (for camsim,
//! a capture against its noise-free counterpart, or an ISP's output against the ideal one).
//!
//! - [`psnr_db`]: 10 log10(peak^2 / MSE).
//! - [`ssim`]: the structural similarity index of Wang, Bovik, Sheikh & Simoncelli, "Image
//!   quality assessment: from error visibility to structural similarity", IEEE TIP 13(4), 2004:
//!   per pixel SSIM = (2 mu_x mu_y + C1)(2 sigma_xy + C2) / ((mu_x^2 + mu_y^2 + C1)(sigma_x^2 +
//!   sigma_y^2 + C2)) with local statistics under an 11 x 11 circular Gaussian window of
//!   sigma 1.5 samples, C1 = (0.01 L)^2, C2 = (0.03 L)^2, L the dynamic range; the index is the
//!   mean over the pixels whose window lies inside the image (the paper's "valid" region).
//!   Multi-channel images: the mean of the channels' indices.

use crate::{AnalysisError, Plane, Result};
use rayon::prelude::*;

/// The paper's window: 11 x 11 samples, Gaussian sigma 1.5.
const WINDOW_RADIUS: usize = 5;
const WINDOW_SIGMA: f64 = 1.5;
/// The paper's stabilizing constants, as fractions of the dynamic range.
const K1: f64 = 0.01;
const K2: f64 = 0.03;

fn same_size(reference: &Plane, test: &Plane) -> Result<()> {
    if (reference.rows, reference.cols) != (test.rows, test.cols) {
        return Err(AnalysisError::invalid(
            "image quality",
            format!(
                "the test image is {} x {}, the reference {} x {}",
                test.rows, test.cols, reference.rows, reference.cols
            ),
        ));
    }
    Ok(())
}

/// Mean squared error of `test` against `reference` (same size).
pub fn mse(reference: &Plane, test: &Plane) -> Result<f64> {
    same_size(reference, test)?;
    // Partial sums per fixed chunk, added in order: the same bits for any thread count.
    let partial: Vec<f64> = reference
        .data
        .par_chunks(4096)
        .zip(test.data.par_chunks(4096))
        .map(|(a, b)| {
            a.iter()
                .zip(b)
                .map(|(x, y)| (*x as f64 - *y as f64).powi(2))
                .sum::<f64>()
        })
        .collect();
    Ok(partial.iter().sum::<f64>() / reference.data.len() as f64)
}

/// Peak signal-to-noise ratio in dB, 10 log10(peak^2 / MSE), `peak` the largest value the
/// images can take (255 for 8-bit, the white level above black for a raw). Identical images
/// give infinity.
pub fn psnr_db(reference: &Plane, test: &Plane, peak: f64) -> Result<f64> {
    if !(peak.is_finite() && peak > 0.0) {
        return Err(AnalysisError::invalid(
            "psnr peak",
            format!("{peak}: must be > 0"),
        ));
    }
    let m = mse(reference, test)?;
    Ok(10.0 * (peak * peak / m).log10())
}

/// SSIM of `test` against `reference` (same size, at least 11 x 11), `dynamic_range` L the
/// images' value range (255 for 8-bit). 1 for identical images.
pub fn ssim(reference: &Plane, test: &Plane, dynamic_range: f64) -> Result<f64> {
    same_size(reference, test)?;
    let (rows, cols) = (reference.rows, reference.cols);
    let side = 2 * WINDOW_RADIUS + 1;
    if rows < side || cols < side {
        return Err(AnalysisError::invalid(
            "ssim",
            format!("{rows} x {cols} is smaller than the {side} x {side} window"),
        ));
    }
    if !(dynamic_range.is_finite() && dynamic_range > 0.0) {
        return Err(AnalysisError::invalid(
            "ssim dynamic range",
            format!("{dynamic_range}: must be > 0"),
        ));
    }
    let c1 = (K1 * dynamic_range).powi(2);
    let c2 = (K2 * dynamic_range).powi(2);
    // The separable Gaussian, normalized to unit sum.
    let w1: Vec<f64> = (0..side)
        .map(|i| {
            let d = i as f64 - WINDOW_RADIUS as f64;
            (-d * d / (2.0 * WINDOW_SIGMA * WINDOW_SIGMA)).exp()
        })
        .collect();
    let norm: f64 = w1.iter().sum();
    let w1: Vec<f64> = w1.iter().map(|w| w / norm).collect();
    let (x, y) = (&reference.data, &test.data);
    let out_rows = rows - side + 1;
    let out_cols = cols - side + 1;
    // Per output row: the five weighted moments, filtered horizontally then vertically; the
    // rows' sums are added in order (the same bits for any thread count).
    let rows_sum: Vec<f64> = (0..out_rows)
        .into_par_iter()
        .map(|r0| {
            let mut acc = vec![[0.0f64; 5]; out_cols];
            for (dy, wy) in w1.iter().enumerate() {
                let base = (r0 + dy) * cols;
                for (c0, a) in acc.iter_mut().enumerate() {
                    let mut m = [0.0f64; 5];
                    for (dx, wx) in w1.iter().enumerate() {
                        let i = base + c0 + dx;
                        let (xv, yv) = (x[i] as f64, y[i] as f64);
                        m[0] += wx * xv;
                        m[1] += wx * yv;
                        m[2] += wx * xv * xv;
                        m[3] += wx * yv * yv;
                        m[4] += wx * xv * yv;
                    }
                    for k in 0..5 {
                        a[k] += wy * m[k];
                    }
                }
            }
            acc.iter()
                .map(|m| {
                    let (mx, my) = (m[0], m[1]);
                    let vx = (m[2] - mx * mx).max(0.0);
                    let vy = (m[3] - my * my).max(0.0);
                    let cxy = m[4] - mx * my;
                    (2.0 * mx * my + c1) * (2.0 * cxy + c2)
                        / ((mx * mx + my * my + c1) * (vx + vy + c2))
                })
                .sum::<f64>()
        })
        .collect();
    Ok(rows_sum.iter().sum::<f64>() / (out_rows * out_cols) as f64)
}

/// PSNR and SSIM of a test image against a reference.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Quality {
    /// Peak signal-to-noise ratio, dB (the mean over channels of their MSE, then the ratio);
    /// identical images give infinity, which JSON writes as null.
    #[serde(deserialize_with = "null_is_infinity")]
    pub psnr_db: f64,
    /// Structural similarity (the mean of the channels' indices); None where a channel is
    /// smaller than SSIM's 11 x 11 window.
    #[serde(default)]
    pub ssim: Option<f64>,
}

fn null_is_infinity<'de, D: serde::Deserializer<'de>>(d: D) -> std::result::Result<f64, D::Error> {
    let v: Option<f64> = serde::Deserialize::deserialize(d)?;
    Ok(v.unwrap_or(f64::INFINITY))
}

/// [`psnr_db`] over all channels together and the mean [`ssim`] of the channels; `peak` is
/// both the PSNR peak and the SSIM dynamic range.
pub fn quality(reference: &[Plane], test: &[Plane], peak: f64) -> Result<Quality> {
    if reference.len() != test.len() || reference.is_empty() {
        return Err(AnalysisError::invalid(
            "image quality",
            format!(
                "{} test channels against {} reference channels",
                test.len(),
                reference.len()
            ),
        ));
    }
    let side = 2 * WINDOW_RADIUS + 1;
    let windowed = reference.iter().all(|p| p.rows >= side && p.cols >= side);
    let mut mse_sum = 0.0;
    let mut ssim_sum = 0.0;
    for (a, b) in reference.iter().zip(test) {
        mse_sum += mse(a, b)?;
        if windowed {
            ssim_sum += ssim(a, b, peak)?;
        }
    }
    let n = reference.len() as f64;
    Ok(Quality {
        psnr_db: 10.0 * (peak * peak / (mse_sum / n)).log10(),
        ssim: windowed.then_some(ssim_sum / n),
    })
}
