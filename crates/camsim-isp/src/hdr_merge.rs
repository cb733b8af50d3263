//! Exposure brackets and bursts merged into one linear HDR frame, each pixel's samples weighted by
//! the inverse of their noise variance from the sensor's noise model, saturated samples dropped
//! (Hasinoff, Durand and Freeman, CVPR 2010, "Noise-optimal capture for high dynamic range
//! photography", sec. 3: the minimum-variance unbiased combination of independent estimates is
//! their inverse-variance weighted mean).
//!
//! Frame i, exposed for t_i, gives the estimate x_i = (DN_i - black) / K x t_ref / t_i of the
//! signal in electrons at the reference exposure t_ref (the longest), with variance
//! (t_ref / t_i)^2 (mu_i + sigma_read^2) where mu_i = x t_i / t_ref are its expected electrons
//! (shot noise, EMVA 1288 eq. 9; sigma_read in electrons includes the quantization's 1/12 DN^2).
//! The weights need the unknown x: it is built up from the shortest exposure to the longest,
//! each longer frame accepted only while the estimate from the shorter ones predicts it below
//! [`SATURATION_MARGIN`] of its saturation (so no frame's own noise decides whether it is used,
//! which would bias the kept samples low), then refined (two passes; a fixed number, so every
//! pixel does the same work). A sample at or above that margin is never used; a pixel saturated in every frame
//! keeps its shortest frame's value (clipped: [`Merged::saturated`] counts them). A fixed offset
//! (DSNU) would be multiplied by t_ref / t_i with the signal: a calibration dark frame is
//! subtracted first (the sensor model gives it exactly, `Sensor::fixed_offset_dn`).

use camsim_core::RawImage;
use rayon::prelude::*;

/// A sample above this fraction of its frame's saturation signal is dropped: the clipped noise
/// distribution near saturation biases the mean low (at 0.95 the clip lies > 3 sigma above
/// the mean for signals above ~3600 e-, and every practical well is larger).
pub const SATURATION_MARGIN: f64 = 0.95;

/// Refinement passes of the weights after the first estimate.
const PASSES: usize = 2;

/// The sensor's noise, as the merge needs it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MergeNoise {
    /// Overall system gain K, DN per electron.
    pub gain_dn_per_e: f64,
    /// Temporal noise at zero signal, DN (read noise and quantization; DSNU is fixed and the
    /// same in every frame, so it does not enter the weights).
    pub read_noise_dn: f64,
    /// Saturation signal above black, DN (the smaller of the ADC range and the full well x K).
    pub saturation_dn: f64,
}

/// A merged frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Merged {
    /// Electrons at the reference exposure per pixel, row-major (the raw's CFA geometry).
    pub electrons: Vec<f32>,
    /// The reference exposure (the longest of the frames), s.
    pub reference_exposure_s: f64,
    /// Pixels saturated in every frame (their value is the shortest frame's, clipped).
    pub saturated: usize,
    /// Predicted standard deviation of each merged value, electrons (from the model and the
    /// merged value).
    pub sigma_e: Vec<f32>,
}

/// Merge `frames` (same size and CFA; each its own `exposure_s`, black and white level) with
/// the noise model `noise`; `dark_dn`, a calibration dark frame (per pixel, the fixed offset
/// above black at zero exposure, DN: DSNU), is subtracted from every frame first. Errors name
/// what does not fit.
pub fn merge_frames(
    frames: &[RawImage],
    noise: &MergeNoise,
    dark_dn: Option<&[f32]>,
) -> Result<Merged, String> {
    let first = frames.first().ok_or("hdr merge: no frames")?;
    let n = first.rows * first.cols;
    if let Some(d) = dark_dn.filter(|d| d.len() != n) {
        return Err(format!(
            "hdr merge: the dark frame has {} values for {} x {} pixels",
            d.len(),
            first.rows,
            first.cols
        ));
    }
    for (i, f) in frames.iter().enumerate() {
        if f.rows != first.rows || f.cols != first.cols {
            return Err(format!(
                "hdr merge: frame {i} is {} x {}, frame 0 {} x {}",
                f.rows, f.cols, first.rows, first.cols
            ));
        }
        if !(f.exposure_s > 0.0 && f.exposure_s.is_finite()) {
            return Err(format!(
                "hdr merge: frame {i} has exposure {} s; the merge needs times > 0",
                f.exposure_s
            ));
        }
    }
    if !(noise.gain_dn_per_e > 0.0 && noise.saturation_dn > 0.0 && noise.read_noise_dn >= 0.0) {
        return Err(format!("hdr merge: bad noise model {noise:?}"));
    }
    let t_ref = frames.iter().map(|f| f.exposure_s).fold(0.0, f64::max);
    let k = noise.gain_dn_per_e;
    let read_e2 = (noise.read_noise_dn / k).powi(2);
    // Frames from the longest exposure to the shortest: the first estimate is the longest
    // unsaturated sample.
    if frames.len() > 64 {
        return Err(format!(
            "hdr merge: {} frames; at most 64 are merged",
            frames.len()
        ));
    }
    // Frames from the shortest exposure to the longest.
    let mut order: Vec<usize> = (0..frames.len()).collect();
    order.sort_by(|a, b| frames[*a].exposure_s.total_cmp(&frames[*b].exposure_s));
    let shortest = order[0];
    // Per frame: t_i / t_ref and the signal at which its samples are dropped, DN above black.
    let ratio: Vec<f64> = frames.iter().map(|f| f.exposure_s / t_ref).collect();
    let limit_dn: Vec<f64> = frames
        .iter()
        .map(|f| SATURATION_MARGIN * noise.saturation_dn.min(f.white_level_dn - f.black_level_dn))
        .collect();
    let mut electrons = vec![0.0f32; n];
    let mut sigma_e = vec![0.0f32; n];
    let saturated: usize = electrons
        .par_chunks_mut(first.cols.max(1))
        .zip(sigma_e.par_chunks_mut(first.cols.max(1)))
        .enumerate()
        .map(|(r, (row, srow))| {
            let mut sat = 0;
            for (c, (out, sout)) in row.iter_mut().zip(srow.iter_mut()).enumerate() {
                let i = r * first.cols + c;
                let offset = dark_dn.map_or(0.0, |d| d[i] as f64);
                // Frame j's estimate at t_ref, electrons, unless its sample is near saturation.
                let sample = |j: usize| -> Option<f64> {
                    let dn = frames[j].dn[i] as f64 - frames[j].black_level_dn - offset;
                    (dn < limit_dn[j]).then_some(dn / k / ratio[j])
                };
                // The inverse-variance mean of the frames in `mask` with weights from `x`:
                // var(x_j) = (mu_j + read^2) / ratio_j^2, mu_j = x ratio_j (>= 0).
                let combine = |mask: u64, x: f64| -> (f64, f64) {
                    let (mut sw, mut swx) = (0.0, 0.0);
                    for (j, rj) in ratio.iter().enumerate() {
                        if mask >> j & 1 == 1 {
                            if let Some(xj) = sample(j) {
                                let w = rj * rj / ((x * rj).max(0.0) + read_e2);
                                sw += w;
                                swx += w * xj;
                            }
                        }
                    }
                    (swx / sw, 1.0 / sw)
                };
                // Every frame whose sample is below its limit; the first estimate from the
                // longest of them.
                let mut mask = 0u64;
                let mut x: Option<f64> = None;
                for &j in order.iter().rev() {
                    if let Some(xj) = sample(j) {
                        mask |= 1 << j;
                        x.get_or_insert(xj);
                    }
                }
                let Some(mut x) = x else {
                    let f = &frames[shortest];
                    *out =
                        ((f.dn[i] as f64 - f.black_level_dn - offset) / k / ratio[shortest]) as f32;
                    *sout = f32::NAN;
                    sat += 1;
                    continue;
                };
                let mut var = 0.0;
                for _ in 0..PASSES {
                    (x, var) = combine(mask, x);
                }
                *out = x as f32;
                *sout = var.sqrt() as f32;
            }
            sat
        })
        .sum();
    Ok(Merged {
        electrons,
        reference_exposure_s: t_ref,
        saturated,
        sigma_e,
    })
}
