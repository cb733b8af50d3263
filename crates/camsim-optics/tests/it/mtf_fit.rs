//! The MTF fit (camsim_optics::mtf_fit) and the `pixel4a-measured` lens preset:
//! - the fit recovers known parameters from a synthetic curve;
//! - the PSF's Gaussian crosstalk blur multiplies the MTF by exp(-2 pi^2 sigma^2 f^2);
//! - the `pixel4a-measured` preset, with the 1.4 um pixel aperture, matches the measured MTF of a
//!   real Pixel 4a (ISET/isetcornellbox `pixel4a-measured-mtf-in-focus.csv`, Lyu et al. 2022):
//!   RMS difference <= 0.03 over 0-250 cycles/mm and MTF50 within 5 %.

use camsim_core::math::sinc;
use camsim_optics::mtf_fit::{fit_mtf, mtf_crossing, FitParams, MtfFitOptions, SystemMtfModel};
use camsim_optics::{Optics, Wavefront};
use std::f64::consts::PI;

const MEASURED: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../../shared/data/isetcornellbox/pixel4a-measured-mtf-in-focus.csv"
);

fn measured() -> camsim_io::measurements::MeasuredMtf {
    camsim_io::measurements::read_mtf_csv(std::path::Path::new(MEASURED)).unwrap()
}

#[test]
fn fit_recovers_known_defocus_and_crosstalk_from_a_synthetic_curve() {
    let truth = SystemMtfModel {
        defocus_um: 0.21,
        crosstalk_sigma_um: 0.55,
        ..SystemMtfModel::pixel4a()
    };
    let freq: Vec<f64> = (1..=40).map(|i| i as f64 * 7.0).collect();
    let curve = truth.mtf(&freq).unwrap();
    let (fitted, fit) = fit_mtf(
        &freq,
        &curve,
        &SystemMtfModel::pixel4a(),
        &MtfFitOptions::default(),
    )
    .unwrap();
    println!("{fit:?}");
    assert!(
        (fitted.defocus_um - 0.21).abs() < 0.002,
        "defocus {}",
        fitted.defocus_um
    );
    assert!(
        (fitted.crosstalk_sigma_um - 0.55).abs() < 0.01,
        "sigma {}",
        fitted.crosstalk_sigma_um
    );
    assert!(fit.rms < 1e-3, "rms {}", fit.rms);
    // Defocus only, crosstalk held at its true value.
    let start = SystemMtfModel {
        crosstalk_sigma_um: 0.55,
        ..SystemMtfModel::pixel4a()
    };
    let opts = MtfFitOptions {
        fit: FitParams {
            defocus: true,
            crosstalk: false,
        },
        ..MtfFitOptions::default()
    };
    let (fitted, _) = fit_mtf(&freq, &curve, &start, &opts).unwrap();
    assert!(
        (fitted.defocus_um - 0.21).abs() < 0.002,
        "defocus {}",
        fitted.defocus_um
    );
    assert_eq!(fitted.crosstalk_sigma_um, 0.55);
    // Bad input is an error, not a panic.
    assert!(fit_mtf(&freq[..3], &curve[..2], &start, &opts).is_err());
    assert!(fit_mtf(&[1.0, f64::NAN, 3.0], &[1.0, 0.5, 0.2], &start, &opts).is_err());
    let none = MtfFitOptions {
        fit: FitParams {
            defocus: false,
            crosstalk: false,
        },
        ..MtfFitOptions::default()
    };
    assert!(fit_mtf(&freq, &curve, &start, &none).is_err());
}

#[test]
fn crosstalk_blur_multiplies_the_mtf_by_a_gaussian() {
    let sigma_m = 1.2e-6;
    let wf = Wavefront::diffraction_limited(4.38e-3, 1.73)
        .unwrap()
        .with_extra_defocus_um(0.1);
    let plain = wf.mtf(550.0).unwrap();
    let blurred = wf
        .clone()
        .with_crosstalk_sigma_m(sigma_m)
        .mtf(550.0)
        .unwrap();
    let mut worst: f64 = 0.0;
    for (i, f) in plain.freq_cyc_per_mm.iter().enumerate() {
        let f_per_m = f * 1e3;
        let want = plain.mtf_x[i] * (-2.0 * PI * PI * sigma_m * sigma_m * f_per_m * f_per_m).exp();
        let j = blurred
            .freq_cyc_per_mm
            .iter()
            .position(|g| (g - f).abs() < 1e-9)
            .expect("same frequency grid");
        worst = worst.max((blurred.mtf_x[j] - want).abs());
    }
    println!("crosstalk MTF: largest |PSF-based - product| = {worst:.2e}");
    assert!(worst < 2e-3, "{worst}");
}

/// The preset's system MTF at 550 nm: its wavefront (crosstalk included) x the pixel4a sensor's
/// 1.4 um pixel aperture (100 % fill factor).
fn preset_system_mtf(name: &str, freq: &[f64]) -> Vec<f64> {
    let optics = Optics::preset(name).unwrap();
    let wf = optics.wavefront_for(None, f64::INFINITY).unwrap();
    let m = wf.mtf(550.0).unwrap();
    freq.iter()
        .map(|f| {
            let lens = camsim_analysis_free_interp(&m.freq_cyc_per_mm, &m.mtf_x, *f);
            lens * sinc(f * 1e-3 * 1.4).abs()
        })
        .collect()
}

/// Linear interpolation, 0 beyond the last sample (the diffraction cutoff).
fn camsim_analysis_free_interp(x: &[f64], y: &[f64], x0: f64) -> f64 {
    let i = x.partition_point(|v| *v < x0);
    if i == 0 {
        y[0]
    } else if i >= x.len() {
        0.0
    } else {
        let w = (x0 - x[i - 1]) / (x[i] - x[i - 1]);
        y[i - 1] * (1.0 - w) + y[i] * w
    }
}

#[test]
fn pixel4a_measured_preset_matches_the_measured_mtf() {
    let m = measured();
    let keep: Vec<usize> = (0..m.mtf.len())
        .filter(|i| m.freq_cyc_per_mm[*i] <= 250.0)
        .collect();
    let f: Vec<f64> = keep.iter().map(|i| m.freq_cyc_per_mm[*i]).collect();
    let y: Vec<f64> = keep.iter().map(|i| m.mtf[*i]).collect();
    let measured50 = mtf_crossing(&m.freq_cyc_per_mm, &m.mtf, 0.5).unwrap();
    let dense: Vec<f64> = (0..=300).map(|i| i as f64).collect();
    for (name, must_match) in [("pixel4a-measured", true), ("pixel4a", false)] {
        let model = preset_system_mtf(name, &f);
        let rms = (model
            .iter()
            .zip(&y)
            .map(|(a, b)| (a - b).powi(2))
            .sum::<f64>()
            / f.len() as f64)
            .sqrt();
        let m50 = mtf_crossing(&dense, &preset_system_mtf(name, &dense), 0.5).unwrap();
        let at = |fr: f64| preset_system_mtf(name, &[fr])[0];
        println!(
            "{name}: RMS {rms:.4} over {} points <= 250 cycles/mm; MTF50 {m50:.1} vs measured {measured50:.1} cycles/mm ({:+.1} %); \
             MTF at 50/100/200 cycles/mm {:.2}/{:.2}/{:.2}",
            f.len(),
            100.0 * (m50 / measured50 - 1.0),
            at(50.0),
            at(100.0),
            at(200.0)
        );
        if must_match {
            assert!(rms <= 0.03, "{name}: RMS {rms}");
            assert!(
                (m50 / measured50 - 1.0).abs() <= 0.05,
                "{name}: MTF50 {m50} vs {measured50}"
            );
        } else {
            // The paper's lens (no crosstalk) is the sharper one the issue reports.
            assert!(m50 > 1.2 * measured50, "{name}: MTF50 {m50}");
        }
    }
}

#[test]
fn fit_to_the_measured_pixel4a_mtf_needs_the_crosstalk() {
    let m = measured();
    let fit = |defocus: bool, crosstalk: bool| {
        let opts = MtfFitOptions {
            fit: FitParams { defocus, crosstalk },
            max_freq_cyc_per_mm: 250.0,
            ..MtfFitOptions::default()
        };
        let (_, fit) = fit_mtf(
            &m.freq_cyc_per_mm,
            &m.mtf,
            &SystemMtfModel::pixel4a(),
            &opts,
        )
        .unwrap();
        println!("fit defocus {defocus}, crosstalk {crosstalk}: {fit:?}");
        fit
    };
    let both = fit(true, true);
    assert!(both.rms <= 0.03, "RMS {}", both.rms);
    let (a, b) = (
        both.mtf50_fit_cyc_per_mm.unwrap(),
        both.mtf50_measured_cyc_per_mm.unwrap(),
    );
    assert!((a / b - 1.0).abs() <= 0.05, "MTF50 {a} vs {b}");
    // The preset carries these values (rounded).
    let preset = Optics::preset("pixel4a-measured").unwrap();
    assert!((preset.config().crosstalk_sigma_um - both.crosstalk_sigma_um).abs() < 0.01);
    let c4 = preset
        .wavefront_for(None, f64::INFINITY)
        .unwrap()
        .defocus_at_lens_pupil_um();
    assert!(
        (c4 - both.defocus_um).abs() < 0.002,
        "preset c4 {c4} vs fit {}",
        both.defocus_um
    );
    // Defocus alone fits worse: the measured curve's long tail needs the sensor's blur.
    let defocus_only = fit(true, false);
    assert!(defocus_only.rms > both.rms);
}
