//! `camsim isp`: raw DNG -> bilinear demosaic -> sRGB preview PNG.

use crate::common::say;
use anyhow::Result;
use camsim_core::WavelengthGrid;
use camsim_isp::ColorPipeline;
use std::path::PathBuf;

/// Demosaic a raw DNG bilinearly (the paper's method) and render an sRGB preview: white balance
/// and a 3x3 sensor -> XYZ matrix fitted by least squares on the ColorChecker under the scene
/// illuminant, XYZ -> linear sRGB -> sRGB gamma.
#[derive(clap::Args)]
#[command(after_help = "Example:\n  camsim isp --in out/raw/raw.dng --sensor pixel4a --illuminant D65 --out out/preview.png")]
pub struct Args {
    /// Raw DNG.
    #[arg(long = "in")]
    pub input: PathBuf,
    /// The sensor that made it (its QE sets the colour matrix): preset or TOML file.
    #[arg(long, default_value = "pixel4a")]
    pub sensor: String,
    /// Scene illuminant for white balance and the colour fit: built-in name or spectrum file.
    #[arg(long, default_value = "D65")]
    pub illuminant: String,
    /// Output PNG.
    #[arg(long, default_value = "out/preview.png")]
    pub out: PathBuf,
}

pub fn run(a: Args) -> Result<()> {
    let (raw, _info) = camsim_io::dng::read_dng(&a.input)?;
    let sensor = camsim_pipeline::load_sensor(&a.sensor)?;
    let grid = WavelengthGrid::default();
    let illum = camsim_scene::load_illuminant(&a.illuminant, "--illuminant")?;
    let color = ColorPipeline::fit(&sensor.channel_qe(&grid), &grid, &illum)?;
    let rgb = camsim_isp::demosaic_bilinear(&raw);
    let srgb = color.render_srgb8_clipped(&rgb, None, Some(raw.white_level_dn - raw.black_level_dn));
    crate::common::parent_dir(&a.out)?;
    camsim_io::raster::write_png8_rgb(&a.out, rgb.rows, rgb.cols, &srgb)?;
    say(format!("wrote {} ({} x {})", a.out.display(), rgb.cols, rgb.rows));
    Ok(())
}
