//! Field-dependent wavefronts of a traced lens prescription (Zemax's "FFT PSF" route): for a field
//! point, rays on a grid over the entrance pupil are traced through the lens ([`camsim_lens`]);
//! their optical path to the reference sphere centred on the chief ray's image point (at 550 nm)
//! gives the optical path difference W over the pupil, fitted with OSA Zernike terms up to radial
//! order [`FIT_ORDER`]; the existing FFT machinery ([`crate::Wavefront`]) turns them into PSFs.
//! The chief ray's film point gives the distortion; the relative illumination comes from
//! [`LensCamera::relative_illumination`] (the traced exit pupil's solid angle).
//!
//! Conventions: lens coordinates of [`camsim_lens::trace`] (mm, axis z, light toward +z); the
//! field point is placed so that its image lies on +x (x radial, y tangential), which is the
//! frame of the field PSFs that [`crate::shift_variant`] rotates to each block's azimuth.
//! Approximations (documented trade-offs): the pupil is the full circle of the entrance pupil
//! radius EFL / (2 N) (rays an element vignettes are left out of the fit, and the fitted
//! polynomial stands in for them in the PSF; vignetting reaches the image through the relative
//! illumination only); the pupil grid is uniform in the entrance pupil (as Zemax's FFT PSF), and
//! the PSF's image-plane scale takes the sine condition (exit ray direction sine = pupil height /
//! image distance).

use crate::error::{OpticsError, Result};
use crate::zernike::Zernike;
use camsim_lens::{Lens, LensCamera, Ray};
use std::path::Path;

/// Radial order of the Zernike fit to the traced optical path difference.
pub const FIT_ORDER: usize = 6;
/// Number of OSA terms up to [`FIT_ORDER`] (j = 0..28).
pub const FIT_TERMS: usize = (FIT_ORDER + 1) * (FIT_ORDER + 2) / 2;
/// Rays across the entrance pupil diameter for the fit.
pub const PUPIL_RAYS: usize = 32;
/// Wavelength of the chief rays that define distortion and the reference point, nm.
pub const REFERENCE_WAVELENGTH_NM: f64 = 550.0;

/// A field point of the object.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ObjectField {
    /// An object at infinity seen at angle theta from the axis: `tan_theta`.
    Infinity {
        /// tan of the field angle.
        tan_theta: f64,
    },
    /// A point `height_mm` off axis at `distance_mm` in front of the first vertex.
    Finite {
        /// Object height, mm (>= 0; it is placed on -x so that its image lies on +x).
        height_mm: f64,
        /// Distance in front of the first vertex, mm.
        distance_mm: f64,
    },
}

/// A lens prescription with its stop set for an f-number, ready for field tracing.
#[derive(Debug, Clone)]
pub struct TracedLens {
    /// The lens (stop scaled to the f-number).
    pub lens: Lens,
    /// Paraxial effective focal length at 550 nm, mm.
    pub efl_mm: f64,
    /// Entrance pupil radius EFL / (2 N), mm.
    pub entrance_pupil_radius_mm: f64,
    /// The lens with every aperture opened (for aiming chief rays, which pass the stop's centre).
    open: Lens,
    /// Start plane of collimated rays, mm (in front of the first surface).
    z_start_mm: f64,
    /// Entrance pupil plane (paraxial: where a near-axis chief ray's object-space line crosses
    /// the axis), mm.
    z_entrance_mm: f64,
    what: String,
}

fn lens_err(key: &str, e: impl std::fmt::Display) -> OpticsError {
    OpticsError::config(key, e.to_string())
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

impl TracedLens {
    /// Read a lens file (ISET3d JSON or pbrt-v4 lens file) and set it up for `f_number`; its
    /// paraxial focal length must be within 2 % of `focal_length_mm`.
    pub fn from_file(path: &Path, f_number: f64, focal_length_mm: f64) -> Result<TracedLens> {
        let lens = Lens::from_file(path).map_err(|e| lens_err("blur.lens_file", e))?;
        TracedLens::new(lens, &path.display().to_string(), f_number, focal_length_mm)
    }

    /// Set `lens` up for `f_number` (`what` names it in errors): the stop is scaled so that the
    /// entrance pupil radius is EFL / (2 N) (paraxial stop height per pupil height from a
    /// near-axis ray), and a real axial ray at 0.98 of that radius must pass every element.
    pub fn new(lens: Lens, what: &str, f_number: f64, focal_length_mm: f64) -> Result<TracedLens> {
        let key = "blur.lens_file";
        let p = lens.paraxial(REFERENCE_WAVELENGTH_NM);
        let efl = p.efl_mm;
        if !(efl.is_finite() && efl > 0.0) {
            return Err(lens_err(
                key,
                format!("{what}: the lens has no positive focal length (EFL {efl} mm)"),
            ));
        }
        if ((efl - focal_length_mm) / focal_length_mm).abs() > 0.02 {
            return Err(lens_err(
                key,
                format!("{what}: the lens's focal length is {efl:.4} mm but focal_length_mm = {focal_length_mm}; set it within 2 %"),
            ));
        }
        let mut open = lens.clone();
        open.surfaces
            .iter_mut()
            .for_each(|s| s.semi_aperture_mm *= 1e3);
        let first = &lens.surfaces[0];
        let z_start_mm = -1.0
            - first
                .semi_aperture_mm
                .min(first.radius_mm.abs().max(first.semi_aperture_mm));
        let a = efl / (2.0 * f_number);
        let h0 = 1e-3 * a;
        let near = open
            .trace_forward_path(
                &Ray::new([h0, 0.0, z_start_mm], [0.0, 0.0, 1.0]),
                REFERENCE_WAVELENGTH_NM,
            )
            .map_err(|b| {
                lens_err(
                    key,
                    format!("{what}: a near-axis ray does not pass ({b:?})"),
                )
            })?;
        let k = near.stop_point_mm[0] / h0;
        if !(k.is_finite() && k > 0.0) {
            return Err(lens_err(
                key,
                format!("{what}: the stop is not imaged into an entrance pupil (ratio {k})"),
            ));
        }
        let lens = lens.with_stop_semi_aperture_mm(k * a);
        let mut t = TracedLens {
            lens,
            efl_mm: efl,
            entrance_pupil_radius_mm: a,
            open,
            z_start_mm,
            z_entrance_mm: 0.0,
            what: what.to_string(),
        };
        // Entrance pupil: aim a near-axis collimated chief ray from the first vertex's plane.
        let tan0 = 1e-4;
        let f0 = ObjectField::Infinity { tan_theta: tan0 };
        let x0 = t.aim_chief(f0)?;
        t.z_entrance_mm = z_start_mm - x0 / tan0;
        // The axial beam must fill the pupil: element apertures may not cut it.
        let passes = |h: f64| {
            t.lens
                .trace_forward(
                    &Ray::new([h, 0.0, z_start_mm], [0.0, 0.0, 1.0]),
                    REFERENCE_WAVELENGTH_NM,
                )
                .is_ok()
        };
        if !passes(0.98 * a) {
            let (mut lo, mut hi) = (0.0f64, 0.98 * a);
            for _ in 0..40 {
                let m = 0.5 * (lo + hi);
                if passes(m) {
                    lo = m;
                } else {
                    hi = m;
                }
            }
            return Err(lens_err(
                "f_number",
                format!(
                    "{what}: the lens's element apertures allow at most f/{:.2}; f/{f_number} needs a larger pupil",
                    efl / (2.0 * lo.max(1e-12))
                ),
            ));
        }
        Ok(t)
    }

    /// The lens focused on `object_distance_mm` (`inf`: infinity) with a film of diagonal
    /// `film_diagonal_mm` (paraxial focus at 550 nm, [`LensCamera::focused`]).
    pub fn camera(&self, object_distance_mm: f64, film_diagonal_mm: f64) -> Result<LensCamera> {
        LensCamera::focused(self.lens.clone(), object_distance_mm, film_diagonal_mm)
            .map_err(|e| lens_err("blur.lens_file", e))
    }

    /// The object-space ray of field `f` through start parameter `x` (infinity: the start point's
    /// x on the start plane; finite: the x where it crosses the first vertex plane).
    fn field_ray(&self, f: ObjectField, x: f64, y: f64) -> Ray {
        match f {
            ObjectField::Infinity { tan_theta } => {
                Ray::new([x, y, self.z_start_mm], [tan_theta, 0.0, 1.0])
            }
            ObjectField::Finite {
                height_mm,
                distance_mm,
            } => Ray::new(
                [-height_mm, 0.0, -distance_mm],
                [x + height_mm, y, distance_mm],
            ),
        }
    }

    /// The chief ray's start parameter: the x for which the ray passes the stop's centre at 550 nm
    /// (secant iteration on the stop-plane height; apertures opened).
    fn aim_chief(&self, f: ObjectField) -> Result<f64> {
        let g = |x: f64| -> Result<f64> {
            self.open
                .trace_forward_path(&self.field_ray(f, x, 0.0), REFERENCE_WAVELENGTH_NM)
                .map(|p| p.stop_point_mm[0])
                .map_err(|b| {
                    lens_err(
                        "blur.lens_file",
                        format!(
                            "{}: the chief ray of field {f:?} does not pass ({b:?})",
                            self.what
                        ),
                    )
                })
        };
        // Start: the line through the (paraxial) entrance pupil's centre.
        let ze = self.z_entrance_mm;
        let mut x0 = match f {
            ObjectField::Infinity { tan_theta } => (self.z_start_mm - ze) * tan_theta,
            ObjectField::Finite {
                height_mm,
                distance_mm,
            } => -height_mm * ze / (ze + distance_mm),
        };
        let mut x1 = x0 + 1e-3 * self.entrance_pupil_radius_mm;
        let (mut g0, mut g1) = (g(x0)?, g(x1)?);
        for _ in 0..60 {
            if g1.abs() < 1e-11 || g1 == g0 {
                break;
            }
            // Secant step, halved while the trial ray misses a surface.
            let mut step = -g1 * (x1 - x0) / (g1 - g0);
            let mut next = None;
            for _ in 0..30 {
                if let Ok(v) = g(x1 + step) {
                    next = Some(v);
                    break;
                }
                step *= 0.5;
            }
            let g2 = next.ok_or_else(|| {
                lens_err(
                    "blur.lens_file",
                    format!(
                        "{}: cannot aim the chief ray of field {f:?} at the stop",
                        self.what
                    ),
                )
            })?;
            (x0, g0) = (x1, g1);
            x1 += step;
            g1 = g2;
        }
        if g1.is_nan() || g1.abs() >= 1e-6 {
            return Err(lens_err(
                "blur.lens_file",
                format!(
                    "{}: cannot aim the chief ray of field {f:?} at the stop",
                    self.what
                ),
            ));
        }
        Ok(x1)
    }

    /// Where the 550 nm chief ray of field `f` meets the film of `cam`, mm (x radial; y ~ 0).
    pub fn chief_image_point_mm(&self, cam: &LensCamera, f: ObjectField) -> Result<[f64; 3]> {
        let x = self.aim_chief(f)?;
        let out = self
            .open
            .trace_forward(&self.field_ray(f, x, 0.0), REFERENCE_WAVELENGTH_NM)
            .map_err(|b| {
                lens_err(
                    "blur.lens_file",
                    format!("{}: chief ray blocked ({b:?})", self.what),
                )
            })?;
        out.at_z(cam.film_z_mm()).ok_or_else(|| {
            lens_err(
                "blur.lens_file",
                format!("{}: the chief ray does not reach the film", self.what),
            )
        })
    }

    /// z of the exit pupil, mm: where a near-axis chief ray (through the stop's centre) crosses the
    /// axis in image space.
    fn exit_pupil_z_mm(&self) -> Result<f64> {
        let f = ObjectField::Infinity { tan_theta: 1e-4 };
        let x = self.aim_chief(f)?;
        let out = self
            .open
            .trace_forward(&self.field_ray(f, x, 0.0), REFERENCE_WAVELENGTH_NM)
            .map_err(|b| {
                lens_err(
                    "blur.lens_file",
                    format!("{}: chief ray blocked ({b:?})", self.what),
                )
            })?;
        let (o, d) = (out.origin_mm, out.direction);
        Ok(o[2] - o[0] * d[2] / d[0])
    }

    /// OSA Zernike coefficients (um, unit RMS over the entrance pupil circle, x radial) of the
    /// wavefront aberration W of field `f` at each of `wavelengths_nm`, with the reference sphere
    /// centred on the 550 nm chief ray's film point moved by `reference_offset_mm` (x, y) and
    /// passing through the exit pupil's centre. W = -(OPL - OPL_chief): positive W where the ray's
    /// optical path to the reference sphere is short, so a focus in front of the film has W > 0
    /// at the rim, as the Seidel W020 of [`crate::lens::defocus_w020_m`]. The optical path of a ray
    /// is the path to the last surface ([`Lens::trace_forward_path`]) plus the (signed) distance on
    /// to the reference sphere (Welford, Aberrations of Optical Systems, sec. 6.3: the wavefront
    /// aberration as the optical path difference to a reference sphere); collimated rays start on
    /// one plane, corrected to the plane normal to the beam.
    pub fn wavefront_zernike_um(
        &self,
        cam: &LensCamera,
        f: ObjectField,
        wavelengths_nm: &[f64],
        reference_offset_mm: [f64; 2],
    ) -> Result<Vec<Vec<f64>>> {
        let key = "blur.lens_file";
        let xc = self.aim_chief(f)?;
        let chief = self
            .open
            .trace_forward(&self.field_ray(f, xc, 0.0), REFERENCE_WAVELENGTH_NM)
            .map_err(|b| lens_err(key, format!("{b:?}")))?;
        let p0 = chief
            .at_z(cam.film_z_mm())
            .ok_or_else(|| lens_err(key, "the chief ray does not reach the film"))?;
        let centre = [
            p0[0] + reference_offset_mm[0],
            p0[1] + reference_offset_mm[1],
            p0[2],
        ];
        let e = chief
            .at_z(self.exit_pupil_z_mm()?)
            .ok_or_else(|| lens_err(key, "the chief ray does not reach the exit pupil"))?;
        let radius = dot(sub(centre, e), sub(centre, e)).sqrt();
        let a = self.entrance_pupil_radius_mm;
        // The pupil grid's origin: the chief ray's start (collimated) or its crossing of the first
        // vertex plane (finite).
        let zern: Vec<Zernike> = (0..FIT_TERMS).map(Zernike::new).collect();
        let n = PUPIL_RAYS;
        // Grid radius on the start plane (collimated: the pupil's circle moved along the beam) or
        // on the first vertex plane (finite: the cone from the object point through the pupil).
        let a = match f {
            ObjectField::Infinity { .. } => a,
            ObjectField::Finite { distance_mm, .. } => {
                a * distance_mm / (distance_mm + self.z_entrance_mm)
            }
        };
        let mut out = Vec::with_capacity(wavelengths_nm.len());
        let chief_start = self.field_ray(f, xc, 0.0);
        for &wl in wavelengths_nm {
            let opl = |x: f64, y: f64| -> Option<f64> {
                let ray = self.field_ray(f, x, y);
                let lens = if x == xc && y == 0.0 {
                    &self.open
                } else {
                    &self.lens
                };
                let path = lens.trace_forward_path(&ray, wl).ok()?;
                let start = match f {
                    ObjectField::Infinity { .. } => {
                        dot(sub(ray.origin_mm, chief_start.origin_mm), ray.direction)
                    }
                    ObjectField::Finite { .. } => 0.0,
                };
                // On to the reference sphere: |q + t d - c| = R, the root near the pupil.
                let (q, d) = (path.ray.origin_mm, path.ray.direction);
                let qc = sub(q, centre);
                let b = dot(qc, d);
                let disc = b * b - (dot(qc, qc) - radius * radius);
                if disc < 0.0 {
                    return None;
                }
                Some(start + path.optical_path_mm + (-b - disc.sqrt()))
            };
            let opl_chief = opl(xc, 0.0).ok_or_else(|| {
                lens_err(
                    key,
                    format!("{}: the chief ray misses the reference sphere", self.what),
                )
            })?;
            let mut ata = vec![0.0; FIT_TERMS * FIT_TERMS];
            let mut atb = vec![0.0; FIT_TERMS];
            let mut zv = vec![0.0; FIT_TERMS];
            let (mut used, mut inside) = (0usize, 0usize);
            for i in 0..n {
                for j in 0..n {
                    let u = (j as f64 + 0.5) / n as f64 * 2.0 - 1.0;
                    let v = (i as f64 + 0.5) / n as f64 * 2.0 - 1.0;
                    let rho = u.hypot(v);
                    if rho > 1.0 {
                        continue;
                    }
                    inside += 1;
                    let Some(l) = opl(xc + a * u, a * v) else {
                        continue;
                    };
                    let w_um = -(l - opl_chief) * 1e3;
                    let pt = crate::zernike::PointTerms::new(rho, u, v, FIT_ORDER);
                    for (z, o) in zern.iter().zip(zv.iter_mut()) {
                        *o = z.eval_at(&pt);
                    }
                    for r in 0..FIT_TERMS {
                        for c in 0..FIT_TERMS {
                            ata[r * FIT_TERMS + c] += zv[r] * zv[c];
                        }
                        atb[r] += zv[r] * w_um;
                    }
                    used += 1;
                }
            }
            // A pupil vignetted to a sliver leaves the fit's extrapolation over the blocked part
            // unconstrained: refuse fits on less than a quarter of the pupil.
            if used < 2 * FIT_TERMS || 4 * used < inside {
                return Err(lens_err(
                    key,
                    format!("{}: only {used} of {inside} pupil rays of field {f:?} pass the lens at {wl} nm", self.what),
                ));
            }
            let c = crate::shading::solve(ata, atb, FIT_TERMS).filter(|c| c.iter().all(|v| v.is_finite())).ok_or_else(|| {
                lens_err(key, format!("{}: the Zernike fit of field {f:?} at {wl} nm is singular (the pupil is vignetted)", self.what))
            })?;
            out.push(c);
        }
        Ok(out)
    }
}
