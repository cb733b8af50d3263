//! Impossible sensor configs are errors whose message names the source and the key.

use camsim_sensor::{presets, Sensor};

/// The imx363 preset text with `key = value` replaced (or `extra` appended before the tables).
fn with(key: &str, value: &str) -> String {
    let text = presets::toml("imx363").unwrap();
    let mut out = String::new();
    let mut done = false;
    for line in text.lines() {
        let trimmed = line.trim_start();
        if !done && trimmed.starts_with(&format!("{key} =")) {
            out.push_str(&format!("{key} = {value}\n"));
            done = true;
        } else {
            out.push_str(line);
            out.push('\n');
        }
    }
    assert!(done, "key {key} not in the preset");
    out
}

fn error_of(text: &str) -> String {
    Sensor::from_toml_str(text, "test.toml")
        .unwrap_err()
        .to_string()
}

#[test]
fn impossible_values_name_the_key() {
    let cases = [
        ("pixel_pitch_um", "0.0"),
        ("pixel_pitch_um", "-1.4"),
        ("pixel_pitch_um", "nan"),
        ("bits", "0"),
        ("bits", "17"),
        ("fill_factor", "0.0"),
        ("fill_factor", "1.5"),
        ("voltage_swing_v", "0.0"),
        ("voltage_swing_v", "-0.4"),
        ("conversion_gain_uv_per_e", "0.0"),
        ("analog_gain", "0.0"),
        ("read_noise_mv", "-5.0"),
        ("dsnu_mv", "-1.0"),
        ("prnu_percent", "-0.7"),
        ("dark_voltage_mv_per_s", "-1.0"),
        ("well_capacity_e", "8000.0"),
        ("rows", "0"),
        ("cols", "0"),
        ("cfa", "\"RGBX\""),
    ];
    for (key, value) in cases {
        let err = error_of(&with(key, value));
        assert!(
            err.contains("test.toml") && err.contains(key),
            "{key} = {value}: {err}"
        );
    }
}

#[test]
fn bad_qe_tables_name_the_key() {
    let base = presets::toml("ideal").unwrap();
    let cases = [
        ("r = [1.0, 1.0]", "r = [1.0, nan]", "qe.r"),
        ("g = [1.0, 1.0]", "g = [1.0, -0.1]", "qe.g"),
        ("b = [1.0, 1.0]", "b = [1.0]", "qe.b"),
        (
            "wavelengths_nm = [300.0, 1100.0]",
            "wavelengths_nm = [1100.0, 300.0]",
            "qe.wavelengths_nm",
        ),
        (
            "wavelengths_nm = [300.0, 1100.0]",
            "wavelengths_nm = [300.0, 300.0]",
            "qe.wavelengths_nm",
        ),
        (
            "b = [1.0, 1.0]",
            "b = [1.0, 1.0]\nir_cut = [1.0]",
            "qe.ir_cut",
        ),
        (
            "b = [1.0, 1.0]",
            "b = [1.0, 1.0]\npixel_qe = [1.0, inf]",
            "qe.pixel_qe",
        ),
    ];
    for (from, to, key) in cases {
        let text = base.replacen(from, to, 1);
        assert_ne!(text, base);
        let err = error_of(&text);
        assert!(err.contains(key), "{to}: {err}");
    }
    // A correction that makes the QE negative.
    let text = base.replacen(
        "fixed_pattern_seed = 0",
        "fixed_pattern_seed = 0\nqe_correction = [[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0]]",
        1,
    );
    assert_ne!(text, base);
    let err = error_of(&text);
    assert!(err.contains("qe_correction"), "{err}");
}

#[test]
fn unknown_keys_and_types_are_parse_errors() {
    let text =
        presets::toml("ideal")
            .unwrap()
            .replacen("bits = 16", "bits = 16\npixel_size_um = 2.0", 1);
    let err = error_of(&text);
    assert!(
        err.contains("test.toml") && err.contains("pixel_size_um"),
        "{err}"
    );
    let text = presets::toml("ideal")
        .unwrap()
        .replacen("bits = 16", "bits = \"twelve\"", 1);
    let err = error_of(&text);
    assert!(err.contains("test.toml") && err.contains("bits"), "{err}");
    let text =
        presets::toml("ideal")
            .unwrap()
            .replacen("shot = false", "shot = false\nflicker = true", 1);
    assert!(error_of(&text).contains("flicker"));
}

#[test]
fn missing_file_names_the_path() {
    let err = Sensor::from_file("/nonexistent/sensor.toml")
        .unwrap_err()
        .to_string();
    assert!(err.contains("/nonexistent/sensor.toml"), "{err}");
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("mine.toml");
    std::fs::write(&p, with("bits", "40")).unwrap();
    let err = Sensor::from_file(&p).unwrap_err().to_string();
    assert!(err.contains("mine.toml") && err.contains("bits"), "{err}");
    std::fs::write(&p, presets::toml("pixel4a").unwrap()).unwrap();
    assert_eq!(
        Sensor::from_file(&p).unwrap(),
        Sensor::preset("pixel4a").unwrap()
    );
}
