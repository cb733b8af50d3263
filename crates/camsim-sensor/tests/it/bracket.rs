//! Exposure bracketing and bursts ([`Sensor::compute_bracket`]): the mean signal above black
//! scales with the exposure time, every frame has its own temporal noise (correlation between
//! frames ~ 0, within its standard error 1/sqrt(n)), and a one-entry bracket is exactly a capture.

use crate::common;
use camsim_core::WavelengthGrid;
use camsim_sensor::{Capture, Sensor};
use common::{channel_pixels, config, uniform_image};

fn flat(grid: &WavelengthGrid) -> Vec<f64> {
    vec![1e-3; grid.len()]
}

fn green_mean(raw: &camsim_core::RawImage) -> f64 {
    let idx = channel_pixels(raw, 1);
    idx.iter().map(|i| raw.dn[*i] as f64).sum::<f64>() / idx.len() as f64
}

#[test]
fn frame_means_scale_with_exposure() {
    let grid = WavelengthGrid::default();
    let spec = flat(&grid);
    let s = config("pixel4a-raw10", |c| {
        c.rows = 64;
        c.cols = 64;
    });
    let img = uniform_image(64, 64, grid, s.pixel_pitch_m(), &spec);
    let per_s = s.mean_electrons_uniform(&spec, &grid, 1.0).unwrap();
    let t0 = 500.0 / per_s[1]; // 500 green e- in the shortest exposure; 2000 e- (~340 DN) in the longest
    let times = [t0, 2.0 * t0, 4.0 * t0];
    let f = s.compute_bracket(&img, &times, 1, 11).unwrap();
    assert_eq!(f.raw.len(), 3);
    assert_eq!(f.exposure_s, t0);
    let k = s.k_dn_per_e();
    for (raw, t) in f.raw.iter().zip(times) {
        assert_eq!(raw.exposure_s, t);
        let m = green_mean(raw) - 64.0;
        let want = k * per_s[1] * t;
        // Standard error of the mean over 2048 green pixels (temporal + fixed-pattern noise).
        let se = s.predicted_noise_dn(want, t).total / 2048f64.sqrt();
        assert!(
            (m - want).abs() < 4.0 * se,
            "t = {t} s: {m} DN above black, want {want} +- {se}"
        );
        eprintln!(
            "exposure {:.3} ms: {m:.2} DN above black (closed form {want:.2} +- {se:.2})",
            t * 1e3
        );
    }
}

#[test]
fn burst_frames_have_independent_noise() {
    let grid = WavelengthGrid::default();
    let spec = flat(&grid);
    // Fixed pattern off: what remains from pixel to pixel is temporal noise (shot + read).
    let s = config("pixel4a-raw10", |c| {
        c.rows = 128;
        c.cols = 128;
        c.noise.dsnu = false;
        c.noise.prnu = false;
    });
    let img = uniform_image(128, 128, grid, s.pixel_pitch_m(), &spec);
    let per_s = s.mean_electrons_uniform(&spec, &grid, 1.0).unwrap();
    let t = 1000.0 / per_s[1];
    let f = s.compute_bracket(&img, &[t, t], 2, 5).unwrap();
    assert_eq!(f.raw.len(), 4);
    let idx = channel_pixels(&f.raw[0], 1);
    let n = idx.len() as f64;
    let resid = |k: usize| -> Vec<f64> {
        let m = green_mean(&f.raw[k]);
        idx.iter().map(|i| f.raw[k].dn[*i] as f64 - m).collect()
    };
    let r: Vec<Vec<f64>> = (0..4).map(resid).collect();
    for a in 0..4 {
        for b in a + 1..4 {
            let dot: f64 = r[a].iter().zip(&r[b]).map(|(x, y)| x * y).sum();
            let na: f64 = r[a].iter().map(|x| x * x).sum::<f64>().sqrt();
            let nb: f64 = r[b].iter().map(|x| x * x).sum::<f64>().sqrt();
            let rho = dot / (na * nb);
            assert!(
                rho.abs() < 4.0 / n.sqrt(),
                "frames {a} and {b}: correlation {rho}"
            );
            eprintln!(
                "frames {a},{b}: correlation {rho:+.4} (4 sigma {:.4})",
                4.0 / n.sqrt()
            );
        }
        assert_ne!(f.raw[a].dn, f.raw[(a + 1) % 4].dn);
    }
    // With the fixed pattern on, the shared DSNU/PRNU correlates frames by exactly
    // var_fpn / var_total (closed form), which the same estimator finds.
    let s = config("pixel4a-raw10", |c| {
        c.rows = 128;
        c.cols = 128;
        c.dsnu_mv = 5.0; // as large as the read noise, so the correlation is far from 0
    });
    let f = s.compute_bracket(&img, &[t], 2, 5).unwrap();
    let (x, y) = (&f.raw[0], &f.raw[1]);
    let (mx, my) = (green_mean(x), green_mean(y));
    let dot: f64 = idx
        .iter()
        .map(|i| (x.dn[*i] as f64 - mx) * (y.dn[*i] as f64 - my))
        .sum();
    let nx: f64 = idx
        .iter()
        .map(|i| (x.dn[*i] as f64 - mx).powi(2))
        .sum::<f64>()
        .sqrt();
    let ny: f64 = idx
        .iter()
        .map(|i| (y.dn[*i] as f64 - my).powi(2))
        .sum::<f64>()
        .sqrt();
    let rho = dot / (nx * ny);
    let p = s.predicted_noise_dn(mx - 64.0, t);
    let want = (p.dsnu.powi(2) + p.prnu.powi(2)) / p.total.powi(2);
    assert!(
        (rho - want).abs() < 4.0 / n.sqrt(),
        "fixed-pattern correlation {rho}, closed form {want}"
    );
    eprintln!("with DSNU 5 mV: correlation {rho:.4}, closed form {want:.4}");
}

#[test]
fn a_one_entry_bracket_is_a_capture() {
    let grid = WavelengthGrid::default();
    let s = config("pixel4a", |c| {
        c.rows = 32;
        c.cols = 32;
    });
    let img = uniform_image(32, 32, grid, s.pixel_pitch_m(), &flat(&grid));
    let a = s.compute_bracket(&img, &[0.004], 3, 9).unwrap();
    let b = s
        .compute(&img, &Capture::seconds(0.004).with_frames(3).with_seed(9))
        .unwrap();
    assert_eq!(a, b);
}

#[test]
fn bad_brackets_are_refused() {
    let s: Sensor = config("ideal", |c| {
        c.rows = 4;
        c.cols = 4;
    });
    let grid = WavelengthGrid::default();
    let img = uniform_image(4, 4, grid, s.pixel_pitch_m(), &flat(&grid));
    for (times, frames, want) in [
        (vec![], 1, "empty"),
        (vec![0.01, -1.0], 1, "entry 1"),
        (vec![0.01, f64::NAN], 1, "entry 1"),
        (vec![0.01], 0, "frames"),
    ] {
        let e = s
            .compute_bracket(&img, &times, frames, 0)
            .unwrap_err()
            .to_string();
        assert!(e.contains(want), "{e} lacks {want}");
    }
}
