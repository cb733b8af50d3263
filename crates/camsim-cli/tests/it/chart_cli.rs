//! `camsim analyze chart` and `analyze roi` through the binary: the chart found from a camsim
//! run's run.json and measured against the Macbeth reflectances, a real camera DNG with its
//! corners, LinearRaw DNGs read as RGB, and malformed arguments exit 2 without a panic.

use camsim_core::WavelengthGrid;
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

fn json_of(o: &Output) -> serde_json::Value {
    assert!(o.status.success(), "camsim failed: {}", stderr(o));
    serde_json::from_slice(&o.stdout).unwrap_or_else(|e| {
        panic!(
            "stdout is not JSON ({e}): {}",
            String::from_utf8_lossy(&o.stdout)
        )
    })
}

fn canon_dng() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/data/dng/canon-550d-colorchecker-passport.dng")
}

/// Corners of the Passport's 24-patch grid in the Canon file (outer corners of the dark-skin,
/// bluish-green, black and white patches, x,y in active-area pixels), read off a preview of the
/// decoded file and refined with edge profiles across the patch borders.
const CANON_CORNERS: &str = "671,587,1293,572,1304,962,655,974";

/// Patch means, standard deviations and pixel counts from chart.json.
fn patches(v: &serde_json::Value) -> Vec<([f64; 3], [f64; 3], [f64; 3])> {
    let p = v["patches"].as_array().expect("patches");
    p.iter()
        .map(|p| {
            let f = |k: &str| {
                let a = p[k].as_array().unwrap();
                [0, 1, 2].map(|c| a[c].as_f64().unwrap())
            };
            (f("mean"), f("std"), f("n"))
        })
        .collect()
}

/// A macbeth chart of 40-sample patches and 10-sample borders imaged at about 0.9 sensor pixels
/// per scene sample (fov 5.1 deg at 1.2 m through the pixel4a lens onto 1.4 um pixels) in the
/// middle of a 220 x 320 window: the grid lands at non-integer pixel positions.
const CHART_CONFIG: &str = r#"
seed = 3
[scene]
kind = "macbeth"
fov_deg = 5.1
distance_m = 1.2
patch_size_px = 40
border_px = 10
illuminant = "D65"
[optics]
preset = "pixel4a"
[sensor]
preset = "pixel4a"
rows = 220
cols = 320
[capture]
exposure_ms = 6.0 # the white patch well below saturation
"#;

#[test]
fn chart_of_a_camsim_run_is_found_from_run_json_and_neutral_ratios_match_macbeth_reflectances() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("chart.toml");
    std::fs::write(&cfg, CHART_CONFIG).unwrap();
    let sim = dir.path().join("sim");
    let o = camsim(&[
        "simulate",
        cfg.to_str().unwrap(),
        "--out",
        sim.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "simulate: {}", stderr(&o));
    let out = dir.path().join("chart");
    let v = json_of(&camsim(&[
        "analyze",
        "chart",
        sim.join("raw.dng").to_str().unwrap(),
        "--json",
        "--out",
        out.to_str().unwrap(),
    ]));
    for f in ["patches.csv", "profile.csv", "profile.png", "chart.json"] {
        assert!(out.join(f).is_file(), "missing {f}");
    }
    let p = patches(&v);
    assert_eq!(p.len(), 24);

    // Noise-free expectation of each neutral patch's green mean relative to white: the D65 x
    // reflectance x green-QE integral over the grid (the scene, optics and sensor scale every
    // patch alike; N. Ohta's reflectances from camsim-core's table).
    let grid = WavelengthGrid::default();
    let d65 = camsim_core::tables::illuminant("D65")
        .unwrap()
        .sample(&grid);
    let qe_g = camsim_sensor::Sensor::preset("pixel4a")
        .unwrap()
        .channel_qe(&grid)[1]
        .clone();
    let refl = camsim_core::tables::macbeth_reflectances();
    let signal = |k: usize| -> f64 {
        refl[k]
            .sample(&grid)
            .iter()
            .zip(&d65)
            .zip(&qe_g)
            .map(|((r, e), q)| r * e * q)
            .sum()
    };
    let white = 18;
    let (mw, sw, nw) = (p[white].0[1], p[white].1[1], p[white].2[1]);
    for k in 18..24 {
        let (m, s, n) = (p[k].0[1], p[k].1[1], p[k].2[1]);
        if k > 18 {
            assert!(
                m < p[k - 1].0[1],
                "green means not ordered white > ... > black: {:?}",
                (18..24).map(|i| p[i].0[1]).collect::<Vec<_>>()
            );
        }
        let expected = signal(k) / signal(white);
        let ratio = m / mw;
        // Sampling error of the ratio (standard errors of both means) at 4 sigma, plus 1 % of
        // the ratio for the optics: the lens PSF's tail and relative illumination across the
        // 5 deg field shift a patch's central mean by a fraction of that (measured: 0.2-0.6 %).
        let se = ratio * ((s / m).powi(2) / n + (sw / mw).powi(2) / nw).sqrt();
        let tol = 4.0 * se + 0.01 * ratio;
        println!("patch {k}: green ratio {ratio:.4}, expected {expected:.4}, tolerance {tol:.4}");
        assert!((ratio - expected).abs() < tol, "patch {k}: green mean ratio to white {ratio:.4}, Macbeth reflectances give {expected:.4}");
    }
    // Corners and the centre of each patch lie where the run's geometry puts them: every patch
    // is uniform inside its measured square (std within a few times the white patch's noise
    // level scaled by sqrt(mean)), which fails if a square straddles a border.
    for (k, (m, s, _)) in p.iter().enumerate() {
        for c in 0..3 {
            let noise_bound = 3.0 * (p[white].1[c] / p[white].0[c].sqrt()) * m[c].max(1.0).sqrt()
                + 3.0 * p[23].1[c];
            assert!(s[c] < noise_bound, "patch {k} channel {c}: std {} DN > {noise_bound:.2}: the square straddles a border", s[c]);
        }
    }
}

#[test]
fn chart_of_the_real_canon_dng_with_corners_orders_the_neutral_patches() {
    let dng = canon_dng();
    let dir = tempfile::tempdir().unwrap();
    let v = json_of(&camsim(&[
        "analyze",
        "chart",
        dng.to_str().unwrap(),
        "--corners",
        CANON_CORNERS,
        "--json",
        "--out",
        dir.path().join("c").to_str().unwrap(),
    ]));
    let p = patches(&v);
    assert_eq!(p.len(), 24);
    for c in 0..3 {
        for k in 19..24 {
            let (a, b) = (&p[k - 1], &p[k]);
            // Ordered, and by more than 4 standard errors of the difference.
            let se = ((a.1[c].powi(2) / a.2[c]) + (b.1[c].powi(2) / b.2[c])).sqrt();
            assert!(
                a.0[c] - b.0[c] > 4.0 * se,
                "channel {c}: neutral patch {} ({:.1} DN) not above {} ({:.1} DN), se {se:.2}",
                k - 1,
                a.0[c],
                k,
                b.0[c]
            );
        }
        assert!(
            p[23].0[c] > -5.0,
            "channel {c}: black patch {} DN below black",
            p[23].0[c]
        );
    }
    // Dark skin (0) is redder than it is blue; bluish green (5) is bluer than red; red (14) is red.
    assert!(p[0].0[0] > p[0].0[2] && p[5].0[2] > p[5].0[0] && p[14].0[0] > 2.0 * p[14].0[1]);
}

/// An RGB LinearRaw DNG of the chart: patch k has (R, G, B) = black + value(k, c) on a grid of
/// 20-pixel pitch (16-pixel patches, 4-pixel black borders) from (10, 8).
fn linear_raw_chart(path: &Path) -> [f64; 3] {
    let (rows, cols) = (100, 140);
    let black = [64.0, 70.0, 80.0];
    let mut dn = vec![0u16; rows * cols * 3];
    for r in 0..rows {
        for c in 0..cols {
            let (u, v) = (c as i64 - 10, r as i64 - 8);
            let patch = (u >= 0
                && v >= 0
                && u < 120
                && v < 80
                && u % 20 >= 2
                && u % 20 < 18
                && v % 20 >= 2
                && v % 20 < 18)
                .then(|| (v / 20 * 6 + u / 20) as usize);
            for k in 0..3 {
                dn[(r * cols + c) * 3 + k] =
                    (black[k] + patch.map_or(0.0, |p| lin_value(p, k))) as u16;
            }
        }
    }
    let img = camsim_io::dng::LinearRawImage {
        rows,
        cols,
        dn,
        black_level_dn: black,
        white_level_dn: [65535.0; 3],
        exposure_s: 0.01,
        pixel_pitch_m: 0.0,
    };
    camsim_io::dng::write_linear_raw_dng(path, &img, &camsim_io::dng::DngMetadata::default())
        .unwrap();
    black
}

fn lin_value(p: usize, c: usize) -> f64 {
    200.0 + 50.0 * p as f64 + 3000.0 * c as f64
}

#[test]
fn linear_raw_dngs_are_read_as_rgb_by_chart_and_roi() {
    let dir = tempfile::tempdir().unwrap();
    let dng = dir.path().join("lin.dng");
    linear_raw_chart(&dng);
    let v = json_of(&camsim(&[
        "analyze",
        "chart",
        dng.to_str().unwrap(),
        "--corners",
        "10,8,130,8,130,88,10,88",
        "--json",
        "--out",
        dir.path().join("c").to_str().unwrap(),
    ]));
    assert_eq!(v["data"], "LinearRaw RGB");
    let p = patches(&v);
    for (k, (m, s, n)) in p.iter().enumerate() {
        for c in 0..3 {
            // Every pixel of the measured square (10 x 10: half the 20-pixel pitch) is value(k, c).
            assert_eq!(m[c], lin_value(k, c), "patch {k} channel {c}");
            assert_eq!(s[c], 0.0);
            assert_eq!(n[c], 100.0);
        }
    }
    // roi: the white patch (18) square and one across the border between patches 0 and 1.
    let v = json_of(&camsim(&[
        "analyze",
        "roi",
        dng.to_str().unwrap(),
        "--region",
        "72,14,10,10",
        "--json",
        "--out",
        dir.path().join("r").to_str().unwrap(),
    ]));
    let m = v["a"][0]["mean_dn"].as_array().unwrap();
    let n = v["a"][0]["n"].as_array().unwrap();
    for c in 0..3 {
        assert_eq!(m[c].as_f64().unwrap(), lin_value(18, c));
        assert_eq!(
            n[c].as_u64().unwrap(),
            100,
            "every pixel carries all three channels"
        );
    }
}

#[test]
fn malformed_chart_and_roi_arguments_exit_2_with_a_message() {
    let dir = tempfile::tempdir().unwrap();
    let dng = dir.path().join("lin.dng");
    linear_raw_chart(&dng);
    let d = dng.to_str().unwrap();
    let nocfg = dir.path().join("alone").join("raw.dng");
    std::fs::create_dir_all(nocfg.parent().unwrap()).unwrap();
    std::fs::copy(&dng, &nocfg).unwrap();
    let out = dir.path().join("out");
    let o = out.to_str().unwrap();
    let cases: Vec<(Vec<&str>, &str)> = vec![
        // The --help example form: 8 numbers (panicked with a clap type mismatch before).
        (
            vec![
                "chart",
                d,
                "--corners",
                "100,80,700,80,700,480,100,480",
                "--out",
                o,
            ],
            "outside",
        ),
        (vec!["chart", d, "--corners", "1,2,3", "--out", o], "8"),
        (
            vec!["chart", d, "--corners", "1,2,3,4,5,6,7,8,9", "--out", o],
            "8",
        ),
        (
            vec!["chart", d, "--corners", "a,b,c,d,e,f,g,h", "--out", o],
            "numbers",
        ),
        (
            vec![
                "chart",
                d,
                "--corners",
                "10,8,130,8,130,88,nan,88",
                "--out",
                o,
            ],
            "finite",
        ),
        (
            vec![
                "chart",
                d,
                "--corners",
                "-10,8,130,8,130,88,10,88",
                "--out",
                o,
            ],
            "outside",
        ),
        (
            vec![
                "chart",
                d,
                "--corners",
                "10,88,130,88,130,8,10,8",
                "--out",
                o,
            ],
            "upright",
        ),
        (
            vec![
                "chart",
                d,
                "--corners",
                "10,8,130,8,130,88,10,88",
                "--fraction",
                "0",
                "--out",
                o,
            ],
            "fraction",
        ),
        (
            vec![
                "chart",
                d,
                "--corners",
                "10,8,130,8,130,88,10,88",
                "--fraction",
                "1.5",
                "--out",
                o,
            ],
            "fraction",
        ),
        (
            vec![
                "chart",
                d,
                "--corners",
                "10,8,130,8,130,88,10,88",
                "--fraction",
                "x",
                "--out",
                o,
            ],
            "fraction",
        ),
        (vec!["chart", d, "--corners"], "corners"),
        (
            vec!["chart", nocfg.to_str().unwrap(), "--out", o],
            "run.json",
        ),
        (
            vec![
                "chart",
                "/nonexistent/raw.dng",
                "--corners",
                "10,8,130,8,130,88,10,88",
                "--out",
                o,
            ],
            "/nonexistent/raw.dng",
        ),
        (vec!["roi", d, "--out", o], "--region"),
        (
            vec!["roi", d, "--region", "1,2,3", "--out", o],
            "ROW,COL,ROWS,COLS",
        ),
        (vec!["roi", d, "--region", "0,0,0,5", "--out", o], "ROWS"),
        (
            vec![
                "roi",
                d,
                "--region",
                "0,0,5,5",
                "--region-b",
                "0,0,5,5",
                "--out",
                o,
            ],
            "second image",
        ),
        (
            vec![
                "roi",
                d,
                d,
                "--region",
                "0,0,5,5",
                "--region-b",
                "0,0,5,5",
                "--region-b",
                "1,1,5,5",
                "--out",
                o,
            ],
            "--region-b",
        ),
        (
            vec!["roi", d, "--region", "95,0,10,10", "--out", o],
            "does not fit",
        ),
        (
            vec![
                "roi",
                d,
                "--region",
                "18446744073709551615,0,10,10",
                "--out",
                o,
            ],
            "does not fit",
        ),
        (
            vec![
                "roi",
                d,
                "--region",
                "0,0,5,5",
                "--sensor",
                "nosuchsensor",
                "--out",
                o,
            ],
            "nosuchsensor",
        ),
    ];
    for (args, needle) in cases {
        let mut full = vec!["analyze"];
        full.extend(&args);
        let r = camsim(&full);
        let e = stderr(&r);
        assert_eq!(
            r.status.code(),
            Some(2),
            "{args:?}: exit code {:?}, stderr: {e}",
            r.status.code()
        );
        assert!(
            !e.contains("internal error") && !e.contains("panicked"),
            "{args:?}: {e}"
        );
        assert!(
            e.to_lowercase().contains(&needle.to_lowercase()),
            "{args:?}: the message should mention '{needle}': {e}"
        );
        let left: Vec<_> = std::fs::read_dir(&out)
            .map(|d| d.filter_map(|e| e.ok()).map(|e| e.file_name()).collect())
            .unwrap_or_default();
        assert!(left.is_empty(), "{args:?}: left {left:?}");
    }
}

#[test]
fn chart_and_roi_help_describe_every_option_and_examples_are_single_lines() {
    for sub in ["chart", "roi"] {
        let o = camsim(&["analyze", sub, "--help"]);
        assert!(o.status.success());
        let text = String::from_utf8_lossy(&o.stdout).into_owned();
        let (_, rest) = text
            .split_once("Options:")
            .unwrap_or_else(|| panic!("{sub}: {text}"));
        let (options, examples) = rest
            .split_once("Examples:")
            .unwrap_or_else(|| panic!("{sub}: no Examples: {text}"));
        // Every option line ("  -q, --quiet  Hide ..." / "  --out <OUT>  Output ...") has a description.
        let mut seen = Vec::new();
        for line in options.lines() {
            let t = line.trim_start();
            if t.starts_with('-') {
                let desc = t.split_once("  ").map(|(_, d)| d.trim()).unwrap_or("");
                assert!(
                    !desc.is_empty(),
                    "{sub}: option without a description: {line}"
                );
                seen.push(
                    t.split_whitespace()
                        .find(|w| w.starts_with("--"))
                        .unwrap_or("")
                        .to_string(),
                );
            }
        }
        for opt in ["--json", "--out", "--cfa", "--black-dn", "--bits"] {
            assert!(
                seen.iter().any(|s| s == opt),
                "{sub} --help lacks {opt}: {seen:?}"
            );
        }
        // Example lines are whole commands (a wrapped line would not start with "camsim").
        let lines: Vec<&str> = examples.lines().filter(|l| !l.trim().is_empty()).collect();
        assert!(lines.len() >= 2, "{sub}: {examples}");
        for l in lines {
            assert!(
                l.starts_with(&format!("  camsim analyze {sub} ")),
                "{sub}: example line is not a whole command: {l:?}"
            );
        }
    }
}
