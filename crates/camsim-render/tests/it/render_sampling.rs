//! Sampling routines against their densities: a chi-square goodness-of-fit test of the
//! Lambertian BSDF's sampled directions against its own `pdf`, and Monte Carlo integrals of the
//! densities over their domains (must be 1).

use camsim_render::bsdf::Bsdf;
use camsim_render::geometry::{intersect_sphere, intersect_triangle};
use camsim_render::math::{Frame, V3};
use camsim_render::sampling::*;
use rand::Rng;
use std::f64::consts::PI;

use crate::common;
use common::{chi2_critical, pooled_chi_square};

/// Chi-square test of sampled directions against `pdf`, on a (cos theta, phi) grid over the
/// sphere; expected counts come from integrating `pdf` over each cell (Simpson, 8 x 8 points).
fn chi_square_directions(
    sample: impl Fn(f32, f32) -> Option<V3>,
    pdf: impl Fn(V3) -> f64,
    n: usize,
    seed: u64,
) -> (f64, f64) {
    let (nt, np) = (20usize, 40usize);
    let mut observed = vec![0f64; nt * np];
    let mut rng = camsim_core::rng::seeded(seed);
    for _ in 0..n {
        if let Some(w) = sample(rng.gen(), rng.gen()) {
            let ct = (w.z as f64).clamp(-1.0, 1.0);
            let phi = (w.y as f64).atan2(w.x as f64).rem_euclid(2.0 * PI);
            let i = (((ct + 1.0) / 2.0 * nt as f64) as usize).min(nt - 1);
            let j = ((phi / (2.0 * PI) * np as f64) as usize).min(np - 1);
            observed[i * np + j] += 1.0;
        }
    }
    // Expected: n * integral of pdf over the cell (d omega = d cos theta d phi).
    let q = 8usize;
    let mut expected = vec![0f64; nt * np];
    for i in 0..nt {
        for j in 0..np {
            let (c0, c1) = (
                -1.0 + 2.0 * i as f64 / nt as f64,
                -1.0 + 2.0 * (i + 1) as f64 / nt as f64,
            );
            let (p0, p1) = (
                2.0 * PI * j as f64 / np as f64,
                2.0 * PI * (j + 1) as f64 / np as f64,
            );
            let mut s = 0.0;
            for a in 0..=q {
                for b in 0..=q {
                    let wa = if a == 0 || a == q {
                        1.0
                    } else if a % 2 == 1 {
                        4.0
                    } else {
                        2.0
                    };
                    let wb = if b == 0 || b == q {
                        1.0
                    } else if b % 2 == 1 {
                        4.0
                    } else {
                        2.0
                    };
                    let ct = c0 + (c1 - c0) * a as f64 / q as f64;
                    let ph = p0 + (p1 - p0) * b as f64 / q as f64;
                    let st = (1.0 - ct * ct).max(0.0).sqrt();
                    s += wa
                        * wb
                        * pdf(V3::new(
                            (st * ph.cos()) as f32,
                            (st * ph.sin()) as f32,
                            ct as f32,
                        ));
                }
            }
            expected[i * np + j] = n as f64 * s * (c1 - c0) * (p1 - p0) / (9.0 * (q * q) as f64);
        }
    }
    // Pool cells with small expectation (standard practice: expected >= 5).
    let (chi2, dof, pool_o, pool_e) = pooled_chi_square(&observed, &expected);
    if pool_e <= 5.0 {
        assert!(
            pool_o < 10.0,
            "{pool_o} samples where the pdf expects {pool_e}"
        );
    }
    (chi2, chi2_critical((dof - 1) as f64, 3.719))
}

#[test]
fn lambertian_sampling_passes_chi_square_against_its_pdf() {
    let bsdf: Bsdf<4> = Bsdf::Diffuse {
        reflectance: [0.5; 4],
    };
    for (k, wo) in [
        V3::new(0.0, 0.0, 1.0),
        V3::new(0.6, 0.0, 0.8),
        V3::new(0.3, 0.4, -0.866),
    ]
    .iter()
    .enumerate()
    {
        let wo = wo.normalize();
        let (chi2, crit) = chi_square_directions(
            |u0, u1| bsdf.sample(&wo, 0.5, u0, u1).map(|s| s.wi_local),
            |wi| bsdf.pdf(&wo, &wi) as f64,
            400_000,
            10 + k as u64,
        );
        eprintln!("lambertian wo {wo:?}: chi2 {chi2:.1}, critical (p = 1e-4) {crit:.1}");
        assert!(chi2 < crit, "chi-square {chi2} exceeds {crit}");
        // Weight f cos / pdf is the reflectance, and eval's pdf equals the sampling pdf.
        let s = bsdf.sample(&wo, 0.5, 0.3, 0.7).unwrap();
        assert_eq!(s.weight, [0.5; 4]);
        let (f, pdf) = bsdf.eval(&wo, &s.wi_local);
        assert!((pdf - s.pdf).abs() < 1e-6 && (f[0] - 0.5 / std::f32::consts::PI).abs() < 1e-7);
    }
}

#[test]
fn chi_square_test_rejects_a_wrong_pdf() {
    // The same samples against a uniform-hemisphere pdf must fail: the test can fail.
    let bsdf: Bsdf<1> = Bsdf::Diffuse { reflectance: [1.0] };
    let wo = V3::new(0.0, 0.0, 1.0);
    let (chi2, crit) = chi_square_directions(
        |u0, u1| bsdf.sample(&wo, 0.5, u0, u1).map(|s| s.wi_local),
        |wi| if wi.z > 0.0 { 1.0 / (2.0 * PI) } else { 0.0 },
        100_000,
        3,
    );
    assert!(chi2 > 10.0 * crit);
}

#[test]
fn sphere_cone_sampling_is_uniform_in_its_cone() {
    // Uniform in solid angle within the cone <=> (1 - cos theta)/(1 - cos theta_max) and
    // phi/(2 pi) are independent uniforms: chi-square on a 16 x 16 grid of those.
    for (center, radius) in [
        (V3::new(0.0, 0.0, 3.0), 1.2f32),
        (V3::new(0.0, 0.0, 50.0), 0.5),
    ] {
        let p = V3::splat(0.0);
        let (cos_max, sin2_max) = sphere_cone(p, center, radius).unwrap();
        let one_minus = one_minus_cos(cos_max, sin2_max) as f64;
        let k = 16usize;
        let n = 256_000usize;
        let mut counts = vec![0f64; k * k];
        let mut rng = camsim_core::rng::seeded(5);
        for _ in 0..n {
            let (q, nrm) =
                sample_sphere_cone(p, center, radius, cos_max, sin2_max, rng.gen(), rng.gen());
            // The point is on the sphere, its normal is outward and it faces p.
            assert!(((q - center).length() - radius).abs() < 1e-4 * center.length());
            assert!((nrm - (q - center) / radius).length() < 1e-3 && nrm.dot(p - q) >= -1e-4);
            let w = (q - p).normalize();
            // 1 - cos theta without cancellation: |w - z|^2 / 2.
            let omc =
                ((w.x as f64).powi(2) + (w.y as f64).powi(2) + (w.z as f64 - 1.0).powi(2)) / 2.0;
            let a = ((omc / one_minus * k as f64) as usize).min(k - 1);
            let phi = (w.y as f64).atan2(w.x as f64).rem_euclid(2.0 * PI);
            let b = ((phi / (2.0 * PI) * k as f64) as usize).min(k - 1);
            counts[a * k + b] += 1.0;
        }
        let e = n as f64 / (k * k) as f64;
        let chi2: f64 = counts.iter().map(|o| (o - e) * (o - e) / e).sum();
        let crit = chi2_critical((k * k - 1) as f64, 3.719);
        eprintln!(
            "sphere cone (r/d = {:.3}): chi2 {chi2:.1}, critical {crit:.1}",
            radius / center.length()
        );
        assert!(chi2 < crit, "chi-square {chi2} exceeds {crit}");
    }
}

/// Integral over the cap of directions within `cos_cap` of +z of `f`, by uniform sampling of
/// the cap (the cap must contain the support of `f`); mean and standard error.
fn integrate_over_cap(f: impl Fn(V3) -> f64, cos_cap: f64, n: usize, seed: u64) -> (f64, f64) {
    let mut rng = camsim_core::rng::seeded(seed);
    let solid = 2.0 * PI * (1.0 - cos_cap);
    let (mut s, mut s2) = (0.0, 0.0);
    for _ in 0..n {
        let ct = 1.0 - rng.gen::<f64>() * (1.0 - cos_cap);
        let st = (1.0 - ct * ct).max(0.0).sqrt();
        let ph = 2.0 * PI * rng.gen::<f64>();
        let w = V3::new((st * ph.cos()) as f32, (st * ph.sin()) as f32, ct as f32);
        let v = f(w) * solid;
        s += v;
        s2 += v * v;
    }
    let m = s / n as f64;
    (m, ((s2 / n as f64 - m * m) / n as f64).sqrt())
}

/// Mean of `f(w) / (1/(4 pi))` over uniform directions: the integral of `f` over the sphere,
/// with its standard error.
fn integrate_over_sphere(f: impl Fn(V3) -> f64, n: usize, seed: u64) -> (f64, f64) {
    let mut rng = camsim_core::rng::seeded(seed);
    let (mut s, mut s2) = (0.0, 0.0);
    for _ in 0..n {
        let w = uniform_sphere(rng.gen(), rng.gen());
        let v = f(w) / UNIFORM_SPHERE_PDF as f64;
        s += v;
        s2 += v * v;
    }
    let m = s / n as f64;
    (m, ((s2 / n as f64 - m * m) / n as f64).sqrt())
}

#[test]
fn sampling_pdfs_integrate_to_one() {
    let n = 400_000;
    // Cosine hemisphere.
    let (m, se) = integrate_over_sphere(|w| cosine_hemisphere_pdf(w.z) as f64, n, 1);
    eprintln!("cosine hemisphere pdf integral {m:.5} +- {se:.5}");
    assert!((m - 1.0).abs() < 4.5 * se && se < 0.005);

    // Triangle area sampling as a solid-angle density, pdf = d^2 / (cos A), seen from a point.
    let (p0, p1, p2) = (
        V3::new(-0.5, -0.3, 1.0),
        V3::new(0.7, -0.2, 1.3),
        V3::new(0.1, 0.8, 0.7),
    );
    let (e1, e2) = (p1 - p0, p2 - p0);
    let area = 0.5 * e1.cross(e2).length() as f64;
    let ng = e1.cross(e2).normalize();
    let o = V3::new(0.05, 0.1, 0.0);
    let (m, se) = integrate_over_sphere(
        |w| match intersect_triangle(o, w, p0, e1, e2, f32::INFINITY) {
            Some((t, _, _)) => (t as f64).powi(2) / ((ng.dot(w).abs() as f64) * area),
            None => 0.0,
        },
        n,
        2,
    );
    eprintln!("triangle solid-angle pdf integral {m:.5} +- {se:.5}");
    assert!((m - 1.0).abs() < 4.5 * se && se < 0.01);
    // And its samples land on the triangle uniformly: the mean barycentrics are (1/3, 1/3).
    let mut rng = camsim_core::rng::seeded(9);
    let (mut b1s, mut b2s) = (0.0, 0.0);
    for _ in 0..n {
        let (b1, b2) = uniform_triangle(rng.gen(), rng.gen());
        assert!(b1 >= 0.0 && b2 >= 0.0 && b1 + b2 <= 1.0 + 1e-6);
        b1s += b1 as f64;
        b2s += b2 as f64;
    }
    // Each barycentric has variance 1/18 under the uniform distribution.
    let tol = 4.5 * (1.0f64 / 18.0 / n as f64).sqrt();
    assert!((b1s / n as f64 - 1.0 / 3.0).abs() < tol && (b2s / n as f64 - 1.0 / 3.0).abs() < tol);

    // Sphere cone density over the directions that hit the sphere.
    // (a) a wide cone, (b) a cone narrower than 1.5 degrees (the small-angle branch), integrated
    // over a cap three times wider than the cone.
    for (c, r) in [
        (V3::new(0.0, 0.0, 2.0), 0.9f32),
        (V3::new(0.0, 0.0, 30.0), 0.3),
    ] {
        let (cos_max, sin2_max) = sphere_cone(V3::splat(0.0), c, r).unwrap();
        let pdf = cone_pdf(cos_max, sin2_max) as f64;
        let cap = (3.0 * (r as f64 / c.length() as f64).asin()).cos();
        let (m, se) = integrate_over_cap(
            |w| {
                if intersect_sphere(V3::splat(0.0), w, c, r, f32::INFINITY).is_some() {
                    pdf
                } else {
                    0.0
                }
            },
            cap,
            n,
            3,
        );
        eprintln!(
            "sphere cone pdf integral (r/d = {:.3}) {m:.5} +- {se:.5}",
            r / c.length()
        );
        assert!((m - 1.0).abs() < 4.5 * se && se < 0.01, "{m} +- {se}");
    }
}

#[test]
fn frame_round_trip() {
    let f = Frame::from_normal(V3::new(0.0, 0.0, -1.0));
    let v = V3::new(0.1, 0.2, 0.97).normalize();
    assert!((f.to_local(f.to_world(v)) - v).length() < 1e-6);
}
