//! `camsim analyze demosaic`: every demosaicking method on a gray zone plate (MTF, MTF50, false
//! colour), camsim_isp::demosaic_quality.

use crate::common::{self, say};
use anyhow::{bail, Result};
use camsim_core::CfaPattern;
use camsim_isp::demosaic_quality::{zone_plate_quality, ZonePlate};
use camsim_isp::DemosaicMethod;
use std::fmt::Write as _;
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

fn parse_cfa(s: &str) -> std::result::Result<CfaPattern, String> {
    CfaPattern::parse(s).map_err(|e| e.to_string())
}

pub fn run(a: Args) -> Result<()> {
    if a.size < 32 || a.size > 8192 {
        bail!("--size {}: give 32 to 8192 pixels", a.size);
    }
    let zp = ZonePlate::new(a.size, a.f_max);
    let raw = zp.mosaic(a.cfa);
    let df = 0.01f64.min(a.f_max / 10.0);
    let mut results = Vec::new();
    for m in DemosaicMethod::ALL {
        let rgb = camsim_isp::demosaic(&raw, m)?;
        results.push((m, zone_plate_quality(&zp, &rgb, df)));
    }
    let staged = common::stage_out_dir(&a.out)?;
    let mut csv = String::from("freq_cyc_per_px");
    for (m, _) in &results {
        write!(csv, ",mtf_{}", m.name().replace('-', "_"))?;
    }
    csv.push('\n');
    for (i, f) in results[0].1.frequency_cy_per_px.iter().enumerate() {
        write!(csv, "{f:.4}")?;
        for (_, q) in &results {
            write!(csv, ",{:.5}", q.mtf.get(i).copied().unwrap_or(f64::NAN))?;
        }
        csv.push('\n');
    }
    std::fs::write(staged.join("demosaic_mtf.csv"), csv)?;
    let json: Vec<serde_json::Value> = results
        .iter()
        .map(|(m, q)| {
            serde_json::json!({
                "method": m.name(),
                "mtf50_cyc_per_px": q.mtf50_cy_per_px,
                "false_colour_rms_below_0_25": q.false_colour_low_rms,
                "false_colour_rms": q.false_colour_rms,
            })
        })
        .collect();
    let doc = serde_json::json!({ "size_px": a.size, "f_max_cyc_per_px": a.f_max, "cfa": a.cfa.name(), "methods": json });
    std::fs::write(
        staged.join("demosaic.json"),
        serde_json::to_string_pretty(&doc)?,
    )?;
    common::commit(staged)?;
    for (m, q) in &results {
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
