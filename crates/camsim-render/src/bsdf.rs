//! BSDFs at a surface point, in the local shading frame (z = shading normal). The set is closed
//! (dispatch by `match`): a conductor, dielectric or coated diffuse BSDF is a new variant here, a
//! new [`crate::scene::Material`] variant and a new arm in the tracer's material compile step.

use crate::math::V3;
use crate::sampling::{cosine_hemisphere, cosine_hemisphere_pdf};
use std::f32::consts::FRAC_1_PI;

/// A BSDF evaluated at the path's `N` wavelengths.
#[derive(Debug, Clone, Copy)]
pub enum Bsdf<const N: usize> {
    /// Lambertian reflection, f = reflectance / pi (pbrt-v4 `DiffuseBxDF`), reflecting on both
    /// sides of the surface.
    Diffuse { reflectance: [f32; N] },
}

/// A sampled incident direction.
#[derive(Debug, Clone, Copy)]
pub struct BsdfSample<const N: usize> {
    /// Sampled direction in the local frame.
    pub wi_local: V3,
    /// `f |cos theta_i| / pdf` per wavelength.
    pub weight: [f32; N],
    /// Density of the sample, per steradian.
    pub pdf: f32,
}

#[inline(always)]
fn same_hemisphere(a: &V3, b: &V3) -> bool {
    a.z * b.z > 0.0
}

impl<const N: usize> Bsdf<N> {
    /// `(f(wo, wi), pdf(wi | wo))` for local directions.
    #[inline]
    pub fn eval(&self, wo: &V3, wi: &V3) -> ([f32; N], f32) {
        match self {
            Bsdf::Diffuse { reflectance } => {
                if !same_hemisphere(wo, wi) {
                    return ([0.0; N], 0.0);
                }
                let mut f = [0f32; N];
                for i in 0..N {
                    f[i] = reflectance[i] * FRAC_1_PI;
                }
                (f, cosine_hemisphere_pdf(wi.z.abs()))
            }
        }
    }

    /// Sample `wi` given `wo` from two uniform numbers.
    #[inline]
    pub fn sample(&self, wo: &V3, u0: f32, u1: f32) -> Option<BsdfSample<N>> {
        match self {
            Bsdf::Diffuse { reflectance } => {
                // Cosine-weighted on wo's side (pbrt-v4 DiffuseBxDF::Sample_f).
                let mut wi = cosine_hemisphere(u0, u1);
                if wo.z < 0.0 {
                    wi.z = -wi.z;
                }
                let pdf = cosine_hemisphere_pdf(wi.z.abs());
                if pdf <= 0.0 {
                    return None;
                }
                // f cos / pdf = (rho / pi) cos / (cos / pi) = rho.
                Some(BsdfSample { wi_local: wi, weight: *reflectance, pdf })
            }
        }
    }

    /// Density of sampling `wi` given `wo` (per steradian).
    #[inline]
    pub fn pdf(&self, wo: &V3, wi: &V3) -> f32 {
        match self {
            Bsdf::Diffuse { .. } => {
                if same_hemisphere(wo, wi) {
                    cosine_hemisphere_pdf(wi.z.abs())
                } else {
                    0.0
                }
            }
        }
    }
}
