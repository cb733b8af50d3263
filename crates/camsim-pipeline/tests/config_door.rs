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
