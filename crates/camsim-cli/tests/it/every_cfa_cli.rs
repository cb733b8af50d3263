//! Every CFA through the `camsim` binary (issue 42): `camsim simulate` of a monochrome, an RCCC,
//! a CMYG and an RGB-IR sensor made over the pixel4a preset writes the raw and a preview, and
//! `camsim isp` takes each DNG back (RGB-IR's as a monochrome LinearRaw mosaic with its layout). Checks: the files exist and run.json notes no fallback preview, the
//! monochrome preview is grey, a neutral patch of every preview is neutral (the ISP of each
//! family maps a perfect white to R = G = B; the ColorChecker's neutral 6.5 is near-flat: within
//! 6 %, noise included), `camsim isp` gives simulate's preview bit for bit, `--json` names the
//! family, and bad input is exit 2 with a message naming it.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn camsim(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_camsim"))
        .args(args)
        .arg("--quiet")
        .output()
        .expect("camsim runs")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// A small ColorChecker capture on the pixel4a, its sensor table `sensor`.
fn config(sensor: &str) -> String {
    format!(
        r#"
seed = 5
[scene]
kind = "macbeth"
fov_deg = 1.6
patch_size_px = 12
border_px = 2
[optics]
preset = "pixel4a"
[optics.config]
shading = "none"
{sensor}
"#
    )
}

/// A sensor file `NAME-sensor.toml` in `d`: the pixel4a's pixel (Table 1 of Lyu et al.) behind
/// the tile `pattern` (TOML rows of filter names), its QE from the file `qe`.
fn sensor_file(d: &Path, name: &str, pattern: &str, qe: &Path) -> PathBuf {
    write(
        d.join(format!("{name}-sensor.toml")),
        &format!(
            "name = \"{name}\"\nrows = 3024\ncols = 4032\npixel_pitch_um = 1.4\nfill_factor = 1.0\n\
             cfa_pattern = {pattern}\nconversion_gain_uv_per_e = 76.5\n\
             voltage_swing_v = 0.4591\nbits = 12\nread_noise_mv = 0.2\n[qe]\nfile = \"{}\"\n",
            s(qe)
        ),
    )
}

fn write(path: PathBuf, text: &str) -> PathBuf {
    std::fs::write(&path, text).unwrap();
    path
}

/// The preview's linear sRGB mean over the central half of the neutral 6.5 patch (21; the white
/// can clip in the preview, which biases its noisier channels down): the corners
/// from the run.json beside the DNG (the pipeline's own mapping of the chart onto the sensor).
fn neutral_patch(png: &Path, dng: &Path) -> [f64; 3] {
    let (rows, cols, rgb) = camsim::io::raster::read_png8_rgb(png).unwrap();
    let corners = camsim::pipeline::records::chart_corners_beside(dng, rows, cols).unwrap();
    let plane = |k: usize| {
        camsim::analysis::Plane::new(
            rows,
            cols,
            (0..rows * cols)
                .map(|i| {
                    camsim::core::colorimetry::srgb_decode(rgb[3 * i + k] as f64 / 255.0) as f32
                })
                .collect(),
        )
        .unwrap()
    };
    let stats = camsim::analysis::chart::chart_patch_stats_rgb(
        &[plane(0), plane(1), plane(2)],
        &corners,
        0.5,
    )
    .unwrap();
    stats[20].mean
}

#[test]
fn mono_rccc_cmyg_and_rgb_ir_captures_simulate_and_go_through_camsim_isp() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // CMYG: a QE file with the complementary filters (a coarse, smooth set: c = g + b,
    // m = r + b, y = r + g of Gaussian-like r, g, b).
    let qe = write(
        d.join("cmyg.csv"),
        "wavelength_nm,r,g,b,c,m,y\n\
         400,0.02,0.05,0.40,0.45,0.42,0.07\n\
         450,0.02,0.15,0.60,0.75,0.62,0.17\n\
         500,0.03,0.45,0.35,0.80,0.38,0.48\n\
         550,0.08,0.60,0.08,0.68,0.16,0.68\n\
         600,0.55,0.25,0.03,0.28,0.58,0.80\n\
         650,0.50,0.05,0.02,0.07,0.52,0.55\n\
         700,0.30,0.02,0.02,0.04,0.32,0.32\n",
    );
    // The pixel4a's pixel (Table 1 of Lyu et al.) behind the CMYG tile.
    let cmyg_sensor = sensor_file(d, "cmyg", r#"[["c", "y"], ["m", "g"]]"#, &qe);
    // RGB-IR: the same r, g, b with an NIR-passing filter `nir` in one green's place (a QE
    // column `ir` is the IR-cut filter). Its DNG is a monochrome LinearRaw mosaic with the
    // layout in DNGPrivateData: DNG has no colour code for infrared.
    let qe_ir = write(
        d.join("rgbir.csv"),
        "wavelength_nm,r,g,b,nir\n\
         400,0.02,0.05,0.40,0.01\n\
         450,0.02,0.15,0.60,0.01\n\
         500,0.03,0.45,0.35,0.02\n\
         550,0.08,0.60,0.08,0.03\n\
         600,0.55,0.25,0.03,0.08\n\
         650,0.50,0.05,0.02,0.20\n\
         700,0.30,0.02,0.02,0.35\n",
    );
    let rgbir_sensor = sensor_file(d, "rgbir", r#"[["r", "g"], ["nir", "b"]]"#, &qe_ir);
    let cases = [
        (
            "rgbir",
            format!(
                "[sensor]\nfile = \"{}\"\nrows = 64\ncols = 96\n",
                s(&rgbir_sensor)
            ),
            "multichannel",
        ),
        (
            "mono",
            "[sensor]\npreset = \"pixel4a\"\nrows = 64\ncols = 96\n[sensor.config]\ncfa_pattern = [[\"w\"]]\n".to_string(),
            "monochrome",
        ),
        (
            "rccc",
            "[sensor]\npreset = \"pixel4a\"\nrows = 64\ncols = 96\n[sensor.config]\ncfa_pattern = [[\"r\", \"clear\"], [\"clear\", \"clear\"]]\n".to_string(),
            "rccc",
        ),
        (
            "cmyg",
            format!(
                "[sensor]\nfile = \"{}\"\nrows = 64\ncols = 96\n",
                s(&cmyg_sensor)
            ),
            "multichannel",
        ),
    ];
    for (name, sensor, family) in cases {
        let cfg = write(d.join(format!("{name}.toml")), &config(&sensor));
        let out = d.join(name);
        let o = camsim(&["simulate", s(&cfg), "--out", s(&out)]);
        assert!(o.status.success(), "{name}: {}", stderr(&o));
        for f in ["raw.dng", "preview.png", "run.json"] {
            assert!(out.join(f).is_file(), "{name}: no {f}");
        }
        let run: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("run.json")).unwrap()).unwrap();
        assert!(
            run["files"].get("preview.png").is_none(),
            "{name}: the ISP rendered it: {}",
            run["files"]
        );
        let w = neutral_patch(&out.join("preview.png"), &out.join("raw.dng"));
        for k in [0, 2] {
            assert!(
                (w[k] / w[1] - 1.0).abs() < 0.06,
                "{name}: the neutral patch is not neutral: linear {w:?}"
            );
        }
        if name == "mono" {
            let (_, _, rgb) = camsim::io::raster::read_png8_rgb(&out.join("preview.png")).unwrap();
            assert!(rgb.chunks(3).all(|p| p[0] == p[1] && p[1] == p[2]));
        }
        // camsim isp takes the DNG back (the sensor that made it: its QE for the frame's filters).
        let sensor_arg = if name == "cmyg" || name == "rgbir" {
            s(&d.join(format!("{name}-sensor.toml"))).to_string()
        } else {
            "pixel4a".to_string()
        };
        let png = d.join(format!("{name}-isp.png"));
        let o = camsim(&[
            "isp",
            "--in",
            s(&out.join("raw.dng")),
            "--sensor",
            &sensor_arg,
            "--out",
            s(&png),
            "--json",
        ]);
        assert!(o.status.success(), "{name} isp: {}", stderr(&o));
        let report: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        assert_eq!(report["cfa_family"], family, "{name}: {report}");
        // The same ISP as simulate's preview: the same image.
        assert_eq!(
            std::fs::read(&png)
                .ok()
                .map(|_| camsim::io::raster::read_png8_rgb(&png).unwrap()),
            Some(camsim::io::raster::read_png8_rgb(&out.join("preview.png")).unwrap()),
            "{name}: camsim isp and simulate's preview differ"
        );
        if name == "cmyg" {
            assert_eq!(report["channels"].as_array().map(|a| a.len()), Some(4));
            assert!(report["channel_fit_delta_e2000"][0].as_f64().unwrap() < 10.0);
        }
        if name == "rccc" {
            let o = camsim(&[
                "isp",
                "--in",
                s(&out.join("raw.dng")),
                "--rccc-clear",
                "analog",
                "--out",
                s(&d.join("rccc-analog.png")),
            ]);
            assert!(o.status.success(), "{}", stderr(&o));
            let o = camsim(&[
                "isp",
                "--in",
                s(&out.join("raw.dng")),
                "--rccc-clear",
                "bogus",
                "--out",
                s(&d.join("x.png")),
            ]);
            assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
            assert!(stderr(&o).contains("edge-aware"), "{}", stderr(&o));
            // White patch white balance has nothing to work on in RCCC: refused by name.
            let o = camsim(&[
                "isp",
                "--in",
                s(&out.join("raw.dng")),
                "--white-balance",
                "white-patch",
                "--out",
                s(&d.join("x.png")),
            ]);
            assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
            assert!(stderr(&o).contains("white-patch"), "{}", stderr(&o));
        }
    }
}

/// The ISETCam presets (MT9V024 mono and RCCC, AR0132AT RCCC) simulate with their own CFA,
/// through the family's ISP, and `camsim presets sensor NAME` prints the source file.
#[test]
fn isetcam_presets_simulate_and_print_their_source() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (name, file, family) in [
        ("mt9v024-mono", "MT9V024SensorMono.mat", "monochrome"),
        ("mt9v024-rccc", "MT9V024SensorRCCC.mat", "rccc"),
        ("ar0132at-rccc", "ar0132atSensorRCCC.mat", "rccc"),
        ("mt9v024-rgbw", "MT9V024SensorRGBW.mat", "rgbw"),
    ] {
        let o = camsim(&["presets", "sensor", name]);
        assert!(o.status.success(), "{}", stderr(&o));
        let toml = String::from_utf8_lossy(&o.stdout);
        assert!(
            toml.contains(&format!("source = \"ISETCam sensor file {file}")),
            "{toml}"
        );
        let cfg = write(
            d.join(format!("{name}.toml")),
            &config(&format!(
                "[sensor]\npreset = \"{name}\"\nrows = 48\ncols = 64\n"
            )),
        );
        let out = d.join(name);
        let o = camsim(&["simulate", s(&cfg), "--out", s(&out)]);
        assert!(o.status.success(), "{name}: {}", stderr(&o));
        assert!(out.join("raw.dng").is_file() && out.join("preview.png").is_file());
        let png = d.join(format!("{name}.png"));
        let o = camsim(&[
            "isp",
            "--in",
            s(&out.join("raw.dng")),
            "--sensor",
            name,
            "--out",
            s(&png),
            "--json",
        ]);
        assert!(o.status.success(), "{name}: {}", stderr(&o));
        let report: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        assert_eq!(report["cfa_family"], family, "{name}");
    }
}
