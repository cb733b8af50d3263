//! Saturation, quantization, analog gain and offset, auto-exposure and determinism, checked against
//! the formulas of ISETCam's sensorCompute: v_out = clip((v + offset) / gain, 0, swing),
//! DN = min(round(v_out / (swing / 2^bits)), 2^bits - 1).

use crate::common;
use camsim_core::WavelengthGrid;
use camsim_sensor::{Capture, Exposure, Sensor};
use common::{channel_pixels, config, quiet, uniform_image};

fn flat(grid: &WavelengthGrid) -> Vec<f64> {
    vec![1e-3; grid.len()]
}

/// The DN the formulas give for `e` electrons (noise-free).
fn formula_dn(s: &Sensor, e: f64) -> f64 {
    let v = e * s.conversion_gain_v_per_e();
    let v_out = ((v + s.analog_offset_v()) / s.analog_gain()).clamp(0.0, s.voltage_swing_v());
    let step = s.voltage_swing_v() / 2f64.powi(s.bits() as i32);
    (v_out / step).round().min(2f64.powi(s.bits() as i32) - 1.0)
}

#[test]
fn saturation_at_the_swing_gives_the_largest_dn() {
    let s = config("imx363", |c| {
        c.rows = 16;
        c.cols = 16;
    });
    let grid = WavelengthGrid::default();
    let img = uniform_image(16, 16, grid, s.pixel_pitch_m(), &flat(&grid));
    // 100 x the well capacity in every channel: every pixel clips at the swing -> 4095.
    let per_s = s.mean_electrons_uniform(&flat(&grid), &grid, 1.0).unwrap();
    let t = 100.0 * s.well_capacity_e() / per_s.iter().cloned().fold(f64::INFINITY, f64::min);
    let f = s.compute(&img, &Capture::seconds(t)).unwrap();
    assert!(f.raw[0].dn.iter().all(|v| *v == 4095), "not all saturated");
    assert_eq!(f.raw[0].white_level_dn, 4095.0);
    // Just below the swing (noise-free), DN follows the ramp; at the swing it is 4095, not 4096.
    let q = s.with_noise(quiet(false));
    let e_at_swing = s.well_capacity_e();
    assert_eq!(formula_dn(&q, e_at_swing), 4095.0);
    let t = 0.5 * e_at_swing / per_s[1];
    let f = q.compute(&img, &Capture::seconds(t)).unwrap();
    for i in channel_pixels(&f.raw[0], 1) {
        assert_eq!(f.raw[0].dn[i] as f64, formula_dn(&q, per_s[1] * t));
    }
}

/// A noise-free exposure ramp through an 8-bit sensor: every DN equals round(v / (swing / 256))
/// for the analytic electrons, and consecutive levels step by the quantization step.
#[test]
fn quantization_step_is_swing_over_two_to_the_bits() {
    let s = config("ideal", |c| {
        c.rows = 4;
        c.cols = 4;
        c.bits = 8;
        c.voltage_swing_v = 1.0;
        c.conversion_gain_uv_per_e = 100.0; // 10 000 e- well, 39.06 e- per DN
        c.noise = quiet(false);
    });
    assert_eq!(s.dn_per_v(), 256.0);
    let grid = WavelengthGrid::default();
    let spec = flat(&grid);
    let img = uniform_image(4, 4, grid, s.pixel_pitch_m(), &spec);
    let per_s = s.mean_electrons_uniform(&spec, &grid, 1.0).unwrap()[0];
    let mut seen = std::collections::BTreeSet::new();
    for k in 0..830 {
        // Electrons from 0 to ~1.2 x well in steps of 0.37 DN.
        let e = k as f64 * 0.37 / s.k_dn_per_e();
        let f = s.compute(&img, &Capture::seconds(e / per_s)).unwrap();
        let want = formula_dn(&s, e);
        let x = e * s.k_dn_per_e();
        if (x.fract() - 0.5).abs() < 1e-4 {
            continue; // exactly half a step: either rounding is right within f32
        }
        assert!(
            f.raw[0].dn.iter().all(|v| *v as f64 == want),
            "{e} e-: {:?} vs {want}",
            &f.raw[0].dn[..4]
        );
        seen.insert(f.raw[0].dn[0]);
    }
    // Every level 0..=255 is reached (the step is one DN per swing / 256 volts).
    assert_eq!(seen.len(), 256);
    assert_eq!(*seen.iter().next_back().unwrap(), 255);
}

/// Analog gain 2 and offset 50 mV: DN = round((e cg + 0.05) / 2 x 2^bits / swing); black level
/// = offset / gain in DN; a negative offset clips dark pixels to 0.
#[test]
fn analog_gain_and_offset_follow_the_formula() {
    let grid = WavelengthGrid::default();
    let spec = flat(&grid);
    for (gain, offset_mv) in [(2.0, 50.0), (0.5, 10.0), (1.0, -20.0)] {
        let s = config("imx363", |c| {
            c.rows = 4;
            c.cols = 4;
            c.analog_gain = gain;
            c.analog_offset_mv = offset_mv;
            c.noise = quiet(true);
        });
        assert!((s.black_level_dn() - offset_mv * 1e-3 / gain * s.dn_per_v()).abs() < 1e-9);
        assert!((s.k_dn_per_e() - 7.65e-5 / gain * 4096.0 / 0.4591).abs() < 1e-12);
        let img = uniform_image(4, 4, grid, s.pixel_pitch_m(), &spec);
        let per_s = s.mean_electrons_uniform(&spec, &grid, 1.0).unwrap();
        for e_target in [0.0, 100.0, 1000.0, 2500.0] {
            let t = e_target / per_s[1];
            let f = s.compute(&img, &Capture::seconds(t)).unwrap();
            assert!((f.raw[0].black_level_dn - s.black_level_dn()).abs() < 1e-12);
            let analog = &f.analog_dn.as_ref().unwrap()[0];
            for c in 0..3 {
                let e = per_s[c] * t;
                for i in channel_pixels(&f.raw[0], c) {
                    let want = formula_dn(&s, e);
                    assert_eq!(
                        f.raw[0].dn[i] as f64, want,
                        "gain {gain}, offset {offset_mv} mV, {e} e-"
                    );
                    let v_out = ((e * 7.65e-5 + offset_mv * 1e-3) / gain).clamp(0.0, 0.4591);
                    assert!((analog[i] as f64 - v_out * 4096.0 / 0.4591).abs() < 1e-3);
                }
            }
        }
        if offset_mv < 0.0 {
            let f = s.compute(&img, &Capture::seconds(0.0)).unwrap();
            assert!(f.raw[0].dn.iter().all(|v| *v == 0));
        }
    }
}

/// Auto-exposure: the brightest filter's 99th percentile of the noise-free signal reaches the target fraction of the
/// swing. For a uniform field that is the brightest channel.
#[test]
fn auto_exposure_reaches_the_target() {
    let s = config("imx363", |c| {
        c.rows = 32;
        c.cols = 32;
        c.noise = quiet(true);
        c.analog_offset_mv = 10.0;
    });
    let grid = WavelengthGrid::default();
    let spec = flat(&grid);
    let img = uniform_image(32, 32, grid, s.pixel_pitch_m(), &spec);
    for target in [0.5, 0.9] {
        let f = s
            .compute(
                &img,
                &Capture {
                    exposure: Exposure::Auto {
                        target_fraction: target,
                    },
                    frames: 1,
                    seed: 0,
                    global_reset: None,
                    light: None,
                },
            )
            .unwrap();
        let analog = &f.analog_dn.as_ref().unwrap()[0];
        let brightest = analog.iter().cloned().fold(0.0f32, f32::max) as f64;
        let want = target * s.voltage_swing_v() * s.dn_per_v();
        assert!(
            (brightest / want - 1.0).abs() < 1e-4,
            "{brightest} vs {want}"
        );
    }
    // No light: an error that says so, not a panic or an infinite time.
    let dark = uniform_image(32, 32, grid, s.pixel_pitch_m(), &vec![0.0; grid.len()]);
    let err = s.compute(&dark, &Capture::auto()).unwrap_err().to_string();
    assert!(err.contains("auto exposure"), "{err}");
}

/// Auto-exposure takes the 99th percentile per colour filter, so a small white patch of a reddish
/// scene is not clipped: a 6 x 6 patch on a 40 x 40 frame (2.25 % of the pixels, but only 0.56 %
/// of the mosaic are its red pixels, below the 1 % a mosaic-wide percentile lets clip) reaches
/// exactly the target, and no pixel saturates.
#[test]
fn auto_exposure_does_not_clip_a_small_patch_of_the_brightest_filter() {
    let s = config("imx363", |c| {
        c.rows = 40;
        c.cols = 40;
        c.noise = quiet(true);
    });
    let grid = WavelengthGrid::default();
    // Deep red light (nothing below 600 nm): the red filter is by far the brightest.
    let red: Vec<f64> = grid
        .wavelengths_nm()
        .iter()
        .map(|w| if *w >= 600.0 { 1e-3 } else { 0.0 })
        .collect();
    let mut img = uniform_image(40, 40, grid, s.pixel_pitch_m(), &red);
    for plane in img.bands_mut() {
        for (i, v) in plane.iter_mut().enumerate() {
            let (r, c) = (i / 40, i % 40);
            if !((10..16).contains(&r) && (20..26).contains(&c)) {
                *v *= 0.2;
            }
        }
    }
    let target = 0.9;
    let f = s
        .compute(
            &img,
            &Capture {
                exposure: Exposure::Auto {
                    target_fraction: target,
                },
                frames: 1,
                seed: 0,
                global_reset: None,
                light: None,
            },
        )
        .unwrap();
    let analog = &f.analog_dn.as_ref().unwrap()[0];
    let brightest = analog.iter().cloned().fold(0.0f32, f32::max) as f64;
    let want = target * s.voltage_swing_v() * s.dn_per_v();
    assert!(
        (brightest / want - 1.0).abs() < 1e-4,
        "brightest pixel {brightest} DN, target {want} DN"
    );
    assert!(
        f.raw[0]
            .dn
            .iter()
            .all(|v| (*v as f64) < f.raw[0].white_level_dn),
        "a pixel clipped"
    );
}

/// Three frames of a horizontal sawtooth (0 to ~5000 e- over every 64 columns: both the exact-Poisson
/// and the normal shot-noise regimes) computed on `threads` threads.
fn noisy_frames(s: &Sensor, seed: u64, threads: usize) -> Vec<Vec<u16>> {
    let grid = WavelengthGrid::default();
    let mut img = uniform_image(s.rows(), s.cols(), grid, s.pixel_pitch_m(), &flat(&grid));
    let cols = s.cols();
    for plane in img.bands_mut() {
        for (i, v) in plane.iter_mut().enumerate() {
            *v *= ((i % cols) % 64) as f32 / 64.0;
        }
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    let t = 5000.0 / s.mean_electrons_uniform(&flat(&grid), &grid, 1.0).unwrap()[1];
    let f = pool.install(|| {
        s.compute(&img, &Capture::seconds(t).with_frames(3).with_seed(seed))
            .unwrap()
    });
    f.raw.into_iter().map(|r| r.dn).collect()
}

#[test]
fn same_seed_is_bit_identical_for_any_thread_count() {
    let s = config("imx363", |c| {
        c.rows = 96;
        c.cols = 80;
        c.analog_offset_mv = 30.0;
        c.dark_voltage_mv_per_s = 100.0;
    });
    let one = noisy_frames(&s, 42, 1);
    let two = noisy_frames(&s, 42, 2);
    let three = noisy_frames(&s, 42, 3);
    assert_eq!(one, two);
    assert_eq!(one, three);
    // Frames of one capture differ from each other (new temporal noise per frame).
    assert_ne!(one[0], one[1]);
    // Another seed: different noise.
    let other = noisy_frames(&s, 43, 2);
    assert_ne!(one, other);
}

/// Temporal noise off, fixed pattern on: the frame is the fixed pattern alone, identical for any
/// capture seed (same sensor), different for another fixed_pattern_seed, and its spread is the DSNU.
#[test]
fn fixed_pattern_belongs_to_the_sensor() {
    let mk = |fp_seed: u64| {
        config("imx363", |c| {
            c.rows = 128;
            c.cols = 128;
            c.analog_offset_mv = 30.0;
            c.fixed_pattern_seed = fp_seed;
            c.noise.shot = false;
            c.noise.read = false;
        })
    };
    let s = mk(363);
    let a = noisy_frames(&s, 1, 2);
    let b = noisy_frames(&s, 2, 1);
    assert_eq!(
        a, b,
        "the fixed pattern must not depend on the capture seed"
    );
    assert_eq!(a[0], a[2]);
    let c = noisy_frames(&mk(364), 1, 2);
    assert_ne!(a[0], c[0]);
    // A window of the same sensor has the same pattern in the top-left corner.
    let small = noisy_frames(&s.with_size(16, 20).unwrap(), 9, 2);
    for r in 0..16 {
        assert_eq!(
            &small[0][r * 20..(r + 1) * 20],
            &a[0][r * 128..r * 128 + 20]
        );
    }
    // With shot and read noise on, frames of different seeds differ but their mean over many
    // frames converges to the same pattern: checked in noise.rs (DSNU/PRNU recovery).
}

#[test]
fn bad_capture_input_is_an_error() {
    let s = Sensor::preset("ideal").unwrap();
    let grid = WavelengthGrid::default();
    let img = uniform_image(8, 8, grid, 1.4e-6, &flat(&grid));
    let cases: Vec<(Capture, &str)> = vec![
        (Capture::seconds(-1.0), "exposure_s"),
        (Capture::seconds(f64::NAN), "exposure_s"),
        (Capture::seconds(1.0).with_frames(0), "frames"),
        (
            Capture {
                exposure: Exposure::Auto {
                    target_fraction: 1.5,
                },
                frames: 1,
                seed: 0,
                global_reset: None,
                light: None,
            },
            "target_fraction",
        ),
    ];
    for (cap, key) in cases {
        let err = s.compute(&img, &cap).unwrap_err().to_string();
        assert!(err.contains(key), "{err}");
    }
    let mut radiance = img.clone();
    radiance.quantity = camsim_core::Quantity::Radiance;
    let err = s
        .compute(&radiance, &Capture::seconds(1.0))
        .unwrap_err()
        .to_string();
    assert!(err.contains("irradiance"), "{err}");
    let err = s
        .emva_series(&grid, &flat(&grid), &[1e-3], 1, 8, 8, 0)
        .unwrap_err()
        .to_string();
    assert!(err.contains("frames_per_level"), "{err}");
    let err = s
        .emva_series(&grid, &flat(&grid)[..5], &[1e-3], 2, 8, 8, 0)
        .unwrap_err()
        .to_string();
    assert!(err.contains("5 values"), "{err}");
    let err = s
        .emva_series(&grid, &flat(&grid), &[1e-3], 2, 800, 8, 0)
        .unwrap_err()
        .to_string();
    assert!(err.contains("window"), "{err}");
}

/// NaN or negative irradiance (a broken upstream stage) counts as no light: no panic, no hang.
#[test]
fn nan_irradiance_is_no_light() {
    let s = config("imx363", |c| {
        c.rows = 8;
        c.cols = 8;
        c.noise.read = false;
        c.noise.dsnu = false;
    });
    let grid = WavelengthGrid::default();
    let mut img = uniform_image(8, 8, grid, s.pixel_pitch_m(), &flat(&grid));
    for plane in img.bands_mut() {
        plane[0] = f32::NAN;
        plane[1] = -1.0;
    }
    let f = s.compute(&img, &Capture::seconds(1e-3)).unwrap();
    assert_eq!(f.raw[0].dn[0], 0);
    assert_eq!(f.raw[0].dn[1], 0);
    assert!(f.raw[0].dn[9] > 0);
}

/// The noise model's terms are the formulas of EMVA 1288 / ISETCam with the analog gain applied
/// after the pixel: read and DSNU scale with dn_per_v / gain, shot with K = cg / gain x dn_per_v;
/// a switched-off source contributes 0.
#[test]
fn predicted_noise_terms_follow_the_formulas() {
    let s = config("imx363", |c| {
        c.analog_gain = 2.0;
        c.dark_voltage_mv_per_s = 10.0;
        c.noise.quantization = false;
    });
    let dpv = 4096.0 / 0.4591;
    let k = 7.65e-5 / 2.0 * dpv;
    let t = 0.5;
    let dark_e = 0.005 / 7.65e-5;
    let mean_dn = k * (1000.0 + dark_e);
    let p = s.predicted_noise_dn(mean_dn, t);
    assert!((p.shot - k * 1000f64.sqrt()).abs() < 1e-9);
    assert!((p.dark - k * dark_e.sqrt()).abs() < 1e-9);
    assert!((p.read - 5e-3 * dpv / 2.0).abs() < 1e-9);
    assert!((p.dsnu - 0.64e-3 * dpv / 2.0).abs() < 1e-9);
    assert!((p.prnu - 0.007 * mean_dn).abs() < 1e-9);
    assert_eq!(p.quantization, 0.0);
    let total =
        (p.shot.powi(2) + p.dark.powi(2) + p.read.powi(2) + p.dsnu.powi(2) + p.prnu.powi(2)).sqrt();
    assert!((p.total - total).abs() < 1e-9);
    let quiet = s
        .with_noise(camsim_sensor::NoiseSwitches::none())
        .predicted_noise_dn(mean_dn, t);
    assert_eq!(
        (quiet.shot, quiet.read, quiet.dsnu, quiet.prnu, quiet.dark),
        (0.0, 0.0, 0.0, 0.0, 0.0)
    );
    assert!((quiet.total - (1.0f64 / 12.0).sqrt()).abs() < 1e-12);
}
