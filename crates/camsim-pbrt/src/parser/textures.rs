//! `Texture`: pbrt-v4 spectrum and float textures `constant`, `imagemap`, `checkerboard` (2D),
//! `scale`, `mix`, `directionmix`, `bilerp`, `dots`, and the solid noises `fbm`, `wrinkled`,
//! `windy` (float) and `marble` (spectrum), with pbrt-v4's parameter names and defaults
//! (pbrt-v4 `textures.cpp`, `*Texture::Create`), and the helpers materials use to read a
//! spectrum- or float-texture parameter.

use super::{load_image, SceneBuilder};
use crate::params::ParamList;
use crate::scene::{
    FloatTexture, MappingKind, NoiseKind, NoiseTexture, PlanarMapping, TexelFilter, Texture,
    Transform, UvMapping, WrapMode,
};
use crate::spectra::{param_spectrum, SpectrumUse};
use crate::{Loc, PbrtError};
use camsim_core::Spectrum;
use std::path::Path;

/// The float texture classes read here (for messages).
const FLOAT_CLASSES: &str = "constant, imagemap, checkerboard, scale, mix, directionmix, bilerp, dots, fbm, wrinkled, windy";
/// The spectrum texture classes read here (for messages).
const SPECTRUM_CLASSES: &str =
    "constant, imagemap, checkerboard, scale, mix, directionmix, bilerp, dots, marble";

/// An image texture's width, height, texels, mapping, wrap mode and texel filter.
type ImageMap = (
    usize,
    usize,
    Vec<[f32; 3]>,
    UvMapping,
    WrapMode,
    TexelFilter,
);

/// Whether an image texture is inverted (`bool invert`, already read and checked).
fn invert_clamps(params: &ParamList) -> bool {
    params.bool("invert", false).unwrap_or(false)
}

/// A constant spectrum `v` at every wavelength.
pub(crate) fn flat(v: f64) -> Spectrum {
    Spectrum::from_pairs(&[(360.0, v), (830.0, v)])
        .with_extrapolation(camsim_core::spectrum::Extrapolation::Hold)
}

impl SceneBuilder {
    /// A spectrum-texture parameter: `rgb`/`spectrum`/`blackbody` value (reflectance use, so
    /// RGB above 1 is an error as in pbrt-v4) or `texture` name; `None` if absent.
    pub(crate) fn spectrum_texture_param(
        &self,
        params: &ParamList,
        name: &str,
        file: &Path,
    ) -> Result<Option<Texture>, PbrtError> {
        let Some(p) = params.get(name, &["rgb", "spectrum", "blackbody", "texture"])? else {
            return Ok(None);
        };
        if p.ty == "texture" {
            let names = p.strings()?;
            let [tname] = names.as_slice() else {
                return Err(p
                    .loc
                    .err(format!("\"texture {name}\" needs one texture name")));
            };
            return self.textures.get(tname).cloned().map(Some).ok_or_else(|| {
                if self.float_textures.contains_key(tname) {
                    p.loc.err(format!("texture \"{tname}\" is a float texture; \"{name}\" needs a spectrum texture"))
                } else {
                    p.loc.err(format!("no spectrum texture named \"{tname}\" (textures must be defined before use)"))
                }
            });
        }
        let resolve = |n: &str| self.resolve(file, n);
        Ok(Some(Texture::Constant(
            param_spectrum(p, SpectrumUse::Albedo, &resolve)?.spectrum,
        )))
    }

    /// A float-texture parameter: `float` value or `texture` name, `default` if absent.
    pub(crate) fn float_texture_param(
        &self,
        params: &ParamList,
        name: &str,
        default: f64,
    ) -> Result<FloatTexture, PbrtError> {
        let Some(p) = params.get(name, &["float", "texture"])? else {
            return Ok(FloatTexture::Constant(default));
        };
        if p.ty == "texture" {
            let names = p.strings()?;
            let [tname] = names.as_slice() else {
                return Err(p
                    .loc
                    .err(format!("\"texture {name}\" needs one texture name")));
            };
            return self.float_textures.get(tname).cloned().ok_or_else(|| {
                if self.textures.contains_key(tname) {
                    p.loc.err(format!("texture \"{tname}\" is a spectrum texture; \"{name}\" needs a float texture"))
                } else {
                    p.loc.err(format!("no float texture named \"{tname}\" (textures must be defined before use)"))
                }
            });
        }
        match p.nums()?.as_slice() {
            [v] => Ok(FloatTexture::Constant(*v)),
            v => Err(p
                .loc
                .err(format!("\"float {name}\" needs one value, got {}", v.len()))),
        }
    }

    fn uv_mapping(
        &self,
        name: &str,
        params: &ParamList,
        loc: &Loc,
    ) -> Result<UvMapping, PbrtError> {
        // pbrt-v4 TextureMapping2D::Create: "uv" (default), "spherical", "cylindrical", "planar".
        let mapping = params.string("mapping")?.unwrap_or_else(|| "uv".into());
        let what = format!("Texture \"{name}\"");
        let kind = match mapping.as_str() {
            "uv" => {
                return Ok(UvMapping {
                    uscale: params.float("uscale", 1.0)?,
                    vscale: params.float("vscale", 1.0)?,
                    udelta: params.float("udelta", 0.0)?,
                    vdelta: params.float("vdelta", 0.0)?,
                    kind: MappingKind::Uv,
                })
            }
            "spherical" => MappingKind::Spherical {
                texture_from_world: Box::new(self.texture_from_world(loc, &what)?),
            },
            "cylindrical" => MappingKind::Cylindrical {
                texture_from_world: Box::new(self.texture_from_world(loc, &what)?),
            },
            "planar" => {
                let v = |n: &str, d: [f64; 3]| -> Result<[f64; 3], PbrtError> {
                    match params.get(n, &["vector3", "vector"])? {
                        None => Ok(d),
                        Some(p) => match p.nums()?.as_slice() {
                            [x, y, z] if [x, y, z].iter().all(|c| c.is_finite()) => {
                                Ok([*x, *y, *z])
                            }
                            v => Err(p.loc.err(format!(
                                "{what}: \"vector3 {n}\" needs 3 finite numbers, got {v:?}"
                            ))),
                        },
                    }
                };
                MappingKind::Planar(Box::new(PlanarMapping {
                    texture_from_world: self.texture_from_world(loc, &what)?,
                    v1: v("v1", [1.0, 0.0, 0.0])?,
                    v2: v("v2", [0.0, 1.0, 0.0])?,
                }))
            }
            _ => {
                return Err(loc.err(format!(
                    "{what}: mapping \"{mapping}\" is not one of uv, spherical, cylindrical, planar"
                )))
            }
        };
        let (udelta, vdelta) = match &kind {
            MappingKind::Planar(_) => (params.float("udelta", 0.0)?, params.float("vdelta", 0.0)?),
            _ => (0.0, 0.0),
        };
        Ok(UvMapping {
            uscale: 1.0,
            vscale: 1.0,
            udelta,
            vdelta,
            kind,
        })
    }

    /// pbrt-v4 image texture parameters and texels: (width, height, linear rgb * scale,
    /// inverted if asked, not clamped), mapping.
    fn imagemap(
        &mut self,
        name: &str,
        params: &ParamList,
        loc: &Loc,
        file: &Path,
    ) -> Result<ImageMap, PbrtError> {
        let what = format!("Texture \"{name}\"");
        let fname = params
            .string("filename")?
            .ok_or_else(|| loc.err(format!("{what}: imagemap needs \"string filename\"")))?;
        let path = self.resolve(file, &fname);
        let encoding = self.image_encoding(&fname, params, loc, &what)?;
        let scale = params.float("scale", 1.0)? as f32;
        let invert = params.bool("invert", false)?;
        let mapping = self.uv_mapping(name, params, loc)?;
        let wrap_name = params.string("wrap")?.unwrap_or_else(|| "repeat".into());
        let wrap = WrapMode::from_name(&wrap_name).ok_or_else(|| {
            loc.err(format!(
                "{what}: wrap \"{wrap_name}\" is not one of repeat, clamp, black, octahedralsphere"
            ))
        })?;
        if wrap == WrapMode::OctahedralSphere && !matches!(mapping.kind, MappingKind::Uv) {
            self.note(
                loc,
                format!("{what}: wrap \"octahedralsphere\" with a non-uv mapping"),
            );
        }
        let filter_name = params
            .string("filter")?
            .unwrap_or_else(|| "bilinear".into());
        let mut filter = TexelFilter::from_name(&filter_name).ok_or_else(|| {
            loc.err(format!(
                "{what}: filter \"{filter_name}\" is not one of point, bilinear, trilinear, ewa"
            ))
        })?;
        // pbrt-v4 `maxanisotropy` (default 8): read by `ewa` alone.
        let max_anisotropy = params.float("maxanisotropy", 8.0)?;
        if !(max_anisotropy.is_finite() && max_anisotropy >= 1.0) {
            return Err(loc.err(format!(
                "{what}: \"maxanisotropy\" {max_anisotropy} must be a number >= 1"
            )));
        }
        if let TexelFilter::Ewa { max_anisotropy: m } = &mut filter {
            *m = max_anisotropy as f32;
        }
        params.check_unused("Texture \"imagemap\"")?;
        let (width, height, mut rgb) =
            load_image(&path, encoding).map_err(|e| loc.err(format!("{what}: {e}")))?;
        // pbrt-v4 `*ImageTexture::Evaluate`: scale, then 1 - v if inverted (applied per texel
        // here: the same after bilinear weights that sum to 1, i.e. for every wrap but black).
        for c in rgb.iter_mut().flatten() {
            let v = *c * scale;
            *c = if invert { 1.0 - v } else { v };
        }
        Ok((width, height, rgb, mapping, wrap, filter))
    }

    pub(super) fn texture(
        &mut self,
        name: &str,
        ty: &str,
        class: &str,
        params: &ParamList,
        loc: &Loc,
        file: &Path,
    ) -> Result<(), PbrtError> {
        let float = match ty {
            "spectrum" | "color" => false,
            "float" => true,
            _ => {
                return Err(loc.err(format!(
                    "Texture \"{name}\": type \"{ty}\" must be \"spectrum\" or \"float\""
                )))
            }
        };
        let what = format!("Texture \"{name}\" \"{ty}\" \"{class}\"");
        // pbrt-v4 CheckerboardTexture: `dimension` 2 (uv mapping) or 3 (texture space).
        let checker_3d = class == "checkerboard" && {
            let dim = params.int("dimension", 2)?;
            if dim != 2 && dim != 3 {
                return Err(loc.err(format!("{what}: \"dimension\" {dim} must be 2 or 3")));
            }
            dim == 3
        };
        if class == "imagemap" {
            let (width, height, rgb, mapping, wrap, filter) =
                self.imagemap(name, params, loc, file)?;
            if float {
                // pbrt-v4 5f7a606 reads one value from an RGB texel two ways: `MIPMap::Bilerp
                // <Float>` (the `bilinear` and `trilinear` filters) averages R, G and B,
                // `MIPMap::Texel<Float>` (`point`, and `ewa`'s texel weights) takes R; a grey
                // image gives Y either way. A float texture never goes negative through
                // `invert` (pbrt-v4 max(0, 1 - v)).
                let averaged = matches!(filter, TexelFilter::MipBilinear | TexelFilter::Trilinear);
                let clamps = invert_clamps(params);
                let values = rgb
                    .iter()
                    .map(|c| {
                        let v = if averaged {
                            (c[0] + c[1] + c[2]) / 3.0
                        } else {
                            c[0]
                        };
                        if clamps {
                            v.max(0.0)
                        } else {
                            v
                        }
                    })
                    .collect();
                self.float_textures.insert(
                    name.to_string(),
                    FloatTexture::Image {
                        width,
                        height,
                        values,
                        mapping,
                        wrap,
                        filter,
                    },
                );
            } else {
                // pbrt-v4 SpectrumImageTexture for albedo: clamp to [0, 1].
                let rgb = rgb
                    .into_iter()
                    .map(|c| {
                        c.map(|v| {
                            if v.is_finite() {
                                v.clamp(0.0, 1.0)
                            } else {
                                0.0
                            }
                        })
                    })
                    .collect();
                let UvMapping {
                    uscale,
                    vscale,
                    udelta,
                    vdelta,
                    kind,
                } = mapping;
                self.textures.insert(
                    name.to_string(),
                    Texture::Image {
                        width,
                        height,
                        rgb,
                        uscale,
                        vscale,
                        udelta,
                        vdelta,
                        kind,
                        wrap,
                        filter,
                    },
                );
            }
            return Ok(());
        }
        if float {
            let f = |p: &Self, n: &str, d: f64| p.float_texture_param(params, n, d).map(Box::new);
            let t = match class {
                "constant" => FloatTexture::Constant(params.float("value", 1.0)?),
                "checkerboard" if checker_3d => FloatTexture::Checkerboard3d {
                    tex1: f(self, "tex1", 1.0)?,
                    tex2: f(self, "tex2", 0.0)?,
                    texture_from_world: self.texture_from_world(loc, &what)?,
                },
                "checkerboard" => FloatTexture::Checkerboard {
                    tex1: f(self, "tex1", 1.0)?,
                    tex2: f(self, "tex2", 0.0)?,
                    mapping: self.uv_mapping(name, params, loc)?,
                },
                "scale" => FloatTexture::Scale {
                    tex: f(self, "tex", 1.0)?,
                    scale: f(self, "scale", 1.0)?,
                },
                "mix" => FloatTexture::Mix {
                    tex1: f(self, "tex1", 0.0)?,
                    tex2: f(self, "tex2", 1.0)?,
                    amount: f(self, "amount", 0.5)?,
                },
                "directionmix" => FloatTexture::DirectionMix {
                    tex1: f(self, "tex1", 0.0)?,
                    tex2: f(self, "tex2", 1.0)?,
                    direction: self.mix_dir(params, loc, &what)?,
                },
                "bilerp" => FloatTexture::Bilerp {
                    v00: params.float("v00", 0.0)?,
                    v01: params.float("v01", 1.0)?,
                    v10: params.float("v10", 0.0)?,
                    v11: params.float("v11", 1.0)?,
                    mapping: self.uv_mapping(name, params, loc)?,
                },
                "dots" => FloatTexture::Dots {
                    inside: f(self, "inside", 1.0)?,
                    outside: f(self, "outside", 0.0)?,
                    mapping: self.uv_mapping(name, params, loc)?,
                },
                "fbm" | "wrinkled" => FloatTexture::Noise(NoiseTexture {
                    kind: if class == "fbm" {
                        NoiseKind::Fbm
                    } else {
                        NoiseKind::Wrinkled
                    },
                    octaves: self.octaves(params, loc, &what)?,
                    roughness: params.float("roughness", 0.5)?,
                    texture_from_world: self.texture_from_world(loc, &what)?,
                }),
                "windy" => FloatTexture::Noise(NoiseTexture {
                    kind: NoiseKind::Windy,
                    octaves: 6,
                    roughness: 0.5,
                    texture_from_world: self.texture_from_world(loc, &what)?,
                }),
                _ => {
                    return Err(loc.err(format!(
                        "{what}: class \"{class}\" is not supported ({FLOAT_CLASSES})"
                    )))
                }
            };
            params.check_unused(&what)?;
            self.float_textures.insert(name.to_string(), t);
            return Ok(());
        }
        let s = |p: &Self, n: &str, d: f64| -> Result<Box<Texture>, PbrtError> {
            Ok(Box::new(
                p.spectrum_texture_param(params, n, file)?
                    .unwrap_or_else(|| Texture::Constant(flat(d))),
            ))
        };
        let t = match class {
            "constant" => *s(self, "value", 1.0)?,
            "checkerboard" if checker_3d => Texture::Checkerboard3d {
                tex1: s(self, "tex1", 1.0)?,
                tex2: s(self, "tex2", 0.0)?,
                texture_from_world: self.texture_from_world(loc, &what)?,
            },
            "checkerboard" => Texture::Checkerboard {
                tex1: s(self, "tex1", 1.0)?,
                tex2: s(self, "tex2", 0.0)?,
                mapping: self.uv_mapping(name, params, loc)?,
            },
            "scale" => Texture::Scale {
                tex: s(self, "tex", 1.0)?,
                scale: self.float_texture_param(params, "scale", 1.0)?,
            },
            "mix" => Texture::Mix {
                tex1: s(self, "tex1", 0.0)?,
                tex2: s(self, "tex2", 1.0)?,
                amount: self.float_texture_param(params, "amount", 0.5)?,
            },
            "directionmix" => Texture::DirectionMix {
                tex1: s(self, "tex1", 0.0)?,
                tex2: s(self, "tex2", 1.0)?,
                direction: self.mix_dir(params, loc, &what)?,
            },
            "bilerp" => {
                let v = |n: &str, d: f64| -> Result<Spectrum, PbrtError> {
                    match params.get(n, &["rgb", "spectrum", "blackbody"])? {
                        Some(p) => {
                            let resolve = |f: &str| self.resolve(file, f);
                            Ok(param_spectrum(p, SpectrumUse::Albedo, &resolve)?.spectrum)
                        }
                        None => Ok(flat(d)),
                    }
                };
                Texture::Bilerp {
                    v00: v("v00", 0.0)?,
                    v01: v("v01", 1.0)?,
                    v10: v("v10", 0.0)?,
                    v11: v("v11", 1.0)?,
                    mapping: self.uv_mapping(name, params, loc)?,
                }
            }
            "dots" => Texture::Dots {
                inside: s(self, "inside", 1.0)?,
                outside: s(self, "outside", 0.0)?,
                mapping: self.uv_mapping(name, params, loc)?,
            },
            "marble" => Texture::Marble {
                octaves: self.octaves(params, loc, &what)?,
                roughness: params.float("roughness", 0.5)?,
                scale: params.float("scale", 1.0)?,
                variation: params.float("variation", 0.2)?,
                texture_from_world: self.texture_from_world(loc, &what)?,
            },
            _ => {
                return Err(loc.err(format!(
                    "{what}: class \"{class}\" is not supported ({SPECTRUM_CLASSES})"
                )))
            }
        };
        params.check_unused(&what)?;
        self.textures.insert(name.to_string(), t);
        Ok(())
    }

    /// `octaves` (pbrt-v4 default 8), at least 1 and at most 30 (beyond, 1.99^i overflows the
    /// noise lattice's useful range).
    fn octaves(&self, params: &ParamList, loc: &Loc, what: &str) -> Result<u32, PbrtError> {
        let n = params.int("octaves", 8)?;
        if !(1..=30).contains(&n) {
            return Err(loc.err(format!("{what}: \"octaves\" {n} must be between 1 and 30")));
        }
        Ok(n as u32)
    }

    /// pbrt-v4 `TextureMapping3D`: world (render) space to texture space, the inverse of the CTM
    /// at the `Texture` directive.
    fn texture_from_world(&self, loc: &Loc, what: &str) -> Result<Transform, PbrtError> {
        crate::xform::inverse(&self.gs.ctm)
            .ok_or_else(|| loc.err(format!("{what}: the current transform is singular")))
    }

    /// pbrt-v4 DirectionMixTexture: `dir` (default (0, 1, 0)) in texture space, transformed by the
    /// CTM and normalised.
    fn mix_dir(&self, params: &ParamList, loc: &Loc, what: &str) -> Result<[f64; 3], PbrtError> {
        let d = match params.get("dir", &["vector3"])? {
            None => [0.0, 1.0, 0.0],
            Some(p) => match p.nums()?.as_slice() {
                [x, y, z] => [*x, *y, *z],
                v => {
                    return Err(p.loc.err(format!(
                        "{what}: \"vector3 dir\" needs 3 numbers, got {}",
                        v.len()
                    )))
                }
            },
        };
        let w = self.gs.ctm.apply_vector(d);
        if !(crate::xform::dot(w, w) > 0.0) {
            return Err(loc.err(format!("{what}: \"dir\" is the zero vector")));
        }
        Ok(crate::xform::normalize(w))
    }
}
