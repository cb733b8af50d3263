//! Measured PSFs: a lab's PSF measurements, per field height and wavelength, in place of a lens
//! model (`blur = { method = "shift-variant", measured_psf = { ... } }`).
//!
//! Each field height is one spectral OpenEXR (the Fichet et al. 2021 layout camsim writes and
//! reads: one `S0.<wavelength>nm` channel per wavelength, a uniform wavelength grid): the PSF
//! measured at that height along +x of the sensor plane, columns along the radius, rows along
//! the tangent, its array centre (sample `(n - 1) / 2` of an odd side, between the two middle
//! samples of an even one) on the ideal image point, so that an off-centre measured PSF keeps its
//! lateral shift (the lens's distortion and lateral colour). Its sample spacing is the file's
//! `camsimSampleSpacingM`, or `spacing_um` for files that do not carry it. Values are relative
//! (each PSF is normalized to unit sum); the lens's transmission and shading stay the optics'
//! own keys.
//!
//! For the shift-variant stage ([`crate::shift_variant`]) the PSF at each of its field heights
//! and wavelengths is built from the measurements: linear in wavelength between the file's
//! bands (the nearest band outside them), then the two bracketing heights' PSFs, each resampled
//! to the stage's fine grid and normalized, mixed linearly in height (the last height beyond the
//! last measurement). Resampling conserves each PSF's energy and centroid: a measurement finer
//! than the grid is splatted bilinearly onto it; a coarser one is sampled bilinearly at the grid's
//! sample centres. The stage then rotates each block's PSF to its azimuth as for any other
//! source.

use crate::config::MeasuredPsfConfig;
use crate::error::{OpticsError, Result};
use crate::rtf_psf::FieldKernels;
use rayon::prelude::*;

/// One measured field height's PSF.
#[derive(Debug, Clone)]
struct Measured {
    rows: usize,
    cols: usize,
    spacing_m: f64,
    wavelengths_nm: Vec<f64>,
    /// Band-major, `data[(b * rows + r) * cols + c]`, each band non-negative with unit sum.
    data: Vec<f32>,
}

/// The measured PSFs of a lens, checked ([`MeasuredPsfConfig`]).
#[derive(Debug, Clone)]
pub struct MeasuredPsf {
    /// Field heights of the measurements, m in the sensor plane, increasing.
    heights_m: Vec<f64>,
    fields: Vec<Measured>,
}

/// The largest PSF file side the reader takes, samples.
pub const MAX_PSF_SIDE: usize = 4096;

impl MeasuredPsf {
    /// Read and check every file of `c` (errors name the key and the file).
    pub fn from_config(c: &MeasuredPsfConfig) -> Result<MeasuredPsf> {
        let key = "blur.measured_psf";
        if c.files.is_empty() {
            return Err(OpticsError::config(
                format!("{key}.files"),
                "give at least one { field_height_mm, file }",
            ));
        }
        if let Some(s) = c.spacing_um {
            if !(s > 0.0 && s.is_finite()) {
                return Err(OpticsError::config(
                    format!("{key}.spacing_um"),
                    format!("{s} must be a positive number"),
                ));
            }
        }
        let mut heights_m = Vec::with_capacity(c.files.len());
        let mut fields = Vec::with_capacity(c.files.len());
        for (i, f) in c.files.iter().enumerate() {
            let fkey = format!("{key}.files[{i}]");
            let h = f.field_height_mm;
            if !(h >= 0.0 && h.is_finite()) || heights_m.last().is_some_and(|&l| h * 1e-3 <= l) {
                return Err(OpticsError::config(
                    format!("{fkey}.field_height_mm"),
                    format!("{h}: field heights must be finite, >= 0 and strictly increasing"),
                ));
            }
            let named =
                |m: String| OpticsError::config(&fkey, format!("{}: {m}", f.file.display()));
            let (img, info) = camsim_io::exr::read_spectral_exr_with_info(&f.file)
                .map_err(|e| OpticsError::config(&fkey, e.to_string()))?;
            let spacing_m = match (c.spacing_um, info.sample_spacing_known) {
                (Some(s), _) => s * 1e-6,
                (None, true) => img.sample_spacing_m,
                (None, false) => {
                    return Err(named(
                        "the file does not carry its sample spacing (camsimSampleSpacingM): give measured_psf.spacing_um".into(),
                    ))
                }
            };
            if img.rows > MAX_PSF_SIDE || img.cols > MAX_PSF_SIDE {
                return Err(named(format!(
                    "{} x {} samples: at most {MAX_PSF_SIDE} a side",
                    img.cols, img.rows
                )));
            }
            let n = img.rows * img.cols;
            let wavelengths_nm: Vec<f64> = (0..img.bands())
                .map(|b| img.grid.wavelength_nm(b))
                .collect();
            let mut data = img.data;
            // Each band to unit sum, so that bands mix by weight, not by their measured scale.
            for (b, band) in data.chunks_mut(n).enumerate() {
                let sum: f64 = band.iter().map(|&v| v as f64).sum();
                if !(sum > 0.0 && sum.is_finite()) {
                    return Err(named(format!(
                        "the PSF at {} nm has no energy (its samples sum to {sum})",
                        wavelengths_nm[b]
                    )));
                }
                band.iter_mut().for_each(|v| *v = (*v as f64 / sum) as f32);
            }
            heights_m.push(h * 1e-3);
            fields.push(Measured {
                rows: img.rows,
                cols: img.cols,
                spacing_m,
                wavelengths_nm,
                data,
            });
        }
        Ok(MeasuredPsf { heights_m, fields })
    }

    /// The stage's field kernels ([`FieldKernels`]) at `heights_m` and `wavelengths_nm`, on the
    /// grid `s` times finer than `spacing_m`; the kernel side (image samples, odd, at most
    /// `max_kernel`) covers the largest measurement.
    pub(crate) fn field_kernels(
        &self,
        heights_m: &[f64],
        wavelengths_nm: &[f64],
        spacing_m: f64,
        s: usize,
        max_kernel: usize,
    ) -> Result<FieldKernels> {
        let extent_m = self
            .fields
            .iter()
            .map(|f| f.rows.max(f.cols) as f64 * f.spacing_m)
            .fold(0.0, f64::max);
        let k = (2 * (0.5 * extent_m / spacing_m).ceil() as usize + 1)
            .max(3)
            .min(max_kernel);
        let n = k * s;
        let fine_m = spacing_m / s as f64;
        let kernels = heights_m
            .par_iter()
            .map(|&h| {
                // The bracketing measurements and the weight of the upper one.
                let hs = &self.heights_m;
                let (i, t) = match hs.iter().position(|&m| m > h) {
                    None => (hs.len() - 1, 0.0),
                    Some(0) => (0, 0.0),
                    Some(j) => (j - 1, (h - hs[j - 1]) / (hs[j] - hs[j - 1])),
                };
                wavelengths_nm
                    .iter()
                    .map(|&wl| {
                        let mut k = self.fields[i].resampled(wl, fine_m, n);
                        if t > 0.0 {
                            let up = self.fields[i + 1].resampled(wl, fine_m, n);
                            for (a, b) in k.iter_mut().zip(&up) {
                                *a = ((1.0 - t) * *a as f64 + t * *b as f64) as f32;
                            }
                        }
                        k
                    })
                    .collect::<Vec<_>>()
            })
            .collect();
        Ok(FieldKernels { k, kernels })
    }
}

impl Measured {
    /// The PSF at `wl` nm (linear between bands, the nearest band outside them) on an `n` x `n`
    /// grid of spacing `fine_m` centred like the file's, normalized to unit sum.
    fn resampled(&self, wl: f64, fine_m: f64, n: usize) -> Vec<f32> {
        let w = &self.wavelengths_nm;
        let (b0, b1, t) = match w.iter().position(|&x| x > wl) {
            None => (w.len() - 1, w.len() - 1, 0.0),
            Some(0) => (0, 0, 0.0),
            Some(j) => (j - 1, j, (wl - w[j - 1]) / (w[j] - w[j - 1])),
        };
        let px = self.rows * self.cols;
        let at = |b: usize, r: usize, c: usize| self.data[b * px + r * self.cols + c] as f64;
        let value = |r: usize, c: usize| (1.0 - t) * at(b0, r, c) + t * at(b1, r, c);
        let mut out = vec![0.0f64; n * n];
        let mid_f = (n as f64 - 1.0) / 2.0;
        let (mid_r, mid_c) = (
            (self.rows as f64 - 1.0) / 2.0,
            (self.cols as f64 - 1.0) / 2.0,
        );
        let ratio = self.spacing_m / fine_m;
        if ratio <= 1.0 {
            // Finer (or equal) measurement: splat each sample onto the 4 nearest grid samples.
            for r in 0..self.rows {
                let y = (r as f64 - mid_r) * ratio + mid_f;
                for c in 0..self.cols {
                    let v = value(r, c);
                    if v == 0.0 {
                        continue;
                    }
                    let x = (c as f64 - mid_c) * ratio + mid_f;
                    let (x0, y0) = (x.floor(), y.floor());
                    let (fx, fy) = (x - x0, y - y0);
                    for (dy, wy) in [(0isize, 1.0 - fy), (1, fy)] {
                        for (dx, wx) in [(0isize, 1.0 - fx), (1, fx)] {
                            let (cx, cy) = (x0 as isize + dx, y0 as isize + dy);
                            if cx >= 0 && cy >= 0 && (cx as usize) < n && (cy as usize) < n {
                                out[cy as usize * n + cx as usize] += v * wx * wy;
                            }
                        }
                    }
                }
            }
        } else {
            // Coarser measurement: bilinear samples of it at the grid's sample centres.
            for gy in 0..n {
                let y = (gy as f64 - mid_f) / ratio + mid_r;
                if y < 0.0 || y > (self.rows - 1) as f64 {
                    continue;
                }
                let (r0, fy) = (y.floor() as usize, y - y.floor());
                let r1 = (r0 + 1).min(self.rows - 1);
                for gx in 0..n {
                    let x = (gx as f64 - mid_f) / ratio + mid_c;
                    if x < 0.0 || x > (self.cols - 1) as f64 {
                        continue;
                    }
                    let (c0, fx) = (x.floor() as usize, x - x.floor());
                    let c1 = (c0 + 1).min(self.cols - 1);
                    out[gy * n + gx] = (1.0 - fy)
                        * ((1.0 - fx) * value(r0, c0) + fx * value(r0, c1))
                        + fy * ((1.0 - fx) * value(r1, c0) + fx * value(r1, c1));
                }
            }
        }
        let sum: f64 = out.iter().sum();
        if sum > 0.0 {
            out.iter().map(|v| (v / sum) as f32).collect()
        } else {
            // All of it fell outside the kernel: a point (the grid cannot hold it).
            let mut d = vec![0.0f32; n * n];
            d[(n / 2) * n + n / 2] = 1.0;
            d
        }
    }
}
