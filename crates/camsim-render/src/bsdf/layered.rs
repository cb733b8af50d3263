//! Layered BSDFs by a stochastic random walk between two interfaces (pbrt-v4 `LayeredBxDF`,
//! Pharr, Jakob & Humphreys, "Physically Based Rendering", 4th ed., §14.3; the method of Guo,
//! Hašan & Zhao 2018, "Position-free Monte Carlo simulation for arbitrary layered BSDFs").
//!
//! A dielectric coating (`top`, smooth or Trowbridge-Reitz rough, relative index `eta`) lies at
//! `z = thickness` over an opaque base (`bottom`: Lambertian or conductor) at `z = 0`; between
//! them a homogeneous medium of unit extinction per unit thickness, single-scattering `albedo`
//! and Henyey-Greenstein asymmetry `g` (albedo 0: no scattering, only the attenuation
//! `exp(-thickness / |cos|)` of each pass). The BSDF is two-sided (directions below the surface
//! are mirrored through the origin) and reflects only, as pbrt-v4's `CoatedDiffuseBxDF` and
//! `CoatedConductorBxDF`.
//!
//! The three operations are unbiased or consistent Monte Carlo estimates, as in pbrt-v4:
//! * `Layered::f` estimates the BSDF value by `n_samples` walks from `wo` into the layer with
//!   next-event estimation towards `wi` through the top (the exit direction pre-sampled from
//!   `wi` in importance transport, the adjoint of the radiance walk), combined with the walk's
//!   own exit by the power heuristic (§14.3.2). The weight of the walk's own exit uses the
//!   density with which the pre-sampling from `wi` produces that direction,
//!   `pdf_top(wi -> -w)`; pbrt-v4 uses the reverse density `pdf_top(-w -> wi)`, with which the
//!   two weights do not sum to 1 through a rough coating (Veach 1997, §9.2: a biased
//!   combination; measured here as a 5-sigma failure of reciprocity and of the chi-square
//!   test, and with pbrt-v4 itself: a white-based coating of roughness 0.3 integrates its `f`
//!   to 1.08 times its sampled albedo). `Layer::pbrt_v4_exit_weight` switches to pbrt-v4's
//!   weight, only to reproduce its renders;
//! * `Layered::sample` follows one walk until it leaves the top; the returned weight
//!   `f cos / pdf` is the product of the events' weights (an unbiased estimator of the BSDF
//!   integral, not a ratio of the estimates of `f` and `pdf`);
//! * `Layered::pdf` estimates the density of the sampled directions by the TRT term
//!   (transmission, reflection at the base, transmission) mixed 9:1 with a uniform sphere
//!   density (§14.3.3); it only serves multiple importance sampling, where any positive density
//!   keeps the estimator unbiased.
//!
//! Every walk is driven by a generator seeded from a hash of the directions (and of the sample's
//! uniform numbers for `sample`), as pbrt-v4 does: the same call gives the same result on any
//! thread, in any order.

use super::fresnel::{fr_dielectric, reflect, refract};
use super::{dielectric_half_vector, Bsdf, TrowbridgeReitz};
use crate::math::V3;
use crate::phase::{hg_p, hg_sample};
use camsim_core::rng::{mix64, Rng};
use rand::Rng as _;
use std::f32::consts::PI;

/// Transport direction of a walk (pbrt-v4 `TransportMode`): radiance carried from `wi` to
/// `wo`, or importance (its adjoint) carried from `wo` to `wi`. Only dielectric transmission
/// differs: radiance is scaled by `1 / eta'^2` when it crosses into a medium of relative index
/// `eta'` (pbrt-v4 §9.5.2).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Mode {
    Radiance,
    Importance,
}

/// Lobes a sampling call may choose from (pbrt-v4 `BxDFReflTransFlags`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Lobes {
    All,
    Reflection,
    Transmission,
}

impl Lobes {
    #[inline(always)]
    fn reflection(self) -> bool {
        self != Lobes::Transmission
    }
    #[inline(always)]
    fn transmission(self) -> bool {
        self != Lobes::Reflection
    }
}

/// One sampled scattering event at an interface: BSDF value (not weighted), direction, density.
#[derive(Debug, Clone, Copy)]
struct Event<const N: usize> {
    wi: V3,
    f: [f32; N],
    pdf: f32,
    specular: bool,
    transmission: bool,
}

impl<const N: usize> Event<N> {
    /// pbrt-v4's validity test of a sample (`!bs || !bs->f || bs->pdf == 0 || bs->wi.z == 0`).
    #[inline(always)]
    fn valid(self) -> Option<Self> {
        let nonzero = self.f.iter().any(|&v| v > 0.0);
        (nonzero
            && self.pdf > 0.0
            && self.pdf.is_finite()
            && self.wi.z != 0.0
            && self.f.iter().all(|v| v.is_finite()))
        .then_some(self)
    }
}

/// The random walk's parameters and the medium between the interfaces.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Layer<const N: usize> {
    /// Optical depth of the layer (dimensionless; pbrt-v4 `thickness`, default 0.01).
    pub thickness: f32,
    /// Single-scattering albedo of the medium per wavelength (0: no medium).
    pub albedo: [f32; N],
    /// Henyey-Greenstein asymmetry parameter of the medium.
    pub g: f32,
    /// Maximum number of scattering events of one walk (pbrt-v4 `maxdepth`, default 10).
    pub max_depth: u32,
    /// Walks averaged per evaluation of `f` and `pdf` (pbrt-v4 `nsamples`, default 1).
    pub n_samples: u32,
    /// Weigh a sample leaving through a rough top by pbrt-v4's reverse density `pdf(-w -> wi)`
    /// instead of the pre-sampled strategy's `pdf(wi -> -w)` (`camsim_scene3d::scene::
    /// LayeredExitWeight::PbrtV4`: biased, only for reproducing pbrt-v4; default false).
    pub pbrt_v4_exit_weight: bool,
}

impl<const N: usize> Layer<N> {
    /// pbrt-v4's defaults (`thickness` 0.01, no medium, `maxdepth` 10, `nsamples` 1).
    pub fn pbrt_default() -> Self {
        Layer {
            thickness: 0.01,
            albedo: [0.0; N],
            g: 0.0,
            max_depth: 10,
            n_samples: 1,
            pbrt_v4_exit_weight: false,
        }
    }
}

/// The top interface: a dielectric of relative index `eta` (inside over outside), smooth or
/// rough (pbrt-v4 `DielectricBxDF`, §9.5 and §9.7), with transport mode and lobe selection.
#[derive(Debug, Clone, Copy)]
struct Top {
    eta: f32,
    distrib: TrowbridgeReitz,
}

impl Top {
    /// A delta interface: perfectly smooth, or index-matched (pbrt-v4 treats eta = 1 as a
    /// smooth pass-through whatever the roughness).
    #[inline(always)]
    fn specular(&self) -> bool {
        self.eta == 1.0 || self.distrib.effectively_smooth()
    }

    /// `1 / eta'^2` of a transmission in radiance mode, 1 in importance mode; `etap` is the
    /// relative index seen from `wo`'s side.
    #[inline(always)]
    fn radiance_scale(mode: Mode, etap: f32) -> f32 {
        if mode == Mode::Radiance {
            1.0 / (etap * etap)
        } else {
            1.0
        }
    }

    /// BSDF value (non-delta part; pbrt-v4 `DielectricBxDF::f`, eq. 9.33 and 9.40).
    fn f(&self, wo: V3, wi: V3, mode: Mode) -> f32 {
        if self.specular() {
            return 0.0;
        }
        let Some((wm, etap, is_reflection)) = dielectric_half_vector(self.eta, &wo, &wi) else {
            return 0.0;
        };
        let d = &self.distrib;
        let r = fr_dielectric(wo.dot(wm), self.eta);
        if is_reflection {
            d.d(wm) * d.g(wo, wi) * r / (4.0 * wo.z * wi.z).abs()
        } else {
            let denom = wi.dot(wm) + wo.dot(wm) / etap;
            let ft = d.d(wm)
                * (1.0 - r)
                * d.g(wo, wi)
                * (wi.dot(wm) * wo.dot(wm) / (wi.z * wo.z * denom * denom)).abs();
            ft * Self::radiance_scale(mode, etap)
        }
    }

    /// Density of [`Top::sample`] restricted to `lobes` (pbrt-v4 `DielectricBxDF::PDF`).
    fn pdf(&self, wo: V3, wi: V3, lobes: Lobes) -> f32 {
        if self.specular() {
            return 0.0;
        }
        let Some((wm, etap, is_reflection)) = dielectric_half_vector(self.eta, &wo, &wi) else {
            return 0.0;
        };
        let r = fr_dielectric(wo.dot(wm), self.eta);
        let (pr, pt) = (
            if lobes.reflection() { r } else { 0.0 },
            if lobes.transmission() { 1.0 - r } else { 0.0 },
        );
        if pr + pt <= 0.0 {
            return 0.0;
        }
        let d = &self.distrib;
        if is_reflection {
            d.pdf(wo, wm) / (4.0 * wo.dot(wm).abs()) * pr / (pr + pt)
        } else {
            // Jacobian of the refracted half vector, pbrt-v4 eq. 9.37.
            let denom = wi.dot(wm) + wo.dot(wm) / etap;
            d.pdf(wo, wm) * wi.dot(wm).abs() / (denom * denom) * pt / (pr + pt)
        }
    }

    /// Sample a direction (pbrt-v4 `DielectricBxDF::Sample_f`): Fresnel-weighted choice between
    /// reflection and transmission among `lobes`, on the smooth interface or on a visible
    /// microfacet.
    fn sample<const N: usize>(
        &self,
        wo: V3,
        uc: f32,
        u0: f32,
        u1: f32,
        mode: Mode,
        lobes: Lobes,
    ) -> Option<Event<N>> {
        if wo.z == 0.0 {
            return None;
        }
        if self.specular() {
            let r = fr_dielectric(wo.z, self.eta);
            let (pr, pt) = (
                if lobes.reflection() { r } else { 0.0 },
                if lobes.transmission() { 1.0 - r } else { 0.0 },
            );
            if pr + pt <= 0.0 {
                return None;
            }
            if uc < pr / (pr + pt) {
                let wi = V3::new(-wo.x, -wo.y, wo.z);
                let f = r / wi.z.abs();
                return Event {
                    wi,
                    f: [f; N],
                    pdf: pr / (pr + pt),
                    specular: true,
                    transmission: false,
                }
                .valid();
            }
            let (wi, etap) = refract(wo, V3::new(0.0, 0.0, 1.0), self.eta)?;
            let f = (1.0 - r) / wi.z.abs() * Self::radiance_scale(mode, etap);
            return Event {
                wi,
                f: [f; N],
                pdf: pt / (pr + pt),
                specular: true,
                transmission: true,
            }
            .valid();
        }
        let wm = self.distrib.sample_wm(wo, u0, u1);
        let r = fr_dielectric(wo.dot(wm), self.eta);
        let (pr, pt) = (
            if lobes.reflection() { r } else { 0.0 },
            if lobes.transmission() { 1.0 - r } else { 0.0 },
        );
        if pr + pt <= 0.0 {
            return None;
        }
        let wi = if uc < pr / (pr + pt) {
            let wi = reflect(wo, wm);
            if wo.z * wi.z <= 0.0 {
                return None;
            }
            wi
        } else {
            let (wi, _) = refract(wo, wm, self.eta)?;
            if wo.z * wi.z >= 0.0 {
                return None;
            }
            wi
        };
        let f = self.f(wo, wi, mode);
        let pdf = self.pdf(wo, wi, lobes);
        Event {
            wi,
            f: [f; N],
            pdf,
            specular: false,
            transmission: wo.z * wi.z < 0.0,
        }
        .valid()
    }
}

/// The base: an opaque BSDF of camsim's set (Lambertian or conductor), evaluated inside the layer.
#[derive(Debug, Clone, Copy)]
struct Bottom<const N: usize>(Bsdf<N>);

impl<const N: usize> Bottom<N> {
    #[inline(always)]
    fn specular(&self) -> bool {
        self.0.is_delta()
    }
    #[inline(always)]
    fn f(&self, wo: V3, wi: V3) -> [f32; N] {
        self.0.eval(&wo, &wi).0
    }
    #[inline(always)]
    fn pdf(&self, wo: V3, wi: V3) -> f32 {
        self.0.pdf(&wo, &wi)
    }
    /// A reflection sample (the base never transmits), its value recovered from the weight.
    #[inline]
    fn sample(&self, wo: V3, uc: f32, u0: f32, u1: f32) -> Option<Event<N>> {
        let s = self.0.sample(&wo, uc, u0, u1)?;
        let c = s.wi_local.z.abs();
        if c == 0.0 {
            return None;
        }
        let f = std::array::from_fn(|i| s.weight[i] * s.pdf / c);
        Event {
            wi: s.wi_local,
            f,
            pdf: s.pdf,
            specular: s.specular,
            transmission: false,
        }
        .valid()
    }
}

/// Transmittance of a straight path crossing a height difference `dz` along `w` in a medium of
/// unit extinction (pbrt-v4 `LayeredBxDF::Tr`).
#[inline(always)]
fn tr(dz: f32, w: V3) -> f32 {
    if dz.abs() <= f32::MIN_POSITIVE {
        1.0
    } else {
        (-(dz / w.z).abs()).exp()
    }
}

/// Power heuristic with exponent 2 for one sample of each strategy (Veach 1997, eq. 9.13).
#[inline(always)]
fn power_heuristic(pa: f32, pb: f32) -> f32 {
    let (a, b) = (pa * pa, pb * pb);
    if a.is_infinite() {
        1.0
    } else if a + b == 0.0 {
        0.0
    } else {
        a / (a + b)
    }
}

/// A generator seeded from up to six floats' bits (pbrt-v4 seeds its layered RNG with a hash of
/// the directions, or of the direction and the sample's uniform numbers).
#[inline]
fn rng_from(a: [f32; 3], b: [f32; 3], salt: u64) -> Rng {
    let mut h = mix64(salt);
    for v in a {
        h = mix64(h ^ v.to_bits() as u64);
    }
    let mut k = h;
    for v in b {
        k = mix64(k ^ v.to_bits() as u64);
    }
    Rng::new(((h as u128) << 64) | (k as u128 | 1))
}

const SALT_F: u64 = 0x4C41_5945_5245_4446; // "LAYEREDF"
const SALT_PDF: u64 = 0x4C41_5945_5250_4446;
const SALT_SAMPLE: u64 = 0x4C41_5945_5253_4D50;

/// A uniform number in [0, 1).
#[inline(always)]
fn uniform(rng: &mut Rng) -> f32 {
    rng.gen::<f32>().min(1.0 - f32::EPSILON / 2.0)
}

#[inline(always)]
fn max_of<const N: usize>(v: &[f32; N]) -> f32 {
    v.iter().fold(0.0, |a, &b| a.max(b))
}

/// A layered BSDF: a dielectric coating over an opaque base with a medium between them.
#[derive(Debug, Clone, Copy)]
pub(super) struct Layered<const N: usize> {
    top: Top,
    bottom: Bottom<N>,
    layer: Layer<N>,
    has_medium: bool,
}

/// A sample of the layered BSDF: direction (upper hemisphere, mirrored back by the caller),
/// weight `f cos / pdf` per wavelength, the density for multiple importance sampling, and
/// whether every event of the walk was specular.
pub(super) struct LayeredSample<const N: usize> {
    pub wi: V3,
    pub weight: [f32; N],
    pub pdf: f32,
    pub specular: bool,
}

impl<const N: usize> Layered<N> {
    /// `eta`, `distrib`: the coating; `bottom`: the base's BSDF (already relative to the coating).
    pub(super) fn new(
        eta: f32,
        distrib: TrowbridgeReitz,
        bottom: Bsdf<N>,
        layer: &Layer<N>,
    ) -> Self {
        let mut layer = *layer;
        // pbrt-v4 clamps the thickness to the smallest positive float.
        layer.thickness = layer.thickness.max(f32::MIN_POSITIVE);
        let has_medium = layer.albedo.iter().any(|&a| a > 0.0);
        Layered {
            top: Top { eta, distrib },
            bottom: Bottom(bottom),
            layer,
            has_medium,
        }
    }

    /// True when every walk is a chain of delta events: `f` and `pdf` are zero everywhere.
    pub(super) fn is_delta(&self) -> bool {
        self.top.specular() && self.bottom.specular() && !self.has_medium
    }

    /// Estimate of `f(wo, wi)` for `wo`, `wi` in the upper hemisphere (pbrt-v4
    /// `LayeredBxDF::f`, two-sided, exit through the top).
    pub(super) fn f(&self, wo: V3, wi: V3) -> [f32; N] {
        let mut f = [0.0f32; N];
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return f;
        }
        let (top, bottom, layer) = (&self.top, &self.bottom, &self.layer);
        let thickness = layer.thickness;
        let n = layer.n_samples.max(1);
        // Reflection at the top interface, once per walk.
        let fr = top.f(wo, wi, Mode::Radiance);
        for v in f.iter_mut() {
            *v = n as f32 * fr;
        }
        let mut rng = rng_from([wo.x, wo.y, wo.z], [wi.x, wi.y, wi.z], SALT_F);
        let r = &mut rng;
        // The exit is through the top, at z = thickness.
        let exit_z = thickness;
        // The pre-sampled strategy's density of the interior direction `-w` (pbrt-v4 5f7a606:
        // the reverse, `wi` given `-w`; see the module notes).
        let exit_pdf = |w: V3| {
            if layer.pbrt_v4_exit_weight {
                top.pdf(-w, wi, Lobes::Transmission)
            } else {
                top.pdf(wi, -w, Lobes::Transmission)
            }
        };
        let add = |f: &mut [f32; N], beta: &[f32; N], k: &[f32; N], s: f32| {
            for i in 0..N {
                f[i] += beta[i] * k[i] * s;
            }
        };
        for _ in 0..n {
            // Into the layer along wo (radiance) and, for next-event estimation, along wi
            // (importance: the adjoint walk).
            let Some(wos) = top.sample::<N>(
                wo,
                uniform(r),
                uniform(r),
                uniform(r),
                Mode::Radiance,
                Lobes::Transmission,
            ) else {
                continue;
            };
            let Some(wis) = top.sample::<N>(
                wi,
                uniform(r),
                uniform(r),
                uniform(r),
                Mode::Importance,
                Lobes::Transmission,
            ) else {
                continue;
            };
            let mut beta: [f32; N] = std::array::from_fn(|i| wos.f[i] * wos.wi.z.abs() / wos.pdf);
            let mut z = thickness;
            let mut w = wos.wi;
            for depth in 0..layer.max_depth {
                // Russian roulette (pbrt-v4: after 3 events, below a throughput of 0.25).
                let mb = max_of(&beta);
                if depth > 3 && mb < 0.25 {
                    let q = (1.0 - mb).max(0.0);
                    if uniform(r) < q {
                        break;
                    }
                    for b in beta.iter_mut() {
                        *b /= 1.0 - q;
                    }
                }
                if !self.has_medium {
                    // Straight to the other interface.
                    z = if z == thickness { 0.0 } else { thickness };
                    let t = tr(thickness, w);
                    for b in beta.iter_mut() {
                        *b *= t;
                    }
                } else {
                    // Free flight in the medium (unit extinction): exponential distance in z.
                    let dz = -(1.0 - uniform(r)).ln() * w.z.abs();
                    let zp = if w.z > 0.0 { z + dz } else { z - dz };
                    if zp == z {
                        continue;
                    }
                    if 0.0 < zp && zp < thickness {
                        // Scattering in the medium: next-event estimation through the top
                        // along the pre-sampled wis, then a phase-function sample.
                        let wt = if top.specular() {
                            1.0
                        } else {
                            power_heuristic(wis.pdf, hg_p(layer.g, -w, -wis.wi))
                        };
                        let k = hg_p(layer.g, -w, -wis.wi) * wt * tr(zp - exit_z, wis.wi) / wis.pdf;
                        for i in 0..N {
                            f[i] += beta[i] * layer.albedo[i] * k * wis.f[i];
                        }
                        let (pw, pp) = hg_sample(layer.g, -w, uniform(r), uniform(r));
                        if pp <= 0.0 || pw.z == 0.0 {
                            continue;
                        }
                        for (b, a) in beta.iter_mut().zip(&layer.albedo) {
                            *b *= a;
                        }
                        w = pw;
                        z = zp;
                        // The phase sample's own way out through a rough top.
                        if ((z < exit_z && w.z > 0.0) || (z > exit_z && w.z < 0.0))
                            && !top.specular()
                        {
                            let f_exit = top.f(-w, wi, Mode::Radiance);
                            if f_exit > 0.0 {
                                let wt = power_heuristic(pp, exit_pdf(w));
                                let s = tr(zp - exit_z, w) * f_exit * wt;
                                add(&mut f, &beta, &[1.0; N], s);
                            }
                        }
                        continue;
                    }
                    z = zp.clamp(0.0, thickness);
                }
                if z == exit_z {
                    // Internal reflection at the top.
                    let Some(bs) = top.sample::<N>(
                        -w,
                        uniform(r),
                        uniform(r),
                        uniform(r),
                        Mode::Radiance,
                        Lobes::Reflection,
                    ) else {
                        break;
                    };
                    for (b, fe) in beta.iter_mut().zip(&bs.f) {
                        *b *= fe * bs.wi.z.abs() / bs.pdf;
                    }
                    w = bs.wi;
                } else {
                    // At the base: next-event estimation through the top along wis.
                    if !bottom.specular() {
                        let wt = if top.specular() {
                            1.0
                        } else {
                            power_heuristic(wis.pdf, bottom.pdf(-w, -wis.wi))
                        };
                        let fb = bottom.f(-w, -wis.wi);
                        let s = wis.wi.z.abs() * wt * tr(thickness, wis.wi) / wis.pdf;
                        for i in 0..N {
                            f[i] += beta[i] * fb[i] * s * wis.f[i];
                        }
                    }
                    let Some(bs) = bottom.sample(-w, uniform(r), uniform(r), uniform(r)) else {
                        break;
                    };
                    for (b, fe) in beta.iter_mut().zip(&bs.f) {
                        *b *= fe * bs.wi.z.abs() / bs.pdf;
                    }
                    w = bs.wi;
                    // The base sample's own way out through a rough top.
                    if !top.specular() {
                        let f_exit = top.f(-w, wi, Mode::Radiance);
                        if f_exit > 0.0 {
                            let wt = if bottom.specular() {
                                1.0
                            } else {
                                power_heuristic(bs.pdf, exit_pdf(w))
                            };
                            add(&mut f, &beta, &[1.0; N], tr(thickness, bs.wi) * f_exit * wt);
                        }
                    }
                }
            }
        }
        let inv = 1.0 / n as f32;
        f.map(|v| v * inv)
    }

    /// Estimate of the sampling density of `wi` given `wo` (pbrt-v4 `LayeredBxDF::PDF`), both in
    /// the upper hemisphere.
    pub(super) fn pdf(&self, wo: V3, wi: V3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        let (top, bottom) = (&self.top, &self.bottom);
        let n = self.layer.n_samples.max(1);
        let mut rng = rng_from([wi.x, wi.y, wi.z], [wo.x, wo.y, wo.z], SALT_PDF);
        let r = &mut rng;
        let mut pdf_sum = n as f32 * top.pdf(wo, wi, Lobes::Reflection);
        for _ in 0..n {
            // TRT: into the layer, reflected by the base, out through the top.
            let wos = top.sample::<N>(
                wo,
                uniform(r),
                uniform(r),
                uniform(r),
                Mode::Radiance,
                Lobes::Transmission,
            );
            let wis = top.sample::<N>(
                wi,
                uniform(r),
                uniform(r),
                uniform(r),
                Mode::Importance,
                Lobes::Transmission,
            );
            let (Some(wos), Some(wis)) = (wos, wis) else {
                continue;
            };
            if top.specular() {
                pdf_sum += bottom.pdf(-wos.wi, -wis.wi);
                continue;
            }
            // Two estimates of the product of the three densities, combined by MIS.
            let Some(rs) = bottom.sample(-wos.wi, uniform(r), uniform(r), uniform(r)) else {
                continue;
            };
            if bottom.specular() {
                pdf_sum += top.pdf(-rs.wi, wi, Lobes::All);
            } else {
                let r_pdf = bottom.pdf(-wos.wi, -wis.wi);
                pdf_sum += power_heuristic(wis.pdf, r_pdf) * r_pdf;
                let t_pdf = top.pdf(-rs.wi, wi, Lobes::All);
                pdf_sum += power_heuristic(rs.pdf, t_pdf) * t_pdf;
            }
        }
        // Mixed with the uniform sphere density, which bounds it away from 0.
        0.1 / (4.0 * PI) + 0.9 * pdf_sum / n as f32
    }

    /// Sample `wi` given `wo` (upper hemisphere) by one walk (pbrt-v4 `LayeredBxDF::Sample_f`).
    pub(super) fn sample(&self, wo: V3, uc: f32, u0: f32, u1: f32) -> Option<LayeredSample<N>> {
        if wo.z <= 0.0 {
            return None;
        }
        let (top, bottom, layer) = (&self.top, &self.bottom, &self.layer);
        let thickness = layer.thickness;
        let bs = top.sample::<N>(wo, uc, u0, u1, Mode::Radiance, Lobes::All)?;
        if !bs.transmission {
            // Reflected by the coating: the density for MIS is the layered density estimate.
            let pdf = if bs.specular {
                bs.pdf
            } else {
                self.pdf(wo, bs.wi)
            };
            let weight = bs.f.map(|v| v * bs.wi.z.abs() / bs.pdf);
            return Some(LayeredSample {
                wi: bs.wi,
                weight,
                pdf,
                specular: bs.specular,
            });
        }
        let mut w = bs.wi;
        let mut specular_path = bs.specular;
        let mut rng = rng_from([wo.x, wo.y, wo.z], [uc, u0, u1], SALT_SAMPLE);
        let r = &mut rng;
        // Throughput numerator (f cos of each event) and the product of the densities.
        let mut f: [f32; N] = bs.f.map(|v| v * bs.wi.z.abs());
        let mut pdf = bs.pdf;
        let mut z = thickness;
        for depth in 0..layer.max_depth {
            let rr_beta = max_of(&f) / pdf;
            if depth > 3 && rr_beta < 0.25 {
                let q = (1.0 - rr_beta).max(0.0);
                if uniform(r) < q {
                    return None;
                }
                pdf *= 1.0 - q;
            }
            if w.z == 0.0 {
                return None;
            }
            if self.has_medium {
                let dz = -(1.0 - uniform(r)).ln() * w.z.abs();
                let zp = if w.z > 0.0 { z + dz } else { z - dz };
                if zp == z {
                    return None;
                }
                if 0.0 < zp && zp < thickness {
                    let (pw, pp) = hg_sample(layer.g, -w, uniform(r), uniform(r));
                    if pp <= 0.0 || pw.z == 0.0 {
                        return None;
                    }
                    for (v, a) in f.iter_mut().zip(&layer.albedo) {
                        *v *= a * pp;
                    }
                    pdf *= pp;
                    specular_path = false;
                    w = pw;
                    z = zp;
                    continue;
                }
                z = zp.clamp(0.0, thickness);
            } else {
                z = if z == thickness { 0.0 } else { thickness };
                let t = tr(thickness, w);
                for v in f.iter_mut() {
                    *v *= t;
                }
            }
            let (uc, u0, u1) = (uniform(r), uniform(r), uniform(r));
            let e = if z == 0.0 {
                bottom.sample(-w, uc, u0, u1)?
            } else {
                top.sample::<N>(-w, uc, u0, u1, Mode::Radiance, Lobes::All)?
            };
            for (v, fe) in f.iter_mut().zip(&e.f) {
                *v *= fe;
            }
            pdf *= e.pdf;
            specular_path &= e.specular;
            w = e.wi;
            if e.transmission {
                // Left through the top.
                let weight = f.map(|v| v * w.z.abs() / pdf);
                let pdf = if specular_path { pdf } else { self.pdf(wo, w) };
                return Some(LayeredSample {
                    wi: w,
                    weight,
                    pdf,
                    specular: specular_path,
                });
            }
            for v in f.iter_mut() {
                *v *= w.z.abs();
            }
        }
        None
    }
}
