//! Sampling routines and their densities (pbrt-v4, Pharr, Jakob & Humphreys, "Physically Based
//! Rendering", 4th ed., ch. A.5 and 6). Directions are unit vectors; pdfs are per steradian or per
//! square metre as named.

use crate::math::{Frame, V3};
use std::f32::consts::{FRAC_1_PI, FRAC_PI_2, FRAC_PI_4, PI};

/// Concentric map of the unit square to the unit disk (Shirley & Chiu 1997).
#[inline(always)]
pub fn concentric_disk(u0: f32, u1: f32) -> (f32, f32) {
    let (ox, oy) = (2.0 * u0 - 1.0, 2.0 * u1 - 1.0);
    if ox == 0.0 && oy == 0.0 {
        return (0.0, 0.0);
    }
    let (r, theta) = if ox.abs() > oy.abs() {
        (ox, FRAC_PI_4 * (oy / ox))
    } else {
        (oy, FRAC_PI_2 - FRAC_PI_4 * (ox / oy))
    };
    let (s, c) = theta.sin_cos();
    (r * c, r * s)
}

/// Cosine-weighted direction on the hemisphere around +z (Malley's method); pdf = cos(theta)/pi.
#[inline(always)]
pub fn cosine_hemisphere(u0: f32, u1: f32) -> V3 {
    let (x, y) = concentric_disk(u0, u1);
    let z = (1.0 - x * x - y * y).max(0.0).sqrt();
    V3::new(x, y, z)
}

/// Density of [`cosine_hemisphere`] per steradian for a local direction with `cos_theta = z`.
#[inline(always)]
pub fn cosine_hemisphere_pdf(cos_theta: f32) -> f32 {
    if cos_theta > 0.0 {
        cos_theta * FRAC_1_PI
    } else {
        0.0
    }
}

/// Uniform direction on the unit sphere; pdf = 1/(4 pi).
#[inline(always)]
pub fn uniform_sphere(u0: f32, u1: f32) -> V3 {
    let z = 1.0 - 2.0 * u0;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u1;
    let (s, c) = phi.sin_cos();
    V3::new(r * c, r * s, z)
}

/// Density of [`uniform_sphere`] per steradian.
pub const UNIFORM_SPHERE_PDF: f32 = 1.0 / (4.0 * PI);

/// Uniform barycentrics on a triangle (pbrt-v3 `UniformSampleTriangle`, Turk 1990):
/// returns `(b1, b2)`, point = (1 - b1 - b2) p0 + b1 p1 + b2 p2; pdf = 1/area.
#[inline(always)]
pub fn uniform_triangle(u0: f32, u1: f32) -> (f32, f32) {
    let su0 = u0.sqrt();
    (1.0 - su0, u1 * su0)
}

/// Cone of directions that a sphere (`center`, `radius`) subtends from `p` outside it:
/// `(cos_theta_max, sin2_theta_max)`, or `None` when `p` is inside or on the sphere.
#[inline(always)]
pub fn sphere_cone(p: V3, center: V3, radius: f32) -> Option<(f32, f32)> {
    let dc2 = (center - p).length_squared();
    let r2 = radius * radius;
    if dc2 <= r2 * 1.0001 {
        return None;
    }
    let sin2 = r2 / dc2;
    let cos_max = (1.0 - sin2).max(0.0).sqrt();
    Some((cos_max, sin2))
}

/// `1 - cos_theta_max` without cancellation for small cones.
#[inline(always)]
pub fn one_minus_cos(cos_max: f32, sin2_max: f32) -> f32 {
    if sin2_max < 0.00068523 {
        // sin^2 < 0.00068523 (~1.5 degrees): 1 - cos = sin^2 / 2 to first order (pbrt-v4 Sphere::Sample).
        sin2_max / 2.0
    } else {
        1.0 - cos_max
    }
}

/// Density per steradian of sampling the cone uniformly.
#[inline(always)]
pub fn cone_pdf(cos_max: f32, sin2_max: f32) -> f32 {
    1.0 / (2.0 * PI * one_minus_cos(cos_max, sin2_max))
}

/// Sample a point on the visible cap of a sphere seen from `p` (outside), uniformly in solid
/// angle (pbrt-v4 `Sphere::Sample(ctx, u)`, after Shirley et al. 1996). Returns the point on the
/// sphere and the outward unit normal there.
#[inline]
pub fn sample_sphere_cone(
    p: V3,
    center: V3,
    radius: f32,
    cos_max: f32,
    sin2_max: f32,
    u0: f32,
    u1: f32,
) -> (V3, V3) {
    let one_minus = one_minus_cos(cos_max, sin2_max);
    // cos(theta) uniform in [cos_max, 1].
    let (cos_theta, sin2_theta) = if sin2_max < 0.00068523 {
        let s2 = sin2_max * u0;
        ((1.0 - s2).sqrt(), s2)
    } else {
        let c = 1.0 - u0 * one_minus;
        (c, 1.0 - c * c)
    };
    // Angle alpha at the centre between -wc and the sampled point (pbrt-v4 eq. in Sphere::Sample).
    let cos_alpha =
        sin2_theta / sin2_max.sqrt() + cos_theta * (1.0 - sin2_theta / sin2_max).max(0.0).sqrt();
    let sin_alpha = (1.0 - cos_alpha * cos_alpha).max(0.0).sqrt();
    let phi = 2.0 * PI * u1;
    let (s, c) = phi.sin_cos();
    let wc = (center - p).normalize();
    let frame = Frame::from_normal(-wc);
    let n = frame.to_world(V3::new(sin_alpha * c, sin_alpha * s, cos_alpha));
    (center + n * radius, n)
}

/// Power heuristic with beta = 2 (Veach 1997, eq. 9.13): weight of a sample from strategy `f`.
#[inline(always)]
pub fn power_heuristic(pdf_f: f32, pdf_g: f32) -> f32 {
    let (f, g) = (pdf_f * pdf_f, pdf_g * pdf_g);
    if f.is_infinite() {
        1.0
    } else if f + g == 0.0 {
        0.0
    } else {
        f / (f + g)
    }
}
