//! The scene description the renderer consumes: what the pbrt-v4 parser, the built-in scenes and
//! the TOML overlay produce. Plain data, world space, metres, absolute spectral units.
//!
//! Conventions (pbrt-v4's): camera space is left-handed, +z looks into the scene, +y is up, +x is
//! to the right in the image; raster (0, 0) is the top-left pixel. `Camera::camera_to_world` is
//! pbrt's camera transform (the inverse of the CTM at `WorldBegin`).

use camsim_core::{Spectrum, WavelengthGrid};
use std::collections::HashMap;

pub use crate::transform::Transform;

/// pbrt-v4's 2D texture mappings (4th ed. sec. 10.2.1): `kind` [`MappingKind::Uv`] gives
/// `(s, t) = (uscale u + udelta, vscale v + vdelta)`; the others map the hit point (see
/// [`MappingKind`]; `udelta`/`vdelta` are the planar mapping's offsets, the scales unused).
#[derive(Debug, Clone, PartialEq)]
pub struct UvMapping {
    pub uscale: f64,
    pub vscale: f64,
    pub udelta: f64,
    pub vdelta: f64,
    pub kind: MappingKind,
}

impl Default for UvMapping {
    fn default() -> Self {
        UvMapping {
            uscale: 1.0,
            vscale: 1.0,
            udelta: 0.0,
            vdelta: 0.0,
            kind: MappingKind::Uv,
        }
    }
}

/// What an image lookup returns outside `[0, 1]^2` (pbrt-v4 `WrapMode`, 4th ed. sec. 10.4.3):
/// texel coordinates are remapped before the bilinear lookup reads them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum WrapMode {
    /// The image tiles the plane (pbrt-v4 default).
    #[default]
    Repeat,
    /// Texel coordinates are clamped to the edge texels.
    Clamp,
    /// Texels outside the image are zero.
    Black,
    /// pbrt-v4's equal-area octahedral sphere: a texel beyond an edge is the mirror image across
    /// that edge's midpoint (the square's edges fold onto each other on the sphere).
    OctahedralSphere,
}

impl WrapMode {
    /// pbrt-v4's names: `repeat`, `clamp`, `black`, `octahedralsphere`.
    pub fn from_name(name: &str) -> Option<WrapMode> {
        match name {
            "repeat" => Some(WrapMode::Repeat),
            "clamp" => Some(WrapMode::Clamp),
            "black" => Some(WrapMode::Black),
            "octahedralsphere" => Some(WrapMode::OctahedralSphere),
            _ => None,
        }
    }
}

/// How an image texture reads its texels between texel centres (pbrt-v4 `imagemap`'s
/// `filter`; glTF samplers' magnification filter).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum TexelFilter {
    /// Bilinear between the four nearest texel centres of the full-resolution image (glTF's
    /// `LINEAR` as Blender's Cycles reads it, without MIP maps).
    #[default]
    Bilinear,
    /// The texel nearest `(s, t)` at full resolution (glTF `NEAREST`).
    Point,
    /// pbrt-v4 `bilinear`: [`TexelFilter::Bilinear`] on one level of the image's MIP pyramid,
    /// `max(0, floor(l))` of the level `l` the ray's footprint picks (pbrt-v4 5f7a606
    /// `MIPMap::Filter`; `camsim_render`'s `image_tex` module).
    MipBilinear,
    /// pbrt-v4 `point`: the nearest texel of the same pyramid level as [`TexelFilter::MipBilinear`].
    MipPoint,
    /// pbrt-v4 `trilinear`: a MIP pyramid of the image (power-of-two levels, each the box
    /// average of the one below), the level picked from the ray's footprint on the texture and
    /// the two levels around it blended.
    Trilinear,
    /// pbrt-v4 `ewa`: an elliptically weighted average (Heckbert 1989; pbrt-v4 4th ed. sec.
    /// 10.4.4) over the footprint's ellipse on the level its shorter axis picks and the next,
    /// blended; the longer axis clamped to `max_anisotropy` times the shorter (pbrt-v4's
    /// `maxanisotropy`, default 8).
    Ewa { max_anisotropy: f32 },
}

impl TexelFilter {
    /// pbrt-v4's names: `point`, `bilinear`, `trilinear` and `ewa` (with pbrt-v4's default
    /// `maxanisotropy` 8), each reading the MIP pyramid as pbrt-v4 does.
    pub fn from_name(name: &str) -> Option<TexelFilter> {
        match name {
            "point" => Some(TexelFilter::MipPoint),
            "bilinear" => Some(TexelFilter::MipBilinear),
            "trilinear" => Some(TexelFilter::Trilinear),
            "ewa" => Some(TexelFilter::Ewa {
                max_anisotropy: 8.0,
            }),
            _ => None,
        }
    }

    /// Whether the filter reads a MIP pyramid (pbrt-v4's filters) rather than the
    /// full-resolution image (glTF's, as Cycles reads them).
    pub fn uses_mip(self) -> bool {
        matches!(
            self,
            TexelFilter::MipBilinear
                | TexelFilter::MipPoint
                | TexelFilter::Trilinear
                | TexelFilter::Ewa { .. }
        )
    }

    /// Whether a texel is read by the nearest texel rather than bilinearly.
    pub fn is_point(self) -> bool {
        matches!(self, TexelFilter::Point | TexelFilter::MipPoint)
    }
}

/// How a 2D texture finds its `(s, t)` (pbrt-v4 `TextureMapping2D`); the transforms take world
/// space to texture space (the inverse of the texture's CTM; boxed, so that the common uv mapping
/// keeps textures small).
#[derive(Debug, Clone, PartialEq, Default)]
pub enum MappingKind {
    /// The surface's (u, v), scaled and offset.
    #[default]
    Uv,
    /// The surface's second uv set ([`Geometry::Triangles`]'s `uvs1`; glTF `TEXCOORD_n` that a
    /// texture's `texCoord` picks when the mesh's first set is another), scaled and offset.
    /// Where a shape has no second set it reads the first.
    Uv1,
    /// `(theta / pi, phi / (2 pi))` of the texture-space point's direction from the origin.
    Spherical { texture_from_world: Box<Transform> },
    /// `((pi + atan2(y, x)) / (2 pi), z)` of the texture-space point.
    Cylindrical { texture_from_world: Box<Transform> },
    /// `(udelta + p . v1, vdelta + p . v2)` of the texture-space point `p`.
    Planar(Box<PlanarMapping>),
}

/// pbrt-v4's planar texture mapping: the texture-space point projected on `v1` and `v2`.
#[derive(Debug, Clone, PartialEq)]
pub struct PlanarMapping {
    pub texture_from_world: Transform,
    pub v1: [f64; 3],
    pub v2: [f64; 3],
}

/// A spectrum (reflectance fraction 0..1, or any other spectral quantity a material takes) that
/// may vary over the surface. Compiled and evaluated by `camsim_render`'s texture module.
#[derive(Debug, Clone, PartialEq)]
pub enum Texture {
    /// The same spectrum everywhere.
    Constant(Spectrum),
    /// An RGB image (linear reflectance, row 0 at v = 1 as in pbrt) looked up by the mesh's uv,
    /// uplifted to a smooth spectrum per lookup ([`crate::uplift`]); `wrap` outside `[0, 1]^2`.
    Image {
        width: usize,
        height: usize,
        /// Row-major texels, shared by every material that names the texture (and by the
        /// renderer's compiled copy), so an image is held once.
        rgb: std::sync::Arc<[[f32; 3]]>,
        uscale: f64,
        vscale: f64,
        udelta: f64,
        vdelta: f64,
        kind: MappingKind,
        wrap: WrapMode,
        filter: TexelFilter,
    },
    /// glTF 2.0 sec. 3.9.2 with `COLOR_0`: an [`Texture::Image`]'s linear RGB times the
    /// colour interpolated from the mesh's vertex colours (`Geometry::Triangles::colors`; white
    /// on a shape without), clamped to [0, 1] and uplifted per lookup as `Image` is (so the
    /// product, not each factor, is the reflectance's RGB). A constant base colour is a 1 x 1
    /// image.
    VertexColored(Box<Texture>),
    /// pbrt-v4 2D `checkerboard`: `tex1` where `floor(s) + floor(t)` is even, else `tex2`,
    /// filtered over the pixel footprint as pbrt-v4 filters it (the checks integrated against a
    /// triangle filter 1.5 footprints wide; uv mappings).
    Checkerboard {
        tex1: Box<Texture>,
        tex2: Box<Texture>,
        mapping: UvMapping,
    },
    /// pbrt-v4 3D `checkerboard` (`dimension 3`): `tex1` where floor(x) + floor(y) + floor(z) of
    /// the hit point in texture space is even, else `tex2` (point-sampled).
    Checkerboard3d {
        tex1: Box<Texture>,
        tex2: Box<Texture>,
        texture_from_world: Transform,
    },
    /// pbrt-v4 `scale`: `tex * scale`.
    Scale {
        tex: Box<Texture>,
        scale: FloatTexture,
    },
    /// pbrt-v4 `mix`: `(1 - amount) tex1 + amount tex2`.
    Mix {
        tex1: Box<Texture>,
        tex2: Box<Texture>,
        amount: FloatTexture,
    },
    /// pbrt-v4 `directionmix`: `w tex1 + (1 - w) tex2` with `w = |n . dir|` (`dir` unit, world).
    DirectionMix {
        tex1: Box<Texture>,
        tex2: Box<Texture>,
        direction: [f64; 3],
    },
    /// pbrt-v4 `bilerp`: bilinear in `(s, t)` between `v00` (0,0), `v10` (1,0), `v01` (0,1), `v11`.
    Bilerp {
        v00: Spectrum,
        v01: Spectrum,
        v10: Spectrum,
        v11: Spectrum,
        mapping: UvMapping,
    },
    /// pbrt-v4 `marble`: stripes of a fixed grey and blue-grey palette (RGB albedo) along texture
    /// space's y, bent by fractional Brownian motion: t = 1/2 + sin(y + variation FBm(p)) / 2 with
    /// p the hit point in texture space times `scale`.
    Marble {
        octaves: u32,
        roughness: f64,
        scale: f64,
        variation: f64,
        texture_from_world: Transform,
    },
    /// pbrt-v4 `dots`: `inside` within the polka dots of the `(s, t)` unit cells, else `outside`.
    Dots {
        inside: Box<Texture>,
        outside: Box<Texture>,
        mapping: UvMapping,
    },
}

/// A solid-noise float texture (pbrt-v4 `fbm`, `wrinkled`, `windy`), evaluated at the hit point
/// in texture space.
#[derive(Debug, Clone, PartialEq)]
pub struct NoiseTexture {
    pub kind: NoiseKind,
    /// Octaves summed (`fbm`, `wrinkled`; `windy` has its own 3 and 6).
    pub octaves: u32,
    /// Amplitude ratio between octaves (pbrt-v4 `roughness`, omega).
    pub roughness: f64,
    /// World to texture space: the inverse of the CTM at the `Texture` directive.
    pub texture_from_world: Transform,
}

/// Which octave sum a [`NoiseTexture`] is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NoiseKind {
    /// Fractional Brownian motion: sum of omega^i noise(1.99^i p).
    Fbm,
    /// Turbulence: sum of omega^i |noise(1.99^i p)|.
    Wrinkled,
    /// |FBm(0.1 p, 0.5, 3)| FBm(p, 0.5, 6).
    Windy,
}

/// A dimensionless scalar that may vary over the surface (roughness, amounts, scales).
/// Same node set as [`Texture`]; image values are the image's first channel (pbrt-v4
/// `FloatImageTexture` reads channel 0, R of an RGB image).
#[derive(Debug, Clone, PartialEq)]
pub enum FloatTexture {
    Constant(f64),
    /// Row 0 at t = 1, read by `filter`, `wrap` outside `[0, 1]^2` (as [`Texture::Image`]).
    Image {
        width: usize,
        height: usize,
        /// Row-major texels, shared as [`Texture::Image`]'s.
        values: std::sync::Arc<[f32]>,
        mapping: UvMapping,
        wrap: WrapMode,
        filter: TexelFilter,
    },
    Checkerboard {
        tex1: Box<FloatTexture>,
        tex2: Box<FloatTexture>,
        mapping: UvMapping,
    },
    /// As [`Texture::Checkerboard3d`].
    Checkerboard3d {
        tex1: Box<FloatTexture>,
        tex2: Box<FloatTexture>,
        texture_from_world: Transform,
    },
    Scale {
        tex: Box<FloatTexture>,
        scale: Box<FloatTexture>,
    },
    Mix {
        tex1: Box<FloatTexture>,
        tex2: Box<FloatTexture>,
        amount: Box<FloatTexture>,
    },
    DirectionMix {
        tex1: Box<FloatTexture>,
        tex2: Box<FloatTexture>,
        direction: [f64; 3],
    },
    Bilerp {
        v00: f64,
        v01: f64,
        v10: f64,
        v11: f64,
        mapping: UvMapping,
    },
    /// pbrt-v4 `fbm`, `wrinkled`, `windy`.
    Noise(NoiseTexture),
    /// pbrt-v4 `dots` (as [`Texture::Dots`]).
    Dots {
        inside: Box<FloatTexture>,
        outside: Box<FloatTexture>,
        mapping: UvMapping,
    },
    /// glTF 2.0 sec. 3.9.4 with `COLOR_0`'s alpha: `tex` times the alpha interpolated from the
    /// mesh's vertex colours (1 on a shape without), then with `cutoff` (alphaMode MASK) 1 where
    /// the product is at least the cutoff, else 0.
    VertexAlpha {
        tex: Box<FloatTexture>,
        cutoff: Option<f64>,
    },
}

/// Surface scattering, with pbrt-v4's material semantics (see `camsim_render::bsdf` for the BSDFs).
/// The set is closed (dispatch by `match`); a new BSDF is a new variant here and a new arm in
/// the renderer.
// A scene holds a handful of materials, read once at compile time: the size of the largest
// variant (two inline textures) costs nothing worth an extra indirection in the public API.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, PartialEq)]
pub enum Material {
    /// Lambertian reflection with a spectral reflectance (pbrt-v4 `diffuse`).
    Diffuse { reflectance: Texture },
    /// A metal (pbrt-v4 `conductor`).
    Conductor {
        optics: ConductorOptics,
        roughness: Roughness,
    },
    /// A dielectric interface (pbrt-v4 `dielectric`): `eta` is the index of refraction inside
    /// (the side the geometric normal points away from) relative to outside. A spectrum that
    /// varies with wavelength is dispersive: the path keeps only its hero wavelength.
    Dielectric { eta: Spectrum, roughness: Roughness },
    /// A thin dielectric slab (pbrt-v4 `thindielectric`), index `eta`; as in pbrt-v4 a
    /// wavelength-dependent `eta` keeps only the path's hero wavelength.
    ThinDielectric { eta: Spectrum },
    /// Lambertian reflection and transmission (pbrt-v4 `diffusetransmission`), both multiplied
    /// by `scale`.
    DiffuseTransmission {
        reflectance: Texture,
        transmittance: Texture,
        scale: f64,
    },
    /// A dielectric coating over a diffuse base (pbrt-v4 `coateddiffuse`, 4th ed. §14.3: a
    /// stochastic random walk between the interfaces, see `camsim_render::bsdf::Bsdf::CoatedDiffuse`).
    /// `thickness` is pbrt-v4's layer thickness, an optical depth (dimensionless: transmittance
    /// `exp(-thickness / |cos|)`); `walk` the medium and the walk's parameters.
    CoatedDiffuse {
        reflectance: Texture,
        roughness: Roughness,
        eta: f64,
        thickness: f64,
        walk: LayerWalk,
    },
    /// A dielectric coating over a conductor (pbrt-v4 `coatedconductor`, 4th ed. §14.3):
    /// coating index `interface_eta` and roughness, layer `thickness` (optical depth, as
    /// [`Material::CoatedDiffuse`]), the conductor's optics (relative to the outside, as pbrt-v4
    /// gives them; divided by the coating's index at render time) and roughness, evaluated by
    /// pbrt-v4's random walk (see `camsim_render::bsdf::Bsdf::CoatedConductor`).
    CoatedConductor {
        interface_eta: f64,
        interface_roughness: Roughness,
        thickness: f64,
        conductor: ConductorOptics,
        conductor_roughness: Roughness,
        walk: LayerWalk,
    },
    /// Chooses `materials[1]` with probability `amount` and `materials[0]` otherwise, per hit
    /// by a deterministic hash of the hit point and direction (pbrt-v4 `mix`). Indices into
    /// `SceneDescription::materials`.
    Mix { materials: [usize; 2], amount: f64 },
    /// No surface: rays pass straight through (pbrt-v4 `interface`, a boundary of media).
    Interface,
    /// A shape's `alpha` cut-out (pbrt-v4 4th ed. §7.1.1, `GeometricPrimitive::Intersect`) with
    /// the shape's own material `material` (index into `SceneDescription::materials`). pbrt-v4
    /// keeps `alpha` with the shape; camsim's reader gives each alpha-textured shape this
    /// wrapper as its material. At a hit with `a = alpha(uv)`: `a >= 1` keeps the hit, `a <= 0`
    /// ignores it (the ray goes on), otherwise the hit is ignored when a deterministic hash of
    /// the ray's origin and direction, uniform in [0, 1), exceeds `a` (pbrt-v4
    /// `HashFloat(r.o, r.d)`). The test applies to camera, bounce and shadow rays alike.
    AlphaMasked {
        material: usize,
        alpha: FloatTexture,
    },
    /// Material `material` (index into `SceneDescription::materials`) with its shading normal
    /// perturbed at every hit by a bump or normal map (pbrt-v4 materials' `displacement` and
    /// `normalmap`; the renderer's `bump` module).
    Bumped {
        material: usize,
        perturbation: NormalPerturbation,
    },
    /// A shape that separates two participating media (pbrt-v4 `MediumInterface "inside"
    /// "outside"` on a shape, 4th ed. sec. 11.4.1) with the shape's own material `material`
    /// (index into `SceneDescription::materials`; `interface` for a boundary that does not
    /// scatter). `inside` and `outside` index `SceneDescription::media.list` (`None` is
    /// vacuum) and differ: a ray leaving the surface on the side the oriented geometric normal
    /// points to (see `Shape::reverse_orientation`) travels in `outside`, else in `inside`.
    /// Shapes without this wrapper leave a ray's medium unchanged. Like `AlphaMasked`, the
    /// reader gives each such shape this wrapper as its material (inside an alpha mask's).
    MediumInterface {
        material: usize,
        inside: Option<usize>,
        outside: Option<usize>,
    },
    /// A hair fibre (pbrt-v4 `hair`; Chiang et al. 2016, see `camsim_render::bsdf::hair`), for
    /// curves: the fibre's absorption, its index of refraction `eta`, longitudinal and azimuthal
    /// roughness `beta_m`, `beta_n` (0..1; pbrt-v4 clamps them to [0.01, 1]) and the cuticle
    /// scales' tilt `alpha_deg` (degrees). pbrt-v4 defaults: eta 1.55, beta_m 0.3, beta_n 0.3,
    /// alpha 2 deg.
    Hair {
        absorption: HairAbsorption,
        eta: f64,
        beta_m: f64,
        beta_n: f64,
        alpha_deg: f64,
    },
    /// The glTF 2.0 metallic-roughness material (glTF 2.0 specification, Appendix B, with
    /// `KHR_materials_specular` and `KHR_materials_ior`), see [`GltfPbr`] and
    /// `camsim_render::bsdf::Bsdf::GltfPbr`.
    GltfPbr(Box<GltfPbr>),
    /// Roughness that varies over the surface: material `material` (a conductor, dielectric or
    /// coated diffuse; index into `SceneDescription::materials`) with its constant roughness
    /// replaced at every hit by the float textures `u` and `v` (pbrt-v4 materials take
    /// `roughness`, `uroughness`, `vroughness` as float textures evaluated per hit, 4th ed.
    /// §10.4). `remap` as [`Roughness::remap`]; negative texture values count as 0.
    VaryingRoughness {
        material: usize,
        u: FloatTexture,
        v: FloatTexture,
        remap: bool,
    },
}

/// The glTF 2.0 metallic-roughness BRDF's inputs (glTF 2.0 specification, Appendix B): with
/// `alpha = roughness^2`, `D` the GGX (Trowbridge-Reitz) distribution and `V` the
/// height-correlated Smith visibility `G2 / (4 |n.l| |n.v|)`, at each wavelength
///
/// `f = (1 - metallic) [(1 - F_d) base / pi + F_d D V] + metallic F_m D V`
///
/// with Schlick's Fresnel `F_d = F0_d + (F90_d - F0_d)(1 - |v.h|)^5`, `F0_d = min(((ior - 1) /
/// (ior + 1))^2 specular_color, 1) specular`, `F90_d = specular` (`KHR_materials_specular`;
/// without it `specular = 1`, `specular_color = 1`, `ior = 1.5`: `F0_d = 0.04`) and
/// `F_m = base + (1 - base)(1 - |v.h|)^5`. Reflection only, the same on both sides.
#[derive(Debug, Clone, PartialEq)]
pub struct GltfPbr {
    /// Base colour as a reflectance (the linear base colour, factor times texture, uplifted).
    pub base_color: Texture,
    /// Metalness, 0..1 (factor times the metallicRoughness texture's B channel).
    pub metallic: FloatTexture,
    /// Perceptual roughness, 0..1 (factor times the texture's G channel); `alpha = roughness^2`.
    pub roughness: FloatTexture,
    /// `KHR_materials_specular` `specularFactor` (times its texture's alpha), 0..1.
    pub specular: FloatTexture,
    /// `KHR_materials_specular` `specularColorFactor` (times its texture) as a spectrum (may
    /// exceed 1).
    pub specular_color: Texture,
    /// Index of refraction of the dielectric part (`KHR_materials_ior`, default 1.5).
    pub ior: f64,
}

/// What perturbs a material's shading normal per hit (pbrt-v4 4th ed. sec. 10.5.1).
#[derive(Debug, Clone, PartialEq)]
pub enum NormalPerturbation {
    /// pbrt-v4 `displacement` (or `bumpmap`): a float texture, the surface displaced along its
    /// shading normal by that distance (scene units); the shading normal is the displaced
    /// surface's (pbrt-v4 `BumpMap`).
    Displacement(FloatTexture),
    /// pbrt-v4 `normalmap`: an image of tangent-space normals (pbrt-v4 `NormalMap`).
    NormalMap(std::sync::Arc<NormalMapImage>),
}

/// A normal map: linear RGB texels (row 0 at v = 1), each `(n + 1) / 2` of a unit normal in the
/// tangent frame (dp/du, n x dp/du, n), or (t, w n x t, n) on a mesh with `tangents`; looked up bilinearly at the surface's (u, v) with repeat
/// wrap.
#[derive(Debug, Clone, PartialEq)]
pub struct NormalMapImage {
    pub width: usize,
    pub height: usize,
    pub rgb: Vec<[f32; 3]>,
    /// Looked up at the second uv set (`Geometry::Triangles::uvs1`) instead of the first.
    pub uv1: bool,
}

/// How a hair fibre absorbs (pbrt-v4 `HairMaterial`'s three parametrizations; melanin
/// concentrations are turned into [`HairAbsorption::SigmaA`] by the reader).
#[derive(Debug, Clone, PartialEq)]
pub enum HairAbsorption {
    /// Absorption coefficient inside the fibre per unit fibre radius (dimensionless, >= 0).
    SigmaA(Texture),
    /// The fibre's colour (its multiple-scattering albedo, 0..1), mapped per wavelength to
    /// `sigma_a` by Chiang et al. 2016's fit for the material's `beta_n` (sec. 4.2).
    Color(Texture),
}

/// The medium between a coating's two interfaces and the random walk that evaluates the
/// layered BSDF (pbrt-v4 `LayeredBxDF`, 4th ed. §14.3; parameters `albedo`, `g`, `maxdepth`,
/// `nsamples` of `coateddiffuse` and `coatedconductor`).
#[derive(Debug, Clone, PartialEq)]
pub struct LayerWalk {
    /// Single-scattering albedo of the homogeneous medium in the layer (0: no medium, the layer
    /// only attenuates by `exp(-thickness / |cos|)`); unit extinction per unit of thickness.
    pub albedo: Texture,
    /// Henyey-Greenstein asymmetry of the medium's phase function, in (-1, 1).
    pub g: f64,
    /// Scattering events of one walk before it is cut (pbrt-v4 default 10).
    pub max_depth: u32,
    /// Independent walks averaged per evaluation (pbrt-v4 default 1).
    pub n_samples: u32,
}

impl Default for LayerWalk {
    /// pbrt-v4's defaults: no medium, g 0, maxdepth 10, nsamples 1.
    fn default() -> Self {
        LayerWalk {
            albedo: Texture::Constant(Spectrum::from_pairs(&[(300.0, 0.0), (900.0, 0.0)])),
            g: 0.0,
            max_depth: 10,
            n_samples: 1,
        }
    }
}

/// The optical constants of a conductor.
#[derive(Debug, Clone, PartialEq)]
pub enum ConductorOptics {
    /// Complex index of refraction `eta + i k` relative to the outside medium.
    EtaK { eta: Spectrum, k: Spectrum },
    /// Normal-incidence reflectance `r`, turned into `eta = 1`, `k = 2 sqrt(r) / sqrt(1 - r)`
    /// as pbrt-v4's `ConductorMaterial` does (this reproduces `r` at normal incidence exactly).
    Reflectance(Texture),
}

/// Microfacet roughness as pbrt-v4 materials take it: `u` along the surface's first tangent,
/// `v` along the second; `remap` (pbrt's `remaproughness`, default true) turns a perceptual
/// roughness into the Trowbridge-Reitz alpha by `alpha = sqrt(roughness)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Roughness {
    pub u: f64,
    pub v: f64,
    pub remap: bool,
}

impl Roughness {
    /// A perfectly smooth surface.
    pub const SMOOTH: Roughness = Roughness {
        u: 0.0,
        v: 0.0,
        remap: true,
    };

    /// The Trowbridge-Reitz `(alpha_x, alpha_y)` (NaN for a negative roughness when remapped:
    /// the renderer refuses non-finite or negative alphas).
    pub fn alphas(&self) -> (f64, f64) {
        if self.remap {
            (self.u.sqrt(), self.v.sqrt())
        } else {
            (self.u, self.v)
        }
    }
}

/// A diffuse area emitter attached to a shape: spectral radiance in W/(sr m^2 nm), after every
/// scale and normalization the source format applies.
#[derive(Debug, Clone, PartialEq)]
pub struct AreaLight {
    pub radiance: Spectrum,
    pub two_sided: bool,
    /// pbrt-v4 `DiffuseAreaLight` with `filename`: the emission varies over the surface as this
    /// image, looked up by the shape's uv (bilinear, repeat, row 0 at v = 1), each RGB value an
    /// illuminant spectrum `2 m S(rgb / 2m)(lambda) radiance(lambda)` (`m` the largest
    /// component; pbrt-v4 `RGBIlluminantSpectrum`): `radiance` is then the colour space's
    /// illuminant with every scale applied, W/(sr m^2 nm) per unit RGB. Triangle meshes and
    /// (partial) spheres (pbrt-v4 sphere uv, object frame).
    pub image: Option<std::sync::Arc<EmissionImage>>,
}

/// A linear RGB emission image (non-negative), row-major, row 0 at the top (v = 1).
#[derive(Debug, Clone, PartialEq)]
pub struct EmissionImage {
    pub width: usize,
    pub height: usize,
    /// Row-major texels, shared with the renderer (not copied).
    pub rgb: std::sync::Arc<[[f32; 3]]>,
    /// Looked up at the second uv set (`Geometry::Triangles::uvs1`) instead of the first.
    pub uv1: bool,
}

/// Geometry in world space, metres.
#[derive(Debug, Clone, PartialEq)]
pub enum Geometry {
    Triangles {
        positions: Vec<[f64; 3]>,
        indices: Vec<[u32; 3]>,
        uvs: Option<Vec<[f32; 2]>>,
        normals: Option<Vec<[f64; 3]>>,
        /// Per-vertex linear RGBA colours (glTF `COLOR_0`, alpha 1 where it has none),
        /// interpolated over each triangle: RGB multiplies the texel of a
        /// [`Texture::VertexColored`] base colour, alpha a [`FloatTexture::VertexAlpha`] (white
        /// and opaque where a mesh has none). 16 bytes a vertex, only on meshes with colours.
        colors: Option<Vec<[f32; 4]>>,
        /// A second uv set, read by textures of [`MappingKind::Uv1`] and maps with `uv1` (glTF:
        /// the `TEXCOORD_n` of a texture slot whose set is not the first's). Only on meshes a
        /// material reads two sets of.
        uvs1: Option<Vec<[f32; 2]>>,
        /// Per-vertex tangents `[x, y, z, w]` (world space, `w = +-1` the handedness: the
        /// bitangent is `w n x t`, glTF `TANGENT`): the x and y axes of a normal map's tangent
        /// frame; without them the frame is the triangle's `dp/du` (pbrt-v4's).
        tangents: Option<Vec<[f32; 4]>>,
    },
    Sphere {
        center: [f64; 3],
        radius: f64,
    },
    /// A partial sphere (pbrt-v4 `sphere` with `zmin`, `zmax`, `phimax`; 4th ed. §6.2): the
    /// points of the sphere of `radius` about `center` whose object-frame coordinates have
    /// `z_min <= z <= z_max` (m, `-radius <= z_min < z_max <= radius`) and azimuth
    /// `0 <= phi <= phi_max_deg` (from the frame's x axis toward its y axis). `axes` are the
    /// object frame's x, y, z unit axes in world space (a mirrored frame when the transform
    /// swaps handedness). The outward normal is flipped by `Shape::reverse_orientation`.
    PartialSphere {
        center: [f64; 3],
        radius: f64,
        axes: [[f64; 3]; 3],
        z_min: f64,
        z_max: f64,
        phi_max_deg: f64,
    },
    /// A pbrt-v4 `curve` (hair, fur): cubic Bezier segments with a width, see [`crate::curves`].
    Curves(crate::curves::Curves),
}

impl Geometry {
    /// A triangle mesh with optional uvs and normals and none of the glTF attributes (vertex
    /// colours, a second uv set, tangents).
    pub fn mesh(
        positions: Vec<[f64; 3]>,
        indices: Vec<[u32; 3]>,
        uvs: Option<Vec<[f32; 2]>>,
        normals: Option<Vec<[f64; 3]>>,
    ) -> Geometry {
        Geometry::Triangles {
            positions,
            indices,
            uvs,
            normals,
            colors: None,
            uvs1: None,
            tangents: None,
        }
    }
}

/// One object: geometry, its material (index into `SceneDescription::materials`), and an
/// optional emitter. `name` lets overlays find it ("left_wall", "short_block", "light", ...).
#[derive(Debug, Clone, PartialEq)]
pub struct Shape {
    pub name: Option<String>,
    pub geometry: Geometry,
    pub material: usize,
    pub area_light: Option<AreaLight>,
    /// Flip the geometric normal (pbrt `ReverseOrientation`): decides the emitting side of a
    /// one-sided area light. Geometry here is already in world space, so this must be pbrt's
    /// `ReverseOrientation XOR transformSwapsHandedness`. The renderer's geometric normal is,
    /// for triangles, `(p1 - p0) x (p2 - p0)` normalized, turned toward the vertex normals when
    /// the mesh has them (then this flag is ignored, as in pbrt-v4) and negated by this flag
    /// otherwise; for spheres the outward normal, negated by this flag.
    pub reverse_orientation: bool,
    /// Which object instance and light group the shape belongs to (training-data labels).
    pub tags: ShapeTags,
}

/// What a shape is part of, for labels and light groups (camsim's own data: pbrt-v4 keeps none).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ShapeTags {
    /// Shapes with the same `Some(k)` form one object instance (the shapes of one pbrt-v4
    /// `ObjectInstance`, or one `Shape` directive split into several shapes); `None`: the shape is
    /// an instance by itself.
    pub instance: Option<u32>,
    /// The object-to-world transform the geometry was placed with (pbrt's CTM at the `Shape`,
    /// then the instance's and any overlay's transforms): the orientation of the instance's 3D
    /// box. `None`: unknown (the box is then aligned with the world axes).
    pub object_to_world: Option<Transform>,
    /// Light group of the shape's area light (pbrt `AreaLightSource ... "string lightgroup"`, or
    /// an overlay `[[light_group]]`); `None`: the group `default`.
    pub light_group: Option<String>,
    /// The semantic category of the instance (an overlay's `[[object]] category`, an asset
    /// manifest's): labels and COCO name it; `None`: none given.
    pub category: Option<String>,
    /// The instance's own 3D keypoints (an asset manifest's `keypoints`), in world coordinates
    /// like the geometry (moved with it by [`crate::xform::transform_shape`]); `None`: labels
    /// use its 3D box's centre and corners.
    pub keypoints: Option<std::sync::Arc<ObjectKeypoints>>,
}

/// Named 3D points on an object (a pose model's keypoints: a mug's handle, a tool's tip) and
/// the edges drawn between them.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ObjectKeypoints {
    /// One name per point, unique.
    pub names: Vec<String>,
    /// Edges between points, 0-based indices into `names` (COCO's `skeleton` less one).
    pub skeleton: Vec<[usize; 2]>,
    /// The points, m (world coordinates in a scene's `ShapeTags`).
    pub points_m: Vec<[f64; 3]>,
}

/// Lights that are not shapes. Point, spot and distant lights are delta lights: reached only by
/// next-event estimation, never by a ray.
#[derive(Debug, Clone, PartialEq)]
pub enum Light {
    /// Uniform radiance from every direction, W/(sr m^2 nm) (pbrt-v4 `infinite` without a map).
    Infinite { radiance: Spectrum },
    /// Isotropic point source: radiant intensity in W/(sr nm) (pbrt-v4 `point`).
    Point {
        position_m: [f64; 3],
        intensity: Spectrum,
    },
    /// Spot light (pbrt-v4 `spot`): intensity `intensity * falloff(cos(cone_angle),
    /// cos(cone_angle - cone_delta), cos theta)` around the unit axis `direction`, W/(sr nm);
    /// `falloff` pbrt-v4's smoothstep or `KHR_lights_punctual`'s squared ramp ([`SpotFalloff`]).
    Spot {
        position_m: [f64; 3],
        direction: [f64; 3],
        intensity: Spectrum,
        cone_angle_deg: f64,
        cone_delta_deg: f64,
        falloff: SpotFalloff,
    },
    /// Light from one direction (pbrt-v4 `distant`): `direction` is the unit vector the light
    /// travels along (from -> to); `irradiance` W/(m^2 nm) on a surface facing the light.
    Distant {
        direction: [f64; 3],
        irradiance: Spectrum,
    },
    /// Image-based environment light (pbrt-v4 `infinite` with `filename`).
    Environment(EnvironmentMap),
    /// Point light with a tabulated angular distribution (pbrt-v4 `goniometric`).
    Goniometric(GoniometricLight),
    /// Point light projecting an image through a frustum (pbrt-v4 `projection`).
    Projection(ProjectionLight),
}

/// How a spot light's intensity falls from the inner cone (`cos_start`) to the outer cone
/// (`cos_end`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SpotFalloff {
    /// pbrt-v4 `SpotLight`: `smoothstep(cos_end, cos_start, cos theta)`.
    #[default]
    Smoothstep,
    /// `KHR_lights_punctual` (its implementation note): `t^2` with `t = clamp((cos theta -
    /// cos_end) / (cos_start - cos_end), 0, 1)`.
    GltfSquared,
}

/// pbrt-v4 `ProjectionLight` (4th ed. §12.2.2): a point source at `position_m` projecting an RGB
/// image along its light-frame +z. A light-frame direction `w` with `w.z >= 1e-3` meets the
/// plane z = 1 at `(w.x, w.y) / w.z`; divided by `tan(fov / 2)` that is the screen point, and the
/// screen window is `[-a, a] x [-1, 1]` for an aspect `a = width / height > 1`, else `[-1, 1] x
/// [-1/a, 1/a]` (the field of view spans the shorter image side). Outside it the intensity is
/// zero; inside it is the nearest texel (screen y from its minimum at row 0, the image top) as
/// an illuminant: `I(lambda) = 2 m S(rgb / 2m)(lambda) illuminant(lambda)`, W/(sr nm).
#[derive(Debug, Clone, PartialEq)]
pub struct ProjectionLight {
    pub position_m: [f64; 3],
    /// Light-to-world linear map (translation ignored). For pbrt scenes this is the CTM times
    /// pbrt-v4's `Scale(1, -1, 1)`, so the image's top row lights the CTM's +y side.
    pub light_to_world: Transform,
    /// Full field of view across the shorter image side, degrees (pbrt-v4 `fov`).
    pub fov_deg: f64,
    pub width: usize,
    pub height: usize,
    /// Linear RGB texels, row 0 at the top.
    pub rgb: Vec<[f32; 3]>,
    /// The colour space's illuminant with every scale applied: W/(sr nm) per unit RGB.
    pub illuminant: Spectrum,
}

/// The flux integral of a projection light's image per unit intensity scale: `A mean(weight(rgb)
/// cos^3 theta)` over the texel centres, `A = 4 tan^2(fov / 2) max(a, 1 / a)` the screen
/// window's area at z = 1 (aspect a = width / height, `fov` across the shorter side) and
/// `cos^3 theta` the solid angle per unit area there (pbrt-v4 `ProjectionLight` constructor and
/// `Phi`, midpoint sum). `weight` turns a texel into the quantity integrated (luminance for
/// `power`, a channel mean for picking lights by power).
pub fn projection_frustum_sum(
    width: usize,
    height: usize,
    rgb: &[[f32; 3]],
    fov_deg: f64,
    weight: impl Fn([f32; 3]) -> f64,
) -> f64 {
    let aspect = width as f64 / height as f64;
    let (sx, sy) = if aspect > 1.0 {
        (aspect, 1.0)
    } else {
        (1.0, 1.0 / aspect)
    };
    let tan_half = (fov_deg.to_radians() / 2.0).tan();
    let mut sum = 0.0;
    for (i, c) in rgb.iter().enumerate() {
        // Texel centre on the plane z = 1 (light frame).
        let px = (-sx + 2.0 * sx * ((i % width) as f64 + 0.5) / width as f64) * tan_half;
        let py = (-sy + 2.0 * sy * ((i / width) as f64 + 0.5) / height as f64) * tan_half;
        sum += weight(*c) * (1.0 + px * px + py * py).powf(-1.5);
    }
    4.0 * tan_half * tan_half * sx * sy * sum / rgb.len() as f64
}

/// pbrt-v4 `GoniometricLight` (4th ed. §12.2.3): a point source at `position_m` whose radiant
/// intensity toward the unit light-frame direction `w` is `intensity(lambda) * value(w)`, W/(sr nm),
/// with `value` the single-channel, equal-area octahedral square image looked up at the nearest
/// texel of `EqualAreaSphereToSquare(w)` (row 0 at the top).
#[derive(Debug, Clone, PartialEq)]
pub struct GoniometricLight {
    pub position_m: [f64; 3],
    /// Light-to-world linear map (translation ignored). For pbrt scenes this is the CTM times
    /// pbrt-v4's y <-> z swap, so the image's pole (its +z) is the CTM's +y axis.
    pub light_to_world: Transform,
    /// Square image, `size x size` non-negative values (pbrt-v4 averages RGB channels).
    pub size: usize,
    pub values: Vec<f32>,
    /// Intensity per unit image value, W/(sr nm), every scale applied.
    pub intensity: Spectrum,
}

/// How an environment image covers the sphere of directions (light space: +z up).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EnvMapping {
    /// pbrt-v4's equal-area octahedral square (Clarberg 2008), square images.
    EqualAreaOctahedral,
    /// Latitude-longitude (equirectangular) image, width = 2 height: column u = phi / (2 pi),
    /// phi = atan2(y, x); row v = theta / pi, theta = acos(z) (pbrt-v3 `InfiniteAreaLight`).
    LatLong,
}

/// An environment map: three values per texel (row 0 at the top, nearest lookup as pbrt-v4's
/// `ImageInfiniteLight`). Without a [`basis`](Self::basis) they are linear RGB, uplifted per
/// texel as an illuminant: `L(lambda) = 2 m S(rgb / 2m)(lambda) illuminant(lambda)` with `m` the
/// largest component (pbrt-v4 `RGBIlluminantSpectrum`). With a basis `B` they are the
/// coefficients of a spectrum: `L(lambda) = max(0, c0 B0 + c1 B1 + c2 B2)(lambda)
/// illuminant(lambda)` (coefficients may be negative; the spectral sky of `camsim-compose`,
/// with `B` the CIE daylight basis [`crate::daylight`]), so each direction has a full spectrum.
#[derive(Debug, Clone, PartialEq)]
pub struct EnvironmentMap {
    pub width: usize,
    pub height: usize,
    /// Row-major texels: linear RGB, or the coefficients of [`Self::basis`].
    pub rgb: Vec<[f32; 3]>,
    pub mapping: EnvMapping,
    /// With RGB texels, the colour space's illuminant with every scale applied: W/(sr m^2 nm)
    /// per unit RGB. With a basis, a factor on the basis sum (a constant 1 keeps the basis's
    /// units; a scale applied to the light scales it).
    pub illuminant: Spectrum,
    /// `Some`: the texels are coefficients of these three spectra (see the type's docs);
    /// `None`: linear RGB.
    pub basis: Option<std::sync::Arc<[Spectrum; 3]>>,
    /// Light-to-world rotation (pbrt's CTM at the `LightSource`; translation ignored).
    pub light_to_world: Transform,
}

/// The camera: a pinhole perspective camera (pbrt-v4 `perspective` with lensradius 0), or with
/// `lens` a pbrt-v4 `realistic` camera (a traced lens in front of the film).
#[derive(Debug, Clone, PartialEq)]
pub struct Camera {
    pub camera_to_world: Transform,
    /// Field of view across the shorter image axis, degrees (pbrt-v4 `fov`). For a realistic
    /// camera, the pinhole-equivalent field (film size over film distance), used for the depth
    /// map and the image geometry only.
    pub fov_deg: f64,
    pub width: usize,
    pub height: usize,
    /// `Some`: camera rays are traced through this lens (a realistic or ray-transfer camera).
    pub lens: Option<CameraLens>,
}

/// The optics of a camera that is not a pinhole.
#[derive(Debug, Clone, PartialEq)]
pub enum CameraLens {
    /// pbrt-v4 `realistic`: rays traced through a lens prescription.
    Realistic(RealisticLens),
    /// ISET3d's `raytransfer`: rays mapped through a ray-transfer function.
    RayTransfer(RayTransferLens),
}

impl CameraLens {
    /// The prescription lens of a realistic camera.
    pub fn realistic(&self) -> Option<&RealisticLens> {
        match self {
            CameraLens::Realistic(l) => Some(l),
            CameraLens::RayTransfer(_) => None,
        }
    }
}

/// A lens known only by its ray-transfer function (Goossens et al. 2022; ISET3d's `raytransfer`
/// camera): the film lies `film_offset_mm` behind the RTF's input plane (ISET3d's `filmdistance`,
/// film to the lens's sensor-side vertex, is the RTF's `plane_offset_input_mm` plus this).
#[derive(Debug, Clone, PartialEq)]
pub struct RayTransferLens {
    pub rtf: std::sync::Arc<camsim_lens::Rtf>,
    /// Film distance behind the RTF's input plane, mm (0: the film on the input plane; the
    /// shipped Pixel 4a RTF focuses at infinity 0.0166 mm behind it).
    pub film_offset_mm: f64,
    /// Film diagonal, mm (pbrt-v4 `Film` `diagonal`).
    pub film_diagonal_mm: f64,
    /// Effective focal length measured from the RTF (Abbe sine condition on the axis), mm.
    pub focal_length_mm: f64,
    /// Pinhole-equivalent image distance, mm: a film height over the tangent of its chief ray's
    /// angle in object space, near the axis (about f plus the film's move from the infinity
    /// focus); with [`Self::pupil_z_mm`] the pinhole of the depth map, the object ids and the
    /// image geometry.
    pub image_distance_mm: f64,
    /// The entrance pupil's distance in front of the film, mm: where the chief rays, continued
    /// back from object space, cross the axis (the centre of perspective; the depth map is
    /// measured from there).
    pub pupil_z_mm: f64,
}

/// A pbrt-v4 `realistic` camera (4th ed. sec. 5.3): a focused lens with its film. Camera space
/// as pbrt: the film at the origin, the lens toward +z.
#[derive(Debug, Clone, PartialEq)]
pub struct RealisticLens {
    /// The lens with its film plane and exit-pupil bounds (camsim-lens).
    pub camera: std::sync::Arc<camsim_lens::LensCamera>,
    /// Film diagonal, mm (pbrt-v4 `Film` `diagonal`).
    pub film_diagonal_mm: f64,
    /// Pinhole-equivalent image distance, mm (a film height over the tangent of its chief ray's
    /// object-space angle, near the axis); with `pupil_z_mm` the pinhole of the depth map, the
    /// object ids and the image geometry.
    pub image_distance_mm: f64,
    /// The entrance pupil's distance in front of the film, mm (the centre of perspective; the
    /// depth map is measured from there).
    pub pupil_z_mm: f64,
}

impl RealisticLens {
    /// The pinhole-equivalent field of view across the shorter axis of a `width` x `height`
    /// film, degrees.
    pub fn fov_deg(&self, width: usize, height: usize) -> f64 {
        let half = film_half_extent_mm(self.film_diagonal_mm, width, height);
        2.0 * (half[0].min(half[1]) / self.image_distance_mm)
            .atan()
            .to_degrees()
    }
}

impl Camera {
    /// A move of the camera in its own frame (x right, y up, z forward, the image's directions):
    /// by `translation_m`, then turned by `yaw_deg` (> 0 toward +x, the right), `pitch_deg`
    /// (> 0 toward +y, up) and `roll_deg` (> 0 turning +x toward +y), applied in that order
    /// about the moved centre, as the transform on the right of `camera_to_world`: T(t)
    /// R_y(yaw) R_x(-pitch) R_z(roll) (old camera frame from moved camera frame). A rig's
    /// camera is its reference camera moved by its extrinsics
    /// ([`SceneDescription::move_camera_in_own_frame`]).
    pub fn own_frame_offset(
        translation_m: [f64; 3],
        yaw_deg: f64,
        pitch_deg: f64,
        roll_deg: f64,
    ) -> Transform {
        Transform::translate(translation_m)
            .then_apply_to(&Transform::rotate(yaw_deg, [0.0, 1.0, 0.0]))
            .then_apply_to(&Transform::rotate(-pitch_deg, [1.0, 0.0, 0.0]))
            .then_apply_to(&Transform::rotate(roll_deg, [0.0, 0.0, 1.0]))
    }

    /// Horizontal field of view in degrees (what the optics stage needs).
    pub fn horizontal_fov_deg(&self) -> f64 {
        let half_short = (self.fov_deg.to_radians() / 2.0).tan();
        let aspect = self.width as f64 / self.height as f64;
        let half_h = if aspect >= 1.0 {
            half_short * aspect
        } else {
            half_short
        };
        2.0 * half_h.atan().to_degrees()
    }
}

/// How to render.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderSettings {
    /// Output wavelength grid; radiance is reported on it.
    pub grid: WavelengthGrid,
    pub samples_per_pixel: u32,
    /// Maximum number of bounces (pbrt-v4 `maxdepth`, default 5).
    pub max_depth: u32,
    /// Wavelengths traced together per path (hero-wavelength style; pbrt-v4 uses 4).
    pub wavelengths_per_path: usize,
    pub seed: u64,
    /// Stop after this many seconds even if `samples_per_pixel` is not reached.
    pub time_budget_s: Option<f64>,
    /// Direct lighting only (tests).
    pub direct_only: bool,
    /// Where the uniform numbers come from (`camsim_render::sampler`); default Owen-scrambled Sobol.
    pub sampler: SamplerKind,
    /// Russian roulette runs at scattering vertices `depth >= russian_roulette_depth` (1 is the
    /// first surface hit). pbrt-v4 starts at 2; camsim's default 5 traces longer paths for less
    /// variance, which reaches a given luminance error sooner on the Cornell box (measured by
    /// `examples/convergence.rs`). 0 behaves as 1.
    pub russian_roulette_depth: u32,
    /// The pixel reconstruction filter (pbrt-v4 `PixelFilter`), applied by filter importance
    /// sampling; default a box of radius 0.5 (each pixel averages its own square).
    pub filter: PixelFilter,
    /// The time dimension: the shutter window camera rays sample and what moves during it
    /// ([`crate::motion`]; default: a static scene, pbrt-v4's shutter 0-1).
    pub time: crate::motion::TimeSettings,
    /// How next-event estimation chooses among the lights (pbrt-v4's `Integrator`
    /// `lightsampler`; default `bvh`, pbrt-v4's default).
    pub light_sampler: LightSampler,
    /// Adaptive sampling (camsim's own; pbrt-v4 has none): each pixel stops once its estimated
    /// Monte Carlo error meets a target, `samples_per_pixel` being the most it takes. `None`:
    /// every pixel takes `samples_per_pixel`.
    pub adaptive: Option<AdaptiveSampling>,
    /// How a layered BSDF's estimate of its value weighs a base sample that leaves through a rough
    /// coating (`coateddiffuse`, `coatedconductor`; [`LayeredExitWeight`]): camsim's unbiased
    /// weights by default, pbrt-v4 5f7a606's for comparisons with its renders.
    pub layered_exit_weight: LayeredExitWeight,
    /// Denoise the film after rendering (camsim's own; pbrt-v4 has none): Intel Open Image
    /// Denoise, loaded at run time, guided by the first surfaces' albedo and normals
    /// (`camsim_render::denoise`). `None`: the unbiased film.
    pub denoise: Option<DenoiseSettings>,
}

/// How the film is denoised ([`RenderSettings::denoise`]).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct DenoiseSettings {
    /// The OIDN shared library (`libOpenImageDenoise.so.*`); `None`: `$CAMSIM_OIDN_LIBRARY`,
    /// else the system's library path.
    pub library: Option<std::path::PathBuf>,
}

/// When a pixel has enough samples ([`RenderSettings::adaptive`]).
///
/// After every pass of samples from `min_samples` on, each pixel still sampling computes, for
/// each channel `c`, its mean `m_c` and the variance of that mean `v_c` (the sample variance of
/// its per-sample channel values over the sample count, the filter's ratio estimator to first
/// order), and is done when every channel meets
/// `v_c <= relative^2 m_c^2 + shot max(m_c, 0) + floor^2`
/// and so do its 8 neighbours (a converged pixel next to an unconverged one goes on: the
/// spatial guard of Cycles' adaptive sampler, against a pixel stopped by a lucky run).
/// `relative` alone is a relative error target; `shot` and `floor` make it a noise model: with
/// channels in electrons, `shot = f^2` and `floor = f sigma_0` ask the render's noise to be the
/// fraction `f` of shot noise and a noise floor `sigma_0` (the sensor's, in camsim-pipeline).
#[derive(Debug, Clone, PartialEq)]
pub struct AdaptiveSampling {
    /// Samples every pixel takes before its first test (rounded up to whole passes of 8).
    pub min_samples: u32,
    /// The channels tested, each a weight per band of the radiance image: the channel's value
    /// of a pixel is `sum_b w[b] L_b` (`L_b` the band's radiance, W/(sr m^2 nm); the weights
    /// carry the channel's unit per radiance unit). Empty: one channel, luminance in cd/m^2
    /// (`683 ybar(lambda_b) step_nm`).
    pub channels: Vec<Vec<f64>>,
    /// Relative standard error allowed (0.01: 1 % of the pixel's mean).
    pub relative: f64,
    /// Variance allowed per unit of the mean, in the channel's unit (a Poisson-like term).
    pub shot: f64,
    /// Standard error allowed at any mean, in the channel's unit.
    pub floor: f64,
}

impl AdaptiveSampling {
    /// A relative error target on luminance: each pixel stops when the standard error of its
    /// mean luminance is `relative` of the mean (or, at a black pixel, `floor_cd_m2`).
    pub fn relative(relative: f64, floor_cd_m2: f64, min_samples: u32) -> AdaptiveSampling {
        AdaptiveSampling {
            min_samples,
            channels: Vec::new(),
            relative,
            shot: 0.0,
            floor: floor_cd_m2,
        }
    }

    /// Check the parameters against the grid's band count; the message names the bad one.
    pub fn validate(&self, bands: usize) -> Result<(), String> {
        if self.min_samples < 2 {
            return Err(format!(
                "adaptive min_samples = {}: at least 2 samples are needed to estimate a variance",
                self.min_samples
            ));
        }
        for (name, v) in [
            ("relative", self.relative),
            ("shot", self.shot),
            ("floor", self.floor),
        ] {
            if !(v >= 0.0) || !v.is_finite() {
                return Err(format!("adaptive {name} = {v} is not a finite number >= 0"));
            }
        }
        if self.relative == 0.0 && self.shot == 0.0 && self.floor == 0.0 {
            return Err("adaptive sampling with relative, shot and floor all 0 never stops a pixel early: give a target".into());
        }
        for (c, w) in self.channels.iter().enumerate() {
            if w.len() != bands {
                return Err(format!(
                    "adaptive channel {c} has {} band weights for {bands} bands",
                    w.len()
                ));
            }
            if w.iter().any(|v| !v.is_finite()) {
                return Err(format!("adaptive channel {c} has a non-finite weight"));
            }
        }
        Ok(())
    }
}

/// pbrt-v4's pixel reconstruction filters (4th ed. sec. 8.8.1), separable, radii in pixels per
/// axis (x, y). The renderer samples each camera ray's film offset from the filter and weights
/// the sample by filter / pdf (sec. 8.8.2; negative lobes give negative weights); a pixel is
/// the weighted mean of its samples. pbrt-v4's defaults in brackets.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PixelFilter {
    /// 1 inside the radius [0.5].
    Box { radius: [f64; 2] },
    /// `max(0, G(x) - G(r))` per axis, `G` the normal density of standard deviation `sigma`
    /// [radius 1.5, sigma 0.5]. pbrt-v4's default when a file has no `PixelFilter`.
    Gaussian { radius: [f64; 2], sigma: f64 },
    /// Mitchell-Netravali cubic of `2 x / r` with `b`, `c` [radius 2, b = c = 1/3].
    Mitchell { radius: [f64; 2], b: f64, c: f64 },
    /// Lanczos windowed sinc, `sinc(x) sinc(x / tau)` inside the radius (pbrt-v4 `sinc`)
    /// [radius 4, tau 3].
    Lanczos { radius: [f64; 2], tau: f64 },
    /// `max(0, r - |x|)` per axis [radius 2].
    Triangle { radius: [f64; 2] },
}

impl Default for PixelFilter {
    fn default() -> Self {
        PixelFilter::Box { radius: [0.5, 0.5] }
    }
}

impl PixelFilter {
    /// Largest filter radius accepted, pixels (pbrt-v4 has no limit; the sampling table grows
    /// with the radius, and a wider filter blurs the image beyond use).
    pub const MAX_RADIUS_PX: f64 = 64.0;

    /// Check the parameters (radii between 1/32 pixel, pbrt-v4's table resolution, and
    /// [`Self::MAX_RADIUS_PX`]; a positive `sigma` and `tau`; finite `B` and `C`); the message
    /// names the bad one.
    pub fn validate(&self) -> Result<(), String> {
        let r = self.radius();
        if !r
            .iter()
            .all(|v| v.is_finite() && *v >= 1.0 / 32.0 && *v <= Self::MAX_RADIUS_PX)
        {
            return Err(format!(
                "radius {r:?} must lie between 1/32 and {} pixels",
                Self::MAX_RADIUS_PX
            ));
        }
        match *self {
            PixelFilter::Gaussian { sigma, .. } if !(sigma > 0.0 && sigma.is_finite()) => {
                Err(format!("sigma {sigma} must be > 0"))
            }
            PixelFilter::Mitchell { b, c, .. } if !(b.is_finite() && c.is_finite()) => {
                Err(format!("B {b} and C {c} must be finite"))
            }
            PixelFilter::Lanczos { tau, .. } if !(tau > 0.0 && tau.is_finite()) => {
                Err(format!("tau {tau} must be > 0"))
            }
            _ => Ok(()),
        }
    }

    /// The filter's radius in pixels, (x, y).
    pub fn radius(&self) -> [f64; 2] {
        match *self {
            PixelFilter::Box { radius }
            | PixelFilter::Gaussian { radius, .. }
            | PixelFilter::Mitchell { radius, .. }
            | PixelFilter::Lanczos { radius, .. }
            | PixelFilter::Triangle { radius } => radius,
        }
    }
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            grid: WavelengthGrid::default(),
            samples_per_pixel: 64,
            max_depth: 5,
            wavelengths_per_path: 4,
            seed: 0,
            time_budget_s: None,
            direct_only: false,
            sampler: SamplerKind::Sobol,
            russian_roulette_depth: 5,
            filter: PixelFilter::default(),
            time: crate::motion::TimeSettings::default(),
            light_sampler: LightSampler::Bvh,
            layered_exit_weight: LayeredExitWeight::Unbiased,
            adaptive: None,
            denoise: None,
        }
    }
}

/// Everything the renderer needs.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneDescription {
    pub camera: Camera,
    pub shapes: Vec<Shape>,
    pub materials: Vec<Material>,
    /// Named materials (pbrt `MakeNamedMaterial`, built-in wall names) -> index in `materials`.
    pub named_materials: HashMap<String, usize>,
    pub lights: Vec<Light>,
    pub settings: RenderSettings,
    /// Focus distance the scene was set up for, m (built-in scenes; used by optics for defocus).
    pub focus_distance_m: Option<f64>,
    /// Things the reader ignored or approximated (unsupported parameters), for the user.
    pub notes: Vec<String>,
    /// Participating media and the camera's medium (none: every ray travels in vacuum).
    pub media: crate::media::Media,
    /// Light group of each entry of `lights` (pbrt `LightSource ... "string lightgroup"`, or an
    /// overlay `[[light_group]]`); missing entries and `None`: the group `default`.
    pub light_groups: Vec<Option<String>>,
}

impl SceneDescription {
    /// Move the camera in its own frame by [`Camera::own_frame_offset`] (camera_to_world' =
    /// camera_to_world O), together with its motion during the exposure if it has one: the
    /// moved camera is fixed to the moving one
    /// (a rig on one body), world_from_camera'(t) = world_from_camera(t) O with O the
    /// [`Camera::own_frame_offset`], so a turning rig's offset camera swings about the rig's
    /// centre, not its own; the motion's reference pose stays the stored `camera_to_world`.
    pub fn move_camera_in_own_frame(
        &mut self,
        translation_m: [f64; 3],
        yaw_deg: f64,
        pitch_deg: f64,
        roll_deg: f64,
    ) {
        let offset = Camera::own_frame_offset(translation_m, yaw_deg, pitch_deg, roll_deg);
        self.camera.camera_to_world = self.camera.camera_to_world.then_apply_to(&offset);
        if let Some(m) = &mut self.settings.time.camera {
            // Motion parts compose outermost first: the offset is the innermost factor.
            m.parts.push(crate::motion::MotionPart::Fixed(offset));
        }
    }
}

/// Which sampler a render uses (pbrt-v4's `Sampler` types).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SamplerKind {
    /// Independent uniform pseudo-random numbers (pbrt-v4 `"independent"`).
    Independent,
    /// Owen-scrambled, padded Sobol (pbrt-v4 `"paddedsobol"`; also what camsim uses for
    /// `"sobol"` and `"zsobol"`).
    #[default]
    Sobol,
}

impl SamplerKind {
    /// The name used in settings, overlays and reports.
    pub fn name(self) -> &'static str {
        match self {
            SamplerKind::Independent => "independent",
            SamplerKind::Sobol => "sobol",
        }
    }

    /// Parse a sampler name: `independent`, or `sobol` / `paddedsobol` / `zsobol`.
    pub fn from_name(name: &str) -> Option<SamplerKind> {
        match name {
            "independent" => Some(SamplerKind::Independent),
            "sobol" | "paddedsobol" | "zsobol" => Some(SamplerKind::Sobol),
            _ => None,
        }
    }
}

/// The multiple-importance weight a layered BSDF's estimate of `f` gives a base (or medium)
/// sample that leaves through a rough top interface towards `wi`, against the direction
/// pre-sampled from `wi` (pbrt-v4 4th ed. sec. 14.3.2's two next-event strategies).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LayeredExitWeight {
    /// The power heuristic with the density the pre-sampling from `wi` gives that direction,
    /// `pdf(wi -> -w)`: the two strategies' weights sum to 1 and the estimate is unbiased
    /// (Veach 1997, sec. 9.2).
    #[default]
    Unbiased,
    /// pbrt-v4 5f7a606's `LayeredBxDF::f`: the reverse density `pdf(-w -> wi)`, with which the
    /// weights do not sum to 1 through a rough coating. Its estimate of `f` is then biased (a
    /// white-based coating of roughness 0.3 integrates to 0.755 where its sampled albedo is
    /// 0.700, measured with pbrt-v4 itself); only for reproducing pbrt-v4's renders.
    PbrtV4,
}

/// How next-event estimation chooses among a scene's lights (pbrt-v4's `lightsampler`
/// integrator parameter, 4th ed. sec. 12.6). All three are unbiased; they differ in variance.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LightSampler {
    /// By each light's importance at the shading point (pbrt-v4 `bvh`, its default; 4th ed.
    /// sec. 12.6.3): power over squared distance and the emitter's and the surface's
    /// orientation bounds, through a tree of light bounds. Scenes with moving lights fall back
    /// to [`LightSampler::Power`].
    #[default]
    Bvh,
    /// In proportion to each light's emitted power, the same everywhere (pbrt-v4 `power`).
    Power,
    /// Each of the n lights with probability 1 / n (pbrt-v4 `uniform`).
    Uniform,
}

impl LightSampler {
    /// The name used in pbrt-v4 files, overlays and reports.
    pub fn name(self) -> &'static str {
        match self {
            LightSampler::Bvh => "bvh",
            LightSampler::Power => "power",
            LightSampler::Uniform => "uniform",
        }
    }

    /// Parse a pbrt-v4 light sampler name: `bvh`, `power` or `uniform`.
    pub fn from_name(name: &str) -> Option<LightSampler> {
        match name {
            "bvh" => Some(LightSampler::Bvh),
            "power" => Some(LightSampler::Power),
            "uniform" => Some(LightSampler::Uniform),
            _ => None,
        }
    }
}

/// Half the width and height (mm) of a film of diagonal `diagonal_mm` with `width` x `height`
/// square pixels (pbrt-v4 `PixelSensor`/`Film` physical extent).
pub fn film_half_extent_mm(diagonal_mm: f64, width: usize, height: usize) -> [f64; 2] {
    let (w, h) = (width as f64, height as f64);
    let k = diagonal_mm / 2.0 / w.hypot(h);
    [w * k, h * k]
}
