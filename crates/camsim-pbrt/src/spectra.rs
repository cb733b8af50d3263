//! Spectrum-valued parameters as pbrt-v4 builds them (`ParameterDictionary::GetOneSpectrum`):
//! `rgb` (uplifted, see [`camsim_scene3d::uplift`]), `spectrum` (inline pairs, a named spectrum or a file)
//! and `blackbody`, for the three uses pbrt distinguishes (albedo, unbounded, illuminant), plus
//! pbrt-v4's photometric normalisation of lights (`SpectrumToPhotometric`).

use super::params::{Param, Value};
use super::PbrtError;
use camsim_core::spectrum::Extrapolation;
use camsim_core::{tables, Spectrum};
use camsim_scene3d::uplift;
use std::path::Path;
use std::sync::OnceLock;

/// How a spectrum will be used (pbrt-v4 `SpectrumType`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SpectrumUse {
    /// A reflectance: RGB components must lie in [0, 1].
    Albedo,
    /// Any non-negative RGB (scale x uplift of rgb / scale).
    Unbounded,
    /// An emission: RGB is multiplied by the colour space's illuminant (D65 for sRGB).
    Illuminant,
}

/// A parsed spectrum and the value pbrt-v4's `SpectrumToPhotometric` returns for it (for an
/// RGB illuminant only the illuminant part counts, as in pbrt-v4).
#[derive(Debug, Clone, PartialEq)]
pub struct ParsedSpectrum {
    pub spectrum: Spectrum,
    /// `sum_{lambda = 360..830 nm} y_bar(lambda) s(lambda) * 1 nm` of the spectrum (or of its
    /// illuminant for an RGB illuminant).
    pub photometric: f64,
}

/// pbrt-v4's `CIE_Y_integral` (the integral of y-bar over 360-830 nm, in nm).
pub const CIE_Y_INTEGRAL: f64 = 106.856895;

/// Named spectra camsim carries (pbrt-v4 names).
pub const NAMED_SPECTRA: &[&str] = &[
    "stdillum-D65",
    "stdillum-A",
    "stdillum-F2",
    "stdillum-F11",
    "stdillum-C",
    "stdillum-E",
];

pub use camsim_scene3d::spectra::photometric;

/// Scale a named illuminant so its photometric integral is `CIE_Y_INTEGRAL` (pbrt-v4 normalises
/// its named illuminant spectra this way, `FromInterleaved(..., normalize = true)`).
fn normalize_named(s: Spectrum) -> Spectrum {
    let p = photometric(&s);
    if p > 0.0 {
        s.scaled(CIE_Y_INTEGRAL / p)
    } else {
        s
    }
}

/// The colour space's illuminant (sRGB: CIE D65), normalised as pbrt-v4's `stdillum-D65`.
pub fn srgb_illuminant() -> &'static Spectrum {
    static D65: OnceLock<Spectrum> = OnceLock::new();
    D65.get_or_init(|| normalize_named(tables::illuminant("D65").expect("built-in D65")))
}

/// A pbrt-v4 named spectrum, if camsim carries it. `Some(Err)` for names pbrt-v4 knows but
/// camsim does not carry.
pub fn named_spectrum(name: &str) -> Option<Result<Spectrum, String>> {
    let table = match name {
        "stdillum-D65" => "D65",
        "stdillum-A" => "A",
        "stdillum-F2" => "F2",
        "stdillum-F11" => "F11",
        "stdillum-C" => "C",
        "stdillum-E" => "E",
        _ if super::optical_constants::NAMES.contains(&name) => {
            return super::optical_constants::named(name).map(Ok);
        }
        _ => {
            let pbrt_prefixes = [
                "stdillum-",
                "illum-",
                "glass-",
                "metal-",
                "canon_",
                "nikon_",
                "sony_",
                "hasselblad_",
                "fujifilm_",
                "dji_",
                "gopro_",
                "apple_",
                "google_",
                "samsung_",
                "nokia_",
                "olympus_",
                "pentax_",
                "panasonic_",
                "phaseone_",
                "red_",
                "arri_",
            ];
            if pbrt_prefixes.iter().any(|p| name.starts_with(p)) {
                return Some(Err(format!(
                    "named spectrum \"{name}\" is a pbrt-v4 built-in that camsim does not carry; camsim has {}, {}",
                    NAMED_SPECTRA.join(", "),
                    super::optical_constants::NAMES.join(", ")
                )));
            }
            return None;
        }
    };
    Some(
        tables::illuminant(table)
            .map(normalize_named)
            .map_err(|e| e.to_string()),
    )
}

/// pbrt-v4 `BlackbodySpectrum(T)`: Planck's law normalised to 1 at its peak (Wien's law
/// lambda_max = 2.8977721e-3 m K / T), sampled every 1 nm over 300-1100 nm.
pub fn blackbody(temperature_k: f64) -> Result<Spectrum, String> {
    if !(temperature_k.is_finite() && temperature_k > 0.0) {
        return Err(format!(
            "blackbody temperature {temperature_k} K must be a positive number"
        ));
    }
    let lambda_max_nm = 2.897_772_1e-3 / temperature_k * 1e9; // Wien's displacement law
    let peak = camsim_core::units::planck_radiance_w_per_sr_m2_nm(lambda_max_nm, temperature_k);
    if !(peak > 0.0 && peak.is_finite()) {
        return Err(format!(
            "blackbody temperature {temperature_k} K is out of range"
        ));
    }
    let pairs: Vec<(f64, f64)> = (300..=1100)
        .map(|l| {
            let v =
                camsim_core::units::planck_radiance_w_per_sr_m2_nm(l as f64, temperature_k) / peak;
            (l as f64, if v.is_finite() { v } else { 0.0 })
        })
        .collect();
    Ok(Spectrum::from_pairs(&pairs))
}

/// Read a two-column spectrum file (pbrt-v4 `PiecewiseLinearSpectrum::Read`: wavelength, value
/// pairs separated by white space; `#` starts a comment). camsim also accepts commas as separators
/// and skips header lines (any line before the first numeric one that does not parse).
pub fn read_spectrum_file(path: &Path) -> Result<Spectrum, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut vals = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line = line.split('#').next().unwrap_or("");
        let toks: Vec<&str> = line
            .split(|c: char| c.is_whitespace() || c == ',')
            .filter(|s| !s.is_empty())
            .collect();
        if toks.is_empty() {
            continue;
        }
        let nums: Result<Vec<f64>, _> = toks.iter().map(|t| t.parse::<f64>()).collect();
        match nums {
            Ok(n) => vals.extend(n),
            Err(_) if vals.is_empty() => continue, // a header line
            Err(_) => {
                return Err(format!(
                    "{}, line {}: not a number in \"{}\"",
                    path.display(),
                    i + 1,
                    line.trim()
                ))
            }
        }
    }
    if vals.is_empty() || vals.len() % 2 != 0 {
        return Err(format!(
            "{}: a spectrum file needs wavelength-value pairs (two columns); found {} numbers",
            path.display(),
            vals.len()
        ));
    }
    let (w, v): (Vec<f64>, Vec<f64>) = vals.chunks(2).map(|c| (c[0], c[1])).unzip();
    Spectrum::new(w, v, &path.display().to_string()).map_err(|e| e.to_string())
}

/// The RGB uplift pbrt-v4 applies for each use.
pub fn rgb_spectrum(rgb: [f64; 3], usage: SpectrumUse) -> Result<ParsedSpectrum, String> {
    if rgb.iter().any(|v| *v < 0.0 || !v.is_finite()) {
        return Err(format!(
            "RGB value ({}, {}, {}) has a negative component",
            rgb[0], rgb[1], rgb[2]
        ));
    }
    let f = |v: [f64; 3]| [v[0] as f32, v[1] as f32, v[2] as f32];
    match usage {
        SpectrumUse::Albedo => {
            if rgb.iter().any(|v| *v > 1.0) {
                return Err(format!(
                    "RGB reflectance value ({}, {}, {}) has a component > 1",
                    rgb[0], rgb[1], rgb[2]
                ));
            }
            let s = uplift::rgb_to_reflectance_full(f(rgb)).with_extrapolation(Extrapolation::Hold);
            let p = photometric(&s);
            Ok(ParsedSpectrum {
                spectrum: s,
                photometric: p,
            })
        }
        SpectrumUse::Unbounded | SpectrumUse::Illuminant => {
            // pbrt-v4 RGBUnboundedSpectrum / RGBIlluminantSpectrum: scale = 2 max(rgb),
            // s = scale * uplift(rgb / scale) [* illuminant].
            let m = rgb[0].max(rgb[1]).max(rgb[2]);
            let scale = 2.0 * m;
            let base = if scale > 0.0 {
                uplift::rgb_to_reflectance_full(f([rgb[0] / scale, rgb[1] / scale, rgb[2] / scale]))
                    .scaled(scale)
            } else {
                uplift::rgb_to_reflectance_full([0.0; 3])
            };
            if usage == SpectrumUse::Unbounded {
                let p = photometric(&base);
                return Ok(ParsedSpectrum {
                    spectrum: base.with_extrapolation(Extrapolation::Hold),
                    photometric: p,
                });
            }
            let ill = srgb_illuminant();
            let pairs: Vec<(f64, f64)> = ill
                .wavelengths_nm
                .iter()
                .zip(&ill.values)
                .map(|(&l, &e)| (l, e * base.eval(l)))
                .collect();
            Ok(ParsedSpectrum {
                spectrum: Spectrum::from_pairs(&pairs),
                photometric: photometric(ill),
            })
        }
    }
}

/// Build the spectrum of parameter `p` (type rgb, spectrum or blackbody). `resolve` turns a
/// file name into a path (relative to the including file).
pub fn param_spectrum(
    p: &Param,
    usage: SpectrumUse,
    resolve: &dyn Fn(&str) -> std::path::PathBuf,
) -> Result<ParsedSpectrum, PbrtError> {
    let err = |m: String| p.loc.err(format!("parameter \"{}\": {m}", p.name));
    let plain = |s: Spectrum| -> Result<ParsedSpectrum, PbrtError> {
        if usage == SpectrumUse::Albedo && s.values.iter().any(|v| *v < 0.0) {
            return Err(p.loc.err(format!(
                "parameter \"{}\": a reflectance spectrum has a negative value",
                p.name
            )));
        }
        let ph = photometric(&s);
        Ok(ParsedSpectrum {
            spectrum: s,
            photometric: ph,
        })
    };
    match p.ty.as_str() {
        "rgb" => {
            let v = p.nums()?;
            if v.len() != 3 {
                return Err(err(format!("rgb needs 3 values, got {}", v.len())));
            }
            rgb_spectrum([v[0], v[1], v[2]], usage).map_err(err)
        }
        "blackbody" => {
            let v = p.nums()?;
            if v.len() != 1 {
                return Err(err(format!(
                    "blackbody takes one value (the temperature in K; pbrt-v4 dropped v3's scale), got {}",
                    v.len()
                )));
            }
            plain(blackbody(v[0]).map_err(err)?)
        }
        "spectrum" => {
            if let Some(Value::Str(_)) = p.values.first() {
                if p.values.len() != 1 {
                    return Err(err("give one named spectrum or file name".into()));
                }
                let Value::Str(name) = &p.values[0] else {
                    unreachable!()
                };
                if let Some(named) = named_spectrum(name) {
                    return plain(named.map_err(err)?);
                }
                let path = resolve(name);
                if !path.exists() {
                    return Err(err(format!(
                        "\"{name}\" is neither a named spectrum ({}) nor a file (looked for {})",
                        NAMED_SPECTRA.join(", "),
                        path.display()
                    )));
                }
                return plain(read_spectrum_file(&path).map_err(err)?);
            }
            let v = p.nums()?;
            if v.is_empty() || v.len() % 2 != 0 {
                return Err(err(format!(
                    "inline spectrum needs wavelength-value pairs, got {} numbers",
                    v.len()
                )));
            }
            let (w, vals): (Vec<f64>, Vec<f64>) = v.chunks(2).map(|c| (c[0], c[1])).unzip();
            if let Some(i) = (1..w.len()).find(|&i| w[i] <= w[i - 1]) {
                return Err(err(format!(
                    "spectrum wavelengths must increase: entry {} is {} nm after {} nm",
                    i + 1,
                    w[i],
                    w[i - 1]
                )));
            }
            plain(Spectrum::new(w, vals, &p.name).map_err(|e| err(e.to_string()))?)
        }
        other => Err(err(format!(
            "type \"{other}\" is not a spectrum type (rgb, spectrum, blackbody)"
        ))),
    }
}
