//! Acutance: the SFR weighted by the eye's contrast sensitivity at a viewing condition, a single
//! number for perceived sharpness (IEEE Std 1858-2016, Camera Phone Image Quality (CPIQ),
//! "visual acutance"; the same construction as ISO 15739's visual noise weighting).
//!
//! `A = int_0^nu_max SFR(nu) CSF(nu) dnu / int_0^nu_max CSF(nu) dnu`, nu in cycles per degree of
//! visual angle, nu_max the image's Nyquist frequency (0.5 cycles/pixel) at the viewing condition,
//! with the CPIQ luminance CSF `CSF(nu) = a nu^c exp(-b nu) / K`, a = 75, b = 0.2, c = 0.8,
//! K = 34.05 (the peak is 3.0, at 4 cycles/degree; K cancels in A).
//! A perfect SFR (1 at every frequency) has acutance 1.

use crate::error::{AnalysisError, Result};
use serde::{Deserialize, Serialize};

/// CPIQ CSF constants (IEEE 1858-2016): a, b (degrees), c, K.
pub const CPIQ_CSF: [f64; 4] = [75.0, 0.2, 0.8, 34.05];

/// The CPIQ contrast sensitivity at `nu_cpd` cycles per degree.
pub fn csf_cpiq(nu_cpd: f64) -> f64 {
    let [a, b, c, k] = CPIQ_CSF;
    if nu_cpd <= 0.0 {
        0.0
    } else {
        a * nu_cpd.powf(c) * (-b * nu_cpd).exp() / k
    }
}

/// How an image is viewed: its height on the display or print, the distance to the eye, and how
/// many pixels span that height.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ViewingCondition {
    /// Image height in pixels (the full picture).
    pub image_height_px: usize,
    /// Height of the picture as shown, m.
    pub display_height_m: f64,
    /// Viewing distance, m.
    pub viewing_distance_m: f64,
}

impl ViewingCondition {
    /// Pixels per degree of visual angle at the centre of view: the picture has
    /// `image_height_px / display_height_m` pixels per metre and one degree spans
    /// `2 d tan(0.5 deg)` metres at distance d.
    pub fn pixels_per_degree(&self) -> Result<f64> {
        if self.image_height_px == 0
            || !(self.display_height_m > 0.0 && self.display_height_m.is_finite())
        {
            return Err(AnalysisError::invalid(
                "viewing condition",
                format!(
                    "{} pixels over {} m: need a positive pixel count and height",
                    self.image_height_px, self.display_height_m
                ),
            ));
        }
        if !(self.viewing_distance_m > 0.0 && self.viewing_distance_m.is_finite()) {
            return Err(AnalysisError::invalid(
                "viewing condition",
                format!("distance {} m must be positive", self.viewing_distance_m),
            ));
        }
        let px_per_m = self.image_height_px as f64 / self.display_height_m;
        Ok(px_per_m * 2.0 * self.viewing_distance_m * 0.5f64.to_radians().tan())
    }
}

/// The acutance of an SFR at a viewing condition.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Acutance {
    /// The acutance, dimensionless (1 for a perfect system).
    pub acutance: f64,
    /// Pixels per degree of the viewing condition.
    pub pixels_per_degree: f64,
    /// Upper end of the integrals, cycles/degree (the Nyquist frequency, or the last measured
    /// SFR frequency if lower).
    pub upper_cpd: f64,
}

/// Acutance of an SFR given at `freq_cy_per_px` (increasing, from 0 or near it) with values
/// `sfr`, viewed at `pixels_per_degree` ([`ViewingCondition::pixels_per_degree`]). The SFR is
/// interpolated linearly; the integrals use the trapezoid rule on 4096 intervals in
/// `t = sqrt(nu)` (nu = t^2 takes out the nu^0.8 cusp of the CSF at 0).
pub fn acutance(freq_cy_per_px: &[f64], sfr: &[f64], pixels_per_degree: f64) -> Result<Acutance> {
    if freq_cy_per_px.len() != sfr.len() || freq_cy_per_px.len() < 2 {
        return Err(AnalysisError::invalid(
            "acutance",
            format!(
                "{} frequencies and {} SFR values: need the same number, at least 2",
                freq_cy_per_px.len(),
                sfr.len()
            ),
        ));
    }
    if freq_cy_per_px.iter().chain(sfr).any(|v| !v.is_finite())
        || freq_cy_per_px.windows(2).any(|w| !(w[1] > w[0]))
    {
        return Err(AnalysisError::invalid(
            "acutance",
            "the frequencies must increase and every value must be finite",
        ));
    }
    if !(pixels_per_degree > 0.0 && pixels_per_degree.is_finite()) {
        return Err(AnalysisError::invalid(
            "acutance",
            format!("{pixels_per_degree} pixels per degree must be positive"),
        ));
    }
    let f_last = *freq_cy_per_px.last().unwrap_or(&0.5);
    let upper_cy_per_px = f_last.min(0.5);
    if !(upper_cy_per_px > 0.0) {
        return Err(AnalysisError::invalid(
            "acutance",
            "the SFR has no positive frequency",
        ));
    }
    let upper_cpd = upper_cy_per_px * pixels_per_degree;
    let steps = 4096;
    let t_max = upper_cpd.sqrt();
    let (mut num, mut den) = (0.0, 0.0);
    for i in 0..=steps {
        let t = t_max * i as f64 / steps as f64;
        let nu = t * t;
        // d nu = 2 t dt.
        let w = if i == 0 || i == steps { 0.5 } else { 1.0 } * csf_cpiq(nu) * 2.0 * t;
        num += w * crate::sfr::interp(freq_cy_per_px, sfr, nu / pixels_per_degree);
        den += w;
    }
    Ok(Acutance {
        acutance: num / den,
        pixels_per_degree,
        upper_cpd,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn viewing_geometry() {
        // 1000 pixels over 0.2 m at 0.5 m: 5000 px/m x 2 x 0.5 m x tan(0.5 deg) = 43.63 px/deg.
        let v = ViewingCondition {
            image_height_px: 1000,
            display_height_m: 0.2,
            viewing_distance_m: 0.5,
        };
        assert!((v.pixels_per_degree().unwrap() - 5000.0 * 0.5f64.to_radians().tan()).abs() < 1e-9);
        assert!(ViewingCondition {
            viewing_distance_m: f64::NAN,
            ..v
        }
        .pixels_per_degree()
        .is_err());
        assert!(ViewingCondition {
            image_height_px: 0,
            ..v
        }
        .pixels_per_degree()
        .is_err());
    }

    #[test]
    fn a_perfect_sfr_has_acutance_one() {
        let f: Vec<f64> = (0..=64).map(|i| i as f64 / 128.0).collect();
        for ppd in [10.0, 43.6, 300.0] {
            let a = acutance(&f, &vec![1.0; f.len()], ppd).unwrap();
            assert!((a.acutance - 1.0).abs() < 1e-12, "{ppd}: {}", a.acutance);
        }
    }

    #[test]
    fn an_exponential_sfr_matches_the_closed_form() {
        // SFR = exp(-k nu) with nu in cycles/degree: int_0^inf nu^c e^{-(b + k) nu} dnu =
        // Gamma(c + 1) / (b + k)^(c + 1), so A = (b / (b + k))^(c + 1) when the Nyquist frequency
        // is far beyond the CSF (here 0.5 x 400 = 200 cycles/degree, CSF(200) ~ 1e-16).
        let ppd = 400.0;
        let [_, b, c, _] = CPIQ_CSF;
        let f: Vec<f64> = (0..=4000).map(|i| i as f64 / 8000.0).collect();
        for k in [0.02, 0.1, 0.5] {
            let sfr: Vec<f64> = f.iter().map(|x| (-k * x * ppd).exp()).collect();
            let a = acutance(&f, &sfr, ppd).unwrap();
            let expect = (b / (b + k)).powf(c + 1.0);
            eprintln!(
                "exponential SFR k = {k} deg: acutance {:.6} vs closed form {expect:.6}",
                a.acutance
            );
            assert!(
                (a.acutance - expect).abs() < 1e-3 * expect,
                "k = {k}: {} vs {expect}",
                a.acutance
            );
        }
    }

    #[test]
    fn a_gaussian_sfr_matches_independent_quadrature_and_falls_with_blur() {
        // SFR = exp(-(nu / s)^2 / 2): compared with a fine midpoint rule in nu (an independent
        // quadrature of the same integrals), and sharper systems score higher.
        let ppd = 60.0;
        let f: Vec<f64> = (0..=2000).map(|i| i as f64 / 4000.0).collect();
        let mut last = 0.0;
        for s in [2.0, 5.0, 10.0, 20.0] {
            let g = |nu: f64| (-0.5 * (nu / s) * (nu / s)).exp();
            let sfr: Vec<f64> = f.iter().map(|x| g(x * ppd)).collect();
            let a = acutance(&f, &sfr, ppd).unwrap().acutance;
            let (mut num, mut den) = (0.0, 0.0);
            let m = 200_000;
            for i in 0..m {
                let nu = (i as f64 + 0.5) * 30.0 / m as f64;
                num += csf_cpiq(nu) * g(nu);
                den += csf_cpiq(nu);
            }
            assert!(
                (a - num / den).abs() < 1e-3,
                "s = {s}: {a} vs {}",
                num / den
            );
            assert!(a > last && a < 1.0, "s = {s}: {a}");
            last = a;
        }
    }

    #[test]
    fn bad_sfr_is_an_error() {
        assert!(acutance(&[0.0, 0.1], &[1.0], 40.0).is_err());
        assert!(acutance(&[0.0, 0.0], &[1.0, 1.0], 40.0).is_err());
        assert!(acutance(&[0.0, 0.1], &[1.0, f64::NAN], 40.0).is_err());
        assert!(acutance(&[0.0, 0.1], &[1.0, 1.0], 0.0).is_err());
    }
}
