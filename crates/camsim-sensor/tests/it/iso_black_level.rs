//! ISO as analog gain, the black-level pedestal and the pixel4a-raw10 preset, checked against the
//! closed form DN = min(round(black + K e), 2^bits - 1), K = cg / gain x 2^bits / swing,
//! gain = base_iso / iso (ISETCam divides by its analog gain, sensorCompute).

use crate::common;
use camsim_core::WavelengthGrid;
use camsim_sensor::{Capture, Sensor, SensorError};
use common::{channel_pixels, config, quiet, uniform_image};

fn flat(grid: &WavelengthGrid) -> Vec<f64> {
    vec![1e-3; grid.len()]
}

/// pixel4a-raw10 as the preset has it: 10-bit, black 64, white 1023, ISO 55 = base ISO = gain 1.
#[test]
fn pixel4a_raw10_preset_has_the_phone_raw_format() {
    let s = Sensor::preset("pixel4a-raw10").unwrap();
    assert_eq!(s.name(), "pixel4a-raw10");
    assert_eq!(s.bits(), 10);
    assert_eq!(s.max_dn(), 1023);
    assert_eq!(s.black_level_dn(), 64.0);
    assert_eq!(s.analog_gain(), 1.0);
    assert_eq!(s.iso(), Some(55.0));
    // Everything else is the paper's pixel4a (Table 1, corrected QE).
    let p = Sensor::preset("pixel4a").unwrap();
    assert_eq!(p.black_level_dn(), 0.0);
    assert_eq!(p.bits(), 12);
    assert_eq!(s.conversion_gain_v_per_e(), p.conversion_gain_v_per_e());
    assert_eq!(s.voltage_swing_v(), p.voltage_swing_v());
    assert_eq!(s.read_noise_v(), p.read_noise_v());
    let grid = WavelengthGrid::default();
    assert_eq!(s.channel_qe(&grid), p.channel_qe(&grid));
    // The listed presets include it, and its TOML round-trips.
    assert!(camsim_sensor::presets::names().contains(&"pixel4a-raw10"));
    let again = Sensor::from_toml_str(&s.to_toml(), "round trip").unwrap();
    assert_eq!(again.black_level_dn(), 64.0);
    assert_eq!(again.analog_gain(), 1.0);
}

/// Noise-free uniform exposure: every pixel's DN = round(64 + K e) with K from the formula, and
/// the raw carries black 64 and white 1023.
#[test]
fn dn_of_a_uniform_exposure_is_black_plus_gain_times_signal() {
    let grid = WavelengthGrid::default();
    let spec = flat(&grid);
    for iso in [55.0, 110.0, 220.0] {
        let s = config("pixel4a-raw10", |c| {
            c.rows = 8;
            c.cols = 8;
            c.iso = Some(iso);
            c.noise = quiet(false);
        });
        let gain = 55.0 / iso;
        assert!((s.analog_gain() - gain).abs() < 1e-15);
        let k = 76.5e-6 / gain * 1024.0 / 0.4591;
        assert!((s.k_dn_per_e() - k).abs() < 1e-12 * k);
        let img = uniform_image(8, 8, grid, s.pixel_pitch_m(), &spec);
        let per_s = s.mean_electrons_uniform(&spec, &grid, 1.0).unwrap();
        for e_target in [0.0, 37.0, 400.0, 1500.0] {
            let t = e_target / per_s[1];
            let f = s.compute(&img, &Capture::seconds(t)).unwrap();
            let raw = &f.raw[0];
            assert_eq!(raw.black_level_dn, 64.0);
            assert_eq!(raw.white_level_dn, 1023.0);
            for c in 0..3 {
                let want = (64.0 + k * per_s[c] * t).round().min(1023.0);
                for i in channel_pixels(raw, c) {
                    assert_eq!(
                        raw.dn[i] as f64,
                        want,
                        "ISO {iso}, channel {c}, {} e-",
                        per_s[c] * t
                    );
                }
            }
        }
    }
}

/// Doubling the ISO doubles the signal above black: exactly in the unrounded ADC value without
/// noise, and within the statistical error of the mean with every noise source on.
#[test]
fn iso_doubling_doubles_the_signal_above_black() {
    let grid = WavelengthGrid::default();
    let spec = flat(&grid);
    let at = |iso: f64, analog: bool| {
        config("pixel4a-raw10", |c| {
            c.rows = 64;
            c.cols = 64;
            c.iso = Some(iso);
            if analog {
                c.noise = quiet(true);
            }
        })
    };
    let base = at(55.0, true);
    let per_s = base.mean_electrons_uniform(&spec, &grid, 1.0).unwrap();
    let t = 1000.0 / per_s[1]; // 1000 green electrons: ~170 DN above black at ISO 55, ~680 at 220
    let img = uniform_image(64, 64, grid, base.pixel_pitch_m(), &spec);
    let analog_mean = |s: &Sensor| {
        let f = s.compute(&img, &Capture::seconds(t)).unwrap();
        let a = &f.analog_dn.as_ref().unwrap()[0];
        let idx = channel_pixels(&f.raw[0], 1);
        idx.iter().map(|i| a[*i] as f64).sum::<f64>() / idx.len() as f64 - 64.0
    };
    let s55 = analog_mean(&base);
    let s110 = analog_mean(&at(110.0, true));
    let s220 = analog_mean(&at(220.0, true));
    assert!(
        (s110 / s55 - 2.0).abs() < 1e-5,
        "ISO 110 / ISO 55 = {}",
        s110 / s55
    );
    assert!(
        (s220 / s55 - 4.0).abs() < 1e-5,
        "ISO 220 / ISO 55 = {}",
        s220 / s55
    );
    // Noisy: mean over 2048 green pixels; sigma of the mean from the predicted noise.
    let noisy_mean = |s: &Sensor| {
        let f = s.compute(&img, &Capture::seconds(t).with_seed(7)).unwrap();
        let idx = channel_pixels(&f.raw[0], 1);
        let m = idx.iter().map(|i| f.raw[0].dn[*i] as f64).sum::<f64>() / idx.len() as f64 - 64.0;
        let sd = s.predicted_noise_dn(m, t).total / (idx.len() as f64).sqrt();
        (m, sd)
    };
    let (m55, sd55) = noisy_mean(&at(55.0, false));
    let (m110, sd110) = noisy_mean(&at(110.0, false));
    let ratio_sd = 2.0 * (sd110 / m110).hypot(sd55 / m55);
    assert!(
        (m110 / m55 - 2.0).abs() < 4.0 * ratio_sd,
        "noisy ratio {} (4 sigma {})",
        m110 / m55,
        4.0 * ratio_sd
    );
    eprintln!(
        "ISO 110/55 signal ratio: exact {:.6}, noisy {:.4} +- {:.4}",
        s110 / s55,
        m110 / m55,
        ratio_sd
    );
}

/// Over-exposure clips at the white level 1023 (not at 1023 + 64), and the largest signal above
/// black is 1023 - 64 = 959 DN.
#[test]
fn clipping_at_the_white_level() {
    let grid = WavelengthGrid::default();
    let spec = flat(&grid);
    let s = config("pixel4a-raw10", |c| {
        c.rows = 8;
        c.cols = 8;
    });
    let img = uniform_image(8, 8, grid, s.pixel_pitch_m(), &spec);
    let per_s = s.mean_electrons_uniform(&spec, &grid, 1.0).unwrap();
    let t = 10.0 * s.well_capacity_e() / per_s.iter().cloned().fold(f64::INFINITY, f64::min);
    let f = s.compute(&img, &Capture::seconds(t)).unwrap();
    assert!(f.raw[0].dn.iter().all(|v| *v == 1023));
    // Noise-free: 64 + K e just below 1023 is not clipped, just above it is.
    let q = s.with_noise(quiet(false));
    let k = q.k_dn_per_e();
    for (dn_above_black, want) in [(950.0, 1014.0), (958.0, 1022.0), (975.0, 1023.0)] {
        let t = dn_above_black / k / per_s[1];
        let f = q.compute(&img, &Capture::seconds(t)).unwrap();
        for i in channel_pixels(&f.raw[0], 1) {
            assert_eq!(
                f.raw[0].dn[i] as f64, want,
                "{dn_above_black} DN above black"
            );
        }
    }
}

/// With a pedestal, dark frames keep their read noise below black: mean = black (unbiased), and
/// the spread is the predicted read + DSNU + quantization noise (no clipping at 0 DN).
#[test]
fn dark_frame_noise_is_not_clipped_below_black() {
    let s = config("pixel4a-raw10", |c| {
        c.rows = 64;
        c.cols = 64;
    });
    let grid = WavelengthGrid::default();
    let img = uniform_image(64, 64, grid, s.pixel_pitch_m(), &vec![0.0; grid.len()]);
    let f = s
        .compute(&img, &Capture::seconds(0.01).with_seed(3))
        .unwrap();
    let n = f.raw[0].dn.len() as f64;
    let mean = f.raw[0].dn.iter().map(|v| *v as f64).sum::<f64>() / n;
    let var = f.raw[0]
        .dn
        .iter()
        .map(|v| (*v as f64 - mean).powi(2))
        .sum::<f64>()
        / (n - 1.0);
    let want_sd = s.predicted_noise_dn(0.0, 0.01).total; // sqrt(11.15^2 + 1.43^2 + 1/12) DN
    assert!((want_sd - 11.25).abs() < 0.05, "predicted {want_sd}");
    assert!(
        (mean - 64.0).abs() < 4.0 * want_sd / n.sqrt(),
        "dark mean {mean}"
    );
    // Standard error of a variance estimate: sigma^2 sqrt(2 / (n - 1)).
    assert!(
        (var - want_sd * want_sd).abs() < 4.0 * want_sd * want_sd * (2.0 / (n - 1.0)).sqrt(),
        "dark sd {}",
        var.sqrt()
    );
    eprintln!(
        "dark frame: mean {mean:.3} DN (black 64), sd {:.3} DN (predicted {want_sd:.3})",
        var.sqrt()
    );
}

/// Bad ISO and black-level keys are typed errors naming the key.
#[test]
fn bad_iso_and_black_level_are_refused() {
    let text = camsim_sensor::presets::toml("pixel4a-raw10").unwrap();
    let cases = [
        (
            text.replace("base_iso = 55.0", "base_iso = 0.0"),
            "base_iso",
        ),
        (
            text.replace(
                "iso = 55.0                         # base",
                "iso = -100.0 # base",
            ),
            "iso",
        ),
        (text.replace("base_iso = 55.0", ""), "needs base_iso"),
        (
            text.replace(
                "iso = 55.0                         # base",
                "iso = 100.0\nanalog_gain = 2.0 # base",
            ),
            "either iso or analog_gain",
        ),
        (
            text.replace("black_level_dn = 64.0", "black_level_dn = 1023.0"),
            "black_level_dn",
        ),
        (
            text.replace("black_level_dn = 64.0", "black_level_dn = -1.0"),
            "black_level_dn",
        ),
    ];
    for (t, want) in cases {
        match Sensor::from_toml_str(&t, "test") {
            Err(e @ SensorError::Config { .. }) => {
                assert!(e.to_string().contains(want), "{e} lacks {want}")
            }
            other => panic!("expected a config error naming {want}, got {other:?}"),
        }
    }
}
