//! The ISO 18844 glare target (`kind = "glare_target"`): the hole's area and the surround's
//! luminance against their closed forms, a grid of holes, bad keys named.

use camsim_scene::{create, GlareTargetScene, SceneConfig};

#[test]
fn glare_target_hole_area_and_levels() {
    let cfg = SceneConfig::from_toml(
        "kind = \"glare_target\"\nrows = 128\ncols = 160\nhole_diameter_px = 40\nmean_luminance_cd_m2 = 100\n",
        "test",
    )
    .unwrap();
    assert_eq!(cfg.kind(), "glare_target");
    let grid = cfg.grid();
    let img = create(&cfg, &grid).unwrap();
    let (rows, cols) = (img.rows, img.cols);
    assert_eq!((rows, cols), (128, 160));
    let band = &img.data[..rows * cols];
    let surround = band[0] as f64;
    // Dark area (hole reflectance 0) in pixel units: pi r^2 within 0.2 %.
    let dark: f64 = band.iter().map(|v| 1.0 - *v as f64 / surround).sum();
    let want = std::f64::consts::PI * 20.0 * 20.0;
    assert!((dark / want - 1.0).abs() < 2e-3, "{dark} vs {want}");
    // Hole centre: black.
    assert_eq!(band[64 * cols + 80], 0.0);
    // The surround's luminance: mean / (1 - hole fraction).
    let lum = camsim_scene::mean_luminance_cd_m2(&img);
    assert!((lum - 100.0).abs() < 1e-3, "{lum}");
}

#[test]
fn glare_target_grid_and_bad_keys() {
    let t = GlareTargetScene {
        rows: 200,
        cols: 200,
        hole_diameter_px: 20.0,
        holes: 3,
        pitch_px: 60.0,
        ..GlareTargetScene::default()
    };
    let c = t.hole_centres();
    assert_eq!(c.len(), 9);
    assert_eq!(c[0], (40.0, 40.0));
    assert_eq!(c[8], (160.0, 160.0));
    let cfg = SceneConfig::GlareTarget(t.clone());
    let img = create(&cfg, &cfg.grid()).unwrap();
    let band = &img.data[..200 * 200];
    for (x, y) in c {
        assert_eq!(band[(y as usize) * 200 + x as usize], 0.0);
    }
    let bad = |t: GlareTargetScene| {
        let cfg = SceneConfig::GlareTarget(t);
        create(&cfg, &cfg.grid()).unwrap_err().to_string()
    };
    let e = bad(GlareTargetScene {
        pitch_px: 10.0,
        ..t.clone()
    });
    assert!(e.contains("scene.pitch_px"), "{e}");
    let e = bad(GlareTargetScene {
        hole_diameter_px: -1.0,
        ..t.clone()
    });
    assert!(e.contains("scene.hole_diameter_px"), "{e}");
    let e = bad(GlareTargetScene {
        surround_reflectance: 0.0,
        ..t
    });
    assert!(e.contains("scene.surround_reflectance"), "{e}");
}
