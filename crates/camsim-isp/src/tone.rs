//! Tone mapping for display: a linear scene-referred luminance (of linear sRGB, 1 = the
//! display's white at the preview's exposure) to a display luminance in [0, 1]; each pixel's
//! channels are scaled alike (its chromaticity kept, as Reinhard et al. map the luminance) and
//! clipped per channel by the sRGB encoding. A merged HDR frame holds 10^4..10^6 : 1; clipping at white (the default preview)
//! shows only its bottom decades.
//!
//! - `clip`: min(v, 1) (what every preview did before).
//! - `reinhard`: Reinhard, Stark, Shirley and Ferwerda 2002, "Photographic tone reproduction for
//!   digital images", eq. 4: v (1 + v / w^2) / (1 + v), with w the smallest value mapped to white
//!   (the "burn-out" level), and the exposure set by the image's log-average (eq. 1-2: the key
//!   a = 0.18 at the log-average luminance).
//! - `filmic`: the ACES filmic curve as fitted by K. Narkowicz (2016, "ACES filmic tone mapping
//!   curve"): v (2.51 v + 0.03) / (v (2.43 v + 0.59) + 0.14), clipped to [0, 1]; the same
//!   exposure rule.

use crate::RgbImage;
use serde::{Deserialize, Serialize};

/// Which tone curve a preview uses.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, schemars::JsonSchema,
)]
#[serde(rename_all = "kebab-case")]
pub enum ToneMap {
    /// Clip at white (an 8-bit preview of a linear frame; the default for single frames).
    #[default]
    Clip,
    /// Reinhard et al. 2002 global operator with burn-out.
    Reinhard,
    /// The ACES filmic curve (Narkowicz 2016 fit).
    Filmic,
}

/// Reinhard's key: the log-average luminance maps to this display value (Reinhard et al. 2002,
/// eq. 2, "normal-key" scenes).
pub const KEY: f64 = 0.18;

/// A tone curve with its parameters fixed for one image.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ToneCurve {
    /// min(v, 1).
    Clip,
    /// v (1 + v / w^2) / (1 + v), white level w (> 0).
    Reinhard {
        /// The (scaled) value that maps to 1.
        white: f64,
    },
    /// The ACES fit.
    Filmic,
}

impl ToneCurve {
    /// Display value in [0, 1] of a linear value (negative and NaN -> 0).
    #[inline]
    pub fn apply(&self, v: f64) -> f64 {
        if !(v > 0.0) {
            return 0.0;
        }
        match *self {
            ToneCurve::Clip => v.min(1.0),
            ToneCurve::Reinhard { white } => (v * (1.0 + v / (white * white)) / (1.0 + v)).min(1.0),
            ToneCurve::Filmic => {
                (v * (2.51 * v + 0.03) / (v * (2.43 * v + 0.59) + 0.14)).clamp(0.0, 1.0)
            }
        }
    }
}

impl ToneMap {
    /// The name the configs take.
    pub fn name(self) -> &'static str {
        match self {
            ToneMap::Clip => "clip",
            ToneMap::Reinhard => "reinhard",
            ToneMap::Filmic => "filmic",
        }
    }

    /// The exposure scale and tone curve for an image whose luminance per pixel is
    /// `weights . (r, g, b)` (after the scale 1): `clip` keeps `clip_scale` (the caller's
    /// automatic or given exposure); `reinhard` and `filmic` put the log-average luminance at
    /// [`KEY`] (Reinhard et al. eq. 1, with delta = 1e-6 of the maximum against log(0)), and
    /// `reinhard`'s white is the largest scaled luminance (its 99.9th percentile, so that a few
    /// hot pixels do not set it), at least 1.
    pub fn fit(self, img: &RgbImage, weights: [f64; 3], clip_scale: f64) -> (f64, ToneCurve) {
        if self == ToneMap::Clip {
            return (clip_scale, ToneCurve::Clip);
        }
        let n = img.pixels();
        let stride = n.div_ceil(1 << 20).max(1);
        let mut ys: Vec<f64> = (0..n)
            .step_by(stride)
            .map(|i| {
                weights[0] * img.r[i] as f64
                    + weights[1] * img.g[i] as f64
                    + weights[2] * img.b[i] as f64
            })
            .filter(|y| y.is_finite())
            .map(|y| y.max(0.0))
            .collect();
        if ys.is_empty() {
            return (clip_scale, ToneCurve::Clip);
        }
        let max = ys.iter().cloned().fold(0.0, f64::max);
        if !(max > 0.0) {
            return (clip_scale, ToneCurve::Clip);
        }
        let delta = 1e-6 * max;
        let log_avg = (ys.iter().map(|y| (delta + y).ln()).sum::<f64>() / ys.len() as f64).exp();
        let scale = KEY / log_avg;
        let curve = match self {
            ToneMap::Reinhard => {
                let k = ((ys.len() - 1) as f64 * 0.999).round() as usize;
                let (_, p999, _) = ys.select_nth_unstable_by(k, |a, b| a.total_cmp(b));
                ToneCurve::Reinhard {
                    white: (*p999 * scale).max(1.0),
                }
            }
            _ => ToneCurve::Filmic,
        };
        (scale, curve)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reinhard_maps_its_white_to_one_and_small_values_linearly() {
        let c = ToneCurve::Reinhard { white: 50.0 };
        assert!((c.apply(50.0) - 1.0).abs() < 1e-12);
        assert!((c.apply(1e-4) / 1e-4 - 1.0).abs() < 2e-4);
        // Without burn-out (w -> infinity) eq. 3: v / (1 + v).
        let plain = ToneCurve::Reinhard { white: 1e12 };
        assert!((plain.apply(3.0) - 0.75).abs() < 1e-12);
        // Monotone over 20 stops.
        let mut last = 0.0;
        for k in 0..200 {
            let v = 2f64.powf(-10.0 + k as f64 * 0.1);
            let d = c.apply(v);
            assert!(d >= last, "{v}: {d} < {last}");
            last = d;
        }
        assert_eq!(c.apply(-1.0), 0.0);
        assert_eq!(c.apply(f64::NAN), 0.0);
    }

    #[test]
    fn the_filmic_fit_has_its_published_shape() {
        // f(0) = 0, f(1) = 2.54 / 3.16 = 0.8038, saturating at 2.51 / 2.43 > 1 (clipped).
        let f = ToneCurve::Filmic;
        assert_eq!(f.apply(0.0), 0.0);
        assert!((f.apply(1.0) - 2.54 / 3.16).abs() < 1e-12);
        assert_eq!(f.apply(1e6), 1.0);
        assert!(
            (f.apply(0.18) - 0.18 * (2.51 * 0.18 + 0.03) / (0.18 * (2.43 * 0.18 + 0.59) + 0.14))
                .abs()
                < 1e-12
        );
    }

    #[test]
    fn the_exposure_puts_the_log_average_at_the_key() {
        // A two-level image: log-average = sqrt(a b).
        let (a, b) = (0.01f32, 100.0f32);
        let mut img = RgbImage::zeros(2, 2);
        for (i, v) in [a, b, a, b].iter().enumerate() {
            img.r[i] = *v;
            img.g[i] = *v;
            img.b[i] = *v;
        }
        let w = [0.2126, 0.7152, 0.0722];
        let (scale, curve) = ToneMap::Reinhard.fit(&img, w, 1.0);
        let log_avg =
            ((1e-6 * 100.0f64 + 0.01).ln() / 2.0 + (1e-6 * 100.0f64 + 100.0).ln() / 2.0).exp();
        // (f32 pixel values: 1e-6 relative.)
        assert!((scale - KEY / log_avg).abs() < 1e-6 * scale);
        match curve {
            ToneCurve::Reinhard { white } => assert!((white - 100.0 * scale).abs() < 1e-6 * white),
            c => panic!("{c:?}"),
        }
        assert_eq!(ToneMap::Clip.fit(&img, w, 3.0), (3.0, ToneCurve::Clip));
    }
}
