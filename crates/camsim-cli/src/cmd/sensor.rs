//! `camsim sensor`: sensor-plane irradiance EXR -> raw DNG frames; or an EMVA 1288 series.

use crate::common::{self, say};
use anyhow::Result;
use camsim_core::WavelengthGrid;
use camsim_io::dng::DngMetadata;
use camsim_isp::ColorPipeline;
use camsim_sensor::{Capture, Exposure, NoiseSwitches, Sensor};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Turn irradiance into raw digital values with the ISETCam sensor model: pixel area
/// integration, QE x colour filter x IR cut, photon shot noise, dark current, DSNU and PRNU
/// (a fixed pattern that belongs to the sensor), read noise, analog gain and offset, clipping at
/// the voltage swing and quantization. Writes raw.dng (the exact ADC values; raw_0001.dng ...
/// for more frames) and raw.png (the mosaic scaled to the full 16-bit range for viewing:
/// value = round(DN x 65535 / (2^bits - 1))). --rows/--cols larger than the sensor are refused.
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
    after_help = "Examples:\n  camsim sensor --in out/irradiance.exr --sensor pixel4a --out out/raw\n  camsim sensor --in out/irradiance.exr --sensor my-sensor.toml --exposure-ms 20 --frames 16 --out out/stack\n  camsim sensor --in out/irradiance.exr --sensor pixel4a-raw10 --iso 110 --exposures-ms 5,10,20 --out out/bracket\n  camsim sensor --emva-series --sensor imx363 --out out/emva && camsim analyze emva out/emva/series.csv\n  camsim sensor --in out/irradiance.exr --sensor pixel4a --cfa RGBW --rows 480 --cols 640 --out out/raw-rgbw\n  camsim sensor --in out/irradiance.exr --sensor pixel4a --cfa quad-bayer --rows 480 --cols 640 --out out/raw-quad\n  camsim sensor --in out/irradiance.exr --sensor examples/sensor-dcg.toml --out out/raw-dcg\n  camsim sensor --in out/irradiance.exr --sensor examples/sensor-split-pixel.toml --exposure-ms 20 --out out/raw-split"
)]
pub struct Args {
    /// Spectral irradiance EXR (from `camsim optics`).
    #[arg(long = "in", required_unless_present = "emva_series")]
    pub input: Option<PathBuf>,
    /// Sensor: a preset (pixel4a, pixel4a-raw10, imx363, ideal) or a sensor TOML file.
    #[arg(long, default_value = "pixel4a")]
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
    /// Colour filter array instead of the sensor's: a Bayer name (RGGB, GRBG, GBRG, BGGR), RGBW
    /// (R G / W B, W = the pixel without colour filter) or quad-bayer (4x4, each Bayer colour on
    /// 2x2 pixels). Other tiles: `cfa_pattern` in the sensor TOML.
    #[arg(long)]
    pub cfa: Option<String>,
    /// Output folder (created; an earlier camsim run in it is replaced as a whole when this
    /// run completes; any other existing content is refused).
    #[arg(long, default_value = "out/sensor")]
    pub out: PathBuf,
}

pub fn run(a: Args) -> Result<()> {
    let mut sensor = camsim_pipeline::load_sensor(&a.sensor)?;
    if (a.rows.is_some() || a.cols.is_some()) && !a.emva_series {
        sensor = sensor.window(
            a.rows.unwrap_or(sensor.rows()),
            a.cols.unwrap_or(sensor.cols()),
        )?;
    }
    if let Some(iso) = a.iso {
        let mut c = sensor.config().clone();
        c.iso = Some(iso);
        c.analog_gain = 1.0;
        sensor = Sensor::from_config_named(c, &format!("{} with --iso {iso}", a.sensor))?;
    }
    if let Some(cfa) = &a.cfa {
        let mut c = sensor.config().clone();
        c.cfa = cfa.clone();
        c.cfa_pattern = None;
        sensor = Sensor::from_config_named(c, &format!("{} with --cfa", a.sensor))?;
    }
    if a.no_noise {
        sensor = sensor.with_noise(NoiseSwitches::none());
    }
    if a.frames == 0 {
        anyhow::bail!("--frames must be at least 1");
    }
    let inputs: Vec<&std::path::Path> = a.input.iter().map(|p| p.as_path()).collect();
    let out = common::stage_out_dir_reading(&a.out, &inputs)?;
    if a.emva_series {
        emva_series(&sensor, &a, out.path())?;
        return common::commit(out);
    }
    let input = a
        .input
        .as_ref()
        .expect("clap requires --in without --emva-series");
    if sensor.hdr_model().is_some() && a.exposures_ms.is_some() {
        anyhow::bail!(
            "--exposures-ms: an [hdr] sensor ({}) takes one exposure (--exposure-ms)",
            a.sensor
        );
    }
    let irr = common::read_spectral_exr(input)?;
    let exposure = match a.exposure_ms {
        Some(ms) if !camsim_sensor::exposure_in_range(ms * 1e-3) => {
            anyhow::bail!(
                "--exposure-ms {ms}: must be in [0, {}] ms (at most an hour)",
                camsim_sensor::MAX_EXPOSURE_S * 1e3
            )
        }
        Some(ms) => Exposure::Seconds(ms * 1e-3),
        None => Exposure::default(),
    };
    if sensor.hdr_model().is_some() {
        return hdr_capture(
            &sensor,
            &irr,
            Capture {
                exposure,
                frames: a.frames,
                seed: a.seed,
            },
            &a,
            out,
        );
    }
    let pb = common::spinner("sensor");
    let frame = match &a.exposures_ms {
        None => sensor.compute(
            &irr,
            &Capture {
                exposure,
                frames: a.frames,
                seed: a.seed,
            },
        )?,
        Some(list) => {
            let times_s: Vec<f64> = list.iter().map(|ms| ms * 1e-3).collect();
            sensor.compute_bracket(&irr, &times_s, a.frames, a.seed)?
        }
    };
    pb.finish_and_clear();
    let illum = camsim_core::tables::illuminant("D65")?;
    let color = ColorPipeline::fit(&sensor.channel_qe(&irr.grid), &irr.grid, &illum)?;
    let meta = camsim_pipeline::dng_metadata(&sensor, &color, None)?;
    for (i, raw) in frame.raw.iter().enumerate() {
        let name = if i == 0 {
            "raw.dng".to_string()
        } else {
            format!("raw_{i:04}.dng")
        };
        camsim_io::dng::write_dng(&out.join(name), raw, &meta)?;
    }
    let r0 = &frame.raw[0];
    camsim_io::raster::write_png16_mosaic_scaled(
        &out.join("raw.png"),
        r0.rows,
        r0.cols,
        &r0.dn,
        r0.bits,
    )?;
    common::commit(out)?;
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
    Ok(())
}

/// An `[hdr]` sensor: high.dng, low.dng and merged.exr per frame (see the command's help).
fn hdr_capture(
    sensor: &Sensor,
    irr: &camsim_core::SpectralImage,
    capture: Capture,
    a: &Args,
    out: camsim_io::atomic::OutputDir,
) -> Result<()> {
    let pb = common::spinner("sensor (HDR)");
    let f = sensor.compute_hdr(irr, &capture)?;
    pb.finish_and_clear();
    let illum = camsim_core::tables::illuminant("D65")?;
    let color = ColorPipeline::fit(&sensor.channel_qe(&irr.grid), &irr.grid, &illum)?;
    let meta = camsim_pipeline::dng_metadata(sensor, &color, None)?;
    for (i, ((hi, lo), merged)) in f.high.iter().zip(&f.low).zip(&f.merged_e).enumerate() {
        let suffix = if i == 0 {
            String::new()
        } else {
            format!("_{i:04}")
        };
        camsim_io::dng::write_dng(&out.join(format!("high{suffix}.dng")), hi, &meta)?;
        camsim_io::dng::write_dng(&out.join(format!("low{suffix}.dng")), lo, &meta)?;
        camsim_io::exr::write_gray_exr(
            &out.join(format!("merged{suffix}.exr")),
            hi.rows,
            hi.cols,
            "Y",
            merged,
        )?;
    }
    common::commit(out)?;
    let m = f.model;
    let peak = f.merged_e[0].iter().fold(0.0f32, |a, b| a.max(*b));
    say(format!(
        "{} HDR frame(s) ({}), exposure {:.3} ms, merged peak {peak:.0} e-, switch at {:.0} e-, dynamic range {:.1} dB -> {}",
        f.high.len(),
        match m.mode {
            camsim_sensor::HdrMode::Dcg => "dual conversion gain",
            camsim_sensor::HdrMode::SplitPixel => "split pixel",
        },
        f.exposure_s * 1e3,
        m.switch_e,
        m.dynamic_range_db(),
        a.out.display()
    ));
    Ok(())
}

fn emva_series(sensor: &Sensor, a: &Args, out: &Path) -> Result<()> {
    let grid = WavelengthGrid::default();
    // EMVA 1288 needs dark frames above 0 DN: give the sensor a black level if it has none.
    let mut cfg = sensor.config().clone();
    let read_mv = sensor.read_noise_v() * 1e3;
    let offset_mv = match a.analog_offset_mv {
        Some(mv) => mv,
        None if sensor.analog_offset_v() * 1e3 < 5.0 * read_mv => {
            let mv = (8.0 * read_mv).max(1.0);
            say(format!("EMVA 1288 needs unclipped dark frames: analog offset set to {mv:.1} mV (--analog-offset-mv to choose)"));
            mv
        }
        None => sensor.analog_offset_v() * 1e3,
    };
    cfg.analog_offset_mv = offset_mv;
    let sensor = Sensor::from_config_named(cfg, "--emva-series sensor")?;
    // A window larger than the sensor is refused by emva_series (never clamped).
    let rows = a.rows.unwrap_or(128.min(sensor.rows()));
    let cols = a.cols.unwrap_or(128.min(sensor.cols()));
    if a.levels < 3 {
        anyhow::bail!("--levels {}: an EMVA 1288 series needs at least 3 exposure levels (dark to past saturation)", a.levels);
    }
    if a.frames_per_level < 2 {
        anyhow::bail!("--frames-per-level {}: EMVA 1288 needs at least 2 frames per level (temporal noise is their difference)", a.frames_per_level);
    }
    if rows == 0 || cols == 0 || rows > sensor.rows() || cols > sensor.cols() {
        anyhow::bail!(
            "--rows {rows} --cols {cols}: the EMVA window {rows} x {cols} must be at least 1 x 1 and fit the {} x {} sensor",
            sensor.rows(),
            sensor.cols()
        );
    }
    // Every frame is a DNG of 2 bytes a pixel (and a header): refuse a series the disk cannot
    // hold. The user's --out is named (the staging folder beside it is on the same disk).
    let frames = (a.levels as u64) * 2 * a.frames_per_level as u64;
    camsim_core::mem::check_disk(
        &a.out,
        frames.saturating_mul((rows as u64).saturating_mul(cols as u64) * 2 + 65536),
        &format!("the EMVA series ({frames} DNG files of {rows} x {cols})"),
    )?;
    // Three lines balanced so every channel collects 1e5 e-/s; exposures from 0 to 1.3 x the
    // time at which the signal reaches the clipping level.
    let rate_e_per_s = 1e5;
    let irr = sensor.balanced_emva_irradiance(&grid, rate_e_per_s)?;
    let clip_e = (sensor.voltage_swing_v() * sensor.analog_gain() - sensor.analog_offset_v())
        / sensor.conversion_gain_v_per_e();
    let t_sat = clip_e / rate_e_per_s;
    let n = a.levels;
    let exposures: Vec<f64> = (0..n)
        .map(|i| 1.3 * t_sat * i as f64 / (n - 1) as f64)
        .collect();
    let pb = common::progress(n as u64, "emva");
    let levels = sensor.emva_series(
        &grid,
        &irr,
        &exposures,
        a.frames_per_level,
        rows,
        cols,
        a.seed,
    )?;
    let f = a.frames_per_level;
    let mut csv = String::from("exposure_s,photons_per_pixel");
    for kind in ["bright", "dark"] {
        for k in 0..f {
            write!(csv, ",{kind}_{k}")?;
        }
    }
    csv.push('\n');
    let meta = DngMetadata {
        camera_model: format!("camsim {}", sensor.name()),
        ..DngMetadata::default()
    };
    for (i, l) in levels.iter().enumerate() {
        let mut names = Vec::new();
        for (kind, frames) in [("bright", &l.bright), ("dark", &l.dark)] {
            for (k, raw) in frames.iter().enumerate() {
                let name = format!("level{i:02}_{kind}{k}.dng");
                camsim_io::dng::write_dng(&out.join(&name), raw, &meta)?;
                names.push(name);
            }
        }
        writeln!(
            csv,
            "{},{},{}",
            l.exposure_s,
            l.photons_per_pixel,
            names.join(",")
        )?;
        pb.inc(1);
    }
    pb.finish_and_clear();
    camsim_io::atomic::write_bytes_atomic(&out.join("series.csv"), csv.as_bytes())?;
    say(format!("wrote an EMVA 1288 series of {n} levels ({rows} x {cols}) in {}; next: camsim analyze emva {}", a.out.display(), a.out.join("series.csv").display()));
    Ok(())
}
