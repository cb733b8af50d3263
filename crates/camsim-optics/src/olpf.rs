//! The optical low-pass (anti-aliasing) filter in front of the sensor: birefringent plates that
//! split each ray into two (or, with two crossed plates, four) rays of equal power a fixed
//! displacement apart, so every point images as two or four spots.
//!
//! A 2-spot filter of displacement d along x has the point spread
//! h(x) = [delta(x - d/2) + delta(x + d/2)] / 2, and so the transfer function
//! H(f) = cos(pi f d): a zero at f = 1 / (2 d) (with d the pixel pitch, at the sampling
//! frequency's half, Nyquist), no phase (the spots are centred). The 4-spot filter is the product
//! of one plate along x and one along y, H = cos(pi f_x d_x) cos(pi f_y d_y). (ISETCam
//! `oiBirefringentDiffuser` models the same four spots; Greivenkamp, "Color dependent optical
//! prefilter for the suppression of aliasing artifacts", Appl. Opt. 29(5), 1990, derives the
//! transfer function.)
//!
//! Applied exactly to the sampled irradiance: per row (then per column) the band-limited signal's
//! spectrum is multiplied by cos(pi f d) (an FFT of the row padded with its edge values, so the
//! image's borders act as if the edge continued).

use crate::{OpticsError, Result};
use camsim_core::SpectralImage;
use rayon::prelude::*;
use rustfft::num_complex::Complex32;
use rustfft::FftPlanner;
use serde::{Deserialize, Serialize};

/// `olpf = { spots = 4, displacement_um = 1.4 }`: a birefringent optical low-pass filter.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct OlpfConfig {
    /// 2 (one plate: spots along x) or 4 (two crossed plates: x and y). Default 4.
    #[serde(default = "default_spots")]
    pub spots: u32,
    /// Distance between the spots in the sensor plane, um (> 0); the MTF's first zero is at
    /// 1 / (2 d). A filter matched to the pixel pitch p has d = p.
    pub displacement_um: f64,
    /// The y plate's displacement, um, if it differs (4 spots only; default `displacement_um`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub displacement_y_um: Option<f64>,
}

fn default_spots() -> u32 {
    4
}

impl OlpfConfig {
    /// Check the keys (errors name them under `olpf.`).
    pub fn validate(&self) -> Result<()> {
        if self.spots != 2 && self.spots != 4 {
            return Err(OpticsError::Input(format!(
                "olpf.spots = {}: give 2 (one plate) or 4 (two crossed plates)",
                self.spots
            )));
        }
        for (k, v) in [
            ("displacement_um", Some(self.displacement_um)),
            ("displacement_y_um", self.displacement_y_um),
        ] {
            if let Some(v) = v.filter(|v| !(v.is_finite() && *v > 0.0)) {
                return Err(OpticsError::Input(format!(
                    "olpf.{k} = {v}: must be a distance > 0 um"
                )));
            }
        }
        if self.spots == 2 && self.displacement_y_um.is_some() {
            return Err(OpticsError::Input(
                "olpf.displacement_y_um: a 2-spot filter splits along x only (give spots = 4)"
                    .into(),
            ));
        }
        Ok(())
    }

    /// Displacements along x and y, m (y = 0 for 2 spots).
    pub fn displacements_m(&self) -> (f64, f64) {
        let dx = self.displacement_um * 1e-6;
        let dy = if self.spots == 4 {
            self.displacement_y_um.unwrap_or(self.displacement_um) * 1e-6
        } else {
            0.0
        };
        (dx, dy)
    }

    /// The filter's MTF at spatial frequency (fx, fy), cycles/mm: |cos(pi fx dx) cos(pi fy dy)|.
    pub fn mtf(&self, fx_cyc_per_mm: f64, fy_cyc_per_mm: f64) -> f64 {
        let (dx, dy) = self.displacements_m();
        let c = |f: f64, d: f64| (std::f64::consts::PI * f * 1e3 * d).cos();
        (c(fx_cyc_per_mm, dx) * c(fy_cyc_per_mm, dy)).abs()
    }
}

/// Filter an irradiance image in place (every band; sample spacing from the image).
pub fn apply(img: &mut SpectralImage, cfg: &OlpfConfig) -> Result<()> {
    cfg.validate()?;
    let spacing = img.sample_spacing_m;
    if !(spacing.is_finite() && spacing > 0.0) {
        return Err(OpticsError::Input(format!(
            "olpf: the image's sample spacing {spacing} m is not a distance > 0"
        )));
    }
    let (dx, dy) = cfg.displacements_m();
    let (rows, cols) = (img.rows, img.cols);
    if rows == 0 || cols == 0 {
        return Ok(());
    }
    // Band planes, row-major: data[b * rows * cols + r * cols + c].
    if dx > 0.0 {
        let line = Line::new(cols, dx / spacing);
        img.data
            .par_chunks_mut(cols)
            .for_each_init(|| line.scratch(), |s, row| line.filter(row, s));
    }
    if dy > 0.0 {
        let line = Line::new(rows, dy / spacing);
        for plane in img.data.chunks_mut(rows * cols) {
            // Columns: each gathered, filtered and written back (one column per task).
            let src: &[f32] = plane;
            let filtered: Vec<Vec<f32>> = (0..cols)
                .into_par_iter()
                .map_init(
                    || line.scratch(),
                    |s, c| {
                        let mut col: Vec<f32> = (0..rows).map(|r| src[r * cols + c]).collect();
                        line.filter(&mut col, s);
                        col
                    },
                )
                .collect();
            for (c, col) in filtered.iter().enumerate() {
                for (r, v) in col.iter().enumerate() {
                    plane[r * cols + c] = *v;
                }
            }
        }
    }
    Ok(())
}

/// One axis's filter: signals of `n` samples, displacement `d` in samples.
struct Line {
    n: usize,
    pad: usize,
    len: usize,
    gain: Vec<f32>,
    fwd: std::sync::Arc<dyn rustfft::Fft<f32>>,
    inv: std::sync::Arc<dyn rustfft::Fft<f32>>,
}

impl Line {
    fn new(n: usize, d_samples: f64) -> Line {
        // Edge padding of at least the spots' reach, so wrap-around only sees edge values.
        let pad = (d_samples / 2.0).ceil() as usize + 4;
        let len = n + 2 * pad;
        let mut planner = FftPlanner::new();
        let gain = (0..len)
            .map(|k| {
                // Signed frequency of bin k, cycles per sample.
                let f = if k <= len / 2 {
                    k as f64
                } else {
                    k as f64 - len as f64
                } / len as f64;
                ((std::f64::consts::PI * f * d_samples).cos() / len as f64) as f32
            })
            .collect();
        Line {
            n,
            pad,
            len,
            gain,
            fwd: planner.plan_fft_forward(len),
            inv: planner.plan_fft_inverse(len),
        }
    }

    fn scratch(&self) -> Vec<Complex32> {
        vec![Complex32::new(0.0, 0.0); self.len]
    }

    /// Filter the signal `v` (`n` samples) in place.
    fn filter(&self, v: &mut [f32], buf: &mut [Complex32]) {
        for (k, z) in buf.iter_mut().enumerate() {
            let i = k.saturating_sub(self.pad).min(self.n - 1);
            *z = Complex32::new(v[i], 0.0);
        }
        self.fwd.process(buf);
        for (z, g) in buf.iter_mut().zip(&self.gain) {
            *z *= *g;
        }
        self.inv.process(buf);
        for (i, x) in v.iter_mut().enumerate() {
            *x = buf[i + self.pad].re;
        }
    }
}
