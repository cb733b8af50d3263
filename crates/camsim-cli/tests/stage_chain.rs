//! The stages run one by one between files give the same raw image as `camsim simulate` in
//! memory: `scene -> optics -> sensor -> isp` and `render -> optics -> sensor`, same config,
//! same seed. The irradiance and radiance files are f32 OpenEXR, which holds the in-memory f32
//! planes exactly, so the raw DN must agree bit for bit.

use std::path::Path;
use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_camsim");

fn camsim(args: &[&str]) {
    let o = Command::new(BIN).args(args).arg("--quiet").output().unwrap();
    assert!(o.status.success(), "`camsim {}` failed: {}", args.join(" "), String::from_utf8_lossy(&o.stderr));
}

fn raw(p: &Path) -> camsim_core::RawImage {
    camsim_io::dng::read_dng(p).unwrap_or_else(|e| panic!("{}: {e}", p.display())).0
}

fn assert_same_raw(a: &Path, b: &Path) {
    let (ra, rb) = (raw(a), raw(b));
    assert_eq!((ra.rows, ra.cols), (rb.rows, rb.cols), "sizes differ");
    assert_eq!(ra.cfa, rb.cfa);
    assert_eq!(ra.black_level_dn, rb.black_level_dn);
    let differing = ra.dn.iter().zip(&rb.dn).filter(|(x, y)| x != y).count();
    let mean = ra.dn.iter().map(|&v| v as f64).sum::<f64>() / ra.dn.len() as f64;
    assert!(mean > ra.black_level_dn + 20.0, "the test image is too dark to prove anything (mean {mean} DN)");
    assert_eq!(differing, 0, "{differing} of {} pixels differ between {} and {}", ra.dn.len(), a.display(), b.display());
}

const CHART: &str = r#"
seed = 7
[scene]
kind = "macbeth"
fov_deg = 2.0
patch_size_px = 12
border_px = 2
[optics]
preset = "pixel4a"
[sensor]
preset = "pixel4a"
rows = 64
cols = 96
[capture]
exposure_ms = 5.0
"#;

#[test]
fn scene_optics_sensor_isp_equals_simulate() {
    let dir = tempfile::tempdir().unwrap();
    let d = |s: &str| dir.path().join(s).to_string_lossy().into_owned();
    std::fs::write(dir.path().join("chart.toml"), CHART).unwrap();
    camsim(&["simulate", &d("chart.toml"), "--out", &d("sim")]);
    camsim(&["scene", &d("chart.toml"), "--out", &d("radiance.exr")]);
    camsim(&["optics", "--in", &d("radiance.exr"), "--lens", "pixel4a", "--out", &d("irradiance.exr")]);
    camsim(&["sensor", "--in", &d("irradiance.exr"), "--sensor", "pixel4a", "--rows", "64", "--cols", "96", "--exposure-ms", "5", "--seed", "7", "--out", &d("raw")]);
    assert_same_raw(&dir.path().join("sim/raw.dng"), &dir.path().join("raw/raw.dng"));
    camsim(&["isp", "--in", &d("raw/raw.dng"), "--sensor", "pixel4a", "--illuminant", "D65", "--out", &d("preview.png")]);
    let (a, b) = (camsim_io::raster::read_png8_rgb(&dir.path().join("sim/preview.png")).unwrap(), camsim_io::raster::read_png8_rgb(&dir.path().join("preview.png")).unwrap());
    assert_eq!((a.0, a.1), (b.0, b.1));
    assert!(a.2 == b.2, "the isp stage's preview differs from simulate's");
}

const BOX: &str = r#"
seed = 3
[render]
builtin = "cornell-box"
samples_per_pixel = 2
resolution = [48, 32]
[optics]
preset = "pixel4a"
[sensor]
preset = "pixel4a"
rows = 64
cols = 96
[capture]
exposure_ms = 20.0
"#;

#[test]
fn render_optics_sensor_equals_simulate() {
    let dir = tempfile::tempdir().unwrap();
    let d = |s: &str| dir.path().join(s).to_string_lossy().into_owned();
    std::fs::write(dir.path().join("box.toml"), BOX).unwrap();
    camsim(&["simulate", &d("box.toml"), "--out", &d("sim")]);
    // The renderer's camera follows the simulate config (field of view of the sensor window).
    camsim(&["render", "--config", &d("box.toml"), "--out", &d("render")]);
    camsim(&["optics", "--in", &d("render/radiance.exr"), "--lens", "pixel4a", "--out", &d("irradiance.exr")]);
    camsim(&["sensor", "--in", &d("irradiance.exr"), "--sensor", "pixel4a", "--rows", "64", "--cols", "96", "--exposure-ms", "20", "--seed", "3", "--out", &d("raw")]);
    assert_same_raw(&dir.path().join("sim/raw.dng"), &dir.path().join("raw/raw.dng"));
}
