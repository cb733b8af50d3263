//! EMVA 1288 release 4.0 (Linear) characterization of a camera or a sensor model from a series of
//! flat-field and dark frames at increasing exposure: the photon-transfer method.
//!
//! Model (EMVA 1288 4.0 Linear, sec. 2): `mu_y = mu_y.dark + K eta mu_p` and
//! `sigma_y^2 = K^2 sigma_d^2 + sigma_q^2 + K (mu_y - mu_y.dark)`, so
//! `sigma_y^2 - sigma_y.dark^2 = K (mu_y - mu_y.dark)` (the photon transfer curve, PTC).
//!
//! Per level: the mean over all frames and pixels, and the temporal variance from frame pairs
//! `sigma_y^2 = 1/2 var(y_A - y_B)` (mean difference removed; averaged over the disjoint pairs
//! available). K is the slope of the PTC fitted from the darkest level to 70 % of the saturation
//! signal; saturation is the level of maximum temporal variance. DSNU and PRNU come from the
//! frame stack of one level (most frames, ties broken by closeness to 50 % of saturation) with
//! the temporal variance of the L-frame average removed: `s^2 = s_measured^2 - sigma_y^2 / L`.
//!
//! Colour sensors are characterized per channel ([`emva_raw`]), as the standard asks.

use crate::error::{AnalysisError, Result};
use crate::image::{cfa_channel_plane, Plane};
use camsim_core::{CfaChannel, RawImage};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// One illumination level: frames at one exposure, with and without light.
#[derive(Debug, Clone)]
pub struct EmvaInput<'a> {
    /// Exposure time, s.
    pub exposure_s: f64,
    /// Mean number of photons reaching a pixel during the exposure (None when not known: QE,
    /// responsivity and thresholds in photons are then left out).
    pub photons_per_pixel: Option<f64>,
    /// Focal-plane (sensor-plane) photometric exposure, lux s, when known: ISO 12232 speeds and
    /// the SNR against lux s need it.
    pub exposure_lux_s: Option<f64>,
    /// Illuminated frames (at least 2; more frames improve DSNU/PRNU).
    pub bright: Vec<&'a Plane>,
    /// Dark frames at the same exposure (at least 2 at one level or more; levels without darks
    /// use the dark values interpolated linearly in exposure).
    pub dark: Vec<&'a Plane>,
}

/// Options of the evaluation.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EmvaOptions {
    /// Upper end of the PTC and responsivity fit range, as a fraction of the saturation signal
    /// (EMVA 1288 4.0: 0.7).
    pub fit_max_fraction: f64,
    /// Quantization noise variance, DN^2 (1/12 for a uniform quantizer of 1 DN step).
    pub quantization_var_dn2: f64,
}

impl Default for EmvaOptions {
    fn default() -> Self {
        EmvaOptions {
            fit_max_fraction: 0.7,
            quantization_var_dn2: 1.0 / 12.0,
        }
    }
}

/// Measured values at one level (the data of the photon-transfer and SNR plots).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EmvaPoint {
    /// Exposure time, s.
    pub exposure_s: f64,
    /// Mean photons per pixel, when known.
    pub photons_per_pixel: Option<f64>,
    /// Sensor-plane photometric exposure, lux s, when known.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub exposure_lux_s: Option<f64>,
    /// Mean of the illuminated frames, DN.
    pub mean_dn: f64,
    /// Temporal variance of the illuminated frames, DN^2.
    pub var_dn2: f64,
    /// Mean of the dark frames (measured or interpolated), DN.
    pub dark_mean_dn: f64,
    /// Temporal variance of the dark frames, DN^2.
    pub dark_var_dn2: f64,
    /// Signal `mean - dark mean`, DN.
    pub signal_dn: f64,
    /// Signal temporal variance `var - dark var`, DN^2 (the PTC ordinate).
    pub signal_var_dn2: f64,
    /// Measured SNR `signal / sqrt(var)` (temporal noise only).
    pub snr: f64,
    /// Whether the point was inside the K (PTC) and responsivity fit range.
    pub in_fit: bool,
    /// Illuminated and dark frames used.
    pub frames: [usize; 2],
}

/// One point of the model SNR curve.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SnrPoint {
    /// Mean electrons per pixel.
    pub electrons: f64,
    /// Mean photons per pixel (when the QE is known).
    pub photons: Option<f64>,
    /// SNR with temporal noise only (EMVA 1288 4.0 eq. for SNR with sigma_d, sigma_q, shot noise).
    pub snr_temporal: f64,
    /// SNR including DSNU and PRNU (the total SNR of the standard).
    pub snr_total: f64,
    /// Sensor-plane exposure of this signal, lux s (when the series gives lux s).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub exposure_lux_s: Option<f64>,
}

/// ISO 12232:2019 speeds of a series whose levels give their sensor-plane exposure in lux s,
/// for the light of the series and this channel (the standard weights channels into a luminance
/// signal; per channel, the green one is the closest to it).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct IsoSpeeds {
    /// Exposure per electron, lux s: the least-squares slope of H against the signal over the
    /// levels of the responsivity fit range (the sensor is linear there).
    pub lux_s_per_e: f64,
    /// Exposure at the saturation capacity, lux s.
    pub saturation_exposure_lux_s: f64,
    /// Saturation-based speed S_sat = 78 / H_sat (ISO 12232: the exposure 10 / S of the
    /// standard's mid-grey then sits at 10 / 78 = 12.8 % of saturation).
    pub saturation_speed: f64,
    /// Noise-based speed S_40 = 10 / H_40, H_40 the exposure at SNR 40 ("excellent").
    pub noise_speed_40: Option<f64>,
    /// Noise-based speed S_10 = 10 / H_10, H_10 the exposure at SNR 10 ("acceptable").
    pub noise_speed_10: Option<f64>,
}

/// The EMVA 1288 characterization.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EmvaResult {
    /// System gain K, DN per electron (slope of the photon transfer curve).
    pub system_gain_dn_per_e: f64,
    /// Standard error of K from the regression, DN per electron.
    pub system_gain_std_err: f64,
    /// Offset of the PTC regression line, DN^2 (ideally 0).
    pub ptc_offset_dn2: f64,
    /// Inverse system gain 1/K, electrons per DN.
    pub inverse_gain_e_per_dn: f64,
    /// Responsivity R = K eta, DN per photon (slope of signal vs photons), when photons are known.
    pub responsivity_dn_per_photon: Option<f64>,
    /// Quantum efficiency eta = R / K (fraction), when photons are known.
    pub quantum_efficiency: Option<f64>,
    /// Dark mean at the shortest exposure, DN (the black level).
    pub dark_offset_dn: f64,
    /// Temporal dark noise at the shortest exposure, DN (sqrt of the dark variance, quantization
    /// noise included).
    pub temporal_dark_noise_dn: f64,
    /// Temporal dark noise sigma_d = sqrt(sigma_y.dark^2 - sigma_q^2) / K, electrons.
    pub temporal_dark_noise_e: f64,
    /// Signal at saturation (the level of maximum temporal variance), DN above dark.
    pub saturation_signal_dn: f64,
    /// Saturation capacity, electrons: eta * mu_p.sat when photons are known, else the
    /// saturation signal / K.
    pub saturation_capacity_e: f64,
    /// Largest mean signal of the series, DN above dark: the clipping level (full well or ADC
    /// range) when the series goes past saturation.
    pub saturation_plateau_dn: f64,
    /// The plateau in electrons (plateau / K): the configured well capacity of a sensor model
    /// whose output clips there. The EMVA saturation point (maximum variance) lies below it by
    /// two to three standard deviations of the pixels' signal (temporal noise and PRNU).
    pub saturation_plateau_e: f64,
    /// Photons per pixel at saturation, when known.
    pub saturation_photons: Option<f64>,
    /// Dark current from the slope of the dark mean vs exposure, electrons/s (None with fewer
    /// than two distinct exposures with dark frames).
    pub dark_current_e_per_s: Option<f64>,
    /// Dark current from the slope of the dark variance vs exposure, electrons/s.
    pub dark_current_from_variance_e_per_s: Option<f64>,
    /// DSNU: spatial standard deviation of the dark frames (temporal part removed), DN.
    pub dsnu_dn: f64,
    /// DSNU in electrons (DSNU_1288).
    pub dsnu_e: f64,
    /// PRNU: spatial standard deviation of the signal (dark nonuniformity and temporal part
    /// removed) over the mean signal, percent (PRNU_1288).
    pub prnu_percent: f64,
    /// Level used for DSNU and PRNU (index into `points`).
    pub nonuniformity_level: usize,
    /// Frames averaged for DSNU and PRNU: [illuminated, dark].
    pub nonuniformity_frames: [usize; 2],
    /// Maximum SNR sqrt(mu_e.sat) (ratio).
    pub snr_max: f64,
    /// Maximum SNR, dB (20 log10).
    pub snr_max_db: f64,
    /// Absolute sensitivity threshold (SNR = 1) in electrons:
    /// `1/2 + sqrt(sigma_y.dark^2 / K^2 + 1/4)`.
    pub threshold_e: f64,
    /// Absolute sensitivity threshold in photons (threshold_e / eta), when photons are known.
    pub threshold_photons: Option<f64>,
    /// Dynamic range mu_e.sat / mu_e.min (ratio).
    pub dynamic_range: f64,
    /// Dynamic range, dB (20 log10).
    pub dynamic_range_db: f64,
    /// ISO 15739 (2013, 2023) sensor dynamic range: the saturation capacity over the signal at
    /// which the *total* SNR (temporal dark noise, shot noise, DSNU and PRNU, as one frame of the
    /// standard's chart holds them) is 1, `mu_e.min = (1 + sqrt(1 + 4 (1 - PRNU^2)
    /// (sigma_d^2 + DSNU^2))) / (2 (1 - PRNU^2))`, the root of `mu^2 = sigma_d^2 + DSNU^2 + mu +
    /// PRNU^2 mu^2`; below the EMVA figure, which counts temporal noise only, by the fixed pattern.
    /// Raw data are linear, so the standard's incremental gain is constant and cancels.
    #[serde(default)]
    pub iso_15739_dynamic_range: f64,
    /// The same, dB (20 log10).
    #[serde(default)]
    pub iso_15739_dynamic_range_db: f64,
    /// ISO 12232 speeds, when the series gives each level's exposure in lux s.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub iso_12232: Option<IsoSpeeds>,
    /// The measured points (photon-transfer and SNR plot data).
    pub points: Vec<EmvaPoint>,
    /// The model SNR curve from the threshold to saturation (log-spaced).
    pub snr_curve: Vec<SnrPoint>,
}

/// Mean and temporal variance of a frame stack: mean over frames and pixels; temporal variance
/// averaged over disjoint consecutive pairs, each `1/2 var(A - B)` (EMVA 1288 4.0 Linear, eq.
/// for sigma_y^2 from two frames).
fn stack_stats(frames: &[&Plane]) -> (f64, f64) {
    let n = frames[0].data.len() as f64;
    let mean = frames
        .iter()
        .map(|f| f.data.iter().map(|v| *v as f64).sum::<f64>() / n)
        .sum::<f64>()
        / frames.len() as f64;
    let pairs = frames.len() / 2;
    let mut var = 0.0;
    for p in 0..pairs {
        let (a, b) = (&frames[2 * p].data, &frames[2 * p + 1].data);
        let (mut s, mut s2) = (0.0f64, 0.0f64);
        for (x, y) in a.iter().zip(b) {
            let d = *x as f64 - *y as f64;
            s += d;
            s2 += d * d;
        }
        let md = s / n;
        var += 0.5 * (s2 / n - md * md);
    }
    (mean, var / pairs as f64)
}

/// Spatial variance (n - 1) of the per-pixel average of a stack (before removing the temporal part).
fn averaged_spatial_var(frames: &[&Plane]) -> f64 {
    let n = frames[0].data.len();
    let l = frames.len() as f64;
    let mut avg = vec![0.0f64; n];
    for f in frames {
        for (a, v) in avg.iter_mut().zip(&f.data) {
            *a += *v as f64;
        }
    }
    let mean = avg.iter().sum::<f64>() / (n as f64 * l);
    avg.iter().map(|a| (a / l - mean).powi(2)).sum::<f64>() / (n as f64 - 1.0).max(1.0)
}

/// Least-squares line y = a + b x: (a, b, standard error of b).
fn line_fit(x: &[f64], y: &[f64]) -> Option<(f64, f64, f64)> {
    let n = x.len() as f64;
    if x.len() < 2 {
        return None;
    }
    let mx = x.iter().sum::<f64>() / n;
    let my = y.iter().sum::<f64>() / n;
    let sxx: f64 = x.iter().map(|v| (v - mx).powi(2)).sum();
    if !(sxx > 0.0) {
        return None;
    }
    let sxy: f64 = x.iter().zip(y).map(|(a, b)| (a - mx) * (b - my)).sum();
    let b = sxy / sxx;
    let a = my - b * mx;
    let se = if x.len() > 2 {
        let rss: f64 = x.iter().zip(y).map(|(u, v)| (v - a - b * u).powi(2)).sum();
        (rss / (n - 2.0) / sxx).sqrt()
    } else {
        0.0
    };
    Some((a, b, se))
}

fn check_levels(levels: &[EmvaInput]) -> Result<(usize, usize)> {
    if levels.len() < 3 {
        return Err(AnalysisError::invalid(
            "emva",
            format!(
                "{} levels given; the photon transfer method needs at least 3",
                levels.len()
            ),
        ));
    }
    let first = levels
        .iter()
        .flat_map(|l| l.bright.first())
        .next()
        .ok_or_else(|| AnalysisError::invalid("emva", "no frames"))?;
    let (rows, cols) = (first.rows, first.cols);
    if rows * cols < 2 {
        return Err(AnalysisError::invalid(
            "emva",
            "frames need at least 2 pixels",
        ));
    }
    for (i, l) in levels.iter().enumerate() {
        if !(l.exposure_s >= 0.0 && l.exposure_s.is_finite()) {
            return Err(AnalysisError::invalid(
                "emva",
                format!(
                    "level {i}: exposure {} s is not a non-negative number",
                    l.exposure_s
                ),
            ));
        }
        if let Some(p) = l.photons_per_pixel {
            if !(p >= 0.0 && p.is_finite()) {
                return Err(AnalysisError::invalid(
                    "emva",
                    format!("level {i}: photons per pixel {p} is not a non-negative number"),
                ));
            }
        }
        if l.bright.len() < 2 {
            return Err(AnalysisError::invalid(
                "emva",
                format!(
                    "level {i} has {} illuminated frames; at least 2 are needed",
                    l.bright.len()
                ),
            ));
        }
        if l.dark.len() == 1 {
            return Err(AnalysisError::invalid(
                "emva",
                format!("level {i} has 1 dark frame; give 0 or at least 2"),
            ));
        }
        for f in l.bright.iter().chain(&l.dark) {
            if f.rows != rows || f.cols != cols || f.data.len() != rows * cols {
                return Err(AnalysisError::invalid(
                    "emva",
                    format!(
                        "level {i}: a {} x {} frame in a {rows} x {cols} series",
                        f.rows, f.cols
                    ),
                ));
            }
        }
    }
    if levels.iter().all(|l| l.dark.is_empty()) {
        return Err(AnalysisError::invalid("emva", "no level has dark frames"));
    }
    Ok((rows, cols))
}

/// Linear interpolation in exposure of dark (mean, var) from the levels that have darks.
fn dark_at(known: &[(f64, f64, f64)], t: f64) -> (f64, f64) {
    if known.len() == 1 {
        return (known[0].1, known[0].2);
    }
    let i = known.partition_point(|k| k.0 < t).clamp(1, known.len() - 1);
    let (a, b) = (known[i - 1], known[i]);
    if (b.0 - a.0).abs() < 1e-300 {
        return (a.1, a.2);
    }
    let w = (t - a.0) / (b.0 - a.0);
    (a.1 + w * (b.1 - a.1), a.2 + w * (b.2 - a.2))
}

/// EMVA 1288 characterization of a monochrome sensor (or one colour channel) from a series of
/// levels at increasing exposure or irradiance.
pub fn emva(levels: &[EmvaInput], opts: &EmvaOptions) -> Result<EmvaResult> {
    check_levels(levels)?;
    if !(opts.fit_max_fraction > 0.0 && opts.fit_max_fraction <= 1.0)
        || !(opts.quantization_var_dn2 >= 0.0)
    {
        return Err(AnalysisError::invalid(
            "emva options",
            "fit_max_fraction must be in (0, 1] and quantization_var_dn2 >= 0",
        ));
    }
    // Statistics per level (levels in parallel; each sum is sequential, so results do not depend
    // on the thread count).
    type MeanVar = (f64, f64);
    let stats: Vec<(MeanVar, Option<MeanVar>)> = levels
        .par_iter()
        .map(|l| {
            (
                stack_stats(&l.bright),
                (!l.dark.is_empty()).then(|| stack_stats(&l.dark)),
            )
        })
        .collect();
    let mut known: Vec<(f64, f64, f64)> = levels
        .iter()
        .zip(&stats)
        .filter_map(|(l, s)| s.1.map(|(m, v)| (l.exposure_s, m, v)))
        .collect();
    known.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut points: Vec<EmvaPoint> = levels
        .iter()
        .zip(&stats)
        .map(|(l, ((m, v), d))| {
            let (dm, dv) = d.unwrap_or_else(|| dark_at(&known, l.exposure_s));
            let signal = m - dm;
            EmvaPoint {
                exposure_s: l.exposure_s,
                photons_per_pixel: l.photons_per_pixel,
                exposure_lux_s: l.exposure_lux_s,
                mean_dn: *m,
                var_dn2: *v,
                dark_mean_dn: dm,
                dark_var_dn2: dv,
                signal_dn: signal,
                signal_var_dn2: v - dv,
                snr: if *v > 0.0 { signal / v.sqrt() } else { 0.0 },
                in_fit: false,
                frames: [l.bright.len(), l.dark.len()],
            }
        })
        .collect();

    // Saturation: the level of maximum temporal variance (EMVA 1288 4.0 Linear, saturation point).
    let sat = (0..points.len())
        .max_by(|a, b| points[*a].var_dn2.total_cmp(&points[*b].var_dn2))
        .unwrap_or(0);
    let sat_signal = points[sat].signal_dn;
    if !(sat_signal > 0.0) {
        return Err(AnalysisError::invalid(
            "emva",
            "the illuminated frames are not brighter than the dark frames",
        ));
    }
    // PTC fit: from the darkest level up to fit_max_fraction of the saturation signal.
    let limit = opts.fit_max_fraction * sat_signal;
    for p in points.iter_mut() {
        p.in_fit = p.signal_dn <= limit;
    }
    let fit_idx: Vec<usize> = (0..points.len()).filter(|i| points[*i].in_fit).collect();
    if fit_idx.len() < 2 {
        return Err(AnalysisError::invalid(
            "emva",
            format!("only {} level(s) below {:.0} % of saturation; the series needs more levels in the linear range", fit_idx.len(), 100.0 * opts.fit_max_fraction),
        ));
    }
    let xs: Vec<f64> = fit_idx.iter().map(|i| points[*i].signal_dn).collect();
    let ys: Vec<f64> = fit_idx.iter().map(|i| points[*i].signal_var_dn2).collect();
    let (ptc_offset, k, k_se) = line_fit(&xs, &ys).ok_or_else(|| {
        AnalysisError::invalid(
            "emva",
            "the levels in the fit range all have the same signal",
        )
    })?;
    if !(k > 0.0) {
        return Err(AnalysisError::invalid("emva", format!("the photon transfer curve has slope {k:.4}; the variance does not grow with the signal")));
    }

    // Responsivity and QE (photons known at every fitted level).
    let photons_known = levels.iter().all(|l| l.photons_per_pixel.is_some());
    let responsivity = if photons_known {
        let px: Vec<f64> = fit_idx
            .iter()
            .map(|i| points[*i].photons_per_pixel.unwrap_or(0.0))
            .collect();
        line_fit(&px, &xs).map(|(_, r, _)| r)
    } else {
        None
    };
    let eta = responsivity.map(|r| r / k);

    // Dark values at the shortest exposure.
    let (t0, dark0, dark_var0) = known[0];
    let _ = t0;
    let sigma_d_e = (dark_var0 - opts.quantization_var_dn2).max(0.0).sqrt() / k;
    let dark_current = if known.len() >= 2 {
        let t: Vec<f64> = known.iter().map(|k| k.0).collect();
        let m: Vec<f64> = known.iter().map(|k| k.1).collect();
        let v: Vec<f64> = known.iter().map(|k| k.2).collect();
        // EMVA 1288 4.0: mu_y.dark = mu_y.dark(0) + K mu_I t_exp; sigma_y.dark^2 grows by K^2 mu_I t_exp.
        (
            line_fit(&t, &m).map(|f| f.1 / k),
            line_fit(&t, &v).map(|f| f.1 / (k * k)),
        )
    } else {
        (None, None)
    };

    let plateau = points
        .iter()
        .map(|p| p.signal_dn)
        .fold(f64::NEG_INFINITY, f64::max);
    // Saturation capacity.
    let sat_photons = points[sat].photons_per_pixel.filter(|_| eta.is_some());
    let sat_e = match (eta, sat_photons) {
        (Some(e), Some(p)) => e * p,
        _ => sat_signal / k,
    };

    // DSNU and PRNU from the level with the largest stacks (ties: closest to 50 % saturation).
    let candidates: Vec<usize> = (0..levels.len())
        .filter(|i| !levels[*i].dark.is_empty() && *i != sat && points[*i].signal_dn < sat_signal)
        .collect();
    let nu = candidates
        .iter()
        .copied()
        .max_by(|a, b| {
            let fa = levels[*a].bright.len().min(levels[*a].dark.len());
            let fb = levels[*b].bright.len().min(levels[*b].dark.len());
            fa.cmp(&fb).then_with(|| {
                let da = (points[*a].signal_dn / sat_signal - 0.5).abs();
                let db = (points[*b].signal_dn / sat_signal - 0.5).abs();
                db.total_cmp(&da)
            })
        })
        .ok_or_else(|| {
            AnalysisError::invalid(
                "emva",
                "no level below saturation has dark frames for DSNU/PRNU",
            )
        })?;
    let lvl = &levels[nu];
    let (lb, ld) = (lvl.bright.len() as f64, lvl.dark.len() as f64);
    // EMVA 1288 4.0: s_y^2 = s_y.measured^2 - sigma_y^2 / L.
    let s2_dark = (averaged_spatial_var(&lvl.dark) - points[nu].dark_var_dn2 / ld).max(0.0);
    let s2_bright = (averaged_spatial_var(&lvl.bright) - points[nu].var_dn2 / lb).max(0.0);
    let dsnu_dn = s2_dark.sqrt();
    let prnu = (s2_bright - s2_dark).max(0.0).sqrt() / points[nu].signal_dn;

    // Threshold (SNR = 1): mu_e.min = 1/2 + sqrt(sigma_y.dark^2 / K^2 + 1/4).
    let threshold_e = 0.5 + (dark_var0 / (k * k) + 0.25).sqrt();
    let dynamic_range = sat_e / threshold_e;
    let snr_max = sat_e.max(0.0).sqrt();
    // ISO 15739: SNR 1 of the total noise, fixed pattern included (closed form of the quadratic).
    let fixed2 = dark_var0 / (k * k) + (dsnu_dn / k).powi(2);
    let q = (1.0 - prnu * prnu).max(1e-12);
    let iso_threshold_e = (1.0 + (1.0 + 4.0 * q * fixed2).sqrt()) / (2.0 * q);
    let iso_15739_dynamic_range = sat_e / iso_threshold_e;

    // Model SNR curve (EMVA 1288 4.0: SNR = eta mu_p / sqrt(sigma_d^2 + sigma_q^2/K^2 + eta mu_p),
    // total with DSNU^2 + PRNU^2 (eta mu_p)^2 added).
    let dsnu_e = dsnu_dn / k;
    let n_curve = 64;
    let lo = threshold_e.max(1e-3).ln();
    let hi = sat_e.max(threshold_e * 1.01).ln();
    let snr_total_at = |e: f64| {
        let temporal = dark_var0 / (k * k) + e;
        e / (temporal + dsnu_e * dsnu_e + (prnu * e).powi(2)).sqrt()
    };
    // ISO 12232: exposure per electron from the levels in the fit range (H = a mu_e, least
    // squares through 0), the saturation speed 78 / H_sat and the noise speeds 10 / H at SNR 40
    // and 10 (total SNR, fixed pattern included, as the standard's noise is measured on one
    // frame; the SNR found on the model curve, which rises monotonically with the signal).
    let iso_12232 = {
        let fit: Vec<(f64, f64)> = points
            .iter()
            .filter(|p| p.in_fit)
            .filter_map(|p| p.exposure_lux_s.map(|h| (h, p.signal_dn / k)))
            .collect();
        let see = fit.iter().map(|(_, e)| e * e).sum::<f64>();
        (levels.iter().all(|l| l.exposure_lux_s.is_some()) && fit.len() >= 2 && see > 0.0).then(
            || {
                let a = fit.iter().map(|(h, e)| h * e).sum::<f64>() / see;
                let at_snr = |target: f64| -> Option<f64> {
                    if snr_total_at(sat_e) < target {
                        return None;
                    }
                    let (mut lo, mut hi) = (1e-6f64, sat_e);
                    for _ in 0..200 {
                        let mid = (lo * hi).sqrt();
                        if snr_total_at(mid) < target {
                            lo = mid;
                        } else {
                            hi = mid;
                        }
                    }
                    Some(10.0 / (a * hi))
                };
                IsoSpeeds {
                    lux_s_per_e: a,
                    saturation_exposure_lux_s: a * sat_e,
                    saturation_speed: 78.0 / (a * sat_e),
                    noise_speed_40: at_snr(40.0),
                    noise_speed_10: at_snr(10.0),
                }
            },
        )
    };
    let snr_curve = (0..n_curve)
        .map(|i| {
            let e = (lo + (hi - lo) * i as f64 / (n_curve - 1) as f64).exp();
            let temporal = dark_var0 / (k * k) + e;
            SnrPoint {
                electrons: e,
                photons: eta.map(|h| e / h),
                snr_temporal: e / temporal.sqrt(),
                snr_total: snr_total_at(e),
                exposure_lux_s: iso_12232.map(|s| s.lux_s_per_e * e),
            }
        })
        .collect();

    Ok(EmvaResult {
        system_gain_dn_per_e: k,
        system_gain_std_err: k_se,
        ptc_offset_dn2: ptc_offset,
        inverse_gain_e_per_dn: 1.0 / k,
        responsivity_dn_per_photon: responsivity,
        quantum_efficiency: eta,
        dark_offset_dn: dark0,
        temporal_dark_noise_dn: dark_var0.max(0.0).sqrt(),
        temporal_dark_noise_e: sigma_d_e,
        saturation_signal_dn: sat_signal,
        saturation_capacity_e: sat_e,
        saturation_photons: sat_photons,
        saturation_plateau_dn: plateau,
        saturation_plateau_e: plateau / k,
        dark_current_e_per_s: dark_current.0,
        dark_current_from_variance_e_per_s: dark_current.1,
        dsnu_dn,
        dsnu_e,
        prnu_percent: 100.0 * prnu,
        nonuniformity_level: nu,
        nonuniformity_frames: [lvl.bright.len(), lvl.dark.len()],
        snr_max,
        snr_max_db: 20.0 * snr_max.max(1e-300).log10(),
        threshold_e,
        threshold_photons: eta.map(|h| threshold_e / h),
        dynamic_range,
        dynamic_range_db: 20.0 * dynamic_range.max(1e-300).log10(),
        iso_15739_dynamic_range,
        iso_15739_dynamic_range_db: 20.0 * iso_15739_dynamic_range.max(1e-300).log10(),
        iso_12232,
        points,
        snr_curve,
    })
}

/// One level of a raw (Bayer) series.
#[derive(Debug, Clone)]
pub struct EmvaRawInput<'a> {
    /// Exposure time, s.
    pub exposure_s: f64,
    /// Mean photons per pixel reaching each pixel (before its colour filter), when known.
    pub photons_per_pixel: Option<f64>,
    /// Sensor-plane photometric exposure, lux s, when known.
    pub exposure_lux_s: Option<f64>,
    /// Illuminated raw frames.
    pub bright: Vec<&'a RawImage>,
    /// Dark raw frames.
    pub dark: Vec<&'a RawImage>,
}

/// EMVA result of one colour channel.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ChannelEmva {
    /// The channel (R, G, B; green pools both greens of the 2x2 block).
    pub channel: CfaChannel,
    /// Its characterization.
    pub result: EmvaResult,
}

/// The pixels of one CFA channel as a plane (both greens stacked for G), black subtracted.
fn channel_pixels(raw: &RawImage, ch: CfaChannel) -> Result<Plane> {
    if ch == CfaChannel::G {
        let a = cfa_channel_plane(raw, ch, Some(0))?;
        let b = cfa_channel_plane(raw, ch, Some(1))?;
        let cols = a.cols.min(b.cols);
        let mut data = Vec::with_capacity((a.rows + b.rows) * cols);
        for p in [&a, &b] {
            for r in 0..p.rows {
                data.extend_from_slice(&p.row(r)[..cols]);
            }
        }
        Plane::new(a.rows + b.rows, cols, data)
    } else {
        cfa_channel_plane(raw, ch, None)
    }
}

/// EMVA 1288 per colour channel of a raw series (EMVA 1288 4.0: colour sensors are characterized
/// channel by channel on the raw data).
pub fn emva_raw(levels: &[EmvaRawInput], opts: &EmvaOptions) -> Result<Vec<ChannelEmva>> {
    [CfaChannel::R, CfaChannel::G, CfaChannel::B]
        .into_iter()
        .map(|ch| {
            let planes: Vec<(Vec<Plane>, Vec<Plane>)> = levels
                .iter()
                .map(|l| {
                    Ok((
                        l.bright
                            .iter()
                            .map(|r| channel_pixels(r, ch))
                            .collect::<Result<Vec<_>>>()?,
                        l.dark
                            .iter()
                            .map(|r| channel_pixels(r, ch))
                            .collect::<Result<Vec<_>>>()?,
                    ))
                })
                .collect::<Result<_>>()?;
            let inputs: Vec<EmvaInput> = levels
                .iter()
                .zip(&planes)
                .map(|(l, (b, d))| EmvaInput {
                    exposure_s: l.exposure_s,
                    photons_per_pixel: l.photons_per_pixel,
                    exposure_lux_s: l.exposure_lux_s,
                    bright: b.iter().collect(),
                    dark: d.iter().collect(),
                })
                .collect();
            Ok(ChannelEmva {
                channel: ch,
                result: emva(&inputs, opts)?,
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pair_variance_is_half_the_difference_variance() {
        // A = offset pattern + t, B = offset pattern - t: var(A - B) / 2 = 2 var(t).
        let pattern: Vec<f32> = (0..100).map(|i| (i % 7) as f32 * 10.0).collect();
        let t: Vec<f32> = (0..100)
            .map(|i| if i % 2 == 0 { 1.0 } else { -1.0 })
            .collect();
        let a = Plane::new(10, 10, pattern.iter().zip(&t).map(|(p, v)| p + v).collect()).unwrap();
        let b = Plane::new(
            10,
            10,
            pattern.iter().zip(&t).map(|(p, v)| p - v + 3.0).collect(),
        )
        .unwrap();
        let (m, v) = stack_stats(&[&a, &b]);
        let pm = pattern.iter().map(|v| *v as f64).sum::<f64>() / 100.0;
        assert!((m - (pm + 1.5)).abs() < 1e-9);
        assert!((v - 2.0).abs() < 1e-12, "{v}");
    }

    #[test]
    fn bad_series_are_errors() {
        let p = Plane::zeros(4, 4).unwrap();
        let q = Plane::zeros(4, 5).unwrap();
        let lvl = |b: Vec<&'static Plane>, d: Vec<&'static Plane>| EmvaInput {
            exposure_s: 1e-3,
            photons_per_pixel: None,
            exposure_lux_s: None,
            bright: b,
            dark: d,
        };
        let p: &'static Plane = Box::leak(Box::new(p));
        let q: &'static Plane = Box::leak(Box::new(q));
        let o = EmvaOptions::default();
        assert!(emva(&[lvl(vec![p, p], vec![p, p])], &o).is_err());
        assert!(emva(
            &[
                lvl(vec![p], vec![p, p]),
                lvl(vec![p, p], vec![]),
                lvl(vec![p, p], vec![])
            ],
            &o
        )
        .is_err());
        assert!(emva(
            &[
                lvl(vec![p, q], vec![p, p]),
                lvl(vec![p, p], vec![]),
                lvl(vec![p, p], vec![])
            ],
            &o
        )
        .is_err());
        // Flat frames (no signal) are an error, not a panic.
        assert!(emva(
            &[
                lvl(vec![p, p], vec![p, p]),
                lvl(vec![p, p], vec![]),
                lvl(vec![p, p], vec![])
            ],
            &o
        )
        .is_err());
    }
}
