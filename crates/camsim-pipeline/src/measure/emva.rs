//! EMVA 1288 measurement series, end to end: simulate one with a sensor model and write it as
//! the series CSV camsim reads plus its DNG frames ([`simulate_series`], `camsim sensor
//! --emva-series`); read a series CSV, load its raw frames (DNG or PNG/TIFF mosaics), run the
//! analysis (camsim-analysis) and draw the photon transfer and SNR plots ([`analyze_series`],
//! `camsim analyze emva` and Python's `camsim.emva_series`). The CSV format is camsim-io's
//! (`camsim_io::measurements::{read_emva_series, write_emva_series}`).

use crate::{MosaicFormat, PipelineError, Progress, Result};
use camsim_analysis::emva::{emva_raw, ChannelEmva, EmvaOptions, EmvaRawInput};
use camsim_core::{CfaChannel, CfaPattern, RawImage, WavelengthGrid};
use camsim_io::atomic::OutputDir;
use camsim_io::dng::DngMetadata;
use camsim_io::measurements::{read_emva_series, write_emva_series, EmvaLevelFiles};
use camsim_io::plot::{Figure, Series, CHANNEL_COLORS};
use camsim_sensor::Sensor;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

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

/// One level of a series in memory: its exposure, the photons per pixel when known, and at least
/// two bright frames and none or at least two dark frames.
#[derive(Debug, Clone)]
pub struct LevelFrames {
    /// Exposure time, s.
    pub exposure_s: f64,
    /// Mean photons per pixel (for QE and responsivity), when known.
    pub photons_per_pixel: Option<f64>,
    /// Sensor-plane photometric exposure, lux s (for ISO 12232 speeds), when known.
    pub exposure_lux_s: Option<f64>,
    /// Frames of the uniform irradiance.
    pub bright: Vec<RawImage>,
    /// Frames without light at the same exposure.
    pub dark: Vec<RawImage>,
}

/// The EMVA 1288 analysis of a series in memory, per CFA channel (`camsim_analysis::emva`).
pub fn analyze_levels(
    levels: &[LevelFrames],
    options: &EmvaOptions,
) -> std::result::Result<Vec<ChannelEmva>, camsim_analysis::AnalysisError> {
    let inputs: Vec<EmvaRawInput> = levels
        .iter()
        .map(|l| EmvaRawInput {
            exposure_s: l.exposure_s,
            photons_per_pixel: l.photons_per_pixel,
            exposure_lux_s: l.exposure_lux_s,
            bright: l.bright.iter().collect(),
            dark: l.dark.iter().collect(),
        })
        .collect();
    emva_raw(&inputs, options)
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
    let mut first: Option<(usize, usize, CfaPattern, PathBuf)> = None;
    let mut done = 0u64;
    let mut frames: Vec<(Vec<RawImage>, Vec<RawImage>)> = Vec::with_capacity(levels.len());
    for l in &levels {
        let mut load = |paths: &[PathBuf]| -> Result<Vec<RawImage>> {
            let mut out = Vec::with_capacity(paths.len());
            for p in paths {
                let raw = crate::load_raw(p, &format).map_err(|e| {
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
    let inputs: Vec<LevelFrames> = levels
        .iter()
        .zip(frames)
        .map(|(l, (bright, dark))| LevelFrames {
            exposure_s: l.exposure_s,
            photons_per_pixel: l.photons_per_pixel,
            exposure_lux_s: l.exposure_lux_s,
            bright,
            dark,
        })
        .collect();
    let channels = analyze_levels(&inputs, options)
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
            "{:<3} {:>10} {:>11} {:>9} {:>8} {:>10} {:>10} {:>7} {:>8} {:>12}",
            "ch",
            "K (DN/e-)",
            "read (e-)",
            "DSNU (e-)",
            "PRNU (%)",
            "sat. (e-)",
            "clip (e-)",
            "QE",
            "DR (dB)",
            "ISO DR (dB)"
        );
        for c in &self.channels {
            let r = &c.result;
            let qe = r
                .quantum_efficiency
                .map(|x| format!("{x:.4}"))
                .unwrap_or_else(|| "-".into());
            let _ = writeln!(
                t,
                "{:<3} {:>10.5} {:>11.3} {:>9.3} {:>8.3} {:>10.0} {:>10.0} {:>7} {:>8.1} {:>12.1}",
                c.channel.letter(),
                r.system_gain_dn_per_e,
                r.temporal_dark_noise_e,
                r.dsnu_e,
                r.prnu_percent,
                r.saturation_capacity_e,
                r.saturation_plateau_e,
                qe,
                r.dynamic_range_db,
                r.iso_15739_dynamic_range_db
            );
        }
        t.push_str(
            "sat. = EMVA saturation (maximum temporal variance); clip = largest mean signal / K; DR = sat. / the signal of temporal SNR 1 (EMVA 1288), ISO DR = sat. / the signal of total SNR 1, DSNU and PRNU included (ISO 15739)\n",
        );
        if self.channels.iter().all(|c| c.result.iso_12232.is_some()) {
            let _ = writeln!(
                t,
                "{:<3} {:>14} {:>10} {:>10} {:>10}",
                "ch", "lux s / e-", "ISO S_sat", "ISO S_40", "ISO S_10"
            );
            let speed = |v: Option<f64>| v.map_or_else(|| "-".into(), |v| format!("{v:.0}"));
            for c in &self.channels {
                if let Some(i) = c.result.iso_12232 {
                    let _ = writeln!(
                        t,
                        "{:<3} {:>14.4e} {:>10.0} {:>10} {:>10}",
                        c.channel.letter(),
                        i.lux_s_per_e,
                        i.saturation_speed,
                        speed(i.noise_speed_40),
                        speed(i.noise_speed_10)
                    );
                }
            }
            t.push_str("ISO 12232 speeds of each channel for the series' light, from the sensor-plane exposure (lux s): S_sat = 78 / H_sat, S_x = 10 / H at SNR x (total noise)\n");
        }
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
        ptc_plot(&self.channels).write_png(&dir.join("ptc.png"))?;
        snr_plot(&self.channels).write_png(&dir.join("snr.png"))?;
        if let Some(fig) = snr_lux_plot(&self.channels) {
            fig.write_png(&dir.join("snr_lux.png"))?;
        }
        Ok(())
    }

    /// Write emva.json, ptc.png and snr.png into `dir`; returns emva.json's value.
    pub fn write_files(&self, dir: &Path) -> Result<serde_json::Value> {
        let json = self.to_json();
        camsim_io::atomic::write_json_atomic(&dir.join("emva.json"), &json)?;
        self.write_plots(dir)?;
        Ok(json)
    }
}

fn colored(name: String, points: Vec<(f64, f64)>, ch: CfaChannel, dashed: bool) -> Series {
    let s = Series::new(name, points).colored(CHANNEL_COLORS[ch.index()]);
    if dashed {
        s.dashed()
    } else {
        s
    }
}

/// Photon transfer plot (EMVA 1288 4.0 §6.3): temporal variance above dark vs mean signal above
/// dark (DN), measured points and the fitted line K x + offset over the fit range, per channel.
fn ptc_plot(results: &[ChannelEmva]) -> Figure {
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
    let mut fig = Figure::new(
        "EMVA 1288 photon transfer: temporal variance vs mean signal (DN)",
        "mean signal above dark (DN)",
        "temporal variance above dark (DN^2)",
    )
    .sized(900, 600);
    fig.series = series;
    fig
}

/// SNR against the sensor-plane exposure in lux s on log10 axes (the datasheet's plot), with the
/// ISO 12232 noise-speed levels (SNR 10 and 40) as lines; `None` unless every level gives lux s.
fn snr_lux_plot(results: &[ChannelEmva]) -> Option<Figure> {
    if !results.iter().all(|c| c.result.iso_12232.is_some()) {
        return None;
    }
    let lg = |v: f64| if v > 0.0 { v.log10() } else { f64::NAN };
    let mut series = Vec::new();
    let (mut xmin, mut xmax) = (f64::INFINITY, f64::NEG_INFINITY);
    for c in results {
        let r = &c.result;
        let measured: Vec<(f64, f64)> = r
            .points
            .iter()
            .filter(|p| p.signal_dn <= r.saturation_signal_dn)
            .filter_map(|p| p.exposure_lux_s.map(|h| (lg(h), lg(p.snr))))
            .collect();
        series.push(colored(
            format!("{} measured", c.channel.letter()),
            measured,
            c.channel,
            false,
        ));
        let model: Vec<(f64, f64)> = r
            .snr_curve
            .iter()
            .filter_map(|p| p.exposure_lux_s.map(|h| (lg(h), lg(p.snr_total))))
            .collect();
        for (x, _) in &model {
            xmin = xmin.min(*x);
            xmax = xmax.max(*x);
        }
        series.push(colored(
            format!("{} model (total)", c.channel.letter()),
            model,
            c.channel,
            true,
        ));
    }
    for snr in [10.0f64, 40.0] {
        series.push(
            Series::new(
                format!("SNR {snr} (ISO 12232 S_{snr})"),
                vec![(xmin, snr.log10()), (xmax, snr.log10())],
            )
            .dashed(),
        );
    }
    let mut fig = Figure::new(
        "Signal-to-noise ratio against sensor-plane exposure",
        "log10 exposure (lux s)",
        "log10 SNR",
    )
    .sized(900, 600);
    fig.series = series;
    Some(fig)
}

/// SNR plot on log10 axes (the plot API draws linear axes): measured SNR and the model's total
/// SNR curve against photons per pixel (electrons when the photon count is unknown).
fn snr_plot(results: &[ChannelEmva]) -> Figure {
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
    let x_label = if photons {
        "log10 photons per pixel"
    } else {
        "log10 electrons per pixel"
    };
    let mut fig =
        Figure::new("EMVA 1288 signal-to-noise ratio", x_label, "log10 SNR").sized(900, 600);
    fig.series = series;
    fig
}

/// A series to simulate ([`simulate_series`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SeriesRequest {
    /// Exposure levels from dark to past saturation (at least 3).
    pub levels: usize,
    /// Frames per level, bright and dark each (at least 2).
    pub frames_per_level: usize,
    /// Frame size, pixels (at most the sensor's).
    pub rows: usize,
    /// Frame columns.
    pub cols: usize,
    /// Analog offset, mV (None: the sensor's, or 8 x its read noise when that is below 5 x the
    /// read noise: EMVA 1288 needs dark frames that do not clip at 0).
    pub analog_offset_mv: Option<f64>,
    /// Seed of the temporal noise.
    pub seed: u64,
}

/// A field of a [`SeriesRequest`], by a neutral name: each door (the CLI's flags, Python's
/// keywords) spells it its own way when it reports a refused request ([`SeriesError`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SeriesField {
    /// [`SeriesRequest::levels`].
    Levels,
    /// [`SeriesRequest::frames_per_level`].
    FramesPerLevel,
    /// [`SeriesRequest::rows`].
    Rows,
    /// [`SeriesRequest::cols`].
    Cols,
}

impl SeriesField {
    /// The field's name in [`SeriesRequest`] (snake case).
    pub fn name(self) -> &'static str {
        match self {
            SeriesField::Levels => "levels",
            SeriesField::FramesPerLevel => "frames_per_level",
            SeriesField::Rows => "rows",
            SeriesField::Cols => "cols",
        }
    }
}

/// A series request refused: the offending fields with their values, and why. Its `Display`
/// names the fields as [`SeriesField::name`] does; a door with other spellings formats it with
/// [`SeriesError::spelled`].
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{}", self.spelled(|f| f.name(), " = "))]
pub struct SeriesError {
    /// The fields at fault, with their values.
    pub fields: Vec<(SeriesField, usize)>,
    /// What is wrong, without the fields' names.
    pub message: String,
}

impl SeriesError {
    /// The message with each field spelled by `name` and joined to its value by `sep`
    /// (`--levels 0: ...` for the CLI, `levels=0: ...` for Python).
    pub fn spelled(&self, name: impl Fn(SeriesField) -> &'static str, sep: &str) -> String {
        let fields: Vec<String> = self
            .fields
            .iter()
            .map(|(f, v)| format!("{}{sep}{v}", name(*f)))
            .collect();
        format!("{}: {}", fields.join(", "), self.message)
    }
}

impl SeriesRequest {
    /// Refuse a series that cannot be made as asked (never clamped): fewer than 3 levels, fewer
    /// than 2 frames per level, a window that does not fit `sensor`.
    pub fn validate(&self, sensor: &Sensor) -> Result<(), SeriesError> {
        let bad = |fields: Vec<(SeriesField, usize)>, message: String| {
            Err(SeriesError { fields, message })
        };
        if self.levels < 3 {
            return bad(
                vec![(SeriesField::Levels, self.levels)],
                "an EMVA 1288 series needs at least 3 exposure levels (dark to past saturation)"
                    .into(),
            );
        }
        if self.frames_per_level < 2 {
            return bad(
                vec![(SeriesField::FramesPerLevel, self.frames_per_level)],
                "EMVA 1288 needs at least 2 frames per level (temporal noise is their difference)"
                    .into(),
            );
        }
        let (rows, cols) = (self.rows, self.cols);
        if rows == 0 || cols == 0 || rows > sensor.rows() || cols > sensor.cols() {
            return bad(
                vec![(SeriesField::Rows, rows), (SeriesField::Cols, cols)],
                format!(
                    "the EMVA window {rows} x {cols} must be at least 1 x 1 and fit the {} x {} sensor",
                    sensor.rows(),
                    sensor.cols()
                ),
            );
        }
        Ok(())
    }

    /// Refuse a series the disk holding `out` cannot hold: every frame a DNG of 2 bytes a pixel
    /// and a header ([`camsim_core::mem::check_disk`]).
    pub fn check_disk(&self, out: &Path) -> Result<()> {
        let frames = (self.levels as u64) * 2 * self.frames_per_level as u64;
        let per_frame = (self.rows as u64).saturating_mul(self.cols as u64) * 2 + 65536;
        camsim_core::mem::check_disk(
            out,
            frames.saturating_mul(per_frame),
            &format!(
                "the EMVA series ({frames} DNG files of {} x {})",
                self.rows, self.cols
            ),
        )?;
        Ok(())
    }
}

/// A simulated series, in memory.
#[derive(Debug, Clone)]
pub struct SimulatedSeries {
    /// The levels' frames, exposure and photons.
    pub levels: Vec<camsim_sensor::EmvaLevel>,
    /// The analog offset used, mV.
    pub analog_offset_mv: f64,
    /// Whether the offset was raised for the dark frames (not asked for).
    pub offset_raised: bool,
    /// The sensor (with that offset).
    pub sensor_name: String,
}

/// Simulate an EMVA 1288 photon-transfer series with `sensor`: flat fields of three lines
/// balanced so every channel collects 1e5 e-/s, at exposures from 0 to 1.3 x the time the signal
/// reaches the clipping level, plus dark frames; `progress("emva", level, levels)`.
pub fn simulate_series(
    sensor: &Sensor,
    req: &SeriesRequest,
    progress: &Progress<'_>,
) -> Result<SimulatedSeries> {
    let grid = WavelengthGrid::default();
    // EMVA 1288 needs dark frames above 0 DN: give the sensor a black level if it has none.
    let mut cfg = sensor.config().clone();
    let read_mv = sensor.read_noise_v() * 1e3;
    let (offset_mv, raised) = match req.analog_offset_mv {
        Some(mv) => (mv, false),
        None if sensor.analog_offset_v() * 1e3 < 5.0 * read_mv => ((8.0 * read_mv).max(1.0), true),
        None => (sensor.analog_offset_v() * 1e3, false),
    };
    cfg.analog_offset_mv = offset_mv;
    let sensor = Sensor::from_config_named(cfg, "the EMVA series' sensor")?;
    req.validate(&sensor)?;
    let (rows, cols) = (req.rows, req.cols);
    let rate_e_per_s = 1e5;
    let irr = sensor.balanced_emva_irradiance(&grid, rate_e_per_s)?;
    let clip_e = (sensor.voltage_swing_v() * sensor.analog_gain() - sensor.analog_offset_v())
        / sensor.conversion_gain_v_per_e();
    let t_sat = clip_e / rate_e_per_s;
    let n = req.levels;
    let exposures: Vec<f64> = (0..n)
        .map(|i| 1.3 * t_sat * i as f64 / (n - 1) as f64)
        .collect();
    progress("emva", 0, n as u64);
    let levels = sensor.emva_series(
        &grid,
        &irr,
        &exposures,
        req.frames_per_level,
        rows,
        cols,
        req.seed,
    )?;
    progress("emva", n as u64, n as u64);
    Ok(SimulatedSeries {
        levels,
        analog_offset_mv: offset_mv,
        offset_raised: raised,
        sensor_name: sensor.name().to_string(),
    })
}

impl SimulatedSeries {
    /// Write the frames (`levelNN_brightK.dng`, `levelNN_darkK.dng`) and `series.csv` into `out`.
    pub fn write_files(&self, out: &OutputDir) -> Result<()> {
        let meta = DngMetadata {
            camera_model: format!("camsim {}", self.sensor_name),
            ..DngMetadata::default()
        };
        let mut files = Vec::with_capacity(self.levels.len());
        for (i, l) in self.levels.iter().enumerate() {
            let names = |kind: &str, frames: &[RawImage]| -> Result<Vec<PathBuf>> {
                frames
                    .iter()
                    .enumerate()
                    .map(|(k, raw)| {
                        let name = format!("level{i:02}_{kind}{k}.dng");
                        camsim_io::dng::write_dng(&out.join(&name), raw, &meta)?;
                        Ok(PathBuf::from(name))
                    })
                    .collect()
            };
            files.push(EmvaLevelFiles {
                line: i + 2,
                exposure_s: l.exposure_s,
                photons_per_pixel: Some(l.photons_per_pixel),
                exposure_lux_s: Some(l.exposure_lux_s),
                bright: names("bright", &l.bright)?,
                dark: names("dark", &l.dark)?,
            });
        }
        write_emva_series(&out.join("series.csv"), &files)?;
        Ok(())
    }
}
