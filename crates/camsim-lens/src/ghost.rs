//! Two-bounce lens ghosts: the light that reflects back at one surface and forward again at an
//! earlier one before it reaches the film (Hullin, Eisemann, Seidel and Lee, "Physically-based
//! real-time lens flare rendering", ACM SIGGRAPH 2011, sec. 3: a ghost per ordered pair of
//! surfaces, traced as a sequence of refractions and two reflections).
//!
//! - [`Lens::ghost_paths`]: the N (N - 1) / 2 paths of a lens with N refracting surfaces (the stop
//!   is no reflector): for surfaces `back` > `front`, transmit to `back`, reflect there, go back
//!   to `front`, reflect there, transmit to the film.
//! - [`Coating`] and [`Lens::surface_reflectance`]: the reflectance of each surface at normal
//!   incidence, uncoated (Fresnel), with a single quarter-wave layer, or a given constant.
//! - [`Lens::trace_ghost`]: one real ray through a path (the refraction and aperture code of
//!   [`crate::trace`] plus [`crate::trace::reflect`]); [`Lens::trace_bundle`]: a collimated bundle
//!   on a square grid over the front element to the film, each ray's landing point;
//!   [`Lens::path_transmission`]: the fraction of a ray's power that the path's reflections and
//!   transmissions leave (R_back R_front times the product of 1 - R over the crossings).
//!
//! Approximations: reflectances at normal incidence (the ghost rays meet the surfaces within a
//! few tens of degrees; Fresnel reflectance of glass changes by < 10 % of itself below 30
//! degrees, Born & Wolf sec. 1.5.3); no polarization; no absorption in the glass; a coating only
//! on surfaces with air on one side (cemented surfaces are uncoated); ghosts of more than two
//! reflections and reflections at the sensor or a filter not in the prescription are left out.

use crate::prescription::Lens;
use crate::trace::{reflect, Blocked, Ray};

/// Reflectance model of a refracting surface at normal incidence.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Coating {
    /// Bare interface: Fresnel reflectance ((n1 - n2) / (n1 + n2))^2 from the two media's
    /// indices at the wavelength (Hecht, Optics, 5th ed., eq. 4.67).
    Uncoated,
    /// One layer of index `layer_index`, a quarter wave thick at `design_wavelength_nm`, on each
    /// air-glass surface (cemented surfaces stay uncoated).
    QuarterWave {
        /// Wavelength at which the layer is a quarter wave thick (optical thickness), nm.
        design_wavelength_nm: f64,
        /// Refractive index of the layer (MgF2: 1.38).
        layer_index: f64,
    },
    /// The same reflectance at every wavelength (fraction in [0, 1)).
    Reflectance(f64),
}

impl Coating {
    /// Reflectance at normal incidence of an interface between media of index `n0` and `n2` at
    /// `wavelength_nm`.
    ///
    /// Single layer of index n1 and phase thickness delta = 2 pi n1 d / lambda (a quarter wave at
    /// lambda_0: delta = (pi / 2) lambda_0 / lambda): with r01 = (n0 - n1) / (n0 + n1) and
    /// r12 = (n1 - n2) / (n1 + n2), R = (r01^2 + r12^2 + 2 r01 r12 cos 2 delta) /
    /// (1 + r01^2 r12^2 + 2 r01 r12 cos 2 delta) (Hecht, Optics, 5th ed., sec. 9.7.2; Macleod,
    /// Thin-Film Optical Filters, 4th ed., sec. 3.2), which at lambda_0 is
    /// ((n0 n2 - n1^2) / (n0 n2 + n1^2))^2.
    pub fn reflectance(&self, n0: f64, n2: f64, wavelength_nm: f64) -> f64 {
        match *self {
            Coating::Uncoated => fresnel_normal(n0, n2),
            Coating::Reflectance(r) => r,
            Coating::QuarterWave {
                design_wavelength_nm,
                layer_index: n1,
            } => {
                let air_side = (n0 - 1.0).abs() < 1e-9 || (n2 - 1.0).abs() < 1e-9;
                if !air_side {
                    return fresnel_normal(n0, n2);
                }
                let r01 = (n0 - n1) / (n0 + n1);
                let r12 = (n1 - n2) / (n1 + n2);
                let two_delta = std::f64::consts::PI * design_wavelength_nm / wavelength_nm;
                let x = 2.0 * r01 * r12 * two_delta.cos();
                (r01 * r01 + r12 * r12 + x) / (1.0 + r01 * r01 * r12 * r12 + x)
            }
        }
    }

    /// A message when the model is impossible (a reflectance outside [0, 1), a layer index below
    /// 1, a design wavelength that is not > 0).
    pub fn check(&self) -> Result<(), String> {
        match *self {
            Coating::Uncoated => Ok(()),
            Coating::Reflectance(r) if (0.0..1.0).contains(&r) => Ok(()),
            Coating::Reflectance(r) => Err(format!("reflectance {r} is not in [0, 1)")),
            Coating::QuarterWave {
                design_wavelength_nm,
                layer_index,
            } => {
                if !(design_wavelength_nm.is_finite() && design_wavelength_nm > 0.0) {
                    return Err(format!(
                        "design wavelength {design_wavelength_nm} nm is not > 0"
                    ));
                }
                if !(layer_index.is_finite() && layer_index >= 1.0) {
                    return Err(format!("layer index {layer_index} is not >= 1"));
                }
                Ok(())
            }
        }
    }
}

/// Fresnel reflectance at normal incidence between indices `n1` and `n2`:
/// ((n1 - n2) / (n1 + n2))^2 (Hecht, Optics, 5th ed., eq. 4.67).
pub fn fresnel_normal(n1: f64, n2: f64) -> f64 {
    let r = (n1 - n2) / (n1 + n2);
    r * r
}

/// A two-bounce ghost: light reflects back at surface `back`, then forward at surface `front`
/// (0-based surface indices, `front` < `back`, neither the stop).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct GhostPath {
    /// The later surface, where light first reflects (back toward the object).
    pub back: usize,
    /// The earlier surface, where it reflects forward again.
    pub front: usize,
}

/// What happens at one surface along a path.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Event {
    /// Cross travelling toward +z.
    Forward,
    /// Cross travelling toward -z.
    Backward,
    /// Reflect, arriving toward +z (the light stays in the medium before the surface).
    ReflectForward,
    /// Reflect, arriving toward -z (the light stays in the medium after the surface).
    ReflectBackward,
}

/// A collimated bundle traced through one path to the film ([`Lens::trace_bundle`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Bundle {
    /// Rays per side of the square launch grid.
    pub n: usize,
    /// Grid step on the first vertex plane (z = 0), mm; each ray carries the power through one
    /// cell, spacing^2 mm^2 of that plane.
    pub spacing_mm: f64,
    /// Rays launched (the grid cells whose centre lies in the launch disk).
    pub launched: usize,
    /// Rays that reached the film.
    pub passed: usize,
    /// Film landing point (x, y) of each grid ray, mm, row-major (row: y); NaN where the ray was
    /// not launched or was blocked.
    pub landing_mm: Vec<[f64; 2]>,
}

impl Bundle {
    /// Fraction of the launched rays that reached the film.
    pub fn passed_fraction(&self) -> f64 {
        if self.launched == 0 {
            0.0
        } else {
            self.passed as f64 / self.launched as f64
        }
    }

    /// Area of the launch disk on the first vertex plane as the grid counts it, mm^2.
    pub fn launch_area_mm2(&self) -> f64 {
        self.launched as f64 * self.spacing_mm * self.spacing_mm
    }
}

impl Lens {
    /// The two-bounce ghost paths: every pair of refracting surfaces (the stop is no reflector),
    /// `back` > `front`, ordered by `back` then `front`; N (N - 1) / 2 of them for N refracting
    /// surfaces.
    pub fn ghost_paths(&self) -> Vec<GhostPath> {
        let refr: Vec<usize> = (0..self.surfaces.len())
            .filter(|&i| !self.surfaces[i].is_stop)
            .collect();
        let mut out = Vec::with_capacity(refr.len() * refr.len().saturating_sub(1) / 2);
        for (b, &back) in refr.iter().enumerate() {
            for &front in &refr[..b] {
                out.push(GhostPath { back, front });
            }
        }
        out
    }

    /// Reflectance of surface `i` at `wavelength_nm` with `coating` (0 for the stop).
    pub fn surface_reflectance(&self, i: usize, wavelength_nm: f64, coating: &Coating) -> f64 {
        if self.surfaces[i].is_stop {
            return 0.0;
        }
        coating.reflectance(
            self.index_before(i, wavelength_nm),
            self.surfaces[i].medium.index(wavelength_nm),
            wavelength_nm,
        )
    }

    /// The surfaces a path meets, in order, and what happens at each (`None`: the main image,
    /// every surface crossed forward once).
    fn events(&self, path: Option<GhostPath>) -> Vec<(usize, Event)> {
        let n = self.surfaces.len();
        match path {
            None => (0..n).map(|i| (i, Event::Forward)).collect(),
            Some(GhostPath { back, front }) => {
                let mut e: Vec<(usize, Event)> = (0..back).map(|i| (i, Event::Forward)).collect();
                e.push((back, Event::ReflectForward));
                e.extend((front + 1..back).rev().map(|i| (i, Event::Backward)));
                e.push((front, Event::ReflectBackward));
                e.extend((front + 1..n).map(|i| (i, Event::Forward)));
                e
            }
        }
    }

    /// Fraction of a ray's power left after path `path` (`None`: the main image) at
    /// `wavelength_nm`: the product of R over its two reflections and of 1 - R over every crossing
    /// of a refracting surface (energy conservation at a lossless interface, R + T = 1). Surface
    /// `i` has `coatings[i]` (missing entries: the last one; an empty slice: uncoated).
    pub fn path_transmission(
        &self,
        path: Option<GhostPath>,
        wavelength_nm: f64,
        coatings: &[Coating],
    ) -> f64 {
        let coat = |i: usize| {
            coatings
                .get(i)
                .or(coatings.last())
                .copied()
                .unwrap_or(Coating::Uncoated)
        };
        self.events(path)
            .into_iter()
            .map(|(i, e)| {
                let r = self.surface_reflectance(i, wavelength_nm, &coat(i));
                match e {
                    Event::Forward | Event::Backward => 1.0 - r,
                    Event::ReflectForward | Event::ReflectBackward => r,
                }
            })
            .product()
    }

    /// Trace `ray` (object space, toward +z) through `path` (`None`: the main image, as
    /// [`Lens::trace_forward`]) at `wavelength_nm`: the ray leaving the last surface toward the
    /// film. Every surface (the stop included, each time it is crossed) blocks rays outside its
    /// semi-aperture.
    pub fn trace_ghost(
        &self,
        path: Option<GhostPath>,
        ray: &Ray,
        wavelength_nm: f64,
    ) -> Result<Ray, Blocked> {
        let z = self.vertex_z_mm();
        let mut r = *ray;
        for (i, e) in self.events(path) {
            let s = &self.surfaces[i];
            let before = self.index_before(i, wavelength_nm);
            let after = s.medium.index(wavelength_nm);
            r = match e {
                Event::Forward => self.through_surface(i, s, z[i], &r, before, after)?,
                Event::Backward => self.through_surface(i, s, z[i], &r, after, before)?,
                Event::ReflectForward | Event::ReflectBackward => {
                    let (t, n) =
                        crate::trace::intersect(s, z[i], &r).ok_or(Blocked::Aperture(i))?;
                    let p = r.at(t);
                    if t < -1e-9 || p[0].hypot(p[1]) > s.semi_aperture_mm {
                        return Err(Blocked::Aperture(i));
                    }
                    Ray {
                        origin_mm: p,
                        direction: reflect(r.direction, n),
                    }
                }
            };
        }
        Ok(r)
    }

    /// A collimated bundle travelling along `direction` (toward +z; normalized here) traced
    /// through `path` (`None`: the main image) at `wavelength_nm` to the film plane z =
    /// `film_z_mm`. The rays start on an `n` x `n` grid of cell centres over the square around
    /// the launch disk on the first vertex plane: the front element's clear aperture widened by
    /// its largest sag times the beam's slope, so every ray that can meet the first surface inside
    /// its aperture is launched (Hullin et al. 2011 sec. 4.1: a ray grid over the entrance
    /// aperture).
    pub fn trace_bundle(
        &self,
        path: Option<GhostPath>,
        direction: [f64; 3],
        film_z_mm: f64,
        wavelength_nm: f64,
        n: usize,
    ) -> Bundle {
        let n = n.max(1);
        let l = (direction[0] * direction[0]
            + direction[1] * direction[1]
            + direction[2] * direction[2])
            .sqrt();
        let d = [direction[0] / l, direction[1] / l, direction[2] / l];
        let mut landing_mm = vec![[f64::NAN; 2]; n * n];
        if !(d[2] > 1e-9) || !film_z_mm.is_finite() {
            return Bundle {
                n,
                spacing_mm: 0.0,
                launched: 0,
                passed: 0,
                landing_mm,
            };
        }
        let s0 = &self.surfaces[0];
        let r0 = s0.semi_aperture_mm;
        let max_sag = (0..=16)
            .filter_map(|k| s0.sag_mm(r0 * k as f64 / 16.0))
            .fold(0.0f64, |m, v| m.max(v.abs()));
        let slope = d[0].hypot(d[1]) / d[2];
        let r_launch = r0 + max_sag * slope;
        let h = 2.0 * r_launch / n as f64;
        let z_start = -max_sag - 1.0;
        let (mut launched, mut passed) = (0usize, 0usize);
        for (k, out) in landing_mm.iter_mut().enumerate() {
            let (row, col) = (k / n, k % n);
            let x = -r_launch + (col as f64 + 0.5) * h;
            let y = -r_launch + (row as f64 + 0.5) * h;
            if x * x + y * y > r_launch * r_launch {
                continue;
            }
            launched += 1;
            let s = z_start / d[2];
            let ray = Ray {
                origin_mm: [x + s * d[0], y + s * d[1], z_start],
                direction: d,
            };
            let Ok(o) = self.trace_ghost(path, &ray, wavelength_nm) else {
                continue;
            };
            if !(o.direction[2] > 0.0) {
                continue;
            }
            if let Some(p) = o.at_z(film_z_mm) {
                if p[0].is_finite() && p[1].is_finite() {
                    *out = [p[0], p[1]];
                    passed += 1;
                }
            }
        }
        Bundle {
            n,
            spacing_mm: h,
            launched,
            passed,
            landing_mm,
        }
    }
}
