//! `camsim analyze emva`: EMVA 1288 (release 4.0) characterization of a frame series listed in a
//! CSV, per colour channel (camsim_analysis::emva::emva_raw). Wiring only: loading the frames,
//! plotting and printing; the series CSV is read by camsim_io::measurements::read_emva_series and
//! the measurement is in camsim-analysis.

use crate::common::{self, say};
use anyhow::{bail, Context, Result};
use camsim_analysis::emva::{emva_raw, ChannelEmva, EmvaOptions, EmvaRawInput};
use camsim_core::{CfaChannel, RawImage};
use camsim_io::measurements::{read_emva_series, EmvaLevelFiles};
use camsim_io::plot::{LinePlot, Series};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Load every frame of the series, checking they share size and CFA pattern.
fn load_frames(a: &super::analyze::EmvaArgs, csv: &Path, files: &[EmvaLevelFiles]) -> Result<Vec<(Vec<RawImage>, Vec<RawImage>)>> {
    let total: usize = files.iter().map(|l| l.bright.len() + l.dark.len()).sum();
    let pb = common::progress(total as u64, "reading");
    let mut first: Option<(usize, usize, camsim_core::CfaPattern, PathBuf)> = None;
    let mut out = Vec::with_capacity(files.len());
    for l in files {
        let mut load = |paths: &[PathBuf]| -> Result<Vec<RawImage>> {
            paths
                .iter()
                .map(|p| {
                    let raw = camsim_pipeline::load_raw(p, a.raw.cfa, a.raw.black_dn, a.raw.bits)
                        .with_context(|| format!("{}, line {}: cannot load {}", csv.display(), l.line, p.display()))?;
                    match &first {
                        None => first = Some((raw.rows, raw.cols, raw.cfa, p.clone())),
                        Some((r, c, cfa, p0)) => {
                            if raw.rows != *r || raw.cols != *c || raw.cfa != *cfa {
                                bail!(
                                    "{}, line {}: {} is {} x {} {} but {} is {r} x {c} {}",
                                    csv.display(),
                                    l.line,
                                    p.display(),
                                    raw.rows,
                                    raw.cols,
                                    raw.cfa.name(),
                                    p0.display(),
                                    cfa.name()
                                );
                            }
                        }
                    }
                    pb.inc(1);
                    Ok(raw)
                })
                .collect()
        };
        let bright = load(&l.bright)?;
        let dark = load(&l.dark)?;
        out.push((bright, dark));
    }
    pb.finish_and_clear();
    Ok(out)
}

fn channel_color(ch: CfaChannel) -> [u8; 3] {
    match ch {
        CfaChannel::R => [220, 40, 40],
        CfaChannel::G => [30, 160, 60],
        CfaChannel::B => [40, 80, 220],
    }
}

/// Photon transfer plot: temporal variance above dark vs mean signal above dark (DN), measured
/// points and the fitted line K x + offset over the fit range, per channel.
fn ptc_plot(results: &[ChannelEmva], path: &Path) -> Result<()> {
    let mut series = Vec::new();
    for c in results {
        let r = &c.result;
        let mut s = Series::new(
            format!("{} measured", c.channel.letter()),
            // Past saturation the variance collapses below the dark variance: leave those out.
            r.points.iter().filter(|p| p.signal_var_dn2 >= 0.0).map(|p| (p.signal_dn, p.signal_var_dn2)).collect(),
        );
        s.color = Some(channel_color(c.channel));
        series.push(s);
        let xmax = r.points.iter().filter(|p| p.in_fit).map(|p| p.signal_dn).fold(0.0, f64::max);
        let mut fit = Series::new(
            format!("{} fit K = {:.4} DN/e-", c.channel.letter(), r.system_gain_dn_per_e),
            vec![(0.0, r.ptc_offset_dn2), (xmax, r.ptc_offset_dn2 + r.system_gain_dn_per_e * xmax)],
        );
        fit.color = Some(channel_color(c.channel));
        fit.dashed = true;
        series.push(fit);
    }
    LinePlot {
        title: "EMVA 1288 photon transfer".into(),
        x_label: "mean signal above dark (DN)".into(),
        y_label: "temporal variance above dark (DN^2)".into(),
        series,
        x_range: None,
        y_range: None,
    }
    .write_png(path, 900, 600)?;
    Ok(())
}

/// SNR plot on log10 axes (the plot API draws linear axes): measured SNR and the model's total
/// SNR curve against photons per pixel (electrons when the photon count is unknown).
fn snr_plot(results: &[ChannelEmva], path: &Path) -> Result<()> {
    let photons = results.iter().all(|c| c.result.points.iter().all(|p| p.photons_per_pixel.is_some()));
    let lg = |v: f64| if v > 0.0 { v.log10() } else { f64::NAN };
    let mut series = Vec::new();
    for c in results {
        let r = &c.result;
        // Up to the saturation point (beyond it the clipped frames have no temporal noise).
        let measured: Vec<(f64, f64)> = r
            .points
            .iter()
            .filter(|p| p.signal_dn <= r.saturation_signal_dn)
            .map(|p| {
                let x = if photons { p.photons_per_pixel.unwrap_or(f64::NAN) } else { p.signal_dn / r.system_gain_dn_per_e };
                (lg(x), lg(p.snr))
            })
            .collect();
        let mut s = Series::new(format!("{} measured", c.channel.letter()), measured);
        s.color = Some(channel_color(c.channel));
        series.push(s);
        let model: Vec<(f64, f64)> = r
            .snr_curve
            .iter()
            .map(|p| (lg(if photons { p.photons.unwrap_or(f64::NAN) } else { p.electrons }), lg(p.snr_total)))
            .collect();
        let mut m = Series::new(format!("{} model (total)", c.channel.letter()), model);
        m.color = Some(channel_color(c.channel));
        m.dashed = true;
        series.push(m);
    }
    LinePlot {
        title: "EMVA 1288 signal-to-noise ratio".into(),
        x_label: if photons { "log10 photons per pixel".into() } else { "log10 electrons per pixel".into() },
        y_label: "log10 SNR".into(),
        series,
        x_range: None,
        y_range: None,
    }
    .write_png(path, 900, 600)?;
    Ok(())
}

fn opt(v: Option<f64>, prec: usize) -> String {
    v.map(|x| format!("{x:.prec$}")).unwrap_or_else(|| "-".into())
}

/// The summary table, one row per channel.
fn summary(results: &[ChannelEmva]) -> Result<String> {
    let mut t = String::new();
    writeln!(
        t,
        "{:<3} {:>10} {:>11} {:>9} {:>8} {:>10} {:>10} {:>7} {:>8}",
        "ch", "K (DN/e-)", "read (e-)", "DSNU (e-)", "PRNU (%)", "sat. (e-)", "clip (e-)", "QE", "DR (dB)"
    )?;
    for c in results {
        let r = &c.result;
        writeln!(
            t,
            "{:<3} {:>10.5} {:>11.3} {:>9.3} {:>8.3} {:>10.0} {:>10.0} {:>7} {:>8.1}",
            c.channel.letter(),
            r.system_gain_dn_per_e,
            r.temporal_dark_noise_e,
            r.dsnu_e,
            r.prnu_percent,
            r.saturation_capacity_e,
            r.saturation_plateau_e,
            opt(r.quantum_efficiency, 4),
            r.dynamic_range_db
        )?;
    }
    t.push_str("sat. = EMVA saturation (maximum temporal variance); clip = largest mean signal / K\n");
    Ok(t)
}

pub fn run(a: super::analyze::EmvaArgs) -> Result<()> {
    let files = read_emva_series(&a.series)?;
    let frames = load_frames(&a, &a.series, &files)?;
    let levels: Vec<EmvaRawInput> = files
        .iter()
        .zip(&frames)
        .map(|(l, (b, d))| EmvaRawInput {
            exposure_s: l.exposure_s,
            photons_per_pixel: l.photons_per_pixel,
            bright: b.iter().collect(),
            dark: d.iter().collect(),
        })
        .collect();
    let opts = EmvaOptions::default();
    let results = emva_raw(&levels, &opts).with_context(|| format!("EMVA 1288 analysis of {}", a.series.display()))?;
    let staged = common::stage_out_dir_reading(&a.out, &[a.series.as_path()])?;
    let out = staged.path().to_path_buf();
    let raw0 = &frames[0].0[0];
    let json = serde_json::json!({
        "series": a.series.display().to_string(),
        "levels": files.len(),
        "frame_size": [raw0.rows, raw0.cols],
        "cfa": raw0.cfa.name(),
        "options": opts,
        "channels": results,
    });
    camsim_io::atomic::write_json_atomic(&out.join("emva.json"), &json)?;
    ptc_plot(&results, &out.join("ptc.png"))?;
    snr_plot(&results, &out.join("snr.png"))?;
    if a.json {
        // A closed pipe (`| head`) is not an error of the analysis.
        use std::io::Write as _;
        let _ = writeln!(std::io::stdout().lock(), "{}", serde_json::to_string_pretty(&json)?);
    }
    say(summary(&results)?);
    for c in &results {
        let r = &c.result;
        // Past saturation the temporal variance collapses (clipped pixels do not fluctuate); if it
        // has not at the brightest level, the series never clipped in this channel.
        let peak = r.points.iter().map(|p| p.var_dn2).fold(0.0, f64::max);
        let brightest = r.points.iter().max_by(|a, b| a.signal_dn.total_cmp(&b.signal_dn));
        if brightest.is_some_and(|p| p.var_dn2 > 0.5 * peak) {
            say(format!(
                "warning: channel {}: the temporal variance still grows at the brightest level, so the series does not reach saturation; its saturation, dynamic range and PRNU level are not meaningful (extend the exposures or use light this channel sees)",
                c.channel.letter()
            ));
        }
    }
    say(format!("{} levels -> {}", files.len(), a.out.join("emva.json").display()));
    common::commit(staged)?;
    Ok(())
}
