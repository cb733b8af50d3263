//! `camsim sensor`: sensor-plane irradiance EXR -> raw DNG frames; or an EMVA 1288 series. The
//! capture, its files and the series are the application layer's
//! (`camsim::pipeline::{capture, measure::emva}`).

use crate::common::{self, say};
use anyhow::Result;
use camsim::pipeline::capture::{capture, CaptureRequest, Captured, CLI_KEYS};
use camsim::pipeline::measure::emva::{simulate_series, SeriesError, SeriesField, SeriesRequest};
use camsim::sensor::NoiseSwitches;
use camsim::{Isp, SensorOverrides};
use std::path::PathBuf;

/// Turn irradiance into raw digital values with the ISETCam sensor model: pixel area
/// integration, QE x colour filter x IR cut, photon shot noise, dark current, DSNU and PRNU
/// (a fixed pattern that belongs to the sensor), read noise, analog gain and offset, clipping at
/// the voltage swing and quantization. Writes raw.dng (the exact ADC values; raw_0001.dng ...
/// for more frames) and raw.png (the mosaic scaled to the full 16-bit range for viewing:
/// value = round(DN x 65535 / (2^bits - 1))). --rows/--cols larger than the sensor are refused.
/// Without --rows/--cols the whole sensor is read out (the pixel4a: 4032 x 3024): a small chart
/// then covers a few percent of the frame, so give a window the size of the scene's image
/// (its size in pixels: the irradiance size printed by `camsim optics` x its sample spacing /
/// the pixel pitch; 480 x 640 for examples/macbeth-d65.toml) for a picture the chart fills.
///
/// The output folder always holds one complete run (written beside it, swapped in at the end; an
/// earlier run is replaced as a whole, a failed or interrupted one leaves it untouched).
///
/// An HDR sensor (`[hdr]` in its TOML: dual conversion gain or split pixel) writes each readout
/// as its own DNG (high.dng: HCG / large photodiode, low.dng: LCG / small photodiode;
/// high_0001.dng ... for more frames) and the merged linear frame as merged.exr (one channel Y,
/// f32, in electrons of the HCG / large photodiode, black level removed).
///
/// With --emva-series it instead simulates an EMVA 1288 photon-transfer series (flat fields at
/// increasing exposure plus dark frames, two of each) so `camsim analyze emva` can characterize
/// the sensor model exactly as it characterizes a real camera.
#[derive(clap::Args)]
#[command(
    after_help = "Examples:\n  camsim sensor --in out/irradiance.exr --sensor pixel4a --rows 480 --cols 640 --out out/raw\n  camsim sensor --in out/irradiance.exr --sensor my-sensor.toml --exposure-ms 20 --frames 16 --out out/stack\n  camsim sensor --in out/irradiance.exr --sensor pixel4a-raw10 --iso 110 --exposures-ms 5,10,20 --out out/bracket\n  camsim sensor --emva-series --sensor imx363 --out out/emva && camsim analyze emva out/emva/series.csv\n  camsim sensor --in out/irradiance.exr --sensor pixel4a --cfa RGBW --rows 480 --cols 640 --out out/raw-rgbw\n  camsim sensor --in out/irradiance.exr --sensor pixel4a --cfa quad-bayer --rows 480 --cols 640 --out out/raw-quad\n  camsim sensor --in out/irradiance.exr --sensor examples/sensor-dcg.toml --out out/raw-dcg\n  camsim sensor --in out/irradiance.exr --sensor examples/sensor-split-pixel.toml --exposure-ms 20 --out out/raw-split"
)]
pub struct Args {
    /// Spectral irradiance EXR (from `camsim optics`).
    #[arg(long = "in", required_unless_present = "emva_series")]
    pub input: Option<PathBuf>,
    #[arg(long, default_value = "pixel4a", help = format!("Sensor: a preset ({}) or a sensor TOML file", camsim::sensor::presets::SENSOR_PRESETS.known()))]
    pub sensor: String,
    /// Window rows centred on the optical axis (default: the full sensor; at most the sensor's rows).
    #[arg(long)]
    pub rows: Option<usize>,
    /// Window columns (at most the sensor's columns).
    #[arg(long)]
    pub cols: Option<usize>,
    /// Exposure time, ms (default: auto-exposure, the brightest colour filter's 99th percentile at
    /// 90 % of the swing).
    #[arg(long, conflicts_with = "exposures_ms")]
    pub exposure_ms: Option<f64>,
    /// Exposure bracket / burst: comma-separated exposure times, ms (e.g. 5,10,20); one raw per
    /// time (x --frames), raw.dng, raw_0001.dng, ... in this order, each with its own noise.
    #[arg(long, value_delimiter = ',', value_name = "MS,MS,...")]
    pub exposures_ms: Option<Vec<f64>>,
    /// Sensitivity as ISO (analog gain = base_iso / iso, ISETCam's divisor); the sensor needs a
    /// base_iso (the presets have 55).
    #[arg(long, value_parser = crate::common::finite_f64)]
    pub iso: Option<f64>,
    /// Frames of the same exposure (with --exposures-ms: frames per exposure).
    #[arg(long, default_value_t = 1)]
    pub frames: usize,
    /// Temporal noise seed.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Switch every noise source off (mean signal only).
    #[arg(long)]
    pub no_noise: bool,
    /// Simulate an EMVA 1288 series instead (flat field, dark frames).
    #[arg(long)]
    pub emva_series: bool,
    /// EMVA series: exposure levels from dark to past saturation.
    #[arg(long, default_value_t = 24)]
    pub levels: usize,
    /// EMVA series: frames per level (bright and dark each; more frames, smaller errors).
    #[arg(long, default_value_t = 8)]
    pub frames_per_level: usize,
    /// EMVA series: analog offset, mV. EMVA 1288 needs dark frames that do not clip at 0; by
    /// default a sensor whose offset is below 5 x its read noise gets 8 x its read noise.
    #[arg(long, value_parser = crate::common::finite_f64)]
    pub analog_offset_mv: Option<f64>,
    #[arg(long, help = format!("Colour filter array instead of the sensor's, one of {}: a Bayer phase, RGBW (R G / W B, W = the pixel without colour filter) or quad-bayer (4x4, each Bayer colour on 2x2 pixels). Other tiles: `cfa_pattern` in the sensor TOML", camsim::core::cfa::CFA_NAMES.known()))]
    pub cfa: Option<String>,
    /// Scene illuminant of the DNGs' colour matrix and neutral (ColorMatrix1, AsShotNeutral: the
    /// ISP's QE fit under it, as `camsim simulate` fits it under its scene's): a built-in name or
    /// a spectrum file.
    #[arg(long, default_value = "D65")]
    pub illuminant: String,
    /// Output folder (created; an earlier camsim run in it is replaced as a whole when this
    /// run completes; any other existing content is refused).
    #[arg(long, default_value = "out/sensor")]
    pub out: PathBuf,
}

/// The flag of each EMVA series field (the pipeline names them neutrally).
fn series_flag(f: SeriesField) -> &'static str {
    match f {
        SeriesField::Levels => "--levels",
        SeriesField::FramesPerLevel => "--frames-per-level",
        SeriesField::Rows => "--rows",
        SeriesField::Cols => "--cols",
    }
}

/// A refused EMVA series request, naming the flags the user gave.
fn series_error(e: SeriesError) -> anyhow::Error {
    anyhow::anyhow!(e.spelled(series_flag, " "))
}

pub fn run(a: Args) -> Result<()> {
    let base = camsim::pipeline::load_sensor(&a.sensor)?;
    let overrides = SensorOverrides {
        // The EMVA series takes its own frame size (--rows, --cols).
        rows: a.rows.filter(|_| !a.emva_series),
        cols: a.cols.filter(|_| !a.emva_series),
        iso: a.iso,
        cfa: a.cfa.clone(),
        noise: a.no_noise.then(NoiseSwitches::none),
    };
    let sensor = overrides.apply(base, &a.sensor)?;
    if a.frames == 0 {
        anyhow::bail!("--frames must be at least 1");
    }
    let inputs: Vec<&std::path::Path> = a.input.iter().map(|p| p.as_path()).collect();
    let out = common::stage_out_dir_reading(&a.out, &inputs)?;
    if a.emva_series {
        let req = SeriesRequest {
            levels: a.levels,
            frames_per_level: a.frames_per_level,
            rows: a.rows.unwrap_or(128.min(sensor.rows())),
            cols: a.cols.unwrap_or(128.min(sensor.cols())),
            analog_offset_mv: a.analog_offset_mv,
            seed: a.seed,
        };
        req.validate(&sensor).map_err(series_error)?;
        // The user's --out is named (the staging folder beside it is on the same disk).
        req.check_disk(&a.out)?;
        let pb = common::spinner("emva");
        let series = simulate_series(&sensor, &req, &|_, _, _| {}).map_err(|e| match e {
            camsim::Error::Series(e) => series_error(e),
            e => e.into(),
        })?;
        if series.offset_raised {
            say(format!("EMVA 1288 needs unclipped dark frames: analog offset set to {:.1} mV (--analog-offset-mv to choose)", series.analog_offset_mv));
        }
        series.write_files(&out)?;
        pb.finish_and_clear();
        common::commit(out)?;
        let l0 = &series.levels[0].bright[0];
        say(format!(
            "wrote an EMVA 1288 series of {} levels ({} x {}) in {}; next: camsim analyze emva {}",
            series.levels.len(),
            l0.rows,
            l0.cols,
            a.out.display(),
            a.out.join("series.csv").display()
        ));
        return Ok(());
    }
    let input = a
        .input
        .as_ref()
        .expect("clap requires --in without --emva-series");
    let request = CaptureRequest::new(
        a.exposure_ms,
        a.exposures_ms.as_deref(),
        0.9,
        a.frames,
        a.seed,
        CLI_KEYS,
    )?;
    let irr = common::read_spectral_exr(input)?;
    let illuminant = camsim::scene::load_illuminant(&a.illuminant, "--illuminant")?;
    let meta = Isp::new(illuminant, irr.grid).dng_metadata(&sensor, None)?;
    let pb = common::spinner("sensor");
    let captured = capture(&sensor, &irr, &request)?;
    pb.finish_and_clear();
    captured.write_files(&out, &meta)?;
    common::commit(out)?;
    match &captured {
        Captured::Frames(frame) => {
            if !sensor.is_bayer() {
                let layout = sensor.cfa_layout();
                let per: Vec<String> = layout
                    .filters()
                    .iter()
                    .zip(&frame.mean_electrons_by_filter)
                    .map(|(f, e)| format!("{f} {e:.0}"))
                    .collect();
                say(format!(
                    "CFA {}: mean electrons {}",
                    layout.name(),
                    per.join(", ")
                ));
            }
            say(format!(
                "{} frame(s), exposure {:.3} ms, mean electrons r/g/b {:.0}/{:.0}/{:.0} -> {}",
                frame.raw.len(),
                frame.exposure_s * 1e3,
                frame.mean_electrons[0],
                frame.mean_electrons[1],
                frame.mean_electrons[2],
                a.out.display()
            ));
        }
        Captured::Hdr(f) => {
            let m = f.model;
            let peak = f.merged_e[0].iter().fold(0.0f32, |a, b| a.max(*b));
            say(format!(
                "{} HDR frame(s) ({}), exposure {:.3} ms, merged peak {peak:.0} e-, switch at {:.0} e-, dynamic range {:.1} dB -> {}",
                f.high.len(),
                match m.mode {
                    camsim::sensor::HdrMode::Dcg => "dual conversion gain",
                    camsim::sensor::HdrMode::SplitPixel => "split pixel",
                },
                f.exposure_s * 1e3,
                m.switch_e,
                m.dynamic_range_db(),
                a.out.display()
            ));
        }
    }
    Ok(())
}
