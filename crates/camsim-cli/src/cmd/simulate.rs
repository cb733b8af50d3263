//! `camsim simulate`: the whole pipeline, scene -> optics -> sensor -> isp, in memory.

use crate::common::{self, say};
use anyhow::Result;
use camsim::io::exr::{ExrCompression, ExrPrecision, EXR_COMPRESSIONS, EXR_PRECISIONS};
use camsim::{ExrOptions, Output, OutputSet, RunInfo, SimulateConfig, SimulateOptions};
use std::path::PathBuf;

/// Run the whole pipeline: scene (2D chart or 3D scene) -> optics -> sensor -> raw DNG and preview.
///
/// With no CONFIG it runs the built-in default: the Macbeth ColorChecker under D65 at
/// 100 cd/m^2, imaged by the pixel4a lens and a 480 x 640 window of the pixel4a (IMX363)
/// sensor, auto-exposed. Every config key is documented in README.md ("Config reference") and in
/// the files under examples/.
///
/// Writes in --out the outputs --save names (default: raw,preview; the list is below) and
/// run.json (every parameter; `camsim simulate out/run.json` repeats the run). Spectral EXRs cost
/// most of a large run's time: ask for them only when needed, and choose --exr-compression none
/// (fastest) or zip (smallest) and --exr-precision f32 or f16.
///
/// The folder always holds one complete run: the files are written into DIR.camsim-tmp-<pid> beside it
/// and swapped in at the end, replacing an earlier run as a whole; a failed or interrupted run
/// (Ctrl-C) leaves the earlier one untouched and no temporary behind.
#[derive(clap::Args)]
#[command(
    after_help = after_help()
)]
pub struct Args {
    /// Pipeline config (TOML), or a run.json written by an earlier run. Default: built-in.
    pub config: Option<PathBuf>,
    /// Output folder (created; an earlier camsim run in it is replaced as a whole when this
    /// run completes; any other existing content is refused).
    #[arg(long, default_value = "out/simulate")]
    pub out: PathBuf,
    /// Number of raw frames of the same exposure (new temporal noise, same fixed pattern).
    #[arg(long)]
    pub frames: Option<usize>,
    /// Seed of the temporal noise and of the renderer.
    #[arg(long)]
    pub seed: Option<u64>,
    /// Exposure time in ms (default: auto-exposure).
    #[arg(long, conflicts_with = "exposures_ms")]
    pub exposure_ms: Option<f64>,
    /// Exposure bracket / burst: comma-separated exposure times, ms (e.g. 5,10,20); one raw per
    /// time (x --frames), raw.dng, raw_0001.dng, ... in this order, each with its own noise.
    #[arg(long, value_delimiter = ',', value_name = "MS,MS,...")]
    pub exposures_ms: Option<Vec<f64>>,
    #[arg(long, default_value = "default", value_name = "LIST", help = format!("Outputs to write, comma-separated: {}; or all; or default (raw,preview). run.json is always written", camsim::pipeline::outputs::OUTPUTS.known()))]
    pub save: String,
    /// Sample precision of the spectral EXRs: f32 (exact) or f16 (half the size).
    #[arg(long, default_value = "f32", value_parser = |s: &str| EXR_PRECISIONS.get(s).map_err(|e| e.to_string()))]
    pub exr_precision: ExrPrecision,
    /// Compression of the spectral EXRs: none (default: fastest), rle, zip (smallest, slow), zips, piz.
    #[arg(long, default_value = "none", value_parser = |s: &str| EXR_COMPRESSIONS.get(s).map_err(|e| e.to_string()))]
    pub exr_compression: ExrCompression,
    /// Print the effective config (TOML) and exit.
    #[arg(long)]
    pub print_config: bool,
}

/// The outputs (from their name table) and the examples.
fn after_help() -> String {
    format!(
        "Outputs (--save, comma-separated; or all, default):\n{}\nExamples:\n  camsim simulate --out out/default\n  camsim simulate --save all --out out/everything\n  camsim simulate examples/slanted-edge.toml --out out/edge-irr --save raw,preview,irradiance\n  camsim simulate examples/cornell-box.toml --out out/box --frames 4 --seed 3\n  camsim simulate out/default/run.json --out out/again     (repeat a run)",
        camsim::pipeline::outputs::OUTPUTS.listing()
    )
}

pub fn run(a: Args) -> Result<()> {
    let t0 = std::time::Instant::now();
    let exr = ExrOptions {
        precision: a.exr_precision,
        compression: a.exr_compression,
    };
    let mut cfg = match &a.config {
        None => SimulateConfig::builtin_default(),
        Some(p) => SimulateConfig::load(p)?,
    };
    if let Some(f) = a.frames {
        cfg.capture.frames = f;
    }
    if let Some(s) = a.seed {
        cfg.seed = s;
    }
    if let Some(e) = a.exposure_ms {
        cfg.capture.exposure_ms = Some(e);
        cfg.capture.exposures_ms = None;
    }
    if let Some(list) = a.exposures_ms {
        cfg.capture.exposures_ms = Some(list);
        cfg.capture.exposure_ms = None;
    }
    if a.print_config {
        println!("{}", toml::to_string_pretty(&cfg)?);
        return Ok(());
    }
    let outputs = OutputSet::parse(&a.save)?;
    OutputSet::check_applies(&a.save, cfg.scene.is_some())?;
    let staged = common::stage_out_dir(&a.out)?;
    let pb = common::progress(1, "simulate");
    let opts = SimulateOptions {
        noise_free: outputs.contains(Output::NoiseFree),
        labels: outputs.label_request(),
        flow: outputs.contains(Output::Flow),
    };
    let sim = camsim::simulate(&cfg, &opts, &|stage, done, total| {
        pb.set_message(stage.to_string());
        pb.set_length(total.max(1));
        pb.set_position(done);
    })?;
    pb.set_message("writing files");
    let info = RunInfo {
        command: Some(std::env::args().collect::<Vec<_>>().join(" ")),
        config_file: a.config.clone(),
    };
    sim.write_into(&staged, &outputs, exr, &info)?;
    pb.finish_and_clear();
    common::commit(staged)?;
    let out = &a.out;
    if let (Some(note), true) = (&sim.preview_note, outputs.contains(Output::Preview)) {
        say(format!("warning: preview.png is {note}"));
    }
    say(format!(
        "exposure {:.3} ms, mean DN r/g/b = {:.1} / {:.1} / {:.1}; {} frame(s) in {:.2} s ({:.2} s with files) -> {} ({})",
        sim.exposure_s * 1e3,
        sim.mean_dn_rgb[0],
        sim.mean_dn_rgb[1],
        sim.mean_dn_rgb[2],
        sim.frames.len(),
        sim.times_s.get("total_s").and_then(|v| v.as_f64()).unwrap_or(0.0),
        t0.elapsed().as_secs_f64(),
        out.display(),
        outputs.names()
    ));
    if let Some(r) = sim.render_samples.as_ref().filter(|r| r.adaptive.is_some()) {
        say(format!(
            "adaptive render: {:.0} samples per pixel on average ({}..{} of {}){}",
            r.mean_per_pixel,
            r.min_per_pixel,
            r.max_per_pixel,
            r.requested_per_pixel,
            if r.at_most_share > 0.01 {
                format!(
                    "; {:.0} % of the pixels took all {} and are still noisier than the target: raise samples_per_pixel",
                    100.0 * r.at_most_share,
                    r.requested_per_pixel
                )
            } else {
                String::new()
            }
        ));
    }
    if let Some(h) = &sim.hdr {
        let m = &h.model;
        say(format!(
            "[hdr] sensor: raw.dng is the high readout, raw_low.dng the low one, merged.exr the merge (switch at {:.0} e-, up to {:.0} e-, dynamic range {:.1} dB)",
            m.switch_e,
            m.max_merged_e(),
            m.dynamic_range_db()
        ));
    }
    Ok(())
}
