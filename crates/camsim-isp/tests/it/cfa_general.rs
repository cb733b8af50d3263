//! ISP for general CFAs: per-filter bilinear interpolation (equal to the Bayer bilinear demosaic
//! on a Bayer tile, exact on uniform fields), Quad Bayer 2x2 binning (exact sums; noise variances
//! add), RGBW -> RGB fusion on a gray field.

use camsim_core::{CfaLayout, CfaPattern, Quantity, RawImage, SpectralImage, WavelengthGrid};
use camsim_isp::cfa_general::{bin_2x2, demosaic_any, demosaic_layout_bilinear, rgbw_to_rgb};
use camsim_isp::demosaic_bilinear;
use camsim_sensor::{Capture, NoiseSwitches, Sensor};

fn raw_with(
    rows: usize,
    cols: usize,
    layout: Option<CfaLayout>,
    f: impl Fn(usize, usize) -> u16,
) -> RawImage {
    let mut raw = RawImage::new(rows, cols, CfaPattern::Rggb, 12).unwrap();
    raw.layout = layout;
    raw.black_level_dn = 64.0;
    for r in 0..rows {
        for c in 0..cols {
            raw.dn[r * cols + c] = f(r, c);
        }
    }
    raw
}

/// A deterministic pseudo-random DN (splitmix-style hash).
fn hash_dn(r: usize, c: usize) -> u16 {
    let mut x = (r as u64) << 32 ^ c as u64 ^ 0x9e37_79b9_7f4a_7c15;
    x = (x ^ (x >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    (64 + (x >> 40) % 4000) as u16
}

#[test]
fn general_bilinear_equals_the_bayer_bilinear_on_bayer_tiles() {
    for p in [
        CfaPattern::Rggb,
        CfaPattern::Grbg,
        CfaPattern::Gbrg,
        CfaPattern::Bggr,
    ] {
        let mut raw = raw_with(13, 18, None, hash_dn);
        raw.cfa = p;
        let a = demosaic_bilinear(&raw);
        let b = demosaic_layout_bilinear(&raw).unwrap();
        let mut worst = 0.0f32;
        for (c, name) in ["r", "g", "b"].iter().enumerate() {
            for (x, y) in a.plane(c).iter().zip(b.plane(name).unwrap()) {
                worst = worst.max((x - y).abs());
            }
        }
        // Same means, summed in another order (f32).
        assert!(worst < 2e-3, "{p:?}: largest difference {worst} DN");
    }
}

#[test]
fn uniform_filter_fields_stay_uniform_for_any_tile() {
    let custom = CfaLayout::from_names(&[
        vec!["c".into(), "y".into(), "w".into()],
        vec!["y".into(), "m".into(), "c".into()],
        vec!["w".into(), "c".into(), "y".into()],
    ])
    .unwrap();
    for layout in [
        CfaLayout::parse("RGBW").unwrap(),
        CfaLayout::parse("quad-bayer").unwrap(),
        custom,
    ] {
        let level = |f: usize| 100.0 + 250.0 * f as f32;
        let l2 = layout.clone();
        let raw = raw_with(11, 14, Some(layout.clone()), move |r, c| {
            (64.0 + level(l2.filter_at(r, c))) as u16
        });
        let p = demosaic_layout_bilinear(&raw).unwrap();
        assert_eq!(p.names, layout.filters());
        for (f, plane) in p.planes.iter().enumerate() {
            assert!(
                plane.iter().all(|v| (v - level(f)).abs() < 1e-3),
                "{} filter {}",
                layout.name(),
                p.names[f]
            );
        }
    }
    // Bayer-only tools refuse a non-Bayer frame.
    let raw = raw_with(8, 8, Some(CfaLayout::parse("RGBW").unwrap()), hash_dn);
    assert!(camsim_isp::try_demosaic_bilinear(&raw)
        .unwrap_err()
        .to_string()
        .contains("RGBW"));
    assert!(camsim_isp::demosaic(&raw, camsim_isp::DemosaicMethod::Malvar).is_err());
}

#[test]
fn quad_bayer_binning_sums_the_four_pixels() {
    let raw = raw_with(
        10,
        13,
        Some(CfaLayout::parse("quad-bayer").unwrap()),
        hash_dn,
    );
    let b = bin_2x2(&raw).unwrap();
    assert_eq!(
        (b.rows, b.cols, b.cfa, b.layout.is_none()),
        (5, 6, CfaPattern::Rggb, true)
    );
    // 12-bit input (white 4095, black 64): white 4 x 4031 + 64, 14 bits.
    assert_eq!((b.white_level_dn, b.bits), (16188.0, 14));
    for i in 0..5 {
        for j in 0..6 {
            let sum: i64 = [(0, 0), (0, 1), (1, 0), (1, 1)]
                .iter()
                .map(|(a, c)| raw.at(2 * i + a, 2 * j + c) as i64 - 64)
                .sum();
            assert_eq!(b.at(i, j) as i64 - 64, sum, "({i}, {j})");
        }
    }
    // The binned frame is a Bayer mosaic: the Bayer demosaic takes it.
    assert!(demosaic_any(&b).is_ok() && camsim_isp::try_demosaic_bilinear(&b).is_ok());
    assert!(bin_2x2(&raw_with(
        8,
        8,
        Some(CfaLayout::parse("RGBW").unwrap()),
        hash_dn
    ))
    .is_err());
}

fn flat(sensor: &Sensor, level_w_m2_nm: f64) -> SpectralImage {
    let grid = WavelengthGrid::new(400.0, 700.0, 10.0).unwrap();
    let mut img = SpectralImage::zeros(
        sensor.rows(),
        sensor.cols(),
        grid,
        sensor.pixel_pitch_m(),
        Quantity::Irradiance,
    )
    .unwrap();
    for plane in img.bands_mut() {
        plane.fill(level_w_m2_nm as f32);
    }
    img
}

fn sensor_with(cfa: &str, rows: usize, cols: usize, noise: NoiseSwitches) -> Sensor {
    let mut c = Sensor::preset("imx363").unwrap().config().clone();
    c.cfa = cfa.into();
    c.rows = rows;
    c.cols = cols;
    c.bits = 12;
    c.noise = noise;
    Sensor::from_config(c).unwrap()
}

#[test]
fn binned_flat_field_noise_variance_is_four_times_the_pixel_variance() {
    // Shot + read noise (and ADC rounding) only: the four pixels of a block are independent, so
    // var(sum) = 4 var(pixel) and mean(sum) = 4 mean(pixel) (above black).
    let noise = NoiseSwitches {
        shot: true,
        read: true,
        dsnu: false,
        prnu: false,
        dark: false,
        quantization: true,
    };
    let s = sensor_with("quad-bayer", 256, 256, noise);
    let frame = s
        .compute(&flat(&s, 0.05), &Capture::seconds(1e-4).with_seed(3))
        .unwrap();
    let raw = &frame.raw[0];
    assert!(frame
        .mean_electrons_by_filter
        .iter()
        .all(|e| *e < 0.5 * s.well_capacity_e()));
    let binned = bin_2x2(raw).unwrap();
    let layout = raw.cfa_layout();
    let g = layout.filter_index("g").unwrap();
    let stats = |vals: Vec<f64>| {
        let n = vals.len() as f64;
        let m = vals.iter().sum::<f64>() / n;
        (
            m,
            vals.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (n - 1.0),
        )
    };
    let (m1, v1) = stats(
        (0..raw.rows * raw.cols)
            .filter(|i| layout.filter_at(i / raw.cols, i % raw.cols) == g)
            .map(|i| raw.dn[i] as f64 - raw.black_level_dn)
            .collect(),
    );
    let (m4, v4) = stats(
        (0..binned.rows * binned.cols)
            .filter(|i| {
                binned
                    .cfa
                    .channel_at(i / binned.cols, i % binned.cols)
                    .index()
                    == 1
            })
            .map(|i| binned.dn[i] as f64 - binned.black_level_dn)
            .collect(),
    );
    println!("green: pixel mean {m1:.2} DN var {v1:.3} DN^2; binned mean {m4:.2} DN var {v4:.3} DN^2; ratios {:.4} {:.4}", m4 / m1, v4 / v1);
    assert!((m4 / m1 - 4.0).abs() < 1e-3, "{}", m4 / m1);
    // 32768 green pixels, 8192 binned: the variance ratio's standard error is about 1.8 %.
    assert!((v4 / v1 - 4.0).abs() < 4.0 * 0.06, "{}", v4 / v1);
    // And the predicted shot + read variance of one pixel matches the measured one.
    let pred = s.predicted_noise_dn(m1, 1e-4);
    let v_pred = pred.shot.powi(2) + pred.read.powi(2) + pred.quantization.powi(2);
    assert!((v1 / v_pred - 1.0).abs() < 0.06, "{v1} vs {v_pred}");
}

#[test]
fn rgbw_gray_field_w_matches_the_qe_weighted_sum() {
    let s = sensor_with("RGBW", 32, 32, NoiseSwitches::none());
    let weights = s.filter_from_rgb_weights("w").unwrap();
    let frame = s.compute(&flat(&s, 0.05), &Capture::seconds(5e-5)).unwrap();
    let e = &frame.mean_electrons_by_filter;
    let predicted = weights[0] * e[0] + weights[1] * e[1] + weights[2] * e[2];
    println!(
        "w from rgb weights {weights:?}; W {:.1} e- vs a R + b G + c B = {predicted:.1} e-",
        e[3]
    );
    assert!(
        (e[3] / predicted - 1.0).abs() < 0.05,
        "{} vs {predicted}",
        e[3]
    );
    let rgb = rgbw_to_rgb(&frame.raw[0], weights).unwrap();
    let k = (e[3] / predicted) as f32;
    let dn_per_e = s.k_dn_per_e() as f32;
    for (c, plane) in [&rgb.r, &rgb.g, &rgb.b].iter().enumerate() {
        let want = e[c] as f32 * dn_per_e * k;
        let mean = plane.iter().sum::<f32>() / plane.len() as f32;
        assert!(
            (mean / want - 1.0).abs() < 0.01,
            "channel {c}: {mean} vs {want}"
        );
    }
}
