//! The stages run one by one between files give the same raw image as `camsim simulate` in
//! memory: `scene -> optics -> sensor -> isp` and `render -> optics -> sensor`, same config,
//! same seed. The irradiance and radiance files are f32 OpenEXR, which holds the in-memory f32
//! planes exactly, so the raw DN must agree bit for bit.

use std::path::Path;
use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_camsim");

fn camsim(args: &[&str]) {
    let o = Command::new(BIN)
        .args(args)
        .arg("--quiet")
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "`camsim {}` failed: {}",
        args.join(" "),
        String::from_utf8_lossy(&o.stderr)
    );
}

fn raw(p: &Path) -> camsim_core::RawImage {
    camsim_io::dng::read_dng(p)
        .unwrap_or_else(|e| panic!("{}: {e}", p.display()))
        .0
}

fn assert_same_raw(a: &Path, b: &Path) {
    let (ra, rb) = (raw(a), raw(b));
    assert_eq!((ra.rows, ra.cols), (rb.rows, rb.cols), "sizes differ");
    assert_eq!(ra.cfa, rb.cfa);
    assert_eq!(ra.black_level_dn, rb.black_level_dn);
    let differing = ra.dn.iter().zip(&rb.dn).filter(|(x, y)| x != y).count();
    let mean = ra.dn.iter().map(|&v| v as f64).sum::<f64>() / ra.dn.len() as f64;
    assert!(
        mean > ra.black_level_dn + 20.0,
        "the test image is too dark to prove anything (mean {mean} DN)"
    );
    assert_eq!(
        differing,
        0,
        "{differing} of {} pixels differ between {} and {}",
        ra.dn.len(),
        a.display(),
        b.display()
    );
}

/// The CLI tests' small chart config (a 64 x 96 sensor window).
const CHART: &str = include_str!("../small-chart.toml");

/// Run `simulate` on `config` into `sim/`, then the stage commands (`{D}` = the scratch folder,
/// the config is `{D}/run.toml`), and check the stages' `raw/raw.dng` equals simulate's bit for
/// bit. Returns the scratch folder for further checks.
fn simulate_and_chain(config: &str, stages: &[&[&str]]) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().to_string_lossy().into_owned();
    std::fs::write(dir.path().join("run.toml"), config).unwrap();
    camsim(&[
        "simulate",
        &format!("{d}/run.toml"),
        "--out",
        &format!("{d}/sim"),
    ]);
    for stage in stages {
        let args: Vec<String> = stage.iter().map(|a| a.replace("{D}", &d)).collect();
        camsim(&args.iter().map(|a| a.as_str()).collect::<Vec<_>>());
    }
    assert_same_raw(
        &dir.path().join("sim/raw.dng"),
        &dir.path().join("raw/raw.dng"),
    );
    dir
}

#[test]
fn scene_optics_sensor_isp_equals_simulate() {
    let dir = simulate_and_chain(
        CHART,
        &[
            &["scene", "{D}/run.toml", "--out", "{D}/radiance.exr"],
            &[
                "optics",
                "--in",
                "{D}/radiance.exr",
                "--lens",
                "pixel4a",
                "--out",
                "{D}/irradiance.exr",
            ],
            &[
                "sensor",
                "--in",
                "{D}/irradiance.exr",
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
                "--out",
                "{D}/raw",
            ],
            &[
                "isp",
                "--in",
                "{D}/raw/raw.dng",
                "--sensor",
                "pixel4a",
                "--illuminant",
                "D65",
                "--out",
                "{D}/preview.png",
            ],
        ],
    );
    let read = |name: &str| camsim_io::raster::read_png8_rgb(&dir.path().join(name)).unwrap();
    let (a, b) = (read("sim/preview.png"), read("preview.png"));
    assert_eq!((a.0, a.1), (b.0, b.1));
    assert!(
        a.2 == b.2,
        "the isp stage's preview differs from simulate's"
    );
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
    // `render --config`: the renderer's camera follows the simulate config (the field of view of
    // the sensor window through the lens).
    simulate_and_chain(
        BOX,
        &[
            &["render", "--config", "{D}/run.toml", "--out", "{D}/render"],
            &[
                "optics",
                "--in",
                "{D}/render/radiance.exr",
                "--lens",
                "pixel4a",
                "--out",
                "{D}/irradiance.exr",
            ],
            &[
                "sensor",
                "--in",
                "{D}/irradiance.exr",
                "--sensor",
                "pixel4a",
                "--rows",
                "64",
                "--cols",
                "96",
                "--exposure-ms",
                "20",
                "--seed",
                "3",
                "--out",
                "{D}/raw",
            ],
        ],
    );
}
