//! The inverse ISP (issue 42 item 6): a Macbeth raw rendered to an sRGB preview by the `Isp`,
//! unprocessed (Brooks et al. 2019) and given the sensor's noise, gives back the raw's patch
//! means within noise and the 8-bit rounding's bound; and the raw-domain steps of the `Isp`
//! (column correction, defect correction) remove the sensor's own defects.

use camsim_core::colorimetry::srgb_decode;
use camsim_core::{tables, Quantity, RawImage, SpectralImage, WavelengthGrid};
use camsim_isp::defect_correction::DefectCorrection;
use camsim_isp::line_noise::ColumnCorrection;
use camsim_pipeline::isp::Isp;
use camsim_sensor::{Capture, Sensor};

const PATCH_PX: usize = 16;
const ROWS: usize = 4 * PATCH_PX;
const COLS: usize = 6 * PATCH_PX;

/// A noise-free Macbeth mosaic of `sensor` under D65 (patch k at row k / 6, column k % 6), the
/// white patch's largest channel at half the DN range; with the expected DN above black of each
/// patch and channel, and the exposure, s.
fn macbeth_raw(sensor: &Sensor, grid: &WavelengthGrid) -> (RawImage, Vec<[f64; 3]>, f64) {
    let d65 = tables::illuminant("D65").unwrap().sample(grid);
    let refl = tables::macbeth_reflectances();
    let k = sensor.k_dn_per_e();
    let electrons = |i: usize, t: f64| -> [f64; 3] {
        let r = refl[i].sample(grid);
        let irr: Vec<f64> = d65.iter().zip(&r).map(|(a, b)| 1e-3 * a * b).collect();
        sensor.mean_electrons_uniform(&irr, grid, t).unwrap()
    };
    let white = electrons(18, 1.0);
    let range_dn = sensor.max_dn() as f64 - sensor.black_level_dn();
    let t = 0.5 * range_dn / k / white.iter().cloned().fold(0.0, f64::max);
    let means: Vec<[f64; 3]> = (0..24).map(|i| electrons(i, t).map(|e| e * k)).collect();
    let mut raw = RawImage::new(ROWS, COLS, sensor.cfa(), sensor.bits()).unwrap();
    raw.black_level_dn = sensor.black_level_dn();
    raw.white_level_dn = sensor.max_dn() as f64;
    for r in 0..ROWS {
        for c in 0..COLS {
            let p = (r / PATCH_PX) * 6 + c / PATCH_PX;
            let ch = raw.channel_at(r, c).index();
            raw.dn[r * COLS + c] = (raw.black_level_dn + means[p][ch]).round() as u16;
        }
    }
    (raw, means, t)
}

/// Inner (PATCH_PX - 6)^2 pixels of patch p: (row, col).
fn inner(p: usize) -> impl Iterator<Item = (usize, usize)> {
    let (r0, c0) = ((p / 6) * PATCH_PX + 3, (p % 6) * PATCH_PX + 3);
    (r0..r0 + PATCH_PX - 6).flat_map(move |r| (c0..c0 + PATCH_PX - 6).map(move |c| (r, c)))
}

#[test]
fn unprocessed_macbeth_preview_gives_back_the_patch_means() {
    let grid = WavelengthGrid::default();
    let sensor = Sensor::preset("imx363")
        .unwrap()
        .with_size(ROWS, COLS)
        .unwrap();
    let (raw, means, _) = macbeth_raw(&sensor, &grid);
    let isp = Isp::new(tables::illuminant("D65").unwrap(), grid);
    let out = isp.compute(&raw, &sensor).unwrap();
    let params = isp.unprocess_params(&sensor, &out.report).unwrap();
    let inv = camsim_isp::color::mat3_inverse(&params.camera_to_linear_srgb).unwrap();
    let mosaic = isp.unprocess(&out.preview, &sensor, &out.report).unwrap();
    let noisy = isp
        .unprocess_raw(&out.preview, &sensor, &out.report, 0.01, 5)
        .unwrap();
    let k = sensor.k_dn_per_e();
    let read_dn = sensor.predicted_noise_dn(0.0, 0.0).read;
    let (mut used, mut worst_clean, mut worst_noisy) = (0, 0.0f64, 0.0f64);
    for (p, want) in means.iter().enumerate() {
        // The patch's codes (all alike: a noise-free raw), and the 8-bit rounding's bound in
        // camera DN: half a code's linear step per display channel through |M^-1| / scale.
        let codes: Vec<[u8; 3]> = inner(p)
            .map(|(r, c)| {
                let i = (r * COLS + c) * 3;
                [
                    out.preview.data[i],
                    out.preview.data[i + 1],
                    out.preview.data[i + 2],
                ]
            })
            .collect();
        if codes.iter().flatten().any(|v| *v == 0 || *v == 255) {
            continue; // clipped in the preview: not invertible
        }
        used += 1;
        let half_step = [0, 1, 2].map(|j| {
            codes
                .iter()
                .map(|px| {
                    let v = px[j] as f64;
                    0.5 * (srgb_decode((v + 0.5) / 255.0) - srgb_decode((v - 0.5) / 255.0))
                })
                .fold(0.0, f64::max)
        });
        for ch in 0..3 {
            let sites: Vec<(usize, usize)> = inner(p)
                .filter(|&(r, c)| raw.channel_at(r, c).index() == ch)
                .collect();
            let n = sites.len() as f64;
            let bound = (0..3).map(|j| inv[ch][j].abs() * half_step[j]).sum::<f64>()
                / (params.exposure_scale * params.white_balance_gains[ch]);
            // + 0.5 DN: the raw's own rounding; + 5 % (measured up to 4.4 %, patch 4 blue) for the chroma coring and the demosaic's
            // 1-pixel reach, which the forward ISP does not undo.
            let tol_clean = bound + 0.5 + 0.05 * want[ch];
            let clean = sites
                .iter()
                .map(|&(r, c)| mosaic[r * COLS + c] as f64)
                .sum::<f64>()
                / n;
            let e = (clean - want[ch]).abs();
            assert!(
                e < tol_clean,
                "patch {}, channel {ch}: unprocessed {clean:.2} DN, raw {:.2} DN (bound {tol_clean:.2})",
                p + 1,
                want[ch]
            );
            worst_clean = worst_clean.max(e / tol_clean);
            // The simulated raw: its patch mean within 4 standard errors of the sensor's noise.
            let sigma = (k * want[ch] + read_dn * read_dn + 1.0 / 12.0).sqrt();
            let noisy_mean = sites
                .iter()
                .map(|&(r, c)| noisy.dn[r * COLS + c] as f64 - noisy.black_level_dn)
                .sum::<f64>()
                / n;
            let tol = tol_clean + 4.0 * sigma / n.sqrt();
            let e = (noisy_mean - want[ch]).abs();
            assert!(
                e < tol,
                "patch {}, channel {ch}: simulated {noisy_mean:.2} DN, raw {:.2} DN (tolerance {tol:.2})",
                p + 1,
                want[ch]
            );
            worst_noisy = worst_noisy.max(e / tol);
        }
    }
    eprintln!(
        "patches used {used} of 24; worst |error| / tolerance: unprocessed {worst_clean:.3}, simulated {worst_noisy:.3}"
    );
    assert!(used >= 20, "only {used} patches unclipped");
    // The same seed gives the same raw.
    let again = isp
        .unprocess_raw(&out.preview, &sensor, &out.report, 0.01, 5)
        .unwrap();
    assert_eq!(again.dn, noisy.dn);
}

/// The sensor's own column FPN and faulty pixels (camsim-sensor `[defects]`) removed by the ISP:
/// the column offsets from 8 dark captures (a trimmed mean per column, so the dark frame's stuck
/// and hot pixels do not shift them) take the column-mean variance down to that of independent
/// pixels, and each listed defect comes back to its filter's level. Column correction from dark
/// frames needs a black-level pedestal (a dark frame clipped at 0 DN loses negative offsets).
#[test]
fn the_isp_removes_the_sensors_column_fpn_and_defects() {
    let grid = WavelengthGrid::default();
    let base = Sensor::preset("imx363")
        .unwrap()
        .with_size(ROWS, COLS)
        .unwrap();
    let (_, _, t) = macbeth_raw(&base, &grid);
    // A flat field of neutral 5 (patch 22) at the Macbeth exposure.
    let d65 = tables::illuminant("D65").unwrap().sample(&grid);
    let r22 = tables::macbeth_reflectances()[21].sample(&grid);
    let level_e = base
        .mean_electrons_uniform(
            &d65.iter()
                .zip(&r22)
                .map(|(a, b)| 1e-3 * a * b)
                .collect::<Vec<_>>(),
            &grid,
            t,
        )
        .unwrap()[1];
    let mut cfg = base.config().clone();
    // A black-level pedestal well above the column offsets' spread (3 mV is ~28 DN here): the
    // imx363 preset has none, and a dark frame clipped at 0 DN cannot show a negative offset.
    cfg.black_level_dn = 256.0;
    cfg.defects = Some(camsim_sensor::defects::DefectsConfig {
        column_offset_mv: 3.0,
        hot_fraction: 0.003,
        // 30 % of the field's signal extra over the exposure.
        hot_dark_current_e_per_s: 0.3 * level_e / t,
        dead_fraction: 0.003,
        stuck_fraction: 0.003,
        ..Default::default()
    });
    let sensor = Sensor::from_config(cfg).unwrap();
    let defects: Vec<(usize, usize)> = sensor
        .defect_list()
        .iter()
        .map(|d| (d.row, d.col))
        .collect();
    assert!(defects.len() >= 10, "{} defects", defects.len());
    let mut irr = SpectralImage::zeros(
        ROWS,
        COLS,
        grid,
        sensor.pixel_pitch_m(),
        Quantity::Irradiance,
    )
    .unwrap();
    for (b, v) in d65
        .iter()
        .zip(&r22)
        .enumerate()
        .map(|(b, (a, r))| (b, 1e-3 * a * r))
    {
        irr.band_mut(b).iter_mut().for_each(|x| *x = v as f32);
    }
    let raw = sensor
        .compute(&irr, &Capture::seconds(t).with_seed(3))
        .unwrap()
        .raw
        .remove(0);
    // Dark frames: 8 captures without light, their mean's column and row offsets.
    let dark_irr = SpectralImage::zeros(
        ROWS,
        COLS,
        grid,
        sensor.pixel_pitch_m(),
        Quantity::Irradiance,
    )
    .unwrap();
    let darks = sensor
        .compute(&dark_irr, &Capture::seconds(t).with_seed(9).with_frames(8))
        .unwrap()
        .raw;
    let isp = Isp {
        dark_offsets: Some(
            camsim_isp::line_noise::LineOffsets::from_dark_frames(&darks, false).unwrap(),
        ),
        column_correction: ColumnCorrection::Off,
        defect_correction: DefectCorrection::Sensor,
        ..Isp::new(tables::illuminant("D65").unwrap(), grid)
    };
    let fixed = isp.correct_raw(&raw, &sensor, 1.0).unwrap().into_owned();
    // Residuals from each filter's median level (robust to the defects).
    let residual = |raw: &RawImage| -> Vec<f64> {
        let med: Vec<f64> = (0..3)
            .map(|ch| {
                let mut v: Vec<u16> = (0..ROWS * COLS)
                    .filter(|i| raw.channel_at(i / COLS, i % COLS).index() == ch)
                    .map(|i| raw.dn[i])
                    .collect();
                v.sort_unstable();
                v[v.len() / 2] as f64
            })
            .collect();
        (0..ROWS * COLS)
            .map(|i| raw.dn[i] as f64 - med[raw.channel_at(i / COLS, i % COLS).index()])
            .collect()
    };
    // Column-mean variance across columns and the mean within-column variance, over the pixels
    // that are not defects.
    let is_defect: std::collections::HashSet<(usize, usize)> = defects.iter().cloned().collect();
    let column_stats = |res: &[f64]| -> (f64, f64) {
        let mut means = Vec::new();
        let mut within = 0.0;
        for c in 0..COLS {
            let v: Vec<f64> = (0..ROWS)
                .filter(|r| !is_defect.contains(&(*r, c)))
                .map(|r| res[r * COLS + c])
                .collect();
            let m = v.iter().sum::<f64>() / v.len() as f64;
            within += v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (v.len() - 1) as f64;
            means.push(m);
        }
        let mm = means.iter().sum::<f64>() / COLS as f64;
        let across = means.iter().map(|m| (m - mm).powi(2)).sum::<f64>() / (COLS - 1) as f64;
        (across, within / COLS as f64)
    };
    let (before, _) = column_stats(&residual(&raw));
    let (after, within) = column_stats(&residual(&fixed));
    // Independent pixels: the column means vary by the pixel variance / rows; the sample
    // variance of 96 columns has relative sd sqrt(2 / 95) = 14.5 %, 4 of those above.
    // The 8-frame dark mean adds 1/8 of the dark frame's temporal variance (at most the
    // pixel variance) / rows.
    let expected = within / ROWS as f64 * (1.0 + 1.0 / 8.0);
    eprintln!(
        "column-mean variance: before {before:.3} DN^2, after {after:.4}, expected {expected:.4}"
    );
    assert!(
        after < expected * (1.0 + 4.0 * (2.0 / 95.0f64).sqrt()),
        "{after} vs {expected}"
    );
    assert!(before > 10.0 * expected, "the FPN was not there: {before}");
    // Each defect back within 5 pixel sigmas of its filter's level.
    let (res_before, res_after) = (residual(&raw), residual(&fixed));
    let sigma = within.sqrt();
    let far = defects
        .iter()
        .filter(|&&(r, c)| res_before[r * COLS + c].abs() > 5.0 * sigma)
        .count();
    assert!(
        far * 2 > defects.len(),
        "only {far} of {} defects stood out",
        defects.len()
    );
    for &(r, c) in &defects {
        let e = res_after[r * COLS + c];
        assert!(
            e.abs() < 5.0 * sigma,
            "defect ({r}, {c}) left at {e:.1} DN (sigma {sigma:.1})"
        );
    }
}
