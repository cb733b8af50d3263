//! Denoising of the raw mosaic by non-local means (Buades, Coll and Morel, "A non-local
//! algorithm for image denoising", CVPR 2005; the pixelwise form and parameters of Buades, Coll
//! and Morel, "Non-Local Means Denoising", Image Processing On Line 1 (2011) 208-212), run on
//! each CFA sub-lattice (the pixels of one tile position: one filter, no demosaic yet, so the
//! noise is independent between pixels and the sensor's model holds exactly).
//!
//! Each pixel p becomes the weighted mean of the pixels q of its (2 s + 1)^2 search window,
//! w(p, q) = exp(-max(d^2 - 2 sigma^2, 0) / h^2), d^2 the mean squared difference of the
//! (2 f + 1)^2 patches around p and q (edges clamped), h = [`NLM_H_PER_SIGMA`] x strength x sigma,
//! and the centre's own weight the largest of the others' (IPOL 2011, sec. 2). The noise is the
//! sensor's Poisson-Gaussian model (EMVA 1288 linear model): sigma^2(v) = K max(v, 0) +
//! sigma_floor^2 at p's patch mean v (DN above black), so one `strength` of 1 ('auto') fits every
//! signal level. The 2 sigma^2 subtracted is the expected d^2 of two patches of the same mean.

use camsim_core::error::{CoreError, Result};
use camsim_core::RawImage;
use rayon::prelude::*;

/// The ISP's denoising method.
#[derive(
    Debug,
    Clone,
    Copy,
    PartialEq,
    Eq,
    Default,
    serde::Serialize,
    serde::Deserialize,
    schemars::JsonSchema,
)]
#[serde(rename_all = "kebab-case")]
pub enum Denoise {
    /// No denoising (the default).
    #[default]
    Off,
    /// Non-local means per CFA sub-lattice, its strength from the sensor's noise model.
    Nlm,
}

impl Denoise {
    /// The name the configs take.
    pub fn name(self) -> &'static str {
        match self {
            Denoise::Off => "off",
            Denoise::Nlm => "nlm",
        }
    }
}

/// h / sigma of the weights at strength 1: IPOL 2011's value for grey images with sigma up to
/// 15 (of 255) and 3 x 3 patches.
pub const NLM_H_PER_SIGMA: f64 = 0.4;

/// Patch half-width, sub-lattice pixels (3 x 3 patches, IPOL 2011 for sigma up to 15).
pub const NLM_PATCH_RADIUS: usize = 1;

/// Search half-width, sub-lattice pixels: an 11 x 11 window (121 candidates; IPOL 2011 uses
/// 21 x 21, which costs 3.6x as much for little more smoothing on a mosaic's sub-lattices).
pub const NLM_SEARCH_RADIUS: usize = 5;

/// The sensor's noise model in DN: variance K v + floor^2 at v DN above black.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NoiseModel {
    /// Conversion gain, DN per electron (the shot-noise term; 0 for read noise only).
    pub k_dn_per_e: f64,
    /// Noise at black, DN (read, DSNU, quantization).
    pub floor_dn: f64,
}

impl NoiseModel {
    /// Noise sigma at `v_dn` above black, DN.
    #[inline]
    pub fn sigma_dn(&self, v_dn: f64) -> f64 {
        (self.k_dn_per_e * v_dn.max(0.0) + self.floor_dn * self.floor_dn).sqrt()
    }

    fn check(&self) -> Result<()> {
        if !(self.k_dn_per_e >= 0.0 && self.floor_dn >= 0.0)
            || !self.k_dn_per_e.is_finite()
            || !self.floor_dn.is_finite()
            || self.k_dn_per_e + self.floor_dn == 0.0
        {
            return Err(CoreError::invalid(
                "denoise",
                format!(
                    "noise model K = {} DN/e, floor {} DN: both must be >= 0 and one positive",
                    self.k_dn_per_e, self.floor_dn
                ),
            ));
        }
        Ok(())
    }
}

/// Non-local means of one plane (`rows x cols`, values DN above black), sigma of each value by
/// `noise`, h = [`NLM_H_PER_SIGMA`] x `strength` x sigma. Parallel over rows.
pub fn nlm_plane(
    plane: &[f32],
    rows: usize,
    cols: usize,
    noise: &NoiseModel,
    strength: f64,
) -> Vec<f32> {
    let f = NLM_PATCH_RADIUS as isize;
    let s = NLM_SEARCH_RADIUS as isize;
    let (ri, ci) = (rows as isize, cols as isize);
    let at = |r: isize, c: isize| plane[(r.clamp(0, ri - 1) * ci + c.clamp(0, ci - 1)) as usize];
    let patch_n = ((2 * f + 1) * (2 * f + 1)) as f64;
    let h_per_sigma = NLM_H_PER_SIGMA * strength;
    let mut out = vec![0f32; rows * cols];
    out.par_chunks_mut(cols.max(1))
        .enumerate()
        .for_each(|(r, line)| {
            let r = r as isize;
            for (c, o) in line.iter_mut().enumerate() {
                let c = c as isize;
                let mut mean = 0.0f64;
                for dr in -f..=f {
                    for dc in -f..=f {
                        mean += at(r + dr, c + dc) as f64;
                    }
                }
                let sigma = noise.sigma_dn(mean / patch_n);
                let var2 = 2.0 * sigma * sigma;
                let h2 = (h_per_sigma * sigma).powi(2);
                let (mut sum, mut wsum, mut wmax) = (0.0f64, 0.0f64, 0.0f64);
                for qr in (r - s).max(0)..=(r + s).min(ri - 1) {
                    for qc in (c - s).max(0)..=(c + s).min(ci - 1) {
                        if (qr, qc) == (r, c) {
                            continue;
                        }
                        let mut d2 = 0.0f64;
                        for dr in -f..=f {
                            for dc in -f..=f {
                                let d = at(r + dr, c + dc) as f64 - at(qr + dr, qc + dc) as f64;
                                d2 += d * d;
                            }
                        }
                        let x = (d2 / patch_n - var2).max(0.0);
                        let w = if h2 > 0.0 { (-x / h2).exp() } else { 0.0 };
                        wmax = wmax.max(w);
                        sum += w * at(qr, qc) as f64;
                        wsum += w;
                    }
                }
                // The centre takes the largest weight of the others (IPOL 2011).
                let centre = if wmax > 0.0 { wmax } else { 1.0 };
                sum += centre * at(r, c) as f64;
                wsum += centre;
                *o = (sum / wsum) as f32;
            }
        });
    out
}

/// Non-local means of a raw frame, each CFA sub-lattice (tile position) on its own, values
/// rounded back to DN. `noise` is the sensor's model in DN above the frame's black level;
/// `strength` scales h (1 = IPOL's h = 0.4 sigma; 0 returns the frame as it is).
pub fn nlm_raw(raw: &RawImage, noise: &NoiseModel, strength: f64) -> Result<RawImage> {
    noise.check()?;
    if !(strength >= 0.0) || !strength.is_finite() {
        return Err(CoreError::invalid(
            "denoise",
            format!("strength {strength}: must be >= 0"),
        ));
    }
    if raw.dn.len() != raw.rows * raw.cols || raw.rows == 0 || raw.cols == 0 {
        return Err(CoreError::invalid(
            "denoise",
            format!("{} values for {} x {}", raw.dn.len(), raw.rows, raw.cols),
        ));
    }
    if strength == 0.0 {
        return Ok(raw.clone());
    }
    let layout = raw.cfa_layout();
    let (tr, tc) = (layout.rows().max(1), layout.cols().max(1));
    let black = raw.black_level_dn;
    let white = raw.white_level_dn.clamp(0.0, u16::MAX as f64);
    let mut out = raw.clone();
    for r0 in 0..tr.min(raw.rows) {
        for c0 in 0..tc.min(raw.cols) {
            let pr = (raw.rows - r0).div_ceil(tr);
            let pc = (raw.cols - c0).div_ceil(tc);
            let mut plane = Vec::with_capacity(pr * pc);
            for r in 0..pr {
                for c in 0..pc {
                    plane.push(
                        (raw.dn[(r0 + r * tr) * raw.cols + c0 + c * tc] as f64 - black) as f32,
                    );
                }
            }
            let den = nlm_plane(&plane, pr, pc, noise, strength);
            for r in 0..pr {
                for c in 0..pc {
                    out.dn[(r0 + r * tr) * raw.cols + c0 + c * tc] =
                        (den[r * pc + c] as f64 + black).round().clamp(0.0, white) as u16;
                }
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use camsim_core::rng::{keyed, stage};
    use camsim_core::CfaPattern;
    use rand_distr::{Distribution, StandardNormal};

    /// A frame whose mean at column c is `level(c)` DN above black 64, with the model's noise.
    fn frame(
        rows: usize,
        cols: usize,
        noise: &NoiseModel,
        level: impl Fn(usize) -> f64,
    ) -> RawImage {
        let mut raw = RawImage::new(rows, cols, CfaPattern::Rggb, 12).unwrap();
        raw.black_level_dn = 64.0;
        for r in 0..rows {
            let mut rng = keyed(11, stage::ANALYSIS, 0, r as u64);
            for c in 0..cols {
                let z: f64 = StandardNormal.sample(&mut rng);
                let m = level(c);
                raw.dn[r * cols + c] = (64.0 + m + noise.sigma_dn(m) * z).round() as u16;
            }
        }
        raw
    }

    fn std_dev(v: &[f64]) -> f64 {
        let m = v.iter().sum::<f64>() / v.len() as f64;
        (v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (v.len() - 1) as f64).sqrt()
    }

    /// 10-90 % width of a rising profile (linear interpolation between samples), pixels.
    fn width_10_90(p: &[f64]) -> f64 {
        let (lo, hi) = (
            p[..8].iter().sum::<f64>() / 8.0,
            p[p.len() - 8..].iter().sum::<f64>() / 8.0,
        );
        let cross = |t: f64| {
            let y = lo + t * (hi - lo);
            let i = p.windows(2).position(|w| w[0] < y && w[1] >= y).unwrap();
            i as f64 + (y - p[i]) / (p[i + 1] - p[i])
        };
        cross(0.9) - cross(0.1)
    }

    #[test]
    fn flat_noise_falls_and_an_edge_stays_sharp() {
        let noise = NoiseModel {
            k_dn_per_e: 0.5,
            floor_dn: 3.0,
        };
        // Flat: 400 DN above black, sigma = sqrt(0.5 * 400 + 9) = 14.5 DN.
        let flat = frame(48, 48, &noise, |_| 400.0);
        let den = nlm_raw(&flat, &noise, 1.0).unwrap();
        let vals = |raw: &RawImage| -> Vec<f64> {
            // The interior (away from the clamped edges), one filter: R sites.
            (8..40)
                .step_by(2)
                .flat_map(|r| (8..40).step_by(2).map(move |c| (r, c)))
                .map(|(r, c)| raw.dn[r * 48 + c] as f64)
                .collect()
        };
        let (before, after) = (std_dev(&vals(&flat)), std_dev(&vals(&den)));
        let ratio = after / before;
        // Bounds: a weighted mean of the N = 121 window pixels (weights <= 1, the centre's the
        // largest) has at least the variance of their plain mean, sigma^2 / 121 (ratio 0.091).
        // On a flat field the patch distance is d^2 = 2 sigma^2 chi^2_9 / 9, so w = 1 for the
        // 56 % of patches below its mean and exp(-12.5 (chi^2_9 / 9 - 1)) above: about 85
        // effective pixels (ratio 0.11) if the weights were independent of the values; that they
        // favour values near the centre's raises it, and the test asks for < 0.25 (a fourfold
        // fall) and checks the lower bound.
        eprintln!("nlm flat: sigma {before:.2} -> {after:.2} DN, ratio {ratio:.4}");
        assert!(
            ratio < 0.25 && ratio > 1.0 / 121f64.sqrt(),
            "sigma ratio {ratio}"
        );
        // The mean is kept (within 3 standard errors of the input's).
        let m = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
        let (mb, ma) = (m(&vals(&flat)), m(&vals(&den)));
        assert!((ma - mb).abs() < 3.0 * before / 16.0 + 0.5, "{mb} -> {ma}");

        // Edge: 200 -> 1400 DN across a 2 px ramp at column 32 (contrast 40 sigma).
        let edge = |c: usize| 200.0 + 1200.0 * ((c as f64 - 31.0) / 2.0).clamp(0.0, 1.0);
        let raw = frame(32, 64, &noise, edge);
        let den = nlm_raw(&raw, &noise, 1.0).unwrap();
        let profile = |raw: &RawImage| -> Vec<f64> {
            (0..64)
                .map(|c| (0..32).map(|r| raw.dn[r * 64 + c] as f64).sum::<f64>() / 32.0)
                .collect()
        };
        let (w0, w1) = (width_10_90(&profile(&raw)), width_10_90(&profile(&den)));
        // The patch distance across the edge is (1200 DN)^2 / 9 per column of patch overlap,
        // 700 sigma^2: those weights are e^-4000, so the edge may widen by at most a fraction
        // of a pixel (the sub-lattice's pixel is 2 raw pixels).
        eprintln!("nlm edge 10-90 width {w0:.3} -> {w1:.3} px");
        assert!(w1 - w0 < 0.5, "10-90 width {w0} -> {w1} px");
    }

    #[test]
    fn bad_parameters_are_errors() {
        let raw = RawImage::new(4, 4, CfaPattern::Rggb, 12).unwrap();
        let bad = NoiseModel {
            k_dn_per_e: -1.0,
            floor_dn: 1.0,
        };
        assert!(nlm_raw(&raw, &bad, 1.0).is_err());
        let ok = NoiseModel {
            k_dn_per_e: 1.0,
            floor_dn: 1.0,
        };
        assert!(nlm_raw(&raw, &ok, -1.0).is_err());
        assert_eq!(nlm_raw(&raw, &ok, 0.0).unwrap(), raw);
    }
}
