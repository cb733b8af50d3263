//! The sensor description as engineers write it (TOML; um, uV, mV, %, s), and its validation.
//!
//! Units in the file are the ones data sheets use; [`crate::Sensor`] converts them to SI.

use crate::error::{Result, SensorError};
use crate::hdr_config::{HdrConfig, HdrHost};
use camsim_core::CfaLayout;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Which noise sources are on. All default to on; a noise-free sensor is how tests check the mean
/// signal. (ISETCam's `noise flag`, split per source.)
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct NoiseSwitches {
    /// Photon shot noise (Poisson statistics of the collected electrons, dark electrons included).
    #[serde(default = "yes")]
    pub shot: bool,
    /// Temporal read noise (`read_noise_mv`, Gaussian, new every frame).
    #[serde(default = "yes")]
    pub read: bool,
    /// Dark signal non-uniformity (`dsnu_mv`): a fixed per-pixel voltage offset map.
    #[serde(default = "yes")]
    pub dsnu: bool,
    /// Photo-response non-uniformity (`prnu_percent`): a fixed per-pixel gain map.
    #[serde(default = "yes")]
    pub prnu: bool,
    /// Dark current (`dark_voltage_mv_per_s`): its mean signal and, with `shot`, its shot noise.
    #[serde(default = "yes")]
    pub dark: bool,
    /// ADC quantization noise. The raw frames are integers either way (the ADC rounds); with this
    /// off, [`crate::Frame::analog_dn`] also keeps the unrounded values, and the noise model
    /// ([`crate::Sensor::predicted_noise_dn`]) leaves out the 1/12 DN^2 term.
    #[serde(default = "yes")]
    pub quantization: bool,
}

fn yes() -> bool {
    true
}

impl Default for NoiseSwitches {
    fn default() -> Self {
        NoiseSwitches {
            shot: true,
            read: true,
            dsnu: true,
            prnu: true,
            dark: true,
            quantization: true,
        }
    }
}

impl NoiseSwitches {
    /// Every noise source off (quantization stays: the ADC always rounds).
    pub fn none() -> Self {
        NoiseSwitches {
            shot: false,
            read: false,
            dsnu: false,
            prnu: false,
            dark: false,
            quantization: true,
        }
    }
}

/// Spectral quantum efficiency, sampled at `wavelengths_nm` (linear interpolation between samples,
/// 0 outside). Channel QE = colour filter x IR-cut filter x pixel QE (ISETCam `sensorGet(...,'spectral qe')`),
/// then the QE correction M (`correction` here, or `qe_correction` of [`SensorConfig`]).
///
/// The curves are given inline, or read from a spectra `file` (relative to the sensor TOML):
/// a CSV (`wavelength_nm,r,g,b[,ir_cut][,pixel_qe]`) or an ISETCam sensor `.mat` (`wavelength`,
/// `data`, `filterNames`). Columns are found by name: `r`/`red`, `g`/`green`, `b`/`blue`,
/// `ir_cut`/`ir_filter`/`ir`, `pixel_qe`; failing an exact name, ISETCam's convention that a
/// filter name starts with its colour letter (`rDefault`, `gDefault`, ...). Any other column is a
/// named filter (`filters`, e.g. `w`, `cyan`, `yellow`) that a general CFA (`cfa_pattern`) can use.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct QeConfig {
    /// A spectra file (.csv, .txt or ISETCam .mat) holding the curves, instead of the inline
    /// arrays. Read when the sensor is built; the config then holds the curves inline and the
    /// file's path in `loaded_from`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub file: Option<PathBuf>,
    /// Where the curves were read from (written by camsim; ignored on input).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub loaded_from: Option<String>,
    /// Sample wavelengths, nm, strictly increasing.
    #[serde(default)]
    pub wavelengths_nm: Vec<f64>,
    /// Red colour-filter transmittance (fraction, 0..1), one value per wavelength; empty (left out)
    /// when the CFA has no r filter (a monochrome or an RCCC sensor).
    #[serde(default)]
    pub r: Vec<f64>,
    /// Green colour-filter transmittance (fraction), one value per wavelength; empty (left out)
    /// when the CFA has no g filter (a monochrome or an RCCC sensor).
    #[serde(default)]
    pub g: Vec<f64>,
    /// Blue colour-filter transmittance (fraction), one value per wavelength; empty (left out)
    /// when the CFA has no b filter (a monochrome or an RCCC sensor).
    #[serde(default)]
    pub b: Vec<f64>,
    /// IR-cut filter transmittance (fraction), one value per wavelength; absent = 1.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ir_cut: Option<Vec<f64>>,
    /// Photodetector QE (fraction), one value per wavelength; absent = 1.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pixel_qe: Option<Vec<f64>>,
    /// The 3x3 QE correction M fitted for these curves (same form as `qe_correction` of
    /// [`SensorConfig`]). It lives in this table so that replacing the curves (a new `[qe]`
    /// table, e.g. `file = "my-qe.csv"`) drops it: a sensor made from the pixel4a template
    /// with other QE gets no correction unless it sets one. When the sensor is built it is
    /// moved to `qe_correction` (giving both is an error).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub correction: Option<[[f64; 3]; 3]>,
    /// More colour filters by name (transmittance, fraction, one value per wavelength) for a
    /// general CFA (`cfa = "RGBW"`, `cfa_pattern`): `[qe.filters] cyan = [...]`, or the extra
    /// columns of a QE file. Their QE = filter x IR-cut x pixel QE (no QE correction). A `w`
    /// (white, panchromatic) filter that is not given has transmittance 1.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub filters: BTreeMap<String, Vec<f64>>,
}

/// Column names accepted for each curve of a QE file (case-insensitive).
const QE_COLUMNS: [(&str, &[&str]); 5] = [
    ("r", &["r", "red"]),
    ("g", &["g", "green"]),
    ("b", &["b", "blue"]),
    (
        "ir_cut",
        &["ir_cut", "ir_filter", "ir", "ircut", "irfilter"],
    ),
    ("pixel_qe", &["pixel_qe", "pixel", "pd_qe"]),
];

impl QeConfig {
    /// Read `file` (relative paths against `base_dir`) into the inline curves. No-op without a
    /// file. Errors name the file, the missing column or the conflicting inline key.
    pub fn load_file(&mut self, base_dir: &Path, source_name: &str) -> Result<()> {
        let Some(file) = self.file.take() else {
            return Ok(());
        };
        let path = if file.is_relative() {
            base_dir.join(&file)
        } else {
            file.clone()
        };
        let bad = |key: &str, message: String| SensorError::Config {
            source_name: source_name.to_string(),
            key: key.to_string(),
            message,
        };
        if !self.wavelengths_nm.is_empty()
            || !self.r.is_empty()
            || !self.g.is_empty()
            || !self.b.is_empty()
        {
            return Err(bad(
                "qe.file",
                "give either file or the inline curves (wavelengths_nm, r, g, b), not both".into(),
            ));
        }
        let table = camsim_core::spectrum_csv::load_spectra(&path)?;
        let lower: Vec<String> = table
            .names
            .iter()
            .map(|n| n.trim().to_ascii_lowercase())
            .collect();
        let mut used = vec![false; lower.len()];
        let mut found: [Option<Vec<f64>>; 5] = Default::default();
        for (k, (key, aliases)) in QE_COLUMNS.iter().enumerate() {
            let exact = lower.iter().position(|n| aliases.contains(&n.as_str()));
            // ISETCam: the first letter of a filter name is its colour (sensorColorOrder).
            let by_letter = || {
                if k >= 3 {
                    return None;
                }
                let hits: Vec<usize> = (0..lower.len())
                    .filter(|&i| {
                        !used[i]
                            && lower[i].starts_with(*key)
                            && !QE_COLUMNS
                                .iter()
                                .any(|(_, a)| a.contains(&lower[i].as_str()))
                    })
                    .collect();
                (hits.len() == 1).then(|| hits[0])
            };
            if let Some(i) = exact.or_else(by_letter) {
                used[i] = true;
                found[k] = Some(table.columns[i].clone());
            }
        }
        let names = table.names.join(", ");
        let file_key = format!("qe.file {}", path.display());
        // Columns that are not r, g, b, IR cut or pixel QE are named filters of a general CFA.
        for (i, u) in used.iter().enumerate() {
            if !u {
                let name = camsim_core::cfa::canonical_filter_name(&table.names[i]);
                if self
                    .filters
                    .insert(name.clone(), table.columns[i].clone())
                    .is_some()
                {
                    return Err(bad(&file_key, format!("filter '{name}' is given twice (inline [qe.filters] or another column)")));
                }
            }
        }
        let [r, g, b, ir, px] = found;
        let need = |c: Option<Vec<f64>>, key: &str| {
            c.ok_or_else(|| {
                bad(
                    &file_key,
                    format!("no '{key}' column (the file has {names})"),
                )
            })
        };
        self.r = need(r, "r")?;
        self.g = need(g, "g")?;
        self.b = need(b, "b")?;
        if ir.is_some() {
            if self.ir_cut.is_some() {
                return Err(bad(
                    "qe.ir_cut",
                    format!("given inline and as a column of {}", path.display()),
                ));
            }
            self.ir_cut = ir;
        }
        if px.is_some() {
            if self.pixel_qe.is_some() {
                return Err(bad(
                    "qe.pixel_qe",
                    format!("given inline and as a column of {}", path.display()),
                ));
            }
            self.pixel_qe = px;
        }
        self.wavelengths_nm = table.wavelengths_nm;
        self.loaded_from = Some(path.display().to_string());
        Ok(())
    }
}

/// Pairs of keys that state one setting two ways (giving both is an error): a table put over a
/// preset (`[sensor] preset = ...` with `[sensor.config]`) that gives one of a pair replaces the
/// preset's other one.
pub const ALTERNATIVE_KEYS: [(&str, &str); 2] = [("cfa", "cfa_pattern"), ("iso", "analog_gain")];

/// A sensor as written in a TOML file (presets are such files, built in). Unknown keys are errors.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SensorConfig {
    /// Sensor name (free text; written to DNG UniqueCameraModel and run.json).
    pub name: String,
    /// Where the figures come from (free text).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub source: Option<String>,
    /// Pixel rows (image height), pixels.
    pub rows: usize,
    /// Pixel columns (image width), pixels.
    pub cols: usize,
    /// Pixel pitch (square pixels), um.
    pub pixel_pitch_um: f64,
    /// Photosensitive fraction of the pixel area, in (0, 1]. The photodetector is a centred square
    /// of side pitch x sqrt(fill_factor) (ISETCam `pixelCenterFillPD`).
    pub fill_factor: f64,
    /// Colour filter array, by name (a Bayer phase, top-left first, or a preset layout; `camsim
    /// presets` lists them). Leave it out (or "custom") when `cfa_pattern` gives the pattern.
    #[serde(default)]
    pub cfa: String,
    /// A general CFA tile (ISETCam `sensorSet(sensor, 'pattern', ...)` with `filterNames`): rows
    /// of filter names, up to 8 x 8, e.g. `[["r", "g"], ["w", "b"]]`. Names are r/red, g/green,
    /// b/blue (the QE curves `r`, `g`, `b`), w/white (panchromatic: transmittance 1 unless
    /// `[qe.filters]` gives `w`) or any filter of `[qe.filters]` / a QE file's extra columns.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cfa_pattern: Option<Vec<Vec<String>>>,
    /// Conversion gain, uV per electron (Table 1 of the paper: 7.65e-5 V/e- = 76.5 uV/e-).
    pub conversion_gain_uv_per_e: f64,
    /// Optional cross-check of the well capacity, electrons: if given it must agree with
    /// voltage_swing_v / conversion gain within 1 %. (The model uses the swing.)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub well_capacity_e: Option<f64>,
    /// Voltage swing (the largest pixel voltage the ADC converts), V.
    pub voltage_swing_v: f64,
    /// Analog gain (dimensionless, > 0): v_out = (v + offset) / gain (ISETCam sensorCompute).
    #[serde(default = "one")]
    pub analog_gain: f64,
    /// Sensitivity as ISO (ISO 12232 arithmetic units), an alternative to `analog_gain`: the signal
    /// above black scales with ISO / `base_iso`. ISETCam divides by its analog gain
    /// (v_out = (v + offset) / gain, sensorCompute), so `iso` sets analog_gain = base_iso / iso.
    /// Giving both `iso` and an `analog_gain` other than 1 is an error.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub iso: Option<f64>,
    /// The ISO at analog gain 1 (unity gain), needed by `iso`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub base_iso: Option<f64>,
    /// Analog offset, mV, added before the gain (ISETCam `analog offset`).
    #[serde(default)]
    pub analog_offset_mv: f64,
    /// Black level, DN: a digital pedestal added to every pixel before rounding (after the analog
    /// gain and the clip at the voltage swing), so read noise around zero light is kept instead of
    /// being clipped at 0 DN; DN values still clip to [0, 2^bits - 1] (the white level). Written
    /// to the DNG's BlackLevel tag (with any analog offset). Real raws have one (the Pixel 4a: 64
    /// DN of 1023). 0 (the default) is ISETCam's model exactly.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub black_level_dn: f64,
    /// ADC bits, 1..=16. Quantization step = voltage_swing_v / 2^bits.
    pub bits: u32,
    /// DSNU: standard deviation of the fixed per-pixel dark offset, mV.
    #[serde(default)]
    pub dsnu_mv: f64,
    /// PRNU: standard deviation of the fixed per-pixel gain, percent.
    #[serde(default)]
    pub prnu_percent: f64,
    /// Dark current expressed as pixel voltage per second, mV/s.
    #[serde(default)]
    pub dark_voltage_mv_per_s: f64,
    /// Read noise: standard deviation of the temporal voltage noise per frame, mV.
    #[serde(default)]
    pub read_noise_mv: f64,
    /// Seed of the fixed-pattern maps (DSNU, PRNU): the same seed gives the same sensor instance.
    /// 0 ..= 2^63 - 1 (a TOML integer).
    #[serde(default)]
    pub fixed_pattern_seed: u64,
    /// Optional 3x3 QE correction M (dimensionless): [r', g', b'] = [r, g, b] M, where r, g, b
    /// are the channel QE curves as columns, so rows of M index the input channel:
    /// r' = M00 r + M10 g + M20 b, g' = M01 r + M11 g + M21 b, b' = M02 r + M12 g + M22 b
    /// (the paper's eq. 1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub qe_correction: Option<[[f64; 3]; 3]>,
    /// Noise switches (all on when the table is absent).
    #[serde(default)]
    pub noise: NoiseSwitches,
    /// Spectral QE.
    pub qe: QeConfig,
    /// Pixel vignetting (light lost in the pixel stack at oblique chief rays; absent = none).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pixel_vignetting: Option<crate::pixel_vignetting::PixelVignettingConfig>,
    /// HDR pixel (dual conversion gain or split pixel, [`crate::hdr`]); absent = a plain pixel.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hdr: Option<HdrConfig>,
    /// Column and row fixed-pattern noise and hot, dead and stuck pixels ([`crate::defects`]);
    /// absent = none.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub defects: Option<crate::defects::DefectsConfig>,
    /// Charge or digital binning of k x k blocks of these photodiodes: the raws are rows / k x
    /// cols / k (docs/src/sensors.md, "Binning"); absent = every photodiode read alone.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub binning: Option<BinningConfig>,
    /// Dual-pixel autofocus (phase detection on every pixel, as in Canon's Dual Pixel CMOS AF
    /// and the Pixel phones): each pixel is two photodiodes side by side under its microlens,
    /// which images the lens pupil onto them, so the left photodiode sees the light through the
    /// pupil's left half (x < 0) and the right one through its right half. Each photodiode holds
    /// half the pixel's well (its signal clips at half the swing), collects half its dark
    /// current, has its own fixed pattern (DSNU, PRNU) and temporal noise and is read on its own;
    /// the raw is their digital sum (so its read noise is sqrt 2 of one read's). `camsim
    /// simulate` writes `raw_left.dng` and `raw_right.dng` beside `raw.dng`; the disparity
    /// between them grows with defocus (`camsim analyze dual-pixel`). The optics images each half
    /// pupil apart (the wavefront model; not with an `[hdr]` pixel, binning or a lens camera's
    /// irradiance render; under `[light_flicker]` each half takes its share of every group).
    /// Default false.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub dual_pixel: bool,
}

fn one() -> f64 {
    1.0
}

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

/// Largest pixel count a sensor may have (a guard against typos; 2^31 pixels).
const MAX_PIXELS: u64 = 1 << 31;

impl SensorConfig {
    /// Parse TOML text; `source_name` (file name or preset) goes into every error message.
    pub fn from_toml_str(text: &str, source_name: &str) -> Result<Self> {
        toml::from_str::<SensorConfig>(text).map_err(|e| SensorError::Parse {
            source_name: source_name.to_string(),
            message: e.to_string(),
        })
    }

    /// The config as TOML text (parses back to an equal config).
    pub fn to_toml(&self) -> String {
        // Serialising a struct of plain numbers, strings and arrays cannot fail.
        toml::to_string(self)
            .unwrap_or_else(|e| format!("# could not serialise sensor config: {e}\n"))
    }

    /// Make the config self-contained: read `[qe] file` (relative to `base_dir`) into the
    /// inline curves, and move `[qe] correction` to `qe_correction` (both given: an error).
    pub fn resolve(&mut self, base_dir: &Path, source_name: &str) -> Result<()> {
        self.qe.load_file(base_dir, source_name)?;
        if let Some(m) = self.qe.correction.take() {
            if self.qe_correction.is_some() {
                return Err(SensorError::Config {
                    source_name: source_name.to_string(),
                    key: "qe_correction".into(),
                    message: "given both at the top level and as [qe] correction; keep one".into(),
                });
            }
            self.qe_correction = Some(m);
        }
        Ok(())
    }

    /// The colour filter array this config describes (`cfa_pattern`, else the `cfa` name).
    pub fn cfa_layout(&self) -> camsim_core::error::Result<CfaLayout> {
        match &self.cfa_pattern {
            Some(_) if !(self.cfa.is_empty() || self.cfa.eq_ignore_ascii_case("custom")) => {
                Err(camsim_core::CoreError::invalid(
                    "cfa",
                    "give either a cfa name or cfa_pattern, not both",
                ))
            }
            Some(p) => CfaLayout::from_names(p),
            None => CfaLayout::parse(&self.cfa),
        }
    }

    /// The `[qe.filters]` transmittance of a filter (any alias of its name), if given.
    pub fn filter_curve(&self, name: &str) -> Option<&Vec<f64>> {
        let n = camsim_core::cfa::canonical_filter_name(name);
        self.qe
            .filters
            .iter()
            .find(|(k, _)| camsim_core::cfa::canonical_filter_name(k) == n)
            .map(|(_, v)| v)
    }

    /// ISETCam's analog gain (the divisor of v_out = (v + offset) / gain): base_iso / iso when
    /// `iso` is given (a camera's ISO gain multiplies the signal by iso / base_iso), else
    /// `analog_gain`.
    pub fn effective_analog_gain(&self) -> f64 {
        match (self.iso, self.base_iso) {
            (Some(iso), Some(base)) => base / iso,
            _ => self.analog_gain,
        }
    }

    /// Check every value; the error names `source_name` and the key.
    pub fn validate(&self, source_name: &str) -> Result<()> {
        self.check_geometry()
            .and_then(|()| self.check_electronics())
            .and_then(|()| self.check_extras())
            .and_then(|()| self.check_qe())
            .and_then(|()| self.defects.as_ref().map_or(Ok(()), |d| d.validate()))
            .map_err(|(key, message)| SensorError::Config {
                source_name: source_name.to_string(),
                key,
                message,
            })
    }

    /// Size, pixel pitch, fill factor and the CFA.
    fn check_geometry(&self) -> Checked {
        if self.rows == 0 {
            return bad("rows", "must be at least 1");
        }
        if self.cols == 0 {
            return bad("cols", "must be at least 1");
        }
        if (self.rows as u64).saturating_mul(self.cols as u64) > MAX_PIXELS {
            return bad(
                "rows",
                format!("{} x {} pixels is more than 2^31", self.rows, self.cols),
            );
        }
        positive("pixel_pitch_um", self.pixel_pitch_um)?;
        if !(self.fill_factor.is_finite() && self.fill_factor > 0.0 && self.fill_factor <= 1.0) {
            return bad(
                "fill_factor",
                format!("must be in (0, 1], got {}", self.fill_factor),
            );
        }
        match (self.cfa_layout(), &self.cfa_pattern) {
            (Ok(_), _) => Ok(()),
            (Err(_), Some(_))
                if !(self.cfa.is_empty() || self.cfa.eq_ignore_ascii_case("custom")) =>
            {
                bad(
                    "cfa",
                    format!(
                        "give either cfa = \"{}\" or cfa_pattern, not both",
                        self.cfa
                    ),
                )
            }
            (Err(e), Some(_)) => bad("cfa_pattern", e.to_string()),
            (Err(e), None) => bad("cfa", format!("{e} (or give cfa_pattern)")),
        }
    }

    /// Conversion gain, swing and well, gain and ISO, offset, ADC bits and black level, noise.
    fn check_electronics(&self) -> Checked {
        positive("conversion_gain_uv_per_e", self.conversion_gain_uv_per_e)?;
        positive("voltage_swing_v", self.voltage_swing_v)?;
        if let Some(w) = self.well_capacity_e {
            positive("well_capacity_e", w)?;
            let derived = self.voltage_swing_v / (self.conversion_gain_uv_per_e * 1e-6);
            if (w / derived - 1.0).abs() > 0.01 {
                return bad(
                    "well_capacity_e",
                    format!(
                        "{w} e- disagrees with voltage_swing_v / conversion gain = {derived:.1} e- by more than 1 %"
                    ),
                );
            }
        }
        positive("analog_gain", self.analog_gain)?;
        if let Some(base) = self.base_iso {
            positive("base_iso", base)?;
        }
        if let Some(iso) = self.iso {
            positive("iso", iso)?;
            if self.base_iso.is_none() {
                return bad(
                    "iso",
                    format!("iso = {iso} needs base_iso (the ISO at analog gain 1)"),
                );
            }
            if self.analog_gain != 1.0 {
                return bad(
                    "iso",
                    format!(
                        "give either iso or analog_gain, not both (iso = {iso}, analog_gain = {})",
                        self.analog_gain
                    ),
                );
            }
        }
        if !self.analog_offset_mv.is_finite() {
            return bad(
                "analog_offset_mv",
                format!("must be a finite number, got {}", self.analog_offset_mv),
            );
        }
        if !(1..=16).contains(&self.bits) {
            return bad("bits", format!("must be in 1..=16, got {}", self.bits));
        }
        let white_dn = ((1u64 << self.bits) - 1) as f64;
        if !(self.black_level_dn.is_finite()
            && self.black_level_dn >= 0.0
            && self.black_level_dn < white_dn)
        {
            return bad(
                "black_level_dn",
                format!(
                    "must be in [0, {white_dn}) (below the white level 2^bits - 1), got {}",
                    self.black_level_dn
                ),
            );
        }
        non_negative("dsnu_mv", self.dsnu_mv)?;
        non_negative("prnu_percent", self.prnu_percent)?;
        non_negative("dark_voltage_mv_per_s", self.dark_voltage_mv_per_s)?;
        non_negative("read_noise_mv", self.read_noise_mv)
    }

    /// The QE correction matrix's entries, pixel vignetting and the `[hdr]` table.
    fn check_extras(&self) -> Checked {
        if let Some(m) = &self.qe_correction {
            for (i, row) in m.iter().enumerate() {
                for (j, v) in row.iter().enumerate() {
                    if !v.is_finite() {
                        return bad(
                            "qe_correction",
                            format!("element [{i}][{j}] is {v}, not a finite number"),
                        );
                    }
                }
            }
        }
        if let Some(pv) = &self.pixel_vignetting {
            pv.validate()?;
        }
        if self.dual_pixel && self.hdr.is_some() {
            return bad(
                "dual_pixel",
                "a dual-pixel sensor with an [hdr] pixel is not modelled: give one of them",
            );
        }
        if self.dual_pixel && self.binning.is_some() {
            return bad(
                "dual_pixel",
                "a dual-pixel sensor with [binning] is not modelled: give one of them",
            );
        }
        if let Some(h) = &self.hdr {
            h.validate(&HdrHost {
                analog_gain: self.effective_analog_gain(),
                iso_given: self.iso.is_some(),
                analog_offset_mv: self.analog_offset_mv,
                voltage_swing_v: self.voltage_swing_v,
                conversion_gain_uv_per_e: self.conversion_gain_uv_per_e,
            })?;
        }
        Ok(())
    }

    /// The QE tables: wavelengths, the curves, named filters against the CFA, the corrected QE.
    fn check_qe<'a>(&'a self) -> Checked {
        let q = &self.qe;
        let n = q.wavelengths_nm.len();
        if n == 0 {
            return bad("qe.wavelengths_nm", "is empty");
        }
        for (i, w) in q.wavelengths_nm.iter().enumerate() {
            if !(w.is_finite() && *w > 0.0) {
                return bad(
                    "qe.wavelengths_nm",
                    format!("value {i} is {w}, not a positive number"),
                );
            }
        }
        if let Some(i) = q.wavelengths_nm.windows(2).position(|p| p[1] <= p[0]) {
            return bad(
                "qe.wavelengths_nm",
                format!(
                    "must be strictly increasing, but {} nm follows {} nm",
                    q.wavelengths_nm[i + 1],
                    q.wavelengths_nm[i]
                ),
            );
        }
        // r, g or b may be left empty when the CFA has no such filter (monochrome, RCCC).
        let layout = self.cfa_layout().ok();
        let curve = |key: &'static str, c: &'static str, v: &'a Vec<f64>| {
            let unused = layout.as_ref().is_some_and(|l| l.filter_index(c).is_none());
            (key, (!(v.is_empty() && unused)).then_some(v))
        };
        let curves: [(&str, Option<&Vec<f64>>); 5] = [
            curve("qe.r", "r", &q.r),
            curve("qe.g", "g", &q.g),
            curve("qe.b", "b", &q.b),
            ("qe.ir_cut", q.ir_cut.as_ref()),
            ("qe.pixel_qe", q.pixel_qe.as_ref()),
        ];
        let named = q
            .filters
            .iter()
            .map(|(name, c)| (format!("qe.filters.{name}"), c));
        for (key, c) in curves
            .into_iter()
            .filter_map(|(k, c)| c.map(|c| (k.to_string(), c)))
            .chain(named)
        {
            if c.len() != n {
                return bad(&key, format!("has {} values for {n} wavelengths", c.len()));
            }
            if let Some((v, w)) = c
                .iter()
                .zip(&q.wavelengths_nm)
                .find(|(v, _)| !(v.is_finite() && **v >= 0.0))
            {
                return bad(
                    &key,
                    format!("value at {w} nm is {v}, not a finite number >= 0"),
                );
            }
        }
        self.check_filters()?;
        self.check_corrected_qe()
    }

    /// Every named filter is used by the CFA, and every CFA filter has a curve.
    fn check_filters(&self) -> Checked {
        let q = &self.qe;
        let layout = match self.cfa_layout() {
            Ok(l) => l,
            Err(e) => return bad("cfa_pattern", e.to_string()),
        };
        // A named filter no CFA cell uses is most likely a typo (or a wrong file): refuse it.
        if let Some(unused) = q.filters.keys().find(|k| layout.filter_index(k).is_none()) {
            let from = q
                .loaded_from
                .as_ref()
                .map_or(String::new(), |f| format!(" of {f}"));
            return bad(
                &format!("qe.filters.{unused}"),
                format!(
                    "filter column '{unused}'{from} is not r, g, b, ir_cut or pixel_qe, and the CFA {} does not use it",
                    layout.name()
                ),
            );
        }
        for f in layout.filters() {
            let known =
                ["r", "g", "b", "w"].contains(&f.as_str()) || self.filter_curve(f).is_some();
            if !known {
                return bad(
                    "cfa_pattern",
                    format!("filter '{f}' has no transmittance curve: add it to [qe.filters] or as a column of the QE file"),
                );
            }
        }
        Ok(())
    }

    /// The corrected QE ([r', g', b'] = [r, g, b] M) stays non-negative.
    fn check_corrected_qe(&self) -> Checked {
        let (q, Some(m)) = (&self.qe, &self.qe_correction) else {
            return Ok(());
        };
        for k in 0..q.wavelengths_nm.len() {
            let ir = q.ir_cut.as_ref().map_or(1.0, |v| v[k]);
            let px = q.pixel_qe.as_ref().map_or(1.0, |v| v[k]);
            let at = |c: &[f64]| c.get(k).copied().unwrap_or(0.0);
            let rgb = [at(&q.r) * ir * px, at(&q.g) * ir * px, at(&q.b) * ir * px];
            for c in 0..3 {
                let v: f64 = (0..3).map(|i| rgb[i] * m[i][c]).sum();
                if v < 0.0 {
                    return bad(
                        "qe_correction",
                        format!(
                            "gives a negative QE {v:.4} for channel {} at {} nm",
                            ["r", "g", "b"][c],
                            q.wavelengths_nm[k]
                        ),
                    );
                }
            }
        }
        Ok(())
    }
}

/// A config check: `Err((key, message))` names the offending key.
type Checked = std::result::Result<(), (String, String)>;

fn bad(key: &str, message: impl Into<String>) -> Checked {
    Err((key.to_string(), message.into()))
}

fn positive(key: &str, v: f64) -> Checked {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        bad(key, format!("must be a positive number, got {v}"))
    }
}

fn non_negative(key: &str, v: f64) -> Checked {
    if v.is_finite() && v >= 0.0 {
        Ok(())
    } else {
        bad(key, format!("must be a finite number >= 0, got {v}"))
    }
}

/// How the pixels of a binned block are combined ([`crate::binning`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum BinningMode {
    /// The block's charge summed on one floating diffusion, then one readout.
    Charge,
    /// Every photodiode read and converted, the k^2 digital values summed on chip.
    Digital,
}

/// `[binning]`: k x k blocks of photodiodes read as one output pixel (docs/src/sensors.md
/// gives every value of the binned pixel). `rows`, `cols` and `pixel_pitch_um` stay those of
/// the photodiode array; the sensor's raws are rows / k x cols / k (a remainder row or column
/// is not read).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct BinningConfig {
    /// Photodiodes per block side, k: 2 bins 2 x 2 blocks. Charge: 1..=8; digital: 1, 2, 4 or 8
    /// (the sum keeps the ADC step only for a power of two).
    pub factor: usize,
    /// `"charge"` (summed before one readout) or `"digital"` (k^2 readouts summed).
    pub mode: BinningMode,
    /// Charge binning: the conversion gain of the binned readout, uV per electron, for a sensor
    /// that switches its floating diffusion to a lower gain to hold the block's charge (the well
    /// becomes voltage_swing_v / this). Default: the pixel's `conversion_gain_uv_per_e`, so the
    /// block saturates at one photodiode's well.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub conversion_gain_uv_per_e: Option<f64>,
}
