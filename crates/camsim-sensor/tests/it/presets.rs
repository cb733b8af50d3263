//! Presets against their published sources: the paper's Table 1, the published IMX363 QE and the
//! paper's corrected Pixel 4a QE (ISET/isetcornellbox p4aCorrected).

use crate::common;
use camsim_sensor::{presets, Sensor};
use common::read_csv;

#[test]
fn imx363_has_every_value_of_table_1() {
    let s = Sensor::preset("imx363").unwrap();
    // Lyu et al., Table 1.
    assert_eq!(s.pixel_pitch_m(), 1.4e-6);
    assert_eq!(s.fill_factor(), 1.0);
    assert!(
        (s.well_capacity_e() - 6000.0).abs() / 6000.0 < 0.001,
        "well {}",
        s.well_capacity_e()
    );
    assert_eq!(s.voltage_swing_v(), 0.4591);
    assert!((s.conversion_gain_v_per_e() - 7.65e-5).abs() < 1e-12);
    assert_eq!(s.analog_gain(), 1.0);
    assert_eq!(s.analog_offset_v(), 0.0);
    assert_eq!(s.bits(), 12);
    assert!((s.dsnu_v() - 0.64e-3).abs() < 1e-12);
    assert!((s.prnu_fraction() - 0.007).abs() < 1e-12);
    assert_eq!(s.dark_voltage_v_per_s(), 0.0);
    assert!((s.read_noise_v() - 5e-3).abs() < 1e-12);
    assert_eq!((s.rows(), s.cols()), (3024, 4032));
    assert_eq!(s.cfa(), camsim_core::CfaPattern::Rggb);
    // K = 7.65e-5 V/e- x 4096 / 0.4591 V.
    assert!((s.k_dn_per_e() - 7.65e-5 * 4096.0 / 0.4591).abs() < 1e-9);
}

#[test]
fn imx363_qe_is_the_published_filter_times_ir_cut() {
    let s = Sensor::preset("imx363").unwrap();
    let rows = read_csv("imx363_qe.csv");
    assert_eq!(rows.len(), 33);
    for row in &rows {
        for c in 0..3 {
            let want = row[1 + c] * row[4];
            let got = s.qe_spectrum(c).eval(row[0]);
            assert!(
                (got - want).abs() < 1e-12,
                "channel {c} at {} nm: {got} vs {want}",
                row[0]
            );
        }
    }
}

#[test]
fn pixel4a_is_imx363_with_the_correction() {
    let a = Sensor::preset("imx363").unwrap().config().clone();
    let mut b = Sensor::preset("pixel4a").unwrap().config().clone();
    assert_eq!(
        b.qe_correction,
        Some([[0.532, 0.0, 0.0], [0.06, 0.70, 0.0], [0.0, 0.36, 0.84]])
    );
    b.name = a.name.clone();
    b.source = a.source.clone();
    b.qe_correction = None;
    assert_eq!(a, b);
}

fn normalized_difference(x: &[f64], y: &[f64]) -> f64 {
    let nx = x.iter().map(|v| v * v).sum::<f64>().sqrt();
    let ny = y.iter().map(|v| v * v).sum::<f64>().sqrt();
    x.iter()
        .zip(y)
        .map(|(a, b)| (a / nx - b / ny).powi(2))
        .sum::<f64>()
        .sqrt()
}

fn correlation(x: &[f64], y: &[f64]) -> f64 {
    let n = x.len() as f64;
    let (mx, my) = (x.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
    let sxy: f64 = x.iter().zip(y).map(|(a, b)| (a - mx) * (b - my)).sum();
    let sxx: f64 = x.iter().map(|a| (a - mx).powi(2)).sum();
    let syy: f64 = y.iter().map(|b| (b - my).powi(2)).sum();
    sxy / (sxx * syy).sqrt()
}

/// Which product of the paper's eq. 1 reproduces ISET/isetcornellbox p4aCorrected? The paper's
/// reading, [r', g', b'] = [r, g, b] M with rows of M for the input channel (g' = 0.70 g + 0.36 b:
/// blue crosstalk gives p4aCorrected's green its 440-480 nm shoulder), matches the shape of all
/// three channels (correlation > 0.98); the transpose (g' = 0.06 r + 0.70 g, b' = 0.36 g + 0.84 b)
/// misses green and blue. (p4aCorrected comes from an older QE file, so neither is exact: the
/// paper's product leaves a 0.06 g shoulder in red that p4aCorrected lacks.)
#[test]
fn pixel4a_correction_matches_p4a_corrected() {
    let p4a = read_csv("isetcornellbox/p4aCorrected.csv");
    let paper = Sensor::preset("pixel4a").unwrap();
    // The transposed product, built as a config.
    let mut cfg = paper.config().clone();
    let m = cfg.qe_correction.unwrap();
    cfg.qe_correction = Some([
        [m[0][0], m[1][0], m[2][0]],
        [m[0][1], m[1][1], m[2][1]],
        [m[0][2], m[1][2], m[2][2]],
    ]);
    let transposed = Sensor::from_config(cfg).unwrap();
    let wl: Vec<f64> = p4a.iter().map(|r| r[0]).collect();
    let mut nd_paper = [0.0; 3];
    let mut nd_transposed = [0.0; 3];
    for c in 0..3 {
        let reference: Vec<f64> = p4a.iter().map(|r| r[1 + c]).collect();
        let a: Vec<f64> = wl.iter().map(|w| paper.qe_spectrum(c).eval(*w)).collect();
        let b: Vec<f64> = wl
            .iter()
            .map(|w| transposed.qe_spectrum(c).eval(*w))
            .collect();
        nd_paper[c] = normalized_difference(&a, &reference);
        nd_transposed[c] = normalized_difference(&b, &reference);
        let corr = correlation(&a, &reference);
        assert!(
            corr > 0.98,
            "channel {c}: correlation {corr:.4} of [r,g,b]M with p4aCorrected"
        );
        eprintln!(
            "channel {c}: normalized difference [r,g,b]M {:.4}, transposed {:.4}; correlation {:.4} vs {:.4}",
            nd_paper[c],
            nd_transposed[c],
            corr,
            correlation(&b, &reference)
        );
    }
    // Green and blue decide: the transposed product is far off there.
    assert!(nd_paper[1] < 0.5 * nd_transposed[1]);
    assert!(nd_paper[2] < 0.1 * nd_transposed[2]);
    assert!(nd_paper.iter().sum::<f64>() < 0.5 * nd_transposed.iter().sum::<f64>());
}

#[test]
fn presets_round_trip_through_toml() {
    for name in presets::names() {
        let s = Sensor::preset(name).unwrap();
        let back = Sensor::from_toml_str(&s.to_toml(), "round trip").unwrap();
        assert_eq!(back.config(), s.config(), "{name}");
        assert_eq!(back, s, "{name}");
    }
    let err = presets::toml("imx999").unwrap_err().to_string();
    assert!(err.contains("imx999") && err.contains("imx363"), "{err}");
}

#[test]
fn ideal_preset_is_noise_free_with_unit_qe() {
    let s = Sensor::preset("ideal").unwrap();
    let n = s.noise();
    assert!(!n.shot && !n.read && !n.dsnu && !n.prnu && !n.dark);
    let qe = s.channel_qe(&camsim_core::WavelengthGrid::default());
    assert!(qe.iter().all(|c| c.iter().all(|v| *v == 1.0)));
}

/// The IMX490 split-pixel preset is imx490-large with imx490-small as its small photodiode
/// (ISETCam sensorCreate('imx490-large' / 'imx490-small'): wells 120 000 / 60 000 e-, fill
/// factors 0.9 / 0.1, 0.25 mV per DN, 4096 DN, read noise 1 e-), and its dynamic range is the
/// closed form from those numbers: the SPD's range (60 000 e-, or 4095 DN / K_SPD if smaller)
/// times 9, over the LPD's floor sqrt(1 + 1 / (12 K_LPD^2)) electrons (EMVA 1288 eq. 9).
#[test]
fn imx490_split_pixel_is_its_two_photodiodes() {
    let hdr = Sensor::preset("imx490").unwrap();
    let large = Sensor::preset("imx490-large").unwrap();
    let small = Sensor::preset("imx490-small").unwrap();
    let m = hdr.hdr_model().expect("imx490 has [hdr]");
    let rel = |a: f64, b: f64| (a / b - 1.0).abs();
    // ISETCam's numbers: K = 4096 DN / well (the 1.024 V swing over the well's conversion gain).
    let (k_lpd, k_spd) = (4096.0 / 120_000.0, 4096.0 / 60_000.0);
    assert!(
        rel(m.k_high_dn_per_e, k_lpd) < 1e-4,
        "{}",
        m.k_high_dn_per_e
    );
    assert!(rel(m.k_low_dn_per_e, k_spd) < 1e-4, "{}", m.k_low_dn_per_e);
    assert!(rel(large.k_dn_per_e(), k_lpd) < 1e-4);
    assert!(rel(small.k_dn_per_e(), k_spd) < 1e-4);
    assert!(rel(m.read_high_e, 1.0) < 1e-4 && rel(m.read_low_e, 1.0) < 1e-12);
    assert!(rel(m.full_well_low_e, 60_000.0) < 1e-12);
    assert!(rel(m.ratio, 0.1 / 0.9) < 1e-12);
    assert_eq!(hdr.config().qe, large.config().qe);
    assert_eq!(large.config().qe, small.config().qe);
    let spd_range_e = 60_000.0f64.min(4095.0 / k_spd);
    let floor_e = (1.0 + 1.0 / (12.0 * k_lpd * k_lpd)).sqrt();
    let dr_db = 20.0 * (spd_range_e * 9.0 / floor_e).log10();
    eprintln!(
        "imx490 dynamic range {:.2} dB (closed form {dr_db:.2})",
        m.dynamic_range_db()
    );
    assert!((m.dynamic_range_db() - dr_db).abs() < 0.01);
}
