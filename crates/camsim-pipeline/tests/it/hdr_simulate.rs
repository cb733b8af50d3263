//! An `[hdr]` sensor through `simulate` (issue 41 item 4): the run's capture is the sensor
//! stage's own (the same readouts and merge, bit for bit), its files hold both readouts and the
//! merged frame, and the dynamic range measured on simulated captures equals the sensor model's.
//!
//! Closed forms (examples/sensor-dcg.toml; EMVA 1288 release 4.0, eqs. 9 and 11):
//! - temporal noise at zero light, from the difference of two frames (fixed pattern cancels):
//!   sigma_d = sqrt(read_HCG^2 + 1 / (12 K_HCG^2)) electrons ([`camsim_sensor::HdrModel::noise_floor_e`]);
//! - saturation: the merged frame tops out at the low readout's saturation / sensitivity ratio
//!   ([`camsim_sensor::HdrModel::max_merged_e`]);
//! - so DR = 20 log10(saturation / sigma_d). The noise estimate from 64 x 64 pixel pairs has a
//!   relative standard error of 1 / sqrt(2 x 4096) = 1.1 %, 0.1 dB: the bound is 0.3 dB.
//! - above the switch the merged frame stays linear: its mean over the green pixels equals the
//!   noise-free mean electrons within PRNU's and the LCG quantization's share (< 1 %).

use camsim_pipeline::{simulate, Captured, SimulateConfig, SimulateOptions};
use std::path::Path;

fn examples() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples")
}

fn config(luminance_cd_m2: f64, frames: usize) -> SimulateConfig {
    let text = format!(
        r#"
seed = 3
[scene]
kind = "uniform"
mean_luminance_cd_m2 = {luminance_cd_m2}
fov_deg = 10.0
illuminant = "D65"
rows = 32
cols = 32
[optics]
preset = "diffraction-limited"
[optics.config]
shading = "none"
[sensor]
file = "sensor-dcg.toml"
rows = 64
cols = 64
[capture]
exposure_ms = 10.0
frames = {frames}
"#
    );
    SimulateConfig::from_toml_str(&text, &examples()).unwrap()
}

fn run(luminance_cd_m2: f64, frames: usize) -> camsim_pipeline::Simulation {
    simulate(
        &config(luminance_cd_m2, frames),
        &SimulateOptions::default(),
        &|_, _, _| {},
    )
    .unwrap()
}

/// Mean of the merged frame over the green pixels of an RGGB mosaic.
fn green_mean(merged: &[f32], cols: usize) -> f64 {
    let (mut s, mut n) = (0.0, 0usize);
    for (i, v) in merged.iter().enumerate() {
        let (r, c) = (i / cols, i % cols);
        if (r + c) % 2 == 1 {
            s += *v as f64;
            n += 1;
        }
    }
    s / n as f64
}

#[test]
fn simulate_captures_an_hdr_sensor_as_the_sensor_stage_does_and_measures_its_dynamic_range() {
    // Dark: two frames, their difference is temporal noise only.
    let dark = run(0.0, 2);
    let h = dark
        .hdr
        .as_ref()
        .expect("an [hdr] sensor's run keeps both readouts");
    assert_eq!(
        (h.low.len(), h.merged_e.len(), dark.frames.len()),
        (2, 2, 2)
    );
    let model = h.model;
    let n = h.merged_e[0].len();
    let diff: Vec<f64> = h.merged_e[0]
        .iter()
        .zip(&h.merged_e[1])
        .map(|(a, b)| (*a - *b) as f64)
        .collect();
    let mean = diff.iter().sum::<f64>() / n as f64;
    let var = diff.iter().map(|d| (d - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
    let noise_e = (var / 2.0).sqrt();

    // Saturated: every pixel past the low readout's saturation.
    let bright = run(1e6, 1);
    let hb = bright.hdr.as_ref().unwrap();
    let sat_e = hb.merged_e[0].iter().map(|v| *v as f64).sum::<f64>() / n as f64;
    assert!(
        (sat_e / model.max_merged_e() - 1.0).abs() < 2e-3,
        "merged saturation {sat_e:.0} e- against the model's {:.0} e-",
        model.max_merged_e()
    );
    let dr_db = 20.0 * (sat_e / noise_e).log10();
    assert!(
        (dr_db - model.dynamic_range_db()).abs() < 0.3,
        "dynamic range through simulate {dr_db:.2} dB (noise {noise_e:.3} e-, saturation {sat_e:.0} e-) against the sensor model's {:.2} dB",
        model.dynamic_range_db()
    );
    // The run.json figures are the model's.
    let rec = dark.record(&Default::default(), &Default::default());
    let hr = rec.results.hdr.expect("run.json results.hdr");
    assert_eq!(hr.dynamic_range_db, model.dynamic_range_db());

    // Above the switch: linear. Find the luminance that puts ~4x the switch signal on green.
    let probe = run(1.0, 1);
    let e_per_cd = probe.mean_electrons_rgb[1];
    let target_e = 4.0 * model.switch_e;
    let mid = run(target_e / e_per_cd, 1);
    let g_mean = green_mean(&mid.hdr.as_ref().unwrap().merged_e[0], mid.frames[0].cols);
    assert!(
        (g_mean / mid.mean_electrons_rgb[1] - 1.0).abs() < 0.01,
        "merged green mean {g_mean:.0} e- against the noise-free {:.0} e-",
        mid.mean_electrons_rgb[1]
    );

    // The capture is the sensor stage's: the same request on the run's irradiance gives the same
    // readouts and merge, bit for bit.
    let cfg = config(0.0, 2);
    let sensor = cfg.sensor().unwrap();
    let req = cfg.capture_request().unwrap();
    let Captured::Hdr(stage) =
        camsim_pipeline::capture::capture(&sensor, &dark.irradiance, &req).unwrap()
    else {
        panic!("an [hdr] sensor's capture is an HDR one");
    };
    assert_eq!(stage.high, dark.frames);
    assert_eq!(stage.low, h.low);
    assert_eq!(stage.merged_e, h.merged_e);
}

/// A ColorChecker on the DCG sensor, lit so that its white patch lands at ~5x the HCG
/// readout's saturation: the bright grey patches all saturate the HCG raw, but the merge keeps
/// them apart.
fn macbeth_run() -> (camsim_pipeline::Simulation, SimulateConfig) {
    let text = |l: f64| {
        format!(
            r#"
seed = 5
[scene]
kind = "macbeth"
mean_luminance_cd_m2 = {l}
fov_deg = 6.0
patch_size_px = 16
border_px = 4
[optics]
preset = "diffraction-limited"
[optics.config]
shading = "none"
[sensor]
file = "sensor-dcg.toml"
rows = 120
cols = 160
[capture]
exposure_ms = 10.0
[isp]
tone_map = "clip"    # linear up to white, so patch ratios are the scene's
"#
        )
    };
    let cfg = |l: f64| SimulateConfig::from_toml_str(&text(l), &examples()).unwrap();
    let go = |c: &SimulateConfig| simulate(c, &SimulateOptions::default(), &|_, _, _| {}).unwrap();
    // The chart's mean reflectance is ~0.2 of the white patch's (0.9): its mean green signal
    // at 1 cd/m^2 sets the scale.
    let probe = go(&cfg(1.0));
    let sat_e = probe.hdr.as_ref().unwrap().model.high_saturation_e();
    let l = 5.0 * sat_e * 0.2 / probe.mean_electrons_rgb[1];
    let c = cfg(l);
    (go(&c), c)
}

#[test]
fn an_hdr_run_writes_both_readouts_and_the_merged_frame_and_its_preview_shows_the_merge() {
    use camsim_analysis::chart::{chart_patch_stats_rgb, ChartCorners};
    use camsim_analysis::Plane;
    let (sim, cfg) = macbeth_run();
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    sim.write(
        &out,
        &camsim_pipeline::OutputSet::default(),
        Default::default(),
        &Default::default(),
    )
    .unwrap();
    for f in [
        "raw.dng",
        "raw_low.dng",
        "merged.exr",
        "preview.png",
        "run.json",
    ] {
        assert!(out.join(f).is_file(), "{f} written");
    }
    let (high, _) = camsim_io::dng::read_dng(&out.join("raw.dng")).unwrap();
    let (low, _) = camsim_io::dng::read_dng(&out.join("raw_low.dng")).unwrap();
    let (_, _, merged) = camsim_io::exr::read_gray_exr(&out.join("merged.exr"), Some("Y")).unwrap();
    let h = sim.hdr.as_ref().unwrap();
    assert_eq!(high.dn, sim.frames[0].dn);
    for ((a, b), m) in high.dn.iter().zip(&low.dn).zip(&merged) {
        assert_eq!(
            h.model.merge(*a, *b),
            *m,
            "merged.exr follows the merge rule"
        );
    }

    // Patch means of the HCG raw (green pixels, as a plane) and of the decoded preview.
    let raw = &sim.frames[0];
    let c = camsim_pipeline::macbeth_chart_corners_px(
        &cfg,
        &sim.optics,
        sim.sensor.pixel_pitch_um * 1e-6,
        raw.rows,
        raw.cols,
    )
    .unwrap()
    .unwrap();
    let corners = ChartCorners {
        top_left: c[0],
        top_right: c[1],
        bottom_right: c[2],
        bottom_left: c[3],
    };
    let grey = |v: Vec<f32>| Plane::new(raw.rows, raw.cols, v).unwrap();
    let raw_plane = grey(raw.dn.iter().map(|v| *v as f32).collect());
    let raw_stats = chart_patch_stats_rgb(
        &[raw_plane.clone(), raw_plane.clone(), raw_plane],
        &corners,
        0.5,
    )
    .unwrap();
    let p = &sim.preview;
    let plane = |k: usize| {
        grey(
            (0..p.rows * p.cols)
                .map(|i| {
                    camsim_core::colorimetry::srgb_decode(p.data[3 * i + k] as f64 / 255.0) as f32
                })
                .collect(),
        )
    };
    let stats = chart_patch_stats_rgb(&[plane(0), plane(1), plane(2)], &corners, 0.5).unwrap();
    // White (19) and neutral 8 (20) both saturate the HCG readout...
    for patch in [19, 20] {
        assert!(
            raw_stats[patch - 1].mean[0] > 0.99 * raw.white_level_dn,
            "patch {patch}: HCG mean {:.0} DN, white {}",
            raw_stats[patch - 1].mean[0],
            raw.white_level_dn
        );
    }
    // ... yet the preview of the merged frame keeps them apart (luminance ratio 0.90 / 0.59 of
    // Ohta's reflectances, ~1.5; below 1.25 would mean the merge was lost).
    assert!(sim.preview_note.is_none(), "{:?}", sim.preview_note);
    let (w, n8) = (stats[18].mean[1], stats[19].mean[1]);
    assert!(
        w > 1.25 * n8 && w < 1.8 * n8,
        "preview green: white {w:.3}, neutral 8 {n8:.3}"
    );
}

/// Issue 41 item 6 through `simulate`: a bracket of a plain sensor (64, 4, 0.25 ms) of a field
/// that saturates the longest frame merges into merged.exr, electrons at the longest exposure:
/// its mean over the green pixels is the noise-free signal there (which no single frame holds:
/// the 64 ms one is clipped) within 1 %.
#[test]
fn a_bracket_of_a_plain_sensor_merges_into_one_linear_frame() {
    let text = |l: f64| {
        format!(
            r#"
seed = 4
[scene]
kind = "uniform"
mean_luminance_cd_m2 = {l}
rows = 16
cols = 16
[optics]
preset = "diffraction-limited"
[optics.config]
shading = "none"
[sensor]
preset = "pixel4a"
rows = 64
cols = 64
[capture]
exposures_ms = [64.0, 4.0, 0.25]
"#
        )
    };
    let go = |l: f64| {
        let c = SimulateConfig::from_toml_str(&text(l), Path::new("")).unwrap();
        simulate(&c, &SimulateOptions::default(), &|_, _, _| {}).unwrap()
    };
    // 30x the long frame's saturation on green.
    let probe = go(1.0);
    let sensor = probe.config.sensor().unwrap();
    let l = 30.0 * sensor.well_capacity_e() / probe.mean_electrons_rgb[1];
    let sim = go(l);
    assert!(
        sim.frames[0]
            .dn
            .iter()
            .all(|v| *v as f64 >= sim.frames[0].white_level_dn),
        "the 64 ms frame is saturated"
    );
    let b = sim.bracket_merge.as_ref().expect("a bracket is merged");
    assert_eq!(b.merged.reference_exposure_s, 64e-3);
    assert_eq!(b.merged.saturated, 0);
    let g = green_mean(&b.merged.electrons, 64);
    assert!(
        (g / sim.mean_electrons_rgb[1] - 1.0).abs() < 0.01,
        "merged green {g:.0} e-, noise-free {:.0} e-",
        sim.mean_electrons_rgb[1]
    );
    let dir = tempfile::tempdir().unwrap();
    sim.write(
        &dir.path().join("b"),
        &camsim_pipeline::OutputSet::default(),
        Default::default(),
        &Default::default(),
    )
    .unwrap();
    let (_, _, m) =
        camsim_io::exr::read_gray_exr(&dir.path().join("b/merged.exr"), Some("Y")).unwrap();
    assert_eq!(m, b.merged.electrons);
    assert!(sim.preview_note.is_none(), "{:?}", sim.preview_note);
}
