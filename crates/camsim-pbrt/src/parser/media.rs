//! Participating media (pbrt-v4 4th ed. ch. 11; pbrt-v4 `media.cpp` `*Medium::Create` for the
//! parameter names and defaults): `MakeNamedMedium` of type `homogeneous`, `uniformgrid`,
//! `rgbgrid` and `cloud`, `MediumInterface` (scoped like the rest of the graphics state), the
//! camera's medium (the outside medium current at `Camera`), and the shapes' medium boundaries
//! ([`Material::MediumInterface`] wrappers, made when the scene is finished: media may be
//! defined after they are selected, as in pbrt-v4).
//!
//! Units as pbrt-v4 reads them: coefficients per scene unit (camsim's metre), `Le` an
//! illuminant normalised to luminance 1 (`Le / SpectrumToPhotometric(Le)`, the area lights'
//! rule), turned into W/(sr m^2 nm) by dividing by 683 lm/W (see [`crate`]).

use super::{lights::point3, SceneBuilder};
use crate::params::ParamList;
use crate::scene::Material;
use crate::spectra::{rgb_spectrum, SpectrumUse};
use crate::{Loc, PbrtError};
use camsim_core::units::LUMINOUS_EFFICACY_LM_PER_W;
use camsim_core::Spectrum;
use camsim_scene3d::media::{
    preset, preset_names, CloudMedium, Coefficients, GridMedium, GridSize, Media, Medium,
    MediumBox, MediumKind, RgbGridMedium, TemperatureGrid,
};
use std::collections::HashMap;
use std::path::Path;

/// The media a `MediumInterface` selects (pbrt-v4 graphics state `currentInsideMedium`,
/// `currentOutsideMedium`; the empty name is vacuum), and where.
#[derive(Debug, Clone)]
pub(super) struct MediumNames {
    pub inside: String,
    pub outside: String,
    pub loc: Loc,
}

/// Media read so far and what selects them.
#[derive(Debug, Default)]
pub(super) struct ParsedMedia {
    list: Vec<Medium>,
    names: HashMap<String, usize>,
    /// The graphics state's media at `Camera` (its outside medium is the camera's).
    pub camera: Option<MediumNames>,
    /// The `Integrator` type and where, for the note on how it is rendered.
    pub integrator: Option<(String, Loc)>,
    /// (material, inside, outside) -> its [`Material::MediumInterface`] wrapper.
    wrappers: HashMap<(usize, Option<usize>, Option<usize>), usize>,
}

/// A constant spectrum (pbrt-v4 `ConstantSpectrum`), held at every wavelength.
fn constant(v: f64) -> Spectrum {
    Spectrum::from_pairs(&[(300.0, v), (900.0, v)])
        .with_extrapolation(camsim_core::spectrum::Extrapolation::Hold)
}

impl ParsedMedia {
    /// The medium called `name` (`None` for the empty name, vacuum).
    fn resolve(&self, name: &str, loc: &Loc) -> Result<Option<usize>, PbrtError> {
        if name.is_empty() {
            return Ok(None);
        }
        match self.names.get(name) {
            Some(i) => Ok(Some(*i)),
            None => Err(loc.err(format!(
                "MediumInterface: medium \"{name}\" is not defined (no MakeNamedMedium \"{name}\")"
            ))),
        }
    }

    /// Material `material` of a shape with the media selection `sel`: wrapped in a
    /// [`Material::MediumInterface`] (shared by shapes with the same material and media) when
    /// the two sides differ, else unchanged (pbrt-v4 keeps the ray's medium at a surface that
    /// is not a medium transition).
    pub(super) fn wrap(
        &mut self,
        material: usize,
        sel: Option<&MediumNames>,
        materials: &mut Vec<Material>,
    ) -> Result<usize, PbrtError> {
        let Some(sel) = sel else {
            return Ok(material);
        };
        let inside = self.resolve(&sel.inside, &sel.loc)?;
        let outside = self.resolve(&sel.outside, &sel.loc)?;
        if inside == outside {
            return Ok(material);
        }
        Ok(*self
            .wrappers
            .entry((material, inside, outside))
            .or_insert_with(|| {
                materials.push(Material::MediumInterface {
                    material,
                    inside,
                    outside,
                });
                materials.len() - 1
            }))
    }

    /// The scene's media, after every shape was wrapped; notes how the integrator is
    /// rendered.
    pub(super) fn finish(self, notes: &mut Vec<String>) -> Result<Media, PbrtError> {
        let camera = match &self.camera {
            Some(sel) => self.resolve(&sel.outside, &sel.loc)?,
            None => None,
        };
        let used = camera.is_some() || !self.wrappers.is_empty();
        if let Some((ty, loc)) = &self.integrator {
            let how = match (ty.as_str(), used) {
                ("volpath" | "simplevolpath", true) => Some("camsim's volumetric path tracer (pbrt-v4 VolPathIntegrator: delta tracking with spectral MIS)".to_string()),
                ("volpath" | "simplevolpath", false) => Some("no participating medium is selected: camsim's path tracer (the same converged radiance)".to_string()),
                (_, true) => Some(format!("the scene has participating media: rendered with camsim's volumetric path tracer (pbrt-v4 \"volpath\"), not \"{ty}\"")),
                _ => None,
            };
            if let Some(how) = how {
                notes.push(format!("{}: Integrator \"{ty}\": {how}", loc.describe()));
            }
        }
        Ok(Media {
            list: self.list,
            camera,
        })
    }
}

impl SceneBuilder {
    /// `MakeNamedMedium "name" "string type" ...`: defined with the CTM current here (the
    /// medium's frame for bounded media) and the `Attribute "medium"` defaults.
    pub(super) fn make_named_medium(
        &mut self,
        name: String,
        params: &ParamList,
        loc: &Loc,
        file: &Path,
    ) -> Result<(), PbrtError> {
        if self.media.names.contains_key(&name) {
            return Err(loc.err(format!("MakeNamedMedium: medium \"{name}\" redefined")));
        }
        let ty = params.string("type")?.ok_or_else(|| {
            loc.err(format!(
                "MakeNamedMedium \"{name}\": no \"string type\" parameter"
            ))
        })?;
        let what = format!("MakeNamedMedium \"{name}\" (\"{ty}\")");
        let g = params.float("g", 0.0)?;
        if !(g > -1.0 && g < 1.0) {
            return Err(loc.err(format!(
                "{what}: g {g} must lie in (-1, 1) (Henyey-Greenstein)"
            )));
        }
        let kind = match ty.as_str() {
            "homogeneous" => self.homogeneous(params, &what, loc, file)?,
            "uniformgrid" => self.uniform_grid(params, &what, loc, file)?,
            "rgbgrid" => self.rgb_grid(params, &what, loc)?,
            "cloud" => self.cloud(params, &what, loc, file)?,
            "nanovdb" => {
                return Err(loc.err(format!(
                    "{what}: NanoVDB media are not supported (homogeneous, uniformgrid, rgbgrid, cloud)"
                )))
            }
            other => {
                return Err(loc.err(format!(
                    "MakeNamedMedium \"{name}\": unknown type \"{other}\" (homogeneous, uniformgrid, rgbgrid, cloud)"
                )))
            }
        };
        params.check_unused(&what)?;
        self.media.names.insert(name.clone(), self.media.list.len());
        self.media.list.push(Medium { name, g, kind });
        Ok(())
    }

    /// `MediumInterface "inside" ["outside"]` (one name sets both sides).
    pub(super) fn medium_interface(&mut self, inside: String, outside: String, loc: &Loc) {
        self.gs.medium = Some(MediumNames {
            inside,
            outside,
            loc: loc.clone(),
        });
    }

    /// `sigma_a`, `sigma_s` (unbounded spectra or RGB; default 1 per scene unit) or a
    /// `preset`, times `scale`.
    fn sigmas(
        &self,
        params: &ParamList,
        what: &str,
        loc: &Loc,
        file: &Path,
        allow_preset: bool,
    ) -> Result<(Spectrum, Spectrum), PbrtError> {
        let scale = params.float("scale", 1.0)?;
        if !(scale >= 0.0 && scale.is_finite()) {
            return Err(loc.err(format!("{what}: scale {scale} must be >= 0")));
        }
        let named = match allow_preset.then(|| params.string("preset")).transpose()? {
            Some(Some(p)) => Some(match preset(&p) {
                Some(Ok(m)) => {
                    let up = |rgb: [f64; 3]| {
                        rgb_spectrum(rgb, SpectrumUse::Unbounded)
                            .map(|s| s.spectrum)
                            .map_err(|e| loc.err(format!("{what}: preset \"{p}\": {e}")))
                    };
                    // pbrt-v4 GetMediumScatteringProperties: the table's numbers (mm^-1) as
                    // coefficients per scene unit, sigma_s = the reduced scattering.
                    (up(m.sigma_a_per_mm)?, up(m.sigma_s_prime_per_mm)?)
                }
                Some(Err(msg)) => return Err(loc.err(format!("{what}: {msg}"))),
                None => {
                    return Err(loc.err(format!(
                        "{what}: unknown preset \"{p}\" (camsim has {})",
                        preset_names()
                    )))
                }
            }),
            _ => None,
        };
        let (a, s) = match named {
            Some(v) => v,
            None => {
                let one = |n: &str| -> Result<Spectrum, PbrtError> {
                    Ok(self
                        .spectrum_param(params, n, SpectrumUse::Unbounded, file)?
                        .map_or_else(|| constant(1.0), |p| p.spectrum))
                };
                (one("sigma_a")?, one("sigma_s")?)
            }
        };
        for (sp, n) in [(&a, "sigma_a"), (&s, "sigma_s")] {
            if sp.values.iter().any(|v| !(v.is_finite() && *v >= 0.0)) {
                return Err(loc.err(format!(
                    "{what}: {n} must be finite and >= 0 at every wavelength"
                )));
            }
        }
        Ok((a.scaled(scale), s.scaled(scale)))
    }

    /// `Le` (an illuminant, normalised to luminance 1 as pbrt-v4 does) in W/(sr m^2 nm), and
    /// whether one was given with a positive value.
    fn emission(&self, params: &ParamList, file: &Path) -> Result<Option<Spectrum>, PbrtError> {
        Ok(self
            .spectrum_param(params, "Le", SpectrumUse::Illuminant, file)?
            .filter(|p| p.spectrum.max_value() > 0.0 && p.photometric > 0.0)
            .map(|p| {
                p.spectrum
                    .scaled(1.0 / (p.photometric * LUMINOUS_EFFICACY_LM_PER_W))
            }))
    }

    /// pbrt-v4 `HomogeneousMedium::Create`.
    fn homogeneous(
        &self,
        params: &ParamList,
        what: &str,
        loc: &Loc,
        file: &Path,
    ) -> Result<MediumKind, PbrtError> {
        let (a, s) = self.sigmas(params, what, loc, file, true)?;
        let le_scale = params.float("Lescale", 1.0)?;
        let le = self
            .emission(params, file)?
            .map(|l| l.scaled(le_scale))
            .filter(|_| le_scale > 0.0);
        Ok(MediumKind::Homogeneous(Coefficients {
            sigma_a_per_m: a,
            sigma_s_per_m: s,
            le,
        }))
    }

    /// The box `p0`, `p1` (default the unit cube) in the frame of the current CTM.
    fn medium_box(
        &self,
        params: &ParamList,
        what: &str,
        loc: &Loc,
    ) -> Result<MediumBox, PbrtError> {
        let p0 = point3(params, "p0", [0.0; 3])?;
        let p1 = point3(params, "p1", [1.0; 3])?;
        if !(0..3).all(|k| p0[k] < p1[k]) {
            return Err(loc.err(format!("{what}: the box p0 {p0:?} .. p1 {p1:?} is empty")));
        }
        let medium_from_world = crate::xform::inverse(&self.gs.ctm)
            .ok_or_else(|| loc.err(format!("{what}: the current transform is singular")))?;
        Ok(MediumBox {
            p0,
            p1,
            medium_from_world,
        })
    }

    /// `nx`, `ny`, `nz` (default 1) for `n` samples.
    fn grid_size(
        params: &ParamList,
        n: usize,
        what: &str,
        loc: &Loc,
    ) -> Result<GridSize, PbrtError> {
        let mut d = [0usize; 3];
        for (k, name) in ["nx", "ny", "nz"].iter().enumerate() {
            let v = params.int(name, 1)?;
            if !(1..=1 << 16).contains(&v) {
                return Err(loc.err(format!("{what}: {name} {v} must be between 1 and 65536")));
            }
            d[k] = v as usize;
        }
        let size = GridSize {
            nx: d[0],
            ny: d[1],
            nz: d[2],
        };
        if size.count() != n {
            return Err(loc.err(format!(
                "{what}: {n} values but nx ny nz = {} x {} x {} = {}",
                size.nx,
                size.ny,
                size.nz,
                size.count()
            )));
        }
        Ok(size)
    }

    /// pbrt-v4 `GridMedium::Create` (`uniformgrid`).
    fn uniform_grid(
        &self,
        params: &ParamList,
        what: &str,
        loc: &Loc,
        file: &Path,
    ) -> Result<MediumKind, PbrtError> {
        let floats = |n: &str| -> Result<Option<Vec<f32>>, PbrtError> {
            match params.get(n, &["float"])? {
                None => Ok(None),
                Some(p) => {
                    let v = p.nums()?;
                    if v.iter()
                        .any(|x| !(x.is_finite() && *x >= 0.0) && n != "temperature")
                    {
                        return Err(p.loc.err(format!(
                            "{what}: \"{n}\" has a negative or non-finite value"
                        )));
                    }
                    Ok(Some(v.into_iter().map(|x| x as f32).collect()))
                }
            }
        };
        let density =
            floats("density")?.ok_or_else(|| loc.err(format!("{what}: no \"density\" values")))?;
        let size = Self::grid_size(params, density.len(), what, loc)?;
        let temperature = floats("temperature")?;
        if let Some(t) = &temperature {
            if t.len() != density.len() {
                return Err(loc.err(format!(
                    "{what}: {} \"temperature\" values for {} \"density\" values",
                    t.len(),
                    density.len()
                )));
            }
        }
        let le = self.emission(params, file)?;
        if le.is_some() && temperature.is_some() {
            return Err(loc.err(format!(
                "{what}: give \"Le\" or \"temperature\", not both (as pbrt-v4)"
            )));
        }
        let le_scale = match floats("Lescale")? {
            None => vec![1.0],
            Some(v) if v.len() == size.count() => v,
            Some(v) => {
                return Err(loc.err(format!(
                    "{what}: {} \"Lescale\" values; expected {}",
                    v.len(),
                    size.count()
                )))
            }
        };
        let bounds = self.medium_box(params, what, loc)?;
        let (a, s) = self.sigmas(params, what, loc, file, false)?;
        let offset_k = match params.float_opt("temperatureoffset")? {
            Some(v) => v,
            None => params.float("temperaturecutoff", 0.0)?,
        };
        let t_scale = params.float("temperaturescale", 1.0)?;
        Ok(MediumKind::UniformGrid(Box::new(GridMedium {
            bounds,
            size,
            coefficients: Coefficients {
                sigma_a_per_m: a,
                sigma_s_per_m: s,
                le,
            },
            density,
            le_scale,
            temperature: temperature.map(|values| TemperatureGrid {
                values,
                offset_k,
                scale: t_scale,
            }),
        })))
    }

    /// pbrt-v4 `RGBGridMedium::Create` (`rgbgrid`).
    fn rgb_grid(&self, params: &ParamList, what: &str, loc: &Loc) -> Result<MediumKind, PbrtError> {
        let rgbs = |n: &str| -> Result<Option<Vec<[f32; 3]>>, PbrtError> {
            match params.tuples(n, &["rgb"], 3)? {
                None => Ok(None),
                Some(v) => {
                    if v.iter().flatten().any(|x| !(x.is_finite() && *x >= 0.0)) {
                        return Err(loc.err(format!(
                            "{what}: \"{n}\" has a negative or non-finite value"
                        )));
                    }
                    Ok(Some(
                        v.iter()
                            .map(|c| [c[0] as f32, c[1] as f32, c[2] as f32])
                            .collect(),
                    ))
                }
            }
        };
        let (sigma_a, sigma_s, le) = (rgbs("sigma_a")?, rgbs("sigma_s")?, rgbs("Le")?);
        let n = match (&sigma_a, &sigma_s) {
            (Some(a), Some(s)) if a.len() != s.len() => {
                return Err(loc.err(format!(
                    "{what}: {} \"sigma_a\" values but {} \"sigma_s\" values",
                    a.len(),
                    s.len()
                )))
            }
            (Some(a), _) => a.len(),
            (None, Some(s)) => s.len(),
            (None, None) => {
                return Err(loc.err(format!(
                    "{what}: needs \"rgb sigma_a\" and/or \"rgb sigma_s\" values"
                )))
            }
        };
        if let Some(l) = &le {
            if sigma_a.is_none() || l.len() != n {
                return Err(loc.err(format!(
                    "{what}: \"Le\" needs \"sigma_a\" and one value per sample ({n})"
                )));
            }
        }
        let size = Self::grid_size(params, n, what, loc)?;
        let bounds = self.medium_box(params, what, loc)?;
        let le_scale = params.float("Lescale", 1.0)?;
        let sigma_scale = params.float("scale", 1.0)?;
        if !(sigma_scale >= 0.0 && sigma_scale.is_finite() && le_scale.is_finite()) {
            return Err(loc.err(format!("{what}: scale {sigma_scale} must be >= 0")));
        }
        // pbrt-v4 RGBIlluminantSpectrum: the colour space's illuminant (not normalised by its
        // photometric value for this medium), times Lescale; camsim's unit: / 683.
        let illuminant = crate::spectra::srgb_illuminant()
            .clone()
            .scaled(le_scale.max(0.0) / LUMINOUS_EFFICACY_LM_PER_W);
        Ok(MediumKind::RgbGrid(Box::new(RgbGridMedium {
            bounds,
            size,
            sigma_a,
            sigma_s,
            sigma_scale_per_m: sigma_scale,
            le: le.filter(|_| le_scale > 0.0),
            illuminant,
        })))
    }

    /// pbrt-v4 `CloudMedium::Create` (`cloud`).
    fn cloud(
        &self,
        params: &ParamList,
        what: &str,
        loc: &Loc,
        file: &Path,
    ) -> Result<MediumKind, PbrtError> {
        let density = params.float("density", 1.0)?;
        let wispiness = params.float("wispiness", 1.0)?;
        let frequency = params.float("frequency", 5.0)?;
        if ![density, wispiness, frequency]
            .iter()
            .all(|v| v.is_finite())
            || density < 0.0
        {
            return Err(loc.err(format!(
                "{what}: density {density}, wispiness {wispiness} and frequency {frequency} must be finite, density >= 0"
            )));
        }
        let one = |n: &str| -> Result<Spectrum, PbrtError> {
            let s = self
                .spectrum_param(params, n, SpectrumUse::Unbounded, file)?
                .map_or_else(|| constant(1.0), |p| p.spectrum);
            if s.values.iter().any(|v| !(v.is_finite() && *v >= 0.0)) {
                return Err(loc.err(format!("{what}: {n} must be finite and >= 0")));
            }
            Ok(s)
        };
        Ok(MediumKind::Cloud(Box::new(CloudMedium {
            bounds: self.medium_box(params, what, loc)?,
            sigma_a_per_m: one("sigma_a")?,
            sigma_s_per_m: one("sigma_s")?,
            density,
            wispiness,
            frequency,
        })))
    }
}
