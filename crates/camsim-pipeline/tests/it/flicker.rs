//! `[flicker]` through `simulate` (issue 41 item 5): a 90 Hz, 10 % duty LED lighting a uniform
//! field, a top-down rolling shutter (stored row r starts (rows - 1 - r) line times after its
//! frame, raw.dng's bottom row first), two frames at 25 fps from capture.start_ms = 2 ms. Each
//! row's noise-free signal above black over the steady light's is the share of the light its own
//! window [start_k + delay_r, + T] holds, on-time / (D T), with the on-time summed from the
//! square wave on a 0.1 us grid here (not by camsim's closed form). The noise-free pass is
//! unquantized: the bound is float rounding plus the grid's 1e-4 ms.

use camsim_pipeline::{simulate, SimulateConfig, SimulateOptions};
use std::path::Path;

const ROWS: usize = 200;
const LINE_US: f64 = 100.0;
const EXPOSURE_MS: f64 = 1.0;

fn config(flicker: &str) -> SimulateConfig {
    let text = format!(
        r#"
seed = 2
{flicker}
[scene]
kind = "uniform"
mean_luminance_cd_m2 = 100.0
rows = 16
cols = 16
[optics]
preset = "diffraction-limited"
[optics.config]
shading = "none"
[sensor]
preset = "pixel4a"
rows = {ROWS}
cols = 8
[capture]
exposure_ms = {EXPOSURE_MS}
frames = 2
fps = 25.0
start_ms = 2.0
shutter = {{ rolling = {{ line_time_us = {LINE_US}, direction = "top-down" }} }}
"#
    );
    SimulateConfig::from_toml_str(&text, Path::new("")).unwrap()
}

fn on_time_numeric_s(t0: f64, t1: f64) -> f64 {
    let dt = 1e-7;
    let n = ((t1 - t0) / dt).round() as usize;
    (0..n)
        .filter(|i| {
            let u = (t0 + (*i as f64 + 0.5) * dt) * 90.0 - 0.25;
            u - u.floor() < 0.1
        })
        .count() as f64
        * dt
}

#[test]
fn each_rows_window_captures_its_share_of_a_flickering_led() {
    let opts = SimulateOptions {
        noise_free: true,
        ..Default::default()
    };
    let lit = simulate(
        &config("[flicker]\nfrequency_hz = 90.0\nduty = 0.1\nphase = 0.25"),
        &opts,
        &|_, _, _| {},
    )
    .unwrap();
    let steady = simulate(&config(""), &opts, &|_, _, _| {}).unwrap();
    let black = lit.frames[0].black_level_dn;
    let (nl, ns) = (
        lit.noise_free_dn.as_ref().unwrap(),
        steady.noise_free_dn.as_ref().unwrap(),
    );
    let t = EXPOSURE_MS * 1e-3;
    let mut dark_rows = 0;
    for (k, start_s) in [(0, 2e-3), (1, 2e-3 + 1.0 / 25.0)] {
        for r in 0..ROWS {
            let i = r * 8 + 1;
            let got = (nl[k][i] as f64 - black) / (ns[k][i] as f64 - black);
            let t0 = start_s + (ROWS - 1 - r) as f64 * LINE_US * 1e-6;
            let want = on_time_numeric_s(t0, t0 + t) / (0.1 * t);
            assert!(
                (got - want).abs() < 1e-3 * want.max(1.0),
                "frame {k} row {r}: {got:.4} of the steady signal, the window's share {want:.4}"
            );
            dark_rows += (want == 0.0) as usize;
        }
    }
    // The rows span 20 ms, 1.8 periods: most windows of 1 ms miss the 1.1 ms on-phase, some
    // catch it whole.
    assert!(dark_rows > ROWS, "{dark_rows} dark rows of {}", 2 * ROWS);
    // The raw frames themselves show the bands.
    let raw = &lit.frames[1];
    let row_mean = |r: usize| {
        raw.dn[r * 8..(r + 1) * 8]
            .iter()
            .map(|v| *v as f64)
            .sum::<f64>()
            / 8.0
    };
    let (lo, hi) = (0..ROWS)
        .map(row_mean)
        .fold((f64::MAX, 0.0f64), |(a, b), m| (a.min(m), b.max(m)));
    assert!(
        hi - black > 5.0 * (lo - black).max(1.0),
        "raw rows from {lo} to {hi} DN"
    );
}

#[test]
fn bad_flicker_keys_are_refused_naming_the_key() {
    for (text, key) in [
        (
            "[flicker]\nfrequency_hz = 0.0\nduty = 0.1",
            "flicker.frequency_hz",
        ),
        ("[flicker]\nfrequency_hz = 90.0\nduty = 1.5", "flicker.duty"),
        (
            "[flicker]\nfrequency_hz = 90.0\nduty = 0.1\nphase = -0.2",
            "flicker.phase",
        ),
        (
            "[flicker]\nfrequency_hz = 100.0\nwaveform = \"sine\"\ndepth = 1.2",
            "flicker.depth",
        ),
        (
            "[flicker]\nfrequency_hz = 100.0\nwaveform = \"sine\"\nduty = 0.5",
            "flicker.duty",
        ),
    ] {
        let e = simulate(&config(text), &SimulateOptions::default(), &|_, _, _| {})
            .unwrap_err()
            .to_string();
        assert!(e.contains(key), "{text}: {e}");
    }
}
