//! One ISP whichever command runs it: for the same raw and settings, `camsim simulate`'s
//! preview, `camsim isp`'s and `camsim validate`'s report preview are the same image, and
//! `camsim sensor` writes the colour matrix and neutral `camsim simulate` writes (both the ISP's
//! QE fit under the scene's illuminant; `sensor` fitted under D65 whatever the scene was). A
//! scene under CIE illuminant A, so a D65 fit anywhere would show.

use std::path::Path;

use crate::common;
use common::run_ok as camsim;

fn png(p: &Path) -> (usize, usize, Vec<u8>) {
    camsim_io::raster::read_png8_rgb(p).unwrap()
}

#[test]
fn simulate_isp_sensor_and_validate_share_one_isp() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cfg = include_str!("../small-chart.toml")
        .replace("border_px = 2", "border_px = 2\nilluminant = \"A\"");
    std::fs::write(d.join("run.toml"), cfg).unwrap();
    let p = |name: &str| d.join(name).to_string_lossy().into_owned();
    camsim(&["simulate", &p("run.toml"), "--out", &p("sim")]);
    // The stage commands: scene, optics, sensor under the same illuminant.
    camsim(&["scene", &p("run.toml"), "--out", &p("radiance.exr")]);
    camsim(&[
        "optics",
        "--in",
        &p("radiance.exr"),
        "--lens",
        "pixel4a",
        "--out",
        &p("irradiance.exr"),
    ]);
    camsim(&[
        "sensor",
        "--in",
        &p("irradiance.exr"),
        "--sensor",
        "pixel4a",
        "--rows",
        "64",
        "--cols",
        "96",
        "--exposure-ms",
        "5",
        "--seed",
        "5",
        "--illuminant",
        "A",
        "--out",
        &p("raw"),
    ]);
    let (sim_raw, sim_info) = camsim_io::dng::read_dng(&d.join("sim/raw.dng")).unwrap();
    let (stage_raw, stage_info) = camsim_io::dng::read_dng(&d.join("raw/raw.dng")).unwrap();
    assert_eq!(sim_raw.dn, stage_raw.dn, "the stage chain's raw differs");
    // camsim sensor: the same colour metadata as simulate (the ISP's fit under A, not D65).
    assert!(sim_info.color_matrix1.is_some());
    assert_eq!(sim_info.color_matrix1, stage_info.color_matrix1);
    assert_eq!(sim_info.as_shot_neutral, stage_info.as_shot_neutral);
    let n = sim_info.as_shot_neutral.unwrap();
    assert!(
        n[2] < 0.7 * n[0],
        "the neutral of illuminant A is red-heavy: {n:?}"
    );

    // camsim isp on simulate's raw, same sensor and illuminant: simulate's preview exactly.
    let isp = |illuminant: &str| {
        let out = p(&format!("isp-{illuminant}.png"));
        camsim(&[
            "isp",
            "--in",
            &p("sim/raw.dng"),
            "--sensor",
            "pixel4a",
            "--illuminant",
            illuminant,
            "--out",
            &out,
        ]);
        png(Path::new(&out))
    };
    let preview = png(&d.join("sim/preview.png"));
    assert_eq!(isp("A"), preview, "camsim isp's preview");

    // camsim validate's report preview of the same raw (96 columns: no downsampling).
    let sensor = camsim::sensor::Sensor::preset("pixel4a").unwrap();
    let rgb = camsim::isp::demosaic_bilinear(&sim_raw);
    let (img, k, _) = camsim::validate::scene_fig::report_preview(
        &rgb,
        &sensor,
        camsim::core::tables::illuminant("A").unwrap(),
        camsim::core::WavelengthGrid::default(),
        None,
        sim_raw.white_level_dn - sim_raw.black_level_dn,
    )
    .unwrap();
    assert_eq!(k, 1);
    assert_eq!(
        (img.h, img.w, img.data),
        preview,
        "camsim validate's preview"
    );

    // A D65 ISP (the old `camsim sensor` fit) gives another image: the test can tell.
    assert_ne!(isp("D65"), preview);
}

/// The ISP's correction steps are the same through both doors: `[isp]` keys in a simulate config
/// and `camsim isp`'s flags give the same preview, and the steps change the image (a preview
/// without them differs).
#[test]
fn isp_steps_from_the_config_and_from_the_flags_give_the_same_preview() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cfg = format!(
        "{}\n[isp]\ndefect_correction = \"detect\"\ndefect_sigmas = 5.0\ndenoise = \"nlm\"\ndenoise_strength = 1.5\nsharpen = {{ radius_px = 1.2, amount = 0.6, threshold = 2.0 }}\ntone_map = \"reinhard\"\nlens_shading = \"shading.toml\"\n",
        include_str!("../small-chart.toml")
    );
    std::fs::write(d.join("run.toml"), cfg).unwrap();
    // A lens shading 1 - 0.2 (x^2 + y^2) in every channel (monomials 1, x, y, x^2, xy, y^2),
    // named relative to the config.
    let coef = "[1.0, 0.0, 0.0, -0.2, 0.0, -0.2]";
    std::fs::write(
        d.join("shading.toml"),
        format!("order = 2\nrows = 64\ncols = 96\nred = {coef}\ngreen = {coef}\nblue = {coef}\nrms_residual_percent = 0.5\nnoise_percent = 0.5\n"),
    )
    .unwrap();
    let p = |name: &str| d.join(name).to_string_lossy().into_owned();
    camsim(&["simulate", &p("run.toml"), "--out", &p("sim")]);
    let isp = |extra: &[&str], out: &str| {
        let (raw, o) = (p("sim/raw.dng"), p(out));
        let mut args = vec!["isp", "--in", &raw, "--sensor", "pixel4a"];
        args.extend_from_slice(extra);
        args.extend_from_slice(&["--out", &o]);
        camsim(&args);
        png(Path::new(&o))
    };
    let shading = p("shading.toml");
    let steps = [
        "--defect-correction",
        "detect",
        "--defect-sigmas",
        "5",
        "--denoise",
        "nlm",
        "--denoise-strength",
        "1.5",
        "--sharpen",
        "1.2,0.6,2",
        "--tone-map",
        "reinhard",
        "--lens-shading",
        &shading,
    ];
    let preview = png(&d.join("sim/preview.png"));
    assert_eq!(
        isp(&steps, "flags.png"),
        preview,
        "camsim isp with the flags"
    );
    assert_ne!(
        isp(&["--tone-map", "reinhard"], "plain.png"),
        preview,
        "without the steps the preview differs"
    );
}
