//! Sharpening by unsharp masking: out = in + amount (in - G_r * in) where |in - G_r * in| >
//! threshold (else in), G_r a normalised Gaussian of standard deviation r pixels (sampled, cut at
//! ceil(3 r), edges clamped), per channel. The filter's transfer function is
//! 1 + amount (1 - G(f)), G(f) = sum_n g_n cos(2 pi f n) the sampled kernel's (its DTFT; about
//! exp(-2 pi^2 r^2 f^2) for r >~ 1): frequencies the blur removes are boosted by up to 1 + amount
//! (e.g. Gonzalez and Woods, Digital Image Processing, 4th ed., sec. 3.6 "unsharp masking and
//! highboost filtering").

use crate::RgbImage;
use camsim_core::error::{CoreError, Result};
use rayon::prelude::*;

/// Unsharp-mask settings.
#[derive(
    Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize, schemars::JsonSchema,
)]
#[serde(deny_unknown_fields)]
pub struct UnsharpMask {
    /// Standard deviation of the Gaussian blur, pixels (> 0).
    pub radius_px: f64,
    /// Gain of the detail (in - blur) added back (>= 0; 0 does nothing).
    pub amount: f64,
    /// Details of at most this magnitude are left alone, in the image's units (DN above black
    /// for the ISP's camera RGB); 0 sharpens everything.
    #[serde(default)]
    pub threshold: f64,
}

impl UnsharpMask {
    /// Check the values; errors name the field.
    pub fn validate(&self) -> Result<()> {
        if !(self.radius_px > 0.0 && self.radius_px <= 64.0) {
            return Err(CoreError::invalid(
                "sharpen.radius_px",
                format!("{}: must be in (0, 64] pixels", self.radius_px),
            ));
        }
        if !(self.amount >= 0.0) || !self.amount.is_finite() {
            return Err(CoreError::invalid(
                "sharpen.amount",
                format!("{}: must be >= 0", self.amount),
            ));
        }
        if !(self.threshold >= 0.0) || !self.threshold.is_finite() {
            return Err(CoreError::invalid(
                "sharpen.threshold",
                format!("{}: must be >= 0", self.threshold),
            ));
        }
        Ok(())
    }

    /// The sampled, normalised Gaussian g_-n..g_n (n = ceil(3 r)).
    pub fn kernel(&self) -> Vec<f64> {
        let n = (3.0 * self.radius_px).ceil() as isize;
        let k: Vec<f64> = (-n..=n)
            .map(|i| (-0.5 * (i as f64 / self.radius_px).powi(2)).exp())
            .collect();
        let s: f64 = k.iter().sum();
        k.into_iter().map(|v| v / s).collect()
    }

    /// The kernel's 1-D transfer function at `f` cycles per pixel: sum_n g_n cos(2 pi f n).
    pub fn blur_transfer(&self, f: f64) -> f64 {
        let k = self.kernel();
        let n = (k.len() / 2) as f64;
        k.iter()
            .enumerate()
            .map(|(i, g)| g * (2.0 * std::f64::consts::PI * f * (i as f64 - n)).cos())
            .sum()
    }

    /// Sharpen one plane (`rows x cols`).
    pub fn apply_plane(&self, plane: &[f32], rows: usize, cols: usize) -> Vec<f32> {
        let k: Vec<f32> = self.kernel().iter().map(|v| *v as f32).collect();
        let n = (k.len() / 2) as isize;
        let (ri, ci) = (rows as isize, cols as isize);
        // Horizontal pass, then vertical (separable Gaussian), edges clamped.
        let mut tmp = vec![0f32; rows * cols];
        tmp.par_chunks_mut(cols).enumerate().for_each(|(r, line)| {
            let src = &plane[r * cols..(r + 1) * cols];
            for (c, o) in line.iter_mut().enumerate() {
                *o = k
                    .iter()
                    .enumerate()
                    .map(|(j, g)| g * src[(c as isize + j as isize - n).clamp(0, ci - 1) as usize])
                    .sum();
            }
        });
        let (amount, thr) = (self.amount as f32, self.threshold as f32);
        let mut out = vec![0f32; rows * cols];
        out.par_chunks_mut(cols).enumerate().for_each(|(r, line)| {
            for (c, o) in line.iter_mut().enumerate() {
                let blur: f32 = k
                    .iter()
                    .enumerate()
                    .map(|(j, g)| {
                        g * tmp[(r as isize + j as isize - n).clamp(0, ri - 1) as usize * cols + c]
                    })
                    .sum();
                let v = plane[r * cols + c];
                let detail = v - blur;
                *o = if detail.abs() > thr {
                    v + amount * detail
                } else {
                    v
                };
            }
        });
        out
    }

    /// Sharpen each channel of `img`.
    pub fn apply(&self, img: &RgbImage) -> Result<RgbImage> {
        self.validate()?;
        let mut out = img.clone();
        if img.pixels() == 0 || self.amount == 0.0 {
            return Ok(out);
        }
        out.r = self.apply_plane(&img.r, img.rows, img.cols);
        out.g = self.apply_plane(&img.g, img.rows, img.cols);
        out.b = self.apply_plane(&img.b, img.rows, img.cols);
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Amplitude of the sinusoid at `f` cycles/px in the middle row's interior (least squares on
    /// sin and cos over whole periods).
    fn amplitude(p: &[f32], cols: usize, f: f64, c0: usize, c1: usize) -> f64 {
        let w = 2.0 * std::f64::consts::PI * f;
        let (mut s, mut c, mut n) = (0.0, 0.0, 0.0);
        let mean = p[c0..c1].iter().map(|v| *v as f64).sum::<f64>() / (c1 - c0) as f64;
        for x in c0..c1 {
            let v = p[x] as f64 - mean;
            s += v * (w * x as f64).sin();
            c += v * (w * x as f64).cos();
            n += 1.0;
        }
        let _ = cols;
        2.0 * (s * s + c * c).sqrt() / n
    }

    #[test]
    fn sine_gain_is_one_plus_amount_times_one_minus_the_blur_transfer() {
        let usm = UnsharpMask {
            radius_px: 1.5,
            amount: 0.8,
            threshold: 0.0,
        };
        let (rows, cols) = (8, 128);
        for f in [0.05, 0.125, 0.25] {
            let a0 = 10.0;
            let mut img = RgbImage::zeros(rows, cols);
            for r in 0..rows {
                for c in 0..cols {
                    let v = 100.0 + a0 * (2.0 * std::f64::consts::PI * f * c as f64).sin();
                    img.r[r * cols + c] = v as f32;
                    img.g[r * cols + c] = v as f32;
                    img.b[r * cols + c] = v as f32;
                }
            }
            let out = usm.apply(&img).unwrap();
            let row = &out.g[4 * cols..5 * cols];
            // 80 px = a whole number of periods at each f; away from the clamped edges.
            let a = amplitude(row, cols, f, 24, 104);
            let want = 1.0 + usm.amount * (1.0 - usm.blur_transfer(f));
            eprintln!("usm f {f}: gain {:.5}, closed form {want:.5}", a / a0);
            assert!(
                (a / a0 - want).abs() < 2e-3,
                "f {f}: gain {} vs {want}",
                a / a0
            );
            // The sampled kernel's transfer is close to the continuous Gaussian's.
            let g = (-2.0 * std::f64::consts::PI.powi(2) * 1.5f64.powi(2) * f * f).exp();
            assert!((usm.blur_transfer(f) - g).abs() < 1e-3);
        }
        // Details below the threshold are left alone.
        let quiet = UnsharpMask {
            threshold: 50.0,
            ..usm
        };
        let mut img = RgbImage::zeros(4, 32);
        img.g
            .iter_mut()
            .enumerate()
            .for_each(|(i, v)| *v = (i % 2) as f32 * 10.0);
        assert_eq!(quiet.apply(&img).unwrap().g, img.g);
        assert!(UnsharpMask {
            radius_px: 0.0,
            ..usm
        }
        .apply(&img)
        .is_err());
    }
}
