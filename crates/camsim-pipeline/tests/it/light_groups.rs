//! `[render] light_groups` end to end (issue 29): weighing every group by 2 gives the raw of the
//! scene whose lights the overlay scales by 2 (the same seed draws the same samples: equal to the
//! ADC's rounding), a sky at weight 0 leaves only the lamp's light, and a weight naming no group
//! of the scene is refused with its key.

use camsim_pipeline::{simulate, SimulateConfig, SimulateOptions};

const SCENE: &str = r#"LookAt 0 3 -3  0 0 0  0 1 0
Camera "perspective" "float fov" 40
Film "rgb" "integer xresolution" 64 "integer yresolution" 48
WorldBegin
LightSource "infinite" "rgb L" [0.3 0.4 0.6] "string lightgroup" "sky"
AttributeBegin
  #ObjectName lamp
  AreaLightSource "diffuse" "rgb L" [8 7 5] "string lightgroup" "lamp"
  Shape "trianglemesh" "point3 P" [-0.3 1.5 -0.3  0.3 1.5 -0.3  0.3 1.5 0.3  -0.3 1.5 0.3]
    "integer indices" [0 1 2 0 2 3]
AttributeEnd
Material "diffuse" "rgb reflectance" [0.5 0.5 0.5]
Shape "trianglemesh" "point3 P" [-3 0 -3  3 0 -3  3 0 3  -3 0 3] "integer indices" [0 2 1 0 3 2]
"#;

fn run(render_extra: &str) -> Result<camsim_pipeline::Simulation, String> {
    let dir = tempfile::tempdir().unwrap();
    let pbrt = dir.path().join("scene.pbrt");
    std::fs::write(&pbrt, SCENE).unwrap();
    let text = format!(
        r#"seed = 4
[render]
pbrt = "{}"
samples_per_pixel = 8
{render_extra}
[sensor]
preset = "pixel4a"
rows = 48
cols = 64
[capture]
exposure_ms = 40.0
"#,
        pbrt.display()
    );
    let cfg = SimulateConfig::from_toml_str(&text, std::path::Path::new(""))
        .map_err(|e| e.to_string())?;
    let opts = SimulateOptions {
        noise_free: true,
        ..Default::default()
    };
    simulate(&cfg, &opts, &|_, _, _| {}).map_err(|e| e.to_string())
}

#[test]
fn weighted_groups_equal_scaled_lights_through_the_pipeline() {
    let weighted = run("light_groups = { sky = 2.0, lamp = 2.0 }").unwrap();
    let scaled = run("[render.overlay_inline.light]\nradiance_scale = 2.0").unwrap();
    let (a, b) = (
        weighted.noise_free_frame(0).unwrap(),
        scaled.noise_free_frame(0).unwrap(),
    );
    let worst = a
        .iter()
        .zip(b)
        .map(|(x, y)| ((x - y) / y.max(1.0)).abs())
        .fold(0f32, f32::max);
    assert!(worst < 1e-4, "largest relative difference {worst}");

    // The sky off: less light everywhere, and the floor under the lamp still lit.
    let night = run("light_groups = { sky = 0.0 }").unwrap();
    let plain = run("").unwrap();
    let (n, p) = (
        night.noise_free_frame(0).unwrap(),
        plain.noise_free_frame(0).unwrap(),
    );
    let (sn, sp): (f64, f64) = (
        n.iter().map(|v| *v as f64).sum(),
        p.iter().map(|v| *v as f64).sum(),
    );
    assert!(
        sn < 0.95 * sp && sn > 0.05 * sp,
        "night {sn} against day {sp}"
    );

    let e = run("light_groups = { headlights = 1.0 }").unwrap_err();
    assert!(
        e.contains("render.light_groups.headlights") && e.contains("lamp, sky"),
        "{e}"
    );
}
