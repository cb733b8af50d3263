//! Visual noise: the noise of a uniform patch as a viewer sees it, weighted by the eye's contrast
//! sensitivity at a viewing condition (ISO 15739:2013 / 2017 Annex B; the same framework as
//! IEEE Std 1858-2016, CPIQ, and D. Baxter, F. Cao, H. Eliasson, J. Phillips, "Development of the
//! I3A CPIQ spatial metrics", Proc. SPIE 8293, 2012).
//!
//! The method, step by step:
//! 1. The patch's CIE XYZ (white `white_xyz`) is adapted to equal-energy white E with the linear
//!    Bradford transform, so a neutral has X = Y = Z.
//! 2. XYZ(E) goes to the opponent space A C1 C2: `A = Y`, `C1 = X - Y`, `C2 = 0.4 (Y - Z)`
//!    (neutrals have C1 = C2 = 0).
//! 3. Each channel's fluctuation about its mean is filtered in the frequency domain (a 2D DFT of
//!    the patch) by its contrast sensitivity function at `nu` cycles per degree, `nu` = the
//!    frequency in cycles per pixel times the pixels per degree of the viewing condition; the mean
//!    passes unchanged, so L* u* v* are taken about the patch's own colour (Image Engineering's
//!    note on the ISO reference implementation says its DFT forces the DC term to zero; how it
//!    then restores the mean is camsim's reading).
//!    - luminance A: `CSF_A(nu) = 75 nu^0.8 exp(-0.2 nu) / 34.05` (peak 3.0 at 4 cycles/degree;
//!      [`crate::acutance::csf_cpiq`]);
//!    - C1 (red-green) and C2 (blue-yellow): `a1 exp(-b1 nu^c1) + a2 exp(-b2 nu^c2)`, the
//!      chromatic CSFs of G. M. Johnson and M. D. Fairchild ("On contrast sensitivity in an image
//!      difference model", PICS 2002, pp. 18-23), normalised to 1 at zero frequency.
//! 4. Back to XYZ(E), adapted back to the white, negative tristimulus values set to 0 (as the ISO
//!    reference implementation does), then CIE 1976 L* u* v* relative to the white.
//! 5. `VN = 1.0 sigma(L*) + 0.852 sigma(u*) + 0.323 sigma(v*)`, the standard deviations over the
//!    patch (ISO 15739:2013 Annex B's weights).
//!
//! What is camsim's own reading: the DFT is periodic over the patch, without padding or window
//! (the patch is uniform, its mean removed first); standard deviations are population ones (RMS
//! about the mean). Not checked against ISO's reference code, which is not public: the tests check
//! each step against its closed form. ISO 15739:2023 revised the metric (CIELAB, a normalised
//! luminance CSF and new weights, after D. Wueller, A. Matsui, N. Katoh, "Visual noise revision for
//! ISO 15739", EI 2019); this module computes the 2013/2017 form.

use crate::acutance::csf_cpiq;
use crate::color_difference::xyz_to_luv;
use crate::error::{AnalysisError, Result};
use crate::image::{Plane, Rect};
use camsim_core::colorimetry::{
    bradford_adaptation, mat3_inverse, mat3_mul_vec, srgb_decode, LINEAR_SRGB_TO_XYZ,
};
use rayon::prelude::*;
use rustfft::num_complex::Complex;
use rustfft::FftPlanner;
use serde::Serialize;

/// CIE XYZ (under E) -> opponent A, C1, C2 (ISO 15739 Annex B; CPIQ).
pub const XYZ_TO_AC1C2: [[f64; 3]; 3] = [[0.0, 1.0, 0.0], [1.0, -1.0, 0.0], [0.0, 0.4, -0.4]];

/// Weights of sigma(L*), sigma(u*), sigma(v*) in the visual noise (ISO 15739:2013 Annex B).
pub const VISUAL_NOISE_WEIGHTS_LUV: [f64; 3] = [1.0, 0.852, 0.323];

/// Johnson & Fairchild (2002) red-green CSF: (a1, b1, c1, a2, b2, c2) of
/// `a1 exp(-b1 nu^c1) + a2 exp(-b2 nu^c2)`, nu in cycles per degree.
pub const CSF_RED_GREEN: [f64; 6] = [109.14130, 0.00038, 3.42436, 93.59711, 0.00367, 2.16771];

/// Johnson & Fairchild (2002) blue-yellow CSF, same form as [`CSF_RED_GREEN`].
pub const CSF_BLUE_YELLOW: [f64; 6] = [7.032845, 0.000004, 4.258205, 40.690950, 0.103909, 1.648658];

/// A chromatic CSF of the form of [`CSF_RED_GREEN`] at `nu_cpd` cycles per degree, normalised
/// to 1 at zero frequency.
pub fn csf_chromatic(p: &[f64; 6], nu_cpd: f64) -> f64 {
    let nu = nu_cpd.max(0.0);
    let [a1, b1, c1, a2, b2, c2] = *p;
    (a1 * (-b1 * nu.powf(c1)).exp() + a2 * (-b2 * nu.powf(c2)).exp()) / (a1 + a2)
}

/// The CSF of opponent channel `channel` (0 = A, 1 = C1, 2 = C2) at `nu_cpd` cycles per degree.
pub fn csf_opponent(channel: usize, nu_cpd: f64) -> f64 {
    match channel {
        0 => csf_cpiq(nu_cpd),
        1 => csf_chromatic(&CSF_RED_GREEN, nu_cpd),
        _ => csf_chromatic(&CSF_BLUE_YELLOW, nu_cpd),
    }
}

/// The visual noise of one patch.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct VisualNoise {
    /// `1.0 sigma(L*) + 0.852 sigma(u*) + 0.323 sigma(v*)` of the CSF-filtered patch.
    pub visual_noise: f64,
    /// Standard deviation of L* after filtering.
    pub sigma_l_star: f64,
    /// Standard deviation of u* after filtering.
    pub sigma_u_star: f64,
    /// Standard deviation of v* after filtering.
    pub sigma_v_star: f64,
    /// The same three without the CSF filter (the pixel-level noise in L* u* v*).
    pub unfiltered_sigma_luv: [f64; 3],
    /// Mean L*, u*, v* of the patch.
    pub mean_luv: [f64; 3],
    /// Pixels per degree of visual angle the CSFs were evaluated at.
    pub pixels_per_degree: f64,
    /// The patch.
    pub rect: Rect,
    /// Pixels whose filtered tristimulus values went negative and were set to 0.
    pub clipped_pixels: usize,
}

/// Visual noise of the patch `rect` (default: the whole image) of an image given as CIE XYZ planes
/// relative to `white_xyz` (same units), viewed at `pixels_per_degree`
/// ([`crate::acutance::ViewingCondition::pixels_per_degree`]).
pub fn visual_noise(
    xyz: &[Plane; 3],
    rect: Option<Rect>,
    white_xyz: [f64; 3],
    pixels_per_degree: f64,
) -> Result<VisualNoise> {
    let what = "visual noise";
    let (rows, cols) = (xyz[0].rows, xyz[0].cols);
    for (ch, p) in xyz.iter().enumerate() {
        if p.rows != rows || p.cols != cols {
            return Err(AnalysisError::invalid(
                what,
                format!(
                    "plane {ch} is {} x {}, plane 0 {rows} x {cols}",
                    p.rows, p.cols
                ),
            ));
        }
    }
    if !(pixels_per_degree > 0.0 && pixels_per_degree.is_finite()) {
        return Err(AnalysisError::invalid(
            "pixels per degree",
            format!("{pixels_per_degree} must be a positive number"),
        ));
    }
    if !white_xyz.iter().all(|w| *w > 0.0 && w.is_finite()) {
        return Err(AnalysisError::invalid(
            "visual noise white",
            format!("{white_xyz:?} must be three positive tristimulus values"),
        ));
    }
    let rect = rect.unwrap_or_else(|| xyz[0].full_rect());
    if rect.rows < 2 || rect.cols < 2 {
        return Err(AnalysisError::invalid(
            "visual noise region",
            format!("{rect} must be at least 2 x 2 pixels"),
        ));
    }
    if rect.row_end() > rows || rect.col_end() > cols {
        return Err(AnalysisError::invalid(
            "visual noise region",
            format!("{rect} lies outside the {rows} x {cols} image"),
        ));
    }
    let (h, w) = (rect.rows, rect.cols);
    // Per pixel: the cropped f32 XYZ (12 bytes), three f64 opponent planes (24), one channel's
    // two complex DFT buffers at a time (32), the filtered and the unfiltered L*u*v* (48).
    camsim_core::mem::check_alloc(
        (h as u64)
            .saturating_mul(w as u64)
            .saturating_mul(12 + 24 + 32 + 48),
        &format!("the visual noise of a {h} x {w} patch"),
    )?;
    let patch: Vec<Plane> = xyz.iter().map(|p| p.crop(&rect)).collect::<Result<_>>()?;
    let n = h * w;
    if patch.iter().any(|p| p.data.iter().any(|v| !v.is_finite())) {
        return Err(AnalysisError::invalid(
            what,
            format!("the patch {rect} holds values that are not finite"),
        ));
    }
    let y_w = white_xyz[1];
    let to_e = bradford_adaptation(white_xyz, [y_w; 3]);
    let from_e = bradford_adaptation([y_w; 3], white_xyz);
    let opp_to_xyz = mat3_inverse(&XYZ_TO_AC1C2).expect("the A C1 C2 matrix is invertible");
    let pixel = |i: usize| [0, 1, 2].map(|c| patch[c].data[i] as f64);
    let mut opp: [Vec<f64>; 3] = [vec![0.0; n], vec![0.0; n], vec![0.0; n]];
    for i in 0..n {
        let o = mat3_mul_vec(&XYZ_TO_AC1C2, mat3_mul_vec(&to_e, pixel(i)));
        for c in 0..3 {
            opp[c][i] = o[c];
        }
    }
    for (c, plane) in opp.iter_mut().enumerate() {
        csf_filter(plane, h, w, |nu_cy_per_px| {
            csf_opponent(c, nu_cy_per_px * pixels_per_degree)
        });
    }
    let mut clipped = 0usize;
    let filtered_luv: Vec<[f64; 3]> = (0..n)
        .map(|i| {
            let o = [opp[0][i], opp[1][i], opp[2][i]];
            let x = mat3_mul_vec(&from_e, mat3_mul_vec(&opp_to_xyz, o));
            if x.iter().any(|v| *v < 0.0) {
                clipped += 1;
            }
            xyz_to_luv(x.map(|v| v.max(0.0)), white_xyz)
        })
        .collect();
    let raw_luv: Vec<[f64; 3]> = (0..n).map(|i| xyz_to_luv(pixel(i), white_xyz)).collect();
    let (mean, sigma) = mean_std(&filtered_luv);
    let (_, raw_sigma) = mean_std(&raw_luv);
    let vn = (0..3).map(|c| VISUAL_NOISE_WEIGHTS_LUV[c] * sigma[c]).sum();
    Ok(VisualNoise {
        visual_noise: vn,
        sigma_l_star: sigma[0],
        sigma_u_star: sigma[1],
        sigma_v_star: sigma[2],
        unfiltered_sigma_luv: raw_sigma,
        mean_luv: mean,
        pixels_per_degree,
        rect,
        clipped_pixels: clipped,
    })
}

/// Linear sRGB (white = 1) or sRGB code values (in [0, 1]) as CIE XYZ planes relative to the sRGB
/// white with Y = 100 (IEC 61966-2-1:1999: the transfer function of eq. 5.2-5.3, then the matrix
/// of section 5.3), and that white. A visual noise input for display images.
pub fn srgb_to_xyz(rgb: &[Plane; 3], code_values: bool) -> Result<([Plane; 3], [f64; 3])> {
    let (rows, cols) = (rgb[0].rows, rgb[0].cols);
    if rgb.iter().any(|p| p.rows != rows || p.cols != cols) {
        return Err(AnalysisError::invalid(
            "sRGB image",
            "the three planes must have the same size",
        ));
    }
    let lin = |v: f32| {
        if code_values {
            srgb_decode(v as f64)
        } else {
            v as f64
        }
    };
    let mut out = [
        Plane::zeros(rows, cols)?,
        Plane::zeros(rows, cols)?,
        Plane::zeros(rows, cols)?,
    ];
    for i in 0..rows * cols {
        let x = mat3_mul_vec(
            &LINEAR_SRGB_TO_XYZ,
            [
                lin(rgb[0].data[i]),
                lin(rgb[1].data[i]),
                lin(rgb[2].data[i]),
            ],
        );
        for c in 0..3 {
            out[c].data[i] = (100.0 * x[c]) as f32;
        }
    }
    let white = mat3_mul_vec(&LINEAR_SRGB_TO_XYZ, [100.0; 3]);
    Ok((out, white))
}

/// Mean and population standard deviation of each of three components.
fn mean_std(v: &[[f64; 3]]) -> ([f64; 3], [f64; 3]) {
    let n = v.len().max(1) as f64;
    let mean = [0, 1, 2].map(|c| v.iter().map(|p| p[c]).sum::<f64>() / n);
    let std =
        [0, 1, 2].map(|c| (v.iter().map(|p| (p[c] - mean[c]).powi(2)).sum::<f64>() / n).sqrt());
    (mean, std)
}

/// Signed DFT frequency of index `k` of `n` samples, cycles per sample.
fn dft_freq(k: usize, n: usize) -> f64 {
    if 2 * k <= n {
        k as f64 / n as f64
    } else {
        (k as f64 - n as f64) / n as f64
    }
}

/// Filter a row-major `h` x `w` plane in place: its mean kept, its fluctuation's 2D DFT multiplied
/// by `gain(radial frequency in cycles per pixel)`. At the Nyquist index of an even length the
/// single (real) term takes the gain of |f| = 1/2, so a real image stays real.
fn csf_filter(plane: &mut [f64], h: usize, w: usize, gain: impl Fn(f64) -> f64 + Sync) {
    let mean = plane.iter().sum::<f64>() / plane.len() as f64;
    let mut planner = FftPlanner::<f64>::new();
    let (fw, iw) = (planner.plan_fft_forward(w), planner.plan_fft_inverse(w));
    let (fh, ih) = (planner.plan_fft_forward(h), planner.plan_fft_inverse(h));
    let mut buf: Vec<Complex<f64>> = plane.iter().map(|v| Complex::new(v - mean, 0.0)).collect();
    // Rows, then columns through a transpose (column-major `t[c * h + r]`).
    buf.par_chunks_mut(w).for_each(|row| fw.process(row));
    let mut t = vec![Complex::new(0.0, 0.0); h * w];
    for r in 0..h {
        for c in 0..w {
            t[c * h + r] = buf[r * w + c];
        }
    }
    t.par_chunks_mut(h).enumerate().for_each(|(c, col)| {
        fh.process(col);
        let fx = dft_freq(c, w);
        for (r, v) in col.iter_mut().enumerate() {
            let fy = dft_freq(r, h);
            *v *= gain((fx * fx + fy * fy).sqrt());
        }
        ih.process(col);
    });
    for r in 0..h {
        for c in 0..w {
            buf[r * w + c] = t[c * h + r];
        }
    }
    buf.par_chunks_mut(w).for_each(|row| iw.process(row));
    let norm = 1.0 / (h * w) as f64;
    for (p, v) in plane.iter_mut().zip(&buf) {
        *p = mean + v.re * norm;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use camsim_core::colorimetry::srgb_encode;

    const D65_100: [f64; 3] = [95.05, 100.0, 108.9];

    /// XYZ planes of `f(row, col)` times the white (a neutral of that luminance factor).
    fn neutral(rows: usize, cols: usize, f: impl Fn(usize, usize) -> f64) -> [Plane; 3] {
        [0, 1, 2].map(|c| Plane::from_fn(rows, cols, |r, k| (D65_100[c] * f(r, k)) as f32).unwrap())
    }

    #[test]
    fn csfs_have_their_published_shapes() {
        // The CPIQ luminance CSF peaks at nu = c / b = 4 cycles/degree with 3.0.
        assert!((csf_opponent(0, 4.0) - 3.0003).abs() < 1e-3);
        assert!(csf_opponent(0, 3.9) < csf_opponent(0, 4.0));
        assert!(csf_opponent(0, 4.1) < csf_opponent(0, 4.0));
        assert_eq!(csf_opponent(0, 0.0), 0.0);
        // The chromatic CSFs are low-pass, 1 at zero frequency, below 1 % by 25 cycles/degree.
        for c in [1, 2] {
            assert!((csf_opponent(c, 0.0) - 1.0).abs() < 1e-15);
            assert!(csf_opponent(c, 1.0) < 1.0 && csf_opponent(c, 5.0) < csf_opponent(c, 1.0));
            assert!(
                csf_opponent(c, 25.0) < 0.01,
                "{c}: {}",
                csf_opponent(c, 25.0)
            );
        }
    }

    #[test]
    fn a_uniform_patch_has_no_visual_noise() {
        let img = neutral(24, 30, |_, _| 0.18);
        let r = visual_noise(&img, None, D65_100, 30.0).unwrap();
        assert!(r.visual_noise < 1e-9, "{r:?}");
        assert!(
            (r.mean_luv[0] - 49.496).abs() < 0.01,
            "L* of 18 %: {:?}",
            r.mean_luv
        );
        assert!(r.mean_luv[1].abs() < 1e-3 && r.mean_luv[2].abs() < 1e-3);
    }

    /// A neutral luminance grating of `k` cycles across the patch: its A channel is filtered by
    /// exactly CSF_A at that frequency and it stays neutral, so sigma(L*) is that of the grating
    /// of amplitude `CSF_A a`, computed here pixel by pixel with the CIE L* formula, and
    /// sigma(u*) = sigma(v*) = 0.
    #[test]
    fn a_neutral_grating_is_weighted_by_the_luminance_csf() {
        let (rows, cols, k) = (16, 64, 8.0);
        let (y0, a) = (0.2, 0.01);
        let grating =
            |col: usize| (2.0 * std::f64::consts::PI * k * col as f64 / cols as f64).sin();
        let img = neutral(rows, cols, |_, c| y0 + a * grating(c));
        for ppd in [16.0, 32.0, 96.0] {
            let r = visual_noise(&img, None, D65_100, ppd).unwrap();
            let g = csf_cpiq(k / cols as f64 * ppd);
            let l: Vec<f64> = (0..cols)
                .map(|c| {
                    let y = y0 + g * a * grating(c);
                    116.0 * y.cbrt() - 16.0
                })
                .collect();
            let m = l.iter().sum::<f64>() / cols as f64;
            let want = (l.iter().map(|v| (v - m).powi(2)).sum::<f64>() / cols as f64).sqrt();
            assert!(
                (r.sigma_l_star - want).abs() < 2e-3 * want,
                "ppd {ppd}: {} vs {want}",
                r.sigma_l_star
            );
            assert!(r.sigma_u_star < 1e-3 && r.sigma_v_star < 1e-3, "{r:?}");
            assert!((r.visual_noise - r.sigma_l_star).abs() < 1e-3);
        }
        // At 32 pixels per degree the grating is at the CSF's peak (4 cycles/degree): the
        // filtered sigma is 3.0 times the unfiltered one.
        let r = visual_noise(&img, None, D65_100, 32.0).unwrap();
        let ratio = r.sigma_l_star / r.unfiltered_sigma_luv[0];
        assert!((ratio - 3.0).abs() < 0.01, "{ratio}");
    }

    /// A red-green grating (along C1 under E, A = C2 = 0) of `k` cycles: C1 is multiplied by
    /// CSF_C1, so the filtered image equals the grating of amplitude `CSF_C1 a` built directly.
    #[test]
    fn a_chromatic_grating_is_weighted_by_its_chromatic_csf() {
        let (rows, cols, k) = (8, 80, 5.0);
        let y_w = D65_100[1];
        let from_e = bradford_adaptation([y_w; 3], D65_100);
        let to_xyz = mat3_inverse(&XYZ_TO_AC1C2).unwrap();
        let build = |amp: f64| {
            let px = |col: usize| {
                let s = (2.0 * std::f64::consts::PI * k * col as f64 / cols as f64).sin();
                mat3_mul_vec(&from_e, mat3_mul_vec(&to_xyz, [30.0, amp * s, 0.0]))
            };
            [0, 1, 2].map(|c| Plane::from_fn(rows, cols, |_, col| px(col)[c] as f32).unwrap())
        };
        let a = 4.0;
        let ppd = 200.0;
        let r = visual_noise(&build(a), None, D65_100, ppd).unwrap();
        let g = csf_chromatic(&CSF_RED_GREEN, k / cols as f64 * ppd);
        assert!(g > 0.05 && g < 0.95, "{g}");
        let want = visual_noise(&build(g * a), None, D65_100, 1e-9).unwrap();
        // At (nearly) zero pixels per degree every CSF is its value at 0: 1 for the chromatic
        // channels, so `want` holds the unfiltered L* u* v* of the directly built grating.
        // (L* varies a little too: Bradford's adaptation back to D65 does not keep Y.)
        for (got, exp) in [
            (r.sigma_l_star, want.unfiltered_sigma_luv[0]),
            (r.sigma_u_star, want.unfiltered_sigma_luv[1]),
            (r.sigma_v_star, want.unfiltered_sigma_luv[2]),
        ] {
            assert!((got - exp).abs() < 1e-3 * exp.max(1e-3), "{got} vs {exp}");
        }
        assert!(
            r.sigma_u_star > 0.1 && r.sigma_l_star < 0.01 * r.sigma_u_star,
            "{r:?}"
        );
        let vn = r.sigma_l_star + 0.852 * r.sigma_u_star + 0.323 * r.sigma_v_star;
        assert!((r.visual_noise - vn).abs() < 1e-12);
    }

    #[test]
    fn white_noise_looks_less_noisy_from_further_away() {
        // Deterministic pseudo-random luminance noise on mid grey.
        let mut s = 0x9e3779b97f4a7c15u64;
        let mut next = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let noise: Vec<f64> = (0..64 * 64).map(|_| next()).collect();
        let img = neutral(64, 64, |r, c| 0.2 + 0.02 * noise[r * 64 + c]);
        let vn: Vec<f64> = [10.0, 40.0, 160.0]
            .iter()
            .map(|&ppd| visual_noise(&img, None, D65_100, ppd).unwrap().visual_noise)
            .collect();
        assert!(vn[0] > vn[1] && vn[1] > vn[2], "{vn:?}");
    }

    #[test]
    fn srgb_white_and_grey_map_to_their_xyz() {
        let code = srgb_encode(0.18) as f32;
        let rgb = [0, 1, 2].map(|_| Plane::new(1, 2, vec![1.0, code]).unwrap());
        let (xyz, white) = srgb_to_xyz(&rgb, true).unwrap();
        assert!((white[1] - 100.0).abs() < 1e-9 && (white[0] - 95.05).abs() < 1e-9);
        assert!((xyz[1].data[0] - 100.0).abs() < 1e-4);
        assert!((xyz[1].data[1] - 18.0).abs() < 1e-3, "{}", xyz[1].data[1]);
    }

    #[test]
    fn bad_input_is_refused() {
        let img = neutral(8, 8, |_, _| 0.2);
        assert!(visual_noise(&img, None, D65_100, 0.0).is_err());
        assert!(visual_noise(&img, None, D65_100, f64::NAN).is_err());
        assert!(visual_noise(&img, Some(Rect::new(4, 4, 8, 8)), D65_100, 30.0).is_err());
        assert!(visual_noise(&img, Some(Rect::new(0, 0, 1, 8)), D65_100, 30.0).is_err());
        assert!(visual_noise(&img, None, [0.0, 100.0, 100.0], 30.0).is_err());
        let mut bad = img.clone();
        bad[1].data[5] = f32::NAN;
        assert!(visual_noise(&bad, None, D65_100, 30.0).is_err());
    }
}
