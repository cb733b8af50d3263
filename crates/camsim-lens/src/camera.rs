//! A lens in front of a film plane: the calls a renderer's `realistic` camera makes (pbrt-v4 4th
//! ed. sec. 5.3, `RealisticCamera`): focus, trace a ray from a film point out through the lens,
//! and the exit-pupil bounds that let it sample only directions that can pass.
//!
//! Coordinates: lens coordinates of [`crate::trace`] (mm; optical axis z, first vertex at z = 0,
//! scene at z < 0); the film plane is at z = last vertex + `film_distance_mm`, so a film ray
//! travels toward -z. A renderer maps film (x, y) and the returned ray to its camera space (pbrt
//! flips z and scales mm to m).
//!
//! Typical use: `let cam = LensCamera::focused(lens, 500.0, 7.06)?;` then per sample: a film point
//! p, a point q drawn uniformly in `cam.exit_pupil_bounds(|p|)` rotated to p's azimuth, the
//! direction q - p, and `cam.trace_ray(p, dir, wavelength_nm)`; the radiance weight is
//! cos^4(theta) times the bounds' area over the squared film-to-rear distance (pbrt's
//! `GenerateRay`).

use crate::error::{LensError, Result};
use crate::prescription::Lens;
use crate::trace::Ray;

/// A lens with its film plane.
#[derive(Debug, Clone, PartialEq)]
pub struct LensCamera {
    /// The lens.
    pub lens: Lens,
    /// Distance from the last vertex to the film, mm.
    pub film_distance_mm: f64,
    /// Largest film radius (half the film diagonal), mm.
    pub max_film_radius_mm: f64,
    /// Exit-pupil bounds [x0, x1, y0, y1] on the rear vertex plane, mm, for film points at
    /// (r, 0) with r in each of `PUPIL_INTERVALS` equal intervals of [0, max_film_radius_mm].
    pupil_bounds: Vec<[f64; 4]>,
}

/// Film-radius intervals with their own exit-pupil bounds.
pub const PUPIL_INTERVALS: usize = 32;

impl LensCamera {
    /// The lens with the film `film_distance_mm` behind its last vertex and a film of diagonal
    /// `film_diagonal_mm`; computes the exit-pupil bounds at 550 nm.
    pub fn new(lens: Lens, film_distance_mm: f64, film_diagonal_mm: f64) -> Result<LensCamera> {
        if !(film_distance_mm > 0.0 && film_distance_mm.is_finite()) {
            return Err(LensError::Lens {
                what: lens.name.clone(),
                message: format!("film distance {film_distance_mm} mm is not > 0"),
            });
        }
        if !(film_diagonal_mm > 0.0 && film_diagonal_mm.is_finite()) {
            return Err(LensError::Lens {
                what: lens.name.clone(),
                message: format!("film diagonal {film_diagonal_mm} mm is not > 0"),
            });
        }
        let mut cam = LensCamera {
            lens,
            film_distance_mm,
            max_film_radius_mm: film_diagonal_mm / 2.0,
            pupil_bounds: Vec::new(),
        };
        cam.pupil_bounds = (0..PUPIL_INTERVALS)
            .map(|i| cam.bound_exit_pupil(i))
            .collect();
        Ok(cam)
    }

    /// The lens focused on an object `object_distance_mm` in front of its first vertex (`inf`:
    /// infinity) at 550 nm: the film where a near-axis real ray from the axial object point
    /// crosses the axis.
    pub fn focused(
        lens: Lens,
        object_distance_mm: f64,
        film_diagonal_mm: f64,
    ) -> Result<LensCamera> {
        let what = lens.name.clone();
        let err = |m: String| LensError::Lens {
            what: what.clone(),
            message: m,
        };
        let h = lens.surfaces[0].semi_aperture_mm * 1e-3;
        let ray = if object_distance_mm.is_infinite() {
            Ray::new([0.0, h, -1.0], [0.0, 0.0, 1.0])
        } else if object_distance_mm > 0.0 {
            Ray::new(
                [0.0, 0.0, -object_distance_mm],
                [0.0, h, object_distance_mm],
            )
        } else {
            return Err(err(format!(
                "object distance {object_distance_mm} mm is not > 0"
            )));
        };
        let out = lens
            .trace_forward(&ray, 550.0)
            .map_err(|b| err(format!("the focusing ray is blocked ({b:?})")))?;
        let (o, d) = (out.origin_mm, out.direction);
        if (d[1] * o[1]).partial_cmp(&0.0) != Some(std::cmp::Ordering::Less) {
            return Err(err(format!(
                "no real image of an object at {object_distance_mm} mm (the rays diverge)"
            )));
        }
        let z_cross = o[2] - o[1] * d[2] / d[1];
        let z_last = lens.vertex_z_mm().last().copied().unwrap_or(0.0);
        LensCamera::new(lens, z_cross - z_last, film_diagonal_mm)
    }

    /// z of the film plane, mm.
    pub fn film_z_mm(&self) -> f64 {
        self.lens.vertex_z_mm().last().copied().unwrap_or(0.0) + self.film_distance_mm
    }

    /// Trace a ray leaving the film point `origin_on_film_mm` (x, y) along `direction` (toward the
    /// lens: z < 0) out through the lens at `wavelength_nm`: the ray in object space, or `None`
    /// when an aperture blocks it or it reflects totally.
    pub fn trace_ray(
        &self,
        origin_on_film_mm: [f64; 2],
        direction: [f64; 3],
        wavelength_nm: f64,
    ) -> Option<Ray> {
        if direction[2].partial_cmp(&0.0) != Some(std::cmp::Ordering::Less) {
            return None;
        }
        let ray = Ray::new(
            [origin_on_film_mm[0], origin_on_film_mm[1], self.film_z_mm()],
            direction,
        );
        self.lens.trace_backward(&ray, wavelength_nm).ok()
    }

    /// Bounds [x0, x1, y0, y1] (mm, on the plane of the last vertex) of the points through which
    /// rays from a film point at distance `film_radius_mm` from the axis, rotated to lie on +x,
    /// can pass the lens. Rotate them by the film point's azimuth.
    pub fn exit_pupil_bounds(&self, film_radius_mm: f64) -> [f64; 4] {
        let t = (film_radius_mm / self.max_film_radius_mm * PUPIL_INTERVALS as f64).floor();
        self.pupil_bounds[(t.max(0.0) as usize).min(PUPIL_INTERVALS - 1)]
    }

    /// Relative illumination at film heights `heights_mm` for a uniform Lambertian scene, at
    /// `wavelength_nm`, normalized to the axis: E(h) = L integral of cos(theta) d(omega) over the
    /// directions from the film point (h, 0) that pass the lens (radiance is conserved along a ray
    /// through a lossless lens). Sampled on an `n` x `n` grid of the exit-pupil bounds on the rear
    /// vertex plane, where cos(theta) d(omega) = D^2 dA / rho^4 (D film distance, rho the distance
    /// from the film point). For a thin lens with a small stop at the lens this tends to
    /// cos^4 of the chief ray angle (the "cosine-fourth law"; Kingslake, Optical System Design,
    /// sec. 6.5).
    pub fn relative_illumination(
        &self,
        heights_mm: &[f64],
        n: usize,
        wavelength_nm: f64,
    ) -> Vec<f64> {
        let e = |h: f64| {
            let b = self.exit_pupil_bounds(h);
            let (dx, dy) = ((b[1] - b[0]) / n as f64, (b[3] - b[2]) / n as f64);
            let d = self.film_distance_mm;
            let mut s = 0.0;
            for a in 0..n {
                for c in 0..n {
                    let (x, y) = (b[0] + (a as f64 + 0.5) * dx, b[2] + (c as f64 + 0.5) * dy);
                    let v = [x - h, y, -d];
                    if self.trace_ray([h, 0.0], v, wavelength_nm).is_some() {
                        let rho2 = v[0] * v[0] + v[1] * v[1] + d * d;
                        s += d * d / (rho2 * rho2);
                    }
                }
            }
            s * dx * dy
        };
        let e0 = e(0.0);
        heights_mm.iter().map(|h| e(*h) / e0).collect()
    }

    /// pbrt-v4's `BoundExitPupil`: trace from film points across interval `i` to a grid on the
    /// rear vertex plane spanning the last surface's aperture; the box of those that pass, grown
    /// by one grid cell.
    fn bound_exit_pupil(&self, i: usize) -> [f64; 4] {
        let last = self
            .lens
            .surfaces
            .last()
            .map(|s| s.semi_aperture_mm)
            .unwrap_or(0.0);
        let rear = 1.5 * last;
        let z_rear = self.film_z_mm() - self.film_distance_mm;
        let n = 48;
        let cell = 2.0 * rear / n as f64;
        let (r0, r1) = (
            i as f64 / PUPIL_INTERVALS as f64,
            (i + 1) as f64 / PUPIL_INTERVALS as f64,
        );
        let mut b = [
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ];
        for k in 0..=4 {
            let fx = self.max_film_radius_mm * (r0 + (r1 - r0) * k as f64 / 4.0);
            for a in 0..n {
                for c in 0..n {
                    let (x, y) = (
                        -rear + (a as f64 + 0.5) * cell,
                        -rear + (c as f64 + 0.5) * cell,
                    );
                    let d = [x - fx, y, z_rear - self.film_z_mm()];
                    if self.trace_ray([fx, 0.0], d, 550.0).is_some() {
                        b = [b[0].min(x), b[1].max(x), b[2].min(y), b[3].max(y)];
                    }
                }
            }
        }
        if b[0] > b[1] {
            return [0.0; 4];
        }
        [b[0] - cell, b[1] + cell, b[2] - cell, b[3] + cell]
    }
}
