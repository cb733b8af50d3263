//! S-CIELAB, the spatial extension of CIELAB (X. Zhang and B. A. Wandell, "A spatial extension of
//! CIELAB for digital color-image reproduction", J. Soc. Inf. Display 5(1), 61-63, 1997; ISETCam
//! `scielab`).
//!
//! Both images (CIE XYZ planes) are taken to the opponent colour space of Poirson and Wandell
//! (1993) (one luminance and two chromatic channels), each channel is blurred by the eye's
//! pattern-colour separable point spread (a weighted sum of two or three Gaussians whose widths
//! are angles, so the filters depend on the viewing condition's samples per degree), taken back to
//! XYZ, then to CIELAB relative to the white, and the colour difference is computed pixel by pixel
//! (CIE 1976 ΔE*ab, the original metric, or CIEDE2000).
//!
//! The filter data are those of Zhang's `separableFilters.m` (the weights normalised to sum to 1
//! per channel); the widths are full widths at half maximum in degrees of visual angle, and every
//! filter is limited to one degree of support, as there.

use crate::color_difference::{cie94, ciede2000, delta_e_uv, xyz_to_lab};
use crate::error::{AnalysisError, Result};
use crate::image::Plane;
use rayon::prelude::*;
use serde::Serialize;

/// CIE XYZ -> opponent (O1 luminance, O2 red-green, O3 blue-yellow), Poirson & Wandell 1993 as
/// used by S-CIELAB (`cmatrix('xyz2opp')` of Zhang's S-CIELAB code).
pub const XYZ_TO_OPPONENT: [[f64; 3]; 3] = [
    [0.2787336, 0.7218031, -0.1065520],
    [-0.4487736, 0.2898056, 0.0771569],
    [0.0859513, -0.5899859, 0.5011089],
];

/// The Gaussians of each opponent channel as (full width at half maximum, degrees; weight):
/// Zhang's `separableFilters.m` (Zhang & Wandell 1997), weights normalised to sum to 1.
pub const CHANNEL_GAUSSIANS_DEG: [&[(f64, f64)]; 3] = [
    &[(0.05, 1.00327), (0.225, 0.114416), (7.0, -0.117686)],
    &[(0.0685, 0.616725), (0.826, 0.383275)],
    &[(0.0920, 0.567885), (0.6451, 0.432115)],
];

/// Which colour difference S-CIELAB reports per pixel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum DeltaEFormula {
    /// CIE 1976 ΔE*ab (Euclidean distance in CIELAB), the original S-CIELAB metric.
    #[default]
    Cie76,
    /// CIEDE2000 (CIE 142-2001).
    Ciede2000,
    /// CIE 1994 ΔE*94, graphic-arts weights (CIE 116-1995), the first image the reference.
    Cie94,
    /// CIE 1976 ΔE*uv (Euclidean distance in CIELUV).
    Cieuv,
}

impl DeltaEFormula {
    /// The difference between two tristimulus values under `white_xyz`.
    pub fn between(self, a_xyz: [f64; 3], b_xyz: [f64; 3], white_xyz: [f64; 3]) -> f64 {
        if self == DeltaEFormula::Cieuv {
            return delta_e_uv(a_xyz, b_xyz, white_xyz);
        }
        let (la, lb) = (xyz_to_lab(a_xyz, white_xyz), xyz_to_lab(b_xyz, white_xyz));
        match self {
            DeltaEFormula::Cie76 => {
                ((la.l - lb.l).powi(2) + (la.a - lb.a).powi(2) + (la.b - lb.b).powi(2)).sqrt()
            }
            DeltaEFormula::Ciede2000 => ciede2000(la, lb),
            DeltaEFormula::Cie94 => cie94(la, lb),
            DeltaEFormula::Cieuv => unreachable!("handled above"),
        }
    }
}

impl std::str::FromStr for DeltaEFormula {
    type Err = AnalysisError;
    fn from_str(s: &str) -> Result<Self> {
        match s.trim().to_ascii_lowercase().as_str() {
            "cie76" | "76" | "deltaeab" => Ok(DeltaEFormula::Cie76),
            "ciede2000" | "2000" | "de2000" => Ok(DeltaEFormula::Ciede2000),
            "cie94" | "94" | "de94" => Ok(DeltaEFormula::Cie94),
            "cieuv" | "uv" | "deuv" => Ok(DeltaEFormula::Cieuv),
            _ => Err(AnalysisError::invalid(
                "colour difference formula",
                format!("'{s}' is not one of cie76, ciede2000, cie94, cieuv"),
            )),
        }
    }
}

/// One Gaussian of a channel's point spread, sampled in 1D (unit sum) with its weight: the 2D
/// point spread is `sum_i weight_i g_i(x) g_i(y)`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GaussianTerm {
    /// Weight of this Gaussian in the channel's filter.
    pub weight: f64,
    /// 1D kernel, odd length, centred, summing to 1.
    pub kernel: Vec<f64>,
}

/// The three opponent channels' filters at a sampling rate.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ScielabFilters {
    /// Image samples per degree of visual angle.
    pub samples_per_deg: f64,
    /// Luminance, red-green and blue-yellow filters.
    pub channels: [Vec<GaussianTerm>; 3],
}

impl ScielabFilters {
    /// The filters at `samples_per_deg` samples per degree. Each Gaussian is
    /// `exp(-4 ln 2 x^2 / w^2)` with `w` its full width at half maximum in samples, sampled on the
    /// filter's support of one degree (an odd number of taps, `2 ceil(spd / 2) - 1`, as Zhang's
    /// code) and normalised to unit sum there.
    pub fn new(samples_per_deg: f64) -> Result<ScielabFilters> {
        if !(1.0..=10_000.0).contains(&samples_per_deg) {
            return Err(AnalysisError::invalid(
                "samples_per_deg",
                format!("{samples_per_deg} must be in [1, 10000] samples per degree"),
            ));
        }
        let taps = ((samples_per_deg / 2.0).ceil() as usize * 2)
            .saturating_sub(1)
            .max(1);
        let half = (taps / 2) as f64;
        let channels = CHANNEL_GAUSSIANS_DEG.map(|terms| {
            terms
                .iter()
                .map(|&(fwhm_deg, weight)| {
                    let w = fwhm_deg * samples_per_deg;
                    let mut k: Vec<f64> = (0..taps)
                        .map(|i| {
                            let x = i as f64 - half;
                            // A width below one sample is a delta at this sampling.
                            if w > 1e-9 {
                                (-4.0 * std::f64::consts::LN_2 * x * x / (w * w)).exp()
                            } else if x == 0.0 {
                                1.0
                            } else {
                                0.0
                            }
                        })
                        .collect();
                    let s: f64 = k.iter().sum();
                    k.iter_mut().for_each(|v| *v /= s);
                    GaussianTerm { weight, kernel: k }
                })
                .collect()
        });
        Ok(ScielabFilters {
            samples_per_deg,
            channels,
        })
    }

    /// Sum of a channel's 2D point spread (`sum_i w_i (sum g_i)^2`): 1 for every channel, so a
    /// uniform image passes unchanged.
    pub fn dc_gain(&self, channel: usize) -> f64 {
        self.channels[channel]
            .iter()
            .map(|t| t.weight * t.kernel.iter().sum::<f64>().powi(2))
            .sum()
    }

    /// The channel's 2D point spread as a `taps x taps` plane (for plots and tests).
    pub fn point_spread(&self, channel: usize) -> Vec<Vec<f64>> {
        let n = self.channels[channel][0].kernel.len();
        let mut psf = vec![vec![0.0; n]; n];
        for t in &self.channels[channel] {
            for (r, row) in psf.iter_mut().enumerate() {
                for (c, v) in row.iter_mut().enumerate() {
                    *v += t.weight * t.kernel[r] * t.kernel[c];
                }
            }
        }
        psf
    }
}

/// The S-CIELAB difference of two images.
#[derive(Debug, Clone, Serialize)]
pub struct ScielabResult {
    /// Colour difference per pixel.
    #[serde(skip)]
    pub delta_e: Plane,
    /// Mean over the pixels.
    pub mean: f64,
    /// 95th percentile.
    pub p95: f64,
    /// Largest value.
    pub max: f64,
    /// Formula used.
    pub formula: DeltaEFormula,
    /// Samples per degree of the viewing condition.
    pub samples_per_deg: f64,
}

/// Mirror index (edge sample repeated: ..., 1, 0 | 0, 1, ...) so a uniform image stays uniform.
#[inline]
fn mirror(i: isize, n: usize) -> usize {
    let n = n as isize;
    let period = 2 * n;
    let m = i.rem_euclid(period);
    (if m < n { m } else { period - 1 - m }) as usize
}

/// Convolve a row-major plane (f64) with `k` along rows then along columns (mirror boundaries).
fn separable(data: &[f64], rows: usize, cols: usize, k: &[f64]) -> Vec<f64> {
    let h = (k.len() / 2) as isize;
    let mut tmp = vec![0.0; data.len()];
    tmp.par_chunks_mut(cols).enumerate().for_each(|(r, out)| {
        let row = &data[r * cols..(r + 1) * cols];
        for (c, o) in out.iter_mut().enumerate() {
            *o = k
                .iter()
                .enumerate()
                .map(|(j, w)| w * row[mirror(c as isize + j as isize - h, cols)])
                .sum();
        }
    });
    let mut out = vec![0.0; data.len()];
    out.par_chunks_mut(cols).enumerate().for_each(|(r, o)| {
        for (j, w) in k.iter().enumerate() {
            let src = &tmp[mirror(r as isize + j as isize - h, rows) * cols..][..cols];
            for (v, s) in o.iter_mut().zip(src) {
                *v += w * s;
            }
        }
    });
    out
}

/// Filter the three XYZ planes as S-CIELAB does and return the filtered XYZ (f64, row-major).
fn filtered_xyz(xyz: &[Plane; 3], filters: &ScielabFilters) -> [Vec<f64>; 3] {
    let (rows, cols) = (xyz[0].rows, xyz[0].cols);
    let n = rows * cols;
    let m = XYZ_TO_OPPONENT;
    let opp: [Vec<f64>; 3] = [0, 1, 2].map(|o| {
        (0..n)
            .map(|i| {
                m[o][0] * xyz[0].data[i] as f64
                    + m[o][1] * xyz[1].data[i] as f64
                    + m[o][2] * xyz[2].data[i] as f64
            })
            .collect()
    });
    let blurred: Vec<Vec<f64>> = (0..3)
        .map(|ch| {
            let mut acc = vec![0.0; n];
            for t in &filters.channels[ch] {
                let b = separable(&opp[ch], rows, cols, &t.kernel);
                acc.iter_mut().zip(&b).for_each(|(a, v)| *a += t.weight * v);
            }
            acc
        })
        .collect();
    // XYZ_TO_OPPONENT is a fixed, well-conditioned matrix (det = 0.118).
    let inv =
        camsim_core::colorimetry::mat3_inverse(&m).expect("the opponent matrix is invertible");
    [0, 1, 2].map(|x| {
        (0..n)
            .map(|i| {
                inv[x][0] * blurred[0][i] + inv[x][1] * blurred[1][i] + inv[x][2] * blurred[2][i]
            })
            .collect()
    })
}

/// S-CIELAB difference between two images given as CIE XYZ planes (same size, same units as
/// `white_xyz`, the reference white of CIELAB), viewed at `samples_per_deg` image samples per
/// degree of visual angle ([`crate::acutance::ViewingCondition::pixels_per_degree`]).
pub fn scielab(
    a_xyz: &[Plane; 3],
    b_xyz: &[Plane; 3],
    white_xyz: [f64; 3],
    samples_per_deg: f64,
    formula: DeltaEFormula,
) -> Result<ScielabResult> {
    let (rows, cols) = (a_xyz[0].rows, a_xyz[0].cols);
    if rows == 0 || cols == 0 {
        return Err(AnalysisError::invalid(
            "scielab",
            "the images have no pixels",
        ));
    }
    for (name, img) in [("first image", a_xyz), ("second image", b_xyz)] {
        for (ch, p) in img.iter().enumerate() {
            if p.rows != rows || p.cols != cols || p.data.len() != rows * cols {
                return Err(AnalysisError::invalid(
                    "scielab",
                    format!(
                        "{name} plane {ch} is {} x {}, the first X plane {rows} x {cols}",
                        p.rows, p.cols
                    ),
                ));
            }
            if p.data.iter().any(|v| !v.is_finite()) {
                return Err(AnalysisError::invalid(
                    "scielab",
                    format!("{name} plane {ch} holds values that are not finite"),
                ));
            }
        }
    }
    if !white_xyz.iter().all(|w| *w > 0.0 && w.is_finite()) {
        return Err(AnalysisError::invalid(
            "scielab white",
            format!("{white_xyz:?} must be three positive tristimulus values"),
        ));
    }
    let filters = ScielabFilters::new(samples_per_deg)?;
    let fa = filtered_xyz(a_xyz, &filters);
    let fb = filtered_xyz(b_xyz, &filters);
    let de: Vec<f32> = (0..rows * cols)
        .into_par_iter()
        .map(|i| {
            formula.between(
                [fa[0][i], fa[1][i], fa[2][i]],
                [fb[0][i], fb[1][i], fb[2][i]],
                white_xyz,
            ) as f32
        })
        .collect();
    let mut sorted: Vec<f32> = de.clone();
    sorted.sort_by(|x, y| x.total_cmp(y));
    let mean = de.iter().map(|v| *v as f64).sum::<f64>() / de.len() as f64;
    let p95 = sorted[((sorted.len() - 1) as f64 * 0.95).round() as usize] as f64;
    let max = *sorted.last().unwrap_or(&0.0) as f64;
    Ok(ScielabResult {
        delta_e: Plane::new(rows, cols, de)?,
        mean,
        p95,
        max,
        formula,
        samples_per_deg,
    })
}

/// Pixelwise colour difference without any spatial filtering (what S-CIELAB reduces to for
/// uniform fields), for comparison.
pub fn pixelwise_delta_e(
    a_xyz: &[Plane; 3],
    b_xyz: &[Plane; 3],
    white_xyz: [f64; 3],
    formula: DeltaEFormula,
) -> Result<Plane> {
    let (rows, cols) = (a_xyz[0].rows, a_xyz[0].cols);
    if a_xyz
        .iter()
        .chain(b_xyz.iter())
        .any(|p| p.rows != rows || p.cols != cols || p.data.len() != rows * cols)
    {
        return Err(AnalysisError::invalid(
            "pixelwise colour difference",
            "the six planes must have the same size",
        ));
    }
    let de = (0..rows * cols)
        .map(|i| {
            formula.between(
                [0, 1, 2].map(|c| a_xyz[c].data[i] as f64),
                [0, 1, 2].map(|c| b_xyz[c].data[i] as f64),
                white_xyz,
            ) as f32
        })
        .collect();
    Plane::new(rows, cols, de)
}

#[cfg(test)]
mod tests {
    use super::*;

    const D65: [f64; 3] = [95.047, 100.0, 108.883];

    fn uniform(rows: usize, cols: usize, xyz: [f64; 3]) -> [Plane; 3] {
        xyz.map(|v| Plane::new(rows, cols, vec![v as f32; rows * cols]).unwrap())
    }

    #[test]
    fn filters_have_unit_dc_gain_and_one_degree_support() {
        for spd in [1.0, 7.3, 23.0, 64.0, 101.0] {
            let f = ScielabFilters::new(spd).unwrap();
            for ch in 0..3 {
                let psf = f.point_spread(ch);
                let sum: f64 = psf.iter().flatten().sum();
                assert!(
                    (sum - 1.0).abs() < 1e-12 && (f.dc_gain(ch) - 1.0).abs() < 1e-12,
                    "spd {spd} ch {ch}: {sum}"
                );
                assert_eq!(psf.len() % 2, 1);
                assert!(
                    psf.len() as f64 <= spd.max(1.0) + 1.0,
                    "spd {spd}: {} taps",
                    psf.len()
                );
            }
        }
        // The published weights themselves sum to 1 per channel (Zhang's normalised table).
        for terms in CHANNEL_GAUSSIANS_DEG {
            assert!((terms.iter().map(|t| t.1).sum::<f64>() - 1.0).abs() < 1e-5);
        }
    }

    #[test]
    fn identical_images_give_zero() {
        let img = [0, 1, 2].map(|c| {
            Plane::from_fn(40, 50, |r, k| {
                (20.0 + 30.0 * ((r * 7 + k * 3 + c) % 11) as f64 / 11.0) as f32
            })
            .unwrap()
        });
        let r = scielab(&img, &img, D65, 40.0, DeltaEFormula::Ciede2000).unwrap();
        assert_eq!(r.max, 0.0);
    }

    #[test]
    fn a_uniform_shift_gives_the_cielab_difference() {
        let (a, b) = ([30.0, 25.0, 12.0], [26.0, 27.0, 20.0]);
        let expect76 = {
            let (la, lb) = (xyz_to_lab(a, D65), xyz_to_lab(b, D65));
            ((la.l - lb.l).powi(2) + (la.a - lb.a).powi(2) + (la.b - lb.b).powi(2)).sqrt()
        };
        let expect00 = ciede2000(xyz_to_lab(a, D65), xyz_to_lab(b, D65));
        for (formula, expect) in [
            (DeltaEFormula::Cie76, expect76),
            (DeltaEFormula::Ciede2000, expect00),
        ] {
            let r = scielab(&uniform(24, 30, a), &uniform(24, 30, b), D65, 30.0, formula).unwrap();
            // f32 inputs and outputs: agreement to single precision.
            assert!(
                (r.mean - expect).abs() < 1e-4 * expect && (r.max - expect).abs() < 1e-4 * expect,
                "{formula:?}: {} vs {expect}",
                r.mean
            );
        }
    }

    #[test]
    fn fine_chromatic_pattern_is_invisible_to_s_cielab() {
        // A red-green column grating of period 2 samples at 60 samples/degree = 30 cycles/degree,
        // far above the chromatic channels' cut-off (a few cycles/degree), against its uniform mean.
        let (rows, cols) = (48, 64);
        let (p, q) = ([40.0, 30.0, 20.0], [25.0, 32.0, 24.0]);
        let img = [0, 1, 2].map(|c| {
            Plane::from_fn(
                rows,
                cols,
                |_, k| if k % 2 == 0 { p[c] } else { q[c] } as f32,
            )
            .unwrap()
        });
        let mean = uniform(rows, cols, [0, 1, 2].map(|c| 0.5 * (p[c] + q[c])));
        let s = scielab(&img, &mean, D65, 60.0, DeltaEFormula::Cie76).unwrap();
        let px = pixelwise_delta_e(&img, &mean, D65, DeltaEFormula::Cie76).unwrap();
        let px_mean = px.data.iter().map(|v| *v as f64).sum::<f64>() / px.data.len() as f64;
        eprintln!(
            "30 cy/deg grating: S-CIELAB mean {:.3}, pixelwise mean {px_mean:.3}",
            s.mean
        );
        assert!(
            s.mean < 0.1 * px_mean,
            "S-CIELAB {} vs pixelwise {px_mean}",
            s.mean
        );
        // A coarse grating (period 32 samples = 1.9 cycles/degree) stays visible: S-CIELAB keeps
        // a large part of the pixelwise difference.
        let coarse = [0, 1, 2].map(|c| {
            Plane::from_fn(
                rows,
                cols,
                |_, k| if (k / 16) % 2 == 0 { p[c] } else { q[c] } as f32,
            )
            .unwrap()
        });
        let s2 = scielab(&coarse, &mean, D65, 60.0, DeltaEFormula::Cie76).unwrap();
        assert!(
            s2.mean > 0.5 * px_mean,
            "coarse: S-CIELAB {} vs pixelwise {px_mean}",
            s2.mean
        );
    }

    #[test]
    fn bad_input_is_an_error() {
        let a = uniform(8, 8, [1.0, 1.0, 1.0]);
        let b = uniform(8, 9, [1.0, 1.0, 1.0]);
        assert!(scielab(&a, &b, D65, 20.0, DeltaEFormula::Cie76).is_err());
        assert!(scielab(&a, &a, D65, f64::NAN, DeltaEFormula::Cie76).is_err());
        assert!(scielab(&a, &a, [0.0, 1.0, 1.0], 20.0, DeltaEFormula::Cie76).is_err());
        assert!("x".parse::<DeltaEFormula>().is_err());
    }
}
