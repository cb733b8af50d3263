//! Zernike polynomials in the OSA/ANSI convention (ANSI Z80.28-2017; Thibos, Applegate, Schwiegerling
//! & Webb, "Standards for reporting the optical aberrations of eyes", JOSA A 2002), as ISETCam's `wvf`
//! uses them: single index j, unit-RMS normalization over the unit disk.

/// OSA/ANSI single index j -> (n, m): n = ceil((-3 + sqrt(9 + 8 j)) / 2), m = 2 j - n (n + 2)
/// (Thibos et al. 2002, eq. 4). j = 0 piston, 1 (1,-1) vertical tilt, 2 (1,1) horizontal tilt,
/// 3 (2,-2) oblique astigmatism, 4 (2,0) defocus, 5 (2,2) astigmatism, 12 (4,0) spherical.
pub fn osa_to_nm(j: usize) -> (usize, i64) {
    // Integer search avoids floating-point ceil trouble at exact triangular numbers.
    let mut n = 0usize;
    while (n + 1) * (n + 2) / 2 <= j {
        n += 1;
    }
    let m = 2 * j as i64 - (n as i64) * (n as i64 + 2);
    (n, m)
}

/// (n, m) -> OSA/ANSI single index j = (n (n + 2) + m) / 2.
pub fn nm_to_osa(n: usize, m: i64) -> Option<usize> {
    if m.unsigned_abs() as usize > n || (n as i64 - m).rem_euclid(2) != 0 {
        return None;
    }
    Some(((n as i64 * (n as i64 + 2) + m) / 2) as usize)
}

/// One Zernike polynomial prepared for fast evaluation: Z = norm * R_n^|m|(rho) * (cos m theta
/// for m >= 0, sin |m| theta for m < 0), normalization sqrt(2 (n + 1) / (1 + delta_m0)) so that
/// (1/pi) * integral over the unit disk of Z^2 = 1 (unit RMS).
#[derive(Debug, Clone)]
pub struct Zernike {
    /// Radial order n.
    pub n: usize,
    /// Azimuthal frequency m (negative: sine term).
    pub m: i64,
    /// Coefficients of the radial polynomial: R(rho) = sum_k radial[k] * rho^(n - 2k).
    radial: Vec<f64>,
    norm: f64,
}

fn factorial(k: usize) -> f64 {
    (1..=k).fold(1.0, |a, b| a * b as f64)
}

impl Zernike {
    /// The polynomial with OSA index `j`.
    pub fn new(j: usize) -> Self {
        let (n, m) = osa_to_nm(j);
        let ma = m.unsigned_abs() as usize;
        // R_n^m(rho) = sum_{k=0}^{(n-m)/2} (-1)^k (n-k)! / (k! ((n+m)/2-k)! ((n-m)/2-k)!) rho^(n-2k)
        // (Born & Wolf, Principles of Optics, sec. 9.2.1).
        let radial = (0..=(n - ma) / 2)
            .map(|k| {
                let s = if k % 2 == 0 { 1.0 } else { -1.0 };
                s * factorial(n - k)
                    / (factorial(k) * factorial((n + ma) / 2 - k) * factorial((n - ma) / 2 - k))
            })
            .collect();
        let norm = if m == 0 {
            ((n + 1) as f64).sqrt()
        } else {
            (2.0 * (n + 1) as f64).sqrt()
        };
        Zernike { n, m, radial, norm }
    }

    /// Radial polynomial R_n^|m|(rho).
    pub fn radial(&self, rho: f64) -> f64 {
        let mut r = 0.0;
        for (k, c) in self.radial.iter().enumerate() {
            r += c * rho.powi((self.n - 2 * k) as i32);
        }
        r
    }

    /// Z_j at polar coordinates (rho, theta); rho is not restricted to the unit disk.
    pub fn eval(&self, rho: f64, theta: f64) -> f64 {
        let ang = if self.m >= 0 {
            (self.m as f64 * theta).cos()
        } else {
            ((-self.m) as f64 * theta).sin()
        };
        self.norm * self.radial(rho) * ang
    }

    /// Z_j from precomputed powers and harmonics of one point, [`PointTerms`]: no trigonometry
    /// (for many polynomials at one point, as a wavefront of many terms is evaluated).
    pub fn eval_at(&self, p: &PointTerms) -> f64 {
        let mut r = 0.0;
        for (k, c) in self.radial.iter().enumerate() {
            r += c * p.rho_pow[self.n - 2 * k];
        }
        let ma = self.m.unsigned_abs() as usize;
        let ang = if self.m >= 0 {
            p.cos_m[ma]
        } else {
            p.sin_m[ma]
        };
        self.norm * r * ang
    }
}

/// Highest radial order [`PointTerms`] holds (OSA index 230).
pub const MAX_ORDER: usize = 20;

/// Powers rho^k and harmonics cos(m theta), sin(m theta) (k, m <= [`MAX_ORDER`]) of one point,
/// the harmonics by the angle-addition recurrence cos((m+1) t) = cos(m t) cos t - sin(m t) sin t,
/// sin((m+1) t) = sin(m t) cos t + cos(m t) sin t from cos t = x / rho, sin t = y / rho.
pub struct PointTerms {
    rho_pow: [f64; MAX_ORDER + 1],
    cos_m: [f64; MAX_ORDER + 1],
    sin_m: [f64; MAX_ORDER + 1],
}

impl PointTerms {
    /// The point (rho cos t, rho sin t) given by its polar radius `rho` and the direction (x, y)
    /// of its angle (any length; (0, 0) counts as t = 0, as `atan2(0, 0)`), up to order `order`.
    pub fn new(rho: f64, x: f64, y: f64, order: usize) -> Self {
        let order = order.min(MAX_ORDER);
        let len = x.hypot(y);
        let (c, s) = if len > 0.0 {
            (x / len, y / len)
        } else {
            (1.0, 0.0)
        };
        let mut t = PointTerms {
            rho_pow: [0.0; MAX_ORDER + 1],
            cos_m: [0.0; MAX_ORDER + 1],
            sin_m: [0.0; MAX_ORDER + 1],
        };
        t.rho_pow[0] = 1.0;
        t.cos_m[0] = 1.0;
        for k in 1..=order {
            t.rho_pow[k] = t.rho_pow[k - 1] * rho;
            t.cos_m[k] = t.cos_m[k - 1] * c - t.sin_m[k - 1] * s;
            t.sin_m[k] = t.sin_m[k - 1] * c + t.cos_m[k - 1] * s;
        }
        t
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eval_at_matches_eval_for_every_term_up_to_order_20() {
        for &(rho, th) in &[
            (0.0f64, 0.0f64),
            (0.3, 0.7),
            (0.95, -2.9),
            (1.0, 3.0),
            (0.6, 1.2),
        ] {
            let p = PointTerms::new(rho, th.cos(), th.sin(), MAX_ORDER);
            for j in 0..231 {
                let z = Zernike::new(j);
                let (a, b) = (z.eval(rho, th), z.eval_at(&p));
                assert!(
                    (a - b).abs() <= 1e-9 * (1.0 + a.abs()),
                    "j {j} rho {rho} theta {th}: {a} against {b}"
                );
            }
        }
    }

    #[test]
    fn osa_index_follows_ansi_z80_28() {
        let table: [(usize, (usize, i64)); 13] = [
            (0, (0, 0)),
            (1, (1, -1)),
            (2, (1, 1)),
            (3, (2, -2)),
            (4, (2, 0)),
            (5, (2, 2)),
            (6, (3, -3)),
            (7, (3, -1)),
            (8, (3, 1)),
            (9, (3, 3)),
            (10, (4, -4)),
            (12, (4, 0)),
            (14, (4, 4)),
        ];
        for (j, nm) in table {
            assert_eq!(osa_to_nm(j), nm, "j = {j}");
            assert_eq!(nm_to_osa(nm.0, nm.1), Some(j));
        }
        for j in 0..200 {
            let (n, m) = osa_to_nm(j);
            assert_eq!(nm_to_osa(n, m), Some(j));
        }
        assert_eq!(nm_to_osa(2, 1), None);
    }

    #[test]
    fn known_closed_forms() {
        // Defocus sqrt(3)(2 rho^2 - 1), spherical sqrt(5)(6 rho^4 - 6 rho^2 + 1), vertical tilt 2 rho sin.
        let (rho, th) = (0.7f64, 0.3f64);
        assert!(
            (Zernike::new(4).eval(rho, th) - 3f64.sqrt() * (2.0 * rho * rho - 1.0)).abs() < 1e-12
        );
        let r2 = rho * rho;
        assert!(
            (Zernike::new(12).eval(rho, th) - 5f64.sqrt() * (6.0 * r2 * r2 - 6.0 * r2 + 1.0)).abs()
                < 1e-12
        );
        assert!((Zernike::new(1).eval(rho, th) - 2.0 * rho * th.sin()).abs() < 1e-12);
        assert!(
            (Zernike::new(5).eval(rho, th) - 6f64.sqrt() * r2 * (2.0 * th).cos()).abs() < 1e-12
        );
    }

    #[test]
    fn orthonormal_over_the_unit_disk() {
        // (1/pi) int_0^1 int_0^2pi Z_i Z_j rho drho dtheta = delta_ij. Gauss-Legendre-free check:
        // midpoint rule in rho (400 rings) and uniform theta (256, exact for trig up to degree 255).
        let nj = 21;
        let zs: Vec<Zernike> = (0..nj).map(Zernike::new).collect();
        let (nr, nt) = (400, 256);
        let mut gram = vec![0.0f64; nj * nj];
        let mut vals = vec![0.0f64; nj];
        for ir in 0..nr {
            let rho = (ir as f64 + 0.5) / nr as f64;
            for it in 0..nt {
                let th = 2.0 * std::f64::consts::PI * it as f64 / nt as f64;
                for (k, z) in zs.iter().enumerate() {
                    vals[k] = z.eval(rho, th);
                }
                let w = rho * (1.0 / nr as f64) * (2.0 * std::f64::consts::PI / nt as f64)
                    / std::f64::consts::PI;
                for a in 0..nj {
                    for b in 0..nj {
                        gram[a * nj + b] += w * vals[a] * vals[b];
                    }
                }
            }
        }
        for a in 0..nj {
            for b in 0..nj {
                let want = if a == b { 1.0 } else { 0.0 };
                // Midpoint rule error ~ n^2 / nr^2 for degree-n polynomials: < 2e-4 here.
                assert!(
                    (gram[a * nj + b] - want).abs() < 2e-3,
                    "<Z{a}, Z{b}> = {}",
                    gram[a * nj + b]
                );
            }
        }
    }
}
