//! `camsim analyze visual-noise` through the binary: a neutral grating's closed form (the CPIQ
//! luminance CSF at the grating's frequency), the previews of simulated captures (less light,
//! more visual noise; further away, less), and bad input (exit 2, no output folder).

use std::path::Path;
use std::process::{Command, Output};

fn camsim(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_camsim"))
        .args(args)
        .arg("--quiet")
        .output()
        .expect("camsim runs")
}

fn ok(args: &[&str]) -> Output {
    let o = camsim(args);
    assert!(
        o.status.success(),
        "camsim {}: {}",
        args.join(" "),
        String::from_utf8_lossy(&o.stderr)
    );
    o
}

fn vn_json(image: &Path, extra: &[&str], out: &Path) -> serde_json::Value {
    let mut args = vec![
        "analyze",
        "visual-noise",
        image.to_str().unwrap(),
        "--json",
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    let o = ok(&args);
    assert!(out.join("visual_noise.csv").is_file());
    serde_json::from_slice(&o.stdout).expect("--json prints JSON")
}

/// sRGB encoding (IEC 61966-2-1:1999 eq. 5.5-5.6), written here independently of camsim.
fn srgb_encode(v: f64) -> f64 {
    if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

#[test]
fn a_grating_follows_the_csf_and_captures_with_less_light_look_noisier() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // A 16-bit grey PNG: 8 cycles over 64 columns, Y = 0.2 + 0.01 sin. At 32 pixels per degree it
    // is at 4 cycles/degree, the peak of 75 nu^0.8 exp(-0.2 nu) / 34.05 (3.0003).
    let (rows, cols, y0, a) = (16usize, 64usize, 0.2, 0.01);
    let s = |c: usize| (2.0 * std::f64::consts::PI * 8.0 * c as f64 / cols as f64).sin();
    let px: Vec<u16> = (0..rows * cols)
        .map(|i| (srgb_encode(y0 + a * s(i % cols)) * 65535.0).round() as u16)
        .collect();
    let png = d.join("grating.png");
    camsim_io::raster::write_png16_gray(&png, rows, cols, &px).unwrap();
    let j = vn_json(
        &png,
        &["--pixels-per-degree", "32", "--region", "0,0,16,64"],
        &d.join("g"),
    );
    let p = &j["patches"][0];
    let g = 75.0 * 4f64.powf(0.8) * (-0.8f64).exp() / 34.05;
    let l: Vec<f64> = (0..cols)
        .map(|c| 116.0 * (y0 + g * a * s(c)).cbrt() - 16.0)
        .collect();
    let m = l.iter().sum::<f64>() / cols as f64;
    let want = (l.iter().map(|v| (v - m).powi(2)).sum::<f64>() / cols as f64).sqrt();
    let got = p["sigma_l_star"].as_f64().unwrap();
    assert!((got - want).abs() < 3e-3 * want, "{got} vs {want}");
    assert!(p["sigma_u_star"].as_f64().unwrap() < 1e-2, "{p}");
    assert_eq!(j["encoding"], "srgb");

    // Previews of a uniform field at 10 and 2.5 ms: a quarter of the light, more visual noise;
    // the same picture viewed from 4x the distance, less.
    let uniform = concat!(env!("CARGO_MANIFEST_DIR"), "/../../examples/uniform.toml");
    let vn = |ms: &str, extra: &[&str]| {
        let sim = d.join(format!("sim{ms}"));
        if !sim.join("preview.png").is_file() {
            ok(&[
                "simulate",
                uniform,
                "--exposure-ms",
                ms,
                "--frames",
                "1",
                "--out",
                sim.to_str().unwrap(),
            ]);
        }
        let j = vn_json(&sim.join("preview.png"), extra, &d.join(format!("vn{ms}")));
        j["patches"][0]["visual_noise"].as_f64().unwrap()
    };
    let (bright, dim) = (vn("10", &[]), vn("2.5", &[]));
    assert!(dim > 1.5 * bright && bright > 0.0, "{dim} vs {bright}");
    let far = vn("10", &["--viewing-distance-m", "1.6"]);
    assert!(far < 0.7 * bright, "{far} vs {bright}");

    // Bad input: exit 2 with the file named, no output folder.
    std::fs::write(d.join("not.png"), b"no image here").unwrap();
    for (args, needle) in [
        (
            vec![d.join("not.png").to_str().unwrap().to_string()],
            "not.png",
        ),
        (
            vec![
                png.to_str().unwrap().to_string(),
                "--region".into(),
                "10,60,8,8".into(),
            ],
            "region 1",
        ),
    ] {
        let out = d.join("bad");
        let mut a = vec!["analyze", "visual-noise"];
        a.extend(args.iter().map(|s| s.as_str()));
        a.extend(["--out", out.to_str().unwrap()]);
        let o = camsim(&a);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert!(err.contains(needle), "{err}");
        assert!(!out.exists());
    }
}
