//! `Material "hair"` (pbrt-v4 `HairMaterial::Create`): the fibre's absorption from `sigma_a`
//! (a spectrum or texture, unbounded), else `reflectance` / `color` (a reflectance or texture,
//! mapped to `sigma_a` per wavelength by the renderer), else the melanin concentrations
//! `eumelanin` / `pheomelanin`, else pbrt-v4's default eumelanin 1.3; `eta` (default 1.55),
//! `beta_m` and `beta_n` (0.3), `alpha` (2 degrees).

use super::super::params::ParamList;
use super::super::spectra::{param_spectrum, rgb_spectrum, SpectrumUse};
use super::super::{Loc, PbrtError};
use super::SceneBuilder;
use crate::scene::{HairAbsorption, Material, Texture};
use std::path::Path;

/// Absorption coefficients per unit concentration of eumelanin and pheomelanin, linear sRGB,
/// per unit fibre radius: the values pbrt-v4 uses (`HairBxDF::SigmaAFromConcentration`; pbrt-v3
/// 3rd ed. sec. 9.9.5). They are d'Eon, Francois, Hill, Letteri and Aubry 2011 ("An
/// Energy-Conserving Hair Reflectance Model", EGSR, sec. 6.1) rescaled: Blender's Principled Hair
/// BSDF, which cites that section, lists (0.506, 0.841, 1.653) and (0.343, 0.733, 1.924).
const EUMELANIN_SIGMA_A: [f64; 3] = [0.419, 0.697, 1.37];
const PHEOMELANIN_SIGMA_A: [f64; 3] = [0.187, 0.4, 1.05];

/// pbrt-v4's default: brown hair.
const DEFAULT_EUMELANIN: f64 = 1.3;

impl SceneBuilder {
    /// The hair material's parameters.
    pub(super) fn hair_material(
        &mut self,
        params: &ParamList,
        file: &Path,
        loc: &Loc,
        what: &str,
    ) -> Result<Material, PbrtError> {
        let sigma_a = match params.get("sigma_a", &["rgb", "spectrum", "blackbody", "texture"])? {
            None => None,
            Some(p) if p.ty == "texture" => self.spectrum_texture_param(params, "sigma_a", file)?,
            Some(p) => {
                let resolve = |n: &str| self.resolve(file, n);
                let s = param_spectrum(p, SpectrumUse::Unbounded, &resolve)?.spectrum;
                if s.values.iter().any(|v| !(*v >= 0.0)) {
                    return Err(p.loc.err(format!("{what}: \"sigma_a\" must be >= 0")));
                }
                Some(Texture::Constant(s))
            }
        };
        let color_name = if params
            .get("reflectance", &["rgb", "spectrum", "blackbody", "texture"])?
            .is_some()
        {
            "reflectance"
        } else {
            "color"
        };
        let color = self.spectrum_texture_param(params, color_name, file)?;
        let mut melanin = false;
        for n in ["eumelanin", "pheomelanin"] {
            melanin |= params.get(n, &["float", "texture"])?.is_some();
        }
        let absorption = if let Some(s) = sigma_a {
            self.note_ignored(
                params,
                &[color_name, "eumelanin", "pheomelanin"],
                "sigma_a",
                what,
            );
            HairAbsorption::SigmaA(s)
        } else if let Some(c) = color {
            self.note_ignored(params, &["eumelanin", "pheomelanin"], color_name, what);
            HairAbsorption::Color(c)
        } else {
            let (ce, cp) = if melanin {
                (
                    self.float_param(params, "eumelanin", 0.0, what)?,
                    self.float_param(params, "pheomelanin", 0.0, what)?,
                )
            } else {
                (DEFAULT_EUMELANIN, 0.0)
            };
            // pbrt-v4 clamps negative concentrations to 0.
            let (ce, cp) = (ce.max(0.0), cp.max(0.0));
            let rgb: [f64; 3] =
                std::array::from_fn(|i| ce * EUMELANIN_SIGMA_A[i] + cp * PHEOMELANIN_SIGMA_A[i]);
            let s = rgb_spectrum(rgb, SpectrumUse::Unbounded)
                .map_err(|e| loc.err(format!("{what}: melanin: {e}")))?;
            HairAbsorption::SigmaA(Texture::Constant(s.spectrum))
        };
        let eta = self.float_param(params, "eta", 1.55, what)?;
        let beta_m = self.float_param(params, "beta_m", 0.3, what)?;
        let beta_n = self.float_param(params, "beta_n", 0.3, what)?;
        let alpha_deg = self.float_param(params, "alpha", 2.0, what)?;
        if !(eta > 0.0 && eta.is_finite()) {
            return Err(loc.err(format!("{what}: eta {eta} must be > 0")));
        }
        for (n, v) in [("beta_m", beta_m), ("beta_n", beta_n)] {
            if !(0.0..=1.0).contains(&v) {
                return Err(loc.err(format!("{what}: {n} {v} must lie in [0, 1]")));
            }
        }
        if !alpha_deg.is_finite() {
            return Err(loc.err(format!("{what}: alpha {alpha_deg} must be finite")));
        }
        Ok(Material::Hair {
            absorption,
            eta,
            beta_m,
            beta_n,
            alpha_deg,
        })
    }

    /// Note the absorption parameters that lose to `winner` (pbrt-v4 warns about them).
    fn note_ignored(&mut self, params: &ParamList, names: &[&str], winner: &str, what: &str) {
        for n in names {
            if let Some(l) = params.ignore(n) {
                self.note(
                    &l,
                    format!("{what}: \"{n}\" ignored since \"{winner}\" is given"),
                );
            }
        }
    }
}
