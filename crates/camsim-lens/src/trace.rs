//! Sequential ray tracing through a [`Lens`] and its paraxial (ABCD) first-order properties.

use crate::prescription::{Lens, Surface};

/// A ray: origin (mm) and unit direction, in lens coordinates (optical axis z, first vertex at
/// z = 0, object side at z < 0).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ray {
    /// Origin, mm.
    pub origin_mm: [f64; 3],
    /// Unit direction.
    pub direction: [f64; 3],
}

impl Ray {
    /// A ray from `origin_mm` along `direction` (normalized here).
    pub fn new(origin_mm: [f64; 3], direction: [f64; 3]) -> Ray {
        Ray {
            origin_mm,
            direction: normalize(direction),
        }
    }

    /// The point at parameter `t` (mm along the ray).
    pub fn at(&self, t: f64) -> [f64; 3] {
        [
            self.origin_mm[0] + t * self.direction[0],
            self.origin_mm[1] + t * self.direction[1],
            self.origin_mm[2] + t * self.direction[2],
        ]
    }

    /// Where the ray meets the plane z = `z_mm` (`None` when parallel to it).
    pub fn at_z(&self, z_mm: f64) -> Option<[f64; 3]> {
        if self.direction[2].abs() < 1e-300 {
            return None;
        }
        Some(self.at((z_mm - self.origin_mm[2]) / self.direction[2]))
    }
}

/// Why a ray did not pass the lens.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Blocked {
    /// It missed surface `i` (0-based) or met it outside its semi-aperture (the stop included).
    Aperture(usize),
    /// Total internal reflection at surface `i`.
    TotalInternalReflection(usize),
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn normalize(a: [f64; 3]) -> [f64; 3] {
    let l = dot(a, a).sqrt();
    [a[0] / l, a[1] / l, a[2] / l]
}

/// Refract unit direction `d` at unit normal `n` (either orientation) from index `n1` into `n2`:
/// vector Snell's law t = eta d + (eta cos_i - cos_t) n, eta = n1 / n2, with n facing the
/// incident ray (Heckbert's form; pbrt-v4 4th ed. sec. 9.3, `Refract`). `None` on total
/// internal reflection.
pub fn refract(d: [f64; 3], n: [f64; 3], n1: f64, n2: f64) -> Option<[f64; 3]> {
    let mut n = n;
    let mut cos_i = -dot(d, n);
    if cos_i < 0.0 {
        n = [-n[0], -n[1], -n[2]];
        cos_i = -cos_i;
    }
    let eta = n1 / n2;
    let sin2_t = eta * eta * (1.0 - cos_i * cos_i).max(0.0);
    if sin2_t > 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    Some(normalize([
        eta * d[0] + (eta * cos_i - cos_t) * n[0],
        eta * d[1] + (eta * cos_i - cos_t) * n[1],
        eta * d[2] + (eta * cos_i - cos_t) * n[2],
    ]))
}

/// Mirror unit direction `d` at unit normal `n` (either orientation): r = d - 2 (d . n) n (the
/// law of reflection in vector form; pbrt-v4 4th ed. sec. 9.3, `Reflect`).
pub fn reflect(d: [f64; 3], n: [f64; 3]) -> [f64; 3] {
    let k = 2.0 * dot(d, n);
    normalize([d[0] - k * n[0], d[1] - k * n[1], d[2] - k * n[2]])
}

/// Intersection of `ray` with surface `s` whose vertex is at z = `z0`: the parameter t and the
/// unit surface normal (pointing toward +z). Newton's method on
/// g(t) = z(t) - z0 - sag(r(t)) from the vertex plane, after an exact start for spheres.
pub(crate) fn intersect(s: &Surface, z0: f64, ray: &Ray) -> Option<(f64, [f64; 3])> {
    let o = ray.origin_mm;
    let d = ray.direction;
    let c = s.curvature_per_mm();
    // Start: the vertex plane, or for a sphere the exact near intersection.
    let mut t = if c == 0.0 {
        if d[2].abs() < 1e-300 {
            return None;
        }
        (z0 - o[2]) / d[2]
    } else {
        // Sphere centre at z0 + R: |o + t d - C|^2 = R^2; the vertex side root.
        let r = s.radius_mm;
        let oc = [o[0], o[1], o[2] - (z0 + r)];
        let b = dot(oc, d);
        let cc = dot(oc, oc) - r * r;
        let disc = b * b - cc;
        if disc < 0.0 {
            if s.is_spherical() {
                return None;
            }
            (z0 - o[2]) / d[2]
        } else {
            let sq = disc.sqrt();
            // The root on the vertex's hemisphere: z - (z0 + R) has the sign of -R.
            let (t1, t2) = (-b - sq, -b + sq);
            let on_vertex_side = |t: f64| (o[2] + t * d[2] - (z0 + r)) * -r.signum() > 0.0;
            if on_vertex_side(t1) {
                t1
            } else {
                t2
            }
        }
    };
    if !s.is_spherical() || c == 0.0 {
        for _ in 0..60 {
            let p = ray.at(t);
            let r = (p[0] * p[0] + p[1] * p[1]).sqrt();
            let sag = s.sag_mm(r)?;
            let g = p[2] - z0 - sag;
            let slope = s.sag_slope(r)?;
            let dr_dt = if r > 0.0 {
                (p[0] * d[0] + p[1] * d[1]) / r
            } else {
                0.0
            };
            let dg = d[2] - slope * dr_dt;
            if dg.abs() < 1e-300 {
                return None;
            }
            let step = g / dg;
            t -= step;
            if step.abs() < 1e-13 {
                break;
            }
        }
    }
    let p = ray.at(t);
    let r = (p[0] * p[0] + p[1] * p[1]).sqrt();
    let g = p[2] - z0 - s.sag_mm(r)?;
    if g.abs() > 1e-9 || !t.is_finite() {
        return None;
    }
    let slope = s.sag_slope(r)?;
    let n = if r > 0.0 {
        normalize([-slope * p[0] / r, -slope * p[1] / r, 1.0])
    } else {
        [0.0, 0.0, 1.0]
    };
    Some((t, n))
}

/// A ray traced through the lens with its optical path ([`Lens::trace_forward_path`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TracedPath {
    /// The ray leaving the last surface (image space).
    pub ray: Ray,
    /// Optical path from the input ray's origin to the point on the last surface, mm.
    pub optical_path_mm: f64,
    /// Where the ray crossed the stop plane, mm.
    pub stop_point_mm: [f64; 3],
}

/// Paraxial (first-order) properties of a lens at one wavelength.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Paraxial {
    /// System matrix [[A, B], [C, D]] from just before the first vertex to just after the last,
    /// acting on (height mm, reduced angle n u).
    pub abcd: [[f64; 2]; 2],
    /// Effective focal length -1 / C, mm (object and image space in air).
    pub efl_mm: f64,
    /// Back focal distance -A / C: from the last vertex to the rear focal point, mm.
    pub bfd_mm: f64,
    /// Front focal distance D / C: from the first vertex to the front focal point, mm (< 0: in
    /// front of the lens).
    pub ffd_mm: f64,
}

impl Lens {
    /// Paraxial ray-transfer (ABCD) matrix and focal properties at `wavelength_nm`: per surface
    /// a refraction [[1, 0], [-(n' - n) c, 1]] and per gap a transfer [[1, t / n'], [0, 1]] on
    /// (y, n u) (Hecht, Optics, 5th ed., sec. 6.2 "matrix methods"), with the paraxial curvature
    /// of each surface (vertex curvature plus twice the r^2 aspheric term).
    pub fn paraxial(&self, wavelength_nm: f64) -> Paraxial {
        let mut m = [[1.0, 0.0], [0.0, 1.0]];
        let mul = |a: [[f64; 2]; 2], b: [[f64; 2]; 2]| {
            [
                [
                    a[0][0] * b[0][0] + a[0][1] * b[1][0],
                    a[0][0] * b[0][1] + a[0][1] * b[1][1],
                ],
                [
                    a[1][0] * b[0][0] + a[1][1] * b[1][0],
                    a[1][0] * b[0][1] + a[1][1] * b[1][1],
                ],
            ]
        };
        let last = self.surfaces.len() - 1;
        for (i, s) in self.surfaces.iter().enumerate() {
            let n1 = self.index_before(i, wavelength_nm);
            let n2 = s.medium.index(wavelength_nm);
            let power = (n2 - n1) * s.paraxial_curvature_per_mm();
            m = mul([[1.0, 0.0], [-power, 1.0]], m);
            if i < last {
                m = mul([[1.0, s.thickness_mm / n2], [0.0, 1.0]], m);
            }
        }
        let (a, c, d) = (m[0][0], m[1][0], m[1][1]);
        Paraxial {
            abcd: m,
            efl_mm: -1.0 / c,
            bfd_mm: -a / c,
            ffd_mm: d / c,
        }
    }

    /// Trace `ray` (in object space, travelling toward +z) through every surface at
    /// `wavelength_nm`. Returns the ray leaving the last surface, in image space.
    pub fn trace_forward(&self, ray: &Ray, wavelength_nm: f64) -> Result<Ray, Blocked> {
        let z = self.vertex_z_mm();
        let mut r = *ray;
        for (i, s) in self.surfaces.iter().enumerate() {
            r = self.through_surface(
                i,
                s,
                z[i],
                &r,
                self.index_before(i, wavelength_nm),
                s.medium.index(wavelength_nm),
            )?;
        }
        Ok(r)
    }

    /// Trace `ray` (in image space, travelling toward -z, e.g. from a point on the film) back
    /// through the surfaces to object space at `wavelength_nm` (pbrt-v4's `TraceLensesFromFilm`
    /// direction).
    pub fn trace_backward(&self, ray: &Ray, wavelength_nm: f64) -> Result<Ray, Blocked> {
        let z = self.vertex_z_mm();
        let mut r = *ray;
        for (i, s) in self.surfaces.iter().enumerate().rev() {
            r = self.through_surface(
                i,
                s,
                z[i],
                &r,
                s.medium.index(wavelength_nm),
                self.index_before(i, wavelength_nm),
            )?;
        }
        Ok(r)
    }

    /// [`Lens::trace_forward`] that also returns the optical path length (mm: sum of index x
    /// geometric length, Born & Wolf sec. 3.3.1) from the ray's origin to where it leaves the last
    /// surface, and the point where it crosses the stop plane. The wavefront stage builds
    /// optical path differences from it.
    pub fn trace_forward_path(&self, ray: &Ray, wavelength_nm: f64) -> Result<TracedPath, Blocked> {
        let z = self.vertex_z_mm();
        let mut r = *ray;
        let mut opl = 0.0;
        let mut stop = r.origin_mm;
        for (i, s) in self.surfaces.iter().enumerate() {
            let n_in = self.index_before(i, wavelength_nm);
            let next = self.through_surface(i, s, z[i], &r, n_in, s.medium.index(wavelength_nm))?;
            let d = [
                next.origin_mm[0] - r.origin_mm[0],
                next.origin_mm[1] - r.origin_mm[1],
                next.origin_mm[2] - r.origin_mm[2],
            ];
            opl += n_in * dot(d, d).sqrt();
            if s.is_stop {
                stop = next.origin_mm;
            }
            r = next;
        }
        Ok(TracedPath {
            ray: r,
            optical_path_mm: opl,
            stop_point_mm: stop,
        })
    }

    pub(crate) fn through_surface(
        &self,
        i: usize,
        s: &Surface,
        z0: f64,
        r: &Ray,
        n_in: f64,
        n_out: f64,
    ) -> Result<Ray, Blocked> {
        if s.is_stop {
            let p = r.at_z(z0).ok_or(Blocked::Aperture(i))?;
            let t = (z0 - r.origin_mm[2]) / r.direction[2];
            if t < -1e-9 || p[0].hypot(p[1]) > s.semi_aperture_mm {
                return Err(Blocked::Aperture(i));
            }
            return Ok(Ray {
                origin_mm: p,
                direction: r.direction,
            });
        }
        let (t, n) = intersect(s, z0, r).ok_or(Blocked::Aperture(i))?;
        let p = r.at(t);
        if t < -1e-9 || p[0].hypot(p[1]) > s.semi_aperture_mm {
            return Err(Blocked::Aperture(i));
        }
        let d = refract(r.direction, n, n_in, n_out).ok_or(Blocked::TotalInternalReflection(i))?;
        Ok(Ray {
            origin_mm: p,
            direction: d,
        })
    }

    /// Effective focal length and back focal distance by real ray tracing: a ray parallel to the
    /// axis at height `h_mm` from object space; EFL = h / tan(-U') (the principal-plane
    /// definition, exact as h -> 0), BFD = axial distance from the last vertex to where the ray
    /// crosses the axis.
    pub fn traced_focus(&self, h_mm: f64, wavelength_nm: f64) -> Result<(f64, f64), Blocked> {
        let out =
            self.trace_forward(&Ray::new([0.0, h_mm, -1.0], [0.0, 0.0, 1.0]), wavelength_nm)?;
        let d = out.direction;
        let tan_u = d[1] / d[2];
        let efl = -h_mm / tan_u;
        let z_cross = out.origin_mm[2] - out.origin_mm[1] / tan_u;
        let z_last = self.vertex_z_mm().last().copied().unwrap_or(0.0);
        Ok((efl, z_cross - z_last))
    }
}
