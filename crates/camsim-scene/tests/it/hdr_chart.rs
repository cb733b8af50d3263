//! ISETCam's HDR chart (`kind = "hdr_chart"`): log-spaced strips, their ratios against the
//! closed form, the brightest strip's luminance against a uniform field of that luminance (the
//! uniform scene's own normalization), and bad keys named.

use camsim_scene::{create, mean_luminance_cd_m2, SceneConfig};

fn chart(extra: &str) -> camsim_core::SpectralImage {
    let cfg = SceneConfig::from_toml(
        &format!("kind = \"hdr_chart\"\ndynamic_range = 1e5\nlevels = 11\nlevel_width_px = 4\nrows = 8\n{extra}"),
        "test",
    )
    .unwrap();
    create(&cfg, &cfg.grid()).unwrap()
}

#[test]
fn hdr_chart_strips_span_the_dynamic_range_in_equal_log_steps() {
    let img = chart("max_luminance_cd_m2 = 500\n");
    assert_eq!((img.rows, img.cols), (8, 44));
    let (rows, cols) = (img.rows, img.cols);
    // Every band: strip i is 10^(5 / 10) brighter than strip i - 1, and 1e5 from end to end.
    let step = 10f64.powf(0.5);
    for band in img.data.chunks(rows * cols) {
        let strip = |i: usize| band[5 * cols + 4 * i + 2] as f64;
        for i in 1..11 {
            assert!((strip(i) / strip(i - 1) / step - 1.0).abs() < 1e-5);
        }
        assert!((strip(10) / strip(0) / 1e5 - 1.0).abs() < 1e-5);
    }
    // The brightest strip is a uniform white field of 500 cd/m^2.
    let cfg = SceneConfig::from_toml(
        "kind = \"uniform\"\nmean_luminance_cd_m2 = 500\nrows = 4\ncols = 4\nreflectance = 1.0\n",
        "test",
    )
    .unwrap();
    let white = create(&cfg, &cfg.grid()).unwrap();
    for (b, band) in img.data.chunks(rows * cols).enumerate() {
        let want = white.data[b * 16] as f64;
        let got = band[cols - 1] as f64;
        assert!((got / want - 1.0).abs() < 1e-4, "band {b}: {got} vs {want}");
    }
    // Without max_luminance_cd_m2, the mean luminance scales it, as for every pattern.
    let img = chart("");
    assert!((mean_luminance_cd_m2(&img) - 100.0).abs() < 1e-3);
}

#[test]
fn hdr_chart_bad_keys_are_named() {
    let bad = |extra: &str| {
        let cfg =
            SceneConfig::from_toml(&format!("kind = \"hdr_chart\"\n{extra}"), "test").unwrap();
        create(&cfg, &cfg.grid()).unwrap_err().to_string()
    };
    for (extra, key) in [
        ("levels = 1", "scene.levels"),
        ("dynamic_range = 0.5", "scene.dynamic_range"),
        ("level_width_px = 0", "scene.level_width_px"),
        (
            "max_luminance_cd_m2 = 10\nmean_luminance_cd_m2 = 5",
            "scene.max_luminance_cd_m2",
        ),
    ] {
        let e = bad(extra);
        assert!(e.contains(key), "{extra}: {e}");
    }
}
