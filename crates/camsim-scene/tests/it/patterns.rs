//! The ISETCam test patterns checked against their closed forms: the harmonic's mean, contrast and
//! FFT peak; the zone plate's local frequency `k r / pi` from zero crossings; the sweep's zero
//! crossings `x^3 = m / (2 max_freq)` and row contrasts; the star's bright fraction and spoke count;
//! exact pixel counts of the checkerboard, grid lines and point array; the ramp's linearity.
//! Luminance is computed here straight from the CIE 1931 table, not through the crate.

use camsim_core::{tables, SpectralImage, WavelengthGrid};
use camsim_scene::*;
use rustfft::num_complex::Complex;
use rustfft::FftPlanner;

/// Per-pixel luminance, cd/m^2: 683 sum ybar L dl (CIE 015:2018), row-major.
fn luminance(img: &SpectralImage) -> Vec<f64> {
    let ybar = &tables::cie1931_xyz_cmfs()[1];
    let mut lum = vec![0.0; img.pixels()];
    for b in 0..img.bands() {
        let w = 683.0 * ybar.eval(img.grid.wavelength_nm(b)) * img.grid.step_nm;
        for (l, v) in lum.iter_mut().zip(img.band(b)) {
            *l += w * *v as f64;
        }
    }
    lum
}

fn make(cfg: SceneConfig) -> (SpectralImage, Vec<f64>) {
    let img = create(&cfg, &WavelengthGrid::default()).unwrap();
    let lum = luminance(&img);
    (img, lum)
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len() as f64
}

fn max(v: &[f64]) -> f64 {
    v.iter().cloned().fold(f64::MIN, f64::max)
}

fn min(v: &[f64]) -> f64 {
    v.iter().cloned().fold(f64::MAX, f64::min)
}

/// Positions (fractional indices) where `v` changes sign, by linear interpolation.
fn zero_crossings(v: &[f64]) -> Vec<f64> {
    v.windows(2)
        .enumerate()
        .filter(|(_, w)| (w[0] < 0.0) != (w[1] < 0.0))
        .map(|(i, w)| i as f64 + w[0] / (w[0] - w[1]))
        .collect()
}

#[test]
fn every_pattern_has_the_requested_mean_luminance_and_round_trips_through_toml() {
    let cases = vec![
        SceneConfig::Harmonic(HarmonicScene {
            mean_luminance_cd_m2: 42.0,
            freq: 3.3,
            ..Default::default()
        }),
        SceneConfig::ZonePlate(ZonePlateScene {
            illuminant: "A".into(),
            size_px: 64,
            ..Default::default()
        }),
        SceneConfig::SweepFrequency(SweepFrequencyScene {
            size_px: 64,
            ..Default::default()
        }),
        SceneConfig::Star(StarScene {
            mean_luminance_cd_m2: 5.0,
            size_px: 40,
            ..Default::default()
        }),
        SceneConfig::Checkerboard(CheckerboardScene {
            illuminant: "F11".into(),
            ..Default::default()
        }),
        SceneConfig::GridLines(GridLinesScene {
            mean_luminance_cd_m2: 1000.0,
            ..Default::default()
        }),
        SceneConfig::PointArray(PointArrayScene {
            point_size_px: 3,
            ..Default::default()
        }),
        SceneConfig::Ramp(RampScene {
            size_px: 50,
            ..Default::default()
        }),
        SceneConfig::DeadLeaves(DeadLeavesScene {
            size_px: 48,
            r_max_px: 12.0,
            mean_luminance_cd_m2: 7.0,
            ..Default::default()
        }),
    ];
    for cfg in cases {
        let want = match &cfg {
            SceneConfig::Harmonic(c) => c.mean_luminance_cd_m2,
            SceneConfig::ZonePlate(c) => c.mean_luminance_cd_m2,
            SceneConfig::SweepFrequency(c) => c.mean_luminance_cd_m2,
            SceneConfig::Star(c) => c.mean_luminance_cd_m2,
            SceneConfig::Checkerboard(c) => c.mean_luminance_cd_m2,
            SceneConfig::GridLines(c) => c.mean_luminance_cd_m2,
            SceneConfig::PointArray(c) => c.mean_luminance_cd_m2,
            SceneConfig::Ramp(c) => c.mean_luminance_cd_m2,
            SceneConfig::DeadLeaves(c) => c.mean_luminance_cd_m2,
            _ => unreachable!(),
        };
        let (img, lum) = make(cfg.clone());
        assert!(
            (mean(&lum) - want).abs() < 1e-5 * want,
            "{}: {} vs {want} cd/m^2",
            cfg.kind(),
            mean(&lum)
        );
        assert!(min(&lum) >= 0.0, "{}", cfg.kind());
        assert!(img.data.iter().all(|v| v.is_finite()));
        let back = SceneConfig::from_toml(&cfg.to_toml(), "round trip").unwrap();
        assert_eq!(back, cfg, "{}", cfg.kind());
    }
}

#[test]
fn harmonic_mean_contrast_and_fft_peak_match_imageharmonic() {
    // Wave vector (kx, ky) = (3, 4) cycles per image: freq = 5 at atan2(4, 3) = 53.13 degrees.
    let angle_deg = 4.0f64.atan2(3.0).to_degrees();
    let n = 64;
    let cfg = HarmonicScene {
        freq: 5.0,
        contrast: 0.6,
        phase_deg: 30.0,
        angle_deg,
        rows: n,
        cols: n,
        ..Default::default()
    };
    let (_, lum) = make(SceneConfig::Harmonic(cfg));
    assert!((mean(&lum) - 100.0).abs() < 1e-4, "mean {}", mean(&lum));
    let (hi, lo) = (max(&lum), min(&lum));
    let contrast = (hi - lo) / (hi + lo);
    // The samples land on phases 2 pi m / 64 + 30 deg: the extremes are missed by at most
    // 1 - cos(pi / 64) = 1.2e-3 of the amplitude.
    assert!((contrast - 0.6).abs() < 1.5e-3, "contrast {contrast}");
    // 2D DFT (rows, then columns) of the luminance; the strongest non-DC bin.
    let mut planner = FftPlanner::<f64>::new();
    let fft = planner.plan_fft_forward(n);
    let mut data: Vec<Complex<f64>> = lum.iter().map(|v| Complex::new(*v, 0.0)).collect();
    for row in data.chunks_exact_mut(n) {
        fft.process(row);
    }
    let mut col = vec![Complex::new(0.0, 0.0); n];
    for j in 0..n {
        for i in 0..n {
            col[i] = data[i * n + j];
        }
        fft.process(&mut col);
        for i in 0..n {
            data[i * n + j] = col[i];
        }
    }
    let signed = |k: usize| {
        if k > n / 2 {
            k as f64 - n as f64
        } else {
            k as f64
        }
    };
    let (best, _) = data
        .iter()
        .enumerate()
        .skip(1)
        .map(|(k, c)| (k, c.norm()))
        .fold((0, 0.0), |a, b| if b.1 > a.1 { b } else { a });
    let (ky, kx) = (signed(best / n), signed(best % n));
    let freq = kx.hypot(ky);
    let angle = ky.atan2(kx).to_degrees().rem_euclid(180.0);
    assert!(
        (freq - 5.0).abs() < 1e-12 && (angle - angle_deg).abs() < 1e-9,
        "peak at (kx, ky) = ({kx}, {ky})"
    );
    // All the AC power is in that bin and its mirror: a pure sinusoid.
    let dc = data[0].norm();
    let peak = data[best].norm();
    assert!(
        (2.0 * peak / dc - 0.6).abs() < 1e-5,
        "AC/DC amplitude ratio {}",
        2.0 * peak / dc
    );
}

#[test]
fn zone_plate_local_frequency_is_k_r_over_pi() {
    // Along the centre row, crossings of the mid level sit at pi r^2 / N = pi/2 + m pi; between
    // neighbours the local frequency 0.5 / (r2 - r1) cycles/pixel equals k r_mid / pi = r_mid / N
    // with k = pi / N (the chord of r^2 is exact), up to the linear interpolation of crossings.
    let n = 512;
    let (_, lum) = make(SceneConfig::ZonePlate(ZonePlateScene {
        size_px: n,
        ..Default::default()
    }));
    let c = n / 2;
    // Amplitude 1: the centre pixel has reflectance 1, so the mid level is half its luminance.
    let mid = 0.5 * lum[c * n + c];
    let profile: Vec<f64> = (c..n).map(|j| lum[c * n + j] - mid).collect();
    let crossings = zero_crossings(&profile);
    let k = std::f64::consts::PI / n as f64;
    let mut worst = 0.0f64;
    let mut count = 0;
    for w in crossings.windows(2) {
        let r_mid = 0.5 * (w[0] + w[1]);
        if r_mid > 0.2 * n as f64 {
            break; // above 0.2 cycles/pixel linear interpolation of the crossings loses accuracy
        }
        let measured = 0.5 / (w[1] - w[0]);
        let expected = k * r_mid / std::f64::consts::PI;
        worst = worst.max((measured / expected - 1.0).abs());
        count += 1;
    }
    eprintln!("zone plate: {count} crossing pairs up to 0.2 cycles/pixel, worst relative frequency error {worst:.2e}");
    // (0.2 N)^2 / N - 1/2 = 20: about 20 pairs.
    assert!(count >= 19, "{count}");
    assert!(worst < 2e-2, "worst relative error {worst}");
    // The crossings themselves: r_m^2 = N (m + 1/2).
    let mut worst_px = 0.0f64;
    for (m, r) in crossings
        .iter()
        .enumerate()
        .take_while(|(_, r)| **r < 0.2 * n as f64)
    {
        worst_px = worst_px.max((r - (n as f64 * (m as f64 + 0.5)).sqrt()).abs());
    }
    eprintln!("zone plate: worst crossing position error {worst_px:.3} px");
    assert!(worst_px < 0.05, "{worst_px} px");
}

#[test]
fn sweep_crossings_follow_x_cubed_and_contrast_falls_down_the_rows() {
    let n = 256;
    let f = 10.0;
    let (_, lum) = make(SceneConfig::SweepFrequency(SweepFrequencyScene {
        size_px: n,
        max_freq: f,
        ..Default::default()
    }));
    let row = |i: usize| &lum[i * n..(i + 1) * n];
    // Row i is K (1 + c_i s_j) / 2 with c_i = (N - i) / N: rows 0 and 1 differ by K s_j / (2N),
    // whose zeros are those of s_j = sin(2 pi f x^3), x = (j + 1) / N: x_m^3 = m / (2 f).
    let diff: Vec<f64> = row(0).iter().zip(row(1)).map(|(a, b)| a - b).collect();
    let crossings = zero_crossings(&diff);
    assert!(!crossings.is_empty());
    let mut worst = 0.0f64;
    for (m, j) in crossings.iter().enumerate() {
        let x = (((m + 1) as f64) / (2.0 * f)).cbrt();
        let j_expected = x * n as f64 - 1.0;
        worst = worst.max((j - j_expected).abs());
    }
    eprintln!(
        "sweep: {} crossings, worst position error {worst:.3} px",
        crossings.len()
    );
    // 2 f x^3 reaches 2 f = 20 at x = 1: crossings m = 1..=19 (m = 20 is the last pixel itself).
    assert!(crossings.len() >= 19, "{}", crossings.len());
    assert!(worst < 0.05, "worst crossing error {worst} px");
    // Per-row Michelson contrast equals c_i (the row's first peak is sampled at < 1/100 cycle/px).
    for i in [0, 64, 128, 200, 255] {
        let r = row(i);
        let contrast = (max(r) - min(r)) / (max(r) + min(r));
        let want = (n - i) as f64 / n as f64;
        assert!(
            (contrast - want).abs() < 1e-3,
            "row {i}: contrast {contrast} vs {want}"
        );
    }
}

#[test]
fn star_is_half_bright_with_n_spokes() {
    let n = 256;
    for spokes in [4, 8, 13] {
        let (_, lum) = make(SceneConfig::Star(StarScene {
            size_px: n,
            number_of_spokes: spokes,
            ..Default::default()
        }));
        let k = max(&lum); // a fully bright pixel has reflectance 1
        let bright_fraction = mean(&lum) / k;
        assert!(
            (bright_fraction - 0.5).abs() < 1e-3,
            "{spokes} spokes: bright fraction {bright_fraction}"
        );
        // Angular profile at radius 0.35 N: count changes between bright (> 3/4 of a full pixel)
        // and dark (< 1/4) around the circle; the anti-aliased pixels in between are skipped.
        let r = 0.35 * n as f64;
        let samples = 7200;
        let states: Vec<bool> = (0..samples)
            .filter_map(|s| {
                let t = 2.0 * std::f64::consts::PI * s as f64 / samples as f64;
                let (x, y) = (0.5 * n as f64 + r * t.cos(), 0.5 * n as f64 + r * t.sin());
                let v = lum[(y as usize) * n + x as usize] / k;
                if v > 0.75 {
                    Some(true)
                } else if v < 0.25 {
                    Some(false)
                } else {
                    None
                }
            })
            .collect();
        let m = states.len();
        let transitions = (0..m).filter(|s| states[*s] != states[(s + 1) % m]).count();
        assert_eq!(transitions, 2 * spokes, "{spokes} spokes");
    }
}

#[test]
fn checkerboard_grid_lines_and_point_array_have_exact_pixel_counts() {
    // Checkerboard: 6 periods of 8 px -> 48 x 48, 4-px checks, dark at the top left.
    let (img, lum) = make(SceneConfig::Checkerboard(CheckerboardScene {
        period_px: 8,
        number_of_checks: 6,
        ..Default::default()
    }));
    assert_eq!((img.rows, img.cols), (48, 48));
    let k = max(&lum);
    let bright = lum.iter().filter(|v| **v > 0.5 * k).count();
    assert_eq!(bright * 2, 48 * 48);
    assert_eq!(lum[0], 0.0);
    assert!(lum[4] > 0.5 * k && lum[4 * 48] > 0.5 * k && lum[4 * 48 + 4] == 0.0 && lum[3] == 0.0);

    // Grid lines: 128 px, pitch 16, width 2: lines start at 0-based 7 -> 8 lines of 2 px per axis.
    let (_, lum) = make(SceneConfig::GridLines(GridLinesScene {
        line_thickness_px: 2,
        ..Default::default()
    }));
    let k = max(&lum);
    let bright = lum.iter().filter(|v| **v > 0.5 * k).count();
    let on = 8 * 2;
    assert_eq!(bright, 128 * 128 - (128 - on) * (128 - on));
    assert!(lum[7 * 128] > 0.5 * k && lum[9 * 128 + 9] == 0.0 && lum[8 * 128 + 100] > 0.5 * k);

    // Point array: 128 px, pitch 32, 3-px points starting at 0-based 15: 4 x 4 points.
    let (_, lum) = make(SceneConfig::PointArray(PointArrayScene {
        pixels_between_points: 32,
        point_size_px: 3,
        ..Default::default()
    }));
    let k = max(&lum);
    let bright: Vec<usize> = (0..lum.len()).filter(|p| lum[*p] > 0.5 * k).collect();
    assert_eq!(bright.len(), 16 * 9);
    assert!(bright
        .iter()
        .all(|p| ((p / 128) + 32 - 15) % 32 < 3 && ((p % 128) + 32 - 15) % 32 < 3));
}

#[test]
fn ramp_is_linear_with_the_requested_dynamic_range() {
    let n = 100;
    let (_, lum) = make(SceneConfig::Ramp(RampScene {
        size_px: n,
        dynamic_range: 50.0,
        ..Default::default()
    }));
    let cols: Vec<f64> = (0..n)
        .map(|j| (0..n).map(|i| lum[i * n + j]).sum::<f64>() / n as f64)
        .collect();
    // Least-squares line through (j, L_j) and its R^2.
    let xs: Vec<f64> = (0..n).map(|j| j as f64).collect();
    let (mx, my) = (mean(&xs), mean(&cols));
    let sxy: f64 = xs.iter().zip(&cols).map(|(x, y)| (x - mx) * (y - my)).sum();
    let sxx: f64 = xs.iter().map(|x| (x - mx).powi(2)).sum();
    let slope = sxy / sxx;
    let ss_res: f64 = xs
        .iter()
        .zip(&cols)
        .map(|(x, y)| (y - my - slope * (x - mx)).powi(2))
        .sum();
    let ss_tot: f64 = cols.iter().map(|y| (y - my).powi(2)).sum();
    let r2 = 1.0 - ss_res / ss_tot;
    eprintln!("ramp: R^2 = 1 - {:.1e}", 1.0 - r2);
    assert!(r2 > 1.0 - 1e-10, "R^2 = {r2}");
    assert!(
        (cols[n - 1] / cols[0] - 50.0).abs() < 1e-4,
        "dynamic range {}",
        cols[n - 1] / cols[0]
    );
    // Every row is the same.
    assert!((0..n).all(|i| (lum[i * n + 7] - cols[7]).abs() < 1e-9 * cols[7]));
}

#[test]
fn bad_pattern_keys_are_named_in_errors() {
    let bad = |cfg: SceneConfig, key: &str| {
        let e = create(&cfg, &WavelengthGrid::default())
            .unwrap_err()
            .to_string();
        assert!(e.contains(key), "{key}: {e}");
    };
    bad(
        SceneConfig::Harmonic(HarmonicScene {
            contrast: 1.5,
            ..Default::default()
        }),
        "scene.contrast",
    );
    bad(
        SceneConfig::Harmonic(HarmonicScene {
            freq: f64::NAN,
            ..Default::default()
        }),
        "scene.freq",
    );
    bad(
        SceneConfig::Harmonic(HarmonicScene {
            rows: 0,
            ..Default::default()
        }),
        "scene.rows",
    );
    bad(
        SceneConfig::ZonePlate(ZonePlateScene {
            amplitude: -0.1,
            ..Default::default()
        }),
        "scene.amplitude",
    );
    bad(
        SceneConfig::SweepFrequency(SweepFrequencyScene {
            max_freq: 0.0,
            ..Default::default()
        }),
        "scene.max_freq",
    );
    bad(
        SceneConfig::Star(StarScene {
            number_of_spokes: 0,
            ..Default::default()
        }),
        "scene.number_of_spokes",
    );
    bad(
        SceneConfig::Checkerboard(CheckerboardScene {
            period_px: 7,
            ..Default::default()
        }),
        "scene.period_px",
    );
    bad(
        SceneConfig::Checkerboard(CheckerboardScene {
            number_of_checks: 0,
            ..Default::default()
        }),
        "scene.number_of_checks",
    );
    bad(
        SceneConfig::GridLines(GridLinesScene {
            line_thickness_px: 16,
            ..Default::default()
        }),
        "scene.line_thickness_px",
    );
    bad(
        SceneConfig::GridLines(GridLinesScene {
            size_px: 5,
            ..Default::default()
        }),
        "scene.size_px",
    );
    bad(
        SceneConfig::PointArray(PointArrayScene {
            pixels_between_points: 1,
            ..Default::default()
        }),
        "scene.pixels_between_points",
    );
    bad(
        SceneConfig::Ramp(RampScene {
            dynamic_range: 0.5,
            ..Default::default()
        }),
        "scene.dynamic_range",
    );
    bad(
        SceneConfig::Ramp(RampScene {
            fov_deg: 200.0,
            ..Default::default()
        }),
        "scene.fov_deg",
    );
    // An unknown key is reported at its own line.
    let e = SceneConfig::from_toml(
        "kind = \"zone_plate\"\nsize_px = 64\nampltude = 0.5\n",
        "zp.toml",
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("ampltude") && e.contains("line 3"), "{e}");
    // Missing keys take ISETCam's defaults.
    let cfg = SceneConfig::from_toml("kind = \"harmonic\"\n", "h.toml").unwrap();
    assert_eq!(cfg, SceneConfig::Harmonic(HarmonicScene::default()));
}

#[test]
fn the_zone_plate_example_config_builds() {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../examples/zone-plate.toml"
    );
    let text = std::fs::read_to_string(path).unwrap();
    assert_eq!(
        camsim_scene::config::locate_scene_error(&text, Some("scene")),
        None
    );
    let doc: toml::Table = toml::from_str(&text).unwrap();
    let scene = toml::to_string(&doc["scene"]).unwrap();
    let cfg = SceneConfig::from_toml(&scene, path).unwrap();
    assert_eq!(cfg.kind(), "zone_plate");
    let img = create(&cfg, &cfg.grid()).unwrap();
    assert_eq!((img.rows, img.cols), (512, 512));
}
