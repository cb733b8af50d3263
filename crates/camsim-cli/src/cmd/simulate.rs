//! `camsim simulate`: the whole pipeline, scene -> optics -> sensor -> isp, in memory.

use crate::common::{self, say};
use camsim_pipeline::SimulateConfig;
use anyhow::Result;
use std::path::PathBuf;

/// Run the whole pipeline: scene (2D chart or 3D scene) -> optics -> sensor -> raw DNG and preview.
///
/// With no CONFIG it runs the built-in default: the Macbeth ColorChecker under D65 at
/// 100 cd/m^2, imaged by the pixel4a lens and a 480 x 640 window of the pixel4a (IMX363)
/// sensor, auto-exposed. Every config key is documented in README.md ("Config reference") and in
/// the files under examples/.
///
/// Writes in --out: radiance.exr (scene, W/(sr m^2 nm)), irradiance.exr (sensor plane,
/// W/(m^2 nm)), raw.dng (the exact ADC values; raw_0001.dng ... with --frames N), raw.png (the
/// mosaic scaled to the full 16-bit range for viewing: value = round(DN x 65535 / (2^bits - 1)),
/// recorded in run.json), preview.png (sRGB) and run.json (every parameter; `camsim simulate
/// out/run.json` repeats the run).
///
/// The folder always holds one complete run: the files are written into DIR.tmp-<pid> beside it
/// and swapped in at the end, replacing an earlier run as a whole; a failed or interrupted run
/// (Ctrl-C) leaves the earlier one untouched and no temporary behind.
#[derive(clap::Args)]
#[command(after_help = "Examples:\n  camsim simulate --out out/default\n  camsim simulate examples/slanted-edge.toml --out out/edge\n  camsim simulate examples/cornell-box.toml --out out/box --frames 8 --seed 3\n  camsim simulate out/default/run.json --out out/again     (repeat a run)")]
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
    #[arg(long)]
    pub exposure_ms: Option<f64>,
    /// Print the effective config (TOML) and exit.
    #[arg(long)]
    pub print_config: bool,
}

pub fn run(a: Args) -> Result<()> {
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
    }
    if a.print_config {
        println!("{}", toml::to_string_pretty(&cfg)?);
        return Ok(());
    }
    let staged = common::stage_out_dir(&a.out)?;
    let pb = common::progress(1, "simulate");
    let s = camsim_pipeline::run_simulation(&cfg, a.config.as_deref(), &staged, &|stage, done, total| {
        pb.set_message(stage.to_string());
        pb.set_length(total.max(1));
        pb.set_position(done);
    })?;
    pb.finish_and_clear();
    common::commit(staged)?;
    let out = &a.out;
    say(format!(
        "exposure {:.3} ms, mean DN r/g/b = {:.1} / {:.1} / {:.1}; {} frame(s) in {:.2} s -> {}",
        s.exposure_s * 1e3,
        s.mean_dn_rgb[0],
        s.mean_dn_rgb[1],
        s.mean_dn_rgb[2],
        s.frames,
        s.total_s,
        out.display()
    ));
    Ok(())
}
