//! ISETCam sensor structs: a MATLAB `.mat` holding the `sensor` variable ISETCam saves
//! (`sensorCreate` ... `save(file, 'sensor')`, e.g. its `MT9V024SensorRCCC.mat`) read into a
//! [`SensorConfig`] ([`read_isetcam_sensor`]).
//!
//! Read (ISETCam field -> camsim key, units converted): `name`; `rows`, `cols`; `pixel.width` =
//! `pixel.height` (m; square pixels only) -> `pixel_pitch_um`; `pixel.pdWidth` x `pixel.pdHeight`
//! over the pixel area -> `fill_factor` (ISETCam `pixelGet(pixel, 'fill factor')`);
//! `pixel.conversionGain` (V/e-) -> `conversion_gain_uv_per_e`; `pixel.voltageSwing` (V);
//! `pixel.darkVoltage` (V/s) -> `dark_voltage_mv_per_s`; `pixel.readNoise` (V) -> `read_noise_mv`;
//! `sigmaGainFPN` (PRNU, percent, as ISETCam's `sensorSet(..., 'prnu level', %)`) ->
//! `prnu_percent`; `sigmaOffsetFPN` (DSNU, V) -> `dsnu_mv`; `analogGain`; `analogOffset` (V) ->
//! `analog_offset_mv`; `quantization.bits` (absent when `quantization.method` is `analog`: then
//! the caller gives the bits); `cfa.pattern` (1-based indices into `color.filterNames`) ->
//! `cfa_pattern`; `color.filterSpectra` (one column per filter) -> `qe.r`, `qe.g`, `qe.b` and
//! `[qe.filters]` (a filter's colour is its name's first letter, ISETCam's `sensorColorOrder`:
//! `rAR0132` is r, `w` white); `color.irFilter` -> `qe.ir_cut`; `pixel.spectralQE` ->
//! `qe.pixel_qe`; `spectrum.wave` (nm) -> `qe.wavelengths_nm`. A filter the pattern does not
//! use is left out; converted values are rounded to 13 significant digits (the conversion's
//! last-bit error).
//!
//! Not read (camsim has no such parameter or models it apart): `pixel.widthGap`/`heightGap` and
//! `pdXpos`/`pdYpos` (camsim centres the photodetector in a gap-free pixel), `pixel.n` and
//! `pixel.layerThickness` (the pixel stack: camsim's `[pixel_vignetting]` is configured on its
//! own), `integrationTime`, `AE`, `CDS`, `noiseFlag`, and the stored `data`, `gainFPNimage`,
//! `offsetFPNimage` (camsim draws its fixed-pattern maps from `fixed_pattern_seed`).

use crate::config::{NoiseSwitches, QeConfig, SensorConfig};
use crate::error::{Result, SensorError};
use camsim_core::mat::{read_mat_variables, MatValue};
use std::collections::BTreeMap;
use std::path::Path;

/// The ISETCam fields [`read_isetcam_sensor`] does not take (module docs).
pub const NOT_READ: [&str; 13] = [
    "pixel.widthGap",
    "pixel.heightGap",
    "pixel.pdXpos",
    "pixel.pdYpos",
    "pixel.n",
    "pixel.layerThickness",
    "integrationTime",
    "AE",
    "CDS",
    "noiseFlag",
    "data",
    "gainFPNimage",
    "offsetFPNimage",
];

/// `x` to 13 significant digits: a unit conversion's last-bit rounding removed (6e-6 m x 1e6 is
/// 6 um, not 5.999999999999999).
fn tidy(x: f64) -> f64 {
    format!("{x:.12e}").parse().unwrap_or(x)
}

/// Field `name` of a 1x1 struct.
fn field<'a>(v: &'a MatValue, name: &str) -> Option<&'a MatValue> {
    match v {
        MatValue::Struct {
            field_names,
            elements,
            ..
        } => {
            let i = field_names.iter().position(|f| f == name)?;
            elements.first()?.get(i)
        }
        _ => None,
    }
}

/// The ISETCam sensor in `path` as a camsim sensor config (module docs). `bits_if_analog` gives
/// the ADC bits when the file's quantization is `analog` (no bits stored); `source` goes to the
/// config's `source`. Errors name the file and the field.
pub fn read_isetcam_sensor(
    path: &Path,
    bits_if_analog: Option<u32>,
    source: Option<String>,
) -> Result<SensorConfig> {
    let file = path.display().to_string();
    let bad = |key: &str, message: String| SensorError::Config {
        source_name: file.clone(),
        key: key.to_string(),
        message,
    };
    let vars = read_mat_variables(path)?;
    let sensor = &vars
        .iter()
        .find(|v| v.name == "sensor")
        .ok_or_else(|| {
            bad(
                "sensor",
                format!(
                    "no 'sensor' variable (the file has {}): not an ISETCam sensor file",
                    vars.iter()
                        .map(|v| v.name.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            )
        })?
        .value;
    let get = |path: &[&str]| -> Result<&MatValue> {
        let mut v = sensor;
        for p in path {
            v = field(v, p).ok_or_else(|| bad(&path.join("."), "missing".into()))?;
        }
        Ok(v)
    };
    let numbers = |path: &[&str]| -> Result<Vec<f64>> {
        get(path)?
            .as_f64()
            .map(<[f64]>::to_vec)
            .ok_or_else(|| bad(&path.join("."), "not a numeric array".into()))
    };
    let scalar = |path: &[&str]| -> Result<f64> {
        match numbers(path)?.as_slice() {
            [v] => Ok(*v),
            other => Err(bad(
                &path.join("."),
                format!("{} values, expected one", other.len()),
            )),
        }
    };
    let name = get(&["name"])?
        .as_string()
        .ok_or_else(|| bad("name", "not a string".into()))?;
    let (width_m, height_m) = (scalar(&["pixel", "width"])?, scalar(&["pixel", "height"])?);
    if !(width_m > 0.0) || (width_m - height_m).abs() > 1e-12 * width_m {
        return Err(bad(
            "pixel.width",
            format!("{width_m} m x {height_m} m: camsim takes square pixels"),
        ));
    }
    let pd_area_m2 = scalar(&["pixel", "pdWidth"])? * scalar(&["pixel", "pdHeight"])?;
    let bits = match numbers(&["quantization", "bits"])?.as_slice() {
        [b] if *b >= 1.0 && *b <= 16.0 && b.fract() == 0.0 => *b as u32,
        [] => bits_if_analog.ok_or_else(|| {
            bad(
                "quantization.bits",
                "the file's quantization is analog (no bits): give the ADC's bits".into(),
            )
        })?,
        other => {
            return Err(bad(
                "quantization.bits",
                format!("{other:?} is not a number of bits in 1..=16"),
            ))
        }
    };
    // The CFA: 1-based indices into the filter names, column-major (MATLAB).
    let names = get(&["color", "filterNames"])?
        .as_strings()
        .ok_or_else(|| bad("color.filterNames", "not a cell array of strings".into()))?;
    let letter = |n: &str| {
        let c = camsim_core::cfa::canonical_filter_name(&n.chars().take(1).collect::<String>());
        if c.is_empty() {
            camsim_core::cfa::canonical_filter_name(n)
        } else {
            c
        }
    };
    let canon: Vec<String> = names.iter().map(|n| letter(n)).collect();
    if let Some(i) = (0..canon.len()).find(|&i| canon[..i].contains(&canon[i])) {
        return Err(bad(
            "color.filterNames",
            format!(
                "two filters of colour '{}' ({:?}): camsim names a filter by its colour",
                canon[i], names
            ),
        ));
    }
    let pattern = get(&["cfa", "pattern"])?;
    let dims = pattern.dims().to_vec();
    let idx = pattern
        .as_f64()
        .ok_or_else(|| bad("cfa.pattern", "not numeric".into()))?;
    let (pr, pc) = (
        dims.first().copied().unwrap_or(0),
        dims.get(1).copied().unwrap_or(1),
    );
    if pr * pc != idx.len() || idx.is_empty() {
        return Err(bad(
            "cfa.pattern",
            format!("dims {dims:?} for {} values", idx.len()),
        ));
    }
    let mut cfa_pattern = vec![vec![String::new(); pc]; pr];
    for c in 0..pc {
        for r in 0..pr {
            let k = idx[c * pr + r];
            let i = k as usize;
            if k.fract() != 0.0 || i == 0 || i > canon.len() {
                return Err(bad(
                    "cfa.pattern",
                    format!("index {k} is not a filter of {names:?} (1-based)"),
                ));
            }
            cfa_pattern[r][c] = canon[i - 1].clone();
        }
    }
    let wave = numbers(&["spectrum", "wave"])?;
    let n = wave.len();
    let spectra = numbers(&["color", "filterSpectra"])?;
    if spectra.len() != n * names.len() {
        return Err(bad(
            "color.filterSpectra",
            format!(
                "{} values for {n} wavelengths x {} filters",
                spectra.len(),
                names.len()
            ),
        ));
    }
    let column = |k: usize| spectra[k * n..(k + 1) * n].to_vec();
    let curve = |path: &[&str]| -> Result<Vec<f64>> {
        let v = numbers(path)?;
        if v.len() != n {
            return Err(bad(
                &path.join("."),
                format!("{} values for {n} wavelengths", v.len()),
            ));
        }
        Ok(v)
    };
    let mut qe = QeConfig {
        file: None,
        loaded_from: Some(file.clone()),
        wavelengths_nm: wave.clone(),
        r: Vec::new(),
        g: Vec::new(),
        b: Vec::new(),
        ir_cut: Some(curve(&["color", "irFilter"])?),
        pixel_qe: Some(curve(&["pixel", "spectralQE"])?),
        correction: None,
        filters: BTreeMap::new(),
    };
    // Filters the pattern does not use are left out (ISETCam's ar0132atSensorRGBW.mat carries a
    // w curve behind a GRBG pattern).
    let used = |c: &String| cfa_pattern.iter().flatten().any(|x| x == c);
    for (k, c) in canon.iter().enumerate().filter(|(_, c)| used(c)) {
        match c.as_str() {
            "r" => qe.r = column(k),
            "g" => qe.g = column(k),
            "b" => qe.b = column(k),
            _ => {
                qe.filters.insert(c.clone(), column(k));
            }
        }
    }
    let config = SensorConfig {
        name,
        source,
        rows: scalar(&["rows"])? as usize,
        cols: scalar(&["cols"])? as usize,
        pixel_pitch_um: tidy(width_m * 1e6),
        fill_factor: tidy(pd_area_m2 / (width_m * height_m)),
        cfa: String::new(),
        cfa_pattern: Some(cfa_pattern),
        conversion_gain_uv_per_e: tidy(scalar(&["pixel", "conversionGain"])? * 1e6),
        well_capacity_e: None,
        voltage_swing_v: scalar(&["pixel", "voltageSwing"])?,
        analog_gain: scalar(&["analogGain"])?,
        iso: None,
        base_iso: None,
        analog_offset_mv: tidy(scalar(&["analogOffset"])? * 1e3),
        black_level_dn: 0.0,
        bits,
        dsnu_mv: tidy(scalar(&["sigmaOffsetFPN"])? * 1e3),
        prnu_percent: scalar(&["sigmaGainFPN"])?,
        dark_voltage_mv_per_s: tidy(scalar(&["pixel", "darkVoltage"])? * 1e3),
        read_noise_mv: tidy(scalar(&["pixel", "readNoise"])? * 1e3),
        fixed_pattern_seed: 0,
        qe_correction: None,
        noise: NoiseSwitches::default(),
        qe,
        pixel_vignetting: None,
        hdr: None,
        defects: None,
        binning: None,
        dual_pixel: false,
    };
    config.validate(&file)?;
    Ok(config)
}

/// A built-in preset made from an ISETCam sensor file (`presets/<name>.toml`, written by the
/// `isetcam-presets` example).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct IsetcamPreset {
    /// Preset name.
    pub name: &'static str,
    /// The ISETCam file (in `../shared/data/isetcam/sensor`).
    pub file: &'static str,
    /// ADC bits (the files' quantization is analog).
    pub bits: u32,
    /// Where `bits` comes from.
    pub bits_source: &'static str,
    /// One line on the sensor.
    pub about: &'static str,
}

impl IsetcamPreset {
    /// The preset's `source`: the file, and where what the file lacks comes from.
    pub fn source(&self) -> String {
        format!(
            "ISETCam sensor file {} (ISETCam, MIT licence, as in the horizon-research/isetcam fork at ad56275): every value read from it; bits = {} ({})",
            self.file, self.bits, self.bits_source
        )
    }
}

const MT9V024_BITS: &str = "ON Semiconductor MT9V024 data sheet: 10-bit ADC";
const AR0132AT_BITS: &str = "ON Semiconductor AR0132AT data sheet: 12-bit ADC";

/// The presets built from ISETCam's sensor files: ON Semiconductor MT9V024 (6 um, 480 x 752;
/// filter curves digitized by ISETCam from ON's data sheet) and AR0132AT (3.75 um, 960 x 1280),
/// ISETCam's `MT9V024Create.m` / `ar0132atCreate.m` electronics (conversion gain 110 uV/e-,
/// swing 2.8 V, read noise 1 mV, dark voltage 1 mV/s, no DSNU or PRNU). ISETCam's
/// `ar0132atSensorRGBW.mat` is not among them: its pattern is GRBG, its w filter unused (it would
/// be `ar0132at-rgb` under another name).
pub const ISETCAM_PRESETS: [IsetcamPreset; 6] = [
    IsetcamPreset {
        name: "mt9v024-mono",
        file: "MT9V024SensorMono.mat",
        bits: 10,
        bits_source: MT9V024_BITS,
        about: "ON Semiconductor MT9V024, monochrome (ISETCam MT9V024SensorMono.mat)",
    },
    IsetcamPreset {
        name: "mt9v024-rgb",
        file: "MT9V024SensorRGB.mat",
        bits: 10,
        bits_source: MT9V024_BITS,
        about: "ON Semiconductor MT9V024, Bayer GRBG (ISETCam MT9V024SensorRGB.mat)",
    },
    IsetcamPreset {
        name: "mt9v024-rccc",
        file: "MT9V024SensorRCCC.mat",
        bits: 10,
        bits_source: MT9V024_BITS,
        about: "ON Semiconductor MT9V024, RCCC (ISETCam MT9V024SensorRCCC.mat)",
    },
    IsetcamPreset {
        name: "mt9v024-rgbw",
        file: "MT9V024SensorRGBW.mat",
        bits: 10,
        bits_source: MT9V024_BITS,
        about: "ON Semiconductor MT9V024, RGBW (ISETCam MT9V024SensorRGBW.mat)",
    },
    IsetcamPreset {
        name: "ar0132at-rgb",
        file: "ar0132atSensorRGB.mat",
        bits: 12,
        bits_source: AR0132AT_BITS,
        about: "ON Semiconductor AR0132AT, Bayer GRBG (ISETCam ar0132atSensorRGB.mat)",
    },
    IsetcamPreset {
        name: "ar0132at-rccc",
        file: "ar0132atSensorRCCC.mat",
        bits: 12,
        bits_source: AR0132AT_BITS,
        about: "ON Semiconductor AR0132AT, RCCC (ISETCam ar0132atSensorRCCC.mat)",
    },
];
