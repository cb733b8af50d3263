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

/// The camera sampler's view validation, through `simulate`: every object the sampler counted
/// as visible is seen in the capture's own labels (the renderer's instance map), and as many of
/// them as the spec asked for: the sampler validates the frame the capture has (the lens and
/// sensor's field of view, set before composing), not the scene file's.
#[test]
fn the_sampled_view_shows_the_objects_its_validation_counted() {
    let dir = tempfile::tempdir().unwrap();
    let trimesh = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../../shared/assets/trimesh"
    );
    let table = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../examples/pbrt/tabletop.pbrt"
    );
    std::fs::write(
        dir.path().join("assets.csv"),
        format!("path,category,scale_to_m\n{trimesh}/cube.OBJ,crate,0.03\n"),
    )
    .unwrap();
    let path = dir.path().join("t.toml");
    std::fs::write(
        &path,
        format!(
            r#"
seed = 3
[wavelengths]
start_nm = 400.0
step_nm = 50.0
count = 7
[render]
pbrt = "{table}"
samples_per_pixel = 1
[render.compose]
assets = ["assets.csv"]
[[render.compose.spawn]]
count = [5, 5]
on = {{ point_m = [0.0, 0.75, 0.0], normal = [0.0, 1.0, 0.0], extent_m = [0.4, 0.4] }}
min_separation_m = 0.03
[render.compose.environment]
kind = "sky"
[render.compose.camera]
distance_m = [0.5, 0.9]
elevation_deg = [25.0, 60.0]
min_visible_objects = 4
min_visible_fraction = 0.6
[optics.config]
f_number = 2.8
focal_length_mm = 0.5
shading = "none"
[sensor]
preset = "pixel4a"
rows = 72
cols = 96
[capture]
exposure_ms = 1.0
"#
        ),
    )
    .unwrap();
    let cfg = SimulateConfig::load(&path).unwrap();
    let opts = camsim_pipeline::SimulateOptions {
        labels: Some(camsim_render::LabelRequest::default()),
        ..Default::default()
    };
    let sim = camsim_pipeline::simulate(&cfg, &opts, &|_, _, _| {}).unwrap();
    let rec = sim.compose.as_ref().unwrap();
    let cam = rec.camera.as_ref().expect("a camera record");
    assert!(cam.visible_objects.unwrap() >= 4, "{cam:?}");
    let labels = &sim.labels.as_ref().unwrap().scene;
    let mut seen = 0;
    for o in cam.objects.iter().filter(|o| o.fraction >= 0.6) {
        let inst = labels
            .instances
            .iter()
            .find(|i| i.name == o.object)
            .unwrap_or_else(|| panic!("{} has no instance", o.object));
        // At 96 x 72 a 3 cm crate 0.5-0.9 m away covers tens of render pixels.
        assert!(
            inst.visible_px >= 4,
            "{}: the sampler saw {:.2} of it, the capture {} px",
            o.object,
            o.fraction,
            inst.visible_px
        );
        seen += 1;
    }
    assert!(seen >= 4);
}
