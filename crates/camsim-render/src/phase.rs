//! The Henyey-Greenstein phase function (Henyey & Greenstein 1941; pbrt-v4 4th ed. sec. 11.3.1),
//! shared by participating media and the layered BSDFs' internal medium. Directions are unit
//! vectors pointing away from the scattering point: `wo` back along the arriving path, `wi`
//! toward the next vertex, so forward scattering is `wi = -wo`.

use crate::math::{Frame, V3};
use std::f32::consts::PI;

/// Phase function value, 1/sr: `(1 - g^2) / (4 pi (1 + g^2 + 2 g cos)^{3/2})` with
/// `cos = wo . wi` (4th ed. eq. 11.12 with pbrt-v4's direction convention). Integrates to 1
/// over the sphere for `|g| < 1`.
#[inline]
pub fn hg_p(g: f32, wo: V3, wi: V3) -> f32 {
    let denom = 1.0 + g * g + 2.0 * g * wo.dot(wi);
    (1.0 - g * g) / (4.0 * PI * denom * denom.max(0.0).sqrt())
}

/// Sample the phase function around the propagation direction `-wo`: the cosine to `-wo` by
/// inverting the cumulative distribution, `cos = (1 + g^2 - ((1 - g^2) / (1 - g + 2 g u0))^2) /
/// (2 g)` (uniform in [-1, 1] for `|g| < 1e-3`), azimuth `2 pi u1`. Returns `(wi, p)`; `p` is
/// also the density, per steradian.
#[inline]
pub fn hg_sample(g: f32, wo: V3, u0: f32, u1: f32) -> (V3, f32) {
    let cos_theta = if g.abs() < 1e-3 {
        1.0 - 2.0 * u0
    } else {
        let s = (1.0 - g * g) / (1.0 - g + 2.0 * g * u0);
        ((1.0 + g * g - s * s) / (2.0 * g)).clamp(-1.0, 1.0)
    };
    let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
    let (sp, cp) = (2.0 * PI * u1).sin_cos();
    let frame = Frame::from_normal(-wo);
    let wi = frame.to_world(V3::new(sin_theta * cp, sin_theta * sp, cos_theta));
    (wi, hg_p(g, wo, wi))
}
