//! The scene compiled for tracing ([`Tracer`]: BVH, materials, lights as lookup tables; built
//! step by step in `integrator/compile.rs`) and the spectral path integrator: next-event estimation combined with BSDF sampling by multiple importance
//! sampling (power heuristic), Russian roulette, a maximum depth (pbrt-v4 `PathIntegrator::Li`).

use crate::bsdf::Bsdf;
use crate::bvh::Bvh;
use crate::geometry::{
    offset_ray_origin, sphere_point_err, tri_point_err, MeshShading, Prim, PrimInfo, Ray, RayInv,
    SurfaceHit, NO_LIGHT,
};
use crate::image_tex::ImageTex;
use crate::light_groups::PathRadiance;
use crate::lights::{LightSample, Lights, NO_ALPHA};
use crate::materials::Mat;
use crate::math::{Frame, V3};
use crate::motion::PathTime;
use crate::sampler::{dim, PathSampler};
use crate::sampling::power_heuristic;
use crate::spectral::{Lambdas, SpectrumTable};
use crate::texture::{eval_float, FTex, Tex, TexCtx};

mod compile;
mod material_eval;
mod moving;
mod shading;
mod volpath;

pub(crate) use compile::prim_count;

/// Most `interface` surfaces (and alpha cut-out hits) one path passes through before it is
/// ended (a guard against rays trapped by coincident surfaces; pbrt-v4 has none).
const MAX_INTERFACE_SKIPS: u32 = 256;

/// Counters of rays cast, per tile (summed into [`crate::RenderStats`]).
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct RayCounts {
    pub camera: u64,
    pub bounce: u64,
    pub shadow: u64,
}

/// The scene prepared for tracing.
pub(crate) struct Tracer {
    pub bvh: Bvh,
    pub info: Vec<PrimInfo>,
    /// Unit geometric normal of each triangle, in BVH order (zero for spheres).
    pub tri_normals: Vec<V3>,
    pub meshes: Vec<Option<MeshShading>>,
    pub materials: Vec<Mat>,
    pub tables: Vec<SpectrumTable>,
    pub images: Vec<ImageTex>,
    pub lights: Lights,
    pub max_depth: u32,
    /// Russian roulette runs at scattering vertices with `depth >= rr_depth`.
    pub rr_depth: u32,
    /// Per shape: its geometric normal is flipped (`Shape::reverse_orientation`), which decides
    /// the inside of dielectrics.
    pub shape_flip: Vec<bool>,
    /// Some material is (or mixes in) `interface`: shadow rays must pass through those surfaces.
    pub has_interface: bool,
    /// Some shape has an alpha cut-out: every ray runs the alpha test at its hits.
    pub has_alpha: bool,
    /// The camera's pixel footprint, for bump mapping's finite differences (`crate::bump`) and
    /// the filtered textures.
    pub footprint: crate::bump::Footprint,
    /// Some texture reads the footprint (a MIP-mapped image, a 2D checkerboard): every
    /// scattering hit computes [`TexCtx::duv`].
    pub footprint_textures: bool,
    /// Layered BSDFs weigh their exits as pbrt-v4 5f7a606 does
    /// ([`crate::scene::LayeredExitWeight::PbrtV4`]).
    pub layered_exit_pbrt_v4: bool,
    /// Participating media, when a ray can be in one (then `volpath` renders the scene).
    pub media: Option<Box<crate::media::MediaSet>>,
    /// Per compiled light (`lights.list`): the shape it belongs to, or `shapes.len()` plus the
    /// index of its scene light.
    pub light_source: Vec<u32>,
    /// What moves (`crate::motion`); `None` for a static scene.
    pub motion: Option<Box<crate::motion::MotionTracer>>,
}

impl Tracer {
    /// Closest hit along `r` within `t_max` at the path's time, if any.
    #[inline(always)]
    pub(crate) fn intersect_within(
        &self,
        r: &Ray,
        t_max: f32,
        pt: &PathTime,
    ) -> Option<crate::bvh::Hit> {
        let h = self.bvh.intersect(&RayInv::new(r), t_max);
        match &self.motion {
            None => h,
            Some(m) => m.intersect(r, t_max, pt, h),
        }
    }

    /// Closest hit along `r` at the path's time, if any.
    #[inline(always)]
    pub(crate) fn intersect(&self, r: &Ray, pt: &PathTime) -> Option<crate::bvh::Hit> {
        self.intersect_within(r, f32::INFINITY, pt)
    }

    /// The surface of hit `h` of ray `r` at the path's time.
    pub(crate) fn surface(&self, r: &Ray, h: &crate::bvh::Hit, pt: &PathTime) -> SurfaceHit {
        let slot = h.slot as usize;
        match self.bvh.prims.get(slot) {
            Some(prim) => self.surface_of(prim, self.tri_normals[slot], &self.bvh, r, h),
            None => self.moving_surface(r, h, pt),
        }
    }

    /// The surface of hit `h` on `prim` (triangle normal `tri_normal`; partial-sphere clips and
    /// curve segments from `side`, the BVH that holds `prim`; `h.slot` indexes `info`).
    pub(crate) fn surface_of(
        &self,
        prim: &Prim,
        tri_normal: V3,
        side: &crate::bvh::Bvh,
        r: &Ray,
        h: &crate::bvh::Hit,
    ) -> SurfaceHit {
        let slot = h.slot as usize;
        match *prim {
            Prim::Tri { p0, e1, e2 } => {
                let p = p0 + e1 * h.u + e2 * h.v;
                let err = tri_point_err(p0, e1, e2, h.u, h.v);
                let ng = tri_normal;
                let pi = &self.info[slot];
                let (mut ns, mut uv) = (ng, [h.u, h.v]);
                let (mut uv1, mut color) = (None, [1.0f32; 4]);
                if let Some(m) = &self.meshes[pi.shape as usize] {
                    let tri = m.indices[pi.tri as usize];
                    let w = 1.0 - h.u - h.v;
                    if let Some(n) = &m.normals {
                        let v = n[tri[0] as usize] * w
                            + n[tri[1] as usize] * h.u
                            + n[tri[2] as usize] * h.v;
                        if v.length_squared() > 0.0 {
                            ns = v.normalize();
                        }
                    }
                    if let Some(t) = &m.uvs {
                        let (a, b, c) =
                            (t[tri[0] as usize], t[tri[1] as usize], t[tri[2] as usize]);
                        uv = [
                            w * a[0] + h.u * b[0] + h.v * c[0],
                            w * a[1] + h.u * b[1] + h.v * c[1],
                        ];
                    } else {
                        // pbrt-v4 default triangle uvs (0,0), (1,0), (1,1).
                        uv = [h.u + h.v, h.v];
                    }
                    // Barycentric interpolation of the second uv set and the vertex colours
                    // (glTF 2.0 sec. 3.7.2.1: attributes are linearly interpolated).
                    if let Some(t) = &m.uvs1 {
                        let (a, b, c) =
                            (t[tri[0] as usize], t[tri[1] as usize], t[tri[2] as usize]);
                        uv1 = Some([
                            w * a[0] + h.u * b[0] + h.v * c[0],
                            w * a[1] + h.u * b[1] + h.v * c[1],
                        ]);
                    }
                    if let Some(cs) = &m.colors {
                        let (a, b, c) = (
                            cs[tri[0] as usize],
                            cs[tri[1] as usize],
                            cs[tri[2] as usize],
                        );
                        color = std::array::from_fn(|k| w * a[k] + h.u * b[k] + h.v * c[k]);
                    }
                } else {
                    uv = [uv[0] + uv[1], uv[1]];
                }
                SurfaceHit {
                    p,
                    ng,
                    ns,
                    uv,
                    uv1: uv1.unwrap_or(uv),
                    color,
                    dpdu: V3::splat(0.0),
                    err,
                }
            }
            Prim::Sphere { center, radius } => {
                let p0 = r.o + r.d * h.t;
                let n = (p0 - center).normalize();
                let p = center + n * radius;
                // pbrt-v4 full-sphere uv, z up (`lights::full_sphere_uv`). Rotated spheres are
                // partial spheres with their object frame (pbrt::xform).
                let uv = crate::lights::full_sphere_uv(n);
                SurfaceHit {
                    p,
                    ng: n,
                    ns: n,
                    uv,
                    uv1: uv,
                    color: [1.0; 4],
                    dpdu: V3::splat(0.0),
                    err: sphere_point_err(center, radius, n),
                }
            }
            Prim::PartialSphere {
                center,
                radius,
                clip,
            } => {
                let c = &side.clips[clip as usize];
                let n = (r.o + r.d * h.t - center).normalize();
                let p = center + n * radius;
                // pbrt-v4 Sphere::InteractionFromIntersection (4th ed. §6.2.3), object frame
                // (`lights::zone_uv`).
                let uv = crate::lights::zone_uv(c, radius, n);
                SurfaceHit {
                    p,
                    ng: n,
                    ns: n,
                    uv,
                    uv1: uv,
                    color: [1.0; 4],
                    dpdu: V3::splat(0.0),
                    err: sphere_point_err(center, radius, n),
                }
            }
            Prim::Curve { seg, .. } => {
                let c = side.curves.surface(seg, r.o, r.d, h.t, h.u, h.v);
                SurfaceHit {
                    p: c.p,
                    ng: c.n,
                    ns: c.n,
                    uv: [h.u, h.v],
                    uv1: [h.u, h.v],
                    color: [1.0; 4],
                    dpdu: c.dpdu,
                    err: V3::splat(c.err),
                }
            }
        }
    }

    /// The geometric normal oriented as pbrt-v4 orients it (toward the shading normal on meshes
    /// with vertex normals, else flipped by `ReverseOrientation`): it points to the outside of a
    /// dielectric.
    #[inline]
    pub(crate) fn oriented_normal(&self, pi: &PrimInfo, sh: &SurfaceHit) -> V3 {
        let has_normals = self.meshes[pi.shape as usize]
            .as_ref()
            .is_some_and(|m| m.normals.is_some());
        if has_normals {
            sh.ng.face_forward(sh.ns)
        } else if self.shape_flip[pi.shape as usize] {
            -sh.ng
        } else {
            sh.ng
        }
    }

    /// A spectrum texture at a hit, at the path's wavelengths (`crate::texture`).
    #[inline]
    pub(crate) fn eval_texture<const N: usize>(
        &self,
        tex: &Tex,
        ctx: &TexCtx,
        lambdas: &Lambdas<N>,
    ) -> [f32; N] {
        match tex {
            Tex::Table(t) => self.tables[*t as usize].eval_path(lambdas),
            Tex::Image(im, map) => {
                // RGB -> smooth spectrum (Jakob & Hanika 2019 sigmoid polynomial, crate::uplift).
                let (s, t) = map.st(ctx);
                let rgb = self.images[*im as usize].lookup_filtered([s, t], map.dst(ctx));
                let poly = crate::uplift::rgb_to_coefficients(rgb);
                std::array::from_fn(|i| poly.eval(lambdas.nm[i] as f64) as f32)
            }
            Tex::VertexColored(im, map) => {
                // glTF 2.0 sec. 3.9.2: base colour = factor x texture x COLOR_0, linear RGB,
                // clamped to a reflectance, then uplifted as `Image` is.
                let (s, t) = map.st(ctx);
                let c = self.images[*im as usize].lookup_filtered([s, t], map.dst(ctx));
                let rgb: [f32; 3] = std::array::from_fn(|k| (c[k] * ctx.color[k]).clamp(0.0, 1.0));
                let poly = crate::uplift::rgb_to_coefficients(rgb);
                std::array::from_fn(|i| poly.eval(lambdas.nm[i] as f64) as f32)
            }
            Tex::Checker(c, map) => {
                // pbrt-v4 `SpectrumCheckerboardTexture`: the two textures blended by the
                // filtered weight (one of them alone where the footprint stays in a check).
                let (s, t) = map.st(ctx);
                let w = crate::texture::checker_weight_filtered(s, t, map.dst(ctx));
                if w == 0.0 || w == 1.0 {
                    return self.eval_texture(&c[w as usize], ctx, lambdas);
                }
                let (a, b) = (
                    self.eval_texture(&c[0], ctx, lambdas),
                    self.eval_texture(&c[1], ctx, lambdas),
                );
                std::array::from_fn(|i| (1.0 - w) * a[i] + w * b[i])
            }
            Tex::Checker3(c, space) => self.eval_texture(&c[space.checker(ctx.p)], ctx, lambdas),
            Tex::Scale(t, sc) => {
                // pbrt-v4 SpectrumScaledTexture: a zero scale short-circuits.
                let k = eval_float(sc, ctx);
                if k == 0.0 {
                    return [0.0; N];
                }
                self.eval_texture(t, ctx, lambdas).map(|v| v * k)
            }
            Tex::Mix(c, amount) => {
                let amt = eval_float(amount, ctx);
                let a = if amt != 1.0 {
                    self.eval_texture(&c[0], ctx, lambdas)
                } else {
                    [0.0; N]
                };
                let b = if amt != 0.0 {
                    self.eval_texture(&c[1], ctx, lambdas)
                } else {
                    [0.0; N]
                };
                std::array::from_fn(|i| (1.0 - amt) * a[i] + amt * b[i])
            }
            Tex::DirMix(c, dir) => {
                let amt = ctx.n.dot(*dir).abs();
                let a = if amt != 0.0 {
                    self.eval_texture(&c[0], ctx, lambdas)
                } else {
                    [0.0; N]
                };
                let b = if amt != 1.0 {
                    self.eval_texture(&c[1], ctx, lambdas)
                } else {
                    [0.0; N]
                };
                std::array::from_fn(|i| amt * a[i] + (1.0 - amt) * b[i])
            }
            Tex::Bilerp(t, map) => {
                let (s, tt) = map.st(ctx);
                let w = crate::texture::bilerp_weights(s, tt);
                let mut out = [0f32; N];
                for k in 0..4 {
                    let v = self.tables[t[k] as usize].eval_path(lambdas);
                    for i in 0..N {
                        out[i] += w[k] * v[i];
                    }
                }
                out
            }
            Tex::Marble(solid) => {
                let poly = crate::uplift::rgb_to_coefficients(solid.rgb(ctx));
                std::array::from_fn(|i| poly.eval(lambdas.nm[i] as f64) as f32)
            }
            Tex::Dots(c, map) => {
                let (s, t) = map.st(ctx);
                self.eval_texture(
                    &c[!crate::noise::inside_polka_dot(s as f64, t as f64) as usize],
                    ctx,
                    lambdas,
                )
            }
        }
    }

    /// A float texture at a hit (`crate::texture`).
    #[inline]
    #[allow(dead_code)] // consumed by materials with float parameters
    pub(crate) fn eval_float_texture(&self, tex: &FTex, ctx: &TexCtx) -> f32 {
        eval_float(tex, ctx)
    }

    /// `p` moved off its surface to the side of the unit normal `n` by its per-axis error bound
    /// `err` (`SurfaceHit::err`; pbrt-v4 `OffsetRayOrigin`, 4th ed. §6.8.6: far enough that a ray
    /// from there cannot hit the surface it leaves, near enough to hit a surface a hair's
    /// breadth away, as pbrt-v4 does).
    #[inline(always)]
    pub(crate) fn offset(p: V3, n: V3, err: V3) -> V3 {
        offset_ray_origin(p, err, n)
    }

    /// The origin of a ray leaving hit `sh` along `wi` (geometric normal `ng`, either side):
    /// offset to the side of the surface that `wi` goes to, whatever the BSDF lobe that chose
    /// it (pbrt-v4 `SurfaceInteraction::SpawnRay` / `OffsetRayOrigin`). With shading normals a
    /// reflected direction can go through the surface and a refracted one stay on `wo`'s side;
    /// pbrt-v4 keeps both paths on the side they geometrically go to (and the medium there,
    /// `GetMedium(wi)`), so camsim does too rather than ending them.
    #[inline(always)]
    pub(crate) fn spawn_origin(sh: &SurfaceHit, ng: V3, wi: V3) -> V3 {
        Self::offset(sh.p, ng.face_forward(wi), sh.err)
    }

    /// Visibility of a sampled light point from the (already offset) shading point `p_from`
    /// (pbrt-v4 `SpawnRayTo(pFrom, nFrom, time, pTo, nTo)`: both ends offset). The ray runs from
    /// `p_from` toward `p_light` moved off the light's surface along its normal `n_light`, turned
    /// toward `p_from`, by the light point's own error bound `err_light` (computed as for a hit on
    /// the same shape, `LightSample::p_err`), and stops `ShadowEpsilon` (1e-4) of the way short of
    /// it: so it can
    /// neither reach the light's own surface nor miss an occluder in between. `wi` and `dist` (the
    /// direction and distance from the un-offset point) are used for lights at infinity only.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn unoccluded(
        &self,
        p_from: V3,
        wi: V3,
        dist: f32,
        p_light: V3,
        n_light: V3,
        err_light: V3,
        pt: &PathTime,
    ) -> bool {
        const SHADOW_EPSILON: f32 = 1e-4;
        if !dist.is_finite() {
            return !self.occluded(p_from, wi, f32::INFINITY, pt);
        }
        let n_to = n_light.face_forward(p_from - p_light);
        let p_to = Self::offset(p_light, n_to, err_light);
        let d = p_to - p_from;
        let len = d.length();
        if !(len > 0.0 && len.is_finite()) {
            return false;
        }
        !self.occluded(p_from, d / len, len * (1.0 - SHADOW_EPSILON), pt)
    }

    /// Whether a surface that scatters lies on the segment `o + t d`, `0 < t < t_max`.
    /// `interface` surfaces (also when a `mix` picks one) let shadow rays through, as they let
    /// path rays through.
    #[inline]
    fn occluded(&self, o: V3, d: V3, t_max: f32, pt: &PathTime) -> bool {
        if !self.has_interface && !self.has_alpha {
            let r = Ray { o, d };
            return self.bvh.occluded(&RayInv::new(&r), t_max)
                || self
                    .motion
                    .as_ref()
                    .is_some_and(|m| m.occluded(&r, t_max, pt));
        }
        let (mut o, mut t_left) = (o, t_max);
        for _ in 0..MAX_INTERFACE_SKIPS {
            let r = Ray { o, d };
            let Some(h) = self.intersect_within(&r, t_left, pt) else {
                return false;
            };
            let sh = self.surface(&r, &h, pt);
            let pi = self.info[h.slot as usize];
            let keep = !self.has_alpha || self.alpha_keeps(pi.material, &TexCtx::at(&sh), o, d);
            if keep
                && !matches!(
                    self.materials[self.resolve_material(pi.material, sh.p, -d) as usize],
                    Mat::Interface
                )
            {
                return true;
            }
            let next = Self::offset(sh.p, sh.ng.face_forward(d), sh.err);
            t_left -= (next - o).dot(d);
            if t_left.is_nan() || t_left <= 0.0 {
                return false;
            }
            o = next;
        }
        true
    }

    /// Spectral radiance arriving along `ray` at the path's wavelengths (one sample of the path
    /// integral; pbrt-v4 `PathIntegrator::Li` restricted to the materials we have), each light's
    /// contribution added to `l` (one sum, or one per light group: [`crate::light_groups`]). The
    /// uniform numbers of bounce `depth` come from `sampler` at `dim::bounce(depth)` onward.
    /// Every ray of the path sees the scene at the path's time `pt`.
    pub(crate) fn li_into<const N: usize, S: PathSampler, R: PathRadiance<N>>(
        &self,
        mut ray: Ray,
        lambdas: &Lambdas<N>,
        sampler: &mut S,
        counts: &mut RayCounts,
        pt: &PathTime,
        l: &mut R,
    ) {
        let mut beta = [1f32; N];
        let mut depth = 0u32;
        let mut prev_p = ray.o;
        // The previous vertex's shading normal, for the light sampler's probability there.
        let mut prev_n = V3::splat(0.0);
        let mut prev_bsdf_pdf = 0f32;
        // The last bounce was a delta lobe: emission found next gets MIS weight 1 (pbrt-v4
        // `specularBounce`).
        let mut prev_specular = false;
        // Product of eta'^2 over transmissions (pbrt-v4 `etaScale`), undone for Russian roulette.
        let mut eta_scale = 1f32;
        // Secondary wavelengths terminated by a dispersive material.
        let mut terminated = false;
        let mut skips = 0u32;
        counts.camera += 1;
        loop {
            let hit = self.intersect(&ray, pt);
            let Some(h) = hit else {
                // Escaped: infinite lights.
                for &li in &self.lights.infinite {
                    let (le, light_pdf) = self.lights.escaped(li, ray.d, &self.tables, lambdas);
                    let w = if depth == 0 || prev_specular {
                        1.0
                    } else {
                        power_heuristic(prev_bsdf_pdf, light_pdf)
                    };
                    l.add(li, std::array::from_fn(|i| beta[i] * w * le[i]));
                }
                break;
            };
            let sh = self.surface(&ray, &h, pt);
            let pi = self.info[h.slot as usize];
            if self.has_alpha && !self.alpha_keeps(pi.material, &TexCtx::at(&sh), ray.o, ray.d) {
                // Alpha test failed: the hit is ignored and the ray goes on from the far side
                // (pbrt-v4 `GeometricPrimitive::Intersect` re-intersects a spawned ray), no bounce.
                skips += 1;
                if skips > MAX_INTERFACE_SKIPS {
                    break;
                }
                ray = Ray {
                    o: Self::offset(sh.p, sh.ng.face_forward(ray.d), sh.err),
                    d: ray.d,
                };
                counts.bounce += 1;
                continue;
            }
            let wo = -ray.d;
            // Emission seen by this path vertex.
            if pi.light != NO_LIGHT {
                let light = &self.lights.list[pi.light as usize];
                // The light's density is needed for the MIS weight only (not for camera rays
                // and specular bounces).
                let need_pdf = !(depth == 0 || prev_specular);
                let (emits, pdf_light) = self.light_hit(
                    pi.light as usize,
                    prev_p,
                    prev_n,
                    sh.p,
                    sh.ng,
                    wo,
                    pt,
                    need_pdf,
                );
                if emits {
                    let w = if need_pdf {
                        power_heuristic(prev_bsdf_pdf, pdf_light)
                    } else {
                        1.0
                    };
                    let le = self.lights.emitted(
                        light,
                        self.lights.hit_uv(light, &sh),
                        &self.tables,
                        lambdas,
                    );
                    l.add(pi.light, std::array::from_fn(|i| beta[i] * w * le[i]));
                }
            }
            let m = self.resolve_material(pi.material, sh.p, wo);
            if let Mat::Interface = self.materials[m as usize] {
                // No surface: continue the ray on the far side without counting a bounce
                // (pbrt-v4 `SurfaceInteraction::SkipIntersection`).
                skips += 1;
                if skips > MAX_INTERFACE_SKIPS {
                    break;
                }
                let far = sh.ng.face_forward(ray.d);
                ray = Ray {
                    o: Self::offset(sh.p, far, sh.err),
                    d: ray.d,
                };
                counts.bounce += 1;
                continue;
            }
            if depth >= self.max_depth {
                break;
            }
            depth += 1;
            let d0 = dim::bounce(depth);

            let outside = wo.dot(self.oriented_normal(&pi, &sh)) > 0.0;
            let mut ctx = TexCtx::at(&sh);
            if self.footprint_textures {
                // pbrt-v4 `SurfaceInteraction::ComputeDifferentials` with the camera's
                // `Approximate_dp_dxy` at every hit (`crate::bump::Footprint`).
                let g = self.shading_geometry(&h, &pi, &sh, pt);
                ctx.duv = self.footprint.uv_derivatives(&g);
            }
            // Bump and normal maps (pbrt-v4 `GetBSDF`): the material under them, its normal.
            let (m, ns_shading) = self.shading_normal(m, &h, &pi, &sh, pt);
            let (bsdf, terminate): (Bsdf<N>, bool) = self.bsdf_at(m, &ctx, lambdas, outside);
            if terminate && !terminated && N > 1 {
                // Dispersion: only the hero wavelength (index 0, marginally uniform like each
                // of them) follows this path from here on, weighted by N so the band estimate
                // stays unbiased (pbrt-v4 `TerminateSecondary`).
                terminated = true;
                beta[0] *= N as f32;
                for b in beta.iter_mut().skip(1) {
                    *b = 0.0;
                }
            }
            // Two-sided shading: normals turned toward the outgoing direction.
            let ng = sh.ng.face_forward(wo);
            let ns = ns_shading.face_forward(ng);
            let frame = if sh.dpdu.length_squared() > 0.0 {
                crate::curve::fibre_frame(sh.dpdu, ns)
            } else {
                Frame::from_normal(ns)
            };
            let wo_local = frame.to_local(wo);
            // The light sampler's normal: none on fibres (their BSDF scatters all around).
            let n_sel = if sh.dpdu.length_squared() > 0.0 {
                V3::splat(0.0)
            } else {
                ns
            };

            // Next-event estimation (not for delta BSDFs: they cannot reach a sampled point).
            if !self.lights.is_empty() && !bsdf.is_delta() {
                let u_sel = sampler.get_1d(d0 + dim::LIGHT_CHOICE);
                let [u0, u1] = sampler.get_2d(d0 + dim::LIGHT_POSITION);
                if let Some(ls) = self.sample_light::<N>(sh.p, n_sel, u_sel, u0, u1, lambdas, pt) {
                    let LightSample {
                        wi,
                        dist,
                        p_light,
                        light,
                        n_light,
                        p_err,
                        le,
                        pdf,
                        delta,
                        uv,
                        alpha_mat,
                    } = ls;
                    // pbrt-v4 `SampleLd`: the BSDF alone (in the shading frame) decides whether
                    // `wi` scatters; the shadow ray leaves from `wi`'s geometric side.
                    {
                        let wi_local = frame.to_local(wi);
                        let (f, bsdf_pdf) = bsdf.eval(&wo_local, &wi_local);
                        let p_from = Self::spawn_origin(&sh, ng, wi);
                        // A masked emitter gives nothing where its alpha test rejects the sampled
                        // point (pbrt-v4 `DiffuseAreaLight::SampleLi` via `AlphaMasked`); the test
                        // is the per-hit one with the ray a BSDF sample toward it would carry
                        // (origin `p_from`, direction `wi`), so both strategies see one mask.
                        let masked = alpha_mat != NO_ALPHA
                            && !self.alpha_keeps(
                                alpha_mat,
                                &TexCtx::at_uv(uv, n_light, p_light),
                                p_from,
                                wi,
                            );
                        if bsdf_pdf > 0.0 && !masked {
                            counts.shadow += 1;
                            if self.unoccluded(p_from, wi, dist, p_light, n_light, p_err, pt) {
                                // Delta lights cannot be hit by BSDF samples: no MIS weight.
                                let mis = if delta {
                                    1.0
                                } else {
                                    power_heuristic(pdf, bsdf_pdf)
                                };
                                let w = mis * wi_local.z.abs() / pdf;
                                l.add(light, std::array::from_fn(|i| beta[i] * f[i] * le[i] * w));
                            }
                        }
                    }
                }
            }

            // BSDF sampling for the next vertex.
            let uc = sampler.get_1d(d0 + dim::BSDF_LOBE);
            let [u0, u1] = sampler.get_2d(d0 + dim::BSDF_DIRECTION);
            let Some(bs) = bsdf.sample(&wo_local, uc, u0, u1) else {
                break;
            };
            let wi = frame.to_world(bs.wi_local);
            let mut max_beta = 0f32;
            for i in 0..N {
                beta[i] *= bs.weight[i];
                max_beta = max_beta.max(beta[i]);
            }
            if max_beta.is_nan() || max_beta <= 0.0 {
                break;
            }
            prev_bsdf_pdf = bs.pdf;
            prev_specular = bs.specular;
            prev_p = sh.p;
            prev_n = n_sel;
            if bs.transmission {
                eta_scale *= bs.eta * bs.eta;
            }
            // Russian roulette (pbrt-v4 4th ed. §13.4.1, `PathIntegrator::Li`): from vertex
            // `rr_depth` on, end the path with probability q = max(0, 1 - max(beta) etaScale)
            // and divide the survivors' beta by 1 - q, which keeps the estimator unbiased.
            let rr_beta = max_beta * eta_scale;
            if rr_beta < 1.0 && depth >= self.rr_depth {
                let q = (1.0 - rr_beta).max(0.0);
                let u = sampler.get_1d(d0 + dim::RUSSIAN_ROULETTE);
                if u < q {
                    break;
                }
                let k = 1.0 / (1.0 - q);
                for b in beta.iter_mut() {
                    *b *= k;
                }
            }
            counts.bounce += 1;
            ray = Ray {
                o: Self::spawn_origin(&sh, ng, wi),
                d: wi,
            };
        }
    }

    /// Distance along the camera's forward axis to the first surface (or infinity) and 1 + the
    /// index of its shape in `SceneDescription::shapes` (0 when the ray escapes), at `pt`.
    pub(crate) fn first_surface(
        &self,
        r: &Ray,
        forward: V3,
        counts: &mut RayCounts,
        pt: &PathTime,
    ) -> (f32, u32) {
        counts.camera += 1;
        match self.first_kept(r, pt) {
            None => (f32::INFINITY, 0),
            Some((_, h)) if !self.has_alpha => {
                (h.t * r.d.dot(forward), self.info[h.slot as usize].shape + 1)
            }
            Some((ray, h)) => (
                (self.surface(&ray, &h, pt).p - r.o).dot(forward),
                self.info[h.slot as usize].shape + 1,
            ),
        }
    }

    /// The first hit along `r` at `pt` that the alpha test keeps (surfaces cut out by alpha are
    /// skipped as the path skips them), with the ray that found it.
    pub(crate) fn first_kept(&self, r: &Ray, pt: &PathTime) -> Option<(Ray, crate::bvh::Hit)> {
        let mut ray = *r;
        for _ in 0..MAX_INTERFACE_SKIPS {
            let h = self.intersect(&ray, pt)?;
            if !self.has_alpha {
                return Some((ray, h));
            }
            let sh = self.surface(&ray, &h, pt);
            let pi = self.info[h.slot as usize];
            if self.alpha_keeps(pi.material, &TexCtx::at(&sh), ray.o, ray.d) {
                return Some((ray, h));
            }
            ray = Ray {
                o: Self::offset(sh.p, sh.ng.face_forward(ray.d), sh.err),
                d: ray.d,
            };
        }
        None
    }

    /// The first surface along `r` at `pt` that the alpha test keeps (cut-outs are skipped as
    /// the path skips them), with its primitive's data; `None` when the ray escapes.
    pub(crate) fn first_hit(&self, r: &Ray, pt: &PathTime) -> Option<(SurfaceHit, PrimInfo)> {
        let (ray, h) = self.first_kept(r, pt)?;
        Some((self.surface(&ray, &h, pt), self.info[h.slot as usize]))
    }
}
