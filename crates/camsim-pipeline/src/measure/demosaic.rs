//! Demosaicking quality: every method of `camsim_isp::DEMOSAIC_METHODS` on a gray zone plate (a
//! circular chirp whose local frequency rises linearly from 0 at the centre to `f_max` cycles per
//! pixel at the edge's midpoints) sampled by a Bayer mosaic: the luminance MTF per annulus (in-phase
//! amplitude / true amplitude), MTF50 and the RMS false colour (`camsim_isp::demosaic_quality`).

use super::write_text;
use crate::{PipelineError, Result};
use camsim_core::CfaPattern;
use camsim_io::atomic::OutputDir;
use camsim_isp::demosaic_quality::{zone_plate_quality, ZonePlate, ZonePlateQuality};
use camsim_isp::DemosaicMethod;
use std::fmt::Write as _;

/// The zone plate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ZonePlateRequest {
    /// Side, pixels (32 to 8192).
    pub size_px: usize,
    /// Local frequency at the edge's midpoints, cycles per pixel (0 < f <= 0.5).
    pub f_max_cyc_per_px: f64,
    /// Bayer pattern.
    pub cfa: CfaPattern,
}

/// Every method's quality, in table order.
#[derive(Debug, Clone)]
pub struct DemosaicReport {
    /// The zone plate measured.
    pub request: ZonePlateRequest,
    /// (method, quality) per method.
    pub methods: Vec<(DemosaicMethod, ZonePlateQuality)>,
}

/// Measure every demosaicking method on the zone plate of `req`.
pub fn demosaic_zone_plate(req: &ZonePlateRequest) -> Result<DemosaicReport> {
    if !(32..=8192).contains(&req.size_px) {
        return Err(PipelineError::config(format!(
            "size {}: give 32 to 8192 pixels",
            req.size_px
        )));
    }
    let f = req.f_max_cyc_per_px;
    if !(f > 0.0 && f <= 0.5) {
        return Err(PipelineError::config(format!(
            "f_max {f}: give a frequency in (0, 0.5] cycles/pixel"
        )));
    }
    let zp = ZonePlate::new(req.size_px, f);
    let raw = zp.mosaic(req.cfa);
    let df = 0.01f64.min(f / 10.0);
    let methods = DemosaicMethod::ALL
        .into_iter()
        .map(|m| {
            Ok((
                m,
                zone_plate_quality(&zp, &camsim_isp::demosaic(&raw, m)?, df),
            ))
        })
        .collect::<Result<_>>()?;
    Ok(DemosaicReport {
        request: *req,
        methods,
    })
}

impl DemosaicReport {
    /// demosaic_mtf.csv: the frequency, then one MTF column per method.
    pub fn csv(&self) -> String {
        let mut csv = String::from("freq_cyc_per_px");
        for (m, _) in &self.methods {
            let _ = write!(csv, ",mtf_{}", m.name().replace('-', "_"));
        }
        csv.push('\n');
        for (i, f) in self.methods[0].1.frequency_cy_per_px.iter().enumerate() {
            let _ = write!(csv, "{f:.4}");
            for (_, q) in &self.methods {
                let _ = write!(csv, ",{:.5}", q.mtf.get(i).copied().unwrap_or(f64::NAN));
            }
            csv.push('\n');
        }
        csv
    }

    /// demosaic.json: the zone plate and, per method, MTF50 and the false colour.
    pub fn to_json(&self) -> serde_json::Value {
        let methods: Vec<serde_json::Value> = self
            .methods
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
        let r = &self.request;
        serde_json::json!({ "size_px": r.size_px, "f_max_cyc_per_px": r.f_max_cyc_per_px, "cfa": r.cfa.name(), "methods": methods })
    }

    /// Write demosaic_mtf.csv and demosaic.json into `out`.
    pub fn write_files(&self, out: &OutputDir) -> Result<()> {
        write_text(&out.join("demosaic_mtf.csv"), &self.csv())?;
        write_text(
            &out.join("demosaic.json"),
            &serde_json::to_string_pretty(&self.to_json())?,
        )
    }
}
