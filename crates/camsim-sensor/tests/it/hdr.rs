//! HDR pixels (`[hdr]`, [`Sensor::compute_hdr`]) against closed forms: the merged frame is linear
//! in exposure from the read-noise floor to saturation, each branch's SNR is the shot + read +
//! quantization model S / sqrt(S + sigma^2 + 1/(12 K^2)) (EMVA 1288 rel. 4.0 eq. 9; DCG: the same
//! electrons, split pixel: the SPD's own electrons), the SNR step at the switch level has the
//! predicted size, the dynamic range is 20 log10(full well / noise floor), any thread count gives
//! the same bits, and bad `[hdr]` values are refused naming the key.
//!
//! The sensors are the examples `examples/sensor-dcg.toml` and `examples/sensor-split-pixel.toml`
//! (HCG / LPD: 80 uV/e-, 0.16 mV = 2 e- read noise, 0.5 V swing, 12 bits, black level 64 DN).

use camsim_core::WavelengthGrid;
use camsim_sensor::{Capture, HdrMode, NoiseSwitches, Sensor, SensorConfig};

const ROWS: usize = 128;
const COLS: usize = 256;

fn example(name: &str) -> SensorConfig {
    let path = format!("{}/../../examples/{name}", env!("CARGO_MANIFEST_DIR"));
    Sensor::from_file(&path).unwrap().config().clone()
}

/// The example with a 128 x 256 window and no fixed pattern (the SNR model is temporal).
fn sensor(name: &str, f: impl FnOnce(&mut SensorConfig)) -> Sensor {
    let mut c = example(name);
    c.rows = ROWS;
    c.cols = COLS;
    c.prnu_percent = 0.0;
    c.dsnu_mv = 0.0;
    f(&mut c);
    Sensor::from_config(c).unwrap()
}

/// Mean and standard deviation of the merged frame of a uniform exposure of `signal_e` electrons.
fn merged_stats(s: &Sensor, signal_e: f64, seed: u64) -> (f64, f64) {
    let rate = vec![signal_e as f32; ROWS * COLS];
    let f = s
        .compute_hdr_from_rate(&rate, &Capture::seconds(1.0).with_seed(seed))
        .unwrap();
    let m = &f.merged_e[0];
    let n = m.len() as f64;
    let mean = m.iter().map(|v| *v as f64).sum::<f64>() / n;
    let var = m.iter().map(|v| (*v as f64 - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, var.sqrt())
}

// The examples' closed-form figures, from their TOML values (not from the crate's model).
const K_HIGH: f64 = 80e-6 * 4096.0 / 0.5; // DN/e-: conversion gain x 2^bits / swing
const READ_HIGH_E: f64 = 0.16e-3 / 80e-6; // 2 e-
const HIGH_SAT_E: f64 = (4095.0 - 64.0) / K_HIGH; // ADC range above black, e-
const SWITCH_E: f64 = 0.8 * HIGH_SAT_E;

fn snr(s: f64, read_e: f64, k: f64) -> f64 {
    s / (s + read_e * read_e + 1.0 / (12.0 * k * k)).sqrt()
}

#[test]
fn merged_response_is_linear_from_the_noise_floor_to_saturation() {
    for (name, max_e) in [
        ("sensor-dcg.toml", 40000.0),
        ("sensor-split-pixel.toml", 10000.0 / 0.0625),
    ] {
        let s = sensor(name, |_| {});
        let mut worst: f64 = 0.0;
        // 4 e- (2 x the read noise) to 95 % of the largest merged signal, log-spaced.
        let levels = 24;
        for i in 0..levels {
            let signal_e = 4.0 * (0.95 * max_e / 4.0f64).powf(i as f64 / (levels - 1) as f64);
            let (mean, _) = merged_stats(&s, signal_e, i as u64);
            let err = mean / signal_e - 1.0;
            println!(
                "{name} {signal_e:10.1} e-: merged mean {mean:10.2} ({:+.3} %)",
                err * 100.0
            );
            // 1 %, or 4 standard errors of the mean over the 32768 pixels where that is larger
            // (below ~10 e-, where the noise is sqrt(S + 4 e-^2) per pixel).
            let se = (signal_e + READ_HIGH_E * READ_HIGH_E).sqrt()
                / ((ROWS * COLS) as f64).sqrt()
                / signal_e;
            assert!(
                err.abs() < 0.01f64.max(4.0 * se),
                "{name}: {signal_e:.1} e- gives a merged mean of {mean:.2} ({:.2} %)",
                err * 100.0
            );
            worst = worst.max(err.abs());
        }
        println!(
            "{name}: merged/exposure linear within {:.3} % over 4 e- .. {:.0} e-",
            worst * 100.0,
            0.95 * max_e
        );
    }
}

#[test]
fn dcg_snr_per_branch_and_the_step_at_the_switch() {
    // A noisy LCG (40 e-) makes the step at the switch visible: SNR falls from the HCG's to the LCG's.
    let s = sensor("sensor-dcg.toml", |c| {
        c.hdr.as_mut().unwrap().lcg_read_noise_e = Some(40.0)
    });
    let k_low = 10e-6 * 4096.0 / 0.5;
    let predict = |e: f64| {
        if e < SWITCH_E {
            snr(e, READ_HIGH_E, K_HIGH)
        } else {
            snr(e, 40.0, k_low)
        }
    };
    for (i, frac) in [0.002, 0.01, 0.1, 0.5, 0.9, 1.1, 2.0, 4.0, 7.0]
        .iter()
        .enumerate()
    {
        let e = frac * SWITCH_E;
        let (mean, sd) = merged_stats(&s, e, 100 + i as u64);
        let (got, want) = (mean / sd, predict(e));
        println!("DCG {e:8.0} e-: SNR {got:7.2}, model {want:7.2}");
        // Standard error of a standard deviation over 32768 pixels: 1/sqrt(2n) = 0.4 %.
        assert!(
            (got / want - 1.0).abs() < 0.02,
            "DCG at {e:.0} e-: SNR {got:.3}, model {want:.3}"
        );
    }
    let (m0, s0) = merged_stats(&s, 0.9 * SWITCH_E, 7);
    let (m1, s1) = merged_stats(&s, 1.1 * SWITCH_E, 8);
    let step = (m1 / s1) / (m0 / s0);
    let want = predict(1.1 * SWITCH_E) / predict(0.9 * SWITCH_E);
    println!(
        "DCG SNR step 0.9 -> 1.1 x switch: {step:.4} (model {want:.4}; shot noise alone {:.4})",
        (1.1f64 / 0.9).sqrt()
    );
    assert!((step / want - 1.0).abs() < 0.02);
    assert!(
        step < 1.0,
        "the LCG read noise must lower the SNR above the switch"
    );
}

#[test]
fn split_pixel_snr_per_branch_and_the_dip_at_the_switch() {
    let s = sensor("sensor-split-pixel.toml", |_| {});
    let (ratio, read_spd_e, k_spd) = (0.0625, 3.0, 40e-6 * 4096.0 / 0.5);
    // Above the switch the SNR is the SPD's own: S_spd / sqrt(S_spd + sigma_spd^2 + q^2).
    let predict = |e: f64| {
        if e < SWITCH_E {
            snr(e, READ_HIGH_E, K_HIGH)
        } else {
            snr(e * ratio, read_spd_e, k_spd)
        }
    };
    for (i, frac) in [0.002, 0.05, 0.5, 0.9, 1.1, 3.0, 10.0, 25.0]
        .iter()
        .enumerate()
    {
        let e = frac * SWITCH_E;
        let (mean, sd) = merged_stats(&s, e, 200 + i as u64);
        let (got, want) = (mean / sd, predict(e));
        println!("split {e:8.0} e-: SNR {got:7.2}, model {want:7.2}");
        assert!(
            (got / want - 1.0).abs() < 0.02,
            "split pixel at {e:.0} e-: SNR {got:.3}, model {want:.3}"
        );
    }
    let (m0, s0) = merged_stats(&s, 0.9 * SWITCH_E, 17);
    let (m1, s1) = merged_stats(&s, 1.1 * SWITCH_E, 18);
    let dip_db = 20.0 * ((m0 / s0) / (m1 / s1)).log10();
    let want_db = 20.0 * (predict(0.9 * SWITCH_E) / predict(1.1 * SWITCH_E)).log10();
    println!("split-pixel SNR dip at the switch: {dip_db:.2} dB (model {want_db:.2} dB)");
    assert!(
        (dip_db - want_db).abs() < 0.2,
        "dip {dip_db:.2} dB, model {want_db:.2} dB"
    );
}

#[test]
fn dynamic_range_is_full_well_over_the_noise_floor() {
    let floor_e = (READ_HIGH_E * READ_HIGH_E + 1.0 / (12.0 * K_HIGH * K_HIGH)).sqrt();
    for (name, max_e) in [
        ("sensor-dcg.toml", 40000.0),
        ("sensor-split-pixel.toml", 10000.0 / 0.0625),
    ] {
        let s = sensor(name, |_| {});
        let want_db = 20.0 * (max_e / floor_e).log10();
        let model = s.hdr_model().unwrap();
        assert!((model.dynamic_range_db() - want_db).abs() < 1e-9);
        let (_, noise_e) = merged_stats(&s, 0.0, 1);
        let (top_e, _) = merged_stats(&s, 3.0 * max_e, 2);
        let got_db = 20.0 * (top_e / noise_e).log10();
        println!("{name}: dynamic range {got_db:.2} dB (closed form {want_db:.2} dB; max {top_e:.0} e-, floor {noise_e:.3} e-)");
        assert!(
            (top_e / max_e - 1.0).abs() < 1e-3,
            "{name}: saturated merged mean {top_e}, want {max_e}"
        );
        assert!(
            (got_db - want_db).abs() < 0.1,
            "{name}: {got_db:.3} dB, closed form {want_db:.3} dB"
        );
    }
}

#[test]
fn hdr_frames_are_bit_identical_for_any_thread_count() {
    for name in ["sensor-dcg.toml", "sensor-split-pixel.toml"] {
        let mut c = example(name);
        c.rows = 64;
        c.cols = 96;
        let s = Sensor::from_config(c).unwrap();
        // A ramp from dark to past saturation, with every noise source (PRNU included).
        let rate: Vec<f32> = (0..64 * 96)
            .map(|i| (i as f32 * 37.0) % 200_000.0)
            .collect();
        let run = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| {
                s.compute_hdr_from_rate(&rate, &Capture::seconds(1.0).with_frames(2).with_seed(5))
                    .unwrap()
            })
        };
        let (a, b) = (run(1), run(4));
        assert_eq!(a, b, "{name}");
        assert_ne!(
            a.merged_e[0], a.merged_e[1],
            "{name}: frames must have their own noise"
        );
    }
}

#[test]
fn irradiance_capture_merges_to_the_mean_electrons() {
    // compute_hdr from an irradiance image: the noise-free merged green equals the predicted
    // electrons, well above the HCG range (so through the LCG / SPD branch).
    let grid = WavelengthGrid::default();
    let spec = vec![1e-3; grid.len()];
    for name in ["sensor-dcg.toml", "sensor-split-pixel.toml"] {
        let s = sensor(name, |c| c.noise = NoiseSwitches::none());
        let mut img = camsim_core::SpectralImage::zeros(
            ROWS,
            COLS,
            grid,
            s.pixel_pitch_m(),
            camsim_core::Quantity::Irradiance,
        )
        .unwrap();
        for (b, plane) in img.bands_mut().enumerate() {
            plane.iter_mut().for_each(|v| *v = spec[b] as f32);
        }
        let per_s = s.mean_electrons_uniform(&spec, &grid, 1.0).unwrap();
        let t = 3.0 * HIGH_SAT_E / per_s[1];
        let f = s.compute_hdr(&img, &Capture::seconds(t)).unwrap();
        assert_eq!(f.high[0].cfa, s.cfa());
        let green = f.merged_e[0][1] as f64; // RGGB: (0, 1) is green
        let want = per_s[1] * t;
        let step_e = match s.hdr_model().unwrap().mode {
            HdrMode::Dcg => 1.0 / (10e-6 * 4096.0 / 0.5),
            HdrMode::SplitPixel => 1.0 / (40e-6 * 4096.0 / 0.5) / 0.0625,
        };
        // Noise-free: the only error is the low readout's quantization (half a step).
        assert!(
            (green - want).abs() <= 0.5 * step_e + 1e-3 * want,
            "{name}: {green} e-, want {want}"
        );
    }
}

#[test]
fn bad_hdr_values_are_refused_naming_the_key() {
    let check = |name: &str, f: &dyn Fn(&mut SensorConfig), key: &str| {
        let mut c = example(name);
        f(&mut c);
        let e = Sensor::from_config_named(c, "my.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains(key) && e.contains("my.toml"), "{key}: {e}");
    };
    check(
        "sensor-split-pixel.toml",
        &|c| c.hdr.as_mut().unwrap().sensitivity_ratio = Some(0.0),
        "hdr.sensitivity_ratio",
    );
    check(
        "sensor-split-pixel.toml",
        &|c| c.hdr.as_mut().unwrap().sensitivity_ratio = Some(-0.1),
        "hdr.sensitivity_ratio",
    );
    check(
        "sensor-split-pixel.toml",
        &|c| c.hdr.as_mut().unwrap().sensitivity_ratio = Some(1.5),
        "hdr.sensitivity_ratio",
    );
    check(
        "sensor-dcg.toml",
        &|c| c.hdr.as_mut().unwrap().switch_level = 1.2,
        "hdr.switch_level",
    );
    check(
        "sensor-dcg.toml",
        &|c| c.hdr.as_mut().unwrap().lcg_conversion_gain_uv_per_e = Some(80.0),
        "hdr.lcg_conversion_gain_uv_per_e",
    );
    check(
        "sensor-dcg.toml",
        &|c| c.hdr.as_mut().unwrap().lcg_conversion_gain_uv_per_e = None,
        "hdr.lcg_conversion_gain_uv_per_e",
    );
    check(
        "sensor-dcg.toml",
        &|c| c.hdr.as_mut().unwrap().full_well_e = Some(5000.0),
        "hdr.full_well_e",
    );
    check(
        "sensor-dcg.toml",
        &|c| c.hdr.as_mut().unwrap().sensitivity_ratio = Some(0.1),
        "hdr.sensitivity_ratio",
    );
    check("sensor-dcg.toml", &|c| c.analog_gain = 2.0, "analog_gain");
    // An unknown key in [hdr] is a parse error naming it.
    let path = format!(
        "{}/../../examples/sensor-dcg.toml",
        env!("CARGO_MANIFEST_DIR")
    );
    let text = std::fs::read_to_string(path).unwrap().replace(
        "switch_level = 0.8",
        "switch_level = 0.8\nswitch_levle = 0.5",
    );
    let e = Sensor::from_toml_str(&text, "typo.toml")
        .unwrap_err()
        .to_string();
    assert!(e.contains("switch_levle") && e.contains("typo.toml"), "{e}");
    // A sensor without [hdr] cannot make an HDR capture.
    let plain = Sensor::preset("ideal").unwrap();
    let e = plain
        .compute_hdr_from_rate(&vec![1.0; 64 * 64], &Capture::seconds(1.0))
        .unwrap_err()
        .to_string();
    assert!(e.contains("[hdr]"), "{e}");
}
