//! The analysis on frames from camsim's own sensor model (camsim-sensor, the ISETCam model), so
//! the measurement chain is checked against the parameters the frames were made with.
//!
//! # 1. EMVA 1288 on `Sensor::emva_series` (the first two tests)
//!
//! Two sensors: the `imx363` preset (paper, Table 1; 12 bit) and a 10-bit sensor written here
//! (low read noise, other conversion gain, analog gain 0.8, GRBG, fill factor 0.8, dark current).
//! EMVA 1288 requires an offset so dark values are not clipped: the imx363 preset has analog
//! offset 0 (Table 1), so its dark frames (read noise 44.6 DN) would clip at 0 DN and bias the dark
//! mean, dark noise and DSNU. Each sensor is therefore given a black level, as a real camera has
//! (40 mV = 357 DN = 8 sigma of the dark noise for the imx363; 64 DN for the 10-bit sensor).
//!
//! The configured values the measurement must recover (ISETCam model, `v_out = (v + offset) / gain`,
//! `DN = round(v_out 2^bits / swing)`):
//! - K = conversion gain x 2^bits / swing / analog gain (DN/e-);
//! - temporal dark noise = read_noise_v / conversion gain (e-) (no dark current at t = 0);
//! - DSNU = dsnu_v x 2^bits / swing / analog gain (DN), = dsnu_v / conversion gain (e-);
//! - PRNU = prnu_percent (fraction of the signal);
//! - saturation = the clipping level in electrons, (swing x analog gain - offset) / conversion
//!   gain: the model clips the voltage after gain and offset (ISETCam `sensorCompute`), so with an
//!   offset the output clips below the well `swing / conversion gain`;
//! - QE = photo-electrons / photons per pixel (`mean_electrons_uniform / photons_per_pixel`, fill
//!   factor included), for the light used.
//!
//! Saturation is compared with `saturation_plateau_e` (largest mean signal / K): the analysis
//! documents it as the configured clipping level of a sensor model, while the EMVA saturation
//! point (maximum temporal variance, `saturation_capacity_e`) lies below it by two to three
//! standard deviations of the pixels' signal, because the variance falls as soon as the upper tail
//! of the distribution reaches the clip. That one is only checked to lie in [0.85, 1] x the clip.
//!
//! The flat field is three spectral lines (460, 540, 620 nm) weighted so that the R, G and B
//! pixels collect the same electron rate, so one exposure ladder takes every channel from dark
//! to past saturation; each channel is characterized on its own pixels (`emva_raw`).
//!
//! Sampling error (256 x 512 window: n = 32768 R or B pixels, 65536 G pixels per frame; one level
//! at 50 % of saturation with L = 128 bright and 128 dark frames for DSNU and PRNU):
//! - a temporal variance from P frame pairs of n pixels has relative s.e. sqrt(2 / (n P)). K is
//!   the slope of variance against signal over the levels up to 70 % of saturation; for the
//!   imx363 the read noise (44.6 DN, 1990 DN^2) dominates every variance there, so it gets 8 pairs
//!   per level: s.e.(K) ~ 0.45 % (R, B), 0.25 % (G); the 10-bit sensor (read noise 1.3 DN) needs
//!   only 2 pairs: ~0.3 %. The test also asserts the regression's own standard error < 0.75 %;
//! - sigma_d (dark variance at t = 0) has half the relative s.e. of its variance plus that of K;
//! - DSNU^2 is measured as s^2 - sigma_t^2 / L: s.e.(s^2) = sqrt(2/n) (DSNU^2 + sigma_t^2/L). For
//!   the imx363 (DSNU 5.7 DN, read noise 44.6 DN) that is 0.0078 x (32.6 + 15.5) DN^2, 1.15 % of
//!   DSNU^2, 0.58 % of the DSNU; for the 10-bit sensor 0.40 %;
//! - PRNU^2 = s_bright^2 - s_dark^2 at 50 % saturation: 0.52 % (imx363), 0.62 % (10-bit) of PRNU;
//! - the plateau and the QE are divided by K and carry its error.
//!
//! So 3 % is five or more standard errors for every quantity and channel.
//!
//! # 2. QE correction fit on camsim "measurements" (the last test)
//!
//! The paper fits M in `[r', g', b'] = [r, g, b] M` so that the published IMX363 QE predicts the
//! Pixel 4a's measured ColorChecker values. Here the "measurements" are noisy raw frames of the
//! `pixel4a` preset (its QE is the published QE times the paper's M) and the predictions are the
//! noise-free `imx363` preset at the same irradiance and exposure, so the fit in the paper's form
//! must give back the paper's M up to the measurement noise: 24 Ohta patches under CIE A, F2 and
//! D65, each a uniform 64 x 64 irradiance image (1024 R, 2048 G, 1024 B pixels), one frame with
//! every noise source on. The expected error of each entry is computed from the noise model
//! (`predicted_noise_dn` / sqrt(pixels), propagated through the least-squares normal equations):
//! the largest is ~5e-4, so the 0.01 tolerance is twenty standard errors; each entry is also
//! checked to lie within five of its own standard errors of the paper's value.

// Channel loops index several arrays at once (r, g, b).
#![allow(clippy::needless_range_loop)]

use camsim_analysis::emva::{emva_raw, ChannelEmva, EmvaOptions, EmvaRawInput};
use camsim_analysis::qefit::{fit_qe_matrix, MatrixForm, PAPER_M};
use camsim_analysis::roi::roi_stats_raw;
use camsim_analysis::Rect;
use camsim_core::{tables, CfaChannel, Quantity, SpectralImage, WavelengthGrid};
use camsim_sensor::{Capture, EmvaLevel, NoiseSwitches, Sensor, SensorConfig};
use nalgebra::{DMatrix, DVector};

const ROWS: usize = 256;
const COLS: usize = 512;

fn rel(a: f64, b: f64) -> f64 {
    (a / b - 1.0).abs()
}

/// The sensor with an analog offset giving `black_dn` DN of black level.
fn with_black_level(sensor: &Sensor, black_dn: f64) -> Sensor {
    let mut c = sensor.config().clone();
    // black_dn = offset / gain x 2^bits / swing  (ISETCam sensorCompute: v_out = (v + offset) / gain).
    c.analog_offset_mv = black_dn / sensor.dn_per_v() * sensor.analog_gain() * 1e3;
    Sensor::from_config_named(c, "EMVA test sensor").unwrap()
}

/// A 10-bit sensor unlike the imx363: larger pixels, higher conversion gain, low read noise
/// (3 e-), analog gain 0.8 (ISETCam divides by the gain, so < 1 amplifies), GRBG, fill factor 0.8,
/// dark current 66.7 e-/s, black level 64 DN. QE: the imx363's published curves.
fn ten_bit_sensor() -> Sensor {
    let qe = Sensor::preset("imx363").unwrap().config().qe.clone();
    let c = SensorConfig {
        name: "ten-bit test sensor".into(),
        source: None,
        rows: ROWS,
        cols: COLS,
        pixel_pitch_um: 3.45,
        fill_factor: 0.8,
        cfa: "GRBG".into(),
        conversion_gain_uv_per_e: 150.0,
        well_capacity_e: None,
        voltage_swing_v: 0.45,
        analog_gain: 0.8,
        analog_offset_mv: 0.0,
        bits: 10,
        dsnu_mv: 0.3,
        prnu_percent: 1.0,
        dark_voltage_mv_per_s: 10.0,
        read_noise_mv: 0.45,
        fixed_pattern_seed: 1288,
        qe_correction: None,
        noise: Default::default(),
        qe,
    };
    with_black_level(&Sensor::from_config(c).unwrap(), 64.0)
}

/// Clipping level in electrons: (swing x gain - offset) / conversion gain.
fn clip_e(s: &Sensor) -> f64 {
    (s.voltage_swing_v() * s.analog_gain() - s.analog_offset_v()) / s.conversion_gain_v_per_e()
}

/// Three lines (460, 540, 620 nm) weighted so that every channel collects `rate_e_per_s`.
fn balanced_irradiance(s: &Sensor, grid: &WavelengthGrid, rate_e_per_s: f64) -> Vec<f64> {
    let irr = s.balanced_emva_irradiance(grid, rate_e_per_s).unwrap();
    let check = s.mean_electrons_uniform(&irr, grid, 1.0).unwrap();
    assert!(check.iter().all(|r| rel(*r, rate_e_per_s) < 1e-9), "{check:?}");
    irr
}

/// The series: a ladder of exposures from 0 to 1.3 x the clipping time (`frames_per_level` frames
/// each up to 0.7, the PTC fit range; 4 frames above), and 128 frames at half of it for DSNU and
/// PRNU. Each call has its own temporal seed; the fixed pattern is the sensor's.
fn series(s: &Sensor, grid: &WavelengthGrid, irr: &[f64], t_clip_s: f64, frames_per_level: usize) -> Vec<EmvaLevel> {
    let fit = [0.0, 0.02, 0.05, 0.1, 0.15, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7];
    let high = [0.8, 0.9, 0.95, 1.0, 1.05, 1.15, 1.3];
    let t = |f: &[f64]| f.iter().map(|f| f * t_clip_s).collect::<Vec<f64>>();
    let mut levels = s.emva_series(grid, irr, &t(&fit), frames_per_level, ROWS, COLS, 11).unwrap();
    levels.extend(s.emva_series(grid, irr, &t(&high), 4, ROWS, COLS, 12).unwrap());
    levels.extend(s.emva_series(grid, irr, &[0.5 * t_clip_s], 128, ROWS, COLS, 13).unwrap());
    levels
}

fn characterize(s: &Sensor, t_clip_s: f64, frames_per_level: usize) -> (Vec<ChannelEmva>, f64) {
    let grid = WavelengthGrid::default();
    let irr = balanced_irradiance(s, &grid, clip_e(s) / t_clip_s);
    let levels = series(s, &grid, &irr, t_clip_s, frames_per_level);
    let inputs: Vec<EmvaRawInput> = levels
        .iter()
        .map(|l| EmvaRawInput {
            exposure_s: l.exposure_s,
            photons_per_pixel: Some(l.photons_per_pixel),
            bright: l.bright.iter().collect(),
            dark: l.dark.iter().collect(),
        })
        .collect();
    let res = emva_raw(&inputs, &EmvaOptions::default()).unwrap();
    // Configured QE for this light: photo-electrons per photon reaching the pixel (pitch^2).
    let qe = clip_e(s) / t_clip_s / s.photons_per_pixel(&irr, &grid, 1.0).unwrap();
    (res, qe)
}

fn check(s: &Sensor, name: &str, t_clip_s: f64, frames_per_level: usize) {
    let (res, qe_true) = characterize(s, t_clip_s, frames_per_level);
    let g = s.analog_gain();
    let cg = s.conversion_gain_v_per_e();
    let k_true = cg * s.dn_per_v() / g;
    assert!(rel(k_true, s.k_dn_per_e()) < 1e-12);
    let read_e_true = s.read_noise_v() / cg;
    let dsnu_dn_true = s.dsnu_v() * s.dn_per_v() / g;
    let dsnu_e_true = s.dsnu_v() / cg;
    let prnu_true = s.prnu_fraction() * 100.0;
    let sat_true = clip_e(s);
    let dark_true = s.dark_voltage_v_per_s() / cg;
    for ChannelEmva { channel, result: r } in &res {
        let pct = |a: f64, b: f64| 100.0 * (a / b - 1.0);
        println!(
            "{name} {}: K {:.5} DN/e- ({:+.2} %, regression s.e. {:.2} %), dark noise {:.3} e- ({:+.2} %), DSNU {:.3} DN ({:+.2} %) {:.3} e- ({:+.2} %), \
             PRNU {:.4} % ({:+.2} %), plateau {:.1} e- ({:+.2} %), EMVA saturation {:.1} e- ({:.3} x clip), QE {:.4} ({:+.2} %), \
             dark current {:.2} e-/s (configured {:.2}), DR {:.1} dB",
            channel.letter(),
            r.system_gain_dn_per_e,
            pct(r.system_gain_dn_per_e, k_true),
            100.0 * r.system_gain_std_err / r.system_gain_dn_per_e,
            r.temporal_dark_noise_e,
            pct(r.temporal_dark_noise_e, read_e_true),
            r.dsnu_dn,
            pct(r.dsnu_dn, dsnu_dn_true),
            r.dsnu_e,
            pct(r.dsnu_e, dsnu_e_true),
            r.prnu_percent,
            pct(r.prnu_percent, prnu_true),
            r.saturation_plateau_e,
            pct(r.saturation_plateau_e, sat_true),
            r.saturation_capacity_e,
            r.saturation_capacity_e / sat_true,
            r.quantum_efficiency.unwrap(),
            pct(r.quantum_efficiency.unwrap(), qe_true),
            r.dark_current_e_per_s.unwrap_or(f64::NAN),
            dark_true,
            r.dynamic_range_db,
        );
        let ch = channel.letter();
        // The sampling error of K (the regression's own standard error) is well below 3 %.
        assert!(r.system_gain_std_err < 0.0075 * r.system_gain_dn_per_e, "{name} {ch}: K s.e. {}", r.system_gain_std_err);
        assert!(rel(r.system_gain_dn_per_e, k_true) < 0.03, "{name} {ch}: K");
        assert!(rel(r.temporal_dark_noise_e, read_e_true) < 0.03, "{name} {ch}: temporal dark noise");
        assert!(rel(r.dsnu_dn, dsnu_dn_true) < 0.03, "{name} {ch}: DSNU (DN)");
        assert!(rel(r.dsnu_e, dsnu_e_true) < 0.03, "{name} {ch}: DSNU (e-)");
        assert!(rel(r.prnu_percent, prnu_true) < 0.03, "{name} {ch}: PRNU");
        assert!(rel(r.saturation_plateau_e, sat_true) < 0.03, "{name} {ch}: saturation (plateau)");
        assert!(rel(r.quantum_efficiency.unwrap(), qe_true) < 0.03, "{name} {ch}: QE");
        let sat_ratio = r.saturation_capacity_e / sat_true;
        assert!((0.85..1.0).contains(&sat_ratio), "{name} {ch}: EMVA saturation point {sat_ratio} x clip");
        assert_eq!(r.nonuniformity_frames, [128, 128], "{name} {ch}: DSNU/PRNU level");
        // The frames carry the configured black level (offset / gain x 2^bits / swing), which the
        // analysis subtracts: the dark mean left is 0 within 5 standard errors of a mean over the
        // channel's pixels (DSNU, and read noise over the 4 dark frames at t = 0).
        let read_dn = s.read_noise_v() * s.dn_per_v() / g;
        let n_min = (ROWS * COLS / 4) as f64;
        let tol = 5.0 * (dsnu_dn_true.powi(2) + read_dn.powi(2) / 4.0).sqrt() / n_min.sqrt();
        assert!(r.dark_offset_dn.abs() < tol, "{name} {ch}: dark mean above black {} DN", r.dark_offset_dn);
        if dark_true > 0.0 {
            assert!(rel(r.dark_current_e_per_s.unwrap(), dark_true) < 0.03, "{name} {ch}: dark current");
        }
    }
    let chans: Vec<CfaChannel> = res.iter().map(|c| c.channel).collect();
    assert_eq!(chans, [CfaChannel::R, CfaChannel::G, CfaChannel::B]);
}

#[test]
fn emva_recovers_the_imx363_preset_with_a_black_level() {
    let s = with_black_level(&Sensor::preset("imx363").unwrap(), 0.0);
    assert_eq!(s.analog_offset_v(), 0.0, "Table 1: analog offset 0");
    // 40 mV of offset: 357 DN of black level, 8 sigma of the dark noise.
    let s = with_black_level(&s, 40e-3 * s.dn_per_v());
    // Read noise dominates the variance of every level in the fit range: 8 pairs per level.
    check(&s, "imx363", 10e-3, 16);
}

#[test]
fn emva_recovers_a_ten_bit_low_noise_sensor() {
    // A clipping time of 100 ms gives 8.7 e- of dark signal at the longest exposure, enough for
    // the dark-current slope (its s.e. is ~0.1 %).
    check(&ten_bit_sensor(), "10-bit", 100e-3, 4);
}

/// A uniform irradiance image (W/(m^2 nm)) covering the sensor exactly (sample spacing = pitch).
fn uniform_image(s: &Sensor, grid: &WavelengthGrid, irr: &[f64]) -> SpectralImage {
    let n = s.rows() * s.cols();
    let data: Vec<f32> = irr.iter().flat_map(|v| (0..n).map(move |_| *v as f32)).collect();
    SpectralImage::from_data(s.rows(), s.cols(), *grid, s.pixel_pitch_m(), Quantity::Irradiance, data).unwrap()
}

#[test]
fn qe_fit_of_pixel4a_frames_against_the_imx363_preset_gives_the_paper_m() {
    let grid = WavelengthGrid::default();
    let side = 64;
    // The measuring camera: the pixel4a preset with every noise source on and a black level (the
    // same 40 mV as above; without it the dark patches' noise would clip at 0 DN and bias their means).
    let p4a = Sensor::preset("pixel4a").unwrap().with_size(side, side).unwrap();
    let p4a = with_black_level(&p4a, 40e-3 * p4a.dn_per_v());
    // The model: the published QE (imx363 preset), noise-free and unrounded.
    let imx = Sensor::preset("imx363")
        .unwrap()
        .with_size(side, side)
        .unwrap()
        .with_noise(NoiseSwitches { quantization: false, ..NoiseSwitches::none() });
    let t_s = 10e-3;
    let patches = tables::macbeth_reflectances();
    let full = Rect::new(0, 0, side, side);
    let (mut measured, mut predicted, mut sigma) = (vec![], vec![], vec![]);
    for (li, light) in ["A", "F2", "D65"].iter().enumerate() {
        let spd = tables::illuminant(light).unwrap().sample(&grid);
        // Scale each light so the white patch's largest pixel4a channel sits at 70 % of the clip.
        let white = patches[18].sample(&grid);
        let unit: Vec<f64> = spd.iter().zip(&white).map(|(e, r)| e * r).collect();
        let e_white = p4a.mean_electrons_uniform(&unit, &grid, t_s).unwrap();
        let scale = 0.7 * clip_e(&p4a) / e_white.iter().cloned().fold(0.0, f64::max);
        for (pi, patch) in patches.iter().enumerate() {
            let refl = patch.sample(&grid);
            let irr: Vec<f64> = spd.iter().zip(&refl).map(|(e, r)| scale * e * r).collect();
            let img = uniform_image(&p4a, &grid, &irr);
            // Its own temporal seed per capture (the same seed would repeat the same normals).
            let seed = (li * 24 + pi) as u64 + 1;
            let frame = p4a.compute(&img, &Capture::seconds(t_s).with_seed(seed)).unwrap();
            let stats = &roi_stats_raw(&frame.raw[0], &[full]).unwrap()[0];
            measured.push(stats.mean_dn);
            // Standard error of each mean: the model's per-pixel noise (temporal and fixed pattern)
            // over the channel's pixels.
            sigma.push([0, 1, 2].map(|c| p4a.predicted_noise_dn(stats.mean_dn[c], t_s).total / (stats.n[c] as f64).sqrt()));
            // Prediction: the noise-free model's unrounded output, per channel.
            let pf = imx.compute(&img, &Capture::seconds(t_s)).unwrap();
            let analog = &pf.analog_dn.as_ref().unwrap()[0];
            let mut sum = [0.0f64; 3];
            let mut count = [0usize; 3];
            for r in 0..side {
                for c in 0..side {
                    let ch = imx.cfa().channel_at(r, c).index();
                    sum[ch] += analog[r * side + c] as f64;
                    count[ch] += 1;
                }
            }
            let p = [0, 1, 2].map(|c| sum[c] / count[c] as f64 - imx.black_level_dn());
            // Independent check of the prediction: mean electrons x K.
            for c in 0..3 {
                let k_e = pf.mean_electrons[c] * imx.k_dn_per_e();
                assert!((p[c] - k_e).abs() <= 1e-5 * k_e + 1e-3, "prediction {} vs {k_e}", p[c]);
            }
            predicted.push(p);
        }
    }
    let fit = fit_qe_matrix(&measured, &predicted, MatrixForm::PaperLowerNonNegative).unwrap();
    // Expected error of each free entry: weighted least squares covariance with the (unweighted)
    // estimator, (A^T A)^-1 A^T diag(sigma^2) A (A^T A)^-1, per output column j.
    let mask = MatrixForm::PaperLowerNonNegative.mask();
    let mut se = [[0.0f64; 3]; 3];
    for j in 0..3 {
        let inputs: Vec<usize> = (0..3).filter(|i| mask[*i][j]).collect();
        let a = DMatrix::from_fn(predicted.len(), inputs.len(), |r, k| predicted[r][inputs[k]]);
        let w = DVector::from_fn(predicted.len(), |r, _| sigma[r][j] * sigma[r][j]);
        let ata_inv = (a.transpose() * &a).try_inverse().unwrap();
        let cov = &ata_inv * (a.transpose() * DMatrix::from_diagonal(&w) * &a) * &ata_inv;
        for (k, i) in inputs.iter().enumerate() {
            se[*i][j] = cov[(k, k)].sqrt();
        }
    }
    println!("fitted M {:?}\npaper  M {PAPER_M:?}\nexpected s.e. {se:?}\nrelative RMS before {:.4}, after {:.5}", fit.m, fit.relative_rms_before, fit.relative_rms_after);
    for i in 0..3 {
        for j in 0..3 {
            assert!(5.0 * se[i][j] < 0.01, "M[{i}][{j}]: expected error {} is not well below 0.01", se[i][j]);
            let err = (fit.m[i][j] - PAPER_M[i][j]).abs();
            assert!(err < 0.01, "M[{i}][{j}] = {} vs the paper's {} (expected error {})", fit.m[i][j], PAPER_M[i][j], se[i][j]);
            assert!(err <= 5.0 * se[i][j], "M[{i}][{j}] = {} is {:.1} standard errors from the paper's {}", fit.m[i][j], err / se[i][j], PAPER_M[i][j]);
            if !mask[i][j] {
                assert_eq!(fit.m[i][j], 0.0);
            }
        }
    }
    // The correction explains the data down to the noise: residual RMS of the order of sigma.
    let rms_sigma = (sigma.iter().flatten().map(|s| s * s).sum::<f64>() / (3 * sigma.len()) as f64).sqrt();
    assert!(fit.rms_after < 2.0 * rms_sigma, "RMS after {} vs noise {rms_sigma}", fit.rms_after);
    assert!(fit.rms_before > 20.0 * fit.rms_after);
}
