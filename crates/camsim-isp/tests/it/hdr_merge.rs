//! Issue 41 item 6: three brackets 4 stops apart (64, 4 and 0.25 ms) of a 20-stop irradiance ramp
//! merge to the scene's signal within noise over the whole range.
//!
//! The truth is the same sensor's noise-free capture (no shot or read noise, no quantization; the
//! same PRNU pattern) at the shortest exposure, scaled to the longest: the ramp tops out just
//! below the short frame's saturation, so it is linear everywhere. Each merged pixel's error is
//! divided by the merge's own predicted sigma ([`Merged::sigma_e`]); per half-stop bin of the
//! ramp the mean of these z-scores must be within 4 / sqrt(n) of 0 plus the 10-bit ADC's
//! rounding bias (an ADC step is ~6 e- at 64 ms: where read noise does not dither it, rounding
//! biases a mean by up to a few tenths of a step) and their spread within 25 % of 1.
//! DSNU and dark current are off: a fixed offset is not an exposure-proportional signal, and a
//! bracket merge needs a dark frame subtracted first (not modelled here).

use camsim_core::{Quantity, SpectralImage, WavelengthGrid};
use camsim_isp::hdr_merge::{merge_frames, MergeNoise};
use camsim_sensor::{Capture, NoiseSwitches, Sensor};

const ROWS: usize = 32;
const COLS: usize = 400;
const STOPS: f64 = 20.0;

fn sensor(noise: NoiseSwitches) -> Sensor {
    let mut c = Sensor::preset("pixel4a-raw10").unwrap().config().clone();
    c.rows = ROWS;
    c.cols = COLS;
    c.dsnu_mv = 0.0;
    c.dark_voltage_mv_per_s = 0.0;
    c.noise = noise;
    Sensor::from_config(c).unwrap()
}

fn ramp(s: &Sensor, top: f64) -> SpectralImage {
    let grid = WavelengthGrid::default();
    let mut img =
        SpectralImage::zeros(ROWS, COLS, grid, s.pixel_pitch_m(), Quantity::Irradiance).unwrap();
    for plane in img.bands_mut() {
        for (i, v) in plane.iter_mut().enumerate() {
            let c = i % COLS;
            *v = (top * 2f64.powf(STOPS * (c as f64 / (COLS - 1) as f64 - 1.0))) as f32;
        }
    }
    img
}

#[test]
fn three_brackets_four_stops_apart_merge_a_twenty_stop_ramp_within_noise() {
    let (t_long, t_mid, t_short) = (64e-3, 4e-3, 0.25e-3);
    let mut quiet_sw = NoiseSwitches::none();
    quiet_sw.prnu = true;
    quiet_sw.quantization = false;
    let quiet = sensor(quiet_sw);
    let noisy = sensor(NoiseSwitches::default());
    let k = noisy.k_dn_per_e();
    let black = quiet.black_level_dn();
    let sat_dn = (noisy.max_dn() as f64 - black).min(noisy.well_capacity_e() * k);
    // Scale the ramp so its brightest pixel reaches 85 % of the short frame's saturation.
    // (A faint probe: the sensor is linear below saturation.)
    let probe_level = 1e-7;
    let probe = quiet
        .compute(&ramp(&quiet, probe_level), &Capture::seconds(t_short))
        .unwrap();
    let peak_dn = probe.analog_dn.as_ref().unwrap()[0]
        .iter()
        .map(|v| *v as f64 - black)
        .fold(0.0, f64::max);
    assert!(peak_dn < 0.5 * sat_dn, "the probe is linear: {peak_dn} DN");
    let img = ramp(&quiet, probe_level * 0.85 * sat_dn / peak_dn);
    let truth_dn = quiet
        .compute(&img, &Capture::seconds(t_short))
        .unwrap()
        .analog_dn
        .unwrap()
        .remove(0);
    let truth_e: Vec<f64> = truth_dn
        .iter()
        .map(|v| (*v as f64 - black) / k * t_long / t_short)
        .collect();

    let frames = noisy
        .compute_bracket(&img, &[t_long, t_mid, t_short], 1, 17)
        .unwrap()
        .raw;
    let read_dn = noisy.predicted_noise_dn(0.0, 0.0).total;
    let merged = merge_frames(
        &frames,
        &MergeNoise {
            gain_dn_per_e: k,
            read_noise_dn: read_dn,
            saturation_dn: sat_dn,
        },
        None,
    )
    .unwrap();
    assert_eq!(merged.reference_exposure_s, t_long);
    assert_eq!(
        merged.saturated, 0,
        "the ramp stays below the short frame's saturation"
    );
    // Half-stop bins of the ramp.
    let bins = (2.0 * STOPS) as usize;
    let mut z: Vec<Vec<f64>> = vec![Vec::new(); bins];
    for i in 0..ROWS * COLS {
        let c = i % COLS;
        let b = ((c as f64 / COLS as f64) * bins as f64) as usize;
        let (m, t) = (merged.electrons[i] as f64, truth_e[i]);
        z[b].push((m - t) / merged.sigma_e[i] as f64);
    }
    let step_e = 1.0 / k;
    for b in 0..bins {
        let n = z[b].len() as f64;
        let mean = z[b].iter().sum::<f64>() / n;
        let sd = (z[b].iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
        // The bin's truth (mid) and the ADC rounding bias allowance in sigmas.
        let mid_e = truth_e[((b as f64 + 0.5) / bins as f64 * COLS as f64) as usize];
        let sigma_mid = (mid_e.max(0.0) + (read_dn / k).powi(2)).sqrt();
        let rounding = 0.3 * step_e / sigma_mid;
        let stops = STOPS * (b as f64 + 0.5) / bins as f64;
        assert!(
            mean.abs() < 4.0 / n.sqrt() + rounding,
            "bin {b} ({stops:.1} stops up, ~{mid_e:.1} e-): mean z {mean:.3} (n {n})"
        );
        assert!(
            (sd - 1.0).abs() < 0.25,
            "bin {b} ({stops:.1} stops up, ~{mid_e:.1} e-): z spread {sd:.3}"
        );
    }
    // Every bin's merged total is its true total within 4 predicted sigmas (plus the rounding
    // allowance above): the merge is unbiased over all 20 stops, not only on average.
    for b in 0..bins {
        let idx: Vec<usize> = (0..ROWS * COLS)
            .filter(|i| (((i % COLS) as f64 / COLS as f64) * bins as f64) as usize == b)
            .collect();
        let sum_m: f64 = idx.iter().map(|&i| merged.electrons[i] as f64).sum();
        let sum_t: f64 = idx.iter().map(|&i| truth_e[i]).sum();
        let sigma: f64 = idx
            .iter()
            .map(|&i| (merged.sigma_e[i] as f64).powi(2))
            .sum::<f64>()
            .sqrt();
        let allowance = 4.0 * sigma + 0.3 * step_e * (idx.len() as f64).sqrt();
        assert!(
            (sum_m - sum_t).abs() < allowance,
            "bin {b}: merged total {sum_m:.1} e-, truth {sum_t:.1} e- (4 sigma {:.1} e-)",
            4.0 * sigma
        );
    }
}
