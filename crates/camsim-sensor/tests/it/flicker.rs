//! LED flicker (issue 41 item 5): a 90 Hz PWM light at 10 % duty, captured by a rolling shutter
//! at exposures of 1, 5.5 and 11.1 ms. Each row integrates the light over its own window, so its
//! signal above black is the steady light's times the captured fraction
//! g(t0) = (on-time in [t0, t0 + T]) / (D T) (the light's radiance is its time mean). The test
//! computes the on-time independently, by summing the square wave on a 0.1 us grid, and checks
//! the closed-form extremes:
//! - T = 1 ms is shorter than the on-phase (1.11 ms): rows wholly inside it capture 1/D = 10x
//!   the steady signal, and a fraction (P - D P - T) / P = 0.81 of the phases sees no light;
//! - T = 5.5 ms: at most D P / (D T) = 2.02x, and (P - D P - T) / P = 0.405 of the phases dark;
//! - T = 11.1 ms, about one period (11.11 ms): rows between (D P - (P - T)) / (D T) = 0.991
//!   (the sliver the window misses falls in the on-phase) and P / T = 1.001 (it falls off).
//!
//! Noise is off (and quantization: the analog values), so the bounds are float rounding.

use crate::common;
use camsim_core::WavelengthGrid;
use camsim_sensor::{Capture, Flicker, LightTiming, NoiseSwitches, Waveform};
use common::{config, uniform_image};

const ROWS: usize = 400;
const COLS: usize = 4;
/// Line time: the 400 rows start over exactly two periods of the 90 Hz light (55.6 us apart), so
/// the rows sample the light's phase uniformly.
const LINE_S: f64 = 2.0 / 90.0 / ROWS as f64;

fn led() -> Flicker {
    Flicker {
        frequency_hz: 90.0,
        waveform: Waveform::Square,
        duty: 0.1,
        depth: 0.0,
        phase: 0.3,
    }
}

/// A mains lamp on 45 Hz mains: a 90 Hz sine (so the 400 rows span two periods as for the LED),
/// modulation depth 0.3 (a magnetic-ballast fluorescent tube).
fn mains_lamp() -> Flicker {
    Flicker {
        frequency_hz: 90.0,
        waveform: Waveform::Sine,
        duty: 1.0,
        depth: 0.3,
        phase: 0.3,
    }
}

/// The sine's captured fraction in [t0, t1] by summing 1 + m cos 2 pi (f t - phase) on a 0.1 us
/// grid.
fn sine_gain_numeric(f: &Flicker, t0: f64, t1: f64) -> f64 {
    let dt = 1e-7;
    let n = ((t1 - t0) / dt).round() as usize;
    (0..n)
        .map(|i| {
            let t = t0 + (i as f64 + 0.5) * dt;
            1.0 + f.depth * (std::f64::consts::TAU * (t * f.frequency_hz - f.phase)).cos()
        })
        .sum::<f64>()
        / n as f64
}

/// On-time of the LED in [t0, t1] by summing the square wave on a 0.1 us grid, s.
fn on_time_numeric(f: &Flicker, t0: f64, t1: f64) -> f64 {
    let dt = 1e-7;
    let n = ((t1 - t0) / dt).round() as usize;
    (0..n)
        .filter(|i| {
            let t = t0 + (*i as f64 + 0.5) * dt;
            let u = t * f.frequency_hz - f.phase;
            u - u.floor() < f.duty
        })
        .count() as f64
        * dt
}

/// Per row, the signal above black with the LED over that of the steady light, exposure `t_s`,
/// frame `frame` of a burst at `fps` (rolling shutter, bottom-up: row r starts r line times
/// after the frame).
fn row_gains(flicker: Flicker, t_s: f64, frames: usize, fps: f64) -> Vec<Vec<f64>> {
    let grid = WavelengthGrid::default();
    let s = config("pixel4a-raw10", |c| {
        c.rows = ROWS;
        c.cols = COLS;
        c.noise = NoiseSwitches::none();
        c.noise.quantization = false;
    });
    let img = uniform_image(ROWS, COLS, grid, s.pixel_pitch_m(), &vec![1e-4; grid.len()]);
    let black = s.black_level_dn();
    let steady = s
        .compute(&img, &Capture::seconds(t_s))
        .unwrap()
        .analog_dn
        .unwrap()
        .remove(0);
    let light = LightTiming {
        flicker,
        start_s: 0.0,
        frame_interval_s: Some(1.0 / fps),
        row0_s: 0.0,
        per_row_s: LINE_S,
    };
    let lit = s
        .compute(
            &img,
            &Capture::seconds(t_s)
                .with_frames(frames)
                .with_light(Some(light)),
        )
        .unwrap()
        .analog_dn
        .unwrap();
    lit.iter()
        .map(|f| {
            (0..ROWS)
                .map(|r| {
                    let i = r * COLS + 1;
                    (f[i] as f64 - black) / (steady[i] as f64 - black)
                })
                .collect()
        })
        .collect()
}

#[test]
fn each_row_captures_its_windows_share_of_a_90_hz_led() {
    let f = led();
    let period = 1.0 / 90.0;
    for (t_s, max_gain) in [
        (1e-3, 10.0),
        (5.5e-3, 0.1 * period / (0.1 * 5.5e-3)),
        (11.1e-3, period / 11.1e-3),
    ] {
        let gains = &row_gains(led(), t_s, 1, 30.0)[0];
        for (r, g) in gains.iter().enumerate() {
            let t0 = r as f64 * LINE_S;
            let want = on_time_numeric(&f, t0, t0 + t_s) / (f.duty * t_s);
            assert!(
                (g - want).abs() < 2e-3 * want.max(1.0),
                "T {t_s} s, row {r}: captured fraction {g:.4}, the square wave's {want:.4}"
            );
            assert!(
                *g <= max_gain * (1.0 + 1e-3),
                "row {r}: {g} above {max_gain}"
            );
        }
        // The share of phases whose window misses the on-phase: (P - D P - T) / P, where
        // positive (to a row of the 200 per period).
        let dark = gains.iter().filter(|g| **g < 1e-6).count() as f64 / ROWS as f64;
        let want = ((period - 0.1 * period - t_s) / period).max(0.0);
        assert!(
            (dark - want).abs() <= 1.0 / 200.0 + 1e-9,
            "T {t_s} s: {dark} of rows dark, the closed form {want:.4}"
        );
        if t_s > 11e-3 {
            // Within one period: between (D P - (P - T)) / (D T) (the missed sliver falls in the
            // on-phase) and P / T (it falls off).
            let (lo, hi) = ((0.1 * period - (period - t_s)) / (0.1 * t_s), period / t_s);
            let (min, max) = gains
                .iter()
                .fold((f64::MAX, f64::MIN), |(a, b), g| (a.min(*g), b.max(*g)));
            assert!(
                (min - lo).abs() < 1e-4 && (max - hi).abs() < 1e-4,
                "T 11.1 ms: rows in [{min}, {max}], the closed form [{lo}, {hi}]"
            );
        }
    }
}

#[test]
fn the_bands_move_from_frame_to_frame_of_a_burst() {
    // At 30 fps, the 90 Hz light is back in phase every frame (3 periods per frame): the same
    // bands; at 25 fps (3.6 periods) they move by 0.6 of a period.
    let same = row_gains(led(), 1e-3, 2, 30.0);
    for (a, b) in same[0].iter().zip(&same[1]) {
        assert!((a - b).abs() < 1e-3, "30 fps: frames differ ({a} vs {b})");
    }
    let moved = row_gains(led(), 1e-3, 2, 25.0);
    let differ = moved[0]
        .iter()
        .zip(&moved[1])
        .filter(|(a, b)| (*a - *b).abs() > 0.1)
        .count();
    assert!(differ > ROWS / 10, "25 fps: only {differ} rows changed");
    let f = led();
    for (r, g) in moved[1].iter().enumerate() {
        let t0 = 1.0 / 25.0 + r as f64 * LINE_S;
        let want = on_time_numeric(&f, t0, t0 + 1e-3) / (f.duty * 1e-3);
        assert!(
            (g - want).abs() < 2e-3 * want.max(1.0),
            "frame 2 row {r}: {g} vs {want}"
        );
    }
}

/// A mains lamp's sine flicker through the rolling shutter: each row captures the mean of
/// 1 + m cos over its window (summed numerically), so a short exposure shows bands between
/// 1 - m and 1 + m and a whole number of periods none; the band's peak-to-peak amplitude is the
/// closed form 2 m |sin(pi f T)| / (pi f T).
#[test]
fn each_row_captures_its_windows_mean_of_a_sine_flicker() {
    let f = mains_lamp();
    for t_s in [0.5e-3, 4e-3, 1.0 / 90.0] {
        let gains = &row_gains(f, t_s, 1, 30.0)[0];
        for (r, g) in gains.iter().enumerate() {
            let t0 = r as f64 * LINE_S;
            let want = sine_gain_numeric(&f, t0, t0 + t_s);
            assert!(
                (g - want).abs() < 2e-3,
                "T {t_s} s, row {r}: captured fraction {g:.4}, the sine's {want:.4}"
            );
        }
        let (min, max) = gains
            .iter()
            .fold((f64::MAX, f64::MIN), |(a, b), g| (a.min(*g), b.max(*g)));
        let x = std::f64::consts::PI * f.frequency_hz * t_s;
        let amplitude = 2.0 * f.depth * (x.sin() / x).abs();
        // The rows sample the phase every 1/200 period: the extremes within 1 - cos(pi / 200).
        assert!(
            ((max - min) - amplitude).abs() < 2e-3,
            "T {t_s} s: rows span {:.4}, the closed form {amplitude:.4}",
            max - min
        );
    }
    // The keys: depth is the sine's, duty the square wave's.
    assert!(f.validate("flicker").is_ok());
    assert!(Flicker { depth: 1.5, ..f }.validate("flicker").is_err());
    assert!(Flicker { duty: 0.5, ..f }.validate("flicker").is_err());
    assert!(Flicker {
        depth: 0.2,
        ..led()
    }
    .validate("flicker")
    .is_err());
}
