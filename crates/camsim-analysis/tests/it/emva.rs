//! EMVA 1288 on frame series from a simple, independent sensor simulator with known parameters:
//! electrons = Poisson(eta mu_p (1 + PRNU_i) + I_dark t), clipped at the full well; plus a fixed
//! offset DSNU_i and Gaussian read noise (electrons); DN = round(K e + black), clipped to the ADC.
//! The standard's estimates must recover K, read noise, DSNU, PRNU, QE, saturation and dark
//! current within 3 % (sampling error: 128 x 128 pixels, 4 frame pairs per level give variances
//! to 0.55 %, K to about 0.5 %; 100-frame stacks give DSNU and PRNU to about 1 %).
//!
//! Saturation: EMVA 1288 defines it at the level of maximum temporal variance. The output clips at
//! the full well *after* read noise (as ISETCam clips at the voltage swing), so the variance starts
//! to fall when the upper tail of the pixels' distribution (temporal noise sigma_tot and PRNU)
//! reaches the clip: the EMVA point lies between W - 4 sigma_tot and W (for the IMX363,
//! sigma_tot ~ 100 e- at 6000 e-, i.e. 5-6 % below). The test checks that bracket, and that the
//! plateau (largest mean signal / K) recovers the configured well within 3 %.

use camsim_analysis::emva::{emva, emva_raw, EmvaInput, EmvaOptions, EmvaRawInput};
use camsim_analysis::Plane;
use camsim_core::rng::{keyed, stage};
use camsim_core::{CfaPattern, RawImage};
use rand_distr::{Distribution, Normal, Poisson};

/// (exposure, photons, bright frames, dark frames) of one level.
type Level = (f64, f64, Vec<Vec<f64>>, Vec<Vec<f64>>);

#[derive(Clone, Copy)]
struct Synth {
    rows: usize,
    cols: usize,
    k_dn_per_e: f64,
    qe: f64,
    read_e: f64,
    dsnu_e: f64,
    prnu: f64,
    well_e: f64,
    dark_current_e_per_s: f64,
    black_dn: f64,
    max_dn: f64,
    seed: u64,
}

impl Synth {
    /// Fixed-pattern maps (DSNU offsets in e-, PRNU gains), keyed per row.
    fn maps(&self) -> (Vec<f64>, Vec<f64>) {
        let n = self.rows * self.cols;
        let (mut dsnu, mut prnu) = (Vec::with_capacity(n), Vec::with_capacity(n));
        for r in 0..self.rows {
            let mut rng = keyed(self.seed, stage::SENSOR_FIXED_PATTERN, 0, r as u64);
            let nd = Normal::new(0.0, self.dsnu_e).unwrap();
            let np = Normal::new(0.0, self.prnu).unwrap();
            for _ in 0..self.cols {
                dsnu.push(nd.sample(&mut rng));
                prnu.push(np.sample(&mut rng));
            }
        }
        (dsnu, prnu)
    }

    /// One frame: `photons` mean photons per pixel in `t_s` seconds; `frame` keys the noise.
    fn frame(&self, maps: &(Vec<f64>, Vec<f64>), photons: f64, t_s: f64, frame: u64) -> Vec<f64> {
        let mut out = Vec::with_capacity(self.rows * self.cols);
        let read = Normal::new(0.0, self.read_e).unwrap();
        for r in 0..self.rows {
            let mut rng = keyed(self.seed, stage::SENSOR_TEMPORAL, frame, r as u64);
            for c in 0..self.cols {
                let i = r * self.cols + c;
                let lambda =
                    self.qe * photons * (1.0 + maps.1[i]) + self.dark_current_e_per_s * t_s;
                let e = if lambda > 0.0 {
                    Poisson::new(lambda).unwrap().sample(&mut rng)
                } else {
                    0.0
                };
                let v = e.min(self.well_e) + maps.0[i] + read.sample(&mut rng);
                out.push(
                    (self.k_dn_per_e * v + self.black_dn)
                        .round()
                        .clamp(0.0, self.max_dn),
                );
            }
        }
        out
    }

    /// Levels at fractions of the full well: (exposure, photons, bright frames, dark frames).
    fn series(&self, stack: usize) -> Vec<Level> {
        let maps = self.maps();
        let fractions = [
            0.01, 0.03, 0.06, 0.1, 0.15, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.85, 0.9, 0.94, 0.97,
            0.98, 0.99, 1.0, 1.02, 1.05, 1.1, 1.2,
        ];
        let mut id = 0u64;
        let mut next = || {
            id += 1;
            id
        };
        fractions
            .iter()
            .map(|f| {
                let photons = f * self.well_e / self.qe;
                let t = f * 0.1; // fixed irradiance, exposure time grows with the level
                let n = if (*f - 0.5).abs() < 1e-9 { stack } else { 8 };
                let bright = (0..n)
                    .map(|_| self.frame(&maps, photons, t, next()))
                    .collect();
                let dark = (0..n).map(|_| self.frame(&maps, 0.0, t, next())).collect();
                (t, photons, bright, dark)
            })
            .collect()
    }
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

fn check(s: &Synth, name: &str) {
    check_opt(s, name, true)
}

fn check_opt(s: &Synth, name: &str, strict: bool) {
    let series = s.series(100);
    let planes: Vec<(Vec<Plane>, Vec<Plane>)> = series
        .iter()
        .map(|(_, _, b, d)| {
            let p = |v: &Vec<f64>| {
                Plane::new(s.rows, s.cols, v.iter().map(|x| *x as f32).collect()).unwrap()
            };
            (b.iter().map(p).collect(), d.iter().map(p).collect())
        })
        .collect();
    let inputs: Vec<EmvaInput> = series
        .iter()
        .zip(&planes)
        .map(|((t, ph, _, _), (b, d))| EmvaInput {
            exposure_s: *t,
            photons_per_pixel: Some(*ph),
            exposure_lux_s: None,
            bright: b.iter().collect(),
            dark: d.iter().collect(),
        })
        .collect();
    let r = emva(&inputs, &EmvaOptions::default()).unwrap();
    let json = serde_json::to_string(&r).unwrap();
    assert!(json.contains("system_gain_dn_per_e"));
    let sat_true = s.well_e.min((s.max_dn - s.black_dn) / s.k_dn_per_e);
    let dark_e = s.dark_current_e_per_s;
    println!(
        "{name}: K {:.4} (true {:.4}, {:+.2} %), sigma_d {:.3} e (true {:.3}, {:+.2} %), DSNU {:.3} e (true {:.3}, {:+.2} %), PRNU {:.3} % (true {:.3}, {:+.2} %), QE {:.4} (true {:.4}, {:+.2} %), sat {:.0} e (true {:.0}, {:+.2} %), plateau {:.0} e ({:+.2} %), dark current {:.2} e/s (true {dark_e}), DR {:.1} dB, stack level {}",
        r.system_gain_dn_per_e, s.k_dn_per_e, 100.0 * (r.system_gain_dn_per_e / s.k_dn_per_e - 1.0),
        r.temporal_dark_noise_e, s.read_e, 100.0 * (r.temporal_dark_noise_e / s.read_e - 1.0),
        r.dsnu_e, s.dsnu_e, 100.0 * (r.dsnu_e / s.dsnu_e - 1.0),
        r.prnu_percent, 100.0 * s.prnu, 100.0 * (r.prnu_percent / (100.0 * s.prnu) - 1.0),
        r.quantum_efficiency.unwrap(), s.qe, 100.0 * (r.quantum_efficiency.unwrap() / s.qe - 1.0),
        r.saturation_capacity_e, sat_true, 100.0 * (r.saturation_capacity_e / sat_true - 1.0),
        r.saturation_plateau_e, 100.0 * (r.saturation_plateau_e / sat_true - 1.0),
        r.dark_current_e_per_s.unwrap(), r.dynamic_range_db, r.nonuniformity_level
    );
    if !strict {
        return;
    }
    assert!(
        rel(r.system_gain_dn_per_e, s.k_dn_per_e) < 0.03,
        "{name}: K"
    );
    assert!(
        rel(r.temporal_dark_noise_e, s.read_e) < 0.03,
        "{name}: read noise"
    );
    assert!(rel(r.dsnu_e, s.dsnu_e) < 0.03, "{name}: DSNU");
    assert!(rel(r.prnu_percent, 100.0 * s.prnu) < 0.03, "{name}: PRNU");
    assert!(
        rel(r.quantum_efficiency.unwrap(), s.qe) < 0.03,
        "{name}: QE"
    );
    let sigma_tot =
        (s.read_e.powi(2) + s.dsnu_e.powi(2) + sat_true + (s.prnu * sat_true).powi(2)).sqrt();
    assert!(
        r.saturation_capacity_e < sat_true && r.saturation_capacity_e > sat_true - 4.0 * sigma_tot,
        "{name}: EMVA saturation point"
    );
    assert!(
        rel(r.saturation_plateau_e, sat_true) < 0.03,
        "{name}: saturation plateau"
    );
    if dark_e > 0.0 {
        assert!(
            rel(r.dark_current_e_per_s.unwrap(), dark_e) < 0.05,
            "{name}: dark current"
        );
    }
    assert_eq!(r.nonuniformity_frames, [100, 100]);
    // Threshold and dynamic range follow from the recovered values (EMVA definitions).
    let thr =
        0.5 + (r.temporal_dark_noise_dn.powi(2) / r.system_gain_dn_per_e.powi(2) + 0.25).sqrt();
    assert!((r.threshold_e - thr).abs() < 1e-9);
    assert!((r.dynamic_range - r.saturation_capacity_e / thr).abs() < 1e-6 * r.dynamic_range);
    // ISO 15739's threshold from the synthetic sensor's own parameters: total SNR 1, the root of
    // mu^2 = read^2 + DSNU^2 + mu + PRNU^2 mu^2 (the read noise plus the 1/12 DN^2 of quantization
    // the dark frames hold).
    let fixed2 = s.read_e.powi(2) + 1.0 / (12.0 * s.k_dn_per_e.powi(2)) + s.dsnu_e.powi(2);
    let q = 1.0 - s.prnu * s.prnu;
    let iso_thr = (1.0 + (1.0 + 4.0 * q * fixed2).sqrt()) / (2.0 * q);
    let want = r.saturation_capacity_e / iso_thr;
    eprintln!(
        "{name}: ISO 15739 DR {:.1} (from the truth {want:.1}), EMVA DR {:.1}",
        r.iso_15739_dynamic_range, r.dynamic_range
    );
    assert!(
        rel(r.iso_15739_dynamic_range, want) < 0.03,
        "{name}: ISO 15739 dynamic range {} vs {want}",
        r.iso_15739_dynamic_range
    );
    assert!(r.iso_15739_dynamic_range < r.dynamic_range);
    assert!((r.iso_15739_dynamic_range_db - 20.0 * r.iso_15739_dynamic_range.log10()).abs() < 1e-9);
}

#[test]
fn imx363_like_sensor_parameters_are_recovered() {
    // Paper Table 1 in electrons: conversion gain 7.65e-5 V/e-, swing 0.4591 V (6000 e-), read
    // noise 5 mV = 65.4 e-, DSNU 0.64 mV = 8.37 e-, PRNU 0.7 %; a 12-bit ADC with a 256 DN black
    // level spanning the full well.
    // 256 x 128 pixels: with 65 e- read noise the PTC needs more pixels for K to 1 %.
    let s = Synth {
        rows: 256,
        cols: 128,
        k_dn_per_e: (4095.0 - 256.0) / 6001.3,
        qe: 0.6,
        read_e: 5e-3 / 7.65e-5,
        dsnu_e: 0.64e-3 / 7.65e-5,
        prnu: 0.007,
        well_e: 6001.3,
        dark_current_e_per_s: 0.0,
        black_dn: 256.0,
        max_dn: 4095.0,
        seed: 11,
    };
    check(&s, "imx363-like");
}

#[test]
fn low_noise_sensor_with_dark_current_is_recovered() {
    let s = Synth {
        rows: 128,
        cols: 128,
        k_dn_per_e: 0.19,
        qe: 0.45,
        read_e: 4.0,
        dsnu_e: 3.0,
        prnu: 0.01,
        well_e: 20000.0,
        dark_current_e_per_s: 200.0,
        black_dn: 128.0,
        max_dn: 4095.0,
        seed: 12,
    };
    check(&s, "low-noise");
}

#[test]
fn raw_series_are_characterized_per_cfa_channel() {
    // Same synthetic model on a Bayer mosaic, with a different QE per channel: each channel's
    // QE is recovered, K is common.
    let s = Synth {
        rows: 128,
        cols: 128,
        k_dn_per_e: 0.5,
        qe: 1.0,
        read_e: 6.0,
        dsnu_e: 2.0,
        prnu: 0.01,
        well_e: 8000.0,
        dark_current_e_per_s: 0.0,
        black_dn: 64.0,
        max_dn: 4095.0,
        seed: 13,
    };
    let qe = [0.3, 0.6, 0.45];
    let cfa = CfaPattern::Rggb;
    // Photons chosen so that green spans its full well; per-channel QE scales the mean.
    let maps = s.maps();
    // Green saturates near 1.0, blue near 1.33, red near 2.0: dense levels below each.
    let fractions = [
        0.02, 0.05, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 0.95, 0.97, 0.98, 0.99, 1.0, 1.03,
        1.1, 1.2, 1.27, 1.29, 1.31, 1.33, 1.36, 1.5, 1.7, 1.85, 1.92, 1.95, 1.97, 1.99, 2.05, 2.2,
        2.6,
    ];
    let mut frames: Vec<(f64, Vec<RawImage>, Vec<RawImage>)> = vec![];
    let mut id = 0;
    for f in fractions {
        let photons = f * s.well_e / qe[1];
        let mut make = |light: bool| {
            id += 1;
            let mut raw = RawImage::new(s.rows, s.cols, cfa, 12).unwrap();
            raw.black_level_dn = s.black_dn;
            // Per channel: a frame from the scalar model with that channel's QE, sampled at its pixels.
            for (ch, q) in qe.iter().enumerate() {
                let sc = Synth { qe: *q, ..s };
                let v = sc.frame(
                    &maps,
                    if light { photons } else { 0.0 },
                    0.01,
                    id * 4 + ch as u64,
                );
                for r in 0..s.rows {
                    for c in 0..s.cols {
                        if cfa.channel_at(r, c).index() == ch {
                            raw.dn[r * s.cols + c] = v[r * s.cols + c] as u16;
                        }
                    }
                }
            }
            raw
        };
        let n = if (f - 0.4).abs() < 1e-9 { 16 } else { 8 };
        let b: Vec<RawImage> = (0..n).map(|_| make(true)).collect();
        let d: Vec<RawImage> = (0..n).map(|_| make(false)).collect();
        frames.push((photons, b, d));
    }
    let inputs: Vec<EmvaRawInput> = frames
        .iter()
        .map(|(p, b, d)| EmvaRawInput {
            exposure_s: 0.01,
            photons_per_pixel: Some(*p),
            exposure_lux_s: None,
            bright: b.iter().collect(),
            dark: d.iter().collect(),
        })
        .collect();
    let res = emva_raw(&inputs, &EmvaOptions::default()).unwrap();
    for c in &res {
        let i = c.channel.index();
        let r = &c.result;
        println!(
            "raw channel {}: K {:.4}, QE {:.4} (true {}), sat {:.0} e, plateau {:.0} e",
            c.channel.letter(),
            r.system_gain_dn_per_e,
            r.quantum_efficiency.unwrap(),
            qe[i],
            r.saturation_capacity_e,
            r.saturation_plateau_e
        );
        assert!(rel(r.system_gain_dn_per_e, s.k_dn_per_e) < 0.03);
        assert!(rel(r.quantum_efficiency.unwrap(), qe[i]) < 0.03);
        let sigma_tot =
            (s.read_e.powi(2) + s.dsnu_e.powi(2) + s.well_e + (s.prnu * s.well_e).powi(2)).sqrt();
        assert!(
            r.saturation_capacity_e < s.well_e
                && r.saturation_capacity_e > s.well_e - 4.0 * sigma_tot
        );
        assert!(rel(r.saturation_plateau_e, s.well_e) < 0.03);
    }
}
