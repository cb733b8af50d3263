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

use crate::config::{CoatingConfig, CoatingName, GhostConfig};
use crate::error::{OpticsError, Result};
use crate::zernike::Zernike;
use camsim_core::SpectralImage;
use camsim_lens::{Bundle, Coating, Lens, LensCamera, Ray};
use rayon::prelude::*;
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

// ---------------------------------------------------------------------------------------------
// Lens ghosts.
// ---------------------------------------------------------------------------------------------

/// The ghost settings (`blur.ghosts`), checked against the lens: the reflectance model of each of
/// its surfaces, the source detection and the sampling.
#[derive(Debug, Clone, PartialEq)]
pub struct Ghosts {
    /// Reflectance model per surface of the lens, object side first (the stop's is unused).
    pub coatings: Vec<Coating>,
    /// Detection threshold, fraction of the largest band-summed irradiance.
    pub threshold: f64,
    /// Most detected sources.
    pub max_sources: usize,
    /// Explicit sources (empty: detect them in the image).
    pub sources: Vec<GhostSource>,
    /// Rays across the front element's diameter.
    pub rays: usize,
    /// Raster samples along the image's longer side.
    pub raster_px: usize,
}

/// How bright a ghost source is, per band (one entry: every band).
#[derive(Debug, Clone, PartialEq)]
pub enum SourceStrength {
    /// Spectral irradiance of the beam at the lens, normal to the beam, W/(m^2 nm).
    Irradiance(Vec<f64>),
    /// Spectral power of the source's main image on the film, W/nm (a detected source): the beam
    /// irradiance follows from the main path's traced throughput.
    ImagePower(Vec<f64>),
}

/// A point source at infinity for [`ghost_irradiance`].
#[derive(Debug, Clone, PartialEq)]
pub struct GhostSource {
    /// Direction of travel of its light in lens coordinates (toward +z; x along image columns, y
    /// along image rows); its image lies near f (d_x / d_z, d_y / d_z).
    pub direction: [f64; 3],
    /// Its brightness.
    pub strength: SourceStrength,
}

/// The film as a pixel grid centred on the optical axis: pixel (row r, column c) has its centre
/// at x = (c + 0.5 - cols / 2) pitch, y = (r + 0.5 - rows / 2) pitch (as the irradiance images of
/// the shift-variant stage).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SensorGeometry {
    /// Rows.
    pub rows: usize,
    /// Columns.
    pub cols: usize,
    /// Pixel pitch, mm.
    pub pixel_pitch_mm: f64,
    /// Axial position of the film in lens coordinates, mm ([`LensCamera::film_z_mm`]).
    pub film_z_mm: f64,
}

/// A bright region of an irradiance image taken as a ghost source ([`detect_sources`]).
#[derive(Debug, Clone, PartialEq)]
pub struct DetectedSource {
    /// Centroid (weighted by the band-summed irradiance) on the film, mm from the axis.
    pub x_mm: f64,
    /// Centroid y, mm.
    pub y_mm: f64,
    /// Pixels in the region.
    pub pixels: usize,
    /// Spectral power of the region per band, W/nm (irradiance times pixel area, summed).
    pub power_w_nm: Vec<f64>,
}

impl Ghosts {
    /// Check `cfg` (keys `blur.ghosts.*`) for `lens` (the surface list of `surface_reflectance`).
    pub fn from_config(cfg: &GhostConfig, lens: &Lens) -> Result<Ghosts> {
        let key = |k: &str| format!("blur.ghosts.{k}");
        let coating = match &cfg.coating {
            CoatingConfig::Named(CoatingName::Uncoated) => Coating::Uncoated,
            CoatingConfig::QuarterWave(q) => Coating::QuarterWave {
                design_wavelength_nm: q.quarter_wave_nm,
                layer_index: q.layer_index,
            },
            CoatingConfig::Constant(c) => Coating::Reflectance(c.reflectance),
        };
        coating
            .check()
            .map_err(|m| OpticsError::config(key("coating"), m))?;
        let n = lens.surfaces.len();
        let coatings = match &cfg.surface_reflectance {
            None => vec![coating; n],
            Some(v) => {
                if v.len() != n {
                    return Err(OpticsError::config(
                        key("surface_reflectance"),
                        format!(
                            "{} values for a lens of {n} surfaces (one per surface, the stop's ignored)",
                            v.len()
                        ),
                    ));
                }
                v.iter()
                    .enumerate()
                    .map(|(i, r)| {
                        let c = Coating::Reflectance(*r);
                        c.check().map(|_| c).map_err(|m| {
                            OpticsError::config(
                                key("surface_reflectance"),
                                format!("surface {}: {m}", i + 1),
                            )
                        })
                    })
                    .collect::<Result<Vec<_>>>()?
            }
        };
        if !(cfg.threshold > 0.0 && cfg.threshold <= 1.0) {
            return Err(OpticsError::config(
                key("threshold"),
                format!("{} is not in (0, 1]", cfg.threshold),
            ));
        }
        if !(1..=64).contains(&cfg.max_sources) {
            return Err(OpticsError::config(
                key("max_sources"),
                format!("{} is not in 1..=64", cfg.max_sources),
            ));
        }
        if !(8..=512).contains(&cfg.rays) {
            return Err(OpticsError::config(
                key("rays"),
                format!("{} is not in 8..=512", cfg.rays),
            ));
        }
        if !(16..=16384).contains(&cfg.raster_px) {
            return Err(OpticsError::config(
                key("raster_px"),
                format!("{} is not in 16..=16384", cfg.raster_px),
            ));
        }
        let mut sources = Vec::new();
        for (i, s) in cfg.sources.iter().flatten().enumerate() {
            let bad = |m: String| OpticsError::config(format!("blur.ghosts.sources[{i}]"), m);
            if s.field_deg
                .iter()
                .any(|a| !(a.is_finite() && a.abs() < 89.0))
            {
                return Err(bad(format!(
                    "field_deg {:?} must be finite and within 89 degrees of the axis",
                    s.field_deg
                )));
            }
            if !(s.irradiance_w_m2_nm.is_finite() && s.irradiance_w_m2_nm >= 0.0) {
                return Err(bad(format!(
                    "irradiance_w_m2_nm {} is not a number >= 0",
                    s.irradiance_w_m2_nm
                )));
            }
            sources.push(GhostSource {
                direction: [
                    s.field_deg[0].to_radians().tan(),
                    s.field_deg[1].to_radians().tan(),
                    1.0,
                ],
                strength: SourceStrength::Irradiance(vec![s.irradiance_w_m2_nm]),
            });
        }
        Ok(Ghosts {
            coatings,
            threshold: cfg.threshold,
            max_sources: cfg.max_sources,
            sources,
            rays: cfg.rays,
            raster_px: cfg.raster_px,
        })
    }
}

/// Pixel-centre offset from the optical axis (the image centre), samples.
fn centre_offset(i: usize, n: usize) -> f64 {
    i as f64 + 0.5 - n as f64 / 2.0
}

/// The connected regions (4-neighbour) of `image` whose band-summed irradiance is at least
/// `threshold` times the image's largest, brightest (most power summed over bands) first, at most
/// `max_sources`; ties keep the scan order (the first pixel of each region, row-major), so the
/// result does not depend on the thread count.
pub fn detect_sources(
    image: &SpectralImage,
    threshold: f64,
    max_sources: usize,
) -> Vec<DetectedSource> {
    let (rows, cols) = (image.rows, image.cols);
    let plane = rows * cols;
    let bands = image.bands();
    if plane == 0 || bands == 0 {
        return Vec::new();
    }
    let sum_at = |k: usize| -> f64 { (0..bands).map(|b| image.data[b * plane + k] as f64).sum() };
    let max = (0..rows)
        .into_par_iter()
        .map(|r| {
            (0..cols)
                .map(|c| sum_at(r * cols + c))
                .fold(f64::NEG_INFINITY, f64::max)
        })
        .reduce(|| f64::NEG_INFINITY, f64::max);
    if !(max > 0.0 && max.is_finite()) {
        return Vec::new();
    }
    let level = threshold * max;
    // 0: below the threshold, 1: above and not yet visited, 2: visited.
    let mut mask: Vec<u8> = (0..rows)
        .into_par_iter()
        .flat_map_iter(|r| (0..cols).map(move |c| r * cols + c))
        .map(|k| u8::from(sum_at(k) >= level))
        .collect();
    let pitch_mm = image.sample_spacing_m * 1e3;
    let area_m2 = image.sample_spacing_m * image.sample_spacing_m;
    let mut found: Vec<(f64, DetectedSource)> = Vec::new();
    let mut stack = Vec::new();
    for start in 0..plane {
        if mask[start] != 1 {
            continue;
        }
        mask[start] = 2;
        stack.push(start);
        let (mut wsum, mut wx, mut wy, mut pixels) = (0.0, 0.0, 0.0, 0usize);
        let mut power = vec![0.0; bands];
        while let Some(k) = stack.pop() {
            let (r, c) = (k / cols, k % cols);
            let w = sum_at(k);
            wsum += w;
            wx += w * centre_offset(c, cols);
            wy += w * centre_offset(r, rows);
            pixels += 1;
            for (b, p) in power.iter_mut().enumerate() {
                *p += image.data[b * plane + k] as f64 * area_m2;
            }
            let mut visit = |n: usize| {
                if mask[n] == 1 {
                    mask[n] = 2;
                    stack.push(n);
                }
            };
            if c > 0 {
                visit(k - 1);
            }
            if c + 1 < cols {
                visit(k + 1);
            }
            if r > 0 {
                visit(k - cols);
            }
            if r + 1 < rows {
                visit(k + cols);
            }
        }
        found.push((
            wsum,
            DetectedSource {
                x_mm: wx / wsum * pitch_mm,
                y_mm: wy / wsum * pitch_mm,
                pixels,
                power_w_nm: power,
            },
        ));
    }
    // Stable sort: equal powers keep the scan order.
    found.sort_by(|a, b| b.0.partial_cmp(&a.0).unwrap_or(std::cmp::Ordering::Equal));
    found
        .into_iter()
        .take(max_sources)
        .map(|(_, s)| s)
        .collect()
}

/// The ghosts of `sources` on `sensor` through `lens` with surface reflectances `coatings`, at
/// `wavelengths_nm`, `rays` rays across the front element: spectral irradiance W/(m^2 nm),
/// band-sequential (band b is `[b * rows * cols, (b + 1) * rows * cols)`), to add to the main
/// image. Every two-bounce path of [`Lens::ghost_paths`] is traced per source and band
/// ([`Lens::trace_bundle`]); each ray carries E cos(theta) h^2 times the path's transmission
/// ([`Lens::path_transmission`]: R_back R_front and 1 - R per crossing), E the beam irradiance, h
/// the launch grid step; its power is spread over its footprint on the film (the image of its
/// launch cell, corners from the neighbouring rays' landing points: the area ratio of the ray
/// map's grid, as Hullin et al. 2011 sec. 4.3 shade a ghost's ray-grid quads), at each pixel
/// centre inside, or bilinearly at the landing point where the footprint is under two pixels. rayon over bands;
/// each band's plane is computed serially, so the result does not depend on the thread count.
pub fn ghost_irradiance(
    lens: &Lens,
    coatings: &[Coating],
    sensor: &SensorGeometry,
    sources: &[GhostSource],
    wavelengths_nm: &[f64],
    rays: usize,
) -> Vec<f32> {
    let plane = sensor.rows * sensor.cols;
    let mut out = vec![0.0f32; plane * wavelengths_nm.len()];
    if plane == 0 {
        return out;
    }
    out.par_chunks_mut(plane)
        .zip(wavelengths_nm.par_iter())
        .enumerate()
        .for_each(|(b, (dst, &wl))| {
            splat_band(lens, coatings, sensor, sources, b, wl, rays, dst);
        });
    out
}

/// The beam irradiance of `s` in band `b`, W/(m^2 nm), given the main path's traced bundle at
/// that band (for [`SourceStrength::ImagePower`]: the image power over the power that the main
/// path delivers per unit beam irradiance, cos(theta) A_launch T_main passed / launched).
fn beam_irradiance(
    lens: &Lens,
    coatings: &[Coating],
    s: &GhostSource,
    b: usize,
    wl: f64,
    film_z_mm: f64,
    rays: usize,
) -> f64 {
    let pick = |v: &[f64]| v.get(b).or(v.last()).copied().unwrap_or(0.0);
    match &s.strength {
        SourceStrength::Irradiance(v) => pick(v),
        SourceStrength::ImagePower(v) => {
            let main = lens.trace_bundle(None, s.direction, film_z_mm, wl, rays);
            let cos = cos_to_axis(s.direction);
            let per_e = cos
                * main.passed as f64
                * main.spacing_mm
                * main.spacing_mm
                * 1e-6
                * lens.path_transmission(None, wl, coatings);
            if per_e > 0.0 {
                pick(v) / per_e
            } else {
                0.0
            }
        }
    }
}

fn cos_to_axis(d: [f64; 3]) -> f64 {
    d[2] / (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()
}

/// One band of [`ghost_irradiance`], added into `dst` (rows x cols of `sensor`).
#[allow(clippy::too_many_arguments)]
fn splat_band(
    lens: &Lens,
    coatings: &[Coating],
    sensor: &SensorGeometry,
    sources: &[GhostSource],
    b: usize,
    wl: f64,
    rays: usize,
    dst: &mut [f32],
) {
    let paths = lens.ghost_paths();
    for s in sources {
        let e = beam_irradiance(lens, coatings, s, b, wl, sensor.film_z_mm, rays);
        if !(e > 0.0) {
            continue;
        }
        for &p in &paths {
            let t = lens.path_transmission(Some(p), wl, coatings);
            if !(t > 0.0) {
                continue;
            }
            let bundle = lens.trace_bundle(Some(p), s.direction, sensor.film_z_mm, wl, rays);
            if bundle.passed == 0 {
                continue;
            }
            // Irradiance of one ray's power spread over one pixel, W/(m^2 nm):
            // E cos(theta) h^2 T / pitch^2 (both areas in mm^2).
            let pitch = sensor.pixel_pitch_mm;
            let per_pixel = e * cos_to_axis(s.direction) * bundle.spacing_mm * bundle.spacing_mm
                / (pitch * pitch)
                * t;
            splat_bundle(&bundle, per_pixel, sensor, dst);
        }
    }
}

/// Spread each passed ray of `bundle` (power `w` in pixel-irradiance units) over its footprint:
/// the quadrilateral on the film whose corners are the images of its launch cell's corners, each
/// estimated as the mean landing point of the four rays around it (so neighbouring footprints
/// share corners and tile the ghost without gaps or overlaps); at the bundle's rim a corner without
/// its four rays is the opposite corner mirrored through the ray's landing point. The footprint
/// is split into two triangles, each pixel centre inside taking density w / area (a shared edge's
/// centres go to one side only: the top-left rule); footprints under two pixels, or without a
/// corner, go bilinearly to the landing point.
fn splat_bundle(bundle: &Bundle, w: f64, sensor: &SensorGeometry, dst: &mut [f32]) {
    let (rows, cols, n) = (sensor.rows, sensor.cols, bundle.n);
    let pitch = sensor.pixel_pitch_mm;
    // Film mm -> fractional pixel coordinates of pixel centres.
    let to_px = |p: [f64; 2]| {
        [
            p[0] / pitch + cols as f64 / 2.0 - 0.5,
            p[1] / pitch + rows as f64 / 2.0 - 0.5,
        ]
    };
    let at = |r: usize, c: usize| -> Option<[f64; 2]> {
        let p = bundle.landing_mm[r * n + c];
        p[0].is_finite().then(|| to_px(p))
    };
    // Corner (i, j), 0..=n: between rays (i - 1, j - 1), (i - 1, j), (i, j - 1), (i, j).
    let corner = |i: usize, j: usize| -> Option<[f64; 2]> {
        if i == 0 || j == 0 || i > n - 1 || j > n - 1 {
            return None;
        }
        let (a, b, c, d) = (at(i - 1, j - 1)?, at(i - 1, j)?, at(i, j - 1)?, at(i, j)?);
        Some([
            0.25 * (a[0] + b[0] + c[0] + d[0]),
            0.25 * (a[1] + b[1] + c[1] + d[1]),
        ])
    };
    // A footprint larger than this many pixels is a fold of the ray map (neighbouring rays
    // separated by a caustic): its power goes to the landing point.
    let max_area_px = 0.25 * (rows * cols) as f64;
    for r in 0..n {
        for c in 0..n {
            let Some(q) = at(r, c) else { continue };
            // Corners in cyclic order: (r, c), (r, c + 1), (r + 1, c + 1), (r + 1, c).
            let k = [
                corner(r, c),
                corner(r, c + 1),
                corner(r + 1, c + 1),
                corner(r + 1, c),
            ];
            let mirror = |o: Option<[f64; 2]>| o.map(|o| [2.0 * q[0] - o[0], 2.0 * q[1] - o[1]]);
            let quad = [
                k[0].or_else(|| mirror(k[2])),
                k[1].or_else(|| mirror(k[3])),
                k[2].or_else(|| mirror(k[0])),
                k[3].or_else(|| mirror(k[1])),
            ];
            let [Some(c0), Some(c1), Some(c2), Some(c3)] = quad else {
                splat_point(q, w, rows, cols, dst);
                continue;
            };
            let area = (tri_area2(c0, c1, c2).abs() + tri_area2(c0, c2, c3).abs()) * 0.5;
            if !(area >= 2.0 && area <= max_area_px) {
                splat_point(q, w, rows, cols, dst);
                continue;
            }
            let density = (w / area) as f32;
            fill_triangle(c0, c1, c2, density, rows, cols, dst);
            fill_triangle(c0, c2, c3, density, rows, cols, dst);
        }
    }
}

/// Twice the signed area of triangle (a, b, c).
fn tri_area2(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

/// Add `density` at every pixel centre (integer coordinates) inside triangle (a, b, c); a centre
/// on an edge counts when the edge is a "top-left" one of the counter-clockwise triangle (the
/// rasterization fill rule, e.g. Direct3D's), so two triangles sharing that edge never both take
/// it.
fn fill_triangle(
    a: [f64; 2],
    b: [f64; 2],
    c: [f64; 2],
    density: f32,
    rows: usize,
    cols: usize,
    dst: &mut [f32],
) {
    let (a, b, c) = if tri_area2(a, b, c) < 0.0 {
        (a, c, b)
    } else {
        (a, b, c)
    };
    if tri_area2(a, b, c) == 0.0 {
        return;
    }
    let x0 = a[0].min(b[0]).min(c[0]).ceil().max(0.0);
    let x1 = a[0].max(b[0]).max(c[0]).floor().min(cols as f64 - 1.0);
    let y0 = a[1].min(b[1]).min(c[1]).ceil().max(0.0);
    let y1 = a[1].max(b[1]).max(c[1]).floor().min(rows as f64 - 1.0);
    if x0 > x1 || y0 > y1 {
        return;
    }
    // Edge p -> q of the counter-clockwise triangle (y down or up: only consistency matters).
    let top_left = |p: [f64; 2], q: [f64; 2]| {
        let (dx, dy) = (q[0] - p[0], q[1] - p[1]);
        dy < 0.0 || (dy == 0.0 && dx > 0.0)
    };
    let edges = [
        (a, b, top_left(a, b)),
        (b, c, top_left(b, c)),
        (c, a, top_left(c, a)),
    ];
    for py in y0 as usize..=y1 as usize {
        let row = &mut dst[py * cols..(py + 1) * cols];
        for (px, d) in row
            .iter_mut()
            .enumerate()
            .take(x1 as usize + 1)
            .skip(x0 as usize)
        {
            let p = [px as f64, py as f64];
            let inside = edges.iter().all(|&(e0, e1, tl)| {
                let e = tri_area2(e0, e1, p);
                e > 0.0 || (e == 0.0 && tl)
            });
            if inside {
                *d += density;
            }
        }
    }
}

/// Add `w` bilinearly at fractional pixel position `q` (the part off the sensor is lost).
fn splat_point(q: [f64; 2], w: f64, rows: usize, cols: usize, dst: &mut [f32]) {
    let (x0, y0) = (q[0].floor(), q[1].floor());
    let (fx, fy) = (q[0] - x0, q[1] - y0);
    for (dy, wy) in [(0.0, 1.0 - fy), (1.0, fy)] {
        for (dx, wx) in [(0.0, 1.0 - fx), (1.0, fx)] {
            let (x, y) = (x0 + dx, y0 + dy);
            if x >= 0.0 && y >= 0.0 && x < cols as f64 && y < rows as f64 {
                dst[y as usize * cols + x as usize] += (w * wx * wy) as f32;
            }
        }
    }
}

impl TracedLens {
    /// The direction of travel (lens coordinates, z = 1) of a source at infinity whose 550 nm
    /// chief ray lands on the film of `cam` at (`x_mm`, `y_mm`): secant iteration on the field
    /// angle's tangent along the point's azimuth (the lens is rotationally symmetric).
    pub fn direction_to_film_point(
        &self,
        cam: &LensCamera,
        x_mm: f64,
        y_mm: f64,
    ) -> Result<[f64; 3]> {
        let h = x_mm.hypot(y_mm);
        if h < 1e-12 {
            return Ok([0.0, 0.0, 1.0]);
        }
        let g = |t: f64| -> Result<f64> {
            Ok(self.chief_image_point_mm(cam, ObjectField::Infinity { tan_theta: t })?[0] - h)
        };
        let (mut t0, mut t1) = (h / self.efl_mm, 1.01 * h / self.efl_mm);
        let (mut g0, mut g1) = (g(t0)?, g(t1)?);
        for _ in 0..40 {
            if g1.abs() < 1e-10 * h.max(1.0) || g1 == g0 {
                break;
            }
            let t2 = t1 - g1 * (t1 - t0) / (g1 - g0);
            (t0, g0) = (t1, g1);
            t1 = t2;
            g1 = g(t1)?;
        }
        if !(g1.abs() < 1e-6) {
            return Err(lens_err(
                "blur.ghosts",
                format!(
                    "{}: no field angle images onto film height {h} mm",
                    self.what
                ),
            ));
        }
        Ok([t1 * x_mm / h, t1 * y_mm / h, 1.0])
    }

    /// Add the lens ghosts of `g` to `image` (a sensor-plane irradiance image, W/(m^2 nm), centred
    /// on the optical axis, after distortion and relative illumination) for the lens focused as
    /// `cam`. Sources: `g.sources`, or the regions of [`detect_sources`] as points at infinity in
    /// the direction of [`TracedLens::direction_to_film_point`] with their power per band (a
    /// region whose direction cannot be found, e.g. beyond the lens's field, is skipped). The
    /// ghosts are splatted ([`ghost_irradiance`]) on a raster `k` = ceil(longer side /
    /// `g.raster_px`) times coarser than the image and added with bilinear interpolation of the
    /// irradiance (k = 1: directly). Returns the sources used.
    pub fn add_ghosts(
        &self,
        cam: &LensCamera,
        g: &Ghosts,
        image: &mut SpectralImage,
    ) -> Result<Vec<GhostSource>> {
        let sources: Vec<GhostSource> = if g.sources.is_empty() {
            detect_sources(image, g.threshold, g.max_sources)
                .into_iter()
                .filter_map(|d| {
                    self.direction_to_film_point(cam, d.x_mm, d.y_mm)
                        .ok()
                        .map(|direction| GhostSource {
                            direction,
                            strength: SourceStrength::ImagePower(d.power_w_nm),
                        })
                })
                .collect()
        } else {
            g.sources.clone()
        };
        if sources.is_empty() {
            return Ok(sources);
        }
        let (rows, cols) = (image.rows, image.cols);
        let k = rows.max(cols).div_ceil(g.raster_px).max(1);
        let raster = SensorGeometry {
            rows: rows.div_ceil(k),
            cols: cols.div_ceil(k),
            pixel_pitch_mm: image.sample_spacing_m * 1e3 * k as f64,
            film_z_mm: cam.film_z_mm(),
        };
        let wavelengths = image.grid.wavelengths_nm();
        let plane = rows * cols;
        let lens = &self.lens;
        image
            .data
            .par_chunks_mut(plane)
            .zip(wavelengths.par_iter())
            .enumerate()
            .for_each(|(b, (dst, &wl))| {
                if k == 1 {
                    splat_band(lens, &g.coatings, &raster, &sources, b, wl, g.rays, dst);
                    return;
                }
                let mut coarse = vec![0.0f32; raster.rows * raster.cols];
                splat_band(
                    lens,
                    &g.coatings,
                    &raster,
                    &sources,
                    b,
                    wl,
                    g.rays,
                    &mut coarse,
                );
                add_upsampled(&coarse, &raster, k, rows, cols, dst);
            });
        Ok(sources)
    }
}

/// Add the coarse raster (`k` times the image's pitch, both centred on the axis) to the image
/// plane by bilinear interpolation of the irradiance between coarse sample centres (zero beyond
/// the outermost ones' half cell).
fn add_upsampled(
    coarse: &[f32],
    raster: &SensorGeometry,
    k: usize,
    rows: usize,
    cols: usize,
    dst: &mut [f32],
) {
    let (cr, cc) = (raster.rows, raster.cols);
    let at = |r: isize, c: isize| -> f32 {
        if r >= 0 && c >= 0 && (r as usize) < cr && (c as usize) < cc {
            coarse[r as usize * cc + c as usize]
        } else {
            0.0
        }
    };
    for r in 0..rows {
        // Fine centre offset in coarse samples, then the coarse fractional index.
        let y = centre_offset(r, rows) / k as f64 + cr as f64 / 2.0 - 0.5;
        let (y0, fy) = (y.floor(), (y - y.floor()) as f32);
        for c in 0..cols {
            let x = centre_offset(c, cols) / k as f64 + cc as f64 / 2.0 - 0.5;
            let (x0, fx) = (x.floor(), (x - x.floor()) as f32);
            let (yi, xi) = (y0 as isize, x0 as isize);
            let v = (at(yi, xi) * (1.0 - fx) + at(yi, xi + 1) * fx) * (1.0 - fy)
                + (at(yi + 1, xi) * (1.0 - fx) + at(yi + 1, xi + 1) * fx) * fy;
            dst[r * cols + c] += v;
        }
    }
}
