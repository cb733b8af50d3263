//! Fit the lens defocus (and optionally a sensor crosstalk blur) to a measured system MTF.
//!
//! A slanted-edge SFR of a real camera (ISO 12233) measures the whole capture chain on axis. The
//! model of that chain here is a product of transfer functions (linear shift-invariant stages
//! multiply in frequency; Goodman, Introduction to Fourier Optics, 3rd ed., sec. 6.3):
//!
//! ```text
//! MTF(f) = MTF_lens(f; c4, lambda, N) x |sinc(f p)| x exp(-2 pi^2 sigma^2 f^2)
//! ```
//!
//! - `MTF_lens`: the wavefront model camsim renders with ([`Wavefront::mtf`]): a
//!   diffraction-limited pupil of f-number N with an OSA defocus term c4 over the *lens* pupil
//!   (um of optical path);
//! - `|sinc(f p)|`: the pixel aperture, a square photodetector of side p sqrt(fill factor)
//!   (ISETCam's pixel MTF; Boreman, Modulation Transfer Function in Optical and Electro-Optical
//!   Systems, sec. 2.2);
//! - `exp(-2 pi^2 sigma^2 f^2)`: pixel crosstalk (carrier diffusion and optical crosstalk between
//!   neighbouring photodiodes) modelled as a Gaussian point spread of standard deviation sigma in
//!   the sensor plane; the Fourier transform of a unit-area Gaussian of standard deviation sigma
//!   is exp(-2 pi^2 sigma^2 f^2).
//!
//! [`fit_mtf`] minimises the RMS difference between model and measurement over the measured
//! frequencies (up to `max_freq_cyc_per_mm`): a coarse scan over c4 (the lens MTF is computed once
//! per c4; the Gaussian costs a multiplication), then Nelder-Mead (Nelder & Mead 1965) on the free
//! parameters, bounded by clamping. The MTF of pure defocus does not depend on the sign of c4
//! (the PSF of -W is the mirror image of the PSF of W), so c4 >= 0 is fitted.

use crate::error::{OpticsError, Result};
use crate::lens;
use crate::wavefront::Wavefront;
use camsim_core::math::sinc;

/// The system MTF model (see the module docs): lens with defocus, pixel aperture, crosstalk.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SystemMtfModel {
    /// f-number of the lens (focal length / pupil diameter).
    pub f_number: f64,
    /// Focal length, mm (sets the pupil diameter; the MTF depends on N only).
    pub focal_length_mm: f64,
    /// Wavelength of the lens MTF, nm.
    pub wavelength_nm: f64,
    /// Pixel pitch, um (0: no pixel aperture factor).
    pub pixel_pitch_um: f64,
    /// Fill factor of the square photodetector, fraction in (0, 1].
    pub fill_factor: f64,
    /// Defocus c4 (OSA, unit-RMS) over the lens pupil, um of optical path.
    pub defocus_um: f64,
    /// Crosstalk blur: standard deviation of a Gaussian in the sensor plane, um (0: none).
    pub crosstalk_sigma_um: f64,
}

impl SystemMtfModel {
    /// The Pixel 4a rear camera: f/1.73, 4.38 mm, 1.4 um pixels of 100 % fill factor (Lyu et al.,
    /// Table 1), at 550 nm, with no defocus and no crosstalk.
    pub fn pixel4a() -> Self {
        SystemMtfModel {
            f_number: 1.73,
            focal_length_mm: 4.38,
            wavelength_nm: 550.0,
            pixel_pitch_um: 1.4,
            fill_factor: 1.0,
            defocus_um: 0.0,
            crosstalk_sigma_um: 0.0,
        }
    }

    /// The defocus in waves at the model's wavelength (c4 / lambda).
    pub fn defocus_waves(&self) -> f64 {
        self.defocus_um / (self.wavelength_nm * 1e-3)
    }

    fn check(&self) -> Result<()> {
        let pos = |key: &str, v: f64| {
            if v > 0.0 && v.is_finite() {
                Ok(())
            } else {
                Err(OpticsError::config(
                    key,
                    format!("{v} is not a positive number"),
                ))
            }
        };
        pos("f_number", self.f_number)?;
        pos("focal_length_mm", self.focal_length_mm)?;
        pos("wavelength_nm", self.wavelength_nm)?;
        if !(self.pixel_pitch_um >= 0.0 && self.pixel_pitch_um.is_finite()) {
            return Err(OpticsError::config(
                "pixel_pitch_um",
                format!("{} is not a number >= 0", self.pixel_pitch_um),
            ));
        }
        if !(self.fill_factor > 0.0 && self.fill_factor <= 1.0) {
            return Err(OpticsError::config(
                "fill_factor",
                format!("{} is not in (0, 1]", self.fill_factor),
            ));
        }
        if !self.defocus_um.is_finite() {
            return Err(OpticsError::config(
                "defocus_um",
                format!("{} is not a finite number", self.defocus_um),
            ));
        }
        if !(self.crosstalk_sigma_um >= 0.0 && self.crosstalk_sigma_um.is_finite()) {
            return Err(OpticsError::config(
                "crosstalk_sigma_um",
                format!("{} is not a number >= 0", self.crosstalk_sigma_um),
            ));
        }
        Ok(())
    }

    /// The lens MTF alone (wavefront model) at `freq_cyc_per_mm`.
    pub fn lens_mtf(&self, freq_cyc_per_mm: &[f64]) -> Result<Vec<f64>> {
        self.check()?;
        LensCurve::new(self, self.defocus_um)
            .map(|c| freq_cyc_per_mm.iter().map(|f| c.at(*f)).collect())
    }

    /// Pixel aperture x crosstalk factor at `f_cyc_per_mm` (the sensor's share of the MTF).
    pub fn sensor_factor(&self, f_cyc_per_mm: f64) -> f64 {
        let f_per_um = f_cyc_per_mm * 1e-3;
        let side_um = self.pixel_pitch_um * self.fill_factor.sqrt();
        let s = self.crosstalk_sigma_um;
        sinc(f_per_um * side_um).abs()
            * (-2.0 * std::f64::consts::PI.powi(2) * s * s * f_per_um * f_per_um).exp()
    }

    /// The system MTF at each frequency (cycles/mm in the sensor plane).
    pub fn mtf(&self, freq_cyc_per_mm: &[f64]) -> Result<Vec<f64>> {
        let lens = self.lens_mtf(freq_cyc_per_mm)?;
        Ok(freq_cyc_per_mm
            .iter()
            .zip(lens)
            .map(|(f, l)| l * self.sensor_factor(*f))
            .collect())
    }
}

/// The lens MTF (x direction; rotationally symmetric for pure defocus) of one defocus value,
/// sampled from 0 to the diffraction cutoff.
struct LensCurve {
    freq_cyc_per_mm: Vec<f64>,
    mtf: Vec<f64>,
}

impl LensCurve {
    fn new(m: &SystemMtfModel, defocus_um: f64) -> Result<Self> {
        let wf = Wavefront::diffraction_limited(m.focal_length_mm * 1e-3, m.f_number)?
            .with_extra_defocus_um(defocus_um);
        let c = wf.mtf(m.wavelength_nm)?;
        Ok(LensCurve {
            freq_cyc_per_mm: c.freq_cyc_per_mm,
            mtf: c.mtf_x,
        })
    }

    /// Linear interpolation; 0 beyond the diffraction cutoff.
    fn at(&self, f: f64) -> f64 {
        let x = &self.freq_cyc_per_mm;
        let i = x.partition_point(|v| *v < f);
        if i == 0 {
            self.mtf[0]
        } else if i >= x.len() {
            0.0
        } else {
            let w = (f - x[i - 1]) / (x[i] - x[i - 1]);
            self.mtf[i - 1] * (1.0 - w) + self.mtf[i] * w
        }
    }
}

/// Which parameters [`fit_mtf`] varies; the others keep the model's values.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FitParams {
    /// Fit the defocus c4 (um over the lens pupil).
    pub defocus: bool,
    /// Fit the crosstalk Gaussian sigma (um).
    pub crosstalk: bool,
}

/// Options of [`fit_mtf`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MtfFitOptions {
    /// Free parameters.
    pub fit: FitParams,
    /// Only measured points at or below this frequency count, cycles/mm (`inf`: all).
    pub max_freq_cyc_per_mm: f64,
    /// Largest defocus searched, um over the lens pupil.
    pub max_defocus_um: f64,
    /// Largest crosstalk sigma searched, um.
    pub max_crosstalk_sigma_um: f64,
}

impl Default for MtfFitOptions {
    fn default() -> Self {
        MtfFitOptions {
            fit: FitParams {
                defocus: true,
                crosstalk: true,
            },
            max_freq_cyc_per_mm: f64::INFINITY,
            max_defocus_um: 1.0,
            max_crosstalk_sigma_um: 3.0,
        }
    }
}

/// The result of [`fit_mtf`].
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct MtfFit {
    /// Fitted defocus c4 over the lens pupil, um.
    pub defocus_um: f64,
    /// The same in waves at the model wavelength.
    pub defocus_waves: f64,
    /// The same over ISETCam's default 8 mm measurement pupil, um (the convention of the paper's
    /// 1.225 um): c4 (8 mm / lens pupil)^2.
    pub defocus_um_over_8mm: f64,
    /// Fitted crosstalk sigma, um.
    pub crosstalk_sigma_um: f64,
    /// RMS of (model - measured) over the points used.
    pub rms: f64,
    /// Largest |model - measured| over the points used.
    pub max_abs: f64,
    /// Points used.
    pub points: usize,
    /// MTF50 of the measurement (linear interpolation between points), cycles/mm.
    pub mtf50_measured_cyc_per_mm: Option<f64>,
    /// MTF50 of the fitted model, cycles/mm.
    pub mtf50_fit_cyc_per_mm: Option<f64>,
    /// Model evaluations the fit took.
    pub evaluations: usize,
}

/// First frequency where `mtf` falls below `level`, by linear interpolation between samples
/// (`None` when it never does). Samples must be in increasing frequency.
pub fn mtf_crossing(freq: &[f64], mtf: &[f64], level: f64) -> Option<f64> {
    (1..freq.len().min(mtf.len()))
        .find(|i| mtf[i - 1] >= level && mtf[*i] < level)
        .map(|i| {
            let w = (mtf[i - 1] - level) / (mtf[i - 1] - mtf[i]);
            freq[i - 1] + w * (freq[i] - freq[i - 1])
        })
}

/// MTF50 of `model`, cycles/mm: bisection of the continuous model between samples 1 cycle/mm
/// apart up to the diffraction cutoff.
pub fn model_mtf50(model: &SystemMtfModel) -> Result<Option<f64>> {
    let cutoff = lens::cutoff_cyc_per_mm(model.wavelength_nm, model.f_number);
    let freq: Vec<f64> = (0..=cutoff.ceil() as usize).map(|i| i as f64).collect();
    let m = model.mtf(&freq)?;
    Ok(mtf_crossing(&freq, &m, 0.5))
}

/// RMS and largest absolute difference of `model` from the measurement at `freq` (same length).
fn residual(model: &[f64], measured: &[f64]) -> (f64, f64) {
    let n = model.len().max(1) as f64;
    let ss: f64 = model
        .iter()
        .zip(measured)
        .map(|(a, b)| (a - b).powi(2))
        .sum();
    let mx = model
        .iter()
        .zip(measured)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    ((ss / n).sqrt(), mx)
}

/// Fit `start`'s free parameters (see [`MtfFitOptions::fit`]) to a measured MTF: `freq_cyc_per_mm`
/// increasing, `measured` as a fraction (1 at zero frequency). Returns the fitted model and the
/// figures of merit. Errors: mismatched or too few points, non-finite values, no free parameter.
pub fn fit_mtf(
    freq_cyc_per_mm: &[f64],
    measured: &[f64],
    start: &SystemMtfModel,
    opts: &MtfFitOptions,
) -> Result<(SystemMtfModel, MtfFit)> {
    start.check()?;
    if freq_cyc_per_mm.len() != measured.len() {
        return Err(OpticsError::Input(format!(
            "{} frequencies for {} MTF values",
            freq_cyc_per_mm.len(),
            measured.len()
        )));
    }
    if let Some(i) =
        (0..measured.len()).find(|i| !(freq_cyc_per_mm[*i].is_finite() && measured[*i].is_finite()))
    {
        return Err(OpticsError::Input(format!(
            "point {} ({}, {}) is not finite",
            i + 1,
            freq_cyc_per_mm[i],
            measured[i]
        )));
    }
    if freq_cyc_per_mm.windows(2).any(|w| w[1] <= w[0])
        || freq_cyc_per_mm.first().is_some_and(|f| *f < 0.0)
    {
        return Err(OpticsError::Input(
            "the frequencies must be >= 0 and increasing".into(),
        ));
    }
    if !(opts.max_defocus_um > 0.0 && opts.max_crosstalk_sigma_um > 0.0) {
        return Err(OpticsError::Input(
            "the search bounds must be positive".into(),
        ));
    }
    let used: Vec<usize> = (0..freq_cyc_per_mm.len())
        .filter(|i| freq_cyc_per_mm[*i] <= opts.max_freq_cyc_per_mm)
        .collect();
    let n_free = opts.fit.defocus as usize + opts.fit.crosstalk as usize;
    if n_free == 0 {
        return Err(OpticsError::Input(
            "nothing to fit: free the defocus, the crosstalk or both".into(),
        ));
    }
    if used.len() < n_free + 1 {
        return Err(OpticsError::Input(format!(
            "{} measured points up to the frequency limit; need at least {}",
            used.len(),
            n_free + 1
        )));
    }
    let f: Vec<f64> = used.iter().map(|i| freq_cyc_per_mm[*i]).collect();
    let y: Vec<f64> = used.iter().map(|i| measured[*i]).collect();
    let mut evaluations = 0usize;
    // Cost of (c4, sigma), with the lens curve given.
    let sensor_part = |sigma_um: f64| {
        let m = SystemMtfModel {
            crosstalk_sigma_um: sigma_um,
            ..*start
        };
        f.iter()
            .map(|fr| m.sensor_factor(*fr))
            .collect::<Vec<f64>>()
    };
    let cost_with = |lens: &LensCurve, sigma_um: f64| {
        let s = sensor_part(sigma_um);
        let model: Vec<f64> = f.iter().zip(&s).map(|(fr, sv)| lens.at(*fr) * sv).collect();
        residual(&model, &y).0
    };
    let sigma_grid: Vec<f64> = if opts.fit.crosstalk {
        (0..=30)
            .map(|i| opts.max_crosstalk_sigma_um * i as f64 / 30.0)
            .collect()
    } else {
        vec![start.crosstalk_sigma_um]
    };
    // Coarse scan: c4 on a grid (one lens MTF each), sigma on a grid.
    let c4_grid: Vec<f64> = if opts.fit.defocus {
        (0..=40)
            .map(|i| opts.max_defocus_um * i as f64 / 40.0)
            .collect()
    } else {
        vec![start.defocus_um]
    };
    let mut best = (f64::INFINITY, start.defocus_um, start.crosstalk_sigma_um);
    for c4 in &c4_grid {
        let lens = LensCurve::new(start, *c4)?;
        for s in &sigma_grid {
            evaluations += 1;
            let c = cost_with(&lens, *s);
            if c < best.0 {
                best = (c, *c4, *s);
            }
        }
    }
    // Nelder-Mead refinement on the free parameters, clamped to [0, max].
    let bounds = [opts.max_defocus_um, opts.max_crosstalk_sigma_um];
    let free: Vec<usize> = [opts.fit.defocus, opts.fit.crosstalk]
        .iter()
        .enumerate()
        .filter(|(_, b)| **b)
        .map(|(i, _)| i)
        .collect();
    let full = |x: &[f64]| {
        let mut p = [best.1, best.2];
        for (k, i) in free.iter().enumerate() {
            p[*i] = x[k].clamp(0.0, bounds[*i]);
        }
        p
    };
    let mut eval_err = None;
    let mut cost = |x: &[f64]| -> f64 {
        evaluations += 1;
        let p = full(x);
        match LensCurve::new(start, p[0]) {
            Ok(l) => cost_with(&l, p[1]),
            Err(e) => {
                eval_err = Some(e);
                f64::INFINITY
            }
        }
    };
    let x0: Vec<f64> = free.iter().map(|i| [best.1, best.2][*i]).collect();
    let steps: Vec<f64> = free.iter().map(|i| bounds[*i] / 40.0).collect();
    let x = nelder_mead(&mut cost, &x0, &steps, 1e-6, 200);
    if let Some(e) = eval_err {
        return Err(e);
    }
    let p = full(&x);
    let fitted = SystemMtfModel {
        defocus_um: p[0],
        crosstalk_sigma_um: p[1],
        ..*start
    };
    let model = fitted.mtf(&f)?;
    let (rms, max_abs) = residual(&model, &y);
    let lens_pupil_mm = start.focal_length_mm / start.f_number;
    let fit = MtfFit {
        defocus_um: fitted.defocus_um,
        defocus_waves: fitted.defocus_waves(),
        defocus_um_over_8mm: lens::rescale_defocus(fitted.defocus_um, lens_pupil_mm / 2.0, 4.0),
        crosstalk_sigma_um: fitted.crosstalk_sigma_um,
        rms,
        max_abs,
        points: f.len(),
        mtf50_measured_cyc_per_mm: mtf_crossing(freq_cyc_per_mm, measured, 0.5),
        mtf50_fit_cyc_per_mm: model_mtf50(&fitted)?,
        evaluations,
    };
    Ok((fitted, fit))
}

/// Minimise `f` from `x0` with the Nelder-Mead simplex method (Nelder & Mead, Computer Journal 7,
/// 1965; standard coefficients reflection 1, expansion 2, contraction 1/2, shrink 1/2), initial
/// simplex `x0` plus `step[i]` along each axis; stops when the spread of the simplex's values is
/// below `ftol` or after `max_iter` iterations.
fn nelder_mead(
    f: &mut dyn FnMut(&[f64]) -> f64,
    x0: &[f64],
    step: &[f64],
    ftol: f64,
    max_iter: usize,
) -> Vec<f64> {
    let n = x0.len();
    let mut pts: Vec<Vec<f64>> = vec![x0.to_vec()];
    for i in 0..n {
        let mut p = x0.to_vec();
        p[i] += step[i];
        pts.push(p);
    }
    let mut vals: Vec<f64> = pts.iter().map(|p| f(p)).collect();
    let lerp = |a: &[f64], b: &[f64], t: f64| {
        a.iter()
            .zip(b)
            .map(|(x, y)| x + t * (y - x))
            .collect::<Vec<f64>>()
    };
    for _ in 0..max_iter {
        let mut order: Vec<usize> = (0..=n).collect();
        order.sort_by(|a, b| vals[*a].total_cmp(&vals[*b]));
        pts = order.iter().map(|i| pts[*i].clone()).collect();
        vals = order.iter().map(|i| vals[*i]).collect();
        if (vals[n] - vals[0]).abs() <= ftol {
            break;
        }
        let centroid: Vec<f64> = (0..n)
            .map(|k| pts[..n].iter().map(|p| p[k]).sum::<f64>() / n as f64)
            .collect();
        // Reflection: centroid + (centroid - worst).
        let xr = lerp(&centroid, &pts[n], -1.0);
        let fr = f(&xr);
        if fr < vals[0] {
            let xe = lerp(&centroid, &pts[n], -2.0);
            let fe = f(&xe);
            if fe < fr {
                (pts[n], vals[n]) = (xe, fe);
            } else {
                (pts[n], vals[n]) = (xr, fr);
            }
        } else if fr < vals[n - 1] {
            (pts[n], vals[n]) = (xr, fr);
        } else {
            // Contraction towards the better of the worst point and its reflection.
            let (base, fb) = if fr < vals[n] {
                (xr.clone(), fr)
            } else {
                (pts[n].clone(), vals[n])
            };
            let xc = lerp(&centroid, &base, 0.5);
            let fc = f(&xc);
            if fc < fb {
                (pts[n], vals[n]) = (xc, fc);
            } else {
                for i in 1..=n {
                    pts[i] = lerp(&pts[0], &pts[i], 0.5);
                    vals[i] = f(&pts[i]);
                }
            }
        }
    }
    let best = (0..=n)
        .min_by(|a, b| vals[*a].total_cmp(&vals[*b]))
        .unwrap_or(0);
    pts[best].clone()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nelder_mead_finds_a_quadratic_minimum() {
        let mut f = |x: &[f64]| (x[0] - 0.3).powi(2) + 4.0 * (x[1] - 1.7).powi(2);
        let x = nelder_mead(&mut f, &[0.0, 0.0], &[0.1, 0.1], 1e-14, 500);
        assert!(
            (x[0] - 0.3).abs() < 1e-5 && (x[1] - 1.7).abs() < 1e-5,
            "{x:?}"
        );
    }

    #[test]
    fn sensor_factor_is_the_pixel_sinc_times_the_gaussian() {
        let m = SystemMtfModel {
            crosstalk_sigma_um: 0.5,
            ..SystemMtfModel::pixel4a()
        };
        // At f = 1 / (2 p) the sinc is 2 / pi; Gaussian exp(-2 pi^2 sigma^2 f^2).
        let f_per_um = 1.0 / 2.8;
        let want = 2.0 / std::f64::consts::PI
            * (-2.0 * std::f64::consts::PI.powi(2) * 0.25 * f_per_um * f_per_um).exp();
        assert!((m.sensor_factor(f_per_um * 1e3) - want).abs() < 1e-12);
    }
}
