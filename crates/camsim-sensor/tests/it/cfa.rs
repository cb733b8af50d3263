//! General colour filter arrays (RGBW, Quad Bayer, `cfa_pattern` with named filters): each
//! filter's pixels collect the closed-form electrons of its QE, and the general path reproduces
//! the Bayer path bit for bit on a Bayer-equivalent tile.

use crate::common;
use camsim_core::units::{PLANCK_J_S, SPEED_OF_LIGHT_M_PER_S};
use camsim_core::WavelengthGrid;
use camsim_sensor::{Capture, NoiseSwitches, Sensor};
use common::{quiet, uniform_image};

/// A test sensor: flat QE per filter (r 0.3, g 0.5, b 0.2, cyan 0.6 when used), IR cut 0.9, pixel QE 0.8,
/// 1 uV/e-, 16 bits over 1 V.
fn sensor(cfa_lines: &str, rows: usize, cols: usize) -> Sensor {
    let text = format!(
        r#"
name = "cfa test"
rows = {rows}
cols = {cols}
pixel_pitch_um = 2.0
fill_factor = 0.5
{cfa_lines}
conversion_gain_uv_per_e = 1.0
voltage_swing_v = 1.0
bits = 16
[qe]
wavelengths_nm = [400.0, 700.0]
r = [0.3, 0.3]
g = [0.5, 0.5]
b = [0.2, 0.2]
ir_cut = [0.9, 0.9]
pixel_qe = [0.8, 0.8]
"#
    );
    // A named filter must be used by the CFA (an unused one is refused as a likely typo).
    let text = if cfa_lines.contains("cyan") {
        text + "[qe.filters]\ncyan = [0.6, 0.6]\n"
    } else {
        text
    };
    Sensor::from_toml_str(&text, "cfa test").unwrap()
}

/// Closed form: a flat irradiance E (W m^-2 nm^-1) on the grid 400..700 nm every 10 nm through a
/// flat QE q gives q E t A / (h c) x sum_b lambda_b d lambda electrons, the sum an arithmetic
/// series n (lambda_0 + lambda_last) / 2 x d lambda.
fn closed_form_e(q: f64, e_w_m2_nm: f64, t_s: f64, area_m2: f64) -> f64 {
    let sum_lambda_dl_m_nm = 31.0 * (400e-9 + 700e-9) / 2.0 * 10.0;
    q * e_w_m2_nm * t_s * area_m2 * sum_lambda_dl_m_nm / (PLANCK_J_S * SPEED_OF_LIGHT_M_PER_S)
}

#[test]
fn each_filter_collects_its_closed_form_electrons() {
    let grid = WavelengthGrid::new(400.0, 700.0, 10.0).unwrap();
    let (e_irr, t_s) = (0.02, 0.01);
    let area_m2 = (2e-6f64).powi(2) * 0.5;
    let transmit = 0.9 * 0.8;
    for (cfa, expect) in [
        (
            "cfa = \"RGBW\"",
            vec![("r", 0.3), ("g", 0.5), ("b", 0.2), ("w", 1.0)],
        ),
        (
            "cfa = \"quad-bayer\"",
            vec![("r", 0.3), ("g", 0.5), ("b", 0.2)],
        ),
        (
            "cfa_pattern = [[\"cyan\", \"white\", \"g\"], [\"red\", \"cyan\", \"b\"]]",
            vec![("r", 0.3), ("g", 0.5), ("b", 0.2), ("c", 0.6), ("w", 1.0)],
        ),
    ] {
        // 30 x 30: not a multiple of the Quad Bayer tile.
        let s = sensor(cfa, 30, 30).with_noise(quiet(true));
        let layout = s.cfa_layout();
        assert_eq!(layout.filters().len(), expect.len(), "{cfa}");
        // Same spacing as the pixels (one sample per pixel) and a finer one (area integration).
        for spacing_m in [2e-6, 0.5e-6] {
            let n = (60e-6 / spacing_m) as usize;
            let img = uniform_image(n, n, grid, spacing_m, &vec![e_irr; grid.len()]);
            let frame = s.compute(&img, &Capture::seconds(t_s)).unwrap();
            let raw = &frame.raw[0];
            assert_eq!(raw.layout.as_ref(), Some(&layout));
            let analog = &frame.analog_dn.as_ref().unwrap()[0];
            let dn_per_e = 1e-6 * s.dn_per_v();
            for (name, q) in &expect {
                let want_e = closed_form_e(q * transmit, e_irr, t_s, area_m2);
                let f = layout.filter_index(name).unwrap();
                let got_mean = frame.mean_electrons_by_filter[f];
                assert!(
                    (got_mean / want_e - 1.0).abs() < 1e-5,
                    "{cfa} {name}: {got_mean} e- vs closed form {want_e}"
                );
                for r in 0..raw.rows {
                    for c in 0..raw.cols {
                        if layout.filter_at(r, c) == f {
                            let e = analog[r * raw.cols + c] as f64 / dn_per_e;
                            assert!(
                                (e / want_e - 1.0).abs() < 1e-4,
                                "{cfa} {name} pixel ({r}, {c}): {e} e- vs {want_e}"
                            );
                        }
                    }
                }
            }
            let from_model = s
                .mean_electrons_uniform_filters(&vec![e_irr; grid.len()], &grid, t_s)
                .unwrap();
            for (a, b) in from_model.iter().zip(&frame.mean_electrons_by_filter) {
                assert!((a / b - 1.0).abs() < 1e-5);
            }
        }
    }
}

#[test]
fn general_path_matches_the_bayer_path_bit_for_bit() {
    // A 2 x 4 tile that repeats RGGB is not the 2x2 Bayer layout object, so it runs the general
    // path; with every noise source on it must give exactly the Bayer sensor's DN.
    let bayer = sensor("cfa = \"RGGB\"", 24, 40);
    let general = sensor(
        "cfa_pattern = [[\"r\", \"g\", \"r\", \"g\"], [\"g\", \"b\", \"g\", \"b\"]]",
        24,
        40,
    );
    assert!(bayer.is_bayer() && !general.is_bayer());
    let noisy = NoiseSwitches {
        shot: true,
        read: true,
        dsnu: true,
        prnu: true,
        dark: true,
        quantization: true,
    };
    let (bayer, general) = (bayer.with_noise(noisy), general.with_noise(noisy));
    let grid = WavelengthGrid::new(400.0, 700.0, 10.0).unwrap();
    for spacing_m in [2e-6, 0.7e-6] {
        let n = (90e-6 / spacing_m) as usize;
        let mut img = uniform_image(n, n, grid, spacing_m, &vec![0.01; grid.len()]);
        for (b, plane) in img.bands_mut().enumerate() {
            for (i, v) in plane.iter_mut().enumerate() {
                *v *= 1.0 + ((i * 7 + b * 3) % 11) as f32 * 0.1;
            }
        }
        let cap = Capture::seconds(0.02).with_seed(5);
        let a = bayer.compute(&img, &cap).unwrap();
        let b = general.compute(&img, &cap).unwrap();
        assert_eq!(a.raw[0].dn, b.raw[0].dn, "spacing {spacing_m}");
        assert!(a.raw[0].dn.iter().any(|v| *v > 100));
        assert_eq!(
            a.mean_electrons_by_filter.len(),
            b.mean_electrons_by_filter.len()
        );
        for (x, y) in a
            .mean_electrons_by_filter
            .iter()
            .zip(&b.mean_electrons_by_filter)
        {
            assert!((x / y - 1.0).abs() < 1e-9);
        }
    }
}

#[test]
fn bad_cfa_configs_name_the_key() {
    let base = |cfa: &str| {
        format!(
            "name = \"x\"\nrows = 4\ncols = 4\npixel_pitch_um = 1.0\nfill_factor = 1.0\n{cfa}\nconversion_gain_uv_per_e = 1.0\nvoltage_swing_v = 1.0\nbits = 12\n[qe]\nwavelengths_nm = [400.0, 700.0]\nr = [1.0, 1.0]\ng = [1.0, 1.0]\nb = [1.0, 1.0]\n"
        )
    };
    for (cfa, key, words) in [
        (
            "cfa_pattern = [[\"r\", \"ir\"], [\"g\", \"b\"]]",
            "cfa_pattern",
            "'ir' has no transmittance",
        ),
        (
            "cfa = \"RGGB\"\ncfa_pattern = [[\"r\", \"g\"], [\"g\", \"b\"]]",
            "cfa",
            "not both",
        ),
        ("cfa = \"RGBX\"", "cfa", "quad-bayer"),
        (
            "cfa_pattern = [[\"r\", \"g\", \"b\"], [\"g\"]]",
            "cfa_pattern",
            "row 1 has 1 cells",
        ),
        ("cfa_pattern = []", "cfa_pattern", "empty"),
    ] {
        let err = Sensor::from_toml_str(&base(cfa), "bad.toml")
            .unwrap_err()
            .to_string();
        assert!(
            err.contains(key) && err.contains(words) && err.contains("bad.toml"),
            "{cfa}: {err}"
        );
    }
}

#[test]
fn qe_file_extra_columns_are_named_filters() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("qe.csv"),
        "wavelength_nm,r,g,b,cyan,ir_cut\n400,0.3,0.5,0.2,0.6,0.9\n700,0.3,0.5,0.2,0.6,0.9\n",
    )
    .unwrap();
    let text = |cfa: &str| {
        format!(
            "name = \"x\"\nrows = 4\ncols = 4\npixel_pitch_um = 2.0\nfill_factor = 0.5\n{cfa}\nconversion_gain_uv_per_e = 1.0\nvoltage_swing_v = 1.0\nbits = 16\n[qe]\nfile = \"qe.csv\"\n"
        )
    };
    let path = dir.path().join("s.toml");
    std::fs::write(
        &path,
        text("cfa_pattern = [[\"r\", \"cyan\"], [\"g\", \"b\"]]"),
    )
    .unwrap();
    let s = Sensor::from_file(&path).unwrap();
    let layout = s.cfa_layout();
    let c = layout.filter_index("cyan").unwrap();
    // Filter QE = column x IR cut (no pixel QE column: 1).
    assert!((s.filter_qe_spectra()[c].eval(500.0) - 0.6 * 0.9).abs() < 1e-12);
    // The same file under a Bayer CFA: the unused column is refused, naming it and the file.
    std::fs::write(&path, text("cfa = \"RGGB\"")).unwrap();
    let err = Sensor::from_file(&path).unwrap_err().to_string();
    assert!(
        err.contains("column 'c'") && err.contains("qe.csv") && err.contains("RGGB"),
        "{err}"
    );
}
