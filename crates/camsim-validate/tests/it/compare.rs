//! `compare` on two synthetic DNGs: region statistics against values computed independently in
//! the test from the pixel pattern, the noise prediction against the sensor model, and bad
//! configs rejected with errors that name the problem.

use camsim_core::{CfaPattern, RawImage};
use camsim_validate::{compare, CompareConfig};
use std::path::Path;

/// A 64 x 64 RGGB frame: black level 64, value black + base[channel] + offset + ((3 r + 5 c) mod 7).
fn frame(base: [u16; 3], offset: u16) -> RawImage {
    let mut raw = RawImage::new(64, 64, CfaPattern::Rggb, 12).unwrap();
    raw.black_level_dn = 64.0;
    raw.exposure_s = 0.01;
    raw.pixel_pitch_m = 1.4e-6;
    for r in 0..64 {
        for c in 0..64 {
            let ch = CfaPattern::Rggb.channel_at(r, c).index();
            raw.dn[r * 64 + c] = 64 + base[ch] + offset + ((3 * r + 5 * c) % 7) as u16;
        }
    }
    raw
}

/// Mean and sample std of channel `ch` above black in [row, col, rows, cols], by direct sums.
fn reference(raw: &RawImage, rect: [usize; 4], ch: usize) -> (f64, f64) {
    let mut v = Vec::new();
    for r in rect[0]..rect[0] + rect[2] {
        for c in rect[1]..rect[1] + rect[3] {
            if raw.cfa.channel_at(r, c).index() == ch {
                v.push(raw.dn[r * raw.cols + c] as f64 - raw.black_level_dn);
            }
        }
    }
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    let s = (v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (n - 1.0)).sqrt();
    (m, s)
}

fn write(path: &Path, raw: &RawImage) {
    camsim_io::dng::write_dng(path, raw, &camsim_io::dng::DngMetadata::default()).unwrap();
}

#[test]
fn compare_two_synthetic_dngs() {
    let dir = tempfile::tempdir().unwrap();
    let sim = frame([400, 800, 300], 0);
    let meas = frame([400, 800, 300], 10);
    write(&dir.path().join("sim.dng"), &sim);
    write(&dir.path().join("meas.dng"), &meas);
    let toml = r#"
simulated = "sim.dng"
measured = "meas.dng"
sensor = "pixel4a"
[[region]]
name = "a"
measured = [8, 8, 16, 16]
simulated = [8, 8, 16, 16]
[[region]]
name = "b (shifted)"
measured = [30, 31, 20, 12]
simulated = [32, 30, 20, 12]
"#;
    std::fs::write(dir.path().join("cmp.toml"), toml).unwrap();
    let cfg = CompareConfig::from_file(&dir.path().join("cmp.toml")).unwrap();
    let out = dir.path().join("out");
    let r = compare(&cfg, &out).unwrap();
    assert_eq!(r.regions.len(), 2);
    let sensor = camsim_sensor::Sensor::preset("pixel4a").unwrap();
    for (g, rc) in r.regions.iter().zip(&cfg.regions) {
        for ch in 0..3 {
            let (ms, ss) = reference(&sim, rc.simulated, ch);
            let (mm, sm) = reference(&meas, rc.measured, ch);
            assert!(
                (g.pair.a.mean_dn[ch] - ms).abs() < 1e-9,
                "{} ch {ch}: {} vs {ms}",
                g.name,
                g.pair.a.mean_dn[ch]
            );
            assert!((g.pair.b.mean_dn[ch] - mm).abs() < 1e-9);
            assert!((g.pair.a.std_dn[ch] - ss).abs() < 1e-9);
            assert!((g.pair.b.std_dn[ch] - sm).abs() < 1e-9);
            let pred = sensor.predicted_noise_dn(mm, sim.exposure_s).total;
            assert!((g.pair.predicted_std_dn_b.unwrap()[ch] - pred).abs() < 1e-9);
        }
    }
    // Region a is the same window: the means differ by exactly the offset, the stds not at all.
    for ch in 0..3 {
        assert!((r.regions[0].pair.mean_difference_dn[ch] - 10.0).abs() < 1e-9);
        assert!(r.regions[0].pair.std_difference_dn[ch].abs() < 1e-9);
    }
    assert!(out.join("report.html").is_file() && out.join("compare_std.png").is_file());
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).unwrap()).unwrap();
    assert_eq!(json["regions"].as_array().unwrap().len(), 2);
}

#[test]
fn bad_configs_are_errors_naming_the_problem() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    let e = CompareConfig::from_toml_str(
        "simulated = \"a.dng\"\nmeasured = \"b.dng\"\nregion = []\n",
        p,
        Path::new("c.toml"),
    )
    .unwrap_err();
    assert!(e.to_string().contains("no [[region]]"), "{e}");
    let e = CompareConfig::from_toml_str("simulated = 3\n", p, Path::new("c.toml")).unwrap_err();
    assert!(e.to_string().contains("c.toml"), "{e}");
    let e = CompareConfig::from_toml_str(
        "simulated = \"a.dng\"\nmeasured = \"b.dng\"\n[[region]]\nname = \"x\"\nmeasured = [0, 0, 0, 4]\nsimulated = [0, 0, 4, 4]\n",
        p,
        Path::new("c.toml"),
    )
    .unwrap_err();
    assert!(e.to_string().contains("has no pixels"), "{e}");
    // A missing DNG: an error naming the file, no panic, no report.
    let cfg = CompareConfig::from_toml_str(
        "simulated = \"missing.dng\"\nmeasured = \"b.dng\"\n[[region]]\nname = \"x\"\nmeasured = [0, 0, 4, 4]\nsimulated = [0, 0, 4, 4]\n",
        p,
        Path::new("c.toml"),
    )
    .unwrap();
    let e = compare(&cfg, &p.join("out")).unwrap_err();
    assert!(e.to_string().contains("missing.dng"), "{e}");
    assert!(!p.join("out/report.html").exists());
    // A region outside the image.
    write(&p.join("s.dng"), &frame([1, 2, 3], 0));
    let cfg = CompareConfig::from_toml_str(
        "simulated = \"s.dng\"\nmeasured = \"s.dng\"\n[[region]]\nname = \"x\"\nmeasured = [60, 60, 10, 10]\nsimulated = [0, 0, 4, 4]\n",
        p,
        Path::new("c.toml"),
    )
    .unwrap();
    assert!(compare(&cfg, &p.join("out")).is_err());
}
