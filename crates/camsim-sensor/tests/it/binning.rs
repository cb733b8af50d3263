//! Charge versus digital binning (issue 42 item 3), against the closed forms of `binning`'s
//! module docs, on ISETCam's MT9V024 (mono, 6 um, 110 uV/e-, 2.8 V swing, 1 mV read noise,
//! 10 bits: K = 0.0402 DN/e-, read noise 0.366 DN):
//! - temporal noise (two frames, var(a - b) / 2): a photodiode at mu e- has
//!   K^2 mu + s_dn^2 + 1/12 DN^2; a charge-binned 2 x 2 block K^2 4 mu + s_dn^2 + 1/12 (one
//!   readout, one rounding), a digitally binned one K^2 4 mu + 4 s_dn^2 + 4/12 (four of each);
//!   both 4x one photodiode's mean;
//! - fixed pattern in the dark (above a black-level pedestal): DSNU d across pixels (charge) and 2 d (digital); PRNU u / 2 at a
//!   flat light (both); dark electrons 4x a photodiode's;
//! - the well: a block at half a photodiode's well each saturates a charge-binned pixel (the
//!   shared readout holds one well) and reads half scale digitally; a binned readout gain of
//!   g / 4 holds it.

use crate::common;
use camsim_core::{SpectralImage, WavelengthGrid};
use camsim_sensor::{Capture, NoiseSwitches, Sensor, SensorConfig};
use common::uniform_image;

/// Photodiodes of the window (binned: 128 x 128 output pixels).
const N: usize = 256;

fn mono(f: impl FnOnce(&mut SensorConfig)) -> Sensor {
    let mut c = Sensor::preset("mt9v024-mono").unwrap().config().clone();
    c.rows = N;
    c.cols = N;
    f(&mut c);
    Sensor::from_config(c).unwrap()
}

fn binned(mode: &str, noise: NoiseSwitches, extra: &str) -> Sensor {
    let text = format!("factor = 2\nmode = \"{mode}\"\n{extra}");
    mono(|c| {
        c.noise = noise;
        c.binning = Some(toml::from_str(&text).unwrap());
    })
}

/// A flat light over the 1.5 mm square every sensor here covers, W / (m^2 nm).
fn flat(level: f64) -> SpectralImage {
    let grid = WavelengthGrid::default();
    uniform_image(N, N, grid, 6e-6, &vec![level; grid.len()])
}

fn temporal_only() -> NoiseSwitches {
    NoiseSwitches {
        shot: true,
        read: true,
        dsnu: false,
        prnu: false,
        dark: false,
        quantization: true,
    }
}

/// Mean DN above black, the temporal variance var(a - b) / 2 (DN^2), and the noise-free mean
/// electrons of two frames of `s` at `irr`, 1 ms.
fn two_frames(s: &Sensor, irr: &SpectralImage) -> (f64, f64, f64) {
    let f = s
        .compute(irr, &Capture::seconds(1e-3).with_frames(2).with_seed(7))
        .unwrap();
    let (a, b) = (&f.raw[0].dn, &f.raw[1].dn);
    let n = a.len() as f64;
    let black = f.raw[0].black_level_dn;
    let mean = a.iter().chain(b).map(|v| *v as f64).sum::<f64>() / (2.0 * n) - black;
    let d: Vec<f64> = a
        .iter()
        .zip(b)
        .map(|(x, y)| *x as f64 - *y as f64)
        .collect();
    let dm = d.iter().sum::<f64>() / n;
    let var = d.iter().map(|v| (v - dm).powi(2)).sum::<f64>() / (n - 1.0) / 2.0;
    (mean, var, f.mean_electrons_by_filter[0])
}

fn rel(a: f64, b: f64) -> f64 {
    (a / b - 1.0).abs()
}

#[test]
fn charge_binning_reads_once_and_digital_binning_sums_four_reads() {
    let one = mono(|c| c.noise = temporal_only());
    let k_dn_per_e: f64 = 110e-6 * 1024.0 / 2.8;
    let read_dn: f64 = 1e-3 * 1024.0 / 2.8;
    // About 100 e- per photodiode in 1 ms: shot and read noise of the same size.
    let irr = flat(8e-6);
    let (m1, v1, mu) = two_frames(&one, &irr);
    assert!((60.0..160.0).contains(&mu), "{mu} e- per photodiode");
    let pred1 = k_dn_per_e.powi(2) * mu + read_dn.powi(2) + 1.0 / 12.0;
    println!(
        "photodiode: mean {m1:.3} DN ({:.3}), var {v1:.4} DN^2 ({pred1:.4})",
        k_dn_per_e * mu
    );
    assert!(rel(v1, pred1) < 0.05, "one photodiode: {v1} vs {pred1}");
    for (mode, reads) in [("charge", 1.0), ("digital", 4.0)] {
        let s = binned(mode, temporal_only(), "");
        assert_eq!((s.rows(), s.cols()), (N / 2, N / 2), "{mode}: output grid");
        assert!(rel(s.pixel_pitch_m(), 12e-6) < 1e-12, "{mode}: pitch");
        let (m, v, mu4) = two_frames(&s, &irr);
        assert!(rel(mu4, 4.0 * mu) < 1e-3, "{mode}: {mu4} e- vs 4 x {mu}");
        assert!(rel(m, 4.0 * m1) < 0.01, "{mode}: mean {m} vs 4 x {m1}");
        let pred = k_dn_per_e.powi(2) * 4.0 * mu + reads * (read_dn.powi(2) + 1.0 / 12.0);
        println!("{mode}: mean {m:.3} DN, var {v:.4} DN^2 ({pred:.4})");
        assert!(
            rel(v, pred) < 0.05,
            "{mode}: temporal variance {v} vs {pred}"
        );
    }
}

#[test]
fn binned_fixed_patterns_and_dark_current() {
    let fixed = |dsnu: bool, prnu: bool| NoiseSwitches {
        shot: false,
        read: false,
        dsnu,
        prnu,
        dark: true,
        quantization: false,
    };
    // Spatial standard deviation (DN) and mean of the unrounded values above black.
    let spread = |s: &Sensor, irr: &SpectralImage| {
        let f = s
            .compute(irr, &Capture::seconds(1e-3).with_seed(3))
            .unwrap();
        let a = &f.analog_dn.as_ref().unwrap()[0];
        let n = a.len() as f64;
        let m = a.iter().map(|v| *v as f64).sum::<f64>() / n;
        let var = a.iter().map(|v| (*v as f64 - m).powi(2)).sum::<f64>() / (n - 1.0);
        (
            var.sqrt(),
            m - f.raw[0].black_level_dn,
            f.mean_electrons_by_filter[0],
        )
    };
    let dn_per_mv = 1024.0 / 2.8 / 1e3;
    let dark = flat(0.0);
    let (_, _, dark1) = spread(&mono(|c| c.noise = fixed(false, false)), &dark);
    for (mode, dsnu_scale) in [("charge", 1.0), ("digital", 2.0)] {
        // DSNU 2 mV: one readout's offset (charge) or the sum of four (digital).
        let s = binned(mode, fixed(true, false), "");
        let s = Sensor::from_config(SensorConfig {
            dsnu_mv: 2.0 * dsnu_scale,
            // A pedestal keeps the offsets below zero light.
            black_level_dn: 32.0,
            ..s.config().clone()
        })
        .unwrap();
        let want = 2.0 * dsnu_scale * dn_per_mv;
        let (sd, _, _) = spread(&s, &dark);
        println!("{mode}: DSNU {sd:.4} DN ({want:.4})");
        assert!(rel(sd, want) < 0.05, "{mode}: DSNU {sd} vs {want}");
        // Four photodiodes' dark current.
        let (_, _, dark4) = spread(&binned(mode, fixed(false, false), ""), &dark);
        assert!(
            rel(dark4, 4.0 * dark1) < 1e-9,
            "{mode}: dark {dark4} vs 4 x {dark1}"
        );
        // PRNU 2 % of the photodiodes: 1 % of a block (the mean of four gains).
        let p = mono(|c| {
            c.noise = fixed(false, true);
            c.prnu_percent = 2.0;
            c.binning = Some(toml::from_str(&format!("factor = 2\nmode = \"{mode}\"")).unwrap());
        });
        let (sd, m, _) = spread(&p, &flat(1e-4));
        println!("{mode}: PRNU {:.3} % (1 %)", 100.0 * sd / m);
        assert!(rel(sd / m, 0.01) < 0.05, "{mode}: PRNU {}", sd / m);
    }
}

#[test]
fn a_charge_binned_block_holds_one_well_unless_its_readout_gain_is_lower() {
    let quiet = common::quiet(true);
    let one = mono(|c| c.noise = quiet);
    // Half a photodiode's well (25 455 e-) in each photodiode.
    let probe = one.compute(&flat(1e-4), &Capture::seconds(1e-3)).unwrap();
    let per_e = probe.mean_electrons_by_filter[0] / 1e-3;
    let t = 0.5 * 2.8 / 110e-6 / per_e;
    let level = |s: &Sensor| {
        let f = s.compute(&flat(1e-4), &Capture::seconds(t)).unwrap();
        let a = &f.analog_dn.as_ref().unwrap()[0];
        a.iter().map(|v| *v as f64).sum::<f64>() / a.len() as f64 / s.max_dn() as f64
    };
    let full = 1023.0 / 1024.0;
    assert!(
        rel(level(&one), 0.5 * 1024.0 / 1023.0) < 1e-3,
        "half a well"
    );
    let charge = level(&binned("charge", quiet, ""));
    assert!(
        rel(charge, 1024.0 / 1023.0) < 1e-3 || charge >= full,
        "charge saturates: {charge}"
    );
    // The sum of four wells reads at half scale, 12 bits.
    let digital = binned("digital", quiet, "");
    assert_eq!(digital.bits(), 12);
    assert!(
        rel(level(&digital), 0.5 * 4096.0 / 4095.0) < 1e-3,
        "digital"
    );
    // A readout at a quarter of the gain holds the block: half scale again.
    let low = binned("charge", quiet, "conversion_gain_uv_per_e = 27.5");
    assert!(
        rel(level(&low), 0.5 * 1024.0 / 1023.0) < 1e-3,
        "low-gain readout"
    );
}

#[test]
fn quad_bayer_bins_to_bayer_and_mixed_blocks_are_refused() {
    let mut c = Sensor::preset("pixel4a").unwrap().config().clone();
    c.rows = 64;
    c.cols = 96;
    c.cfa = "quad-bayer".into();
    c.binning = Some(toml::from_str("factor = 2\nmode = \"charge\"").unwrap());
    let s = Sensor::from_config(c.clone()).unwrap();
    assert_eq!((s.rows(), s.cols()), (32, 48));
    assert_eq!(
        s.cfa_layout().as_bayer().map(|p| p.name()),
        Some("RGGB"),
        "{}",
        s.cfa_layout().name()
    );
    // The binned sensor writes itself as its output pixels, and reads back the same.
    let back = Sensor::from_toml_str(&s.to_toml(), "round trip").unwrap();
    assert_eq!(back.config(), s.config());
    // A Bayer tile's 2 x 2 block mixes filters; a 3 x 3 digital sum; 16-bit overflow; HDR.
    let refused = |f: &dyn Fn(&mut SensorConfig), key: &str, says: &str| {
        let mut c = c.clone();
        f(&mut c);
        let e = Sensor::from_config(c).unwrap_err().to_string();
        assert!(e.contains(key) && e.contains(says), "{e}");
    };
    refused(
        &|c| c.cfa = "RGGB".into(),
        "binning.factor",
        "holds filters r and g",
    );
    refused(
        &|c| c.binning = Some(toml::from_str("factor = 3\nmode = \"digital\"").unwrap()),
        "binning.factor",
        "power of two",
    );
    refused(
        &|c| {
            c.binning = Some(toml::from_str("factor = 8\nmode = \"digital\"").unwrap());
            c.cfa = String::new();
            c.cfa_pattern = Some(vec![vec!["w".into()]]);
            c.bits = 12;
        },
        "binning.factor",
        "needs 18 bits",
    );
    refused(
        &|c| {
            c.binning = Some(
                toml::from_str("factor = 2\nmode = \"digital\"\nconversion_gain_uv_per_e = 20.0")
                    .unwrap(),
            )
        },
        "binning.conversion_gain_uv_per_e",
        "digital",
    );
    let mut h = Sensor::preset("imx490").unwrap().config().clone();
    h.binning = c.binning;
    let e = Sensor::from_config(h).unwrap_err().to_string();
    assert!(e.contains("binning.mode") && e.contains("[hdr]"), "{e}");
    let e = toml::from_str::<camsim_sensor::BinningConfig>("factor = 2\nmode = \"analog\"")
        .unwrap_err()
        .to_string();
    assert!(e.contains("charge") && e.contains("digital"), "{e}");
}
