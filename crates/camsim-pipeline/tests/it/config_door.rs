//! One config door: a config given as TOML text, as a file, as a JSON value (what a Python dict
//! becomes) or as a TOML table (a dataset sample) goes through `SimulateConfig::from_value`, so
//! every source gets the same checks and the same relative paths.

use camsim_pipeline::SimulateConfig;
use std::path::Path;

const CONFIG: &str = r#"
seed = 3
[scene]
kind = "macbeth"
illuminant = "spectra/light.csv"
[optics]
file = "lens.toml"
[sensor]
preset = "pixel4a"
rows = 48
cols = 64
"#;

#[test]
fn text_file_json_and_table_give_one_config() {
    let dir = tempfile::tempdir().unwrap();
    let base = dir.path();
    let path = base.join("run.toml");
    std::fs::write(&path, CONFIG).unwrap();
    let from_text = SimulateConfig::from_toml_str(CONFIG, base).unwrap();
    let from_file = SimulateConfig::load(&path).unwrap();
    let json: serde_json::Value =
        serde_json::to_value(toml::from_str::<toml::Value>(CONFIG).unwrap()).unwrap();
    let from_json = SimulateConfig::from_value(json, base).unwrap();
    let table: toml::Value = toml::from_str(CONFIG).unwrap();
    let from_table = SimulateConfig::from_value(table, base).unwrap();
    let as_toml = |c: &SimulateConfig| c.to_toml();
    for c in [&from_file, &from_json, &from_table] {
        assert_eq!(as_toml(c), as_toml(&from_text));
    }
    // Relative paths are the base folder's, in every door.
    assert_eq!(
        from_json.optics.file.as_deref(),
        Some(base.join("lens.toml").as_path())
    );
    let Some(camsim_scene::SceneConfig::Macbeth(m)) = &from_table.scene else {
        panic!("a macbeth scene")
    };
    assert_eq!(
        Path::new(&m.illuminant),
        base.join("spectra/light.csv").as_path()
    );
    // An empty base keeps them as written.
    let here = SimulateConfig::from_toml_str(CONFIG, Path::new("")).unwrap();
    assert_eq!(here.optics.file.as_deref(), Some(Path::new("lens.toml")));
}

#[test]
fn every_door_checks_the_scene_source_and_names_unknown_keys() {
    let both = format!("{CONFIG}\n[render]\nbuiltin = \"cornell-box\"\n");
    let neither = CONFIG.replace(
        "[scene]\nkind = \"macbeth\"\nilluminant = \"spectra/light.csv\"\n",
        "",
    );
    for text in [both.as_str(), neither.as_str()] {
        let e = SimulateConfig::from_toml_str(text, Path::new("")).unwrap_err();
        assert!(e.to_string().contains("[scene]"), "{e}");
        let json = serde_json::to_value(toml::from_str::<toml::Value>(text).unwrap()).unwrap();
        let e = SimulateConfig::from_value(json, Path::new("")).unwrap_err();
        assert!(e.to_string().contains("[scene]"), "{e}");
    }
    let e = SimulateConfig::from_value(serde_json::json!({"bogus": 1}), Path::new(""))
        .unwrap_err()
        .to_string();
    assert!(e.contains("bogus"), "{e}");
    // TOML text keeps the key's line and column.
    let e =
        SimulateConfig::from_toml_str(&CONFIG.replace("seed = 3", "seed = \"x\""), Path::new(""))
            .unwrap_err()
            .to_string();
    assert!(e.contains("line 2"), "{e}");
}

const SCENE: &str = "[scene]\nkind = \"macbeth\"\n";

#[test]
fn a_preset_is_overridden_key_by_key_in_every_door() {
    let text = format!(
        "{SCENE}[optics]\npreset = \"pixel4a\"\n[optics.config]\nf_number = 2.8\n\
         [sensor]\npreset = \"imx363\"\nrows = 48\ncols = 64\n[sensor.config]\nread_noise_mv = 0.5\n"
    );
    let base = Path::new("");
    let from_text = SimulateConfig::from_toml_str(&text, base).unwrap();
    let json = serde_json::to_value(toml::from_str::<toml::Value>(&text).unwrap()).unwrap();
    let from_json = SimulateConfig::from_value(json, base).unwrap();
    assert_eq!(from_json.to_toml(), from_text.to_toml());

    let preset_lens = camsim_optics::OpticsConfig::preset("pixel4a").unwrap();
    let lens = from_text.optics().unwrap();
    assert_eq!(lens.config().f_number, 2.8);
    // Every other key is the preset's.
    assert_eq!(lens.config().focal_length_mm, preset_lens.focal_length_mm);
    let merged = lens.config().clone();
    let mut expect = preset_lens;
    expect.f_number = 2.8;
    assert_eq!(
        toml::to_string(&merged).unwrap(),
        toml::to_string(&expect).unwrap()
    );

    let preset_sensor = camsim_sensor::Sensor::preset("imx363").unwrap();
    let sensor = from_text.sensor().unwrap();
    assert_eq!(sensor.config().read_noise_mv, 0.5);
    assert_eq!(
        sensor.config().conversion_gain_uv_per_e,
        preset_sensor.config().conversion_gain_uv_per_e
    );
    assert_eq!(
        sensor.config().pixel_pitch_um,
        preset_sensor.config().pixel_pitch_um
    );
    // The window still applies on top.
    assert_eq!((sensor.rows(), sensor.cols()), (48, 64));
    // A nested table merges key by key too: one PSF key leaves the others.
    let nested =
        format!("{SCENE}[optics]\npreset = \"pixel4a\"\n[optics.config.psf]\ntail_energy = 0.02\n");
    let c = SimulateConfig::from_toml_str(&nested, base).unwrap();
    let lens = c.optics().unwrap();
    let preset = camsim_optics::OpticsConfig::preset("pixel4a").unwrap();
    assert_eq!(lens.config().psf.tail_energy, 0.02);
    assert_eq!(lens.config().psf.oversampling, preset.psf.oversampling);
    assert_eq!(lens.config().f_number, preset.f_number);
}

#[test]
fn an_unknown_key_over_a_preset_is_refused_by_name() {
    for (section, preset) in [("optics", "pixel4a"), ("sensor", "pixel4a")] {
        let text = format!(
            "{SCENE}[{section}]\npreset = \"{preset}\"\n[{section}.config]\nf_numbr = 2.8\n"
        );
        let e = SimulateConfig::from_toml_str(&text, Path::new(""))
            .unwrap_err()
            .to_string();
        assert!(e.contains("f_numbr"), "{section}: {e}");
        // And an unknown preset is named too.
        let text =
            format!("{SCENE}[{section}]\npreset = \"nope\"\n[{section}.config]\nf_number = 2.8\n");
        let e = SimulateConfig::from_toml_str(&text, Path::new(""))
            .unwrap_err()
            .to_string();
        assert!(e.contains("nope"), "{section}: {e}");
    }
}

/// Issue 42: a key over a preset replaces the preset's way of stating the same setting. The
/// pixel4a preset says `cfa = "RGGB"`; `cfa_pattern = [["w"]]` over it is a monochrome sensor
/// (every pixel the panchromatic filter), not "give either cfa or cfa_pattern, not both".
#[test]
fn a_key_over_a_preset_replaces_the_presets_alternative_key() {
    let base = Path::new("");
    let mono = format!(
        "{SCENE}[sensor]\npreset = \"pixel4a\"\nrows = 48\ncols = 64\n[sensor.config]\ncfa_pattern = [[\"w\"]]\n"
    );
    let c = SimulateConfig::from_toml_str(&mono, base).unwrap();
    let sensor = c.sensor().unwrap();
    assert_eq!(sensor.cfa_layout().name(), "w");
    assert_eq!(sensor.cfa_layout().filters(), ["w"]);
    let preset = camsim_sensor::Sensor::preset("pixel4a").unwrap();
    assert_eq!(
        sensor.config().conversion_gain_uv_per_e,
        preset.config().conversion_gain_uv_per_e
    );
    // The same through the JSON door (a Python dict).
    let json = serde_json::to_value(toml::from_str::<toml::Value>(&mono).unwrap()).unwrap();
    let from_json = SimulateConfig::from_value(json, base).unwrap();
    assert_eq!(from_json.to_toml(), c.to_toml());
    // A CFA name over a preset's: the name wins.
    let rgbw = mono.replace("cfa_pattern = [[\"w\"]]", "cfa = \"RGBW\"");
    let s = SimulateConfig::from_toml_str(&rgbw, base)
        .unwrap()
        .sensor()
        .unwrap();
    assert_eq!(s.cfa_layout().name(), "RGBW");
    // Both in the override is still the user's contradiction, named as before.
    let both = mono.replace(
        "cfa_pattern = [[\"w\"]]",
        "cfa = \"RGGB\"\ncfa_pattern = [[\"w\"]]",
    );
    let e = SimulateConfig::from_toml_str(&both, base)
        .and_then(|c| c.sensor())
        .unwrap_err()
        .to_string();
    assert!(e.contains("not both"), "{e}");
    // analog_gain over a preset that states its gain as an ISO (pixel4a-raw10: iso = 55 at
    // base_iso 55): the gain replaces the ISO (ISETCam v_out = (v + offset) / gain).
    let gain = format!(
        "{SCENE}[sensor]\npreset = \"pixel4a-raw10\"\n[sensor.config]\nanalog_gain = 2.0\n"
    );
    let s = SimulateConfig::from_toml_str(&gain, base)
        .unwrap()
        .sensor()
        .unwrap();
    assert_eq!(s.analog_gain(), 2.0);
    assert_eq!(s.config().iso, None);
    // A QE file over a preset replaces its curves, and the correction fitted to them goes too.
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("flat.csv"),
        "wavelength_nm,r,g,b\n400,0.5,0.5,0.5\n700,0.5,0.5,0.5\n",
    )
    .unwrap();
    let qe =
        format!("{SCENE}[sensor]\npreset = \"pixel4a\"\n[sensor.config.qe]\nfile = \"flat.csv\"\n");
    let s = SimulateConfig::from_toml_str(&qe, dir.path())
        .unwrap()
        .sensor()
        .unwrap();
    assert_eq!(s.config().qe.wavelengths_nm, [400.0, 700.0]);
    assert_eq!(s.config().qe_correction, None);
}

/// `[sensor.config.binning]` over a preset: the simulate config's sensor is the binned one, and
/// its `[sensor] rows/cols` window counts output pixels.
#[test]
fn binning_over_a_preset_gives_the_binned_sensor_and_its_window() {
    let base = Path::new("");
    let text = format!(
        "{SCENE}[sensor]\npreset = \"pixel4a\"\nrows = 48\ncols = 64\n[sensor.config]\ncfa = \"quad-bayer\"\n[sensor.config.binning]\nfactor = 2\nmode = \"charge\"\n"
    );
    let s = SimulateConfig::from_toml_str(&text, base)
        .unwrap()
        .sensor()
        .unwrap();
    let preset = camsim_sensor::Sensor::preset("pixel4a").unwrap();
    assert_eq!((s.rows(), s.cols()), (48, 64));
    assert_eq!(s.pixel_pitch_m(), 2.0 * preset.pixel_pitch_m());
    assert!(s.is_bayer(), "{}", s.cfa_layout().name());
    // A Bayer preset's own CFA does not bin: the message names the key.
    let bayer = text.replace("cfa = \"quad-bayer\"\n", "");
    let e = SimulateConfig::from_toml_str(&bayer, base)
        .and_then(|c| c.sensor())
        .unwrap_err()
        .to_string();
    assert!(e.contains("binning.factor"), "{e}");
}
