//! Fresnel reflectance and the reflection / refraction directions (local shading frame, z = normal).

use crate::math::V3;

/// Unpolarised Fresnel reflectance of a dielectric interface (pbrt-v4 4th ed. §9.3.2, eq. 9.4-9.6,
/// `FrDielectric`). `cos_i` is the cosine of the incident direction with the normal of the side
/// whose relative index is `eta` (= n_transmitted / n_incident); a negative `cos_i` means the
/// light arrives from the other side, where the relative index is `1 / eta`. Total internal
/// reflection gives 1.
#[inline]
pub fn fr_dielectric(cos_i: f32, eta: f32) -> f32 {
    let mut cos_i = cos_i.clamp(-1.0, 1.0);
    let mut eta = eta;
    if cos_i < 0.0 {
        eta = 1.0 / eta;
        cos_i = -cos_i;
    }
    let sin2_i = 1.0 - cos_i * cos_i;
    let sin2_t = sin2_i / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).max(0.0).sqrt();
    let r_parl = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    (r_parl * r_parl + r_perp * r_perp) / 2.0
}

/// A complex number (just enough arithmetic for the conductor Fresnel equations).
#[derive(Debug, Clone, Copy)]
struct C {
    re: f64,
    im: f64,
}

impl C {
    fn add(self, o: C) -> C {
        C {
            re: self.re + o.re,
            im: self.im + o.im,
        }
    }
    fn sub(self, o: C) -> C {
        C {
            re: self.re - o.re,
            im: self.im - o.im,
        }
    }
    fn mul(self, o: C) -> C {
        C {
            re: self.re * o.re - self.im * o.im,
            im: self.re * o.im + self.im * o.re,
        }
    }
    fn scale(self, s: f64) -> C {
        C {
            re: self.re * s,
            im: self.im * s,
        }
    }
    fn div(self, o: C) -> C {
        let d = o.re * o.re + o.im * o.im;
        C {
            re: (self.re * o.re + self.im * o.im) / d,
            im: (self.im * o.re - self.re * o.im) / d,
        }
    }
    fn norm(self) -> f64 {
        self.re * self.re + self.im * self.im
    }
    /// Principal square root (pbrt-v4 `pstd::sqrt(complex)`).
    fn sqrt(self) -> C {
        let n = self.norm().sqrt();
        if n == 0.0 {
            return C { re: 0.0, im: 0.0 };
        }
        let t1 = (0.5 * (n + self.re.abs())).sqrt();
        let t2 = 0.5 * self.im / t1;
        if self.re >= 0.0 {
            C { re: t1, im: t2 }
        } else {
            C {
                re: t2.abs(),
                im: t1.copysign(self.im),
            }
        }
    }
}

/// Unpolarised Fresnel reflectance of a conductor with complex relative index `eta + i k`
/// (pbrt-v4 4th ed. §9.3.6, `FrComplex`: eq. 9.4-9.6 with complex arithmetic). `cos_i` in [0, 1].
#[inline]
pub fn fr_complex(cos_i: f32, eta: f32, k: f32) -> f32 {
    let cos_i = (cos_i as f64).clamp(0.0, 1.0);
    let e = C {
        re: eta as f64,
        im: k as f64,
    };
    let sin2_i = 1.0 - cos_i * cos_i;
    // sin^2 theta_t = sin^2 theta_i / eta^2 (Snell's law), cos theta_t = sqrt(1 - sin^2 theta_t).
    let sin2_t = C {
        re: sin2_i,
        im: 0.0,
    }
    .div(e.mul(e));
    let cos_t = C { re: 1.0, im: 0.0 }.sub(sin2_t).sqrt();
    let ci = C { re: cos_i, im: 0.0 };
    let r_parl = e.scale(cos_i).sub(cos_t).div(e.scale(cos_i).add(cos_t));
    let r_perp = ci.sub(e.mul(cos_t)).div(ci.add(e.mul(cos_t)));
    let r = (r_parl.norm() + r_perp.norm()) / 2.0;
    if r.is_finite() {
        r as f32
    } else {
        1.0
    }
}

/// Mirror `wo` about the unit vector `n`.
#[inline(always)]
pub fn reflect(wo: V3, n: V3) -> V3 {
    -wo + n * (2.0 * wo.dot(n))
}

/// Refract `wi` through an interface with normal `n` and relative index `eta` (transmitted over
/// incident, for light arriving on `n`'s side; pbrt-v4 §9.3, `Refract`). Returns the transmitted
/// direction and the relative index actually used (`1 / eta` when `wi` is on the other side), or
/// `None` at total internal reflection.
#[inline]
pub fn refract(wi: V3, n: V3, eta: f32) -> Option<(V3, f32)> {
    let mut cos_i = n.dot(wi);
    let (mut eta, mut n) = (eta, n);
    if cos_i < 0.0 {
        eta = 1.0 / eta;
        cos_i = -cos_i;
        n = -n;
    }
    let sin2_i = (1.0 - cos_i * cos_i).max(0.0);
    let sin2_t = sin2_i / (eta * eta);
    if sin2_t >= 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    Some((-wi / eta + n * (cos_i / eta - cos_t), eta))
}

/// Hemispherical (cosine-weighted) average of the dielectric Fresnel reflectance for light
/// arriving from the outside, `F_avg = 2 int_0^1 F(mu, eta) mu dmu` (Simpson's rule, 512
/// intervals). For light inside, energy conservation and reciprocity give
/// `1 - F_avg,int = (1 - F_avg) / eta^2` (d'Eon & Irving 2011, "A quantized-diffusion model", §5.1).
pub fn fresnel_hemispherical_average(eta: f32) -> f32 {
    let n = 512;
    let h = 1.0 / n as f64;
    let f = |mu: f64| fr_dielectric(mu as f32, eta) as f64 * mu;
    let mut s = f(0.0) + f(1.0);
    for i in 1..n {
        s += f(i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 };
    }
    (2.0 * s * h / 3.0) as f32
}

/// Probability that light leaving the diffuse base of a coating (cosine-distributed) comes back
/// to it: internal Fresnel reflection at the top (total beyond the critical angle) with the
/// layer's attenuation over the way up and down,
/// `R_ret = int_0^1 2 mu F(mu, 1 / eta) exp(-2 thickness / mu) dmu` (midpoint rule, 4096
/// points). `thickness` is an optical depth (pbrt-v4 `LayeredBxDF` transmittance
/// `exp(-thickness / |cos|)`). For thickness 0 this is the internal hemispherical Fresnel
/// average `F_int = 1 - (1 - F_avg) / eta^2`.
pub fn coating_return_probability(eta: f32, thickness: f32) -> f32 {
    let n = 4096;
    let s: f64 = (0..n)
        .map(|i| {
            let mu = (i as f64 + 0.5) / n as f64;
            2.0 * mu
                * fr_dielectric(mu as f32, 1.0 / eta) as f64
                * (-2.0 * thickness as f64 / mu).exp()
        })
        .sum();
    (s / n as f64) as f32
}
