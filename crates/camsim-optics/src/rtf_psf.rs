//! Field PSFs, distortion and relative illumination from a ray-transfer function (RTF,
//! [`camsim_lens::Rtf`]) for the shift-variant blur (`blur = { method = "shift-variant",
//! rtf_file = "..." }`).
//!
//! An RTF holds no optical path, so no wavefront: Goossens et al. 2022 (Optics Express 30(13)
//! 24031, "Ray-transfer functions for camera simulation of 3D scenes with hidden lens design")
//! render PSFs and edge spread functions by tracing rays through the RTF in pbrt (pure ray optics,
//! checked against Zemax's geometric edge spread functions). This module does the same trace
//! without a renderer and adds diffraction:
//!
//! 1. Geometric spot. The film sits `dz` behind the RTF's input plane, where the on-axis spot of
//!    an object at the focus distance is smallest ([`RtfLens::focus_offset_mm`], autofocus). For an object point of ideal
//!    image height h (direction tan = -h / v at infinity, or the point -h d / v at distance d), a
//!    grid of points Q over the pass plane (the plane where the RTF's pass ellipse is defined)
//!    stands for the pupil; for each Q the film point P whose ray P -> Q leaves the RTF toward the
//!    object point is found by a chord Newton iteration (the 2 x 2 Jacobian of the miss against P
//!    taken once, at the chief ray). The ray must pass the ellipse at P. Its weight is the
//!    projected solid angle of the pupil patch seen from P, D^2 dA / rho^4 (the integrand of
//!    [`Rtf::irradiance`]: the cos^4 law of a plane patch), so the spot's total is the
//!    relative illumination's and the spot is the irradiance distribution of the point image. The
//!    landings, relative to the chief ray's (the ray through the ellipse's centre), are splatted
//!    bilinearly (energy-conserving) onto the fine kernel grid, normalized to unit sum.
//! 2. Diffraction. The pass ellipse is the pupil as seen from the film point: its semi-axes over
//!    the distance rho_c to its centre give the numerical apertures, tangential r_x / rho_c and
//!    radial r_y cos^2(theta_c) / rho_c (the cone foreshortened by the chief ray's tilt theta_c,
//!    and its pattern stretched by 1 / cos(theta_c) on the film). The incoherent OTF of an
//!    elliptical pupil is the circular pupil's (Goodman, Introduction to Fourier Optics, 3rd ed.,
//!    eq. 6-32) with the frequency scaled by each axis's cutoff 2 NA / lambda; the PSF is the
//!    spot's spectrum times this OTF, per wavelength (the RTF itself is fitted at one wavelength,
//!    so the geometric spot is the same at every band; only diffraction depends on lambda).
//!
//! Limits: geometric spot (x) diffraction is exact in the two limits (aberration-free: the Airy of
//! the ellipse; large aberrations: the geometric spot) and an approximation between them, where
//! the true PSF (the Fourier transform of the pupil with its aberration phase) is sharper than the
//! convolution. The RTF has no chromatic aberration (one wavelength fitted). The Jacobian of the
//! ray's miss against the film point is held constant over the pupil (its change across the pupil
//! is second order in the spot size). The relative illumination is [`Rtf::relative_illumination`]
//! on the input plane (the film of the infinity focus), also when the film is moved for a near
//! focus (the move is f^2 / d, 16 um at 1.2 m for f = 4.38 mm).

use crate::conv::Fft2;
use crate::error::{OpticsError, Result};
use crate::lens_maps::LensMaps;
use camsim_lens::Rtf;
use rayon::prelude::*;
use std::path::Path;

const KEY: &str = "blur.rtf_file";
/// Pupil samples across the pass ellipse's bounding box (each axis).
pub const PUPIL_SAMPLES: usize = 64;
/// Pupil samples per axis for the autofocus search.
const FOCUS_PUPIL_SAMPLES: usize = 24;
/// Relative illumination table: samples from the axis to the largest film height.
const RI_SAMPLES: usize = 129;
/// Integration grid of [`Rtf::relative_illumination`] (per axis): the midpoint rule's error from
/// the ellipse's rim is ~1e-4 at 256 (~1e-3 at 64).
pub const RI_GRID: usize = 256;

/// An RTF set up for the shift-variant blur.
#[derive(Debug, Clone)]
pub struct RtfLens {
    /// The ray-transfer function.
    pub rtf: Rtf,
    /// Focal length by the Abbe sine condition (as `camsim_scene3d::camera::ray_transfer_lens`), mm.
    pub focal_length_mm: f64,
    /// The f-number of the on-axis pass region: N = sqrt(pi / (4 Omega)), Omega its projected
    /// solid angle (a cone of half-angle a has Omega = pi sin^2 a = pi / (4 N^2)).
    pub f_number: f64,
    what: String,
}

/// One field point's PSF (fine grid) and its chief ray.
#[derive(Debug, Clone)]
pub struct FieldPsf {
    /// The chief ray's film landing (radial height), m.
    pub chief_height_m: f64,
    /// The geometric spot, `n` x `n` samples of `spacing_m`, row-major, rows tangential, columns
    /// radial (outward = increasing column), centred on the chief ray's landing; unit sum.
    pub spot: Vec<f64>,
    /// Spot side, samples (odd).
    pub n: usize,
    /// Sample spacing, m.
    pub spacing_m: f64,
    /// Weighted centroid of the landings relative to the chief ray (radial, tangential), m.
    pub centroid_m: [f64; 2],
    /// RMS radius of the landings about their centroid, m.
    pub rms_radius_m: f64,
    /// Radius about the chief ray that holds 99.5 % of the spot's weight, m.
    pub r995_m: f64,
    /// Numerical apertures of the pass ellipse seen from the film point (radial, tangential).
    pub na: [f64; 2],
}

/// The object point of a field.
#[derive(Debug, Clone, Copy)]
pub struct Field {
    /// Ideal (rectilinear) image height, mm.
    pub ideal_height_mm: f64,
    /// Thin-lens image distance of the optics model, mm (sets tan = -h / v).
    pub image_distance_mm: f64,
    /// Object distance from the RTF's output plane, mm (infinite allowed).
    pub object_distance_mm: f64,
}

impl RtfLens {
    /// Read an RTF file and check it against the optics config: its focal length within 2 % of
    /// `focal_length_mm`, its on-axis f-number within 2 % of `f_number` (the camera equation's).
    pub fn from_file(path: &Path, f_number: f64, focal_length_mm: f64) -> Result<RtfLens> {
        let rtf = Rtf::from_file(path).map_err(|e| OpticsError::config(KEY, e.to_string()))?;
        RtfLens::new(rtf, &path.display().to_string(), f_number, focal_length_mm)
    }

    /// Check `rtf` (`what` names it in errors); see [`Self::from_file`].
    pub fn new(rtf: Rtf, what: &str, f_number: f64, focal_length_mm: f64) -> Result<RtfLens> {
        let s = 0.02f64;
        let h = |s: f64| {
            rtf.trace([0.0, 0.0], [0.0, s, (1.0 - s * s).sqrt()])
                .map(|(p, _)| p[1])
        };
        let f_mm = match (h(0.0), h(s)) {
            (Some(a), Some(b)) if (b - a) / s > 0.0 => (b - a) / s,
            _ => {
                return Err(OpticsError::config(
                    KEY,
                    format!(
                    "{what}: no ray passes from the film centre near the axis (no focal length)"
                ),
                ))
            }
        };
        if ((f_mm - focal_length_mm) / focal_length_mm).abs() > 0.02 {
            return Err(OpticsError::config(
                KEY,
                format!("{what}: the RTF's focal length is {f_mm:.4} mm but focal_length_mm = {focal_length_mm}; set it within 2 %"),
            ));
        }
        let omega = rtf
            .irradiance(0.0, 256)
            .filter(|v| *v > 0.0 && v.is_finite());
        let n_rtf = match omega {
            Some(o) => (std::f64::consts::PI / (4.0 * o)).sqrt(),
            None => {
                return Err(OpticsError::config(
                    KEY,
                    format!("{what}: no light passes on the axis"),
                ))
            }
        };
        if ((n_rtf - f_number) / f_number).abs() > 0.02 {
            return Err(OpticsError::config(
                "f_number",
                format!("{what}: the RTF's on-axis pass region is an f/{n_rtf:.3} aperture but f_number = {f_number}; set f_number = {n_rtf:.2} (the camera equation uses it)"),
            ));
        }
        Ok(RtfLens {
            rtf,
            focal_length_mm: f_mm,
            f_number: n_rtf,
            what: what.to_string(),
        })
    }

    /// Film offset behind the input plane (mm) that focuses an object at `focus_distance_mm`
    /// (infinite allowed) from the RTF's output plane: the offset that minimizes the RMS radius of
    /// the on-axis spot (autofocus; golden-section search over +-0.2 mm, to 0.1 um). The RTF's
    /// input plane need not be the infinity focus: for the Pixel 4a file the best infinity focus
    /// lies 16.6 um behind it (the renderer's `raytransfer` camera focuses with
    /// [`Rtf::focus_offset_mm`], the object-space twin of this image-space criterion).
    pub fn focus_offset_mm(&self, focus_distance_mm: f64) -> Result<f64> {
        let f = Field {
            ideal_height_mm: 0.0,
            image_distance_mm: self.focal_length_mm,
            object_distance_mm: focus_distance_mm,
        };
        let mut failed = None;
        let rms = |dz: f64| match self.spot_with(&f, dz, FOCUS_PUPIL_SAMPLES) {
            Ok(s) => s.rms_radius_m,
            Err(e) => {
                failed.get_or_insert(e);
                f64::INFINITY
            }
        };
        let dz = camsim_lens::rtf::golden_section_min(rms, -0.2, 0.2, 1e-4);
        match failed {
            Some(e) => Err(e),
            None => Ok(dz),
        }
    }

    /// The RTF ray from film point `p` (mm, film `dz` mm behind the input plane) through pass-plane
    /// point `q`: the input-plane point and direction, and whether it passes.
    fn ray(&self, p: [f64; 2], q: [f64; 2], dz: f64) -> ([f64; 2], [f64; 3]) {
        // A film at or beyond the pass plane has no ray: NaN, which the callers' finiteness
        // checks turn into an error.
        self.rtf
            .film_ray(p, dz, q)
            .map_or(([f64::NAN; 2], [f64::NAN; 3]), |(pin, dir, _)| (pin, dir))
    }

    /// Miss of the ray P -> Q against the object point, in object-space angle (tan) units.
    fn miss(&self, p: [f64; 2], q: [f64; 2], dz: f64, f: &Field) -> [f64; 2] {
        let (pin, dir) = self.ray(p, q, dz);
        let (o, w) = self.rtf.transfer(pin, dir);
        let (tx, ty) = (w[0] / w[2], w[1] / w[2]);
        let target_tan = -f.ideal_height_mm / f.image_distance_mm;
        if f.object_distance_mm.is_finite() {
            let l = f.object_distance_mm;
            [(o[0] + tx * l) / l, (o[1] + ty * l) / l - target_tan]
        } else {
            [tx, ty - target_tan]
        }
    }

    /// The pass ellipse's centre in absolute pass-plane coordinates for film point `p` (the file's
    /// ellipse is given in the frame where the input-plane point lies on +y).
    fn pupil_frame(&self, p_in: [f64; 2]) -> Option<(camsim_lens::rtf::PassEllipse, f64, f64)> {
        let r = p_in[0].hypot(p_in[1]);
        let e = self.rtf.pass_region(r)?;
        let (c, s) = if r > 0.0 {
            (p_in[1] / r, p_in[0] / r)
        } else {
            (1.0, 0.0)
        };
        Some((e, c, s))
    }

    /// Inverse Jacobian of [`Self::miss`] against the film point: central differences, except
    /// within 0.05 mm of the axis, where the paraxial -1 / f is used: the RTF's polynomials are in
    /// the distance r from the axis and keep a constant exit tilt at r = 0 (1.2e-4 in the Pixel 4a
    /// file), so the ray map has a kink there and differences across it are meaningless.
    fn inverse_jacobian(
        &self,
        p: [f64; 2],
        q: [f64; 2],
        dz: f64,
        f: &Field,
    ) -> Option<[[f64; 2]; 2]> {
        if p[0].hypot(p[1]) < 0.05 {
            let fl = self.focal_length_mm;
            return Some([[-fl, 0.0], [0.0, -fl]]);
        }
        inverse(&self.jacobian(p, q, dz, f))
    }

    /// Jacobian of [`Self::miss`] against the film point (central differences).
    fn jacobian(&self, p: [f64; 2], q: [f64; 2], dz: f64, f: &Field) -> [[f64; 2]; 2] {
        let e = 1e-4;
        let mx = [
            self.miss([p[0] + e, p[1]], q, dz, f),
            self.miss([p[0] - e, p[1]], q, dz, f),
        ];
        let my = [
            self.miss([p[0], p[1] + e], q, dz, f),
            self.miss([p[0], p[1] - e], q, dz, f),
        ];
        [
            [
                (mx[0][0] - mx[1][0]) / (2.0 * e),
                (my[0][0] - my[1][0]) / (2.0 * e),
            ],
            [
                (mx[0][1] - mx[1][1]) / (2.0 * e),
                (my[0][1] - my[1][1]) / (2.0 * e),
            ],
        ]
    }

    /// Solve miss(P, q) = 0 for P by the chord method with inverse Jacobian `ji`.
    fn solve(
        &self,
        mut p: [f64; 2],
        q: impl Fn([f64; 2]) -> Option<[f64; 2]>,
        dz: f64,
        f: &Field,
        ji: &[[f64; 2]; 2],
    ) -> Option<[f64; 2]> {
        // Off the axis the chord steps shrink by about the distortion's change over the spot and
        // converge in a few steps (to 1e-8 mm). At the axis the RTF's kink (see
        // `inverse_jacobian`) leaves a ring of near-solutions and a tangential residue: there
        // the steps stop after 12, which is the first-order landing f x (angular aberration).
        for _ in 0..12 {
            let m = self.miss(p, q(p)?, dz, f);
            let step = [
                ji[0][0] * m[0] + ji[0][1] * m[1],
                ji[1][0] * m[0] + ji[1][1] * m[1],
            ];
            p = [p[0] - step[0], p[1] - step[1]];
            if step[0].hypot(step[1]) < 1e-8 {
                break;
            }
        }
        p.iter().all(|v| v.is_finite()).then_some(p)
    }

    /// The chief ray's film point (mm, on +y for a field on +y) and its pupil point.
    fn chief(&self, f: &Field, dz: f64) -> Result<([f64; 2], [f64; 2])> {
        let centre = |p: [f64; 2]| -> Option<[f64; 2]> {
            let (pin, _) = self.ray(p, p, dz);
            let (e, c, s) = self.pupil_frame(pin)?;
            Some([
                e.center_mm[0] * c + e.center_mm[1] * s,
                -e.center_mm[0] * s + e.center_mm[1] * c,
            ])
        };
        let p0 = [
            0.0,
            f.ideal_height_mm * self.focal_length_mm / f.image_distance_mm,
        ];
        let fail = || {
            OpticsError::config(
                KEY,
                format!(
                    "{}: no chief ray for the field at ideal image height {:.4} mm",
                    self.what, f.ideal_height_mm
                ),
            )
        };
        let mut q = centre(p0).ok_or_else(fail)?;
        let ji = self.inverse_jacobian(p0, q, dz, f).ok_or_else(fail)?;
        // Fixed point: the film point for the pupil point q, then q at that film point. On the
        // axis the ellipse's frame (its azimuth) is undefined: the axial frame is kept there.
        let mut p = p0;
        for round in 0..3 {
            p = self.solve(p, |_| Some(q), dz, f, &ji).ok_or_else(fail)?;
            if round < 2 && f.ideal_height_mm > 0.0 {
                q = centre(p).ok_or_else(fail)?;
            }
        }
        Ok((p, q))
    }

    /// The chief ray's film height for a field, mm.
    pub fn chief_height_mm(&self, f: &Field, dz: f64) -> Result<f64> {
        self.chief(f, dz).map(|(p, _)| p[1])
    }

    /// The geometric spot of field `f` with the film `dz` mm behind the input plane, on an `n` x
    /// `n` grid (n odd) of `spacing_m` centred on the chief ray.
    pub fn field_psf(&self, f: &Field, dz: f64, spacing_m: f64, n: usize) -> Result<FieldPsf> {
        Ok(self.field_spot(f, dz)?.psf(spacing_m, n))
    }

    /// The ray landings of field `f` (module docs, step 1).
    pub fn field_spot(&self, f: &Field, dz: f64) -> Result<Spot> {
        self.spot_with(f, dz, PUPIL_SAMPLES)
    }

    /// [`Self::field_spot`] with `m` x `m` pupil samples.
    fn spot_with(&self, f: &Field, dz: f64, m: usize) -> Result<Spot> {
        let (pc, qc) = self.chief(f, dz)?;
        let ji = self.inverse_jacobian(pc, qc, dz, f).ok_or_else(|| {
            OpticsError::config(
                KEY,
                format!("{}: singular ray map at the chief ray", self.what),
            )
        })?;
        let (pin, _) = self.ray(pc, qc, dz);
        let (e, c, s) = self
            .pupil_frame(pin)
            .ok_or_else(|| OpticsError::config(KEY, format!("{}: no pass region", self.what)))?;
        let d = self.rtf.pass_plane_distance_mm + dz;
        // Pupil grid over the ellipse's bounding box (5 % margin: the pass region moves a little
        // with the landing point), in the ellipse's frame, turned to absolute coordinates.
        let (ax, ay) = (1.05 * e.radii_mm[0], 1.05 * e.radii_mm[1]);
        let da = (2.0 * ax / m as f64) * (2.0 * ay / m as f64);
        let mut hits: Vec<([f64; 2], f64)> = Vec::with_capacity(m * m);
        for i in 0..m {
            for k in 0..m {
                let u = e.center_mm[0] + ax * (-1.0 + (2 * i + 1) as f64 / m as f64);
                let v = e.center_mm[1] + ay * (-1.0 + (2 * k + 1) as f64 / m as f64);
                let q = [u * c + v * s, -u * s + v * c];
                let Some(p) = self.solve(pc, |_| Some(q), dz, f, &ji) else {
                    continue;
                };
                let (pin, dir) = self.ray(p, q, dz);
                let Some((ep, _, _)) = self.pupil_frame(pin) else {
                    continue;
                };
                if !self.rtf.inside(&ep, pin, dir) {
                    continue;
                }
                let rho2 = (q[0] - p[0]).powi(2) + (q[1] - p[1]).powi(2) + d * d;
                hits.push(([p[1] - pc[1], -(p[0] - pc[0])], d * d / (rho2 * rho2) * da));
            }
        }
        let total: f64 = hits.iter().map(|h| h.1).sum();
        if hits.len() < 16 || total.is_nan() || total <= 0.0 {
            return Err(OpticsError::config(
                KEY,
                format!(
                    "{}: no ray of the field at {:.4} mm passes",
                    self.what, f.ideal_height_mm
                ),
            ));
        }
        let cen = hits.iter().fold([0.0, 0.0], |a, (p, w)| {
            [a[0] + p[0] * w / total, a[1] + p[1] * w / total]
        });
        let var = hits
            .iter()
            .map(|(p, w)| ((p[0] - cen[0]).powi(2) + (p[1] - cen[1]).powi(2)) * w)
            .sum::<f64>()
            / total;
        let mut radii: Vec<(f64, f64)> = hits.iter().map(|(p, w)| (p[0].hypot(p[1]), *w)).collect();
        radii.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut acc = 0.0;
        let r995 = radii.iter().find(|(_, w)| {
            acc += w;
            acc >= 0.995 * total
        });
        let r995_m = r995.map(|r| r.0).unwrap_or(0.0) * 1e-3;
        // Numerical apertures of the pass ellipse seen from the chief ray's film point.
        let rho_c = ((qc[0] - pc[0]).powi(2) + (qc[1] - pc[1]).powi(2) + d * d).sqrt();
        let cos_t = d / rho_c;
        let na = [
            e.radii_mm[1] * cos_t * cos_t / rho_c.hypot(e.radii_mm[1]),
            e.radii_mm[0] / rho_c.hypot(e.radii_mm[0]),
        ];
        Ok(Spot {
            chief_height_m: pc[1] * 1e-3,
            hits: hits
                .into_iter()
                .map(|(p, w)| ([p[0] * 1e-3, p[1] * 1e-3], w / total))
                .collect(),
            centroid_m: [cen[0] * 1e-3, cen[1] * 1e-3],
            rms_radius_m: var.sqrt() * 1e-3,
            r995_m,
            na,
        })
    }
}

/// The ray landings of one field point.
#[derive(Debug, Clone)]
pub struct Spot {
    /// The chief ray's film landing (radial height), m.
    pub chief_height_m: f64,
    /// Landings relative to the chief ray's (radial, tangential), m, and weights (unit sum).
    pub hits: Vec<([f64; 2], f64)>,
    /// Weighted centroid of the landings relative to the chief ray (radial, tangential), m.
    pub centroid_m: [f64; 2],
    /// RMS radius of the landings about their centroid, m.
    pub rms_radius_m: f64,
    /// Radius about the chief ray that holds 99.5 % of the spot's weight, m.
    pub r995_m: f64,
    /// Numerical apertures of the pass ellipse seen from the film point (radial, tangential).
    pub na: [f64; 2],
}

impl Spot {
    /// The landings splatted bilinearly (energy-conserving) on an `n` x `n` grid (n odd) of
    /// `spacing_m` centred on the chief ray.
    pub fn psf(&self, spacing_m: f64, n: usize) -> FieldPsf {
        // Bilinear splat onto the grid (columns radial, rows tangential).
        let mut spot = vec![0.0; n * n];
        let h = (n / 2) as f64;

        for (p, w) in &self.hits {
            let (x, y) = (p[0] / spacing_m + h, p[1] / spacing_m + h);
            let (x0, y0) = (x.floor(), y.floor());
            let (fx, fy) = (x - x0, y - y0);
            for (dy, wy) in [(0, 1.0 - fy), (1, fy)] {
                for (dx, wx) in [(0, 1.0 - fx), (1, fx)] {
                    let (cx, cy) = (x0 as isize + dx, y0 as isize + dy);
                    if cx >= 0 && cy >= 0 && (cx as usize) < n && (cy as usize) < n {
                        spot[cy as usize * n + cx as usize] += w * wx * wy;
                    }
                }
            }
        }
        FieldPsf {
            chief_height_m: self.chief_height_m,
            spot,
            n,
            spacing_m,
            centroid_m: self.centroid_m,
            rms_radius_m: self.rms_radius_m,
            r995_m: self.r995_m,
            na: self.na,
        }
    }
}

impl RtfLens {
    /// The geometric spot convolved with the diffraction PSF of the pass ellipse at each
    /// wavelength (module docs, step 2): `n` x `n` f32 kernels, not renormalized (each sums to the
    /// energy the window holds, <= 1).
    pub fn with_diffraction(&self, fp: &FieldPsf, wavelengths_nm: &[f64]) -> Vec<Vec<f32>> {
        let n = fp.n;
        // Padding: the Airy's far rings wrap around the FFT period; twice the kernel keeps the
        // wrapped part under the kernel's own truncation.
        let m = crate::wavefront::fast_fft_len(2 * n);
        let fft = Fft2::new(m, m);
        let mut plane = vec![0.0; m * m];
        for r in 0..n {
            plane[r * m..r * m + n].copy_from_slice(&fp.spot[r * n..(r + 1) * n]);
        }
        let spec = fft.forward(&plane);
        let nc = m / 2 + 1;
        wavelengths_nm
            .iter()
            .map(|wl| {
                let lam_m = wl * 1e-9;
                // Cutoffs 2 NA / lambda (cycles per m) along columns (radial) and rows (tangential).
                let (cx, cy) = (2.0 * fp.na[0] / lam_m, 2.0 * fp.na[1] / lam_m);
                let df = 1.0 / (m as f64 * fp.spacing_m);
                let mut s = spec.clone();
                for c in 0..nc {
                    let fx = c as f64 * df;
                    for r in 0..m {
                        let fy = (if r <= m / 2 {
                            r as f64
                        } else {
                            r as f64 - m as f64
                        }) * df;
                        let rho = ((fx / cx).powi(2) + (fy / cy).powi(2)).sqrt();
                        // Goodman eq. 6-32: the diffraction-limited OTF of a circular pupil.
                        let otf = if rho >= 1.0 {
                            0.0
                        } else {
                            2.0 / std::f64::consts::PI
                                * (rho.acos() - rho * (1.0 - rho * rho).sqrt())
                        };
                        s[c * m + r] *= otf;
                    }
                }
                let out = fft.inverse(s);
                // The spot lies in the plane's first n x n samples (its centre at (n/2, n/2));
                // the Airy's spill outside that window is the kernel's truncation.
                let mut k = vec![0.0f32; n * n];
                for r in 0..n {
                    for (kv, v) in k[r * n..(r + 1) * n].iter_mut().zip(&out[r * m..r * m + n]) {
                        *kv = v.max(0.0) as f32;
                    }
                }
                k
            })
            .collect()
    }

    /// Distortion (ideal -> chief-ray film height) out to `out_half_diag_m` and the relative
    /// illumination table ([`Rtf::relative_illumination`]) for the shift-variant stage.
    pub fn maps(
        &self,
        image_distance_mm: f64,
        object_distance_mm: f64,
        dz: f64,
        out_half_diag_m: f64,
    ) -> Result<LensMaps> {
        let n_table = 48;
        let ideal_mm: Vec<f64> = (0..=n_table)
            .map(|i| 1.1 * out_half_diag_m * 1e3 * i as f64 / n_table as f64)
            .collect();
        let chief: Vec<Result<f64>> = ideal_mm
            .par_iter()
            .map(|h| {
                if *h == 0.0 {
                    Ok(0.0)
                } else {
                    self.chief_height_mm(
                        &Field {
                            ideal_height_mm: *h,
                            image_distance_mm,
                            object_distance_mm,
                        },
                        dz,
                    )
                }
            })
            .collect();
        let n_ok = chief.iter().take_while(|r| r.is_ok()).count();
        if n_ok < 3 {
            return Err(chief
                .into_iter()
                .find_map(|r| r.err())
                .unwrap_or_else(|| OpticsError::config(KEY, "no chief ray passes")));
        }
        let ideal_m: Vec<f64> = ideal_mm[..n_ok].iter().map(|h| h * 1e-3).collect();
        let real_m: Vec<f64> = chief
            .into_iter()
            .take(n_ok)
            .map(|r| r.unwrap_or(0.0) * 1e-3)
            .collect();
        if real_m
            .windows(2)
            .any(|p| p[1].partial_cmp(&p[0]) != Some(std::cmp::Ordering::Greater))
        {
            return Err(OpticsError::config(
                KEY,
                format!(
                    "{}: the chief-ray image height does not grow with field height",
                    self.what
                ),
            ));
        }
        let r_max_m = 1.05 * out_half_diag_m;
        let ri_height_m: Vec<f64> = (0..RI_SAMPLES)
            .map(|i| r_max_m * i as f64 / (RI_SAMPLES - 1) as f64)
            .collect();
        let h_mm: Vec<f64> = ri_height_m.iter().map(|h| h * 1e3).collect();
        let ri: Vec<f64> = self
            .rtf
            .relative_illumination(&h_mm, RI_GRID)
            .into_iter()
            .map(|v| v.unwrap_or(0.0))
            .collect();
        Ok(LensMaps {
            ideal_m,
            real_m,
            ri_height_m,
            ri,
        })
    }
}

fn inverse(j: &[[f64; 2]; 2]) -> Option<[[f64; 2]; 2]> {
    let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
    if !(det.abs() > 0.0 && det.is_finite()) {
        return None;
    }
    Some([
        [j[1][1] / det, -j[0][1] / det],
        [-j[1][0] / det, j[0][0] / det],
    ])
}

/// What the shift-variant stage takes from an RTF: the kernel side, the fine field kernels per
/// field height (outer) and band (inner), `k s` x `k s` samples of `spacing_m / s`.
pub(crate) struct FieldKernels {
    pub k: usize,
    pub kernels: Vec<Vec<Vec<f32>>>,
}

impl RtfLens {
    /// The field kernels at ideal heights `heights_m` (module docs); film `dz` mm behind the input
    /// plane. The kernel side covers the largest 99.5 % spot radius plus the radius outside of
    /// which the Airy pattern at the longest wavelength holds `tail_energy`.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn field_kernels(
        &self,
        heights_m: &[f64],
        wavelengths_nm: &[f64],
        image_distance_m: f64,
        object_distance_m: f64,
        dz: f64,
        spacing_m: f64,
        s: usize,
        max_kernel: usize,
        tail_energy: f64,
    ) -> Result<FieldKernels> {
        let mut spots: Vec<Result<Spot>> = heights_m
            .par_iter()
            .map(|h| {
                self.field_spot(
                    &Field {
                        ideal_height_mm: h * 1e3,
                        image_distance_mm: image_distance_m * 1e3,
                        object_distance_mm: object_distance_m * 1e3,
                    },
                    dz,
                )
            })
            .collect();
        // Heights past the RTF's last pass region reuse the last height that has one (no light
        // reaches them: the relative illumination is 0 there).
        for i in 1..spots.len() {
            if spots[i].is_err() && spots[i - 1].is_ok() {
                spots[i] = Ok(spots[i - 1]
                    .as_ref()
                    .map(|v| v.clone())
                    .map_err(|_| OpticsError::Input(String::new()))?);
            }
        }
        let spots = spots.into_iter().collect::<Result<Vec<_>>>()?;
        let lam_max_m = wavelengths_nm.iter().cloned().fold(0.0, f64::max) * 1e-9;
        // The Airy pattern's energy beyond radius r is about 2 lambda N / (pi^2 r) (Born & Wolf,
        // sec. 8.5.2, the encircled energy's asymptote), so `tail_energy` sets r (at least 3 lambda N).
        let r_m = spots
            .iter()
            .map(|sp| {
                let ln = lam_max_m / (2.0 * sp.na[0].min(sp.na[1]));
                sp.r995_m
                    + (2.0 * ln / (std::f64::consts::PI.powi(2) * tail_energy.max(1e-6)))
                        .max(3.0 * ln)
            })
            .fold(0.0, f64::max);
        let k = (2 * (r_m / spacing_m).ceil() as usize + 1)
            .max(3)
            .min(max_kernel);
        let ks = k * s;
        let fine = spacing_m / s as f64;
        let kernels = spots
            .par_iter()
            .map(|sp| {
                let mut ks = self.with_diffraction(&sp.psf(fine, ks), wavelengths_nm);
                for k in ks.iter_mut() {
                    let sum: f32 = k.iter().sum();
                    if sum > 0.0 {
                        k.iter_mut().for_each(|v| *v /= sum);
                    }
                }
                ks
            })
            .collect();
        Ok(FieldKernels { k, kernels })
    }
}
