//! The anisotropic Trowbridge-Reitz (GGX) microfacet distribution with Smith's height-correlated
//! masking-shadowing and visible-normal sampling (pbrt-v4 4th ed. §9.6; Trowbridge & Reitz 1975,
//! Walter et al. 2007, Heitz 2014 "Understanding the Masking-Shadowing Function", Heitz 2018
//! "Sampling the GGX Distribution of Visible Normals"). Directions are in the local shading frame.

use crate::math::V3;
use std::f32::consts::PI;

/// Trowbridge-Reitz distribution with roughness `alpha_x`, `alpha_y` along the frame's x and y.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrowbridgeReitz {
    pub alpha_x: f32,
    pub alpha_y: f32,
}

#[inline(always)]
fn cos2_theta(w: V3) -> f32 {
    w.z * w.z
}
#[inline(always)]
fn sin2_theta(w: V3) -> f32 {
    (1.0 - cos2_theta(w)).max(0.0)
}
#[inline(always)]
fn tan2_theta(w: V3) -> f32 {
    sin2_theta(w) / cos2_theta(w)
}
#[inline(always)]
fn cos_phi(w: V3) -> f32 {
    let s = sin2_theta(w).sqrt();
    if s == 0.0 {
        1.0
    } else {
        (w.x / s).clamp(-1.0, 1.0)
    }
}
#[inline(always)]
fn sin_phi(w: V3) -> f32 {
    let s = sin2_theta(w).sqrt();
    if s == 0.0 {
        0.0
    } else {
        (w.y / s).clamp(-1.0, 1.0)
    }
}

impl TrowbridgeReitz {
    /// pbrt-v4 `RoughnessToAlpha`: alpha = sqrt(roughness) (used when `remaproughness` is true).
    pub fn roughness_to_alpha(roughness: f32) -> f32 {
        roughness.max(0.0).sqrt()
    }

    /// Below alpha = 1e-3 the surface is treated as perfectly smooth (a delta BSDF), as pbrt-v4's
    /// `EffectivelySmooth` does.
    #[inline(always)]
    pub fn effectively_smooth(&self) -> bool {
        self.alpha_x.max(self.alpha_y) < 1e-3
    }

    /// Microfacet normal density D(wm) (pbrt-v4 eq. 9.16).
    #[inline]
    pub fn d(&self, wm: V3) -> f32 {
        let t2 = tan2_theta(wm);
        if !t2.is_finite() {
            return 0.0;
        }
        let c4 = cos2_theta(wm) * cos2_theta(wm);
        if c4 < 1e-16 {
            return 0.0;
        }
        let (cp, sp) = (cos_phi(wm), sin_phi(wm));
        let e = t2
            * (cp * cp / (self.alpha_x * self.alpha_x) + sp * sp / (self.alpha_y * self.alpha_y));
        1.0 / (PI * self.alpha_x * self.alpha_y * c4 * (1.0 + e) * (1.0 + e))
    }

    /// Smith's auxiliary function Lambda(w) (pbrt-v4 eq. 9.22).
    #[inline]
    pub fn lambda(&self, w: V3) -> f32 {
        let t2 = tan2_theta(w);
        if !t2.is_finite() {
            return 0.0;
        }
        let (cp, sp) = (cos_phi(w), sin_phi(w));
        let alpha2 = cp * cp * self.alpha_x * self.alpha_x + sp * sp * self.alpha_y * self.alpha_y;
        ((1.0 + alpha2 * t2).sqrt() - 1.0) / 2.0
    }

    /// Masking function G1(w) = 1 / (1 + Lambda(w)).
    #[inline]
    pub fn g1(&self, w: V3) -> f32 {
        1.0 / (1.0 + self.lambda(w))
    }

    /// Height-correlated masking-shadowing G(wo, wi) = 1 / (1 + Lambda(wo) + Lambda(wi))
    /// (pbrt-v4 eq. 9.27).
    #[inline]
    pub fn g(&self, wo: V3, wi: V3) -> f32 {
        1.0 / (1.0 + self.lambda(wo) + self.lambda(wi))
    }

    /// Density of visible normals from `w`: D_w(wm) = G1(w) / |cos theta_w| D(wm) |w . wm|
    /// (pbrt-v4 eq. 9.23); this is the density [`Self::sample_wm`] draws from.
    #[inline]
    pub fn pdf(&self, w: V3, wm: V3) -> f32 {
        let c = w.z.abs();
        if c == 0.0 {
            return 0.0;
        }
        self.g1(w) / c * self.d(wm) * w.dot(wm).abs()
    }

    /// Sample a visible microfacet normal seen from `w` (Heitz 2018; pbrt-v4 §9.6.4
    /// `Sample_wm`): stretch `w` to the hemisphere configuration, sample the projected disk with
    /// the visible half warped, and unstretch.
    #[inline]
    pub fn sample_wm(&self, w: V3, u0: f32, u1: f32) -> V3 {
        let mut wh = V3::new(self.alpha_x * w.x, self.alpha_y * w.y, w.z).normalize();
        if wh.z < 0.0 {
            wh = -wh;
        }
        let t1 = if wh.z < 0.99999 {
            V3::new(0.0, 0.0, 1.0).cross(wh).normalize()
        } else {
            V3::new(1.0, 0.0, 0.0)
        };
        let t2 = wh.cross(t1);
        // Uniform disk sample (polar mapping).
        let r = u0.sqrt();
        let (s, c) = (2.0 * PI * u1).sin_cos();
        let (px, mut py) = (r * c, r * s);
        // Warp the half disk hidden behind the projected hemisphere.
        let h = (1.0 - px * px).max(0.0).sqrt();
        let t = (1.0 + wh.z) / 2.0;
        py = (1.0 - t) * h + t * py;
        let pz = (1.0 - px * px - py * py).max(0.0).sqrt();
        let nh = t1 * px + t2 * py + wh * pz;
        V3::new(self.alpha_x * nh.x, self.alpha_y * nh.y, nh.z.max(1e-6)).normalize()
    }
}
