//! Noise of a uniform region: signal-to-noise ratio per channel and the noise power spectrum.
//!
//! - [`snr`], [`snr_raw`]: mean / standard deviation of a region (ISO 15739:2023 §6 "total" SNR
//!   of a uniform patch: temporal and fixed-pattern noise together), also in dB, 20 log10(mean/std).
//! - [`nps`]: the 2D noise power spectrum `NPS(u, v) = <|DFT(roi - trend)|^2> dx dy / (Nx Ny)`
//!   averaged over overlapping square sub-ROIs (IEC 62220-1-1:2015 §5.4 / ISO 15739 Annex
//!   style), with the mean or a least-squares plane removed from each sub-ROI, and its radial
//!   average. With dx = dy = 1 pixel its integral over the frequency plane (cycles/pixel)^2 is the
//!   variance of the detrended region (Parseval), in the plane's unit squared.

use crate::error::{AnalysisError, Result};
use crate::image::{Moments, Plane, Rect};
use crate::roi::raw_rect_moments;
use camsim_core::RawImage;
use rayon::prelude::*;
use rustfft::num_complex::Complex;
use rustfft::FftPlanner;
use serde::{Deserialize, Serialize};

/// Signal-to-noise ratio of one channel of a uniform region.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Snr {
    /// Mean, the plane's unit (DN above black for raw data).
    pub mean: f64,
    /// Sample standard deviation (n - 1), same unit.
    pub std: f64,
    /// mean / std (infinite for a noise-free region).
    pub snr: f64,
    /// 20 log10(mean / std), dB.
    pub snr_db: f64,
    /// Pixels used.
    pub n: usize,
}

impl Snr {
    fn from_moments(m: &Moments) -> Snr {
        let (mean, std) = (m.mean(), m.std());
        let snr = mean / std;
        Snr {
            mean,
            std,
            snr,
            snr_db: 20.0 * snr.log10(),
            n: m.n,
        }
    }
}

/// SNR of the pixels of `plane` in `rect` (None: the whole plane).
pub fn snr(plane: &Plane, rect: Option<Rect>) -> Result<Snr> {
    let rect = rect.unwrap_or_else(|| plane.full_rect());
    let (mean, std, n) = plane.stats(&rect)?;
    if n < 2 {
        return Err(AnalysisError::invalid(
            "snr region",
            format!("{rect} holds {n} pixel(s): need at least 2"),
        ));
    }
    let snr = mean / std;
    Ok(Snr {
        mean,
        std,
        snr,
        snr_db: 20.0 * snr.log10(),
        n,
    })
}

/// SNR per CFA channel (R, G, B; both greens pooled) of a raw mosaic in `rect`, black subtracted.
pub fn snr_raw(raw: &RawImage, rect: &Rect) -> Result<[Snr; 3]> {
    let m = raw_rect_moments(raw, rect)?;
    if let Some(k) = m.iter().position(|m| m.n < 2) {
        return Err(AnalysisError::invalid(
            "snr region",
            format!(
                "{rect} holds {} pixel(s) of channel {k}: need at least 2",
                m[k].n
            ),
        ));
    }
    Ok(m.map(|m| Snr::from_moments(&m)))
}

/// What is subtracted from each sub-ROI before its transform.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Detrend {
    /// The sub-ROI's mean.
    #[default]
    Mean,
    /// The least-squares plane a + b x + c y (removes illumination fall-off and shading ramps).
    Plane,
}

/// Options of [`nps`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct NpsOptions {
    /// Side of the square sub-ROIs, pixels (>= 4; 64 or 128 is usual).
    pub roi_px: usize,
    /// Overlap of neighbouring sub-ROIs, fraction in [0, 0.9] (0.5 = half, IEC 62220-1).
    pub overlap: f64,
    /// Trend removal per sub-ROI.
    pub detrend: Detrend,
}

impl Default for NpsOptions {
    fn default() -> Self {
        NpsOptions {
            roi_px: 64,
            overlap: 0.5,
            detrend: Detrend::Mean,
        }
    }
}

/// The noise power spectrum of a region.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct NpsResult {
    /// Side of the sub-ROIs, pixels.
    pub roi_px: usize,
    /// Number of sub-ROIs averaged.
    pub rois: usize,
    /// Frequency of each row / column of `nps_2d`, cycles/pixel, from -1/2 (zero in the middle).
    pub freq_cy_per_px: Vec<f64>,
    /// NPS(v, u), `roi_px x roi_px` row-major (rows: vertical frequency v), zero frequency at
    /// index roi_px / 2; unit: the plane's unit squared times pixel^2.
    pub nps_2d: Vec<f64>,
    /// Centres of the radial bins, cycles/pixel (0 to 1/2 in steps of 1 / roi_px).
    pub radial_freq_cy_per_px: Vec<f64>,
    /// Radially averaged NPS in each bin.
    pub radial_nps: Vec<f64>,
    /// Integral of the NPS over the frequency plane = mean variance of the detrended sub-ROIs.
    pub variance: f64,
    /// Mean signal of the region.
    pub mean: f64,
}

/// Noise power spectrum of `plane` inside `rect` (None: the whole plane).
pub fn nps(plane: &Plane, rect: Option<Rect>, opts: &NpsOptions) -> Result<NpsResult> {
    let rect = rect.unwrap_or_else(|| plane.full_rect());
    rect.check_inside(plane.rows, plane.cols, "nps region")?;
    let n = opts.roi_px;
    if !(4..=4096).contains(&n) {
        return Err(AnalysisError::invalid(
            "nps roi_px",
            format!("{n}: must be 4 to 4096 pixels"),
        ));
    }
    if !(opts.overlap >= 0.0 && opts.overlap <= 0.9) {
        return Err(AnalysisError::invalid(
            "nps overlap",
            format!("{}: must be in [0, 0.9]", opts.overlap),
        ));
    }
    if rect.rows < n || rect.cols < n {
        return Err(AnalysisError::invalid(
            "nps region",
            format!("{rect} is smaller than one {n} x {n} sub-ROI"),
        ));
    }
    if plane.data.iter().any(|v| !v.is_finite()) {
        return Err(AnalysisError::invalid(
            "nps",
            "the plane holds values that are not finite",
        ));
    }
    let step = ((n as f64 * (1.0 - opts.overlap)).round() as usize).max(1);
    let starts = |len: usize| (0..=(len - n) / step).map(move |i| i * step);
    let corners: Vec<(usize, usize)> = starts(rect.rows)
        .flat_map(|r| starts(rect.cols).map(move |c| (rect.row + r, rect.col + c)))
        .collect();
    let fft = FftPlanner::<f64>::new().plan_fft_forward(n);
    // One periodogram per sub-ROI (in parallel), summed in a fixed order: deterministic.
    let spectra: Vec<Vec<f64>> = corners
        .par_iter()
        .map(|&(r0, c0)| {
            let mut buf: Vec<Complex<f64>> = Vec::with_capacity(n * n);
            for r in r0..r0 + n {
                buf.extend(
                    plane.row(r)[c0..c0 + n]
                        .iter()
                        .map(|v| Complex::new(*v as f64, 0.0)),
                );
            }
            detrend(&mut buf, n, opts.detrend);
            // 2D DFT: rows, then columns (through a transpose).
            fft.process(&mut buf);
            let mut t = transpose(&buf, n);
            fft.process(&mut t);
            // t[u][v] -> |.|^2 at (v, u), rows v.
            let mut p = vec![0.0; n * n];
            for u in 0..n {
                for v in 0..n {
                    p[v * n + u] = t[u * n + v].norm_sqr();
                }
            }
            p
        })
        .collect();
    let mut acc = vec![0.0f64; n * n];
    for s in &spectra {
        acc.iter_mut().zip(s).for_each(|(a, v)| *a += v);
    }
    // NPS = <|DFT|^2> dx dy / (Nx Ny), dx = dy = 1 pixel; then shift zero frequency to the middle.
    let norm = 1.0 / (corners.len() as f64 * (n * n) as f64);
    let h = n / 2;
    let mut nps_2d = vec![0.0; n * n];
    for v in 0..n {
        for u in 0..n {
            nps_2d[((v + h) % n) * n + (u + h) % n] = acc[v * n + u] * norm;
        }
    }
    let freq_cy_per_px: Vec<f64> = (0..n).map(|i| (i as f64 - h as f64) / n as f64).collect();
    // Integral over the frequency plane: sum NPS du dv, du = dv = 1/n cycles/pixel.
    let variance = nps_2d.iter().sum::<f64>() / (n * n) as f64;
    // Radial bins of width 1/n centred on k/n, k = 0..=n/2.
    let mut sum = vec![0.0; h + 1];
    let mut cnt = vec![0usize; h + 1];
    for (v, fv) in freq_cy_per_px.iter().enumerate() {
        for (u, fu) in freq_cy_per_px.iter().enumerate() {
            let k = ((fu * fu + fv * fv).sqrt() * n as f64).round() as usize;
            if k <= h {
                sum[k] += nps_2d[v * n + u];
                cnt[k] += 1;
            }
        }
    }
    let radial_nps = sum
        .iter()
        .zip(&cnt)
        .map(|(s, c)| s / (*c).max(1) as f64)
        .collect();
    let radial_freq_cy_per_px = (0..=h).map(|k| k as f64 / n as f64).collect();
    let (mean, _, _) = plane.stats(&rect)?;
    Ok(NpsResult {
        roi_px: n,
        rois: corners.len(),
        freq_cy_per_px,
        nps_2d,
        radial_freq_cy_per_px,
        radial_nps,
        variance,
        mean,
    })
}

fn transpose(a: &[Complex<f64>], n: usize) -> Vec<Complex<f64>> {
    let mut t = vec![Complex::new(0.0, 0.0); n * n];
    for r in 0..n {
        for c in 0..n {
            t[c * n + r] = a[r * n + c];
        }
    }
    t
}

/// Remove the mean, or the least-squares plane a + b x + c y (x, y centred, so the three terms
/// are orthogonal on the square grid and each coefficient is a ratio of sums).
fn detrend(buf: &mut [Complex<f64>], n: usize, how: Detrend) {
    let mean = buf.iter().map(|c| c.re).sum::<f64>() / (n * n) as f64;
    let centre = (n as f64 - 1.0) / 2.0;
    let (mut b, mut c) = (0.0, 0.0);
    if how == Detrend::Plane {
        let (mut sx, mut sy, mut sxx) = (0.0, 0.0, 0.0);
        for r in 0..n {
            for k in 0..n {
                let (x, y) = (k as f64 - centre, r as f64 - centre);
                let v = buf[r * n + k].re - mean;
                sx += x * v;
                sy += y * v;
                sxx += x * x;
            }
        }
        // sum x^2 = sum y^2 on a square grid.
        b = sx / sxx;
        c = sy / sxx;
    }
    for r in 0..n {
        for k in 0..n {
            let (x, y) = (k as f64 - centre, r as f64 - centre);
            buf[r * n + k].re -= mean + b * x + c * y;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};

    fn gaussian_plane(rows: usize, cols: usize, sigma: f64, seed: u64) -> Vec<f64> {
        let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
        let d = Normal::new(0.0, sigma).unwrap();
        (0..rows * cols).map(|_| d.sample(&mut rng)).collect()
    }

    #[test]
    fn white_noise_has_a_flat_nps_whose_integral_is_the_variance() {
        let (rows, cols, sigma) = (512, 512, 3.0);
        let v: Vec<f32> = gaussian_plane(rows, cols, sigma, 11)
            .iter()
            .map(|x| (100.0 + x) as f32)
            .collect();
        let p = Plane::new(rows, cols, v).unwrap();
        let r = nps(&p, None, &NpsOptions::default()).unwrap();
        assert_eq!(r.rois, 15 * 15);
        let s2 = sigma * sigma;
        eprintln!(
            "white noise: NPS integral {:.4} vs sigma^2 {s2}, mean {:.3}",
            r.variance, r.mean
        );
        assert!(
            (r.variance / s2 - 1.0).abs() < 0.03,
            "Parseval: {} vs {s2}",
            r.variance
        );
        // Flat: every radial bin but DC (removed with the mean) at sigma^2 dx dy. Each periodogram
        // value scatters by 100 % (exponential); bin k holds ~8k points of which half are
        // mirror images, in ~100 independent sub-ROIs: 5 % scatter in bin 1, less beyond, so the
        // bounds are 4 standard deviations.
        let dev: Vec<f64> = r.radial_nps.iter().map(|x| (x / s2 - 1.0).abs()).collect();
        let worst = dev[2..].iter().cloned().fold(0.0, f64::max);
        eprintln!(
            "white noise: radial bin 1 off by {:.3}, worst of bins 2.. {:.3}",
            dev[1], worst
        );
        assert!(
            dev[1] < 0.2 && worst < 0.12,
            "radial NPS {:?}",
            r.radial_nps
        );
        assert!(r.radial_nps[0] < 1e-6 * s2, "DC bin {}", r.radial_nps[0]);
    }

    #[test]
    fn low_pass_filtered_noise_matches_the_filter_transfer_function() {
        // y[c] = x[c-1]/4 + x[c]/2 + x[c+1]/4 along rows: H(u) = cos^2(pi u), so
        // NPS(u, v) = sigma^2 cos^4(pi u) for every v, and the variance is sigma^2 * 3/8.
        let (rows, cols, sigma) = (512, 514, 2.0);
        let x = gaussian_plane(rows, cols, sigma, 5);
        let y: Vec<f32> = (0..rows)
            .flat_map(|r| {
                let x = &x;
                (1..cols - 1).map(move |c| {
                    (50.0
                        + 0.25 * x[r * cols + c - 1]
                        + 0.5 * x[r * cols + c]
                        + 0.25 * x[r * cols + c + 1]) as f32
                })
            })
            .collect();
        let p = Plane::new(rows, cols - 2, y).unwrap();
        let r = nps(
            &p,
            None,
            &NpsOptions {
                roi_px: 64,
                overlap: 0.5,
                detrend: Detrend::Mean,
            },
        )
        .unwrap();
        let n = r.roi_px;
        let s2 = sigma * sigma;
        let mut worst = 0.0f64;
        for u in 0..n {
            let fu = r.freq_cy_per_px[u];
            // Average over the vertical frequencies except v = 0 (the mean removal's zero row).
            let meas = (0..n)
                .filter(|v| r.freq_cy_per_px[*v] != 0.0)
                .map(|v| r.nps_2d[v * n + u])
                .sum::<f64>()
                / (n - 1) as f64;
            let expect = s2 * (std::f64::consts::PI * fu).cos().powi(4);
            worst = worst.max((meas - expect).abs() / s2);
            assert!(
                (meas - expect).abs() < 0.04 * s2 + 0.05 * expect,
                "u = {fu}: {meas} vs {expect}"
            );
        }
        eprintln!("low-pass noise: worst |NPS - sigma^2 cos^4| = {worst:.4} sigma^2; variance {:.4} vs {:.4}", r.variance, s2 * 0.375);
        assert!((r.variance / (s2 * 0.375) - 1.0).abs() < 0.04);
    }

    #[test]
    fn plane_detrending_removes_a_ramp() {
        let (rows, cols, sigma) = (256, 256, 1.0);
        let g = gaussian_plane(rows, cols, sigma, 3);
        let v: Vec<f32> = (0..rows * cols)
            .map(|i| (100.0 + 0.2 * (i % cols) as f64 - 0.1 * (i / cols) as f64 + g[i]) as f32)
            .collect();
        let p = Plane::new(rows, cols, v).unwrap();
        let with_plane = nps(
            &p,
            None,
            &NpsOptions {
                detrend: Detrend::Plane,
                ..Default::default()
            },
        )
        .unwrap();
        let with_mean = nps(&p, None, &NpsOptions::default()).unwrap();
        assert!(
            (with_plane.variance - 1.0).abs() < 0.05,
            "{}",
            with_plane.variance
        );
        assert!(with_mean.variance > 10.0, "{}", with_mean.variance);
    }

    #[test]
    fn snr_of_a_known_region_and_bad_input() {
        let p = Plane::from_fn(10, 10, |r, c| if (r + c) % 2 == 0 { 90.0 } else { 110.0 }).unwrap();
        let s = snr(&p, None).unwrap();
        // mean 100, std = 10 sqrt(100/99) (n - 1).
        assert!(
            (s.mean - 100.0).abs() < 1e-9 && (s.std - 10.0 * (100.0f64 / 99.0).sqrt()).abs() < 1e-9
        );
        assert!((s.snr_db - 20.0 * s.snr.log10()).abs() < 1e-12);
        assert!(
            nps(&p, None, &NpsOptions::default()).is_err(),
            "10 x 10 is smaller than a 64 x 64 sub-ROI"
        );
        assert!(nps(
            &p,
            None,
            &NpsOptions {
                roi_px: 4,
                overlap: f64::NAN,
                ..Default::default()
            }
        )
        .is_err());
        assert!(snr(&p, Some(Rect::new(0, 0, 1, 1))).is_err());
    }
}
