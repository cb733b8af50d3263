//! Noise statistics from frame stacks against the EMVA 1288 / ISETCam noise model.
//!
//! Sampling errors used for the tolerances (normal statistics): the unbiased variance of n samples
//! has relative standard error sqrt(2 / (n - 1)); averaging P independent per-pixel variances divides
//! it by sqrt(P). A spatial variance over P pixels has relative standard error sqrt(2 / (P - 1)).
//! A mean of N samples of spread sigma has standard error sigma / sqrt(N). Tests allow 4 standard
//! errors (a false failure once in ~16 000 runs per check; the seeds are fixed anyway).

use crate::common;
use camsim_core::WavelengthGrid;
use camsim_sensor::{Sensor, SensorConfig};
use common::{channel_pixels, config, mean_var, stack_stats};

const ROWS: usize = 64;
const COLS: usize = 64;

/// The imx363 electronics (Table 1) on a 64 x 64 window, with a 40 mV analog offset so that dark
/// frames are not clipped at 0 (the noise floor is ~45 DN at 5 mV read noise).
fn imx363_window(f: impl FnOnce(&mut SensorConfig)) -> Sensor {
    config("imx363", |c| {
        c.rows = ROWS;
        c.cols = COLS;
        c.analog_offset_mv = 40.0;
        f(c);
    })
}

fn flat_spectrum(grid: &WavelengthGrid) -> Vec<f64> {
    vec![1e-3; grid.len()]
}

/// Temporal noise over a stack of 16 frames at 4 exposures, per channel:
/// var_DN = K^2 mu_e + sigma_read_DN^2 + 1/12 (EMVA 1288 rel. 4.0 eq. 9) and mean = black + K mu_e.
/// Levels span the exact-Poisson range (mu < 100 e-) and the normal range. Run with Table 1's read
/// noise (5 mV) and with a small one (0.3 mV), where shot noise dominates.
#[test]
fn temporal_variance_follows_the_photon_transfer_model() {
    let grid = WavelengthGrid::default();
    let spectrum = flat_spectrum(&grid);
    let n = 16usize;
    for read_mv in [5.0, 0.3] {
        let s = imx363_window(|c| c.read_noise_mv = read_mv);
        let k = s.k_dn_per_e();
        let per_s = s.mean_electrons_uniform(&spectrum, &grid, 1.0).unwrap();
        let g_rate = per_s[1];
        for (level, target_e) in [30.0, 400.0, 2000.0, 4500.0].into_iter().enumerate() {
            let t = target_e / g_rate;
            let levels = s
                .emva_series(&grid, &spectrum, &[t], n, ROWS, COLS, 1000 + level as u64)
                .unwrap();
            let (mean, var) = stack_stats(&levels[0].bright);
            let black = s.black_level_dn();
            for c in 0..3 {
                let idx = channel_pixels(&levels[0].bright[0], c);
                let mu_e = per_s[c] * t;
                let read_dn = s.read_noise_v() * s.dn_per_v() / s.analog_gain();
                let want_var = k * k * mu_e + read_dn * read_dn + 1.0 / 12.0;
                let got_var = idx.iter().map(|i| var[*i]).sum::<f64>() / idx.len() as f64;
                let se_var = want_var * (2.0 / ((n - 1) as f64 * idx.len() as f64)).sqrt();
                eprintln!(
                    "read {read_mv} mV, {target_e} e- (green), channel {c}: var {got_var:.2} DN^2 vs model {want_var:.2} ({:+.2} SE)",
                    (got_var - want_var) / se_var
                );
                assert!(
                    (got_var - want_var).abs() < 4.0 * se_var,
                    "channel {c}: {got_var} vs {want_var} (SE {se_var})"
                );
                // Mean: black + K mu_e; spread of the mean over pixels and frames includes PRNU and DSNU.
                let got_mean = idx.iter().map(|i| mean[*i]).sum::<f64>() / idx.len() as f64;
                let want_mean = black + k * mu_e;
                let spatial = s.predicted_noise_dn(k * mu_e, t);
                let se_mean = ((spatial.prnu.powi(2) + spatial.dsnu.powi(2)) / idx.len() as f64
                    + want_var / (idx.len() * n) as f64)
                    .sqrt();
                assert!(
                    (got_mean - want_mean).abs() < 4.0 * se_mean + 1e-9,
                    "mean {got_mean} vs {want_mean} (SE {se_mean})"
                );
            }
        }
    }
}

/// Dark frames (no light), 64 frames of 128 x 128 with dark current 20 mV/s for 0.1 s: the mean is
/// the offset plus the dark signal, the temporal spread is read noise plus dark shot noise plus
/// quantization, and the spread of the per-pixel means is DSNU plus the temporal noise / n.
#[test]
fn dark_frames_match_offset_dsnu_and_read_noise() {
    let (rows, cols, n) = (128, 128, 64);
    let s = config("imx363", |c| {
        c.rows = rows;
        c.cols = cols;
        c.analog_offset_mv = 40.0;
        c.dark_voltage_mv_per_s = 20.0;
    });
    let grid = WavelengthGrid::default();
    let t = 0.1;
    let levels = s
        .emva_series(&grid, &vec![0.0; grid.len()], &[t], n, rows, cols, 7)
        .unwrap();
    let dark = &levels[0].dark;
    let (mean, var) = stack_stats(dark);
    let all: Vec<usize> = (0..rows * cols).collect();
    let k = s.k_dn_per_e();
    let dark_e = s.dark_electrons(t);
    assert!((dark_e - 0.002 / 7.65e-5).abs() < 1e-9);
    let dpv = s.dn_per_v();
    let read_dn = s.read_noise_v() * dpv;
    let want_temporal = read_dn * read_dn + k * k * dark_e + 1.0 / 12.0;
    let got_temporal = var.iter().sum::<f64>() / var.len() as f64;
    let se_t = want_temporal * (2.0 / ((n - 1) * var.len()) as f64).sqrt();
    eprintln!("dark temporal variance {got_temporal:.2} vs {want_temporal:.2} DN^2 (SE {se_t:.2})");
    assert!((got_temporal - want_temporal).abs() < 4.0 * se_t);
    let (m, spatial_var) = mean_var(&mean, &all);
    let dsnu_dn = s.dsnu_v() * dpv;
    let want_mean = s.black_level_dn() + k * dark_e;
    let se_m = ((dsnu_dn * dsnu_dn + want_temporal / n as f64) / all.len() as f64).sqrt();
    eprintln!("dark mean {m:.3} vs {want_mean:.3} DN (SE {se_m:.3})");
    assert!((m - want_mean).abs() < 4.0 * se_m);
    // DSNU recovered: spatial variance of the temporal means minus the measured temporal part / n.
    let dsnu_est = (spatial_var - got_temporal / n as f64).sqrt();
    let se_spatial = spatial_var * (2.0 / (all.len() - 1) as f64).sqrt();
    let se_dsnu = se_spatial / (2.0 * dsnu_dn); // d sqrt(x) = dx / (2 sqrt x)
    eprintln!("DSNU {dsnu_est:.3} vs {dsnu_dn:.3} DN (SE {se_dsnu:.3})");
    assert!((dsnu_est - dsnu_dn).abs() < 4.0 * se_dsnu);
}

/// PRNU recovered from a bright stack (64 frames, 128 x 128, green channel at ~4000 e-):
/// spatial variance of the per-pixel means = (PRNU x mean)^2 + DSNU^2 + temporal / n.
#[test]
fn prnu_is_recovered_from_a_frame_stack() {
    let (rows, cols, n) = (128, 128, 64);
    let s = config("imx363", |c| {
        c.rows = rows;
        c.cols = cols;
        c.analog_offset_mv = 40.0;
    });
    let grid = WavelengthGrid::default();
    let spectrum = flat_spectrum(&grid);
    let per_s = s.mean_electrons_uniform(&spectrum, &grid, 1.0).unwrap();
    let t = 4000.0 / per_s[1];
    let levels = s
        .emva_series(&grid, &spectrum, &[t], n, rows, cols, 11)
        .unwrap();
    let (mean, var) = stack_stats(&levels[0].bright);
    let idx = channel_pixels(&levels[0].bright[0], 1);
    let (m, spatial_var) = mean_var(&mean, &idx);
    let temporal = idx.iter().map(|i| var[*i]).sum::<f64>() / idx.len() as f64;
    let dsnu_dn = s.dsnu_v() * s.dn_per_v();
    let signal = m - s.black_level_dn();
    let prnu_var = spatial_var - dsnu_dn * dsnu_dn - temporal / n as f64;
    let prnu_est = prnu_var.sqrt() / signal;
    let se_spatial = spatial_var * (2.0 / (idx.len() - 1) as f64).sqrt();
    let se_prnu = se_spatial / (2.0 * prnu_var.sqrt()) / signal;
    eprintln!(
        "PRNU {:.4} % vs 0.7 % (SE {:.4} %)",
        100.0 * prnu_est,
        100.0 * se_prnu
    );
    assert!((prnu_est - s.prnu_fraction()).abs() < 4.0 * se_prnu);
}

/// The noise model's total (temporal + fixed pattern) equals the spread over the pixels of one
/// channel in a single frame of a uniform field (128 x 128, green, several levels).
#[test]
fn predicted_total_noise_matches_a_single_frame() {
    let s = config("imx363", |c| {
        c.rows = 128;
        c.cols = 128;
        c.analog_offset_mv = 40.0;
        c.dark_voltage_mv_per_s = 50.0;
    });
    let grid = WavelengthGrid::default();
    let spectrum = flat_spectrum(&grid);
    let per_s = s.mean_electrons_uniform(&spectrum, &grid, 1.0).unwrap();
    for (j, target_e) in [50.0, 1000.0, 5000.0].into_iter().enumerate() {
        let t = target_e / per_s[1];
        let levels = s
            .emva_series(&grid, &spectrum, &[t], 2, 128, 128, 21 + j as u64)
            .unwrap();
        let frame = &levels[0].bright[0];
        let values: Vec<f64> = frame.dn.iter().map(|v| *v as f64).collect();
        let idx = channel_pixels(frame, 1);
        let (m, v) = mean_var(&values, &idx);
        let p = s.predicted_noise_dn(m - s.black_level_dn(), t);
        let want = p.total * p.total;
        let se = want * (2.0 / (idx.len() - 1) as f64).sqrt();
        eprintln!("{target_e} e-: single-frame variance {v:.1} vs predicted {want:.1} DN^2 (SE {se:.1}); {p:?}");
        assert!((v - want).abs() < 4.0 * se);
        // The dark term: K^2 x dark electrons.
        let dark_e = s.dark_electrons(t);
        assert!((p.dark - s.k_dn_per_e() * dark_e.sqrt()).abs() < 1e-9);
    }
}

/// Photon transfer with the ideal sensor: mean electrons equal mean photons (QE 1, fill factor 1),
/// and with shot noise on the variance equals the mean in electrons (Poisson).
#[test]
fn ideal_sensor_emva_series_is_poisson() {
    let s = config("ideal", |c| {
        c.rows = 64;
        c.cols = 64;
        c.noise.shot = true;
        c.conversion_gain_uv_per_e = 20.0; // K = 20e-6 x 65536 = 1.31 DN/e-
    });
    let grid = WavelengthGrid::default();
    let spectrum = vec![1e-6; grid.len()];
    let photons_per_s = s.photons_per_pixel(&spectrum, &grid, 1.0).unwrap();
    let exposures: Vec<f64> = [20.0, 80.0, 300.0, 3000.0]
        .iter()
        .map(|p| p / photons_per_s)
        .collect();
    let n = 8;
    let series = s
        .emva_series(&grid, &spectrum, &exposures, n, 64, 64, 5)
        .unwrap();
    let k = s.k_dn_per_e();
    for level in &series {
        let (mean, var) = stack_stats(&level.bright);
        let (dmean, _) = stack_stats(&level.dark);
        let mu_e = (mean.iter().sum::<f64>() - dmean.iter().sum::<f64>()) / mean.len() as f64 / k;
        let var_e = (var.iter().sum::<f64>() / var.len() as f64 - 1.0 / 12.0) / (k * k);
        let mu_p = level.photons_per_pixel;
        let se_mu = (mu_p / (mean.len() * n) as f64).sqrt();
        let se_var = mu_p * (2.0 / ((n - 1) * var.len()) as f64).sqrt();
        eprintln!("{mu_p:.1} photons: mean {mu_e:.2} e-, variance {var_e:.2} e^2");
        assert!((mu_e - mu_p).abs() < 4.0 * se_mu + 0.5 / k / (mean.len() as f64).sqrt());
        assert!((var_e - mu_p).abs() < 4.0 * se_var);
    }
}
