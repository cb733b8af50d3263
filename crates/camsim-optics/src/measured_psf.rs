//! Measured PSFs: a lab's PSF measurements, per field height and wavelength, in place of a lens
//! model (`blur = { method = "shift-variant", measured_psf = { ... } }`).
//!
//! Each field height is one spectral OpenEXR (or a lens MTF table, below) (the Fichet et al. 2021 layout camsim writes and
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
//! source. Its kernels are as large as the square that holds all but 1e-4 of every measured PSF's
//! energy (so an EXR with wide empty margins costs no more than its PSF).
//!
//! A file ending in `.csv` is a lens MTF table instead (a lens bench's or a lens datasheet's
//! tangential and sagittal MTF in cycles/mm at that height, per wavelength or for the band; see
//! [`camsim_io::measurements::read_lens_mtf_csv`]): its PSF is the separable zero-phase PSF
//! whose radial and tangential sections have those MTFs (`Measured::from_mtf`), so the table
//! gives the blur's size and shape but not its asymmetry or shift; `spacing_um` does not apply.

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
            let is_csv = f
                .file
                .extension()
                .is_some_and(|e| e.eq_ignore_ascii_case("csv"));
            if is_csv {
                let table = camsim_io::measurements::read_lens_mtf_csv(&f.file)
                    .map_err(|e| OpticsError::config(&fkey, e.to_string()))?;
                heights_m.push(h * 1e-3);
                fields.push(Measured::from_mtf(&table));
                continue;
            }
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
        let half_width_m = self
            .fields
            .iter()
            .map(Measured::support_half_width_m)
            .fold(0.0, f64::max);
        let k = (2 * (half_width_m / spacing_m).ceil() as usize + 1)
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

/// The energy a kernel may leave outside its square (per band, before renormalizing).
const SUPPORT_TAIL: f64 = 1e-4;

impl Measured {
    /// The PSF of a lens MTF table ([`camsim_io::measurements::read_lens_mtf_csv`]) as the
    /// separable PSF `LSF_t(x) LSF_s(y)` (x along the radius, y along the tangent), each line
    /// spread function the inverse Fourier transform of its OTF section MTF e^(i PTF): the LSF is
    /// real, so the OTF is Hermitian and `LSF(x) = 2 int_0^f_max MTF(f) cos(2 pi f x + PTF(f))
    /// df` (Goodman, *Introduction to Fourier Optics*, 4th ed., sec. 7.3: the LSF is the 1D
    /// inverse transform of the OTF's section). Without phase columns the PTF is 0 (an even,
    /// centred LSF); with them a lateral shift (a PTF linear in f) or coma's asymmetry comes
    /// through. The PSF's sections reproduce both curves exactly (the OTF of a separable PSF
    /// along x is the transform of its x factor), though a real lens's PSF need not be separable.
    ///
    /// The MTF is taken linear between the table's points, 1 at zero frequency when the table
    /// starts above it, normalized by its value there, and 0 beyond the last point (the table
    /// should reach the cut-off or the MTF's floor; a truncated curve rings, and the ringing's
    /// negative lobes are clipped). Samples are `1 / (4 f_max)` apart (twice the table's Nyquist
    /// rate), on a frequency grid of half the table's finest step (at most `f_max / 16`), over half
    /// the cosine series' period (so its periodic copies stay outside), at most 1025 a side.
    fn from_mtf(table: &camsim_io::measurements::LensMtf) -> Measured {
        let curves = &table.curves;
        let f_max = curves
            .iter()
            .flat_map(|(_, c)| c.freq_cyc_per_mm.last().copied())
            .fold(0.0, f64::max)
            .max(1e-9);
        let min_step = curves
            .iter()
            .flat_map(|(_, c)| c.freq_cyc_per_mm.windows(2).map(|w| w[1] - w[0]))
            .fold(f64::INFINITY, f64::min);
        // The frequency step: half the table's finest, at most f_max / 16 (so the window holds 33
        // samples at least) and at least f_max / 8192 (a bound on the work).
        let df = (0.5 * min_step).clamp(f_max / 8192.0, f_max / 16.0);
        let spacing_mm = 1.0 / (4.0 * f_max);
        // The frequency grid: f_j = j df, j = 0..=m, trapezoid weights; the window 2 m + 1
        // samples (half the period 1 / df), at most 1025.
        let m = (f_max / df).ceil() as usize;
        let half = m.min(512);
        let n = 2 * half + 1;
        // `values` linear in frequency between the table's points, `v0` at zero frequency
        // before the first point, 0 beyond the last.
        let interp = |freq: &[f64], values: &[f64], v0: f64, f: f64| -> f64 {
            if f > freq[freq.len() - 1] {
                return 0.0;
            }
            let (mut f0, mut m0) = (0.0, v0);
            for (&fi, &mi) in freq.iter().zip(values) {
                if fi >= f {
                    if fi == f0 {
                        return mi;
                    }
                    return m0 + (mi - m0) * (f - f0) / (fi - f0);
                }
                (f0, m0) = (fi, mi);
            }
            m0
        };
        let lsf = |freq: &[f64], mtf: &[f64], ptf_rad: &[f64]| -> Vec<f64> {
            let m_at_0 = interp(freq, mtf, 1.0, 0.0).max(1e-12);
            // Trapezoid weight x MTF, and the phase, at f_j = j df.
            let w: Vec<(f64, f64)> = (0..=m)
                .map(|j| {
                    let trap = if j == 0 || j == m { 0.5 } else { 1.0 };
                    let f = j as f64 * df;
                    (
                        trap * interp(freq, mtf, 1.0, f) / m_at_0,
                        interp(freq, ptf_rad, 0.0, f),
                    )
                })
                .collect();
            let mut out: Vec<f64> = (0..n)
                .map(|i| {
                    let x_mm = (i as f64 - half as f64) * spacing_mm;
                    let v: f64 = w
                        .iter()
                        .enumerate()
                        .map(|(j, (wj, phase))| {
                            wj * (2.0 * std::f64::consts::PI * j as f64 * df * x_mm + phase).cos()
                        })
                        .sum();
                    v.max(0.0)
                })
                .collect();
            let sum: f64 = out.iter().sum();
            if sum > 0.0 {
                out.iter_mut().for_each(|v| *v /= sum);
            } else {
                out.iter_mut().for_each(|v| *v = 0.0);
                out[half] = 1.0;
            }
            out
        };
        let mut data = Vec::with_capacity(curves.len() * n * n);
        for (_, c) in curves {
            let lt = lsf(&c.freq_cyc_per_mm, &c.tangential, &c.tangential_phase_rad);
            let ls = lsf(&c.freq_cyc_per_mm, &c.sagittal, &c.sagittal_phase_rad);
            for &sy in &ls {
                data.extend(lt.iter().map(|&tx| (sy * tx) as f32));
            }
        }
        Measured {
            rows: n,
            cols: n,
            spacing_m: spacing_mm * 1e-3,
            // Without a wavelength column: one band that every wavelength takes.
            wavelengths_nm: curves.iter().map(|(w, _)| w.unwrap_or(0.0)).collect(),
            data,
        }
    }

    /// Half the side of the square about the array centre that holds all but [`SUPPORT_TAIL`]
    /// of every band's energy, m (the kernel need not be larger).
    fn support_half_width_m(&self) -> f64 {
        let (mid_r, mid_c) = (
            (self.rows as f64 - 1.0) / 2.0,
            (self.cols as f64 - 1.0) / 2.0,
        );
        let px = self.rows * self.cols;
        let rings = self.rows.max(self.cols);
        let mut worst = 0.0f64;
        for band in self.data.chunks(px) {
            // Energy per square ring, the ring of a sample its Chebyshev distance from the centre
            // rounded up (in half-sample steps for even sides).
            let mut per_ring = vec![0.0f64; rings + 1];
            for r in 0..self.rows {
                for c in 0..self.cols {
                    let d = (r as f64 - mid_r).abs().max((c as f64 - mid_c).abs());
                    per_ring[(d.ceil() as usize).min(rings)] += band[r * self.cols + c] as f64;
                }
            }
            let total: f64 = per_ring.iter().sum();
            let mut acc = 0.0;
            for (d, e) in per_ring.iter().enumerate() {
                acc += e;
                if acc >= (1.0 - SUPPORT_TAIL) * total {
                    worst = worst.max(d as f64 + 0.5);
                    break;
                }
            }
        }
        worst * self.spacing_m
    }

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
