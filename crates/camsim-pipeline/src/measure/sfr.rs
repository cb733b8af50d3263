//! ISO 12233 slanted-edge SFR (e-SFR, as Burns' sfrmat) of any image camsim reads: per colour
//! channel of a raw CFA mosaic (each channel on its own sub-grid, no demosaicking) and of the
//! luminance of its bilinear demosaic, or of a spectral image's luminance. One luminance for every
//! door: Rec. 709 weights of RGB planes, the CIE photopic curve of spectral bands
//! (`camsim_analysis::image::{luminance, spectral_luminance}`), so `camsim analyze sfr`, Python's
//! `camsim.sfr` and `camsim validate` measure the same numbers on the same image.
//!
//! One frequency unit everywhere (console, sfr.json, sfr.csv, sfr.png): cycles per sensor pixel,
//! and cycles/mm on the sensor when the pixel pitch is known. The SFR of a CFA channel reaches
//! 0.25 cycles per sensor pixel at its own Nyquist (its samples are 2 sensor pixels apart).

use super::write_text;
use crate::{MosaicFormat, PipelineError, Result};
use camsim_analysis::image::{luminance, raw_plane, spectral_luminance};
use camsim_analysis::sfr::{self, SfrOptions, SfrResult};
use camsim_analysis::{Plane, Rect};
use camsim_core::{CfaChannel, RawImage, SpectralImage};
use camsim_io::atomic::OutputDir;
use camsim_io::measurements::read_sfr_csv;
use camsim_io::plot::{Figure, Series};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// An image to measure.
#[derive(Debug, Clone)]
pub enum SfrImage {
    /// A raw CFA mosaic: the R, G, B channels and the luminance of its demosaic.
    Raw(RawImage),
    /// A spectral image (irradiance): its luminance, at its own sampling.
    Spectral(SpectralImage),
}

impl SfrImage {
    /// A spectral OpenEXR (`.exr`), or a raw DNG or PNG/TIFF mosaic (read with `format`); and a
    /// warning when an EXR's round-off negatives were clamped.
    pub fn load(path: &Path, format: &MosaicFormat) -> Result<(SfrImage, Option<String>)> {
        if crate::inputs::extension(path) == "exr" {
            let (img, warning) = crate::inputs::read_spectral_exr(path)?;
            return Ok((SfrImage::Spectral(img), warning));
        }
        Ok((SfrImage::Raw(crate::load_raw(path, format)?), None))
    }
}

/// What to measure.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SfrRequest {
    /// Region of interest in sensor pixels (None: found around the slanted edge of largest
    /// contrast on the whole mosaic or image, once for every curve).
    pub roi: Option<Rect>,
    /// Fit the edge with a 2nd-order polynomial (lens distortion) instead of a line.
    pub quadratic: bool,
    /// Sensor pixel pitch, mm, for cycles/mm (raw frames record their own; for a spectral image
    /// it also defines the "sensor pixel" of the frequency axis, default its sample spacing).
    pub pixel_pitch_mm: Option<f64>,
    /// The image's name in messages (a file name).
    pub label: String,
}

/// One named SFR curve.
#[derive(Debug, Clone, PartialEq)]
pub struct SfrCurve {
    /// "R", "G", "B" or "luminance".
    pub name: String,
    /// The measurement.
    pub result: SfrResult,
}

/// The SFR curves of one image.
#[derive(Debug, Clone, PartialEq)]
pub struct SfrReport {
    /// The curves: R, G, B and luminance of a raw frame, luminance of a spectral image.
    pub curves: Vec<SfrCurve>,
    /// Sensor pixel pitch, mm, when known.
    pub pitch_mm: Option<f64>,
    /// The region measured, sensor pixels (the luminance curve's, on the full-resolution plane).
    pub roi: Option<Rect>,
}

/// Measure the SFR curves of `image`.
pub fn measure_sfr(image: &SfrImage, req: &SfrRequest) -> Result<SfrReport> {
    let opts = SfrOptions {
        poly_order: if req.quadratic { 2 } else { 1 },
        ..SfrOptions::default()
    };
    let curves_pitch = match image {
        SfrImage::Spectral(img) => spectral_curves(img, req, opts)?,
        SfrImage::Raw(raw) => raw_curves(raw, req, opts)?,
    };
    let (curves, pitch_mm) = curves_pitch;
    let roi = curves.last().map(|c| c.result.roi);
    Ok(SfrReport {
        curves,
        pitch_mm,
        roi,
    })
}

fn ctx(req: &SfrRequest, what: String) -> impl Fn(camsim_analysis::AnalysisError) -> PipelineError {
    let label = if req.label.is_empty() {
        "image".to_string()
    } else {
        req.label.clone()
    };
    move |e| PipelineError::Config(format!("{label}: {what}: {e}"))
}

/// A spectral image: the luminance at the image's own sampling, frequencies rescaled to sensor
/// pixels of `pitch_um` (default: one sample).
fn spectral_curves(
    img: &SpectralImage,
    req: &SfrRequest,
    mut opts: SfrOptions,
) -> Result<(Vec<SfrCurve>, Option<f64>)> {
    let spacing_mm = img.sample_spacing_m * 1e3;
    if !(spacing_mm > 0.0 && spacing_mm.is_finite()) {
        return Err(PipelineError::Config(format!(
            "{}: the image records no sample spacing",
            req.label
        )));
    }
    // Cycles/mm from the image's own sample spacing; "sensor pixel" = pitch_um (or a sample).
    opts.pixel_pitch_mm = Some(spacing_mm);
    let pitch_mm = req.pixel_pitch_mm.unwrap_or(spacing_mm);
    let plane = spectral_luminance(img)?;
    let mut r =
        sfr::sfr(&plane, req.roi, &opts).map_err(ctx(req, "SFR of the luminance".into()))?;
    let to_sensor_px = pitch_mm / spacing_mm; // cycles per sample -> cycles per sensor pixel
    r.freq_cyc_per_sensor_px = r
        .freq_cyc_per_sample
        .iter()
        .map(|f| f * to_sensor_px)
        .collect();
    r.mtf50_cyc_per_sensor_px = r.mtf50_cyc_per_sample.map(|f| f * to_sensor_px);
    r.nyquist_cyc_per_sensor_px = 0.5 * to_sensor_px;
    r.sample_pitch_sensor_px = 1.0 / to_sensor_px;
    Ok((
        vec![SfrCurve {
            name: "luminance".into(),
            result: r,
        }],
        Some(pitch_mm),
    ))
}

/// A raw mosaic: R, G, B on their own sub-grids and the luminance of the bilinear demosaic, all
/// in one ROI (found once on the whole mosaic).
fn raw_curves(
    raw: &RawImage,
    req: &SfrRequest,
    mut opts: SfrOptions,
) -> Result<(Vec<SfrCurve>, Option<f64>)> {
    let pitch_mm = req
        .pixel_pitch_mm
        .or((raw.pixel_pitch_m > 0.0 && raw.pixel_pitch_m.is_finite())
            .then_some(raw.pixel_pitch_m * 1e3));
    opts.pixel_pitch_mm = pitch_mm;
    let roi = match req.roi {
        Some(r) => r,
        None => sfr::find_edge_roi(&raw_plane(raw)?)
            .map_err(ctx(req, "finding the slanted edge (give the ROI)".into()))?,
    };
    let mut out = Vec::new();
    for ch in [CfaChannel::R, CfaChannel::G, CfaChannel::B] {
        let r = sfr::sfr_raw_channel(raw, ch, Some(roi), &opts).map_err(ctx(
            req,
            format!("SFR of channel {} in ROI {roi}", ch.letter()),
        ))?;
        out.push(SfrCurve {
            name: ch.letter().to_string(),
            result: r,
        });
    }
    let rgb = camsim_isp::try_demosaic_bilinear(raw)?;
    let [r, g, b] = [rgb.r, rgb.g, rgb.b].map(|p| Plane::new(rgb.rows, rgb.cols, p));
    let y = luminance(&[r?, g?, b?])?;
    let lum = sfr::sfr(&y, Some(roi), &opts)
        .map_err(ctx(req, format!("SFR of the luminance in ROI {roi}")))?;
    out.push(SfrCurve {
        name: "luminance".into(),
        result: lum,
    });
    Ok((out, pitch_mm))
}

impl SfrReport {
    /// The curve called `name` ("R", "G", "B", "luminance"; any case).
    pub fn curve(&self, name: &str) -> Option<&SfrResult> {
        self.curves
            .iter()
            .find(|c| c.name.eq_ignore_ascii_case(name))
            .map(|c| &c.result)
    }

    /// sfr.csv: on a common frequency axis 0..1 cycles per sensor pixel (step 0.01), the
    /// frequency in cycles/mm when the pitch is known, then one `mtf_<name>` column per curve
    /// (`nan` past the curve's end).
    pub fn csv(&self) -> String {
        let mut csv = String::from("freq_cyc_per_sensor_px");
        if self.pitch_mm.is_some() {
            csv.push_str(",freq_cyc_per_mm");
        }
        for c in &self.curves {
            let _ = write!(csv, ",mtf_{}", c.name);
        }
        csv.push('\n');
        for f in (0..=100).map(|i| i as f64 * 0.01) {
            let _ = write!(csv, "{f:.3}");
            if let Some(p) = self.pitch_mm {
                let _ = write!(csv, ",{:.4}", f / p);
            }
            for c in &self.curves {
                let r = &c.result;
                let v = if f <= *r.freq_cyc_per_sensor_px.last().unwrap_or(&0.0) {
                    sfr::interp(&r.freq_cyc_per_sensor_px, &r.mtf, f)
                } else {
                    f64::NAN
                };
                let _ = write!(csv, ",{v:.5}");
            }
            csv.push('\n');
        }
        csv
    }

    /// sfr.json: per curve MTF50 in cycles per sensor pixel and cycles/mm, the SFR at the curve's
    /// Nyquist, the edge angle, the rows used; the image, pixel pitch and ROI.
    pub fn to_json(&self, image: &str) -> serde_json::Value {
        let summary: Vec<serde_json::Value> = self
            .curves
            .iter()
            .map(|c| {
                let r = &c.result;
                serde_json::json!({
                    "curve": c.name,
                    "mtf50_cyc_per_sensor_px": r.mtf50_cyc_per_sensor_px,
                    "mtf50_cyc_per_mm": r.mtf50_cyc_per_sensor_px.and_then(|f| self.pitch_mm.map(|p| f / p)),
                    "nyquist_cyc_per_sensor_px": r.nyquist_cyc_per_sensor_px,
                    "mtf_at_nyquist": r.mtf_at_nyquist,
                    "edge_angle_deg": r.edge_angle_deg,
                    "rows_used": r.rows_used,
                    "sample_pitch_sensor_px": r.sample_pitch_sensor_px,
                })
            })
            .collect();
        serde_json::json!({
            "image": image,
            "frequency_unit": "cycles per sensor pixel (and cycles/mm on the sensor)",
            "pixel_pitch_um": self.pitch_mm.map(|p| p * 1e3),
            "roi_sensor_px": self.roi,
            "curves": summary,
        })
    }

    /// The SFR plot (0-1 cycles per sensor pixel), with the curves of other sfr.csv files
    /// `compare` dashed.
    pub fn figure(&self, image: &str, compare: &[PathBuf]) -> Result<Figure> {
        let mut fig = Figure::new(
            format!("ISO 12233 SFR: {image}"),
            "spatial frequency (cycles per sensor pixel)",
            "SFR",
        )
        .ranges(Some((0.0, 1.0)), Some((0.0, 1.1)))
        .sized(900, 600);
        for c in &self.curves {
            fig = fig.with(Series::new(
                c.name.clone(),
                c.result
                    .freq_cyc_per_sensor_px
                    .iter()
                    .zip(&c.result.mtf)
                    .filter(|(f, _)| **f <= 1.0)
                    .map(|(f, m)| (*f, *m))
                    .collect(),
            ));
        }
        for path in compare {
            for c in read_sfr_csv(path)? {
                fig = fig.with(
                    Series::new(
                        format!("{} ({})", c.name.trim_start_matches("mtf_"), path.display()),
                        c.points,
                    )
                    .dashed(),
                );
            }
        }
        Ok(fig)
    }

    /// Write sfr.csv, sfr.json and sfr.png into `out`; returns sfr.json's value.
    pub fn write_files(
        &self,
        out: &OutputDir,
        image: &str,
        compare: &[PathBuf],
    ) -> Result<serde_json::Value> {
        write_text(&out.join("sfr.csv"), &self.csv())?;
        let json = self.to_json(image);
        camsim_io::atomic::write_json_atomic(&out.join("sfr.json"), &json)?;
        self.figure(image, compare)?
            .write_png(&out.join("sfr.png"))?;
        Ok(json)
    }

    /// One line per curve: MTF50 (cycles per sensor pixel and cycles/mm), the SFR at its Nyquist,
    /// the edge angle.
    pub fn summary(&self) -> Vec<String> {
        self.curves
            .iter()
            .map(|c| {
                let r = &c.result;
                format!(
                    "{:>10}: MTF50 {} cycles/sensor-pixel{}, SFR {:.3} at its Nyquist ({} cycles/sensor-pixel), edge {:.2} deg",
                    c.name,
                    r.mtf50_cyc_per_sensor_px
                        .map(|v| format!("{v:.4}"))
                        .unwrap_or_else(|| "(not reached)".into()),
                    r.mtf50_cyc_per_sensor_px
                        .and_then(|f| self.pitch_mm.map(|p| format!(" = {:.1} cycles/mm", f / p)))
                        .unwrap_or_default(),
                    r.mtf_at_nyquist,
                    r.nyquist_cyc_per_sensor_px,
                    r.edge_angle_deg
                )
            })
            .collect()
    }
}
