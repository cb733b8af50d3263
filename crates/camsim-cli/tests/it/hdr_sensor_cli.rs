//! `camsim sensor` with an `[hdr]` sensor: bad HDR values exit 2 naming the file and the key and
//! leave no output; a good one writes both readouts' DNGs and the merged EXR, whose values are
//! the merged electrons (checked against the DNGs with the documented merge rule).

use std::path::Path;
use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_camsim");

fn examples() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples")
}

fn camsim(args: &[&str], dir: &Path) -> (Option<i32>, String) {
    let o = Command::new(BIN)
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap();
    (
        o.status.code(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

#[test]
fn bad_hdr_values_exit_2_and_good_ones_write_high_low_and_merged() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (code, err) = camsim(
        &[
            "scene",
            &examples().join("zone-plate.toml").to_string_lossy(),
            "--out",
            "radiance.exr",
        ],
        d,
    );
    assert_eq!(code, Some(0), "{err}");
    let (code, err) = camsim(
        &["optics", "--in", "radiance.exr", "--out", "irradiance.exr"],
        d,
    );
    assert_eq!(code, Some(0), "{err}");
    let dcg = std::fs::read_to_string(examples().join("sensor-dcg.toml")).unwrap();
    let split = std::fs::read_to_string(examples().join("sensor-split-pixel.toml")).unwrap();
    let cases = [
        (
            split.replace("sensitivity_ratio = 0.0625", "sensitivity_ratio = 0.0"),
            "hdr.sensitivity_ratio",
        ),
        (
            split.replace("sensitivity_ratio = 0.0625", "sensitivity_ratio = -1.0"),
            "hdr.sensitivity_ratio",
        ),
        (
            dcg.replace("switch_level = 0.8", "switch_level = 1.5"),
            "hdr.switch_level",
        ),
        (
            dcg.replace(
                "lcg_conversion_gain_uv_per_e = 10.0",
                "lcg_conversion_gain_uv_per_e = 90.0",
            ),
            "hdr.lcg_conversion_gain_uv_per_e",
        ),
        (dcg.replace("mode = \"dcg\"", "mode = \"triple\""), "triple"),
    ];
    for (i, (text, key)) in cases.iter().enumerate() {
        assert_ne!(text, &dcg);
        let file = format!("bad{i}.toml");
        std::fs::write(d.join(&file), text).unwrap();
        let out = format!("out-bad{i}");
        let (code, err) = camsim(
            &[
                "sensor",
                "--in",
                "irradiance.exr",
                "--sensor",
                &file,
                "--out",
                &out,
            ],
            d,
        );
        assert_eq!(code, Some(2), "{key}: {err}");
        assert!(err.contains(key) && err.contains(&file), "{key}: {err}");
        assert!(!d.join(&out).exists(), "{key}: output written");
    }
    let (code, err) = camsim(
        &[
            "sensor",
            "--in",
            "irradiance.exr",
            "--sensor",
            &examples().join("sensor-dcg.toml").to_string_lossy(),
            "--out",
            "dcg",
        ],
        d,
    );
    assert_eq!(code, Some(0), "{err}");
    for f in ["high.dng", "low.dng", "merged.exr"] {
        assert!(d.join("dcg").join(f).is_file(), "{f}");
    }
    let (high, _) = camsim_io::dng::read_dng(&d.join("dcg/high.dng")).unwrap();
    let (low, _) = camsim_io::dng::read_dng(&d.join("dcg/low.dng")).unwrap();
    let (rows, cols, merged) =
        camsim_io::exr::read_gray_exr(&d.join("dcg/merged.exr"), Some("Y")).unwrap();
    assert_eq!((rows, cols), (high.rows, high.cols));
    // The documented merge: HCG electrons below 80 % of the HCG range, LCG electrons above.
    let k_high = 80e-6 * 4096.0 / 0.5;
    let k_low = 10e-6 * 4096.0 / 0.5;
    let switch_e = 0.8 * (4095.0 - 64.0) / k_high;
    let mut used_low = 0;
    for (i, m) in merged.iter().enumerate() {
        let e_high = (high.dn[i] as f64 - 64.0) / k_high;
        let want = if e_high < switch_e {
            e_high
        } else {
            (low.dn[i] as f64 - 64.0) / k_low
        };
        used_low += (e_high >= switch_e) as usize;
        assert!(
            (*m as f64 - want).abs() <= 1e-3 * want.abs().max(1.0),
            "pixel {i}: {m} vs {want}"
        );
    }
    assert!(
        used_low > 0,
        "auto-exposure at 90 % of the HCG swing puts some pixels above the switch"
    );
}

/// `camsim simulate` with an `[hdr]` sensor writes both readouts and their merge (issue 41
/// item 4): the high-gain raw as `raw.dng`, the low-gain one as `raw_low.dng`, the merged
/// linear image in electrons as `merged.exr`, and the readouts' figures under `results.hdr`.
#[test]
fn simulate_with_an_hdr_sensor_writes_both_readouts_and_the_merge() {
    let dir = tempfile::tempdir().unwrap();
    let sensor = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../examples/sensor-dcg.toml"
    );
    let cfg = dir.path().join("hdr.toml");
    std::fs::write(
        &cfg,
        format!("seed = 1\n[scene]\nkind = \"macbeth\"\n[sensor]\nfile = \"{sensor}\"\n"),
    )
    .unwrap();
    let out = dir.path().join("out");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_camsim"))
        .args([
            "simulate",
            cfg.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--quiet",
        ])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{stderr}");
    for f in ["raw.dng", "raw_low.dng", "merged.exr", "run.json"] {
        assert!(out.join(f).is_file(), "{f} missing: {stderr}");
    }
    let run: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("run.json")).unwrap()).unwrap();
    assert!(
        run["results"]["hdr"].is_object(),
        "run.json has no results.hdr: {run}"
    );

    // The same sensor noise-free cannot be merged (the merge weighs each readout by its
    // noise): refused with exit 2, naming [hdr], and nothing written.
    let out2 = dir.path().join("out2");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_camsim"))
        .args([
            "simulate",
            cfg.to_str().unwrap(),
            "--out",
            out2.to_str().unwrap(),
            "--save",
            "raw,noise-free",
            "--quiet",
        ])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("[hdr]"), "{stderr}");
    assert!(!out2.exists(), "a partial output folder was left");
}
