//! `camsim analyze demosaic`: every demosaicking method on a gray zone plate (MTF, MTF50, false
//! colour), camsim_isp::demosaic_quality.

use crate::cmd::args::parse_cfa;
use crate::common::{self, say};
use anyhow::Result;
use camsim::core::CfaPattern;
use camsim::pipeline::measure::demosaic::{demosaic_zone_plate, ZonePlateRequest};
use std::path::PathBuf;

/// Demosaic a gray zone plate (a circular chirp whose local frequency rises linearly from 0 at
/// the centre to --f-max cycles/pixel at the edge) sampled by a Bayer mosaic, with every method,
/// and measure the luminance MTF per annulus (in-phase amplitude / true amplitude), MTF50 and the
/// RMS false colour (chroma error / amplitude, below 0.25 cycles/pixel and overall). Writes
/// demosaic_mtf.csv (one column per method) and demosaic.json in --out, and prints a summary.
#[derive(clap::Args)]
#[command(
    after_help = "Examples:\n  camsim analyze demosaic --out out/demosaic\n  camsim analyze demosaic --size 256 --cfa GRBG --out out/demosaic-grbg"
)]
pub struct Args {
    /// Zone plate side, pixels (at least 32).
    #[arg(long, default_value_t = 512)]
    pub size: usize,
    /// Local frequency at the edge's midpoints, cycles per pixel (0 < f <= 0.5).
    #[arg(long, default_value_t = 0.5, value_parser = parse_f_max)]
    pub f_max: f64,
    /// Bayer pattern.
    #[arg(long, default_value = "RGGB", value_parser = parse_cfa)]
    pub cfa: CfaPattern,
    /// Output folder (created if missing).
    #[arg(long, default_value = "out/demosaic")]
    pub out: PathBuf,
}

fn parse_f_max(s: &str) -> std::result::Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v > 0.0 && v <= 0.5 => Ok(v),
        _ => Err(format!("'{s}': give a frequency in (0, 0.5] cycles/pixel")),
    }
}

pub fn run(a: Args) -> Result<()> {
    let report = demosaic_zone_plate(&ZonePlateRequest {
        size_px: a.size,
        f_max_cyc_per_px: a.f_max,
        cfa: a.cfa,
    })
    .map_err(|e| anyhow::anyhow!("--{e}"))?;
    let staged = common::stage_out_dir(&a.out)?;
    report.write_files(&staged)?;
    common::commit(staged)?;
    for (m, q) in &report.methods {
        say(format!(
            "{:>18}: MTF50 {} cycles/pixel, false colour RMS {:.4} below 0.25 cycles/pixel, {:.4} overall",
            m.name(),
            q.mtf50_cy_per_px.map(|v| format!("{v:.3}")).unwrap_or_else(|| format!("> {:.2}", a.f_max)),
            q.false_colour_low_rms,
            q.false_colour_rms
        ));
    }
    say(format!("wrote {}", a.out.display()));
    Ok(())
}
