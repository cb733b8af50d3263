//! Textures compiled for tracing, and their evaluation (pbrt-v4 "Textures": `constant`,
//! `imagemap`, `checkerboard` (2D), `scale`, `mix`, `directionmix`, `bilerp`, `dots`, and the
//! solid noises `fbm`, `wrinkled`, `windy`, `marble` ([`crate::noise`])), for spectrum and float
//! textures.
//!
//! API for materials: compile a scene [`Texture`] with [`compile_texture`] (spectrum; tables and
//! images go into the tracer's shared lists) or a [`FloatTexture`] with
//! [`compile_float_texture`], then evaluate at a hit with `Tracer::eval_texture(&tex, &ctx,
//! lambdas)` (`[f32; N]` at the path's wavelengths) or [`eval_float`] (`f32`). The context
//! [`TexCtx`] holds what pbrt-v4's `TextureEvalContext` holds that these textures read: the
//! surface's `(u, v)`, normal and point.
//!
//! A compiled texture is a small tree (`Box`ed nodes); leaves are indices into the tracer's
//! spectrum tables and RGB images. Evaluation allocates nothing.

use crate::error::RenderError;
use crate::image_tex::texels;
use crate::math::V3;
use crate::scene::{FloatTexture, TexelFilter, Texture, UvMapping, WrapMode};
use crate::spectral::{SpectrumTable, WavelengthSampler};
use std::sync::Arc;

/// Where a texture is evaluated (pbrt-v4 `TextureEvalContext`, the parts used here).
#[derive(Debug, Clone, Copy)]
pub(crate) struct TexCtx {
    /// Surface parameterisation (mesh uv, or pbrt's defaults).
    pub uv: [f32; 2],
    /// Unit surface normal (its sign does not matter to any texture here).
    pub n: V3,
    /// The hit point, world space (the solid textures map it to texture space).
    pub p: V3,
    /// The second uv set ([`crate::scene::MappingKind::Uv1`]; `uv` where a shape has none).
    pub uv1: [f32; 2],
    /// Linear RGBA vertex colour at the hit ([`crate::scene::Texture::VertexColored`],
    /// [`crate::scene::FloatTexture::VertexAlpha`]; white, opaque where a shape has none).
    pub color: [f32; 4],
    /// The pixel footprint on the surface's uv: `du/dx`, `du/dy`, `dv/dx`, `dv/dy` (pbrt-v4
    /// `TextureEvalContext::dudx` ...: one pixel step along the image's rows and columns,
    /// scaled by `max(1/8, 1/sqrt(spp))`). Zero where none was computed: MIP-mapped images then
    /// read level 0 and checkerboards are unfiltered.
    pub duv: [f32; 4],
}

impl TexCtx {
    /// The context of a surface hit: its uvs, vertex colour, geometric normal and point.
    #[inline]
    pub(crate) fn at(sh: &crate::geometry::SurfaceHit) -> TexCtx {
        TexCtx {
            uv: sh.uv,
            n: sh.ng,
            p: sh.p,
            uv1: sh.uv1,
            color: sh.color,
            duv: [0.0; 4],
        }
    }

    /// A context at `uv` (both sets) without vertex colour (light samples, tests).
    #[inline]
    pub(crate) fn at_uv(uv: [f32; 2], n: V3, p: V3) -> TexCtx {
        TexCtx {
            uv,
            n,
            p,
            uv1: uv,
            color: [1.0; 4],
            duv: [0.0; 4],
        }
    }
}

thread_local! {
    /// Set while compiling when a texture reads the pixel footprint ([`TexCtx::duv`]): a
    /// MIP-mapped image or a 2D checkerboard on a uv mapping ([`take_footprint_needed`]).
    static FOOTPRINT_NEEDED: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

fn mark_footprint_needed() {
    FOOTPRINT_NEEDED.with(|f| f.set(true));
}

/// Whether a texture compiled on this thread since the last call reads the pixel footprint
/// (the tracer then computes [`TexCtx::duv`] at every hit); resets the flag.
pub(crate) fn take_footprint_needed() -> bool {
    FOOTPRINT_NEEDED.with(|f| f.replace(false))
}

/// What a solid texture computes ([`crate::noise`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum SolidKind {
    Fbm,
    Wrinkled,
    Windy,
    Marble,
}

/// pbrt-v4 `TransformMapping3D`: world to texture space (the top three rows of the affine
/// matrix, the inverse of the texture's CTM).
#[derive(Debug, Clone, Copy)]
pub(crate) struct TexSpace([[f64; 4]; 3]);

impl TexSpace {
    fn new(t: &crate::scene::Transform) -> Result<TexSpace, String> {
        if t.m.iter().flatten().any(|v| !v.is_finite()) {
            return Err("a 3D texture's transform has a non-finite entry".into());
        }
        Ok(TexSpace([t.m[0], t.m[1], t.m[2]]))
    }

    /// The hit point in texture space.
    #[inline]
    pub(crate) fn point(&self, p: V3) -> [f64; 3] {
        let q = [p.x as f64, p.y as f64, p.z as f64];
        self.0
            .map(|r| r[0] * q[0] + r[1] * q[1] + r[2] * q[2] + r[3])
    }

    /// pbrt-v4's 3D checkerboard with a zero footprint: which of the two textures (0 or 1) at `p`,
    /// by the parity of floor(x) + floor(y) + floor(z).
    #[inline]
    pub(crate) fn checker(&self, p: V3) -> usize {
        (self.point(p).iter().map(|v| v.floor() as i64).sum::<i64>() & 1) as usize
    }
}

/// A compiled solid (3D) texture: pbrt-v4 `fbm`, `wrinkled`, `windy` (float) or `marble`
/// (spectrum), at the hit point mapped to texture space.
#[derive(Debug, Clone)]
pub(crate) struct Solid {
    kind: SolidKind,
    octaves: u32,
    omega: f64,
    /// `marble`'s `scale` and `variation`.
    scale: f64,
    variation: f64,
    space: TexSpace,
}

impl Solid {
    fn new(
        kind: SolidKind,
        octaves: u32,
        omega: f64,
        scale: f64,
        variation: f64,
        t: &crate::scene::Transform,
    ) -> Result<Solid, String> {
        if !(omega.is_finite() && scale.is_finite() && variation.is_finite()) {
            return Err(format!("solid texture with a non-finite roughness {omega}, scale {scale} or variation {variation}"));
        }
        Ok(Solid {
            kind,
            octaves,
            omega,
            scale,
            variation,
            space: TexSpace::new(t)?,
        })
    }

    /// A float solid texture's value at `ctx`.
    pub(crate) fn value(&self, ctx: &TexCtx) -> f32 {
        let q = self.space.point(ctx.p);
        (match self.kind {
            SolidKind::Fbm => crate::noise::fbm(q, self.omega, self.octaves),
            SolidKind::Wrinkled => crate::noise::turbulence(q, self.omega, self.octaves),
            SolidKind::Windy => crate::noise::windy(q),
            SolidKind::Marble => {
                let c = self.rgb(ctx);
                (c[0] + c[1] + c[2]) as f64 / 3.0
            }
        }) as f32
    }

    /// `marble`'s RGB albedo at `ctx` (clamped to [0, 1], as pbrt-v4's `RGBAlbedoSpectrum`).
    pub(crate) fn rgb(&self, ctx: &TexCtx) -> [f32; 3] {
        let q = self.space.point(ctx.p).map(|v| v * self.scale);
        crate::noise::marble_rgb(q, self.variation, self.omega, self.octaves)
            .map(|v| v.clamp(0.0, 1.0) as f32)
    }
}

/// pbrt-v4's 2D texture mappings (`UVMapping` in f32; spherical, cylindrical and planar on the
/// hit point in texture space).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Map {
    pub su: f32,
    pub sv: f32,
    pub du: f32,
    pub dv: f32,
    kind: MapKind,
}

#[derive(Debug, Clone, Copy)]
enum MapKind {
    Uv,
    Uv1,
    Spherical(TexSpace),
    Cylindrical(TexSpace),
    Planar(TexSpace, [f64; 3], [f64; 3]),
}

impl Map {
    fn new(m: &UvMapping) -> Result<Map, String> {
        use crate::scene::MappingKind as K;
        let unit = |v: [f64; 3]| -> Result<[f64; 3], String> {
            if v.iter().all(|c| c.is_finite()) {
                Ok(v)
            } else {
                Err(format!("planar mapping vector {v:?} is not finite"))
            }
        };
        let kind = match &m.kind {
            K::Uv => MapKind::Uv,
            K::Uv1 => MapKind::Uv1,
            K::Spherical { texture_from_world } => {
                MapKind::Spherical(TexSpace::new(texture_from_world)?)
            }
            K::Cylindrical { texture_from_world } => {
                MapKind::Cylindrical(TexSpace::new(texture_from_world)?)
            }
            K::Planar(p) => MapKind::Planar(
                TexSpace::new(&p.texture_from_world)?,
                unit(p.v1)?,
                unit(p.v2)?,
            ),
        };
        Ok(Map {
            su: m.uscale as f32,
            sv: m.vscale as f32,
            du: m.udelta as f32,
            dv: m.vdelta as f32,
            kind,
        })
    }

    /// Whether the mapping carries the footprint's uv derivatives to `(s, t)` (the uv mappings;
    /// pbrt-v4 also differentiates the others, which read unfiltered here).
    fn is_uv(&self) -> bool {
        matches!(self.kind, MapKind::Uv | MapKind::Uv1)
    }

    /// The footprint's `(ds/dx, ds/dy, dt/dx, dt/dy)` at `ctx` (pbrt-v4 `UVMapping::Map`: the uv
    /// derivatives times the scales); zero for the other mappings.
    #[inline]
    pub fn dst(&self, ctx: &TexCtx) -> [f32; 4] {
        if !self.is_uv() {
            return [0.0; 4];
        }
        let [dudx, dudy, dvdx, dvdy] = ctx.duv;
        [
            self.su * dudx,
            self.su * dudy,
            self.sv * dvdx,
            self.sv * dvdy,
        ]
    }

    /// Texture coordinates `(s, t)` at `ctx` (pbrt-v4 4th ed. sec. 10.2.1).
    #[inline(always)]
    pub fn st(&self, ctx: &TexCtx) -> (f32, f32) {
        match &self.kind {
            MapKind::Uv => (self.su * ctx.uv[0] + self.du, self.sv * ctx.uv[1] + self.dv),
            MapKind::Uv1 => (
                self.su * ctx.uv1[0] + self.du,
                self.sv * ctx.uv1[1] + self.dv,
            ),
            MapKind::Spherical(space) => {
                let p = space.point(ctx.p);
                let r = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
                if r == 0.0 {
                    return (0.0, 0.0);
                }
                let theta = (p[2] / r).clamp(-1.0, 1.0).acos();
                let phi = p[1].atan2(p[0]).rem_euclid(std::f64::consts::TAU);
                (
                    (theta / std::f64::consts::PI) as f32,
                    (phi / std::f64::consts::TAU) as f32,
                )
            }
            MapKind::Cylindrical(space) => {
                let p = space.point(ctx.p);
                (
                    ((std::f64::consts::PI + p[1].atan2(p[0])) / std::f64::consts::TAU) as f32,
                    p[2] as f32,
                )
            }
            MapKind::Planar(space, v1, v2) => {
                let p = space.point(ctx.p);
                let dot = |v: &[f64; 3]| p[0] * v[0] + p[1] * v[1] + p[2] * v[2];
                (self.du + dot(v1) as f32, self.dv + dot(v2) as f32)
            }
        }
    }
}

/// A compiled spectrum texture.
#[derive(Debug, Clone)]
pub(crate) enum Tex {
    /// Index into `Tracer::tables`.
    Table(u32),
    /// Index into `Tracer::images`, and the mapping to its (s, t).
    Image(u32, Map),
    Checker(Box<[Tex; 2]>, Map),
    /// 3D checkerboard.
    Checker3(Box<[Tex; 2]>, TexSpace),
    Scale(Box<Tex>, Box<FTex>),
    Mix(Box<[Tex; 2]>, Box<FTex>),
    DirMix(Box<[Tex; 2]>, V3),
    /// Tables of v00, v10, v01, v11.
    Bilerp([u32; 4], Map),
    /// pbrt-v4 `marble`.
    Marble(Box<Solid>),
    /// pbrt-v4 `dots`: inside, outside.
    Dots(Box<[Tex; 2]>, Map),
    /// An image (index into `Tracer::images`) whose RGB is multiplied by the hit's vertex colour
    /// before the uplift (glTF `COLOR_0`, [`Texture::VertexColored`]).
    VertexColored(u32, Map),
}

/// A one-channel image (float `imagemap`).
#[derive(Debug, Clone)]
pub(crate) struct FloatImage {
    pub width: usize,
    pub height: usize,
    pub values: Arc<[f32]>,
    pub wrap: WrapMode,
    pub filter: TexelFilter,
    /// The MIP pyramid of an image read by a pbrt-v4 filter ([`TexelFilter::uses_mip`]).
    pub mip: Option<crate::image_tex::Pyramid<1>>,
}

/// A compiled float texture.
#[derive(Debug, Clone)]
pub(crate) enum FTex {
    Const(f32),
    Image(Arc<FloatImage>, Map),
    Checker(Box<[FTex; 2]>, Map),
    Checker3(Box<[FTex; 2]>, TexSpace),
    Scale(Box<[FTex; 2]>),
    Mix(Box<[FTex; 3]>),
    DirMix(Box<[FTex; 2]>, V3),
    Bilerp([f32; 4], Map),
    Solid(Box<Solid>),
    /// pbrt-v4 `dots`: inside, outside.
    Dots(Box<[FTex; 2]>, Map),
    /// Times the hit's vertex alpha, then the cutoff where one is given (negative: none).
    VertexAlpha(Box<FTex>, f32),
}

/// Weight of `tex2` in pbrt-v4's 2D checkerboard without filtering: 0 where
/// `floor(s) + floor(t)` is even, 1 where odd (pbrt-v4 `Checkerboard()` with zero footprint).
#[inline(always)]
pub(crate) fn checker_weight(s: f32, t: f32) -> f32 {
    let k = (s.floor() as i64).wrapping_add(t.floor() as i64);
    (k & 1) as f32
}

/// The +-1 square wave of the checks along one axis (+1 on even cells) averaged against a
/// triangle filter of half-width `r` centred at `x` (pbrt-v4 `Checkerboard()`'s `bf`): the
/// second difference of the wave's second antiderivative `d`, over `r^2`; the cell's own sign
/// where the filter stays inside it.
#[inline]
fn filtered_square_wave(x: f32, r: f32) -> f32 {
    if (x - r).floor() == (x + r).floor() {
        return 1.0 - 2.0 * ((x.floor() as i64) & 1) as f32;
    }
    // d(x) = x/2 + y (1 - 2|y|), y = x/2 - floor(x/2) - 1/2: twice integrated square wave.
    let d = |x: f32| {
        let y = x / 2.0 - (x / 2.0).floor() - 0.5;
        x / 2.0 + y * (1.0 - 2.0 * y.abs())
    };
    (d(x + r) - 2.0 * d(x) + d(x - r)) / (r * r)
}

/// Weight of `tex2` in pbrt-v4's 2D checkerboard filtered over the footprint `dst`
/// ([`Map::dst`]): each axis's square wave against a triangle filter 1.5 times the larger of
/// its two derivatives wide, `1/2 - bf(s) bf(t) / 2` (pbrt-v4 `Checkerboard()`); unfiltered
/// where the footprint is zero.
#[inline]
pub(crate) fn checker_weight_filtered(s: f32, t: f32, dst: [f32; 4]) -> f32 {
    let ds = 1.5 * dst[0].abs().max(dst[1].abs());
    let dt = 1.5 * dst[2].abs().max(dst[3].abs());
    if !(ds > 0.0 || dt > 0.0) || !(ds.is_finite() && dt.is_finite()) {
        return checker_weight(s, t);
    }
    0.5 - filtered_square_wave(s, ds) * filtered_square_wave(t, dt) / 2.0
}

/// Refuses a MIP pyramid of a `width` x `height` image of `channels` f32 channels that would not
/// fit in the memory left, before it is allocated ([`crate::image_tex::pyramid_bytes`]).
fn check_pyramid(width: usize, height: usize, channels: usize) -> Result<(), String> {
    camsim_core::mem::check_alloc(
        crate::image_tex::pyramid_bytes(width, height, channels),
        &format!("the MIP pyramid of a {width} x {height} image texture"),
    )
    .map_err(|e| e.to_string())
}

/// Bilinear interpolation weights (pbrt-v4 `Bilerp`): v00, v10, v01, v11.
#[inline(always)]
pub(crate) fn bilerp_weights(s: f32, t: f32) -> [f32; 4] {
    [(1.0 - s) * (1.0 - t), s * (1.0 - t), (1.0 - s) * t, s * t]
}

/// Evaluate a float texture at `ctx`.
pub(crate) fn eval_float(t: &FTex, ctx: &TexCtx) -> f32 {
    match t {
        FTex::Const(v) => *v,
        FTex::Image(im, map) => {
            let (s, tt) = map.st(ctx);
            if let Some(p) = &im.mip {
                return p.filter_footprint(im.filter, s, tt, map.dst(ctx), im.wrap)[0];
            }
            let (idx, w) = texels(im.width, im.height, s, tt, im.wrap, im.filter);
            (0..4).map(|k| w[k] * im.values[idx[k]]).sum()
        }
        FTex::Checker(c, map) => {
            let (s, tt) = map.st(ctx);
            let w = checker_weight_filtered(s, tt, map.dst(ctx));
            let a = if w != 1.0 {
                eval_float(&c[0], ctx)
            } else {
                0.0
            };
            let b = if w != 0.0 {
                eval_float(&c[1], ctx)
            } else {
                0.0
            };
            (1.0 - w) * a + w * b
        }
        FTex::Checker3(c, space) => eval_float(&c[space.checker(ctx.p)], ctx),
        FTex::VertexAlpha(t, cutoff) => {
            // glTF 2.0 sec. 3.9.4: alpha = factor x texture x COLOR_0's alpha, then MASK's cutoff.
            let a = eval_float(t, ctx) * ctx.color[3];
            if *cutoff < 0.0 {
                a
            } else if a >= *cutoff {
                1.0
            } else {
                0.0
            }
        }
        FTex::Scale(c) => {
            // pbrt-v4 FloatScaledTexture: a zero scale short-circuits.
            let sc = eval_float(&c[1], ctx);
            if sc == 0.0 {
                0.0
            } else {
                sc * eval_float(&c[0], ctx)
            }
        }
        FTex::Mix(c) => {
            let amt = eval_float(&c[2], ctx);
            let a = if amt != 1.0 {
                eval_float(&c[0], ctx)
            } else {
                0.0
            };
            let b = if amt != 0.0 {
                eval_float(&c[1], ctx)
            } else {
                0.0
            };
            (1.0 - amt) * a + amt * b
        }
        FTex::DirMix(c, dir) => {
            let amt = ctx.n.dot(*dir).abs();
            let a = if amt != 0.0 {
                eval_float(&c[0], ctx)
            } else {
                0.0
            };
            let b = if amt != 1.0 {
                eval_float(&c[1], ctx)
            } else {
                0.0
            };
            amt * a + (1.0 - amt) * b
        }
        FTex::Bilerp(v, map) => {
            let (s, tt) = map.st(ctx);
            let w = bilerp_weights(s, tt);
            (0..4).map(|k| w[k] * v[k]).sum()
        }
        FTex::Solid(solid) => solid.value(ctx),
        FTex::Dots(c, map) => {
            let (s, tt) = map.st(ctx);
            eval_float(
                &c[!crate::noise::inside_polka_dot(s as f64, tt as f64) as usize],
                ctx,
            )
        }
    }
}

fn unit_dir(d: [f64; 3]) -> Result<V3, String> {
    let v = V3::from_f64(d);
    let l = v.length();
    if l > 0.0 && l.is_finite() {
        Ok(v / l)
    } else {
        Err(format!(
            "directionmix direction {d:?} is not a usable direction"
        ))
    }
}

fn check_map(m: &UvMapping) -> Result<Map, String> {
    if [m.uscale, m.vscale, m.udelta, m.vdelta]
        .iter()
        .all(|v| v.is_finite())
    {
        Map::new(m)
    } else {
        Err(format!("texture mapping {m:?} has a non-finite value"))
    }
}

/// Compile a float texture.
pub(crate) fn compile_float_texture(
    t: &FloatTexture,
    material_index: usize,
) -> Result<FTex, RenderError> {
    compile_float(t).map_err(|message| RenderError::Material {
        index: material_index,
        message,
    })
}

fn compile_float(t: &FloatTexture) -> Result<FTex, String> {
    Ok(match t {
        FloatTexture::VertexAlpha { tex, cutoff } => {
            let c = match cutoff {
                Some(c) if c.is_finite() => (*c as f32).max(0.0),
                Some(c) => return Err(format!("alpha cutoff {c} is not finite")),
                None => -1.0,
            };
            FTex::VertexAlpha(Box::new(compile_float(tex)?), c)
        }
        FloatTexture::Constant(v) => {
            if !v.is_finite() {
                return Err(format!("float texture value {v} is not finite"));
            }
            FTex::Const(*v as f32)
        }
        FloatTexture::Image {
            width,
            height,
            values,
            mapping,
            wrap,
            filter,
        } => {
            if *width == 0 || *height == 0 || values.len() != width * height {
                return Err(format!(
                    "float image texture of {width} x {height} pixels has {} values",
                    values.len()
                ));
            }
            if values.iter().any(|v| !v.is_finite()) {
                return Err("float image texture has a non-finite value".into());
            }
            let map = check_map(mapping)?;
            let mip = if filter.uses_mip() {
                check_pyramid(*width, *height, 1)?;
                let texels: Vec<[f32; 1]> = values.iter().map(|v| [*v]).collect();
                Some(crate::image_tex::Pyramid::new(
                    *width, *height, &texels, *wrap,
                ))
            } else {
                None
            };
            if mip.is_some() && map.is_uv() {
                mark_footprint_needed();
            }
            FTex::Image(
                Arc::new(FloatImage {
                    width: *width,
                    height: *height,
                    values: values.clone(),
                    wrap: *wrap,
                    filter: *filter,
                    mip,
                }),
                map,
            )
        }
        FloatTexture::Checkerboard {
            tex1,
            tex2,
            mapping,
        } => {
            let map = check_map(mapping)?;
            if map.is_uv() {
                mark_footprint_needed();
            }
            FTex::Checker(Box::new([compile_float(tex1)?, compile_float(tex2)?]), map)
        }
        FloatTexture::Checkerboard3d {
            tex1,
            tex2,
            texture_from_world,
        } => FTex::Checker3(
            Box::new([compile_float(tex1)?, compile_float(tex2)?]),
            TexSpace::new(texture_from_world)?,
        ),
        FloatTexture::Scale { tex, scale } => {
            FTex::Scale(Box::new([compile_float(tex)?, compile_float(scale)?]))
        }
        FloatTexture::Mix { tex1, tex2, amount } => FTex::Mix(Box::new([
            compile_float(tex1)?,
            compile_float(tex2)?,
            compile_float(amount)?,
        ])),
        FloatTexture::DirectionMix {
            tex1,
            tex2,
            direction,
        } => FTex::DirMix(
            Box::new([compile_float(tex1)?, compile_float(tex2)?]),
            unit_dir(*direction)?,
        ),
        FloatTexture::Bilerp {
            v00,
            v01,
            v10,
            v11,
            mapping,
        } => {
            let v = [*v00, *v10, *v01, *v11];
            if v.iter().any(|x| !x.is_finite()) {
                return Err(format!("bilerp values {v:?} must be finite"));
            }
            FTex::Bilerp(v.map(|x| x as f32), check_map(mapping)?)
        }
        FloatTexture::Noise(n) => {
            let kind = match n.kind {
                crate::scene::NoiseKind::Fbm => SolidKind::Fbm,
                crate::scene::NoiseKind::Wrinkled => SolidKind::Wrinkled,
                crate::scene::NoiseKind::Windy => SolidKind::Windy,
            };
            FTex::Solid(Box::new(Solid::new(
                kind,
                n.octaves,
                n.roughness,
                1.0,
                0.0,
                &n.texture_from_world,
            )?))
        }
        FloatTexture::Dots {
            inside,
            outside,
            mapping,
        } => FTex::Dots(
            Box::new([compile_float(inside)?, compile_float(outside)?]),
            check_map(mapping)?,
        ),
    })
}

/// Compile a spectrum texture: constants become spectrum tables (appended to `tables`), RGB
/// images are appended to `images`. Negative spectra are an error (`what` names the parameter).
pub(crate) fn compile_texture(
    t: &Texture,
    material_index: usize,
    ws: &WavelengthSampler,
    tables: &mut Vec<SpectrumTable>,
    images: &mut Vec<crate::image_tex::ImageTex>,
) -> Result<Tex, RenderError> {
    let err = |message: String| RenderError::Material {
        index: material_index,
        message,
    };
    let table =
        |s: &camsim_core::Spectrum, tables: &mut Vec<SpectrumTable>| -> Result<u32, RenderError> {
            s.require_non_negative("texture spectrum")
                .map_err(|e| err(e.to_string()))?;
            tables.push(SpectrumTable::new(s, 1.0, ws));
            Ok((tables.len() - 1) as u32)
        };
    Ok(match t {
        Texture::Constant(s) => Tex::Table(table(s, tables)?),
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
        } => {
            if *width == 0 || *height == 0 || rgb.len() != width * height {
                return Err(err(format!(
                    "image texture of {width} x {height} pixels has {} values",
                    rgb.len()
                )));
            }
            if rgb.iter().flatten().any(|v| !v.is_finite()) {
                return Err(err("image texture has a non-finite value".into()));
            }
            // The mapping gives (s, t); the image itself is looked up with the identity scale.
            let map = check_map(&UvMapping {
                uscale: *uscale,
                vscale: *vscale,
                udelta: *udelta,
                vdelta: *vdelta,
                kind: kind.clone(),
            })
            .map_err(err)?;
            // One pyramid per image and wrap mode, shared by every material that names it.
            let mip = if filter.uses_mip() {
                let shared = images
                    .iter()
                    .find(|i| Arc::ptr_eq(&i.rgb, rgb) && i.wrap == *wrap && i.mip.is_some())
                    .and_then(|i| i.mip.clone());
                Some(match shared {
                    Some(p) => p,
                    None => {
                        check_pyramid(*width, *height, 3).map_err(err)?;
                        Arc::new(crate::image_tex::Pyramid::new(*width, *height, rgb, *wrap))
                    }
                })
            } else {
                None
            };
            if mip.is_some() && map.is_uv() {
                mark_footprint_needed();
            }
            images.push(crate::image_tex::ImageTex {
                width: *width,
                height: *height,
                rgb: rgb.clone(),
                uscale: 1.0,
                vscale: 1.0,
                udelta: 0.0,
                vdelta: 0.0,
                wrap: *wrap,
                filter: *filter,
                mip,
            });
            Tex::Image((images.len() - 1) as u32, map)
        }
        Texture::VertexColored(inner) => {
            match compile_texture(inner, material_index, ws, tables, images)? {
                Tex::Image(im, map) => Tex::VertexColored(im, map),
                _ => {
                    return Err(err(
                        "a vertex-coloured texture must wrap an image texture".into()
                    ))
                }
            }
        }
        Texture::Checkerboard {
            tex1,
            tex2,
            mapping,
        } => {
            let map = check_map(mapping).map_err(err)?;
            if map.is_uv() {
                mark_footprint_needed();
            }
            Tex::Checker(
                Box::new([
                    compile_texture(tex1, material_index, ws, tables, images)?,
                    compile_texture(tex2, material_index, ws, tables, images)?,
                ]),
                map,
            )
        }
        Texture::Checkerboard3d {
            tex1,
            tex2,
            texture_from_world,
        } => Tex::Checker3(
            Box::new([
                compile_texture(tex1, material_index, ws, tables, images)?,
                compile_texture(tex2, material_index, ws, tables, images)?,
            ]),
            TexSpace::new(texture_from_world).map_err(err)?,
        ),
        Texture::Scale { tex, scale } => Tex::Scale(
            Box::new(compile_texture(tex, material_index, ws, tables, images)?),
            Box::new(compile_float_texture(scale, material_index)?),
        ),
        Texture::Mix { tex1, tex2, amount } => Tex::Mix(
            Box::new([
                compile_texture(tex1, material_index, ws, tables, images)?,
                compile_texture(tex2, material_index, ws, tables, images)?,
            ]),
            Box::new(compile_float_texture(amount, material_index)?),
        ),
        Texture::DirectionMix {
            tex1,
            tex2,
            direction,
        } => Tex::DirMix(
            Box::new([
                compile_texture(tex1, material_index, ws, tables, images)?,
                compile_texture(tex2, material_index, ws, tables, images)?,
            ]),
            unit_dir(*direction).map_err(err)?,
        ),
        Texture::Bilerp {
            v00,
            v01,
            v10,
            v11,
            mapping,
        } => {
            let map = check_map(mapping).map_err(err)?;
            Tex::Bilerp(
                [
                    table(v00, tables)?,
                    table(v10, tables)?,
                    table(v01, tables)?,
                    table(v11, tables)?,
                ],
                map,
            )
        }
        Texture::Marble {
            octaves,
            roughness,
            scale,
            variation,
            texture_from_world,
        } => Tex::Marble(Box::new(
            Solid::new(
                SolidKind::Marble,
                *octaves,
                *roughness,
                *scale,
                *variation,
                texture_from_world,
            )
            .map_err(err)?,
        )),
        Texture::Dots {
            inside,
            outside,
            mapping,
        } => Tex::Dots(
            Box::new([
                compile_texture(inside, material_index, ws, tables, images)?,
                compile_texture(outside, material_index, ws, tables, images)?,
            ]),
            check_map(mapping).map_err(err)?,
        ),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// pbrt-v4's filtered checkerboard is the checks averaged against a triangle filter: its
    /// closed form against a midpoint-rule integral of the square wave times `(r - |u|) / r^2`,
    /// inside a cell, across one edge and over several cells; a zero footprint is unfiltered and
    /// a wide one tends to the mean blend 1/2.
    #[test]
    fn the_filtered_checkerboard_is_the_triangle_filtered_average() {
        let square = |x: f64| 1.0 - 2.0 * ((x.floor() as i64) & 1) as f64;
        let numeric = |x: f64, r: f64| {
            let n = 20_000;
            let (mut s, mut w) = (0.0, 0.0);
            for i in 0..n {
                let u = -r + 2.0 * r * (i as f64 + 0.5) / n as f64;
                let k = r - u.abs();
                s += square(x + u) * k;
                w += k;
            }
            s / w
        };
        for (x, r) in [
            (0.9, 0.2),
            (0.5, 0.6),
            (1.3, 2.7),
            (0.95, 0.1),
            (0.2, 0.25),
            (-0.7, 1.1),
            (3.5, 0.4),
        ] {
            let got = filtered_square_wave(x as f32, r as f32) as f64;
            let want = numeric(x, r);
            assert!((got - want).abs() < 1e-4, "x {x} r {r}: {got} vs {want}");
        }
        assert_eq!(checker_weight_filtered(1.5, 0.5, [0.0; 4]), 1.0);
        // Both axes filtered: 1/2 - bf(s) bf(t) / 2 with each half-width 1.5 x the larger
        // derivative.
        let (s, t, d) = (0.9f32, 0.3f32, [0.1f32, -0.2, 0.05, 0.0]);
        let want = 0.5 - numeric(0.9, 0.3) * numeric(0.3, 0.075) / 2.0;
        let got = checker_weight_filtered(s, t, d) as f64;
        assert!((got - want).abs() < 1e-4, "{got} vs {want}");
        let wide = checker_weight_filtered(0.37, 0.81, [40.0, 0.0, 40.0, 0.0]);
        assert!((wide - 0.5).abs() < 1e-3, "{wide}");
    }

    #[test]
    fn checker_parity_and_bilerp_corners() {
        assert_eq!(checker_weight(0.5, 0.5), 0.0);
        assert_eq!(checker_weight(1.5, 0.5), 1.0);
        assert_eq!(checker_weight(-0.5, 0.5), 1.0);
        assert_eq!(checker_weight(-0.5, -0.5), 0.0);
        assert_eq!(bilerp_weights(0.0, 0.0), [1.0, 0.0, 0.0, 0.0]);
        assert_eq!(bilerp_weights(1.0, 0.0), [0.0, 1.0, 0.0, 0.0]);
        assert_eq!(bilerp_weights(0.0, 1.0), [0.0, 0.0, 1.0, 0.0]);
        let w = bilerp_weights(0.3, 0.7);
        assert!((w.iter().sum::<f32>() - 1.0).abs() < 1e-6);
    }

    /// The value a bilinear lookup of a 4 x 2 image with texel value `10 y + x` returns.
    fn lookup(s: f32, t: f32, wrap: WrapMode) -> f32 {
        lookup_by(s, t, wrap, TexelFilter::Bilinear)
    }

    /// The value a lookup by `filter` of the 4 x 2 image with texel value `10 y + x` returns.
    fn lookup_by(s: f32, t: f32, wrap: WrapMode, filter: TexelFilter) -> f32 {
        let (idx, w) = texels(4, 2, s, t, wrap, filter);
        (0..4)
            .map(|k| w[k] * ((idx[k] / 4) * 10 + idx[k] % 4) as f32)
            .sum()
    }

    #[test]
    fn wrap_modes_remap_texels_as_pbrt_v4() {
        // Texel centres: x = (i + 0.5) / 4, row y at t = 1 - (j + 0.5) / 2. At a texel centre
        // every mode reads the texel itself.
        for wrap in [
            WrapMode::Repeat,
            WrapMode::Clamp,
            WrapMode::Black,
            WrapMode::OctahedralSphere,
        ] {
            assert_eq!(lookup(0.625, 0.75, wrap), 2.0, "{wrap:?}");
            assert_eq!(lookup(0.375, 0.25, wrap), 11.0, "{wrap:?}");
        }
        // The centre of texel column -1 (s = -1/8), row 0: repeat reads column 3, clamp column
        // 0, black 0, the octahedral sphere column 1 of the mirrored row 1 (pbrt-v4
        // `RemapPixelCoords`: x -> -x, y -> h - 1 - y).
        assert_eq!(lookup(-0.125, 0.75, WrapMode::Repeat), 3.0);
        assert_eq!(lookup(-0.125, 0.75, WrapMode::Clamp), 0.0);
        assert_eq!(lookup(-0.125, 0.75, WrapMode::Black), 0.0);
        assert_eq!(lookup(-0.125, 0.75, WrapMode::OctahedralSphere), 11.0);
        // Beyond the right edge (column 4): repeat 0, clamp 3, octahedral 2 w - 1 - 4 = 3 in
        // the mirrored row.
        assert_eq!(lookup(1.125, 0.75, WrapMode::Repeat), 0.0);
        assert_eq!(lookup(1.125, 0.75, WrapMode::Clamp), 3.0);
        assert_eq!(lookup(1.125, 0.75, WrapMode::OctahedralSphere), 13.0);
        // Above the top (row -1, t = 1.25): octahedral mirrors u about 0.5 (column 3 - x) and
        // reads row 1; clamp reads row 0; black 0.
        assert_eq!(lookup(0.125, 1.25, WrapMode::OctahedralSphere), 13.0);
        assert_eq!(lookup(0.125, 1.25, WrapMode::Clamp), 0.0);
        assert_eq!(lookup(0.125, 1.25, WrapMode::Black), 0.0);
        assert_eq!(lookup(0.125, 1.25, WrapMode::Repeat), 10.0);
        // Halfway between the last column and the one beyond: black weighs the outside texel
        // as zero (pbrt-v4: 0.5 * 3 + 0.5 * 0), clamp as the edge texel.
        assert!((lookup(1.0, 0.75, WrapMode::Black) - 1.5).abs() < 1e-6);
        assert!((lookup(1.0, 0.75, WrapMode::Clamp) - 3.0).abs() < 1e-6);
        assert!((lookup(1.0, 0.75, WrapMode::Repeat) - 1.5).abs() < 1e-6);
    }

    #[test]
    fn point_filter_reads_the_nearest_texel() {
        let point = |s, t, wrap| lookup_by(s, t, wrap, TexelFilter::Point);
        // pbrt-v4 `point`: texel (round(4 s - 1/2), round(2 (1 - t) - 1/2)). Just left and just
        // right of the boundary between columns 1 and 2 (s = 0.5), row 0 (t = 0.75) and row 1.
        assert_eq!(point(0.49, 0.75, WrapMode::Repeat), 1.0);
        assert_eq!(point(0.51, 0.75, WrapMode::Repeat), 2.0);
        assert_eq!(point(0.49, 0.26, WrapMode::Repeat), 11.0);
        // A quarter texel off the centre of texel (2, 1) in both axes: bilinear blends, point not.
        assert_eq!(point(0.6875, 0.125, WrapMode::Repeat), 12.0);
        assert!((lookup(0.6875, 0.125, WrapMode::Repeat) - 12.0).abs() > 0.1);
        // Beyond the edges the wrap mode picks the texel: column -1 is column 3 (repeat),
        // column 0 (clamp), nothing (black); row 1 mirrored for the octahedral sphere.
        assert_eq!(point(-0.1, 0.75, WrapMode::Repeat), 3.0);
        assert_eq!(point(-0.1, 0.75, WrapMode::Clamp), 0.0);
        assert_eq!(point(-0.1, 0.75, WrapMode::Black), 0.0);
        assert_eq!(point(-0.1, 0.75, WrapMode::OctahedralSphere), 11.0);
        // Nearer the inside texel than the black outside one: the texel, whole.
        assert_eq!(point(0.99, 0.75, WrapMode::Black), 3.0);
    }

    #[test]
    fn float_graph_evaluates_like_pbrt() {
        let ctx = TexCtx::at_uv([0.25, 0.75], V3::new(0.0, 0.0, 1.0), V3::new(0.0, 0.0, 0.0));
        let c = |v: f64| Box::new(FloatTexture::Constant(v));
        let mix = FloatTexture::Mix {
            tex1: c(2.0),
            tex2: c(4.0),
            amount: c(0.25),
        };
        assert!((eval_float(&compile_float(&mix).unwrap(), &ctx) - 2.5).abs() < 1e-6);
        let sc = FloatTexture::Scale {
            tex: c(3.0),
            scale: c(0.5),
        };
        assert!((eval_float(&compile_float(&sc).unwrap(), &ctx) - 1.5).abs() < 1e-6);
        // |n . dir| = cos 60 deg = 0.5.
        let dm = FloatTexture::DirectionMix {
            tex1: c(1.0),
            tex2: c(0.0),
            direction: [0.0, 3f64.sqrt() / 2.0, -0.5],
        };
        assert!((eval_float(&compile_float(&dm).unwrap(), &ctx) - 0.5).abs() < 1e-6);
        let bl = FloatTexture::Bilerp {
            v00: 0.0,
            v01: 1.0,
            v10: 10.0,
            v11: 100.0,
            mapping: UvMapping::default(),
        };
        // (1-s)(1-t) 0 + s(1-t) 10 + (1-s) t 1 + s t 100 at s = 0.25, t = 0.75.
        let want = 0.25 * 0.25 * 10.0 + 0.75 * 0.75 * 1.0 + 0.25 * 0.75 * 100.0;
        assert!((eval_float(&compile_float(&bl).unwrap(), &ctx) - want).abs() < 1e-4);
        let ck = FloatTexture::Checkerboard {
            tex1: c(1.0),
            tex2: c(2.0),
            mapping: UvMapping {
                uscale: 4.0,
                ..UvMapping::default()
            },
        };
        // s = 1, t = 0.75: floor sum 1 -> tex2.
        assert_eq!(eval_float(&compile_float(&ck).unwrap(), &ctx), 2.0);
        assert!(compile_float(&FloatTexture::Constant(f64::NAN)).is_err());
    }
}
