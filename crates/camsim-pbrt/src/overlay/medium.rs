//! `[render] medium`: fill a scene with one homogeneous participating medium (fog, haze,
//! murky water) for the camera simulations users run. The medium becomes the camera's: every
//! ray starts in it and keeps it at every surface that is not a medium boundary (pbrt-v4's
//! rule), so it fills the scene; shapes with a `MediumInterface` still switch media.
//!
//! ```toml
//! [render]
//! medium = { sigma_a_per_m = 0.01, sigma_s_per_m = 0.5, g = 0.3 }   # fog: 1/m, HG asymmetry
//! # medium = { preset = "Wholemilk", scale = 0.01 }                 # Jensen et al. 2001
//! ```
//!
//! `sigma_a_per_m` and `sigma_s_per_m` take any overlay spectrum (a number, a table name, a
//! file column); `preset` names a measured material of Jensen et al. 2001 (Table 1, mm^-1,
//! converted to 1/m; `sigma_s` is the table's reduced scattering, as pbrt-v4's presets);
//! `scale` multiplies either; `g` is the Henyey-Greenstein asymmetry in (-1, 1).

use super::{resolve_spectrum, SpectrumSpec};
use crate::scene::SceneDescription;
use crate::spectra::{rgb_spectrum, SpectrumUse};
use camsim_scene3d::media::{preset, preset_names, Coefficients, Medium, MediumKind};
use serde::Deserialize;
use std::path::Path;

/// `[render] medium`.
#[derive(Debug, Clone, Deserialize, Default, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct MediumOverlay {
    /// Absorption coefficient, 1/m (default 0 without a preset).
    pub sigma_a_per_m: Option<SpectrumSpec>,
    /// Scattering coefficient, 1/m (default 0 without a preset).
    pub sigma_s_per_m: Option<SpectrumSpec>,
    /// A measured material of Jensen et al. 2001 (instead of the two coefficients).
    pub preset: Option<String>,
    /// Multiplies the coefficients (default 1).
    pub scale: Option<f64>,
    /// Henyey-Greenstein asymmetry in (-1, 1) (default 0, isotropic).
    pub g: Option<f64>,
}

/// Make `m` the camera's medium of `scene`.
pub(super) fn fill(
    scene: &mut SceneDescription,
    m: &MediumOverlay,
    base_dir: &Path,
) -> Result<(), String> {
    let g = m.g.unwrap_or(0.0);
    if !(g > -1.0 && g < 1.0) {
        return Err(format!("render.medium.g {g} must lie in (-1, 1)"));
    }
    let scale = m.scale.unwrap_or(1.0);
    if !(scale >= 0.0 && scale.is_finite()) {
        return Err(format!("render.medium.scale {scale} must be >= 0"));
    }
    let (sigma_a, sigma_s) = match &m.preset {
        Some(name) => {
            if m.sigma_a_per_m.is_some() || m.sigma_s_per_m.is_some() {
                return Err(
                    "render.medium: give preset or sigma_a_per_m / sigma_s_per_m, not both".into(),
                );
            }
            let p = match preset(name) {
                Some(Ok(p)) => p,
                Some(Err(e)) => return Err(format!("render.medium: {e}")),
                None => {
                    return Err(format!(
                        "render.medium.preset \"{name}\" is unknown (camsim has {})",
                        preset_names()
                    ))
                }
            };
            // The table is per millimetre; the scene is in metres.
            let per_m = |rgb: [f64; 3]| {
                rgb_spectrum(rgb.map(|v| v * 1000.0), SpectrumUse::Unbounded)
                    .map(|s| s.spectrum)
                    .map_err(|e| format!("render.medium.preset \"{name}\": {e}"))
            };
            (per_m(p.sigma_a_per_mm)?, per_m(p.sigma_s_prime_per_mm)?)
        }
        None => {
            let one = |s: &Option<SpectrumSpec>, key: &str| match s {
                Some(s) => resolve_spectrum(s, base_dir, &format!("render.medium.{key}")),
                None => resolve_spectrum(&SpectrumSpec::Constant(0.0), base_dir, key),
            };
            (
                one(&m.sigma_a_per_m, "sigma_a_per_m")?,
                one(&m.sigma_s_per_m, "sigma_s_per_m")?,
            )
        }
    };
    if sigma_a.max_value() <= 0.0 && sigma_s.max_value() <= 0.0 {
        return Err("render.medium: sigma_a_per_m and sigma_s_per_m are both zero: the medium would change nothing".into());
    }
    scene.media.fill(Medium {
        name: "render.medium".into(),
        g,
        kind: MediumKind::Homogeneous(Coefficients {
            sigma_a_per_m: sigma_a.scaled(scale),
            sigma_s_per_m: sigma_s.scaled(scale),
            le: None,
        }),
    });
    Ok(())
}
