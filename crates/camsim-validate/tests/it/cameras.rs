//! `compare_cameras`: closed-form checks, not snapshots.

use camsim_validate::{compare_cameras, CameraCompareOptions, CameraSpec};

/// The pixel4a sensor with only photon shot noise (no read, DSNU, PRNU, dark or quantization
/// noise), written as a sensor TOML file.
fn shot_noise_only_sensor(dir: &std::path::Path) -> String {
    let mut cfg = camsim_sensor::Sensor::preset("pixel4a")
        .unwrap()
        .config()
        .clone();
    cfg.noise = camsim_sensor::NoiseSwitches {
        shot: true,
        read: false,
        dsnu: false,
        prnu: false,
        dark: false,
        quantization: false,
    };
    let path = dir.join("shot-only.toml");
    std::fs::write(&path, cfg.to_toml()).unwrap();
    path.to_string_lossy().into_owned()
}

#[test]
fn a_camera_compared_with_itself_measures_the_same() {
    let mut o = CameraCompareOptions::new(
        CameraSpec::new("pixel4a", "pixel4a"),
        CameraSpec::new("pixel4a", "pixel4a"),
    );
    o.size_px = 64;
    let r = compare_cameras(&o, &|_, _, _| {}).unwrap();
    assert_eq!(r.a.mtf.mtf, r.b.mtf.mtf);
    assert_eq!(r.a.color.patch_delta_e2000, r.b.color.patch_delta_e2000);
    assert_eq!(r.a.noise.snr[1].snr, r.b.noise.snr[1].snr);
    assert_eq!(r.a.noise.visual_noise, r.b.noise.visual_noise);
    // Sanity of the numbers themselves: an MTF that starts at 1 and an MTF50 below Nyquist, a
    // colour error of a few units, a finite SNR.
    assert!((r.a.mtf.mtf[0] - 1.0).abs() < 0.05, "{}", r.a.mtf.mtf[0]);
    let mtf50 = r.a.mtf.mtf50_cy_per_px.unwrap();
    assert!(mtf50 > 0.05 && mtf50 < 0.5, "{mtf50}");
    assert!(
        r.a.mtf.acutance > 0.2 && r.a.mtf.acutance < 1.0,
        "{}",
        r.a.mtf.acutance
    );
    assert!(
        r.a.color.mean_delta_e2000 > 0.0 && r.a.color.mean_delta_e2000 < 10.0,
        "{}",
        r.a.color.mean_delta_e2000
    );
    assert!(r.a.noise.snr[1].snr.is_finite() && r.a.noise.snr[1].snr > 5.0);
}

#[test]
fn four_times_the_pixel_area_doubles_the_shot_noise_limited_snr() {
    let dir = tempfile::tempdir().unwrap();
    let sensor = shot_noise_only_sensor(dir.path());
    let a = CameraSpec::new(sensor.clone(), "pixel4a");
    let pitch_um = camsim_sensor::Sensor::preset("pixel4a")
        .unwrap()
        .pixel_pitch_m()
        * 1e6;
    let b = CameraSpec {
        pixel_pitch_um: Some(2.0 * pitch_um),
        ..CameraSpec::new(sensor, "pixel4a")
    };
    let mut o = CameraCompareOptions::new(a, b);
    o.size_px = 128;
    o.out_dir = Some(dir.path().join("report"));
    let r = compare_cameras(&o, &|_, _, _| {}).unwrap();
    // Same exposure time, 4x the collecting area: 4x the electrons, SNR = sqrt(N) twice as high.
    assert_eq!(r.a.noise.exposure_s, r.b.noise.exposure_s);
    let signal = r.b.noise.snr[1].mean / r.a.noise.snr[1].mean;
    let ratio = r.b.noise.snr[1].snr / r.a.noise.snr[1].snr;
    eprintln!("4x pixel area: signal x {signal:.3}, green SNR x {ratio:.3} (expected 4 and 2)");
    assert!((signal - 4.0).abs() < 0.1, "signal ratio {signal}");
    assert!((ratio - 2.0).abs() < 0.1, "SNR ratio {ratio}");
    for k in 0..3 {
        let rk = r.b.noise.snr[k].snr / r.a.noise.snr[k].snr;
        assert!((rk - 2.0).abs() < 0.15, "channel {k}: SNR ratio {rk}");
    }
    // The same processing and viewing for both, half the relative noise: half the visual noise
    // (small noise: L*, u*, v* are linear in it about the grey).
    let (va, vb) = (&r.a.noise.visual_noise, &r.b.noise.visual_noise);
    let vn = vb.visual_noise / va.visual_noise;
    eprintln!("4x pixel area: visual noise x {vn:.3} (expected 0.5)");
    assert!(
        (vn - 0.5).abs() < 0.05,
        "visual noise ratio {vn}: {va:?} {vb:?}"
    );
    assert!(
        (va.mean_luv[0] - 76.07).abs() < 0.5,
        "the field as 50 % grey: {va:?}"
    );
    for f in [
        "report.html",
        "results.json",
        "compare_mtf.png",
        "compare_snr.png",
        "compare_nps.png",
        "compare_delta_e.png",
    ] {
        assert!(dir.path().join("report").join(f).is_file(), "{f} missing");
    }
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("report/results.json")).unwrap())
            .unwrap();
    assert_eq!(
        json["a"]["color"]["patch_delta_e2000"]
            .as_array()
            .map(|v| v.len()),
        Some(24)
    );
}

#[test]
fn bad_cameras_are_errors() {
    let mut o = CameraCompareOptions::new(
        CameraSpec::new("no-such-sensor", "pixel4a"),
        CameraSpec::new("pixel4a", "pixel4a"),
    );
    let e = compare_cameras(&o, &|_, _, _| {}).unwrap_err();
    assert!(e.to_string().contains("no-such-sensor"), "{e}");
    o.a = CameraSpec {
        pixel_pitch_um: Some(f64::NAN),
        ..CameraSpec::new("pixel4a", "pixel4a")
    };
    assert!(compare_cameras(&o, &|_, _, _| {}).is_err());
    o.a = CameraSpec::new("pixel4a", "pixel4a");
    o.size_px = 4;
    assert!(compare_cameras(&o, &|_, _, _| {})
        .unwrap_err()
        .to_string()
        .contains("size"));
}
