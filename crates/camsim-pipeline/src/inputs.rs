//! Inputs of the recipes: sensors and lenses by preset name or file ([`load_sensor`],
//! [`load_lens`]), the one set of changes a command may make to a sensor ([`SensorOverrides`]),
//! raw mosaics ([`load_raw`], [`raw_from_mosaic`]) and images to measure ([`MeasuredImage`]).

use crate::{PipelineError, Result};
use camsim_analysis::Plane;
use camsim_core::{CfaPattern, RawImage};
use camsim_optics::OpticsConfig;
use camsim_sensor::{NoiseSwitches, Sensor};
use std::path::Path;

/// A sensor from a preset name (`camsim_sensor::presets::SENSOR_PRESETS`, any case) or a TOML
/// file path.
pub fn load_sensor(spec: &str) -> Result<Sensor> {
    let p = Path::new(spec);
    if spec.ends_with(".toml") || p.exists() {
        Ok(Sensor::from_file(p)?)
    } else {
        Ok(Sensor::preset(spec)?)
    }
}

/// A lens from a preset name (`camsim_optics::presets::LENS_PRESETS`, any case) or a TOML file
/// path.
pub fn load_lens(spec: &str) -> Result<OpticsConfig> {
    let p = Path::new(spec);
    if spec.ends_with(".toml") || p.exists() {
        Ok(OpticsConfig::from_file(p)?)
    } else {
        Ok(OpticsConfig::preset(spec)?)
    }
}

/// What a command may change on a sensor before it captures, applied in one order (window,
/// ISO, CFA, noise) by [`SensorOverrides::apply`]: `camsim sensor --rows --cols --iso --cfa
/// --no-noise` and Python's `camsim.sensor(..., rows=, cols=, iso=, cfa=, noise=False)`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SensorOverrides {
    /// Window rows centred on the optical axis (None: the sensor's).
    pub rows: Option<usize>,
    /// Window columns.
    pub cols: Option<usize>,
    /// Sensitivity as ISO: analog gain = base_iso / iso (ISETCam's divisor); replaces the
    /// sensor's analog gain, and needs its `base_iso`.
    pub iso: Option<f64>,
    /// A colour filter array by name (`camsim_core::cfa::CFA_NAMES`) in place of the sensor's.
    pub cfa: Option<String>,
    /// Noise sources (None: the sensor's; `NoiseSwitches::none()`: the mean signal only).
    pub noise: Option<NoiseSwitches>,
}

impl SensorOverrides {
    /// `sensor` with the overrides; `name` names it in errors (the preset or file).
    pub fn apply(&self, mut sensor: Sensor, name: &str) -> Result<Sensor> {
        if self.rows.is_some() || self.cols.is_some() {
            sensor = sensor.window(
                self.rows.unwrap_or(sensor.rows()),
                self.cols.unwrap_or(sensor.cols()),
            )?;
        }
        if let Some(iso) = self.iso {
            let mut c = sensor.config().clone();
            c.iso = Some(iso);
            c.analog_gain = 1.0;
            sensor = Sensor::from_config_named(c, &format!("{name} with iso {iso}"))?;
        }
        if let Some(cfa) = &self.cfa {
            let mut c = sensor.config().clone();
            c.cfa = cfa.clone();
            c.cfa_pattern = None;
            sensor = Sensor::from_config_named(c, &format!("{name} with cfa {cfa}"))?;
        }
        if let Some(n) = self.noise {
            sensor = sensor.with_noise(n);
        }
        Ok(sensor)
    }
}

/// How to read a PNG/TIFF mosaic or a numpy array (a DNG carries its own CFA, black level and
/// bit depth).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MosaicFormat {
    /// Bayer pattern of the mosaic (required for PNG/TIFF).
    pub cfa: Option<CfaPattern>,
    /// Black level, DN.
    pub black_dn: f64,
    /// ADC bits (1..=16).
    pub bits: u32,
}

impl Default for MosaicFormat {
    fn default() -> Self {
        MosaicFormat {
            cfa: None,
            black_dn: 0.0,
            bits: 16,
        }
    }
}

/// A raw frame from a `rows` x `cols` mosaic of DN (row-major) and its format; the CFA defaults
/// to RGGB.
pub fn raw_from_mosaic(
    rows: usize,
    cols: usize,
    dn: Vec<u16>,
    format: &MosaicFormat,
) -> Result<RawImage> {
    if !(1..=16).contains(&format.bits) {
        return Err(PipelineError::config(format!(
            "bits = {}: must be 1..16",
            format.bits
        )));
    }
    if !(format.black_dn >= 0.0 && format.black_dn.is_finite()) {
        return Err(PipelineError::config(format!(
            "black level {} DN: must be a finite number >= 0",
            format.black_dn
        )));
    }
    if dn.len() != rows * cols {
        return Err(PipelineError::config(format!(
            "the mosaic has {} values for {rows} x {cols}",
            dn.len()
        )));
    }
    let mut raw = RawImage::new(rows, cols, format.cfa.unwrap_or_default(), format.bits)?;
    raw.dn = dn;
    raw.black_level_dn = format.black_dn;
    Ok(raw)
}

/// A raw mosaic from a DNG, or from a 16-bit PNG/TIFF mosaic read with `format` (which must name
/// its CFA: PNG/TIFF carry none of these).
pub fn load_raw(path: &Path, format: &MosaicFormat) -> Result<RawImage> {
    match extension(path).as_str() {
        "dng" => Ok(camsim_io::dng::read_dng(path)?.0),
        "png" | "tif" | "tiff" => {
            if format.cfa.is_none() {
                return Err(PipelineError::file(
                    path,
                    "a PNG/TIFF mosaic needs its CFA pattern (--cfa RGGB|GRBG|GBRG|BGGR)",
                ));
            }
            if !(1..=16).contains(&format.bits) {
                return Err(PipelineError::config(format!(
                    "--bits {}: must be 1..16",
                    format.bits
                )));
            }
            let (rows, cols, dn) = camsim_io::raster::read_mosaic_16(path)?;
            raw_from_mosaic(rows, cols, dn, format)
        }
        _ => Err(PipelineError::file(
            path,
            "not a raw file camsim reads (DNG, or a 16-bit PNG/TIFF mosaic with --cfa)",
        )),
    }
}

/// A spectral OpenEXR (radiance or irradiance) and, when round-off-sized negative samples
/// (another tool's FFT output) were clamped to 0 (`camsim_io::exr::NEGATIVE_ROUNDOFF_FRACTION`),
/// a warning saying so.
pub fn read_spectral_exr(path: &Path) -> Result<(camsim_core::SpectralImage, Option<String>)> {
    let (img, info) = camsim_io::exr::read_spectral_exr_with_info(path)?;
    let warning = (info.clamped_negatives > 0).then(|| {
        format!(
            "{}: clamped {} round-off negative samples to 0 (most negative {:e})",
            path.display(),
            info.clamped_negatives,
            info.most_negative_clamped
        )
    });
    Ok((img, warning))
}

/// The lower-case extension of `path` ("" when none).
pub(crate) fn extension(path: &Path) -> String {
    path.extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase()
}

/// An image for chart and region statistics: a raw CFA mosaic (each channel measured on its own
/// pixels), or demosaicked RGB planes above black (a LinearRaw DNG, as phones write).
#[derive(Debug, Clone)]
pub enum MeasuredImage {
    /// A CFA mosaic.
    Raw(RawImage),
    /// LinearRaw RGB, black subtracted.
    Rgb {
        planes: Box<[Plane; 3]>,
        exposure_s: f64,
        pixel_pitch_m: f64,
    },
}

impl MeasuredImage {
    /// A DNG (CFA or LinearRaw) or a PNG/TIFF mosaic (read with `format`).
    pub fn load(path: &Path, format: &MosaicFormat) -> Result<MeasuredImage> {
        if extension(path) != "dng" {
            return Ok(MeasuredImage::Raw(load_raw(path, format)?));
        }
        Ok(match camsim_io::dng::read_dng_image(path)?.0 {
            camsim_io::dng::DngImage::Cfa(r) => MeasuredImage::Raw(r),
            camsim_io::dng::DngImage::LinearRaw(l) => {
                let plane = |k: usize| {
                    let data = (0..l.rows * l.cols)
                        .map(|i| (l.dn[i * 3 + k] as f64 - l.black_level_dn[k]) as f32)
                        .collect();
                    Plane::new(l.rows, l.cols, data)
                };
                MeasuredImage::Rgb {
                    planes: Box::new([plane(0)?, plane(1)?, plane(2)?]),
                    exposure_s: l.exposure_s,
                    pixel_pitch_m: l.pixel_pitch_m,
                }
            }
        })
    }

    /// (rows, cols).
    pub fn size(&self) -> (usize, usize) {
        match self {
            MeasuredImage::Raw(r) => (r.rows, r.cols),
            MeasuredImage::Rgb { planes, .. } => (planes[0].rows, planes[0].cols),
        }
    }

    /// Exposure time, s (0 when unknown).
    pub fn exposure_s(&self) -> f64 {
        match self {
            MeasuredImage::Raw(r) => r.exposure_s,
            MeasuredImage::Rgb { exposure_s, .. } => *exposure_s,
        }
    }

    /// Pixel pitch, m (0 when unknown).
    pub fn pixel_pitch_m(&self) -> f64 {
        match self {
            MeasuredImage::Raw(r) => r.pixel_pitch_m,
            MeasuredImage::Rgb { pixel_pitch_m, .. } => *pixel_pitch_m,
        }
    }

    /// What the statistics are measured on, for the reports.
    pub fn kind(&self) -> &'static str {
        match self {
            MeasuredImage::Raw(_) => "raw CFA (each channel on its own pixels)",
            MeasuredImage::Rgb { .. } => "LinearRaw RGB",
        }
    }
}

impl From<RawImage> for MeasuredImage {
    fn from(r: RawImage) -> Self {
        MeasuredImage::Raw(r)
    }
}
