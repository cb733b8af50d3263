//! Camera RGB -> 8-bit display values with chroma coring against the sensor's noise floor.
//!
//! Why: a display cannot show negative light, so every preview clips at 0, and clipping
//! zero-mean noise adds a positive mean in proportion to that noise. After the colour-correction
//! matrix the channels' noise differs several-fold (under a tungsten lamp the blue channel's
//! white-balance gain makes its noise about 3x the others'), so a black surround with nothing
//! but read noise renders navy. Per-pixel fixes fail: mapping negative colours into the gamut at
//! constant luminance turns the surround yellow (the channel most often negative goes to 0), and
//! coring each pixel's chroma against its own noise greys out real but dim colours (a dark
//! patch whose chroma is 1-2 sigma per pixel, which the eye sees plainly over many pixels).
//!
//! So the decision is made on the local mean chroma: with a pixel's chroma u = (R - Y, B - Y)
//! (display-linear, Y the display's luminance), its mean u_bar over the (2r + 1)^2 window around
//! it (n pixels, clamped at the image's edges) and the chroma covariance C of one pixel under
//! the noise floor alone (camera noise sigma per channel, carried through the matrix), the
//! significance is d^2 = n u_bar^T C^-1 u_bar (u_bar's Mahalanobis distance from grey: its
//! covariance is C / n). The pixel's own chroma is scaled by max(0, 1 - tau^2 / d^2), the
//! non-negative garrote (Breiman 1995, Technometrics 37:373), tau = [`CHROMA_CORING_SIGMAS`].
//! Where nothing but noise is, d is about 1 and the pixels go grey at their own luminance, so
//! clipping biases every channel alike; where there is colour, d grows as sqrt(n) times the
//! per-pixel signal-to-noise ratio and the pixel keeps its chroma (and its own noise) untouched
//! in practice. Luminance is never changed. The noise floor is the dark-level noise (read, DSNU,
//! quantization); brighter pixels have more (shot) noise, so there coring errs on the side of
//! keeping chroma.
//!
//! A sensor without a black pedestal (the paper's Table 1: analog offset 0) clips its read noise
//! at 0 in the ADC, so the raw itself holds a positive black, E[max(0, N(0, sigma))] = 0.399 sigma
//! in every channel, which white balance turns blue. Where the clip level is known
//! ([`BlackModel::clip`]) each channel's local mean m (the same window) is corrected to the mean
//! mu of the unclipped signal, inverting m = L + (mu - L) Phi(z) + sigma phi(z), z = (mu - L) /
//! sigma (the mean of a Gaussian censored at L; Greene, Econometric Analysis, sec. 19.3), and
//! the pixel is shifted by mu - m: black goes back to 0 on average, bright pixels (m - L > 6
//! sigma) are not touched.

use crate::demosaic::RgbImage;
use camsim_core::colorimetry;
use rayon::prelude::*;

/// A 3 x 3 matrix, rows first (the colour pipeline's `Mat3`; spelled out so this module does not
/// depend on the colour module that uses it).
type Mat3 = [[f64; 3]; 3];

/// Luminance of linear sRGB: the Y row of its RGB -> XYZ matrix (IEC 61966-2-1 section 5.3).
pub const SRGB_LUMINANCE_WEIGHTS: [f64; 3] = colorimetry::LINEAR_SRGB_TO_XYZ[1];

/// Threshold of [`ChromaCoring`] in standard deviations of the local mean chroma under the noise
/// floor: with 3 a field of pure noise renders grey within about 1 % between channels (test
/// `zero_mean_noise_on_black_renders_neutral`).
pub const CHROMA_CORING_SIGMAS: f64 = 3.0;

/// Half-width of [`ChromaCoring`]'s window, pixels: the window is 7 x 7 (49 pixels), so a colour
/// at 1 sigma per pixel stands 7 sigma above the noise in the mean and keeps 82 % of its chroma.
pub const CHROMA_CORING_RADIUS_PX: usize = 3;

/// Rows per parallel band of [`render_display8`] (each band reads its window's halo rows again).
const BAND_ROWS: usize = 32;

/// Chroma coring for one camera -> display matrix and noise floor (see the module docs).
#[derive(Debug, Clone, Copy)]
pub struct ChromaCoring {
    /// Inverse covariance of one pixel's (R - Y, B - Y) under the noise floor, display-linear
    /// units^-2.
    inv_cov: [[f64; 2]; 2],
}

impl ChromaCoring {
    /// Coring for `camera_to_display` (exposure scale included) applied to camera values whose
    /// noise floor is `sigma_camera[c]` in channel c, independent between channels. `None` where
    /// there is no noise or the chroma covariance is singular (nothing to core).
    pub fn new(
        camera_to_display: &Mat3,
        y_weights: [f64; 3],
        sigma_camera: [f64; 3],
    ) -> Option<Self> {
        if sigma_camera.iter().any(|s| !(*s >= 0.0) || !s.is_finite()) {
            return None;
        }
        // Rows of the chroma map u = Q x: (R - Y, B - Y) as functions of camera values.
        let y_row: [f64; 3] =
            [0, 1, 2].map(|j| (0..3).map(|i| y_weights[i] * camera_to_display[i][j]).sum());
        let q = [0usize, 2].map(|i| [0, 1, 2].map(|j| camera_to_display[i][j] - y_row[j]));
        let v = sigma_camera.map(|s| s * s);
        let c =
            [0, 1].map(|a| [0, 1].map(|b| (0..3).map(|j| q[a][j] * q[b][j] * v[j]).sum::<f64>()));
        let det = c[0][0] * c[1][1] - c[0][1] * c[1][0];
        if !(det > 0.0) || !det.is_finite() {
            return None;
        }
        Some(ChromaCoring {
            inv_cov: [
                [c[1][1] / det, -c[0][1] / det],
                [-c[1][0] / det, c[0][0] / det],
            ],
        })
    }

    /// The chroma gain max(0, 1 - tau^2 / d^2) for the chroma sum `s` of `n` pixels:
    /// d^2 = s^T C^-1 s / n (the mean's Mahalanobis distance, its covariance being C / n).
    #[inline]
    pub fn gain(&self, s: [f64; 2], n: f64) -> f64 {
        let m = &self.inv_cov;
        let d2 = (s[0] * (m[0][0] * s[0] + m[0][1] * s[1])
            + s[1] * (m[1][0] * s[0] + m[1][1] * s[1]))
            / n;
        let tau2 = CHROMA_CORING_SIGMAS * CHROMA_CORING_SIGMAS;
        if d2 > tau2 {
            1.0 - tau2 / d2
        } else {
            0.0
        }
    }
}

/// What a preview knows about its camera values at black: the noise there (for chroma coring)
/// and, where the raw was clipped below, the clip level and the raw noise (for the censored-mean
/// correction). All in the image's units (black-subtracted DN times any gains applied).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BlackModel {
    /// Noise sigma of each channel's values at black, as the image holds them (after any
    /// averaging).
    pub sigma: [f64; 3],
    /// `(level, raw_sigma)`: each raw value was clipped at `level[c]` (e.g. minus the black
    /// level) with the raw pixel's noise `raw_sigma[c]`.
    pub clip: Option<([f64; 3], [f64; 3])>,
}

/// Mean of max(L, X), X ~ N(mu, sigma^2), as a function of t = mu - L:
/// t Phi(t / sigma) + sigma phi(t / sigma) (the mean of a censored Gaussian).
fn censored_mean_above(t: f64, sigma: f64) -> f64 {
    let z = t / sigma;
    let cdf = 0.5 * libm::erfc(-z / std::f64::consts::SQRT_2);
    let pdf = (-0.5 * z * z).exp() / (2.0 * std::f64::consts::PI).sqrt();
    t * cdf + sigma * pdf
}

/// The t = mu - L whose censored mean above L is `a` (Newton's method from t = a, where the
/// convex increasing function lies above the line: it converges monotonically). Bounded below at
/// -3 sigma (a mean that low says the window is black, not how black).
pub fn uncensored_offset(a: f64, sigma: f64) -> f64 {
    if !(sigma > 0.0) || a > 6.0 * sigma {
        return a;
    }
    let floor = -3.0 * sigma;
    if a <= censored_mean_above(floor, sigma) {
        return floor;
    }
    let mut t = a;
    for _ in 0..50 {
        let z = t / sigma;
        let slope = 0.5 * libm::erfc(-z / std::f64::consts::SQRT_2);
        let step = (censored_mean_above(t, sigma) - a) / slope;
        t -= step;
        if step.abs() < 1e-9 * sigma {
            break;
        }
    }
    t.max(floor)
}

/// Interleaved 8-bit RGB of `img`: camera values clipped at `clip` per channel (highlights),
/// corrected for a censored black and chroma-cored where `black` says how (see the module docs),
/// times `m` (camera -> display linear), tone-mapped by `tone` on the luminance (every channel
/// scaled by tone(Y) / Y, which keeps the chromaticity; `ToneCurve::Clip` leaves the values as
/// they are), then `encode` (which clips to [0, 1] and applies the transfer function) per
/// channel. Parallel over bands of rows; the same bytes for any thread count.
pub fn render_display8(
    img: &RgbImage,
    m: &Mat3,
    clip: [f64; 3],
    y_weights: [f64; 3],
    black: Option<&BlackModel>,
    tone: crate::tone::ToneCurve,
    encode: impl Fn(f64) -> u8 + Sync,
) -> Vec<u8> {
    let toned = tone != crate::tone::ToneCurve::Clip;
    let (rows, cols) = (img.rows, img.cols.max(1));
    let coring = black.and_then(|b| ChromaCoring::new(m, y_weights, b.sigma));
    let censored = black.and_then(|b| b.clip);
    let windowed = coring.is_some() || censored.is_some();
    let camera = |i: usize| -> [f64; 3] {
        [
            (img.r[i] as f64).min(clip[0]),
            (img.g[i] as f64).min(clip[1]),
            (img.b[i] as f64).min(clip[2]),
        ]
    };
    let times_m = |c: [f64; 3]| colorimetry::mat3_mul_vec(m, c);
    let luminance = |v: [f64; 3]| y_weights[0] * v[0] + y_weights[1] * v[1] + y_weights[2] * v[2];
    let mut out = vec![0u8; img.pixels() * 3];
    out.par_chunks_mut(BAND_ROWS * cols * 3)
        .enumerate()
        .for_each(|(band, chunk)| {
            let r0 = band * BAND_ROWS;
            let r1 = (r0 + chunk.len() / (cols * 3)).min(rows);
            // Sums of the camera values over each pixel's horizontal window, for the band and its
            // halo rows (one buffer per band, none per pixel).
            let rad = CHROMA_CORING_RADIUS_PX;
            let (ha, hb) = (r0.saturating_sub(rad), (r1 + rad).min(rows));
            let mut hsum = Vec::new();
            if windowed {
                hsum = vec![[0.0f64; 3]; (hb - ha) * cols];
                for r in ha..hb {
                    let line = &mut hsum[(r - ha) * cols..(r - ha + 1) * cols];
                    for (x, hx) in line.iter_mut().enumerate() {
                        let (a, b) = (x.saturating_sub(rad), (x + rad + 1).min(cols));
                        *hx = (a..b).fold([0.0; 3], |s, xx| {
                            let c = camera(r * cols + xx);
                            [s[0] + c[0], s[1] + c[1], s[2] + c[2]]
                        });
                    }
                }
            }
            for r in r0..r1 {
                let (wa, wb) = (r.saturating_sub(rad), (r + rad + 1).min(rows));
                let line = &mut chunk[(r - r0) * cols * 3..(r - r0 + 1) * cols * 3];
                for (x, px) in line.chunks_exact_mut(3).enumerate() {
                    let mut c = camera(r * cols + x);
                    let mut gain = 1.0;
                    if windowed {
                        let s = (wa..wb).fold([0.0; 3], |s, rr| {
                            let h = hsum[(rr - ha) * cols + x];
                            [s[0] + h[0], s[1] + h[1], s[2] + h[2]]
                        });
                        let n =
                            ((wb - wa) * ((x + rad + 1).min(cols) - x.saturating_sub(rad))) as f64;
                        let mut mean = s.map(|v| v / n);
                        if let Some((level, raw_sigma)) = censored {
                            for k in 0..3 {
                                let mu =
                                    level[k] + uncensored_offset(mean[k] - level[k], raw_sigma[k]);
                                c[k] += mu - mean[k];
                                mean[k] = mu;
                            }
                        }
                        if let Some(k) = &coring {
                            let v = times_m(mean);
                            let y = luminance(v);
                            gain = k.gain([(v[0] - y) * n, (v[2] - y) * n], n);
                        }
                    }
                    let mut v = times_m(c);
                    if gain != 1.0 {
                        let y = luminance(v);
                        v = v.map(|c| y + gain * (c - y));
                    }
                    if toned {
                        let y = luminance(v);
                        let f = if y > 0.0 { tone.apply(y) / y } else { 0.0 };
                        v = v.map(|c| c * f);
                    }
                    for (o, c) in px.iter_mut().zip(v) {
                        *o = encode(c);
                    }
                }
            }
        });
    out
}
