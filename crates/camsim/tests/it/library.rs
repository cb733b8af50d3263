//! The library facade as a Rust user calls it: the pipeline in memory, files as a separate step
//! (read back bit for bit), the field-of-view rule, typed errors.

use camsim::{
    simulate, Error, ExrCompression, ExrOptions, ExrPrecision, OutputSet, RunInfo, SimulateConfig,
    SimulateOptions,
};
use std::path::Path;

/// A small config (48 x 64 window, 2 frames), shared with the Python tests.
const SMALL: &str = include_str!("../small.toml");

fn quiet(_: &str, _: u64, _: u64) {}

#[test]
fn simulation_in_memory_equals_its_files_bit_for_bit() {
    let cfg = SimulateConfig::from_toml_str(SMALL, Path::new("")).unwrap();
    let sim = simulate(
        &cfg,
        &SimulateOptions {
            noise_free: true,
            ..Default::default()
        },
        &quiet,
    )
    .unwrap();
    assert_eq!(sim.frames.len(), 2);
    assert_eq!((sim.frames[0].rows, sim.frames[0].cols), (48, 64));
    assert_eq!(
        (sim.preview.rows, sim.preview.cols, sim.preview.data.len()),
        (48, 64, 48 * 64 * 3)
    );
    assert!(sim.times_s.contains_key("total_s"));
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let outputs = OutputSet::parse("raw,irradiance,radiance,noise-free,depth").unwrap();
    sim.write(&out, &outputs, ExrOptions::default(), &RunInfo::default())
        .unwrap();
    // Raw frames: the DNGs hold exactly the in-memory DN.
    for (i, name) in ["raw.dng", "raw_0001.dng"].iter().enumerate() {
        let (raw, _) = camsim::io::dng::read_dng(&out.join(name)).unwrap();
        assert_eq!(raw.dn, sim.frames[i].dn, "{name}");
    }
    // Spectral EXRs (f32, uncompressed by default): bit-exact.
    let irr = camsim::io::exr::read_spectral_exr(&out.join("irradiance.exr")).unwrap();
    assert_eq!(irr.data, sim.irradiance.data);
    assert_eq!(irr.sample_spacing_m, sim.irradiance.sample_spacing_m);
    let rad = camsim::io::exr::read_spectral_exr(&out.join("radiance.exr")).unwrap();
    assert_eq!(
        rad.data,
        sim.radiance.as_ref().expect("a chart has radiance").data
    );
    let (r, c, nf) =
        camsim::io::exr::read_gray_exr(&out.join("noise_free.exr"), Some("Y")).unwrap();
    assert_eq!((r, c), (48, 64));
    assert_eq!(Some(nf.as_slice()), sim.noise_free_frame(0));
    // Not asked for: not written. A 2D chart has no depth map: skipped, and run.json says so.
    assert!(
        !out.join("preview.png").exists()
            && !out.join("raw.png").exists()
            && !out.join("depth.exr").exists()
    );
    let run: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("run.json")).unwrap()).unwrap();
    assert!(run["files"]["depth.exr"]
        .as_str()
        .unwrap()
        .contains("no depth map"));
    assert_eq!(run["results"]["frames"], 2);
    // The noise-free image is the mean the noisy frames scatter around: over the pixels well above
    // the read noise (the pixel4a preset has no black-level offset, so the ADC clips the read
    // noise of the darkest pixels at 0 and raises their mean), the two agree to within the noise
    // of the mean; and the noise-free values are not rounded.
    let lit: Vec<usize> = (0..nf.len())
        .filter(|i| nf[*i] > 100.0 && nf[*i] < 3500.0)
        .collect();
    assert!(lit.len() > nf.len() / 3);
    let mean_nf = lit.iter().map(|i| nf[*i] as f64).sum::<f64>() / lit.len() as f64;
    let raw_mean = lit.iter().map(|i| sim.frames[0].dn[*i] as f64).sum::<f64>() / lit.len() as f64;
    assert!(
        (raw_mean - mean_nf).abs() < 0.01 * mean_nf,
        "noisy mean {raw_mean} vs noise-free {mean_nf}"
    );
    assert!(
        nf.iter().any(|v| v.fract() != 0.0),
        "noise-free values should be unquantized"
    );
}

#[test]
fn half_float_exrs_round_to_within_half_precision() {
    let cfg = SimulateConfig::from_toml_str(SMALL, Path::new("")).unwrap();
    let sim = simulate(&cfg, &SimulateOptions::default(), &quiet).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let opts = ExrOptions {
        precision: ExrPrecision::F16,
        compression: ExrCompression::Zip,
    };
    sim.write(
        &out,
        &OutputSet::parse("radiance").unwrap(),
        opts,
        &RunInfo::default(),
    )
    .unwrap();
    let rad = camsim::io::exr::read_spectral_exr(&out.join("radiance.exr")).unwrap();
    // Radiance of a 100 cd/m^2 chart is ~1e-3..1e-2 W/(sr m^2 nm): normal f16 range, relative
    // rounding error <= 2^-11.
    for (a, b) in rad
        .data
        .iter()
        .zip(&sim.radiance.as_ref().expect("a chart has radiance").data)
    {
        assert!(
            (a - b).abs() <= b.abs() * 2f32.powi(-11) + 1e-7,
            "{a} vs {b}"
        );
    }
}

#[test]
fn the_field_of_view_rule_uses_the_image_distance_of_the_focus() {
    let mut lens = camsim::optics::OpticsConfig::preset("pixel4a").unwrap();
    let f = lens.focal_length_mm * 1e-3;
    // No focus distance anywhere: focused at infinity, v = f.
    assert_eq!(camsim::sensor_image_distance_m(&lens, None).unwrap(), f);
    // The scene's focus distance, 1 m: v = 1 / (1/f - 1/d), 0.44 % beyond f.
    let v = camsim::sensor_image_distance_m(&lens, Some(1.0)).unwrap();
    assert!((v - 1.0 / (1.0 / f - 1.0)).abs() < 1e-15 && v / f > 1.004);
    // The lens's own focus distance wins over the scene's.
    lens.focus_distance_m = Some(0.3);
    assert_eq!(
        camsim::sensor_image_distance_m(&lens, Some(1.0)).unwrap(),
        1.0 / (1.0 / f - 1.0 / 0.3)
    );
    let fov = camsim::field_of_view_deg(2.0 * v, v);
    assert!((fov - 90.0).abs() < 1e-12);
    lens.focus_distance_m = Some(0.001);
    assert!(matches!(
        camsim::sensor_image_distance_m(&lens, None),
        Err(Error::Config(_))
    ));
}

#[test]
fn bad_configs_are_typed_errors_naming_the_key() {
    let e = SimulateConfig::from_toml_str(
        &SMALL.replace("exposure_ms = 8.0", "exposure_ms = \"x\""),
        Path::new(""),
    )
    .unwrap_err();
    assert!(
        matches!(e, Error::Config(_)) && e.to_string().contains("exposure_ms"),
        "{e}"
    );
    let mut cfg = SimulateConfig::from_toml_str(SMALL, Path::new("")).unwrap();
    cfg.capture.frames = 0;
    let e = simulate(&cfg, &SimulateOptions::default(), &quiet).unwrap_err();
    assert!(e.to_string().contains("capture.frames"), "{e}");
    cfg.capture.frames = 1;
    cfg.sensor.rows = Some(100_000);
    let e = simulate(&cfg, &SimulateOptions::default(), &quiet).unwrap_err();
    assert!(matches!(e, Error::Sensor(_)), "{e:?}");
}
