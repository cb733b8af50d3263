//! `[light_flicker]` through `simulate` (issue 41 item 5, per light): a scene lit by a steady sky
//! (group `sky`) and a lamp (group `lamp`) driven at 90 Hz, 10 % duty. The sensor is linear in
//! light before noise, so each pixel's noise-free signal is the sky's plus the lamp's times the
//! share of the lamp's time-mean light its row's window holds, on-time / (D T):
//! `nf = nf(sky) + g (nf(sky + lamp) - nf(sky))`, with nf(sky) the render whose lamp group
//! weighs 0 and nf(sky + lamp) the steady render (the same seed draws the same samples). The
//! on-time is summed from the square wave on a 0.1 us grid here, not by camsim's closed form.
//! Exposures of 1, 5.5 and 11.1 ms as the issue asks, a global shutter; then a rolling shutter,
//! where every row has its own share.

use camsim_pipeline::{simulate, SimulateConfig, SimulateOptions};

const SCENE: &str = r#"LookAt 0 3 -3  0 0 0  0 1 0
Camera "perspective" "float fov" 40
Film "rgb" "integer xresolution" 64 "integer yresolution" 48
WorldBegin
LightSource "infinite" "rgb L" [60 80 120] "string lightgroup" "sky"
AttributeBegin
  AreaLightSource "diffuse" "rgb L" [4800 4200 3000] "string lightgroup" "lamp"
  Shape "trianglemesh" "point3 P" [-0.3 1.5 -0.3  0.3 1.5 -0.3  0.3 1.5 0.3  -0.3 1.5 0.3]
    "integer indices" [0 1 2 0 2 3]
AttributeEnd
Material "diffuse" "rgb reflectance" [0.5 0.5 0.5]
Shape "trianglemesh" "point3 P" [-3 0 -3  3 0 -3  3 0 3  -3 0 3] "integer indices" [0 2 1 0 3 2]
"#;

const FREQ_HZ: f64 = 90.0;
const DUTY: f64 = 0.1;
const PHASE: f64 = 0.25;
const START_MS: f64 = 2.0;

fn run(
    extra: &str,
    render_extra: &str,
    exposure_ms: f64,
    shutter: &str,
) -> Result<Vec<f32>, String> {
    let opts = SimulateOptions {
        noise_free: true,
        ..Default::default()
    };
    let sim = simulate_scene(extra, render_extra, "", exposure_ms, shutter, &opts)?;
    Ok(sim.noise_free_frame(0).unwrap().to_vec())
}

/// `simulate` of [`SCENE`] on a 64 x 48 Pixel 4a window, with `extra` top-level tables,
/// `render_extra` and `sensor_extra` keys of `[render]` and `[sensor]`.
fn simulate_scene(
    extra: &str,
    render_extra: &str,
    sensor_extra: &str,
    exposure_ms: f64,
    shutter: &str,
    opts: &SimulateOptions,
) -> Result<camsim_pipeline::Simulation, String> {
    let dir = tempfile::tempdir().unwrap();
    let pbrt = dir.path().join("scene.pbrt");
    std::fs::write(&pbrt, SCENE).unwrap();
    let text = format!(
        r#"seed = 4
{extra}
[render]
pbrt = "{}"
samples_per_pixel = 4
{render_extra}
[sensor]
preset = "pixel4a"
rows = 48
cols = 64
{sensor_extra}
[capture]
exposure_ms = {exposure_ms}
start_ms = {START_MS}
shutter = {shutter}
"#,
        pbrt.display()
    );
    let cfg = SimulateConfig::from_toml_str(&text, std::path::Path::new(""))
        .map_err(|e| e.to_string())?;
    simulate(&cfg, opts, &|_, _, _| {}).map_err(|e| e.to_string())
}

const LAMP: &str = "[light_flicker]\nlamp = { frequency_hz = 90.0, duty = 0.1, phase = 0.25 }";

/// On-time of the LED within [t0, t1], s, summed on a 0.1 us grid.
fn on_time_numeric_s(t0: f64, t1: f64) -> f64 {
    let dt = 1e-7;
    let n = ((t1 - t0) / dt).round() as usize;
    (0..n)
        .filter(|i| {
            let u = (t0 + (*i as f64 + 0.5) * dt) * FREQ_HZ - PHASE;
            u - u.floor() < DUTY
        })
        .count() as f64
        * dt
}

fn share(start_s: f64, exposure_s: f64) -> f64 {
    on_time_numeric_s(start_s, start_s + exposure_s) / (DUTY * exposure_s)
}

/// Largest |nf - (sky + g (steady - sky))| over the pixels the lamp lights, relative to the
/// lamp's signal there, with `gain(row)` the row's share; and how many pixels were compared.
fn worst(nf: &[f32], sky: &[f32], steady: &[f32], gain: impl Fn(usize) -> f64) -> (f64, usize) {
    let white = 1023.0 * 0.95; // unsaturated pixels only (pixel4a: 10 bits)
    let mut worst = 0f64;
    let mut n = 0;
    for (i, ((f, s), p)) in nf.iter().zip(sky).zip(steady).enumerate() {
        let lamp = (*p - *s) as f64;
        if lamp < 2.0 || *f as f64 > white || *p as f64 > white {
            continue;
        }
        let want = *s as f64 + gain(i / 64) * lamp;
        worst = worst.max((*f as f64 - want).abs() / lamp);
        n += 1;
    }
    (worst, n)
}

#[test]
fn a_flickering_light_group_adds_its_share_and_the_steady_one_stays() {
    for exposure_ms in [1.0, 5.5, 11.1] {
        let shutter = "\"global\"";
        let nf = run(LAMP, "", exposure_ms, shutter).unwrap();
        let sky = run("", "light_groups = { lamp = 0.0 }", exposure_ms, shutter).unwrap();
        let steady = run("", "", exposure_ms, shutter).unwrap();
        let g = share(START_MS * 1e-3, exposure_ms * 1e-3);
        let (w, n) = worst(&nf, &sky, &steady, |_| g);
        assert!(n > 300, "{exposure_ms} ms: only {n} pixels lit by the lamp");
        assert!(
            w < 1e-3,
            "{exposure_ms} ms (share {g:.4}): worst relative error {w}"
        );
        // The LED turns on 7.8 ms into the capture's clock period (phase 0.25 of 11.11 ms, the
        // window from 2 ms): 1 ms holds 0.222 ms of on-time (2.22 x the mean), 5.5 ms a whole
        // on-phase (1.111 ms, 2.02 x), 11.1 ms nearly one period: flicker fades at whole periods.
        let want = [(1.0, 2.222), (5.5, 1.1111 / 0.55), (11.1, 1.001)];
        let (_, g0) = want.iter().find(|(t, _)| *t == exposure_ms).unwrap();
        assert!((g - g0).abs() < 2e-3, "{exposure_ms} ms: share {g}");
    }
}

#[test]
fn under_a_rolling_shutter_each_row_holds_its_own_share_of_the_group() {
    // Top-down: stored row r starts (rows - 1 - r) line times after its frame (raw.dng's bottom
    // row first, as tests/flicker.rs documents).
    let (line_us, exposure_ms) = (150.0, 1.0);
    let shutter =
        format!("{{ rolling = {{ line_time_us = {line_us}, direction = \"top-down\" }} }}");
    let nf = run(LAMP, "", exposure_ms, &shutter).unwrap();
    let sky = run("", "light_groups = { lamp = 0.0 }", exposure_ms, &shutter).unwrap();
    let steady = run("", "", exposure_ms, &shutter).unwrap();
    let gains: Vec<f64> = (0..48)
        .map(|r| {
            let start = START_MS * 1e-3 + (47 - r) as f64 * line_us * 1e-6;
            share(start, exposure_ms * 1e-3)
        })
        .collect();
    let (w, n) = worst(&nf, &sky, &steady, |r| gains[r]);
    assert!(n > 300, "only {n} pixels lit by the lamp");
    // The rows' grid of 0.1 us against the windows: 1e-4 of a 1 ms exposure.
    assert!(w < 2e-3, "worst relative error {w}");
    let (lo, hi) = gains
        .iter()
        .fold((f64::MAX, 0f64), |(a, b), g| (a.min(*g), b.max(*g)));
    assert!(
        lo < 0.5 && hi > 5.0,
        "the rows should see the LED off and on: {lo}..{hi}"
    );
}

/// The raw frame of a noiseless dual-pixel Pixel 4a sensor (DN, row-major) and the mean of its
/// left and right photodiode raws over the frame.
fn dual_raw(extra: &str, render_extra: &str, exposure_ms: f64) -> (Vec<f64>, [f64; 2]) {
    let dual = "[sensor.config]\ndual_pixel = true\n[sensor.config.noise]\n\
                shot = false\nread = false\ndsnu = false\nprnu = false\ndark = false";
    let opts = SimulateOptions::default();
    let sim = simulate_scene(extra, render_extra, dual, exposure_ms, "\"global\"", &opts).unwrap();
    let d = sim.dual_pixel.as_ref().expect("the photodiodes' raws");
    let mean =
        |r: &camsim_core::RawImage| r.dn.iter().map(|v| *v as f64).sum::<f64>() / r.dn.len() as f64;
    let raw = &sim.frames[0];
    let black = raw.black_level_dn;
    (
        raw.dn.iter().map(|v| *v as f64 - black).collect(),
        [mean(&d.left[0]) - black, mean(&d.right[0]) - black],
    )
}

/// A dual-pixel sensor under `[light_flicker]`: each photodiode integrates its half of the pupil's
/// steady and flickering light, and their sum is the pixel's, so the raw (noise off: rounding
/// alone) is the sky's plus the lamp's times its share of the window, as for one photodiode:
/// `raw = sky + g (steady - sky)` within the halves' rounding, and the two halves
/// each hold about half of it (a pinhole-rendered scene through a lens in focus).
#[test]
fn a_dual_pixel_sensor_takes_each_halfs_share_of_a_flickering_group() {
    let exposure_ms = 1.0;
    let (flicker, halves) = dual_raw(LAMP, "", exposure_ms);
    let (sky, _) = dual_raw("", "light_groups = { lamp = 0.0 }", exposure_ms);
    let (steady, _) = dual_raw("", "", exposure_ms);
    let g = share(START_MS * 1e-3, exposure_ms * 1e-3);
    assert!(g > 2.0, "share {g}");
    let white = 1023.0 * 0.95;
    let mut n = 0;
    let mut worst = 0f64;
    for ((f, s), p) in flicker.iter().zip(&sky).zip(&steady) {
        let lamp = p - s;
        if lamp < 5.0 || *f > white || *p > white {
            continue;
        }
        worst = worst.max((f - (s + g * lamp)).abs());
        n += 1;
    }
    assert!(n > 300, "only {n} pixels lit by the lamp");
    // Each raw is two rounded halves (+-1 DN): the identity's error is at most
    // 1 + |1 - g| + g = 2 g DN for g > 1.
    assert!(
        worst <= 2.0 * g,
        "worst |raw - (sky + g lamp)| {worst} DN (share {g})"
    );
    let total: f64 = flicker.iter().sum::<f64>() / flicker.len() as f64;
    for h in halves {
        assert!(
            (h / total - 0.5).abs() < 0.05,
            "halves {halves:?} of {total}"
        );
    }
}

#[test]
fn light_flicker_names_its_bad_keys() {
    let e = run(
        "[light_flicker]\nheadlamp = { frequency_hz = 90.0, duty = 0.1 }",
        "",
        1.0,
        "\"global\"",
    )
    .unwrap_err();
    assert!(
        e.contains("light_flicker.headlamp") && e.contains("lamp, sky"),
        "{e}"
    );
    let e = run(
        "[light_flicker]\nlamp = { frequency_hz = 90.0, duty = 1.5 }",
        "",
        1.0,
        "\"global\"",
    )
    .unwrap_err();
    assert!(e.contains("light_flicker.lamp.duty"), "{e}");
    let e = run(
        &format!("{LAMP}\n[flicker]\nfrequency_hz = 90.0\nduty = 0.1"),
        "",
        1.0,
        "\"global\"",
    )
    .unwrap_err();
    assert!(e.contains("not both"), "{e}");
}
