//! `camsim analyze sfr`, `analyze emva` and `fit qe` through the binary: one frequency unit in
//! every SFR output (checked against a closed-form MTF), the shipped slanted-edge example end to
//! end, the documented EMVA series header, help texts, and bad arguments (exit 2, no panic).

use std::path::Path;
use std::process::{Command, Output};

fn camsim(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_camsim"))
        .args(args)
        .output()
        .expect("camsim runs")
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

/// Complementary error function, Numerical Recipes (Press et al. 2007, sec. 6.2) Chebyshev fit,
/// fractional error below 1.2e-7.
fn erfc(x: f64) -> f64 {
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let p = -z * z - 1.26551223
        + t * (1.00002368
            + t * (0.37409196
                + t * (0.09678418
                    + t * (-0.18628806
                        + t * (0.27886807
                            + t * (-1.13520398
                                + t * (1.48851587 + t * (-0.82215223 + t * 0.17087277))))))));
    let ans = t * p.exp();
    if x >= 0.0 {
        ans
    } else {
        2.0 - ans
    }
}

/// Standard normal CDF.
fn phi(t: f64) -> f64 {
    0.5 * erfc(-t / std::f64::consts::SQRT_2)
}

fn sinc(x: f64) -> f64 {
    if x.abs() < 1e-12 {
        1.0
    } else {
        (std::f64::consts::PI * x).sin() / (std::f64::consts::PI * x)
    }
}

const PITCH_UM: f64 = 1.4;
const SIGMA_PX: f64 = 1.4;
const ANGLE_DEG: f64 = 5.0;

/// A Bayer (RGGB) raw of a 5-degree edge blurred by a Gaussian of SIGMA_PX sensor pixels and
/// integrated over each square pixel (8 x 8 midpoint samples), a different gain per channel.
fn write_edge_dng(path: &Path) {
    let (rows, cols) = (192usize, 128usize);
    let mut raw =
        camsim_core::RawImage::new(rows, cols, camsim_core::CfaPattern::Rggb, 16).unwrap();
    raw.black_level_dn = 512.0;
    raw.pixel_pitch_m = PITCH_UM * 1e-6;
    let th = ANGLE_DEG.to_radians();
    let (x0, y0) = (cols as f64 / 2.0 + 0.3, rows as f64 / 2.0);
    let gain = [20000.0, 40000.0, 15000.0];
    for r in 0..rows {
        for c in 0..cols {
            let mut acc = 0.0;
            for i in 0..8 {
                for j in 0..8 {
                    let x = c as f64 + (i as f64 + 0.5) / 8.0;
                    let y = r as f64 + (j as f64 + 0.5) / 8.0;
                    acc += phi(((x - x0) * th.cos() - (y - y0) * th.sin()) / SIGMA_PX) / 64.0;
                }
            }
            let ch = raw.channel_at(r, c).index();
            raw.dn[r * cols + c] = (512.0 + 1000.0 + gain[ch] * acc).round() as u16;
        }
    }
    let meta = camsim_io::dng::DngMetadata {
        camera_model: "sfr_cli test edge".into(),
        ..Default::default()
    };
    camsim_io::dng::write_dng(path, &raw, &meta).unwrap();
}

/// One SFR whichever door measures it: `camsim analyze sfr`, the application layer's
/// `measure_sfr` (what Python's `camsim.sfr` calls) and `camsim validate`'s edge measurement give
/// the same numbers on the same image, and the luminance curve is the SFR of the one luminance of
/// RGB data, Rec. 709 (the CLI used Rec. 601, Python and validate Rec. 709).
#[test]
fn the_cli_the_library_and_validate_measure_one_sfr() {
    use camsim::analysis::sfr;
    use camsim::pipeline::measure::sfr::{measure_sfr, SfrImage, SfrRequest};
    let dir = tempfile::tempdir().unwrap();
    let dng = dir.path().join("edge.dng");
    write_edge_dng(&dng);
    let raw = camsim_io::dng::read_dng(&dng).unwrap().0;
    // The CLI, with and without a given ROI.
    let roi = "20,40,150,48";
    for given in [None, Some(roi)] {
        let out = dir.path().join(format!("sfr-{}", given.is_some()));
        let mut args = vec!["analyze", "sfr", dng.to_str().unwrap(), "--json", "--quiet"];
        args.extend(["--out", out.to_str().unwrap()]);
        if let Some(r) = given {
            args.extend(["--roi", r]);
        }
        let o = camsim(&args);
        assert!(o.status.success(), "{}", text(&o.stderr));
        let json: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        let req = SfrRequest {
            roi: given.map(|r| {
                let v: Vec<usize> = r.split(',').map(|x| x.parse().unwrap()).collect();
                camsim::analysis::Rect::new(v[0], v[1], v[2], v[3])
            }),
            ..SfrRequest::default()
        };
        let report = measure_sfr(&SfrImage::Raw(raw.clone()), &req).unwrap();
        let curves = json["curves"].as_array().unwrap();
        assert_eq!(curves.len(), 4);
        for (c, r) in curves.iter().zip(&report.curves) {
            assert_eq!(c["curve"], r.name.as_str());
            let f = |k: &str| c[k].as_f64().unwrap();
            // The same computation; the binary (opt-level 1) and this test (opt-level 2) may
            // round the last bit differently (LLVM's `powi` has unspecified precision), so to
            // 1e-12 relative: far below any door's difference (Rec. 601 against 709: ~1e-3).
            let same = |a: f64, b: f64, what: &str| {
                assert!(
                    (a - b).abs() <= 1e-12 * a.abs().max(b.abs()),
                    "{what}: CLI {a} library {b}"
                )
            };
            same(
                f("mtf50_cyc_per_sensor_px"),
                r.result.mtf50_cyc_per_sensor_px.unwrap(),
                "mtf50",
            );
            same(
                f("mtf_at_nyquist"),
                r.result.mtf_at_nyquist,
                "mtf_at_nyquist",
            );
            same(
                f("edge_angle_deg"),
                r.result.edge_angle_deg,
                "edge_angle_deg",
            );
        }
        assert_eq!(
            std::fs::read_to_string(out.join("sfr.csv")).unwrap(),
            report.csv(),
            "sfr.csv"
        );
        // The luminance curve is the SFR of 0.2126 R + 0.7152 G + 0.0722 B of the bilinear
        // demosaic (ITU-R BT.709), in the same ROI.
        let rgb = camsim::isp::demosaic_bilinear(&raw);
        let y: Vec<f32> = (0..rgb.pixels())
            .map(|i| 0.2126f32 * rgb.r[i] + 0.7152f32 * rgb.g[i] + 0.0722f32 * rgb.b[i])
            .collect();
        let plane = camsim::analysis::Plane::new(rgb.rows, rgb.cols, y).unwrap();
        let opts = sfr::SfrOptions {
            pixel_pitch_mm: Some(PITCH_UM * 1e-3),
            ..Default::default()
        };
        let lum = sfr::sfr(&plane, report.roi, &opts).unwrap();
        assert_eq!(lum.mtf, report.curve("luminance").unwrap().mtf);
        if given.is_some() {
            // camsim validate's edge measurement, on the same image and ROI (and pitch: the
            // DNG's FocalPlaneXResolution is a rounded rational).
            let pitch_m = PITCH_UM * 1e-6;
            let v = camsim::validate::optics_fig::slanted_edge_curves(
                &raw,
                report.roi.unwrap(),
                pitch_m,
            )
            .unwrap();
            let same_pitch = SfrRequest {
                pixel_pitch_mm: Some(pitch_m * 1e3),
                ..req.clone()
            };
            let layer = measure_sfr(&SfrImage::Raw(raw.clone()), &same_pitch).unwrap();
            let layer: Vec<_> = layer.curves.into_iter().map(|c| c.result).collect();
            assert_eq!(v, layer, "validate's SFR differs from the CLI's");
            assert_eq!(v[3].mtf, lum.mtf);
        }
    }
}

/// MTF50 of the closed form, cycles per sensor pixel: Gaussian exp(-2 pi^2 sigma^2 f^2) times the
/// sensor pixel's square aperture projected on the edge normal, |sinc(f cos) sinc(f sin)|.
fn closed_form_mtf50() -> f64 {
    let th = ANGLE_DEG.to_radians();
    let mtf = |f: f64| {
        (-2.0 * std::f64::consts::PI.powi(2) * SIGMA_PX * SIGMA_PX * f * f).exp()
            * (sinc(f * th.cos()) * sinc(f * th.sin())).abs()
    };
    let (mut a, mut b) = (0.0, 0.5);
    for _ in 0..60 {
        let m = 0.5 * (a + b);
        if mtf(m) > 0.5 {
            a = m
        } else {
            b = m
        }
    }
    0.5 * (a + b)
}

#[test]
fn sfr_outputs_give_one_mtf50_in_cycles_per_sensor_pixel_and_per_mm_matching_the_closed_form() {
    let dir = tempfile::tempdir().unwrap();
    let dng = dir.path().join("edge.dng");
    write_edge_dng(&dng);
    let out = dir.path().join("sfr");
    let o = camsim(&[
        "analyze",
        "sfr",
        dng.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let console = text(&o.stderr);
    let f50 = closed_form_mtf50();
    println!("closed form MTF50 {f50:.4} cycles/sensor pixel\n{console}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("sfr.json")).unwrap()).unwrap();
    let csv = std::fs::read_to_string(out.join("sfr.csv")).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert_eq!(&header[..2], ["freq_cyc_per_sensor_px", "freq_cyc_per_mm"]);
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|v| v.parse::<f64>().unwrap()).collect())
        .collect();
    for ch in ["R", "G", "B"] {
        // Console: "R: MTF50 0.1234 cycles/sensor-pixel = 88.1 cycles/mm, ...".
        let line = console
            .lines()
            .find(|l| l.trim_start().starts_with(&format!("{ch}:")))
            .unwrap_or_else(|| panic!("no {ch} line"));
        let num_after = |key: &str| -> f64 {
            let i = line
                .find(key)
                .unwrap_or_else(|| panic!("'{key}' not in '{line}'"));
            line[..i]
                .split_whitespace()
                .last()
                .unwrap()
                .parse()
                .unwrap()
        };
        let console_px = num_after("cycles/sensor-pixel =");
        let console_mm = num_after("cycles/mm");
        // JSON.
        let curve = json["curves"]
            .as_array()
            .unwrap()
            .iter()
            .find(|c| c["curve"] == ch)
            .unwrap();
        let json_px = curve["mtf50_cyc_per_sensor_px"].as_f64().unwrap();
        let json_mm = curve["mtf50_cyc_per_mm"].as_f64().unwrap();
        // CSV: where the column first falls below 0.5 (linear between the 0.01 samples; the
        // curve's curvature makes that at most ~1e-4 off).
        let k = header
            .iter()
            .position(|h| *h == format!("mtf_{ch}"))
            .unwrap();
        let i = rows.iter().position(|r| r[k] < 0.5).unwrap();
        let w = (rows[i - 1][k] - 0.5) / (rows[i - 1][k] - rows[i][k]);
        let csv_px = rows[i - 1][0] + w * (rows[i][0] - rows[i - 1][0]);
        let csv_mm = rows[i - 1][1] + w * (rows[i][1] - rows[i - 1][1]);
        println!("{ch}: console {console_px} / {console_mm}, json {json_px:.5} / {json_mm:.2}, csv {csv_px:.5} / {csv_mm:.2}");
        // One unit: all three agree (console rounds to 4 decimals, 0.1 cycles/mm).
        assert!(
            (console_px - json_px).abs() <= 5e-5 + 1e-12,
            "{ch}: console {console_px} vs json {json_px}"
        );
        assert!(
            (csv_px - json_px).abs() <= 5e-4,
            "{ch}: csv {csv_px} vs json {json_px}"
        );
        assert!(
            (json_mm - json_px / (PITCH_UM * 1e-3)).abs() < 1e-6 * json_mm,
            "{ch}: cycles/mm {json_mm}"
        );
        assert!(
            (console_mm - json_mm).abs() <= 0.05 + 1e-9,
            "{ch}: console {console_mm} cycles/mm vs json {json_mm}"
        );
        assert!(
            (csv_mm - json_mm).abs() <= 5e-4 / (PITCH_UM * 1e-3),
            "{ch}: csv {csv_mm} cycles/mm vs json {json_mm}"
        );
        // And the closed form, within the e-SFR's 2 % on MTF50 (tests/sfr.rs of camsim-analysis).
        assert!(
            (json_px / f50 - 1.0).abs() < 0.02,
            "{ch}: MTF50 {json_px} vs closed form {f50} cycles per sensor pixel"
        );
        assert_eq!(
            curve["nyquist_cyc_per_sensor_px"].as_f64(),
            Some(0.25),
            "{ch}: a CFA channel's Nyquist"
        );
    }
}

#[test]
fn the_slanted_edge_example_simulates_and_its_sfr_finds_the_5_degree_edge() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../examples/slanted-edge.toml"
    );
    let sim = dir.path().join("edge");
    let o = camsim(&["simulate", cfg, "--out", sim.to_str().unwrap(), "--quiet"]);
    assert!(o.status.success(), "simulate: {}", text(&o.stderr));
    let out = dir.path().join("sfr");
    let o = camsim(&[
        "analyze",
        "sfr",
        sim.join("raw.dng").to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--json",
    ]);
    assert!(o.status.success(), "analyze sfr: {}", text(&o.stderr));
    let json: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    for c in json["curves"].as_array().unwrap() {
        let angle = c["edge_angle_deg"].as_f64().unwrap();
        println!(
            "{}: edge {angle:.3} deg, MTF50 {} cycles/sensor pixel",
            c["curve"], c["mtf50_cyc_per_sensor_px"]
        );
        // The scene's 5 degrees, within what the edge fit and the optics' distortion allow.
        assert!(
            (angle.abs() - 5.0).abs() < 0.3,
            "{}: edge at {angle} degrees",
            c["curve"]
        );
        assert!(c["mtf50_cyc_per_sensor_px"].as_f64().is_some());
    }
}

/// The option lines of a `-h` text with no help text, neither after the flag on the same line
/// nor (clap's layout for long texts) on the next line.
fn undocumented_options(help: &str) -> Vec<String> {
    // The "Options:" section: up to the next blank line.
    let lines: Vec<&str> = help
        .lines()
        .skip_while(|l| !l.starts_with("Options:"))
        .skip(1)
        .take_while(|l| !l.trim().is_empty())
        .collect();
    let is_flag = |l: &str| l.trim_start().starts_with('-');
    (0..lines.len())
        .filter(|i| is_flag(lines[*i]))
        .filter(|i| !lines[*i].trim().contains("  ") && lines.get(i + 1).is_none_or(|n| is_flag(n)))
        .map(|i| lines[i].trim().to_string())
        .collect()
}

#[test]
fn help_texts_describe_every_option_and_the_emva_header_is_what_the_series_writer_writes() {
    for cmd in [
        &["analyze", "sfr", "-h"][..],
        &["analyze", "emva", "-h"],
        &["fit", "qe", "-h"],
    ] {
        let o = camsim(cmd);
        assert!(o.status.success());
        let h = text(&o.stdout);
        for opt in ["--json", "--out"] {
            assert!(h.contains(opt), "{cmd:?}: no {opt}");
        }
        assert!(
            undocumented_options(&h).is_empty(),
            "{cmd:?}: options without help: {:?}",
            undocumented_options(&h)
        );
        assert!(h.contains("Examples:"), "{cmd:?}");
    }
    // The documented series header (for 2 frames per level) against the one written.
    let h = text(&camsim(&["analyze", "emva", "--help"]).stdout);
    let key = "with --frames-per-level 2:";
    let at = h.find(key).expect("the help documents the header") + key.len();
    let documented = h[at..].split('`').nth(1).unwrap().to_string();
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("emva");
    let o = camsim(&[
        "sensor",
        "--emva-series",
        "--sensor",
        "imx363",
        "--rows",
        "16",
        "--cols",
        "16",
        "--levels",
        "3",
        "--frames-per-level",
        "2",
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let written = std::fs::read_to_string(out.join("series.csv")).unwrap();
    assert_eq!(written.lines().next().unwrap(), documented);
}

#[test]
fn malformed_arguments_exit_2_with_a_message() {
    let dir = tempfile::tempdir().unwrap();
    let d = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let dng = d("edge.dng");
    write_edge_dng(Path::new(&dng));
    let flat = d("flat.dng");
    let mut raw = camsim_core::RawImage::new(32, 32, camsim_core::CfaPattern::Rggb, 12).unwrap();
    raw.dn.iter_mut().for_each(|v| *v = 100);
    camsim_io::dng::write_dng(Path::new(&flat), &raw, &Default::default()).unwrap();
    std::fs::write(d("bad.csv"), "a,b\n1,2\n").unwrap();
    std::fs::write(d("means.csv"), "light,patch,r,g,b\nD65,25,1,2,3\n").unwrap();
    std::fs::write(
        d("means_nan.csv"),
        "light,patch,r,g,b\nD65,1,1,nan,3\nD65,2,1,2,3\nD65,3,1,2,3\n",
    )
    .unwrap();
    std::fs::write(d("noheader.csv"), "D65,1,1,2,3\nD65,2,1,2,3\nD65,3,1,2,3\n").unwrap();
    let out = d("out");
    let cases: Vec<Vec<String>> = vec![
        vec!["analyze".into(), "sfr".into(), d("missing.dng")],
        vec![
            "analyze".into(),
            "sfr".into(),
            dng.clone(),
            "--roi".into(),
            "1,2,3".into(),
        ],
        vec![
            "analyze".into(),
            "sfr".into(),
            dng.clone(),
            "--roi".into(),
            "0,0,500,500".into(),
        ],
        vec![
            "analyze".into(),
            "sfr".into(),
            dng.clone(),
            "--roi".into(),
            "0,0,2,2".into(),
        ],
        vec![
            "analyze".into(),
            "sfr".into(),
            dng.clone(),
            "--pitch-um".into(),
            "-1".into(),
        ],
        vec![
            "analyze".into(),
            "sfr".into(),
            dng.clone(),
            "--pitch-um".into(),
            "nan".into(),
        ],
        vec![
            "analyze".into(),
            "sfr".into(),
            dng.clone(),
            "--compare".into(),
            d("bad.csv"),
        ],
        vec!["analyze".into(), "sfr".into(), flat.clone()],
        vec!["analyze".into(), "sfr".into(), d("bad.csv")],
        vec!["analyze".into(), "emva".into(), d("missing.csv")],
        vec!["analyze".into(), "emva".into(), d("bad.csv")],
        vec!["fit".into(), "qe".into(), "--measured".into(), d("bad.csv")],
        vec![
            "fit".into(),
            "qe".into(),
            "--measured".into(),
            d("means.csv"),
        ],
        vec![
            "fit".into(),
            "qe".into(),
            "--measured".into(),
            d("means_nan.csv"),
        ],
        vec![
            "fit".into(),
            "qe".into(),
            "--measured".into(),
            d("noheader.csv"),
        ],
        vec![
            "fit".into(),
            "qe".into(),
            "--measured".into(),
            d("means.csv"),
            "--form".into(),
            "cubic".into(),
        ],
        vec![
            "fit".into(),
            "qe".into(),
            "--measured".into(),
            d("means.csv"),
            "--luminance-cd-m2".into(),
            "0".into(),
        ],
        vec![
            "fit".into(),
            "qe".into(),
            "--measured".into(),
            d("means.csv"),
            "--f-number".into(),
            "inf".into(),
        ],
        vec![
            "fit".into(),
            "qe".into(),
            "--measured".into(),
            d("means.csv"),
            "--exposure-ms".into(),
            "-3".into(),
        ],
        vec![
            "fit".into(),
            "qe".into(),
            "--measured".into(),
            d("means.csv"),
            "--lights".into(),
            "NOPE".into(),
        ],
    ];
    for mut args in cases {
        args.extend(["--out".to_string(), out.clone()]);
        let o = Command::new(env!("CARGO_BIN_EXE_camsim"))
            .args(&args)
            .output()
            .unwrap();
        let err = text(&o.stderr);
        println!(
            "{args:?}: {} {}",
            o.status,
            err.lines().next().unwrap_or("")
        );
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(
            !err.trim().is_empty() && !err.contains("panicked"),
            "{args:?}: {err}"
        );
        assert!(
            !Path::new(&out).join("sfr.json").exists()
                && !Path::new(&out).join("fit.json").exists(),
            "{args:?}: partial output"
        );
    }
}
