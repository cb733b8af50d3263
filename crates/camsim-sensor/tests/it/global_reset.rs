//! A global-reset sensor mode read out row by row ([`camsim_sensor::GlobalReset`]): every row
//! starts integrating at the reset, row r is read `extra(r)` later than the first row. Without
//! a mechanical shutter row r collects light for T + extra(r) (Hamamatsu's "global reset
//! trigger mode": the first line exposes for the set time, later lines for it plus their readout
//! delay): the noise-free signal above black grows linearly down the readout. With a mechanical
//! shutter the light is the same for every row and only the dark signal grows with the delay.

use crate::common;
use camsim_core::WavelengthGrid;
use camsim_sensor::{Capture, GlobalReset, NoiseSwitches};
use common::{config, uniform_image};

const ROWS: usize = 32;

/// The noise-free analog frame (DN, unquantized) of a uniform irradiance `level` (W/(m^2 nm)).
fn analog(level: f64, dark_mv_s: f64, t_s: f64, g: Option<GlobalReset>) -> (Vec<f32>, f64, f64) {
    let grid = WavelengthGrid::default();
    let s = config("pixel4a-raw10", |c| {
        c.rows = ROWS;
        c.cols = 16;
        c.dark_voltage_mv_per_s = dark_mv_s;
        c.noise = NoiseSwitches::none();
        c.noise.dark = true;
        c.noise.quantization = false;
    });
    let img = uniform_image(ROWS, 16, grid, s.pixel_pitch_m(), &vec![level; grid.len()]);
    let f = s
        .compute(&img, &Capture::seconds(t_s).with_global_reset(g))
        .unwrap();
    // DN per second of dark current: V/s over the analog gain, times DN/V.
    let dark_dn_s = dark_mv_s * 1e-3 / s.config().analog_gain * s.dn_per_v();
    (
        f.analog_dn.unwrap().remove(0),
        s.black_level_dn(),
        dark_dn_s,
    )
}

/// Pixel (r, c) of an analog frame, DN (compared only with the same pixel of another frame).
fn at(v: &[f32], r: usize, c: usize) -> f64 {
    v[r * 16 + c] as f64
}

#[test]
fn without_a_mechanical_shutter_rows_integrate_their_readout_delay() {
    let (t, lt) = (1e-3, 50e-6);
    // Top-down: the last stored row (the sensor's top row) is read first.
    let g = GlobalReset {
        row0_extra_s: lt * (ROWS - 1) as f64,
        per_row_extra_s: -lt,
        mechanical_shutter: false,
    };
    let (v, black, _) = analog(2e-4, 0.0, t, Some(g));
    let (plain, _, _) = analog(2e-4, 0.0, t, None);
    for r in 0..ROWS {
        for c in 0..2 {
            let want = (at(&plain, r, c) - black) * (t + g.extra_s(r)) / t;
            let got = at(&v, r, c) - black;
            assert!(
                (got / want - 1.0).abs() < 1e-4,
                "row {r} col {c}: {got} DN above black, want {want}"
            );
        }
    }
    // The first row read is the plain exposure.
    assert!((at(&v, ROWS - 1, 0) - at(&plain, ROWS - 1, 0)).abs() < 1e-3);
}

#[test]
fn with_a_mechanical_shutter_only_the_dark_signal_grows() {
    let (t, lt) = (1e-3, 50e-6);
    let g = GlobalReset {
        row0_extra_s: 0.0,
        per_row_extra_s: lt,
        mechanical_shutter: true,
    };
    // Light without dark current: every row as the global shutter.
    let (lit, _, _) = analog(2e-4, 0.0, t, Some(g));
    let (plain, _, _) = analog(2e-4, 0.0, t, None);
    assert_eq!(lit, plain);
    // Dark current without light: row r reads black + dark rate x (T + r line time).
    let (dark, black, dark_dn_s) = analog(0.0, 2000.0, t, Some(g));
    for r in 0..ROWS {
        let want = dark_dn_s * (t + r as f64 * lt);
        let got = at(&dark, r, 0) - black;
        assert!(
            (got / want - 1.0).abs() < 1e-4,
            "row {r}: dark {got} DN, want {want}"
        );
    }
}

/// Auto-exposure in global-reset mode meters the row that integrates longest (the row read
/// last: exposure + its readout delay). With a readout as long as the plain auto exposure T0,
/// metering the first row read (the exposure T0) gave the last row about 2 T0 of light, past
/// full scale; now the last row collects exactly what the plain auto exposure collects
/// (T + extra_max = T0) and no row clips.
#[test]
fn auto_exposure_meters_the_row_read_last() {
    use camsim_sensor::Exposure;
    let grid = WavelengthGrid::default();
    let s = config("pixel4a-raw10", |c| {
        c.rows = ROWS;
        c.cols = 16;
        c.noise = NoiseSwitches::none();
    });
    let img = uniform_image(ROWS, 16, grid, s.pixel_pitch_m(), &vec![2e-4; grid.len()]);
    let auto = Capture {
        exposure: Exposure::Auto {
            target_fraction: 0.9,
        },
        ..Capture::seconds(0.0)
    };
    let plain = s.compute(&img, &auto).unwrap();
    let t0 = plain.exposure_s;
    let lt = t0 / ROWS as f64;
    // Top-down: the last stored row is read first, stored row 0 last.
    let g = GlobalReset {
        row0_extra_s: lt * (ROWS - 1) as f64,
        per_row_extra_s: -lt,
        mechanical_shutter: false,
    };
    let f = s.compute(&img, &auto.with_global_reset(Some(g))).unwrap();
    let white = plain.raw[0].white_level_dn;
    let max = |raw: &camsim_core::RawImage| raw.dn.iter().copied().max().unwrap() as f64;
    assert!(max(&f.raw[0]) < white, "a row clips: {} DN", max(&f.raw[0]));
    let want = t0 - g.extra_s(0);
    assert!(
        (f.exposure_s / want - 1.0).abs() < 1e-9,
        "exposure {} s, want T0 - readout = {want}",
        f.exposure_s
    );
    // The row read last (stored row 0) sees the plain auto exposure's signal.
    let row0 = |raw: &camsim_core::RawImage| raw.dn[0] as f64;
    assert!(
        (row0(&f.raw[0]) - row0(&plain.raw[0])).abs() <= 1.0,
        "{} vs {}",
        row0(&f.raw[0]),
        row0(&plain.raw[0])
    );
}
