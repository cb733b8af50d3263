//! A dielectric coating over a conductor (pbrt-v4 `coatedconductor`, 4th ed. §14.3), in camsim's
//! closed form with one pass through the layer instead of pbrt-v4's stochastic `LayeredBxDF`
//! random walk.
//!
//! For `wo`, `wi` in the upper hemisphere (the BSDF is two-sided as pbrt-v4's):
//! `f = f_coat + f_base`, with `f_coat` the coating's reflection (a mirror weighted by the
//! smooth Fresnel reflectance `F`, or the Trowbridge-Reitz microfacet reflection of a rough
//! coating) and
//! `f_base = (1 - F(cos_o)) (1 - F(cos_i)) A(o) A(i) f_c(wo_t, wi_t) / eta^2`,
//! where `wo_t`, `wi_t` are the directions refracted into the layer by the smooth interface
//! (Snell), `A(x) = exp(-thickness / cos theta_t(x))` the attenuation of one pass (pbrt-v4's
//! layer transmittance with albedo 0) and `f_c` the conductor's BRDF (pbrt-v4 `ConductorBxDF`,
//! mirror or microfacet) inside the layer, whose optical constants the caller gives relative to
//! the coating. The `1 / eta^2` is the radiance change of entering and leaving the layer with the
//! solid-angle compression `eta^2 cos_t d omega_t = cos d omega` (Weidlich & Wilkie 2007). Light
//! reflected back down by the interface is dropped (no inter-reflections): the model conserves
//! energy (`f_base`'s albedo is at most `(1 - F(cos_o))` times the conductor's) but is darker than
//! pbrt-v4's random walk where the internal reflections matter: light the rough conductor sends
//! beyond the critical angle is trapped by total internal reflection and lost here (measured:
//! albedo 0.48 at normal incidence for eta 1.5 over a conductor of alpha 0.3 whose smooth
//! counterpart reflects 0.79; `tests/bsdf_physics.rs` prints the figures). A rough coating's
//! base lobe keeps the smooth-interface refraction.

use super::fresnel::{fr_complex, fr_dielectric, reflect};
use super::{same_hemisphere, BsdfSample, TrowbridgeReitz};
use crate::math::V3;

/// The coated conductor at one hit, `wo`/`wi` mirrored to the upper hemisphere by the caller.
pub(super) struct CoatedConductor<'a, const N: usize> {
    /// Index of the coating relative to the outside.
    pub eta: f32,
    pub coat: TrowbridgeReitz,
    pub thickness: f32,
    /// Conductor constants relative to the coating.
    pub c_eta: &'a [f32; N],
    pub c_k: &'a [f32; N],
    pub base: TrowbridgeReitz,
}

impl<const N: usize> CoatedConductor<'_, N> {
    /// The direction inside the layer that leaves as `w` (Snell at the smooth interface), or
    /// `None` when `w` cannot be reached from inside.
    #[inline]
    fn inside(&self, w: V3) -> Option<V3> {
        let sin2_t = (1.0 - w.z * w.z).max(0.0) / (self.eta * self.eta);
        if sin2_t >= 1.0 {
            return None;
        }
        Some(V3::new(
            w.x / self.eta,
            w.y / self.eta,
            (1.0 - sin2_t).sqrt(),
        ))
    }

    /// The outside direction of the inside direction `w_t` (inverse of [`Self::inside`]).
    #[inline]
    fn outside(&self, w_t: V3) -> Option<V3> {
        let sin2 = (1.0 - w_t.z * w_t.z).max(0.0) * self.eta * self.eta;
        if sin2 >= 1.0 {
            return None;
        }
        Some(V3::new(
            w_t.x * self.eta,
            w_t.y * self.eta,
            (1.0 - sin2).sqrt(),
        ))
    }

    /// `(1 - F(cos)) A(cos_t)`: transmission through the interface and one pass of the layer.
    #[inline]
    fn pass(&self, w: V3, w_t: V3) -> f32 {
        (1.0 - fr_dielectric(w.z, self.eta)) * (-self.thickness / w_t.z.max(1e-6)).exp()
    }

    /// Probability of sampling the coating rather than the base.
    #[inline]
    pub fn p_coat(&self, wo: &V3) -> f32 {
        let f = fr_dielectric(wo.z, self.eta);
        let t = match self.inside(*wo) {
            Some(wt) => self.pass(*wo, wt) * (-self.thickness / wt.z.max(1e-6)).exp(),
            None => 0.0,
        };
        if f + t > 0.0 {
            f / (f + t)
        } else {
            1.0
        }
    }

    /// Rough coating reflection `D G F / (4 cos_o cos_i)` and its sampling density.
    #[inline]
    fn coat_lobe(&self, wo: &V3, wi: &V3) -> (f32, f32) {
        let wm = *wo + *wi;
        if wm.length_squared() == 0.0 {
            return (0.0, 0.0);
        }
        let wm = wm.normalize();
        let f = self.coat.d(wm) * self.coat.g(*wo, *wi) * fr_dielectric(wo.dot(wm), self.eta)
            / (4.0 * wo.z * wi.z);
        (f, self.coat.pdf(*wo, wm) / (4.0 * wo.dot(wm).abs()))
    }

    /// Rough base lobe `f_base` and its density per outside steradian.
    #[inline]
    fn base_lobe(&self, wo: &V3, wi: &V3) -> ([f32; N], f32) {
        let (Some(wo_t), Some(wi_t)) = (self.inside(*wo), self.inside(*wi)) else {
            return ([0.0; N], 0.0);
        };
        let wm = (wo_t + wi_t).normalize();
        let dot = wo_t.dot(wm).abs();
        if dot.is_nan() || dot <= 0.0 {
            return ([0.0; N], 0.0);
        }
        let k = self.pass(*wo, wo_t) * self.pass(*wi, wi_t) / (self.eta * self.eta);
        // pbrt-v4 eq. 9.33 inside the layer.
        let common = k * self.base.d(wm) * self.base.g(wo_t, wi_t) / (4.0 * wo_t.z * wi_t.z);
        let f = std::array::from_fn(|i| common * fr_complex(dot, self.c_eta[i], self.c_k[i]));
        // p(wi) = p_t(wi_t) |d omega_t / d omega| = D_wo(wm) / (4 |wo_t . wm|) cos_i / (eta^2 cos_t).
        let pdf = self.base.pdf(wo_t, wm) / (4.0 * dot) * wi.z / (self.eta * self.eta * wi_t.z);
        (f, pdf)
    }

    /// `(f, pdf)` of the non-delta lobes.
    pub fn eval(&self, wo: &V3, wi: &V3) -> ([f32; N], f32) {
        if !same_hemisphere(wo, wi) || wo.z <= 0.0 {
            return ([0.0; N], 0.0);
        }
        let pc = self.p_coat(wo);
        let (mut f, mut pdf) = ([0.0; N], 0.0);
        if !self.coat.effectively_smooth() {
            let (fc, p) = self.coat_lobe(wo, wi);
            f = [fc; N];
            pdf += pc * p;
        }
        if !self.base.effectively_smooth() {
            let (fb, p) = self.base_lobe(wo, wi);
            for i in 0..N {
                f[i] += fb[i];
            }
            pdf += (1.0 - pc) * p;
        }
        (f, pdf)
    }

    /// Sample `wi` (upper hemisphere) given `wo`: the coating with probability `p_coat`, else
    /// the base through the layer.
    pub fn sample(&self, wo: &V3, uc: f32, u0: f32, u1: f32) -> Option<BsdfSample<N>> {
        if wo.z <= 0.0 {
            return None;
        }
        let pc = self.p_coat(wo);
        let mirror = V3::new(-wo.x, -wo.y, wo.z);
        if uc < pc {
            if self.coat.effectively_smooth() {
                let f = fr_dielectric(wo.z, self.eta);
                return BsdfSample::new(mirror, [f / pc; N], pc, true, false, 1.0);
            }
            let wi = reflect(*wo, self.coat.sample_wm(*wo, u0, u1));
            return self.weighted(wo, wi);
        }
        let wo_t = self.inside(*wo)?;
        if self.base.effectively_smooth() {
            // Mirror inside and out: (1 - F)^2 A^2 F_c (the eta^2 of entering and leaving cancel).
            let t = self.pass(*wo, wo_t);
            let w = std::array::from_fn(|i| {
                t * t * fr_complex(wo_t.z, self.c_eta[i], self.c_k[i]) / (1.0 - pc)
            });
            return BsdfSample::new(mirror, w, 1.0 - pc, true, false, 1.0);
        }
        let wi_t = reflect(wo_t, self.base.sample_wm(wo_t, u0, u1));
        if wi_t.z <= 0.0 {
            return None;
        }
        let wi = self.outside(wi_t)?;
        self.weighted(wo, wi)
    }

    /// A non-delta sample: weight `f cos / pdf` with the mixture's `(f, pdf)`.
    #[inline]
    fn weighted(&self, wo: &V3, wi: V3) -> Option<BsdfSample<N>> {
        if wi.z <= 0.0 {
            return None;
        }
        let (f, pdf) = self.eval(wo, &wi);
        BsdfSample::new(
            wi,
            std::array::from_fn(|i| f[i] * wi.z / pdf),
            pdf,
            false,
            false,
            1.0,
        )
    }
}
