//! `camsim compare`: the run writes its report, results and plots; the same camera twice measures
//! the same; a bad sensor is refused with exit 2 and no output folder.

use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_camsim");

#[test]
fn compare_writes_the_report_and_a_camera_matches_itself() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("cmp");
    let o = Command::new(BIN)
        .args([
            "compare", "--a", "pixel4a", "--b", "pixel4a", "--size", "64", "--quiet", "--out",
        ])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for f in [
        "report.html",
        "results.json",
        "compare_mtf.png",
        "compare_snr.png",
        "compare_nps.png",
        "compare_delta_e.png",
    ] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    let j: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("results.json")).unwrap()).unwrap();
    assert_eq!(j["a"]["mtf"]["mtf"], j["b"]["mtf"]["mtf"]);
    assert_eq!(
        j["a"]["color"]["patch_delta_e2000"],
        j["b"]["color"]["patch_delta_e2000"]
    );
    assert_eq!(
        j["a"]["color"]["patch_delta_e2000"]
            .as_array()
            .map(|v| v.len()),
        Some(24)
    );
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(html.contains("CIEDE2000") && html.contains("MTF50") && html.contains("SNR G"));
}

#[test]
fn a_bad_sensor_exits_2_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("cmp");
    let o = Command::new(BIN)
        .args(["compare", "--a", "no-such-sensor", "--size", "64", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("no-such-sensor"));
    assert!(!out.exists());
}
