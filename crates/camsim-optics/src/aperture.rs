//! The shape of the lens pupil in the wavefront model: the circle (default), a regular N-blade
//! iris with straight or curved blades, a central obstruction, spider vanes, a grey
//! transmission mask, and one half of any of them (a dual-pixel photodiode's view).
//!
//! Conventions. Shapes are given in pupil coordinates normalized by the lens pupil *radius*
//! a = D / 2, D = focal length / f-number: x along image columns, y along image rows (as the
//! pupil of [`crate::Wavefront`]); angles from +x towards +y, degrees. The iris polygon is
//! inscribed in the lens pupil: its vertices lie on the circle of diameter D, so the f-number
//! keeps meaning the circumscribed diameter (as a lens maker's stop scale does) and the diffraction
//! cutoff stays 1 / (lambda N) along the vertex directions. The open area is smaller than the
//! circle's: an N-gon passes N sin(2 pi / N) / (2 pi) of it (0.827 for 6 blades, 0.757 for 5),
//! and [`Aperture::area_fraction`] gives the whole aperture's (obstruction, vanes, mask included).
//! [`crate::Optics`] scales the irradiance by that fraction (like a T-stop); the PSF itself is
//! normalized to unit volume.

use crate::error::{OpticsError, Result};
use std::f64::consts::PI;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// A grey transmission mask over the pupil's bounding square [-1, 1]^2 (row 0 at y = -1).
#[derive(Debug, Clone, PartialEq)]
pub struct TransmissionMask {
    /// The file it came from (for messages).
    pub path: PathBuf,
    rows: usize,
    cols: usize,
    data: Arc<[f32]>,
}

impl TransmissionMask {
    /// A mask from values in [0, 1], row-major `rows x cols`.
    pub fn new(path: PathBuf, rows: usize, cols: usize, data: Vec<f32>) -> Result<Self> {
        if rows == 0 || cols == 0 || data.len() != rows * cols {
            return Err(OpticsError::File {
                path,
                message: format!(
                    "aperture mask of {rows} x {cols} pixels has {} values",
                    data.len()
                ),
            });
        }
        if let Some((i, v)) = data
            .iter()
            .enumerate()
            .find(|(_, v)| !(v.is_finite() && (0.0..=1.0).contains(*v)))
        {
            return Err(OpticsError::File {
                path,
                message: format!(
                    "aperture mask pixel (row {}, col {}) is {v}; a transmission must be in [0, 1]",
                    i / cols,
                    i % cols
                ),
            });
        }
        Ok(TransmissionMask {
            path,
            rows,
            cols,
            data: data.into(),
        })
    }

    /// Read a grey image: PNG/TIFF (8 or 16 bit code values / full scale, taken as linear
    /// transmission, no display transfer function) or OpenEXR (one channel, or R = G = B / Y).
    pub fn from_file(path: &Path) -> Result<Self> {
        let err = |e: camsim_io::IoError| OpticsError::File {
            path: path.to_path_buf(),
            message: format!("aperture mask: {e}"),
        };
        let is_exr = std::fs::read(path)
            .map(|b| b.starts_with(&[0x76, 0x2f, 0x31, 0x01]))
            .map_err(|e| OpticsError::File {
                path: path.to_path_buf(),
                message: format!("aperture mask: {e}"),
            })?;
        if is_exr {
            if let Ok((rows, cols, data)) = camsim_io::exr::read_gray_exr(path, None) {
                return Self::new(path.to_path_buf(), rows, cols, data);
            }
        }
        let img = camsim_io::rgb_image::read_rgb_image(path).map_err(err)?;
        let mut data = Vec::with_capacity(img.rows * img.cols);
        for (i, px) in img.rgb.chunks_exact(3).enumerate() {
            if (px[0] - px[1]).abs() > 1e-6 || (px[0] - px[2]).abs() > 1e-6 {
                return Err(OpticsError::File {
                    path: path.to_path_buf(),
                    message: format!(
                        "aperture mask pixel (row {}, col {}) is coloured ({}, {}, {}); a transmission mask must be grey",
                        i / img.cols,
                        i % img.cols,
                        px[0],
                        px[1],
                        px[2]
                    ),
                });
            }
            data.push(px[0]);
        }
        Self::new(path.to_path_buf(), img.rows, img.cols, data)
    }

    /// Bilinear transmission at normalized pupil point (x, y) (pixel centres at
    /// -1 + (c + 0.5) 2 / cols; edge pixels held).
    pub fn eval(&self, x: f64, y: f64) -> f64 {
        let fc = ((x + 1.0) * 0.5 * self.cols as f64 - 0.5).clamp(0.0, (self.cols - 1) as f64);
        let fr = ((y + 1.0) * 0.5 * self.rows as f64 - 0.5).clamp(0.0, (self.rows - 1) as f64);
        let (c0, r0) = (fc.floor() as usize, fr.floor() as usize);
        let (c1, r1) = ((c0 + 1).min(self.cols - 1), (r0 + 1).min(self.rows - 1));
        let (tc, tr) = (fc - c0 as f64, fr - r0 as f64);
        let v = |r: usize, c: usize| self.data[r * self.cols + c] as f64;
        (1.0 - tr) * ((1.0 - tc) * v(r0, c0) + tc * v(r0, c1))
            + tr * ((1.0 - tc) * v(r1, c0) + tc * v(r1, c1))
    }
}

/// One blade edge: outward unit normal n, apothem h = cos(pi / N) and, for curved blades, the
/// offset m of the arc's centre behind the origin (centre at -m n) and the arc radius.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Edge {
    nx: f64,
    ny: f64,
    apothem: f64,
    /// None: a straight blade (half-plane).
    arc: Option<(f64, f64)>,
}

/// The pupil's shape and transmission. `Aperture::default()` is the plain circle.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Aperture {
    blades: Option<(usize, f64, f64)>,
    edges: Vec<Edge>,
    obstruction: f64,
    /// Vane directions (unit vectors) and half-width (normalized radius units).
    vanes: Vec<(f64, f64)>,
    vane_half_width: f64,
    mask: Option<TransmissionMask>,
    /// Only this half open (x < 0 or x > 0).
    half: Option<crate::config::PupilHalf>,
}

impl Aperture {
    /// The circle of the lens pupil.
    pub fn circle() -> Self {
        Self::default()
    }

    /// True for the plain circle (the PSF code then runs its original path, bit for bit).
    pub fn is_circle(&self) -> bool {
        self.edges.is_empty()
            && self.obstruction == 0.0
            && self.vanes.is_empty()
            && self.mask.is_none()
            && self.half.is_none()
    }

    /// Only one half of the pupil open, cut by the straight line x = 0: `Left` keeps x < 0,
    /// `Right` x > 0 (a half-shielded pixel's or a dual-pixel photodiode's view of the pupil).
    pub fn with_half(mut self, half: crate::config::PupilHalf) -> Self {
        self.half = Some(half);
        self
    }

    /// The open half, if only one is.
    pub fn half(&self) -> Option<crate::config::PupilHalf> {
        self.half
    }

    /// A regular iris of `blades` (>= 3) blades inscribed in the lens pupil, a vertex at
    /// `rotation_deg` from +x; `curvature` in [0, 1] makes each blade an arc through its two
    /// vertices with sagitta `curvature (1 - cos(pi / N))` (0: straight chords, 1: the circle).
    pub fn with_blades(mut self, blades: usize, rotation_deg: f64, curvature: f64) -> Result<Self> {
        if !(3..=64).contains(&blades) {
            return Err(OpticsError::config(
                "aperture.blades",
                format!("{blades} blades; an iris needs 3..=64"),
            ));
        }
        if !rotation_deg.is_finite() {
            return Err(OpticsError::config(
                "aperture.rotation_deg",
                format!("{rotation_deg} is not a finite angle"),
            ));
        }
        if !(0.0..=1.0).contains(&curvature) {
            return Err(OpticsError::config(
                "aperture.curvature",
                format!("{curvature} is not in [0, 1] (0 straight blades, 1 the circle)"),
            ));
        }
        let half_rad = PI / blades as f64;
        let (s, h) = (half_rad.sin(), half_rad.cos());
        // Circle through both vertices (half-chord s) with sagitta t: radius (s^2 + t^2) / (2 t),
        // centre at distance h + t - R from the origin along n (the intersecting-chords theorem).
        let t = curvature * (1.0 - h);
        let arc = (t > 0.0).then(|| {
            let r = (s * s + t * t) / (2.0 * t);
            ((r - h - t).max(0.0), r)
        });
        self.edges = (0..blades)
            .map(|k| {
                let phi = rotation_deg.to_radians() + (2 * k + 1) as f64 * half_rad;
                Edge {
                    nx: phi.cos(),
                    ny: phi.sin(),
                    apothem: h,
                    arc,
                }
            })
            .collect();
        self.blades = Some((blades, rotation_deg, curvature));
        Ok(self)
    }

    /// A central obstruction of `fraction` (in [0, 1)) of the pupil diameter.
    pub fn with_obstruction(mut self, fraction: f64) -> Result<Self> {
        if !(0.0..1.0).contains(&fraction) {
            return Err(OpticsError::config(
                "aperture.obstruction",
                format!("{fraction} is not a fraction of the pupil diameter in [0, 1)"),
            ));
        }
        self.obstruction = fraction;
        Ok(self)
    }

    /// `count` spider vanes from the centre to the rim, each `width` (fraction of the pupil
    /// diameter, in [0, 0.5)) wide, the first along `rotation_deg`, equally spaced.
    pub fn with_vanes(mut self, count: usize, width: f64, rotation_deg: f64) -> Result<Self> {
        if count > 64 {
            return Err(OpticsError::config(
                "aperture.vanes",
                format!("{count} vanes; at most 64"),
            ));
        }
        if !(0.0..0.5).contains(&width) {
            return Err(OpticsError::config(
                "aperture.vane_width",
                format!("{width} is not a fraction of the pupil diameter in [0, 0.5)"),
            ));
        }
        if count > 0 && width == 0.0 {
            return Err(OpticsError::config(
                "aperture.vane_width",
                format!(
                    "{count} vanes of width 0; give their width (fraction of the pupil diameter)"
                ),
            ));
        }
        if !rotation_deg.is_finite() {
            return Err(OpticsError::config(
                "aperture.vane_rotation_deg",
                format!("{rotation_deg} is not a finite angle"),
            ));
        }
        self.vanes = (0..count)
            .map(|k| {
                let phi = rotation_deg.to_radians() + 2.0 * PI * k as f64 / count as f64;
                (phi.cos(), phi.sin())
            })
            .collect();
        // Width w D = 2 w a: half-width w in units of a.
        self.vane_half_width = width;
        Ok(self)
    }

    /// Multiply by a grey transmission mask over the pupil's bounding square.
    pub fn with_mask(mut self, mask: TransmissionMask) -> Self {
        self.mask = Some(mask);
        self
    }

    /// Blade count, rotation (deg) and curvature, if an iris is set.
    pub fn blades(&self) -> Option<(usize, f64, f64)> {
        self.blades
    }

    /// A 1-Lipschitz function of the normalized pupil point, > 0 inside the open (binary) aperture
    /// and < 0 outside: the minimum of the constraints' signed distances (or lower bounds of them).
    fn field(&self, x: f64, y: f64) -> f64 {
        let r2 = x * x + y * y;
        let r = r2.sqrt();
        let mut f = 1.0 - r;
        for e in &self.edges {
            let pn = x * e.nx + y * e.ny;
            let g = match e.arc {
                None => e.apothem - pn,
                // R - |p + m n| written as (R^2 - |p + m n|^2) / (R + |p + m n|), with
                // R^2 = 1 + m^2 + 2 m h (the arc passes the vertices): stable as R grows.
                Some((m, big_r)) => {
                    let q = (r2 + m * m + 2.0 * m * pn).max(0.0).sqrt();
                    (1.0 - r2 + 2.0 * m * (e.apothem - pn)) / (big_r + q)
                }
            };
            f = f.min(g);
        }
        if self.obstruction > 0.0 {
            f = f.min(r - self.obstruction);
        }
        for (dx, dy) in &self.vanes {
            // Outside the half-strip {p.d >= 0, |p x d| <= w}: max of the two half-plane bounds.
            let along = x * dx + y * dy;
            let across = (x * dy - y * dx).abs();
            f = f.min((across - self.vane_half_width).max(-along));
        }
        match self.half {
            Some(crate::config::PupilHalf::Left) => f = f.min(-x),
            Some(crate::config::PupilHalf::Right) => f = f.min(x),
            None => {}
        }
        f
    }

    /// Amplitude of the pupil sample cell of side `cell` centred at normalized (x, y), and the
    /// energy it passes (the integral of |A|^2 over the cell, in cell areas): the open fraction
    /// c of the cell (8 x 8 subsamples where the boundary crosses it) times the amplitude
    /// sqrt(T) of the mask's intensity transmission T at its centre, and c T. (The PSF restores
    /// the energy that the sampled amplitude c sqrt(T) misses, c T - c^2 T, as a pedestal; see
    /// `Wavefront::psf_grid`.)
    pub fn cell_amplitude(&self, x: f64, y: f64, cell: f64) -> (f64, f64) {
        let f = self.field(x, y);
        let reach = 0.7072 * cell;
        let cov = if f >= reach {
            1.0
        } else if f < -reach {
            0.0
        } else {
            let sub = 8usize;
            let mut c = 0usize;
            for sy in 0..sub {
                for sx in 0..sub {
                    let xx = x + ((sx as f64 + 0.5) / sub as f64 - 0.5) * cell;
                    let yy = y + ((sy as f64 + 0.5) / sub as f64 - 0.5) * cell;
                    if self.field(xx, yy) >= 0.0 {
                        c += 1;
                    }
                }
            }
            c as f64 / (sub * sub) as f64
        };
        match &self.mask {
            Some(m) if cov > 0.0 => {
                // The mask holds the intensity transmission T: amplitude sqrt(T), energy T.
                let t = m.eval(x, y).max(0.0);
                (cov * t.sqrt(), cov * t)
            }
            _ => (cov, cov),
        }
    }

    /// Open area of the blades alone as a fraction of the circle's: the N-gon's
    /// N sin(2 pi / N) / (2 pi) plus N circular segments of the blade arcs (segment area
    /// R^2 acos((R - t) / R) - (R - t) sqrt(2 R t - t^2)); 1 without blades.
    pub fn blade_area_fraction(&self) -> f64 {
        let Some((n, _, curvature)) = self.blades else {
            return 1.0;
        };
        let nf = n as f64;
        let half = PI / nf;
        let poly = nf * (2.0 * half).sin() / 2.0;
        let t = curvature * (1.0 - half.cos());
        let seg = if t > 0.0 {
            let s = half.sin();
            let r = (s * s + t * t) / (2.0 * t);
            r * r * ((r - t) / r).clamp(-1.0, 1.0).acos() - (r - t) * (2.0 * r * t - t * t).sqrt()
        } else {
            0.0
        };
        (poly + nf * seg) / PI
    }

    /// Transmitted energy (open area times the intensity transmission) as a fraction of the
    /// circle's, by integrating [`Self::cell_amplitude`]'s energy on a 512 x 512 grid over the
    /// bounding square.
    pub fn area_fraction(&self) -> f64 {
        if self.is_circle() {
            return 1.0;
        }
        let n = 512usize;
        let cell = 2.0 / n as f64;
        let mut sum = 0.0;
        for i in 0..n {
            let y = -1.0 + (i as f64 + 0.5) * cell;
            for j in 0..n {
                let x = -1.0 + (j as f64 + 0.5) * cell;
                sum += self.cell_amplitude(x, y, cell).1;
            }
        }
        sum * cell * cell / PI
    }
}
