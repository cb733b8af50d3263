//! An EMVA 1288 measurement series from files, end to end: read the series CSV, load its raw
//! frames (DNG or PNG/TIFF mosaics), run the analysis (camsim-analysis) and draw the photon
//! transfer and SNR plots. `camsim analyze emva` and the Python package both call this.

use crate::{PipelineError, Progress, Result};
use camsim_analysis::emva::{emva_raw, ChannelEmva, EmvaOptions, EmvaRawInput};
use camsim_core::{CfaChannel, CfaPattern, RawImage};
use camsim_io::measurements::{read_emva_series, EmvaLevelFiles};
use camsim_io::plot::{LinePlot, Series};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// How to read PNG/TIFF mosaics (DNG files carry their own CFA, black level and bit depth).
#[derive(Debug, Clone, Copy, Default)]
pub struct MosaicFormat {
    /// CFA pattern of a PNG/TIFF mosaic.
    pub cfa: Option<CfaPattern>,
    /// Black level of a PNG/TIFF mosaic, DN.
    pub black_dn: f64,
    /// ADC bits of a PNG/TIFF mosaic (0: 16).
    pub bits: u32,
}

/// The analysed series.
#[derive(Debug, Clone)]
pub struct EmvaSeries {
    /// The series CSV.
    pub csv: PathBuf,
    /// The levels as the CSV lists them.
    pub levels: Vec<EmvaLevelFiles>,
    /// Frame size (rows, cols) and CFA shared by every frame.
    pub frame_size: (usize, usize),
    pub cfa: CfaPattern,
    /// Analysis options used.
    pub options: EmvaOptions,
    /// One result per CFA channel.
    pub channels: Vec<ChannelEmva>,
}

/// Read `csv`, load every frame (reporting `progress("reading", done, total)`), check they share
/// size and CFA pattern, and run the EMVA 1288 analysis.
pub fn analyze_series(
    csv: &Path,
    format: MosaicFormat,
    options: &EmvaOptions,
    progress: &Progress<'_>,
) -> Result<EmvaSeries> {
    let levels = read_emva_series(csv)?;
    let total = levels
        .iter()
        .map(|l| (l.bright.len() + l.dark.len()) as u64)
        .sum();
    let bits = if format.bits == 0 { 16 } else { format.bits };
    let mut first: Option<(usize, usize, CfaPattern, PathBuf)> = None;
    let mut done = 0u64;
    let mut frames: Vec<(Vec<RawImage>, Vec<RawImage>)> = Vec::with_capacity(levels.len());
    for l in &levels {
        let mut load = |paths: &[PathBuf]| -> Result<Vec<RawImage>> {
            let mut out = Vec::with_capacity(paths.len());
            for p in paths {
                let raw = crate::load_raw(p, format.cfa, format.black_dn, bits).map_err(|e| {
                    PipelineError::file(
                        csv,
                        format!("line {}: cannot load {}: {e}", l.line, p.display()),
                    )
                })?;
                match &first {
                    None => first = Some((raw.rows, raw.cols, raw.cfa, p.clone())),
                    Some((r, c, cfa, p0))
                        if raw.rows != *r || raw.cols != *c || raw.cfa != *cfa =>
                    {
                        return Err(PipelineError::file(
                            csv,
                            format!(
                                "line {}: {} is {} x {} {} but {} is {r} x {c} {}",
                                l.line,
                                p.display(),
                                raw.rows,
                                raw.cols,
                                raw.cfa.name(),
                                p0.display(),
                                cfa.name()
                            ),
                        ))
                    }
                    Some(_) => {}
                }
                done += 1;
                progress("reading", done, total);
                out.push(raw);
            }
            Ok(out)
        };
        let bright = load(&l.bright)?;
        let dark = load(&l.dark)?;
        frames.push((bright, dark));
    }
    let (rows, cols, cfa, _) =
        first.ok_or_else(|| PipelineError::file(csv, "the series has no frames"))?;
    let inputs: Vec<EmvaRawInput> = levels
        .iter()
        .zip(&frames)
        .map(|(l, (b, d))| EmvaRawInput {
            exposure_s: l.exposure_s,
            photons_per_pixel: l.photons_per_pixel,
            bright: b.iter().collect(),
            dark: d.iter().collect(),
        })
        .collect();
    let channels = emva_raw(&inputs, options)
        .map_err(|e| PipelineError::file(csv, format!("EMVA 1288 analysis: {e}")))?;
    Ok(EmvaSeries {
        csv: csv.to_path_buf(),
        levels,
        frame_size: (rows, cols),
        cfa,
        options: *options,
        channels,
    })
}

impl EmvaSeries {
    /// The `emva.json` record: the series, its frame size and CFA, the options and every
    /// channel's result.
    pub fn to_json(&self) -> serde_json::Value {
        serde_json::json!({
            "series": self.csv.display().to_string(),
            "levels": self.levels.len(),
            "frame_size": [self.frame_size.0, self.frame_size.1],
            "cfa": self.cfa.name(),
            "options": self.options,
            "channels": self.channels,
        })
    }

    /// The summary table, one row per channel (K, read noise, DSNU, PRNU, saturation, QE, DR).
    pub fn summary(&self) -> String {
        let mut t = String::new();
        let _ = writeln!(
            t,
            "{:<3} {:>10} {:>11} {:>9} {:>8} {:>10} {:>10} {:>7} {:>8}",
            "ch",
            "K (DN/e-)",
            "read (e-)",
            "DSNU (e-)",
            "PRNU (%)",
            "sat. (e-)",
            "clip (e-)",
            "QE",
            "DR (dB)"
        );
        for c in &self.channels {
            let r = &c.result;
            let qe = r
                .quantum_efficiency
                .map(|x| format!("{x:.4}"))
                .unwrap_or_else(|| "-".into());
            let _ = writeln!(
                t,
                "{:<3} {:>10.5} {:>11.3} {:>9.3} {:>8.3} {:>10.0} {:>10.0} {:>7} {:>8.1}",
                c.channel.letter(),
                r.system_gain_dn_per_e,
                r.temporal_dark_noise_e,
                r.dsnu_e,
                r.prnu_percent,
                r.saturation_capacity_e,
                r.saturation_plateau_e,
                qe,
                r.dynamic_range_db
            );
        }
        t.push_str(
            "sat. = EMVA saturation (maximum temporal variance); clip = largest mean signal / K\n",
        );
        t
    }

    /// Channels whose temporal variance still grows at the brightest level: the series never
    /// reached saturation there, so saturation, dynamic range and PRNU are not meaningful.
    pub fn unsaturated_channels(&self) -> Vec<CfaChannel> {
        self.channels
            .iter()
            .filter(|c| {
                let pts = &c.result.points;
                let peak = pts.iter().map(|p| p.var_dn2).fold(0.0, f64::max);
                let brightest = pts
                    .iter()
                    .max_by(|a, b| a.signal_dn.total_cmp(&b.signal_dn));
                brightest.is_some_and(|p| p.var_dn2 > 0.5 * peak)
            })
            .map(|c| c.channel)
            .collect()
    }

    /// Write the photon transfer plot (`ptc.png`) and the SNR plot (`snr.png`) into `dir`.
    pub fn write_plots(&self, dir: &Path) -> Result<()> {
        ptc_plot(&self.channels).write_png(&dir.join("ptc.png"), 900, 600)?;
        snr_plot(&self.channels).write_png(&dir.join("snr.png"), 900, 600)?;
        Ok(())
    }
}

fn channel_color(ch: CfaChannel) -> [u8; 3] {
    match ch {
        CfaChannel::R => [220, 40, 40],
        CfaChannel::G => [30, 160, 60],
        CfaChannel::B => [40, 80, 220],
    }
}

fn colored(name: String, points: Vec<(f64, f64)>, ch: CfaChannel, dashed: bool) -> Series {
    let mut s = Series::new(name, points);
    s.color = Some(channel_color(ch));
    s.dashed = dashed;
    s
}

/// Photon transfer plot (EMVA 1288 4.0 §6.3): temporal variance above dark vs mean signal above
/// dark (DN), measured points and the fitted line K x + offset over the fit range, per channel.
fn ptc_plot(results: &[ChannelEmva]) -> LinePlot {
    let mut series = Vec::new();
    for c in results {
        let r = &c.result;
        // Past saturation the variance collapses below the dark variance: leave those out.
        let measured = r
            .points
            .iter()
            .filter(|p| p.signal_var_dn2 >= 0.0)
            .map(|p| (p.signal_dn, p.signal_var_dn2))
            .collect();
        series.push(colored(
            format!("{} measured", c.channel.letter()),
            measured,
            c.channel,
            false,
        ));
        let xmax = r
            .points
            .iter()
            .filter(|p| p.in_fit)
            .map(|p| p.signal_dn)
            .fold(0.0, f64::max);
        let line = vec![
            (0.0, r.ptc_offset_dn2),
            (xmax, r.ptc_offset_dn2 + r.system_gain_dn_per_e * xmax),
        ];
        series.push(colored(
            format!(
                "{} fit K = {:.4} DN/e-",
                c.channel.letter(),
                r.system_gain_dn_per_e
            ),
            line,
            c.channel,
            true,
        ));
    }
    LinePlot {
        title: "EMVA 1288 photon transfer".into(),
        x_label: "mean signal above dark (DN)".into(),
        y_label: "temporal variance above dark (DN^2)".into(),
        series,
        x_range: None,
        y_range: None,
    }
}

/// SNR plot on log10 axes (the plot API draws linear axes): measured SNR and the model's total
/// SNR curve against photons per pixel (electrons when the photon count is unknown).
fn snr_plot(results: &[ChannelEmva]) -> LinePlot {
    let photons = results.iter().all(|c| {
        c.result
            .points
            .iter()
            .all(|p| p.photons_per_pixel.is_some())
    });
    let lg = |v: f64| if v > 0.0 { v.log10() } else { f64::NAN };
    let mut series = Vec::new();
    for c in results {
        let r = &c.result;
        // Up to the saturation point (beyond it the clipped frames have no temporal noise).
        let measured = r
            .points
            .iter()
            .filter(|p| p.signal_dn <= r.saturation_signal_dn)
            .map(|p| {
                let x = if photons {
                    p.photons_per_pixel.unwrap_or(f64::NAN)
                } else {
                    p.signal_dn / r.system_gain_dn_per_e
                };
                (lg(x), lg(p.snr))
            })
            .collect();
        series.push(colored(
            format!("{} measured", c.channel.letter()),
            measured,
            c.channel,
            false,
        ));
        let model = r
            .snr_curve
            .iter()
            .map(|p| {
                (
                    lg(if photons {
                        p.photons.unwrap_or(f64::NAN)
                    } else {
                        p.electrons
                    }),
                    lg(p.snr_total),
                )
            })
            .collect();
        series.push(colored(
            format!("{} model (total)", c.channel.letter()),
            model,
            c.channel,
            true,
        ));
    }
    LinePlot {
        title: "EMVA 1288 signal-to-noise ratio".into(),
        x_label: if photons {
            "log10 photons per pixel".into()
        } else {
            "log10 electrons per pixel".into()
        },
        y_label: "log10 SNR".into(),
        series,
        x_range: None,
        y_range: None,
    }
}
