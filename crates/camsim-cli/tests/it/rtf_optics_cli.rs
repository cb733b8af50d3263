//! `camsim simulate` with shift-variant optics from the Pixel 4a ray-transfer function
//! (`examples/pixel4a-rtf-shift-variant.toml`, on a small window): a complete run, and a clear
//! error (exit code 2, naming the key) when `f_number` does not match the RTF's aperture.

use std::path::PathBuf;
use std::process::Command;

fn example() -> PathBuf {
    PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../examples/pixel4a-rtf-shift-variant.toml"
    ))
}

/// The example with a 96 x 128 window (and a field of view to match), the RTF copied next to the
/// config and named by a relative path (resolved against the config's folder).
fn small_config(dir: &std::path::Path, f_number: &str) -> PathBuf {
    let ex = example();
    let text = std::fs::read_to_string(&ex).unwrap();
    let rtf = ex
        .parent()
        .unwrap()
        .join("../../shared/data/isetcornellbox/lens/pixel4a-rearcamera-ellipse-raytransfer.json");
    let text = text
        .lines()
        .map(|l| {
            let key = l.split('=').next().unwrap_or("").trim();
            match key {
                "rows" => "rows = 96".to_string(),
                "cols" => "cols = 128".to_string(),
                "fov_deg" => "fov_deg = 3.0".to_string(),
                "patch_size_px" => "patch_size_px = 10".to_string(),
                "border_px" => "border_px = 2".to_string(),
                "count" => "count = 7".to_string(),
                "step_nm" => "step_nm = 50.0".to_string(),
                "f_number" => format!("f_number = {f_number}"),
                "rtf_file" => "rtf_file = \"lens/pixel4a-rtf.json\"".to_string(),
                _ => l.to_string(),
            }
        })
        .collect::<Vec<_>>()
        .join("\n");
    std::fs::create_dir_all(dir.join("lens")).unwrap();
    std::fs::copy(&rtf, dir.join("lens/pixel4a-rtf.json")).unwrap();
    let p = dir.join("rtf.toml");
    std::fs::write(&p, text).unwrap();
    p
}

#[test]
fn simulate_with_the_rtf_shift_variant_optics() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = small_config(dir.path(), "3.44");
    let out = dir.path().join("run");
    let o = Command::new(env!("CARGO_BIN_EXE_camsim"))
        .args([
            "simulate",
            cfg.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--quiet",
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(out.join("run.json").is_file());
}

#[test]
fn rtf_with_the_wrong_f_number_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = small_config(dir.path(), "1.73");
    let out = dir.path().join("run");
    let o = Command::new(env!("CARGO_BIN_EXE_camsim"))
        .args([
            "simulate",
            cfg.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--quiet",
        ])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("f_number") && err.contains("3.44"), "{err}");
    assert!(!out.join("run.json").exists());
}
