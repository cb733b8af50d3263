//! The volumetric path tracer (pbrt-v4 `VolPathIntegrator`, 4th ed. sec. 14.1): delta tracking
//! against majorants with null scattering, spectral MIS over the path's wavelengths (the
//! distances are sampled with the hero wavelength; `r_u` and `r_l` carry each wavelength's
//! path probability, unidirectional and light-sampled, relative to the hero's: Miller, Georgiev
//! & Jarosz 2019), light sampling from surfaces and from points in media with ratio-tracked
//! transmittance along shadow rays through media and `interface` surfaces, emission from
//! media, and medium transitions at shapes with a `MediumInterface`.
//!
//! Used for every scene where a ray can be in a medium ([`MediaSet::compile`]); other scenes
//! keep the path tracer (`Tracer::li`), bit for bit. A child module of `integrator`, for the
//! tracer's private hit helpers.

use super::*;
use crate::bvh::Hit;
use crate::media::{MediaSet, NO_MEDIUM};
use crate::phase::{hg_p, hg_sample};
use camsim_core::rng::{mix64, Rng};
use rand::Rng as _;

/// The sampler dimensions of the tracking along the segment that leads to scattering vertex
/// `depth + 1` (two numbers: the first collision distance and the seed of the rest): the
/// bounce layout's light-position pair of a bounce far beyond any path depth, so they never
/// meet a bounce's own numbers.
#[inline(always)]
fn track_dim(depth: u32) -> u32 {
    dim::bounce((1 << 28) + depth) + dim::LIGHT_POSITION
}

/// The generator of one tracking segment, seeded by a hash of its sampler numbers and of the
/// segment's index since the last scattering (pbrt-v4 seeds it from a hash of sampler values).
#[inline]
fn segment_rng(u: [f32; 2], depth: u32, skips: u32) -> Rng {
    let a = mix64(((u[0].to_bits() as u64) << 32) | u[1].to_bits() as u64);
    let b = mix64(a ^ (((depth as u64) << 32) | skips as u64));
    Rng::new(((a as u128) << 64) | b as u128 | 1)
}

/// The mean of the path's wavelengths' ratios (the balance heuristic over the wavelengths), or
/// the hero's alone once the secondary wavelengths were dropped (dispersion).
#[inline(always)]
fn avg<const N: usize>(r: &[f32; N], hero_only: bool) -> f32 {
    if hero_only {
        r[0]
    } else {
        r.iter().sum::<f32>() / N as f32
    }
}

#[inline(always)]
fn any_positive<const N: usize>(v: &[f32; N]) -> bool {
    v.iter().any(|x| *x > 0.0)
}

/// Where next-event estimation starts: a surface vertex with its BSDF, or a point in a medium.
enum Vertex<'a, const N: usize> {
    Surface {
        bsdf: &'a Bsdf<N>,
        frame: &'a Frame,
        wo_local: V3,
        /// The hit point and its geometric normal turned toward `wo`.
        p: V3,
        ng: V3,
        /// The hit point's per-axis error bound (`SurfaceHit::err`).
        err: V3,
        /// The primitive's material (for its medium boundary) and oriented normal.
        material: u32,
        n_oriented: V3,
        /// The light sampler's normal (the shading normal; zero on fibres).
        n_sel: V3,
    },
    Medium {
        p: V3,
        wo: V3,
        g: f32,
    },
}

/// The path state that the volumetric estimator updates.
struct PathState<const N: usize> {
    beta: [f32; N],
    r_u: [f32; N],
    r_l: [f32; N],
    depth: u32,
    hero_only: bool,
}

impl Tracer {
    /// Spectral radiance along `ray` at the path's time `pt`: the volumetric path tracer where
    /// the scene has media, the path tracer otherwise.
    #[inline(always)]
    pub(crate) fn radiance<const N: usize, S: PathSampler>(
        &self,
        ray: Ray,
        lambdas: &Lambdas<N>,
        sampler: &mut S,
        counts: &mut RayCounts,
        pt: &PathTime,
    ) -> [f32; N] {
        let mut l = [0f32; N];
        self.radiance_into(ray, lambdas, sampler, counts, pt, &mut l);
        l
    }

    /// [`Self::radiance`] adding each light's contribution to `out` (one sum, or one per light
    /// group: [`crate::light_groups`]).
    #[inline(always)]
    pub(crate) fn radiance_into<const N: usize, S: PathSampler, R: PathRadiance<N>>(
        &self,
        ray: Ray,
        lambdas: &Lambdas<N>,
        sampler: &mut S,
        counts: &mut RayCounts,
        pt: &PathTime,
        out: &mut R,
    ) {
        match &self.media {
            None => self.li_into(ray, lambdas, sampler, counts, pt, out),
            Some(media) => self.li_vol(media, ray, lambdas, sampler, counts, pt, out),
        }
    }

    /// The first hit along `ray` that the alpha test keeps (pbrt-v4's `Intersect` skips the
    /// rejected ones), and its distance from `ray.o`.
    fn kept_hit(
        &self,
        ray: &Ray,
        counts: &mut RayCounts,
        pt: &PathTime,
    ) -> Option<(SurfaceHit, PrimInfo, f32, Hit)> {
        let mut r = *ray;
        for _ in 0..MAX_INTERFACE_SKIPS {
            let h = self.intersect(&r, pt)?;
            let sh = self.surface(&r, &h, pt);
            let pi = self.info[h.slot as usize];
            let ctx = TexCtx::at(&sh);
            if !self.has_alpha || self.alpha_keeps(pi.material, &ctx, r.o, r.d) {
                let t = (sh.p - ray.o).dot(ray.d);
                return Some((sh, pi, t, h));
            }
            r.o = Self::offset(sh.p, sh.ng.face_forward(r.d), sh.err);
            counts.bounce += 1;
        }
        None
    }

    /// One sample of the radiance arriving along `ray` at the path's wavelengths (pbrt-v4
    /// `VolPathIntegrator::Li`, with camsim's dimensions, Russian roulette start and
    /// dispersion handling as in [`Tracer::li_into`]), each light's contribution added to `out`
    /// (a medium's own emission, which belongs to no light, under [`NO_LIGHT`]).
    #[allow(clippy::too_many_arguments)]
    fn li_vol<const N: usize, S: PathSampler, R: PathRadiance<N>>(
        &self,
        media: &MediaSet,
        mut ray: Ray,
        lambdas: &Lambdas<N>,
        sampler: &mut S,
        counts: &mut RayCounts,
        pt: &PathTime,
        out: &mut R,
    ) {
        let mut st = PathState {
            beta: [1f32; N],
            r_u: [1f32; N],
            r_l: [1f32; N],
            depth: 0,
            hero_only: false,
        };
        let mut specular = false;
        let mut eta_scale = 1f32;
        let mut skips = 0u32;
        let mut medium = media.camera;
        let mut prev_p = ray.o;
        // The previous vertex's shading normal (zero at a medium vertex) for the light sampler.
        let mut prev_n = V3::splat(0.0);
        counts.camera += 1;
        loop {
            let hit = self.kept_hit(&ray, counts, pt);
            if medium != NO_MEDIUM {
                let t_max = hit.as_ref().map_or(f32::INFINITY, |h| h.2);
                let u = sampler.get_2d(track_dim(st.depth));
                let mut rng = segment_rng(u, st.depth, skips);
                let (mut scattered, mut terminated) = (false, false);
                let seg = ray;
                let g = media.media[medium as usize].g;
                let t_maj = media.sample_t_maj(
                    medium,
                    &seg,
                    t_max,
                    u[0],
                    &mut rng,
                    lambdas,
                    |rng, p, mp, sigma_maj, t_maj| {
                        if !any_positive(&st.beta) {
                            terminated = true;
                            return false;
                        }
                        // Emission, weighted by the probability of reaching here unscattered
                        // (4th ed. eq. 14.8 with spectral MIS).
                        if st.depth < self.max_depth && any_positive(&mp.le) {
                            let pdf = sigma_maj[0] * t_maj[0];
                            let r_e: [f32; N] =
                                std::array::from_fn(|i| st.r_u[i] * sigma_maj[i] * t_maj[i] / pdf);
                            let a = avg(&r_e, st.hero_only);
                            if a > 0.0 {
                                out.add(
                                    NO_LIGHT,
                                    std::array::from_fn(|i| {
                                        st.beta[i] * t_maj[i] / pdf * mp.sigma_a[i] * mp.le[i] / a
                                    }),
                                );
                            }
                        }
                        // Absorption, real scattering or null scattering, chosen with the hero's
                        // probabilities sigma / sigma_maj.
                        let p_absorb = mp.sigma_a[0] / sigma_maj[0];
                        let p_scatter = mp.sigma_s[0] / sigma_maj[0];
                        let um = rng.gen::<f32>();
                        if um < p_absorb {
                            terminated = true;
                            return false;
                        }
                        if um < p_absorb + p_scatter {
                            if st.depth >= self.max_depth {
                                terminated = true;
                                return false;
                            }
                            st.depth += 1;
                            let pdf = t_maj[0] * mp.sigma_s[0];
                            for i in 0..N {
                                let k = t_maj[i] * mp.sigma_s[i] / pdf;
                                st.beta[i] *= k;
                                st.r_u[i] *= k;
                            }
                            if any_positive(&st.beta) && any_positive(&st.r_u) {
                                let d0 = dim::bounce(st.depth);
                                let wo = -seg.d;
                                if !self.lights.is_empty() {
                                    if let Some((light, ld)) = self.sample_ld_vol(
                                        media,
                                        &Vertex::Medium { p, wo, g },
                                        medium,
                                        &st,
                                        lambdas,
                                        sampler,
                                        d0,
                                        counts,
                                        pt,
                                    ) {
                                        out.add(light, ld);
                                    }
                                }
                                let [u0, u1] = sampler.get_2d(d0 + dim::BSDF_DIRECTION);
                                let (wi, pdf) = hg_sample(g, wo, u0, u1);
                                if !(pdf > 0.0 && pdf.is_finite()) {
                                    terminated = true;
                                } else {
                                    // beta *= p / pdf = 1: sampled exactly.
                                    st.r_l = st.r_u.map(|v| v / pdf);
                                    prev_p = p;
                                    prev_n = V3::splat(0.0);
                                    scattered = true;
                                    ray = Ray { o: p, d: wi };
                                    specular = false;
                                    counts.bounce += 1;
                                }
                            }
                            return false;
                        }
                        // Null scattering: continue with the ratio of the null coefficients.
                        let sigma_n: [f32; N] = std::array::from_fn(|i| {
                            (sigma_maj[i] - mp.sigma_a[i] - mp.sigma_s[i]).max(0.0)
                        });
                        let pdf = t_maj[0] * sigma_n[0];
                        if !(pdf > 0.0) {
                            st.beta = [0.0; N];
                            return false;
                        }
                        for i in 0..N {
                            st.beta[i] *= t_maj[i] * sigma_n[i] / pdf;
                            st.r_u[i] *= t_maj[i] * sigma_n[i] / pdf;
                            st.r_l[i] *= t_maj[i] * sigma_maj[i] / pdf;
                        }
                        any_positive(&st.beta) && any_positive(&st.r_u)
                    },
                );
                if terminated || !any_positive(&st.beta) || !any_positive(&st.r_u) {
                    return;
                }
                if scattered {
                    skips = 0;
                    continue;
                }
                if !(t_maj[0] > 0.0) {
                    return;
                }
                for i in 0..N {
                    let k = t_maj[i] / t_maj[0];
                    st.beta[i] *= k;
                    st.r_u[i] *= k;
                    st.r_l[i] *= k;
                }
            }

            let Some((sh, pi, _, h)) = hit else {
                // Escaped: infinite lights.
                let first = depth0_or(specular, st.depth);
                for &li in &self.lights.infinite {
                    let (le, light_pdf) = self.lights.escaped(li, ray.d, &self.tables, lambdas);
                    Self::add_emission(&st, &le, first, light_pdf, li, out);
                }
                break;
            };
            let wo = -ray.d;
            if pi.light != NO_LIGHT {
                let li = pi.light as usize;
                let first = depth0_or(specular, st.depth);
                // At the path's time: a moving emitter's side and density in its own pose.
                let (emits, p_l) = self.light_hit(li, prev_p, prev_n, sh.p, sh.ng, wo, pt, !first);
                if emits {
                    let light = &self.lights.list[li];
                    let le = self.lights.emitted(
                        light,
                        self.lights.hit_uv(light, &sh),
                        &self.tables,
                        lambdas,
                    );
                    Self::add_emission(&st, &le, first, p_l, li as u32, out);
                }
            }
            let m = self.resolve_material(pi.material, sh.p, wo);
            let n_oriented = self.oriented_normal(&pi, &sh);
            if let Mat::Interface = self.materials[m as usize] {
                // No surface: the ray goes on in the medium on the far side (pbrt-v4
                // `SkipIntersection`), no bounce.
                skips += 1;
                if skips > MAX_INTERFACE_SKIPS {
                    break;
                }
                medium = media.after(pi.material, n_oriented, ray.d, medium);
                ray = Ray {
                    o: Self::offset(sh.p, sh.ng.face_forward(ray.d), sh.err),
                    d: ray.d,
                };
                counts.bounce += 1;
                continue;
            }
            if st.depth >= self.max_depth {
                break;
            }
            st.depth += 1;
            skips = 0;
            let d0 = dim::bounce(st.depth);
            let outside = wo.dot(n_oriented) > 0.0;
            let ctx = TexCtx::at(&sh);
            // Bump and normal maps (pbrt-v4 `GetBSDF`): the material under them, its normal.
            let (m, ns_shading) = self.shading_normal(m, &h, &pi, &sh, pt);
            let (bsdf, terminate): (Bsdf<N>, bool) = self.bsdf_at(m, &ctx, lambdas, outside);
            if terminate && !st.hero_only && N > 1 {
                // Dispersion: only the hero wavelength goes on (as `Tracer::li`).
                st.hero_only = true;
                st.beta[0] *= N as f32;
                for b in st.beta.iter_mut().skip(1) {
                    *b = 0.0;
                }
            }
            let ng = sh.ng.face_forward(wo);
            let ns = ns_shading.face_forward(ng);
            let frame = if sh.dpdu.length_squared() > 0.0 {
                crate::curve::fibre_frame(sh.dpdu, ns)
            } else {
                Frame::from_normal(ns)
            };
            let wo_local = frame.to_local(wo);
            let n_sel = if sh.dpdu.length_squared() > 0.0 {
                V3::splat(0.0)
            } else {
                ns
            };
            if !self.lights.is_empty() && !bsdf.is_delta() {
                let v = Vertex::Surface {
                    bsdf: &bsdf,
                    frame: &frame,
                    wo_local,
                    p: sh.p,
                    ng,
                    err: sh.err,
                    material: pi.material,
                    n_oriented,
                    n_sel,
                };
                if let Some((light, ld)) =
                    self.sample_ld_vol(media, &v, medium, &st, lambdas, sampler, d0, counts, pt)
                {
                    out.add(light, ld);
                }
            }
            let uc = sampler.get_1d(d0 + dim::BSDF_LOBE);
            let [u0, u1] = sampler.get_2d(d0 + dim::BSDF_DIRECTION);
            let Some(bs) = bsdf.sample(&wo_local, uc, u0, u1) else {
                break;
            };
            let wi = frame.to_world(bs.wi_local);
            for i in 0..N {
                st.beta[i] *= bs.weight[i];
            }
            let max_beta = st.beta.iter().fold(0f32, |a, b| a.max(*b));
            if max_beta.is_nan() || max_beta <= 0.0 || !(bs.pdf > 0.0) {
                break;
            }
            st.r_l = st.r_u.map(|v| v / bs.pdf);
            specular = bs.specular;
            prev_p = sh.p;
            prev_n = n_sel;
            if bs.transmission {
                eta_scale *= bs.eta * bs.eta;
            }
            // Russian roulette on the throughput relative to the hero's path probability
            // (pbrt-v4 `rrBeta = beta etaScale / r_u.Average()`), from camsim's start depth.
            let rr_beta = max_beta * eta_scale / avg(&st.r_u, st.hero_only);
            if rr_beta < 1.0 && st.depth >= self.rr_depth {
                let q = (1.0 - rr_beta).max(0.0);
                if sampler.get_1d(d0 + dim::RUSSIAN_ROULETTE) < q {
                    break;
                }
                let k = 1.0 / (1.0 - q);
                for b in st.beta.iter_mut() {
                    *b *= k;
                }
            }
            counts.bounce += 1;
            // The side and medium `wi` geometrically goes to, whatever the lobe (pbrt-v4
            // `SpawnRay`, `GetMedium(wi)`; see `Tracer::spawn_origin`).
            medium = media.after(pi.material, n_oriented, wi, medium);
            ray = Ray {
                o: Self::spawn_origin(&sh, ng, wi),
                d: wi,
            };
        }
    }

    /// Add emission `le` of compiled light `light` found by the path to `out`: with weight `1 /
    /// avg(r_u)` after the camera or a delta lobe (`first`), else by the balance heuristic
    /// with light sampling, whose density for this point is `p_l` (selection probability
    /// included).
    #[inline]
    fn add_emission<const N: usize, R: PathRadiance<N>>(
        st: &PathState<N>,
        le: &[f32; N],
        first: bool,
        p_l: f32,
        light: u32,
        out: &mut R,
    ) {
        let d = if first {
            avg(&st.r_u, st.hero_only)
        } else {
            let r: [f32; N] = std::array::from_fn(|i| st.r_u[i] + st.r_l[i] * p_l);
            avg(&r, st.hero_only)
        };
        if d > 0.0 {
            out.add(light, std::array::from_fn(|i| st.beta[i] * le[i] / d));
        }
    }

    /// Next-event estimation from vertex `v` in medium `medium` (pbrt-v4
    /// `VolPathIntegrator::SampleLd`): one light sample, its transmittance through media and
    /// `interface` surfaces by ratio tracking, weighted by the balance heuristic over light and
    /// BSDF / phase sampling and over the wavelengths; the light and its contribution, `None`
    /// where it gives nothing.
    #[allow(clippy::too_many_arguments)]
    fn sample_ld_vol<const N: usize, S: PathSampler>(
        &self,
        media: &MediaSet,
        v: &Vertex<N>,
        medium: u32,
        st: &PathState<N>,
        lambdas: &Lambdas<N>,
        sampler: &mut S,
        d0: u32,
        counts: &mut RayCounts,
        pt: &PathTime,
    ) -> Option<(u32, [f32; N])> {
        let u_sel = sampler.get_1d(d0 + dim::LIGHT_CHOICE);
        let [u0, u1] = sampler.get_2d(d0 + dim::LIGHT_POSITION);
        let (p_ref, n_ref) = match v {
            Vertex::Surface { p, n_sel, .. } => (*p, *n_sel),
            Vertex::Medium { p, .. } => (*p, V3::splat(0.0)),
        };
        let ls = self.sample_light::<N>(p_ref, n_ref, u_sel, u0, u1, lambdas, pt)?;
        if !(ls.pdf > 0.0) || !any_positive(&ls.le) {
            return None;
        }
        let (f_hat, scatter_pdf, p_from, start) = match v {
            Vertex::Surface {
                bsdf,
                frame,
                wo_local,
                p,
                ng,
                err,
                material,
                n_oriented,
                ..
            } => {
                // The BSDF alone decides (pbrt-v4 `SampleLd`); the shadow ray leaves from
                // `wi`'s geometric side.
                let wi_local = frame.to_local(ls.wi);
                let (f, pdf) = bsdf.eval(wo_local, &wi_local);
                let c = wi_local.z.abs();
                let p_from = Self::offset(*p, ng.face_forward(ls.wi), *err);
                (
                    f.map(|x| x * c),
                    pdf,
                    p_from,
                    media.after(*material, *n_oriented, ls.wi, medium),
                )
            }
            Vertex::Medium { p, wo, g } => {
                let ph = hg_p(*g, *wo, ls.wi);
                ([ph; N], ph, *p, medium)
            }
        };
        if !any_positive(&f_hat) {
            return None;
        }
        // A masked emitter gives nothing where its alpha test rejects the point (as `li`).
        if ls.alpha_mat != NO_ALPHA
            && !self.alpha_keeps(
                ls.alpha_mat,
                &TexCtx::at_uv(ls.uv, ls.n_light, ls.p_light),
                p_from,
                ls.wi,
            )
        {
            return None;
        }
        counts.shadow += 1;
        let (t_ray, mut r_l, mut r_u) =
            self.transmittance(media, p_from, start, &ls, st.hero_only, lambdas, pt)?;
        for i in 0..N {
            r_l[i] *= st.r_u[i] * ls.pdf;
            r_u[i] *= st.r_u[i] * scatter_pdf;
        }
        let d = if ls.delta {
            avg(&r_l, st.hero_only)
        } else {
            let s: [f32; N] = std::array::from_fn(|i| r_l[i] + r_u[i]);
            avg(&s, st.hero_only)
        };
        if !(d > 0.0) {
            return None;
        }
        Some((
            ls.light,
            std::array::from_fn(|i| st.beta[i] * f_hat[i] * t_ray[i] * ls.le[i] / d),
        ))
    }

    /// Transmittance from `p_from` (in `medium`) to the light sample `ls` by ratio tracking
    /// (pbrt-v4 `SampleLd`'s shadow ray): `None` when a scattering surface blocks it, else the
    /// transmittance estimate and the ratios it multiplies into `r_l` and `r_u`. `interface`
    /// surfaces and alpha cut-outs let it through; medium boundaries change its medium.
    #[allow(clippy::too_many_arguments)]
    fn transmittance<const N: usize>(
        &self,
        media: &MediaSet,
        p_from: V3,
        mut medium: u32,
        ls: &LightSample<N>,
        hero_only: bool,
        lambdas: &Lambdas<N>,
        pt: &PathTime,
    ) -> Option<([f32; N], [f32; N], [f32; N])> {
        const SHADOW_EPSILON: f32 = 1e-4;
        // As `unoccluded`: toward the light point moved off its surface, stopping short of it.
        let (d, mut t_left) = if ls.dist.is_finite() {
            let n_to = ls.n_light.face_forward(p_from - ls.p_light);
            let p_to = Self::offset(ls.p_light, n_to, ls.p_err);
            let v = p_to - p_from;
            let len = v.length();
            if !(len > 0.0 && len.is_finite()) {
                return None;
            }
            (v / len, len * (1.0 - SHADOW_EPSILON))
        } else {
            (ls.wi, f32::INFINITY)
        };
        let h = |v: V3| {
            mix64(
                ((v.x.to_bits() as u64) << 32)
                    ^ ((v.y.to_bits() as u64) << 16)
                    ^ v.z.to_bits() as u64,
            )
        };
        let (ka, kb) = (h(p_from), h(d));
        let mut rng = Rng::new(((ka as u128) << 64) | (mix64(kb ^ ka) as u128) | 1);
        let (mut t_ray, mut r_l, mut r_u) = ([1f32; N], [1f32; N], [1f32; N]);
        let mut o = p_from;
        for _ in 0..MAX_INTERFACE_SKIPS {
            let r = Ray { o, d };
            let mut pass = None;
            if let Some(hit) = self.intersect_within(&r, t_left, pt) {
                let sh = self.surface(&r, &hit, pt);
                let pi = self.info[hit.slot as usize];
                let ctx = TexCtx::at(&sh);
                let keep = !self.has_alpha || self.alpha_keeps(pi.material, &ctx, o, d);
                if keep
                    && !matches!(
                        self.materials[self.resolve_material(pi.material, sh.p, -d) as usize],
                        Mat::Interface
                    )
                {
                    return None;
                }
                pass = Some((sh, pi, hit.t, keep));
            }
            if medium != NO_MEDIUM {
                let seg_t = pass.as_ref().map_or(t_left, |p| p.2);
                let u = rng.gen::<f32>();
                let t_maj = media.sample_t_maj(
                    medium,
                    &r,
                    seg_t,
                    u,
                    &mut rng,
                    lambdas,
                    |rng, _, mp, sigma_maj, t_maj| {
                        let pdf = t_maj[0] * sigma_maj[0];
                        for i in 0..N {
                            let sigma_n = (sigma_maj[i] - mp.sigma_a[i] - mp.sigma_s[i]).max(0.0);
                            t_ray[i] *= t_maj[i] * sigma_n / pdf;
                            r_l[i] *= t_maj[i] * sigma_maj[i] / pdf;
                            r_u[i] *= t_maj[i] * sigma_n / pdf;
                        }
                        // Russian roulette once the estimate is small (pbrt-v4: below 0.05,
                        // survive with probability 1/4).
                        let s: [f32; N] = std::array::from_fn(|i| r_l[i] + r_u[i]);
                        let a = avg(&s, hero_only);
                        let tr_max = t_ray.iter().fold(0f32, |m, v| m.max(*v)) / a;
                        if tr_max < 0.05 {
                            if rng.gen::<f32>() < 0.75 {
                                t_ray = [0.0; N];
                            } else {
                                t_ray = t_ray.map(|v| v / 0.25);
                            }
                        }
                        any_positive(&t_ray)
                    },
                );
                if !(t_maj[0] > 0.0) {
                    return None;
                }
                for i in 0..N {
                    let k = t_maj[i] / t_maj[0];
                    t_ray[i] *= k;
                    r_l[i] *= k;
                    r_u[i] *= k;
                }
            }
            if !any_positive(&t_ray) {
                return None;
            }
            let Some((sh, pi, _, keep)) = pass else {
                return Some((t_ray, r_l, r_u));
            };
            if keep {
                medium = media.after(pi.material, self.oriented_normal(&pi, &sh), d, medium);
            }
            let next = Self::offset(sh.p, sh.ng.face_forward(d), sh.err);
            t_left -= (next - o).dot(d);
            if t_left.is_nan() || t_left <= 0.0 {
                return Some((t_ray, r_l, r_u));
            }
            o = next;
        }
        None
    }
}

/// Emission is found right after the camera or a delta lobe: no light-sampling competitor.
#[inline(always)]
fn depth0_or(specular: bool, depth: u32) -> bool {
    depth == 0 || specular
}
