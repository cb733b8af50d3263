//! ISETCam's HDR lights (`kind = "hdr_lights"`): each disc's lit area against pi r^2, each bar's
//! against its length x width, a lit pixel's radiance against a uniform white field of the
//! lights' luminance (the uniform scene's own normalization), the ground at its reflectance, and
//! bad keys named.

use camsim_scene::{create, SceneConfig};

fn scene(extra: &str) -> camsim_core::SpectralImage {
    let cfg = SceneConfig::from_toml(&format!("kind = \"hdr_lights\"\n{extra}"), "test").unwrap();
    create(&cfg, &cfg.grid()).unwrap()
}

#[test]
fn hdr_lights_areas_and_levels() {
    // 400 px: discs of radius 4, 14, 28, 40 px at row 100, columns 80, 160, 240, 320; bars of
    // 40 x 2 px at row 200, columns 40, 133.3, 226.7, 320 (the ISETCam layout).
    let img = scene("size_px = 400\nlight_luminance_cd_m2 = 2e4\nbackground_reflectance = 1e-4\n");
    let n = 400;
    let band = &img.data[..n * n];
    let lit = band[100 * n + 320] as f64;
    let bg = band[0] as f64;
    assert!(
        (bg / lit / 1e-4 - 1.0).abs() < 1e-4,
        "ground {bg} vs lights {lit}"
    );
    // Lit area (fraction of a lit pixel above the ground) inside each disc's bounding square.
    let area = |r0: usize, r1: usize, c0: usize, c1: usize| -> f64 {
        (r0..r1)
            .flat_map(|r| (c0..c1).map(move |c| (r, c)))
            .map(|(r, c)| (band[r * n + c] as f64 - bg) / (lit - bg))
            .sum()
    };
    for (c, r) in [(80.0, 4.0), (160.0, 14.0), (240.0, 28.0), (320.0, 40.0)] {
        let (lo, hi) = ((c - r - 2.0) as usize, (c + r + 2.0) as usize);
        let (rlo, rhi) = ((100.0 - r - 2.0) as usize, (100.0 + r + 2.0) as usize);
        let got = area(rlo, rhi, lo, hi);
        let want = std::f64::consts::PI * r * r;
        assert!(
            (got / want - 1.0).abs() < 0.01,
            "disc r {r}: {got} vs {want}"
        );
    }
    let bars = area(196, 204, 0, n);
    assert!(
        (bars / (4.0 * 40.0 * 2.0) - 1.0).abs() < 1e-3,
        "bars {bars}"
    );
    // A lit pixel is a uniform white field of the lights' luminance.
    let cfg = SceneConfig::from_toml(
        "kind = \"uniform\"\nmean_luminance_cd_m2 = 2e4\nrows = 4\ncols = 4\nreflectance = 1.0\n",
        "test",
    )
    .unwrap();
    let white = create(&cfg, &cfg.grid()).unwrap();
    for (b, plane) in img.data.chunks(n * n).enumerate() {
        let (got, want) = (plane[100 * n + 320] as f64, white.data[b * 16] as f64);
        assert!((got / want - 1.0).abs() < 1e-4, "band {b}: {got} vs {want}");
    }
}

#[test]
fn hdr_lights_bad_keys_are_named() {
    for (extra, key) in [
        ("circle_radii = [0.7]", "scene.circle_radii"),
        ("circle_radii = []\nlines = 0", "scene.circle_radii"),
        ("lines = 40", "scene.lines"),
        (
            "background_reflectance = 1.0",
            "scene.background_reflectance",
        ),
        ("light_luminance_cd_m2 = 0", "scene.light_luminance_cd_m2"),
        ("mean_luminance_cd_m2 = 5", "scene.light_luminance_cd_m2"),
    ] {
        let cfg = SceneConfig::from_toml(&format!("kind = \"hdr_lights\"\n{extra}"), "t").unwrap();
        let e = create(&cfg, &cfg.grid()).unwrap_err().to_string();
        assert!(e.contains(key), "{extra}: {e}");
    }
}
