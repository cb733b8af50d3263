//! The environment map's parameterisations (pbrt-v4 `ImageInfiniteLight`): equal-area
//! octahedral (pbrt-v4's) and latitude-longitude, from the unit square to the sphere and back.
//! Sampling and radiance lookup are the tracer's (`camsim_render::envmap`).

use std::f64::consts::PI;

/// pbrt-v4 `EqualAreaSquareToSphere` (Clarberg, "Fast Equal-Area Mapping of the (Hemi)Sphere
/// using SIMD", JGT 2008): `(u, v)` in [0, 1]^2 to a unit direction; area-preserving, so a
/// uniform density on the square is `1 / (4 pi)` per steradian.
pub fn equal_area_square_to_sphere(u: f64, v: f64) -> [f64; 3] {
    let (x, y) = (2.0 * u - 1.0, 2.0 * v - 1.0);
    let (ax, ay) = (x.abs(), y.abs());
    let signed_distance = 1.0 - (ax + ay);
    let r = 1.0 - signed_distance.abs();
    let phi = if r == 0.0 { 1.0 } else { (ay - ax) / r + 1.0 } * PI / 4.0;
    let z = (1.0 - r * r).copysign(signed_distance);
    let cos_phi = phi.cos().copysign(x);
    let sin_phi = phi.sin().copysign(y);
    let k = r * (2.0 - r * r).max(0.0).sqrt();
    [cos_phi * k, sin_phi * k, z]
}

/// Inverse of [`equal_area_square_to_sphere`] (pbrt-v4 `EqualAreaSphereToSquare`, with an exact
/// arctangent).
pub fn equal_area_sphere_to_square(d: [f64; 3]) -> (f64, f64) {
    let (x, y, z) = (d[0].abs(), d[1].abs(), d[2].abs());
    let r = (1.0 - z).max(0.0).sqrt();
    let (a, b) = (x.max(y), x.min(y));
    let b = if a == 0.0 { 0.0 } else { b / a };
    let mut phi = b.atan() * 2.0 / PI;
    if x < y {
        phi = 1.0 - phi;
    }
    let mut v = phi * r;
    let mut u = r - v;
    if d[2] < 0.0 {
        std::mem::swap(&mut u, &mut v);
        u = 1.0 - u;
        v = 1.0 - v;
    }
    u = u.copysign(d[0]);
    v = v.copysign(d[1]);
    (0.5 * (u + 1.0), 0.5 * (v + 1.0))
}

/// Latitude-longitude: `(u, v)` to a direction, `phi = 2 pi u`, `theta = pi v` (z up).
pub fn latlong_to_sphere(u: f64, v: f64) -> [f64; 3] {
    let (sp, cp) = (2.0 * PI * u).sin_cos();
    let (st, ct) = (PI * v).sin_cos();
    [st * cp, st * sp, ct]
}

/// Inverse of [`latlong_to_sphere`].
pub fn sphere_to_latlong(d: [f64; 3]) -> (f64, f64) {
    let mut phi = d[1].atan2(d[0]);
    if phi < 0.0 {
        phi += 2.0 * PI;
    }
    // atan2 rather than acos(z): accurate near the poles.
    (phi / (2.0 * PI), d[0].hypot(d[1]).atan2(d[2]) / PI)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn equal_area_mapping_round_trips_and_preserves_area() {
        let n = 64;
        let mut z_hist = [0usize; 8];
        for j in 0..n {
            for i in 0..n {
                let (u, v) = ((i as f64 + 0.37) / n as f64, (j as f64 + 0.61) / n as f64);
                let d = equal_area_square_to_sphere(u, v);
                let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                assert!((len - 1.0).abs() < 1e-9);
                let (u2, v2) = equal_area_sphere_to_square(d);
                assert!(
                    (u - u2).abs() < 1e-9 && (v - v2).abs() < 1e-9,
                    "({u}, {v}) -> ({u2}, {v2})"
                );
                z_hist[(((d[2] + 1.0) / 2.0 * 8.0) as usize).min(7)] += 1;
            }
        }
        // Uniform on the sphere <=> z uniform in [-1, 1] (Archimedes): equal counts per z band.
        let want = (n * n) as f64 / 8.0;
        for c in z_hist {
            assert!((c as f64 - want).abs() < 0.05 * want, "{z_hist:?}");
        }
        let (u, v) = sphere_to_latlong(latlong_to_sphere(0.3, 0.6));
        assert!((u - 0.3).abs() < 1e-12 && (v - 0.6).abs() < 1e-12);
    }
}
