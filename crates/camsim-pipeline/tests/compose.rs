//! `[render.compose]` in a simulate config: applied in `render_section_scene` after the
//! overlays, with the config's seed, its relative paths resolved against the config's folder.

use camsim_pipeline::render::render_section_scene_with_record;
use camsim_pipeline::SimulateConfig;

fn config(dir: &std::path::Path, seed: u64) -> SimulateConfig {
    let trimesh = std::path::PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../../shared/assets/trimesh"
    ));
    std::fs::write(
        dir.join("assets.csv"),
        format!(
            "path,category,scale_to_m\n{}/cube.OBJ,crate,0.08\n",
            trimesh.display()
        ),
    )
    .unwrap();
    let path = dir.join("scene.toml");
    std::fs::write(
        &path,
        format!(
            r#"
seed = {seed}
[render]
builtin = "cornell-box"
resolution = [32, 32]
samples_per_pixel = 1
[render.compose]
assets = ["assets.csv"]
[[render.compose.spawn]]
count = [3, 3]
on = "floor"
min_separation_m = 0.02
[render.compose.physics]
max_steps = 400
"#
        ),
    )
    .unwrap();
    SimulateConfig::load(&path).unwrap()
}

#[test]
fn render_compose_spawns_on_the_builtin_floor_from_the_configs_folder() {
    let dir = tempfile::tempdir().unwrap();
    let scene_of = |seed: u64| {
        let cfg = config(dir.path(), seed);
        let r = cfg.render.clone().unwrap();
        render_section_scene_with_record(&r, &cfg, &cfg.sensor().unwrap(), &cfg.optics().unwrap())
            .unwrap()
    };
    let (scene, rec) = scene_of(5);
    let rec = rec.expect("a compose record");
    assert_eq!(rec.seed, 5);
    assert_eq!(rec.objects.len(), 3);
    for (k, o) in rec.objects.iter().enumerate() {
        assert_eq!(o.name, format!("crate_{k}"));
        let shapes: Vec<_> = scene
            .shapes
            .iter()
            .filter(|s| s.name.as_deref() == Some(o.name.as_str()))
            .collect();
        assert!(!shapes.is_empty(), "{} is not in the scene", o.name);
        for s in shapes {
            assert_eq!(s.tags.category.as_deref(), Some("crate"));
            assert!(s.tags.instance.is_some());
        }
        // On the floor (y = 0): a 0.08 m cube's centre rests 0.04 m up.
        assert!((o.translation_m[1] - 0.04).abs() < 1e-3, "{o:?}");
    }
    // The record serialises for the sample record (run.json's `compose`).
    let json = serde_json::to_string(&rec).unwrap();
    assert!(json.contains("\"crate_0\"") && json.contains("rotation_wxyz"));
    // Another seed composes another scene.
    let (_, rec6) = scene_of(6);
    assert_ne!(rec6.unwrap().objects, rec.objects);
}
