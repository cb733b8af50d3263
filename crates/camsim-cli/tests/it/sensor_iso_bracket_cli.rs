//! The CLI paths of the pixel4a-raw10 preset, `--iso` and exposure brackets (`--exposures-ms`,
//! `[capture] exposures_ms`): the DNGs carry black 64 and white 1023, one raw per exposure with
//! its own ExposureTime, and the mean signal above black scales with exposure time and ISO.

use std::path::Path;
use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_camsim");

fn camsim(args: &[&str]) -> std::process::Output {
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
    o
}

fn raw(p: &Path) -> camsim_core::RawImage {
    camsim_io::dng::read_dng(p)
        .unwrap_or_else(|e| panic!("{}: {e}", p.display()))
        .0
}

/// Mean DN above the DNG's black level over every pixel.
fn mean_above_black(r: &camsim_core::RawImage) -> f64 {
    r.dn.iter().map(|&v| v as f64).sum::<f64>() / r.dn.len() as f64 - r.black_level_dn
}

const CHART: &str = include_str!("../small-chart.toml");

#[test]
fn pixel4a_raw10_iso_and_bracket_from_the_cli() {
    let list = String::from_utf8(camsim(&["presets"]).stdout).unwrap();
    assert!(list.contains("pixel4a-raw10"), "{list}");
    let toml = String::from_utf8(camsim(&["presets", "sensor", "pixel4a-raw10"]).stdout).unwrap();
    assert!(
        toml.contains("black_level_dn = 64.0") && toml.contains("bits = 10"),
        "{toml}"
    );

    let dir = tempfile::tempdir().unwrap();
    let d = |s: &str| dir.path().join(s);
    let p = |s: &str| d(s).to_string_lossy().into_owned();
    std::fs::write(d("run.toml"), CHART).unwrap();
    camsim(&[
        "simulate",
        &p("run.toml"),
        "--save",
        "raw,irradiance",
        "--out",
        &p("sim"),
    ]);
    let irr = p("sim/irradiance.exr");
    let sensor = |out: &str, extra: &[&str]| {
        let mut args = vec!["sensor", "--in", &irr, "--sensor", "pixel4a-raw10"];
        args.extend_from_slice(&["--rows", "64", "--cols", "96", "--seed", "2"]);
        args.extend_from_slice(extra);
        let o = p(out);
        args.extend_from_slice(&["--out", &o]);
        camsim(&args);
    };
    // Auto-exposure (99th percentile at 90 % of the swing) gives the time scale.
    sensor("auto", &[]);
    let auto = raw(&d("auto/raw.dng"));
    assert_eq!(
        (auto.black_level_dn, auto.white_level_dn, auto.bits),
        (64.0, 1023.0, 10)
    );
    let t_ms = auto.exposure_s * 1e3;
    let (t1, t2) = (format!("{}", t_ms / 4.0), format!("{}", t_ms / 2.0));
    // A bracket of t/4, t/2, t/4: three DNGs in list order, each with its own exposure time.
    sensor("bracket", &["--exposures-ms", &format!("{t1},{t2},{t1}")]);
    let frames: Vec<_> = ["raw.dng", "raw_0001.dng", "raw_0002.dng"]
        .iter()
        .map(|n| raw(&d(&format!("bracket/{n}"))))
        .collect();
    assert!(!d("bracket/raw_0003.dng").exists());
    for (f, want_ms) in frames.iter().zip([t_ms / 4.0, t_ms / 2.0, t_ms / 4.0]) {
        assert!(
            (f.exposure_s * 1e3 / want_ms - 1.0).abs() < 1e-3,
            "ExposureTime {} s, want {want_ms} ms",
            f.exposure_s
        );
        assert_eq!(f.black_level_dn, 64.0);
    }
    let m: Vec<f64> = frames.iter().map(mean_above_black).collect();
    assert!(m[0] > 30.0, "too dark to prove anything: {m:?}");
    assert!(
        (m[1] / m[0] - 2.0).abs() < 0.04,
        "t/2 over t/4: {}",
        m[1] / m[0]
    );
    // The two t/4 frames: same mean, different noise.
    assert!((m[2] / m[0] - 1.0).abs() < 0.02, "{m:?}");
    assert_ne!(frames[0].dn, frames[2].dn);
    // ISO 110 = twice the base ISO 55: twice the signal above black at t/4.
    sensor("iso", &["--exposure-ms", &t1, "--iso", "110"]);
    let iso = mean_above_black(&raw(&d("iso/raw.dng")));
    // The EXIF ISO tag: the sensor's iso (55 for the preset, 110 with --iso 110).
    let iso_tag = |f: &str| camsim_io::dng::read_dng(&d(f)).unwrap().1.iso;
    assert_eq!(
        (iso_tag("auto/raw.dng"), iso_tag("iso/raw.dng")),
        (Some(55.0), Some(110.0))
    );
    assert!(
        (iso / m[0] - 2.0).abs() < 0.04,
        "ISO 110 over ISO 55: {}",
        iso / m[0]
    );
    eprintln!("auto {t_ms:.3} ms; bracket means above black {m:?}; t/2 over t/4 {:.4}; ISO 110 over 55 {:.4}", m[1] / m[0], iso / m[0]);

    // simulate --exposures-ms: the same bracket through the whole pipeline, listed in run.json.
    camsim(&[
        "simulate",
        &p("run.toml"),
        "--save",
        "raw",
        "--exposures-ms",
        "2,4",
        "--out",
        &p("simb"),
    ]);
    let a = raw(&d("simb/raw.dng"));
    let b = raw(&d("simb/raw_0001.dng"));
    assert!((a.exposure_s - 2e-3).abs() < 1e-9 && (b.exposure_s - 4e-3).abs() < 1e-9);
    let run: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d("simb/run.json")).unwrap()).unwrap();
    assert_eq!(
        run["results"]["frame_exposures_s"],
        serde_json::json!([0.002, 0.004])
    );
    assert_eq!(run["results"]["frames"], 2);
}

#[test]
fn bad_brackets_and_iso_are_refused_with_a_message() {
    let dir = tempfile::tempdir().unwrap();
    let run = |args: &[&str]| {
        Command::new(BIN)
            .args(args)
            .arg("--quiet")
            .output()
            .unwrap()
    };
    let cfg = dir.path().join("run.toml");
    std::fs::write(
        &cfg,
        CHART.replace("exposure_ms = 5.0", "exposures_ms = [1.0, -2.0]"),
    )
    .unwrap();
    let out = dir.path().join("o").to_string_lossy().into_owned();
    let o = run(&["simulate", &cfg.to_string_lossy(), "--out", &out]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("exposures_ms[1]"),
        "{err}"
    );
    std::fs::write(
        &cfg,
        CHART.replace(
            "exposure_ms = 5.0",
            "exposure_ms = 5.0\nexposures_ms = [1.0]",
        ),
    )
    .unwrap();
    let o = run(&["simulate", &cfg.to_string_lossy(), "--out", &out]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("not both"), "{err}");
    // --iso on a sensor without a base ISO names the key.
    let s = dir.path().join("s.toml");
    let text = String::from_utf8(run(&["presets", "sensor", "ideal"]).stdout).unwrap();
    std::fs::write(&s, text).unwrap();
    let o = run(&[
        "sensor",
        "--emva-series",
        "--sensor",
        &s.to_string_lossy(),
        "--iso",
        "100",
        "--rows",
        "8",
        "--cols",
        "8",
        "--out",
        &out,
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("base_iso"), "{err}");
}
