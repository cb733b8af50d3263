//! `Material` and `MakeNamedMaterial`: pbrt-v4's materials with its parameter names and
//! defaults (pbrt-v4 file format, "Materials"; `materials.cpp` `*Material::Create`).

use super::super::params::ParamList;
use super::super::spectra::{param_spectrum, SpectrumUse};
use super::super::{Loc, PbrtError};
use super::textures::flat;
use super::{load_image, Encoding, SceneBuilder};
use crate::scene::{
    ConductorOptics, FloatTexture, LayerWalk, Material, NormalMapImage, NormalPerturbation,
    Roughness, Texture,
};
use camsim_core::Spectrum;
use std::path::Path;

/// Materials camsim reads.
pub(super) const SUPPORTED: &str = "diffuse, conductor, dielectric, thindielectric, diffusetransmission, coateddiffuse, coatedconductor, hair, mix, interface";

impl SceneBuilder {
    /// A float parameter that pbrt-v4 also accepts as a float texture: a number or the name of a
    /// `constant` float texture (read by the texture helper); other float textures are refused
    /// (camsim's materials take these parameters per material, not per hit).
    pub(super) fn float_param(
        &self,
        params: &ParamList,
        name: &str,
        default: f64,
        what: &str,
    ) -> Result<f64, PbrtError> {
        let Some(p) = params.get(name, &["float", "texture"])? else {
            return Ok(default);
        };
        match self.float_texture_param(params, name, default)? {
            FloatTexture::Constant(v) => Ok(v),
            _ => Err(p.loc.err(format!(
                "{what}: \"{name}\" as a varying float texture is not supported (give a number or a constant texture)"
            ))),
        }
    }

    /// `roughness`, `uroughness`, `vroughness`, `remaproughness` (pbrt-v4: u and v default to
    /// `roughness`, which defaults to 0; remap defaults to true).
    /// Any of them may be a float texture (pbrt-v4 evaluates them per hit): then the material's
    /// own roughness is a placeholder and `self.varying` holds the textures, which
    /// [`SceneBuilder::material`] turns into a [`Material::VaryingRoughness`] around the material.
    fn roughness(
        &mut self,
        params: &ParamList,
        what: &str,
        loc: &Loc,
    ) -> Result<Roughness, PbrtError> {
        let r = self.float_texture_param(params, "roughness", 0.0)?;
        let u = match params.get("uroughness", &["float", "texture"])? {
            Some(_) => self.float_texture_param(params, "uroughness", 0.0)?,
            None => r.clone(),
        };
        let v = match params.get("vroughness", &["float", "texture"])? {
            Some(_) => self.float_texture_param(params, "vroughness", 0.0)?,
            None => r,
        };
        let remap = params.bool("remaproughness", true)?;
        match (&u, &v) {
            (FloatTexture::Constant(u), FloatTexture::Constant(v)) => {
                for x in [*u, *v] {
                    if !(x >= 0.0) {
                        return Err(loc.err(format!("{what}: roughness {x} must be >= 0")));
                    }
                }
                Ok(Roughness {
                    u: *u,
                    v: *v,
                    remap,
                })
            }
            _ => {
                self.varying = Some((u, v, remap));
                Ok(Roughness::SMOOTH)
            }
        }
    }

    /// An index of refraction: `float eta` or a spectrum (`spectrum eta "glass-BK7"`, inline
    /// pairs, a file, or rgb); `default` if absent.
    fn eta_param(
        &self,
        params: &ParamList,
        file: &Path,
        default: f64,
        what: &str,
    ) -> Result<Spectrum, PbrtError> {
        match params.get("eta", &["float", "spectrum", "rgb", "texture"])? {
            None => Ok(flat(default)),
            Some(p) if p.ty == "texture" => Err(p
                .loc
                .err(format!("{what}: \"eta\" as a texture is not supported"))),
            Some(p) if p.ty == "float" => {
                let v = p.nums()?;
                match v.as_slice() {
                    [x] if *x > 0.0 => Ok(flat(*x)),
                    _ => Err(p
                        .loc
                        .err(format!("{what}: \"eta\" needs one positive value"))),
                }
            }
            Some(p) => {
                let resolve = |n: &str| self.resolve(file, n);
                let s = param_spectrum(p, SpectrumUse::Unbounded, &resolve)?.spectrum;
                if s.values.iter().any(|v| !(*v > 0.0)) {
                    return Err(p.loc.err(format!(
                        "{what}: \"eta\" must be positive at every wavelength"
                    )));
                }
                Ok(s)
            }
        }
    }

    /// A conductor's optical constants: spectra `eta_name` and `k_name` (pbrt-v4's copper where
    /// absent) or a `reflectance`, not both (pbrt-v4 `conductor` and `coatedconductor`).
    fn conductor_optics(
        &self,
        params: &ParamList,
        file: &Path,
        loc: &Loc,
        eta_name: &str,
        k_name: &str,
        what: &str,
    ) -> Result<ConductorOptics, PbrtError> {
        let eta = self.conductor_spectrum(params, eta_name, file, "metal-Cu-eta")?;
        let k = self.conductor_spectrum(params, k_name, file, "metal-Cu-k")?;
        let refl = params
            .get("reflectance", &["rgb", "spectrum", "blackbody", "texture"])?
            .map(|p| p.loc.clone());
        Ok(match (refl, eta, k) {
            (Some(l), e, k) if e.is_some() || k.is_some() => {
                return Err(l.err(format!("{what}: give either \"reflectance\" or \"{eta_name}\" and \"{k_name}\", not both")));
            }
            (Some(_), _, _) => ConductorOptics::Reflectance(self.spectrum_texture(
                params,
                "reflectance",
                file,
                0.0,
            )?),
            (None, e, k) => {
                let named = |n: &str| {
                    super::super::optical_constants::named(n)
                        .ok_or_else(|| loc.err(format!("built-in spectrum {n} missing")))
                };
                ConductorOptics::EtaK {
                    eta: match e {
                        Some(s) => s,
                        None => named("metal-Cu-eta")?,
                    },
                    k: match k {
                        Some(s) => s,
                        None => named("metal-Cu-k")?,
                    },
                }
            }
        })
    }

    /// A spectrum parameter of a conductor (`eta` or `k`), or `default_name` (pbrt-v4's copper).
    fn conductor_spectrum(
        &self,
        params: &ParamList,
        name: &str,
        file: &Path,
        default_name: &str,
    ) -> Result<Option<Spectrum>, PbrtError> {
        match params.get(name, &["float", "spectrum", "rgb", "texture"])? {
            None => Ok(None),
            Some(p) if p.ty == "texture" => Err(p.loc.err(format!(
                "material \"conductor\": \"{name}\" as a texture is not supported"
            ))),
            Some(p) if p.ty == "float" => {
                let v = p.nums()?;
                match v.as_slice() {
                    [x] if *x >= 0.0 => Ok(Some(flat(*x))),
                    _ => Err(p.loc.err(format!(
                        "material \"conductor\": \"{name}\" needs one value >= 0"
                    ))),
                }
            }
            Some(p) => {
                let resolve = |n: &str| self.resolve(file, n);
                let s = param_spectrum(p, SpectrumUse::Unbounded, &resolve)?.spectrum;
                if s.values.iter().any(|v| !(*v >= 0.0)) {
                    return Err(p.loc.err(format!(
                        "material \"conductor\": \"{name}\" must be >= 0 (default {default_name})"
                    )));
                }
                Ok(Some(s))
            }
        }
    }

    /// A spectrum texture parameter (`reflectance`, `transmittance`: a value or any spectrum
    /// texture, see `textures.rs`) or a constant default.
    fn spectrum_texture(
        &self,
        params: &ParamList,
        name: &str,
        file: &Path,
        default: f64,
    ) -> Result<Texture, PbrtError> {
        Ok(self
            .spectrum_texture_param(params, name, file)?
            .unwrap_or_else(|| Texture::Constant(flat(default))))
    }

    /// The layered BSDF's random walk (pbrt-v4 `CoatedDiffuseMaterial::Create` and
    /// `CoatedConductorMaterial::Create`): `albedo` (spectrum texture, default 0), `g` (default 0),
    /// `maxdepth` (default 10), `nsamples` (default 1).
    fn layer_walk(
        &self,
        params: &ParamList,
        file: &Path,
        what: &str,
        loc: &Loc,
    ) -> Result<LayerWalk, PbrtError> {
        let albedo = self.spectrum_texture(params, "albedo", file, 0.0)?;
        // Errors point at the parameter when it is given, else at the material.
        let at = |name: &str, types: &[&str]| -> Result<Loc, PbrtError> {
            Ok(params
                .get(name, types)?
                .map(|p| p.loc.clone())
                .unwrap_or_else(|| loc.clone()))
        };
        let g = self.float_param(params, "g", 0.0, what)?;
        if !(g > -1.0 && g < 1.0) {
            return Err(at("g", &["float", "texture"])?
                .err(format!("{what}: \"g\" {g} must lie in (-1, 1)")));
        }
        let max_depth = params.int("maxdepth", 10)?;
        if !(0..=100_000).contains(&max_depth) {
            return Err(at("maxdepth", &["integer"])?.err(format!(
                "{what}: \"maxdepth\" {max_depth} must lie in 0..=100000"
            )));
        }
        let n_samples = params.int("nsamples", 1)?;
        if !(1..=10_000).contains(&n_samples) {
            return Err(at("nsamples", &["integer"])?.err(format!(
                "{what}: \"nsamples\" {n_samples} must lie in 1..=10000"
            )));
        }
        Ok(LayerWalk {
            albedo,
            g,
            max_depth: max_depth as u32,
            n_samples: n_samples as u32,
        })
    }

    /// Build a material of type `ty` from its parameters.
    pub(super) fn material(
        &mut self,
        ty: &str,
        params: &ParamList,
        loc: &Loc,
        file: &Path,
    ) -> Result<Material, PbrtError> {
        let what = format!("material \"{ty}\"");
        // Bump and normal maps on the materials pbrt-v4 gives them to; on the others (`mix`,
        // `interface`) they stay unused, an error as in pbrt-v4.
        let perturbation = match ty {
            "diffuse"
            | "conductor"
            | "dielectric"
            | "thindielectric"
            | "diffusetransmission"
            | "coateddiffuse"
            | "coatedconductor" => self.normal_perturbation(params, loc, file, &what)?,
            _ => None,
        };
        params.get("type", &["string"])?;
        self.varying = None;
        let m = match ty {
            "diffuse" => Material::Diffuse {
                reflectance: self.spectrum_texture(params, "reflectance", file, 0.5)?,
            },
            "conductor" => {
                let optics = self.conductor_optics(params, file, loc, "eta", "k", &what)?;
                Material::Conductor {
                    optics,
                    roughness: self.roughness(params, &what, loc)?,
                }
            }
            "dielectric" => Material::Dielectric {
                eta: self.eta_param(params, file, 1.5, &what)?,
                roughness: self.roughness(params, &what, loc)?,
            },
            "thindielectric" => Material::ThinDielectric {
                eta: self.eta_param(params, file, 1.5, &what)?,
            },
            "diffusetransmission" => Material::DiffuseTransmission {
                reflectance: self.spectrum_texture(params, "reflectance", file, 0.25)?,
                transmittance: self.spectrum_texture(params, "transmittance", file, 0.25)?,
                scale: self.float_param(params, "scale", 1.0, &what)?,
            },
            "coateddiffuse" => {
                let reflectance = self.spectrum_texture(params, "reflectance", file, 0.5)?;
                let roughness = self.roughness(params, &what, loc)?;
                let thickness = self.float_param(params, "thickness", 0.01, &what)?;
                let eta_s = self.eta_param(params, file, 1.5, &what)?;
                let eta = eta_s.eval(550.0);
                if eta_s
                    .values
                    .iter()
                    .any(|v| (v - eta_s.values[0]).abs() > 1e-9)
                {
                    self.note(
                        loc,
                        format!("{what}: a wavelength-dependent eta is taken at 550 nm ({eta:.4})"),
                    );
                }
                let walk = self.layer_walk(params, file, &what, loc)?;
                if !(thickness >= 0.0) {
                    return Err(loc.err(format!("{what}: thickness {thickness} must be >= 0")));
                }
                Material::CoatedDiffuse {
                    reflectance,
                    roughness,
                    eta,
                    thickness,
                    walk,
                }
            }
            "coatedconductor" => {
                // pbrt-v4 CoatedConductorMaterial::Create: interface.{u,v}roughness (default
                // interface.roughness, 0), interface.eta 1.5, thickness 0.01, conductor.eta/k
                // (default copper) or reflectance, conductor.{u,v}roughness (default 0).
                let rough = |p: &str, loc: &Loc| -> Result<Roughness, PbrtError> {
                    let r = self.float_param(params, &format!("{p}.roughness"), 0.0, &what)?;
                    let u = self.float_param(params, &format!("{p}.uroughness"), r, &what)?;
                    let v = self.float_param(params, &format!("{p}.vroughness"), r, &what)?;
                    if !(u >= 0.0 && v >= 0.0) {
                        return Err(
                            loc.err(format!("{what}: {p} roughness ({u}, {v}) must be >= 0"))
                        );
                    }
                    Ok(Roughness { u, v, remap: true })
                };
                let mut interface_roughness = rough("interface", loc)?;
                let mut conductor_roughness = rough("conductor", loc)?;
                let remap = params.bool("remaproughness", true)?;
                interface_roughness.remap = remap;
                conductor_roughness.remap = remap;
                let thickness = self.float_param(params, "thickness", 0.01, &what)?;
                if !(thickness >= 0.0) {
                    return Err(loc.err(format!("{what}: thickness {thickness} must be >= 0")));
                }
                let ieta = match params.get("interface.eta", &["float", "spectrum"])? {
                    None => 1.5,
                    Some(p) if p.ty == "float" => match p.nums()?.as_slice() {
                        [x] if *x > 0.0 => *x,
                        _ => {
                            return Err(p
                                .loc
                                .err(format!("{what}: \"interface.eta\" needs one value > 0")))
                        }
                    },
                    Some(p) => {
                        let resolve = |n: &str| self.resolve(file, n);
                        let s = param_spectrum(p, SpectrumUse::Unbounded, &resolve)?.spectrum;
                        let e = s.eval(550.0);
                        self.note(&p.loc, format!("{what}: a wavelength-dependent interface.eta is taken at 550 nm ({e:.4})"));
                        e
                    }
                };
                let conductor = self.conductor_optics(
                    params,
                    file,
                    loc,
                    "conductor.eta",
                    "conductor.k",
                    &what,
                )?;
                let walk = self.layer_walk(params, file, &what, loc)?;
                Material::CoatedConductor {
                    interface_eta: ieta,
                    interface_roughness,
                    thickness,
                    conductor,
                    conductor_roughness,
                    walk,
                }
            }
            "mix" => {
                let p = params.get("materials", &["string"])?.ok_or_else(|| {
                    loc.err("material \"mix\": needs \"string materials\" [ \"a\" \"b\" ]")
                })?;
                let names = p.strings()?;
                let [a, b] = names.as_slice() else {
                    return Err(p.loc.err(format!(
                        "material \"mix\": \"materials\" needs two names, got {}",
                        names.len()
                    )));
                };
                let idx = |n: &String| {
                    self.named_materials.get(n).copied().ok_or_else(|| {
                        p.loc.err(format!("material \"mix\": no named material \"{n}\" (MakeNamedMaterial it before the mix)"))
                    })
                };
                let materials = [idx(a)?, idx(b)?];
                // As pbrt-v4: a mix chooses between surfaces, not between a surface and none.
                for (n, &i) in [a, b].into_iter().zip(&materials) {
                    if matches!(self.materials[i], Material::Interface) {
                        return Err(p.loc.err(format!(
                            "material \"mix\": \"{n}\" is an \"interface\" material, which cannot be mixed"
                        )));
                    }
                }
                let amount = self.float_param(params, "amount", 0.5, &what)?;
                Material::Mix { materials, amount }
            }
            "hair" => self.hair_material(params, file, loc, &what)?,
            "interface" => Material::Interface,
            "" | "none" => Material::Interface,
            _ => {
                return Err(loc.err(format!(
                    "material type \"{ty}\" is not supported (camsim supports {SUPPORTED})"
                )));
            }
        };
        params.check_unused(&what)?;
        // Roughness textures: the material as read is the base of a per-hit roughness wrapper.
        let m = match self.varying.take() {
            Some((u, v, remap)) => {
                self.materials.push(m);
                Material::VaryingRoughness {
                    material: self.materials.len() - 1,
                    u,
                    v,
                    remap,
                }
            }
            None => m,
        };
        // A bump or normal map wraps the whole material (its shading normal, per hit).
        Ok(match perturbation {
            Some(perturbation) => {
                self.materials.push(m);
                Material::Bumped {
                    material: self.materials.len() - 1,
                    perturbation,
                }
            }
            None => m,
        })
    }

    /// pbrt-v4's `normalmap` (an image file, read with a linear encoding and cached by path)
    /// or `displacement` (a float texture; pbrt-v3's name `bumpmap` is renamed to it, as
    /// pbrt-v4's parser does). With both, the normal map wins (pbrt-v4 `GetBSDF`); a constant
    /// zero displacement is none.
    fn normal_perturbation(
        &mut self,
        params: &ParamList,
        loc: &Loc,
        file: &Path,
        what: &str,
    ) -> Result<Option<NormalPerturbation>, PbrtError> {
        let disp_name = match (
            params.get("displacement", &["float", "texture"])?,
            params.get("bumpmap", &["float", "texture"])?,
        ) {
            (Some(_), Some(p)) => {
                return Err(p.loc.err(format!(
                    "{what}: give \"displacement\" or its old name \"bumpmap\", not both"
                )))
            }
            (Some(_), None) => Some("displacement"),
            (None, Some(_)) => Some("bumpmap"),
            (None, None) => None,
        };
        let displacement = match disp_name {
            Some(n) => Some(self.float_texture_param(params, n, 0.0)?),
            None => None,
        };
        if let Some(fname) = params.string("normalmap")?.filter(|f| !f.is_empty()) {
            let path = self.resolve(file, &fname);
            let image = match self.normal_maps.get(&path) {
                Some(im) => im.clone(),
                None => {
                    let (width, height, rgb) = load_image(&path, Encoding::Linear)
                        .map_err(|e| loc.err(format!("{what}: normalmap: {e}")))?;
                    let im = std::sync::Arc::new(NormalMapImage {
                        width,
                        height,
                        rgb,
                        uv1: false,
                    });
                    self.normal_maps.insert(path, im.clone());
                    im
                }
            };
            if displacement.is_some() {
                self.note(
                    loc,
                    format!("{what}: \"normalmap\" used, displacement ignored (pbrt-v4 applies the normal map when both are given)"),
                );
            }
            return Ok(Some(NormalPerturbation::NormalMap(image)));
        }
        Ok(match displacement {
            None | Some(FloatTexture::Constant(0.0)) => None,
            Some(t) => Some(NormalPerturbation::Displacement(t)),
        })
    }
}
