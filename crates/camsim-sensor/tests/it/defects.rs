//! `[defects]` (issue 42 item 3) against closed forms: column and row FPN of the configured sigma
//! (offset in DN = mV x dn_per_v / analog gain; gain as a fraction of the signal), faulty pixel
//! counts within binomial bounds, each kind's value (hot: its dark current's electrons x K above
//! black; dead: black; stuck: its value), and one map per seed: a window's map is the full
//! sensor's there.
//!
//! Temporal noise is off and the analog values are read, so the only spread is the pattern: the
//! standard deviation of n column values has relative standard error 1 / sqrt(2 (n - 1)), 1.6 %
//! for 2048 columns; the bound is 8 %.

use crate::common;
use camsim_core::WavelengthGrid;
use camsim_sensor::defects::{DefectKind, DefectsConfig};
use camsim_sensor::{Capture, NoiseSwitches, Sensor};
use common::{config, uniform_image};

fn sensor(rows: usize, cols: usize, d: DefectsConfig) -> Sensor {
    config("pixel4a-raw10", |c| {
        c.rows = rows;
        c.cols = cols;
        c.noise = NoiseSwitches::none();
        c.noise.quantization = false;
        c.noise.dark = true;
        c.dark_voltage_mv_per_s = 0.0;
        c.black_level_dn = 64.0;
        c.defects = Some(d);
    })
}

fn analog(s: &Sensor, level: f64, t_s: f64) -> Vec<f32> {
    let grid = WavelengthGrid::default();
    let img = uniform_image(
        s.rows(),
        s.cols(),
        grid,
        s.pixel_pitch_m(),
        &vec![level; grid.len()],
    );
    s.compute(&img, &Capture::seconds(t_s))
        .unwrap()
        .analog_dn
        .unwrap()
        .remove(0)
}

fn sd(v: &[f64]) -> f64 {
    let m = v.iter().sum::<f64>() / v.len() as f64;
    (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (v.len() - 1) as f64).sqrt()
}

#[test]
fn column_and_row_fpn_have_the_configured_spread() {
    let (rows, cols) = (8, 2048);
    let s = sensor(
        rows,
        cols,
        DefectsConfig {
            column_offset_mv: 0.5,
            column_gain_percent: 1.0,
            ..Default::default()
        },
    );
    let black = s.black_level_dn();
    let dn_per_mv = 1e-3 * s.dn_per_v() / s.analog_gain();
    // Dark: each column's offset (every row of a column the same).
    let dark = analog(&s, 0.0, 1e-3);
    let col_off: Vec<f64> = (0..cols).map(|c| dark[c] as f64 - black).collect();
    for r in 1..rows {
        assert!(
            (dark[r * cols + 7] - dark[7]).abs() < 1e-3,
            "a column's offset is the same in every row"
        );
    }
    let got = sd(&col_off) / dn_per_mv;
    assert!(
        (got / 0.5 - 1.0).abs() < 0.08,
        "column offset sigma {got:.4} mV, configured 0.5"
    );
    // Bright: each column's gain (offset removed, one colour's columns: green on even rows of
    // RGGB are odd columns).
    let bright = analog(&s, 2e-4, 5e-3);
    let steady = sensor(rows, cols, DefectsConfig::default());
    let flat = analog(&steady, 2e-4, 5e-3);
    let ratio: Vec<f64> = (0..cols)
        .map(|c| (bright[c] as f64 - black - col_off[c]) / (flat[c] as f64 - black))
        .collect();
    let g = sd(&ratio);
    assert!(
        (g / 0.01 - 1.0).abs() < 0.08,
        "column gain sigma {g:.5}, configured 0.01"
    );

    // Rows alike.
    let s = sensor(
        2048,
        4,
        DefectsConfig {
            row_offset_mv: 0.3,
            ..Default::default()
        },
    );
    let dark = analog(&s, 0.0, 1e-3);
    let row_off: Vec<f64> = (0..2048).map(|r| dark[r * 4] as f64 - black).collect();
    let got = sd(&row_off) / dn_per_mv;
    assert!(
        (got / 0.3 - 1.0).abs() < 0.08,
        "row offset sigma {got:.4} mV, configured 0.3"
    );
}

#[test]
fn faulty_pixels_come_in_binomial_numbers_and_read_what_their_kind_says() {
    let (rows, cols) = (256, 256);
    let d = DefectsConfig {
        hot_fraction: 0.004,
        hot_dark_current_e_per_s: 50_000.0,
        dead_fraction: 0.002,
        stuck_fraction: 0.001,
        stuck_dn: Some(700.0),
        ..Default::default()
    };
    let s = sensor(rows, cols, d.clone());
    let n = (rows * cols) as f64;
    let list = s.defect_list();
    for (kind, p) in [
        (DefectKind::Hot, 0.004),
        (DefectKind::Dead, 0.002),
        (DefectKind::Stuck, 0.001),
    ] {
        let k = list.iter().filter(|f| f.kind == kind).count() as f64;
        let (mean, sigma) = (n * p, (n * p * (1.0 - p)).sqrt());
        assert!(
            (k - mean).abs() < 5.0 * sigma,
            "{kind:?}: {k} pixels, expect {mean:.0} +- {sigma:.1}"
        );
    }
    let black = s.black_level_dn();
    let t = 10e-3;
    let level = 1e-4;
    let v = analog(&s, level, t);
    let flat = analog(&sensor(rows, cols, DefectsConfig::default()), level, t);
    let k = s.k_dn_per_e();
    for f in list {
        let i = f.row * cols + f.col;
        let (got, plain) = (v[i] as f64, flat[i] as f64);
        match f.kind {
            DefectKind::Hot => {
                let want = plain + 50_000.0 * t * k;
                assert!(
                    (got - want).abs() < 1e-2 * want,
                    "hot {f:?}: {got} DN, expect {want}"
                );
            }
            DefectKind::Dead => assert!((got - black).abs() < 1e-3, "dead {f:?}: {got} DN"),
            DefectKind::Stuck => assert_eq!(got, 700.0, "stuck {f:?}"),
            DefectKind::Rtn => unreachable!("no RTN configured"),
        }
    }
    // Every other pixel is the defect-free sensor's.
    let faulty: std::collections::HashSet<usize> =
        list.iter().map(|f| f.row * cols + f.col).collect();
    assert!((0..rows * cols)
        .filter(|i| !faulty.contains(i))
        .all(|i| v[i] == flat[i]));
    // One map per seed: a window's map is the full sensor's there; another seed another map.
    let w = s.window(128, 100).unwrap();
    let inside: Vec<_> = list
        .iter()
        .filter(|f| f.row < 128 && f.col < 100)
        .copied()
        .collect();
    assert_eq!(w.defect_list(), inside.as_slice());
    let other = config("pixel4a-raw10", |c| {
        c.rows = rows;
        c.cols = cols;
        c.fixed_pattern_seed += 1;
        c.defects = Some(d);
    });
    assert_ne!(other.defect_list(), list);
}

/// Random telegraph noise: each RTN pixel reads one of two levels A x K apart, the high one in
/// a binomial share p of the frames; its variance over frames is (A K)^2 p (1 - p) (a two-state
/// process sampled once per frame); the other pixels do not change from frame to frame.
#[test]
fn rtn_pixels_step_between_two_levels_in_the_configured_share_of_frames() {
    let (rows, cols, frames) = (64, 64, 200);
    let (amp_e, p) = (25.0, 0.3);
    let s = sensor(
        rows,
        cols,
        DefectsConfig {
            rtn_fraction: 0.01,
            rtn_amplitude_e: amp_e,
            rtn_high_probability: p,
            ..Default::default()
        },
    );
    let grid = WavelengthGrid::default();
    let img = uniform_image(rows, cols, grid, s.pixel_pitch_m(), &vec![1e-4; grid.len()]);
    let out = s
        .compute(&img, &Capture::seconds(5e-3).with_frames(frames))
        .unwrap()
        .analog_dn
        .unwrap();
    let plain = analog(&sensor(rows, cols, DefectsConfig::default()), 1e-4, 5e-3);
    let list = s.defect_list();
    assert!(list.len() > 10 && list.iter().all(|f| f.kind == DefectKind::Rtn));
    let step_dn = amp_e * s.k_dn_per_e();
    let mut high_total = 0usize;
    for f in list {
        let i = f.row * cols + f.col;
        let low = plain[i] as f64;
        let mut high = 0;
        for fr in &out {
            let d = fr[i] as f64 - low;
            if (d - step_dn).abs() < 1e-3 * step_dn {
                high += 1;
            } else {
                assert!(
                    d.abs() < 1e-3,
                    "{f:?}: {d} DN off both levels (step {step_dn})"
                );
            }
        }
        high_total += high;
    }
    let n = (list.len() * frames) as f64;
    let sigma = (n * p * (1.0 - p)).sqrt();
    assert!(
        (high_total as f64 - n * p).abs() < 5.0 * sigma,
        "{high_total} high states of {n}, expect {:.0} +- {sigma:.1}",
        n * p
    );
    let rtn: std::collections::HashSet<usize> = list.iter().map(|f| f.row * cols + f.col).collect();
    for fr in &out {
        assert!((0..rows * cols)
            .filter(|i| !rtn.contains(i))
            .all(|i| fr[i] == plain[i]));
    }
}

#[test]
fn bad_defect_keys_are_refused_naming_them() {
    for (d, key) in [
        (
            DefectsConfig {
                hot_fraction: 1.5,
                ..Default::default()
            },
            "defects.hot_fraction",
        ),
        (
            DefectsConfig {
                column_offset_mv: -1.0,
                ..Default::default()
            },
            "defects.column_offset_mv",
        ),
        (
            DefectsConfig {
                stuck_dn: Some(f64::NAN),
                ..Default::default()
            },
            "defects.stuck_dn",
        ),
    ] {
        let mut c = Sensor::preset("pixel4a-raw10").unwrap().config().clone();
        c.defects = Some(d);
        let e = Sensor::from_config(c).unwrap_err().to_string();
        assert!(e.contains(key), "{e}");
    }
}
