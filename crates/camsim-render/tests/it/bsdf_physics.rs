//! The BSDFs against their own densities and against physics: chi-square goodness-of-fit of
//! every BSDF's `sample` against its `pdf`, sample weights equal `f cos / pdf`, reciprocity,
//! energy conservation (directional albedo <= 1), the conductor Fresnel equations against the
//! closed real-arithmetic form (Born & Wolf), the rough -> smooth limit, and the single-scatter
//! energy loss of rough microfacet reflection (a bound that grows with roughness). The layered
//! (coated) BSDFs, whose `f` and `pdf` are stochastic estimates, are tested in `layered_bsdf.rs`.

use camsim_render::bsdf::fresnel::{fr_complex, fr_dielectric};
use camsim_render::bsdf::{Bsdf, TrowbridgeReitz};
use camsim_render::math::V3;
use rand::Rng;
use std::f64::consts::PI;

use crate::common;
use common::{chi2_critical, pooled_chi_square};

fn tr(ax: f32, ay: f32) -> TrowbridgeReitz {
    TrowbridgeReitz {
        alpha_x: ax,
        alpha_y: ay,
    }
}

/// Direction with polar cosine `cos_theta` and azimuth `phi`.
fn dir(cos_theta: f64, phi: f64) -> V3 {
    let s = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
    V3::new(
        (s * phi.cos()) as f32,
        (s * phi.sin()) as f32,
        cos_theta as f32,
    )
}

/// Chi-square test of `bsdf.sample(wo)` against `bsdf.pdf(wo, .)` on a (cos theta, phi) grid over
/// the whole sphere (pbrt-v4's and Mitsuba's BSDF test method): expected counts integrate the pdf
/// over each cell (midpoint rule, 24 x 24 points per cell); delta samples fall outside
/// every cell, as the pdf has no mass for them. Cells expecting < 5 are pooled. Returns
/// `(chi2, critical value at p = 1e-4)`.
fn chi_square(bsdf: &Bsdf<1>, wo: V3, n: usize, seed: u64) -> (f64, f64) {
    chi_square_with(bsdf, bsdf, wo, n, seed)
}

/// [`chi_square`] with samples from `sampler` and the pdf of `density`.
fn chi_square_with(
    sampler: &Bsdf<1>,
    density: &Bsdf<1>,
    wo: V3,
    n: usize,
    seed: u64,
) -> (f64, f64) {
    let (nt, np) = (20usize, 40usize);
    let mut observed = vec![0f64; nt * np];
    let mut rng = camsim_core::rng::seeded(seed);
    for _ in 0..n {
        if let Some(s) = sampler.sample(&wo, rng.gen(), rng.gen(), rng.gen()) {
            if s.specular {
                continue;
            }
            let w = s.wi_local;
            let ct = (w.z as f64).clamp(-1.0, 1.0);
            let phi = (w.y as f64).atan2(w.x as f64).rem_euclid(2.0 * PI);
            let i = (((ct + 1.0) / 2.0 * nt as f64) as usize).min(nt - 1);
            let j = ((phi / (2.0 * PI) * np as f64) as usize).min(np - 1);
            observed[i * np + j] += 1.0;
        }
    }
    // Midpoint rule, q x q points per cell: robust where the pdf has edges (the rough
    // dielectric's discarded back-facing microfacets).
    let q = 24usize;
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
            for a in 0..q {
                for b in 0..q {
                    let ct = c0 + (c1 - c0) * (a as f64 + 0.5) / q as f64;
                    let ph = p0 + (p1 - p0) * (b as f64 + 0.5) / q as f64;
                    s += density.pdf(&wo, &dir(ct, ph)) as f64;
                }
            }
            expected[i * np + j] = n as f64 * s * (c1 - c0) * (p1 - p0) / (q * q) as f64;
        }
    }
    let (chi2, dof, pool_o, pool_e) = pooled_chi_square(&observed, &expected);
    if pool_e <= 5.0 {
        assert!(
            pool_o < 10.0 + 3.0 * pool_e,
            "{pool_o} samples where the pdf expects {pool_e}"
        );
    }
    assert!(dof > 5, "too few cells ({dof}) for a meaningful test");
    (chi2, chi2_critical((dof - 1) as f64, 3.719))
}

/// Every configuration the sampling tests run: (name, BSDF).
fn bsdfs() -> Vec<(String, Bsdf<1>)> {
    let mut v: Vec<(String, Bsdf<1>)> = vec![
        ("diffuse".into(), Bsdf::Diffuse { reflectance: [0.7] }),
        (
            "diffuse transmission".into(),
            Bsdf::DiffuseTransmission { r: [0.3], t: [0.6] },
        ),
    ];
    for (ax, ay) in [(0.1, 0.1), (0.3, 0.3), (0.7, 0.7), (0.1, 0.4)] {
        v.push((
            format!("conductor alpha ({ax}, {ay})"),
            Bsdf::Conductor {
                eta: [0.2],
                k: [3.0],
                distrib: tr(ax, ay),
            },
        ));
    }
    for (eta, a) in [(1.5, 0.15), (1.5, 0.4), (1.0 / 1.5, 0.3), (1.33, 0.8)] {
        v.push((
            format!("rough dielectric eta {eta:.3} alpha {a}"),
            Bsdf::Dielectric {
                eta,
                distrib: tr(a, a),
            },
        ));
    }
    v
}

const INCIDENT_COS: [f64; 3] = [0.95, 0.55, 0.2];

#[test]
fn every_bsdf_samples_its_pdf_chi_square() {
    let mut seed = 1;
    for (name, b) in bsdfs() {
        for ct in INCIDENT_COS {
            let wo = dir(ct, 0.7);
            seed += 1;
            let (chi2, crit) = chi_square(&b, wo, 200_000, seed);
            eprintln!("{name}, cos theta_o {ct}: chi2 {chi2:.1}, critical (p = 1e-4) {crit:.1}");
            assert!(
                chi2 < crit,
                "{name}, cos theta_o {ct}: chi-square {chi2:.1} exceeds {crit:.1}"
            );
        }
    }
}

/// The test detects a sampler that does not match its pdf: a conductor whose pdf claims a
/// narrower lobe than the one sampled.
#[test]
fn chi_square_rejects_a_mismatched_pdf() {
    // Sample with alpha 0.3, evaluate the pdf of alpha 0.25 (normalised, but the wrong shape).
    let sampled = Bsdf::<1>::Conductor {
        eta: [0.2],
        k: [3.0],
        distrib: tr(0.3, 0.3),
    };
    let claimed = Bsdf::<1>::Conductor {
        eta: [0.2],
        k: [3.0],
        distrib: tr(0.25, 0.25),
    };
    let (chi2, crit) = chi_square_with(&sampled, &claimed, dir(0.8, 0.3), 200_000, 5);
    eprintln!("mismatched pdf: chi2 {chi2:.0} vs critical {crit:.0}");
    assert!(
        chi2 > 5.0 * crit,
        "the chi-square test failed to notice a wrong pdf ({chi2} vs {crit})"
    );
}

#[test]
fn sample_weights_and_pdfs_agree_with_eval() {
    let mut rng = camsim_core::rng::seeded(11);
    for (name, b) in bsdfs() {
        for ct in INCIDENT_COS {
            let wo = dir(ct, 2.1);
            let mut checked = 0;
            for _ in 0..2000 {
                let Some(s) = b.sample(&wo, rng.gen(), rng.gen(), rng.gen()) else {
                    continue;
                };
                if s.specular {
                    continue;
                }
                let (f, pdf) = b.eval(&wo, &s.wi_local);
                let want = f[0] * s.wi_local.z.abs() / pdf;
                assert!(
                    (pdf - s.pdf).abs() <= 2e-3 * pdf.max(1e-3),
                    "{name}: pdf {} from sample vs {pdf}",
                    s.pdf
                );
                assert!(
                    (s.weight[0] - want).abs() <= 2e-3 * want.max(1e-3),
                    "{name}: weight {} vs f cos / pdf {want}",
                    s.weight[0]
                );
                checked += 1;
            }
            assert!(checked > 100, "{name}: only {checked} non-specular samples");
        }
    }
}

#[test]
fn reflection_is_reciprocal() {
    let mut rng = camsim_core::rng::seeded(3);
    let reflecting: Vec<(String, Bsdf<1>)> = bsdfs()
        .into_iter()
        .filter(|(n, _)| !n.contains("eta 0.667"))
        .collect();
    for (name, b) in reflecting {
        let mut compared = 0;
        for _ in 0..3000 {
            let wo = dir(rng.gen_range(0.05..1.0), rng.gen_range(0.0..2.0 * PI));
            let wi = dir(rng.gen_range(0.05..1.0), rng.gen_range(0.0..2.0 * PI));
            let (a, _) = b.eval(&wo, &wi);
            let (c, _) = b.eval(&wi, &wo);
            if a[0] > 0.0 || c[0] > 0.0 {
                compared += 1;
            }
            assert!(
                (a[0] - c[0]).abs() <= 1e-4 * a[0].max(c[0]).max(1e-3),
                "{name}: f(wo, wi) = {} but f(wi, wo) = {}",
                a[0],
                c[0]
            );
        }
        assert!(compared > 100, "{name}: only {compared} non-zero pairs");
    }
}

/// Directional albedo by sampling: mean of `weight` (times `eta'^2` for transmission, which
/// turns radiance weights into energy: pbrt-v4 radiance mode scales by 1/eta'^2), with its
/// standard error.
fn albedo(b: &Bsdf<1>, wo: V3, n: usize, seed: u64) -> (f64, f64) {
    let mut rng = camsim_core::rng::seeded(seed);
    let (mut s, mut s2) = (0.0, 0.0);
    for _ in 0..n {
        if let Some(x) = b.sample(&wo, rng.gen(), rng.gen(), rng.gen()) {
            let w = x.weight[0] as f64 * (x.eta as f64).powi(2);
            s += w;
            s2 += w * w;
        }
    }
    let m = s / n as f64;
    (m, ((s2 / n as f64 - m * m).max(0.0) / n as f64).sqrt())
}

#[test]
fn no_bsdf_creates_energy() {
    let mut all = bsdfs();
    // Extremes: white bases, a thin coating, a lossless conductor, glass from both sides.
    all.push((
        "diffuse transmission white".into(),
        Bsdf::DiffuseTransmission { r: [0.5], t: [0.5] },
    ));
    all.push((
        "smooth glass".into(),
        Bsdf::Dielectric {
            eta: 1.5,
            distrib: tr(0.0, 0.0),
        },
    ));
    all.push((
        "smooth glass, inside".into(),
        Bsdf::Dielectric {
            eta: 1.0 / 1.5,
            distrib: tr(0.0, 0.0),
        },
    ));
    all.push(("thin glass".into(), Bsdf::ThinDielectric { eta: 1.5 }));
    for (name, b) in all {
        for ct in [1.0, 0.7, 0.3, 0.05] {
            let (m, se) = albedo(&b, dir(ct, 0.4), 100_000, 17);
            eprintln!("{name}, cos theta_o {ct}: albedo {m:.4} +- {se:.4}");
            assert!(
                m <= 1.0 + 4.0 * se + 1e-4,
                "{name} at cos {ct}: albedo {m} > 1"
            );
        }
    }
}

#[test]
fn lossless_interfaces_conserve_energy_exactly() {
    // Smooth glass and a thin slab: R + T = 1 at every angle (pbrt-v4 eq. 9.5 with T = 1 - R),
    // from either side, including total internal reflection.
    for b in [
        Bsdf::<1>::Dielectric {
            eta: 1.5,
            distrib: tr(0.0, 0.0),
        },
        Bsdf::<1>::Dielectric {
            eta: 1.0 / 1.5,
            distrib: tr(0.0, 0.0),
        },
        Bsdf::<1>::ThinDielectric { eta: 1.7 },
    ] {
        for ct in [1.0, 0.6, 0.2, 0.02] {
            let (m, se) = albedo(&b, dir(ct, 0.1), 20_000, 4);
            assert!(
                (m - 1.0).abs() < 1e-5 && se < 1e-5,
                "{b:?} at cos {ct}: albedo {m} +- {se}"
            );
        }
    }
}

/// Fresnel reflectance of a conductor in real arithmetic (Born & Wolf, "Principles of Optics",
/// §14.2; the form of pbrt-v3's `FrConductor`): an independent check of the complex-arithmetic
/// `fr_complex`.
fn fresnel_conductor_closed_form(cos_i: f64, eta: f64, k: f64) -> f64 {
    let c2 = cos_i * cos_i;
    let s2 = 1.0 - c2;
    let t0 = eta * eta - k * k - s2;
    let a2b2 = (t0 * t0 + 4.0 * eta * eta * k * k).sqrt();
    let t1 = a2b2 + c2;
    let a = (0.5 * (a2b2 + t0)).max(0.0).sqrt();
    let t2 = 2.0 * cos_i * a;
    let rs = (t1 - t2) / (t1 + t2);
    let t3 = c2 * a2b2 + s2 * s2;
    let t4 = t2 * s2;
    let rp = rs * (t3 - t4) / (t3 + t4);
    0.5 * (rp + rs)
}

#[test]
fn smooth_conductor_reflects_the_fresnel_closed_form() {
    // Copper at 600 nm and gold at 500 nm (Johnson & Christy 1972, interpolated), silver, and
    // an artificial absorber.
    for (eta, k) in [(0.30, 3.20), (1.00, 1.85), (0.05, 3.86), (2.5, 0.5)] {
        // Normal incidence: ((n-1)^2 + k^2) / ((n+1)^2 + k^2).
        let r0 = ((eta - 1.0f64).powi(2) + k * k) / ((eta + 1.0f64).powi(2) + k * k);
        assert!((fr_complex(1.0, eta as f32, k as f32) as f64 - r0).abs() < 1e-5);
        let b = Bsdf::<1>::Conductor {
            eta: [eta as f32],
            k: [k as f32],
            distrib: tr(0.0, 0.0),
        };
        for ct in [1.0, 0.8, 0.5, 0.2, 0.05] {
            let s = b.sample(&dir(ct, 1.0), 0.5, 0.3, 0.3).unwrap();
            assert!(s.specular && (s.wi_local.z as f64 - ct).abs() < 1e-6);
            let want = fresnel_conductor_closed_form(ct, eta, k);
            assert!(
                (s.weight[0] as f64 - want).abs() < 2e-5,
                "eta {eta} k {k} cos {ct}: {} vs {want}",
                s.weight[0]
            );
        }
    }
}

#[test]
fn dielectric_fresnel_matches_normal_incidence_and_brewster() {
    let eta = 1.5f32;
    assert!((fr_dielectric(1.0, eta) - 0.04).abs() < 1e-6);
    // At Brewster's angle the p-polarised reflectance vanishes: F = R_s / 2.
    let tb = eta.atan();
    let (ci, si) = (tb.cos(), tb.sin());
    let ct = (1.0 - (si / eta).powi(2)).sqrt();
    let rs = ((ci - eta * ct) / (ci + eta * ct)).powi(2);
    assert!((fr_dielectric(ci, eta) - rs / 2.0).abs() < 1e-6);
    // Total internal reflection from inside beyond the critical angle.
    assert_eq!(fr_dielectric(-0.5, eta), 1.0);
}

/// Directional albedo of a Fresnel-1 isotropic GGX surface without multiple scattering,
/// `E(mu_o) = int D(wh) G2(wo, wi) / (4 mu_o mu_i) mu_i dwi`, by midpoint quadrature over
/// (cos theta_i, phi_i), written independently from the crate's code with the isotropic closed
/// forms D = alpha^2 / (pi cos^4 (alpha^2 + tan^2)^2) and
/// Lambda = (sqrt(1 + alpha^2 tan^2) - 1) / 2 (Walter et al. 2007 eq. 33 and 72).
fn ggx_albedo_quadrature(mu_o: f64, alpha: f64) -> f64 {
    let a2 = alpha * alpha;
    let d = |c: f64| {
        let t2 = (1.0 - c * c) / (c * c);
        a2 / (PI * c.powi(4) * (a2 + t2).powi(2))
    };
    let lambda = |c: f64| ((1.0 + a2 * (1.0 - c * c) / (c * c)).sqrt() - 1.0) / 2.0;
    let so = (1.0 - mu_o * mu_o).sqrt();
    let (nc, np) = (600usize, 600usize);
    let mut sum = 0.0;
    for i in 0..nc {
        let mu_i = (i as f64 + 0.5) / nc as f64;
        let si = (1.0 - mu_i * mu_i).sqrt();
        let g2 = 1.0 / (1.0 + lambda(mu_o) + lambda(mu_i));
        for j in 0..np {
            let phi = PI * (j as f64 + 0.5) / np as f64; // symmetric in phi: integrate [0, pi], double
            let h = [so + si * phi.cos(), si * phi.sin(), mu_o + mu_i];
            let hz = h[2] / (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt();
            sum += d(hz) * g2 / (4.0 * mu_o);
        }
    }
    2.0 * sum * (1.0 / nc as f64) * (PI / np as f64)
}

#[test]
fn perfect_conductor_furnace_and_single_scatter_loss() {
    // eta = 0, k = 1e4: Fresnel = 1 at every angle (a perfect mirror material).
    for ct in [1.0f32, 0.5, 0.1, 0.01] {
        assert!((fr_complex(ct, 0.0, 1e4) - 1.0).abs() < 1e-3);
    }
    // Smooth: all energy returns, exactly.
    for ct in [1.0, 0.5, 0.05] {
        let b = Bsdf::<1>::Conductor {
            eta: [0.0],
            k: [1e4],
            distrib: tr(0.0, 0.0),
        };
        let (m, _) = albedo(&b, dir(ct, 0.2), 1000, 9);
        assert!((m - 1.0).abs() < 1e-4, "smooth mirror albedo {m}");
    }
    // Rough: the single-scattering microfacet model loses the light that would scatter again
    // between microfacets (Heitz et al. 2016, "Multiple-scattering microfacet BSDFs with the
    // Smith model"; Kulla & Conty 2017): the sampled albedo must equal the independent
    // quadrature of the same model, stay <= 1, and the loss grows with roughness at every angle.
    let mut prev_loss = [0.0f64; 3];
    for a in [0.05f32, 0.2, 0.5, 1.0] {
        for (k, ct) in [0.9, 0.5, 0.2].into_iter().enumerate() {
            let b = Bsdf::<1>::Conductor {
                eta: [0.0],
                k: [1e4],
                distrib: tr(a, a),
            };
            let (m, se) = albedo(&b, dir(ct, 0.2), 200_000, 9);
            let want = if a >= 0.2 {
                ggx_albedo_quadrature(ct, a as f64)
            } else {
                f64::NAN
            };
            eprintln!("perfect conductor alpha {a}, cos theta_o {ct}: albedo {m:.4} +- {se:.4}, quadrature {want:.4} (loss {:.4})", 1.0 - m);
            assert!(m <= 1.0 + 4.0 * se + 1e-4, "albedo {m} > 1");
            if want.is_finite() {
                assert!(
                    (m - want).abs() < 4.5 * se + 2e-3 * want,
                    "alpha {a}, cos {ct}: albedo {m} vs quadrature {want}"
                );
            }
            let loss = 1.0 - m;
            if a == 0.05 && ct == 0.9 {
                // Nearly smooth, near normal incidence: almost no loss (measured 0.3 %).
                assert!(loss < 0.005, "alpha 0.05 loses {loss}");
            }
            assert!(
                loss > prev_loss[k] - 4.0 * se,
                "loss {loss} at alpha {a} is below the loss at smaller roughness {}",
                prev_loss[k]
            );
            prev_loss[k] = loss;
        }
    }
}

#[test]
fn nearly_smooth_conductor_albedo_equals_the_smooth_one() {
    // alpha = 1e-3 is the smallest alpha treated as rough (pbrt-v4 `EffectivelySmooth` is
    // alpha < 1e-3): its directional albedo must equal the mirror's Fresnel reflectance.
    for (eta, k) in [(0.30f32, 3.20f32), (1.00, 1.85)] {
        let rough = Bsdf::<1>::Conductor {
            eta: [eta],
            k: [k],
            distrib: tr(1e-3, 1e-3),
        };
        assert!(!rough.is_delta());
        for ct in [0.95, 0.6, 0.25] {
            let (m, se) = albedo(&rough, dir(ct, 0.3), 50_000, 21);
            let want = fr_complex(ct as f32, eta, k) as f64;
            eprintln!("alpha 1e-3 conductor ({eta}, {k}) cos {ct}: albedo {m:.5} +- {se:.5}, smooth {want:.5}");
            assert!((m - want).abs() < 2e-3 * want, "{m} vs smooth {want}");
        }
    }
}
